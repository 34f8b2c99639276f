use super::argmax::ArgMax;
use super::iteration::{self, Regressor};
use super::samples::load;
use super::{FqiConfig, SampleSet};
use crate::error::ensure_all_finite;
use crate::error::{Error, Result};
use crate::float::Real;
use rand_core::Rng;

mod growth;
mod stream;

use growth::{Growth, RUNS_AHEAD, add_next_state_values, grow, predict, swap};
use stream::{lazy_tree, tree_seed};

/// A node whose weighted impurity is at most this is a leaf (spec §4.1).
pub const MIN_IMPURITY: f64 = 1e-7;

/// A feature whose range over a node is at most this is not split on (spec §4.1).
pub const CONSTANT_FEATURE_TOLERANCE: f64 = 1e-7;

/// The `feature` field of a leaf (a split stores its feature plus 1, so an all-zero node
/// is the leaf 0 and node storage can live in `.bss`).
const LEAF: u16 = 0;

/// Weighted FQI with an Extra-Trees Q-function in caller-lent fixed memory: the regressor
/// of the reference (spec §4.1, the harness's `trees.rs`), either stored with a node budget
/// per tree or **streamed** so that the memory does not depend on the number of trees.
///
/// Tiles and kernel averaging fix their resolution in advance; a regression tree places
/// its splits where the regression targets change, so the values around a verified greedy
/// path, a narrow passage or a puddle edge are separated from the rest by the data
/// themselves, which is what adaptive AWFQI's verified greedy paths need
/// (`docs/active-budget.md`).
///
/// **The regressor** (per action, as the harness's `ActionForests`): `M` trees, each grown
/// on every record of the action (no bootstrap). At a node the `D` features are tried in a
/// random order; for each, `lo, hi` = the node's range, skipped when `hi ≤ lo + 10⁻⁷`,
/// else a threshold `τ ~ U[lo, hi)` (`lo` when rounding reaches `hi`), records with
/// `x ≤ τ` going left. A candidate is valid when both children keep at least
/// `min_samples_leaf` records and a total weight that is positive and at least
/// [`FqiConfig::min_weight`] (0: any positive weight, the reference's rule); the valid
/// candidate of largest `S_L²/W_L + S_R²/W_R` (weighted variance reduction; `S = Σ w y`,
/// `W = Σ w`; first in trial order on ties) is chosen. A node is a leaf when it holds fewer
/// than `max(min_samples_split, 2·min_samples_leaf)` records, when its weighted impurity is
/// at most 10⁻⁷, when no candidate is valid, when it is at the depth limit
/// ([`ExtraTrees::with_max_depth`]; none by default), or when its tree has no room for two
/// more nodes ([`ExtraTrees::max_nodes`]). Leaf value `Σwy/Σw`; the forest predicts the mean
/// of its trees; an action whose records have total weight 0 (or that has none) predicts 0.
/// The sums are taken relative to the node's first target (the same choice, and a leaf of
/// equal targets is exactly constant in `f32` too).
///
/// **Growth order.** Breadth first, with the tree's node slots as the queue (a node not yet
/// grown keeps its records' range), so a tree that hits its node budget is cut at a depth,
/// not down one branch, and growth needs no stack. Records are partitioned in place.
///
/// **FQI** (IWFQI's structure, as the other approximators): iteration 1 fits the rewards
/// (the replacement rewards when a [`SampleSet`] has them) with the reward weights; every
/// record's reward becomes the model's `R̂(sᵢ, aᵢ)`; iterations 2..N fit
/// `yᵢ = R̂ᵢ + γ(1 − ωᵢ) maxₐ′ Q_{k−1}(s′ᵢ, a′)` with the transition weights. Every `y` is
/// computed before the forests are regrown, so one set of forests is held at a time.
///
/// **Stored or streamed.** [`ExtraTrees::new`] keeps every tree of every action
/// (`actions · trees · max_nodes` nodes): fast predictions, memory growing with the trees.
/// [`ExtraTrees::streamed`] needs FQI's forests only where it evaluates them: in iterations
/// 1..N−1 each tree is grown in one scratch tree, evaluated at every record's next state
/// (and, in iteration 1, at its own records' states for `R̂`), added to the records' sums
/// and discarded; iteration N is only a seed. A query grows the final trees along its own
/// path: a node's records are those of its action inside the node's box (a scan), and its
/// split is drawn from a stream of its own (SplitMix64 from a seed chained from the tree's
/// seed, which the caller's generator drew), so the path is the one a full growth would
/// take. Memory: the records and one scratch tree, whatever the number of trees; the price
/// is a prediction that grows `trees` paths per action (`O(records · depth)` each) instead
/// of walking them. Statistically the two are the same forests (tested).
///
/// **Randomness**: only the caller's generator (for streamed final trees, through the seed
/// it drew): `D − 1` index draws for the trial order and one uniform per non-constant
/// feature at every node that is tried.
///
/// **Memory.** One [`TreeRecord`] per record (`2D + 6` scalars and 3 bytes: 44 bytes for
/// `f32`, `D = 2`) and [`ExtraTrees::required_nodes`] [`TreeNode`]s (one scalar and two
/// `u16`: 8 bytes for `f32`). At most 65 534 records and 65 535 nodes per tree. Fit cost per
/// iteration: `O(records · depth · D · trees)` to grow, `O(records · actions · trees ·
/// depth)` for the next states' values. Measured on the host at Puddle World's size (1 333
/// records, 60 iterations, `examples/core_tree_timing.rs`): 50 streamed trees fit in about
/// 2.5 s and decide in about 6 ms; 10 stored trees fit in 0.6 s and decide in 2 µs.
///
/// The size of the forests: trees per action, the node budget of a tree, and the growth
/// limits. What a caller chooses before storage exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExtraTrees {
    trees: usize,
    max_nodes: usize,
    min_samples_split: usize,
    min_samples_leaf: usize,
    max_depth: usize,
    streamed: bool,
}

