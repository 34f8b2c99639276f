//! A model sweep on **representative states** ("anchors") placed from the records, within a
//! node budget the caller sets: the memory is `M` nodes whatever the dimension, where the
//! grid of [`super::ModelSweep`] needs `(cells + 1)^D`.
//!
//! The model and its value iteration are the grid sweep's ([`super::sweep`]: reward, mean
//! step and absorption of the weighted records, `Q_k(x, a) = R̂ + γ(1 − Ω(y))V_{k−1}(y)`);
//! only where the nodes lie and how a point is read from them differ, as in kernel-based
//! RL with representative states (Barreto, Precup and Pineau, *Practical Kernel-Based
//! Reinforcement Learning*, JMLR 2016), whose model is a small MDP on a few states chosen
//! from the sample transitions:
//!
//! - **placement** at every fit, from the records' states (target first, as the sets come):
//!   a record becomes a node when it lies farther than a radius `r` from every node; when
//!   the budget is full, `r` grows (×1.25, at least to the closest pair's distance) and the
//!   nodes closer than `r` to an earlier node are dropped. The nodes then cover the records
//!   at spacing `r`, dense where the plant goes, absent where it does not; a last pass at
//!   `r / 1.25` spends what the budget has left. Records of weight 0 place nothing (when
//!   all weigh 0, the first record places the one node);
//! - **reading a point** `s` (clamped into the box, in units of the box's widths): its `k`
//!   nearest nodes ([`AnchorSweep::with_neighbours`], at most [`ANCHOR_LINKS`]), weighted
//!   `(1 − d²/ρ²)²` with `ρ` the distance of the `(k+1)`-th nearest, normalised: weights
//!   that sum to 1 and change continuously as `s` moves (a node enters or leaves at weight
//!   0);
//! - **landing points** `y = x + d̂(x, a)` are kept as their `k` nodes and 15-bit weights,
//!   so an iteration costs `k` reads per node and action;
//! - a node without data for a quantity takes the mean of its `k` nearest nodes with data,
//!   round after round (the grid's dilation on the nodes' nearest-neighbour graph).
//!
//! **Memory**, `M` nodes, `A` actions, `f32`: an [`AnchorEntry`] per node and action
//! (20 bytes: room for [`ANCHOR_LINKS`] links whatever `k`), a [`SweepNode`] (12 bytes),
//! its position and a landing scratch (`2·4D` bytes) per node
//! ([`AnchorSweep::bytes_per_node`]). No randomness; the nearest-node searches scan the
//! nodes sorted on their widest axis and stop at the `(k+1)`-th distance.

use super::sweep::{Layout, ModelFqi, Nodes};
use super::{RewardModel, SampleSet, SweepNode};
use crate::error::{Error, Result};
use crate::float::Real;

/// The most nodes a point is read from.
pub const ANCHOR_LINKS: usize = 4;

/// Fixed-point scale of an entry's weights: `2¹⁵`.
const WEIGHT_ONE: u16 = 1 << 15;

/// Growth of the placement radius when the budget is full.
const GROW: f64 = 1.25;

/// The settings of a sweep on anchors: the box, the node budget, the neighbours a point is
/// read from and the model's options (those of [`super::ModelSweep`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AnchorSweep<T, const D: usize> {
    lower: [T; D],
    upper: [T; D],
    budget: usize,
    neighbours: usize,
    rewards: RewardModel,
    min_mass: T,
    lookahead: bool,
}

impl<T: Real, const D: usize> AnchorSweep<T, D> {
    /// At most `budget` nodes in the box `[lower, upper]`, each point read from its
    /// [`ANCHOR_LINKS`] nearest; rewards per action, any positive weight counts as data.
    ///
    /// Errors: the box's errors as [`super::CellGrid::new`]; a budget of 0
    /// ([`Error::InvalidParameter`] `budget`) or above `u16::MAX`
    /// ([`Error::CapacityExceeded`]).
    pub fn new(lower: [T; D], upper: [T; D], budget: usize) -> Result<Self> {
        super::CellGrid::new(lower, upper, [1; D])?;
        if budget == 0 {
            return Err(Error::InvalidParameter {
                parameter: "budget",
            });
        }
        if budget > usize::from(u16::MAX) {
            return Err(Error::CapacityExceeded {
                capacity: usize::from(u16::MAX),
            });
        }
        Ok(Self {
            lower,
            upper,
            budget,
            neighbours: ANCHOR_LINKS,
            rewards: RewardModel::PerAction,
            min_mass: T::ZERO,
            lookahead: false,
        })
    }

