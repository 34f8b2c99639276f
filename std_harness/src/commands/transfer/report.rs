//! What a transfer command prints and logs besides the result files: the Markdown report,
//! the per-run progress lines, the wall-time log and the GP-search check.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use crate::transfer::algorithms::{Algorithm, Experiment};
use crate::transfer::gp::GpSearch;
use crate::transfer::metrics::{TransferMetrics, markdown_table};
use crate::transfer::protocol;
use crate::transfer::result_dir::ResultDir;
use crate::transfer::results::{RunRecord, SummaryRow};

use super::Config;

/// `[ 3/40] iwfqi run 2: last step -21.35 (6 steps, 5.3 s); 12 s elapsed`: one finished
/// run, for output that is not a terminal.
pub(super) fn progress_line(
    done: usize,
    total: usize,
    algorithm: Algorithm,
    record: &RunRecord,
    start: Instant,
) -> String {
    let width = total.to_string().len();
    let last = record
        .steps
        .last()
        .map_or(f64::NAN, |s| s.perf_disc_greedy_mean);
    format!(
        "[{done:>width$}/{total}] {} run {}: last step {last:.2} ({} steps, {:.1} s); {:.0} s elapsed",
        algorithm.name(),
        record.run,
        record.steps.len(),
        record.seconds,
        start.elapsed().as_secs_f64()
    )
}

/// "Kept 3 run(s) already in OUT (fqi: 0, 1; iwfqi: 0) …": the runs skipped because a
/// result file holds them.
pub(super) fn kept_note(kept: &BTreeMap<Algorithm, Vec<usize>>, out: &Path) -> String {
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
pub(super) fn title<const D: usize>(experiment: &Experiment<D>) -> String {
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
pub(super) fn timing_report(
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
pub(super) fn report_markdown<const D: usize>(
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
pub(super) fn write_search_checks(
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
pub(super) fn summarise_search_checks(out: &std::path::Path) -> anyhow::Result<()> {
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
