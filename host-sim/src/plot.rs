//! PNG plots of range–azimuth maps and point clouds, rasterised here.
//!
//! No font library and no system font is needed: text uses a built-in 5 × 7 pixel font
//! (upper-case letters, digits and a few symbols; lower case is drawn upper case), scaled 2×.
//! Images are RGB, 8 bits per channel, written atomically (see [`crate::io::atomic`]).
//!
//! Every plot returns the [`Axes`] of its data area so that callers (and tests) can map data
//! coordinates to pixels.

use std::path::Path;

use crate::cloud::PointRecord;
use crate::io::{write_file_atomic, IoError};

/// Image size of [`plot_range_azimuth`], pixels (width, height).
pub const RA_SIZE: (u32, u32) = (800, 600);
/// Image size of the top view of [`plot_points`].
pub const TOP_SIZE: (u32, u32) = (720, 720);
/// Image size of the side view of [`plot_points`].
pub const SIDE_SIZE: (u32, u32) = (900, 450);
/// Dynamic range of the range–azimuth colour scale: the map's maximum is the top colour, values
/// this many dB below it (or lower) the bottom colour.
pub const RA_DYNAMIC_RANGE_DB: f64 = 40.0;
/// Colour of detected points.
pub const POINT_COLOUR: [u8; 3] = [220, 50, 32];
/// Colour of truth markers.
pub const TRUTH_COLOUR: [u8; 3] = [0, 90, 200];

const WHITE: [u8; 3] = [255, 255, 255];
const BLACK: [u8; 3] = [0, 0, 0];
const GRID: [u8; 3] = [225, 225, 225];
const SCALE: u32 = 2; // font scale: glyphs are 10 × 14 pixels, advance 12

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
    /// Pixel `(column, row)` holding data point `(x, y)`, or `None` outside the data area:
    /// `column = left + ⌊(x − x0)/(x1 − x0) · width⌋`, `row = top + ⌊(y1 − y)/(y1 − y0) · height⌋`.
    pub fn pixel(&self, x: f64, y: f64) -> Option<(u32, u32)> {
        Some((self.column(x)?, self.row(y)?))
    }

    /// Pixel column of `x`, or `None` outside the data area.
    fn column(&self, x: f64) -> Option<u32> {
        let f = (x - self.x_range.0) / (self.x_range.1 - self.x_range.0);
        (0.0..1.0)
            .contains(&f)
            .then(|| self.left + (f * f64::from(self.width)) as u32)
    }

    /// Pixel row of `y`, or `None` outside the data area.
    fn row(&self, y: f64) -> Option<u32> {
        let f = (self.y_range.1 - y) / (self.y_range.1 - self.y_range.0);
        (0.0..1.0)
            .contains(&f)
            .then(|| self.top + (f * f64::from(self.height)) as u32)
    }

    /// Data coordinates of the centre of pixel `(column, row)`.
    fn data(&self, col: u32, row: u32) -> (f64, f64) {
        let fx = (f64::from(col - self.left) + 0.5) / f64::from(self.width);
        let fy = (f64::from(row - self.top) + 0.5) / f64::from(self.height);
        (
            self.x_range.0 + fx * (self.x_range.1 - self.x_range.0),
            self.y_range.1 - fy * (self.y_range.1 - self.y_range.0),
        )
    }
}

/// An RGB raster.
struct Canvas {
    width: u32,
    height: u32,
    px: Vec<[u8; 3]>,
}

