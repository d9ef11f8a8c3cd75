//! PNG plots of one frame: its range–azimuth and range–Doppler maps side by side, and its point
//! cloud from above and from the side.
//!
//! Drawn with `plotters` into an in-memory RGB buffer, encoded by `png` and written atomically
//! (see [`crate::io::atomic`]). Text is DejaVu Sans embedded in the binary (the `dejavu` crate),
//! so no system font or font library is needed. [`crate::eval::chart`] draws the evaluation's
//! line charts with the same (crate-private) helpers, `render_png` and `font`.
//!
//! Every plot returns the [`Axes`] of its data areas so that callers (and tests) can map data
//! coordinates to pixels.

use std::error::Error;
use std::path::Path;
use std::sync::Once;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::colors::colormaps::{DerivedColorMap, ViridisRGB};
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::cloud::PointRecord;
use crate::io::{write_file_atomic, IoError};

/// Image size of [`plot_maps`], pixels (width, height).
pub const MAPS_SIZE: (u32, u32) = (1500, 680);
/// Image size of the top view of [`plot_points`].
pub const TOP_SIZE: (u32, u32) = (900, 800);
/// Image size of the side view of [`plot_points`].
pub const SIDE_SIZE: (u32, u32) = (1000, 500);
/// Dynamic range of the maps' colour scale: each map's maximum is the top colour, values this
/// many dB below it (or lower) the bottom colour.
pub const DYNAMIC_RANGE_DB: f64 = 40.0;

/// The colour scales [`plot_maps`] accepts, dB below each map's maximum.
pub const DYNAMIC_RANGES_DB: core::ops::RangeInclusive<f64> = 3.0..=200.0;
/// Colour of range bins the chain does not process (outside `Params::range_first ..=
/// range_last`): the near-range band and the last bins.
pub const UNPROCESSED_COLOUR: [u8; 3] = [215, 215, 215];
/// Colour of truth markers (drawn under the points).
pub const TRUTH_COLOUR: [u8; 3] = [150, 150, 150];
/// Colour of the points' markers on the maps.
pub const MAP_POINT_COLOUR: [u8; 3] = [255, 255, 255];

/// The family name the embedded font is registered under.
const FONT_FAMILY: &str = "sans-serif";

/// Register the embedded font with `plotters` (once per process).
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are DejaVu Sans itself: parsing cannot fail, and if it did every text
        // would fail to draw with an error naming the file being drawn.
        let _ =
            plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// The embedded sans-serif font at `size` pixels, black.
pub(crate) fn font(size: u32) -> TextStyle<'static> {
    (FONT_FAMILY, size).into_font().color(&BLACK)
}

/// A drawing area on the in-memory RGB buffer of [`render_png`].
pub(crate) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// What a drawing closure returns: its result or any `plotters` error.
pub(crate) type Drawn<T> = Result<T, Box<dyn Error>>;

/// Draw an image of `size` with `draw` on a white background and write it to `path` as an RGB8
/// PNG, atomically. A drawing error is reported against `path` and writes nothing.
pub(crate) fn render_png<T>(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> Drawn<T>,
) -> Result<T, IoError> {
    register_font();
    let failed = |e: Box<dyn Error>| IoError::invalid(path, format!("drawing the plot: {e}"));
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    let out = {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        let out = draw(&root).map_err(failed)?;
        root.present().map_err(|e| failed(e.into()))?;
        out
    };
    let mut png_bytes = Vec::new();
    let fail = |e: png::EncodingError| IoError::invalid(path, format!("PNG encoding: {e}"));
    {
        let mut enc = png::Encoder::new(&mut png_bytes, size.0, size.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // Charts are mostly flat colour: the best deflate level and per-row filter choice
        // make them several times smaller for a few milliseconds.
        enc.set_compression(png::Compression::Best);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut w = enc.write_header().map_err(fail)?;
        w.write_image_data(&buf).map_err(fail)?;
        w.finish().map_err(fail)?;
    }
    write_file_atomic(path, &png_bytes)?;
    Ok(out)
}

/// `root` below a title line (with a top margin, so that no glyph touches the image edge).
pub(crate) fn titled<'a>(root: &Area<'a>, title: &str) -> Drawn<Area<'a>> {
    Ok(root.margin(8, 0, 0, 0).titled(title, font(22))?)
}

