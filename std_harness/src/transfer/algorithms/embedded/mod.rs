//! The core's algorithms on the same protocol as the std ones, so the embedded versions are
//! measured, not guessed: `awfqi-embedded`, the thesis's AWFQI ([`awfqi::thesis::Awfqi`], in
//! [`thesis`]), and `awfqi-adaptive`, the adaptive AWFQI ([`awfqi::adaptive::AdaptiveAwfqi`], in
//! [`adaptive`]).
//!
//! They run as on a microcontroller, in `f32`, with everything in fixed storage sized once
//! per run. What both share is here and built once per experiment ([`EmbeddedSetup`]): the
//! source records and their stored reward posteriors converted to `f32`, the setting's
//! score-table rows, and one `Gp<f32, 64, 3>` reward GP per source whose posterior means
//! give the realistic score table (`V_r` only) and the adaptive algorithm's source means;
//! and the FQI approximator each runs ([`EmbeddedQ`]). Budget, steps, evaluation and
//! records are the protocol's: each is a [`Learner`]
//! that [`protocol::run`](crate::transfer::protocol::run) drives like every other
//! algorithm. Every domain runs them: what differs between domains (the approximators'
//! box, the score table's grid, the GP and weight settings) is an [`EmbeddedDomain`], and
//! the plant with its dimensions is a type the command chooses once ([`OnPlant`]), so the
//! compiler checks that every learner gets the set-up and plant it was built for.

pub mod adaptive;
pub mod thesis;

use std::fmt::Debug;
use std::marker::PhantomData;
use std::sync::Arc;
use std::time::Instant;

use awfqi::env::{Acrobot, Dam, PUDDLE_ACTIONS, PuddleWorld, Tanks, Thermal, Zones};
use awfqi::model::GenerativeModel;
use awfqi::prelude::{
    AliasEntry, Approximator, AwfqiConfig, CellGrid, Dims, EmptyCells, ExtraTrees, FqiConfig, Gp,
    Kernel, MeanFunction, Neighbours, Posterior, RowSet, ScoreTable, Scores, SourceScales,
    StatePlusAction, SubsetRule, Tilings, Transition,
};
use rand_chacha::ChaCha8Rng;

use crate::domains::{Domain, Rows};
use crate::transfer::algorithms::Experiment;
use crate::transfer::gp::GpSummary;
use crate::transfer::protocol::{Diagnostics, Learner};
use crate::transfer::score_tables::{GridRows, Mode};
use crate::transfer::sources::SourceSet;

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
    rewards: awfqi::fqi::RewardModel::Pooled,
    min_mass: 0.0,
    lookahead: false,
    sweeps: None,
    anchors: None,
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
    pub rewards: awfqi::fqi::RewardModel,
    /// The least reward weight of a node with data.
    pub min_mass: f64,
    /// Decide by one step of lookahead.
    pub lookahead: bool,
    /// Value-iteration sweeps of its own (`None`: FQI's iterations): at a discount near 1
    /// the protocol's iterations value too short a horizon.
    pub sweeps: Option<usize>,
    /// Nodes at representative states placed from the records instead of the grid
    /// (`cells` then unused).
    pub anchors: Option<AnchorKnobs>,
}

