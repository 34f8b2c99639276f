//! The continuous Puddle World of spec §2: a point moves in the closed box [0, 10]² with
//! noisy unit steps, pays −1 per step plus 100 × the summed Gaussian densities of the
//! puddles at its position, and the episode ends when it comes within 1.41 of the goal.
//!
//! Two dynamics variants share the four instances of §2.6: in [`Dynamics::Shared`] (κ = 0,
//! the thesis setting) every step has length 1; in [`Dynamics::PuddleBased`] (κ = 5) the
//! step length shrinks to 1/(1 + κ·W(s)) inside puddles, so tasks differ in their
//! transitions too.
//!
//! Everything follows the reference implementation (trlib's `puddleworld.py`): the puddle
//! weight, step length and goal test use the **current** state, noise is added before
//! clipping, and the three standard-normal draws of a step are taken in the order
//! ε_x, ε_y, η.
//!
//! Episodes and rollouts live in the submodule `episode`; the [`Policy`] trait that drives
//! them lives in [`crate::policy`].

mod episode;

pub use episode::EpisodeRecord;

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use crate::model::{SourceMeans, SourceModel};
use crate::rng;
use crate::score::PointGrid;
use rand_core::Rng;

/// Number of actions of Puddle World; valid actions are `0..PUDDLE_ACTIONS`.
pub const PUDDLE_ACTIONS: usize = 4;
/// Action 0: move right (+x).
pub const ACTION_RIGHT: usize = 0;
/// Action 1: move left (−x).
pub const ACTION_LEFT: usize = 1;
/// Action 2: move up (+y).
pub const ACTION_UP: usize = 2;
/// Action 3: move down (−y).
pub const ACTION_DOWN: usize = 3;

/// Lower bound of both state coordinates; states are clipped into the closed box
/// [`PUDDLE_STATE_LOW`, `PUDDLE_STATE_HIGH`]².
pub const PUDDLE_STATE_LOW: f64 = 0.0;
/// Upper bound of both state coordinates.
pub const PUDDLE_STATE_HIGH: f64 = 10.0;
/// The deterministic initial state s₀ = (0, 0) of every episode.
pub const PUDDLE_INITIAL_STATE: [f64; 2] = [0.0, 0.0];
/// Base step length, before the puddle slow-down: α = base / (1 + κ·W(s)).
pub const PUDDLE_BASE_STEP: f64 = 1.0;
/// Standard deviation (not variance) of the independent Gaussian noise on each next-state
/// coordinate.
pub const PUDDLE_TRANSITION_NOISE_STD: f64 = 0.2;
/// Standard deviation (not variance) of the Gaussian reward noise.
pub const PUDDLE_REWARD_NOISE_STD: f64 = 0.1;
/// Goal radius ρ ("fudge"): a state x is in the goal region iff ‖x − g‖₂ < ρ (strict).
pub const PUDDLE_GOAL_RADIUS: f64 = 1.41;
/// Puddle penalty coefficient: the mean reward subtracts `PUDDLE_PENALTY · W(s)`.
pub const PUDDLE_PENALTY: f64 = 100.0;
/// Slow-down factor κ of [`Dynamics::PuddleBased`] (κ = 0 in [`Dynamics::Shared`]).
pub const PUDDLE_SLOW_DOWN: f64 = 5.0;
/// Off-diagonal entry of every puddle covariance [[v, 10⁻⁵], [10⁻⁵, v]], kept to match the
/// reference exactly.
pub const PUDDLE_COVARIANCE_OFF_DIAGONAL: f64 = 1e-5;
/// Episode horizon H: an episode has at most this many steps.
pub const PUDDLE_HORIZON: usize = 50;
/// Discount factor γ of Puddle World.
pub const PUDDLE_DISCOUNT: f64 = 0.99;
/// Number of rollouts of the reference evaluation (spec §3.3).
pub const PUDDLE_EVALUATION_ROLLOUTS: usize = 5;
/// Most puddles a [`PuddleWorld`] can hold (the spec's instances have at most 6).
pub const MAX_PUDDLES: usize = 8;

