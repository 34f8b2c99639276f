//! What the greedy verification rollouts say about the plan they verify: the plan promises
//! a return (its Q-function's value along the rollout) and the target answers with the
//! return it delivers. A plan whose rollouts fall well short of its promise learned its
//! values where it went from records the target contradicts; a step whose last plan
//! verified so warns ([`crate::thesis::Warning::PlanVerifiedShort`]), and with
//! [`crate::adaptive::AdaptiveConfig::safeguard`] the step spends the drawn queries of a sub-batch
//! whose plan verified short on more verification of it, so the next re-plan sees more
//! of the path the plan actually takes.

use crate::float::Real;

/// Above this shortfall per rollout step, in standard deviations of the target's rewards,
/// a verified plan counts as short of its promise (module docs).
///
/// Chosen on the tuning seeds (100–119) of the zones example (`docs/active-budget.md`).
pub const SHORTFALL_LIMIT: f64 = 0.5;

/// The greedy verification rollouts of one plan: their delivered and promised discounted
/// returns and the discount mass they span.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlanCheck<T> {
    /// Sum over the rollouts of `Σₜ γᵗ rₜ`, the returns the target delivered.
    pub delivered: T,
    /// Sum over the rollouts of `Q(s₀, a₀) − γᴸ max_a Q(s_L, a)` (without the last term when
    /// the rollout ended absorbed): what the plan's Q-function promised for the same steps.
    pub promised: T,
    /// Sum over the rollouts of `Σₜ γᵗ` over their steps.
    pub mass: T,
    /// Rollouts checked.
    pub rollouts: usize,
}

impl<T: Real> PlanCheck<T> {
    /// No rollout checked.
    pub const fn empty() -> Self {
        Self {
            delivered: T::ZERO,
            promised: T::ZERO,
            mass: T::ZERO,
            rollouts: 0,
        }
    }

    /// Adds one rollout.
    pub fn add(&mut self, delivered: T, promised: T, mass: T) {
        self.delivered += delivered;
        self.promised += promised;
        self.mass += mass;
        self.rollouts += 1;
    }

    /// The promise minus the delivery per (discounted) rollout step: positive when the plan
    /// delivered less than it promised; 0 without a rollout.
    pub fn shortfall(&self) -> T {
        if self.rollouts == 0 || self.mass <= T::ZERO {
            return T::ZERO;
        }
        (self.promised - self.delivered) / self.mass
    }

    /// Whether the shortfall exceeds [`SHORTFALL_LIMIT`] standard deviations `scale` of the
    /// target's rewards.
    pub fn is_short(&self, scale: T) -> bool {
        self.rollouts > 0
            && scale > T::ZERO
            && self.shortfall() > T::from_f64(SHORTFALL_LIMIT) * scale
    }
}

/// One rollout being checked: its delivered return, its discount so far and the promise.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rollout<T> {
    pub(crate) delivered: T,
    pub(crate) discount: T,
    pub(crate) mass: T,
    pub(crate) promised: T,
}

impl<T: Real> Rollout<T> {
    /// A rollout whose plan promises `q` for its first state and action.
    pub(crate) fn new(q: T) -> Self {
        Self {
            delivered: T::ZERO,
            discount: T::ONE,
            mass: T::ZERO,
            promised: q,
        }
    }

    /// One step of reward `r` under discount `gamma`.
    pub(crate) fn step(&mut self, r: T, gamma: T) {
        self.delivered += self.discount * r;
        self.mass += self.discount;
        self.discount *= gamma;
    }

    /// The rollout ended in a state the plan values at `v` (0 when absorbed): its promise
    /// for the steps it ran is `Q(s₀, a₀) − γᴸ v`.
    pub(crate) fn finish(self, v: T, check: &mut PlanCheck<T>) {
        check.add(self.delivered, self.promised - self.discount * v, self.mass);
    }
}

/// The standard deviation of `rewards` (0 for fewer than two).
pub(crate) fn reward_std<T: Real>(rewards: impl Iterator<Item = T> + Clone) -> T {
    let (n, sum) = rewards
        .clone()
        .fold((0usize, T::ZERO), |(n, s), r| (n + 1, s + r));
    if n < 2 {
        return T::ZERO;
    }
    let mean = sum / T::from_usize(n);
    let ss = rewards.fold(T::ZERO, |s, r| s + (r - mean).squared());
    (ss / T::from_usize(n - 1)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rollout_promised_its_q_minus_the_discounted_value_where_it_stopped() {
        let mut check = PlanCheck::<f64>::empty();
        let mut r = Rollout::new(10.0);
        for reward in [1.0, 2.0, 3.0] {
            r.step(reward, 0.5);
        }
        // Delivered 1 + 0.5·2 + 0.25·3 = 2.75; mass 1.75; promised 10 − 0.125·4 = 9.5.
        r.finish(4.0, &mut check);
        assert!((check.delivered - 2.75).abs() < 1e-12);
        assert!((check.mass - 1.75).abs() < 1e-12);
        assert!((check.promised - 9.5).abs() < 1e-12);
        assert!((check.shortfall() - (9.5 - 2.75) / 1.75).abs() < 1e-12);
        assert!(check.is_short(1.0));
        // A shortfall of 3.857 is 0.39 of a std of 10: not short.
        assert!(!check.is_short(10.0));
        assert!(!PlanCheck::<f64>::empty().is_short(1.0));
    }

    #[test]
    fn a_plan_that_delivers_its_promise_is_not_short() {
        let mut check = PlanCheck::<f64>::empty();
        let mut r = Rollout::new(1.0 + 0.9 * 1.0);
        r.step(1.0, 0.9);
        r.step(1.0, 0.9);
        r.finish(0.0, &mut check);
        assert!(check.shortfall().abs() < 1e-12);
        assert!(!check.is_short(0.1));
    }

    #[test]
    fn the_reward_std_is_the_sample_std() {
        let r = [1.0, 2.0, 3.0, 4.0];
        assert!((reward_std(r.iter().copied()) - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(reward_std([1.0f64].iter().copied()), 0.0);
    }
}
