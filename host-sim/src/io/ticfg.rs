//! TI mmWave SDK configuration files (`.cfg`: the CLI commands a TI demo is started with) as a
//! sensor description, with the board naming the antenna layout.
//!
//! | command | fields used | becomes |
//! |---|---|---|
//! | `channelCfg rxEn txEn cascading` | RX and TX enable masks | RX count (and the RX positions of the board), TX that may fire |
//! | `adcCfg bits format` | format: 1 or 2 = complex | refused when real (0) |
//! | `profileCfg id f0 idle adcStart rampEnd txPwr txPhase slope txStart samples fs …` | GHz, µs, MHz/µs, ksps | waveform, samples, ADC start time |
//! | `chirpCfg start end profile fVar slopeVar idleVar adcVar txMask` | one TX bit per chirp | the TDM order: slot `t` = the TX of chirp `chirpStart + t` |
//! | `frameCfg chirpStart chirpEnd loops …` | chirps and loops | TX slots per loop, loops per frame |
//! | `compRangeBiasAndRxChanPhase bias re im …` | range bias (m), one (Re, Im) factor per virtual antenna | `range_bias_m`, `channel_gains` (none when every factor is 1) |
//! | `dfeDataOutputMode mode` | 1 = frames | refused otherwise (continuous wave, advanced frames); `advFrameCfg` and `subFrameCfg` likewise |
//!
//! Lines starting with `%` are comments; other commands are ignored. What the chains cannot run
//! is an error naming the line: several profiles, a chirp without a `chirpCfg`, a chirp with no
//! or several TX (simultaneous transmission / BPM), a TX used twice in a loop or not enabled,
//! chirp variations, real ADC output, advanced frames. The board gives the antenna positions
//! (half-wavelength units) and the frequency they are measured at.
//!
//! `compRangeBiasAndRxChanPhase` is read as TI's demos read it: one (Re, Im) pair per physical
//! antenna pair of the board, `TX·4 + RX` by physical index (TX0 RX0, TX0 RX1, …, all of them
//! whichever are enabled), each TDM slot taking the pair of the TX it fires and the enabled RX
//! (the demos' `rxChPhaseComp[txAntOrder[t]·SYS_COMMON_NUM_RX_CHANNEL + rxAntOrder[r]]`). A pair
//! that is 0 is an error: it would erase its channel.

use std::path::Path;

use clap::ValueEnum;

use super::{content_lines, read_text, IoError};
use crate::sensor::SensorConfig;
use dbe_radar::Waveform;

/// A TI evaluation board: its antenna layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Board {
    /// AWR1843BOOST (ColoRadar's radar): TX0 az 0, TX1 az 2 el 1, TX2 az 4; RX az 0..3.
    Awr1843boost,
    /// IWR6843ISK: the same layout as the AWR1843BOOST at 60 GHz.
    Iwr6843isk,
    /// IWR6843AOP: antennas on package, a 2-D virtual array.
    Iwr6843aop,
    /// AWR1642BOOST (and IWR1642/IWR1443BOOST): TX0 az 0, TX1 az 4, both on the RX line; RX
    /// az 0..3. An 8-element line without an elevation row: azimuth-only points.
    Awr1642boost,
}

/// Antenna layout of a board: physical TX and RX positions `(az, el)` in half-wavelength units
/// at `f_design_hz`.
struct Layout {
    tx: &'static [(f32, f32)],
    rx: [(f32, f32); 4],
    f_design_hz: f64,
}

