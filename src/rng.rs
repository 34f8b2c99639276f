//! Random draws from the caller's generator.
//!
//! The core owns no generator and no global state: every function takes a
//! [`rand_core::Rng`], so the same seed always gives the same result, on a host or a
//! microcontroller. Each draw consumes a fixed, documented amount of the stream where
//! possible, so `f32` and `f64` runs from the same seed stay in step.
//!
//! The trait is `rand_core` 0.10's, re-exported as [`crate::rand_core`] so a caller names
//! the same version the core does; generators of `rand_core` 0.6 or 0.9 are passed through
//! the adapters of [`compat`] (features `rand_core_06`, `rand_core_09`).

pub mod compat;

use crate::error::{Error, Result};

use crate::float::Real;
use rand_core::Rng;

/// 2⁻⁵³: the spacing of the 53-bit uniform grid on [0, 1).
const UNIT_53: f64 = 1.0 / 9_007_199_254_740_992.0;

/// A uniform draw on [0, 1) with 53 random bits; consumes one `u64`.
#[inline]
pub fn uniform_f64<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    (rng.next_u64() >> 11) as f64 * UNIT_53
}

/// A uniform draw on [0, 1) in `T`; consumes one `u64` for both precisions.
///
/// In `f32` the draw is rounded from the 53-bit value and kept strictly below 1.
#[inline]
pub fn uniform<T: Real, R: Rng + ?Sized>(rng: &mut R) -> T {
    let u = T::from_f64(uniform_f64(rng));
    if u < T::ONE {
        u
    } else {
        // Rounding (f32 only) reached 1: return the largest value below 1, 1 − ε/2.
        T::ONE - T::EPSILON / T::from_f64(2.0)
    }
}

/// A uniform draw on [`low`, `high`); consumes one `u64`.
///
/// Errors: non-finite bounds, or `low > high`.
pub fn uniform_in<T: Real, R: Rng + ?Sized>(rng: &mut R, low: T, high: T) -> Result<T> {
    crate::error::ensure_finite(low, "low")?;
    crate::error::ensure_finite(high, "high")?;
    if low > high {
        return Err(Error::InvalidParameter { parameter: "low" });
    }
    let u: T = uniform(rng);
    let x = low + (high - low) * u;
    // Guard against rounding up to `high` (and against overflow of `high - low`).
    Ok(if x.is_finite() && x < high {
        x
    } else {
        low.max(high - (high - low).abs() * T::EPSILON)
    })
}

/// An index drawn uniformly from `0..n` (`n >= 1`; `n == 0` gives 0); consumes one `u64`.
///
/// Uses the high half of the 128-bit product `u64 · n`, which is exactly uniform when `n`
/// is a power of two (as Puddle World's 4 actions are) and has bias below n/2⁶⁴ otherwise.
#[inline]
pub fn uniform_index<R: Rng + ?Sized>(rng: &mut R, n: usize) -> usize {
    ((u128::from(rng.next_u64()) * n as u128) >> 64) as usize
}

/// Attempts of the polar method before its (probability < 10⁻⁴²) fallback.
const POLAR_ATTEMPTS: usize = 64;

/// A standard normal draw, 𝒩(0, 1), by Marsaglia's polar method.
///
/// Each attempt consumes two `u64`; an attempt is accepted with probability π/4, so a draw
/// uses 2.55 `u64` on average. The method needs only `sqrt` and `ln`, which keeps it cheap
/// on a single-precision FPU. After 64 rejected attempts (probability below 10⁻⁴²) it
/// returns 0 rather than loop without bound.
pub fn standard_normal<T: Real, R: Rng + ?Sized>(rng: &mut R) -> T {
    let two = T::from_f64(2.0);
    for _ in 0..POLAR_ATTEMPTS {
        let u = two * uniform::<T, R>(rng) - T::ONE;
        let v = two * uniform::<T, R>(rng) - T::ONE;
        let s = u * u + v * v;
        if s > T::ZERO && s < T::ONE {
            return u * (-two * s.ln() / s).sqrt();
        }
    }
    T::ZERO
}

