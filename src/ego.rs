//! Ego-velocity: the radar's own 3-D velocity from one frame's points (the odometry input).
//!
//! Every static scatterer `i` in direction `u_i` (unit vector, radar frame) has the radial
//! velocity `v_r,i = −u_iᵀ·v` (positive receding; Kellner et al. 2013 in the plane, Doer &
//! Trommer 2020 in 3-D), so the points of a frame are a linear system `y = H·v` with rows
//! `h_i = −u_iᵀ`, `y_i = v_r,i`. Moving objects (people, cars) break it and are outliers.
//!
//! ```text
//! gate      : range, |azimuth|, |elevation|, SNR                      ──▶ candidate points
//! standstill: median |v_r| ≤ standstill_mps                            ──▶ v = 0
//! RANSAC    : fixed number of 3-point fits (seeded generator),
//!             inliers |y_i − h_iᵀv| ≤ inlier_mps, keep the most          ──▶ inlier set
//! refine    : weighted least squares on the inliers, inliers again, again ──▶ v
//! covariance: max(σ̂², floor²)·(HᵀWH)⁻¹ + floor²·I, σ̂² = Σ w·r² / (n − 3)
//! ```
//!
//! The weights are an errors-in-variables model: a point's direction is uncertain too, and a
//! direction error `δu ⊥ u` changes the residual by `δuᵀ·v`. A point is a patch of a surface
//! more often than a single scatterer, and its position is uncertain across the line of sight
//! by about `σ⊥` metres whatever its range, so `|δu| ≈ σ⊥/r` and the residual variance is
//! `σ_i² = floor² + |v|²·sin²θ_i·(σ⊥/r_i)²`, `θ_i` the angle between `u_i` and `v` (taken from
//! the previous fit). `w_i = floor² / σ_i²`: nearby points abeam of the motion, whose
//! direction sweeps fastest, count less. On the simulated odometry sequences the residual
//! of the static points grows from 0.01–0.02 m/s straight ahead or far away to 0.045 m/s at
//! `|v|·sinθ/r ≈ 0.5 rad/s`, both chains, which `σ⊥ ≈ 0.1 m` describes (`dbe eval`, odometry
//! section). `σ⊥ = 0` (or a zero floor) gives equal weights, the plain least squares.
//!
//! The iteration count is the classic `⌈ln(1 − p) / ln(1 − (1 − ε)³)⌉` for an assumed outlier
//! ratio `ε` and success probability `p` (Fischler & Bolles), capped at
//! [`MAX_ITERATIONS`]; with a seeded generator the estimate is a deterministic function of
//! the points. No allocation: the estimator's scratch is a fixed-size value of the point
//! capacity `P`.

use core::fmt;

use glam::Vec3;

use crate::config::{finite, ConfigError, Param};
use crate::points::Point;

/// Upper bound of the RANSAC iteration count (whatever `ε` and `p` ask for).
pub const MAX_ITERATIONS: u16 = 512;

/// Parameters of the ego-velocity estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EgoParams {
    /// Points nearer than this are not used, m (near-field and coupling leftovers).
    pub min_range_m: f32,
    /// Points farther than this are not used, m.
    pub max_range_m: f32,
    /// Largest |azimuth| of a used point, degrees (edges of the field of view are less
    /// accurate).
    pub max_azimuth_deg: f32,
    /// Largest |elevation| of a used point, degrees.
    pub max_elevation_deg: f32,
    /// Smallest SNR of a used point, dB.
    pub min_snr_db: f32,
    /// Standstill when the median |v_r| of the used points is at most this, m/s.
    pub standstill_mps: f32,
    /// A point is an inlier when its residual is at most this, m/s.
    pub inlier_mps: f32,
    /// Assumed outlier ratio ε of the RANSAC iteration count.
    pub outlier_ratio: f32,
    /// Wanted probability p that one 3-point sample is outlier-free.
    pub success_probability: f32,
    /// Fewest inliers for an estimate (at least 3).
    pub min_inliers: u8,
    /// Smallest per-point velocity noise, and the standard deviation added to every axis of
    /// the covariance, m/s (the model's floor: grid quantisation and unmodelled effects).
    pub sigma_floor_mps: f32,
    /// Cross-range position uncertainty `σ⊥` of a point, m: the direction term of the
    /// refinement's weights (module docs). `0` weighs every inlier equally.
    pub cross_range_sigma_m: f32,
    /// Seed of the sample generator.
    pub seed: u64,
}

