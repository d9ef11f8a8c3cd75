//! Cramér–Rao bounds of one source seen by the ColoRadar array in one range bin.
//!
//! # Model
//!
//! Both chains estimate angles and Doppler from the range-FFT output of the target's range
//! bin: `M` virtual antennas × `K` loops of snapshots. For one point source in that bin,
//! snapshot `(m, k)` is
//!
//! ```text
//! x[m,k] = α · exp( j·[ ω·(k + τ_m) − κ·(μ·az_m + ν·el_m) ] ) + n[m,k]
//! ```
//!
//! with `α` the complex amplitude after the range FFT (unknown), `ω` the Doppler phase per
//! loop (rad; `ω = 4π·v·T_loop/λ`), `τ_m = t_m / TX` the TDM slot offset of row `m` in loops,
//! `az_m`, `el_m` the positions in half-wavelength units, `κ = π·f_c/F_design`, and `n` white
//! complex Gaussian noise of known power `σ²` per snapshot. The per-snapshot SNR is
//! `ρ = |α|²/σ²`; [`super::snr`] relates it to the ADC samples.
//!
//! # Fisher information
//!
//! For a deterministic signal `s(θ)` in white complex noise of known power `σ²`,
//! `J_ij = (2/σ²)·Re Σ (∂s/∂θ_i)* (∂s/∂θ_j)` (Kay, *Fundamentals of Statistical Signal
//! Processing I*, eq. 15.52). Write `α = |α|·e^{jψ}` and the phase `Φ[m,k] = ψ + ω(k + τ_m) −
//! κ(μ·az_m + ν·el_m)`: every parameter except `|α|` enters through `Φ`, and
//! `∂s/∂|α|` is orthogonal to all of them, so on `(ψ, μ, ν, ω)`
//!
//! ```text
//! J = 2ρ · Σ_{m,k} g·gᵀ,    g = ∂Φ/∂(ψ, μ, ν, ω) = (1, −κ·az_m, −κ·el_m, k + τ_m).
//! ```
//!
//! The unknown phase `ψ` is eliminated by the Schur complement of its entry, which centres
//! `g`: the bound on `(μ, ν, ω)` is the inverse of `2ρ · Σ (g − ḡ)(g − ḡ)ᵀ`. Without the slot
//! offsets (`τ_m = 0`) the snapshot set is the product of rows and loops, the centred loop
//! index is orthogonal to the centred positions, and
//!
//! ```text
//! CRB(μ, ν) = [2ρ·K·κ² · S]⁻¹,   S = Σ_m (p_m − p̄)(p_m − p̄)ᵀ,  p_m = (az_m, el_m)
//! CRB(ω)    = 1 / (2ρ·M·Σ_k (k − k̄)²) = 6 / (ρ·M·K·(K² − 1)).
//! ```
//!
//! **Azimuth** is estimated from the 8-element line (both chains): positions 0..7, `ν` does
//! not enter, `S_az = Σ (az − 3.5)² = 42`, so `CRB(μ) = 1/(84·ρ·K·κ²)`. **Elevation** uses the
//! whole 12-element array with `μ` unknown too: the elevation row (az 2..5, el 1) is centred
//! on the line's centre, so `S` is diagonal (`Σ(az − ā)(el − ē) = 0`) and
//! `CRB(ν) = 1/(2ρ·K·κ²·S_el)` with `S_el = Σ (el − 1/3)² = 8/3`. The TDM offsets couple `ω` to
//! the positions through `Σ (τ_m − τ̄)(p_m − p̄)`, which changes these bounds by about 1e-5
//! relative for ColoRadar (the exact inverse, [`SnapshotModel::crb`], includes it).
//!
//! Angles follow by the delta method: `φ = asin(μ/√(1 − ν²))`, `θ = asin ν`,
//! `var φ = (∂φ/∂μ)²·var μ + (∂φ/∂ν)²·var ν` ([`angle_variances`]). Radial velocity:
//! `v = ω·λ/(4π·T_loop)`.
//!
//! These are bounds for unbiased estimators that use the one range bin; an estimator confined
//! to a grid (0.75° azimuth, 0.5° elevation, one Doppler bin) cannot follow them once they fall
//! below the grid's quantisation error (step/√12).

