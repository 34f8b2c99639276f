//! The core's algorithms on the same protocol as the std ones, so the embedded versions are
//! measured, not guessed: `awfqi-embedded`, the thesis's AWFQI ([`awfqi::Awfqi`], in
//! [`thesis`]), and `awfqi-adaptive`, the adaptive AWFQI ([`awfqi::AdaptiveAwfqi`], in
//! [`adaptive`]).
//!
//! They run as on a microcontroller, in `f32`, with everything in fixed storage sized once
//! per run. What both share is here and built once per experiment ([`EmbeddedSetup`]): the
//! source records and their stored reward posteriors converted to `f32`, the setting's
//! score-table rows, and one `Gp<f32, 64, 3>` reward GP per source whose posterior means
//! give the realistic score table (`V_r` only) and the adaptive algorithm's source means;
//! and the FQI approximator each runs ([`EmbeddedQ`]). Budget, steps, evaluation and
//! records are the protocol's: each is a [`Learner`](crate::transfer::protocol::Learner)
//! that [`protocol::run`](crate::transfer::protocol::run) drives like every other
//! algorithm. Puddle World only, until this path is generic over the state dimension.

pub mod adaptive;
pub mod thesis;

use std::time::Instant;

use awfqi::env::{PUDDLE_ACTIONS, PuddleWorld};
use awfqi::{
    AliasEntry, Approximator, CellGrid, ExtraTrees, Gp, GpTraining, Kernel, MeanFunction,
    Neighbours, Posterior, RowSet, ScoreTable, Scores, SubsetRule, Tilings, Transition,
};
use rand_chacha::ChaCha8Rng;

use crate::transfer::gp::GpSummary;
use crate::transfer::protocol::Diagnostics;
use crate::transfer::score_tables::{GridRows, Mode};
use crate::transfer::sources::{Record, SourceSet};

/// FQI cells per axis by default (cells about one unit step wide; see
/// `tests/awfqi_puddle.rs`).
pub const CELLS: usize = 11;
/// Capacity of every GP of the embedded path.
pub const GP_POINTS: usize = 64;
/// Tiles per axis of `awfqi-embedded`'s tile coding by default, and tilings: chosen on a
/// tuning seed
/// (`--seed 1`: 3–21 tiles × 4, 8, 16 tilings) and measured on the evaluation seeds
/// (`docs/algorithms.md` §12.1).
pub const TILES: usize = 6;
/// Offset tilings of `awfqi-embedded`'s tile coding by default.
pub const TILINGS: usize = 4;

/// Trees per action of `awfqi-adaptive`'s Extra-Trees by default: chosen on the tuning runs
/// (`--seed 100`, 20 runs: 50 against 20, 10 stored and tiles; `docs/active-budget.md`).
pub const ADAPTIVE_TREES: usize = 50;
/// Nodes of the streamed trees' scratch tree by default (the FQI iterations' trees of the
/// largest action are cut at this budget; the final trees are fully grown).
pub const ADAPTIVE_TREE_NODES: usize = 1023;
/// Cells per axis of `awfqi-adaptive`'s model sweep by default (13 × 13 nodes over
/// `[0, 10]²`), chosen on the tuning runs (`docs/embedded-adaptive.md`).
pub const ADAPTIVE_SWEEP_CELLS: usize = 12;
/// `awfqi-adaptive`'s default approximator: a model sweep on [`ADAPTIVE_SWEEP_CELLS`] cells
/// per axis with one reward model for every action (Puddle World's reward depends on the
/// state only).
pub const ADAPTIVE_Q: EmbeddedQ = EmbeddedQ::Sweep(SweepKnobs {
    cells: ADAPTIVE_SWEEP_CELLS,
    rewards: awfqi::RewardModel::Pooled,
    min_mass: 0.0,
    lookahead: false,
});
/// Tiles per axis of `awfqi-adaptive`'s tile coding by default: chosen on the tuning runs
/// (`--seed 100`, 6 runs each: 6 × 4, 8 × 8, 10 × 8, 10 × 16, 12 × 8, 12 × 16, 14 × 8,
/// 16 × 8, 20 × 8; 12 × 8 best at every step but one, see `docs/active-budget.md`).
pub const ADAPTIVE_TILES: usize = 12;
/// Offset tilings of `awfqi-adaptive`'s tile coding by default.
pub const ADAPTIVE_TILINGS: usize = 8;

