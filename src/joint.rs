//! Joint elevation fit of the points of one range bin (beyond the paper's chain;
//! [`crate::Params::joint_elevation`]).
//!
//! The Capon elevation sweep of one detection treats the other returns of its range bin as
//! interference, nulled with the few degrees of freedom of a 12-element array whose
//! elevation aperture is one row; when several returns share a bin, their elevations are
//! pulled toward each other. This stage fits them together on the deterministic model
//! `x_k = Σ_s a_s·s_s(k) + n_k` of the range bin's snapshots, on its raw sample covariance
//! `R` (no loading, no averaging, no TDM rotation). Each source's steering vector carries
//! its own TDM slot phase, `a_s(ν) = conj(rot(d_s)) ⊙ a(μ_s, ν)` with `d_s` its Doppler
//! ([`crate::tdm::rotation`]), so sources of different radial velocities share one
//! covariance, and coherent sources (equal Dopplers) need no smoothing: the deterministic
//! model does not assume uncorrelated signals.
//!
//! The azimuths stay as the chain measured them; the elevations are found by alternating
//! projection (Ziskind & Wax 1988): each source in turn takes the elevation grid bin within
//! [`SEARCH_BINS`] of its start (the Capon elevation) that maximises `bᴴ R b / bᴴ b`,
//! `b = P⊥ a_s(ν)` with `P⊥` the projection off the span of the other sources' steering
//! vectors at their current elevations. Each step cannot lower `tr(P_A R)` (the model's
//! explained power), and the sweeps stop when no bin moves, at most `sweeps` times.

use num_complex::Complex32;

use crate::covariance::Matrix;

/// The most sources of one range bin fitted jointly; a bin with more points keeps their
/// Capon elevations (bounds the stack and the cost, `MAX_SOURCES` ≤ M − 4 on a 12-element
/// array leaves the projection four dimensions).
pub const MAX_SOURCES: usize = 8;

/// Passes of the alternating projection, at most (it stops earlier when no bin moves; on
/// the evaluation's scenes two or three suffice).
pub const SWEEPS: u8 = 4;

/// Range bins either side whose points join a bin's fit as sources: the Blackman range
/// window's main lobe spans ±3 bins, so a return two bins away still reaches the bin at
/// about −20 dB, and left out of the model it pulls the bin's elevations as in Capon.
pub const NEIGHBOUR_BINS: u16 = 2;

/// How far (elevation grid bins) a source may move from its start: 8 bins (4° on the
/// default grid) covers the pull of crowded bins measured on point scatterers (up to 2° with
/// four in a bin, `host-sim/tests/harness.rs`) and keeps a source of a surface, which the
/// few-point model describes poorly, from jumping to another maximum of the objective (over
/// the whole grid the odometry sequences' ego-velocity z error grew, 0.093 → 0.096 m/s on
/// hallways; within 8 bins it fell to 0.087).
pub const SEARCH_BINS: usize = 8;

/// One source of the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source<const M: usize> {
    /// Its steering vector without the elevation row: azimuth row `exp(−j·κ·μ·az_m)` times
    /// the conjugate of its TDM rotation.
    pub base: [Complex32; M],
    /// Elevation grid bin (in: the start; out: the fit).
    pub bin: usize,
    /// Sub-bin offset of the fit's objective peak (log-parabola, [`crate::refine`]); 0 at
    /// the grid's ends.
    pub frac: f32,
}

/// An orthonormal basis of up to `MAX_SOURCES` vectors.
struct Basis<const M: usize> {
    q: [[Complex32; M]; MAX_SOURCES],
    len: usize,
}

impl<const M: usize> Basis<M> {
    /// The basis of the steering vectors of every source but `skip` (modified Gram–Schmidt;
    /// a vector already in the span adds nothing).
    fn others<const NEL: usize>(
        sources: &[Source<M>],
        skip: usize,
        el_steer: &[[Complex32; M]; NEL],
    ) -> Self {
        let mut basis = Self {
            q: [[Complex32::new(0.0, 0.0); M]; MAX_SOURCES],
            len: 0,
        };
        for (t, src) in sources.iter().enumerate().take(MAX_SOURCES) {
            if t == skip {
                continue;
            }
            let Some(el) = el_steer.get(src.bin) else {
                continue;
            };
            let v = basis.residual(&steering(&src.base, el));
            let n2 = norm_sqr(&v);
            if n2 > 1e-6 * M as f32 {
                let inv = 1.0 / libm::sqrtf(n2);
                let slot = &mut basis.q[basis.len];
                for (o, x) in slot.iter_mut().zip(v.iter()) {
                    *o = x * inv;
                }
                basis.len += 1;
            }
        }
        basis
    }

