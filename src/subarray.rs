//! Coherent targets: forward–backward spatial smoothing (FBSS) on centro-symmetric sub-arrays.
//!
//! Two scatterers of one range bin with one Doppler (a static radar looking at a static scene;
//! a radar driving between symmetric walls) are *coherent*: their snapshots are proportional,
//! the covariance has rank 1, and Capon cancels them. Forward–backward (FB) averaging alone
//! restores rank 2 except near one phase difference of the pair, where the two points merge
//! into one between them or vanish; averaging FB over two shifted sub-arrays as well (spatial
//! smoothing) restores it for every phase (Pillai & Kwon 1989: `L` sub-arrays with FB
//! decorrelate up to `2L` coherent sources).
//!
//! * Azimuth ([`smooth_line`]): the `AZ`-element line as two overlapping `AZ − 1`-element
//!   lines, `R_s = (R[0..AZ−1] + R[1..AZ]) / 2`, then FB. One element of aperture is lost
//!   (Rayleigh width 16.4° instead of 14.3° for `AZ = 8`).
//! * Elevation ([`SubArray`]): the elevation row (AWR1843: azimuth positions 2..5) and the
//!   line elements at the same positions form a 2 × `E` rectangle; its two 2 × (`E` − 1)
//!   sub-rectangles are centro-symmetric (element `(p, e)` mirrors to
//!   `(p_min + p_max − p, e_min + e_max − e)`), so `J·a(μ, ν)* = e^{jc}·a(μ, ν)` and FB keeps
//!   every steering vector's Capon power. The full 12-element array cannot be averaged (it is
//!   not centro-symmetric: averaging would mirror +θ onto −θ, spec §3).
//!
//! Smoothing costs aperture and noise averaging, so the chain uses the elevation sub-array
//! only where coherence is expected (see [`crate::pipeline::Params::coherent_doppler_bins`]).
//!
//! Both smoothed covariances have fewer rows than the matrix type that holds them. They fill
//! its leading `S × S` block; the other rows are an identity scaled to the block's mean power,
//! so the chain's `Capon<D>` solves them: the Cholesky factor is block diagonal, and for a
//! steering vector zero beyond the block `aᴴR⁻¹a` and the weight are exactly the block's.

use num_complex::Complex32;

use crate::config::ArrayLayout;
use crate::covariance::{load_diagonal_rows, Matrix};

/// Positions closer than this (half-wavelength units) are the same.
const SAME_POSITION: f32 = 1e-3;

/// Spatial smoothing of a uniform line's covariance (rows in position order) over its two
/// `D − 1`-element sub-lines, in place into the leading block, then FB averaging when `fb`,
/// and loading `δ = γ · tr / (D − 1)` of the block. Returns `(D − 1, δ)`; the last row and
/// column become the padding (module docs).
pub fn smooth_line<const D: usize>(r: &mut Matrix<D>, fb: bool, gamma: f32) -> (usize, f32) {
    let n = D.saturating_sub(1);
    let orig = *r;
    let mut out = [[Complex32::new(0.0, 0.0); D]; D];
    for i in 0..n {
        for j in 0..n {
            out[i][j] = (orig[i][j] + orig[i + 1][j + 1]) * 0.5;
        }
    }
    if fb {
        let s = out;
        for i in 0..n {
            for j in 0..n {
                out[i][j] = (s[i][j] + s[n - 1 - i][n - 1 - j].conj()) * 0.5;
            }
        }
    }
    let delta = load_diagonal_rows(&mut out, n, gamma);
    pad(&mut out, n, delta);
    *r = out;
    (n, delta)
}

/// Fill the diagonal beyond the leading `n × n` block with the block's mean loaded power
/// (at least `delta`; 1 for an empty block), so the matrix is as well conditioned as the block.
fn pad<const D: usize>(r: &mut Matrix<D>, n: usize, delta: f32) {
    let mut trace = 0.0f32;
    for (k, row) in r.iter().enumerate().take(n) {
        trace += row[k].re;
    }
    let level = if n > 0 { trace / n as f32 } else { 1.0 };
    for (k, row) in r.iter_mut().enumerate().skip(n) {
        row[k] = Complex32::new(level.max(delta).max(f32::MIN_POSITIVE), 0.0);
    }
}

/// The 2 × `E` rectangle of a virtual array (the elevation row and the line elements at its
/// azimuth positions), for FBSS over its two 2 × (`E` − 1) sub-rectangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubArray<const M: usize> {
    /// Cube rows of the rectangle's line elements, in position order (`width` of them).
    line: [u8; M],
    /// Cube rows of the elevation row's elements at the same positions.
    upper: [u8; M],
    /// `E`; 0 when the array has no such rectangle with `E ≥ 3`.
    width: u8,
}

impl<const M: usize> SubArray<M> {
    /// No sub-array (an unconfigured chain; all-zero bytes).
    pub const NONE: Self = Self {
        line: [0; M],
        upper: [0; M],
        width: 0,
    };

