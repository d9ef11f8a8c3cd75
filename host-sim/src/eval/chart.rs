//! Line charts as PNG: the evaluation's curves (RMSE vs SNR, resolution vs separation, …) and
//! the odometry's trajectories.
//!
//! Drawn with `plotters` through [`crate::plot`]'s helpers (embedded DejaVu Sans, atomic PNG
//! writes): x–y curves on linear or logarithmic axes, a marker shape per series, dashed lines for
//! bounds, and the legend beside the plot so that it never hides a curve.

use std::ops::Range;
use std::path::Path;

use plotters::coord::combinators::BindKeyPoints;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;

use crate::io::IoError;
use crate::plot::{data_area, equal_units, font, render_png, rgb, tick_label, titled, Area, Drawn};

/// Image size, pixels.
pub const SIZE: (u32, u32) = (1040, 600);
/// Width of the legend column right of the plot, pixels.
const LEGEND_W: u32 = 300;

/// Colours for series, in order (colour-blind-safe Okabe–Ito palette, then greys).
pub const PALETTE: [[u8; 3]; 8] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
    [0, 0, 0],
    [120, 120, 120],
];

/// One curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points `(x, y)`; a non-finite `y` (or `y ≤ 0` on a log axis) breaks the line.
    pub points: Vec<(f64, f64)>,
    /// RGB colour.
    pub colour: [u8; 3],
    /// Dashed line (used for bounds).
    pub dashed: bool,
}

/// A chart: title, axis titles, scales and series.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// x-axis title.
    pub x_label: String,
    /// y-axis title.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
    /// Equal units per pixel on both axes (linear axes only; a top view in metres): the
    /// fitted ranges grow about their centres until they do.
    pub equal_aspect: bool,
    /// The curves.
    pub series: Vec<Series>,
}

