//! Capon (MVDR) beamforming: spectrum `P(a) = 1 / Re(aᴴ R⁻¹ a)` and weights
//! `w = R⁻¹ a / (aᴴ R⁻¹ a)`, through the Cholesky factor `R = L·Lᴴ`.
//!
//! With `z = L⁻¹ a`, `aᴴR⁻¹a = ‖z‖²` and `R⁻¹a = L⁻ᴴ z`; `L⁻¹` is formed once per covariance,
//! so every steering vector costs one triangular matrix–vector product (`D(D+1)/2` complex
//! multiply–adds). Power is in the units of `R` (range-FFT units squared).

use nalgebra::{Cholesky, SMatrix};
use num_complex::Complex32;

use crate::covariance::{zero, Matrix};

/// The Capon solver of one (loaded) covariance matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capon<const D: usize> {
    /// `L⁻¹`, lower triangular (`linv[i][k]` for `k ≤ i`).
    linv: Matrix<D>,
}

impl<const D: usize> Capon<D> {
    /// Factor `r` (Hermitian, already loaded). `None` when it is not positive definite
    /// (all-zero or non-finite data): the caller skips that range bin and counts it.
    pub fn new(r: &Matrix<D>) -> Option<Self> {
        let m = SMatrix::<Complex32, D, D>::from_fn(|i, j| r[i][j]);
        let l = Cholesky::new(m)?.unpack();
        let mut linv = zero::<D>();
        for c in 0..D {
            // Solve L·x = e_c by forward substitution; x[i] = 0 for i < c.
            for i in c..D {
                let mut acc = if i == c {
                    Complex32::new(1.0, 0.0)
                } else {
                    Complex32::new(0.0, 0.0)
                };
                for k in c..i {
                    acc -= l[(i, k)] * linv[k][c];
                }
                let diag = l[(i, i)];
                if !(diag.re > 0.0 && diag.re.is_finite()) {
                    return None;
                }
                linv[i][c] = acc / diag.re;
            }
        }
        Some(Self { linv })
    }

    /// `z = L⁻¹ a`.
    fn whiten(&self, a: &[Complex32; D]) -> [Complex32; D] {
        let mut z = [Complex32::new(0.0, 0.0); D];
        for (i, zi) in z.iter_mut().enumerate() {
            let mut acc = Complex32::new(0.0, 0.0);
            for k in 0..=i {
                acc += self.linv[i][k] * a[k];
            }
            *zi = acc;
        }
        z
    }

    /// Capon power `1 / (aᴴ R⁻¹ a)`, linear.
    pub fn power(&self, a: &[Complex32; D]) -> f32 {
        let q: f32 = self.whiten(a).iter().map(|v| v.norm_sqr()).sum();
        if q > 0.0 {
            1.0 / q
        } else {
            0.0
        }
    }

    /// Capon weight `w = R⁻¹ a / (aᴴ R⁻¹ a)`; distortionless: `wᴴ a = 1`.
    pub fn weight(&self, a: &[Complex32; D]) -> [Complex32; D] {
        let z = self.whiten(a);
        let q: f32 = z.iter().map(|v| v.norm_sqr()).sum();
        let scale = if q > 0.0 { 1.0 / q } else { 0.0 };
        let mut w = [Complex32::new(0.0, 0.0); D];
        for (k, wk) in w.iter_mut().enumerate() {
            let mut acc = Complex32::new(0.0, 0.0);
            for i in k..D {
                acc += self.linv[i][k].conj() * z[i];
            }
            *wk = acc * scale;
        }
        w
    }
}
