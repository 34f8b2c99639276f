//! Score tables (spec §11): where do the sources disagree, and so where is a target query
//! worth its price?
//!
//! A score table is a list of state-action rows. For each row and each source `j` a
//! [`SourceModel`] gives a value triple `(ρʲ_r, ρʲ_x, ρʲ_y)` (mean reward, mean next x,
//! mean next y), and the row's scores are the population variances over the sources
//! (division by `m`): `V_r`, `V_x`, `V_y`, and their sum.
//!
//! - **Row sets** ([`RowSet`], §11.1): a grid of points with spacing `(dx, dy)`, both borders
//!   included, times every action ("grid mode"); the `(s, a)` of every source record, source
//!   by source, duplicates kept ("source-data mode"); or grid rows followed by source rows
//!   ("both").
//! - **Value sources** ([`SourceModel`]): the sources' noise-free mean functions give the
//!   *oracle* table (implemented for [`PuddleWorld`]); the posterior means of one GP per
//!   source and output give the *realistic* table ([`GpSourceModel`]).
//! - **Sampling** (§11.3): [`ScoreTable::sampler`] builds an [`AliasTable`] on one column
//!   (the thesis uses `V_r`), so a budget of `n` rows is drawn with replacement in O(1) per
//!   draw; a column that sums to 0 is sampled uniformly **\[spec CHOICE\]**.
//!
//! The values live in caller storage, one [`Scores`] per row (3 `T`: 12 bytes in `f32`; the
//! sum column is computed on read), so the same code fills the harness's 40 804-row table
//! and a coarse one on a microcontroller. Grid rows are not stored at all: a row index maps
//! to its `(s, a)` arithmetically.
//!
//! Variances are computed on values shifted by the first source's value, so a row where all
//! sources agree exactly has score exactly 0 (and the shift keeps the computation accurate
//! when the values are large and close).

use crate::alias::{AliasEntry, AliasTable};
use crate::dataset::{INPUT_DIM, input};
use crate::env::{PuddleWorld, Transition};
use crate::error::ensure_finite;
use crate::gp::Gp;
use crate::{Error, Real, Result};
use rand_core::Rng;

/// What a source says about a state-action pair: `(ρ_r, ρ_x, ρ_y)`, the (estimated) mean
/// reward and mean next state.
pub trait SourceModel<T: Real> {
    /// The value triple at `(state, action)`.
    ///
    /// Errors: whatever the model reports for an invalid state or action.
    fn predict(&self, state: [T; 2], action: usize) -> Result<[T; 3]>;
}

/// The oracle: the noise-free model functions r̄(s) and s̄′(s, a) of spec §2.4.
impl<T: Real> SourceModel<T> for PuddleWorld<T> {
    fn predict(&self, state: [T; 2], action: usize) -> Result<[T; 3]> {
        let [x, y] = self.mean_next_state(state, action)?;
        Ok([self.mean_reward(state)?, x, y])
    }
}

/// The realistic model of one source (§11.2): the posterior means of GPs fitted on that
/// source's records only, at `z = (s_x, s_y, a)`.
///
/// The next-state GPs are optional: without them `ρ_x = ρ_y = 0`, so `V_x = V_y = 0`, which
/// saves two GP fits per source when only `V_r` drives sampling (the thesis's choice).
/// Borrows the GPs; size: 3 pointers.
#[derive(Debug, Clone, Copy)]
pub struct GpSourceModel<'g, T, const N: usize> {
    reward: &'g Gp<T, N, INPUT_DIM>,
    next_state: Option<[&'g Gp<T, N, INPUT_DIM>; 2]>,
}

impl<'g, T: Real, const N: usize> GpSourceModel<'g, T, N> {
    /// A model from the source's reward GP and, optionally, its next-x and next-y GPs.
    pub fn new(
        reward: &'g Gp<T, N, INPUT_DIM>,
        next_state: Option<[&'g Gp<T, N, INPUT_DIM>; 2]>,
    ) -> Self {
        Self { reward, next_state }
    }
}

impl<T: Real, const N: usize> SourceModel<T> for GpSourceModel<'_, T, N> {
    fn predict(&self, state: [T; 2], action: usize) -> Result<[T; 3]> {
        let z = input(state, action);
        let r = self.reward.predict(&z)?.mean;
        let (x, y) = match self.next_state {
            Some([gx, gy]) => (gx.predict(&z)?.mean, gy.predict(&z)?.mean),
            None => (T::ZERO, T::ZERO),
        };
        Ok([r, x, y])
    }
}

