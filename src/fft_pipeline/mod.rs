//! The FFT baseline chain (spec §4): the classic single-chip processing the paper compares
//! DBE against, on the same cube and with the same [`Point`] output.
//!
//! ```text
//! Frontend      : DC removal, window, range FFT ──▶ Cube ──▶ Frame          (as the DBE chain)
//! doppler_map   : for each kept range bin b, for each row m
//!                    K-point scratch ← window · cube[b][m]; FFT
//!                    RD[b][d] += |scratch[d]|²                         (non-coherent sum)
//! detect_targets: CA- or OS-CFAR on RD (Doppler periodic) + 3×3 local max   (cfar.rs)
//! angles        : per detection (b, d):
//!                    x_m = Σ_k w_k·cube[b][m][k]·e^{−j2πdk/K}          (single-bin DFT)
//!                    x_m ·= e^{−j·4π·v·t_m·Tc/λ}, v of d + its sub-bin offset  (tdm.rs)
//!                    azimuth: beamscan |aᴴx|² of the line on the μ grid → peak i
//!                    elevation: ψ = arg Σ x_line(a)·x_el(a)*, ν = ψ / (κ·Δel)  (elevation.rs)
//!                    Point::at(range, μ, ν)                            (points.rs)
//! ```
//!
//! # Input
//!
//! The [`Frame`] of the shared [`Frontend`] (DC removal, range window, unnormalised range
//! FFT, optional coupling subtraction, rows in [`ArrayLayout`] order): both chains run on one
//! frame, which is how they are compared.
//!
//! # Memory and layout
//!
//! The range–Doppler (RD) map is the only frame-sized buffer of this chain: `N · K` `f32` in
//! [`FftWorkspace`] (`N·K·4` bytes: 64 KiB for ColoRadar, 64 KiB for the IWR6843 fixture).
//! No Doppler cube is kept. The Doppler FFTs run per range bin and row into one `K`-point
//! scratch on the stack (`K·8` bytes), which is accumulated into the RD row and discarded:
//! each of the `(range_last − range_first + 1) · M` Doppler FFTs is computed exactly once.
//! After the CFAR, a detection needs the complex Doppler value of its cell for every row;
//! that is one DFT bin per row, recomputed from the cube as a `K`-term sum against a
//! `K`-entry twiddle table (`M·K` complex multiply–adds per detection, 1,536 for ColoRadar,
//! less than four 128-point FFTs). Keeping the Doppler spectra instead would cost `N·M·K·8`
//! bytes (1.5 MiB) or transforming the cube in place, which would destroy the range-FFT
//! cube the DBE chain needs; recomputing 12 FFTs per detected range bin would cost
//! `12 · (K/2)·log₂K` butterflies, more than the single bins unless a range bin holds more
//! than three detections.
//!
//! # Detection
//!
//! 2-D CFAR on the RD map ([`crate::cfar`], the DBE chain's detector with periodic columns):
//! cell averaging by default (the classic chain, as TI's
//! mmWave SDK `CFAR-CA`), ordered statistic selectable; the Doppler axis wraps (it is
//! periodic, and the 0 m/s ridge of static clutter sits at the FFT's wrap), the range axis is
//! truncated at the processed window; a 3×3 local maximum keeps one detection per target.
//!
//! # Angles
//!
//! Azimuth is a beamscan (Bartlett, the DFT of the 8-element line without taper) evaluated
//! on the same `NAZ`-bin μ grid as the DBE chain (±70°, 188 bins by default), so both chains
//! report on identical bins: [`Point::azimuth_bin`] means the same angle in both clouds.
//! This is the only azimuth estimator offered. A 64-point zero-padded FFT would be cheaper
//! (192 butterflies vs `NAZ·AZ` = 1,504 multiply–adds per detection, both small next to the
//! frame's Doppler FFTs) but samples μ every `2π/(64·κ)` ≈ 0.031, i.e. 1.8° at boresight and
//! 5.2° at 70°, while the default grid steps 140°/187 = 0.75° everywhere; and its bins would
//! not line up with the DBE chain's. A peak at either end of the grid means the target lies
//! outside the span: the detection gives no point.
//!
//! Elevation is the phase of `Σ x_line(a) · conj(x_el(a))` over the pairs of an
//! elevation-row element and the azimuth-line element at the same azimuth position `a`
//! (ColoRadar: elevation row az 2..5 at el 1, paired with line elements az 2..5). With the
//! spec §2 steering vector each product is `|s|²·e^{jκ·ν·Δel}`, so `ν = ψ / (κ·Δel)`,
//! unambiguous for `|ν| < π/(κ·Δel)` (0.99 for ColoRadar). ν is continuous; the point's
//! position uses it as is and [`Point::elevation_bin`] is only the nearest bin of the DBE
//! chain's `NEL`-bin elevation grid, clamped to its ends (an elevation outside the span is
//! still reported, at its true angle). Accuracy: with per-element SNR ρ of the detection
//! cell and `P` pairs, `σ_ν = sqrt(1/(P·ρ) + 1/(2·P·ρ²)) / (κ·Δel)`, e.g. 0.028 (1.6° at
//! boresight) at ρ = 15 dB for ColoRadar; `tests/fft_pipeline.rs` derives it and checks it.
//!
//! TDM-MIMO compensation multiplies row `m` (TX slot `t_m`) by `exp(−j·4π·v·t_m·Tc/λ)` with
//! the detection's Doppler `v = d'·λ/(2·K·TX·Tc)`, i.e. `exp(−j·2π·d'·t_m/(K·TX))`, where
//! `d'` is the detection's signed bin plus its sub-bin offset on the RD map (the integer bin
//! alone leaves up to half a bin of slot phase, an elevation bias of up to 0.2°). Without
//! it a moving target's slot-dependent phase biases both angles: for ColoRadar the elevation
//! row (slot 2) is paired with line elements of slots 0 and 1, so ν is off by about
//! `−2π·f·1.5/(K·TX·κ·Δel)` (f the Doppler in bins): −0.20 (−11.5°) at 1 m/s.
//!
//! # Output
//!
//! One point per detection: `x, y, z` from the detection's range bin, the grid μ and the
//! continuous ν (spec §2); velocity `d'·λ/(2·K·T_loop)`; `power_db` = 10·log10 of the RD
//! power (sum over the `M` rows of `|X|²`, unnormalised range and Doppler FFTs of ADC units,
//! so not comparable in absolute terms with the DBE chain's Capon power); `snr_db` = RD power
//! over the CFAR noise level; bins as in the DBE chain. [`FrameStats::skipped_range_bins`]
//! is always 0 here (nothing can fail per range bin).
//!
//! [`FrameStats::skipped_range_bins`]: crate::FrameStats::skipped_range_bins

