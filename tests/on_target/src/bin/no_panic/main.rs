//! The no-panic proof: an image that calls every public entry point of the core, in `f32`
//! and `f64`, with inputs the optimiser cannot see through (`black_box`), linked with a
//! panic handler that calls a symbol defined nowhere. If any panic path of the core
//! survives optimisation (release, LTO, opt-level s), the handler is live and the link
//! fails naming `awfqi_core_has_a_reachable_panic_path`. Built by `scripts/no-panic`; it
//! is never run.
//!
//! Keep it complete: a new public function of the core gets a call here, in the module of
//! its concept.
#![no_std]
#![no_main]

use core::hint::black_box as opaque;

use awfqi::adaptive;
use awfqi::alias::AliasTable;
use awfqi::env::{
    Acrobot, AcrobotTask, Dam, Dynamics, EpisodeRecord, GridWorld, InflowProfile, Puddle,
    PuddleWorld,
};
use awfqi::identify::{
    Belief, Criterion, MiConfig, RewardEntropy, Scoring, StateAction, belief_weighted_policy,
    belief_weighted_q, compute_score, draw_pair, draw_pairs, log_likelihood, run_queries,
};
use awfqi::identify::{mutual_information_score, uniform_score, variance_score};
use awfqi::model::FiniteMdp;
use awfqi::planning::{
    StoppingRule, backup, evaluate_policy, greedy_action, greedy_policy, q_from_values,
    value_iteration,
};
use awfqi::policy::{EpsilonGreedyPolicy, Policy, UniformPolicy};
use awfqi::prelude::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, AliasEntry, AnchorEntry, AnchorFqi,
    AnchorParts, AnchorStorage, AnchorSweep, Approximator, Awfqi, AwfqiBuffers, AwfqiConfig,
    AwfqiStorage, CellGrid, EmptyCells, EvaluationProtocol, ExtraTrees, FqiConfig, FqiEntry,
    GenerativeModel, Gp, GpTraining, Greedy, HybridFqi, HyperparameterBounds, Hyperparameters,
    Kernel, KnnFqi, KnnRecord, KnnStorage, MeanFunction, ModelSweep, MultiStartProtocol,
    Neighbours, Output, QFunction, Real, RewardModel, RowSet, SampleSet, ScoreColumn, ScoreTable,
    Scores, SearchOptions, SourceData, SourceMeans, SourceModel, SourceScales, SubsetRule,
    SweepEntry, SweepFqi, SweepNode, SweepStorage, TabularFqi, TileFqi, Tilings, Transition,
    TreeFqi, TreeNode, TreeRecord, TreeStorage, WhenFull, evaluate, evaluate_greedy,
    evaluate_greedy_multi_start, evaluate_multi_start, rollout,
};
use awfqi::record_gp::{
    batch_transform, fit_gp, fit_gp_on, input, map_posteriors, predict_posteriors,
};
use awfqi::score::{GpSourceModel, PointGrid};
use awfqi::weights::{
    Estimator, NoiseSubtraction, Posterior, StdTransform, WeightParams, WeightSummary,
    effective_sample_size, ideal_weight, predictive_stds,
};
use cortex_m_rt::entry;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

mod basics;
mod domains;
mod gp;
mod identification;
mod kernels;
mod transfer;

use basics::{error_and_float, generator_adapters, rng_and_policy};
use domains::{acrobot, dam, grid, puddle};
use gp::gp;
use identification::identification;
use transfer::transfer;

/// A `core::fmt` sink, so `Display` implementations are linked.
struct Sink;

impl core::fmt::Write for Sink {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        opaque(s);
        Ok(())
    }
}

/// A value of `T` the optimiser cannot know.
fn num<T: Real>(x: f64) -> T {
    opaque(T::from_f64(opaque(x)))
}

fn index(i: usize) -> usize {
    opaque(i)
}

fn keep<V>(v: V) {
    opaque(v);
}

fn exercise<T: Real>(seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    error_and_float::<T>();
    generator_adapters(&mut rng);
    rng_and_policy::<T>(&mut rng);
    grid::<T>(&mut rng);
    puddle::<T>(&mut rng);
    dam::<T>(&mut rng);
    acrobot::<T>(&mut rng);
    gp::<T>(&mut rng);
    transfer::<T>(&mut rng);
    identification::<T>(&mut rng);
}

#[entry]
fn main() -> ! {
    exercise::<f32>(opaque(1));
    exercise::<f64>(opaque(2));
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "diagnose"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe extern "C" {
        fn awfqi_core_has_a_reachable_panic_path() -> !;
    }
    // SAFETY: never linked; the link fails if this handler is reachable.
    unsafe { awfqi_core_has_a_reachable_panic_path() }
}

/// `scripts/no-panic --diagnose`: links with a looping handler so the surviving panic
/// calls can be listed from the disassembly with their source lines.
#[cfg(feature = "diagnose")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    #[unsafe(no_mangle)]
    #[inline(never)]
    extern "C" fn awfqi_core_has_a_reachable_panic_path() -> ! {
        loop {
            cortex_m::asm::nop();
        }
    }
    awfqi_core_has_a_reachable_panic_path()
}
