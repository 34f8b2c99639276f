//! Adaptive AWFQI (not a thesis algorithm): the query distribution is recomputed
//! from what the target has answered, several times per step, and aims at what decides the
//! greedy policy, in fixed memory, for any plant with a `D`-dimensional state; the harness
//! runs it as `awfqi-adaptive` (`docs/active-budget.md`).
//!
//! Each step's budget `n` is spent in [`AdaptiveConfig::sub_batches`] sub-batches; in each:
//!
//! 1. **verification** ([`AdaptiveConfig::verify`] of the sub-batch): rollouts of the current
//!    greedy policy from [`AdaptiveConfig::start`] in the generative model (ε-greedy after
//!    the first rollout of the sub-batch), so a feature of the target no source has is met
//!    where the policy would meet it;
//! 2. **drawn queries** (the rest): [`AdaptiveConfig::candidates`] rows drawn uniformly
//!    (with replacement) from the candidate set, then drawn with probability
//!    `(1 − floor)·score/Σscore + floor·relevance/Σrelevance`, with
//!    `score = relevance × (surprise + disagreement) × uncertainty`
//!    ([`candidates`]): *surprise*, the squared mean of the residual GP (a GP on
//!    `r − m(z)`, `m(z) = Σₖ πₖ μₖ(z)` the sources' reward means weighted by their
//!    plausibility, [`plausibility`]); *disagreement*, the π-weighted variance of the
//!    sources' means; *uncertainty*, the residual GP's remaining variance as a share of its
//!    signal variance (reference noise subtraction over the batch), at most 1;
//!    *relevance*, `exp(−d²/2)` with `d` the distance to the nearest state verified in this
//!    step in units of [`AdaptiveConfig::relevance_width`] of each coordinate's range;
//! 3. **re-plan**: the target reward GP, then FQI on `D₀` and the sources (§12 steps 4–5,
//!    the core's [`crate::Awfqi`] pieces). Without [`AdaptiveConfig::relabel`] (off in
//!    [`AdaptiveConfig::recommended`]) the GP has the thesis's zero prior mean and the
//!    source records get §7.3 reward weights. With it the GP's prior mean is the target
//!    rewards' median, and every source record keeps weight 1 with its reward relabelled
//!    towards the GP's mean where the GP contradicts it ([`relabelled_reward`]). Then the
//!    residual GP for the next sub-batch, in the same GP. Before any target data the plan
//!    is FQI on the unweighted sources.
//!
//! **What it needs beyond AWFQI's set-up:** one [`MeanFunction`] per source (its reward
//! GP's posterior mean, 1 048 bytes for `f32`, `N = 64`), the candidate rows (a
//! [`RowSet`]; no score table), the start state, horizon and exploration rate of the
//! verification rollouts, and the state bounds.
//!
//! **The Q-function** is any of the core's approximators; recommended on Puddle World, the
//! model sweep ([`crate::fqi::ModelSweep`]). Every GP has a fixed capacity `N`, fitted on an
//! even spread of its data ([`crate::SubsetRule`]), and is refitted warm after its first fit
//! ([`AdaptiveConfig::refit`]); the residual GP is fitted after the weights' GP in the same
//! GP.
//!
//! **Errors part-way** are those of [`crate::Awfqi`]: records already queried stay in `D₀`,
//! the Q-function keeps its last fit, the step counter does not advance.

pub mod candidates;
pub mod fading;
pub mod mean_function;
pub mod plausibility;
pub mod safeguard;
pub mod schedule;
pub mod storage;

pub use candidates::Candidate;
pub use fading::{FadeCell, Fading};
pub use mean_function::MeanFunction;
pub use plausibility::SourceBelief;
pub use safeguard::PlanCheck;
pub use schedule::Schedule;
pub use storage::{AdaptiveBuffers, AdaptiveStorage};

use crate::awfqi::builder::{buffer, short};
use crate::awfqi::transfer::{ReplanGp, SourceValues, Transfer, for_each_source};
use crate::awfqi::{AwfqiConfig, SourceData, SourceScales, StepReport};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::{Approximator, QFunction};
use crate::gp::{Gp, Hyperparameters, SearchOptions};
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{
    Dims, GpTraining, InputDim, StatePlusAction, fit_gp_searched, input, visit_posteriors,
};
use crate::score::RowSet;
use crate::weights::{NoiseSubtraction, StdTransform, WeightSummary, WeightTally};
use rand_core::Rng;

