//! The per-antenna SNR used throughout the evaluation, and its conversion to ADC amplitudes.
//!
//! **Definition.** The SNR of a target is the per-antenna, per-chirp SNR *after the range
//! FFT*, in the target's range bin: `ρ = |α|² / σ²`, where `α` is the target's complex value
//! in one snapshot `x[m, k]` (one virtual antenna `m`, one loop `k`) of that bin and `σ²` the
//! noise power of one snapshot. It is the SNR of the data both chains' angle and Doppler
//! stages see, and the `ρ` of the Cramér–Rao bound ([`super::crb`]).
//!
//! **Relation to the ADC.** With ADC amplitude `A` (LSB), noise standard deviation `s` on I
//! and on Q (plus the int16 rounding, `1/12` LSB² per component), the complex noise power per
//! ADC sample is `σ_c² = 2·(s² + 1/12)`. A target on a range-bin centre has zero mean over the
//! chirp (DC removal takes nothing from it) and gives `|α| = A·Σw` after the window `w` and
//! the unnormalised FFT; the noise gives `σ² = σ_c²·Σw²`. Hence
//!
//! ```text
//! ρ = (A² / σ_c²) · G,   G = (Σw)² / Σw² = N / ENBW
//! ```
//!
//! For ColoRadar's 128-sample Blackman window `G` = 73.9 (18.7 dB): a per-ADC-sample SNR
//! `A²/σ_c²` is 18.7 dB below `ρ`. Further integration is up to the chains: `K` = 128 loops
//! (21.1 dB) and 8 or 12 antennas (9.0 / 10.8 dB).

use dbe_radar::presets::coloradar as p;

/// Window gains and noise of the ColoRadar preset's range processing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SnrModel {
    /// ADC noise standard deviation on I and on Q, LSB.
    pub noise_std: f64,
    /// `Σw` of the range window.
    pub window_sum: f64,
    /// `Σw²` of the range window.
    pub window_energy: f64,
}

impl SnrModel {
    /// The ColoRadar preset's range window (the DBE defaults) with ADC noise `noise_std`.
    pub fn coloradar(noise_std: f64) -> Self {
        let w: [f32; p::SAMPLES] = dbe_radar::Params::defaults(p::SAMPLES)
            .range_window
            .coefficients();
        Self {
            noise_std,
            window_sum: w.iter().map(|&c| f64::from(c)).sum(),
            window_energy: w.iter().map(|&c| f64::from(c) * f64::from(c)).sum(),
        }
    }

    /// Complex noise power per ADC sample, `σ_c² = 2·(s² + 1/12)`, LSB².
    pub fn adc_noise_power(&self) -> f64 {
        2.0 * (self.noise_std * self.noise_std + 1.0 / 12.0)
    }

    /// Noise power of one snapshot after the range FFT, `σ_c²·Σw²`.
    pub fn snapshot_noise_power(&self) -> f64 {
        self.adc_noise_power() * self.window_energy
    }

    /// Range-FFT SNR gain `G = (Σw)²/Σw²` (linear).
    pub fn range_gain(&self) -> f64 {
        self.window_sum * self.window_sum / self.window_energy
    }

    /// ADC amplitude `A` (LSB) of a target on a bin centre with snapshot SNR `snr_db`.
    pub fn amplitude(&self, snr_db: f64) -> f64 {
        (db_to_linear(snr_db) * self.adc_noise_power() / self.range_gain()).sqrt()
    }

    /// The snapshot's complex amplitude modulus `|α| = A·Σw` for ADC amplitude `a`.
    pub fn snapshot_amplitude(&self, a: f64) -> f64 {
        a * self.window_sum
    }

    /// Per-ADC-sample SNR `A²/σ_c²` (dB) of snapshot SNR `snr_db`.
    pub fn adc_snr_db(&self, snr_db: f64) -> f64 {
        snr_db - 10.0 * self.range_gain().log10()
    }
}

/// `10^(db/10)`.
pub fn db_to_linear(db: f64) -> f64 {
    10f64.powf(db / 10.0)
}
