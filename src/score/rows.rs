//! Candidate sets (§11.1): the state-action rows a score table scores and a query rule
//! draws from, borrowed, never copied.

use super::PointGrid;
use crate::error::ensure_all_finite;
use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::Transition;

/// The rows of a score table (§11.1): the candidate state-action pairs.
///
/// Grid rows come first: row `r < grid.len()·actions` is point `r / actions` with action
/// `r % actions` (**\[CHOICE\]**: points in the order of [`PointGrid::point`], actions
/// fastest). Explicit pairs follow in the caller's order, then source rows, source by
/// source, record by record. Nothing is copied: the pairs and records are borrowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSet<'a, T, const D: usize> {
    grid: Option<(PointGrid<T, D>, usize)>,
    pairs: &'a [([T; D], usize)],
    sources: &'a [&'a [Transition<[T; D], T>]],
}

impl<'a, T: Real, const D: usize> RowSet<'a, T, D> {
    /// Grid mode: every point of `grid` with every action `0..actions`.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]), a row count overflowing
    /// `usize` ([`Error::CapacityExceeded`]).
    pub fn grid(grid: PointGrid<T, D>, actions: usize) -> Result<Self> {
        Self::new(Some((grid, actions)), &[], &[])
    }

    /// The caller's own candidate pairs `(state, action)`, in order.
    ///
    /// Errors: no pairs ([`Error::EmptyData`]); a state that is not finite
    /// ([`Error::NonFinite`] naming `state`).
    pub fn pairs(pairs: &'a [([T; D], usize)]) -> Result<Self> {
        Self::new(None, pairs, &[])
    }

    /// Source-data mode: the `(s, a)` of every record of every source, in order.
    ///
    /// Errors: no records at all ([`Error::EmptyData`]); a record whose state is not
    /// finite ([`Error::NonFinite`] naming `state`).
    pub fn source_data(sources: &'a [&'a [Transition<[T; D], T>]]) -> Result<Self> {
        Self::new(None, &[], sources)
    }

    /// Both: the grid rows followed by the source rows.
    ///
    /// Errors: those of [`RowSet::grid`]; a record whose state is not finite
    /// ([`Error::NonFinite`] naming `state`).
    pub fn both(
        grid: PointGrid<T, D>,
        actions: usize,
        sources: &'a [&'a [Transition<[T; D], T>]],
    ) -> Result<Self> {
        Self::new(Some((grid, actions)), &[], sources)
    }

    /// Any combination, in this row order: an optional grid with its action count, explicit
    /// pairs, source records.
    ///
    /// Errors: a grid with 0 actions ([`Error::InvalidParameter`] `actions`); a pair or
    /// record whose state is not finite ([`Error::NonFinite`] `state`); no rows at all
    /// ([`Error::EmptyData`]); more than `usize::MAX` rows ([`Error::CapacityExceeded`]).
    pub fn new(
        grid: Option<(PointGrid<T, D>, usize)>,
        pairs: &'a [([T; D], usize)],
        sources: &'a [&'a [Transition<[T; D], T>]],
    ) -> Result<Self> {
        if let Some((_, 0)) = grid {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        // Rows are handed out as query points: a non-finite state is refused here.
        for (state, _) in pairs {
            ensure_all_finite(state, "state")?;
        }
        for record in sources.iter().flat_map(|s| s.iter()) {
            ensure_all_finite(&record.state, "state")?;
        }
        let rows = Self {
            grid,
            pairs,
            sources,
        };
        match rows.checked_len() {
            None => Err(Error::CapacityExceeded {
                capacity: usize::MAX,
            }),
            Some(0) => Err(Error::EmptyData),
            Some(_) => Ok(rows),
        }
    }

    fn grid_rows(&self) -> usize {
        self.grid.map_or(0, |(g, a)| g.len().saturating_mul(a))
    }

    fn checked_len(&self) -> Option<usize> {
        let grid = match self.grid {
            Some((g, a)) => g.len().checked_mul(a)?,
            None => 0,
        };
        self.sources
            .iter()
            .try_fold(grid.checked_add(self.pairs.len())?, |n, s| {
                n.checked_add(s.len())
            })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.checked_len().unwrap_or(usize::MAX)
    }

    /// `false`: a row set has at least one row.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row `r` as `(state, action)`; `None` out of range. O(1) for grid rows and pairs,
    /// O(m) for source rows.
    pub fn row(&self, r: usize) -> Option<([T; D], usize)> {
        let grid_rows = self.grid_rows();
        if r < grid_rows {
            let (grid, actions) = self.grid?;
            return Some((
                grid.point(r.checked_div(actions)?)?,
                r.checked_rem(actions)?,
            ));
        }
        let mut k = r - grid_rows;
        if let Some(&pair) = self.pairs.get(k) {
            return Some(pair);
        }
        k -= self.pairs.len();
        for source in self.sources {
            match source.get(k) {
                Some(t) => return Some((t.state, t.action)),
                None => k -= source.len(),
            }
        }
        None
    }

    /// Every row in order (O(1) per row).
    pub fn iter(&self) -> impl Iterator<Item = ([T; D], usize)> + '_ {
        let grid = self.grid.into_iter().flat_map(|(g, a)| {
            (0..g.len()).flat_map(move |p| {
                let s = g.point(p).unwrap_or([T::ZERO; D]);
                (0..a).map(move |action| (s, action))
            })
        });
        let sources = self
            .sources
            .iter()
            .flat_map(|s| s.iter().map(|t| (t.state, t.action)));
        grid.chain(self.pairs.iter().copied()).chain(sources)
    }
}
