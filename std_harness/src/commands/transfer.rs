//! The transfer-experiment commands (`awfqi-harness puddle`, `dam`, `acrobot`): every
//! algorithm on the common protocol of one domain, result files in the reference's layout,
//! a summary, transfer metrics, learning curves and sample scatters.
//!
//! The three commands share their options ([`Args`]); an option left out takes the
//! domain's default ([`Defaults`]: Puddle World's thesis setting 2 (b), the Dam's and
//! Acrobot's published configurations). Runs of all algorithms go in parallel (rayon,
//! `--threads`), each run seeded from (`--seed`, algorithm, run index), so the same seed
//! gives the same numbers whatever the scheduling, and `--runs A..B` computes a slice of
//! runs whose results merge into the `<algorithm>.json` files already in `--out`
//! ([`crate::transfer::result_dir`]: same configuration only, runs already there kept,
//! writers locked).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, anyhow, bail};
use awfqi::env::Dynamics;
use awfqi::weights::NoiseSubtraction;
use clap::{Args as ClapArgs, ValueEnum};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::domains::{Domain, IdealMeans};
use crate::gp_large::fixed::PredictiveVariance;
use crate::run_range::RunRange;
use crate::store::write_csv;
use crate::transfer::algorithms::adaptive::{AdaptiveOptions, AdaptiveOracle, AdaptiveSetup};
use crate::transfer::algorithms::adaptive_kernel::{
    ADAPTIVE_SWEEP_CELLS, ADAPTIVE_TILES, ADAPTIVE_TILINGS, ADAPTIVE_TREE_NODES, ADAPTIVE_TREES,
};
use crate::transfer::algorithms::awfqi_kernel::{
    KernelConfig, KernelQFunction, KernelSetup, SweepKnobs, TreeKnobs,
};
use crate::transfer::algorithms::rbt::ComplianceSum;
use crate::transfer::algorithms::{
    Algorithm, Experiment, ScopedLearner, TransferOptions, Variances,
};
use crate::transfer::gp::{FixedGpUpdate, GpOptions, GpSearch};
use crate::transfer::metrics::{TransferMetrics, markdown_table, transfer_metrics};
use crate::transfer::protocol::{self, Protocol};
use crate::transfer::result_dir::{ResultDir, recorded_command};
use crate::transfer::results::{ResultFile, RunRecord, SAMPLE_RUNS, SummaryRow, write_summary};
use crate::transfer::score_tables::{self, Mode, ScoreTableData};
use crate::transfer::sources::SourceSet;
use crate::transfer::{IDEAL_WEIGHTS, RUN, SCORE_TABLE, figures, stream};

/// Puddle World's dynamics variants on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DynamicsArg {
    /// κ = 0: all tasks share their transitions (the thesis's setting).
    Shared,
    /// κ = 5: puddles slow the agent down.
    Puddle,
}

impl DynamicsArg {
    /// The core's variant.
    pub fn dynamics(self) -> Dynamics {
        match self {
            DynamicsArg::Shared => Dynamics::Shared,
            DynamicsArg::Puddle => Dynamics::PuddleBased,
        }
    }
}

/// Noise subtraction of the target GPs' stds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum NoiseArg {
    /// The reference's rule: subtract the noise std (§4.2, §14.7).
    Reference,
    /// `√max(v − σ²ₙ, 0)`.
    Principled,
}

/// The Q-function approximator of `awfqi-kernel`'s FQI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum KernelQ {
    /// One table of `--kernel-resolution` cells per axis (spec §5.1).
    Tabular,
    /// Tile coding: `--kernel-tilings` offset tilings of `--kernel-resolution` tiles per
    /// axis, averaged (the core's `TileFqi`).
    Tiles,
}

/// The Q-function approximator of `awfqi-adaptive-kernel`'s FQI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AdaptiveKernelQ {
    /// Tile coding (12 × 12 tiles × 8 tilings unless `--kernel-resolution` is given; the
    /// default before the trees).
    Tiles,
    /// Kernel averaging over the `--kernel-neighbours` nearest records (the core's
    /// `KnnFqi`), uniform or Gaussian (`--kernel-bandwidth`).
    Knn,
    /// The mean of both, each fitted on the same data (tiles as for `tiles`).
    Hybrid,
    /// Per-action Extra-Trees forests in fixed memory (the core's `TreeFqi`, the default):
    /// `--kernel-trees` trees, streamed through a scratch tree of `--kernel-tree-nodes`
    /// nodes (or stored, each of at most that many, with `--kernel-tree-streamed false`).
    Trees,
    /// Value iteration on a grid model of the weighted records (the core's `SweepFqi`):
    /// `--kernel-sweep-cells` cells per axis, nodes at their corners.
    Sweep,
}

/// `--kernel-sweep-rewards`: the core's `RewardModel`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SweepRewards {
    /// The action's own records.
    PerAction,
    /// Every action's records.
    Pooled,
    /// The action's own where it has some, every action's elsewhere.
    Backfilled,
}

impl From<SweepRewards> for awfqi::RewardModel {
    fn from(r: SweepRewards) -> Self {
        match r {
            SweepRewards::PerAction => Self::PerAction,
            SweepRewards::Pooled => Self::Pooled,
            SweepRewards::Backfilled => Self::Backfilled,
        }
    }
}

