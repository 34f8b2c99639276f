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

/// The lowest mean a clipped panel shows: returns below it (stuck or puddle-crossing
/// runs, −100 to −600 at the first steps) would squash every other difference.
pub const CLIP_BELOW: f64 = -110.0;

/// `panel` restricted to `y ∈ [lo, hi]` (bands cut at the edges) over the steps with
/// `x ≥ from`; every mean below `lo` is drawn on the bottom edge and marked with a black
/// point ("clipped") so that it is not read as a value. `hi` is the data's maximum (with
/// errors) padded by 5 % of the range when `None`.
fn clipped(mut panel: Panel, lo: f64, hi: Option<f64>, from: f64) -> Panel {
    let mut marks = Vec::new();
    let mut top = f64::NEG_INFINITY;
    for s in &mut panel.series {
        let errors = s.errors.take().unwrap_or_else(|| vec![0.0; s.points.len()]);
        let kept: Vec<((f64, f64), f64)> = s
            .points
            .iter()
            .copied()
            .zip(errors)
            .filter(|((x, _), _)| *x >= from)
            .collect();
        s.points = kept.iter().map(|&((x, y), _)| (x, y.max(lo))).collect();
        s.errors = Some(
            kept.iter()
                .map(|&((_, y), e)| if y < lo { 0.0 } else { e.min(y - lo) })
                .collect(),
        );
        for &((x, y), e) in &kept {
            top = top.max(y + e);
            if y < lo {
                marks.push((x, lo));
            }
        }
    }
    let hi = hi.unwrap_or(top + 0.05 * (top - lo).abs().max(1.0));
    if !marks.is_empty() {
        panel.series.push(Series {
            label: format!("clipped (mean below {lo})"),
            points: marks,
            errors: None,
            style: SeriesStyle::Points,
            color: 7,
        });
    }
    panel.y_range = Some((lo, hi));
    panel
}

/// Where the learning curves are clipped: Puddle World's returns live in [−50, 0] once
/// learned, with stuck runs far below; the Dam's (≈ −2 000) and Acrobot's (≈ −50) scales
/// need no clip ([`learning_curves`] with `None`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clip {
    /// Means below this are drawn on the main panel's bottom edge ([`CLIP_BELOW`]).
    pub below: f64,
    /// The zoom panel never reaches below this (−50).
    pub zoom_floor: f64,
}

/// Puddle World's clip: [`CLIP_BELOW`] and a zoom floor of −50.
pub const PUDDLE_CLIP: Clip = Clip {
    below: CLIP_BELOW,
    zoom_floor: -50.0,
};