/// The two dynamics variants of spec §2.6, which differ only in the slow-down factor κ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Dynamics {
    /// κ = 0: every step has length 1, all instances share their transitions (the
    /// "reward only" experiments of the thesis).
    Shared,
    /// κ = 5: steps shrink inside puddles, α = 1/(1 + 5·W(s)).
    PuddleBased,
}

impl Dynamics {
    /// The slow-down factor κ of this variant (0 or [`PUDDLE_SLOW_DOWN`]).
    pub fn slow_down(self) -> f64 {
        match self {
            Dynamics::Shared => 0.0,
            Dynamics::PuddleBased => PUDDLE_SLOW_DOWN,
        }
    }
}

/// One puddle: a bivariate Gaussian bump with mean `mean` and covariance
/// [[`variance`, 10⁻⁵], [10⁻⁵, `variance`]] (spec §2.2).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Puddle<T> {
    /// Centre μ of the puddle.
    pub mean: [T; 2],
    /// Diagonal entry v of the covariance (0.8 or 0.7 in the spec's instances); must exceed
    /// the off-diagonal 10⁻⁵ so the covariance is positive definite.
    pub variance: T,
}

impl<T> Puddle<T> {
    /// A puddle centred at `mean` with diagonal covariance entry `variance`.
    pub const fn new(mean: [T; 2], variance: T) -> Self {
        Self { mean, variance }
    }
}

/// A puddle with the constants of its density precomputed, so a density evaluation costs
/// one `exp` and a handful of multiply-adds.
///
/// With Σ = [[v, c], [c, v]] the quadratic form splits along the eigenvectors (1, 1) and
/// (1, −1): ½ dᵀΣ⁻¹d = (dx + dy)²/(4(v + c)) + (dx − dy)²/(4(v − c)). Both terms are
/// non-negative, so a far-away state gives exp(−∞) = 0 and never ∞ − ∞.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct PuddleDensity<T> {
    puddle: Puddle<T>,
    /// 1 / (4 (v + c)).
    along: T,
    /// 1 / (4 (v − c)).
    across: T,
    /// 1 / (2π √det Σ) = 1 / (2π √(v − c) √(v + c)).
    scale: T,
}

impl<T: Real> PuddleDensity<T> {
    /// Precomputes the density constants in f64 (then rounds to `T`). Does not validate.
    fn prepare(puddle: Puddle<T>) -> Self {
        let v = puddle.variance.to_f64();
        let c = PUDDLE_COVARIANCE_OFF_DIAGONAL;
        let (plus, minus) = (v + c, v - c);
        let scale = 1.0 / (2.0 * core::f64::consts::PI * libm::sqrt(minus) * libm::sqrt(plus));
        Self {
            puddle,
            along: T::from_f64(0.25 / plus),
            across: T::from_f64(0.25 / minus),
            scale: T::from_f64(scale),
        }
    }

    /// 𝒩₂(x; μ, Σ).
    #[inline]
    fn density(&self, [x, y]: [T; 2]) -> T {
        let [mx, my] = self.puddle.mean;
        let (dx, dy) = (x - mx, y - my);
        let (u, w) = (dx + dy, dx - dy);
        self.scale * (-(self.along * u * u + self.across * w * w)).exp()
    }
}

/// One Puddle World instance: a goal, up to [`MAX_PUDDLES`] puddles and a dynamics variant.
///
/// `Copy`, no heap: the puddles live in a fixed array. Memory: 6·[`MAX_PUDDLES`] + 3
/// scalars plus a `usize` and a byte: 216 bytes in `f32`, 424 bytes in `f64` (x86-64 and
/// Cortex-M alike up to padding).
///
/// States are `[x, y]`. Every function that takes a state accepts exactly the closed box
/// [0, 10]² (the set the dynamics can reach, and the generative model's domain): a NaN or
/// infinite coordinate is [`Error::NonFinite`] and a finite one outside the box is
/// [`Error::OutOfRange`], both naming `state`. An action `>= 4` is [`Error::OutOfRange`]
/// naming `action`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PuddleWorld<T> {
    goal: [T; 2],
    puddles: [PuddleDensity<T>; MAX_PUDDLES],
    num_puddles: usize,
    dynamics: Dynamics,
    slow_down: T,
}

