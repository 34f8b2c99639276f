//! Grids of points, the grid mode of a candidate set (§11.1).

use crate::error::{Error, Result};
use crate::error::{ensure_all_finite, ensure_finite};
use crate::float::Real;

/// A grid of points `lower + (i₀·spacing₀, i₁·spacing₁, …)` for `i_k < points[k]` (§11.1),
/// the first axis fastest.
///
/// The coordinates are computed as spacing × integer, never accumulated. Size: `2D` `T`
/// and `D` `usize`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PointGrid<T, const D: usize> {
    lower: [T; D],
    spacing: [T; D],
    points: [usize; D],
}

impl<T: Real, const D: usize> PointGrid<T, D> {
    /// `points[0] × … × points[D−1]` points from `lower` with spacing `spacing`.
    ///
    /// Errors: non-finite values ([`Error::NonFinite`] naming `lower` or `spacing`), a
    /// non-positive spacing, zero points or a last point that overflows `T`
    /// ([`Error::InvalidParameter`]), more than `usize::MAX` points
    /// ([`Error::CapacityExceeded`]). `D = 0` does not compile.
    pub fn new(lower: [T; D], spacing: [T; D], points: [usize; D]) -> Result<Self> {
        const { assert!(D > 0, "a point grid needs at least one dimension") };
        for (&lo, &d) in lower.iter().zip(&spacing) {
            ensure_finite(lo, "lower")?;
            ensure_finite(d, "spacing")?;
            if d <= T::ZERO {
                return Err(Error::InvalidParameter {
                    parameter: "spacing",
                });
            }
        }
        if points.contains(&0) {
            return Err(Error::InvalidParameter {
                parameter: "points",
            });
        }
        points
            .iter()
            .try_fold(1usize, |n, &p| n.checked_mul(p))
            .ok_or(Error::CapacityExceeded {
                capacity: usize::MAX,
            })?;
        // Every point must be finite: the last one along each axis is the largest.
        for ((&lo, &d), &n) in lower.iter().zip(&spacing).zip(&points) {
            if !(lo + d * T::from_usize(n - 1)).is_finite() {
                return Err(Error::InvalidParameter {
                    parameter: "spacing",
                });
            }
        }
        Ok(Self {
            lower,
            spacing,
            points,
        })
    }

    /// Points per axis of [`PointGrid::spanning`] over `[lower, upper]` with spacing `d`,
    /// `round((upper − lower)/d) + 1`, as a `const fn` so a capacity can be sized by it
    /// (`PointGrid::<f32, 2>::spanning_points(0.0, 10.0, 0.1)` is 101); 0 for a spacing or
    /// an extent that [`PointGrid::spanning`] refuses.
    pub const fn spanning_points(lower: f64, upper: f64, d: f64) -> usize {
        if !d.is_finite() || d <= 0.0 || !(upper - lower).is_finite() || upper <= lower {
            return 0;
        }
        let steps = (upper - lower) / d;
        if steps < 0.5 || steps > 1e9 {
            return 0;
        }
        let rounded = (steps + 0.5) as usize;
        let error = steps - rounded as f64;
        if error > 1e-6 * rounded as f64 || -error > 1e-6 * rounded as f64 {
            return 0;
        }
        rounded + 1
    }

    /// Rows of [`RowSet::grid`](super::RowSet::grid) over a grid of `points` per axis on each
    /// of `D` axes with `actions` actions, `points^D × actions`, as a `const fn` (the alias
    /// table's capacity of the thesis's AWFQI; `usize::MAX` on overflow).
    pub const fn rows(points: usize, actions: usize) -> usize {
        match points.checked_pow(D as u32) {
            Some(n) => n.saturating_mul(actions),
            None => usize::MAX,
        }
    }

    /// The grid with spacing `d` on every axis that spans the box `[lower, upper]`, both
    /// borders included: points `lower_k, lower_k + d, …` up to `upper_k`
    /// (`round((upper_k − lower_k)/d) + 1` per axis; Puddle World's `[0, 10]²` with
    /// `d = 0.1` gives 101 × 101).
    ///
    /// Errors: a non-finite bound ([`Error::NonFinite`] `lower` or `upper`); a non-finite
    /// ([`Error::NonFinite`]) or non-positive `d`, or a `d` that does not divide an axis's
    /// extent (to within 10⁻⁶ relative) so its last point would not be `upper_k`
    /// ([`Error::InvalidParameter`] `spacing`).
    pub fn spanning(lower: [T; D], upper: [T; D], d: T) -> Result<Self> {
        ensure_all_finite(&lower, "lower")?;
        ensure_all_finite(&upper, "upper")?;
        ensure_finite(d, "spacing")?;
        if d <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "spacing",
            });
        }
        let mut points = [0usize; D];
        for ((p, &lo), &hi) in points.iter_mut().zip(&lower).zip(&upper) {
            let steps = (hi.to_f64() - lo.to_f64()) / d.to_f64();
            let rounded = libm::round(steps);
            if !(1.0..=1e9).contains(&rounded) || libm::fabs(steps - rounded) > 1e-6 * rounded {
                return Err(Error::InvalidParameter {
                    parameter: "spacing",
                });
            }
            *p = rounded as usize + 1;
        }
        Self::new(lower, [d; D], points)
    }

    /// Number of points along each axis.
    pub fn points(&self) -> [usize; D] {
        self.points
    }

    /// Total number of points.
    pub fn len(&self) -> usize {
        // Checked at construction not to overflow.
        self.points.iter().product()
    }

    /// `false`: a grid has at least one point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The spacing along each axis.
    pub fn spacing(&self) -> [T; D] {
        self.spacing
    }

    /// Point `p = i₀ + points[0]·(i₁ + points[1]·(…))`; `None` out of range.
    pub fn point(&self, p: usize) -> Option<[T; D]> {
        if p >= self.len() {
            return None;
        }
        let mut rest = p;
        let mut out = self.lower;
        for ((o, &d), &n) in out.iter_mut().zip(&self.spacing).zip(&self.points) {
            let i = rest.checked_rem(n)?;
            rest = rest.checked_div(n)?;
            *o += d * T::from_usize(i);
        }
        Some(out)
    }
}
