//! # awfqi: active transfer of samples in fixed memory
//!
//! A `#![no_std]` kernel for a controller that must learn a *target* task (your plant) from
//! samples of related *source* tasks, querying a generative model of the target only a limited
//! number of times: it chooses where to query, weights every source sample by its importance
//! for the target, and solves the target with weighted fitted Q-iteration (AWFQI). No
//! allocator, no panics, all memory lent by you with its size fixed at compile time.
//!
//! ## What to use
//!
//! - **Your plant** implements [`GenerativeModel`](model::GenerativeModel) (one sampled
//!   transition from any state-action pair; states are `[T; D]` for any `D`). Built-in
//!   plants: [`env`](mod@env) (Puddle World, Grid World, the Dam, Acrobot).
//! - **The recommended learner**, [`AdaptiveAwfqi`](adaptive::AdaptiveAwfqi): each step's
//!   queries in sub-batches that verify the current greedy policy in the generative model,
//!   draw the rest where the target surprised the sources, then re-plan by value iteration
//!   on a grid model of the records. [`AdaptiveAwfqi::builder`](adaptive::AdaptiveAwfqi::builder)
//!   sets it up from the plant, the source records, the budget, the state ranges and the
//!   start state; [`adaptive_storage!`] declares its memory by named capacities.
//! - **The thesis's algorithm as published**, [`Awfqi`](thesis::Awfqi) (module
//!   [`thesis`]): each step's queries drawn from a score table of where the sources
//!   disagree ([`Awfqi::builder`](thesis::Awfqi::builder)).
//! - **Parts on their own:** [`gp`] (fixed-capacity Gaussian-process regression), [`weights`]
//!   (importance weights), [`fqi`] (weighted FQI: model sweep, table, tiles, kernel averaging,
//!   Extra-Trees), [`identify`] and [`planning`] (identification among finite MDPs),
//!   [`evaluation`] (greedy rollouts).
//!
//! Every item lives at one path, in its module; [`prelude`] brings what an embedder uses in
//! one import (`use awfqi::prelude::*;`, or `use awfqi::*;` for the modules as well).
//!
//! ## Memory
//!
//! [`adaptive_storage!`] declares one block with all the memory a learner and its set-up
//! write, from named capacities (`gp_points: 32, sources: 3, …`); every size follows from
//! them, the block's `new()` is `const` and all-zero, so a `static` of it lands in `.bss`.
//! A capacity of 0 does not compile; a block too small for the run (steps × budget target
//! records, one weight per source record, …) is refused by the builder with
//! [`Error::BufferTooSmall`] before the first GP fit. [`awfqi_storage!`] declares the
//! thesis's learner's block the same way (its builder's `steps` refuses a target buffer too
//! short for the run); code generic over the scalar uses
//! [`AwfqiStorage`](thesis::AwfqiStorage) or any [`AwfqiBuffers`](thesis::AwfqiBuffers). Measured footprints (flash, RAM, stack per
//! configuration on a Cortex-M4F) are in the repository's `docs/footprint.md`, written by
//! `scripts/footprint`.
//!
//! ## Errors, randomness, guarantees
//!
//! - Every fallible call returns [`Result`] with a typed [`Error`] naming the parameter or
//!   capacity at fault, and leaves your data as it was. A step that fails part-way keeps the
//!   records already queried, the Q-function keeps its last fit and the step counter does
//!   not advance, so the next step can continue.
//! - Randomness comes only from the generator you pass (`&mut impl rand_core::Rng`): the same
//!   seed gives the same bytes, on the host and on the device.
//! - No allocation (there is no `alloc`), no panics: `unwrap`, `expect`, `panic!` and
//!   indexing are denied by lint, and the repository's `scripts/no-panic` links every public
//!   entry point for a Cortex-M4F with a panic handler that does not exist.
//! - Dependencies: `libm` (the float functions a `no_std` target lacks) and `rand_core` (the
//!   generator trait every randomised call takes), nothing else without a feature.
//! - Cargo features: `defmt` (`defmt::Format` for [`Error`] and the public data types);
//!   `rand_core_06`, `rand_core_09` (generators of older `rand_core` versions, [`rng::compat`]);
//!   `nalgebra` (Q-values, states and plants as `nalgebra::SVector`s) and `heapless` (a step's
//!   warnings as a `heapless::Vec`), both in [`interop`].
//!
//! ## Example: a room heater learned from two other heaters
//!
//! The recommended learner on a plant of your own: the memory declared by name, the set-up
//! in one builder (settings scaled from the source records, each source's reward GP fitted
//! once, a model sweep over the state range), then steps that verify the current plan,
//! query where the plant surprised the sources and re-plan.
//!
//! ```rust
//! use awfqi::prelude::*;
//! use rand_chacha::ChaCha8Rng;
//! use rand_core::{Rng, SeedableRng};
//!
//! /// A room heater: normalised temperature s ∈ [0, 1], action 0 = off, 1 = on.
//! /// s′ = s + gain·a − 0.1·s (+ noise), reward −|s − 0.5|: hold the set-point 0.5.
//! #[derive(Clone, Copy)]
//! struct Heater {
//!     gain: f32,
//! }
//!
//! impl GenerativeModel<f32> for Heater {
//!     type State = [f32; 1];
//!     fn num_actions(&self) -> usize {
//!         2
//!     }
//!     fn query<R: Rng + ?Sized>(
//!         &self,
//!         [s]: [f32; 1],
//!         action: usize,
//!         rng: &mut R,
//!     ) -> awfqi::Result<Transition<[f32; 1], f32>> {
//!         if !(0.0..=1.0).contains(&s) || action > 1 {
//!             return Err(Error::OutOfRange { parameter: "state" });
//!         }
//!         let noise = (rng.next_u32() as f32 / u32::MAX as f32 - 0.5) * 0.02; // the caller's randomness
//!         let next = (s + self.gain * action as f32 - 0.1 * s + noise).clamp(0.0, 1.0);
//!         let reward = -(s - 0.5).abs();
//!         Ok(Transition { state: [s], action, reward, next_state: [next], absorbing: false })
//!     }
//! }
//!
//! // All the memory the learner and its set-up write (a `static` in `.bss` on a device).
//! awfqi::adaptive_storage! {
//!     struct HeaterMemory {
//!         scalar: f32, state_dim: 1, actions: 2, gp_points: 16, steps: 2, budget: 10,
//!         sources: 2, source_records: 40, source_posteriors: 40, candidates: 40, sweep_cells: 10,
//!     }
//! }
//!
//! # fn main() -> awfqi::Result<()> {
//! let mut rng = ChaCha8Rng::seed_from_u64(7);
//! // Source data: 20 records of each of two other heaters (on a device: tables in flash).
//! let mut data = [[Transition::EMPTY; 20]; 2];
//! for (gain, records) in [0.15, 0.3].into_iter().zip(&mut data) {
//!     for (i, r) in records.iter_mut().enumerate() {
//!         *r = Heater { gain }.query([i as f32 / 19.0], i % 2, &mut rng)?;
//!     }
//! }
//! let records: [&[Transition<[f32; 1], f32>]; 2] = [&data[0], &data[1]];
//!
//! // 10 queries a step, temperatures in [0, 1], verification rollouts from s = 0.2.
//! let mut memory = HeaterMemory::new();
//! let mut kernel = AdaptiveAwfqi::builder(Heater { gain: 0.2 }, &records, 10, [(0.0, 1.0)], [0.2])
//!     .rewards(RewardModel::Pooled) // the reward depends on the state only
//!     .build(&mut memory, &mut rng)?;
//! kernel.plan(&mut rng)?; // the plan on the sources alone: set-up, once
//! for _ in 0..2 {
//!     kernel.step(&mut rng)?; // 10 queries in 3 sub-batches, each then re-planned
//! }
//! // The greedy policy heats when cold and not when hot.
//! assert_eq!(kernel.q().greedy_action([0.2])?, 1);
//! assert_eq!(kernel.q().greedy_action([0.9])?, 0);
//! // Every derived setting can be read back; bad input is a typed error, never a panic.
//! assert_eq!((kernel.config().candidates(), kernel.config().horizon()), (40, 10));
//! assert!(kernel.q().greedy_action([f32::NAN]).is_err());
//! # Ok(())
//! # }
//! ```
//!
//! The thesis's AWFQI on the same plant is an example of the [`thesis`] module; Extra-Trees
//! as the Q-function on their own, one of [`fqi`]. `use awfqi::*;` brings every module,
//! [`Error`] and [`Result`] (and `use awfqi::prelude::*;` the items):
//!
//! ```rust
//! use awfqi::*;
//! let grid = fqi::CellGrid::<f32, 1>::cube(0.0, 1.0, 4)?;
//! assert_eq!(grid.len(), 4);
//! # Ok::<(), Error>(())
//! ```
//!
//! The experiments, their results and the harness that runs them are described in the
//! repository's README.md and `docs/` (`docs/results-puddle.md` for the headline comparison,
//! `docs/algorithms.md` for every formula).
//!
//! The embedding guide (the repository's `docs/embedding.md`) follows: depending on the crate,
//! settings derived from your logs, the recommended learner, the step reports' warnings.
//!
#![doc = include_str!("../docs/embedding.md")]
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
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