/// Goal shared by the target and sources 1 and 2.
const GOAL_TOP_MIDDLE: [f64; 2] = [5.0, 10.0];
/// Goal of source 3.
const GOAL_TOP_RIGHT: [f64; 2] = [7.0, 10.0];

/// Puddles `(mean, variance)` of the target instance (spec §2.6).
const TARGET_PUDDLES: [([f64; 2], f64); 5] = [
    ([1.0, 4.0], 0.7),
    ([1.0, 10.0], 0.8),
    ([1.0, 8.0], 0.8),
    ([6.0, 6.0], 0.8),
    ([6.0, 4.0], 0.8),
];
/// Puddles of source 1: the target without the (1, 4) puddle.
const SOURCE_1_PUDDLES: [([f64; 2], f64); 4] = [
    ([1.0, 10.0], 0.8),
    ([1.0, 8.0], 0.8),
    ([6.0, 6.0], 0.8),
    ([6.0, 4.0], 0.8),
];
/// Puddles of source 2: a very different layout.
const SOURCE_2_PUDDLES: [([f64; 2], f64); 6] = [
    ([2.0, 2.0], 0.8),
    ([4.0, 6.0], 0.8),
    ([1.0, 8.0], 0.8),
    ([2.0, 4.0], 0.8),
    ([8.5, 7.0], 0.8),
    ([8.5, 5.0], 0.8),
];
/// Puddles of source 3: (8, 2) instead of (1, 4), with goal (7, 10).
const SOURCE_3_PUDDLES: [([f64; 2], f64); 5] = [
    ([8.0, 2.0], 0.7),
    ([1.0, 10.0], 0.8),
    ([1.0, 8.0], 0.8),
    ([6.0, 6.0], 0.8),
    ([6.0, 4.0], 0.8),
];

impl<T: Real> PuddleWorld<T> {
    /// A custom instance with goal `goal`, the given puddles and dynamics variant.
    ///
    /// Errors, checked in this order: a non-finite goal ([`Error::NonFinite`] `goal`); more
    /// than [`MAX_PUDDLES`] puddles ([`Error::CapacityExceeded`]); a non-finite puddle
    /// mean or variance ([`Error::NonFinite`] `puddle mean` / `puddle variance`); a
    /// variance `<=` 10⁻⁵, for which the covariance is not positive definite, or so extreme
    /// that the density constants do not fit in `T` ([`Error::InvalidParameter`]
    /// `puddle variance`).
    pub fn new(goal: [T; 2], puddles: &[Puddle<T>], dynamics: Dynamics) -> Result<Self> {
        crate::error::ensure_all_finite(&goal, "goal")?;
        if puddles.len() > MAX_PUDDLES {
            return Err(Error::CapacityExceeded {
                capacity: MAX_PUDDLES,
            });
        }
        let mut densities = [PuddleDensity::default(); MAX_PUDDLES];
        for (slot, &puddle) in densities.iter_mut().zip(puddles) {
            crate::error::ensure_all_finite(&puddle.mean, "puddle mean")?;
            crate::error::ensure_finite(puddle.variance, "puddle variance")?;
            let invalid = Error::InvalidParameter {
                parameter: "puddle variance",
            };
            if puddle.variance.to_f64() <= PUDDLE_COVARIANCE_OFF_DIAGONAL {
                return Err(invalid);
            }
            let density = PuddleDensity::prepare(puddle);
            let constants = [density.along, density.across, density.scale];
            if !constants.iter().all(|c| c.is_finite() && *c > T::ZERO) {
                return Err(invalid);
            }
            *slot = density;
        }
        Ok(Self::assemble(goal, densities, puddles.len(), dynamics))
    }

