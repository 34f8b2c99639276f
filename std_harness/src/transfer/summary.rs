//! What the runs of a result directory say together: each algorithm's per-step means ±
//! standard errors (`summary.csv`) and its transfer metrics against FQI
//! (`transfer_metrics.csv`), computed from every run in the directory, this invocation's
//! and earlier ones'.

use std::collections::BTreeMap;
use std::path::Path;

use super::algorithms::Algorithm;
use super::metrics::{TransferMetrics, transfer_metrics};
use super::results::{ResultFile, SummaryRow, write_summary};

/// The summary of a directory's result files.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Each algorithm's per-step rows, in the algorithm table's order.
    pub curves: Vec<(Algorithm, Vec<SummaryRow>)>,
    /// The transfer metrics of every algorithm with steps, against FQI's curve when the
    /// directory holds it.
    pub metrics: Vec<TransferMetrics>,
    /// The time-to-threshold level of the metrics.
    pub threshold: f64,
}

impl Summary {
    /// The summary of `files`, with `threshold` for the time to threshold.
    pub fn of(files: &BTreeMap<Algorithm, ResultFile>, threshold: f64) -> Self {
        let curves: Vec<(Algorithm, Vec<SummaryRow>)> = files
            .iter()
            .map(|(a, f)| (*a, f.summary(a.name())))
            .collect();
        let baseline = curves
            .iter()
            .find(|(a, _)| *a == Algorithm::Fqi)
            .map(|(_, r)| r.as_slice());
        let metrics = curves
            .iter()
            .filter_map(|(a, rows)| transfer_metrics(a.name(), rows, baseline, threshold))
            .collect();
        Self {
            curves,
            metrics,
            threshold,
        }
    }

    /// Writes `summary.csv` and `transfer_metrics.csv` in `out` (each atomically).
    ///
    /// Errors: a write fails.
    pub fn write(&self, out: &Path) -> anyhow::Result<()> {
        let rows: Vec<SummaryRow> = self.curves.iter().flat_map(|(_, r)| r.clone()).collect();
        write_summary(&out.join("summary.csv"), &rows)?;
        crate::store::write_csv(&out.join("transfer_metrics.csv"), &self.metrics)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transfer::protocol::{Diagnostics, StepRecord};
    use crate::transfer::results::RunRecord;

    fn run(i: usize, values: &[f64]) -> RunRecord {
        let step = |k: usize, value: f64| StepRecord {
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
        };
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

    fn files() -> BTreeMap<Algorithm, ResultFile> {
        let file = |runs| ResultFile::new(serde_json::json!({}), runs);
        BTreeMap::from([
            (Algorithm::Iwfqi, file(vec![run(0, &[-30.0, -10.0])])),
            (
                Algorithm::Fqi,
                file(vec![run(0, &[-60.0, -30.0]), run(1, &[-40.0, -20.0])]),
            ),
        ])
    }

    #[test]
    fn the_summary_holds_every_algorithm_s_curve_and_its_metrics_against_fqi() {
        let summary = Summary::of(&files(), -20.0);
        let order: Vec<Algorithm> = summary.curves.iter().map(|(a, _)| *a).collect();
        assert_eq!(order, [Algorithm::Fqi, Algorithm::Iwfqi]);
        let fqi: Vec<(f64, usize)> = summary.curves[0]
            .1
            .iter()
            .map(|r| (r.mean, r.runs))
            .collect();
        assert_eq!(fqi, [(-50.0, 2), (-25.0, 2)]);
        let iwfqi = &summary.metrics[1];
        assert_eq!(iwfqi.algorithm, "iwfqi");
        assert_eq!(iwfqi.jump_start, Some(20.0));
        assert_eq!((iwfqi.asymptotic, iwfqi.total_reward), (-10.0, -40.0));
        // (−40 − (−75)) / 75.
        assert!((iwfqi.transfer_ratio.unwrap() - 35.0 / 75.0).abs() < 1e-12);
        assert_eq!(iwfqi.time_to_threshold, Some(20));
        assert_eq!(summary.metrics[0].time_to_threshold, None);
    }

    #[test]
    fn the_summary_writes_both_tables() {
        let dir = std::env::temp_dir().join(format!("awfqi-summary-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Summary::of(&files(), -20.0).write(&dir).unwrap();
        let summary = std::fs::read_to_string(dir.join("summary.csv")).unwrap();
        let lines: Vec<&str> = summary.lines().collect();
        assert_eq!(lines.len(), 5, "{summary}");
        assert!(lines[1].starts_with("fqi,1,10,"), "{summary}");
        assert!(lines[4].starts_with("iwfqi,2,20,"), "{summary}");
        let metrics = std::fs::read_to_string(dir.join("transfer_metrics.csv")).unwrap();
        assert_eq!(metrics.lines().count(), 3, "{metrics}");
        assert!(
            metrics.lines().nth(2).unwrap().starts_with("iwfqi,20"),
            "{metrics}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
