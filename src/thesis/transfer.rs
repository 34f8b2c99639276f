//! What every AWFQI learner holds and does with it, once: the target model and its dataset
//! `D₀`, the sources with their stored posteriors, one value per source record (a reward
//! weight, or a relabelled reward), the target GP, the Q-function and the step count; and
//! the passes over them that the learners share — a query appended to `D₀`, the reward
//! weights, weighted FQI, a step's report. [`crate::Awfqi`] adds the score table's sampler
//! and transition weights, [`crate::AdaptiveAwfqi`] its adaptive query rule.

use super::{Records, SourceData, StepReport};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::{FqiConfig, QFunction, SampleSet};
use crate::gp::{Gp, Hyperparameters};
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{Dims, StatePlusAction, visit_posteriors};
use crate::weights::{NoiseSubtraction, Posterior, WeightParams, WeightSummary, WeightTally};
use rand_core::Rng;

/// The state of a transfer run that every learner has (module docs). Its fields are the
/// learners' to borrow apart.
#[derive(Debug)]
pub(crate) struct Transfer<'a, T, G, const D: usize, const I: usize, const N: usize> {
    /// The target's generative model.
    pub(crate) target: G,
    /// The source records with their stored reward posteriors.
    pub(crate) sources: SourceData<'a, T, D>,
    /// Room for `D₀`; the first `len` records are it.
    pub(crate) samples: &'a mut [Transition<[T; D], T>],
    pub(crate) len: usize,
    /// One value per source record: its reward weight, or its relabelled reward.
    pub(crate) weights: &'a mut [T],
    /// The target GP.
    pub(crate) gp: &'a mut Gp<T, N, I>,
    /// The Q-function of the last fit.
    pub(crate) fqi: QFunction<'a, T, D>,
    /// Steps completed in this run.
    pub(crate) steps: usize,
}

/// What the per-record values of [`Transfer::weights`] mean to a fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SourceValues {
    /// Nothing: every source record has weight 1 and its own reward.
    Unused,
    /// Reward weights.
    Weights,
    /// Rewards that replace the records' own (every weight 1).
    Rewards,
}

impl<'a, T, G, const D: usize, const I: usize, const N: usize> Transfer<'a, T, G, D, I, N>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]>,
{
    /// A fresh run (`D₀` empty, Q = 0, the GP empty) over checked parts.
    pub(crate) fn new(
        target: G,
        sources: SourceData<'a, T, D>,
        samples: &'a mut [Transition<[T; D], T>],
        weights: &'a mut [T],
        gp: &'a mut Gp<T, N, I>,
        fqi: QFunction<'a, T, D>,
    ) -> Self {
        let mut run = Self {
            target,
            sources,
            samples,
            len: 0,
            weights,
            gp,
            fqi,
            steps: 0,
        };
        run.reset();
        run
    }

    /// Empties `D₀`, resets Q to 0, the GP and the step count.
    pub(crate) fn reset(&mut self) {
        self.len = 0;
        self.steps = 0;
        self.fqi.clear();
        self.gp.clear();
    }

    /// `D₀`, in query order.
    pub(crate) fn target_samples(&self) -> &[Transition<[T; D], T>] {
        self.samples.get(..self.len).unwrap_or(&[])
    }

    /// The per-record values of the sources, source by source, record by record.
    pub(crate) fn source_values(&self) -> &[T] {
        self.weights.get(..self.sources.len()).unwrap_or(&[])
    }

    /// Checks, before a step draws anything, that `D₀` has room for `budget` more records.
    ///
    /// Errors: no room ([`Error::BufferTooSmall`] naming `samples` and its `Q`).
    pub(crate) fn ensure_room(&self, budget: usize) -> Result<()> {
        super::builder::room_for(self.len, budget, self.samples.len())
    }

    /// Appends `record` to `D₀` (nothing when it is full: [`Transfer::ensure_room`] checks
    /// first).
    pub(crate) fn push(&mut self, record: Transition<[T; D], T>) {
        if let Some(slot) = self.samples.get_mut(self.len) {
            *slot = record;
            self.len += 1;
        }
    }

