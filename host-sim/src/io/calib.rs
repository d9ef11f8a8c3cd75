//! ColoRadar calibration files (`calib/single_chip/*.txt`) ⇄ [`SensorConfig`].
//!
//! Formats (see `shared/fixtures/coloradar-calib/README.md`):
//! - `waveform_cfg.txt`: `name value` per line, SI units. Required: `num_rx`, `num_tx`,
//!   `num_adc_samples_per_chirp`, `num_chirps_per_frame` (loops: chirps per TX),
//!   `adc_sample_frequency` (Hz), `start_frequency` (Hz), `idle_time` (s), `ramp_end_time` (s),
//!   `frequency_slope` (Hz/s). Optional: `adc_start_time` (s). Unknown keys are ignored.
//! - `antenna_cfg.txt`: `num_rx N`, `num_tx N`, `F_design GHz`, then `rx idx az el` and
//!   `tx idx az el` lines in any order (half-wavelength units at `F_design`). Unknown keys are
//!   ignored.
//! - `coupling_calib.txt`: `num_tx:3`, `num_rx:4`, `num_range_bins:B`, `num_doppler_bins:D`
//!   (ignored), `data:re,im,re,im,…` in C order `[tx][rx][range bin]`.
//!
//! `#` starts a comment anywhere. Every value must be finite; counts are positive integers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use dbe_radar::config::limits;
use dbe_radar::Waveform;
use num_complex::Complex32;

use super::atomic::{create_dir, write_plain, StagedDir};
use super::{content_lines, read_text, IoError};
use crate::sensor::{Coupling, SensorConfig};

/// File name of the waveform description.
pub const WAVEFORM_FILE: &str = "waveform_cfg.txt";
/// File name of the antenna layout.
pub const ANTENNA_FILE: &str = "antenna_cfg.txt";
/// File name of the coupling calibration.
pub const COUPLING_FILE: &str = "coupling_calib.txt";
/// Sub-folder of a ColoRadar `calib/` folder that holds the single-chip sensor's files.
pub const SINGLE_CHIP: &str = "single_chip";

/// Largest count accepted for sizes (samples, loops, antennas, bins): guards against absurd
/// allocations from a corrupted file.
const MAX_COUNT: usize = 1 << 16;
/// Largest raw frame accepted, bytes (1 GiB; ColoRadar's is 786,432).
const MAX_FRAME_BYTES: usize = 1 << 30;

/// Contents of `waveform_cfg.txt`.
#[derive(Clone, Debug, PartialEq)]
pub struct WaveformCfg {
    /// `num_rx`.
    pub num_rx: usize,
    /// `num_tx`.
    pub num_tx: usize,
    /// `num_adc_samples_per_chirp`.
    pub samples: usize,
    /// `num_chirps_per_frame`: loops per frame (chirps per TX).
    pub loops: usize,
    /// The RF values.
    pub waveform: Waveform,
    /// `adc_start_time`, s, when present.
    pub adc_start_time_s: Option<f64>,
}

/// Contents of `antenna_cfg.txt`.
#[derive(Clone, Debug, PartialEq)]
pub struct AntennaCfg {
    /// `(az, el)` per TX index.
    pub tx: Vec<(f32, f32)>,
    /// `(az, el)` per RX index.
    pub rx: Vec<(f32, f32)>,
    /// `F_design`, converted to Hz.
    pub f_design_hz: f64,
}

/// Parse a number token; `what` names it in errors.
fn number(path: &Path, line: usize, what: &str, token: &str) -> Result<f64, IoError> {
    let v: f64 = token
        .parse()
        .map_err(|_| IoError::syntax(path, line, format!("`{what}`: `{token}` is not a number")))?;
    if !v.is_finite() {
        return Err(IoError::syntax(
            path,
            line,
            format!("`{what}`: `{token}` is not finite; expected a finite number"),
        ));
    }
    Ok(v)
}

/// Parse a count in `1..=MAX_COUNT` (an integral float such as `128.0` is accepted).
fn count(path: &Path, line: usize, what: &str, token: &str) -> Result<usize, IoError> {
    let v = number(path, line, what, token)?;
    if v.fract() != 0.0 || v < 1.0 || v > MAX_COUNT as f64 {
        return Err(IoError::syntax(
            path,
            line,
            format!("`{what}`: `{token}`; expected a whole number in 1..={MAX_COUNT}"),
        ));
    }
    Ok(v as usize)
}

