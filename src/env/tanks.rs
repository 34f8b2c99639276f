//! Two tanks in cascade fed and drained by two pumps whose speeds ramp (written for the
//! plant suite): a four-state plant, nine actions.
//!
//! State `[h₁, h₂, p₁, p₂]`: both tanks' levels and both pumps' speeds, each normalised to
//! `[0, 1]`. Action `a = 3i + j` moves pump 1's speed by `0.1·(i − 1)` and pump 2's by
//! `0.1·(j − 1)` (down, hold, up). One step (gains of the target; see [`Plantroom`]):
//!
//! - `h₁′ = h₁ + g·p₁ − 0.12·h₁` (pump 1 fills tank 1, `g = 0.2`, which drains into tank 2);
//! - `h₂′ = h₂ + 0.12·h₁ − 0.15·p₂ − 0.02` (pump 2 drains tank 2; a small constant draw);
//! - `p₁′ = p₁ + 0.1·(i − 1)`, `p₂′ = p₂ + 0.1·(j − 1)`;
//!
//! each plus 𝒩(0, 0.01²) noise, clamped into `[0, 1]`. The reward is
//! `−|h₁ − 0.5| − |h₂ − h₂*| − 0.02·(p₁ + p₂)` (`h₂* = 0.5`) plus 𝒩(0, 0.02²) noise.
//! Nothing is absorbing; an episode is [`TANKS_HORIZON`] = 50 periods discounted by 0.95.
//!
//! The sources agree with the target on part of the problem ([`Plantroom`]): one holds tank
//! 2 at another level (its rewards differ, its physics is the target's), one has a worn pump
//! 1 (its physics differs, its rewards are the target's).

use super::unit_box;
use crate::error::Result;
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use rand_core::Rng;

/// State dimension.
pub const TANKS_DIM: usize = 4;
/// Actions: each pump down, hold or up.
pub const TANKS_ACTIONS: usize = 9;
/// Discount of the task.
pub const TANKS_DISCOUNT: f64 = 0.95;
/// Periods per episode.
pub const TANKS_HORIZON: usize = 50;
/// The level both tanks of the target hold.
pub const TANKS_SETPOINT: f64 = 0.5;
/// The evaluation's start states: empty and still, full and running, and two uneven ones.
pub const TANKS_STARTS: [[f64; TANKS_DIM]; 4] = [
    [0.1, 0.1, 0.0, 0.0],
    [0.9, 0.9, 0.5, 0.5],
    [0.2, 0.8, 0.0, 1.0],
    [0.7, 0.2, 1.0, 0.0],
];

/// Tank 1's outflow into tank 2 per period (a share of its level).
const OUTFLOW: f64 = 0.12;
/// Pump 2's draw from tank 2 at full speed.
const DRAIN: f64 = 0.15;
/// Tank 2's constant draw per period.
const DRAW: f64 = 0.02;
/// A pump's speed change per action.
const RAMP: f64 = 0.1;
/// Energy cost per unit of pump speed.
const ENERGY: f64 = 0.02;
/// Standard deviation of each state coordinate's noise per period.
const STATE_NOISE: f64 = 0.01;
/// Standard deviation of the reward's noise.
const REWARD_NOISE: f64 = 0.02;

/// Which plant room: the target or one of its sources.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Plantroom {
    /// Pump 1's gain 0.2; both tanks held at 0.5.
    Target,
    /// The target's physics; tank 2 held at 0.3 (rewards differ only).
    Recipe,
    /// A worn pump 1 (gain 0.12); the target's levels (dynamics differ only).
    Worn,
}

/// The two tanks of the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tanks<T> {
    room: Plantroom,
    _scalar: core::marker::PhantomData<T>,
}

impl<T: Real> Tanks<T> {
    /// The plant of `room`.
    pub const fn new(room: Plantroom) -> Self {
        Self {
            room,
            _scalar: core::marker::PhantomData,
        }
    }

    /// The target.
    pub const fn target() -> Self {
        Self::new(Plantroom::Target)
    }

    /// The sources: the target's own plant, another recipe, the worn pump.
    pub const fn sources() -> [Self; 3] {
        [
            Self::new(Plantroom::Target),
            Self::new(Plantroom::Recipe),
            Self::new(Plantroom::Worn),
        ]
    }

    /// Which plant room.
    pub fn room(&self) -> Plantroom {
        self.room
    }

    /// `(pump 1's gain, tank 2's setpoint)`.
    fn constants(&self) -> (f64, f64) {
        match self.room {
            Plantroom::Target => (0.2, TANKS_SETPOINT),
            Plantroom::Recipe => (0.2, 0.3),
            Plantroom::Worn => (0.12, TANKS_SETPOINT),
        }
    }

    /// The noise-free next state (before clamping) and reward; checks nothing (an action
    /// out of range holds both pumps).
    pub fn mean_unchecked(
        &self,
        [h1, h2, p1, p2]: [T; TANKS_DIM],
        action: usize,
    ) -> ([T; TANKS_DIM], T) {
        let c = T::from_f64;
        let (gain, level) = self.constants();
        let action = if action < TANKS_ACTIONS { action } else { 4 };
        let step = |k: usize| c(RAMP) * (c(k as f64) - T::ONE);
        let next = [
            h1 + c(gain) * p1 - c(OUTFLOW) * h1,
            h2 + c(OUTFLOW) * h1 - c(DRAIN) * p2 - c(DRAW),
            p1 + step(action / 3),
            p2 + step(action % 3),
        ];
        let half = c(TANKS_SETPOINT);
        let reward = -(h1 - half).abs() - (h2 - c(level)).abs() - c(ENERGY) * (p1 + p2);
        (next, reward)
    }

