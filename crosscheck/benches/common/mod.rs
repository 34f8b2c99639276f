//! Inputs shared by the criterion suite (`crosscheck/benches/core_ops.rs`) and the instruction-count
//! driver (`crosscheck/examples/perf_ops.rs`), so both measure the same operations on the same data.
//!
//! Everything is generated from fixed seeds in f64; the f32 variants are the same numbers
//! rounded to f32, and the harness's reference receives the f64 numbers.

#![allow(dead_code)]

use awfqi::env::{Dynamics, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::identify::MiConfig;
use awfqi::record_gp::{Output, fit_gp, predict_posteriors};
use awfqi::rng::uniform_f64;
use awfqi::{
    Result,
    prelude::{
        Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, FqiConfig, FqiEntry, GenerativeModel, Gp,
        GpTraining, Hyperparameters, Real, RowSet, SampleSet, Scores, SubsetRule, TabularFqi,
        Transition,
    },
};
use awfqi_harness::forest_fqi;
use awfqi_harness::gp_large::{FitOptions, GpHyperparameters, LargeGp, Parallelism};
use awfqi_reference::gp as reference;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// Input dimension of every GP benchmark (spec §4.2's `z = (s_x, s_y, a)`).
pub const D: usize = 3;
/// Number of test inputs of a "predict" measurement.
pub const PREDICTIONS: usize = 100;
/// Fixed hyperparameters of the GP benchmarks: `c = 1`, `ℓ = 2`, `σ²ₙ = 0.01` — about what
/// the search finds on Puddle World rewards, and well-conditioned in f32 up to N = 128.
pub const SIGNAL_VARIANCE: f64 = 1.0;
/// See [`SIGNAL_VARIANCE`].
pub const LENGTH_SCALE: f64 = 2.0;
/// See [`SIGNAL_VARIANCE`].
pub const NOISE_VARIANCE: f64 = 0.01;

/// A GP data set: `n` training inputs `z = (x, y, a)` with `x, y ∈ [0, 10]`, `a ∈ {0..3}`,
/// targets from a smooth function plus noise, and [`PREDICTIONS`] test inputs.
#[derive(Debug, Clone)]
pub struct GpCase {
    pub x: Vec<[f64; D]>,
    pub y: Vec<f64>,
    pub test: Vec<[f64; D]>,
}

fn puddle_input(rng: &mut ChaCha8Rng) -> [f64; D] {
    let a = (uniform_f64(rng) * 4.0).floor().min(3.0);
    [10.0 * uniform_f64(rng), 10.0 * uniform_f64(rng), a]
}

/// The data set with `n` training points (the first `k` points are the same for every
/// `n ≥ k`: the add-point benchmarks rely on it).
pub fn gp_case(n: usize) -> GpCase {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let x: Vec<[f64; D]> = (0..n).map(|_| puddle_input(&mut rng)).collect();
    let mut noise = ChaCha8Rng::seed_from_u64(8);
    let y = x
        .iter()
        .map(|z| {
            (z[0] / 2.0).sin()
                + (z[1] / 3.0).cos()
                + 0.1 * z[2]
                + 0.1 * awfqi::rng::standard_normal::<f64, _>(&mut noise)
        })
        .collect();
    let mut test_rng = ChaCha8Rng::seed_from_u64(9);
    let test = (0..PREDICTIONS)
        .map(|_| puddle_input(&mut test_rng))
        .collect();
    GpCase { x, y, test }
}

/// The fixed hyperparameters in the core's type.
pub fn hyper<T: Real>() -> Hyperparameters<T, D> {
    Hyperparameters::isotropic(
        T::from_f64(SIGNAL_VARIANCE),
        T::from_f64(LENGTH_SCALE),
        T::from_f64(NOISE_VARIANCE),
    )
}

/// The fixed hyperparameters in the reference's type.
pub fn reference_hyper() -> reference::Hyperparameters {
    reference::Hyperparameters {
        signal_variance: SIGNAL_VARIANCE,
        length_scales: vec![LENGTH_SCALE; D],
        noise_variance: NOISE_VARIANCE,
    }
}

/// The fixed hyperparameters in the faithful path's type (its kernel is isotropic).
pub fn faithful_hyper() -> GpHyperparameters {
    GpHyperparameters {
        signal_variance: SIGNAL_VARIANCE,
        length_scale: LENGTH_SCALE,
        noise_variance: NOISE_VARIANCE,
    }
}

/// The faithful path's GP (faer Cholesky, sequential) with the fixed hyperparameters.
pub fn faithful_gp(case: &GpCase) -> LargeGp<D> {
    LargeGp::new(&case.x, &case.y, faithful_hyper(), Parallelism::Seq).expect("faithful fit")
}

/// The faithful path's fit with spec §4.2's search (L-BFGS-style with the analytic
/// gradient, initial values and 10 restarts, sequential).
pub fn faithful_search(case: &GpCase, seed: u64) -> LargeGp<D> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    LargeGp::fit(&case.x, &case.y, &FitOptions::default(), &mut rng)
        .expect("faithful search")
        .0
}