/// Arguments of `awfqi-harness puddle`, `dam` and `acrobot`. Options without a value take
/// the domain's default (see each command's help).
#[derive(Debug, Clone, ClapArgs)]
pub struct Args {
    /// Score-table rows of AWFQI and AWFQI_oracle: thesis setting 1 (source), 2 (grid), 3
    /// (both). Default: grid.
    #[arg(long, value_enum)]
    pub setting: Option<Mode>,
    /// Episodes per step B (the active algorithms query H·B pairs per step). Default:
    /// Puddle World 1, Dam 1, Acrobot 10.
    #[arg(long)]
    pub episodes_per_step: Option<usize>,
    /// Steps K. Default: Puddle World 6, Dam 10, Acrobot 20.
    #[arg(long)]
    pub steps: Option<usize>,
    /// Runs: a count N (runs 0..N) or a range A..B; results merge with those in --out.
    /// Default: Puddle World 10, Dam and Acrobot 20.
    #[arg(long)]
    pub runs: Option<RunRange>,
    /// Algorithms to run. Default: all but iwfqi-heuristic (and, on the Dam and Acrobot,
    /// awfqi-kernel (Puddle World only) and awfqi-adaptive (by name there)).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub algorithms: Vec<Algorithm>,
    /// Puddle World's dynamics variant (puddle only). Default: shared.
    #[arg(long, value_enum)]
    pub dynamics: Option<DynamicsArg>,
    /// Source data: `published` (the reference runs' data, embedded), `generate` (fresh, as
    /// the domain's paper describes; written to `<out>/sources`), or a directory with the
    /// domain's source files in the published layout.
    #[arg(long, default_value = "published")]
    pub sources: String,
    /// Experiment seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory. Default: `results/<command>`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// FQI iterations. Default: Puddle World and Dam 60, Acrobot 50.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Trees per forest. Default: Puddle World 50, Dam 100, Acrobot 50.
    #[arg(long)]
    pub trees: Option<usize>,
    /// GP restarts after the initial-value optimisation of fitted GPs (spec: 10; the Dam's
    /// and Acrobot's GPs have fixed kernels).
    #[arg(long, default_value_t = 10)]
    pub gp_restarts: usize,
    /// GP training cap `max_gp`: the last this many records. Default: Puddle World 4000,
    /// Dam and Acrobot 10000.
    #[arg(long)]
    pub max_gp: Option<usize>,
    /// GP hyperparameter search: `spec` (§4.2: every start optimised on all data),
    /// `screened` (starts screened on a 300-point subsample, then refined on all data) or
    /// `staged` (screened, then refined on 1 000 points, then on all data from there with
    /// the curvature model carried over; opt-in, checked on fewer fits). Default:
    /// `screened` where it was checked to reach the spec's optimum (README, performance):
    /// iwfqi on Puddle World (with or without transition weights), iwfqi
    /// elsewhere, iwfqi-heuristic, awfqi and awfqi-oracle without them; `spec` for the
    /// others. `spec` reproduces the spec's procedure exactly.
    #[arg(long, value_enum)]
    pub gp_search: Option<GpSearch>,
    /// Also run the other GP search (spec ↔ screened, staged → spec) on every fitted GP, on
    /// the same data and starts, keep `--gp-search`'s GP (results unchanged) and write both optima to
    /// `gp_search_check.tsv` in the output directory, with a summary on stderr.
    #[arg(long)]
    pub check_gp_search: bool,
    /// How IWFQI's fixed-kernel target GPs (Dam, Acrobot) follow the target data:
    /// `incremental` appends each step's records to the factor and to the posterior at the
    /// source records (the refit's posterior to rounding, ≈ 10× fewer flops on Acrobot,
    /// but it holds every GP's factor between steps: ≈ 7 GB a run on Acrobot's last
    /// step); `refit` reconditions on all target records every step, as the reference.
    #[arg(long, value_enum, default_value_t = FixedGpUpdate::Incremental)]
    pub fixed_gp: FixedGpUpdate,
    /// How the fixed-kernel GPs (Dam, Acrobot) compute their predictive variance:
    /// `stable` (`k** − ‖L⁻¹k*‖²`) or `explicit-inverse` (`k** − k*ᵀK⁻¹k*` with `K⁻¹`
    /// formed, negatives set to 0: scikit-learn ≤ 0.23's arithmetic, which the IWFQI
    /// reference ran; an ablation, implies `--fixed-gp refit` for IWFQI's target GPs).
    #[arg(long, value_enum, default_value_t = PredictiveVariance::Stable)]
    pub fixed_gp_variance: PredictiveVariance,
    /// IWFQI/AWFQI estimator variances: `published` or (Puddle World only) `corrected`
    /// (0.01, 0.04), spec §14.6.
    #[arg(long, value_enum, default_value = "published")]
    pub variances: Variances,
    /// Noise subtraction of the target GPs' stds (spec §14.7).
    #[arg(long, value_enum, default_value = "reference")]
    pub noise: NoiseArg,
    /// Transition weights of IWFQI on (every state coordinate) or off (default: the
    /// published configuration: off for shared, on for puddle dynamics, spec §7.6; the
    /// Dam's storage; Acrobot's four coordinates). awfqi-kernel weighs transitions only
    /// with `true` (spec §12.1).
    #[arg(long)]
    pub transition_weights: Option<bool>,
    /// How IWFQI-ideal gets the models' mean next states (default: the published way:
    /// exact for Puddle World and Acrobot, one sampled step for the Dam).
    #[arg(long, value_enum)]
    pub ideal_means: Option<IdealMeans>,
    /// RBT's n_total (source records per step). Default: Puddle World 500, Dam 60000,
    /// Acrobot 8000.
    #[arg(long)]
    pub rbt_total: Option<usize>,
    /// RBT's task compliance: `means` over a source's records (spec §8, the default) or
    /// `sums` (what the published Acrobot RBT runs computed; docs/paper-domains.md).
    #[arg(long, value_enum, default_value_t = ComplianceSum::Means)]
    pub rbt_compliance: ComplianceSum,
    /// Step 1's collection policy: `uniform` (spec §3.2, the default) or `zero-q` (the
    /// reference code's ε-greedy around a zero Q-function: mostly the first action).
    #[arg(long, value_enum)]
    pub first_step: Option<protocol::FirstStep>,
    /// FQI's Q-function: `per-action` forests (spec §5, the default) or `joint`, one forest
    /// over (state, action value) as the reference code fits on the Dam (whose action
    /// space it leaves undeclared). An ablation; FQI on 2-D states (Dam, Puddle World) only.
    #[arg(long, value_enum)]
    pub q_function: Option<crate::joint_q::QFunctionKind>,
    /// Grid spacing of the score tables. Default: Puddle World 0.1 (both coordinates), Dam
    /// 10 (storage; every day), Acrobot π/6 (angles; 9 values per velocity).
    #[arg(long)]
    pub spacing: Option<f64>,
    /// Threshold of the "time to threshold" metric (discounted return). Default: Puddle
    /// World −25, Dam −1000, Acrobot −50.
    #[arg(long, allow_hyphen_values = true)]
    pub threshold: Option<f64>,
    /// Q-function approximator of awfqi-kernel's FQI (`tabular`: the 11 × 11 table of
    /// spec §12.1 before tile coding became the default, measured worse).
    #[arg(long, value_enum, default_value = "tiles")]
    pub kernel_q: KernelQ,
    /// Cells (tabular) or tiles (tiles) per axis of awfqi-kernel's FQI. Default: 11 for
    /// the table, 6 for tiles; awfqi-adaptive-kernel's tiles (`--adaptive-kernel-q tiles`
    /// or `hybrid`) have their own default, 12 × 8, which an explicit resolution replaces
    /// (with `--kernel-q` and `--kernel-tilings`).
    #[arg(long)]
    pub kernel_resolution: Option<usize>,
    /// Offset tilings of `--kernel-q tiles`.
    #[arg(long, default_value_t = 4)]
    pub kernel_tilings: usize,
    /// Q-function approximator of awfqi-adaptive-kernel's FQI.
    #[arg(long, value_enum, default_value = "sweep")]
    pub adaptive_kernel_q: AdaptiveKernelQ,
    /// Neighbours per prediction of `--adaptive-kernel-q knn`.
    #[arg(long, default_value_t = 4)]
    pub kernel_neighbours: usize,
    /// Gaussian bandwidth of `--adaptive-kernel-q knn`, as a share of each coordinate's
    /// range (absent: the neighbours weigh equally).
    #[arg(long)]
    pub kernel_bandwidth: Option<f64>,
    /// Reach of `--adaptive-kernel-q knn`, as a share of each coordinate's range: an action
    /// whose nearest record is farther, where another's is nearer, is valued at most that
    /// one's value (absent: no cap).
    #[arg(long)]
    pub kernel_reach: Option<f64>,
    /// `--adaptive-kernel-q knn`: one ball for every action (the radius of the
    /// `--kernel-neighbours` nearest records of any action bounds every action's mean and
    /// acts as the reach).
    #[arg(long)]
    pub kernel_common_ball: bool,
    /// Trees per action of `--adaptive-kernel-q trees`.
    #[arg(long, default_value_t = ADAPTIVE_TREES)]
    pub kernel_trees: usize,
    /// Node budget of `--adaptive-kernel-q trees`: of the scratch tree when streamed, of
    /// each tree when stored (at most 65 535; a tree is grown breadth first and cut when
    /// full).
    #[arg(long, default_value_t = ADAPTIVE_TREE_NODES)]
    pub kernel_tree_nodes: usize,
    /// `min_samples_split` of `--adaptive-kernel-q trees`.
    #[arg(long, default_value_t = 2)]
    pub kernel_min_samples_split: usize,
    /// `min_samples_leaf` of `--adaptive-kernel-q trees`.
    #[arg(long, default_value_t = 1)]
    pub kernel_min_samples_leaf: usize,
    /// `--adaptive-kernel-q trees`: stream the trees (grow each in one scratch tree of
    /// `--kernel-tree-nodes` nodes during FQI, and the final trees along each query's path),
    /// so the memory does not grow with `--kernel-trees`; `false`: store every tree.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = true)]
    pub kernel_tree_streamed: bool,
    /// Depth limit of `--adaptive-kernel-q trees` (absent: none; the root is at depth 0).
    #[arg(long)]
    pub kernel_tree_max_depth: Option<usize>,
    /// Cells per axis of `--adaptive-kernel-q sweep` (its nodes: one more per axis).
    #[arg(long, default_value_t = ADAPTIVE_SWEEP_CELLS)]
    pub kernel_sweep_cells: usize,
    /// `--adaptive-kernel-q sweep`: which records a node's reward averages (`pooled`: every
    /// action's, for rewards that depend on the state only; `backfilled`: the action's own
    /// where it has some, every action's elsewhere).
    #[arg(long, value_enum, default_value = "pooled")]
    pub kernel_sweep_rewards: SweepRewards,
    /// `--adaptive-kernel-q sweep`: the least reward weight of a node with data (a record
    /// at the node weighs 1).
    #[arg(long, default_value_t = 0.0)]
    pub kernel_sweep_min_mass: f64,
    /// `--adaptive-kernel-q sweep`: decide by one step of lookahead at the state instead of
    /// interpolating the node Q-values.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = false)]
    pub kernel_sweep_lookahead: bool,
    /// Skip the plots.
    #[arg(long)]
    pub no_plots: bool,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    /// Compute nothing: summarise and plot the runs of this configuration already in --out.
    #[arg(long)]
    pub no_run: bool,
    /// Recompute runs already in --out, and start anew a result file that holds another
    /// configuration or cannot be read, keeping the old file as
    /// `<name>.json.<timestamp>.bak`. Without it such a file is an error (nothing is
    /// written) and runs already there are kept, so rerunning an interrupted command
    /// finishes only the runs it lacks.
    #[arg(long)]
    pub replace: bool,
    /// The command line as typed (the subcommand and its options), recorded in the result
    /// files without the options that only say where and how; filled by the binary.
    #[arg(skip)]
    pub command: Vec<String>,
    /// awfqi-adaptive: sub-batches (re-planning points) per step.
    #[arg(long, default_value_t = AdaptiveOptions::default().sub_batches)]
    pub adaptive_sub_batches: usize,
    /// awfqi-adaptive: share of each sub-batch spent verifying the greedy policy.
    #[arg(long, default_value_t = AdaptiveOptions::default().verify)]
    pub adaptive_verify: f64,
    /// awfqi-adaptive: score rows by residual surprise.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().surprise)]
    pub adaptive_surprise: bool,
    /// awfqi-adaptive: scale scores by the residual GP's remaining variance.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().uncertainty)]
    pub adaptive_uncertainty: bool,
    /// awfqi-adaptive: weight rows by closeness to the verified greedy paths.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().decision)]
    pub adaptive_decision: bool,
    /// awfqi-adaptive: source-informed prior mean of the weights' target reward GP.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().prior)]
    pub adaptive_prior: bool,
    /// awfqi-adaptive: coverage floor (share of the drawn probability spread uniformly).
    #[arg(long, default_value_t = AdaptiveOptions::default().floor)]
    pub adaptive_floor: f64,
    /// awfqi-adaptive: candidate rows scored per sub-batch.
    #[arg(long, default_value_t = AdaptiveOptions::default().candidates)]
    pub adaptive_candidates: usize,
    /// awfqi-adaptive: trees of the intermediate plans (0: the protocol's).
    #[arg(long, default_value_t = AdaptiveOptions::default().plan_trees)]
    pub adaptive_plan_trees: usize,
    /// awfqi-adaptive: trees of each step's last fit, the plan it ends with (0: the
    /// protocol's).
    #[arg(long, default_value_t = AdaptiveOptions::default().final_trees)]
    pub adaptive_final_trees: usize,
    /// awfqi-adaptive: relevance-kernel width (share of each state coordinate's range).
    #[arg(long, default_value_t = AdaptiveOptions::default().relevance_width)]
    pub adaptive_relevance_width: f64,
    /// awfqi-adaptive: FQI's rewards from the target reward model.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().model_rewards)]
    pub adaptive_model_rewards: bool,
    /// awfqi-adaptive: weigh source records by their source's plausibility.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().source_weights)]
    pub adaptive_source_weights: bool,
    /// awfqi-adaptive: end a verification rollout at the first surprising reward.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().surprise_stop)]
    pub adaptive_surprise_stop: bool,
    /// awfqi-adaptive: hyperparameter search of its own GP fits (`screened` equals `spec`
    /// up to 300 target points).
    #[arg(long, value_enum, default_value_t = AdaptiveOptions::default().gp_search)]
    pub adaptive_gp_search: GpSearch,
    /// awfqi-adaptive: exploration ε of the verification rollouts after a sub-batch's
    /// first (default: the protocol's ε).
    #[arg(long)]
    pub adaptive_verify_epsilon: Option<f64>,
    /// awfqi-adaptive: rollouts of the current plan simulated per sub-batch in a
    /// nearest-record model, whose states join the relevance centres (0: off).
    #[arg(long, default_value_t = AdaptiveOptions::default().simulate)]
    pub adaptive_simulate: usize,
    /// awfqi-adaptive: resume an unfinished verification rollout in the next sub-batch.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().resume)]
    pub adaptive_resume: bool,
    /// awfqi-adaptive: temperature of the source plausibilities (1: the likelihood; inf:
    /// uniform).
    #[arg(long, default_value_t = AdaptiveOptions::default().temperature)]
    pub adaptive_temperature: f64,
    /// awfqi-adaptive: the reward model's prior mean is the median of the sources' means.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().consensus)]
    pub adaptive_consensus: bool,
    /// awfqi-adaptive: relabel contradicted source rewards by the target GP instead of
    /// down-weighting the records.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().relabel)]
    pub adaptive_relabel: bool,
    /// awfqi-adaptive-kernel: relabel contradicted source rewards (the core's
    /// `AdaptiveConfig::relabel`); off by default, as chosen on the tuning runs.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().kernel_relabel)]
    pub adaptive_kernel_relabel: bool,
    /// awfqi-adaptive-kernel: after a target GP's first fit in a run, start each later
    /// search from its last hyperparameters with this many likelihood evaluations (the
    /// core's `Refit::Warm`); 0: every fit searches as the thesis does.
    #[arg(long, default_value_t = 30)]
    pub adaptive_kernel_refit_evaluations: usize,
    /// awfqi-adaptive-kernel: random restarts of those warm searches.
    #[arg(long, default_value_t = 0)]
    pub adaptive_kernel_refit_restarts: usize,
    /// awfqi-adaptive-kernel: points of the target GPs and of the sources' mean functions
    /// (16, 24, 32, 48 or 64).
    #[arg(long, default_value_t = AdaptiveOptions::default().kernel_gp_points)]
    pub adaptive_kernel_gp_points: usize,
    /// awfqi-adaptive-kernel: candidate rows scored per sub-batch (`--adaptive-candidates`
    /// is awfqi-adaptive's).
    #[arg(long, default_value_t = AdaptiveOptions::default().kernel_candidates)]
    pub adaptive_kernel_candidates: usize,
    /// awfqi-adaptive: drop source records whose episode end no other source or target
    /// record corroborates.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().corroborate)]
    pub adaptive_corroborate: bool,
    /// awfqi-adaptive: an oracle diagnostic (reads the true target model; not an
    /// algorithm).
    #[arg(long, value_enum, default_value_t = AdaptiveOracle::None)]
    pub adaptive_oracle: AdaptiveOracle,
    /// awfqi-adaptive: simulated rollouts per plan for plan selection (0: off).
    #[arg(long, default_value_t = AdaptiveOptions::default().select)]
    pub adaptive_select: usize,
}

