//! Instruction-count image of the adaptive kernel (`scripts/m4-counts`): adaptive AWFQI on
//! Puddle World in its recommended configuration, f32 — the set-up (the sources' mean
//! functions fitted on the device, the kernel built), the plan on the sources alone, then
//! six steps of 50 queries, each between two calls of the marker (see `m4_counts.rs`).
#![no_std]
#![no_main]

use awfqi::Result;
use awfqi_on_target::probe;
use awfqi_on_target::workloads::{
    ADAPTIVE_RECOMMENDED, AdaptiveRecommended, AdaptiveRecommendedFqi, adaptive_setup,
};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

static mut MEMORY: AdaptiveRecommended = AdaptiveRecommended::new();
static mut FQI: AdaptiveRecommendedFqi = AdaptiveRecommendedFqi::new();

/// The marker (as in `m4_counts.rs`).
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn m4_counts_mark() {
    // SAFETY: a no-op instruction.
    unsafe { core::arch::asm!("nop", options(nomem, nostack, preserves_flags)) };
}

fn run() -> Result<()> {
    m4_counts_mark();
    m4_counts_mark();
    probe::report("empty", 1);
    // SAFETY: the only references to the statics.
    let memory = unsafe { &mut *core::ptr::addr_of_mut!(MEMORY) };
    let fqi = unsafe { &mut *core::ptr::addr_of_mut!(FQI) };
    let mut rng = ChaCha8Rng::seed_from_u64(core::hint::black_box(1));
    m4_counts_mark();
    let mut kernel = adaptive_setup(memory, fqi.storage(), &ADAPTIVE_RECOMMENDED, &mut rng)?;
    m4_counts_mark();
    probe::report("setup", 1);
    m4_counts_mark();
    kernel.plan(&mut rng)?;
    m4_counts_mark();
    probe::report("plan", 1);
    const STEP_LABELS: [&str; 6] = ["step1", "step2", "step3", "step4", "step5", "step6"];
    for label in STEP_LABELS.iter().take(ADAPTIVE_RECOMMENDED.steps) {
        m4_counts_mark();
        core::hint::black_box(kernel.step(&mut rng)?);
        m4_counts_mark();
        probe::report(label, 1);
    }
    parts(&kernel, &mut rng)
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

/// The parts of a step, on the state after the last one: the FQI fit with 1 and 60
/// iterations, the target GP's training (the thesis's search and a warm refit), a GP
/// prediction (one per source record for the weights, one per candidate for the scores)
/// and a source mean function's evaluation.
fn parts<const N: usize>(
    kernel: &awfqi::adaptive::AdaptiveAwfqi<'_, f32, awfqi::env::PuddleWorld<f32>, 2, 3, N>,
    rng: &mut ChaCha8Rng,
) -> Result<()> {
    use awfqi::fqi::{FqiConfig, SampleSet};
    use awfqi::record_gp::{GpTraining, Output, fit_gp};
    use awfqi_on_target::puddle_tables as t;
    static mut SCRATCH: AdaptiveRecommendedFqi = AdaptiveRecommendedFqi::new();
    // SAFETY: the only reference.
    let scratch = unsafe { &mut *core::ptr::addr_of_mut!(SCRATCH) };
    let config = kernel.config();
    let target = kernel.target_samples();
    let weights = kernel.reward_weights();
    let (n1, n2) = (t::SOURCE_1.len(), t::SOURCE_1.len() + t::SOURCE_2.len());
    let sets = [
        SampleSet::unweighted(target),
        SampleSet::weighted(&t::SOURCE_1, weights.get(..n1), None),
        SampleSet::weighted(&t::SOURCE_2, weights.get(n1..n2), None),
        SampleSet::weighted(&t::SOURCE_3, weights.get(n2..), None),
    ];
    let approximator = awfqi_on_target::workloads::adaptive_approximator(ADAPTIVE_RECOMMENDED.q)?;
    let mut q = approximator.build(awfqi::env::PUDDLE_ACTIONS, scratch.storage())?;
    let fqi = config.awfqi.fqi;
    for (label, iterations) in [("fqi_1_iteration", 1), ("fqi_60_iterations", 60)] {
        let cfg = FqiConfig::new(fqi.discount(), iterations, fqi.empty_cells())?
            .with_min_weight(fqi.min_weight())?;
        measure(label, 1, || q.fit(&sets, &cfg, rng))?;
    }
    let mut gp = kernel.gp().clone();
    let thesis = config.awfqi.gp_training;
    measure("gp_thesis_search", 1, || {
        fit_gp(
            &mut gp,
            target,
            Output::Reward,
            config.awfqi.subset,
            &thesis,
            rng,
        )
    })?;
    if let awfqi::adaptive::Refit::Warm(search) = config.refit {
        let warm = GpTraining {
            initial: *gp.hyperparameters(),
            search,
            ..thesis
        };
        measure("gp_warm_refit", 1, || {
            fit_gp(
                &mut gp,
                target,
                Output::Reward,
                config.awfqi.subset,
                &warm,
                rng,
            )
        })?;
    }
    let mut i = 0u16;
    measure("gp_predict", 100, || {
        i += 1;
        let s = f32::from(i % 100) * 0.1;
        gp.predict(&[s, 10.0 - s, f32::from(i % 4)])
    })?;
    measure("mean_function", 100, || {
        i += 1;
        let s = f32::from(i % 100) * 0.1;
        kernel.means()[0].mean(&[s, 10.0 - s, f32::from(i % 4)])
    })?;
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