impl Canvas {
    fn new((width, height): (u32, u32)) -> Self {
        Self {
            width,
            height,
            px: vec![WHITE; (width * height) as usize],
        }
    }

    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            self.px[(y as u32 * self.width + x as u32) as usize] = c;
        }
    }

    fn rect(&mut self, x: i64, y: i64, w: i64, h: i64, c: [u8; 3]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.set(xx, yy, c);
            }
        }
    }

    fn hline(&mut self, x0: i64, x1: i64, y: i64, c: [u8; 3]) {
        self.rect(x0, y, x1 - x0 + 1, 1, c);
    }

    fn vline(&mut self, x: i64, y0: i64, y1: i64, c: [u8; 3]) {
        self.rect(x, y0, 1, y1 - y0 + 1, c);
    }

    fn frame(&mut self, a: &Axes, c: [u8; 3]) {
        let (l, t) = (i64::from(a.left) - 1, i64::from(a.top) - 1);
        let (r, b) = (i64::from(a.left + a.width), i64::from(a.top + a.height));
        self.hline(l, r, t, c);
        self.hline(l, r, b, c);
        self.vline(l, t, b, c);
        self.vline(r, t, b, c);
    }

    /// Text with its top-left corner at `(x, y)`.
    fn text(&mut self, x: i64, y: i64, s: &str, c: [u8; 3]) {
        for (i, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            let gx = x + i as i64 * i64::from(6 * SCALE);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        self.rect(
                            gx + i64::from(col * SCALE),
                            y + (row as u32 * SCALE) as i64,
                            i64::from(SCALE),
                            i64::from(SCALE),
                            c,
                        );
                    }
                }
            }
        }
    }

    /// Text rotated 90° counter-clockwise (reads bottom to top), its bounding box's top-left at
    /// `(x, y)`.
    fn text_up(&mut self, x: i64, y: i64, s: &str, c: [u8; 3]) {
        let len = text_width(s);
        for (i, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            // Glyph i occupies rows [y + len − (i+1)·advance, …) going up.
            let base_y = y + len - i as i64 * i64::from(6 * SCALE);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5u32 {
                    if bits & (0x10 >> col) != 0 {
                        self.rect(
                            x + (row as u32 * SCALE) as i64,
                            base_y - i64::from((col + 1) * SCALE),
                            i64::from(SCALE),
                            i64::from(SCALE),
                            c,
                        );
                    }
                }
            }
        }
    }

    fn encode(&self, path: &Path) -> Result<Vec<u8>, IoError> {
        let mut out = Vec::new();
        let fail = |e: png::EncodingError| IoError::invalid(path, format!("PNG encoding: {e}"));
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().map_err(fail)?;
            let flat: Vec<u8> = self.px.iter().flatten().copied().collect();
            w.write_image_data(&flat).map_err(fail)?;
            w.finish().map_err(fail)?;
        }
        Ok(out)
    }

    fn save(&self, path: &Path) -> Result<(), IoError> {
        write_file_atomic(path, &self.encode(path)?)
    }
}

/// Width of `s` in pixels.
fn text_width(s: &str) -> i64 {
    let n = s.chars().count() as i64;
    if n == 0 {
        0
    } else {
        n * i64::from(6 * SCALE) - i64::from(SCALE)
    }
}

/// Height of a line of text, pixels.
const TEXT_HEIGHT: i64 = 7 * SCALE as i64;

/// 5 × 7 glyphs: 7 rows, bit 4 = leftmost column. Lower case maps to upper case; unknown
/// characters draw as `?`.
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        ' ' => [0; 7],
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '[' => [0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E],
        ']' => [0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        '°' => [0x0C, 0x12, 0x12, 0x0C, 0x00, 0x00, 0x00],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04],
    }
}

/// Tick positions ("nice" steps 1, 2, 5 × 10^k) for about `target` ticks over `[lo, hi]`.
fn ticks(lo: f64, hi: f64, target: f64) -> (Vec<f64>, f64) {
    let raw = (hi - lo) / target;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let v = (first..=last).map(|i| i as f64 * step).collect();
    (v, step)
}

/// A tick label with as many decimals as the step needs.
fn tick_label(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10()).ceil() as usize
    };
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        format!("{:.decimals$}", 0.0) // no "-0"
    } else {
        s
    }
}

