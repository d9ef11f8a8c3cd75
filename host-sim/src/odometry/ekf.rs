//! Radar-inertial odometry: an error-state EKF driven by the IMU and corrected by the radar's
//! ego-velocity (Doer & Trommer 2020, "An EKF based approach to radar inertial odometry").
//!
//! ```text
//! nominal state   p, v (world), q (IMU → world), b_a, b_g, t_d (the radar's time offset),
//!                 s (the radar's velocity scale)
//! error state     δp, δv, δθ (IMU frame), δb_a, δb_g, δt_d, δs       17 values
//! propagation     a = R_mid·(f − b_a) + g,  p += v·dt + a·dt²/2,  v += a·dt,
//!                 q ← q ⊗ Exp((ω − b_g)·dt),  R_mid = R(q ⊗ Exp((ω − b_g)·dt/2))
//!                 (f, ω: the two IMU samples' mean over the interval, the force rotated by
//!                 the interval's mid attitude); t_d constant, s a random walk
//!                 (`velocity_scale_walk`, by default 0: constant)
//! radar update    at stamp + t_d on the IMU's clock:
//!                 v_radar = s·h,  h = R_irᵀ·(Rᵀ·v + (ω − b_g) × l_ir)  ω × l: the lever arm
//!                 H = [0, s·R_irᵀRᵀ, s·R_irᵀ[Rᵀv]×, 0, s·R_irᵀ[l_ir]×, s·ḣ, h],  χ² gate
//!                 ḣ = R_irᵀ·(Rᵀ·a − ω × Rᵀ·v): the velocity's rate of change (`time_offset_sigma`)
//! point update    v_r = −uᵀ·v_radar for one static point (direction u, radar frame), scalar,
//!                 H = −uᵀ·H_radar, σ² = σ_f² + (σ⊥/r)²·|v_radar × u|², its own χ² gate
//! initialisation  the first `init_standstill_s` of IMU data at rest: roll and pitch from the
//!                 mean specific force, gyro bias from the mean rate, yaw 0, p = v = 0
//! moving start    (the IMU, or a radar velocity over `rest_speed_mps`, shows the rig moving
//!                 in that window) at the first radar velocity: roll and pitch from the mean
//!                 specific force over `init_moving_window_s` around it (tilt σ
//!                 `init_moving_tilt_sigma`), v = R·(R_ir·v_radar − ω × l_ir) with its
//!                 covariance raised to `init_moving_velocity_sigma`, gyro bias 0 (σ
//!                 `init_moving_gyro_bias_sigma`), yaw 0, p = 0
//! widening        after `widen_after_s` with every radar update gated (and no point update
//!                 applied), the velocity's variances grow by `init_moving_velocity_sigma²` and
//!                 the gated update is tried again (each further gated frame, again)
//! zero rate       between two radar standstills with the IMU at rest in between: the mean
//!                 rate ω̄ = b_g + n, H = [0, 0, 0, 0, I], σ² = σ_g²/T + zero_rate_sigma²,
//!                 χ² gate (`zero_rate_updates`)
//! ```
//!
//! A moving start has no standstill mean of the gyro: the yaw rate's turn-on bias, which no
//! velocity update observes, turns the whole path, so expect more heading drift than from a
//! start at rest. Every later stop measures it (the zero-rate update): the radar's standstill
//! says the rig does not move, the IMU's rest test that it does not turn (a rig turning about
//! the radar keeps a static scene's Doppler at zero), and the filter learns its gyro bias
//! there, and through their correlation corrects the heading and position that bias has
//! turned since the last stop. Nothing but the χ² gate tells a slow turn at a standstill from
//! a bias: a rig panned at under about 0.3°/s (4σ of the update once the bias is known; more
//! while it is not) is partly taken for one. A person turning round, at tens of degrees per
//! second, fails the IMU's rest test. The start velocity's raised covariance keeps one wrong
//! first estimate (a pedestrian pulling the fit) from gating out every right one after it.
//! The widening is for a filter whose velocity went wrong (IMU errors beyond its parameters,
//! a wrong start): its χ² gate would reject every right radar velocity after, and the IMU
//! alone carries it off by metres within seconds. A moving object that fills the view for
//! longer is let in the same way, and the static scene after it again: an error of a second
//! or two, not a lost filter.
//!
//! The time offset: a radar's stamps are rarely the IMU's clock at the middle of the chirps
//! (a frame-end or arrival stamp, a transfer delay), and a velocity taken at the wrong time is
//! wrong by the acceleration times the offset and turned by the rate times it, most in turns,
//! where the filter takes it for a heading error, and for a gyro bias that then turns the
//! rest of the path: 50 ms cost the simulated hallways walk 1.9–2.2 % of its path (velocities
//! exact but for 2 cm/s of noise, no standstill frames, so no zero-rate update pins the bias
//! down; `host-sim/tests/odometry.rs`). The filter starts from `time_offset_s` ±
//! `time_offset_sigma` and learns the offset wherever the velocity changes.
//!
//! The velocity scale: a radar can read every velocity a little slow or fast, and no fit
//! within one frame can tell. The points' directions are biased towards the boresight where
//! a vertical surface returns from above and below the radar at one range (the eval's *v_r
//! scale*, 0.980–0.996 on the simulated sequences), and a wrong chirp slope or carrier in a
//! configuration scales the Doppler itself. A scale stretches the whole path. The IMU measures
//! every change of the velocity (starts, stops, turns) and the radar reads s times it, so the
//! filter estimates s from `velocity_scale` (1) ± `velocity_scale_sigma`; the eval's ablation
//! shows what it changes (`docs/eval/report.md`).
//!
//! `R_ir`, `l_ir` place the radar in the IMU frame (from the base → sensor transforms). The
//! world frame is gravity-aligned (z up) with the IMU's initial yaw as its x axis. The radar
//! measurement is the velocity at the frame's mean chirp time; the covariance is the
//! estimator's. A frame whose points are too few (or too flat) for a velocity still
//! constrains it along each point's direction: its gated points update the filter one by one
//! ([`Ekf::update_point`], Doppler-only, as tightly coupled radar-inertial odometry does), so
//! a walk that ends facing open space, or a standstill with three points in view, is not
//! left to the IMU alone. The point noise is the ego-velocity stage's model
//! (`dbe_radar::EgoParams`: a floor plus the cross-range term), and the gate rejects moving
//! objects against the filter's prediction, not against the other points.