/// `v` with a true minus sign (U+2212), so that a negative tick label cannot be mistaken for a
/// tick mark next to a positive one, and `-0` printed as `0`.
pub(crate) fn signed_label(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        Some(rest) => format!("\u{2212}{rest}"),
        None => s,
    }
}

/// A tick label: up to six decimals, trailing zeros dropped, a true minus sign.
pub(crate) fn tick_label(v: f64) -> String {
    let s = signed_label(v, 6);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The data area of a plot and the data range it shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axes {
    /// Left edge of the data area, pixels.
    pub left: u32,
    /// Top edge of the data area, pixels.
    pub top: u32,
    /// Width of the data area, pixels.
    pub width: u32,
    /// Height of the data area, pixels.
    pub height: u32,
    /// Data value at the left and right edges.
    pub x_range: (f64, f64),
    /// Data value at the bottom and top edges (up is increasing).
    pub y_range: (f64, f64),
}

impl Axes {
    /// The axes of a `plotters` chart: its data area and coordinate ranges.
    fn of<DB: DrawingBackend>(
        chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    ) -> Self {
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let (x_range, y_range) = (chart.x_range(), chart.y_range());
        Self {
            left: xs.start.max(0) as u32,
            top: ys.start.max(0) as u32,
            width: (xs.end - xs.start).max(1) as u32,
            height: (ys.end - ys.start).max(1) as u32,
            x_range: (x_range.start, x_range.end),
            y_range: (y_range.start, y_range.end),
        }
    }

    /// Pixel `(column, row)` of data point `(x, y)` as `plotters` maps it, or `None` outside
    /// the data area: `column = left + ⌊(width − 1)·fx⌋`, `row = top + height − 1 −
    /// ⌊(height − 1)·fy⌋` with `fx`, `fy` the point's fractions of the x and y ranges.
    pub fn pixel(&self, x: f64, y: f64) -> Option<(u32, u32)> {
        let fx = (x - self.x_range.0) / (self.x_range.1 - self.x_range.0);
        let fy = (y - self.y_range.0) / (self.y_range.1 - self.y_range.0);
        if !((0.0..=1.0).contains(&fx) && (0.0..=1.0).contains(&fy)) {
            return None;
        }
        let col = (f64::from(self.width - 1) * fx + 1e-3).floor() as u32;
        let row = (f64::from(self.height - 1) * fy + 1e-3).floor() as u32;
        Some((self.left + col, self.top + self.height - 1 - row))
    }
}

/// Viridis colour of `f` in [0, 1] (clamped), the maps' colour scale.
pub fn map_colour(f: f64) -> [u8; 3] {
    let c = ViridisRGB::get_color(f.clamp(0.0, 1.0));
    [c.0, c.1, c.2]
}

/// Colour of radial velocity `v` (m/s) on a scale of ±`scale`: blue approaching, dark grey
/// static, red receding (clamped beyond the scale).
pub fn doppler_colour(v: f64, scale: f64) -> [u8; 3] {
    let map = DerivedColorMap::new(&[
        RGBColor(33, 102, 172),
        RGBColor(70, 70, 70),
        RGBColor(200, 30, 30),
    ]);
    let s = if scale > 0.0 { scale } else { 1.0 };
    let c = map.get_color_normalized(v.clamp(-s, s), -s, s);
    [c.0, c.1, c.2]
}

/// A `plotters` colour from RGB bytes.
pub(crate) fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Size of a chart's data area on an area of `dim` pixels: what is left after a `margin` on
/// every side and the x- and y-label areas.
pub(crate) fn data_area(dim: (u32, u32), margin: u32, x_labels: u32, y_labels: u32) -> (u32, u32) {
    (
        dim.0.saturating_sub(2 * margin + y_labels).max(1),
        dim.1.saturating_sub(2 * margin + x_labels).max(1),
    )
}

/// What one frame's title names.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameInfo {
    /// The recording: a sequence folder's or a capture file's name.
    pub source: String,
    /// Frame index in the recording.
    pub frame: usize,
    /// Frame time, s (the recording's timestamp).
    pub time_s: f64,
    /// The chain that made the points ("DBE" or "FFT").
    pub chain: String,
}

