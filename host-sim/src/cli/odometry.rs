//! `dbe odometry`: a ColoRadar sequence (radar + IMU) → the rig's trajectory by radar-inertial
//! odometry, and its errors when the sequence has ground truth.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use dbe_radar::{EgoEstimator, EgoParams, EgoStatus};
use host_sim::eval::chart::{render, Chart, Series};
use host_sim::io::{
    load_transforms, navigation, read_groundtruth, read_imu, StagedDir, StampedPose,
};
use host_sim::odometry::{self, ekf::EkfParams, metrics, FrameVelocity};
use nalgebra::Vector3;
use serde_json::json;

use super::input::Input;
use super::process::{run_frames, Pipeline};
use super::ParamArgs;

/// Points the ego-velocity stage takes from one frame (the largest preset capacity).
const EGO_POINTS: usize = 256;

/// Arguments of `dbe odometry`.
#[derive(Args, Debug)]
pub struct OdometryArgs {
    /// ColoRadar sequence folder with `single_chip/adc_samples/` and `imu/` (and, for the
    /// evaluation, `groundtruth/`).
    pub input: PathBuf,
    /// Calibration folder: a ColoRadar `calib` folder with `single_chip/` and `transforms/`
    /// [default: SEQ/calib].
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// Processing chain that makes the points.
    #[arg(long, value_enum, default_value = "dbe")]
    pub pipeline: Pipeline,
    /// Output folder (must not exist or be empty; written all-or-nothing):
    /// `trajectory_tum.txt`, `ego_velocity.csv`, `summary.json`, and with ground truth
    /// `groundtruth_tum.txt`, `trajectory_top.png`, `trajectory_side.png`.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub params: ParamArgs,
}

/// The ego-velocity of every frame's points.
fn ego_velocities(
    results: &[super::process::FrameResult],
    mid_frame_s: f64,
) -> Result<Vec<FrameVelocity>> {
    let mut ego = Box::new(EgoEstimator::<EGO_POINTS>::new(EgoParams::DEFAULT)?);
    Ok(results
        .iter()
        .map(|r| {
            let points: Vec<dbe_radar::Point> = r.points.iter().map(|p| p.to_point()).collect();
            FrameVelocity {
                frame_time_s: r.time_s,
                measure_time_s: r.time_s + mid_frame_s,
                points: points.len(),
                ego: ego.estimate(&points),
            }
        })
        .collect())
}

/// Ego-velocity errors against what the ground truth implies.
fn ego_errors(
    frames: &[FrameVelocity],
    gt: &[StampedPose],
    radar: &host_sim::sim::trajectory::Mount,
) -> serde_json::Value {
    let h = odometry::median_spacing(gt);
    let (mut sq, mut n, mut moving, mut moving_ok) = ([0.0f64; 3], 0usize, 0usize, 0usize);
    for f in frames {
        let Some(truth) = odometry::ego_truth(gt, radar, f.measure_time_s, h) else {
            continue;
        };
        let ok = matches!(f.ego.status, EgoStatus::Ok | EgoStatus::Standstill);
        if truth.norm() > 0.1 {
            moving += 1;
            moving_ok += usize::from(ok);
        }
        if ok {
            let v = f.ego.velocity;
            for (i, e) in [v.x, v.y, v.z].into_iter().enumerate() {
                sq[i] += (f64::from(e) - truth[i]).powi(2);
            }
            n += 1;
        }
    }
    let rmse = sq.map(|s| {
        if n > 0 {
            (s / n as f64).sqrt()
        } else {
            f64::NAN
        }
    });
    json!({
        "rmse_mps": {"x": rmse[0], "y": rmse[1], "z": rmse[2]},
        "frames_compared": n,
        "moving_frames": moving,
        "estimated_while_moving_pct": if moving > 0 { 100.0 * moving_ok as f64 / moving as f64 } else { f64::NAN },
        "truth": "central differences of the interpolated ground-truth poses, radar lever arm included",
    })
}

/// A chart coordinate from a pose's index and position.
type Coordinates<'a> = dyn Fn(usize, &Vector3<f64>) -> (f64, f64) + 'a;

