//! The multitask Acrobot of the IWFQI paper's experiments: a two-link pendulum actuated at
//! the middle joint, whose link masses and first-link length are task parameters, with two
//! tasks — **swing-up** (raise the tip above a line) and **rotate** (spin the first link at
//! π rad/s).
//!
//! State `[θ₁, θ₂, θ̇₁, θ̇₂]` with θ₁, θ₂ ∈ [−π, π], θ̇₁ ∈ [−4π, 4π], θ̇₂ ∈ [−9π, 9π].
//! Two actions: torque −2 (action 0) or +2 (action 1) at the second joint. One step (the
//! reference's `AcrobotMultitask.step`, the equations of the RL book / RLPy, noise-free):
//!
//! 1. the reward depends on the **current** state only: swing-up
//!    `−cos θ₁ − cos(θ₁ + θ₂) − 2`, rotate `−|θ̇₁ − π|`;
//! 2. one classical Runge–Kutta step of length 0.2 s of the equations of motion (link
//!    centres of mass at 0.5, moments of inertia 1, g = 9.8; the second link's length
//!    enters nothing but the picture);
//! 3. the angles are wrapped into [−π, π] and the velocities clipped into their ranges;
//! 4. swing-up only: the next state is absorbing when `−cos θ₁′ − cos(θ₁′ + θ₂′) > 1`.
//!
//! The dynamics have no noise, so the mean next state and the mean reward are the step's
//! own; [`GenerativeModel::query`] draws nothing. An episode starts at `[θ₁, 0, 0, 0]` with
//! θ₁ ~ U[−2, 2) ([`Acrobot::initial_state`]) and lasts at most [`ACROBOT_HORIZON`] = 100
//! steps, discounted by γ = 0.95.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::{GenerativeModel, Transition};
use crate::rng;
use rand_core::Rng;

/// Number of actions; valid actions are `0..ACROBOT_ACTIONS`.
pub const ACROBOT_ACTIONS: usize = 2;
/// The torque of each action.
pub const ACROBOT_TORQUES: [f64; ACROBOT_ACTIONS] = [-2.0, 2.0];
/// Episode horizon H.
pub const ACROBOT_HORIZON: usize = 100;
/// Discount factor γ.
pub const ACROBOT_DISCOUNT: f64 = 0.95;
/// Integration step (seconds): one Runge–Kutta step per action.
pub const ACROBOT_TIME_STEP: f64 = 0.2;
/// Position of each link's centre of mass along the link.
pub const ACROBOT_CENTRE_OF_MASS: f64 = 0.5;
/// Moment of inertia of each link.
pub const ACROBOT_INERTIA: f64 = 1.0;
/// Gravity.
pub const ACROBOT_GRAVITY: f64 = 9.8;
/// Bound of |θ̇₁|: 4π.
pub const ACROBOT_MAX_VELOCITY_1: f64 = 4.0 * core::f64::consts::PI;
/// Bound of |θ̇₂|: 9π.
pub const ACROBOT_MAX_VELOCITY_2: f64 = 9.0 * core::f64::consts::PI;
/// Episodes start with θ₁ ~ U[−2, 2).
pub const ACROBOT_INITIAL_ANGLE: f64 = 2.0;
/// θ₁ of the nine start states `[θ₁, 0, 0, 0]` of the published evaluation rollouts.
pub const ACROBOT_EVALUATION_ANGLES: [f64; 9] = [-2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0];

/// What the Acrobot is asked to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AcrobotTask {
    /// Reward `−cos θ₁ − cos(θ₁ + θ₂) − 2`; the episode ends when the tip rises above 1.
    SwingUp,
    /// Reward `−|θ̇₁ − π|`; never absorbing.
    Rotate,
}

/// One Acrobot instance: link masses, link lengths and a task.
///
/// `Copy`, no heap: 4 scalars and a byte. States are `[θ₁, θ₂, θ̇₁, θ̇₂]`; every function
/// that takes a state accepts exactly the box above: a NaN or infinite coordinate is
/// [`Error::NonFinite`] and a finite one outside the box is [`Error::OutOfRange`], both
/// naming `state`. An action `>= 2` is [`Error::OutOfRange`] naming `action`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Acrobot<T> {
    masses: [T; 2],
    lengths: [T; 2],
    task: AcrobotTask,
}

/// The reference's `wrap` loop runs at most this many times before reducing with `floor`
/// (a step moves an angle by far less than a turn, so the loop exits after one pass).
const WRAP_PASSES: usize = 4;

