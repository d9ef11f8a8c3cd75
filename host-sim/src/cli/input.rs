//! Opening what `dbe` is pointed at: a ColoRadar sequence folder or a DCA1000 `.bin` capture,
//! with its calibration.

use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use host_sim::core_run::CoreRunner;
use host_sim::frame::AdcFrame;
use host_sim::io::ticfg::{load_ti_cfg, Board};
use host_sim::io::{coloradar, dca1000, load_calib, Sequence};
use host_sim::sensor::SensorConfig;

/// Frame period assumed for DCA1000 captures, which carry no timestamps (ColoRadar: 10 Hz).
pub const DCA1000_FRAME_PERIOD_S: f64 = 0.1;

/// Recorded frames and the sensor that recorded them.
pub enum Input {
    /// A ColoRadar sequence folder (`root`) and its frames.
    Sequence { root: PathBuf, seq: Box<Sequence> },
    /// A DCA1000 capture, decoded whole (a capture is a few frames).
    Dca1000 {
        path: PathBuf,
        frames: Vec<AdcFrame>,
    },
}

/// Where the calibration came from, for the user.
pub struct Opened {
    pub input: Input,
    pub sensor: SensorConfig,
    pub calib_source: String,
    /// The calibration folder used, if any (none: the built-in values).
    pub calib_dir: Option<PathBuf>,
}

impl Input {
    /// Open `path` with `calib` (a calibration folder), or else a calibration found beside the
    /// input (`<seq>/calib`, or `waveform_cfg.txt` + `antenna_cfg.txt` next to a `.bin`), or
    /// else the built-in ColoRadar single-chip values.
    pub fn open(path: &Path, calib: Option<&Path>, board: Option<Board>) -> Result<Opened> {
        if !path.exists() {
            bail!("{}: no such file or folder (expected a ColoRadar sequence folder or a DCA1000 .bin file)", path.display());
        }
        if let Some(seq) = coloradar_frame_sequence(path) {
            bail!(
                "{}: a single frame of a ColoRadar sequence, not a DCA1000 capture (its layout \
                 is [tx][rx][chirp][sample], a capture's is loop → TX → RX); process the \
                 sequence folder {} (with --frames to choose frames)",
                path.display(),
                seq.display()
            );
        }
        let beside = if path.is_dir() {
            Some(path.join("calib"))
        } else {
            path.parent().map(Path::to_path_buf)
        };
        if calib.is_none() && !path.is_dir() {
            // A DCA1000 capture has no header: its sizes come from a configuration only.
            if let Some(dir) = beside.as_deref().filter(|d| !has_calib(d)) {
                refuse_headerless_capture(path, dir)?;
            }
        }
        let ti_cfg = calib.filter(|c| c.is_file());
        if let Some(f) = ti_cfg.filter(|f| f.extension().is_none_or(|e| e != "cfg")) {
            bail!(
                "{}: --calib takes a folder (a ColoRadar calib folder, or waveform_cfg.txt and \
                 antenna_cfg.txt) or a TI mmWave SDK .cfg file",
                f.display()
            );
        }
        let (sensor, calib_source, calib_dir) = match (calib, ti_cfg, board) {
            (_, Some(c), None) => bail!(
                "{}: a TI .cfg does not say where the antennas are; add --board awr1843boost, \
                 iwr6843isk, awr1642boost or iwr6843aop",
                c.display()
            ),
            (_, None, Some(b)) => bail!(
                "--board {} goes with a TI .cfg given as --calib FILE; a calibration folder \
                 has its own antenna_cfg.txt",
                b.name()
            ),
            (_, Some(cfg), Some(board)) => (
                load_ti_cfg(cfg, board)?,
                format!("{} (TI .cfg, board {})", cfg.display(), board.name()),
                None,
            ),
            (Some(dir), None, None) => (
                load_calib(dir)?,
                dir.display().to_string(),
                Some(dir.to_path_buf()),
            ),
            (None, _, _) => match beside.filter(|d| has_calib(d)) {
                Some(dir) => (
                    load_calib(&dir)?,
                    format!("{} (found beside the input)", dir.display()),
                    Some(dir),
                ),
                None => (
                    SensorConfig::coloradar(),
                    "built-in ColoRadar single-chip values".to_string(),
                    None,
                ),
            },
        };
        // The core's own checks (frame size, waveform, antenna geometry), before any frame
        // is read, with the calibration that failed them named.
        if let Err(e) = CoreRunner::new(&sensor, dbe_radar::Params::defaults(sensor.samples)) {
            bail!("{calib_source}: {e}");
        }
        let input = if path.is_dir() {
            Input::Sequence {
                root: path.to_path_buf(),
                seq: Box::new(coloradar::open_sequence(path, &sensor)?),
            }
        } else {
            let frames = dca1000::read_dca1000(path, &sensor)?;
            Input::Dca1000 {
                path: path.to_path_buf(),
                frames,
            }
        };
        Ok(Opened {
            input,
            sensor,
            calib_source,
            calib_dir,
        })
    }