use num_complex::Complex32;

use crate::cfar::{self, CfarParams, Columns, Detection, Detections, MapShape, MAX_TRAINING_CELLS};
use crate::chain::Chain;
use crate::config::{sine_at, sine_grid, validate_bins_and_spans, ArrayLayout, ConfigError, Param};
use crate::cube::{Frame, Snapshots};
use crate::doppler::signed_bin;
use crate::elevation;
use crate::fft::fft_from;
use crate::frontend::Frontend;
use crate::pipeline::Params;
use crate::points::{power_db, ratio_db, Point, PointCloud};
use crate::refine::{parabolic_offset, power_offset};
use crate::tdm;
use crate::window::WindowKind;

const ZERO: Complex32 = Complex32::new(0.0, 0.0);

/// Processing parameters of the FFT chain (defaults of spec §4 and the DBE chain's windows).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FftParams {
    /// First range bin processed (inclusive).
    pub range_first: u16,
    /// Last range bin processed (inclusive); at most `N − 1`.
    pub range_last: u16,
    /// Range window applied before the range FFT: the [`Frontend`]'s, which
    /// [`FftChain::configure`] checks.
    pub range_window: WindowKind,
    /// Slow-time window applied before the Doppler FFT (default Hann).
    pub doppler_window: WindowKind,
    /// TDM-MIMO phase compensation of each detection before the angle stages (default on).
    pub tdm_compensation: bool,
    /// Azimuth grid: first and last angle, degrees (the grid size is a const generic).
    pub azimuth_span_deg: (f32, f32),
    /// Elevation grid used to label points with the nearest elevation bin, degrees.
    pub elevation_span_deg: (f32, f32),
    /// Sub-grid refinement of range, azimuth and Doppler (see [`crate::refine`]); the
    /// phase-difference elevation is continuous already.
    pub subgrid: bool,
    /// Detection parameters (the column axis is the periodic Doppler axis; `edge_skip` is
    /// not used).
    pub cfar: CfarParams,
}