    /// `a` minus its projection on the basis.
    fn residual(&self, a: &[Complex32; M]) -> [Complex32; M] {
        let mut b = *a;
        for q in &self.q[..self.len] {
            let c: Complex32 = q.iter().zip(b.iter()).map(|(q, x)| q.conj() * x).sum();
            for (x, q) in b.iter_mut().zip(q.iter()) {
                *x -= c * q;
            }
        }
        b
    }
}

fn norm_sqr<const M: usize>(v: &[Complex32; M]) -> f32 {
    v.iter().map(|x| x.norm_sqr()).sum()
}

/// `base ⊙ el`.
fn steering<const M: usize>(base: &[Complex32; M], el: &[Complex32; M]) -> [Complex32; M] {
    let mut a = *base;
    for (x, e) in a.iter_mut().zip(el.iter()) {
        *x *= e;
    }
    a
}

/// `bᴴ R b / bᴴ b` of `b = P⊥ a`: the power the source explains beyond the others; 0 where
/// `a` lies (numerically) in their span.
fn objective<const M: usize>(r: &Matrix<M>, basis: &Basis<M>, a: &[Complex32; M]) -> f32 {
    let b = basis.residual(a);
    let bb = norm_sqr(&b);
    if !(bb > 1e-4 * M as f32) {
        return 0.0;
    }
    let mut q = 0.0f32;
    for (row, bi) in r.iter().zip(b.iter()) {
        let rb: Complex32 = row.iter().zip(b.iter()).map(|(x, y)| x * y).sum();
        q += (bi.conj() * rb).re;
    }
    q / bb
}

