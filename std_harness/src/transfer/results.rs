//! Result files in the reference's layout (spec §3.4): one `<algorithm>.json` per algorithm
//! with `experiment`, `n_runs` and `runs[]`, each run with its parameters and `steps[]`
//! (and the command that made them, so the outputs can be regenerated elsewhere); the
//! aggregated `summary.csv`; and merging of runs computed separately (`--runs A..B`).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};

use super::protocol::StepRecord;

/// One run of one algorithm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Run index (its seed is derived from the experiment seed, the algorithm and this).
    pub run: usize,
    /// The algorithm's parameters (§3.4).
    pub parameters: serde_json::Value,
    /// Wall time of the run, seconds (not written: see `timing.csv`).
    #[serde(skip)]
    pub seconds: f64,
    /// Per-step records.
    pub steps: Vec<StepRecord>,
    /// The target `(s_x, s_y, a)` collected over all steps (kept for runs 0–2 only, for
    /// the scatter plots).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub samples: Vec<[f64; 3]>,
}

/// Runs whose collected samples are kept in the result files.
pub const SAMPLE_RUNS: usize = 3;

/// One `<algorithm>.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// The experiment's configuration (the same for every run; runs merge only when equal).
    pub experiment: serde_json::Value,
    /// The command line that computes these runs, without the options that only say where
    /// and how (`--runs`, `--out`, `--threads`, …): `awfqi-harness merge` regenerates the
    /// summary and plots with it. Empty when unknown.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub command: Vec<String>,
    /// Number of runs in the file.
    pub n_runs: usize,
    /// The runs, by increasing index.
    pub runs: Vec<RunRecord>,
}

impl ResultFile {
    /// A file of `runs` (sorted by index).
    pub fn new(experiment: serde_json::Value, mut runs: Vec<RunRecord>) -> Self {
        runs.sort_by_key(|r| r.run);
        Self {
            experiment,
            command: Vec::new(),
            n_runs: runs.len(),
            runs,
        }
    }

    /// The file recording `command` (kept as it was when `command` is empty).
    pub fn with_command(mut self, command: &[String]) -> Self {
        if !command.is_empty() {
            self.command = command.to_vec();
        }
        self
    }

    /// Merges `other`'s runs into this file: a run index present in both takes `other`'s.
    ///
    /// Errors: different experiment configurations.
    pub fn merge(&mut self, other: ResultFile) -> anyhow::Result<()> {
        if self.experiment != other.experiment {
            bail!("cannot merge runs of different experiment configurations");
        }
        let mut by_index: BTreeMap<usize, RunRecord> =
            self.runs.drain(..).map(|r| (r.run, r)).collect();
        for r in other.runs {
            by_index.insert(r.run, r);
        }
        self.runs = by_index.into_values().collect();
        self.n_runs = self.runs.len();
        Ok(())
    }

    /// Reads a file.
    ///
    /// Errors: it cannot be read or parsed, or it holds a run index twice.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let file: Self =
            serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        crate::store::unique_runs(path, file.runs.iter().map(|r| r.run))?;
        Ok(file)
    }

    /// Writes the file (pretty JSON) atomically ([`crate::store::write_atomic`]): an
    /// interrupted or failed write leaves the previous file as it was.
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        crate::store::write_atomic(path, text.as_bytes())
    }

    /// Per-step statistics across runs (§3.4 aggregation).
    pub fn summary(&self, algorithm: &str) -> Vec<SummaryRow> {
        let steps = self.runs.iter().map(|r| r.steps.len()).max().unwrap_or(0);
        (0..steps)
            .filter_map(|i| {
                let at: Vec<&StepRecord> =
                    self.runs.iter().filter_map(|r| r.steps.get(i)).collect();
                let first = at.first()?;
                let values: Vec<f64> = at.iter().map(|s| s.perf_disc_greedy_mean).collect();
                let (mean, stderr) = mean_and_stderr(&values);
                let samples: Vec<f64> = at.iter().map(|s| s.n_target_samples as f64).collect();
                Some(SummaryRow {
                    algorithm: algorithm.to_string(),
                    step: first.step,
                    n_episodes: first.n_episodes,
                    n_target_samples: mean_and_stderr(&samples).0,
                    mean,
                    stderr,
                    runs: values.len(),
                })
            })
            .collect()
    }
}