use dbe_radar::EgoParams;
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use crate::sim::imu::{ImuSample, GRAVITY_MPS2};
use crate::sim::trajectory::Mount;

/// Error-state size: δp, δv, δθ, δb_a, δb_g (3 each), the radar's time offset δt_d and its
/// velocity scale δs.
const N: usize = 17;
/// Index of δt_d in the error state.
const TD: usize = 15;
/// Index of δs in the error state.
const SC: usize = 16;
type MatN = SMatrix<f64, N, N>;
type Mat3xN = SMatrix<f64, 3, N>;

/// Largest gyroscope turn-on bias taken for one at initialisation, rad/s (3°/s).
pub const MAX_GYRO_BIAS: f64 = 0.05;

/// The 0.999 quantile of χ² with 3 degrees of freedom: the default innovation gate.
pub const CHI2_3DOF_999: f64 = 16.266;

/// The 0.999 quantile of χ² with 1 degree of freedom: the default gate of a point update.
pub const CHI2_1DOF_999: f64 = 10.828;

/// Parameters of the filter. The IMU densities are the usual four (Kalibr / `imu_utils`
/// units); the defaults are those of the simulated IMU ([`crate::sim::imu::ImuSpec`]) inflated
/// by 2, so they hold for a real MEMS IMU of that class too.
#[derive(Clone, Debug, PartialEq)]
pub struct EkfParams {
    /// Accelerometer white-noise density, m/s²/√Hz.
    pub accel_noise: f64,
    /// Gyroscope white-noise density, rad/s/√Hz.
    pub gyro_noise: f64,
    /// Accelerometer bias random walk, m/s³/√Hz.
    pub accel_bias_walk: f64,
    /// Gyroscope bias random walk, rad/s²/√Hz.
    pub gyro_bias_walk: f64,
    /// Length of the standstill at the start used to initialise, s.
    pub init_standstill_s: f64,
    /// Initial standard deviation of the accelerometer bias, m/s².
    pub init_accel_bias_sigma: f64,
    /// Initial standard deviation of the gyroscope bias (after the standstill mean), rad/s.
    pub init_gyro_bias_sigma: f64,
    /// Initial standard deviation of roll and pitch, rad.
    pub init_tilt_sigma: f64,
    /// Largest radar speed, m/s, that the standstill start takes for rest (an IMU cannot tell
    /// rest from a steady walk; a faster radar velocity in the window starts the filter in
    /// motion instead).
    pub rest_speed_mps: f64,
    /// After this long with every radar update gated (none applied, nor any point update), a
    /// gated update is tried again with the velocity's covariance widened by
    /// `init_moving_velocity_sigma` per axis ([`Ekf::widen_velocity`]), s.
    pub widen_after_s: f64,
    /// Moving start: the IMU span around the first radar velocity whose mean specific force
    /// gives roll and pitch, s.
    pub init_moving_window_s: f64,
    /// Moving start: standard deviation of roll and pitch (the rig's own acceleration tilts
    /// the mean specific force), rad.
    pub init_moving_tilt_sigma: f64,
    /// Moving start: the least standard deviation per axis of the start velocity, m/s.
    pub init_moving_velocity_sigma: f64,
    /// Moving start: standard deviation of the gyroscope bias (no standstill mean), rad/s.
    pub init_moving_gyro_bias_sigma: f64,
    /// Innovation gate: updates whose squared Mahalanobis distance exceeds it are rejected.
    pub chi2_gate: f64,
    /// Standard deviation added to each axis of the radar velocity's covariance, m/s.
    pub velocity_sigma_floor: f64,
    /// Update with single points on frames without a velocity estimate ([`Ekf::update_point`]).
    pub point_updates: bool,
    /// Radial-velocity noise floor of one point, m/s.
    pub point_sigma_mps: f64,
    /// Cross-range position uncertainty of one point, m (its direction noise is this over the
    /// range).
    pub point_cross_range_m: f64,
    /// Gate of a point update (squared Mahalanobis distance, 1 degree of freedom).
    pub point_chi2_gate: f64,
    /// The radar's time offset at the start, s: a radar measurement stamped `t` was taken at
    /// `t + time_offset_s` on the IMU's clock.
    pub time_offset_s: f64,
    /// Standard deviation of that start value, s: the filter estimates the offset from the
    /// velocity's rate of change (0: it is taken as exact). The default, 50 ms, covers a
    /// frame-start stamp taken for a frame-end one, or a host's arrival stamp.
    pub time_offset_sigma: f64,
    /// Update the gyro bias with the mean rate between two radar standstills when the IMU
    /// is at rest in between ([`Ekf::update_zero_rate`]).
    pub zero_rate_updates: bool,
    /// Standard deviation added to each axis of a zero-rate measurement, rad/s: what the rig
    /// may still turn, on average over a frame interval, while the radar reads a standstill
    /// and the IMU rest.
    pub zero_rate_sigma: f64,
    /// The radar's velocity scale at the start: its velocities read this many times the true
    /// one.
    pub velocity_scale: f64,
    /// Standard deviation of that start value: the filter estimates the scale from the IMU's
    /// velocity changes (0: it is taken as exact).
    pub velocity_scale_sigma: f64,
    /// Random walk of that scale, 1/√s: how fast it may drift as the scene changes.
    pub velocity_scale_walk: f64,
}

