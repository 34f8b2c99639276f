//! The cyclostationary water reservoir ("Dam") of the IWFQI paper's experiments: a
//! reservoir whose storage is fed by a noisy seasonal inflow and drained by a daily release
//! decision, paying for floods and for unmet water demand.
//!
//! State `[storage, day]`: the stored volume (any finite value ≥ 0) and the day of the year
//! (an integer 1..=360). Actions are indices into the eight releases [`DAM_RELEASES`]. One
//! step (the reference's `Dam.step`, with its illegal-action penalty off as in every
//! published run):
//!
//! 1. the release is bounded into what the reservoir allows:
//!    `u = min(max(release, max(s − 500, 0)), max(s − 50, 0))`;
//! 2. the inflow is `μ_p(day) + 2ε`, ε ~ 𝒩(0, 1) (one [`rng::standard_normal`] draw);
//! 3. `s′ = max(s + inflow − u, 0)`, `day′ = day + 1` (360 wraps to 1);
//! 4. the reward, a function of the **current** storage and the bounded release only, is
//!    `α·(−max(s − 300, 0)/4) + β·(−max(10 − u, 0)²)`: α weighs the flooding cost, β the
//!    demand cost (α + β = 1).
//!
//! No state is absorbing; an episode lasts [`DAM_HORIZON`] = 360 days and is discounted by
//! γ = 0.999. The instances differ in their inflow profile `p` (one of seven seasonal
//! curves, [`InflowProfile`]) and in (α, β): [`Dam::target`] and the six sources of the
//! published experiment ([`Dam::sources`]).
//!
//! The memory of an instance is three scalars and a byte; the inflow means are computed on
//! demand (in `f64`, as the reference does, then rounded to `T`).

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use crate::rng;
use rand_core::Rng;

/// Number of actions (releases); valid actions are `0..DAM_ACTIONS`.
pub const DAM_ACTIONS: usize = 8;
/// The release of each action (volume per day), before the bounds of step 1.
pub const DAM_RELEASES: [f64; DAM_ACTIONS] = [0.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0];
/// Days per year (and per episode).
pub const DAM_DAYS: usize = 360;
/// Episode horizon H (one year).
pub const DAM_HORIZON: usize = 360;
/// Discount factor γ.
pub const DAM_DISCOUNT: f64 = 0.999;
/// Water demand: releasing less than this costs `β·(demand − u)²`.
pub const DAM_DEMAND: f64 = 10.0;
/// Flooding threshold: storing more than this costs `α·(s − threshold)/4`.
pub const DAM_FLOODING: f64 = 300.0;
/// Minimum storage: at most `max(s − 50, 0)` can be released.
pub const DAM_MIN_STORAGE: f64 = 50.0;
/// Maximum storage: at least `max(s − 500, 0)` must be released.
pub const DAM_MAX_STORAGE: f64 = 500.0;
/// Standard deviation (not variance) of the daily inflow noise.
pub const DAM_INFLOW_STD: f64 = 2.0;
/// The days an episode may start on ([`Dam::initial_state`] picks one uniformly).
pub const DAM_INITIAL_DAYS: [f64; 3] = [1.0, 120.0, 240.0];
/// The start state of the published evaluation rollouts (storage 200 on day 1).
pub const DAM_EVALUATION_STATE: [f64; 2] = [200.0, 1.0];

/// One third of a year of an inflow profile: `sin(x·3π/359 + phase)·mul/div + offset`,
/// `x = day − 1`. `mul`/`div` keep the reference's order of operations (`sin·3`, `sin/4`).
#[derive(Debug, Clone, Copy)]
struct Segment {
    mul: f64,
    div: f64,
    phase: f64,
    offset: f64,
}

const fn seg(mul: f64, div: f64, phase: f64, offset: f64) -> Segment {
    Segment {
        mul,
        div,
        phase,
        offset,
    }
}

const PI: f64 = core::f64::consts::PI;

