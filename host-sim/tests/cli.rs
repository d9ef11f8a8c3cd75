//! The `dbe` command as a user runs it: every subcommand, its help, and its failure modes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn dbe(args: &[&str]) -> Output {
    match Command::new(env!("CARGO_BIN_EXE_dbe")).args(args).output() {
        Ok(o) => o,
        Err(e) => panic!("cannot run dbe: {e}"),
    }
}

fn ok(args: &[&str]) -> String {
    let o = dbe(args);
    assert!(
        o.status.success(),
        "dbe {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn fails(args: &[&str]) -> String {
    let o = dbe(args);
    assert!(!o.status.success(), "dbe {args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `../shared` beside the repository when the TI capture is there; `None` (a skip) outside CI,
/// a failure naming the path under `CI=true`.
/// The real TI capture, under `../shared`.
const TI_CAPTURE: &str = "fixtures/ti-iwr6843-corner-reflector/adc_data_Raw_0.bin";

/// The real TI capture's path ([`shared_fixture_dir`]: `None` is a skip outside CI).
fn ti_capture() -> Option<PathBuf> {
    shared_fixture_dir().map(|shared| shared.join(TI_CAPTURE))
}

fn shared_fixture_dir() -> Option<PathBuf> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared");
    let bin = shared.join(TI_CAPTURE);
    if bin.is_file() {
        return Some(shared);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{} is missing (../shared beside the repository)",
        bin.display()
    );
    eprintln!("skipped: {} not found", bin.display());
    None
}

/// `dbe process` of the real capture `bin` into `out` as CSV, with the options `extra`: its
/// one frame's points.
fn process_capture(
    bin: &Path,
    out: &Path,
    extra: &[&str],
) -> Result<Vec<host_sim::cloud::PointRecord>, Box<dyn std::error::Error>> {
    let mut args = vec!["process", s(bin), "--out", s(out), "--format", "csv"];
    args.extend_from_slice(extra);
    ok(&args);
    Ok(host_sim::io::pointcloud::read_csv(
        &out.join("csv/frame_0.csv"),
    )?)
}

/// The range bins of `pts`, sorted.
fn range_bins(pts: &[host_sim::cloud::PointRecord]) -> Vec<u32> {
    let mut bins: Vec<u32> = pts.iter().map(|p| p.range_bin).collect();
    bins.sort_unstable();
    bins
}

/// Simulate `frames` frames of the shipped scene `scene` into `dir/seq`; returns the sequence.
fn simulated(dir: &Path, scene: &str, frames: &str) -> PathBuf {
    let seq = dir.join("seq");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{scene}.toml"));
    ok(&[
        "simulate",
        "--scene",
        s(&scene),
        "--frames",
        frames,
        "--out",
        s(&seq),
    ]);
    seq
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap_or_default()
}

#[test]
fn every_subcommand_has_help() {
    for sub in [
        "process", "simulate", "validate", "plot", "demo", "eval", "bench", "odometry",
    ] {
        let help = ok(&[sub, "--help"]);
        assert!(help.contains("Usage: dbe"), "{sub}: {help}");
    }
    assert!(ok(&["--help"]).contains("process"));
}

#[test]
fn simulate_process_validate_plot() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let seq = simulated(tmp.path(), "moving_sensor", "3");
    assert!(seq
        .join("single_chip/adc_samples/data/frame_2.bin")
        .is_file());
    assert!(seq.join("calib/single_chip/antenna_cfg.txt").is_file());
    assert!(seq.join("groundtruth/frame_0.json").is_file());

    let out = tmp.path().join("points");
    let msg = ok(&[
        "process",
        s(&seq),
        "--out",
        s(&out),
        "--format",
        "coloradar,csv,pcd,ply",
    ]);
    assert!(msg.contains("3 frames"), "{msg}");
    let clouds = host_sim::io::read_coloradar_pointclouds(&out)?;
    assert_eq!(clouds.len(), 3);
    assert!(
        clouds.iter().all(|(_, pts)| pts.len() >= 3),
        "three reflectors per frame"
    );
    let csv = host_sim::io::pointcloud::read_csv(&out.join("csv/frame_1.csv"))?;
    assert_eq!(csv.len(), clouds[1].1.len());
    for f in [
        "pcd/frame_0.pcd",
        "ply/frame_2.ply",
        "single_chip/pointclouds/timestamps.txt",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }

    // The FFT chain and the switches run too; a frame range selects frames.
    let fft = tmp.path().join("fft");
    ok(&[
        "process",
        s(&seq),
        "--out",
        s(&fft),
        "--pipeline",
        "fft",
        "--frames",
        "1..3",
        "--grid",
    ]);
    assert_eq!(host_sim::io::read_coloradar_pointclouds(&fft)?.len(), 2);

    let table = ok(&["validate", s(&seq)]);
    assert!(table.contains("3 of 3 frames match"), "{table}");

    let plots = tmp.path().join("plots");
    ok(&["plot", s(&seq), "--frame", "2", "--out", s(&plots)]);
    for f in ["maps_2.png", "points_top_2.png", "points_side_2.png"] {
        assert!(plots.join(f).is_file(), "{f}");
    }
    // A wider colour scale for real data; an absurd one is refused before anything is made.
    let wide = tmp.path().join("wide");
    ok(&[
        "plot",
        s(&seq),
        "--dynamic-range-db",
        "80",
        "--out",
        s(&wide),
    ]);
    assert!(wide.join("maps_0.png").is_file());
    let bad = tmp.path().join("bad");
    let err = fails(&["plot", s(&seq), "--dynamic-range-db", "1", "--out", s(&bad)]);
    assert!(
        err.contains("--dynamic-range-db 1: expected 3 to 200 dB"),
        "{err}"
    );
    assert!(!bad.exists());
    Ok(())
}

#[test]
fn failures_are_one_line_errors_and_leave_nothing_behind() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let missing = tmp.path().join("nope");
    let err = fails(&["process", s(&missing), "--out", s(&tmp.path().join("o"))]);
    assert!(err.contains("no such file or folder"), "{err}");
    assert!(!tmp.path().join("o").exists());

    // A truncated DCA1000 capture: the size matches no whole number of frames.
    let bin = tmp.path().join("short.bin");
    std::fs::write(&bin, vec![0u8; 1000])?;
    let out = tmp.path().join("out");
    let err = fails(&["process", s(&bin), "--out", s(&out)]);
    assert!(err.contains("short.bin"), "{err}");
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(tmp.path())?.count(),
        1,
        "no staging left behind"
    );

    // An existing, non-empty output folder is never overwritten.
    let taken = tmp.path().join("taken");
    std::fs::create_dir(&taken)?;
    std::fs::write(taken.join("keep.txt"), "mine")?;
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/single_target.toml");
    let err = fails(&[
        "simulate",
        "--scene",
        s(&scene),
        "--frames",
        "1",
        "--out",
        s(&taken),
    ]);
    assert!(err.contains("not empty"), "{err}");
    assert_eq!(std::fs::read_to_string(taken.join("keep.txt"))?, "mine");
    assert_eq!(
        std::fs::read_dir(&taken)?.count(),
        1,
        "nothing else written"
    );

    let err = fails(&["process", s(&bin), "--out", s(&out), "--format", "xyz"]);
    assert!(err.contains("xyz"), "{err}");
    Ok(())
}