/// Parse an index in `0..MAX_COUNT`.
fn index(path: &Path, line: usize, what: &str, token: &str) -> Result<usize, IoError> {
    token
        .parse::<usize>()
        .ok()
        .filter(|&i| i < MAX_COUNT)
        .ok_or_else(|| {
            IoError::syntax(
                path,
                line,
                format!("{what} index `{token}`; expected a non-negative whole number"),
            )
        })
}

/// `(key, (lowest, highest), unit, [(SI value of one likely wrong unit, its name)])`.
type Plausible = (
    &'static str,
    (f64, f64),
    &'static str,
    &'static [(f64, &'static str)],
);

/// The range each `waveform_cfg.txt` value must lie in: the core's limits
/// ([`dbe_radar::config::limits`]; the ADC start time is the host's own), with the units TI's
/// tools and datasheets write the same values in.
const PLAUSIBLE: [Plausible; 6] = [
    (
        "start_frequency",
        limits::START_FREQUENCY_HZ,
        "Hz",
        &[(1e9, "GHz"), (1e6, "MHz")],
    ),
    (
        "frequency_slope",
        limits::SLOPE_HZ_PER_S,
        "Hz/s",
        &[(1e12, "MHz/µs"), (1e9, "kHz/µs")],
    ),
    (
        "adc_sample_frequency",
        limits::ADC_SAMPLE_RATE_HZ,
        "Hz",
        &[(1e6, "Msps"), (1e3, "ksps")],
    ),
    (
        "idle_time",
        limits::IDLE_TIME_S,
        "s",
        &[(1e-6, "µs"), (1e-3, "ms")],
    ),
    (
        "ramp_end_time",
        limits::RAMP_END_TIME_S,
        "s",
        &[(1e-6, "µs"), (1e-3, "ms")],
    ),
    ("adc_start_time", (0.0, 1e-3), "s", &[(1e-6, "µs")]),
];

/// Check `value` of `key` against [`PLAUSIBLE`]; the error names the likely unit.
fn plausible(path: &Path, line: usize, key: &str, value: f64) -> Result<(), IoError> {
    let Some(&(_, (lo, hi), unit, hints)) = PLAUSIBLE.iter().find(|p| p.0 == key) else {
        return Ok(());
    };
    if (lo..=hi).contains(&value) {
        return Ok(());
    }
    let hint = hints
        .iter()
        .find(|(scale, _)| (lo..=hi).contains(&(value * scale)))
        .map(|(scale, name)| {
            format!(
                "; it looks like {name}: this file is in SI units, write {:e}",
                value * scale
            )
        })
        .unwrap_or_default();
    Err(IoError::syntax(
        path,
        line,
        format!("`{key}` = {value} {unit} is outside what FMCW radars use ({lo:e} to {hi:e} {unit}){hint}"),
    ))
}