impl EgoParams {
    /// Defaults for the ColoRadar waveform: ranges 0.5–50 m, the angle grids' spans (|azimuth|
    /// ≤ 70°, |elevation| ≤ 25°) and no SNR gate beyond the CFAR's (the DBE chain's points are
    /// sparse, and the wide field of view is what makes the fit well conditioned: tighten
    /// these for a sensor whose edges are poor); standstill below 0.05 m/s median; inliers
    /// within 0.15 m/s (about four Doppler bins of 0.039 m/s, the spread of grid Doppler
    /// estimates plus angle errors at walking speed); ε = 0.4, p = 0.999 (29 iterations); at
    /// least 5 inliers; floor 0.02 m/s (half a Doppler bin); `σ⊥` 0.1 m (module docs).
    pub const DEFAULT: Self = Self {
        min_range_m: 0.5,
        max_range_m: 50.0,
        max_azimuth_deg: 70.0,
        max_elevation_deg: 25.0,
        min_snr_db: 0.0,
        standstill_mps: 0.05,
        inlier_mps: 0.15,
        outlier_ratio: 0.4,
        success_probability: 0.999,
        min_inliers: 5,
        sigma_floor_mps: 0.02,
        cross_range_sigma_m: 0.1,
        seed: 0x5eed_0e60,
    };

    /// Validate (every value finite, ranges ordered, probabilities in `(0, 1)`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let p = Param::EgoVelocity;
        for v in [
            self.min_range_m,
            self.max_range_m,
            self.max_azimuth_deg,
            self.max_elevation_deg,
            self.min_snr_db,
            self.standstill_mps,
            self.inlier_mps,
            self.outlier_ratio,
            self.success_probability,
            self.sigma_floor_mps,
            self.cross_range_sigma_m,
        ] {
            finite(f64::from(v), p)?;
        }
        let ok = self.min_range_m >= 0.0
            && self.max_range_m > self.min_range_m
            && self.max_azimuth_deg > 0.0
            && self.max_elevation_deg > 0.0
            && self.standstill_mps >= 0.0
            && self.inlier_mps > 0.0
            && self.outlier_ratio >= 0.0
            && self.outlier_ratio < 1.0
            && self.success_probability > 0.0
            && self.success_probability < 1.0
            && self.min_inliers >= 3
            && self.sigma_floor_mps >= 0.0
            && self.cross_range_sigma_m >= 0.0;
        if ok {
            Ok(())
        } else {
            Err(ConfigError::OutOfRange(p))
        }
    }

    /// The RANSAC iteration count `⌈ln(1 − p) / ln(1 − (1 − ε)³)⌉`, at least 1, at most
    /// [`MAX_ITERATIONS`].
    pub fn iterations(&self) -> u16 {
        let good = 1.0 - self.outlier_ratio;
        let all_good = good * good * good;
        let n = libm::logf(1.0 - self.success_probability) / libm::logf(1.0 - all_good);
        if n.is_finite() && n >= 1.0 {
            libm::ceilf(n).min(f32::from(MAX_ITERATIONS)) as u16
        } else {
            1
        }
    }
}

impl EgoParams {
    /// The unit direction `u` (radar frame) and range `r` of `point` if the estimator's gate
    /// admits it (range, |azimuth|, |elevation|, SNR, a finite radial velocity), else `None`:
    /// the points a fit uses, for a caller that uses them one by one (a filter's per-point
    /// Doppler update on a frame with too few points for a fit).
    pub fn admit(&self, point: &Point) -> Option<(Vec3, f32)> {
        self.admitted(point, self.gate_sines())
    }

    /// `(sin max_azimuth, sin max_elevation)`.
    fn gate_sines(&self) -> (f32, f32) {
        (
            libm::sinf(self.max_azimuth_deg.to_radians()),
            libm::sinf(self.max_elevation_deg.to_radians()),
        )
    }

    /// [`Self::admit`] with the sines of the angle limits given.
    #[inline(always)]
    fn admitted(&self, pt: &Point, (sin_az, sin_el): (f32, f32)) -> Option<(Vec3, f32)> {
        let r = pt.position.length();
        if !(r >= self.min_range_m && r <= self.max_range_m && pt.snr_db >= self.min_snr_db) {
            return None;
        }
        let u = pt.position / r;
        // μ = −u_y = cos θ·sin φ; |φ| ≤ max ⇔ |μ| ≤ cos θ·sin(max).
        let cos_el = libm::sqrtf((1.0 - u.z * u.z).max(0.0));
        if u.z.abs() > sin_el || u.y.abs() > cos_el * sin_az || !pt.velocity_mps.is_finite() {
            return None;
        }
        Some((u, r))
    }
}

