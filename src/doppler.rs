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

/// Signed Doppler bin of FFT bin `d`.
pub const fn signed_bin<const K: usize>(d: usize) -> i16 {
    if d < K / 2 {
        d as i16
    } else {
        d as i16 - K as i16
    }
}
