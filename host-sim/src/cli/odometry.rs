//! `dbe odometry`: a ColoRadar sequence (radar + IMU) → the rig's trajectory by radar-inertial
//! odometry, and its errors when the sequence has ground truth.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use dbe_radar::EgoStatus;
use host_sim::eval::chart::{render, Chart, Series};
use host_sim::io::{
    load_transforms, navigation, read_groundtruth, read_imu, StagedDir, StampedPose,
};
use host_sim::odometry::{
    self,
    ekf::{EkfParams, Start},
    metrics,
};
use nalgebra::Vector3;
use serde_json::json;

use super::input::Input;
use super::process::{run_frames, Pipeline};
use super::ParamArgs;

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
    /// Give the filter no single-point Doppler updates on frames whose points are too few
    /// (or too flat) for an ego-velocity (an ablation; by default their gated points update
    /// it one by one).
    #[arg(long)]
    pub no_point_updates: bool,
    /// Give the filter no zero-rate updates (an ablation; by default, between two frames
    /// whose points read a standstill, with the IMU at rest in between, the mean gyro rate
    /// updates the gyro bias).
    #[arg(long)]
    pub no_zero_rate_updates: bool,
    /// The radar's time offset to start from, s, in [−1, 1]: a frame's velocity, stamped at
    /// its timestamp plus half its chirps' span, was measured this much later on the IMU's
    /// clock. The filter estimates it from there (± 50 ms) unless --fix-time-offset
    /// [default: 0].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub time_offset: Option<f64>,
    /// Take the time offset (--time-offset, or 0) as exact instead of estimating it.
    #[arg(long)]
    pub fix_time_offset: bool,
    /// The radar's velocity scale to start from, in [0.5, 2]: its velocities read this many
    /// times the true one (a direction bias of the points, a Doppler scale error). The filter
    /// estimates it from there (± 0.03) unless --fix-velocity-scale [default: 1].
    #[arg(long, value_name = "K")]
    pub velocity_scale: Option<f64>,
    /// Take the velocity scale (--velocity-scale, or 1) as exact instead of estimating it.
    #[arg(long)]
    pub fix_velocity_scale: bool,
    #[command(flatten)]
    pub params: ParamArgs,
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
    let chart =
        |title: String, x_label: &str, y_label: &str, equal_aspect: bool, xy: &Coordinates<'_>| {
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
                equal_aspect,
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
        true,
        &|_, p| (p.x, p.y),
    );
    render(&top, &dir.join("trajectory_top.png"))?;
    let side = chart(
        format!("{name}: height over time"),
        "time (s)",
        "z (m)",
        false,
        &|i, p| (times[i], p.z),
    );
    render(&side, &dir.join("trajectory_side.png"))?;
    Ok(())
}

/// `dbe odometry`.
pub fn run(args: &OdometryArgs) -> Result<()> {
    let time_offset_s = args.time_offset.unwrap_or(0.0);
    if !(time_offset_s.abs() <= 1.0) {
        bail!("--time-offset {time_offset_s}: expected a value in [-1, 1] s");
    }
    let velocity_scale = args.velocity_scale.unwrap_or(1.0);
    if !(0.5..=2.0).contains(&velocity_scale) {
        bail!("--velocity-scale {velocity_scale}: expected a value in [0.5, 2]");
    }
    if !args.input.is_dir() {
        bail!(
            "{}: expected a ColoRadar sequence folder (odometry needs its imu/ data)",
            args.input.display()
        );
    }
    let opened = Input::open(&args.input, args.calib.as_deref(), None)?;
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
        Some("odometry"),
    )?;
    let per_frame: Vec<(f64, &[host_sim::cloud::PointRecord])> = results
        .iter()
        .map(|r| (r.time_s, r.points.as_slice()))
        .collect();
    let frames =
        odometry::frame_velocities(&per_frame, host_sim::score::mid_frame_s(&opened.sensor))?;
    let ekf = EkfParams {
        point_updates: !args.no_point_updates,
        zero_rate_updates: !args.no_zero_rate_updates,
        time_offset_s,
        time_offset_sigma: if args.fix_time_offset {
            0.0
        } else {
            EkfParams::default().time_offset_sigma
        },
        velocity_scale,
        velocity_scale_sigma: if args.fix_velocity_scale {
            0.0
        } else {
            EkfParams::default().velocity_scale_sigma
        },
        ..EkfParams::default()
    };
    let run = odometry::run(&ekf, &imu, &frames, &transforms).context("radar-inertial odometry")?;
    if let Start::Moving { time_s } = run.start {
        eprintln!(
            "note: the rig is not at rest during the first {} s (IMU or radar), so the filter started in \
             motion at the first radar velocity ({time_s:.3} s; {} frames before it are not in \
             the trajectory): roll and pitch from the mean specific force, no gyro-bias mean, \
             so expect more heading drift than from a start at rest",
            ekf.init_standstill_s, run.updates.before_start
        );
    }
    if run.updates.widened > 0 {
        eprintln!(
            "note: {} times every radar velocity for {} s or more was gated, and one was taken \
             only after the filter widened its velocity's covariance (a velocity gone wrong: IMU \
             errors beyond its parameters? or a moving object filling the view)",
            run.updates.widened, ekf.widen_after_s
        );
    }
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
        "start": run.start,
        "time_offset": {
            "start_s": time_offset_s,
            "estimated": !args.fix_time_offset,
            "estimate_s": run.time_offset_s.0,
            "sigma_s": run.time_offset_s.1,
        },
        "velocity_scale": {
            "start": velocity_scale,
            "estimated": !args.fix_velocity_scale,
            "estimate": run.velocity_scale.0,
            "sigma": run.velocity_scale.1,
        },
        "imu_samples": imu.len(),
        "trajectory_poses": run.trajectory.len(),
    });
    let mut line = String::new();
    if let Some(gt) = &gt {
        write("groundtruth_tum.txt", &odometry::tum_text(gt))?;
        // The truth: central differences of the interpolated ground-truth poses, the radar's
        // lever arm included.
        let h = odometry::median_spacing(gt);
        let ego = odometry::ego_errors(&frames, |t| {
            odometry::ego_truth(gt, &transforms.radar, t, h)
        });
        summary["ego_velocity"] = serde_json::to_value(&ego)?;
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
    outln!(
        "{} frames, {} radar updates ({} gated), {} point updates on {} frames without one ({} gated), {} zero-rate updates at standstills ({} rejected), radar time offset {:.1} ± {:.1} ms, velocity scale {:.4} ± {:.4} in {:.1} s{line} → {}",
        frames.len(),
        run.updates.applied,
        run.updates.gated,
        run.updates.points_applied,
        run.updates.point_frames,
        run.updates.points_gated,
        run.updates.zero_rate,
        run.updates.zero_rate_rejected,
        run.time_offset_s.0 * 1e3,
        run.time_offset_s.1 * 1e3,
        run.velocity_scale.0,
        run.velocity_scale.1,
        started.elapsed().as_secs_f64(),
        args.out.display()
    )?;
    Ok(())
}
