//! `awfqi-harness puddle`: the Puddle World transfer experiments (spec §3–§9, §11–§13) —
//! every algorithm on the common protocol, result files in the reference's layout, a
//! summary, transfer metrics, learning curves and sample scatters.
//!
//! Runs of all algorithms go in parallel (rayon, `--threads`), each run seeded from
//! (`--seed`, algorithm, run index), so the same seed gives the same numbers whatever the
//! scheduling, and `--runs A..B` computes a slice of runs whose results merge into the
//! `<algorithm>.json` files already in `--out` (same configuration only).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, anyhow, bail};
use awfqi::env::Dynamics;
use awfqi::weights::NoiseSubtraction;
use clap::{Args as ClapArgs, ValueEnum};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::commands::identify::RunRange;
use crate::puddle::algorithms::{Algorithm, Experiment, TransferOptions, Variances, kernel};
use crate::puddle::gp::{GpOptions, GpSearch};
use crate::puddle::metrics::{TransferMetrics, markdown_table, transfer_metrics};
use crate::puddle::protocol::{self, Protocol};
use crate::puddle::results::{ResultFile, RunRecord, SAMPLE_RUNS, SummaryRow, write_summary};
use crate::puddle::score_tables::{self, Mode, ScoreTableData};
use crate::puddle::sources::{Generation, SourceSet};
use crate::puddle::{RUN, SCORE_TABLE, figures, stream};

/// The dynamics variants on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DynamicsArg {
    /// κ = 0: all tasks share their transitions (the thesis's setting).
    Shared,
    /// κ = 5: puddles slow the agent down.
    Puddle,
}

