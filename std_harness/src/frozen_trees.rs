//! FQI's later iterations on **frozen trees**: the forests of one iteration keep their
//! splits, and each further iteration only gives their leaves new values, the weighted
//! means of the new targets of the training records in each leaf. An option
//! (`FqiOptions::freeze_after`), not the spec's FQI, which regrows every forest (§5).
//!
//! Why: with a fixed structure FQI's update is a fixed averaging operator (Ernst, Geurts
//! and Wehenkel, JMLR 2005: tree ensembles whose splits do not depend on the targets make
//! the iteration a contraction), and the leaf each training record and each next-state
//! query falls in is found once. An iteration then costs one pass over the records per
//! tree (leaf sums) and one gather per query and tree, instead of growing the trees and
//! walking every query through them: on the Dam's 65 000 records × 8 releases × 100 trees,
//! ≈ 20× less per iteration (docs/large-data.md).
//!
//! A query's prediction is the sum of its leaves' values in tree order divided by the
//! number of trees, the arithmetic of [`Forest::predict_into`], so before any refit the
//! frozen forest predicts exactly what the forest it was taken from does.

use crate::trees::{ActionForests, Forest};
use awfqi::{Error, Result};

/// One forest's structure, frozen: the leaf of every training record and every query in
/// every tree, and the leaves' total training weights.
///
/// Memory: `4·M·(n + q)` bytes of leaf indices (`M` trees, `n` records, `q` queries) and
/// `16` bytes per node.
#[derive(Debug, Clone)]
pub struct FrozenForest {
    n_trees: usize,
    n_nodes: usize,
    n_records: usize,
    n_queries: usize,
    weights: Vec<f64>,
    /// Tree-major: `record_leaves[t·n + i]` is record `i`'s leaf in tree `t`.
    record_leaves: Vec<u32>,
    /// Tree-major: `query_leaves[t·q + j]` is query `j`'s leaf in tree `t`.
    query_leaves: Vec<u32>,
    /// Total training weight of each leaf, by arena index (0 at splits).
    leaf_weight: Vec<f64>,
    /// `Σ w·y` per leaf during a refit, by arena index.
    sums: Vec<f64>,
}

impl FrozenForest {
    /// Freezes `forest`, grown on `inputs` with `weights`, for predictions at `queries`.
    ///
    /// Errors: `weights` of another length than `inputs`, negative or non-finite
    /// ([`Error::InvalidParameter`], [`Error::NonFinite`]); a leaf that holds no training
    /// weight (the forest was grown on other data, [`Error::InvalidParameter`] `weights`);
    /// more than `u32::MAX` records or queries ([`Error::CapacityExceeded`]).
    pub fn new<const D: usize>(
        forest: &Forest<D>,
        inputs: &[[f64; D]],
        weights: &[f64],
        queries: &[[f64; D]],
    ) -> Result<Self> {
        if weights.len() != inputs.len() {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        if weights.iter().any(|w| !w.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "weights",
            });
        }
        if weights.iter().any(|&w| w < 0.0) {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        let limit = u32::MAX as usize;
        if inputs.len() > limit || queries.len() > limit {
            return Err(Error::CapacityExceeded { capacity: limit });
        }
        let (m, n, q) = (forest.n_trees(), inputs.len(), queries.len());
        let mut record_leaves = vec![0u32; m * n];
        let mut query_leaves = vec![0u32; m * q];
        let mut leaf_weight = vec![0.0; forest.n_nodes()];
        for t in 0..m {
            let leaves = &mut record_leaves[t * n..(t + 1) * n];
            forest.leaf_ids_into(t, inputs, leaves)?;
            for (&l, &w) in leaves.iter().zip(weights) {
                leaf_weight[l as usize] += w;
            }
            forest.leaf_ids_into(t, queries, &mut query_leaves[t * q..(t + 1) * q])?;
        }
        let empty_leaf =
            (0..forest.n_nodes()).any(|node| forest.is_leaf(node) && leaf_weight[node] <= 0.0);
        if empty_leaf {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        Ok(Self {
            n_trees: m,
            n_nodes: forest.n_nodes(),
            n_records: n,
            n_queries: q,
            weights: weights.to_vec(),
            record_leaves,
            query_leaves,
            leaf_weight,
            sums: Vec::new(),
        })
    }

    /// Number of queries.
    pub fn n_queries(&self) -> usize {
        self.n_queries
    }

    /// `forest`'s prediction at every query, into `out` (bit-identical to
    /// [`Forest::predict_into`] at the queries).
    ///
    /// Errors: `forest` is not the one frozen (another shape), `out.len()` differs from
    /// the number of queries ([`Error::InvalidParameter`]).
    pub fn predict_into<const D: usize>(&self, forest: &Forest<D>, out: &mut [f64]) -> Result<()> {
        self.check(forest)?;
        if out.len() != self.n_queries {
            return Err(Error::InvalidParameter { parameter: "out" });
        }
        out.fill(0.0);
        if self.n_trees == 0 {
            return Ok(());
        }
        let values = forest.node_values();
        for leaves in self.query_leaves.chunks_exact(self.n_queries.max(1)) {
            for (o, &l) in out.iter_mut().zip(leaves) {
                *o += values[l as usize];
            }
        }
        let m = self.n_trees as f64;
        out.iter_mut().for_each(|v| *v /= m);
        Ok(())
    }

    /// Gives every leaf of `forest` the weighted mean of `targets` over its training
    /// records (the frozen weights); splits are unchanged.
    ///
    /// Errors: `forest` is not the one frozen, `targets` of another length than the
    /// records ([`Error::InvalidParameter`]), a non-finite target ([`Error::NonFinite`]);
    /// the forest is unchanged then.
    pub fn refit<const D: usize>(&mut self, forest: &mut Forest<D>, targets: &[f64]) -> Result<()> {
        self.check(forest)?;
        if targets.len() != self.n_records {
            return Err(Error::InvalidParameter {
                parameter: "targets",
            });
        }
        if targets.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "targets",
            });
        }
        self.sums.clear();
        self.sums.resize(self.n_nodes, 0.0);
        for leaves in self.record_leaves.chunks_exact(self.n_records.max(1)) {
            for ((&l, &w), &y) in leaves.iter().zip(&self.weights).zip(targets) {
                self.sums[l as usize] += w * y;
            }
        }
        let values = forest.node_values_mut();
        for ((v, &s), &w) in values.iter_mut().zip(&self.sums).zip(&self.leaf_weight) {
            if w > 0.0 {
                *v = s / w;
            }
        }
        Ok(())
    }

    fn check<const D: usize>(&self, forest: &Forest<D>) -> Result<()> {
        if forest.n_trees() != self.n_trees || forest.n_nodes() != self.n_nodes {
            return Err(Error::InvalidParameter {
                parameter: "forest",
            });
        }
        Ok(())
    }
}

