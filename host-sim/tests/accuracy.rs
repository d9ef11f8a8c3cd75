//! Accuracy of the core on simulated scenes against ground truth (issue thresholds):
//! static targets: detection ≥ 95 %, azimuth RMSE ≤ 0.5°, elevation RMSE ≤ 1°, at most
//! 2 points per frame farther than 0.6 m from every object; moving sensor at 1.2 m/s with TDM
//! compensation: elevation RMSE ≤ 1.5°, Doppler RMSE ≤ 0.05 m/s.

use std::path::Path;

use dbe_radar::Params;
use host_sim::cloud::PointRecord;
use host_sim::core_run::CoreRunner;
use host_sim::score::{accuracy, mid_frame_s, Accuracy};
use host_sim::sensor::SensorConfig;
use host_sim::sim::{load_scene, FrameTruth, Scene, Simulation};

type TestResult = Result<(), Box<dyn std::error::Error>>;

const FRAMES: usize = 10;

fn run(scene: &Scene, params: Params) -> Result<Accuracy, Box<dyn std::error::Error>> {
    run_frames(scene, params, FRAMES)
}

fn run_frames(
    scene: &Scene,
    params: Params,
    n: usize,
) -> Result<Accuracy, Box<dyn std::error::Error>> {
    let sensor = SensorConfig::coloradar();
    let sim = Simulation::new(scene, &sensor)?;
    let mut runner = CoreRunner::new(&sensor, params)?;
    let mut frames: Vec<(FrameTruth, Vec<PointRecord>)> = Vec::new();
    for i in 0..n {
        let f = sim.frame(i)?;
        let out = runner.process(&f.adc)?;
        frames.push((f.truth, out.points));
    }
    let a = accuracy(
        frames.iter().map(|(t, p)| (t, p.as_slice())),
        mid_frame_s(&sensor),
    );
    println!("{}: {a:?}", scene.name);
    Ok(a)
}

fn scene(name: &str) -> Result<Scene, Box<dyn std::error::Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    Ok(load_scene(&dir.join(format!("{name}.toml")))?)
}

fn assert_static(a: &Accuracy, what: &str) {
    assert!(a.targets >= FRAMES, "{what}: {a:?}");
    assert!(a.detection_rate() >= 0.95, "{what}: detection {a:?}");
    assert!(a.azimuth_rmse_deg <= 0.5, "{what}: azimuth {a:?}");
    assert!(a.elevation_rmse_deg <= 1.0, "{what}: elevation {a:?}");
    assert!(a.max_false_points <= 2, "{what}: false points {a:?}");
}

#[test]
fn static_targets_meet_the_accuracy_goals() -> TestResult {
    let params = Params::defaults(128);
    assert_static(&run(&scene("single_target")?, params)?, "single_target");
    // The demo's reflectors, wall and pole, seen by a static sensor.
    let mut demo = Scene::builtin_demo();
    demo.sensor.velocity = Some([0.0; 3]);
    demo.name = "demo, static sensor".into();
    assert_static(&run(&demo, params)?, "demo static");
    Ok(())
}

#[test]
fn moving_sensor_meets_the_accuracy_goals_with_tdm_compensation() -> TestResult {
    let params = Params::defaults(128);
    for s in [scene("moving_sensor")?, Scene::builtin_demo()] {
        assert_eq!(s.sensor.velocity, Some([1.2, 0.0, 0.0]), "{}", s.name);
        let a = run(&s, params)?;
        assert!(a.detection_rate() >= 0.95, "{}: {a:?}", s.name);
        assert!(a.elevation_rmse_deg <= 1.5, "{}: {a:?}", s.name);
        assert!(a.doppler_rmse_mps <= 0.05, "{}: {a:?}", s.name);
        assert!(a.max_false_points <= 2, "{}: {a:?}", s.name);
    }
    Ok(())
}

/// The same moving scene without compensation (the paper's chain): the elevation row fires in
/// another TDM slot than the azimuth line, so at 1.2 m/s every reflector still gives its point
/// but more than 10° off in elevation — more than 0.6 m away at these ranges.
#[test]
fn without_tdm_compensation_the_moving_sensor_loses_elevation_accuracy() -> TestResult {
    let on = run(&Scene::builtin_demo(), Params::defaults(128))?;
    let off = run(
        &Scene::builtin_demo(),
        Params {
            tdm_compensation: false,
            ..Params::defaults(128)
        },
    )?;
    assert!(on.detection_rate() >= 0.95, "on {on:?}");
    assert!(off.detection_rate() < 0.5, "off {off:?}");
    // The reflectors' points are displaced, not lost: without compensation at least as many
    // points per frame lie farther than 0.6 m from every object as there are reflectors
    // detected per frame with it. (The total point count is no measure: compensation also
    // makes weak moving surface returns coherent over the TX slots, so more of them pass.)
    let detected_per_frame = on.detected as f64 / FRAMES as f64;
    assert!(
        off.false_points_per_frame >= detected_per_frame,
        "on {on:?}, off {off:?}"
    );
    Ok(())
}

