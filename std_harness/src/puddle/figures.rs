//! The experiment's figures, through the harness's plotting helpers ([`crate::plot`]):
//! learning curves (mean ± standard error of `perf_disc_greedy_mean` against `n_episodes`,
//! §3.4) and scatters of the target samples each algorithm collected over the source states
//! (§13.2 output 2).

use crate::plot::{Figure, LegendPosition, Panel, Series, SeriesStyle, XScale};

use super::results::SummaryRow;
use super::sources::SourceSet;

/// The learning curves of all algorithms in one panel.
pub fn learning_curves(title: &str, curves: &[(String, usize, Vec<SummaryRow>)]) -> Figure {
    let series = curves
        .iter()
        .map(|(name, color, rows)| Series {
            label: name.clone(),
            points: rows.iter().map(|r| (r.n_episodes as f64, r.mean)).collect(),
            errors: Some(rows.iter().map(|r| r.stderr).collect()),
            style: SeriesStyle::LineWithMarkers,
            color: *color,
        })
        .collect();
    Figure {
        panels: vec![Panel {
            title: title.to_string(),
            x_label: "episodes (equivalent episodes for the active algorithms)".into(),
            y_label: "discounted greedy return".into(),
            x_scale: XScale::Linear,
            y_range: None,
            series,
            references: vec![],
            legend: LegendPosition::LowerRight,
        }],
        panel_width: 900,
        height: 560,
    }
}

/// One panel per algorithm: the source states (grey) and the target states the algorithm
/// collected in one run over all steps (coloured).
pub fn sample_scatter(sources: &SourceSet, samples: &[(String, usize, Vec<[f64; 3]>)]) -> Figure {
    let source_points: Vec<(f64, f64)> = sources
        .sources
        .iter()
        .flat_map(|s| s.records.iter().map(|r| (r.state[0], r.state[1])))
        .collect();
    let panels = samples
        .iter()
        .map(|(name, color, pts)| Panel {
            title: format!("{name} ({} samples)", pts.len()),
            x_label: "x".into(),
            y_label: "y".into(),
            x_scale: XScale::Linear,
            y_range: Some((-0.5, 10.5)),
            series: vec![
                Series {
                    label: "source states".into(),
                    points: source_points.clone(),
                    errors: None,
                    style: SeriesStyle::Points,
                    color: 7,
                },
                Series {
                    label: "target samples".into(),
                    points: pts.iter().map(|p| (p[0], p[1])).collect(),
                    errors: None,
                    style: SeriesStyle::Points,
                    color: *color,
                },
            ],
            references: vec![],
            legend: LegendPosition::UpperLeft,
        })
        .collect();
    Figure {
        panels,
        panel_width: 420,
        height: 460,
    }
}
