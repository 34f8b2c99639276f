//! Instruction counts and memory of every configuration of the adaptive kernel in the
//! Pareto table of `docs/embedded-adaptive.md` (run by hand: `scripts/m4-counts` covers the
//! recommended one). For each configuration, one after another: its static memory
//! (`size_of` of the blocks a firmware would keep in `.bss`), then under the marker of
//! `m4_counts.rs` its set-up, its plan on the sources and its steps, then the stack it used
//! (painted before it started). Built with `PARETO=light` (the model sweeps, six steps each)
//! or `PARETO=heavy` (the 64-point, 4 000-candidate configurations with tiles, trees or a
//! 20-cell sweep, three steps; the trees two).
#![no_std]
#![no_main]

use awfqi::fqi::RewardModel::{Backfilled, PerAction, Pooled};
use awfqi::{
    Result,
    prelude::{SweepStorage, TreeStorage},
};
use awfqi_on_target::probe;
use awfqi_on_target::workloads::{ADAPTIVE_RECOMMENDED, AdaptiveQ, AdaptiveRun, adaptive_setup};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// The marker (as in `m4_counts.rs`).
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn m4_counts_mark() {
    // SAFETY: a no-op instruction.
    unsafe { core::arch::asm!("nop", options(nomem, nostack, preserves_flags)) };
}

/// The labels of a configuration's regions (`name`, then the region).
fn label<'b>(buffer: &'b mut [u8; 48], name: &str, region: &str) -> &'b str {
    let mut n = 0;
    for b in name.bytes().chain(*b"_").chain(region.bytes()) {
        if let Some(slot) = buffer.get_mut(n) {
            *slot = b;
            n += 1;
        }
    }
    core::str::from_utf8(buffer.get(..n).unwrap_or(&[])).unwrap_or("label")
}

/// Runs one configuration: memory, set-up, plan, steps, stack (not inlined, so the stack
/// it reports is its own and its callees', as a footprint image's would be).
#[inline(never)]
fn measure<S: AdaptiveStorage<f32, 2, 3, N>, const N: usize>(
    name: &str,
    memory: &mut S,
    fqi: awfqi::fqi::QStorage<'_, f32, 2>,
    fqi_bytes: usize,
    run: AdaptiveRun,
) -> Result<()> {
    let mut buffer = [0u8; 48];
    let ram = core::mem::size_of::<S>() + fqi_bytes;
    probe::report(label(&mut buffer, name, "RAM"), ram);
    probe::paint_stack();
    let mut rng = ChaCha8Rng::seed_from_u64(core::hint::black_box(1));
    m4_counts_mark();
    let mut kernel = adaptive_setup(memory, fqi, &run, &mut rng)?;
    m4_counts_mark();
    probe::report(label(&mut buffer, name, "setup"), 1);
    m4_counts_mark();
    kernel.plan(&mut rng)?;
    m4_counts_mark();
    probe::report(label(&mut buffer, name, "plan"), 1);
    const STEPS: [&str; 6] = ["step1", "step2", "step3", "step4", "step5", "step6"];
    for step in STEPS.iter().take(run.steps) {
        m4_counts_mark();
        core::hint::black_box(kernel.step(&mut rng)?);
        m4_counts_mark();
        probe::report(label(&mut buffer, name, step), 1);
    }
    probe::report(label(&mut buffer, name, "STACK"), probe::stack_used());
    Ok(())
}

/// A configuration's memory and sweep storage, as statics, and its run.
macro_rules! config {
    ($name:expr, $n:expr, $c:expr, $e:expr, $fqi:ty, $run:expr) => {{
        awfqi::adaptive_storage! {
            struct Memory {
                scalar: f32,
                state_dim: 2,
                actions: 4,
                gp_points: $n,
                steps: 6,
                budget: 50,
                sources: 3,
                source_records: 1033,
                source_posteriors: 0,
                candidates: $c,
                table_entries: $e,
            }
        }
        static mut MEMORY: Memory = Memory::new();
        static mut FQI: $fqi = <$fqi>::new();
        // SAFETY: the only references to this configuration's statics.
        let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
        let fqi = unsafe { &mut *core::ptr::addr_of_mut!(FQI) };
        measure($name, memory, fqi.storage(), core::mem::size_of::<$fqi>(), $run)?;
    }};
}

type Sweep12 = SweepStorage<f32, 2, { 169 * 4 }, 169>;
type Sweep16 = SweepStorage<f32, 2, { 289 * 4 }, 289>;
type Sweep20 = SweepStorage<f32, 2, { 441 * 4 }, 441>;
type NoFqi = SweepStorage<f32, 2, 0, 0>;

fn run() -> Result<()> {
    m4_counts_mark();
    m4_counts_mark();
    probe::report("empty", 1);
    let rec = ADAPTIVE_RECOMMENDED;
    if option_env!("PARETO") == Some("heavy") {
        let big = AdaptiveRun {
            candidates: 4000,
            refit: None,
            steps: 3,
            ..rec
        };
        let sweep = AdaptiveRun {
            q: AdaptiveQ::Sweep(20, Pooled, 0.0),
            ..big
        };
        config!("sweeponly", 64, 4000, 0, Sweep20, sweep);
        let tiles = AdaptiveRun {
            q: AdaptiveQ::Tiles(12, 8),
            ..big
        };
        config!("tiles", 64, 4000, 5408, NoFqi, tiles);
        let trees = AdaptiveRun {
            q: AdaptiveQ::Trees(50, 1023),
            steps: 2,
            ..big
        };
        config!("trees", 64, 4000, 0, TreeStorage<f32, 2, 1333, 1023>, trees);
        return Ok(());
    }
    let with = |q| AdaptiveRun { q, ..rec };
    config!("rec", 32, 250, 0, Sweep12, rec);
    config!(
        "peraction",
        32,
        250,
        0,
        Sweep12,
        with(AdaptiveQ::Sweep(12, PerAction, 0.0))
    );
    config!(
        "backfilled",
        32,
        250,
        0,
        Sweep12,
        with(AdaptiveQ::Sweep(12, Backfilled, 0.0))
    );
    config!(
        "thesissearch",
        32,
        250,
        0,
        Sweep12,
        AdaptiveRun { refit: None, ..rec }
    );
    config!("n64", 64, 250, 0, Sweep12, rec);
    config!("n16", 16, 250, 0, Sweep12, rec);
    config!(
        "c4000",
        32,
        4000,
        0,
        Sweep12,
        AdaptiveRun {
            candidates: 4000,
            ..rec
        }
    );
    config!(
        "cells20",
        32,
        250,
        0,
        Sweep20,
        with(AdaptiveQ::Sweep(20, Pooled, 0.0))
    );
    config!(
        "cells16",
        32,
        250,
        0,
        Sweep16,
        with(AdaptiveQ::Sweep(16, Pooled, 0.0))
    );
    Ok(())
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let ok = run().is_ok();
    probe::exit(ok)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    probe::exit(false)
}
