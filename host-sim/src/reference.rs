//! The reference DBE chain: spec §3 written again in plain `f64`, for validating the core.
//!
//! This module exists to be compared with `dbe_radar` (see [`crate::harness`]), so it shares
//! **no DSP code** with it. The core's configuration types ([`Params`], [`CfarParams`],
//! [`ElevationParams`], [`WindowKind`], the waveform and antenna positions inside
//! [`SensorConfig`]) are read as plain data; everything computed from them is computed here:
//! windows, the range FFT (rustfft), the virtual-array layout, covariance, forward–backward
//! averaging, diagonal loading, Capon (nalgebra Cholesky on `DMatrix<Complex64>`), OS-CFAR,
//! TDM-MIMO motion compensation, the elevation peak rules and the Doppler FFT. Clarity comes
//! before speed: dynamic matrices, one allocation per step, every formula as the spec states
//! it.
//!
//! # Contract (identical to the core's, so that the two agree)
//!
//! - **Range (§3.0).** Per chirp and RX: subtract the complex mean of the `N` samples, multiply
//!   by the *symmetric* range window (`w[n]`, period `N − 1`), `N`-point FFT, unnormalised,
//!   `X[b] = Σ x[n]·exp(−j·2π·b·n/N)`. With a coupling table, subtract `c[t][r][b]` for the
//!   bins `b` it covers; with channel gains, then multiply every bin by `g[t][r]`. A range
//!   bias (`SensorConfig::range_bias_m`) moves every point along its direction at the end.
//! - **Array.** Virtual antenna `(t, r)` sits at `az = tx_az[t] + rx_az[r]`,
//!   `el = tx_el[t] + rx_el[r]` (half-wavelength units at `F_design`), TDM slot `t`. The
//!   azimuth line is the elements at the lowest elevation, sorted by azimuth; it must be
//!   uniform when forward–backward averaging is on.
//! - **Azimuth (§3.1).** For range bins `range_first ..= range_last`: `R = X·Xᴴ/K` over all
//!   virtual antennas; the azimuth line's block (with `Params::spatial_smoothing`, beyond the
//!   spec: the mean of its two `D − 1`-element sub-line blocks, and `D − 1` for `D` below),
//!   forward–backward averaged `(R + J·R*·J)/2` if enabled, loaded with `δ = γ·tr(R)/D`; Capon power
//!   `P = 1/Re(aᴴR⁻¹a)` with `a_m = exp(−j·κ·μ·az_m)`, `κ = π·f_c/F_design`,
//!   `f_c = f_start + S·(N/fs)/2`, on `μ_i = sin φ_i`, `φ_i` = linspace over the azimuth span.
//!   A bin whose loaded covariance is not positive definite is a zero row (and counted).
//! - **Detection (§3.2).** A cell `(b, i)` with `i` outside the skipped edges, `P > 0`, and a
//!   maximum of its 3×3 neighbourhood (neighbours limited to the processed range rows and the
//!   grid; an equal neighbour at a lower `(b, i)` wins) is a detection when `P > α·level`,
//!   `α = 10^(dB/10)`, `level` = the `⌈q·n⌉`-th smallest of the `n` training cells (the window
//!   of half-widths guard + train minus the guard window, truncated at the grid edges and the
//!   processed range rows, never wrapped). Beyond the capacity the strongest are kept.
//!   [`process_frame`] uses that level as spec §3.2 states it; the core raises it to the
//!   row's loading floor `δ_b/D` ([`CfarLevel::LoadingFloor`], selected by
//!   [`ReferenceOptions::CORE_CONTRACT`] in [`process_frame_with`]), which the spec does not
//!   say. Spec as written detects the ripples of the loading ridge under every strong target.
//! - **CFAR window gate (beyond the spec, `CfarParams::window_gate_db` > 0).** A detection
//!   also needs `P ≥ W / 10^(dB/10)`, `W` the largest value of its whole CFAR window (guard
//!   and training cells and the cell itself, truncated as the training window).
//! - **TDM-MIMO compensation (when enabled).** The Capon weight of the azimuth line at the
//!   detection's `μ` beamforms the slow time; the strongest bin `d` of its windowed Doppler FFT
//!   plus its sub-bin offset `δ` from the two neighbours (Jacobsen's complex ratio with
//!   Candan's `tan(π/K)/(π/K)` under the rectangular window, the vertex of the log-parabola
//!   through the powers under the others) gives
//!   `v = (d + δ)·λ/(2·K·T_loop)`; every row `m` is multiplied by
//!   `exp(−j·4π·v·slot_m·Tc/λ)` (the covariance becomes `D·R·Dᴴ`); the azimuth bin then
//!   climbs the compensated azimuth spectrum uphill, at most `tdm_azimuth_search` bins (left
//!   when `left > here` and `left ≥ right`, else right when `right > here`).
//! - **Doppler test (beyond the spec, `Params::doppler_test_db` > 0).** The azimuth Capon beam
//!   after TDM compensation by the beam Doppler and the climb (with compensation off: the
//!   uncompensated beam at the detection's bin; a compensated covariance that is not positive
//!   definite passes) is windowed and transformed; when its strongest power is below
//!   `10^(dB/10)` times the median power (the ⌊K/2⌋-th smallest, 0-based; a zero median
//!   passes) the detection gives no point and is counted.
//! - **Doppler agreement (beyond the spec, `Params::doppler_agreement_bins` > 0).** A point
//!   whose Doppler (strongest bin plus its offset, stage 4) lies farther than the window
//!   (circular distance, bins) from its detection's beam Doppler is dropped.
//! - **Coherent targets (beyond the spec, `Params::coherent_doppler_bins`).** The TDM step's
//!   beam Doppler is measured for every detection first; a detection whose beam Doppler lies
//!   within the window (circular distance, bins) of another detection's in the same run of
//!   one range bin is *coherent*. Its elevation and Doppler use, instead of the full array,
//!   the 2 × E rectangle (the elevation row and the line elements below it): the mean over its
//!   two 2 × (E − 1) sub-rectangles of `(R_s + J·R_s*·J)/2` (`J` the point mirror), loaded;
//!   steering vectors and the Capon weight on the first sub-rectangle, zero elsewhere.
//! - **Elevation (§3.3).** The full (compensated) covariance, loaded, no forward–backward
//!   averaging (an array without an elevation row, all on the azimuth line: forward–backward
//!   averaged when the map is, and one direction ν = 0 labelled with the elevation bin
//!   nearest to 0° instead of the sweep's peaks); Capon power over `ν_j = sin θ_j` with `a_m = exp(−j·κ·(μ·az_m + ν·el_m))`;
//!   keep interior bins with `P[j−1] < P[j] ≥ P[j+1]`, the strongest `max_peaks` (equal powers:
//!   lower `j` first), each at least `10^(−peak_range_db/10)` times the strongest; drop
//!   directions with `μ² + ν² ≥ 1`.
//! - **Doppler (§3.4).** `w = R⁻¹a/(aᴴR⁻¹a)` of the loaded (compensated) covariance;
//!   `y_k = Σ_m conj(w_m)·rot_m·x_m[k]`; Doppler window; `K`-point FFT; the first strongest
//!   bin `d`, signed `d' = d` for `d < K/2` else `d − K`.
//! - **Point (§3.5).** `R = b·c·fs/(2·S·N)`, `x = R·√(1−μ²−ν²)`, `y = −R·μ`, `z = R·ν`,
//!   `v = d'·λ/(2·K·T_loop)`, intensity `10·log10 P` (elevation spectrum), SNR
//!   `10·log10(power/level)` of the detection.
//! - **Sub-grid refinement (`Params::subgrid`, beyond the spec).** Bins are unchanged; the
//!   point's range, `μ`, `ν` and velocity use `bin + δ`, `δ` the vertex of the parabola through
//!   the logarithms of the peak and its two neighbours (clamped to `±½`, 0 unless the centre
//!   is the largest of three positive values): range along the RA-map column of the
//!   detection, azimuth along its RA row (or, under TDM compensation, along the compensated
//!   azimuth spectrum at the climbed bin), Doppler along the circular Doppler spectrum. The
//!   elevation is the exact peak of the elevation spectrum within half a bin of its grid peak
//!   (`Setup::elevation_peak_nu`: on an array of two elevation levels the spectrum is a
//!   sinusoid in `κ·Δ·ν`). The sweep and the Capon weights stay on the grid.
//!   The azimuth then moves to the peak of the azimuth line's Capon spectrum within half a
//!   bin of the climbed bin: Newton's method on `q(μ) = bᴴR⁻¹b` from the log-parabola's μ
//!   (`Setup::line_peak_mu`).
//!
//! Accuracy: every step is `f64`; relative errors are ~1e-12, far below the core's `f32`.
//! Cost: ~30 ms per ColoRadar frame (128 × 128 × 12, a few targets) with the test profile's
//! opt-level 2, a few times the core's.

use std::f64::consts::PI;
use std::sync::Arc;

use dbe_radar::window::WindowKind;
use dbe_radar::Params;
use dbe_radar::{CfarKind, CfarParams, ElevationParams};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use crate::cloud::PointRecord;
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;

/// Speed of light in vacuum, m/s (defined here again so that no formula comes from the core).
const SPEED_OF_LIGHT: f64 = 299_792_458.0;

/// Two elevations closer than this (half-wavelength units) are the same row.
const SAME_POSITION: f64 = 1e-6;

