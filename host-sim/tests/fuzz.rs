//! Seeded mutation fuzzing of every reader, with a fixed budget that CI runs (`cargo fuzz`
//! needs a nightly toolchain, which `.ci/run` does not install).
//!
//! Each seed file (a valid file of the reader's format, written by our writers or taken from
//! the fixtures) is mutated [`MUTATIONS`] times by 1–4 random edits: a byte flipped, the file
//! truncated, random bytes inserted, a token replaced by an evil one (`1e39`, `nan`, `-0`, 2⁶⁴,
//! an escape sequence, …), a line duplicated, deleted or swapped. Every read must
//!
//! - return, never panic (each read runs under `catch_unwind`; a panic fails the test with the
//!   seed and the mutated text, so it can be replayed);
//! - on error, name a path inside the test's folder (which file or folder is wrong);
//! - on success for a sensor description (calibration folder, TI `.cfg`): either be refused by
//!   the core with an error, or run the core on a frame with a target, giving finite points.
//!
//! `FUZZ_MUTATIONS=N` raises the budget for a longer local run.

mod common;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use common::{fixture, synth_frame, Target};
use dbe_radar::Params;
use host_sim::cloud::PointRecord;
use host_sim::core_run::CoreRunner;
use host_sim::io::{self, ticfg, IoError};
use host_sim::sensor::SensorConfig;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Mutations per seed file in CI.
const MUTATIONS: usize = 150;

