//! Sensor-rig motion: 6-DoF trajectories of the rig's base frame, the rigid mounts of the radar
//! and the IMU on it, and the full kinematic state (pose, velocity, acceleration, angular
//! velocity and acceleration) at any instant.
//!
//! A [`Trajectory`] is either a start pose moving with a constant world velocity and yaw rate,
//! or timed [`Waypoint`]s (position, yaw, pitch, roll) joined by
//!
//! - `interpolation = "linear"` (default): straight segments, piecewise-constant velocity and
//!   angle rates, no acceleration (the motion of the original scenes);
//! - `interpolation = "spline"`: a cubic Hermite spline through every waypoint, per channel
//!   (x, y, z, yaw, pitch, roll), with the parabolic tangent of the three waypoints around each
//!   knot, zero where the channel turns back or stands still and limited to three times either
//!   neighbouring secant (Fritsch–Carlson: each segment is monotone, so the path never
//!   overshoots a waypoint and repeated waypoints are a standstill), zero at both ends. Velocity is continuous, acceleration piecewise
//!   linear: what an IMU on a walking or driving rig sees.
//!
//! Attitude is `R = Rz(yaw)·Ry(pitch)·Rx(roll)` (body → world, z–y–x Euler angles), and the
//! body angular velocity follows from the angle rates by the z–y–x kinematic equations.
//!
//! A [`Mount`] places a sensor in the base frame as ColoRadar's `calib/transforms/*.txt` do:
//! `p_base = R·p_sensor + t`. [`Pose::mounted`] carries the whole kinematic state over (lever
//! arm terms included), so the radar and the IMU of one rig move consistently.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Step of the central difference that gives the angular acceleration, s.
const ANGULAR_DIFF_S: f64 = 1e-4;

/// Sensor trajectory in the world frame (see the module docs); every field defaults to zero,
/// a static rig at the origin.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trajectory {
    /// Start position, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 3]>,
    /// Constant velocity in the world frame, m/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<[f64; 3]>,
    /// Start yaw (rotation about z, counter-clockwise from the world x axis), degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw_deg: Option<f64>,
    /// Constant yaw rate, degrees per second.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw_rate_deg_s: Option<f64>,
    /// How waypoints are joined.
    #[serde(default, skip_serializing_if = "is_linear")]
    pub interpolation: Interpolation,
    /// Timed poses, strictly increasing in time.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub waypoints: Vec<Waypoint>,
}

/// How [`Trajectory::waypoints`] are joined.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Straight segments at constant velocity.
    #[default]
    Linear,
    /// A cubic Hermite spline (continuous velocity).
    Spline,
}

fn is_linear(i: &Interpolation) -> bool {
    *i == Interpolation::Linear
}

/// One timed pose of the rig's base frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Waypoint {
    /// Time, s.
    pub time_s: f64,
    /// Position, m.
    pub position: [f64; 3],
    /// Yaw, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Pitch (rotation about the body y axis, nose down positive), degrees.
    #[serde(default)]
    pub pitch_deg: f64,
    /// Roll (rotation about the body x axis), degrees.
    #[serde(default)]
    pub roll_deg: f64,
}

impl Waypoint {
    /// The six channels `[x, y, z, yaw, pitch, roll]` (angles in radians).
    fn channels(&self) -> [f64; 6] {
        let [x, y, z] = self.position;
        [
            x,
            y,
            z,
            self.yaw_deg.to_radians(),
            self.pitch_deg.to_radians(),
            self.roll_deg.to_radians(),
        ]
    }
}

/// Where a sensor sits on the rig: `p_base = R·p_sensor + t` (ColoRadar's transform files).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mount {
    /// Translation `t`: the sensor's origin in the base frame, m.
    #[serde(default)]
    pub position: [f64; 3],
    /// Rotation `R` (sensor → base) as a unit quaternion `[qx, qy, qz, qw]`.
    #[serde(default = "identity_quaternion")]
    pub quaternion: [f64; 4],
}

fn identity_quaternion() -> [f64; 4] {
    [0.0, 0.0, 0.0, 1.0]
}

