//! The DBE chain (spec §3), stage by stage.
//!
//! ```text
//! Frontend::push_chirp : DC removal, window, range FFT ──▶ Cube[bin][loop][row]  (frontend.rs)
//! Frontend::frame      : all chirps in order? ──▶ Frame
//! Dbe::azimuth_map     : per kept range bin b: R_b = X·Xᴴ/K of the AZ azimuth rows,
//!   (Chain::map)         FB averaging, loading ──▶ RA[b][i] = Capon power      (capon.rs)
//! Dbe::detect_targets  : OS-CFAR on RA, row floor δ_b/AZ ──▶ detections (b, i) (cfar.rs)
//!   (Chain::detect)
//! Dbe::resolve         : per run of detections in one range bin, the full M×M R_b once:
//!   (Chain::points)      beam_doppler of every detection; equal Dopplers ──▶ coherent;
//!                        a lone detection that is a merged coherent pair ──▶ two (split.rs)
//!                        per detection: compensate_tdm: rotate R_b by its Doppler,
//!                          climb to the compensated azimuth peak            (tdm.rs)
//!                        elevation::sweep on R_b (no FB), or coherent: on the
//!                          FBSS 2×4 rectangle ──▶ ≤ 2 peaks     (elevation.rs, subarray.rs)
//!                        per peak: Capon weight ──▶ slow time ──▶ Doppler FFT (doppler.rs)
//!                          ──▶ Point::at(range, μ, ν)                         (points.rs)
//! ```
//!
//! `Chain::process` is the three stages in order; a caller can run and time them one by one.

use num_complex::Complex32;

use crate::capon::{line_phase, Capon, LineSpectrum};
use crate::cfar::{self, CfarParams, Columns, Detection, Detections, MapShape, MAX_TRAINING_CELLS};
use crate::chain::Chain;
use crate::config::{
    finite, sine_at, sine_grid, validate_bins_and_spans, ArrayLayout, ConfigError, Param,
};
use crate::covariance::{
    covariance, forward_backward, leading_block, load_diagonal, rotate_rows, scale_rows, zero,
    Matrix,
};
use crate::cube::{Frame, Snapshots};
use crate::doppler::{doppler_peak, passes_peak_to_median};
use crate::elevation::{self, ElevationParams};
use crate::frontend::Frontend;
use crate::joint::{self, Source, MAX_SOURCES, NEIGHBOUR_BINS, SWEEPS};
use crate::points::{power_db, ratio_db, Point, PointCloud};
use crate::refine::parabolic_offset;
use crate::ring;
use crate::split::{split_line_from, start_vector};
use crate::subarray::{smooth_line, SubArray};
use crate::tdm;
use crate::window::{Window, WindowKind};

const ZERO: Complex32 = Complex32::new(0.0, 0.0);
const ONE: Complex32 = Complex32::new(1.0, 0.0);

/// Azimuths whose map powers a host evaluates side by side ([`LineSpectrum::powers_at`]).
#[cfg(not(target_arch = "arm"))]
const LANES: usize = 16;

