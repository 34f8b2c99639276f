//! The one weighted-FQI loop every approximator runs (the steps in the [module docs](super)):
//! the checks before anything changes, iteration 1's reward model, iterations 2..N. An
//! approximator only supplies its regressions, as a [`Regressor`].

use super::samples::check_magnitudes;
use super::{FqiConfig, SampleSet};
use crate::error::{Error, Result};
use crate::float::Real;
use rand_core::Rng;

/// What differs between approximators in weighted FQI: how one iteration's regression is
/// fitted and how the last Q-function is predicted at the next states. [`fit`] calls the
/// methods in this order, after every check has passed: [`fit_reward_model`] once, then
/// [`bellman_iteration`] for `k = 2, …, N`, then [`finish`].
///
/// [`fit_reward_model`]: Regressor::fit_reward_model
/// [`bellman_iteration`]: Regressor::bellman_iteration
/// [`finish`]: Regressor::finish
pub(crate) trait Regressor<T: Real, const D: usize> {
    /// Number of actions (every sample's action is checked against it).
    fn actions(&self) -> usize;

    /// The most samples one fit can hold (`None`: any number, as a table's sums can).
    fn capacity(&self) -> Option<usize> {
        None
    }

    /// Iteration 1: the reward model `R̂` from the sets' rewards with the reward weights,
    /// and `Q₁ = R̂`. The sets are valid, hold `total` samples (at least one, within
    /// [`capacity`](Regressor::capacity)), and no value of the fit can overflow `T`.
    fn fit_reward_model<'s, I, R>(
        &mut self,
        sets: I,
        total: usize,
        config: &FqiConfig<T>,
        rng: &mut R,
    ) where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized;

    /// Iteration `k ≥ 2`: regress `R̂ + γ(1 − ω)·maxₐ′ Q_{k−1}(s′, a′)` with the transition
    /// weights (`k == 2` is the first, `k == config.iterations()` the last).
    fn bellman_iteration<'s, I, R>(
        &mut self,
        sets: I,
        k: usize,
        config: &FqiConfig<T>,
        rng: &mut R,
    ) where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized;

    /// After the last iteration (e.g. the seed of streamed trees). Nothing by default.
    fn finish<R: Rng + ?Sized>(&mut self, _config: &FqiConfig<T>, _rng: &mut R) {}
}

/// Fits `q` from scratch by weighted FQI on the union of `sets` (cloned once per pass).
///
/// Everything is checked before `q` changes. Errors: a set's own errors
/// ([`SampleSet`]: an action `≥ actions`, a non-finite value, a negative weight, a slice of
/// the wrong length); no samples at all ([`Error::EmptyData`]); more samples than
/// [`Regressor::capacity`] ([`Error::CapacityExceeded`] with it); rewards, weights and
/// iterations so large that a value of the fit could overflow `T`
/// ([`Error::InvalidParameter`] `reward`).
pub(crate) fn fit<'s, Q, I, R, T, const D: usize>(
    q: &mut Q,
    sets: I,
    config: &FqiConfig<T>,
    rng: &mut R,
) -> Result<()>
where
    Q: Regressor<T, D> + ?Sized,
    I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
    T: Real + 's,
    R: Rng + ?Sized,
{
    let total = check(sets.clone(), q.actions(), q.capacity(), config)?;
    iterate(q, sets, total, config, rng);
    Ok(())
}

/// The checks of [`fit`]; returns the number of samples. One copy per kind of sets, shared
/// by every approximator.
#[inline(never)]
fn check<'s, I, T, const D: usize>(
    sets: I,
    actions: usize,
    capacity: Option<usize>,
    config: &FqiConfig<T>,
) -> Result<usize>
where
    I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
    T: Real + 's,
{
    let mut total = 0usize;
    for set in sets.clone() {
        set.validate(actions)?;
        total = total.saturating_add(set.len());
    }
    if total == 0 {
        return Err(Error::EmptyData);
    }
    if let Some(capacity) = capacity {
        if total > capacity {
            return Err(Error::CapacityExceeded { capacity });
        }
    }
    check_magnitudes(sets, config)?;
    Ok(total)
}

/// The iterations of [`fit`] on checked sets. Not inlined: inlined into
/// `QFunction::fit_sets`, every approximator's loop shared one stack frame (+552 bytes of
/// peak stack in the firmware example).
#[inline(never)]
fn iterate<'s, Q, I, R, T, const D: usize>(
    q: &mut Q,
    sets: I,
    total: usize,
    config: &FqiConfig<T>,
    rng: &mut R,
) where
    Q: Regressor<T, D> + ?Sized,
    I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
    T: Real + 's,
    R: Rng + ?Sized,
{
    q.fit_reward_model(sets.clone(), total, config, rng);
    for k in 2..=config.iterations() {
        q.bellman_iteration(sets.clone(), k, config, rng);
    }
    q.finish(config, rng);
}

/// The generator handed to [`fit`] by the approximators that draw nothing (the table, tile
/// coding, kernel averaging); it yields zeros if asked.
pub(crate) struct NoDraws;

impl rand_core::TryRng for NoDraws {
    type Error = core::convert::Infallible;

    fn try_next_u32(&mut self) -> core::result::Result<u32, Self::Error> {
        Ok(0)
    }

    fn try_next_u64(&mut self) -> core::result::Result<u64, Self::Error> {
        Ok(0)
    }

    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> core::result::Result<(), Self::Error> {
        dst.fill(0);
        Ok(())
    }
}