#[test]
fn demo_runs_and_replaces_only_its_own_output() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let out: PathBuf = tmp.path().join("demo");
    let text = ok(&["demo", "--frames", "2", "--out", s(&out)]);
    assert!(text.contains("2 of 2 frames match"), "{text}");
    assert!(out.join("summary.json").is_file() && out.join("plots").is_dir());
    // A second demo replaces the first; a folder that is not a demo's is refused.
    ok(&["demo", "--frames", "1", "--out", s(&out)]);
    let other = tmp.path().join("other");
    std::fs::create_dir(&other)?;
    std::fs::write(other.join("x"), "")?;
    let err = fails(&["demo", "--frames", "1", "--out", s(&other)]);
    assert!(err.contains("not a previous `dbe demo` output"), "{err}");
    Ok(())
}

/// The real TI capture (its folder holds the calibration; a static scene): at the defaults the
/// corner reflector at range bin 38, its double bounce at twice the range and its triple bounce,
/// all static, and nothing else. Without the Doppler agreement the weak static returns beside
/// them come out as moving points (their full-array Capon weights cancel them: the array is
/// uncalibrated).
#[test]
fn processes_the_real_capture() -> TestResult {
    let Some(bin) = ti_capture() else {
        return Ok(());
    };
    let tmp = tempfile::tempdir()?;
    let pts = process_capture(&bin, &tmp.path().join("ti"), &[])?;
    let strongest = pts
        .iter()
        .max_by(|a, b| a.intensity_db.total_cmp(&b.intensity_db))
        .ok_or("no points")?;
    assert!(
        strongest.range_bin.abs_diff(38) <= 1 && strongest.doppler_bin == 0,
        "{strongest:?}"
    );
    let double = pts.iter().filter(|p| p.range_bin.abs_diff(76) <= 1).count();
    assert_eq!(double, 1, "the double bounce: {pts:?}");
    assert_eq!(range_bins(&pts), [38, 75, 111], "{pts:?}");
    assert!(pts.iter().all(|p| p.doppler_bin == 0), "{pts:?}");
    let without = tmp.path().join("without");
    let pts = process_capture(&bin, &without, &["--no-doppler-agreement"])?;
    let moving = pts.iter().filter(|p| p.doppler_bin != 0).count();
    assert!(moving >= 5, "{moving} moving of {}: {pts:?}", pts.len());
    Ok(())
}

/// How low the CFAR threshold goes on the real capture before it adds a point (README and the
/// eval report quote it): the three static points down to 1.64 dB; from 1.62 dB down a fourth,
/// static, at range bin 27 with an SNR of 1.63 dB over the CFAR level.
#[test]
fn the_real_capture_keeps_its_three_points_down_to_1_64_db() -> TestResult {
    let Some(bin) = ti_capture() else {
        return Ok(());
    };
    let tmp = tempfile::tempdir()?;
    let run = |alpha: &str| {
        process_capture(
            &bin,
            &tmp.path().join(alpha),
            &["--cfar-threshold-db", alpha],
        )
    };
    let at = run("1.64")?;
    assert_eq!(range_bins(&at), [38, 75, 111], "{at:?}");
    let below = run("1.62")?;
    assert_eq!(range_bins(&below), [27, 38, 75, 111], "{below:?}");
    assert!(below.iter().all(|p| p.doppler_bin == 0), "{below:?}");
    let extra = below.iter().find(|p| p.range_bin == 27).ok_or("bin 27")?;
    assert!(
        (1.62..1.64).contains(&extra.snr_db),
        "its SNR: {}",
        extra.snr_db
    );
    Ok(())
}

#[test]
fn bench_prints_every_stage_of_both_chains() {
    let out = ok(&["bench", "--frames", "3"]);
    for row in [
        "| dbe | ingest",
        "| dbe | azimuth_capon |",
        "| dbe | cfar |",
        "| dbe | elevation_doppler |",
        "| fft | doppler_fft |",
        "| fft | rd_cfar |",
        "| fft | angles |",
        "| fft | **frame** (",
    ] {
        assert!(out.contains(row), "no `{row}` in\n{out}");
    }
    assert!(fails(&["bench", "--frames", "0"]).contains("--frames 0"));
}

