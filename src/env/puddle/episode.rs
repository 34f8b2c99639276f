//! Episodes and evaluation rollouts on Puddle World (spec §2.5, §3.3), without allocation.
//!
//! An episode starts at s₀ = (0, 0) and repeats [`PuddleWorld::step`] with the actions of a
//! [`Policy`] until a step reports ω = 1 (that step is included) or `horizon` steps have
//! been taken, so it has 1 to `horizon` records and only the last can be absorbing. Per
//! step the policy draws first, then the step's three noise draws ε_x, ε_y, η.

use super::{PUDDLE_DISCOUNT, PUDDLE_EVALUATION_ROLLOUTS, PUDDLE_HORIZON, PuddleWorld};
use crate::error::{Error, Result};
use crate::evaluation::{EvaluationProtocol, Rollout};
use crate::float::Real;
use crate::model::Transition;
use crate::policy::Policy;
use rand_core::Rng;

/// One record of an episode: spec §1's 8-tuple (t, s, a, r, s′, ω), i.e. the time index
/// `t` inside the episode (0, 1, …) and the sampled [`Transition`] taken at that time.
///
/// Memory: 6 scalars, a `usize` t, a `usize` action and a flag: 40 bytes in `f32` and
/// 64 bytes in `f64` on a 64-bit host (smaller on 32-bit targets), so a full 50-step
/// episode buffer is 2000 bytes (`f32`) or 3200 bytes (`f64`) on such a host.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeRecord<T> {
    /// Time index t of the step inside its episode, from 0.
    pub t: usize,
    /// The step (s_t, a_t, r_t, s_{t+1}, ω_t).
    pub transition: Transition<[T; 2], T>,
}

impl<T: Real> Default for EpisodeRecord<T> {
    /// A placeholder record (t = 0, the origin, action 0, reward 0, not absorbing) for
    /// initialising caller-provided storage.
    fn default() -> Self {
        Self {
            t: 0,
            transition: Transition {
                state: [T::ZERO; 2],
                action: 0,
                reward: T::ZERO,
                next_state: [T::ZERO; 2],
                absorbing: false,
            },
        }
    }
}

impl<T: Real> PuddleWorld<T> {
    /// Runs one episode from s₀ = (0, 0), handing each record to `visit` as it is produced,
    /// and returns the number of records (1 to `horizon`).
    ///
    /// This is the allocation-free core of [`PuddleWorld::run_episode`] and
    /// [`PuddleWorld::rollout`]; use it directly to append records to any storage.
    ///
    /// Errors: `horizon == 0` ([`Error::InvalidParameter`] `horizon`); otherwise the first
    /// error of the policy, of a step (an action `>= 4` is [`Error::OutOfRange`] `action`)
    /// or of `visit`, which stops the episode. Records already visited stay visited.
    pub fn run_episode_with<P, R, F>(
        &self,
        policy: &mut P,
        horizon: usize,
        rng: &mut R,
        mut visit: F,
    ) -> Result<usize>
    where
        P: Policy<[T; 2]> + ?Sized,
        R: Rng + ?Sized,
        F: FnMut(EpisodeRecord<T>) -> Result<()>,
    {
        if horizon == 0 {
            return Err(Error::InvalidParameter {
                parameter: "horizon",
            });
        }
        let mut state = self.initial_state();
        for t in 0..horizon {
            let action = policy.action(&state, rng)?;
            let transition = self.step(state, action, rng)?;
            visit(EpisodeRecord { t, transition })?;
            if transition.absorbing {
                return Ok(t + 1);
            }
            state = transition.next_state;
        }
        Ok(horizon)
    }

    /// Runs one episode from s₀ = (0, 0) (spec §2.5) and writes its records to
    /// `records[0..n]`, returning `n` (1 to `horizon`). Record `t` has time index `t`, and
    /// its next state is the state of record `t + 1`.
    ///
    /// `records` must hold at least `horizon` records, so an episode can never run out of
    /// room halfway; entries from `n` on are left untouched.
    ///
    /// Errors: `horizon == 0` ([`Error::InvalidParameter`]); `records.len() < horizon`
    /// ([`Error::CapacityExceeded`] with `records.len()`), both before anything is drawn
    /// or written; then the first error of the policy or of a step, after which
    /// `records[0..t]` hold the steps completed before the failure.
    pub fn run_episode<P, R>(
        &self,
        policy: &mut P,
        horizon: usize,
        records: &mut [EpisodeRecord<T>],
        rng: &mut R,
    ) -> Result<usize>
    where
        P: Policy<[T; 2]> + ?Sized,
        R: Rng + ?Sized,
    {
        if horizon == 0 {
            return Err(Error::InvalidParameter {
                parameter: "horizon",
            });
        }
        let capacity = records.len();
        if capacity < horizon {
            return Err(Error::CapacityExceeded { capacity });
        }
        let mut slots = records.iter_mut();
        self.run_episode_with(policy, horizon, rng, |record| match slots.next() {
            Some(slot) => {
                *slot = record;
                Ok(())
            }
            None => Err(Error::CapacityExceeded { capacity }),
        })
    }

    /// One evaluation rollout (spec §3.3) from (0, 0): [`crate::evaluation::rollout`]
    /// with this world's initial state.
    ///
    /// The spec's evaluation is `rollout(&mut greedy, PUDDLE_HORIZON, PUDDLE_DISCOUNT, rng)`
    /// with the constants converted to `T`, repeated 5 times
    /// ([`PuddleWorld::evaluation_protocol`]).
    ///
    /// Errors: those of [`crate::evaluation::rollout`].
    pub fn rollout<P, R>(
        &self,
        policy: &mut P,
        horizon: usize,
        discount: T,
        rng: &mut R,
    ) -> Result<Rollout<T>>
    where
        P: Policy<[T; 2]> + ?Sized,
        R: Rng + ?Sized,
    {
        crate::evaluation::rollout(self, policy, self.initial_state(), horizon, discount, rng)
    }

    /// The reference evaluation of spec §3.3: 5 rollouts from (0, 0) of at most 50 steps,
    /// γ = 0.99.
    pub fn evaluation_protocol(&self) -> EvaluationProtocol<T, 2> {
        EvaluationProtocol {
            start: self.initial_state(),
            rollouts: PUDDLE_EVALUATION_ROLLOUTS,
            horizon: PUDDLE_HORIZON,
            discount: T::from_f64(PUDDLE_DISCOUNT),
        }
    }
}
