//! Radar-inertial odometry on the host: the core's per-frame ego-velocity fed to an
//! error-state EKF with the IMU, and the trajectory's errors against ground truth.
//!
//! ```text
//! frame points ──▶ dbe_radar::EgoEstimator ──▶ FrameVelocity (radar frame, mean chirp time)
//! IMU samples  ──▶ ekf::Ekf::propagate ─┐
//!                                       ├──▶ base pose at every frame time ──▶ metrics::evaluate
//! FrameVelocity ─▶ ekf::Ekf::update ────┘   (no estimate: its gated points, one by one,
//!                                             ekf::Ekf::update_point)
//! ```
//!
//! - [`ekf`]: the filter (IMU propagation, radar ego-velocity update with the lever arm, χ²
//!   gate, initialisation at a standstill or in motion).
//! - [`metrics`]: association, 4-DoF alignment, ATE, relative errors, end-point drift.
//! - [`start`]: which initialisation a sequence gets; [`run`]: the whole sequence;
//!   [`ego_truth`]: the radar velocity the ground truth implies.
//!
//! The same [`ekf::EkfParams`] serve whichever chain made the points.

pub mod ekf;
pub mod metrics;

use std::fmt::Write as _;

use dbe_radar::{ConfigError, EgoEstimator, EgoParams, EgoStatus, EgoVelocity};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use crate::cloud::PointRecord;
use crate::io::{StampedPose, Transforms};
use crate::sim::imu::ImuSample;
use crate::sim::trajectory::Mount;
use ekf::{Ekf, EkfError, EkfParams, RadarVelocity, RadialVelocity, Start, UpdateOutcome};

/// The ego-velocity of one radar frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameVelocity {
    /// The frame's timestamp, s (the trajectory is written at these times).
    pub frame_time_s: f64,
    /// The time the velocity refers to: the frame's mean chirp time, s.
    pub measure_time_s: f64,
    /// Points of the frame.
    pub points: usize,
    /// The core's estimate.
    pub ego: EgoVelocity,
    /// The points the estimate's gate admitted (`EgoParams::admit`), for the filter's point
    /// updates when the estimate is not usable.
    pub radials: Vec<RadialVelocity>,
}

impl FrameVelocity {
    /// The measurement the filter takes, if the estimate is usable (`ok` or `standstill`).
    pub fn measurement(&self) -> Option<RadarVelocity> {
        matches!(self.ego.status, EgoStatus::Ok | EgoStatus::Standstill).then(|| {
            let v = self.ego.velocity;
            let c = self.ego.covariance;
            RadarVelocity {
                time_s: self.measure_time_s,
                velocity: Vector3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z)),
                covariance: Matrix3::from_fn(|r, k| f64::from(c[r][k])),
            }
        })
    }
}

/// Points the ego-velocity stage takes from one frame (the largest preset's point capacity).
pub const EGO_POINTS: usize = 256;

/// The core's ego-velocity estimate (default parameters) of every frame: `frames` holds each
/// frame's timestamp and points; the velocity refers to `timestamp + mid_frame_s` (the mean
/// chirp time, [`crate::score::mid_frame_s`]).
pub fn frame_velocities(
    frames: &[(f64, &[PointRecord])],
    mid_frame_s: f64,
) -> Result<Vec<FrameVelocity>, ConfigError> {
    let mut ego = Box::new(EgoEstimator::<EGO_POINTS>::new(EgoParams::DEFAULT)?);
    Ok(frames
        .iter()
        .map(|&(t, points)| {
            let points: Vec<dbe_radar::Point> = points.iter().map(PointRecord::to_point).collect();
            let radials = points
                .iter()
                .filter_map(|p| {
                    let (u, r) = ego.params().admit(p)?;
                    Some(RadialVelocity {
                        direction: Vector3::new(f64::from(u.x), f64::from(u.y), f64::from(u.z)),
                        range_m: f64::from(r),
                        velocity_mps: f64::from(p.velocity_mps),
                    })
                })
                .collect();
            FrameVelocity {
                frame_time_s: t,
                measure_time_s: t + mid_frame_s,
                points: points.len(),
                ego: ego.estimate(&points),
                radials,
            }
        })
        .collect())
}

