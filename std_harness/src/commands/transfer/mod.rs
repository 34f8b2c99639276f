//! The transfer-experiment commands (`awfqi-harness puddle`, `dam`, `acrobot`): every
//! algorithm on the common protocol of one domain, result files in the reference's layout,
//! a summary, transfer metrics, learning curves and sample scatters.
//!
//! The three commands share their options ([`Args`]); an option left out takes the
//! domain's default ([`crate::domains::Published`]: Puddle World's thesis setting 2 (b),
//! the Dam's and Acrobot's published configurations). Runs of all algorithms go in parallel (rayon,
//! `--threads`), each run seeded from (`--seed`, algorithm, run index), so the same seed
//! gives the same numbers whatever the scheduling, and `--runs A..B` computes a slice of
//! runs whose results merge into the `<algorithm>.json` files already in `--out`
//! ([`crate::transfer::result_dir`]: same configuration only, runs already there kept,
//! writers locked).

mod config;
mod report;
mod run;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use awfqi::env::Dynamics;
use awfqi::weights::NoiseSubtraction;
use clap::{Args as ClapArgs, ValueEnum};
use rand_chacha::ChaCha8Rng;

use crate::domains::{Domain, IdealMeans};
use crate::gp_large::fixed::PredictiveVariance;
use crate::run_range::RunRange;
use crate::transfer::algorithms::adaptive::{AdaptiveOptions, AdaptiveOracle, AdaptiveSetup};
use crate::transfer::algorithms::adaptive_kernel::{
    ADAPTIVE_TILES, ADAPTIVE_TILINGS, ADAPTIVE_TREE_NODES, ADAPTIVE_TREES,
};
use crate::transfer::algorithms::awfqi_kernel::{
    KernelConfig, KernelQFunction, KernelSetup, TreeKnobs,
};
use crate::transfer::algorithms::rbt::ComplianceSum;
use crate::transfer::algorithms::{
    Algorithm, Experiment, ScopedLearner, TransferOptions, Variances,
};
use crate::transfer::domain_data::DomainData;
use crate::transfer::gp::{FixedGpUpdate, GpSearch};
use crate::transfer::protocol::{self, Protocol};
use crate::transfer::score_tables::{self, Mode, ScoreTableData};
use crate::transfer::sources::SourceSet;

use crate::transfer::{IDEAL_WEIGHTS, SCORE_TABLE, stream};
pub use config::{
    AlgorithmChoice, BASELINES_AND_AWFQI, Config, MAX_EPISODES_PER_STEP, MAX_GP_POINTS,
    MAX_GP_RESTARTS, MAX_ITERATIONS, MAX_RUN_INDEX, MAX_STEPS, MAX_TREES,
};
pub use report::TIMING_HEADER;
use run::load_sources;
pub use run::{ensure_writable, run, run_one};

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
    /// Algorithms to run, or `all` of those the domain runs. Default: Puddle World
    /// fqi, iwfqi, awfqi, awfqi-adaptive-kernel; the Dam and Acrobot fqi, iwfqi,
    /// iwfqi-ideal, rbt, sdt, awfqi, awfqi-oracle.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub algorithms: Vec<AlgorithmChoice>,
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
    pub q_function: Option<crate::joint_q::ForestLayout>,
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
    #[arg(long, value_enum, default_value = "trees")]
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
            corroborate: self.adaptive_corroborate,
            oracle: self.adaptive_oracle,
            select: self.adaptive_select,
        }
    }
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

/// Builds the shared experiment context (sources, score tables, ideal weights, kernel
/// set-up) for the algorithms of `config`.
pub fn build_experiment<const D: usize>(
    config: &Config,
    domain: Arc<Domain<D>>,
    data: Arc<DomainData<D>>,
    dynamics: Option<Dynamics>,
    hooks: Option<KernelHooks<D>>,
) -> anyhow::Result<Experiment<D>> {
    let args = &config.args;
    let sources = Arc::new(load_sources(config, &domain, &data)?);
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
            &data.weighting,
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
            let q = match args.kernel_q {
                KernelQ::Tabular => KernelQFunction::tabular(args.kernel_resolution)?,
                KernelQ::Tiles => {
                    KernelQFunction::tiles(args.kernel_resolution, args.kernel_tilings)?
                }
            };
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
        data,
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
