//! `dbe simulate`: a scene → a ColoRadar-layout sequence with calibration and ground truth.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use host_sim::io::{load_calib, write_sequence, StagedDir};
use host_sim::sensor::SensorConfig;
use host_sim::sim::{self, Scene, SimFrame, Simulation};
use rayon::prelude::*;

use super::process::progress;

/// Arguments of `dbe simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Scene file (TOML, see host-sim/scenes/), or `demo` for the built-in demo scene.
    #[arg(long)]
    pub scene: String,
    /// Frames to simulate.
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// Sensor calibration folder [default: built-in ColoRadar single-chip values].
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// Output sequence folder (must not exist or be empty; written all-or-nothing):
    /// `single_chip/adc_samples/`, `calib/single_chip/`, `calib/transforms/`, `groundtruth/`,
    /// `imu/`.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace the scene's `[surfaces]` with the realistic set of `dbe eval` (specular lobe,
    /// bright edges and corners, floor-bounce ghosts); needs a horizontal rectangle as floor.
    #[arg(long)]
    pub realistic_surfaces: bool,
}

/// The scene named on the command line.
pub fn load(scene: &str) -> Result<Scene> {
    if scene == "demo" {
        return Ok(Scene::builtin_demo());
    }
    Ok(sim::load_scene(Path::new(scene))?)
}

/// Simulate `frames` frames of `scene` in parallel, with a progress bar.
pub fn simulate(scene: &Scene, sensor: &SensorConfig, frames: usize) -> Result<Vec<SimFrame>> {
    let simulation = Simulation::new(scene, sensor)?;
    let bar = progress(frames as u64, "simulate");
    let out: Vec<Result<SimFrame>> = (0..frames)
        .into_par_iter()
        .map(|i| {
            let f = simulation.frame(i).with_context(|| format!("frame {i}"));
            bar.inc(1);
            f
        })
        .collect();
    bar.finish_and_clear();
    out.into_iter().collect()
}

/// Write `frames` of `scene` as a sequence with ground truth, IMU and transforms into `dir`
/// (must not exist or be empty).
pub fn write(dir: &Path, scene: &Scene, sensor: &SensorConfig, frames: &[SimFrame]) -> Result<()> {
    let staged = StagedDir::new(dir)?;
    write_into(&staged, dir, scene, sensor, frames)?;
    staged.commit()?;
    Ok(())
}

/// Write `frames` into the staged folder of `dir` (not committed).
fn write_into(
    staged: &StagedDir,
    dir: &Path,
    scene: &Scene,
    sensor: &SensorConfig,
    frames: &[SimFrame],
) -> Result<()> {
    let pairs: Vec<(f64, &host_sim::frame::AdcFrame)> =
        frames.iter().map(|f| (f.time_s, &f.adc)).collect();
    write_sequence(staged.path(), sensor, &pairs)?;
    sim::write_truth(staged.path(), frames)
        .with_context(|| format!("writing ground truth under {}", dir.display()))?;
    sim::write_navigation(staged.path(), scene, frames.len())?;
    Ok(())
}

/// `dbe simulate`.
pub fn run(args: &SimulateArgs) -> Result<()> {
    if args.frames == 0 {
        anyhow::bail!("--frames 0: expected at least one frame");
    }
    let mut scene = load(&args.scene)?;
    if args.realistic_surfaces {
        scene.surfaces = sim::SurfaceModel::realistic();
        scene
            .validate()
            .map_err(|e| anyhow::anyhow!("--realistic-surfaces on {}: {e}", args.scene))?;
    }
    let sensor = match &args.calib {
        Some(dir) => load_calib(dir)?,
        None => SensorConfig::coloradar(),
    };
    // The output folder is checked (and staged) before the simulation, not after it.
    let staged = StagedDir::new(&args.out)?;
    let frames = simulate(&scene, &sensor, args.frames)?;
    write_into(&staged, &args.out, &scene, &sensor, &frames)?;
    staged.commit()?;
    let scatterers: usize = frames.iter().map(|f| f.truth.scatterers).sum();
    let ghosts: usize = frames
        .iter()
        .flat_map(|f| &f.truth.objects)
        .map(|o| o.ghosts)
        .sum();
    outln!(
        "scene `{}`: {} frames ({} scatterers per frame on average{}) → {}",
        scene.name,
        frames.len(),
        scatterers / frames.len(),
        if ghosts > 0 {
            format!(", {} of them floor ghosts", ghosts / frames.len())
        } else {
            String::new()
        },
        args.out.display()
    )?;
    Ok(())
}