    /// The target task of spec §2.6: goal (5, 10), five puddles including (1, 4).
    pub fn target(dynamics: Dynamics) -> Self {
        Self::builtin(GOAL_TOP_MIDDLE, &TARGET_PUDDLES, dynamics)
    }

    /// Source 1 of spec §2.6: the target without the (1, 4) puddle.
    pub fn source_1(dynamics: Dynamics) -> Self {
        Self::builtin(GOAL_TOP_MIDDLE, &SOURCE_1_PUDDLES, dynamics)
    }

    /// Source 2 of spec §2.6: goal (5, 10), six puddles in a very different layout.
    pub fn source_2(dynamics: Dynamics) -> Self {
        Self::builtin(GOAL_TOP_MIDDLE, &SOURCE_2_PUDDLES, dynamics)
    }

    /// Source 3 of spec §2.6: goal (7, 10), a puddle at (8, 2) instead of (1, 4).
    pub fn source_3(dynamics: Dynamics) -> Self {
        Self::builtin(GOAL_TOP_RIGHT, &SOURCE_3_PUDDLES, dynamics)
    }

    /// The three sources of spec §2.6, in order 1, 2, 3.
    pub fn sources(dynamics: Dynamics) -> [Self; 3] {
        [
            Self::source_1(dynamics),
            Self::source_2(dynamics),
            Self::source_3(dynamics),
        ]
    }

    /// Builds one of the spec's instances; their constants are valid, so no check is needed.
    fn builtin(goal: [f64; 2], puddles: &[([f64; 2], f64)], dynamics: Dynamics) -> Self {
        let mut densities = [PuddleDensity::default(); MAX_PUDDLES];
        for (slot, &(mean, variance)) in densities.iter_mut().zip(puddles) {
            let puddle = Puddle::new(mean.map(T::from_f64), T::from_f64(variance));
            *slot = PuddleDensity::prepare(puddle);
        }
        let count = puddles.len().min(MAX_PUDDLES);
        Self::assemble(goal.map(T::from_f64), densities, count, dynamics)
    }

    fn assemble(
        goal: [T; 2],
        puddles: [PuddleDensity<T>; MAX_PUDDLES],
        num_puddles: usize,
        dynamics: Dynamics,
    ) -> Self {
        Self {
            goal,
            puddles,
            num_puddles,
            dynamics,
            slow_down: T::from_f64(dynamics.slow_down()),
        }
    }

    /// The goal g.
    pub fn goal(&self) -> [T; 2] {
        self.goal
    }

    /// The dynamics variant.
    pub fn dynamics(&self) -> Dynamics {
        self.dynamics
    }

    /// The slow-down factor κ (0 or 5) as a `T`.
    pub fn slow_down(&self) -> T {
        self.slow_down
    }

    /// Number of puddles.
    pub fn num_puddles(&self) -> usize {
        self.num_puddles
    }

