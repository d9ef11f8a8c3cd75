//! Line charts as PNG: the evaluation's curves (RMSE vs SNR, resolution vs separation, …).
//!
//! Rasterised here (the `png` crate only encodes), with a built-in 5 × 7 pixel font drawn at
//! 2× (upper and lower case, digits, a few symbols and Greek letters used in the labels), so
//! no font or system library is needed. [`crate::plot`] draws maps and clouds; this draws
//! x–y curves with linear or logarithmic axes, markers, dashed lines and a legend.

use std::path::Path;

use crate::io::{write_file_atomic, IoError};

/// Image size, pixels.
pub const SIZE: (u32, u32) = (900, 560);
const LEFT: i64 = 120;
const TOP: i64 = 48;
const PLOT_W: i64 = 540;
const PLOT_H: i64 = 420;
const SCALE: i64 = 2;
const ADVANCE: i64 = 6 * SCALE;
const WHITE: [u8; 3] = [255, 255, 255];
const BLACK: [u8; 3] = [0, 0, 0];
const GRID: [u8; 3] = [228, 228, 228];

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
    /// The curves.
    pub series: Vec<Series>,
}

struct Canvas {
    w: i64,
    h: i64,
    px: Vec<[u8; 3]>,
}

impl Canvas {
    fn new() -> Self {
        Self {
            w: i64::from(SIZE.0),
            h: i64::from(SIZE.1),
            px: vec![WHITE; (SIZE.0 * SIZE.1) as usize],
        }
    }

    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if (0..self.w).contains(&x) && (0..self.h).contains(&y) {
            self.px[(y * self.w + x) as usize] = c;
        }
    }

    fn rect(&mut self, x: i64, y: i64, w: i64, h: i64, c: [u8; 3]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.set(xx, yy, c);
            }
        }
    }

    /// A line of width 2 from `a` to `b`; dashed lines draw 8 px on, 6 px off.
    fn line(&mut self, a: (i64, i64), b: (i64, i64), c: [u8; 3], dashed: bool) {
        let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
        let (sx, sy) = (
            if a.0 < b.0 { 1 } else { -1 },
            if a.1 < b.1 { 1 } else { -1 },
        );
        let (mut x, mut y, mut err) = (a.0, a.1, dx + dy);
        let mut step = 0i64;
        loop {
            if !dashed || step % 14 < 8 {
                self.rect(x, y, 2, 2, c);
            }
            if x == b.0 && y == b.1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
            step += 1;
        }
    }

    fn marker(&mut self, x: i64, y: i64, kind: usize, c: [u8; 3]) {
        match kind % 4 {
            0 => self.rect(x - 3, y - 3, 7, 7, c),
            1 => {
                for d in -4i64..=4 {
                    let w = 4 - d.abs();
                    self.rect(x - w, y + d, 2 * w + 1, 1, c);
                }
            }
            2 => {
                for d in 0..7i64 {
                    self.rect(x - d / 2, y - 3 + d, d + 1, 1, c);
                }
            }
            _ => {
                for d in -3i64..=3 {
                    self.rect(x + d, y + d, 2, 2, c);
                    self.rect(x + d, y - d, 2, 2, c);
                }
            }
        }
    }

    fn text(&mut self, x: i64, y: i64, s: &str, c: [u8; 3]) {
        for (i, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            let gx = x + i as i64 * ADVANCE;
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        self.rect(gx + col * SCALE, y + row as i64 * SCALE, SCALE, SCALE, c);
                    }
                }
            }
        }
    }

    /// Text reading bottom to top, its box's top-left corner at `(x, y)`.
    fn text_up(&mut self, x: i64, y: i64, s: &str, c: [u8; 3]) {
        let len = text_width(s);
        for (i, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            let base = y + len - i as i64 * ADVANCE;
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        self.rect(
                            x + row as i64 * SCALE,
                            base - (col + 1) * SCALE,
                            SCALE,
                            SCALE,
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
            let mut enc = png::Encoder::new(&mut out, SIZE.0, SIZE.1);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().map_err(fail)?;
            let flat: Vec<u8> = self.px.iter().flatten().copied().collect();
            w.write_image_data(&flat).map_err(fail)?;
            w.finish().map_err(fail)?;
        }
        Ok(out)
    }
}

fn text_width(s: &str) -> i64 {
    let n = s.chars().count() as i64;
    if n == 0 {
        0
    } else {
        n * ADVANCE - SCALE
    }
}

