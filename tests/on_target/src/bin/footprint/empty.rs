//! Footprint baseline: the runtime (vector table, reset handler) and the probe, no core.
#![no_std]
#![no_main]

use awfqi_on_target::probe;
use cortex_m_rt::entry;

#[entry]
fn main() -> ! {
    probe::paint_stack();
    probe::report("stack", probe::stack_used());
    probe::exit(true)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    probe::exit(false)
}
