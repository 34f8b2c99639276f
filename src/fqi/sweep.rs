use super::iteration::{self, NoDraws, Regressor};
use super::{CellGrid, FqiConfig, SampleSet};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::Transition;

mod interpolation;
mod nodes;

pub(crate) use nodes::{Layout, Nodes};

/// Weighted FQI as a **model sweep**: value iteration on a grid of nodes over a model
/// fitted from the weighted records, so an iteration costs `O(nodes · actions)` whatever
/// the number of records, and the memory is a few scalars per node and action.
///
/// Trees and averagers fit every iteration's regression from the records; a model sweep
/// fits from the records once per fit, then iterates on the grid. The model, per node `x`
/// (the corners of a [`CellGrid`]'s cells: `cells + 1` per axis) and action `a`, is made
/// of multilinear ("hat") averages of the records around `x` — each record spreads its
/// value over the `2^D` corners of its cell with the interpolation weights `φ`:
///
/// - **reward** `R̂(x, a) = Σ φ w_r r / Σ φ w_r` over the action's records, or over every
///   action's ([`RewardModel`]: for plants whose reward depends on the state only, so an
///   action never tried at `x` still meets the penalty the others found there);
/// - **step** `d̂(x, a) = Σ φ w_s (s′ − s) / Σ φ w_s`: the mean displacement, so an action
///   tried elsewhere moves the same way at `x` (a locally translation-invariant plant);
/// - **absorption** `Ω(y) = Σ φ(s′) w_s ω / Σ φ(s′) w_s`, spread at the records' *next*
///   states: the chance that landing at `y` ends the episode.
///
/// A node whose total weight is below [`ModelSweep::with_min_mass`] (reward) or 0 (step,
/// absorption) has no data and takes the value of the nearest node that has (Euclidean in
/// node units, ties to the smallest index, as the table's [`super::EmptyCells::Nearest`]);
/// a quantity without data anywhere is 0. Then, with `y = clamp(x + d̂(x, a))` in the box
/// and `V₀ = 0`:
///
/// ```text
/// Q_k(x, a) = R̂(x, a) + γ (1 − Ω(y)) V_{k−1}(y),   V_k(x) = maxₐ Q_k(x, a),
/// ```
///
/// `V` and `Ω` interpolated multilinearly at `y`, for [`FqiConfig::iterations`] iterations
/// (iteration 1 is `R̂`, as FQI's first). A decision at a state `s` interpolates the node
/// Q-values of `s`'s cell (or, with [`ModelSweep::with_lookahead`], takes `R̂`, `d̂` at
/// `s` and looks one step ahead). Reward weights enter `R̂` only, transition weights `d̂`
/// and `Ω`, as in IWFQI.
///
/// **Memory.** One [`SweepEntry`] per node and action (`1 + D` scalars: 12 bytes for `f32`,
/// `D = 2`) and one [`SweepNode`] per node (3 scalars). A 21 × 21 node grid (20 cells per
/// axis) with 4 actions: 21 168 + 5 292 bytes. No randomness.
///
/// The settings of a model sweep: the grid and the model's options. What a caller chooses
/// before storage exists.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelSweep<T, const D: usize> {
    cells: CellGrid<T, D>,
    /// The nodes as a grid of `cells + 1` per axis (index arithmetic and donor search).
    nodes: CellGrid<T, D>,
    /// Node index steps per axis.
    strides: [usize; D],
    rewards: RewardModel,
    min_mass: T,
    lookahead: bool,
}

impl<T: Real, const D: usize> ModelSweep<T, D> {
    /// Nodes at the corners of `cells`' cells; rewards per action, any positive weight
    /// counts as data, decisions by interpolated node values.
    ///
    /// Errors: more nodes than `u32::MAX − 1` ([`Error::CapacityExceeded`]).
    pub fn new(cells: CellGrid<T, D>) -> Result<Self> {
        let nodes = CellGrid::new(cells.lower(), cells.upper(), cells.cells().map(|n| n + 1))?;
        let mut strides = [0usize; D];
        let mut stride = 1;
        for (s, &n) in strides.iter_mut().zip(&nodes.cells()) {
            *s = stride;
            stride *= n;
        }
        Ok(Self {
            cells,
            nodes,
            strides,
            rewards: RewardModel::PerAction,
            min_mass: T::ZERO,
            lookahead: false,
        })
    }