/// A normal draw with the given `mean` and standard deviation `std` (not variance).
///
/// Errors: non-finite `mean` or `std`, or negative `std`.
pub fn normal<T: Real, R: Rng + ?Sized>(rng: &mut R, mean: T, std: T) -> Result<T> {
    crate::error::ensure_finite(mean, "mean")?;
    crate::error::ensure_finite(std, "std")?;
    if std < T::ZERO {
        return Err(Error::InvalidParameter { parameter: "std" });
    }
    Ok(mean + std * standard_normal::<T, R>(rng))
}

/// Draws an index with probability proportional to `weights[i]`; consumes one `u64`.
///
/// The weights need not be normalised. An index whose weight is 0 is never returned.
/// Errors: an empty slice ([`Error::EmptyData`]), a NaN or infinite weight
/// ([`Error::NonFinite`]), a negative weight or all weights zero
/// ([`Error::InvalidParameter`], naming `weights`).
pub fn categorical<T: Real, R: Rng + ?Sized>(rng: &mut R, weights: &[T]) -> Result<usize> {
    let largest = validate_weights(weights)?;
    // Scale by the largest weight so the running sum cannot overflow.
    let total: T = weights.iter().map(|&w| w / largest).sum();
    let target = uniform::<T, R>(rng) * total;
    let mut cumulative = T::ZERO;
    let mut last_positive = 0;
    for (i, &w) in weights.iter().enumerate() {
        if w > T::ZERO {
            cumulative += w / largest;
            last_positive = i;
            if target < cumulative {
                return Ok(i);
            }
        }
    }
    // Rounding left `target` at or above the final sum: take the last positive weight.
    Ok(last_positive)
}

