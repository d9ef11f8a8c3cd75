//! Sub-grid refinement of spectral peaks (beyond the paper; `Params::subgrid`).
//!
//! A peak sampled at bins `i − 1`, `i`, `i + 1` is refined by fitting a parabola to the
//! *logarithm* of the three powers (exact for a Gaussian-shaped main lobe, close for the
//! windowed FFT and Capon main lobes): the vertex is at `i + δ` with
//! `δ = ½ · (l − r) / (l − 2c + r)`, clamped to `[−½, ½]` so the refined value never leaves
//! the bin that won the grid search. A rectangular window's `sinc`-shaped lobe has its own,
//! exact estimator ([`dirichlet_offset`]); [`power_offset`] picks by window.

use crate::window::WindowKind;

/// Offset of the vertex of the parabola through `(−1, ln left)`, `(0, ln centre)`,
/// `(1, ln right)`, in bins; 0 when the three points are not a peak or not all positive.
///
/// ```
/// use dbe_radar::refine::parabolic_offset;
/// // A Gaussian peak at +0.3 bin: exact on log power.
/// let g = |x: f32| (-(x - 0.3) * (x - 0.3)).exp();
/// assert!((parabolic_offset(g(-1.0), g(0.0), g(1.0)) - 0.3).abs() < 1e-5);
/// ```
pub fn parabolic_offset(left: f32, centre: f32, right: f32) -> f32 {
    if !(left > 0.0 && centre > 0.0 && right > 0.0) || centre < left || centre < right {
        return 0.0;
    }
    let (l, c, r) = (libm::logf(left), libm::logf(centre), libm::logf(right));
    let den = l - 2.0 * c + r;
    if !(den < 0.0) {
        return 0.0;
    }
    (0.5 * (l - r) / den).clamp(-0.5, 0.5)
}

/// Offset of a tone from the powers of the strongest bin of its unwindowed `K`-point DFT and
/// of its two neighbours, in bins: the rectangular window's main lobe is a Dirichlet kernel,
/// whose magnitude ratio to the stronger neighbour, `r = sin(πδ/K) / sin(π(1 − δ)/K)`, gives
/// `δ = (K/π)·atan(r·sin(π/K) / (1 + r·cos(π/K)))` exactly for a noise-free tone (also for a
/// sum of powers over channels that see the same tone). Clamped to `[−½, ½]`; 0 when the
/// three powers are not a peak (a flat triple included) or not finite. The log-parabola of
/// [`parabolic_offset`] is off by up to 0.17 bin on this lobe (`K = 128`).
///
/// ```
/// use dbe_radar::refine::dirichlet_offset;
/// // |X_k|² of a tone 0.3 bin above bin 0 of a 64-point DFT.
/// let p = |k: f32| {
///     let x = core::f32::consts::PI * (0.3 - k);
///     (x.sin() / (x / 64.0).sin()).powi(2)
/// };
/// assert!((dirichlet_offset::<64>(p(-1.0), p(0.0), p(1.0)) - 0.3).abs() < 1e-4);
/// ```
pub fn dirichlet_offset<const K: usize>(left: f32, centre: f32, right: f32) -> f32 {
    if !(left >= 0.0 && right >= 0.0 && centre > 0.0 && centre.is_finite())
        || centre < left
        || centre < right
        || (left == centre && right == centre)
    {
        return 0.0;
    }
    let (side, neighbour) = match right >= left {
        true => (1.0, right),
        false => (-1.0, left),
    };
    let r = libm::sqrtf(neighbour / centre);
    // sin and cos of b = π/K by their series to b⁷ (below 10⁻⁹ for K ≥ 8): `libm`'s sinf
    // and cosf work in f64, software on a Cortex-M4F; its atanf is f32.
    let b = core::f32::consts::PI / K as f32;
    let b2 = b * b;
    let sin_b = b * (1.0 - b2 / 6.0 * (1.0 - b2 / 20.0 * (1.0 - b2 / 42.0)));
    let cos_b = 1.0 - b2 / 2.0 * (1.0 - b2 / 12.0 * (1.0 - b2 / 30.0));
    let a = libm::atanf(r * sin_b / (1.0 + r * cos_b));
    (side * a / b).clamp(-0.5, 0.5)
}

/// The sub-bin offset from three powers that suits the window the spectrum was taken with:
/// [`dirichlet_offset`] under [`WindowKind::Rectangular`], [`parabolic_offset`] under the
/// others (Gaussian-like main lobes).
pub fn power_offset<const K: usize>(window: WindowKind, left: f32, centre: f32, right: f32) -> f32 {
    match window {
        WindowKind::Rectangular => dirichlet_offset::<K>(left, centre, right),
        _ => parabolic_offset(left, centre, right),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Noise-free tones between bins of a rectangular-window DFT: the Dirichlet estimator is
    /// exact to f32 rounding where the log-parabola errs by up to 0.17 bin.
    #[test]
    fn the_dirichlet_offset_finds_a_tone_under_a_rectangular_window() {
        const K: usize = 128;
        let power = |delta: f64, k: f64| {
            let x = core::f64::consts::PI * (delta - k);
            if x == 0.0 {
                (K * K) as f32
            } else {
                ((x.sin() / (x / K as f64).sin()).powi(2)) as f32
            }
        };
        let mut worst_parabola = 0.0f32;
        for i in 0..=20 {
            let delta = -0.5 + 0.05 * f64::from(i);
            let (l, c, r) = (power(delta, -1.0), power(delta, 0.0), power(delta, 1.0));
            let got = power_offset::<K>(WindowKind::Rectangular, l, c, r);
            assert!((f64::from(got) - delta).abs() < 2e-4, "{got} for {delta}");
            let parabola = power_offset::<K>(WindowKind::Hann, l, c, r);
            worst_parabola = worst_parabola.max((f64::from(parabola) - delta).abs() as f32);
        }
        assert!(worst_parabola > 0.15, "{worst_parabola}");
        assert_eq!(dirichlet_offset::<K>(1.0, 1.0, 1.0), 0.0);
        assert_eq!(dirichlet_offset::<K>(2.0, 1.0, 0.5), 0.0);
        assert_eq!(dirichlet_offset::<K>(f32::NAN, 1.0, 0.5), 0.0);
        assert_eq!(dirichlet_offset::<K>(0.0, f32::INFINITY, 0.0), 0.0);
        assert_eq!(dirichlet_offset::<K>(0.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn flat_or_non_peaks_give_zero() {
        assert_eq!(parabolic_offset(1.0, 1.0, 1.0), 0.0);
        assert_eq!(parabolic_offset(2.0, 1.0, 3.0), 0.0);
        assert_eq!(parabolic_offset(0.0, 1.0, 0.5), 0.0);
        assert_eq!(parabolic_offset(f32::NAN, 1.0, 0.5), 0.0);
    }

    #[test]
    fn symmetric_peak_is_centred_and_offsets_are_clamped() {
        assert_eq!(parabolic_offset(0.5, 1.0, 0.5), 0.0);
        assert!(parabolic_offset(1.0, 1.0, 1e-6) <= -0.4999);
        assert!(parabolic_offset(1e-6, 1.0, 1.0) >= 0.4999);
    }
}
