//! ColoRadar raw sequences: `<seq>/single_chip/adc_samples/{data/frame_<i>.bin, timestamps.txt}`.
//!
//! A frame file is int16 little-endian, I then Q, C order `[tx][rx][chirp][sample][I,Q]`
//! (786,432 bytes for the default sensor); [`AdcFrame`] keeps TDM order
//! `[loop][tx][rx][sample]`, so reading and writing transpose. `timestamps.txt` has one time
//! in seconds per line, line `i` for frame `i`.

use std::fs;
use std::path::{Path, PathBuf};

use super::atomic::{create_dir, write_plain, StagedDir};
use super::calib::{check_sensor, write_calib_files, SINGLE_CHIP};
use super::{content_lines, not_found_or_os, read_bytes_into, read_text, IoError};
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;

/// Path of the raw-data folder inside a sequence: `single_chip/adc_samples`.
pub const ADC_SAMPLES: &str = "single_chip/adc_samples";
/// Frame file name prefix.
pub const FRAME_PREFIX: &str = "frame_";
/// Timestamp file name.
pub const TIMESTAMPS_FILE: &str = "timestamps.txt";

/// Name of frame `i`: `frame_<i>.bin`.
pub fn frame_file_name(i: usize) -> String {
    format!("{FRAME_PREFIX}{i}.bin")
}

/// Index of a canonical `<prefix><i>.bin` name (no sign, no leading zeros).
pub(crate) fn indexed_name(name: &str, prefix: &str) -> Option<usize> {
    let digits = name.strip_prefix(prefix)?.strip_suffix(".bin")?;
    let i: usize = digits.parse().ok()?;
    (i.to_string() == digits).then_some(i)
}

/// List `dir`, which must hold exactly the files `<prefix>0.bin ..= <prefix>{n-1}.bin`;
/// returns their paths by index.
pub(crate) fn list_indexed(dir: &Path, prefix: &str) -> Result<Vec<PathBuf>, IoError> {
    let entries = fs::read_dir(dir).map_err(|e| {
        not_found_or_os(
            dir,
            &format!("a folder of {prefix}<i>.bin files"),
            "list",
            e,
        )
    })?;
    let mut found: Vec<(usize, PathBuf)> = Vec::new();
    let mut extra = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| IoError::os(dir, "list", e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let is_file = entry.file_type().map(|t| t.is_file()).unwrap_or(false);
        match indexed_name(&name, prefix) {
            Some(i) if is_file => found.push((i, entry.path())),
            _ => extra.push(name),
        }
    }
    if !extra.is_empty() {
        extra.sort();
        return Err(IoError::ExtraFiles {
            dir: dir.to_path_buf(),
            files: extra,
            expected: format!("files {prefix}<i>.bin with i = 0, 1, … (no leading zeros)"),
        });
    }
    if found.is_empty() {
        return Err(IoError::NotFound {
            path: dir.join(format!("{prefix}0.bin")),
            expected: format!("at least one {prefix}<i>.bin file"),
        });
    }
    found.sort();
    let highest = found[found.len() - 1].0;
    // Indices are distinct, so they run 0..n exactly when the highest is n − 1 (no `+ 1`: a
    // stray frame_18446744073709551615.bin must not overflow).
    if highest != found.len() - 1 {
        let (mut missing, mut missing_count, mut next) = (Vec::new(), 0usize, 0usize);
        for &(i, _) in &found {
            if i > next {
                missing_count += i - next;
                if missing.len() < super::MAX_LISTED_GAPS {
                    missing.push((next, i - 1));
                }
            }
            next = i.saturating_add(1);
        }
        return Err(IoError::MissingFrames {
            dir: dir.to_path_buf(),
            missing,
            missing_count,
            found: found.len(),
            highest,
        });
    }
    Ok(found.into_iter().map(|(_, p)| p).collect())
}

/// Parse a timestamps file: one finite, non-decreasing time in seconds per line (blank lines
/// and `#` comments ignored); `expected` is the number of frames.
pub(crate) fn parse_timestamps(
    path: &Path,
    text: &str,
    expected: usize,
) -> Result<Vec<f64>, IoError> {
    let out = parse_times(path, text)?;
    if out.len() != expected {
        return Err(IoError::TimestampCount {
            path: path.to_path_buf(),
            found: out.len(),
            expected,
        });
    }
    Ok(out)
}

