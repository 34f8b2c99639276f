//! Weighted fitted Q-iteration over a tabular discretisation of a continuous `D`-dimensional
//! state space (spec §5, §7.2 step 5).
//!
//! The regressor of every iteration is a table: the state space is cut into a uniform
//! [`CellGrid`], and the fitted value of a (cell, action) pair is the weighted mean of the
//! regression targets of the samples that start in that cell with that action. This
//! replaces the reference's Extra-Trees (§4.1), which cannot live in fixed memory; the
//! IWFQI structure is kept exactly:
//!
//! 1. **Iteration 1** fits the reward with the **reward weights** `w_r`; the result is the
//!    reward model `R̂` (and `Q₁ = R̂`).
//! 2. Every sample's reward is replaced by the model's value `r̂ᵢ = R̂(sᵢ, aᵢ)`.
//! 3. **Iterations 2..N** fit `yᵢ = r̂ᵢ + γ (1 − ωᵢ) maxₐ′ Q_{k−1}(s′ᵢ, a′)` with the
//!    **transition weights** `w_s`; an absorbing sample (`ω = 1`) does not bootstrap.
//!
//! Because `r̂` is constant in a cell, iteration k gives
//! `Q_k(c, a) = R̂(c, a) + γ · Σ w_s (1−ω) V_{k−1}(s′) / Σ w_s` over the pair's samples, which
//! is what [`TabularFqi::fit`] computes in O(samples + cells·actions) per iteration. With
//! all weights 1 this is plain FQI on the same discretisation (the no-transfer baseline,
//! [`SampleSet::unweighted`]): the weighted mean of `r̂ᵢ` is the cell's mean reward.
//!
//! **Pairs with no sample.** A (cell, action) pair with no sample of positive weight has no
//! regression target; [`EmptyCells`] decides what it predicts:
//! - [`EmptyCells::Nearest`]: the fitted value of the nearest pair with data, for the same
//!   action — nearest in cell-index units (Euclidean, `Σ_k Δi_k²`), ties broken by the
//!   smallest cell index. This mimics the reference's trees, which extend a leaf's value
//!   over the region around its samples.
//! - [`EmptyCells::CappedNearest`] (the default, [`FqiConfig::published`]): the same, but
//!   never more than the lowest value of the actions that have data in the same cell.
//!   Plain nearest filling is optimistic for actions never tried where the data lie: with
//!   the narrow paths of source data and AWFQI's scattered queries, a greedy policy would
//!   pick an untried action whose value was copied from a cell near the goal — e.g. "up"
//!   at the top border, which loops in place — and never learn otherwise. The cap makes
//!   tried actions win in visited cells and keeps nearest filling where nothing was tried.
//! - [`EmptyCells::Value`]: a fixed value.
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

mod grid;
pub mod knn;
mod q_function;
pub mod sweep;
mod tiles;
pub mod trees;

pub use grid::CellGrid;
pub use knn::{Kernel, KnnFqi, KnnRecord, KnnStorage, Neighbours};
pub use q_function::{Approximator, Greedy, QFunction, QStorage};
pub use sweep::{ModelSweep, RewardModel, SweepEntry, SweepFqi, SweepNode, SweepStorage};
pub use tiles::{TileFqi, Tilings};
pub use trees::{ExtraTrees, TreeFqi, TreeNode, TreeRecord, TreeStorage};

use crate::env::Transition;
use crate::error::ensure_finite;
use crate::{Error, Real, Result};

/// "No donor" marker in [`FqiEntry`].
const NIL: u32 = u32::MAX;

/// One (cell, action) pair of the table: the Q-value and the working values of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FqiEntry<T> {
    q: T,
    reward: T,
    weight: T,
    next: T,
    donor: u32,
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
}

/// What a (cell, action) pair with no sample of positive weight predicts.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EmptyCells<T> {
    /// The value of the nearest pair with data, same action (ties: smallest cell index);
    /// 0 when the action has no data at all.
    Nearest,
    /// As [`EmptyCells::Nearest`], but never more than the lowest value among the actions
    /// that do have data in the same cell: an action never tried in a visited cell is not
    /// preferred to the tried ones (pessimism for unseen actions; the default).
    CappedNearest,
    /// This fixed value.
    Value(T),
}

