//! Elevation: the DBE chain's Capon sweep with its peak rules (spec §3 step 3), and the FFT
//! chain's phase-difference estimate (spec §4).
//!
//! The sweep evaluates the full-array Capon spectrum `P(ν_j) = 1 / aᴴ R⁻¹ a` with
//! `a = a(μ_detection, ν_j)` over the `NEL` grid bins, on the loaded (and, with TDM
//! compensation, rotated) `M × M` covariance, without forward–backward averaging (the
//! 12-element array is not centro-symmetric: averaging mirrors +θ onto −θ). It keeps the
//! interior local maxima, at most `max_peaks`, each within `peak_range_db` of the strongest.
//! On this crate's two-level arrays the spectrum along elevation is a sinusoid ([`TwoLevel`]),
//! evaluated in closed form.

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

/// Sweep the Capon spectrum `line` along the elevation grid, `phase(j)` the elevation row's
/// steering factor `t_j = e^{−j·κ·Δ·ν_j}` of bin `j`, into `spectrum` (linear), and return
/// its peaks.
pub fn sweep<const NEL: usize>(
    line: &TwoLevel,
    phase: impl Fn(usize) -> Complex32,
    p: &ElevationParams,
    spectrum: &mut [f32; NEL],
) -> Peaks {
    for (j, s) in spectrum.iter_mut().enumerate() {
        *s = line.power_at(phase(j));
    }
    strongest_interior_peaks(spectrum, usize::from(p.max_peaks), p.peak_range_db)
}

/// The Capon spectrum along elevation of an array on two elevation levels, in closed form.
///
/// Every array of this crate has its elements on the azimuth line (elevation 0) or on one
/// elevation row (elevation `Δ`; [`crate::config::ArrayLayout`]). At a fixed azimuth the
/// steering vector is then `a(ν) = a_lo + t·a_hi` up to a unit factor, with `a_lo` (`a_hi`)
/// the azimuth steering vector on the line's (the row's) elements and zero elsewhere, and
/// `t = e^{−jψ}`, `ψ = κ·Δ·ν`. So
///
/// ```text
/// aᴴR⁻¹a = s + 2·Re(t·c),   s = a_loᴴR⁻¹a_lo + a_hiᴴR⁻¹a_hi,   c = a_loᴴR⁻¹a_hi
/// ```
///
/// is a sinusoid in `ψ`: two whitenings per detection instead of one per grid bin, a complex
/// multiply per bin, and its minimum, the spectrum's peak, is at `ψ* = arg c − π` (mod 2π)
/// exactly ([`TwoLevel::peak_phase`]), so the sub-grid elevation needs no interpolation (a
/// parabola through three grid powers is biased by the main lobe's shape, which narrows as
/// the SNR grows). Any linear restriction of the rows (the coherent path's sub-array) keeps
/// the form.
///
/// Accuracy: the sum cancels where the spectrum peaks. Diagonal loading bounds it: `s ≤ M/δ`
/// (`λ_max(R⁻¹) ≤ 1/δ`) while `s − 2|c| = min aᴴR⁻¹a ≥ 1/P_max ≥ M/tr(R)`, so the relative
/// error of a power is at most about `tr(R)/δ·ε = M/γ·ε` ≈ 10⁻⁴ for `M = 12`, `γ = 0.01` in
/// `f32`.
///
/// ```
/// use dbe_radar::capon::Capon;
/// use dbe_radar::elevation::TwoLevel;
/// use dbe_radar::Complex32;
/// // Two elements, one per level: R = I + 100·a·aᴴ for a source at ψ = 0.4 rad.
/// let a = [Complex32::new(1.0, 0.0), Complex32::from_polar(1.0, -0.4)];
/// let r = core::array::from_fn(|i| core::array::from_fn(|j| {
///     let one = if i == j { 1.0 } else { 0.0 };
///     Complex32::new(one, 0.0) + a[i] * a[j].conj() * 100.0
/// }));
/// let capon = Capon::<2>::new(&r).unwrap();
/// let zero = Complex32::new(0.0, 0.0);
/// let line = TwoLevel::new(&capon, &[a[0], zero], &[zero, Complex32::new(1.0, 0.0)]);
/// assert!((line.peak_phase() + 2.0 * core::f32::consts::PI - 0.4).abs() < 1e-5);
/// assert!((line.power_at(a[1]) - capon.power(&a)).abs() < 1e-4 * capon.power(&a));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLevel {
    /// `s = a_loᴴR⁻¹a_lo + a_hiᴴR⁻¹a_hi`.
    sum: f32,
    /// `c = a_loᴴR⁻¹a_hi`.
    cross: Complex32,
}

