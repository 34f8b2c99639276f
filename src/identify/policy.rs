//! Policies from a belief: the belief-weighted greedy policy (beyond the thesis).
//!
//! The thesis's eq. 4.16 asks for the policy that maximises the belief-averaged return,
//! and leaves it open; it uses the MAP candidate's optimal policy instead, which ignores
//! every other candidate however much mass it has. The belief-weighted policy is greedy
//! in Σ_θ b_θ Q*_θ(s, a): the expected optimal action value if the agent learned the true
//! candidate right after this step (the "QMDP" approximation). It equals the MAP policy
//! once the belief is sharp, and hedges (heads for goals several candidates share, or
//! between them) while it is not.

use crate::error::{Error, Result};

use crate::float::Real;

/// Σ_θ b_θ Q_θ / Σ_θ b_θ into `out`.
///
/// `q_tables` holds the K tables one after another (candidate-major, each |𝒮|·|𝒜|
/// entries, index `s·|𝒜| + a`); `belief` one non-negative weight per candidate (need not
/// be normalised); `out` one table.
///
/// Errors: a bad belief (see [`super::compute_score`]); `q_tables.len()` not `K·out.len()`
/// ([`Error::InvalidParameter`] naming `q_tables`); an empty `out`; a non-finite Q value.
/// `out` is written only after all inputs were checked.
pub fn belief_weighted_q<T: Real>(q_tables: &[T], belief: &[T], out: &mut [T]) -> Result<()> {
    if out.is_empty() {
        return Err(Error::EmptyData);
    }
    let total = super::belief_total(belief, belief.len())?;
    if belief.len().checked_mul(out.len()) != Some(q_tables.len()) {
        return Err(Error::InvalidParameter {
            parameter: "q_tables",
        });
    }
    crate::error::ensure_all_finite(q_tables, "q_tables")?;
    out.iter_mut().for_each(|o| *o = T::ZERO);
    for (table, &b) in q_tables.chunks_exact(out.len()).zip(belief) {
        if b > T::ZERO {
            let w = b / total;
            for (o, &q) in out.iter_mut().zip(table) {
                *o += w * q;
            }
        }
    }
    Ok(())
}

/// The greedy policy of Σ_θ b_θ Q_θ into `policy` (one action per state, ties to the
/// smallest action), using `q_scratch` (|𝒮|·|𝒜| entries) for the weighted table.
///
/// Errors: as [`belief_weighted_q`] and [`crate::planning::greedy_policy`].
pub fn belief_weighted_policy<T: Real>(
    q_tables: &[T],
    belief: &[T],
    num_actions: usize,
    q_scratch: &mut [T],
    policy: &mut [usize],
) -> Result<()> {
    if num_actions == 0 || q_scratch.len() % num_actions != 0 {
        return Err(Error::InvalidParameter {
            parameter: "num_actions",
        });
    }
    crate::planning::check_len(policy.len(), q_scratch.len() / num_actions, "policy")?;
    belief_weighted_q(q_tables, belief, q_scratch)?;
    crate::planning::greedy_policy(q_scratch, num_actions, policy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weighted_q_is_the_belief_average() {
        // Two candidates, one state, two actions.
        let q = [1.0f64, 0.0, 0.0, 3.0];
        let mut out = [0.0; 2];
        belief_weighted_q(&q, &[3.0, 1.0], &mut out).unwrap();
        assert_eq!(out, [0.75, 0.75]);
        let mut pi = [9];
        belief_weighted_policy(&q, &[3.0, 1.0], 2, &mut out, &mut pi).unwrap();
        assert_eq!(pi, [0], "tie goes to the smallest action");
        belief_weighted_policy(&q, &[0.5, 0.5], 2, &mut out, &mut pi).unwrap();
        assert_eq!(pi, [1]);
        // A sharp belief gives that candidate's greedy policy.
        belief_weighted_policy(&q, &[1.0, 0.0], 2, &mut out, &mut pi).unwrap();
        assert_eq!(pi, [0]);
    }

    #[test]
    fn mismatched_inputs_are_rejected() {
        let mut out = [5.0f32; 2];
        assert!(belief_weighted_q(&[1.0f32; 3], &[0.5, 0.5], &mut out).is_err());
        assert!(belief_weighted_q(&[1.0f32; 4], &[0.0, 0.0], &mut out).is_err());
        assert!(belief_weighted_q(&[1.0, f32::NAN, 1.0, 1.0], &[0.5, 0.5], &mut out).is_err());
        assert_eq!(out, [5.0; 2]);
    }
}
