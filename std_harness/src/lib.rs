//! The std side of awfqi: subcommands of the `awfqi-harness` binary, the faithful `f64`
//! algorithms of the experiments, plots. (The independent reference implementations the
//! core is tested against are the `awfqi-reference` crate.)
//!
//! Section numbers in these docs ("spec §7.3", "§12") are sections of the algorithm
//! reference, `docs/algorithms.md` at the repository root.

pub mod commands;
pub mod domains;
pub mod forest_fqi;
pub mod frozen_trees;
pub mod gp_large;
pub mod identification;
pub mod joint_q;
pub mod plot;
pub mod run_range;
pub mod seeding;
pub mod store;
pub mod transfer;
pub mod trees;
