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
    Approximator, CellGrid, EmptyCells, ExtraTrees, FqiConfig, FqiEntry, Greedy, HybridFqi, Kernel,
    KnnFqi, KnnRecord, KnnStorage, ModelSweep, Neighbours, QFunction, QStorage, RewardModel,
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
