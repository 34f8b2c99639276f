//! The workloads of the footprint images (`src/bin/footprint/`), kept here so the on-target
//! suite runs them too (a footprint of code that does not work would mean nothing).

use awfqi::gp::{Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
use awfqi::rng::{normal, uniform_in};
use awfqi::{Result, prelude::Real};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// A GP reward model as a controller would run it: `N` noisy observations of a puddle-like
/// reward `−1 − 20·exp(−‖s − (6, 4)‖²/1.6)` at random `(s_x, s_y, a)`, added one by one;
/// a bounded hyperparameter search (30 evaluations, 1 restart, spec §4.2's box); four more
/// observations through the sliding window; eight predictions and the log marginal
/// likelihood. Returns the sum of the predicted means and variances plus the likelihood.
///
/// `gp` may hold anything on entry (even all-zero bits): it is re-initialised first.
pub fn gp_reward_model<const N: usize>(gp: &mut Gp<f32, N, 3>, seed: u64) -> Result<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    gp.clear();
    gp.set_hyperparameters(Hyperparameters::isotropic(1.0, 1.0, 0.1))?;
    let observe = |rng: &mut ChaCha8Rng, i: usize| -> Result<([f32; 3], f32)> {
        let x = uniform_in(rng, 0.0f32, 10.0)?;
        let y = uniform_in(rng, 0.0f32, 10.0)?;
        let d2 = (x - 6.0) * (x - 6.0) + (y - 4.0) * (y - 4.0);
        let reward = -1.0 - 20.0 * (-d2 / 1.6).exp();
        Ok(([x, y, (i % 4) as f32], normal(rng, reward, 0.1)?))
    };
    for i in 0..N {
        let (x, y) = observe(&mut rng, i)?;
        gp.add_point(x, y, WhenFull::Refuse)?;
    }
    let options = SearchOptions {
        max_evaluations: 30,
        restarts: 1,
        isotropic: true,
    };
    let mut total =
        gp.optimize_hyperparameters(&HyperparameterBounds::spec_default(), &options, &mut rng)?;
    for i in 0..4 {
        let (x, y) = observe(&mut rng, i)?;
        gp.add_point(x, y, WhenFull::DropOldest)?;
    }
    for i in 0..8u8 {
        let p = gp.predict(&[f32::from(i), 4.0, f32::from(i % 4)])?;
        total += p.mean + p.latent_variance;
    }
    Ok(total + gp.log_marginal_likelihood()?)
}

