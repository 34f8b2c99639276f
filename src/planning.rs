//! Dynamic programming on finite MDPs (spec §10.2): value iteration, exact policy
//! evaluation and greedy policies.
//!
//! Every function works on storage the caller provides, so a controller decides where the
//! tables live: `values` has one entry per state (|𝒮|·`size_of::<T>()` bytes), `q` one entry
//! per state-action pair laid out state-major, index `s·|𝒜| + a` (|𝒮|·|𝒜|·`size_of::<T>()`
//! bytes), and a policy one action index per state (|𝒮|·`size_of::<usize>()` bytes).
//!
//! Nothing here allocates or panics; the models are read through [`FiniteMdp`], so sparse
//! models cost O(successors) per backup rather than O(|𝒮|).

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::FiniteMdp;

/// Stopping rule of value iteration and policy evaluation.
///
/// The default is spec §10.2's: stop when ‖V_{k+1} − V_k‖∞ < 10⁻¹⁰ or after 10⁵ sweeps. In
/// `f32` a tolerance of 10⁻¹⁰ is below the rounding of values near 1; the iteration then
/// still stops as soon as a sweep changes nothing (a residual of exactly 0), which is where
/// floating-point iteration ends up, or after `max_sweeps`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StoppingRule<T> {
    /// Stop when the largest change of a sweep is strictly below this (≥ 0).
    pub tolerance: T,
    /// Stop after this many sweeps even if the tolerance was not reached (≥ 1).
    pub max_sweeps: usize,
}

impl<T: Real> Default for StoppingRule<T> {
    fn default() -> Self {
        Self {
            tolerance: T::from_f64(1e-10),
            max_sweeps: 100_000,
        }
    }
}

impl<T: Real> StoppingRule<T> {
    fn validate(&self) -> Result<()> {
        crate::error::ensure_finite(self.tolerance, "tolerance")?;
        if self.tolerance < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "tolerance",
            });
        }
        if self.max_sweeps == 0 {
            return Err(Error::InvalidParameter {
                parameter: "max_sweeps",
            });
        }
        Ok(())
    }
}

/// How an iterative solve ended.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Convergence<T> {
    /// Sweeps performed.
    pub sweeps: usize,
    /// ‖V_{k+1} − V_k‖∞ of the last sweep.
    pub residual: T,
    /// `true` when the tolerance was reached (or a sweep changed nothing) before
    /// `max_sweeps`.
    pub converged: bool,
}

/// Checks a discount factor: finite and in [0, 1).
fn check_gamma<T: Real>(gamma: T) -> Result<()> {
    crate::error::ensure_finite(gamma, "gamma")?;
    if gamma < T::ZERO || gamma >= T::ONE {
        return Err(Error::InvalidParameter { parameter: "gamma" });
    }
    Ok(())
}

/// Checks that `storage` has exactly `needed` entries: fewer is
/// [`Error::CapacityExceeded`], more is [`Error::InvalidParameter`] naming `parameter`.
pub(crate) fn check_len(len: usize, needed: usize, parameter: &'static str) -> Result<()> {
    if len < needed {
        Err(Error::CapacityExceeded { capacity: len })
    } else if len > needed {
        Err(Error::InvalidParameter { parameter })
    } else {
        Ok(())
    }
}

/// The number of state-action pairs |𝒮|·|𝒜| of `mdp`, or an error if a dimension is 0
/// or the product overflows.
pub(crate) fn pair_count<T: Real, M: FiniteMdp<T>>(mdp: &M) -> Result<usize> {
    let (s, a) = (mdp.num_states(), mdp.num_actions());
    if s == 0 || a == 0 {
        return Err(Error::EmptyData);
    }
    s.checked_mul(a).ok_or(Error::InvalidParameter {
        parameter: "num_states",
    })
}

/// One Bellman backup r(s, a) + γ Σ_{s′} p(s′|s, a) V(s′).
///
/// Errors: model errors, a non-finite reward or probability, a successor outside `values`.
pub fn backup<T: Real, M: FiniteMdp<T>>(
    mdp: &M,
    gamma: T,
    values: &[T],
    state: usize,
    action: usize,
) -> Result<T> {
    let reward = crate::error::ensure_finite(mdp.reward_mean(state, action)?, "reward_mean")?;
    let mut expected = T::ZERO;
    let mut failure = None;
    mdp.for_each_successor(state, action, |next, p| match values.get(next) {
        Some(&v) if p.is_finite() => expected += p * v,
        Some(_) => {
            failure.get_or_insert(Error::NonFinite {
                parameter: "transition_probability",
            });
        }
        None => {
            failure.get_or_insert(Error::OutOfRange {
                parameter: "next_state",
            });
        }
    })?;
    match failure {
        Some(e) => Err(e),
        None => Ok(reward + gamma * expected),
    }
}

