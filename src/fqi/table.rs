//! Weighted fitted Q-iteration over a tabular discretisation of a continuous `D`-dimensional
//! state space (spec §5, §7.2 step 5).
//!
//! The regressor of every iteration is a table: the state space is cut into a uniform
//! [`CellGrid`], and the fitted value of a (cell, action) pair is the weighted mean of the
//! regression targets of the samples that start in that cell with that action. This
//! replaces the reference's Extra-Trees (§4.1), which cannot live in fixed memory; the
//! IWFQI structure ([module docs](super)) is kept exactly.
//!
//! Because `r̂` is constant in a cell, iteration k gives
//! `Q_k(c, a) = R̂(c, a) + γ · Σ w_s (1−ω) V_{k−1}(s′) / Σ w_s` over the pair's samples, which
//! is what [`TabularFqi::fit`] computes in O(samples + cells·actions) per iteration. With
//! all weights 1 this is plain FQI on the same discretisation (the no-transfer baseline,
//! [`SampleSet::unweighted`]): the weighted mean of `r̂ᵢ` is the cell's mean reward.
//!
//! **Pairs with no sample.** A (cell, action) pair with no sample of positive weight has no
//! regression target; [`EmptyCells`](super::EmptyCells) decides what it predicts:
//! - [`EmptyCells::Nearest`](super::EmptyCells::Nearest): the fitted value of the nearest pair with data, for the same
//!   action — nearest in cell-index units (Euclidean, `Σ_k Δi_k²`), ties broken by the
//!   smallest cell index. This mimics the reference's trees, which extend a leaf's value
//!   over the region around its samples.
//! - [`EmptyCells::CappedNearest`](super::EmptyCells::CappedNearest) (the default, [`FqiConfig::published`]): the same, but
//!   never more than the lowest value of the actions that have data in the same cell.
//!   Plain nearest filling is optimistic for actions never tried where the data lie: with
//!   the narrow paths of source data and AWFQI's scattered queries, a greedy policy would
//!   pick an untried action whose value was copied from a cell near the goal — e.g. "up"
//!   at the top border, which loops in place — and never learn otherwise. The cap makes
//!   tried actions win in visited cells and keeps nearest filling where nothing was tried.
//! - [`EmptyCells::Value`](super::EmptyCells::Value): a fixed value.
//!
//! **Near-zero weights.** A pair "has data" when the total weight of its samples reaches
//! [`FqiConfig::with_min_weight`] (0.5 in [`FqiConfig::published`], i.e. half a target
//! sample's worth). A weighted mean over samples whose weights are all tiny is still their
//! plain mean, so without this threshold a cell holding only source records that the
//! weights all but discard (e.g. weight 10⁻²⁰ where the target has a puddle) would keep
//! their reward. The reference's trees avoid this by merging near-zero-weight samples into
//! the leaves of positive-weight neighbours (§4.1 notes, §14.9); the threshold is the
//! tabular counterpart, and the fill rule then supplies the value.
//!
//! An action with no data anywhere gets 0 under the nearest rules (as the reference's
//! forest of total weight 0 predicts 0, §4.1). The reward model and the later iterations
//! have their own "has data" sets (positive `w_r` and positive `w_s` respectively).
//!
//! **Memory.** All state lives in one caller slice of [`FqiEntry`], one per (cell, action)
//! pair (index `cell·actions + action`): 4 `T` and a `u32` = 20 bytes in `f32`, 40 in
//! `f64`. A 21 × 21 grid with 4 actions needs 1 764 entries = 35 280 bytes in `f32`.

use super::argmax::ArgMax;
use super::entry::{FqiEntry, NIL};
use super::fill::{fill_empty, nearest_donors};
use super::iteration::{self, NoDraws, Regressor};
use super::samples::each;
use super::{CellGrid, FqiConfig, SampleSet};
use crate::error::{Error, Result};
use crate::float::Real;
use rand_core::Rng;