/// The knobs of a model sweep on anchors ([`SweepKnobs::anchors`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnchorKnobs {
    /// The node budget.
    pub nodes: usize,
    /// The nodes a point is read from.
    pub neighbours: usize,
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
    /// Errors: those of [`awfqi::fqi::Neighbours::new`].
    pub fn knn(
        k: usize,
        bandwidth: Option<f64>,
        reach: Option<f64>,
        common: bool,
    ) -> anyhow::Result<Self> {
        let out = Self::Knn(k, bandwidth, reach, common);
        out.check()?;
        Ok(out)
    }

    /// Per-action Extra-Trees forests.
    ///
    /// Errors: those of [`awfqi::fqi::ExtraTrees::new`] and
    /// [`awfqi::fqi::ExtraTrees::with_min_samples`].
    pub fn trees(knobs: TreeKnobs) -> anyhow::Result<Self> {
        let out = Self::Trees(knobs);
        out.check()?;
        Ok(out)
    }

    /// A model sweep.
    ///
    /// Errors: those of [`awfqi::fqi::ModelSweep::cube`] and [`awfqi::fqi::ModelSweep::with_min_mass`].
    pub fn sweep(knobs: SweepKnobs) -> anyhow::Result<Self> {
        let out = Self::Sweep(knobs);
        out.check()?;
        Ok(out)
    }

    /// Checks the knobs (their checks do not depend on the state box).
    fn check(self) -> anyhow::Result<()> {
        self.fqi(FqiConfig::published())?;
        self.approximator(&[(0.0, 1.0); 2]).map(|_| ())
    }

    /// `fqi` with the iterations this approximator runs: a model sweep's own sweeps where
    /// it has them, `fqi`'s otherwise.
    ///
    /// Errors: zero sweeps ([`FqiConfig::new`]).
    pub fn fqi(self, fqi: FqiConfig<T>) -> anyhow::Result<FqiConfig<T>> {
        Ok(match self {
            Self::Sweep(SweepKnobs {
                sweeps: Some(n), ..
            }) => FqiConfig::new(fqi.discount(), n, fqi.empty_cells())?
                .with_min_weight(fqi.min_weight())?,
            _ => fqi,
        })
    }

    /// The core's approximator over the box `bounds` (`(lower, upper)` of every state
    /// coordinate).
    fn approximator<const D: usize>(
        self,
        bounds: &[(f64, f64); D],
    ) -> anyhow::Result<Approximator<T, D>> {
        let lower = bounds.map(|b| b.0 as T);
        let upper = bounds.map(|b| b.1 as T);
        Ok(match self {
            Self::Tabular(n) => CellGrid::new(lower, upper, [n; D])?.into(),
            Self::Tiles(n, k) => Tilings::new(lower, upper, n, k)?.into(),
            Self::Knn(k, h, reach, common) => neighbours(k, h, reach, common, bounds)?.into(),
            Self::Hybrid((n, t), (k, h, reach, common)) => Approximator::Hybrid(
                Tilings::new(lower, upper, n, t)?,
                neighbours(k, h, reach, common, bounds)?,
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
            Self::Sweep(k) => match k.anchors {
                Some(a) => awfqi::fqi::AnchorSweep::new(lower, upper, a.nodes)?
                    .with_neighbours(a.neighbours)?
                    .with_rewards(k.rewards)
                    .with_min_mass(k.min_mass as T)?
                    .with_lookahead(k.lookahead)
                    .into(),
                None => awfqi::fqi::ModelSweep::new(CellGrid::new(lower, upper, [k.cells; D])?)?
                    .with_rewards(k.rewards)
                    .with_min_mass(k.min_mass as T)?
                    .with_lookahead(k.lookahead)
                    .into(),
            },
        })
    }
}