impl ExtraTrees {
    /// `trees` trees per action of at most `max_nodes` nodes each, otherwise fully grown
    /// (`min_samples_split = 2`, `min_samples_leaf = 1`).
    ///
    /// Errors: `trees == 0` ([`Error::InvalidParameter`] `trees`); `max_nodes` 0 or above
    /// 65 535 ([`Error::InvalidParameter`] `max_nodes`).
    pub fn new(trees: usize, max_nodes: usize) -> Result<Self> {
        if trees == 0 {
            return Err(Error::InvalidParameter { parameter: "trees" });
        }
        if max_nodes == 0 || max_nodes > usize::from(u16::MAX) {
            return Err(Error::InvalidParameter {
                parameter: "max_nodes",
            });
        }
        Ok(Self {
            trees,
            max_nodes,
            min_samples_split: 2,
            min_samples_leaf: 1,
            max_depth: usize::MAX,
            streamed: false,
        })
    }

    /// `trees` trees per action, **streamed** (module docs): during FQI every tree is grown
    /// in one scratch tree of at most `max_nodes` nodes, used and discarded, and the final
    /// Q-function is grown along each query's path from the records, so the memory does not
    /// depend on the number of trees. Give the scratch tree room for a fully grown tree
    /// (`2n − 1` nodes for the `n` records of the largest action) to grow trees fully.
    ///
    /// Errors: as [`ExtraTrees::new`].
    pub fn streamed(trees: usize, max_nodes: usize) -> Result<Self> {
        Ok(Self {
            streamed: true,
            ..Self::new(trees, max_nodes)?
        })
    }

    /// `true` for [`ExtraTrees::streamed`] forests.
    pub fn is_streamed(&self) -> bool {
        self.streamed
    }

