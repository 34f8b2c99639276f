//! Plots for every experiment of the harness: line charts with ± error bands (learning
//! curves, rates against budgets) and scatter plots (queried samples), each written as
//! PNG and SVG from one description.
//!
//! Text is drawn with the DejaVu Sans font embedded in the binary (see
//! `assets/fonts/LICENSE-DejaVu.txt`) through plotters' `ab_glyph` renderer, so plotting
//! needs no system font library (fontconfig, freetype) and looks the same on every
//! machine.

use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{Context, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;

/// DejaVu Sans (Bitstream Vera licence, see `assets/fonts/LICENSE-DejaVu.txt`).
static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// Family name under which the embedded font is registered.
pub const FONT_FAMILY: &str = "sans-serif";

/// The Okabe–Ito colour-blind-safe palette (black eighth), then a crimson, a purple and a
/// grey, so each of the transfer algorithms has a colour of its own.
pub const PALETTE: [RGBColor; 11] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(240, 228, 66),
    RGBColor(0, 0, 0),
    RGBColor(170, 0, 60),
    RGBColor(117, 112, 179),
    RGBColor(120, 120, 120),
];

fn ensure_font() -> anyhow::Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT)
            .map_err(|_| anyhow!("the embedded DejaVu Sans font could not be parsed"));
    });
    result
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A line through the points with a marker at each point.
    LineWithMarkers,
    /// A line only (dense learning curves).
    Line,
    /// Markers only (scatter plots).
    Points,
    /// A thin line without band or markers, in the legend only when labelled (the
    /// outlines of regions on a map).
    Outline,
}

/// One named data series.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    /// (x, y) points, in data coordinates (before any axis transform).
    pub points: Vec<(f64, f64)>,
    /// Optional half-width of a band drawn around the line (e.g. a standard error), one
    /// per point.
    pub errors: Option<Vec<f64>>,
    /// How to draw it.
    pub style: SeriesStyle,
    /// Index into [`PALETTE`] (modulo its length).
    pub color: usize,
}

/// Scale of the x axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum XScale {
    /// Linear.
    Linear,
    /// Base-2 logarithmic, ticks at powers of two (budgets 1, 2, 4, …).
    Log2,
}

/// One chart: axes, series and optional horizontal reference lines.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Caption above the chart.
    pub title: String,
    /// x-axis description.
    pub x_label: String,
    /// y-axis description.
    pub y_label: String,
    /// x-axis scale.
    pub x_scale: XScale,
    /// Fixed x range (linear scale); computed from the data when `None`.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; computed from the data (with errors) when `None`.
    pub y_range: Option<(f64, f64)>,
    /// The series.
    pub series: Vec<Series>,
    /// Dashed horizontal lines with legend labels (e.g. the optimal return).
    pub references: Vec<(String, f64)>,
    /// Where the legend goes (pick a corner the data leave empty).
    pub legend: LegendPosition,
}

/// Corner of the legend box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// Upper left.
    UpperLeft,
    /// Upper right.
    UpperRight,
    /// Lower left.
    LowerLeft,
    /// Lower right.
    #[default]
    LowerRight,
}

/// A figure of one or more panels side by side.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Panels, left to right.
    pub panels: Vec<Panel>,
    /// Width in pixels of each panel.
    pub panel_width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl Figure {
    /// A figure with one panel of the default size (800 × 500).
    pub fn single(panel: Panel) -> Self {
        Self {
            panels: vec![panel],
            panel_width: 800,
            height: 500,
        }
    }

    /// Writes `<stem>.png` and `<stem>.svg` and returns their paths.
    pub fn save(&self, stem: &Path) -> anyhow::Result<[PathBuf; 2]> {
        ensure_font()?;
        let png = stem.with_extension("png");
        let svg = stem.with_extension("svg");
        // Drawn under temporary names, then renamed: a failed write (no space, no
        // permission) leaves the previous figure as it was.
        let name = stem
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let partial = |ext: &str| {
            stem.with_file_name(format!(".{name}.{}.partial.{ext}", std::process::id()))
        };
        let (png_partial, svg_partial) = (partial("png"), partial("svg"));
        let drawn = self.draw_files(&png_partial, &svg_partial).and_then(|()| {
            std::fs::rename(&png_partial, &png)
                .with_context(|| format!("writing {}", png.display()))?;
            std::fs::rename(&svg_partial, &svg)
                .with_context(|| format!("writing {}", svg.display()))
        });
        if drawn.is_err() {
            let _ = std::fs::remove_file(&png_partial);
            let _ = std::fs::remove_file(&svg_partial);
        }
        drawn?;
        Ok([png, svg])
    }

    fn draw_files(&self, png: &Path, svg: &Path) -> anyhow::Result<()> {
        let size = (
            self.panel_width * self.panels.len().max(1) as u32,
            self.height,
        );
        {
            let root = BitMapBackend::new(png, size).into_drawing_area();
            self.draw(&root)
                .with_context(|| format!("drawing {}", png.display()))?;
            root.present().map_err(plot_error)?;
        }
        {
            let root = SVGBackend::new(svg, size).into_drawing_area();
            self.draw(&root)
                .with_context(|| format!("drawing {}", svg.display()))?;
            root.present().map_err(plot_error)?;
        }
        Ok(())
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        root.fill(&WHITE).map_err(plot_error)?;
        let areas = root.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(areas.iter()) {
            draw_panel(area, panel)?;
        }
        Ok(())
    }
}

