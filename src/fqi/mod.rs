//! Weighted fitted Q-iteration (spec §5, §7.2 step 5) in fixed memory, with a choice of
//! Q-function approximators and one iteration loop for all of them.
//!
//! **The loop** (IWFQI's structure, the same for every approximator): a fit takes the union
//! of some [`SampleSet`]s (AWFQI: the target's samples, then one set per source, none
//! copied), checks all of them before anything changes, and then
//!
//! 1. **iteration 1** fits the rewards (a set's replacement rewards where it has them) with
//!    the **reward weights** `w_r`: the reward model `R̂`, and `Q₁ = R̂`;
//! 2. every sample's reward is replaced by the model's value `r̂ᵢ = R̂(sᵢ, aᵢ)`;
//! 3. **iterations 2..N** ([`FqiConfig::iterations`]) fit
//!    `yᵢ = r̂ᵢ + γ (1 − ωᵢ) maxₐ′ Q_{k−1}(s′ᵢ, a′)` with the **transition weights** `w_s`;
//!    an absorbing sample (`ω = 1`) does not bootstrap.
//!
//! With all weights 1 this is plain FQI (the no-transfer baseline,
//! [`SampleSet::unweighted`]). A pair or region whose total weight stays below
//! [`FqiConfig::with_min_weight`] counts as having no data; each approximator says what it
//! predicts there.
//!
//! **The approximators**, each over memory the caller lends (sizes in its own docs):
//!
//! | type | [`Approximator`] | storage | regression of one iteration |
//! |---|---|---|---|
//! | [`TabularFqi`] | [`CellGrid`] | [`FqiEntry`] per (cell, action) | weighted mean per cell, [`EmptyCells`] fills the rest |
//! | [`TileFqi`] | [`Tilings`] | [`FqiEntry`] per (tile, action) per tiling | a table per tiling, averaged |
//! | [`KnnFqi`] | [`Neighbours`] | [`KnnRecord`] per sample, `u16` links | kernel mean of the `k` nearest records |
//! | [`HybridFqi`] | [`Approximator::Hybrid`] | both of the above | the mean of tiles and kNN |
//! | [`TreeFqi`] | [`ExtraTrees`] | [`TreeRecord`] per sample, [`TreeNode`]s | Extra-Trees forests, stored or streamed |
//! | [`SweepFqi`] | [`ModelSweep`] | [`SweepEntry`] per (node, action), [`SweepNode`] per node | none: value iteration on a grid model fitted once per fit |
//! | [`AnchorFqi`] | [`AnchorSweep`] | [`AnchorEntry`] per (node, action), [`SweepNode`], position and landing per node | none: the same on representative states placed from the records, within a node budget |
//!
//! [`Approximator`] is the choice before storage exists; [`Approximator::build`] makes the
//! [`QFunction`] that AWFQI and adaptive AWFQI hold. Only the trees draw random numbers,
//! from the caller's generator.
//!
//! **Adding an approximator.** The loop lives once, in `iteration.rs`: it validates the
//! sets, counts them against the approximator's capacity, checks that no value can
//! overflow, and runs the iterations. A new approximator is a file here with
//! - a type holding borrowed storage, with the query methods every approximator has
//!   (`actions`, `clear`, `value`, `max_value`, `greedy_action` with the common tie rule of
//!   `argmax.rs`; an error for a non-finite state, never a panic), and `fit`/`fit_sets`
//!   that call `iteration::fit`;
//! - an `impl Regressor` (crate-private, in `iteration.rs`): `actions`, `capacity` (if it
//!   keeps one record per sample), `fit_reward_model` (iteration 1), `bellman_iteration`
//!   (iteration `k ≥ 2`; `k == 2` is where work done once per fit goes, such as the
//!   table's donors or kNN's links) and, if needed, `finish`;
//! - a variant in [`Approximator`] (with its `required_entries` and `build` arms, and a
//!   slice in [`QStorage`] if it needs memory of a new kind), a variant in [`QFunction`]
//!   (the `each!` macro in `q_function.rs` lists the variants once for all its methods,
//!   `entries` and `as_tabular` aside), and its name in the `Greedy` macro there;
//! - its public entry points in the no-panic image (`tests/on_target/src/bin/no_panic/`).
//!
//! **Example**: streamed Extra-Trees as the Q-function on their own (a corridor of four cells):
//!
//! ```rust
//! use awfqi::prelude::{Approximator, EmptyCells, ExtraTrees, FqiConfig, SampleSet, Transition, TreeStorage};
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

mod anchors;
mod argmax;
mod config;
mod entry;
mod fill;
mod grid;
mod hybrid;
mod iteration;
mod knn;
mod q_function;
mod samples;
mod sweep;
mod table;
mod tiles;
mod trees;

pub use anchors::{
    ANCHOR_LINKS, AnchorEntry, AnchorFqi, AnchorParts, AnchorStorage, AnchorSweep, Anchors,
};
pub use config::{EmptyCells, FqiConfig};
pub use entry::FqiEntry;
pub use grid::CellGrid;
pub use hybrid::HybridFqi;
pub use knn::{Kernel, KnnFqi, KnnRecord, KnnStorage, MAX_NEIGHBOURS, NO_LINK, Neighbours};
pub use q_function::{Approximator, Greedy, QFunction, QStorage};
pub use samples::SampleSet;
pub use sweep::{
    ModelFqi, ModelSweep, RewardModel, SweepEntry, SweepFqi, SweepNode, SweepStorage,
    sweep_entries, sweep_nodes,
};
pub use table::{TableStorage, TabularFqi};
pub use tiles::{TileFqi, Tilings};
pub use trees::{
    CONSTANT_FEATURE_TOLERANCE, ExtraTrees, MIN_IMPURITY, TreeFqi, TreeNode, TreeRecord,
    TreeStorage,
};