/// Settings of adaptive AWFQI for a `D`-dimensional plant (`I = D + 1`): the AWFQI
/// settings it shares (budget, weights, GP training, subset rule, FQI; its `sampling`
/// column is unused) and its own. [`AdaptiveConfig::validate`] checks them.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdaptiveConfig<T, const D: usize, const I: usize> {
    /// The AWFQI settings: per-step budget `n`, the reward weights' estimator (`v_r` is
    /// also the plausibilities' scale), noise subtraction, subset rule, GP training, FQI.
    pub awfqi: AwfqiConfig<T, I>,
    /// Sub-batches per step (re-planning points), ≥ 1.
    pub sub_batches: usize,
    /// Share of each sub-batch spent on verification rollouts, in [0, 1].
    pub verify: T,
    /// Score by residual surprise.
    pub surprise: bool,
    /// Scale scores by the residual GP's remaining variance.
    pub uncertainty: bool,
    /// Weight rows by their closeness to this step's verified states.
    pub decision: bool,
    /// Coverage floor, in [0, 1].
    pub floor: T,
    /// Relabel instead of down-weighting: every source record keeps weight 1 and its
    /// reward `r` becomes `λ r + (1 − λ) μ`, `λ = exp(−u²/2)`, `u = (r − μ)/√(σ² + v)`,
    /// under the target reward GP's posterior `(μ, σ)` (fitted around the target rewards'
    /// median) and the estimator's `v` ([`relabelled_reward`]). `false`: the §7.3 reward
    /// weights of a zero-mean target GP, the thesis's.
    pub relabel: bool,
    /// Candidate rows scored per sub-batch (at most the number of rows are), ≥ 1.
    pub candidates: usize,
    /// Width of the relevance kernel as a share of each coordinate's range, > 0.
    pub relevance_width: T,
    /// The state every verification rollout starts in (the target's initial state).
    pub start: [T; D],
    /// Most steps of a verification rollout, ≥ 1.
    pub horizon: usize,
    /// Exploration rate of the verification rollouts after the first of a sub-batch.
    pub epsilon: T,
    /// `(lower, upper)` of every state coordinate (`lower < upper`): the relevance kernel's
    /// and the nearest-record distances' units.
    pub bounds: [(T, T); D],
    /// How the target GPs' hyperparameters are searched after their first fit of a run.
    pub refit: Refit,
    /// Spend a sub-batch's drawn queries on more verification when its plan verified short
    /// of its promise ([`safeguard`]).
    pub safeguard: bool,
}

/// How a re-plan searches the hyperparameters of the weights' reward GP and of the residual
/// GP once each has been fitted in the run: the search is most of a step's cost, and the
/// data change by a few records between two fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refit {
    /// Every fit searches from [`AwfqiConfig::gp_training`]'s initial values with its
    /// search options (the thesis's training).
    Search,
    /// Every fit after the first of its GP starts from that GP's last hyperparameters and
    /// searches with these options (the first fit of each is the thesis's).
    Warm(SearchOptions),
}

impl<T: Real, const D: usize, const I: usize> AdaptiveConfig<T, D, I> {
    /// The recommended configuration (`docs/embedded-adaptive.md`, the harness's
    /// `awfqi-adaptive`): sub-batches and verification share by the budget schedule's rule
    /// ([`Schedule::rule`]: 3 sub-batches and 70 % verification at 50 queries a step; rollouts
    /// from several start states by [`AdaptiveAwfqi::with_starts`]), surprise, uncertainty
    /// and decision relevance on, floor 0.1, 250 candidates, relevance width 0.1,
    /// relabelling off, warm refits of the GPs (30 likelihood evaluations, no restart, after
    /// each GP's first fit), on the thesis's AWFQI settings for `budget`
    /// ([`AwfqiConfig::thesis`]: Puddle World's scales; for a plant of your own,
    /// [`AdaptiveConfig::scaled`]), for a plant that starts in `start`, with episodes of
    /// `horizon` steps, exploration `epsilon` (the protocol's 0.3) and state `bounds`.
    ///
    /// With it, on Puddle World: 32-point GPs (`N = 32`) and FQI by a model sweep on 12
    /// cells per axis with pooled rewards
    /// (`ModelSweep::cube(0.0, 10.0, 12)?.with_rewards(RewardModel::Pooled)`), in 47 KB of
    /// RAM and about 10⁸ Cortex-M4F instructions per step. `RewardModel::Pooled` assumes a
    /// reward that depends on the state only; otherwise `RewardModel::Backfilled`.
    pub fn recommended(
        budget: usize,
        start: [T; D],
        horizon: usize,
        epsilon: T,
        bounds: [(T, T); D],
    ) -> Self
    where
        Dims<D, I>: StatePlusAction,
    {
        let schedule = Schedule::<T>::rule(budget, horizon, 1);
        Self {
            awfqi: AwfqiConfig::thesis(budget),
            sub_batches: schedule.sub_batches,
            verify: schedule.verify,
            surprise: true,
            uncertainty: true,
            decision: true,
            floor: T::from_f64(0.1),
            relabel: false,
            candidates: 250,
            relevance_width: T::from_f64(0.1),
            start,
            horizon,
            epsilon,
            bounds,
            refit: Refit::Warm(SearchOptions {
                max_evaluations: 30,
                restarts: 0,
                isotropic: true,
            }),
            safeguard: false,
        }
    }

    /// [`AdaptiveConfig::recommended`] on settings derived from the source data
    /// ([`AwfqiConfig::scaled`], the state bounds from [`SourceScales::bounds`]): the start
    /// for a plant of your own. Set `awfqi.fqi` to its discount.
    ///
    /// Errors: those of [`AwfqiConfig::scaled`].
    pub fn scaled(
        budget: usize,
        scales: &SourceScales<T, D>,
        start: [T; D],
        horizon: usize,
        epsilon: T,
    ) -> Result<Self>
    where
        Dims<D, I>: StatePlusAction,
    {
        Ok(Self {
            awfqi: AwfqiConfig::scaled(budget, scales)?,
            ..Self::recommended(budget, start, horizon, epsilon, scales.bounds())
        })
    }