/// The plotted range of one axis: the data (or `fixed`) with a 4 % margin (of the log span on a
/// log axis), or on a log axis with `decades` the data widened to whole decades. Non-finite
/// values (and `v ≤ 0` on a log axis) are ignored; no data gives 0..1 (1..10 on a log axis).
fn fit(
    values: impl Iterator<Item = f64>,
    log: bool,
    fixed: Option<(f64, f64)>,
    decades: bool,
) -> (f64, f64) {
    if let Some(r) = fixed {
        return r;
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if log {
        if !(lo.is_finite() && hi.is_finite()) {
            return (1.0, 10.0);
        }
        let (mut a, mut b) = (lo.log10(), hi.log10());
        if decades {
            (a, b) = (a.floor(), b.ceil());
            if b <= a {
                b = a + 1.0;
            }
        } else {
            let pad = (0.04 * (b - a)).max(0.02);
            (a, b) = (a - pad, b + pad);
        }
        return (10f64.powf(a), 10f64.powf(b));
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        let pad = lo.abs().max(1.0) * 0.1;
        return (lo - pad, hi + pad);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Ticks of a log axis over `lo..hi`: 1, 2, 5 per decade when the axis spans at most 2.5
/// decades, else the decades; and the light grid lines at 1..9 per decade.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (a, b) = (lo.log10(), hi.log10());
    let mults: &[f64] = if b - a <= 2.5 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let inside = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
    let (mut bold, mut light) = (Vec::new(), Vec::new());
    for e in (a.floor() as i32)..=(b.ceil() as i32) {
        // m·10^e rounded once (m / 10^−e for e < 0), so that 0.02 is the f64 nearest 0.02.
        let at = |m: f64| {
            if e < 0 {
                m / 10f64.powi(-e)
            } else {
                m * 10f64.powi(e)
            }
        };
        bold.extend(mults.iter().map(|&m| at(m)).filter(|&v| inside(v)));
        light.extend((1..10).map(|m| at(f64::from(m))).filter(|&v| inside(v)));
    }
    (bold, light)
}

/// The runs of consecutive drawable points of `s` (a non-finite value, or `y ≤ 0` on a log
/// axis, breaks the line).
fn segments(s: &Series, log_x: bool, log_y: bool) -> Vec<Vec<(f64, f64)>> {
    let ok = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut run = Vec::new();
    for &(x, y) in &s.points {
        if ok(x, log_x) && ok(y, log_y) {
            run.push((x, y));
        } else if !run.is_empty() {
            out.push(std::mem::take(&mut run));
        }
    }
    if !run.is_empty() {
        out.push(run);
    }
    out
}

/// Draw marker shape `k % 4` (circle, triangle, square, cross) at each of `at` on `area`, a
/// drawing area or a chart's plotting area.
fn markers<DB, CT>(
    area: &DrawingArea<DB, CT>,
    at: impl Iterator<Item = CT::From>,
    k: usize,
    c: RGBColor,
) -> Drawn<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    CT: plotters::coord::CoordTranslate,
    CT::From: Clone,
{
    for p in at {
        let e = EmptyElement::at(p);
        match k % 4 {
            0 => area.draw(&(e + Circle::new((0, 0), 4, c.filled())))?,
            1 => area.draw(&(e + TriangleMarker::new((0, 0), 5, c.filled())))?,
            2 => area.draw(&(e + Rectangle::new([(-4, -4), (4, 4)], c.filled())))?,
            _ => area.draw(&(e + Cross::new((0, 0), 5, c.stroke_width(2))))?,
        }
    }
    Ok(())
}

/// Series with more points than this are drawn as lines only (markers would hide the line).
const MAX_MARKED_POINTS: usize = 40;

/// Whether `s` is drawn with markers: a solid line of at most [`MAX_MARKED_POINTS`] points.
fn marked(s: &Series) -> bool {
    !s.dashed && s.points.len() <= MAX_MARKED_POINTS
}

/// Margin around the plot and the sizes of its label areas, pixels.
const PLOT_MARGIN: u32 = 14;
const X_LABELS: u32 = 56;
const Y_LABELS: u32 = 84;

/// The plot itself on `area`: mesh, axis titles, every series (lines and markers).
fn draw_plot<X, Y>(area: &Area<'_>, chart: &Chart, x: X, y: Y) -> Drawn<()>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut c = ChartBuilder::on(area)
        .margin(PLOT_MARGIN)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(x, y)?;
    c.configure_mesh()
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .label_style(font(16))
        .axis_desc_style(font(18))
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .draw()?;
    for (k, s) in chart.series.iter().enumerate() {
        let col = rgb(s.colour);
        for run in segments(s, chart.log_x, chart.log_y) {
            if s.dashed {
                c.draw_series(DashedLineSeries::new(
                    run.iter().copied(),
                    8,
                    6,
                    col.stroke_width(2),
                ))?;
            } else {
                c.draw_series(LineSeries::new(run.iter().copied(), col.stroke_width(2)))?;
                if marked(s) {
                    markers(c.plotting_area(), run.iter().copied(), k, col)?;
                }
            }
        }
    }
    Ok(())
}

/// The legend column: a line sample (dashed for bounds), the series' marker if it has one, its
/// label.
fn draw_legend(area: &Area<'_>, chart: &Chart) -> Drawn<()> {
    for (k, s) in chart.series.iter().enumerate() {
        let y = 40 + 30 * k as i32;
        let col = rgb(s.colour);
        if s.dashed {
            for x0 in (8..44).step_by(12) {
                area.draw(&PathElement::new(
                    vec![(x0, y), (x0 + 7, y)],
                    col.stroke_width(2),
                ))?;
            }
        } else {
            area.draw(&PathElement::new(
                vec![(8, y), (44, y)],
                col.stroke_width(2),
            ))?;
            if marked(s) {
                markers(area, std::iter::once((26, y)), k, col)?;
            }
        }
        area.draw(&Text::new(s.label.clone(), (54, y - 9), font(16)))?;
    }
    Ok(())
}

/// Render `chart` to a PNG file at `path` (written atomically), [`SIZE`].
pub fn render(chart: &Chart, path: &Path) -> Result<(), IoError> {
    let xs = || {
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0))
    };
    let ys = || {
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1))
    };
    let x = fit(xs(), chart.log_x, None, false);
    let y = fit(ys(), chart.log_y, chart.y_range, true);
    render_png(path, SIZE, |root| {
        root.fill(&WHITE)?;
        let root = titled(root, &chart.title)?;
        let (plot, legend) = root.split_horizontally(SIZE.0 - LEGEND_W);
        let ((x0, x1), (y0, y1)) = if chart.equal_aspect && !chart.log_x && !chart.log_y {
            let data = data_area(plot.dim_in_pixel(), PLOT_MARGIN, X_LABELS, Y_LABELS);
            equal_units(x, y, data)
        } else {
            (x, y)
        };
        let (xr, yr): (Range<f64>, Range<f64>) = (x0..x1, y0..y1);
        let log = |r: Range<f64>| {
            let (bold, light) = log_ticks(r.start, r.end);
            r.log_scale().with_key_points(bold).with_light_points(light)
        };
        match (chart.log_x, chart.log_y) {
            (false, false) => draw_plot(&plot, chart, xr, yr)?,
            (true, false) => draw_plot(&plot, chart, log(xr), yr)?,
            (false, true) => draw_plot(&plot, chart, xr, log(yr))?,
            (true, true) => draw_plot(&plot, chart, log(xr), log(yr))?,
        }
        draw_legend(&legend, chart)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_fit_the_data() {
        assert_eq!(fit([0.02, 0.3].into_iter(), true, None, true), (0.01, 1.0));
        assert_eq!(
            fit([f64::NAN, -1.0].into_iter(), true, None, true),
            (1.0, 10.0)
        );
        let (lo, hi) = fit([0.01, 1.0].into_iter(), true, None, false);
        assert!((lo.log10() + 2.08).abs() < 1e-9 && (hi.log10() - 0.08).abs() < 1e-9);
        let (lo, hi) = fit([0.0, 10.0].into_iter(), false, None, false);
        assert!((lo + 0.4).abs() < 1e-12 && (hi - 10.4).abs() < 1e-12);
        assert_eq!(
            fit([5.0].into_iter(), false, Some((0.0, 1.0)), false),
            (0.0, 1.0)
        );
    }

    #[test]
    fn log_ticks_step_1_2_5_on_short_axes() {
        let (bold, light) = log_ticks(0.009, 0.22);
        assert_eq!(bold, vec![0.01, 0.02, 0.05, 0.1, 0.2]);
        assert_eq!(light.len(), 1 + 9 + 2, "0.009, 0.01..0.09, 0.1, 0.2");
        let (bold, _) = log_ticks(0.001, 1.0);
        assert_eq!(bold, vec![0.001, 0.01, 0.1, 1.0]);
    }

    #[test]
    fn a_chart_draws_its_series_in_the_plot_and_the_legend(
    ) -> Result<(), Box<dyn std::error::Error>> {
        let chart = Chart {
            title: "RMSE vs SNR".into(),
            x_label: "SNR (dB)".into(),
            y_label: "RMSE (\u{b0})".into(),
            log_x: false,
            log_y: true,
            y_range: None,
            equal_aspect: false,
            series: vec![
                Series {
                    label: "dbe".into(),
                    points: vec![(0.0, 1.0), (10.0, 0.1), (20.0, 0.03)],
                    colour: PALETTE[0],
                    dashed: false,
                },
                Series {
                    label: "bound".into(),
                    points: vec![(0.0, 0.5), (20.0, 0.01)],
                    colour: PALETTE[1],
                    dashed: true,
                },
            ],
        };
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("c.png");
        render(&chart, &path)?;
        let mut reader =
            png::Decoder::new(std::io::Cursor::new(std::fs::read(&path)?)).read_info()?;
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf)?;
        assert_eq!((info.width, info.height), SIZE);
        // Pixels of each series' colour left of the legend column (the curve) and in it.
        let split = (SIZE.0 - LEGEND_W) as usize;
        let count = |c: [u8; 3], legend: bool| {
            buf.chunks_exact(3)
                .enumerate()
                .filter(|(i, px)| ((i % SIZE.0 as usize) >= split) == legend && **px == c)
                .count()
        };
        for s in &chart.series {
            assert!(count(s.colour, false) > 100, "{} curve", s.label);
            assert!(count(s.colour, true) > 10, "{} legend", s.label);
        }
        Ok(())
    }

    #[test]
    fn equal_units_grow_the_short_axis() {
        let (x, y) = equal_units((0.0, 12.0), (0.0, 3.0), (600, 400));
        assert_eq!(x, (0.0, 12.0));
        assert!((y.1 - y.0 - 8.0).abs() < 1e-12 && (y.0 + y.1 - 3.0).abs() < 1e-12);
    }

    #[test]
    fn lines_break_at_undrawable_points() {
        let s = Series {
            label: "a".into(),
            points: vec![
                (1.0, 1.0),
                (2.0, f64::NAN),
                (3.0, 2.0),
                (4.0, 0.0),
                (5.0, 3.0),
            ],
            colour: PALETTE[0],
            dashed: false,
        };
        assert_eq!(segments(&s, false, true).len(), 3);
        assert_eq!(segments(&s, false, false).len(), 2);
    }
}
