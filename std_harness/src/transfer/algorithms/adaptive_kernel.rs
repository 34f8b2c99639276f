//! `awfqi-adaptive-kernel`: the core's adaptive AWFQI ([`awfqi::AdaptiveAwfqi`]) on the
//! same protocol as `awfqi-adaptive`, so the embedded version of the algorithm is measured,
//! not guessed.
//!
//! It runs as on a microcontroller, in `f32`, in fixed storage sized once per run: the
//! kernel path's set-up ([`KernelSetup`]: the `f32` source records, their stored posteriors,
//! the candidate rows of the setting and one `Gp<f32, 64, 3>` reward GP per source, whose
//! posterior means are the sources' [`MeanFunction`]s), tile coding with
//! [`ADAPTIVE_TILINGS`] offset tilings of [`ADAPTIVE_TILES`] tiles per axis (chosen on the
//! tuning runs `--seed 100`, `docs/active-budget.md`; `--kernel-resolution` given
//! explicitly sets the approximator of both kernels; `--adaptive-kernel-q knn|hybrid|trees`
//! selects the core's kernel averaging over the records, its mean with the tiles, or
//! per-action Extra-Trees forests, measured in `docs/active-budget.md`), and `awfqi-adaptive`'s options that the core has (`--adaptive-*`: sub-batches,
//! verification share, surprise, uncertainty, decision relevance, floor, candidates,
//! relevance width; the others must keep their defaults).

use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, FqiEntry, Gp, KnnRecord, MeanFunction,
    QStorage, SourceData, Transition, TreeNode, TreeRecord,
};
use rand_chacha::ChaCha8Rng;

use super::Experiment;
use super::adaptive::AdaptiveOptions;
use super::awfqi_kernel::{
    GP_POINTS, KernelQFunction, KernelSetup, Record32, SweepKnobs, T, print_warnings,
    reward_gp_summary, row_set, to_f64,
};
use crate::transfer::protocol::{Diagnostics, Learner};
use crate::transfer::sources::Record;

/// Trees per action of `--adaptive-kernel-q trees` by default: chosen on the tuning runs
/// (`--seed 100`, 20 runs: 50 against 20, 10 stored and tiles; `docs/active-budget.md`).
pub const ADAPTIVE_TREES: usize = 50;
/// Nodes of the streamed trees' scratch tree by default (the FQI iterations' trees of the
/// largest action are cut at this budget; the final trees are fully grown).
pub const ADAPTIVE_TREE_NODES: usize = 1023;
/// Cells per axis of the model sweep by default (13 × 13 nodes over `[0, 10]²`), chosen on
/// the tuning runs (`docs/embedded-adaptive.md`).
pub const ADAPTIVE_SWEEP_CELLS: usize = 12;
/// The adaptive kernel's default approximator: a model sweep on [`ADAPTIVE_SWEEP_CELLS`]
/// cells per axis with one reward model for every action (Puddle World's reward depends on
/// the state only).
pub const ADAPTIVE_Q: KernelQFunction = KernelQFunction::Sweep(SweepKnobs {
    cells: ADAPTIVE_SWEEP_CELLS,
    rewards: awfqi::RewardModel::Pooled,
    min_mass: 0.0,
    lookahead: false,
});

/// Tiles per axis of the adaptive kernel's tile coding (`--adaptive-kernel-q tiles`, the
/// default before the trees): chosen on the tuning runs
/// (`--seed 100`, 6 runs each: 6 × 4, 8 × 8, 10 × 8, 10 × 16, 12 × 8, 12 × 16, 14 × 8,
/// 16 × 8, 20 × 8; 12 × 8 best at every step but one, see `docs/active-budget.md`).
pub const ADAPTIVE_TILES: usize = 12;
/// Offset tilings of the adaptive kernel's tile coding.
pub const ADAPTIVE_TILINGS: usize = 8;