/// Parse a timestamps file of any length: one finite, non-decreasing time in seconds per line
/// (blank lines and `#` comments ignored).
pub(crate) fn parse_times(path: &Path, text: &str) -> Result<Vec<f64>, IoError> {
    let mut out: Vec<f64> = Vec::new();
    for (line, content) in content_lines(text) {
        let t: f64 = content.parse().map_err(|_| {
            IoError::syntax(path, line, format!("`{content}` is not a time in seconds"))
        })?;
        if !t.is_finite() {
            return Err(IoError::syntax(
                path,
                line,
                format!("`{content}` is not finite; expected a time in seconds"),
            ));
        }
        if let Some(&prev) = out.last() {
            if t < prev {
                return Err(IoError::syntax(
                    path,
                    line,
                    format!("time {t} s goes back from {prev} s; expected non-decreasing times"),
                ));
            }
        }
        out.push(t);
    }
    Ok(out)
}

/// An opened, checked ColoRadar sequence: every frame file exists with the right size and has
/// a timestamp. Frames are read on demand.
#[derive(Clone, Debug)]
pub struct Sequence {
    dir: PathBuf,
    sensor: SensorConfig,
    frames: Vec<PathBuf>,
    timestamps: Vec<f64>,
}

/// Open the ColoRadar sequence in `dir` for `sensor`.
///
/// `dir` is the sequence folder (holding `single_chip/adc_samples`) or the `adc_samples`
/// folder itself. Checks, each an [`IoError`] naming the file: the data folder holds only
/// `frame_<i>.bin` files numbered `0..n` without gaps; every one is
/// [`SensorConfig::frame_bytes`] long; `timestamps.txt` has exactly `n` finite,
/// non-decreasing times.
pub fn open_sequence(dir: &Path, sensor: &SensorConfig) -> Result<Sequence, IoError> {
    check_sensor(dir, sensor)?;
    let nested = dir.join(ADC_SAMPLES);
    let base = if nested.is_dir() {
        nested
    } else if dir.join("data").is_dir() && dir.join(TIMESTAMPS_FILE).is_file() {
        dir.to_path_buf()
    } else {
        return Err(IoError::NotFound {
            path: nested,
            expected: format!(
                "a ColoRadar sequence: {ADC_SAMPLES}/data/frame_<i>.bin and \
                 {ADC_SAMPLES}/{TIMESTAMPS_FILE}"
            ),
        });
    };
    let frames = list_indexed(&base.join("data"), FRAME_PREFIX)?;
    let expected = sensor.frame_bytes() as u64;
    for path in &frames {
        let len = fs::metadata(path)
            .map_err(|e| IoError::os(path, "inspect", e))?
            .len();
        if len != expected {
            return Err(frame_size_error(path, len, sensor));
        }
    }
    let tpath = base.join(TIMESTAMPS_FILE);
    let text = read_text(&tpath, "one timestamp per frame")?;
    let timestamps = parse_timestamps(&tpath, &text, frames.len())?;
    Ok(Sequence {
        dir: base,
        sensor: sensor.clone(),
        frames,
        timestamps,
    })
}

fn frame_size_error(path: &Path, len: u64, s: &SensorConfig) -> IoError {
    IoError::Size {
        path: path.to_path_buf(),
        found: len,
        expected: format!(
            "{} = {} TX × {} RX × {} chirps × {} samples × 4 bytes (int16 I and Q)",
            s.frame_bytes(),
            s.num_tx,
            s.num_rx,
            s.loops,
            s.samples
        ),
    }
}

