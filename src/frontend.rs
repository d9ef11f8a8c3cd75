//! The frontend both chains share: chirps in, a checked [`Frame`] out.
//!
//! ```text
//! push_chirp : TDM order check → per RX: DC removal, window, range FFT (range.rs)
//!              → − coupling calibration of its cube row → × channel gain of the row
//!              → Cube[bin][loop][row]
//! push_range_spectra : the same from range spectra computed off the core (the radar's
//!              FFT accelerator, a DSP): TDM order check → − coupling → × gain → Cube
//! push_range_blocks  : the same from 16-bit spectra with an exponent (`mantissa · 2^e`, an
//!              accelerator's fixed-point output): without coupling and gains copied into
//!              the Cube as they are, else decoded → − coupling → × gain → Cube
//! frame      : all K·TX chirps in order? → Frame (else FrameError)
//! ```
//!
//! The frontend owns what depends on the sensor alone: the waveform, the antenna geometry and
//! the cube row order derived from it ([`ArrayLayout`]), the range window, and the optional
//! coupling and channel gain calibrations. A chain is configured from a frontend
//! ([`crate::Dbe::configure`], [`crate::FftChain::configure`]) and processes the frames it
//! fills; both chains can process one frame, which is how they are compared.

use num_complex::Complex32;

use crate::config::{AntennaGeometry, ArrayLayout, ConfigError, Param, Waveform};
use crate::cube::{BlockExponent, ChirpId, Cube, CubeSample, Frame, FrameError};
#[cfg(not(target_arch = "arm"))]
use crate::fft::Lanes;
use crate::range::RangeFft;
use crate::window::WindowKind;

const ZERO: Complex32 = Complex32::new(0.0, 0.0);

/// Waveform, geometry, range window, coupling and channel gain calibrations; `push_chirp` and
/// `frame`.
///
/// Const generics: `N` samples per chirp (= range bins), `K` loops per frame, `TX`, `RX`,
/// `M = TX·RX` virtual antennas of which `AZ` form the azimuth line.
///
/// An impossible shape is a compile error (`const` assertions in [`Self::configure`]), not a
/// run-time one. The ColoRadar shape compiles:
///
/// ```
/// use dbe_radar::{window::WindowKind, AntennaGeometry, Frontend, Waveform};
/// let (w, g) = (Waveform::COLORADAR, AntennaGeometry::COLORADAR);
/// assert!(Frontend::<128, 128, 3, 4, 12, 8>::new(w, g, WindowKind::Blackman).is_ok());
/// ```
///
/// 100 samples per chirp (no radix-2 FFT) does not:
///
/// ```compile_fail,E0080
/// use dbe_radar::{window::WindowKind, AntennaGeometry, Frontend, Waveform};
/// let (w, g) = (Waveform::COLORADAR, AntennaGeometry::COLORADAR);
/// let _ = Frontend::<100, 128, 3, 4, 12, 8>::new(w, g, WindowKind::Blackman);
/// ```
///
/// nor 96 loops:
///
/// ```compile_fail,E0080
/// use dbe_radar::{window::WindowKind, AntennaGeometry, Frontend, Waveform};
/// let (w, g) = (Waveform::COLORADAR, AntennaGeometry::COLORADAR);
/// let _ = Frontend::<128, 96, 3, 4, 12, 8>::new(w, g, WindowKind::Blackman);
/// ```
///
/// nor `M ≠ TX · RX`:
///
/// ```compile_fail,E0080
/// use dbe_radar::{window::WindowKind, AntennaGeometry, Frontend, Waveform};
/// let (w, g) = (Waveform::COLORADAR, AntennaGeometry::COLORADAR);
/// let _ = Frontend::<128, 128, 3, 4, 10, 8>::new(w, g, WindowKind::Blackman);
/// ```
///
/// nor an azimuth line longer than the array:
///
/// ```compile_fail,E0080
/// use dbe_radar::{window::WindowKind, AntennaGeometry, Frontend, Waveform};
/// let (w, g) = (Waveform::COLORADAR, AntennaGeometry::COLORADAR);
/// let _ = Frontend::<128, 128, 3, 4, 12, 13>::new(w, g, WindowKind::Blackman);
/// ```
///
/// An azimuth line as long as the whole array (`AZ = M`: 2 TX × 4 RX on a line, as on
/// AWR1642/IWR1443-class boards) is an array without an elevation row: both chains then give
/// azimuth-only points (ν = 0, [`Frontend::MEASURES_ELEVATION`] false).
#[derive(Clone, Debug)]
pub struct Frontend<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
> {
    waveform: Waveform,
    geometry: AntennaGeometry<TX, RX>,
    layout: ArrayLayout<TX, RX, M>,
    range: RangeFft<N>,
    range_window: WindowKind,
    /// Coupling calibration per cube row (all zero, and unused, when `coupling_on` is false).
    coupling: [[Complex32; N]; M],
    coupling_on: bool,
    /// Complex gain per cube row (all zero, and unused, when `gains_on` is false).
    gains: [Complex32; M],
    gains_on: bool,
    configured: bool,
}