/// The seven profiles: days 1–120, 121–240, 241–360, then `scale` and `shift` of
/// `y·scale + shift`.
const PROFILES: [([Segment; 3], f64, f64); 7] = [
    (
        [
            seg(1.0, 1.0, 0.0, 0.5),
            seg(1.0, 2.0, 0.0, 0.5),
            seg(1.0, 1.0, 0.0, 0.5),
        ],
        8.0,
        4.0,
    ),
    (
        [
            seg(1.0, 2.0, 0.0, 0.25),
            seg(3.0, 1.0, PI, 0.25),
            seg(1.0, 4.0, PI, 0.25),
        ],
        8.0,
        4.0,
    ),
    (
        [
            seg(3.0, 1.0, 0.0, 0.25),
            seg(1.0, 4.0, 0.0, 0.25),
            seg(1.0, 2.0, 0.0, 0.25),
        ],
        8.0,
        4.0,
    ),
    (
        [
            seg(1.0, 1.0, 0.0, 0.5),
            seg(1.0, 2.5, 0.0, 0.5),
            seg(1.0, 1.0, 0.0, 0.5),
        ],
        7.0,
        4.0,
    ),
    (
        [
            seg(1.0, 2.0, -PI / 12.0, 0.5),
            seg(1.0, 2.0, -PI / 12.0, 0.5),
            seg(1.0, 2.0, -PI / 12.0, 0.5),
        ],
        8.0,
        5.0,
    ),
    (
        [
            seg(1.0, 3.0, PI / 8.0, 0.5),
            seg(1.0, 3.0, PI / 8.0, 0.5),
            seg(1.0, 3.0, PI / 8.0, 0.5),
        ],
        8.0,
        4.0,
    ),
    (
        [
            seg(1.0, 1.0, 0.0, 0.5),
            seg(1.0, 3.0, 0.0, 0.5),
            seg(2.0, 1.0, 0.0, 0.5),
        ],
        8.0,
        5.0,
    ),
];

/// One of the seven seasonal inflow-mean curves of the reference (`inflow_profile` 1..=7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InflowProfile(u8);

impl InflowProfile {
    /// Profile `index` (1..=7, the reference's numbering).
    ///
    /// Errors: any other index ([`Error::OutOfRange`] `inflow profile`).
    pub const fn new(index: u8) -> Result<Self> {
        if index >= 1 && index <= 7 {
            Ok(Self(index))
        } else {
            Err(Error::OutOfRange {
                parameter: "inflow profile",
            })
        }
    }

    /// The profile's number, 1..=7.
    pub const fn index(self) -> u8 {
        self.0
    }

    /// The mean inflow on `day` (1..=360; other days are taken modulo the year), in `f64`.
    pub fn mean(self, day: usize) -> f64 {
        let x = (day + DAM_DAYS - 1) % DAM_DAYS;
        let Some((segments, scale, shift)) = PROFILES.get(usize::from(self.0).wrapping_sub(1))
        else {
            return 0.0;
        };
        let Some(s) = segments.get((x / 120).min(2)) else {
            return 0.0;
        };
        let y = libm::sin(x as f64 * 3.0 * PI / 359.0 + s.phase) * s.mul / s.div + s.offset;
        y * scale + shift
    }
}

/// One Dam instance: an inflow profile and the cost weights (α flooding, β demand).
///
/// `Copy`, no heap: 3 scalars and a byte. States are `[storage, day]`; every function that
/// takes a state accepts a finite storage ≥ 0 and an integer day in 1..=360: a NaN or
/// infinite coordinate is [`Error::NonFinite`] and anything else outside that set is
/// [`Error::OutOfRange`], both naming `state`. An action `>= 8` is [`Error::OutOfRange`]
/// naming `action`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dam<T> {
    profile: InflowProfile,
    flooding_weight: T,
    demand_weight: T,
}

/// `(profile, α, β)` of the target of the published experiment.
const TARGET: (u8, f64, f64) = (1, 0.3, 0.7);
/// `(profile, α, β)` of its six sources, in order 1..=6.
const SOURCES: [(u8, f64, f64); 6] = [
    (2, 0.8, 0.2),
    (3, 0.35, 0.65),
    (4, 0.7, 0.3),
    (5, 0.4, 0.6),
    (6, 0.6, 0.4),
    (7, 0.45, 0.55),
];