impl<T: Real> Acrobot<T> {
    /// An instance with link masses `masses = [m₁, m₂]`, link lengths `[l₁, l₂]` and `task`.
    ///
    /// Errors: a non-finite mass or length ([`Error::NonFinite`] `masses` / `lengths`), or
    /// one `<= 0` ([`Error::InvalidParameter`]).
    pub fn new(masses: [T; 2], lengths: [T; 2], task: AcrobotTask) -> Result<Self> {
        crate::error::ensure_all_finite(&masses, "masses")?;
        crate::error::ensure_all_finite(&lengths, "lengths")?;
        if masses.iter().any(|&m| m <= T::ZERO) {
            return Err(Error::InvalidParameter {
                parameter: "masses",
            });
        }
        if lengths.iter().any(|&l| l <= T::ZERO) {
            return Err(Error::InvalidParameter {
                parameter: "lengths",
            });
        }
        Ok(Self {
            masses,
            lengths,
            task,
        })
    }

    fn builtin(masses: [f64; 2], lengths: [f64; 2], task: AcrobotTask) -> Self {
        Self {
            masses: masses.map(T::from_f64),
            lengths: lengths.map(T::from_f64),
            task,
        }
    }

    /// The target of the published experiment: unit masses and lengths, swing-up.
    pub fn target() -> Self {
        Self::builtin([1.0, 1.0], [1.0, 1.0], AcrobotTask::SwingUp)
    }

    /// The two sources of the published experiment: `m = (0.9, 0.6)`, `l = (1.1, 0.7)`,
    /// swing-up; `m = (0.95, 1.0)`, `l = (0.95, 0.95)`, rotate.
    pub fn sources() -> [Self; 2] {
        [
            Self::builtin([0.9, 0.6], [1.1, 0.7], AcrobotTask::SwingUp),
            Self::builtin([0.95, 1.0], [0.95, 0.95], AcrobotTask::Rotate),
        ]
    }

    /// Link masses `[m₁, m₂]`.
    pub fn masses(&self) -> [T; 2] {
        self.masses
    }

    /// Link lengths `[l₁, l₂]`.
    pub fn lengths(&self) -> [T; 2] {
        self.lengths
    }

    /// The task.
    pub fn task(&self) -> AcrobotTask {
        self.task
    }

    /// Checks that `state` lies in the box of the module docs.
    ///
    /// Errors: [`Error::NonFinite`] or [`Error::OutOfRange`], naming `state`.
    pub fn check_state(&self, state: [T; 4]) -> Result<()> {
        crate::error::ensure_all_finite(&state, "state")?;
        let bounds = [
            T::PI,
            T::PI,
            T::from_f64(ACROBOT_MAX_VELOCITY_1),
            T::from_f64(ACROBOT_MAX_VELOCITY_2),
        ];
        if state.iter().zip(bounds).all(|(&x, b)| x >= -b && x <= b) {
            Ok(())
        } else {
            Err(Error::OutOfRange { parameter: "state" })
        }
    }

    /// The reward in `state` (the task's formula; no noise, so also the mean reward).
    ///
    /// Errors: an invalid `state`.
    pub fn mean_reward(&self, state: [T; 4]) -> Result<T> {
        self.check_state(state)?;
        Ok(self.reward_unchecked(state))
    }

    /// `true` when `state` is in the swing-up goal region `−cos θ₁ − cos(θ₁ + θ₂) > 1`
    /// (always `false` for the rotate task).
    ///
    /// Errors: an invalid `state`.
    pub fn in_goal(&self, state: [T; 4]) -> Result<bool> {
        self.check_state(state)?;
        Ok(self.in_goal_unchecked(state))
    }

    /// The next state (deterministic, so also the mean next state).
    ///
    /// Errors: an invalid `state` or `action`; [`Error::NonFinite`] `next state` when the
    /// integration overflows (possible only for extreme custom parameters).
    pub fn mean_next_state(&self, state: [T; 4], action: usize) -> Result<[T; 4]> {
        self.check(state, action)?;
        self.integrate(state, action)
    }

    /// One step `(s, a) ↦ (s′, r, ω)` as the module docs say; draws nothing.
    ///
    /// Errors: those of [`Acrobot::mean_next_state`].
    pub fn step(&self, state: [T; 4], action: usize) -> Result<Transition<[T; 4], T>> {
        let next_state = self.mean_next_state(state, action)?;
        Ok(Transition {
            state,
            action,
            reward: self.reward_unchecked(state),
            next_state,
            absorbing: self.in_goal_unchecked(next_state),
        })
    }

    /// The start of an episode: `[θ₁, 0, 0, 0]` with θ₁ ~ U[−2, 2) (one `u64`).
    pub fn initial_state<R: Rng + ?Sized>(&self, rng: &mut R) -> [T; 4] {
        let half = T::from_f64(ACROBOT_INITIAL_ANGLE);
        let u = rng::uniform::<T, R>(rng);
        [-half + (half + half) * u, T::ZERO, T::ZERO, T::ZERO]
    }

    fn check(&self, state: [T; 4], action: usize) -> Result<()> {
        self.check_state(state)?;
        if action < ACROBOT_ACTIONS {
            Ok(())
        } else {
            Err(Error::OutOfRange {
                parameter: "action",
            })
        }
    }

