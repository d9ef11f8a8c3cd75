//! `dbe validate`: the core, fed chirp by chirp, against the f64 reference implementation.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;
use host_sim::harness::{format_indexed_table, FrameReport, Validator};
use host_sim::sensor::SensorConfig;
use rayon::prelude::*;

use super::input::{frame_range, Input};
use super::process::progress;
use super::ParamArgs;

/// Arguments of `dbe validate`.
#[derive(Args, Debug)]
pub struct ValidateArgs {
    /// ColoRadar sequence folder or DCA1000 `.bin` capture.
    pub input: PathBuf,
    /// Calibration folder (as for `dbe process`).
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// The TI board whose antenna layout a TI `.cfg` given as `--calib` runs on.
    #[arg(long, value_enum)]
    pub board: Option<host_sim::io::ticfg::Board>,
    /// Frames to validate: `A..B`, `A..`, `..B` or one index.
    #[arg(long)]
    pub frames: Option<String>,
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Validate frames `range` of `input`, in parallel; reports in frame order.
pub fn validate(
    input: &Input,
    sensor: &SensorConfig,
    params: &dbe_radar::Params,
    range: std::ops::Range<usize>,
) -> Result<Vec<(usize, FrameReport)>> {
    Validator::new(sensor, *params)?;
    let bar = progress(range.len() as u64, "validate");
    let reports: Vec<Result<(usize, FrameReport)>> = range
        .into_par_iter()
        .map_init(
            || Validator::new(sensor, *params),
            |v, i| {
                let v = v.as_mut().map_err(|e| anyhow::anyhow!("{e}"))?;
                let report = v.check(&input.frame(i)?)?;
                bar.inc(1);
                Ok((i, report))
            },
        )
        .collect();
    bar.finish_and_clear();
    reports.into_iter().collect()
}

/// Print the table; `true` when every frame agrees.
pub fn print(reports: &[(usize, FrameReport)]) -> Result<bool> {
    out!("{}", format_indexed_table(reports))?;
    Ok(reports.iter().all(|(_, r)| r.agreement.is_match()))
}

/// `dbe validate`.
pub fn run(args: &ValidateArgs) -> Result<()> {
    let opened = Input::open(&args.input, args.calib.as_deref(), args.board)?;
    let range = frame_range(args.frames.as_deref(), opened.input.len())?;
    let params = args.params.to_params(&opened.sensor)?;
    eprintln!("calibration: {}", opened.calib_source);
    let reports = validate(&opened.input, &opened.sensor, &params, range)?;
    if !print(&reports)? {
        bail!("the core and the reference disagree (see the table above)");
    }
    Ok(())
}