    /// The puddles, in the order they were given (the order W(s) sums them in).
    pub fn puddles(&self) -> impl Iterator<Item = Puddle<T>> + '_ {
        self.active().map(|d| d.puddle)
    }

    /// The initial state s₀ = (0, 0) as a `T` state.
    pub fn initial_state(&self) -> [T; 2] {
        PUDDLE_INITIAL_STATE.map(T::from_f64)
    }

    /// The score-table grid of the thesis (§11.1) for spacing `d` on both axes: points
    /// `0, d, 2d, …` up to 10 inclusive (`round(10/d) + 1` per axis; `d = 0.1` gives
    /// 101 × 101), i.e. [`PointGrid::spanning`] over the state box.
    ///
    /// Errors: a non-finite or non-positive `d`, or a `d` that does not divide 10 (to
    /// within 10⁻⁶ relative), so the last point would not be 10
    /// ([`Error::InvalidParameter`] `spacing`).
    pub fn score_grid(d: T) -> Result<PointGrid<T, 2>> {
        let (low, high) = (
            T::from_f64(PUDDLE_STATE_LOW),
            T::from_f64(PUDDLE_STATE_HIGH),
        );
        PointGrid::spanning([low; 2], [high; 2], d)
    }

    /// Checks that `state` lies in the closed box [0, 10]².
    ///
    /// Errors: a NaN or infinite coordinate ([`Error::NonFinite`] `state`), a finite one
    /// outside the box ([`Error::OutOfRange`] `state`).
    pub fn check_state(&self, state: [T; 2]) -> Result<()> {
        crate::error::ensure_all_finite(&state, "state")?;
        let (low, high) = (
            T::from_f64(PUDDLE_STATE_LOW),
            T::from_f64(PUDDLE_STATE_HIGH),
        );
        if state.iter().all(|&c| c >= low && c <= high) {
            Ok(())
        } else {
            Err(Error::OutOfRange { parameter: "state" })
        }
    }

    /// The puddle weight W(s) = Σᵤ 𝒩₂(s; μᵤ, Σᵤ) (spec §2.2).
    ///
    /// Errors: `state` outside [0, 10]² or non-finite.
    pub fn puddle_weight(&self, state: [T; 2]) -> Result<T> {
        self.check_state(state)?;
        Ok(self.weight_unchecked(state))
    }

    /// The step length α(s) = 1/(1 + κ·W(s)), exactly 1 in [`Dynamics::Shared`].
    ///
    /// Errors: `state` outside [0, 10]² or non-finite.
    pub fn step_length(&self, state: [T; 2]) -> Result<T> {
        self.check_state(state)?;
        Ok(self.step_length_for(self.weight_unchecked(state)))
    }

    /// The goal test G(s): ‖s − g‖₂ < 1.41 (strict).
    ///
    /// Errors: `state` outside [0, 10]² or non-finite.
    pub fn in_goal(&self, state: [T; 2]) -> Result<bool> {
        self.check_state(state)?;
        Ok(self.in_goal_unchecked(state))
    }

    /// The mean reward r̄(s) = (0 if G(s) else −1) − 100·W(s) (spec §2.4); it does not
    /// depend on the action.
    ///
    /// Errors: `state` outside [0, 10]² or non-finite.
    pub fn mean_reward(&self, state: [T; 2]) -> Result<T> {
        self.check_state(state)?;
        Ok(self.mean_reward_for(state, self.weight_unchecked(state)))
    }

    /// The noise-free next state s̄′(s, a) = clip₍₀,₁₀₎(s + e_a) with α taken at `state`
    /// (spec §2.4). Near the border this is not the true mean of the clipped noisy next
    /// state; the reference uses it as the mean anyway.
    ///
    /// Errors: `state` outside [0, 10]² or non-finite, `action >= 4`.
    pub fn mean_next_state(&self, state: [T; 2], action: usize) -> Result<[T; 2]> {
        self.check(state, action)?;
        let alpha = self.step_length_for(self.weight_unchecked(state));
        Ok(clip(displace(state, action, alpha)))
    }

    /// Samples one step (s, a) ↦ (s′, r, ω) exactly as spec §2.3.
    ///
    /// With w = W(s) and α = 1/(1 + κw): s′ = clip₍₀,₁₀₎(s + e_a + ε) with
    /// ε ~ 𝒩(0, 0.2²I) added before clipping, r = (0 if G(s) else −1) − 100w + η with
    /// η ~ 𝒩(0, 0.1²), and ω = G(s′). Consumes three [`rng::standard_normal`] draws, in
    /// the order ε_x, ε_y, η; nothing is drawn when the arguments are invalid.
    ///
    /// Errors: `state` outside [0, 10]² or non-finite, `action >= 4`.
    pub fn step<R: Rng + ?Sized>(
        &self,
        state: [T; 2],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; 2], T>> {
        self.check(state, action)?;
        let weight = self.weight_unchecked(state);
        let moved = displace(state, action, self.step_length_for(weight));
        let transition_std = T::from_f64(PUDDLE_TRANSITION_NOISE_STD);
        let noise_x = transition_std * rng::standard_normal::<T, R>(rng);
        let noise_y = transition_std * rng::standard_normal::<T, R>(rng);
        let reward_noise = T::from_f64(PUDDLE_REWARD_NOISE_STD) * rng::standard_normal::<T, R>(rng);
        let [mx, my] = moved;
        let next_state = clip([mx + noise_x, my + noise_y]);
        Ok(Transition {
            state,
            action,
            reward: self.mean_reward_for(state, weight) + reward_noise,
            next_state,
            absorbing: self.in_goal_unchecked(next_state),
        })
    }

    fn active(&self) -> impl Iterator<Item = &PuddleDensity<T>> {
        self.puddles.iter().take(self.num_puddles)
    }

    fn check(&self, state: [T; 2], action: usize) -> Result<()> {
        self.check_state(state)?;
        if action < PUDDLE_ACTIONS {
            Ok(())
        } else {
            Err(Error::OutOfRange {
                parameter: "action",
            })
        }
    }

    /// W(s), summed in puddle order like the reference.
    #[inline]
    fn weight_unchecked(&self, state: [T; 2]) -> T {
        self.active()
            .fold(T::ZERO, |sum, puddle| sum + puddle.density(state))
    }

    #[inline]
    fn step_length_for(&self, weight: T) -> T {
        T::from_f64(PUDDLE_BASE_STEP) / (T::ONE + self.slow_down * weight)
    }

    #[inline]
    fn in_goal_unchecked(&self, [x, y]: [T; 2]) -> bool {
        let [gx, gy] = self.goal;
        let (dx, dy) = (x - gx, y - gy);
        (dx * dx + dy * dy).sqrt() < T::from_f64(PUDDLE_GOAL_RADIUS)
    }

    /// (0 if G(s) else −1) − 100·w, in the reference's order of operations.
    #[inline]
    fn mean_reward_for(&self, state: [T; 2], weight: T) -> T {
        let base = if self.in_goal_unchecked(state) {
            T::ZERO
        } else {
            -T::ONE
        };
        base - T::from_f64(PUDDLE_PENALTY) * weight
    }
}

