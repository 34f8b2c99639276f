//! The transfer commands' arguments, in groups each command flattens: every command's
//! ([`CommonArgs`]) and the fixed-kernel GPs' of the IWFQI paper's domains
//! ([`FixedGpArgs`], `dam` and `acrobot`); the core's algorithms' are in
//! [`super::embedded`], Puddle World's own in [`crate::commands::puddle`].

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use crate::domains::IdealMeans;
use crate::gp_large::fixed::PredictiveVariance;
use crate::joint_q::ForestLayout;
use crate::run_range::RunRange;
use crate::transfer::algorithms::Variances;
use crate::transfer::algorithms::rbt::ComplianceSum;
use crate::transfer::gp::{FixedGpUpdate, GpSearch};
use crate::transfer::protocol::FirstStep;
use crate::transfer::score_tables::Mode;

use super::AlgorithmChoice;
use super::embedded::{AdaptiveArgs, EmbeddedArgs};

/// Noise subtraction of the target GPs' stds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum NoiseArg {
    /// The reference's rule: subtract the noise std (§4.2, §14.7).
    Reference,
    /// `√max(v − σ²ₙ, 0)`.
    Principled,
}

/// The options of every transfer command (`puddle`, `dam`, `acrobot`). Options without a
/// value take the domain's default (see each command's help).
#[derive(Debug, Clone, Args)]
pub struct CommonArgs {
    /// Score-table rows of AWFQI and AWFQI_oracle: thesis setting 1 (source), 2 (grid), 3
    /// (both). Default: grid.
    #[arg(long, value_enum)]
    pub setting: Option<Mode>,
    /// Episodes per step B (the active algorithms query H·B pairs per step). Default:
    /// Puddle World 1, Dam 1, Acrobot 10.
    #[arg(long)]
    pub episodes_per_step: Option<usize>,
    /// Generative-model queries per step of the active algorithms (awfqi, awfqi-oracle,
    /// awfqi-embedded, awfqi-adaptive). Default: H·B, the samples of the step's episodes.
    #[arg(long)]
    pub queries_per_step: Option<usize>,
    /// Cut the episodes of the episodic algorithms (fqi, iwfqi, rbt, sdt, …) to this many
    /// steps: with `--episodes-per-step B`, at most B·L target samples per step, the same
    /// number as a query budget of B·L. Default: the domain's horizon.
    #[arg(long)]
    pub episode_length: Option<usize>,
    /// Steps K. Default: Puddle World 6, Dam 10, Acrobot 20.
    #[arg(long)]
    pub steps: Option<usize>,
    /// Runs: a count N (runs 0..N) or a range A..B (at most 100 000 runs); results merge
    /// with those in --out.
    /// Default: Puddle World 10, Dam and Acrobot 20.
    #[arg(long)]
    pub runs: Option<RunRange>,
    /// Algorithms to run, or `all` of those the domain runs. Default: Puddle World
    /// fqi, iwfqi, awfqi, awfqi-adaptive; the Dam and Acrobot fqi, iwfqi,
    /// iwfqi-ideal, rbt, sdt, awfqi, awfqi-oracle.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub algorithms: Vec<AlgorithmChoice>,
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
    /// Worker threads (0: all cores; at most 4 per core).
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
    /// IWFQI/AWFQI estimator variances: `published` or (Puddle World only) `corrected`
    /// (0.01, 0.04), spec §14.6.
    #[arg(long, value_enum, default_value = "published")]
    pub variances: Variances,
    /// Noise subtraction of the target GPs' stds (spec §14.7).
    #[arg(long, value_enum, default_value = "reference")]
    pub noise: NoiseArg,
    /// Transition weights of IWFQI on (every state coordinate) or off (default: the
    /// published configuration: off for shared, on for puddle dynamics, spec §7.6; the
    /// Dam's storage; Acrobot's four coordinates). awfqi-embedded weighs transitions only
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
    pub first_step: Option<FirstStep>,
    /// FQI's Q-function: `per-action` forests (spec §5, the default) or `joint`, one forest
    /// over (state, action value) as the reference code fits on the Dam (whose action
    /// space it leaves undeclared). An ablation; FQI on 2-D states (Dam, Puddle World) only.
    #[arg(long, value_enum)]
    pub q_function: Option<ForestLayout>,
    /// FQI keeps the trees of this iteration (≥ 2) and only refits their leaf values in
    /// the later ones, a fixed averaging operator (absent: every iteration grows new trees,
    /// spec §5). A speed option, compared with the default in docs/large-data.md.
    #[arg(long, value_parser = clap::value_parser!(u64).range(2..))]
    pub freeze_trees_after: Option<u64>,
    /// With `--freeze-trees-after K`: grow and freeze new trees every R iterations after
    /// K (K + R, K + 2R, …), so the frozen operator follows the changing targets at a
    /// fraction of the cost of new trees every iteration. A speed option, compared with the
    /// default in docs/large-data.md.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..), requires = "freeze_trees_after")]
    pub regrow_trees_every: Option<u64>,
    /// Grid spacing of the score tables. Default: Puddle World 0.1 (both coordinates), Dam
    /// 10 (storage; every day), Acrobot π/6 (angles; 9 values per velocity).
    #[arg(long)]
    pub spacing: Option<f64>,
    /// Threshold of the "time to threshold" metric (discounted return). Default: Puddle
    /// World −25, Dam −1000, Acrobot −50.
    #[arg(long, allow_hyphen_values = true)]
    pub threshold: Option<f64>,
    /// Skip the plots.
    #[arg(long)]
    pub no_plots: bool,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    /// Compute nothing: summarise and plot the runs of this configuration already in --out.
    #[arg(long)]
    pub no_run: bool,
    /// Recompute runs already in --out, and start anew a result file of an algorithm asked
    /// for that holds another
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
}