/// An axis: data range (in axis units: log10 of the data on a log axis) and pixel span.
#[derive(Clone, Copy, Debug)]
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
}

impl Axis {
    /// Fit the data (or take `fixed`); a log axis spans whole decades when `round_decades`,
    /// else the data plus a margin.
    fn fit(
        values: impl Iterator<Item = f64>,
        log: bool,
        fixed: Option<(f64, f64)>,
        round_decades: bool,
    ) -> Self {
        let t = |v: f64| if log { v.log10() } else { v };
        let (mut lo, mut hi) = match fixed {
            Some((a, b)) => (t(a), t(b)),
            None => {
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
                    lo = lo.min(t(v));
                    hi = hi.max(t(v));
                }
                (lo, hi)
            }
        };
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (0.0, 1.0);
        }
        if hi - lo < 1e-12 {
            let pad = if log { 0.5 } else { lo.abs().max(1.0) * 0.1 };
            lo -= pad;
            hi += pad;
        }
        if log && round_decades {
            lo = lo.floor();
            hi = hi.ceil();
        } else if fixed.is_none() {
            let pad = 0.04 * (hi - lo);
            lo -= pad;
            hi += pad;
        }
        Self { lo, hi, log }
    }

    fn frac(&self, v: f64) -> Option<f64> {
        if self.log && v <= 0.0 || !v.is_finite() {
            return None;
        }
        let t = if self.log { v.log10() } else { v };
        Some((t - self.lo) / (self.hi - self.lo))
    }

    /// Tick values (data units) and their labels.
    fn ticks(&self) -> Vec<(f64, String)> {
        if self.log {
            let span = self.hi - self.lo;
            let mults: &[f64] = if span <= 2.0 {
                &[1.0, 2.0, 5.0]
            } else {
                &[1.0]
            };
            let mut out = Vec::new();
            let mut e = self.lo.floor() as i32;
            while f64::from(e) <= self.hi + 1e-9 {
                for &m in mults {
                    let v = m * 10f64.powi(e);
                    let t = v.log10();
                    if t >= self.lo - 1e-9 && t <= self.hi + 1e-9 {
                        let decimals = (-e).max(0) as usize;
                        out.push((v, format!("{v:.decimals$}")));
                    }
                }
                e += 1;
            }
            return out;
        }
        let raw = (self.hi - self.lo) / 7.0;
        let mag = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 2.5, 5.0, 10.0]
            .iter()
            .map(|m| m * mag)
            .find(|&s| s >= raw)
            .unwrap_or(10.0 * mag);
        let decimals = if step >= 1.0 {
            0
        } else {
            (-step.log10()).ceil() as usize + 1
        };
        let first = (self.lo / step).ceil() as i64;
        let last = (self.hi / step).floor() as i64;
        (first..=last)
            .map(|i| {
                let v = i as f64 * step;
                let s = format!("{v:.decimals$}");
                let s = if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
                    s[1..].to_string()
                } else {
                    s
                };
                (v, s)
            })
            .collect()
    }
}