/// Parse `waveform_cfg.txt` text; `path` names the file in errors.
pub fn parse_waveform_cfg(path: &Path, text: &str) -> Result<WaveformCfg, IoError> {
    const KEYS: [&str; 10] = [
        "num_rx",
        "num_tx",
        "num_adc_samples_per_chirp",
        "num_chirps_per_frame",
        "adc_sample_frequency",
        "start_frequency",
        "idle_time",
        "ramp_end_time",
        "frequency_slope",
        "adc_start_time",
    ];
    // key → (line, token)
    let mut found: BTreeMap<&str, (usize, &str)> = BTreeMap::new();
    for (line, content) in content_lines(text) {
        let mut tokens = content.split_whitespace();
        let (Some(key), value) = (tokens.next(), tokens.next()) else {
            continue;
        };
        let Some(&key) = KEYS.iter().find(|&&k| k == key) else {
            continue; // unknown key: ignored
        };
        let Some(value) = value else {
            return Err(IoError::syntax(
                path,
                line,
                format!("`{key}` has no value; expected `{key} VALUE`"),
            ));
        };
        if tokens.next().is_some() {
            return Err(IoError::syntax(
                path,
                line,
                format!("`{key}` has more than one value; expected `{key} VALUE`"),
            ));
        }
        if let Some((first, _)) = found.insert(key, (line, value)) {
            return Err(IoError::syntax(
                path,
                line,
                format!("`{key}` given twice (first on line {first})"),
            ));
        }
    }
    let get = |key: &str| -> Result<(usize, &str), IoError> {
        found.get(key).copied().ok_or_else(|| IoError::MissingKey {
            path: path.to_path_buf(),
            key: key.to_string(),
        })
    };
    let cnt = |key: &str| -> Result<usize, IoError> {
        let (l, t) = get(key)?;
        count(path, l, key, t)
    };
    // A number that must be > 0 (or ≥ 0 with `allow_zero`).
    let positive = |key: &str, allow_zero: bool| -> Result<f64, IoError> {
        let (l, t) = get(key)?;
        let v = number(path, l, key, t)?;
        if v > 0.0 || (allow_zero && v == 0.0) {
            plausible(path, l, key, v)?;
            Ok(v)
        } else {
            let rule = if allow_zero { "≥ 0" } else { "> 0" };
            Err(IoError::syntax(
                path,
                l,
                format!("`{key}` = {t}; expected a value {rule}"),
            ))
        }
    };
    let num_rx = cnt("num_rx")?;
    let num_tx = cnt("num_tx")?;
    let samples = cnt("num_adc_samples_per_chirp")?;
    let loops = cnt("num_chirps_per_frame")?;
    let waveform = Waveform {
        adc_sample_rate_hz: positive("adc_sample_frequency", false)?,
        slope_hz_per_s: positive("frequency_slope", false)?,
        start_frequency_hz: positive("start_frequency", false)?,
        idle_time_s: positive("idle_time", true)?,
        ramp_end_time_s: positive("ramp_end_time", false)?,
    };
    let adc_start_time_s = match found.get("adc_start_time") {
        Some(_) => Some(positive("adc_start_time", true)?),
        None => None,
    };
    let sampling_s = samples as f64 / waveform.adc_sample_rate_hz;
    let end_s = adc_start_time_s.unwrap_or(0.0) + sampling_s;
    if end_s > waveform.ramp_end_time_s {
        return Err(IoError::invalid(
            path,
            format!(
                "sampling ends at {:.3} µs (adc_start_time + num_adc_samples_per_chirp / \
                 adc_sample_frequency) after ramp_end_time {:.3} µs; expected the samples to fit \
                 inside the ramp",
                end_s * 1e6,
                waveform.ramp_end_time_s * 1e6
            ),
        ));
    }
    Ok(WaveformCfg {
        num_rx,
        num_tx,
        samples,
        loops,
        waveform,
        adc_start_time_s,
    })
}

/// Parse `antenna_cfg.txt` text; `path` names the file in errors.
pub fn parse_antenna_cfg(path: &Path, text: &str) -> Result<AntennaCfg, IoError> {
    let mut num: [Option<(usize, usize)>; 2] = [None, None]; // rx, tx: (line, value)
    let mut f_design: Option<(usize, f64)> = None;
    let mut elems: [Vec<(usize, usize, f32, f32)>; 2] = [Vec::new(), Vec::new()];
    for (line, content) in content_lines(text) {
        let tokens: Vec<&str> = content.split_whitespace().collect();
        let key = tokens[0];
        match key {
            "num_rx" | "num_tx" | "F_design" => {
                if tokens.len() != 2 {
                    return Err(IoError::syntax(
                        path,
                        line,
                        format!("expected `{key} VALUE`, found `{content}`"),
                    ));
                }
                if key == "F_design" {
                    if let Some((first, _)) = f_design {
                        return Err(IoError::syntax(
                            path,
                            line,
                            format!("`F_design` given twice (first on line {first})"),
                        ));
                    }
                    f_design = Some((line, ghz_to_hz(path, line, tokens[1])?));
                } else {
                    let slot = &mut num[usize::from(key == "num_tx")];
                    if let Some((first, _)) = *slot {
                        return Err(IoError::syntax(
                            path,
                            line,
                            format!("`{key}` given twice (first on line {first})"),
                        ));
                    }
                    *slot = Some((line, count(path, line, key, tokens[1])?));
                }
            }
            "rx" | "tx" => {
                if tokens.len() != 4 {
                    return Err(IoError::syntax(
                        path,
                        line,
                        format!("expected `{key} INDEX AZ EL`, found `{content}`"),
                    ));
                }
                let i = index(path, line, key, tokens[1])?;
                let az = position(path, line, &format!("{key} {i} az"), tokens[2])?;
                let el = position(path, line, &format!("{key} {i} el"), tokens[3])?;
                elems[usize::from(key == "tx")].push((line, i, az, el));
            }
            _ => {} // unknown key: ignored
        }
    }
    let missing = |key: &str| IoError::MissingKey {
        path: path.to_path_buf(),
        key: key.to_string(),
    };
    let (_, num_rx) = num[0].ok_or_else(|| missing("num_rx"))?;
    let (_, num_tx) = num[1].ok_or_else(|| missing("num_tx"))?;
    let (_, f_design_hz) = f_design.ok_or_else(|| missing("F_design"))?;
    let mut out = [Vec::new(), Vec::new()];
    for (kind, (list, n)) in elems.iter().zip([num_rx, num_tx]).enumerate() {
        let key = ["rx", "tx"][kind];
        let mut pos: Vec<Option<(usize, (f32, f32))>> = vec![None; n];
        for &(line, i, az, el) in list {
            let Some(slot) = pos.get_mut(i) else {
                return Err(IoError::syntax(
                    path,
                    line,
                    format!("`{key} {i}`: index out of range; expected 0..{n} (num_{key} {n})"),
                ));
            };
            if let Some((first, _)) = *slot {
                return Err(IoError::syntax(
                    path,
                    line,
                    format!("`{key} {i}` given twice (first on line {first})"),
                ));
            }
            *slot = Some((line, (az, el)));
        }
        let absent: Vec<usize> = (0..n).filter(|&i| pos[i].is_none()).collect();
        if !absent.is_empty() {
            return Err(IoError::invalid(
                path,
                format!("no `{key} INDEX AZ EL` line for index {absent:?}; expected one for each of 0..{n} (num_{key} {n})"),
            ));
        }
        out[kind] = pos.into_iter().flatten().map(|(_, p)| p).collect();
    }
    let [rx, tx] = out;
    Ok(AntennaCfg {
        tx,
        rx,
        f_design_hz,
    })
}

