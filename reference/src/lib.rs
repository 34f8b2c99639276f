//! Independent reference implementations: `f64`, heap-allocated, written to be read and
//! checked by eye, never optimised. The core's differential tests and the harness's
//! `gp --reference` compare against these; they live in their own small crate so that the
//! core's tests do not need the whole harness.
//!
//! Section numbers ("spec §2.3", "§10") are sections of the algorithm reference,
//! `docs/algorithms.md` at the repository root.

pub mod gp;
pub mod identify;
