//! Growing one Extra-Trees tree and evaluating it: the split search, the in-place
//! partition, breadth-first growth and the predictions FQI needs (the module docs of
//! [`super`] state the rules).

use super::{CONSTANT_FEATURE_TOLERANCE, ExtraTrees, MIN_IMPURITY, TreeNode, TreeRecord};
use crate::float::Real;
use rand_core::Rng;

/// A node's weighted sums relative to `y0`: `W = Σw`, `S = Σw(y − y0)`,
/// `Q = Σw(y − y0)²`, and the per-feature range.
pub(super) struct Stats<T, const D: usize> {
    pub(super) n: usize,
    pub(super) w: T,
    pub(super) s: T,
    pub(super) q: T,
    pub(super) y0: T,
    pub(super) lo: [T; D],
    pub(super) hi: [T; D],
}

impl<T: Real, const D: usize> Stats<T, D> {
    pub(super) fn of<'r>(
        mut records: impl Iterator<Item = &'r TreeRecord<T, D>> + Clone,
        first: bool,
    ) -> Self
    where
        T: 'r,
    {
        let y0 = records.clone().next().map_or(T::ZERO, |r| r.target);
        let mut st = Self {
            n: 0,
            w: T::ZERO,
            s: T::ZERO,
            q: T::ZERO,
            y0,
            lo: [T::INFINITY; D],
            hi: [T::NEG_INFINITY; D],
        };
        for r in &mut records {
            let w = r.w(first);
            let dy = r.target - y0;
            st.n += 1;
            st.w += w;
            st.s += w * dy;
            st.q += w * dy * dy;
            for ((lo, hi), &x) in st.lo.iter_mut().zip(st.hi.iter_mut()).zip(&r.state) {
                *lo = lo.min(x);
                *hi = hi.max(x);
            }
        }
        st
    }

    /// `Σwy/Σw` (0 without weight).
    pub(super) fn mean(&self) -> T {
        if self.w > T::ZERO {
            self.y0 + self.s / self.w
        } else {
            T::ZERO
        }
    }

    /// `Σw(y − ȳ)²/Σw`.
    pub(super) fn impurity(&self) -> T {
        let m = self.s / self.w;
        self.q / self.w - m * m
    }
}

/// The growth settings shared by every node of a fit.
#[derive(Debug, Clone, Copy)]
pub(super) struct Growth<T> {
    pub(super) first: bool,
    pub(super) min_weight: T,
    pub(super) min_leaf: usize,
    pub(super) min_node: usize,
    pub(super) max_depth: usize,
}

impl<T: Real> Growth<T> {
    /// `forests`' limits for iteration 1 (reward weights), children of at least
    /// `min_weight`.
    pub(super) fn of(forests: &ExtraTrees, min_weight: T) -> Self {
        Self {
            first: true,
            min_weight,
            min_leaf: forests.min_samples_leaf,
            min_node: forests.min_node(),
            max_depth: forests.max_depth,
        }
    }
}

/// The two sides of one feature's candidate split: weight `W`, weighted sum `S` (relative
/// to the node's first target) and, on the left, the record count.
#[derive(Clone, Copy)]
pub(super) struct Sides<T> {
    pub(super) wl: T,
    pub(super) sl: T,
    pub(super) wr: T,
    pub(super) sr: T,
    pub(super) nl: usize,
}

impl<T: Real> Sides<T> {
    pub(super) const EMPTY: Self = Self {
        wl: T::ZERO,
        sl: T::ZERO,
        wr: T::ZERO,
        sr: T::ZERO,
        nl: 0,
    };

    /// Adds a record of weight `w` and weighted target `wy` to its side.
    pub(super) fn add(&mut self, left: bool, w: T, wy: T) {
        if left {
            self.wl += w;
            self.sl += wy;
            self.nl += 1;
        } else {
            self.wr += w;
            self.sr += wy;
        }
    }

    /// [`Sides::add`] without a branch: both sides gain a term, +0 on the other. The sums
    /// start at +0 and never become −0, so adding +0 leaves them as they are: the same
    /// bits as [`Sides::add`].
    pub(super) fn add_both(&mut self, left: bool, w: T, wy: T) {
        self.wl += if left { w } else { T::ZERO };
        self.sl += if left { wy } else { T::ZERO };
        self.wr += if left { T::ZERO } else { w };
        self.sr += if left { T::ZERO } else { wy };
        self.nl += usize::from(left);
    }
}

/// Whether the target runs ahead of its branches (a 64-bit host: out of order, deep
/// pipeline). There, branch-free sums ([`Sides::add_both`]: a random threshold's branch
/// is mispredicted half the time) and lockstep tree walks ([`predict_lanes`]) are faster;
/// on an in-order microcontroller (a Cortex-M's 3-stage pipeline) they only add
/// instructions (+25 % for a step of adaptive AWFQI under QEMU). The values are the
/// same either way, to the bit.
pub(super) const RUNS_AHEAD: bool = cfg!(target_pointer_width = "64");