/// The kNN geometry over the box `bounds`.
fn neighbours<const D: usize>(
    k: usize,
    h: Option<f64>,
    reach: Option<f64>,
    common: bool,
    bounds: &[(f64, f64); D],
) -> anyhow::Result<Neighbours<T, D>> {
    let kernel = h.map_or(Kernel::Uniform, |h| Kernel::Gaussian(h as T));
    let lower = bounds.map(|b| b.0 as T);
    let upper = bounds.map(|b| b.1 as T);
    let mut nb = Neighbours::new(k, lower, upper, kernel)?;
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
type Record32<const D: usize = 2> = Transition<[T; D], T>;
/// A record of the harness (`f64`).
type Record<const D: usize = 2> = crate::domains::Record<D>;

fn to_f32<const D: usize>(r: &Record<D>) -> Record32<D> {
    Transition {
        state: r.state.map(|x| x as T),
        action: r.action,
        reward: r.reward as T,
        next_state: r.next_state.map(|x| x as T),
        absorbing: r.absorbing,
    }
}

fn to_f64<const D: usize>(r: &Record32<D>) -> Record<D> {
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

/// The score table's grid rows of a domain, for a spacing.
#[derive(Debug, Clone, Copy)]
pub enum DomainGrid<const D: usize> {
    /// A core point grid for a spacing × this many actions (Puddle World's
    /// [`PuddleWorld::score_grid`]).
    Points(fn(T) -> awfqi::Result<awfqi::score::PointGrid<T, D>>, usize),
    /// The domain's `(state, action)` pairs ([`Domain::grid_rows`]), converted to `f32`.
    Pairs(fn(f64) -> anyhow::Result<Rows<D>>),
}

/// The GP, weight and FQI settings of the core's algorithms on a domain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DomainSettings {
    /// The thesis's ([`AwfqiConfig::thesis`]): Puddle World's units.
    Thesis,
    /// Derived from the source records ([`AwfqiConfig::scaled`] on
    /// [`SourceScales::measure`], what an embedder of a new plant does), with FQI at the
    /// domain's discount and the protocol's iterations.
    Scaled {
        /// FQI's discount.
        discount: f64,
        /// FQI's iterations (value-iteration sweeps of a model sweep).
        iterations: usize,
    },
}

/// What the core's algorithms need to know of a domain beyond its source data: the box
/// their approximators cover, where the adaptive kernel's verification rollouts start, the
/// score table's grid and the settings.
#[derive(Debug, Clone, Copy)]
pub struct EmbeddedDomain<const D: usize> {
    /// `(lower, upper)` of every state coordinate: the approximators' box and the adaptive
    /// kernel's bounds.
    pub bounds: [(f64, f64); D],
    /// The adaptive kernel's start: the middle one of the domain's evaluation starts.
    pub start: [f64; D],
    /// The score table's grid rows.
    pub grid: DomainGrid<D>,
    /// GP, weight and FQI settings.
    pub settings: DomainSettings,
}

impl<const D: usize> EmbeddedDomain<D> {
    /// `domain`'s box and start, its own grid rows and settings scaled from the source
    /// data, with FQI at its discount and `iterations` (the protocol's).
    pub fn scaled(domain: &Domain<D>, iterations: usize) -> Self {
        Self {
            bounds: domain.state_bounds,
            start: middle_start(domain),
            grid: DomainGrid::Pairs(domain.grid_rows),
            settings: DomainSettings::Scaled {
                discount: domain.discount,
                iterations,
            },
        }
    }
}

impl EmbeddedDomain<2> {
    /// Puddle World: `[0, 10]²`, its initial state, the core's point grid and the thesis's
    /// settings (the faithful ones).
    pub fn puddle() -> Self {
        Self {
            bounds: [(0.0, 10.0); 2],
            start: awfqi::env::PUDDLE_INITIAL_STATE,
            grid: DomainGrid::Points(PuddleWorld::score_grid, PUDDLE_ACTIONS),
            settings: DomainSettings::Thesis,
        }
    }
}

/// The middle one of `domain`'s evaluation starts (Acrobot's: hanging at rest; the others
/// evaluate from one state).
fn middle_start<const D: usize>(domain: &Domain<D>) -> [f64; D] {
    let starts = &domain.evaluation_starts;
    starts.get(starts.len() / 2).copied().unwrap_or([0.0; D])
}

/// The target plant of a domain as the core queries it, in `f32` (a `'static` type: the
/// experiment holds the set-up on its plant for every run).
pub trait Plant<const D: usize>: GenerativeModel<T, State = [T; D]> + Sized + 'static {
    /// The target of `experiment`.
    ///
    /// Errors: an experiment this plant does not run (Puddle World without its dynamics).
    fn target(experiment: &Experiment<D>) -> anyhow::Result<Self>;
}

impl Plant<2> for PuddleWorld<T> {
    fn target(experiment: &Experiment<2>) -> anyhow::Result<Self> {
        let dynamics = experiment
            .protocol
            .dynamics
            .ok_or_else(|| anyhow::anyhow!("Puddle World's plant needs its dynamics variant"))?;
        Ok(PuddleWorld::target(dynamics))
    }
}

impl Plant<2> for Dam<T> {
    fn target(_: &Experiment<2>) -> anyhow::Result<Self> {
        Ok(Dam::target())
    }
}

impl Plant<4> for Acrobot<T> {
    fn target(_: &Experiment<4>) -> anyhow::Result<Self> {
        Ok(Acrobot::target())
    }
}

impl Plant<3> for Zones<T> {
    fn target(_: &Experiment<3>) -> anyhow::Result<Self> {
        Ok(Zones::target())
    }
}

impl Plant<3> for Thermal<T> {
    fn target(_: &Experiment<3>) -> anyhow::Result<Self> {
        Ok(Thermal::target())
    }
}

impl Plant<4> for Tanks<T> {
    fn target(_: &Experiment<4>) -> anyhow::Result<Self> {
        Ok(Tanks::target())
    }
}

/// A continuation that runs the protocol on a learner (the embedded learners borrow their
/// run's memory and the set-up, so they are handed to it rather than returned).
pub type RunLearner<'f, const D: usize> =
    &'f mut dyn FnMut(&mut dyn Learner<D>, &mut ChaCha8Rng) -> anyhow::Result<()>;

