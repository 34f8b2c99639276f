//! Score tables (§11): the variances over the sources at every candidate row, from the
//! sources' means or from one GP per source at a time, and the sampler on one column.

use super::{RowSampler, RowSet};
use crate::alias::{AliasEntry, AliasTable};
use crate::error::{Error, Result};
use crate::error::{ensure_all_finite, ensure_finite};
use crate::float::Real;
use crate::gp::Gp;
use crate::model::{SourceModel, Transition};
use crate::record_gp::{Dims, GpTraining, Output, StatePlusAction, SubsetRule, fit_gp, input};
use rand_core::Rng;

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
    /// [`GpSourceModel`](super::GpSourceModel)s of the same GPs without next-state GPs, which needs all `m` GPs
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
        Dims<D, I>: StatePlusAction,
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
        Ok(RowSampler::new(self.rows, alias))
    }
}
