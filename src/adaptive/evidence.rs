//! What the target's answers say about the sources: each source's reward mean function and
//! its belief, updated by every queried record and read by the scores and the residual GP.

use super::mean_function::MeanFunction;
use super::plausibility::{self, SourceBelief};
use super::{ValidAdaptiveConfig, candidates};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{Dims, StatePlusAction, input};
use crate::thesis::builder::{buffer, short};
use crate::thesis::transfer::Transfer;

/// The sources' mean functions and beliefs (one each per source).
#[derive(Debug)]
pub(super) struct Evidence<'a, T, const N: usize, const I: usize> {
    means: &'a [MeanFunction<T, N, I>],
    beliefs: &'a mut [SourceBelief<T>],
}

impl<'a, T: Real, const N: usize, const I: usize> Evidence<'a, T, N, I> {
    /// The evidence of `sources` sources over their `means` and the `beliefs` buffer.
    ///
    /// Errors: a mean-function count other than `sources` ([`Error::InvalidParameter`]
    /// `means`), `beliefs` shorter than `sources` ([`Error::BufferTooSmall`]).
    pub(super) fn new(
        means: &'a [MeanFunction<T, N, I>],
        beliefs: &'a mut [SourceBelief<T>],
        sources: usize,
    ) -> Result<Self> {
        if means.len() != sources {
            return Err(Error::InvalidParameter { parameter: "means" });
        }
        short(beliefs.len(), sources, buffer::BELIEFS)?;
        let beliefs = beliefs
            .get_mut(..sources)
            .ok_or(Error::CapacityExceeded { capacity: sources })?;
        let mut evidence = Self { means, beliefs };
        evidence.reset();
        Ok(evidence)
    }

    /// Every source equally plausible, no error seen.
    pub(super) fn reset(&mut self) {
        plausibility::reset(self.beliefs);
    }

    /// The sources' reward mean functions.
    pub(super) fn means(&self) -> &'a [MeanFunction<T, N, I>] {
        self.means
    }

    /// The sources' beliefs.
    pub(super) fn beliefs(&self) -> &[SourceBelief<T>] {
        self.beliefs
    }

    /// The plausibilities from the errors so far (reward variance `v`).
    pub(super) fn update(&mut self, v: T) -> Result<()> {
        plausibility::update(self.beliefs, v)
    }

    /// The plausibility-weighted mean `m(z) = Σₖ πₖ μₖ(z)` of the sources' means at `z` and
    /// their weighted variance.
    pub(super) fn spread(&self, z: &[T; I]) -> Result<(T, T)> {
        candidates::weighted_spread(
            self.means
                .iter()
                .zip(self.beliefs.iter())
                .map(|(f, b)| Ok((f.mean(z)?, b.plausibility))),
        )
    }

    /// Adds `record`'s clipped errors to the beliefs and appends it to `run`'s `D₀`.
    ///
    /// Errors: `D₀` full ([`Error::CapacityExceeded`], checked first), those of a mean
    /// function; either way nothing changes.
    pub(super) fn append<G, const D: usize>(
        &mut self,
        config: &ValidAdaptiveConfig<T, D, I>,
        run: &mut Transfer<'_, T, G, D, I, N>,
        record: Transition<[T; D], T>,
    ) -> Result<()>
    where
        G: GenerativeModel<T, State = [T; D]>,
        Dims<D, I>: StatePlusAction,
    {
        run.ensure_room(1)?;
        let z = input(record.state, record.action);
        let v = config.awfqi.weights.noise_variance();
        for ((belief, mean), source) in self
            .beliefs
            .iter_mut()
            .zip(self.means)
            .zip(run.sources.records())
        {
            let ends =
                plausibility::nearest_ends(source, &record.state, record.action, &config.bounds);
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