impl<
        const N: usize,
        const K: usize,
        const TX: usize,
        const RX: usize,
        const M: usize,
        const AZ: usize,
    > Frontend<N, K, TX, RX, M, AZ>
{
    /// Whether the array has an elevation row (`AZ < M`). Without one (`AZ = M`, e.g. 2 TX ×
    /// 4 RX on a line) every point of either chain has elevation ν = 0 (`z = 0`): the array
    /// cannot measure it.
    pub const MEASURES_ELEVATION: bool = AZ < M;

    /// Validate the waveform and geometry and precompute the range window.
    pub fn new(
        waveform: Waveform,
        geometry: AntennaGeometry<TX, RX>,
        range_window: WindowKind,
    ) -> Result<Self, ConfigError> {
        let mut f = Self::unconfigured();
        f.configure(waveform, geometry, range_window)?;
        Ok(f)
    }

    /// A frontend whose every byte is zero, `const`, so that a `static` of it lands in `.bss`;
    /// [`Self::configure`] it in place before use. Unconfigured, it stores zeros.
    pub const fn unconfigured() -> Self {
        Self {
            waveform: Waveform::ZEROED,
            geometry: AntennaGeometry {
                tx: [(0.0, 0.0); TX],
                rx: [(0.0, 0.0); RX],
                f_design_hz: 0.0,
            },
            layout: ArrayLayout::ZEROED,
            range: RangeFft::unconfigured(),
            range_window: WindowKind::Rectangular,
            coupling: [[ZERO; N]; M],
            coupling_on: false,
            gains: [ZERO; M],
            gains_on: false,
            configured: false,
        }
    }

    /// Validate and configure in place. On error `self` is unchanged. Any coupling or channel
    /// gain calibration is removed.
    pub fn configure(
        &mut self,
        waveform: Waveform,
        geometry: AntennaGeometry<TX, RX>,
        range_window: WindowKind,
    ) -> Result<(), ConfigError> {
        const {
            assert!(M == TX * RX, "M must equal TX · RX");
            assert!(AZ >= 2 && AZ <= M, "the azimuth line needs 2..=M elements");
            assert!(N.is_power_of_two() && K.is_power_of_two());
            assert!(N <= u16::MAX as usize && K <= i16::MAX as usize);
        };
        waveform.validate()?;
        let layout = ArrayLayout::new(&geometry, AZ)?;
        self.waveform = waveform;
        self.geometry = geometry;
        self.layout = layout;
        self.range = RangeFft::new(range_window);
        self.range_window = range_window;
        self.coupling_on = false;
        self.gains_on = false;
        self.configured = true;
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

    /// Attach a per-channel gain and phase calibration in data order `[tx][rx]`: every range
    /// bin of the channel's chirps is multiplied by its factor, after the coupling is
    /// subtracted (TI's `compRangeBiasAndRxChanPhase`: the factors that make a reflector at
    /// boresight arrive with one amplitude and phase on every virtual antenna). Factors must be
    /// finite and non-zero; on error the previous calibration is kept. Without one (the
    /// default) nothing is multiplied: the array is taken as matched.
    pub fn set_channel_gains(&mut self, gains: &[[Complex32; RX]; TX]) -> Result<(), ConfigError> {
        for g in gains.iter().flatten() {
            if !(g.re.is_finite() && g.im.is_finite()) {
                return Err(ConfigError::NotFinite(Param::ChannelGains));
            }
            if !(g.norm_sqr() > 0.0) {
                return Err(ConfigError::OutOfRange(Param::ChannelGains));
            }
        }
        for (t, per_rx) in gains.iter().enumerate() {
            for (r, g) in per_rx.iter().enumerate() {
                if let Some(dst) = self.gains.get_mut(usize::from(self.layout.row_of[t][r])) {
                    *dst = *g;
                }
            }
        }
        self.gains_on = true;
        Ok(())
    }

    /// Remove the channel gain calibration (nothing is multiplied again).
    pub fn clear_channel_gains(&mut self) {
        self.gains = [ZERO; M];
        self.gains_on = false;
    }

    /// Whether [`Self::configure`] has succeeded (chains refuse an unconfigured frontend).
    pub fn is_configured(&self) -> bool {
        self.configured
    }

    /// The waveform.
    pub fn waveform(&self) -> &Waveform {
        &self.waveform
    }

    /// The antenna geometry.
    pub fn geometry(&self) -> &AntennaGeometry<TX, RX> {
        &self.geometry
    }

    /// The cube row order derived from the geometry.
    pub fn layout(&self) -> &ArrayLayout<TX, RX, M> {
        &self.layout
    }

    /// The range window.
    pub fn range_window(&self) -> WindowKind {
        self.range_window
    }

    /// Metres per range bin, `c · fs / (2 · S · N)`.
    pub fn range_bin_m(&self) -> f32 {
        self.waveform.range_bin_m(N) as f32
    }

    /// m/s per Doppler bin, `λ / (2 · K · T_loop)`.
    pub fn doppler_bin_mps(&self) -> f32 {
        self.waveform.doppler_bin_mps(N, K, TX) as f32
    }

    /// The frame's `K · TX` chirps in the TDM order [`Self::push_chirp`] and its siblings
    /// take them: loop 0 slot 0, loop 0 slot 1, …, loop 1 slot 0, …
    ///
    /// ```
    /// use dbe_radar::{presets::coloradar as p, ChirpId};
    /// let frontend = p::frontend().unwrap();
    /// let order: Vec<ChirpId> = frontend.tdm_order().collect();
    /// assert_eq!(order.len(), p::LOOPS * p::TX);
    /// assert_eq!(order[4], ChirpId { loop_index: 1, tx_slot: 1 });
    /// ```
    pub fn tdm_order(&self) -> impl Iterator<Item = ChirpId> + Clone {
        crate::cube::tdm_order(K, TX)
    }

    /// Ingest one chirp: `chirp[rx][sample] = [I, Q]` of TX slot `id.tx_slot` in loop
    /// `id.loop_index`, as the ADC delivers it. Chirps must come in TDM order (loop 0 slot 0,
    /// loop 0 slot 1, …); any other chirp is not stored and makes the frame an error (returned
    /// here and by [`Self::frame`]) until [`Cube::begin_frame`].
    pub fn push_chirp(
        &self,
        cube: &mut Cube<'_, N, K, M>,
        id: ChirpId,
        chirp: &[[[i16; 2]; N]; RX],
    ) -> Result<(), FrameError> {
        let Some(k) = cube.accept(id, TX) else {
            return cube.frame(TX).and(Err(FrameError::TooManyChirps));
        };
        let Some(rows) = self.layout.row_of.get(usize::from(id.tx_slot)) else {
            return Ok(());
        };
        // With SIMD lanes (host) the chirp's RX channels are transformed and stored side by
        // side; on a Cortex-M (no SIMD; a lanes buffer would add RX × N × 8 bytes of stack)
        // one after the other. Both give bit-identical cubes (`RangeFft::process_lanes`,
        // `Cube::store_lanes`).
        #[cfg(not(target_arch = "arm"))]
        {
            let mut lanes = [Lanes::<RX>::ZERO; N];
            self.range.process_lanes(chirp, &mut lanes);
            if let Some(c) = self.coupling_on.then_some(&self.coupling) {
                for (l, &row) in rows.iter().enumerate() {
                    let Some(c) = c.get(usize::from(row)) else {
                        continue;
                    };
                    for (s, c) in lanes.iter_mut().zip(c.iter()) {
                        s.re[l] -= c.re;
                        s.im[l] -= c.im;
                    }
                }
            }
            if self.gains_on {
                for (l, &row) in rows.iter().enumerate() {
                    let Some(&g) = self.gains.get(usize::from(row)) else {
                        continue;
                    };
                    for s in lanes.iter_mut() {
                        let v = Complex32::new(s.re[l], s.im[l]) * g;
                        (s.re[l], s.im[l]) = (v.re, v.im);
                    }
                }
            }
            cube.store_lanes(rows, k, &lanes);
        }
        #[cfg(target_arch = "arm")]
        {
            let mut spectrum = [ZERO; N];
            for (samples, &row) in chirp.iter().zip(rows.iter()) {
                let row = usize::from(row);
                self.range.process(samples, &mut spectrum);
                self.correct(row, &mut spectrum);
                cube.store(row, k, &spectrum);
            }
        }
        Ok(())
    }

    /// Ingest one chirp whose range FFT was computed off this core — by the radar chip's
    /// FFT accelerator or a DSP, as TI's own chains do during the chirp — given as
    /// `spectra[rx][bin]` of TX slot `id.tx_slot` in loop `id.loop_index`.
    ///
    /// The spectra must be in this frontend's units: the unnormalised FFT ([`crate::fft`])
    /// of the chirp's samples with their complex mean removed and [`Self::range_window`]
    /// applied, which is what [`RangeFft::process`] computes. An accelerator's output must be
    /// scaled back to that and windowed alike, or the coupling table (in these units), the
    /// points' powers and the sub-bin range estimate (which assumes the window) are off. The
    /// coupling calibration, the channel gains, the block-float store and the TDM order rules
    /// are [`Self::push_chirp`]'s: given `RangeFft::process`'s spectra the cube is
    /// bit-identical to `push_chirp`'s. On the emulated Cortex-M4F it costs about a quarter of
    /// `push_chirp` (`cargo xtask budget`, `ingest_from_spectra`: the block-float store).
    pub fn push_range_spectra(
        &self,
        cube: &mut Cube<'_, N, K, M>,
        id: ChirpId,
        spectra: &[[Complex32; N]; RX],
    ) -> Result<(), FrameError> {
        let Some(k) = cube.accept(id, TX) else {
            return cube.frame(TX).and(Err(FrameError::TooManyChirps));
        };
        let Some(rows) = self.layout.row_of.get(usize::from(id.tx_slot)) else {
            return Ok(());
        };
        for (s, &row) in spectra.iter().zip(rows.iter()) {
            let row = usize::from(row);
            if self.coupling_on || self.gains_on {
                self.store_corrected(cube, row, k, &mut s.clone());
            } else {
                cube.store(row, k, s);
            }
        }
        Ok(())
    }

    /// Ingest one chirp whose range FFT was computed off this core in 16-bit fixed point: the
    /// spectrum of RX channel `rx` is `mantissas[rx][bin] · 2^exponents[rx]` (`[re, im]`; TI's
    /// radar cube, `cmplx16ImRe_t`, holds `[im, re]`: swap them), in this frontend's units as
    /// for [`Self::push_range_spectra`]. An accelerator with a fixed output scale gives every
    /// chirp one exponent; a block-floating-point FFT, each chirp its own.
    ///
    /// This is the cube's own format, so without a coupling calibration or channel gains the
    /// mantissas are stored as they are (no rounding, no `f32`): given the cube's own
    /// mantissas and exponents ([`Cube::mantissas`], [`Cube::exponents`]) it is bit-identical
    /// to the cube they came from. With either calibration on, the spectrum is decoded to
    /// `f32` (exact: 16 bits times a power of two) and ingested as by `push_range_spectra`.
    /// The TDM order rules are [`Self::push_chirp`]'s.
    pub fn push_range_blocks(
        &self,
        cube: &mut Cube<'_, N, K, M>,
        id: ChirpId,
        mantissas: &[[CubeSample; N]; RX],
        exponents: &[BlockExponent; RX],
    ) -> Result<(), FrameError> {
        let Some(k) = cube.accept(id, TX) else {
            return cube.frame(TX).and(Err(FrameError::TooManyChirps));
        };
        let Some(rows) = self.layout.row_of.get(usize::from(id.tx_slot)) else {
            return Ok(());
        };
        for ((m, &e), &row) in mantissas.iter().zip(exponents.iter()).zip(rows.iter()) {
            let row = usize::from(row);
            if self.coupling_on || self.gains_on {
                let (f, mut spectrum) = (e.factor(), [ZERO; N]);
                for (s, m) in spectrum.iter_mut().zip(m.iter()) {
                    *s = Complex32::new(f32::from(m[0]) * f, f32::from(m[1]) * f);
                }
                self.store_corrected(cube, row, k, &mut spectrum);
            } else {
                cube.store_mantissas(row, k, m, e);
            }
        }
        Ok(())
    }

    /// [`Self::correct`] `spectrum`, then store it as row `row`, loop `k`: the calibrated
    /// path of [`Self::push_range_spectra`] and [`Self::push_range_blocks`], one copy of the
    /// block-float store for both (flash on a microcontroller).
    #[inline(never)]
    fn store_corrected(
        &self,
        cube: &mut Cube<'_, N, K, M>,
        row: usize,
        k: usize,
        spectrum: &mut [Complex32; N],
    ) {
        self.correct(row, spectrum);
        cube.store(row, k, spectrum);
    }

    /// Subtract the coupling calibration of cube row `row` and apply its channel gain, in
    /// place (each only when configured).
    #[inline(always)]
    fn correct(&self, row: usize, spectrum: &mut [Complex32; N]) {
        if self.coupling_on {
            if let Some(c) = self.coupling.get(row) {
                for (s, c) in spectrum.iter_mut().zip(c.iter()) {
                    *s -= *c;
                }
            }
        }
        if self.gains_on {
            if let Some(&g) = self.gains.get(row) {
                for s in spectrum.iter_mut() {
                    *s *= g;
                }
            }
        }
    }

    /// The cube's frame when all `K · TX` chirps arrived in order, else a [`FrameError`]
    /// naming the missing, repeated or out-of-order chirp.
    pub fn frame<'c>(&self, cube: &'c Cube<'_, N, K, M>) -> Result<Frame<'c, N, K, M>, FrameError> {
        cube.frame(TX)
    }
}
