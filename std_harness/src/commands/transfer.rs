//! The transfer-experiment commands (`awfqi-harness puddle`, `dam`, `acrobot`): every
//! algorithm on the common protocol of one domain, result files in the reference's layout,
//! a summary, transfer metrics, learning curves and sample scatters.
//!
//! The three commands share their options ([`Args`]); an option left out takes the
//! domain's default ([`Defaults`]: Puddle World's thesis setting 2 (b), the Dam's and
//! Acrobot's published configurations). Runs of all algorithms go in parallel (rayon,
//! `--threads`), each run seeded from (`--seed`, algorithm, run index), so the same seed
//! gives the same numbers whatever the scheduling, and `--runs A..B` computes a slice of
//! runs whose results merge into the `<algorithm>.json` files already in `--out` (same
//! configuration only).

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

use crate::commands::identify::RunRange;
use crate::domains::{Domain, IdealMeans};
use crate::puddle::algorithms::{
    Algorithm, Experiment, KernelRunner, TransferOptions, Variances, kernel,
};
use crate::puddle::gp::{GpOptions, GpSearch};
use crate::puddle::metrics::{TransferMetrics, markdown_table, transfer_metrics};
use crate::puddle::protocol::{self, Protocol};
use crate::puddle::results::{ResultFile, RunRecord, SAMPLE_RUNS, SummaryRow, write_summary};
use crate::puddle::score_tables::{self, Mode, ScoreTableData};
use crate::puddle::sources::SourceSet;
use crate::puddle::{IDEAL_WEIGHTS, RUN, SCORE_TABLE, figures, stream};

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
    /// the Puddle-World-only awfqi-kernel).
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
    /// GP hyperparameter search: `spec` (§4.2) or `screened` (faster, not the spec's
    /// procedure: starts screened on a 300-point subsample, then refined on all data).
    #[arg(long, value_enum, default_value = "spec")]
    pub gp_search: GpSearch,
    /// IWFQI/AWFQI estimator variances: `published` or (Puddle World only) `corrected`
    /// (0.01, 0.04), spec §14.6.
    #[arg(long, value_enum, default_value = "published")]
    pub variances: Variances,
    /// Noise subtraction of the target GPs' stds (spec §14.7).
    #[arg(long, value_enum, default_value = "reference")]
    pub noise: NoiseArg,
    /// Transition weights of IWFQI on (every state coordinate) or off (default: the
    /// published configuration: off for shared, on for puddle dynamics, spec §7.6; the
    /// Dam's storage; Acrobot's four coordinates).
    #[arg(long)]
    pub transition_weights: Option<bool>,
    /// How IWFQI-ideal gets the models' mean next states (default: the published way:
    /// exact for Puddle World and Acrobot, one sampled step for the Dam).
    #[arg(long, value_enum)]
    pub ideal_means: Option<IdealMeans>,
    /// RBT's n_total (source records per step). Default: Puddle World 500, Dam 60000,
    /// Acrobot 10000.
    #[arg(long)]
    pub rbt_total: Option<usize>,
    /// Step 1's collection policy: `uniform` (spec §3.2, the default) or `zero-q` (the
    /// reference code's ε-greedy around a zero Q-function: mostly the first action).
    #[arg(long, value_enum)]
    pub first_step: Option<protocol::FirstStep>,
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

