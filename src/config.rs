//! The sensor's runtime description (waveform, antenna geometry, the cube row order derived
//! from it) and the one error type of configuration.
//!
//! Values live at runtime, shapes live in types: the array sizes are const generics, every
//! value is validated once (by [`crate::Frontend::new`] and the chains' `configure`) into a
//! typed [`ConfigError`] that names the offending parameter. After that the hot path is
//! infallible. Each stage's parameters live with the stage ([`crate::cfar::CfarParams`],
//! [`crate::elevation::ElevationParams`], the chains' [`crate::Params`] and
//! [`crate::FftParams`]).

use core::fmt;

/// Speed of light in vacuum, m/s.
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;

/// The chirp waveform, in SI units (the values of ColoRadar's `waveform_cfg.txt`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waveform {
    /// ADC sample rate fs, Hz (complex samples per second).
    pub adc_sample_rate_hz: f64,
    /// Chirp slope S, Hz/s.
    pub slope_hz_per_s: f64,
    /// Start frequency of the ramp, Hz.
    pub start_frequency_hz: f64,
    /// Idle time before each ramp, s.
    pub idle_time_s: f64,
    /// Ramp end time, s. The chirp period is `Tc = idle + ramp_end`.
    pub ramp_end_time_s: f64,
}

impl Waveform {
    /// ColoRadar's single-chip AWR1843BOOST waveform (`calib/single_chip/waveform_cfg.txt`).
    pub const COLORADAR: Self = Self {
        adc_sample_rate_hz: 10_666_000.0,
        slope_hz_per_s: 1.000_000_003_77e14,
        start_frequency_hz: 76_999_999_488.0,
        idle_time_s: 0.000_110_000_000_859,
        ramp_end_time_s: 1.999_999_949_48e-5,
    };

    /// The TI IWR6843 fixture's waveform. Its RF values are ASSUMED (typical IWR6843
    /// settings, see `shared/fixtures/ti-iwr6843-corner-reflector/README.md`): bin indices and
    /// angles do not depend on them, metres and m/s do.
    pub const IWR6843_FIXTURE: Self = Self {
        adc_sample_rate_hz: 10_000_000.0,
        slope_hz_per_s: 60.0e12,
        start_frequency_hz: 60.25e9,
        idle_time_s: 10.0e-6,
        ramp_end_time_s: 60.0e-6,
    };

    /// Every field zero: the waveform of an unconfigured frontend (all-zero bytes).
    pub(crate) const ZEROED: Self = Self {
        adc_sample_rate_hz: 0.0,
        slope_hz_per_s: 0.0,
        start_frequency_hz: 0.0,
        idle_time_s: 0.0,
        ramp_end_time_s: 0.0,
    };

    /// Chirp period `Tc = idle + ramp_end`, s: the time between two TX slots.
    pub fn chirp_period_s(&self) -> f64 {
        self.idle_time_s + self.ramp_end_time_s
    }

    /// Loop period `T_loop = num_tx · Tc`, s: the slow-time sample interval.
    pub fn loop_period_s(&self, num_tx: usize) -> f64 {
        num_tx as f64 * self.chirp_period_s()
    }

    /// Carrier used for phases: `f_c = f_start + S · (N / fs) / 2`, Hz.
    pub fn center_frequency_hz(&self, samples: usize) -> f64 {
        self.start_frequency_hz
            + self.slope_hz_per_s * (samples as f64 / self.adc_sample_rate_hz) / 2.0
    }

    /// Wavelength at the carrier, `λ = c / f_c`, m.
    pub fn wavelength_m(&self, samples: usize) -> f64 {
        SPEED_OF_LIGHT / self.center_frequency_hz(samples)
    }

    /// Range per range bin, `c · fs / (2 · S · N)`, m.
    pub fn range_bin_m(&self, samples: usize) -> f64 {
        SPEED_OF_LIGHT * self.adc_sample_rate_hz / (2.0 * self.slope_hz_per_s * samples as f64)
    }

    /// Radial velocity per Doppler bin, `λ / (2 · K · T_loop)`, m/s.
    pub fn doppler_bin_mps(&self, samples: usize, loops: usize, num_tx: usize) -> f64 {
        self.wavelength_m(samples) / (2.0 * loops as f64 * self.loop_period_s(num_tx))
    }

