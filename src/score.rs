//! Score tables (spec §11): where do the sources disagree, and so where is a target query
//! worth its price?
//!
//! A score table is a list of state-action rows — a **candidate set** the caller chooses.
//! For each row and each source `j` a [`SourceModel`] gives the source's mean reward `ρʲ_r`
//! and mean next state `ρʲ_s′` (one value per state coordinate), and the row's scores are the
//! population variances over the sources (division by `m`): `V_r` and one `V_k` per
//! next-state coordinate, and their sum.
//!
//! - **Candidate sets** ([`RowSet`], §11.1): a grid of points (a [`PointGrid`], borders
//!   included) times every action ("grid mode"); explicit `(s, a)` pairs the caller lists;
//!   the `(s, a)` of every source record, source by source, duplicates kept ("source-data
//!   mode"); or a grid followed by source rows ("both"). Puddle World's thesis grids are
//!   [`crate::env::PuddleWorld::score_grid`].
//! - **Value sources** ([`SourceModel`]): the sources' noise-free mean functions give the
//!   *oracle* table (a plant's noise-free mean functions, e.g. Puddle World's); the posterior means
//!   of one GP per source and output give the *realistic* table ([`GpSourceModel`], or
//!   [`ScoreTable::realistic`] with a single GP in memory at a time).
//! - **Sampling** (§11.3): [`ScoreTable::sampler`] builds an [`AliasTable`] on one column
//!   (the thesis uses `V_r`), so a budget of `n` rows is drawn with replacement in O(1) per
//!   draw; a column that sums to 0 is sampled uniformly **\[spec CHOICE\]**.
//!
//! The values live in caller storage, one [`Scores`] per row (`D + 1` `T`: 12 bytes in `f32`
//! for a 2-D state; the sum column is computed on read), so the same code fills the
//! harness's 40 804-row table and a coarse one on a microcontroller. Grid rows are not
//! stored at all: a row index maps to its `(s, a)` arithmetically.
//!
//! Variances are computed on values shifted by the first source's value, so a row where all
//! sources agree exactly has score exactly 0 (and the shift keeps the computation accurate
//! when the values are large and close).

use crate::alias::{AliasEntry, AliasTable};
use crate::env::Transition;
use crate::error::{ensure_all_finite, ensure_finite};
use crate::gp::Gp;
use crate::record_gp::{GpTraining, InputDim, Output, SubsetRule, fit_gp, input};
use crate::{Error, Real, Result};
use rand_core::Rng;

/// What a source says about a state-action pair: its (estimated) mean reward and mean next
/// state.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SourceMeans<T, const D: usize> {
    /// `ρ_r`, the mean reward.
    pub reward: T,
    /// `ρ_s′`, the mean next state.
    pub next_state: [T; D],
}

/// A source task as the score table sees it: its mean reward and mean next state at any
/// state-action pair.
///
/// A plant whose noise-free mean functions are known implements it to give the *oracle*
/// table (Puddle World does, spec §2.4; the same means give §7.7's ideal weights);
/// [`GpSourceModel`] estimates them from a source's data (the *realistic* table).
pub trait SourceModel<T: Real, const D: usize> {
    /// The mean reward and next state at `(state, action)`.
    ///
    /// Errors: whatever the model reports for an invalid state or action.
    fn predict(&self, state: [T; D], action: usize) -> Result<SourceMeans<T, D>>;
}

/// The realistic model of one source (§11.2): the posterior means of GPs fitted on that
/// source's records only, at `z = (s, a)` (`I = D + 1`).
///
/// The next-state GPs are optional: without them `ρ_s′ = 0`, so the next-state scores are
/// 0, which saves `D` GP fits per source when only `V_r` drives sampling (the thesis's
/// choice). Borrows the GPs; size: `D + 2` pointers.
#[derive(Debug, Clone, Copy)]
pub struct GpSourceModel<'g, T, const N: usize, const D: usize, const I: usize> {
    reward: &'g Gp<T, N, I>,
    next_state: Option<[&'g Gp<T, N, I>; D]>,
}

impl<'g, T: Real, const N: usize, const D: usize, const I: usize> GpSourceModel<'g, T, N, D, I> {
    /// A model from the source's reward GP and, optionally, one GP per next-state
    /// coordinate.
    pub fn new(reward: &'g Gp<T, N, I>, next_state: Option<[&'g Gp<T, N, I>; D]>) -> Self {
        let () = InputDim::<D, I>::CHECK;
        Self { reward, next_state }
    }
}