/// Draws the candidate splits of a node and returns the best valid one.
pub(super) fn best_split<'r, T: Real + 'r, const D: usize, R: Rng + ?Sized>(
    records: impl Iterator<Item = &'r TreeRecord<T, D>>,
    st: &Stats<T, D>,
    growth: &Growth<T>,
    rng: &mut R,
) -> Option<(usize, T)> {
    // The trial order (Fisher–Yates), then one threshold per non-constant feature.
    let mut order = [0usize; D];
    for (i, o) in order.iter_mut().enumerate() {
        *o = i;
    }
    for i in (1..D).rev() {
        order.swap(i, crate::rng::uniform_index(rng, i + 1).min(i));
    }
    let tolerance = T::from_f64(CONSTANT_FEATURE_TOLERANCE);
    let mut thresholds = [T::NEG_INFINITY; D];
    let mut candidate = [false; D];
    for &f in &order {
        let (Some(&lo), Some(&hi)) = (st.lo.get(f), st.hi.get(f)) else {
            continue;
        };
        if hi <= lo + tolerance {
            continue;
        }
        let u: T = crate::rng::uniform(rng);
        let mut tau = lo + u * (hi - lo);
        if tau >= hi {
            tau = lo;
        }
        if let (Some(t), Some(c)) = (thresholds.get_mut(f), candidate.get_mut(f)) {
            *t = tau;
            *c = true;
        }
    }
    if !candidate.contains(&true) {
        return None;
    }
    // Both sides summed on their own, so a side of zero weight has exactly W = 0.
    let mut sides = [Sides::<T>::EMPTY; D];
    for r in records {
        let w = r.w(growth.first);
        let wy = w * (r.target - st.y0);
        for ((&x, &tau), side) in r.state.iter().zip(&thresholds).zip(&mut sides) {
            if RUNS_AHEAD {
                side.add_both(x <= tau, w, wy);
            } else {
                side.add(x <= tau, w, wy);
            }
        }
    }
    let n = st.n;
    let enough = |w: T| w > T::ZERO && w >= growth.min_weight;
    let mut best = None;
    let mut best_score = T::NEG_INFINITY;
    for &f in &order {
        let (Some(&c), Some(side), Some(&tau)) =
            (candidate.get(f), sides.get(f), thresholds.get(f))
        else {
            continue;
        };
        let Sides { wl, sl, wr, sr, nl } = *side;
        let counted = nl >= growth.min_leaf && n - nl.min(n) >= growth.min_leaf;
        if !(c && counted && enough(wl) && enough(wr)) {
            continue;
        }
        let score = sl * sl / wl + sr * sr / wr;
        if score > best_score {
            best_score = score;
            best = Some((f, tau));
        }
    }
    best
}

/// Moves the records with `x[feature] ≤ threshold` to the front; returns their number.
pub(super) fn partition<T: Real, const D: usize>(
    records: &mut [TreeRecord<T, D>],
    feature: usize,
    threshold: T,
) -> usize {
    let mut left = 0;
    for j in 0..records.len() {
        let goes_left = records
            .get(j)
            .is_some_and(|r| r.coordinate(feature) <= threshold);
        if goes_left {
            swap(records, left, j);
            left += 1;
        }
    }
    left
}

/// Swaps elements `i ≤ j` of `items` (nothing when out of range; no bounds-check panic).
pub(super) fn swap<X>(items: &mut [X], i: usize, j: usize) {
    if i >= j {
        return;
    }
    if let Some((head, tail)) = items.split_at_mut_checked(j) {
        if let (Some(a), Some(b)) = (head.get_mut(i), tail.first_mut()) {
            core::mem::swap(a, b);
        }
    }
}

