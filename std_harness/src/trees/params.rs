//! The growth limits of the trees ([`TreeParams`]).

use awfqi::{Error, Result};

/// The growth limits of scikit-learn's `min_samples_split` and `min_samples_leaf`: a node
/// with fewer than `min_samples_split` samples, or fewer than `2·min_samples_leaf`, is a
/// leaf, and a candidate split that leaves fewer than `min_samples_leaf` samples on a side
/// is invalid (rejected like a zero-weight child, before the scores are compared).
///
/// The defaults (2 and 1) are the fully grown trees of spec §4.1; the IWFQI paper's Dam
/// runs use `min_samples_split = 20`, its Acrobot runs `5` and `2`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct TreeParams {
    /// Fewest samples a node needs to be split (≥ 2).
    pub min_samples_split: usize,
    /// Fewest samples each child of a split must keep (≥ 1).
    pub min_samples_leaf: usize,
}

impl Default for TreeParams {
    /// Fully grown trees (spec §4.1): 2 and 1.
    fn default() -> Self {
        Self::FULLY_GROWN
    }
}

impl TreeParams {
    /// Fully grown trees (spec §4.1): `min_samples_split = 2`, `min_samples_leaf = 1`.
    pub const FULLY_GROWN: Self = Self {
        min_samples_split: 2,
        min_samples_leaf: 1,
    };

    /// `true` for [`TreeParams::FULLY_GROWN`].
    pub fn is_fully_grown(&self) -> bool {
        *self == Self::FULLY_GROWN
    }

    /// Checks `min_samples_split ≥ 2` and `min_samples_leaf ≥ 1`.
    ///
    /// Errors: [`Error::InvalidParameter`] naming the offending field.
    pub fn validate(&self) -> Result<()> {
        if self.min_samples_split < 2 {
            return Err(Error::InvalidParameter {
                parameter: "min_samples_split",
            });
        }
        if self.min_samples_leaf < 1 {
            return Err(Error::InvalidParameter {
                parameter: "min_samples_leaf",
            });
        }
        Ok(())
    }

    /// The fewest samples a node must hold to be split at all.
    pub(super) fn min_node(&self) -> usize {
        self.min_samples_split.max(2 * self.min_samples_leaf)
    }
}
