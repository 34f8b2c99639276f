//! How a step's budget is spent, by one rule for every plant and every budget schedule:
//! the sub-batches (re-planning points), the share of each spent on verification rollouts,
//! and how long each rollout runs, from the budget per step, the horizon and the start
//! states alone (no per-plant setting of these).
//!
//! **The rule** ([`Schedule::rule`]):
//! - sub-batches `S = clamp(⌊n / SUB_BATCH_QUERIES⌋, 1, MAX_SUB_BATCHES)`: re-planning inside
//!   the step is worth most when each sub-batch still holds a verification rollout and a
//!   few drawn queries; below [`SUB_BATCH_QUERIES`] queries a sub-batch verifies too few
//!   steps of the path for its re-plan to be more than noise;
//! - verification share [`VERIFY_SHARE`] of every sub-batch;
//! - rollout length `L = min(H, max(1, ⌈V / m⌉))` with `V = round(n · VERIFY_SHARE)` the
//!   step's verification queries and `m` the start states: a step verifies every start
//!   state once, each for an equal share of the verification queries, and no rollout runs
//!   past the horizon `H`.
//!
//! With one start state and 50 queries a step (Puddle World, the Dam) the rule gives the
//! settings the loop was tuned with: 3 sub-batches, 70 % verification, rollouts cut only by
//! the sub-batch's quota or the horizon.

use crate::float::Real;

/// Queries a sub-batch needs at least for the rule to add one (see the module docs).
pub const SUB_BATCH_QUERIES: usize = 16;

/// Most sub-batches a step is split into (more were no better on Puddle World).
pub const MAX_SUB_BATCHES: usize = 3;

/// Share of each sub-batch spent on verification rollouts.
pub const VERIFY_SHARE: f64 = 0.7;

/// What the rule derives for one budget schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Schedule<T> {
    /// Sub-batches per step.
    pub sub_batches: usize,
    /// Share of each sub-batch spent on verification rollouts.
    pub verify: T,
    /// Most steps of one verification rollout.
    pub rollout: usize,
}

impl<T: Real> Schedule<T> {
    /// The rule (module docs) for `budget` queries a step, episodes of `horizon` steps and
    /// `starts` start states (0 counts as 1).
    pub fn rule(budget: usize, horizon: usize, starts: usize) -> Self {
        let sub_batches = (budget / SUB_BATCH_QUERIES).clamp(1, MAX_SUB_BATCHES);
        let verify = T::from_f64(VERIFY_SHARE);
        Self {
            sub_batches,
            verify,
            rollout: rollout_length(budget, verify, horizon, starts),
        }
    }
}

/// The verification queries of a step of `budget` queries at share `verify`.
pub fn verification_queries<T: Real>(budget: usize, verify: T) -> usize {
    let v = (T::from_usize(budget) * verify + T::from_f64(0.5)).floor();
    v.to_usize_saturating().min(budget)
}

/// Most steps of a verification rollout: `min(horizon, max(1, ⌈V / starts⌉))`, `V` the
/// step's verification queries, `starts` at least 1; `horizon` itself when the step has
/// no verification.
pub fn rollout_length<T: Real>(budget: usize, verify: T, horizon: usize, starts: usize) -> usize {
    let v = verification_queries(budget, verify);
    if v == 0 {
        return horizon.max(1);
    }
    v.div_ceil(starts.max(1)).clamp(1, horizon.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifty_queries_and_one_start_give_the_tuned_settings() {
        let s = Schedule::<f64>::rule(50, 50, 1);
        assert_eq!(s.sub_batches, 3);
        assert!((s.verify - 0.7).abs() < 1e-12);
        // 35 verification queries from one start: the horizon and the quotas cut first.
        assert_eq!(s.rollout, 35);
    }

    #[test]
    fn small_budgets_get_fewer_sub_batches_and_large_ones_at_most_three() {
        assert_eq!(Schedule::<f32>::rule(25, 40, 1).sub_batches, 1);
        assert_eq!(Schedule::<f32>::rule(32, 40, 1).sub_batches, 2);
        assert_eq!(Schedule::<f32>::rule(5, 40, 1).sub_batches, 1);
        assert_eq!(Schedule::<f32>::rule(500, 40, 1).sub_batches, 3);
    }

    #[test]
    fn every_start_gets_an_equal_share_of_the_verification() {
        // 35 verification queries over 4 starts: rollouts of 9 steps.
        assert_eq!(Schedule::<f64>::rule(50, 40, 4).rollout, 9);
        // 18 over 4: 5.
        assert_eq!(Schedule::<f64>::rule(25, 40, 4).rollout, 5);
        // Never past the horizon, never 0.
        assert_eq!(Schedule::<f64>::rule(500, 40, 1).rollout, 40);
        assert_eq!(Schedule::<f64>::rule(1, 40, 9).rollout, 1);
        assert_eq!(rollout_length(10, 0.0, 7, 2), 7);
    }
}