/// The core's algorithms of an experiment, whatever the plant and its GP input dimension:
/// the shared set-up on its plant ([`OnPlant`]), chosen once by the command, so each learner
/// gets its set-up and plant as the types they are.
pub trait SharedSetup<const D: usize>: Debug + Send + Sync {
    /// The configuration.
    fn config(&self) -> &EmbeddedConfig;
    /// The fixed parameters of an algorithm of this set-up whose FQI approximator is `q`.
    fn parameters(&self, q: EmbeddedQ) -> serde_json::Value;
    /// How the GPs' hyperparameters are searched.
    fn gp_search(&self) -> String;
    /// Hands a fresh `awfqi-embedded` learner for one run of `experiment` to `f`.
    ///
    /// Errors: those of [`thesis::with_learner`] and of `f`.
    fn with_thesis_learner(
        &self,
        experiment: &Experiment<D>,
        rng: &mut ChaCha8Rng,
        f: RunLearner<'_, D>,
    ) -> anyhow::Result<()>;
    /// Hands a fresh `awfqi-adaptive` learner for one run of `experiment` to `f`.
    ///
    /// Errors: those of [`adaptive::with_learner`] and of `f`.
    fn with_adaptive_learner(
        &self,
        experiment: &Experiment<D>,
        rng: &mut ChaCha8Rng,
        f: RunLearner<'_, D>,
    ) -> anyhow::Result<()>;
}

/// The shared set-up ([`EmbeddedSetup`] of [`GP_POINTS`]-point source GPs, states of `D`
/// coordinates, GP inputs of `I = D + 1`) for runs on the target plant `P`.
pub struct OnPlant<P, const D: usize, const I: usize> {
    setup: EmbeddedSetup<GP_POINTS, D, I>,
    plant: PhantomData<fn() -> P>,
}

impl<P, const D: usize, const I: usize> Debug for OnPlant<P, D, I> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnPlant")
            .field("setup", &self.setup)
            .finish()
    }
}

