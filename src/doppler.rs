//! Stage 4: Doppler FFT of a beamformed slow-time signal.
//!
//! Bin `d` of the `K`-point FFT (natural order, not fftshifted) is the signed bin
//! `d' = d` for `d < K/2`, else `d − K`, ↔ radial velocity `v = d' · λ / (2·K·T_loop)`,
//! positive = receding (spec §2).

use num_complex::Complex32;

use crate::fft::fft_from;
use crate::window::{Window, WindowKind};

/// The strongest bin of a slow-time signal, after windowing and FFT.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DopplerPeak {
    /// Signed bin `d'` in `−K/2 .. K/2`.
    pub bin: i16,
    /// `|Y[d]|²` of that bin.
    pub power: f32,
    /// Sub-bin offset of the peak from its neighbours, in `[−½, ½]`: [`jacobsen_offset`]
    /// under the rectangular window, the log-parabola of [`crate::refine`] under the others.
    pub offset: f32,
}

/// Window `y` in place, FFT it and return its strongest bin with the sub-bin offset
/// estimator that suits the window's kind.
///
/// Not inlined: the chain calls it from two places per detection, and a copy of the FFT at
/// each would cost flash for no measurable speed.
#[inline(never)]
pub fn doppler_peak<const K: usize>(y: &mut [Complex32; K], window: &Window<K>) -> DopplerPeak {
    let (x, w) = (*y, window.coefficients());
    fft_from(y, |n| x[n & (K - 1)] * w[n & (K - 1)]);
    let mut best = (0usize, -1.0f32);
    for (d, v) in y.iter().enumerate() {
        let p = v.norm_sqr();
        if p > best.1 {
            best = (d, p);
        }
    }
    let (left, centre, right) = (y[(best.0 + K - 1) % K], y[best.0], y[(best.0 + 1) % K]);
    let offset = match window.kind() {
        WindowKind::Rectangular => jacobsen_offset::<K>(left, centre, right),
        _ => crate::refine::parabolic_offset(left.norm_sqr(), best.1, right.norm_sqr()),
    };
    DopplerPeak {
        bin: signed_bin::<K>(best.0),
        power: best.1.max(0.0),
        offset,
    }
}

/// Sub-bin offset of a tone from the complex values of the strongest bin of its unwindowed
/// `K`-point DFT and of its two neighbours: Jacobsen's estimator
/// `Re[(X₋ − X₊) / (2X₀ − X₋ − X₊)]` with Candan's correction `tan(π/K)/(π/K)` (IEEE Signal
/// Processing Letters 18(6), 2011), exact for a noise-free tone up to `O(K⁻²)`, clamped to
/// `[−½, ½]`; 0 when the ratio is not finite (a vanishing denominator, an infinite or NaN
/// value). The correction is its Taylor series to `x⁶`
/// (`x = π/K`: below 2·10⁻⁵ relative for `K ≥ 8`, 10⁻¹² at `K = 128`), so no `tanf` runs on the
/// device (`libm`'s works in `f64`, software on a Cortex-M4F).
///
/// The log-parabola of [`crate::refine`] suits a Gaussian-like main lobe (Hann, Blackman);
/// on the rectangular window's `sinc` it is biased by up to 0.17 bin, which TDM compensation
/// turns into elevation error.
pub fn jacobsen_offset<const K: usize>(
    left: Complex32,
    centre: Complex32,
    right: Complex32,
) -> f32 {
    let den = centre * 2.0 - left - right;
    let ratio = ((left - right) * den.conj()).re / den.norm_sqr();
    if !ratio.is_finite() {
        return 0.0;
    }
    let x2 = (core::f32::consts::PI / K as f32) * (core::f32::consts::PI / K as f32);
    let candan = 1.0 + x2 * (1.0 / 3.0 + x2 * (2.0 / 15.0 + x2 * (17.0 / 315.0)));
    (ratio * candan).clamp(-0.5, 0.5)
}