    /// The same sweep reading a point from its `k` nearest nodes.
    ///
    /// Errors: `k` of 0 or above [`ANCHOR_LINKS`] ([`Error::InvalidParameter`]
    /// `neighbours`).
    pub fn with_neighbours(self, k: usize) -> Result<Self> {
        if k == 0 || k > ANCHOR_LINKS {
            return Err(Error::InvalidParameter {
                parameter: "neighbours",
            });
        }
        Ok(Self {
            neighbours: k,
            ..self
        })
    }

    /// The same sweep with another reward model.
    pub fn with_rewards(self, rewards: RewardModel) -> Self {
        Self { rewards, ..self }
    }

    /// The same sweep with a node's reward counted as data only from a total weight of
    /// `min_mass` ([`super::ModelSweep::with_min_mass`]).
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

    /// The same sweep deciding by one step of lookahead at the state itself.
    pub fn with_lookahead(self, lookahead: bool) -> Self {
        Self { lookahead, ..self }
    }

    /// The node budget `M`.
    pub fn nodes(&self) -> usize {
        self.budget
    }

    /// The neighbours a point is read from.
    pub fn neighbours(&self) -> usize {
        self.neighbours
    }

    /// Bytes of storage one node needs with `actions` actions: its entries, its
    /// [`SweepNode`], its position and its landing scratch.
    pub const fn bytes_per_node(actions: usize) -> usize {
        actions * core::mem::size_of::<AnchorEntry<T>>()
            + core::mem::size_of::<SweepNode<T>>()
            + 2 * core::mem::size_of::<[T; D]>()
    }

    /// The node budget a memory budget buys: the most nodes whose storage with `actions`
    /// actions fits in `bytes` (at most `u16::MAX`). The rule that sizes a sweep on anchors
    /// from the plant's dimension (`D`), its actions and what the learner's other buffers
    /// leave of the RAM budget.
    pub const fn budget_within(bytes: usize, actions: usize) -> usize {
        let per = Self::bytes_per_node(actions);
        let n = match bytes.checked_div(per) {
            Some(n) => n,
            None => 0,
        };
        if n > u16::MAX as usize {
            u16::MAX as usize
        } else {
            n
        }
    }

    /// [`AnchorEntry`]s needed with `actions` actions (`None` on overflow).
    pub fn required_entries(&self, actions: usize) -> Option<usize> {
        self.budget.checked_mul(actions)
    }

    /// The box.
    pub fn bounds(&self) -> ([T; D], [T; D]) {
        (self.lower, self.upper)
    }
}

/// The model of one node and action: the reward and where the mean step lands, as the
/// landing point's nearest nodes and their weights (`2¹⁵` is 1; unused slots weigh 0).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AnchorEntry<T> {
    reward: T,
    node: [u16; ANCHOR_LINKS],
    weight: [u16; ANCHOR_LINKS],
}

impl<T: Real> AnchorEntry<T> {
    /// A fresh entry; `const` and all-zero, so storage can be a `static` in `.bss`.
    pub const EMPTY: Self = Self {
        reward: T::ZERO,
        node: [0; ANCHOR_LINKS],
        weight: [0; ANCHOR_LINKS],
    };

    /// The fitted reward `R̂`.
    pub fn reward(&self) -> T {
        self.reward
    }
}

impl<T: Real> Default for AnchorEntry<T> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// The anchors' layout over caller-lent positions and landing scratch (one per node of
/// the budget), in units of the box's widths (`[0, 1]` per axis).
#[derive(Debug)]
pub struct Anchors<'a, T, const D: usize> {
    settings: AnchorSweep<T, D>,
    positions: &'a mut [[T; D]],
    landings: &'a mut [[T; D]],
    /// Nodes placed (the rest of the budget is unused).
    count: usize,
    /// The axis the positions are sorted on.
    axis: usize,
}

/// The nearest nodes of a point, nearest first: `(node, squared distance)`.
type Nearest<T> = [(usize, T); ANCHOR_LINKS + 1];

