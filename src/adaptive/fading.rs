//! Source weights that fade where the target has spoken: the sources act as a prior whose
//! strength in a region is at most a fixed number of pseudo-records once the target has
//! records there, so the target's own samples outweigh any number of source records as they
//! grow (`κ` pseudo-records against the target's `n`: the sources' share `κ/(κ + n)`).
//!
//! Regions are the cells of a grid of [`Fading::cells`] per state coordinate (over the
//! learner's state bounds) times the actions. After the reward weights of a re-plan, for
//! every cell with `n ≥ 1` target records whose source records weigh `W > κ` in all, each
//! of those source records' weights is scaled by `κ / W`; elsewhere the weights stay. It
//! works on the per-record weights handed to the approximator, so it is the same for every
//! approximator.
//!
//! The cells' sums live in a caller's table of [`FadeCell`]s
//! ([`crate::adaptive::AdaptiveAwfqi::with_fading`]); a table shorter than the grid folds cells
//! together (cell index modulo its length), which merges regions but stays correct in
//! kind. `cells^D × A` entries of 8 bytes (`f32`) make it exact.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::Transition;

/// The fading's settings (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Fading<T> {
    /// `κ`: the most the sources weigh in a cell where the target has records, in records.
    pub pseudo_records: T,
    /// Cells per state coordinate, ≥ 1.
    pub cells: usize,
}

impl<T: Real> Fading<T> {
    /// Checks the settings.
    ///
    /// Errors: `cells` 0 ([`Error::InvalidParameter`] `cells`); `pseudo_records` not finite
    /// or negative ([`Error::OutOfRange`] `pseudo_records`).
    pub fn validate(self) -> Result<Self> {
        if self.cells == 0 {
            return Err(Error::InvalidParameter { parameter: "cells" });
        }
        if !self.pseudo_records.is_finite() || self.pseudo_records < T::ZERO {
            return Err(Error::OutOfRange {
                parameter: "pseudo_records",
            });
        }
        Ok(self)
    }
}

/// One region's sums: the target's records and the source records' total weight.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FadeCell<T> {
    /// Target records in the region.
    pub target: T,
    /// Total weight of the source records in the region.
    pub source: T,
}

impl<T: Real> FadeCell<T> {
    /// An empty cell.
    pub const EMPTY: Self = Self {
        target: T::ZERO,
        source: T::ZERO,
    };
}

/// The table slot of `(state, action)`: the action, then the grid cell of each coordinate
/// (`cells` per coordinate over `bounds`), in mixed radix, modulo the table's length
/// `len ≥ 1`.
fn slot<T: Real, const D: usize>(
    state: &[T; D],
    action: usize,
    bounds: &[(T, T); D],
    cells: usize,
    len: usize,
) -> usize {
    let n = cells as u64;
    let mut index = action as u64;
    for (&x, &(lo, hi)) in state.iter().zip(bounds) {
        let u = (x - lo) / (hi - lo) * T::from_usize(cells);
        let c = if u.is_finite() && u > T::ZERO {
            (u.to_usize_saturating() as u64).min(n.saturating_sub(1))
        } else {
            0
        };
        index = index.wrapping_mul(n).wrapping_add(c);
    }
    (index % len.max(1) as u64) as usize
}

