//! `awfqi-kernel`: the core's embedded AWFQI path ([`awfqi::Awfqi`]) on the same
//! protocol as the std algorithms, so the cost of the embedded path is measured, not guessed.
//!
//! The kernel runs as it would on a microcontroller, in `f32`, with everything in fixed
//! storage: a target reward GP of capacity [`GP_POINTS`] fitted on an even spread of `D₀`
//! (the core's [`SubsetRule::Spread`]) with the core's bounded Nelder–Mead search,
//! weighted FQI by tile coding ([`TILINGS`] offset tilings of [`TILES`] × [`TILES`] tiles;
//! `--kernel-q tabular` for the [`CELLS`] × [`CELLS`] table) instead of Extra-Trees,
//! transition weights on request (`--transition-weights true`), and a score table
//! with the setting's rows whose values come from one fixed-capacity reward GP per source
//! (realistic table, `V_r` only). The source records and their stored reward posteriors are
//! the experiment's source data, converted to `f32`. Budget, steps, evaluation and records
//! are the protocol's: the kernel is a [`Learner`] that
//! [`protocol::run`](crate::transfer::protocol::run) drives like every other algorithm.

use std::time::Instant;

use awfqi::env::{Dynamics, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::{
    AliasEntry, Approximator, Awfqi, AwfqiBuffers, AwfqiConfig, CellGrid, Estimator, ExtraTrees,
    FqiEntry, Gp, GpTraining, Kernel, MeanFunction, Neighbours, Posterior, RowSet, ScoreTable,
    Scores, SubsetRule, Tilings, Transition, WeightParams,
};
use rand_chacha::ChaCha8Rng;

use super::Experiment;
use crate::transfer::gp::GpSummary;
use crate::transfer::protocol::{Diagnostics, Learner};
use crate::transfer::score_tables::{GridRows, Mode};
use crate::transfer::sources::{Record, SourceSet};

/// FQI cells per axis by default (cells about one unit step wide; see
/// `tests/awfqi_puddle.rs`).
pub const CELLS: usize = 11;
/// Capacity of every kernel GP.
pub const GP_POINTS: usize = 64;
/// Tiles per axis of `--kernel-q tiles` by default, and tilings: chosen on a tuning seed
/// (`--seed 1`: 3–21 tiles × 4, 8, 16 tilings) and measured on the evaluation seeds
/// (`docs/algorithms.md` §12.1).
pub const TILES: usize = 6;
/// Offset tilings of `--kernel-q tiles` by default.
pub const TILINGS: usize = 4;

/// The Q-function approximator of the kernel's FQI (`--kernel-q`, `--kernel-resolution`,
/// `--kernel-tilings`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KernelQFunction {
    /// A table of this many cells per axis.
    Tabular(usize),
    /// Tile coding: tiles per axis, tilings.
    Tiles(usize, usize),
    /// Kernel averaging over this many nearest records, with a Gaussian bandwidth (share of
    /// the range) or uniform weights (`None`), a reach (share of the range) or none, and
    /// one ball for every action or not; `awfqi-adaptive-kernel` only.
    Knn(usize, Option<f64>, Option<f64>, bool),
    /// The mean of tile coding (tiles per axis, tilings) and kernel averaging (as
    /// [`KernelQFunction::Knn`]); `awfqi-adaptive-kernel` only.
    Hybrid((usize, usize), (usize, Option<f64>, Option<f64>, bool)),
    /// Per-action Extra-Trees forests; `awfqi-adaptive-kernel` only.
    Trees(TreeKnobs),
    /// Value iteration on a grid model of the records; `awfqi-adaptive-kernel` only.
    Sweep(SweepKnobs),
}

/// The knobs of [`KernelQFunction::Sweep`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepKnobs {
    /// Cells per axis (nodes at their corners).
    pub cells: usize,
    /// Which records a node's reward averages.
    pub rewards: awfqi::RewardModel,
    /// The least reward weight of a node with data.
    pub min_mass: f64,
    /// Decide by one step of lookahead.
    pub lookahead: bool,
}

