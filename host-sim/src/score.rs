//! Accuracy of point clouds against simulated ground truth (point targets).
//!
//! A visible point target counts as detected when a point lies within [`MATCH_RADIUS_M`] of
//! it; the nearest such point gives its azimuth, elevation and Doppler errors (angles as in
//! spec §2: φ = asin(μ/√(1−ν²)), θ = asin(ν)). A point farther than [`MATCH_RADIUS_M`] from
//! every visible object (targets and sampled surfaces) is a false point.

use crate::cloud::PointRecord;
use crate::sim::truth::look;
use crate::sim::{FrameTruth, ObjectKind};

/// Match radius between a point and a target or surface sample, m.
pub const MATCH_RADIUS_M: f64 = 0.6;

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

/// Score `clouds[i]` against `truths[i]` for every frame.
pub fn accuracy<'a>(
    frames: impl IntoIterator<Item = (&'a FrameTruth, &'a [PointRecord])>,
) -> Accuracy {
    let mut a = Accuracy::default();
    let (mut az2, mut el2, mut v2) = (0.0, 0.0, 0.0);
    let (mut false_points, mut points, mut n_frames) = (0usize, 0usize, 0usize);
    for (truth, cloud) in frames {
        n_frames += 1;
        let visible: Vec<_> = truth.objects.iter().filter(|o| o.visible).collect();
        for t in visible.iter().filter(|o| o.kind == ObjectKind::Point) {
            a.targets += 1;
            let best = cloud
                .iter()
                .map(|p| (distance(p, t.position), p))
                .filter(|(d, _)| *d <= MATCH_RADIUS_M)
                .min_by(|x, y| x.0.total_cmp(&y.0));
            if let Some((_, p)) = best {
                a.detected += 1;
                let l = look([p.x, p.y, p.z], [0.0; 3]);
                az2 += (l.azimuth_deg - t.azimuth_deg).powi(2);
                el2 += (l.elevation_deg - t.elevation_deg).powi(2);
                v2 += (p.doppler - t.radial_velocity_mps).powi(2);
            }
        }
        let mut false_here = 0;
        for p in cloud {
            points += 1;
            let near = visible.iter().any(|o| {
                distance(p, o.position) <= MATCH_RADIUS_M
                    || o.surface_points
                        .iter()
                        .any(|s| distance(p, *s) <= MATCH_RADIUS_M)
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