impl<T: Real, const N: usize, const D: usize, const I: usize> SourceModel<T, D>
    for GpSourceModel<'_, T, N, D, I>
{
    fn predict(&self, state: [T; D], action: usize) -> Result<SourceMeans<T, D>> {
        let z = input(state, action);
        let reward = self.reward.predict(&z)?.mean;
        let mut next_state = [T::ZERO; D];
        if let Some(gps) = self.next_state {
            for (n, gp) in next_state.iter_mut().zip(gps) {
                *n = gp.predict(&z)?.mean;
            }
        }
        Ok(SourceMeans { reward, next_state })
    }
}

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

/// The scores of one row: population variances over the sources of the mean reward and of
/// each mean next-state coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scores<T, const D: usize> {
    /// `V_r`: variance of the sources' mean rewards.
    pub reward: T,
    /// `V_k`: variance of the sources' mean next-state coordinate `k`.
    pub next_state: [T; D],
}

impl<T: Real, const D: usize> Default for Scores<T, D> {
    fn default() -> Self {
        Self::ZERO
    }
}

impl<T: Real, const D: usize> Scores<T, D> {
    /// All scores 0; `const`, for storage in a `static`.
    pub const ZERO: Self = Self {
        reward: T::ZERO,
        next_state: [T::ZERO; D],
    };

    /// [`Scores::ZERO`] under the name every buffer element type of the crate shares
    /// (`Transition::EMPTY`, `Posterior::EMPTY`, `FqiEntry::EMPTY`, …).
    pub const EMPTY: Self = Self::ZERO;

    /// `V_r + Σ_k V_k`, the table's last column.
    pub fn total(&self) -> T {
        self.next_state.iter().fold(self.reward, |sum, &v| sum + v)
    }

    /// The value of `column`; `None` for a next-state coordinate `≥ D`.
    pub fn get(&self, column: ScoreColumn) -> Option<T> {
        match column {
            ScoreColumn::Reward => Some(self.reward),
            ScoreColumn::NextState(k) => self.next_state.get(k).copied(),
            ScoreColumn::Total => Some(self.total()),
        }
    }
}

/// A column of the score table, e.g. the one that drives sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScoreColumn {
    /// `V_r` (the thesis's choice, §11.3).
    Reward,
    /// `V_k`, next-state coordinate `k` (Puddle World: 0 is `V_x`, 1 is `V_y`).
    NextState(usize),
    /// `V_r + Σ_k V_k`.
    Total,
}

/// One row of a table: its state-action pair and scores.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScoreRow<T, const D: usize> {
    /// The row's state.
    pub state: [T; D],
    /// The row's action.
    pub action: usize,
    /// The row's scores.
    pub scores: Scores<T, D>,
}

/// Running sums of one row's shifted two-pass variance: `d_j = ρ_j − ρ_1`,
/// `Var = mean(d²) − mean(d)²`.
#[derive(Clone, Copy)]
struct ShiftedSums<T> {
    first: T,
    sum: T,
    sum_sq: T,
}

impl<T: Real> ShiftedSums<T> {
    /// The sums after the first source (whose shifted value is exactly 0).
    fn new(first: T) -> Self {
        Self {
            first,
            sum: T::ZERO,
            sum_sq: T::ZERO,
        }
    }

    fn add(&mut self, value: T) {
        let d = value - self.first;
        self.sum += d;
        self.sum_sq += d * d;
    }

    /// The population variance over `m` sources (rounding below 0 clipped).
    fn variance(&self, m: T) -> T {
        let mean = self.sum / m;
        (self.sum_sq / m - mean * mean).max(T::ZERO)
    }
}

/// Finite values so far apart that their variance (or the sum column) overflows.
fn check_total<T: Real, const D: usize>(scores: &Scores<T, D>) -> Result<()> {
    if scores.total().is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            parameter: "source value",
        })
    }
}

/// A computed score table: rows and their scores, in caller storage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoreTable<'a, T, const D: usize> {
    rows: RowSet<'a, T, D>,
    values: &'a [Scores<T, D>],
}