use awfqi::env::{Dynamics, EpisodeRecord, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::prelude::{
    AdaptiveAwfqi, AdaptiveConfig, AdaptiveStorage, Approximator, ExtraTrees, ModelSweep,
    SourceData, Tilings,
};
use awfqi::prelude::{
    Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, EmptyCells, EpsilonGreedyPolicy, Evaluation,
    FqiConfig, GenerativeModel, PointGrid, Posterior, RowSet, Scores, SourceMeans, SourceModel,
    StepReport, Transition, evaluate_greedy,
};

/// A transition record in `f32`.
pub type Record = Transition<[f32; 2], f32>;

/// Everything the AWFQI Puddle World workload needs, as one block (in an image: one
/// zero-initialised `static`): the source records generated on the device and their
/// stored posteriors (`W` records of 3 sources), the score values (`R` rows, set-up only)
/// and the kernel's own [`AwfqiStorage`] (`E` FQI entries = cells × 4 actions, `Q` target
/// samples = steps × budget, `N` the target GP's capacity).
pub struct KernelStorage<
    const W: usize,
    const R: usize,
    const E: usize,
    const Q: usize,
    const N: usize,
> {
    /// Source datasets, source after source.
    pub records: [Record; W],
    /// Stored reward posteriors of the source records (§6 step 3).
    pub posteriors: [Posterior<f32>; W],
    /// Score table values.
    pub scores: [Scores<f32, 2>; R],
    /// The kernel's memory.
    pub kernel: AwfqiStorage<f32, 2, 3, N, Q, W, R, E>,
}

impl<const W: usize, const R: usize, const E: usize, const Q: usize, const N: usize>
    KernelStorage<W, R, E, Q, N>
{
    /// All-zero storage, for a `static` in `.bss`.
    pub const fn new() -> Self {
        Self {
            records: [Transition::EMPTY; W],
            posteriors: [Posterior {
                mean: 0.0,
                std: 0.0,
            }; W],
            scores: [Scores::ZERO; R],
            kernel: AwfqiStorage::new(),
        }
    }
}

/// The AWFQI configuration of a run of [`awfqi_puddle`].
#[derive(Clone, Copy)]
pub struct KernelRun {
    /// FQI cells per axis (`E` must be `cells² · 4`).
    pub cells: usize,
    /// Score-grid spacing (10 must be a multiple): `(10/spacing + 1)² · 4` rows (`R`).
    pub spacing: f32,
    /// Queries per step.
    pub budget: usize,
    /// Steps (`Q` must be `steps · budget`).
    pub steps: usize,
    /// Source episodes per source (`W` must hold `3 · episodes · 50` records).
    pub episodes: usize,
    /// Likelihood evaluations and restarts of each GP search.
    pub search: (usize, usize),
}

/// The AWFQI Puddle World kernel end to end, on a microcontroller: source datasets from an
/// ε-greedy walk towards each source's goal (ε = 0.3); then the builder's set-up — one
/// reward GP per source fitted in the target GP's storage and its posteriors stored, the
/// oracle score table on the puddle grid (column `V_r`) — then `steps` AWFQI steps on the
/// shared-dynamics target and the greedy policy's evaluation (5 rollouts) after the last
/// one. `inspect` sees the target samples of the run.
pub fn awfqi_puddle<
    const W: usize,
    const R: usize,
    const E: usize,
    const Q: usize,
    const N: usize,
>(
    storage: &mut KernelStorage<W, R, E, Q, N>,
    run: KernelRun,
    seed: u64,
    inspect: impl FnOnce(&[Record]),
) -> Result<(StepReport<f32, 3>, Evaluation<f32>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let KernelStorage {
        records,
        posteriors,
        scores,
        kernel,
    } = storage;
    let worlds = PuddleWorld::<f32>::sources(Dynamics::Shared);
    // The plant lent to the kernel, not moved into it (see `awfqi_puddle_32k`).
    let target = PuddleWorld::target(Dynamics::Shared);
    let mut config = AwfqiConfig::thesis(run.budget);
    config.gp_training.search.max_evaluations = run.search.0;
    config.gp_training.search.restarts = run.search.1;

    // Source data: walk right to the goal's column, then up; sources one after the other.
    let mut lens = [0usize; 3];
    let mut slots = records.iter_mut();
    for (world, len) in worlds.iter().zip(lens.iter_mut()) {
        let goal_x = world.goal()[0];
        let towards_goal =
            move |s: &[f32; 2]| -> Result<usize> { Ok(if s[0] < goal_x - 0.5 { 0 } else { 2 }) };
        let mut policy = EpsilonGreedyPolicy::new(towards_goal, 0.3, PUDDLE_ACTIONS)?;
        for _ in 0..run.episodes {
            world.run_episode_with(&mut policy, 50, &mut rng, |r: EpisodeRecord<f32>| {
                let slot = slots
                    .next()
                    .ok_or(awfqi::Error::CapacityExceeded { capacity: W })?;
                *slot = r.transition;
                *len += 1;
                Ok(())
            })?;
        }
    }
    let (first, rest) = records.split_at(lens[0]);
    let (second, rest) = rest.split_at(lens[1]);
    let sources: [&[Record]; 3] = [first, second, rest.get(..lens[2]).unwrap_or(&[])];
    let rows = RowSet::grid(PuddleWorld::score_grid(run.spacing)?, PUDDLE_ACTIONS)?;
    let total = lens.iter().sum::<usize>();
    let mut kernel = Awfqi::builder(
        config.validate()?,
        CellGrid::cube(0.0, 10.0, run.cells)?,
        &sources,
        rows,
    )
    .fit_posteriors(posteriors.get_mut(..total).unwrap_or(&mut []))
    .scores_from(&worlds, scores)?
    .build(&target, kernel, &mut rng)?;
    let mut report = None;
    for _ in 0..run.steps {
        report = Some(kernel.step(&mut rng)?);
    }
    let evaluation = evaluate_greedy(&target, kernel.q(), &target.evaluation_protocol(), &mut rng)?;
    inspect(kernel.target_samples());
    Ok((report.ok_or(awfqi::Error::EmptyData)?, evaluation))
}

/// The recommended Puddle World configuration in 32 KiB of RAM: the
/// kernel's whole memory, `AwfqiStorage<f32, 2, 3, 24, 300, 1033, 324, 484>` = 27 616 B on
/// this target — a 24-point target GP, 6 steps × 50 target records, one weight per
/// published source record (1033), the sampler over the 324 rows of the spacing-1.25
/// puddle grid, 11 × 11 × 4 FQI entries. The source records, their posteriors and the
/// score values are [`crate::puddle_tables`], in flash.
pub type Storage32k = AwfqiStorage<f32, 2, 3, 24, 300, 1033, 324, 484>;

/// The main job's AWFQI on the device in the 32 KiB configuration: the builder over the
/// flash tables, 6 steps of 50 queries (thesis configuration, §4.2 search), the greedy
/// policy's evaluation. `std_harness/examples/embedded_capacity.rs` (`24 11 1.25`) measures
/// the return of this configuration on the host.
pub fn awfqi_puddle_32k(
    storage: &mut Storage32k,
    seed: u64,
) -> Result<(StepReport<f32, 3>, Evaluation<f32>)> {
    use crate::puddle_tables as t;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // The list of the source tables in flash too, not built on the stack.
    static SOURCES: [&[Record]; 3] = [&t::SOURCE_1, &t::SOURCE_2, &t::SOURCE_3];
    let target = PuddleWorld::target(Dynamics::Shared);
    let rows = RowSet::grid(PuddleWorld::score_grid(1.25)?, PUDDLE_ACTIONS)?;
    let mut kernel = Awfqi::builder(
        AwfqiConfig::thesis(50).validate()?,
        CellGrid::cube(0.0, 10.0, 11)?,
        &SOURCES,
        rows,
    )
    .stored_posteriors(&t::SOURCE_POSTERIORS)
    .stored_scores(&t::SCORES)
    // The plant lent, not moved: the kernel holds a reference instead of its 200 bytes.
    .build(&target, storage, &mut rng)?;
    let mut report = None;
    for _ in 0..6 {
        report = Some(kernel.step(&mut rng)?);
    }
    let evaluation = evaluate_greedy(&target, kernel.q(), &target.evaluation_protocol(), &mut rng)?;
    Ok((report.ok_or(awfqi::Error::EmptyData)?, evaluation))
}

/// A 4-D toy plant (the one of `tests/generic_plant.rs`, in `f32`): states in `[−1, 1]⁴`,
/// action 0 moves every coordinate by −0.5, action 1 by +0.5 (clipped, plus noise
/// 𝒩(0, 0.05²)), reward `−(Σ s̄′ − c)²/4` at the mean next state (+ noise).
#[derive(Clone, Copy)]
pub struct SumPlant {
    /// Set-point of the sum of the coordinates.
    pub c: f32,
}

impl SourceModel<f32, 4> for SumPlant {
    fn predict(&self, state: [f32; 4], action: usize) -> Result<SourceMeans<f32, 4>> {
        if action > 1 {
            return Err(awfqi::Error::OutOfRange {
                parameter: "action",
            });
        }
        let step = if action == 0 { -0.5 } else { 0.5 };
        let next_state = state.map(|x| (x + step).clamp(-1.0, 1.0));
        let sum: f32 = next_state.iter().sum();
        Ok(SourceMeans {
            reward: -(sum - self.c) * (sum - self.c) / 4.0,
            next_state,
        })
    }
}

impl GenerativeModel<f32> for SumPlant {
    type State = [f32; 4];

    fn num_actions(&self) -> usize {
        2
    }

    fn query<R: rand_core::Rng + ?Sized>(
        &self,
        state: [f32; 4],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[f32; 4], f32>> {
        let mean = self.predict(state, action)?;
        let mut next_state = mean.next_state;
        for x in &mut next_state {
            *x = (*x + normal(rng, 0.0, 0.05)?).clamp(-1.0, 1.0);
        }
        Ok(Transition {
            state,
            action,
            reward: mean.reward + normal(rng, 0.0, 0.05)?,
            next_state,
            absorbing: false,
        })
    }
}

/// Memory of [`awfqi_4d`]: two sources' records (512 each: every point of the 4⁴ lattice
/// of cell centres with both actions), their posteriors, the score values of the 512
/// candidate rows, and the kernel's `AwfqiStorage` (64-point GP over (s, a) ∈ ℝ⁵, 3 steps
/// × 40 target records, 1024 weights, 512 alias entries, 4⁴ cells × 2 actions).
pub struct Storage4d {
    /// Source records, source after source.
    pub records: [Transition<[f32; 4], f32>; 1024],
    /// Their stored reward posteriors.
    pub posteriors: [Posterior<f32>; 1024],
    /// Score values (set-up only).
    pub scores: [Scores<f32, 4>; 512],
    /// The kernel's memory.
    pub kernel: AwfqiStorage<f32, 4, 5, 64, 120, 1024, 512, 512>,
}

impl Storage4d {
    /// All-zero storage, for a `static` in `.bss`.
    pub const fn new() -> Self {
        Self {
            records: [Transition::EMPTY; 1024],
            posteriors: [Posterior {
                mean: 0.0,
                std: 0.0,
            }; 1024],
            scores: [Scores::ZERO; 512],
            kernel: AwfqiStorage::new(),
        }
    }
}

/// The AWFQI loop at four state dimensions on the device, as `tests/generic_plant.rs` runs
/// it on the host (one record per lattice pair instead of two): sources with set-points 0
/// (the target's twin) and 1 logged on the device, the builder (source GPs fitted, their
/// posteriors stored, the realistic score table), 3 steps of 40 queries, then the greedy
/// policy against the closed-form optimum `π*(s) = 0 if Σ s ≥ 1, 1 if Σ s ≤ −1`. Returns
/// the cells checked and the cells where the greedy action is π*'s.
pub fn awfqi_4d(storage: &mut Storage4d, seed: u64) -> Result<(usize, usize)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let Storage4d {
        records,
        posteriors,
        scores,
        kernel,
    } = storage;
    let lattice = PointGrid::new([-0.75f32; 4], [0.5; 4], [4; 4])?;
    let plants = [SumPlant { c: 0.0 }, SumPlant { c: 1.0 }];
    for (k, slot) in records.iter_mut().enumerate() {
        let plant = plants.get(k / 512).copied().unwrap_or(plants[0]);
        let point = lattice
            .point((k % 512) / 2)
            .ok_or(awfqi::Error::EmptyData)?;
        *slot = plant.query(point, k % 2, &mut rng)?;
    }
    let (first, second) = records.split_at(512);
    let sources: [&[Transition<[f32; 4], f32>]; 2] = [first, second];
    let mut config = AwfqiConfig::thesis(40);
    config.gp_training.search.max_evaluations = 120;
    config.gp_training.search.restarts = 2;
    config.fqi = FqiConfig::new(0.8, 30, EmptyCells::CappedNearest)?.with_min_weight(0.05)?;
    let grid = CellGrid::cube(-1.0, 1.0, 4)?;
    let mut kernel = Awfqi::builder(
        config.validate()?,
        grid,
        &sources,
        RowSet::grid(lattice, 2)?,
    )
    .fit_posteriors(posteriors)
    .realistic_scores(scores)
    .build(SumPlant { c: 0.0 }, kernel, &mut rng)?;
    for _ in 0..3 {
        kernel.step(&mut rng)?;
    }
    let q = kernel.q();
    let (mut checked, mut optimal) = (0, 0);
    for cell in 0..grid.len() {
        let centre = grid.center(cell).ok_or(awfqi::Error::EmptyData)?;
        let sum: f32 = centre.iter().sum();
        let best = if sum >= 1.0 {
            0
        } else if sum <= -1.0 {
            1
        } else {
            continue;
        };
        checked += 1;
        optimal += usize::from(q.greedy_action(centre)? == best);
    }
    Ok((checked, optimal))
}

use awfqi::env::GridWorld;
use awfqi::identify::{Belief, Criterion, MiConfig, Scoring, compute_score, run_queries};
use awfqi::planning::{StoppingRule, greedy_policy, value_iteration};

/// What [`grid_identification`] found.
#[derive(Clone, Copy, Debug)]
pub struct Identified {
    /// The maximum-a-posteriori candidate after the queries.
    pub map: usize,
    /// Its posterior probability.
    pub map_probability: f32,
    /// The optimal value of the initial state under the MAP candidate.
    pub initial_value: f32,
    /// The greedy action at the initial state.
    pub initial_action: usize,
}

/// Caller storage of [`grid_identification`]: 4 KiB in `f32` on a 32-bit target.
pub struct IdentificationStorage {
    /// One score per state-action pair.
    pub score: [f32; 400],
    /// State values of the MAP candidate.
    pub values: [f32; 100],
    /// Q-table of the MAP candidate.
    pub q: [f32; 400],
    /// Its greedy policy.
    pub policy: [usize; 100],
}

/// Finite-MDP identification on the thesis Grid World (spec §10.4): K = 4 candidates,
/// 100 states × 4 actions = 400 state-action pairs, the true MDP being candidate `truth`.
/// `budget` queries drawn adaptively from the inter-MDP variance score with Bayesian belief
/// updates, one mutual-information score (`mi_samples` samples, 30 bins) of the final
/// belief, then value iteration (γ = 0.9) on the MAP candidate and its greedy policy.
pub fn grid_identification(
    storage: &mut IdentificationStorage,
    truth: usize,
    budget: usize,
    mi_samples: usize,
    seed: u64,
) -> Result<Identified> {
    let IdentificationStorage {
        score,
        values,
        q,
        policy,
    } = storage;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let candidates = GridWorld::<f32>::thesis_candidates(false);
    let model = *candidates
        .get(truth)
        .ok_or(awfqi::Error::OutOfRange { parameter: "truth" })?;
    let mut belief = Belief::<f32, 4>::uniform(4)?;
    let scoring = Scoring::Adaptive(Criterion::Variance);
    run_queries(
        &candidates,
        &model,
        &scoring,
        budget,
        &mut belief,
        score,
        &mut rng,
        |_, _| {},
    )?;
    let probabilities = belief.probability_array();
    let mi = Criterion::MutualInformation(MiConfig {
        samples: mi_samples,
        ..MiConfig::default()
    });
    compute_score(&mi, &candidates, &probabilities, &mut rng, score)?;
    let map = belief.map();
    let chosen = candidates
        .get(map)
        .ok_or(awfqi::Error::OutOfRange { parameter: "map" })?;
    let rule = StoppingRule {
        tolerance: 1e-5,
        max_sweeps: 1000,
    };
    value_iteration(chosen, 0.9, rule, values, q)?;
    greedy_policy(q, 4, policy)?;
    Ok(Identified {
        map,
        map_probability: probabilities.get(map).copied().unwrap_or(0.0),
        initial_value: values.first().copied().unwrap_or(0.0),
        initial_action: policy.first().copied().unwrap_or(0),
    })
}

/// The FQI approximator of an adaptive run.
#[derive(Clone, Copy)]
pub enum AdaptiveQ {
    /// Tile coding: tiles per axis and tilings (`E` must hold its entries).
    Tiles(usize, usize),
    /// Streamed Extra-Trees: trees per action and the scratch tree's nodes (the lent
    /// storage must hold the target and source records and the nodes).
    Trees(usize, usize),
    /// A model sweep: cells per axis, reward model, least reward mass (the lent storage
    /// must hold its entries and nodes).
    Sweep(usize, awfqi::fqi::RewardModel, f32),
}

/// What a run of [`adaptive_puddle`] changes from the recommended configuration.
#[derive(Clone, Copy)]
pub struct AdaptiveRun {
    /// Queries per step.
    pub budget: usize,
    /// Steps (`Q` must hold `steps · budget`).
    pub steps: usize,
    /// Candidate rows per sub-batch (`C` must hold them).
    pub candidates: usize,
    /// The FQI approximator.
    pub q: AdaptiveQ,
    /// Likelihood evaluations and restarts of each GP search (`None`: the thesis's).
    pub search: Option<(usize, usize)>,
    /// Relabel the sources' rewards instead of weighting them (`AdaptiveConfig::relabel`).
    pub relabel: bool,
    /// Likelihood evaluations and restarts of the warm refits (`Refit::Warm`; `None`: every
    /// fit searches as the thesis does).
    pub refit: Option<(usize, usize)>,
}

/// The published shared-dynamics sources, in flash.
pub static PUBLISHED_SOURCES: [&[Record]; 3] = [
    &crate::puddle_tables::SOURCE_1,
    &crate::puddle_tables::SOURCE_2,
    &crate::puddle_tables::SOURCE_3,
];

/// The approximator `q` names, over Puddle World's `[0, 10]²`.
pub fn adaptive_approximator(q: AdaptiveQ) -> Result<Approximator<f32, 2>> {
    Ok(match q {
        AdaptiveQ::Tiles(n, k) => Tilings::cube(0.0, 10.0, n, k)?.into(),
        AdaptiveQ::Trees(count, nodes) => ExtraTrees::streamed(count, nodes)?.into(),
        AdaptiveQ::Sweep(cells, rewards, min_mass) => ModelSweep::cube(0.0, 10.0, cells)?
            .with_rewards(rewards)
            .with_min_mass(min_mass)?
            .into(),
    })
}

/// The set-up of adaptive AWFQI on Puddle World on the device: the published source
/// records and their posteriors from flash ([`crate::puddle_tables`]), one reward GP per
/// source fitted in the kernel's GP and kept as a mean function, the candidate rows of the
/// spacing-0.1 puddle grid (arithmetic, no memory), the shared-dynamics target; `fqi` lends
/// the memory of trees or a model sweep.
pub fn adaptive_setup<'m, S: AdaptiveStorage<f32, 2, 3, N>, const N: usize>(
    memory: &'m mut S,
    fqi: awfqi::fqi::QStorage<'m, f32, 2>,
    run: &AdaptiveRun,
    rng: &mut ChaCha8Rng,
) -> Result<AdaptiveAwfqi<'m, f32, PuddleWorld<f32>, 2, 3, N>> {
    use crate::puddle_tables as t;
    let awfqi::adaptive::AdaptiveParts {
        mut buffers, means, ..
    } = memory.parts();
    let target = PuddleWorld::target(Dynamics::Shared);
    let mut config = AdaptiveConfig::recommended(
        run.budget,
        target.initial_state(),
        50,
        0.3,
        [(0.0, 10.0); 2],
    );
    config.candidates = run.candidates;
    config.relabel = run.relabel;
    if let Some((evaluations, restarts)) = run.search {
        config.awfqi.gp_training.search.max_evaluations = evaluations;
        config.awfqi.gp_training.search.restarts = restarts;
    }
    config.refit = match run.refit {
        Some((max_evaluations, restarts)) => {
            awfqi::adaptive::Refit::Warm(awfqi::gp::SearchOptions {
                max_evaluations,
                restarts,
                isotropic: true,
            })
        }
        None => awfqi::adaptive::Refit::Search,
    };
    let sources = &PUBLISHED_SOURCES;
    let approximator = adaptive_approximator(run.q)?;
    if !matches!(run.q, AdaptiveQ::Tiles(..)) {
        buffers.fqi = fqi;
    }
    for (mean, source) in means.iter_mut().zip(sources) {
        mean.fit_rewards(
            &mut *buffers.gp,
            source,
            &config.awfqi.gp_training,
            config.awfqi.subset,
            rng,
        )?;
    }
    let rows = RowSet::grid(PuddleWorld::score_grid(0.1)?, PUDDLE_ACTIONS)?;
    AdaptiveAwfqi::new(
        config.validate()?,
        approximator,
        SourceData::new(sources, &t::SOURCE_POSTERIORS)?,
        &*means,
        rows,
        target,
        buffers,
    )
}