impl Default for EkfParams {
    fn default() -> Self {
        Self {
            accel_noise: 4.0e-3,
            gyro_noise: 3.4e-4,
            accel_bias_walk: 6.0e-4,
            gyro_bias_walk: 4.0e-5,
            init_standstill_s: 1.0,
            init_accel_bias_sigma: 0.05,
            init_gyro_bias_sigma: 2.0e-3,
            init_tilt_sigma: 1.0_f64.to_radians(),
            rest_speed_mps: 0.1,
            widen_after_s: 1.0,
            init_moving_window_s: 0.5,
            init_moving_tilt_sigma: 5.0_f64.to_radians(),
            init_moving_velocity_sigma: 0.5,
            init_moving_gyro_bias_sigma: 0.003,
            chi2_gate: CHI2_3DOF_999,
            velocity_sigma_floor: 0.0,
            point_updates: true,
            point_sigma_mps: f64::from(EgoParams::DEFAULT.sigma_floor_mps),
            point_cross_range_m: f64::from(EgoParams::DEFAULT.cross_range_sigma_m),
            point_chi2_gate: CHI2_1DOF_999,
            time_offset_s: 0.0,
            time_offset_sigma: 0.05,
            zero_rate_updates: true,
            zero_rate_sigma: 1.0e-3,
            velocity_scale: 1.0,
            velocity_scale_sigma: 0.03,
            velocity_scale_walk: 0.0,
        }
    }
}

/// The range an [`EkfParams`] field must lie in ([`EkfParams::validate`]).
#[derive(Clone, Copy)]
enum Range {
    /// Finite, above 0.
    Positive,
    /// Above 0, `+∞` allowed (a gate: `+∞` is none).
    Gate,
    /// Finite, at least 0 (0: none or exact).
    NonNegative,
    /// At least 0, `+∞` allowed (never).
    NonNegativeOrNever,
    /// Finite.
    Finite,
}

impl Range {
    fn admits(self, v: f64) -> bool {
        match self {
            Self::Positive => v.is_finite() && v > 0.0,
            Self::Gate => v > 0.0,
            Self::NonNegative => v.is_finite() && v >= 0.0,
            Self::NonNegativeOrNever => v >= 0.0,
            Self::Finite => v.is_finite(),
        }
    }

    fn expected(self) -> &'static str {
        match self {
            Self::Positive => "a finite value above 0",
            Self::Gate => "a value above 0 (+inf: none)",
            Self::NonNegative => "a finite value of at least 0",
            Self::NonNegativeOrNever => "a value of at least 0 (+inf: never)",
            Self::Finite => "a finite value",
        }
    }
}

