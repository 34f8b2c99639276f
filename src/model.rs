//! What a task lets the algorithms see, and nothing of which task it is: a sampled
//! [`Transition`], a target's [`GenerativeModel`] (the algorithms' only door to the target),
//! a source's mean functions ([`SourceModel`], for oracle scores and ideal weights) and a
//! fully known [`FiniteMdp`] (identification, planning). The plants of [`crate::env`]
//! implement them; a plant of your own does the same and gets the whole transfer path.

use crate::error::Result;

use crate::float::Real;
use rand_core::Rng;

/// One sampled transition `(s, a, r, s′, ω)`: spec §1's record without its time index.
///
/// `Default` is the all-zero record (action 0, not absorbing) when `S` has a default;
/// for a state `[T; D]` of any `D`, [`Transition::EMPTY`] is the same record as a `const`,
/// for storage in a `static`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Transition<S, T> {
    /// The state the action was taken in.
    pub state: S,
    /// The action index.
    pub action: usize,
    /// The observed (noisy) reward.
    pub reward: T,
    /// The observed next state.
    pub next_state: S,
    /// `true` when the next state is absorbing (the episode ends there).
    pub absorbing: bool,
}

impl<T: Real, const D: usize> Transition<[T; D], T> {
    /// The all-zero record (state and next state 0, action 0, reward 0, not absorbing):
    /// `static mut SAMPLES: [Transition<[f32; 4], f32>; 64] = [Transition::EMPTY; 64];`.
    pub const EMPTY: Self = Self {
        state: [T::ZERO; D],
        action: 0,
        reward: T::ZERO,
        next_state: [T::ZERO; D],
        absorbing: false,
    };
}

/// A simulator that returns one sampled transition from *any* state-action pair.
///
/// This is the only access the active algorithms have to a target task (thesis §4.1.1):
/// the budget is counted in calls to [`GenerativeModel::query`].
pub trait GenerativeModel<T: Real> {
    /// The state type (`[T; 2]` for Puddle World and the Dam, `[T; 4]` for Acrobot, a cell
    /// index for Grid World).
    type State: Copy;

    /// Number of actions; valid actions are `0..num_actions()`.
    fn num_actions(&self) -> usize;

    /// Samples one transition from `state` under `action`, drawing noise from `rng`.
    ///
    /// Errors: a non-finite or out-of-range state, or an action `>= num_actions()`.
    fn query<R: Rng + ?Sized>(
        &self,
        state: Self::State,
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<Self::State, T>>;
}

/// A model lent by reference is a model: a learner can borrow a plant that lives in a
/// `static` or is shared with the rest of the firmware, instead of holding a copy of it
/// (for Puddle World's 200-byte model, 200 bytes less in every frame that holds the learner).
impl<T: Real, G: GenerativeModel<T> + ?Sized> GenerativeModel<T> for &G {
    type State = G::State;

    fn num_actions(&self) -> usize {
        (**self).num_actions()
    }

    fn query<R: Rng + ?Sized>(
        &self,
        state: Self::State,
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<Self::State, T>> {
        (**self).query(state, action, rng)
    }
}

/// A fully known finite MDP with Gaussian rewards (spec §10.1).
///
/// States are `0..num_states()`, actions `0..num_actions()`. Rewards are
/// 𝒩(`reward_mean`, `reward_variance`), independent of the next state.
pub trait FiniteMdp<T: Real> {
    /// Number of states |𝒮|.
    fn num_states(&self) -> usize;
    /// Number of actions |𝒜|.
    fn num_actions(&self) -> usize;
    /// The deterministic initial state s₀.
    fn initial_state(&self) -> usize;
    /// The exact probability p(s′ | s, a).
    ///
    /// Errors: any index out of range ([`crate::Error::OutOfRange`]).
    fn transition_probability(&self, state: usize, action: usize, next_state: usize) -> Result<T>;
    /// Calls `visit(s′, p(s′ | s, a))` for every successor with non-zero probability, so
    /// sparse models (the Grid World has one successor) cost O(successors), not O(|𝒮|).
    ///
    /// Errors: `state` or `action` out of range.
    fn for_each_successor<F: FnMut(usize, T)>(
        &self,
        state: usize,
        action: usize,
        visit: F,
    ) -> Result<()>;
    /// The mean reward r(s, a).
    ///
    /// Errors: `state` or `action` out of range.
    fn reward_mean(&self, state: usize, action: usize) -> Result<T>;
    /// The reward variance v(s, a) (> 0).
    ///
    /// Errors: `state` or `action` out of range.
    fn reward_variance(&self, state: usize, action: usize) -> Result<T>;
}

/// What a source says about a state-action pair: its (estimated) mean reward and mean next
/// state.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SourceMeans<T, const D: usize> {
    /// `ρ_r`, the mean reward.
    pub reward: T,
    /// `ρ_s′`, the mean next state.
    pub next_state: [T; D],
}

/// A source task as the score table (and the ideal weights) see it: its mean reward and mean next state at any
/// state-action pair.
///
/// A plant whose noise-free mean functions are known implements it to give the *oracle*
/// table (Puddle World does, spec §2.4; the same means give §7.7's ideal weights);
/// [`crate::score::GpSourceModel`] estimates them from a source's data (the *realistic* table).
pub trait SourceModel<T: Real, const D: usize> {
    /// The mean reward and next state at `(state, action)`.
    ///
    /// Errors: whatever the model reports for an invalid state or action.
    fn predict(&self, state: [T; D], action: usize) -> Result<SourceMeans<T, D>>;
}
