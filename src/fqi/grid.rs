//! The uniform grid of cells that discretises a continuous 2-D state space for tabular FQI.

use crate::error::ensure_finite;
use crate::{Error, Real, Result};

/// A box `[lower, upper]` in 2-D cut into `cells[0] × cells[1]` equal cells; cell
/// `(i, j)` has index `i + cells[0]·j`.
///
/// A state is mapped to the cell that contains it; the upper border belongs to the last
/// cell, and states outside the box are clamped into the nearest border cell (the box is
/// the state space of Puddle World, so this only matters for foreign data). Size: 7 words.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CellGrid<T> {
    lower: [T; 2],
    upper: [T; 2],
    cells: [usize; 2],
}

impl<T: Real> CellGrid<T> {
    /// A grid of `cells[0] × cells[1]` cells over `[lower[0], upper[0]] × [lower[1], upper[1]]`.
    ///
    /// Errors: non-finite bounds ([`Error::NonFinite`] naming `lower` or `upper`),
    /// `lower ≥ upper` on an axis or a zero cell count ([`Error::InvalidParameter`]), more
    /// than `u32::MAX − 1` cells ([`Error::CapacityExceeded`]).
    pub fn new(lower: [T; 2], upper: [T; 2], cells: [usize; 2]) -> Result<Self> {
        for (&lo, &hi) in lower.iter().zip(&upper) {
            ensure_finite(lo, "lower")?;
            ensure_finite(hi, "upper")?;
            if lo >= hi || !(hi - lo).is_finite() {
                return Err(Error::InvalidParameter { parameter: "upper" });
            }
        }
        if cells.contains(&0) {
            return Err(Error::InvalidParameter { parameter: "cells" });
        }
        let limit = u32::MAX as usize - 1;
        match cells[0].checked_mul(cells[1]) {
            Some(n) if n <= limit => {}
            _ => return Err(Error::CapacityExceeded { capacity: limit }),
        }
        Ok(Self {
            lower,
            upper,
            cells,
        })
    }

    /// `n × n` cells over the square `[lower, upper]²` (Puddle World: `[0, 10]²`).
    ///
    /// Errors: as [`CellGrid::new`].
    pub fn square(lower: T, upper: T, n: usize) -> Result<Self> {
        Self::new([lower, lower], [upper, upper], [n, n])
    }

    /// Number of cells along each axis.
    pub fn cells(&self) -> [usize; 2] {
        self.cells
    }

    /// Total number of cells.
    pub fn len(&self) -> usize {
        self.cells[0] * self.cells[1]
    }

    /// `false`: a grid has at least one cell.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Lower corner of the box.
    pub fn lower(&self) -> [T; 2] {
        self.lower
    }

    /// Upper corner of the box.
    pub fn upper(&self) -> [T; 2] {
        self.upper
    }

    /// Index of the cell containing `state` (clamped into the box).
    ///
    /// Errors: a non-finite coordinate ([`Error::NonFinite`] naming `state`).
    pub fn cell_of(&self, state: [T; 2]) -> Result<usize> {
        ensure_finite(state[0], "state")?;
        ensure_finite(state[1], "state")?;
        Ok(self.cell_of_finite(state))
    }

    /// [`CellGrid::cell_of`] for a state known to be finite.
    pub(crate) fn cell_of_finite(&self, state: [T; 2]) -> usize {
        let ix = self.axis_index(state[0], 0);
        let iy = self.axis_index(state[1], 1);
        ix + self.cells[0] * iy
    }

    fn axis_index(&self, x: T, axis: usize) -> usize {
        let (lo, hi, n) = match axis {
            0 => (self.lower[0], self.upper[0], self.cells[0]),
            _ => (self.lower[1], self.upper[1], self.cells[1]),
        };
        let t = (x - lo) / (hi - lo) * T::from_usize(n);
        // `as` truncates towards zero and saturates: ⌊t⌋ for t ≥ 0; 0 for t < 0 and NaN
        // (as ⌊t⌋ would give after saturating); usize::MAX when huge, then clamp. So no
        // `floor` is needed (libm's is software, and this runs twice per sample per sweep).
        let i = t.to_f64() as usize;
        i.min(n - 1)
    }

