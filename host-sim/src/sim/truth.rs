//! Ground truth of simulated frames and its files.
//!
//! `write_truth(dir, frames)` writes, under `<dir>/groundtruth/`:
//!
//! - `frame_<i>.json`: one [`FrameTruth`] per frame (JSON object, fields as documented here);
//! - `groundtruth_poses.txt`: one line per frame, `x y z qx qy qz qw` (world position of the
//!   rig's base frame, m, and its orientation as a unit quaternion, base → world), the layout
//!   and meaning of ColoRadar's file (the radar sits at `calib/transforms/base_to_single_chip.txt`
//!   on the base; in scenes without a `[rig]` the two are the same);
//! - `timestamps.txt`: one line per frame, the frame start time in seconds.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::scene::{ObjectKind, Pose};
use super::trajectory::xyzw;
use super::SimFrame;

/// Ground truth of one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTruth {
    /// Frame index.
    pub index: usize,
    /// Start time of the frame, s.
    pub time_s: f64,
    /// Radar pose at the frame start.
    pub sensor: SensorPose,
    /// The rig's base-frame pose at the frame start (equal to `sensor` without a `[rig]`).
    pub base: SensorPose,
    /// Scatterers rendered into the frame.
    pub scatterers: usize,
    /// Every object of the scene, visible or not, in scene order.
    pub objects: Vec<ObjectTruth>,
}

/// Pose of a sensor or of the rig's base in the world frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorPose {
    /// Position, m.
    pub position: [f64; 3],
    /// Orientation as a unit quaternion `[qx, qy, qz, qw]` (body → world).
    pub orientation: [f64; 4],
    /// Yaw, degrees.
    pub yaw_deg: f64,
    /// Velocity in the world frame, m/s.
    pub velocity: [f64; 3],
    /// Yaw rate (world z component of the angular velocity), degrees per second.
    pub yaw_rate_deg_s: f64,
    /// Angular velocity in the body frame, rad/s.
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

impl From<Pose> for SensorPose {
    fn from(p: Pose) -> Self {
        Self {
            position: p.position.into(),
            orientation: xyzw(&p.rotation),
            yaw_deg: p.yaw_rad().to_degrees(),
            velocity: p.velocity.into(),
            yaw_rate_deg_s: p.angular_velocity_world().z.to_degrees(),
            angular_velocity: p.angular_velocity.into(),
        }
    }
}

/// Ground truth of one object in one frame, in the radar frame at the frame start.
///
/// For a point target the position is the target; for a surface it is the object's centre
/// (rectangle or box centre, middle of a pole's axis), and `surface_points` hold the visible
/// part of the surface sampled on a regular grid of `truth_spacing_m`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectTruth {
    /// Index of the object in the scene.
    pub id: usize,
    /// Name from the scene.
    pub name: String,
    /// Kind of object.
    pub kind: ObjectKind,
    /// Position, m.
    pub position: [f64; 3],
    /// Velocity relative to the radar, m/s.
    pub velocity: [f64; 3],
    /// Range `|position|`, m.
    pub range_m: f64,
    /// Azimuth direction cosine `μ = −u_y`.
    pub mu: f64,
    /// Elevation direction cosine `ν = u_z`.
    pub nu: f64,
    /// Azimuth `φ = asin(μ / √(1 − ν²))`, degrees (positive to the right).
    pub azimuth_deg: f64,
    /// Elevation `θ = asin(ν)`, degrees (positive up).
    pub elevation_deg: f64,
    /// Range rate `u · velocity`, m/s, positive receding.
    pub radial_velocity_mps: f64,
    /// Point target: inside the field of view and not hidden; surface: any point visible.
    pub visible: bool,
    /// Scatterers this object contributed to the frame (its floor ghosts not counted).
    pub scatterers: usize,
    /// Floor-bounce ghosts of those scatterers (`[surfaces.multipath]`), rendered as well.
    #[serde(default)]
    pub ghosts: usize,
    /// Visible surface points, m, rounded to 1 mm (empty for point targets).
    pub surface_points: Vec<[f64; 3]>,
}

/// Range, direction and range rate of a radar-frame position and relative velocity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Look {
    /// Range, m.
    pub range_m: f64,
    /// `μ = −u_y`.
    pub mu: f64,
    /// `ν = u_z`.
    pub nu: f64,
    /// `asin(μ / √(1 − ν²))`, degrees.
    pub azimuth_deg: f64,
    /// `asin(ν)`, degrees.
    pub elevation_deg: f64,
    /// `u · v`, m/s.
    pub radial_velocity_mps: f64,
}

/// The [`Look`] of position `p` moving with `v`, both in the radar frame. At the origin all
/// fields are 0; straight up or down the azimuth is 0.
pub fn look(p: [f64; 3], v: [f64; 3]) -> Look {
    let range = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    if range == 0.0 {
        return Look {
            range_m: 0.0,
            mu: 0.0,
            nu: 0.0,
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            radial_velocity_mps: 0.0,
        };
    }
    let u = p.map(|x| x / range);
    let (mu, nu) = (-u[1], u[2]);
    let horizontal = (1.0 - nu * nu).max(0.0).sqrt();
    let az = if horizontal > 0.0 {
        (mu / horizontal).clamp(-1.0, 1.0).asin()
    } else {
        0.0
    };
    Look {
        range_m: range,
        mu,
        nu,
        azimuth_deg: az.to_degrees(),
        elevation_deg: nu.clamp(-1.0, 1.0).asin().to_degrees(),
        radial_velocity_mps: u[0] * v[0] + u[1] * v[1] + u[2] * v[2],
    }
}

/// Write the ground truth of `frames` under `<dir>/groundtruth/` (see the module docs),
/// creating the folders.
pub fn write_truth(dir: &Path, frames: &[SimFrame]) -> io::Result<()> {
    let gt = dir.join("groundtruth");
    fs::create_dir_all(&gt)?;
    let with_path =
        |path: &Path, e: io::Error| io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    let mut poses = String::new();
    let mut stamps = String::new();
    for f in frames {
        let path = gt.join(format!("frame_{}.json", f.index));
        let file = fs::File::create(&path).map_err(|e| with_path(&path, e))?;
        let mut w = BufWriter::new(file);
        serde_json::to_writer(&mut w, &f.truth).map_err(|e| with_path(&path, e.into()))?;
        w.flush().map_err(|e| with_path(&path, e))?;
        let s = &f.truth.base;
        let [x, y, z] = s.position;
        let [qx, qy, qz, qw] = s.orientation;
        poses.push_str(&format!("{x} {y} {z} {qx} {qy} {qz} {qw}\n"));
        stamps.push_str(&format!("{:.6}\n", f.time_s));
    }
    for (name, text) in [("groundtruth_poses.txt", poses), ("timestamps.txt", stamps)] {
        let path = gt.join(name);
        fs::write(&path, text).map_err(|e| with_path(&path, e))?;
    }
    Ok(())
}