    /// The same forests with scikit-learn's growth limits: a node with fewer than
    /// `min_samples_split` records is a leaf, and a split must leave `min_samples_leaf` on
    /// each side.
    ///
    /// Errors: `min_samples_split < 2` or `min_samples_leaf < 1`
    /// ([`Error::InvalidParameter`] naming it).
    pub fn with_min_samples(
        self,
        min_samples_split: usize,
        min_samples_leaf: usize,
    ) -> Result<Self> {
        if min_samples_split < 2 {
            return Err(Error::InvalidParameter {
                parameter: "min_samples_split",
            });
        }
        if min_samples_leaf < 1 {
            return Err(Error::InvalidParameter {
                parameter: "min_samples_leaf",
            });
        }
        Ok(Self {
            min_samples_split,
            min_samples_leaf,
            ..self
        })
    }

    /// The same forests with every node at depth `max_depth` a leaf (the root is at depth
    /// 0): a limit that, unlike the node budget, a streamed forest's final trees obey too.
    pub fn with_max_depth(self, max_depth: usize) -> Self {
        Self { max_depth, ..self }
    }

    /// The depth limit (`usize::MAX`: none).
    pub fn max_depth(&self) -> usize {
        self.max_depth
    }

    /// Trees per action.
    pub fn trees(&self) -> usize {
        self.trees
    }

    /// The node budget of one tree.
    pub fn max_nodes(&self) -> usize {
        self.max_nodes
    }

    /// Fewest records a node needs to be split.
    pub fn min_samples_split(&self) -> usize {
        self.min_samples_split
    }

    /// Fewest records each child of a split keeps.
    pub fn min_samples_leaf(&self) -> usize {
        self.min_samples_leaf
    }

    /// [`TreeNode`]s needed with `actions` actions (`None` on overflow): every tree's
    /// budget, or one scratch tree's when streamed.
    pub fn required_nodes(&self, actions: usize) -> Option<usize> {
        if self.streamed {
            return (actions > 0).then_some(self.max_nodes);
        }
        actions.checked_mul(self.trees)?.checked_mul(self.max_nodes)
    }

    /// The fewest records of a node that is split.
    fn min_node(&self) -> usize {
        self.min_samples_split
            .max(self.min_samples_leaf.saturating_mul(2))
    }
}

/// One record of a tree fit: where it starts and ends, its weights and the values of the
/// fit.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TreeRecord<T, const D: usize> {
    state: [T; D],
    next_state: [T; D],
    /// Transition weight `w_s`.
    weight: T,
    /// The reward weight `w_r` during iteration 1, then `R̂` at the record.
    reward: T,
    /// The regression target `y` of the last iteration (the reward during iteration 1).
    target: T,
    /// Streamed: the sum over the current action's trees at the next state.
    acc: T,
    /// Streamed: `maxₐ Q(s′, a)` over the actions done so far.
    best: T,
    /// Streamed, iteration 1: the sum over the record's action's trees at its own state.
    own: T,
    action: u16,
    absorbing: bool,
}

impl<T: Real, const D: usize> TreeRecord<T, D> {
    /// An unused slot; `const` and all-zero, so storage can be a `static` in `.bss`.
    pub const EMPTY: Self = Self {
        state: [T::ZERO; D],
        next_state: [T::ZERO; D],
        weight: T::ZERO,
        reward: T::ZERO,
        target: T::ZERO,
        acc: T::ZERO,
        best: T::ZERO,
        own: T::ZERO,
        action: 0,
        absorbing: false,
    };

    /// The fitted reward model `R̂` at the record.
    pub fn reward_model(&self) -> T {
        self.reward
    }

    /// The record's regression target of the last iteration.
    pub fn target(&self) -> T {
        self.target
    }

    /// The record's action.
    pub fn action(&self) -> usize {
        usize::from(self.action)
    }