impl<T: Real> Dam<T> {
    /// An instance with inflow `profile`, flooding weight `alpha` and demand weight `beta`.
    ///
    /// Errors: a non-finite weight ([`Error::NonFinite`] `alpha` / `beta`); a negative one,
    /// or `α + β` farther than 10⁻⁶ from 1 ([`Error::InvalidParameter`] `alpha` / `beta`).
    pub fn new(profile: InflowProfile, alpha: T, beta: T) -> Result<Self> {
        crate::error::ensure_finite(alpha, "alpha")?;
        crate::error::ensure_finite(beta, "beta")?;
        if alpha < T::ZERO {
            return Err(Error::InvalidParameter { parameter: "alpha" });
        }
        if beta < T::ZERO || libm::fabs(alpha.to_f64() + beta.to_f64() - 1.0) > 1e-6 {
            return Err(Error::InvalidParameter { parameter: "beta" });
        }
        Ok(Self {
            profile,
            flooding_weight: alpha,
            demand_weight: beta,
        })
    }

    fn builtin((profile, alpha, beta): (u8, f64, f64)) -> Self {
        Self {
            profile: InflowProfile(profile),
            flooding_weight: T::from_f64(alpha),
            demand_weight: T::from_f64(beta),
        }
    }

    /// The target of the published experiment: profile 1, α = 0.3, β = 0.7.
    pub fn target() -> Self {
        Self::builtin(TARGET)
    }

    /// The six sources of the published experiment, in order 1..=6: profiles 2..=7 with
    /// (α, β) = (0.8, 0.2), (0.35, 0.65), (0.7, 0.3), (0.4, 0.6), (0.6, 0.4), (0.45, 0.55).
    pub fn sources() -> [Self; 6] {
        SOURCES.map(Self::builtin)
    }

    /// The inflow profile.
    pub fn profile(&self) -> InflowProfile {
        self.profile
    }

    /// α, the weight of the flooding cost.
    pub fn flooding_weight(&self) -> T {
        self.flooding_weight
    }

    /// β, the weight of the demand cost.
    pub fn demand_weight(&self) -> T {
        self.demand_weight
    }

    /// Checks that `state` is a finite storage ≥ 0 and an integer day in 1..=360.
    ///
    /// Errors: [`Error::NonFinite`] or [`Error::OutOfRange`], naming `state`.
    pub fn check_state(&self, state: [T; 2]) -> Result<()> {
        crate::error::ensure_all_finite(&state, "state")?;
        let [storage, day] = state;
        let valid_day = day >= T::ONE && day <= T::from_usize(DAM_DAYS) && day.floor() == day;
        if storage >= T::ZERO && valid_day {
            Ok(())
        } else {
            Err(Error::OutOfRange { parameter: "state" })
        }
    }

    /// The mean inflow μ_p(day) of this instance's profile on the state's day.
    ///
    /// Errors: an invalid `state`.
    pub fn inflow_mean(&self, state: [T; 2]) -> Result<T> {
        self.check_state(state)?;
        Ok(T::from_f64(self.profile.mean(day_index(state))))
    }

    /// The release `u` actually made: the action's release bounded into
    /// `[max(s − 500, 0), max(s − 50, 0)]` (step 1 of the module docs).
    ///
    /// Errors: an invalid `state` or `action`.
    pub fn release(&self, state: [T; 2], action: usize) -> Result<T> {
        self.check(state, action)?;
        Ok(bounded_release(state[0], action))
    }

    /// The reward `α·(−max(s − 300, 0)/4) + β·(−max(10 − u, 0)²)`; it has no noise, so it
    /// is also the mean reward.
    ///
    /// Errors: an invalid `state` or `action`.
    pub fn mean_reward(&self, state: [T; 2], action: usize) -> Result<T> {
        self.check(state, action)?;
        Ok(self.reward_unchecked(state[0], bounded_release(state[0], action)))
    }