/// Adaptive AWFQI on Puddle World on the device: [`adaptive_setup`], the plan on the
/// sources, `steps` steps and the greedy policy's evaluation. `inspect` sees the kernel
/// after the last step.
pub fn adaptive_puddle<S: AdaptiveStorage<f32, 2, 3, N>, const N: usize>(
    memory: &mut S,
    fqi: awfqi::fqi::QStorage<'_, f32, 2>,
    run: AdaptiveRun,
    seed: u64,
    inspect: impl FnOnce(&AdaptiveAwfqi<'_, f32, PuddleWorld<f32>, 2, 3, N>),
) -> Result<(StepReport<f32, 3>, Evaluation<f32>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut kernel = adaptive_setup(memory, fqi, &run, &mut rng)?;
    kernel.plan(&mut rng)?;
    let mut report = None;
    for _ in 0..run.steps {
        report = Some(kernel.step(&mut rng)?);
    }
    let target = kernel.target();
    let evaluation = evaluate_greedy(target, kernel.q(), &target.evaluation_protocol(), &mut rng)?;
    inspect(&kernel);
    Ok((report.ok_or(awfqi::Error::EmptyData)?, evaluation))
}

awfqi::adaptive_storage! {
    /// The trees' configuration of adaptive AWFQI (the harness's `awfqi-adaptive` with
    /// `--adaptive-q trees`): the sources' 64-point mean functions and the kernel's
    /// memory — a 64-point target GP, 6 steps × 50 target records, one weight per
    /// published source record, 4 000 candidate slots, 50 verified states, 3 beliefs —
    /// with [`AdaptiveTreeMemory`] lent beside it (the posteriors are in flash).
    pub struct AdaptiveTrees {
        scalar: f32,
        state_dim: 2,
        actions: 4,
        gp_points: 64,
        steps: 6,
        budget: 50,
        sources: 3,
        source_records: 1033,
        source_posteriors: 0,
        candidates: 4000,
        table_entries: 0,
    }
}

/// The trees' FQI memory: one record slot per target and source record (300 + 1 033) and
/// a 1 023-node scratch tree.
pub type AdaptiveTreeMemory = awfqi::fqi::TreeStorage<f32, 2, 1333, 1023>;

/// The trees' run: 6 steps of 50 queries, 4 000 candidates, 50 streamed trees per action,
/// the thesis's GP search.
pub const ADAPTIVE_TREES: AdaptiveRun = AdaptiveRun {
    budget: 50,
    steps: 6,
    candidates: 4000,
    q: AdaptiveQ::Trees(50, 1023),
    search: None,
    relabel: false,
    refit: None,
};

awfqi::adaptive_storage! {
    /// The former recommendation's memory, tile coding: 12 × 12 tiles × 8 tilings of FQI
    /// entries (13² · 8 · 4 = 5 408) instead of the trees.
    pub struct AdaptiveTiles {
        scalar: f32,
        state_dim: 2,
        actions: 4,
        gp_points: 64,
        steps: 6,
        budget: 50,
        sources: 3,
        source_records: 1033,
        source_posteriors: 0,
        candidates: 4000,
        table_entries: 5408,
    }
}

/// The former recommendation's run: [`ADAPTIVE_TREES`] with 12 × 8 tiles.
pub const ADAPTIVE_TILES: AdaptiveRun = AdaptiveRun {
    q: AdaptiveQ::Tiles(12, 8),
    ..ADAPTIVE_TREES
};

awfqi::adaptive_storage! {
    /// The recommended configuration of adaptive AWFQI on Puddle World (what the harness's
    /// `awfqi-adaptive` runs by default, the footprint image `adaptive_puddle` and the
    /// instruction-count image `m4_adaptive`): the sources' 32-point mean functions and
    /// the kernel's memory — a 32-point target GP, 6 steps × 50 target records, one weight
    /// per published source record, 250 candidate slots, 50 verified states, 3 beliefs —
    /// with [`AdaptiveRecommendedFqi`] lent beside it (the posteriors are in flash).
    pub struct AdaptiveRecommended {
        scalar: f32,
        state_dim: 2,
        actions: 4,
        gp_points: 32,
        steps: 6,
        budget: 50,
        sources: 3,
        source_records: 1033,
        source_posteriors: 0,
        candidates: 250,
        table_entries: 0,
    }
}
/// Its FQI memory: a model sweep of 12 × 12 cells (13² nodes), 4 actions.
pub type AdaptiveRecommendedFqi = awfqi::fqi::SweepStorage<f32, 2, { 169 * 4 }, 169>;
/// Its run: 6 steps of 50 queries, 250 candidates, the sweep with pooled rewards, warm
/// refits of 30 evaluations.
pub const ADAPTIVE_RECOMMENDED: AdaptiveRun = AdaptiveRun {
    budget: 50,
    steps: 6,
    candidates: 250,
    q: AdaptiveQ::Sweep(12, awfqi::fqi::RewardModel::Pooled, 0.0),
    search: None,
    relabel: false,
    refit: Some((30, 0)),
};
