//! The DBE chain end to end (spec §3): ingestion → azimuth Capon → OS-CFAR → TDM compensation
//! → elevation Capon → Capon-weighted Doppler → points.
//!
//! ```text
//! per chirp  push_chirp : DC removal, window, range FFT ──▶ Cube[bin][row][loop]
//! per frame  process    : for each kept range bin b (dequantised into the f32 block)
//!                            R_b = X·Xᴴ/K of the AZ azimuth rows
//!                            RA[b][i] = Capon power of R_b (FB, loading)
//!                         OS-CFAR on RA ──▶ detections (b, i)
//!                         per detection bin: the full M×M R_b, once per distinct bin
//!                         per detection: TDM-compensate R_b with the beam's Doppler,
//!                            refine azimuth, sweep elevation Capon on R_b (no FB),
//!                            per peak: Capon weight ──▶ slow time ──▶ Doppler FFT ──▶ Point
//! ```

use num_complex::Complex32;

use crate::capon::Capon;
use crate::cfar::{self, Detection, Detections, MAX_TRAINING_CELLS};
use crate::config::{
    sine_at, sine_grid, AntennaGeometry, ArrayLayout, ConfigError, Param, Params, Waveform,
    MAX_ELEVATION_PEAKS,
};
use crate::covariance::{
    covariance, forward_backward, leading_block, load_diagonal, rotate_rows, zero, Matrix,
};
use crate::cube::{ChirpId, Cube, FrameError, Snapshots};
use crate::doppler::doppler_peak;
use crate::points::{ratio_db, Point, PointCloud};
use crate::range::RangeFft;
use crate::refine::parabolic_offset;

const ZERO: Complex32 = Complex32::new(0.0, 0.0);
const ONE: Complex32 = Complex32::new(1.0, 0.0);

/// Mutable per-frame state besides the cube: the `f32` snapshots of the range bin in flight,
/// the range–azimuth map, the CFAR scratch and the detection list. Construct it once (it is
/// `const`), reuse it every frame.
#[derive(Clone, Debug)]
pub struct Workspace<
    const N: usize,
    const M: usize,
    const K: usize,
    const NAZ: usize,
    const DET: usize,
> {
    block: Snapshots<M, K>,
    ra: [[f32; NAZ]; N],
    floor: [f32; N],
    scratch: [f32; MAX_TRAINING_CELLS],
    detections: Detections<DET>,
}

impl<const N: usize, const M: usize, const K: usize, const NAZ: usize, const DET: usize>
    Workspace<N, M, K, NAZ, DET>
{
    /// A zeroed workspace.
    pub const fn new() -> Self {
        Self {
            block: [[ZERO; K]; M],
            ra: [[0.0; NAZ]; N],
            floor: [0.0; N],
            scratch: [0.0; MAX_TRAINING_CELLS],
            detections: Detections::new(),
        }
    }

    /// The range–azimuth map of the last frame: `ra[range bin][azimuth bin]`, linear Capon
    /// power; rows outside the processed range window and skipped rows are zero.
    pub fn range_azimuth(&self) -> &[[f32; NAZ]; N] {
        &self.ra
    }

    /// The CFAR detections of the last frame.
    pub fn detections(&self) -> &[Detection] {
        self.detections.as_slice()
    }
}

impl<const N: usize, const M: usize, const K: usize, const NAZ: usize, const DET: usize> Default
    for Workspace<N, M, K, NAZ, DET>
{
    fn default() -> Self {
        Self::new()
    }
}

