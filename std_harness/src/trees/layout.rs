//! The data a forest is made of: arena nodes, training records, the growth stack and the
//! reusable buffers of a fit.

/// One node of the flat arena: 16 bytes.
///
/// A split sends `x[feature] ≤ threshold` to `left` and the rest to `left + 1` (the two
/// children are adjacent and come after their parent). A leaf is a node that leads to
/// itself: `threshold = +∞`, `feature = 0`, `left` = its own index; its value is in the
/// forest's `values`. Prediction is then one branch-free step per level, and a walk has
/// ended when a step does not move.
#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    pub(super) threshold: f64,
    pub(super) feature: u32,
    pub(super) left: u32,
}

impl Node {
    pub(super) fn leaf(index: u32) -> Self {
        Self {
            threshold: f64::INFINITY,
            feature: 0,
            left: index,
        }
    }

    /// The node `x` moves to from this one (itself for a leaf).
    #[inline(always)]
    pub(super) fn step<const D: usize>(&self, x: &[f64; D]) -> usize {
        self.left as usize + usize::from(x[self.feature as usize] > self.threshold)
    }
}

/// One training sample during growth: inputs, weight, target.
#[derive(Debug, Clone, Copy)]
pub(super) struct Record<const D: usize> {
    pub(super) x: [f64; D],
    pub(super) w: f64,
    pub(super) y: f64,
}

impl<const D: usize> Record<D> {
    /// The value of a leaf holding only this record, `w·y / w` as the weighted mean
    /// computes it; with `w = 1` that is `y` exactly, without the division.
    #[inline(always)]
    pub(super) fn leaf_value(&self) -> f64 {
        if self.w == 1.0 {
            self.y
        } else {
            self.w * self.y / self.w
        }
    }
}

/// A node waiting to be grown: its arena index, its records `start..end` and which of the
/// two record buffers holds them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pending {
    pub(super) node: u32,
    pub(super) start: u32,
    pub(super) end: u32,
    pub(super) in_second: bool,
}

/// Reusable buffers of a fit.
#[derive(Debug, Clone, Default)]
pub(super) struct Workspace<const D: usize> {
    /// The training set as records, in input order.
    pub(super) master: Vec<Record<D>>,
    /// The two buffers a tree partitions between: a node's records are in one, its
    /// children's in the other.
    pub(super) first: Vec<Record<D>>,
    pub(super) second: Vec<Record<D>>,
    pub(super) stack: Vec<Pending>,
    pub(super) seeds: Vec<u64>,
}
