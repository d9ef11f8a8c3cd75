//! C API of dbe-radar: the DBE chain for C firmware, as a `no_std` static library.
//!
//! The header is `ffi/dbe_radar.h`, generated from this file by cbindgen (`cargo xtask
//! header`; CI fails when it is stale). Build the library with
//! `cargo build --release --manifest-path ffi/Cargo.toml [--target thumbv7em-none-eabihf]` and
//! link `libdbe_radar_ffi.a` (plus `-lm` on a hosted target).
//!
//! ```text
//! dbe_sizes(preset)            → bytes and alignment of the state and the cube, array sizes
//! dbe_default_config(preset)   → the preset's waveform, antennas and the chain's defaults
//! dbe_init(preset, state, cube, config) → handle (all in the caller's memory)
//! per frame: dbe_push_chirp × (loops · TX), in TDM order → dbe_process_frame
//!            → dbe_points, dbe_ego_velocity
//!            (or dbe_push_range_spectra / dbe_push_range_blocks, when an FFT accelerator
//!            computed the range FFT: float spectra, or 16-bit ones with an exponent)
//! ```
//!
//! Contract:
//! - **Memory** is the caller's: one state block (`state_bytes`, aligned to `state_align`) and
//!   the cube (`cube_bytes`, the largest buffer, so the firmware decides where it lives). The
//!   library never allocates and keeps no global state; handles are independent.
//! - **Errors** are `dbe_status_t` codes, named by `dbe_status_name`. A failed call changes
//!   nothing, except that a wrong chirp makes the frame an error until it is processed or
//!   `dbe_begin_frame` is called (as the core does). A failed `dbe_init` leaves no valid
//!   handle in the state memory.
//! - **No panic crosses the boundary**: the core does not panic on any input, and the
//!   library is built with `panic = "abort"`; should one happen anyway, the process aborts
//!   (hosted) or the core stops on a permanently undefined instruction (bare metal).
//! - **Not thread-safe**: one handle is used by one thread at a time.
//!
//! Presets are compiled in: `DBE_PRESET_COLORADAR` (128 samples × 128 loops, 3 TX × 4 RX) and
//! `DBE_PRESET_IWR6843` (256 × 64, 3 × 4). Their sizes are also `#define`s
//! (`DBE_COLORADAR_CUBE_BYTES`, `DBE_COLORADAR_STATE_BYTES_MAX`, …) so that C can declare its
//! buffers statically; the state's exact size depends on the target's pointer width and is
//! at most the `_MAX` value (checked at compile time for every target this is built for).
#![no_std]
#![allow(non_camel_case_types)]

use core::ffi::{c_char, c_void};
use core::mem::{align_of, size_of};
use core::ptr::{self, addr_of_mut};

use dbe_radar::cfar::CfarKind;
use dbe_radar::config::{AntennaGeometry, ConfigError, Waveform};
use dbe_radar::cube::CubeStorage;
use dbe_radar::presets::{coloradar, iwr6843};
use dbe_radar::window::WindowKind;
use dbe_radar::{
    ChirpId, Cube, Dbe, EgoEstimator, EgoParams, EgoStatus, FrameError, Frontend, Params,
    PointCloud, Workspace,
};

// ---------------------------------------------------------------------------------------------
// Constants

/// The ColoRadar preset (TI AWR1843BOOST): 128 samples, 128 loops, 3 TX × 4 RX.
pub const DBE_PRESET_COLORADAR: u32 = 0;
/// The TI IWR6843 fixture's preset: 256 samples, 64 loops, 3 TX × 4 RX.
pub const DBE_PRESET_IWR6843: u32 = 1;

/// Most TX antennas a `dbe_antennas_t` describes.
pub const DBE_MAX_TX: usize = 4;
/// Most RX antennas a `dbe_antennas_t` describes.
pub const DBE_MAX_RX: usize = 4;

/// Window: all ones.
pub const DBE_WINDOW_RECTANGULAR: u32 = 0;
/// Window: Hann.
pub const DBE_WINDOW_HANN: u32 = 1;
/// Window: Hamming.
pub const DBE_WINDOW_HAMMING: u32 = 2;
/// Window: Blackman.
pub const DBE_WINDOW_BLACKMAN: u32 = 3;

/// Alignment the state block needs, bytes (at least; `dbe_sizes_t::state_align` is exact).
pub const DBE_STATE_ALIGN: usize = 8;
/// Alignment the cube needs, bytes (at least).
pub const DBE_CUBE_ALIGN: usize = 4;

/// Cube bytes of the ColoRadar preset (128 · 12 · 128 · 4).
pub const DBE_COLORADAR_CUBE_BYTES: usize = 786_432;
/// State bytes of the ColoRadar preset, at most (any target).
pub const DBE_COLORADAR_STATE_BYTES_MAX: usize = 174_080;
/// Cube bytes of the IWR6843 preset (256 · 12 · 64 · 4).
pub const DBE_IWR6843_CUBE_BYTES: usize = 786_432;
/// State bytes of the IWR6843 preset, at most (any target).
pub const DBE_IWR6843_STATE_BYTES_MAX: usize = 278_528;

/// Marks an initialised handle ("DBE1").
const MAGIC: u32 = 0x4442_4531;

// ---------------------------------------------------------------------------------------------
// Types

/// Result of every call; `dbe_status_name` names it.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum dbe_status_t {
    /// Success.
    DBE_OK = 0,
    /// A required pointer argument is NULL.
    DBE_ERR_NULL_POINTER = 1,
    /// The preset number is not one this library was built with.
    DBE_ERR_UNKNOWN_PRESET = 2,
    /// A buffer is smaller than the call needs.
    DBE_ERR_BUFFER_TOO_SMALL = 3,
    /// A buffer is not aligned as the call needs.
    DBE_ERR_MISALIGNED = 4,
    /// The handle was not made by a successful `dbe_init`.
    DBE_ERR_BAD_HANDLE = 5,
    /// A configuration value is NaN or infinite (`detail` names it).
    DBE_ERR_NOT_FINITE = 6,
    /// A configuration value is out of range (`detail` names it).
    DBE_ERR_OUT_OF_RANGE = 7,
    /// `num_tx`, `num_rx` do not match the preset.
    DBE_ERR_ARRAY_SHAPE = 8,
    /// The antenna layout's azimuth line does not hold the preset's number of elements.
    DBE_ERR_AZIMUTH_ROW_COUNT = 9,
    /// The azimuth line is not uniformly spaced.
    DBE_ERR_AZIMUTH_NOT_UNIFORM = 10,
    /// The elements off the azimuth line are not on one elevation row.
    DBE_ERR_ELEVATION_ROW_NOT_FLAT = 11,
    /// A chirp's length is not `rx · samples · 2` int16 values.
    DBE_ERR_CHIRP_SIZE = 12,
    /// A chirp arrived out of TDM order (missing, repeated or reordered).
    DBE_ERR_CHIRP_OUT_OF_ORDER = 13,
    /// More chirps than a frame holds arrived before it was processed.
    DBE_ERR_TOO_MANY_CHIRPS = 14,
    /// The frame was processed before all its chirps arrived.
    DBE_ERR_FRAME_INCOMPLETE = 15,
}

use dbe_status_t::*;