/// The knobs of [`KernelQFunction::Trees`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TreeKnobs {
    /// Trees per action.
    pub trees: usize,
    /// Node budget of a tree (of the scratch tree when streamed).
    pub nodes: usize,
    /// `min_samples_split`.
    pub min_samples_split: usize,
    /// `min_samples_leaf`.
    pub min_samples_leaf: usize,
    /// Depth limit (`None`: none).
    pub max_depth: Option<usize>,
    /// Streamed (one scratch tree; the final trees grown along each query's path) or stored.
    pub streamed: bool,
}

impl KernelQFunction {
    /// The approximator the options name.
    ///
    /// Errors: a zero resolution or tiling count.
    pub fn from_args(
        q: crate::commands::transfer::KernelQ,
        resolution: Option<usize>,
        tilings: usize,
    ) -> anyhow::Result<Self> {
        use crate::commands::transfer::KernelQ;
        let out = match q {
            KernelQ::Tabular => Self::Tabular(resolution.unwrap_or(CELLS)),
            KernelQ::Tiles => Self::Tiles(resolution.unwrap_or(TILES), tilings),
        };
        match out {
            Self::Tabular(0) | Self::Tiles(0, _) => {
                anyhow::bail!("--kernel-resolution must be at least 1")
            }
            Self::Tiles(_, 0) => anyhow::bail!("--kernel-tilings must be at least 1"),
            _ => Ok(out),
        }
    }

    /// Kernel averaging over `k` neighbours (`--kernel-neighbours`, `--kernel-bandwidth`).
    ///
    /// Errors: those of [`awfqi::Neighbours::new`].
    pub fn knn(
        k: usize,
        bandwidth: Option<f64>,
        reach: Option<f64>,
        common: bool,
    ) -> anyhow::Result<Self> {
        let out = Self::Knn(k, bandwidth, reach, common);
        out.approximator()?;
        Ok(out)
    }

    /// Per-action Extra-Trees forests (`--kernel-trees`, `--kernel-tree-nodes`,
    /// `--kernel-min-samples-split`, `--kernel-min-samples-leaf`, `--kernel-tree-max-depth`,
    /// `--kernel-tree-streamed`).
    ///
    /// Errors: those of [`awfqi::ExtraTrees::new`] and
    /// [`awfqi::ExtraTrees::with_min_samples`].
    pub fn trees(knobs: TreeKnobs) -> anyhow::Result<Self> {
        let out = Self::Trees(knobs);
        out.approximator()?;
        Ok(out)
    }

    /// A model sweep (`--kernel-sweep-*`).
    ///
    /// Errors: those of [`awfqi::ModelSweep::cube`] and [`awfqi::ModelSweep::with_min_mass`].
    pub fn sweep(knobs: SweepKnobs) -> anyhow::Result<Self> {
        let out = Self::Sweep(knobs);
        out.approximator()?;
        Ok(out)
    }

    /// The core's approximator over Puddle World's `[0, 10]²`.
    pub(super) fn approximator(self) -> anyhow::Result<Approximator<T, 2>> {
        Ok(match self {
            Self::Tabular(n) => CellGrid::cube(0.0, 10.0, n)?.into(),
            Self::Tiles(n, k) => Tilings::cube(0.0, 10.0, n, k)?.into(),
            Self::Knn(k, h, reach, common) => neighbours(k, h, reach, common)?.into(),
            Self::Hybrid((n, t), (k, h, reach, common)) => Approximator::Hybrid(
                Tilings::cube(0.0, 10.0, n, t)?,
                neighbours(k, h, reach, common)?,
            ),
            Self::Trees(k) => {
                let forests = if k.streamed {
                    ExtraTrees::streamed(k.trees, k.nodes)?
                } else {
                    ExtraTrees::new(k.trees, k.nodes)?
                };
                let forests = forests.with_min_samples(k.min_samples_split, k.min_samples_leaf)?;
                k.max_depth
                    .map_or(forests, |d| forests.with_max_depth(d))
                    .into()
            }
            Self::Sweep(k) => awfqi::ModelSweep::cube(0.0, 10.0, k.cells)?
                .with_rewards(k.rewards)
                .with_min_mass(k.min_mass as T)?
                .with_lookahead(k.lookahead)
                .into(),
        })
    }
}

