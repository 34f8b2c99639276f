//! The experiment's figures, through the harness's plotting helpers ([`crate::plot`]):
//! learning curves (mean ± standard error of `perf_disc_greedy_mean` against `n_episodes`,
//! §3.4) and scatters of the target samples each algorithm collected over the source states
//! (§13.2 output 2).

use crate::plot::{Figure, LegendPosition, Panel, Series, SeriesStyle, XScale};

use super::results::SummaryRow;
use super::sources::SourceSet;
use crate::domains::Domain;

/// Curves as `(label, colour, summary rows)`.
pub type Curves = [(String, usize, Vec<SummaryRow>)];

fn curve_panel(title: String, curves: &Curves) -> Panel {
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
    Panel {
        title,
        x_label: "episodes (equivalent episodes for the active algorithms)".into(),
        y_label: "discounted greedy return".into(),
        x_scale: XScale::Linear,
        y_range: None,
        series,
        references: vec![],
        legend: LegendPosition::LowerRight,
    }
}

/// Learning curves: the faithful std algorithms in the left panel; FQI, AWFQI,
/// AWFQI_oracle and the kernel's embedded AWFQI in the right one (omitted when empty).
pub fn learning_curves(title: &str, std_path: &Curves, embedded: &Curves) -> Figure {
    let mut panels = vec![curve_panel(title.to_string(), std_path)];
    if embedded.iter().any(|(name, ..)| name == "awfqi-kernel") {
        panels.push(curve_panel(
            "embedded kernel path vs std AWFQI".into(),
            embedded,
        ));
    }
    Figure {
        panels,
        panel_width: 820,
        height: 560,
    }
}

/// One panel per algorithm: the source states (yellow) and the target states the algorithm
/// collected in one run over all steps (coloured), on the first two state coordinates.
pub fn sample_scatter<const D: usize>(
    domain: &Domain<D>,
    sources: &SourceSet<D>,
    samples: &[(String, usize, Vec<[f64; 3]>)],
) -> Figure {
    let axis = |d: usize| domain.state_names.get(d).copied().unwrap_or("").to_string();
    let (lo, hi) = domain.state_bounds.get(1).copied().unwrap_or((0.0, 1.0));
    let pad = 0.05 * (hi - lo);
    let source_points: Vec<(f64, f64)> = sources
        .sources
        .iter()
        .flat_map(|s| s.records.iter().map(|r| (r.state[0], r.state[1])))
        .collect();
    let panels = samples
        .iter()
        .map(|(name, color, pts)| Panel {
            title: format!("{name} ({} samples)", pts.len()),
            x_label: axis(0),
            y_label: axis(1),
            x_scale: XScale::Linear,
            y_range: Some((lo - pad, hi + pad)),
            series: vec![
                Series {
                    label: "source states".into(),
                    points: source_points.clone(),
                    errors: None,
                    style: SeriesStyle::Points,
                    color: 6,
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
