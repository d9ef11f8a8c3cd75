//! The paper's Table III in simulation: radar-inertial odometry fed by the DBE and by the FFT
//! chain on the four simulated sequences (`scenes/odometry/`), several seeds each.
//!
//! Per sequence and seed the scene's seed is replaced by a mix of the evaluation seed and the
//! seed index, so scatterer phases, ADC noise and the IMU's biases and noise are drawn anew;
//! both chains process the same simulated frames and feed the same EKF ([`crate::odometry`],
//! default parameters) with the same IMU samples. The ego-velocity truth is exact (the
//! radar's velocity in its own frame at each frame's mean chirp time), the trajectory truth
//! the rig's base pose at each frame time.

use serde::Serialize;

use super::bench::Bench;
use super::scenarios::{par_run, scene_file, SceneFile};
use super::EvalError;
use crate::cloud::PointRecord;
use crate::io::StampedPose;
use crate::odometry::ekf::{EkfParams, Start};
use crate::odometry::{self, metrics, EgoErrors, FrameVelocity, RadialConsistency, UpdateCounts};
use crate::sensor::SensorConfig;
use crate::sim::{render::mix, scene_imu, Scene, Simulation};

/// The simulated sequences, after the paper's four (hallways, outdoors, aspen, army), then
/// the same four with the simulator's realistic surfaces (`<name>_realistic`:
/// [`crate::sim::SurfaceModel::realistic`], specular walls, bright edges and corners,
/// floor-bounce ghosts), on the same seeds: the same IMU draw and ADC noise, so each twin is
/// a paired comparison of what the surfaces change. The goals are the plain four's
/// ([`PAPER_SEQUENCES`]).
pub const SEQUENCES: [SceneFile; 8] = [
    scene_file("hallways", HALLWAYS, false),
    scene_file("outdoors", OUTDOORS, false),
    scene_file("aspen", ASPEN, false),
    scene_file("army", ARMY, false),
    scene_file("hallways_realistic", HALLWAYS, true),
    scene_file("outdoors_realistic", OUTDOORS, true),
    scene_file("aspen_realistic", ASPEN, true),
    scene_file("army_realistic", ARMY, true),
];

/// How many of [`SEQUENCES`] come first as the paper's four, with the scenes' own surfaces.
pub const PAPER_SEQUENCES: usize = 4;

const HALLWAYS: &str = include_str!("../../scenes/odometry/hallways.toml");
const OUTDOORS: &str = include_str!("../../scenes/odometry/outdoors.toml");
const ASPEN: &str = include_str!("../../scenes/odometry/aspen.toml");
const ARMY: &str = include_str!("../../scenes/odometry/army.toml");

/// Stream of the per-seed scene seeds.
const SEED_STREAM: u64 = 0x4F44_4F4D;

/// Where the moving-start run cuts each sequence, s: 1 s after its 2 s standstill, while the
/// rig walks ([`crate::odometry::start`]).
pub const MOVING_START_CUT_S: f64 = 3.0;

/// The time offset the stamp test puts on every radar velocity, s: stamped this much early
/// (a velocity stamped t was measured at t + 0.05 s), as a frame-start stamp taken for the
/// middle of the chirps or a transfer delay would.
pub const STAMP_TEST_OFFSET_S: f64 = 0.05;

/// One chain on one sequence and seed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OdometryRow {
    /// Sequence.
    pub sequence: String,
    /// Seed index.
    pub seed: usize,
    /// Variant (chain).
    pub variant: String,
    /// Frames.
    pub frames: usize,
    /// Mean points per frame.
    pub points_per_frame: f64,
    /// Ego-velocity errors against the exact truth.
    pub ego: EgoErrors,
    /// The static points' radial velocities against their directions and the truth.
    pub radial: RadialConsistency,
    /// What the filter did with the frames.
    pub updates: UpdateCounts,
    /// Trajectory errors (`None` if the filter could not run).
    pub errors: Option<metrics::TrajectoryErrors>,
    /// The same filter without point updates on frames without an estimate (the ablation of
    /// [`EkfParams::point_updates`]): XYZ drift, % of the path.
    pub xyz_pct_without_point_updates: Option<f64>,
    /// The same filter on the sequence cut at [`MOVING_START_CUT_S`] (IMU data and frames
    /// before it dropped), so that it starts in motion: XYZ drift, % of the shorter path.
    pub xyz_pct_moving_start: Option<f64>,
    /// The same filter without zero-rate updates (the ablation of
    /// [`EkfParams::zero_rate_updates`]), from rest and in motion: XYZ drift, % of the path.
    pub xyz_pct_without_zero_rate: [Option<f64>; 2],
    /// ATE without zero-rate updates, from rest, m.
    pub ate_m_without_zero_rate: Option<f64>,
    /// The filter's estimate of the radar's time offset (truth 0), s.
    pub time_offset_s: Option<f64>,
    /// The stamp test: every radar velocity stamped [`STAMP_TEST_OFFSET_S`] early. XYZ drift
    /// (% of the path) with the offset taken as 0 and estimated.
    pub xyz_pct_stamp_test: [Option<f64>; 2],
    /// The stamp test's ATE, m, with the offset taken as 0 and estimated.
    pub ate_m_stamp_test: [Option<f64>; 2],
    /// The stamp test's estimate of the offset, s.
    pub time_offset_stamp_test_s: Option<f64>,
    /// The filter's estimate of the radar's velocity scale.
    pub velocity_scale: Option<f64>,
    /// The same filter with the velocity scale taken as 1 (the ablation of
    /// [`EkfParams::velocity_scale_sigma`]): XYZ drift, % of the path, and ATE, m.
    pub fixed_scale: [Option<f64>; 2],
    /// Why the filter could not run.
    pub failure: Option<String>,
}

