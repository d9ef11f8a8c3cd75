//! ColoRadar navigation files: the IMU, the ground-truth poses and the sensor transforms.
//!
//! | file | content |
//! |---|---|
//! | `SEQ/imu/imu_data.txt` | one sample per line, `ax ay az gx gy gz`: specific force (m/s²) and angular rate (rad/s) in the IMU frame |
//! | `SEQ/imu/timestamps.txt` | one time (s) per line, line i for sample i |
//! | `SEQ/groundtruth/groundtruth_poses.txt` | one pose per line, `x y z qx qy qz qw`: the base frame in the world (base → world) |
//! | `SEQ/groundtruth/timestamps.txt` | one time (s) per line, line i for pose i |
//! | `calib/transforms/base_to_single_chip.txt`, `base_to_imu.txt` | line 1 `x y z`, line 2 `qx qy qz qw`: `p_base = R·p_sensor + t` |
//!
//! Blank lines and `#` comments are skipped. Every value must be a finite number, quaternions
//! unit within 10⁻³ (they are normalised), times non-decreasing, and each data file must have
//! exactly one line per timestamp; anything else is an [`IoError`] naming the file and line.

use std::path::{Path, PathBuf};

use nalgebra::{UnitQuaternion, Vector3};

use super::atomic::{create_dir, write_plain};
use super::coloradar::parse_times;
use super::{content_lines, read_text, IoError};
use crate::sim::imu::ImuSample;
use crate::sim::scene::Rig;
use crate::sim::trajectory::{quaternion_from_xyzw, Mount};

/// The IMU folder of a sequence.
pub const IMU_DIR: &str = "imu";
/// The IMU sample file.
pub const IMU_DATA_FILE: &str = "imu_data.txt";
/// The ground-truth folder of a sequence.
pub const GROUNDTRUTH_DIR: &str = "groundtruth";
/// The ground-truth pose file.
pub const POSES_FILE: &str = "groundtruth_poses.txt";
/// The transforms folder of a calibration.
pub const TRANSFORMS_DIR: &str = "transforms";
/// The radar's mount on the base.
pub const RADAR_TRANSFORM_FILE: &str = "base_to_single_chip.txt";
/// The IMU's mount on the base.
pub const IMU_TRANSFORM_FILE: &str = "base_to_imu.txt";

const TIMESTAMPS: &str = "timestamps.txt";

/// One timed pose: the base frame in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StampedPose {
    /// Time, s.
    pub time_s: f64,
    /// Position, m.
    pub position: Vector3<f64>,
    /// Orientation, body → world.
    pub rotation: UnitQuaternion<f64>,
}

/// Where the radar and the IMU sit on the base (`calib/transforms/`): the scene's [`Rig`],
/// one type for the simulator's mounts and the files'.
pub type Transforms = Rig;

/// `n` whitespace-separated finite numbers of one line.
fn numbers<const N: usize>(
    path: &Path,
    line: usize,
    content: &str,
    what: &str,
) -> Result<[f64; N], IoError> {
    let fields: Vec<&str> = content.split_whitespace().collect();
    if fields.len() != N {
        return Err(IoError::syntax(
            path,
            line,
            format!("{} values, expected {N}: {what}", fields.len()),
        ));
    }
    let mut out = [0.0; N];
    for (o, f) in out.iter_mut().zip(&fields) {
        *o = f
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                IoError::syntax(path, line, format!("`{f}` is not a finite number: {what}"))
            })?;
    }
    Ok(out)
}

/// A unit quaternion `[qx, qy, qz, qw]` read from line `line`.
fn unit_quaternion(path: &Path, line: usize, q: [f64; 4]) -> Result<UnitQuaternion<f64>, IoError> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if (n - 1.0).abs() > 1e-3 {
        return Err(IoError::syntax(
            path,
            line,
            format!("quaternion {q:?} has norm {n}; expected a unit quaternion qx qy qz qw"),
        ));
    }
    Ok(quaternion_from_xyzw(q))
}

/// Rows of a data file with its timestamps file beside it: `(time, values)`.
fn stamped_rows<const N: usize>(
    dir: &Path,
    data_file: &str,
    what: &str,
) -> Result<Vec<(f64, usize, [f64; N])>, IoError> {
    let data_path = dir.join(data_file);
    let time_path = dir.join(TIMESTAMPS);
    let data = read_text(&data_path, what)?;
    let times = parse_times(
        &time_path,
        &read_text(&time_path, "one time in seconds per line")?,
    )?;
    let rows: Vec<(usize, [f64; N])> = content_lines(&data)
        .map(|(line, c)| numbers::<N>(&data_path, line, c, what).map(|v| (line, v)))
        .collect::<Result<_, _>>()?;
    if rows.len() != times.len() {
        return Err(IoError::invalid(
            &data_path,
            format!(
                "{} lines, but {} has {} times; expected one line per timestamp",
                rows.len(),
                time_path.display(),
                times.len()
            ),
        ));
    }
    if rows.is_empty() {
        return Err(IoError::invalid(
            &data_path,
            format!("no data; expected {what}"),
        ));
    }
    Ok(times
        .into_iter()
        .zip(rows)
        .map(|(t, (line, v))| (t, line, v))
        .collect())
}

