//! `dbe process`: recorded frames → point clouds in the formats people's tools read.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use host_sim::cloud::PointRecord;
use host_sim::core_run::{Chain, CoreRunner};
use host_sim::io::pointcloud::{write_coloradar_bin, write_csv, write_pcd, write_ply, PlyEncoding};
use host_sim::io::{write_file_atomic, StagedDir};
use host_sim::sensor::SensorConfig;
use indicatif::{ParallelProgressIterator, ProgressBar, ProgressStyle};
use rayon::prelude::*;

use super::input::{frame_range, Input};
use super::ParamArgs;

/// Which chain turns frames into points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Pipeline {
    /// Range FFT → Capon azimuth → OS-CFAR → Capon elevation → Capon-weighted Doppler.
    Dbe,
    /// The classic FFT chain (the paper's baseline).
    Fft,
}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// `OUT/single_chip/pointclouds/data/radar_pointcloud_<i>.bin` + `timestamps.txt`.
    Coloradar,
    /// `OUT/csv/frame_<i>.csv`.
    Csv,
    /// `OUT/pcd/frame_<i>.pcd` (PCL, binary).
    Pcd,
    /// `OUT/ply/frame_<i>.ply` (binary little-endian).
    Ply,
}

/// Arguments of `dbe process`.
#[derive(Args, Debug)]
pub struct ProcessArgs {
    /// ColoRadar sequence folder or DCA1000 `.bin` capture.
    pub input: PathBuf,
    /// Output folder (must not exist or be empty; written all-or-nothing).
    #[arg(long)]
    pub out: PathBuf,
    /// Calibration folder: ColoRadar `calib` (DIR/single_chip/*.txt) or a folder with
    /// waveform_cfg.txt and antenna_cfg.txt. Default: one found beside the input, else the
    /// built-in ColoRadar single-chip values.
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// Processing chain.
    #[arg(long, value_enum, default_value = "dbe")]
    pub pipeline: Pipeline,
    /// Output formats, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "coloradar")]
    pub format: Vec<Format>,
    /// Frames to process: `A..B` (B excluded), `A..`, `..B` or one index.
    #[arg(long)]
    pub frames: Option<String>,
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Points of one frame.
pub struct FrameResult {
    pub index: usize,
    pub time_s: f64,
    pub points: Vec<PointRecord>,
    pub stats: dbe_radar::FrameStats,
}

/// Run the chosen chain on frames `range` of `input`, in parallel, with a progress bar.
pub fn run_frames(
    input: &Input,
    sensor: &SensorConfig,
    params: &dbe_radar::Params,
    pipeline: Pipeline,
    range: std::ops::Range<usize>,
    label: &str,
) -> Result<Vec<FrameResult>> {
    let chain = match pipeline {
        Pipeline::Dbe => Chain::Dbe,
        Pipeline::Fft => Chain::Fft,
    };
    CoreRunner::with_chain(sensor, *params, chain).context("configuring the core")?;
    let bar = progress(range.len() as u64, label);
    let results: Vec<Result<FrameResult>> = range
        .into_par_iter()
        .progress_with(bar.clone())
        .map_init(
            || CoreRunner::with_chain(sensor, *params, chain),
            |runner, i| {
                let runner = runner.as_mut().map_err(|e| anyhow::anyhow!("{e}"))?;
                let frame = input.frame(i)?;
                let out = runner
                    .process(&frame)
                    .with_context(|| format!("frame {i}"))?;
                Ok(FrameResult {
                    index: i,
                    time_s: input.time(i),
                    points: out.points,
                    stats: out.stats,
                })
            },
        )
        .collect();
    bar.finish_and_clear();
    results.into_iter().collect()
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn progress(len: u64, label: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} frames, {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(label.to_string());
    bar
}

/// Write `results` in `formats` under the staged folder `dir`.
pub fn write_outputs(dir: &Path, results: &[FrameResult], formats: &[Format]) -> Result<()> {
    for format in formats {
        match format {
            Format::Coloradar => {
                let base = dir.join("single_chip/pointclouds");
                let data = base.join("data");
                fs::create_dir_all(&data)
                    .with_context(|| format!("creating {}", data.display()))?;
                let mut times = String::new();
                for (n, r) in results.iter().enumerate() {
                    write_coloradar_bin(
                        &data.join(format!("radar_pointcloud_{n}.bin")),
                        &r.points,
                    )?;
                    times.push_str(&format!("{}\n", r.time_s));
                }
                write_file_atomic(&base.join("timestamps.txt"), times.as_bytes())?;
            }
            Format::Csv | Format::Pcd | Format::Ply => {
                let (sub, ext) = match format {
                    Format::Csv => ("csv", "csv"),
                    Format::Pcd => ("pcd", "pcd"),
                    _ => ("ply", "ply"),
                };
                let folder = dir.join(sub);
                fs::create_dir_all(&folder)
                    .with_context(|| format!("creating {}", folder.display()))?;
                for r in results {
                    let path = folder.join(format!("frame_{}.{ext}", r.index));
                    match format {
                        Format::Csv => write_csv(&path, &r.points)?,
                        Format::Pcd => write_pcd(&path, &r.points)?,
                        _ => write_ply(&path, &r.points, PlyEncoding::BinaryLittleEndian)?,
                    }
                }
            }
        }
    }
    Ok(())
}

/// `dbe process`.
pub fn run(args: &ProcessArgs) -> Result<()> {
    let opened = Input::open(&args.input, args.calib.as_deref())?;
    let range = frame_range(args.frames.as_deref(), opened.input.len())?;
    let params = args.params.to_params(&opened.sensor)?;
    eprintln!(
        "{}: {} frames of {}×{} ({} TX × {} RX), calibration: {}",
        args.input.display(),
        range.len(),
        opened.sensor.samples,
        opened.sensor.loops,
        opened.sensor.num_tx,
        opened.sensor.num_rx,
        opened.calib_source
    );
    let staged = StagedDir::new(&args.out)?;
    let results = run_frames(
        &opened.input,
        &opened.sensor,
        &params,
        args.pipeline,
        range,
        "process",
    )?;
    write_outputs(staged.path(), &results, &args.format)?;
    staged.commit()?;
    let points: usize = results.iter().map(|r| r.points.len()).sum();
    let skipped: u32 = results.iter().map(|r| r.stats.skipped_range_bins).sum();
    let overflow: u32 = results
        .iter()
        .map(|r| r.stats.detection_overflow + r.stats.point_overflow)
        .sum();
    println!(
        "{} frames → {} points ({:.1} per frame) in {}",
        results.len(),
        points,
        points as f64 / results.len().max(1) as f64,
        args.out.display()
    );
    if points == 0 && !results.is_empty() {
        eprintln!(
            "warning: no points in any of the {} frames; check the calibration ({}): a waveform \
             or antenna layout that does not match the recording, or a CFAR threshold too high \
             (--cfar-threshold-db), gives none",
            results.len(),
            opened.calib_source
        );
    }
    if skipped > 0 || overflow > 0 {
        println!("note: {skipped} range bins skipped (covariance not positive definite), {overflow} detections/points over capacity");
    }
    Ok(())
}
