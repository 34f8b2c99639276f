//! The invocation's logs in the output directory, beside the result files: the wall times
//! (`timing.csv`) and the GP-search check (`gp_search_check.tsv`). Wall times are the only
//! output that differs between identical invocations, so they stay out of every other file.

use std::collections::BTreeMap;
use std::time::Instant;

use crate::transfer::algorithms::Algorithm;
use crate::transfer::result_dir::ResultDir;
use crate::transfer::results::RunRecord;

/// Closes the invocation's logs in `store`: appends the wall times of the `finished` runs to
/// `timing.csv` ([`timing_report`]) and, with `check_gp_search`, the fits checked since the
/// last run's append to `gp_search_check.tsv`, whose totals it prints. Returns the timing table.
///
/// Errors: a log cannot be read or written.
pub(super) fn log_invocation(
    store: &ResultDir,
    finished: &[(Algorithm, RunRecord)],
    start: Instant,
    check_gp_search: bool,
) -> anyhow::Result<String> {
    let compute_seconds = start.elapsed().as_secs_f64();
    let timing = timing_report(store, finished, compute_seconds)?;
    if check_gp_search {
        write_search_checks(store, &crate::transfer::gp::search_checks())?;
        summarise_search_checks(store.path())?;
    }
    Ok(timing)
}

/// Appends this invocation's wall times to `timing.csv` (`algorithm,run,step,seconds`, one
/// row per step and one with step 0 for the whole run) and returns a Markdown table of the
/// mean time per run.
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