impl EgoParams {
    /// Every field zero (an unconfigured estimator).
    const ZEROED: Self = Self {
        min_range_m: 0.0,
        max_range_m: 0.0,
        max_azimuth_deg: 0.0,
        max_elevation_deg: 0.0,
        min_snr_db: 0.0,
        standstill_mps: 0.0,
        inlier_mps: 0.0,
        outlier_ratio: 0.0,
        success_probability: 0.0,
        min_inliers: 0,
        sigma_floor_mps: 0.0,
        cross_range_sigma_m: 0.0,
        seed: 0,
    };
}

impl Default for EgoParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// How an estimate ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EgoStatus {
    /// A velocity from at least `min_inliers` inliers.
    Ok,
    /// The median |v_r| of the used points is below `standstill_mps`: the velocity is zero.
    Standstill,
    /// Fewer used points, or inliers, than `min_inliers`.
    #[default]
    TooFewPoints,
    /// The inliers' directions do not span 3-D well enough to solve for `v`.
    IllConditioned,
}

impl EgoStatus {
    /// The status as written in files (`ok`, `standstill`, `too_few_points`, `ill_conditioned`).
    pub const fn name(self) -> &'static str {
        match self {
            EgoStatus::Ok => "ok",
            EgoStatus::Standstill => "standstill",
            EgoStatus::TooFewPoints => "too_few_points",
            EgoStatus::IllConditioned => "ill_conditioned",
        }
    }
}

impl fmt::Display for EgoStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The radar's velocity in one frame.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct EgoVelocity {
    /// Velocity of the radar, m/s, radar frame (x forward, y left, z up); zero unless the
    /// status is `Ok` or `Standstill`.
    pub velocity: Vec3,
    /// Its covariance, (m/s)², row-major.
    pub covariance: [[f32; 3]; 3],
    /// Inliers of the final fit.
    pub inliers: u16,
    /// Points that passed the gate.
    pub points: u16,
    /// How the estimate ended.
    pub status: EgoStatus,
}

/// The ego-velocity stage: parameters and the scratch of `P` points.
#[derive(Clone, Debug)]
pub struct EgoEstimator<const P: usize> {
    params: EgoParams,
    iterations: u16,
    /// `h_i = −u_i` of the gated points.
    rows: [Vec3; P],
    /// `v_r,i` of the gated points.
    y: [f32; P],
    /// `1 / r_i` of the gated points.
    inv_range: [f32; P],
    /// Inlier mask of the best hypothesis / the refinement.
    inlier: [bool; P],
    /// Scratch for the median.
    scratch: [f32; P],
}

impl<const P: usize> EgoEstimator<P> {
    /// An estimator with validated parameters.
    pub fn new(params: EgoParams) -> Result<Self, ConfigError> {
        params.validate()?;
        Ok(Self {
            params,
            iterations: params.iterations(),
            rows: [Vec3::ZERO; P],
            y: [0.0; P],
            inv_range: [0.0; P],
            inlier: [false; P],
            scratch: [0.0; P],
        })
    }

    /// An estimator whose every byte is zero, `const`, so that a `static` of it lands in
    /// `.bss` on firmware; [`Self::configure`] it before use. Unconfigured, it reports
    /// `too_few_points` for every frame.
    pub const fn unconfigured() -> Self {
        Self {
            params: EgoParams::ZEROED,
            iterations: 0,
            rows: [Vec3::ZERO; P],
            y: [0.0; P],
            inv_range: [0.0; P],
            inlier: [false; P],
            scratch: [0.0; P],
        }
    }

    /// Validate and set the parameters in place. On error `self` is unchanged.
    pub fn configure(&mut self, params: EgoParams) -> Result<(), ConfigError> {
        params.validate()?;
        self.params = params;
        self.iterations = params.iterations();
        Ok(())
    }

    /// The parameters.
    pub fn params(&self) -> &EgoParams {
        &self.params
    }

    /// The RANSAC iteration count in use.
    pub fn iterations(&self) -> u16 {
        self.iterations
    }

