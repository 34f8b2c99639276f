//! The forest ([`Forest`]) and its fit: validation, seeding, and growing every tree.

use super::growth::Tree;
use super::layout::{Node, Record, Workspace};
use super::params::TreeParams;
use awfqi::{Error, Result};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// An Extra-Trees regression forest on `D`-dimensional inputs with sample weights
/// (spec §4.1; see the [module docs](super) for the rules).
///
/// Memory: 24 bytes per node (16 for the node, 8 for its value); a tree on `n` samples has
/// at most `2n − 1` nodes, so a forest of `M` trees takes at most `24·M·(2n − 1)` bytes,
/// plus `(8D + 16)·3n` bytes of growth buffers kept for the next [`Forest::refit`].
#[derive(Debug, Clone, Default)]
pub struct Forest<const D: usize> {
    pub(super) nodes: Vec<Node>,
    /// Leaf values, indexed like `nodes` (0 at splits).
    pub(super) values: Vec<f64>,
    /// Arena index of each tree's root; empty when the forest predicts 0.
    pub(super) roots: Vec<u32>,
    pub(super) workspace: Workspace<D>,
}

/// Checks lengths and values of a training set: finite inputs and targets, finite
/// non-negative weights.
pub(super) fn validate<const D: usize>(
    states: &[[f64; D]],
    targets: &[f64],
    weights: &[f64],
) -> Result<()> {
    if targets.len() != states.len() {
        return Err(Error::InvalidParameter {
            parameter: "targets",
        });
    }
    if weights.len() != states.len() {
        return Err(Error::InvalidParameter {
            parameter: "weights",
        });
    }
    if states.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "states",
        });
    }
    if targets.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "targets",
        });
    }
    if weights.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "weights",
        });
    }
    if weights.iter().any(|&w| w < 0.0) {
        return Err(Error::InvalidParameter {
            parameter: "weights",
        });
    }
    Ok(())
}

impl<const D: usize> Forest<D> {
    /// A forest with no trees: it predicts 0 everywhere (FQI's `Q₀ ≡ 0`).
    pub fn empty() -> Self {
        Self::default()
    }

    /// Fits `n_trees` extra-trees on `(states, targets)` with sample `weights`.
    ///
    /// Draws `n_trees` sub-seeds from `rng` (none when the total weight is 0, in which case
    /// the forest predicts 0).
    ///
    /// Errors: `n_trees == 0` or mismatched lengths ([`Error::InvalidParameter`]), a
    /// non-finite input, target or weight ([`Error::NonFinite`]), a negative weight
    /// ([`Error::InvalidParameter`]), more than `u32::MAX / 2` samples
    /// ([`Error::CapacityExceeded`]).
    pub fn fit<R: Rng + ?Sized>(
        states: &[[f64; D]],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        rng: &mut R,
    ) -> Result<Self> {
        let mut forest = Self::empty();
        forest.refit(states, targets, weights, n_trees, rng)?;
        Ok(forest)
    }

    /// [`Forest::fit`] in place, reusing this forest's buffers. On error the forest is left
    /// as it was.
    pub fn refit<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        rng: &mut R,
    ) -> Result<()> {
        self.refit_with(
            states,
            targets,
            weights,
            n_trees,
            &TreeParams::FULLY_GROWN,
            rng,
        )
    }

    /// [`Forest::refit`] with the growth limits `params` (the same draws as fully grown
    /// trees: limits only turn nodes into leaves and reject candidates).
    ///
    /// Errors: as [`Forest::fit`], plus invalid `params` ([`TreeParams::validate`]).
    pub fn refit_with<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        params: &TreeParams,
        rng: &mut R,
    ) -> Result<()> {
        self.refit_stopping(states, targets, weights, n_trees, params, true, rng)
    }

    /// [`Forest::refit_with`] without the impurity stop: a node is split until the size
    /// limits or constant inputs stop it, so the leaves stay small where this fit's
    /// targets happen to be constant. For a structure that later fits reuse with other
    /// targets ([`crate::frozen_trees`]). A pure node's children keep its mean, but the
    /// draws for its splits shift those of the nodes grown after it, so the forest is
    /// another draw of the spec's, not the same one.
    ///
    /// Errors: as [`Forest::refit_with`].
    pub fn refit_fine<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        params: &TreeParams,
        rng: &mut R,
    ) -> Result<()> {
        self.refit_stopping(states, targets, weights, n_trees, params, false, rng)
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn refit_stopping<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        params: &TreeParams,
        impurity_stop: bool,
        rng: &mut R,
    ) -> Result<()> {
        params.validate()?;
        if n_trees == 0 {
            return Err(Error::InvalidParameter {
                parameter: "n_trees",
            });
        }
        validate(states, targets, weights)?;
        // Node indices are u32 and a tree has at most 2n − 1 nodes per tree.
        let limit = (u32::MAX / 2) as usize;
        if states.len() > limit || n_trees.saturating_mul(2 * states.len()) > u32::MAX as usize {
            return Err(Error::CapacityExceeded { capacity: limit });
        }
        self.grow(
            states,
            targets,
            weights,
            n_trees,
            params,
            impurity_stop,
            rng,
        );
        Ok(())
    }

    /// Grows the trees on validated input.
    #[allow(clippy::too_many_arguments)]
    fn grow<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        params: &TreeParams,
        impurity_stop: bool,
        rng: &mut R,
    ) {
        self.nodes.clear();
        self.values.clear();
        self.roots.clear();
        let total_weight: f64 = weights.iter().sum();
        if total_weight <= 0.0 {
            return;
        }
        let ws = &mut self.workspace;
        ws.seeds.clear();
        ws.seeds.extend((0..n_trees).map(|_| rng.next_u64()));
        ws.master.clear();
        ws.master.extend(
            states
                .iter()
                .zip(weights)
                .zip(targets)
                .map(|((&x, &w), &y)| Record { x, w, y }),
        );
        let n = states.len();
        ws.second.clear();
        ws.second.resize(n, ws.master[0]);
        let capacity = n_trees * (2 * n - 1);
        self.nodes.reserve(capacity);
        self.values.reserve(capacity);
        for &seed in &ws.seeds {
            ws.first.clear();
            ws.first.extend_from_slice(&ws.master);
            let mut tree_rng = ChaCha8Rng::seed_from_u64(seed);
            self.roots.push(self.nodes.len() as u32);
            let mut tree = Tree {
                nodes: &mut self.nodes,
                values: &mut self.values,
                params,
                impurity_stop,
            };
            tree.grow(&mut ws.first, &mut ws.second, &mut ws.stack, &mut tree_rng);
        }
    }
}
