//! Transfer metrics of a learning curve against the no-transfer baseline (FQI), after
//! Taylor & Stone (2009): computed on the per-step means of `perf_disc_greedy_mean`.
//!
//! - **jump-start**: the first step's mean minus FQI's first step's mean;
//! - **asymptotic performance**: the last step's mean;
//! - **total reward**: the sum of the per-step means (the area under the curve, one unit
//!   per step);
//! - **transfer ratio**: `(total − total_FQI) / |total_FQI|`, positive when the algorithm
//!   collects more reward over the curve than FQI (\[CHOICE\]: the returns are negative, so
//!   the textbook ratio of areas would invert its meaning; this relative difference keeps
//!   "larger is better");
//! - **time to threshold**: the first `n_episodes` at which the mean reaches the threshold
//!   (`None`: never within the steps run).

use serde::Serialize;

use super::results::SummaryRow;

/// The metrics of one algorithm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransferMetrics {
    /// Algorithm name.
    pub algorithm: String,
    /// First-step mean minus FQI's.
    pub jump_start: Option<f64>,
    /// Last-step mean.
    pub asymptotic: f64,
    /// Sum of the per-step means.
    pub total_reward: f64,
    /// `(total − total_FQI) / |total_FQI|`.
    pub transfer_ratio: Option<f64>,
    /// First `n_episodes` whose mean reaches the threshold.
    pub time_to_threshold: Option<usize>,
}

/// The metrics of `rows` (one algorithm's summary, by step) against `baseline` (FQI's).
pub fn transfer_metrics(
    algorithm: &str,
    rows: &[SummaryRow],
    baseline: Option<&[SummaryRow]>,
    threshold: f64,
) -> Option<TransferMetrics> {
    let first = rows.first()?;
    let last = rows.last()?;
    let total: f64 = rows.iter().map(|r| r.mean).sum();
    let base_total = baseline.map(|b| b.iter().map(|r| r.mean).sum::<f64>());
    Some(TransferMetrics {
        algorithm: algorithm.to_string(),
        jump_start: baseline
            .and_then(|b| b.first())
            .map(|b| first.mean - b.mean),
        asymptotic: last.mean,
        total_reward: total,
        transfer_ratio: base_total
            .filter(|t| *t != 0.0)
            .map(|t| (total - t) / t.abs()),
        time_to_threshold: rows
            .iter()
            .find(|r| r.mean >= threshold)
            .map(|r| r.n_episodes),
    })
}

/// The metrics as a Markdown table.
pub fn markdown_table(metrics: &[TransferMetrics], threshold: f64) -> String {
    let mut out = format!(
        "| algorithm | jump-start | asymptotic | total reward | transfer ratio vs FQI | episodes to reach {threshold} |\n|---|---:|---:|---:|---:|---:|\n"
    );
    let opt = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.2}"));
    for m in metrics {
        out.push_str(&format!(
            "| {} | {} | {:.2} | {:.2} | {} | {} |\n",
            m.algorithm,
            opt(m.jump_start),
            m.asymptotic,
            m.total_reward,
            opt(m.transfer_ratio),
            m.time_to_threshold
                .map_or("never".to_string(), |e| e.to_string()),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(means: &[f64]) -> Vec<SummaryRow> {
        means
            .iter()
            .enumerate()
            .map(|(i, &m)| SummaryRow {
                algorithm: "x".into(),
                step: i + 1,
                n_episodes: 10 * (i + 1),
                n_target_samples: 0.0,
                mean: m,
                stderr: 0.0,
                runs: 1,
            })
            .collect()
    }

    #[test]
    fn metrics_by_hand() {
        let fqi = rows(&[-50.0, -40.0, -30.0]);
        let alg = rows(&[-25.0, -20.0, -19.0]);
        let m = transfer_metrics("iwfqi", &alg, Some(&fqi), -22.0).unwrap();
        assert_eq!(m.jump_start, Some(25.0));
        assert_eq!(m.asymptotic, -19.0);
        assert_eq!(m.total_reward, -64.0);
        // (−64 − (−120)) / 120.
        assert!((m.transfer_ratio.unwrap() - 56.0 / 120.0).abs() < 1e-12);
        assert_eq!(m.time_to_threshold, Some(20));
        let never = transfer_metrics("fqi", &fqi, Some(&fqi), -22.0).unwrap();
        assert_eq!(never.time_to_threshold, None);
        assert_eq!(never.transfer_ratio, Some(0.0));
        assert!(markdown_table(&[m, never], -22.0).contains("| fqi | 0.00 |"));
    }
}