/// Ego-velocity errors of a sequence against a truth.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EgoErrors {
    /// RMSE per radar axis (x, y, z) over the frames with an estimate, m/s.
    pub rmse_mps: [f64; 3],
    /// Mean error (estimate − truth) per radar axis over the same frames, m/s: the part of
    /// the RMSE that is a bias.
    pub mean_error_mps: [f64; 3],
    /// Frames with an estimate (`ok` or `standstill`) and a truth.
    pub frames_compared: usize,
    /// Frames whose true speed exceeds 0.1 m/s.
    pub moving_frames: usize,
    /// Of those, the share with an estimate, %.
    pub estimated_while_moving_pct: f64,
    /// Consistency of the reported covariances: the mean of `eᵀ·Σ⁻¹·e / 3` over the `ok`
    /// estimates (1 for a covariance that matches the errors; above 1 it is too small).
    pub nees: f64,
    /// The estimator's own standard deviation per axis, RMS over the same `ok` estimates,
    /// m/s: the RMSE a consistent covariance predicts (`√(mean Σ_ii)`).
    pub predicted_rms_mps: [f64; 3],
}

/// The errors of `frames`' estimates against `truth(t)`, the radar's true velocity in its own
/// frame at time `t` (`None` where unknown).
pub fn ego_errors(
    frames: &[FrameVelocity],
    truth: impl Fn(f64) -> Option<Vector3<f64>>,
) -> EgoErrors {
    let (mut sq, mut n, mut moving, mut moving_ok) = ([0.0f64; 3], 0usize, 0usize, 0usize);
    let mut sum = [0.0f64; 3];
    let (mut nees, mut n_ok, mut var) = (0.0, 0usize, [0.0f64; 3]);
    for f in frames {
        let Some(t) = truth(f.measure_time_s) else {
            continue;
        };
        let ok = f.measurement().is_some();
        if t.norm() > 0.1 {
            moving += 1;
            moving_ok += usize::from(ok);
        }
        if let Some(z) = f.measurement() {
            let e = z.velocity - t;
            for i in 0..3 {
                sq[i] += e[i].powi(2);
                sum[i] += e[i];
            }
            n += 1;
            if f.ego.status == EgoStatus::Ok {
                if let Some(inv) = z.covariance.try_inverse() {
                    nees += (e.transpose() * inv * e)[(0, 0)] / 3.0;
                    n_ok += 1;
                    for (i, v) in var.iter_mut().enumerate() {
                        *v += z.covariance[(i, i)];
                    }
                }
            }
        }
    }
    EgoErrors {
        rmse_mps: sq.map(|s| {
            if n > 0 {
                (s / n as f64).sqrt()
            } else {
                f64::NAN
            }
        }),
        mean_error_mps: sum.map(|s| if n > 0 { s / n as f64 } else { f64::NAN }),
        frames_compared: n,
        moving_frames: moving,
        estimated_while_moving_pct: if moving > 0 {
            100.0 * moving_ok as f64 / moving as f64
        } else {
            f64::NAN
        },
        nees: if n_ok > 0 {
            nees / n_ok as f64
        } else {
            f64::NAN
        },
        predicted_rms_mps: var.map(|v| {
            if n_ok > 0 {
                (v / n_ok as f64).sqrt()
            } else {
                f64::NAN
            }
        }),
    }
}

/// How well the points' radial velocities agree with their directions, against the truth:
/// for a static scatterer `v_r = −u·v`, so `v_r + u·v_true` is the part of a point's error
/// that the ego-velocity fit sees (Doppler error plus direction error times the speed).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RadialConsistency {
    /// Points used: those of frames moving faster than [`RadialConsistency::MIN_SPEED_MPS`]
    /// whose residual against the truth is within the estimator's inlier band (static).
    pub points: usize,
    /// Least-squares slope through the origin of the measured `v_r` against `−u·v_true`:
    /// 1 when unbiased; below 1 the points read a slower radar.
    pub scale: f64,
    /// Residual RMS, m/s, of the points whose direction sweeps slowly (`|v|·sinθ/r` below
    /// 0.1 rad/s) and fast (at or above 0.3 rad/s): the direction term of the estimator's
    /// weights (`EgoParams::cross_range_sigma_m`).
    pub rms_slow_fast_mps: [f64; 2],
}