    /// The reward weights of every source record under the target GP (§7.2 steps 2–3) into
    /// the per-record values, each source's also added to `summary` and `tally`.
    ///
    /// With `once`, each record is predicted once (see [`reward_weights`]).
    ///
    /// Errors: those of [`reward_weights`].
    pub(crate) fn fit_reward_weights(
        &mut self,
        params: &WeightParams<T>,
        noise: NoiseSubtraction,
        summary: &mut WeightSummary<T>,
        tally: &mut WeightTally<T>,
        once: bool,
    ) -> Result<()>
    where
        Dims<D, I>: StatePlusAction,
    {
        reward_weights(
            self.gp,
            &self.sources,
            params,
            noise,
            self.weights,
            summary,
            tally,
            once,
        )
    }

    /// Weighted FQI (§12 step 5) on `D₀` (weight 1) followed by the sources in order, with
    /// the per-record values used as `values` says and the sources' transition weights
    /// `transition` (`None`: all 1).
    ///
    /// Errors: those of [`QFunction::fit_sets`].
    pub(crate) fn fit_q<R: Rng + ?Sized>(
        &mut self,
        values: SourceValues,
        transition: Option<&[T]>,
        config: &FqiConfig<T>,
        rng: &mut R,
    ) -> Result<()> {
        let target = self.samples.get(..self.len).unwrap_or(&[]);
        let mine = self.weights.get(..self.sources.len());
        let (weights, rewards) = match values {
            SourceValues::Unused => (None, None),
            SourceValues::Weights => (mine, None),
            SourceValues::Rewards => (None, mine),
        };
        fit_weighted_fqi(
            &mut self.fqi,
            target,
            &self.sources,
            weights,
            transition,
            rewards,
            config,
            rng,
        )
    }

    /// A step's report with the reward weights' summary `wr` over all records and `tally`
    /// over the source records, the weights' GP as it was after its fit, and the GP fits
    /// whose optimum was `refused`; the transition weights are all 1 and the queries 0 (the
    /// step fills them in).
    pub(crate) fn report(
        &self,
        wr: &WeightSummary<T>,
        tally: &WeightTally<T>,
        gp: ReplanGp<T, I>,
        refused: usize,
    ) -> StepReport<T, I> {
        StepReport {
            step: self.steps,
            queries: 0,
            n_target_samples: self.len,
            n_source_samples: self.sources.len(),
            gp_points: gp.points,
            gp_log_likelihood: gp.lml,
            gp_hyperparameters: gp.hyper,
            gp_jitter: gp.jitter,
            gp_condition: gp.condition,
            gp_refused_fits: refused,
            wr_mean: wr.mean(),
            wr_eff: wr.effective_sample_size(),
            wr_source_eff: tally.sources.effective_sample_size(),
            wr_discarded: tally.discarded,
            wr_capped: tally.capped,
            ws_mean: T::ONE,
            ws_eff: wr.count(),
            ws_source_eff: T::from_usize(self.sources.len()),
            ws_discarded: 0,
            ws_capped: 0,
            plan_shortfall: T::ZERO,
            reward_std: T::ZERO,
        }
    }
}

/// The weights' reward GP of a step or re-plan as its report describes it, taken right
/// after its fit (the GP may hold another model by the end of the step).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ReplanGp<T, const I: usize> {
    pub(crate) lml: T,
    pub(crate) hyper: Hyperparameters<T, I>,
    pub(crate) points: usize,
    pub(crate) jitter: T,
    pub(crate) condition: T,
}

impl<T: Real, const I: usize> ReplanGp<T, I> {
    /// `gp` as it is now, with the log marginal likelihood its search reached.
    pub(crate) fn of<const N: usize>(gp: &Gp<T, N, I>, lml: T) -> Self {
        Self {
            lml,
            hyper: *gp.hyperparameters(),
            points: gp.len(),
            jitter: gp.jitter(),
            condition: gp.condition_estimate(),
        }
    }

    /// No fit yet: the GP's hyperparameters, no points, no jitter, condition 1.
    pub(crate) fn none<const N: usize>(gp: &Gp<T, N, I>) -> Self {
        Self {
            lml: T::ZERO,
            hyper: *gp.hyperparameters(),
            points: 0,
            jitter: T::ZERO,
            condition: T::ONE,
        }
    }
}

