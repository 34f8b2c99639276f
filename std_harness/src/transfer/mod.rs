//! The transfer experiments (spec §3–§9, §11–§13) on any [`crate::domains::Domain`]: the
//! thesis's Chapter 5 and the IWFQI paper's Puddle World, water-reservoir (Dam) and Acrobot
//! curves, with every baseline. The protocol and the algorithms are generic over the state
//! dimension; the commands that run them are [`crate::commands::transfer`] and its
//! per-domain front ends.
//!
//! - [`domain_data`]: each domain's published source data, their layout, their
//!   generation and IWFQI's GPs;
//! - [`sources`]: source datasets (the published ones, a user's own in the same CSV layout,
//!   or freshly generated as each domain's paper says);
//! - [`gp`]: the GP fits (§4.2, or the published fixed kernels) on records;
//! - [`protocol`]: the common experiment protocol of §3 (episodic collection, evaluation,
//!   per-step records);
//! - [`algorithms`]: FQI, IWFQI (mean, heuristic, ideal weights), RBT, SDT, AWFQI and
//!   AWFQI_oracle on the faithful std path, and `awfqi-embedded` and `awfqi-adaptive`, the
//!   core's algorithms;
//! - [`score_tables`]: the oracle and realistic score tables (§11), built once per
//!   experiment and shared by all runs;
//! - [`results`]: result files in the reference's layout, summaries, merging of run ranges;
//! - [`result_dir`]: an output directory shared by invocations: locked, checked, resumable;
//! - [`metrics`]: transfer metrics (jump-start, asymptotic performance, total reward,
//!   transfer ratio, time to threshold);
//! - [`figures`]: learning curves and sample scatters;
//! - [`anchors`]: the plant suite's anchors (the random policy's return, dynamic
//!   programming on the mean model, hand-written controllers);
//! - [`suite`]: the plant suite: its plants, their budget schedules and the summary of
//!   their runs against the anchors.
//!
//! **Seeding** (spec §1's \[CHOICE\]): every random stream is a ChaCha8 generator seeded from
//! a hash of the experiment seed and a purpose: (seed, RUN, algorithm, run index) for a run,
//! (seed, SCORE_TABLE) for the realistic tables, (seed, SOURCE_GENERATION, source) for
//! generated source data, (seed, IDEAL_WEIGHTS) for the sampled means of the ideal weights, (seed, ANCHORS, k)
//! for the anchors' rollouts. No stream depends on thread scheduling or on which other
//! algorithms or runs are computed, so `--runs 0..5` and `--runs 5..10` give the same runs
//! as `--runs 0..10`.

pub mod algorithms;
pub mod anchors;
pub mod domain_data;
pub mod figures;
pub mod gp;
pub mod metrics;
pub mod protocol;
pub mod result_dir;
pub mod results;
pub mod score_tables;
pub mod sources;
pub mod suite;
pub mod summary;

/// Stream purpose: one run of one algorithm.
pub const RUN: u64 = 1;
/// Stream purpose: the realistic score tables' source-GP fits.
pub const SCORE_TABLE: u64 = 2;
/// Stream purpose: generating a source dataset.
pub const SOURCE_GENERATION: u64 = 3;
/// Stream purpose: the sampled model steps of the ideal weights (the Dam's).
pub const IDEAL_WEIGHTS: u64 = 4;

pub use crate::seeding::stream;
