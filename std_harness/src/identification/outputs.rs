//! The study's outputs: `identify.json`, `identify.csv`, the identification-rate and
//! policy-return figures, and the console table.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::Context;

use super::{K, PolicyName, Row, Study};
use crate::plot::{Figure, LegendPosition, Panel, Series, SeriesStyle, XScale};

/// Writes `identify.json`, `identify.csv` and (unless disabled) the two plots, each
/// atomically (a failed write leaves the previous file).
pub fn write_outputs(study: &Study, out: &Path, plots: bool) -> anyhow::Result<Vec<PathBuf>> {
    fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let json = out.join("identify.json");
    let mut text = serde_json::to_vec_pretty(study)?;
    text.push(b'\n');
    crate::store::write_atomic(&json, &text)?;
    let csv_path = out.join("identify.csv");
    crate::store::write_csv(&csv_path, &study.rows)?;
    let mut written = vec![json, csv_path];
    if plots {
        written.extend(identification_figure(study).save(&out.join("identification_rate"))?);
        written.extend(return_figure(study).save(&out.join("policy_return"))?);
    }
    Ok(written)
}

fn criterion_color(name: &str) -> usize {
    match name {
        "uniform" => 7,
        "variance" => 0,
        "mi" => 1,
        "adaptive" => 2,
        "adaptive-variance" => 3,
        "mi-literal" => 4,
        _ => 5,
    }
}

/// Fig. 4.2: identification rate (%) against the budget, one line per criterion, with
/// ± one binomial standard error.
pub fn identification_figure(study: &Study) -> Figure {
    let policy = study.config.policies[0].name();
    let series = study
        .config
        .criteria
        .iter()
        .map(|c| {
            let rows: Vec<&Row> = study
                .rows
                .iter()
                .filter(|r| r.criterion == c.name() && r.policy == policy)
                .collect();
            Series {
                label: c.name().to_string(),
                points: rows
                    .iter()
                    .map(|r| (r.budget as f64, 100.0 * r.identification_rate))
                    .collect(),
                errors: Some(
                    rows.iter()
                        .map(|r| {
                            let p = r.identification_rate;
                            100.0 * (p * (1.0 - p) / r.runs.max(1) as f64).sqrt()
                        })
                        .collect(),
                ),
                style: SeriesStyle::LineWithMarkers,
                color: criterion_color(c.name()),
            }
        })
        .collect();
    let runs = study.records.len();
    Figure::single(Panel {
        title: format!("Identification rate of θ* (Grid World, {runs} runs)"),
        x_label: "budget n (queries)".into(),
        y_label: "runs with MAP = θ* (%)".into(),
        x_scale: XScale::Log2,
        x_range: None,
        y_range: Some((0.0, 105.0)),
        series,
        references: vec![(format!("chance (1/{K})"), 100.0 / K as f64)],
        legend: LegendPosition::LowerRight,
    })
}

/// Fig. 4.3: mean return of the chosen policy in the true MDP, one panel per policy,
/// ± one standard error, with the mean optimal return for reference.
pub fn return_figure(study: &Study) -> Figure {
    let lo = study
        .rows
        .iter()
        .map(|r| r.return_mean - r.return_stderr)
        .fold(f64::INFINITY, f64::min);
    let hi = study
        .rows
        .iter()
        .map(|r| (r.return_mean + r.return_stderr).max(r.optimal_return))
        .fold(f64::NEG_INFINITY, f64::max);
    let pad = 0.05 * (hi - lo).max(1e-9);
    let optimal = study.rows.first().map_or(0.0, |r| r.optimal_return);
    let panels = study
        .config
        .policies
        .iter()
        .map(|p| Panel {
            title: match p {
                PolicyName::Map => "MAP policy (thesis)".to_string(),
                PolicyName::Belief => "Belief-weighted policy".to_string(),
            },
            x_label: "budget n (queries)".into(),
            y_label: "return from (0,0) in the true MDP".into(),
            x_scale: XScale::Log2,
            x_range: None,
            y_range: Some((lo - pad, hi + pad)),
            series: study
                .config
                .criteria
                .iter()
                .map(|c| {
                    let rows: Vec<&Row> = study
                        .rows
                        .iter()
                        .filter(|r| r.criterion == c.name() && r.policy == p.name())
                        .collect();
                    Series {
                        label: c.name().to_string(),
                        points: rows
                            .iter()
                            .map(|r| (r.budget as f64, r.return_mean))
                            .collect(),
                        errors: Some(rows.iter().map(|r| r.return_stderr).collect()),
                        style: SeriesStyle::LineWithMarkers,
                        color: criterion_color(c.name()),
                    }
                })
                .collect(),
            references: vec![("mean V*".to_string(), optimal)],
            legend: LegendPosition::LowerRight,
        })
        .collect();
    Figure {
        panels,
        panel_width: 650,
        height: 480,
    }
}

/// A plain-text table of the rows.
pub fn table(study: &Study) -> String {
    let mut s = format!(
        "{:<18} {:<7} {:>6} {:>8} {:>16}\n",
        "criterion", "policy", "budget", "id rate", "return ± se"
    );
    for r in &study.rows {
        s.push_str(&format!(
            "{:<18} {:<7} {:>6} {:>7.0}% {:>8.3} ± {:.3}\n",
            r.criterion,
            r.policy,
            r.budget,
            100.0 * r.identification_rate,
            r.return_mean,
            r.return_stderr
        ));
    }
    if let Some(r) = study.rows.first() {
        s.push_str(&format!(
            "mean optimal return V*(s0): {:.3}\n",
            r.optimal_return
        ));
    }
    s
}