    /// Checks every setting.
    ///
    /// Errors: those of [`AwfqiConfig::validate`]; `sub_batches`, `candidates` or `horizon`
    /// 0 ([`Error::InvalidParameter`] naming it); `verify`, `floor` or `epsilon` outside
    /// [0, 1], `relevance_width ≤ 0`, a non-finite `start` or bound, a bound with
    /// `lower ≥ upper` ([`Error::OutOfRange`] / [`Error::NonFinite`] naming it).
    pub fn validate(self) -> Result<ValidAdaptiveConfig<T, D, I>> {
        self.awfqi.validate()?;
        if let Refit::Warm(options) = self.refit {
            options.validate()?;
        }
        for (value, parameter) in [
            (self.sub_batches, "sub_batches"),
            (self.candidates, "candidates"),
            (self.horizon, "horizon"),
        ] {
            if value == 0 {
                return Err(Error::InvalidParameter { parameter });
            }
        }
        for (value, parameter) in [
            (self.verify, "verify"),
            (self.floor, "floor"),
            (self.epsilon, "epsilon"),
        ] {
            crate::error::ensure_finite(value, parameter)?;
            if !(T::ZERO..=T::ONE).contains(&value) {
                return Err(Error::OutOfRange { parameter });
            }
        }
        crate::error::ensure_finite(self.relevance_width, "relevance_width")?;
        if self.relevance_width <= T::ZERO {
            return Err(Error::OutOfRange {
                parameter: "relevance_width",
            });
        }
        crate::error::ensure_all_finite(&self.start, "start")?;
        for &(lo, hi) in &self.bounds {
            crate::error::ensure_finite(lo, "bounds")?;
            crate::error::ensure_finite(hi, "bounds")?;
            if !(lo < hi && (hi - lo).is_finite()) {
                return Err(Error::OutOfRange {
                    parameter: "bounds",
                });
            }
        }
        Ok(ValidAdaptiveConfig { config: self })
    }
}

/// An [`AdaptiveConfig`] that passed [`AdaptiveConfig::validate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidAdaptiveConfig<T, const D: usize, const I: usize> {
    config: AdaptiveConfig<T, D, I>,
}

impl<T: Copy, const D: usize, const I: usize> ValidAdaptiveConfig<T, D, I> {
    /// The checked settings (also reachable field by field through `Deref`:
    /// `valid.sub_batches`).
    pub fn config(&self) -> &AdaptiveConfig<T, D, I> {
        &self.config
    }

    /// The checked settings, by value (to change one and validate again).
    pub fn into_inner(self) -> AdaptiveConfig<T, D, I> {
        self.config
    }

    /// The AWFQI settings it shares (budget, weights, GP training, subset rule, FQI).
    pub fn awfqi(&self) -> &AwfqiConfig<T, I> {
        &self.config.awfqi
    }

    /// Queries per step.
    pub fn budget(&self) -> usize {
        self.config.awfqi.budget
    }

    /// Sub-batches per step.
    pub fn sub_batches(&self) -> usize {
        self.config.sub_batches
    }

    /// Share of each sub-batch spent on verification rollouts.
    pub fn verify(&self) -> T {
        self.config.verify
    }

    /// Candidate rows scored per sub-batch.
    pub fn candidates(&self) -> usize {
        self.config.candidates
    }

    /// The state every verification rollout starts in.
    pub fn start(&self) -> [T; D] {
        self.config.start
    }

    /// Most steps of a verification rollout.
    pub fn horizon(&self) -> usize {
        self.config.horizon
    }

    /// Exploration rate of the verification rollouts.
    pub fn epsilon(&self) -> T {
        self.config.epsilon
    }

    /// `(lower, upper)` of every state coordinate.
    pub fn bounds(&self) -> [(T, T); D] {
        self.config.bounds
    }
}

impl<T, const D: usize, const I: usize> core::ops::Deref for ValidAdaptiveConfig<T, D, I> {
    type Target = AdaptiveConfig<T, D, I>;

    fn deref(&self) -> &AdaptiveConfig<T, D, I> {
        &self.config
    }
}

/// The adaptive AWFQI learner: configuration, borrowed storage and the state of a run.
///
/// Generic like [`crate::Awfqi`]: scalar `T`, target model `G`, state dimension `D`, GP
/// input dimension `I = D + 1`, GP capacity `N` (the target GP's and the sources' mean
/// functions'); every buffer's capacity is its slice's length.
#[derive(Debug)]
pub struct AdaptiveAwfqi<'a, T, G, const D: usize, const I: usize, const N: usize> {
    config: ValidAdaptiveConfig<T, D, I>,
    rows: RowSet<'a, T, D>,
    means: &'a [MeanFunction<T, N, I>],
    beliefs: &'a mut [SourceBelief<T>],
    /// `run.gp` holds the residual GP of the last re-plan.
    residual: bool,
    /// `run.weights` holds the relabelled rewards the Q-function was last fitted on.
    relabelled: bool,
    /// The last hyperparameters of the weights' reward GP and of the residual GP in this
    /// run (the warm starts of [`Refit::Warm`]).
    last_hyper: [Option<Hyperparameters<T, I>>; 2],
    slots: &'a mut [Candidate<T>],
    /// The verification rollouts' start states ([`AdaptiveAwfqi::with_starts`]; empty:
    /// [`AdaptiveConfig::start`] alone).
    starts: &'a [[T; D]],
    /// The start of the next verification rollout, an index into `starts` (cycles over
    /// the run).
    next_start: usize,
    path: &'a mut [[T; D]],
    path_len: usize,
    /// The greedy verification rollouts of the current sub-batch.
    check: PlanCheck<T>,
    /// Source weights that fade where the target has records ([`AdaptiveAwfqi::with_fading`]).
    fading: Option<Fading<T>>,
    /// The fading's cell sums.
    fade_table: &'a mut [FadeCell<T>],
    /// The Q-function has been fitted in this run.
    planned: bool,
    /// GP fits of the current step whose optimum the conditioning policy refused.
    refused_fits: usize,
    last: Option<StepReport<T, I>>,
    /// `D₀`, the sources, the weights, the GP, the Q-function, the step count.
    run: Transfer<'a, T, G, D, I, N>,
}

