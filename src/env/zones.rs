//! Three heated zones in a row (the zones firmware example's plant): each zone loses heat
//! to the outside and exchanges heat with its neighbours, and one heater is switched
//! between the zones.
//!
//! State `[t₁, t₂, t₃]`: each zone's temperature, normalised to `[0, 1]`. Actions: 0 =
//! heater off, 1–3 = heat zone 1–3. One step, per zone `i`:
//! `tᵢ′ = tᵢ + 0.1·(0.2 − tᵢ) + 0.05·(neighbours' differences) + 0.25·[a = i]`, plus
//! 𝒩(0, 0.02²) noise, clamped into `[0, 1]`. The reward is the comfort
//! `−|t₁ − 0.6| − |t₂ − 0.6| − |t₃ − 0.6| − (heating cost 0.05 when the heater is on)`
//! plus 𝒩(0, 0.05²) noise. Nothing is absorbing; a day is [`ZONES_HORIZON`] = 40 periods
//! discounted by 0.95.
//!
//! The buildings share the physics, not the comfort rule ([`Building`]): the target and two
//! sources whose rewards differ from the target's in half of the state space each.

use super::unit_box;
use crate::error::Result;
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use rand_core::Rng;

/// Zones (the state dimension).
pub const ZONES: usize = 3;
/// Actions: heater off, heat zone 1, 2 or 3.
pub const ZONES_ACTIONS: usize = 4;
/// The comfort temperature every zone of the target should hold.
pub const ZONES_SETPOINT: f64 = 0.6;
/// Discount of the task.
pub const ZONES_DISCOUNT: f64 = 0.95;
/// Control periods per episode (a day).
pub const ZONES_HORIZON: usize = 40;
/// The evaluation's start states: a cold morning, a warm afternoon and two uneven ones.
pub const ZONES_STARTS: [[f64; ZONES]; 4] = [
    [0.2, 0.2, 0.2],
    [0.7, 0.6, 0.8],
    [0.3, 0.8, 0.4],
    [0.9, 0.3, 0.1],
];

/// Heat loss to the outside per period (a share of the gap to the outside temperature).
const LOSS: f64 = 0.1;
/// The outside temperature.
const OUTSIDE: f64 = 0.2;
/// Heat exchange with each neighbouring zone per period.
const COUPLING: f64 = 0.05;
/// Temperature rise of the heated zone per period.
const GAIN: f64 = 0.25;
/// Standard deviation of each zone's temperature noise per period.
const STATE_NOISE: f64 = 0.02;
/// Standard deviation of the measured comfort (the reward's noise).
const REWARD_NOISE: f64 = 0.05;

/// Whose comfort is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Building {
    /// The target: every zone at 0.6, heating costs 0.05 a period.
    Target,
    /// The east wing: as the target while zone 1 is below 0.5; above, its third zone is a
    /// store room held at 0.3.
    East,
    /// The west wing: as the target while zone 1 is at 0.5 or above; below, heating costs
    /// 0.4 a period (a night tariff).
    West,
}

/// Three zones in a row, scored by one building's comfort rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zones<T> {
    building: Building,
    _scalar: core::marker::PhantomData<T>,
}

impl<T: Real> Zones<T> {
    /// The plant scored by `building`'s comfort rule.
    pub const fn new(building: Building) -> Self {
        Self {
            building,
            _scalar: core::marker::PhantomData,
        }
    }

    /// The target building.
    pub const fn target() -> Self {
        Self::new(Building::Target)
    }

    /// The two sources: the east and the west wing.
    pub const fn sources() -> [Self; 2] {
        [Self::new(Building::East), Self::new(Building::West)]
    }

    /// Whose comfort rule scores the periods.
    pub fn building(&self) -> Building {
        self.building
    }