/// The kNN geometry over Puddle World's `[0, 10]²`.
fn neighbours(
    k: usize,
    h: Option<f64>,
    reach: Option<f64>,
    common: bool,
) -> anyhow::Result<Neighbours<T, 2>> {
    let kernel = h.map_or(Kernel::Uniform, |h| Kernel::Gaussian(h as T));
    let mut nb = Neighbours::cube(k, 0.0, 10.0, kernel)?;
    if let Some(r) = reach {
        nb = nb.with_reach(r as T)?;
    }
    if common {
        nb = nb.with_common_ball();
    }
    Ok(nb)
}

/// The kernels' scalar.
pub(super) type T = f32;
/// A record in the kernels' scalar.
pub(super) type Record32 = Transition<[T; 2], T>;

fn to_f32(r: &Record) -> Record32 {
    Transition {
        state: r.state.map(|x| x as T),
        action: r.action,
        reward: r.reward as T,
        next_state: r.next_state.map(|x| x as T),
        absorbing: r.absorbing,
    }
}

pub(super) fn to_f64(r: &Record32) -> Record {
    Transition {
        state: r.state.map(f64::from),
        action: r.action,
        reward: f64::from(r.reward),
        next_state: r.next_state.map(f64::from),
        absorbing: r.absorbing,
    }
}

/// Everything that configures the kernel path, in one place: options the kernel gains
/// (another approximator, transition weights, …) belong here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelConfig {
    /// Row mode of the score table.
    pub mode: Mode,
    /// Grid spacing of the score table.
    pub spacing: f64,
    /// The FQI approximator.
    pub q: KernelQFunction,
    /// The FQI approximator of `awfqi-adaptive-kernel`.
    pub adaptive_q: KernelQFunction,
}

impl KernelConfig {
    /// The kernel with the setting's score table (`mode`, `spacing`) and the default
    /// approximators: for `awfqi-kernel` tile coding with [`TILINGS`] tilings of [`TILES`]
    /// tiles per axis, for `awfqi-adaptive-kernel` streamed Extra-Trees
    /// ([`super::adaptive_kernel::ADAPTIVE_Q`]).
    pub fn new(mode: Mode, spacing: f64) -> Self {
        Self {
            mode,
            spacing,
            q: KernelQFunction::Tiles(TILES, TILINGS),
            adaptive_q: super::adaptive_kernel::ADAPTIVE_Q,
        }
    }

    /// The same configuration with another FQI approximator (for `awfqi-kernel`).
    pub fn with_q(self, q: KernelQFunction) -> Self {
        Self { q, ..self }
    }

    /// The same configuration with another FQI approximator for `awfqi-adaptive-kernel`.
    pub fn with_adaptive_q(self, adaptive_q: KernelQFunction) -> Self {
        Self { adaptive_q, ..self }
    }
}

/// What the kernel path builds once per experiment and shares by all runs (§11.2): the
/// `f32` source data with their stored posteriors, and the values of its realistic score
/// table, from source GPs of capacity `N` (the kernel's GP capacity; [`GP_POINTS`] unless a
/// capacity study such as `examples/kernel_capacity.rs` asks for another).
#[derive(Debug, Clone)]
pub struct KernelSetup<const N: usize = GP_POINTS> {
    /// The kernel's configuration.
    pub config: KernelConfig,
    records: Vec<Vec<Record32>>,
    /// Stored reward posteriors of all sources, source after source.
    posteriors: Vec<Posterior<T>>,
    values: Vec<Scores<T, 2>>,
    /// Stored next-state posteriors of all sources, record after record, 2 per record
    /// (empty when the sources have none).
    transition_posteriors: Vec<Posterior<T>>,
    /// Each source's reward-GP posterior mean (the score table's GPs), for
    /// `awfqi-adaptive-kernel`.
    means: Vec<MeanFunction<T, N, 3>>,
    /// Wall time of the set-up (source GP fits and score table), seconds.
    pub setup_seconds: f64,
}

