//! Trajectory errors as the field reports them (uzh-rpg `rpg_trajectory_evaluation`, and the
//! end-point drift columns of the DBE paper's Table III).
//!
//! ```text
//! association  every estimated pose with the ground truth interpolated at its time
//!              (linear position, slerp attitude); poses outside the ground truth are dropped
//! alignment    position + yaw (4-DoF, "posyaw"): the rotation about z and the translation
//!              that minimise Σ |g_i − (Rz·e_i + t)|² (closed form, least squares)
//! ATE          RMSE of the aligned positions; yaw RMSE
//! relative     for sub-trajectories of 10 / 20 / 30 % of the path length: each start i, the
//!              first j at least that far along the ground truth; the estimate's segment
//!              aligned to the truth at i by position and yaw; errors at j: position (m, % of
//!              the length) and yaw
//! drift        the estimate aligned to the truth at its first pose (position and yaw), then
//!              the error at the last pose: XYZ, XY and Z in m and % of the path length, yaw in
//!              ° and °/m
//! ```

use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use serde::Serialize;

use crate::io::StampedPose;

/// Sub-trajectory lengths of the relative error, fractions of the path length.
pub const RELATIVE_FRACTIONS: [f64; 3] = [0.1, 0.2, 0.3];

/// Yaw of a body → world rotation, rad.
pub fn yaw_of(q: &UnitQuaternion<f64>) -> f64 {
    let m = q.to_rotation_matrix().into_inner();
    m[(1, 0)].atan2(m[(0, 0)])
}

/// An angle wrapped into (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(std::f64::consts::TAU);
    if w > std::f64::consts::PI {
        w - std::f64::consts::TAU
    } else {
        w
    }
}

/// The ground truth interpolated at `t`, or `None` outside its time span.
pub fn interpolate(gt: &[StampedPose], t: f64) -> Option<StampedPose> {
    let (first, last) = (gt.first()?, gt.last()?);
    if t < first.time_s || t > last.time_s {
        return None;
    }
    let i = gt.partition_point(|p| p.time_s <= t);
    if i == 0 {
        return Some(*first);
    }
    if i >= gt.len() {
        return Some(*last);
    }
    let (a, b) = (&gt[i - 1], &gt[i]);
    let span = b.time_s - a.time_s;
    let f = if span > 0.0 {
        (t - a.time_s) / span
    } else {
        0.0
    };
    Some(StampedPose {
        time_s: t,
        position: a.position + f * (b.position - a.position),
        rotation: a.rotation.slerp(&b.rotation, f),
    })
}

/// Matched pairs `(estimate, truth)`.
pub fn associate(estimate: &[StampedPose], gt: &[StampedPose]) -> Vec<(StampedPose, StampedPose)> {
    estimate
        .iter()
        .filter_map(|e| interpolate(gt, e.time_s).map(|g| (*e, g)))
        .collect()
}

/// A position + yaw transform: `p ↦ Rz(yaw)·p + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosYaw {
    /// Rotation about z, rad.
    pub yaw: f64,
    /// Translation, m.
    pub translation: Vector3<f64>,
}

impl PosYaw {
    fn rotation(&self) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Vector3::z_axis(), self.yaw)
    }

    /// Apply to a position.
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation() * p + self.translation
    }
}

/// The least-squares position + yaw alignment of `est` onto `gt` (equal lengths, ≥ 1).
pub fn align_posyaw(est: &[Vector3<f64>], gt: &[Vector3<f64>]) -> PosYaw {
    let n = est.len().min(gt.len()).max(1) as f64;
    let me: Vector3<f64> = est.iter().sum::<Vector3<f64>>() / n;
    let mg: Vector3<f64> = gt.iter().sum::<Vector3<f64>>() / n;
    let (mut s, mut c) = (0.0, 0.0);
    for (e, g) in est.iter().zip(gt) {
        let (e, g) = (e - me, g - mg);
        s += e.x * g.y - e.y * g.x;
        c += e.x * g.x + e.y * g.y;
    }
    let yaw = if s == 0.0 && c == 0.0 {
        0.0
    } else {
        s.atan2(c)
    };
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw);
    PosYaw {
        yaw,
        translation: mg - rot * me,
    }
}

/// The alignment that puts the estimate's pose `e` onto the truth's `g` (position and yaw).
fn align_at(e: &StampedPose, g: &StampedPose) -> PosYaw {
    let yaw = wrap(yaw_of(&g.rotation) - yaw_of(&e.rotation));
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw);
    PosYaw {
        yaw,
        translation: g.position - rot * e.position,
    }
}

/// Relative errors over one sub-trajectory length.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelativeError {
    /// Fraction of the path length.
    pub fraction: f64,
    /// Sub-trajectory length, m.
    pub length_m: f64,
    /// Sub-trajectories evaluated.
    pub segments: usize,
    /// RMSE of the end-position errors, m.
    pub translation_rmse_m: f64,
    /// Mean end-position error, % of `length_m`.
    pub translation_mean_pct: f64,
    /// Mean |yaw error| at the segment end, degrees.
    pub yaw_mean_deg: f64,
}

