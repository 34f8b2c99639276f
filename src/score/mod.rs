//! Score tables (spec §11): where do the sources disagree, and so where is a target query
//! worth its price?
//!
//! A score table is a list of state-action rows — a **candidate set** the caller chooses.
//! For each row and each source `j` a [`SourceModel`](crate::model::SourceModel) gives the source's mean reward `ρʲ_r`
//! and mean next state `ρʲ_s′` (one value per state coordinate), and the row's scores are the
//! population variances over the sources (division by `m`): `V_r` and one `V_k` per
//! next-state coordinate, and their sum.
//!
//! - **Candidate sets** ([`RowSet`], §11.1): a grid of points (a [`PointGrid`], borders
//!   included) times every action ("grid mode"); explicit `(s, a)` pairs the caller lists;
//!   the `(s, a)` of every source record, source by source, duplicates kept ("source-data
//!   mode"); or a grid followed by source rows ("both"). Puddle World's thesis grids are
//!   [`crate::env::PuddleWorld::score_grid`].
//! - **Value sources** ([`SourceModel`](crate::model::SourceModel)): the sources' noise-free mean functions give the
//!   *oracle* table (a plant's noise-free mean functions, e.g. Puddle World's); the
//!   posterior means of one GP per source and output give the *realistic* table
//!   ([`GpSourceModel`], or [`ScoreTable::realistic`] with a single GP in memory at a time).
//! - **Sampling** (§11.3): [`ScoreTable::sampler`] builds an
//!   [`AliasTable`](crate::alias::AliasTable) on one column (the thesis uses `V_r`), so a
//!   budget of `n` rows is drawn with replacement in O(1) per draw ([`RowSampler`]); a
//!   column that sums to 0 is sampled uniformly **\[spec CHOICE\]**.
//!
//! The values live in caller storage, one [`Scores`] per row (`D + 1` `T`: 12 bytes in `f32`
//! for a 2-D state; the sum column is computed on read), so the same code fills the
//! harness's 40 804-row table and a coarse one on a microcontroller. Grid rows are not
//! stored at all: a row index maps to its `(s, a)` arithmetically.
//!
//! Variances are computed on values shifted by the first source's value, so a row where all
//! sources agree exactly has score exactly 0 (and the shift keeps the computation accurate
//! when the values are large and close).
//!
//! [`SourceModel`]: crate::model::SourceModel

mod points;
mod rows;
mod sampler;
mod source_model;
mod table;

pub use points::PointGrid;
pub use rows::RowSet;
pub use sampler::RowSampler;
pub use source_model::GpSourceModel;
pub use table::{ScoreColumn, ScoreRow, ScoreTable, Scores};

#[cfg(test)]
mod tests;