    /// The rectangle of `layout` (azimuth line = rows `0..az`, in position order): the
    /// off-line rows must be one uniformly spaced row of at least 3 elements, each above a
    /// line element; otherwise [`Self::NONE`].
    pub fn of<const TX: usize, const RX: usize>(
        layout: &ArrayLayout<TX, RX, M>,
        az: usize,
    ) -> Self {
        let same = |a: f32, b: f32| (a - b).abs() <= SAME_POSITION;
        let mut s = Self::NONE;
        let az = az.min(M);
        // The off-line rows in position order (insertion sort: at most M elements).
        let mut upper = [0u8; M];
        let mut e = 0usize;
        for m in az..M {
            let mut k = e;
            while k > 0 && layout.az[usize::from(upper[k - 1])] > layout.az[m] {
                upper[k] = upper[k - 1];
                k -= 1;
            }
            upper[k] = m as u8;
            e += 1;
        }
        if e < 3 {
            return Self::NONE;
        }
        let pos = |k: usize| layout.az[usize::from(upper[k])];
        let step = pos(1) - pos(0);
        for k in 0..e {
            let m = usize::from(upper[k]);
            let uniform = same(pos(k) - pos(0), step * k as f32);
            let flat = same(layout.el[m], layout.el[usize::from(upper[0])]);
            let below = (0..az).find(|&l| same(layout.az[l], pos(k)));
            match below {
                Some(l)
                    if uniform && flat && !same(step, 0.0) && !same(layout.el[l], layout.el[m]) =>
                {
                    s.line[k] = l as u8;
                    s.upper[k] = m as u8;
                }
                _ => return Self::NONE,
            }
        }
        s.width = e as u8;
        s
    }

    /// Elements of one smoothing sub-rectangle, `2·(E − 1)` (0: none).
    pub fn len(&self) -> usize {
        2 * usize::from(self.width).saturating_sub(1)
    }

    /// Whether the array has no such rectangle.
    pub fn is_empty(&self) -> bool {
        self.width == 0
    }

    /// Cube row of element `k` of sub-rectangle `s` (`k < E − 1`: line, else upper row).
    fn row(&self, s: usize, k: usize) -> usize {
        let w = usize::from(self.width).saturating_sub(1);
        let (rows, k) = if k < w {
            (&self.line, k)
        } else {
            (&self.upper, k - w)
        };
        usize::from(rows[(s + k).min(M - 1)])
    }

    /// Index of element `k`'s mirror image within a sub-rectangle.
    fn mirror(&self, k: usize) -> usize {
        let w = usize::from(self.width).saturating_sub(1);
        if k < w {
            w + (w - 1 - k)
        } else {
            w - 1 - (k - w)
        }
    }

    /// The FBSS covariance of the rectangle, loaded (`δ = γ · tr / S`), in the leading block
    /// of an `M × M` matrix (module docs), from the full-array covariance `r`.
    pub fn covariance(&self, r: &Matrix<M>, gamma: f32) -> Matrix<M> {
        let n = self.len().min(M);
        let mut out = [[Complex32::new(0.0, 0.0); M]; M];
        for s in 0..2 {
            for k in 0..n {
                let (rk, rmk) = (self.row(s, k), self.row(s, self.mirror(k)));
                for l in 0..n {
                    let (rl, rml) = (self.row(s, l), self.row(s, self.mirror(l)));
                    out[k][l] += (r[rk][rl] + r[rmk][rml].conj()) * 0.25;
                }
            }
        }
        let delta = load_diagonal_rows(&mut out, n, gamma);
        pad(&mut out, n, delta);
        out
    }

    /// The full-array vector `a` on the first sub-rectangle, in the leading block's order
    /// (zeros beyond).
    pub fn restrict(&self, a: &[Complex32; M]) -> [Complex32; M] {
        let mut out = [Complex32::new(0.0, 0.0); M];
        for (k, o) in out.iter_mut().enumerate().take(self.len()) {
            *o = a[self.row(0, k)];
        }
        out
    }