impl RadialConsistency {
    /// Frames slower than this are left out, m/s.
    pub const MIN_SPEED_MPS: f64 = 0.3;

    /// From `frames` (measurement time, points) and `truth(t)`, the radar's velocity in its
    /// own frame.
    pub fn measure(
        frames: &[(f64, &[PointRecord])],
        truth: impl Fn(f64) -> Option<Vector3<f64>>,
    ) -> Self {
        let band = f64::from(EgoParams::DEFAULT.inlier_mps);
        let (mut xy, mut xx, mut n) = (0.0, 0.0, 0usize);
        let mut sums = [(0.0f64, 0usize); 2];
        for &(t, points) in frames {
            let Some(v) = truth(t).filter(|v| v.norm() > Self::MIN_SPEED_MPS) else {
                continue;
            };
            for p in points {
                let pos = Vector3::new(p.x, p.y, p.z);
                let r = pos.norm();
                if !(r > 0.0) {
                    continue;
                }
                let u = pos / r;
                let predicted = -u.dot(&v);
                let e = p.doppler - predicted;
                if !(e.abs() <= band) {
                    continue;
                }
                xy += p.doppler * predicted;
                xx += predicted * predicted;
                n += 1;
                let rate = u.cross(&v).norm() / r;
                let slot = match rate {
                    x if x < 0.1 => Some(0),
                    x if x >= 0.3 => Some(1),
                    _ => None,
                };
                if let Some(k) = slot {
                    sums[k].0 += e * e;
                    sums[k].1 += 1;
                }
            }
        }
        let rms = |(s, c): (f64, usize)| {
            if c > 0 {
                (s / c as f64).sqrt()
            } else {
                f64::NAN
            }
        };
        Self {
            points: n,
            scale: if xx > 0.0 { xy / xx } else { f64::NAN },
            rms_slow_fast_mps: sums.map(rms),
        }
    }
}

/// What the filter did over a sequence.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct UpdateCounts {
    /// Radar updates applied.
    pub applied: usize,
    /// Radar updates rejected by the χ² gate.
    pub gated: usize,
    /// Radar updates applied only after `widen_after_s` of gated ones widened the velocity's
    /// covariance ([`ekf::Ekf::widen_velocity`]; not counted as gated or applied).
    pub widened: usize,
    /// Frames without a usable estimate (too few points, ill-conditioned).
    pub no_estimate: usize,
    /// Of those, frames with at least one point update applied.
    pub point_frames: usize,
    /// Point updates applied (frames without an estimate).
    pub points_applied: usize,
    /// Point updates rejected by their gate.
    pub points_gated: usize,
    /// Zero-rate updates applied: frames with a radar standstill after one, the IMU at rest
    /// in between ([`ekf::Ekf::update_zero_rate`]).
    pub zero_rate: usize,
    /// Zero-rate updates not applied: the IMU not at rest between the two standstills, or
    /// the mean rate rejected by the χ² gate.
    pub zero_rate_rejected: usize,
    /// Frames before the end of the initial standstill (no update).
    pub during_init: usize,
    /// Frames before a moving start (not in the trajectory).
    pub before_start: usize,
    /// Frames after the last IMU sample (not in the trajectory).
    pub after_imu: usize,
}

/// The estimated trajectory of a sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct OdometryRun {
    /// The base frame in the gravity-aligned world, one pose per frame time.
    pub trajectory: Vec<StampedPose>,
    /// What happened to the frames' measurements.
    pub updates: UpdateCounts,
    /// How the filter started.
    pub start: Start,
    /// The radar's time offset t_d at the end, s, and its standard deviation
    /// ([`ekf::EkfParams::time_offset_sigma`]).
    pub time_offset_s: (f64, f64),
    /// The radar's velocity scale at the end and its standard deviation
    /// ([`ekf::EkfParams::velocity_scale_sigma`]).
    pub velocity_scale: (f64, f64),
}