impl<T: Real, const D: usize> Anchors<'_, T, D> {
    /// `state` clamped into the box, in units of its widths.
    fn scaled(&self, state: &[T; D]) -> [T; D] {
        let mut out = [T::ZERO; D];
        for (((o, &x), &lo), &hi) in out
            .iter_mut()
            .zip(state)
            .zip(&self.settings.lower)
            .zip(&self.settings.upper)
        {
            *o = ((x - lo) / (hi - lo)).clamp_to(T::ZERO, T::ONE);
        }
        out
    }

    /// The squared distance between two scaled points.
    fn distance(a: &[T; D], b: &[T; D]) -> T {
        a.iter()
            .zip(b)
            .fold(T::ZERO, |sum, (&x, &y)| sum + (x - y).squared())
    }

    /// The position on the sorted axis.
    fn key(&self, node: usize) -> T {
        self.positions
            .get(node)
            .and_then(|p| p.get(self.axis))
            .copied()
            .unwrap_or(T::ZERO)
    }

    /// The `want` nearest placed nodes of the scaled point `x` (other than `skip`) into
    /// `out`, nearest first (ties: the smaller index first); returns how many were found.
    fn nearest(&self, x: &[T; D], skip: Option<usize>, want: usize, out: &mut Nearest<T>) -> usize {
        let want = want.min(out.len());
        let mut found = 0usize;
        let consider = |node: usize, out: &mut Nearest<T>, found: &mut usize| {
            if Some(node) == skip {
                return;
            }
            let Some(p) = self.positions.get(node) else {
                return;
            };
            let d = Self::distance(x, p);
            if *found == want {
                match out.get(want.wrapping_sub(1)) {
                    Some(&(j, worst)) if d < worst || (d == worst && node < j) => {}
                    _ => return,
                }
            } else {
                *found += 1;
            }
            // Insert, keeping the order.
            let mut at = *found - 1;
            while at > 0 {
                let Some(&(j, prev)) = out.get(at - 1) else {
                    break;
                };
                if prev < d || (prev == d && j < node) {
                    break;
                }
                if let Some(slot) = out.get_mut(at) {
                    *slot = (j, prev);
                }
                at -= 1;
            }
            if let Some(slot) = out.get_mut(at) {
                *slot = (node, d);
            }
        };
        let key = x.get(self.axis).copied().unwrap_or(T::ZERO);
        // The first node at or above the key, then outwards on both sides.
        let (mut lo, mut hi) = (0usize, self.count);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.key(mid) < key {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        let (mut down, mut up) = (lo, lo);
        loop {
            let gap_up = (up < self.count).then(|| (self.key(up) - key).squared());
            let gap_down = (down > 0).then(|| (key - self.key(down - 1)).squared());
            let worst = (found == want)
                .then(|| out.get(want.wrapping_sub(1)).map(|&(_, d)| d))
                .flatten();
            let open = |gap: Option<T>| gap.is_some_and(|g| worst.is_none_or(|w| g <= w));
            let (go_up, go_down) = (open(gap_up), open(gap_down));
            match (go_up, go_down) {
                (false, false) => break,
                (true, false) => {
                    consider(up, out, &mut found);
                    up += 1;
                }
                (false, true) => {
                    down -= 1;
                    consider(down, out, &mut found);
                }
                (true, true) => {
                    if gap_up <= gap_down {
                        consider(up, out, &mut found);
                        up += 1;
                    } else {
                        down -= 1;
                        consider(down, out, &mut found);
                    }
                }
            }
        }
        found
    }

    /// The interpolation weights of the scaled point `x`: `(node, weight)` for its `k`
    /// nearest nodes (module docs); returns how many.
    fn read(&self, x: &[T; D], out: &mut [(usize, T); ANCHOR_LINKS]) -> usize {
        let k = self.settings.neighbours;
        let mut near = [(0usize, T::ZERO); ANCHOR_LINKS + 1];
        let found = self.nearest(x, None, k + 1, &mut near);
        let used = found.min(k);
        if used == 0 {
            return 0;
        }
        let radius = if found > k {
            near.get(k).map_or(T::ZERO, |&(_, d)| d)
        } else {
            // Fewer nodes than neighbours: all of them, none at weight 0.
            near.get(found - 1).map_or(T::ZERO, |&(_, d)| d + d) + T::from_f64(1e-12)
        };
        let mut total = T::ZERO;
        for ((o, &(node, d)), _) in out.iter_mut().zip(&near).zip(0..used) {
            let w = if radius > T::ZERO {
                (T::ONE - d / radius).max(T::ZERO).squared()
            } else {
                T::ONE
            };
            *o = (node, w);
            total += w;
        }
        for (o, _) in out.iter_mut().zip(0..used) {
            o.1 = if total > T::ZERO {
                o.1 / total
            } else {
                T::ONE / T::from_usize(used)
            };
        }
        used
    }

    /// Places the nodes from the record states of `sets` (module docs), then sorts them on
    /// their widest axis.
    fn place_from<'s, I>(&mut self, sets: I)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        let budget = self.settings.budget.min(self.positions.len());
        self.count = 0;
        self.axis = 0;
        let mut radius = T::ZERO;
        for set in sets.clone() {
            for (s, _, w_r, w_s) in set.iter() {
                if w_r <= T::ZERO && w_s <= T::ZERO {
                    continue;
                }
                let x = self.scaled(&s.state);
                while !self.covers(&x, radius) {
                    if self.count < budget {
                        self.push(x);
                        break;
                    }
                    radius = self.thin(radius);
                }
            }
        }
        if self.count == 0 {
            // Every record weighs 0: one node at the first record keeps the model defined.
            if let Some((s, ..)) = sets.clone().flat_map(|set| set.iter()).next() {
                let x = self.scaled(&s.state);
                self.push(x);
            }
        }
        // Spend the rest of the budget at a finer spacing.
        let finer = radius / T::from_f64(GROW);
        'top: for set in sets {
            for (s, _, w_r, w_s) in set.iter() {
                if self.count >= budget {
                    break 'top;
                }
                if w_r <= T::ZERO && w_s <= T::ZERO {
                    continue;
                }
                let x = self.scaled(&s.state);
                if !self.covers(&x, finer) {
                    self.push(x);
                }
            }
        }
        self.sort();
    }

    /// `true` when a placed node lies within `radius` (squared distance `≤ radius²`) of `x`.
    fn covers(&self, x: &[T; D], radius: T) -> bool {
        let r2 = radius * radius;
        self.positions
            .iter()
            .take(self.count)
            .any(|p| Self::distance(x, p) <= r2)
    }

    /// Appends a node at `x`.
    fn push(&mut self, x: [T; D]) {
        if let Some(slot) = self.positions.get_mut(self.count) {
            *slot = x;
            self.count += 1;
        }
    }

    /// Grows the radius from `radius` (×1.25, at least to the closest pair's distance) and
    /// drops every node within it of an earlier kept node; returns the new radius.
    fn thin(&mut self, radius: T) -> T {
        let mut closest = T::INFINITY;
        for (i, p) in self.positions.iter().take(self.count).enumerate() {
            for q in self.positions.iter().take(i) {
                closest = closest.min(Self::distance(p, q));
            }
        }
        let radius = (radius * T::from_f64(GROW)).max(closest.sqrt());
        let r2 = radius * radius;
        let mut kept = 0usize;
        for i in 0..self.count {
            let Some(p) = self.positions.get(i).copied() else {
                break;
            };
            let near = self
                .positions
                .iter()
                .take(kept)
                .any(|q| Self::distance(&p, q) <= r2);
            if !near {
                if let Some(slot) = self.positions.get_mut(kept) {
                    *slot = p;
                }
                kept += 1;
            }
        }
        self.count = kept;
        radius
    }

    /// Sorts the placed nodes on their widest axis (insertion sort: no recursion, no
    /// allocation; stable).
    fn sort(&mut self) {
        let mut widest = (0usize, T::NEG_INFINITY);
        for axis in 0..D {
            let (mut lo, mut hi) = (T::INFINITY, T::NEG_INFINITY);
            for p in self.positions.iter().take(self.count) {
                let v = p.get(axis).copied().unwrap_or(T::ZERO);
                lo = lo.min(v);
                hi = hi.max(v);
            }
            if hi - lo > widest.1 {
                widest = (axis, hi - lo);
            }
        }
        self.axis = widest.0;
        let axis = self.axis;
        let placed = self.positions.get_mut(..self.count).unwrap_or_default();
        for i in 1..placed.len() {
            let mut j = i;
            while j > 0 {
                let (Some(a), Some(b)) = (placed.get(j - 1), placed.get(j)) else {
                    break;
                };
                if a.get(axis) <= b.get(axis) {
                    break;
                }
                placed.swap(j - 1, j);
                j -= 1;
            }
        }
    }
}