/// Processing parameters of the DBE chain (defaults of spec §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// First range bin processed (inclusive).
    pub range_first: u16,
    /// Last range bin processed (inclusive); at most `N − 1`.
    pub range_last: u16,
    /// Range window applied before the range FFT: the [`Frontend`]'s, which
    /// [`Dbe::configure`] checks (the reference implementation and reports read it here).
    pub range_window: WindowKind,
    /// Slow-time window applied before the Doppler FFT (the sub-bin estimator follows the
    /// window: [`crate::doppler::doppler_peak`]).
    pub doppler_window: WindowKind,
    /// Diagonal loading factor γ: `δ = γ · tr(R) / M`.
    pub loading: f32,
    /// Forward–backward averaging of the azimuth covariance.
    pub forward_backward: bool,
    /// Spatial smoothing of the azimuth covariance over the line's two `AZ − 1`-element
    /// sub-lines (before FB averaging; [`crate::subarray::smooth_line`]). Off by default and
    /// in the paper's chain. Measured on 40 pairs of equal targets at 20 dB per separation
    /// (`host-sim/tests/accuracy.rs`): coherent pairs 12° and 20° apart are resolved in every
    /// trial instead of 90 % and 95 %, but one element of aperture is lost: coherent pairs
    /// 4–8° apart 23–70 % instead of 33–75 %, non-coherent pairs 6° apart 45 % instead of
    /// 57 %, and their elevations (climbed from a broader azimuth peak) 0.42° RMSE at 8°
    /// instead of 0.27°.
    pub spatial_smoothing: bool,
    /// TDM-MIMO motion compensation before elevation and Doppler.
    pub tdm_compensation: bool,
    /// With TDM compensation: how far (azimuth bins) the detection's azimuth may move to the
    /// peak of the compensated spectrum. The uncompensated slot step between the two halves
    /// of a 3-TX azimuth line shifts the peak by up to ~5° at the unambiguous velocity limit;
    /// 8 bins (6° on the default grid) covers it without reaching a neighbouring target.
    pub tdm_azimuth_search: u8,
    /// Sub-grid refinement of range, azimuth, elevation and Doppler (see [`crate::refine`]):
    /// points get continuous coordinates instead of grid values; bin indices are unchanged.
    /// On by default: in the evaluation (`docs/eval/report.md`, "Sub-grid refinement") it
    /// lowers the angle and velocity RMSE at every SNR and the Chamfer distance on every scene,
    /// and changes no detection or resolution. Off in the paper's chain (grid points).
    pub subgrid: bool,
    /// Coherent targets (see [`crate::subarray`]): a detection whose azimuth beam's Doppler
    /// lies within this many bins of another detection's of the same range bin is resolved
    /// on the forward–backward averaged centro-symmetric sub-array instead of the full array.
    /// Two tones `Δ` bins apart are correlated over the frame by about `|sinc(Δ)|`, zero from
    /// one bin; 1.5 bins leaves half a bin for the error of the two estimates. `0` turns it
    /// off (the paper's chain: always the full array).
    pub coherent_doppler_bins: f32,
    /// Doppler test of every detection, dB: the strongest bin of the windowed Doppler spectrum
    /// of its azimuth Capon beam, after TDM compensation by the beam's Doppler and the climb
    /// to the compensated azimuth peak, must exceed the spectrum's median by this much
    /// ([`crate::doppler::peak_to_median`]), or the detection is dropped (counted in
    /// `FrameStats::doppler_rejected`). It is the slow-time integration the range–azimuth map
    /// lacks: a map cell of a target is a power averaged over the loops, whose coherent gain
    /// only appears in the Doppler spectrum of its beam. In white noise the ratio exceeds `t`
    /// with probability `K·2^{−t}`: 12 dB (t = 15.8) rejects a noise candidate with
    /// probability 1 − 2.3·10⁻³ (K = 128), while a target at the map's detection limit
    /// (α = 2 dB: 1 + 8ρ = 1.58, ρ = −11.4 dB per antenna and loop, −2.3 dB after the
    /// 8-element beam) peaks ≈ 17 dB over the median (K·ρ_beam / 1.5, the Hann window's noise bandwidth). `0` or
    /// below passes everything (the paper's chain). Compensation matters: the uncompensated
    /// beam of a strong target moving at −1.6 m/s is steered where the target's slot phases do
    /// not point, MVDR cancels it, and it fails the test (`tests/pipeline.rs`, sub-grid test,
    /// seed 1).
    pub doppler_test_db: f32,
    /// Doppler agreement of every point, bins: the strongest bin of the point's own Capon beam
    /// (spec §3 step 4, the weight of its 3-D direction on the full array) must lie within this
    /// many bins (circular, sub-bin offsets included) of the Doppler of its detection's azimuth
    /// beam, or the point is dropped (a detection left without a point is counted in
    /// `FrameStats::detections_without_point`). A weight that passes the detection's signal
    /// shows its tone; one that does not was steered at a direction the signal does not come
    /// from (an elevation not of this target, or, on a real uncalibrated array, a steering
    /// vector the target's phases do not match, which MVDR cancels), and its strongest bin is
    /// noise. On the real TI corner-reflector capture such points are the moving ones of a
    /// static scene: at α = 2 dB, 15 points of which 12 move without the rule, the reflector
    /// and its two bounces, all static, with it; on the simulated scenes it drops 14 % of the
    /// points at α = 3 dB and lowers the false points per frame from 0.17 to 0.03 (`dbe eval`,
    /// defaults sweep). 1.5 bins (as the
    /// coherent window) leaves half a bin for the error of each estimate. The rule also drops
    /// a second elevation peak whose target moves at another radial velocity than the one
    /// the azimuth beam shows (no detection of the evaluation's scenes has a second peak).
    /// `0` turns it off (the paper's chain).
    pub doppler_agreement_bins: f32,
    /// Joint elevation fit of the points of each range bin (see [`crate::joint`]): after
    /// the Capon sweeps, the elevations of a range bin's points are re-fitted together on the
    /// bin's raw covariance by alternating projection, each point a source with its own TDM
    /// slot phase, the points of the two neighbouring range bins included, each moving at
    /// most [`crate::joint::SEARCH_BINS`] from its Capon elevation. Measured: on two coherent
    /// pairs two range bins apart seen from a sensor moving at 1.5 m/s
    /// (`host-sim/tests/harness.rs`, six seeds) the elevation RMSE falls from 0.77° to
    /// 0.074°; in `dbe eval`'s defaults sweep it lowers the false points per scene frame
    /// from 0.84 to 0.79 and the Chamfer distance from 0.974 to 0.972 m. Off by default
    /// and in the paper's chain: with it on in every DBE variant of `dbe eval` (the default
    /// switched), non-coherent pairs 8° apart at 20 dB get better elevations (0.24° → 0.14°
    /// RMSE) but coherent ones worse (0.12° → 0.38°: the fit replaces their sub-array
    /// elevations, and why it does worse on a static coherent pair is not yet known), and
    /// odometry drift falls on two simulated sequences and rises on two (XYZ hallways,
    /// outdoors, aspen, army 0.46/2.99/0.23/0.35 → 0.40/2.53/0.35/0.43 %).
    pub joint_elevation: bool,
    /// Coherent split (see [`crate::split`]): a detection with no coherent partner whose
    /// TDM-compensated line covariance is a coherent pair merged into one map peak (nearly
    /// rank 1, two undamped exponentials fit its principal eigenvector far better than one)
    /// is resolved as two coherent detections at the fitted azimuths. On by default: in
    /// `dbe eval`'s defaults sweep it resolves coherent pairs at 20 dB 8° apart in 99 % of
    /// trials instead of 81 % (6°: 93 % instead of 68 %), raises the extended scenes' points
    /// per frame from 21.9 to 23.1 and lowers their Chamfer distance by 1.6 % at 0.86 instead
    /// of 0.84 false points per scene frame and none on noise-only frames; the TI capture
    /// keeps its three static points. Off in the paper's chain, and whenever the coherent
    /// path is (`coherent_doppler_bins` 0), whose sub-array resolves the split detections.
    pub coherent_split: bool,
    /// Ring split (see [`crate::ring`]): a point at the horizon whose elevation row sees it
    /// clearly weaker than its azimuth line does, on its own Doppler bin, is the two returns
    /// of a vertical surface's range ring, above and below the radar: it becomes two points
    /// at ± the pair's half-separation about the horizon. Only on an array with an elevation
    /// row, and not for the points of a coherent pair (their sub-array has its own elevation
    /// fit). Off by default and in the paper's chain: measured by `dbe eval` it serves the
    /// ego-velocity (odometry section, `dbe[ring split = on]` rows against `dbe`: the static
    /// points' *v_r scale* from 0.987 to 0.992 on the outdoors sequence, XYZ drift
    /// 1.56 → 1.06 % there, 0.49 → 0.39 % on hallways, 0.17 → 0.13 % on aspen, 0.31 % on army
    /// either way) and costs the point cloud (defaults sweep: false points per scene frame
    /// 0.86 → 1.29, Chamfer distance 0.959 → 0.968 m), because one complex ratio cannot tell
    /// a pair's separation from its phase. On real boards it needs the elevation row's gain matched to the line's
    /// ([`crate::ring`], "Real arrays").
    pub ring_split: bool,
    /// Azimuth grid: first and last angle, degrees (the grid size is a const generic).
    pub azimuth_span_deg: (f32, f32),
    /// Elevation grid: first and last angle, degrees.
    pub elevation_span_deg: (f32, f32),
    /// Detection parameters.
    pub cfar: CfarParams,
    /// Elevation peak rules.
    pub elevation: ElevationParams,
}

impl Params {
    /// Defaults for `samples` samples per chirp: range bins `12 ..= N − 3`, Blackman range
    /// window, Hann Doppler window, γ = 0.01, FB averaging, TDM compensation and sub-grid
    /// refinement on, azimuth ±70° (the paper's Table I), elevation ±25°.
    ///
    /// The last kept bin is `N − 3`, not the spec's `N − 2`: the spectrum of a Blackman window
    /// spans bins 0, ±1, ±2 (coefficients 0.42, 0.25, 0.04), so whatever sits at DC before the
    /// window — the ADC's offset, and what DC removal takes out of every off-bin target —
    /// lands in bins `N − 2` and `N − 1` (negative frequencies wrap with complex sampling).
    /// Bin `N − 2` carries −52…−60 dB of every target (measured for targets at bins 13.6 to
    /// 48.5), so a target 60 dB above the noise leaves a ghost there; bin `N − 3` is below
    /// −78 dB. Bins `0..12` are excluded for the same reason and for TX–RX coupling.
    pub const fn defaults(samples: usize) -> Self {
        let last = samples.saturating_sub(3);
        Self {
            range_first: 12,
            range_last: last as u16,
            range_window: WindowKind::Blackman,
            doppler_window: WindowKind::Hann,
            loading: 0.01,
            forward_backward: true,
            spatial_smoothing: false,
            tdm_compensation: true,
            tdm_azimuth_search: 8,
            subgrid: true,
            coherent_doppler_bins: 1.5,
            doppler_test_db: 12.0,
            doppler_agreement_bins: 1.5,
            joint_elevation: false,
            coherent_split: true,
            ring_split: false,
            azimuth_span_deg: (-70.0, 70.0),
            elevation_span_deg: (-25.0, 25.0),
            cfar: CfarParams::RANGE_AZIMUTH,
            elevation: ElevationParams::DEFAULT,
        }
    }

