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

pub use error::{Error, Result};
pub use float::Real;

// The types a user of the transfer path meets, at the crate root (as heapless does).
pub use adaptive::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, AdaptiveStorage, MeanFunction,
    ValidAdaptiveConfig,
};
pub use alias::AliasEntry;
pub use awfqi::{
    Awfqi, AwfqiBuffers, AwfqiBuilder, AwfqiConfig, AwfqiStorage, SourceData, StepReport,
    ValidAwfqiConfig,
};
pub use evaluation::{Evaluation, EvaluationProtocol, Rollout, evaluate, evaluate_greedy, rollout};
pub use fqi::{
    Approximator, CellGrid, EmptyCells, ExtraTrees, FqiConfig, FqiEntry, Greedy, HybridFqi, Kernel,
    KnnFqi, KnnRecord, KnnStorage, ModelSweep, Neighbours, QFunction, QStorage, RewardModel,
    SampleSet, SweepEntry, SweepFqi, SweepNode, SweepStorage, TabularFqi, TileFqi, Tilings,
    TreeFqi, TreeNode, TreeRecord, TreeStorage,
};
pub use gp::{Conditioning, Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
pub use model::{GenerativeModel, Transition};
pub use policy::{EpsilonGreedyPolicy, Policy, UniformPolicy};
pub use record_gp::{GpTraining, Output, SubsetRule};
pub use score::{
    GpSourceModel, PointGrid, RowSampler, RowSet, ScoreColumn, ScoreTable, Scores, SourceMeans,
    SourceModel,
};
pub use weights::{Estimator, NoiseSubtraction, Posterior, WeightParams};