/// Sizes of a preset: the arrays it is compiled for and the memory the caller provides.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct dbe_sizes_t {
    /// Samples per chirp (= range bins).
    pub samples: u32,
    /// Loops (chirps per TX) per frame.
    pub loops: u32,
    /// TX antennas (TDM slots).
    pub tx: u32,
    /// RX antennas.
    pub rx: u32,
    /// Virtual antennas, `tx · rx`.
    pub virtual_antennas: u32,
    /// Azimuth-line elements.
    pub azimuth_elements: u32,
    /// Azimuth grid bins.
    pub azimuth_bins: u32,
    /// Elevation grid bins.
    pub elevation_bins: u32,
    /// Detections kept per frame, at most.
    pub max_detections: u32,
    /// Points per frame, at most.
    pub max_points: u32,
    /// int16 values of one chirp: `rx · samples · 2` (`[rx][sample][I, Q]`).
    pub chirp_values: u32,
    /// Chirps per frame: `loops · tx`.
    pub chirps_per_frame: u32,
    /// Bytes of the state block.
    pub state_bytes: usize,
    /// Alignment of the state block, bytes.
    pub state_align: usize,
    /// Bytes of the cube.
    pub cube_bytes: usize,
    /// Alignment of the cube, bytes.
    pub cube_align: usize,
}

/// The chirp waveform (what TI's `profileCfg` sets), SI units.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct dbe_waveform_t {
    /// ADC sample rate, complex samples per second.
    pub adc_sample_rate_hz: f64,
    /// Chirp slope, Hz/s.
    pub slope_hz_per_s: f64,
    /// Start frequency of the ramp, Hz.
    pub start_frequency_hz: f64,
    /// Idle time before each ramp, s.
    pub idle_time_s: f64,
    /// Ramp end time, s.
    pub ramp_end_time_s: f64,
}

/// Antenna positions `(azimuth, elevation)` in half wavelengths at `f_design_hz`, TX by TDM
/// slot (the order chirps arrive in), RX by data index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct dbe_antennas_t {
    /// TX antennas used (must equal the preset's).
    pub num_tx: u32,
    /// RX antennas used (must equal the preset's).
    pub num_rx: u32,
    /// `(az, el)` of each TX slot; entries past `num_tx` are ignored.
    pub tx: [[f32; 2]; DBE_MAX_TX],
    /// `(az, el)` of each RX; entries past `num_rx` are ignored.
    pub rx: [[f32; 2]; DBE_MAX_RX],
    /// Frequency at which the half-wavelength units are defined, Hz.
    pub f_design_hz: f64,
}

/// The DBE chain's parameters (spec §3). Flags are 0 (off) or non-zero (on).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct dbe_params_t {
    /// First range bin processed (inclusive).
    pub range_first: u16,
    /// Last range bin processed (inclusive).
    pub range_last: u16,
    /// Range window, a `DBE_WINDOW_*` value.
    pub range_window: u32,
    /// Doppler window, a `DBE_WINDOW_*` value.
    pub doppler_window: u32,
    /// Diagonal loading γ (δ = γ · tr(R) / M), in (0, 1].
    pub loading: f32,
    /// Forward–backward averaging of the azimuth covariance.
    pub forward_backward: u8,
    /// TDM-MIMO motion compensation before elevation and Doppler.
    pub tdm_compensation: u8,
    /// Sub-grid refinement: continuous coordinates instead of grid values.
    pub subgrid: u8,
    /// Azimuth bins the TDM-compensated azimuth may move.
    pub tdm_azimuth_search: u8,
    /// Azimuth grid: first and last angle, degrees.
    pub azimuth_span_deg: [f32; 2],
    /// Elevation grid: first and last angle, degrees.
    pub elevation_span_deg: [f32; 2],
    /// OS-CFAR threshold α over the noise level, dB.
    pub cfar_threshold_db: f32,
    /// OS-CFAR quantile q of the training cells, in (0, 1].
    pub cfar_quantile: f32,
    /// CFAR guard half-width along range, bins.
    pub cfar_guard_range: u8,
    /// CFAR guard half-width along azimuth, bins.
    pub cfar_guard_azimuth: u8,
    /// CFAR training half-width along range beyond the guard, bins.
    pub cfar_train_range: u8,
    /// CFAR training half-width along azimuth beyond the guard, bins.
    pub cfar_train_azimuth: u8,
    /// Azimuth bins skipped at each end of the map.
    pub cfar_edge_skip: u8,
    /// Elevation peaks kept per detection, at most.
    pub elevation_max_peaks: u8,
    /// An elevation peak is kept within this many dB of the strongest.
    pub elevation_peak_range_db: f32,
    /// Doppler test, dB: a detection's azimuth beam must peak this far over its Doppler
    /// spectrum's median (0: off, the paper's chain).
    pub doppler_test_db: f32,
    /// Coherent targets: detections of one range bin whose azimuth beams' Dopplers lie within
    /// this many bins are resolved on the FB-averaged sub-array (0: off, the paper's chain).
    pub coherent_doppler_bins: f32,
    /// Spatial smoothing of the azimuth covariance over two sub-lines (off by default).
    pub spatial_smoothing: u8,
    /// Doppler agreement, bins: a point whose own Capon beam peaks farther than this from its
    /// detection's azimuth-beam Doppler is dropped (0: off, the paper's chain).
    pub doppler_agreement_bins: f32,
    /// CFAR window gate, dB: a detection more than this below the strongest cell of its CFAR
    /// window is dropped (0: off, the paper's chain).
    pub cfar_window_gate_db: f32,
    /// Joint elevation fit of the points of each range bin (off by default and in the
    /// paper's chain; `dbe_radar::joint`).
    pub joint_elevation: u8,
    /// Coherent split: a coherent pair merged into one detection is resolved as two (on by
    /// default, off in the paper's chain; `dbe_radar::split`).
    pub coherent_split: u8,
    /// Ring split: a point at the horizon that the elevation row sees clearly weaker than the
    /// azimuth line (a vertical surface's range ring) becomes the two points above and below
    /// the radar (off by default and in the paper's chain; `dbe_radar::ring`).
    pub ring_split: u8,
}

/// Everything `dbe_init` configures.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct dbe_config_t {
    /// The chirp waveform.
    pub waveform: dbe_waveform_t,
    /// The antenna layout.
    pub antennas: dbe_antennas_t,
    /// The chain's parameters.
    pub params: dbe_params_t,
}

/// One point of the cloud, radar frame (x forward, y left, z up).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct dbe_point_t {
    /// Position, m.
    pub x: f32,
    /// Position, m.
    pub y: f32,
    /// Position, m.
    pub z: f32,
    /// Radial velocity, m/s, positive receding.
    pub velocity_mps: f32,
    /// Capon power at the point's direction, dB of range-FFT units squared.
    pub power_db: f32,
    /// Range–azimuth power over the CFAR noise level, dB.
    pub snr_db: f32,
    /// Range bin.
    pub range_bin: u16,
    /// Azimuth grid bin.
    pub azimuth_bin: u16,
    /// Elevation grid bin.
    pub elevation_bin: u16,
    /// Signed Doppler bin, `−loops/2 .. loops/2`.
    pub doppler_bin: i16,
}

/// Statistics of the last processed frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct dbe_frame_stats_t {
    /// CFAR detections kept.
    pub detections: u32,
    /// Detections dropped because the detection list was full.
    pub detection_overflow: u32,
    /// Points written.
    pub points: u32,
    /// Points dropped because the point list was full.
    pub point_overflow: u32,
    /// Range bins skipped (covariance not positive definite).
    pub skipped_range_bins: u32,
    /// Detections that gave no point.
    pub detections_without_point: u32,
    /// Detections whose azimuth beam failed the Doppler test.
    pub doppler_rejected: u32,
}

/// Ego-velocity status: a velocity from enough inliers.
pub const DBE_EGO_OK: u32 = 0;
/// Ego-velocity status: the median radial speed is below the standstill limit; velocity 0.
pub const DBE_EGO_STANDSTILL: u32 = 1;
/// Ego-velocity status: too few points or inliers.
pub const DBE_EGO_TOO_FEW_POINTS: u32 = 2;
/// Ego-velocity status: the inliers' directions do not span 3-D.
pub const DBE_EGO_ILL_CONDITIONED: u32 = 3;