/// The Q-function approximator of an embedded algorithm's FQI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EmbeddedQ {
    /// A table of this many cells per axis.
    Tabular(usize),
    /// Tile coding: tiles per axis, tilings.
    Tiles(usize, usize),
    /// Kernel averaging over this many nearest records, with a Gaussian bandwidth (share of
    /// the range) or uniform weights (`None`), a reach (share of the range) or none, and
    /// one ball for every action or not; `awfqi-adaptive` only.
    Knn(usize, Option<f64>, Option<f64>, bool),
    /// The mean of tile coding (tiles per axis, tilings) and kernel averaging (as
    /// [`EmbeddedQ::Knn`]); `awfqi-adaptive` only.
    Hybrid((usize, usize), (usize, Option<f64>, Option<f64>, bool)),
    /// Per-action Extra-Trees forests; `awfqi-adaptive` only.
    Trees(TreeKnobs),
    /// Value iteration on a grid model of the records; `awfqi-adaptive` only.
    Sweep(SweepKnobs),
}

/// The knobs of [`EmbeddedQ::Sweep`].
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

/// The knobs of [`EmbeddedQ::Trees`].
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

impl EmbeddedQ {
    /// A table of `cells` per axis ([`CELLS`] unless given).
    ///
    /// Errors: zero cells.
    pub fn tabular(cells: Option<usize>) -> anyhow::Result<Self> {
        match cells.unwrap_or(CELLS) {
            0 => anyhow::bail!("the table needs at least 1 cell per axis"),
            n => Ok(Self::Tabular(n)),
        }
    }

    /// Tile coding: `tilings` offset tilings of `tiles` per axis ([`TILES`] unless given).
    ///
    /// Errors: zero tiles or tilings.
    pub fn tiles(tiles: Option<usize>, tilings: usize) -> anyhow::Result<Self> {
        match (tiles.unwrap_or(TILES), tilings) {
            (0, _) => anyhow::bail!("tile coding needs at least 1 tile per axis"),
            (_, 0) => anyhow::bail!("tile coding needs at least 1 tiling"),
            (n, k) => Ok(Self::Tiles(n, k)),
        }
    }

    /// Kernel averaging over `k` neighbours, uniform or Gaussian of bandwidth `bandwidth`
    /// (a share of the range), with a `reach` and one ball for every action or not.
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

    /// Per-action Extra-Trees forests.
    ///
    /// Errors: those of [`awfqi::ExtraTrees::new`] and
    /// [`awfqi::ExtraTrees::with_min_samples`].
    pub fn trees(knobs: TreeKnobs) -> anyhow::Result<Self> {
        let out = Self::Trees(knobs);
        out.approximator()?;
        Ok(out)
    }

    /// A model sweep.
    ///
    /// Errors: those of [`awfqi::ModelSweep::cube`] and [`awfqi::ModelSweep::with_min_mass`].
    pub fn sweep(knobs: SweepKnobs) -> anyhow::Result<Self> {
        let out = Self::Sweep(knobs);
        out.approximator()?;
        Ok(out)
    }