/// Learning curves: the faithful std algorithms with the main panel clipped at
/// `clip.below` (clipped means marked; no clip with `None`) and a zoom on the asymptote
/// (the second half of the steps, as the thesis's figures do, floored at
/// `clip.zoom_floor`); FQI, AWFQI, AWFQI_oracle, awfqi-adaptive and the core's embedded
/// versions of AWFQI and of awfqi-adaptive in a last panel (omitted without either
/// kernel).
pub fn learning_curves(
    title: &str,
    std_path: &Curves,
    embedded: &Curves,
    clip: Option<Clip>,
) -> Figure {
    let below = clip.map_or(f64::NEG_INFINITY, |c| c.below);
    let zoom_floor = clip.map_or(f64::NEG_INFINITY, |c| c.zoom_floor);
    let full = curve_panel(title.to_string(), std_path);
    let min = std_path
        .iter()
        .flat_map(|(_, _, rows)| rows.iter().map(|r| r.mean))
        .fold(f64::INFINITY, f64::min);
    let last = std_path
        .iter()
        .flat_map(|(_, _, rows)| rows.iter().map(|r| r.n_episodes as f64))
        .fold(0.0, f64::max);
    let mut panels = Vec::new();
    if min < below {
        panels.push(clipped(full.clone(), below, None, 0.0));
    } else {
        panels.push(full.clone());
    }
    // The zoom: from the middle step on, down to the lowest of those means (or the floor).
    let from = (last / 2.0).ceil();
    let zoom_lo = std_path
        .iter()
        .flat_map(|(_, _, rows)| rows.iter().filter(|r| r.n_episodes as f64 >= from))
        .map(|r| r.mean - r.stderr)
        .fold(f64::INFINITY, f64::min)
        .max(zoom_floor);
    if last >= 2.0 && zoom_lo.is_finite() {
        let mut zoom = clipped(full, zoom_lo.floor() - 1.0, None, from);
        zoom.title = "zoom: the second half of the steps".into();
        panels.push(zoom);
    }
    if embedded
        .iter()
        .any(|(name, ..)| name == "awfqi-kernel" || name == "awfqi-adaptive-kernel")
    {
        let panel = curve_panel("embedded kernel paths vs std AWFQI".into(), embedded);
        let min = embedded
            .iter()
            .flat_map(|(_, _, rows)| rows.iter().map(|r| r.mean))
            .fold(f64::INFINITY, f64::min);
        panels.push(if min < below {
            clipped(panel, below, None, 0.0)
        } else {
            panel
        });
    }
    Figure {
        panels,
        panel_width: 620,
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

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(means: &[f64]) -> Vec<SummaryRow> {
        means
            .iter()
            .enumerate()
            .map(|(i, &mean)| SummaryRow {
                algorithm: "a".into(),
                step: i + 1,
                n_episodes: i + 1,
                n_target_samples: 0.0,
                mean,
                stderr: 2.0,
                runs: 10,
            })
            .collect()
    }

    #[test]
    fn clipped_points_sit_on_the_edge_and_are_marked() {
        let curves = vec![("a".to_string(), 0, rows(&[-400.0, -60.0, -25.0, -20.0]))];
        let figure = learning_curves("t", &curves, &[], Some(PUDDLE_CLIP));
        assert_eq!(figure.panels.len(), 2);
        let main = &figure.panels[0];
        let (lo, hi) = main.y_range.unwrap();
        assert_eq!(lo, CLIP_BELOW);
        // Top: the best mean plus its error (−18), padded by 5 % of the range.
        assert!((hi - (-18.0 + 0.05 * (CLIP_BELOW + 18.0).abs())).abs() < 1e-9);
        let line = &main.series[0];
        assert_eq!(line.points[0], (1.0, CLIP_BELOW));
        assert_eq!(line.points[1], (2.0, -60.0));
        // The clipped point has no band; the others keep theirs.
        assert_eq!(line.errors.as_ref().unwrap()[..2], [0.0, 2.0]);
        let marks = &main.series[1];
        assert_eq!(marks.points, vec![(1.0, CLIP_BELOW)]);
        assert_eq!(marks.style, SeriesStyle::Points);
        // The zoom keeps steps 2–4 and starts just below the lowest mean − s.e. there,
        // capped at −50: −60 lies below it and is marked.
        let zoom = &figure.panels[1];
        assert_eq!(zoom.series[0].points.len(), 3);
        assert_eq!(zoom.y_range.unwrap().0, -51.0);
        assert_eq!(zoom.series[1].points, vec![(2.0, -51.0)]);
    }

    #[test]
    fn unclipped_curves_keep_their_automatic_range() {
        let curves = vec![("a".to_string(), 0, rows(&[-40.0, -30.0]))];
        let figure = learning_curves("t", &curves, &[], Some(PUDDLE_CLIP));
        assert_eq!(figure.panels[0].y_range, None);
        assert_eq!(figure.panels[0].series.len(), 1);
    }

    #[test]
    fn unclipped_domains_zoom_on_their_own_scale() {
        // The Dam's scale: nothing clipped, the zoom (steps 2–4) starts just below the
        // lowest mean − s.e. there (−1 950 − 2 → −1 953), not at −50.
        let curves = vec![(
            "a".to_string(),
            0,
            rows(&[-2500.0, -1950.0, -1900.0, -1920.0]),
        )];
        let figure = learning_curves("t", &curves, &[], None);
        assert_eq!(figure.panels[0].y_range, None);
        let zoom = &figure.panels[1];
        assert_eq!(zoom.y_range.unwrap().0, -1953.0);
        assert_eq!(zoom.series.len(), 1, "no clipped marks");
    }
}