    /// The record's weight in the iteration being grown (`w_r` in iteration 1).
    fn w(&self, first: bool) -> T {
        if first { self.reward } else { self.weight }
    }

    fn coordinate(&self, feature: usize) -> T {
        self.state.get(feature).copied().unwrap_or(T::ZERO)
    }
}

impl<T: Real, const D: usize> Default for TreeRecord<T, D> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// One node of a tree: a split sends `x[feature] ≤ value` to `left` and the rest to
/// `left + 1` (indices within the tree, children after their parent); a leaf predicts
/// `value`. While a tree grows, a node not yet grown holds its records' range
/// `left..feature` instead.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TreeNode<T> {
    value: T,
    left: u16,
    feature: u16,
}

impl<T: Real> TreeNode<T> {
    /// A leaf predicting 0; `const` and all-zero, so storage can be a `static` in `.bss`.
    pub const EMPTY: Self = Self::leaf(T::ZERO);

    const fn leaf(value: T) -> Self {
        Self {
            value,
            left: 0,
            feature: LEAF,
        }
    }

    /// `true` for a leaf.
    pub fn is_leaf(&self) -> bool {
        self.feature == LEAF
    }

    /// The leaf's value, or the split's threshold.
    pub fn value(&self) -> T {
        self.value
    }

    /// The split's feature (`None` for a leaf).
    pub fn feature(&self) -> Option<usize> {
        usize::from(self.feature).checked_sub(1)
    }

    /// The index of the split's child that holds `state` (`x ≤ τ` left; a feature past
    /// `D` reads 0).
    fn child<const D: usize>(&self, state: &[T; D]) -> usize {
        let x = state
            .get(usize::from(self.feature).wrapping_sub(1))
            .copied()
            .unwrap_or(T::ZERO);
        usize::from(self.left) + usize::from(x > self.value)
    }
}

impl<T: Real> Default for TreeNode<T> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// A Q-function of per-action Extra-Trees forests (module docs), over caller-lent records
/// and nodes.
#[derive(Debug)]
pub struct TreeFqi<'a, T, const D: usize> {
    forests: ExtraTrees,
    actions: usize,
    records: &'a mut [TreeRecord<T, D>],
    nodes: &'a mut [TreeNode<T>],
    len: usize,
    /// The growth rules of the iteration being grown (its weights, the minimum weight),
    /// after a fit those of the last one (a streamed forest's final trees), and the seed of
    /// a streamed forest's final trees.
    growth: Growth<T>,
    seed: u64,
}