    /// The core's approximator over Puddle World's `[0, 10]²`.
    fn approximator(self) -> anyhow::Result<Approximator<T, 2>> {
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

/// The embedded path's scalar.
type T = f32;
/// A record in the embedded path's scalar.
type Record32 = Transition<[T; 2], T>;

fn to_f32(r: &Record) -> Record32 {
    Transition {
        state: r.state.map(|x| x as T),
        action: r.action,
        reward: r.reward as T,
        next_state: r.next_state.map(|x| x as T),
        absorbing: r.absorbing,
    }
}

fn to_f64(r: &Record32) -> Record {
    Transition {
        state: r.state.map(f64::from),
        action: r.action,
        reward: f64::from(r.reward),
        next_state: r.next_state.map(f64::from),
        absorbing: r.absorbing,
    }
}

/// Everything that configures the embedded path, in one place: options it gains (another
/// approximator, transition weights, …) belong here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmbeddedConfig {
    /// Row mode of the score table.
    pub mode: Mode,
    /// Grid spacing of the score table.
    pub spacing: f64,
    /// The FQI approximator of `awfqi-embedded`.
    pub q: EmbeddedQ,
    /// The FQI approximator of `awfqi-adaptive`.
    pub adaptive_q: EmbeddedQ,
}

impl EmbeddedConfig {
    /// The setting's score table (`mode`, `spacing`) and the default approximators: for
    /// `awfqi-embedded` tile coding with [`TILINGS`] tilings of [`TILES`] tiles per axis,
    /// for `awfqi-adaptive` [`ADAPTIVE_Q`].
    pub fn new(mode: Mode, spacing: f64) -> Self {
        Self {
            mode,
            spacing,
            q: EmbeddedQ::Tiles(TILES, TILINGS),
            adaptive_q: ADAPTIVE_Q,
        }
    }

    /// The same configuration with another FQI approximator for `awfqi-embedded`.
    pub fn with_q(self, q: EmbeddedQ) -> Self {
        Self { q, ..self }
    }

    /// The same configuration with another FQI approximator for `awfqi-adaptive`.
    pub fn with_adaptive_q(self, adaptive_q: EmbeddedQ) -> Self {
        Self { adaptive_q, ..self }
    }
}

/// What the embedded path builds once per experiment and shares by all runs (§11.2): the
/// `f32` source data with their stored posteriors, and the values of its realistic score
/// table, from source GPs of capacity `N` ([`GP_POINTS`] unless a capacity study such as
/// `examples/embedded_capacity.rs` asks for another).
#[derive(Debug, Clone)]
pub struct EmbeddedSetup<const N: usize = GP_POINTS> {
    /// The configuration.
    pub config: EmbeddedConfig,
    records: Vec<Vec<Record32>>,
    /// Stored reward posteriors of all sources, source after source.
    posteriors: Vec<Posterior<T>>,
    values: Vec<Scores<T, 2>>,
    /// Stored next-state posteriors of all sources, record after record, 2 per record
    /// (empty when the sources have none).
    transition_posteriors: Vec<Posterior<T>>,
    /// Each source's reward-GP posterior mean (the score table's GPs), for
    /// `awfqi-adaptive`.
    means: Vec<MeanFunction<T, N, 3>>,
    /// Wall time of the set-up (source GP fits and score table), seconds.
    pub setup_seconds: f64,
}

impl<const N: usize> EmbeddedSetup<N> {
    /// Converts the sources and builds the realistic score table from one
    /// `Gp<f32, N, 3>` reward GP per source (an even spread of its records, the core's
    /// published training, [`ScoreTable::realistic`]), from the stream `rng`.
    pub fn new(
        sources: &SourceSet,
        config: EmbeddedConfig,
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

    /// The fixed parameters of an algorithm of this set-up whose FQI approximator is `q`,
    /// for the result files.
    pub fn parameters(&self, q: EmbeddedQ) -> serde_json::Value {
        let mut out = serde_json::json!({
            "scalar": "f32",
            "gp_capacity": N,
            "gp_subset": "spread",
            "gp_search": "core Nelder-Mead, 10 restarts",
            "score_rows": self.values.len(),
            "score_spacing": self.config.spacing,
        });
        match q {
            EmbeddedQ::Tabular(n) => out["fqi_cells"] = serde_json::json!([n, n]),
            EmbeddedQ::Tiles(n, k) => {
                out["fqi_tiles"] = serde_json::json!([n, n]);
                out["fqi_tilings"] = k.into();
            }
            EmbeddedQ::Knn(k, h, reach, common) => {
                out["fqi_neighbours"] = k.into();
                out["fqi_bandwidth"] = h.into();
                out["fqi_reach"] = reach.into();
                if common {
                    out["fqi_common_ball"] = true.into();
                }
            }
            EmbeddedQ::Hybrid((n, t), (k, h, reach, common)) => {
                if common {
                    out["fqi_common_ball"] = true.into();
                }
                out["fqi_tiles"] = serde_json::json!([n, n]);
                out["fqi_tilings"] = t.into();
                out["fqi_neighbours"] = k.into();
                out["fqi_bandwidth"] = h.into();
                out["fqi_reach"] = reach.into();
            }
            EmbeddedQ::Trees(k) => {
                out["fqi_trees_streamed"] = k.streamed.into();
                out["fqi_trees"] = k.trees.into();
                out["fqi_tree_nodes"] = k.nodes.into();
                out["fqi_min_samples_split"] = k.min_samples_split.into();
                out["fqi_min_samples_leaf"] = k.min_samples_leaf.into();
                out["fqi_tree_max_depth"] = k.max_depth.into();
            }
            EmbeddedQ::Sweep(k) => {
                out["fqi_sweep_cells"] = k.cells.into();
                out["fqi_sweep_rewards"] = format!("{:?}", k.rewards).into();
                out["fqi_sweep_min_mass"] = k.min_mass.into();
                out["fqi_sweep_lookahead"] = k.lookahead.into();
            }
        }
        out
    }

    /// Rows of the score table (one alias entry each in `awfqi-embedded`'s memory).
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
    fn means(&self) -> &[MeanFunction<T, N, 3>] {
        &self.means
    }

    /// The source records, one slice per source (what a run borrows).
    pub fn source_slices(&self) -> Vec<&[Record32]> {
        self.records.iter().map(Vec::as_slice).collect()
    }
}

fn row_set<'a>(
    config: &EmbeddedConfig,
    slices: &'a [&'a [Record32]],
) -> anyhow::Result<RowSet<'a, T, 2>> {
    let grid = PuddleWorld::score_grid(config.spacing as T)?;
    let grid = GridRows::Points(grid, PUDDLE_ACTIONS);
    Ok(config.mode.row_set(grid, slices)?)
}

