//! Stage 0: per-chirp range processing (DC removal, window, range FFT), run by
//! [`crate::Frontend::push_chirp`].

use num_complex::Complex32;

use crate::fft::fft_in_place;

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
        let mut sum = [0i64; 2];
        for s in samples.iter() {
            sum[0] += i64::from(s[0]);
            sum[1] += i64::from(s[1]);
        }
        let mean = Complex32::new(sum[0] as f32 / N as f32, sum[1] as f32 / N as f32);
        for ((o, s), w) in out.iter_mut().zip(samples.iter()).zip(self.window.iter()) {
            *o = (Complex32::new(f32::from(s[0]), f32::from(s[1])) - mean) * *w;
        }
        fft_in_place(out);
    }
}
