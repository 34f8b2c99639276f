#![doc = include_str!("../README.md")]
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
pub mod policy;
pub mod rng;

pub use error::{Error, Result};
pub use float::Real;