/// End-point drift after aligning the first pose (the paper's Table III columns).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Drift {
    /// |Δp|, m.
    pub xyz_m: f64,
    /// |Δp| / path length, %.
    pub xyz_pct: f64,
    /// Horizontal |Δp|, m.
    pub xy_m: f64,
    /// Horizontal |Δp| / path length, %.
    pub xy_pct: f64,
    /// |Δz|, m.
    pub z_m: f64,
    /// |Δz| / path length, %.
    pub z_pct: f64,
    /// |yaw error|, degrees.
    pub yaw_deg: f64,
    /// |yaw error| / path length, degrees per metre.
    pub yaw_deg_per_m: f64,
}

/// Every error of one estimated trajectory against its ground truth.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrajectoryErrors {
    /// Estimated poses matched with the truth.
    pub matched: usize,
    /// Ground-truth path length over the matched span, m.
    pub path_length_m: f64,
    /// RMSE of the positions after the 4-DoF alignment, m.
    pub ate_rmse_m: f64,
    /// RMSE of the yaw after the 4-DoF alignment, degrees.
    pub ate_yaw_rmse_deg: f64,
    /// Relative errors, one per [`RELATIVE_FRACTIONS`] entry that fits the path.
    pub relative: Vec<RelativeError>,
    /// End-point drift.
    pub drift: Drift,
}

/// Evaluate `estimate` against `gt`; `None` with fewer than two matched poses.
pub fn evaluate(estimate: &[StampedPose], gt: &[StampedPose]) -> Option<TrajectoryErrors> {
    let pairs = associate(estimate, gt);
    if pairs.len() < 2 {
        return None;
    }
    let along: Vec<f64> = std::iter::once(0.0)
        .chain(pairs.windows(2).scan(0.0, |d, w| {
            *d += (w[1].1.position - w[0].1.position).norm();
            Some(*d)
        }))
        .collect();
    let path = *along.last().unwrap_or(&0.0);

    let est: Vec<Vector3<f64>> = pairs.iter().map(|(e, _)| e.position).collect();
    let tru: Vec<Vector3<f64>> = pairs.iter().map(|(_, g)| g.position).collect();
    let al = align_posyaw(&est, &tru);
    let n = pairs.len() as f64;
    let ate = (pairs
        .iter()
        .map(|(e, g)| (g.position - al.apply(&e.position)).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    let ate_yaw = (pairs
        .iter()
        .map(|(e, g)| wrap(yaw_of(&g.rotation) - yaw_of(&e.rotation) - al.yaw).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();

    let mut relative = Vec::new();
    for fraction in RELATIVE_FRACTIONS {
        let length = fraction * path;
        if !(length > 0.0) {
            continue;
        }
        let (mut sq, mut pct, mut yaw, mut count) = (0.0, 0.0, 0.0, 0usize);
        let mut j = 0;
        for i in 0..pairs.len() {
            j = j.max(i);
            while j < pairs.len() && along[j] - along[i] < length {
                j += 1;
            }
            if j >= pairs.len() {
                break;
            }
            let (ei, gi) = &pairs[i];
            let (ej, gj) = &pairs[j];
            let a = align_at(ei, gi);
            let err = (gj.position - a.apply(&ej.position)).norm();
            let dyaw = wrap(yaw_of(&gj.rotation) - yaw_of(&ej.rotation) - a.yaw);
            sq += err * err;
            pct += 100.0 * err / length;
            yaw += dyaw.abs().to_degrees();
            count += 1;
        }
        if count > 0 {
            let c = count as f64;
            relative.push(RelativeError {
                fraction,
                length_m: length,
                segments: count,
                translation_rmse_m: (sq / c).sqrt(),
                translation_mean_pct: pct / c,
                yaw_mean_deg: yaw / c,
            });
        }
    }

    let (e0, g0) = &pairs[0];
    let (e1, g1) = &pairs[pairs.len() - 1];
    let a = align_at(e0, g0);
    let d = g1.position - a.apply(&e1.position);
    let dyaw = wrap(yaw_of(&g1.rotation) - yaw_of(&e1.rotation) - a.yaw)
        .abs()
        .to_degrees();
    let pct = |m: f64| if path > 0.0 { 100.0 * m / path } else { 0.0 };
    let xy = (d.x * d.x + d.y * d.y).sqrt();
    Some(TrajectoryErrors {
        matched: pairs.len(),
        path_length_m: path,
        ate_rmse_m: ate,
        ate_yaw_rmse_deg: ate_yaw.to_degrees(),
        relative,
        drift: Drift {
            xyz_m: d.norm(),
            xyz_pct: pct(d.norm()),
            xy_m: xy,
            xy_pct: pct(xy),
            z_m: d.z.abs(),
            z_pct: pct(d.z.abs()),
            yaw_deg: dyaw,
            yaw_deg_per_m: if path > 0.0 { dyaw / path } else { 0.0 },
        },
    })
}
