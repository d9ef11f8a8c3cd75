//! Elevation: the DBE chain's Capon sweep with its peak rules (spec §3 step 3), and the FFT
//! chain's phase-difference estimate (spec §4).
//!
//! The sweep evaluates the full-array Capon spectrum `P(ν_j) = 1 / aᴴ R⁻¹ a` with
//! `a = a(μ_detection, ν_j)` over the `NEL` grid bins, on the loaded (and, with TDM
//! compensation, rotated) `M × M` covariance, without forward–backward averaging (the
//! 12-element array is not centro-symmetric: averaging mirrors +θ onto −θ). It keeps the
//! interior local maxima, at most `max_peaks`, each within `peak_range_db` of the strongest.

use num_complex::Complex32;

use crate::capon::Capon;
use crate::config::{finite, ConfigError, Param};

/// The most elevation peaks a detection may keep (bounds a stack buffer).
pub const MAX_ELEVATION_PEAKS: usize = 4;

/// Rules for keeping elevation-spectrum peaks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElevationParams {
    /// Peaks kept per detection, at most (interior local maxima only).
    pub max_peaks: u8,
    /// A peak is kept only within this many dB of the strongest peak.
    pub peak_range_db: f32,
}

impl ElevationParams {
    /// At most 2 peaks within 6 dB of the strongest (spec §3).
    pub const DEFAULT: Self = Self {
        max_peaks: 2,
        peak_range_db: 6.0,
    };

    /// Every field zero (an unconfigured chain).
    pub(crate) const ZEROED: Self = Self {
        max_peaks: 0,
        peak_range_db: 0.0,
    };

    pub(crate) fn validate(&self) -> Result<(), ConfigError> {
        finite(f64::from(self.peak_range_db), Param::ElevationPeakRange)?;
        if self.max_peaks == 0
            || usize::from(self.max_peaks) > MAX_ELEVATION_PEAKS
            || self.peak_range_db < 0.0
        {
            return Err(ConfigError::OutOfRange(Param::ElevationPeakRange));
        }
        Ok(())
    }
}

impl Default for ElevationParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Up to [`MAX_ELEVATION_PEAKS`] `(grid bin, power)` pairs, strongest first.
pub type Peaks = [Option<(usize, f32)>; MAX_ELEVATION_PEAKS];

/// Sweep the Capon spectrum of `capon` (the solver of the loaded covariance) along the
/// elevation grid, `steer(j)` the steering vector of bin `j` at the detection's azimuth, into
/// `spectrum` (linear), and return its peaks.
pub fn sweep<const M: usize, const NEL: usize>(
    capon: &Capon<M>,
    steer: impl Fn(usize) -> [Complex32; M],
    p: &ElevationParams,
    spectrum: &mut [f32; NEL],
) -> Peaks {
    for (j, s) in spectrum.iter_mut().enumerate() {
        *s = capon.power(&steer(j));
    }
    strongest_interior_peaks(spectrum, usize::from(p.max_peaks), p.peak_range_db)
}

/// The full-array steering vector `a(μ, ν)`: the element-wise product of its azimuth row
/// `exp(−j·κ·μ·az_m)` and elevation row `exp(−j·κ·ν·el_m)`.
pub fn steering<const M: usize>(az: &[Complex32; M], el: &[Complex32; M]) -> [Complex32; M] {
    let mut a = [Complex32::new(0.0, 0.0); M];
    for ((o, x), y) in a.iter_mut().zip(az.iter()).zip(el.iter()) {
        *o = x * y;
    }
    a
}

/// Up to `max` interior local maxima of `p` (`p[j−1] < p[j] ≥ p[j+1]`), strongest first, each
/// within `range_db` of the strongest.
pub fn strongest_interior_peaks<const L: usize>(p: &[f32; L], max: usize, range_db: f32) -> Peaks {
    let max = max.min(MAX_ELEVATION_PEAKS);
    let mut best: Peaks = [None; MAX_ELEVATION_PEAKS];
    for j in 1..L.saturating_sub(1) {
        if !(p[j] > p[j - 1] && p[j] >= p[j + 1]) {
            continue;
        }
        // Insertion into the sorted list of the `max` strongest: a stronger candidate takes
        // the slot and carries the weaker one down; what falls off the end is dropped.
        let mut cand = (j, p[j]);
        for slot in best.iter_mut().take(max) {
            match slot {
                None => {
                    *slot = Some(cand);
                    break;
                }
                Some(s) if cand.1 > s.1 => core::mem::swap(s, &mut cand),
                Some(_) => {}
            }
        }
    }
    if let Some((_, top)) = best[0] {
        let floor = top * libm::powf(10.0, -range_db / 10.0);
        for slot in best.iter_mut() {
            if slot.is_some_and(|(_, q)| q < floor) {
                *slot = None;
            }
        }
    }
    best
}

/// The FFT chain's elevation: ν from the phase of `Σ x_line(a) · conj(x_el(a))` over the
/// `(line row, elevation row)` pairs at the same azimuth position, `ν = ψ / (κ·Δel)`
/// (`kappa_del` = κ·Δel). `None` when the pairs carry no power.
pub fn phase_difference<const M: usize>(
    x: &[Complex32; M],
    pairs: &[(u8, u8)],
    kappa_del: f32,
) -> Option<f32> {
    let mut z = Complex32::new(0.0, 0.0);
    for &(a, e) in pairs {
        if let (Some(xa), Some(xe)) = (x.get(usize::from(a)), x.get(usize::from(e))) {
            z += xa * xe.conj();
        }
    }
    if !(z.norm_sqr() > 0.0) {
        return None;
    }
    Some(libm::atan2f(z.im, z.re) / kappa_del)
}

/// The nearest bin of an `NEL`-bin elevation grid (linear in θ over `span` degrees, as the
/// DBE chain's), clamped to its ends.
pub fn nearest_bin<const NEL: usize>(nu: f32, span: (f32, f32)) -> u16 {
    let (e0, e1) = span;
    let theta = libm::asinf(nu.clamp(-1.0, 1.0)).to_degrees();
    let step = (e1 - e0) / (NEL - 1) as f32;
    let j = libm::roundf((theta - e0) / step);
    // `as` saturates (NaN → 0); the clamp keeps the index on the grid.
    (j.max(0.0) as usize).min(NEL - 1) as u16
}