impl Sequence {
    /// The `adc_samples` folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The sensor the frames were checked against.
    pub fn sensor(&self) -> &SensorConfig {
        &self.sensor
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// `true` if the sequence has no frames (never, once opened).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frame times, s, one per frame.
    pub fn timestamps(&self) -> &[f64] {
        &self.timestamps
    }

    /// Path of frame `i`, if it exists.
    pub fn frame_path(&self, i: usize) -> Option<&Path> {
        self.frames.get(i).map(PathBuf::as_path)
    }

    /// Read frame `i` into TDM order. Fails if `i` is out of range or the file changed size
    /// since the sequence was opened.
    pub fn read_frame(&self, i: usize) -> Result<AdcFrame, IoError> {
        self.read_frame_reusing(i, &mut Vec::new())
    }

    /// [`Self::read_frame`] through `bytes`, a buffer the caller keeps from frame to frame: a
    /// reader of many frames then allocates (and the kernel zeroes) no fresh megabyte of file
    /// bytes per frame.
    pub fn read_frame_reusing(&self, i: usize, bytes: &mut Vec<u8>) -> Result<AdcFrame, IoError> {
        let path = self.frames.get(i).ok_or_else(|| {
            IoError::invalid(
                &self.dir,
                format!(
                    "frame {i} requested; the sequence has frames 0..{}",
                    self.len()
                ),
            )
        })?;
        read_bytes_into(path, "a frame file", bytes)?;
        if bytes.len() != self.sensor.frame_bytes() {
            return Err(frame_size_error(path, bytes.len() as u64, &self.sensor));
        }
        Ok(decode_frame(bytes, &self.sensor))
    }
}

/// File order `[tx][rx][chirp][sample][I,Q]` → [`AdcFrame`]. `bytes` has the right length.
///
/// The frame is written in its own (TDM) order, each channel's chirp copied whole from its
/// place in the file: no zeroing pass and no per-sample bookkeeping (this loop took 7 % of
/// `dbe process`'s time before).
fn decode_frame(bytes: &[u8], s: &SensorConfig) -> AdcFrame {
    let chirp_bytes = 4 * s.samples;
    let mut data = Vec::with_capacity(s.samples * s.loops * s.num_tx * s.num_rx);
    for k in 0..s.loops {
        for t in 0..s.num_tx {
            for r in 0..s.num_rx {
                let at = ((t * s.num_rx + r) * s.loops + k) * chirp_bytes;
                match bytes.get(at..at + chirp_bytes) {
                    // On a little-endian host the file's bytes are the samples: one copy of
                    // the chirp (the buffer is the allocator's, aligned, and `at` a multiple
                    // of 4, so the cast succeeds; 4.6 % of `dbe process`'s CPU time went to
                    // converting sample by sample).
                    Some(chirp) => match bytemuck::try_cast_slice::<u8, [i16; 2]>(chirp) {
                        Ok(samples) if cfg!(target_endian = "little") => {
                            data.extend_from_slice(samples)
                        }
                        _ => data.extend(chirp.chunks_exact(4).map(le_sample)),
                    },
                    // Beyond a short `bytes` (the caller checks the length): zeros, in place.
                    None => data.extend(std::iter::repeat_n([0, 0], s.samples)),
                }
            }
        }
    }
    AdcFrame {
        samples: s.samples,
        loops: s.loops,
        tx: s.num_tx,
        rx: s.num_rx,
        data,
    }
}

/// One sample from its 4 little-endian bytes `[I, Q]`.
fn le_sample(b: &[u8]) -> [i16; 2] {
    [
        i16::from_le_bytes([b[0], b[1]]),
        i16::from_le_bytes([b[2], b[3]]),
    ]
}

/// [`AdcFrame`] → file order `[tx][rx][chirp][sample][I,Q]`.
fn encode_frame(frame: &AdcFrame) -> Vec<u8> {
    let mut out = Vec::with_capacity(frame.data.len() * 4);
    for t in 0..frame.tx {
        for r in 0..frame.rx {
            for k in 0..frame.loops {
                let start = frame.index(k, t, r, 0);
                for &[i, q] in &frame.data[start..start + frame.samples] {
                    out.extend_from_slice(&i.to_le_bytes());
                    out.extend_from_slice(&q.to_le_bytes());
                }
            }
        }
    }
    out
}

/// Check that `frame` has the sensor's shape; `path` names the output in errors.
pub(crate) fn check_frame_shape(
    path: &Path,
    index: usize,
    frame: &AdcFrame,
    s: &SensorConfig,
) -> Result<(), IoError> {
    let shape = (frame.samples, frame.loops, frame.tx, frame.rx);
    let want = (s.samples, s.loops, s.num_tx, s.num_rx);
    if shape != want || frame.data.len() != s.samples * s.loops * s.num_tx * s.num_rx {
        return Err(IoError::invalid(
            path,
            format!(
                "frame {index} is {} samples × {} loops × {} TX × {} RX with {} values; expected \
                 {} × {} × {} × {} as the sensor",
                frame.samples,
                frame.loops,
                frame.tx,
                frame.rx,
                frame.data.len(),
                s.samples,
                s.loops,
                s.num_tx,
                s.num_rx
            ),
        ));
    }
    Ok(())
}

/// Check times are finite and non-decreasing; `path` names the output in errors.
pub(crate) fn check_times(path: &Path, times: impl Iterator<Item = f64>) -> Result<(), IoError> {
    let mut prev = f64::NEG_INFINITY;
    for (i, t) in times.enumerate() {
        if !t.is_finite() || t < prev {
            return Err(IoError::invalid(
                path,
                format!("time of frame {i} is {t} s; expected finite, non-decreasing times"),
            ));
        }
        prev = t;
    }
    Ok(())
}

/// Write a ColoRadar sequence to `dir`: `dir/single_chip/adc_samples/data/frame_<i>.bin`,
/// `dir/single_chip/adc_samples/timestamps.txt`, and the sensor's calibration in
/// `dir/calib/single_chip/` (read it back with `load_calib(&dir.join("calib"))`).
///
/// Times are written with Rust's shortest round-trip formatting, so [`open_sequence`] returns
/// them bit-exact. `dir` must not exist or be empty; it appears complete or not at all.
pub fn write_sequence(
    dir: &Path,
    sensor: &SensorConfig,
    frames: &[(f64, &AdcFrame)],
) -> Result<(), IoError> {
    check_sensor(dir, sensor)?;
    if frames.is_empty() {
        return Err(IoError::invalid(
            dir,
            "no frames given; expected at least one",
        ));
    }
    check_times(dir, frames.iter().map(|&(t, _)| t))?;
    for (i, &(_, f)) in frames.iter().enumerate() {
        check_frame_shape(dir, i, f, sensor)?;
    }
    let staged = StagedDir::new(dir)?;
    let base = staged.path().join(ADC_SAMPLES);
    let data = base.join("data");
    create_dir(&data)?;
    let mut times = String::new();
    for (i, &(t, frame)) in frames.iter().enumerate() {
        write_plain(&data.join(frame_file_name(i)), &encode_frame(frame))?;
        times.push_str(&format!("{t}\n"));
    }
    write_plain(&base.join(TIMESTAMPS_FILE), times.as_bytes())?;
    let calib = staged.path().join("calib").join(SINGLE_CHIP);
    create_dir(&calib)?;
    write_calib_files(&calib, sensor)?;
    staged.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_names_only() {
        assert_eq!(indexed_name("frame_12.bin", FRAME_PREFIX), Some(12));
        assert_eq!(indexed_name("frame_0.bin", FRAME_PREFIX), Some(0));
        assert_eq!(indexed_name("frame_012.bin", FRAME_PREFIX), None);
        assert_eq!(indexed_name("frame_+1.bin", FRAME_PREFIX), None);
        assert_eq!(indexed_name("frame_1.bin.bak", FRAME_PREFIX), None);
    }

    #[test]
    fn transpose_round_trip() {
        let s = SensorConfig {
            samples: 3,
            loops: 2,
            ..SensorConfig::coloradar()
        };
        let mut f = AdcFrame::zeros(3, 2, 3, 4);
        for (j, v) in f.data.iter_mut().enumerate() {
            *v = [j as i16, -(j as i16)];
        }
        let bytes = encode_frame(&f);
        // File order: first value is tx0 rx0 chirp0 sample0, the second sample 1; after 3
        // samples comes chirp 1 of the same tx/rx, which is loop 1 in TDM order.
        let word = |w: usize| i16::from_le_bytes([bytes[2 * w], bytes[2 * w + 1]]);
        assert_eq!(word(0), 0);
        assert_eq!(word(2), 1);
        assert_eq!(word(6), f.data[f.index(1, 0, 0, 0)][0]);
        assert_eq!(decode_frame(&bytes, &s), f);
    }
}
