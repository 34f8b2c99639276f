//! Running a transfer experiment as a pipeline of named stages: plan the invocation
//! ([`Plan`]), run the planned jobs in parallel, each stored in its result file as it ends
//! ([`run_jobs`]), load every run the directory holds under its lock
//! ([`ResultDir::load_locked`](crate::transfer::result_dir::ResultDir::load_locked)), summarise them ([`Summary`]) and report
//! ([`report::publish`]).

use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, anyhow};
use awfqi::env::Dynamics;
use rayon::prelude::*;

use crate::domains::Domain;
use crate::transfer::algorithms::{Algorithm, Experiment};
use crate::transfer::domain_data::DomainData;
use crate::transfer::protocol;
use crate::transfer::results::{RunRecord, SAMPLE_RUNS};
use crate::transfer::summary::Summary;
use crate::transfer::{RUN, stream};

use super::logs;
use super::plan::Plan;
use super::progress::Progress;
use super::report;
use super::{Config, EmbeddedPath};

/// One run of one algorithm.
pub fn run_one<const D: usize>(
    experiment: &Experiment<D>,
    algorithm: Algorithm,
    run: usize,
    seed: u64,
    on_step: impl Fn(),
) -> anyhow::Result<RunRecord> {
    let start = Instant::now();
    let parameters = experiment.parameters(algorithm);
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
        parameters,
        seconds: start.elapsed().as_secs_f64(),
        steps,
        samples,
    })
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

/// The stages, in the pool.
fn run_in_pool<const D: usize>(
    config: &Config,
    domain: Arc<Domain<D>>,
    data: Arc<DomainData<D>>,
    dynamics: Option<Dynamics>,
    embedded: Option<EmbeddedPath<D>>,
) -> anyhow::Result<()> {
    let args = &config.args;
    let wall = Instant::now();
    let plan = Plan::new(config, domain, data, dynamics, embedded)?;
    let progress = Progress::new(
        &config.algorithms,
        &plan.jobs,
        config.steps,
        args.quiet,
        wall,
    )?;
    let finished = run_jobs(&plan, &progress, args.seed, args.check_gp_search)?;
    let timing = logs::log_invocation(&plan.store, &finished, wall, args.check_gp_search)?;
    // Every run in --out (this invocation's and earlier ones', all of this configuration),
    // with no writer half-way, and no writer until the outputs below are written.
    let (_lock, files) = plan.store.load_locked()?;
    let summary = Summary::of(&files, config.threshold);
    summary.write(&config.out)?;
    report::publish(config, &plan, &summary, &files, &timing)
}

/// Runs `plan`'s jobs in parallel, each merged into its result file as soon as it ends, so
/// an interrupted invocation keeps every finished run; `progress` hears of every step and
/// run, and with `check_gp_search` the fits checked so far are logged after every run.
///
/// Errors: the first run or save that fails, naming the algorithm and the run.
fn run_jobs<const D: usize>(
    plan: &Plan<D>,
    progress: &Progress,
    seed: u64,
    check_gp_search: bool,
) -> anyhow::Result<Vec<(Algorithm, RunRecord)>> {
    let finished: Mutex<Vec<(Algorithm, RunRecord)>> = Mutex::new(Vec::new());
    plan.jobs
        .par_iter()
        .try_for_each(|&(algorithm, run)| -> anyhow::Result<()> {
            let on_step = || progress.step(algorithm);
            let record = run_one(&plan.experiment, algorithm, run, seed, on_step)
                .with_context(|| format!("{} run {run}", algorithm.name()))?;
            let mut done = finished.lock().map_err(|_| anyhow!("poisoned"))?;
            plan.store.save_run(algorithm, record.clone())?;
            progress.run_done(done.len() + 1, algorithm, &record);
            if check_gp_search {
                // The fits checked so far (this run's and, with several threads, some of
                // the runs still going), kept even if the invocation is interrupted.
                logs::write_search_checks(&plan.store, &crate::transfer::gp::search_checks())?;
            }
            done.push((algorithm, record));
            Ok(())
        })?;
    progress.finish();
    finished.into_inner().map_err(|_| anyhow!("poisoned"))
}
