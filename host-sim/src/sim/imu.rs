//! A simulated strapdown IMU on the rig: specific force and angular rate in the IMU frame,
//! with white noise and random-walk biases.
//!
//! Sample `j` (time `t_j = j / rate_hz`) is the mean of the IMU frame's true specific force and
//! angular rate over the sample's interval centred on its time, `[t_j − Δ/2, t_j + Δ/2]`
//! (`Δ = 1 / rate_hz`), as an IMU's averaging output filter gives it:
//!
//! ```text
//! accelerometer  f = mean of R_imuᵀ·(a_imu − g) + b_a + n_a     g = (0, 0, −9.80665) m/s² (world z up)
//! gyroscope      ω = mean of ω_imu + b_g + n_g                  ω_imu in the IMU frame
//! ```
//!
//! The mean, not the value at `t_j`: a spline trajectory's acceleration jumps at its waypoints,
//! which lie on the sample grid, and a sample taken there held the later segment's value, so
//! every change of acceleration reached the samples half a sample early. Integrated, the IMU
//! then ran `Δ/2` ahead of the truth (trapezoidal integration of the true accelerations at the
//! sample times: 1.75 mm/s of velocity error one second into the hallways walk at 200 Hz,
//! 0.33 mm/s at 1000 Hz), and the odometry filter read it as a radar time offset of
//! `−Δ/2` (−2.5 ms at 200 Hz, −4.9 ms at 100 Hz, −0.5 ms at 1000 Hz with an ideal IMU and
//! exact velocities). A step at the centre of the interval gives the mean of its two sides,
//! which the filter's trapezoidal propagation integrates without that lead.
//!
//! `n_a`, `n_g` are white with the continuous densities `accel_noise` (m/s²/√Hz) and
//! `gyro_noise` (rad/s/√Hz), so one sample has the standard deviation `density·√rate`; the
//! biases start from a draw of `accel_bias_std` / `gyro_bias_std` and walk with the densities
//! `accel_bias_walk` (m/s³/√Hz) and `gyro_bias_walk` (rad/s²/√Hz): a step of
//! `density / √rate` per sample. These are the four numbers of a Kalibr / `imu_utils` IMU
//! description, so a real IMU's datasheet values can be used as they are. Every draw follows
//! from the scene seed.

use nalgebra::Vector3;
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::render::mix;
use super::trajectory::{Mount, Trajectory};

/// Standard gravity, m/s².
pub const GRAVITY_MPS2: f64 = 9.80665;

/// Stream of the IMU noise generator.
const IMU_STREAM: u64 = 0x494D_5531;

/// The IMU's rate and noise model (module docs). Defaults: 200 Hz and a good MEMS IMU
/// (accelerometer 2·10⁻³ m/s²/√Hz, gyroscope 1.7·10⁻⁴ rad/s/√Hz ≈ 0.6°/√h; bias walks
/// 3·10⁻⁴ m/s³/√Hz and 2·10⁻⁵ rad/s²/√Hz; turn-on biases 0.03 m/s² and 0.003 rad/s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    /// Sample rate, Hz (at least 100).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Accelerometer white-noise density, m/s²/√Hz.
    #[serde(default = "default_accel_noise")]
    pub accel_noise: f64,
    /// Gyroscope white-noise density, rad/s/√Hz.
    #[serde(default = "default_gyro_noise")]
    pub gyro_noise: f64,
    /// Accelerometer bias random-walk density, m/s³/√Hz.
    #[serde(default = "default_accel_walk")]
    pub accel_bias_walk: f64,
    /// Gyroscope bias random-walk density, rad/s²/√Hz.
    #[serde(default = "default_gyro_walk")]
    pub gyro_bias_walk: f64,
    /// Standard deviation of the turn-on accelerometer bias per axis, m/s².
    #[serde(default = "default_accel_bias")]
    pub accel_bias_std: f64,
    /// Standard deviation of the turn-on gyroscope bias per axis, rad/s.
    #[serde(default = "default_gyro_bias")]
    pub gyro_bias_std: f64,
}

fn default_rate() -> f64 {
    200.0
}
fn default_accel_noise() -> f64 {
    2.0e-3
}
fn default_gyro_noise() -> f64 {
    1.7e-4
}
fn default_accel_walk() -> f64 {
    3.0e-4
}
fn default_gyro_walk() -> f64 {
    2.0e-5
}
fn default_accel_bias() -> f64 {
    0.03
}
fn default_gyro_bias() -> f64 {
    0.003
}

