//! Instruction-count image (`scripts/m4-counts`): the recommended Puddle World configuration
//! (`awfqi_puddle_32k`: f32, target GP N = 24, 11 × 11 FQI cells, 324 score rows, 6 steps of
//! 50 queries, the thesis's GP search) run step by step, then the step's parts on the state
//! after the last step: GP fit at fixed hyperparameters, prediction, hyperparameter search,
//! the step's target-GP training (`fit_gp`: reset, load, search), and weighted FQI with 1
//! and 60 iterations (one sweep is their difference ÷ 59).
//!
//! Each measured region is bracketed by calls of [`m4_counts_mark`]; QEMU's counting plugin
//! (`tests/on_target/m4-counts/insn_count.c`) records the executed-instruction count at
//! every call, and the image prints the region's label and repetitions through semihosting
//! after its closing mark, so the script pairs the `k`-th label with marks `2k` and `2k + 1`.
//! The first region is empty: its count is the bracketing's own cost, subtracted from all.
#![no_std]
#![no_main]

use awfqi::env::{Dynamics, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::fqi::{Approximator, FqiConfig, FqiEntry, SampleSet};
use awfqi::record_gp::{Output, fit_gp};
use awfqi::{
    Result,
    prelude::{Awfqi, AwfqiConfig, CellGrid, Conditioning, RowSet},
};
use awfqi_on_target::probe;
use awfqi_on_target::puddle_tables as t;
use awfqi_on_target::workloads::{Record, Storage32k};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

static mut STORAGE: Storage32k = Storage32k::new();
static mut FQI_ENTRIES: [FqiEntry<f32>; 484] = [FqiEntry::EMPTY; 484];

/// The marker: the plugin records the running instruction count each time its first
/// instruction executes. Never inlined, and with a body the linker cannot fold.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn m4_counts_mark() {
    // SAFETY: a no-op instruction.
    unsafe { core::arch::asm!("nop", options(nomem, nostack, preserves_flags)) };
}

/// Runs `op` `reps` times between two marks and reports `label reps`.
fn measure<T>(label: &str, reps: usize, mut op: impl FnMut() -> Result<T>) -> Result<()> {
    m4_counts_mark();
    for _ in 0..reps {
        core::hint::black_box(op()?);
    }
    m4_counts_mark();
    probe::report(label, reps);
    Ok(())
}

fn run() -> Result<()> {
    measure("empty", 1, || Ok(()))?;
    // SAFETY: the only references to the statics.
    let storage = unsafe { &mut *core::ptr::addr_of_mut!(STORAGE) };
    let fqi_entries = unsafe { &mut *core::ptr::addr_of_mut!(FQI_ENTRIES) };
    let mut rng = ChaCha8Rng::seed_from_u64(core::hint::black_box(1));
    let sources: [&[Record]; 3] = [&t::SOURCE_1, &t::SOURCE_2, &t::SOURCE_3];
    // As `workloads::awfqi_puddle_32k` (whose seed-1 run needs the unbounded jitter ladder).
    let mut config = AwfqiConfig::thesis(50);
    config.gp_training.conditioning = Conditioning::UNBOUNDED;
    let config = config.validate()?;
    let grid = CellGrid::cube(0.0, 10.0, 11)?;
    // The set-up (not a closure: the kernel borrows the storage beyond it).
    m4_counts_mark();
    let rows = RowSet::grid(PuddleWorld::score_grid(1.25)?, PUDDLE_ACTIONS)?;
    let mut kernel = Awfqi::builder(config, grid, &sources, rows)
        .stored_posteriors(&t::SOURCE_POSTERIORS)
        .stored_scores(&t::SCORES)
        .build(PuddleWorld::target(Dynamics::Shared), storage, &mut rng)?;
    m4_counts_mark();
    probe::report("build", 1);
    const STEP_LABELS: [&str; 6] = ["step1", "step2", "step3", "step4", "step5", "step6"];
    for label in STEP_LABELS {
        measure(label, 1, || kernel.step(&mut rng))?;
    }

    // The parts, on the state after the last step.
    let training = &config.gp_training;
    let mut gp = kernel.gp().clone();
    let n = gp.len();
    let mut x = [[0.0f32; 3]; 24];
    let mut y = [0.0f32; 24];
    for ((xi, yi), (a, b)) in x
        .iter_mut()
        .zip(y.iter_mut())
        .zip(gp.inputs().iter().zip(gp.targets()))
    {
        *xi = *a;
        *yi = *b;
    }
    let (x, y) = (x.get(..n).unwrap_or(&[]), y.get(..n).unwrap_or(&[]));
    measure("gp_fit", 10, || gp.fit(x, y))?;
    let mut i = 0u16;
    measure("gp_predict", 100, || {
        i += 1;
        let s = f32::from(i % 100) * 0.1;
        gp.predict(&[s, 10.0 - s, f32::from(i % 4)])
    })?;
    let mut searched = gp.clone();
    searched.set_hyperparameters(training.initial)?;
    measure("gp_search", 1, || {
        searched.optimize_hyperparameters(&training.bounds, &training.search, &mut rng)
    })?;
    let mut trained = gp.clone();
    let target = kernel.target_samples();
    measure("target_gp_training", 1, || {
        fit_gp(
            &mut trained,
            target,
            Output::Reward,
            config.subset,
            training,
            &mut rng,
        )
    })?;
    let weights = kernel.reward_weights();
    let sets = [
        SampleSet::unweighted(target),
        SampleSet::weighted(&t::SOURCE_1, weights.get(..t::SOURCE_1.len()), None),
        SampleSet::weighted(
            &t::SOURCE_2,
            weights.get(t::SOURCE_1.len()..t::SOURCE_1.len() + t::SOURCE_2.len()),
            None,
        ),
        SampleSet::weighted(
            &t::SOURCE_3,
            weights.get(t::SOURCE_1.len() + t::SOURCE_2.len()..),
            None,
        ),
    ];
    let fqi = config.fqi;
    let mut q = Approximator::Table(grid).build(PUDDLE_ACTIONS, &mut fqi_entries[..])?;
    for (label, iterations) in [("fqi_1_iteration", 1), ("fqi_60_iterations", 60)] {
        let cfg = FqiConfig::new(fqi.discount(), iterations, fqi.empty_cells())?
            .with_min_weight(fqi.min_weight())?;
        measure(label, 1, || q.fit(&sets, &cfg, &mut rng))?;
    }
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