/// Coherent targets (issue 10 §2): `two_targets` puts two equal static reflectors in one
/// range bin; seen by a static sensor their snapshots are identical up to noise, and seen by a
/// sensor moving straight ahead they share one radial velocity, so in both cases they are
/// coherent. Both are detected, and both get their elevation (the static scene's goal, ≤ 1°),
/// because detections of one range bin with one Doppler are resolved on the forward–backward
/// averaged 2 × 4 sub-array (`dbe_radar::subarray`).
#[test]
fn coherent_pairs_in_scenes_get_their_elevations() -> TestResult {
    let mut moving = scene("two_targets")?;
    moving.sensor.velocity = Some([1.2, 0.0, 0.0]);
    moving.name = "two_targets, moving".into();
    for s in [scene("two_targets")?, moving] {
        let a = run(&s, Params::defaults(128))?;
        assert!(a.detection_rate() >= 0.95, "{}: {a:?}", s.name);
        assert!(a.azimuth_rmse_deg <= 0.5, "{}: azimuth {a:?}", s.name);
        assert!(a.elevation_rmse_deg <= 1.0, "{}: elevation {a:?}", s.name);
        // The paper's chain (full array, no averaging) is what the sub-array fixes.
        let paper = Params {
            coherent_doppler_bins: 0.0,
            ..Params::defaults(128)
        };
        let b = run(&s, paper)?;
        assert!(b.detection_rate() < 0.5, "{}: full array {b:?}", s.name);
    }
    Ok(())
}

/// Issue 10 §2 on the evaluation's own trial generator: two equal coherent (static) targets at
/// 20 dB (random centre in ±25°, common elevation in ±10°, random phases), 40 fixed trials per
/// separation. Resolved points get their elevations: RMSE ≤ 1° at every separation from 8°
/// (the full-array chain: 7–9°). Measured resolution: 78 % at 8°, 90 % at 12°, 100 % at 20°, so
/// the goal (≥ 90 %) holds from 12° and is missed at 8°: forward–backward averaging of the
/// 8-element line leaves a band of phase differences where the pair merges into one point or
/// cancels on the range–azimuth map (`Params::spatial_smoothing` trades that for aperture).
/// 8° is held at ≥ 60 % so that a regression shows.
#[test]
fn coherent_pairs_are_resolved_with_their_elevations() -> TestResult {
    use host_sim::eval::scenarios::{resolve, two_targets, Context, Pair};
    use rand::{rngs::StdRng, SeedableRng};
    const TRIALS: u64 = 40;
    let ctx = Context::coloradar(8.0)?;
    let mut runner = CoreRunner::new(&ctx.sensor, Params::defaults(128))?;
    for (sep, goal) in [(8.0, 0.6), (12.0, 0.9), (20.0, 0.9)] {
        let (mut resolved, mut sq, mut n) = (0u32, 0.0, 0u32);
        for i in 0..TRIALS {
            let targets = two_targets(&ctx, sep, Pair::Coherent, 20.0, 7000 + i);
            let mut rng = StdRng::seed_from_u64(9000 + i);
            let scat = targets.map(|t| t.scatterer(ctx.t_mid_s));
            let frame = host_sim::sim::try_render_frame(&ctx.sensor, &scat, 8.0, &mut rng)?;
            let out = runner.process(&frame)?;
            if let Some(el) = resolve(&out.points, &targets, ctx.range_bin_m) {
                resolved += 1;
                for e in el {
                    sq += e * e;
                    n += 1;
                }
            }
        }
        let rate = f64::from(resolved) / TRIALS as f64;
        let rmse = (sq / f64::from(n.max(1))).sqrt();
        println!("{sep}°: resolved {rate:.2}, elevation RMSE {rmse:.2}°");
        assert!(rate >= goal, "{sep}°: resolved in {rate:.2} of the trials");
        assert!(rmse <= 1.0, "{sep}°: elevation RMSE {rmse:.2}°");
    }
    Ok(())
}

