//! `dbe bench`: the wall time of every stage of both chains on simulated ColoRadar frames,
//! on one thread, as a table (the host figures of issue 13; the firmware's are the budget).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Args;
use host_sim::core_run::{Chain, CoreRunner, StageTimes};
use host_sim::frame::AdcFrame;
use host_sim::sensor::SensorConfig;
use host_sim::sim::{load_scene, Scene, Simulation};

/// The default scene: the corridor (extended walls, a typical indoor load of detections).
const CORRIDOR: &str = include_str!("../../scenes/corridor.toml");

/// Arguments of `dbe bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Frames timed per chain (after 2 warm-up frames).
    #[arg(long, default_value_t = 50)]
    pub frames: usize,
    /// Scene file to simulate [default: the built-in corridor].
    #[arg(long)]
    pub scene: Option<PathBuf>,
}

/// Distinct frames rendered; the timed frames cycle through them (rendering costs more than
/// processing).
const DISTINCT: usize = 8;

/// `dbe bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 {
        bail!("--frames 0: expected at least one frame");
    }
    let sensor = SensorConfig::coloradar();
    let scene = match &args.scene {
        Some(path) => load_scene(path)?,
        None => Scene::from_toml_str(CORRIDOR, "corridor (built in)")?,
    };
    let sim = Simulation::new(&scene, &sensor)?;
    let frames: Vec<AdcFrame> = (0..DISTINCT.min(args.frames))
        .map(|i| sim.frame(i).map(|f| f.adc))
        .collect::<Result<_, _>>()
        .context("simulating the frames")?;
    outln!(
        "scene `{}`, ColoRadar preset, {} frames per chain, one thread; median wall time per frame",
        scene.name,
        args.frames
    )?;
    outln!()?;
    outln!("| chain | stage | ms | share |")?;
    outln!("|---|---|---:|---:|")?;
    for chain in [Chain::Dbe, Chain::Fft] {
        let params = dbe_radar::Params::defaults(sensor.samples);
        let mut runner = CoreRunner::with_chain(&sensor, params, chain)?;
        for f in frames.iter().take(2) {
            runner.process(f)?;
        }
        let mut times: Vec<StageTimes> = Vec::with_capacity(args.frames);
        for i in 0..args.frames {
            times.push(runner.process_timed(&frames[i % frames.len()])?.1);
        }
        let median = |f: &dyn Fn(&StageTimes) -> Duration| {
            let mut v: Vec<Duration> = times.iter().map(f).collect();
            v.sort();
            v[v.len() / 2]
        };
        let total = median(&|t| t.total());
        let name = match chain {
            Chain::Dbe => "dbe",
            Chain::Fft => "fft",
        };
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let share = |d: Duration| 100.0 * d.as_secs_f64() / total.as_secs_f64();
        let ingest = median(&|t| t.ingest);
        outln!(
            "| {name} | ingest (range FFT, block-float store) | {:.3} | {:.0} % |",
            ms(ingest),
            share(ingest)
        )?;
        for (k, stage) in times[0].names.iter().enumerate() {
            let d = median(&|t| t.stages[k]);
            outln!("| {name} | {stage} | {:.3} | {:.0} % |", ms(d), share(d))?;
        }
        outln!(
            "| {name} | **frame** ({:.0} frames/s) | **{:.3}** | |",
            1.0 / total.as_secs_f64(),
            ms(total)
        )?;
    }
    Ok(())
}