/// The core kernel's hooks on a domain: its set-up and its run (Puddle World only until
/// the kernel is generic over the state dimension).
#[derive(Debug, Clone, Copy)]
pub struct KernelHooks<const D: usize> {
    /// Builds the kernel's set-up from the sources, the setting, the spacing and a stream.
    pub setup: fn(&SourceSet<D>, Mode, f64, &mut ChaCha8Rng) -> anyhow::Result<kernel::KernelSetup>,
    /// Runs it.
    pub run: KernelRunner<D>,
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
            Algorithm::DEFAULT
                .into_iter()
                .filter(|&a| kernel_available || a != Algorithm::AwfqiKernel)
                .collect()
        } else {
            args.algorithms.clone()
        };
        algorithms.sort();
        algorithms.dedup();
        if algorithms.contains(&Algorithm::AwfqiKernel) && !kernel_available {
            bail!(
                "awfqi-kernel runs on Puddle World only until the core's kernel path is generic over the state dimension"
            );
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
        if config.steps == 0 || config.episodes_per_step == 0 {
            bail!("--steps and --episodes-per-step must be positive");
        }
        Ok(config)
    }

    fn gp(&self) -> GpOptions {
        GpOptions {
            restarts: self.args.gp_restarts,
            max_gp: self.max_gp,
            search: self.args.gp_search,
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
                crate::puddle::sources::generate(domain, &generation, &config.gp(), args.seed)?;
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
    let options = TransferOptions {
        variances: args.variances,
        noise: match args.noise {
            NoiseArg::Reference => NoiseSubtraction::Reference,
            NoiseArg::Principled => NoiseSubtraction::Principled,
        },
        gp: config.gp(),
        transition_weights: args.transition_weights,
        rbt_total: config.rbt_total,
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
    let realistic_table = if wants(Algorithm::Awfqi) {
        let gps = score_tables::fit_source_gps(&domain, &sources, &options.gp, args.seed)?;
        Some(Arc::new(ScoreTableData::realistic(
            &domain,
            config.setting,
            &sources,
            &gps,
            config.spacing,
        )?))
    } else {
        None
    };
    let kernel = match (wants(Algorithm::AwfqiKernel), hooks) {
        (true, Some(h)) => {
            let mut rng = stream(args.seed, &[SCORE_TABLE, 100]);
            Some(Arc::new((h.setup)(
                &sources,
                config.setting,
                config.spacing,
                &mut rng,
            )?))
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
        kernel_runner: hooks.map(|h| h.run),
    };
    experiment.variances()?;
    if wants(Algorithm::IwfqiIdeal) {
        let mut rng = stream(args.seed, &[IDEAL_WEIGHTS]);
        let weights = crate::puddle::algorithms::iwfqi::ideal_weights(
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
    let (steps, samples) = if algorithm == Algorithm::AwfqiKernel {
        let runner = experiment.kernel_runner.ok_or_else(|| {
            anyhow!(
                "awfqi-kernel is not available on {}",
                experiment.domain.name
            )
        })?;
        runner(experiment, &mut rng, &mut |_| on_step())?
    } else {
        let mut learner = experiment.learner(algorithm)?;
        let steps = protocol::run(
            &experiment.domain,
            &experiment.protocol,
            learner.as_mut(),
            &mut rng,
            |_| on_step(),
        )?;
        (steps, learner.target_samples().to_vec())
    };
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
        Algorithm::Awfqi | Algorithm::AwfqiOracle => 0,
        Algorithm::Iwfqi | Algorithm::IwfqiHeuristic => 1,
        Algorithm::Sdt | Algorithm::IwfqiIdeal | Algorithm::Rbt => 2,
        Algorithm::Fqi => 3,
        Algorithm::AwfqiKernel => 4,
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

fn run_in_pool<const D: usize>(
    config: &Config,
    domain: Arc<Domain<D>>,
    dynamics: Option<Dynamics>,
    hooks: Option<KernelHooks<D>>,
) -> anyhow::Result<()> {
    let args = &config.args;
    let out = &config.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
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
    let runs: Vec<usize> = (config.runs.start..config.runs.end).collect();
    let mut jobs: Vec<(Algorithm, usize)> = algorithms
        .iter()
        .flat_map(|&a| runs.iter().map(move |&r| (a, r)))
        .collect();
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
            let bar = multi.add(ProgressBar::new((runs.len() * config.steps) as u64));
            bar.set_style(style.clone());
            bar.set_prefix(a.name());
            (a, bar)
        })
        .collect();
    let json = experiment_json(config, &experiment);
    let finished: Mutex<Vec<(Algorithm, RunRecord)>> = Mutex::new(Vec::new());
    let jobs = if args.no_run { Vec::new() } else { jobs };
    jobs.par_iter()
        .try_for_each(|&(algorithm, run)| -> anyhow::Result<()> {
            let bar = &bars[&algorithm];
            let record = run_one(&experiment, algorithm, run, args.seed, || bar.inc(1))
                .with_context(|| format!("{} run {run}", algorithm.name()))?;
            // Each run is merged into its file as soon as it ends, so an interrupted
            // invocation keeps every finished run.
            let mut done = finished.lock().map_err(|_| anyhow!("poisoned"))?;
            save_run(out, &json, algorithm, record.clone())?;
            done.push((algorithm, record));
            Ok(())
        })?;
    for bar in bars.values() {
        bar.finish();
    }
    let compute_seconds = wall.elapsed().as_secs_f64();
    let finished = finished.into_inner().map_err(|_| anyhow!("poisoned"))?;
    let timing = timing_report(out, &finished, compute_seconds)?;

    // Summarise every run of this configuration in --out (this invocation's and earlier
    // ones').
    let mut files: BTreeMap<Algorithm, ResultFile> = BTreeMap::new();
    for a in Algorithm::ALL {
        let path = out.join(format!("{}.json", a.name()));
        if let Ok(old) = ResultFile::read(&path)
            && old.experiment == json
        {
            files.insert(a, old);
        }
    }
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
    std::fs::write(out.join("report.md"), &report)?;
    let mut w = csv::Writer::from_path(out.join("transfer_metrics.csv"))?;
    for m in &metrics {
        w.serialize(m)?;
    }
    w.flush()?;

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
        let std_path = curve(&|a| a != Algorithm::AwfqiKernel);
        let embedded = curve(&|a| {
            matches!(
                a,
                Algorithm::Fqi | Algorithm::Awfqi | Algorithm::AwfqiOracle | Algorithm::AwfqiKernel
            )
        });
        figures::learning_curves(&title, &std_path, &embedded)
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
    println!("outputs in {}", out.display());
    Ok(())
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

/// Merges one finished run into `<out>/<algorithm>.json` (created when absent; a file of
/// another configuration is replaced, with a note).
fn save_run(
    out: &Path,
    config: &serde_json::Value,
    algorithm: Algorithm,
    record: RunRecord,
) -> anyhow::Result<()> {
    let path = out.join(format!("{}.json", algorithm.name()));
    let mut file = ResultFile::new(config.clone(), vec![record]);
    if path.exists() {
        match ResultFile::read(&path) {
            Ok(mut old) if old.experiment == *config => {
                old.merge(file)?;
                file = old;
            }
            _ => eprintln!(
                "note: {} holds another configuration; replacing it",
                path.display()
            ),
        }
    }
    file.write(&path)
}

/// Appends this invocation's wall times to `timing.csv` (`algorithm,run,step,seconds`, one
/// row per step and one with step 0 for the whole run) and returns a Markdown table of the
/// mean time per run. Wall times are the only output that differs between identical
/// invocations, so they stay out of every other file.
fn timing_report(
    out: &Path,
    finished: &[(Algorithm, RunRecord)],
    compute_seconds: f64,
) -> anyhow::Result<String> {
    use std::fmt::Write as _;
    use std::io::Write as _;
    let path = out.join("timing.csv");
    let new = !path.exists();
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)?;
    if new {
        writeln!(file, "algorithm,run,step,seconds,threads")?;
    }
    let threads = rayon::current_num_threads();
    let mut per_algorithm: BTreeMap<Algorithm, Vec<f64>> = BTreeMap::new();
    for (a, r) in finished {
        for s in &r.steps {
            writeln!(
                file,
                "{},{},{},{:.3},{threads}",
                a.name(),
                r.run,
                s.step,
                s.seconds
            )?;
        }
        writeln!(file, "{},{},0,{:.3},{threads}", a.name(), r.run, r.seconds)?;
        per_algorithm.entry(*a).or_default().push(r.seconds);
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
        "Sources: {} ({:?} records). Seed {}. GP: {} restarts, max_gp {}, {:?} search. {} iterations, {} trees.\n",
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
        experiment.options.gp.search,
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