impl<P: Plant<D>, const D: usize, const I: usize> OnPlant<P, D, I>
where
    Dims<D, I>: StatePlusAction,
{
    /// The set-up for runs on `P` ([`EmbeddedSetup::for_domain`]).
    ///
    /// Errors: those of [`EmbeddedSetup::for_domain`].
    pub fn new(
        sources: &SourceSet<D>,
        config: EmbeddedConfig,
        domain: EmbeddedDomain<D>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        Ok(Self {
            setup: EmbeddedSetup::for_domain(sources, config, domain, rng)?,
            plant: PhantomData,
        })
    }

    /// [`OnPlant::new`] as the experiment holds it: the one place a command's choice of
    /// plant and dimensions becomes a set-up.
    ///
    /// Errors: those of [`EmbeddedSetup::for_domain`].
    pub fn shared(
        sources: &SourceSet<D>,
        config: EmbeddedConfig,
        domain: EmbeddedDomain<D>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Arc<dyn SharedSetup<D>>> {
        Ok(Arc::new(Self::new(sources, config, domain, rng)?))
    }

    /// The set-up.
    pub fn setup(&self) -> &EmbeddedSetup<GP_POINTS, D, I> {
        &self.setup
    }
}

impl<P: Plant<D>, const D: usize, const I: usize> SharedSetup<D> for OnPlant<P, D, I>
where
    Dims<D, I>: StatePlusAction,
{
    fn config(&self) -> &EmbeddedConfig {
        &self.setup.config
    }

    fn parameters(&self, q: EmbeddedQ) -> serde_json::Value {
        self.setup.parameters(q)
    }

    fn gp_search(&self) -> String {
        self.setup.gp_search()
    }

    fn with_thesis_learner(
        &self,
        experiment: &Experiment<D>,
        rng: &mut ChaCha8Rng,
        f: RunLearner<'_, D>,
    ) -> anyhow::Result<()> {
        thesis::with_learner::<P, D, I>(&self.setup, experiment, rng, f)
    }

    fn with_adaptive_learner(
        &self,
        experiment: &Experiment<D>,
        rng: &mut ChaCha8Rng,
        f: RunLearner<'_, D>,
    ) -> anyhow::Result<()> {
        adaptive::with_learner::<P, D, I>(&self.setup, experiment, rng, f)
    }
}

/// What the embedded path builds once per experiment and shares by all runs (§11.2): the
/// `f32` source data with their stored posteriors, the domain's settings, and the values of
/// its realistic score table, from source GPs of capacity `N` ([`GP_POINTS`] unless a
/// capacity study such as `examples/embedded_capacity.rs` asks for another), for states of
/// `D` coordinates (GP inputs of `I = D + 1`).
#[derive(Debug, Clone)]
pub struct EmbeddedSetup<const N: usize = GP_POINTS, const D: usize = 2, const I: usize = 3> {
    /// The configuration.
    pub config: EmbeddedConfig,
    /// The domain.
    pub domain: EmbeddedDomain<D>,
    /// The AWFQI settings of every run (its budget set per experiment).
    awfqi: AwfqiConfig<T, I>,
    records: Vec<Vec<Record32<D>>>,
    /// The domain's grid pairs in `f32` (empty for a core point grid).
    pairs: Vec<([T; D], usize)>,
    /// Stored reward posteriors of all sources, source after source.
    posteriors: Vec<Posterior<T>>,
    values: Vec<Scores<T, D>>,
    /// Stored next-state posteriors of all sources, record after record, `D` per record
    /// (empty when the sources have none).
    transition_posteriors: Vec<Posterior<T>>,
    /// Each source's reward-GP posterior mean (the score table's GPs), for
    /// `awfqi-adaptive`.
    means: Vec<MeanFunction<T, N, I>>,
    /// Wall time of the set-up (source GP fits and score table), seconds.
    pub setup_seconds: f64,
}

impl<const N: usize> EmbeddedSetup<N> {
    /// Converts Puddle World's sources and builds the realistic score table
    /// ([`EmbeddedSetup::for_domain`] on [`EmbeddedDomain::puddle`]).
    pub fn new(
        sources: &SourceSet,
        config: EmbeddedConfig,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        Self::for_domain(sources, config, EmbeddedDomain::puddle(), rng)
    }
}

impl<const N: usize, const D: usize, const I: usize> EmbeddedSetup<N, D, I>
where
    Dims<D, I>: StatePlusAction,
{
    /// Converts the sources, derives the domain's settings and builds the realistic score
    /// table from one `Gp<f32, N, I>` reward GP per source (an even spread of its records,
    /// the settings' training, [`ScoreTable::realistic`]), from the stream `rng`.
    pub fn for_domain(
        sources: &SourceSet<D>,
        config: EmbeddedConfig,
        domain: EmbeddedDomain<D>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        let start = Instant::now();
        let records: Vec<Vec<Record32<D>>> = sources
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
        let slices: Vec<&[Record32<D>]> = records.iter().map(Vec::as_slice).collect();
        let awfqi = match domain.settings {
            DomainSettings::Thesis => AwfqiConfig::thesis(1),
            DomainSettings::Scaled {
                discount,
                iterations,
            } => {
                let scales = SourceScales::measure(&slices)?;
                let mut c = AwfqiConfig::scaled(1, &scales)?;
                c.fqi = FqiConfig::new(discount as T, iterations, EmptyCells::CappedNearest)?
                    .with_min_weight(FqiConfig::<T>::published().min_weight())?;
                c
            }
        };
        let pairs = match (config.mode, domain.grid) {
            (Mode::Source, _) | (_, DomainGrid::Points(..)) => Vec::new(),
            (_, DomainGrid::Pairs(grid)) => grid(config.spacing)?
                .into_iter()
                .map(|(s, a)| (s.map(|x| x as T), a))
                .collect(),
        };
        let rows = row_set(&config, &domain, &pairs, &slices)?;
        let mut values = vec![Scores::ZERO; rows.len()];
        let mut scratch = vec![AliasEntry::EMPTY; rows.len()];
        let mut gp = Box::new(Gp::<T, N, I>::empty());
        let mut means = vec![MeanFunction::EMPTY; slices.len()];
        ScoreTable::realistic(
            rows,
            &slices,
            &mut gp,
            &awfqi.gp_training,
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
            domain,
            awfqi,
            records,
            pairs,
            posteriors,
            values,
            transition_posteriors,
            means,
            setup_seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The AWFQI settings of a run with `budget` queries per step.
    pub fn awfqi_config(&self, budget: usize) -> AwfqiConfig<T, I> {
        let mut config = self.awfqi;
        config.budget = budget;
        config
    }

    /// The score table's rows over `sources` (this set-up's
    /// [`EmbeddedSetup::source_slices`]).
    ///
    /// Errors: those of [`Mode::row_set`].
    fn rows<'a>(&'a self, sources: &'a [&'a [Record32<D>]]) -> anyhow::Result<RowSet<'a, T, D>> {
        row_set(&self.config, &self.domain, &self.pairs, sources)
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
        if let DomainSettings::Scaled { .. } = self.domain.settings {
            out["gp_search"] = self.gp_search().into();
            out["settings"] = "scaled from the source records".into();
            out["var_rw"] = f64::from(self.awfqi.weights.noise_variance()).into();
            out["fqi_discount"] = f64::from(self.awfqi.fqi.discount()).into();
            out["fqi_iterations"] = self.awfqi.fqi.iterations().into();
        }
        let n = |n: usize| serde_json::Value::from(vec![n; D]);
        match q {
            EmbeddedQ::Tabular(c) => out["fqi_cells"] = n(c),
            EmbeddedQ::Tiles(c, k) => {
                out["fqi_tiles"] = n(c);
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
            EmbeddedQ::Hybrid((c, t), (k, h, reach, common)) => {
                if common {
                    out["fqi_common_ball"] = true.into();
                }
                out["fqi_tiles"] = n(c);
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
                if let Some(n) = k.sweeps {
                    out["fqi_sweep_iterations"] = n.into();
                }
            }
        }
        out
    }

    /// How the GPs' hyperparameters are searched, for the result files.
    pub fn gp_search(&self) -> String {
        let search = &self.awfqi.gp_training.search;
        match self.domain.settings {
            DomainSettings::Thesis => "core Nelder-Mead, 10 restarts".into(),
            DomainSettings::Scaled { .. } => format!(
                "core Nelder-Mead, {} restarts, {} evaluations",
                search.restarts, search.max_evaluations
            ),
        }
    }

    /// Rows of the score table (one alias entry each in `awfqi-embedded`'s memory).
    pub fn score_rows(&self) -> usize {
        self.values.len()
    }

    /// The realistic score table's values, one per row (what the builder's
    /// `stored_scores` reads; a firmware keeps them in flash).
    pub fn score_values(&self) -> &[Scores<T, D>] {
        &self.values
    }

    /// The stored reward posteriors of all source records, source after source.
    pub fn posteriors(&self) -> &[Posterior<T>] {
        &self.posteriors
    }

    /// Each source's reward mean function.
    fn means(&self) -> &[MeanFunction<T, N, I>] {
        &self.means
    }

    /// The source records, one slice per source (what a run borrows).
    pub fn source_slices(&self) -> Vec<&[Record32<D>]> {
        self.records.iter().map(Vec::as_slice).collect()
    }
}

fn row_set<'a, const D: usize>(
    config: &EmbeddedConfig,
    domain: &EmbeddedDomain<D>,
    pairs: &'a [([T; D], usize)],
    slices: &'a [&'a [Record32<D>]],
) -> anyhow::Result<RowSet<'a, T, D>> {
    let grid = match domain.grid {
        DomainGrid::Points(grid, actions) => GridRows::Points(grid(config.spacing as T)?, actions),
        DomainGrid::Pairs(_) => GridRows::Pairs(pairs),
    };
    Ok(config.mode.row_set(grid, slices)?)
}