impl Args {
    /// awfqi-adaptive's options.
    pub fn adaptive(&self) -> AdaptiveOptions {
        AdaptiveOptions {
            sub_batches: self.adaptive_sub_batches,
            verify: self.adaptive_verify,
            surprise: self.adaptive_surprise,
            uncertainty: self.adaptive_uncertainty,
            decision: self.adaptive_decision,
            prior: self.adaptive_prior,
            floor: self.adaptive_floor,
            candidates: self.adaptive_candidates,
            plan_trees: self.adaptive_plan_trees,
            final_trees: self.adaptive_final_trees,
            relevance_width: self.adaptive_relevance_width,
            model_rewards: self.adaptive_model_rewards,
            source_weights: self.adaptive_source_weights,
            surprise_stop: self.adaptive_surprise_stop,
            gp_search: self.adaptive_gp_search,
            verify_epsilon: self.adaptive_verify_epsilon,
            simulate: self.adaptive_simulate,
            resume: self.adaptive_resume,
            temperature: self.adaptive_temperature,
            consensus: self.adaptive_consensus,
            relabel: self.adaptive_relabel,
            kernel_relabel: self.adaptive_kernel_relabel,
            kernel_refit: (self.adaptive_kernel_refit_evaluations > 0).then_some((
                self.adaptive_kernel_refit_evaluations,
                self.adaptive_kernel_refit_restarts,
            )),
            kernel_gp_points: self.adaptive_kernel_gp_points,
            kernel_candidates: self.adaptive_kernel_candidates,
            corroborate: self.adaptive_corroborate,
            oracle: self.adaptive_oracle,
            select: self.adaptive_select,
        }
    }
}