    /// Estimate the radar's velocity from one frame's points (`PointCloud::points`; module
    /// docs). Never fails; the status says what the estimate is worth. At most `P` points
    /// pass the gate (the first `P` in order).
    pub fn estimate(&mut self, points: &[Point]) -> EgoVelocity {
        let n = self.gate(points);
        let mut out = EgoVelocity {
            points: n as u16,
            ..EgoVelocity::default()
        };
        // At least 3 points whatever the parameters (an unconfigured estimator has 0).
        let min = usize::from(self.params.min_inliers).max(3);
        if n < min {
            return out;
        }
        // Standstill: the median |v_r|.
        for (s, y) in self.scratch.iter_mut().zip(self.y.iter()).take(n) {
            *s = y.abs();
        }
        let (_, median, _) = self.scratch[..n].select_nth_unstable_by(n / 2, f32::total_cmp);
        if *median <= self.params.standstill_mps {
            out.status = EgoStatus::Standstill;
            out.inliers = n as u16;
            let f2 = self.params.sigma_floor_mps * self.params.sigma_floor_mps;
            out.covariance = [[f2, 0.0, 0.0], [0.0, f2, 0.0], [0.0, 0.0, f2]];
            return out;
        }

        // RANSAC over 3-point subsets.
        let mut rng = SplitMix64(self.params.seed);
        let mut best = 0usize;
        let mut best_v = None;
        for _ in 0..self.iterations {
            let (a, b, c) = rng.three_distinct(n);
            let Some(v) = solve3(
                [self.rows[a], self.rows[b], self.rows[c]],
                [self.y[a], self.y[b], self.y[c]],
            ) else {
                continue;
            };
            let count = self.count_inliers(n, v);
            if count > best {
                best = count;
                best_v = Some(v);
            }
        }
        let Some(mut v) = best_v else {
            out.status = EgoStatus::IllConditioned;
            return out;
        };

        // Refine: least squares on the inliers, twice (the inlier set of the refined fit).
        let mut fit = None;
        for _ in 0..2 {
            let count = self.mark_inliers(n, v);
            if count < min {
                out.inliers = count as u16;
                return out;
            }
            match self.least_squares(n, v) {
                Some(f) => {
                    v = f.velocity;
                    fit = Some((f, count));
                }
                None => {
                    out.status = EgoStatus::IllConditioned;
                    return out;
                }
            }
        }
        let Some((f, count)) = fit else {
            return out;
        };
        let floor2 = self.params.sigma_floor_mps * self.params.sigma_floor_mps;
        let mut cov = f.inverse;
        let dof = (count as f32 - 3.0).max(1.0);
        // A few inliers chosen for their small residuals understate the points' noise: the
        // residual variance is taken no lower than the floor, so that a direction the points
        // barely constrain (large (HᵀH)⁻¹, e.g. vertical on a flat scene) keeps a large variance.
        let s2 = (f.residual2 / dof).max(floor2);
        for (i, row) in cov.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                *c *= s2;
                if i == j {
                    *c += floor2;
                }
            }
        }
        out.velocity = v;
        out.covariance = cov;
        out.inliers = count as u16;
        out.status = EgoStatus::Ok;
        out
    }

    /// Copy the points that pass the gate into the scratch rows; returns their number.
    fn gate(&mut self, points: &[Point]) -> usize {
        let sines = self.params.gate_sines();
        let mut n = 0;
        for pt in points {
            let Some((u, r)) = self.params.admitted(pt, sines) else {
                continue;
            };
            if let (Some(row), Some(y), Some(inv_r)) = (
                self.rows.get_mut(n),
                self.y.get_mut(n),
                self.inv_range.get_mut(n),
            ) {
                *row = -u;
                *y = pt.velocity_mps;
                *inv_r = 1.0 / r;
                n += 1;
            }
        }
        n
    }

    fn residual(&self, i: usize, v: Vec3) -> f32 {
        self.y[i] - self.rows[i].dot(v)
    }

    fn count_inliers(&self, n: usize, v: Vec3) -> usize {
        (0..n)
            .filter(|&i| self.residual(i, v).abs() <= self.params.inlier_mps)
            .count()
    }

    fn mark_inliers(&mut self, n: usize, v: Vec3) -> usize {
        let mut count = 0;
        for i in 0..n {
            let inside = self.residual(i, v).abs() <= self.params.inlier_mps;
            self.inlier[i] = inside;
            count += usize::from(inside);
        }
        count
    }

    /// Weight of point `i` at the velocity `v` (module docs): `floor² / σ_i²`, 1 without a
    /// direction term.
    fn weight(&self, i: usize, v: Vec3) -> f32 {
        let floor2 = self.params.sigma_floor_mps * self.params.sigma_floor_mps;
        let cross = self.params.cross_range_sigma_m * self.inv_range[i];
        // |v|²·sin²θ = |v|² − (u·v)² = |v × u|² (h_i = −u_i).
        let across2 = v.cross(self.rows[i]).length_squared();
        let direction2 = across2 * cross * cross;
        if floor2 > 0.0 && direction2.is_finite() {
            floor2 / (floor2 + direction2)
        } else {
            1.0
        }
    }

    /// Weighted least squares over the marked inliers, weights at the velocity `prior`:
    /// `v = (HᵀWH)⁻¹HᵀWy`, with `(HᵀWH)⁻¹` and the weighted sum of squared residuals.
    fn least_squares(&self, n: usize, prior: Vec3) -> Option<Fit> {
        let mut hth = [[0.0f32; 3]; 3];
        let mut hty = [0.0f32; 3];
        for i in (0..n).filter(|&i| self.inlier[i]) {
            let h = self.rows[i].to_array();
            let w = self.weight(i, prior);
            for r in 0..3 {
                hty[r] += w * h[r] * self.y[i];
                for c in 0..3 {
                    hth[r][c] += w * h[r] * h[c];
                }
            }
        }
        let inverse = inverse3(&hth)?;
        let velocity = Vec3::from_array(mul3(&inverse, &hty));
        let residual2 = (0..n)
            .filter(|&i| self.inlier[i])
            .map(|i| {
                let r = self.residual(i, velocity);
                self.weight(i, prior) * r * r
            })
            .sum();
        Some(Fit {
            velocity,
            inverse,
            residual2,
        })
    }
}

