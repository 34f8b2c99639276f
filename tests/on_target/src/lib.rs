//! Shared pieces of the on-target images: the host-computed expected values ([`golden`]),
//! tolerance checks, and a tiny probe ([`probe`]) that paints the stack, measures its
//! high-water mark and reports through semihosting without pulling in `core::fmt`.
#![no_std]

pub mod golden;
pub mod probe;

/// `|actual − expected| ≤ abs + rel·|expected|`.
pub fn close(actual: f64, expected: f64, abs: f64, rel: f64) -> bool {
    let diff = actual - expected;
    let diff = if diff < 0.0 { -diff } else { diff };
    let scale = if expected < 0.0 { -expected } else { expected };
    diff <= abs + rel * scale
}
