//! Stage 4: Doppler FFT of a beamformed slow-time signal.
//!
//! Bin `d` of the `K`-point FFT (natural order, not fftshifted) is the signed bin
//! `d' = d` for `d < K/2`, else `d − K`, ↔ radial velocity `v = d' · λ / (2·K·T_loop)`,
//! positive = receding (spec §2).

use num_complex::Complex32;

use crate::fft::fft_from;

/// The strongest bin of a slow-time signal, after windowing and FFT.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DopplerPeak {
    /// Signed bin `d'` in `−K/2 .. K/2`.
    pub bin: i16,
    /// `|Y[d]|²` of that bin.
    pub power: f32,
    /// Sub-bin offset of the peak from its neighbours (see [`crate::refine`]), in `[−½, ½]`.
    pub offset: f32,
}

/// Window `y` in place, FFT it and return its strongest bin.
///
/// Not inlined: the chain calls it from two places per detection, and a copy of the FFT at
/// each would cost flash for no measurable speed.
#[inline(never)]
pub fn doppler_peak<const K: usize>(y: &mut [Complex32; K], window: &[f32; K]) -> DopplerPeak {
    let x = *y;
    fft_from(y, |n| x[n & (K - 1)] * window[n & (K - 1)]);
    let mut best = (0usize, -1.0f32);
    for (d, v) in y.iter().enumerate() {
        let p = v.norm_sqr();
        if p > best.1 {
            best = (d, p);
        }
    }
    let left = y[(best.0 + K - 1) % K].norm_sqr();
    let right = y[(best.0 + 1) % K].norm_sqr();
    DopplerPeak {
        bin: signed_bin::<K>(best.0),
        power: best.1.max(0.0),
        offset: crate::refine::parabolic_offset(left, best.1, right),
    }
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
        let window = crate::window::WindowKind::Hann.coefficients::<K>();
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
}