    /// The exact mean next state: `[E max(m + 2ε, 0), day′]` with `m = s + μ_p(day) − u`,
    /// i.e. `m·Φ(m/2) + 2·φ(m/2)` (the clipping at 0 makes it exceed `max(m, 0)` near an
    /// empty reservoir). Computed in `f64`.
    ///
    /// Errors: an invalid `state` or `action`.
    pub fn mean_next_state(&self, state: [T; 2], action: usize) -> Result<[T; 2]> {
        self.check(state, action)?;
        let u = bounded_release(state[0], action).to_f64();
        let m = state[0].to_f64() + self.profile.mean(day_index(state)) - u;
        let z = m / DAM_INFLOW_STD;
        let cdf = 0.5 * libm::erfc(-z / core::f64::consts::SQRT_2);
        let pdf = libm::exp(-0.5 * z * z) / libm::sqrt(2.0 * PI);
        let mean = m * cdf + DAM_INFLOW_STD * pdf;
        Ok([T::from_f64(mean), next_day(state[1])])
    }

    /// Samples one step `(s, a) ↦ (s′, r)` as the module docs say, drawing one
    /// [`rng::standard_normal`] (nothing when the arguments are invalid). Never absorbing.
    ///
    /// Errors: an invalid `state` or `action`.
    pub fn step<R: Rng + ?Sized>(
        &self,
        state: [T; 2],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; 2], T>> {
        self.check(state, action)?;
        let [storage, day] = state;
        let u = bounded_release(storage, action);
        let noise = T::from_f64(DAM_INFLOW_STD) * rng::standard_normal::<T, R>(rng);
        let inflow = T::from_f64(self.profile.mean(day_index(state))) + noise;
        let next_storage = (storage + inflow - u).max(T::ZERO);
        Ok(Transition {
            state,
            action,
            reward: self.reward_unchecked(storage, u),
            next_state: [next_storage, next_day(day)],
            absorbing: false,
        })
    }

    /// The start of an episode: storage ~ U[50, 500) (one `u64`), then a day drawn
    /// uniformly from [`DAM_INITIAL_DAYS`] (one `u64`), the reference's order.
    pub fn initial_state<R: Rng + ?Sized>(&self, rng: &mut R) -> [T; 2] {
        let (low, high) = (T::from_f64(DAM_MIN_STORAGE), T::from_f64(DAM_MAX_STORAGE));
        let storage = low + (high - low) * rng::uniform::<T, R>(rng);
        let day = DAM_INITIAL_DAYS
            .get(rng::uniform_index(rng, DAM_INITIAL_DAYS.len()))
            .copied()
            .unwrap_or(1.0);
        [storage.min(high), T::from_f64(day)]
    }

    fn check(&self, state: [T; 2], action: usize) -> Result<()> {
        self.check_state(state)?;
        if action < DAM_ACTIONS {
            Ok(())
        } else {
            Err(Error::OutOfRange {
                parameter: "action",
            })
        }
    }

    /// α·(−max(s − 300, 0)/4) + β·(−max(10 − u, 0)²), in the reference's order.
    fn reward_unchecked(&self, storage: T, release: T) -> T {
        let flooding = -(storage - T::from_f64(DAM_FLOODING)).max(T::ZERO) / T::from_f64(4.0);
        let deficit = (T::from_f64(DAM_DEMAND) - release).max(T::ZERO);
        self.flooding_weight * flooding + self.demand_weight * -(deficit * deficit)
    }
}

/// The day of a valid state as an index 1..=360.
fn day_index<T: Real>(state: [T; 2]) -> usize {
    state[1].to_f64() as usize
}

/// `day + 1`, 360 wrapping to 1.
fn next_day<T: Real>(day: T) -> T {
    if day < T::from_usize(DAM_DAYS) {
        day + T::ONE
    } else {
        T::ONE
    }
}

/// The action's release bounded into what storage `s` allows (valid action assumed).
fn bounded_release<T: Real>(storage: T, action: usize) -> T {
    let release = T::from_f64(DAM_RELEASES.get(action).copied().unwrap_or(0.0));
    let lower = (storage - T::from_f64(DAM_MAX_STORAGE)).max(T::ZERO);
    let upper = (storage - T::from_f64(DAM_MIN_STORAGE)).max(T::ZERO);
    release.max(lower).min(upper)
}

impl<T: Real> GenerativeModel<T> for Dam<T> {
    type State = [T; 2];

    fn num_actions(&self) -> usize {
        DAM_ACTIONS
    }

    /// One [`Dam::step`] from any valid state.
    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; 2],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; 2], T>> {
        self.step(state, action, rng)
    }
}