/// The base frame's pose from the IMU's: `R_wb = R_wi·R_biᵀ`, `p_wb = p_wi − R_wb·t_bi`.
fn base_pose(
    time_s: f64,
    p_wi: Vector3<f64>,
    q_wi: UnitQuaternion<f64>,
    imu: &Mount,
) -> StampedPose {
    let q_bi = UnitQuaternion::from_rotation_matrix(&imu.rotation());
    let q_wb = q_wi * q_bi.inverse();
    StampedPose {
        time_s,
        position: p_wi - (q_wb * imu.translation()),
        rotation: q_wb,
    }
}

/// The filter at its start, the index of the IMU sample after it, and how it started: from
/// the standstill at the start of the IMU data ([`Ekf::initialise`]) when the IMU shows the rig
/// at rest there and no radar velocity measured in that window exceeds `rest_speed_mps` (an
/// IMU cannot tell rest from a steady walk), else in motion ([`Ekf::initialise_moving`]) at the
/// first radar velocity with half the moving window of IMU data on both sides.
pub fn start(
    params: &EkfParams,
    imu: &[ImuSample],
    frames: &[FrameVelocity],
    transforms: &Transforms,
) -> Result<(Ekf, usize, Start), EkfError> {
    let (radar, imu_mount) = (&transforms.radar, &transforms.imu);
    let window_s = params.init_standstill_s;
    match Ekf::initialise(params.clone(), imu, radar, imu_mount) {
        Ok((ekf, next)) => {
            let time_s = ekf.state().time_s;
            let radar_moves = frames
                .iter()
                .filter(|f| f.measure_time_s <= time_s && f.ego.status == EgoStatus::Ok)
                .filter_map(FrameVelocity::measurement)
                .any(|z| z.velocity.norm() > params.rest_speed_mps);
            if !radar_moves {
                return Ok((ekf, next, Start::Standstill { time_s }));
            }
        }
        Err(EkfError::NotAtRest { .. }) => {}
        Err(e) => return Err(e),
    }
    let half = 0.5 * params.init_moving_window_s;
    let (first, last) = match (imu.first(), imu.last()) {
        (Some(a), Some(b)) => (a.time_s + half, b.time_s - half),
        _ => return Err(EkfError::NoStartVelocity { window_s }),
    };
    let z = frames
        .iter()
        .filter_map(FrameVelocity::measurement)
        .find(|z| z.time_s >= first && z.time_s <= last)
        .ok_or(EkfError::NoStartVelocity { window_s })?;
    let (ekf, next) = Ekf::initialise_moving(params.clone(), imu, &z, radar, imu_mount)?;
    Ok((ekf, next, Start::Moving { time_s: z.time_s }))
}