/// The strongest power of a spectrum transformed by [`doppler_peak`] over its median power
/// (the `⌊K/2⌋`-th smallest `|Y[d]|²`, 0-based); infinite when the median is 0.
///
/// In white noise the `K` bins are independent exponential powers, so the ratio exceeds `t`
/// with probability about `K·2^{−t}` (the strongest of `K` against the median `ln 2`); a target
/// concentrates its slow-time energy in one or two bins (`K` times its per-loop power, less the
/// window's loss) and stands far above it. See [`crate::pipeline::Params::doppler_test_db`].
pub fn peak_to_median<const K: usize>(spectrum: &[Complex32; K], peak: f32) -> f32 {
    let mut p = [0.0f32; K];
    for (o, v) in p.iter_mut().zip(spectrum.iter()) {
        *o = v.norm_sqr();
    }
    let median = match p.len() {
        0 => 0.0,
        n => *p.select_nth_unstable_by(n / 2, |a, b| a.total_cmp(b)).1,
    };
    if median > 0.0 {
        peak / median
    } else {
        f32::INFINITY
    }
}

/// `peak_to_median(spectrum, peak) >= min_ratio`, exactly, without sorting: the test
/// `r(p) = peak / p ≥ min_ratio` (`r` = ∞ for `p` = 0, as for a zero median) holds for the
/// median exactly when it holds for more than `K/2` bins, since `r` never increases with `p`
/// (`f32` division is monotone), so the bins that pass are the smallest. A count instead of
/// a selection over `K` powers per detection (on the Cortex-M4F a quickselect of 128 values);
/// a NaN power (which the ordering of the selection places by its sign bit) takes the
/// selection itself.
pub fn passes_peak_to_median<const K: usize>(
    spectrum: &[Complex32; K],
    peak: f32,
    min_ratio: f32,
) -> bool {
    let mut passing = 0usize;
    for v in spectrum.iter() {
        let p = v.norm_sqr();
        if p.is_nan() {
            return peak_to_median(spectrum, peak) >= min_ratio;
        }
        let ratio = if p > 0.0 { peak / p } else { f32::INFINITY };
        passing += usize::from(ratio >= min_ratio);
    }
    match K {
        0 => f32::INFINITY >= min_ratio,
        _ => passing > K / 2,
    }
}