/// Grid lines, ticks and tick labels on both axes, plus the axis titles.
fn draw_axes(cv: &mut Canvas, a: &Axes, x_title: &str, y_title: &str, grid: bool) {
    let (l, t) = (i64::from(a.left), i64::from(a.top));
    let (r, b) = (l + i64::from(a.width) - 1, t + i64::from(a.height) - 1);
    let (xt, xs) = ticks(a.x_range.0, a.x_range.1, 8.0);
    for v in xt {
        let Some(px) = a.column(v) else {
            continue;
        };
        let px = i64::from(px);
        if grid {
            cv.vline(px, t, b, GRID);
        }
        cv.vline(px, b + 1, b + 6, BLACK);
        let s = tick_label(v, xs);
        cv.text(px - text_width(&s) / 2, b + 10, &s, BLACK);
    }
    let (yt, ys) = ticks(a.y_range.0, a.y_range.1, 6.0);
    for v in yt {
        let Some(py) = a.row(v) else {
            continue;
        };
        let py = i64::from(py);
        if grid {
            cv.hline(l, r, py, GRID);
        }
        cv.hline(l - 6, l - 1, py, BLACK);
        let s = tick_label(v, ys);
        cv.text(l - 10 - text_width(&s), py - TEXT_HEIGHT / 2, &s, BLACK);
    }
    cv.text(
        l + i64::from(a.width) / 2 - text_width(x_title) / 2,
        b + 34,
        x_title,
        BLACK,
    );
    cv.text_up(
        8,
        t + i64::from(a.height) / 2 - text_width(y_title) / 2,
        y_title,
        BLACK,
    );
    cv.frame(a, BLACK);
}

/// Viridis, sampled at 9 points and interpolated linearly; `f` in `[0, 1]`.
fn viridis(f: f64) -> [u8; 3] {
    const C: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let x = f.clamp(0.0, 1.0) * 8.0;
    let i = (x.floor() as usize).min(7);
    let w = x - i as f64;
    let mut out = [0u8; 3];
    for (k, o) in out.iter_mut().enumerate() {
        *o = (C[i][k] * (1.0 - w) + C[i + 1][k] * w).round() as u8;
    }
    out
}

/// Colour of the range–azimuth map's maximum.
pub const RA_TOP_COLOUR: [u8; 3] = [253, 231, 37];
/// Colour of values [`RA_DYNAMIC_RANGE_DB`] or more below the maximum.
pub const RA_BOTTOM_COLOUR: [u8; 3] = [68, 1, 84];