impl FftParams {
    /// Defaults for `samples` samples per chirp: range bins `12 ..= N − 3`, Blackman range and
    /// Hann Doppler windows, TDM compensation on, azimuth ±70°, elevation ±25° (all as the
    /// DBE chain's [`Params::defaults`]), CA-CFAR ([`CfarParams::RANGE_DOPPLER_CA`]).
    pub const fn defaults(samples: usize) -> Self {
        Self::from_dbe(&Params::defaults(samples))
    }

    /// The FFT chain matching a DBE configuration: same range window and bins, Doppler
    /// window, TDM switch and angle grids (so both clouds use identical bins), default CFAR.
    pub const fn from_dbe(p: &Params) -> Self {
        Self {
            range_first: p.range_first,
            range_last: p.range_last,
            range_window: p.range_window,
            doppler_window: p.doppler_window,
            tdm_compensation: p.tdm_compensation,
            azimuth_span_deg: p.azimuth_span_deg,
            elevation_span_deg: p.elevation_span_deg,
            subgrid: p.subgrid,
            cfar: CfarParams::RANGE_DOPPLER_CA,
        }
    }

    /// Every field zero: the parameters of an unconfigured chain (all-zero bytes).
    const ZEROED: Self = Self {
        range_first: 0,
        range_last: 0,
        range_window: WindowKind::Rectangular,
        doppler_window: WindowKind::Rectangular,
        tdm_compensation: false,
        azimuth_span_deg: (0.0, 0.0),
        elevation_span_deg: (0.0, 0.0),
        subgrid: false,
        cfar: CfarParams::ZEROED,
    };

    fn validate(&self, samples: usize, loops: usize, nel: usize) -> Result<(), ConfigError> {
        validate_bins_and_spans(
            self.range_first,
            self.range_last,
            samples,
            self.azimuth_span_deg,
            self.elevation_span_deg,
        )?;
        if nel < 3 {
            return Err(ConfigError::OutOfRange(Param::GridSize));
        }
        self.cfar.validate(loops, Columns::Periodic)
    }
}

/// Mutable per-frame state of the FFT chain: the range–Doppler map, the CFAR scratch and the
/// detection list. Construct it once (it is `const`), reuse it every frame.
#[derive(Clone, Debug)]
pub struct FftWorkspace<const N: usize, const K: usize, const M: usize, const DET: usize> {
    block: Snapshots<K, M>,
    rd: [[f32; K]; N],
    scratch: [f32; MAX_TRAINING_CELLS],
    detections: Detections<DET>,
}

impl<const N: usize, const K: usize, const M: usize, const DET: usize> FftWorkspace<N, K, M, DET> {
    /// A zeroed workspace.
    pub const fn new() -> Self {
        Self {
            block: [[ZERO; K]; M],
            rd: [[0.0; K]; N],
            scratch: [0.0; MAX_TRAINING_CELLS],
            detections: Detections::new(),
        }
    }

    /// The range–Doppler map of the last frame: `rd[range bin][d]`, `d` the natural FFT index
    /// (bin 0 = 0 m/s, `d ≥ K/2` negative, not fftshifted), value `Σ_m |X_m[d]|²` over the
    /// `M` rows in (range-FFT units)². Rows outside the processed range window are zero.
    pub fn range_doppler(&self) -> &[[f32; K]; N] {
        &self.rd
    }

    /// The CFAR detections of the last frame (`column` = natural Doppler index; the signed
    /// bin is [`signed_bin`]).
    pub fn detections(&self) -> &[Detection] {
        self.detections.as_slice()
    }
}

impl<const N: usize, const K: usize, const M: usize, const DET: usize> Default
    for FftWorkspace<N, K, M, DET>
{
    fn default() -> Self {
        Self::new()
    }
}