impl Default for ImuSpec {
    fn default() -> Self {
        Self {
            rate_hz: default_rate(),
            accel_noise: default_accel_noise(),
            gyro_noise: default_gyro_noise(),
            accel_bias_walk: default_accel_walk(),
            gyro_bias_walk: default_gyro_walk(),
            accel_bias_std: default_accel_bias(),
            gyro_bias_std: default_gyro_bias(),
        }
    }
}

impl ImuSpec {
    /// A noise-free, bias-free IMU at `rate_hz` (for tests of what the motion alone gives).
    pub fn ideal(rate_hz: f64) -> Self {
        Self {
            rate_hz,
            accel_noise: 0.0,
            gyro_noise: 0.0,
            accel_bias_walk: 0.0,
            gyro_bias_walk: 0.0,
            accel_bias_std: 0.0,
            gyro_bias_std: 0.0,
        }
    }

    /// Check the values: rate in [100, 10 000] Hz, noise values finite and ≥ 0.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.rate_hz >= 100.0 && self.rate_hz <= 10_000.0) {
            return Err(format!(
                "imu.rate_hz must be in [100, 10000] Hz, got {}",
                self.rate_hz
            ));
        }
        for (name, v) in [
            ("accel_noise", self.accel_noise),
            ("gyro_noise", self.gyro_noise),
            ("accel_bias_walk", self.accel_bias_walk),
            ("gyro_bias_walk", self.gyro_bias_walk),
            ("accel_bias_std", self.accel_bias_std),
            ("gyro_bias_std", self.gyro_bias_std),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("imu.{name} must be finite and ≥ 0, got {v}"));
            }
        }
        Ok(())
    }
}

/// One IMU sample, IMU frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// Time, s.
    pub time_s: f64,
    /// Specific force, m/s².
    pub accel: Vector3<f64>,
    /// Angular rate, rad/s.
    pub gyro: Vector3<f64>,
}

/// Sub-intervals of the mean over a sample's interval (midpoint rule). Even, so that a step
/// at the sample's time, where the waypoints lie, falls between two of them and gives the mean
/// of its two sides exactly.
const MEAN_STEPS: usize = 8;

/// The true specific force and angular rate of the IMU at `mount`, IMU frame, averaged over
/// `[time_s − span_s/2, time_s + span_s/2]` (module docs).
fn interval_mean(
    trajectory: &Trajectory,
    mount: &Mount,
    time_s: f64,
    span_s: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let gravity = Vector3::new(0.0, 0.0, -GRAVITY_MPS2);
    let (mut force, mut rate) = (Vector3::zeros(), Vector3::zeros());
    for i in 0..MEAN_STEPS {
        let t = time_s + span_s * ((i as f64 + 0.5) / MEAN_STEPS as f64 - 0.5);
        let imu = trajectory.pose(t).mounted(mount);
        force += imu.rotation.inverse() * (imu.acceleration - gravity);
        rate += imu.angular_velocity;
    }
    (force / MEAN_STEPS as f64, rate / MEAN_STEPS as f64)
}

/// The IMU samples of `trajectory` with the IMU at `mount`, from time 0 to `duration_s`
/// inclusive (module docs); `seed` draws the biases and the noise.
pub fn simulate_imu(
    spec: &ImuSpec,
    trajectory: &Trajectory,
    mount: &Mount,
    duration_s: f64,
    seed: u64,
) -> Vec<ImuSample> {
    let mut rng = StdRng::seed_from_u64(mix(seed, IMU_STREAM));
    let mut normal3 = |s: f64| {
        let v: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
        Vector3::from(v) * s
    };
    let mut bias_a = normal3(spec.accel_bias_std);
    let mut bias_g = normal3(spec.gyro_bias_std);
    let (sa, sg) = (
        spec.accel_noise * spec.rate_hz.sqrt(),
        spec.gyro_noise * spec.rate_hz.sqrt(),
    );
    let (wa, wg) = (
        spec.accel_bias_walk / spec.rate_hz.sqrt(),
        spec.gyro_bias_walk / spec.rate_hz.sqrt(),
    );
    let count = (duration_s * spec.rate_hz + 1e-9).floor().max(0.0) as usize + 1;
    let mut out = Vec::with_capacity(count);
    for j in 0..count {
        let time_s = j as f64 / spec.rate_hz;
        let (force, rate) = interval_mean(trajectory, mount, time_s, 1.0 / spec.rate_hz);
        out.push(ImuSample {
            time_s,
            accel: force + bias_a + normal3(sa),
            gyro: rate + bias_g + normal3(sg),
        });
        bias_a += normal3(wa);
        bias_g += normal3(wg);
    }
    out
}
