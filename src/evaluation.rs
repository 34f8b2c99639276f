//! Policy evaluation as the reference reports it (spec §3.3, `perf_disc_greedy`): a few
//! rollouts from a start state on the noisy target, each scored by its discounted return.
//!
//! A rollout runs any [`GenerativeModel`] from a start state under a [`Policy`] until an
//! absorbing transition or the horizon; an [`EvaluationProtocol`] fixes the start, the
//! number of rollouts, the horizon and the discount (Puddle World's reference protocol is
//! [`crate::env::PuddleWorld::evaluation_protocol`]: 5 rollouts from (0, 0), horizon 50,
//! γ = 0.99).

use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::Greedy;
use crate::model::GenerativeModel;
use crate::policy::Policy;
use rand_core::Rng;

/// What one evaluation rollout produced (spec §3.3).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rollout<T> {
    /// The discounted return Σₜ γᵗ rₜ over the rollout's steps.
    pub discounted_return: T,
    /// Number of steps taken (1 to the horizon).
    pub steps: usize,
    /// `true` when the last step was absorbing (Puddle World: it entered the goal).
    pub absorbed: bool,
}

/// How a policy is evaluated: `rollouts` rollouts from `start`, each at most `horizon`
/// steps, scored by the return discounted with `discount`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EvaluationProtocol<T, const D: usize> {
    /// The state every rollout starts in.
    pub start: [T; D],
    /// Number of rollouts (≥ 1).
    pub rollouts: usize,
    /// Most steps of a rollout (≥ 1).
    pub horizon: usize,
    /// The discount γ in `[0, 1]`.
    pub discount: T,
}

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
    /// How many rollouts ended in an absorbing state (Puddle World: reached the goal).
    pub absorbed: usize,
}

/// One rollout of `policy` on `model` from `start`: per step the policy chooses (drawing
/// from `rng` first), then the model samples the transition; it stops after the first
/// absorbing transition or `horizon` steps. Returns the discounted return Σₜ γᵗ rₜ
/// (γ = `discount`, accumulated in `T`) and the length.
///
/// Errors: a non-finite `discount` ([`Error::NonFinite`]) or one outside [0, 1]
/// ([`Error::OutOfRange`] `discount`), `horizon == 0` ([`Error::InvalidParameter`]
/// `horizon`), all before anything is drawn; then the first error of the policy or of a
/// query (e.g. an action out of range).
pub fn rollout<T, G, P, R, const D: usize>(
    model: &G,
    policy: &mut P,
    start: [T; D],
    horizon: usize,
    discount: T,
    rng: &mut R,
) -> Result<Rollout<T>>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + ?Sized,
    P: Policy<[T; D]> + ?Sized,
    R: Rng + ?Sized,
{
    crate::error::ensure_finite(discount, "discount")?;
    if discount < T::ZERO || discount > T::ONE {
        return Err(Error::OutOfRange {
            parameter: "discount",
        });
    }
    if horizon == 0 {
        return Err(Error::InvalidParameter {
            parameter: "horizon",
        });
    }
    let mut discounted_return = T::ZERO;
    let mut weight = T::ONE;
    let mut state = start;
    for t in 0..horizon {
        let action = policy.action(&state, rng)?;
        let transition = model.query(state, action, rng)?;
        discounted_return += weight * transition.reward;
        weight *= discount;
        if transition.absorbing {
            return Ok(Rollout {
                discounted_return,
                steps: t + 1,
                absorbed: true,
            });
        }
        state = transition.next_state;
    }
    Ok(Rollout {
        discounted_return,
        steps: horizon,
        absorbed: false,
    })
}

/// Runs the rollouts of `protocol` with `policy` on `model` and returns their statistics.
///
/// Errors: `protocol.rollouts == 0` ([`Error::InvalidParameter`] `rollouts`); those of
/// [`rollout`].
pub fn evaluate<T, G, P, R, const D: usize>(
    model: &G,
    policy: &mut P,
    protocol: &EvaluationProtocol<T, D>,
    rng: &mut R,
) -> Result<Evaluation<T>>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + ?Sized,
    P: Policy<[T; D]> + ?Sized,
    R: Rng + ?Sized,
{
    let multi = MultiStartProtocol {
        starts: core::slice::from_ref(&protocol.start),
        rollouts: protocol.rollouts,
        horizon: protocol.horizon,
        discount: protocol.discount,
    };
    evaluate_multi_start(model, policy, &multi, rng)
}