/// Fills `q` (index `s·|𝒜| + a`) with the one-step look-ahead of `values`:
/// Q(s, a) = r(s, a) + γ Σ_{s′} p(s′|s, a) V(s′).
///
/// Errors: a bad `gamma`; `values` not of length |𝒮| or `q` not of length |𝒮|·|𝒜|
/// ([`Error::CapacityExceeded`] when too short, [`Error::InvalidParameter`] when too
/// long); model errors (then `q` may be partly written).
pub fn q_from_values<T: Real, M: FiniteMdp<T>>(
    mdp: &M,
    gamma: T,
    values: &[T],
    q: &mut [T],
) -> Result<()> {
    check_gamma(gamma)?;
    let pairs = pair_count(mdp)?;
    check_len(values.len(), mdp.num_states(), "values")?;
    check_len(q.len(), pairs, "q")?;
    let actions = mdp.num_actions();
    for (s, row) in q.chunks_exact_mut(actions).enumerate() {
        for (a, slot) in row.iter_mut().enumerate() {
            *slot = backup(mdp, gamma, values, s, a)?;
        }
    }
    Ok(())
}

/// The action with the largest value in one row of Q; ties go to the smallest action.
///
/// Errors: an empty row ([`Error::EmptyData`]) or a NaN entry ([`Error::NonFinite`]).
pub fn greedy_action<T: Real>(row: &[T]) -> Result<usize> {
    let mut best: Option<(usize, T)> = None;
    for (a, &v) in row.iter().enumerate() {
        if v.is_nan() {
            return Err(Error::NonFinite { parameter: "q" });
        }
        match best {
            Some((_, b)) if v <= b => {}
            _ => best = Some((a, v)),
        }
    }
    best.map(|(a, _)| a).ok_or(Error::EmptyData)
}

/// The greedy policy of `q` (state-major, `num_actions` per state) into `policy`, ties to
/// the smallest action.
///
/// Errors: `num_actions == 0`, `q.len()` not a multiple of it, `policy` not one entry per
/// state, a NaN in `q`. `policy` is written only after every row was checked.
pub fn greedy_policy<T: Real>(q: &[T], num_actions: usize, policy: &mut [usize]) -> Result<()> {
    if num_actions == 0 {
        return Err(Error::InvalidParameter {
            parameter: "num_actions",
        });
    }
    if q.len() % num_actions != 0 {
        return Err(Error::InvalidParameter { parameter: "q" });
    }
    check_len(policy.len(), q.len() / num_actions, "policy")?;
    if q.iter().any(|v| v.is_nan()) {
        return Err(Error::NonFinite { parameter: "q" });
    }
    for (slot, row) in policy.iter_mut().zip(q.chunks_exact(num_actions)) {
        *slot = greedy_action(row)?;
    }
    Ok(())
}

/// Discounted value iteration (spec §10.2): from V₀ ≡ 0,
/// V_{k+1}(s) = max_a [r(s, a) + γ Σ_{s′} p(s′|s, a) V_k(s′)], stopping by `rule`.
///
/// On return `values` holds the last V_{k+1} and `q` the Q-function of the last sweep,
/// computed from V_k (the greedy policy of `q` is the spec's policy). The sweep is
/// synchronous (Jacobi): `q` doubles as the second buffer, so no other storage is needed.
///
/// Errors: a bad `gamma` or `rule`; wrong storage lengths (see [`q_from_values`]); model
/// errors or non-finite model values.
pub fn value_iteration<T: Real, M: FiniteMdp<T>>(
    mdp: &M,
    gamma: T,
    rule: StoppingRule<T>,
    values: &mut [T],
    q: &mut [T],
) -> Result<Convergence<T>> {
    check_gamma(gamma)?;
    rule.validate()?;
    let pairs = pair_count(mdp)?;
    check_len(values.len(), mdp.num_states(), "values")?;
    check_len(q.len(), pairs, "q")?;
    let actions = mdp.num_actions();
    values.iter_mut().for_each(|v| *v = T::ZERO);
    let mut residual = T::INFINITY;
    for sweep in 1..=rule.max_sweeps {
        q_from_values(mdp, gamma, values, q)?;
        residual = T::ZERO;
        for (v, row) in values.iter_mut().zip(q.chunks_exact(actions)) {
            let best = row.iter().copied().fold(T::NEG_INFINITY, T::max);
            crate::error::ensure_finite(best, "q")?;
            residual = residual.max((best - *v).abs());
            *v = best;
        }
        if residual < rule.tolerance || residual == T::ZERO {
            return Ok(Convergence {
                sweeps: sweep,
                residual,
                converged: true,
            });
        }
    }
    Ok(Convergence {
        sweeps: rule.max_sweeps,
        residual,
        converged: false,
    })
}