/// The core's configuration for `experiment`: the recommended one with the harness's
/// adaptive options.
///
/// Errors: an option the core does not have set away from its default, or an invalid one.
fn config(experiment: &Experiment) -> anyhow::Result<AdaptiveConfig<T, 2, 3>> {
    let o = experiment.adaptive_options;
    let d = AdaptiveOptions::default();
    anyhow::ensure!(
        o.prior == d.prior
            && o.model_rewards == d.model_rewards
            && o.source_weights == d.source_weights
            && o.surprise_stop == d.surprise_stop
            && o.simulate == d.simulate
            && o.resume == d.resume
            && o.temperature == d.temperature
            && o.consensus == d.consensus
            && o.corroborate == d.corroborate
            && o.oracle == d.oracle
            && o.select == d.select
            && o.final_trees == d.final_trees,
        "awfqi-adaptive-kernel has the default configuration of awfqi-adaptive only \
         (no --adaptive-prior, --adaptive-model-rewards, --adaptive-source-weights, \
         --adaptive-surprise-stop, --adaptive-simulate, --adaptive-resume, \
         --adaptive-temperature, --adaptive-consensus, --adaptive-corroborate, \
         --adaptive-oracle, --adaptive-select, --adaptive-final-trees)"
    );
    let domain = &experiment.domain;
    let mut bounds = [(0.0, 0.0); 2];
    for (b, &(lo, hi)) in bounds.iter_mut().zip(&domain.state_bounds) {
        *b = (lo as T, hi as T);
    }
    let start = awfqi::env::PUDDLE_INITIAL_STATE.map(|x| x as T);
    let mut c = AdaptiveConfig::recommended(
        experiment.budget(),
        start,
        domain.horizon,
        experiment.protocol.epsilon as T,
        bounds,
    );
    c.sub_batches = o.sub_batches;
    c.verify = o.verify as T;
    c.surprise = o.surprise;
    c.uncertainty = o.uncertainty;
    c.decision = o.decision;
    c.floor = o.floor as T;
    c.candidates = o.kernel_candidates;
    c.relevance_width = o.relevance_width as T;
    c.relabel = o.kernel_relabel;
    c.refit = match o.kernel_refit {
        Some((max_evaluations, restarts)) => awfqi::adaptive::Refit::Warm(awfqi::SearchOptions {
            max_evaluations,
            restarts,
            isotropic: c.awfqi.gp_training.search.isotropic,
        }),
        None => awfqi::adaptive::Refit::Search,
    };
    Ok(c)
}

/// The memory one run writes, on the heap and sized at run time: what a firmware holds in
/// an [`awfqi::AdaptiveStorage`].
#[derive(Debug)]
struct Memory<const N: usize> {
    gp: Box<Gp<T, N, 3>>,
    samples: Vec<Record32>,
    weights: Vec<T>,
    candidates: Vec<awfqi::adaptive::Candidate<T>>,
    fqi: Vec<FqiEntry<T>>,
    records: Vec<KnnRecord<T, 2>>,
    links: Vec<u16>,
    tree_records: Vec<TreeRecord<T, 2>>,
    nodes: Vec<TreeNode<T>>,
    sweep_entries: Vec<awfqi::SweepEntry<T, 2>>,
    sweep_nodes: Vec<awfqi::SweepNode<T>>,
    path: Vec<[T; 2]>,
    beliefs: Vec<awfqi::adaptive::SourceBelief<T>>,
}

impl<const N: usize> Memory<N> {
    fn buffers(&mut self) -> AdaptiveBuffers<'_, T, 2, 3, N> {
        AdaptiveBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            candidates: &mut self.candidates,
            fqi: QStorage {
                entries: &mut self.fqi,
                records: &mut self.records,
                links: &mut self.links,
                tree_records: &mut self.tree_records,
                nodes: &mut self.nodes,
                sweep_entries: &mut self.sweep_entries,
                sweep_nodes: &mut self.sweep_nodes,
            },
            path: &mut self.path,
            beliefs: &mut self.beliefs,
        }
    }
}

/// `awfqi-adaptive-kernel` as a [`Learner`]: each protocol step is one
/// [`AdaptiveAwfqi::step`]; the greedy action is the `f32` Q-function's, and `D₀` is kept in
/// `f64` for the result files.
struct AdaptiveKernelLearner<'a, const N: usize> {
    kernel: AdaptiveAwfqi<'a, T, PuddleWorld<T>, 2, 3, N>,
    collected: Vec<Record>,
}

impl<const N: usize> Learner for AdaptiveKernelLearner<'_, N> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let report = self.kernel.step(rng)?;
        print_warnings("awfqi-adaptive-kernel", &report);
        let new = &self.kernel.target_samples()[self.collected.len()..];
        self.collected.extend(new.iter().map(to_f64));
        Ok(Diagnostics {
            n_source_samples: Some(report.n_source_samples),
            wr_mean: Some(f64::from(report.wr_mean)),
            wr_eff: Some(f64::from(report.wr_eff)),
            reward_gp: Some(reward_gp_summary(&report)),
            ..Diagnostics::default()
        })
    }

    fn greedy_action(&self, s: &[f64; 2]) -> usize {
        let state = [s[0] as T, s[1] as T];
        self.kernel.q().greedy_action(state).unwrap_or(0)
    }

    fn target_samples(&self) -> &[Record] {
        &self.collected
    }
}

/// Hands a fresh learner for one run of `experiment` to `f` (the kernel borrows its memory
/// and the set-up for the whole run, so they live in this frame).
pub fn with_learner(
    experiment: &Experiment,
    rng: &mut ChaCha8Rng,
    f: &mut dyn FnMut(&mut dyn Learner, &mut ChaCha8Rng) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    match experiment.adaptive_options.kernel_gp_points {
        GP_POINTS => with_learner_of::<GP_POINTS>(experiment, rng, f),
        16 => with_learner_of::<16>(experiment, rng, f),
        24 => with_learner_of::<24>(experiment, rng, f),
        32 => with_learner_of::<32>(experiment, rng, f),
        48 => with_learner_of::<48>(experiment, rng, f),
        n => anyhow::bail!("--adaptive-kernel-gp-points {n}: 16, 24, 32, 48 or 64"),
    }
}