impl<'a, T, G, const D: usize, const I: usize, const N: usize> AdaptiveAwfqi<'a, T, G, D, I, N>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]>,
    Dims<D, I>: StatePlusAction,
{
    /// A learner for a fresh run (`D₀` empty, Q = 0) over `buffers`: the sources with their
    /// stored reward posteriors, one mean function per source (`means`, e.g.
    /// [`MeanFunction::fit_rewards`] on each source), the candidate `rows`, the FQI
    /// `approximator` and the `target` model.
    ///
    /// Errors, checked before anything changes: a model without actions
    /// ([`Error::InvalidParameter`] `actions`), a row whose action the model lacks
    /// ([`Error::OutOfRange`] `actions`); no sources ([`Error::EmptyData`]), a mean-function
    /// count other than the source count ([`Error::InvalidParameter`] `means`); a buffer
    /// too short ([`Error::BufferTooSmall`] naming it and its const parameter): `samples`
    /// for one budget, `weights` for the source records, `candidates` for
    /// `min(candidates, rows)`, `path` for the budget, `beliefs` for the sources, `fqi`
    /// for the approximator.
    pub fn new(
        config: ValidAdaptiveConfig<T, D, I>,
        approximator: impl Into<Approximator<T, D>>,
        sources: SourceData<'a, T, D>,
        means: &'a [MeanFunction<T, N, I>],
        rows: RowSet<'a, T, D>,
        target: G,
        buffers: impl Into<AdaptiveBuffers<'a, T, D, I, N>>,
    ) -> Result<Self>
    where
        Dims<D, I>: StatePlusAction,
    {
        let () = InputDim::<D, I>::CHECK;
        let AdaptiveBuffers {
            gp,
            samples,
            weights,
            candidates,
            fqi,
            path,
            beliefs,
        } = buffers.into();
        let actions = target.num_actions();
        if actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        if rows.iter().any(|(_, a)| a >= actions) {
            return Err(Error::OutOfRange {
                parameter: "actions",
            });
        }
        let m = sources.records().len();
        if m == 0 {
            return Err(Error::EmptyData);
        }
        if means.len() != m {
            return Err(Error::InvalidParameter { parameter: "means" });
        }
        let slots = config.candidates.min(rows.len());
        let budget = config.awfqi.budget;
        short(samples.len(), budget, buffer::SAMPLES)?;
        short(weights.len(), sources.len(), buffer::WEIGHTS)?;
        short(candidates.len(), slots, buffer::CANDIDATES)?;
        short(path.len(), budget, buffer::PATH)?;
        short(beliefs.len(), m, buffer::BELIEFS)?;
        let approximator = approximator.into();
        if let Some(entries) = approximator.required_entries(actions) {
            short(fqi.entries.len(), entries, buffer::FQI)?;
        }
        let fqi = approximator.build(actions, fqi)?;
        let beliefs = beliefs
            .get_mut(..m)
            .ok_or(Error::CapacityExceeded { capacity: m })?;
        let mut learner = Self {
            config,
            rows,
            means,
            beliefs,
            residual: false,
            relabelled: false,
            last_hyper: [None; 2],
            slots: candidates,
            starts: &[],
            next_start: 0,
            path,
            path_len: 0,
            check: PlanCheck::empty(),
            fading: None,
            fade_table: &mut [],
            planned: false,
            refused_fits: 0,
            last: None,
            run: Transfer::new(target, sources, samples, weights, gp, fqi),
        };
        learner.reset();
        Ok(learner)
    }

    /// Verifies from every state of `starts` (the start states the plant declares) instead
    /// of [`AdaptiveConfig::start`] alone: the rollouts of a sub-batch start from successive
    /// states of `starts` (cycling over the run), the first from each greedy, and each runs
    /// at most [`schedule::rollout_length`] steps, so a step verifies every start state for
    /// an equal share of its verification queries.
    ///
    /// Errors: `starts` empty ([`Error::EmptyData`]) or with a non-finite coordinate
    /// ([`Error::NonFinite`] `start`); the learner is unchanged then.
    pub fn with_starts(mut self, starts: &'a [[T; D]]) -> Result<Self> {
        if starts.is_empty() {
            return Err(Error::EmptyData);
        }
        for s in starts {
            crate::error::ensure_all_finite(s, "start")?;
        }
        self.starts = starts;
        self.next_start = 0;
        Ok(self)
    }

    /// Fades the sources' reward weights where the target has records ([`fading`]): after
    /// each re-plan's reward weights, the source records of a region where the target has
    /// answered weigh at most `fading.pseudo_records` in all; `table` holds the regions'
    /// sums (`fading.cells^D × actions` entries make them exact). Without relabelling only
    /// ([`AdaptiveConfig::relabel`] keeps every weight 1).
    ///
    /// Errors: those of [`Fading::validate`]; `table` empty ([`Error::BufferTooSmall`]
    /// `fading`); the learner is unchanged then.
    pub fn with_fading(mut self, fading: Fading<T>, table: &'a mut [FadeCell<T>]) -> Result<Self> {
        let fading = fading.validate()?;
        if table.is_empty() {
            return Err(Error::BufferTooSmall {
                buffer: "fading (the regions' sums)",
                capacity: 0,
                needed: 1,
            });
        }
        self.fading = Some(fading);
        self.fade_table = table;
        Ok(self)
    }

    /// The verification rollouts' start states.
    pub fn starts(&self) -> &[[T; D]] {
        if self.starts.is_empty() {
            core::slice::from_ref(&self.config.config.start)
        } else {
            self.starts
        }
    }

    /// Starts a new run on the same set-up: empties `D₀`, resets Q, the beliefs and the
    /// step count.
    pub fn reset(&mut self) {
        self.run.reset();
        self.path_len = 0;
        self.next_start = 0;
        self.planned = false;
        self.residual = false;
        self.relabelled = false;
        self.last_hyper = [None; 2];
        self.last = None;
        plausibility::reset(self.beliefs);
    }

    /// The configuration.
    pub fn config(&self) -> &ValidAdaptiveConfig<T, D, I> {
        &self.config
    }

    /// Steps completed in this run.
    pub fn steps(&self) -> usize {
        self.run.steps
    }

    /// The target dataset `D₀` (generative-model records, in query order).
    pub fn target_samples(&self) -> &[Transition<[T; D], T>] {
        self.run.target_samples()
    }

    /// The reward weights of the last re-plan, source by source, record by record (empty
    /// with [`AdaptiveConfig::relabel`]: every weight is then 1).
    pub fn reward_weights(&self) -> &[T] {
        if self.config.relabel {
            return &[];
        }
        self.run.source_values()
    }

    /// The sources' rewards as the last re-plan relabelled them, source by source, record by
    /// record ([`AdaptiveConfig::relabel`]; empty without relabelling or before a re-plan
    /// with target data, when the records' own rewards are used).
    pub fn relabelled_rewards(&self) -> &[T] {
        if !self.relabelled {
            return &[];
        }
        self.run.source_values()
    }

    /// The sources' beliefs (plausibilities as of the last re-plan).
    pub fn beliefs(&self) -> &[SourceBelief<T>] {
        self.beliefs
    }

    /// The states verified in the current step.
    pub fn path(&self) -> &[[T; D]] {
        self.path.get(..self.path_len).unwrap_or(&[])
    }

    /// The Q-function of the last re-plan (0 before the first).
    pub fn q(&self) -> &QFunction<'a, T, D> {
        &self.run.fqi
    }

    /// The GP: the residual GP of the last re-plan (empty before target data).
    pub fn gp(&self) -> &Gp<T, N, I> {
        self.run.gp
    }

    /// The target model.
    pub fn target(&self) -> &G {
        &self.run.target
    }

    /// The sources' reward mean functions.
    pub fn means(&self) -> &'a [MeanFunction<T, N, I>] {
        self.means
    }

    /// Plans on the sources alone (the plan the first step starts from), if no plan exists
    /// yet; [`AdaptiveAwfqi::step`] does it otherwise. It depends on the set-up only, so a
    /// firmware can run it at boot and keep it out of the first step's time.
    ///
    /// Errors: those of FQI; the learner is unchanged then.
    pub fn plan<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<()> {
        if !self.planned {
            self.replan(rng)?;
        }
        Ok(())
    }

    /// Runs one step (module docs): `sub_batches` × (verification, drawn queries,
    /// re-plan). The report's GP fields describe the weights' reward GP of the last
    /// re-plan.
    ///
    /// Errors: `D₀` has no room for `n` more records ([`Error::BufferTooSmall`] naming
    /// `samples` and its `Q`; checked before anything is drawn); then the first error of a
    /// greedy action, a query, a GP fit, a prediction, a weight or FQI (module docs).
    pub fn step<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<StepReport<T, I>> {
        let n = self.config.awfqi.budget;
        self.run.ensure_room(n)?;
        self.path_len = 0;
        self.refused_fits = 0;
        self.plan(rng)?;
        let s = self.config.sub_batches;
        let mut report = None;
        for b in 0..s {
            // n·b/s without overflow: b < s, n·(b + 1) ≤ n·s fits when n·s does.
            let share = |k: usize| n.checked_mul(k).and_then(|x| x.checked_div(s)).unwrap_or(n);
            let quota = share(b + 1).saturating_sub(share(b));
            let verify = (T::from_usize(quota) * self.config.verify + T::from_f64(0.5))
                .floor()
                .to_f64() as usize;
            let verify = verify.min(quota);
            self.check = PlanCheck::empty();
            self.verify(verify, rng)?;
            let (verify, draw) = if self.config.safeguard && self.verified_short() {
                (quota - verify, 0)
            } else {
                (0, quota - verify)
            };
            self.verify(verify, rng)?;
            self.draw(draw, rng)?;
            let check = self.check;
            let mut r = self.replan(rng)?;
            r.plan_shortfall = check.shortfall();
            r.reward_std = self.reward_std();
            report = Some(r);
        }
        self.run.steps += 1;
        let mut report = report.ok_or(Error::InvalidParameter {
            parameter: "sub_batches",
        })?;
        report.step = self.run.steps;
        report.queries = n;
        self.last = Some(report);
        Ok(report)
    }

    /// The standard deviation of the target's rewards in `D₀`.
    fn reward_std(&self) -> T {
        safeguard::reward_std(self.run.target_samples().iter().map(|r| r.reward))
    }

    /// Whether the current sub-batch's plan verified short of its promise.
    fn verified_short(&self) -> bool {
        self.check.is_short(self.reward_std())
    }

    /// Appends a queried record to `D₀` and adds its clipped errors to the beliefs.
    fn record(&mut self, record: Transition<[T; D], T>) -> Result<()> {
        let mut evidence = Evidence {
            config: &self.config,
            means: self.means,
            beliefs: self.beliefs,
        };
        evidence.append(&mut self.run, record)
    }

    /// `n` queries along greedy rollouts from the start states (ε-greedy after the first
    /// rollout of the call from each start), each state kept in the path.
    fn verify<R: Rng + ?Sized>(&mut self, n: usize, rng: &mut R) -> Result<()> {
        let actions = self.run.target.num_actions();
        let m = self.starts().len();
        let length = schedule::rollout_length(
            self.config.awfqi.budget,
            self.config.verify,
            self.config.horizon,
            m,
        );
        let gamma = self.config.awfqi.fqi.discount();
        let mut left = n;
        let mut rollouts = 0usize;
        while left > 0 {
            let first = rollouts < m;
            let starts = self.starts();
            let mut state = starts
                .get(self.next_start % m.max(1))
                .copied()
                .unwrap_or(self.config.start);
            self.next_start = (self.next_start + 1) % m.max(1);
            rollouts += 1;
            // A greedy rollout of a fitted plan checks the plan's promise.
            let mut checked: Option<safeguard::Rollout<T>> = None;
            let mut absorbed = false;
            for t in 0..length {
                if left == 0 {
                    break;
                }
                let explore = !first && crate::rng::uniform::<T, R>(rng) < self.config.epsilon;
                let action = if explore {
                    crate::rng::uniform_index(rng, actions)
                } else {
                    self.run.fqi.greedy_action(state)?
                };
                if t == 0 && first && self.planned {
                    checked = Some(safeguard::Rollout::new(self.run.fqi.value(state, action)?));
                }
                let record = self.run.target.query(state, action, rng)?;
                self.record(record)?;
                if let Some(slot) = self.path.get_mut(self.path_len) {
                    *slot = state;
                    self.path_len += 1;
                }
                if let Some(c) = checked.as_mut() {
                    c.step(record.reward, gamma);
                }
                left -= 1;
                if record.absorbing {
                    absorbed = true;
                    break;
                }
                state = record.next_state;
            }
            if let Some(c) = checked {
                let v = if absorbed {
                    T::ZERO
                } else {
                    self.run.fqi.max_value(state)?
                };
                c.finish(v, &mut self.check);
            }
        }
        Ok(())
    }

    /// `n` queries drawn from a fresh candidate subset by the adaptive score.
    fn draw<R: Rng + ?Sized>(&mut self, n: usize, rng: &mut R) -> Result<()> {
        if n == 0 {
            return Ok(());
        }
        let rows = self.rows.len();
        let c = self.config.candidates.min(rows);
        let capacity = self.slots.len();
        let slots = self
            .slots
            .get_mut(..c)
            .ok_or(Error::CapacityExceeded { capacity })?;
        let path = self.path.get(..self.path_len).unwrap_or(&[]);
        let config = &self.config;
        let residual = self.residual.then_some(&*self.run.gp);
        let mut smallest = T::INFINITY;
        // Pass 1: rows and the factors that do not depend on the batch.
        for slot in slots.iter_mut() {
            let row = crate::rng::uniform_index(rng, rows);
            let (state, action) = self
                .rows
                .row(row)
                .ok_or(Error::OutOfRange { parameter: "row" })?;
            let z = input(state, action);
            let relevance = if config.decision {
                candidates::relevance(&state, path, &config.bounds, config.relevance_width)
            } else {
                T::ONE
            };
            let (_, disagreement) = spread(self.means, self.beliefs, &z)?;
            let (surprise, variance) = match residual {
                Some(gp) => {
                    let p = gp.predict(&z)?;
                    smallest = smallest.min(p.noisy_variance);
                    let s = if config.surprise {
                        p.mean.squared()
                    } else {
                        T::ZERO
                    };
                    (s, p.noisy_variance)
                }
                None => (T::ZERO, T::ZERO),
            };
            *slot = Candidate {
                row,
                relevance,
                score: surprise + disagreement,
                variance,
            };
        }
        // Pass 2: the uncertainty factor needs the batch's smallest variance.
        let totals = match residual {
            Some(gp) if config.uncertainty => {
                let hyper: &Hyperparameters<T, I> = gp.hyperparameters();
                let signal = hyper.signal_variance.max(T::MIN_POSITIVE);
                let transform =
                    StdTransform::new(NoiseSubtraction::Reference, hyper.noise_variance, smallest)?;
                let share = move |v: T| transform.apply(v).squared() / signal;
                let u = move |v: T| share(v).min(T::ONE);
                candidates::finish_scores(slots, Some(&u))
            }
            _ => candidates::finish_scores(slots, None),
        };
        // Pass 3: the queries, each drawn by a scan of the slots' probabilities (a few
        // queries per sub-batch: cheaper in memory than a table, and as fast).
        let floor = config.floor;
        let probability = |s: &Candidate<T>| candidates::probability(s, totals, floor, c);
        let total = slots.iter().map(probability).fold(T::ZERO, |a, p| a + p);
        let mut evidence = Evidence {
            config: &self.config,
            means: self.means,
            beliefs: self.beliefs,
        };
        for _ in 0..n {
            let u = crate::rng::uniform::<T, R>(rng) * total;
            let mut row = slots.last().map_or(0, |s| s.row);
            let mut sum = T::ZERO;
            for s in slots.iter() {
                sum += probability(s);
                if u < sum {
                    row = s.row;
                    break;
                }
            }
            let (state, action) = self
                .rows
                .row(row)
                .ok_or(Error::OutOfRange { parameter: "row" })?;
            let record = self.run.target.query(state, action, rng)?;
            evidence.append(&mut self.run, record)?;
        }
        Ok(())
    }

    /// Re-plans: reward GP, reward weights and weighted FQI on `D₀` and the sources (the
    /// sources unweighted before any target data), then the plausibilities and the
    /// residual GP.
    fn replan<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<StepReport<T, I>> {
        let (reward_training, residual_training) =
            (self.training(REWARD_GP), self.training(RESIDUAL_GP));
        let config = &self.config.awfqi;
        let run = &mut self.run;
        let mut wr = WeightSummary::new();
        wr.add_ones(run.len);
        let mut tally = WeightTally::new();
        if run.len == 0 {
            run.fit_q(SourceValues::Unused, None, &config.fqi, rng)?;
            wr.add_ones(run.sources.len());
            tally.sources.add_ones(run.sources.len());
            self.planned = true;
            self.residual = false;
            self.relabelled = false;
            let gp = ReplanGp::none(run.gp);
            return Ok(run.report(&wr, &tally, gp, self.refused_fits));
        }
        let target = run.samples.get(..run.len).unwrap_or(&[]);
        let relabel = self.config.relabel;
        // Relabelling reads the GP far from the target data too, so its prior mean is the
        // target rewards' median there (a zero prior would relabel towards an optimistic 0).
        let centre = if relabel { median(target) } else { T::ZERO };
        // `r − 0` is `r` exactly: without relabelling this is the thesis's zero-mean GP.
        let fit = fit_gp_searched(
            run.gp,
            target,
            |r| Ok(r.reward - centre),
            config.subset,
            &reward_training,
            rng,
        )?;
        self.refused_fits += usize::from(fit.refused);
        self.last_hyper[REWARD_GP] = Some(*run.gp.hyperparameters());
        let gp = ReplanGp::of(run.gp, fit.lml);
        self.relabelled = false;
        let values = if relabel {
            // The per-record values are the relabelled rewards; every weight is 1.
            relabel_rewards(
                run.gp,
                &run.sources,
                centre,
                config.weights.noise_variance(),
                config.noise_subtraction,
                run.weights,
            )?;
            wr.add_ones(run.sources.len());
            tally.sources.add_ones(run.sources.len());
            SourceValues::Rewards
        } else {
            run.fit_reward_weights(
                &config.weights,
                config.noise_subtraction,
                &mut wr,
                &mut tally,
                true,
            )?;
            if let Some(f) = &self.fading {
                fading::fade(
                    f,
                    run.weights,
                    run.sources.records().iter().copied(),
                    run.samples.get(..run.len).unwrap_or(&[]),
                    &self.config.bounds,
                    self.fade_table,
                )?;
            }
            SourceValues::Weights
        };
        run.fit_q(values, None, &config.fqi, rng)?;
        self.relabelled = relabel;
        self.planned = true;
        // The residual model for the next sub-batch's scores.
        self.residual = false;
        plausibility::update(self.beliefs, config.weights.noise_variance())?;
        let (means, beliefs) = (self.means, &*self.beliefs);
        let target = run.samples.get(..run.len).unwrap_or(&[]);
        let residual = fit_gp_searched(
            run.gp,
            target,
            |r| {
                let (prior, _) = spread(means, beliefs, &input(r.state, r.action))?;
                Ok(r.reward - prior)
            },
            config.subset,
            &residual_training,
            rng,
        )?;
        self.refused_fits += usize::from(residual.refused);
        self.last_hyper[RESIDUAL_GP] = Some(*run.gp.hyperparameters());
        self.residual = true;
        Ok(run.report(&wr, &tally, gp, self.refused_fits))
    }

    /// The training of GP `which` ([`REWARD_GP`], [`RESIDUAL_GP`]) by [`Refit`].
    fn training(&self, which: usize) -> GpTraining<T, I> {
        let thesis = self.config.awfqi.gp_training;
        match (
            self.config.refit,
            self.last_hyper.get(which).copied().flatten(),
        ) {
            (Refit::Warm(search), Some(initial)) => GpTraining {
                initial,
                search,
                ..thesis
            },
            _ => thesis,
        }
    }
}

