//! Sub-grid refinement of spectral peaks (beyond the paper; `Params::subgrid`).
//!
//! A peak sampled at bins `i − 1`, `i`, `i + 1` is refined by fitting a parabola to the
//! *logarithm* of the three powers (exact for a Gaussian-shaped main lobe, close for the
//! windowed FFT and Capon main lobes): the vertex is at `i + δ` with
//! `δ = ½ · (l − r) / (l − 2c + r)`, clamped to `[−½, ½]` so the refined value never leaves
//! the bin that won the grid search.

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

#[cfg(test)]
mod tests {
    use super::*;

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