/// Sum of the means and stds of the faithful GP's predictions at `test`, as the faithful
/// path predicts: one batched call (`predict_into`).
pub fn faithful_predict_all(gp: &LargeGp<D>, test: &[[f64; D]]) -> f64 {
    let mut means = vec![0.0; test.len()];
    let mut stds = vec![0.0; test.len()];
    gp.predict_into(test, &mut means, &mut stds)
        .expect("faithful predictions");
    means.iter().sum::<f64>() + stds.iter().sum::<f64>()
}

/// Inputs converted to `T`.
pub fn inputs<T: Real>(x: &[[f64; D]]) -> Vec<[T; D]> {
    x.iter().map(|z| z.map(T::from_f64)).collect()
}

/// Values converted to `T`.
pub fn values<T: Real>(y: &[f64]) -> Vec<T> {
    y.iter().map(|&v| T::from_f64(v)).collect()
}

/// Inputs as the reference's rows.
pub fn reference_inputs(x: &[[f64; D]]) -> Vec<Vec<f64>> {
    x.iter().map(|z| z.to_vec()).collect()
}

/// A core GP of capacity `N` fitted on the first `n` points of `case` (boxed: up to
/// 136 KB).
pub fn fitted_gp<T: Real, const N: usize>(case: &GpCase, n: usize) -> Box<Gp<T, N, D>> {
    let mut gp = Box::new(Gp::<T, N, D>::empty());
    gp.set_hyperparameters(hyper())
        .expect("valid hyperparameters");
    if n > 0 {
        gp.fit(&inputs::<T>(&case.x[..n]), &values::<T>(&case.y[..n]))
            .expect("well-conditioned case");
    }
    gp
}

/// Sum of the means and variances of `PREDICTIONS` core predictions (the measured unit of
/// "predict").
pub fn predict_all<T: Real, const N: usize>(gp: &Gp<T, N, D>, test: &[[T; D]]) -> T {
    let mut acc = T::ZERO;
    for z in test {
        let p = gp.predict(z).expect("finite prediction");
        acc += p.mean + p.latent_variance;
    }
    acc
}

/// The same with the reference GP.
pub fn reference_predict_all(gp: &reference::ReferenceGp, test: &[Vec<f64>]) -> f64 {
    test.iter()
        .map(|z| {
            let (m, v) = gp.predict(z);
            m + v
        })
        .sum()
}

/// Puddle World transitions from uniformly drawn states and actions of `world`.
pub fn transitions<T: Real>(
    world: &PuddleWorld<T>,
    count: usize,
    seed: u64,
) -> Vec<Transition<[T; 2], T>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let s = [
                T::from_f64(10.0 * uniform_f64(&mut rng)),
                T::from_f64(10.0 * uniform_f64(&mut rng)),
            ];
            let a = ((uniform_f64(&mut rng) * 4.0) as usize).min(3);
            world.query(s, a, &mut rng).expect("state in the box")
        })
        .collect()
}

