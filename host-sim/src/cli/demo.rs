//! `dbe demo`: simulate the built-in scene, process it, validate the core against the
//! reference, measure accuracy against ground truth, and plot one frame.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use host_sim::io::StagedDir;
use host_sim::score::{self, Accuracy, MATCH_RADIUS_M};
use host_sim::sensor::SensorConfig;
use host_sim::sim::{Scene, SimFrame};

use super::input::Input;
use super::process::{run_frames, write_outputs, Format, FrameResult, Pipeline};
use super::ParamArgs;

/// Marks a folder as `dbe demo` output, which a later demo may replace.
const MARKER: &str = ".dbe-demo";

/// Arguments of `dbe demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output folder; a previous demo's output there is replaced, anything else is refused.
    #[arg(long, default_value = "dbe-demo")]
    pub out: PathBuf,
    /// Frames to simulate.
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Score `results` against the ground truth of `frames` (the crate's one matching rule,
/// [`score`]).
fn accuracy(sensor: &SensorConfig, frames: &[SimFrame], results: &[FrameResult]) -> Accuracy {
    score::accuracy(
        frames
            .iter()
            .zip(results.iter())
            .map(|(f, r)| (&f.truth, r.points.as_slice())),
        score::mid_frame_s(sensor),
    )
}

/// Make room for the demo's output: refuse a non-empty folder that is not a previous demo.
fn clear(out: &Path) -> Result<()> {
    if out.join(MARKER).is_file() {
        fs::remove_dir_all(out)
            .with_context(|| format!("removing the previous demo in {}", out.display()))?;
    } else if out.exists()
        && fs::read_dir(out)
            .map(|mut d| d.next().is_some())
            .unwrap_or(true)
    {
        bail!(
            "{}: exists and is not a previous `dbe demo` output; pass --out NEW_FOLDER",
            out.display()
        );
    }
    Ok(())
}

/// `dbe demo`.
pub fn run(args: &DemoArgs) -> Result<()> {
    let start = Instant::now();
    if args.frames == 0 {
        bail!("--frames 0: expected at least one frame");
    }
    clear(&args.out)?;
    let staged = StagedDir::new(&args.out)?;
    let root = staged.path().to_path_buf();
    let sensor = SensorConfig::coloradar();
    let scene = Scene::builtin_demo();
    let params = args.params.to_params(&sensor)?;

    outln!(
        "1. simulate: scene `{}` ({}), {} frames",
        scene.name,
        scene.description,
        args.frames
    )?;
    let frames = super::simulate::simulate(&scene, &sensor, args.frames)?;
    let seq = root.join("sequence");
    super::simulate::write(&seq, &scene, &sensor, &frames)?;

    outln!("2. process: DBE chain, core fed chirp by chirp")?;
    let opened = Input::open(&seq, None, None)?;
    let results = run_frames(
        &opened.input,
        &opened.sensor,
        &params,
        Pipeline::Dbe,
        0..args.frames,
        Some("process"),
    )?;
    write_outputs(
        &root.join("pointclouds"),
        &results,
        &[Format::Coloradar, Format::Csv],
    )?;

    outln!("3. validate: core (f32, no_std) against the f64 reference implementation")?;
    let reports =
        super::validate::validate(&opened.input, &opened.sensor, &params, 0..args.frames)?;
    let agree = super::validate::print(&reports)?;

    outln!("4. accuracy against ground truth (point targets; {MATCH_RADIUS_M} m match radius)")?;
    let acc = accuracy(&sensor, &frames, &results);
    outln!(
        "   detected {}/{} targets ({:.1} %), azimuth RMSE {:.2}°, elevation RMSE {:.2}°, Doppler RMSE {:.3} m/s",
        acc.detected,
        acc.targets,
        100.0 * acc.detection_rate(),
        acc.azimuth_rmse_deg,
        acc.elevation_rmse_deg,
        acc.doppler_rmse_mps
    )?;
    outln!(
        "   {:.1} points per frame, {:.2} per frame farther than {MATCH_RADIUS_M} m from every object",
        acc.points_per_frame, acc.false_points_per_frame
    )?;

    let mid = args.frames / 2;
    let plots = super::plot::plot_frame(
        &opened.input,
        &opened.sensor,
        &params,
        mid,
        &root.join("plots"),
        host_sim::plot::DYNAMIC_RANGE_DB,
    )?;
    outln!("5. plots of frame {mid}: {} files", plots.len())?;

    let summary = serde_json::json!({
        "frames": args.frames,
        "frames_agreeing_with_reference": reports.iter().filter(|(_, r)| r.agreement.is_match()).count(),
        "accuracy": acc,
    });
    fs::write(
        root.join("summary.json"),
        serde_json::to_string_pretty(&summary)?,
    )
    .context("writing summary.json")?;
    fs::write(
        root.join(MARKER),
        "written by `dbe demo`; a later demo may replace this folder\n",
    )
    .context("writing the demo marker")?;
    staged.commit()?;
    outln!(
        "done in {:.1} s → {} (sequence/, pointclouds/, plots/, summary.json)",
        start.elapsed().as_secs_f64(),
        args.out.display()
    )?;
    if !agree {
        bail!("the core and the reference disagree on some frames (see step 3)");
    }
    Ok(())
}