/// Signed Doppler bin of FFT bin `d`.
pub const fn signed_bin<const K: usize>(d: usize) -> i16 {
    if d < K / 2 {
        d as i16
    } else {
        d as i16 - K as i16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tone stands far above the median of its spectrum; white noise does not: over 2,000
    /// noise spectra of K = 128 the ratio exceeds 12 dB (15.85) with probability about
    /// K·2^{−15.85} = 2.2·10⁻³, i.e. a handful of times at most.
    #[test]
    fn peak_to_median_separates_a_tone_from_noise() {
        use rand::{Rng, SeedableRng};
        const K: usize = 128;
        let window = Window::<K>::new(WindowKind::Hann);
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut noise = || Complex32::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        // A tone at 0 dB per sample in the same noise: K / 1.5 ≈ 19 dB over the median.
        let mut y: [Complex32; K] =
            core::array::from_fn(|k| Complex32::from_polar(0.58, 0.3 * k as f32) + noise());
        let peak = doppler_peak(&mut y, &window);
        assert!(peak_to_median(&y, peak.power) > 40.0);
        let mut above = 0;
        for _ in 0..2000 {
            let mut y: [Complex32; K] = core::array::from_fn(|_| noise());
            let peak = doppler_peak(&mut y, &window);
            if peak_to_median(&y, peak.power) >= 15.85 {
                above += 1;
            }
        }
        assert!(above <= 15, "{above} of 2000 noise spectra pass 12 dB");
        // All zero: infinite, so a beam is never rejected for want of a median.
        let zero = [Complex32::new(0.0, 0.0); K];
        assert_eq!(peak_to_median(&zero, 0.0), f32::INFINITY);
    }

    /// The count gives the selection's verdict bit for bit: random spectra with ties, zeros,
    /// infinities and NaNs, thresholds at, between and beyond their ratios.
    #[test]
    fn the_counting_test_is_the_median_test() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let values = [
            0.0,
            -0.0,
            1.0,
            2.0,
            0.5,
            f32::INFINITY,
            f32::NAN,
            1e-30,
            3.0e30,
        ];
        let mut checked = [0usize; 2];
        for trial in 0..20_000 {
            let pick = |rng: &mut rand::rngs::StdRng| match rng.gen_range(0..4) {
                0 => values[rng.gen_range(0..values.len())],
                _ => rng.gen_range(-2.0f32..2.0),
            };
            let spectrum: [Complex32; 8] = core::array::from_fn(|_| match trial % 3 {
                // Few distinct values, zero among them: ties at the median.
                0 => Complex32::new(values[rng.gen_range(0..5)], 0.0),
                _ => Complex32::new(pick(&mut rng), pick(&mut rng)),
            });
            let peak = match rng.gen_range(0..5) {
                0 => values[rng.gen_range(0..values.len())],
                _ => spectrum.iter().map(|v| v.norm_sqr()).fold(0.0, f32::max),
            };
            let ratio = peak_to_median(&spectrum, peak);
            let min_ratio = match rng.gen_range(0..4) {
                0 => ratio,
                1 => values[rng.gen_range(0..values.len())],
                _ => rng.gen_range(0.0f32..8.0),
            };
            let want = ratio >= min_ratio;
            assert_eq!(
                passes_peak_to_median(&spectrum, peak, min_ratio),
                want,
                "{spectrum:?} peak {peak} min_ratio {min_ratio} ratio {ratio}"
            );
            checked[usize::from(want)] += 1;
        }
        assert!(checked[0] > 2_000 && checked[1] > 2_000, "{checked:?}");
        // A silent beam (all zero, peak 0): an infinite ratio, as the zero median gives.
        let zero = [Complex32::new(0.0, 0.0); 8];
        assert!(passes_peak_to_median(&zero, 0.0, 15.85));
    }

    /// A noise-free tone between bins: under the rectangular window the corrected Jacobsen
    /// offset finds it to 10⁻³ bin (its residual is O(K⁻²) plus f32 rounding), where the
    /// log-parabola on the `sinc²` main lobe is off by up to 0.17 bin; under Hann the
    /// log-parabola stays within 0.02 bin.
    #[test]
    fn sub_bin_offset_matches_the_window() {
        const K: usize = 128;
        let tone = |f: f32| -> [Complex32; K] {
            core::array::from_fn(|k| {
                Complex32::from_polar(
                    1.0,
                    2.0 * core::f32::consts::PI * f * k as f32 / K as f32 + 0.7,
                )
            })
        };
        let rect = Window::<K>::new(WindowKind::Rectangular);
        let hann = Window::<K>::new(WindowKind::Hann);
        let mut worst_parabola_rect = 0.0f32;
        for i in 0..19 {
            let delta = -0.45 + 0.05 * i as f32;
            for base in [-40.0f32, 3.0, 17.0] {
                let f = base + delta;
                let mut y = tone(f);
                let peak = doppler_peak(&mut y, &rect);
                let got = f32::from(peak.bin) + peak.offset;
                assert!((got - f).abs() < 1e-3, "rectangular: {got} for {f}");
                // The log-parabola on the same (rectangular) spectrum.
                let mut y = tone(f);
                let p = doppler_peak(&mut y, &rect);
                let d = i32::from(p.bin).rem_euclid(K as i32) as usize;
                let at = |i: usize| y[i % K].norm_sqr();
                let off = crate::refine::parabolic_offset(at(d + K - 1), at(d), at(d + 1));
                worst_parabola_rect = worst_parabola_rect.max((f32::from(p.bin) + off - f).abs());
                let mut y = tone(f);
                let peak = doppler_peak(&mut y, &hann);
                let got = f32::from(peak.bin) + peak.offset;
                assert!((got - f).abs() < 0.02, "Hann: {got} for {f}");
            }
        }
        assert!(worst_parabola_rect > 0.15, "{worst_parabola_rect}");
    }

    /// Degenerate neighbourhoods give no offset instead of NaN.
    #[test]
    fn jacobsen_offset_of_a_flat_spectrum_is_zero() {
        let z = Complex32::new(0.0, 0.0);
        let one = Complex32::new(1.0, 0.0);
        assert_eq!(jacobsen_offset::<128>(z, z, z), 0.0);
        assert_eq!(jacobsen_offset::<128>(one, one * 0.5, one), 0.0);
        assert_eq!(jacobsen_offset::<128>(one * f32::NAN, one, one), 0.0);
        assert_eq!(jacobsen_offset::<128>(one * f32::INFINITY, one, one), 0.0);
    }
}