    /// `n` cells (`n + 1` nodes) on every axis of the cube `[lower, upper]^D`.
    ///
    /// Errors: those of [`CellGrid::cube`] and [`ModelSweep::new`].
    pub fn cube(lower: T, upper: T, n: usize) -> Result<Self> {
        Self::new(CellGrid::cube(lower, upper, n)?)
    }

    /// The same sweep with another reward model ([`RewardModel`]).
    pub fn with_rewards(self, rewards: RewardModel) -> Self {
        Self { rewards, ..self }
    }

    /// The same sweep with a node's reward counted as data only when its total weight
    /// `Σ φ w_r` reaches `min_mass` (a record at the node weighs 1): nodes of nearly
    /// discarded source records then take their nearest trusted neighbour's reward.
    ///
    /// Errors: a non-finite or negative `min_mass` ([`Error::InvalidParameter`]).
    pub fn with_min_mass(self, min_mass: T) -> Result<Self> {
        if !min_mass.is_finite() || min_mass < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "min_mass",
            });
        }
        Ok(Self { min_mass, ..self })
    }

    /// The same sweep deciding by one step of lookahead at the state itself
    /// (`R̂(s, a) + γ(1 − Ω(y))V(y)`, `R̂` and `d̂` interpolated at `s`) instead of
    /// interpolating the node Q-values of its cell.
    pub fn with_lookahead(self, lookahead: bool) -> Self {
        Self { lookahead, ..self }
    }

    /// The cells whose corners are the nodes.
    pub fn cells(&self) -> &CellGrid<T, D> {
        &self.cells
    }

    /// Number of nodes, `Π (cells + 1)`.
    pub fn nodes(&self) -> usize {
        self.nodes.len()
    }

    /// [`SweepEntry`]s needed with `actions` actions (`None` on overflow).
    pub fn required_entries(&self, actions: usize) -> Option<usize> {
        self.nodes.len().checked_mul(actions)
    }

    /// The reward model.
    pub fn rewards(&self) -> RewardModel {
        self.rewards
    }

    /// The least reward mass of a node with data.
    pub fn min_mass(&self) -> T {
        self.min_mass
    }

    /// `true` when decisions look one step ahead.
    pub fn lookahead(&self) -> bool {
        self.lookahead
    }
}

/// Fixed-point scale of a [`SweepEntry`]'s position within a cell: `2¹⁵` steps, so 0, ½
/// and 1 are exact.
const FRAC_ONE: u16 = 1 << 15;

/// Which records a node's reward `R̂(x, a)` averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RewardModel {
    /// The action's own records; a node without them takes its neighbours' value.
    PerAction,
    /// Every action's records: `R̂(x, a)` is the same for all `a`, for rewards that depend
    /// on the state only (Puddle World's, a set-point's cost), so an action never tried at
    /// `x` still meets the penalty the others found there.
    Pooled,
    /// The action's own records where it has some at the node, every action's elsewhere:
    /// no assumption where the action was tried, the pooled guess where it was not.
    Backfilled,
}

/// The model of one node and action: the reward and where the mean step lands, as the
/// interpolation corner of the landing point (its cell's lowest node) and its position in
/// that cell, so an iteration looks ahead without arithmetic on coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SweepEntry<T, const D: usize> {
    reward: T,
    base: u32,
    frac: [u16; D],
}

impl<T: Real, const D: usize> SweepEntry<T, D> {
    /// A fresh entry; `const` and all-zero, so storage can be a `static` in `.bss`.
    pub const EMPTY: Self = Self {
        reward: T::ZERO,
        base: 0,
        frac: [0; D],
    };

    /// The fitted reward `R̂`.
    pub fn reward(&self) -> T {
        self.reward
    }
}

impl<T: Real, const D: usize> Default for SweepEntry<T, D> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// The values of one node: `V` of the last iteration, `V` of the one before (what the
/// last iteration's Q-values look ahead to), and the absorption `Ω`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SweepNode<T> {
    value: T,
    previous: T,
    absorbing: T,
}