impl EkfParams {
    /// Check every parameter. Noise densities, windows, the point noise floor and the
    /// velocity scale: finite and above zero. Random walks, start deviations and floors:
    /// finite and not below zero (0 where it means "none" or "exact"). The gates: above zero,
    /// `+∞` allowed (no gate); the rest speed and the widening delay: not below zero, `+∞`
    /// allowed (never take the radar's motion for motion; never widen). The time offset:
    /// finite. The first parameter out of its range is named in [`EkfError::Param`].
    /// [`Ekf::initialise`] and [`Ekf::initialise_moving`] call it, so a filter never runs on
    /// parameters that would give it an infinite start velocity (`velocity_scale` 0), an
    /// empty initialisation window or a NaN covariance.
    pub fn validate(&self) -> Result<(), EkfError> {
        use Range::*;
        let checks = [
            ("accel_noise", self.accel_noise, Positive),
            ("gyro_noise", self.gyro_noise, Positive),
            ("init_standstill_s", self.init_standstill_s, Positive),
            ("init_moving_window_s", self.init_moving_window_s, Positive),
            ("point_sigma_mps", self.point_sigma_mps, Positive),
            ("velocity_scale", self.velocity_scale, Positive),
            ("chi2_gate", self.chi2_gate, Gate),
            ("point_chi2_gate", self.point_chi2_gate, Gate),
            ("rest_speed_mps", self.rest_speed_mps, NonNegativeOrNever),
            ("widen_after_s", self.widen_after_s, NonNegativeOrNever),
            ("accel_bias_walk", self.accel_bias_walk, NonNegative),
            ("gyro_bias_walk", self.gyro_bias_walk, NonNegative),
            (
                "init_accel_bias_sigma",
                self.init_accel_bias_sigma,
                NonNegative,
            ),
            (
                "init_gyro_bias_sigma",
                self.init_gyro_bias_sigma,
                NonNegative,
            ),
            ("init_tilt_sigma", self.init_tilt_sigma, NonNegative),
            (
                "init_moving_tilt_sigma",
                self.init_moving_tilt_sigma,
                NonNegative,
            ),
            (
                "init_moving_velocity_sigma",
                self.init_moving_velocity_sigma,
                NonNegative,
            ),
            (
                "init_moving_gyro_bias_sigma",
                self.init_moving_gyro_bias_sigma,
                NonNegative,
            ),
            (
                "velocity_sigma_floor",
                self.velocity_sigma_floor,
                NonNegative,
            ),
            ("point_cross_range_m", self.point_cross_range_m, NonNegative),
            ("time_offset_sigma", self.time_offset_sigma, NonNegative),
            ("zero_rate_sigma", self.zero_rate_sigma, NonNegative),
            (
                "velocity_scale_sigma",
                self.velocity_scale_sigma,
                NonNegative,
            ),
            ("velocity_scale_walk", self.velocity_scale_walk, NonNegative),
            ("time_offset_s", self.time_offset_s, Finite),
        ];
        match checks.into_iter().find(|&(_, v, range)| !range.admits(v)) {
            Some((name, value, range)) => Err(EkfError::Param {
                name,
                value,
                expected: range.expected(),
            }),
            None => Ok(()),
        }
    }
}

/// Why the filter could not run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EkfError {
    /// A parameter is out of its range ([`EkfParams::validate`]).
    #[error("EKF parameter {name} = {value}: expected {expected}")]
    Param {
        /// The field of [`EkfParams`].
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// Not enough IMU data for the initial standstill.
    #[error("the IMU data span {span_s:.3} s; initialisation needs a standstill of {needed_s} s at the start")]
    TooShort {
        /// Time covered by the samples, s.
        span_s: f64,
        /// `init_standstill_s`.
        needed_s: f64,
    },
    /// The rig is not at rest during the initialisation window.
    #[error("the rig moves during the first {window_s} s (mean specific force {force:.3} m/s², gyro spread {gyro_spread:.4} rad/s, mean rate {mean_rate:.4} rad/s); initialisation needs it at rest")]
    NotAtRest {
        /// Largest |mean gyro| axis, rad/s.
        mean_rate: f64,
        /// The window, s.
        window_s: f64,
        /// |mean specific force|, m/s² (≈ 9.81 at rest).
        force: f64,
        /// Largest deviation of a gyro sample from the mean, rad/s.
        gyro_spread: f64,
    },
    /// The rig moves at the start and no radar velocity lies within the IMU data to start from.
    #[error("the rig is not at rest during the first {window_s} s (IMU or radar) and no frame inside the IMU data has an ego-velocity to start from in motion")]
    NoStartVelocity {
        /// `init_standstill_s`.
        window_s: f64,
    },
    /// IMU timestamps go backwards or repeat.
    #[error("IMU sample {index} at {time_s} s does not follow the previous one")]
    Time {
        /// The sample.
        index: usize,
        /// Its time, s.
        time_s: f64,
    },
}

/// One radar velocity measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadarVelocity {
    /// Time the velocity refers to (mean chirp time of the frame), s.
    pub time_s: f64,
    /// Radar velocity in the radar frame, m/s.
    pub velocity: Vector3<f64>,
    /// Its covariance, (m/s)².
    pub covariance: Matrix3<f64>,
}

/// One static point's Doppler: a radial-velocity measurement along one direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadialVelocity {
    /// Unit direction of the point, radar frame.
    pub direction: Vector3<f64>,
    /// Its range, m.
    pub range_m: f64,
    /// Its radial velocity, m/s (positive receding).
    pub velocity_mps: f64,
}

/// The filter's estimate at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Time, s.
    pub time_s: f64,
    /// IMU position in the world, m.
    pub position: Vector3<f64>,
    /// IMU velocity in the world, m/s.
    pub velocity: Vector3<f64>,
    /// IMU → world.
    pub attitude: UnitQuaternion<f64>,
    /// Accelerometer bias, m/s².
    pub accel_bias: Vector3<f64>,
    /// Gyroscope bias, rad/s.
    pub gyro_bias: Vector3<f64>,
    /// The radar's time offset t_d, s: a radar measurement stamped `t` was taken at `t + t_d`
    /// on the IMU's clock.
    pub time_offset_s: f64,
    /// The radar's velocity scale s: its velocities read s times the true one.
    pub velocity_scale: f64,
}

/// What an update did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateOutcome {
    /// Applied.
    Applied,
    /// Rejected by the χ² gate.
    Gated,
}