/// A tabular Q-function on a [`CellGrid`] with `actions` actions, fitted by weighted FQI,
/// over caller-provided [`FqiEntry`] storage.
#[derive(Debug)]
pub struct TabularFqi<'a, T, const D: usize> {
    grid: CellGrid<T, D>,
    actions: usize,
    entries: &'a mut [FqiEntry<T>],
}

impl<'a, T: Real, const D: usize> TabularFqi<'a, T, D> {
    /// Number of [`FqiEntry`] a grid with `actions` actions needs (`None` on overflow).
    pub fn required_entries(grid: &CellGrid<T, D>, actions: usize) -> Option<usize> {
        grid.len().checked_mul(actions)
    }

    /// A Q-function that is 0 everywhere, in the first `grid.len()·actions` entries of
    /// `storage`.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]); `storage` too short
    /// ([`Error::CapacityExceeded`] with its length), or more pairs than `u32::MAX − 1`.
    pub fn new(
        grid: CellGrid<T, D>,
        actions: usize,
        storage: &'a mut [FqiEntry<T>],
    ) -> Result<Self> {
        if actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        let limit = NIL as usize - 1;
        let needed = Self::required_entries(&grid, actions)
            .filter(|&n| n <= limit)
            .ok_or(Error::CapacityExceeded { capacity: limit })?;
        if storage.len() < needed {
            return Err(Error::CapacityExceeded {
                capacity: storage.len(),
            });
        }
        let entries = storage
            .get_mut(..needed)
            .ok_or(Error::CapacityExceeded { capacity: needed })?;
        entries.fill(FqiEntry::EMPTY);
        Ok(Self {
            grid,
            actions,
            entries,
        })
    }

    /// The grid.
    pub fn grid(&self) -> &CellGrid<T, D> {
        &self.grid
    }

    /// Number of actions.
    pub fn actions(&self) -> usize {
        self.actions
    }

    /// The table, `cell·actions + action` → entry.
    pub fn entries(&self) -> &[FqiEntry<T>] {
        self.entries
    }

    /// Resets Q to 0 everywhere.
    pub fn clear(&mut self) {
        self.entries.fill(FqiEntry::default());
    }

    /// Fits Q from scratch by weighted FQI on the union of `sets` (see the module docs).
    ///
    /// Everything is checked before the table changes. Errors: no samples at all
    /// ([`Error::EmptyData`]); an action `≥ actions` ([`Error::OutOfRange`]); a
    /// non-finite state, next state, reward or weight ([`Error::NonFinite`]); a negative
    /// weight or a weight slice whose length differs from its samples'
    /// ([`Error::InvalidParameter`]); rewards, weights and iterations so large that a
    /// value of the fit could overflow `T` ([`Error::InvalidParameter`] `reward`).
    pub fn fit(&mut self, sets: &[SampleSet<'_, T, D>], config: &FqiConfig<T>) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config)
    }

    /// [`TabularFqi::fit`] on sets produced by an iterator, so a caller can assemble them
    /// (target samples, then one set per source) without a buffer. The iterator is cloned
    /// once per pass over the data.
    ///
    /// Errors: those of [`TabularFqi::fit`].
    pub fn fit_sets<'s, I>(&mut self, sets: I, config: &FqiConfig<T>) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        iteration::fit(self, sets, config, &mut NoDraws)
    }

    fn index(&self, state: [T; D], action: usize) -> usize {
        self.grid.cell_of_finite(state) * self.actions + action
    }

    fn row(&self, state: [T; D]) -> &[FqiEntry<T>] {
        let start = self.grid.cell_of_finite(state) * self.actions;
        self.entries
            .get(start..start + self.actions)
            .unwrap_or_default()
    }

    fn max_value_finite(&self, state: [T; D]) -> T {
        self.row(state)
            .iter()
            .map(|e| e.q)
            .fold(T::NEG_INFINITY, |m, q| if q > m { q } else { m })
    }