/// A command's defaults for the options left out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Defaults {
    /// Episodes per step.
    pub episodes_per_step: usize,
    /// Steps.
    pub steps: usize,
    /// Runs.
    pub runs: usize,
    /// Metric threshold.
    pub threshold: f64,
}

/// The core kernel's hooks on a domain: its set-up and its learner (Puddle World only
/// until the kernel is generic over the state dimension).
#[derive(Debug, Clone, Copy)]
pub struct KernelHooks<const D: usize> {
    /// Builds the kernel's set-up from the sources, its configuration and a stream.
    pub setup: fn(&SourceSet<D>, KernelConfig, &mut ChaCha8Rng) -> anyhow::Result<KernelSetup>,
    /// Hands one run's learner to the protocol.
    pub learner: ScopedLearner<D>,
    /// Hands one run's adaptive-kernel learner to the protocol.
    pub adaptive_learner: ScopedLearner<D>,
}

/// The options resolved against the domain's defaults.
#[derive(Debug, Clone)]
pub struct Config {
    /// The raw arguments.
    pub args: Args,
    /// Setting.
    pub setting: Mode,
    /// Episodes per step.
    pub episodes_per_step: usize,
    /// Steps.
    pub steps: usize,
    /// Runs.
    pub runs: RunRange,
    /// Algorithms (sorted, unique).
    pub algorithms: Vec<Algorithm>,
    /// Output directory.
    pub out: PathBuf,
    /// FQI iterations.
    pub iterations: usize,
    /// Trees.
    pub trees: usize,
    /// Fitted GPs' `max_gp`.
    pub max_gp: usize,
    /// RBT's `n_total`.
    pub rbt_total: usize,
    /// Score-table spacing.
    pub spacing: f64,
    /// Metric threshold.
    pub threshold: f64,
}

/// The largest `--steps` accepted.
pub const MAX_STEPS: usize = 1_000;
/// The largest `--episodes-per-step` accepted.
pub const MAX_EPISODES_PER_STEP: usize = 10_000;
/// The largest `--iterations` (FQI) accepted.
pub const MAX_ITERATIONS: usize = 100_000;
/// The largest `--trees` accepted.
pub const MAX_TREES: usize = 10_000;
/// The largest `--max-gp` accepted (a dense GP of this many points needs 8·n² bytes).
pub const MAX_GP_POINTS: usize = 100_000;
/// The largest `--gp-restarts` accepted.
pub const MAX_GP_RESTARTS: usize = 10_000;
/// Run indices must be below this (seeds are derived from them).
pub const MAX_RUN_INDEX: usize = 1 << 32;

impl Config {
    /// Resolves `args` for `domain` with the command's `defaults`.
    pub fn resolve<const D: usize>(
        args: &Args,
        domain: &Domain<D>,
        defaults: &Defaults,
        kernel_available: bool,
    ) -> anyhow::Result<Self> {
        let p = &domain.published;
        let mut algorithms = if args.algorithms.is_empty() {
            // awfqi-kernel and awfqi-adaptive: Puddle World's default set only (see
            // `Algorithm::DEFAULT`).
            Algorithm::DEFAULT
                .into_iter()
                .filter(|&a| {
                    kernel_available
                        || !matches!(
                            a,
                            Algorithm::AwfqiKernel
                                | Algorithm::AwfqiAdaptive
                                | Algorithm::AwfqiAdaptiveKernel
                        )
                })
                .collect()
        } else {
            args.algorithms.clone()
        };
        algorithms.sort();
        algorithms.dedup();
        for kernel in [Algorithm::AwfqiKernel, Algorithm::AwfqiAdaptiveKernel] {
            if algorithms.contains(&kernel) && !kernel_available {
                bail!(
                    "{} runs on Puddle World only until the harness's kernel path is generic over the state dimension",
                    kernel.name()
                );
            }
        }
        let config = Self {
            args: args.clone(),
            setting: args.setting.unwrap_or(Mode::Grid),
            episodes_per_step: args.episodes_per_step.unwrap_or(defaults.episodes_per_step),
            steps: args.steps.unwrap_or(defaults.steps),
            runs: args.runs.unwrap_or(RunRange {
                start: 0,
                end: defaults.runs,
            }),
            algorithms,
            out: args
                .out
                .clone()
                .unwrap_or_else(|| PathBuf::from("results").join(domain.command)),
            iterations: args.iterations.unwrap_or(p.iterations),
            trees: args.trees.unwrap_or(p.trees),
            max_gp: args.max_gp.unwrap_or(p.max_gp),
            rbt_total: args.rbt_total.unwrap_or(p.rbt_total),
            spacing: args.spacing.unwrap_or(domain.grid_spacing),
            threshold: args.threshold.unwrap_or(defaults.threshold),
        };
        config.check_ranges()?;
        Ok(config)
    }