/// Run the filter over a sequence: `imu` in time order, `frames` in time order. It starts
/// ([`start`]) from the standstill at the start of the IMU data, or in motion at the first
/// radar velocity. The trajectory has one base pose per frame from the start (a standstill's
/// frames included) up to the last IMU sample.
pub fn run(
    params: &EkfParams,
    imu: &[ImuSample],
    frames: &[FrameVelocity],
    transforms: &Transforms,
) -> Result<OdometryRun, EkfError> {
    let (mut ekf, mut next, start) = start(params, imu, frames, transforms)?;
    let init_end = ekf.state().time_s;
    let mut last_applied = init_end;
    let mut updates = UpdateCounts::default();
    // The measurement time of the last frame (IMU clock), if it was a radar standstill
    // (zero-rate updates span two).
    let mut standstill_since: Option<f64> = None;
    let mut trajectory = Vec::with_capacity(frames.len());
    let last_imu = imu.last().map_or(f64::NEG_INFINITY, |s| s.time_s);
    let advance = |ekf: &mut Ekf, next: &mut usize, t: f64| {
        while *next < imu.len() && imu[*next].time_s <= t {
            ekf.propagate(&imu[*next]);
            *next += 1;
        }
        if *next < imu.len() {
            ekf.propagate_to(t, &imu[*next]);
        }
    };
    for f in frames {
        let previous = standstill_since.take();
        if matches!(start, Start::Moving { .. }) && f.frame_time_s < init_end {
            updates.before_start += 1;
            continue;
        }
        if f.frame_time_s > last_imu {
            updates.after_imu += 1;
            continue;
        }
        advance(&mut ekf, &mut next, f.frame_time_s);
        let s = ekf.state();
        trajectory.push(base_pose(
            f.frame_time_s,
            s.position,
            s.attitude,
            &transforms.imu,
        ));
        if f.measure_time_s <= init_end {
            updates.during_init += 1;
            continue;
        }
        let Some(z) = f.measurement() else {
            updates.no_estimate += 1;
            if params.point_updates && !f.radials.is_empty() && f.measure_time_s <= last_imu {
                let t = ekf.measure_time(f.measure_time_s);
                advance(&mut ekf, &mut next, t);
                let mut applied = 0;
                for p in &f.radials {
                    match ekf.update_point(p, f.measure_time_s) {
                        UpdateOutcome::Applied => applied += 1,
                        UpdateOutcome::Gated => updates.points_gated += 1,
                    }
                }
                updates.points_applied += applied;
                updates.point_frames += usize::from(applied > 0);
                if applied > 0 {
                    last_applied = f.measure_time_s;
                }
            }
            continue;
        };
        if z.time_s > last_imu {
            updates.after_imu += 1;
            continue;
        }
        let t = ekf.measure_time(z.time_s);
        advance(&mut ekf, &mut next, t);
        let standstill = f.ego.status == EgoStatus::Standstill;
        if standstill {
            standstill_since = Some(t);
        }
        match ekf.update(&z) {
            UpdateOutcome::Applied => {
                updates.applied += 1;
                last_applied = z.time_s;
            }
            UpdateOutcome::Gated if z.time_s - last_applied >= params.widen_after_s => {
                ekf.widen_velocity(params.init_moving_velocity_sigma);
                match ekf.update(&z) {
                    UpdateOutcome::Applied => {
                        updates.widened += 1;
                        last_applied = z.time_s;
                    }
                    UpdateOutcome::Gated => updates.gated += 1,
                }
            }
            UpdateOutcome::Gated => updates.gated += 1,
        }
        if let Some(t0) = previous.filter(|_| standstill && params.zero_rate_updates) {
            let window = &imu[imu.partition_point(|s| s.time_s <= t0).min(next)..next];
            match ekf.update_zero_rate(window) {
                Some(UpdateOutcome::Applied) => updates.zero_rate += 1,
                _ => updates.zero_rate_rejected += 1,
            }
        }
    }
    Ok(OdometryRun {
        trajectory,
        updates,
        start,
        time_offset_s: (ekf.state().time_offset_s, ekf.time_offset_sigma()),
        velocity_scale: (ekf.state().velocity_scale, ekf.velocity_scale_sigma()),
    })
}

/// The radar's velocity in its own frame at `t` that the ground-truth base poses imply
/// (central differences over `h` s of the interpolated truth, the radar's lever arm included);
/// `None` outside the truth's span.
pub fn ego_truth(gt: &[StampedPose], radar: &Mount, t: f64, h: f64) -> Option<Vector3<f64>> {
    let a = metrics::interpolate(gt, t - h)?;
    let b = metrics::interpolate(gt, t + h)?;
    let c = metrics::interpolate(gt, t)?;
    let v_world = (b.position - a.position) / (2.0 * h);
    let omega_body = (a.rotation.inverse() * b.rotation).scaled_axis() / (2.0 * h);
    let r_wb = c.rotation.to_rotation_matrix();
    let v_radar_world = v_world + r_wb * omega_body.cross(&radar.translation());
    let r_wr: Rotation3<f64> = r_wb * radar.rotation();
    Some(r_wr.inverse() * v_radar_world)
}

