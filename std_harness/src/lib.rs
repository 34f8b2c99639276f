//! The std side of awfqi: subcommands of the `awfqi-harness` binary and an independent
//! reference implementation (f64, heap, written for clarity) that the core is tested against.
//!
//! Section numbers in these docs ("spec §7.3", "§12") are sections of the algorithm
//! reference, `docs/algorithms.md` at the repository root.

pub mod commands;
pub mod domains;
pub mod fqi;
pub mod gp_large;
pub mod plot;
pub mod puddle;
pub mod reference;
pub mod seeding;
pub mod trees;