fn budget() -> usize {
    std::env::var("FUZZ_MUTATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(MUTATIONS)
}

/// Tokens that broke readers somewhere, once.
const EVIL: [&str; 16] = [
    "1e39",
    "-1e39",
    "nan",
    "inf",
    "-0",
    "0",
    "1e-300",
    "18446744073709551616",
    "-1",
    "4294967296",
    "\u{1b}[31m",
    "\0",
    "é",
    "",
    "1,5",
    "0x10",
];

/// 1–4 random edits of `bytes`.
fn mutate(rng: &mut StdRng, bytes: &[u8]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for _ in 0..rng.gen_range(1..=4) {
        let len = b.len();
        match rng.gen_range(0..7) {
            0 if len > 0 => {
                let i = rng.gen_range(0..len);
                b[i] ^= 1 << rng.gen_range(0..8);
            }
            1 => b.truncate(rng.gen_range(0..=len)),
            2 => {
                let at = rng.gen_range(0..=len);
                let junk: Vec<u8> = (0..rng.gen_range(1..8)).map(|_| rng.gen()).collect();
                b.splice(at..at, junk);
            }
            3 => {
                // Replace one whitespace-separated token of the text.
                let text = String::from_utf8_lossy(&b).into_owned();
                let tokens: Vec<(usize, usize)> = token_spans(&text);
                if let Some(&(s, e)) = tokens.get(rng.gen_range(0..tokens.len().max(1))) {
                    let evil = EVIL[rng.gen_range(0..EVIL.len())];
                    b = format!("{}{evil}{}", &text[..s], &text[e..]).into_bytes();
                }
            }
            op => {
                let text = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<&str> = text.lines().collect();
                if lines.is_empty() {
                    continue;
                }
                let i = rng.gen_range(0..lines.len());
                match op {
                    4 => lines.insert(i, lines[i]),
                    5 => {
                        lines.remove(i);
                    }
                    _ => {
                        let j = rng.gen_range(0..lines.len());
                        lines.swap(i, j);
                    }
                }
                b = (lines.join("\n") + "\n").into_bytes();
            }
        }
    }
    b
}

/// Byte spans of the whitespace-separated tokens of `text`.
fn token_spans(text: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = None;
    for (i, c) in text.char_indices() {
        match (c.is_whitespace(), start) {
            (true, Some(s)) => {
                spans.push((s, i));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(s) = start {
        spans.push((s, text.len()));
    }
    spans
}

/// Run `read` on `MUTATIONS` mutations of the file `target` (whose valid content is `seed`),
/// restoring it after each; `check` sees each result. A panic fails with what reproduces it.
fn fuzz<T>(
    name: &str,
    root: &Path,
    target: &Path,
    seed: &[u8],
    read: impl Fn() -> Result<T, IoError>,
    check: impl Fn(&T),
) {
    let mut rng = StdRng::seed_from_u64(0x5eed ^ name.len() as u64);
    let (mut accepted, mut refused) = (0usize, 0usize);
    for n in 0..budget() {
        let bytes = mutate(&mut rng, seed);
        std::fs::write(target, &bytes).unwrap_or_else(|e| panic!("{}: {e}", target.display()));
        let outcome = catch_unwind(AssertUnwindSafe(|| match read() {
            Ok(v) => {
                check(&v);
                true
            }
            Err(e) => {
                let text = e.to_string();
                assert!(
                    text.contains(&root.display().to_string()),
                    "{name} #{n}: the error names no path under {}: {text}",
                    root.display()
                );
                false
            }
        }));
        match outcome {
            Ok(true) => accepted += 1,
            Ok(false) => refused += 1,
            Err(_) => {}
        }
        if let Err(panic) = outcome {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!(
                "{name} mutation #{n} panicked: {what}\nfile {}:\n{:?}",
                target.display(),
                String::from_utf8_lossy(&bytes)
            );
        }
    }
    std::fs::write(target, seed).unwrap_or_else(|e| panic!("{}: {e}", target.display()));
    // Both paths exercised: mutations the reader accepts (checked further) and refuses.
    assert!(
        accepted > 0 && refused > 0,
        "{name}: {accepted} accepted, {refused} refused of {} mutations",
        budget()
    );
}

/// An accepted sensor is refused by the core or gives finite points on a frame with a target.
fn sensor_runs_or_is_refused(sensor: &SensorConfig) {
    let params = Params::defaults(sensor.samples);
    let Ok(mut runner) = CoreRunner::new(sensor, params) else {
        return;
    };
    // A frame of the sensor's sizes (small presets only: the budget is per mutation).
    if sensor.samples * sensor.loops > 128 * 128 {
        return;
    }
    let frame = synth_frame(sensor, &[Target::at(4.0, 10.0, 3.0, 0.5, 300.0)], 5.0, 1);
    let out = runner
        .process(&frame)
        .unwrap_or_else(|e| panic!("an accepted sensor's own frame: {e}"));
    for p in &out.points {
        assert!(finite(p), "non-finite point {p:?} from {sensor:?}");
    }
}

fn finite(p: &PointRecord) -> bool {
    [p.x, p.y, p.z, p.doppler, p.intensity_db, p.snr_db]
        .iter()
        .all(|v| v.is_finite())
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap_or_else(|e| panic!("tempdir: {e}"))
}

#[test]
fn calibration_files_never_panic_and_accepted_ones_run() {
    let Some(_) = fixture("coloradar-calib/single_chip/waveform_cfg.txt") else {
        return;
    };
    let dir = tmp();
    let calib = dir.path().join("calib");
    let src = common::shared_dir().join("fixtures/coloradar-calib/single_chip");
    std::fs::create_dir(&calib).unwrap_or_else(|e| panic!("{e}"));
    for f in ["waveform_cfg.txt", "antenna_cfg.txt", "coupling_calib.txt"] {
        std::fs::copy(src.join(f), calib.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    }
    for f in ["waveform_cfg.txt", "antenna_cfg.txt", "coupling_calib.txt"] {
        let path = calib.join(f);
        let seed = std::fs::read(&path).unwrap_or_else(|e| panic!("{f}: {e}"));
        fuzz(
            f,
            dir.path(),
            &path,
            &seed,
            || io::load_calib(&calib),
            sensor_runs_or_is_refused,
        );
    }
}

#[test]
fn ti_cfgs_never_panic_and_accepted_ones_run() {
    let dir = tmp();
    let path = dir.path().join("radar.cfg");
    for (file, board) in [
        ("coloradar_awr1843.cfg", ticfg::Board::Awr1843boost),
        ("awr1642_2tx.cfg", ticfg::Board::Awr1642boost),
    ] {
        let seed = std::fs::read(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data")
                .join(file),
        )
        .unwrap_or_else(|e| panic!("{file}: {e}"));
        fuzz(
            file,
            dir.path(),
            &path,
            &seed,
            || ticfg::load_ti_cfg(&path, board),
            sensor_runs_or_is_refused,
        );
    }
}

/// A small sensor whose frames are quick to write and read.
fn small_sensor() -> SensorConfig {
    SensorConfig {
        samples: 16,
        loops: 4,
        ..SensorConfig::coloradar()
    }
}

#[test]
fn raw_captures_and_sequences_never_panic() {
    let dir = tmp();
    let sensor = small_sensor();
    let frame = synth_frame(&sensor, &[Target::at(2.0, 0.0, 0.0, 0.0, 100.0)], 3.0, 2);
    // DCA1000: the whole capture mutated (sizes and interleave are its only structure).
    let bin = dir.path().join("adc_data.bin");
    io::write_dca1000(&bin, &sensor, &[&frame, &frame]).unwrap_or_else(|e| panic!("{e}"));
    let seed = std::fs::read(&bin).unwrap_or_else(|e| panic!("{e}"));
    fuzz(
        "dca1000",
        dir.path(),
        &bin,
        &seed,
        || io::read_dca1000(&bin, &sensor),
        |_| {},
    );

    // A ColoRadar sequence: its timestamps and one frame file.
    let seq = dir.path().join("seq");
    io::write_sequence(&seq, &sensor, &[(0.0, &frame), (0.1, &frame)])
        .unwrap_or_else(|e| panic!("{e}"));
    let adc = seq.join("single_chip/adc_samples");
    let read = || -> Result<usize, IoError> {
        let s = io::coloradar::open_sequence(&seq, &sensor)?;
        for i in 0..s.len() {
            s.read_frame(i)?;
        }
        Ok(s.len())
    };
    for file in ["timestamps.txt", "data/frame_1.bin"] {
        let path = adc.join(file);
        let seed = std::fs::read(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
        fuzz(file, dir.path(), &path, &seed, read, |_| {});
    }
    // Stray files whose names are almost frame names.
    let data = adc.join("data");
    for name in [
        "frame_18446744073709551615.bin",
        "frame_1000000000000.bin",
        "frame_-1.bin",
        "frame_.bin",
        "frame_1.bin.bak",
        "frame_01.bin",
    ] {
        let stray = data.join(name);
        std::fs::write(&stray, b"").unwrap_or_else(|e| panic!("{e}"));
        let r = catch_unwind(AssertUnwindSafe(read));
        assert!(r.is_ok(), "{name}: panicked");
        std::fs::remove_file(&stray).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn navigation_files_never_panic() {
    let dir = tmp();
    let seq = dir.path().join("seq");
    let (imu, gt) = (seq.join("imu"), seq.join("groundtruth"));
    for d in [&imu, &gt] {
        std::fs::create_dir_all(d).unwrap_or_else(|e| panic!("{e}"));
    }
    let write = |p: PathBuf, s: &str| std::fs::write(p, s).unwrap_or_else(|e| panic!("{e}"));
    write(
        imu.join("imu_data.txt"),
        "0.1 0.0 9.81 0.0 0.0 0.01\n0.1 0.0 9.80 0.0 0.0 0.01\n0.2 0.1 9.81 0.01 0.0 0.0\n",
    );
    write(imu.join("timestamps.txt"), "0.00\n0.01\n0.02\n");
    write(
        gt.join("groundtruth_poses.txt"),
        "0 0 0 0 0 0 1\n0.1 0 0 0 0 0.0499792 0.9987503\n",
    );
    write(gt.join("timestamps.txt"), "0.0\n0.1\n");
    let transform = dir.path().join("base_to_imu.txt");
    write(transform.clone(), "0.1 0 0.2\n0 0 0 1\n");
    for (name, path) in [
        ("imu_data.txt", imu.join("imu_data.txt")),
        ("imu timestamps", imu.join("timestamps.txt")),
    ] {
        let seed = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        fuzz(
            name,
            dir.path(),
            &path,
            &seed,
            || io::navigation::read_imu(&seq),
            |_| {},
        );
    }
    for (name, path) in [
        ("groundtruth_poses.txt", gt.join("groundtruth_poses.txt")),
        ("groundtruth timestamps", gt.join("timestamps.txt")),
    ] {
        let seed = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        fuzz(
            name,
            dir.path(),
            &path,
            &seed,
            || io::navigation::read_groundtruth(&seq),
            |_| {},
        );
    }
    let seed = std::fs::read(&transform).unwrap_or_else(|e| panic!("{e}"));
    fuzz(
        "transform",
        dir.path(),
        &transform,
        &seed,
        || io::navigation::read_transform(&transform),
        |m| {
            let _ = m;
        },
    );
}

#[test]
fn point_cloud_files_never_panic_and_read_back_finite() {
    let dir = tmp();
    let points: Vec<PointRecord> = (0..5)
        .map(|i| PointRecord {
            x: 1.0 + f64::from(i),
            y: -0.5,
            z: 0.25,
            doppler: 0.1,
            intensity_db: 60.0,
            snr_db: 12.0,
            range_bin: 10 + i,
            azimuth_bin: 90,
            elevation_bin: 50,
            doppler_bin: 1,
        })
        .collect();
    let csv = dir.path().join("frame_0.csv");
    io::write_csv(&csv, &points).unwrap_or_else(|e| panic!("{e}"));
    let seed = std::fs::read(&csv).unwrap_or_else(|e| panic!("{e}"));
    fuzz(
        "csv",
        dir.path(),
        &csv,
        &seed,
        || io::read_csv(&csv),
        |_| {},
    );
    let bin = dir.path().join("frame_0.bin");
    io::write_coloradar_bin(&bin, &points).unwrap_or_else(|e| panic!("{e}"));
    let seed = std::fs::read(&bin).unwrap_or_else(|e| panic!("{e}"));
    fuzz(
        "coloradar bin",
        dir.path(),
        &bin,
        &seed,
        || io::read_coloradar_bin(&bin),
        |_| {},
    );
}