use nalgebra::DMatrix;
use num_complex::Complex64;

use dbe_radar::config::ArrayLayout;
use dbe_radar::presets::coloradar as p;
use dbe_radar::{AntennaGeometry, Waveform};

/// An unknown parameter of the snapshot model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unknown {
    /// Azimuth direction cosine μ.
    Mu,
    /// Elevation direction cosine ν.
    Nu,
    /// Doppler phase per loop ω, rad.
    Omega,
    /// Real part of the amplitude α.
    AmplitudeRe,
    /// Imaginary part of the amplitude α.
    AmplitudeIm,
}

/// The parameters of one source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Azimuth direction cosine μ.
    pub mu: f64,
    /// Elevation direction cosine ν.
    pub nu: f64,
    /// Doppler phase per loop ω, rad.
    pub omega: f64,
    /// Complex amplitude α after the range FFT.
    pub amplitude: Complex64,
}

impl Source {
    fn get(&self, u: Unknown) -> f64 {
        match u {
            Unknown::Mu => self.mu,
            Unknown::Nu => self.nu,
            Unknown::Omega => self.omega,
            Unknown::AmplitudeRe => self.amplitude.re,
            Unknown::AmplitudeIm => self.amplitude.im,
        }
    }

    fn with(mut self, u: Unknown, v: f64) -> Self {
        match u {
            Unknown::Mu => self.mu = v,
            Unknown::Nu => self.nu = v,
            Unknown::Omega => self.omega = v,
            Unknown::AmplitudeRe => self.amplitude.re = v,
            Unknown::AmplitudeIm => self.amplitude.im = v,
        }
        self
    }
}

/// The snapshot model of one range bin: element positions, TDM offsets, `κ` and `K`.
#[derive(Clone, Debug, PartialEq)]
pub struct SnapshotModel {
    /// Azimuth position of each element, half-wavelength units.
    pub az: Vec<f64>,
    /// Elevation position of each element, half-wavelength units.
    pub el: Vec<f64>,
    /// TDM offset `τ_m = t_m / TX` of each element, loops.
    pub offset: Vec<f64>,
    /// Phase per half-wavelength unit and unit direction cosine, `κ = π·f_c/F_design`.
    pub kappa: f64,
    /// Loops (snapshots) `K`.
    pub loops: usize,
}

/// Why a bound could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CrbError {
    /// The Fisher information is singular for these unknowns (a parameter does not enter).
    #[error("the Fisher information is singular for {0:?}")]
    Singular(Vec<Unknown>),
    /// The array's geometry is rejected by the core's layout rules.
    #[error("antenna geometry: {0}")]
    Geometry(dbe_radar::ConfigError),
}

impl SnapshotModel {
    /// The ColoRadar array in the core's row order (8-element line, then the elevation row),
    /// `K = 128`.
    pub fn coloradar() -> Result<Self, CrbError> {
        let g = AntennaGeometry::COLORADAR;
        let layout = ArrayLayout::<{ p::TX }, { p::RX }, { p::VIRTUAL }>::new(&g, p::AZIMUTH)
            .map_err(CrbError::Geometry)?;
        let fc = Waveform::COLORADAR.center_frequency_hz(p::SAMPLES);
        Ok(Self {
            az: layout.az.iter().map(|&a| f64::from(a)).collect(),
            el: layout.el.iter().map(|&e| f64::from(e)).collect(),
            offset: layout
                .slot
                .iter()
                .map(|&t| f64::from(t) / p::TX as f64)
                .collect(),
            kappa: std::f64::consts::PI * fc / g.f_design_hz,
            loops: p::LOOPS,
        })
    }