impl Default for Mount {
    fn default() -> Self {
        Self {
            position: [0.0; 3],
            quaternion: identity_quaternion(),
        }
    }
}

impl Mount {
    /// The rotation (sensor → base); the quaternion is normalised.
    pub fn rotation(&self) -> Rotation3<f64> {
        quaternion_from_xyzw(self.quaternion).to_rotation_matrix()
    }

    /// The translation as a vector.
    pub fn translation(&self) -> Vector3<f64> {
        Vector3::from(self.position)
    }

    /// Check that the values are finite and the quaternion has a usable norm.
    pub fn validate(&self, name: &str) -> Result<(), String> {
        if !self
            .position
            .iter()
            .chain(&self.quaternion)
            .all(|v| v.is_finite())
        {
            return Err(format!("{name}: values must be finite"));
        }
        let n = self.quaternion.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (n - 1.0).abs() > 1e-3 {
            return Err(format!(
                "{name}.quaternion {:?} must be a unit quaternion [qx, qy, qz, qw] (norm {n})",
                self.quaternion
            ));
        }
        Ok(())
    }
}

/// A unit quaternion from `[qx, qy, qz, qw]` (normalised).
pub fn quaternion_from_xyzw(q: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[3], q[0], q[1], q[2]))
}

/// `[qx, qy, qz, qw]` of a rotation, with `qw ≥ 0`.
pub fn xyzw(r: &Rotation3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(r);
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    [s * q.i, s * q.j, s * q.k, s * q.w]
}

/// The kinematic state of a rigid frame (the rig's base, the radar or the IMU) at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Position in the world frame, m.
    pub position: Vector3<f64>,
    /// Orientation, body → world.
    pub rotation: Rotation3<f64>,
    /// Velocity in the world frame, m/s.
    pub velocity: Vector3<f64>,
    /// Acceleration in the world frame (gravity not included), m/s².
    pub acceleration: Vector3<f64>,
    /// Angular velocity in the body frame, rad/s.
    pub angular_velocity: Vector3<f64>,
    /// Angular acceleration in the body frame, rad/s².
    pub angular_acceleration: Vector3<f64>,
}

impl Pose {
    /// At rest at `position` with orientation `rotation`.
    pub fn at_rest(position: Vector3<f64>, rotation: Rotation3<f64>) -> Self {
        Self {
            position,
            rotation,
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            angular_acceleration: Vector3::zeros(),
        }
    }

    /// Yaw of the body x axis in the world, rad.
    pub fn yaw_rad(&self) -> f64 {
        let m = self.rotation.matrix();
        m[(1, 0)].atan2(m[(0, 0)])
    }

    /// Velocity in the body frame, `Rᵀ·v`, m/s (for the radar: the ego-velocity truth).
    pub fn body_velocity(&self) -> Vector3<f64> {
        self.rotation.inverse() * self.velocity
    }

    /// The trajectory's pose at `time_s` as a stamped pose (the ground-truth format).
    pub fn stamped(&self, time_s: f64) -> crate::io::StampedPose {
        crate::io::StampedPose {
            time_s,
            position: self.position,
            rotation: UnitQuaternion::from_rotation_matrix(&self.rotation),
        }
    }

    /// Angular velocity in the world frame, rad/s.
    pub fn angular_velocity_world(&self) -> Vector3<f64> {
        self.rotation * self.angular_velocity
    }

    /// The state of a frame rigidly mounted on this body at `mount`: position `p + R·t`,
    /// orientation `R·R_m`, velocity `v + R·(ω × t)`, acceleration
    /// `a + R·(ω̇ × t + ω × (ω × t))`, angular velocity and acceleration rotated into the
    /// mounted frame.
    pub fn mounted(&self, mount: &Mount) -> Pose {
        let t = mount.translation();
        let rm = mount.rotation();
        let (w, dw) = (self.angular_velocity, self.angular_acceleration);
        Pose {
            position: self.position + self.rotation * t,
            rotation: self.rotation * rm,
            velocity: self.velocity + self.rotation * w.cross(&t),
            acceleration: self.acceleration
                + self.rotation * (dw.cross(&t) + w.cross(&w.cross(&t))),
            angular_velocity: rm.inverse() * w,
            angular_acceleration: rm.inverse() * dw,
        }
    }

