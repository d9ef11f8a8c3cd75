//! MCAP output: one file per run, one `foxglove.PointCloud` message per frame, so that
//! Foxglove (and any MCAP reader) opens a `dbe process` run as it is.
//!
//! | record | value |
//! |---|---|
//! | schema | `foxglove.PointCloud`, encoding `jsonschema` ([`POINT_CLOUD_SCHEMA`]) |
//! | channel | topic [`TOPIC`], message encoding `json` |
//! | message | per frame: log and publish time = the frame's timestamp (ns); `frame_id` [`FRAME_ID`]; identity pose |
//! | point data | little-endian float32 `x y z intensity doppler snr` ([`FIELDS`]), stride 24, base64 in the JSON |
//!
//! Units as everywhere in `dbe`: metres in the radar frame (x forward, y left, z up),
//! intensity = Capon power in dB, doppler in m/s (positive receding), snr in dB.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

use base64::Engine as _;

use super::atomic::write_file_atomic;
use super::IoError;
use crate::cloud::PointRecord;

/// The channel's topic.
pub const TOPIC: &str = "/radar/points";
/// The frame of reference of every point cloud.
pub const FRAME_ID: &str = "radar";
/// The packed fields of a point, in order: float32 each.
pub const FIELDS: [&str; 6] = ["x", "y", "z", "intensity", "doppler", "snr"];
/// Bytes per packed point.
pub const POINT_STRIDE: usize = 4 * FIELDS.len();
/// `foxglove.NumericType` of a float32 field.
const FLOAT32: u32 = 7;

/// JSON Schema of the messages: the structure of Foxglove's `foxglove.PointCloud`.
pub const POINT_CLOUD_SCHEMA: &str = r#"{
  "title": "foxglove.PointCloud",
  "description": "Points of one radar frame (dbe-radar): packed little-endian fields, see `fields`",
  "type": "object",
  "properties": {
    "timestamp": {
      "type": "object",
      "title": "time",
      "properties": {
        "sec": { "type": "integer", "minimum": 0 },
        "nsec": { "type": "integer", "minimum": 0, "maximum": 999999999 }
      }
    },
    "frame_id": { "type": "string" },
    "pose": {
      "title": "foxglove.Pose",
      "type": "object",
      "properties": {
        "position": {
          "title": "foxglove.Vector3",
          "type": "object",
          "properties": { "x": { "type": "number" }, "y": { "type": "number" }, "z": { "type": "number" } }
        },
        "orientation": {
          "title": "foxglove.Quaternion",
          "type": "object",
          "properties": {
            "x": { "type": "number" }, "y": { "type": "number" }, "z": { "type": "number" }, "w": { "type": "number" }
          }
        }
      }
    },
    "point_stride": { "type": "integer", "minimum": 0 },
    "fields": {
      "type": "array",
      "items": {
        "title": "foxglove.PackedElementField",
        "type": "object",
        "properties": {
          "name": { "type": "string" },
          "offset": { "type": "integer", "minimum": 0 },
          "type": { "title": "foxglove.NumericType", "type": "integer", "minimum": 0, "maximum": 8 }
        }
      }
    },
    "data": { "type": "string", "contentEncoding": "base64" }
  }
}
"#;

/// One frame of a run: its timestamp (seconds, as the input gives it) and its points.
#[derive(Clone, Copy, Debug)]
pub struct McapFrame<'a> {
    /// Timestamp, s (ColoRadar: Unix time; DCA1000: 0.1 s apart from 0).
    pub time_s: f64,
    /// The frame's points.
    pub points: &'a [PointRecord],
}