/// Why the reference cannot process a frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReferenceError {
    /// A frame size does not match the sensor.
    #[error("frame has {found} {field}, the sensor configuration says {expected}")]
    FrameShape {
        /// The size that differs (`samples`, `loops`, `TX slots`, `RX channels`).
        field: &'static str,
        /// What the sensor says.
        expected: usize,
        /// What the frame holds.
        found: usize,
    },
    /// The frame's sample buffer has the wrong length.
    #[error("frame holds {found} samples, its sizes need {expected}")]
    FrameLength {
        /// `samples · loops · tx · rx`.
        expected: usize,
        /// `data.len()`.
        found: usize,
    },
    /// The sensor's antenna list does not match its TX/RX counts.
    #[error("sensor has {found} {field} positions for {expected} antennas")]
    SensorShape {
        /// `TX` or `RX`.
        field: &'static str,
        /// The antenna count.
        expected: usize,
        /// Positions given.
        found: usize,
    },
    /// The antenna geometry cannot be processed.
    #[error("antenna geometry: {0}")]
    Geometry(&'static str),
    /// A processing parameter is out of its valid range.
    #[error("parameter {name}: {reason}")]
    Parameter {
        /// The parameter.
        name: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The channel gain table does not have `tx · rx` finite, non-zero entries.
    #[error("channel gain calibration needs {expected} finite, non-zero values ([tx][rx]); it has {found} values")]
    ChannelGains {
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// The coupling table does not have `tx · rx · range_bins` entries or covers too many bins.
    #[error("coupling calibration has {found} values, expected {expected} ([tx][rx][range bin], at most the chirp's samples per table)")]
    Coupling {
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
}

/// One OS-CFAR detection of the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefDetection {
    /// Range bin.
    pub range_bin: usize,
    /// Azimuth grid bin (before any TDM refinement).
    pub azimuth_bin: usize,
    /// Range–azimuth power of the cell, linear.
    pub power: f64,
    /// CFAR noise level (the order statistic, before α), linear.
    pub level: f64,
    /// The smallest relative gap `|a − b| / max(|a|, |b|)` between two values compared by a
    /// discrete decision while resolving this detection into points (Doppler argmax, azimuth
    /// climb, elevation peak status, count and floor). A tiny value means that an `f32`
    /// implementation may legitimately decide otherwise; infinity when no decision was taken.
    pub decision_margin: f64,
}

/// Everything the reference computes for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceOutput {
    /// Range–azimuth map, `ra_map[range bin][azimuth bin]`, linear Capon power; zero outside
    /// the processed range window and on skipped range bins.
    pub ra_map: Vec<Vec<f64>>,
    /// Detections, in map order (range bin, then azimuth bin).
    pub detections: Vec<RefDetection>,
    /// Detections beyond the capacity (the weakest), not resolved.
    pub detection_overflow: usize,
    /// Range bins whose loaded azimuth covariance was not positive definite.
    pub skipped_range_bins: usize,
    /// Detections whose azimuth beam failed the Doppler test (`Params::doppler_test_db`).
    pub doppler_rejected: usize,
    /// `δ_b / D` per range bin: the lower bound of the loaded azimuth Capon spectrum (see
    /// [`CfarLevel::LoadingFloor`]); zero outside the processed window.
    pub loading_floor: Vec<f64>,
    /// Points, in detection order; per detection strongest elevation peak first.
    pub points: Vec<PointRecord>,
    /// The choices this output was computed with.
    pub options: ReferenceOptions,
    /// Radial velocity per Doppler bin, m/s (`λ / (2·K·T_loop)`).
    pub doppler_bin_mps: f64,
    /// Largest quantisation step `2^e` of any chirp under [`CubePrecision::BlockFloat16`]
    /// (0 for an exact cube): the resolution at which a quantised cube can be compared.
    pub cube_step_max: f64,
}

/// One element of the virtual array.
#[derive(Clone, Copy, Debug)]
struct Element {
    /// Azimuth position, half-wavelength units.
    az: f64,
    /// Elevation position, half-wavelength units.
    el: f64,
    /// TDM slot (= TX data index).
    slot: usize,
}

/// The virtual array in processing order: the azimuth line first (sorted by azimuth), then
/// the other elements (sorted by elevation, then azimuth).
#[derive(Clone, Debug)]
struct VirtualArray {
    elements: Vec<Element>,
    /// `row[t][r]`: processing row of virtual antenna `(t, r)`.
    row: Vec<Vec<usize>>,
    /// Elements on the azimuth line (rows `0..line`).
    line: usize,
    /// The 2 × E rectangle for coherent targets: `(line rows, elevation-row rows)` at the same
    /// azimuth positions, in position order; `None` unless the off-line elements are one
    /// uniform row of ≥ 3 elements, each above a line element.
    rectangle: Option<(Vec<usize>, Vec<usize>)>,
}

impl VirtualArray {
    fn new(sensor: &SensorConfig, need_uniform_line: bool) -> Result<Self, ReferenceError> {
        let mut all = Vec::with_capacity(sensor.num_tx * sensor.num_rx);
        for (t, &(ta, te)) in sensor.tx.iter().enumerate() {
            for (r, &(ra, re)) in sensor.rx.iter().enumerate() {
                let (az, el) = (f64::from(ta) + f64::from(ra), f64::from(te) + f64::from(re));
                if !(az.is_finite() && el.is_finite()) {
                    return Err(ReferenceError::Geometry("antenna position is not finite"));
                }
                all.push((Element { az, el, slot: t }, t, r));
            }
        }
        let Some(lowest) = all.iter().map(|e| e.0.el).reduce(f64::min) else {
            return Err(ReferenceError::Geometry("no antennas"));
        };
        let on_line = |e: &Element| (e.el - lowest).abs() < SAME_POSITION;
        let (mut line, mut rest): (Vec<_>, Vec<_>) = all.into_iter().partition(|e| on_line(&e.0));
        line.sort_by(|a, b| a.0.az.total_cmp(&b.0.az));
        rest.sort_by(|a, b| {
            (a.0.el, a.0.az)
                .partial_cmp(&(b.0.el, b.0.az))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        if line.len() < 2 {
            return Err(ReferenceError::Geometry(
                "the azimuth line needs at least 2 elements",
            ));
        }
        if need_uniform_line {
            let spacing = line[1].0.az - line[0].0.az;
            let uniform = spacing.abs() > 1e-3
                && line
                    .windows(2)
                    .all(|p| ((p[1].0.az - p[0].0.az) - spacing).abs() <= 1e-3);
            if !uniform {
                return Err(ReferenceError::Geometry(
                    "forward–backward averaging needs a uniformly spaced azimuth line",
                ));
            }
        }
        let line_len = line.len();
        let mut row = vec![vec![0; sensor.num_rx]; sensor.num_tx];
        let mut elements = Vec::with_capacity(line_len + rest.len());
        for (i, (e, t, r)) in line.into_iter().chain(rest).enumerate() {
            row[t][r] = i;
            elements.push(e);
        }
        let rectangle = Self::rectangle(&elements, line_len);
        Ok(Self {
            elements,
            row,
            line: line_len,
            rectangle,
        })
    }

    fn rectangle(elements: &[Element], line: usize) -> Option<(Vec<usize>, Vec<usize>)> {
        let same = |a: f64, b: f64| (a - b).abs() < SAME_POSITION;
        let mut upper: Vec<usize> = (line..elements.len()).collect();
        upper.sort_by(|&a, &b| elements[a].az.total_cmp(&elements[b].az));
        if upper.len() < 3 {
            return None;
        }
        let (p0, el0) = (elements[upper[0]].az, elements[upper[0]].el);
        let step = elements[upper[1]].az - p0;
        let mut below = Vec::with_capacity(upper.len());
        for (k, &u) in upper.iter().enumerate() {
            let e = &elements[u];
            if same(step, 0.0) || !same(e.az - p0, step * k as f64) || !same(e.el, el0) {
                return None;
            }
            below.push((0..line).find(|&l| same(elements[l].az, e.az))?);
        }
        Some((below, upper))
    }

    fn len(&self) -> usize {
        self.elements.len()
    }

    /// Height of the first off-line element above the line, half-wavelength units (0 without
    /// one): the `Δ` of the elevation phase `κ·Δ·ν` between the row and the line.
    fn row_offset(&self) -> f64 {
        match (self.elements.first(), self.elements.get(self.line)) {
            (Some(line), Some(row)) => row.el - line.el,
            _ => 0.0,
        }
    }
}

/// The contract's range step for one chirp of one channel (module docs, §3.0): subtract the
/// complex mean of `samples`, multiply by `window`, unnormalised FFT into `out` (all three the
/// chirp's length, and `fft` of that length).
pub fn range_spectrum(
    samples: &[[i16; 2]],
    window: &[f64],
    fft: &dyn rustfft::Fft<f64>,
    out: &mut [Complex64],
) {
    let n = samples.len().max(1);
    let mean = samples
        .iter()
        .map(|s| Complex64::new(f64::from(s[0]), f64::from(s[1])))
        .sum::<Complex64>()
        / n as f64;
    for ((o, s), w) in out.iter_mut().zip(samples).zip(window) {
        *o = (Complex64::new(f64::from(s[0]), f64::from(s[1])) - mean) * *w;
    }
    fft.process(out);
}

/// Symmetric window of length `n`: `w[k]` with period `n − 1` (as `numpy.blackman(n)`).
pub fn window(kind: WindowKind, n: usize) -> Vec<f64> {
    if n < 2 {
        return vec![1.0; n];
    }
    (0..n)
        .map(|k| {
            let x = 2.0 * PI * k as f64 / (n - 1) as f64;
            match kind {
                WindowKind::Rectangular => 1.0,
                WindowKind::Hann => 0.5 - 0.5 * x.cos(),
                WindowKind::Hamming => 0.54 - 0.46 * x.cos(),
                WindowKind::Blackman => 0.42 - 0.5 * x.cos() + 0.08 * (2.0 * x).cos(),
            }
        })
        .collect()
}

/// `sin` of the angle at (fractional) index `x` of `bins` angles spaced evenly over `span`
/// (degrees, both ends included).
fn grid_sine(span: (f32, f32), bins: usize, x: f64) -> f64 {
    let (a, b) = (f64::from(span.0), f64::from(span.1));
    (a + (b - a) * x / (bins - 1) as f64).to_radians().sin()
}

/// `sin` of every grid angle.
/// The bin of a `bins`-bin grid linear in degrees over `span` nearest to elevation `theta_deg`.
fn nearest_grid_bin(span: (f32, f32), bins: usize, theta_deg: f64) -> usize {
    let (a, b) = (f64::from(span.0), f64::from(span.1));
    let step = (b - a) / (bins.max(2) - 1) as f64;
    let j = ((theta_deg - a) / step).round();
    (j.max(0.0) as usize).min(bins.saturating_sub(1))
}

fn sine_grid(span: (f32, f32), bins: usize) -> Vec<f64> {
    (0..bins).map(|i| grid_sine(span, bins, i as f64)).collect()
}

/// Sub-grid peak position (`Params::subgrid`): the vertex of the parabola through
/// `(−1, ln l)`, `(0, ln c)`, `(1, ln r)`, in bins from the centre, clamped to `[−½, ½]`; 0
/// unless all three powers are positive, `c` is the largest and the parabola opens downwards.
pub(crate) fn log_parabola_vertex(l: f64, c: f64, r: f64) -> f64 {
    if !(l > 0.0 && c > 0.0 && r > 0.0) || c < l || c < r {
        return 0.0;
    }
    let (yl, yc, yr) = (l.ln(), c.ln(), r.ln());
    // y(x) = a·x² + s·x + yc.
    let a = (yl + yr) / 2.0 - yc;
    let s = (yr - yl) / 2.0;
    if a < 0.0 {
        (-s / (2.0 * a)).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// Sub-bin offset of a tone from the unwindowed `k`-point DFT's strongest bin `c` and its
/// neighbours `l`, `r`: Jacobsen's `Re[(l − r)/(2c − l − r)]` scaled by Candan's
/// `tan(π/k)/(π/k)`, clamped to `[−½, ½]`; 0 when `2c − l − r` is 0 or not finite.
pub(crate) fn candan_offset(l: Complex64, c: Complex64, r: Complex64, k: usize) -> f64 {
    let q = (l - r) / (2.0 * c - l - r);
    if !q.re.is_finite() {
        return 0.0;
    }
    let x = PI / k as f64;
    (q.re * x.tan() / x).clamp(-0.5, 0.5)
}

/// Relative gap of two compared values, `|a − b| / max(|a|, |b|)` (0 when both are 0).
pub(crate) fn relative_gap(a: f64, b: f64) -> f64 {
    let scale = a.abs().max(b.abs());
    if scale > 0.0 {
        (a - b).abs() / scale
    } else {
        0.0
    }
}

/// Tracks the smallest relative gap of the decisions taken.
#[derive(Clone, Copy, Debug)]
struct Margin(f64);

impl Margin {
    fn new() -> Self {
        Self(f64::INFINITY)
    }

    fn note(&mut self, a: f64, b: f64) {
        self.0 = self.0.min(relative_gap(a, b));
    }
}

/// The Capon solver of one loaded covariance.
struct Capon {
    chol: Cholesky<Complex64, Dyn>,
}

impl Capon {
    /// `None` when `r` is not positive definite.
    fn new(r: DMatrix<Complex64>) -> Option<Self> {
        Cholesky::new(r).map(|chol| Self { chol })
    }

    /// `(R⁻¹a, aᴴR⁻¹a)`.
    fn solve(&self, a: &DVector<Complex64>) -> (DVector<Complex64>, f64) {
        let x = self.chol.solve(a);
        let q = a.dotc(&x).re;
        (x, q)
    }

    /// `1 / Re(aᴴR⁻¹a)`.
    fn power(&self, a: &DVector<Complex64>) -> f64 {
        let (_, q) = self.solve(a);
        if q > 0.0 {
            1.0 / q
        } else {
            0.0
        }
    }

    /// `R⁻¹a / (aᴴR⁻¹a)`.
    fn weight(&self, a: &DVector<Complex64>) -> DVector<Complex64> {
        let (x, q) = self.solve(a);
        let scale = if q > 0.0 { 1.0 / q } else { 0.0 };
        x.map(|v| v * scale)
    }
}

/// `(R + J·R*·J) / 2`, `J` the exchange matrix.
fn forward_backward(r: &DMatrix<Complex64>) -> DMatrix<Complex64> {
    let d = r.nrows();
    DMatrix::from_fn(d, d, |i, j| {
        (r[(i, j)] + r[(d - 1 - i, d - 1 - j)].conj()) * 0.5
    })
}

/// `(R + δ·I, δ)`, `δ = γ·tr(R)/D`.
fn load(r: &DMatrix<Complex64>, gamma: f64) -> (DMatrix<Complex64>, f64) {
    let d = r.nrows();
    let trace: f64 = (0..d).map(|i| r[(i, i)].re).sum();
    let delta = gamma * trace / d as f64;
    let mut out = r.clone();
    for i in 0..d {
        out[(i, i)] += Complex64::new(delta, 0.0);
    }
    (out, delta)
}

/// Frame-independent quantities derived from the sensor and the parameters.
struct Setup {
    n: usize,
    k: usize,
    array: VirtualArray,
    kappa: f64,
    range_bin_m: f64,
    doppler_bin_mps: f64,
    /// Phase per TDM slot per m/s of radial velocity: `4π·Tc/λ`.
    slot_phase_per_mps: f64,
    az_mu: Vec<f64>,
    el_nu: Vec<f64>,
    range_window: Vec<f64>,
    doppler_window: Vec<f64>,
    /// The Doppler sub-bin estimator follows the window: Jacobsen–Candan under the
    /// rectangular one, the log-parabola under the others.
    doppler_rectangular: bool,
    range_fft: Arc<dyn Fft<f64>>,
    doppler_fft: Arc<dyn Fft<f64>>,
    first: usize,
    last: usize,
}

impl Setup {
    fn new(
        sensor: &SensorConfig,
        params: &Params,
        azimuth_bins: usize,
        elevation_bins: usize,
    ) -> Result<Self, ReferenceError> {
        if sensor.tx.len() != sensor.num_tx {
            return Err(ReferenceError::SensorShape {
                field: "TX",
                expected: sensor.num_tx,
                found: sensor.tx.len(),
            });
        }
        if sensor.rx.len() != sensor.num_rx {
            return Err(ReferenceError::SensorShape {
                field: "RX",
                expected: sensor.num_rx,
                found: sensor.rx.len(),
            });
        }
        check_params(sensor, params, azimuth_bins, elevation_bins)?;
        let array = VirtualArray::new(sensor, params.forward_backward)?;
        let (n, k) = (sensor.samples, sensor.loops);
        let w = &sensor.waveform;
        let fc = w.start_frequency_hz + w.slope_hz_per_s * (n as f64 / w.adc_sample_rate_hz) / 2.0;
        let lambda = SPEED_OF_LIGHT / fc;
        let tc = w.idle_time_s + w.ramp_end_time_s;
        let t_loop = sensor.num_tx as f64 * tc;
        let mut planner = FftPlanner::<f64>::new();
        Ok(Self {
            n,
            k,
            array,
            kappa: PI * fc / sensor.f_design_hz,
            range_bin_m: SPEED_OF_LIGHT * w.adc_sample_rate_hz
                / (2.0 * w.slope_hz_per_s * n as f64),
            doppler_bin_mps: lambda / (2.0 * k as f64 * t_loop),
            slot_phase_per_mps: 4.0 * PI * tc / lambda,
            az_mu: sine_grid(params.azimuth_span_deg, azimuth_bins),
            el_nu: sine_grid(params.elevation_span_deg, elevation_bins),
            range_window: window(params.range_window, n),
            doppler_window: window(params.doppler_window, k),
            doppler_rectangular: params.doppler_window == WindowKind::Rectangular,
            range_fft: planner.plan_fft_forward(n),
            doppler_fft: planner.plan_fft_forward(k),
            first: usize::from(params.range_first),
            last: usize::from(params.range_last),
        })
    }

    /// Steering vector of the first `rows` rows for direction cosines `(μ, ν)`.
    fn steering(&self, rows: usize, mu: f64, nu: f64) -> DVector<Complex64> {
        DVector::from_iterator(
            rows,
            self.array.elements[..rows]
                .iter()
                .map(|e| Complex64::from_polar(1.0, -self.kappa * (mu * e.az + nu * e.el))),
        )
    }

    /// The μ in `[lo, hi]` where the azimuth line's Capon spectrum of `az` (over its first
    /// `rows` elements) peaks near `start`: Newton's method on `q(μ) = bᴴR⁻¹b`,
    /// `b_m = exp(−j·κ·μ·az_m)`, with `q' = 2·Re(b'ᴴR⁻¹b)` and
    /// `q'' = 2·Re(b''ᴴR⁻¹b + b'ᴴR⁻¹b')` (`b' = −j·κ·az ⊙ b`, `b'' = −κ²·az² ⊙ b`);
    /// [`dbe_radar::capon::NEWTON_STEPS`] steps clamped to `[lo, hi]`, stopping where
    /// `q'' ≤ 0`. The core iterates in the line phase `κ·Δ·μ` on the diagonal sums of `R⁻¹`;
    /// Newton's iterates do not depend on that linear change of variable.
    fn line_peak_mu(&self, az: &Capon, rows: usize, start: f64, lo: f64, hi: f64) -> f64 {
        let pos: Vec<f64> = self.array.elements[..rows].iter().map(|e| e.az).collect();
        let mut mu = start.clamp(lo, hi);
        for _ in 0..dbe_radar::capon::NEWTON_STEPS {
            let b = self.steering(rows, mu, 0.0);
            let j = Complex64::new(0.0, 1.0);
            let db = DVector::from_iterator(
                rows,
                b.iter().zip(&pos).map(|(v, p)| -j * self.kappa * p * v),
            );
            let ddb = DVector::from_iterator(
                rows,
                b.iter()
                    .zip(&pos)
                    .map(|(v, p)| -(self.kappa * p).powi(2) * v),
            );
            let (x, _) = az.solve(&b);
            let (dx, _) = az.solve(&db);
            let d1 = 2.0 * db.dotc(&x).re;
            let d2 = 2.0 * (ddb.dotc(&x).re + db.dotc(&dx).re);
            if !(d2 > 0.0) {
                break;
            }
            let next = (mu - d1 / d2).clamp(lo, hi);
            if !next.is_finite() {
                break;
            }
            mu = next;
        }
        mu
    }

    /// Capon solver of the azimuth line's block of `r` (spatial smoothing over the two
    /// `D − 1`-element sub-lines and FB averaging if on, loading), the loading `δ` used and the
    /// number of line elements it spans.
    fn azimuth_capon(
        &self,
        r: &DMatrix<Complex64>,
        params: &Params,
    ) -> Option<(Capon, f64, usize)> {
        let d = self.array.line;
        let mut block = r.view((0, 0), (d, d)).into_owned();
        let mut rows = d;
        if params.spatial_smoothing {
            rows = d - 1;
            block = (r.view((0, 0), (rows, rows)) + r.view((1, 1), (rows, rows))).map(|v| v * 0.5);
        }
        if params.forward_backward {
            block = forward_backward(&block);
        }
        let (loaded, delta) = load(&block, f64::from(params.loading));
        Capon::new(loaded).map(|c| (c, delta, rows))
    }

    /// The FBSS covariance of the coherent-target rectangle (module [`dbe_radar::subarray`]'s
    /// contract): the mean over its two 2 × (E − 1) sub-rectangles `s` of
    /// `(R_s + J·R_s*·J) / 2`, `J` the point mirror of a sub-rectangle (line position `k` ↔
    /// elevation-row position `E − 2 − k`), loaded; and the rows of the first sub-rectangle.
    fn coherent_covariance(
        &self,
        r: &DMatrix<Complex64>,
        params: &Params,
    ) -> Option<(DMatrix<Complex64>, Vec<usize>)> {
        let (line, upper) = self.array.rectangle.as_ref()?;
        let w = line.len() - 1;
        let rows = |s: usize| -> Vec<usize> {
            line[s..s + w]
                .iter()
                .chain(&upper[s..s + w])
                .copied()
                .collect()
        };
        let mirror = |k: usize| {
            if k < w {
                w + (w - 1 - k)
            } else {
                w - 1 - (k - w)
            }
        };
        let n = 2 * w;
        let mut acc = DMatrix::<Complex64>::zeros(n, n);
        for s in 0..2 {
            let idx = rows(s);
            for k in 0..n {
                for l in 0..n {
                    acc[(k, l)] +=
                        (r[(idx[k], idx[l])] + r[(idx[mirror(k)], idx[mirror(l)])].conj()) * 0.25;
                }
            }
        }
        Some((load(&acc, f64::from(params.loading)).0, rows(0)))
    }

    /// Steering vector on the given rows for `(μ, ν)`.
    fn steering_on(&self, rows: &[usize], mu: f64, nu: f64) -> DVector<Complex64> {
        DVector::from_iterator(
            rows.len(),
            rows.iter().map(|&m| {
                let e = &self.array.elements[m];
                Complex64::from_polar(1.0, -self.kappa * (mu * e.az + nu * e.el))
            }),
        )
    }

    /// The ν in `[lo, hi]` where the elevation spectrum of `el` (on `rows`, at azimuth `mu`)
    /// peaks nearest to `near`. The array's elements lie on two elevation levels (0 and the
    /// elevation row's `Δ`), so `q(ν) = aᴴR⁻¹a` is `c₀ + 2·Re(c₁·e^{−jψ})` in `ψ = κ·Δ·ν`;
    /// `c₀`, `c₁` from `q` at `ψ = 0, π/2, π` (`q = c₀ + 2·Re c₁`, `c₀ + 2·Im c₁`,
    /// `c₀ − 2·Re c₁`), and `q` is smallest at `ψ = arg c₁ − π` (mod 2π). The core forms
    /// `c₀`, `c₁` from the line's and the row's parts of the steering vector instead.
    fn elevation_peak_nu(
        &self,
        el: &Capon,
        rows: &[usize],
        mu: f64,
        near: f64,
        (lo, hi): (f64, f64),
    ) -> f64 {
        let kd = self.kappa * self.array.row_offset();
        if kd == 0.0 {
            return near.clamp(lo, hi);
        }
        let q = |psi: f64| el.solve(&self.steering_on(rows, mu, psi / kd)).1;
        let (q0, q1, q2) = (q(0.0), q(PI / 2.0), q(PI));
        let c0 = (q0 + q2) / 2.0;
        let c1 = Complex64::new((q0 - q2) / 4.0, (q1 - c0) / 2.0);
        let psi = c1.arg() - PI;
        let nu = (psi + ((kd * near - psi) / (2.0 * PI)).round() * 2.0 * PI) / kd;
        if nu.is_finite() {
            nu.clamp(lo, hi)
        } else {
            near.clamp(lo, hi)
        }
    }

    /// The Doppler test (`Params::doppler_test_db`, beyond the spec) of a slow-time signal: the
    /// windowed spectrum's strongest power over its median (the ⌊K/2⌋-th smallest, 0-based)
    /// is at least the threshold; always true when the threshold is 0 or below.
    fn passes_doppler_test(&self, y: &[Complex64], params: &Params, margin: &mut Margin) -> bool {
        if !(params.doppler_test_db > 0.0) {
            return true;
        }
        let mut spectrum: Vec<Complex64> = y
            .iter()
            .zip(&self.doppler_window)
            .map(|(v, w)| v * w)
            .collect();
        self.doppler_fft.process(&mut spectrum);
        let mut power: Vec<f64> = spectrum.iter().map(|v| v.norm_sqr()).collect();
        let peak = power.iter().copied().fold(0.0, f64::max);
        power.sort_by(f64::total_cmp);
        let median = power[power.len() / 2];
        let ratio = if median > 0.0 {
            peak / median
        } else {
            f64::INFINITY
        };
        let min_ratio = 10f64.powf(f64::from(params.doppler_test_db) / 10.0);
        margin.note(ratio, min_ratio);
        ratio >= min_ratio
    }

    /// Window, FFT and the first strongest bin (signed) of a slow-time signal, with its
    /// sub-bin offset from its (circular) neighbours; notes the gap between the strongest and
    /// the runner-up.
    fn doppler(&self, mut y: Vec<Complex64>, margin: &mut Margin) -> (i32, f64) {
        for (v, w) in y.iter_mut().zip(&self.doppler_window) {
            *v *= *w;
        }
        self.doppler_fft.process(&mut y);
        let power: Vec<f64> = y.iter().map(|v| v.norm_sqr()).collect();
        let mut best = 0;
        for (d, &p) in power.iter().enumerate() {
            if p > power[best] {
                best = d;
            }
        }
        let runner_up = power
            .iter()
            .enumerate()
            .filter(|&(d, _)| d != best)
            .map(|(_, &p)| p)
            .fold(0.0, f64::max);
        margin.note(power[best], runner_up);
        let k = self.k;
        let (l, r) = ((best + k - 1) % k, (best + 1) % k);
        let offset = if self.doppler_rectangular {
            candan_offset(y[l], y[best], y[r], k)
        } else {
            log_parabola_vertex(power[l], power[best], power[r])
        };
        let signed = if best < k / 2 {
            best as i32
        } else {
            best as i32 - k as i32
        };
        (signed, offset)
    }
}

fn bad(name: &'static str, reason: &'static str) -> ReferenceError {
    ReferenceError::Parameter { name, reason }
}

fn check_params(
    sensor: &SensorConfig,
    params: &Params,
    azimuth_bins: usize,
    elevation_bins: usize,
) -> Result<(), ReferenceError> {
    if sensor.samples < 2 || sensor.loops < 2 || sensor.num_tx == 0 || sensor.num_rx == 0 {
        return Err(bad(
            "sensor sizes",
            "need ≥ 2 samples, ≥ 2 loops, ≥ 1 TX and RX",
        ));
    }
    let w = &sensor.waveform;
    let positive = [
        w.adc_sample_rate_hz,
        w.slope_hz_per_s,
        w.start_frequency_hz,
        w.ramp_end_time_s,
        sensor.f_design_hz,
    ];
    let idle_ok = w.idle_time_s.is_finite() && w.idle_time_s >= 0.0;
    if !(idle_ok && positive.iter().all(|v| v.is_finite() && *v > 0.0)) {
        return Err(bad("waveform", "values must be finite and positive"));
    }
    if params.range_first > params.range_last || usize::from(params.range_last) >= sensor.samples {
        return Err(bad(
            "range_first..=range_last",
            "must lie inside 0..samples",
        ));
    }
    if !(params.loading.is_finite() && params.loading > 0.0) {
        return Err(bad("loading", "must be finite and > 0"));
    }
    for (name, (a, b)) in [
        ("azimuth_span_deg", params.azimuth_span_deg),
        ("elevation_span_deg", params.elevation_span_deg),
    ] {
        if !(a.is_finite() && b.is_finite() && a < b && a > -90.0 && b < 90.0) {
            return Err(bad(name, "needs −90° < first < last < 90°"));
        }
    }
    if azimuth_bins < 3 || elevation_bins < 3 {
        return Err(bad("grid size", "needs at least 3 bins"));
    }
    let c: &CfarParams = &params.cfar;
    if let CfarKind::OrderStatistic { quantile: q } = c.kind {
        if !(q.is_finite() && q > 0.0 && q <= 1.0) {
            return Err(bad("cfar.quantile", "must be in (0, 1]"));
        }
    }
    if !c.threshold_db.is_finite() {
        return Err(bad("cfar.threshold_db", "must be finite"));
    }
    if !(c.window_gate_db.is_finite() && c.window_gate_db >= 0.0) {
        return Err(bad("cfar.window_gate_db", "must be finite and ≥ 0"));
    }
    if c.train_range == 0 && c.train_cross == 0 {
        return Err(bad("cfar training window", "must not be empty"));
    }
    if 2 * usize::from(c.edge_skip) + 1 > azimuth_bins {
        return Err(bad("cfar.edge_skip", "leaves no azimuth bin"));
    }
    let e: &ElevationParams = &params.elevation;
    if e.max_peaks == 0 || !(e.peak_range_db.is_finite() && e.peak_range_db >= 0.0) {
        return Err(bad(
            "elevation",
            "needs max_peaks ≥ 1 and a finite peak_range_db ≥ 0",
        ));
    }
    Ok(())
}

/// How the CFAR noise level of a cell is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CfarLevel {
    /// Spec §3.2 as written: the level is the order statistic of the training cells.
    #[default]
    OrderStatistic,
    /// The core's documented rule (`dbe_radar::cfar`): `level = max(order statistic,
    /// floor_b)` with `floor_b = δ_b / D` the lower bound of the loaded azimuth Capon
    /// spectrum of range bin `b` (`(R + δI)⁻¹ ≼ I/δ` gives `aᴴ(R + δI)⁻¹a ≤ D/δ`), so that
    /// the ripples of the loading ridge under a strong target are not detections. Not in
    /// spec §3.2.
    LoadingFloor,
}

/// Where the reference can follow either spec §3 literally or the core's documented
/// contract where the two differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ReferenceOptions {
    /// The CFAR level rule.
    pub cfar_level: CfarLevel,
    /// How range-FFT values are stored between ingestion and processing.
    pub cube: CubePrecision,
}

impl ReferenceOptions {
    /// Spec §3 as written, in full f64 precision.
    pub const SPEC: Self = Self {
        cfar_level: CfarLevel::OrderStatistic,
        cube: CubePrecision::Exact,
    };
    /// The core's contract (spec §3 plus the CFAR loading floor and the 16-bit block
    /// floating-point cube), as the harness uses it.
    pub const CORE_CONTRACT: Self = Self {
        cfar_level: CfarLevel::LoadingFloor,
        cube: CubePrecision::BlockFloat16,
    };
}

/// Storage precision of the range-FFT values (the radar cube).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CubePrecision {
    /// f64, as computed.
    #[default]
    Exact,
    /// As the core stores them: per chirp (one virtual antenna, one loop) a power-of-two step
    /// `2^e`, the smallest with `max(|re|, |im|) / 2^e ≤ 32767`, and each component rounded
    /// to the nearest multiple of it (ties to even), within ±32767 steps.
    BlockFloat16,
}

/// Quantise one chirp's range spectrum as [`CubePrecision::BlockFloat16`] describes;
/// returns the step (0 for an all-zero spectrum).
fn block_float16(spectrum: &mut [Complex64]) -> f64 {
    let peak = spectrum
        .iter()
        .map(|v| v.re.abs().max(v.im.abs()))
        .fold(0.0f64, f64::max);
    if !(peak > 0.0 && peak.is_finite()) {
        return 0.0;
    }
    // peak / 32767 = f · 2^e with f in [1/2, 1): e = floor(log2(peak / 32767)) + 1.
    let e = ((peak / 32767.0).log2().floor() as i32 + 1).clamp(-125, 125);
    let step = 2f64.powi(e);
    // Nearest step, ties to even (the core's FPU rounding), within ±32767 steps.
    let q = |x: f64| (x / step).round_ties_even().clamp(-32767.0, 32767.0) * step;
    for v in spectrum.iter_mut() {
        *v = Complex64::new(q(v.re), q(v.im));
    }
    step
}

/// How one map cell fares in the OS-CFAR test (see [`cfar_cell`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellTest {
    /// The `⌈q·n⌉`-th smallest training value; `None` when the window has no training cell.
    pub order_statistic: Option<f64>,
    /// The noise level: the order statistic, raised to the floor given to [`cfar_cell`].
    pub level: Option<f64>,
    /// `α · level` (infinite without a level).
    pub threshold: f64,
    /// The window gate: the strongest cell of the whole CFAR window (guard and training
    /// cells) over `10^(window_gate_db/10)`, which a detection must reach; 0 with the gate
    /// off.
    pub gate: f64,
    /// The cell is the maximum of its 3×3 neighbourhood (ties to the lower index).
    pub local_max: bool,
    /// Smallest relative change of a compared pair that would flip `local_max`.
    pub local_max_margin: f64,
}

impl CellTest {
    /// The cell is a detection: local maximum, positive, above the threshold.
    pub fn detects(&self, power: f64) -> bool {
        self.local_max && power > 0.0 && power > self.threshold && power >= self.gate
    }
}

/// Processed rows `first ..= last` of a map with `rows` rows.
fn processed_rows(params: &Params, rows: usize) -> (usize, usize) {
    let first = usize::from(params.range_first);
    let last = usize::from(params.range_last).min(rows.saturating_sub(1));
    (first, last)
}

/// Whether `(b, i)` is the maximum of its 3×3 neighbourhood inside rows `first..=last` (an
/// equal neighbour at a lower `(b, i)` wins), and the smallest relative change of a compared
/// pair that would flip the answer.
fn local_max(map: &[Vec<f64>], first: usize, last: usize, b: usize, i: usize) -> (bool, f64) {
    let naz = map[b].len();
    let cell = |rb: usize, ai: usize| map[rb][ai];
    let v = cell(b, i);
    let mut beaten_by = Vec::new();
    let mut holds_over = Vec::new();
    for rb in b.saturating_sub(1).max(first)..=(b + 1).min(last) {
        for ai in i.saturating_sub(1)..=(i + 1).min(naz - 1) {
            if (rb, ai) == (b, i) {
                continue;
            }
            let u = cell(rb, ai);
            let earlier = (rb, ai) < (b, i);
            if u > v || (earlier && u == v) {
                beaten_by.push(relative_gap(u, v));
            } else {
                holds_over.push(relative_gap(u, v));
            }
        }
    }
    if beaten_by.is_empty() {
        (true, holds_over.into_iter().fold(f64::INFINITY, f64::min))
    } else {
        // Every neighbour that wins must stop winning.
        (false, beaten_by.into_iter().fold(0.0, f64::max))
    }
}

/// The noise statistic of the training cells around `(b, i)`: the `⌈q·n⌉`-th smallest
/// (OS-CFAR) or their mean (CA-CFAR); `None` without training cells.
fn order_statistic(
    map: &[Vec<f64>],
    p: &CfarParams,
    first: usize,
    last: usize,
    b: usize,
    i: usize,
) -> Option<f64> {
    let naz = map[b].len();
    let (gr, ga) = (usize::from(p.guard_range), usize::from(p.guard_cross));
    let (wr, wa) = (
        gr + usize::from(p.train_range),
        ga + usize::from(p.train_cross),
    );
    let mut train = Vec::new();
    for (rb, row) in map
        .iter()
        .enumerate()
        .take(last.min(b + wr) + 1)
        .skip(first.max(b.saturating_sub(wr)))
    {
        for (ai, &v) in row
            .iter()
            .enumerate()
            .take((i + wa).min(naz - 1) + 1)
            .skip(i.saturating_sub(wa))
        {
            if rb.abs_diff(b) > gr || ai.abs_diff(i) > ga {
                train.push(v);
            }
        }
    }
    if train.is_empty() {
        return None;
    }
    let n = train.len();
    let quantile = match p.kind {
        CfarKind::OrderStatistic { quantile } => quantile,
        CfarKind::CellAveraging => return Some(train.iter().sum::<f64>() / n as f64),
    };
    train.sort_by(f64::total_cmp);
    // ⌈q·n⌉ with q as the decimal the user wrote: q arrives as f32, whose rounding (≤ 6e-8
    // relative) must not push an integral q·n to the next integer.
    let qn = f64::from(quantile) * n as f64;
    let k = ((qn - 1e-6 * qn.max(1.0)).ceil() as usize).clamp(1, n);
    Some(train[k - 1])
}

/// The strongest cell of the CFAR window around `(b, i)`: guard and training cells and the
/// cell itself, rows `first..=last`, columns truncated at the grid.
fn window_max(
    map: &[Vec<f64>],
    p: &CfarParams,
    first: usize,
    last: usize,
    b: usize,
    i: usize,
) -> f64 {
    let wr = usize::from(p.guard_range) + usize::from(p.train_range);
    let wa = usize::from(p.guard_cross) + usize::from(p.train_cross);
    let rows = first.max(b.saturating_sub(wr))..=last.min(b + wr);
    map.get(rows)
        .unwrap_or(&[])
        .iter()
        .flat_map(|row| {
            let cols = i.saturating_sub(wa)..=(i + wa).min(row.len().saturating_sub(1));
            row.get(cols).unwrap_or(&[]).iter().copied()
        })
        .fold(0.0, f64::max)
}

/// Evaluate the OS-CFAR rule of the module docs at cell `(b, i)` of `map` (rows
/// `params.range_first ..= range_last` processed), with the level raised to `floor` (pass 0
/// for spec §3.2 as written). Cells outside the processed rows or the grid give no level.
pub fn cfar_cell(map: &[Vec<f64>], params: &Params, b: usize, i: usize, floor: f64) -> CellTest {
    let (first, last) = processed_rows(params, map.len());
    if b < first || b > last || map.get(b).is_none_or(|row| i >= row.len()) {
        return CellTest {
            order_statistic: None,
            level: None,
            threshold: f64::INFINITY,
            gate: 0.0,
            local_max: false,
            local_max_margin: f64::INFINITY,
        };
    }
    let (is_max, local_max_margin) = local_max(map, first, last, b, i);
    let order = order_statistic(map, &params.cfar, first, last, b, i);
    let level = order.map(|o| o.max(floor));
    let alpha = 10f64.powf(f64::from(params.cfar.threshold_db) / 10.0);
    let gate_db = f64::from(params.cfar.window_gate_db);
    let gate = if gate_db > 0.0 {
        window_max(map, &params.cfar, first, last, b, i) / 10f64.powf(gate_db / 10.0)
    } else {
        0.0
    };
    CellTest {
        order_statistic: order,
        level,
        threshold: level.map_or(f64::INFINITY, |l| alpha * l),
        gate,
        local_max: is_max,
        local_max_margin,
    }
}

/// OS-CFAR over the whole map (module docs), levels raised to `floor[b]` when given; keeps
/// the `capacity` strongest (equal powers: the earlier in map order) in map order and returns
/// them with the number dropped.
pub fn detect(
    map: &[Vec<f64>],
    floor: Option<&[f64]>,
    params: &Params,
    capacity: usize,
) -> (Vec<RefDetection>, usize) {
    let (first, last) = processed_rows(params, map.len());
    let edge = usize::from(params.cfar.edge_skip);
    let mut found = Vec::new();
    for b in first..=last {
        let naz = map[b].len();
        for i in edge..naz.saturating_sub(edge) {
            let power = map[b][i];
            // Only positive local maxima can be detections: test them alone.
            if !(power > 0.0 && local_max(map, first, last, b, i).0) {
                continue;
            }
            let floor_b = floor.and_then(|f| f.get(b)).copied().unwrap_or(0.0);
            let test = cfar_cell(map, params, b, i, floor_b);
            if let (true, Some(level)) = (test.detects(power), test.level) {
                found.push(RefDetection {
                    range_bin: b,
                    azimuth_bin: i,
                    power,
                    level,
                    decision_margin: f64::INFINITY,
                });
            }
        }
    }
    let overflow = found.len().saturating_sub(capacity);
    if overflow > 0 {
        let mut by_power: Vec<usize> = (0..found.len()).collect();
        by_power.sort_by(|&a, &b| found[b].power.total_cmp(&found[a].power));
        let mut keep = vec![false; found.len()];
        for &i in by_power.iter().take(capacity) {
            keep[i] = true;
        }
        let mut it = keep.into_iter();
        found.retain(|_| it.next().unwrap_or(false));
    }
    (found, overflow)
}

/// Run the reference chain on one frame, spec §3 as written ([`ReferenceOptions::SPEC`]).
///
/// `azimuth_bins` / `elevation_bins` are the grid sizes (the core's compiled `NAZ` / `NEL`),
/// `detection_capacity` the most detections resolved per frame (the core's `DET`).
pub fn process_frame(
    frame: &AdcFrame,
    sensor: &SensorConfig,
    params: &Params,
    azimuth_bins: usize,
    elevation_bins: usize,
    detection_capacity: usize,
) -> Result<ReferenceOutput, ReferenceError> {
    process_frame_with(
        frame,
        sensor,
        params,
        azimuth_bins,
        elevation_bins,
        detection_capacity,
        &ReferenceOptions::SPEC,
    )
}

/// [`process_frame`] with the choices of `options`.
pub fn process_frame_with(
    frame: &AdcFrame,
    sensor: &SensorConfig,
    params: &Params,
    azimuth_bins: usize,
    elevation_bins: usize,
    detection_capacity: usize,
    options: &ReferenceOptions,
) -> Result<ReferenceOutput, ReferenceError> {
    for (field, expected, found) in [
        ("samples", sensor.samples, frame.samples),
        ("loops", sensor.loops, frame.loops),
        ("TX slots", sensor.num_tx, frame.tx),
        ("RX channels", sensor.num_rx, frame.rx),
    ] {
        if expected != found {
            return Err(ReferenceError::FrameShape {
                field,
                expected,
                found,
            });
        }
    }
    let expected = frame.samples * frame.loops * frame.tx * frame.rx;
    if frame.data.len() != expected {
        return Err(ReferenceError::FrameLength {
            expected,
            found: frame.data.len(),
        });
    }
    let setup = Setup::new(sensor, params, azimuth_bins, elevation_bins)?;
    let (cube, cube_step_max) = range_cube(frame, sensor, &setup, options.cube)?;

    // Stage 1: covariance and azimuth Capon per processed range bin.
    let mut ra_map = vec![vec![0.0; azimuth_bins]; setup.n];
    let mut covariances: Vec<Option<DMatrix<Complex64>>> = vec![None; setup.n];
    let mut loading_floor = vec![0.0; setup.n];
    let mut skipped_range_bins = 0;
    for b in setup.first..=setup.last {
        let x = &cube[b];
        let r = (x * x.adjoint()).map(|v| v / setup.k as f64);
        match setup.azimuth_capon(&r, params) {
            Some((capon, delta, rows)) => {
                loading_floor[b] = delta / rows as f64;
                for (p, &mu) in ra_map[b].iter_mut().zip(&setup.az_mu) {
                    *p = capon.power(&setup.steering(rows, mu, 0.0));
                }
            }
            None => skipped_range_bins += 1,
        }
        covariances[b] = Some(r);
    }

    // Stage 2: OS-CFAR.
    let floor = match options.cfar_level {
        CfarLevel::OrderStatistic => None,
        CfarLevel::LoadingFloor => Some(loading_floor.as_slice()),
    };
    let (mut found, detection_overflow) = detect(&ra_map, floor, params, detection_capacity);

    // Stages 3–5.
    // The Doppler of every detection's azimuth beam (TDM compensation and the coherence test).
    let need_doppler = params.tdm_compensation
        || params.coherent_doppler_bins > 0.0
        || params.doppler_agreement_bins > 0.0
        || params.doppler_test_db > 0.0;
    let mut margins = vec![Margin::new(); found.len()];
    let beams: Vec<Option<BeamDoppler>> = found
        .iter()
        .zip(margins.iter_mut())
        .map(|(det, margin)| {
            let r = covariances.get(det.range_bin)?.as_ref()?;
            let x = cube.get(det.range_bin)?;
            need_doppler
                .then(|| beam_doppler(&setup, params, r, x, det.azimuth_bin, margin))
                .flatten()
        })
        .collect();
    let mut doppler_rejected = 0;
    let bins: Vec<Option<f64>> = beams
        .iter()
        .map(|b| match b {
            Some(BeamDoppler::Bins(d)) => Some(*d),
            _ => None,
        })
        .collect();
    let mut points = Vec::new();
    let mut start = 0;
    while start < found.len() {
        let bin = found[start].range_bin;
        let end = start
            + found[start..]
                .iter()
                .take_while(|d| d.range_bin == bin)
                .count();
        for n in start..end {
            if beams[n] == Some(BeamDoppler::Rejected) {
                doppler_rejected += 1;
                continue;
            }
            let coherent = coherent(
                &setup,
                params,
                &bins[start..end],
                n - start,
                &mut margins[n],
            );
            let det = found[n];
            let (Some(Some(r)), Some(x)) = (covariances.get(bin), cube.get(bin)) else {
                continue;
            };
            let split_on = params.coherent_split && params.coherent_doppler_bins > 0.0;
            let split = match (split_on, coherent, bins[n]) {
                (true, false, Some(d)) if setup.array.rectangle.is_some() => {
                    split_line(&setup, params, r, d, &mut margins[n])
                }
                _ => None,
            };
            let targets: Vec<(RefDetection, bool, Option<f64>)> = match split {
                Some(mus) => mus
                    .iter()
                    .map(|&mu| {
                        let deg = mu.clamp(-1.0, 1.0).asin().to_degrees();
                        let column =
                            nearest_grid_bin(params.azimuth_span_deg, setup.az_mu.len(), deg);
                        let d = RefDetection {
                            azimuth_bin: column,
                            ..det
                        };
                        (d, true, Some(mu))
                    })
                    .collect(),
                None => vec![(det, coherent, None)],
            };
            for (det, coherent, at_mu) in targets {
                let beam = Beam {
                    doppler: bins[n],
                    coherent,
                    at_mu,
                };
                resolve(
                    &setup,
                    params,
                    &det,
                    beam,
                    x,
                    r,
                    &ra_map,
                    &mut margins[n],
                    &mut points,
                );
            }
        }
        start = end;
    }
    if params.joint_elevation && setup.array.line < setup.array.len() {
        joint_elevations(
            &setup,
            params,
            &covariances,
            &found,
            &mut margins,
            &mut points,
        );
    }
    for (det, margin) in found.iter_mut().zip(margins) {
        det.decision_margin = margin.0;
    }
    // The range bias (`SensorConfig::range_bias_m`, TI's): every point moves along its
    // direction; one it would carry through the radar is dropped (the core's
    // `PointCloud::subtract_range_bias`).
    let bias = sensor.range_bias_m;
    if bias != 0.0 && bias.is_finite() {
        points.retain_mut(|p| {
            let r = (p.x * p.x + p.y * p.y + p.z * p.z).sqrt();
            let keep = r - bias > 0.0;
            if keep {
                let s = (r - bias) / r;
                (p.x, p.y, p.z) = (p.x * s, p.y * s, p.z * s);
            }
            keep
        });
    }
    Ok(ReferenceOutput {
        ra_map,
        detections: found,
        detection_overflow,
        skipped_range_bins,
        doppler_rejected,
        loading_floor,
        points,
        options: *options,
        doppler_bin_mps: setup.doppler_bin_mps,
        cube_step_max,
    })
}

/// Range FFT of every chirp: `cube[range bin]` is the `M × K` snapshot matrix (rows in
/// [`VirtualArray`] order), and the largest quantisation step used (0 when exact).
fn range_cube(
    frame: &AdcFrame,
    sensor: &SensorConfig,
    setup: &Setup,
    precision: CubePrecision,
) -> Result<(Vec<DMatrix<Complex64>>, f64), ReferenceError> {
    let (n, k) = (setup.n, setup.k);
    let coupling = match &sensor.coupling {
        Some(c) => {
            let expected = sensor.num_tx * sensor.num_rx * c.range_bins;
            if c.data.len() != expected || c.range_bins > n {
                return Err(ReferenceError::Coupling {
                    expected,
                    found: c.data.len(),
                });
            }
            Some(c)
        }
        None => None,
    };
    let gains = match &sensor.channel_gains {
        Some(g) => {
            let expected = sensor.num_tx * sensor.num_rx;
            let valid = |v: &num_complex::Complex32| {
                v.re.is_finite() && v.im.is_finite() && v.norm_sqr() > 0.0
            };
            if g.len() != expected || !g.iter().all(valid) {
                return Err(ReferenceError::ChannelGains {
                    expected,
                    found: g.len(),
                });
            }
            Some(g)
        }
        None => None,
    };
    let m = setup.array.len();
    let mut cube = vec![DMatrix::<Complex64>::zeros(m, k); n];
    let mut buf = vec![Complex64::new(0.0, 0.0); n];
    let mut step_max = 0.0f64;
    for kk in 0..k {
        for t in 0..sensor.num_tx {
            for r in 0..sensor.num_rx {
                let start = frame.index(kk, t, r, 0);
                range_spectrum(
                    &frame.data[start..start + n],
                    &setup.range_window,
                    setup.range_fft.as_ref(),
                    &mut buf,
                );
                if let Some(c) = coupling {
                    let table = &c.data[(t * sensor.num_rx + r) * c.range_bins..][..c.range_bins];
                    for (v, cv) in buf.iter_mut().zip(table) {
                        *v -= Complex64::new(f64::from(cv.re), f64::from(cv.im));
                    }
                }
                if let Some(g) = gains {
                    let g = g[t * sensor.num_rx + r];
                    let g = Complex64::new(f64::from(g.re), f64::from(g.im));
                    for v in buf.iter_mut() {
                        *v *= g;
                    }
                }
                if precision == CubePrecision::BlockFloat16 {
                    step_max = step_max.max(block_float16(&mut buf));
                }
                let row = setup.array.row[t][r];
                for (b, v) in buf.iter().enumerate() {
                    cube[b][(row, kk)] = *v;
                }
            }
        }
    }
    Ok((cube, step_max))
}

/// `y_k = Σ_m conj(w_m) · rot_m · x_m[k]` over the first `w.len()` rows.
fn beamform(w: &DVector<Complex64>, rot: &[Complex64], x: &DMatrix<Complex64>) -> Vec<Complex64> {
    (0..x.ncols())
        .map(|k| (0..w.len()).map(|m| w[m].conj() * rot[m] * x[(m, k)]).sum())
        .collect()
}

/// The Doppler (bins plus the sub-bin offset) of the azimuth Capon beam of bin `i` on the
/// uncompensated covariance, or `Rejected` when the Doppler test is on and the azimuth beam
/// after TDM compensation by that Doppler (and the climb) fails it; `None` when the azimuth
/// covariance is not positive definite. (A compensated covariance that is not positive
/// definite passes the test: it rejects only what it measured.)
fn beam_doppler(
    setup: &Setup,
    params: &Params,
    r: &DMatrix<Complex64>,
    x: &DMatrix<Complex64>,
    i: usize,
    margin: &mut Margin,
) -> Option<BeamDoppler> {
    let (az, _, rows) = setup.azimuth_capon(r, params)?;
    let w = az.weight(&setup.steering(rows, *setup.az_mu.get(i)?, 0.0));
    let y = beamform(&w, &vec![Complex64::new(1.0, 0.0); rows], x);
    let (d, offset) = setup.doppler(y, margin);
    let d = f64::from(d) + offset;
    if params.doppler_test_db > 0.0 {
        let c = match params.tdm_compensation {
            true => compensate(setup, params, r, d, i, margin),
            false => Compensation {
                rotation: vec![Complex64::new(1.0, 0.0); setup.array.len()],
                covariance: r.clone(),
                azimuth_bin: i,
                azimuth_frac: None,
            },
        };
        if let Some((az, _, rows)) = setup.azimuth_capon(&c.covariance, params) {
            let w = az.weight(&setup.steering(rows, setup.az_mu[c.azimuth_bin], 0.0));
            let y = beamform(&w, &c.rotation[..rows], x);
            if !setup.passes_doppler_test(&y, params, margin) {
                return Some(BeamDoppler::Rejected);
            }
        }
    }
    Some(BeamDoppler::Bins(d))
}

/// TDM compensation of one detection at azimuth bin `i` whose beam Doppler is `d` bins.
struct Compensation {
    /// `exp(−j·4π·v·slot_m·Tc/λ)` per row.
    rotation: Vec<Complex64>,
    /// `D·R·Dᴴ`.
    covariance: DMatrix<Complex64>,
    /// The azimuth bin after the climb on the compensated spectrum.
    azimuth_bin: usize,
    /// The log-parabola offset there (`None`: the compensated line was not positive definite).
    azimuth_frac: Option<f64>,
}

/// The rotation `exp(−j·4π·v·slot_m·Tc/λ)` of every row for a Doppler of `d` bins, and
/// `D·r·Dᴴ`: slot t fires t·Tc after the loop start, so its Doppler phase is 4π·v·t·Tc/λ ahead.
fn rotate(setup: &Setup, r: &DMatrix<Complex64>, d: f64) -> (Vec<Complex64>, DMatrix<Complex64>) {
    let v = d * setup.doppler_bin_mps;
    let rotation: Vec<Complex64> = setup
        .array
        .elements
        .iter()
        .map(|e| Complex64::from_polar(1.0, -setup.slot_phase_per_mps * v * e.slot as f64))
        .collect();
    let dm = DMatrix::from_diagonal(&DVector::from_column_slice(&rotation));
    let covariance = &dm * r * dm.adjoint();
    (rotation, covariance)
}

/// Rotate every row by its slot's Doppler phase and climb the compensated azimuth spectrum
/// uphill from bin `i`, at most `tdm_azimuth_search` bins (left when `left > here` and
/// `left ≥ right`, else right when `right > here`).
fn compensate(
    setup: &Setup,
    params: &Params,
    r: &DMatrix<Complex64>,
    d: f64,
    mut i: usize,
    margin: &mut Margin,
) -> Compensation {
    let naz = setup.az_mu.len();
    let (rotation, covariance) = rotate(setup, r, d);
    let mut azimuth_frac = None;
    if let Some((az, _, rows)) = setup.azimuth_capon(&covariance, params) {
        let power = |i: usize| az.power(&setup.steering(rows, setup.az_mu[i], 0.0));
        let mut here = power(i);
        for _ in 0..params.tdm_azimuth_search {
            let left = if i > 0 { power(i - 1) } else { 0.0 };
            let right = if i + 1 < naz { power(i + 1) } else { 0.0 };
            if left > here && left >= right {
                margin.note(left, here);
                margin.note(left, right);
                i -= 1;
                here = left;
            } else if right > here {
                margin.note(right, here);
                if left > here {
                    margin.note(left, right);
                }
                i += 1;
                here = right;
            } else {
                margin.note(left, here);
                margin.note(right, here);
                break;
            }
        }
        let edge = |i: Option<usize>| i.filter(|&i| i < naz).map_or(0.0, power);
        azimuth_frac = Some(log_parabola_vertex(
            edge(i.checked_sub(1)),
            power(i),
            edge(Some(i + 1)),
        ));
    }
    Compensation {
        rotation,
        covariance,
        azimuth_bin: i,
        azimuth_frac,
    }
}

/// The circular distance of two Dopplers, bins (modulo `K`).
fn doppler_gap(setup: &Setup, a: f64, b: f64) -> f64 {
    let k = setup.k as f64;
    let gap = (a - b).abs() % k;
    gap.min(k - gap)
}

/// The beam Doppler of one detection.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BeamDoppler {
    /// Bins, with the sub-bin offset.
    Bins(f64),
    /// The beam failed the Doppler test: the detection gives no point.
    Rejected,
}