impl<T: Real> SweepNode<T> {
    /// A fresh node; `const` and all-zero, so storage can be a `static` in `.bss`.
    pub const EMPTY: Self = Self {
        value: T::ZERO,
        previous: T::ZERO,
        absorbing: T::ZERO,
    };

    /// `V` of the last iteration.
    pub fn value(&self) -> T {
        self.value
    }

    /// The fitted absorption `Ω`.
    pub fn absorbing(&self) -> T {
        self.absorbing
    }

    /// `V` of the iteration before the last (what the last iteration looked ahead to).
    pub(crate) fn previous(&self) -> T {
        self.previous
    }
}

impl<T: Real> Default for SweepNode<T> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// A Q-function fitted by a model sweep on a node layout `N` (the grid of
/// [`ModelSweep`], or the representative states of [`crate::fqi::AnchorSweep`]), over
/// caller-lent entries and nodes.
#[derive(Debug)]
pub struct ModelFqi<'a, T, const D: usize, N: Layout<T, D>> {
    layout: N,
    actions: usize,
    discount: T,
    entries: &'a mut [N::Entry],
    nodes: &'a mut [SweepNode<T>],
}

/// A Q-function fitted by a model sweep on a grid.
pub type SweepFqi<'a, T, const D: usize> = ModelFqi<'a, T, D, ModelSweep<T, D>>;

impl<'a, T: Real, const D: usize> SweepFqi<'a, T, D> {
    /// A Q-function that is 0 everywhere, in the first [`ModelSweep::required_entries`]
    /// entries and [`ModelSweep::nodes`] nodes of the storage.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]); `entries` or `nodes` too
    /// short ([`Error::CapacityExceeded`] with its length).
    pub fn new(
        sweep: ModelSweep<T, D>,
        actions: usize,
        entries: &'a mut [SweepEntry<T, D>],
        nodes: &'a mut [SweepNode<T>],
    ) -> Result<Self> {
        let count = sweep.nodes();
        ModelFqi::with_layout(sweep, count, actions, entries, nodes)
    }

    /// The settings.
    pub fn sweep(&self) -> &ModelSweep<T, D> {
        &self.layout
    }
}

impl<'a, T: Real, const D: usize, N: Nodes<T, D>> ModelFqi<'a, T, D, N> {
    /// A Q-function that is 0 everywhere on `layout`'s `count` nodes, in the first
    /// `count · actions` entries and `count` nodes of the storage.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]); `entries` or `nodes` too
    /// short ([`Error::CapacityExceeded`] with its length).
    pub(crate) fn with_layout(
        layout: N,
        count: usize,
        actions: usize,
        entries: &'a mut [N::Entry],
        nodes: &'a mut [SweepNode<T>],
    ) -> Result<Self> {
        if actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        let needed = count.checked_mul(actions).ok_or(Error::CapacityExceeded {
            capacity: usize::MAX,
        })?;
        let capacity = entries.len();
        let entries = entries
            .get_mut(..needed)
            .ok_or(Error::CapacityExceeded { capacity })?;
        let capacity = nodes.len();
        let nodes = nodes
            .get_mut(..count)
            .ok_or(Error::CapacityExceeded { capacity })?;
        let mut q = Self {
            layout,
            actions,
            discount: T::ZERO,
            entries,
            nodes,
        };
        q.clear();
        Ok(q)
    }

    /// The node layout.
    pub(crate) fn layout(&self) -> &N {
        &self.layout
    }

    /// Number of actions.
    pub fn actions(&self) -> usize {
        self.actions
    }

    /// The model, `node·actions + action` → entry.
    pub fn entries(&self) -> &[N::Entry] {
        self.entries
    }

    /// The nodes' values and absorption.
    pub fn nodes(&self) -> &[SweepNode<T>] {
        self.nodes
    }

    /// Resets Q to 0 everywhere.
    pub fn clear(&mut self) {
        self.entries.fill(N::EMPTY_ENTRY);
        self.nodes.fill(SweepNode::EMPTY);
        self.discount = T::ZERO;
    }

