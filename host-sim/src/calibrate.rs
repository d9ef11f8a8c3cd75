//! Channel calibration from a corner reflector, as TI's `measureRangeBiasAndRxChanPhase` does
//! it: the per-channel gain and phase factors and the range bias of
//! `compRangeBiasAndRxChanPhase` (read back by [`crate::io::ticfg`], applied by
//! `dbe_radar::Frontend::set_channel_gains` and `PointCloud::subtract_range_bias`).
//!
//! ```text
//! per channel c : range spectrum of every chirp (the contract's range step), mean over the loops
//!                 and frames → X_c[b]  (a static reflector adds up coherently, noise does not)
//! peak          : b* = argmax Σ_c |X_c[b]|² within distance ± search; range = (b* + δ)·Δr with δ
//!                 the chains' sub-grid offset (the log-power parabola through b* − 1, b*, b* + 1),
//!                 so that the bias is measured as the points' ranges are
//! range bias    : range − distance
//! factors       : g_c = conj(x_c) · min_c|x_c| / |x_c|², x_c = X_c[b*]: every channel then has
//!                 the weakest one's amplitude and phase 0, what a reflector at boresight gives
//!                 on a matched array (every factor has |g| ≤ 1, as TI's Q15 values must)
//! ```
//!
//! The reflector must be at boresight (azimuth and elevation 0) and alone within the search
//! window; nothing else of the scene may move.

use num_complex::{Complex32, Complex64};
use rustfft::FftPlanner;

use crate::frame::AdcFrame;
use crate::reference;
use crate::sensor::SensorConfig;
use dbe_radar::window::WindowKind;

/// What the reflector gave.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelCalibration {
    /// Range bias, m: measured range − the reflector's distance.
    pub range_bias_m: f64,
    /// The reflector's measured range, m.
    pub range_m: f64,
    /// Its range bin (the peak, before interpolation).
    pub range_bin: usize,
    /// Its power over the median range bin outside its main lobe, dB (how clearly it stands
    /// out of everything else the capture holds).
    pub peak_over_median_db: f64,
    /// Factors in data order `[tx slot][rx]` (`SensorConfig::channel_gains`).
    pub gains: Vec<Complex32>,
    /// The reflector's phase on each channel before calibration, degrees, relative to the
    /// first channel (data order).
    pub phases_deg: Vec<f64>,
    /// Its amplitude on each channel against the first, dB (data order).
    pub amplitudes_db: Vec<f64>,
}

/// Why no calibration could be measured.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    /// No frames given.
    #[error("no frames to measure the reflector in")]
    NoFrames,
    /// A frame's sizes are not the sensor's.
    #[error("frame {index} has {found} values, the sensor's frame has {expected}")]
    FrameSize {
        /// The frame.
        index: usize,
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// The search window lies outside the measured ranges or is empty.
    #[error("the search window {from_m:.3}–{to_m:.3} m holds no range bin (bins 1..{bins} cover {bin_m:.4} m each)")]
    Window {
        /// Window start, m.
        from_m: f64,
        /// Window end, m.
        to_m: f64,
        /// Range bins.
        bins: usize,
        /// Metres per bin.
        bin_m: f64,
    },
    /// A channel has no signal at the peak.
    #[error("channel {channel} (TX slot {tx}, RX {rx}) has no signal at the reflector's range bin {bin}")]
    DeadChannel {
        /// Data-order channel index.
        channel: usize,
        /// Its TX slot.
        tx: usize,
        /// Its RX.
        rx: usize,
        /// The peak bin.
        bin: usize,
    },
    /// The distance or the search width is not a positive finite number.
    #[error("distance {distance_m} m and search ±{search_m} m must be positive and finite")]
    Arguments {
        /// The distance given.
        distance_m: f64,
        /// The search half-width given.
        search_m: f64,
    },
}