/// Index of the weights' reward GP in [`AdaptiveAwfqi`]'s warm starts.
const REWARD_GP: usize = 0;
/// Index of the residual GP.
const RESIDUAL_GP: usize = 1;

/// What a query changes besides `D₀`: the sources' running errors.
struct Evidence<'k, 'a, T, const D: usize, const I: usize, const N: usize> {
    config: &'k ValidAdaptiveConfig<T, D, I>,
    means: &'a [MeanFunction<T, N, I>],
    beliefs: &'k mut [SourceBelief<T>],
}

impl<T: Real, const D: usize, const I: usize, const N: usize> Evidence<'_, '_, T, D, I, N>
where
    Dims<D, I>: StatePlusAction,
{
    /// Adds `record`'s clipped errors to the beliefs and appends it to `run`'s `D₀`.
    ///
    /// Errors: `D₀` full ([`Error::CapacityExceeded`], checked first), those of a mean
    /// function; either way nothing changes.
    fn append<G: GenerativeModel<T, State = [T; D]>>(
        &mut self,
        run: &mut Transfer<'_, T, G, D, I, N>,
        record: Transition<[T; D], T>,
    ) -> Result<()> {
        run.ensure_room(1)?;
        let z = input(record.state, record.action);
        let v = self.config.awfqi.weights.noise_variance();
        for ((belief, mean), source) in self
            .beliefs
            .iter_mut()
            .zip(self.means)
            .zip(run.sources.records())
        {
            let ends = plausibility::nearest_ends(
                source,
                &record.state,
                record.action,
                &self.config.bounds,
            );
            let e2 = plausibility::clipped_error(
                record.reward,
                mean.mean(&z)?,
                ends == record.absorbing,
                v,
            );
            belief.squared_errors += e2;
        }
        run.push(record);
        Ok(())
    }
}