    /// The first `count` elements only (the azimuth line for `count = 8`).
    pub fn first(&self, count: usize) -> Self {
        let n = count.min(self.az.len());
        Self {
            az: self.az[..n].to_vec(),
            el: self.el[..n].to_vec(),
            offset: self.offset[..n].to_vec(),
            kappa: self.kappa,
            loops: self.loops,
        }
    }

    /// Elements `M`.
    pub fn elements(&self) -> usize {
        self.az.len()
    }

    /// Phase of snapshot `(m, k)` without the amplitude's phase.
    fn phase(&self, s: &Source, m: usize, k: usize) -> f64 {
        s.omega * (k as f64 + self.offset[m]) - self.kappa * (s.mu * self.az[m] + s.nu * self.el[m])
    }

    /// The noiseless snapshots `s[m·K + k]`.
    pub fn signal(&self, s: &Source) -> Vec<Complex64> {
        let mut out = Vec::with_capacity(self.elements() * self.loops);
        for m in 0..self.elements() {
            for k in 0..self.loops {
                out.push(s.amplitude * Complex64::from_polar(1.0, self.phase(s, m, k)));
            }
        }
        out
    }

    /// `∂s/∂θ` for each unknown, analytic.
    fn jacobian(&self, s: &Source, unknowns: &[Unknown]) -> Vec<Vec<Complex64>> {
        let j = Complex64::new(0.0, 1.0);
        unknowns
            .iter()
            .map(|u| {
                let mut col = Vec::with_capacity(self.elements() * self.loops);
                for m in 0..self.elements() {
                    for k in 0..self.loops {
                        let e = Complex64::from_polar(1.0, self.phase(s, m, k));
                        col.push(match u {
                            Unknown::Mu => -j * self.kappa * self.az[m] * s.amplitude * e,
                            Unknown::Nu => -j * self.kappa * self.el[m] * s.amplitude * e,
                            Unknown::Omega => j * (k as f64 + self.offset[m]) * s.amplitude * e,
                            Unknown::AmplitudeRe => e,
                            Unknown::AmplitudeIm => j * e,
                        });
                    }
                }
                col
            })
            .collect()
    }

    /// `∂s/∂θ` by central differences of [`Self::signal`] with step `h` (absolute, per
    /// parameter): an independent check of [`Self::fisher`].
    fn jacobian_fd(&self, s: &Source, unknowns: &[Unknown], h: f64) -> Vec<Vec<Complex64>> {
        unknowns
            .iter()
            .map(|&u| {
                let x = s.get(u);
                let plus = self.signal(&s.with(u, x + h));
                let minus = self.signal(&s.with(u, x - h));
                plus.iter()
                    .zip(&minus)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect()
            })
            .collect()
    }

    /// The Fisher information on `unknowns` for noise power `noise_power` per snapshot,
    /// from the analytic derivatives.
    pub fn fisher(&self, s: &Source, unknowns: &[Unknown], noise_power: f64) -> DMatrix<f64> {
        gram(&self.jacobian(s, unknowns), noise_power)
    }

    /// The Fisher information from central differences of the signal model with step `h`.
    pub fn fisher_finite_difference(
        &self,
        s: &Source,
        unknowns: &[Unknown],
        noise_power: f64,
        h: f64,
    ) -> DMatrix<f64> {
        gram(&self.jacobian_fd(s, unknowns, h), noise_power)
    }

    /// The bounds (variances) of `unknowns`, in their order: the diagonal of the inverse
    /// Fisher information.
    pub fn crb(
        &self,
        s: &Source,
        unknowns: &[Unknown],
        noise_power: f64,
    ) -> Result<Vec<f64>, CrbError> {
        let j = self.fisher(s, unknowns, noise_power);
        let inv = j
            .try_inverse()
            .filter(|m| m.diagonal().iter().all(|v| v.is_finite() && *v > 0.0))
            .ok_or_else(|| CrbError::Singular(unknowns.to_vec()))?;
        Ok(inv.diagonal().iter().copied().collect())
    }
}

