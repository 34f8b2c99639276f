//! The one error type of the core.
//!
//! Small and `Copy` so it can be returned from an interrupt handler or logged with `defmt`
//! without allocating. Every variant names what was wrong, so a firmware engineer reading
//! a log line knows which argument to fix.

use core::fmt;

/// Everything that can go wrong in the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// A fixed capacity would be exceeded; `capacity` is the limit that was hit.
    CapacityExceeded {
        /// The capacity (number of elements) of the container that is full.
        capacity: usize,
    },
    /// A buffer lent to a kernel (a part of a block of [`adaptive_storage!`](crate::adaptive_storage)
    /// or [`awfqi_storage!`](crate::awfqi_storage), or a set-up buffer) is shorter than the
    /// set-up or the run needs: `buffer` names it and the named capacity that sizes it.
    BufferTooSmall {
        /// The buffer and the capacity that sizes it, e.g. ``"samples (`steps` × `budget`
        /// target records)"``.
        buffer: &'static str,
        /// Its length.
        capacity: usize,
        /// The length needed.
        needed: usize,
    },
    /// An input value was NaN or infinite.
    NonFinite {
        /// Name of the offending parameter or data field.
        parameter: &'static str,
    },
    /// A parameter is finite but outside the values the function accepts (for example a
    /// negative variance, a zero length scale or inverted bounds).
    InvalidParameter {
        /// Name of the offending parameter.
        parameter: &'static str,
    },
    /// A state, action or index lies outside the space it must belong to.
    OutOfRange {
        /// Name of the offending parameter.
        parameter: &'static str,
    },
    /// A finite input is too large for the working precision: computing with it overflows
    /// (for example GP targets whose whitened values `L⁻¹y` exceed the largest `f32`).
    Overflow {
        /// Name of the offending parameter or data field.
        parameter: &'static str,
    },
    /// An operation needs at least one data point and got none.
    EmptyData,
    /// A kernel matrix could not be factorised even after the largest jitter was added to
    /// its diagonal.
    NotPositiveDefinite,
    /// A kernel matrix factorises only with more diagonal jitter than the caller's
    /// conditioning policy allows (`crate::gp::Conditioning::max_jitter_ratio`): with that
    /// jitter the GP would answer for a different model than the one asked for.
    JitterLimit {
        /// The smallest jitter of the escalation ladder that factorised the matrix.
        needed: Number,
        /// The largest jitter the policy allowed for this noise variance.
        allowed: Number,
    },
    /// A kernel matrix factorised, but its estimated condition number is beyond what the
    /// working precision can be trusted with (`crate::gp::Conditioning::max_condition`):
    /// predictions could be wrong in their leading digits.
    IllConditioned {
        /// The condition estimate of the factorised matrix.
        condition: Number,
        /// The largest estimate the policy accepts.
        limit: Number,
    },
}

/// A number carried by an [`Error`], so it can say how far off a value was.
///
/// Compared and hashed by its bits, so [`Error`] stays `Eq` and `Hash`; print it or read it
/// with [`Number::value`].
#[derive(Debug, Clone, Copy)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Number(pub f64);

impl Number {
    /// The value.
    pub fn value(self) -> f64 {
        self.0
    }
}

impl PartialEq for Number {
    fn eq(&self, other: &Self) -> bool {
        self.0.to_bits() == other.0.to_bits()
    }
}

impl Eq for Number {}

impl core::hash::Hash for Number {
    fn hash<H: core::hash::Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state);
    }
}

