//! The ARD squared-exponential kernel and its hyperparameters.
//!
//! `k(x, x′) = c · exp(−½ Σ_d ((x_d − x′_d) / ℓ_d)²)`, plus the noise variance `σ²ₙ` on the
//! diagonal of the training Gram matrix only (spec §4.2, with one length scale per input
//! dimension; spec §4.2's isotropic kernel is the case of equal length scales).

use crate::error::ensure_finite;
use crate::error::{Error, Result};
use crate::float::Real;

/// Hyperparameters of the kernel: signal variance `c`, one length scale per input dimension
/// and the noise variance `σ²ₙ`. Memory: `(D + 2) · size_of::<T>()` bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Hyperparameters<T, const D: usize> {
    /// Signal variance `c` (the prior variance of the latent function), > 0.
    pub signal_variance: T,
    /// Length scale `ℓ_d` of each input dimension, > 0.
    pub length_scales: [T; D],
    /// Noise variance `σ²ₙ` of the observations, ≥ 0.
    pub noise_variance: T,
}

impl<T: Real, const D: usize> Hyperparameters<T, D> {
    /// Spec §4.2's initial values: `c = 1`, every `ℓ_d = 1`, `σ²ₙ = 1`.
    pub const SPEC_INITIAL: Self = Self {
        signal_variance: T::ONE,
        length_scales: [T::ONE; D],
        noise_variance: T::ONE,
    };

    /// Hyperparameters with the same length scale in every dimension (spec §4.2's kernel).
    pub const fn isotropic(signal_variance: T, length_scale: T, noise_variance: T) -> Self {
        Self {
            signal_variance,
            length_scales: [length_scale; D],
            noise_variance,
        }
    }

    /// Checks that every value is finite, `c > 0`, every `ℓ_d > 0`, `σ²ₙ ≥ 0`, and that
    /// `c + σ²ₙ` (the Gram diagonal and the prior's noisy variance) is finite too.
    ///
    /// Errors: [`Error::NonFinite`] or [`Error::InvalidParameter`] naming the field
    /// (`noise_variance` when `c + σ²ₙ` overflows).
    pub fn validate(&self) -> Result<()> {
        ensure_finite(self.signal_variance, "signal_variance")?;
        crate::error::ensure_all_finite(&self.length_scales, "length_scales")?;
        ensure_finite(self.noise_variance, "noise_variance")?;
        if self.signal_variance <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "signal_variance",
            });
        }
        if self.length_scales.iter().any(|&l| l <= T::ZERO) {
            return Err(Error::InvalidParameter {
                parameter: "length_scales",
            });
        }
        if self.noise_variance < T::ZERO
            || !(self.signal_variance + self.noise_variance).is_finite()
        {
            return Err(Error::InvalidParameter {
                parameter: "noise_variance",
            });
        }
        Ok(())
    }

    /// The kernel (without noise) between two inputs.
    ///
    /// Each difference is divided by its length scale (not multiplied by a reciprocal), so a
    /// tiny length scale gives 0 or `∞` terms, never `0 · ∞ = NaN`; `exp(−∞) = 0`.
    #[inline]
    pub fn covariance(&self, a: &[T; D], b: &[T; D]) -> T {
        let mut sum = T::ZERO;
        for ((&p, &q), &l) in a.iter().zip(b).zip(&self.length_scales) {
            sum += ((p - q) / l).squared();
        }
        self.signal_variance * (-(sum / (T::ONE + T::ONE))).exp()
    }
}

/// Writes the kernel matrix rows `from..n` (columns `0..=i` of row `i`) into a row-major
/// buffer with `stride` columns, for the inputs `xs[..n]`, adding `noise_variance + jitter`
/// on the diagonal as `(c + σ²ₙ) + jitter` (the reference's order). Returns `false` when a
/// buffer is too small.
pub(crate) fn fill_rows<T: Real, const D: usize>(
    hyper: &Hyperparameters<T, D>,
    xs: &[[T; D]],
    jitter: T,
    l: &mut [T],
    stride: usize,
    from: usize,
    n: usize,
) -> bool {
    let diagonal = (hyper.signal_variance + hyper.noise_variance) + jitter;
    for i in from..n {
        let (Some(xi), Some(row)) = (xs.get(i), l.get_mut(i * stride..i * stride + i + 1)) else {
            return false;
        };
        let Some((diag, left)) = row.split_last_mut() else {
            return false;
        };
        for (entry, xj) in left.iter_mut().zip(xs) {
            *entry = hyper.covariance(xi, xj);
        }
        *diag = diagonal;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covariance_matches_the_closed_form() {
        let h = Hyperparameters {
            signal_variance: 2.0f64,
            length_scales: [0.5, 2.0],
            noise_variance: 0.1,
        };
        // Scaled squared distance: (1/0.5)² + (−3/2)² = 4 + 2.25.
        let k = h.covariance(&[1.0, 0.0], &[0.0, 3.0]);
        assert!((k - 2.0 * (-0.5f64 * 6.25).exp()).abs() < 1e-15);
        assert_eq!(h.covariance(&[1.0, 2.0], &[1.0, 2.0]), 2.0);
    }

    #[test]
    fn tiny_length_scales_and_huge_distances_give_zero_not_nan() {
        let h = Hyperparameters::<f32, 2>::isotropic(1.0, 1e-45, 0.0);
        assert_eq!(h.covariance(&[0.0, 1.0], &[0.0, 2.0]), 0.0);
        assert_eq!(h.covariance(&[0.0, 1.0], &[0.0, 1.0]), 1.0);
        let h = Hyperparameters::<f32, 1>::isotropic(1.0, 1.0, 0.0);
        assert_eq!(h.covariance(&[3e38], &[-3e38]), 0.0);
    }

    #[test]
    fn validate_names_each_bad_field() {
        let ok = Hyperparameters::<f64, 2>::isotropic(1.0, 1.0, 0.0);
        assert_eq!(ok.validate(), Ok(()));
        let nf = |parameter| Err(Error::NonFinite { parameter });
        let inv = |parameter| Err(Error::InvalidParameter { parameter });
        let mut h = ok;
        h.signal_variance = f64::NAN;
        assert_eq!(h.validate(), nf("signal_variance"));
        h.signal_variance = 0.0;
        assert_eq!(h.validate(), inv("signal_variance"));
        let mut h = ok;
        h.length_scales[1] = f64::INFINITY;
        assert_eq!(h.validate(), nf("length_scales"));
        h.length_scales[1] = -1.0;
        assert_eq!(h.validate(), inv("length_scales"));
        let mut h = ok;
        h.noise_variance = f64::NEG_INFINITY;
        assert_eq!(h.validate(), nf("noise_variance"));
        h.noise_variance = -1e-300;
        assert_eq!(h.validate(), inv("noise_variance"));
    }

    #[test]
    fn spec_initial_values() {
        let h = Hyperparameters::<f32, 3>::SPEC_INITIAL;
        assert_eq!(h, Hyperparameters::isotropic(1.0, 1.0, 1.0));
    }
}
