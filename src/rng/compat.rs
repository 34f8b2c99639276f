//! Generators of other `rand_core` versions, passed to the core.
//!
//! The core's generator trait is [`rand_core::Rng`] of `rand_core` 0.10 (re-exported as
//! [`crate::rand_core`]). A HAL's hardware generator or a PRNG crate built on an older
//! `rand_core` implements that version's `RngCore` instead, which the compiler treats as
//! another trait; wrap it in `Rng06` (feature `rand_core_06`) or `Rng09` (feature
//! `rand_core_09`) and pass `&mut` the wrapper. A wrapper forwards every call unchanged,
//! so the same generator state gives the same draws.
//!
//! ```toml
//! awfqi = { version = "0.1", features = ["rand_core_06"] }
//! ```
//!
//! ```ignore
//! let mut rng = awfqi::rng::Rng06(hal_rng); // any rand_core 0.6 `RngCore`
//! kernel.step(&mut rng)?;
//! ```

/// The core's `TryRng` (infallible) for a wrapper of another version's `RngCore`, each call
/// forwarded unchanged.
#[cfg(any(feature = "rand_core_06", feature = "rand_core_09"))]
macro_rules! forward_rng {
    ($wrapper:ident, $trait:path) => {
        impl<R: $trait> rand_core::TryRng for $wrapper<R> {
            type Error = core::convert::Infallible;

            fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
                Ok(self.0.next_u32())
            }

            fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
                Ok(self.0.next_u64())
            }

            fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Self::Error> {
                self.0.fill_bytes(dst);
                Ok(())
            }
        }
    };
}

/// A `rand_core` 0.6 generator as the core's [`rand_core::Rng`] (feature `rand_core_06`).
/// Its fallible `try_fill_bytes` is not used: `fill_bytes` is, as the 0.6 trait's
/// infallible path.
#[cfg(feature = "rand_core_06")]
#[cfg_attr(docsrs, doc(cfg(feature = "rand_core_06")))]
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rng06<R>(pub R);

#[cfg(feature = "rand_core_06")]
forward_rng!(Rng06, rand_core_06::RngCore);

/// A `rand_core` 0.9 generator as the core's [`rand_core::Rng`] (feature `rand_core_09`).
#[cfg(feature = "rand_core_09")]
#[cfg_attr(docsrs, doc(cfg(feature = "rand_core_09")))]
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rng09<R>(pub R);

#[cfg(feature = "rand_core_09")]
forward_rng!(Rng09, rand_core_09::RngCore);

#[cfg(test)]
mod tests {
    /// A counter generator of each older trait: its draws are known in advance.
    #[allow(unused_imports)]
    use rand_core::Rng;

    #[cfg(feature = "rand_core_06")]
    #[test]
    fn rand_core_06_draws_pass_through_unchanged() {
        struct Counter(u64);
        impl rand_core_06::RngCore for Counter {
            fn next_u32(&mut self) -> u32 {
                self.next_u64() as u32
            }
            fn next_u64(&mut self) -> u64 {
                self.0 += 1;
                self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15)
            }
            fn fill_bytes(&mut self, dst: &mut [u8]) {
                dst.fill(0xAB);
            }
            fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), rand_core_06::Error> {
                self.fill_bytes(dst);
                Ok(())
            }
        }
        let mut rng = super::Rng06(Counter(0));
        assert_eq!(rng.next_u64(), 0x9E37_79B9_7F4A_7C15);
        assert_eq!(
            rng.next_u32(),
            2u64.wrapping_mul(0x9E37_79B9_7F4A_7C15) as u32
        );
        let mut bytes = [0u8; 3];
        rng.fill_bytes(&mut bytes);
        assert_eq!(bytes, [0xAB; 3]);
        // The core's draws take it: uniform() is next_u64's top 53 bits scaled to [0, 1).
        let u: f64 = crate::rng::uniform(&mut rng);
        let want = ((3u64.wrapping_mul(0x9E37_79B9_7F4A_7C15)) >> 11) as f64 / (1u64 << 53) as f64;
        assert_eq!(u, want);
    }

    #[cfg(feature = "rand_core_09")]
    #[test]
    fn rand_core_09_draws_pass_through_unchanged() {
        struct Counter(u64);
        impl rand_core_09::RngCore for Counter {
            fn next_u32(&mut self) -> u32 {
                self.next_u64() as u32
            }
            fn next_u64(&mut self) -> u64 {
                self.0 += 1;
                self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15)
            }
            fn fill_bytes(&mut self, dst: &mut [u8]) {
                dst.fill(0xCD);
            }
        }
        let mut rng = super::Rng09(Counter(0));
        assert_eq!(rng.next_u64(), 0x9E37_79B9_7F4A_7C15);
        assert_eq!(
            rng.next_u32(),
            2u64.wrapping_mul(0x9E37_79B9_7F4A_7C15) as u32
        );
        let mut bytes = [0u8; 2];
        rng.fill_bytes(&mut bytes);
        assert_eq!(bytes, [0xCD; 2]);
        let u: f64 = crate::rng::uniform(&mut rng);
        let want = ((3u64.wrapping_mul(0x9E37_79B9_7F4A_7C15)) >> 11) as f64 / (1u64 << 53) as f64;
        assert_eq!(u, want);
    }
}