    /// Every value inside what FMCW radars can do ([`limits`]), so that every derived
    /// quantity (bin sizes, wavelengths, phases) is finite and meaningful.
    pub(crate) fn validate(&self) -> Result<(), ConfigError> {
        within(
            self.adc_sample_rate_hz,
            limits::ADC_SAMPLE_RATE_HZ,
            Param::AdcSampleRate,
        )?;
        within(self.slope_hz_per_s, limits::SLOPE_HZ_PER_S, Param::Slope)?;
        within(
            self.start_frequency_hz,
            limits::START_FREQUENCY_HZ,
            Param::StartFrequency,
        )?;
        within(self.idle_time_s, limits::IDLE_TIME_S, Param::IdleTime)?;
        within(
            self.ramp_end_time_s,
            limits::RAMP_END_TIME_S,
            Param::RampEndTime,
        )
    }
}

/// What FMCW radars can do: the closed range each configured value must lie in, SI units.
/// Wide enough for every single-chip radar from 24 to 300 GHz; narrow enough that an accepted
/// configuration cannot produce a non-finite bin size, wavelength or phase.
pub mod limits {
    /// ADC sample rate, Hz (100 ksps to 1 Gsps).
    pub const ADC_SAMPLE_RATE_HZ: (f64, f64) = (1e5, 1e9);
    /// Chirp slope, Hz/s (0.1 to 1000 MHz/µs).
    pub const SLOPE_HZ_PER_S: (f64, f64) = (1e11, 1e15);
    /// Ramp start frequency, Hz (1 to 300 GHz).
    pub const START_FREQUENCY_HZ: (f64, f64) = (1e9, 300e9);
    /// Idle time before a ramp, s (0 to 10 ms).
    pub const IDLE_TIME_S: (f64, f64) = (0.0, 1e-2);
    /// Ramp end time, s (100 ns to 10 ms).
    pub const RAMP_END_TIME_S: (f64, f64) = (1e-7, 1e-2);
    /// Frequency of the antenna layout's half-wavelength unit, Hz (1 to 300 GHz).
    pub const DESIGN_FREQUENCY_HZ: (f64, f64) = (1e9, 300e9);
}

/// Antenna positions in half-wavelength units at `f_design_hz` (ColoRadar's `antenna_cfg.txt`).
///
/// Virtual antenna `(t, r)` sits at `az = tx[t].0 + rx[r].0`, `el = tx[t].1 + rx[r].1`, where
/// `t` is the TX *data index*, which is also its TDM slot: TX `t` fires at `t · Tc` in each loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AntennaGeometry<const TX: usize, const RX: usize> {
    /// `(az, el)` of each TX, indexed by TX data index.
    pub tx: [(f32, f32); TX],
    /// `(az, el)` of each RX.
    pub rx: [(f32, f32); RX],
    /// Frequency at which the half-wavelength units are defined, Hz.
    pub f_design_hz: f64,
}

impl AntennaGeometry<3, 4> {
    /// ColoRadar single-chip layout: TX0 at az 0, TX1 at az 4, TX2 at az 2 / el 1;
    /// `F_design` = 76.8 GHz (inferred, see `shared/fixtures/coloradar-calib/README.md`).
    pub const COLORADAR: Self = Self {
        tx: [(0.0, 0.0), (4.0, 0.0), (2.0, 1.0)],
        rx: [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)],
        f_design_hz: 76.8e9,
    };

    /// The IWR6843 fixture's layout (inferred from its phases): TX0 at az 0, TX1 at az 2 /
    /// el 1, TX2 at az 4; `F_design` = 60.5 GHz.
    pub const IWR6843_FIXTURE: Self = Self {
        tx: [(0.0, 0.0), (2.0, 1.0), (4.0, 0.0)],
        rx: [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)],
        f_design_hz: 60.5e9,
    };
}