impl Board {
    /// The board's name on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Board::Awr1843boost => "awr1843boost",
            Board::Iwr6843isk => "iwr6843isk",
            Board::Iwr6843aop => "iwr6843aop",
            Board::Awr1642boost => "awr1642boost",
        }
    }

    fn layout(self, path: &Path) -> Result<Layout, IoError> {
        let line = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)];
        match self {
            // F_design as in ColoRadar's calibration of this board (76.8 GHz).
            Board::Awr1843boost => Ok(Layout {
                tx: &[(0.0, 0.0), (2.0, 1.0), (4.0, 0.0)],
                rx: line,
                f_design_hz: 76.8e9,
            }),
            // The TI layout of the 77 GHz 2-TX boards, at ColoRadar's 76.8 GHz design unit.
            Board::Awr1642boost => Ok(Layout {
                tx: &[(0.0, 0.0), (4.0, 0.0)],
                rx: line,
                f_design_hz: 76.8e9,
            }),
            // As in the IWR6843 corner-reflector fixture (layout inferred from its phases).
            Board::Iwr6843isk => Ok(Layout {
                tx: &[(0.0, 0.0), (2.0, 1.0), (4.0, 0.0)],
                rx: line,
                f_design_hz: 60.5e9,
            }),
            Board::Iwr6843aop => Err(IoError::invalid(
                path,
                "--board iwr6843aop: its antennas on package form a 2-D virtual array without \
                 the 8-element uniform azimuth line (+ 4 elevation elements) the chains need; \
                 boards whose TX sit on a line with one raised (awr1843boost, iwr6843isk) run",
            )),
        }
    }
}

/// The numbers after a command, parsed as f64.
fn fields(
    path: &Path,
    line: usize,
    cmd: &str,
    rest: &str,
    min: usize,
) -> Result<Vec<f64>, IoError> {
    let v: Vec<f64> = rest
        .split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| IoError::syntax(path, line, format!("{cmd}: `{t}` is not a number")))
        })
        .collect::<Result<_, _>>()?;
    if v.len() < min {
        return Err(IoError::syntax(
            path,
            line,
            format!("{cmd} has {} values, expected at least {min}", v.len()),
        ));
    }
    Ok(v)
}

/// A whole number from a field.
fn whole(path: &Path, line: usize, cmd: &str, v: f64) -> Result<usize, IoError> {
    if v >= 0.0 && v.fract() == 0.0 && v < 65_536.0 {
        Ok(v as usize)
    } else {
        Err(IoError::syntax(
            path,
            line,
            format!("{cmd}: {v} is not a whole number in 0..65536"),
        ))
    }
}