impl<const N: usize> KernelSetup<N> {
    /// Converts the sources and builds the realistic score table from one
    /// `Gp<f32, N, 3>` reward GP per source (an even spread of its records, the core's
    /// published training, [`ScoreTable::realistic`]), from the stream `rng`.
    pub fn new(
        sources: &SourceSet,
        config: KernelConfig,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        let start = Instant::now();
        let records: Vec<Vec<Record32>> = sources
            .sources
            .iter()
            .map(|s| s.records.iter().map(to_f32).collect())
            .collect();
        let posteriors = sources
            .sources
            .iter()
            .flat_map(|s| &s.reward)
            .map(|p| Posterior::new(p.mean as T, p.std as T))
            .collect();
        let slices: Vec<&[Record32]> = records.iter().map(Vec::as_slice).collect();
        let rows = row_set(&config, &slices)?;
        let mut values = vec![Scores::ZERO; rows.len()];
        let mut scratch = vec![AliasEntry::EMPTY; rows.len()];
        let mut gp = Box::new(Gp::<T, N, 3>::empty());
        let mut means = vec![MeanFunction::EMPTY; slices.len()];
        ScoreTable::realistic(
            rows,
            &slices,
            &mut gp,
            &GpTraining::published(),
            SubsetRule::Spread,
            &mut values,
            &mut scratch,
            rng,
            |j, gp| match means.get_mut(j) {
                Some(m) => m.copy_from(gp),
                None => Ok(()),
            },
        )?;
        let transition_posteriors = sources
            .sources
            .iter()
            .flat_map(|s| {
                (0..s.records.len()).flat_map(move |i| {
                    s.next_state
                        .iter()
                        .filter_map(move |dim| dim.get(i))
                        .map(|p| Posterior::new(p.mean as T, p.std as T))
                })
            })
            .collect();
        Ok(Self {
            config,
            records,
            posteriors,
            values,
            transition_posteriors,
            means,
            setup_seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The kernel's fixed parameters for the result files.
    pub fn parameters(&self) -> serde_json::Value {
        self.parameters_with(self.config.q)
    }

    /// The fixed parameters with the FQI approximator `q` (`awfqi-adaptive-kernel`'s).
    pub fn parameters_with(&self, q: KernelQFunction) -> serde_json::Value {
        let mut out = serde_json::json!({
            "scalar": "f32",
            "gp_capacity": N,
            "gp_subset": "spread",
            "gp_search": "core Nelder-Mead, 10 restarts",
            "score_rows": self.values.len(),
            "score_spacing": self.config.spacing,
        });
        match q {
            KernelQFunction::Tabular(n) => out["fqi_cells"] = serde_json::json!([n, n]),
            KernelQFunction::Tiles(n, k) => {
                out["fqi_tiles"] = serde_json::json!([n, n]);
                out["fqi_tilings"] = k.into();
            }
            KernelQFunction::Knn(k, h, reach, common) => {
                out["fqi_neighbours"] = k.into();
                out["fqi_bandwidth"] = h.into();
                out["fqi_reach"] = reach.into();
                if common {
                    out["fqi_common_ball"] = true.into();
                }
            }
            KernelQFunction::Hybrid((n, t), (k, h, reach, common)) => {
                if common {
                    out["fqi_common_ball"] = true.into();
                }
                out["fqi_tiles"] = serde_json::json!([n, n]);
                out["fqi_tilings"] = t.into();
                out["fqi_neighbours"] = k.into();
                out["fqi_bandwidth"] = h.into();
                out["fqi_reach"] = reach.into();
            }
            KernelQFunction::Trees(k) => {
                out["fqi_trees_streamed"] = k.streamed.into();
                out["fqi_trees"] = k.trees.into();
                out["fqi_tree_nodes"] = k.nodes.into();
                out["fqi_min_samples_split"] = k.min_samples_split.into();
                out["fqi_min_samples_leaf"] = k.min_samples_leaf.into();
                out["fqi_tree_max_depth"] = k.max_depth.into();
            }
            KernelQFunction::Sweep(k) => {
                out["fqi_sweep_cells"] = k.cells.into();
                out["fqi_sweep_rewards"] = format!("{:?}", k.rewards).into();
                out["fqi_sweep_min_mass"] = k.min_mass.into();
                out["fqi_sweep_lookahead"] = k.lookahead.into();
            }
        }
        out
    }

    /// Rows of the score table (one alias entry each in a kernel's memory).
    pub fn score_rows(&self) -> usize {
        self.values.len()
    }

    /// The realistic score table's values, one per row (what the builder's
    /// `stored_scores` reads; a firmware keeps them in flash).
    pub fn score_values(&self) -> &[Scores<T, 2>] {
        &self.values
    }

    /// The stored reward posteriors of all source records, source after source.
    pub fn posteriors(&self) -> &[Posterior<T>] {
        &self.posteriors
    }

    /// Each source's reward mean function.
    pub(super) fn means(&self) -> &[MeanFunction<T, N, 3>] {
        &self.means
    }

    /// The source records, one slice per source (what the kernel borrows).
    pub fn source_slices(&self) -> Vec<&[Record32]> {
        self.records.iter().map(Vec::as_slice).collect()
    }
}

pub(super) fn row_set<'a>(
    config: &KernelConfig,
    slices: &'a [&'a [Record32]],
) -> anyhow::Result<RowSet<'a, T, 2>> {
    let grid = PuddleWorld::score_grid(config.spacing as T)?;
    let grid = GridRows::Points(grid, PUDDLE_ACTIONS);
    Ok(config.mode.row_set(grid, slices)?)
}

