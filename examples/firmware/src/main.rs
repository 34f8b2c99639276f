//! AWFQI as firmware: a water-reservoir controller that learns its release policy from
//! three other reservoirs' logged data and 200 queries to a model of its own.
//!
//! The plant is the IWFQI paper's Dam (`awfqi::env::Dam`): state `[storage, day]`, eight
//! daily releases (0, 3, 5, 7, 10, 15, 20, 30), a noisy seasonal inflow, a cost for
//! flooding (storage above 300) and for missing the demand (releasing less than 10). Our
//! reservoir (the paper's target) has its own inflow season and cost weights; the source
//! reservoirs' records were logged elsewhere. Yours would be a motor, a pump, a heater:
//! implement `awfqi::GenerativeModel` for it (one sampled step from any state and action)
//! and change the sizes below.
//!
//! What runs where:
//! - **host, once** (`tests/firmware_tables.rs`): the source records, the posterior of each
//!   source's reward GP at its records, and the score table (where the sources disagree
//!   about the reward) → `src/tables.rs`, `static` arrays that stay in **flash**;
//! - **device**: the builder's set-up over those tables, four AWFQI steps (each: draw 50
//!   state-action pairs from the score table, query the plant model there, fit the target's
//!   reward GP, weight every source record by how well it agrees, weighted FQI), then the
//!   learned greedy policy and a fixed baseline are each run for one year from the same
//!   start, with the same inflows, and both returns are printed.
//!
//! RAM: one `AwfqiStorage` in `.bss` (18 KB, see `Storage`) plus ≈ 4.3 KB of stack; nothing
//! is allocated and every fallible call returns `awfqi::Result`.
//!
//! Build and run under QEMU: `scripts/firmware-example` (or, in this directory,
//! `cargo run --release`).
#![no_std]
#![no_main]

mod stack;
#[rustfmt::skip]
mod tables;

use awfqi::env::{DAM_ACTIONS, DAM_DISCOUNT, DAM_EVALUATION_STATE, DAM_HORIZON, Dam};
use awfqi::{
    Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, EmptyCells, Estimator, EvaluationProtocol,
    FqiConfig, HyperparameterBounds, Hyperparameters, PointGrid, RowSet, WeightParams, evaluate,
    evaluate_greedy,
};
use cortex_m_rt::entry;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use semihosting::{println, process};

// ---- Sizes: every buffer is fixed at compile time. ----

/// Generative-model queries per AWFQI step.
const BUDGET: usize = 50;
/// AWFQI steps (the target records of all steps are kept: `STEPS × BUDGET` of them).
const STEPS: usize = 4;
/// Capacity of the target's reward GP (its memory grows as `N²`: 32 points ≈ 4.8 KB).
const GP_POINTS: usize = 32;
/// FQI cells along the storage axis (0–500, 55.6 units each). The day gets one cell: the
/// costs do not depend on the day, and a table over days would need far more data.
///
/// Check the resolution on the host before you flash (the same code runs there): a
/// release changes the storage by a few units a day, so in a coarse table most steps stay
/// in their cell, and whether "release 20" looks as good as "release 10" can hinge on the
/// cell borders. Measured on 20 host runs (other seeds than this one): 9 cells beat the
/// baseline in 17 of 20 runs (mean −1494 against ≈ −1765); 10 cells lost in 20 of 20
/// (they released 20 between storage 100 and 150 and ran dry); 8 cells won 16 of 20.
const STORAGE_CELLS: usize = 9;
/// The Q-table: one entry per (cell, action).
const FQI_ENTRIES: usize = STORAGE_CELLS * DAM_ACTIONS;
/// Source records in flash (all sources).
const SOURCE_RECORDS: usize = tables::SOURCES * tables::RECORDS_PER_SOURCE;
/// The action of the baseline: release the demand (10 units) every day.
const RELEASE_DEMAND: usize = 4;
/// Seed of the run. On a device, take it from a hardware RNG or a unique ID.
const SEED: u64 = 3;

/// All the RAM the loop writes, in one block: `f32`, state dimension 2, GP input dimension
/// 3 (state + action), then the capacities: GP points, target records, one weight per
/// source record, one alias entry per candidate row, the Q-table: 18 428 bytes.
type Storage = AwfqiStorage<
    f32,
    2,
    3,
    GP_POINTS,
    { STEPS * BUDGET },
    SOURCE_RECORDS,
    { tables::SCORE_ROWS },
    FQI_ENTRIES,
