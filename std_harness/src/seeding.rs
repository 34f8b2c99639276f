//! Seeded random streams of the experiment commands: every stream is a ChaCha8 generator
//! seeded from a hash of (`--seed`, purpose, indices…), so a run's randomness depends only
//! on what it is, never on thread scheduling or on which other runs an invocation computes.

use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// A seeded stream: ChaCha8 from a SplitMix64 hash of the seed and the parts.
pub fn stream(seed: u64, parts: &[u64]) -> ChaCha8Rng {
    fn mix(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    let mut h = mix(seed);
    for &p in parts {
        h = mix(h ^ mix(p));
    }
    ChaCha8Rng::seed_from_u64(h)
}
