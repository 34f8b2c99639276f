//! Shared pieces of the on-target images: the host-computed expected values ([`golden`]),
//! tolerance checks, and a tiny probe ([`probe`]) that paints the stack, measures its
//! high-water mark and reports through semihosting without pulling in `core::fmt`.
#![no_std]

#[cfg(feature = "compare")]
pub mod cholesky_size;
pub mod golden;
pub mod probe;
#[rustfmt::skip]
pub mod puddle_tables;
pub mod workloads;

/// The body of a footprint image: paints the stack, runs `$work` (an expression giving
/// `awfqi::Result<_>`), reports the stack used through semihosting and exits QEMU with
/// status 0 on success, 1 on an error.
#[macro_export]
macro_rules! footprint_image {
    ($work:expr) => {
        #[cortex_m_rt::entry]
        fn main() -> ! {
            $crate::probe::paint_stack();
            let result = $work;
            core::hint::black_box(&result);
            $crate::probe::report("stack", $crate::probe::stack_used());
            $crate::probe::exit(result.is_ok())
        }

        #[panic_handler]
        fn panic(_: &core::panic::PanicInfo) -> ! {
            $crate::probe::exit(false)
        }
    };
}

/// `|actual − expected| ≤ abs + rel·|expected|`.
pub fn close(actual: f64, expected: f64, abs: f64, rel: f64) -> bool {
    let diff = actual - expected;
    let diff = if diff < 0.0 { -diff } else { diff };
    let scale = if expected < 0.0 { -expected } else { expected };
    diff <= abs + rel * scale
}
