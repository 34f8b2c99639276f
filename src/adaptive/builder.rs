use super::storage::{AdaptiveParts, AdaptiveStorage};
use super::{AdaptiveAwfqi, AdaptiveConfig, Evidence, Lent};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::{Approximator, CellGrid, ModelSweep, RewardModel};
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{Dims, InputDim, StatePlusAction, predict_posteriors};
use crate::score::{PointGrid, RowSet};
use crate::thesis::builder::{buffer, short};
use crate::thesis::{SourceData, SourceScales};
use crate::weights::Posterior;
use rand_core::Rng;

/// Candidate rows per sweep cell and axis of the default candidate grid.
pub const ROWS_PER_CELL: usize = 4;

/// Points per axis of the default candidate grid without a model sweep.
pub const ROWS_PER_AXIS: usize = 21;

/// Setting up the adaptive learner once: from the plant, the source records, the budget,
/// the state ranges and the start state to a learner, in a block declared by
/// [`adaptive_storage!`](crate::adaptive_storage).
///
/// The builder derives every setting it is not given: the GP and weight settings from the
/// source records ([`AdaptiveConfig::scaled`]), the candidates scored per sub-batch from
/// the block's `candidates`, the rest as [`AdaptiveConfig::recommended`]; verification rollouts as long as a step's budget;
/// FQI by a model sweep over the ranges on the block's cells; candidate rows on a grid
/// over the ranges, four per sweep cell and axis. It fits each source's reward GP once in
/// the learner's GP, keeps it as the source's mean function and as the posteriors at its
/// records, and lends the rest of the block to the learner. Every setting can be read
/// back from the learner ([`AdaptiveAwfqi::config`], [`AdaptiveAwfqi::q`],
/// [`AdaptiveAwfqi::rows`]).
///
/// The set-up of an [`AdaptiveAwfqi`], performed once by [`build`](Self::build)
/// ([`AdaptiveAwfqi::builder`]; the list above says what it derives).
#[derive(Debug)]
pub struct AdaptiveBuilder<
    'a,
    T,
    G,
    const D: usize,
    const I: usize,
    F = fn(&mut AdaptiveConfig<T, D, I>),
> {
    target: G,
    sources: &'a [&'a [Transition<[T; D], T>]],
    budget: usize,
    bounds: [(T, T); D],
    start: [T; D],
    steps: Option<usize>,
    horizon: Option<usize>,
    epsilon: T,
    thesis: bool,
    rows: Option<RowSet<'a, T, D>>,
    rewards: RewardModel,
    approximator: Option<Approximator<T, D>>,
    stored: Option<&'a [Posterior<T>]>,
    configure: F,
}

/// The entry point of the set-up. (The GP capacity is fixed later, by the storage given to
/// [`AdaptiveBuilder::build`]; this `impl` names it 0 only so that
/// `AdaptiveAwfqi::builder(…)` needs no type annotations.)
impl<'a, T, G, const D: usize, const I: usize> AdaptiveAwfqi<'a, T, G, D, I, 0>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]>,
    Dims<D, I>: StatePlusAction,
{
    /// The set-up of a learner for the plant `target` from the `sources`' records (one
    /// slice per source), `budget` queries a step, the state `bounds` (`(lower, upper)` of
    /// each coordinate) and the `start` state of the verification rollouts.
    pub fn builder(
        target: G,
        sources: &'a [&'a [Transition<[T; D], T>]],
        budget: usize,
        bounds: [(T, T); D],
        start: [T; D],
    ) -> AdaptiveBuilder<'a, T, G, D, I> {
        AdaptiveBuilder {
            target,
            sources,
            budget,
            bounds,
            start,
            steps: None,
            horizon: None,
            epsilon: T::from_f64(0.3),
            thesis: false,
            rows: None,
            rewards: RewardModel::Backfilled,
            approximator: None,
            stored: None,
            configure: |_| {},
        }
    }
}