/// Read a TI `.cfg` for `board` (module docs).
pub fn load_ti_cfg(path: &Path, board: Board) -> Result<SensorConfig, IoError> {
    let text = read_text(path, "a TI mmWave SDK configuration (.cfg)")?;
    let layout = board.layout(path)?;
    let mut channel: Option<(usize, usize, usize)> = None; // (line, rx mask, tx mask)
    let mut profile: Option<(usize, Vec<f64>)> = None;
    let mut chirps: Vec<(usize, usize, usize, usize, Vec<f64>)> = Vec::new(); // line, start, end, mask, vars
    let mut frame: Option<(usize, usize, usize, usize)> = None; // line, start, end, loops
    let mut comp: Option<(usize, Vec<f64>)> = None; // line, values
    for (line, content) in content_lines(&text.replace('%', "#")) {
        let (cmd, rest) = content
            .split_once(char::is_whitespace)
            .unwrap_or((content, ""));
        match cmd {
            "channelCfg" => {
                let v = fields(path, line, cmd, rest, 2)?;
                channel = Some((
                    line,
                    whole(path, line, cmd, v[0])?,
                    whole(path, line, cmd, v[1])?,
                ));
            }
            "adcCfg" => {
                let v = fields(path, line, cmd, rest, 2)?;
                if v[1] == 0.0 {
                    return Err(IoError::syntax(
                        path,
                        line,
                        "adcCfg: real ADC output; the chains need complex samples (adcCfg 2 1)",
                    ));
                }
            }
            "profileCfg" => {
                let v = fields(path, line, cmd, rest, 11)?;
                if let Some((first, p)) = &profile {
                    if p[0] != v[0] {
                        return Err(IoError::syntax(
                            path,
                            line,
                            format!("a second profile (first on line {first}); the chains run one chirp profile"),
                        ));
                    }
                }
                profile = Some((line, v));
            }
            "chirpCfg" => {
                let v = fields(path, line, cmd, rest, 8)?;
                let (start, end) = (whole(path, line, cmd, v[0])?, whole(path, line, cmd, v[1])?);
                let mask = whole(path, line, cmd, v[7])?;
                chirps.push((line, start, end, mask, v[3..7].to_vec()));
            }
            "frameCfg" => {
                let v = fields(path, line, cmd, rest, 3)?;
                frame = Some((
                    line,
                    whole(path, line, cmd, v[0])?,
                    whole(path, line, cmd, v[1])?,
                    whole(path, line, cmd, v[2])?,
                ));
            }
            "compRangeBiasAndRxChanPhase" => {
                comp = Some((line, fields(path, line, cmd, rest, 3)?));
            }
            // Mode 1 is frames of one frameCfg; 2 (continuous wave) has no chirps, 3 (advanced
            // frames) interleaves sub-frames of different chirps and profiles.
            "dfeDataOutputMode" => {
                let v = fields(path, line, cmd, rest, 1)?;
                if v[0] != 1.0 {
                    return Err(IoError::syntax(
                        path,
                        line,
                        format!(
                            "dfeDataOutputMode {}: the chains run frames of one frameCfg \
                             (dfeDataOutputMode 1), not {}",
                            v[0],
                            match v[0] {
                                2.0 => "continuous-wave mode",
                                3.0 => "advanced frames (advFrameCfg, subFrameCfg)",
                                _ => "an unknown mode",
                            }
                        ),
                    ));
                }
            }
            "advFrameCfg" | "subFrameCfg" => {
                return Err(IoError::syntax(
                    path,
                    line,
                    format!(
                        "{cmd}: advanced frames (sub-frames of different chirps) are not \
                         supported; the chains run frames of one frameCfg"
                    ),
                ));
            }
            _ => {}
        }
    }
    let missing = |what: &str| {
        IoError::invalid(path, format!("no {what} command; a TI .cfg for the chains needs channelCfg, profileCfg, chirpCfg and frameCfg"))
    };
    let (cline, rx_mask, tx_mask) = channel.ok_or_else(|| missing("channelCfg"))?;
    let (pline, p) = profile.ok_or_else(|| missing("profileCfg"))?;
    let (fline, first, last, loops) = frame.ok_or_else(|| missing("frameCfg"))?;
    if last < first {
        return Err(IoError::syntax(
            path,
            fline,
            "frameCfg: chirpEnd before chirpStart",
        ));
    }
    // The TDM order: the TX of each chirp of the loop.
    let mut slots = Vec::new();
    for c in first..=last {
        let Some((line, _, _, mask, vars)) =
            chirps.iter().find(|(_, s, e, _, _)| (*s..=*e).contains(&c))
        else {
            return Err(IoError::syntax(
                path,
                fline,
                format!("frameCfg uses chirp {c}, which no chirpCfg defines"),
            ));
        };
        if vars.iter().any(|&x| x != 0.0) {
            return Err(IoError::syntax(path, *line, "chirpCfg: chirp variations (start frequency, slope, idle or ADC start time) are not supported; every chirp must be the profile's"));
        }
        if mask.count_ones() != 1 || *mask >= 8 {
            return Err(IoError::syntax(path, *line, format!("chirpCfg: TX mask {mask} enables {} transmitters; the chains need time-division MIMO, one TX (mask 1, 2 or 4) per chirp", mask.count_ones())));
        }
        let tx = mask.trailing_zeros() as usize;
        if tx >= layout.tx.len() {
            return Err(IoError::syntax(
                path,
                *line,
                format!(
                    "chirpCfg: TX{tx} (mask {mask}) does not exist on the {} ({} TX)",
                    board.name(),
                    layout.tx.len()
                ),
            ));
        }
        if tx_mask & mask == 0 {
            return Err(IoError::syntax(path, *line, format!("chirpCfg: TX{tx} is not enabled in channelCfg (line {cline}, TX mask {tx_mask})")));
        }
        if slots.contains(&tx) {
            return Err(IoError::syntax(
                path,
                *line,
                format!("chirpCfg: TX{tx} fires twice in one loop; each TX once per loop"),
            ));
        }
        slots.push(tx);
    }
    let rx: Vec<(f32, f32)> = (0..4)
        .filter(|r| rx_mask & (1 << r) != 0)
        .map(|r| layout.rx[r])
        .collect();
    if rx.is_empty() || rx_mask >= 16 {
        return Err(IoError::syntax(
            path,
            cline,
            format!("channelCfg: RX mask {rx_mask}; expected 1..15 (RX0..RX3)"),
        ));
    }
    let (samples, adc_start_s) = (whole(path, pline, "profileCfg", p[9])?, p[3] * 1e-6);
    let (range_bias_m, channel_gains) = match comp {
        None => (0.0, None),
        Some((line, v)) => {
            // Physical pairs: every TX of the board × its 4 RX.
            let pairs = layout.tx.len() * 4;
            if v.len() != 1 + 2 * pairs {
                return Err(IoError::syntax(
                    path,
                    line,
                    format!(
                        "compRangeBiasAndRxChanPhase has {} values; expected the range bias and a \
                         (Re, Im) pair for each of the {pairs} TX–RX pairs of the {} ({} TX × 4 RX)",
                        v.len(),
                        board.name(),
                        layout.tx.len()
                    ),
                ));
            }
            let enabled: Vec<usize> = (0..4).filter(|r| rx_mask & (1 << r) != 0).collect();
            let mut gains = Vec::with_capacity(slots.len() * enabled.len());
            for &tx in &slots {
                for &r in &enabled {
                    let i = tx * 4 + r;
                    let g = num_complex::Complex32::new(v[1 + 2 * i] as f32, v[2 + 2 * i] as f32);
                    if !(g.norm_sqr() > 0.0) {
                        return Err(IoError::syntax(
                            path,
                            line,
                            format!(
                                "compRangeBiasAndRxChanPhase: the factor of TX{tx} RX{r} is 0; it \
                                 would erase the channel"
                            ),
                        ));
                    }
                    gains.push(g);
                }
            }
            let identity = gains
                .iter()
                .all(|g| *g == num_complex::Complex32::new(1.0, 0.0));
            (v[0], (!identity).then_some(gains))
        }
    };
    let sensor = SensorConfig {
        samples,
        loops,
        num_tx: slots.len(),
        num_rx: rx.len(),
        waveform: Waveform {
            start_frequency_hz: p[1] * 1e9,
            idle_time_s: p[2] * 1e-6,
            ramp_end_time_s: p[4] * 1e-6,
            slope_hz_per_s: p[7] * 1e12,
            adc_sample_rate_hz: p[10] * 1e3,
        },
        tx: slots.iter().map(|&t| layout.tx[t]).collect(),
        rx,
        f_design_hz: layout.f_design_hz,
        coupling: None,
        channel_gains,
        range_bias_m,
        adc_start_time_s: adc_start_s,
    };
    let sampling_end_us = p[3] + samples as f64 / (p[10] * 1e-3);
    if sampling_end_us > p[4] {
        return Err(IoError::syntax(
            path,
            pline,
            format!(
                "profileCfg: sampling ends at {sampling_end_us:.3} µs (adcStartTime + numAdcSamples / \
                 digOutSampleRate), after rampEndTime {} µs",
                p[4]
            ),
        ));
    }
    super::calib::check_sensor(path, &sensor)?;
    Ok(sensor)
}