    /// A world point in this body's frame: `Rᵀ·(w − p)`.
    pub fn to_body(&self, w: Vector3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (w - self.position)
    }

    /// The velocity, relative to this body and in its frame, of a point at body position `p`
    /// that moves in the world with constant velocity `v`: `Rᵀ·(v − v_body) − ω × p`.
    pub fn relative_velocity(&self, v: Vector3<f64>, p: Vector3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (v - self.velocity) - self.angular_velocity.cross(&p)
    }

    /// The second derivative of that point's body-frame position (the first is
    /// [`Self::relative_velocity`]): with `d = Rᵀ·(v − v_body)`,
    /// `−ω̇ × p − 2·ω × d + ω × (ω × p) − Rᵀ·a_body`.
    pub fn relative_acceleration(&self, v: Vector3<f64>, p: Vector3<f64>) -> Vector3<f64> {
        let rt = self.rotation.inverse();
        let d = rt * (v - self.velocity);
        let w = self.angular_velocity;
        -self.angular_acceleration.cross(&p) - 2.0 * w.cross(&d) + w.cross(&w.cross(&p))
            - rt * self.acceleration
    }
}

/// `Rz(yaw)·Ry(pitch)·Rx(roll)`, written out so that zero pitch and roll give the exact yaw
/// matrix.
pub fn rotation_zyx(yaw: f64, pitch: f64, roll: f64) -> Rotation3<f64> {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sr, cr) = roll.sin_cos();
    Rotation3::from_matrix_unchecked(Matrix3::new(
        cy * cp,
        cy * sp * sr - sy * cr,
        cy * sp * cr + sy * sr,
        sy * cp,
        sy * sp * sr + cy * cr,
        sy * sp * cr - cy * sr,
        -sp,
        cp * sr,
        cp * cr,
    ))
}

/// Body angular velocity of z–y–x Euler angles `[yaw, pitch, roll]` changing at `rates`.
fn body_rate(angles: [f64; 3], rates: [f64; 3]) -> Vector3<f64> {
    let [_, pitch, roll] = angles;
    let [dyaw, dpitch, droll] = rates;
    let (sp, cp) = pitch.sin_cos();
    let (sr, cr) = roll.sin_cos();
    Vector3::new(
        droll - dyaw * sp,
        dpitch * cr + dyaw * cp * sr,
        -dpitch * sr + dyaw * cp * cr,
    )
}

/// Value, first and second derivative of the six channels at one instant.
type Channels = ([f64; 6], [f64; 6], [f64; 6]);

impl Trajectory {
    /// The base frame's kinematic state at time `t` (s).
    pub fn pose(&self, t: f64) -> Pose {
        let state = |t: f64| self.channels(t);
        let (x, dx, ddx) = state(t);
        let angles = [x[3], x[4], x[5]];
        let omega = |(x, dx, _): Channels| body_rate([x[3], x[4], x[5]], [dx[3], dx[4], dx[5]]);
        let h = ANGULAR_DIFF_S;
        let angular_acceleration = (omega(state(t + h)) - omega(state(t - h))) / (2.0 * h);
        Pose {
            position: Vector3::new(x[0], x[1], x[2]),
            rotation: rotation_zyx(angles[0], angles[1], angles[2]),
            velocity: Vector3::new(dx[0], dx[1], dx[2]),
            acceleration: Vector3::new(ddx[0], ddx[1], ddx[2]),
            angular_velocity: body_rate(angles, [dx[3], dx[4], dx[5]]),
            angular_acceleration,
        }
    }