impl FrameInfo {
    /// `what — source, frame i, t = … s, … chain`.
    pub fn title(&self, what: &str) -> String {
        format!(
            "{what} \u{2014} {}, frame {}, t = {:.3} s, {} chain",
            self.source, self.frame, self.time_s, self.chain
        )
    }
}

/// A map to draw: `rows[b][i]` is the linear power of range bin `b` and column `i`, `columns[i]`
/// the column's coordinate (strictly increasing).
#[derive(Clone, Copy, Debug)]
pub struct Map<'a> {
    /// The rows, one per range bin.
    pub rows: &'a [Vec<f32>],
    /// Column coordinates (azimuth in degrees, radial velocity in m/s), strictly increasing.
    pub columns: &'a [f64],
}

/// Everything [`plot_maps`] draws.
#[derive(Clone, Copy, Debug)]
pub struct MapsInput<'a> {
    /// Title contents.
    pub info: &'a FrameInfo,
    /// Range of one bin, m.
    pub range_bin_m: f64,
    /// The range bins the chain processes (`Params::range_first ..= range_last`).
    pub processed_bins: (usize, usize),
    /// The DBE chain's range–azimuth map, columns in degrees.
    pub range_azimuth: Map<'a>,
    /// A range–Doppler map (the FFT chain's `Σ_m |X_m[d]|²`), columns in m/s, fftshifted.
    pub range_doppler: Map<'a>,
    /// The frame's points, marked on both maps at their azimuth, radial velocity and range.
    pub points: &'a [PointRecord],
    /// The colour scale spans this many dB below each map's maximum ([`DYNAMIC_RANGE_DB`] by
    /// default; real data with a strong reflector may want more).
    pub dynamic_range_db: f64,
}

/// The data areas of [`plot_maps`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapAxes {
    /// The range–azimuth panel.
    pub range_azimuth: Axes,
    /// The range–Doppler panel.
    pub range_doppler: Axes,
    /// The colour bar.
    pub colour_bar: Axes,
}

/// Check a map and convert it to dB relative to its maximum (`−∞` for zero power).
fn map_db(path: &Path, what: &str, map: &Map<'_>) -> Result<Vec<Vec<f64>>, IoError> {
    let bad = |m: String| Err(IoError::invalid(path, format!("{what}: {m}")));
    if map.rows.is_empty() || map.columns.is_empty() {
        return bad("empty map; expected at least one range bin and one column".into());
    }
    if map.columns.iter().any(|a| !a.is_finite()) || map.columns.windows(2).any(|w| w[1] <= w[0]) {
        return bad("column grid is not finite and strictly increasing".into());
    }
    let n = map.columns.len();
    let mut db = Vec::with_capacity(map.rows.len());
    for (b, row) in map.rows.iter().enumerate() {
        if row.len() != n {
            return bad(format!(
                "range bin {b} has {} values; expected {n} (the column grid)",
                row.len()
            ));
        }
        let mut out = Vec::with_capacity(n);
        for (i, &v) in row.iter().enumerate() {
            let v = f64::from(v);
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!(
                    "power at range bin {b}, column {i} is {v}; expected finite linear power ≥ 0"
                ));
            }
            out.push(10.0 * v.log10());
        }
        db.push(out);
    }
    let top = db
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    if top.is_finite() {
        for v in db.iter_mut().flatten() {
            *v -= top;
        }
    }
    Ok(db)
}