impl AntennaGeometry<2, 4> {
    /// A 2 TX × 4 RX board with both TX on the RX line, 2 λ apart (AWR1642BOOST, IWR1443BOOST
    /// class): an 8-element uniform azimuth line and no elevation row.
    pub const AWR1642: Self = Self {
        tx: [(0.0, 0.0), (4.0, 0.0)],
        rx: [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)],
        f_design_hz: 76.8e9,
    };
}

/// Where each virtual antenna went: the cube's row order, derived from an [`AntennaGeometry`].
///
/// Rows `0..AZ` are the azimuth line (lowest elevation), sorted by azimuth position; rows
/// `AZ..M` are the elevation row, sorted by azimuth position. The azimuth covariance is then
/// the top-left `AZ × AZ` block of the full `M × M` covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrayLayout<const TX: usize, const RX: usize, const M: usize> {
    /// Cube row of virtual antenna `(t, r)`: `row_of[t][r]`.
    pub row_of: [[u8; RX]; TX],
    /// Azimuth position of each row, half-wavelength units.
    pub az: [f32; M],
    /// Elevation position of each row, half-wavelength units (relative to the azimuth line).
    pub el: [f32; M],
    /// TDM slot (TX data index) of each row.
    pub slot: [u8; M],
}

impl<const TX: usize, const RX: usize, const M: usize> ArrayLayout<TX, RX, M> {
    /// Every field zero: the layout of an unconfigured frontend or chain (all-zero bytes).
    pub(crate) const ZEROED: Self = Self {
        row_of: [[0; RX]; TX],
        az: [0.0; M],
        el: [0.0; M],
        slot: [0; M],
    };

    /// Sort the virtual array into an azimuth line of `az` elements followed by the rest.
    ///
    /// The azimuth line is the `az` elements at the lowest elevation; it must be a uniform line
    /// (constant non-zero spacing), which forward–backward averaging requires. All remaining
    /// elements must share one elevation different from the line's.
    pub fn new(geometry: &AntennaGeometry<TX, RX>, az: usize) -> Result<Self, ConfigError> {
        if TX * RX != M || M > u8::MAX as usize || az == 0 || az > M {
            return Err(ConfigError::ArrayShape);
        }
        for &(a, e) in geometry.tx.iter().chain(geometry.rx.iter()) {
            finite(f64::from(a), Param::AntennaPosition)?;
            finite(f64::from(e), Param::AntennaPosition)?;
        }
        within(
            geometry.f_design_hz,
            limits::DESIGN_FREQUENCY_HZ,
            Param::DesignFrequency,
        )?;

        // Virtual positions in data order m = t·RX + r.
        let mut pos = [(0.0f32, 0.0f32, 0u8, 0u8); M];
        for (t, &(ta, te)) in geometry.tx.iter().enumerate() {
            for (r, &(ra, re)) in geometry.rx.iter().enumerate() {
                pos[t * RX + r] = (ta + ra, te + re, t as u8, r as u8);
            }
        }
        // Sort by (elevation, azimuth); insertion sort keeps this allocation-free and stable.
        for i in 1..M {
            let mut j = i;
            while j > 0 && key_less(pos[j], pos[j - 1]) {
                pos.swap(j, j - 1);
                j -= 1;
            }
        }
        let line_el = pos[0].1;
        let line_count = pos.iter().filter(|p| p.1 == line_el).count();
        if line_count != az {
            return Err(ConfigError::AzimuthRowCount {
                found: line_count as u8,
                expected: az as u8,
            });
        }
        if az > 1 {
            let spacing = pos[1].0 - pos[0].0;
            let uniform = spacing.abs() > 1e-3
                && (1..az).all(|i| ((pos[i].0 - pos[i - 1].0) - spacing).abs() <= 1e-3);
            if !uniform {
                return Err(ConfigError::AzimuthNotUniform);
            }
        }
        if az < M {
            let row_el = pos[az].1;
            if pos[az..].iter().any(|p| p.1 != row_el) {
                return Err(ConfigError::ElevationRowNotFlat);
            }
        }
        let mut layout = Self {
            row_of: [[0; RX]; TX],
            az: [0.0; M],
            el: [0.0; M],
            slot: [0; M],
        };
        for (row, &(a, e, t, r)) in pos.iter().enumerate() {
            layout.row_of[t as usize][r as usize] = row as u8;
            layout.az[row] = a;
            layout.el[row] = e - line_el;
            layout.slot[row] = t;
        }
        Ok(layout)
    }
}