/// The configured FFT chain: parameters and precomputed tables (`&self` only, never mutated
/// by processing).
///
/// Const generics as [`crate::Dbe`]: `N` samples per chirp, `K` loops, `TX`, `RX`,
/// `M = TX·RX` virtual antennas of which `AZ` form the azimuth line, `NAZ` azimuth grid bins,
/// `NEL` elevation grid bins (used only to label points), `DET` detections per frame.
///
/// ```
/// use dbe_radar::{presets::coloradar as p, Chain};
///
/// let frontend = p::frontend().unwrap();
/// let chain = p::fft_chain(&frontend).unwrap();
/// let mut storage: Box<p::CubeStorage> =
///     vec![[[Default::default(); p::VIRTUAL]; p::LOOPS]; p::SAMPLES].try_into().unwrap();
/// let mut cube = p::Cube::new(&mut storage);
/// let mut work = Box::new(p::FftWorkspace::new());
/// let mut cloud = Box::new(p::PointCloud::new());
/// let silence: p::Chirp = [[[0, 0]; p::SAMPLES]; p::RX];
/// for id in frontend.tdm_order() {
///     frontend.push_chirp(&mut cube, id, &silence).unwrap();
/// }
/// chain.process(&frontend.frame(&cube).unwrap(), &mut work, &mut cloud);
/// // An all-zero frame has an all-zero range–Doppler map: no detection, no point.
/// assert_eq!(work.range_doppler()[40][0], 0.0);
/// assert_eq!(cloud.stats.detections, 0);
/// ```
#[derive(Clone, Debug)]
pub struct FftChain<
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
    params: FftParams,
    layout: ArrayLayout<TX, RX, M>,
    doppler_window: [f32; K],
    /// `exp(−j·2π·k/K)`.
    twiddle: [Complex32; K],
    az_mu: [f32; NAZ],
    /// `conj(a_m(μ_i)) = exp(+j·κ·μ_i·az_m)` for the azimuth line.
    az_beam: [[Complex32; AZ]; NAZ],
    /// `(line row, elevation row)` pairs at the same azimuth position; the first
    /// `pair_count` are valid.
    pairs: [(u8, u8); M],
    pair_count: usize,
    /// `κ · Δel`: elevation phase per unit of ν.
    kappa_del: f32,
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
        const DET: usize,
    > FftChain<N, K, TX, RX, M, AZ, NAZ, NEL, DET>
{
    /// Validate `params` and precompute windows, twiddles and steering tables for frames of
    /// `frontend`.
    ///
    /// At least one elevation-row element must share its azimuth position with an
    /// azimuth-line element, else `ConfigError::OutOfRange(Param::AntennaPosition)`; an array
    /// without an elevation row (`AZ = M`) gives azimuth-only points (ν = 0).
    pub fn new(
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: FftParams,
    ) -> Result<Self, ConfigError> {
        let mut chain = Self::unconfigured();
        chain.configure(frontend, params)?;
        Ok(chain)
    }

    /// A chain whose every byte is zero, `const`, so that a `static` of it lands in `.bss`
    /// on firmware; [`Self::configure`] it in place before use. Unconfigured, it never panics
    /// and produces no points.
    pub const fn unconfigured() -> Self {
        Self {
            params: FftParams::ZEROED,
            layout: ArrayLayout::ZEROED,
            doppler_window: [0.0; K],
            twiddle: [ZERO; K],
            az_mu: [0.0; NAZ],
            az_beam: [[ZERO; AZ]; NAZ],
            pairs: [(0, 0); M],
            pair_count: 0,
            kappa_del: 0.0,
            range_bin_m: 0.0,
            doppler_bin_mps: 0.0,
        }
    }

    /// Validate and compute the tables in place (no chain-sized value on the stack). On error
    /// `self` is unchanged.
    pub fn configure(
        &mut self,
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: FftParams,
    ) -> Result<(), ConfigError> {
        const {
            assert!(NAZ <= u16::MAX as usize && NEL <= u16::MAX as usize);
        };
        if !frontend.is_configured() {
            return Err(ConfigError::FrontendUnconfigured);
        }
        params.validate(N, K, NEL)?;
        if NAZ < 3 {
            return Err(ConfigError::OutOfRange(Param::GridSize));
        }
        if params.range_window != frontend.range_window() {
            return Err(ConfigError::OutOfRange(Param::RangeWindowKind));
        }
        let layout = *frontend.layout();
        let mut pairs = [(0u8, 0u8); M];
        let mut pair_count = 0;
        for e in AZ..M {
            if let Some(a) = (0..AZ).find(|&a| (layout.az[a] - layout.az[e]).abs() <= 1e-3) {
                pairs[pair_count] = (a as u8, e as u8);
                pair_count += 1;
            }
        }
        // ArrayLayout puts the line at the lowest elevation and the rest on one row above it;
        // an array without that row (`AZ = M`) gives azimuth-only points (ν = 0).
        let del = layout.el.get(AZ).copied().unwrap_or(0.0);
        if AZ < M && (pair_count == 0 || !(del > 0.0)) {
            return Err(ConfigError::OutOfRange(Param::AntennaPosition));
        }
        let fc = frontend.waveform().center_frequency_hz(N);
        let kappa = core::f64::consts::PI * fc / frontend.geometry().f_design_hz;
        self.az_mu = sine_grid::<NAZ>(params.azimuth_span_deg);
        for (row, mu) in self.az_beam.iter_mut().zip(self.az_mu.iter()) {
            for (a, pos) in row.iter_mut().zip(layout.az.iter()) {
                *a = Complex32::from_polar(1.0, kappa as f32 * mu * pos);
            }
        }
        for (k, t) in self.twiddle.iter_mut().enumerate() {
            let ph = -core::f64::consts::TAU * k as f64 / K as f64;
            *t = Complex32::new(libm::cos(ph) as f32, libm::sin(ph) as f32);
        }
        self.params = params;
        self.layout = layout;
        self.doppler_window = params.doppler_window.coefficients();
        self.pairs = pairs;
        self.pair_count = pair_count;
        self.kappa_del = (kappa * f64::from(del)) as f32;
        self.range_bin_m = frontend.range_bin_m();
        self.doppler_bin_mps = frontend.doppler_bin_mps();
        Ok(())
    }

    /// The cube row order of the frontend the chain was configured from.
    pub fn layout(&self) -> &ArrayLayout<TX, RX, M> {
        &self.layout
    }

    /// The processing parameters.
    pub fn params(&self) -> &FftParams {
        &self.params
    }

    /// Direction cosine μ = sin φ of each azimuth grid bin (identical to the DBE chain's).
    pub fn azimuth_grid(&self) -> &[f32; NAZ] {
        &self.az_mu
    }

    /// The `(azimuth-line row, elevation row)` pairs the elevation estimate uses.
    pub fn elevation_pairs(&self) -> &[(u8, u8)] {
        &self.pairs[..self.pair_count]
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

    /// Stage 1: the range–Doppler map. Doppler FFT per range bin and row into one scratch,
    /// non-coherent sum over the rows.
    pub fn doppler_map(&self, frame: &Frame<'_, N, K, M>, work: &mut FftWorkspace<N, K, M, DET>) {
        let (first, last) = self.range_window();
        for row in work.rd.iter_mut() {
            *row = [0.0; K];
        }
        let mut buf = [ZERO; K];
        for (b, rd) in work.rd.iter_mut().enumerate().take(last + 1).skip(first) {
            frame.snapshots(b, &mut work.block);
            for x in work.block.iter() {
                let w = &self.doppler_window;
                fft_from(&mut buf, |n| x[n & (K - 1)] * w[n & (K - 1)]);
                for (p, v) in rd.iter_mut().zip(buf.iter()) {
                    *p += v.norm_sqr();
                }
            }
        }
    }

    /// Stage 2: CFAR on the range–Doppler map (Doppler periodic).
    pub fn detect_targets(&self, work: &mut FftWorkspace<N, K, M, DET>) {
        let (first, last) = self.range_window();
        let shape = MapShape {
            first,
            last,
            columns: Columns::Periodic,
        };
        cfar::detect(
            &work.rd,
            None,
            shape,
            &self.params.cfar,
            &mut work.scratch,
            &mut work.detections,
        );
    }

    /// Stage 3: angles and a point per detection (one dequantisation per distinct bin), and
    /// the frame's statistics.
    pub fn angles<const P: usize>(
        &self,
        frame: &Frame<'_, N, K, M>,
        work: &mut FftWorkspace<N, K, M, DET>,
        out: &mut PointCloud<P>,
    ) {
        out.clear();
        out.stats.detections = work.detections.as_slice().len() as u32;
        out.stats.detection_overflow = work.detections.overflow;
        let FftWorkspace {
            block,
            rd,
            detections,
            ..
        } = work;
        let mut block_bin = usize::MAX;
        for det in detections.as_slice() {
            let before = out.stats.points + out.stats.point_overflow;
            let b = usize::from(det.range_bin);
            if b != block_bin {
                frame.snapshots(b, block);
                block_bin = b;
            }
            self.resolve_detection(det, block, rd, out);
            if out.stats.points + out.stats.point_overflow == before {
                out.stats.detections_without_point += 1;
            }
        }
    }

    /// The windowed Doppler bin `d` (natural index) of every row, TDM-compensated when on
    /// for the Doppler `doppler_bins` (signed, fractional).
    fn doppler_cell(&self, snap: &Snapshots<K, M>, d: usize, doppler_bins: f32) -> [Complex32; M] {
        let mut x = [ZERO; M];
        for (o, row) in x.iter_mut().zip(snap.iter()) {
            let mut acc = ZERO;
            for (k, (v, w)) in row.iter().zip(self.doppler_window.iter()).enumerate() {
                // (d·k) mod K: K is a power of two.
                acc += *v * *w * self.twiddle[(d * k) & (K - 1)];
            }
            *o = acc;
        }
        if self.params.tdm_compensation {
            let rot = tdm::rotation::<K, TX, M>(&self.layout.slot, doppler_bins);
            for (v, r) in x.iter_mut().zip(rot.iter()) {
                *v *= r;
            }
        }
        x
    }

    /// Azimuth, elevation and the point of one detection.
    fn resolve_detection<const P: usize>(
        &self,
        det: &Detection,
        snap: &Snapshots<K, M>,
        rd: &[[f32; K]; N],
        out: &mut PointCloud<P>,
    ) {
        let d = usize::from(det.column) & (K - 1);
        let signed = signed_bin::<K>(d);
        let b = usize::from(det.range_bin);
        let at = |b: Option<usize>, d: usize| {
            b.and_then(|b| rd.get(b))
                .map_or(0.0, |row| row[d & (K - 1)])
        };
        // The detection's fractional Doppler from its RD neighbours, by the estimator that
        // suits the Doppler window: TDM compensation with the integer bin alone leaves up to
        // half a bin of slot phase (an elevation bias).
        let c = at(Some(b), d);
        let doppler_frac = power_offset::<K>(
            self.params.doppler_window,
            at(Some(b), d + K - 1),
            c,
            at(Some(b), d + 1),
        );
        let x = self.doppler_cell(snap, d, f32::from(signed) + doppler_frac);

        // Azimuth: beamscan of the line on the μ grid; an end-of-grid peak is out of span.
        let beam_power = |beam: &[Complex32; AZ]| {
            let mut s = ZERO;
            for (b, v) in beam.iter().zip(x.iter()) {
                s += b * v;
            }
            s.norm_sqr()
        };
        let mut best = (0usize, -1.0f32);
        for (i, beam) in self.az_beam.iter().enumerate() {
            let p = beam_power(beam);
            if p > best.1 {
                best = (i, p);
            }
        }
        let i = best.0;
        if i == 0 || i + 1 >= NAZ {
            return;
        }
        let (mut range_bins, mut doppler_bins, mut mu) =
            (b as f32, f32::from(signed), self.az_mu[i]);
        if self.params.subgrid {
            range_bins += parabolic_offset(at(b.checked_sub(1), d), c, at(Some(b + 1), d));
            doppler_bins += doppler_frac;
            let frac = parabolic_offset(
                beam_power(&self.az_beam[i - 1]),
                best.1,
                beam_power(&self.az_beam[i + 1]),
            );
            mu = sine_at(self.params.azimuth_span_deg, NAZ, i as f32 + frac);
        }

        // Elevation: phase of the pair products (line element × conj(elevation element)).
        let nu = match AZ < M {
            true => elevation::phase_difference(&x, self.elevation_pairs(), self.kappa_del),
            false => Some(0.0),
        };
        let Some(nu) = nu else {
            return;
        };
        let Some(point) = Point::at(range_bins * self.range_bin_m, mu, nu) else {
            return;
        };
        out.push(Point {
            velocity_mps: doppler_bins * self.doppler_bin_mps,
            power_db: power_db(det.power),
            snr_db: ratio_db(det.power, det.level),
            range_bin: det.range_bin,
            azimuth_bin: i as u16,
            elevation_bin: elevation::nearest_bin::<NEL>(nu, self.params.elevation_span_deg),
            doppler_bin: signed,
            ..point
        });
    }
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
    > Chain<N, K, TX, RX, M, AZ> for FftChain<N, K, TX, RX, M, AZ, NAZ, NEL, DET>
{
    const NAME: &'static str = "fft";
    const STAGES: [&'static str; 3] = ["doppler_fft", "rd_cfar", "angles"];
    type Params = FftParams;
    type Workspace = FftWorkspace<N, K, M, DET>;

    fn configure(
        &mut self,
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: FftParams,
    ) -> Result<(), ConfigError> {
        FftChain::configure(self, frontend, params)
    }

    fn map(&self, frame: &Frame<'_, N, K, M>, work: &mut Self::Workspace) {
        self.doppler_map(frame, work);
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
        self.angles(frame, work, out);
    }

    fn detections(work: &Self::Workspace) -> &[Detection] {
        work.detections()
    }
}