/// Cell edges of a strictly increasing grid: half a step beyond the end values.
fn cell_edges(c: &[f64]) -> Vec<f64> {
    let n = c.len();
    if n == 1 {
        return vec![c[0] - 0.5, c[0] + 0.5];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(c[0] - (c[1] - c[0]) / 2.0);
    e.extend(c.windows(2).map(|w| (w[0] + w[1]) / 2.0));
    e.push(c[n - 1] + (c[n - 1] - c[n - 2]) / 2.0);
    e
}

/// One heatmap panel: cells in viridis (dB relative to the map's maximum over `range_db`),
/// unprocessed range bins in [`UNPROCESSED_COLOUR`] and labelled, points as hollow circles at
/// `marks`.
#[allow(clippy::too_many_arguments)]
fn heatmap_panel(
    area: &Area<'_>,
    title: &str,
    x_desc: &str,
    db: &[Vec<f64>],
    columns: &[f64],
    range_bin_m: f64,
    processed: (usize, usize),
    marks: &[(f64, f64)],
    range_db: f64,
) -> Drawn<Axes> {
    let edges = cell_edges(columns);
    let nr = db.len();
    let x = (edges[0], edges[edges.len() - 1]);
    let y = (-0.5 * range_bin_m, (nr as f64 - 0.5) * range_bin_m);
    let mut chart = ChartBuilder::on(area)
        .caption(title, font(20))
        .margin(10)
        .x_label_area_size(56)
        .y_label_area_size(70)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    let cells = db.iter().enumerate().flat_map(|(b, row)| {
        let edges = &edges;
        row.iter().enumerate().map(move |(i, &v)| {
            let colour = if b < processed.0 || b > processed.1 {
                rgb(UNPROCESSED_COLOUR)
            } else {
                rgb(map_colour((v + range_db) / range_db))
            };
            let (r0, r1) = (
                (b as f64 - 0.5) * range_bin_m,
                (b as f64 + 0.5) * range_bin_m,
            );
            Rectangle::new([(edges[i], r1), (edges[i + 1], r0)], colour.filled())
        })
    });
    chart.draw_series(cells)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(x_desc)
        .y_desc("range (m)")
        .label_style(font(16))
        .axis_desc_style(font(18))
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .draw()?;
    // Label the near-range band when it is tall enough to hold a line of text.
    let axes = Axes::of(&chart);
    let band_px = processed.0 as f64 * range_bin_m / (y.1 - y.0) * f64::from(axes.height);
    if processed.0 > 0 && band_px >= 18.0 {
        let mid = (processed.0 as f64 / 2.0 - 0.5) * range_bin_m;
        chart.draw_series(std::iter::once(Text::new(
            format!("bins 0\u{2013}{}: not processed", processed.0 - 1),
            ((x.0 + x.1) / 2.0, mid),
            font(16).pos(Pos::new(HPos::Center, VPos::Center)),
        )))?;
    }
    chart.draw_series(marks.iter().map(|&p| {
        Circle::new(
            p,
            5,
            ShapeStyle::from(&rgb(MAP_POINT_COLOUR)).stroke_width(2),
        )
    }))?;
    Ok(axes)
}

/// Vertical colour bar for a scale from `lo` to `hi` drawn with `colour(f)`, `f` in [0, 1];
/// positive tick labels carry a `+` when `signed` (so that no label reads as negative next to
/// its tick mark).
#[allow(clippy::too_many_arguments)]
fn colour_bar(
    area: &Area<'_>,
    desc: &str,
    (lo, hi): (f64, f64),
    step: f64,
    signed: bool,
    colour: &dyn Fn(f64) -> [u8; 3],
    top_margin: u32,
) -> Drawn<Axes> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(top_margin)
        .margin_bottom(66)
        .margin_left(4)
        .margin_right(10)
        .right_y_label_area_size(80)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    let n = 200;
    chart.draw_series((0..n).map(|k| {
        let (f0, f1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
        let (v0, v1) = (lo + (hi - lo) * f0, lo + (hi - lo) * f1);
        Rectangle::new(
            [(0.0, v1), (1.0, v0)],
            rgb(colour((f0 + f1) / 2.0)).filled(),
        )
    }))?;
    let ticks = ((hi - lo) / step).round() as usize + 1;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(ticks)
        .set_tick_mark_size(LabelAreaPosition::Right, 4)
        .y_desc(desc)
        .label_style(font(16))
        .axis_desc_style(font(18))
        .y_label_formatter(&|v| match tick_label(*v) {
            t if signed && *v > 0.0 => format!("+{t}"),
            t => t,
        })
        .draw()?;
    Ok(Axes::of(&chart))
}

/// Range of a point, m.
fn point_range(p: &PointRecord) -> f64 {
    (p.x * p.x + p.y * p.y + p.z * p.z).sqrt()
}

/// Azimuth of a point in degrees (spec §1: μ = −u_y, φ = asin(μ/√(1 − ν²)), positive to the
/// right).
fn point_azimuth_deg(p: &PointRecord) -> f64 {
    let r = point_range(p);
    if r == 0.0 {
        return 0.0;
    }
    let (mu, nu) = (-p.y / r, p.z / r);
    (mu / (1.0 - nu * nu).max(1e-12).sqrt())
        .clamp(-1.0, 1.0)
        .asin()
        .to_degrees()
}

/// Plot a frame's range–azimuth map (left) and range–Doppler map (right) as one PNG with a
/// shared dB colour bar and the frame's points marked on both.
///
/// Each map is drawn in dB relative to its own maximum, viridis from 0 dB down to
/// −`dynamic_range_db`; cells are centred on their bins, range goes up. Range bins outside
/// `processed_bins` are drawn in [`UNPROCESSED_COLOUR`] and labelled. The image is
/// [`MAPS_SIZE`].
///
/// Errors (naming `path`, nothing written): an empty map, rows of a length other than the
/// column grid's, a grid that is not strictly increasing and finite, a power that is negative
/// or not finite, maps of different range lengths, a `range_bin_m` that is not finite and
/// positive, a dynamic range outside [`DYNAMIC_RANGES_DB`], or a non-finite point.
pub fn plot_maps(path: &Path, m: &MapsInput<'_>) -> Result<MapAxes, IoError> {
    let range_db = m.dynamic_range_db;
    if !DYNAMIC_RANGES_DB.contains(&range_db) {
        return Err(IoError::invalid(
            path,
            format!(
                "dynamic range {range_db} dB; expected {} to {} dB",
                DYNAMIC_RANGES_DB.start(),
                DYNAMIC_RANGES_DB.end()
            ),
        ));
    }
    if !(m.range_bin_m.is_finite() && m.range_bin_m > 0.0) {
        return Err(IoError::invalid(
            path,
            format!("range bin {} m; expected a finite value > 0", m.range_bin_m),
        ));
    }
    check_points(path, m.points, &[])?;
    let ra = map_db(path, "range-azimuth map", &m.range_azimuth)?;
    let rd = map_db(path, "range-Doppler map", &m.range_doppler)?;
    if ra.len() != rd.len() {
        return Err(IoError::invalid(
            path,
            format!(
                "the range-azimuth map has {} range bins, the range-Doppler map {}; expected the same",
                ra.len(),
                rd.len()
            ),
        ));
    }
    let ra_marks: Vec<(f64, f64)> = m
        .points
        .iter()
        .map(|p| (point_azimuth_deg(p), point_range(p)))
        .collect();
    let rd_marks: Vec<(f64, f64)> = m
        .points
        .iter()
        .map(|p| (p.doppler, point_range(p)))
        .collect();
    let title = m
        .info
        .title("range\u{2013}azimuth and range\u{2013}Doppler power");
    render_png(path, MAPS_SIZE, |root| {
        root.fill(&WHITE)?;
        let root = titled(root, &title)?;
        let (maps, bar) = root.split_horizontally(MAPS_SIZE.0 - 130);
        let panels = maps.split_evenly((1, 2));
        let ra_axes = heatmap_panel(
            &panels[0],
            &format!(
                "range\u{2013}azimuth (DBE chain, Capon), {} points",
                m.points.len()
            ),
            "azimuth (\u{b0}, + right)",
            &ra,
            m.range_azimuth.columns,
            m.range_bin_m,
            m.processed_bins,
            &ra_marks,
            range_db,
        )?;
        let rd_axes = heatmap_panel(
            &panels[1],
            "range\u{2013}Doppler (FFT over loops, \u{3a3} over antennas)",
            "radial velocity (m/s, + receding)",
            &rd,
            m.range_doppler.columns,
            m.range_bin_m,
            m.processed_bins,
            &rd_marks,
            range_db,
        )?;
        let bar_axes = colour_bar(
            &bar,
            "power re map maximum (dB)",
            (-range_db, 0.0),
            // About four to eight labelled ticks.
            match range_db {
                r if r > 80.0 => 20.0,
                r if r < 20.0 => 5.0,
                _ => 10.0,
            },
            false,
            &map_colour,
            ra_axes.top - root.get_base_pixel().1.max(0) as u32,
        )?;
        Ok(MapAxes {
            range_azimuth: ra_axes,
            range_doppler: rd_axes,
            colour_bar: bar_axes,
        })
    })
}

/// Check finiteness of plotted coordinates.
fn check_points(path: &Path, points: &[PointRecord], truth: &[[f64; 3]]) -> Result<(), IoError> {
    if let Some(i) = points.iter().position(|p| {
        !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite() && p.doppler.is_finite())
    }) {
        return Err(IoError::invalid(
            path,
            format!("point {i} has a non-finite coordinate or Doppler; expected finite values"),
        ));
    }
    if let Some(i) = truth.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(IoError::invalid(
            path,
            format!("truth point {i} has a non-finite coordinate; expected finite x, y, z"),
        ));
    }
    Ok(())
}