    /// Fits the model on the union of `sets` and sweeps (module docs).
    ///
    /// Errors: those of [`super::TabularFqi::fit`]; on error Q is unchanged.
    pub fn fit(&mut self, sets: &[SampleSet<'_, T, D>], config: &FqiConfig<T>) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config)
    }

    /// Fits the model on the union of `sets` and sweeps (module docs). The iterator is
    /// cloned once per pass over the data.
    ///
    /// Everything is checked before anything changes. Errors: those of
    /// [`super::TabularFqi::fit`].
    pub fn fit_sets<'s, I>(&mut self, sets: I, config: &FqiConfig<T>) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        iteration::fit(self, sets, config, &mut NoDraws)
    }

    /// `state` clamped into the box.
    fn clamp(&self, mut state: [T; D]) -> [T; D] {
        let (lower, upper) = self.layout.bounds();
        for ((x, &lo), &hi) in state.iter_mut().zip(&lower).zip(&upper) {
            *x = x.clamp_to(lo, hi);
        }
        state
    }

    /// Calls `add(self, record, reward, w_r, w_s)` for every record whose action `keep`
    /// accepts (the reward is the set's replacement when it has one).
    fn spread<'s, I>(
        &mut self,
        sets: I,
        keep: impl Fn(usize) -> bool,
        mut add: impl FnMut(&mut Self, &Transition<[T; D], T>, T, T, T),
    ) where
        I: Iterator<Item = SampleSet<'s, T, D>>,
        T: 's,
    {
        for set in sets {
            for (s, reward, w_r, w_s) in set.iter() {
                if keep(s.action) {
                    add(self, s, reward, w_r, w_s);
                }
            }
        }
    }

    /// `R̂` into every entry, by [`RewardModel`].
    fn fit_rewards<'s, I>(&mut self, sets: I)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        let model = self.layout.rewards();
        let min_mass = self.layout.min_mass();
        if model != RewardModel::PerAction {
            self.spread_rewards(sets.clone(), None);
            self.fill(min_mass, false);
            self.write_rewards(None, |_| true);
        }
        if model == RewardModel::Pooled {
            return;
        }
        for action in 0..self.actions {
            self.spread_rewards(sets.clone(), Some(action));
            if model == RewardModel::PerAction {
                self.fill(min_mass, false);
                self.write_rewards(Some(action), |_| true);
            } else {
                // Only where the action has data of its own; the pooled value stays elsewhere.
                let has = |n: &SweepNode<T>| n.value > T::ZERO && n.value >= min_mass;
                for n in self.nodes.iter_mut() {
                    if has(n) {
                        n.previous /= n.value;
                    }
                }
                self.write_rewards(Some(action), has);
            }
        }
    }

    /// The reward sums of `action`'s records (every action's for `None`) into the scratch.
    fn spread_rewards<'s, I>(&mut self, sets: I, action: Option<usize>)
    where
        I: Iterator<Item = SampleSet<'s, T, D>>,
        T: 's,
    {
        self.reset_scratch();
        self.spread(
            sets,
            |a| action.is_none_or(|b| a == b),
            |q, s, reward, w_r, _| {
                if w_r <= T::ZERO {
                    return;
                }
                let nodes = &mut *q.nodes;
                q.layout.weights(&s.state, |i, phi| {
                    if let Some(n) = nodes.get_mut(i) {
                        n.value += phi * w_r;
                        n.previous += phi * w_r * reward;
                    }
                });
            },
        );
    }

    /// The nodes' `previous` as the reward of `action` (every action for `None`) at every
    /// node that `take` accepts.
    fn write_rewards(&mut self, action: Option<usize>, take: impl Fn(&SweepNode<T>) -> bool) {
        let range = action.map_or(0..self.actions, |a| a..a + 1);
        for (row, n) in self
            .entries
            .chunks_exact_mut(self.actions.max(1))
            .zip(&*self.nodes)
        {
            if take(n) {
                for e in row.get_mut(range.clone()).unwrap_or_default() {
                    N::set_reward(e, n.previous);
                }
            }
        }
    }

    /// Zeroes the scratch sums `value` (mass), `previous` and `absorbing` (weighted sums).
    fn reset_scratch(&mut self) {
        self.nodes.fill(SweepNode::EMPTY);
    }

    /// Turns the scratch sums into means: `previous ← previous / value` (and `absorbing`
    /// alike when `pair`) at every node whose mass `value` is positive and at least
    /// `min_mass` (it has data); every other node takes the mean of its layout neighbours
    /// ([`Nodes::neighbours`]: a grid's axis neighbours) that have data, then of those
    /// filled in the round before, round after round (a dilation: the nearest data in
    /// neighbour steps, ties averaged). No data anywhere: 0 everywhere. `value` is left 1
    /// at every node.
    fn fill(&mut self, min_mass: T, pair: bool) {
        let half = T::from_f64(0.5);
        let mut any = false;
        for n in self.nodes.iter_mut() {
            if n.value > T::ZERO && n.value >= min_mass {
                n.previous /= n.value;
                if pair {
                    n.absorbing /= n.value;
                }
                n.value = T::ONE;
                any = true;
            } else {
                n.value = T::ZERO;
            }
        }
        if !any {
            for n in self.nodes.iter_mut() {
                n.previous = T::ZERO;
                n.absorbing = T::ZERO;
                n.value = T::ONE;
            }
            return;
        }
        loop {
            let mut changed = false;
            for i in 0..self.nodes.len() {
                if self.nodes.get(i).is_some_and(|n| n.value == T::ZERO) {
                    let (mut sum, mut other, mut count) = (T::ZERO, T::ZERO, T::ZERO);
                    let nodes = &*self.nodes;
                    self.layout.neighbours(i, |j| {
                        if let Some(m) = nodes.get(j).filter(|m| m.value == T::ONE) {
                            sum += m.previous;
                            other += m.absorbing;
                            count += T::ONE;
                        }
                    });
                    if count > T::ZERO {
                        if let Some(node) = self.nodes.get_mut(i) {
                            node.previous = sum / count;
                            if pair {
                                node.absorbing = other / count;
                            }
                            node.value = half;
                            changed = true;
                        }
                    }
                }
            }
            for n in self.nodes.iter_mut() {
                if n.value == half {
                    n.value = T::ONE;
                }
            }
            if !changed {
                break;
            }
        }
    }

    /// Where `action`'s mean step lands from every node, two axes at a time: on axis `d`,
    /// the mean displacement `Σφw_s(s′_d − s_d)/Σφw_s` ([`ModelFqi::fill`]ed where a node
    /// has no data), added to the node's coordinate and clamped into the box, is handed to
    /// the layout ([`Nodes::land`]).
    fn fit_steps<'s, I>(&mut self, sets: I, action: usize)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        let actions = self.actions;
        for (e, _) in self
            .entries
            .iter_mut()
            .skip(action)
            .step_by(actions.max(1))
            .zip(0..self.nodes.len())
        {
            self.layout.start_landing(e);
        }
        for first in (0..D).step_by(2) {
            let second = first + 1;
            self.reset_scratch();
            self.spread(
                sets.clone(),
                |a| a == action,
                |q, s, _, _, w_s| {
                    if w_s <= T::ZERO {
                        return;
                    }
                    let (from, to) = (q.clamp(s.state), q.clamp(s.next_state));
                    let delta = |axis: usize| {
                        to.get(axis).copied().unwrap_or(T::ZERO)
                            - from.get(axis).copied().unwrap_or(T::ZERO)
                    };
                    let (d0, d1) = (delta(first), delta(second));
                    let nodes = &mut *q.nodes;
                    q.layout.weights(&s.state, |i, phi| {
                        if let Some(n) = nodes.get_mut(i) {
                            let w = phi * w_s;
                            n.value += w;
                            n.previous += w * d0;
                            n.absorbing += w * d1;
                        }
                    });
                },
            );
            self.fill(T::ZERO, second < D);
            self.land(action, first, |n| n.previous);
            if second < D {
                self.land(action, second, |n| n.absorbing);
            }
        }
        let rows = self.entries.chunks_exact_mut(actions.max(1));
        for (i, row) in rows.enumerate().take(self.nodes.len()) {
            if let Some(e) = row.get_mut(action) {
                self.layout.finish_landing(e, i);
            }
        }
    }

    /// Axis `axis` of `action`'s landing points from the filled mean displacements
    /// `step(node)` (module docs), handed to the layout.
    fn land(&mut self, action: usize, axis: usize, step: impl Fn(&SweepNode<T>) -> T) {
        let rows = self.entries.chunks_exact_mut(self.actions.max(1));
        for (i, (row, n)) in rows.zip(&*self.nodes).enumerate() {
            if let Some(e) = row.get_mut(action) {
                self.layout.land(e, i, axis, step(n));
            }
        }
    }

    /// `Ω` into every node.
    fn fit_absorption<'s, I>(&mut self, sets: I)
    where
        I: Iterator<Item = SampleSet<'s, T, D>>,
        T: 's,
    {
        self.reset_scratch();
        self.spread(
            sets,
            |_| true,
            |q, s, _, _, w_s| {
                if w_s <= T::ZERO {
                    return;
                }
                let omega = if s.absorbing { T::ONE } else { T::ZERO };
                let nodes = &mut *q.nodes;
                q.layout.weights(&s.next_state, |i, phi| {
                    if let Some(n) = nodes.get_mut(i) {
                        n.value += phi * w_s;
                        n.previous += phi * w_s * omega;
                    }
                });
            },
        );
        self.fill(T::ZERO, false);
        for n in self.nodes.iter_mut() {
            n.absorbing = n.previous;
            n.value = T::ZERO;
            n.previous = T::ZERO;
        }
    }

    /// `R̂ + γ(1 − Ω(y))V_{k−1}(y)` for `entry`.
    fn backup(&self, entry: &N::Entry) -> T {
        let (v, omega) = self.layout.ahead(entry, self.nodes);
        N::reward(entry) + self.discount * (T::ONE - omega) * v
    }

    /// The node Q-value of the last iteration.
    fn node_q(&self, node: usize, action: usize) -> T {
        self.entries
            .get(node * self.actions + action)
            .map_or(T::ZERO, |e| self.backup(e))
    }

    /// Where `action`'s mean step lands from node `node` (`None` out of range).
    pub fn next_state(&self, node: usize, action: usize) -> Option<[T; D]> {
        let e = self.entries.get(node * self.actions + action)?;
        self.layout.landing(e)
    }

    /// One iteration: `V_{k−1}` into `previous`, then `V_k(x) = maxₐ Q_k(x, a)` into
    /// `value` (iteration 1, from `V₀ = 0`: `maxₐ R̂`).
    fn iterate(&mut self) {
        let gamma = self.discount;
        for n in self.nodes.iter_mut() {
            n.previous = n.value;
        }
        for (i, row) in self.entries.chunks_exact(self.actions.max(1)).enumerate() {
            let mut best = T::NEG_INFINITY;
            for e in row {
                let (v, omega) = self.layout.ahead(e, self.nodes);
                best = best.max(N::reward(e) + gamma * (T::ONE - omega) * v);
            }
            if let Some(n) = self.nodes.get_mut(i) {
                n.value = best;
            }
        }
    }

    /// `Q(state, action)` for a finite state.
    fn value_finite(&self, state: [T; D], action: usize) -> T {
        let state = self.clamp(state);
        if !self.layout.lookahead() {
            let mut q = T::ZERO;
            self.layout.weights(&state, |i, phi| {
                q += phi * self.node_q(i, action);
            });
            return q;
        }
        // R̂ and the step interpolated at the state, then one backup from there.
        let (mut reward, mut y) = (T::ZERO, state);
        self.layout.weights(&state, |i, phi| {
            let (Some(e), Some(next)) = (
                self.entries.get(i * self.actions + action),
                self.next_state(i, action),
            ) else {
                return;
            };
            reward += phi * N::reward(e);
            for ((s, &n), &x) in y.iter_mut().zip(&next).zip(&self.layout.position(i)) {
                *s += phi * (n - x);
            }
        });
        let (mut v, mut omega) = (T::ZERO, T::ZERO);
        self.layout.weights(&self.clamp(y), |i, phi| {
            if let Some(n) = self.nodes.get(i) {
                v += phi * n.previous;
                omega += phi * n.absorbing;
            }
        });
        reward + self.discount * (T::ONE - omega) * v
    }

    /// `Q(state, action)`.
    ///
    /// Errors: a non-finite state ([`Error::NonFinite`] `state`), an action `≥ actions`
    /// ([`Error::OutOfRange`] `action`).
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        crate::error::ensure_all_finite(&state, "state")?;
        if action >= self.actions {
            return Err(Error::OutOfRange {
                parameter: "action",
            });
        }
        Ok(self.value_finite(state, action))
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        crate::error::ensure_all_finite(&state, "state")?;
        Ok((0..self.actions)
            .map(|a| self.value_finite(state, a))
            .fold(T::NEG_INFINITY, T::max))
    }

    /// The greedy action (ties: the smallest index).
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        crate::error::ensure_all_finite(&state, "state")?;
        let mut best = 0;
        let mut best_q = T::NEG_INFINITY;
        for a in 0..self.actions {
            let q = self.value_finite(state, a);
            if a == 0 || q > best_q {
                best = a;
                best_q = q;
            }
        }
        Ok(best)
    }
}