/// Cells per axis of the FQI sweep benchmark (41 × 41 × 4 actions).
pub const FQI_CELLS: usize = 41;
/// Samples of the FQI sweep benchmark.
pub const FQI_SAMPLES: usize = 3000;

/// The FQI benchmark's data: 3 000 target-world transitions with reward weights and
/// transition weights drawn uniformly in [0, 2].
pub struct FqiCase<T> {
    pub samples: Vec<Transition<[T; 2], T>>,
    pub reward_weights: Vec<T>,
    pub transition_weights: Vec<T>,
    pub storage: Vec<FqiEntry<T>>,
}

impl<T: Real> FqiCase<T> {
    pub fn new() -> Self {
        let samples = transitions(&PuddleWorld::<T>::target(Dynamics::Shared), FQI_SAMPLES, 11);
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let mut draw = |_| T::from_f64(2.0 * uniform_f64(&mut rng));
        let reward_weights = (0..FQI_SAMPLES).map(&mut draw).collect();
        let transition_weights = (0..FQI_SAMPLES).map(&mut draw).collect();
        Self {
            samples,
            reward_weights,
            transition_weights,
            storage: vec![FqiEntry::EMPTY; FQI_CELLS * FQI_CELLS * PUDDLE_ACTIONS],
        }
    }

    /// A weighted FQI fit with `iterations` iterations (1 = the reward model only; each
    /// further iteration is one sweep over the samples and the table).
    pub fn fit(&mut self, iterations: usize) -> Result<T> {
        let grid = CellGrid::cube(T::ZERO, T::from_f64(10.0), FQI_CELLS)?;
        let mut fqi = TabularFqi::new(grid, PUDDLE_ACTIONS, &mut self.storage)?;
        let config = FqiConfig::new(
            T::from_f64(0.99),
            iterations,
            FqiConfig::<T>::published().empty_cells(),
        )?
        .with_min_weight(FqiConfig::<T>::published().min_weight())?;
        let set = SampleSet::weighted(
            &self.samples,
            Some(&self.reward_weights),
            Some(&self.transition_weights),
        );
        fqi.fit(&[set], &config)?;
        fqi.value([T::ONE, T::ONE], 0)
    }
}

/// The FQI benchmark's data for the faithful path (Extra-Trees FQI of the harness): the same
/// samples and weights in f64.
pub struct ForestFqiCase {
    pub data: forest_fqi::Dataset<2>,
    pub reward_weights: Vec<f64>,
    pub transition_weights: Vec<f64>,
}

impl ForestFqiCase {
    pub fn new() -> Self {
        let case = FqiCase::<f64>::new();
        let mut data = forest_fqi::Dataset::new();
        for t in &case.samples {
            data.push(*t);
        }
        Self {
            data,
            reward_weights: case.reward_weights,
            transition_weights: case.transition_weights,
        }
    }

    /// IWFQI's weighted FQI on 50-tree forests with `iterations` iterations.
    pub fn fit(&self, iterations: usize, seed: u64) -> f64 {
        let mut options =
            forest_fqi::FqiOptions::iwfqi(&self.reward_weights, &self.transition_weights);
        options.iterations = iterations;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let out = forest_fqi::fqi(&self.data, &options, &mut rng).expect("forest fqi");
        out.model_rewards.map_or(0.0, |r| r.iter().sum())
    }
}