/// The radar's own velocity from the last frame's points (Doppler ego-velocity, for
/// radar-inertial odometry).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct dbe_ego_t {
    /// Velocity of the radar, m/s, radar frame; zero unless the status is OK or standstill.
    pub velocity: [f32; 3],
    /// Its covariance, (m/s)², row-major.
    pub covariance: [f32; 9],
    /// Inliers of the final fit.
    pub inliers: u16,
    /// Points that passed the gate.
    pub points: u16,
    /// A `DBE_EGO_*` value.
    pub status: u32,
}

/// A handle: the caller's state block after a successful `dbe_init` (opaque to C).
pub struct dbe_t {
    _opaque: [u8; 0],
}

// ---------------------------------------------------------------------------------------------
// The state behind a handle

/// Everything of one radar but the cube's mantissas, which live in the caller's cube buffer.
struct State<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
    const DET: usize,
    const P: usize,
> {
    frontend: Frontend<N, K, TX, RX, M, AZ>,
    chain: Dbe<N, K, TX, RX, M, AZ, NAZ, NEL, DET>,
    work: Workspace<N, K, M, NAZ, DET>,
    cloud: PointCloud<P>,
    ego: EgoEstimator<DET>,
    /// The cube over the caller's buffer (its lifetime is the caller's promise).
    cube: Cube<'static, N, K, M>,
    /// Subtracted from every point's range (`dbe_set_range_bias`), m.
    range_bias_m: f32,
}

/// The state block: a header that identifies it, then the preset's state.
#[repr(C)]
struct Handle<S> {
    /// `MAGIC` once initialised.
    magic: u32,
    /// The preset the state is for.
    preset: u32,
    state: S,
}

macro_rules! preset_state {
    ($alias:ident, $p:ident) => {
        type $alias = State<
            { $p::SAMPLES },
            { $p::LOOPS },
            { $p::TX },
            { $p::RX },
            { $p::VIRTUAL },
            { $p::AZIMUTH },
            { $p::AZIMUTH_BINS },
            { $p::ELEVATION_BINS },
            { $p::DETECTIONS },
            { $p::POINTS },
        >;
    };
}
preset_state!(ColoradarState, coloradar);
preset_state!(Iwr6843State, iwr6843);

// The header's `#define`s hold on every target this library is built for.
const _: () = {
    assert!(size_of::<Handle<ColoradarState>>() <= DBE_COLORADAR_STATE_BYTES_MAX);
    assert!(size_of::<Handle<Iwr6843State>>() <= DBE_IWR6843_STATE_BYTES_MAX);
    assert!(size_of::<coloradar::CubeStorage>() == DBE_COLORADAR_CUBE_BYTES);
    assert!(size_of::<iwr6843::CubeStorage>() == DBE_IWR6843_CUBE_BYTES);
    assert!(align_of::<Handle<ColoradarState>>() <= DBE_STATE_ALIGN);
    assert!(align_of::<Handle<Iwr6843State>>() <= DBE_STATE_ALIGN);
    assert!(align_of::<coloradar::CubeStorage>() <= DBE_CUBE_ALIGN);
    assert!(align_of::<iwr6843::CubeStorage>() <= DBE_CUBE_ALIGN);
};