/// The sources' rewards as the target sees them ([`AdaptiveConfig::relabel`]), source after
/// source into `out`: each record's posterior under `gp` (fitted on the target rewards
/// minus `centre`; one noise-subtraction batch per source, as the reward weights do), then
/// [`relabelled_reward`].
///
/// Errors: `out` shorter than the source records ([`Error::CapacityExceeded`]), those of
/// [`crate::Gp::predict`] and a non-finite result ([`Error::NonFinite`] `reward`).
fn relabel_rewards<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    sources: &SourceData<'_, T, D>,
    centre: T,
    v: T,
    noise: NoiseSubtraction,
    out: &mut [T],
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    for_each_source(sources, out, |records, _, mine| {
        if records.is_empty() {
            return Ok(());
        }
        let mut slots = mine.iter_mut();
        visit_posteriors(gp, records, noise, |r, p| {
            if let Some(slot) = slots.next() {
                let y = relabelled_reward(r.reward, centre + p.mean, p.std, v);
                crate::error::ensure_finite(y, "reward")?;
                *slot = y;
            }
            Ok(())
        })
    })
}

/// A source reward `r` as the target sees it: `λ r + (1 − λ) μ` with `λ = exp(−u²/2)` and
/// `u = (r − μ)/√(σ² + v)`, the reward's z-score under the target's posterior `(μ, σ)` and
/// the reward variance `v`. A reward the target does not contradict (`u ≈ 0`, also
/// wherever the target GP is unsure) stays; one it confidently contradicts becomes `μ`.
pub fn relabelled_reward<T: Real>(r: T, mean: T, std: T, v: T) -> T {
    let u = (r - mean) / (std * std + v).sqrt();
    let lambda = (-(u * u) / T::from_f64(2.0)).exp();
    lambda * r + (T::ONE - lambda) * mean
}