fn plot_error<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e:?}")
}

fn transform(scale: XScale, x: f64) -> f64 {
    match scale {
        XScale::Linear => x,
        XScale::Log2 => x.log2(),
    }
}

/// The data range padded by 5 % on each side (a unit range around a single value).
fn padded(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi > lo {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        (lo - 0.5, hi + 0.5)
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> anyhow::Result<()> {
    let scale = panel.x_scale;
    let xs = panel
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| transform(scale, p.0)));
    let (x_lo, x_hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    let (x_lo, x_hi) = match panel.x_range {
        Some((lo, hi)) => (transform(scale, lo), transform(scale, hi)),
        None => padded(x_lo, x_hi),
    };
    let (y_lo, y_hi) = match panel.y_range {
        Some(range) => range,
        None => {
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            for s in &panel.series {
                for (i, &(_, y)) in s.points.iter().enumerate() {
                    let e = s.errors.as_ref().and_then(|e| e.get(i)).copied();
                    let e = e.unwrap_or(0.0);
                    lo = lo.min(y - e);
                    hi = hi.max(y + e);
                }
            }
            for &(_, y) in &panel.references {
                lo = lo.min(y);
                hi = hi.max(y);
            }
            padded(lo, hi)
        }
    };
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, (FONT_FAMILY, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)
        .map_err(plot_error)?;
    let formatter = |x: &f64| match scale {
        XScale::Linear => format!("{x}"),
        XScale::Log2 => format!("{}", 2f64.powf(*x).round()),
    };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .label_style((FONT_FAMILY, 14))
        .axis_desc_style((FONT_FAMILY, 16))
        .x_label_formatter(&formatter)
        .y_label_formatter(&|y: &f64| format!("{}", (y * 1000.0).round() / 1000.0))
        .light_line_style(WHITE.mix(0.0));
    if scale == XScale::Log2 {
        // One tick per power of two inside the range.
        let ticks = (x_hi.floor() - x_lo.ceil()).max(0.0) as usize + 1;
        mesh.x_labels(ticks);
    }
    mesh.draw().map_err(plot_error)?;

    for series in &panel.series {
        let color = PALETTE[series.color % PALETTE.len()];
        let points: Vec<(f64, f64)> = series
            .points
            .iter()
            .map(|&(x, y)| (transform(scale, x), y))
            .collect();
        if let Some(errors) = &series.errors {
            let upper = points.iter().zip(errors).map(|(&(x, y), e)| (x, y + e));
            let lower = points.iter().zip(errors).map(|(&(x, y), e)| (x, y - e));
            let mut band: Vec<(f64, f64)> = upper.collect();
            band.extend(lower.rev());
            chart
                .draw_series(std::iter::once(Polygon::new(
                    band,
                    color.mix(0.18).filled(),
                )))
                .map_err(plot_error)?;
        }
        let legend_style = color.stroke_width(2);
        match series.style {
            SeriesStyle::Line | SeriesStyle::LineWithMarkers => {
                chart
                    .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
                    .map_err(plot_error)?
                    .label(&series.label)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], legend_style)
                    });
                if series.style == SeriesStyle::LineWithMarkers {
                    chart
                        .draw_series(points.iter().map(|&p| Circle::new(p, 4, color.filled())))
                        .map_err(plot_error)?;
                }
            }
            SeriesStyle::Points => {
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(plot_error)?
                    .label(&series.label)
                    .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
            }
            SeriesStyle::Outline => {
                let style = color.stroke_width(1);
                let drawn = chart
                    .draw_series(LineSeries::new(points.clone(), style))
                    .map_err(plot_error)?;
                if !series.label.is_empty() {
                    drawn
                        .label(&series.label)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
                }
            }
        }
    }
    for (label, y) in &panel.references {
        let style = BLACK.stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x_lo, *y), (x_hi, *y)],
                6,
                4,
                style,
            ))
            .map_err(plot_error)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    }
    chart
        .configure_series_labels()
        .label_font((FONT_FAMILY, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.5))
        .position(match panel.legend {
            LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
            LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
            LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
            LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
        })
        .draw()
        .map_err(plot_error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_png_and_svg_with_embedded_text() {
        let dir = std::env::temp_dir().join(format!("awfqi-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let panel = Panel {
            title: "Test".into(),
            x_label: "budget".into(),
            y_label: "value".into(),
            x_scale: XScale::Log2,
            x_range: None,
            y_range: None,
            series: vec![
                Series {
                    label: "a".into(),
                    points: vec![(1.0, 0.1), (2.0, 0.5), (4.0, 0.9)],
                    errors: Some(vec![0.05, 0.05, 0.02]),
                    style: SeriesStyle::LineWithMarkers,
                    color: 0,
                },
                Series {
                    label: "b".into(),
                    points: vec![(1.0, 0.3), (4.0, 0.4)],
                    errors: None,
                    style: SeriesStyle::Points,
                    color: 1,
                },
            ],
            references: vec![("optimum".into(), 1.0)],
            legend: LegendPosition::UpperLeft,
        };
        let [png, svg] = Figure::single(panel).save(&dir.join("chart")).unwrap();
        let png_bytes = std::fs::read(&png).unwrap();
        assert_eq!(&png_bytes[1..4], b"PNG");
        let svg_text = std::fs::read_to_string(&svg).unwrap();
        assert!(svg_text.contains("<svg") && svg_text.contains("optimum"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
