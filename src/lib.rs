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
//! - **Your plant** implements [`GenerativeModel`] (one sampled transition from any
//!   state-action pair; states are `[T; D]` for any `D`) and, if you know them, its noise-free
//!   means as [`SourceModel`]. Built-in plants: [`env`](mod@env) (Puddle World, Grid World,
//!   the Dam, Acrobot).
//! - **The kernel.** [`AdaptiveAwfqi`] is the recommended one: each step's queries in
//!   sub-batches that verify the current greedy policy in the generative model, draw the rest
//!   where the target surprised the sources, then re-plan ([`AdaptiveConfig::recommended`],
//!   [`AdaptiveStorage`]; on Puddle World 39 KB of RAM and about 10⁸ Cortex-M4F instructions
//!   a step, the repository's `docs/embedded-adaptive.md`). [`Awfqi`] is the thesis's algorithm as published: each step's
//!   queries drawn from a score table, computed once, of where the sources disagree
//!   ([`Awfqi::builder`], [`AwfqiConfig::thesis`], [`AwfqiStorage`]).
//! - **The Q-function** is a value, [`Approximator`]: a model sweep ([`ModelSweep`]: value
//!   iteration on the corners of a grid over a reward, step and absorption model of the
//!   weighted records, so an iteration costs nodes × actions backups whatever the number of
//!   records; the adaptive kernel's recommended one), a table over cells ([`CellGrid`]), tile
//!   coding ([`Tilings`]), kernel averaging over the records ([`Kernel`]) or Extra-Trees
//!   ([`ExtraTrees`]; [`ExtraTrees::streamed`] grows each tree in one scratch tree, so 50
//!   trees take the memory of one, at the price of compute).
//! - **Parts on their own:** [`gp`] (fixed-capacity Gaussian-process regression with a
//!   conditioning policy), [`weights`] (importance weights), [`fqi`] (weighted FQI),
//!   [`identify`] and [`planning`] (Bayesian identification among finite MDPs), [`evaluation`]
//!   (greedy rollouts).
//!
//! ## Capacities
//!
//! Every buffer is a const generic of one storage block that fits in a `static` (its `new()`
//! is `const` and all-zero, so it lands in `.bss` and costs no flash). For
//! `AwfqiStorage<T, D, I, N, Q, W, R, E>`:
//!
//! | parameter | what | how to size it |
//! |---|---|---|
//! | `T` | `f32` or `f64` | `f32` on an FPU-less or single-precision MCU |
//! | `D`, `I` | state dimension, GP input dimension | `I = D + 1` (a wrong pair does not compile) |
//! | `N` | points of the target reward GP | memory grows as `N²` (`N = 24`: 2.8 KB in `f32`, `N = 64`: 17.7 KB) |
//! | `Q` | target samples | steps × queries per step |
//! | `W` | reward weights | the number of source records |
//! | `R` | alias entries | the number of candidate rows |
//! | `E` | FQI entries | cells × actions for a table (other approximators: their own storage) |
//!
//! [`AdaptiveStorage`] adds candidate slots (rows scored per sub-batch), path states (the
//! budget) and one belief per source; a model sweep's nodes and entries are a
//! [`SweepStorage`] of their own. A buffer that is too short is
//! [`Error::CapacityExceeded`] when the kernel is built, never a write past its end.
//! Measured footprints (flash, RAM, stack per configuration on a Cortex-M4F) are in the
//! repository's `docs/footprint.md`; the recommended Puddle World configuration of
//! [`Awfqi`] fits in 32 KiB of RAM.
//!
//! ## Errors, randomness, guarantees
//!
//! - Every fallible call returns [`Result`] with a typed [`Error`] naming the parameter or
//!   capacity at fault, and leaves your data as it was. A kernel step that fails part-way
//!   keeps the records already queried, the Q-function keeps its last fit and the step
//!   counter does not advance, so the next step can continue.
//! - Randomness comes only from the generator you pass (`&mut impl rand_core::Rng`): the same
//!   seed gives the same bytes, on the host and on the device.
//! - No allocation (there is no `alloc`), no panics: `unwrap`, `expect`, `panic!` and
//!   indexing are denied by lint, and the repository's `scripts/no-panic` links every public
//!   entry point for a Cortex-M4F with a panic handler that does not exist.
//! - Cargo features: `defmt` (`defmt::Format` for [`Error`] and the public data types);
//!   `rand_core_06`, `rand_core_09` (generators of older `rand_core` versions, [`rng::compat`]).
//! - Dependencies: `libm`, `nalgebra` (no default features), `heapless`, `rand_core`.
//!
//! ## Example: a room heater learned from two other heaters
//!
//! [`AdaptiveAwfqi`], the recommended kernel, on a plant of your own: each source's reward GP
//! is fitted once and kept as a mean function and as stored posteriors; then every step
//! verifies the current plan in the plant, queries where the plant surprised the sources, and
//! re-plans by value iteration on a grid model of the records ([`ModelSweep`]).
//!
//! ```rust
//! use awfqi::record_gp::predict_posteriors;
//! use awfqi::{
//!     AdaptiveAwfqi, AdaptiveConfig, AdaptiveStorage, GenerativeModel, MeanFunction, ModelSweep,
//!     NoiseSubtraction, PointGrid, Posterior, RewardModel, RowSet, SourceData, SourceMeans,
//!     SourceModel, SweepStorage, Transition,
//! };
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
//! impl SourceModel<f32, 1> for Heater {
//!     fn predict(&self, [s]: [f32; 1], action: usize) -> awfqi::Result<SourceMeans<f32, 1>> {
//!         if !(0.0..=1.0).contains(&s) || action > 1 {
//!             return Err(awfqi::Error::OutOfRange { parameter: "state" });
//!         }
//!         let next = s + self.gain * action as f32 - 0.1 * s;
//!         Ok(SourceMeans { reward: -(s - 0.5).abs(), next_state: [next.clamp(0.0, 1.0)] })
//!     }
//! }
//!
//! impl GenerativeModel<f32> for Heater {
//!     type State = [f32; 1];
//!     fn num_actions(&self) -> usize {
//!         2
//!     }
//!     fn query<R: Rng + ?Sized>(
//!         &self,
//!         state: [f32; 1],
//!         action: usize,
//!         rng: &mut R,
//!     ) -> awfqi::Result<Transition<[f32; 1], f32>> {
//!         let mean = self.predict(state, action)?;
//!         let noise = (rng.next_u32() as f32 / u32::MAX as f32 - 0.5) * 0.02; // all randomness from the caller
//!         let next_state = [(mean.next_state[0] + noise).clamp(0.0, 1.0)];
//!         Ok(Transition { state, action, reward: mean.reward, next_state, absorbing: false })
//!     }
//! }
//!
//! # fn main() -> awfqi::Result<()> {
//! let mut rng = ChaCha8Rng::seed_from_u64(7);
//! // Source data: 20 records from each of two other heaters (on a device: tables in flash).
//! let sources = [Heater { gain: 0.15 }, Heater { gain: 0.3 }];
//! let mut data = [[Transition::EMPTY; 20]; 2];
//! for (heater, records) in sources.iter().zip(&mut data) {
//!     for (i, r) in records.iter_mut().enumerate() {
//!         *r = heater.query([i as f32 / 19.0], i % 2, &mut rng)?;
//!     }
//! }
//! let records: [&[Transition<[f32; 1], f32>]; 2] = [&data[0], &data[1]];
//!
//! // 10 queries per step, verification rollouts of 20 steps from s = 0.2, the state box [0, 1].
//! let mut config = AdaptiveConfig::recommended(10, [0.2], 20, 0.3, [(0.0, 1.0)]);
//! config.awfqi.gp_training.search.restarts = 1;
//! let config = config.validate()?;
//!
//! // All the memory the loop writes (`static`s in `.bss` on a device): a 16-point GP over
//! // (s, a), 2 steps × 10 queries, 40 source records, 42 candidate slots, no table entries,
//! // 10 verified states, 2 source beliefs; the FQI's 11 nodes × 2 actions; and the set-up's
//! // reward mean function and stored posteriors of each source.
//! let mut storage = AdaptiveStorage::<f32, 1, 2, 16, 20, 40, 42, 0, 10, 2>::new();
//! let mut sweep = SweepStorage::<f32, 1, 22, 11>::new();
//! let mut means = [MeanFunction::<f32, 16, 2>::EMPTY; 2];
//! let mut posteriors = [Posterior::default(); 40];
//!
//! // Set-up: each source's reward GP, fitted in the kernel's GP, kept as its mean function
//! // and as the posterior at each of its records.
//! let mut buffers = storage.buffers();
//! for ((mean, source), stored) in means.iter_mut().zip(records).zip(posteriors.chunks_mut(20)) {
//!     mean.fit_rewards(buffers.gp, source, &config.awfqi.gp_training, config.awfqi.subset, &mut rng)?;
//!     predict_posteriors(buffers.gp, source, NoiseSubtraction::Reference, stored)?;
//! }
//! buffers.fqi = sweep.storage();
//! // FQI by value iteration on 11 nodes over [0, 1]; the reward depends on the state only.
//! let q = ModelSweep::cube(0.0, 1.0, 10)?.with_rewards(RewardModel::Pooled);
//! let candidates = RowSet::grid(PointGrid::spanning([0.0], [1.0], 0.05)?, 2)?;
//! let data = SourceData::new(&records, &posteriors)?;
//! let mut kernel =
//!     AdaptiveAwfqi::new(config, q, data, &means, candidates, Heater { gain: 0.2 }, buffers)?;
//! kernel.plan(&mut rng)?; // the plan on the sources alone: set-up, once
//! for _ in 0..2 {
//!     let report = kernel.step(&mut rng)?; // 10 queries in 3 sub-batches, each then re-planned
//!     assert!(report.wr_eff > 0.0);
//! }
//! // The greedy policy heats when cold and not when hot.
//! assert_eq!(kernel.q().greedy_action([0.2])?, 1);
//! assert_eq!(kernel.q().greedy_action([0.9])?, 0);
//!
//! // Bad input is a typed error, never a panic.
//! assert!(kernel.q().greedy_action([f32::NAN]).is_err());
//! # Ok(())
//! # }
//! ```
//!
//! The thesis's AWFQI ([`Awfqi`]) on the same plant: the builder performs its whole set-up
//! once (source reward GPs → stored posteriors → score table over your candidate pairs →
//! sampler → source data → FQI table).
//!
//! ```rust
//! use awfqi::{
//!     Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, GenerativeModel, PointGrid, Posterior, RowSet,
//!     Scores, SourceMeans, SourceModel, Transition,
//! };
//! use rand_chacha::ChaCha8Rng;
//! use rand_core::{Rng, SeedableRng};
//! # #[derive(Clone, Copy)]
//! # struct Heater {
//! #     gain: f32,
//! # }
//! # impl SourceModel<f32, 1> for Heater {
//! #     fn predict(&self, [s]: [f32; 1], action: usize) -> awfqi::Result<SourceMeans<f32, 1>> {
//! #         if !(0.0..=1.0).contains(&s) || action > 1 {
//! #             return Err(awfqi::Error::OutOfRange { parameter: "state" });
//! #         }
//! #         let next = s + self.gain * action as f32 - 0.1 * s;
//! #         Ok(SourceMeans { reward: -(s - 0.5).abs(), next_state: [next.clamp(0.0, 1.0)] })
//! #     }
//! # }
//! # impl GenerativeModel<f32> for Heater {
//! #     type State = [f32; 1];
//! #     fn num_actions(&self) -> usize {
//! #         2
//! #     }
//! #     fn query<R: Rng + ?Sized>(
//! #         &self,
//! #         state: [f32; 1],
//! #         action: usize,
//! #         rng: &mut R,
//! #     ) -> awfqi::Result<Transition<[f32; 1], f32>> {
//! #         let mean = self.predict(state, action)?;
//! #         let noise = (rng.next_u32() as f32 / u32::MAX as f32 - 0.5) * 0.02;
//! #         let next_state = [(mean.next_state[0] + noise).clamp(0.0, 1.0)];
//! #         Ok(Transition { state, action, reward: mean.reward, next_state, absorbing: false })
//! #     }
//! # }
//!
//! # fn main() -> awfqi::Result<()> {
//! let mut rng = ChaCha8Rng::seed_from_u64(7);
//! let sources = [Heater { gain: 0.15 }, Heater { gain: 0.3 }];
//! let mut data = [[Transition::EMPTY; 20]; 2];
//! for (heater, records) in sources.iter().zip(&mut data) {
//!     for (i, r) in records.iter_mut().enumerate() {
//!         *r = heater.query([i as f32 / 19.0], i % 2, &mut rng)?;
//!     }
//! }
//! let records: [&[Transition<[f32; 1], f32>]; 2] = [&data[0], &data[1]];
//!
//! // All the memory the loop writes: a 16-point GP over (s, a), 2 steps × 10 queries,
//! // 40 source records, 42 candidate rows, 10 cells × 2 actions (`static` in `.bss` on a
//! // device). Set-up memory: the fitted source posteriors and the score values.
//! let mut storage = AwfqiStorage::<f32, 1, 2, 16, 20, 40, 42, 20>::new();
//! let mut posteriors = [Posterior::default(); 40];
//! let mut scores = [Scores::ZERO; 42];
//!
//! // The thesis's settings (Puddle World's scales; for a plant of your own derive them from
//! // the logs: `AwfqiConfig::scaled`, docs/embedding.md), 10 queries per step.
//! let mut config = AwfqiConfig::thesis(10);
//! config.gp_training.search.restarts = 1;
//! let candidates = RowSet::grid(PointGrid::spanning([0.0], [1.0], 0.05)?, 2)?;
//! let mut kernel = Awfqi::builder(config.validate()?, CellGrid::cube(0.0, 1.0, 10)?, &records, candidates)
//!     .fit_posteriors(&mut posteriors) // one reward GP per source, fitted here
//!     .scores_from(&sources, &mut scores)? // oracle scores from the sources' means
//!     .build(Heater { gain: 0.2 }, &mut storage, &mut rng)?;
//! for _ in 0..2 {
//!     let report = kernel.step(&mut rng)?; // 10 queries, target GP, weights, weighted FQI
//!     assert!(report.wr_eff > 0.0);
//! }
//! // The greedy policy heats when cold and not when hot.
//! assert_eq!(kernel.q().greedy_action([0.2])?, 1);
//! assert_eq!(kernel.q().greedy_action([0.9])?, 0);
//! # Ok(())
//! # }
//! ```
//!
//! Streamed Extra-Trees as the Q-function on their own (a corridor of four cells):
//!
//! ```rust
//! use awfqi::{Approximator, EmptyCells, ExtraTrees, FqiConfig, SampleSet, Transition, TreeStorage};
//! use rand_chacha::ChaCha8Rng;
//! use rand_core::SeedableRng;
//!
//! # fn main() -> awfqi::Result<()> {
//! // States at c + 0.5 for cells c = 0..4; action 0 moves right (leaving cell 3 ends the
//! // episode at the goal), action 1 moves left; every move costs 1.
//! let mut samples = [Transition::EMPTY; 8];
//! for (i, sample) in samples.iter_mut().enumerate() {
//!     let (cell, action) = (i / 2, i % 2);
//!     let x = cell as f32 + 0.5;
//!     let next = if action == 0 { x + 1.0 } else { (x - 1.0).max(0.5) };
//!     let absorbing = action == 0 && cell == 3;
//!     *sample = Transition { state: [x], action, reward: -1.0, next_state: [next], absorbing };
//! }
//! // 8 record slots and one 15-node scratch tree (a `static` in `.bss` on a device).
//! let mut memory = TreeStorage::<f32, 1, 8, 15>::new();
//! let forests = ExtraTrees::streamed(50, 15)?;
//! let mut q = Approximator::Trees(forests).build(2, memory.storage())?;
//! let config = FqiConfig::new(0.9, 60, EmptyCells::Nearest)?;
//! q.fit(&[SampleSet::unweighted(&samples)], &config, &mut ChaCha8Rng::seed_from_u64(1))?;
//! for cell in 0..4 {
//!     assert_eq!(q.greedy_action([cell as f32 + 0.5])?, 0); // towards the goal
//! }
//! // Q(s, right) is the discounted cost to the goal: −(1 − 0.9^(4 − c)) / (1 − 0.9).
//! assert!((q.value([0.5], 0)? + (1.0 - 0.9f32.powi(4)) / 0.1).abs() < 1e-4);
//! assert!(q.greedy_action([f32::NAN]).is_err()); // bad input is an error
//! # Ok(())
//! # }
//! ```
//!
//! The experiments, their results and the harness that runs them are described in the
//! repository's README.md and `docs/` (`docs/results-puddle.md` for the headline comparison,
//! `docs/algorithms.md` for every formula).
//!
//! The embedding guide (the repository's `docs/embedding.md`) follows: depending on the crate,
//! settings derived from your logs, the recommended kernel, the step reports' warnings.
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
pub mod awfqi;
pub mod env;
pub mod error;
pub mod evaluation;
pub mod float;
pub mod fqi;
pub mod gp;
pub mod identify;
pub mod model;
pub mod planning;
pub mod policy;
pub mod record_gp;
pub mod rng;
pub mod score;
pub mod weights;

