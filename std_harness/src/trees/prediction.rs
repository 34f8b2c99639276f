//! Queries of a fitted [`Forest`]: single and batch predictions, leaf identifiers, and
//! the arena access that frozen structures use.

use super::forest::Forest;
use awfqi::{Error, Result};

/// Inputs walked in lockstep by batch prediction.
const LANES: usize = 8;

impl<const D: usize> Forest<D> {
    /// Number of trees (0 for a forest that predicts 0).
    pub fn n_trees(&self) -> usize {
        self.roots.len()
    }

    /// Total number of nodes over all trees.
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Arena index of the leaf of the tree rooted at `root` that `x` falls in.
    #[inline]
    fn leaf_of(&self, root: u32, x: &[f64; D]) -> usize {
        let mut i = root as usize;
        loop {
            let next = self.nodes[i].step(x);
            if next == i {
                return i;
            }
            i = next;
        }
    }

    /// The prediction of tree `tree` at `x`, or `None` when there is no such tree.
    pub fn tree_prediction(&self, tree: usize, x: &[f64; D]) -> Option<f64> {
        let root = *self.roots.get(tree)?;
        Some(self.values[self.leaf_of(root, x)])
    }

    /// An identifier of the leaf of tree `tree` that `x` falls in (unique within the forest),
    /// or `None` when there is no such tree. Two inputs share a leaf of a tree exactly when
    /// their identifiers are equal.
    pub fn leaf_id(&self, tree: usize, x: &[f64; D]) -> Option<usize> {
        let root = *self.roots.get(tree)?;
        Some(self.leaf_of(root, x))
    }

    /// The forest's prediction at `x`: the unweighted mean of its trees (0 without trees).
    pub fn predict(&self, x: &[f64; D]) -> f64 {
        if self.roots.is_empty() {
            return 0.0;
        }
        let sum: f64 = self
            .roots
            .iter()
            .map(|&root| self.values[self.leaf_of(root, x)])
            .sum();
        sum / self.roots.len() as f64
    }

    /// Predictions at many inputs, written to `out` (bit-identical to [`Forest::predict`]
    /// at each input, but faster: one tree at a time over all inputs).
    ///
    /// Errors: `out.len() != xs.len()` ([`Error::InvalidParameter`]).
    pub fn predict_into(&self, xs: &[[f64; D]], out: &mut [f64]) -> Result<()> {
        if out.len() != xs.len() {
            return Err(Error::InvalidParameter { parameter: "out" });
        }
        out.fill(0.0);
        if self.roots.is_empty() {
            return Ok(());
        }
        for &root in &self.roots {
            self.accumulate_tree(root, xs, out);
        }
        let m = self.roots.len() as f64;
        out.iter_mut().for_each(|v| *v /= m);
        Ok(())
    }

    /// Adds the prediction of the tree rooted at `root` at each input to `out`. Walks
    /// [`LANES`] inputs in lockstep, branch-free, so their memory accesses overlap.
    fn accumulate_tree(&self, root: u32, xs: &[[f64; D]], out: &mut [f64]) {
        let mut chunks_x = xs.chunks_exact(LANES);
        let mut chunks_out = out.chunks_exact_mut(LANES);
        for (cx, co) in (&mut chunks_x).zip(&mut chunks_out) {
            let idx = self.leaves_of_lanes(root, cx);
            for (o, &i) in co.iter_mut().zip(&idx) {
                *o += self.values[i];
            }
        }
        for (x, o) in chunks_x.remainder().iter().zip(chunks_out.into_remainder()) {
            *o += self.values[self.leaf_of(root, x)];
        }
    }

    /// The arena indices of the leaves of the tree rooted at `root` that the [`LANES`]
    /// inputs `xs` fall in, walked in lockstep, branch-free.
    #[inline(always)]
    fn leaves_of_lanes(&self, root: u32, xs: &[[f64; D]]) -> [usize; LANES] {
        let nodes = self.nodes.as_slice();
        let mut idx = [root as usize; LANES];
        loop {
            let mut moved = false;
            for (i, x) in idx.iter_mut().zip(xs) {
                let next = nodes[*i].step(x);
                moved |= next != *i;
                *i = next;
            }
            if !moved {
                return idx;
            }
        }
    }

    /// The arena index of the leaf of tree `tree` that each input falls in, into `out`
    /// (batch form of [`Forest::leaf_id`]).
    ///
    /// Errors: no such tree ([`Error::OutOfRange`]), `out.len() != xs.len()`
    /// ([`Error::InvalidParameter`]).
    pub fn leaf_ids_into(&self, tree: usize, xs: &[[f64; D]], out: &mut [u32]) -> Result<()> {
        let &root = self
            .roots
            .get(tree)
            .ok_or(Error::OutOfRange { parameter: "tree" })?;
        if out.len() != xs.len() {
            return Err(Error::InvalidParameter { parameter: "out" });
        }
        let mut chunks_x = xs.chunks_exact(LANES);
        let mut chunks_out = out.chunks_exact_mut(LANES);
        for (cx, co) in (&mut chunks_x).zip(&mut chunks_out) {
            let idx = self.leaves_of_lanes(root, cx);
            for (o, &i) in co.iter_mut().zip(&idx) {
                *o = i as u32;
            }
        }
        for (x, o) in chunks_x.remainder().iter().zip(chunks_out.into_remainder()) {
            *o = self.leaf_of(root, x) as u32;
        }
        Ok(())
    }

    /// The node values by arena index (a leaf's prediction; 0 at splits).
    pub(crate) fn node_values(&self) -> &[f64] {
        &self.values
    }

    /// The node values by arena index, to give a fixed structure new leaf values.
    pub(crate) fn node_values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// `true` when arena index `node` is a leaf.
    pub(crate) fn is_leaf(&self, node: usize) -> bool {
        self.nodes
            .get(node)
            .is_some_and(|n| n.left as usize == node)
    }
}