    /// The `(i, j)` coordinates of cell `cell`; `None` out of range.
    pub fn coordinates(&self, cell: usize) -> Option<[usize; 2]> {
        let [nx, _] = self.cells;
        match (cell.checked_rem(nx), cell.checked_div(nx)) {
            (Some(i), Some(j)) if cell < self.len() => Some([i, j]),
            _ => None,
        }
    }

    /// The centre of cell `cell`; `None` out of range.
    pub fn center(&self, cell: usize) -> Option<[T; 2]> {
        let [i, j] = self.coordinates(cell)?;
        let half = T::from_f64(0.5);
        let at = |k: usize, lo: T, hi: T, n: usize| {
            lo + (hi - lo) * (T::from_usize(k) + half) / T::from_usize(n)
        };
        Some([
            at(i, self.lower[0], self.upper[0], self.cells[0]),
            at(j, self.lower[1], self.upper[1], self.cells[1]),
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_centres_and_borders() {
        let g = CellGrid::square(0.0f64, 10.0, 21).unwrap();
        assert_eq!(g.len(), 441);
        assert_eq!(g.cell_of([0.0, 0.0]).unwrap(), 0);
        // The upper border belongs to the last cell.
        assert_eq!(g.cell_of([10.0, 10.0]).unwrap(), 440);
        // Outside: clamped.
        assert_eq!(g.cell_of([-3.0, 12.0]).unwrap(), 21 * 20);
        // 10/21 = 0.476…: x = 0.5 lies in cell 1, y = 0.47 in cell 0.
        assert_eq!(g.cell_of([0.5, 0.47]).unwrap(), 1);
        for cell in [0, 1, 22, 440] {
            let c = g.center(cell).unwrap();
            assert_eq!(g.cell_of(c).unwrap(), cell);
        }
        let c = g.center(22).unwrap();
        assert!((c[0] - 1.5 * 10.0 / 21.0).abs() < 1e-12);
        assert!(g.center(441).is_none());
        assert_eq!(g.coordinates(43), Some([1, 2]));
        assert_eq!(
            g.cell_of([f64::NAN, 0.0]),
            Err(Error::NonFinite { parameter: "state" })
        );
    }

    #[test]
    fn cell_index_is_the_clamped_floor_everywhere() {
        // The index is computed by truncation; it must equal ⌊t⌋ clamped into 0..n for
        // states below, inside and above the box, at cell borders, and for huge values.
        let g = CellGrid::square(-1.0f32, 3.0, 8).unwrap();
        let expected = |x: f32| -> usize {
            let t = f64::from((x - -1.0) / 4.0 * 8.0).floor();
            t.clamp(0.0, 7.0) as usize
        };
        let edges = [
            -3e38f32,
            -1e6,
            -1.6,
            -1.5,
            -1.0 - 1e-7,
            -1.0,
            -0.5,
            3.0,
            3.5,
            1e30,
        ];
        let steps = (0..=80).map(|k| -1.0 + k as f32 * 0.05);
        for x in edges.into_iter().chain(steps) {
            let cell = g.cell_of([x, 0.0]).unwrap();
            assert_eq!(cell % 8, expected(x), "x = {x}");
        }
    }

    #[test]
    fn invalid_grids_are_rejected() {
        assert!(CellGrid::square(0.0f32, 0.0, 3).is_err());
        assert!(CellGrid::square(0.0f32, 1.0, 0).is_err());
        assert!(CellGrid::square(f32::NAN, 1.0, 2).is_err());
        assert!(CellGrid::new([0.0f32, 0.0], [1.0, 1.0], [usize::MAX, 2]).is_err());
        let g = CellGrid::new([0.0f32, -1.0], [4.0, 1.0], [4, 2]).unwrap();
        assert_eq!(g.cell_of([3.5, 0.5]).unwrap(), 3 + 4);
    }
}
