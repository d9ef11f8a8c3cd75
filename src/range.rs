//! Stage 0: per-chirp range processing (DC removal, window, range FFT), run by
//! [`crate::Frontend::push_chirp`].

use num_complex::Complex32;

use crate::fft::{fft_from, Lanes};

/// Range processing of one chirp of one virtual antenna, with its window table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeFft<const N: usize> {
    window: [f32; N],
}

impl<const N: usize> RangeFft<N> {
    /// An all-zero window (everything maps to zero), for `const` construction.
    pub const fn unconfigured() -> Self {
        Self { window: [0.0; N] }
    }

    /// Precompute the window.
    pub fn new(window: crate::window::WindowKind) -> Self {
        Self {
            window: window.coefficients(),
        }
    }

    /// Remove the complex DC mean over the `N` samples, window, and FFT into `out`.
    ///
    /// Input: int16 `[I, Q]` pairs. Output: unnormalised FFT (see [`crate::fft`]) in ADC
    /// units; bin `b` ↔ range `b · c·fs/(2·S·N)`. All `N` bins are valid (complex sampling).
    ///
    /// ```
    /// use dbe_radar::{range::RangeFft, window::WindowKind};
    /// let fft = RangeFft::<8>::new(WindowKind::Rectangular);
    /// // e^{j·2π·n/8}: one cycle per chirp lands in bin 1 with amplitude 8·1000.
    /// let chirp: [[i16; 2]; 8] = core::array::from_fn(|n| {
    ///     let p = core::f64::consts::PI * n as f64 / 4.0;
    ///     [(1000.0 * p.cos()).round() as i16, (1000.0 * p.sin()).round() as i16]
    /// });
    /// let mut out = [num_complex::Complex32::new(0.0, 0.0); 8];
    /// fft.process(&chirp, &mut out);
    /// assert!((out[1].norm() - 8000.0).abs() < 8.0);
    /// ```
    pub fn process(&self, samples: &[[i16; 2]; N], out: &mut [Complex32; N]) {
        let mean = dc_mean(samples);
        // DC removal and window inside the FFT's first pass (`n & (N − 1)` is `n`: the mask
        // only lets the compiler drop the bounds checks).
        let (w, x) = (&self.window, samples);
        fft_from(out, |n| {
            let (s, w) = (x[n & (N - 1)], w[n & (N - 1)]);
            (Complex32::new(f32::from(s[0]), f32::from(s[1])) - mean) * w
        });
    }

    /// [`Self::process`] of `L` channels at once, lane `l` of `out` the spectrum of
    /// `samples[l]`: bit-identical to `L` calls of `process` (the same `f32` operations in
    /// the same order, per lane), and on a core with 4-wide SIMD about as fast as one.
    pub fn process_lanes<const L: usize>(
        &self,
        samples: &[[[i16; 2]; N]; L],
        out: &mut [Lanes<L>; N],
    ) {
        let mut mean = Lanes::<L>::ZERO;
        for (l, channel) in samples.iter().enumerate() {
            let m = dc_mean(channel);
            (mean.re[l], mean.im[l]) = (m.re, m.im);
        }
        let w = &self.window;
        fft_from(out, |n| {
            let (n, mut v) = (n & (N - 1), Lanes::<L>::ZERO);
            for l in 0..L {
                let s = samples[l][n];
                v.re[l] = (f32::from(s[0]) - mean.re[l]) * w[n];
                v.im[l] = (f32::from(s[1]) - mean.im[l]) * w[n];
            }
            v
        });
    }
}

/// The complex DC mean of one chirp's samples.
#[inline(always)]
fn dc_mean<const N: usize>(samples: &[[i16; 2]; N]) -> Complex32 {
    // |Σ| ≤ N · 32768 ≤ 2^24 for N ≤ 512: i32 cannot overflow (an i64 sum is two adds
    // per sample on a 32-bit core).
    const { assert!(N <= 1 << 16) };
    let mut sum = [0i32; 2];
    for s in samples.iter() {
        sum[0] += i32::from(s[0]);
        sum[1] += i32::from(s[1]);
    }
    Complex32::new(sum[0] as f32 / N as f32, sum[1] as f32 / N as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::window::WindowKind;

    #[test]
    fn the_lanes_path_is_the_per_channel_path_bit_for_bit() {
        let fft = RangeFft::<256>::new(WindowKind::Blackman);
        let mut state = 7u32;
        let chirp: [[[i16; 2]; 256]; 4] = core::array::from_fn(|_| {
            core::array::from_fn(|_| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                [(state >> 16) as i16, (state >> 3) as i16 >> 2]
            })
        });
        let mut lanes = [Lanes::<4>::ZERO; 256];
        fft.process_lanes(&chirp, &mut lanes);
        let mut one = [Complex32::new(0.0, 0.0); 256];
        for (l, channel) in chirp.iter().enumerate() {
            fft.process(channel, &mut one);
            for (n, (s, v)) in one.iter().zip(lanes.iter()).enumerate() {
                let v = v.lane(l);
                assert!(
                    s.re.to_bits() == v.re.to_bits() && s.im.to_bits() == v.im.to_bits(),
                    "channel {l} bin {n}: {s} vs {v}"
                );
            }
        }
    }
}