/// A least-squares fit.
struct Fit {
    velocity: Vec3,
    /// `(HᵀWH)⁻¹`.
    inverse: [[f32; 3]; 3],
    /// `Σ w·r²` over the inliers.
    residual2: f32,
}

/// Smallest `|det|` of a 3×3 system of unit rows accepted: directions closer to coplanar
/// than this (the volume of the parallelepiped they span) do not fix `v` in 3-D.
const MIN_DETERMINANT: f32 = 1e-3;

/// `v` with `rows[k]·v = y[k]` (Cramer's rule), `None` when nearly singular.
fn solve3(rows: [Vec3; 3], y: [f32; 3]) -> Option<Vec3> {
    let [a, b, c] = rows;
    let det = a.dot(b.cross(c));
    if !(det.abs() >= MIN_DETERMINANT) {
        return None;
    }
    // Inverse of the matrix with rows a, b, c: columns b×c, c×a, a×b over det.
    let v = (b.cross(c) * y[0] + c.cross(a) * y[1] + a.cross(b) * y[2]) / det;
    v.is_finite().then_some(v)
}

/// Inverse of a symmetric positive 3×3 matrix, `None` when its determinant is not above
/// [`MIN_DETERMINANT`] times the cube of its trace / 3 (ill-conditioned geometry).
fn inverse3(m: &[[f32; 3]; 3]) -> Option<[[f32; 3]; 3]> {
    let c = |r: usize, k: usize| m[r % 3][k % 3];
    let mut adj = [[0.0f32; 3]; 3];
    for (r, row) in adj.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            // Cofactor of (k, r): transposed for the adjugate.
            *v = c(k + 1, r + 1) * c(k + 2, r + 2) - c(k + 1, r + 2) * c(k + 2, r + 1);
        }
    }
    let det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
    let scale = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    if !(det > MIN_DETERMINANT * scale * scale * scale) || !det.is_finite() {
        return None;
    }
    for row in adj.iter_mut() {
        for v in row.iter_mut() {
            *v /= det;
        }
    }
    Some(adj)
}

fn mul3(m: &[[f32; 3]; 3], x: &[f32; 3]) -> [f32; 3] {
    let mut out = [0.0f32; 3];
    for (o, row) in out.iter_mut().zip(m.iter()) {
        *o = row[0] * x[0] + row[1] * x[1] + row[2] * x[2];
    }
    out
}

/// SplitMix64: a small, seedable generator (Steele et al. 2014), enough for sampling.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// An index in `0..n` (`n ≥ 1`; the modulo bias is below 2⁻⁵⁰ for `n ≤ 2¹⁴`).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    /// Three distinct indices in `0..n` (`n ≥ 3`).
    fn three_distinct(&mut self, n: usize) -> (usize, usize, usize) {
        let a = self.below(n);
        let mut b = self.below(n - 1);
        if b >= a {
            b += 1;
        }
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        let mut c = self.below(n - 2);
        if c >= lo {
            c += 1;
        }
        if c >= hi {
            c += 1;
        }
        (a, b, c)
    }
}
