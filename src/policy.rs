//! Policies that choose an action in a state: the trait the episode runners call, and the
//! two behaviour policies of spec §3.1 that do not need a learned Q-function (uniform, and
//! ε-greedy around any greedy policy).
//!
//! A greedy policy is any closure `FnMut(&S) -> Result<usize>` (blanket implementation);
//! it returns `Result` because evaluating a learned Q-function can fail.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::rng;
use crate::rng::uniform_index;
use rand_core::Rng;

/// Chooses an action in a state, drawing any randomness from the caller's generator.
///
/// Implementations must return an action in `0..num_actions` of the environment they are
/// used with; an out-of-range action makes the step fail with [`Error::OutOfRange`].
pub trait Policy<S> {
    /// The action to take in `state`.
    ///
    /// Errors: whatever the policy's own computation reports (e.g. a Q-function that cannot
    /// be evaluated).
    fn action<R: Rng + ?Sized>(&mut self, state: &S, rng: &mut R) -> Result<usize>;
}

/// Any closure `FnMut(&S) -> Result<usize>` is a deterministic policy (e.g. greedy w.r.t.
/// a Q-function, ties to the smallest action); it draws nothing from the generator.
impl<S, F> Policy<S> for F
where
    F: FnMut(&S) -> Result<usize>,
{
    fn action<R: Rng + ?Sized>(&mut self, state: &S, _rng: &mut R) -> Result<usize> {
        self(state)
    }
}

/// The uniform policy of spec §3.1: each of `num_actions` actions with probability
/// 1/`num_actions`, whatever the state. Consumes one `u64` per action.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UniformPolicy {
    num_actions: usize,
}

impl UniformPolicy {
    /// A uniform policy over `0..num_actions`.
    ///
    /// Errors: `num_actions == 0` ([`Error::InvalidParameter`] `num_actions`).
    pub fn new(num_actions: usize) -> Result<Self> {
        if num_actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "num_actions",
            });
        }
        Ok(Self { num_actions })
    }

    /// Number of actions drawn from.
    pub fn num_actions(&self) -> usize {
        self.num_actions
    }
}

impl<S> Policy<S> for UniformPolicy {
    fn action<R: Rng + ?Sized>(&mut self, _state: &S, rng: &mut R) -> Result<usize> {
        Ok(uniform_index(rng, self.num_actions))
    }
}

/// The ε-greedy policy of spec §3.1 around a `greedy` policy.
///
/// Draws u ~ U[0, 1) ([`rng::uniform`], one `u64`); if u < ε it returns a uniform action
/// (one more `u64`; it may coincide with the greedy one), otherwise it asks `greedy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpsilonGreedyPolicy<T, G> {
    greedy: G,
    epsilon: T,
    num_actions: usize,
}

impl<T: Real, G> EpsilonGreedyPolicy<T, G> {
    /// ε-greedy around `greedy` with exploration probability `epsilon` over
    /// `0..num_actions` (the spec uses ε = 0.3 and 4 actions).
    ///
    /// Errors: non-finite `epsilon` ([`Error::NonFinite`]), `epsilon` outside [0, 1]
    /// ([`Error::OutOfRange`] `epsilon`), `num_actions == 0` ([`Error::InvalidParameter`]).
    pub fn new(greedy: G, epsilon: T, num_actions: usize) -> Result<Self> {
        crate::error::ensure_finite(epsilon, "epsilon")?;
        if epsilon < T::ZERO || epsilon > T::ONE {
            return Err(Error::OutOfRange {
                parameter: "epsilon",
            });
        }
        if num_actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "num_actions",
            });
        }
        Ok(Self {
            greedy,
            epsilon,
            num_actions,
        })
    }

    /// The exploration probability ε.
    pub fn epsilon(&self) -> T {
        self.epsilon
    }

    /// The wrapped greedy policy.
    pub fn greedy(&self) -> &G {
        &self.greedy
    }

    /// The wrapped greedy policy, mutably (e.g. to swap in a newly learned Q-function).
    pub fn greedy_mut(&mut self) -> &mut G {
        &mut self.greedy
    }

    /// Unwraps the greedy policy.
    pub fn into_greedy(self) -> G {
        self.greedy
    }
}