/// Plot a range–azimuth map as a PNG heatmap of `10·log10(power)`.
///
/// `ra_map[b][i]` is the linear power of range bin `b` (range `b · range_bin_m`) and azimuth bin
/// `i` (angle `azimuth_deg[i]`, strictly increasing): the core's `Workspace::range_azimuth()`
/// rows fit as they are. Each cell is drawn centred on its bin; range goes up, azimuth to the
/// right. Colours: viridis from the maximum ([`RA_TOP_COLOUR`]) down to
/// [`RA_DYNAMIC_RANGE_DB`] below it ([`RA_BOTTOM_COLOUR`]). The image is [`RA_SIZE`].
///
/// Errors (naming `path`): an empty map, rows of a length other than `azimuth_deg.len()`, a grid
/// that is not strictly increasing and finite, a power that is negative or not finite, or a
/// `range_bin_m` that is not finite and positive.
pub fn plot_range_azimuth<R, T>(
    path: &Path,
    ra_map: &[R],
    range_bin_m: f64,
    azimuth_deg: &[f64],
) -> Result<Axes, IoError>
where
    R: AsRef<[T]>,
    T: Copy + Into<f64>,
{
    let bad = |m: String| Err(IoError::invalid(path, m));
    if ra_map.is_empty() || azimuth_deg.is_empty() {
        return bad("empty range-azimuth map; expected at least one range and azimuth bin".into());
    }
    if !(range_bin_m.is_finite() && range_bin_m > 0.0) {
        return bad(format!(
            "range bin {range_bin_m} m; expected a finite value > 0"
        ));
    }
    if azimuth_deg.iter().any(|a| !a.is_finite()) || azimuth_deg.windows(2).any(|w| w[1] <= w[0]) {
        return bad("azimuth grid is not finite and strictly increasing".into());
    }
    let naz = azimuth_deg.len();
    let mut db = Vec::with_capacity(ra_map.len());
    for (b, row) in ra_map.iter().enumerate() {
        let row = row.as_ref();
        if row.len() != naz {
            return bad(format!(
                "range bin {b} has {} azimuth values; expected {naz} (the azimuth grid)",
                row.len()
            ));
        }
        let mut out = Vec::with_capacity(naz);
        for (i, &v) in row.iter().enumerate() {
            let v: f64 = v.into();
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!(
                    "power at range bin {b}, azimuth bin {i} is {v}; expected finite linear power ≥ 0"
                ));
            }
            out.push(10.0 * v.log10()); // −inf for 0
        }
        db.push(out);
    }
    let top_db = db
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let floor_db = top_db - RA_DYNAMIC_RANGE_DB;

    // Cell edges: half a step beyond the end bins.
    let half_first = if naz > 1 {
        (azimuth_deg[1] - azimuth_deg[0]) / 2.0
    } else {
        0.5
    };
    let half_last = if naz > 1 {
        (azimuth_deg[naz - 1] - azimuth_deg[naz - 2]) / 2.0
    } else {
        0.5
    };
    let nr = ra_map.len();
    let axes = Axes {
        left: 90,
        top: 50,
        width: 560,
        height: 460,
        x_range: (
            azimuth_deg[0] - half_first,
            azimuth_deg[naz - 1] + half_last,
        ),
        y_range: (-0.5 * range_bin_m, (nr as f64 - 0.5) * range_bin_m),
    };
    let mut cv = Canvas::new(RA_SIZE);
    for row in axes.top..axes.top + axes.height {
        for col in axes.left..axes.left + axes.width {
            let (az, range) = axes.data(col, row);
            // Nearest azimuth bin: the first whose upper cell edge is above `az`.
            let i = azimuth_deg
                .windows(2)
                .position(|w| az < (w[0] + w[1]) / 2.0)
                .unwrap_or(naz - 1);
            let b = ((range / range_bin_m).round().max(0.0) as usize).min(nr - 1);
            let v = db[b][i];
            let f = if top_db.is_finite() && v.is_finite() {
                (v - floor_db) / RA_DYNAMIC_RANGE_DB
            } else {
                0.0
            };
            cv.set(i64::from(col), i64::from(row), viridis(f));
        }
    }
    draw_axes(&mut cv, &axes, "AZIMUTH (DEG)", "RANGE (M)", false);
    cv.text(i64::from(axes.left), 16, "RANGE-AZIMUTH POWER (DB)", BLACK);

    // Colour bar.
    let (bx, bw) = (i64::from(axes.left + axes.width) + 30, 20);
    let (bt, bh) = (i64::from(axes.top), i64::from(axes.height));
    for y in 0..bh {
        let f = 1.0 - (y as f64 + 0.5) / bh as f64;
        cv.hline(bx, bx + bw - 1, bt + y, viridis(f));
    }
    let bar = Axes {
        left: (bx) as u32,
        top: axes.top,
        width: bw as u32,
        height: axes.height,
        x_range: (0.0, 1.0),
        y_range: if top_db.is_finite() {
            (floor_db, top_db)
        } else {
            (-RA_DYNAMIC_RANGE_DB, 0.0)
        },
    };
    cv.frame(&bar, BLACK);
    let (yt, ys) = ticks(bar.y_range.0, bar.y_range.1, 5.0);
    for v in yt {
        if let Some(py) = bar.row(v) {
            let py = i64::from(py);
            cv.hline(bx + bw, bx + bw + 5, py, BLACK);
            cv.text(bx + bw + 8, py - TEXT_HEIGHT / 2, &tick_label(v, ys), BLACK);
        }
    }
    cv.save(path)?;
    Ok(axes)
}