/// Whether detection `n` of a range bin's run shares its beam Doppler with another of the run
/// (circular distance below `coherent_doppler_bins`) and the array has the rectangle.
fn coherent(
    setup: &Setup,
    params: &Params,
    beams: &[Option<f64>],
    n: usize,
    margin: &mut Margin,
) -> bool {
    let window = f64::from(params.coherent_doppler_bins);
    let (Some(Some(mine)), true, true) =
        (beams.get(n), setup.array.rectangle.is_some(), window > 0.0)
    else {
        return false;
    };
    let mut any = false;
    for (m, d) in beams.iter().enumerate() {
        if let (true, Some(d)) = (m != n, d) {
            let gap = doppler_gap(setup, *d, *mine);
            margin.note(gap, window);
            any |= gap < window;
        }
    }
    any
}

/// What the pre-pass measured for one detection.
#[derive(Clone, Copy, Debug)]
struct Beam {
    /// Doppler of its azimuth beam, bins (`None`: not measured or not positive definite).
    doppler: Option<f64>,
    /// Resolved on the coherent-target rectangle.
    coherent: bool,
    /// The fitted azimuth of a split detection (`Params::coherent_split`): no climb, and the
    /// point's μ with sub-grid refinement.
    at_mu: Option<f64>,
}

/// Beyond the spec, `Params::coherent_split` (core module [`dbe_radar::split`]): the line
/// block of the bin's covariance rotated by the beam Doppler `d` (under TDM compensation);
/// its eigen decomposition; when `λ₂/λ₁` is below the core's ratio, forward–backward linear
/// prediction of order 2 on the principal eigenvector (least squares by SVD here), the
/// roots `z₁, z₂`, amplitudes by least squares, and the split's acceptance rules; the
/// direction cosines `μ = −arg z / (κ·Δaz)`.
fn split_line(
    setup: &Setup,
    params: &Params,
    r: &DMatrix<Complex64>,
    d: f64,
    margin: &mut Margin,
) -> Option<[f64; 2]> {
    use dbe_radar::split::{AMPLITUDE_RATIO, RANK_RATIO, RESIDUAL_RATIO, ROOT_TOLERANCE};
    let line = setup.array.line;
    let elements = &setup.array.elements;
    if line < 4 {
        return None;
    }
    let k = setup.kappa * (elements[1].az - elements[0].az);
    let r = match params.tdm_compensation {
        true => rotate(setup, r, d).1,
        false => r.clone(),
    };
    let block = r.view((0, 0), (line, line)).into_owned();
    let eigen = nalgebra::SymmetricEigen::new(block);
    let mut order: Vec<usize> = (0..line).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    let (l1, l2) = (eigen.eigenvalues[order[0]], eigen.eigenvalues[order[1]]);
    margin.note(l2, f64::from(RANK_RATIO) * l1);
    if !(l1 > 0.0 && l2 < f64::from(RANK_RATIO) * l1) {
        return None;
    }
    let v: Vec<Complex64> = eigen
        .eigenvectors
        .column(order[0])
        .iter()
        .copied()
        .collect();
    // v[m+2] = a·v[m+1] + b·v[m], forwards and on the reversed conjugate.
    let back: Vec<Complex64> = v.iter().rev().map(|x| x.conj()).collect();
    let rows = 2 * (line - 2);
    let mut a_mat = DMatrix::<Complex64>::zeros(rows, 2);
    let mut rhs = DVector::<Complex64>::zeros(rows);
    for (block, x) in [&v, &back].iter().enumerate() {
        for m in 0..line - 2 {
            let row = block * (line - 2) + m;
            a_mat[(row, 0)] = x[m + 1];
            a_mat[(row, 1)] = x[m];
            rhs[row] = x[m + 2];
        }
    }
    let c = a_mat.svd(true, true).solve(&rhs, 1e-12).ok()?;
    let disc = (c[0] * c[0] + c[1] * 4.0).sqrt();
    let z = [(c[0] + disc) / 2.0, (c[0] - disc) / 2.0];
    for zi in &z {
        margin.note((zi.norm() - 1.0).abs(), f64::from(ROOT_TOLERANCE));
    }
    if z.iter()
        .any(|zi| !((zi.norm() - 1.0).abs() <= f64::from(ROOT_TOLERANCE)))
    {
        return None;
    }
    let e = DMatrix::from_fn(line, 2, |m, i| z[i].powi(m as i32));
    let vv = DVector::from_column_slice(&v);
    let amp = e.clone().svd(true, true).solve(&vv, 1e-12).ok()?;
    let two = (&vv - &e * &amp).norm_squared();
    let step: Complex64 = (1..line).map(|m| v[m] * v[m - 1].conj()).sum();
    if !(step.norm() > 0.0) {
        return None;
    }
    let z1 = step / step.norm();
    let p1 = DVector::from_fn(line, |m, _| z1.powi(m as i32));
    let c1 = p1.dotc(&vv) / line as f64;
    let one = (&vv - &p1 * c1).norm_squared();
    let (ca, cb) = (amp[0].norm(), amp[1].norm());
    margin.note(two, f64::from(RESIDUAL_RATIO) * one);
    margin.note(ca.min(cb), f64::from(AMPLITUDE_RATIO) * ca.max(cb));
    if !(two < f64::from(RESIDUAL_RATIO) * one
        && ca.min(cb) >= f64::from(AMPLITUDE_RATIO) * ca.max(cb))
    {
        return None;
    }
    let mu = z.map(|zi| -zi.arg() / k);
    mu.iter()
        .all(|m| m.is_finite() && m.abs() < 1.0)
        .then_some(mu)
}