/// Frames of a sequence: until its trajectory's last waypoint, at most `limit`.
pub fn frame_count(scene: &Scene, limit: Option<usize>) -> usize {
    let n = (scene.sensor.end_time_s() * scene.frame_rate_hz).floor() as usize;
    limit.map_or(n, |l| n.min(l)).max(1)
}

/// Run the variants `which` of `bench` on every sequence for `seeds` seeds; `progress`
/// receives a line as each sequence and seed is done (the whole section takes minutes).
pub fn run_odometry(
    sensor: &SensorConfig,
    bench: &Bench,
    which: &[usize],
    seed: u64,
    seeds: usize,
    limit: Option<usize>,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<OdometryRow>, EvalError> {
    let mid = crate::score::mid_frame_s(sensor);
    let mut rows = Vec::new();
    let (start, runs) = (std::time::Instant::now(), SEQUENCES.len() * seeds);
    for (s, file) in SEQUENCES.iter().enumerate() {
        for k in 0..seeds {
            let mut scene = file.scene()?;
            scene.seed = mix(mix(mix(seed, SEED_STREAM), scene.seed), k as u64);
            let sim = Simulation::new(&scene, sensor)?;
            let n = frame_count(&scene, limit);
            let imu = scene_imu(&scene, n);
            let indices: Vec<usize> = (0..n).collect();
            // points[frame][variant]
            let points: Vec<Vec<Vec<PointRecord>>> = par_run(&indices, |&i, buf| {
                let frame = sim.frame(i)?;
                Ok(bench
                    .run(&frame.adc, which, buf)?
                    .into_iter()
                    .map(|o| o.map(|o| o.points).unwrap_or_default())
                    .collect())
            })?;
            let truth: Vec<StampedPose> = (0..n)
                .map(|i| scene.sensor.pose(sim.time_s(i)).stamped(sim.time_s(i)))
                .collect();
            for (slot, &v) in which.iter().enumerate() {
                let per_frame: Vec<(f64, &[PointRecord])> = points
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (sim.time_s(i), p[slot].as_slice()))
                    .collect();
                let frames = odometry::frame_velocities(&per_frame, mid)
                    .map_err(|e| EvalError::Setup(format!("ego-velocity parameters: {e:?}")))?;
                let velocity = |t: f64| Some(scene.radar_velocity(t));
                let ego = odometry::ego_errors(&frames, velocity);
                let at_mid: Vec<(f64, &[PointRecord])> =
                    per_frame.iter().map(|&(t, p)| (t + mid, p)).collect();
                let radial = RadialConsistency::measure(&at_mid, velocity);
                let run = odometry::run(&EkfParams::default(), &imu, &frames, &scene.rig);
                let cut_imu: Vec<_> = imu
                    .iter()
                    .filter(|s| s.time_s >= MOVING_START_CUT_S)
                    .copied()
                    .collect();
                let cut_frames: Vec<_> = frames
                    .iter()
                    .filter(|f| f.frame_time_s >= MOVING_START_CUT_S)
                    .cloned()
                    .collect();
                // The trajectory errors of the filter with `params`, from rest or (cut at
                // MOVING_START_CUT_S) in motion; `None` if it started the other way.
                let errors = |params: &EkfParams, moving: bool| {
                    let (imu, frames) = if moving {
                        (&cut_imu, &cut_frames)
                    } else {
                        (&imu, &frames)
                    };
                    odometry::run(params, imu, frames, &scene.rig)
                        .ok()
                        .filter(|r| matches!(r.start, Start::Moving { .. }) == moving)
                        .and_then(|r| metrics::evaluate(&r.trajectory, &truth))
                };
                let drift = |params: &EkfParams, moving: bool| {
                    errors(params, moving).map(|e| e.drift.xyz_pct)
                };
                let no_points = EkfParams {
                    point_updates: false,
                    ..EkfParams::default()
                };
                let no_zero_rate = EkfParams {
                    zero_rate_updates: false,
                    ..EkfParams::default()
                };
                let without = drift(&no_points, false);
                let moving = drift(&EkfParams::default(), true);
                let without_zero_rate = [false, true].map(|m| errors(&no_zero_rate, m));
                let fixed_scale = errors(
                    &EkfParams {
                        velocity_scale_sigma: 0.0,
                        ..EkfParams::default()
                    },
                    false,
                );
                // The stamp test: the same frames stamped early, the offset fixed at 0 or
                // estimated.
                let early: Vec<_> = frames
                    .iter()
                    .map(|f| FrameVelocity {
                        measure_time_s: f.measure_time_s - STAMP_TEST_OFFSET_S,
                        ..f.clone()
                    })
                    .collect();
                let stamp_test = [0.0, EkfParams::default().time_offset_sigma].map(|sigma| {
                    let params = EkfParams {
                        time_offset_sigma: sigma,
                        ..EkfParams::default()
                    };
                    odometry::run(&params, &imu, &early, &scene.rig)
                        .ok()
                        .map(|r| (metrics::evaluate(&r.trajectory, &truth), r.time_offset_s.0))
                });
                let total: usize = frames.iter().map(|f| f.points).sum();
                let (updates, errors, time_offset_s, velocity_scale, failure) = match run {
                    Ok(r) => (
                        r.updates,
                        metrics::evaluate(&r.trajectory, &truth),
                        Some(r.time_offset_s.0),
                        Some(r.velocity_scale.0),
                        None,
                    ),
                    Err(e) => (
                        UpdateCounts::default(),
                        None,
                        None,
                        None,
                        Some(e.to_string()),
                    ),
                };
                rows.push(OdometryRow {
                    sequence: file.name.to_string(),
                    seed: k,
                    variant: bench.variants()[v].name.clone(),
                    frames: n,
                    points_per_frame: total as f64 / n as f64,
                    ego,
                    radial,
                    updates,
                    errors,
                    xyz_pct_without_point_updates: without,
                    xyz_pct_moving_start: moving,
                    xyz_pct_without_zero_rate: without_zero_rate
                        .each_ref()
                        .map(|e| e.as_ref().map(|e| e.drift.xyz_pct)),
                    ate_m_without_zero_rate: without_zero_rate[0].as_ref().map(|e| e.ate_rmse_m),
                    time_offset_s,
                    xyz_pct_stamp_test: stamp_test.each_ref().map(|r| {
                        r.as_ref()
                            .and_then(|r| r.0.as_ref())
                            .map(|e| e.drift.xyz_pct)
                    }),
                    ate_m_stamp_test: stamp_test
                        .each_ref()
                        .map(|r| r.as_ref().and_then(|r| r.0.as_ref()).map(|e| e.ate_rmse_m)),
                    time_offset_stamp_test_s: stamp_test[1].as_ref().map(|r| r.1),
                    velocity_scale,
                    fixed_scale: [
                        fixed_scale.as_ref().map(|e| e.drift.xyz_pct),
                        fixed_scale.as_ref().map(|e| e.ate_rmse_m),
                    ],
                    failure,
                });
            }
            progress(&format!(
                "   odometry {}/{runs}: {} seed {} of {seeds}, {n} frames ({:.0} s)",
                s * seeds + k + 1,
                file.name,
                k + 1,
                start.elapsed().as_secs_f64()
            ));
        }
    }
    Ok(rows)
}