/// A grid of points `lower + (i·dx, j·dy)` for `i < points[0]`, `j < points[1]` (§11.1).
///
/// The coordinates are computed as spacing × integer, never accumulated. Size: 4 `T` and
/// 2 `usize`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PointGrid<T> {
    lower: [T; 2],
    spacing: [T; 2],
    points: [usize; 2],
}

impl<T: Real> PointGrid<T> {
    /// `points[0] × points[1]` points from `lower` with spacing `spacing`.
    ///
    /// Errors: non-finite values ([`Error::NonFinite`] naming `lower` or `spacing`), a
    /// non-positive spacing, zero points or a last point that overflows `T`
    /// ([`Error::InvalidParameter`]), more than `usize::MAX` points
    /// ([`Error::CapacityExceeded`]).
    pub fn new(lower: [T; 2], spacing: [T; 2], points: [usize; 2]) -> Result<Self> {
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
        points[0]
            .checked_mul(points[1])
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

    /// The Puddle World grid of the thesis for spacing `d` on both axes: points
    /// `0, d, 2d, …` up to 10 inclusive (`round(10/d) + 1` per axis; `d = 0.1` gives
    /// 101 × 101).
    ///
    /// Errors: a non-finite or non-positive `d`, or a `d` that does not divide 10 (to
    /// within 10⁻⁶ relative), so the last point would not be 10
    /// ([`Error::InvalidParameter`] `spacing`).
    pub fn puddle(d: T) -> Result<Self> {
        ensure_finite(d, "spacing")?;
        if d <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "spacing",
            });
        }
        let steps = 10.0 / d.to_f64();
        let rounded = libm::round(steps);
        if !(1.0..=1e9).contains(&rounded) || libm::fabs(steps - rounded) > 1e-6 * rounded {
            return Err(Error::InvalidParameter {
                parameter: "spacing",
            });
        }
        let n = rounded as usize + 1;
        Self::new([T::ZERO; 2], [d; 2], [n, n])
    }

    /// Number of points along each axis.
    pub fn points(&self) -> [usize; 2] {
        self.points
    }

    /// Total number of points.
    pub fn len(&self) -> usize {
        self.points[0] * self.points[1]
    }

    /// `false`: a grid has at least one point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The spacing `(dx, dy)`.
    pub fn spacing(&self) -> [T; 2] {
        self.spacing
    }

    /// Point `p = i + points[0]·j`; `None` out of range.
    pub fn point(&self, p: usize) -> Option<[T; 2]> {
        if p >= self.len() {
            return None;
        }
        let i = p.checked_rem(self.points[0])?;
        let j = p.checked_div(self.points[0])?;
        Some([
            self.lower[0] + self.spacing[0] * T::from_usize(i),
            self.lower[1] + self.spacing[1] * T::from_usize(j),
        ])
    }
}

/// The rows of a score table (§11.1).
///
/// Grid rows come first: row `r < grid.len()·actions` is point `r / actions` with action
/// `r % actions` (**\[CHOICE\]**: points in the order of [`PointGrid::point`], actions
/// fastest). Source rows follow, source by source, record by record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSet<'a, T> {
    grid: Option<(PointGrid<T>, usize)>,
    sources: &'a [&'a [Transition<[T; 2], T>]],
}

impl<'a, T: Real> RowSet<'a, T> {
    /// Grid mode: every point of `grid` with every action `0..actions`.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]), a row count overflowing
    /// `usize` ([`Error::CapacityExceeded`]).
    pub fn grid(grid: PointGrid<T>, actions: usize) -> Result<Self> {
        Self::build(Some((grid, actions)), &[])
    }

