//! Spatial covariance of one range bin's snapshots, shared by the azimuth and elevation stages.
//!
//! Normalisation: `R = X·Xᴴ / K` with `X` the `M × K` snapshot block in range-FFT units, so
//! `R[i][i]` is the mean power of row `i`. Rows follow [`crate::config::ArrayLayout`].

use num_complex::Complex32;

/// A square complex matrix as plain rows (`r[row][col]`), constant-initialisable.
pub type Matrix<const D: usize> = [[Complex32; D]; D];

/// The zero matrix.
pub const fn zero<const D: usize>() -> Matrix<D> {
    [[Complex32::new(0.0, 0.0); D]; D]
}

/// `R = X·Xᴴ / K` of the first `D` rows of one range bin's snapshots, exactly Hermitian
/// (the upper triangle is computed and mirrored; the diagonal is real). Rows missing from
/// `snapshots` count as zero.
pub fn covariance<const D: usize, const K: usize>(snapshots: &[[Complex32; K]], r: &mut Matrix<D>) {
    let row = |i: usize| snapshots.get(i).map_or(&[][..], |x| &x[..]);
    let scale = 1.0 / K as f32;
    for i in 0..D {
        let xi = row(i);
        let mut p = 0.0f32;
        for v in xi.iter() {
            p += v.norm_sqr();
        }
        r[i][i] = Complex32::new(p * scale, 0.0);
        for j in (i + 1)..D {
            let xj = row(j);
            let mut acc = Complex32::new(0.0, 0.0);
            for (a, b) in xi.iter().zip(xj.iter()) {
                acc += a * b.conj();
            }
            acc *= scale;
            r[i][j] = acc;
            r[j][i] = acc.conj();
        }
    }
}

/// The leading `D × D` block of `r`.
pub fn leading_block<const M: usize, const D: usize>(r: &Matrix<M>) -> Matrix<D> {
    const { assert!(D <= M) };
    let mut out = zero::<D>();
    for (o, row) in out.iter_mut().zip(r.iter()) {
        o.copy_from_slice(&row[..D]);
    }
    out
}

/// Forward–backward averaging `(R + J·R*·J) / 2` (`J` the exchange matrix). Valid only for
/// a uniform line whose rows are in position order; the result stays Hermitian.
pub fn forward_backward<const D: usize>(r: &mut Matrix<D>) {
    let orig = *r;
    for i in 0..D {
        for j in 0..D {
            r[i][j] = (orig[i][j] + orig[D - 1 - i][D - 1 - j].conj()) * 0.5;
        }
    }
}

/// Diagonal loading `R + δ·I`, `δ = γ · tr(R) / D`; returns `δ`.
pub fn load_diagonal<const D: usize>(r: &mut Matrix<D>, gamma: f32) -> f32 {
    let mut trace = 0.0f32;
    for (i, row) in r.iter().enumerate() {
        trace += row[i].re;
    }
    let delta = gamma * trace / D as f32;
    for (i, row) in r.iter_mut().enumerate() {
        row[i].re += delta;
    }
    delta
}

/// `R' = D·R·Dᴴ` for the diagonal unitary `D = diag(d)`: the covariance of snapshots whose
/// row `m` was multiplied by `d[m]` (TDM-MIMO motion compensation).
pub fn rotate_rows<const D: usize>(r: &mut Matrix<D>, d: &[Complex32; D]) {
    for i in 0..D {
        for j in 0..D {
            r[i][j] = d[i] * r[i][j] * d[j].conj();
        }
    }
}
