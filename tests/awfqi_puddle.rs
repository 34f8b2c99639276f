//! End-to-end: the core AWFQI kernel on the shared-dynamics Puddle World (spec §2.6, §6, §12),
//! in the microcontroller configuration: `f32`, 11 × 11 FQI cells, a 64-point target GP,
//! a score grid with spacing 1 (11 × 11 points × 4 actions = 484 rows), 50 queries a step.
//!
//! **Why 11 × 11 cells.** Cells of width 10/11 ≈ 0.91 are about one unit step wide, so a
//! move from the near-integer states the agent visits crosses one cell boundary and the
//! discretised dynamics stay close to deterministic; finer grids (13, 15, 21 cells) alias
//! the unit step into 1- or 2-cell moves and, with AWFQI's sparse data, generalise worse.
//! Measured with this file's `measure_returns_per_step` (10 seeds, 6 steps of 50 queries),
//! which asserts the 11-cell figures: with 11 cells AWFQI-oracle scored −24.9…−19.8 and
//! AWFQI −40.0…−30.0 per step, with 21 cells
//! (and the test's smaller GP search) both scored between −57 and −75; plain FQI on 1 episode a step was no better than −40 on either
//! grid. The score grid's spacing (0.1, 0.25, 0.5 or 1) changed the returns by about their
//! standard errors, so the coarsest (484 rows) is used.
//!
//! **Source data** (spec §6, with the tabular learner instead of Extra-Trees): for each
//! source, tabular FQI on the same 11 × 11 grid learns from 5 steps × 50 episodes (step 1
//! uniform, then ε-greedy with ε = 0.3), and its greedy policy then generates 20 episodes
//! from (0, 0); all their records are the source dataset. A 64-point reward GP per source,
//! fitted on an even spread of the records ([`SubsetRule::Spread`]), gives the stored
//! posteriors (reference noise subtraction) and the realistic score table. Everything is
//! generated here from fixed seeds and shared by all runs (spec §11.2's "built once per
//! experiment" choice).
//!
//! `awfqi_improves_on_the_uniform_policy` runs 3 steps of 50 queries and checks that the
//! greedy return beats the uniform-random policy's. The ignored `measure_returns_per_step`
//! (a minute in release) prints the per-step returns of AWFQI (oracle and realistic tables)
//! next to plain tabular FQI on episodes, over 10 seeds, and the memory of the kernel
//! state, and asserts the figures above:
//!
//! ```text
//! cargo test --release --test awfqi_puddle -- --ignored --nocapture
//! ```