/// The memory one run of the kernel writes, on the heap and sized at run time: what a
/// firmware holds in an [`awfqi::AwfqiStorage`].
#[derive(Debug)]
pub struct KernelMemory<const N: usize = GP_POINTS> {
    gp: Box<Gp<T, N, 3>>,
    samples: Vec<Record32>,
    weights: Vec<T>,
    alias: Vec<AliasEntry<T>>,
    fqi: Vec<FqiEntry<T>>,
    transition_weights: Vec<T>,
}

impl<const N: usize> KernelMemory<N> {
    /// Room for `steps × budget` target samples, one weight per stored posterior, one alias
    /// entry per score row, the FQI entries of `setup`'s approximator and, with
    /// `transition_weights`, one transition weight per source record.
    ///
    /// Errors: an approximator too large for memory.
    pub fn new(
        setup: &KernelSetup<N>,
        steps: usize,
        budget: usize,
        transition_weights: bool,
    ) -> anyhow::Result<Self> {
        let entries = setup
            .config
            .q
            .approximator()?
            .required_entries(PUDDLE_ACTIONS)
            .ok_or_else(|| anyhow::anyhow!("FQI approximator too large"))?;
        let records = setup.posteriors.len();
        Ok(Self {
            gp: Box::new(Gp::<T, N, 3>::empty()),
            samples: vec![Transition::EMPTY; steps * budget],
            weights: vec![0.0; records],
            alias: vec![AliasEntry::EMPTY; setup.values.len()],
            fqi: vec![FqiEntry::EMPTY; entries],
            transition_weights: vec![0.0; if transition_weights { records } else { 0 }],
        })
    }

    /// The kernel's buffers and the transition-weight buffer.
    fn buffers(&mut self) -> (AwfqiBuffers<'_, T, 2, 3, N>, &mut [T]) {
        (
            AwfqiBuffers {
                gp: &mut self.gp,
                samples: &mut self.samples,
                weights: &mut self.weights,
                alias: &mut self.alias,
                fqi: &mut self.fqi,
            },
            &mut self.transition_weights,
        )
    }
}

/// `awfqi-kernel` as a [`Learner`]: each protocol step is one [`Awfqi::step`] (score →
/// draw → query → weights → weighted FQI); the greedy action is the `f32` table's, and `D₀`
/// is kept in `f64` for the result files.
pub struct KernelLearner<'a, const N: usize = GP_POINTS> {
    kernel: Awfqi<'a, T, PuddleWorld<T>, 2, 3, N>,
    collected: Vec<Record>,
}