/// Validated settings of a fit: discount γ, number of iterations N and the handling of
/// pairs without data.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FqiConfig<T> {
    discount: T,
    iterations: usize,
    empty_cells: EmptyCells<T>,
    min_weight: T,
}

impl<T: Real> FqiConfig<T> {
    /// Checks and stores the settings.
    ///
    /// Errors: `discount` non-finite or outside `[0, 1]`, `iterations == 0`, a non-finite
    /// [`EmptyCells::Value`].
    pub fn new(discount: T, iterations: usize, empty_cells: EmptyCells<T>) -> Result<Self> {
        ensure_finite(discount, "discount")?;
        if !(T::ZERO..=T::ONE).contains(&discount) {
            return Err(Error::InvalidParameter {
                parameter: "discount",
            });
        }
        if iterations == 0 {
            return Err(Error::InvalidParameter {
                parameter: "iterations",
            });
        }
        if let EmptyCells::Value(v) = empty_cells {
            ensure_finite(v, "empty_cells")?;
        }
        Ok(Self {
            discount,
            iterations,
            empty_cells,
            min_weight: T::ZERO,
        })
    }

    /// The same settings with pairs whose total sample weight is below `min_weight`
    /// counted as having no data (see the module docs); 0, the default of
    /// [`FqiConfig::new`], counts any positive weight.
    ///
    /// Errors: a non-finite or negative `min_weight`.
    pub fn with_min_weight(self, min_weight: T) -> Result<Self> {
        ensure_finite(min_weight, "min_weight")?;
        if min_weight < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "min_weight",
            });
        }
        Ok(Self { min_weight, ..self })
    }

    /// The published settings (§5, §13): γ = 0.99, 60 iterations, and for pairs without
    /// data [`EmptyCells::CappedNearest`] with a minimum total weight of 0.5
    /// (**\[CHOICE\]**: half a target sample's worth; unweighted data are unaffected).
    pub fn published() -> Self {
        Self {
            discount: T::from_f64(0.99),
            iterations: 60,
            empty_cells: EmptyCells::CappedNearest,
            min_weight: T::from_f64(0.5),
        }
    }

    /// The discount γ.
    pub fn discount(&self) -> T {
        self.discount
    }

    /// The number of iterations N (iteration 1 fits the reward).
    pub fn iterations(&self) -> usize {
        self.iterations
    }

    /// The handling of pairs without data.
    pub fn empty_cells(&self) -> EmptyCells<T> {
        self.empty_cells
    }

    /// The total weight below which a pair counts as having no data.
    pub fn min_weight(&self) -> T {
        self.min_weight
    }
}

/// A slice of samples with optional per-sample weights (absent = all 1) and optional
/// rewards that replace the samples' own (absent = their own).
///
/// AWFQI passes the target samples (unweighted) and one set per source, so the records
/// never need to be copied into one buffer; adaptive AWFQI's relabelling passes the
/// sources' rewards as the target sees them beside the untouched records.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleSet<'a, T, const D: usize> {
    samples: &'a [Transition<[T; D], T>],
    reward_weights: Option<&'a [T]>,
    transition_weights: Option<&'a [T]>,
    rewards: Option<&'a [T]>,
}

impl<'a, T: Real, const D: usize> SampleSet<'a, T, D> {
    /// Samples with weight 1 everywhere.
    pub fn unweighted(samples: &'a [Transition<[T; D], T>]) -> Self {
        Self {
            samples,
            reward_weights: None,
            transition_weights: None,
            rewards: None,
        }
    }

    /// Samples with reward weights (iteration 1) and transition weights (iterations ≥ 2);
    /// `None` means all 1. Lengths are checked by [`TabularFqi::fit`].
    pub fn weighted(
        samples: &'a [Transition<[T; D], T>],
        reward_weights: Option<&'a [T]>,
        transition_weights: Option<&'a [T]>,
    ) -> Self {
        Self {
            samples,
            reward_weights,
            transition_weights,
            rewards: None,
        }
    }