impl<'a, T: Real, const D: usize> TreeFqi<'a, T, D> {
    /// A Q-function that is 0 everywhere, able to hold `records.len()` records.
    ///
    /// Errors: `actions` 0 or above 65 536 ([`Error::InvalidParameter`] `actions`); more
    /// than 65 534 record slots ([`Error::CapacityExceeded`] with that limit); `nodes`
    /// shorter than [`ExtraTrees::required_nodes`] ([`Error::CapacityExceeded`] with its
    /// length).
    pub fn new(
        forests: ExtraTrees,
        actions: usize,
        records: &'a mut [TreeRecord<T, D>],
        nodes: &'a mut [TreeNode<T>],
    ) -> Result<Self> {
        if actions == 0 || actions > usize::from(u16::MAX) + 1 {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        let limit = usize::from(u16::MAX) - 1;
        if records.len() > limit {
            return Err(Error::CapacityExceeded { capacity: limit });
        }
        let needed = forests
            .required_nodes(actions)
            .filter(|&n| n <= nodes.len())
            .ok_or(Error::CapacityExceeded {
                capacity: nodes.len(),
            })?;
        let nodes = nodes
            .get_mut(..needed)
            .ok_or(Error::CapacityExceeded { capacity: needed })?;
        let mut q = Self {
            forests,
            actions,
            records,
            nodes,
            len: 0,
            growth: Growth::of(&forests, T::ZERO),
            seed: 0,
        };
        q.clear();
        Ok(q)
    }

    /// The forests' size.
    pub fn forests(&self) -> &ExtraTrees {
        &self.forests
    }

    /// Number of actions.
    pub fn actions(&self) -> usize {
        self.actions
    }

    /// The records of the last fit (grouped by action).
    pub fn records(&self) -> &[TreeRecord<T, D>] {
        self.records.get(..self.len).unwrap_or(&[])
    }

    /// The nodes of tree `tree` of `action` (its root first), if both exist and the trees
    /// are stored (not [`ExtraTrees::streamed`]).
    pub fn tree(&self, action: usize, tree: usize) -> Option<&[TreeNode<T>]> {
        if action >= self.actions || tree >= self.forests.trees || self.forests.streamed {
            return None;
        }
        let start = (action * self.forests.trees + tree) * self.forests.max_nodes;
        self.nodes.get(start..start + self.forests.max_nodes)
    }

    /// Resets Q to 0 everywhere (forgets the records).
    pub fn clear(&mut self) {
        self.len = 0;
        self.seed = 0;
        self.nodes.fill(TreeNode::EMPTY);
    }

    /// Fits Q from scratch by weighted FQI on the union of `sets` (module docs), drawing
    /// the trees' randomness from `rng`.
    ///
    /// Everything is checked before the records change. Errors: those of
    /// [`TabularFqi::fit`](super::TabularFqi::fit), and more records than slots
    /// ([`Error::CapacityExceeded`] with the slots' count).
    pub fn fit<R: Rng + ?Sized>(
        &mut self,
        sets: &[SampleSet<'_, T, D>],
        config: &FqiConfig<T>,
        rng: &mut R,
    ) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config, rng)
    }