/// Fades `weights` (one per record of `sources`, source after source) where `target` has
/// records (module docs), using `table` for the cells' sums.
///
/// Errors: `table` empty ([`Error::CapacityExceeded`] 0);
/// `weights` shorter than the source records ([`Error::CapacityExceeded`]).
pub fn fade<'s, T: Real + 's, const D: usize>(
    fading: &Fading<T>,
    weights: &mut [T],
    sources: impl Iterator<Item = &'s [Transition<[T; D], T>]> + Clone,
    target: &[Transition<[T; D], T>],
    bounds: &[(T, T); D],
    table: &mut [FadeCell<T>],
) -> Result<()> {
    let len = table.len();
    if len == 0 {
        return Err(Error::CapacityExceeded { capacity: 0 });
    }
    let records: usize = sources.clone().map(<[_]>::len).sum();
    if weights.len() < records {
        return Err(Error::CapacityExceeded {
            capacity: weights.len(),
        });
    }
    table.fill(FadeCell::EMPTY);
    let at = |r: &Transition<[T; D], T>| slot(&r.state, r.action, bounds, fading.cells, len);
    for r in target {
        if let Some(c) = table.get_mut(at(r)) {
            c.target += T::ONE;
        }
    }
    let records = sources.flat_map(|s| s.iter());
    for (r, &w) in records.clone().zip(weights.iter()) {
        if let Some(c) = table.get_mut(at(r)) {
            c.source += w;
        }
    }
    let kappa = fading.pseudo_records;
    for (r, w) in records.zip(weights.iter_mut()) {
        if let Some(c) = table.get(at(r)) {
            if c.target > T::ZERO && c.source > kappa {
                *w *= kappa / c.source;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(x: f64, action: usize) -> Transition<[f64; 1], f64> {
        Transition {
            state: [x],
            action,
            reward: 0.0,
            next_state: [x],
            absorbing: false,
        }
    }

    #[test]
    fn where_the_target_has_records_the_sources_weigh_at_most_kappa() {
        // Two cells on [0, 1]: [0, 0.5) and [0.5, 1]. Source records: four in cell 0
        // (action 0), two in cell 1 (action 0), one in cell 0 with action 1.
        let a = [
            record(0.1, 0),
            record(0.2, 0),
            record(0.3, 0),
            record(0.6, 0),
        ];
        let b = [record(0.4, 0), record(0.9, 0), record(0.2, 1)];
        let mut w = [1.0, 0.5, 1.0, 2.0, 0.5, 2.0, 3.0];
        // The target answered in cell 0 with action 0, and with action 1 (weight 3 ≤ κ there).
        let target = [record(0.05, 0), record(0.45, 1)];
        let fading = Fading {
            pseudo_records: 1.5,
            cells: 2,
        }
        .validate()
        .unwrap();
        let mut table = [FadeCell::EMPTY; 4];
        let sources = [&a[..], &b[..]];
        fade(
            &fading,
            &mut w,
            sources.iter().copied(),
            &target,
            &[(0.0, 1.0)],
            &mut table,
        )
        .unwrap();
        // Cell 0, action 0: weights 1, 0.5, 1, 0.5 sum to 3 > 1.5: each halved.
        let want = [0.5, 0.25, 0.5, 2.0, 0.25, 2.0, 1.5];
        for (g, e) in w.iter().zip(want) {
            assert!((g - e).abs() < 1e-12, "{w:?}");
        }
        // The faded mass of cell 0, action 0 is κ.
        assert!((w[0] + w[1] + w[2] + w[4] - 1.5).abs() < 1e-12);
    }

    #[test]
    fn without_target_records_nothing_fades_and_bad_settings_are_named() {
        let a = [record(0.1, 0), record(0.2, 0)];
        let mut w = [1.0, 1.0];
        let fading = Fading {
            pseudo_records: 0.5,
            cells: 4,
        };
        let mut table = [FadeCell::EMPTY; 1];
        let sources = [&a[..]];
        fade(
            &fading,
            &mut w,
            sources.iter().copied(),
            &[],
            &[(0.0, 1.0)],
            &mut table,
        )
        .unwrap();
        assert_eq!(w, [1.0, 1.0]);
        assert_eq!(
            fade(
                &fading,
                &mut w,
                sources.iter().copied(),
                &[],
                &[(0.0, 1.0)],
                &mut []
            ),
            Err(Error::CapacityExceeded { capacity: 0 })
        );
        assert_eq!(
            Fading {
                pseudo_records: 1.0f64,
                cells: 0
            }
            .validate(),
            Err(Error::InvalidParameter { parameter: "cells" })
        );
        assert_eq!(
            Fading {
                pseudo_records: -1.0f64,
                cells: 2
            }
            .validate(),
            Err(Error::OutOfRange {
                parameter: "pseudo_records"
            })
        );
    }
}