>;

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` at the top of the entry function into a safe
    // `&'static mut`. `AwfqiStorage::new()` is all-zero, so it lands in `.bss`: RAM only,
    // no flash copy.
    static mut STORAGE: Storage = AwfqiStorage::new();

    stack::paint();
    let status = match run(STORAGE) {
        Ok(()) => 0,
        // Every failure is a typed error (bad input, capacity, ill-conditioned GP, …).
        Err(error) => {
            println!("AWFQI failed: {}", error);
            1
        }
    };
    println!("stack used: {} bytes", stack::used());
    process::exit(status)
}

fn run(storage: &'static mut Storage) -> awfqi::Result<()> {
    // All randomness comes from the caller's seeded generator: same seed, same run.
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);

    // 1. Settings: the thesis's (§12 of docs/algorithms.md) with the GP and FQI set to this
    //    plant. The GP input is (storage, day, action), in the plant's own units, so the
    //    hyperparameter search starts and stays in ranges of those units, with one length
    //    scale per input. (The host fitted the source GPs with the same training.)
    let mut config = AwfqiConfig::thesis(BUDGET);
    config.weights = WeightParams::new(Estimator::Mean, 0.25, 1000.0)?;
    config.gp_training.initial = Hyperparameters {
        signal_variance: 400.0,
        length_scales: [100.0, 1000.0, 0.5],
        noise_variance: 0.1,
    };
    config.gp_training.bounds = HyperparameterBounds {
        signal_variance: (1.0, 1e4),
        length_scales: [(10.0, 1e3), (10.0, 1e4), (0.1, 10.0)],
        noise_variance: (1e-2, 1.0),
    };
    config.gp_training.search.isotropic = false;
    config.gp_training.search.restarts = 2;
    config.gp_training.search.max_evaluations = 120;
    // The plant's discount; 200 sweeps of FQI so values look months ahead.
    config.fqi = FqiConfig::new(DAM_DISCOUNT as f32, 200, EmptyCells::CappedNearest)?;

    // 2. What the builder needs: the source records (one slice per source, in flash), the
    //    candidate state-action pairs the score table covers, the FQI grid over the state
    //    space — and, from flash, the stored posteriors and score values.
    let sources = tables::SOURCE_RECORDS
        .each_ref()
        .map(|source| source.as_slice());
    let candidates = RowSet::grid(
        PointGrid::new(
            tables::GRID_LOWER,
            tables::GRID_SPACING,
            tables::GRID_POINTS,
        )?,
        DAM_ACTIONS,
    )?;
    let grid = CellGrid::new([0.0, 1.0], [500.0, 360.0], [STORAGE_CELLS, 1])?;
    let plant = Dam::<f32>::target();
    let mut kernel = Awfqi::builder(config.validate()?, grid, &sources, candidates)
        .stored_posteriors(&tables::SOURCE_POSTERIORS)
        .stored_scores(&tables::SCORES)
        .build(plant, storage, &mut rng)?;

    // 3. The active loop. A step that fails leaves the previous Q-table in place.
    for _ in 0..STEPS {
        let report = kernel.step(&mut rng)?;
        println!(
            "step {}: {} target records, reward-weight ESS {:.0} of {} records",
            report.step,
            report.n_target_samples,
            report.wr_eff,
            report.n_target_samples + report.n_source_samples
        );
    }

    // 4. One year from storage 200 on day 1, ten times, for the learned greedy policy and
    //    for the baseline. Both start from the same generator state, and neither policy
    //    draws random numbers, so both face exactly the same inflows.
    let protocol = EvaluationProtocol {
        start: DAM_EVALUATION_STATE.map(|x| x as f32),
        rollouts: 10,
        horizon: DAM_HORIZON,
        discount: DAM_DISCOUNT as f32,
    };
    let inflows = rng.clone();
    let learned = evaluate_greedy(&plant, kernel.q(), &protocol, &mut rng)?;
    let mut release_demand = |_: &[f32; 2]| Ok(RELEASE_DEMAND);
    let baseline = evaluate(&plant, &mut release_demand, &protocol, &mut inflows.clone())?;
    println!(
        "greedy AWFQI policy: return {:.1} ± {:.1}",
        learned.mean_return, learned.standard_error
    );
    println!(
        "baseline, release the demand (10/day): return {:.1} ± {:.1}",
        baseline.mean_return, baseline.standard_error
    );
    Ok(())
}
