//! `dbe process`: recorded frames → point clouds in the formats people's tools read.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use host_sim::cloud::PointRecord;
use host_sim::core_run::{Chain, CoreRunner, Preset};
use host_sim::io::atomic::write_file_synced;
use host_sim::io::mcap::{write_mcap, McapFrame};
use host_sim::io::pointcloud::{
    encode_coloradar_bin, encode_csv, encode_pcd, encode_ply, PlyEncoding,
};
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
    /// `OUT/points.mcap`: one `foxglove.PointCloud` per frame on `/radar/points` (Foxglove).
    Mcap,
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
    /// waveform_cfg.txt and antenna_cfg.txt; or a TI mmWave SDK `.cfg` file with `--board`.
    /// Default: one found beside the input, else the built-in ColoRadar single-chip values.
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// The TI board whose antenna layout a TI `.cfg` given as `--calib` runs on.
    #[arg(long, value_enum)]
    pub board: Option<host_sim::io::ticfg::Board>,
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
    /// Print nothing but errors and warnings (no header, progress bar or summary line).
    #[arg(long)]
    pub quiet: bool,
}

/// Points of one frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    pub index: usize,
    pub time_s: f64,
    pub points: Vec<PointRecord>,
    pub stats: dbe_radar::FrameStats,
}

/// Run the chosen chain on frames `range` of `input`, in parallel, with a progress bar named
/// `label` (none: no bar).
pub fn run_frames(
    input: &Input,
    sensor: &SensorConfig,
    params: &dbe_radar::Params,
    pipeline: Pipeline,
    range: std::ops::Range<usize>,
    label: Option<&str>,
) -> Result<Vec<FrameResult>> {
    run_frames_with(input, sensor, params, pipeline, range, label, None)
}

/// What [`run_frames_with`] calls for every processed frame: its position in the range and
/// its result (writing its files).
pub type FrameSink<'a> = dyn Fn(usize, &FrameResult) -> Result<()> + Sync + 'a;

/// Threads that run the [`FrameSink`]: writing a file and flushing it to disk mostly waits, and
/// the file system merges concurrent flushes into fewer journal commits (300 ColoRadar point
/// files, written after the frames: 0.10–0.12 s on one thread, 0.06 s on 8, 0.06–0.08 s on 32;
/// measured when each file still took a temporary sibling and a rename).
const WRITERS: usize = 8;

