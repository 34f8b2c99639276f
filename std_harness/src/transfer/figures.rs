//! The experiment's figures, through the harness's plotting helpers ([`crate::plot`]):
//! learning curves (mean ± standard error of `perf_disc_greedy_mean` against `n_episodes`,
//! §3.4) and scatters of the target samples each algorithm collected over the source states
//! (§13.2 output 2).

use crate::plot::{Figure, LegendPosition, Panel, Series, SeriesStyle, XScale};

use std::collections::BTreeMap;
use std::path::Path;

use super::algorithms::{Algorithm, Experiment};
use super::results::{ResultFile, SummaryRow};
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
        x_range: None,
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

/// Learning curves: every algorithm's, the main panel clipped at `clip.below` (clipped
/// means marked; no clip with `None`), a zoom on the asymptote (the second half of the
/// steps, as the thesis's figures do, floored at `clip.zoom_floor`), and, when `curves`
/// hold baselines besides FQI, a last panel with the `active` ones (FQI and the algorithms
/// that query the generative model).
pub fn learning_curves(
    title: &str,
    curves: &Curves,
    active: &Curves,
    clip: Option<Clip>,
) -> Figure {
    let below = clip.map_or(f64::NEG_INFINITY, |c| c.below);
    let zoom_floor = clip.map_or(f64::NEG_INFINITY, |c| c.zoom_floor);
    let full = curve_panel(title.to_string(), curves);
    let lowest = |curves: &Curves| {
        curves
            .iter()
            .flat_map(|(_, _, rows)| rows.iter().map(|r| r.mean))
            .fold(f64::INFINITY, f64::min)
    };
    let last = curves
        .iter()
        .flat_map(|(_, _, rows)| rows.iter().map(|r| r.n_episodes as f64))
        .fold(0.0, f64::max);
    let mut panels = Vec::new();
    if lowest(curves) < below {
        panels.push(clipped(full.clone(), below, None, 0.0));
    } else {
        panels.push(full.clone());
    }
    // The zoom: from the middle step on, down to the lowest of those means (or the floor).
    let from = (last / 2.0).ceil();
    let zoom_lo = curves
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
    if !active.is_empty() && active.len() < curves.len() {
        let panel = curve_panel("the active algorithms against FQI".into(), active);
        panels.push(if lowest(active) < below {
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

/// The outlines of the target's regions (Puddle World's puddles and goal), one closed
/// polyline each, labelled once.
fn region_outlines<const D: usize>(domain: &Domain<D>) -> Vec<Series> {
    const SIDES: usize = 48;
    domain
        .target_regions
        .iter()
        .enumerate()
        .map(|(i, region)| {
            let points = (0..=SIDES)
                .map(|k| {
                    let angle = std::f64::consts::TAU * k as f64 / SIDES as f64;
                    (
                        region.centre[0] + region.radius * angle.cos(),
                        region.centre[1] + region.radius * angle.sin(),
                    )
                })
                .collect();
            let first_of_its_kind = domain.target_regions[..i]
                .iter()
                .all(|r| r.name != region.name);
            Series {
                label: if first_of_its_kind {
                    format!("target {}", region.name)
                } else {
                    String::new()
                },
                points,
                errors: None,
                style: SeriesStyle::Outline,
                color: 7,
            }
        })
        .collect()
}

/// One panel per algorithm: the source states (yellow) and the target states the algorithm
/// collected in one run over all steps (coloured), on the first two state coordinates,
/// with the outlines of the target's regions (Puddle World's puddles and goal).
pub fn sample_scatter<const D: usize>(
    domain: &Domain<D>,
    sources: &SourceSet<D>,
    samples: &[(String, usize, Vec<[f64; 3]>)],
) -> Figure {
    let axis = |d: usize| domain.state_names.get(d).copied().unwrap_or("").to_string();
    let (lo, hi) = domain.state_bounds.get(1).copied().unwrap_or((0.0, 1.0));
    let pad = 0.05 * (hi - lo);
    let (x_lo, x_hi) = domain.state_bounds.first().copied().unwrap_or((0.0, 1.0));
    let x_pad = 0.05 * (x_hi - x_lo);
    let source_points: Vec<(f64, f64)> = sources
        .sources
        .iter()
        .flat_map(|s| s.records.iter().map(|r| (r.state[0], r.state[1])))
        .collect();
    let outlines = region_outlines(domain);
    let panels = samples
        .iter()
        .map(|(name, color, pts)| Panel {
            title: format!("{name} ({} samples)", pts.len()),
            x_label: axis(0),
            y_label: axis(1),
            x_scale: XScale::Linear,
            x_range: Some((x_lo - x_pad, x_hi + x_pad)),
            y_range: Some((lo - pad, hi + pad)),
            series: [
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
            ]
            .into_iter()
            .chain(outlines.iter().cloned())
            .collect(),
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

/// Writes the experiment's figures in `out`: the learning curves of `curves` under `title`
/// (`learning_curves`: every algorithm, and FQI with the active ones), one scatter per
/// algorithm of the first run of `files` that kept its samples (`samples/<algorithm>`) and,
/// when there are any, FQI's and IWFQI's episodes against every active algorithm's queries
/// (`target_samples`).
///
/// Errors: a figure cannot be written.
pub fn write_figures<const D: usize>(
    out: &Path,
    title: &str,
    curves: &[(Algorithm, Vec<SummaryRow>)],
    files: &BTreeMap<Algorithm, ResultFile>,
    experiment: &Experiment<D>,
) -> anyhow::Result<()> {
    let curve = |keep: &dyn Fn(Algorithm) -> bool| -> Vec<(String, usize, Vec<SummaryRow>)> {
        curves
            .iter()
            .filter(|(a, _)| keep(*a))
            .map(|(a, rows)| (a.name().to_string(), a.color(), rows.clone()))
            .collect()
    };
    let every = curve(&|_| true);
    let active = curve(&|a| a == Algorithm::Fqi || a.is_active());
    let clip = experiment.protocol.dynamics.map(|_| PUDDLE_CLIP);
    learning_curves(title, &every, &active, clip).save(&out.join("learning_curves"))?;
    let samples: Vec<(Algorithm, String, usize, Vec<[f64; 3]>)> = files
        .iter()
        .filter_map(|(a, f)| {
            let run = f.runs.iter().find(|r| !r.samples.is_empty())?;
            Some((
                *a,
                format!("{} run {}", a.name(), run.run),
                a.color(),
                run.samples.clone(),
            ))
        })
        .collect();
    let dir = out.join("samples");
    std::fs::create_dir_all(&dir)?;
    let domain = &*experiment.domain;
    for (a, name, color, pts) in &samples {
        sample_scatter(
            domain,
            &experiment.sources,
            &[(name.clone(), *color, pts.clone())],
        )
        .save(&dir.join(a.name()))?;
    }
    // FQI's and IWFQI's episodes against every active algorithm's queries.
    let overview: Vec<(String, usize, Vec<[f64; 3]>)> = samples
        .iter()
        .filter(|(a, ..)| matches!(a, Algorithm::Fqi | Algorithm::Iwfqi) || a.is_active())
        .map(|(_, name, color, pts)| (name.clone(), *color, pts.clone()))
        .collect();
    if !overview.is_empty() {
        sample_scatter(domain, &experiment.sources, &overview).save(&out.join("target_samples"))?;
    }
    Ok(())
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
    fn the_active_panel_comes_only_with_other_baselines() {
        let curve = |name: &str| (name.to_string(), 0, rows(&[-40.0, -30.0]));
        let every = vec![curve("fqi"), curve("rbt"), curve("awfqi-adaptive")];
        let active = vec![curve("fqi"), curve("awfqi-adaptive")];
        let figure = learning_curves("t", &every, &active, Some(PUDDLE_CLIP));
        assert_eq!(figure.panels.len(), 3);
        for panel in &figure.panels[..2] {
            let names: Vec<&str> = panel.series.iter().map(|s| s.label.as_str()).collect();
            assert_eq!(names, ["fqi", "rbt", "awfqi-adaptive"]);
        }
        let last: Vec<&str> = figure.panels[2]
            .series
            .iter()
            .map(|s| s.label.as_str())
            .collect();
        assert_eq!(last, ["fqi", "awfqi-adaptive"]);
        // The same set in both: no third panel.
        assert_eq!(learning_curves("t", &active, &active, None).panels.len(), 2);
    }

    #[test]
    fn the_sample_scatter_outlines_the_target_s_puddles_and_goal() {
        let domain = crate::domains::puddle::domain(awfqi::env::Dynamics::Shared);
        let sources = SourceSet {
            sources: Vec::new(),
            origin: String::new(),
        };
        let samples = vec![("a".to_string(), 8, vec![[1.0, 2.0, 0.0]])];
        let figure = sample_scatter(&domain, &sources, &samples);
        let outlines: Vec<&Series> = figure.panels[0]
            .series
            .iter()
            .filter(|s| s.style == SeriesStyle::Outline)
            .collect();
        let target = awfqi::env::PuddleWorld::<f64>::target(awfqi::env::Dynamics::Shared);
        assert_eq!(outlines.len(), target.num_puddles() + 1);
        let labels: Vec<&str> = outlines
            .iter()
            .map(|s| s.label.as_str())
            .filter(|l| !l.is_empty())
            .collect();
        assert_eq!(labels, ["target puddle", "target goal"]);
        // Each outline is a closed circle around its region's centre.
        for (outline, puddle) in outlines.iter().zip(target.puddles()) {
            let radius = puddle.variance.sqrt();
            assert_eq!(outline.points.first(), outline.points.last());
            for &(x, y) in &outline.points {
                let r = (x - puddle.mean[0]).hypot(y - puddle.mean[1]);
                assert!((r - radius).abs() < 1e-9, "{r} vs {radius}");
            }
        }
        let goal = outlines.last().unwrap();
        let (x, y) = goal.points[0];
        let [gx, gy] = target.goal();
        assert!(((x - gx).hypot(y - gy) - awfqi::env::PUDDLE_GOAL_RADIUS).abs() < 1e-9);
        // The whole state space is shown, wherever one run's samples lie (here one point).
        let (lo, hi) = figure.panels[0].x_range.unwrap();
        assert!(lo < 0.0 && hi > 10.0, "{lo}..{hi}");
        let (lo, hi) = figure.panels[0].y_range.unwrap();
        assert!(lo < 0.0 && hi > 10.0, "{lo}..{hi}");
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