/// TDM compensation, elevation sweep and Doppler of one detection; pushes its points.
#[allow(clippy::too_many_arguments)] // one call site; the stages' inputs, spelled out
fn resolve(
    setup: &Setup,
    params: &Params,
    det: &RefDetection,
    beam: Beam,
    x: &DMatrix<Complex64>,
    r: &DMatrix<Complex64>,
    ra: &[Vec<f64>],
    margin: &mut Margin,
    points: &mut Vec<PointRecord>,
) {
    let m = setup.array.len();
    let naz = setup.az_mu.len();
    let b = det.range_bin;
    let mut i = det.azimuth_bin;
    // Sub-grid offsets (used when `params.subgrid`): range along the RA map's column of the
    // detection, azimuth along its row (replaced by the compensated spectrum's under TDM).
    let ra_at = |row: Option<usize>, col: Option<usize>| -> f64 {
        match (row, col) {
            (Some(rb), Some(ai)) => ra.get(rb).and_then(|r| r.get(ai)).copied().unwrap_or(0.0),
            _ => 0.0,
        }
    };
    let range_frac = log_parabola_vertex(
        ra_at(b.checked_sub(1), Some(i)),
        ra_at(Some(b), Some(i)),
        ra_at(Some(b + 1), Some(i)),
    );
    let mut az_frac = log_parabola_vertex(
        ra_at(Some(b), i.checked_sub(1)),
        ra_at(Some(b), Some(i)),
        ra_at(Some(b), Some(i + 1)),
    );
    let mut rot = vec![Complex64::new(1.0, 0.0); m];
    let mut r = r.clone();

    if params.tdm_compensation {
        // The fractional Doppler (strongest bin plus its sub-bin offset), as the core.
        let Some(d) = beam.doppler else {
            return;
        };
        let c = compensate(setup, params, &r, d, i, margin);
        (rot, r) = (c.rotation, c.covariance);
        // A split detection keeps its fitted azimuth (the climb would lead it back to the
        // merged peak).
        if beam.at_mu.is_none() {
            i = c.azimuth_bin;
            az_frac = c.azimuth_frac.unwrap_or(az_frac);
        }
    }

    // Stage 3: elevation sweep on the full array, no forward–backward averaging; coherent
    // targets on the rectangle's FBSS covariance.
    let all: Vec<usize> = (0..m).collect();
    let line_only = setup.array.line == m;
    let (cov, rows) = match beam.coherent {
        true => match setup.coherent_covariance(&r, params) {
            Some(c) => c,
            None => return,
        },
        // An array without an elevation row is its azimuth line: FB-averaged as on the map.
        false if line_only && params.forward_backward => (
            load(&forward_backward(&r), f64::from(params.loading)).0,
            all,
        ),
        false => (load(&r, f64::from(params.loading)).0, all),
    };
    let Some(el) = Capon::new(cov) else {
        return;
    };
    let mu = setup.az_mu[i];
    let spectrum: Vec<f64> = setup
        .el_nu
        .iter()
        .map(|&nu| el.power(&setup.steering_on(&rows, mu, nu)))
        .collect();
    // Without an elevation row: one direction, ν = 0, labelled with the grid bin nearest it.
    let peaks = match line_only {
        true => {
            let j = nearest_grid_bin(params.elevation_span_deg, spectrum.len(), 0.0);
            vec![(j, spectrum[j])]
        }
        false => elevation_peaks(&spectrum, &params.elevation, margin),
    };

    // Stages 4–5. The sweep and the weights use the grid direction; with sub-grid refinement
    // the point's coordinates use the refined one.
    let (mu_point, range) = if params.subgrid {
        let span = params.azimuth_span_deg;
        let start = grid_sine(span, naz, i as f64 + az_frac);
        // A split detection keeps its fitted azimuth.
        let line = || match setup.azimuth_capon(&r, params) {
            Some((az, _, rows)) if rows > 1 => {
                let (lo, hi) = (
                    grid_sine(span, naz, i as f64 - 0.5),
                    grid_sine(span, naz, i as f64 + 0.5),
                );
                setup.line_peak_mu(&az, rows, start, lo.min(hi), lo.max(hi))
            }
            _ => start,
        };
        let mu = beam.at_mu.unwrap_or_else(line);
        (mu, (b as f64 + range_frac) * setup.range_bin_m)
    } else {
        (mu, b as f64 * setup.range_bin_m)
    };
    let snr_db = if det.power > 0.0 && det.level > 0.0 {
        10.0 * (det.power / det.level).log10()
    } else {
        0.0
    };
    let nel = setup.el_nu.len();
    for (j, power) in peaks {
        let nu = if line_only { 0.0 } else { setup.el_nu[j] };
        let nu_point = if line_only {
            0.0
        } else if params.subgrid {
            let span = params.elevation_span_deg;
            let (lo, hi) = (
                grid_sine(span, nel, j as f64 - 0.5),
                grid_sine(span, nel, j as f64 + 0.5),
            );
            setup.elevation_peak_nu(&el, &rows, mu, nu, (lo.min(hi), lo.max(hi)))
        } else {
            nu
        };
        let cos2 = 1.0 - mu_point * mu_point - nu_point * nu_point;
        margin.note(mu_point * mu_point + nu_point * nu_point, 1.0);
        if cos2 <= 0.0 {
            continue;
        }
        let w_rows = el.weight(&setup.steering_on(&rows, mu, nu));
        let mut w = DVector::<Complex64>::zeros(m);
        for (&row, v) in rows.iter().zip(w_rows.iter()) {
            w[row] = *v;
        }
        let (d, d_frac) = setup.doppler(beamform(&w, &rot, x), margin);
        // Doppler agreement (beyond the spec): the point's beam shows its detection's tone.
        let window = f64::from(params.doppler_agreement_bins);
        if let (Some(beam_d), true) = (beam.doppler, window > 0.0) {
            let gap = doppler_gap(setup, f64::from(d) + d_frac, beam_d);
            margin.note(gap, window);
            if gap > window {
                continue;
            }
        }
        let doppler_bins = if params.subgrid {
            f64::from(d) + d_frac
        } else {
            f64::from(d)
        };
        // One point, or the two of a vertical surface's range ring.
        let half = match params.ring_split && !line_only && !beam.coherent {
            true => ring_half(setup, x, &rot, f64::from(d) + d_frac, mu_point, margin),
            false => None,
        };
        let nus = match half {
            Some(h) => vec![-h, h],
            None => vec![nu_point],
        };
        for nu_point in nus {
            let cos2 = 1.0 - mu_point * mu_point - nu_point * nu_point;
            margin.note(mu_point * mu_point + nu_point * nu_point, 1.0);
            if cos2 <= 0.0 {
                continue;
            }
            let elevation_bin = match half {
                Some(_) => nearest_grid_bin(
                    params.elevation_span_deg,
                    nel,
                    nu_point.clamp(-1.0, 1.0).asin().to_degrees(),
                ),
                None => j,
            };
            points.push(PointRecord {
                x: range * cos2.sqrt(),
                y: -range * mu_point,
                z: range * nu_point,
                doppler: doppler_bins * setup.doppler_bin_mps,
                intensity_db: 10.0 * power.max(f64::MIN_POSITIVE).log10(),
                snr_db,
                range_bin: det.range_bin as u32,
                azimuth_bin: i as u32,
                elevation_bin: elevation_bin as u32,
                doppler_bin: d,
            });
        }
    }
}