    /// `Q(state, action)`.
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        self.grid.cell_of(state)?;
        self.row(state)
            .get(action)
            .map(|e| e.q)
            .ok_or(Error::OutOfRange {
                parameter: "action",
            })
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        self.grid.cell_of(state)?;
        Ok(self.max_value_finite(state))
    }

    /// The greedy action `argmaxₐ Q(state, a)`. Ties go first to an action that has data in
    /// the state's cell, then to the smallest action index (§3.1).
    ///
    /// The first rule only matters for filled values: under [`EmptyCells::CappedNearest`](super::EmptyCells::CappedNearest)
    /// an untried action can equal the worst tried one, and must not win the tie by its
    /// index alone (a source dataset from a deterministic policy tries one action per cell).
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        self.grid.cell_of(state)?;
        let mut best = ArgMax::new();
        for (a, e) in self.row(state).iter().enumerate() {
            best.offer(a, e.q, e.has_data());
        }
        Ok(best.action())
    }
}

impl<T: Real, const D: usize> Regressor<T, D> for TabularFqi<'_, T, D> {
    fn actions(&self) -> usize {
        self.actions
    }

    /// `R̂` into `reward` and `q`, `Σ w_s` into `weight`.
    fn fit_reward_model<'s, I, R>(&mut self, sets: I, _: usize, config: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        for e in self.entries.iter_mut() {
            *e = FqiEntry::default();
        }
        for (s, reward, w_r, w_s) in each(sets) {
            let i = self.index(s.state, s.action);
            if let Some(e) = self.entries.get_mut(i) {
                e.add_reward(reward, w_r, w_s);
            }
        }
        for e in self.entries.iter_mut() {
            e.close_reward_model(config.min_weight());
        }
        nearest_donors(&self.grid, self.actions, self.entries, |e| e.next > T::ZERO);
        fill_empty(
            self.entries,
            self.actions,
            config.empty_cells(),
            |e| e.next > T::ZERO,
            |e| &mut e.reward,
        );
        for e in self.entries.iter_mut() {
            e.q = e.reward;
        }
    }

    /// Q ← R̂ + γ·(weighted mean of (1−ω)·V_{k−1}(s′)).
    fn bellman_iteration<'s, I, R>(&mut self, sets: I, k: usize, config: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        if k == 2 {
            // Transition donors replace the reward donors (no longer needed).
            nearest_donors(&self.grid, self.actions, self.entries, |e| {
                e.weight > T::ZERO
            });
        }
        for e in self.entries.iter_mut() {
            e.next = T::ZERO;
        }
        for (s, _, _, w_s) in each(sets) {
            if w_s <= T::ZERO || s.absorbing {
                continue;
            }
            let v = self.max_value_finite(s.next_state);
            let i = self.index(s.state, s.action);
            if let Some(e) = self.entries.get_mut(i) {
                e.next += w_s * v;
            }
        }
        let gamma = config.discount();
        for e in self.entries.iter_mut() {
            if e.weight > T::ZERO {
                e.q = e.reward + gamma * (e.next / e.weight);
            }
        }
        fill_empty(
            self.entries,
            self.actions,
            config.empty_cells(),
            |e| e.weight > T::ZERO,
            |e| &mut e.q,
        );
    }
}

/// The entries of a table or of tile coding as one block of `E` entries (cells × actions),
/// all-zero so it can be a `static` in `.bss`.
#[derive(Debug, Clone)]
pub struct TableStorage<T, const E: usize> {
    entries: [FqiEntry<T>; E],
}

impl<T: Real, const E: usize> TableStorage<T, E> {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            entries: [FqiEntry::EMPTY; E],
        }
    }

    /// The block as the [`QStorage`](super::QStorage) a Q-function is built in.
    pub fn storage<const D: usize>(&mut self) -> super::QStorage<'_, T, D> {
        super::QStorage::from(&mut self.entries[..])
    }
}

impl<T: Real, const E: usize> Default for TableStorage<T, E> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
