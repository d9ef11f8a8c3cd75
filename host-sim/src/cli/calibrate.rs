//! `dbe calibrate`: a corner reflector at boresight → the `compRangeBiasAndRxChanPhase` line
//! of a TI `.cfg` (per-channel gain and phase factors, range bias; `host_sim::calibrate`).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use host_sim::calibrate;
use host_sim::io::ticfg::{comp_range_bias_line, Board};

use super::input::{frame_range, Input};

/// Arguments of `dbe calibrate`.
#[derive(Args, Debug)]
pub struct CalibrateArgs {
    /// ColoRadar sequence folder or DCA1000 `.bin` capture of a corner reflector at boresight
    /// (azimuth and elevation 0), alone within the search window, nothing else moving.
    pub input: PathBuf,
    /// Calibration folder or TI `.cfg` (as for `dbe process`).
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// The TI board whose antenna layout a TI `.cfg` given as `--calib` runs on.
    #[arg(long, value_enum)]
    pub board: Option<Board>,
    /// The reflector's distance from the radar, m (its range bias is measured against it).
    #[arg(long, value_name = "M")]
    pub distance: f64,
    /// Half-width of the range window the reflector is searched in, m.
    #[arg(long, value_name = "M", default_value_t = 0.3)]
    pub search: f64,
    /// Frames to average: `A..B`, `A..`, `..B` or one index [default: all].
    #[arg(long)]
    pub frames: Option<String>,
}

/// `dbe calibrate`.
pub fn run(args: &CalibrateArgs) -> Result<()> {
    let opened = Input::open(&args.input, args.calib.as_deref(), args.board)?;
    let range = frame_range(args.frames.as_deref(), opened.input.len())?;
    let frames = range
        .clone()
        .map(|i| opened.input.frame(i))
        .collect::<Result<Vec<_>>>()?;
    let sensor = &opened.sensor;
    let window = dbe_radar::Params::defaults(sensor.samples).range_window;
    let cal = calibrate::measure(&frames, sensor, window, args.distance, args.search)
        .with_context(|| format!("{}: measuring the reflector", args.input.display()))?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "% dbe calibrate {}: {} frame(s), reflector at {:.4} m (range bin {}, {:.1} dB over the \
         median range bin), range bias {:+.4} m against {} m",
        args.input.display(),
        frames.len(),
        cal.range_m,
        cal.range_bin,
        cal.peak_over_median_db,
        cal.range_bias_m,
        args.distance
    );
    let list = |v: &[f64], unit: &str| {
        v.iter()
            .map(|x| format!("{x:.1}{unit}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let _ = writeln!(
        out,
        "% before calibration, channel by channel in data order (TX slot × RX), against the first: \
         phase {}, amplitude {}",
        list(&cal.phases_deg, "°"),
        list(&cal.amplitudes_db, " dB")
    );
    let factors = cal
        .gains
        .iter()
        .map(|g| format!("{:.5} {:.5}", g.re, g.im))
        .collect::<Vec<_>>()
        .join(" ");
    match args
        .board
        .and_then(|b| comp_range_bias_line(b, sensor, cal.range_bias_m, &cal.gains))
    {
        Some(line) => {
            let _ = writeln!(out, "{line}");
        }
        None => {
            let _ = writeln!(
                out,
                "% no TI board: the factors in data order, as dbe_set_channel_gains takes them \
                 ([tx slot][rx][re, im]), and the range bias for dbe_set_range_bias\n\
                 % channel_gains {factors}\n% range_bias_m {:.4}",
                cal.range_bias_m
            );
        }
    }
    out!("{out}")?;
    Ok(())
}