/// `J = (2/σ²)·Re(Dᴴ D)` for the columns `D`.
fn gram(cols: &[Vec<Complex64>], noise_power: f64) -> DMatrix<f64> {
    let n = cols.len();
    DMatrix::from_fn(n, n, |a, b| {
        let dot: Complex64 = cols[a]
            .iter()
            .zip(&cols[b])
            .map(|(x, y)| x.conj() * y)
            .sum();
        2.0 * dot.re / noise_power
    })
}

/// Closed-form bounds on `(μ, ν)` for per-snapshot SNR `snr` (linear) and `loops` snapshots
/// of an array at `(az, el)` (no TDM offsets): the inverse of `2ρ·K·κ²·S` (module docs).
/// Returns `(var μ, var ν)`; `var ν` is infinite when the array has no elevation extent.
pub fn direction_cosine_crb(
    snr: f64,
    loops: usize,
    az: &[f64],
    el: &[f64],
    kappa: f64,
) -> (f64, f64) {
    let n = az.len().min(el.len()) as f64;
    let (ma, me) = (az.iter().sum::<f64>() / n, el.iter().sum::<f64>() / n);
    let (mut saa, mut see, mut sae) = (0.0, 0.0, 0.0);
    for (a, e) in az.iter().zip(el) {
        saa += (a - ma) * (a - ma);
        see += (e - me) * (e - me);
        sae += (a - ma) * (e - me);
    }
    let scale = 2.0 * snr * loops as f64 * kappa * kappa;
    let det = saa * see - sae * sae;
    if det <= 1e-12 * (saa * saa + see * see) {
        // One-dimensional array: only μ is identifiable.
        return (1.0 / (scale * saa), f64::INFINITY);
    }
    (see / (scale * det), saa / (scale * det))
}

/// Closed-form bound on the Doppler phase per loop ω (rad²) for `elements` elements and
/// `loops` snapshots at per-snapshot SNR `snr` (linear): `6 / (ρ·M·K·(K² − 1))`.
pub fn omega_crb(snr: f64, elements: usize, loops: usize) -> f64 {
    let k = loops as f64;
    6.0 / (snr * elements as f64 * k * (k * k - 1.0))
}

/// Delta-method variances of azimuth φ and elevation θ (rad²) from those of `μ` and `ν`
/// at the true `(μ, ν)`, treating the two estimates as uncorrelated (they are, for
/// ColoRadar: module docs).
pub fn angle_variances(mu: f64, nu: f64, var_mu: f64, var_nu: f64) -> (f64, f64) {
    let c2 = (1.0 - nu * nu).max(1e-12);
    let c = c2.sqrt();
    let u = mu / c;
    let d = (1.0 - u * u).max(1e-12).sqrt();
    let dphi_dmu = 1.0 / (c * d);
    let dphi_dnu = mu * nu / (c2 * c * d);
    let var_phi = dphi_dmu * dphi_dmu * var_mu + dphi_dnu * dphi_dnu * var_nu;
    let var_theta = var_nu / c2;
    (var_phi, var_theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coloradar_positions_are_centred_as_the_docs_say() -> Result<(), CrbError> {
        let m = SnapshotModel::coloradar()?;
        assert_eq!(m.elements(), 12);
        let line = m.first(8);
        let mean = line.az.iter().sum::<f64>() / 8.0;
        let s: f64 = line.az.iter().map(|a| (a - mean).powi(2)).sum();
        assert!((s - 42.0).abs() < 1e-9);
        let me = m.el.iter().sum::<f64>() / 12.0;
        let see: f64 = m.el.iter().map(|e| (e - me).powi(2)).sum();
        assert!((see - 8.0 / 3.0).abs() < 1e-9);
        Ok(())
    }
}