/// What both embedded learners do after a core step: print its warnings
/// ([`awfqi::thesis::StepReport::warnings`]) to stderr naming the algorithm, append the target
/// samples the step added to `collected` (in f64), and return the step's diagnostics
/// (the transition weights' only when the learner weighs transitions).
fn after_step<const D: usize, const I: usize>(
    algorithm: &str,
    report: &awfqi::thesis::StepReport<T, I>,
    samples: &[Record32<D>],
    collected: &mut Vec<Record<D>>,
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
        plan_shortfall: (report.reward_std > 0.0)
            .then(|| f64::from(report.plan_shortfall / report.reward_std)),
        warnings: Some(report.warnings().map(|w| w.to_string()).collect()),
        ..Diagnostics::default()
    }
}

/// The target reward GP of an embedded step, as the result files record it.
fn reward_gp_summary<const I: usize>(report: &awfqi::thesis::StepReport<T, I>) -> GpSummary {
    let hyper = &report.gp_hyperparameters;
    GpSummary {
        points: report.gp_points,
        signal_variance: f64::from(hyper.signal_variance),
        length_scale: f64::from(hyper.length_scales[0]),
        noise_variance: f64::from(hyper.noise_variance),
        log_marginal_likelihood: f64::from(report.gp_log_likelihood),
    }
}

#[cfg(test)]
mod tests;
