use crate::error::{Error, Result};
use crate::float::Real;
use crate::gp::{Gp, Hyperparameters};
use crate::model::Transition;
use crate::record_gp::{Dims, GpTraining, Output, StatePlusAction, SubsetRule, fit_gp};
use rand_core::Rng;

/// A GP that only predicts its posterior mean: the inputs, the mean weights `α = K⁻¹y` and
/// the hyperparameters, without the `N × N` factor.
///
/// Adaptive AWFQI needs every source's reward-GP mean at every candidate row and at
/// every target record, all the time; keeping one [`Gp`] per source would cost `N²` floats
/// each (17 704 bytes for `Gp<f32, 64, 3>`), a mean function costs `N·(I + 1) + I + 2`
/// floats (1 048 bytes for `f32`, `N = 64`, `I = 3`). It is set-up data, like the stored
/// posteriors: computed once per source (on the device, or on a host and kept in flash).
///
/// The posterior mean `m(z) = Σᵢ k(z, xᵢ) αᵢ` of a fitted GP with room for `N` inputs of
/// dimension `I`. Without points it is the zero function (the GP prior's mean).
#[derive(Debug, Clone, PartialEq)]
pub struct MeanFunction<T, const N: usize, const I: usize> {
    hyper: Hyperparameters<T, I>,
    inputs: [[T; I]; N],
    weights: [T; N],
    len: usize,
}

impl<T: Real, const N: usize, const I: usize> Default for MeanFunction<T, N, I> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<T: Real, const N: usize, const I: usize> MeanFunction<T, N, I> {
    /// The zero function (no points), all-zero so it can live in `.bss`.
    pub const EMPTY: Self = Self {
        hyper: Hyperparameters::isotropic(T::ZERO, T::ZERO, T::ZERO),
        inputs: [[T::ZERO; I]; N],
        weights: [T::ZERO; N],
        len: 0,
    };

    /// Replaces this function by the posterior mean of `gp` (O(n²)).
    ///
    /// Errors: those of [`Gp::mean_weights`]; on error `self` is unchanged.
    pub fn copy_from(&mut self, gp: &Gp<T, N, I>) -> Result<()> {
        let mut weights = [T::ZERO; N];
        let n = gp.mean_weights(&mut weights)?;
        for (slot, x) in self.inputs.iter_mut().zip(gp.inputs()) {
            *slot = *x;
        }
        self.weights = weights;
        self.hyper = *gp.hyperparameters();
        self.len = n;
        Ok(())
    }

    /// Fits `gp` on the rewards of `records` (the `subset` rule, `training`; drawing the
    /// search's restarts from `rng`) and keeps its posterior mean: a source's reward model.
    ///
    /// Errors: those of [`fit_gp`] and [`Gp::mean_weights`]; on error `self` is unchanged.
    pub fn fit_rewards<R: Rng + ?Sized, const D: usize>(
        &mut self,
        gp: &mut Gp<T, N, I>,
        records: &[Transition<[T; D], T>],
        training: &GpTraining<T, I>,
        subset: SubsetRule,
        rng: &mut R,
    ) -> Result<()>
    where
        Dims<D, I>: StatePlusAction,
    {
        fit_gp(gp, records, Output::Reward, subset, training, rng)?;
        self.copy_from(gp)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` for the zero function.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The hyperparameters of the GP it came from.
    pub fn hyperparameters(&self) -> &Hyperparameters<T, I> {
        &self.hyper
    }

    /// The mean at `z`; O(n·I).
    ///
    /// Errors: a non-finite `z` ([`Error::NonFinite`] `z`), a non-finite mean
    /// ([`Error::NonFinite`] `mean`).
    pub fn mean(&self, z: &[T; I]) -> Result<T> {
        if !z.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite { parameter: "z" });
        }
        let mut sum = T::ZERO;
        for (x, &w) in self.inputs.iter().zip(&self.weights).take(self.len) {
            sum += self.hyper.covariance(z, x) * w;
        }
        crate::error::ensure_finite(sum, "mean")?;
        Ok(sum)
    }
}