/// The `compRangeBiasAndRxChanPhase` line that gives `sensor` (read from a `.cfg` for `board`)
/// the range bias `range_bias_m` and the channel factors `gains` (data order `[tx slot][rx]`):
/// one pair per physical TX–RX pair of the board (module docs), the pairs the `.cfg` does not
/// use set to 1. `None` if a channel of `sensor` is not one of the board's antenna pairs (a
/// sensor that did not come from a `.cfg` for this board) or `gains` is not one per channel.
pub fn comp_range_bias_line(
    board: Board,
    sensor: &SensorConfig,
    range_bias_m: f64,
    gains: &[num_complex::Complex32],
) -> Option<String> {
    let layout = board.layout(Path::new("")).ok()?;
    if gains.len() != sensor.num_tx * sensor.num_rx {
        return None;
    }
    let mut pairs = vec![num_complex::Complex32::new(1.0, 0.0); layout.tx.len() * 4];
    for (c, g) in gains.iter().enumerate() {
        let (t, r) = (c / sensor.num_rx, c % sensor.num_rx);
        let (tx_at, rx_at) = (*sensor.tx.get(t)?, *sensor.rx.get(r)?);
        let tx = layout.tx.iter().position(|p| *p == tx_at)?;
        let rx = layout.rx.iter().position(|p| *p == rx_at)?;
        pairs[tx * 4 + rx] = *g;
    }
    let mut line = format!("compRangeBiasAndRxChanPhase {range_bias_m:.4}");
    for g in pairs {
        line.push_str(&format!(" {:.5} {:.5}", g.re, g.im));
    }
    Some(line)
}
