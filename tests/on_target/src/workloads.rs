//! The workloads of the footprint images (`src/bin/footprint/`), kept here so the on-target
//! suite runs them too (a footprint of code that does not work would mean nothing).

use awfqi::gp::{Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
use awfqi::rng::{normal, uniform_in};
use awfqi::{Real, Result};
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

use awfqi::alias::AliasEntry;
use awfqi::awfqi::{Awfqi, AwfqiConfig, SourceData, StepReport};
use awfqi::dataset::{Output, SubsetRule, fit_gp, predict_posteriors};
use awfqi::env::{Dynamics, EpisodeRecord, PUDDLE_ACTIONS, PuddleWorld, Transition};
use awfqi::evaluation::{Evaluation, evaluate_greedy};
use awfqi::fqi::{CellGrid, FqiEntry, TabularFqi};
use awfqi::policy::EpsilonGreedyPolicy;
use awfqi::score::{PointGrid, RowSet, ScoreColumn, ScoreTable, Scores};
use awfqi::weights::{NoiseSubtraction, Posterior};

/// A transition record in `f32`.
pub type Record = Transition<[f32; 2], f32>;

/// Everything the AWFQI Puddle World kernel needs, as one block of caller storage (in an
/// image: one zero-initialised `static`). `S` source records per source (3 sources), `R`
/// score rows (= alias entries), `E` FQI entries (cells × 4 actions), `Q` target samples
/// (steps × budget), `N` the target GP's capacity.
pub struct KernelStorage<
    const S: usize,
    const R: usize,
    const E: usize,
    const Q: usize,
    const N: usize,
> {
    /// Source datasets.
    pub sources: [[Record; S]; 3],
    /// Stored reward posteriors of the source records (§6 step 3).
    pub posteriors: [[Posterior<f32>; S]; 3],
    /// Score table values.
    pub scores: [Scores<f32>; R],
    /// Alias table of the score sampler.
    pub alias: [AliasEntry<f32>; R],
    /// FQI table.
    pub fqi: [FqiEntry<f32>; E],
    /// Target dataset `D₀`.
    pub samples: [Record; Q],
    /// Reward weights of the source records.
    pub weights: [[f32; S]; 3],
    /// Target reward GP (also used to fit the source GPs before the run).
    pub gp: Gp<f32, N, 3>,
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
    /// Source episodes per source (`S` must be `episodes · 50`).
    pub episodes: usize,
    /// Likelihood evaluations and restarts of each GP search.
    pub search: (usize, usize),
}

/// The AWFQI Puddle World kernel end to end, on a microcontroller: source datasets from an
/// ε-greedy walk towards each source's goal (ε = 0.3), one reward GP per source fitted in
/// the target GP's storage and its posteriors stored with the records, the oracle score
/// table on the puddle grid (column `V_r`), then `steps` AWFQI steps on the shared-dynamics
/// target and the greedy policy's evaluation (5 rollouts) after the last one.
pub fn awfqi_puddle<
    const S: usize,
    const R: usize,
    const E: usize,
    const Q: usize,
    const N: usize,
>(
    storage: &mut KernelStorage<S, R, E, Q, N>,
    run: KernelRun,
    seed: u64,
) -> Result<(StepReport<f32>, Evaluation<f32>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let KernelStorage {
        sources,
        posteriors,
        scores,
        alias,
        fqi,
        samples,
        weights,
        gp,
    } = storage;
    let worlds = PuddleWorld::<f32>::sources(Dynamics::Shared);
    let mut config = AwfqiConfig::thesis(run.budget);
    config.gp_training.search.max_evaluations = run.search.0;
    config.gp_training.search.restarts = run.search.1;

    // Source data: walk right to the goal's column, then up.
    let mut lens = [0usize; 3];
    for ((world, records), len) in worlds.iter().zip(sources.iter_mut()).zip(lens.iter_mut()) {
        let goal_x = world.goal()[0];
        let towards_goal =
            move |s: &[f32; 2]| -> Result<usize> { Ok(if s[0] < goal_x - 0.5 { 0 } else { 2 }) };
        let mut policy = EpsilonGreedyPolicy::new(towards_goal, 0.3, PUDDLE_ACTIONS)?;
        let mut slots = records.iter_mut();
        for _ in 0..run.episodes {
            world.run_episode_with(&mut policy, 50, &mut rng, |r: EpisodeRecord<f32>| {
                let slot = slots
                    .next()
                    .ok_or(awfqi::Error::CapacityExceeded { capacity: S })?;
                *slot = r.transition;
                *len += 1;
                Ok(())
            })?;
        }
    }
    // Source reward GPs, one at a time in the target GP's storage; posteriors stored.
    for ((records, post), &len) in sources.iter().zip(posteriors.iter_mut()).zip(lens.iter()) {
        let (records, post) = (
            records.get(..len).unwrap_or(&[]),
            post.get_mut(..len).unwrap_or(&mut []),
        );
        fit_gp(
            gp,
            records,
            Output::Reward,
            SubsetRule::Spread,
            &config.gp_training,
            &mut rng,
        )?;
        predict_posteriors(gp, records, NoiseSubtraction::Reference, post)?;
    }
    // Oracle score table and its sampler.
    let rows = RowSet::grid(PointGrid::puddle(run.spacing)?, PUDDLE_ACTIONS)?;
    let table = ScoreTable::compute(rows, &worlds, scores)?;
    let sampler = table.sampler(ScoreColumn::Reward, alias)?;

    let data = [0, 1, 2].map(|k| {
        let len = lens.get(k).copied().unwrap_or(0);
        let records = sources.get(k).and_then(|r| r.get(..len)).unwrap_or(&[]);
        let post = posteriors.get(k).and_then(|p| p.get(..len)).unwrap_or(&[]);
        SourceData::new(records, post)
    });
    let [a, b, c] = data;
    let data = [a?, b?, c?];
    let table = TabularFqi::new(CellGrid::cube(0.0, 10.0, run.cells)?, PUDDLE_ACTIONS, fqi)?;
    let target = PuddleWorld::target(Dynamics::Shared);
    let mut kernel = Awfqi::new(
        config,
        target,
        sampler,
        &data,
        samples,
        weights.as_flattened_mut(),
        gp,
        table,
    )?;
    let mut report = None;
    for _ in 0..run.steps {
        report = Some(kernel.step(&mut rng)?);
    }
    let evaluation = evaluate_greedy(&target, kernel.q(), &mut rng)?;
    Ok((report.ok_or(awfqi::Error::EmptyData)?, evaluation))
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
