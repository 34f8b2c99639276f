//! The kernel hyperparameters ([`GpHyperparameters`]) and the box the fit searches
//! ([`HyperparameterBox`]).

use awfqi::{Error, Result};

/// Kernel hyperparameters: signal variance `c`, length scale `ℓ`, noise variance `σ²ₙ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpHyperparameters {
    /// Signal variance `c > 0`.
    pub signal_variance: f64,
    /// Isotropic length scale `ℓ > 0`.
    pub length_scale: f64,
    /// Noise variance `σ²ₙ ≥ 0`.
    pub noise_variance: f64,
}

impl GpHyperparameters {
    /// Spec §4.2's initial values: `c = ℓ = σ²ₙ = 1`.
    pub const SPEC_INITIAL: Self = Self {
        signal_variance: 1.0,
        length_scale: 1.0,
        noise_variance: 1.0,
    };

    /// `θ = (ln c, ln ℓ, ln σ²ₙ)`.
    pub fn to_log(&self) -> [f64; 3] {
        [
            self.signal_variance.ln(),
            self.length_scale.ln(),
            self.noise_variance.ln(),
        ]
    }

    /// The hyperparameters of `θ = (ln c, ln ℓ, ln σ²ₙ)`.
    pub fn from_log(theta: &[f64; 3]) -> Self {
        Self {
            signal_variance: theta[0].exp(),
            length_scale: theta[1].exp(),
            noise_variance: theta[2].exp(),
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        for (v, parameter) in [
            (self.signal_variance, "signal_variance"),
            (self.length_scale, "length_scale"),
            (self.noise_variance, "noise_variance"),
        ] {
            if !v.is_finite() {
                return Err(Error::NonFinite { parameter });
            }
        }
        if self.signal_variance <= 0.0 {
            return Err(Error::InvalidParameter {
                parameter: "signal_variance",
            });
        }
        if self.length_scale <= 0.0 {
            return Err(Error::InvalidParameter {
                parameter: "length_scale",
            });
        }
        if self.noise_variance < 0.0 {
            return Err(Error::InvalidParameter {
                parameter: "noise_variance",
            });
        }
        Ok(())
    }
}

/// Bounds of the hyperparameter search, as `(low, high)` of each hyperparameter (not of its
/// logarithm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HyperparameterBox {
    /// Bounds of `c`.
    pub signal_variance: (f64, f64),
    /// Bounds of `ℓ`.
    pub length_scale: (f64, f64),
    /// Bounds of `σ²ₙ`.
    pub noise_variance: (f64, f64),
}

impl HyperparameterBox {
    /// Spec §4.2: `c ∈ [10⁻⁵, 10⁵]`, `ℓ ∈ [10⁻², 10³]`, `σ²ₙ ∈ [10⁻², 1]`.
    pub const SPEC: Self = Self {
        signal_variance: (1e-5, 1e5),
        length_scale: (1e-2, 1e3),
        noise_variance: (1e-2, 1.0),
    };

    /// Lower and upper corners in log space.
    pub fn log_bounds(&self) -> ([f64; 3], [f64; 3]) {
        (
            [
                self.signal_variance.0.ln(),
                self.length_scale.0.ln(),
                self.noise_variance.0.ln(),
            ],
            [
                self.signal_variance.1.ln(),
                self.length_scale.1.ln(),
                self.noise_variance.1.ln(),
            ],
        )
    }

    pub(super) fn validate(&self) -> Result<()> {
        let (lo, hi) = self.log_bounds();
        for i in 0..3 {
            if !(lo[i].is_finite() && hi[i].is_finite()) {
                return Err(Error::NonFinite {
                    parameter: "bounds",
                });
            }
            if lo[i] > hi[i] {
                return Err(Error::InvalidParameter {
                    parameter: "bounds",
                });
            }
        }
        Ok(())
    }
}