    /// The CLI's ranges: every budget positive and below a bound that still finishes, the
    /// run range non-empty, the score spacing and the threshold finite. Each error names
    /// the option.
    fn check_ranges(&self) -> anyhow::Result<()> {
        let within = |name: &str, value: usize, low: usize, high: usize| -> anyhow::Result<()> {
            if !(low..=high).contains(&value) {
                bail!("--{name} {value} is out of range: it must be {low} to {high}");
            }
            Ok(())
        };
        within("steps", self.steps, 1, MAX_STEPS)?;
        within(
            "episodes-per-step",
            self.episodes_per_step,
            1,
            MAX_EPISODES_PER_STEP,
        )?;
        within("iterations", self.iterations, 1, MAX_ITERATIONS)?;
        within("trees", self.trees, 1, MAX_TREES)?;
        within("max-gp", self.max_gp, 1, MAX_GP_POINTS)?;
        within("rbt-total", self.rbt_total, 1, usize::MAX)?;
        within("gp-restarts", self.args.gp_restarts, 0, MAX_GP_RESTARTS)?;
        if self.runs.start >= self.runs.end || self.runs.end > MAX_RUN_INDEX {
            bail!(
                "--runs {}..{} is out of range: it must be a non-empty range of run indices below {MAX_RUN_INDEX}",
                self.runs.start,
                self.runs.end
            );
        }
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            bail!(
                "--spacing {} must be a positive finite number",
                self.spacing
            );
        }
        if !self.threshold.is_finite() {
            bail!("--threshold {} must be a finite number", self.threshold);
        }
        Ok(())
    }

    fn gp(&self) -> GpOptions {
        GpOptions {
            restarts: self.args.gp_restarts,
            max_gp: self.max_gp,
            search: self.args.gp_search,
            check: self.args.check_gp_search,
            fixed_update: self.args.fixed_gp,
            fixed_variance: self.args.fixed_gp_variance,
        }
    }
}

/// The configuration every run of a file shares (runs merge only when it is equal).
fn experiment_json<const D: usize>(
    config: &Config,
    experiment: &Experiment<D>,
) -> serde_json::Value {
    let mut json = serde_json::json!({
        "environment": experiment.domain.name,
        "setting": config.setting.name(),
        "sources": experiment.sources.origin,
        "source_records": experiment.sources.sources.iter().map(|s| s.len()).collect::<Vec<_>>(),
        "seed": config.args.seed,
        "protocol": experiment.protocol,
        "options": experiment.options,
        "score_spacing": config.spacing,
    });
    if let Some(d) = experiment.protocol.dynamics {
        json["dynamics"] = protocol::dynamics_name::name(d).into();
    }
    json
}

fn load_sources<const D: usize>(
    config: &Config,
    domain: &Domain<D>,
) -> anyhow::Result<SourceSet<D>> {
    let args = &config.args;
    match args.sources.as_str() {
        "published" => (domain.load_published)(),
        "generate" => {
            let generation = domain
                .generation
                .with_budget(config.iterations, config.trees);
            eprintln!("generating source data ({generation:?})…");
            let start = Instant::now();
            let set =
                crate::transfer::sources::generate(domain, &generation, &config.gp(), args.seed)?;
            let dir = config.out.join("sources");
            set.write_dir(&dir, &domain.source_layout)?;
            eprintln!(
                "source data: {:?} records, written to {} ({:.1} s)",
                set.sources.iter().map(|s| s.len()).collect::<Vec<_>>(),
                dir.display(),
                start.elapsed().as_secs_f64()
            );
            Ok(set)
        }
        dir => SourceSet::read_layout(
            Path::new(dir),
            &domain.source_layout,
            domain.sources.len(),
            domain.num_actions(),
        ),
    }
}

/// Builds the shared experiment context (sources, score tables, ideal weights, kernel
/// set-up) for the algorithms of `config`.
pub fn build_experiment<const D: usize>(
    config: &Config,
    domain: Arc<Domain<D>>,
    dynamics: Option<Dynamics>,
    hooks: Option<KernelHooks<D>>,
) -> anyhow::Result<Experiment<D>> {
    let args = &config.args;
    let sources = Arc::new(load_sources(config, &domain)?);
    let mut protocol = Protocol::published(&domain, config.steps, config.episodes_per_step);
    protocol.dynamics = dynamics;
    protocol.iterations = config.iterations;
    protocol.trees = config.trees;
    protocol.first_step = config.args.first_step.unwrap_or_default();
    protocol.q_function = config.args.q_function.unwrap_or_default();
    anyhow::ensure!(
        protocol.q_function.is_per_action()
            || (D == 2 && config.algorithms.iter().all(|&a| !a.is_active())),
        "--q-function joint (the reference's one forest over state and action value) applies \
         to 2-D states and the episodic baselines (fqi, iwfqi, iwfqi-heuristic, iwfqi-ideal, \
         rbt, sdt): use it on the Dam or Puddle World without the active algorithms"
    );
    let options = TransferOptions {
        variances: args.variances,
        noise: match args.noise {
            NoiseArg::Reference => NoiseSubtraction::Reference,
            NoiseArg::Principled => NoiseSubtraction::Principled,
        },
        gp: config.gp(),
        transition_weights: args.transition_weights,
        rbt_total: config.rbt_total,
        rbt_compliance: args.rbt_compliance,
        ideal_means: args.ideal_means,
        ..TransferOptions::default()
    };
    let wants = |a: Algorithm| config.algorithms.contains(&a);
    let start = Instant::now();
    let oracle_table = if wants(Algorithm::AwfqiOracle) {
        Some(Arc::new(ScoreTableData::oracle(
            &domain,
            config.setting,
            &sources,
            config.spacing,
        )?))
    } else {
        None
    };
    // The realistic table's source GPs also serve awfqi-adaptive (same streams).
    let source_gps = if wants(Algorithm::Awfqi) || wants(Algorithm::AwfqiAdaptive) {
        Some(score_tables::fit_source_gps(
            &domain,
            &sources,
            &options.gp,
            args.seed,
        )?)
    } else {
        None
    };
    let realistic_table = match &source_gps {
        Some(gps) if wants(Algorithm::Awfqi) => Some(Arc::new(ScoreTableData::realistic(
            &domain,
            config.setting,
            &sources,
            gps,
            config.spacing,
        )?)),
        _ => None,
    };
    let adaptive = match source_gps {
        Some(gps) if wants(Algorithm::AwfqiAdaptive) => {
            let rows = score_tables::rows(&domain, config.setting, &sources, config.spacing)?;
            Some(Arc::new(AdaptiveSetup::new(&domain, rows, &sources, gps)))
        }
        _ => None,
    };
    let wants_kernel = wants(Algorithm::AwfqiKernel) || wants(Algorithm::AwfqiAdaptiveKernel);
    let kernel = match (wants_kernel, hooks) {
        (true, Some(h)) => {
            let mut rng = stream(args.seed, &[SCORE_TABLE, 100]);
            let q = KernelQFunction::from_args(
                args.kernel_q,
                args.kernel_resolution,
                args.kernel_tilings,
            )?;
            let mut kernel = KernelConfig::new(config.setting, config.spacing).with_q(q);
            // The adaptive kernel's tiles (`tiles`, `hybrid`): 12 × 12 × 8 unless a
            // resolution is given, which then sets both kernels' tiles.
            let tiles = if args.kernel_resolution.is_some() {
                q
            } else {
                KernelQFunction::Tiles(ADAPTIVE_TILES, ADAPTIVE_TILINGS)
            };
            let knn = || {
                KernelQFunction::knn(
                    args.kernel_neighbours,
                    args.kernel_bandwidth,
                    args.kernel_reach,
                    args.kernel_common_ball,
                )
            };
            match (args.adaptive_kernel_q, knn()?, tiles) {
                (AdaptiveKernelQ::Knn, q, _) => kernel = kernel.with_adaptive_q(q),
                (
                    AdaptiveKernelQ::Hybrid,
                    KernelQFunction::Knn(k, h, r, c),
                    KernelQFunction::Tiles(n, t),
                ) => {
                    kernel = kernel.with_adaptive_q(KernelQFunction::Hybrid((n, t), (k, h, r, c)));
                }
                (AdaptiveKernelQ::Hybrid, _, _) => {
                    anyhow::bail!("--adaptive-kernel-q hybrid needs tiles (--kernel-q tiles)")
                }
                (AdaptiveKernelQ::Trees, _, _) => {
                    kernel = kernel.with_adaptive_q(KernelQFunction::trees(TreeKnobs {
                        trees: args.kernel_trees,
                        nodes: args.kernel_tree_nodes,
                        min_samples_split: args.kernel_min_samples_split,
                        min_samples_leaf: args.kernel_min_samples_leaf,
                        max_depth: args.kernel_tree_max_depth,
                        streamed: args.kernel_tree_streamed,
                    })?);
                }
                (AdaptiveKernelQ::Tiles, _, tiles) => kernel = kernel.with_adaptive_q(tiles),
                (AdaptiveKernelQ::Sweep, _, _) => {
                    kernel = kernel.with_adaptive_q(KernelQFunction::sweep(SweepKnobs {
                        cells: args.kernel_sweep_cells,
                        rewards: args.kernel_sweep_rewards.into(),
                        min_mass: args.kernel_sweep_min_mass,
                        lookahead: args.kernel_sweep_lookahead,
                    })?);
                }
            }
            Some(Arc::new((h.setup)(&sources, kernel, &mut rng)?))
        }
        _ => None,
    };
    if oracle_table.is_some() || realistic_table.is_some() || kernel.is_some() {
        eprintln!(
            "score tables ({} mode): built in {:.1} s",
            config.setting.name(),
            start.elapsed().as_secs_f64()
        );
    }
    let mut experiment = Experiment {
        domain,
        protocol,
        sources,
        options,
        oracle_table,
        realistic_table,
        ideal_weights: None,
        kernel,
        kernel_learner: hooks.map(|h| h.learner),
        adaptive_kernel_learner: hooks.map(|h| h.adaptive_learner),
        adaptive,
        adaptive_options: args.adaptive(),
    };
    experiment.variances()?;
    if wants(Algorithm::IwfqiIdeal) {
        let mut rng = stream(args.seed, &[IDEAL_WEIGHTS]);
        let weights = crate::transfer::algorithms::iwfqi::ideal_weights(
            &experiment.domain,
            &experiment.sources,
            experiment.domain.published.ideal_variances,
            experiment.ideal_means(),
            &mut rng,
        )?;
        experiment.ideal_weights = Some(Arc::new(weights));
    }
    Ok(experiment)
}