/// How the fixed-kernel GPs of the IWFQI paper's domains (Dam, Acrobot) are computed.
#[derive(Debug, Clone, Copy, Default, Args)]
pub struct FixedGpArgs {
    /// How IWFQI's fixed-kernel target GPs (Dam, Acrobot) follow the target data:
    /// `incremental` appends each step's records to the factor and to the posterior at the
    /// source records (the refit's posterior to rounding, ≈ 10× fewer flops on Acrobot,
    /// but it holds every GP's factor and `L⁻¹K(X, Q)` between steps: ≈ 7 GB a run on
    /// Acrobot's last step); `compact` appends the same way holding only the factor's
    /// lower triangle and recomputing what an append needs from kernel evaluations (the
    /// same posterior to rounding; Acrobot: 2.3 GB a run instead of 7.7 GB); `refit` reconditions on all
    /// target records every step, as the reference.
    #[arg(long, value_enum, default_value_t = FixedGpUpdate::default())]
    pub fixed_gp: FixedGpUpdate,
    /// How the fixed-kernel GPs (Dam, Acrobot) compute their predictive variance:
    /// `stable` (`k** − ‖L⁻¹k*‖²`) or `explicit-inverse` (`k** − k*ᵀK⁻¹k*` with `K⁻¹`
    /// formed, negatives set to 0: scikit-learn ≤ 0.23's arithmetic, which the IWFQI
    /// reference ran; an ablation, implies `--fixed-gp refit` for IWFQI's target GPs).
    #[arg(long, value_enum, default_value_t = PredictiveVariance::default())]
    pub fixed_gp_variance: PredictiveVariance,
}

/// The arguments of `awfqi-harness dam` and `acrobot`.
#[derive(Debug, Clone, Args)]
pub struct PaperArgs {
    /// Every transfer command's options.
    #[command(flatten)]
    pub common: CommonArgs,
    /// The fixed-kernel GPs' options.
    #[command(flatten)]
    pub fixed_gp: FixedGpArgs,
    /// `awfqi-embedded`'s options.
    #[command(flatten)]
    pub embedded: EmbeddedArgs,
    /// `awfqi-adaptive`'s options.
    #[command(flatten)]
    pub adaptive: AdaptiveArgs,
}
