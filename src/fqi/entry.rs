//! One (cell, action) pair of a table or of one tiling: the storage unit of
//! [`TabularFqi`](super::TabularFqi) and [`TileFqi`](super::TileFqi).

use crate::float::Real;

/// "No donor" marker in [`FqiEntry`].
pub(super) const NIL: u32 = u32::MAX;

/// One (cell, action) pair of the table: the Q-value and the working values of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FqiEntry<T> {
    pub(super) q: T,
    pub(super) reward: T,
    pub(super) weight: T,
    pub(super) next: T,
    pub(super) donor: u32,
}

impl<T: Real> Default for FqiEntry<T> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<T: Real> FqiEntry<T> {
    /// An entry of a fresh table (Q = 0, no data); `const` and all-zero, so storage can be
    /// a zero-initialised `static` (`.bss`, no flash image):
    /// `static mut TABLE: [FqiEntry<f32>; 484] = [FqiEntry::EMPTY; 484];`.
    /// (The donor field is only read during a fit, after it has been computed.)
    pub const EMPTY: Self = Self {
        q: T::ZERO,
        reward: T::ZERO,
        weight: T::ZERO,
        next: T::ZERO,
        donor: 0,
    };

    /// The fitted Q-value.
    pub fn q(&self) -> T {
        self.q
    }

    /// The fitted reward model `R̂` (iteration 1).
    pub fn reward_model(&self) -> T {
        self.reward
    }

    /// Total transition weight `Σ w_s` of the pair's samples (0: no data after iteration 1).
    pub fn transition_weight(&self) -> T {
        self.weight
    }

    /// `true` when the last fit had a sample of positive transition weight for this pair
    /// (its Q-value is fitted, not filled).
    pub fn has_data(&self) -> bool {
        self.weight > T::ZERO
    }

    /// Iteration 1: adds a sample's weighted reward and weights to the pair's sums (`next`
    /// holds `Σ w_r` while the reward model is being fitted).
    pub(super) fn add_reward(&mut self, reward: T, w_r: T, w_s: T) {
        self.reward += w_r * reward;
        self.next += w_r;
        self.weight += w_s;
    }

    /// Ends iteration 1's sums: a total below `min_weight` counts as no data (0), and the
    /// reward sum becomes the weighted mean `R̂` where there is reward weight.
    pub(super) fn close_reward_model(&mut self, min_weight: T) {
        if self.next < min_weight {
            self.next = T::ZERO;
        }
        if self.weight < min_weight {
            self.weight = T::ZERO;
        }
        if self.next > T::ZERO {
            self.reward /= self.next;
        }
    }
}
