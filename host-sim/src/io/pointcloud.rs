//! Point-cloud files: ColoRadar `.bin` sequences, CSV, PCD and PLY.
//!
//! | format | content per point | precision |
//! |---|---|---|
//! | ColoRadar `.bin` | float32 LE `[x, y, z, intensity, doppler]`, no header; intensity = `intensity_db` | f32 |
//! | CSV | every [`PointRecord`] field, header [`CSV_HEADER`] | f64, shortest round-trip |
//! | PCD | PCL v0.7 `DATA binary`, fields `x y z intensity doppler snr`, `F` 4 bytes | f32 |
//! | PLY | `binary_little_endian 1.0` or `ascii 1.0`, float `x y z intensity doppler snr` | f32 |
//!
//! Every format has its columns in one order, `x y z intensity doppler snr` (the ColoRadar
//! `.bin`, the dataset's own format, stops after doppler; CSV adds the bins after snr; MCAP,
//! `super::mcap`, packs the same six).
//!
//! Writers refuse points whose written values are not finite (an [`IoError::Invalid`] naming
//! the output file and the point index) and write atomically (see [`super::atomic`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::atomic::{create_dir, write_file_atomic, write_plain, StagedDir};
use super::coloradar::{list_indexed, parse_timestamps, TIMESTAMPS_FILE};
use super::{read_bytes, read_text, IoError};
use crate::cloud::PointRecord;

/// Path of the point-cloud folder inside an output folder: `single_chip/pointclouds`.
pub const POINTCLOUDS: &str = "single_chip/pointclouds";
/// Point-cloud file name prefix.
pub const CLOUD_PREFIX: &str = "radar_pointcloud_";
/// The exact CSV header line.
pub const CSV_HEADER: &str =
    "x,y,z,intensity_db,doppler,snr_db,range_bin,azimuth_bin,elevation_bin,doppler_bin";
/// Bytes per point of the ColoRadar `.bin` (5 × float32; PCD and binary PLY add snr: 24).
pub const POINT_BYTES: usize = 20;

/// Names of the float32 columns of the binary formats, in the one order of every format.
const COLUMNS: [&str; 6] = ["x", "y", "z", "intensity_db", "doppler", "snr_db"];

/// The first `F` float32 columns of `p` (`x y z intensity doppler snr`): 5 for the ColoRadar
/// `.bin`, 6 for PCD and PLY; fails if one is not finite as f32.
fn columns<const F: usize>(path: &Path, i: usize, p: &PointRecord) -> Result<[f32; F], IoError> {
    const { assert!(F <= 6) };
    let all = [p.x, p.y, p.z, p.intensity_db, p.doppler, p.snr_db];
    let v: [f32; F] = std::array::from_fn(|k| all[k] as f32);
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(IoError::invalid(
            path,
            format!(
                "point {i}: {} = {} is not a finite float32; expected finite values",
                COLUMNS[k], all[k]
            ),
        ));
    }
    Ok(v)
}