impl TwoLevel {
    /// The spectrum of `capon` along `a_lo + t·a_hi`.
    pub fn new<const M: usize>(
        capon: &Capon<M>,
        a_lo: &[Complex32; M],
        a_hi: &[Complex32; M],
    ) -> Self {
        let (lo, hi, cross) = capon.forms(a_lo, a_hi);
        Self {
            sum: lo + hi,
            cross,
        }
    }

    /// Capon power `1 / (s + 2·Re(t·c))` at the row factor `t` (`|t| = 1`), linear; 0 when the
    /// form is not positive.
    pub fn power_at(&self, t: Complex32) -> f32 {
        let q = self.sum + 2.0 * (self.cross.re * t.re - self.cross.im * t.im);
        if q > 0.0 {
            1.0 / q
        } else {
            0.0
        }
    }

    /// The phase `ψ* = arg c − π ∈ [−2π, 0]` where the spectrum peaks (mod 2π); `−π` when the
    /// spectrum is flat (`c = 0`).
    pub fn peak_phase(&self) -> f32 {
        libm::atan2f(self.cross.im, self.cross.re) - core::f32::consts::PI
    }

    /// The `ν` of the spectrum's peak nearest to `near`, for `ψ = kappa_delta · ν`, clamped
    /// to `[lo, hi]` (a grid peak's half-bin interval, so the point keeps its bin).
    pub fn peak_nu(&self, kappa_delta: f32, near: f32, lo: f32, hi: f32) -> f32 {
        if !(kappa_delta != 0.0) {
            return near.clamp(lo, hi);
        }
        let tau = core::f32::consts::TAU;
        let psi = self.peak_phase();
        let turns = libm::roundf((kappa_delta * near - psi) / tau);
        let nu = (psi + turns * tau) / kappa_delta;
        if nu.is_finite() {
            nu.clamp(lo, hi)
        } else {
            near.clamp(lo, hi)
        }
    }
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

/// The nearest bin of an `NEL`-bin angle grid (linear in the angle over `span` degrees, as
/// the DBE chain's elevation and azimuth grids) to direction cosine `nu`, clamped to its ends.
pub fn nearest_bin<const NEL: usize>(nu: f32, span: (f32, f32)) -> u16 {
    let (e0, e1) = span;
    let theta = libm::asinf(nu.clamp(-1.0, 1.0)).to_degrees();
    let step = (e1 - e0) / (NEL - 1) as f32;
    let j = libm::roundf((theta - e0) / step);
    // `as` saturates (NaN → 0); the clamp keeps the index on the grid.
    (j.max(0.0) as usize).min(NEL - 1) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{AntennaGeometry, ArrayLayout};
    use crate::covariance::{covariance, load_diagonal};
    use crate::subarray::SubArray;
    use rand::{Rng, SeedableRng};

    const M: usize = 12;
    const AZ: usize = 8;
    const KAPPA: f32 = 3.17;

    fn steer(l: &ArrayLayout<3, 4, M>, mu: f32, nu: f32) -> [Complex32; M] {
        core::array::from_fn(|m| Complex32::from_polar(1.0, -KAPPA * (mu * l.az[m] + nu * l.el[m])))
    }

    /// Two sources and noise on the ColoRadar array, 64 snapshots, loaded as the chain loads.
    fn loaded_covariance(l: &ArrayLayout<3, 4, M>, seed: u64) -> Matrix<M> {
        const K: usize = 64;
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let src = [(0.2f32, 0.12f32, 30.0f32), (-0.35, -0.05, 10.0)];
        let mut x = [[Complex32::new(0.0, 0.0); K]; M];
        for (mu, nu, amp) in src {
            let a = steer(l, mu, nu);
            for k in 0..K {
                let s = Complex32::from_polar(amp, rng.gen_range(0.0..core::f32::consts::TAU));
                for (row, am) in x.iter_mut().zip(a.iter()) {
                    row[k] += am * s;
                }
            }
        }
        for row in x.iter_mut() {
            for v in row.iter_mut() {
                *v += Complex32::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            }
        }
        let mut r = [[Complex32::new(0.0, 0.0); M]; M];
        covariance::<M, K>(&x, &mut r);
        load_diagonal(&mut r, 0.01);
        r
    }

    use crate::covariance::Matrix;

    /// A flat spectrum (`c = 0`), a non-finite one and a zero `κΔ` still give a `ν` inside
    /// the interval asked for, and powers that are finite and never negative.
    #[test]
    fn degenerate_two_level_spectra_stay_in_their_interval() {
        let flat = TwoLevel {
            sum: 2.0,
            cross: Complex32::new(0.0, 0.0),
        };
        let broken = TwoLevel {
            sum: f32::NAN,
            cross: Complex32::new(f32::NAN, f32::INFINITY),
        };
        let one = Complex32::new(1.0, 0.0);
        assert_eq!(flat.power_at(one), 0.5);
        assert_eq!(broken.power_at(one), 0.0);
        for line in [flat, broken] {
            for kd in [KAPPA, 0.0, f32::NAN] {
                let nu = line.peak_nu(kd, 0.1, 0.09, 0.11);
                assert!((0.09..=0.11).contains(&nu), "{line:?} κΔ {kd}: ν {nu}");
            }
        }
    }

    /// The closed form equals the quadratic form `1/aᴴR⁻¹a` of every elevation on the full
    /// array and on the coherent path's sub-array (a restriction of the rows), within the
    /// cancellation bound `M/γ·ε` of [`TwoLevel`]; its peak is the sweep's maximum.
    #[test]
    fn the_two_level_spectrum_is_the_quadratic_form_and_peaks_exactly() {
        let l = ArrayLayout::new(&AntennaGeometry::COLORADAR, AZ).expect("ColoRadar layout");
        let sub = SubArray::of(&l, AZ);
        let delta = l.el[AZ];
        assert!(delta > 0.0 && l.el[..AZ].iter().all(|&e| e == 0.0));
        for seed in 0..4 {
            let r = loaded_covariance(&l, seed);
            for coherent in [false, true] {
                let (cov, restrict): (Matrix<M>, &dyn Fn([Complex32; M]) -> [Complex32; M]) =
                    if coherent {
                        (sub.covariance(&r, 0.01), &|a| sub.restrict(&a))
                    } else {
                        (r, &|a| a)
                    };
                let capon = Capon::new(&cov).expect("positive definite");
                for mu in [0.2f32, -0.35, 0.0] {
                    let (mut lo, mut hi) = (steer(&l, mu, 0.0), steer(&l, mu, 0.0));
                    for m in 0..M {
                        *if m < AZ { &mut hi[m] } else { &mut lo[m] } = Complex32::new(0.0, 0.0);
                    }
                    let line = TwoLevel::new(&capon, &restrict(lo), &restrict(hi));
                    // A fine sweep of ψ = κΔν over one period.
                    let (mut best, mut best_nu) = (0.0f32, 0.0f32);
                    for s in -400..400 {
                        let nu = s as f32 / 400.0 * core::f32::consts::PI / (KAPPA * delta);
                        let want = capon.power(&restrict(steer(&l, mu, nu)));
                        let got = line.power_at(Complex32::from_polar(1.0, -KAPPA * delta * nu));
                        let tol = f32::EPSILON * M as f32 / 0.01 * 4.0;
                        assert!(
                            (got - want).abs() <= tol * want,
                            "seed {seed} coherent {coherent} μ {mu} ν {nu}: {got} vs {want}"
                        );
                        if want > best {
                            (best, best_nu) = (want, nu);
                        }
                    }
                    let step = core::f32::consts::PI / (KAPPA * delta) / 400.0;
                    let nu = line.peak_nu(KAPPA * delta, best_nu, -1.0, 1.0);
                    assert!(
                        (nu - best_nu).abs() <= step,
                        "seed {seed} coherent {coherent} μ {mu}: peak {nu} vs sweep {best_nu}"
                    );
                    // Clamped to the interval it is given.
                    let lo_edge = best_nu + 2.0 * step;
                    assert_eq!(line.peak_nu(KAPPA * delta, best_nu, lo_edge, 1.0), lo_edge);
                }
            }
        }
    }
}