    /// The paper's chain as it describes it: [`Self::defaults`] without the additions of this
    /// crate that change its points (TDM-MIMO compensation, the coherent-target sub-array and
    /// split, the Doppler test and agreement, spatial smoothing, sub-grid refinement, the CFAR
    /// window gate). The CFAR threshold stays the default's: the paper gives none.
    pub const fn paper(samples: usize) -> Self {
        let mut p = Self::defaults(samples);
        p.tdm_compensation = false;
        p.coherent_doppler_bins = 0.0;
        p.doppler_test_db = 0.0;
        p.doppler_agreement_bins = 0.0;
        p.spatial_smoothing = false;
        p.subgrid = false;
        p.joint_elevation = false;
        p.coherent_split = false;
        p.ring_split = false;
        p.cfar.window_gate_db = 0.0;
        p
    }

    /// Every field zero (`false`, `Rectangular`): the parameters of an unconfigured chain,
    /// whose `static` must be all-zero bytes to live in `.bss`.
    pub(crate) const fn zeroed() -> Self {
        Self {
            range_first: 0,
            range_last: 0,
            range_window: WindowKind::Rectangular,
            doppler_window: WindowKind::Rectangular,
            loading: 0.0,
            forward_backward: false,
            spatial_smoothing: false,
            tdm_compensation: false,
            tdm_azimuth_search: 0,
            subgrid: false,
            coherent_doppler_bins: 0.0,
            doppler_test_db: 0.0,
            doppler_agreement_bins: 0.0,
            joint_elevation: false,
            coherent_split: false,
            ring_split: false,
            azimuth_span_deg: (0.0, 0.0),
            elevation_span_deg: (0.0, 0.0),
            cfar: CfarParams::ZEROED,
            elevation: ElevationParams::ZEROED,
        }
    }

    fn validate(&self, samples: usize, az_bins: usize, nel: usize) -> Result<(), ConfigError> {
        validate_bins_and_spans(
            self.range_first,
            self.range_last,
            samples,
            self.azimuth_span_deg,
            self.elevation_span_deg,
        )?;
        finite(f64::from(self.loading), Param::Loading)?;
        if !(self.loading > 0.0) {
            return Err(ConfigError::OutOfRange(Param::Loading));
        }
        finite(
            f64::from(self.coherent_doppler_bins),
            Param::CoherentDoppler,
        )?;
        if !(self.coherent_doppler_bins >= 0.0) {
            return Err(ConfigError::OutOfRange(Param::CoherentDoppler));
        }
        finite(
            f64::from(self.doppler_agreement_bins),
            Param::DopplerAgreement,
        )?;
        if !(self.doppler_agreement_bins >= 0.0) {
            return Err(ConfigError::OutOfRange(Param::DopplerAgreement));
        }
        finite(f64::from(self.doppler_test_db), Param::DopplerTest)?;
        if self.doppler_test_db > 60.0 {
            return Err(ConfigError::OutOfRange(Param::DopplerTest));
        }
        if az_bins < 3 || nel < 3 {
            return Err(ConfigError::OutOfRange(Param::GridSize));
        }
        self.cfar.validate(az_bins, Columns::Truncated)?;
        self.elevation.validate()
    }
}

/// Mutable per-frame state besides the cube: the `f32` snapshots of the range bin in flight,
/// the range–azimuth map and its loading floor, the CFAR scratch and the detection list.
/// Construct it once (it is `const`), reuse it every frame.
#[derive(Clone, Debug)]
pub struct Workspace<
    const N: usize,
    const K: usize,
    const M: usize,
    const NAZ: usize,
    const DET: usize,
> {
    block: Snapshots<K, M>,
    ra: [[f32; NAZ]; N],
    floor: [f32; N],
    skipped_range_bins: u32,
    scratch: [f32; MAX_TRAINING_CELLS],
    detections: Detections<DET>,
    /// Doppler (bins, with sub-bin offset) of each detection's azimuth beam; NaN when unknown.
    beam_doppler: [f32; DET],
}

impl<const N: usize, const K: usize, const M: usize, const NAZ: usize, const DET: usize>
    Workspace<N, K, M, NAZ, DET>
{
    /// A zeroed workspace.
    pub const fn new() -> Self {
        Self {
            block: [[ZERO; K]; M],
            ra: [[0.0; NAZ]; N],
            floor: [0.0; N],
            skipped_range_bins: 0,
            scratch: [0.0; MAX_TRAINING_CELLS],
            detections: Detections::new(),
            beam_doppler: [0.0; DET],
        }
    }

    /// The range–azimuth map of the last frame: `ra[range bin][azimuth bin]`, linear Capon
    /// power; rows outside the processed range window and skipped rows are zero.
    pub fn range_azimuth(&self) -> &[[f32; NAZ]; N] {
        &self.ra
    }

    /// The loading floor `δ_b / AZ` of each row of the range–azimuth map (see [`crate::cfar`]).
    pub fn loading_floor(&self) -> &[f32; N] {
        &self.floor
    }

    /// The CFAR detections of the last frame (`column` = azimuth bin).
    pub fn detections(&self) -> &[Detection] {
        self.detections.as_slice()
    }
}

impl<const N: usize, const K: usize, const M: usize, const NAZ: usize, const DET: usize> Default
    for Workspace<N, K, M, NAZ, DET>
{
    fn default() -> Self {
        Self::new()
    }
}

/// The configured DBE chain: parameters and precomputed tables (`&self` only, never mutated
/// by processing).
///
/// Const generics (the crate's one order): `N` samples per chirp (= range bins), `K` loops
/// per frame, `TX`, `RX`, `M = TX·RX` virtual antennas of which `AZ` form the azimuth line,
/// `NAZ` azimuth and `NEL` elevation grid bins, `DET` detections per frame. With `AZ = M`
/// (no elevation row) the elevation sweep is skipped and every point has ν = 0, labelled with
/// the elevation bin nearest to it.
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
    const DET: usize,