/// Capacity of the GPs of the score-table and AWFQI benchmarks.
pub const SOURCE_GP: usize = 64;
/// Records per source in the score-table and AWFQI benchmarks (3 sources: 900 records,
/// about the size of the end-to-end test's source data).
pub const SOURCE_RECORDS: usize = 300;
/// Score-table grid spacing of the score and AWFQI benchmarks: 11 × 11 points × 4 actions.
pub const SCORE_SPACING: f64 = 1.0;
/// FQI cells per axis of the AWFQI step benchmark.
pub const AWFQI_CELLS: usize = 11;
/// Queries per AWFQI step (one episode's worth, spec §13.2 (b)).
pub const AWFQI_BUDGET: usize = 50;

/// The three Puddle World sources (shared dynamics): records, reward GPs fitted as §4.2
/// says, and the records' stored reward posteriors.
pub struct Sources<T: Real> {
    pub records: Vec<Vec<Transition<[T; 2], T>>>,
    pub gps: Vec<Box<Gp<T, SOURCE_GP, D>>>,
    pub posteriors: Vec<Vec<awfqi::weights::Posterior<T>>>,
}

impl<T: Real> Sources<T> {
    pub fn new() -> Self {
        let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut records = Vec::new();
        let mut gps = Vec::new();
        let mut posteriors = Vec::new();
        for (k, w) in worlds.iter().enumerate() {
            let r = transitions(w, SOURCE_RECORDS, 30 + k as u64);
            let mut gp = Box::new(Gp::<T, SOURCE_GP, D>::empty());
            fit_gp(
                &mut gp,
                &r,
                Output::Reward,
                SubsetRule::Spread,
                &GpTraining::published(),
                &mut rng,
            )
            .expect("source GP fit");
            let mut post = vec![awfqi::weights::Posterior::default(); r.len()];
            predict_posteriors(
                &gp,
                &r,
                awfqi::weights::NoiseSubtraction::Reference,
                &mut post,
            )
            .expect("posteriors");
            records.push(r);
            gps.push(gp);
            posteriors.push(post);
        }
        Self {
            records,
            gps,
            posteriors,
        }
    }

    /// The reference GPs with the same data and hyperparameters as the core's source GPs
    /// (`T`'s values converted to f64).
    pub fn reference_gps(&self) -> Vec<reference::ReferenceGp> {
        self.gps
            .iter()
            .map(|gp| {
                let h = gp.hyperparameters();
                let hyper = reference::Hyperparameters {
                    signal_variance: h.signal_variance.to_f64(),
                    length_scales: h.length_scales.iter().map(|l| l.to_f64()).collect(),
                    noise_variance: h.noise_variance.to_f64(),
                };
                let x: Vec<Vec<f64>> = gp
                    .inputs()
                    .iter()
                    .map(|z| z.iter().map(|v| v.to_f64()).collect())
                    .collect();
                let y: Vec<f64> = gp.targets().iter().map(|v| v.to_f64()).collect();
                reference::ReferenceGp::fit_with_diagonal(&x, &y, &hyper, gp.jitter().to_f64())
                    .expect("reference fit of a source GP")
            })
            .collect()
    }
}

/// Rows of the score and AWFQI benchmarks: 11 × 11 grid points × 4 actions.
pub const SCORE_ROWS: usize = 484;

/// The score benchmark's rows: 11 × 11 grid points × 4 actions = 484.
pub fn score_rows<T: Real>() -> RowSet<'static, T, 2> {
    RowSet::grid(
        PuddleWorld::score_grid(T::from_f64(SCORE_SPACING)).expect("grid"),
        PUDDLE_ACTIONS,
    )
    .expect("rows")
}

/// The reference's score row: the population variance over the sources of the reference
/// GPs' posterior means at `z = (x, y, a)` (the realistic `V_r` of spec §11.2).
pub fn reference_score_row(gps: &[reference::ReferenceGp], z: &[f64]) -> f64 {
    let means: Vec<f64> = gps.iter().map(|g| g.predict(z).0).collect();
    let m = means.len() as f64;
    let mean = means.iter().sum::<f64>() / m;
    means.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / m
}