/// A recording with damaged frames: the frames are read ahead of the workers and processed in
/// any order, but the error is the first damaged frame's, and no output is left behind.
#[test]
fn process_names_the_first_damaged_frame_and_writes_nothing() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let seq = tmp.path().join("seq");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/single_target.toml");
    ok(&[
        "simulate",
        "--scene",
        s(&scene),
        "--frames",
        "6",
        "--out",
        s(&seq),
    ]);
    let data = seq.join("single_chip/adc_samples/data");
    for damaged in [4, 2] {
        let f = data.join(format!("frame_{damaged}.bin"));
        let bytes = std::fs::read(&f)?;
        std::fs::write(&f, &bytes[..bytes.len() - 2])?;
    }
    let out = tmp.path().join("points");
    let err = fails(&["process", s(&seq), "--out", s(&out), "--quiet"]);
    assert!(
        err.contains("frame_2.bin") && !err.contains("frame_4.bin"),
        "{err}"
    );
    assert!(!out.exists(), "output left behind");
    Ok(())
}

/// `dbe bench | head -1`: the reader closes the pipe after the first line; the command ends
/// quietly and successfully instead of panicking on the next write.
#[test]
fn a_reader_that_closes_the_pipe_early_ends_the_command_quietly() -> TestResult {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_dbe"))
        .args(["bench", "--frames", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    let stdout = child.stdout.take().ok_or("no stdout")?;
    let mut first = String::new();
    BufReader::new(stdout).read_line(&mut first)?;
    // The reader is dropped here: every later write meets a closed pipe.
    assert!(first.starts_with("scene `corridor`"), "{first}");
    let out = child.wait_with_output()?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
    Ok(())
}

#[test]
fn parameter_options_take_negative_numbers_and_refuse_absurd_values() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let seq = simulated(tmp.path(), "single_target", "1");
    let out = tmp.path().join("neg");
    ok(&[
        "process",
        s(&seq),
        "--out",
        s(&out),
        "--cfar-threshold-db",
        "-3",
    ]);
    assert!(out.join("single_chip").is_dir());
    for (flag, value, expected) in [
        (
            "--loading",
            "1e9",
            "--loading 1000000000: expected a value in (0, 1]",
        ),
        (
            "--loading",
            "-0.5",
            "--loading -0.5: expected a value in (0, 1]",
        ),
        (
            "--cfar-threshold-db",
            "90",
            "expected a value in [-10, 60] dB",
        ),
        (
            "--doppler-test-db",
            "61",
            "--doppler-test-db 61: expected a value in [0, 60] dB",
        ),
    ] {
        let bad = tmp.path().join(format!("bad{flag}{value}"));
        let err = fails(&["process", s(&seq), "--out", s(&bad), flag, value]);
        assert!(err.contains(expected), "{flag} {value}: {err}");
        assert!(!bad.exists(), "{flag} {value}: nothing is written");
    }
    Ok(())
}

#[test]
fn a_single_coloradar_frame_is_refused_with_its_sequence_named() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let seq = simulated(tmp.path(), "single_target", "1");
    let frame = seq.join("single_chip/adc_samples/data/frame_0.bin");
    assert!(frame.is_file());
    let out = tmp.path().join("out");
    let err = fails(&["process", s(&frame), "--out", s(&out)]);
    assert!(
        err.contains("a single frame of a ColoRadar sequence"),
        "{err}"
    );
    assert!(err.contains(s(&seq)), "names the sequence folder: {err}");
    assert!(!out.exists());
    Ok(())
}

#[test]
fn a_capture_without_configuration_is_refused_with_the_sizes_that_fit() -> TestResult {
    let Some(shared) = shared_fixture_dir() else {
        return Ok(());
    };
    let tmp = tempfile::tempdir()?;
    let capture = tmp.path().join("adc_data.bin");
    std::fs::copy(shared.join(TI_CAPTURE), &capture)?;
    let out = tmp.path().join("out");
    // No configuration: both presets' frames divide its 786,432 bytes, and both are named.
    let err = fails(&["process", s(&capture), "--out", s(&out)]);
    assert!(err.contains("no header"), "{err}");
    assert!(
        err.contains("coloradar") && err.contains("iwr6843"),
        "{err}"
    );
    assert!(!out.exists());
    // Half a configuration: the missing file is named.
    std::fs::copy(
        shared.join("fixtures/ti-iwr6843-corner-reflector/waveform_cfg.txt"),
        tmp.path().join("waveform_cfg.txt"),
    )?;
    let err = fails(&["process", s(&capture), "--out", s(&out)]);
    assert!(err.contains("no antenna_cfg.txt"), "{err}");
    // Both files: it runs.
    std::fs::copy(
        shared.join("fixtures/ti-iwr6843-corner-reflector/antenna_cfg.txt"),
        tmp.path().join("antenna_cfg.txt"),
    )?;
    ok(&["process", s(&capture), "--out", s(&out)]);
    Ok(())
}