/// Mean and sample standard deviation (0 for one value); `None` when empty.
pub fn mean_std(v: &[f64]) -> Option<(f64, f64)> {
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s = if v.len() > 1 {
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    Some((m, s))
}

/// One chain on one sequence over the seeds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OdometrySummary {
    /// Sequence.
    pub sequence: String,
    /// Variant.
    pub variant: String,
    /// Seeds with a trajectory.
    pub seeds: usize,
    /// Path length, m.
    pub path_length_m: f64,
    /// End-point drift XYZ, XY, Z (m and % of the path), yaw (° and °/m): mean over seeds.
    pub drift: metrics::Drift,
    /// XYZ drift, % of the path: standard deviation over seeds.
    pub xyz_pct_std: f64,
    /// ATE after the 4-DoF alignment, m (mean).
    pub ate_rmse_m: f64,
    /// Relative error over sub-trajectories of 10, 20 and 30 % of the path: mean end-position
    /// error, % of their length (mean over seeds; NaN where the path is too short).
    pub relative_pct: [f64; 3],
    /// Ego-velocity RMSE per axis, m/s (mean).
    pub ego_rmse_mps: [f64; 3],
    /// Ego-velocity mean error per axis, m/s (mean over seeds;
    /// [`crate::odometry::EgoErrors::mean_error_mps`]).
    pub ego_mean_error_mps: [f64; 3],
    /// Share of moving frames with an estimate, % (mean).
    pub estimated_while_moving_pct: f64,
    /// Ego-velocity covariance consistency (mean NEES per axis, 1 = consistent; mean).
    pub ego_nees: f64,
    /// The estimator's own σ per axis, RMS over its estimates, m/s (mean;
    /// [`crate::odometry::EgoErrors::predicted_rms_mps`]).
    pub ego_predicted_rms_mps: [f64; 3],
    /// Points per frame (mean).
    pub points_per_frame: f64,
    /// Radial-velocity scale of the static points (mean; [`RadialConsistency::scale`]).
    pub radial_scale: f64,
    /// Their residual RMS at slow and fast direction sweep, m/s (mean).
    pub radial_rms_slow_fast_mps: [f64; 2],
    /// Paired DBE − FFT difference of the XYZ drift (% of the path), mean and standard
    /// deviation over seeds (on the DBE row only).
    pub xyz_pct_minus_fft: Option<(f64, f64)>,
    /// XYZ drift (% of the path) without point updates (mean over the seeds that have it).
    pub xyz_pct_without_point_updates: f64,
    /// Point updates applied per sequence run (mean).
    pub points_applied: f64,
    /// XYZ drift (% of the path) started in motion (mean over the seeds that have it; NaN if
    /// none).
    pub xyz_pct_moving_start: f64,
    /// XYZ drift (% of the path) without zero-rate updates, from rest and in motion (means
    /// over the seeds that have it; NaN if none).
    pub xyz_pct_without_zero_rate: [f64; 2],
    /// ATE without zero-rate updates, from rest, m (mean over the seeds that have it).
    pub ate_m_without_zero_rate: f64,
    /// Zero-rate updates applied per sequence run (mean).
    pub zero_rate_updates: f64,
    /// The filter's time-offset estimate (truth 0), s: mean and standard deviation over seeds.
    pub time_offset_s: (f64, f64),
    /// The stamp test ([`STAMP_TEST_OFFSET_S`]): XYZ drift (% of the path) with the offset
    /// taken as 0 and estimated (means over the seeds that have them).
    pub xyz_pct_stamp_test: [f64; 2],
    /// The stamp test's ATE, m, with the offset taken as 0 and estimated (means).
    pub ate_m_stamp_test: [f64; 2],
    /// The stamp test's time-offset estimate, s: mean and standard deviation over seeds.
    pub time_offset_stamp_test_s: (f64, f64),
    /// The filter's velocity-scale estimate: mean and standard deviation over seeds.
    pub velocity_scale: (f64, f64),
    /// With the velocity scale taken as 1: XYZ drift (% of the path) and ATE (m), means over
    /// the seeds that have them.
    pub fixed_scale: [f64; 2],
}