impl<T, const D: usize> Layout<T, D> for Anchors<'_, T, D> {
    type Entry = AnchorEntry<T>;
}

/// Representative states placed from the records (module docs).
impl<T: Real, const D: usize> Nodes<T, D> for Anchors<'_, T, D> {
    const EMPTY_ENTRY: Self::Entry = AnchorEntry::EMPTY;

    fn len(&self) -> usize {
        self.count
    }

    fn bounds(&self) -> ([T; D], [T; D]) {
        (self.settings.lower, self.settings.upper)
    }

    fn rewards(&self) -> RewardModel {
        self.settings.rewards
    }

    fn min_mass(&self) -> T {
        self.settings.min_mass
    }

    fn lookahead(&self) -> bool {
        self.settings.lookahead
    }

    fn place<'s, I>(&mut self, sets: I)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        self.place_from(sets);
    }

    fn weights(&self, state: &[T; D], mut f: impl FnMut(usize, T)) {
        let mut out = [(0usize, T::ZERO); ANCHOR_LINKS];
        let used = self.read(&self.scaled(state), &mut out);
        for &(node, w) in out.iter().take(used) {
            f(node, w);
        }
    }

    fn neighbours(&self, node: usize, mut f: impl FnMut(usize)) {
        let Some(x) = self.positions.get(node).copied() else {
            return;
        };
        if node >= self.count {
            return;
        }
        let mut near = [(0usize, T::ZERO); ANCHOR_LINKS + 1];
        let found = self.nearest(&x, Some(node), self.settings.neighbours, &mut near);
        for &(j, _) in near.iter().take(found) {
            f(j);
        }
    }

    fn position(&self, node: usize) -> [T; D] {
        let mut out = self.settings.lower;
        if let Some(p) = self.positions.get(node) {
            for (((o, &x), &lo), &hi) in out
                .iter_mut()
                .zip(p)
                .zip(&self.settings.lower)
                .zip(&self.settings.upper)
            {
                *o = lo + (hi - lo) * x;
            }
        }
        out
    }

    fn reward(entry: &Self::Entry) -> T {
        entry.reward
    }

    fn set_reward(entry: &mut Self::Entry, reward: T) {
        entry.reward = reward;
    }

    fn start_landing(&mut self, entry: &mut Self::Entry) {
        entry.node = [0; ANCHOR_LINKS];
        entry.weight = [0; ANCHOR_LINKS];
    }

    fn land(&mut self, _: &mut Self::Entry, node: usize, axis: usize, step: T) {
        let (lo, hi) = (
            self.settings.lower.get(axis).copied().unwrap_or(T::ZERO),
            self.settings.upper.get(axis).copied().unwrap_or(T::ONE),
        );
        let x = self
            .positions
            .get(node)
            .and_then(|p| p.get(axis))
            .copied()
            .unwrap_or(T::ZERO);
        let y = ((x * (hi - lo) + step) / (hi - lo)).clamp_to(T::ZERO, T::ONE);
        if let Some(slot) = self.landings.get_mut(node).and_then(|l| l.get_mut(axis)) {
            *slot = y;
        }
    }

    fn finish_landing(&mut self, entry: &mut Self::Entry, node: usize) {
        let Some(y) = self.landings.get(node).copied() else {
            return;
        };
        let mut out = [(0usize, T::ZERO); ANCHOR_LINKS];
        let used = self.read(&y, &mut out);
        let scale = T::from_usize(usize::from(WEIGHT_ONE));
        for ((&(j, w), n), slot) in out
            .iter()
            .zip(entry.node.iter_mut())
            .zip(entry.weight.iter_mut())
            .take(used)
        {
            *n = j as u16;
            *slot = (w * scale + T::from_f64(0.5))
                .to_usize_saturating()
                .min(usize::from(WEIGHT_ONE)) as u16;
        }
    }

    #[inline]
    fn ahead(&self, entry: &Self::Entry, nodes: &[SweepNode<T>]) -> (T, T) {
        let scale = T::ONE / T::from_usize(usize::from(WEIGHT_ONE));
        let (mut v, mut omega) = (T::ZERO, T::ZERO);
        for (&j, &w) in entry.node.iter().zip(&entry.weight) {
            if w == 0 {
                continue;
            }
            if let Some(n) = nodes.get(usize::from(j)) {
                let w = T::from_usize(usize::from(w)) * scale;
                v += w * n.previous();
                omega += w * n.absorbing();
            }
        }
        (v, omega)
    }

    /// The weighted mean of the landing nodes' positions (the landing point itself only
    /// when it sits on a node; the scratch is reused by the next fit).
    fn landing(&self, entry: &Self::Entry) -> Option<[T; D]> {
        let scale = T::ONE / T::from_usize(usize::from(WEIGHT_ONE));
        let mut out = [T::ZERO; D];
        let mut total = T::ZERO;
        for (&j, &w) in entry.node.iter().zip(&entry.weight) {
            if w == 0 {
                continue;
            }
            let w = T::from_usize(usize::from(w)) * scale;
            let p = self.position(usize::from(j));
            for (o, &x) in out.iter_mut().zip(&p) {
                *o += w * x;
            }
            total += w;
        }
        if total <= T::ZERO {
            return None;
        }
        Some(out.map(|x| x / total))
    }
}

