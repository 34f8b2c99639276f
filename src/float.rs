//! The floating-point abstraction shared by every module: `f32` on a microcontroller with
//! a single-precision FPU, `f64` on a host or for reference runs.
//!
//! The trait is sealed and deliberately small: exactly the operations the core needs, each
//! routed through `libm` so that results do not depend on the platform's `std`.
//!
//! **Maths in a `no_std` program.** `f32::sqrt`, `exp`, `ln`, `sin`, `cos`, `abs`, `floor`
//! and friends are `std` methods, so firmware that writes `x.sqrt()` does not compile
//! ("no method named `sqrt` found for type `f32`"). Bring [`Real`] into scope and the
//! same calls work, with the core's `libm` arithmetic — the same results on the host and
//! on the device:
//!
//! ```
//! use awfqi::float::Real; // sqrt, exp, ln, ln_1p, sin, cos, abs, floor, max, min, squared, clamp_to
//! let gain: f32 = 0.3;
//! let settle = (-gain * 4.0).exp(); // e^(−1.2)
//! let noise = Real::sqrt(0.02f32); // or `0.02f32.sqrt()`; in std code the inherent
//!                                  // method wins, so name the trait to be sure of libm
//! assert!((settle - 0.301_194).abs() < 1e-6);
//! assert!((noise - 0.141_421_36).abs() < 1e-7);
//! assert_eq!((1.7f32).clamp_to(0.0, 1.0), 1.0);
//! assert_eq!(<f32 as Real>::from_f64(0.1), 0.1f32);
//! ```

use core::fmt::{Debug, Display};
use core::iter::Sum;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A real scalar: implemented for `f32` and `f64` only.
pub trait Real:
    sealed::Sealed
    + Copy
    + Default
    + PartialEq
    + PartialOrd
    + Debug
    + Display
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Sum
    + Send
    + Sync
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Machine epsilon of the type.
    const EPSILON: Self;
    /// Largest finite value.
    const MAX: Self;
    /// Smallest positive normal value.
    const MIN_POSITIVE: Self;
    /// Positive infinity.
    const INFINITY: Self;
    /// Negative infinity.
    const NEG_INFINITY: Self;
    /// π.
    const PI: Self;

    /// Converts from `f64`, rounding to nearest.
    fn from_f64(value: f64) -> Self;
    /// Converts to `f64` exactly.
    fn to_f64(self) -> f64;
    /// Converts a count to this type, rounding to nearest.
    fn from_usize(value: usize) -> Self;
    /// `self as usize`: truncates towards zero and saturates (0 for negative values and NaN,
    /// `usize::MAX` above it), in the type's own precision — an `f32` converts with one
    /// hardware instruction on a Cortex-M4F, where a detour through `f64` is software.
    fn to_usize_saturating(self) -> usize;
    /// Square root (NaN for negative input).
    fn sqrt(self) -> Self;
    /// Exponential function.
    fn exp(self) -> Self;
    /// Natural logarithm (NaN for negative input, −∞ for 0).
    fn ln(self) -> Self;
    /// Sine (radians).
    fn sin(self) -> Self;
    /// Cosine (radians).
    fn cos(self) -> Self;
    /// `ln(1 + self)`, accurate near 0.
    fn ln_1p(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Largest integer not greater than `self`.
    fn floor(self) -> Self;
    /// The larger of two values; a NaN argument loses to a number.
    fn max(self, other: Self) -> Self;
    /// The smaller of two values; a NaN argument loses to a number.
    fn min(self, other: Self) -> Self;
    /// `true` unless NaN or ±∞.
    fn is_finite(self) -> bool;
    /// `true` for NaN.
    fn is_nan(self) -> bool;

    /// `self * self`.
    #[inline]
    fn squared(self) -> Self {
        self * self
    }
    /// Clamps into `[lo, hi]` (assumes `lo <= hi`; NaN stays NaN).
    #[inline]
    fn clamp_to(self, lo: Self, hi: Self) -> Self {
        if self < lo {
            lo
        } else if self > hi {
            hi
        } else {
            self
        }
    }
}

macro_rules! impl_real {
    ($t:ty, $sqrt:path, $exp:path, $ln:path, $sin:path, $cos:path, $ln1p:path, $abs:path, $floor:path, $fmax:path, $fmin:path) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const EPSILON: Self = <$t>::EPSILON;
            const MAX: Self = <$t>::MAX;
            const MIN_POSITIVE: Self = <$t>::MIN_POSITIVE;
            const INFINITY: Self = <$t>::INFINITY;
            const NEG_INFINITY: Self = <$t>::NEG_INFINITY;
            const PI: Self = core::f64::consts::PI as $t;

            #[inline]
            fn from_f64(value: f64) -> Self {
                value as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_usize(value: usize) -> Self {
                value as $t
            }
            #[inline]
            fn to_usize_saturating(self) -> usize {
                self as usize
            }
            #[inline]
            fn sqrt(self) -> Self {
                $sqrt(self)
            }
            #[inline]
            fn exp(self) -> Self {
                $exp(self)
            }
            #[inline]
            fn ln(self) -> Self {
                $ln(self)
            }
            #[inline]
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline]
            fn ln_1p(self) -> Self {
                $ln1p(self)
            }
            #[inline]
            fn abs(self) -> Self {
                $abs(self)
            }
            #[inline]
            fn floor(self) -> Self {
                $floor(self)
            }
            #[inline]
            fn max(self, other: Self) -> Self {
                $fmax(self, other)
            }
            #[inline]
            fn min(self, other: Self) -> Self {
                $fmin(self, other)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
        }
    };
}