/// Largest antenna coordinate accepted, half-wavelength units: a 5 m aperture at 77 GHz. Real
/// single-chip layouts span < 20; beyond this a value is a unit or typing mistake (and past
/// 3.4·10³⁸ it would not even be an `f32`).
const MAX_POSITION: f64 = 2_560.0;

/// An antenna coordinate (half-wavelength units), within ±[`MAX_POSITION`].
fn position(path: &Path, line: usize, what: &str, token: &str) -> Result<f32, IoError> {
    let v = number(path, line, what, token)?;
    if v.abs() > MAX_POSITION {
        return Err(IoError::syntax(
            path,
            line,
            format!(
                "`{what}` = {token}; expected half-wavelength units within ±{MAX_POSITION} \
                 (single-chip arrays span a few)"
            ),
        ));
    }
    Ok(v as f32)
}

/// `F_design` in GHz → Hz. A plain decimal is scaled by appending `e9` (exact decimal
/// parsing, so `76.8` is exactly 76.8e9 Hz).
fn ghz_to_hz(path: &Path, line: usize, token: &str) -> Result<f64, IoError> {
    let ghz = number(path, line, "F_design", token)?;
    if !(1.0..=1000.0).contains(&ghz) {
        return Err(IoError::syntax(
            path,
            line,
            format!("`F_design` = {token}; expected a frequency in GHz, 1..=1000"),
        ));
    }
    let hz = if token.contains(['e', 'E']) {
        ghz * 1e9
    } else {
        format!("{token}e9").parse().unwrap_or(ghz * 1e9)
    };
    Ok(hz)
}

/// Hz → GHz as an exact decimal string (the digits of `hz` with the point moved 9 places), so
/// that [`ghz_to_hz`] returns `hz` exactly.
fn hz_to_ghz_text(hz: f64) -> String {
    let s = format!("{hz}"); // Display never uses an exponent
    let (int, frac) = s.split_once('.').unwrap_or((&s, ""));
    let int = format!("{int:0>10}"); // at least 10 digits so 9 can move right of the point
    let (head, tail) = int.split_at(int.len() - 9);
    let digits = format!("{tail}{frac}");
    let digits = digits.trim_end_matches('0');
    let head = head.trim_start_matches('0');
    let head = if head.is_empty() { "0" } else { head };
    if digits.is_empty() {
        head.to_string()
    } else {
        format!("{head}.{digits}")
    }
}

