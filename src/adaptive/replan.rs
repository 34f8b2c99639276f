//! The re-plan: the target reward GP, the sources' reward weights (or relabelled
//! rewards) and weighted FQI on `D₀` and the sources; then the plausibilities and the
//! residual GP that scores the next sub-batch.

use super::evidence::Evidence;
use super::fading::{FadeCell, Fading};
use super::{Refit, ValidAdaptiveConfig};
use crate::error::Result;
use crate::float::Real;
use crate::gp::{Gp, Hyperparameters};
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{
    Dims, GpTraining, StatePlusAction, fit_gp_searched, input, visit_posteriors,
};
use crate::thesis::SourceData;
use crate::thesis::StepReport;
use crate::thesis::transfer::{ReplanGp, SourceValues, Transfer, for_each_source};
use crate::weights::{NoiseSubtraction, WeightSummary, WeightTally};
use rand_core::Rng;

/// What the re-plans of a run leave for the next: whether a plan exists, what the GP and
/// the per-record values hold, the GPs' last hyperparameters, the step's refused fits.
#[derive(Debug, Clone, Copy)]
pub(super) struct Replan<T, const I: usize> {
    /// The Q-function has been fitted in this run.
    planned: bool,
    /// `run.gp` holds the residual GP of the last re-plan.
    residual: bool,
    /// `run.weights` holds the relabelled rewards the Q-function was last fitted on.
    relabelled: bool,
    /// The last hyperparameters of the weights' reward GP and of the residual GP in this
    /// run (the warm starts of [`Refit::Warm`]).
    last_hyper: [Option<Hyperparameters<T, I>>; 2],
    /// GP fits of the current step whose optimum the conditioning policy refused.
    refused_fits: usize,
}

/// Index of the weights' reward GP in [`Replan`]'s warm starts.
const REWARD_GP: usize = 0;
/// Index of the residual GP.
const RESIDUAL_GP: usize = 1;

impl<T: Real, const I: usize> Replan<T, I> {
    /// Nothing planned yet.
    pub(super) const fn new() -> Self {
        Self {
            planned: false,
            residual: false,
            relabelled: false,
            last_hyper: [None; 2],
            refused_fits: 0,
        }
    }

    /// A new step: no refused fit counted yet.
    pub(super) fn start_step(&mut self) {
        self.refused_fits = 0;
    }

    /// The Q-function has been fitted in this run.
    pub(super) fn planned(&self) -> bool {
        self.planned
    }

    /// The GP holds the residual GP of the last re-plan.
    pub(super) fn residual(&self) -> bool {
        self.residual
    }

    /// The per-record values hold relabelled rewards.
    pub(super) fn relabelled(&self) -> bool {
        self.relabelled
    }

    /// Re-plans: reward GP, reward weights (faded where the target has records with
    /// `fading`) and weighted FQI on `D₀` and the sources (the sources unweighted before
    /// any target data), then the plausibilities and the residual GP.
    pub(super) fn run<G, R, const D: usize, const N: usize>(
        &mut self,
        adaptive: &ValidAdaptiveConfig<T, D, I>,
        run: &mut Transfer<'_, T, G, D, I, N>,
        evidence: &mut Evidence<'_, T, N, I>,
        fading: Option<(&Fading<T>, &mut [FadeCell<T>])>,
        rng: &mut R,
    ) -> Result<StepReport<T, I>>
    where
        G: GenerativeModel<T, State = [T; D]>,
        R: Rng + ?Sized,
        Dims<D, I>: StatePlusAction,
    {
        let (reward_training, residual_training) = (
            self.training(adaptive, REWARD_GP),
            self.training(adaptive, RESIDUAL_GP),
        );
        let config = &adaptive.awfqi;
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
        let relabel = adaptive.relabel;
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
            if let Some((f, table)) = fading {
                super::fading::fade(
                    f,
                    run.weights,
                    run.sources.records().iter().copied(),
                    run.samples.get(..run.len).unwrap_or(&[]),
                    &adaptive.bounds,
                    table,
                )?;
            }
            SourceValues::Weights
        };
        run.fit_q(values, None, &config.fqi, rng)?;
        self.relabelled = relabel;
        self.planned = true;
        // The residual model for the next sub-batch's scores.
        self.residual = false;
        evidence.update(config.weights.noise_variance())?;
        let evidence = &*evidence;
        let target = run.samples.get(..run.len).unwrap_or(&[]);
        let residual = fit_gp_searched(
            run.gp,
            target,
            |r| {
                let (prior, _) = evidence.spread(&input(r.state, r.action))?;
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
    fn training<const D: usize>(
        &self,
        adaptive: &ValidAdaptiveConfig<T, D, I>,
        which: usize,
    ) -> GpTraining<T, I> {
        let thesis = adaptive.awfqi.gp_training;
        match (
            adaptive.refit,
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

/// The sources' rewards as the target sees them ([`AdaptiveConfig::relabel`]), source after
/// source into `out`: each record's posterior under `gp` (fitted on the target rewards
/// minus `centre`; one noise-subtraction batch per source, as the reward weights do), then
/// [`relabelled_reward`].
///
/// Errors: `out` shorter than the source records ([`Error::CapacityExceeded`]), those of
/// [`crate::Gp::predict`] and a non-finite result ([`Error::NonFinite`] `reward`).
pub(super) fn relabel_rewards<T: Real, const N: usize, const D: usize, const I: usize>(
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
pub(super) fn median<T: Real, const D: usize>(records: &[Transition<[T; D], T>]) -> T {
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
