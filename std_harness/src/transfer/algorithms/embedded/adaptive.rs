//! `awfqi-adaptive`: the adaptive AWFQI as the core runs it ([`awfqi::AdaptiveAwfqi`]; not
//! a thesis algorithm — the thesis's `awfqi` and `awfqi-oracle` stay as they are): the
//! query distribution is recomputed from what the target has answered, several times per
//! step, and aims at what decides the greedy policy.
//!
//! It runs on the embedded set-up ([`EmbeddedSetup`]: the `f32` source records, their
//! stored posteriors, the candidate rows of the setting and the sources' reward
//! [`MeanFunction`]s) with the FQI approximator of [`EmbeddedConfig::adaptive_q`]
//! (by default [`ADAPTIVE_Q`], chosen on the tuning runs `--seed 100`,
//! `docs/active-budget.md`) and the loop's knobs of [`AdaptiveOptions`] (by default the
//! core's recommended configuration).
//!
//! [`EmbeddedConfig::adaptive_q`]: super::EmbeddedConfig::adaptive_q
//! [`ADAPTIVE_Q`]: super::ADAPTIVE_Q

use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, AliasEntry, FqiEntry, Gp, KnnRecord,
    MeanFunction, QStorage, SourceData, Transition, TreeNode, TreeRecord,
};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::{EmbeddedSetup, GP_POINTS, Record32, T, reward_gp_summary, row_set, to_f64};
use crate::transfer::algorithms::Experiment;
use crate::transfer::protocol::{Diagnostics, Learner};
use crate::transfer::sources::Record;

/// The adaptive loop's knobs a run may set (fields of the core's [`AdaptiveConfig`]), as
/// the result files record them. The defaults are the core's recommended configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AdaptiveOptions {
    /// Sub-batches per step (re-planning points), ≥ 1.
    pub sub_batches: usize,
    /// Share of each sub-batch spent on greedy verification rollouts, in [0, 1].
    pub verify: f64,
    /// Score rows by residual surprise.
    pub surprise: bool,
    /// Scale scores by the residual GP's remaining variance.
    pub uncertainty: bool,
    /// Weight rows by their closeness to the verified greedy paths.
    pub decision: bool,
    /// Share of the drawn probability spread uniformly over the candidates, in [0, 1].
    pub floor: f64,
    /// Candidate rows scored per sub-batch.
    pub candidates: usize,
    /// Width of the relevance kernel, as a share of each state coordinate's range.
    pub relevance_width: f64,
    /// Relabel contradicted source rewards by the target GP instead of down-weighting
    /// the records.
    pub relabel: bool,
}

impl Default for AdaptiveOptions {
    /// The core's [`AdaptiveConfig::recommended`].
    fn default() -> Self {
        let c = AdaptiveConfig::<f64, 2, 3>::recommended(1, [0.0; 2], 1, 0.0, [(0.0, 1.0); 2]);
        Self {
            sub_batches: c.sub_batches,
            verify: c.verify,
            surprise: c.surprise,
            uncertainty: c.uncertainty,
            decision: c.decision,
            floor: c.floor,
            candidates: c.candidates,
            relevance_width: c.relevance_width,
            relabel: c.relabel,
        }
    }
}

/// The core's configuration for `experiment`: the recommended one with the experiment's
/// adaptive options.
fn config(experiment: &Experiment) -> AdaptiveConfig<T, 2, 3> {
    let o = experiment.adaptive_options;
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
    c.candidates = o.candidates;
    c.relevance_width = o.relevance_width as T;
    c.relabel = o.relabel;
    c
}

/// The memory one run writes, on the heap and sized at run time: what a firmware holds in
/// an [`awfqi::AdaptiveStorage`].
#[derive(Debug)]
struct Memory {
    gp: Box<Gp<T, GP_POINTS, 3>>,
    samples: Vec<Record32>,
    weights: Vec<T>,
    candidates: Vec<awfqi::adaptive::Candidate<T>>,
    alias: Vec<AliasEntry<T>>,
    fqi: Vec<FqiEntry<T>>,
    records: Vec<KnnRecord<T, 2>>,
    links: Vec<u16>,
    tree_records: Vec<TreeRecord<T, 2>>,
    nodes: Vec<TreeNode<T>>,
    path: Vec<[T; 2]>,
    beliefs: Vec<awfqi::adaptive::SourceBelief<T>>,
}

impl Memory {
    fn buffers(&mut self) -> AdaptiveBuffers<'_, T, 2, 3, GP_POINTS> {
        AdaptiveBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            candidates: &mut self.candidates,
            alias: &mut self.alias,
            fqi: QStorage {
                entries: &mut self.fqi,
                records: &mut self.records,
                links: &mut self.links,
                tree_records: &mut self.tree_records,
                nodes: &mut self.nodes,
            },
            path: &mut self.path,
            beliefs: &mut self.beliefs,
        }
    }
}

/// `awfqi-adaptive` as a [`Learner`]: each protocol step is one
/// [`AdaptiveAwfqi::step`]; the greedy action is the `f32` Q-function's, and `D₀` is kept in
/// `f64` for the result files.
struct AdaptiveLearner<'a> {
    adaptive: AdaptiveAwfqi<'a, T, PuddleWorld<T>, 2, 3, GP_POINTS>,
    collected: Vec<Record>,
}

impl Learner for AdaptiveLearner<'_> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let report = self.adaptive.step(rng)?;
        let new = &self.adaptive.target_samples()[self.collected.len()..];
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
        self.adaptive.q().greedy_action(state).unwrap_or(0)
    }

    fn target_samples(&self) -> &[Record] {
        &self.collected
    }
}

/// Hands a fresh learner for one run of `experiment` to `f` (the core's adaptive AWFQI
/// borrows its memory and the set-up for the whole run, so they live in this frame).
pub fn with_learner(
    experiment: &Experiment,
    rng: &mut ChaCha8Rng,
    f: &mut dyn FnMut(&mut dyn Learner, &mut ChaCha8Rng) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let setup: &EmbeddedSetup = experiment
        .embedded
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("no embedded set-up"))?;
    let dynamics: Dynamics = experiment
        .protocol
        .dynamics
        .ok_or_else(|| anyhow::anyhow!("awfqi-adaptive runs on Puddle World only"))?;
    let config = config(experiment).validate()?;
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
    let mut memory = Memory {
        gp: Box::new(Gp::empty()),
        samples: vec![Transition::EMPTY; experiment.protocol.steps * budget],
        weights: vec![0.0; setup.posteriors().len()],
        candidates: vec![awfqi::adaptive::Candidate::EMPTY; slots],
        alias: vec![AliasEntry::EMPTY; slots],
        fqi: vec![FqiEntry::EMPTY; entries],
        records: vec![KnnRecord::EMPTY; records],
        links: vec![0; links],
        tree_records: vec![TreeRecord::EMPTY; tree_records],
        nodes: vec![TreeNode::EMPTY; nodes],
        path: vec![[0.0; 2]; budget],
        beliefs: vec![awfqi::adaptive::SourceBelief::EMPTY; sources.len()],
    };
    let means: &[MeanFunction<T, GP_POINTS, 3>] = setup.means();
    let adaptive = AdaptiveAwfqi::new(
        config,
        approximator,
        SourceData::new(&sources, setup.posteriors())?,
        means,
        rows,
        PuddleWorld::target(dynamics),
        memory.buffers(),
    )?;
    let mut learner = AdaptiveLearner {
        adaptive,
        collected: Vec::new(),
    };
    f(&mut learner, rng)
}