/// Beyond the spec, `Params::ring_split` (core module [`dbe_radar::ring`]): every antenna's
/// slow time, rotated by the TDM compensation `rot`, windowed and transformed at the point's
/// fractional Doppler `doppler` (bins), de-steered to its azimuth `mu`; `c` = the elevation
/// row's mean over the line's; a ring pair when `|c| ≤ ring::MAX_RATIO`,
/// `1 − |c| ≥ ring::SIGMAS·σ_c` and `|arg c| ≤ ring::HORIZON_PHASE`, with half-separation
/// `acos(Re c) / (κ·Δ)` in `ν` about the horizon. Notes the margin of each of the three tests.
fn ring_half(
    setup: &Setup,
    x: &DMatrix<Complex64>,
    rot: &[Complex64],
    doppler: f64,
    mu: f64,
    margin: &mut Margin,
) -> Option<f64> {
    use dbe_radar::ring::{HORIZON_PHASE, MAX_RATIO, SIGMAS};
    let (line, m, k) = (setup.array.line, setup.array.len(), setup.k);
    if line < 2 || m < line + 2 {
        return None;
    }
    let t: Vec<Complex64> = (0..m)
        .map(|row| {
            let z: Complex64 = (0..k)
                .map(|n| {
                    let ph = -2.0 * PI * doppler * n as f64 / k as f64;
                    x[(row, n)] * setup.doppler_window[n] * Complex64::from_polar(1.0, ph)
                })
                .sum();
            let e = &setup.array.elements[row];
            z * rot[row] * Complex64::from_polar(1.0, setup.kappa * mu * e.az)
        })
        .collect();
    let (l, r) = t.split_at(line);
    let mean = |v: &[Complex64]| v.iter().sum::<Complex64>() / v.len() as f64;
    let (a, e) = (mean(l), mean(r));
    let spread = |v: &[Complex64], c: Complex64| v.iter().map(|x| (x - c).norm_sqr()).sum::<f64>();
    let noise = (spread(l, a) + spread(r, e)) / (m - 2) as f64;
    if !(a.norm_sqr() > 0.0) {
        return None;
    }
    let c = e / a;
    let size = c.norm();
    let sigma =
        (noise * (1.0 / r.len() as f64 + size * size / l.len() as f64) / a.norm_sqr()).sqrt();
    let horizon = c.arg().abs();
    let (max, sigmas, horizon_max) = (
        f64::from(MAX_RATIO),
        f64::from(SIGMAS),
        f64::from(HORIZON_PHASE),
    );
    margin.note(size, max);
    margin.note(1.0 - size, sigmas * sigma);
    margin.note(horizon, horizon_max);
    let kd = (setup.kappa * setup.array.row_offset()).abs();
    let accept = size <= max && 1.0 - size >= sigmas * sigma && horizon <= horizon_max && kd > 0.0;
    accept.then(|| c.re.acos() / kd)
}