/// A Q-function fitted by a model sweep on anchors.
pub type AnchorFqi<'a, T, const D: usize> = ModelFqi<'a, T, D, Anchors<'a, T, D>>;

impl<'a, T: Real, const D: usize> AnchorFqi<'a, T, D> {
    /// A Q-function that is 0 everywhere, its nodes not yet placed (a fit places them), in
    /// the first [`AnchorSweep::required_entries`] entries and [`AnchorSweep::nodes`]
    /// nodes, positions and landings of the storage.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]); a slice too short
    /// ([`Error::CapacityExceeded`] with its length).
    pub fn new(
        settings: AnchorSweep<T, D>,
        actions: usize,
        storage: AnchorParts<'a, T, D>,
    ) -> Result<Self> {
        let budget = settings.budget;
        for len in [storage.positions.len(), storage.landings.len()] {
            if len < budget {
                return Err(Error::CapacityExceeded { capacity: len });
            }
        }
        let AnchorParts {
            entries,
            nodes,
            positions,
            landings,
        } = storage;
        let layout = Anchors {
            settings,
            positions: positions.get_mut(..budget).unwrap_or_default(),
            landings: landings.get_mut(..budget).unwrap_or_default(),
            count: 0,
            axis: 0,
        };
        ModelFqi::with_layout(layout, budget, actions, entries, nodes)
    }