/// The median of the records' rewards (the mean of the middle two for an even count, 0 for
/// none), without a buffer: the order of `D₀` is kept, at `O(n²)` comparisons (n ≤ the
/// target buffer, a few hundred records).
fn median<T: Real, const D: usize>(records: &[Transition<[T; D], T>]) -> T {
    let n = records.len();
    if n == 0 {
        return T::ZERO;
    }
    // The k-th smallest reward (0-based), counting ties.
    let kth = |k: usize| {
        records
            .iter()
            .map(|r| r.reward)
            .find(|&x| {
                let (below, at) = records.iter().fold((0, 0), |(b, a), r| {
                    (
                        b + usize::from(r.reward < x),
                        a + usize::from(r.reward == x),
                    )
                });
                below <= k && k < below + at
            })
            .unwrap_or(T::ZERO)
    };
    if n % 2 == 1 {
        kth(n / 2)
    } else {
        (kth(n / 2 - 1) + kth(n / 2)) / T::from_f64(2.0)
    }
}

/// The plausibility-weighted mean `m(z) = Σₖ πₖ μₖ(z)` of the sources' means at `z` and
/// their weighted variance.
fn spread<T: Real, const N: usize, const I: usize>(
    means: &[MeanFunction<T, N, I>],
    beliefs: &[SourceBelief<T>],
    z: &[T; I],
) -> Result<(T, T)> {
    candidates::weighted_spread(
        means
            .iter()
            .zip(beliefs)
            .map(|(f, b)| Ok((f.mean(z)?, b.plausibility))),
    )
}

#[cfg(test)]
mod tests;

/// The embedding example of `docs/embedded-adaptive.md`, compiled and run as a doctest so
/// that the page's code stays the code that works.
#[cfg(doctest)]
#[doc = include_str!("../../docs/embedded-adaptive.md")]
struct EmbeddedAdaptiveDoc;