    /// A weight on the first sub-rectangle (leading block's order) back on the full array's
    /// rows (zeros elsewhere).
    pub fn expand(&self, w: &[Complex32; M]) -> [Complex32; M] {
        let mut out = [Complex32::new(0.0, 0.0); M];
        for (k, wk) in w.iter().enumerate().take(self.len()) {
            out[self.row(0, k)] = *wk;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capon::Capon;
    use crate::config::AntennaGeometry;
    use crate::covariance::{covariance, load_diagonal};

    const M: usize = 12;
    const AZ: usize = 8;

    fn layout() -> ArrayLayout<3, 4, M> {
        ArrayLayout::new(&AntennaGeometry::COLORADAR, AZ).expect("ColoRadar layout")
    }

    fn steer(l: &ArrayLayout<3, 4, M>, mu: f32, nu: f32) -> [Complex32; M] {
        core::array::from_fn(|m| Complex32::from_polar(1.0, -3.17 * (mu * l.az[m] + nu * l.el[m])))
    }

    #[test]
    fn the_awr1843_array_has_a_2_by_4_rectangle_and_a_line_has_none() {
        let l = layout();
        let s = SubArray::of(&l, AZ);
        assert_eq!(s.len(), 6);
        for k in 0..s.len() {
            // Mirror images lie point-symmetric about the first sub-rectangle's centre (az 2..4).
            let (a, b) = (s.row(0, k), s.row(0, s.mirror(k)));
            assert!((l.az[a] + l.az[b] - 6.0).abs() < 1e-6, "{k}");
            assert!((l.el[a] + l.el[b] - 1.0).abs() < 1e-6, "{k}");
        }
        // Everything on the line: nothing to average over two elevations.
        let mut flat = l;
        flat.el = [0.0; M];
        assert!(SubArray::of(&flat, AZ).is_empty());
        // A row of two elements is too short for two sub-rectangles.
        assert!(SubArray::<M>::of(&l, 10).is_empty());
    }

    /// Two coherent sources (one signal, two directions): on the FBSS rectangle the Capon
    /// elevation sweep at each source's azimuth peaks at its own elevation, where the full
    /// array's sweep is pulled away by the other source.
    #[test]
    fn fbss_gives_each_coherent_source_its_elevation() {
        const K: usize = 64;
        let l = layout();
        let sub = SubArray::of(&l, AZ);
        let src = [(0.17f32, 0.10f32), (0.50, -0.07)];
        let (a1, a2) = (steer(&l, src[0].0, src[0].1), steer(&l, src[1].0, src[1].1));
        let c = Complex32::from_polar(1.0, 2.0);
        let mut x = [[Complex32::new(0.0, 0.0); K]; M];
        for k in 0..K {
            let s = Complex32::from_polar(10.0, 0.37 * k as f32);
            // Deterministic small "noise" so the covariance is full rank.
            for (m, row) in x.iter_mut().enumerate() {
                let n = Complex32::from_polar(0.05, 1.3 * (m * K + k) as f32);
                row[k] = s * (a1[m] + c * a2[m]) + n;
            }
        }
        let mut r = [[Complex32::new(0.0, 0.0); M]; M];
        covariance(&x[..], &mut r);
        let fbss = Capon::new(&sub.covariance(&r, 0.01)).expect("positive definite");
        let mut full_r = r;
        load_diagonal(&mut full_r, 0.01);
        let full = Capon::new(&full_r).expect("positive definite");
        let peak = |f: &dyn Fn(f32) -> f32| {
            (0..=200)
                .map(|j| -0.4 + 0.004 * j as f32)
                .max_by(|a, b| f(*a).total_cmp(&f(*b)))
                .unwrap_or(0.0)
        };
        let mut full_worst = 0.0f32;
        for &(mu, nu) in &src {
            let on_sub = peak(&|v| fbss.power(&sub.restrict(&steer(&l, mu, v))));
            assert!((on_sub - nu).abs() <= 0.008, "FBSS: ν {on_sub} for {nu}");
            let on_full = peak(&|v| full.power(&steer(&l, mu, v)));
            full_worst = full_worst.max((on_full - nu).abs());
        }
        assert!(
            full_worst > 0.03,
            "the full array is not pulled: {full_worst}"
        );
        // The weight lives on the first sub-rectangle only and is distortionless there.
        let a = steer(&l, src[0].0, src[0].1);
        let w = sub.expand(&fbss.weight(&sub.restrict(&a)));
        let gain: Complex32 = w.iter().zip(a.iter()).map(|(w, a)| w.conj() * a).sum();
        assert!((gain - Complex32::new(1.0, 0.0)).norm() < 1e-3, "{gain}");
        assert_eq!(w.iter().filter(|v| v.norm() > 0.0).count(), sub.len());
    }

    #[test]
    fn smoothing_a_line_keeps_a_single_source_on_its_bin() {
        const D: usize = 8;
        let mut r = [[Complex32::new(0.0, 0.0); D]; D];
        let a: [Complex32; D] =
            core::array::from_fn(|m| Complex32::from_polar(1.0, -0.9 * m as f32));
        for i in 0..D {
            for j in 0..D {
                r[i][j] = a[i] * a[j].conj() * 100.0;
            }
            r[i][i] += Complex32::new(1.0, 0.0);
        }
        let (n, delta) = smooth_line(&mut r, true, 0.01);
        assert_eq!(n, D - 1);
        assert!(delta > 0.0);
        let capon = Capon::new(&r).expect("positive definite");
        let p = |phi: f32| {
            let mut v: [Complex32; D] =
                core::array::from_fn(|m| Complex32::from_polar(1.0, -phi * m as f32));
            v[D - 1] = Complex32::new(0.0, 0.0);
            capon.power(&v)
        };
        assert!(p(0.9) > 10.0 * p(0.5) && p(0.9) > 10.0 * p(1.3));
        // The power at the source is the source's (distortionless, 7-element loaded Capon).
        assert!((p(0.9) - 100.0).abs() < 5.0, "{}", p(0.9));
    }
}