/// Parse `coupling_calib.txt` text; `path` names the file in errors.
pub fn parse_coupling_calib(path: &Path, text: &str) -> Result<(usize, usize, Coupling), IoError> {
    let mut values: BTreeMap<&str, (usize, &str)> = BTreeMap::new();
    for (line, content) in content_lines(text) {
        let Some((key, value)) = content.split_once(':') else {
            return Err(IoError::syntax(
                path,
                line,
                "expected `key:value`".to_string(),
            ));
        };
        let key = key.trim();
        if let Some((first, _)) = values.insert(key, (line, value.trim())) {
            return Err(IoError::syntax(
                path,
                line,
                format!("`{key}` given twice (first on line {first})"),
            ));
        }
    }
    let get = |key: &str| -> Result<(usize, &str), IoError> {
        values.get(key).copied().ok_or_else(|| IoError::MissingKey {
            path: path.to_path_buf(),
            key: key.to_string(),
        })
    };
    let cnt = |key: &str| -> Result<usize, IoError> {
        let (l, t) = get(key)?;
        count(path, l, key, t)
    };
    let num_tx = cnt("num_tx")?;
    let num_rx = cnt("num_rx")?;
    let range_bins = cnt("num_range_bins")?;
    let (line, data) = get("data")?;
    let expected = 2 * num_tx * num_rx * range_bins;
    // One trailing comma is tolerated.
    let data = data.strip_suffix(',').unwrap_or(data);
    let tokens: Vec<&str> = data.split(',').map(str::trim).collect();
    if tokens.len() != expected {
        return Err(IoError::syntax(
            path,
            line,
            format!(
                "`data` has {} values; expected {expected} = 2 (re, im) × num_tx {num_tx} × \
                 num_rx {num_rx} × num_range_bins {range_bins}",
                tokens.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(expected / 2);
    for (i, pair) in tokens.chunks_exact(2).enumerate() {
        let (t, r, b) = (
            i / (num_rx * range_bins),
            (i / range_bins) % num_rx,
            i % range_bins,
        );
        let what = format!("data[tx {t}][rx {r}][bin {b}]");
        let re = number(path, line, &what, pair[0])?;
        let im = number(path, line, &what, pair[1])?;
        out.push(Complex32::new(re as f32, im as f32));
    }
    Ok((
        num_tx,
        num_rx,
        Coupling {
            range_bins,
            data: out,
        },
    ))
}

/// The calibration files [`load_calib`] reads from `dir` (the ones that exist, waveform first).
pub fn calib_files(dir: &Path) -> Result<Vec<PathBuf>, IoError> {
    let base = calib_base(dir)?;
    Ok([WAVEFORM_FILE, ANTENNA_FILE, COUPLING_FILE]
        .iter()
        .map(|f| base.join(f))
        .filter(|p| p.is_file())
        .collect())
}

/// Where [`load_calib`] found the files.
fn calib_base(dir: &Path) -> Result<PathBuf, IoError> {
    if !dir.is_dir() {
        return Err(IoError::NotFound {
            path: dir.to_path_buf(),
            expected: "a calibration folder".to_string(),
        });
    }
    let nested = dir.join(SINGLE_CHIP);
    if nested.join(WAVEFORM_FILE).is_file() {
        Ok(nested)
    } else if dir.join(WAVEFORM_FILE).is_file() {
        Ok(dir.to_path_buf())
    } else {
        Err(IoError::NotFound {
            path: dir.to_path_buf(),
            expected: format!(
                "{SINGLE_CHIP}/{WAVEFORM_FILE} (a ColoRadar calib folder) or {WAVEFORM_FILE} \
                 directly in the folder"
            ),
        })
    }
}

/// Load a sensor description from a calibration folder.
///
/// `dir` is either a ColoRadar `calib/` folder (files in `dir/single_chip/`) or a folder that
/// directly holds `waveform_cfg.txt` and `antenna_cfg.txt`. `coupling_calib.txt` is optional.
/// Checks that the files agree on `num_tx` / `num_rx`, that the coupling table does not have
/// more range bins than the sensor, and that a raw frame is at most 1 GiB.
pub fn load_calib(dir: &Path) -> Result<SensorConfig, IoError> {
    let base = calib_base(dir)?;
    let wpath = base.join(WAVEFORM_FILE);
    let apath = base.join(ANTENNA_FILE);
    let cpath = base.join(COUPLING_FILE);
    let w = parse_waveform_cfg(&wpath, &read_text(&wpath, "waveform_cfg.txt")?)?;
    let a = parse_antenna_cfg(
        &apath,
        &read_text(&apath, "antenna_cfg.txt next to waveform_cfg.txt")?,
    )?;
    if (a.tx.len(), a.rx.len()) != (w.num_tx, w.num_rx) {
        return Err(IoError::invalid(
            &apath,
            format!(
                "num_tx {} / num_rx {}; expected num_tx {} / num_rx {} as in {}",
                a.tx.len(),
                a.rx.len(),
                w.num_tx,
                w.num_rx,
                wpath.display()
            ),
        ));
    }
    let coupling = if cpath.exists() {
        let (num_tx, num_rx, c) = parse_coupling_calib(&cpath, &read_text(&cpath, "coupling")?)?;
        if (num_tx, num_rx) != (w.num_tx, w.num_rx) {
            return Err(IoError::invalid(
                &cpath,
                format!(
                    "num_tx {num_tx} / num_rx {num_rx}; expected num_tx {} / num_rx {} as in {}",
                    w.num_tx,
                    w.num_rx,
                    wpath.display()
                ),
            ));
        }
        if c.range_bins > w.samples {
            return Err(IoError::invalid(
                &cpath,
                format!(
                    "num_range_bins {} exceeds the {} range bins of the sensor \
                     (num_adc_samples_per_chirp in {})",
                    c.range_bins,
                    w.samples,
                    wpath.display()
                ),
            ));
        }
        Some(c)
    } else {
        None
    };
    let sensor = SensorConfig {
        samples: w.samples,
        loops: w.loops,
        num_tx: w.num_tx,
        num_rx: w.num_rx,
        waveform: w.waveform,
        tx: a.tx,
        rx: a.rx,
        f_design_hz: a.f_design_hz,
        coupling,
        channel_gains: None,
        range_bias_m: 0.0,
        adc_start_time_s: w.adc_start_time_s.unwrap_or(0.0),
    };
    check_sensor(&wpath, &sensor)?;
    Ok(sensor)
}

/// Check that `sensor` can be written and read back: sizes agree, values finite and positive.
/// `path` names the output in errors.
pub(crate) fn check_sensor(path: &Path, sensor: &SensorConfig) -> Result<(), IoError> {
    let bad = |m: String| Err(IoError::invalid(path, format!("sensor description: {m}")));
    for (name, v) in [
        ("samples", sensor.samples),
        ("loops", sensor.loops),
        ("num_tx", sensor.num_tx),
        ("num_rx", sensor.num_rx),
    ] {
        if v == 0 || v > MAX_COUNT {
            return bad(format!("{name} = {v}; expected 1..={MAX_COUNT}"));
        }
    }
    let bytes = [sensor.samples, sensor.loops, sensor.num_tx, sensor.num_rx]
        .iter()
        .try_fold(4usize, |acc, &v| acc.checked_mul(v))
        .filter(|&b| b <= MAX_FRAME_BYTES);
    if bytes.is_none() {
        return bad(format!(
            "{} samples × {} loops × {} TX × {} RX × 4 bytes per frame; expected at most \
             {MAX_FRAME_BYTES} bytes",
            sensor.samples, sensor.loops, sensor.num_tx, sensor.num_rx
        ));
    }
    if sensor.tx.len() != sensor.num_tx || sensor.rx.len() != sensor.num_rx {
        return bad(format!(
            "{} TX / {} RX positions; expected num_tx {} / num_rx {}",
            sensor.tx.len(),
            sensor.rx.len(),
            sensor.num_tx,
            sensor.num_rx
        ));
    }
    if sensor
        .tx
        .iter()
        .chain(&sensor.rx)
        .any(|&(a, e)| !a.is_finite() || !e.is_finite())
    {
        return bad("an antenna position is not finite".to_string());
    }
    let w = &sensor.waveform;
    for (name, v, zero_ok) in [
        ("adc_sample_frequency", w.adc_sample_rate_hz, false),
        ("frequency_slope", w.slope_hz_per_s, false),
        ("start_frequency", w.start_frequency_hz, false),
        ("idle_time", w.idle_time_s, true),
        ("ramp_end_time", w.ramp_end_time_s, false),
        ("F_design", sensor.f_design_hz, false),
    ] {
        if !(v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0))) {
            return bad(format!("{name} = {v}; expected a finite value > 0"));
        }
    }
    if let Some(c) = &sensor.coupling {
        if c.range_bins == 0 || c.range_bins > sensor.samples {
            return bad(format!(
                "coupling has {} range bins; expected 1..={}",
                c.range_bins, sensor.samples
            ));
        }
        if c.data.len() != sensor.num_tx * sensor.num_rx * c.range_bins {
            return bad(format!(
                "coupling has {} values; expected num_tx × num_rx × range_bins = {}",
                c.data.len(),
                sensor.num_tx * sensor.num_rx * c.range_bins
            ));
        }
        if c.data
            .iter()
            .any(|z| !z.re.is_finite() || !z.im.is_finite())
        {
            return bad("a coupling value is not finite".to_string());
        }
    }
    Ok(())
}

/// Write the three files of `sensor` into `dir` (which exists). No atomicity of its own.
pub(crate) fn write_calib_files(dir: &Path, sensor: &SensorConfig) -> Result<(), IoError> {
    let w = &sensor.waveform;
    let mut waveform = format!(
        "num_rx {}\nnum_tx {}\nnum_adc_samples_per_chirp {}\nnum_chirps_per_frame {}\n\
         adc_sample_frequency {}\nstart_frequency {}\nidle_time {}\nramp_end_time {}\n\
         frequency_slope {}\n",
        sensor.num_rx,
        sensor.num_tx,
        sensor.samples,
        sensor.loops,
        w.adc_sample_rate_hz,
        w.start_frequency_hz,
        w.idle_time_s,
        w.ramp_end_time_s,
        w.slope_hz_per_s
    );
    if sensor.adc_start_time_s > 0.0 {
        waveform.push_str(&format!("adc_start_time {}\n", sensor.adc_start_time_s));
    }
    write_plain(&dir.join(WAVEFORM_FILE), waveform.as_bytes())?;

    let mut antenna = format!(
        "# antenna layout, half-wavelength units at F_design (written by dbe-radar host-sim)\n\
         num_rx {}\nnum_tx {}\nF_design {}\n",
        sensor.num_rx,
        sensor.num_tx,
        hz_to_ghz_text(sensor.f_design_hz)
    );
    for (key, list) in [("rx", &sensor.rx), ("tx", &sensor.tx)] {
        for (i, (az, el)) in list.iter().enumerate() {
            antenna.push_str(&format!("{key} {i} {az} {el}\n"));
        }
    }
    write_plain(&dir.join(ANTENNA_FILE), antenna.as_bytes())?;

    if let Some(c) = &sensor.coupling {
        let data: Vec<String> = c
            .data
            .iter()
            .map(|z| format!("{},{}", z.re, z.im))
            .collect();
        let coupling = format!(
            "num_tx:{}\nnum_rx:{}\nnum_range_bins:{}\nnum_doppler_bins:{}\ndata:{}\n",
            sensor.num_tx,
            sensor.num_rx,
            c.range_bins,
            sensor.loops,
            data.join(",")
        );
        write_plain(&dir.join(COUPLING_FILE), coupling.as_bytes())?;
    }
    Ok(())
}

/// Write `sensor` as a ColoRadar calibration folder: `dir/single_chip/{waveform_cfg,
/// antenna_cfg, coupling_calib}.txt` (coupling only when present), readable by [`load_calib`]
/// with every value bit-exact. `num_doppler_bins` is written as `sensor.loops`.
///
/// `dir` must not exist or be empty; it appears complete or not at all (see [`super::atomic`]).
pub fn write_calib(dir: &Path, sensor: &SensorConfig) -> Result<(), IoError> {
    check_sensor(dir, sensor)?;
    let staged = StagedDir::new(dir)?;
    let single = staged.path().join(SINGLE_CHIP);
    create_dir(&single)?;
    write_calib_files(&single, sensor)?;
    staged.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ghz_text_is_exact() {
        for hz in [
            76.8e9,
            60.5e9,
            77e9,
            76_812_345_678.9,
            1.5e9,
            999.123456789e9,
        ] {
            let s = hz_to_ghz_text(hz);
            let back = ghz_to_hz(Path::new("x"), 1, &s).map_err(|e| e.to_string());
            assert_eq!(back, Ok(hz), "{hz} → {s}");
        }
        assert_eq!(hz_to_ghz_text(76.8e9), "76.8");
        assert_eq!(hz_to_ghz_text(77e9), "77");
    }
}
