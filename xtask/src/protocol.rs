//! What an image prints (format: `firmware/src/lib.rs`), parsed.

use std::collections::BTreeMap;

use dbe_radar::FrameStats;
use host_sim::cloud::PointRecord;
use host_sim::core_run::Chain;

use crate::*;
// ---------------------------------------------------------------------------------------------
// Output

/// One CFAR detection as the firmware printed it (`D` line): the core's
/// [`dbe_radar::Detection`], whose `column` is the azimuth bin (DBE chain) or the natural
/// Doppler FFT bin (FFT chain).
pub type FwDetection = dbe_radar::Detection;

/// The ego-velocity estimate as the firmware printed it (`V` line).
#[derive(Clone, Debug, PartialEq)]
pub struct FwEgo {
    /// Velocity of the radar, m/s, radar frame.
    pub velocity: [f32; 3],
    /// Inliers of the final fit.
    pub inliers: u16,
    /// Points that passed the gate.
    pub points: u16,
    /// `ok`, `standstill`, `too_few_points` or `ill_conditioned`.
    pub status: String,
}

/// Everything one firmware run printed.
#[derive(Clone, Debug, PartialEq)]
pub struct FirmwareRun {
    /// Preset name (the core preset: `coloradar`, `iwr6843`).
    pub preset: String,
    /// The chain that ran: the header's `chain` field (`fft`), DBE when absent.
    pub chain: Chain,
    /// `(samples, loops, tx, rx)`.
    pub sizes: (usize, usize, usize, usize),
    /// Instructions per tick of the instruction clock, from the calibration.
    pub instructions_per_tick: u64,
    /// CFAR detections (`D` lines): on the range–azimuth map (DBE chain) or the range–Doppler
    /// map (FFT chain).
    pub detections: Vec<FwDetection>,
    /// Points (`P` lines), `f32` values widened exactly to `f64`.
    pub points: Vec<PointRecord>,
    /// The ego-velocity stage's estimate (`V` line).
    pub ego: Option<FwEgo>,
    /// Frame statistics.
    pub stats: FrameStats,
    /// Instructions per stage (DBE: `range_fft_per_chirp`, `ingest`, `azimuth_capon`, `cfar`,
    /// `elevation_doppler`, `process`, `total`, `setup`, …; FFT: `doppler_fft`, `rd_cfar` and
    /// `angles` instead of the three DBE stages).
    pub stages: BTreeMap<String, u64>,
    /// Stack peak up to and including the chain's setup, bytes.
    pub stack_setup: u64,
    /// Stack peak of the per-frame work (ingest + process) after setup, bytes.
    pub stack_frame: u64,
}

fn field<T: std::str::FromStr>(
    tokens: &[&str],
    i: usize,
    line: usize,
    what: &str,
) -> Result<T, FirmwareError> {
    tokens
        .get(i)
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| FirmwareError::Output {
            line,
            message: format!("expected {what} as field {i}, got {:?}", tokens.get(i)),
        })
}

/// A point line (`P`): ten fields after the tag.
fn parse_point(t: &[&str], line: usize) -> Result<PointRecord, FirmwareError> {
    if t.len() != 11 {
        return Err(FirmwareError::Output {
            line,
            message: format!("a point line has 11 fields, this one {}", t.len()),
        });
    }
    let f = |i: usize, what: &str| field::<f32>(t, i, line, what).map(f64::from);
    Ok(PointRecord {
        range_bin: field(t, 1, line, "range bin")?,
        azimuth_bin: field(t, 2, line, "azimuth bin")?,
        elevation_bin: field(t, 3, line, "elevation bin")?,
        doppler_bin: field(t, 4, line, "Doppler bin")?,
        x: f(5, "x")?,
        y: f(6, "y")?,
        z: f(7, "z")?,
        doppler: f(8, "velocity")?,
        intensity_db: f(9, "power dB")?,
        snr_db: f(10, "SNR dB")?,
    })
}