impl_real!(
    f32,
    libm::sqrtf,
    libm::expf,
    libm::logf,
    libm::sinf,
    libm::cosf,
    libm::log1pf,
    libm::fabsf,
    libm::floorf,
    libm::fmaxf,
    libm::fminf
);
impl_real!(
    f64,
    libm::sqrt,
    libm::exp,
    libm::log,
    libm::sin,
    libm::cos,
    libm::log1p,
    libm::fabs,
    libm::floor,
    libm::fmax,
    libm::fmin
);

/// `ln(exp(a) + exp(b))` without overflow; −∞ when both are −∞.
#[inline]
pub fn log_add_exp<T: Real>(a: T, b: T) -> T {
    let (hi, lo) = if a > b { (a, b) } else { (b, a) };
    if hi == T::NEG_INFINITY {
        return T::NEG_INFINITY;
    }
    hi + (lo - hi).exp().ln_1p()
}

/// `ln Σ exp(vᵢ)` over a slice, stable for very large or very small terms; −∞ for an empty
/// slice or when every term is −∞. NaN in gives NaN out.
pub fn log_sum_exp<T: Real>(values: &[T]) -> T {
    let mut hi = T::NEG_INFINITY;
    for &v in values {
        if v.is_nan() {
            return v;
        }
        if v > hi {
            hi = v;
        }
    }
    if hi == T::NEG_INFINITY || hi == T::INFINITY {
        return hi;
    }
    let sum: T = values.iter().map(|&v| (v - hi).exp()).sum();
    hi + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn libm_routes_match_closed_forms() {
        assert!((Real::sqrt(2.0f64) - core::f64::consts::SQRT_2).abs() < 1e-15);
        assert!((Real::exp(1.0f32) - core::f32::consts::E).abs() < 1e-6);
        assert_eq!(Real::ln(1.0f64), 0.0);
        assert!((Real::sin(core::f64::consts::FRAC_PI_6) - 0.5).abs() < 1e-15);
        assert!((Real::cos(core::f32::consts::FRAC_PI_3) - 0.5).abs() < 1e-6);
        assert_eq!(<f32 as Real>::from_f64(0.5), 0.5f32);
        assert!(Real::max(f64::NAN, 1.0) == 1.0);
    }

    #[test]
    fn saturating_index_equals_the_f64_route() {
        // The cell index of the FQI grid used `t as f64 as usize`; the direct conversion
        // must give the same integer for every f32, including the edges.
        let edges = [
            0.0f32,
            -0.0,
            0.999_999_94,
            1.0,
            10.999_999,
            11.0,
            -1e-30,
            -5.0,
            16_777_217.0,
            3.4e38,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
        ];
        let mut x = 0x1234_5678u32;
        let random = (0..10_000).map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            f32::from_bits(x)
        });
        for t in edges.into_iter().chain(random) {
            assert_eq!(t.to_usize_saturating(), t as f64 as usize, "{t:e}");
        }
        assert_eq!(2.5f32.to_usize_saturating(), 2);
        assert_eq!((-2.5f64).to_usize_saturating(), 0);
        assert_eq!(f64::NAN.to_usize_saturating(), 0);
        assert_eq!(1e300f64.to_usize_saturating(), usize::MAX);
    }

    #[test]
    fn log_sum_exp_is_stable_for_extreme_terms() {
        // ln(e^1000 + e^1000) = 1000 + ln 2, which overflows if computed naively.
        let v = log_sum_exp(&[1000.0f64, 1000.0]);
        assert!((v - (1000.0 + core::f64::consts::LN_2)).abs() < 1e-12);
        let v = log_sum_exp(&[-1000.0f64, -1001.0]);
        assert!((v - (-1000.0 + (1.0 + (-1.0f64).exp()).ln())).abs() < 1e-12);
        assert_eq!(log_sum_exp::<f64>(&[]), f64::NEG_INFINITY);
        assert_eq!(log_sum_exp(&[f64::NEG_INFINITY; 3]), f64::NEG_INFINITY);
        assert!(log_sum_exp(&[0.0f64, f64::NAN]).is_nan());
        assert!((log_add_exp(0.0f64, 0.0) - core::f64::consts::LN_2).abs() < 1e-15);
    }
}