/// What a preset's state can do, so that every entry point is written once.
trait Radar {
    fn push_chirp(&mut self, id: ChirpId, iq: &[i16]) -> dbe_status_t;
    fn push_range_spectra(&mut self, id: ChirpId, values: &[f32]) -> dbe_status_t;
    fn push_range_blocks(
        &mut self,
        id: ChirpId,
        mantissas: &[i16],
        exponents: &[i8],
    ) -> dbe_status_t;
    fn begin_frame(&mut self);
    fn process(&mut self) -> (dbe_status_t, dbe_frame_stats_t);
    fn points(&self) -> &[dbe_radar::points::Point];
    fn ego(&mut self) -> dbe_radar::ego::EgoVelocity;
    fn set_coupling(&mut self, values: &[f32]) -> dbe_status_t;
    fn set_channel_gains(&mut self, values: &[f32]) -> dbe_status_t;
    fn set_range_bias(&mut self, bias_m: f32) -> dbe_status_t;
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
        const P: usize,
    > Radar for State<N, K, TX, RX, M, AZ, NAZ, NEL, DET, P>
{
    fn push_chirp(&mut self, id: ChirpId, iq: &[i16]) -> dbe_status_t {
        if iq.len() != RX * N * 2 {
            return DBE_ERR_CHIRP_SIZE;
        }
        // SAFETY: `[[[i16; 2]; N]; RX]` is `RX · N · 2` contiguous int16 with int16's
        // alignment, exactly what `iq` is; read only, for the duration of the call.
        let chirp = unsafe { &*iq.as_ptr().cast::<[[[i16; 2]; N]; RX]>() };
        match self.frontend.push_chirp(&mut self.cube, id, chirp) {
            Ok(()) => DBE_OK,
            Err(e) => frame_status(e),
        }
    }

    fn push_range_spectra(&mut self, id: ChirpId, values: &[f32]) -> dbe_status_t {
        if values.len() != RX * N * 2 {
            return DBE_ERR_CHIRP_SIZE;
        }
        // SAFETY: `Complex32` is `repr(C)` `{re, im}` of `f32`, so `[[Complex32; N]; RX]` is
        // `RX · N · 2` contiguous `f32` with `f32`'s alignment, exactly what `values` is
        // (the caller checked the alignment); read only, for the duration of the call.
        let spectra = unsafe { &*values.as_ptr().cast::<[[dbe_radar::Complex32; N]; RX]>() };
        match self
            .frontend
            .push_range_spectra(&mut self.cube, id, spectra)
        {
            Ok(()) => DBE_OK,
            Err(e) => frame_status(e),
        }
    }

    fn push_range_blocks(
        &mut self,
        id: ChirpId,
        mantissas: &[i16],
        exponents: &[i8],
    ) -> dbe_status_t {
        if mantissas.len() != RX * N * 2 || exponents.len() != RX {
            return DBE_ERR_CHIRP_SIZE;
        }
        let mut exps = [dbe_radar::BlockExponent::default(); RX];
        for (e, &x) in exps.iter_mut().zip(exponents.iter()) {
            match dbe_radar::BlockExponent::new(x) {
                Some(v) => *e = v,
                None => return DBE_ERR_OUT_OF_RANGE,
            }
        }
        // SAFETY: `[[[i16; 2]; N]; RX]` is `RX · N · 2` contiguous int16 with int16's
        // alignment, exactly what `mantissas` is; read only, for the duration of the call.
        let blocks = unsafe { &*mantissas.as_ptr().cast::<[[[i16; 2]; N]; RX]>() };
        match self
            .frontend
            .push_range_blocks(&mut self.cube, id, blocks, &exps)
        {
            Ok(()) => DBE_OK,
            Err(e) => frame_status(e),
        }
    }

    fn begin_frame(&mut self) {
        self.cube.begin_frame();
    }

    fn process(&mut self) -> (dbe_status_t, dbe_frame_stats_t) {
        let result = match self.frontend.frame(&self.cube) {
            Ok(frame) => {
                use dbe_radar::Chain;
                self.chain.process(&frame, &mut self.work, &mut self.cloud);
                self.cloud.subtract_range_bias(self.range_bias_m);
                DBE_OK
            }
            Err(e) => {
                self.cloud.clear();
                frame_status(e)
            }
        };
        // Whatever happened, the next chirp starts a new frame.
        self.cube.begin_frame();
        let s = self.cloud.stats;
        let stats = dbe_frame_stats_t {
            detections: s.detections,
            detection_overflow: s.detection_overflow,
            points: s.points,
            point_overflow: s.point_overflow,
            skipped_range_bins: s.skipped_range_bins,
            detections_without_point: s.detections_without_point,
            doppler_rejected: s.doppler_rejected,
        };
        (result, stats)
    }

    fn points(&self) -> &[dbe_radar::points::Point] {
        self.cloud.points()
    }

    fn ego(&mut self) -> dbe_radar::ego::EgoVelocity {
        self.ego.estimate(self.cloud.points())
    }

    fn set_coupling(&mut self, values: &[f32]) -> dbe_status_t {
        // values: [tx][rx][bin][re, im], bins = values / (TX · RX · 2).
        let bins = values.len() / (TX * RX * 2);
        if bins * TX * RX * 2 != values.len() || bins > N {
            return DBE_ERR_OUT_OF_RANGE;
        }
        // SAFETY: `Complex32` is `repr(C)` `{ re: f32, im: f32 }`: pairs of floats, float
        // alignment; the slice covers exactly `values`.
        let table: &[dbe_radar::Complex32] =
            unsafe { core::slice::from_raw_parts(values.as_ptr().cast(), values.len() / 2) };
        let slices: [[&[dbe_radar::Complex32]; RX]; TX] = core::array::from_fn(|t| {
            core::array::from_fn(|r| {
                let start = (t * RX + r) * bins;
                table.get(start..start + bins).unwrap_or(&[])
            })
        });
        match self.frontend.set_coupling(&slices) {
            Ok(()) => DBE_OK,
            Err(e) => config_status(e).0,
        }
    }

    fn set_range_bias(&mut self, bias_m: f32) -> dbe_status_t {
        if !bias_m.is_finite() {
            return DBE_ERR_NOT_FINITE;
        }
        self.range_bias_m = bias_m;
        DBE_OK
    }

    fn set_channel_gains(&mut self, values: &[f32]) -> dbe_status_t {
        // values: [tx][rx][re, im], or none to remove the calibration.
        if values.is_empty() {
            self.frontend.clear_channel_gains();
            return DBE_OK;
        }
        if values.len() != TX * RX * 2 {
            return DBE_ERR_OUT_OF_RANGE;
        }
        let gains: [[dbe_radar::Complex32; RX]; TX] = core::array::from_fn(|t| {
            core::array::from_fn(|r| {
                let i = 2 * (t * RX + r);
                dbe_radar::Complex32::new(values[i], values[i + 1])
            })
        });
        match self.frontend.set_channel_gains(&gains) {
            Ok(()) => DBE_OK,
            Err(e) => config_status(e).0,
        }
    }
}

fn frame_status(e: FrameError) -> dbe_status_t {
    match e {
        FrameError::OutOfOrder { .. } => DBE_ERR_CHIRP_OUT_OF_ORDER,
        FrameError::TooManyChirps => DBE_ERR_TOO_MANY_CHIRPS,
        FrameError::Incomplete { .. } => DBE_ERR_FRAME_INCOMPLETE,
    }
}

/// The status of a configuration error and the name of the value it is about.
fn config_status(e: ConfigError) -> (dbe_status_t, &'static [u8]) {
    match e {
        ConfigError::NotFinite(p) => (DBE_ERR_NOT_FINITE, param_name(p)),
        ConfigError::OutOfRange(p) => (DBE_ERR_OUT_OF_RANGE, param_name(p)),
        ConfigError::ArrayShape => (DBE_ERR_ARRAY_SHAPE, b"antennas\0"),
        ConfigError::AzimuthRowCount { .. } => (DBE_ERR_AZIMUTH_ROW_COUNT, b"antennas\0"),
        ConfigError::AzimuthNotUniform => (DBE_ERR_AZIMUTH_NOT_UNIFORM, b"antennas\0"),
        ConfigError::ElevationRowNotFlat => (DBE_ERR_ELEVATION_ROW_NOT_FLAT, b"antennas\0"),
        ConfigError::FrontendUnconfigured => (DBE_ERR_BAD_HANDLE, b"frontend\0"),
    }
}

/// The core's parameter name, NUL-terminated for C (`Param::name` is not).
fn param_name(p: dbe_radar::config::Param) -> &'static [u8] {
    use dbe_radar::config::Param::*;
    match p {
        AdcSampleRate => b"waveform.adc_sample_rate_hz\0",
        Slope => b"waveform.slope_hz_per_s\0",
        StartFrequency => b"waveform.start_frequency_hz\0",
        IdleTime => b"waveform.idle_time_s\0",
        RampEndTime => b"waveform.ramp_end_time_s\0",
        AntennaPosition => b"antennas.tx/rx\0",
        DesignFrequency => b"antennas.f_design_hz\0",
        RangeWindow => b"params.range_first/range_last\0",
        RangeWindowKind => b"params.range_window\0",
        Loading => b"params.loading\0",
        AzimuthSpan => b"params.azimuth_span_deg\0",
        ElevationSpan => b"params.elevation_span_deg\0",
        CfarQuantile => b"params.cfar_quantile\0",
        CfarThreshold => b"params.cfar_threshold_db\0",
        CfarWindow => b"params.cfar_guard/train\0",
        CoherentDoppler => b"params.coherent_doppler_bins\0",
        DopplerTest => b"params.doppler_test_db\0",
        DopplerAgreement => b"params.doppler_agreement_bins\0",
        CfarWindowGate => b"params.cfar_window_gate_db\0",
        ChannelGains => b"channel_gains\0",
        _ => b"params\0",
    }
}

// ---------------------------------------------------------------------------------------------
// Conversions between the C structs and the core's

fn window_kind(w: u32) -> Option<WindowKind> {
    Some(match w {
        DBE_WINDOW_RECTANGULAR => WindowKind::Rectangular,
        DBE_WINDOW_HANN => WindowKind::Hann,
        DBE_WINDOW_HAMMING => WindowKind::Hamming,
        DBE_WINDOW_BLACKMAN => WindowKind::Blackman,
        _ => return None,
    })
}

fn window_code(w: WindowKind) -> u32 {
    match w {
        WindowKind::Rectangular => DBE_WINDOW_RECTANGULAR,
        WindowKind::Hann => DBE_WINDOW_HANN,
        WindowKind::Hamming => DBE_WINDOW_HAMMING,
        WindowKind::Blackman => DBE_WINDOW_BLACKMAN,
    }
}

fn waveform_c(w: &Waveform) -> dbe_waveform_t {
    dbe_waveform_t {
        adc_sample_rate_hz: w.adc_sample_rate_hz,
        slope_hz_per_s: w.slope_hz_per_s,
        start_frequency_hz: w.start_frequency_hz,
        idle_time_s: w.idle_time_s,
        ramp_end_time_s: w.ramp_end_time_s,
    }
}

fn waveform_core(w: &dbe_waveform_t) -> Waveform {
    Waveform {
        adc_sample_rate_hz: w.adc_sample_rate_hz,
        slope_hz_per_s: w.slope_hz_per_s,
        start_frequency_hz: w.start_frequency_hz,
        idle_time_s: w.idle_time_s,
        ramp_end_time_s: w.ramp_end_time_s,
    }
}

fn antennas_c<const TX: usize, const RX: usize>(g: &AntennaGeometry<TX, RX>) -> dbe_antennas_t {
    let mut a = dbe_antennas_t {
        num_tx: TX as u32,
        num_rx: RX as u32,
        f_design_hz: g.f_design_hz,
        ..Default::default()
    };
    for (d, s) in a.tx.iter_mut().zip(g.tx.iter()) {
        *d = [s.0, s.1];
    }
    for (d, s) in a.rx.iter_mut().zip(g.rx.iter()) {
        *d = [s.0, s.1];
    }
    a
}