    /// The mean reward at `(state, action)`.
    ///
    /// Errors: a state outside `[0, 1]⁴` or an action `>= 9`.
    pub fn mean_reward(&self, state: [T; TANKS_DIM], action: usize) -> Result<T> {
        unit_box::check(state, action, TANKS_ACTIONS)?;
        Ok(self.mean_unchecked(state, action).1)
    }

    /// The noise-free next state, clamped into `[0, 1]⁴`.
    ///
    /// Errors: as [`Tanks::mean_reward`].
    pub fn mean_next_state(&self, state: [T; TANKS_DIM], action: usize) -> Result<[T; TANKS_DIM]> {
        unit_box::check(state, action, TANKS_ACTIONS)?;
        Ok(unit_box::clamped(self.mean_unchecked(state, action).0))
    }
}

impl<T: Real> GenerativeModel<T> for Tanks<T> {
    type State = [T; TANKS_DIM];

    fn num_actions(&self) -> usize {
        TANKS_ACTIONS
    }

    /// One step as the module docs say: four normal draws for the state, one for the
    /// reward.
    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; TANKS_DIM],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; TANKS_DIM], T>> {
        unit_box::check(state, action, TANKS_ACTIONS)?;
        let noise = (T::from_f64(STATE_NOISE), T::from_f64(REWARD_NOISE));
        Ok(unit_box::noisy_step(
            state,
            action,
            self.mean_unchecked(state, action),
            noise,
            rng,
        ))
    }
}

/// The hand-written rule: a proportional controller per pump around the target's
/// equilibrium speeds (0.3 and 0.27), gain 2, moving each pump by one step when its wanted
/// speed is more than 0.05 away.
pub fn tanks_proportional<T: Real>(s: &[T; TANKS_DIM]) -> usize {
    let c = T::from_f64;
    let half = c(TANKS_SETPOINT);
    let want = [
        (c(0.3) + c(2.0) * (half - s[0])).clamp_to(T::ZERO, T::ONE),
        (c(0.27) + c(2.0) * (s[1] - half)).clamp_to(T::ZERO, T::ONE),
    ];
    let mv = |want: T, now: T| {
        if want > now + c(0.05) {
            2
        } else if want < now - c(0.05) {
            0
        } else {
            1
        }
    };
    3 * mv(want[0], s[2]) + mv(want[1], s[3])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_s_equilibrium_holds_both_levels() {
        let t = Tanks::<f64>::target();
        // At h = 0.5, p₁ = 0.3, p₂ = 0.8/3 the levels stay.
        let s = [0.5, 0.5, 0.3, 0.04 / 0.15];
        let (next, reward) = t.mean_unchecked(s, 4);
        for (a, b) in next.iter().zip(s) {
            assert!((a - b).abs() < 1e-12, "{next:?}");
        }
        assert!((reward + 0.02 * (0.3 + 0.04 / 0.15)).abs() < 1e-12);
        // Action 8 raises both pumps, 0 lowers both.
        let up = t.mean_unchecked(s, 8).0;
        let down = t.mean_unchecked(s, 0).0;
        assert!((up[2] - 0.4).abs() < 1e-12 && (down[3] - (s[3] - 0.1)).abs() < 1e-12);
        assert!(t.mean_reward(s, 9).is_err());
        assert!(t.mean_reward([0.5, 0.5, 0.5, f64::NAN], 0).is_err());
    }

    #[test]
    fn sources_differ_from_the_target_in_reward_or_in_dynamics_only() {
        let s = [0.4, 0.6, 0.5, 0.2];
        let target = Tanks::<f64>::target();
        let recipe = Tanks::<f64>::new(Plantroom::Recipe);
        let worn = Tanks::<f64>::new(Plantroom::Worn);
        for a in 0..TANKS_ACTIONS {
            let (tn, tr) = target.mean_unchecked(s, a);
            let (n, r) = recipe.mean_unchecked(s, a);
            assert_eq!(n, tn);
            // |0.6 − 0.3| against |0.6 − 0.5|.
            assert!((r - (tr - 0.2)).abs() < 1e-12);
            let (n, r) = worn.mean_unchecked(s, a);
            assert_eq!(r, tr);
            assert!((n[0] - (tn[0] - 0.08 * 0.5)).abs() < 1e-12);
        }
    }

    #[test]
    fn the_controller_fills_an_empty_plant_and_drains_a_full_one() {
        // Tank 1 empty: pump 1 up; tank 2 empty: pump 2 wants 0, already 0: hold.
        assert_eq!(tanks_proportional(&[0.1f64, 0.1, 0.0, 0.0]), 3 * 2 + 1);
        // Both full: pump 1 down, pump 2 up.
        assert_eq!(tanks_proportional(&[0.9f64, 0.9, 0.5, 0.5]), 2);
    }
}