/// s + e_a for a valid action: ±α along x (actions 0, 1) or y (actions 2, 3).
#[inline]
fn displace<T: Real>([x, y]: [T; 2], action: usize, alpha: T) -> [T; 2] {
    match action {
        ACTION_RIGHT => [x + alpha, y],
        ACTION_LEFT => [x - alpha, y],
        ACTION_UP => [x, y + alpha],
        _ => [x, y - alpha],
    }
}

/// Component-wise clipping into [0, 10].
#[inline]
fn clip<T: Real>(state: [T; 2]) -> [T; 2] {
    let (low, high) = (
        T::from_f64(PUDDLE_STATE_LOW),
        T::from_f64(PUDDLE_STATE_HIGH),
    );
    state.map(|c| c.clamp_to(low, high))
}

/// The oracle of the score tables: spec §2.4's noise-free mean functions r̄(s) (which does
/// not depend on the action) and s̄′(s, a).
impl<T: Real> SourceModel<T, 2> for PuddleWorld<T> {
    fn predict(&self, state: [T; 2], action: usize) -> Result<SourceMeans<T, 2>> {
        let next_state = self.mean_next_state(state, action)?;
        Ok(SourceMeans {
            reward: self.mean_reward(state)?,
            next_state,
        })
    }
}

impl<T: Real> GenerativeModel<T> for PuddleWorld<T> {
    type State = [T; 2];

    fn num_actions(&self) -> usize {
        PUDDLE_ACTIONS
    }

    /// One [`PuddleWorld::step`] from any `state` in [0, 10]²; the spec's record for it has
    /// time index 0.
    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; 2],
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<[T; 2], T>> {
        self.step(state, action, rng)
    }
}

#[cfg(test)]
mod tests;