/// Checks unnormalised probability weights and returns the largest one (> 0).
pub(crate) fn validate_weights<T: Real>(weights: &[T]) -> Result<T> {
    if weights.is_empty() {
        return Err(Error::EmptyData);
    }
    let mut largest = T::ZERO;
    for &w in weights {
        if !w.is_finite() {
            return Err(Error::NonFinite {
                parameter: "weights",
            });
        }
        if w < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        if w > largest {
            largest = w;
        }
    }
    if largest > T::ZERO {
        Ok(largest)
    } else {
        Err(Error::InvalidParameter {
            parameter: "weights",
        })
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;
    use std::vec::Vec;

    fn rng(seed: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(seed)
    }

    /// Φ, the standard normal CDF, from libm's erf (independent of the sampler).
    fn normal_cdf(x: f64) -> f64 {
        0.5 * (1.0 + libm::erf(x / core::f64::consts::SQRT_2))
    }

    #[test]
    fn uniform_stays_in_unit_interval_and_has_uniform_moments() {
        let mut r = rng(1);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| uniform(&mut r)).collect();
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        // Standard error of the mean is sqrt(1/12/n) ≈ 6.5e-4; allow 5 of them.
        assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt());
        assert!((var - 1.0 / 12.0).abs() < 2e-3);
    }

    #[test]
    fn f32_and_f64_uniform_streams_agree() {
        let (mut a, mut b) = (rng(7), rng(7));
        for _ in 0..10_000 {
            let x: f32 = uniform(&mut a);
            let y: f64 = uniform(&mut b);
            assert!(x < 1.0);
            assert!((x as f64 - y).abs() <= 6e-8);
        }
    }

    #[test]
    fn uniform_in_respects_bounds_and_rejects_bad_ones() {
        let mut r = rng(2);
        for _ in 0..1000 {
            let x = uniform_in(&mut r, -3.0f32, 2.0).unwrap();
            assert!((-3.0..2.0).contains(&x));
        }
        assert_eq!(
            uniform_in(&mut r, 1.0f64, 0.0),
            Err(Error::InvalidParameter { parameter: "low" })
        );
        assert_eq!(
            uniform_in(&mut r, f64::NAN, 0.0),
            Err(Error::NonFinite { parameter: "low" })
        );
        assert_eq!(
            uniform_in(&mut r, 0.0, f64::INFINITY),
            Err(Error::NonFinite { parameter: "high" })
        );
    }

    #[test]
    fn standard_normal_passes_kolmogorov_smirnov_and_moment_checks() {
        let mut r = rng(3);
        let n = 100_000usize;
        let mut xs: Vec<f64> = (0..n).map(|_| standard_normal(&mut r)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let m2 = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let m3 = xs.iter().map(|x| (x - mean).powi(3)).sum::<f64>() / n as f64;
        let m4 = xs.iter().map(|x| (x - mean).powi(4)).sum::<f64>() / n as f64;
        // Standard errors: mean 1/sqrt(n) = 0.0032, var sqrt(2/n) = 0.0045,
        // skewness sqrt(6/n) = 0.0077, kurtosis sqrt(24/n) = 0.015; allow 5 of each.
        assert!(mean.abs() < 0.016, "mean {mean}");
        assert!((m2 - 1.0).abs() < 0.023, "variance {m2}");
        assert!((m3 / m2.powf(1.5)).abs() < 0.04, "skewness");
        assert!((m4 / (m2 * m2) - 3.0).abs() < 0.08, "kurtosis");
        // Kolmogorov–Smirnov against Φ: the 0.1% critical value is 1.95/sqrt(n).
        xs.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let d = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let f = normal_cdf(x);
                (f - i as f64 / n as f64)
                    .abs()
                    .max(((i + 1) as f64 / n as f64 - f).abs())
            })
            .fold(0.0, f64::max);
        assert!(d < 1.95 / (n as f64).sqrt(), "KS statistic {d}");
    }

    #[test]
    fn same_seed_same_draws() {
        let (mut a, mut b) = (rng(11), rng(11));
        for _ in 0..100 {
            assert_eq!(
                standard_normal::<f64, _>(&mut a),
                standard_normal::<f64, _>(&mut b)
            );
        }
    }

    #[test]
    fn normal_scales_and_validates() {
        let (mut a, mut b) = (rng(5), rng(5));
        let z: f64 = standard_normal(&mut a);
        assert_eq!(normal(&mut b, 2.0, 0.5).unwrap(), 2.0 + 0.5 * z);
        assert_eq!(
            normal(&mut b, 0.0f64, -1.0),
            Err(Error::InvalidParameter { parameter: "std" })
        );
        assert_eq!(
            normal(&mut b, f64::NAN, 1.0),
            Err(Error::NonFinite { parameter: "mean" })
        );
    }

    #[test]
    fn categorical_frequencies_pass_chi_square() {
        let weights = [1.0f64, 0.0, 3.0, 6.0];
        let mut r = rng(9);
        let n = 100_000;
        let mut counts = [0usize; 4];
        for _ in 0..n {
            counts[categorical(&mut r, &weights).unwrap()] += 1;
        }
        assert_eq!(counts[1], 0, "a zero weight is never drawn");
        let total: f64 = weights.iter().sum();
        let chi2: f64 = [0usize, 2, 3]
            .iter()
            .map(|&i| {
                let e = n as f64 * weights[i] / total;
                (counts[i] as f64 - e).powi(2) / e
            })
            .sum();
        // 2 degrees of freedom: the 0.1% critical value is 13.82.
        assert!(chi2 < 13.82, "chi-square {chi2}");
    }

    #[test]
    fn categorical_handles_huge_weights_without_overflow() {
        let mut r = rng(4);
        let w = [f64::MAX, f64::MAX];
        let mut seen = [false; 2];
        for _ in 0..100 {
            seen[categorical(&mut r, &w).unwrap()] = true;
        }
        assert_eq!(seen, [true, true]);
    }

    #[test]
    fn categorical_rejects_bad_weights() {
        let mut r = rng(0);
        assert_eq!(categorical::<f32, _>(&mut r, &[]), Err(Error::EmptyData));
        assert_eq!(
            categorical(&mut r, &[1.0f32, f32::NAN]),
            Err(Error::NonFinite {
                parameter: "weights"
            })
        );
        assert_eq!(
            categorical(&mut r, &[1.0f32, f32::INFINITY]),
            Err(Error::NonFinite {
                parameter: "weights"
            })
        );
        assert_eq!(
            categorical(&mut r, &[1.0f64, -0.5]),
            Err(Error::InvalidParameter {
                parameter: "weights"
            })
        );
        assert_eq!(
            categorical(&mut r, &[0.0f64, 0.0]),
            Err(Error::InvalidParameter {
                parameter: "weights"
            })
        );
    }
}