fn key_less(a: (f32, f32, u8, u8), b: (f32, f32, u8, u8)) -> bool {
    (a.1, a.0) < (b.1, b.0)
}

/// A configuration parameter, named in [`ConfigError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// `Waveform::adc_sample_rate_hz`.
    AdcSampleRate,
    /// `Waveform::slope_hz_per_s`.
    Slope,
    /// `Waveform::start_frequency_hz`.
    StartFrequency,
    /// `Waveform::idle_time_s`.
    IdleTime,
    /// `Waveform::ramp_end_time_s`.
    RampEndTime,
    /// An antenna position.
    AntennaPosition,
    /// `AntennaGeometry::f_design_hz`.
    DesignFrequency,
    /// `Params::range_first` / `range_last`.
    RangeWindow,
    /// `Params::range_window`: it must be the frontend's.
    RangeWindowKind,
    /// `Params::loading`.
    Loading,
    /// `Params::azimuth_span_deg`.
    AzimuthSpan,
    /// `Params::elevation_span_deg`.
    ElevationSpan,
    /// `CfarKind::OrderStatistic::quantile`.
    CfarQuantile,
    /// `CfarParams::threshold_db`.
    CfarThreshold,
    /// `CfarParams` guard / training sizes.
    CfarWindow,
    /// `CfarParams::edge_skip`.
    CfarEdgeSkip,
    /// `ElevationParams`.
    ElevationPeakRange,
    /// The coupling calibration table.
    Coupling,
    /// A grid size (azimuth or elevation bins) too small for peak finding.
    GridSize,
    /// `EgoParams` (gates, thresholds, RANSAC probabilities).
    EgoVelocity,
    /// `Params::coherent_doppler_bins`.
    CoherentDoppler,
    /// `Params::doppler_test_db`.
    DopplerTest,
    /// `Params::doppler_agreement_bins`.
    DopplerAgreement,
    /// `CfarParams::window_gate_db`.
    CfarWindowGate,
    /// The per-channel gain and phase calibration.
    ChannelGains,
}

impl Param {
    /// The parameter's name as written in configuration files and docs.
    pub const fn name(self) -> &'static str {
        match self {
            Param::AdcSampleRate => "adc_sample_frequency",
            Param::Slope => "frequency_slope",
            Param::StartFrequency => "start_frequency",
            Param::IdleTime => "idle_time",
            Param::RampEndTime => "ramp_end_time",
            Param::AntennaPosition => "antenna position",
            Param::DesignFrequency => "F_design",
            Param::RangeWindow => "range window (range_first..=range_last)",
            Param::RangeWindowKind => "range window kind (must be the frontend's)",
            Param::Loading => "diagonal loading γ",
            Param::AzimuthSpan => "azimuth span",
            Param::ElevationSpan => "elevation span",
            Param::CfarQuantile => "CFAR quantile q",
            Param::CfarThreshold => "CFAR threshold α",
            Param::CfarWindow => "CFAR training window",
            Param::CfarEdgeSkip => "CFAR azimuth edge skip",
            Param::ElevationPeakRange => "elevation peak rules",
            Param::Coupling => "coupling calibration",
            Param::GridSize => "angle grid size",
            Param::EgoVelocity => "ego-velocity parameters",
            Param::CoherentDoppler => "coherent Doppler window (bins)",
            Param::DopplerTest => "Doppler test threshold (dB)",
            Param::DopplerAgreement => "Doppler agreement window (bins)",
            Param::CfarWindowGate => "CFAR window gate (dB)",
            Param::ChannelGains => "channel gain and phase calibration",
        }
    }
}