/// The README's examples, compiled and run as doctests (the crate docs are the embedding
/// guide, `docs/embedding.md`).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

pub use error::{Error, Result};
pub use float::Real;
/// The `rand_core` (0.10) whose [`Rng`](rand_core::Rng) every randomised call takes:
/// depend on this one (`awfqi::rand_core::Rng`, `awfqi::rand_core::SeedableRng`) and the
/// versions cannot drift apart. Generators of `rand_core` 0.6 and 0.9 go through
/// [`rng::compat`].
pub use rand_core;

// The types a user of the transfer path meets, at the crate root (as heapless does).
pub use adaptive::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, AdaptiveStorage, MeanFunction,
    ValidAdaptiveConfig,
};
pub use alias::AliasEntry;
pub use awfqi::{
    Awfqi, AwfqiBuffers, AwfqiBuilder, AwfqiConfig, AwfqiStorage, SourceData, SourceScales,
    StepReport, ValidAwfqiConfig, Warning, Warnings,
};
pub use evaluation::{
    Evaluation, EvaluationProtocol, MultiStartProtocol, Rollout, evaluate, evaluate_greedy,
    evaluate_greedy_multi_start, evaluate_multi_start, rollout,
};
pub use fqi::{
    ANCHOR_LINKS, AnchorEntry, AnchorFqi, AnchorParts, AnchorStorage, AnchorSweep, Approximator,
    CellGrid, EmptyCells, ExtraTrees, FqiConfig, FqiEntry, Greedy, HybridFqi, Kernel, KnnFqi,
    KnnRecord, KnnStorage, ModelFqi, ModelSweep, Neighbours, QFunction, QStorage, RewardModel,
    SampleSet, SweepEntry, SweepFqi, SweepNode, SweepStorage, TabularFqi, TileFqi, Tilings,
    TreeFqi, TreeNode, TreeRecord, TreeStorage,
};
pub use gp::{Conditioning, Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
pub use model::{GenerativeModel, Transition};
pub use policy::{EpsilonGreedyPolicy, Policy, UniformPolicy};
pub use record_gp::{Dims, GpTraining, Output, StatePlusAction, SubsetRule};
pub use score::{
    GpSourceModel, PointGrid, RowSampler, RowSet, ScoreColumn, ScoreTable, Scores, SourceMeans,
    SourceModel,
};
pub use weights::{Estimator, NoiseSubtraction, Posterior, WeightParams};