impl<S, T: Real, G: Policy<S>> Policy<S> for EpsilonGreedyPolicy<T, G> {
    fn action<R: Rng + ?Sized>(&mut self, state: &S, rng: &mut R) -> Result<usize> {
        let u: T = rng::uniform(rng);
        if u < self.epsilon {
            Ok(uniform_index(rng, self.num_actions))
        } else {
            self.greedy.action(state, rng)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn uniform_policy_hits_every_action_with_equal_frequency() {
        let mut policy = UniformPolicy::new(4).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 40_000;
        let mut counts = [0usize; 4];
        for _ in 0..n {
            let a = Policy::<[f64; 2]>::action(&mut policy, &[0.0, 0.0], &mut rng).unwrap();
            counts[a] += 1;
        }
        // Binomial(40000, 1/4): std 86.6; allow 5 std.
        for c in counts {
            assert!((c as f64 - 10_000.0).abs() < 433.0, "counts {counts:?}");
        }
    }

    #[test]
    fn uniform_index_consumes_one_u64_and_maps_the_top_bits() {
        let mut a = ChaCha8Rng::seed_from_u64(9);
        let mut b = a.clone();
        let i = uniform_index(&mut a, 4);
        let raw = b.next_u64();
        assert_eq!(i, (raw >> 62) as usize);
        assert_eq!(a.next_u64(), b.next_u64(), "streams stay in step");
    }

    #[test]
    fn epsilon_greedy_explores_with_probability_epsilon() {
        let greedy = |_: &[f64; 2]| -> Result<usize> { Ok(2) };
        let mut policy = EpsilonGreedyPolicy::new(greedy, 0.3f64, 4).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = 40_000;
        let mut counts = [0usize; 4];
        for _ in 0..n {
            counts[policy.action(&[1.0, 1.0], &mut rng).unwrap()] += 1;
        }
        // Non-greedy actions each have probability 0.3/4 = 0.075 (std 52.7 over 40000);
        // the greedy one 0.7 + 0.075 = 0.775 (std 83.5). Allow 5 std.
        for (a, &c) in counts.iter().enumerate() {
            let want = if a == 2 { 0.775 } else { 0.075 } * n as f64;
            let tol = if a == 2 { 418.0 } else { 264.0 };
            assert!((c as f64 - want).abs() < tol, "counts {counts:?}");
        }
    }

    #[test]
    fn epsilon_greedy_extremes_and_draw_order() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut always_greedy =
            EpsilonGreedyPolicy::new(|_: &[f32; 2]| -> Result<usize> { Ok(1) }, 0.0f32, 4).unwrap();
        for _ in 0..200 {
            assert_eq!(always_greedy.action(&[0.0, 0.0], &mut rng).unwrap(), 1);
        }
        // ε = 1: u < 1 always, so the action is the uniform index of the second u64.
        let mut never_greedy =
            EpsilonGreedyPolicy::new(|_: &[f64; 2]| -> Result<usize> { Ok(9) }, 1.0f64, 4).unwrap();
        let mut replay = rng.clone();
        for _ in 0..200 {
            let a = never_greedy.action(&[0.0, 0.0], &mut rng).unwrap();
            let _u = replay.next_u64();
            assert_eq!(a, (replay.next_u64() >> 62) as usize);
        }
    }

    #[test]
    fn greedy_errors_propagate_and_bad_parameters_are_rejected() {
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut failing = EpsilonGreedyPolicy::new(
            |_: &[f64; 2]| -> Result<usize> { Err(Error::EmptyData) },
            0.0f64,
            4,
        )
        .unwrap();
        assert_eq!(failing.action(&[0.0, 0.0], &mut rng), Err(Error::EmptyData));
        let g = |_: &[f64; 2]| -> Result<usize> { Ok(0) };
        assert_eq!(
            EpsilonGreedyPolicy::new(g, f64::NAN, 4).map(|_| ()),
            Err(Error::NonFinite {
                parameter: "epsilon"
            })
        );
        assert_eq!(
            EpsilonGreedyPolicy::new(g, 1.5f64, 4).map(|_| ()),
            Err(Error::OutOfRange {
                parameter: "epsilon"
            })
        );
        assert_eq!(
            EpsilonGreedyPolicy::new(g, -0.1f64, 4).map(|_| ()),
            Err(Error::OutOfRange {
                parameter: "epsilon"
            })
        );
        assert_eq!(
            EpsilonGreedyPolicy::new(g, 0.3f64, 0).map(|_| ()),
            Err(Error::InvalidParameter {
                parameter: "num_actions"
            })
        );
        assert_eq!(
            UniformPolicy::new(0),
            Err(Error::InvalidParameter {
                parameter: "num_actions"
            })
        );
        let p = EpsilonGreedyPolicy::new(g, 0.25f64, 4).unwrap();
        assert_eq!(p.epsilon(), 0.25);
        assert_eq!((p.greedy())(&[0.0, 0.0]), Ok(0));
        assert_eq!(UniformPolicy::new(4).unwrap().num_actions(), 4);
    }
}