/// The configured DBE chain: parameters and precomputed tables (`&self` only, never mutated
/// by processing).
///
/// Const generics: `N` samples per chirp (= range bins), `K` loops per frame, `TX`, `RX`,
/// `M = TX·RX` virtual antennas of which `AZ` form the azimuth line, `NAZ` azimuth and `NEL`
/// elevation grid bins.
#[derive(Clone, Debug)]
pub struct Dbe<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
> {
    waveform: Waveform,
    geometry: AntennaGeometry<TX, RX>,
    params: Params,
    layout: ArrayLayout<TX, RX, M>,
    /// Coupling calibration per cube row (all zero, and unused, when `coupling_on` is false).
    coupling: [[Complex32; N]; M],
    coupling_on: bool,
    range: RangeFft<N>,
    doppler_window: [f32; K],
    az_mu: [f32; NAZ],
    el_nu: [f32; NEL],
    /// `exp(−j·κ·μ_i·az_m)` for every row.
    az_steer: [[Complex32; M]; NAZ],
    /// `exp(−j·κ·ν_j·el_m)` for every row (1 on the azimuth line).
    el_steer: [[Complex32; M]; NEL],
    range_bin_m: f32,
    doppler_bin_mps: f32,
}

impl<
        const N: usize,
        const K: usize,
        const TX: usize,
        const RX: usize,
        const M: usize,
        const AZ: usize,
        const NAZ: usize,
        const NEL: usize,
    > Dbe<N, K, TX, RX, M, AZ, NAZ, NEL>
{
    /// Validate the configuration and precompute windows and steering tables.
    pub fn new(
        waveform: Waveform,
        geometry: AntennaGeometry<TX, RX>,
        params: Params,
    ) -> Result<Self, ConfigError> {
        let mut dbe = Self::unconfigured();
        dbe.configure(waveform, geometry, params)?;
        Ok(dbe)
    }

    /// A chain whose every byte is zero, `const`, so that a `static` of it lands in `.bss`
    /// (no flash image, no copy at boot) on firmware; [`Self::configure`] it in place before
    /// use. Unconfigured, it never panics and produces no points.
    pub const fn unconfigured() -> Self {
        Self {
            waveform: Waveform {
                adc_sample_rate_hz: 0.0,
                slope_hz_per_s: 0.0,
                start_frequency_hz: 0.0,
                idle_time_s: 0.0,
                ramp_end_time_s: 0.0,
            },
            geometry: AntennaGeometry {
                tx: [(0.0, 0.0); TX],
                rx: [(0.0, 0.0); RX],
                f_design_hz: 0.0,
            },
            params: Params::zeroed(),
            layout: ArrayLayout {
                row_of: [[0; RX]; TX],
                az: [0.0; M],
                el: [0.0; M],
                slot: [0; M],
            },
            coupling: [[ZERO; N]; M],
            coupling_on: false,
            range: RangeFft::unconfigured(),
            doppler_window: [0.0; K],
            az_mu: [0.0; NAZ],
            el_nu: [0.0; NEL],
            az_steer: [[ZERO; M]; NAZ],
            el_steer: [[ZERO; M]; NEL],
            range_bin_m: 0.0,
            doppler_bin_mps: 0.0,
        }
    }

    /// Validate the configuration and compute the tables in place (no chain-sized value on
    /// the stack). On error `self` is unchanged. Any coupling calibration is removed.
    pub fn configure(
        &mut self,
        waveform: Waveform,
        geometry: AntennaGeometry<TX, RX>,
        params: Params,
    ) -> Result<(), ConfigError> {
        const {
            assert!(M == TX * RX, "M must equal TX · RX");
            assert!(AZ >= 2 && AZ < M, "the azimuth line needs 2..M elements");
            assert!(N.is_power_of_two() && K.is_power_of_two());
            assert!(N <= u16::MAX as usize && K <= i16::MAX as usize);
            assert!(NAZ <= u16::MAX as usize && NEL <= u16::MAX as usize);
        };
        waveform.validate()?;
        let layout = ArrayLayout::new(&geometry, AZ)?;
        params.validate(N, NAZ)?;
        if NAZ < 3 || NEL < 3 {
            return Err(ConfigError::OutOfRange(Param::GridSize));
        }
        let fc = waveform.center_frequency_hz(N);
        let kappa = (core::f64::consts::PI * fc / geometry.f_design_hz) as f32;
        self.az_mu = sine_grid::<NAZ>(params.azimuth_span_deg);
        self.el_nu = sine_grid::<NEL>(params.elevation_span_deg);
        for (row, mu) in self.az_steer.iter_mut().zip(self.az_mu.iter()) {
            for (a, pos) in row.iter_mut().zip(layout.az.iter()) {
                *a = Complex32::from_polar(1.0, -kappa * mu * pos);
            }
        }
        for (row, nu) in self.el_steer.iter_mut().zip(self.el_nu.iter()) {
            for (a, pos) in row.iter_mut().zip(layout.el.iter()) {
                *a = Complex32::from_polar(1.0, -kappa * nu * pos);
            }
        }
        self.waveform = waveform;
        self.geometry = geometry;
        self.params = params;
        self.layout = layout;
        self.coupling_on = false;
        self.range = RangeFft::new(params.range_window);
        self.doppler_window = params.doppler_window.coefficients();
        self.range_bin_m = waveform.range_bin_m(N) as f32;
        self.doppler_bin_mps = waveform.doppler_bin_mps(N, K, TX) as f32;
        Ok(())
    }

    /// [`Self::set_coupling`], by value.
    pub fn with_coupling(
        mut self,
        coupling: &[[&[Complex32]; RX]; TX],
    ) -> Result<Self, ConfigError> {
        self.set_coupling(coupling)?;
        Ok(self)
    }

    /// Attach a coupling calibration in data order `[tx][rx][range bin]`, subtracted from the
    /// range-FFT output of every chirp (same units: unnormalised FFT of the windowed,
    /// DC-removed chirp). Range bins beyond a table's length are not corrected. On error the
    /// previous calibration is kept.
    pub fn set_coupling(&mut self, coupling: &[[&[Complex32]; RX]; TX]) -> Result<(), ConfigError> {
        for bins in coupling.iter().flatten() {
            if bins.len() > N {
                return Err(ConfigError::OutOfRange(Param::Coupling));
            }
            if bins.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())) {
                return Err(ConfigError::NotFinite(Param::Coupling));
            }
        }
        for row in self.coupling.iter_mut() {
            *row = [ZERO; N];
        }
        for (t, per_rx) in coupling.iter().enumerate() {
            for (r, bins) in per_rx.iter().enumerate() {
                let row = usize::from(self.layout.row_of[t][r]);
                if let Some(dst) = self.coupling.get_mut(row) {
                    for (d, s) in dst.iter_mut().zip(bins.iter()) {
                        *d = *s;
                    }
                }
            }
        }
        self.coupling_on = true;
        Ok(())
    }

    /// The waveform.
    pub fn waveform(&self) -> &Waveform {
        &self.waveform
    }

    /// The antenna geometry.
    pub fn geometry(&self) -> &AntennaGeometry<TX, RX> {
        &self.geometry
    }

    /// The processing parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The cube row order derived from the geometry.
    pub fn layout(&self) -> &ArrayLayout<TX, RX, M> {
        &self.layout
    }

    /// Direction cosine μ = sin φ of each azimuth grid bin.
    pub fn azimuth_grid(&self) -> &[f32; NAZ] {
        &self.az_mu
    }

    /// Direction cosine ν = sin θ of each elevation grid bin.
    pub fn elevation_grid(&self) -> &[f32; NEL] {
        &self.el_nu
    }

    /// Metres per range bin.
    pub fn range_bin_m(&self) -> f32 {
        self.range_bin_m
    }

    /// m/s per Doppler bin.
    pub fn doppler_bin_mps(&self) -> f32 {
        self.doppler_bin_mps
    }

    /// Ingest one chirp: `chirp[rx][sample] = [I, Q]` of TX slot `id.tx_slot` in loop
    /// `id.loop_index`, as the ADC delivers it. Chirps must come in TDM order (loop 0 slot 0,
    /// loop 0 slot 1, …); any other chirp is not stored and makes the frame an error (returned
    /// here and by [`Self::process`]) until [`Cube::begin_frame`].
    pub fn push_chirp(
        &self,
        cube: &mut Cube<'_, N, M, K>,
        id: ChirpId,
        chirp: &[[[i16; 2]; N]; RX],
    ) -> Result<(), FrameError> {
        crate::range::ingest(
            &self.range,
            &self.layout.row_of,
            self.coupling_on.then_some(&self.coupling),
            cube,
            id,
            chirp,
        )
    }

    /// Process a complete frame into `out`. Fails only when the cube is not a complete,
    /// in-order frame; never panics. The workspace keeps the range–azimuth map, covariances
    /// and detections for inspection.
    pub fn process<const DET: usize, const P: usize>(
        &self,
        cube: &Cube<'_, N, M, K>,
        work: &mut Workspace<N, M, K, NAZ, DET>,
        out: &mut PointCloud<P>,
    ) -> Result<(), FrameError> {
        out.clear();
        cube.status(TX)?;
        let first = usize::from(self.params.range_first);
        let last = usize::from(self.params.range_last).min(N - 1);

        // Stage 1: covariance per range bin, azimuth Capon spectrum → RA map.
        for row in work.ra.iter_mut() {
            *row = [0.0; NAZ];
        }
        work.floor = [0.0; N];
        for b in first..=last {
            let (Some(ra), Some(floor)) = (work.ra.get_mut(b), work.floor.get_mut(b)) else {
                continue;
            };
            cube.snapshots(b, &mut work.block);
            let mut cov = zero::<AZ>();
            covariance(&work.block[..], &mut cov);
            match self.azimuth_capon(&cov) {
                Some((capon, delta)) => {
                    // P(θ) ≥ δ / AZ: the loading floor of this row (see `cfar`).
                    *floor = delta / AZ as f32;
                    for (p, steer) in ra.iter_mut().zip(self.az_steer.iter()) {
                        *p = capon.power(&azimuth_part::<M, AZ>(steer));
                    }
                }
                None => out.stats.skipped_range_bins += 1,
            }
        }

        // Stage 2: OS-CFAR.
        cfar::detect(
            &work.ra,
            &work.floor,
            first,
            last,
            &self.params.cfar,
            &mut work.scratch,
            &mut work.detections,
        );
        out.stats.detections = work.detections.as_slice().len() as u32;
        out.stats.detection_overflow = work.detections.overflow;

        // Stages 3–5 per detection; the full covariance once per distinct range bin (the
        // detections come in range order unless an overflow replaced some).
        let Workspace {
            block,
            ra,
            detections,
            ..
        } = work;
        let mut cov = zero::<M>();
        let mut cov_bin = usize::MAX;
        for det in detections.as_slice() {
            let b = usize::from(det.range_bin);
            if b != cov_bin {
                cube.snapshots(b, block);
                covariance(&block[..], &mut cov);
                cov_bin = b;
            }
            let before = out.stats.points + out.stats.point_overflow;
            self.resolve(det, block, &cov, ra, out);
            if out.stats.points + out.stats.point_overflow == before {
                out.stats.detections_without_point += 1;
            }
        }
        Ok(())
    }

    /// Capon solver of the azimuth line's covariance (FB averaging if on, loading), and the
    /// loading `δ` it used.
    fn azimuth_capon(&self, cov: &Matrix<AZ>) -> Option<(Capon<AZ>, f32)> {
        let mut r = *cov;
        if self.params.forward_backward {
            forward_backward(&mut r);
        }
        let delta = load_diagonal(&mut r, self.params.loading);
        Capon::new(&r).map(|c| (c, delta))
    }

    /// Steering vector of all rows for azimuth bin `i`, elevation bin `j`.
    fn steering(&self, i: usize, j: usize) -> [Complex32; M] {
        let mut a = [ZERO; M];
        if let (Some(az), Some(el)) = (self.az_steer.get(i), self.el_steer.get(j)) {
            for ((o, x), y) in a.iter_mut().zip(az.iter()).zip(el.iter()) {
                *o = x * y;
            }
        }
        a
    }

    /// Elevation, Doppler and points of one detection.
    fn resolve<const P: usize>(
        &self,
        det: &Detection,
        snap: &[[Complex32; K]; M],
        cov: &Matrix<M>,
        ra: &[[f32; NAZ]; N],
        out: &mut PointCloud<P>,
    ) {
        let b = usize::from(det.range_bin);
        let mut i = usize::from(det.azimuth_bin).min(NAZ - 1);
        // Sub-grid offsets: range from the RA map's column, azimuth from the spectrum the
        // final azimuth bin was chosen on (replaced below when TDM compensation re-estimates).
        let at = |row: Option<usize>, col: usize| {
            row.and_then(|b| ra.get(b))
                .and_then(|r| r.get(col))
                .copied()
                .unwrap_or(0.0)
        };
        let range_frac =
            parabolic_offset(at(b.checked_sub(1), i), at(Some(b), i), at(Some(b + 1), i));
        let mut az_frac = parabolic_offset(
            at(Some(b), i.wrapping_sub(1)),
            at(Some(b), i),
            at(Some(b), i + 1),
        );
        let mut r = *cov;
        let mut rot = [ONE; M];
        if self.params.tdm_compensation {
            let Some((az, _)) = self.azimuth_capon(&leading_block(&r)) else {
                return;
            };
            let w = az.weight(&azimuth_part::<M, AZ>(&self.az_steer[i]));
            let mut y = [ZERO; K];
            beamform(&w, snap, &[ONE; AZ], &mut y);
            let d = doppler_peak(&mut y, &self.doppler_window).bin;
            // exp(−j·4π·v·t·Tc/λ) with v = d·λ/(2·K·TX·Tc) is exp(−j·2π·d·t/(K·TX)).
            let per_slot = -2.0 * core::f32::consts::PI * f32::from(d) / (K * TX) as f32;
            for (o, &slot) in rot.iter_mut().zip(self.layout.slot.iter()) {
                *o = Complex32::from_polar(1.0, per_slot * f32::from(slot));
            }
            rotate_rows(&mut r, &rot);
            if let Some((az, _)) = self.azimuth_capon(&leading_block(&r)) {
                i = self.climb_azimuth(&az, i);
                let power = |i: usize| match self.az_steer.get(i) {
                    Some(s) => az.power(&azimuth_part::<M, AZ>(s)),
                    None => 0.0,
                };
                az_frac = parabolic_offset(power(i.wrapping_sub(1)), power(i), power(i + 1));
            }
        }

        // Stage 3: elevation sweep on the full array, no FB averaging.
        let _ = load_diagonal(&mut r, self.params.loading);
        let Some(el) = Capon::<M>::new(&r) else {
            return;
        };
        let mut spectrum = [0.0f32; NEL];
        for (j, p) in spectrum.iter_mut().enumerate() {
            *p = el.power(&self.steering(i, j));
        }
        let peaks = strongest_interior_peaks(
            &spectrum,
            usize::from(self.params.elevation.max_peaks),
            self.params.elevation.peak_range_db,
        );

        // Stage 4–5: Capon-weighted Doppler and the point per elevation peak.
        let subgrid = self.params.subgrid;
        let (mu, range) = if subgrid {
            (
                sine_at(self.params.azimuth_span_deg, NAZ, i as f32 + az_frac),
                (b as f32 + range_frac) * self.range_bin_m,
            )
        } else {
            (self.az_mu[i], b as f32 * self.range_bin_m)
        };
        let snr_db = ratio_db(det.power, det.level);
        for &(j, power) in peaks.iter().flatten() {
            let nu = if subgrid {
                let frac = parabolic_offset(spectrum[j - 1], spectrum[j], spectrum[j + 1]);
                sine_at(self.params.elevation_span_deg, NEL, j as f32 + frac)
            } else {
                self.el_nu[j]
            };
            let cos2 = 1.0 - mu * mu - nu * nu;
            if !(cos2 > 0.0) {
                continue;
            }
            let w = el.weight(&self.steering(i, j));
            let mut y = [ZERO; K];
            beamform(&w, snap, &rot, &mut y);
            let peak = doppler_peak(&mut y, &self.doppler_window);
            let d = peak.bin;
            let doppler = if subgrid {
                f32::from(d) + peak.offset
            } else {
                f32::from(d)
            };
            out.push(Point {
                position: glam::Vec3::new(range * libm::sqrtf(cos2), -range * mu, range * nu),
                velocity_mps: doppler * self.doppler_bin_mps,
                power_db: 10.0 * libm::log10f(power.max(f32::MIN_POSITIVE)),
                snr_db,
                range_bin: det.range_bin,
                azimuth_bin: i as u16,
                elevation_bin: j as u16,
                doppler_bin: d,
            });
        }
    }

    /// Move from azimuth bin `i` uphill on the Capon spectrum of `az`, at most
    /// `tdm_azimuth_search` bins.
    fn climb_azimuth(&self, az: &Capon<AZ>, mut i: usize) -> usize {
        let power = |i: usize| az.power(&azimuth_part::<M, AZ>(&self.az_steer[i]));
        let mut here = power(i);
        for _ in 0..self.params.tdm_azimuth_search {
            let left = if i > 0 { power(i - 1) } else { 0.0 };
            let right = if i + 1 < NAZ { power(i + 1) } else { 0.0 };
            if left > here && left >= right {
                i -= 1;
                here = left;
            } else if right > here {
                i += 1;
                here = right;
            } else {
                break;
            }
        }
        i
    }
}