    /// [`TreeFqi::fit`] on sets produced by an iterator (cloned once per pass).
    ///
    /// Errors: those of [`TreeFqi::fit`].
    pub fn fit_sets<'s, I, R>(&mut self, sets: I, config: &FqiConfig<T>, rng: &mut R) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        iteration::fit(self, sets, config, rng)
    }

    /// `y = R̂ + γ(1 − ω)·maxₐ′ Q(s′, a′)` from the streamed sums.
    fn bootstrap_targets(&mut self, gamma: T) {
        for r in self.records.get_mut(..self.len).unwrap_or(&mut []) {
            let future = if r.absorbing { T::ZERO } else { r.best };
            r.target = r.reward + gamma * future;
        }
    }

    /// One streamed iteration: every action's trees grown on the current targets, each
    /// evaluated at every record's next state (`best` = the largest action mean) and, in
    /// iteration 1, at its own records' states (`reward` = `R̂` afterwards).
    fn stream_iteration<R: Rng + ?Sized>(&mut self, growth: &Growth<T>, rng: &mut R) {
        let trees = T::from_usize(self.forests.trees);
        for r in self.records.get_mut(..self.len).unwrap_or(&mut []) {
            r.best = T::NEG_INFINITY;
            r.own = T::ZERO;
        }
        for a in 0..self.actions {
            let (start, end) = self.range_of(a);
            for r in self.records.get_mut(..self.len).unwrap_or(&mut []) {
                r.acc = T::ZERO;
            }
            let total: T = self
                .records
                .get(start..end)
                .unwrap_or(&[])
                .iter()
                .map(|r| r.w(growth.first))
                .sum();
            for _ in 0..self.forests.trees {
                if let Some(mine) = self.records.get_mut(start..end) {
                    grow(mine, self.nodes, growth, total, rng);
                }
                let tree: &[TreeNode<T>] = self.nodes;
                let live = self.records.get_mut(..self.len).unwrap_or(&mut []);
                add_next_state_values(tree, live, RUNS_AHEAD);
                if growth.first {
                    for r in live.get_mut(start..end).unwrap_or(&mut []) {
                        r.own += predict(tree, &r.state);
                    }
                }
            }
            for (i, r) in self
                .records
                .get_mut(..self.len)
                .unwrap_or(&mut [])
                .iter_mut()
                .enumerate()
            {
                r.best = r.best.max(r.acc / trees);
                if growth.first && (start..end).contains(&i) {
                    r.reward = r.own / trees;
                }
            }
        }
    }

    /// Orders the records by action (one partition pass per action).
    fn group_by_action(&mut self) {
        let live = self.records.get_mut(..self.len).unwrap_or(&mut []);
        let mut start = 0usize;
        for a in 0..self.actions {
            let Some(rest) = live.get_mut(start..) else {
                break;
            };
            let mut front = 0usize;
            for j in 0..rest.len() {
                if rest.get(j).is_some_and(|r| r.action() == a) {
                    swap(rest, front, j);
                    front += 1;
                }
            }
            start += front;
        }
    }

    /// The records of `action`, `start..end` (grouped by [`TreeFqi::group_by_action`]).
    fn range_of(&self, action: usize) -> (usize, usize) {
        let live = self.records.get(..self.len).unwrap_or(&[]);
        let start = live.iter().take_while(|r| r.action() < action).count();
        let end = start
            + live
                .get(start..)
                .unwrap_or(&[])
                .iter()
                .take_while(|r| r.action() == action)
                .count();
        (start, end)
    }

    /// Grows every tree of every action.
    fn grow_all<R: Rng + ?Sized>(&mut self, growth: &Growth<T>, rng: &mut R) {
        let per_tree = self.forests.max_nodes;
        for a in 0..self.actions {
            let (start, end) = self.range_of(a);
            let Some(records) = self.records.get_mut(start..end) else {
                continue;
            };
            let total: T = records.iter().map(|r| r.w(growth.first)).sum();
            for t in 0..self.forests.trees {
                let base = (a * self.forests.trees + t) * per_tree;
                if let Some(nodes) = self.nodes.get_mut(base..base + per_tree) {
                    grow(records, nodes, growth, total, rng);
                }
            }
        }
    }

    /// The forest of `action` at `state`: the mean of its trees.
    fn forest_value(&self, state: &[T; D], action: usize) -> T {
        let trees = self.forests.trees;
        if self.forests.streamed {
            let (start, end) = self.range_of(action);
            let records = self.records.get(start..end).unwrap_or(&[]);
            let mut sum = T::ZERO;
            for t in 0..trees {
                sum += lazy_tree(
                    records,
                    state,
                    tree_seed(self.seed, action, t),
                    &self.growth,
                );
            }
            return sum / T::from_usize(trees);
        }
        let per_tree = self.forests.max_nodes;
        let base = action * trees * per_tree;
        let mut sum = T::ZERO;
        for t in 0..trees {
            let start = base + t * per_tree;
            if let Some(nodes) = self.nodes.get(start..start + per_tree) {
                sum += predict(nodes, state);
            }
        }
        sum / T::from_usize(trees)
    }

    fn max_finite(&self, state: &[T; D]) -> T {
        let mut best = T::NEG_INFINITY;
        for a in 0..self.actions {
            best = best.max(self.forest_value(state, a));
        }
        best
    }

    /// `Q(state, action)`.
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        ensure_all_finite(&state, "state")?;
        if action >= self.actions {
            return Err(Error::OutOfRange {
                parameter: "action",
            });
        }
        Ok(self.forest_value(&state, action))
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        ensure_all_finite(&state, "state")?;
        Ok(self.max_finite(&state))
    }

    /// The greedy action: the largest `Q`, ties to the smallest index (spec §3.1).
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        ensure_all_finite(&state, "state")?;
        let mut best = ArgMax::new();
        for a in 0..self.actions {
            best.offer(a, self.forest_value(&state, a), true);
        }
        Ok(best.action())
    }
}

