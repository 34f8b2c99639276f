//! The settings of a weighted FQI fit, shared by every approximator: discount, iterations,
//! the minimum weight of "data", and what a table's pairs without data predict.

use crate::error::ensure_finite;
use crate::error::{Error, Result};
use crate::float::Real;

/// What a (cell, action) pair with no sample of positive weight predicts.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EmptyCells<T> {
    /// The value of the nearest pair with data, same action (ties: smallest cell index);
    /// 0 when the action has no data at all.
    Nearest,
    /// As [`EmptyCells::Nearest`], but never more than the lowest value among the actions
    /// that do have data in the same cell: an action never tried in a visited cell is not
    /// preferred to the tried ones (pessimism for unseen actions; the default).
    CappedNearest,
    /// This fixed value.
    Value(T),
}

/// Validated settings of a fit: discount γ, number of iterations N and the handling of
/// pairs without data.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FqiConfig<T> {
    discount: T,
    iterations: usize,
    empty_cells: EmptyCells<T>,
    min_weight: T,
}

impl<T: Real> FqiConfig<T> {
    /// Checks and stores the settings.
    ///
    /// Errors: `discount` non-finite or outside `[0, 1]`, `iterations == 0`, a non-finite
    /// [`EmptyCells::Value`].
    pub fn new(discount: T, iterations: usize, empty_cells: EmptyCells<T>) -> Result<Self> {
        ensure_finite(discount, "discount")?;
        if !(T::ZERO..=T::ONE).contains(&discount) {
            return Err(Error::InvalidParameter {
                parameter: "discount",
            });
        }
        if iterations == 0 {
            return Err(Error::InvalidParameter {
                parameter: "iterations",
            });
        }
        if let EmptyCells::Value(v) = empty_cells {
            ensure_finite(v, "empty_cells")?;
        }
        Ok(Self {
            discount,
            iterations,
            empty_cells,
            min_weight: T::ZERO,
        })
    }

    /// The same settings with pairs whose total sample weight is below `min_weight`
    /// counted as having no data (see the module docs); 0, the default of
    /// [`FqiConfig::new`], counts any positive weight.
    ///
    /// Errors: a non-finite or negative `min_weight`.
    pub fn with_min_weight(self, min_weight: T) -> Result<Self> {
        ensure_finite(min_weight, "min_weight")?;
        if min_weight < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "min_weight",
            });
        }
        Ok(Self { min_weight, ..self })
    }

    /// The published settings (§5, §13): γ = 0.99, 60 iterations, and for pairs without
    /// data [`EmptyCells::CappedNearest`] with a minimum total weight of 0.5
    /// (**\[CHOICE\]**: half a target sample's worth; unweighted data are unaffected).
    pub fn published() -> Self {
        Self {
            discount: T::from_f64(0.99),
            iterations: 60,
            empty_cells: EmptyCells::CappedNearest,
            min_weight: T::from_f64(0.5),
        }
    }

    /// The discount γ.
    pub fn discount(&self) -> T {
        self.discount
    }

    /// The number of iterations N (iteration 1 fits the reward).
    pub fn iterations(&self) -> usize {
        self.iterations
    }

    /// The handling of pairs without data.
    pub fn empty_cells(&self) -> EmptyCells<T> {
        self.empty_cells
    }

    /// The total weight below which a pair counts as having no data.
    pub fn min_weight(&self) -> T {
        self.min_weight
    }
}
