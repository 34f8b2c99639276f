//! The conditioning policy of a large GP ([`LargeConditioning`]) and its check on a
//! Cholesky factor.

use super::JITTER;
use awfqi::{Error, Result};
use faer::Mat;

/// The conditioning policy of a [`LargeGp`](super::LargeGp) (the core's
/// `awfqi::gp::Conditioning` for f64): the jitter on the training diagonal and the largest
/// trusted condition estimate.
///
/// The large GP never escalates its jitter: it factorises `K + (σ²ₙ + jitter) I` with
/// exactly [`LargeConditioning::jitter`] or fails with [`Error::NotPositiveDefinite`], so the
/// jitter never exceeds `jitter / σ²ₙ` relative to the noise (`10⁻⁸` inside the spec box,
/// `σ²ₙ ≥ 10⁻²`). After the final factorisation of a fit the diagonal condition estimate
/// `(max Lᵢᵢ / min Lᵢᵢ)²` (a lower bound on `κ₂`) must stay within
/// [`LargeConditioning::max_condition`], else the fit is refused with
/// [`Error::IllConditioned`]: in f64 the default `10⁻²/ε = 4.5·10¹³` is far above what the
/// spec box allows (`κ₂ ≤ 1 + n·c/σ²ₙ ≤ 4·10¹⁰` at `n = 4000`), so it never changes a fit of
/// the faithful path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LargeConditioning {
    /// Added to the training diagonal ([`JITTER`], the reference's `alpha`; 0 for none).
    pub jitter: f64,
    /// The largest trusted diagonal condition estimate.
    pub max_condition: f64,
}

impl Default for LargeConditioning {
    fn default() -> Self {
        Self {
            jitter: JITTER,
            max_condition: 1e-2 / f64::EPSILON,
        }
    }
}

impl LargeConditioning {
    pub(super) fn validate(&self) -> Result<()> {
        if !(self.jitter.is_finite() && self.jitter >= 0.0) {
            return Err(Error::InvalidParameter {
                parameter: "jitter",
            });
        }
        if self.max_condition.is_nan() || self.max_condition < 1.0 {
            return Err(Error::InvalidParameter {
                parameter: "max_condition",
            });
        }
        Ok(())
    }
}

/// `(max Lᵢᵢ / min Lᵢᵢ)²` of a lower Cholesky factor.
pub(super) fn diagonal_condition(factor: &Mat<f64>) -> f64 {
    let n = factor.nrows().min(factor.ncols());
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for i in 0..n {
        lo = lo.min(factor[(i, i)]);
        hi = hi.max(factor[(i, i)]);
    }
    if n == 0 {
        1.0
    } else if lo > 0.0 {
        (hi / lo).powi(2)
    } else {
        f64::INFINITY
    }
}

/// [`Error::IllConditioned`] when the factor's diagonal condition estimate exceeds the
/// policy's limit.
pub(super) fn check_condition(factor: &Mat<f64>, conditioning: &LargeConditioning) -> Result<()> {
    let condition = diagonal_condition(factor);
    if condition <= conditioning.max_condition {
        Ok(())
    } else {
        Err(Error::IllConditioned {
            condition: awfqi::Number(condition),
            limit: awfqi::Number(conditioning.max_condition),
        })
    }
}