    /// Frames available.
    pub fn len(&self) -> usize {
        match self {
            Input::Sequence { seq, .. } => seq.len(),
            Input::Dca1000 { frames, .. } => frames.len(),
        }
    }

    /// Frame `i`.
    pub fn frame(&self, i: usize) -> Result<AdcFrame> {
        self.frame_reusing(i, &mut Vec::new())
    }

    /// [`Self::frame`], reading a sequence's frame file through `bytes`, a buffer the caller
    /// keeps from frame to frame.
    pub fn frame_reusing(&self, i: usize, bytes: &mut Vec<u8>) -> Result<AdcFrame> {
        match self {
            Input::Sequence { seq, .. } => Ok(seq.read_frame_reusing(i, bytes)?),
            Input::Dca1000 { path, frames } => frames
                .get(i)
                .cloned()
                .with_context(|| format!("{}: no frame {i}", path.display())),
        }
    }

    /// Time of frame `i`, s: the sequence's timestamp, or `i ·` [`DCA1000_FRAME_PERIOD_S`].
    pub fn time(&self, i: usize) -> f64 {
        match self {
            Input::Sequence { seq, .. } => seq.timestamps().get(i).copied().unwrap_or(0.0),
            Input::Dca1000 { .. } => i as f64 * DCA1000_FRAME_PERIOD_S,
        }
    }

    /// The recording's name for titles: the sequence folder's or the capture file's name.
    pub fn name(&self) -> String {
        let path = match self {
            Input::Sequence { root, .. } => root,
            Input::Dca1000 { path, .. } => path,
        };
        path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    }

    /// The sequence folder, if the input is one (for ground truth lookup).
    pub fn sequence_dir(&self) -> Option<&Path> {
        match self {
            Input::Sequence { root, .. } => Some(root),
            Input::Dca1000 { .. } => None,
        }
    }
}

