//! Running a transfer experiment: the runs in parallel, each saved as it ends, then the
//! summary, the report, the metrics and the plots of every run in the output directory.

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, anyhow, bail};
use awfqi::env::Dynamics;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::domains::Domain;
use crate::store::write_csv;
use crate::transfer::algorithms::{Algorithm, Experiment};
use crate::transfer::domain_data::DomainData;
use crate::transfer::metrics::{TransferMetrics, transfer_metrics};
use crate::transfer::protocol;
use crate::transfer::result_dir::{ResultDir, recorded_command};
use crate::transfer::results::{ResultFile, RunRecord, SAMPLE_RUNS, SummaryRow, write_summary};
use crate::transfer::{RUN, figures, stream};

use super::report::{
    kept_note, progress_line, report_markdown, summarise_search_checks, timing_report, title,
    write_search_checks,
};
use super::{Config, EmbeddedPath, build_experiment};

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
        Algorithm::Iwfqi | Algorithm::IwfqiHeuristic | Algorithm::AwfqiAdaptive => 0,
        Algorithm::Awfqi | Algorithm::AwfqiOracle => 1,
        Algorithm::Sdt | Algorithm::IwfqiIdeal | Algorithm::Rbt => 2,
        Algorithm::Fqi => 3,
        Algorithm::AwfqiEmbedded => 4,
    }
}

/// Runs the experiment of `config` on `domain` in a pool of `--threads` threads and writes
/// every output.
pub fn run<const D: usize>(
    config: &Config,
    domain: Domain<D>,
    data: DomainData<D>,
    dynamics: Option<Dynamics>,
    embedded: Option<EmbeddedPath<D>>,
) -> anyhow::Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(config.args.threads)
        .build()
        .context("building the thread pool")?;
    pool.install(|| run_in_pool(config, Arc::new(domain), Arc::new(data), dynamics, embedded))
}

/// Creates `out` and checks that a file can be written in it, before any run starts (and
/// after every check that can refuse the invocation, so a refusal creates no directory).
pub fn ensure_writable(out: &Path) -> anyhow::Result<()> {
    if out.exists() && !out.is_dir() {
        bail!(
            "output directory {}: it exists and is not a directory",
            out.display()
        );
    }
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
    data: Arc<DomainData<D>>,
    dynamics: Option<Dynamics>,
    embedded: Option<EmbeddedPath<D>>,
) -> anyhow::Result<()> {
    let args = &config.args;
    let out = &config.out;
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
    let experiment = build_experiment(&build, domain, data, dynamics, embedded)?;
    ensure_writable(out)?;
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

    // Progress: bars on a terminal, else one line per finished run (a log, a pipe, CI).
    let lines = !args.quiet && !std::io::stderr().is_terminal();
    let multi = MultiProgress::new();
    if args.quiet || lines {
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
            if lines {
                eprintln!(
                    "{}",
                    progress_line(done.len() + 1, jobs.len(), algorithm, &record, wall)
                );
            }
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
        let every = curve(&|_| true);
        let active = curve(&|a| a == Algorithm::Fqi || a.is_active());
        let clip = experiment.protocol.dynamics.map(|_| figures::PUDDLE_CLIP);
        figures::learning_curves(&title, &every, &active, clip)
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
        // FQI's and IWFQI's episodes against every active algorithm's queries.
        let overview: Vec<(String, usize, Vec<[f64; 3]>)> = samples
            .iter()
            .filter(|(a, ..)| matches!(a, Algorithm::Fqi | Algorithm::Iwfqi) || a.is_active())
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