/// Parse the firmware's output (format: `firmware/src/lib.rs`). Fails unless the run printed
/// its header (with its `chain`), calibration, statistics and stages and ended with `E ok`.
pub fn parse_output(text: &str) -> Result<FirmwareRun, FirmwareError> {
    let mut run = FirmwareRun {
        preset: String::new(),
        chain: Chain::Dbe,
        sizes: (0, 0, 0, 0),
        instructions_per_tick: 0,
        detections: Vec::new(),
        ego: None,
        points: Vec::new(),
        stats: FrameStats::default(),
        stages: BTreeMap::new(),
        stack_setup: 0,
        stack_frame: 0,
    };
    let (mut header, mut stats, mut end) = (false, false, false);
    for (idx, raw) in text.lines().enumerate() {
        let line = idx + 1;
        let t: Vec<&str> = raw.split_whitespace().collect();
        let f = |i: usize, what: &str| field::<f32>(&t, i, line, what);
        let tag = t.first().copied();
        match tag {
            None => {}
            Some("H") => {
                let named = |key: &str| -> Result<usize, FirmwareError> {
                    let pos = t
                        .iter()
                        .position(|x| *x == key)
                        .ok_or(FirmwareError::Output {
                            line,
                            message: format!("header lacks `{key}`"),
                        })?;
                    field(&t, pos + 1, line, key)
                };
                run.preset = field(&t, 2, line, "preset name")?;
                run.chain = match t.iter().position(|x| *x == "chain") {
                    None => {
                        return Err(FirmwareError::Output {
                            line,
                            message: "header lacks `chain`".to_string(),
                        })
                    }
                    Some(pos) => match t.get(pos + 1).copied() {
                        Some("dbe") => Chain::Dbe,
                        Some("fft") => Chain::Fft,
                        other => {
                            return Err(FirmwareError::Output {
                                line,
                                message: format!("unknown chain {other:?} (dbe, fft)"),
                            })
                        }
                    },
                };
                run.sizes = (
                    named("samples")?,
                    named("loops")?,
                    named("tx")?,
                    named("rx")?,
                );
                header = true;
            }
            Some("C") => {
                let instructions: u64 = field(&t, 1, line, "calibration instructions")?;
                let ticks: u64 = field(&t, 2, line, "calibration ticks")?;
                run.instructions_per_tick = field(&t, 3, line, "instructions per tick")?;
                // Two readings, each ±1 tick: the ratio must be the printed integer.
                let per = run.instructions_per_tick;
                if per == 0 || instructions.abs_diff(per * ticks) > 2 * per {
                    return Err(FirmwareError::Output {
                        line,
                        message: format!(
                            "calibration: {instructions} instructions in {ticks} ticks is not \
                             {per} per tick"
                        ),
                    });
                }
            }
            Some("D") => run.detections.push(FwDetection {
                range_bin: field(&t, 1, line, "range bin")?,
                column: field(&t, 2, line, "column")?,
                power: f(3, "power")?,
                level: f(4, "level")?,
            }),
            Some("P") => run.points.push(parse_point(&t, line)?),
            Some("V") => {
                run.ego = Some(FwEgo {
                    velocity: [f(1, "vx")?, f(2, "vy")?, f(3, "vz")?],
                    inliers: field(&t, 4, line, "inliers")?,
                    points: field(&t, 5, line, "ego points")?,
                    status: field(&t, 6, line, "ego status")?,
                });
            }
            Some("F") => {
                run.stats = FrameStats {
                    detections: field(&t, 1, line, "detections")?,
                    detection_overflow: field(&t, 2, line, "detection overflow")?,
                    points: field(&t, 3, line, "points")?,
                    point_overflow: field(&t, 4, line, "point overflow")?,
                    skipped_range_bins: field(&t, 5, line, "skipped range bins")?,
                    detections_without_point: field(&t, 6, line, "detections without point")?,
                    doppler_rejected: field(&t, 7, line, "Doppler-rejected detections")?,
                };
                stats = true;
            }
            Some("S") => {
                let name: String = field(&t, 1, line, "stage name")?;
                let instructions: u64 = field(&t, 2, line, "instructions")?;
                run.stages.insert(name, instructions);
            }
            Some("M") => {
                let bytes: u64 = field(&t, 2, line, "bytes")?;
                match t.get(1).copied() {
                    Some("stack_setup") => run.stack_setup = bytes,
                    Some("stack_frame") => run.stack_frame = bytes,
                    other => {
                        return Err(FirmwareError::Output {
                            line,
                            message: format!("unknown memory figure {other:?}"),
                        })
                    }
                }
            }
            Some("E") => end = t.get(1) == Some(&"ok"),
            Some("X") => {
                return Err(FirmwareError::Output {
                    line,
                    message: format!("the firmware failed: {}", t[1..].join(" ")),
                })
            }
            // Anything else (a panic message, QEMU's own chatter) is not the firmware's format.
            Some(_) => {
                return Err(FirmwareError::Output {
                    line,
                    message: format!("unexpected line {raw:?}"),
                })
            }
        }
    }
    let missing = [
        (header, "the header (H)"),
        (run.instructions_per_tick > 0, "the calibration (C)"),
        (stats, "the frame statistics (F)"),
        (run.stages.contains_key("total"), "the stage costs (S)"),
        (run.stack_frame > 0, "the stack peaks (M)"),
        (end, "the end marker (E ok)"),
    ];
    if let Some((_, what)) = missing.iter().find(|(ok, _)| !ok) {
        return Err(FirmwareError::Output {
            line: 0,
            message: format!("no {what}; the run was cut short"),
        });
    }
    let detections = run.detections.len();
    if run.points.len() != run.stats.points as usize || detections != run.stats.detections as usize
    {
        return Err(FirmwareError::Output {
            line: 0,
            message: format!(
                "{} points and {} detections printed, statistics say {} and {}",
                run.points.len(),
                detections,
                run.stats.points,
                run.stats.detections
            ),
        });
    }
    Ok(run)
}