/// The error for a DCA1000 capture with no (or half a) configuration beside it: name what is
/// missing and, as a hint, the compiled presets whose frame size divides the file.
fn refuse_headerless_capture(path: &Path, dir: &Path) -> Result<()> {
    let (w, a) = ("waveform_cfg.txt", "antenna_cfg.txt");
    match (dir.join(w).is_file(), dir.join(a).is_file()) {
        (true, false) | (false, true) => {
            let (have, lack) = if dir.join(w).is_file() {
                (w, a)
            } else {
                (a, w)
            };
            bail!(
                "{}: has {have} but no {lack}; a DCA1000 capture needs both (or --calib DIR)",
                dir.display()
            );
        }
        _ => {}
    }
    let bytes = std::fs::metadata(path)
        .with_context(|| format!("{}: cannot read", path.display()))?
        .len();
    // The presets whose frame size divides the file, fewest (largest) frames first: many
    // small presets divide any capture, the few largest are the likely ones.
    let mut fits: Vec<(u64, String)> = host_sim::core_run::Preset::ALL
        .iter()
        .filter_map(|p| {
            let (n, k, tx, rx) = p.sizes();
            let frame = (n * k * tx * rx * 4) as u64;
            (bytes > 0 && bytes % frame == 0).then(|| {
                let count = bytes / frame;
                (
                    count,
                    format!("{p}: {count} frame{}", if count == 1 { "" } else { "s" }),
                )
            })
        })
        .collect();
    fits.sort_by_key(|f| f.0);
    const SHOWN: usize = 5;
    let more = fits.len().saturating_sub(SHOWN);
    let named: Vec<String> = fits.into_iter().take(SHOWN).map(|f| f.1).collect();
    let hint = if named.is_empty() {
        "no compiled preset's frame size divides it".to_string()
    } else {
        let more = match more {
            0 => String::new(),
            m => format!(", or {m} smaller presets"),
        };
        format!(
            "its {bytes} bytes are whole frames of {}{more}",
            named.join(" or ")
        )
    };
    bail!(
        "{}: a DCA1000 capture has no header, so its sizes and waveform need a configuration: \
         pass --calib DIR (waveform_cfg.txt and antenna_cfg.txt, or a ColoRadar calib folder) \
         or put both files beside the capture ({hint})",
        path.display()
    )
}

fn has_calib(dir: &Path) -> bool {
    dir.join("single_chip/waveform_cfg.txt").is_file()
        || (dir.join("waveform_cfg.txt").is_file() && dir.join("antenna_cfg.txt").is_file())
}

/// Parse `A..B`, `A..`, `..B` or `I` (one frame) against `len` frames.
pub fn frame_range(spec: Option<&str>, len: usize) -> Result<Range<usize>> {
    let Some(spec) = spec else {
        return Ok(0..len);
    };
    let parse = |s: &str, default: usize| -> Result<usize> {
        if s.is_empty() {
            Ok(default)
        } else {
            s.trim()
                .parse()
                .with_context(|| format!("--frames {spec}: `{s}` is not a frame index"))
        }
    };
    let range = match spec.split_once("..") {
        Some((a, b)) => parse(a, 0)?..parse(b, len)?,
        None => {
            let i = parse(spec, 0)?;
            i..i + 1
        }
    };
    if range.start >= range.end || range.end > len {
        bail!(
            "--frames {spec}: the input has frames 0..{len}; expected a non-empty range inside it"
        );
    }
    Ok(range)
}

/// The sequence folder of a ColoRadar frame file (`SEQ/single_chip/adc_samples/data/
/// frame_<i>.bin`), or `None` for any other path. Decided from the layout of the dataset, not
/// the extension: both formats are `.bin`.
fn coloradar_frame_sequence(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?;
    let index = name.strip_prefix("frame_")?.strip_suffix(".bin")?;
    if index.is_empty() || !index.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let data = path.parent()?;
    let adc = data.parent()?;
    let chip = adc.parent()?;
    let names = [data, adc, chip].map(|d| d.file_name().and_then(|n| n.to_str()));
    (names == [Some("data"), Some("adc_samples"), Some("single_chip")])
        .then(|| chip.parent().map(Path::to_path_buf))
        .flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges() {
        assert_eq!(frame_range(None, 5).unwrap(), 0..5);
        assert_eq!(frame_range(Some("1..3"), 5).unwrap(), 1..3);
        assert_eq!(frame_range(Some("2.."), 5).unwrap(), 2..5);
        assert_eq!(frame_range(Some("..2"), 5).unwrap(), 0..2);
        assert_eq!(frame_range(Some("4"), 5).unwrap(), 4..5);
        assert!(frame_range(Some("3..9"), 5).is_err());
        assert!(frame_range(Some("3..3"), 5).is_err());
        assert!(frame_range(Some("x"), 5).is_err());
    }
}