/// Grows one tree on `records` (reordering them) into `nodes`, breadth first (module
/// docs). `total` is the records' total weight; with none the tree is the leaf 0.
pub(super) fn grow<T: Real, const D: usize, R: Rng + ?Sized>(
    records: &mut [TreeRecord<T, D>],
    nodes: &mut [TreeNode<T>],
    growth: &Growth<T>,
    total: T,
    rng: &mut R,
) {
    let Some(root) = nodes.first_mut() else {
        return;
    };
    *root = TreeNode::leaf(T::ZERO);
    // A range end must fit the u16 that holds it (checked by `TreeFqi::new`).
    let Ok(n) = u16::try_from(records.len()) else {
        return;
    };
    if n == 0 || total <= T::ZERO {
        return;
    }
    root.left = 0;
    root.feature = n;
    let impurity_floor = T::from_f64(MIN_IMPURITY);
    let mut len = 1usize;
    let mut cursor = 0usize;
    // Breadth first: the nodes of one depth are `cursor..level_end`, their children after.
    let mut depth = 0usize;
    let mut level_end = 1usize;
    while cursor < len {
        if cursor == level_end {
            depth += 1;
            level_end = len;
        }
        let Some(&pending) = nodes.get(cursor) else {
            break;
        };
        let (start, end) = (usize::from(pending.left), usize::from(pending.feature));
        let Some(mine) = records.get_mut(start..end) else {
            break;
        };
        let st = Stats::of(mine.iter(), growth.first);
        let mut node = TreeNode::leaf(st.mean());
        let splittable = mine.len() >= 2
            && depth < growth.max_depth
            && mine.len() >= growth.min_node
            && st.w > T::ZERO
            && st.impurity() > impurity_floor
            && len + 2 <= nodes.len();
        if splittable {
            if let Some((feature, tau)) = best_split(mine.iter(), &st, growth, rng) {
                let mid = start + partition(mine, feature, tau);
                if let (Some(children), Ok(left), Ok(feature), Ok(mid), Ok(end)) = (
                    nodes.get_mut(len..len + 2),
                    u16::try_from(len),
                    u16::try_from(feature + 1),
                    u16::try_from(mid),
                    u16::try_from(end),
                ) {
                    if let [l, r] = children {
                        *l = TreeNode {
                            value: T::ZERO,
                            left: pending.left,
                            feature: mid,
                        };
                        *r = TreeNode {
                            value: T::ZERO,
                            left: mid,
                            feature: end,
                        };
                    }
                    node = TreeNode {
                        value: tau,
                        left,
                        feature,
                    };
                    len += 2;
                }
            }
        }
        if let Some(slot) = nodes.get_mut(cursor) {
            *slot = node;
        }
        cursor += 1;
    }
}

/// The prediction of the tree in `nodes` at `state`.
pub(super) fn predict<T: Real, const D: usize>(nodes: &[TreeNode<T>], state: &[T; D]) -> T {
    let mut i = 0usize;
    // Children come after their parent, so a walk takes at most `nodes.len()` steps.
    for _ in 0..nodes.len() {
        let Some(node) = nodes.get(i) else {
            break;
        };
        if node.is_leaf() {
            return node.value;
        }
        let next = node.child(state);
        if next <= i {
            break;
        }
        i = next;
    }
    T::ZERO
}

/// Records walked down a tree in lockstep by [`add_next_state_values`].
pub(super) const LANES: usize = 8;

/// [`predict`] at `LANES` states at once, with the same values: each lane takes one step
/// per round, so the lanes' node loads overlap on a core that runs ahead (the host's);
/// on an in-order core it costs what `LANES` walks cost.
pub(super) fn predict_lanes<T: Real, const D: usize>(
    nodes: &[TreeNode<T>],
    states: &[[T; D]; LANES],
) -> [T; LANES] {
    let mut at = [0usize; LANES];
    // Children come after their parent, so no walk takes `nodes.len()` steps.
    for _ in 0..nodes.len() {
        let mut moved = false;
        for (i, state) in at.iter_mut().zip(states) {
            let node = nodes.get(*i).copied().unwrap_or(TreeNode::EMPTY);
            let next = if node.is_leaf() {
                *i
            } else {
                let child = node.child(state);
                // A child before its parent (never grown so) ends the walk at 0, as in
                // `predict`: past the end.
                if child > *i { child } else { nodes.len() }
            };
            moved |= next != *i;
            *i = next;
        }
        if !moved {
            break;
        }
    }
    at.map(|i| {
        nodes
            .get(i)
            .filter(|node| node.is_leaf())
            .map_or(T::ZERO, |node| node.value)
    })
}

/// Adds the tree's prediction at each non-absorbing record's next state to the record's
/// `acc`: [`predict`]'s values, one record at a time or, `lockstep`, [`LANES`] at a time
/// ([`predict_lanes`]).
pub(super) fn add_next_state_values<T: Real, const D: usize>(
    tree: &[TreeNode<T>],
    records: &mut [TreeRecord<T, D>],
    lockstep: bool,
) {
    if !lockstep {
        for r in records.iter_mut().filter(|r| !r.absorbing) {
            r.acc += predict(tree, &r.next_state);
        }
        return;
    }
    let mut chunks = records.chunks_exact_mut(LANES);
    for chunk in &mut chunks {
        let mut states = [[T::ZERO; D]; LANES];
        for (state, r) in states.iter_mut().zip(chunk.iter()) {
            *state = r.next_state;
        }
        for (r, value) in chunk.iter_mut().zip(predict_lanes(tree, &states)) {
            if !r.absorbing {
                r.acc += value;
            }
        }
    }
    for r in chunks.into_remainder() {
        if !r.absorbing {
            r.acc += predict(tree, &r.next_state);
        }
    }
}