/// How a policy is evaluated over several start states: `rollouts` rollouts from each
/// state of `starts` in turn (start after start), each at most `horizon` steps, scored by
/// the return discounted with `discount`. A plant without one natural initial state (a
/// building that may be cold or warm in the morning) is judged over the states it meets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiStartProtocol<'a, T, const D: usize> {
    /// The start states (at least one).
    pub starts: &'a [[T; D]],
    /// Rollouts from each start (≥ 1).
    pub rollouts: usize,
    /// Most steps of a rollout (≥ 1).
    pub horizon: usize,
    /// The discount γ in `[0, 1]`.
    pub discount: T,
}

/// Runs the rollouts of a [`MultiStartProtocol`] with `policy` on `model`: the statistics
/// of all `starts.len() · rollouts` returns together (mean, standard error of that mean,
/// mean length, absorbed count), as [`evaluate`] gives them for one start.
///
/// Errors: no start ([`Error::EmptyData`]), `rollouts == 0` ([`Error::InvalidParameter`]
/// `rollouts`); those of [`rollout`].
///
/// ```
/// use awfqi::env::{Dynamics, PuddleWorld};
/// use awfqi::evaluation::{MultiStartProtocol, evaluate_multi_start};
/// use awfqi::rand_core::SeedableRng;
/// # fn main() -> awfqi::Result<()> {
/// let world = PuddleWorld::<f32>::target(Dynamics::Shared);
/// let starts = [[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]];
/// let protocol = MultiStartProtocol { starts: &starts, rollouts: 2, horizon: 50, discount: 0.99 };
/// let mut up = |_: &[f32; 2]| Ok(awfqi::env::ACTION_UP);
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
/// let result = evaluate_multi_start(&world, &mut up, &protocol, &mut rng)?;
/// assert!(result.mean_return < 0.0 && result.mean_steps <= 50.0);
/// # Ok(())
/// # }
/// ```
pub fn evaluate_multi_start<T, G, P, R, const D: usize>(
    model: &G,
    policy: &mut P,
    protocol: &MultiStartProtocol<'_, T, D>,
    rng: &mut R,
) -> Result<Evaluation<T>>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + ?Sized,
    P: Policy<[T; D]> + ?Sized,
    R: Rng + ?Sized,
{
    if protocol.starts.is_empty() {
        return Err(Error::EmptyData);
    }
    if protocol.rollouts == 0 {
        return Err(Error::InvalidParameter {
            parameter: "rollouts",
        });
    }
    let mut sum = T::ZERO;
    let mut sum_sq = T::ZERO;
    let mut steps = T::ZERO;
    let mut absorbed = 0;
    let mut count = 0usize;
    for &start in protocol.starts {
        for _ in 0..protocol.rollouts {
            let r = rollout(
                model,
                policy,
                start,
                protocol.horizon,
                protocol.discount,
                rng,
            )?;
            sum += r.discounted_return;
            sum_sq += r.discounted_return * r.discounted_return;
            steps += T::from_usize(r.steps);
            absorbed += usize::from(r.absorbed);
            count += 1;
        }
    }
    let n = T::from_usize(count);
    let mean = sum / n;
    let variance = (sum_sq / n - mean * mean).max(T::ZERO);
    Ok(Evaluation {
        mean_return: mean,
        standard_error: (variance / n).sqrt(),
        mean_steps: steps / n,
        absorbed,
    })
}

/// [`evaluate_multi_start`] for the greedy policy of a Q-function (see
/// [`evaluate_greedy`]).
///
/// Errors: those of [`evaluate_multi_start`].
pub fn evaluate_greedy_multi_start<T, G, R, Q, const D: usize>(
    model: &G,
    q: &Q,
    protocol: &MultiStartProtocol<'_, T, D>,
    rng: &mut R,
) -> Result<Evaluation<T>>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + ?Sized,
    R: Rng + ?Sized,
    Q: Greedy<T, D> + ?Sized,
{
    let mut greedy = |s: &[T; D]| q.greedy(*s);
    evaluate_multi_start(model, &mut greedy, protocol, rng)
}