/// Data ranges `(lo, hi)` with equal metres per pixel on both axes for an area of `w × h`
/// pixels, covering `xs` and `ys` (and the radar at the origin) with a margin.
fn equal_aspect(xs: &[f64], ys: &[f64], w: u32, h: u32) -> ((f64, f64), (f64, f64)) {
    let (x0, x1) = span(xs);
    let (y0, y1) = span(ys);
    // Margin: 8 % of the larger span, at least 0.5 m.
    let pad = (0.08 * (x1 - x0).max(y1 - y0)).max(0.5);
    equal_units((x0 - pad, x1 + pad), (y0 - pad, y1 + pad), (w, h))
}

/// `x` and `y` grown about their centres to equal units per pixel on a data area of
/// `(w, h)` pixels.
pub(crate) fn equal_units(
    x: (f64, f64),
    y: (f64, f64),
    (w, h): (u32, u32),
) -> ((f64, f64), (f64, f64)) {
    let per_px = ((x.1 - x.0) / f64::from(w)).max((y.1 - y.0) / f64::from(h));
    let grow = |(lo, hi): (f64, f64), px: u32| {
        let half = per_px * f64::from(px) / 2.0;
        let mid = (lo + hi) / 2.0;
        (mid - half, mid + half)
    };
    (grow(x, w), grow(y, h))
}