impl DynamicsArg {
    fn dynamics(self) -> Dynamics {
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

/// Arguments of `awfqi-harness puddle`.
#[derive(Debug, Clone, ClapArgs)]
pub struct Args {
    /// Score-table rows of AWFQI and AWFQI_oracle: thesis setting 1 (source), 2 (grid), 3
    /// (both).
    #[arg(long, value_enum, default_value = "grid")]
    pub setting: Mode,
    /// Episodes per step B (the active algorithms query H·B = 50·B pairs per step).
    #[arg(long, default_value_t = 1)]
    pub episodes_per_step: usize,
    /// Steps K.
    #[arg(long, default_value_t = 6)]
    pub steps: usize,
    /// Runs: a count N (runs 0..N) or a range A..B; results merge with those in --out.
    #[arg(long, default_value = "10")]
    pub runs: RunRange,
    /// Algorithms to run.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = default_algorithms())]
    pub algorithms: Vec<Algorithm>,
    /// Dynamics variant.
    #[arg(long, value_enum, default_value = "shared")]
    pub dynamics: DynamicsArg,
    /// Source data: `published` (the reference runs' data, embedded), `generate` (fresh, as
    /// spec §6; written to `<out>/sources`), or a directory with
    /// `{shared|puddle}_dynamics_source_{1,2,3}.csv` in the published layout.
    #[arg(long, default_value = "published")]
    pub sources: String,
    /// Experiment seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "results/puddle")]
    pub out: PathBuf,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// FQI iterations.
    #[arg(long, default_value_t = 60)]
    pub iterations: usize,
    /// Trees per forest.
    #[arg(long, default_value_t = 50)]
    pub trees: usize,
    /// GP restarts after the initial-value optimisation (spec: 10).
    #[arg(long, default_value_t = 10)]
    pub gp_restarts: usize,
    /// GP training cap `max_gp`: the last this many records (spec: 4000).
    #[arg(long, default_value_t = 4000)]
    pub max_gp: usize,
    /// GP hyperparameter search: `spec` (§4.2) or `screened` (faster, not the spec's
    /// procedure: starts screened on a 300-point subsample, then refined on all data).
    #[arg(long, value_enum, default_value = "spec")]
    pub gp_search: GpSearch,
    /// IWFQI/AWFQI estimator variances: `published` (v_r 0.1, v_s 0.2) or `corrected`
    /// (0.01, 0.04), spec §14.6.
    #[arg(long, value_enum, default_value = "published")]
    pub variances: Variances,
    /// Noise subtraction of the target GPs' stds (spec §14.7).
    #[arg(long, value_enum, default_value = "reference")]
    pub noise: NoiseArg,
    /// Transition weights of IWFQI on or off (default: off for shared, on for puddle
    /// dynamics, spec §7.6).
    #[arg(long)]
    pub transition_weights: Option<bool>,
    /// RBT's n_total (source records per step).
    #[arg(long, default_value_t = 500)]
    pub rbt_total: usize,
    /// Grid spacing of the score tables (thesis: 0.1).
    #[arg(long, default_value_t = score_tables::GRID_SPACING)]
    pub spacing: f64,
    /// Threshold of the "time to threshold" metric (discounted return).
    #[arg(long, default_value_t = -25.0, allow_hyphen_values = true)]
    pub threshold: f64,
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

fn default_algorithms() -> Vec<Algorithm> {
    Algorithm::DEFAULT.to_vec()
}

/// The configuration every run of a file shares (runs merge only when it is equal).
fn experiment_json(args: &Args, experiment: &Experiment) -> serde_json::Value {
    serde_json::json!({
        "environment": "puddle world",
        "dynamics": crate::puddle::protocol::dynamics_name::name(experiment.protocol.dynamics),
        "setting": args.setting.name(),
        "sources": experiment.sources.origin,
        "source_records": experiment.sources.sources.iter().map(|s| s.len()).collect::<Vec<_>>(),
        "seed": args.seed,
        "protocol": experiment.protocol,
        "options": experiment.options,
        "score_spacing": args.spacing,
    })
}

fn load_sources(args: &Args, dynamics: Dynamics) -> anyhow::Result<SourceSet> {
    match args.sources.as_str() {
        "published" => SourceSet::published(dynamics),
        "generate" => {
            let g = Generation {
                iterations: args.iterations,
                trees: args.trees,
                gp: GpOptions {
                    restarts: args.gp_restarts,
                    max_gp: args.max_gp,
                    search: args.gp_search,
                },
                ..Generation::default()
            };
            eprintln!(
                "generating source data (spec §6: 250 learning episodes, FQI, 20 greedy episodes, 3 GPs per source)…"
            );
            let start = Instant::now();
            let set = crate::puddle::sources::generate(dynamics, &g, args.seed, |_| ())?;
            let dir = args.out.join("sources");
            set.write_dir(&dir)?;
            eprintln!(
                "source data: {:?} records, written to {} ({:.1} s)",
                set.sources.iter().map(|s| s.len()).collect::<Vec<_>>(),
                dir.display(),
                start.elapsed().as_secs_f64()
            );
            Ok(set)
        }
        dir => SourceSet::read_dir(Path::new(dir), dynamics),
    }
}

/// Builds the shared experiment context (sources, score tables, kernel set-up).
pub fn build_experiment(args: &Args) -> anyhow::Result<Experiment> {
    if args.steps == 0 || args.episodes_per_step == 0 {
        bail!("--steps and --episodes-per-step must be positive");
    }
    let dynamics = args.dynamics.dynamics();
    let sources = Arc::new(load_sources(args, dynamics)?);
    let mut protocol = Protocol::reference(dynamics, args.steps, args.episodes_per_step);
    protocol.iterations = args.iterations;
    protocol.trees = args.trees;
    let options = TransferOptions {
        variances: args.variances,
        noise: match args.noise {
            NoiseArg::Reference => NoiseSubtraction::Reference,
            NoiseArg::Principled => NoiseSubtraction::Principled,
        },
        gp: GpOptions {
            restarts: args.gp_restarts,
            max_gp: args.max_gp,
            search: args.gp_search,
        },
        transition_weights: args.transition_weights,
        rbt_total: args.rbt_total,
        ..TransferOptions::default()
    };
    let wants = |a: Algorithm| args.algorithms.contains(&a);
    let start = Instant::now();
    let oracle_table = if wants(Algorithm::AwfqiOracle) {
        Some(Arc::new(ScoreTableData::oracle(
            args.setting,
            &sources,
            args.spacing,
        )?))
    } else {
        None
    };
    let realistic_table = if wants(Algorithm::Awfqi) {
        let gps = score_tables::fit_source_gps(&sources, &options.gp, args.seed)?;
        Some(Arc::new(ScoreTableData::realistic(
            args.setting,
            &sources,
            &gps,
            args.spacing,
        )?))
    } else {
        None
    };
    let kernel = if wants(Algorithm::AwfqiKernel) {
        let mut rng = stream(args.seed, &[SCORE_TABLE, 100]);
        Some(Arc::new(kernel::KernelSetup::new(
            &sources,
            args.setting,
            args.spacing,
            &mut rng,
        )?))
    } else {
        None
    };
    if oracle_table.is_some() || realistic_table.is_some() || kernel.is_some() {
        eprintln!(
            "score tables ({} mode): built in {:.1} s",
            args.setting.name(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(Experiment {
        protocol,
        sources,
        options,
        oracle_table,
        realistic_table,
        kernel,
    })
}

/// One run of one algorithm.
pub fn run_one(
    experiment: &Experiment,
    algorithm: Algorithm,
    run: usize,
    seed: u64,
    on_step: impl Fn(),
) -> anyhow::Result<RunRecord> {
    let start = Instant::now();
    let mut rng = stream(seed, &[RUN, algorithm.id(), run as u64]);
    let (steps, samples) = if algorithm == Algorithm::AwfqiKernel {
        kernel::run(experiment, &mut rng, |_| on_step())?
    } else {
        let mut learner = experiment.learner(algorithm)?;
        let steps = protocol::run(&experiment.protocol, learner.as_mut(), &mut rng, |_| {
            on_step()
        })?;
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

/// Runs the experiment and writes every output. Returns the summary rows.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .context("building the thread pool")?;
    pool.install(|| run_in_pool(args))
}

fn run_in_pool(args: &Args) -> anyhow::Result<()> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let wall = Instant::now();
    let mut algorithms = args.algorithms.clone();
    algorithms.sort();
    algorithms.dedup();
    if algorithms.is_empty() {
        bail!("--algorithms needs at least one algorithm");
    }
    let experiment = build_experiment(&Args {
        algorithms: if args.no_run {
            Vec::new()
        } else {
            algorithms.clone()
        },
        ..args.clone()
    })?;
    let runs: Vec<usize> = (args.runs.start..args.runs.end).collect();
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
            let bar = multi.add(ProgressBar::new((runs.len() * args.steps) as u64));
            bar.set_style(style.clone());
            bar.set_prefix(a.name());
            (a, bar)
        })
        .collect();
    let config = experiment_json(args, &experiment);
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
            save_run(&args.out, &config, algorithm, record.clone())?;
            done.push((algorithm, record));
            Ok(())
        })?;
    for bar in bars.values() {
        bar.finish();
    }
    let compute_seconds = wall.elapsed().as_secs_f64();
    let finished = finished.into_inner().map_err(|_| anyhow!("poisoned"))?;
    let timing = timing_report(args, &finished, compute_seconds)?;

    // Summarise every run of this configuration in --out (this invocation's and earlier
    // ones').
    let mut files: BTreeMap<Algorithm, ResultFile> = BTreeMap::new();
    for a in Algorithm::ALL {
        let path = args.out.join(format!("{}.json", a.name()));
        if let Ok(old) = ResultFile::read(&path)
            && old.experiment == config
        {
            files.insert(a, old);
        }
    }
    let summaries: Vec<(Algorithm, Vec<SummaryRow>)> = files
        .iter()
        .map(|(a, f)| (*a, f.summary(a.name())))
        .collect();
    let all_rows: Vec<SummaryRow> = summaries.iter().flat_map(|(_, r)| r.clone()).collect();
    write_summary(&args.out.join("summary.csv"), &all_rows)?;

    let baseline = summaries
        .iter()
        .find(|(a, _)| *a == Algorithm::Fqi)
        .map(|(_, r)| r.as_slice());
    let metrics: Vec<TransferMetrics> = summaries
        .iter()
        .filter_map(|(a, rows)| transfer_metrics(a.name(), rows, baseline, args.threshold))
        .collect();
    let report = report_markdown(args, &experiment, &summaries, &metrics);
    std::fs::write(args.out.join("report.md"), &report)?;
    let mut w = csv::Writer::from_path(args.out.join("transfer_metrics.csv"))?;
    for m in &metrics {
        w.serialize(m)?;
    }
    w.flush()?;

    if !args.no_plots {
        let title = format!(
            "Puddle World, {} dynamics, setting {}, B = {}, {} run(s)",
            crate::puddle::protocol::dynamics_name::name(experiment.protocol.dynamics),
            args.setting.name(),
            args.episodes_per_step,
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
            .save(&args.out.join("learning_curves"))?;
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
        let dir = args.out.join("samples");
        std::fs::create_dir_all(&dir)?;
        for (a, name, color, pts) in &samples {
            figures::sample_scatter(&experiment.sources, &[(name.clone(), *color, pts.clone())])
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
            figures::sample_scatter(&experiment.sources, &overview)
                .save(&args.out.join("target_samples"))?;
        }
    }
    println!("{report}");
    println!("{timing}");
    println!("outputs in {}", args.out.display());
    Ok(())
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
    args: &Args,
    finished: &[(Algorithm, RunRecord)],
    compute_seconds: f64,
) -> anyhow::Result<String> {
    use std::fmt::Write as _;
    use std::io::Write as _;
    let path = args.out.join("timing.csv");
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
fn report_markdown(
    args: &Args,
    experiment: &Experiment,
    summaries: &[(Algorithm, Vec<SummaryRow>)],
    metrics: &[TransferMetrics],
) -> String {
    use std::fmt::Write as _;
    let p = &experiment.protocol;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "## Puddle World: {} dynamics, setting {}, B = {}, K = {}\n",
        crate::puddle::protocol::dynamics_name::name(p.dynamics),
        args.setting.name(),
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
        args.seed,
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
    out.push_str(&markdown_table(metrics, args.threshold));
    out
}