/// Render `chart` to a PNG file at `path` (written atomically).
pub fn render(chart: &Chart, path: &Path) -> Result<(), IoError> {
    let mut cv = Canvas::new();
    let xs = Axis::fit(
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0)),
        chart.log_x,
        None,
        false,
    );
    let ys = Axis::fit(
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1)),
        chart.log_y,
        chart.y_range,
        true,
    );
    let px = |x: f64| {
        xs.frac(x)
            .map(|f| LEFT + (f * (PLOT_W - 1) as f64).round() as i64)
    };
    let py = |y: f64| {
        ys.frac(y)
            .map(|f| TOP + PLOT_H - 1 - (f * (PLOT_H - 1) as f64).round() as i64)
    };

    // Grid, ticks and labels.
    for (v, label) in xs.ticks() {
        if let Some(x) = px(v) {
            cv.rect(x, TOP, 1, PLOT_H, GRID);
            cv.rect(x, TOP + PLOT_H, 1, 6, BLACK);
            cv.text(x - text_width(&label) / 2, TOP + PLOT_H + 10, &label, BLACK);
        }
    }
    for (v, label) in ys.ticks() {
        if let Some(y) = py(v) {
            cv.rect(LEFT, y, PLOT_W, 1, GRID);
            cv.rect(LEFT - 6, y, 6, 1, BLACK);
            cv.text(LEFT - 10 - text_width(&label), y - 7, &label, BLACK);
        }
    }
    cv.rect(LEFT - 1, TOP - 1, PLOT_W + 2, 1, BLACK);
    cv.rect(LEFT - 1, TOP + PLOT_H, PLOT_W + 2, 1, BLACK);
    cv.rect(LEFT - 1, TOP - 1, 1, PLOT_H + 2, BLACK);
    cv.rect(LEFT + PLOT_W, TOP - 1, 1, PLOT_H + 2, BLACK);
    cv.text(LEFT, 14, &chart.title, BLACK);
    cv.text(
        LEFT + PLOT_W / 2 - text_width(&chart.x_label) / 2,
        TOP + PLOT_H + 36,
        &chart.x_label,
        BLACK,
    );
    cv.text_up(
        10,
        TOP + PLOT_H / 2 - text_width(&chart.y_label) / 2,
        &chart.y_label,
        BLACK,
    );

    // Series, clipped to the plot area.
    let inside =
        |x: i64, y: i64| (LEFT..LEFT + PLOT_W).contains(&x) && (TOP..TOP + PLOT_H).contains(&y);
    for (k, s) in chart.series.iter().enumerate() {
        let mut prev: Option<(i64, i64)> = None;
        for &(x, y) in &s.points {
            let p = match (px(x), py(y)) {
                (Some(a), Some(b)) => Some((a, b.clamp(TOP, TOP + PLOT_H - 1))),
                _ => None,
            };
            if let (Some(a), Some(b)) = (prev, p) {
                cv.line(a, b, s.colour, s.dashed);
            }
            if let Some((x, y)) = p {
                if !s.dashed && inside(x, y) {
                    cv.marker(x, y, k, s.colour);
                }
            }
            prev = p;
        }
    }

    // Legend to the right of the plot.
    let lx = LEFT + PLOT_W + 16;
    for (k, s) in chart.series.iter().enumerate() {
        let y = TOP + 8 + k as i64 * 24;
        cv.line((lx, y + 6), (lx + 30, y + 6), s.colour, s.dashed);
        if !s.dashed {
            cv.marker(lx + 15, y + 6, k, s.colour);
        }
        cv.text(lx + 38, y, &s.label, BLACK);
    }
    write_file_atomic(path, &cv.encode(path)?)
}

/// 5 × 7 glyphs: 7 rows, bit 4 = leftmost column; unknown characters draw as `?`.
fn glyph(c: char) -> [u8; 7] {
    match c {
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
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'b' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E],
        'c' => [0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'f' => [0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08],
        'g' => [0x00, 0x00, 0x0F, 0x11, 0x0F, 0x01, 0x0E],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'j' => [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'u' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D],
        'v' | 'ν' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'w' => [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        'y' => [0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'z' => [0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '[' => [0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E],
        ']' => [0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        '<' => [0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02],
        '>' => [0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08],
        '\'' => [0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00],
        '°' => [0x0C, 0x12, 0x12, 0x0C, 0x00, 0x00, 0x00],
        '×' => [0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x00],
        'γ' => [0x00, 0x00, 0x11, 0x11, 0x0A, 0x04, 0x04],
        'α' => [0x00, 0x00, 0x09, 0x15, 0x12, 0x12, 0x0D],
        'μ' => [0x00, 0x00, 0x11, 0x11, 0x13, 0x1D, 0x10],
        'θ' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x0E],
        'φ' => [0x04, 0x0E, 0x15, 0x15, 0x15, 0x0E, 0x04],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_cover_decades() {
        let a = Axis::fit([0.02, 3.0].into_iter(), true, None, true);
        assert_eq!((a.lo, a.hi), (-2.0, 1.0));
        let t = a.ticks();
        assert!(t
            .iter()
            .any(|(v, s)| (*v - 0.01).abs() < 1e-12 && s == "0.01"));
        assert!(t.iter().any(|(v, s)| (*v - 10.0).abs() < 1e-9 && s == "10"));
    }

    #[test]
    fn a_point_lands_on_its_pixel() {
        let a = Axis::fit([0.0, 10.0].into_iter(), false, Some((0.0, 10.0)), true);
        assert_eq!(a.frac(5.0), Some(0.5));
        assert_eq!(a.frac(f64::NAN), None);
    }
}