/// README's demo figures are what `dbe demo` measures (its 20 frames of the built-in scene,
/// DBE chain, defaults, scored by `host_sim::score`): a change of the chain or the scoring
/// fails here until README is updated.
#[test]
fn readme_quotes_the_demo() -> TestResult {
    let a = run_frames(&Scene::builtin_demo(), Params::defaults(128), 20)?;
    let line = format!(
        "{}/{} targets detected, azimuth RMSE {:.2}°, elevation RMSE {:.2}°, Doppler RMSE {:.3} m/s,\n{:.1} points per frame",
        a.detected,
        a.targets,
        a.azimuth_rmse_deg,
        a.elevation_rmse_deg,
        a.doppler_rmse_mps,
        a.points_per_frame
    );
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md"))?;
    assert!(
        readme.contains(&line),
        "README lacks the demo's figures:\n{line}"
    );
    let far = if a.false_points_per_frame == 0.0 {
        "none farther than 0.6 m from an object".to_string()
    } else {
        format!(
            "{:.2} per frame farther than 0.6 m from every object",
            a.false_points_per_frame
        )
    };
    assert!(
        readme.contains(&far),
        "README lacks the demo's false points: {far}"
    );
    Ok(())
}

/// The ego-velocity stage on the DBE chain's points of a moving-sensor scene with a car
/// driving the other way (an outlier): every estimate that reports `ok` lies within 4σ of
/// its reported covariance of the sensor's true velocity, and the car never pulls it.
#[test]
fn ego_velocity_from_the_points_of_a_moving_sensor() -> TestResult {
    use dbe_radar::{EgoEstimator, EgoParams, EgoStatus, Point};
    let scene = scene("parking_lot")?;
    let truth = scene
        .sensor
        .velocity
        .ok_or("parking_lot has a moving sensor")?;
    let sensor = SensorConfig::coloradar();
    let sim = Simulation::new(&scene, &sensor)?;
    let mut runner = CoreRunner::new(&sensor, Params::defaults(128))?;
    let mut ego = Box::new(EgoEstimator::<256>::new(EgoParams::DEFAULT)?);
    let mut ok = 0;
    for i in 0..FRAMES {
        let out = runner.process(&sim.frame(i)?.adc)?;
        let points: Vec<Point> = out.points.iter().map(PointRecord::to_point).collect();
        let e = ego.estimate(&points);
        println!("frame {i}: {e:?}");
        if e.status != EgoStatus::Ok {
            continue;
        }
        ok += 1;
        for k in 0..3 {
            let err = f64::from(e.velocity[k]) - truth[k];
            let sigma = f64::from(e.covariance[k][k]).sqrt();
            assert!(err.abs() <= 4.0 * sigma, "frame {i} axis {k}: {e:?}");
        }
    }
    assert!(ok >= FRAMES / 2, "{ok} of {FRAMES} frames with an estimate");
    Ok(())
}

/// The Doppler agreement (`Params::doppler_agreement_bins`) drops a point whose own
/// full-array Capon weight does not pass its detection's signal. Without the coherent
/// sub-array a static coherent pair is such a case: the 12-element covariance is rank 1, the
/// weights steered at either target partly cancel both, and the elevation peak they find is
/// not a target's, and their beams' Doppler peaks are noise. Without the rule those points
/// are reported; with it they are dropped.
#[test]
fn doppler_agreement_drops_points_whose_weights_miss_their_target() -> TestResult {
    let s = scene("two_targets")?;
    let full_array = Params {
        coherent_doppler_bins: 0.0,
        ..Params::defaults(128)
    };
    let with = run(&s, full_array)?;
    let without = run(
        &s,
        Params {
            doppler_agreement_bins: 0.0,
            ..full_array
        },
    )?;
    assert!(
        without.points_per_frame > with.points_per_frame + 0.5,
        "with {with:?}, without {without:?}"
    );
    // Measured: without the rule 1.9 false points per frame and a Doppler RMSE of 0.37 m/s
    // on static targets (the cancelled beams peak at noise); with it none, and every kept
    // point within a Doppler bin (0.039 m/s) of the truth.
    assert!(
        without.false_points_per_frame >= 1.0 && with.false_points_per_frame == 0.0,
        "with {with:?}, without {without:?}"
    );
    assert!(
        without.doppler_rmse_mps > 0.1 && with.doppler_rmse_mps < 0.039,
        "with {with:?}, without {without:?}"
    );
    Ok(())
}
