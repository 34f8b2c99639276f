//! The runs' progress while they go: a bar per algorithm on a terminal, else one line
//! per finished run.

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::time::Instant;

use anyhow::anyhow;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};

use crate::transfer::algorithms::Algorithm;
use crate::transfer::results::RunRecord;

/// The runs' progress: a bar per algorithm on a terminal, else one line per finished run
/// (a log, a pipe, CI), nothing with `--quiet`.
pub(super) struct Progress {
    /// Draws the bars (held so they stay drawn).
    _multi: MultiProgress,
    bars: BTreeMap<Algorithm, ProgressBar>,
    lines: bool,
    total: usize,
    start: Instant,
}

impl Progress {
    /// The progress of `jobs` of `steps` steps each, for `algorithms`, the invocation having
    /// started at `start`.
    ///
    /// Errors: the bars' template is refused.
    pub fn new(
        algorithms: &[Algorithm],
        jobs: &[(Algorithm, usize)],
        steps: usize,
        quiet: bool,
        start: Instant,
    ) -> anyhow::Result<Self> {
        let lines = !quiet && !std::io::stderr().is_terminal();
        let multi = MultiProgress::new();
        if quiet || lines {
            multi.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        let style = ProgressStyle::with_template(
            "{prefix:>16} {bar:30} {pos:>3}/{len:3} steps  {elapsed:>5} (eta {eta})",
        )
        .map_err(|e| anyhow!("{e}"))?;
        let bars = algorithms
            .iter()
            .map(|&a| {
                let todo = jobs.iter().filter(|&&(b, _)| b == a).count();
                let bar = multi.add(ProgressBar::new((todo * steps) as u64));
                bar.set_style(style.clone());
                bar.set_prefix(a.name());
                (a, bar)
            })
            .collect();
        Ok(Self {
            _multi: multi,
            bars,
            lines,
            total: jobs.len(),
            start,
        })
    }

    /// One step of a run of `algorithm` done.
    pub fn step(&self, algorithm: Algorithm) {
        if let Some(bar) = self.bars.get(&algorithm) {
            bar.inc(1);
        }
    }

    /// The `done`-th run, `record` of `algorithm`, finished and stored.
    pub fn run_done(&self, done: usize, algorithm: Algorithm, record: &RunRecord) {
        if self.lines {
            eprintln!(
                "{}",
                progress_line(done, self.total, algorithm, record, self.start)
            );
        }
    }

    /// Every run done.
    pub fn finish(&self) {
        for bar in self.bars.values() {
            bar.finish();
        }
    }
}

/// `[ 3/40] iwfqi run 2: last step -21.35 (6 steps, 5.3 s); 12 s elapsed`: one finished
/// run, for output that is not a terminal.
fn progress_line(
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
