//! Shared pieces of the fuzz targets: a total byte reader that turns the fuzzer's bytes into
//! numbers (raw bit patterns, small decimals and the hard special values), the matching
//! writer used to build the seed corpora in `seeds/`, and the invariant checks every target
//! applies to the core's results.
//!
//! The reader never fails: when the bytes run out it returns zeros, so every input is a
//! valid test case and the seeds written by [`Seed`] decode to exactly the values written.

use awfqi::Error;

/// Special values the fuzzer reaches with one tag byte and one index byte.
pub const SPECIALS: [f64; 16] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.0,
    -0.0,
    f64::MIN_POSITIVE,
    f64::MAX,
    f64::MIN,
    5e-324,
    1e-300,
    1e300,
    f64::EPSILON,
    1e-10,
    1e10,
    3.4e38,
    1.2e-38,
];

/// Reads fuzz bytes as numbers and choices; never fails.
pub struct Bytes<'a> {
    data: &'a [u8],
}

impl<'a> Bytes<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    /// `true` when every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The next byte, or 0.
    pub fn u8(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    /// Two bytes, little-endian.
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    /// A flag from the low bit of one byte.
    pub fn bool(&mut self) -> bool {
        self.u8() & 1 == 1
    }

    /// Eight bytes as an `f64` bit pattern (little-endian).
    pub fn raw(&mut self) -> f64 {
        let mut bytes = [0u8; 8];
        for b in &mut bytes {
            *b = self.u8();
        }
        f64::from_le_bytes(bytes)
    }

    /// A number: tag byte `t % 4` = 0 a raw bit pattern, 1 a small decimal `i16 / 256`,
    /// 2 a special value of [`SPECIALS`], 3 a small integer `i8`.
    pub fn num(&mut self) -> f64 {
        match self.u8() % 4 {
            0 => self.raw(),
            1 => f64::from(self.u16() as i16) / 256.0,
            2 => SPECIALS[usize::from(self.u8()) % SPECIALS.len()],
            _ => f64::from(self.u8() as i8),
        }
    }

    /// An index in `0..n` from one byte (`n` must be 1..=256); larger values of the byte
    /// wrap, so out-of-range indices come from passing a larger `n` than the valid range.
    pub fn index(&mut self, n: usize) -> usize {
        usize::from(self.u8()) % n.max(1)
    }
}

/// Writes inputs that [`Bytes`] reads back exactly: the seed corpora are built with it.
#[derive(Default)]
pub struct Seed {
    /// The bytes written so far.
    pub bytes: Vec<u8>,
}

impl Seed {
    /// An empty seed.
    pub fn new() -> Self {
        Self::default()
    }

    /// One byte.
    pub fn u8(&mut self, b: u8) -> &mut Self {
        self.bytes.push(b);
        self
    }

    /// A flag.
    pub fn bool(&mut self, b: bool) -> &mut Self {
        self.u8(u8::from(b))
    }

    /// A number written as its raw bit pattern (tag 0), read back bit for bit.
    pub fn num(&mut self, x: f64) -> &mut Self {
        self.u8(0);
        self.bytes.extend_from_slice(&x.to_le_bytes());
        self
    }

    /// Several numbers.
    pub fn nums(&mut self, xs: &[f64]) -> &mut Self {
        for &x in xs {
            self.num(x);
        }
        self
    }
}

/// The kinds of [`Error`] a call is documented to return, for [`expect_kind`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// [`Error::CapacityExceeded`] or [`Error::BufferTooSmall`]: a capacity the caller chose.
    Capacity,
    /// [`Error::NonFinite`].
    NonFinite,
    /// [`Error::InvalidParameter`].
    Invalid,
    /// [`Error::OutOfRange`].
    OutOfRange,
    /// [`Error::EmptyData`].
    Empty,
    /// [`Error::NotPositiveDefinite`].
    NotPd,
    /// [`Error::JitterLimit`] or [`Error::IllConditioned`]: the GP's conditioning policy.
    Conditioning,
    /// [`Error::Overflow`]: a value too large for the precision.
    Overflow,
    /// A variant this list does not know yet (`Error` is `#[non_exhaustive]`): never
    /// documented, so [`expect_kind`] reports it.
    Unknown,
}

/// The kind of an error.
pub fn kind(e: &Error) -> Kind {
    match e {
        Error::CapacityExceeded { .. } | Error::BufferTooSmall { .. } => Kind::Capacity,
        Error::NonFinite { .. } => Kind::NonFinite,
        Error::InvalidParameter { .. } => Kind::Invalid,
        Error::OutOfRange { .. } => Kind::OutOfRange,
        Error::EmptyData => Kind::Empty,
        Error::NotPositiveDefinite => Kind::NotPd,
        Error::JitterLimit { .. } | Error::IllConditioned { .. } => Kind::Conditioning,
        Error::Overflow { .. } => Kind::Overflow,
        _ => Kind::Unknown,
    }
}

/// Panics (a fuzz finding) when `e` is not one of the documented kinds of `call`.
#[track_caller]
pub fn expect_kind(call: &str, e: &Error, allowed: &[Kind]) {
    assert!(
        allowed.contains(&kind(e)),
        "{call}: undocumented error {e:?} (documented: {allowed:?})"
    );
}

/// Panics when a value returned as a success is not finite.
#[track_caller]
pub fn finite(call: &str, what: &str, x: f64) {
    assert!(
        x.is_finite(),
        "{call}: success with non-finite {what} = {x}"
    );
}

/// `true` when the environment variable `AWFQI_FUZZ_TRACE` is set: the targets then print
/// each call they make, so a crash input can be turned into a regression test by hand
/// (`AWFQI_FUZZ_TRACE=1 cargo +nightly fuzz run TARGET ARTIFACT`).
pub fn tracing() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("AWFQI_FUZZ_TRACE").is_some())
}

/// Prints its arguments to stderr when [`tracing`] is on.
#[macro_export]
macro_rules! trace {
    ($($arg:tt)*) => {
        if $crate::tracing() {
            eprintln!($($arg)*);
        }
    };
}