/// The points as little-endian float32 rows of their first `F` columns.
fn binary_points<const F: usize>(path: &Path, points: &[PointRecord]) -> Result<Vec<u8>, IoError> {
    let mut out = Vec::with_capacity(points.len() * 4 * F);
    for (i, p) in points.iter().enumerate() {
        for v in columns::<F>(path, i, p)? {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}

/// Write one ColoRadar point-cloud file (float32 LE `[x, y, z, intensity, doppler]` per point).
pub fn write_coloradar_bin(path: &Path, points: &[PointRecord]) -> Result<(), IoError> {
    write_file_atomic(path, &encode_coloradar_bin(path, points)?)
}

/// The bytes [`write_coloradar_bin`] writes (`path` names the file in errors).
pub fn encode_coloradar_bin(path: &Path, points: &[PointRecord]) -> Result<Vec<u8>, IoError> {
    binary_points::<5>(path, points)
}

/// Read one ColoRadar point-cloud file. Only `x, y, z, intensity_db, doppler` are stored; the
/// other fields of the returned records are zero.
pub fn read_coloradar_bin(path: &Path) -> Result<Vec<PointRecord>, IoError> {
    let bytes = read_bytes(path, "a ColoRadar point-cloud file")?;
    if bytes.len() % POINT_BYTES != 0 {
        return Err(IoError::Size {
            path: path.to_path_buf(),
            found: bytes.len() as u64,
            expected: format!(
                "a multiple of {POINT_BYTES} (5 float32 per point); {} trailing bytes",
                bytes.len() % POINT_BYTES
            ),
        });
    }
    bytes
        .chunks_exact(POINT_BYTES)
        .enumerate()
        .map(|(i, c)| {
            let f =
                |k: usize| f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]);
            let v = [f(0), f(1), f(2), f(3), f(4)];
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(IoError::invalid(
                    path,
                    format!(
                        "point {i} (byte {}): value {k} is {}; expected finite float32",
                        i * POINT_BYTES + 4 * k,
                        v[k]
                    ),
                ));
            }
            Ok(PointRecord {
                x: f64::from(v[0]),
                y: f64::from(v[1]),
                z: f64::from(v[2]),
                intensity_db: f64::from(v[3]),
                doppler: f64::from(v[4]),
                ..PointRecord::default()
            })
        })
        .collect()
}

/// Streams a ColoRadar point-cloud sequence: `OUT/single_chip/pointclouds/data/
/// radar_pointcloud_<i>.bin` and `OUT/single_chip/pointclouds/timestamps.txt`.
///
/// Everything is staged in a hidden sibling of `OUT` and appears at `OUT` only when
/// [`ColoradarCloudWriter::finish`] succeeds; dropping the writer unfinished removes it all.
#[derive(Debug)]
pub struct ColoradarCloudWriter {
    staged: StagedDir,
    data: PathBuf,
    times: String,
    last_time: f64,
    frames: usize,
}

impl ColoradarCloudWriter {
    /// Start writing to `out`, which must not exist or be empty.
    pub fn create(out: &Path) -> Result<Self, IoError> {
        let staged = StagedDir::new(out)?;
        let data = staged.path().join(POINTCLOUDS).join("data");
        create_dir(&data)?;
        Ok(Self {
            staged,
            data,
            times: String::new(),
            last_time: f64::NEG_INFINITY,
            frames: 0,
        })
    }

