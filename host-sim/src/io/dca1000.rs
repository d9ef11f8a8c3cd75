//! TI DCA1000 raw captures (`adc_data_Raw_0.bin`), 2-lane LVDS, complex int16.
//!
//! Layout (see `shared/fixtures/ti-iwr6843-corner-reflector/README.md`): no header; frames back
//! to back; within a frame, slowest first: loop → TX slot → RX → sample, which is exactly
//! [`AdcFrame`]'s order. Within one RX's chirp, every 4 int16 little-endian words are
//! `I(n) I(n+1) Q(n) Q(n+1)` (the two LVDS lanes interleaved), so the sample count must be even.

use std::path::Path;

use super::atomic::write_file_atomic;
use super::calib::check_sensor;
use super::coloradar::check_frame_shape;
use super::{read_bytes, IoError};
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;

/// Read every frame of a DCA1000 capture for `sensor`.
///
/// The file size must be a non-zero whole multiple of [`SensorConfig::frame_bytes`], and the
/// sample count even (the 2-lane interleave packs sample pairs).
pub fn read_dca1000(path: &Path, sensor: &SensorConfig) -> Result<Vec<AdcFrame>, IoError> {
    check_sensor(path, sensor)?;
    check_even(path, sensor)?;
    let bytes = read_bytes(path, "a DCA1000 raw capture")?;
    let frame_bytes = sensor.frame_bytes();
    if bytes.is_empty() || bytes.len() % frame_bytes != 0 {
        return Err(IoError::Size {
            path: path.to_path_buf(),
            found: bytes.len() as u64,
            expected: format!(
                "a non-zero multiple of the frame size {frame_bytes} ({} loops × {} TX × {} RX × \
                 {} samples × 4 bytes); {} whole frames and {} trailing bytes",
                sensor.loops,
                sensor.num_tx,
                sensor.num_rx,
                sensor.samples,
                bytes.len() / frame_bytes,
                bytes.len() % frame_bytes
            ),
        });
    }
    Ok(bytes
        .chunks_exact(frame_bytes)
        .map(|chunk| decode(chunk, sensor))
        .collect())
}

fn check_even(path: &Path, sensor: &SensorConfig) -> Result<(), IoError> {
    if sensor.samples % 2 != 0 {
        return Err(IoError::invalid(
            path,
            format!(
                "{} samples per chirp; the DCA1000 2-lane interleave needs an even count",
                sensor.samples
            ),
        ));
    }
    Ok(())
}

/// One frame: groups of 4 words `I(n) I(n+1) Q(n) Q(n+1)`, in AdcFrame order.
fn decode(chunk: &[u8], s: &SensorConfig) -> AdcFrame {
    let mut frame = AdcFrame::zeros(s.samples, s.loops, s.num_tx, s.num_rx);
    let word = |w: &[u8]| i16::from_le_bytes([w[0], w[1]]);
    for (pair, group) in frame.data.chunks_exact_mut(2).zip(chunk.chunks_exact(8)) {
        pair[0] = [word(&group[0..2]), word(&group[4..6])];
        pair[1] = [word(&group[2..4]), word(&group[6..8])];
    }
    frame
}

/// Write `frames` as a DCA1000 capture (the inverse of [`read_dca1000`]), atomically.
pub fn write_dca1000(
    path: &Path,
    sensor: &SensorConfig,
    frames: &[&AdcFrame],
) -> Result<(), IoError> {
    check_sensor(path, sensor)?;
    check_even(path, sensor)?;
    if frames.is_empty() {
        return Err(IoError::invalid(
            path,
            "no frames given; expected at least one",
        ));
    }
    let mut out = Vec::with_capacity(frames.len() * sensor.frame_bytes());
    for (i, f) in frames.iter().enumerate() {
        check_frame_shape(path, i, f, sensor)?;
        for pair in f.data.chunks_exact(2) {
            for w in [pair[0][0], pair[1][0], pair[0][1], pair[1][1]] {
                out.extend_from_slice(&w.to_le_bytes());
            }
        }
    }
    write_file_atomic(path, &out)
}
