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
//!    the core's [`crate::thesis::Awfqi`] pieces). Without [`AdaptiveConfig::relabel`] (off in
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
//! even spread of its data ([`crate::record_gp::SubsetRule`]), and is refitted warm after its first fit
//! ([`AdaptiveConfig::refit`]); the residual GP is fitted after the weights' GP in the same
//! GP.
//!
//! **Errors part-way** are those of [`crate::thesis::Awfqi`]: records already queried stay in `D₀`,
//! the Q-function keeps its last fit, the step counter does not advance.

mod builder;
pub mod candidates;
mod draw;
mod evidence;
pub mod fading;
mod mean_function;
pub mod plausibility;
mod replan;
pub mod safeguard;
pub mod schedule;
mod storage;
mod verify;

pub use builder::{AdaptiveBuilder, ROWS_PER_AXIS, ROWS_PER_CELL};
pub use fading::{FadeCell, Fading};
pub use mean_function::MeanFunction;
pub use replan::relabelled_reward;
pub use safeguard::PlanCheck;
pub use schedule::Schedule;
pub use storage::{AdaptiveBuffers, AdaptiveCapacities, AdaptiveParts, AdaptiveStorage};

use draw::Draw;
use evidence::Evidence;
use plausibility::SourceBelief;
use replan::Replan;
use verify::Verification;

use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::{Approximator, QFunction};
use crate::gp::{Gp, SearchOptions};
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{Dims, InputDim, StatePlusAction};
use crate::score::RowSet;
use crate::thesis::builder::{buffer, short};
use crate::thesis::transfer::Transfer;
use crate::thesis::{AwfqiConfig, SourceData, SourceScales, StepReport};
use rand_core::Rng;
#[cfg(test)]
use replan::median;