> {
    params: Params,
    layout: ArrayLayout<TX, RX, M>,
    doppler_window: Window<K>,
    az_mu: [f32; NAZ],
    el_nu: [f32; NEL],
    /// `exp(−j·κ·μ_i·az_m)` for every row.
    az_steer: [[Complex32; M]; NAZ],
    /// The azimuth line's phase step of every azimuth bin, `line_phase(az_steer[i])`: the
    /// map's Capon power needs only it ([`LineSpectrum::power_at`]).
    az_line_phase: [Complex32; NAZ],
    /// `exp(−j·κ·ν_j·el_m)` for every row (1 on the azimuth line).
    el_steer: [[Complex32; M]; NEL],
    /// Line phase step per unit μ, `κ·(az_1 − az_0)` (rad): `φ = line_phase_per_mu · μ`.
    line_phase_per_mu: f32,
    /// Phase per unit direction cosine and unit element position, `κ = π·f_c/F_design`.
    kappa: f32,
    range_bin_m: f32,
    doppler_bin_mps: f32,
    /// The centro-symmetric sub-array for coherent targets (empty when the array has none).
    sub: SubArray<M>,
    /// The coherent split's power-iteration start ([`crate::split::start_vector`]).
    split_start: [Complex32; AZ],
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
        const DET: usize,
    > Dbe<N, K, TX, RX, M, AZ, NAZ, NEL, DET>
{
    /// Validate `params` and precompute the tables for frames of `frontend`.
    pub fn new(
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: Params,
    ) -> Result<Self, ConfigError> {
        let mut dbe = Self::unconfigured();
        dbe.configure(frontend, params)?;
        Ok(dbe)
    }

    /// A chain whose every byte is zero, `const`, so that a `static` of it lands in `.bss`
    /// (no flash image, no copy at boot) on firmware; [`Self::configure`] it in place before
    /// use. Unconfigured, it never panics and produces no points.
    pub const fn unconfigured() -> Self {
        Self {
            params: Params::zeroed(),
            layout: ArrayLayout::ZEROED,
            doppler_window: Window::unconfigured(),
            az_mu: [0.0; NAZ],
            el_nu: [0.0; NEL],
            az_steer: [[ZERO; M]; NAZ],
            az_line_phase: [ZERO; NAZ],
            el_steer: [[ZERO; M]; NEL],
            line_phase_per_mu: 0.0,
            kappa: 0.0,
            range_bin_m: 0.0,
            doppler_bin_mps: 0.0,
            sub: SubArray::NONE,
            split_start: [ZERO; AZ],
        }
    }

    /// Validate and compute the tables in place (no chain-sized value on the stack). On error
    /// `self` is unchanged.
    pub fn configure(
        &mut self,
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: Params,
    ) -> Result<(), ConfigError> {
        const {
            assert!(NAZ <= u16::MAX as usize && NEL <= u16::MAX as usize);
        };
        if !frontend.is_configured() {
            return Err(ConfigError::FrontendUnconfigured);
        }
        params.validate(N, NAZ, NEL)?;
        if params.range_window != frontend.range_window() {
            return Err(ConfigError::OutOfRange(Param::RangeWindowKind));
        }
        let waveform = frontend.waveform();
        let layout = *frontend.layout();
        let fc = waveform.center_frequency_hz(N);
        let kappa = (core::f64::consts::PI * fc / frontend.geometry().f_design_hz) as f32;
        self.az_mu = sine_grid::<NAZ>(params.azimuth_span_deg);
        self.el_nu = sine_grid::<NEL>(params.elevation_span_deg);
        for (row, mu) in self.az_steer.iter_mut().zip(self.az_mu.iter()) {
            phase_row(kappa * mu, &layout.az, row);
        }
        for (z, row) in self.az_line_phase.iter_mut().zip(self.az_steer.iter()) {
            *z = line_phase(row);
        }
        for (row, nu) in self.el_steer.iter_mut().zip(self.el_nu.iter()) {
            phase_row(kappa * nu, &layout.el, row);
        }
        self.line_phase_per_mu = match (layout.az.first(), layout.az.get(1)) {
            (Some(a0), Some(a1)) => kappa * (a1 - a0),
            _ => 0.0,
        };
        self.kappa = kappa;
        self.params = params;
        self.layout = layout;
        self.sub = SubArray::of(&layout, AZ);
        self.split_start = start_vector();
        self.doppler_window = Window::new(params.doppler_window);
        self.range_bin_m = frontend.range_bin_m();
        self.doppler_bin_mps = frontend.doppler_bin_mps();
        Ok(())
    }

    /// The cube row order of the frontend the chain was configured from.
    pub fn layout(&self) -> &ArrayLayout<TX, RX, M> {
        &self.layout
    }

    /// The processing parameters.
    pub fn params(&self) -> &Params {
        &self.params
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

    /// The processed range bins `first..=last`.
    fn range_window(&self) -> (usize, usize) {
        let first = usize::from(self.params.range_first);
        let last = usize::from(self.params.range_last).min(N - 1);
        (first, last)
    }

    /// Stage 1 (spec §3 step 1): the range–azimuth map. Per kept range bin: covariance of the
    /// azimuth line, Capon power on the azimuth grid, and the row's loading floor.
    pub fn azimuth_map(&self, frame: &Frame<'_, N, K, M>, work: &mut Workspace<N, K, M, NAZ, DET>) {
        let (first, last) = self.range_window();
        for row in work.ra.iter_mut() {
            *row = [0.0; NAZ];
        }
        work.floor = [0.0; N];
        work.skipped_range_bins = 0;
        // On a host the line's rows are decoded straight into the layout its SIMD covariance
        // sums from (bit-identical to the snapshot block below, one pass instead of two).
        #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
        let (mut split, mut scales) = (
            crate::covariance::SplitRows::<K>::ZERO,
            crate::covariance::zero_split::<K>(),
        );
        #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
        let split_ok = frame.chirp_scales(AZ, &mut scales);
        for b in first..=last {
            let (Some(ra), Some(floor)) = (work.ra.get_mut(b), work.floor.get_mut(b)) else {
                continue;
            };
            // Only the azimuth line's rows are read below.
            #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
            let factor = frame.leading_snapshots_factored(b, AZ, &mut work.block);
            let mut cov = zero::<AZ>();
            #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
            covariance(&work.block[..], &mut cov);
            #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
            let factor = if split_ok {
                frame.leading_split(b, AZ, &scales, &mut split);
                crate::covariance::covariance_of_split(&split, AZ, &mut cov);
                [1.0; M]
            } else {
                let factor = frame.leading_snapshots_factored(b, AZ, &mut work.block);
                covariance(&work.block[..], &mut cov);
                factor
            };
            scale_rows(&mut cov, &factor);
            match self.azimuth_capon(&cov) {
                Some((capon, delta, n)) => {
                    // P(θ) ≥ δ / n: the loading floor of this row (see `cfar`).
                    *floor = delta / n as f32;
                    // The azimuth line is uniform and in position order (`ArrayLayout`).
                    let line = LineSpectrum::leading(&capon, n);
                    // On a host four azimuths at a time in SIMD lanes (bit-identical); on a
                    // Cortex-M (no vector registers) one at a time.
                    #[cfg(not(target_arch = "arm"))]
                    let (ra, phases) = {
                        let mut ra = ra.chunks_exact_mut(LANES);
                        let mut phases = self.az_line_phase.chunks_exact(LANES);
                        for (p, z) in (&mut ra).zip(&mut phases) {
                            let z: &[Complex32; LANES] = z.try_into().unwrap_or(&[ZERO; LANES]);
                            p.copy_from_slice(&line.powers_at(z));
                        }
                        (ra.into_remainder(), phases.remainder())
                    };
                    #[cfg(target_arch = "arm")]
                    let phases = &self.az_line_phase;
                    for (p, &z) in ra.iter_mut().zip(phases.iter()) {
                        *p = line.power_at(z);
                    }
                }
                None => work.skipped_range_bins += 1,
            }
        }
    }

    /// Stage 2 (spec §3 step 2): OS-CFAR on the range–azimuth map, never below a row's
    /// loading floor.
    pub fn detect_targets(&self, work: &mut Workspace<N, K, M, NAZ, DET>) {
        let (first, last) = self.range_window();
        let shape = MapShape {
            first,
            last,
            columns: Columns::Truncated,
        };
        cfar::detect(
            &work.ra,
            Some(&work.floor),
            shape,
            &self.params.cfar,
            &mut work.scratch,
            &mut work.detections,
        );
    }

    /// Stages 3–5 (spec §3 steps 3–5, with TDM compensation): the points of every detection,
    /// and the frame's statistics. Detections come in range order (unless an overflow replaced
    /// some); per run of one range bin the full covariance is formed once, the Doppler of each
    /// detection's azimuth beam is measured, and detections whose Dopplers coincide are
    /// resolved as coherent ([`Params::coherent_doppler_bins`]).
    pub fn resolve<const P: usize>(
        &self,
        frame: &Frame<'_, N, K, M>,
        work: &mut Workspace<N, K, M, NAZ, DET>,
        out: &mut PointCloud<P>,
    ) {
        out.clear();
        out.stats.skipped_range_bins = work.skipped_range_bins;
        out.stats.detections = work.detections.as_slice().len() as u32;
        out.stats.detection_overflow = work.detections.overflow;
        let Workspace {
            block,
            ra,
            detections,
            beam_doppler,
            ..
        } = work;
        let dets = detections.as_slice();
        let test = self.params.doppler_test_db;
        let need_doppler = self.params.tdm_compensation
            || self.params.coherent_doppler_bins > 0.0
            || self.params.doppler_agreement_bins > 0.0
            || test > 0.0;
        let min_ratio = libm::powf(10.0, test / 10.0);
        let mut cov = zero::<M>();
        let mut start = 0;
        while let Some(first) = dets.get(start) {
            let run = dets[start..]
                .iter()
                .take_while(|d| d.range_bin == first.range_bin)
                .count();
            let (group, dopplers) = (
                &dets[start..start + run],
                &mut beam_doppler[start..start + run],
            );
            let factor = frame.leading_snapshots_factored(usize::from(first.range_bin), M, block);
            covariance(&block[..], &mut cov);
            scale_rows(&mut cov, &factor);
            let bin = BinRows {
                rows: &*block,
                factor,
            };
            // The TDM compensation of the run's last tested detection, which its resolution
            // below repeats otherwise (most runs hold one detection).
            let mut last: Option<(usize, Compensation<M, AZ>)> = None;
            for (n, (d, det)) in dopplers.iter_mut().zip(group).enumerate() {
                let i = usize::from(det.column);
                *d = match need_doppler {
                    true => match self.beam_doppler(&cov, &bin, i) {
                        Some(d) if test > 0.0 => {
                            let kept = (n, &mut last);
                            // A failed Doppler test: −∞ (never coherent, no point).
                            match self.doppler_test(&cov, &bin, d, i, min_ratio, kept) {
                                true => d,
                                false => f32::NEG_INFINITY,
                            }
                        }
                        Some(d) => d,
                        None => f32::NAN,
                    },
                    false => f32::NAN,
                };
            }
            for (n, det) in group.iter().enumerate() {
                if dopplers[n] == f32::NEG_INFINITY {
                    out.stats.doppler_rejected += 1;
                    continue;
                }
                let before = out.stats.points + out.stats.point_overflow;
                let coherent = self.coherent(dopplers, n);
                // One detection, or the two of a split merged pair (one call site: the
                // resolution's stack frame exists once).
                let mut targets = [(*det, coherent, None), (*det, true, None)];
                let count = match self.split(&cov, dopplers[n], coherent) {
                    Some(mus) => {
                        for (t, mu) in targets.iter_mut().zip(mus) {
                            let span = self.params.azimuth_span_deg;
                            let column = elevation::nearest_bin::<NAZ>(mu, span);
                            *t = (Detection { column, ..*det }, true, Some(mu));
                        }
                        2
                    }
                    None => 1,
                };
                // A split detection is compensated at its own azimuths.
                let known = match (count, &last) {
                    (1, Some((m, c))) if *m == n => Some(c),
                    _ => None,
                };
                for (d, coherent, at_mu) in &targets[..count] {
                    let doppler = dopplers[n];
                    let (snap, cov) = (&bin, &cov);
                    self.resolve_detection(
                        d, doppler, known, *coherent, *at_mu, snap, cov, ra, out,
                    );
                }
                if out.stats.points + out.stats.point_overflow == before {
                    out.stats.detections_without_point += 1;
                }
            }
            start += run;
        }
        if self.params.joint_elevation && AZ < M {
            self.joint_elevations(frame, block, out.points_mut());
        }
    }

    /// The joint elevation fit ([`crate::joint`]) of the frame's `points`, range bin by range
    /// bin: the sources of bin `b` are its own points and those of the bins within
    /// [`joint::NEIGHBOUR_BINS`] (their returns leak into `b` through the range window's main
    /// lobe), at most [`MAX_SOURCES`], each with the TDM slot phase of its own Doppler, on
    /// the raw covariance of `b`; its own points keep range and azimuth and get the fitted
    /// elevation (bin, and with sub-grid refinement its offset).
    fn joint_elevations(
        &self,
        frame: &Frame<'_, N, K, M>,
        block: &mut Snapshots<K, M>,
        points: &mut [Point],
    ) {
        let mut cov = zero::<M>();
        let mut start = 0;
        while let Some(first) = points.get(start) {
            let b = first.range_bin;
            let own = points[start..]
                .iter()
                .take_while(|p| p.range_bin == b)
                .count();
            let mut member = [0usize; MAX_SOURCES];
            let mut n = 0;
            for k in start..start + own {
                if let Some(slot) = member.get_mut(n) {
                    *slot = k;
                }
                n += 1;
            }
            for gap in 1..=NEIGHBOUR_BINS {
                for (k, p) in points.iter().enumerate() {
                    if p.range_bin.abs_diff(b) == gap && n < MAX_SOURCES {
                        member[n] = k;
                        n += 1;
                    }
                }
            }
            if (2..=MAX_SOURCES).contains(&n) {
                let mut sources = [Source {
                    base: [ZERO; M],
                    bin: 0,
                    frac: 0.0,
                }; MAX_SOURCES];
                for (s, &k) in sources.iter_mut().zip(member.iter()).take(n) {
                    *s = self.joint_source(&points[k]);
                }
                frame.snapshots(usize::from(b), block);
                covariance(&block[..], &mut cov);
                let refine = self.params.subgrid;
                joint::fit(&cov, &self.el_steer, &mut sources[..n], SWEEPS, refine);
                for (s, &k) in sources.iter().zip(member.iter()).take(own) {
                    self.set_elevation(&mut points[k], s);
                }
            }
            start += own;
        }
    }

    /// A point as a source of the joint fit: azimuth row at its μ times the conjugate TDM
    /// rotation of its own Doppler (within the agreement window of its beam's, a phase error
    /// of at most 2π·1.5·(TX − 1)/(K·TX) on the last slot), started at its elevation bin.
    fn joint_source(&self, p: &Point) -> Source<M> {
        let (_, mu) = range_and_mu(p).unwrap_or((0.0, 0.0));
        let rot = match self.params.tdm_compensation && self.doppler_bin_mps != 0.0 {
            true => {
                tdm::rotation::<K, TX, M>(&self.layout.slot, p.velocity_mps / self.doppler_bin_mps)
            }
            false => [ONE; M],
        };
        let mut base = [ZERO; M];
        phase_row(self.kappa * mu, &self.layout.az, &mut base);
        for (b, r) in base.iter_mut().zip(rot.iter()) {
            *b *= r.conj();
        }
        Source {
            base,
            bin: usize::from(p.elevation_bin),
            frac: 0.0,
        }
    }

    /// Give `p` the elevation of the fitted source `s`, keeping its range and azimuth.
    fn set_elevation(&self, p: &mut Point, s: &Source<M>) {
        let Some((range, mu)) = range_and_mu(p) else {
            return;
        };
        let nu = match self.params.subgrid {
            true => sine_at(self.params.elevation_span_deg, NEL, s.bin as f32 + s.frac),
            false => self.el_nu[s.bin.min(NEL - 1)],
        };
        if let Some(q) = Point::at(range, mu, nu) {
            p.position = q.position;
            p.elevation_bin = s.bin as u16;
        }
    }

    /// The two azimuths (direction cosines) of a coherent pair merged into one detection
    /// whose beam Doppler is `d`, on the line block of the bin's covariance `cov` rotated by
    /// `d` ([`crate::split`]); `None` when off, already coherent, or not a pair.
    fn split(&self, cov: &Matrix<M>, d: f32, coherent: bool) -> Option<[f32; 2]> {
        // The split's detections take the coherent path: off with it.
        let on = self.params.coherent_split && self.params.coherent_doppler_bins > 0.0;
        if !on || coherent || !d.is_finite() || self.sub.is_empty() {
            return None;
        }
        // Only the line block is read: rotate that alone.
        let mut line = leading_block::<M, AZ>(cov);
        if self.params.tdm_compensation {
            let rotation = tdm::rotation::<K, TX, M>(&self.layout.slot, d);
            rotate_rows(&mut line, &azimuth_part::<M, AZ>(&rotation));
        }
        split_line_from(&line, self.line_phase_per_mu, &self.split_start)
    }

    /// Whether detection `n` of a range bin's run shares its beam Doppler with another
    /// detection of the run, within [`Params::coherent_doppler_bins`] (modulo `K`), and the
    /// array has a centro-symmetric sub-array to resolve them on.
    fn coherent(&self, dopplers: &[f32], n: usize) -> bool {
        let window = self.params.coherent_doppler_bins;
        let Some(&mine) = dopplers.get(n) else {
            return false;
        };
        if self.sub.is_empty() || !(window > 0.0) || !mine.is_finite() {
            return false;
        }
        dopplers
            .iter()
            .enumerate()
            .any(|(m, &d)| m != n && doppler_gap::<K>(d, mine) < window)
    }

    /// The Doppler (bins, with its sub-bin offset) of the azimuth Capon beam of bin `i` on the
    /// uncompensated covariance: what TDM compensation rotates by, the coherence test's
    /// measure and what every point of the detection must agree with
    /// ([`Params::doppler_agreement_bins`]). `None` when the azimuth covariance is not
    /// positive definite.
    fn beam_doppler(&self, cov: &Matrix<M>, snap: &BinRows<'_, K, M>, i: usize) -> Option<f32> {
        let (az, _, n) = self.azimuth_capon(&leading_block(cov))?;
        let w = az.weight(&Self::line_part(self.az_steer.get(i)?, n));
        let mut y = [ZERO; K];
        beamform(&w, snap, &[ONE; AZ], &mut y);
        // The fractional Doppler: the integer bin alone leaves up to half a bin of slot phase,
        // an elevation bias of up to 0.22° on ColoRadar's waveform (tests/pipeline.rs).
        let peak = doppler_peak(&mut y, &self.doppler_window);
        Some(f32::from(peak.bin) + peak.offset)
    }

    /// The Doppler test ([`Params::doppler_test_db`]) of the detection at azimuth bin `i` whose
    /// beam Doppler is `d`: whether the peak-to-median ratio of the Doppler spectrum of its
    /// azimuth Capon beam, after TDM compensation by `d` and the climb to the compensated peak
    /// when compensation is on, reaches `min_ratio`. (Uncompensated, the beam of a target
    /// moving at 1.6 m/s is steered where the target's slot phases do not point, and MVDR
    /// cancels it.) Passed when the compensated covariance is not positive definite: the test
    /// rejects only what it measured.
    fn doppler_test(
        &self,
        cov: &Matrix<M>,
        snap: &BinRows<'_, K, M>,
        d: f32,
        i: usize,
        min_ratio: f32,
        (n, kept): (usize, &mut Option<(usize, Compensation<M, AZ>)>),
    ) -> bool {
        let uncompensated;
        let (rot, i, line) = match self.params.tdm_compensation {
            true => {
                // The climb's solver of the compensated line serves the beam too.
                let mut r = *cov;
                let (_, c) = kept.insert((n, self.compensate_tdm(&mut r, d, i)));
                (&c.rotation, c.azimuth_bin, &c.line)
            }
            false => {
                uncompensated = self
                    .azimuth_capon(&leading_block(cov))
                    .map(|(az, _, n)| (az, n));
                (&[ONE; M], i, &uncompensated)
            }
        };
        let (Some((az, n)), Some(steer)) = (line, self.az_steer.get(i)) else {
            return true;
        };
        let w = az.weight(&Self::line_part(steer, *n));
        let mut y = [ZERO; K];
        beamform(&w, snap, &azimuth_part::<M, AZ>(rot), &mut y);
        let peak = doppler_peak(&mut y, &self.doppler_window);
        passes_peak_to_median(&y, peak.power, min_ratio)
    }

    /// Whether a point's Doppler `d` (bins, with its sub-bin offset) lies within
    /// [`Params::doppler_agreement_bins`] of its detection's beam Doppler `beam` (circular
    /// distance modulo `K`); always true when the rule is off or `beam` was not measured.
    fn agrees(&self, d: f32, beam: f32) -> bool {
        let window = self.params.doppler_agreement_bins;
        if !(window > 0.0) || !beam.is_finite() {
            return true;
        }
        doppler_gap::<K>(d, beam) <= window
    }

    /// Capon solver of the azimuth line's covariance (spatial smoothing and FB averaging if
    /// on, loading): the solver, the loading `δ` and the number of line elements it spans
    /// (`AZ`, or `AZ − 1` smoothed; steering vectors must be zero beyond, [`Self::line_part`]).
    fn azimuth_capon(&self, cov: &Matrix<AZ>) -> Option<(Capon<AZ>, f32, usize)> {
        let mut r = *cov;
        let (n, delta) = if self.params.spatial_smoothing {
            smooth_line(&mut r, self.params.forward_backward, self.params.loading)
        } else {
            if self.params.forward_backward {
                forward_backward(&mut r);
            }
            (AZ, load_diagonal(&mut r, self.params.loading))
        };
        Capon::new(&r).map(|c| (c, delta, n))
    }

    /// The azimuth line's part of a full-array steering row, zero beyond the `n` elements
    /// the azimuth solver spans.
    fn line_part(row: &[Complex32; M], n: usize) -> [Complex32; AZ] {
        let mut a = azimuth_part::<M, AZ>(row);
        for v in a.iter_mut().skip(n) {
            *v = ZERO;
        }
        a
    }

    /// Capon power of azimuth bin `i` on the azimuth solver `az` of `n` elements (0 off the
    /// grid).
    fn azimuth_power(&self, az: &Capon<AZ>, n: usize, i: usize) -> f32 {
        match self.az_steer.get(i) {
            Some(s) => az.power(&Self::line_part(s, n)),
            None => 0.0,
        }
    }

    /// Elevation, Doppler and points of one detection whose azimuth beam has Doppler
    /// `beam_doppler` (bins), on the full array or, when `coherent`, on the FB-averaged
    /// centro-symmetric sub-array; `at_mu`: the azimuth of a split detection
    /// ([`Params::coherent_split`]), kept as it is (no climb, no sub-grid refinement);
    /// `known`: its TDM compensation when the Doppler test has computed it.
    #[allow(clippy::too_many_arguments)] // one call site; the stages' inputs, spelled out
    fn resolve_detection<const P: usize>(
        &self,
        det: &Detection,
        beam_doppler: f32,
        known: Option<&Compensation<M, AZ>>,
        coherent: bool,
        at_mu: Option<f32>,
        snap: &BinRows<'_, K, M>,
        cov: &Matrix<M>,
        ra: &[[f32; NAZ]; N],
        out: &mut PointCloud<P>,
    ) {
        let b = usize::from(det.range_bin);
        let mut i = usize::from(det.column).min(NAZ - 1);
        // Sub-grid offsets: range from the RA map's column, azimuth from the spectrum the
        // final azimuth bin was chosen on (replaced when TDM compensation re-estimates).
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
        let line = if self.params.tdm_compensation {
            if !beam_doppler.is_finite() {
                return;
            }
            let c = match known {
                // The Doppler test's: the same covariance, Doppler and bin.
                Some(c) if usize::from(det.column) == i => {
                    rotate_rows(&mut r, &c.rotation);
                    *c
                }
                _ => self.compensate_tdm(&mut r, beam_doppler, i),
            };
            rot = c.rotation;
            // A split detection keeps its fitted azimuth: the compensated spectrum's climb
            // would lead it back to the merged peak.
            if at_mu.is_none() {
                i = c.azimuth_bin;
                az_frac = c.azimuth_frac.unwrap_or(az_frac);
            }
            c.line
        } else if self.params.subgrid {
            self.azimuth_capon(&leading_block(&r))
                .map(|(az, _, n)| (az, n))
        } else {
            None
        };

        // Elevation sweep on the full array without FB averaging, or for coherent targets
        // on the FB-averaged sub-array (steering vectors and weights restricted to it). An
        // array without an elevation row is its azimuth line, whose FB averaging (as on the
        // range–azimuth map) keeps the Doppler weight of one of two coherent targets from
        // cancelling it.
        let sub = coherent.then_some(&self.sub);
        match sub {
            Some(sub) => r = sub.covariance(&r, self.params.loading),
            None => {
                if AZ == M && self.params.forward_backward {
                    forward_backward(&mut r);
                }
                let _ = load_diagonal(&mut r, self.params.loading);
            }
        }
        let Some(el) = Capon::<M>::new(&r) else {
            return;
        };
        let restrict = |a: [Complex32; M]| sub.map_or(a, |sub| sub.restrict(&a));
        let steer = |j: usize| restrict(elevation::steering(&self.az_steer[i], &self.el_steer[j]));
        // The steering vectors are `a_lo + t_j·a_hi` (the line's and the elevation row's
        // parts, `t_j` the row's factor of bin `j`): the spectrum in closed form.
        let (mut a_lo, mut a_hi) = (self.az_steer[i], self.az_steer[i]);
        for (m, (lo, hi)) in a_lo.iter_mut().zip(a_hi.iter_mut()).enumerate() {
            *if m < AZ { hi } else { lo } = ZERO;
        }
        let spectrum = elevation::TwoLevel::new(&el, &restrict(a_lo), &restrict(a_hi));
        let mut s = [0.0f32; NEL];
        let peaks = if AZ < M {
            elevation::sweep(
                &spectrum,
                |j| self.el_steer[j][AZ],
                &self.params.elevation,
                &mut s,
            )
        } else {
            // No elevation row (`a_hi = 0`): one direction, on the line (ν = 0, the bin
            // nearest to it).
            let j = usize::from(elevation::nearest_bin::<NEL>(
                0.0,
                self.params.elevation_span_deg,
            ));
            let mut one: elevation::Peaks = Default::default();
            one[0] = Some((j, spectrum.power_at(ONE)));
            one
        };

        // Capon-weighted Doppler and the point per elevation peak.
        let subgrid = self.params.subgrid;
        let (mu, range) = if subgrid {
            (
                at_mu.unwrap_or_else(|| self.refined_mu(line.as_ref(), i, az_frac)),
                (b as f32 + range_frac) * self.range_bin_m,
            )
        } else {
            (self.az_mu[i], b as f32 * self.range_bin_m)
        };
        let snr_db = ratio_db(det.power, det.level);
        for &(j, power) in peaks.iter().flatten() {
            let nu = if AZ == M {
                0.0
            } else if subgrid {
                // The exact peak of the sinusoid, within half a bin of the grid peak.
                let span = self.params.elevation_span_deg;
                let (lo, hi) = (
                    sine_at(span, NEL, j as f32 - 0.5),
                    sine_at(span, NEL, j as f32 + 0.5),
                );
                let kappa_delta = self.kappa_delta();
                spectrum.peak_nu(kappa_delta, self.el_nu[j], lo.min(hi), lo.max(hi))
            } else {
                self.el_nu[j]
            };
            let Some(point) = Point::at(range, mu, nu) else {
                continue;
            };
            let w = el.weight(&steer(j));
            let w = sub.map_or(w, |sub| sub.expand(&w));
            let mut y = [ZERO; K];
            beamform(&w, snap, &rot, &mut y);
            let peak = doppler_peak(&mut y, &self.doppler_window);
            let fractional = f32::from(peak.bin) + peak.offset;
            if !self.agrees(fractional, beam_doppler) {
                continue;
            }
            let doppler = if subgrid {
                fractional
            } else {
                f32::from(peak.bin)
            };
            // One point, or the two of a vertical surface's range ring.
            let half = match self.params.ring_split && AZ < M && sub.is_none() {
                true => self.ring_half(snap, &rot, fractional, mu),
                false => None,
            };
            // About the horizon, where a ring's two returns sit (`crate::ring`, "Centre").
            let pair = half.map(|h| [-h, h]);
            let at = |nu: f32| {
                let span = self.params.elevation_span_deg;
                Point::at(range, mu, nu).map(|p| (p, elevation::nearest_bin::<NEL>(nu, span)))
            };
            let points = match pair {
                Some([lo, hi]) => [at(lo), at(hi)],
                None => [Some((point, j as u16)), None],
            };
            for (point, j) in points.into_iter().flatten() {
                out.push(Point {
                    velocity_mps: doppler * self.doppler_bin_mps,
                    power_db: power_db(power),
                    snr_db,
                    range_bin: det.range_bin,
                    azimuth_bin: i as u16,
                    elevation_bin: j,
                    doppler_bin: peak.bin,
                    ..point
                });
            }
        }
    }

    /// `κ·Δ`: the elevation phase per unit `ν` between the elevation row and the line (0 on
    /// an array without a row).
    fn kappa_delta(&self) -> f32 {
        self.kappa * self.layout.el[AZ.min(M - 1)]
    }

    /// The half-separation in `ν` of a ring pair ([`crate::ring`]) at azimuth `mu` whose
    /// Doppler is `doppler` (bins, fractional), or `None`: every antenna's slow time
    /// (rotated by the TDM compensation `rot`) windowed and transformed at the Doppler,
    /// de-steered to `mu`. Not inlined: its transform kernel (`K` values) is on the stack
    /// only while it runs, never in the frame of a chain that has the split off.
    #[inline(never)]
    fn ring_half(
        &self,
        snap: &BinRows<'_, K, M>,
        rot: &[Complex32; M],
        doppler: f32,
        mu: f32,
    ) -> Option<f32> {
        // The windowed transform kernel once, then one dot product per antenna.
        let step = Complex32::from_polar(1.0, -core::f32::consts::TAU * doppler / K as f32);
        let mut kernel = [ZERO; K];
        let mut phasor = ONE;
        for (e, w) in kernel
            .iter_mut()
            .zip(self.doppler_window.coefficients().iter())
        {
            *e = phasor * *w;
            phasor *= step;
        }
        let mut t = [ZERO; M];
        for (m, ((tm, xm), f)) in t
            .iter_mut()
            .zip(snap.rows.iter())
            .zip(snap.factor.iter())
            .enumerate()
        {
            let (mut re, mut im) = (0.0f32, 0.0f32);
            for (x, e) in xm.iter().zip(kernel.iter()) {
                re += x.re * e.re - x.im * e.im;
                im += x.re * e.im + x.im * e.re;
            }
            let desteer = Complex32::from_polar(1.0, self.kappa * mu * self.layout.az[m]);
            *tm = Complex32::new(re, im) * *f * rot[m] * desteer;
        }
        let kappa_delta = libm::fabsf(self.kappa_delta());
        ring::half_phase(&t, AZ)
            .map(|h| h / kappa_delta)
            .filter(|h| h.is_finite())
    }

    /// The sub-grid μ of azimuth bin `i`: the peak of the azimuth line's Capon spectrum
    /// ([`LineSpectrum::peak_phase`]) within half a bin of `i`, started from the log-parabola
    /// offset `frac`; the log-parabola's own μ without a positive-definite line of ≥ 2 elements.
    fn refined_mu(&self, line: Option<&(Capon<AZ>, usize)>, i: usize, frac: f32) -> f32 {
        let span = self.params.azimuth_span_deg;
        let start = sine_at(span, NAZ, i as f32 + frac);
        let k = self.line_phase_per_mu;
        match line {
            Some((az, n)) if *n > 1 && k != 0.0 => {
                let (a, b) = (
                    k * sine_at(span, NAZ, i as f32 - 0.5),
                    k * sine_at(span, NAZ, i as f32 + 0.5),
                );
                LineSpectrum::leading(az, *n).peak_phase(k * start, a.min(b), a.max(b)) / k
            }
            _ => start,
        }
    }

    /// TDM-MIMO motion compensation of one detection at azimuth bin `i` (see [`crate::tdm`])
    /// whose azimuth beam has Doppler `d` (bins, [`Self::beam_doppler`]): the rotation of `r`
    /// by it, and the azimuth re-estimated uphill on the compensated spectrum (at most
    /// `tdm_azimuth_search` bins).
    #[inline(always)]
    fn compensate_tdm(&self, r: &mut Matrix<M>, d: f32, i: usize) -> Compensation<M, AZ> {
        let rotation = tdm::rotation::<K, TX, M>(&self.layout.slot, d);
        rotate_rows(r, &rotation);
        let mut c = Compensation {
            rotation,
            azimuth_bin: i,
            azimuth_frac: None,
            line: None,
        };
        if let Some((az, _, n)) = self.azimuth_capon(&leading_block(r)) {
            let i = self.climb_azimuth(&az, n, i);
            let power = |i: usize| self.azimuth_power(&az, n, i);
            c.azimuth_bin = i;
            c.azimuth_frac = Some(parabolic_offset(
                power(i.wrapping_sub(1)),
                power(i),
                power(i + 1),
            ));
            c.line = Some((az, n));
        }
        c
    }

    /// Move from azimuth bin `i` uphill on the Capon spectrum of `az`, at most
    /// `tdm_azimuth_search` bins.
    fn climb_azimuth(&self, az: &Capon<AZ>, n: usize, mut i: usize) -> usize {
        let power = |i: usize| az.power(&Self::line_part(&self.az_steer[i], n));
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

/// `row[m] = exp(−j·k·pos_m)`: a steering row for phase `k` per unit position (κ times a
/// direction cosine), written in place (the steering tables are filled row by row).
///
/// Elements at one position (the elevation row's azimuths repeat the line's; all line elements
/// share one elevation) get the value of the first of them, copied: the same `f32` argument
/// gives the same value, and `libm`'s `sinf`/`cosf` work in `f64`, software on a Cortex-M4F,
/// so the ColoRadar tables take half the evaluations (issue 13: setup 9.5 M → 6.5 M
/// instructions on the Cortex-M4F).
fn phase_row<const M: usize>(k: f32, pos: &[f32; M], row: &mut [Complex32; M]) {
    for m in 0..M {
        let p = pos[m];
        row[m] = match pos[..m].iter().position(|q| q.to_bits() == p.to_bits()) {
            Some(first) => row[first],
            None => Complex32::from_polar(1.0, -k * p),
        };
    }
}

/// A point's range and azimuth direction cosine `μ = −y/r`; `None` at the origin.
fn range_and_mu(p: &Point) -> Option<(f32, f32)> {
    let range = p.position.length();
    (range > 0.0).then(|| (range, -p.position.y / range))
}

/// What TDM compensation decided for one detection.
#[derive(Clone, Copy)]
struct Compensation<const M: usize, const AZ: usize> {
    /// Per-row rotation applied to the covariance (and to the slow time before Doppler).
    rotation: [Complex32; M],
    /// Azimuth bin after the climb on the compensated spectrum.
    azimuth_bin: usize,
    /// Sub-grid azimuth offset on the compensated spectrum (`None`: keep the map's).
    azimuth_frac: Option<f32>,
    /// The compensated azimuth line's solver and the elements it spans (`None`: not positive
    /// definite), as the climb used it.
    line: Option<(Capon<AZ>, usize)>,
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
        const DET: usize,
    > Chain<N, K, TX, RX, M, AZ> for Dbe<N, K, TX, RX, M, AZ, NAZ, NEL, DET>
{
    const NAME: &'static str = "dbe";
    const STAGES: [&'static str; 3] = ["azimuth_capon", "cfar", "elevation_doppler"];
    type Params = Params;
    type Workspace = Workspace<N, K, M, NAZ, DET>;

    fn configure(
        &mut self,
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: Params,
    ) -> Result<(), ConfigError> {
        Dbe::configure(self, frontend, params)
    }

    fn map(&self, frame: &Frame<'_, N, K, M>, work: &mut Self::Workspace) {
        self.azimuth_map(frame, work);
    }

    fn detect(&self, work: &mut Self::Workspace) {
        self.detect_targets(work);
    }

    fn points<const P: usize>(
        &self,
        frame: &Frame<'_, N, K, M>,
        work: &mut Self::Workspace,
        out: &mut PointCloud<P>,
    ) {
        self.resolve(frame, work, out);
    }

    fn detections(work: &Self::Workspace) -> &[Detection] {
        work.detections()
    }
}

/// The circular distance (bins, modulo `K`) of two Dopplers in `−K/2 ..= K/2` (a signed bin
/// plus a sub-bin offset), for which one wrap suffices. (No `%`: the f32 remainder links
/// compiler_builtins' `fmodf`, whose unwind tables break the C API's host link.)
fn doppler_gap<const K: usize>(a: f32, b: f32) -> f32 {
    let gap = libm::fabsf(a - b);
    gap.min(libm::fabsf(K as f32 - gap))
}

/// One range bin's snapshots as [`Frame::leading_snapshots_factored`] decodes them: row `m`
/// is `rows[m] · factor[m]` (`factor[m]` a power of two, 1 where the row was decoded as it is).
#[derive(Clone, Copy, Debug)]
struct BinRows<'a, const K: usize, const M: usize> {
    rows: &'a Snapshots<K, M>,
    factor: [f32; M],
}

/// `y[k] = Σ_m conj(w_m) · rot_m · x_m[k]` over the first `D` rows of `snap`.
fn beamform<const D: usize, const M: usize, const K: usize>(
    w: &[Complex32; D],
    snap: &BinRows<'_, K, M>,
    rot: &[Complex32; D],
    y: &mut [Complex32; K],
) {
    *y = [ZERO; K];
    for (((wm, rm), xm), f) in w
        .iter()
        .zip(rot.iter())
        .zip(snap.rows.iter())
        .zip(snap.factor.iter())
    {
        // `x_m = rows[m] · f_m` with `f_m` a power of two: scaling the coefficient instead
        // of the row gives the same products bit for bit.
        let c = wm.conj() * rm * *f;
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