/// Read `SEQ/imu/{imu_data,timestamps}.txt`.
pub fn read_imu(seq: &Path) -> Result<Vec<ImuSample>, IoError> {
    let rows = stamped_rows::<6>(
        &seq.join(IMU_DIR),
        IMU_DATA_FILE,
        "ax ay az gx gy gz (m/s², rad/s) per line",
    )?;
    Ok(rows
        .into_iter()
        .map(|(time_s, _, v)| ImuSample {
            time_s,
            accel: Vector3::new(v[0], v[1], v[2]),
            gyro: Vector3::new(v[3], v[4], v[5]),
        })
        .collect())
}

/// Read `SEQ/groundtruth/{groundtruth_poses,timestamps}.txt`.
pub fn read_groundtruth(seq: &Path) -> Result<Vec<StampedPose>, IoError> {
    let dir = seq.join(GROUNDTRUTH_DIR);
    let path = dir.join(POSES_FILE);
    stamped_rows::<7>(&dir, POSES_FILE, "x y z qx qy qz qw per line")?
        .into_iter()
        .map(|(time_s, line, v)| {
            Ok(StampedPose {
                time_s,
                position: Vector3::new(v[0], v[1], v[2]),
                rotation: unit_quaternion(&path, line, [v[3], v[4], v[5], v[6]])?,
            })
        })
        .collect()
}

/// Whether `seq` has a ground-truth pose file.
pub fn has_groundtruth(seq: &Path) -> bool {
    seq.join(GROUNDTRUTH_DIR).join(POSES_FILE).is_file()
}

/// Read one transform file (line 1 `x y z`, line 2 `qx qy qz qw`).
pub fn read_transform(path: &Path) -> Result<Mount, IoError> {
    let text = read_text(path, "a transform: line 1 `x y z`, line 2 `qx qy qz qw`")?;
    let lines: Vec<(usize, &str)> = content_lines(&text).collect();
    if lines.len() != 2 {
        return Err(IoError::invalid(
            path,
            format!(
                "{} lines; expected 2: `x y z` then `qx qy qz qw`",
                lines.len()
            ),
        ));
    }
    let t = numbers::<3>(path, lines[0].0, lines[0].1, "translation x y z (m)")?;
    let q = numbers::<4>(path, lines[1].0, lines[1].1, "rotation qx qy qz qw")?;
    let q = unit_quaternion(path, lines[1].0, q)?;
    Ok(Mount {
        position: t,
        quaternion: [q.i, q.j, q.k, q.w],
    })
}

/// Write one transform file (plainly: into a folder being staged, as the writers below).
pub fn write_transform(path: &Path, mount: &Mount) -> Result<(), IoError> {
    let [x, y, z] = mount.position;
    let [qx, qy, qz, qw] = mount.quaternion;
    write_plain(
        path,
        format!("{x} {y} {z}\n{qx} {qy} {qz} {qw}\n").as_bytes(),
    )
}

/// The transforms folder of a calibration folder `calib` (`calib/transforms`).
pub fn transforms_dir(calib: &Path) -> PathBuf {
    calib.join(TRANSFORMS_DIR)
}

/// Read `calib/transforms/base_to_single_chip.txt` and `base_to_imu.txt`.
pub fn load_transforms(calib: &Path) -> Result<Transforms, IoError> {
    let dir = transforms_dir(calib);
    Ok(Transforms {
        radar: read_transform(&dir.join(RADAR_TRANSFORM_FILE))?,
        imu: read_transform(&dir.join(IMU_TRANSFORM_FILE))?,
    })
}

/// Write `calib/transforms/` (creating the folders) into a folder being staged
/// ([`crate::io::StagedDir`]).
pub fn write_transforms(calib: &Path, t: &Transforms) -> Result<(), IoError> {
    let dir = transforms_dir(calib);
    create_dir(&dir)?;
    write_transform(&dir.join(RADAR_TRANSFORM_FILE), &t.radar)?;
    write_transform(&dir.join(IMU_TRANSFORM_FILE), &t.imu)
}

/// Write `SEQ/imu/` (creating the folder) into a folder being staged. Values use Rust's
/// shortest round-trip formatting, so [`read_imu`] returns them bit-exact.
pub fn write_imu(seq: &Path, samples: &[ImuSample]) -> Result<(), IoError> {
    let dir = seq.join(IMU_DIR);
    create_dir(&dir)?;
    let (mut data, mut times) = (String::new(), String::new());
    for s in samples {
        let (a, g) = (s.accel, s.gyro);
        data.push_str(&format!(
            "{} {} {} {} {} {}\n",
            a.x, a.y, a.z, g.x, g.y, g.z
        ));
        times.push_str(&format!("{}\n", s.time_s));
    }
    for (name, text) in [(IMU_DATA_FILE, data), (TIMESTAMPS, times)] {
        write_plain(&dir.join(name), text.as_bytes())?;
    }
    Ok(())
}