    /// The noise-free next temperatures (before clamping) and comfort of `state` under
    /// `action`; checks nothing.
    pub fn mean_unchecked(&self, s: [T; ZONES], action: usize) -> ([T; ZONES], T) {
        let c = T::from_f64;
        let mut next = s;
        let at = |k: usize| s.get(k).copied().unwrap_or(T::ZERO);
        for (i, t) in next.iter_mut().enumerate() {
            let here = at(i);
            let left = if i > 0 { at(i - 1) - here } else { T::ZERO };
            let right = if i + 1 < ZONES {
                at(i + 1) - here
            } else {
                T::ZERO
            };
            let heat = if action == i + 1 { c(GAIN) } else { T::ZERO };
            *t = here + c(LOSS) * (c(OUTSIDE) - here) + c(COUPLING) * (left + right) + heat;
        }
        let (mut third, mut energy) = (c(ZONES_SETPOINT), c(0.05));
        match self.building {
            Building::Target => {}
            Building::East if s[0] >= c(0.5) => third = c(0.3),
            Building::West if s[0] < c(0.5) => energy = c(0.4),
            _ => {}
        }
        let setpoint = c(ZONES_SETPOINT);
        let discomfort = (s[0] - setpoint).abs() + (s[1] - setpoint).abs() + (s[2] - third).abs();
        let cost = if action == 0 { T::ZERO } else { energy };
        (next, -discomfort - cost)
    }

    /// The mean reward at `(state, action)`.
    ///
    /// Errors: a state outside `[0, 1]³` or an action `>= 4`.
    pub fn mean_reward(&self, state: [T; ZONES], action: usize) -> Result<T> {
        unit_box::check(state, action, ZONES_ACTIONS)?;
        Ok(self.mean_unchecked(state, action).1)
    }

    /// The noise-free next state, clamped into `[0, 1]³`.
    ///
    /// Errors: as [`Zones::mean_reward`].
    pub fn mean_next_state(&self, state: [T; ZONES], action: usize) -> Result<[T; ZONES]> {
        unit_box::check(state, action, ZONES_ACTIONS)?;
        Ok(unit_box::clamped(self.mean_unchecked(state, action).0))
    }
}

impl<T: Real> GenerativeModel<T> for Zones<T> {
    type State = [T; ZONES];

    fn num_actions(&self) -> usize {
        ZONES_ACTIONS
    }

    /// One step as the module docs say: three normal draws for the temperatures, one for
    /// the comfort.
    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; ZONES],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; ZONES], T>> {
        unit_box::check(state, action, ZONES_ACTIONS)?;
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

/// The hand-written rule: heat the zone furthest below the setpoint when it is more than
/// 0.05 below, else switch the heater off.
pub fn zones_thermostat<T: Real>(s: &[T; ZONES]) -> usize {
    let (mut action, mut worst) = (0, T::from_f64(0.05));
    for (i, &t) in s.iter().enumerate() {
        let gap = T::from_f64(ZONES_SETPOINT) - t;
        if gap > worst {
            (action, worst) = (i + 1, gap);
        }
    }
    action
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn heating_warms_the_heated_zone_and_costs_energy() {
        let z = Zones::<f64>::target();
        let s = [0.6, 0.6, 0.6];
        let (off, r_off) = z.mean_unchecked(s, 0);
        let (on, r_on) = z.mean_unchecked(s, 2);
        // Off: every zone loses 0.1·(0.6 − 0.2) = 0.04, no exchange between equal zones.
        for t in off {
            assert!((t - 0.56).abs() < 1e-12);
        }
        assert!((on[1] - 0.81).abs() < 1e-12);
        assert!((r_off - 0.0).abs() < 1e-12 && (r_on + 0.05).abs() < 1e-12);
        // The east wing keeps its third zone at 0.3 once zone 1 is warm.
        let east = Zones::<f64>::new(Building::East);
        assert!((east.mean_reward(s, 0).unwrap() + 0.3).abs() < 1e-12);
        assert!(z.mean_reward([1.1, 0.0, 0.0], 0).is_err());
        assert!(z.mean_reward(s, 4).is_err());
    }

    #[test]
    fn samples_scatter_around_the_mean_within_the_box() {
        let z = Zones::<f64>::target();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let s = [0.3, 0.5, 0.9];
        let mean = z.mean_next_state(s, 1).unwrap();
        let n = 4000;
        let mut sum = [0.0; ZONES];
        for _ in 0..n {
            let t = z.query(s, 1, &mut rng).unwrap();
            for (acc, x) in sum.iter_mut().zip(t.next_state) {
                assert!((0.0..=1.0).contains(&x));
                *acc += x;
            }
        }
        for (acc, m) in sum.iter().zip(mean) {
            // Standard error 0.02/√4000 ≈ 3·10⁻⁴.
            assert!((acc / n as f64 - m).abs() < 1.5e-3, "{acc} {m}");
        }
        assert_eq!(zones_thermostat(&[0.2, 0.5, 0.6]), 1);
        assert_eq!(zones_thermostat(&[0.58, 0.6, 0.6]), 0);
    }
}