#[test]
fn odometry_on_a_simulated_walk_writes_a_trajectory_evo_reads() -> TestResult {
    // The first 12 s of the hallways loop: 2 s standstill, then 9.5 m straight on.
    let dir = tempfile::tempdir()?;
    let seq = simulated(dir.path(), "odometry/hallways", "120");
    for f in [
        "imu/imu_data.txt",
        "imu/timestamps.txt",
        "calib/transforms/base_to_imu.txt",
    ] {
        assert!(seq.join(f).is_file(), "{f} not simulated");
    }
    let out = dir.path().join("odo");
    let stdout = ok(&["odometry", s(&seq), "--out", s(&out)]);
    assert!(
        stdout.contains("radar updates") && stdout.contains("drift"),
        "{stdout}"
    );

    // TUM: `t tx ty tz qx qy qz qw`, one line per frame at the frame's timestamp.
    let tum = std::fs::read_to_string(out.join("trajectory_tum.txt"))?;
    let stamps = std::fs::read_to_string(seq.join("single_chip/adc_samples/timestamps.txt"))?;
    let rows: Vec<Vec<f64>> = tum
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 120);
    for (row, t) in rows.iter().zip(stamps.lines()) {
        assert_eq!(row.len(), 8);
        assert!(row.iter().all(|v| v.is_finite()));
        assert!((row[0] - t.parse::<f64>()?).abs() < 1e-6);
        let qn: f64 = row[4..].iter().map(|q| q * q).sum();
        assert!((qn - 1.0).abs() < 1e-6);
    }
    let csv = std::fs::read_to_string(out.join("ego_velocity.csv"))?;
    assert_eq!(csv.lines().next(), Some(host_sim::odometry::EGO_CSV_HEADER));
    assert_eq!(csv.lines().count(), 121);

    // A sanity bound, not the goal: a filter that mixed up frames or signs is off by metres on
    // 9.5 m; the README's figures come from the full sequences.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json"))?)?;
    let e = &summary["evaluation"];
    let path = e["path_length_m"].as_f64().ok_or("no path length")?;
    assert!((path - 9.5).abs() < 0.5, "path {path}");
    let drift = e["drift"]["xyz_pct"].as_f64().ok_or("no drift")?;
    assert!(drift < 10.0, "drift {drift} % of the path");
    assert!(
        summary["updates"]["applied"].as_u64().unwrap_or(0) > 50,
        "{summary}"
    );
    for png in ["trajectory_top.png", "trajectory_side.png"] {
        assert!(out.join(png).is_file(), "{png}");
    }
    assert!(out.join("groundtruth_tum.txt").is_file());
    evo_reads(&out, e["ate_rmse_m"].as_f64().ok_or("no ATE")?);
    assert_eq!(summary["start"]["mode"], "standstill");
    // The rig stands still for 1 s after the filter's 1 s start: zero-rate updates, none
    // rejected (the IMU is at rest there).
    let zero_rate = &summary["updates"]["zero_rate"];
    assert!(zero_rate.as_u64().is_some_and(|n| n > 0), "{summary}");
    assert_eq!(summary["updates"]["zero_rate_rejected"], 0, "{summary}");
    assert!(stdout.contains("zero-rate updates"), "{stdout}");
    // The simulator stamps frames as the filter assumes: the estimated time offset is 0
    // within 4 of its σ, which the 10 s of walking have shrunk from the 50 ms it starts with.
    let td = &summary["time_offset"];
    assert_eq!(td["estimated"], true, "{summary}");
    let (est, sigma) = (
        td["estimate_s"].as_f64().ok_or("no time offset")?,
        td["sigma_s"].as_f64().ok_or("no time offset σ")?,
    );
    assert!(sigma < 0.05 && est.abs() < 4.0 * sigma, "{td}");
    // The simulated radar's velocity scale: estimated from 1 ± 0.03, what the walk's start
    // and stop show of it (its points' directions may read a slower radar by a per cent or
    // two: the eval's *v_r scale*), within 4 of its σ of 1 … 0.97.
    let k = &summary["velocity_scale"];
    assert_eq!(k["estimated"], true, "{summary}");
    let (est, sigma) = (
        k["estimate"].as_f64().ok_or("no velocity scale")?,
        k["sigma"].as_f64().ok_or("no velocity scale σ")?,
    );
    assert!(
        sigma > 0.0 && sigma < 0.03 && est > 0.97 - 4.0 * sigma && est < 1.0 + 4.0 * sigma,
        "{k}"
    );
    assert!(stdout.contains("velocity scale"), "{stdout}");

    // The IMU data cut 4 s in, while the rig walks: the filter starts in motion at the first
    // radar velocity with 0.25 s of IMU data before it, says so, and leaves the frames before
    // it out of the trajectory (here with the velocity scale fixed at 1.01).
    let lines = |f: &str| -> Result<Vec<String>, std::io::Error> {
        Ok(std::fs::read_to_string(seq.join(f))?
            .lines()
            .map(str::to_owned)
            .collect())
    };
    let (times, samples) = (lines("imu/timestamps.txt")?, lines("imu/imu_data.txt")?);
    let t0: f64 = times[0].parse()?;
    let keep = times
        .iter()
        .position(|t| t.parse::<f64>().is_ok_and(|t| t >= t0 + 4.0))
        .ok_or("short IMU data")?;
    std::fs::write(
        seq.join("imu/timestamps.txt"),
        times[keep..].join("\n") + "\n",
    )?;
    std::fs::write(
        seq.join("imu/imu_data.txt"),
        samples[keep..].join("\n") + "\n",
    )?;
    let moving = dir.path().join("odo-moving");
    let o = dbe(&[
        "odometry",
        s(&seq),
        "--out",
        s(&moving),
        "--velocity-scale",
        "1.01",
        "--fix-velocity-scale",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("started in motion"), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(moving.join("summary.json"))?)?;
    assert_eq!(summary["start"]["mode"], "moving");
    // --velocity-scale 1.01 --fix-velocity-scale: the scale is 1.01 and not estimated.
    let k = &summary["velocity_scale"];
    assert_eq!(
        (
            k["start"].as_f64(),
            &k["estimated"],
            k["estimate"].as_f64(),
            k["sigma"].as_f64()
        ),
        (Some(1.01), &serde_json::json!(false), Some(1.01), Some(0.0)),
        "{k}"
    );
    let start = summary["start"]["time_s"].as_f64().ok_or("no start time")?;
    assert!(start >= t0 + 4.25, "start {start}");
    let before = summary["updates"]["before_start"]
        .as_u64()
        .ok_or("no count")?;
    let poses = std::fs::read_to_string(moving.join("trajectory_tum.txt"))?
        .lines()
        .filter(|l| !l.starts_with('#'))
        .count();
    assert_eq!(poses as u64 + before, 120);
    let first_pose: f64 = stamps
        .lines()
        .nth(before as usize)
        .ok_or("no frame")?
        .parse()?;
    assert!(
        first_pose + 0.1 > start,
        "first pose {first_pose}, start {start}"
    );

    // A time offset outside [−1, 1] s: an error naming the option, nothing written.
    let bad = dir.path().join("odo1");
    let err = fails(&["odometry", s(&seq), "--out", s(&bad), "--time-offset", "-5"]);
    assert!(err.contains("--time-offset"), "{err}");
    assert!(!bad.exists());
    // A velocity scale outside [0.5, 2]: the same.
    let err = fails(&[
        "odometry",
        s(&seq),
        "--out",
        s(&bad),
        "--velocity-scale",
        "0",
    ]);
    assert!(err.contains("--velocity-scale"), "{err}");
    assert!(!bad.exists());

    // Missing IMU data or mounts: an error naming the file, nothing written.
    std::fs::remove_file(seq.join("imu/imu_data.txt"))?;
    let err = fails(&["odometry", s(&seq), "--out", s(&dir.path().join("odo2"))]);
    assert!(err.contains("imu_data.txt"), "{err}");
    assert!(!dir.path().join("odo2").exists());
    std::fs::remove_file(seq.join("calib/transforms/base_to_imu.txt"))?;
    let err = fails(&["odometry", s(&seq), "--out", s(&dir.path().join("odo3"))]);
    assert!(err.contains("base_to_imu.txt"), "{err}");
    Ok(())
}