use awfqi::env::{Dynamics, EpisodeRecord, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi::prelude::{
    AliasEntry, Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, Evaluation, FqiConfig, FqiEntry, Gp,
    GpTraining, Greedy, Posterior, QFunction, RowSet, SampleSet, Scores, TabularFqi, Transition,
    evaluate, evaluate_greedy,
};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

type T = f32;
type Record = Transition<[T; 2], T>;

/// FQI cells per axis: 11 × 11 × 4 actions = 484 entries (9.7 KB in f32).
const CELLS: usize = 11;
/// Capacity of every GP.
const GP_POINTS: usize = 64;
/// Spacing of the score grid: 11 × 11 points × 4 actions = 484 rows.
const SCORE_SPACING: f64 = 1.0;
/// Steps of the end-to-end test (and the size of its target buffer).
const TEST_STEPS: usize = 3;
/// Queries per step (one episode's worth, spec §13.2 sub-setting (b)).
const BUDGET: usize = 50;
const HORIZON: usize = 50;

fn grid() -> CellGrid<T, 2> {
    CellGrid::cube(0.0, 10.0, CELLS).unwrap()
}

fn entries() -> Vec<FqiEntry<T>> {
    vec![FqiEntry::default(); CELLS * CELLS * PUDDLE_ACTIONS]
}

/// Appends one episode of `policy` on `env` to `data`.
fn episode<P: awfqi::policy::Policy<[T; 2]>>(
    env: &PuddleWorld<T>,
    policy: &mut P,
    data: &mut Vec<Record>,
    rng: &mut ChaCha8Rng,
) {
    let mut records = [EpisodeRecord::default(); HORIZON];
    let n = env.run_episode(policy, HORIZON, &mut records, rng).unwrap();
    data.extend(records[..n].iter().map(|r| r.transition));
}

/// Plain tabular FQI on episodes (spec §3.2): `steps` steps of `batch` episodes, the first
/// uniform, then ε-greedy (0.3) w.r.t. the last fit; calls `after_step` after each fit.
fn plain_fqi_on_episodes(
    env: &PuddleWorld<T>,
    steps: usize,
    batch: usize,
    rng: &mut ChaCha8Rng,
    mut after_step: impl FnMut(usize, &TabularFqi<'_, T, 2>, &[Record]),
) -> Vec<Record> {
    let mut storage = entries();
    let mut fqi = TabularFqi::new(grid(), PUDDLE_ACTIONS, &mut storage).unwrap();
    let mut data = Vec::new();
    for step in 0..steps {
        for _ in 0..batch {
            if step == 0 {
                episode(env, &mut UniformPolicy::new(4).unwrap(), &mut data, rng);
            } else {
                let greedy = |s: &[T; 2]| fqi.greedy_action(*s);
                let mut policy = EpsilonGreedyPolicy::new(greedy, 0.3, 4).unwrap();
                episode(env, &mut policy, &mut data, rng);
            }
        }
        fqi.fit(&[SampleSet::unweighted(&data)], &FqiConfig::published())
            .unwrap();
        after_step(step + 1, &fqi, &data);
    }
    data
}

/// Spec §6 with the tabular learner: learn a source policy, then 20 greedy episodes.
///
/// The reference's source datasets reach the goal in every episode (§6), but a learner
/// whose uniform first batch never met the goal learns nothing about it (the goal shows
/// only through absorbing flags, §2.3) and its greedy policy wanders for 50 steps. Such a
/// dataset is regenerated from the next seed (`seed + 1000·attempt`) until at least 15 of
/// the 20 episodes reach the goal.
fn source_dataset(env: &PuddleWorld<T>, seed: u64) -> Vec<Record> {
    for attempt in 0..10 {
        let seed = seed + 1000 * attempt;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut data = Vec::new();
        plain_fqi_on_episodes(env, 5, 50, &mut rng, |step, fqi, _| {
            if step == 5 {
                let mut greedy = |s: &[T; 2]| fqi.greedy_action(*s);
                let mut source_rng = ChaCha8Rng::seed_from_u64(seed + 100);
                for _ in 0..20 {
                    episode(env, &mut greedy, &mut data, &mut source_rng);
                }
            }
        });
        if data.iter().filter(|t| t.absorbing).count() >= 15 {
            return data;
        }
    }
    panic!("no source policy reached the goal in 15 of 20 episodes");
}

/// GP training: the spec's box and initial values; the end-to-end test uses a smaller
/// search budget (2 restarts, 120 likelihood evaluations) to keep the debug build fast, the
/// measurement the reference's (10 restarts, 550 evaluations).
fn training(reference: bool) -> GpTraining<T, 3> {
    let mut t = GpTraining::published();
    if !reference {
        t.search.restarts = 2;
        t.search.max_evaluations = 120;
    }
    t
}

/// Score rows of the grid: 11 × 11 points × 4 actions.
const ROWS: usize = 484;
/// Source records the storage has room for (3 sources of 20 greedy episodes).
const SOURCE_CAPACITY: usize = 3 * 20 * HORIZON;
/// The kernel's memory for `STEPS` steps of 50 queries.
type Storage<const Q: usize> =
    AwfqiStorage<T, 2, 3, GP_POINTS, Q, SOURCE_CAPACITY, ROWS, { CELLS * CELLS * PUDDLE_ACTIONS }>;

/// The source data of an experiment (spec §6), generated once from fixed seeds.
struct Setup {
    training: GpTraining<T, 3>,
    records: Vec<Vec<Record>>,
}

impl Setup {
    fn new(training: GpTraining<T, 3>) -> Self {
        let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
        let records = worlds
            .iter()
            .enumerate()
            .map(|(k, w)| source_dataset(w, 10 + k as u64))
            .collect();
        Self { training, records }
    }

    fn source_records(&self) -> usize {
        self.records.iter().map(Vec::len).sum()
    }

    /// Sets AWFQI up once with the builder — one reward GP per source (an even spread of
    /// its records) for the stored posteriors, and the oracle or the realistic score table
    /// on the grid — then runs `steps` steps from each seed (`reset` between runs);
    /// `after_step` sees the seed, each report's step, the kernel's Q-function and the
    /// target samples.
    fn run_awfqi<const Q: usize>(
        &self,
        oracle: bool,
        seeds: &[u64],
        mut after_step: impl FnMut(u64, usize, &QFunction<'_, T, 2>, &[Record]),
    ) {
        let slices: Vec<&[Record]> = self.records.iter().map(Vec::as_slice).collect();
        let rows = RowSet::grid(PuddleWorld::score_grid(SCORE_SPACING as T).unwrap(), 4).unwrap();
        let mut storage = Box::new(Storage::<Q>::new());
        let mut posteriors = vec![Posterior::default(); self.source_records()];
        let mut scores = vec![Scores::ZERO; rows.len()];
        let mut config = AwfqiConfig::thesis(BUDGET);
        config.gp_training = self.training;
        let builder = Awfqi::builder(config.validate().unwrap(), grid(), &slices, rows)
            .fit_posteriors(&mut posteriors);
        let builder = if oracle {
            let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
            builder.scores_from(&worlds, &mut scores).unwrap()
        } else {
            builder.realistic_scores(&mut scores)
        };
        let mut set_up = ChaCha8Rng::seed_from_u64(77);
        let mut kernel = builder
            .build(
                PuddleWorld::target(Dynamics::Shared),
                &mut *storage,
                &mut set_up,
            )
            .unwrap();
        for &seed in seeds {
            kernel.reset();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            for _ in 0..Q / BUDGET {
                let report = kernel.step(&mut rng).unwrap();
                after_step(seed, report.step, kernel.q(), kernel.target_samples());
            }
        }
    }
}

/// The uniform-random policy's mean discounted return over `n` rollouts.
fn uniform_return(n: usize, seed: u64) -> T {
    let target = PuddleWorld::<T>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let protocol = awfqi::evaluation::EvaluationProtocol {
        rollouts: n,
        ..target.evaluation_protocol()
    };
    evaluate(
        &target,
        &mut UniformPolicy::new(4).unwrap(),
        &protocol,
        &mut rng,
    )
    .unwrap()
    .mean_return
}

fn evaluate_q(q: &impl Greedy<T, 2>, seed: u64) -> Evaluation<T> {
    let target = PuddleWorld::<T>::target(Dynamics::Shared);
    let protocol = target.evaluation_protocol();
    evaluate_greedy(&target, q, &protocol, &mut ChaCha8Rng::seed_from_u64(seed)).unwrap()
}

#[test]
fn awfqi_improves_on_the_uniform_policy() {
    let setup = Setup::new(training(false));
    // Every source episode of a learned policy should mostly reach its goal: the data then
    // carry the goal through the absorbing flags (spec §2.3).
    for r in &setup.records {
        let goals = r.iter().filter(|t| t.absorbing).count();
        assert!(
            goals >= 15,
            "only {goals} of 20 source episodes reached the goal"
        );
    }
    let uniform = uniform_return(200, 5);
    for (name, oracle) in [("oracle", true), ("realistic", false)] {
        let mut last = None;
        setup.run_awfqi::<{ TEST_STEPS * BUDGET }>(oracle, &[1], |_, step, q, samples| {
            assert_eq!(samples.len(), step * BUDGET);
            last = Some(evaluate_q(q, 500 + step as u64));
        });
        // Uniform: about −140 (it wanders 50 steps and meets the (1, 4) puddle); a policy
        // that reaches the goal in ~14 steps scores about −15 to −30.
        let eval = last.unwrap();
        assert!(
            eval.mean_return > uniform + 50.0,
            "{name}: greedy return {} after 3 steps vs uniform {uniform}",
            eval.mean_return
        );
        assert!(eval.absorbed >= 3, "{name}: {eval:?}");
    }
}

#[test]
#[ignore = "measurement: prints and checks the per-step return table (run in release)"]
fn measure_returns_per_step() {
    const RUNS: u64 = 10;
    const STEPS: usize = 6;
    let setup = Setup::new(training(true));
    println!(
        "source records: {:?} (total {})",
        setup.records.iter().map(Vec::len).collect::<Vec<_>>(),
        setup.source_records()
    );
    let seeds: Vec<u64> = (0..RUNS).map(|run| 1000 + run).collect();
    let mut table = vec![vec![Vec::new(); STEPS]; 3];
    for (k, oracle) in [true, false].into_iter().enumerate() {
        setup.run_awfqi::<{ STEPS * BUDGET }>(oracle, &seeds, |seed, step, q, _| {
            table[k][step - 1].push(evaluate_q(q, seed * 100 + step as u64).mean_return);
        });
    }
    for &seed in &seeds {
        let target = PuddleWorld::<T>::target(Dynamics::Shared);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        plain_fqi_on_episodes(&target, STEPS, 1, &mut rng, |step, q, _| {
            table[2][step - 1].push(evaluate_q(q, seed * 100 + step as u64).mean_return);
        });
    }
    let stats = |v: &[T]| {
        let n = v.len() as f64;
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / n;
        let var = v.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / n;
        (mean, (var / n).sqrt())
    };
    println!("mean greedy discounted return ± standard error over {RUNS} runs (5 rollouts each)");
    println!("step  queries  AWFQI oracle      AWFQI realistic   plain FQI (1 episode/step)");
    for step in 0..STEPS {
        let cells: Vec<String> = table
            .iter()
            .map(|algorithm| {
                let (m, se) = stats(&algorithm[step]);
                format!("{m:7.2} ± {se:5.2}")
            })
            .collect();
        println!(
            "{:4}  {:7}  {}   {}   {}",
            step + 1,
            (step + 1) * BUDGET,
            cells[0],
            cells[1],
            cells[2]
        );
    }
    println!(
        "uniform-random policy: {:.2} (1000 rollouts)",
        uniform_return(1000, 5)
    );
    memory_report(setup.source_records());
    // The figures the module documentation states, step by step: the oracle table's AWFQI
    // in −25…−19.5, the realistic table's in −40.5…−29.5 and below the oracle's, both
    // above plain FQI, which never beats −40.
    let steps = table[0].iter().zip(&table[1]).zip(&table[2]).enumerate();
    for (step, ((oracle, realistic), fqi)) in steps {
        let [oracle, realistic, fqi] = [oracle, realistic, fqi].map(|v| stats(v).0);
        let at = format!("step {}: {oracle:.2}, {realistic:.2}, {fqi:.2}", step + 1);
        assert!((-25.0..=-19.5).contains(&oracle), "oracle, {at}");
        assert!((-40.5..=-29.5).contains(&realistic), "realistic, {at}");
        assert!(
            oracle > realistic && realistic > fqi && fqi <= -40.0,
            "{at}"
        );
    }
}

/// Prints the memory of the kernel state for this configuration with 3 steps of 50 queries
/// (host sizes; on Cortex-M `usize` is 4 bytes, see `awfqi::thesis` for the target sizes).
fn memory_report(source_records: usize) {
    use std::mem::size_of;
    let parts = [
        (
            "Awfqi struct (config, target model, slices)",
            size_of::<Awfqi<'static, T, PuddleWorld<T>, 2, 3, GP_POINTS>>(),
        ),
        (
            "AwfqiStorage (GP, 150 target samples, weights, alias, FQI table)",
            size_of::<Storage<{ TEST_STEPS * BUDGET }>>(),
        ),
        (
            "  of which the target GP Gp<f32, 64, 3>",
            size_of::<Gp<T, GP_POINTS, 3>>(),
        ),
        (
            "  of which the FQI table (484 FqiEntry)",
            CELLS * CELLS * PUDDLE_ACTIONS * size_of::<FqiEntry<T>>(),
        ),
        (
            "  of which the alias table (484 AliasEntry)",
            ROWS * size_of::<AliasEntry<T>>(),
        ),
        (
            "source records (Transition), may live in flash",
            source_records * size_of::<Record>(),
        ),
        (
            "source reward posteriors, may live in flash",
            source_records * size_of::<Posterior<T>>(),
        ),
        (
            "score values (set-up only, 484 Scores)",
            ROWS * size_of::<Scores<T, 2>>(),
        ),
    ];
    println!("memory of the kernel state (host sizes, bytes):");
    for (name, bytes) in parts {
        println!("  {bytes:7}  {name}");
    }
}