/// One run of one algorithm.
pub fn run_one<const D: usize>(
    experiment: &Experiment<D>,
    algorithm: Algorithm,
    run: usize,
    seed: u64,
    on_step: impl Fn(),
) -> anyhow::Result<RunRecord> {
    let start = Instant::now();
    let mut rng = stream(seed, &[RUN, algorithm.id(), run as u64]);
    let mut outcome = None;
    experiment.with_learner(algorithm, &mut rng, &mut |learner, rng| {
        let steps = protocol::run(
            &experiment.domain,
            &experiment.protocol,
            learner,
            rng,
            |_| on_step(),
        )?;
        outcome = Some((steps, learner.target_samples().to_vec()));
        Ok(())
    })?;
    let (steps, samples) = outcome.ok_or_else(|| anyhow!("{} did not run", algorithm.name()))?;
    let samples = if run < SAMPLE_RUNS {
        samples
            .iter()
            .map(|r| {
                let round = |x: f64| (x * 1e4).round() / 1e4;
                [round(r.state[0]), round(r.state[1]), r.action as f64]
            })
            .collect()
    } else {
        Vec::new()
    };
    Ok(RunRecord {
        run,
        parameters: experiment.parameters(algorithm),
        seconds: start.elapsed().as_secs_f64(),
        steps,
        samples,
    })
}

/// Rough cost order, so the longest runs start first.
fn cost_rank(a: Algorithm) -> usize {
    match a {
        Algorithm::Awfqi | Algorithm::AwfqiOracle | Algorithm::AwfqiAdaptive => 0,
        Algorithm::Iwfqi | Algorithm::IwfqiHeuristic => 1,
        Algorithm::Sdt | Algorithm::IwfqiIdeal | Algorithm::Rbt => 2,
        Algorithm::Fqi => 3,
        Algorithm::AwfqiKernel | Algorithm::AwfqiAdaptiveKernel => 4,
    }
}

/// Runs the experiment of `config` on `domain` in a pool of `--threads` threads and writes
/// every output.
pub fn run<const D: usize>(
    config: &Config,
    domain: Domain<D>,
    dynamics: Option<Dynamics>,
    hooks: Option<KernelHooks<D>>,
) -> anyhow::Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(config.args.threads)
        .build()
        .context("building the thread pool")?;
    pool.install(|| run_in_pool(config, Arc::new(domain), dynamics, hooks))
}

