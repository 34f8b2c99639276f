//! Drawing rows of a score table with replacement (§11.3, §12 step 1).

use super::RowSet;
use crate::alias::AliasTable;
use crate::float::Real;
use rand_core::Rng;

/// Draws rows of a score table with replacement, O(1) per draw (§12 step 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSampler<'a, T, const D: usize> {
    rows: RowSet<'a, T, D>,
    alias: AliasTable<'a, T>,
}

impl<'a, T: Real, const D: usize> RowSampler<'a, T, D> {
    /// Draws `rows` with the probabilities of `alias` (one entry per row).
    pub(super) fn new(rows: RowSet<'a, T, D>, alias: AliasTable<'a, T>) -> Self {
        Self { rows, alias }
    }

    /// Draws one row and returns its index, state and action; consumes one `u64`.
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> (usize, [T; D], usize) {
        let r = self.alias.sample(rng);
        let (state, action) = self.rows.row(r).unwrap_or(([T::ZERO; D], 0));
        (r, state, action)
    }

    /// The rows.
    pub fn rows(&self) -> &RowSet<'a, T, D> {
        &self.rows
    }

    /// The alias table.
    pub fn alias(&self) -> &AliasTable<'a, T> {
        &self.alias
    }
}