/// `y[k] = Σ_m conj(w_m) · rot_m · x_m[k]` over the first `D` rows of `snap`.
fn beamform<const D: usize, const M: usize, const K: usize>(
    w: &[Complex32; D],
    snap: &[[Complex32; K]; M],
    rot: &[Complex32; D],
    y: &mut [Complex32; K],
) {
    *y = [ZERO; K];
    for ((wm, rm), xm) in w.iter().zip(rot.iter()).zip(snap.iter()) {
        let c = wm.conj() * rm;
        for (yk, xk) in y.iter_mut().zip(xm.iter()) {
            *yk += c * xk;
        }
    }
}

/// The azimuth line's part of a full-array steering row.
fn azimuth_part<const M: usize, const AZ: usize>(row: &[Complex32; M]) -> [Complex32; AZ] {
    let mut a = [ZERO; AZ];
    a.copy_from_slice(&row[..AZ]);
    a
}

/// Up to `max` interior local maxima of `p` (`p[j−1] < p[j] ≥ p[j+1]`), strongest first, each
/// within `range_db` of the strongest.
fn strongest_interior_peaks<const L: usize>(
    p: &[f32; L],
    max: usize,
    range_db: f32,
) -> [Option<(usize, f32)>; MAX_ELEVATION_PEAKS] {
    let max = max.min(MAX_ELEVATION_PEAKS);
    let mut best: [Option<(usize, f32)>; MAX_ELEVATION_PEAKS] = [None; MAX_ELEVATION_PEAKS];
    for j in 1..L.saturating_sub(1) {
        if !(p[j] > p[j - 1] && p[j] >= p[j + 1]) {
            continue;
        }
        // Insertion into the sorted list of the `max` strongest: a stronger candidate takes
        // the slot and carries the weaker one down; what falls off the end is dropped.
        let mut cand = (j, p[j]);
        for slot in best.iter_mut().take(max) {
            match slot {
                None => {
                    *slot = Some(cand);
                    break;
                }
                Some(s) if cand.1 > s.1 => core::mem::swap(s, &mut cand),
                Some(_) => {}
            }
        }
    }
    if let Some((_, top)) = best[0] {
        let floor = top * libm::powf(10.0, -range_db / 10.0);
        for slot in best.iter_mut() {
            if slot.is_some_and(|(_, q)| q < floor) {
                *slot = None;
            }
        }
    }
    best
}