impl<'a, const N: usize> KernelLearner<'a, N> {
    /// The builder's set-up from the shared source data and score values (`sources` are
    /// `setup`'s [`KernelSetup::source_slices`]) over `memory`, with a per-step budget, on
    /// the Puddle World target of `dynamics`, from the stream `rng`; with `transition` (the
    /// estimator variance `v_s`), transition weights on every coordinate.
    pub fn new(
        setup: &'a KernelSetup<N>,
        sources: &'a [&'a [Record32]],
        memory: &'a mut KernelMemory<N>,
        budget: usize,
        dynamics: Dynamics,
        transition: Option<f64>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        let (buffers, transition_weights) = memory.buffers();
        let mut builder = Awfqi::builder(
            AwfqiConfig::thesis(budget).validate()?,
            setup.config.q.approximator()?,
            sources,
            row_set(&setup.config, sources)?,
        )
        .stored_posteriors(&setup.posteriors)
        .stored_scores(&setup.values);
        if let Some(v_s) = transition {
            if setup.transition_posteriors.len() != 2 * setup.posteriors.len() {
                anyhow::bail!("transition weights need the sources' stored next-state posteriors");
            }
            builder = builder.transition_weights(
                WeightParams::new(Estimator::Mean, v_s as T, 1000.0)?,
                &setup.transition_posteriors,
                transition_weights,
            );
        }
        let kernel = builder.build(PuddleWorld::target(dynamics), buffers, rng)?;
        Ok(Self {
            kernel,
            collected: Vec::new(),
        })
    }
}

impl<const N: usize> Learner for KernelLearner<'_, N> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let report = self.kernel.step(rng)?;
        print_warnings("awfqi-kernel", &report);
        let new = &self.kernel.target_samples()[self.collected.len()..];
        self.collected.extend(new.iter().map(to_f64));
        Ok(Diagnostics {
            n_source_samples: Some(report.n_source_samples),
            wr_mean: Some(f64::from(report.wr_mean)),
            wr_eff: Some(f64::from(report.wr_eff)),
            ws_mean: Some(f64::from(report.ws_mean)),
            ws_eff: Some(f64::from(report.ws_eff)),
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

/// Prints a kernel step's warnings ([`awfqi::StepReport::warnings`]) to stderr, one line
/// each, naming the algorithm and the step (shared by the embedded learners).
pub(super) fn print_warnings<const I: usize>(algorithm: &str, report: &awfqi::StepReport<T, I>) {
    for warning in report.warnings() {
        eprintln!("{algorithm}, step {}: warning: {warning}", report.step);
    }
}

/// The target reward GP of a kernel step, as the result files record it (shared by the
/// embedded learners, `awfqi-kernel` and `awfqi-adaptive-kernel`).
pub(super) fn reward_gp_summary<const I: usize>(report: &awfqi::StepReport<T, I>) -> GpSummary {
    let hyper = &report.gp_hyperparameters;
    GpSummary {
        points: report.gp_points,
        signal_variance: f64::from(hyper.signal_variance),
        length_scale: f64::from(hyper.length_scales[0]),
        noise_variance: f64::from(hyper.noise_variance),
        log_marginal_likelihood: f64::from(report.gp_log_likelihood),
    }
}

/// Hands a fresh kernel learner for one run of `experiment` to `f`: the kernel borrows its
/// memory and the source data for the whole run, so they live in this frame while
/// [`protocol::run`](crate::transfer::protocol::run) drives the learner inside `f`.
pub fn with_learner(
    experiment: &Experiment,
    rng: &mut ChaCha8Rng,
    f: &mut dyn FnMut(&mut dyn Learner, &mut ChaCha8Rng) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let setup = experiment
        .kernel
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("no kernel set-up"))?;
    let dynamics = experiment
        .protocol
        .dynamics
        .ok_or_else(|| anyhow::anyhow!("awfqi-kernel runs on Puddle World only"))?;
    let budget = experiment.budget();
    let sources = setup.source_slices();
    // Transition weights only on request (`--transition-weights true`), on every
    // coordinate, with the estimator variance v_s of the experiment: the active algorithms
    // run without them (§12), and on this small-GP path they were measured to hurt under
    // puddle-based dynamics (§12.1).
    let transition = if experiment.options.transition_weights == Some(true) {
        Some(experiment.variances()?.1)
    } else {
        None
    };
    let mut memory = KernelMemory::new(
        setup,
        experiment.protocol.steps,
        budget,
        transition.is_some(),
    )?;
    let mut learner = KernelLearner::new(
        setup,
        &sources,
        &mut memory,
        budget,
        dynamics,
        transition,
        rng,
    )?;
    f(&mut learner, rng)
}