/// [`ActionForests`] frozen: one [`FrozenForest`] per action, on that action's records,
/// every one predicting at the same queries.
#[derive(Debug, Clone)]
pub struct FrozenActionForests {
    forests: Vec<FrozenForest>,
    /// The records of each action, as indices into the dataset (in dataset order, the
    /// order [`ActionForests`] fits them in).
    members: Vec<Vec<usize>>,
    /// Per-action targets during a refit.
    gathered: Vec<f64>,
}

impl FrozenActionForests {
    /// Freezes `q`, fitted on `(states, actions)` with `weights`, for `max_a Q(x, a)` at
    /// `queries`.
    ///
    /// Errors: mismatched lengths ([`Error::InvalidParameter`]), an action out of range
    /// ([`Error::OutOfRange`]), and those of [`FrozenForest::new`].
    pub fn new<const D: usize>(
        q: &ActionForests<D>,
        states: &[[f64; D]],
        actions: &[usize],
        weights: &[f64],
        queries: &[[f64; D]],
    ) -> Result<Self> {
        if actions.len() != states.len() || weights.len() != states.len() {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        let k = q.num_actions();
        if actions.iter().any(|&a| a >= k) {
            return Err(Error::OutOfRange {
                parameter: "actions",
            });
        }
        let mut members = vec![Vec::new(); k];
        for (i, &a) in actions.iter().enumerate() {
            members[a].push(i);
        }
        let mut forests = Vec::with_capacity(k);
        for (a, idx) in members.iter().enumerate() {
            let forest = q.forest(a).ok_or(Error::OutOfRange {
                parameter: "actions",
            })?;
            let xs: Vec<[f64; D]> = idx.iter().map(|&i| states[i]).collect();
            let ws: Vec<f64> = idx.iter().map(|&i| weights[i]).collect();
            forests.push(FrozenForest::new(forest, &xs, &ws, queries)?);
        }
        Ok(Self {
            forests,
            members,
            gathered: Vec::new(),
        })
    }

    /// `max_a Q(queries[j], a)` into `out` (bit-identical to
    /// [`ActionForests::max_over_actions_into`]); `scratch` as long as `out`.
    ///
    /// Errors: `q` is not the one frozen, wrong lengths ([`Error::InvalidParameter`]).
    pub fn max_over_actions_into<const D: usize>(
        &self,
        q: &ActionForests<D>,
        out: &mut [f64],
        scratch: &mut [f64],
    ) -> Result<()> {
        if q.num_actions() != self.forests.len() {
            return Err(Error::InvalidParameter {
                parameter: "forest",
            });
        }
        if scratch.len() != out.len() {
            return Err(Error::InvalidParameter {
                parameter: "scratch",
            });
        }
        if self.forests.is_empty() {
            out.fill(0.0);
            return Ok(());
        }
        for (a, frozen) in self.forests.iter().enumerate() {
            let forest = q.forest(a).ok_or(Error::InvalidParameter {
                parameter: "forest",
            })?;
            if a == 0 {
                frozen.predict_into(forest, out)?;
            } else {
                frozen.predict_into(forest, scratch)?;
                for (o, &v) in out.iter_mut().zip(scratch.iter()) {
                    if v > *o {
                        *o = v;
                    }
                }
            }
        }
        Ok(())
    }

    /// New leaf values for every action's forest from `targets` (one per record of the
    /// dataset the forests were frozen on).
    ///
    /// Errors: as [`FrozenForest::refit`]; forests refitted before an error keep their
    /// new values.
    pub fn refit<const D: usize>(
        &mut self,
        q: &mut ActionForests<D>,
        targets: &[f64],
    ) -> Result<()> {
        let n: usize = self.members.iter().map(Vec::len).sum();
        if targets.len() != n || q.num_actions() != self.forests.len() {
            return Err(Error::InvalidParameter {
                parameter: "targets",
            });
        }
        if targets.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "targets",
            });
        }
        for (a, (frozen, idx)) in self.forests.iter_mut().zip(&self.members).enumerate() {
            self.gathered.clear();
            self.gathered.extend(idx.iter().map(|&i| targets[i]));
            let forest = q.forest_mut(a).ok_or(Error::InvalidParameter {
                parameter: "forest",
            })?;
            frozen.refit(forest, &self.gathered)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