/// Why a configuration was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    /// The parameter is NaN or infinite.
    NotFinite(Param),
    /// The parameter is outside its valid range.
    OutOfRange(Param),
    /// `TX · RX` does not equal the compiled virtual-antenna count `M`, or `AZ > M`.
    ArrayShape,
    /// The lowest-elevation line does not hold the compiled number of azimuth elements.
    AzimuthRowCount {
        /// Elements found at the lowest elevation.
        found: u8,
        /// Compiled azimuth element count.
        expected: u8,
    },
    /// The azimuth line is not uniformly spaced (forward–backward averaging needs it).
    AzimuthNotUniform,
    /// The elements off the azimuth line do not share one elevation.
    ElevationRowNotFlat,
    /// A chain was configured from a frontend that was never configured.
    FrontendUnconfigured,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::NotFinite(p) => write!(f, "{} is not a finite number", p.name()),
            ConfigError::OutOfRange(p) => write!(f, "{} is out of range", p.name()),
            ConfigError::ArrayShape => {
                write!(f, "num_tx × num_rx does not match the compiled virtual array")
            }
            ConfigError::AzimuthRowCount { found, expected } => write!(
                f,
                "antenna geometry: {found} virtual antennas on the azimuth line, expected {expected}"
            ),
            ConfigError::AzimuthNotUniform => {
                write!(f, "antenna geometry: the azimuth line is not uniformly spaced")
            }
            ConfigError::ElevationRowNotFlat => write!(
                f,
                "antenna geometry: the elements off the azimuth line are not on one elevation row"
            ),
            ConfigError::FrontendUnconfigured => {
                write!(f, "the frontend was not configured before the chain")
            }
        }
    }
}

impl core::error::Error for ConfigError {}

pub(crate) fn finite(v: f64, p: Param) -> Result<(), ConfigError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::NotFinite(p))
    }
}

/// A finite `v` inside the closed range `(lo, hi)`.
pub(crate) fn within(v: f64, (lo, hi): (f64, f64), p: Param) -> Result<(), ConfigError> {
    finite(v, p)?;
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange(p))
    }
}

/// An angle span `a < b` inside `±limit` degrees.
pub(crate) fn span(a: f32, b: f32, limit: f32, p: Param) -> Result<(), ConfigError> {
    finite(f64::from(a), p)?;
    finite(f64::from(b), p)?;
    if a < b && a >= -limit && b <= limit {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange(p))
    }
}

/// Check what both chains' parameters share: the processed range bins `first..=last` inside
/// `samples` bins, and the azimuth and elevation grid spans.
pub(crate) fn validate_bins_and_spans(
    first: u16,
    last: u16,
    samples: usize,
    azimuth_span_deg: (f32, f32),
    elevation_span_deg: (f32, f32),
) -> Result<(), ConfigError> {
    if first > last || usize::from(last) >= samples {
        return Err(ConfigError::OutOfRange(Param::RangeWindow));
    }
    let (a0, a1) = azimuth_span_deg;
    span(a0, a1, SPAN_LIMIT_DEG, Param::AzimuthSpan)?;
    let (e0, e1) = elevation_span_deg;
    span(e0, e1, SPAN_LIMIT_DEG, Param::ElevationSpan)
}

/// Largest angle magnitude of a grid span, degrees.
pub(crate) const SPAN_LIMIT_DEG: f32 = 89.9;

/// `sin` of `L` angles evenly spaced over `span` degrees (both ends included, as linspace):
/// the direction cosines of an angle grid. Both chains build their grids with it, so their
/// bins are identical.
pub(crate) fn sine_grid<const L: usize>(span: (f32, f32)) -> [f32; L] {
    let mut g = [0.0f32; L];
    let (a, b) = (f64::from(span.0), f64::from(span.1));
    let step = if L > 1 { (b - a) / (L - 1) as f64 } else { 0.0 };
    for (i, v) in g.iter_mut().enumerate() {
        *v = libm::sin((a + step * i as f64).to_radians()) as f32;
    }
    g
}

/// `sin` of the angle at fractional index `x` of a `len`-point linspace over `span` degrees
/// (sub-grid refinement between the bins of [`sine_grid`]).
pub(crate) fn sine_at(span: (f32, f32), len: usize, x: f32) -> f32 {
    let step = if len > 1 {
        (span.1 - span.0) / (len - 1) as f32
    } else {
        0.0
    };
    libm::sinf((span.0 + step * x).to_radians())
}