/// [`run_frames`], handing every frame's result to `sink` on [`WRITERS`] threads of its own
/// while the workers go on with the next frames. A sink error counts as that frame's error.
pub fn run_frames_with(
    input: &Input,
    sensor: &SensorConfig,
    params: &dbe_radar::Params,
    pipeline: Pipeline,
    range: std::ops::Range<usize>,
    label: Option<&str>,
    sink: Option<&FrameSink<'_>>,
) -> Result<Vec<FrameResult>> {
    let chain = match pipeline {
        Pipeline::Dbe => Chain::Dbe,
        Pipeline::Fft => Chain::Fft,
    };
    CoreRunner::with_chain(sensor, *params, chain).context("configuring the core")?;
    let bar = match label {
        Some(l) => progress(range.len() as u64, l),
        None => ProgressBar::hidden(),
    };
    // One thread reads the frames in order, a few ahead of the workers, so that reading a
    // recording that is not in the page cache overlaps the processing instead of stalling a
    // worker (200 ColoRadar frames on 2 cores, read from disk: 566–635 frames/s with the
    // workers reading, 773–835 with the reader; from the page cache ≈ 900 either way).
    let ahead = 2 * rayon::current_num_threads();
    let first = range.start;
    // Frames for the sink, and what it reported.
    let (to_sink, for_sink) = std::sync::mpsc::channel::<(usize, FrameResult)>();
    let for_sink = std::sync::Mutex::new(for_sink);
    let sink_errors = std::sync::Mutex::new(Vec::<(usize, anyhow::Error)>::new());
    let mut results: Vec<(usize, Result<FrameResult>)> = std::thread::scope(|scope| {
        if let Some(sink) = sink {
            for _ in 0..WRITERS {
                let (for_sink, sink_errors) = (&for_sink, &sink_errors);
                scope.spawn(move || loop {
                    // The lock is held only while waiting for the next frame.
                    let next = match for_sink.lock() {
                        Ok(r) => r.recv(),
                        Err(_) => return,
                    };
                    let Ok((i, result)) = next else { return };
                    if let Err(e) = sink(i - first, &result) {
                        if let Ok(mut errors) = sink_errors.lock() {
                            errors.push((i, e));
                        }
                    }
                });
            }
        }
        let (send, frames) = std::sync::mpsc::sync_channel(ahead);
        scope.spawn(move || {
            let mut bytes = Vec::new();
            for i in range {
                // The receiver is gone only when the workers have stopped: stop reading.
                if send.send((i, input.frame_reusing(i, &mut bytes))).is_err() {
                    break;
                }
            }
        });
        let results: Vec<(usize, Result<FrameResult>)> = frames
            .into_iter()
            .par_bridge()
            .progress_with(bar.clone())
            .map_init(
                || {
                    (
                        CoreRunner::with_chain(sensor, *params, chain),
                        sink.map(|_| to_sink.clone()),
                    )
                },
                |(runner, to_sink), (i, frame)| {
                    let result = (|| {
                        let runner = runner.as_mut().map_err(|e| anyhow::anyhow!("{e}"))?;
                        let out = runner
                            .process_points(&frame?)
                            .with_context(|| format!("frame {i}"))?;
                        Ok(FrameResult {
                            index: i,
                            time_s: input.time(i),
                            points: out.points,
                            stats: out.stats,
                        })
                    })();
                    if let (Some(to_sink), Ok(r)) = (to_sink, &result) {
                        // The writers outlive the workers (same scope): a send cannot fail
                        // unless a writer panicked, which the scope then reports.
                        let _ = to_sink.send((i, r.clone()));
                    }
                    (i, result)
                },
            )
            .collect();
        // The workers' senders are gone with their states; this one ends the writers' loops.
        drop(to_sink);
        results
    });
    bar.finish_and_clear();
    for (i, e) in sink_errors.into_inner().unwrap_or_default() {
        if let Some(slot) = results.iter_mut().find(|(j, _)| *j == i) {
            slot.1 = Err(e);
        }
    }
    // Frame order, and the first error in frame order, as a sequential run would give.
    results.sort_by_key(|(i, _)| *i);
    results.into_iter().map(|(_, r)| r).collect()
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

/// The MCAP file of `--format mcap`, in the output folder.
pub const MCAP_FILE: &str = "points.mcap";

/// Write `results` in `formats` under the staged folder `dir`.
pub fn write_outputs(dir: &Path, results: &[FrameResult], formats: &[Format]) -> Result<()> {
    create_frame_folders(dir, formats)?;
    for (n, r) in results.iter().enumerate() {
        write_frame_files(dir, formats, n, r)?;
    }
    write_run_files(dir, results, formats)
}

/// The folders [`write_frame_files`] writes into.
fn create_frame_folders(dir: &Path, formats: &[Format]) -> Result<()> {
    for format in formats {
        if let Some(folder) = frame_folder(format) {
            let folder = dir.join(folder);
            fs::create_dir_all(&folder)
                .with_context(|| format!("creating {}", folder.display()))?;
        }
    }
    Ok(())
}

/// Where a per-frame format's files go under the output folder (`None`: one file per run).
fn frame_folder(format: &Format) -> Option<&'static str> {
    match format {
        Format::Coloradar => Some("single_chip/pointclouds/data"),
        Format::Csv => Some("csv"),
        Format::Pcd => Some("pcd"),
        Format::Ply => Some("ply"),
        Format::Mcap => None,
    }
}

/// The files of frame `r`, the `n`-th of the run, in every per-frame format of `formats`,
/// under `dir`, a staging tree made for this run: each file is new there and is flushed to
/// disk before this returns (the tree's commit is the atomic step, so the files need no
/// temporary siblings of their own).
fn write_frame_files(dir: &Path, formats: &[Format], n: usize, r: &FrameResult) -> Result<()> {
    for format in formats {
        let Some(folder) = frame_folder(format) else {
            continue;
        };
        let folder = dir.join(folder);
        let (path, bytes) = match format {
            Format::Coloradar => {
                let path = folder.join(format!("radar_pointcloud_{n}.bin"));
                let bytes = encode_coloradar_bin(&path, &r.points)?;
                (path, bytes)
            }
            Format::Csv => {
                let path = folder.join(format!("frame_{}.csv", r.index));
                let bytes = encode_csv(&path, &r.points)?;
                (path, bytes)
            }
            Format::Pcd => {
                let path = folder.join(format!("frame_{}.pcd", r.index));
                let bytes = encode_pcd(&path, &r.points)?;
                (path, bytes)
            }
            Format::Ply => {
                let path = folder.join(format!("frame_{}.ply", r.index));
                let bytes = encode_ply(&path, &r.points, PlyEncoding::BinaryLittleEndian)?;
                (path, bytes)
            }
            Format::Mcap => continue,
        };
        write_file_synced(&path, &bytes)?;
    }
    Ok(())
}