/// Exact evaluation of a deterministic policy: V^π(s) = r(s, π(s)) + γ Σ_{s′} p(s′|s,
/// π(s)) V^π(s′), solved iteratively from V ≡ 0 until a sweep changes no value by
/// `rule.tolerance` or more.
///
/// The sweep is in place (Gauss–Seidel): it converges to the same fixed point as the
/// synchronous sweep, at least as fast, and needs only `values` (|𝒮| entries). With the
/// default rule (10⁻¹⁰) the error is below 10⁻¹⁰·γ/(1−γ) in `f64`.
///
/// Errors: a bad `gamma` or `rule`; `policy` or `values` not one entry per state; an
/// action out of range; model errors. On error `values` may be partly written.
pub fn evaluate_policy<T: Real, M: FiniteMdp<T>>(
    mdp: &M,
    policy: &[usize],
    gamma: T,
    rule: StoppingRule<T>,
    values: &mut [T],
) -> Result<Convergence<T>> {
    check_gamma(gamma)?;
    rule.validate()?;
    pair_count(mdp)?;
    let states = mdp.num_states();
    check_len(policy.len(), states, "policy")?;
    check_len(values.len(), states, "values")?;
    if policy.iter().any(|&a| a >= mdp.num_actions()) {
        return Err(Error::OutOfRange {
            parameter: "policy",
        });
    }
    values.iter_mut().for_each(|v| *v = T::ZERO);
    let mut residual = T::INFINITY;
    for sweep in 1..=rule.max_sweeps {
        residual = T::ZERO;
        for (s, &a) in policy.iter().enumerate() {
            let updated = backup(mdp, gamma, values, s, a)?;
            crate::error::ensure_finite(updated, "values")?;
            let slot = values
                .get_mut(s)
                .ok_or(Error::OutOfRange { parameter: "state" })?;
            residual = residual.max((updated - *slot).abs());
            *slot = updated;
        }
        if residual < rule.tolerance || residual == T::ZERO {
            return Ok(Convergence {
                sweeps: sweep,
                residual,
                converged: true,
            });
        }
    }
    Ok(Convergence {
        sweeps: rule.max_sweeps,
        residual,
        converged: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::GridWorld;

    /// A three-state chain 0 → 1 → 2, state 2 loops with reward 1; action 1 stays put
    /// with reward 0. Hand-solved: V*(2) = 1/(1−γ), V*(1) = γ V*(2), V*(0) = γ² V*(2).
    struct Chain;

    impl FiniteMdp<f64> for Chain {
        fn num_states(&self) -> usize {
            3
        }
        fn num_actions(&self) -> usize {
            2
        }
        fn initial_state(&self) -> usize {
            0
        }
        fn transition_probability(&self, s: usize, a: usize, n: usize) -> Result<f64> {
            let mut p = 0.0;
            self.for_each_successor(s, a, |m, q| {
                if m == n {
                    p = q
                }
            })?;
            Ok(p)
        }
        fn for_each_successor<F: FnMut(usize, f64)>(
            &self,
            s: usize,
            a: usize,
            mut visit: F,
        ) -> Result<()> {
            if s >= 3 || a >= 2 {
                return Err(Error::OutOfRange { parameter: "state" });
            }
            visit(if a == 0 { (s + 1).min(2) } else { s }, 1.0);
            Ok(())
        }
        fn reward_mean(&self, s: usize, a: usize) -> Result<f64> {
            Ok(if s == 2 && a == 0 { 1.0 } else { 0.0 })
        }
        fn reward_variance(&self, _: usize, _: usize) -> Result<f64> {
            Ok(1.0)
        }
    }

    #[test]
    fn value_iteration_matches_the_hand_solved_chain() {
        let gamma = 0.9;
        let mut v = [0.0; 3];
        let mut q = [0.0; 6];
        let c = value_iteration(&Chain, gamma, StoppingRule::default(), &mut v, &mut q).unwrap();
        assert!(c.converged && c.residual < 1e-10);
        let v2 = 1.0 / (1.0 - gamma);
        let want = [gamma * gamma * v2, gamma * v2, v2];
        for (got, want) in v.iter().zip(want) {
            assert!((got - want).abs() < 1e-8, "{got} vs {want}");
        }
        // Q(0, stay) = γ V*(0), Q(0, go) = γ V*(1).
        assert!((q[1] - gamma * want[0]).abs() < 1e-8);
        assert!((q[0] - gamma * want[1]).abs() < 1e-8);
        let mut pi = [9; 3];
        greedy_policy(&q, 2, &mut pi).unwrap();
        assert_eq!(pi, [0, 0, 0]);
        let mut ve = [0.0; 3];
        evaluate_policy(&Chain, &pi, gamma, StoppingRule::default(), &mut ve).unwrap();
        for (a, b) in ve.iter().zip(want) {
            assert!((a - b).abs() < 1e-8);
        }
        // Always staying earns nothing anywhere except... nowhere: V = 0.
        evaluate_policy(&Chain, &[1, 1, 1], gamma, StoppingRule::default(), &mut ve).unwrap();
        assert_eq!(ve, [0.0; 3]);
    }

    #[test]
    fn grid_world_optimal_value_is_the_discounted_distance_to_the_goal() {
        // Goal (9, 9), non-absorbing: walk there in 18 steps, then bounce off a wall and
        // stay: V*(s0) = γ^18 / (1 − γ) since reward 1 is earned at the goal for any action
        // and "up" at the top wall keeps the agent on the goal.
        let g = GridWorld::<f64>::thesis(0, false).unwrap();
        let mut v = [0.0; 100];
        let mut q = [0.0; 400];
        value_iteration(&g, 0.9, StoppingRule::default(), &mut v, &mut q).unwrap();
        let want = 0.9f64.powi(18) / 0.1;
        assert!((v[0] - want).abs() < 1e-8, "{} vs {want}", v[0]);
        // In f32 the fixed point is reached up to rounding.
        let g32 = GridWorld::<f32>::thesis(0, false).unwrap();
        let mut v32 = [0.0f32; 100];
        let mut q32 = [0.0f32; 400];
        let c = value_iteration(&g32, 0.9, StoppingRule::default(), &mut v32, &mut q32).unwrap();
        assert!(c.converged, "f32 must reach a fixed point: {c:?}");
        assert!((v32[0] as f64 - want).abs() < 1e-4);
    }

    #[test]
    fn greedy_ties_go_to_the_smallest_action() {
        assert_eq!(greedy_action(&[1.0f32, 3.0, 3.0, 2.0]).unwrap(), 1);
        assert_eq!(greedy_action(&[0.0f64; 4]).unwrap(), 0);
        assert_eq!(greedy_action::<f64>(&[]), Err(Error::EmptyData));
        assert_eq!(
            greedy_action(&[0.0, f64::NAN]),
            Err(Error::NonFinite { parameter: "q" })
        );
    }

    #[test]
    fn bad_arguments_are_rejected_before_writing() {
        let mut v = [7.0; 3];
        let mut q = [7.0; 6];
        for gamma in [1.0, -0.1, f64::NAN] {
            assert!(
                value_iteration(&Chain, gamma, StoppingRule::default(), &mut v, &mut q).is_err()
            );
        }
        assert_eq!(
            value_iteration(&Chain, 0.9, StoppingRule::default(), &mut v, &mut q[..5]),
            Err(Error::CapacityExceeded { capacity: 5 })
        );
        let rule = StoppingRule {
            tolerance: -1.0,
            max_sweeps: 10,
        };
        assert!(value_iteration(&Chain, 0.9, rule, &mut v, &mut q).is_err());
        assert_eq!(v, [7.0; 3]);
        assert_eq!(q, [7.0; 6]);
        assert_eq!(
            evaluate_policy(&Chain, &[0, 2, 0], 0.9, StoppingRule::default(), &mut v),
            Err(Error::OutOfRange {
                parameter: "policy"
            })
        );
        assert_eq!(v, [7.0; 3]);
        let mut pi = [5usize; 2];
        assert!(greedy_policy(&q, 2, &mut pi).is_err());
        assert_eq!(pi, [5, 5]);
    }

    #[test]
    fn max_sweeps_stops_an_unconverged_iteration() {
        let rule = StoppingRule {
            tolerance: 0.0,
            max_sweeps: 3,
        };
        let mut v = [0.0; 3];
        let mut q = [0.0; 6];
        let c = value_iteration(&Chain, 0.9, rule, &mut v, &mut q).unwrap();
        assert!(!c.converged);
        assert_eq!(c.sweeps, 3);
        // After 3 sweeps: V3(2) = 1 + 0.9 + 0.81.
        assert!((v[2] - 2.71).abs() < 1e-12);
    }
}
