//! The report stage of a transfer command: the Markdown report (`report.md`), the figures
//! and what is printed at the end.

use std::collections::BTreeMap;
use std::path::Path;

use crate::transfer::algorithms::{Algorithm, Experiment};
use crate::transfer::figures;
use crate::transfer::gp::GpSearch;
use crate::transfer::metrics::markdown_table;
use crate::transfer::protocol;
use crate::transfer::results::ResultFile;
use crate::transfer::summary::Summary;

use super::Config;
use super::plan::Plan;

/// The report stage: writes `report.md` of `summary` and, unless `--no-plots`, the
/// figures of `files`, in `--out`; then prints the report, the invocation's `timing`
/// table, the runs `plan` kept and where the outputs are.
///
/// Errors: a write fails.
pub(super) fn publish<const D: usize>(
    config: &Config,
    plan: &Plan<D>,
    summary: &Summary,
    files: &BTreeMap<Algorithm, ResultFile>,
    timing: &str,
) -> anyhow::Result<()> {
    let out = &config.out;
    let experiment = &plan.experiment;
    let title = format!(
        "{}, setting {}, B = {}, {} run(s)",
        title(experiment),
        config.setting.name(),
        config.episodes_per_step,
        files.values().map(|f| f.n_runs).max().unwrap_or(0)
    );
    let kept = (!plan.kept.is_empty()).then(|| kept_note(&plan.kept, out));
    let report = report_markdown(config, experiment, summary);
    crate::store::write_atomic(&out.join("report.md"), report.as_bytes())?;
    if !config.args.no_plots {
        figures::write_figures(out, &title, &summary.curves, files, experiment)?;
    }
    println!("{report}");
    println!("{timing}");
    if let Some(kept) = kept {
        println!("{kept}");
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
    summary: &Summary,
) -> String {
    let summaries = &summary.curves;
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
    out.push_str(&markdown_table(&summary.metrics, summary.threshold));
    out
}