    /// The same set fitted on `rewards` (one per sample, in order) instead of the samples'
    /// own rewards; `None` keeps their own. The length and finiteness are checked by the
    /// fit, like the weights'.
    pub fn with_rewards(self, rewards: Option<&'a [T]>) -> Self {
        Self { rewards, ..self }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// `true` when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    fn validate(&self, actions: usize) -> Result<()> {
        if let Some(r) = self.rewards {
            if r.len() != self.samples.len() {
                return Err(Error::InvalidParameter {
                    parameter: "rewards",
                });
            }
            crate::error::ensure_all_finite(r, "reward")?;
        }
        for (weights, name) in [
            (self.reward_weights, "reward_weights"),
            (self.transition_weights, "transition_weights"),
        ] {
            if let Some(w) = weights {
                if w.len() != self.samples.len() {
                    return Err(Error::InvalidParameter { parameter: name });
                }
                for &x in w {
                    ensure_finite(x, name)?;
                    if x < T::ZERO {
                        return Err(Error::InvalidParameter { parameter: name });
                    }
                }
            }
        }
        for s in self.samples {
            if s.action >= actions {
                return Err(Error::OutOfRange {
                    parameter: "action",
                });
            }
            ensure_finite(s.reward, "reward")?;
            crate::error::ensure_all_finite(&s.state, "state")?;
            crate::error::ensure_all_finite(&s.next_state, "next_state")?;
        }
        Ok(())
    }

    /// `(sample, reward, w_r, w_s)`: the reward is the replacement when there is one.
    fn iter(&self) -> impl Iterator<Item = (&'a Transition<[T; D], T>, T, T, T)> + '_ {
        self.samples.iter().enumerate().map(|(i, s)| {
            let pick = |w: Option<&[T]>| w.and_then(|w| w.get(i).copied()).unwrap_or(T::ONE);
            let reward = self
                .rewards
                .and_then(|r| r.get(i).copied())
                .unwrap_or(s.reward);
            (
                s,
                reward,
                pick(self.reward_weights),
                pick(self.transition_weights),
            )
        })
    }
}

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
        let mut total = 0usize;
        for set in sets.clone() {
            set.validate(self.actions)?;
            total += set.len();
        }
        if total == 0 {
            return Err(Error::EmptyData);
        }
        check_magnitudes(sets.clone(), config)?;
        self.fit_reward_model(sets.clone(), config);
        for e in self.entries.iter_mut() {
            e.q = e.reward;
        }
        if config.iterations > 1 {
            // Transition donors replace the reward donors (no longer needed).
            nearest_donors(&self.grid, self.actions, self.entries, |e| {
                e.weight > T::ZERO
            });
            for _ in 1..config.iterations {
                self.bellman_iteration(sets.clone(), config);
            }
        }
        Ok(())
    }

    /// Iteration 1: `R̂` into `reward`, `Σ w_s` into `weight`.
    fn fit_reward_model<'s>(
        &mut self,
        sets: impl Iterator<Item = SampleSet<'s, T, D>>,
        config: &FqiConfig<T>,
    ) where
        T: 's,
    {
        for e in self.entries.iter_mut() {
            *e = FqiEntry::default();
        }
        for set in sets {
            for (s, reward, w_r, w_s) in set.iter() {
                let i = self.index(s.state, s.action);
                if let Some(e) = self.entries.get_mut(i) {
                    // `next` holds Σ w_r while the reward model is being fitted.
                    e.reward += w_r * reward;
                    e.next += w_r;
                    e.weight += w_s;
                }
            }
        }
        for e in self.entries.iter_mut() {
            // Totals below the minimum weight count as no data.
            if e.next < config.min_weight {
                e.next = T::ZERO;
            }
            if e.weight < config.min_weight {
                e.weight = T::ZERO;
            }
            if e.next > T::ZERO {
                e.reward /= e.next;
            }
        }
        nearest_donors(&self.grid, self.actions, self.entries, |e| e.next > T::ZERO);
        fill_empty(
            self.entries,
            self.actions,
            config.empty_cells,
            |e| e.next > T::ZERO,
            |e| &mut e.reward,
        );
    }

    /// One iteration k ≥ 2: Q ← R̂ + γ·(weighted mean of (1−ω)·V_{k−1}(s′)).
    fn bellman_iteration<'s>(
        &mut self,
        sets: impl Iterator<Item = SampleSet<'s, T, D>>,
        config: &FqiConfig<T>,
    ) where
        T: 's,
    {
        for e in self.entries.iter_mut() {
            e.next = T::ZERO;
        }
        for set in sets {
            for (s, _, _, w_s) in set.iter() {
                if w_s <= T::ZERO || s.absorbing {
                    continue;
                }
                let v = self.max_value_finite(s.next_state);
                let i = self.index(s.state, s.action);
                if let Some(e) = self.entries.get_mut(i) {
                    e.next += w_s * v;
                }
            }
        }
        let gamma = config.discount;
        for e in self.entries.iter_mut() {
            if e.weight > T::ZERO {
                e.q = e.reward + gamma * (e.next / e.weight);
            }
        }
        fill_empty(
            self.entries,
            self.actions,
            config.empty_cells,
            |e| e.weight > T::ZERO,
            |e| &mut e.q,
        );
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
    /// The first rule only matters for filled values: under [`EmptyCells::CappedNearest`]
    /// an untried action can equal the worst tried one, and must not win the tie by its
    /// index alone (a source dataset from a deterministic policy tries one action per cell).
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        self.grid.cell_of(state)?;
        let mut best = 0;
        let mut best_q = T::NEG_INFINITY;
        let mut best_has_data = false;
        for (a, e) in self.row(state).iter().enumerate() {
            let has_data = e.has_data();
            let better = a == 0 || e.q > best_q || (e.q == best_q && has_data && !best_has_data);
            if better {
                best = a;
                best_q = e.q;
                best_has_data = has_data;
            }
        }
        Ok(best)
    }
}