    fn reward_unchecked(&self, [t1, t2, w1, _]: [T; 4]) -> T {
        match self.task {
            AcrobotTask::SwingUp => -t1.cos() - (t2 + t1).cos() - T::from_f64(2.0),
            AcrobotTask::Rotate => -(w1 - T::PI).abs(),
        }
    }

    fn in_goal_unchecked(&self, [t1, t2, _, _]: [T; 4]) -> bool {
        self.task == AcrobotTask::SwingUp && -t1.cos() - (t2 + t1).cos() > T::ONE
    }

    /// One RK4 step of length 0.2 of the equations of motion, then wrap and clip.
    fn integrate(&self, s: [T; 4], action: usize) -> Result<[T; 4]> {
        let torque = T::from_f64(ACROBOT_TORQUES.get(action).copied().unwrap_or(0.0));
        let dt = T::from_f64(ACROBOT_TIME_STEP);
        let half = dt / T::from_f64(2.0);
        let shifted = |y: [T; 4], k: [T; 4], h: T| {
            let mut out = y;
            for (o, k) in out.iter_mut().zip(k) {
                *o += h * k;
            }
            out
        };
        let k1 = self.derivative(s, torque);
        let k2 = self.derivative(shifted(s, k1, half), torque);
        let k3 = self.derivative(shifted(s, k2, half), torque);
        let k4 = self.derivative(shifted(s, k3, dt), torque);
        let two = T::from_f64(2.0);
        let sixth = dt / T::from_f64(6.0);
        let mut y = s;
        for ((((y, a), b), c), d) in y.iter_mut().zip(k1).zip(k2).zip(k3).zip(k4) {
            *y += sixth * (a + two * b + two * c + d);
        }
        crate::error::ensure_all_finite(&y, "next state")?;
        let v1 = T::from_f64(ACROBOT_MAX_VELOCITY_1);
        let v2 = T::from_f64(ACROBOT_MAX_VELOCITY_2);
        Ok([
            wrap(y[0]),
            wrap(y[1]),
            y[2].clamp_to(-v1, v1),
            y[3].clamp_to(-v2, v2),
        ])
    }

    /// The time derivative of `[θ₁, θ₂, θ̇₁, θ̇₂]` under `torque` (the book's equations).
    fn derivative(&self, [t1, t2, w1, w2]: [T; 4], torque: T) -> [T; 4] {
        let [m1, m2] = self.masses;
        let l1 = self.lengths[0];
        let lc = T::from_f64(ACROBOT_CENTRE_OF_MASS);
        let inertia = T::from_f64(ACROBOT_INERTIA);
        let g = T::from_f64(ACROBOT_GRAVITY);
        let two = T::from_f64(2.0);
        let half_pi = T::PI / two;
        let (sin2, cos2) = (t2.sin(), t2.cos());
        // The squares are single factors, as the reference's `θ̇²` are.
        let (w1_sq, w2_sq) = (w1 * w1, w2 * w2);
        let d1 = m1 * lc * lc + m2 * (l1 * l1 + lc * lc + two * l1 * lc * cos2) + inertia + inertia;
        let d2 = m2 * (lc * lc + l1 * lc * cos2) + inertia;
        let phi2 = m2 * lc * g * (t1 + t2 - half_pi).cos();
        let phi1 = -m2 * l1 * lc * w2_sq * sin2 - two * m2 * l1 * lc * w2 * w1 * sin2
            + (m1 * lc + m2 * l1) * g * (t1 - half_pi).cos()
            + phi2;
        let acc2 = (torque + d2 / d1 * phi1 - m2 * l1 * lc * w1_sq * sin2 - phi2)
            / (m2 * lc * lc + inertia - d2 * d2 / d1);
        let acc1 = -(d2 * acc2 + phi1) / d1;
        [w1, w2, acc1, acc2]
    }
}

/// Wraps an angle into [−π, π] as the reference's loop does (`x − 2π` while above π,
/// `x + 2π` while below −π), with a `floor` reduction after a few passes.
fn wrap<T: Real>(mut x: T) -> T {
    let (low, high) = (-T::PI, T::PI);
    let turn = high - low;
    for _ in 0..WRAP_PASSES {
        if x > high {
            x -= turn;
        } else if x < low {
            x += turn;
        } else {
            return x;
        }
    }
    let reduced = x - turn * ((x - low) / turn).floor();
    reduced.clamp_to(low, high)
}

impl<T: Real> GenerativeModel<T> for Acrobot<T> {
    type State = [T; 4];

    fn num_actions(&self) -> usize {
        ACROBOT_ACTIONS
    }

    /// One [`Acrobot::step`] from any valid state; the generator is not used (no noise).
    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; 4],
        action: usize,
        _rng: &mut R,
    ) -> Result<Transition<[T; 4], T>> {
        self.step(state, action)
    }
}