/// Top (x–y) and side (distance–z) views of both trajectories, the estimate aligned to the
/// truth by position and yaw.
fn plot(dir: &Path, name: &str, est: &[StampedPose], gt: &[StampedPose]) -> Result<()> {
    let pairs = metrics::associate(est, gt);
    let e: Vec<_> = pairs.iter().map(|(e, _)| e.position).collect();
    let g: Vec<_> = pairs.iter().map(|(_, g)| g.position).collect();
    let al = metrics::align_posyaw(&e, &g);
    let e: Vec<_> = e.iter().map(|p| al.apply(p)).collect();
    let times: Vec<f64> = pairs.iter().map(|(_, g)| g.time_s).collect();
    // One chart of truth (dashed black) and estimate (blue), each point `xy(index, position)`.
    let chart = |title: String, x_label: &str, y_label: &str, xy: &Coordinates<'_>| {
        let line = |label: &str, pts: &[Vector3<f64>], colour: [u8; 3], dashed: bool| Series {
            label: label.into(),
            points: pts.iter().enumerate().map(|(i, p)| xy(i, p)).collect(),
            colour,
            dashed,
        };
        Chart {
            title,
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            y_range: None,
            series: vec![
                line("ground truth", &g, [0, 0, 0], true),
                line("odometry", &e, [0, 114, 178], false),
            ],
        }
    };
    let top = chart(
        format!("{name}: top view (estimate aligned by position and yaw)"),
        "x (m)",
        "y (m)",
        &|_, p| (p.x, p.y),
    );
    render(&top, &dir.join("trajectory_top.png"))?;
    let side = chart(
        format!("{name}: height over time"),
        "time (s)",
        "z (m)",
        &|i, p| (times[i], p.z),
    );
    render(&side, &dir.join("trajectory_side.png"))?;
    Ok(())
}

/// `dbe odometry`.
pub fn run(args: &OdometryArgs) -> Result<()> {
    if !args.input.is_dir() {
        bail!(
            "{}: expected a ColoRadar sequence folder (odometry needs its imu/ data)",
            args.input.display()
        );
    }
    let opened = Input::open(&args.input, args.calib.as_deref())?;
    let Input::Sequence { .. } = &opened.input else {
        bail!(
            "{}: expected a ColoRadar sequence folder",
            args.input.display()
        );
    };
    let calib_dir = args
        .calib
        .clone()
        .unwrap_or_else(|| args.input.join("calib"));
    let transforms = load_transforms(&calib_dir).with_context(|| {
        format!(
            "the radar and IMU mounts ({}/{}/{{{},{}}})",
            calib_dir.display(),
            navigation::TRANSFORMS_DIR,
            navigation::RADAR_TRANSFORM_FILE,
            navigation::IMU_TRANSFORM_FILE
        )
    })?;
    let imu = read_imu(&args.input)?;
    let gt = if navigation::has_groundtruth(&args.input) {
        Some(read_groundtruth(&args.input)?)
    } else {
        None
    };
    let params = args.params.to_params(&opened.sensor)?;
    let staged = StagedDir::new(&args.out)?;
    let started = std::time::Instant::now();
    let results = run_frames(
        &opened.input,
        &opened.sensor,
        &params,
        args.pipeline,
        0..opened.input.len(),
        "odometry",
    )?;
    let frames = ego_velocities(&results, host_sim::score::mid_frame_s(&opened.sensor))?;
    let ekf = EkfParams::default();
    let run = odometry::run(&ekf, &imu, &frames, &transforms).context("radar-inertial odometry")?;
    let dir = staged.path();
    let write = |name: &str, text: &str| {
        std::fs::write(dir.join(name), text).with_context(|| format!("writing {name}"))
    };
    write("trajectory_tum.txt", &odometry::tum_text(&run.trajectory))?;
    write("ego_velocity.csv", &odometry::ego_csv(&frames))?;
    let statuses = |s: EgoStatus| frames.iter().filter(|f| f.ego.status == s).count();
    let mut summary = json!({
        "sequence": args.input.display().to_string(),
        "pipeline": format!("{:?}", args.pipeline).to_lowercase(),
        "frames": frames.len(),
        "points_per_frame": frames.iter().map(|f| f.points).sum::<usize>() as f64 / frames.len().max(1) as f64,
        "ego_status": {
            "ok": statuses(EgoStatus::Ok),
            "standstill": statuses(EgoStatus::Standstill),
            "too_few_points": statuses(EgoStatus::TooFewPoints),
            "ill_conditioned": statuses(EgoStatus::IllConditioned),
        },
        "updates": run.updates,
        "imu_samples": imu.len(),
        "trajectory_poses": run.trajectory.len(),
    });
    let mut line = String::new();
    if let Some(gt) = &gt {
        write("groundtruth_tum.txt", &odometry::tum_text(gt))?;
        summary["ego_velocity"] = ego_errors(&frames, gt, &transforms.radar);
        match metrics::evaluate(&run.trajectory, gt) {
            Some(e) => {
                line = format!(
                    ", path {:.1} m, ATE {:.3} m, drift {:.3} m ({:.2} %), yaw drift {:.2}°",
                    e.path_length_m, e.ate_rmse_m, e.drift.xyz_m, e.drift.xyz_pct, e.drift.yaw_deg
                );
                summary["evaluation"] = serde_json::to_value(&e)?;
                let name = args
                    .input
                    .file_name()
                    .map_or_else(|| "sequence".into(), |n| n.to_string_lossy().into_owned());
                plot(dir, &name, &run.trajectory, gt)?;
            }
            None => summary["evaluation"] = json!(null),
        }
    }
    write("summary.json", &serde_json::to_string_pretty(&summary)?)?;
    staged.commit()?;
    println!(
        "{} frames, {} radar updates ({} gated) in {:.1} s{line} → {}",
        frames.len(),
        run.updates.applied,
        run.updates.gated,
        started.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}