/// Mean and standard error (population std / √n) of `values` (§3.4); (NaN, NaN) when empty.
pub fn mean_and_stderr(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, (var / n).sqrt())
}

/// One row of `summary.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    /// Algorithm name.
    pub algorithm: String,
    /// Step `k`.
    pub step: usize,
    /// `k·B`.
    pub n_episodes: usize,
    /// Mean over runs of `|D₀|`.
    pub n_target_samples: f64,
    /// Mean over runs of `perf_disc_greedy_mean`.
    pub mean: f64,
    /// Its standard error across runs.
    pub stderr: f64,
    /// Number of runs.
    pub runs: usize,
}

/// Writes `summary.csv` with the columns `algorithm,step,n_episodes,n_target_samples,mean,
/// stderr,runs` (atomically).
pub fn write_summary(path: &Path, rows: &[SummaryRow]) -> anyhow::Result<()> {
    crate::store::write_csv(path, rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transfer::protocol::Diagnostics;

    fn step(k: usize, value: f64) -> StepRecord {
        StepRecord {
            step: k,
            n_episodes: 10 * k,
            n_target_samples: 100 * k,
            perf_disc_greedy_mean: value,
            perf_disc_greedy_std: 0.0,
            perf_disc_greedy_steps: 20.0,
            perf_disc_greedy_goals: 5,
            perf_avg_greedy_mean: None,
            perf_avg_greedy_std: None,
            seconds: 0.0,
            diagnostics: Diagnostics::default(),
        }
    }

    fn run(i: usize, values: &[f64]) -> RunRecord {
        RunRecord {
            run: i,
            parameters: serde_json::json!({}),
            seconds: 0.0,
            steps: values
                .iter()
                .enumerate()
                .map(|(k, &v)| step(k + 1, v))
                .collect(),
            samples: vec![],
        }
    }

    #[test]
    fn summary_is_the_mean_and_standard_error_across_runs() {
        let file = ResultFile::new(
            serde_json::json!({"x": 1}),
            vec![run(1, &[-40.0, -20.0]), run(0, &[-60.0, -30.0])],
        );
        assert_eq!(file.runs[0].run, 0);
        let rows = file.summary("fqi");
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].mean, -50.0);
        // Population std 10, n = 2: s.e. 10/√2.
        assert!((rows[0].stderr - 10.0 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(rows[1].mean, -25.0);
        assert_eq!(rows[1].n_episodes, 20);
        assert_eq!(rows[1].runs, 2);
    }

    #[test]
    fn merging_replaces_and_adds_runs_and_refuses_other_experiments() {
        let e = serde_json::json!({"seed": 0});
        let mut a = ResultFile::new(e.clone(), vec![run(0, &[-1.0]), run(1, &[-2.0])]);
        let b = ResultFile::new(e, vec![run(1, &[-5.0]), run(2, &[-3.0])]);
        a.merge(b).unwrap();
        assert_eq!(a.n_runs, 3);
        let values: Vec<f64> = a
            .runs
            .iter()
            .map(|r| r.steps[0].perf_disc_greedy_mean)
            .collect();
        assert_eq!(values, vec![-1.0, -5.0, -3.0]);
        let other = ResultFile::new(serde_json::json!({"seed": 1}), vec![]);
        assert!(a.merge(other).is_err());
        // JSON round trip keeps the layout.
        let back: ResultFile = serde_json::from_str(&serde_json::to_string(&a).unwrap()).unwrap();
        assert_eq!(back, a);
    }
}