/// `evo_ape tum` (the `evo` package, which `.ci/run` installs) loads both TUM files, and its
/// SE(3)-aligned RMSE is at most ours: Umeyama over 6 DoF can only fit better than the
/// position + yaw alignment over the same matched poses. Skipped outside CI when `evo` is not
/// installed.
fn evo_reads(out: &Path, ate_posyaw_m: f64) {
    let run = Command::new("evo_ape")
        .args([
            "tum",
            "groundtruth_tum.txt",
            "trajectory_tum.txt",
            "--align",
        ])
        .current_dir(out)
        .env("MPLBACKEND", "Agg")
        .output();
    let o = match run {
        Ok(o) => o,
        Err(e) => {
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "evo_ape cannot run ({e}); .ci/run installs it with pip"
            );
            eprintln!("skipped: evo_ape not installed");
            return;
        }
    };
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "evo_ape failed: {text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let rmse = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("rmse"))
        .and_then(|v| v.trim().parse::<f64>().ok());
    let Some(rmse) = rmse else {
        panic!("no rmse in evo_ape's output: {text}");
    };
    assert!(
        rmse.is_finite() && rmse <= ate_posyaw_m + 1e-3,
        "evo {rmse} vs ours {ate_posyaw_m}"
    );
}

#[test]
fn a_run_with_no_points_in_any_frame_says_so() -> TestResult {
    // Noise only: the defaults' CFAR gives no point (tests/robustness.rs), which a user with a
    // wrong calibration sees too.
    let dir = tempfile::tempdir()?;
    let scene = dir.path().join("empty.toml");
    std::fs::write(&scene, "name = \"empty\"\nseed = 1\n")?;
    let seq = dir.path().join("seq");
    ok(&[
        "simulate",
        "--scene",
        s(&scene),
        "--frames",
        "2",
        "--out",
        s(&seq),
    ]);
    let o = dbe(&["process", s(&seq), "--out", s(&dir.path().join("out"))]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no points in any of the 2 frames"), "{err}");
    Ok(())
}

#[test]
fn every_process_run_leaves_a_record_and_quiet_prints_nothing() -> TestResult {
    let dir = tempfile::tempdir()?;
    let seq = simulated(dir.path(), "moving_sensor", "3");
    let out = dir.path().join("out");
    let o = dbe(&[
        "process",
        s(&seq),
        "--out",
        s(&out),
        "--frames",
        "1..3",
        "--format",
        "csv",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stdout.is_empty(),
        "--quiet printed {:?}",
        String::from_utf8_lossy(&o.stdout)
    );
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json"))?)?;
    assert_eq!(run["chain"], "dbe");
    assert_eq!(run["frames"]["first_input_index"], 1);
    assert_eq!(run["frames"]["count"], 2);
    let per_frame = run["points_per_frame"]
        .as_array()
        .ok_or("points_per_frame")?;
    assert_eq!(per_frame.len(), 2);
    let total: u64 = per_frame.iter().filter_map(|v| v.as_u64()).sum();
    assert_eq!(run["points_total"].as_u64(), Some(total));
    // The calibration beside the sequence, each file with its SHA-256.
    let files = run["calibration"]["files"].as_array().ok_or("files")?;
    assert!(files.len() >= 2, "{files:?}");
    for f in files {
        let h = f["sha256"].as_str().ok_or("sha256")?;
        assert!(
            h.len() == 64 && h.chars().all(|c| c.is_ascii_hexdigit()),
            "{h}"
        );
    }
    assert!(run["frames_per_second"].as_f64().is_some_and(|v| v > 0.0));
    assert_eq!(run["parameters"]["doppler_test_db"], 12.0);
    assert_eq!(run["parameters"]["doppler_agreement_bins"], 1.5);
    assert_eq!(run["parameters"]["coherent_doppler_bins"], 1.5);
    // Without --quiet, one summary line with the time and the rate.
    let stdout = ok(&["process", s(&seq), "--out", s(&dir.path().join("out2"))]);
    assert!(stdout.contains("frames/s"), "{stdout}");
    // `--paper`: the paper's chain, recorded as such.
    let paper = dir.path().join("paper");
    ok(&["process", s(&seq), "--out", s(&paper), "--paper", "--quiet"]);
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(paper.join("run.json"))?)?;
    let p = &run["parameters"];
    assert_eq!(p["tdm_compensation"], false);
    assert_eq!(p["doppler_test_db"], 0.0);
    assert_eq!(p["doppler_agreement_bins"], 0.0);
    assert_eq!(p["coherent_doppler_bins"], 0.0);
    assert_eq!(p["spatial_smoothing"], false);
    assert_eq!(p["joint_elevation"], false);
    // `--joint-elevation` on top of the defaults, recorded.
    let joint = dir.path().join("joint");
    ok(&[
        "process",
        s(&seq),
        "--out",
        s(&joint),
        "--joint-elevation",
        "--quiet",
    ]);
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(joint.join("run.json"))?)?;
    assert_eq!(run["parameters"]["joint_elevation"], true);
    assert_eq!(run["parameters"]["tdm_compensation"], true);
    Ok(())
}