/// The packed float32 `x y z intensity doppler snr` of `points`; fails naming the point and
/// field that is not finite as f32.
fn packed(path: &Path, frame: usize, points: &[PointRecord]) -> Result<Vec<u8>, IoError> {
    let mut out = Vec::with_capacity(points.len() * POINT_STRIDE);
    for (i, p) in points.iter().enumerate() {
        let v = [p.x, p.y, p.z, p.intensity_db, p.doppler, p.snr_db].map(|v| v as f32);
        if let Some(k) = v.iter().position(|x| !x.is_finite()) {
            return Err(IoError::invalid(
                path,
                format!(
                    "frame {frame}, point {i}: {} = {}; expected a finite float32",
                    FIELDS[k], v[k]
                ),
            ));
        }
        for x in v {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    Ok(out)
}

/// Nanoseconds of a timestamp; fails unless it is finite, not negative and below 2⁶⁴ ns.
fn nanoseconds(path: &Path, frame: usize, time_s: f64) -> Result<u64, IoError> {
    let ns = time_s * 1e9;
    if !(ns >= 0.0 && ns < u64::MAX as f64) {
        return Err(IoError::invalid(
            path,
            format!("frame {frame}: timestamp {time_s} s cannot be an MCAP time (ns since 0, u64)"),
        ));
    }
    Ok(ns.round() as u64)
}

/// The JSON `foxglove.PointCloud` message of one frame.
fn message(path: &Path, index: usize, frame: &McapFrame<'_>) -> Result<Vec<u8>, IoError> {
    let ns = nanoseconds(path, index, frame.time_s)?;
    let fields: Vec<serde_json::Value> = FIELDS
        .iter()
        .enumerate()
        .map(|(k, name)| serde_json::json!({ "name": name, "offset": 4 * k, "type": FLOAT32 }))
        .collect();
    let data = base64::engine::general_purpose::STANDARD.encode(packed(path, index, frame.points)?);
    let msg = serde_json::json!({
        "timestamp": { "sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000 },
        "frame_id": FRAME_ID,
        "pose": {
            "position": { "x": 0.0, "y": 0.0, "z": 0.0 },
            "orientation": { "x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0 }
        },
        "point_stride": POINT_STRIDE,
        "fields": fields,
        "data": data,
    });
    serde_json::to_vec(&msg).map_err(|e| IoError::invalid(path, format!("frame {index}: {e}")))
}

/// Write `frames` as one MCAP file at `path` (atomically: nothing is left on error). Times
/// must be finite and not negative; frames are written in the order given.
pub fn write_mcap(path: &Path, frames: &[McapFrame<'_>]) -> Result<(), IoError> {
    let fail = |e: mcap::McapError| IoError::invalid(path, format!("MCAP writer: {e}"));
    let mut writer = mcap::Writer::with_options(
        Cursor::new(Vec::new()),
        mcap::WriteOptions::new()
            .compression(None)
            .library(concat!("dbe-radar ", env!("CARGO_PKG_VERSION"))),
    )
    .map_err(fail)?;
    let schema = writer
        .add_schema(
            "foxglove.PointCloud",
            "jsonschema",
            POINT_CLOUD_SCHEMA.as_bytes(),
        )
        .map_err(fail)?;
    let channel = writer
        .add_channel(schema, TOPIC, "json", &BTreeMap::new())
        .map_err(fail)?;
    for (i, frame) in frames.iter().enumerate() {
        let data = message(path, i, frame)?;
        let time = nanoseconds(path, i, frame.time_s)?;
        writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: i as u32,
                    log_time: time,
                    publish_time: time,
                },
                &data,
            )
            .map_err(fail)?;
    }
    writer.finish().map_err(fail)?;
    let bytes = writer.into_inner().into_inner();
    write_file_atomic(path, &bytes)
}

/// One point-cloud message read back: its log time (ns) and points (`x y z intensity doppler
/// snr` as f32), for tests and tools.
#[derive(Clone, Debug, PartialEq)]
pub struct McapCloud {
    /// Log time, ns.
    pub log_time_ns: u64,
    /// The packed points, one `[x, y, z, intensity, doppler, snr]` each.
    pub points: Vec<[f32; 6]>,
}

/// Read every `foxglove.PointCloud` message of [`TOPIC`] from an MCAP file written by
/// [`write_mcap`]; fails naming the file on anything else.
pub fn read_mcap(path: &Path) -> Result<Vec<McapCloud>, IoError> {
    let bytes = super::read_bytes(path, "an MCAP file")?;
    let bad = |m: String| IoError::invalid(path, m);
    let mut out = Vec::new();
    for message in mcap::MessageStream::new(&bytes).map_err(|e| bad(format!("not MCAP: {e}")))? {
        let message = message.map_err(|e| bad(format!("bad record: {e}")))?;
        if message.channel.topic != TOPIC {
            continue;
        }
        let schema = message.channel.schema.as_ref().map(|s| s.name.as_str());
        if schema != Some("foxglove.PointCloud") || message.channel.message_encoding != "json" {
            return Err(bad(format!(
                "{TOPIC}: schema {schema:?}, encoding {}; expected foxglove.PointCloud in json",
                message.channel.message_encoding
            )));
        }
        let json: serde_json::Value = serde_json::from_slice(&message.data)
            .map_err(|e| bad(format!("message at {} ns: {e}", message.log_time)))?;
        let data = json["data"]
            .as_str()
            .and_then(|s| base64::engine::general_purpose::STANDARD.decode(s).ok())
            .ok_or_else(|| {
                bad(format!(
                    "message at {} ns: no base64 `data`",
                    message.log_time
                ))
            })?;
        if json["point_stride"].as_u64() != Some(POINT_STRIDE as u64)
            || data.len() % POINT_STRIDE != 0
        {
            return Err(bad(format!(
                "message at {} ns: stride {} and {} data bytes; expected {POINT_STRIDE}",
                message.log_time,
                json["point_stride"],
                data.len()
            )));
        }
        let points = data
            .chunks_exact(POINT_STRIDE)
            .map(|p| {
                std::array::from_fn(|k| {
                    f32::from_le_bytes([p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3]])
                })
            })
            .collect();
        out.push(McapCloud {
            log_time_ns: message.log_time,
            points,
        });
    }
    Ok(out)
}