/// Settings of adaptive AWFQI for a `D`-dimensional plant (`I = D + 1`): the AWFQI
/// settings it shares (budget, weights, GP training, subset rule, FQI; its `sampling`
/// column is unused) and its own. [`AdaptiveConfig::validate`] checks them.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
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
    /// ([`Schedule::rule`]: 3 sub-batches and 70 % verification at 50 queries a step;
    /// rollouts from several start states with [`AdaptiveAwfqi::with_starts`]), surprise,
    /// uncertainty
    /// and decision relevance on, floor 0.1, 250 candidates, relevance width 0.1,
    /// relabelling off, warm refits of the GPs (30 likelihood evaluations, no restart, after
    /// each GP's first fit), on the thesis's AWFQI settings for `budget`
    /// ([`AwfqiConfig::thesis`]: Puddle World's scales; for a plant of your own,
    /// [`AdaptiveConfig::scaled`]), for a plant that starts in `start`, with episodes of
    /// `horizon` steps, exploration `epsilon` (the protocol's 0.3) and state `bounds`.
    ///
    /// With it, on Puddle World: 32-point GPs (`N = 32`) and FQI by a model sweep on 12
    /// cells per axis with pooled rewards
    /// (`ModelSweep::cube(0.0, 10.0, 12)?.with_rewards(RewardModel::Pooled)`): RAM and
    /// instructions per step measured in `docs/embedded-adaptive.md` (footprint image
    /// `adaptive_puddle`: 40 036 B; `m4_adaptive`: 1.054·10⁸ instructions for the largest
    /// step). `RewardModel::Pooled` assumes a
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
/// Generic like [`crate::thesis::Awfqi`]: scalar `T`, target model `G`, state dimension `D`, GP
/// input dimension `I = D + 1`, GP capacity `N` (the target GP's and the sources' mean
/// functions'); every buffer's capacity is its slice's length. Each phase of a sub-batch
/// keeps its own state in its own module: the verified path (`verify`), the candidate
/// slots (`draw`), what the re-plans leave for the next (`replan`); the sources' beliefs
/// are the evidence every query updates (`evidence`).
#[derive(Debug)]
pub struct AdaptiveAwfqi<'a, T, G, const D: usize, const I: usize, const N: usize> {
    config: ValidAdaptiveConfig<T, D, I>,
    rows: RowSet<'a, T, D>,
    evidence: Evidence<'a, T, N, I>,
    verification: Verification<'a, T, D>,
    draw: Draw<'a, T>,
    replan: Replan<T, I>,
    /// Source weights that fade where the target has records ([`AdaptiveAwfqi::with_fading`])
    /// and the regions' sums.
    fading: Option<(Fading<T>, &'a mut [FadeCell<T>])>,
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
        let records = sources.records();
        let mut lent = Lent::check(
            &config,
            approximator.into(),
            records,
            &rows,
            &target,
            buffers.into(),
        )?;
        let evidence = Evidence::new(means, lent.beliefs(), records.len())?;
        Ok(lent.assemble(config, sources, rows, target, evidence))
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
        self.verification.set_starts(starts)?;
        Ok(self)
    }

    /// The verification rollouts' start states.
    pub fn starts(&self) -> &[[T; D]] {
        self.verification.starts(&self.config.config.start)
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
        self.fading = Some((fading, table));
        Ok(self)
    }

    /// Starts a new run on the same set-up: empties `D₀`, resets Q, the beliefs and the
    /// step count.
    pub fn reset(&mut self) {
        self.run.reset();
        self.verification.reset();
        self.replan = Replan::new();
        self.evidence.reset();
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
        if !self.replan.relabelled() {
            return &[];
        }
        self.run.source_values()
    }

    /// The sources' beliefs (plausibilities as of the last re-plan).
    pub fn beliefs(&self) -> &[SourceBelief<T>] {
        self.evidence.beliefs()
    }

    /// The states verified in the current step.
    pub fn path(&self) -> &[[T; D]] {
        self.verification.states()
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
        self.evidence.means()
    }

    /// The candidate rows the drawn queries come from.
    pub fn rows(&self) -> &RowSet<'a, T, D> {
        &self.rows
    }

    /// The source records and their stored reward posteriors.
    pub fn sources(&self) -> &SourceData<'a, T, D> {
        &self.run.sources
    }

    /// Plans on the sources alone (the plan the first step starts from), if no plan exists
    /// yet; [`AdaptiveAwfqi::step`] does it otherwise. It depends on the set-up only, so a
    /// firmware can run it at boot and keep it out of the first step's time.
    ///
    /// Errors: those of FQI; the learner is unchanged then.
    pub fn plan<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<()> {
        if !self.replan.planned() {
            let fading = self.fading.as_mut().map(|(f, t)| (&*f, &mut **t));
            self.replan
                .run(&self.config, &mut self.run, &mut self.evidence, fading, rng)?;
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
        self.verification.clear();
        self.replan.start_step();
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
            let (config, run, evidence) = (&self.config, &mut self.run, &mut self.evidence);
            self.verification.start_check();
            let planned = self.replan.planned();
            self.verification
                .run(verify, planned, config, run, evidence, rng)?;
            // The safeguard: a plan that verified short of its promise gets the sub-batch's
            // drawn queries as more verification.
            let short = config.safeguard && self.verification.check().is_short(reward_std(run));
            let (more, drawn) = if short {
                (quota - verify, 0)
            } else {
                (0, quota - verify)
            };
            self.verification
                .run(more, planned, config, run, evidence, rng)?;
            self.draw.run(
                drawn,
                config,
                &self.rows,
                self.verification.states(),
                self.replan.residual(),
                run,
                evidence,
                rng,
            )?;
            let check = *self.verification.check();
            let fading = self.fading.as_mut().map(|(f, t)| (&*f, &mut **t));
            let mut r = self.replan.run(config, run, evidence, fading, rng)?;
            r.plan_shortfall = check.shortfall();
            r.reward_std = reward_std(run);
            report = Some(r);
        }
        self.run.steps += 1;
        let mut report = report.ok_or(Error::InvalidParameter {
            parameter: "sub_batches",
        })?;
        report.step = self.run.steps;
        report.queries = n;
        Ok(report)
    }
}