    /// Append the next frame's cloud with its time, s (finite, non-decreasing).
    pub fn push(&mut self, time_s: f64, points: &[PointRecord]) -> Result<(), IoError> {
        let target = self.staged.target().to_path_buf();
        let name = format!("{CLOUD_PREFIX}{}.bin", self.frames);
        if !time_s.is_finite() || time_s < self.last_time {
            return Err(IoError::invalid(
                &target.join(POINTCLOUDS).join(TIMESTAMPS_FILE),
                format!(
                    "time of frame {} is {time_s} s after {} s; expected finite, \
                     non-decreasing times",
                    self.frames, self.last_time
                ),
            ));
        }
        let bytes = binary_points::<5>(&target.join(POINTCLOUDS).join("data").join(&name), points)?;
        write_plain(&self.data.join(name), &bytes)?;
        let _ = writeln!(self.times, "{time_s}");
        self.last_time = time_s;
        self.frames += 1;
        Ok(())
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Write `timestamps.txt` and move the folder into place.
    pub fn finish(self) -> Result<(), IoError> {
        if self.frames == 0 {
            return Err(IoError::invalid(
                self.staged.target(),
                "no frames written; expected at least one",
            ));
        }
        let base = self.staged.path().join(POINTCLOUDS);
        write_plain(&base.join(TIMESTAMPS_FILE), self.times.as_bytes())?;
        self.staged.commit()
    }
}

/// Write a ColoRadar point-cloud sequence to `out` (see [`ColoradarCloudWriter`]): frame `i`
/// of `frames` becomes `radar_pointcloud_<i>.bin`, its time line `i` of `timestamps.txt`.
pub fn write_coloradar_pointclouds(
    out: &Path,
    frames: &[(f64, &[PointRecord])],
) -> Result<(), IoError> {
    let mut w = ColoradarCloudWriter::create(out)?;
    for &(t, points) in frames {
        w.push(t, points)?;
    }
    w.finish()
}

/// Read a ColoRadar point-cloud sequence written by [`write_coloradar_pointclouds`] (or the
/// dataset's own): `(time, points)` per frame. `out` is the folder holding
/// `single_chip/pointclouds`, or the `pointclouds` folder itself.
pub fn read_coloradar_pointclouds(out: &Path) -> Result<Vec<(f64, Vec<PointRecord>)>, IoError> {
    let nested = out.join(POINTCLOUDS);
    let base = if nested.is_dir() {
        nested
    } else if out.join("data").is_dir() {
        out.to_path_buf()
    } else {
        return Err(IoError::NotFound {
            path: nested,
            expected: format!(
                "{POINTCLOUDS}/data/{CLOUD_PREFIX}<i>.bin and {POINTCLOUDS}/{TIMESTAMPS_FILE}"
            ),
        });
    };
    let files = list_indexed(&base.join("data"), CLOUD_PREFIX)?;
    let tpath = base.join(TIMESTAMPS_FILE);
    let times = parse_timestamps(
        &tpath,
        &read_text(&tpath, "one timestamp per point-cloud file")?,
        files.len(),
    )?;
    files
        .iter()
        .zip(times)
        .map(|(f, t)| Ok((t, read_coloradar_bin(f)?)))
        .collect()
}

/// Write points as CSV with the header [`CSV_HEADER`], one row per point, floats in Rust's
/// shortest round-trip form (so [`read_csv`] returns them bit-exact).
pub fn write_csv(path: &Path, points: &[PointRecord]) -> Result<(), IoError> {
    write_file_atomic(path, &encode_csv(path, points)?)
}

/// The bytes [`write_csv`] writes (`path` names the file in errors).
pub fn encode_csv(path: &Path, points: &[PointRecord]) -> Result<Vec<u8>, IoError> {
    let mut s = String::with_capacity(64 * (points.len() + 1));
    s.push_str(CSV_HEADER);
    s.push('\n');
    for (i, p) in points.iter().enumerate() {
        let floats = [
            ("x", p.x),
            ("y", p.y),
            ("z", p.z),
            ("intensity_db", p.intensity_db),
            ("doppler", p.doppler),
            ("snr_db", p.snr_db),
        ];
        if let Some((name, v)) = floats.iter().find(|(_, v)| !v.is_finite()) {
            return Err(IoError::invalid(
                path,
                format!("point {i}: {name} = {v}; expected finite values"),
            ));
        }
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{}",
            p.x,
            p.y,
            p.z,
            p.intensity_db,
            p.doppler,
            p.snr_db,
            p.range_bin,
            p.azimuth_bin,
            p.elevation_bin,
            p.doppler_bin
        );
    }
    Ok(s.into_bytes())
}