/// The CSV points of frames `0..frames` of two `dbe process` outputs agree: the same bins;
/// metres and m/s within the calibration's float32 rounding of the waveform (≤ 2⁻²³ relative)
/// and the f32 output. Returns the pairs.
fn same_csv_points(
    a: &Path,
    b: &Path,
    frames: usize,
) -> Result<
    Vec<(host_sim::cloud::PointRecord, host_sim::cloud::PointRecord)>,
    Box<dyn std::error::Error>,
> {
    let mut pairs = Vec::new();
    for i in 0..frames {
        let name = format!("csv/frame_{i}.csv");
        let pa = host_sim::io::read_csv(&a.join(&name))?;
        let pb = host_sim::io::read_csv(&b.join(&name))?;
        assert_eq!(pa.len(), pb.len(), "frame {i}");
        for (x, y) in pa.into_iter().zip(pb) {
            assert_eq!(
                (x.range_bin, x.azimuth_bin, x.elevation_bin, x.doppler_bin),
                (y.range_bin, y.azimuth_bin, y.elevation_bin, y.doppler_bin)
            );
            for (u, v) in [(x.x, y.x), (x.y, y.y), (x.z, y.z), (x.doppler, y.doppler)] {
                assert!((u - v).abs() < 1e-4, "frame {i}: {u} vs {v}");
            }
            pairs.push((x, y));
        }
    }
    Ok(pairs)
}

#[test]
fn a_ti_cfg_equivalent_to_the_calibration_gives_the_same_points() -> TestResult {
    let dir = tempfile::tempdir()?;
    let seq = simulated(dir.path(), "moving_sensor", "3");
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/coloradar_awr1843.cfg");
    let (a, b) = (dir.path().join("calib_out"), dir.path().join("cfg_out"));
    ok(&["process", s(&seq), "--out", s(&a), "--format", "csv"]);
    ok(&[
        "process",
        s(&seq),
        "--out",
        s(&b),
        "--format",
        "csv",
        "--calib",
        s(&cfg),
        "--board",
        "awr1843boost",
    ]);
    same_csv_points(&a, &b, 3)?;
    // A .cfg needs its board; a board needs a .cfg; a non-.cfg file is not a calibration.
    let err = fails(&[
        "process",
        s(&seq),
        "--out",
        s(&dir.path().join("x")),
        "--calib",
        s(&cfg),
    ]);
    assert!(err.contains("--board"), "{err}");
    let err = fails(&[
        "process",
        s(&seq),
        "--out",
        s(&dir.path().join("y")),
        "--board",
        "iwr6843isk",
    ]);
    assert!(err.contains("goes with a TI .cfg"), "{err}");
    let txt = seq.join("calib/single_chip/waveform_cfg.txt");
    let err = fails(&[
        "process",
        s(&seq),
        "--out",
        s(&dir.path().join("z")),
        "--calib",
        s(&txt),
    ]);
    assert!(err.contains("takes a folder"), "{err}");
    Ok(())
}

/// A `.cfg`'s `compRangeBiasAndRxChanPhase` reaches the points: one common phase on every
/// channel (a factor j) changes no angle or Doppler, and the range bias moves every point
/// towards the radar by itself; `run.json` records both.
#[test]
fn a_ti_cfg_s_range_bias_and_channel_factors_reach_the_points() -> TestResult {
    let dir = tempfile::tempdir()?;
    let seq = simulated(dir.path(), "moving_sensor", "2");
    let base = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/coloradar_awr1843.cfg"),
    )?;
    let (plain, comp) = (dir.path().join("plain.cfg"), dir.path().join("comp.cfg"));
    std::fs::write(&plain, &base)?;
    let line = format!("compRangeBiasAndRxChanPhase 0.05{}", " 0 1".repeat(12));
    std::fs::write(&comp, base.replace("lowPower 0 0", &line))?;
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for (cfg, out) in [(&plain, &a), (&comp, &b)] {
        ok(&[
            "process",
            s(&seq),
            "--out",
            s(out),
            "--format",
            "csv",
            "--calib",
            s(cfg),
            "--board",
            "awr1843boost",
        ]);
    }
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("run.json"))?)?;
    assert_eq!(run["sensor"]["range_bias_m"], 0.05);
    assert_eq!(
        run["sensor"]["channel_gains"][11],
        serde_json::json!([0.0, 1.0])
    );
    let mut points = 0;
    for i in 0..2 {
        let name = format!("csv/frame_{i}.csv");
        let pa = host_sim::io::read_csv(&a.join(&name))?;
        let pb = host_sim::io::read_csv(&b.join(&name))?;
        assert_eq!(pa.len(), pb.len(), "frame {i}");
        for (x, y) in pa.iter().zip(&pb) {
            assert_eq!(
                (x.range_bin, x.azimuth_bin, x.elevation_bin, x.doppler_bin),
                (y.range_bin, y.azimuth_bin, y.elevation_bin, y.doppler_bin)
            );
            let (rx, ry) = (
                (x.x * x.x + x.y * x.y + x.z * x.z).sqrt(),
                (y.x * y.x + y.y * y.y + y.z * y.z).sqrt(),
            );
            // f32 positions, and covariances of the rotated data summed in another order.
            assert!((rx - 0.05 - ry).abs() < 5e-4, "frame {i}: {rx} → {ry}");
            assert!((x.doppler - y.doppler).abs() < 1e-3, "frame {i}");
            points += 1;
        }
    }
    assert!(points > 0, "no points to compare");
    Ok(())
}