/// The standard deviation of the target's rewards in `run`'s `D₀`.
fn reward_std<
    T: Real,
    G: GenerativeModel<T, State = [T; D]>,
    const D: usize,
    const I: usize,
    const N: usize,
>(
    run: &Transfer<'_, T, G, D, I, N>,
) -> T {
    safeguard::reward_std(run.target_samples().iter().map(|r| r.reward))
}

/// The learner's buffers, checked against the set-up before anything is fitted: each
/// phase's own buffer already in its phase.
struct Lent<'a, T, const D: usize, const I: usize, const N: usize> {
    gp: &'a mut Gp<T, N, I>,
    samples: &'a mut [Transition<[T; D], T>],
    weights: &'a mut [T],
    beliefs: Option<&'a mut [SourceBelief<T>]>,
    fqi: QFunction<'a, T, D>,
    verification: Verification<'a, T, D>,
    draw: Draw<'a, T>,
}

impl<'a, T: Real, const D: usize, const I: usize, const N: usize> Lent<'a, T, D, I, N>
where
    Dims<D, I>: StatePlusAction,
{
    /// The errors of [`AdaptiveAwfqi::new`] but the mean functions' (checked by the
    /// evidence), in its order.
    fn check<G: GenerativeModel<T, State = [T; D]>>(
        config: &ValidAdaptiveConfig<T, D, I>,
        approximator: Approximator<T, D>,
        records: &[&[Transition<[T; D], T>]],
        rows: &RowSet<'_, T, D>,
        target: &G,
        buffers: AdaptiveBuffers<'a, T, D, I, N>,
    ) -> Result<Self> {
        let AdaptiveBuffers {
            gp,
            samples,
            weights,
            candidates,
            fqi,
            path,
            beliefs,
        } = buffers;
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
        if records.is_empty() {
            return Err(Error::EmptyData);
        }
        let total = records
            .iter()
            .try_fold(0usize, |n, r| n.checked_add(r.len()))
            .ok_or(Error::CapacityExceeded {
                capacity: usize::MAX,
            })?;
        let budget = config.awfqi.budget;
        short(samples.len(), budget, buffer::SAMPLES)?;
        short(weights.len(), total, buffer::WEIGHTS)?;
        let draw = Draw::new(candidates, config.candidates.min(rows.len()))?;
        let verification = Verification::new(path, budget)?;
        if let Some(entries) = approximator.required_entries(actions) {
            short(fqi.entries.len(), entries, buffer::FQI)?;
        }
        let fqi = approximator.build(actions, fqi)?;
        Ok(Self {
            gp,
            samples,
            weights,
            beliefs: Some(beliefs),
            fqi,
            verification,
            draw,
        })
    }

    /// The beliefs buffer, for the evidence (once).
    fn beliefs(&mut self) -> &'a mut [SourceBelief<T>] {
        self.beliefs.take().unwrap_or(&mut [])
    }

    /// The learner for a fresh run.
    fn assemble<G: GenerativeModel<T, State = [T; D]>>(
        self,
        config: ValidAdaptiveConfig<T, D, I>,
        sources: SourceData<'a, T, D>,
        rows: RowSet<'a, T, D>,
        target: G,
        evidence: Evidence<'a, T, N, I>,
    ) -> AdaptiveAwfqi<'a, T, G, D, I, N> {
        let mut learner = AdaptiveAwfqi {
            config,
            rows,
            evidence,
            verification: self.verification,
            draw: self.draw,
            replan: Replan::new(),
            fading: None,
            run: Transfer::new(
                target,
                sources,
                self.samples,
                self.weights,
                self.gp,
                self.fqi,
            ),
        };
        learner.reset();
        learner
    }
}

#[cfg(test)]
mod tests;

/// The embedding example of `docs/embedded-adaptive.md`, compiled and run as a doctest so
/// that the page's code stays the code that works.
#[cfg(doctest)]
#[doc = include_str!("../../docs/embedded-adaptive.md")]
struct EmbeddedAdaptiveDoc;
