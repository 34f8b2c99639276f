//! What the plants on the unit box share (the zones, the thermal room, the tanks): states in
//! `[0, 1]^D`, a noise-free mean step, Gaussian noise on every coordinate and on the reward,
//! next states clamped back into the box, nothing absorbing. One place for the checks and
//! the noisy step, so each plant file holds only its physics and its rewards.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::Transition;
use crate::rng;
use rand_core::Rng;

/// Checks a state of the unit box and an action below `actions`.
///
/// Errors: a NaN or infinite coordinate ([`Error::NonFinite`] `state`), one outside
/// `[0, 1]` ([`Error::OutOfRange`] `state`), an action `>= actions` ([`Error::OutOfRange`]
/// `action`).
pub(crate) fn check<T: Real, const D: usize>(
    state: [T; D],
    action: usize,
    actions: usize,
) -> Result<()> {
    crate::error::ensure_all_finite(&state, "state")?;
    if !state.iter().all(|&x| x >= T::ZERO && x <= T::ONE) {
        return Err(Error::OutOfRange { parameter: "state" });
    }
    if action >= actions {
        return Err(Error::OutOfRange {
            parameter: "action",
        });
    }
    Ok(())
}

/// One sampled step around the means: each next coordinate `mean + σ_s·ε` clamped into
/// `[0, 1]` (one normal draw per coordinate, in order), then the reward `reward + σ_r·ε`
/// (one more draw).
pub(crate) fn noisy_step<T: Real, R: Rng + ?Sized, const D: usize>(
    state: [T; D],
    action: usize,
    (mean, reward): ([T; D], T),
    (state_noise, reward_noise): (T, T),
    rng: &mut R,
) -> Transition<[T; D], T> {
    let mut next_state = mean;
    for x in &mut next_state {
        let e: T = rng::standard_normal(rng);
        *x = (*x + state_noise * e).clamp_to(T::ZERO, T::ONE);
    }
    let e: T = rng::standard_normal(rng);
    Transition {
        state,
        action,
        reward: reward + reward_noise * e,
        next_state,
        absorbing: false,
    }
}

/// The mean next state clamped into the box (what the noise-free plant would reach).
pub(crate) fn clamped<T: Real, const D: usize>(mean: [T; D]) -> [T; D] {
    mean.map(|x| x.clamp_to(T::ZERO, T::ONE))
}