/// Prints three significant digits, as a plain number from 0.001 to 999 999 (`9.47`,
/// `0.131`, `80000`) and in scientific notation beyond (`1.5e-6`, `2e9`), with integer
/// formatting only: core's float formatting keeps bounds checks that the no-panic proof
/// cannot see through.
impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            return f.write_str("NaN");
        }
        let sign = if v.is_sign_negative() { "-" } else { "" };
        if v.is_infinite() {
            return write!(f, "{sign}inf");
        }
        if v == 0.0 {
            return write!(f, "{sign}0");
        }
        // The mantissa m in [1, 10) and the exponent e of |v| = m·10^e.
        let (mut m, mut e) = (v.abs(), 0i32);
        while m >= 10.0 {
            m /= 10.0;
            e += 1;
        }
        while m < 1.0 {
            m *= 10.0;
            e -= 1;
        }
        // Three significant digits, rounded (999.5 rounds up to the next power of ten).
        let mut digits = (m * 100.0 + 0.5) as u32;
        if digits >= 1000 {
            digits = 100;
            e += 1;
        }
        match e {
            // Plain, whole: the digits followed by e − 2 zeros.
            2..=5 => {
                let scale = 10u32.pow(e.unsigned_abs() - 2);
                write!(f, "{sign}{}", u64::from(digits) * u64::from(scale))
            }
            // Plain, with 2 − e decimal places (1 to 5), trailing zeros dropped. The
            // decimals are split off digit by digit and written one by one: a division by a
            // computed power of ten or a computed width (`{:0w$}`) would keep a panic path.
            -3..=1 => {
                let places = (2 - e).unsigned_abs() as usize;
                let mut whole = digits;
                // decimals[i]: the decimal at 10^(i − places), the last one first.
                let mut decimals = [0u8; 5];
                for d in decimals.iter_mut().take(places) {
                    *d = (whole % 10) as u8;
                    whole /= 10;
                }
                write!(f, "{sign}{whole}")?;
                if let Some(zeros) = decimals.iter().take(places).position(|&d| d != 0) {
                    fmt::Write::write_char(f, '.')?;
                    for &d in decimals.iter().take(places).skip(zeros).rev() {
                        fmt::Write::write_char(f, char::from(b'0' + d))?;
                    }
                }
                Ok(())
            }
            _ => {
                let (whole, fraction) = (digits / 100, digits % 100);
                if fraction == 0 {
                    write!(f, "{sign}{whole}e{e}")
                } else if fraction % 10 == 0 {
                    write!(f, "{sign}{whole}.{}e{e}", fraction / 10)
                } else {
                    write!(f, "{sign}{whole}.{fraction:02}e{e}")
                }
            }
        }
    }
}

/// `core::result::Result` specialised to the core's [`Error`].
pub type Result<T> = core::result::Result<T, Error>;

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::CapacityExceeded { capacity } => {
                write!(f, "capacity exceeded: the limit is {capacity} elements")
            }
            Error::BufferTooSmall {
                buffer,
                capacity,
                needed,
            } => write!(
                f,
                "buffer too small: {buffer} holds {capacity}, {needed} are needed"
            ),
            Error::NonFinite { parameter } => {
                write!(f, "non-finite value (NaN or infinity) in `{parameter}`")
            }
            Error::InvalidParameter { parameter } => {
                write!(f, "invalid value for parameter `{parameter}`")
            }
            Error::OutOfRange { parameter } => write!(f, "`{parameter}` is out of range"),
            Error::Overflow { parameter } => write!(
                f,
                "`{parameter}` is too large for the working precision: computing with it overflows"
            ),
            Error::EmptyData => f.write_str("empty data: at least one point is required"),
            Error::NotPositiveDefinite => f.write_str(
                "matrix is not positive definite, even after the largest jitter was added",
            ),
            Error::JitterLimit { needed, allowed } => write!(
                f,
                "ill-conditioned kernel matrix: it needs a diagonal jitter of {needed}, the \
                 conditioning policy allows {allowed}"
            ),
            Error::IllConditioned { condition, limit } => write!(
                f,
                "ill-conditioned kernel matrix: condition estimate {condition} exceeds {limit}, \
                 beyond what the working precision can be trusted with"
            ),
        }
    }
}

impl core::error::Error for Error {}