/// Errors quote file names and contents with their control characters escaped (no terminal
/// escape sequence reaches the user's terminal, the error stays one line), and a calibration
/// the core refuses is named, its reason printed once.
#[test]
fn errors_escape_control_characters_and_name_the_refused_calibration() -> TestResult {
    let dir = tempfile::tempdir()?;
    let odd = dir.path().join("seq\u{1b}[31m\nred");
    std::fs::create_dir(&odd)?;
    let err = fails(&["process", s(&odd), "--out", s(&dir.path().join("o"))]);
    assert!(
        err.contains("seq\\u{1b}[31m\\nred") && !err.contains('\u{1b}'),
        "{err:?}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err:?}");

    // An antenna layout whose azimuth line is not uniform (TX1 moved from 4 to 5).
    let seq = simulated(dir.path(), "moving_sensor", "1");
    let antenna = seq.join("calib/single_chip/antenna_cfg.txt");
    let text = std::fs::read_to_string(&antenna)?;
    let moved: Vec<String> = text
        .lines()
        .map(|l| match l.split_whitespace().collect::<Vec<_>>()[..] {
            ["tx", i, "4", el] => format!("tx {i} 5 {el}"),
            _ => l.to_string(),
        })
        .collect();
    assert_ne!(
        moved.join("\n"),
        text.trim_end(),
        "no TX at azimuth 4 in {text}"
    );
    std::fs::write(&antenna, moved.join("\n") + "\n")?;
    let out = dir.path().join("out");
    let err = fails(&["process", s(&seq), "--out", s(&out)]);
    assert!(
        err.contains("calib") && err.contains("not uniformly spaced"),
        "{err}"
    );
    assert_eq!(err.matches("not uniformly spaced").count(), 1, "{err}");
    assert!(!out.exists());
    Ok(())
}

/// A 2-TX radar (AWR1642 class: an 8-element line, no elevation row): a sequence simulated
/// with its calibration and the same recording read with a TI `.cfg` and `--board
/// awr1642boost` give the same points, all on the horizon, and the record says elevation was
/// not measured.
#[test]
fn a_two_tx_line_array_gives_azimuth_only_points_from_its_calibration_or_a_ti_cfg() -> TestResult {
    let dir = tempfile::tempdir()?;
    let calib = dir.path().join("calib_2tx");
    host_sim::io::write_calib(&calib, &host_sim::sensor::SensorConfig::awr1642())?;
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/moving_sensor.toml");
    let seq = dir.path().join("seq");
    ok(&[
        "simulate",
        "--scene",
        s(&scene),
        "--frames",
        "3",
        "--calib",
        s(&calib),
        "--out",
        s(&seq),
    ]);
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/awr1642_2tx.cfg");
    let (a, b) = (dir.path().join("calib_out"), dir.path().join("cfg_out"));
    let o = dbe(&["process", s(&seq), "--out", s(&a), "--format", "csv"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no elevation row"), "{stderr}");
    ok(&[
        "process",
        s(&seq),
        "--out",
        s(&b),
        "--format",
        "csv",
        "--calib",
        s(&cfg),
        "--board",
        "awr1642boost",
        "--quiet",
    ]);
    let pairs = same_csv_points(&a, &b, 3)?;
    for (x, y) in &pairs {
        assert!(x.z == 0.0 && y.z == 0.0, "{x:?}");
    }
    assert!(pairs.len() >= 3, "{} points in 3 frames", pairs.len());
    for out in [&a, &b] {
        let run: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("run.json"))?)?;
        assert_eq!(run["sensor"]["tx"], 2);
        assert_eq!(run["sensor"]["preset"], "ti-128x128-2tx");
        assert_eq!(run["sensor"]["elevation_measured"], false);
    }
    Ok(())
}

/// `--format mcap`: one MCAP file, one `foxglove.PointCloud` per frame at the sequence's
/// timestamps, the CSV's points in the common column order; and the Python `mcap` package
/// (which `.ci/run` installs) reads it as Foxglove would. Skipped outside CI without it.
#[test]
fn mcap_output_is_one_foxglove_point_cloud_per_frame() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let seq = simulated(tmp.path(), "moving_sensor", "3");
    let out = tmp.path().join("points");
    ok(&["process", s(&seq), "--out", s(&out), "--format", "mcap,csv"]);
    let mcap = out.join("points.mcap");
    let clouds = host_sim::io::mcap::read_mcap(&mcap)?;
    let times = std::fs::read_to_string(seq.join("single_chip/adc_samples/timestamps.txt"))?;
    let times: Vec<f64> = times
        .lines()
        .map(|l| l.trim().parse().unwrap_or(f64::NAN))
        .collect();
    assert_eq!(clouds.len(), 3);
    for (i, cloud) in clouds.iter().enumerate() {
        assert_eq!(
            cloud.log_time_ns,
            (times[i] * 1e9).round() as u64,
            "frame {i}"
        );
        let csv = host_sim::io::pointcloud::read_csv(&out.join(format!("csv/frame_{i}.csv")))?;
        let want: Vec<[f32; 6]> = csv
            .iter()
            .map(|p| [p.x, p.y, p.z, p.intensity_db, p.doppler, p.snr_db].map(|v| v as f32))
            .collect();
        assert!(!want.is_empty(), "frame {i} has points");
        assert_eq!(cloud.points, want, "frame {i}");
    }

    let script = r#"