/// The sources' reward mean functions of capacity `N`: the set-up's when `N` is its GP
/// capacity, else fitted here as the set-up fits its own (the published training, an even
/// spread), from a stream of their own so every run has the same.
fn means_of<const N: usize>(
    setup: &KernelSetup,
    sources: &[&[Record32]],
) -> anyhow::Result<Vec<MeanFunction<T, N, 3>>> {
    use rand_core::SeedableRng;
    if N == GP_POINTS {
        let means: Vec<MeanFunction<T, N, 3>> = setup
            .means()
            .iter()
            .map(|m| {
                // N == GP_POINTS: the same type.
                let m: &dyn std::any::Any = m;
                m.downcast_ref::<MeanFunction<T, N, 3>>()
                    .cloned()
                    .ok_or_else(|| anyhow::anyhow!("mean function capacity"))
            })
            .collect::<anyhow::Result<_>>()?;
        return Ok(means);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(N as u64);
    let mut gp = Box::new(Gp::<T, N, 3>::empty());
    let mut means = vec![MeanFunction::EMPTY; sources.len()];
    for (mean, source) in means.iter_mut().zip(sources) {
        mean.fit_rewards(
            &mut gp,
            source,
            &awfqi::GpTraining::published(),
            awfqi::SubsetRule::Spread,
            &mut rng,
        )?;
    }
    Ok(means)
}

/// [`with_learner`] with target GPs and mean functions of `N` points.
fn with_learner_of<const N: usize>(
    experiment: &Experiment,
    rng: &mut ChaCha8Rng,
    f: &mut dyn FnMut(&mut dyn Learner, &mut ChaCha8Rng) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let setup: &KernelSetup = experiment
        .kernel
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("no kernel set-up"))?;
    let dynamics: Dynamics = experiment
        .protocol
        .dynamics
        .ok_or_else(|| anyhow::anyhow!("awfqi-adaptive-kernel runs on Puddle World only"))?;
    let config = config(experiment)?.validate()?;
    let sources = setup.source_slices();
    let rows = row_set(&setup.config, &sources)?;
    let approximator = setup.config.adaptive_q.approximator()?;
    let entries = approximator
        .required_entries(awfqi::env::PUDDLE_ACTIONS)
        .ok_or_else(|| anyhow::anyhow!("FQI approximator too large"))?;
    let budget = experiment.budget();
    let slots = config.candidates.min(rows.len());
    // Kernel averaging and trees hold every target and source record of a fit.
    let n = experiment.protocol.steps * budget + setup.posteriors().len();
    let (records, links) = match approximator {
        awfqi::Approximator::Knn(nb) | awfqi::Approximator::Hybrid(_, nb) => {
            let links = nb
                .required_links(n, awfqi::env::PUDDLE_ACTIONS)
                .ok_or_else(|| anyhow::anyhow!("kNN links overflow"))?;
            (n, links)
        }
        _ => (0, 0),
    };
    let (tree_records, nodes) = match approximator {
        awfqi::Approximator::Trees(forests) => {
            let nodes = forests
                .required_nodes(awfqi::env::PUDDLE_ACTIONS)
                .ok_or_else(|| anyhow::anyhow!("tree nodes overflow"))?;
            (n, nodes)
        }
        _ => (0, 0),
    };
    let (sweep_entries, sweep_nodes) = match approximator {
        awfqi::Approximator::Sweep(sweep) => (
            sweep
                .required_entries(awfqi::env::PUDDLE_ACTIONS)
                .ok_or_else(|| anyhow::anyhow!("sweep entries overflow"))?,
            sweep.nodes(),
        ),
        _ => (0, 0),
    };
    let mut memory = Memory::<N> {
        gp: Box::new(Gp::empty()),
        samples: vec![Transition::EMPTY; experiment.protocol.steps * budget],
        weights: vec![0.0; setup.posteriors().len()],
        candidates: vec![awfqi::adaptive::Candidate::EMPTY; slots],
        fqi: vec![FqiEntry::EMPTY; entries],
        records: vec![KnnRecord::EMPTY; records],
        links: vec![0; links],
        tree_records: vec![TreeRecord::EMPTY; tree_records],
        nodes: vec![TreeNode::EMPTY; nodes],
        sweep_entries: vec![awfqi::SweepEntry::EMPTY; sweep_entries],
        sweep_nodes: vec![awfqi::SweepNode::EMPTY; sweep_nodes],
        path: vec![[0.0; 2]; budget],
        beliefs: vec![awfqi::adaptive::SourceBelief::EMPTY; sources.len()],
    };
    let means = means_of::<N>(setup, &sources)?;
    let means: &[MeanFunction<T, N, 3>] = &means;
    let kernel = AdaptiveAwfqi::new(
        config,
        approximator,
        SourceData::new(&sources, setup.posteriors())?,
        means,
        rows,
        PuddleWorld::target(dynamics),
        memory.buffers(),
    )?;
    let mut learner = AdaptiveKernelLearner {
        kernel,
        collected: Vec::new(),
    };
    f(&mut learner, rng)
}