fn antennas_core<const TX: usize, const RX: usize>(
    a: &dbe_antennas_t,
) -> Result<AntennaGeometry<TX, RX>, dbe_status_t> {
    if a.num_tx as usize != TX || a.num_rx as usize != RX || TX > DBE_MAX_TX || RX > DBE_MAX_RX {
        return Err(DBE_ERR_ARRAY_SHAPE);
    }
    Ok(AntennaGeometry {
        tx: core::array::from_fn(|t| (a.tx[t][0], a.tx[t][1])),
        rx: core::array::from_fn(|r| (a.rx[r][0], a.rx[r][1])),
        f_design_hz: a.f_design_hz,
    })
}

fn params_c(p: &Params) -> dbe_params_t {
    let quantile = match p.cfar.kind {
        CfarKind::OrderStatistic { quantile } => quantile,
        CfarKind::CellAveraging => 0.0,
    };
    dbe_params_t {
        range_first: p.range_first,
        range_last: p.range_last,
        range_window: window_code(p.range_window),
        doppler_window: window_code(p.doppler_window),
        loading: p.loading,
        forward_backward: u8::from(p.forward_backward),
        tdm_compensation: u8::from(p.tdm_compensation),
        subgrid: u8::from(p.subgrid),
        tdm_azimuth_search: p.tdm_azimuth_search,
        azimuth_span_deg: [p.azimuth_span_deg.0, p.azimuth_span_deg.1],
        elevation_span_deg: [p.elevation_span_deg.0, p.elevation_span_deg.1],
        cfar_threshold_db: p.cfar.threshold_db,
        cfar_quantile: quantile,
        cfar_guard_range: p.cfar.guard_range,
        cfar_guard_azimuth: p.cfar.guard_cross,
        cfar_train_range: p.cfar.train_range,
        cfar_train_azimuth: p.cfar.train_cross,
        cfar_edge_skip: p.cfar.edge_skip,
        elevation_max_peaks: p.elevation.max_peaks,
        elevation_peak_range_db: p.elevation.peak_range_db,
        doppler_test_db: p.doppler_test_db,
        coherent_doppler_bins: p.coherent_doppler_bins,
        spatial_smoothing: u8::from(p.spatial_smoothing),
        doppler_agreement_bins: p.doppler_agreement_bins,
        cfar_window_gate_db: p.cfar.window_gate_db,
        joint_elevation: u8::from(p.joint_elevation),
        coherent_split: u8::from(p.coherent_split),
        ring_split: u8::from(p.ring_split),
    }
}

/// The core's parameters from the C struct, on top of `defaults` (for fields C does not set).
fn params_core(
    c: &dbe_params_t,
    defaults: Params,
) -> Result<Params, (dbe_status_t, &'static [u8])> {
    let range_window = window_kind(c.range_window)
        .ok_or((DBE_ERR_OUT_OF_RANGE, b"params.range_window\0".as_slice()))?;
    let doppler_window = window_kind(c.doppler_window)
        .ok_or((DBE_ERR_OUT_OF_RANGE, b"params.doppler_window\0".as_slice()))?;
    let mut p = defaults;
    p.range_first = c.range_first;
    p.range_last = c.range_last;
    p.range_window = range_window;
    p.doppler_window = doppler_window;
    p.loading = c.loading;
    p.forward_backward = c.forward_backward != 0;
    p.tdm_compensation = c.tdm_compensation != 0;
    p.subgrid = c.subgrid != 0;
    p.tdm_azimuth_search = c.tdm_azimuth_search;
    p.azimuth_span_deg = (c.azimuth_span_deg[0], c.azimuth_span_deg[1]);
    p.elevation_span_deg = (c.elevation_span_deg[0], c.elevation_span_deg[1]);
    p.cfar.kind = CfarKind::OrderStatistic {
        quantile: c.cfar_quantile,
    };
    p.cfar.threshold_db = c.cfar_threshold_db;
    p.cfar.guard_range = c.cfar_guard_range;
    p.cfar.guard_cross = c.cfar_guard_azimuth;
    p.cfar.train_range = c.cfar_train_range;
    p.cfar.train_cross = c.cfar_train_azimuth;
    p.cfar.edge_skip = c.cfar_edge_skip;
    p.elevation.max_peaks = c.elevation_max_peaks;
    p.elevation.peak_range_db = c.elevation_peak_range_db;
    p.coherent_doppler_bins = c.coherent_doppler_bins;
    p.doppler_test_db = c.doppler_test_db;
    p.spatial_smoothing = c.spatial_smoothing != 0;
    p.doppler_agreement_bins = c.doppler_agreement_bins;
    p.cfar.window_gate_db = c.cfar_window_gate_db;
    p.joint_elevation = c.joint_elevation != 0;
    p.coherent_split = c.coherent_split != 0;
    p.ring_split = c.ring_split != 0;
    Ok(p)
}

fn point_c(p: &dbe_radar::points::Point) -> dbe_point_t {
    dbe_point_t {
        x: p.position.x,
        y: p.position.y,
        z: p.position.z,
        velocity_mps: p.velocity_mps,
        power_db: p.power_db,
        snr_db: p.snr_db,
        range_bin: p.range_bin,
        azimuth_bin: p.azimuth_bin,
        elevation_bin: p.elevation_bin,
        doppler_bin: p.doppler_bin,
    }
}

// ---------------------------------------------------------------------------------------------
// Presets

/// The sizes of a preset's arrays and buffers.
fn sizes_of<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
    const DET: usize,
    const P: usize,
>() -> dbe_sizes_t {
    dbe_sizes_t {
        samples: N as u32,
        loops: K as u32,
        tx: TX as u32,
        rx: RX as u32,
        virtual_antennas: M as u32,
        azimuth_elements: AZ as u32,
        azimuth_bins: NAZ as u32,
        elevation_bins: NEL as u32,
        max_detections: DET as u32,
        max_points: P as u32,
        chirp_values: (RX * N * 2) as u32,
        chirps_per_frame: (K * TX) as u32,
        state_bytes: size_of::<Handle<State<N, K, TX, RX, M, AZ, NAZ, NEL, DET, P>>>(),
        state_align: align_of::<Handle<State<N, K, TX, RX, M, AZ, NAZ, NEL, DET, P>>>(),
        cube_bytes: size_of::<CubeStorage<N, K, M>>(),
        cube_align: align_of::<CubeStorage<N, K, M>>(),
    }
}

fn preset_sizes(preset: u32) -> Option<dbe_sizes_t> {
    macro_rules! sizes {
        ($p:ident) => {
            sizes_of::<
                { $p::SAMPLES },
                { $p::LOOPS },
                { $p::TX },
                { $p::RX },
                { $p::VIRTUAL },
                { $p::AZIMUTH },
                { $p::AZIMUTH_BINS },
                { $p::ELEVATION_BINS },
                { $p::DETECTIONS },
                { $p::POINTS },
            >()
        };
    }
    match preset {
        DBE_PRESET_COLORADAR => Some(sizes!(coloradar)),
        DBE_PRESET_IWR6843 => Some(sizes!(iwr6843)),
        _ => None,
    }
}

/// Configure a state in place; on error the handle's magic stays 0.
///
/// # Safety
/// `handle` points to `size_of::<Handle<S>>()` writable bytes aligned for it, `cube` to a
/// writable cube storage, both valid and not otherwise used for as long as the handle is.
unsafe fn init_state<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
    const DET: usize,
    const P: usize,