impl<'a, T, G, F, const D: usize, const I: usize> AdaptiveBuilder<'a, T, G, D, I, F>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]>,
    F: FnOnce(&mut AdaptiveConfig<T, D, I>),
    Dims<D, I>: StatePlusAction,
{
    /// The steps the run must hold (default: the block's `steps`); [`build`](Self::build)
    /// refuses a target-sample buffer with less room than `steps × budget`.
    pub fn steps(mut self, steps: usize) -> Self {
        self.steps = Some(steps);
        self
    }

    /// Most steps of a verification rollout (default: the budget, so a rollout ends when
    /// it is absorbed or the sub-batch's verification queries are spent).
    pub fn horizon(mut self, horizon: usize) -> Self {
        self.horizon = Some(horizon);
        self
    }

    /// Exploration rate of the verification rollouts after the first of a sub-batch
    /// (default 0.3, the evaluation protocol's).
    pub fn epsilon(mut self, epsilon: T) -> Self {
        self.epsilon = epsilon;
        self
    }

    /// The thesis's GP and weight settings ([`AdaptiveConfig::recommended`], in Puddle
    /// World's units) instead of settings scaled from the source records.
    pub fn thesis_settings(mut self) -> Self {
        self.thesis = true;
        self
    }

    /// The reward model of the default model sweep (default
    /// [`RewardModel::Backfilled`]; [`RewardModel::Pooled`] when the reward depends on
    /// the state only).
    pub fn rewards(mut self, rewards: RewardModel) -> Self {
        self.rewards = rewards;
        self
    }

    /// Another Q-function than the model sweep over the bounds (its memory must be in
    /// the block: a `table_entries` block for a table or tiles).
    pub fn approximator(mut self, approximator: impl Into<Approximator<T, D>>) -> Self {
        self.approximator = Some(approximator.into());
        self
    }

    /// The sources' reward posteriors computed earlier, one per record, source after
    /// source (e.g. on the host, in flash): the builder then fits the mean functions only,
    /// and the block needs no `source_posteriors`.
    pub fn stored_posteriors(mut self, posteriors: &'a [Posterior<T>]) -> Self {
        self.stored = Some(posteriors);
        self
    }

    /// Other candidate rows than the grid over the bounds.
    pub fn rows(mut self, rows: RowSet<'a, T, D>) -> Self {
        self.rows = Some(rows);
        self
    }

    /// Changes the derived settings before they are checked (e.g. the discount:
    /// `|c| c.awfqi.fqi = FqiConfig::new(0.95, 60, EmptyCells::Zero).unwrap_or(c.awfqi.fqi)`).
    pub fn configure<F2>(self, configure: F2) -> AdaptiveBuilder<'a, T, G, D, I, F2>
    where
        F2: FnOnce(&mut AdaptiveConfig<T, D, I>),
    {
        AdaptiveBuilder {
            target: self.target,
            sources: self.sources,
            budget: self.budget,
            bounds: self.bounds,
            start: self.start,
            steps: self.steps,
            horizon: self.horizon,
            epsilon: self.epsilon,
            thesis: self.thesis,
            rows: self.rows,
            rewards: self.rewards,
            approximator: self.approximator,
            stored: self.stored,
            configure,
        }
    }

    /// Performs the set-up in `storage` and returns the learner, ready for
    /// [`AdaptiveAwfqi::plan`] and [`AdaptiveAwfqi::step`].
    ///
    /// Errors, every buffer checked before the first GP fit but the beliefs (checked
    /// after): the settings' ([`configure`](Self::configure)d, then
    /// [`AdaptiveConfig::validate`]); those of [`AdaptiveAwfqi::new`]; a target-sample
    /// buffer without room for `steps × budget` records, fewer mean functions than
    /// sources or fewer posteriors than source records ([`Error::BufferTooSmall`]); the
    /// default sweep's or grid's ([`CellGrid::new`], [`PointGrid::new`]); those of the
    /// source GP fits.
    pub fn build<S, R, const N: usize>(
        self,
        storage: &'a mut S,
        rng: &mut R,
    ) -> Result<AdaptiveAwfqi<'a, T, G, D, I, N>>
    where
        S: AdaptiveStorage<T, D, I, N>,
        R: Rng + ?Sized,
    {
        let () = InputDim::<D, I>::CHECK;
        let capacities = storage.capacities();
        let Self {
            target,
            sources: records,
            budget,
            bounds,
            start,
            steps,
            horizon,
            epsilon,
            thesis,
            rows,
            rewards,
            approximator,
            stored,
            configure,
        } = self;
        // The settings: derived, then changed by `configure`, then checked.
        let horizon = horizon.unwrap_or(budget.max(1));
        let mut config = if thesis {
            AdaptiveConfig::recommended(budget, start, horizon, epsilon, bounds)
        } else {
            let scales = SourceScales::measure(records)?;
            AdaptiveConfig {
                bounds,
                ..AdaptiveConfig::scaled(budget, &scales, start, horizon, epsilon)?
            }
        };
        config.candidates = capacities.candidates;
        configure(&mut config);
        let config = config.validate()?;
        let lower = bounds.map(|(lo, _)| lo);
        let upper = bounds.map(|(_, hi)| hi);
        let approximator = match approximator {
            Some(approximator) => approximator,
            None => {
                let cells = CellGrid::new(lower, upper, [capacities.sweep_cells; D])?;
                ModelSweep::new(cells)?.with_rewards(rewards).into()
            }
        };
        let rows = match rows {
            Some(rows) => rows,
            None => {
                let per_axis = match capacities.sweep_cells {
                    0 => ROWS_PER_AXIS - 1,
                    cells => cells.saturating_mul(ROWS_PER_CELL),
                };
                let mut spacing = [T::ONE; D];
                for (d, (lo, hi)) in spacing.iter_mut().zip(bounds) {
                    *d = (hi - lo) / T::from_usize(per_axis);
                }
                let points = [per_axis.saturating_add(1); D];
                RowSet::grid(
                    PointGrid::new(lower, spacing, points)?,
                    target.num_actions(),
                )?
            }
        };
        let AdaptiveParts {
            buffers,
            means,
            posteriors,
        } = storage.parts();
        let steps = steps.unwrap_or(capacities.steps);
        let room = steps
            .checked_mul(config.budget())
            .ok_or(Error::CapacityExceeded {
                capacity: buffers.samples.len(),
            })?;
        short(buffers.samples.len(), room, buffer::SAMPLES)?;
        let total = records.iter().map(|r| r.len()).sum::<usize>();
        short(means.len(), records.len(), buffer::MEANS)?;
        if stored.is_none() {
            short(posteriors.len(), total, buffer::POSTERIORS)?;
        }
        let mut lent = Lent::check(&config, approximator, records, &rows, &target, buffers)?;
        let capacity = means.len();
        let means = means
            .get_mut(..records.len())
            .ok_or(Error::CapacityExceeded { capacity })?;
        let capacity = posteriors.len();
        let fitted = match stored {
            Some(_) => &mut [],
            None => posteriors
                .get_mut(..total)
                .ok_or(Error::CapacityExceeded { capacity })?,
        };
        // Each source's reward GP, fitted once in the learner's GP: its mean function and
        // the posteriors at its records.
        let (training, subset) = (&config.awfqi.gp_training, config.awfqi.subset);
        let mut rest = &mut *fitted;
        for (mean, source) in means.iter_mut().zip(records) {
            mean.fit_rewards(lent.gp, source, training, subset, rng)?;
            if stored.is_none() {
                let (out, tail) = core::mem::take(&mut rest)
                    .split_at_mut_checked(source.len())
                    .ok_or(Error::CapacityExceeded { capacity: total })?;
                rest = tail;
                predict_posteriors(lent.gp, source, config.awfqi.noise_subtraction, out)?;
            }
        }
        let sources = SourceData::new(records, stored.unwrap_or(fitted))?;
        let evidence = Evidence::new(means, lent.beliefs(), records.len())?;
        Ok(lent.assemble(config, sources, rows, target, evidence))
    }
}