/// The files of the whole run: the ColoRadar timestamps, the MCAP file.
fn write_run_files(dir: &Path, results: &[FrameResult], formats: &[Format]) -> Result<()> {
    for format in formats {
        match format {
            Format::Coloradar => {
                let times: String = results.iter().map(|r| format!("{}\n", r.time_s)).collect();
                write_file_atomic(
                    &dir.join("single_chip/pointclouds/timestamps.txt"),
                    times.as_bytes(),
                )?;
            }
            Format::Mcap => {
                let frames: Vec<McapFrame<'_>> = results
                    .iter()
                    .map(|r| McapFrame {
                        time_s: r.time_s,
                        points: &r.points,
                    })
                    .collect();
                write_mcap(&dir.join(MCAP_FILE), &frames)?;
            }
            Format::Csv | Format::Pcd | Format::Ply => {}
        }
    }
    Ok(())
}

/// The calibration files of `dir` (a ColoRadar `calib` folder or a folder of the files) with
/// their SHA-256, for the run record.
fn calibration_files(dir: &Path) -> Result<Vec<serde_json::Value>> {
    use sha2::{Digest, Sha256};
    let mut out = Vec::new();
    for path in host_sim::io::calib::calib_files(dir)? {
        let bytes = fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
        let hash: String = Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        out.push(serde_json::json!({"path": path.display().to_string(), "sha256": hash}));
    }
    Ok(out)
}

/// `OUT/run.json`: what ran, on what, with which parameters, and what came out.
fn run_record(
    args: &ProcessArgs,
    opened: &super::input::Opened,
    params: &dbe_radar::Params,
    range: &std::ops::Range<usize>,
    results: &[FrameResult],
    elapsed_s: f64,
) -> Result<serde_json::Value> {
    let points: Vec<usize> = results.iter().map(|r| r.points.len()).collect();
    let files = match &opened.calib_dir {
        Some(d) => calibration_files(d)?,
        None => Vec::new(),
    };
    Ok(serde_json::json!({
        "tool": "dbe process",
        "version": env!("CARGO_PKG_VERSION"),
        "input": args.input.display().to_string(),
        "chain": format!("{:?}", args.pipeline).to_lowercase(),
        "formats": args.format.iter().map(|f| format!("{f:?}").to_lowercase()).collect::<Vec<_>>(),
        "parameters": {
            "tdm_compensation": params.tdm_compensation,
            "subgrid": params.subgrid,
            "coherent_doppler_bins": params.coherent_doppler_bins,
            "spatial_smoothing": params.spatial_smoothing,
            "joint_elevation": params.joint_elevation,
            "coherent_split": params.coherent_split,
            "ring_split": params.ring_split,
            "doppler_test_db": params.doppler_test_db,
            "doppler_agreement_bins": params.doppler_agreement_bins,
            "cfar_threshold_db": params.cfar.threshold_db,
            "cfar_window_gate_db": params.cfar.window_gate_db,
            "loading": params.loading,
            "all": format!("{params:?}"),
        },
        "calibration": {"source": opened.calib_source, "files": files},
        "sensor": {
            "samples": opened.sensor.samples,
            "loops": opened.sensor.loops,
            "tx": opened.sensor.num_tx,
            "rx": opened.sensor.num_rx,
            "preset": Preset::for_sensor(&opened.sensor).map(|p| p.name()).ok(),
            "elevation_measured": opened.sensor.measures_elevation(),
            "coupling_calibrated": opened.sensor.coupling.is_some(),
            "channel_gains": opened.sensor.channel_gains.as_ref().map(|g| {
                g.iter().map(|v| [v.re, v.im]).collect::<Vec<_>>()
            }),
            "range_bias_m": opened.sensor.range_bias_m,
            "elevation": if opened.sensor.measures_elevation() {
                "measured (the array has an elevation row)"
            } else {
                "not measured: the virtual array is one line (no elevation row), every point has elevation 0 (z = 0)"
            },
        },
        "frames": {
            "first_input_index": range.start,
            "count": results.len(),
            "numbering": "coloradar files count from 0 (their timestamps.txt lists the selected frames); csv, pcd and ply files keep the input's frame index",
        },
        "points_total": points.iter().sum::<usize>(),
        "points_per_frame": points,
        "elapsed_s": elapsed_s,
        "frames_per_second": results.len() as f64 / elapsed_s.max(1e-9),
    }))
}