>(
    handle: *mut Handle<State<N, K, TX, RX, M, AZ, NAZ, NEL, DET, P>>,
    preset: u32,
    cube: *mut CubeStorage<N, K, M>,
    config: &dbe_config_t,
    defaults: Params,
) -> Result<(), (dbe_status_t, &'static [u8])> {
    let geometry =
        antennas_core::<TX, RX>(&config.antennas).map_err(|s| (s, b"antennas\0".as_slice()))?;
    let params = params_core(&config.params, defaults)?;
    // SAFETY: the caller guarantees both regions; every field is written (with the core's
    // unconfigured values, which optimised builds write as memset, not through the stack)
    // before the first reference to the state is made.
    unsafe {
        addr_of_mut!((*handle).magic).write(0);
        addr_of_mut!((*handle).preset).write(preset);
        let s = addr_of_mut!((*handle).state);
        addr_of_mut!((*s).frontend).write(Frontend::unconfigured());
        addr_of_mut!((*s).chain).write(Dbe::unconfigured());
        addr_of_mut!((*s).work).write(Workspace::new());
        addr_of_mut!((*s).cloud).write(PointCloud::new());
        addr_of_mut!((*s).ego).write(EgoEstimator::unconfigured());
        addr_of_mut!((*s).cube).write(Cube::new(&mut *cube));
        addr_of_mut!((*s).range_bias_m).write(0.0);
        let state = &mut *s;
        state
            .frontend
            .configure(
                waveform_core(&config.waveform),
                geometry,
                params.range_window,
            )
            .map_err(config_status)?;
        state
            .chain
            .configure(&state.frontend, params)
            .map_err(config_status)?;
        state
            .ego
            .configure(EgoParams::DEFAULT)
            .map_err(config_status)?;
        addr_of_mut!((*handle).magic).write(MAGIC);
    }
    Ok(())
}

/// The radar behind `handle` (an entry point's argument), or return its status from that
/// entry point.
macro_rules! radar_or_return {
    ($handle:expr) => {
        // SAFETY: `radar` checks the handle; the entry point's caller promised the rest.
        match unsafe { radar($handle) } {
            Ok(r) => r,
            Err(e) => return e,
        }
    };
}