/// Measure the factors and the range bias from `frames` of a corner reflector at boresight,
/// `distance_m` from the radar, searching `distance_m ± search_m` (module docs). The range
/// window is the chains' (`window`).
pub fn measure(
    frames: &[AdcFrame],
    sensor: &SensorConfig,
    window: WindowKind,
    distance_m: f64,
    search_m: f64,
) -> Result<ChannelCalibration, CalibrationError> {
    if !(distance_m > 0.0 && distance_m.is_finite() && search_m > 0.0 && search_m.is_finite()) {
        return Err(CalibrationError::Arguments {
            distance_m,
            search_m,
        });
    }
    if frames.is_empty() {
        return Err(CalibrationError::NoFrames);
    }
    let (n, channels) = (sensor.samples, sensor.num_tx * sensor.num_rx);
    let expected = sensor.loops * channels * n;
    let w = reference::window(window, n);
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    let mut mean = vec![vec![Complex64::new(0.0, 0.0); n]; channels];
    let mut buf = vec![Complex64::new(0.0, 0.0); n];
    for (index, frame) in frames.iter().enumerate() {
        if frame.data.len() != expected {
            return Err(CalibrationError::FrameSize {
                index,
                expected,
                found: frame.data.len(),
            });
        }
        for k in 0..sensor.loops {
            for (c, acc) in mean.iter_mut().enumerate() {
                let start = frame.index(k, c / sensor.num_rx, c % sensor.num_rx, 0);
                reference::range_spectrum(
                    &frame.data[start..start + n],
                    &w,
                    fft.as_ref(),
                    &mut buf,
                );
                for (a, v) in acc.iter_mut().zip(&buf) {
                    *a += *v;
                }
            }
        }
    }
    let bin_m = sensor.waveform.range_bin_m(n);
    // Bins 1 ..= n − 2, so that the peak has both neighbours.
    let lo = (((distance_m - search_m) / bin_m).ceil().max(1.0)) as usize;
    let hi = (((distance_m + search_m) / bin_m).floor() as usize).min(n.saturating_sub(2));
    if lo > hi {
        return Err(CalibrationError::Window {
            from_m: distance_m - search_m,
            to_m: distance_m + search_m,
            bins: n,
            bin_m,
        });
    }
    // Σ_c |X_c[b]|² per range bin.
    let power: Vec<f64> = (0..n)
        .map(|b| mean.iter().map(|x| x[b].norm_sqr()).sum())
        .collect();
    let peak = (lo..=hi)
        .max_by(|&a, &b| power[a].total_cmp(&power[b]))
        .unwrap_or(lo);
    let delta = reference::log_parabola_vertex(power[peak - 1], power[peak], power[peak + 1]);
    let range_m = (peak as f64 + delta) * bin_m;
    // The floor: every range bin but the peak's main lobe (a Blackman lobe is ±3 bins wide).
    let mut others: Vec<f64> = (1..n)
        .filter(|&x| x.abs_diff(peak) > 3)
        .map(|x| power[x])
        .collect();
    others.sort_by(f64::total_cmp);
    let floor = others.get(others.len() / 2).copied().unwrap_or(0.0);
    let peak_over_median_db = if floor > 0.0 {
        10.0 * (power[peak] / floor).log10()
    } else {
        f64::INFINITY
    };

    let x: Vec<Complex64> = mean.iter().map(|m| m[peak]).collect();
    if let Some(channel) = x.iter().position(|v| !(v.norm_sqr() > 0.0)) {
        return Err(CalibrationError::DeadChannel {
            channel,
            tx: channel / sensor.num_rx,
            rx: channel % sensor.num_rx,
            bin: peak,
        });
    }
    let weakest = x.iter().map(|v| v.norm()).fold(f64::INFINITY, f64::min);
    let gains = x
        .iter()
        .map(|v| {
            let g = v.conj() * (weakest / v.norm_sqr());
            Complex32::new(g.re as f32, g.im as f32)
        })
        .collect();
    Ok(ChannelCalibration {
        range_bias_m: range_m - distance_m,
        range_m,
        range_bin: peak,
        peak_over_median_db,
        gains,
        phases_deg: x.iter().map(|v| (v / x[0]).arg().to_degrees()).collect(),
        amplitudes_db: x
            .iter()
            .map(|v| 20.0 * (v.norm() / x[0].norm()).log10())
            .collect(),
    })
}