/// Check finiteness of plotted coordinates.
fn check_points(path: &Path, points: &[PointRecord], truth: &[[f64; 3]]) -> Result<(), IoError> {
    if let Some(i) = points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(IoError::invalid(
            path,
            format!("point {i} has a non-finite coordinate; expected finite x, y, z"),
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
    let span = |v: &[f64]| {
        let lo = v.iter().copied().fold(0.0f64, f64::min);
        let hi = v.iter().copied().fold(0.0f64, f64::max);
        (lo, hi)
    };
    let (mut x0, mut x1) = span(xs);
    let (mut y0, mut y1) = span(ys);
    // Margin: 8 % of the larger span, at least 0.5 m.
    let pad = (0.08 * (x1 - x0).max(y1 - y0)).max(0.5);
    x0 -= pad;
    x1 += pad;
    y0 -= pad;
    y1 += pad;
    let mpp = ((x1 - x0) / f64::from(w)).max((y1 - y0) / f64::from(h));
    let grow = |lo: f64, hi: f64, px: u32| {
        let extra = mpp * f64::from(px) - (hi - lo);
        (lo - extra / 2.0, hi + extra / 2.0)
    };
    (grow(x0, x1, w), grow(y0, y1, h))
}

/// Draw one view: points as filled 5 × 5 squares in [`POINT_COLOUR`], truth as 9 × 9 crosses in
/// [`TRUTH_COLOUR`] (drawn first, points on top), the radar as a black triangle at the origin
/// pointing forward.
#[allow(clippy::too_many_arguments)]
fn draw_view(
    path: &Path,
    size: (u32, u32),
    axes: &Axes,
    title: &str,
    x_title: &str,
    y_title: &str,
    points: &[(f64, f64)],
    truth: &[(f64, f64)],
) -> Result<(), IoError> {
    let mut cv = Canvas::new(size);
    draw_axes(&mut cv, axes, x_title, y_title, true);
    cv.text(i64::from(axes.left), 16, title, BLACK);
    if let Some((ox, oy)) = axes.pixel(0.0, 0.0) {
        let (ox, oy) = (i64::from(ox), i64::from(oy));
        // A triangle pointing forward (+x is to the right in both views).
        for d in 0..6 {
            cv.vline(ox + 3 - d, oy - d, oy + d, BLACK);
        }
    }
    for &(x, y) in truth {
        if let Some((px, py)) = axes.pixel(x, y) {
            let (px, py) = (i64::from(px), i64::from(py));
            for d in -4..=4 {
                cv.rect(px + d, py + d, 1, 1, TRUTH_COLOUR);
                cv.rect(px + d, py - d, 1, 1, TRUTH_COLOUR);
                cv.rect(px + d, py + d + 1, 1, 1, TRUTH_COLOUR);
                cv.rect(px + d, py - d + 1, 1, 1, TRUTH_COLOUR);
            }
        }
    }
    for &(x, y) in points {
        if let Some((px, py)) = axes.pixel(x, y) {
            cv.rect(i64::from(px) - 2, i64::from(py) - 2, 5, 5, POINT_COLOUR);
        }
    }
    // Legend, inside the data area's top-left corner.
    let (lx, ly) = (i64::from(axes.left) + 10, i64::from(axes.top) + 10);
    cv.rect(lx, ly + 4, 8, 8, POINT_COLOUR);
    cv.text(lx + 14, ly, &format!("POINTS {}", points.len()), BLACK);
    if !truth.is_empty() {
        cv.rect(lx, ly + 28, 8, 8, TRUTH_COLOUR);
        cv.text(lx + 14, ly + 24, &format!("TRUTH {}", truth.len()), BLACK);
    }
    cv.save(path)
}

/// Plot a point cloud as two PNGs: a top view (x forward to the right, y left upwards: seen
/// from above) at `path_top`, [`TOP_SIZE`], and a side view (x to the right, z up: seen from the
/// radar's right) at `path_side`, [`SIDE_SIZE`], with metre axes, ticks and a legend.
///
/// Both views cover every point, every truth point and the radar (origin) with a margin and
/// share the x range; the top view has equal metres per pixel on both axes, the side view too
/// unless the z extent needs more room (then z is compressed). `truth` positions
/// `[x, y, z]` are drawn as crosses. Returns the axes of the top and the side view.
pub fn plot_points(
    path_top: &Path,
    path_side: &Path,
    points: &[PointRecord],
    truth: Option<&[[f64; 3]]>,
) -> Result<(Axes, Axes), IoError> {
    let truth = truth.unwrap_or(&[]);
    check_points(path_top, points, truth)?;
    let xs: Vec<f64> = points
        .iter()
        .map(|p| p.x)
        .chain(truth.iter().map(|t| t[0]))
        .collect();
    let ys: Vec<f64> = points
        .iter()
        .map(|p| p.y)
        .chain(truth.iter().map(|t| t[1]))
        .collect();
    let zs: Vec<f64> = points
        .iter()
        .map(|p| p.z)
        .chain(truth.iter().map(|t| t[2]))
        .collect();

    let (tw, th) = (TOP_SIZE.0 - 120, TOP_SIZE.1 - 130);
    let (x_range, y_range) = equal_aspect(&xs, &ys, tw, th);
    let top = Axes {
        left: 90,
        top: 50,
        width: tw,
        height: th,
        x_range,
        y_range,
    };
    let (sw, sh) = (SIDE_SIZE.0 - 120, SIDE_SIZE.1 - 130);
    // Side view: same x range; z centred on the data (and the radar) at the same metres per
    // pixel, unless z needs more room, in which case z is compressed to fit.
    let mpp = (x_range.1 - x_range.0) / f64::from(sw);
    let z_lo = zs.iter().copied().fold(0.0f64, f64::min);
    let z_hi = zs.iter().copied().fold(0.0f64, f64::max);
    let z_pad = (0.08 * (z_hi - z_lo)).max(0.5);
    let z_half = (mpp * f64::from(sh) / 2.0).max((z_hi - z_lo) / 2.0 + z_pad);
    let z_mid = (z_lo + z_hi) / 2.0;
    let side = Axes {
        left: 90,
        top: 50,
        width: sw,
        height: sh,
        x_range,
        y_range: (z_mid - z_half, z_mid + z_half),
    };

    let top_pts: Vec<(f64, f64)> = points.iter().map(|p| (p.x, p.y)).collect();
    let top_truth: Vec<(f64, f64)> = truth.iter().map(|t| (t[0], t[1])).collect();
    draw_view(
        path_top,
        TOP_SIZE,
        &top,
        "TOP VIEW",
        "X FORWARD (M)",
        "Y LEFT (M)",
        &top_pts,
        &top_truth,
    )?;
    let side_pts: Vec<(f64, f64)> = points.iter().map(|p| (p.x, p.z)).collect();
    let side_truth: Vec<(f64, f64)> = truth.iter().map(|t| (t[0], t[2])).collect();
    draw_view(
        path_side,
        SIDE_SIZE,
        &side,
        "SIDE VIEW",
        "X FORWARD (M)",
        "Z UP (M)",
        &side_pts,
        &side_truth,
    )?;
    Ok((top, side))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ticks() {
        let (v, s) = ticks(-70.0, 70.0, 8.0);
        assert_eq!(s, 20.0);
        assert_eq!(v.first().copied(), Some(-60.0));
        assert_eq!(v.last().copied(), Some(60.0));
        assert_eq!(tick_label(0.5, 0.5), "0.5");
        assert_eq!(tick_label(-1e-17, 0.2), "0.0");
        assert_eq!(tick_label(20.0, 20.0), "20");
    }

    #[test]
    fn viridis_ends() {
        assert_eq!(viridis(0.0), RA_BOTTOM_COLOUR);
        assert_eq!(viridis(1.0), RA_TOP_COLOUR);
        assert_eq!(viridis(2.0), RA_TOP_COLOUR);
    }

    #[test]
    fn pixel_mapping_round_trips() {
        let a = Axes {
            left: 10,
            top: 20,
            width: 100,
            height: 50,
            x_range: (0.0, 10.0),
            y_range: (-5.0, 0.0),
        };
        assert_eq!(a.pixel(0.0, 0.0 - 1e-9), Some((10, 20)));
        assert_eq!(a.pixel(9.99, -4.99), Some((109, 69)));
        assert_eq!(a.pixel(10.0, -1.0), None);
        let (x, y) = a.data(60, 45);
        assert_eq!(a.pixel(x, y), Some((60, 45)));
    }
}