    /// Source-data mode: the `(s, a)` of every record of every source, in order.
    ///
    /// Errors: no records at all ([`Error::EmptyData`]); a record whose state is not
    /// finite ([`Error::NonFinite`] naming `state`).
    pub fn source_data(sources: &'a [&'a [Transition<[T; 2], T>]]) -> Result<Self> {
        Self::build(None, sources)
    }

    /// Both: the grid rows followed by the source rows.
    ///
    /// Errors: those of [`RowSet::grid`]; a record whose state is not finite
    /// ([`Error::NonFinite`] naming `state`).
    pub fn both(
        grid: PointGrid<T>,
        actions: usize,
        sources: &'a [&'a [Transition<[T; 2], T>]],
    ) -> Result<Self> {
        Self::build(Some((grid, actions)), sources)
    }

    fn build(
        grid: Option<(PointGrid<T>, usize)>,
        sources: &'a [&'a [Transition<[T; 2], T>]],
    ) -> Result<Self> {
        if let Some((_, 0)) = grid {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        // Rows are handed out as query points: a non-finite record state is refused here.
        for record in sources.iter().flat_map(|s| s.iter()) {
            crate::error::ensure_all_finite(&record.state, "state")?;
        }
        let rows = Self { grid, sources };
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
            .try_fold(grid, |n, s| n.checked_add(s.len()))
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.checked_len().unwrap_or(usize::MAX)
    }

    /// `false`: a row set has at least one row.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row `r` as `(state, action)`; `None` out of range. O(1) for grid rows, O(m) for
    /// source rows.
    pub fn row(&self, r: usize) -> Option<([T; 2], usize)> {
        let grid_rows = self.grid_rows();
        if r < grid_rows {
            let (grid, actions) = self.grid?;
            return Some((
                grid.point(r.checked_div(actions)?)?,
                r.checked_rem(actions)?,
            ));
        }
        let mut k = r - grid_rows;
        for source in self.sources {
            match source.get(k) {
                Some(t) => return Some((t.state, t.action)),
                None => k -= source.len(),
            }
        }
        None
    }

    /// Every row in order (O(1) per row).
    pub fn iter(&self) -> impl Iterator<Item = ([T; 2], usize)> + '_ {
        let grid = self.grid.into_iter().flat_map(|(g, a)| {
            (0..g.len()).flat_map(move |p| {
                let s = g.point(p).unwrap_or([T::ZERO; 2]);
                (0..a).map(move |action| (s, action))
            })
        });
        let sources = self
            .sources
            .iter()
            .flat_map(|s| s.iter().map(|t| (t.state, t.action)));
        grid.chain(sources)
    }
}

/// The scores of one row: population variances over the sources of the mean reward and of
/// each mean next-state coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scores<T> {
    /// `V_r`: variance of the sources' mean rewards.
    pub reward: T,
    /// `V_x`: variance of the sources' mean next x.
    pub next_x: T,
    /// `V_y`: variance of the sources' mean next y.
    pub next_y: T,
}

impl<T: Real> Scores<T> {
    /// All scores 0; `const`, for storage in a `static`.
    pub const ZERO: Self = Self {
        reward: T::ZERO,
        next_x: T::ZERO,
        next_y: T::ZERO,
    };

    /// `V_r + V_x + V_y`, the table's fourth column.
    pub fn total(&self) -> T {
        self.reward + self.next_x + self.next_y
    }

    /// The value of `column`.
    pub fn get(&self, column: ScoreColumn) -> T {
        match column {
            ScoreColumn::Reward => self.reward,
            ScoreColumn::NextX => self.next_x,
            ScoreColumn::NextY => self.next_y,
            ScoreColumn::Total => self.total(),
        }
    }
}

/// A column of the score table, e.g. the one that drives sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScoreColumn {
    /// `V_r` (the thesis's choice, §11.3).
    Reward,
    /// `V_x`.
    NextX,
    /// `V_y`.
    NextY,
    /// `V_r + V_x + V_y`.
    Total,
}

/// One row of a table: its state-action pair and scores.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScoreRow<T> {
    /// The row's state.
    pub state: [T; 2],
    /// The row's action.
    pub action: usize,
    /// The row's scores.
    pub scores: Scores<T>,
}

/// A computed score table: rows and their scores, in caller storage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoreTable<'a, T> {
    rows: RowSet<'a, T>,
    values: &'a [Scores<T>],
}