/// What both embedded learners do after a core step: print its warnings
/// ([`awfqi::StepReport::warnings`]) to stderr naming the algorithm, append the target
/// samples the step added to `collected` (in f64), and return the step's diagnostics
/// (the transition weights' only when the learner weighs transitions).
fn after_step<const I: usize>(
    algorithm: &str,
    report: &awfqi::StepReport<T, I>,
    samples: &[Record32],
    collected: &mut Vec<Record>,
    transition_weights: bool,
) -> Diagnostics {
    for warning in report.warnings() {
        eprintln!("{algorithm}, step {}: warning: {warning}", report.step);
    }
    collected.extend(samples[collected.len()..].iter().map(to_f64));
    let transitions = |x: T| transition_weights.then_some(f64::from(x));
    Diagnostics {
        n_source_samples: Some(report.n_source_samples),
        wr_mean: Some(f64::from(report.wr_mean)),
        wr_eff: Some(f64::from(report.wr_eff)),
        ws_mean: transitions(report.ws_mean),
        ws_eff: transitions(report.ws_eff),
        reward_gp: Some(reward_gp_summary(report)),
        ..Diagnostics::default()
    }
}

/// The target reward GP of an embedded step, as the result files record it.
fn reward_gp_summary<const I: usize>(report: &awfqi::StepReport<T, I>) -> GpSummary {
    let hyper = &report.gp_hyperparameters;
    GpSummary {
        points: report.gp_points,
        signal_variance: f64::from(hyper.signal_variance),
        length_scale: f64::from(hyper.length_scales[0]),
        noise_variance: f64::from(hyper.noise_variance),
        log_marginal_likelihood: f64::from(report.gp_log_likelihood),
    }
}
