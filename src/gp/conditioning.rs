use crate::error::{Error, Result};

use crate::float::Real;

/// Jitter always added to the training diagonal unless the policy omits it: `10⁻¹⁰`, the
/// reference's `alpha` (spec §4.2).
///
/// In `f32` it is below the rounding of a diagonal near 1 and changes nothing; in `f64` it
/// changes the log marginal likelihood of a nearly singular fit (duplicated inputs, noise
/// `10⁻⁸`) by about `10⁻⁴` relative. [`Conditioning::without_base_jitter`] leaves it out.
pub const BASE_JITTER: f64 = 1e-10;

/// The limit of `ε·κ̂` above which a factor is not trusted (see the module docs).
const TRUSTED_ROUNDING: f64 = 1e-2;

const OWN_RATIO: u8 = 1;
const OWN_CONDITION: u8 = 2;
const NO_BASE_JITTER: u8 = 4;

/// The conditioning policy of a [`Gp`](super::Gp): how much diagonal jitter it may add to
/// factorise an ill-conditioned Gram matrix, and which condition it still trusts (spec §4.2).
///
/// A jitter `j` on the diagonal turns the model with noise variance `σ²ₙ` into one with
/// `σ²ₙ + j`. In the eigenbasis of the Gram matrix each term of the predictive mean is scaled
/// by at most `j / (σ²ₙ + j)`, so (Cauchy–Schwarz over the terms)
/// `|Δμ(x)| ≤ (j / σ²ₙ) · √c · ‖L⁻¹y‖`, where `‖L⁻¹y‖² = yᵀK⁻¹y` is the data-fit term of the
/// log marginal likelihood (about `n` for a model that fits its data). The log marginal
/// likelihood moves by at most `(j / σ²ₙ) · (n + yᵀK⁻¹y) / 2`. The policy therefore bounds the
/// escalated jitter **relative to the noise variance**: `j ≤ ρ · (σ²ₙ + base jitter)`.
/// The default `ρ = √ε` (`3.5·10⁻⁴` in `f32`, `1.5·10⁻⁸` in `f64`) keeps the mean within
/// `√ε · √128 · √c` — `3.9·10⁻³·√c` in `f32`, `1.7·10⁻⁷·√c` in `f64` for `n ≤ 128` — inside
/// the tolerance table of `crosscheck/tests/gp_differential.rs` (hard cases: 10⁻² in `f32`, 10⁻⁶ in
/// `f64`, relative to the data scale). A fit that would need more returns
/// [`Error::JitterLimit`] naming the jitter it needed.
///
/// After a factorisation the GP estimates the spectral condition number from the factor's
/// diagonal, `κ̂ = (max Lᵢᵢ / min Lᵢᵢ)²` (O(n), a lower bound on `κ₂`: `Lᵢᵢ²` are Schur
/// complements, between `λ_min` and `λ_max`). A forward error of order `ε·κ` is what a
/// backward-stable solve promises, so when `ε·κ̂` exceeds `10⁻²` (`κ̂ > 8.4·10⁴` in `f32`,
/// `4.5·10¹³` in `f64`) the GP refuses with [`Error::IllConditioned`]
/// (after trying the jitters the policy allows). Together with the Cholesky pivot guard this is
/// what keeps a wrong `f32` answer from being returned as a success.
///
/// How a GP may condition its Gram matrix: base jitter, largest escalated jitter relative to
/// the noise variance, largest trusted condition estimate. See above.
///
/// The default (every bit zero, so a GP in a zero-initialised `static` carries it): base
/// jitter [`BASE_JITTER`], jitter ratio `√ε`, condition limit `10⁻²/ε`.
///
/// ```
/// use awfqi::gp::{Conditioning, Gp, Hyperparameters};
/// # fn main() -> awfqi::Result<()> {
/// let exact = Conditioning::<f64>::DEFAULT.without_base_jitter();
/// let mut gp = Gp::<f64, 8, 1>::new(Hyperparameters::isotropic(1.0, 1.0, 1e-8))?;
/// gp.set_conditioning(exact)?;
/// gp.fit(&[[0.0], [0.0]], &[1.0, 1.0])?; // duplicates: a jitter of 1e-9 would be needed
/// assert_eq!(gp.jitter(), 0.0);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Conditioning<T> {
    /// Which fields below are the caller's (else the precision's default).
    flags: u8,
    max_jitter_ratio: T,
    max_condition: T,
}

impl<T: Real> Default for Conditioning<T> {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl<T: Real> Conditioning<T> {
    /// The default policy (see the type's docs).
    pub const DEFAULT: Self = Self {
        flags: 0,
        max_jitter_ratio: T::ZERO,
        max_condition: T::ZERO,
    };

    /// No limits: any jitter of the escalation ladder, any condition (the behaviour before
    /// the policy existed; for comparisons, not for firmware).
    pub const UNBOUNDED: Self = Self {
        flags: OWN_RATIO | OWN_CONDITION,
        max_jitter_ratio: T::INFINITY,
        max_condition: T::INFINITY,
    };

    /// The same policy without the base jitter: the GP factorises `K + σ²ₙI` exactly as
    /// asked, and any jitter it needs is an escalation bounded by the ratio.
    pub const fn without_base_jitter(self) -> Self {
        Self {
            flags: self.flags | NO_BASE_JITTER,
            ..self
        }
    }