/// Aggregate `rows` per sequence and variant; `dbe`/`fft` name the paired variants.
pub fn summarise(rows: &[OdometryRow], dbe: &str, fft: &str) -> Vec<OdometrySummary> {
    let mut out = Vec::new();
    for file in &SEQUENCES {
        let mut variants: Vec<&str> = Vec::new();
        for r in rows.iter().filter(|r| r.sequence == file.name) {
            if !variants.contains(&r.variant.as_str()) {
                variants.push(&r.variant);
            }
        }
        for v in variants {
            let mine: Vec<&OdometryRow> = rows
                .iter()
                .filter(|r| r.sequence == file.name && r.variant == v)
                .collect();
            let ok: Vec<&metrics::TrajectoryErrors> =
                mine.iter().filter_map(|r| r.errors.as_ref()).collect();
            let m = |f: &dyn Fn(&metrics::TrajectoryErrors) -> f64| {
                mean_std(&ok.iter().map(|e| f(e)).collect::<Vec<_>>()).map_or(f64::NAN, |x| x.0)
            };
            let me = |f: &dyn Fn(&OdometryRow) -> f64| {
                mean_std(&mine.iter().map(|r| f(r)).collect::<Vec<_>>()).map_or(f64::NAN, |x| x.0)
            };
            // Mean and standard deviation over the rows that have the figure.
            let spread = |f: &dyn Fn(&OdometryRow) -> Option<f64>| {
                mean_std(&mine.iter().filter_map(|r| f(r)).collect::<Vec<_>>())
                    .unwrap_or((f64::NAN, f64::NAN))
            };
            let mean_of_some = |f: &dyn Fn(&OdometryRow) -> Option<f64>| spread(f).0;
            let paired = (v == dbe).then(|| {
                let d: Vec<f64> = mine
                    .iter()
                    .filter_map(|r| {
                        let other = rows.iter().find(|o| {
                            o.sequence == r.sequence && o.seed == r.seed && o.variant == fft
                        })?;
                        Some(
                            r.errors.as_ref()?.drift.xyz_pct - other.errors.as_ref()?.drift.xyz_pct,
                        )
                    })
                    .collect();
                mean_std(&d)
            });
            out.push(OdometrySummary {
                sequence: file.name.to_string(),
                variant: v.to_string(),
                seeds: ok.len(),
                path_length_m: m(&|e| e.path_length_m),
                drift: metrics::Drift {
                    xyz_m: m(&|e| e.drift.xyz_m),
                    xyz_pct: m(&|e| e.drift.xyz_pct),
                    xy_m: m(&|e| e.drift.xy_m),
                    xy_pct: m(&|e| e.drift.xy_pct),
                    z_m: m(&|e| e.drift.z_m),
                    z_pct: m(&|e| e.drift.z_pct),
                    yaw_deg: m(&|e| e.drift.yaw_deg),
                    yaw_deg_per_m: m(&|e| e.drift.yaw_deg_per_m),
                },
                xyz_pct_std: mean_std(&ok.iter().map(|e| e.drift.xyz_pct).collect::<Vec<_>>())
                    .map_or(f64::NAN, |x| x.1),
                ate_rmse_m: m(&|e| e.ate_rmse_m),
                relative_pct: [0, 1, 2].map(|i| {
                    m(&|e| {
                        e.relative
                            .get(i)
                            .map_or(f64::NAN, |r| r.translation_mean_pct)
                    })
                }),
                ego_rmse_mps: [0, 1, 2].map(|i| me(&|r| r.ego.rmse_mps[i])),
                ego_mean_error_mps: [0, 1, 2].map(|i| me(&|r| r.ego.mean_error_mps[i])),
                estimated_while_moving_pct: me(&|r| r.ego.estimated_while_moving_pct),
                ego_nees: me(&|r| r.ego.nees),
                ego_predicted_rms_mps: [0, 1, 2].map(|i| me(&|r| r.ego.predicted_rms_mps[i])),
                points_per_frame: me(&|r| r.points_per_frame),
                radial_scale: me(&|r| r.radial.scale),
                radial_rms_slow_fast_mps: [0, 1].map(|i| me(&|r| r.radial.rms_slow_fast_mps[i])),
                xyz_pct_minus_fft: paired.flatten(),
                xyz_pct_without_point_updates: mean_of_some(&|r| r.xyz_pct_without_point_updates),
                points_applied: me(&|r| r.updates.points_applied as f64),
                xyz_pct_moving_start: mean_of_some(&|r| r.xyz_pct_moving_start),
                xyz_pct_without_zero_rate: [0, 1]
                    .map(|i| mean_of_some(&|r| r.xyz_pct_without_zero_rate[i])),
                ate_m_without_zero_rate: mean_of_some(&|r| r.ate_m_without_zero_rate),
                zero_rate_updates: me(&|r| r.updates.zero_rate as f64),
                time_offset_s: spread(&|r| r.time_offset_s),
                xyz_pct_stamp_test: [0, 1].map(|i| mean_of_some(&|r| r.xyz_pct_stamp_test[i])),
                ate_m_stamp_test: [0, 1].map(|i| mean_of_some(&|r| r.ate_m_stamp_test[i])),
                time_offset_stamp_test_s: spread(&|r| r.time_offset_stamp_test_s),
                velocity_scale: spread(&|r| r.velocity_scale),
                fixed_scale: [0, 1].map(|i| mean_of_some(&|r| r.fixed_scale[i])),
            });
        }
    }
    out
}