/// Alias-table rows of the draw benchmark: the harness's 101 × 101 grid × 4 actions.
pub const ALIAS_ROWS: usize = 40_804;
/// Draws per measured unit of the alias benchmark.
pub const ALIAS_DRAWS: usize = 1000;

/// Skewed weights for the alias table (most rows small, a few large, some 0).
pub fn alias_weights<T: Real>() -> Vec<T> {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    (0..ALIAS_ROWS)
        .map(|i| {
            let u = uniform_f64(&mut rng);
            T::from_f64(if i % 97 == 0 { 0.0 } else { u * u * u * 10.0 })
        })
        .collect()
}

/// The AWFQI step benchmark's kernel (thesis configuration, budget 50, 11 × 11 cells,
/// `N = 64`): the three sources' records ([`Sources`]' data), the whole set-up by the core's
/// builder — source GPs and their stored posteriors, the oracle score table on 484 rows —
/// and storage for one step. Everything is leaked so the kernel can live as long as the
/// process (a benchmark builds one per scalar type).
pub fn awfqi_kernel<T: Real>() -> Awfqi<'static, T, PuddleWorld<T>, 2, D, SOURCE_GP> {
    let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
    let records: &'static [Vec<Transition<[T; 2], T>>] = worlds
        .iter()
        .enumerate()
        .map(|(k, w)| transitions(w, SOURCE_RECORDS, 30 + k as u64))
        .collect::<Vec<_>>()
        .leak();
    let slices: &'static [&'static [Transition<[T; 2], T>]] =
        records.iter().map(Vec::as_slice).collect::<Vec<_>>().leak();
    let posteriors = vec![awfqi::weights::Posterior::default(); 3 * SOURCE_RECORDS].leak();
    let rows = score_rows::<T>();
    let scores = vec![Scores::ZERO; rows.len()].leak();
    let storage = Box::leak(Box::new(AwfqiStorage::<
        T,
        2,
        D,
        SOURCE_GP,
        AWFQI_BUDGET,
        { 3 * SOURCE_RECORDS },
        SCORE_ROWS,
        { AWFQI_CELLS * AWFQI_CELLS * PUDDLE_ACTIONS },
    >::new()));
    let config = AwfqiConfig::thesis(AWFQI_BUDGET)
        .validate()
        .expect("thesis configuration");
    let grid = CellGrid::cube(T::ZERO, T::from_f64(10.0), AWFQI_CELLS).expect("grid");
    Awfqi::builder(config, grid, slices, rows)
        .fit_posteriors(posteriors)
        .scores_from(&worlds, scores)
        .expect("oracle table")
        .build(
            PuddleWorld::target(Dynamics::Shared),
            storage,
            &mut ChaCha8Rng::seed_from_u64(0),
        )
        .expect("kernel")
}

/// The Grid World identification inputs: the thesis's four candidates (non-absorbing
/// goals), the uniform prior and one observation.
pub struct GridCase<T: Real> {
    pub candidates: [awfqi::env::GridWorld<T>; 4],
    pub prior: [T; 4],
    pub score: Vec<T>,
    /// `(state, action, next_state, reward)`.
    pub observation: (usize, usize, usize, T),
}

impl<T: Real> GridCase<T> {
    pub fn new() -> Self {
        let candidates = awfqi::env::GridWorld::<T>::thesis_candidates(false);
        // A query at the goal cell (9, 9) of candidate 0, reward 0.8: informative.
        let target = &candidates[0];
        let state = target.goal();
        let next = target.next_state(state, 0).expect("valid pair");
        Self {
            candidates,
            prior: [T::from_f64(0.25); 4],
            score: vec![T::ZERO; 400],
            observation: (state, 0, next, T::from_f64(0.8)),
        }
    }
}

/// The MI score configuration of the benchmarks: spec §10.3's defaults.
pub fn mi_config() -> MiConfig {
    MiConfig::default()
}