/// `(min, max)` of `v` and 0 (the radar).
fn span(v: &[f64]) -> (f64, f64) {
    (
        v.iter().copied().fold(0.0f64, f64::min),
        v.iter().copied().fold(0.0f64, f64::max),
    )
}

/// The symmetric Doppler colour scale of `points`: their largest |radial velocity| rounded up to
/// a multiple of 0.5 m/s, at least 1 m/s.
pub fn doppler_scale(points: &[PointRecord]) -> f64 {
    let v = points.iter().map(|p| p.doppler.abs()).fold(0.0, f64::max);
    ((v / 0.5).ceil() * 0.5).max(1.0)
}

/// Margins of the views' charts, pixels: around, below (x labels) and left (y labels).
const VIEW_MARGIN: u32 = 12;
const VIEW_X_LABELS: u32 = 56;
const VIEW_Y_LABELS: u32 = 70;
/// Width of the views' Doppler colour bar.
const VIEW_BAR: u32 = 130;

/// One view: truth as grey crosses, points over them as filled circles coloured by Doppler
/// (black outline), the radar as a black triangle pointing forward, a legend, and the Doppler
/// colour bar on the right. The data ranges come from `ranges(width, height)` of the data area.
#[allow(clippy::too_many_arguments)]
fn draw_view(
    path: &Path,
    size: (u32, u32),
    title: &str,
    x_desc: &str,
    y_desc: &str,
    ranges: &dyn Fn(u32, u32) -> ((f64, f64), (f64, f64)),
    points: &[((f64, f64), f64)],
    truth: &[(f64, f64)],
    scale: f64,
) -> Result<Axes, IoError> {
    render_png(path, size, |root| {
        root.fill(&WHITE)?;
        let root = titled(root, title)?;
        let (area, bar) = root.split_horizontally(size.0 - VIEW_BAR);
        let (w, h) = data_area(
            area.dim_in_pixel(),
            VIEW_MARGIN,
            VIEW_X_LABELS,
            VIEW_Y_LABELS,
        );
        let (x, y) = ranges(w, h);
        let mut chart = ChartBuilder::on(&area)
            .margin(VIEW_MARGIN)
            .x_label_area_size(VIEW_X_LABELS)
            .y_label_area_size(VIEW_Y_LABELS)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
        chart
            .configure_mesh()
            .light_line_style(WHITE)
            .bold_line_style(RGBColor(225, 225, 225))
            .x_desc(x_desc)
            .y_desc(y_desc)
            .label_style(font(16))
            .axis_desc_style(font(18))
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .draw()?;
        let grey = rgb(TRUTH_COLOUR);
        if !truth.is_empty() {
            chart
                .draw_series(
                    truth
                        .iter()
                        .map(|&p| Cross::new(p, 7, ShapeStyle::from(&grey).stroke_width(1))),
                )?
                .label(format!("truth ({})", truth.len()))
                .legend(move |(lx, ly)| Cross::new((lx + 8, ly), 6, grey));
        }
        chart.draw_series(std::iter::once(
            EmptyElement::at((0.0, 0.0))
                + Polygon::new(vec![(-5, -6), (7, 0), (-5, 6)], BLACK.filled()),
        ))?;
        chart
            .draw_series(points.iter().map(|&(p, v)| {
                EmptyElement::at(p)
                    + Circle::new((0, 0), 4, rgb(doppler_colour(v, scale)).filled())
                    + Circle::new((0, 0), 5, BLACK.stroke_width(1))
            }))?
            .label(format!(
                "points ({}), colour = radial velocity",
                points.len()
            ))
            .legend(|(lx, ly)| {
                EmptyElement::at((lx + 8, ly))
                    + Circle::new((0, 0), 4, rgb(doppler_colour(0.0, 1.0)).filled())
            });
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(font(16))
            .draw()?;
        let axes = Axes::of(&chart);
        let top = axes.top - root.get_base_pixel().1.max(0) as u32;
        colour_bar(
            &bar,
            "radial velocity (m/s, + receding)",
            (-scale, scale),
            if scale > 2.0 { 1.0 } else { 0.5 },
            true,
            &|f| doppler_colour((2.0 * f - 1.0) * scale, scale),
            top,
        )?;
        Ok(axes)
    })
}

