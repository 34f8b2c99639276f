//! A heated room with a slow wall and a heater element that lags its command (written for
//! the plant suite): a three-state thermal plant whose best policy must anticipate the
//! element's lag and the wall's store of heat, which a thermostat does not.
//!
//! State `[room, wall, element]`, each normalised to `[0, 1]`. Actions: the heater command
//! `u` = 0, ½ or 1 ([`THERMAL_COMMANDS`]). One step (gains of the target; see [`Room`]):
//!
//! - `element′ = element + 0.5·(u − element)`;
//! - `room′ = room + g·element − 0.1·(room − wall) − k·(room − 0.1)`, `g = 0.25`, `k = 0.05`;
//! - `wall′ = wall + 0.05·(room − wall) − 0.03·(wall − 0.1)`;
//!
//! each plus 𝒩(0, 0.01²) noise, clamped into `[0, 1]`. The reward is
//! `−|room − 0.6| − price·u` (price 0.05) plus 𝒩(0, 0.02²) noise. Nothing is absorbing; an
//! episode is [`THERMAL_HORIZON`] = 40 periods discounted by 0.95.
//!
//! The sources agree with the target on part of the problem ([`Room`]): one pays another
//! tariff (its rewards differ, its physics is the target's), one is a leakier room with a
//! stronger heater (its physics differs, its rewards are the target's).

use super::unit_box;
use crate::error::Result;
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use rand_core::Rng;

/// State dimension.
pub const THERMAL_DIM: usize = 3;
/// Actions (heater commands).
pub const THERMAL_ACTIONS: usize = 3;
/// The heater command of each action.
pub const THERMAL_COMMANDS: [f64; THERMAL_ACTIONS] = [0.0, 0.5, 1.0];
/// The room temperature the target holds.
pub const THERMAL_SETPOINT: f64 = 0.6;
/// Discount of the task.
pub const THERMAL_DISCOUNT: f64 = 0.95;
/// Periods per episode.
pub const THERMAL_HORIZON: usize = 40;
/// The evaluation's start states: cold, overheated, a hot element in a cool room, near the
/// setpoint.
pub const THERMAL_STARTS: [[f64; THERMAL_DIM]; 4] = [
    [0.2, 0.2, 0.0],
    [0.8, 0.6, 0.0],
    [0.4, 0.3, 1.0],
    [0.6, 0.4, 0.2],
];

/// The outside temperature.
const OUTSIDE: f64 = 0.1;
/// Exchange between room and wall per period, on the room's side.
const ROOM_WALL: f64 = 0.1;
/// Exchange between wall and room per period, on the wall's side.
const WALL_ROOM: f64 = 0.05;
/// The wall's loss to the outside per period.
const WALL_LOSS: f64 = 0.03;
/// The element's approach to its command per period.
const ELEMENT_RATE: f64 = 0.5;
/// Standard deviation of each state coordinate's noise per period.
const STATE_NOISE: f64 = 0.01;
/// Standard deviation of the reward's noise.
const REWARD_NOISE: f64 = 0.02;

/// Which room: the target or one of its sources.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Room {
    /// Heater gain 0.25, the room's loss to the outside 0.05, energy price 0.05.
    Target,
    /// The target's physics at a price of 0.3 (rewards differ only).
    Tariff,
    /// A leakier room (loss 0.12) with a stronger heater (gain 0.35) at the target's price
    /// (dynamics differ only).
    Leaky,
}

/// The heated room of the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thermal<T> {
    room: Room,
    _scalar: core::marker::PhantomData<T>,
}

impl<T: Real> Thermal<T> {
    /// The plant of `room`.
    pub const fn new(room: Room) -> Self {
        Self {
            room,
            _scalar: core::marker::PhantomData,
        }
    }

    /// The target.
    pub const fn target() -> Self {
        Self::new(Room::Target)
    }

    /// The sources: the target's own room, another tariff, the leaky room.
    pub const fn sources() -> [Self; 3] {
        [
            Self::new(Room::Target),
            Self::new(Room::Tariff),
            Self::new(Room::Leaky),
        ]
    }

    /// Which room.
    pub fn room(&self) -> Room {
        self.room
    }

    /// `(heater gain, room loss, price)` of the room.
    fn constants(&self) -> (f64, f64, f64) {
        match self.room {
            Room::Target => (0.25, 0.05, 0.05),
            Room::Tariff => (0.25, 0.05, 0.3),
            Room::Leaky => (0.35, 0.12, 0.05),
        }
    }