    /// The channels `[x, y, z, yaw, pitch, roll]` and their first two derivatives at `t`.
    fn channels(&self, t: f64) -> Channels {
        let (Some(first), Some(last)) = (self.waypoints.first(), self.waypoints.last()) else {
            let p0 = self.position.unwrap_or_default();
            let v = self.velocity.unwrap_or_default();
            let rate = self.yaw_rate_deg_s.unwrap_or_default().to_radians();
            let yaw0 = self.yaw_deg.unwrap_or_default().to_radians();
            return (
                [
                    p0[0] + v[0] * t,
                    p0[1] + v[1] * t,
                    p0[2] + v[2] * t,
                    yaw0 + rate * t,
                    0.0,
                    0.0,
                ],
                [v[0], v[1], v[2], rate, 0.0, 0.0],
                [0.0; 6],
            );
        };
        if t < first.time_s {
            return (first.channels(), [0.0; 6], [0.0; 6]);
        }
        let Some(i) = self
            .waypoints
            .windows(2)
            .position(|w| t >= w[0].time_s && t < w[1].time_s)
        else {
            return (last.channels(), [0.0; 6], [0.0; 6]);
        };
        let (a, b) = (&self.waypoints[i], &self.waypoints[i + 1]);
        let (pa, pb) = (a.channels(), b.channels());
        let h = b.time_s - a.time_s;
        match self.interpolation {
            Interpolation::Linear => {
                let f = (t - a.time_s) / h;
                (
                    std::array::from_fn(|c| pa[c] + f * (pb[c] - pa[c])),
                    std::array::from_fn(|c| (pb[c] - pa[c]) / h),
                    [0.0; 6],
                )
            }
            Interpolation::Spline => {
                let (ma, mb) = (self.tangent(i), self.tangent(i + 1));
                let s = (t - a.time_s) / h;
                let (s2, s3) = (s * s, s * s * s);
                let basis = [
                    2.0 * s3 - 3.0 * s2 + 1.0,
                    s3 - 2.0 * s2 + s,
                    -2.0 * s3 + 3.0 * s2,
                    s3 - s2,
                ];
                let d1 = [
                    6.0 * s2 - 6.0 * s,
                    3.0 * s2 - 4.0 * s + 1.0,
                    -6.0 * s2 + 6.0 * s,
                    3.0 * s2 - 2.0 * s,
                ];
                let d2 = [
                    12.0 * s - 6.0,
                    6.0 * s - 4.0,
                    -12.0 * s + 6.0,
                    6.0 * s - 2.0,
                ];
                let mix = |w: [f64; 4], c: usize| {
                    w[0] * pa[c] + w[1] * h * ma[c] + w[2] * pb[c] + w[3] * h * mb[c]
                };
                (
                    std::array::from_fn(|c| mix(basis, c)),
                    std::array::from_fn(|c| mix(d1, c) / h),
                    std::array::from_fn(|c| mix(d2, c) / (h * h)),
                )
            }
        }
    }

    /// Spline tangent of every channel at waypoint `i`: the slope of the parabola through
    /// waypoints `i − 1, i, i + 1`, zero at both ends and where the channel stops or turns.
    fn tangent(&self, i: usize) -> [f64; 6] {
        let w = &self.waypoints;
        if i == 0 || i + 1 >= w.len() {
            return [0.0; 6];
        }
        let (p0, p1, p2) = (w[i - 1].channels(), w[i].channels(), w[i + 1].channels());
        let (h0, h1) = (w[i].time_s - w[i - 1].time_s, w[i + 1].time_s - w[i].time_s);
        std::array::from_fn(|c| {
            let (s0, s1) = ((p1[c] - p0[c]) / h0, (p2[c] - p1[c]) / h1);
            if s0 * s1 <= 0.0 {
                0.0
            } else {
                // Fritsch–Carlson: at most 3× either secant keeps the segment monotone.
                let m = (s0 * h1 + s1 * h0) / (h0 + h1);
                m.signum() * m.abs().min(3.0 * s0.abs().min(s1.abs()))
            }
        })
    }

    /// The time of the last waypoint (0 without waypoints): the motion ends there.
    pub fn end_time_s(&self) -> f64 {
        self.waypoints.last().map_or(0.0, |w| w.time_s)
    }
}
