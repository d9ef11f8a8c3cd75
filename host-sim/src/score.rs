//! Matching points to simulated ground truth, and the accuracy of point clouds against it:
//! the one rule of the crate, used by `dbe demo`, the accuracy tests and `dbe eval`.
//!
//! - **When**: truth is placed at the frame's mean chirp start time ([`mid_frame_s`]), since
//!   every estimate of a chain averages over the frame's chirps. A target moving at 1.2 m/s
//!   moves 3 cm during a ColoRadar frame: a quarter of a range bin.
//! - **Which point**: a visible point target counts as detected when a point lies within
//!   [`MATCH_RADIUS_M`] of it; the estimate is the *strongest* such point (largest
//!   `intensity_db`, [`matched_point`]), as a user would pick it, not the nearest to the truth
//!   (which no user knows, and which would flatter a chain that scatters many points around a
//!   target). Angles as in spec §2: φ = asin(μ/√(1−ν²)), θ = asin(ν).
//! - **False point**: farther than [`MATCH_RADIUS_M`] from every visible object (targets and
//!   sampled surfaces, also at mid-frame).

use crate::cloud::PointRecord;
use crate::sensor::SensorConfig;
use crate::sim::truth::look;
use crate::sim::{FrameTruth, ObjectKind};

/// Match radius between a point and a target or surface sample, m.
pub const MATCH_RADIUS_M: f64 = 0.6;

/// Mean chirp start time of a frame of `sensor`, s after the frame start: where truth is
/// placed.
pub fn mid_frame_s(sensor: &SensorConfig) -> f64 {
    let w = &sensor.waveform;
    let t_loop = w.loop_period_s(sensor.num_tx);
    0.5 * ((sensor.loops.max(1) - 1) as f64 * t_loop
        + (sensor.num_tx.max(1) - 1) as f64 * w.chirp_period_s())
}

/// The strongest point (largest `intensity_db`) within [`MATCH_RADIUS_M`] of `at`.
pub fn matched_point<'a>(points: &'a [PointRecord], at: &[f64; 3]) -> Option<&'a PointRecord> {
    points
        .iter()
        .filter(|p| distance(p, *at) <= MATCH_RADIUS_M)
        .max_by(|a, b| a.intensity_db.total_cmp(&b.intensity_db))
}

/// `p + v·t`.
fn at_time(p: [f64; 3], v: [f64; 3], t: f64) -> [f64; 3] {
    [p[0] + v[0] * t, p[1] + v[1] * t, p[2] + v[2] * t]
}

/// Accuracy of a run against ground truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Accuracy {
    /// Visible point targets, summed over frames.
    pub targets: usize,
    /// Of those, detected.
    pub detected: usize,
    /// Azimuth RMSE of detected targets, degrees.
    pub azimuth_rmse_deg: f64,
    /// Elevation RMSE of detected targets, degrees.
    pub elevation_rmse_deg: f64,
    /// Radial-velocity RMSE of detected targets, m/s.
    pub doppler_rmse_mps: f64,
    /// Points farther than the match radius from every visible object, per frame.
    pub false_points_per_frame: f64,
    /// Most false points in one frame.
    pub max_false_points: usize,
    /// Points per frame.
    pub points_per_frame: f64,
}

impl Accuracy {
    /// Detected fraction (1 when there is no target).
    pub fn detection_rate(&self) -> f64 {
        if self.targets == 0 {
            1.0
        } else {
            self.detected as f64 / self.targets as f64
        }
    }
}

fn distance(p: &PointRecord, t: [f64; 3]) -> f64 {
    ((p.x - t[0]).powi(2) + (p.y - t[1]).powi(2) + (p.z - t[2]).powi(2)).sqrt()
}

/// Score `clouds[i]` against `truths[i]` for every frame, truth moved to `t_mid_s` after the
/// frame start ([`mid_frame_s`]; module docs).
pub fn accuracy<'a>(
    frames: impl IntoIterator<Item = (&'a FrameTruth, &'a [PointRecord])>,
    t_mid_s: f64,
) -> Accuracy {
    let mut a = Accuracy::default();
    let (mut az2, mut el2, mut v2) = (0.0, 0.0, 0.0);
    let (mut false_points, mut points, mut n_frames) = (0usize, 0usize, 0usize);
    for (truth, cloud) in frames {
        n_frames += 1;
        let visible: Vec<_> = truth.objects.iter().filter(|o| o.visible).collect();
        for t in visible.iter().filter(|o| o.kind == ObjectKind::Point) {
            a.targets += 1;
            let truth = look(at_time(t.position, t.velocity, t_mid_s), t.velocity);
            let at = at_time(t.position, t.velocity, t_mid_s);
            if let Some(p) = matched_point(cloud, &at) {
                a.detected += 1;
                let l = look([p.x, p.y, p.z], [0.0; 3]);
                az2 += (l.azimuth_deg - truth.azimuth_deg).powi(2);
                el2 += (l.elevation_deg - truth.elevation_deg).powi(2);
                v2 += (p.doppler - truth.radial_velocity_mps).powi(2);
            }
        }
        let mut false_here = 0;
        for p in cloud {
            points += 1;
            let near = visible.iter().any(|o| {
                distance(p, at_time(o.position, o.velocity, t_mid_s)) <= MATCH_RADIUS_M
                    || o.surface_points
                        .iter()
                        .any(|s| distance(p, at_time(*s, o.velocity, t_mid_s)) <= MATCH_RADIUS_M)
            });
            if !near {
                false_here += 1;
            }
        }
        false_points += false_here;
        a.max_false_points = a.max_false_points.max(false_here);
    }
    let n = a.detected.max(1) as f64;
    a.azimuth_rmse_deg = (az2 / n).sqrt();
    a.elevation_rmse_deg = (el2 / n).sqrt();
    a.doppler_rmse_mps = (v2 / n).sqrt();
    a.false_points_per_frame = false_points as f64 / n_frames.max(1) as f64;
    a.points_per_frame = points as f64 / n_frames.max(1) as f64;
    a
}
