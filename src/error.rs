//! The one error type of the core.
//!
//! Small and `Copy` so it can be returned from an interrupt handler or logged with `defmt`
//! without allocating. Every variant names what was wrong, so a firmware engineer reading
//! a log line knows which argument to fix.

use core::fmt;

/// Everything that can go wrong in the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A fixed capacity would be exceeded; `capacity` is the limit that was hit.
    CapacityExceeded {
        /// The capacity (number of elements) of the container that is full.
        capacity: usize,
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
    /// An operation needs at least one data point and got none.
    EmptyData,
    /// A kernel matrix could not be factorised even after the largest jitter was added to
    /// its diagonal.
    NotPositiveDefinite,
}

/// `core::result::Result` specialised to the core's [`Error`].
pub type Result<T> = core::result::Result<T, Error>;

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::CapacityExceeded { capacity } => {
                write!(f, "capacity exceeded: the limit is {capacity} elements")
            }
            Error::NonFinite { parameter } => {
                write!(f, "non-finite value (NaN or infinity) in `{parameter}`")
            }
            Error::InvalidParameter { parameter } => {
                write!(f, "invalid value for parameter `{parameter}`")
            }
            Error::OutOfRange { parameter } => write!(f, "`{parameter}` is out of range"),
            Error::EmptyData => f.write_str("empty data: at least one point is required"),
            Error::NotPositiveDefinite => f.write_str(
                "matrix is not positive definite, even after the largest jitter was added",
            ),
        }
    }
}

impl core::error::Error for Error {}

/// Returns `Ok(value)` when `value` is finite, else the [`Error::NonFinite`] naming `parameter`.
pub(crate) fn ensure_finite<T: crate::Real>(value: T, parameter: &'static str) -> Result<T> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::NonFinite { parameter })
    }
}

/// Checks that every value of `values` is finite.
pub(crate) fn ensure_all_finite<T: crate::Real>(
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