impl<'a, T: Real> ScoreTable<'a, T> {
    /// Computes the scores of every row of `rows` from the `sources`' value triples into
    /// the first `rows.len()` entries of `storage`.
    ///
    /// Cost: `rows.len() · m` model evaluations. Errors: no sources
    /// ([`Error::EmptyData`]); `storage` shorter than the row count
    /// ([`Error::CapacityExceeded`] with its length), checked before anything is computed;
    /// the first error of a model (e.g. a state outside its domain) or a non-finite value
    /// triple ([`Error::NonFinite`] naming `source value`); finite values whose variance
    /// overflows `T` ([`Error::InvalidParameter`] naming `source value`). On error the
    /// storage's contents are unspecified.
    pub fn compute<S: SourceModel<T>>(
        rows: RowSet<'a, T>,
        sources: &[S],
        storage: &'a mut [Scores<T>],
    ) -> Result<Self> {
        if sources.is_empty() {
            return Err(Error::EmptyData);
        }
        let n = rows.len();
        if storage.len() < n {
            return Err(Error::CapacityExceeded {
                capacity: storage.len(),
            });
        }
        let capacity = storage.len();
        let values = storage
            .get_mut(..n)
            .ok_or(Error::CapacityExceeded { capacity })?;
        let m = T::from_usize(sources.len());
        for (slot, (state, action)) in values.iter_mut().zip(rows.iter()) {
            // Shifted two-pass variance: d_j = ρ_j − ρ_1, Var = mean(d²) − mean(d)².
            let mut first = [T::ZERO; 3];
            let mut sum = [T::ZERO; 3];
            let mut sum_sq = [T::ZERO; 3];
            for (j, source) in sources.iter().enumerate() {
                let rho = source.predict(state, action)?;
                crate::error::ensure_all_finite(&rho, "source value")?;
                if j == 0 {
                    first = rho;
                }
                for ((s, q), (&r, &f)) in sum
                    .iter_mut()
                    .zip(sum_sq.iter_mut())
                    .zip(rho.iter().zip(&first))
                {
                    let d = r - f;
                    *s += d;
                    *q += d * d;
                }
            }
            let var = |k: usize| {
                let s = sum.get(k).copied().unwrap_or(T::ZERO);
                let q = sum_sq.get(k).copied().unwrap_or(T::ZERO);
                let mean = s / m;
                (q / m - mean * mean).max(T::ZERO)
            };
            let scores = Scores {
                reward: var(0),
                next_x: var(1),
                next_y: var(2),
            };
            // Finite values so far apart that their variance (or the sum column) overflows.
            if !scores.total().is_finite() {
                return Err(Error::InvalidParameter {
                    parameter: "source value",
                });
            }
            *slot = scores;
        }
        Ok(Self { rows, values })
    }

    /// A table from scores computed earlier (e.g. once per experiment and shared by all
    /// runs, or loaded from a file): the first `rows.len()` entries of `values`.
    ///
    /// Errors: `values` shorter than the row count ([`Error::CapacityExceeded`] with its
    /// length); a non-finite score ([`Error::NonFinite`] `scores`) or a negative one
    /// ([`Error::InvalidParameter`] `scores`).
    pub fn from_parts(rows: RowSet<'a, T>, values: &'a [Scores<T>]) -> Result<Self> {
        let values = values.get(..rows.len()).ok_or(Error::CapacityExceeded {
            capacity: values.len(),
        })?;
        for v in values {
            for x in [v.reward, v.next_x, v.next_y] {
                ensure_finite(x, "scores")?;
                if x < T::ZERO {
                    return Err(Error::InvalidParameter {
                        parameter: "scores",
                    });
                }
            }
        }
        Ok(Self { rows, values })
    }

    /// The rows.
    pub fn rows(&self) -> &RowSet<'a, T> {
        &self.rows
    }

    /// The scores, row by row.
    pub fn values(&self) -> &'a [Scores<T>] {
        self.values
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// `false`: a computed table has at least one row.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Row `r`; `None` out of range.
    pub fn row(&self, r: usize) -> Option<ScoreRow<T>> {
        let (state, action) = self.rows.row(r)?;
        let scores = *self.values.get(r)?;
        Some(ScoreRow {
            state,
            action,
            scores,
        })
    }

    /// The sampling distribution of §11.3 on `column`: `P(row) = V(row) / Σ V`, or uniform
    /// when the column sums to 0. The alias table is built in the first `len()` entries of
    /// `storage` (8 bytes per row in `f32`).
    ///
    /// Errors: `storage` too short ([`Error::CapacityExceeded`]).
    pub fn sampler<'s>(
        &self,
        column: ScoreColumn,
        storage: &'s mut [AliasEntry<T>],
    ) -> Result<RowSampler<'s, T>>
    where
        'a: 's,
    {
        let weights = self.values.iter().map(|v| v.get(column));
        let all_zero = self.values.iter().all(|v| v.get(column) <= T::ZERO);
        let alias = if all_zero {
            AliasTable::build(self.values.iter().map(|_| T::ONE), storage)?
        } else {
            AliasTable::build(weights, storage)?
        };
        Ok(RowSampler {
            rows: self.rows,
            alias,
        })
    }
}

/// Draws rows of a score table with replacement, O(1) per draw (§12 step 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSampler<'a, T> {
    rows: RowSet<'a, T>,
    alias: AliasTable<'a, T>,
}

impl<'a, T: Real> RowSampler<'a, T> {
    /// Draws one row and returns its index, state and action; consumes one `u64`.
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> (usize, [T; 2], usize) {
        let r = self.alias.sample(rng);
        let (state, action) = self.rows.row(r).unwrap_or(([T::ZERO; 2], 0));
        (r, state, action)
    }

    /// The rows.
    pub fn rows(&self) -> &RowSet<'a, T> {
        &self.rows
    }

    /// The alias table.
    pub fn alias(&self) -> &AliasTable<'a, T> {
        &self.alias
    }
}

#[cfg(test)]
mod tests;
