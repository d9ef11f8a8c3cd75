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
///
/// Each row `i` is multiplied with up to four later rows in one pass over the loops, so one
/// load of `x_i[k]` serves four products and every product is four real multiply–adds into
/// its own accumulators (on the Cortex-M4F 21 % fewer instructions than one pair per pass).
pub fn covariance<const D: usize, const K: usize>(snapshots: &[[Complex32; K]], r: &mut Matrix<D>) {
    *r = zero::<D>();
    let rows = &snapshots[..snapshots.len().min(D)];
    let scale = 1.0 / K as f32;
    for (i, xi) in rows.iter().enumerate() {
        let mut p = 0.0f32;
        for v in xi.iter() {
            p += v.re * v.re;
            p += v.im * v.im;
        }
        r[i][i] = Complex32::new(p * scale, 0.0);
        let mut j = i + 1;
        while j < rows.len() {
            let later = &rows[j..];
            let mut block = [Complex32::new(0.0, 0.0); 4];
            let b = match later {
                [a, b, c, d, ..] => {
                    block = cross(xi, [a, b, c, d]);
                    4
                }
                [a, b, c] => {
                    block[..3].copy_from_slice(&cross(xi, [a, b, c]));
                    3
                }
                [a, b] => {
                    block[..2].copy_from_slice(&cross(xi, [a, b]));
                    2
                }
                [a] => {
                    block[..1].copy_from_slice(&cross(xi, [a]));
                    1
                }
                [] => break,
            };
            for (o, acc) in block.iter().take(b).enumerate() {
                let v = *acc * scale;
                r[i][j + o] = v;
                r[j + o][i] = v.conj();
            }
            j += b;
        }
    }
}

/// `Σ_k x[k]·conj(y_b[k])` for each row `y_b`.
#[inline(never)]
fn cross<const K: usize, const B: usize>(
    x: &[Complex32; K],
    y: [&[Complex32; K]; B],
) -> [Complex32; B] {
    let mut re = [0.0f32; B];
    let mut im = [0.0f32; B];
    for (k, xk) in x.iter().enumerate() {
        for b in 0..B {
            let v = y[b][k];
            // x · conj(v), as four multiply–adds.
            re[b] += xk.re * v.re;
            re[b] += xk.im * v.im;
            im[b] += xk.im * v.re;
            im[b] -= xk.re * v.im;
        }
    }
    core::array::from_fn(|b| Complex32::new(re[b], im[b]))
}

/// `r[i][j] · f[i] · f[j]` (in that order; a missing `f[i]` counts as 1): the covariance of
/// snapshots whose row `i` was multiplied by `f[i]`, for real factors (undoes
/// [`crate::cube::Frame::leading_snapshots_factored`]).
pub fn scale_rows<const D: usize>(r: &mut Matrix<D>, f: &[f32]) {
    for (i, row) in r.iter_mut().enumerate() {
        let fi = f.get(i).copied().unwrap_or(1.0);
        for (j, v) in row.iter_mut().enumerate() {
            let fj = f.get(j).copied().unwrap_or(1.0);
            *v = *v * fi * fj;
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
    load_diagonal_rows(r, D, gamma)
}

/// Diagonal loading of the leading `n × n` block only: `δ = γ · tr / n` over that block, added
/// to its diagonal; returns `δ`.
pub fn load_diagonal_rows<const D: usize>(r: &mut Matrix<D>, n: usize, gamma: f32) -> f32 {
    let n = n.min(D);
    let mut trace = 0.0f32;
    for (i, row) in r.iter().enumerate().take(n) {
        trace += row[i].re;
    }
    let delta = if n > 0 { gamma * trace / n as f32 } else { 0.0 };
    for (i, row) in r.iter_mut().enumerate().take(n) {
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