/// The reward weights of every source record under the target GP `gp` (§7.2 steps 2–3),
/// one noise-subtraction batch per source, into `weights` (source after source, record
/// after record), each source's weights also added to `summary` and to `tally` (with the
/// records the variance rule discarded and those at the cap).
///
/// Errors: `weights` shorter than the source records ([`Error::CapacityExceeded`] with its
/// length); those of the predictions and of [`WeightParams::weight`].
/// With `once`, each record is predicted once ([`crate::record_gp::map_posteriors`]: the
/// same weights up to rounding, at about half the cost) instead of twice (the thesis path).
#[allow(clippy::too_many_arguments)] // the run state's parts, lent one by one to share the borrow
pub(crate) fn reward_weights<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    sources: &SourceData<'_, T, D>,
    params: &WeightParams<T>,
    noise: NoiseSubtraction,
    weights: &mut [T],
    summary: &mut WeightSummary<T>,
    tally: &mut WeightTally<T>,
    once: bool,
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    for_each_source(sources, weights, |records, posteriors, mine| {
        if once {
            if !records.is_empty() {
                crate::record_gp::map_posteriors(gp, records, noise, mine, |i, r, target| {
                    let source = posteriors.get(i).copied().ok_or(Error::InvalidParameter {
                        parameter: "posteriors",
                    })?;
                    params.weight(r.reward, target, source)
                })?;
            }
        } else {
            source_weights(gp, records, posteriors, params, noise, mine)?;
        }
        summary.add(mine)?;
        let discarded = posteriors.iter().filter(|&&p| params.discards(p)).count();
        tally.add(mine, params.max_weight(), discarded)
    })
}

/// Calls `f` with each source's records, stored posteriors and its part of `out` (source
/// after source, one value per record), the split every per-record pass over the sources
/// shares.
///
/// Errors: `out` shorter than the source records ([`Error::CapacityExceeded`] with its
/// length, before the first source that does not fit); those of `f`.
pub(crate) fn for_each_source<T: Real, U, const D: usize>(
    sources: &SourceData<'_, T, D>,
    out: &mut [U],
    mut f: impl FnMut(Records<'_, T, D>, &[Posterior<T>], &mut [U]) -> Result<()>,
) -> Result<()> {
    let capacity = out.len();
    let mut rest: &mut [U] = out;
    for (records, posteriors) in sources.iter() {
        let (mine, tail) = core::mem::take(&mut rest)
            .split_at_mut_checked(records.len())
            .ok_or(Error::CapacityExceeded { capacity })?;
        rest = tail;
        f(records, posteriors, mine)?;
    }
    Ok(())
}

/// Weighted FQI (§12 step 5) on `target` (weight 1) followed by the sources in order, with
/// the sources' reward weights `weights`, transition weights `transition` and replacement
/// rewards `rewards` (source after source; `None`: all 1, their own rewards).
///
/// Errors: those of [`QFunction::fit_sets`] (e.g. a weight slice of the wrong length).
#[allow(clippy::too_many_arguments)]
fn fit_weighted_fqi<'s, T: Real, const D: usize, R: Rng + ?Sized>(
    fqi: &mut QFunction<'_, T, D>,
    target: &'s [Transition<[T; D], T>],
    sources: &'s SourceData<'_, T, D>,
    weights: Option<&'s [T]>,
    transition: Option<&'s [T]>,
    rewards: Option<&'s [T]>,
    config: &FqiConfig<T>,
    rng: &mut R,
) -> Result<()> {
    let sets = core::iter::once(SampleSet::unweighted(target)).chain(
        sources.records().iter().scan(0usize, move |offset, &s| {
            let start = *offset;
            *offset += s.len();
            let range = start..*offset;
            let part = |x: Option<&'s [T]>| x.and_then(|x| x.get(range.clone()));
            Some(
                SampleSet::weighted(s, part(weights), part(transition)).with_rewards(part(rewards)),
            )
        }),
    );
    fqi.fit_sets(sets, config, rng)
}

/// The reward weights of one source's records under the target GP (§7.2 steps 2–3).
fn source_weights<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    posteriors: &[Posterior<T>],
    params: &WeightParams<T>,
    noise: NoiseSubtraction,
    out: &mut [T],
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    if records.is_empty() {
        return Ok(());
    }
    let mut slots = out.iter_mut().zip(posteriors);
    visit_posteriors(gp, records, noise, |r, target| {
        if let Some((w, &source)) = slots.next() {
            *w = params.weight(r.reward, target, source)?;
        }
        Ok(())
    })
}