/// Plot a point cloud as two PNGs: a top view (x forward to the right, y left upwards: seen
/// from above) at `path_top`, [`TOP_SIZE`], and a side view (x to the right, z up: seen from the
/// radar's right) at `path_side`, [`SIDE_SIZE`], titled from `info`.
///
/// Points are filled circles coloured by radial velocity ([`doppler_colour`] on
/// ±[`doppler_scale`], with a colour bar), drawn over the `truth` positions `[x, y, z]` (grey
/// crosses). Both views cover every point, every truth point and the radar (origin) with a
/// margin and share the x range; the top view has equal metres per pixel on both axes, the side
/// view too unless the z extent needs more room (then z is compressed). Returns the axes of the
/// top and the side view.
pub fn plot_points(
    path_top: &Path,
    path_side: &Path,
    info: &FrameInfo,
    points: &[PointRecord],
    truth: Option<&[[f64; 3]]>,
) -> Result<(Axes, Axes), IoError> {
    let truth = truth.unwrap_or(&[]);
    check_points(path_top, points, truth)?;
    let all = |k: usize| -> Vec<f64> {
        points
            .iter()
            .map(|p| [p.x, p.y, p.z][k])
            .chain(truth.iter().map(|t| t[k]))
            .collect()
    };
    let (xs, ys, zs) = (all(0), all(1), all(2));
    let scale = doppler_scale(points);
    let view = |k: usize| -> Vec<((f64, f64), f64)> {
        points
            .iter()
            .map(|p| ((p.x, [p.x, p.y, p.z][k]), p.doppler))
            .collect()
    };
    let truth_view = |k: usize| -> Vec<(f64, f64)> { truth.iter().map(|t| (t[0], t[k])).collect() };
    let top_ranges = |w: u32, h: u32| equal_aspect(&xs, &ys, w, h);
    let top = draw_view(
        path_top,
        TOP_SIZE,
        &info.title("top view"),
        "x forward (m)",
        "y left (m)",
        &top_ranges,
        &view(1),
        &truth_view(1),
        scale,
    )?;
    // Side view: the top view's x range; z centred on the data (and the radar) at the same
    // metres per pixel, unless z needs more room, in which case z is compressed to fit.
    let x_range = top.x_range;
    let (z_lo, z_hi) = span(&zs);
    let side_ranges = |w: u32, h: u32| {
        let mpp = (x_range.1 - x_range.0) / f64::from(w);
        let z_pad = (0.08 * (z_hi - z_lo)).max(0.5);
        let z_half = (mpp * f64::from(h) / 2.0).max((z_hi - z_lo) / 2.0 + z_pad);
        let z_mid = (z_lo + z_hi) / 2.0;
        (x_range, (z_mid - z_half, z_mid + z_half))
    };
    let side = draw_view(
        path_side,
        SIDE_SIZE,
        &info.title("side view"),
        "x forward (m)",
        "z up (m)",
        &side_ranges,
        &view(2),
        &truth_view(2),
        scale,
    )?;
    Ok((top, side))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_use_a_true_minus_and_no_negative_zero() {
        assert_eq!(signed_label(-40.0, 0), "\u{2212}40");
        assert_eq!(signed_label(-1e-17, 1), "0.0");
        assert_eq!(signed_label(0.5, 1), "0.5");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(-2.5), "\u{2212}2.5");
        assert_eq!(tick_label(100.0), "100");
    }

    #[test]
    fn colour_scales_have_distinct_ends() {
        assert_ne!(map_colour(0.0), map_colour(1.0));
        assert_eq!(map_colour(2.0), map_colour(1.0));
        let (a, s, r) = (
            doppler_colour(-1.0, 1.0),
            doppler_colour(0.0, 1.0),
            doppler_colour(1.0, 1.0),
        );
        assert!(a[2] > a[0] && r[0] > r[2], "blue approaching, red receding");
        assert_eq!(s, [70, 70, 70]);
    }

    #[test]
    fn pixel_mapping_covers_the_area() {
        let a = Axes {
            left: 10,
            top: 20,
            width: 101,
            height: 51,
            x_range: (0.0, 10.0),
            y_range: (-5.0, 0.0),
        };
        assert_eq!(a.pixel(0.0, 0.0), Some((10, 20)));
        assert_eq!(a.pixel(10.0, -5.0), Some((110, 70)));
        assert_eq!(a.pixel(5.0, -2.5), Some((60, 45)));
        assert_eq!(a.pixel(10.1, -1.0), None);
    }
}