/// Creates `out` and checks that a file can be written in it, before any run starts.
pub fn ensure_writable(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("output directory {}: cannot be created", out.display()))?;
    // One probe per process: writers sharing the directory must not remove each other's.
    let probe = out.join(format!(".awfqi-write-probe.{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("output directory {}: cannot be written", out.display()))?;
    std::fs::remove_file(&probe).with_context(|| {
        format!(
            "output directory {}: cannot remove {}",
            out.display(),
            probe.display()
        )
    })
}

fn run_in_pool<const D: usize>(
    config: &Config,
    domain: Arc<Domain<D>>,
    dynamics: Option<Dynamics>,
    hooks: Option<KernelHooks<D>>,
) -> anyhow::Result<()> {
    let args = &config.args;
    let out = &config.out;
    ensure_writable(out)?;
    let wall = Instant::now();
    let algorithms = config.algorithms.clone();
    if algorithms.is_empty() {
        bail!("--algorithms needs at least one algorithm");
    }
    let build = Config {
        algorithms: if args.no_run {
            Vec::new()
        } else {
            algorithms.clone()
        },
        ..config.clone()
    };
    let experiment = build_experiment(&build, domain, dynamics, hooks)?;
    let runs: Vec<usize> = if args.no_run {
        Vec::new()
    } else {
        (config.runs.start..config.runs.end).collect()
    };
    let json = experiment_json(config, &experiment);
    // Before any run: every result file in --out must hold this configuration.
    let parameters = build
        .algorithms
        .iter()
        .map(|&a| (a, experiment.parameters(a)))
        .collect();
    let (store, notes) = ResultDir::open(
        out,
        json.clone(),
        parameters,
        &runs,
        recorded_command(&args.command),
        args.replace,
    )?;
    for note in &notes {
        eprintln!("note: {note}");
    }
    let mut kept: BTreeMap<Algorithm, Vec<usize>> = BTreeMap::new();
    let mut jobs: Vec<(Algorithm, usize)> = Vec::new();
    for &a in &build.algorithms {
        for &r in &runs {
            if !store.replaces() && store.present(a).is_some_and(|p| p.contains(&r)) {
                kept.entry(a).or_default().push(r);
            } else {
                jobs.push((a, r));
            }
        }
    }
    jobs.sort_by_key(|&(a, r)| (cost_rank(a), r));

    let multi = MultiProgress::new();
    if args.quiet {
        multi.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let style = ProgressStyle::with_template(
        "{prefix:>16} {bar:30} {pos:>3}/{len:3} steps  {elapsed:>5} (eta {eta})",
    )
    .map_err(|e| anyhow!("{e}"))?;
    let bars: BTreeMap<Algorithm, ProgressBar> = algorithms
        .iter()
        .map(|&a| {
            let todo = jobs.iter().filter(|&&(b, _)| b == a).count();
            let bar = multi.add(ProgressBar::new((todo * config.steps) as u64));
            bar.set_style(style.clone());
            bar.set_prefix(a.name());
            (a, bar)
        })
        .collect();
    let finished: Mutex<Vec<(Algorithm, RunRecord)>> = Mutex::new(Vec::new());
    jobs.par_iter()
        .try_for_each(|&(algorithm, run)| -> anyhow::Result<()> {
            let bar = &bars[&algorithm];
            let record = run_one(&experiment, algorithm, run, args.seed, || bar.inc(1))
                .with_context(|| format!("{} run {run}", algorithm.name()))?;
            // Each run is merged into its file as soon as it ends, so an interrupted
            // invocation keeps every finished run.
            let mut done = finished.lock().map_err(|_| anyhow!("poisoned"))?;
            store.save_run(algorithm, record.clone())?;
            if args.check_gp_search {
                // The fits checked so far (this run's and, with several threads, some of
                // the runs still going), kept even if the invocation is interrupted.
                write_search_checks(&store, &crate::transfer::gp::search_checks())?;
            }
            done.push((algorithm, record));
            Ok(())
        })?;
    for bar in bars.values() {
        bar.finish();
    }
    let compute_seconds = wall.elapsed().as_secs_f64();
    let finished = finished.into_inner().map_err(|_| anyhow!("poisoned"))?;
    let timing = timing_report(&store, &finished, compute_seconds)?;
    if args.check_gp_search {
        write_search_checks(&store, &crate::transfer::gp::search_checks())?;
        summarise_search_checks(out)?;
    }

    // Summarise every run in --out (this invocation's and earlier ones', all of this
    // configuration), with no writer half-way.
    let _lock = store.lock()?;
    let files: BTreeMap<Algorithm, ResultFile> = store.load()?;
    let summaries: Vec<(Algorithm, Vec<SummaryRow>)> = files
        .iter()
        .map(|(a, f)| (*a, f.summary(a.name())))
        .collect();
    let all_rows: Vec<SummaryRow> = summaries.iter().flat_map(|(_, r)| r.clone()).collect();
    write_summary(&out.join("summary.csv"), &all_rows)?;

    let baseline = summaries
        .iter()
        .find(|(a, _)| *a == Algorithm::Fqi)
        .map(|(_, r)| r.as_slice());
    let metrics: Vec<TransferMetrics> = summaries
        .iter()
        .filter_map(|(a, rows)| transfer_metrics(a.name(), rows, baseline, config.threshold))
        .collect();
    let report = report_markdown(config, &experiment, &summaries, &metrics);
    crate::store::write_atomic(&out.join("report.md"), report.as_bytes())?;
    write_csv(&out.join("transfer_metrics.csv"), &metrics)?;

    if !args.no_plots {
        let title = format!(
            "{}, setting {}, B = {}, {} run(s)",
            title(&experiment),
            config.setting.name(),
            config.episodes_per_step,
            files.values().map(|f| f.n_runs).max().unwrap_or(0)
        );
        let curve = |keep: &dyn Fn(Algorithm) -> bool| -> Vec<(String, usize, Vec<SummaryRow>)> {
            summaries
                .iter()
                .filter(|(a, _)| keep(*a))
                .map(|(a, rows)| (a.name().to_string(), a.color(), rows.clone()))
                .collect()
        };
        let std_path =
            curve(&|a| !matches!(a, Algorithm::AwfqiKernel | Algorithm::AwfqiAdaptiveKernel));
        let embedded = curve(&|a| {
            matches!(
                a,
                Algorithm::Fqi
                    | Algorithm::Awfqi
                    | Algorithm::AwfqiOracle
                    | Algorithm::AwfqiKernel
                    | Algorithm::AwfqiAdaptive
                    | Algorithm::AwfqiAdaptiveKernel
            )
        });
        let clip = experiment.protocol.dynamics.map(|_| figures::PUDDLE_CLIP);
        figures::learning_curves(&title, &std_path, &embedded, clip)
            .save(&out.join("learning_curves"))?;
        let samples: Vec<(Algorithm, String, usize, Vec<[f64; 3]>)> = files
            .iter()
            .filter_map(|(a, f)| {
                let run = f.runs.iter().find(|r| !r.samples.is_empty())?;
                Some((
                    *a,
                    format!("{} run {}", a.name(), run.run),
                    a.color(),
                    run.samples.clone(),
                ))
            })
            .collect();
        let dir = out.join("samples");
        std::fs::create_dir_all(&dir)?;
        let domain = &*experiment.domain;
        for (a, name, color, pts) in &samples {
            figures::sample_scatter(
                domain,
                &experiment.sources,
                &[(name.clone(), *color, pts.clone())],
            )
            .save(&dir.join(a.name()))?;
        }
        let overview: Vec<(String, usize, Vec<[f64; 3]>)> = samples
            .iter()
            .filter(|(a, ..)| {
                matches!(
                    a,
                    Algorithm::Fqi
                        | Algorithm::Iwfqi
                        | Algorithm::AwfqiOracle
                        | Algorithm::Awfqi
                        | Algorithm::AwfqiKernel
                        | Algorithm::AwfqiAdaptive
                )
            })
            .map(|(_, name, color, pts)| (name.clone(), *color, pts.clone()))
            .collect();
        if !overview.is_empty() {
            figures::sample_scatter(domain, &experiment.sources, &overview)
                .save(&out.join("target_samples"))?;
        }
    }
    println!("{report}");
    println!("{timing}");
    if !kept.is_empty() {
        println!("{}", kept_note(&kept, out));
    }
    println!("outputs in {}", out.display());
    Ok(())
}

/// "Kept 3 run(s) already in OUT (fqi: 0, 1; iwfqi: 0) …": the runs skipped because a
/// result file holds them.
fn kept_note(kept: &BTreeMap<Algorithm, Vec<usize>>, out: &Path) -> String {
    let total: usize = kept.values().map(Vec::len).sum();
    let lists: Vec<String> = kept
        .iter()
        .map(|(a, runs)| {
            let runs: Vec<String> = runs.iter().map(ToString::to_string).collect();
            format!("{}: {}", a.name(), runs.join(", "))
        })
        .collect();
    format!(
        "Kept {total} run(s) already in {} instead of recomputing them ({}); --replace recomputes them.",
        out.display(),
        lists.join("; ")
    )
}

/// "Puddle World, shared dynamics", "Dam", "Acrobot".
fn title<const D: usize>(experiment: &Experiment<D>) -> String {
    match experiment.protocol.dynamics {
        Some(d) => format!(
            "Puddle World, {} dynamics",
            protocol::dynamics_name::name(d)
        ),
        None => {
            let mut name = experiment.domain.name.to_string();
            if let Some(first) = name.get_mut(..1) {
                first.make_ascii_uppercase();
            }
            name
        }
    }
}

/// Appends this invocation's wall times to `timing.csv` (`algorithm,run,step,seconds`, one
/// row per step and one with step 0 for the whole run) and returns a Markdown table of the
/// mean time per run. Wall times are the only output that differs between identical
/// invocations, so they stay out of every other file.
fn timing_report(
    store: &ResultDir,
    finished: &[(Algorithm, RunRecord)],
    compute_seconds: f64,
) -> anyhow::Result<String> {
    use std::fmt::Write as _;
    let threads = rayon::current_num_threads();
    let mut rows = String::new();
    let mut per_algorithm: BTreeMap<Algorithm, Vec<f64>> = BTreeMap::new();
    for (a, r) in finished {
        for s in &r.steps {
            let _ = writeln!(
                rows,
                "{},{},{},{:.3},{threads}",
                a.name(),
                r.run,
                s.step,
                s.seconds
            );
        }
        let _ = writeln!(rows, "{},{},0,{:.3},{threads}", a.name(), r.run, r.seconds);
        per_algorithm.entry(*a).or_default().push(r.seconds);
    }
    {
        let _lock = store.lock()?;
        store.append_log("timing.csv", TIMING_HEADER, &rows)?;
    }
    let mut out = String::from("| algorithm | runs | wall time per run (s) |\n|---|---:|---:|\n");
    for (a, secs) in &per_algorithm {
        let mean = secs.iter().sum::<f64>() / secs.len() as f64;
        let _ = writeln!(out, "| {} | {} | {mean:.1} |", a.name(), secs.len());
    }
    let _ = writeln!(
        out,
        "\nThis invocation: {compute_seconds:.1} s on {threads} thread(s) (runs in parallel; a run uses one thread)."
    );
    Ok(out)
}

/// The GP search of the report's header: the one asked for, else the spec's and those of
/// the summarised `algorithms` whose default differs from it.
fn search_description<const D: usize>(
    algorithms: &[Algorithm],
    experiment: &Experiment<D>,
) -> String {
    if let Some(search) = experiment.options.gp.search {
        return format!("{search:?}");
    }
    let screened: Vec<&str> = algorithms
        .iter()
        .filter(|&&a| experiment.default_search(a) == GpSearch::Screened)
        .map(|a| a.name())
        .collect();
    if screened.is_empty() {
        format!("{:?}", GpSearch::Spec)
    } else {
        format!("Spec ({}: Screened)", screened.join(", "))
    }
}

/// The Markdown report: per-step means ± s.e. and transfer metrics.
fn report_markdown<const D: usize>(
    config: &Config,
    experiment: &Experiment<D>,
    summaries: &[(Algorithm, Vec<SummaryRow>)],
    metrics: &[TransferMetrics],
) -> String {
    use std::fmt::Write as _;
    let p = &experiment.protocol;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "## {}, setting {}, B = {}, K = {}\n",
        title(experiment).replacen(", ", ": ", 1),
        config.setting.name(),
        p.episodes_per_step,
        p.steps
    );
    let _ = writeln!(
        out,
        "Sources: {} ({:?} records). Seed {}. GP: {} restarts, max_gp {}, {} search. {} iterations, {} trees.\n",
        experiment.sources.origin,
        experiment
            .sources
            .sources
            .iter()
            .map(|s| s.len())
            .collect::<Vec<_>>(),
        config.args.seed,
        experiment.options.gp.restarts,
        experiment.options.gp.max_gp,
        search_description(
            &summaries.iter().map(|(a, _)| *a).collect::<Vec<_>>(),
            experiment
        ),
        p.iterations,
        p.trees
    );
    let steps = summaries.iter().map(|(_, r)| r.len()).max().unwrap_or(0);
    let _ = write!(out, "| algorithm | runs |");
    for k in 1..=steps {
        let _ = write!(out, " step {k} ({} ep.) |", k * p.episodes_per_step);
    }
    let _ = write!(out, "\n|---|---:|");
    for _ in 0..steps {
        let _ = write!(out, "---:|");
    }
    out.push('\n');
    for (a, rows) in summaries {
        let runs = rows.first().map_or(0, |r| r.runs);
        let _ = write!(out, "| {} | {} |", a.name(), runs);
        for r in rows {
            let _ = write!(out, " {:.2} ± {:.2} |", r.mean, r.stderr);
        }
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "\nCells: mean ± standard error across runs of `perf_disc_greedy_mean`.\n"
    );
    out.push_str(&markdown_table(metrics, config.threshold));
    out
}

/// Appends one row per checked fit to `gp_search_check.tsv` (header when it is new).
fn write_search_checks(
    store: &ResultDir,
    checks: &[crate::transfer::gp::SearchCheck],
) -> anyhow::Result<()> {
    use std::fmt::Write as _;
    let mut tsv = String::new();
    for c in checks {
        let m = &c.comparison;
        let _ = writeln!(
            tsv,
            "{:?}\t{}\t{:.12e}\t{:.12e}\t{:.3e}\t{}\t{}\t{:.3}\t{:.3}",
            c.search,
            c.points,
            m.log_marginal_likelihood,
            m.other_log_marginal_likelihood,
            m.relative_difference(),
            m.factorizations,
            m.other_factorizations,
            m.seconds,
            m.other_seconds
        );
    }
    let _lock = store.lock()?;
    store.append_log("gp_search_check.tsv", SEARCH_CHECK_HEADER, &tsv)
}

/// The header of `gp_search_check.tsv`.
const SEARCH_CHECK_HEADER: &str = "kept\tpoints\tlml_kept\tlml_other\trelative_difference\tfactorizations_kept\tfactorizations_other\tseconds_kept\tseconds_other\n";

/// The header of `timing.csv`.
pub const TIMING_HEADER: &str = "algorithm,run,step,seconds,threads\n";

/// Prints the largest relative log-marginal-likelihood difference of `gp_search_check.tsv`
/// and the factorisation and time totals of both searches.
fn summarise_search_checks(out: &std::path::Path) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(out.join("gp_search_check.tsv"))?;
    let (mut fits, mut worst) = (0usize, 0.0f64);
    let mut totals = [0.0f64; 4];
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split('\t').collect();
        let num = |i: usize| {
            f.get(i)
                .and_then(|v| v.parse::<f64>().ok())
                .unwrap_or(f64::NAN)
        };
        fits += 1;
        worst = worst.max(num(4));
        for (t, i) in totals.iter_mut().zip(5..9) {
            *t += num(i);
        }
    }
    eprintln!(
        "GP search check: {fits} fits, largest relative LML difference {worst:.3e}; \
         factorisations kept {} / other {}; seconds kept {:.1} / other {:.1}",
        totals[0], totals[1], totals[2], totals[3]
    );
    Ok(())
}