    /// The noise-free next state (before clamping) and reward; checks nothing (an action
    /// out of range commands 0).
    pub fn mean_unchecked(
        &self,
        [room, wall, element]: [T; THERMAL_DIM],
        action: usize,
    ) -> ([T; THERMAL_DIM], T) {
        let c = T::from_f64;
        let (gain, loss, price) = self.constants();
        let u = c(THERMAL_COMMANDS.get(action).copied().unwrap_or(0.0));
        let outside = c(OUTSIDE);
        let next = [
            room + c(gain) * element - c(ROOM_WALL) * (room - wall) - c(loss) * (room - outside),
            wall + c(WALL_ROOM) * (room - wall) - c(WALL_LOSS) * (wall - outside),
            element + c(ELEMENT_RATE) * (u - element),
        ];
        (next, -(room - c(THERMAL_SETPOINT)).abs() - c(price) * u)
    }

    /// The mean reward at `(state, action)`.
    ///
    /// Errors: a state outside `[0, 1]³` or an action `>= 3`.
    pub fn mean_reward(&self, state: [T; THERMAL_DIM], action: usize) -> Result<T> {
        unit_box::check(state, action, THERMAL_ACTIONS)?;
        Ok(self.mean_unchecked(state, action).1)
    }

    /// The noise-free next state, clamped into `[0, 1]³`.
    ///
    /// Errors: as [`Thermal::mean_reward`].
    pub fn mean_next_state(
        &self,
        state: [T; THERMAL_DIM],
        action: usize,
    ) -> Result<[T; THERMAL_DIM]> {
        unit_box::check(state, action, THERMAL_ACTIONS)?;
        Ok(unit_box::clamped(self.mean_unchecked(state, action).0))
    }
}

impl<T: Real> GenerativeModel<T> for Thermal<T> {
    type State = [T; THERMAL_DIM];

    fn num_actions(&self) -> usize {
        THERMAL_ACTIONS
    }

    /// One step as the module docs say: three normal draws for the state, one for the
    /// reward.
    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; THERMAL_DIM],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; THERMAL_DIM], T>> {
        unit_box::check(state, action, THERMAL_ACTIONS)?;
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

/// The hand-written rule: full heat below 0.57, off above 0.63, half in between.
pub fn thermal_thermostat<T: Real>(s: &[T; THERMAL_DIM]) -> usize {
    if s[0] < T::from_f64(THERMAL_SETPOINT - 0.03) {
        2
    } else if s[0] > T::from_f64(THERMAL_SETPOINT + 0.03) {
        0
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_differ_from_the_target_in_reward_or_in_dynamics_only() {
        let s = [0.5, 0.4, 0.3];
        let target = Thermal::<f64>::target();
        let tariff = Thermal::<f64>::new(Room::Tariff);
        let leaky = Thermal::<f64>::new(Room::Leaky);
        for (a, u) in THERMAL_COMMANDS.iter().enumerate().take(THERMAL_ACTIONS) {
            let (tn, tr) = target.mean_unchecked(s, a);
            let (n, r) = tariff.mean_unchecked(s, a);
            assert_eq!(tn, n);
            // Price 0.3 against 0.05 on command u.
            assert!((r - (tr - 0.25 * u)).abs() < 1e-12);
            let (n, r) = leaky.mean_unchecked(s, a);
            assert_eq!(r, tr);
            // Room: +0.1·0.3 from the stronger element, −0.07·0.4 from the larger loss.
            assert!((n[0] - (tn[0] + 0.1 * 0.3 - 0.07 * 0.4)).abs() < 1e-12);
            assert_eq!((n[1], n[2]), (tn[1], tn[2]));
        }
        // By hand: room 0.5 + 0.25·0.3 − 0.1·0.1 − 0.05·0.4 = 0.545.
        assert!((target.mean_unchecked(s, 0).0[0] - 0.545).abs() < 1e-12);
        assert!(target.mean_reward([0.5, 0.5, -0.1], 0).is_err());
        assert!(target.mean_reward(s, 3).is_err());
    }

    #[test]
    fn the_thermostat_heats_a_cold_room_and_stops_in_a_warm_one() {
        assert_eq!(thermal_thermostat(&[0.2f32, 0.2, 0.0]), 2);
        assert_eq!(thermal_thermostat(&[0.6f32, 0.2, 0.0]), 1);
        assert_eq!(thermal_thermostat(&[0.7f32, 0.2, 0.0]), 0);
    }
}