impl<T: Real, const D: usize, N: Nodes<T, D>> Regressor<T, D> for ModelFqi<'_, T, D, N> {
    fn actions(&self) -> usize {
        self.actions
    }

    /// The layout's nodes, the model (rewards, steps, absorption), then iteration 1
    /// (`V₁ = maxₐ R̂`).
    fn fit_reward_model<'s, I, R>(&mut self, sets: I, _: usize, config: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: rand_core::Rng + ?Sized,
    {
        self.layout.place(sets.clone());
        self.fit_rewards(sets.clone());
        for action in 0..self.actions {
            self.fit_steps(sets.clone(), action);
        }
        self.fit_absorption(sets);
        self.discount = config.discount();
        self.iterate();
    }

    /// One sweep over the nodes.
    fn bellman_iteration<'s, I, R>(&mut self, _: I, _: usize, _: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: rand_core::Rng + ?Sized,
    {
        self.iterate();
    }
}

/// The nodes of a model sweep with `cells` cells on each of `dims` axes, `(cells + 1)^dims`
/// (the capacity `K` of a [`SweepStorage`]; `usize::MAX` on overflow, which no storage
/// can hold).
pub const fn sweep_nodes(dims: usize, cells: usize) -> usize {
    match (cells.saturating_add(1)).checked_pow(dims as u32) {
        Some(nodes) => nodes,
        None => usize::MAX,
    }
}