/// `dbe process`.
pub fn run(args: &ProcessArgs) -> Result<()> {
    let opened = Input::open(&args.input, args.calib.as_deref(), args.board)?;
    let range = frame_range(args.frames.as_deref(), opened.input.len())?;
    let params = args.params.to_params(&opened.sensor)?;
    let started = std::time::Instant::now();
    if !args.quiet {
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
        if !opened.sensor.measures_elevation() {
            eprintln!(
                "note: the virtual array is one line (no elevation row): azimuth-only points, \
                 every elevation 0 (z = 0)"
            );
        }
    }
    let staged = StagedDir::new(&args.out)?;
    create_frame_folders(staged.path(), &args.format)?;
    // Every frame's files are written while the next frames are processed.
    let write = |n: usize, r: &FrameResult| write_frame_files(staged.path(), &args.format, n, r);
    let results = run_frames_with(
        &opened.input,
        &opened.sensor,
        &params,
        args.pipeline,
        range.clone(),
        (!args.quiet).then_some("process"),
        Some(&write),
    )?;
    write_run_files(staged.path(), &results, &args.format)?;
    let elapsed_s = started.elapsed().as_secs_f64();
    let record = run_record(args, &opened, &params, &range, &results, elapsed_s)?;
    write_file_atomic(
        &staged.path().join("run.json"),
        serde_json::to_string_pretty(&record)?.as_bytes(),
    )?;
    staged.commit()?;
    let points: usize = results.iter().map(|r| r.points.len()).sum();
    let skipped: u32 = results.iter().map(|r| r.stats.skipped_range_bins).sum();
    let overflow: u32 = results
        .iter()
        .map(|r| r.stats.detection_overflow + r.stats.point_overflow)
        .sum();
    if !args.quiet {
        outln!(
            "{} frames → {} points ({:.1} per frame) in {:.2} s ({:.0} frames/s) → {}",
            results.len(),
            points,
            points as f64 / results.len().max(1) as f64,
            elapsed_s,
            results.len() as f64 / elapsed_s.max(1e-9),
            args.out.display()
        )?;
    }
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
        outln!("note: {skipped} range bins skipped (covariance not positive definite), {overflow} detections/points over capacity")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A six-frame simulated sequence in `dir`.
    fn sequence(dir: &Path) -> Result<super::super::input::Opened> {
        let seq = dir.join("seq");
        super::super::simulate::run(&super::super::simulate::SimulateArgs {
            scene: concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/single_target.toml").into(),
            frames: 6,
            calib: None,
            out: seq.clone(),
            realistic_surfaces: false,
        })?;
        Input::open(&seq, None, None)
    }

    /// The sink sees every frame once, by its position in the range; a sink error is its
    /// frame's error, the first in frame order wins, whatever order the writers met them in.
    #[test]
    fn every_frame_reaches_the_sink_and_its_errors_are_the_runs() -> Result<()> {
        let tmp = tempfile::tempdir()?;
        let opened = sequence(tmp.path())?;
        let params = dbe_radar::Params::defaults(opened.sensor.samples);
        let run = |sink: &FrameSink<'_>| {
            run_frames_with(
                &opened.input,
                &opened.sensor,
                &params,
                Pipeline::Dbe,
                1..6,
                None,
                Some(sink),
            )
        };
        let seen = std::sync::Mutex::new(Vec::new());
        let results = run(&|n, r| {
            seen.lock()
                .map_err(|_| anyhow::anyhow!("poisoned"))?
                .push((n, r.index));
            Ok(())
        })?;
        let mut seen = seen.into_inner().map_err(|_| anyhow::anyhow!("poisoned"))?;
        seen.sort_unstable();
        assert_eq!(seen, (0..5).map(|n| (n, n + 1)).collect::<Vec<_>>());
        assert_eq!(
            results.iter().map(|r| r.index).collect::<Vec<_>>(),
            vec![1, 2, 3, 4, 5]
        );
        let err = run(&|n, _| match n {
            1 | 3 => anyhow::bail!("disk full at {n}"),
            _ => Ok(()),
        })
        .err()
        .map(|e| format!("{e:#}"));
        assert_eq!(err.as_deref(), Some("disk full at 1"));
        Ok(())
    }
}