import base64, json, struct, sys
from mcap.reader import make_reader
with open(sys.argv[1], "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages():
        m = json.loads(message.data)
        assert schema.name == "foxglove.PointCloud" and schema.encoding == "jsonschema"
        assert channel.topic == "/radar/points" and channel.message_encoding == "json"
        names = [f["name"] for f in m["fields"]]
        assert names == ["x", "y", "z", "intensity", "doppler", "snr"], names
        data = base64.b64decode(m["data"])
        x = struct.unpack_from("<f", data, 0)[0] if data else float("nan")
        print(message.log_time, len(data) // m["point_stride"], repr(x))
"#;
    let run = Command::new("python3")
        .args(["-c", script, s(&mcap)])
        .output()?;
    let stderr = String::from_utf8_lossy(&run.stderr);
    if !run.status.success() && stderr.contains("No module named 'mcap'") {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "the Python mcap package is missing; .ci/run installs it with pip"
        );
        eprintln!("skipped: Python mcap not installed");
        return Ok(());
    }
    assert!(run.status.success(), "python mcap: {stderr}");
    let text = String::from_utf8_lossy(&run.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    for (i, line) in lines.iter().enumerate() {
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(f[0].parse::<u64>()?, clouds[i].log_time_ns);
        assert_eq!(f[1].parse::<usize>()?, clouds[i].points.len());
        assert_eq!(f[2].parse::<f32>()?, clouds[i].points[0][0]);
    }
    Ok(())
}

/// `dbe simulate --realistic-surfaces`: the corridor gets floor ghosts (counted in the truth);
/// a scene without a floor is refused before anything is written.
#[test]
fn simulate_with_realistic_surfaces() -> TestResult {
    let tmp = tempfile::tempdir()?;
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let seq = tmp.path().join("corridor");
    let text = ok(&[
        "simulate",
        "--scene",
        s(&scenes.join("corridor.toml")),
        "--frames",
        "1",
        "--realistic-surfaces",
        "--out",
        s(&seq),
    ]);
    assert!(text.contains("floor ghosts"), "{text}");
    let truth: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(
        seq.join("groundtruth/frame_0.json"),
    )?)?;
    let ghosts: u64 = truth["objects"]
        .as_array()
        .ok_or("objects")?
        .iter()
        .filter_map(|o| o["ghosts"].as_u64())
        .sum();
    assert!(ghosts > 0, "no ghosts in the corridor");

    let bare = tmp.path().join("bare");
    let err = fails(&[
        "simulate",
        "--scene",
        s(&scenes.join("single_target.toml")),
        "--realistic-surfaces",
        "--out",
        s(&bare),
    ]);
    assert!(
        err.contains("--realistic-surfaces") && err.contains("plane_z_m"),
        "{err}"
    );
    assert!(!bare.exists(), "nothing written");
    Ok(())
}

/// `dbe calibrate` on the TI capture's corner reflector prints a `compRangeBiasAndRxChanPhase`
/// line a `.cfg` takes as it is; processed with it, the reflector sits at boresight (what the
/// calibration defines: its phases made equal), while without it the reflector is 4° off in
/// azimuth. Refusals: a search window beyond the chirp's ranges.
#[test]
fn calibrate_prints_the_line_a_ti_cfg_takes_and_it_moves_the_reflector_to_boresight() -> TestResult
{
    let Some(bin) = ti_capture() else {
        return Ok(());
    };
    let dir = tempfile::tempdir()?;
    // The capture's sizes with its assumed RF values (the fixture's waveform_cfg.txt).
    let cfg =
        "channelCfg 15 7 0\nadcCfg 2 1\nprofileCfg 0 60.25 10 6 60 0 0 60 1 256 10000 0 0 30\n\
               chirpCfg 0 0 0 0 0 0 0 1\nchirpCfg 1 1 0 0 0 0 0 2\nchirpCfg 2 2 0 0 0 0 0 4\n\
               frameCfg 0 2 64 0 100 1 0\n";
    let plain = dir.path().join("plain.cfg");
    std::fs::write(&plain, cfg)?;
    let board = ["--board", "iwr6843isk"];
    let out = ok(&[
        &[
            "calibrate",
            s(&bin),
            "--calib",
            s(&plain),
            "--distance",
            "3.7",
        ][..],
        &board[..],
    ]
    .concat());
    let line = out
        .lines()
        .find(|l| l.starts_with("compRangeBiasAndRxChanPhase "))
        .ok_or_else(|| format!("no line in {out}"))?;
    assert!(out.contains("range bin 38"), "{out}");
    let calibrated = dir.path().join("calibrated.cfg");
    std::fs::write(&calibrated, format!("{cfg}{out}"))?;
    let sensor =
        host_sim::io::ticfg::load_ti_cfg(&calibrated, host_sim::io::ticfg::Board::Iwr6843isk)?;
    let gains = sensor.channel_gains.ok_or("the line gave no factors")?;
    assert_eq!(gains.len(), 12);
    assert!(line.split_whitespace().count() == 2 + 24, "{line}");

    // The strongest point's azimuth and elevation, degrees, processed with `cfg`.
    let angles = |cfg: &Path, name: &str| -> Result<(f64, f64), Box<dyn std::error::Error>> {
        let o = dir.path().join(name);
        ok(&[
            &[
                "process",
                s(&bin),
                "--out",
                s(&o),
                "--format",
                "csv",
                "--calib",
                s(cfg),
            ][..],
            &board[..],
        ]
        .concat());
        let points = host_sim::io::read_csv(&o.join("csv/frame_0.csv"))?;
        let p = points
            .iter()
            .max_by(|a, b| a.intensity_db.total_cmp(&b.intensity_db))
            .ok_or("no points")?;
        let r = (p.x * p.x + p.y * p.y + p.z * p.z).sqrt();
        Ok((p.y.atan2(p.x).to_degrees(), (p.z / r).asin().to_degrees()))
    };
    let (az0, el0) = angles(&plain, "plain")?;
    let (az1, el1) = angles(&calibrated, "calibrated")?;
    eprintln!(
        "reflector: uncalibrated az {az0:.2}° el {el0:.2}°, calibrated az {az1:.3}° el {el1:.3}°"
    );
    assert!(az0.abs() > 2.0, "uncalibrated azimuth {az0}");
    assert!(
        az1.abs() < 0.2 && el1.abs() < 0.2,
        "calibrated {az1}° {el1}°"
    );

    let err = fails(
        &[
            &[
                "calibrate",
                s(&bin),
                "--calib",
                s(&plain),
                "--distance",
                "900",
            ][..],
            &board[..],
        ]
        .concat(),
    );
    assert!(err.contains("search window"), "{err}");
    Ok(())
}