/// Sets every entry's `donor` to the entry index of the nearest entry with the same action
/// for which `has_data` holds (itself if it holds), or [`NIL`] when the action has none.
///
/// Nearest in cell-index units, Euclidean; ties go to the smallest cell index. Shells of
/// growing Chebyshev radius are scanned around the cell until the radius exceeds the best
/// distance found, so the search is exact and costs O(d^D) for a cell at distance d.
fn nearest_donors<T: Real, const D: usize>(
    grid: &CellGrid<T, D>,
    actions: usize,
    entries: &mut [FqiEntry<T>],
    has_data: impl Fn(&FqiEntry<T>) -> bool,
) {
    let cells = grid.len();
    for action in 0..actions {
        let visited = |cell: usize, entries: &[FqiEntry<T>]| {
            entries.get(cell * actions + action).is_some_and(&has_data)
        };
        let any = (0..cells).any(|c| visited(c, entries));
        for cell in 0..cells {
            let donor = if !any {
                NIL
            } else if visited(cell, entries) {
                (cell * actions + action) as u32
            } else {
                nearest_visited(grid, cell, |c| visited(c, entries))
                    .map_or(NIL, |c| (c * actions + action) as u32)
            };
            if let Some(e) = entries.get_mut(cell * actions + action) {
                e.donor = donor;
            }
        }
    }
}

/// The nearest cell to `cell` (not itself) for which `visited` holds; see
/// [`nearest_donors`].
fn nearest_visited<T: Real, const D: usize>(
    grid: &CellGrid<T, D>,
    cell: usize,
    visited: impl Fn(usize) -> bool,
) -> Option<usize> {
    let dims = grid.cells();
    let centre = grid.coordinates(cell)?.map(|c| c as isize);
    let max_radius = dims.iter().copied().max().unwrap_or(0) as isize;
    let mut best: Option<(isize, usize)> = None;
    for r in 1..=max_radius {
        if let Some((bd, _)) = best {
            if r * r > bd {
                break;
            }
        }
        // The part of the cube [c − r, c + r] inside the grid, as offsets (lo ≤ 0 ≤ hi).
        let mut lo = [0isize; D];
        let mut hi = [0isize; D];
        for (((l, h), &c), &n) in lo.iter_mut().zip(hi.iter_mut()).zip(&centre).zip(&dims) {
            *l = (-r).max(-c);
            *h = r.min(n as isize - 1 - c);
        }
        for_each_on_shell(r, &lo, &hi, |offset| {
            let mut index = 0usize;
            let mut stride = 1usize;
            let mut d2 = 0isize;
            for ((&o, &c), &n) in offset.iter().zip(&centre).zip(&dims) {
                index += (c + o) as usize * stride;
                stride *= n;
                d2 += o * o;
            }
            if !visited(index) {
                return;
            }
            let better = match best {
                None => true,
                Some((bd, bc)) => d2 < bd || (d2 == bd && index < bc),
            };
            if better {
                best = Some((d2, index));
            }
        });
    }
    best.map(|(_, c)| c)
}