/// The radar behind a handle, if the handle is one.
///
/// # Safety
/// `handle` is NULL or points to memory that was passed to `dbe_init` as its state.
unsafe fn radar<'a>(handle: *mut dbe_t) -> Result<&'a mut dyn Radar, dbe_status_t> {
    if handle.is_null() {
        return Err(DBE_ERR_NULL_POINTER);
    }
    if (handle as usize) % align_of::<Handle<()>>() != 0 {
        return Err(DBE_ERR_MISALIGNED);
    }
    // SAFETY: the header has the same layout in every `Handle<S>` (repr(C), first fields);
    // the state is only touched when the magic says it was initialised for that preset.
    unsafe {
        let header = handle as *mut Handle<()>;
        if (*header).magic != MAGIC {
            return Err(DBE_ERR_BAD_HANDLE);
        }
        match (*header).preset {
            DBE_PRESET_COLORADAR => {
                Ok(&mut (*(handle as *mut Handle<ColoradarState>)).state as &mut dyn Radar)
            }
            DBE_PRESET_IWR6843 => {
                Ok(&mut (*(handle as *mut Handle<Iwr6843State>)).state as &mut dyn Radar)
            }
            _ => Err(DBE_ERR_BAD_HANDLE),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Entry points

/// The name of a status code (`"DBE_OK"`, `"DBE_ERR_CHIRP_OUT_OF_ORDER"`, …); `"DBE_ERR_UNKNOWN"`
/// for any other number. Never NULL; the string is static.
#[no_mangle]
pub extern "C" fn dbe_status_name(status: i32) -> *const c_char {
    let s: &'static [u8] = match status {
        0 => b"DBE_OK\0",
        1 => b"DBE_ERR_NULL_POINTER\0",
        2 => b"DBE_ERR_UNKNOWN_PRESET\0",
        3 => b"DBE_ERR_BUFFER_TOO_SMALL\0",
        4 => b"DBE_ERR_MISALIGNED\0",
        5 => b"DBE_ERR_BAD_HANDLE\0",
        6 => b"DBE_ERR_NOT_FINITE\0",
        7 => b"DBE_ERR_OUT_OF_RANGE\0",
        8 => b"DBE_ERR_ARRAY_SHAPE\0",
        9 => b"DBE_ERR_AZIMUTH_ROW_COUNT\0",
        10 => b"DBE_ERR_AZIMUTH_NOT_UNIFORM\0",
        11 => b"DBE_ERR_ELEVATION_ROW_NOT_FLAT\0",
        12 => b"DBE_ERR_CHIRP_SIZE\0",
        13 => b"DBE_ERR_CHIRP_OUT_OF_ORDER\0",
        14 => b"DBE_ERR_TOO_MANY_CHIRPS\0",
        15 => b"DBE_ERR_FRAME_INCOMPLETE\0",
        _ => b"DBE_ERR_UNKNOWN\0",
    };
    s.as_ptr().cast()
}

/// The library's version, `"MAJOR.MINOR.PATCH"` (static, never NULL).
#[no_mangle]
pub extern "C" fn dbe_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

/// The sizes of `preset`: array dimensions, and the bytes and alignment of the state block and
/// the cube the caller provides to `dbe_init`.
///
/// # Safety
/// `out` is NULL or points to a writable `dbe_sizes_t`.
#[no_mangle]
pub unsafe extern "C" fn dbe_sizes(preset: u32, out: *mut dbe_sizes_t) -> dbe_status_t {
    if out.is_null() {
        return DBE_ERR_NULL_POINTER;
    }
    let Some(s) = preset_sizes(preset) else {
        return DBE_ERR_UNKNOWN_PRESET;
    };
    // SAFETY: checked non-null; the caller guarantees it is writable.
    unsafe { out.write(s) };
    DBE_OK
}

/// The default configuration of `preset`: its sensor's waveform and antenna layout and the
/// chain's default parameters (spec §3). Change what differs, then pass it to `dbe_init`.
///
/// # Safety
/// `out` is NULL or points to a writable `dbe_config_t`.
#[no_mangle]
pub unsafe extern "C" fn dbe_default_config(preset: u32, out: *mut dbe_config_t) -> dbe_status_t {
    if out.is_null() {
        return DBE_ERR_NULL_POINTER;
    }
    let c = match preset {
        DBE_PRESET_COLORADAR => dbe_config_t {
            waveform: waveform_c(&coloradar::WAVEFORM),
            antennas: antennas_c(&coloradar::GEOMETRY),
            params: params_c(&coloradar::params()),
        },
        DBE_PRESET_IWR6843 => dbe_config_t {
            waveform: waveform_c(&iwr6843::WAVEFORM),
            antennas: antennas_c(&iwr6843::GEOMETRY),
            params: params_c(&iwr6843::params()),
        },
        _ => return DBE_ERR_UNKNOWN_PRESET,
    };
    // SAFETY: checked non-null; the caller guarantees it is writable.
    unsafe { out.write(c) };
    DBE_OK
}

/// Configure the DBE chain of `preset` in the caller's memory and return its handle.
///
/// `state` (`state_bytes` ≥ `dbe_sizes().state_bytes`, aligned to `state_align`) becomes the
/// handle; `cube` (`cube_bytes` ≥ `dbe_sizes().cube_bytes`, aligned to `cube_align`) holds the
/// radar cube. Both must stay valid, and untouched by the caller, while the handle is used.
/// `config` NULL means `dbe_default_config`. On a configuration error `*detail` (if
/// `detail` is not NULL) names the offending value, a static string; otherwise it is set to
/// NULL. On any error `*out` is NULL and `state` holds no handle.
///
/// # Safety
/// Pointers are NULL or valid for the sizes given; `state` and `cube` do not overlap.
#[no_mangle]
pub unsafe extern "C" fn dbe_init(
    preset: u32,
    state: *mut c_void,
    state_bytes: usize,
    cube: *mut c_void,
    cube_bytes: usize,
    config: *const dbe_config_t,
    out: *mut *mut dbe_t,
    detail: *mut *const c_char,
) -> dbe_status_t {
    let mut why: *const c_char = ptr::null();
    let status = (|| {
        if out.is_null() || state.is_null() || cube.is_null() {
            return DBE_ERR_NULL_POINTER;
        }
        // SAFETY: checked non-null; the caller guarantees it is writable.
        unsafe { out.write(ptr::null_mut()) };
        let Some(sizes) = preset_sizes(preset) else {
            return DBE_ERR_UNKNOWN_PRESET;
        };
        if state_bytes < sizes.state_bytes || cube_bytes < sizes.cube_bytes {
            return DBE_ERR_BUFFER_TOO_SMALL;
        }
        if (state as usize) % sizes.state_align != 0 || (cube as usize) % sizes.cube_align != 0 {
            return DBE_ERR_MISALIGNED;
        }
        let mut default = dbe_config_t::default();
        let config = if config.is_null() {
            // SAFETY: a local.
            unsafe { dbe_default_config(preset, &mut default) };
            &default
        } else {
            // SAFETY: non-null; the caller guarantees a valid struct.
            unsafe { &*config }
        };
        // SAFETY: sizes and alignment checked above; validity is the caller's promise.
        let result = unsafe {
            match preset {
                DBE_PRESET_COLORADAR => init_state(
                    state.cast::<Handle<ColoradarState>>(),
                    preset,
                    cube.cast(),
                    config,
                    coloradar::params(),
                ),
                DBE_PRESET_IWR6843 => init_state(
                    state.cast::<Handle<Iwr6843State>>(),
                    preset,
                    cube.cast(),
                    config,
                    iwr6843::params(),
                ),
                _ => return DBE_ERR_UNKNOWN_PRESET,
            }
        };
        match result {
            Ok(()) => {
                // SAFETY: checked non-null above.
                unsafe { out.write(state.cast()) };
                DBE_OK
            }
            Err((status, name)) => {
                why = name.as_ptr().cast();
                status
            }
        }
    })();
    if !detail.is_null() {
        // SAFETY: non-null; the caller guarantees it is writable.
        unsafe { detail.write(why) };
    }
    status
}

/// Attach a coupling calibration, subtracted from every chirp's range FFT: `values` floats
/// in the order `[tx][rx][range bin][re, im]` for the first `values / (tx · rx · 2)` range
/// bins (at most `samples`), in the units of an unnormalised FFT of the windowed, DC-removed
/// chirp. `values` 0 removes the calibration.
///
/// # Safety
/// `coupling` is valid for `values` floats (or `values` is 0).
#[no_mangle]
pub unsafe extern "C" fn dbe_set_coupling(
    handle: *mut dbe_t,
    coupling: *const f32,
    values: usize,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    // SAFETY: the caller guarantees `values` floats at `coupling`.
    match unsafe { floats(coupling, values) } {
        Ok(v) => r.set_coupling(v),
        Err(e) => e,
    }
}

/// The caller's `values` floats at `ptr` (none when `values` is 0, whatever `ptr`), or
/// `DBE_ERR_NULL_POINTER` for a NULL array of some length.
///
/// # Safety
/// `ptr` is valid for `values` floats for the returned lifetime (or `values` is 0).
unsafe fn floats<'a>(ptr: *const f32, values: usize) -> Result<&'a [f32], dbe_status_t> {
    match (values, ptr.is_null()) {
        (0, _) => Ok(&[]),
        (_, true) => Err(DBE_ERR_NULL_POINTER),
        // SAFETY: non-null, the caller guarantees `values` floats.
        _ => Ok(unsafe { core::slice::from_raw_parts(ptr, values) }),
    }
}

/// Attach a per-channel gain and phase calibration: `values` = `tx · rx · 2` floats in the
/// order `[tx][rx][re, im]` (TX in data order, the TDM slots), each channel's factor, which
/// multiplies its range FFT after the coupling is subtracted (TI's
/// `compRangeBiasAndRxChanPhase` values, reordered to the TDM slots). Factors must be finite
/// and non-zero. `values` 0 removes the calibration.
///
/// # Safety
/// `gains` is valid for `values` floats (or `values` is 0).
#[no_mangle]
pub unsafe extern "C" fn dbe_set_channel_gains(
    handle: *mut dbe_t,
    gains: *const f32,
    values: usize,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    // SAFETY: the caller guarantees `values` floats at `gains`.
    match unsafe { floats(gains, values) } {
        Ok(v) => r.set_channel_gains(v),
        Err(e) => e,
    }
}

/// Set the range bias, m, subtracted from the range of every point of the frames processed
/// after it (TI's `compRangeBiasAndRxChanPhase` first value): each point moves along its
/// direction; one whose range would not stay positive is dropped. 0 (the default) changes
/// nothing.
///
/// # Safety
/// `handle` came from `dbe_init` (NULL is an error).
#[no_mangle]
pub unsafe extern "C" fn dbe_set_range_bias(handle: *mut dbe_t, bias_m: f32) -> dbe_status_t {
    let r = radar_or_return!(handle);
    r.set_range_bias(bias_m)
}

/// The caller's one chirp of `values` `T` at `ptr` (samples or spectra), checked as every
/// chirp entry point checks it: the handle's sizes, then NULL, alignment and count
/// (`chirp_values`).
///
/// # Safety
/// `handle` passed `radar_or_return!`; `ptr` is valid for `values` `T` for the returned
/// lifetime.
unsafe fn chirp_values<'a, T>(
    handle: *mut dbe_t,
    ptr: *const T,
    values: usize,
) -> Result<&'a [T], dbe_status_t> {
    let Some(sizes) = header_sizes(handle) else {
        return Err(DBE_ERR_BAD_HANDLE);
    };
    if ptr.is_null() {
        return Err(DBE_ERR_NULL_POINTER);
    }
    if (ptr as usize) % align_of::<T>() != 0 {
        return Err(DBE_ERR_MISALIGNED);
    }
    if values != sizes.chirp_values as usize {
        return Err(DBE_ERR_CHIRP_SIZE);
    }
    // SAFETY: non-null, aligned, the caller guarantees `values` `T`.
    Ok(unsafe { core::slice::from_raw_parts(ptr, values) })
}

/// Feed one chirp: `iq` holds `chirp_values` int16 (`[rx][sample][I, Q]`, as the ADC
/// delivers them) of TX slot `tx_slot` in loop `loop_index`. Chirps must come in TDM order
/// (loop 0 slot 0, loop 0 slot 1, …); a wrong one is not stored and makes the frame an error.
///
/// # Safety
/// `iq` is valid for `values` int16 values; `handle` came from `dbe_init`.
#[no_mangle]
pub unsafe extern "C" fn dbe_push_chirp(
    handle: *mut dbe_t,
    loop_index: u16,
    tx_slot: u8,
    iq: *const i16,
    values: usize,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    // SAFETY: the caller guarantees `values` int16 at `iq`.
    let samples = match unsafe { chirp_values(handle, iq, values) } {
        Ok(v) => v,
        Err(e) => return e,
    };
    r.push_chirp(
        ChirpId {
            loop_index,
            tx_slot,
        },
        samples,
    )
}