/// Beyond the spec, `Params::joint_elevation` (core module [`dbe_radar::joint`]): range bin by
/// range bin (points in their order), the bin's own points and those of the bins within
/// [`dbe_radar::joint::NEIGHBOUR_BINS`] (at most [`dbe_radar::joint::MAX_SOURCES`]) are sources
/// `conj(rot(v_s)) ⊙ a(μ_s, ν)` on the bin's raw covariance; alternating projection moves
/// each in turn to the grid elevation within [`dbe_radar::joint::SEARCH_BINS`] of its start
/// that maximises `bᴴRb / bᴴb`, `b = (I − P_others)·a`
/// (here the projection from a thin SVD of the others' steering matrix, the core's from
/// Gram–Schmidt), at most [`dbe_radar::joint::SWEEPS`] sweeps, then the log-parabola offset of the
/// objective. The own points get the fitted elevation; every detection of the bin gets
/// the decision margin of each argmax (best against runner-up).
fn joint_elevations(
    setup: &Setup,
    params: &Params,
    covariances: &[Option<DMatrix<Complex64>>],
    found: &[RefDetection],
    margins: &mut [Margin],
    points: &mut [PointRecord],
) {
    const MAX: usize = dbe_radar::joint::MAX_SOURCES;
    let m = setup.array.len();
    let nel = setup.el_nu.len();
    let mut start = 0;
    while start < points.len() {
        let b = points[start].range_bin;
        let own = points[start..]
            .iter()
            .take_while(|p| p.range_bin == b)
            .count();
        let mut members: Vec<usize> = (start..start + own).collect();
        for gap in 1..=u32::from(dbe_radar::joint::NEIGHBOUR_BINS) {
            for (k, p) in points.iter().enumerate() {
                if p.range_bin.abs_diff(b) == gap && members.len() < MAX {
                    members.push(k);
                }
            }
        }
        let r = covariances.get(b as usize).and_then(|r| r.as_ref());
        if let (true, Some(r)) = ((2..=MAX).contains(&members.len()), r) {
            // Per source: azimuth-and-slot part of its steering vector, and its bin.
            let mut sources: Vec<(DVector<Complex64>, usize)> = members
                .iter()
                .map(|&k| {
                    let p = &points[k];
                    let (_, mu) = range_and_mu(p);
                    let v = if params.tdm_compensation {
                        p.doppler
                    } else {
                        0.0
                    };
                    let base = DVector::from_iterator(
                        m,
                        setup.array.elements.iter().map(|e| {
                            let slot = setup.slot_phase_per_mps * v * e.slot as f64;
                            Complex64::from_polar(1.0, -setup.kappa * mu * e.az + slot)
                        }),
                    );
                    (base, p.elevation_bin as usize)
                })
                .collect();
            let el = |j: usize| setup.steering(m, 0.0, setup.el_nu[j]);
            let steer = |base: &DVector<Complex64>, j: usize| base.component_mul(&el(j));
            let complement = |sources: &[(DVector<Complex64>, usize)], skip: usize| {
                let cols: Vec<DVector<Complex64>> = sources
                    .iter()
                    .enumerate()
                    .filter(|&(t, _)| t != skip)
                    .map(|(_, (base, j))| steer(base, *j))
                    .collect();
                let a = DMatrix::from_columns(&cols);
                let svd = a.svd(true, false);
                let u = svd.u.expect("requested U");
                let mut proj = DMatrix::<Complex64>::identity(m, m);
                for (c, sv) in svd.singular_values.iter().enumerate() {
                    if sv * sv > 1e-6 * m as f64 {
                        let q = u.column(c);
                        proj -= q * q.adjoint();
                    }
                }
                proj
            };
            let objective = |proj: &DMatrix<Complex64>, a: &DVector<Complex64>| {
                let b = proj * a;
                let bb = b.norm_squared();
                if bb > 1e-4 * m as f64 {
                    b.dotc(&(r * &b)).re / bb
                } else {
                    0.0
                }
            };
            let mut margin = Margin::new();
            let reach = dbe_radar::joint::SEARCH_BINS;
            let start: Vec<usize> = sources.iter().map(|s| s.1.min(nel - 1)).collect();
            for _ in 0..dbe_radar::joint::SWEEPS {
                let mut moved = false;
                for s in 0..sources.len() {
                    let proj = complement(&sources, s);
                    let window = start[s].saturating_sub(reach)..=(start[s] + reach).min(nel - 1);
                    let f: Vec<(usize, f64)> = window
                        .map(|j| (j, objective(&proj, &steer(&sources[s].0, j))))
                        .collect();
                    // The first of equal maxima, as the core's strict comparison.
                    let mut best = f[0];
                    for &(j, v) in &f {
                        if v > best.1 {
                            best = (j, v);
                        }
                    }
                    let runner_up = f
                        .iter()
                        .filter(|&&(j, _)| j != best.0)
                        .map(|&(_, v)| v)
                        .fold(f64::NEG_INFINITY, f64::max);
                    let best_value = best.1;
                    let best = best.0;
                    margin.note(best_value, runner_up);
                    moved |= best != sources[s].1;
                    sources[s].1 = best;
                }
                if !moved {
                    break;
                }
            }
            for (s, &k) in members.iter().enumerate().take(own) {
                let j = sources[s].1;
                let frac = match (params.subgrid, j.checked_sub(1), j + 1 < nel) {
                    (true, Some(left), true) => {
                        let proj = complement(&sources, s);
                        let f = |j: usize| objective(&proj, &steer(&sources[s].0, j));
                        log_parabola_vertex(f(left), f(j), f(j + 1))
                    }
                    _ => 0.0,
                };
                let nu = match params.subgrid {
                    true => grid_sine(params.elevation_span_deg, nel, j as f64 + frac),
                    false => setup.el_nu[j],
                };
                let p = &mut points[k];
                let (range, mu) = range_and_mu(p);
                let cos2 = 1.0 - mu * mu - nu * nu;
                margin.note(mu * mu + nu * nu, 1.0);
                if cos2 > 0.0 {
                    (p.x, p.y, p.z) = (range * cos2.sqrt(), -range * mu, range * nu);
                    p.elevation_bin = j as u32;
                }
            }
            for (det, g) in found.iter().zip(margins.iter_mut()) {
                if det.range_bin == b as usize {
                    g.0 = g.0.min(margin.0);
                }
            }
        }
        start += own;
    }
}

