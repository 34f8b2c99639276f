//! The uniform grid of cells that discretises a continuous `D`-dimensional state space for
//! tabular FQI.

use crate::error::ensure_finite;
use crate::error::{Error, Result};
use crate::float::Real;

/// A box `[lower, upper]` in `D` dimensions cut into `cells[0] × … × cells[D−1]` equal
/// cells; cell `(i₀, i₁, …)` has index `i₀ + cells[0]·(i₁ + cells[1]·(i₂ + …))` (the first
/// axis fastest).
///
/// A state is mapped to the cell that contains it; the upper border belongs to the last
/// cell, and states outside the box are clamped into the nearest border cell (the box is
/// meant to be the plant's state space, so this only matters for foreign data). Size:
/// `2D` scalars and `D` words.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CellGrid<T, const D: usize> {
    lower: [T; D],
    upper: [T; D],
    cells: [usize; D],
}

impl<T: Real, const D: usize> CellGrid<T, D> {
    /// A grid of `cells[0] × … × cells[D−1]` cells over the box `[lower, upper]`.
    ///
    /// Errors: non-finite bounds ([`Error::NonFinite`] naming `lower` or `upper`),
    /// `lower ≥ upper` on an axis or a zero cell count ([`Error::InvalidParameter`]), more
    /// than `u32::MAX − 1` cells ([`Error::CapacityExceeded`]). `D = 0` does not compile.
    pub fn new(lower: [T; D], upper: [T; D], cells: [usize; D]) -> Result<Self> {
        const { assert!(D > 0, "a cell grid needs at least one dimension") };
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
        match cells.iter().try_fold(1usize, |n, &c| n.checked_mul(c)) {
            Some(n) if n <= limit => {}
            _ => return Err(Error::CapacityExceeded { capacity: limit }),
        }
        Ok(Self {
            lower,
            upper,
            cells,
        })
    }

    /// `n` cells on every axis over the cube `[lower, upper]^D` (Puddle World: `[0, 10]²`).
    ///
    /// Errors: as [`CellGrid::new`].
    pub fn cube(lower: T, upper: T, n: usize) -> Result<Self> {
        Self::new([lower; D], [upper; D], [n; D])
    }

    /// Number of cells along each axis.
    pub fn cells(&self) -> [usize; D] {
        self.cells
    }

    /// Total number of cells.
    pub fn len(&self) -> usize {
        // Checked at construction to stay below u32::MAX.
        self.cells.iter().product()
    }

    /// `false`: a grid has at least one cell.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Lower corner of the box.
    pub fn lower(&self) -> [T; D] {
        self.lower
    }

    /// Upper corner of the box.
    pub fn upper(&self) -> [T; D] {
        self.upper
    }

    /// Index of the cell containing `state` (clamped into the box).
    ///
    /// Errors: a non-finite coordinate ([`Error::NonFinite`] naming `state`).
    pub fn cell_of(&self, state: [T; D]) -> Result<usize> {
        crate::error::ensure_all_finite(&state, "state")?;
        Ok(self.cell_of_finite(state))
    }

    /// [`CellGrid::cell_of`] for a state known to be finite.
    pub(crate) fn cell_of_finite(&self, state: [T; D]) -> usize {
        let mut index = 0;
        let mut stride = 1;
        for (((&x, &lo), &hi), &n) in state
            .iter()
            .zip(&self.lower)
            .zip(&self.upper)
            .zip(&self.cells)
        {
            index += axis_index(x, lo, hi, n) * stride;
            stride *= n;
        }
        index
    }

    /// The coordinates `(i₀, i₁, …)` of cell `cell`; `None` out of range.
    pub fn coordinates(&self, cell: usize) -> Option<[usize; D]> {
        if cell >= self.len() {
            return None;
        }
        let mut rest = cell;
        let mut out = [0; D];
        for (o, &n) in out.iter_mut().zip(&self.cells) {
            *o = rest.checked_rem(n)?;
            rest = rest.checked_div(n)?;
        }
        Some(out)
    }

    /// The centre of cell `cell`; `None` out of range.
    pub fn center(&self, cell: usize) -> Option<[T; D]> {
        let coordinates = self.coordinates(cell)?;
        let half = T::from_f64(0.5);
        let mut out = self.lower;
        for ((((o, &k), &lo), &hi), &n) in out
            .iter_mut()
            .zip(&coordinates)
            .zip(&self.lower)
            .zip(&self.upper)
            .zip(&self.cells)
        {
            *o = lo + (hi - lo) * (T::from_usize(k) + half) / T::from_usize(n);
        }
        Some(out)
    }
}

/// The index of the cell of `[lo, hi]` cut into `n ≥ 1` cells that contains `x`, clamped.
fn axis_index<T: Real>(x: T, lo: T, hi: T, n: usize) -> usize {
    let t = (x - lo) / (hi - lo) * T::from_usize(n);
    // `as` truncates towards zero and saturates: ⌊t⌋ for t ≥ 0; 0 for t < 0 and NaN
    // (as ⌊t⌋ would give after saturating); usize::MAX when huge, then clamp. So no
    // `floor` is needed (libm's is software, and this runs twice per sample per sweep).
    // In `T` itself: the same integer as through `f64` (widening is exact), without the
    // Cortex-M4F's software `f64` (a conversion and two comparisons per call).
    let i = t.to_usize_saturating();
    i.min(n.saturating_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_centres_and_borders() {
        let g = CellGrid::<f64, 2>::cube(0.0f64, 10.0, 21).unwrap();
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
        let g = CellGrid::<f32, 2>::cube(-1.0f32, 3.0, 8).unwrap();
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
        assert!(CellGrid::<f32, 2>::cube(0.0f32, 0.0, 3).is_err());
        assert!(CellGrid::<f32, 2>::cube(0.0f32, 1.0, 0).is_err());
        assert!(CellGrid::<f32, 2>::cube(f32::NAN, 1.0, 2).is_err());
        assert!(CellGrid::new([0.0f32, 0.0], [1.0, 1.0], [usize::MAX, 2]).is_err());
        let g = CellGrid::new([0.0f32, -1.0], [4.0, 1.0], [4, 2]).unwrap();
        assert_eq!(g.cell_of([3.5, 0.5]).unwrap(), 3 + 4);
    }
}
