//! Test helpers: a minimal spec-§2 frame generator and a DCA1000 decoder for the TI fixture.
//!
//! The generator is deliberately small and independent of the project's simulator: it writes
//! the §2 sample formula literally, so the harness tests do not depend on `host-sim::sim`.

#![allow(dead_code)]

use std::f64::consts::PI;
use std::path::PathBuf;

use host_sim::frame::AdcFrame;
use host_sim::sensor::SensorConfig;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// Speed of light, m/s.
pub const C: f64 = 299_792_458.0;

/// One point scatterer.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    /// Position at the frame start, radar frame (x forward, y left, z up), m.
    pub position: [f64; 3],
    /// Radial velocity (range rate), m/s, positive receding.
    pub radial_velocity: f64,
    /// Amplitude A, ADC units.
    pub amplitude: f64,
}

impl Target {
    /// A target at `range` m, azimuth `az_deg`, elevation `el_deg` (spec §2 angles:
    /// μ = sin φ·cos θ, ν = sin θ; positive azimuth towards −y).
    pub fn at(range: f64, az_deg: f64, el_deg: f64, radial_velocity: f64, amplitude: f64) -> Self {
        let (phi, theta) = (az_deg.to_radians(), el_deg.to_radians());
        let mu = phi.sin() * theta.cos();
        let nu = theta.sin();
        let x = (1.0 - mu * mu - nu * nu).sqrt();
        Self {
            position: [range * x, -range * mu, range * nu],
            radial_velocity,
            amplitude,
        }
    }

    /// Range at the frame start, m.
    pub fn range(&self) -> f64 {
        self.position.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// Direction cosines (μ, ν).
    pub fn direction(&self) -> (f64, f64) {
        let r = self.range();
        (-self.position[1] / r, self.position[2] / r)
    }
}

/// Derived waveform quantities of spec §2.
pub struct Derived {
    /// Carrier `f_c`, Hz.
    pub fc: f64,
    /// Wavelength, m.
    pub lambda: f64,
    /// Chirp period Tc, s.
    pub tc: f64,
    /// Loop period, s.
    pub t_loop: f64,
    /// Metres per range bin.
    pub range_bin: f64,
    /// m/s per Doppler bin.
    pub doppler_bin: f64,
}

/// Spec §2 quantities of `sensor`.
pub fn derived(sensor: &SensorConfig) -> Derived {
    let w = &sensor.waveform;
    let n = sensor.samples as f64;
    let fc = w.start_frequency_hz + w.slope_hz_per_s * (n / w.adc_sample_rate_hz) / 2.0;
    let lambda = C / fc;
    let tc = w.idle_time_s + w.ramp_end_time_s;
    let t_loop = sensor.num_tx as f64 * tc;
    Derived {
        fc,
        lambda,
        tc,
        t_loop,
        range_bin: C * w.adc_sample_rate_hz / (2.0 * w.slope_hz_per_s * n),
        doppler_bin: lambda / (2.0 * sensor.loops as f64 * t_loop),
    }
}

/// One frame of `sensor` seeing `targets`, spec §2: per virtual antenna m = (t, r), loop k,
/// sample n, `A·exp(j·[2π·(2·S·R/c)·n/fs + 4π·R·f_0/c − κ·(μ·az_m + ν·el_m) + φ0])` with
/// `R = R0 + v·τ`, `τ = k·T_loop + t·Tc`, a random φ0 per target, plus complex white
/// Gaussian noise of standard deviation `noise_sigma` per component, rounded and clipped to
/// int16.
pub fn synth_frame(
    sensor: &SensorConfig,
    targets: &[Target],
    noise_sigma: f64,
    seed: u64,
) -> AdcFrame {
    let d = derived(sensor);
    let w = &sensor.waveform;
    let kappa = PI * d.fc / sensor.f_design_hz;
    // Spec §2 (amended): the range phase's carrier is the first sample's frequency f_0, not
    // f_c (with f_c, simulated Doppler reads B/(2·f_c) high: 0.77 % on ColoRadar's waveform).
    let f0 = sensor.first_sample_frequency_hz();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let phases: Vec<f64> = targets
        .iter()
        .map(|_| rng.gen_range(0.0..2.0 * PI))
        .collect();
    let noise = Normal::new(0.0, noise_sigma).expect("finite, non-negative sigma");
    let (n_s, k_s, tx_s, rx_s) = (sensor.samples, sensor.loops, sensor.num_tx, sensor.num_rx);
    let mut frame = AdcFrame::zeros(n_s, k_s, tx_s, rx_s);
    for k in 0..k_s {
        for t in 0..tx_s {
            let tau = k as f64 * d.t_loop + t as f64 * d.tc;
            for r in 0..rx_s {
                let az = f64::from(sensor.tx[t].0) + f64::from(sensor.rx[r].0);
                let el = f64::from(sensor.tx[t].1) + f64::from(sensor.rx[r].1);
                for n in 0..n_s {
                    let (mut re, mut im) = (noise.sample(&mut rng), noise.sample(&mut rng));
                    for (tg, phi0) in targets.iter().zip(&phases) {
                        let range = tg.range() + tg.radial_velocity * tau;
                        let (mu, nu) = tg.direction();
                        let beat = 2.0 * w.slope_hz_per_s * range / C;
                        let phase = 2.0 * PI * beat * n as f64 / w.adc_sample_rate_hz
                            + 4.0 * PI * range * f0 / C
                            - kappa * (mu * az + nu * el)
                            + phi0;
                        re += tg.amplitude * phase.cos();
                        im += tg.amplitude * phase.sin();
                    }
                    let idx = frame.index(k, t, r, n);
                    frame.data[idx] = [to_i16(re), to_i16(im)];
                }
            }
        }
    }
    frame
}

fn to_i16(v: f64) -> i16 {
    v.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}

/// `/work/shared`-style folder beside the repository root.
pub fn shared_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared")
}

/// Read a fixture file under `../shared/fixtures`. Missing: panic naming the path when
/// `CI=true`, else print a skip message and return `None`.
pub fn fixture(relative: &str) -> Option<Vec<u8>> {
    let path = shared_dir().join("fixtures").join(relative);
    match std::fs::read(&path) {
        Ok(bytes) => Some(bytes),
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("fixture {} is required under CI: {e}", path.display());
            }
            eprintln!("skipping: fixture {} not readable: {e}", path.display());
            None
        }
    }
}