/// Returns `Ok(value)` when `value` is finite, else the [`Error::NonFinite`] naming `parameter`.
pub(crate) fn ensure_finite<T: crate::float::Real>(value: T, parameter: &'static str) -> Result<T> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::NonFinite { parameter })
    }
}

/// Checks that every value of `values` is finite.
pub(crate) fn ensure_all_finite<T: crate::float::Real>(
    values: &[T],
    parameter: &'static str,
) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::NonFinite { parameter })
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn display_names_the_offending_parameter_and_limit() {
        let e = Error::NonFinite {
            parameter: "noise_variance",
        };
        assert!(e.to_string().contains("noise_variance"));
        let e = Error::CapacityExceeded { capacity: 64 };
        assert!(e.to_string().contains("64"));
        let e = Error::BufferTooSmall {
            buffer: "samples (`steps` × `budget` target records)",
            capacity: 150,
            needed: 200,
        };
        assert_eq!(
            e.to_string(),
            "buffer too small: samples (`steps` × `budget` target records) holds 150, \
             200 are needed"
        );
        let e = Error::InvalidParameter {
            parameter: "length_scales",
        };
        assert!(e.to_string().contains("length_scales"));
        let e = Error::OutOfRange {
            parameter: "action",
        };
        assert!(e.to_string().contains("action"));
        assert!(Error::EmptyData.to_string().contains("empty"));
        assert!(
            Error::NotPositiveDefinite
                .to_string()
                .contains("positive definite")
        );
    }

    #[test]
    fn display_names_the_jitter_and_the_condition() {
        let e = Error::JitterLimit {
            needed: Number(1.5e-6),
            allowed: Number(3e-9),
        };
        let text = e.to_string();
        assert!(text.contains("1.5e-6") && text.contains("3e-9"), "{text}");
        let e = Error::IllConditioned {
            condition: Number(2e9),
            limit: Number(8e4),
        };
        let text = e.to_string();
        assert!(text.contains("2e9") && text.contains("80000"), "{text}");
        let shown = |v: f64| Number(v).to_string();
        assert_eq!(shown(0.13064821), "0.131");
        assert_eq!(shown(9.47), "9.47");
        assert_eq!(shown(-2.5e300), "-2.5e300");
        assert_eq!(shown(9.996), "10");
        assert_eq!(shown(999_999.0), "1e6");
        assert_eq!(shown(123_456.0), "123000");
        assert_eq!(shown(0.001_234_5), "0.00123");
        assert_eq!(shown(0.000_999_9), "0.001");
        assert_eq!(shown(0.010_5), "0.0105");
        assert_eq!(shown(12.5), "12.5");
        assert_eq!(shown(1.0), "1");
        assert_eq!(shown(-0.5), "-0.5");
        assert_eq!(shown(0.000_123), "1.23e-4");
        assert_eq!(shown(-40.0), "-40");
        assert_eq!(shown(5e-324), "4.94e-324");
        assert_eq!(shown(0.0), "0");
        assert_eq!(shown(f64::NEG_INFINITY), "-inf");
        assert_eq!(shown(f64::NAN), "NaN");
        assert_eq!(Number(0.5), Number(0.5));
        assert_ne!(Number(0.5), Number(0.25));
        assert_eq!(Number(0.25).value(), 0.25);
    }

    #[test]
    fn is_a_core_error() {
        fn takes(_: &dyn core::error::Error) {}
        takes(&Error::EmptyData);
    }

    #[test]
    fn finiteness_checks() {
        assert_eq!(ensure_finite(1.0f32, "x"), Ok(1.0));
        assert_eq!(
            ensure_finite(f64::NAN, "x"),
            Err(Error::NonFinite { parameter: "x" })
        );
        assert_eq!(
            ensure_all_finite(&[1.0f64, f64::INFINITY], "y"),
            Err(Error::NonFinite { parameter: "y" })
        );
        assert_eq!(ensure_all_finite::<f32>(&[], "y"), Ok(()));
    }
}