    /// The settings.
    pub fn settings(&self) -> &AnchorSweep<T, D> {
        &self.layout().settings
    }

    /// Number of nodes the last fit placed.
    pub fn placed(&self) -> usize {
        self.layout().count
    }

    /// The position of node `node` (`None` beyond the placed nodes).
    pub fn anchor(&self, node: usize) -> Option<[T; D]> {
        (node < self.layout().count).then(|| self.layout().position(node))
    }
}

/// The memory an [`AnchorFqi`] is built in.
#[derive(Debug)]
pub struct AnchorParts<'a, T, const D: usize> {
    /// One entry per node and action ([`AnchorSweep::required_entries`]).
    pub entries: &'a mut [AnchorEntry<T>],
    /// One per node of the budget.
    pub nodes: &'a mut [SweepNode<T>],
    /// One per node of the budget.
    pub positions: &'a mut [[T; D]],
    /// One per node of the budget.
    pub landings: &'a mut [[T; D]],
}

/// The memory of a sweep on anchors as one block with const-generic capacities (`E`
/// entries, `M` nodes), all-zero so it can be a `static` in `.bss`.
#[derive(Debug, Clone)]
pub struct AnchorStorage<T, const D: usize, const E: usize, const M: usize> {
    entries: [AnchorEntry<T>; E],
    nodes: [SweepNode<T>; M],
    positions: [[T; D]; M],
    landings: [[T; D]; M],
}

impl<T: Real, const D: usize, const E: usize, const M: usize> AnchorStorage<T, D, E, M> {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            entries: [AnchorEntry::EMPTY; E],
            nodes: [SweepNode::EMPTY; M],
            positions: [[T::ZERO; D]; M],
            landings: [[T::ZERO; D]; M],
        }
    }

    /// The block as the [`QStorage`](super::QStorage) a Q-function is built in.
    pub fn storage(&mut self) -> super::QStorage<'_, T, D> {
        super::QStorage {
            sweep_nodes: &mut self.nodes,
            anchor_entries: &mut self.entries,
            anchor_positions: &mut self.positions,
            anchor_landings: &mut self.landings,
            ..super::QStorage::default()
        }
    }
}

impl<T: Real, const D: usize, const E: usize, const M: usize> Default
    for AnchorStorage<T, D, E, M>
{
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
