//! Policy evaluation as the reference reports it (spec §3.3, `perf_disc_greedy`): a few
//! rollouts from (0, 0) on the noisy target, each scored by its discounted return.
//!
//! The rollouts themselves are Puddle World's [`PuddleWorld::rollout`]; this module only
//! fixes the protocol (5 rollouts, horizon 50, γ = 0.99) and the statistics.

use crate::env::{PUDDLE_DISCOUNT, PUDDLE_HORIZON, PuddleWorld};
use crate::fqi::TabularFqi;
use crate::policy::Policy;
use crate::{Error, Real, Result};
use rand_core::Rng;

/// Number of rollouts of the reference evaluation.
pub const EVALUATION_ROLLOUTS: usize = 5;

/// The evaluation fields of §3.3.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Evaluation<T> {
    /// Mean discounted return of the rollouts (`perf_disc_greedy_mean`).
    pub mean_return: T,
    /// Population std of the returns divided by √rollouts — a standard error
    /// (`perf_disc_greedy_std`, despite the reference's name).
    pub standard_error: T,
    /// Mean rollout length (`perf_disc_greedy_steps`).
    pub mean_steps: T,
    /// How many rollouts reached the goal.
    pub reached_goal: usize,
}

/// Runs `rollouts` rollouts of `policy` on `env` (each from (0, 0), at most 50 steps,
/// γ = 0.99, stopping after the absorbing step) and returns their statistics.
///
/// Errors: `rollouts == 0` ([`Error::InvalidParameter`]); the first error of the policy or
/// of a step.
pub fn evaluate<T, P, R>(
    env: &PuddleWorld<T>,
    policy: &mut P,
    rollouts: usize,
    rng: &mut R,
) -> Result<Evaluation<T>>
where
    T: Real,
    P: Policy<[T; 2]> + ?Sized,
    R: Rng + ?Sized,
{
    if rollouts == 0 {
        return Err(Error::InvalidParameter {
            parameter: "rollouts",
        });
    }
    let discount = T::from_f64(PUDDLE_DISCOUNT);
    let mut sum = T::ZERO;
    let mut sum_sq = T::ZERO;
    let mut steps = T::ZERO;
    let mut reached_goal = 0;
    for _ in 0..rollouts {
        let r = env.rollout(policy, PUDDLE_HORIZON, discount, rng)?;
        sum += r.discounted_return;
        sum_sq += r.discounted_return * r.discounted_return;
        steps += T::from_usize(r.steps);
        reached_goal += usize::from(r.reached_goal);
    }
    let n = T::from_usize(rollouts);
    let mean = sum / n;
    let variance = (sum_sq / n - mean * mean).max(T::ZERO);
    Ok(Evaluation {
        mean_return: mean,
        standard_error: (variance / n).sqrt(),
        mean_steps: steps / n,
        reached_goal,
    })
}

/// The reference evaluation of the greedy policy of a tabular Q-function (§3.3): 5
/// rollouts; ties between actions go to the smallest index.
///
/// Errors: those of [`evaluate`].
pub fn evaluate_greedy<T: Real, R: Rng + ?Sized>(
    env: &PuddleWorld<T>,
    q: &TabularFqi<'_, T, 2>,
    rng: &mut R,
) -> Result<Evaluation<T>> {
    let mut greedy = |s: &[T; 2]| q.greedy_action(*s);
    evaluate(env, &mut greedy, EVALUATION_ROLLOUTS, rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::{ACTION_LEFT, ACTION_RIGHT, ACTION_UP, Dynamics};
    use crate::policy::UniformPolicy;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn statistics_match_the_rollouts_they_summarise() {
        let env = PuddleWorld::<f64>::target(Dynamics::Shared);
        let mut policy = UniformPolicy::new(4).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let eval = evaluate(&env, &mut policy, 5, &mut rng).unwrap();
        // Replay the same stream rollout by rollout and recompute the statistics.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let returns: [f64; 5] = core::array::from_fn(|_| {
            env.rollout(&mut policy, 50, 0.99, &mut rng)
                .unwrap()
                .discounted_return
        });
        let mean = returns.iter().sum::<f64>() / 5.0;
        let var = returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / 5.0;
        assert!((eval.mean_return - mean).abs() < 1e-9);
        assert!((eval.standard_error - (var / 5.0).sqrt()).abs() < 1e-9);
        assert!(eval.mean_steps >= 1.0 && eval.mean_steps <= 50.0);
        assert!(evaluate(&env, &mut policy, 0, &mut rng).is_err());
    }

    #[test]
    fn a_policy_that_walks_to_the_goal_scores_its_path() {
        // Right to x ≈ 5, then up (correcting x into [4.5, 5.5]) until the goal (5, 10) is
        // within 1.41: about 14 steps of reward ≈ −1 plus the (6, 4)/(6, 6) puddle
        // penalties on the way.
        let env = PuddleWorld::<f64>::target(Dynamics::Shared);
        let mut to_x5 = |s: &[f64; 2]| {
            Ok(if s[0] < 4.5 {
                ACTION_RIGHT
            } else if s[0] > 5.5 {
                ACTION_LEFT
            } else {
                ACTION_UP
            })
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let eval = evaluate(&env, &mut to_x5, 5, &mut rng).unwrap();
        assert_eq!(eval.reached_goal, 5);
        // At least 4 + 8 = 12 steps of −1 or less: return below −(1 − 0.99¹²)/0.01 = −11.4.
        assert!(eval.mean_return < -11.4, "{}", eval.mean_return);
        assert!(eval.mean_steps >= 12.0 && eval.mean_steps <= 25.0);
    }
}