/// A point's range and azimuth direction cosine `μ = −y/r` (0 at the origin).
fn range_and_mu(p: &PointRecord) -> (f64, f64) {
    let range = (p.x * p.x + p.y * p.y + p.z * p.z).sqrt();
    (range, if range > 0.0 { -p.y / range } else { 0.0 })
}

/// The elevation peaks kept by the rules of [`ElevationParams`], strongest first, with the
/// decision margins of the peak status, count and floor noted.
fn elevation_peaks(p: &[f64], rules: &ElevationParams, margin: &mut Margin) -> Vec<(usize, f64)> {
    let interior = 1..p.len().saturating_sub(1);
    let mut peaks: Vec<(usize, f64)> = interior
        .clone()
        .filter(|&j| p[j] > p[j - 1] && p[j] >= p[j + 1])
        .map(|j| (j, p[j]))
        .collect();
    // Stable: equal powers keep the lower bin first.
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    let Some(&(_, top)) = peaks.first() else {
        return peaks;
    };
    let floor = top * 10f64.powf(-f64::from(rules.peak_range_db) / 10.0);
    let max = usize::from(rules.max_peaks);

    // Decision margins: peak status of every bin that could be kept, the count cut, the floor.
    for j in interior {
        if p[j] < floor {
            continue;
        }
        let (left, right) = (relative_gap(p[j], p[j - 1]), relative_gap(p[j], p[j + 1]));
        let (l_ok, r_ok) = (p[j] > p[j - 1], p[j] >= p[j + 1]);
        margin.0 = margin.0.min(match (l_ok, r_ok) {
            (true, true) => left.min(right),
            (true, false) => right,
            (false, true) => left,
            (false, false) => left.max(right),
        });
    }
    if let (Some(a), Some(b)) = (peaks.get(max.wrapping_sub(1)), peaks.get(max)) {
        margin.note(a.1, b.1);
    }
    peaks.truncate(max);
    for &(_, q) in &peaks {
        margin.note(q, floor);
    }
    peaks.retain(|&(_, q)| q >= floor);
    peaks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_symmetric_and_match_their_formulas() {
        let w = window(WindowKind::Blackman, 9);
        assert!(w[0].abs() < 1e-12 && (w[4] - 1.0).abs() < 1e-12);
        for k in 0..9 {
            assert!((w[k] - w[8 - k]).abs() < 1e-12);
        }
        let h = window(WindowKind::Hann, 5);
        assert!((h[1] - 0.5).abs() < 1e-12);
        let hm = window(WindowKind::Hamming, 3);
        assert!((hm[0] - 0.08).abs() < 1e-12 && (hm[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn capon_is_distortionless_and_finds_a_single_source() {
        // One source at μ0 on an 8-element half-wavelength line (κ = π), unit noise.
        let d = 8;
        let mu0 = 0.3;
        let a = |mu: f64| {
            DVector::from_iterator(
                d,
                (0..d).map(|m| Complex64::from_polar(1.0, -PI * mu * m as f64)),
            )
        };
        let s = a(mu0);
        let r =
            &s * s.adjoint() * Complex64::new(100.0, 0.0) + DMatrix::<Complex64>::identity(d, d);
        let capon = Capon::new(load(&forward_backward(&r), 0.01).0).expect("positive definite");
        let w = capon.weight(&s);
        assert!((w.dotc(&s) - Complex64::new(1.0, 0.0)).norm() < 1e-12);
        let grid: Vec<f64> = (0..201).map(|i| -1.0 + 0.01 * i as f64).collect();
        let best = grid
            .iter()
            .copied()
            .max_by(|x, y| capon.power(&a(*x)).total_cmp(&capon.power(&a(*y))))
            .unwrap_or(f64::NAN);
        assert!((best - mu0).abs() < 0.005, "peak at μ = {best}");
    }

    #[test]
    fn cfar_cell_picks_the_order_statistic_and_breaks_ties_low() {
        // A plateau of two equal cells at (10, 20) and (10, 21) on a background of ones.
        let mut map = vec![vec![1.0; 40]; 20];
        map[10][20] = 100.0;
        map[10][21] = 100.0;
        let mut params = Params::defaults(20);
        params.range_first = 0;
        params.range_last = 19;
        // The mechanics under test do not depend on the default threshold: pin α = 12 dB.
        params.cfar.threshold_db = 12.0;
        // Full window around (10, 20): 13 × 25 − 5 × 9 = 280 training cells, k = ⌈0.75·280⌉
        // = 210. Raise exactly 70 of them (rows 4, 5 and 20 cells of row 6) to 5: the 210th
        // smallest is still 1; one more raised cell makes it 5.
        for row in &mut map[4..=5] {
            row[8..=32].fill(5.0);
        }
        map[6][8..=27].fill(5.0);
        let t = cfar_cell(&map, &params, 10, 20, 0.0);
        assert!(t.local_max && t.detects(100.0));
        assert_eq!(t.level, Some(1.0));
        assert!(!cfar_cell(&map, &params, 10, 21, 0.0).local_max);
        map[6][28] = 5.0;
        assert_eq!(cfar_cell(&map, &params, 10, 20, 0.0).level, Some(5.0));
        // A loading floor above the order statistic raises the level (and only then).
        let raised = cfar_cell(&map, &params, 10, 20, 8.0);
        assert_eq!(
            (raised.order_statistic, raised.level),
            (Some(5.0), Some(8.0))
        );
        assert!((raised.threshold - 8.0 * 10f64.powf(1.2)).abs() < 1e-9);
        assert!(!raised.detects(100.0) && cfar_cell(&map, &params, 10, 20, 2.0).detects(100.0));
        // Truncation at the processed rows: with rows 9..=11 only, the window holds 3 × 25 − 3 × 9.
        params.range_first = 9;
        params.range_last = 11;
        let t = cfar_cell(&map, &params, 10, 20, 0.0);
        assert_eq!(t.level, Some(1.0));
    }

    #[test]
    fn log_parabola_vertex_is_exact_on_gaussian_peaks() {
        // A Gaussian is a parabola in log power: the vertex is exact.
        let g = |x: f64| 5.0 * (-0.7 * (x + 0.2) * (x + 0.2)).exp();
        assert!((log_parabola_vertex(g(-1.0), g(0.0), g(1.0)) + 0.2).abs() < 1e-12);
        assert_eq!(log_parabola_vertex(1.0, 2.0, 1.0), 0.0);
        assert_eq!(log_parabola_vertex(1.0, 1.0, 1.0), 0.0);
        assert_eq!(log_parabola_vertex(3.0, 2.0, 1.0), 0.0);
        assert_eq!(log_parabola_vertex(0.0, 2.0, 1.0), 0.0);
        assert!((log_parabola_vertex(2.0, 2.0, 1e-9) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn candan_offset_finds_a_tone_between_bins() {
        let k = 64;
        for i in 0..19 {
            let f = 10.0 - 0.45 + 0.05 * f64::from(i);
            let x: Vec<Complex64> = (0..k)
                .map(|n| Complex64::from_polar(1.0, 2.0 * PI * f * n as f64 / k as f64 - 1.1))
                .collect();
            let dft = |b: usize| -> Complex64 {
                x.iter()
                    .enumerate()
                    .map(|(n, v)| {
                        v * Complex64::from_polar(1.0, -2.0 * PI * (b * n) as f64 / k as f64)
                    })
                    .sum()
            };
            let b = f.round() as usize;
            let got = b as f64 + candan_offset(dft(b - 1), dft(b), dft(b + 1), k);
            // Candan's residual is O(k⁻²) of the offset.
            assert!((got - f).abs() < 1e-3, "{got} for {f}");
        }
        let z = Complex64::new(0.0, 0.0);
        assert_eq!(candan_offset(z, z, z, 64), 0.0);
    }

    #[test]
    fn elevation_peaks_follow_the_rules() {
        // Peaks at 2 (10), 5 (8), 8 (1: below the 6 dB floor); bin 0 is not interior.
        let p = [20.0, 1.0, 10.0, 2.0, 3.0, 8.0, 4.0, 0.5, 1.0, 0.2];
        let mut m = Margin::new();
        let peaks = elevation_peaks(
            &p,
            &ElevationParams {
                max_peaks: 3,
                peak_range_db: 6.0,
            },
            &mut m,
        );
        assert_eq!(peaks, vec![(2, 10.0), (5, 8.0)]);
        assert!(m.0 > 0.1);
    }
}