/// The entries of a model sweep with `cells` cells on each of `dims` axes and `actions`
/// actions, nodes × actions (the capacity `E` of a [`SweepStorage`]).
pub const fn sweep_entries(dims: usize, cells: usize, actions: usize) -> usize {
    sweep_nodes(dims, cells).saturating_mul(actions)
}

/// The memory of a model sweep as one block with const-generic capacities (`E` entries,
/// `K` nodes), all-zero so it can be a `static` in `.bss`.
#[derive(Debug, Clone)]
pub struct SweepStorage<T, const D: usize, const E: usize, const K: usize> {
    entries: [SweepEntry<T, D>; E],
    nodes: [SweepNode<T>; K],
}

impl<T: Real, const D: usize, const E: usize, const K: usize> SweepStorage<T, D, E, K> {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            entries: [SweepEntry::EMPTY; E],
            nodes: [SweepNode::EMPTY; K],
        }
    }

    /// The block as the [`QStorage`](super::QStorage) a Q-function is built in.
    pub fn storage(&mut self) -> super::QStorage<'_, T, D> {
        super::QStorage {
            sweep_entries: &mut self.entries,
            sweep_nodes: &mut self.nodes,
            ..super::QStorage::default()
        }
    }
}

impl<T: Real, const D: usize, const E: usize, const K: usize> Default for SweepStorage<T, D, E, K> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