    /// The same policy with the largest escalated jitter set to `ratio · (σ²ₙ + base
    /// jitter)`; `0` forbids any escalation, `∞` allows the whole ladder.
    ///
    /// Errors: [`Error::InvalidParameter`] `max_jitter_ratio` for a negative or NaN ratio.
    pub fn with_max_jitter_ratio(self, ratio: T) -> Result<Self> {
        if ratio.is_nan() || ratio < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "max_jitter_ratio",
            });
        }
        Ok(Self {
            flags: self.flags | OWN_RATIO,
            max_jitter_ratio: ratio,
            ..self
        })
    }

    /// The same policy with the largest trusted condition estimate set to `limit` (`∞` trusts
    /// every factor that the pivot guard accepts).
    ///
    /// Errors: [`Error::InvalidParameter`] `max_condition` unless `limit ≥ 1` (a condition
    /// number is never below 1).
    pub fn with_max_condition(self, limit: T) -> Result<Self> {
        if limit.is_nan() || limit < T::ONE {
            return Err(Error::InvalidParameter {
                parameter: "max_condition",
            });
        }
        Ok(Self {
            flags: self.flags | OWN_CONDITION,
            max_condition: limit,
            ..self
        })
    }

    /// The jitter always added: [`BASE_JITTER`], or 0 after [`Self::without_base_jitter`].
    pub fn base_jitter(&self) -> T {
        if self.flags & NO_BASE_JITTER != 0 {
            T::ZERO
        } else {
            T::from_f64(BASE_JITTER)
        }
    }

    /// The largest escalated jitter relative to `σ²ₙ + base jitter` (default `√ε`).
    pub fn max_jitter_ratio(&self) -> T {
        if self.flags & OWN_RATIO != 0 {
            self.max_jitter_ratio
        } else {
            T::EPSILON.sqrt()
        }
    }

    /// The largest trusted condition estimate (default `10⁻²/ε`).
    pub fn max_condition(&self) -> T {
        if self.flags & OWN_CONDITION != 0 {
            self.max_condition
        } else {
            T::from_f64(TRUSTED_ROUNDING) / T::EPSILON
        }
    }

    /// The largest jitter allowed for noise variance `noise_variance`.
    pub fn allowed_jitter(&self, noise_variance: T) -> T {
        let ratio = self.max_jitter_ratio();
        if ratio == T::INFINITY {
            return T::INFINITY;
        }
        ratio * (noise_variance + self.base_jitter())
    }
}

/// `(max Lᵢᵢ / min Lᵢᵢ)²` over the first `n` diagonal entries of a row-major factor with
/// `stride` columns: the diagonal condition estimate (1 for `n = 0`, `∞` for a zero pivot).
pub(crate) fn diagonal_condition<T: Real>(factor: &[T], stride: usize, n: usize) -> T {
    let mut smallest = T::INFINITY;
    let mut largest = T::ZERO;
    for i in 0..n {
        let d = i
            .checked_mul(stride)
            .and_then(|start| factor.get(start.checked_add(i)?))
            .copied()
            .unwrap_or(T::ZERO);
        smallest = smallest.min(d);
        largest = largest.max(d);
    }
    if n == 0 {
        return T::ONE;
    }
    if smallest.is_nan() || smallest <= T::ZERO {
        return T::INFINITY;
    }
    (largest / smallest).squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_follow_the_precision() {
        let f = Conditioning::<f32>::DEFAULT;
        assert_eq!(f.base_jitter(), 1e-10);
        assert!((f.max_jitter_ratio() - f32::EPSILON.sqrt()).abs() < 1e-9);
        assert!((f.max_condition() / (1e-2 / f32::EPSILON) - 1.0).abs() < 1e-6);
        let d = Conditioning::<f64>::default();
        assert!((d.max_jitter_ratio() - 1.4901161193847656e-8).abs() < 1e-20);
        assert_eq!(
            d.allowed_jitter(1e-2),
            d.max_jitter_ratio() * (1e-2 + 1e-10)
        );
        let exact = d.without_base_jitter();
        assert_eq!(exact.base_jitter(), 0.0);
        assert_eq!(exact.allowed_jitter(0.0), 0.0);
        assert_eq!(
            Conditioning::<f64>::UNBOUNDED.allowed_jitter(0.0),
            f64::INFINITY
        );
    }

    #[test]
    fn bad_limits_are_named() {
        let d = Conditioning::<f64>::DEFAULT;
        for bad in [-1.0, f64::NAN] {
            assert_eq!(
                d.with_max_jitter_ratio(bad),
                Err(Error::InvalidParameter {
                    parameter: "max_jitter_ratio"
                })
            );
        }
        for bad in [0.5, f64::NAN, -1.0] {
            assert_eq!(
                d.with_max_condition(bad),
                Err(Error::InvalidParameter {
                    parameter: "max_condition"
                })
            );
        }
        let own = d.with_max_jitter_ratio(0.0).unwrap();
        assert_eq!(own.max_jitter_ratio(), 0.0);
        assert_eq!(own.with_max_condition(10.0).unwrap().max_condition(), 10.0);
    }

    #[test]
    fn diagonal_condition_is_the_squared_pivot_ratio() {
        // Row-major 3 × 3 with diagonal 2, 0.5, 1.
        let l = [2.0, 9.0, 9.0, 9.0, 0.5, 9.0, 9.0, 9.0, 1.0];
        assert_eq!(diagonal_condition(&l, 3, 3), 16.0);
        assert_eq!(diagonal_condition(&l, 3, 1), 1.0);
        assert_eq!(diagonal_condition(&l, 3, 0), 1.0);
        assert_eq!(diagonal_condition(&[0.0, 1.0], 1, 2), f64::INFINITY);
    }
}