/// How the filter started.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "mode")]
pub enum Start {
    /// At rest: roll, pitch and gyro bias from the standstill at the start of the IMU data
    /// ([`Ekf::initialise`]).
    Standstill {
        /// End of the standstill window, s.
        time_s: f64,
    },
    /// In motion, at the first radar velocity ([`Ekf::initialise_moving`]).
    Moving {
        /// That velocity's time, s.
        time_s: f64,
    },
}

/// IMU timestamps must increase.
fn check_times(imu: &[ImuSample]) -> Result<(), EkfError> {
    for (i, w) in imu.windows(2).enumerate() {
        if !(w[1].time_s > w[0].time_s) {
            return Err(EkfError::Time {
                index: i + 1,
                time_s: w[1].time_s,
            });
        }
    }
    Ok(())
}

/// Mean specific force and mean angular rate of `window` (not empty).
fn means(window: &[ImuSample]) -> (Vector3<f64>, Vector3<f64>) {
    let n = window.len() as f64;
    (
        window.iter().map(|s| s.accel).sum::<Vector3<f64>>() / n,
        window.iter().map(|s| s.gyro).sum::<Vector3<f64>>() / n,
    )
}

/// The IMU's view of a window of samples (not empty): its means and how far it is from rest.
struct Rest {
    /// Mean specific force, m/s².
    f_mean: Vector3<f64>,
    /// Mean angular rate, rad/s.
    w_mean: Vector3<f64>,
    /// Largest deviation of a gyro sample from the mean, rad/s.
    gyro_spread: f64,
}

impl Rest {
    fn of(window: &[ImuSample]) -> Self {
        let (f_mean, w_mean) = means(window);
        let gyro_spread = window
            .iter()
            .map(|s| (s.gyro - w_mean).amax())
            .fold(0.0, f64::max);
        Self {
            f_mean,
            w_mean,
            gyro_spread,
        }
    }

    /// At rest |f| = g; a walking or turning rig shows in the force, in the gyro spread, or
    /// (turning steadily) in a mean rate no MEMS bias reaches ([`MAX_GYRO_BIAS`]).
    fn at_rest(&self) -> bool {
        (self.f_mean.norm() - GRAVITY_MPS2).abs() <= 0.5
            && self.gyro_spread <= 0.1
            && self.w_mean.amax() <= MAX_GYRO_BIAS
    }
}

/// The attitude (yaw 0) that maps the measured "up", the mean specific force, onto world z.
fn level(f_mean: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(f_mean, &Vector3::z()).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    })
}