/// Read a CSV written by [`write_csv`]: the first line must be exactly [`CSV_HEADER`]; every
/// other non-blank line has 10 fields, floats finite, bins integers.
pub fn read_csv(path: &Path) -> Result<Vec<PointRecord>, IoError> {
    let text = read_text(path, "a point-cloud CSV")?;
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim_end() == CSV_HEADER => {}
        Some((_, h)) => {
            return Err(IoError::syntax(
                path,
                1,
                format!("header `{h}`; expected `{CSV_HEADER}`"),
            ))
        }
        None => {
            return Err(IoError::syntax(
                path,
                1,
                format!("empty file; expected the header `{CSV_HEADER}`"),
            ))
        }
    }
    let mut out = Vec::new();
    for (i, line) in lines {
        let line_no = i + 1;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 10 {
            return Err(IoError::syntax(
                path,
                line_no,
                format!("{} fields; expected 10 as in the header", f.len()),
            ));
        }
        let names: Vec<&str> = CSV_HEADER.split(',').collect();
        let float = |k: usize| -> Result<f64, IoError> {
            match f[k].parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(IoError::syntax(
                    path,
                    line_no,
                    format!("{} = `{}`; expected a finite number", names[k], f[k]),
                )),
            }
        };
        let bad_int = |k: usize, kind: &str| {
            IoError::syntax(
                path,
                line_no,
                format!("{} = `{}`; expected {kind}", names[k], f[k]),
            )
        };
        let uint = |k: usize| -> Result<u32, IoError> {
            f[k].parse::<u32>()
                .map_err(|_| bad_int(k, "a non-negative whole number"))
        };
        out.push(PointRecord {
            x: float(0)?,
            y: float(1)?,
            z: float(2)?,
            intensity_db: float(3)?,
            doppler: float(4)?,
            snr_db: float(5)?,
            range_bin: uint(6)?,
            azimuth_bin: uint(7)?,
            elevation_bin: uint(8)?,
            doppler_bin: f[9]
                .parse::<i32>()
                .map_err(|_| bad_int(9, "a whole number"))?,
        });
    }
    Ok(out)
}

/// Write points as a PCL PCD v0.7 file, `DATA binary`, fields `x y z intensity doppler snr`
/// (float32 each), unorganised (`HEIGHT 1`).
pub fn write_pcd(path: &Path, points: &[PointRecord]) -> Result<(), IoError> {
    write_file_atomic(path, &encode_pcd(path, points)?)
}

/// The bytes [`write_pcd`] writes (`path` names the file in errors).
pub fn encode_pcd(path: &Path, points: &[PointRecord]) -> Result<Vec<u8>, IoError> {
    let n = points.len();
    let mut out = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n\
         FIELDS x y z intensity doppler snr\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\n\
         COUNT 1 1 1 1 1 1\n\
         WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n"
    )
    .into_bytes();
    out.extend_from_slice(&binary_points::<6>(path, points)?);
    Ok(out)
}

/// PLY body encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyEncoding {
    /// `format binary_little_endian 1.0`: 6 float32 per vertex.
    BinaryLittleEndian,
    /// `format ascii 1.0`: one line per vertex, shortest round-trip f32 text.
    Ascii,
}

/// Write points as a PLY file: `element vertex N` with float properties
/// `x y z intensity doppler snr`.
pub fn write_ply(
    path: &Path,
    points: &[PointRecord],
    encoding: PlyEncoding,
) -> Result<(), IoError> {
    write_file_atomic(path, &encode_ply(path, points, encoding)?)
}

/// The bytes [`write_ply`] writes (`path` names the file in errors).
pub fn encode_ply(
    path: &Path,
    points: &[PointRecord],
    encoding: PlyEncoding,
) -> Result<Vec<u8>, IoError> {
    let format = match encoding {
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::Ascii => "ascii",
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment dbe-radar point cloud: x forward, y left, z up [m], \
         intensity [dB], doppler [m/s, positive receding], snr [dB]\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nproperty float intensity\n\
         property float doppler\nproperty float snr\nend_header\n",
        points.len()
    );
    match encoding {
        PlyEncoding::BinaryLittleEndian => {
            let mut bytes = out.into_bytes();
            bytes.extend_from_slice(&binary_points::<6>(path, points)?);
            Ok(bytes)
        }
        PlyEncoding::Ascii => {
            for (i, p) in points.iter().enumerate() {
                let [x, y, z, intensity, doppler, snr] = columns::<6>(path, i, p)?;
                let _ = writeln!(out, "{x} {y} {z} {intensity} {doppler} {snr}");
            }
            Ok(out.into_bytes())
        }
    }
}