/// Fit the elevations of `sources` on the range bin's covariance `r` (see the module
/// documentation): at most `sweeps` passes of alternating projection over the `NEL`
/// elevation steering rows `el_steer`, then, with `refine`, each source's sub-bin offset
/// (`frac` stays as given without). Fewer than two sources, or more than [`MAX_SOURCES`],
/// are left unchanged.
pub fn fit<const M: usize, const NEL: usize>(
    r: &Matrix<M>,
    el_steer: &[[Complex32; M]; NEL],
    sources: &mut [Source<M>],
    sweeps: u8,
    refine: bool,
) {
    if sources.len() < 2 || sources.len() > MAX_SOURCES || NEL < 3 {
        return;
    }
    let mut start = [0usize; MAX_SOURCES];
    for (o, s) in start.iter_mut().zip(sources.iter()) {
        *o = s.bin.min(NEL - 1);
    }
    for _ in 0..sweeps {
        let mut moved = false;
        for s in 0..sources.len() {
            let basis = Basis::others(sources, s, el_steer);
            let base = sources[s].base;
            let mut best = (sources[s].bin.min(NEL - 1), f32::NEG_INFINITY);
            let (lo, hi) = (
                start[s].saturating_sub(SEARCH_BINS),
                (start[s] + SEARCH_BINS).min(NEL - 1),
            );
            for (j, el) in el_steer.iter().enumerate().take(hi + 1).skip(lo) {
                let f = objective(r, &basis, &steering(&base, el));
                if f > best.1 {
                    best = (j, f);
                }
            }
            moved |= best.0 != sources[s].bin;
            sources[s].bin = best.0;
        }
        if !moved {
            break;
        }
    }
    if !refine {
        return;
    }
    for s in 0..sources.len() {
        let j = sources[s].bin;
        sources[s].frac = match (j.checked_sub(1), el_steer.get(j + 1)) {
            (Some(left), Some(right)) => {
                let basis = Basis::others(sources, s, el_steer);
                let base = sources[s].base;
                let f = |el: &[Complex32; M]| objective(r, &basis, &steering(&base, el));
                crate::refine::parabolic_offset(f(&el_steer[left]), f(&el_steer[j]), f(right))
            }
            _ => 0.0,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const M: usize = 12;
    const NEL: usize = 101;

    /// The AWR1843 virtual array in half wavelengths: the 8-element azimuth line, and 4
    /// elements one row up over line positions 2..5.
    fn layout() -> ([f32; M], [f32; M]) {
        let mut az = [0.0; M];
        let mut el = [0.0; M];
        for m in 0..8 {
            az[m] = m as f32;
        }
        for m in 0..4 {
            az[8 + m] = (m + 2) as f32;
            el[8 + m] = 1.0;
        }
        (az, el)
    }

    fn grid_nu(j: usize) -> f32 {
        libm::sinf((-25.0 + 0.5 * j as f32).to_radians())
    }

    fn el_table(el: &[f32; M]) -> [[Complex32; M]; NEL] {
        let mut t = [[Complex32::new(0.0, 0.0); M]; NEL];
        for (j, row) in t.iter_mut().enumerate() {
            for (a, e) in row.iter_mut().zip(el.iter()) {
                *a = Complex32::from_polar(1.0, -core::f32::consts::PI * grid_nu(j) * e);
            }
        }
        t
    }

    /// Azimuth row at `mu` times a per-row phase `slot_phase · (m / 4)` (a TDM slot step).
    fn base(az: &[f32; M], mu: f32, slot_phase: f32) -> [Complex32; M] {
        let mut b = [Complex32::new(0.0, 0.0); M];
        for (m, (o, p)) in b.iter_mut().zip(az.iter()).enumerate() {
            let slot = (m / 4) as f32;
            *o = Complex32::from_polar(1.0, -core::f32::consts::PI * mu * p + slot_phase * slot);
        }
        b
    }

    /// `R = Σ_s a_s a_sᴴ + σ²·I` for uncorrelated unit-power sources, or with `coherent` the
    /// rank-one `R = (Σ a_s)(Σ a_s)ᴴ + σ²·I`.
    fn covariance(a: &[[Complex32; M]], coherent: bool, noise: f32) -> Matrix<M> {
        let mut r = [[Complex32::new(0.0, 0.0); M]; M];
        let mut sum = [Complex32::new(0.0, 0.0); M];
        for v in a {
            for (s, x) in sum.iter_mut().zip(v.iter()) {
                *s += x;
            }
        }
        let terms: &[[Complex32; M]] = if coherent {
            core::slice::from_ref(&sum)
        } else {
            a
        };
        for v in terms {
            for i in 0..M {
                for j in 0..M {
                    r[i][j] += v[i] * v[j].conj();
                }
            }
        }
        for (i, row) in r.iter_mut().enumerate() {
            row[i] += Complex32::new(noise, 0.0);
        }
        r
    }

    fn scene(coherent: bool) -> (Matrix<M>, [Source<M>; 4], [usize; 4]) {
        let (az, el) = layout();
        let table = el_table(&el);
        let truth = [20usize, 64, 44, 30];
        let mus = [-0.50f32, -0.22, 0.05, 0.31];
        let phases = if coherent {
            [0.0; 4]
        } else {
            [0.0, 0.4, -0.7, 1.1]
        };
        let mut a = [[Complex32::new(0.0, 0.0); M]; 4];
        let mut sources = [Source {
            base: [Complex32::new(0.0, 0.0); M],
            bin: 0,
            frac: 0.0,
        }; 4];
        for s in 0..4 {
            let b = base(&az, mus[s], phases[s]);
            a[s] = steering(&b, &table[truth[s]]);
            // Started 2.5–4° (5–8 bins) off, beyond what the Capon sweep leaves in crowded
            // bins, within the search window.
            sources[s] = Source {
                base: b,
                bin: [truth[0] + 7, truth[1] - 8, truth[2] + 6, truth[3] - 5][s],
                frac: 0.0,
            };
        }
        (covariance(&a, coherent, 1e-3), sources, truth)
    }

    #[test]
    fn four_sources_of_one_range_bin_get_their_elevations() {
        for coherent in [false, true] {
            let (r, mut sources, truth) = scene(coherent);
            let table = el_table(&layout().1);
            fit(&r, &table, &mut sources, 4, true);
            for (s, t) in sources.iter().zip(truth.iter()) {
                assert_eq!(s.bin, *t, "coherent {coherent}: {sources:?}");
                // On the grid, the objective's log-parabola peak stays within a tenth of a bin.
                assert!(s.frac.abs() < 0.1, "coherent {coherent}: {s:?}");
            }
        }
    }

    #[test]
    fn a_source_moves_at_most_the_search_window() {
        let (r, mut sources, truth) = scene(false);
        let table = el_table(&layout().1);
        // Source 0 started two windows away from its truth: it ends at the window's edge
        // nearest the truth, the others still find theirs.
        sources[0].bin = truth[0] + 2 * SEARCH_BINS;
        fit(&r, &table, &mut sources, 4, true);
        assert_eq!(sources[0].bin, truth[0] + SEARCH_BINS, "{sources:?}");
        for (s, t) in sources.iter().zip(truth.iter()).skip(1) {
            assert_eq!(s.bin, *t, "{sources:?}");
        }
    }

    #[test]
    fn one_source_or_too_many_are_left_alone() {
        let (r, sources, _) = scene(false);
        let table = el_table(&layout().1);
        let mut one = [sources[0]];
        fit(&r, &table, &mut one, 4, true);
        assert_eq!(one[0], sources[0]);
        let mut many = [sources[0]; MAX_SOURCES + 1];
        fit(&r, &table, &mut many, 4, true);
        assert!(many.iter().all(|s| *s == sources[0]));
    }
}