impl<'a, T: Real, const D: usize> ScoreTable<'a, T, D> {
    /// Computes the scores of every row of `rows` from the `sources`' means into the first
    /// `rows.len()` entries of `storage`.
    ///
    /// Cost: `rows.len() · m` model evaluations. Errors: no sources
    /// ([`Error::EmptyData`]); `storage` shorter than the row count
    /// ([`Error::CapacityExceeded`] with its length), checked before anything is computed;
    /// the first error of a model (e.g. a state outside its domain) or a non-finite mean
    /// ([`Error::NonFinite`] naming `source value`); finite values whose variance
    /// overflows `T` ([`Error::InvalidParameter`] naming `source value`). On error the
    /// storage's contents are unspecified.
    pub fn compute<S: SourceModel<T, D>>(
        rows: RowSet<'a, T, D>,
        sources: &[S],
        storage: &'a mut [Scores<T, D>],
    ) -> Result<Self> {
        if sources.is_empty() {
            return Err(Error::EmptyData);
        }
        let values = Self::rows_of(&rows, storage)?;
        let m = T::from_usize(sources.len());
        for (slot, (state, action)) in values.iter_mut().zip(rows.iter()) {
            let mut reward = ShiftedSums::new(T::ZERO);
            let mut next = [ShiftedSums::new(T::ZERO); D];
            for (j, source) in sources.iter().enumerate() {
                let rho = source.predict(state, action)?;
                ensure_finite(rho.reward, "source value")?;
                ensure_all_finite(&rho.next_state, "source value")?;
                if j == 0 {
                    reward = ShiftedSums::new(rho.reward);
                    for (n, &x) in next.iter_mut().zip(&rho.next_state) {
                        *n = ShiftedSums::new(x);
                    }
                    continue;
                }
                reward.add(rho.reward);
                for (n, &x) in next.iter_mut().zip(&rho.next_state) {
                    n.add(x);
                }
            }
            let mut scores = Scores {
                reward: reward.variance(m),
                next_state: [T::ZERO; D],
            };
            for (v, n) in scores.next_state.iter_mut().zip(&next) {
                *v = n.variance(m);
            }
            check_total(&scores)?;
            *slot = scores;
        }
        Ok(Self { rows, values })
    }

    /// The realistic table of §11.2 for the reward column, with one GP in memory at a time:
    /// for each source in turn, fits a reward GP on its records (`subset`, `training`, as
    /// [`fit_gp`]) in `gp`, calls `after_fit(j, gp)` (e.g. to store the posteriors of
    /// source `j`'s records while its GP is loaded), and adds its posterior means at every
    /// row to the running variances. The next-state columns are 0 (the thesis samples on
    /// `V_r` only). Gives the same values, bit for bit, as [`ScoreTable::compute`] over
    /// [`GpSourceModel`]s of the same GPs without next-state GPs, which needs all `m` GPs
    /// at once.
    ///
    /// Working memory: the first `rows.len()` entries of `scratch` (e.g. the storage the
    /// sampler is built in afterwards), whose contents are then unspecified.
    ///
    /// Errors: no sources ([`Error::EmptyData`]); `storage` or `scratch` shorter than the
    /// row count ([`Error::CapacityExceeded`] with its length), checked first; those of
    /// [`fit_gp`] (e.g. a source without records), of `after_fit`, of a prediction; a
    /// non-finite mean or an overflowing variance as in [`ScoreTable::compute`].
    #[allow(clippy::too_many_arguments)]
    pub fn realistic<R, F, const N: usize, const I: usize>(
        rows: RowSet<'a, T, D>,
        sources: &[&[Transition<[T; D], T>]],
        gp: &mut Gp<T, N, I>,
        training: &GpTraining<T, I>,
        subset: SubsetRule,
        storage: &'a mut [Scores<T, D>],
        scratch: &mut [AliasEntry<T>],
        rng: &mut R,
        mut after_fit: F,
    ) -> Result<Self>
    where
        R: Rng + ?Sized,
        F: FnMut(usize, &Gp<T, N, I>) -> Result<()>,
    {
        if sources.is_empty() {
            return Err(Error::EmptyData);
        }
        let values = Self::rows_of(&rows, storage)?;
        let capacity = scratch.len();
        let scratch = scratch
            .get_mut(..values.len())
            .ok_or(Error::CapacityExceeded { capacity })?;
        // Row state between sources: the first source's mean in `reward`, the shifted sum in
        // `next_state[0]` (D ≥ 1), the shifted sum of squares in the scratch entry.
        for (j, records) in sources.iter().enumerate() {
            fit_gp(gp, records, Output::Reward, subset, training, rng)?;
            after_fit(j, gp)?;
            for ((slot, extra), (state, action)) in
                values.iter_mut().zip(scratch.iter_mut()).zip(rows.iter())
            {
                let rho = gp.predict(&input(state, action))?.mean;
                ensure_finite(rho, "source value")?;
                let sum_sq = extra.scratch();
                match slot.next_state.first_mut() {
                    Some(sum) if j > 0 => {
                        let mut sums = ShiftedSums {
                            first: slot.reward,
                            sum: *sum,
                            sum_sq: *sum_sq,
                        };
                        sums.add(rho);
                        *sum = sums.sum;
                        *sum_sq = sums.sum_sq;
                    }
                    _ => {
                        *slot = Scores::ZERO;
                        slot.reward = rho;
                        *sum_sq = T::ZERO;
                    }
                }
            }
        }
        let m = T::from_usize(sources.len());
        for (slot, extra) in values.iter_mut().zip(scratch.iter_mut()) {
            let sums = ShiftedSums {
                first: slot.reward,
                sum: slot.next_state.first().copied().unwrap_or(T::ZERO),
                sum_sq: *extra.scratch(),
            };
            let scores = Scores {
                reward: sums.variance(m),
                next_state: [T::ZERO; D],
            };
            check_total(&scores)?;
            *slot = scores;
        }
        Ok(Self { rows, values })
    }