/// Calls `visit` with every offset `o` with `lo ≤ o ≤ hi` (per axis) whose largest
/// |coordinate| is exactly `r`: the Chebyshev shell of radius `r`, clipped. An odometer runs
/// over the first `D − 1` axes; the last axis takes every value when an earlier one is on
/// the shell already, else only `±r`, so each offset of the shell is visited once.
fn for_each_on_shell<const D: usize>(
    r: isize,
    lo: &[isize; D],
    hi: &[isize; D],
    mut visit: impl FnMut(&[isize; D]),
) {
    let Some((&last_lo, &last_hi)) = lo.last().zip(hi.last()) else {
        return;
    };
    let prefix = D - 1;
    let mut offset = *lo;
    loop {
        let on_shell = offset.iter().take(prefix).any(|o| o.abs() == r);
        if on_shell {
            for o in last_lo..=last_hi {
                if let Some(slot) = offset.last_mut() {
                    *slot = o;
                }
                visit(&offset);
            }
        } else {
            for o in [-r, r] {
                if (last_lo..=last_hi).contains(&o) {
                    if let Some(slot) = offset.last_mut() {
                        *slot = o;
                    }
                    visit(&offset);
                }
            }
        }
        // Advance the odometer over the prefix axes.
        let mut k = 0;
        loop {
            if k == prefix {
                return;
            }
            match (offset.get_mut(k), lo.get(k), hi.get(k)) {
                (Some(o), Some(&l), Some(&h)) => {
                    if *o < h {
                        *o += 1;
                        break;
                    }
                    *o = l;
                }
                _ => return,
            }
            k += 1;
        }
    }
}

/// For every entry without data, sets `field` from its donor (or to the configured value,
/// or 0 when there is no donor).
fn fill_empty<T: Real>(
    entries: &mut [FqiEntry<T>],
    actions: usize,
    empty: EmptyCells<T>,
    has_data: impl Fn(&FqiEntry<T>) -> bool,
    field: impl Fn(&mut FqiEntry<T>) -> &mut T,
) {
    for i in 0..entries.len() {
        let Some(e) = entries.get(i) else { break };
        if has_data(e) {
            continue;
        }
        let donor = e.donor as usize;
        let value = match empty {
            EmptyCells::Value(v) => v,
            EmptyCells::Nearest => entries.get_mut(donor).map_or(T::ZERO, |d| *field(d)),
            EmptyCells::CappedNearest => {
                let nearest = entries.get_mut(donor).map_or(T::ZERO, |d| *field(d));
                // The lowest value among the actions with data in the same cell, if any.
                let start = i - i.checked_rem(actions).unwrap_or(0);
                let mut cap = T::INFINITY;
                for j in start..start + actions {
                    if let Some(other) = entries.get_mut(j) {
                        if has_data(other) {
                            cap = cap.min(*field(other));
                        }
                    }
                }
                nearest.min(cap)
            }
        };
        if let Some(e) = entries.get_mut(i) {
            *field(e) = value;
        }
    }
}

/// Rejects finite inputs whose fit could overflow `T`: every sum of the fit is bounded by
/// `Σ w_r·|r|` or by `(Σ w_r + Σ w_s) · max|Q|`, and `|Q_k| ≤ k · max(|r|, |fill value|)`
/// (weighted means never exceed their largest term), so when these bounds are finite (with
/// a factor 4 for rounding) so is every value the fit computes.
fn check_magnitudes<'s, T: Real + 's, const D: usize>(
    sets: impl Iterator<Item = SampleSet<'s, T, D>>,
    config: &FqiConfig<T>,
) -> Result<()> {
    let mut reward_mass = T::ZERO;
    let mut weight_mass = T::ZERO;
    let mut largest = match config.empty_cells {
        EmptyCells::Value(v) => v.abs(),
        _ => T::ZERO,
    };
    for set in sets {
        for (_, reward, w_r, w_s) in set.iter() {
            reward_mass += w_r * reward.abs();
            weight_mass += w_r + w_s;
            largest = largest.max(reward.abs());
        }
    }
    let bound =
        largest * T::from_usize(config.iterations) * (T::ONE + weight_mass) * T::from_f64(4.0);
    if reward_mass.is_finite() && bound.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            parameter: "reward",
        })
    }
}

#[cfg(test)]
mod tests;