/// The median spacing of the truth's timestamps, s (a step for [`ego_truth`]).
pub fn median_spacing(gt: &[StampedPose]) -> f64 {
    let mut d: Vec<f64> = gt.windows(2).map(|w| w[1].time_s - w[0].time_s).collect();
    d.retain(|x| *x > 0.0);
    if d.is_empty() {
        return 0.05;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// A trajectory in the TUM format (`t tx ty tz qx qy qz qw` per line), as `evo` reads it.
pub fn tum_text(trajectory: &[StampedPose]) -> String {
    let mut s = String::from("# t tx ty tz qx qy qz qw\n");
    for p in trajectory {
        let q = p.rotation;
        let _ = writeln!(
            s,
            "{:.6} {:.6} {:.6} {:.6} {:.9} {:.9} {:.9} {:.9}",
            p.time_s, p.position.x, p.position.y, p.position.z, q.i, q.j, q.k, q.w
        );
    }
    s
}

/// The header of `ego_velocity.csv`.
pub const EGO_CSV_HEADER: &str = "t,vx,vy,vz,sigma_x,sigma_y,sigma_z,inliers,points,status";

/// The frames' ego-velocities as CSV ([`EGO_CSV_HEADER`]; radar frame, m/s; σ the square roots
/// of the covariance's diagonal; time the mean chirp time).
pub fn ego_csv(frames: &[FrameVelocity]) -> String {
    let mut s = format!("{EGO_CSV_HEADER}\n");
    for f in frames {
        let e = &f.ego;
        let sd = |i: usize| f64::from(e.covariance[i][i]).max(0.0).sqrt();
        let _ = writeln!(
            s,
            "{:.6},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{},{},{}",
            f.measure_time_s,
            e.velocity.x,
            e.velocity.y,
            e.velocity.z,
            sd(0),
            sd(1),
            sd(2),
            e.inliers,
            e.points,
            e.status
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(t: f64, v: [f32; 3], var: [f32; 3], status: EgoStatus) -> FrameVelocity {
        let mut covariance = [[0.0f32; 3]; 3];
        for (i, row) in covariance.iter_mut().enumerate() {
            row[i] = var[i];
        }
        FrameVelocity {
            frame_time_s: t,
            measure_time_s: t,
            points: 10,
            ego: EgoVelocity {
                velocity: dbe_radar::Vec3::new(v[0], v[1], v[2]),
                covariance,
                inliers: 10,
                points: 10,
                status,
            },
            radials: Vec::new(),
        }
    }

    #[test]
    fn errors_nees_and_predicted_spread_by_hand() {
        // Truth (1, 0, 0) throughout. Two `ok` frames, one standstill (counted in the RMSE,
        // not in the covariance statistics), one without an estimate.
        let frames = [
            frame(0.0, [1.1, 0.0, 0.2], [0.01, 0.04, 0.09], EgoStatus::Ok),
            frame(0.1, [0.9, 0.2, 0.0], [0.03, 0.02, 0.07], EgoStatus::Ok),
            frame(
                0.2,
                [0.0, 0.0, 0.0],
                [0.0004, 0.0004, 0.0004],
                EgoStatus::Standstill,
            ),
            frame(0.3, [0.0, 0.0, 0.0], [0.0; 3], EgoStatus::TooFewPoints),
        ];
        let e = ego_errors(&frames, |_| Some(Vector3::new(1.0, 0.0, 0.0)));
        assert_eq!((e.frames_compared, e.moving_frames), (3, 4));
        assert!((e.estimated_while_moving_pct - 75.0).abs() < 1e-9);
        let rmse = [(0.01f64 + 0.01 + 1.0) / 3.0, 0.04 / 3.0, 0.04 / 3.0].map(f64::sqrt);
        let mean = [(0.1 - 0.1 - 1.0) / 3.0, 0.2 / 3.0, 0.2 / 3.0];
        let nees = ((0.01 / 0.01 + 0.04 / 0.09) + (0.01 / 0.03 + 0.04 / 0.02)) / 6.0;
        let predicted = [0.02f64, 0.03, 0.08].map(f64::sqrt);
        for i in 0..3 {
            assert!((e.rmse_mps[i] - rmse[i]).abs() < 1e-6, "{e:?}");
            assert!((e.mean_error_mps[i] - mean[i]).abs() < 1e-6, "{e:?}");
            assert!(
                (e.predicted_rms_mps[i] - predicted[i]).abs() < 1e-6,
                "{e:?}"
            );
        }
        assert!((e.nees - nees).abs() < 1e-5, "{e:?}");
    }
}