impl<T: Real, const D: usize> Regressor<T, D> for TreeFqi<'_, T, D> {
    fn actions(&self) -> usize {
        self.actions
    }

    fn capacity(&self) -> Option<usize> {
        Some(self.records.len())
    }

    /// The records, grouped by action, then the forests of the rewards and `R̂` at every
    /// record; streamed, the first iteration's trees are grown and evaluated at once (when
    /// there is a second iteration to use them).
    fn fit_reward_model<'s, I, R>(
        &mut self,
        sets: I,
        total: usize,
        config: &FqiConfig<T>,
        rng: &mut R,
    ) where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        load(self.records, sets, |(s, reward, w_r, w_s)| TreeRecord {
            state: s.state,
            next_state: s.next_state,
            weight: w_s,
            reward: w_r,
            target: reward,
            acc: T::ZERO,
            best: T::ZERO,
            own: T::ZERO,
            action: s.action as u16,
            absorbing: s.absorbing,
        });
        self.len = total;
        self.group_by_action();
        let growth = Growth::of(&self.forests, config.min_weight());
        self.growth = growth;
        if self.forests.streamed {
            if config.iterations() > 1 {
                self.stream_iteration(&growth, rng);
                self.growth.first = false;
            }
            return;
        }
        self.grow_all(&growth, rng);
        // R̂ at every record (its reward weight is no longer needed).
        for i in 0..self.len {
            let Some(&r) = self.records.get(i) else {
                break;
            };
            let fitted = self.forest_value(&r.state, r.action());
            if let Some(r) = self.records.get_mut(i) {
                r.reward = fitted;
                r.target = fitted;
            }
        }
        self.growth.first = false;
    }

    /// Every target from `Q_{k−1}`, then the forests regrown on them; streamed, the targets
    /// from the sums of the trees just streamed, and this iteration's trees streamed unless
    /// it is the last (whose trees are grown along each query's path).
    fn bellman_iteration<'s, I, R>(&mut self, _: I, k: usize, config: &FqiConfig<T>, rng: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        let gamma = config.discount();
        let growth = self.growth;
        if self.forests.streamed {
            self.bootstrap_targets(gamma);
            if k < config.iterations() {
                self.stream_iteration(&growth, rng);
            }
            return;
        }
        // Every target from Q_{k−1} before the forests are regrown.
        for i in 0..self.len {
            let Some(&r) = self.records.get(i) else {
                break;
            };
            let future = if r.absorbing {
                T::ZERO
            } else {
                self.max_finite(&r.next_state)
            };
            if let Some(r) = self.records.get_mut(i) {
                r.target = r.reward + gamma * future;
            }
        }
        self.grow_all(&growth, rng);
    }

    /// Streamed: the seed of the final trees.
    fn finish<R: Rng + ?Sized>(&mut self, _: &FqiConfig<T>, rng: &mut R) {
        if self.forests.streamed {
            self.seed = rng.next_u64();
        }
    }
}

/// The memory of a tree Q-function as one block with const-generic capacities (`R` record
/// slots, `N` nodes), all-zero so it can be a `static` in `.bss`.
#[derive(Debug, Clone)]
pub struct TreeStorage<T, const D: usize, const R: usize, const N: usize> {
    records: [TreeRecord<T, D>; R],
    nodes: [TreeNode<T>; N],
}

impl<T: Real, const D: usize, const R: usize, const N: usize> TreeStorage<T, D, R, N> {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            records: [TreeRecord::EMPTY; R],
            nodes: [TreeNode::EMPTY; N],
        }
    }

    /// The block as the [`QStorage`](super::QStorage) a Q-function is built in.
    pub fn storage(&mut self) -> super::QStorage<'_, T, D> {
        super::QStorage {
            tree_records: &mut self.records,
            nodes: &mut self.nodes,
            ..super::QStorage::default()
        }
    }
}

impl<T: Real, const D: usize, const R: usize, const N: usize> Default for TreeStorage<T, D, R, N> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