/// Feed one chirp whose range FFT was computed off this core (the radar chip's FFT
/// accelerator, a DSP): `spectra` holds `chirp_values` floats, `[rx][range bin][re, im]`, of TX
/// slot `tx_slot` in loop `loop_index`, in the units of the library's own range FFT: the
/// unnormalised FFT of the chirp's samples with their complex mean removed and the
/// configured range window applied (an accelerator's output scaled back to that). The
/// coupling table, the channel gains, the storage and the TDM order rules are
/// `dbe_push_chirp`'s; a frame may mix both calls.
///
/// # Safety
/// `spectra` is valid for `values` floats; `handle` came from `dbe_init`.
#[no_mangle]
pub unsafe extern "C" fn dbe_push_range_spectra(
    handle: *mut dbe_t,
    loop_index: u16,
    tx_slot: u8,
    spectra: *const f32,
    values: usize,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    // SAFETY: the caller guarantees `values` floats at `spectra`.
    let values = match unsafe { chirp_values(handle, spectra, values) } {
        Ok(v) => v,
        Err(e) => return e,
    };
    r.push_range_spectra(
        ChirpId {
            loop_index,
            tx_slot,
        },
        values,
    )
}

/// Feed one chirp whose range FFT was computed off this core in 16-bit fixed point (an FFT
/// accelerator's output): `mantissas` holds `chirp_values` int16, `[rx][range bin][re, im]`
/// (TI's radar cube, `cmplx16ImRe_t`, holds `[im, re]`: swap them), of TX slot `tx_slot` in
/// loop `loop_index`, and `exponents` one exponent per RX channel (`rx` of them): channel
/// `r`'s spectrum is `mantissa · 2^exponents[r]` in the units of `dbe_push_range_spectra`.
/// An exponent outside −125..112 is `DBE_ERR_OUT_OF_RANGE`, a wrong count
/// `DBE_ERR_CHIRP_SIZE`, and nothing is stored. This is the cube's own format: without a
/// coupling table or channel gains the mantissas are stored as they are (on the Cortex-M4F
/// about 1,700 instructions per ColoRadar chirp, against 9,800 for `dbe_push_range_spectra`
/// and 39,000 for `dbe_push_chirp`); with either, decoded and ingested as
/// `dbe_push_range_spectra` ingests their values. TDM order rules as `dbe_push_chirp`'s.
///
/// # Safety
/// `mantissas` is valid for `values` int16 and `exponents` for `exponent_count` int8;
/// `handle` came from `dbe_init`.
#[no_mangle]
pub unsafe extern "C" fn dbe_push_range_blocks(
    handle: *mut dbe_t,
    loop_index: u16,
    tx_slot: u8,
    mantissas: *const i16,
    values: usize,
    exponents: *const i8,
    exponent_count: usize,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    // SAFETY: the caller guarantees `values` int16 at `mantissas`.
    let values = match unsafe { chirp_values(handle, mantissas, values) } {
        Ok(v) => v,
        Err(e) => return e,
    };
    if exponents.is_null() {
        return DBE_ERR_NULL_POINTER;
    }
    // SAFETY: non-null (int8 needs no alignment); the caller guarantees `exponent_count`
    // int8 at `exponents`.
    let exponents = unsafe { core::slice::from_raw_parts(exponents, exponent_count) };
    r.push_range_blocks(
        ChirpId {
            loop_index,
            tx_slot,
        },
        values,
        exponents,
    )
}

/// Forget the chirps of the frame in progress (and its error, if a chirp was wrong).
///
/// # Safety
/// `handle` came from `dbe_init`.
#[no_mangle]
pub unsafe extern "C" fn dbe_begin_frame(handle: *mut dbe_t) -> dbe_status_t {
    // SAFETY: `radar` checks the handle.
    match unsafe { radar(handle) } {
        Ok(r) => {
            r.begin_frame();
            DBE_OK
        }
        Err(e) => e,
    }
}

/// Process the frame whose chirps were pushed: detections, elevation, Doppler, points. The
/// next chirp starts a new frame, whether the frame was processed or refused (incomplete, a
/// chirp out of order: then there are no points). `stats` may be NULL.
///
/// # Safety
/// `handle` came from `dbe_init`; `stats` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn dbe_process_frame(
    handle: *mut dbe_t,
    stats: *mut dbe_frame_stats_t,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    let (status, s) = r.process();
    if !stats.is_null() {
        // SAFETY: non-null; the caller guarantees it is writable.
        unsafe { stats.write(s) };
    }
    status
}

/// Copy the last frame's points into `out` (at most `capacity`); `*count` is the number of
/// points the frame has (it may exceed `capacity`: then only `capacity` were copied).
///
/// # Safety
/// `handle` came from `dbe_init`; `out` is valid for `capacity` points (or `capacity` is 0);
/// `count` is writable.
#[no_mangle]
pub unsafe extern "C" fn dbe_points(
    handle: *mut dbe_t,
    out: *mut dbe_point_t,
    capacity: usize,
    count: *mut usize,
) -> dbe_status_t {
    let r = radar_or_return!(handle);
    if count.is_null() || (capacity > 0 && out.is_null()) {
        return DBE_ERR_NULL_POINTER;
    }
    let points = r.points();
    for (i, p) in points.iter().take(capacity).enumerate() {
        // SAFETY: i < capacity, within the caller's buffer.
        unsafe { out.add(i).write(point_c(p)) };
    }
    // SAFETY: non-null; the caller guarantees it is writable.
    unsafe { count.write(points.len()) };
    DBE_OK
}

/// The radar's velocity from the last frame's points (static scatterers; moving objects are
/// RANSAC outliers), with its covariance: the input of radar-inertial odometry.
///
/// # Safety
/// `handle` came from `dbe_init`; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn dbe_ego_velocity(handle: *mut dbe_t, out: *mut dbe_ego_t) -> dbe_status_t {
    let r = radar_or_return!(handle);
    if out.is_null() {
        return DBE_ERR_NULL_POINTER;
    }
    let e = r.ego();
    let mut covariance = [0.0f32; 9];
    for (d, s) in covariance.iter_mut().zip(e.covariance.iter().flatten()) {
        *d = *s;
    }
    let status = match e.status {
        EgoStatus::Ok => DBE_EGO_OK,
        EgoStatus::Standstill => DBE_EGO_STANDSTILL,
        EgoStatus::TooFewPoints => DBE_EGO_TOO_FEW_POINTS,
        EgoStatus::IllConditioned => DBE_EGO_ILL_CONDITIONED,
    };
    // SAFETY: non-null; the caller guarantees it is writable.
    unsafe {
        out.write(dbe_ego_t {
            velocity: [e.velocity.x, e.velocity.y, e.velocity.z],
            covariance,
            inliers: e.inliers,
            points: e.points,
            status,
        })
    };
    DBE_OK
}

/// The sizes of a valid handle's preset.
fn header_sizes(handle: *mut dbe_t) -> Option<dbe_sizes_t> {
    // SAFETY: only called after `radar` accepted the handle.
    let preset = unsafe { (*(handle as *mut Handle<()>)).preset };
    preset_sizes(preset)
}

// ---------------------------------------------------------------------------------------------
// Panics (none are expected: the core does not panic on any input)

#[cfg(all(not(test), target_os = "none"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        // A permanently undefined instruction: the core faults (HardFault), where the
        // firmware's fault handler or a debugger sees it.
        #[cfg(target_arch = "arm")]
        // SAFETY: `udf` only raises the fault.
        unsafe {
            core::arch::asm!("udf #0xfe")
        };
    }
}

#[cfg(all(not(test), not(target_os = "none")))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    extern "C" {
        fn abort() -> !;
    }
    // SAFETY: the C library's `abort` takes no arguments and does not return.
    unsafe { abort() }
}