/// [`evaluate`] for the greedy policy of a Q-function (a [`crate::fqi::TabularFqi`], a
/// [`crate::fqi::TileFqi`] or the [`crate::fqi::QFunction`] of a learner; ties between actions as its
/// `greedy_action` breaks them).
///
/// Errors: those of [`evaluate`].
pub fn evaluate_greedy<T, G, R, Q, const D: usize>(
    model: &G,
    q: &Q,
    protocol: &EvaluationProtocol<T, D>,
    rng: &mut R,
) -> Result<Evaluation<T>>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]> + ?Sized,
    R: Rng + ?Sized,
    Q: Greedy<T, D> + ?Sized,
{
    let mut greedy = |s: &[T; D]| q.greedy(*s);
    evaluate(model, &mut greedy, protocol, rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::{ACTION_LEFT, ACTION_RIGHT, ACTION_UP, Dynamics, PuddleWorld};
    use crate::policy::UniformPolicy;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn statistics_match_the_rollouts_they_summarise() {
        let env = PuddleWorld::<f64>::target(Dynamics::Shared);
        let mut policy = UniformPolicy::new(4).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let protocol = env.evaluation_protocol();
        let eval = evaluate(&env, &mut policy, &protocol, &mut rng).unwrap();
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
        let none = EvaluationProtocol {
            rollouts: 0,
            ..protocol
        };
        assert!(evaluate(&env, &mut policy, &none, &mut rng).is_err());
    }

    #[test]
    fn multi_start_pools_the_rollouts_of_every_start() {
        let env = PuddleWorld::<f64>::target(Dynamics::Shared);
        let mut policy = UniformPolicy::new(4).unwrap();
        let starts = [[0.0, 0.0], [9.0, 9.0]];
        let protocol = MultiStartProtocol {
            starts: &starts,
            rollouts: 3,
            horizon: 20,
            discount: 0.9,
        };
        let eval = evaluate_multi_start(
            &env,
            &mut policy,
            &protocol,
            &mut ChaCha8Rng::seed_from_u64(5),
        )
        .unwrap();
        // The same stream, rollout by rollout: three from (0, 0), then three from (9, 9).
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut returns = [0.0f64; 6];
        let mut lengths = 0usize;
        for (i, r) in returns.iter_mut().enumerate() {
            let out = rollout(&env, &mut policy, starts[i / 3], 20, 0.9, &mut rng).unwrap();
            *r = out.discounted_return;
            lengths += out.steps;
        }
        let mean = returns.iter().sum::<f64>() / 6.0;
        let var = returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / 6.0;
        assert!((eval.mean_return - mean).abs() < 1e-9);
        assert!((eval.standard_error - (var / 6.0).sqrt()).abs() < 1e-9);
        assert!((eval.mean_steps - lengths as f64 / 6.0).abs() < 1e-12);
        let none = MultiStartProtocol {
            starts: &[],
            ..protocol
        };
        assert_eq!(
            evaluate_multi_start(&env, &mut policy, &none, &mut rng),
            Err(Error::EmptyData)
        );
        let zero = MultiStartProtocol {
            rollouts: 0,
            ..protocol
        };
        assert!(evaluate_multi_start(&env, &mut policy, &zero, &mut rng).is_err());
        // One start is exactly `evaluate`.
        let one = EvaluationProtocol {
            start: [0.0, 0.0],
            rollouts: 3,
            horizon: 20,
            discount: 0.9,
        };
        let a = evaluate(&env, &mut policy, &one, &mut ChaCha8Rng::seed_from_u64(8)).unwrap();
        let single = MultiStartProtocol {
            starts: &starts[..1],
            ..protocol
        };
        let b = evaluate_multi_start(
            &env,
            &mut policy,
            &single,
            &mut ChaCha8Rng::seed_from_u64(8),
        )
        .unwrap();
        assert_eq!(a, b);
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
        let eval = evaluate(&env, &mut to_x5, &env.evaluation_protocol(), &mut rng).unwrap();
        assert_eq!(eval.absorbed, 5);
        // At least 4 + 8 = 12 steps of −1 or less: return below −(1 − 0.99¹²)/0.01 = −11.4.
        assert!(eval.mean_return < -11.4, "{}", eval.mean_return);
        assert!(eval.mean_steps >= 12.0 && eval.mean_steps <= 25.0);
    }
}