pub mod adaptive;
pub mod alias;
pub mod env;
mod error;
pub mod evaluation;
pub mod float;
pub mod fqi;
pub mod gp;
pub mod identify;
pub mod interop;
pub mod model;
pub mod planning;
pub mod policy;
pub mod record_gp;
pub mod rng;
pub mod score;
pub mod thesis;
pub mod weights;

/// The README's examples, compiled and run as doctests (the crate docs are the embedding
/// guide, `docs/embedding.md`).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

pub use error::{Error, Number, Result};
/// The `rand_core` (0.10) whose [`Rng`](rand_core::Rng) every randomised call takes:
/// depend on this one (`awfqi::rand_core::Rng`, `awfqi::rand_core::SeedableRng`) and the
/// versions cannot drift apart. Generators of `rand_core` 0.6 and 0.9 go through
/// [`rng::compat`].
pub use rand_core;

/// What an embedder of the transfer path uses, in one import: `use awfqi::prelude::*;`.
/// Every item here also lives at one path in its own module (the prelude is the only
/// second path).
pub mod prelude {
    pub use crate::adaptive::{
        AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, AdaptiveStorage, MeanFunction,
        ValidAdaptiveConfig,
    };
    pub use crate::adaptive_storage;
    pub use crate::alias::AliasEntry;
    pub use crate::awfqi_storage;
    pub use crate::error::{Error, Result};
    pub use crate::evaluation::{
        Evaluation, EvaluationProtocol, MultiStartProtocol, Rollout, evaluate, evaluate_greedy,
        evaluate_greedy_multi_start, evaluate_multi_start, rollout,
    };
    pub use crate::float::Real;
    pub use crate::fqi::{
        ANCHOR_LINKS, AnchorEntry, AnchorFqi, AnchorParts, AnchorStorage, AnchorSweep,
        Approximator, CellGrid, EmptyCells, ExtraTrees, FqiConfig, FqiEntry, Greedy, HybridFqi,
        Kernel, KnnFqi, KnnRecord, KnnStorage, ModelFqi, ModelSweep, Neighbours, QFunction,
        QStorage, RewardModel, SampleSet, SweepEntry, SweepFqi, SweepNode, SweepStorage,
        TabularFqi, TileFqi, Tilings, TreeFqi, TreeNode, TreeRecord, TreeStorage,
    };
    pub use crate::gp::{
        Conditioning, Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull,
    };
    pub use crate::model::{GenerativeModel, SourceMeans, SourceModel, Transition};
    pub use crate::policy::{EpsilonGreedyPolicy, Policy, UniformPolicy};
    pub use crate::record_gp::{Dims, GpTraining, Output, StatePlusAction, SubsetRule};
    pub use crate::score::{
        GpSourceModel, PointGrid, RowSampler, RowSet, ScoreColumn, ScoreTable, Scores,
    };
    pub use crate::thesis::{
        Awfqi, AwfqiBuffers, AwfqiBuilder, AwfqiConfig, AwfqiStorage, SourceData, SourceScales,
        StepReport, ValidAwfqiConfig, Warning, Warnings,
    };
    pub use crate::weights::{Estimator, NoiseSubtraction, Posterior, WeightParams};
}
