//! # awfqi — active transfer of samples, allocation-free
//!
//! An embeddable kernel for *active transfer of samples* in reinforcement learning: a
//! controller that holds samples from several source tasks scores state-action pairs by how
//! much the sources disagree, spends a limited budget of generative-model queries on the
//! target task where the disagreement is largest, weights every source sample by its
//! importance for the target, and solves the target with weighted fitted Q-iteration (AWFQI).
//!
//! Rules of this crate, each one a promise to whoever embeds it:
//! - `#![no_std]`, no `alloc`: capacities are const generics, exceeding one is an [`Error`].
//! - Every fallible function returns [`Result`]; nothing panics on any input.
//! - Randomness comes only from the caller's [`rand_core::Rng`]; the same seed gives the
//!   same result.
//!
//! The algorithms and constants follow `spec/algorithms.md` of the project (section numbers
//! in the docs, e.g. "§2.3", refer to it).
#![no_std]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]
#![deny(missing_docs)]

pub mod env;
pub mod error;
pub mod float;
pub mod gp;
pub mod identify;
pub mod planning;
pub mod rng;

pub use error::{Error, Result};
pub use float::Real;