    /// The first `rows.len()` entries of `storage`, or the capacity error.
    fn rows_of<'s>(
        rows: &RowSet<'_, T, D>,
        storage: &'s mut [Scores<T, D>],
    ) -> Result<&'s mut [Scores<T, D>]> {
        let capacity = storage.len();
        storage
            .get_mut(..rows.len())
            .ok_or(Error::CapacityExceeded { capacity })
    }

    /// A table from scores computed earlier (e.g. once per experiment and shared by all
    /// runs, or kept in flash): the first `rows.len()` entries of `values`.
    ///
    /// Errors: `values` shorter than the row count ([`Error::CapacityExceeded`] with its
    /// length); a non-finite score ([`Error::NonFinite`] `scores`) or a negative one
    /// ([`Error::InvalidParameter`] `scores`).
    pub fn from_parts(rows: RowSet<'a, T, D>, values: &'a [Scores<T, D>]) -> Result<Self> {
        let values = values.get(..rows.len()).ok_or(Error::CapacityExceeded {
            capacity: values.len(),
        })?;
        for v in values {
            for &x in core::iter::once(&v.reward).chain(&v.next_state) {
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
    pub fn rows(&self) -> &RowSet<'a, T, D> {
        &self.rows
    }

    /// The scores, row by row.
    pub fn values(&self) -> &'a [Scores<T, D>] {
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
    pub fn row(&self, r: usize) -> Option<ScoreRow<T, D>> {
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
    /// Errors: a next-state column `≥ D` ([`Error::OutOfRange`] `column`); `storage` too
    /// short ([`Error::CapacityExceeded`]).
    pub fn sampler<'s>(
        &self,
        column: ScoreColumn,
        storage: &'s mut [AliasEntry<T>],
    ) -> Result<RowSampler<'s, T, D>>
    where
        'a: 's,
    {
        if let ScoreColumn::NextState(k) = column {
            if k >= D {
                return Err(Error::OutOfRange {
                    parameter: "column",
                });
            }
        }
        let value = move |v: &Scores<T, D>| v.get(column).unwrap_or(T::ZERO);
        let all_zero = self.values.iter().all(|v| value(v) <= T::ZERO);
        let alias = if all_zero {
            AliasTable::build(self.values.iter().map(|_| T::ONE), storage)?
        } else {
            AliasTable::build(self.values.iter().map(value), storage)?
        };
        Ok(RowSampler {
            rows: self.rows,
            alias,
        })
    }
}

/// Draws rows of a score table with replacement, O(1) per draw (§12 step 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSampler<'a, T, const D: usize> {
    rows: RowSet<'a, T, D>,
    alias: AliasTable<'a, T>,
}

impl<'a, T: Real, const D: usize> RowSampler<'a, T, D> {
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

#[cfg(test)]
mod tests;
