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

pub mod alias;
pub mod awfqi;
pub mod dataset;
pub mod env;
pub mod error;
pub mod evaluation;
pub mod float;
pub mod fqi;
pub mod gp;
pub mod identify;
pub mod planning;
pub mod policy;
pub mod rng;
pub mod score;
pub mod weights;

pub use error::{Error, Result};
pub use float::Real;
