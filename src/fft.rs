//! In-place complex FFT of a compile-time size, on `microfft`.
//!
//! Normalisation: none. `X[k] = Σ_n x[n] · exp(−j·2π·k·n/N)`, bins in natural order
//! (bin 0 = DC, bin `N/2..N` the negative frequencies, not fftshifted).

use num_complex::Complex32;

/// Largest FFT size compiled in (microfft's `size-256` feature).
pub const MAX_FFT_SIZE: usize = 256;

/// Transform `buf` in place.
///
/// `N` must be a power of two from 2 to [`MAX_FFT_SIZE`]; anything else is a compile error.
///
/// ```
/// use num_complex::Complex32;
/// let mut x = [Complex32::new(1.0, 0.0); 8];
/// dbe_radar::fft::fft_in_place(&mut x);
/// assert!((x[0].re - 8.0).abs() < 1e-6 && x[1].norm() < 1e-6);
/// ```
pub fn fft_in_place<const N: usize>(buf: &mut [Complex32; N]) {
    const { assert!(N.is_power_of_two() && N >= 2 && N <= MAX_FFT_SIZE) };
    macro_rules! dispatch {
        ($($n:literal => $f:ident),*) => {
            match N {
                $($n => {
                    if let Ok(a) = <&mut [Complex32; $n]>::try_from(&mut buf[..]) {
                        let _ = microfft::complex::$f(a);
                    }
                })*
                _ => {}
            }
        };
    }
    dispatch!(2 => cfft_2, 4 => cfft_4, 8 => cfft_8, 16 => cfft_16, 32 => cfft_32,
              64 => cfft_64, 128 => cfft_128, 256 => cfft_256);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn naive_dft(x: &[Complex32]) -> [num_complex::Complex64; 256] {
        let n = x.len();
        let mut out = [num_complex::Complex64::new(0.0, 0.0); 256];
        for (k, o) in out.iter_mut().take(n).enumerate() {
            for (i, v) in x.iter().enumerate() {
                let ph = -2.0 * core::f64::consts::PI * (k * i % n) as f64 / n as f64;
                *o += num_complex::Complex64::new(v.re as f64, v.im as f64)
                    * num_complex::Complex64::from_polar(1.0, ph);
            }
        }
        out
    }

    fn check<const N: usize>(seed: u64) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut x = [Complex32::new(0.0, 0.0); N];
        for v in x.iter_mut() {
            *v = Complex32::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        }
        let reference = naive_dft(&x);
        fft_in_place(&mut x);
        // f32 radix-2 error grows like ε·log2(N)·‖x‖; ‖X‖∞ ≤ N, so 1e-5·N is generous but tight
        // enough to catch any wrong twiddle or ordering (those give O(1) errors).
        let tol = 1e-5 * N as f64;
        for k in 0..N {
            let d =
                (reference[k] - num_complex::Complex64::new(x[k].re as f64, x[k].im as f64)).norm();
            assert!(d < tol, "N={N} bin {k}: error {d}");
        }
    }

    #[test]
    fn every_size_matches_naive_dft() {
        check::<2>(1);
        check::<4>(2);
        check::<8>(3);
        check::<16>(4);
        check::<32>(5);
        check::<64>(6);
        check::<128>(7);
        check::<256>(8);
    }
}
