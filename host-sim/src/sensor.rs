//! Sensor description with runtime sizes: what a calibration folder says.

use dbe_radar::{AntennaGeometry, Waveform};
use num_complex::Complex32;

/// ColoRadar-style coupling calibration: `data[(t·rx + r)·range_bins + b]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Coupling {
    /// Range bins in the table.
    pub range_bins: usize,
    /// Complex values, `[tx][rx][range bin]`.
    pub data: Vec<Complex32>,
}

/// Everything known about a sensor: sizes, waveform, antenna layout, optional coupling.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorConfig {
    /// Complex ADC samples per chirp.
    pub samples: usize,
    /// Loops (chirps per TX) per frame.
    pub loops: usize,
    /// TX count (TDM slots, data order).
    pub num_tx: usize,
    /// RX count.
    pub num_rx: usize,
    /// Chirp waveform.
    pub waveform: Waveform,
    /// `(az, el)` per TX in half-wavelength units, by TX data index.
    pub tx: Vec<(f32, f32)>,
    /// `(az, el)` per RX.
    pub rx: Vec<(f32, f32)>,
    /// Frequency of the half-wavelength unit, Hz.
    pub f_design_hz: f64,
    /// Coupling calibration, when present.
    pub coupling: Option<Coupling>,
    /// Per-channel gain and phase calibration, `[tx][rx]` in data order (`tx · rx` factors
    /// multiplying each channel's range spectrum after the coupling; TI's
    /// `compRangeBiasAndRxChanPhase`), when present.
    pub channel_gains: Option<Vec<Complex32>>,
    /// Range bias, m: subtracted from every point's range (TI's `compRangeBiasAndRxChanPhase`
    /// first value; `dbe_radar::PointCloud::subtract_range_bias`); 0 when unknown.
    pub range_bias_m: f64,
    /// Time from the ramp start to the first ADC sample (`adc_start_time`), s; 0 when the
    /// calibration omits it (spec §2).
    pub adc_start_time_s: f64,
}

impl SensorConfig {
    /// ColoRadar's single-chip sensor (built-in values of `calib/single_chip`), no coupling.
    pub fn coloradar() -> Self {
        let g = AntennaGeometry::COLORADAR;
        Self {
            samples: 128,
            loops: 128,
            num_tx: 3,
            num_rx: 4,
            waveform: Waveform::COLORADAR,
            tx: g.tx.to_vec(),
            rx: g.rx.to_vec(),
            f_design_hz: g.f_design_hz,
            coupling: None,
            channel_gains: None,
            range_bias_m: 0.0,
            adc_start_time_s: 0.0,
        }
    }

    /// Frequency of the ramp at the first ADC sample, `f_0 = f_start + S·t_adc`, Hz: the
    /// carrier of the signal model's range phase (spec §2).
    pub fn first_sample_frequency_hz(&self) -> f64 {
        self.waveform.start_frequency_hz + self.waveform.slope_hz_per_s * self.adc_start_time_s
    }

    /// The TI IWR6843 fixture's sensor (RF values assumed, see the fixture README).
    pub fn iwr6843_fixture() -> Self {
        let g = AntennaGeometry::IWR6843_FIXTURE;
        Self {
            samples: 256,
            loops: 64,
            num_tx: 3,
            num_rx: 4,
            waveform: Waveform::IWR6843_FIXTURE,
            tx: g.tx.to_vec(),
            rx: g.rx.to_vec(),
            f_design_hz: g.f_design_hz,
            coupling: None,
            channel_gains: None,
            range_bias_m: 0.0,
            adc_start_time_s: 0.0,
        }
    }

    /// A 2 TX × 4 RX radar on one line (`dbe_radar::presets::awr1642`: AWR1642 / IWR1443
    /// class) with ColoRadar's waveform and frame size; its points are azimuth-only.
    pub fn awr1642() -> Self {
        let g = AntennaGeometry::AWR1642;
        Self {
            num_tx: 2,
            tx: g.tx.to_vec(),
            rx: g.rx.to_vec(),
            f_design_hz: g.f_design_hz,
            ..Self::coloradar()
        }
    }

    /// Whether the virtual array has elements off its lowest row (an elevation row): without
    /// one, the chains give azimuth-only points (elevation 0).
    pub fn measures_elevation(&self) -> bool {
        let el = |t: &(f32, f32), r: &(f32, f32)| t.1 + r.1;
        let mut all = self
            .tx
            .iter()
            .flat_map(|t| self.rx.iter().map(move |r| el(t, r)));
        let Some(first) = all.next() else {
            return false;
        };
        all.any(|e| (e - first).abs() > 1e-3)
    }

    /// The 3 TX × 4 RX geometry the core takes, if the sizes fit.
    pub fn geometry(&self) -> Option<AntennaGeometry<3, 4>> {
        Some(AntennaGeometry {
            tx: self.tx.clone().try_into().ok()?,
            rx: self.rx.clone().try_into().ok()?,
            f_design_hz: self.f_design_hz,
        })
    }

    /// Bytes of one raw frame (int16 I and Q).
    pub fn frame_bytes(&self) -> usize {
        self.samples * self.loops * self.num_tx * self.num_rx * 4
    }
}
