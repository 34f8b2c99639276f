//! Weighted fitted Q-iteration (spec §5, §7.2 step 5) in fixed memory.

mod config;
mod fill;
mod grid;
pub mod knn;
mod q_function;
mod samples;
mod table;
mod tiles;
pub mod trees;

pub use config::{EmptyCells, FqiConfig};
pub use grid::CellGrid;
pub use knn::{Kernel, KnnFqi, KnnRecord, KnnStorage, Neighbours};
pub use q_function::{Approximator, Greedy, QFunction, QStorage};
pub use samples::SampleSet;
pub use table::{FqiEntry, TabularFqi};
pub use tiles::{TileFqi, Tilings};
pub use trees::{ExtraTrees, TreeFqi, TreeNode, TreeRecord, TreeStorage};