/// The radar in the IMU frame: rotation radar → IMU and the radar's position.
fn radar_in_imu(radar: &Mount, imu_mount: &Mount) -> (Matrix3<f64>, Vector3<f64>) {
    let r_bi = imu_mount.rotation().into_inner();
    (
        r_bi.transpose() * radar.rotation().into_inner(),
        r_bi.transpose() * (radar.translation() - imu_mount.translation()),
    )
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The error-state EKF (module docs).
#[derive(Clone, Debug)]
pub struct Ekf {
    params: EkfParams,
    state: State,
    cov: MatN,
    /// The last IMU sample (the propagation's left end).
    last: ImuSample,
    /// Radar in the IMU frame: rotation radar → IMU and position.
    r_ir: Matrix3<f64>,
    l_ir: Vector3<f64>,
    gravity: Vector3<f64>,
}

impl Ekf {
    /// Initialise from the standstill at the start of `imu`; `radar` and `imu_mount` are the
    /// sensors' mounts on the base. Returns the filter at the end of the window and the index
    /// of the first sample after it.
    pub fn initialise(
        params: EkfParams,
        imu: &[ImuSample],
        radar: &Mount,
        imu_mount: &Mount,
    ) -> Result<(Self, usize), EkfError> {
        params.validate()?;
        check_times(imu)?;
        let span_s = match (imu.first(), imu.last()) {
            (Some(a), Some(b)) => b.time_s - a.time_s,
            _ => 0.0,
        };
        if span_s < params.init_standstill_s || imu.len() < 2 {
            return Err(EkfError::TooShort {
                span_s,
                needed_s: params.init_standstill_s,
            });
        }
        let t0 = imu[0].time_s;
        let end = imu
            .iter()
            .position(|s| s.time_s - t0 > params.init_standstill_s)
            .unwrap_or(imu.len());
        let window = &imu[..end];
        let rest = Rest::of(window);
        let (f_mean, w_mean, force) = (rest.f_mean, rest.w_mean, rest.f_mean.norm());
        if !rest.at_rest() {
            return Err(EkfError::NotAtRest {
                mean_rate: w_mean.amax(),
                window_s: params.init_standstill_s,
                force,
                gyro_spread: rest.gyro_spread,
            });
        }
        // The bias along "up" is the excess of |f| over g.
        let accel_bias = f_mean * ((force - GRAVITY_MPS2) / force);
        let mut cov = MatN::zeros();
        for i in 0..6 {
            cov[(i, i)] = 1e-8;
        }
        for i in 12..15 {
            cov[(i, i)] = params.init_gyro_bias_sigma.powi(2);
        }
        let tilt = params.init_tilt_sigma;
        let last = window[window.len() - 1];
        let state = State {
            time_s: last.time_s,
            position: Vector3::zeros(),
            velocity: Vector3::zeros(),
            attitude: level(&f_mean),
            accel_bias,
            gyro_bias: w_mean,
            time_offset_s: params.time_offset_s,
            velocity_scale: params.velocity_scale,
        };
        Ok((
            Self::start(params, state, cov, tilt, last, radar, imu_mount),
            end,
        ))
    }

    /// Initialise in motion at the radar velocity `z` (module docs, *moving start*): for a
    /// sequence whose IMU data do not start at rest. Returns the filter at `z.time_s` and the
    /// index of the first IMU sample after it.
    pub fn initialise_moving(
        params: EkfParams,
        imu: &[ImuSample],
        z: &RadarVelocity,
        radar: &Mount,
        imu_mount: &Mount,
    ) -> Result<(Self, usize), EkfError> {
        params.validate()?;
        check_times(imu)?;
        let half = 0.5 * params.init_moving_window_s;
        let window: Vec<ImuSample> = imu
            .iter()
            .filter(|s| (s.time_s - z.time_s).abs() <= half)
            .copied()
            .collect();
        let next = imu.partition_point(|s| s.time_s <= z.time_s);
        if window.len() < 2 || next == 0 || next >= imu.len() {
            return Err(EkfError::NoStartVelocity {
                window_s: params.init_standstill_s,
            });
        }
        let (f_mean, _) = means(&window);
        // The sample at z's time, interpolated: the propagation's left end.
        let (a, b) = (imu[next - 1], imu[next]);
        let f = (z.time_s - a.time_s) / (b.time_s - a.time_s);
        let last = ImuSample {
            time_s: z.time_s,
            accel: a.accel + f * (b.accel - a.accel),
            gyro: a.gyro + f * (b.gyro - a.gyro),
        };
        let attitude = level(&f_mean);
        let r = attitude.to_rotation_matrix().into_inner();
        let (r_ir, l_ir) = radar_in_imu(radar, imu_mount);
        // z = s·R_irᵀ·(Rᵀ·v + ω × l_ir) with the gyro bias taken as 0.
        let velocity = r * (r_ir * z.velocity / params.velocity_scale - last.gyro.cross(&l_ir));
        let tilt = params.init_moving_tilt_sigma;
        let floor = params
            .velocity_sigma_floor
            .hypot(params.init_moving_velocity_sigma);
        let mut c_v = r * r_ir * z.covariance * (r * r_ir).transpose();
        for i in 0..3 {
            // A start velocity no less uncertain than the floor, and tilted with the attitude.
            c_v[(i, i)] = c_v[(i, i)].max(floor * floor) + (velocity.norm() * tilt).powi(2);
        }
        let mut cov = MatN::zeros();
        for i in 0..3 {
            cov[(i, i)] = 1e-8;
        }
        cov.fixed_view_mut::<3, 3>(3, 3).copy_from(&c_v);
        for i in 12..15 {
            cov[(i, i)] = params.init_moving_gyro_bias_sigma.powi(2);
        }
        let state = State {
            time_s: z.time_s,
            position: Vector3::zeros(),
            velocity,
            attitude,
            accel_bias: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            time_offset_s: params.time_offset_s,
            velocity_scale: params.velocity_scale,
        };
        Ok((
            Self::start(params, state, cov, tilt, last, radar, imu_mount),
            next,
        ))
    }

    /// The filter at `state`; `cov` holds the position, velocity and gyro-bias blocks, and the
    /// tilt and accelerometer-bias variances are set here from `tilt` and the parameters.
    fn start(
        params: EkfParams,
        state: State,
        mut cov: MatN,
        tilt: f64,
        last: ImuSample,
        radar: &Mount,
        imu_mount: &Mount,
    ) -> Self {
        cov[(6, 6)] = tilt * tilt;
        cov[(7, 7)] = tilt * tilt;
        cov[(8, 8)] = 1e-12; // yaw is the world frame's definition
        cov[(TD, TD)] = params.time_offset_sigma.powi(2);
        cov[(SC, SC)] = params.velocity_scale_sigma.powi(2);
        for i in 9..12 {
            cov[(i, i)] = params.init_accel_bias_sigma.powi(2);
        }
        let (r_ir, l_ir) = radar_in_imu(radar, imu_mount);
        Self {
            params,
            state,
            cov,
            last,
            r_ir,
            l_ir,
            gravity: Vector3::new(0.0, 0.0, -GRAVITY_MPS2),
        }
    }

    /// The current estimate.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// When a radar measurement stamped `stamp_s` was taken, on the IMU's clock:
    /// `stamp_s + t_d` with the current time offset.
    pub fn measure_time(&self, stamp_s: f64) -> f64 {
        stamp_s + self.state.time_offset_s
    }

    /// The standard deviation of error-state entry `i`.
    fn sigma(&self, i: usize) -> f64 {
        self.cov[(i, i)].max(0.0).sqrt()
    }

    /// The time offset's standard deviation, s.
    pub fn time_offset_sigma(&self) -> f64 {
        self.sigma(TD)
    }

    /// The velocity scale's standard deviation.
    pub fn velocity_scale_sigma(&self) -> f64 {
        self.sigma(SC)
    }

    /// The error-state covariance (order δp, δv, δθ, δb_a, δb_g, δt_d, δs).
    pub fn covariance(&self) -> &MatN {
        &self.cov
    }

    /// Propagate with the next IMU sample (its time must be later than the last one's).
    pub fn propagate(&mut self, next: &ImuSample) {
        let dt = next.time_s - self.last.time_s;
        if dt > 0.0 {
            let mid = ImuSample {
                time_s: next.time_s,
                accel: 0.5 * (self.last.accel + next.accel),
                gyro: 0.5 * (self.last.gyro + next.gyro),
            };
            self.step(&mid, dt);
        }
        self.last = *next;
    }

    /// Propagate to `time_s` (between the last sample and `next`), interpolating the IMU; the
    /// last sample becomes the interpolated one.
    pub fn propagate_to(&mut self, time_s: f64, next: &ImuSample) {
        let span = next.time_s - self.last.time_s;
        if !(time_s > self.last.time_s) || !(span > 0.0) {
            return;
        }
        let f = ((time_s - self.last.time_s) / span).min(1.0);
        let at = ImuSample {
            time_s,
            accel: self.last.accel + f * (next.accel - self.last.accel),
            gyro: self.last.gyro + f * (next.gyro - self.last.gyro),
        };
        self.propagate(&at);
    }

    fn step(&mut self, m: &ImuSample, dt: f64) {
        let s = &mut self.state;
        let f = m.accel - s.accel_bias;
        let w = m.gyro - s.gyro_bias;
        // The interval's mean force rotated by its mid attitude: the start attitude lags the
        // turn by half the interval, a first-order error (an ideal 200 Hz IMU on the simulated
        // hallways walk: velocity 1.9 mm/s off after 20 s, 10 µm/s with the mid attitude).
        let r = (s.attitude * UnitQuaternion::from_scaled_axis(0.5 * w * dt))
            .to_rotation_matrix()
            .into_inner();
        let a = r * f + self.gravity;
        s.position += s.velocity * dt + 0.5 * a * dt * dt;
        s.velocity += a * dt;
        let dq = UnitQuaternion::from_scaled_axis(w * dt);
        s.attitude *= dq;
        s.time_s = m.time_s;

        let mut fm = MatN::identity();
        let i3 = Matrix3::identity();
        fm.fixed_view_mut::<3, 3>(0, 3).copy_from(&(i3 * dt));
        fm.fixed_view_mut::<3, 3>(3, 6)
            .copy_from(&(-r * skew(&f) * dt));
        fm.fixed_view_mut::<3, 3>(3, 9).copy_from(&(-r * dt));
        fm.fixed_view_mut::<3, 3>(6, 6)
            .copy_from(&dq.to_rotation_matrix().into_inner().transpose());
        fm.fixed_view_mut::<3, 3>(6, 12).copy_from(&(-i3 * dt));
        let p = &self.params;
        let mut q = MatN::zeros();
        for i in 0..3 {
            q[(3 + i, 3 + i)] = p.accel_noise.powi(2) * dt;
            q[(6 + i, 6 + i)] = p.gyro_noise.powi(2) * dt;
            q[(9 + i, 9 + i)] = p.accel_bias_walk.powi(2) * dt;
            q[(12 + i, 12 + i)] = p.gyro_bias_walk.powi(2) * dt;
        }
        q[(SC, SC)] = p.velocity_scale_walk.powi(2) * dt;
        self.cov = fm * self.cov * fm.transpose() + q;
    }

    /// The radar velocity the current state predicts for a measurement stamped `stamp_s`, and
    /// its Jacobian. The measurement was taken at `stamp_s + t_d`; where the filter stands
    /// elsewhere (it cannot go back), the prediction moves along the velocity's rate of change
    /// `ḣ = R_irᵀ·(Rᵀ·a − ω × Rᵀ·v)` (the angular acceleration's part of the lever arm left
    /// out), which is also its derivative by `t_d`.
    fn predict_radar(&self, stamp_s: f64) -> (Vector3<f64>, Mat3xN) {
        let s = &self.state;
        let rt = s.attitude.to_rotation_matrix().into_inner().transpose();
        let w = self.last.gyro - s.gyro_bias;
        let v_body = rt * s.velocity;
        let rit = self.r_ir.transpose();
        // Rᵀ·a: the specific force plus gravity in the IMU frame.
        let a_body = self.last.accel - s.accel_bias + rt * self.gravity;
        let rate = rit * (a_body - w.cross(&v_body));
        let lag = stamp_s + s.time_offset_s - s.time_s;
        let lag = if lag.is_finite() { lag } else { 0.0 };
        let h = rit * (v_body + w.cross(&self.l_ir)) + rate * lag;
        let mut jac = Mat3xN::zeros();
        jac.fixed_view_mut::<3, 1>(0, TD).copy_from(&rate);
        jac.fixed_view_mut::<3, 3>(0, 3).copy_from(&(rit * rt));
        jac.fixed_view_mut::<3, 3>(0, 6)
            .copy_from(&(rit * skew(&v_body)));
        jac.fixed_view_mut::<3, 3>(0, 12)
            .copy_from(&(rit * skew(&self.l_ir)));
        // What the radar reads: s times the true velocity.
        let scale = s.velocity_scale;
        jac *= scale;
        jac.fixed_view_mut::<3, 1>(0, SC).copy_from(&h);
        (h * scale, jac)
    }

    /// Correct with a radar velocity (call [`Self::propagate_to`] its time plus the time
    /// offset first, [`Self::measure_time`]).
    pub fn update(&mut self, z: &RadarVelocity) -> UpdateOutcome {
        let (h, jac) = self.predict_radar(z.time_s);
        let floor = self.params.velocity_sigma_floor.powi(2);
        let r = z.covariance + Matrix3::identity() * floor;
        self.correct(z.velocity - h, jac, r, self.params.chi2_gate)
    }

    /// Raise the velocity's variances by `sigma²` per axis, its correlations kept: the
    /// filter's admission that its velocity may be that far off. For a filter whose radar
    /// updates have all been gated for `widen_after_s`: its velocity went wrong (IMU errors
    /// beyond its parameters, a wrong start), and its gate would reject every right update
    /// after.
    pub fn widen_velocity(&mut self, sigma: f64) {
        for i in 3..6 {
            self.cov[(i, i)] += sigma * sigma;
        }
    }

    /// Correct the gyro bias with the mean rate of `window`, the IMU samples between two
    /// radar standstills (module docs, *zero rate*): `ω̄ = b_g + n`, noise `σ_g²/T` (the white
    /// noise averaged over the window's span `T`) plus `zero_rate_sigma²` per axis, gated at
    /// `chi2_gate`. `None`, and nothing changed, when the window does not show the IMU at rest
    /// (or has fewer than two samples): a rig can turn about its radar with the scene's
    /// Doppler at zero.
    pub fn update_zero_rate(&mut self, window: &[ImuSample]) -> Option<UpdateOutcome> {
        let (Some(first), Some(last)) = (window.first(), window.last()) else {
            return None;
        };
        let span_s = last.time_s - first.time_s;
        let rest = Rest::of(window);
        if window.len() < 2 || !(span_s > 0.0) || !rest.at_rest() {
            return None;
        }
        let p = &self.params;
        let var = p.gyro_noise.powi(2) / span_s + p.zero_rate_sigma.powi(2);
        let mut jac = Mat3xN::zeros();
        jac.fixed_view_mut::<3, 3>(0, 12)
            .copy_from(&Matrix3::identity());
        Some(self.correct(
            rest.w_mean - self.state.gyro_bias,
            jac,
            Matrix3::identity() * var,
            p.chi2_gate,
        ))
    }

    /// Correct with one static point's radial velocity, of a frame stamped `stamp_s` (call
    /// [`Self::propagate_to`] its measurement time first): `v_r = −uᵀ·v_radar`, noise
    /// `point_sigma² + (point_cross_range·|v_radar × u| / r)²` (module docs), gated at
    /// `point_chi2_gate`. A point that moves is rejected when the filter's prediction is
    /// certain enough to tell.
    pub fn update_point(&mut self, z: &RadialVelocity, stamp_s: f64) -> UpdateOutcome {
        let (h, jac) = self.predict_radar(stamp_s);
        let u = z.direction;
        let p = &self.params;
        let direction = p.point_cross_range_m * h.cross(&u).norm() / z.range_m;
        let r2 = p.point_sigma_mps.powi(2) + direction.powi(2);
        let innovation = z.velocity_mps + u.dot(&h);
        let jac = -(u.transpose() * jac);
        if !(innovation.is_finite() && r2 > 0.0 && r2.is_finite()) {
            return UpdateOutcome::Gated;
        }
        self.correct(
            SVector::<f64, 1>::new(innovation),
            jac,
            SMatrix::<f64, 1, 1>::new(r2),
            p.point_chi2_gate,
        )
    }

    /// The EKF correction with innovation `innovation`, Jacobian `jac` and noise `r`, gated at
    /// `gate` (Joseph form; the error state folded into the nominal one).
    fn correct<const D: usize>(
        &mut self,
        innovation: SVector<f64, D>,
        jac: SMatrix<f64, D, N>,
        r: SMatrix<f64, D, D>,
        gate: f64,
    ) -> UpdateOutcome {
        let s = jac * self.cov * jac.transpose() + r;
        let Some(s_inv) = s.try_inverse() else {
            return UpdateOutcome::Gated;
        };
        let d2 = (innovation.transpose() * s_inv * innovation)[(0, 0)];
        if !(d2 <= gate) {
            return UpdateOutcome::Gated;
        }
        let k = self.cov * jac.transpose() * s_inv;
        let dx: SVector<f64, N> = k * innovation;
        let ikh = MatN::identity() - k * jac;
        self.cov = ikh * self.cov * ikh.transpose() + k * r * k.transpose();
        self.cov = 0.5 * (self.cov + self.cov.transpose());
        let st = &mut self.state;
        st.position += dx.fixed_rows::<3>(0);
        st.velocity += dx.fixed_rows::<3>(3);
        st.attitude *= UnitQuaternion::from_scaled_axis(dx.fixed_rows::<3>(6).into_owned());
        st.accel_bias += dx.fixed_rows::<3>(9);
        st.gyro_bias += dx.fixed_rows::<3>(12);
        st.time_offset_s += dx[TD];
        st.velocity_scale += dx[SC];
        UpdateOutcome::Applied
    }
}
