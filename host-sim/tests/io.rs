//! Readers and writers of calibration, raw data and point clouds: round trips on the real
//! fixtures in `../shared/fixtures`, and one test per kind of malformed input.

use std::f64::consts::PI;
use std::fs;
use std::path::{Path, PathBuf};

use host_sim::cloud::PointRecord;
use host_sim::frame::AdcFrame;
use host_sim::io::{self, IoError, PlyEncoding, CSV_HEADER};
use host_sim::sensor::{Coupling, SensorConfig};
use num_complex::{Complex32, Complex64};

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// `../shared/fixtures/<name>` (relative to the repository root). Missing: a loud failure when
/// `CI=true`, otherwise `None` and a printed skip message.
fn fixture(name: &str) -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/fixtures")
        .join(name);
    if path.is_dir() {
        return Some(path);
    }
    if std::env::var("CI").as_deref() == Ok("true") {
        panic!("fixture folder {} is missing (CI=true)", path.display());
    }
    eprintln!("skipping: fixture folder {} is missing", path.display());
    None
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().expect("create a temporary directory")
}

/// Copy the files of `src` into a new folder `dst`.
fn copy_dir(src: &Path, dst: &Path) {
    fs::create_dir_all(dst).expect("create copy folder");
    for e in fs::read_dir(src).expect("list fixture") {
        let e = e.expect("list fixture");
        if e.file_type().map(|t| t.is_file()).unwrap_or(false) {
            fs::copy(e.path(), dst.join(e.file_name())).expect("copy fixture file");
        }
    }
}

/// A calibration folder (files directly inside) holding the ColoRadar fixture with `file`'s
/// text transformed by `edit`.
fn edited_calib(file: &str, edit: impl Fn(&str) -> String) -> Option<(tempfile::TempDir, PathBuf)> {
    let src = fixture("coloradar-calib")?.join("single_chip");
    let dir = tmp();
    let calib = dir.path().join("calib");
    copy_dir(&src, &calib);
    let path = calib.join(file);
    let text = fs::read_to_string(&path).expect("read fixture copy");
    fs::write(&path, edit(&text)).expect("write edited fixture");
    Some((dir, calib))
}

fn replace_line(text: &str, key: &str, new: &str) -> String {
    text.lines()
        .map(|l| {
            if l.split_whitespace().next() == Some(key) {
                new.to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn expect_err<T: std::fmt::Debug>(r: Result<T, IoError>, what: &str) -> IoError {
    match r {
        Ok(v) => panic!("{what}: expected an error, got {v:?}"),
        Err(e) => {
            eprintln!("{what}: {e}");
            e
        }
    }
}

fn small_sensor() -> SensorConfig {
    SensorConfig {
        samples: 8,
        loops: 4,
        ..SensorConfig::coloradar()
    }
}

/// A frame whose every sample is distinct, so a wrong transpose cannot go unnoticed.
fn counting_frame(s: &SensorConfig, seed: i32) -> AdcFrame {
    let mut f = AdcFrame::zeros(s.samples, s.loops, s.num_tx, s.num_rx);
    for (j, v) in f.data.iter_mut().enumerate() {
        let j = j as i32 * 7 + seed;
        *v = [
            (j % 65_536 - 32_768) as i16,
            (32_767 - (j * 3) % 65_535) as i16,
        ];
    }
    f
}

// ---------------------------------------------------------------- calibration

#[test]
fn coloradar_calib_fixture_loads() -> TestResult {
    let Some(dir) = fixture("coloradar-calib") else {
        return Ok(());
    };
    let s = io::load_calib(&dir)?;
    let coupling = s
        .coupling
        .clone()
        .ok_or("coupling_calib.txt was not read")?;
    assert_eq!(
        SensorConfig {
            coupling: None,
            channel_gains: None,
            range_bias_m: 0.0,
            ..s.clone()
        },
        SensorConfig::coloradar()
    );
    assert_eq!(s.frame_bytes(), 786_432);
    assert_eq!(coupling.range_bins, 64);
    assert_eq!(coupling.data.len(), 3 * 4 * 64);
    // First and second values of the file: tx 0, rx 0, bins 0 and 1.
    assert_eq!(coupling.data[0], Complex32::new(-10558.0, -7146.95));
    assert_eq!(coupling.data[1], Complex32::new(4308.63, 5150.11));
    Ok(())
}

#[test]
fn iwr6843_calib_fixture_loads_from_flat_folder() -> TestResult {
    let Some(dir) = fixture("ti-iwr6843-corner-reflector") else {
        return Ok(());
    };
    assert_eq!(io::load_calib(&dir)?, SensorConfig::iwr6843_fixture());
    Ok(())
}

#[test]
fn write_calib_round_trips_bit_exact() -> TestResult {
    let Some(src) = fixture("coloradar-calib") else {
        return Ok(());
    };
    let sensor = io::load_calib(&src)?;
    let dir = tmp();
    let out = dir.path().join("calib");
    io::write_calib(&out, &sensor)?;
    for f in ["waveform_cfg.txt", "antenna_cfg.txt", "coupling_calib.txt"] {
        assert!(out.join("single_chip").join(f).is_file(), "{f} written");
    }
    assert_eq!(io::load_calib(&out)?, sensor);

    // Odd values survive too, and no coupling means no coupling file.
    let mut odd = SensorConfig::iwr6843_fixture();
    odd.f_design_hz = 60.123_456_789_1e9;
    odd.tx[1] = (2.25, 0.5);
    odd.waveform.idle_time_s = 0.0;
    let out2 = dir.path().join("calib2");
    io::write_calib(&out2, &odd)?;
    assert!(!out2.join("single_chip/coupling_calib.txt").exists());
    assert_eq!(io::load_calib(&out2)?, odd);
    Ok(())
}

#[test]
fn calib_tolerates_unknown_keys_comments_and_adc_start_time() -> TestResult {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        format!("# a comment\n{t}\nadc_start_time 6e-06  # trailing comment\nnum_samples_per_chirp_padded 256 extra\n\n")
    }) else {
        return Ok(());
    };
    let s = io::load_calib(&calib)?;
    assert_eq!(s.waveform, SensorConfig::coloradar().waveform);
    Ok(())
}

#[test]
fn waveform_values_in_the_wrong_unit_are_errors_naming_the_likely_unit() {
    // TI's tools write GHz, MHz/µs, ksps and µs; waveform_cfg.txt is SI. Each of these ran
    // before and gave 0 points in every frame.
    for (key, line, unit) in [
        ("start_frequency", "start_frequency 77", "GHz"),
        ("frequency_slope", "frequency_slope 100", "MHz/µs"),
        ("adc_sample_frequency", "adc_sample_frequency 10666", "ksps"),
        ("idle_time", "idle_time 110", "µs"),
        ("ramp_end_time", "ramp_end_time 20", "µs"),
        ("start_frequency", "start_frequency 1e300", ""),
        ("frequency_slope", "frequency_slope 1e-30", ""),
        ("adc_sample_frequency", "adc_sample_frequency 1e300", ""),
    ] {
        let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| replace_line(t, key, line))
        else {
            return;
        };
        let e = expect_err(io::load_calib(&calib), line).to_string();
        assert!(
            e.contains("waveform_cfg.txt")
                && e.contains(key)
                && e.contains("outside what FMCW radars use"),
            "{line}: {e}"
        );
        if !unit.is_empty() {
            assert!(e.contains(&format!("looks like {unit}")), "{line}: {e}");
        }
    }
}

#[test]
fn calib_missing_required_key_names_key_and_file() {
    for key in [
        "num_rx",
        "num_tx",
        "num_adc_samples_per_chirp",
        "num_chirps_per_frame",
        "adc_sample_frequency",
        "start_frequency",
        "idle_time",
        "ramp_end_time",
        "frequency_slope",
    ] {
        let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| replace_line(t, key, ""))
        else {
            return;
        };
        let e = expect_err(io::load_calib(&calib), key);
        match &e {
            IoError::MissingKey { path, key: k } => {
                assert_eq!(k, key);
                assert!(path.ends_with("waveform_cfg.txt"));
            }
            other => panic!("{key}: wrong error {other:?}"),
        }
        assert!(e.to_string().contains(key) && e.to_string().contains("waveform_cfg.txt"));
    }
}

#[test]
fn calib_non_number_is_a_syntax_error_with_line() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        replace_line(t, "adc_sample_frequency", "adc_sample_frequency ten_MHz")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "non-number");
    assert!(matches!(e, IoError::Syntax { line: 5, .. }), "{e:?}");
    assert!(e.to_string().contains("ten_MHz"));
}

#[test]
fn calib_nan_is_rejected() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        replace_line(t, "frequency_slope", "frequency_slope NaN")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "NaN slope");
    assert!(matches!(e, IoError::Syntax { .. }) && e.to_string().contains("not finite"));
}

#[test]
fn calib_non_positive_rate_is_rejected() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        replace_line(t, "adc_sample_frequency", "adc_sample_frequency -10666000")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "negative fs");
    assert!(e.to_string().contains("adc_sample_frequency") && e.to_string().contains("> 0"));
}

#[test]
fn calib_fractional_count_is_rejected() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        replace_line(t, "num_chirps_per_frame", "num_chirps_per_frame 127.5")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "fractional count");
    assert!(e.to_string().contains("whole number"));
}

#[test]
fn calib_sampling_past_ramp_end_is_rejected() {
    // 128 samples at 10.666 MHz take 12.0 µs; a 10 µs ramp cannot hold them.
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        replace_line(t, "ramp_end_time", "ramp_end_time 1e-5")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "short ramp");
    assert!(matches!(e, IoError::Invalid { .. }) && e.to_string().contains("ramp_end_time"));
}

#[test]
fn calib_duplicate_key_is_rejected() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| format!("{t}\nnum_tx 2\n")) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "duplicate");
    assert!(e.to_string().contains("given twice"));
}

#[test]
fn antenna_index_out_of_range_is_rejected() {
    let Some((_d, calib)) = edited_calib("antenna_cfg.txt", |t| t.replace("tx 1 4 0", "tx 3 4 0"))
    else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "tx 3");
    assert!(matches!(e, IoError::Syntax { .. }));
    assert!(e.to_string().contains("antenna_cfg.txt") && e.to_string().contains("0..3"));
}

#[test]
fn antenna_position_beyond_any_array_is_rejected_against_its_own_file() {
    // 1e39 does not fit an f32 (it became +inf and was reported against waveform_cfg.txt).
    for (value, shown) in [("1e39", "1e39"), ("3000", "3000")] {
        let Some((_dir, calib)) = edited_calib("antenna_cfg.txt", |t| {
            t.replacen("tx 1 4 0", &format!("tx 1 {value} 0"), 1)
        }) else {
            return;
        };
        let e = expect_err(io::load_calib(&calib), "antenna position");
        let text = e.to_string();
        assert!(
            text.contains("antenna_cfg.txt:") && text.contains(&format!("`tx 1 az` = {shown}")),
            "{text}"
        );
    }
}

#[test]
fn antenna_duplicate_index_is_rejected() {
    let Some((_d, calib)) = edited_calib("antenna_cfg.txt", |t| t.replace("tx 1 4 0", "tx 2 4 0"))
    else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "tx 2 twice");
    assert!(e.to_string().contains("`tx 2` given twice"));
}

#[test]
fn antenna_missing_index_is_rejected() {
    let Some((_d, calib)) = edited_calib("antenna_cfg.txt", |t| t.replace("rx 2 2 0", "")) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "rx 2 missing");
    assert!(e.to_string().contains("rx INDEX AZ EL") && e.to_string().contains("[2]"));
}

#[test]
fn antenna_count_disagreeing_with_waveform_is_rejected() {
    let Some((_d, calib)) = edited_calib("antenna_cfg.txt", |t| {
        replace_line(t, "num_tx", "num_tx 2").replace("tx 2 2 1", "")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "num_tx 2 vs 3");
    assert!(matches!(e, IoError::Invalid { .. }));
    let msg = e.to_string();
    assert!(
        msg.contains("antenna_cfg.txt") && msg.contains("waveform_cfg.txt"),
        "{msg}"
    );
}

#[test]
fn antenna_f_design_in_hz_is_rejected() {
    let Some((_d, calib)) = edited_calib("antenna_cfg.txt", |t| {
        replace_line(t, "F_design", "F_design 76800000000")
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "F_design in Hz");
    assert!(e.to_string().contains("GHz"));
}

#[test]
fn antenna_missing_f_design_is_rejected() {
    let Some((_d, calib)) = edited_calib("antenna_cfg.txt", |t| replace_line(t, "F_design", ""))
    else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "no F_design");
    assert!(matches!(e, IoError::MissingKey { ref key, .. } if key == "F_design"));
}

#[test]
fn coupling_wrong_length_is_rejected() {
    let Some((_d, calib)) = edited_calib("coupling_calib.txt", |t| {
        t.trim_end().to_string() + ",1,2\n"
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "coupling too long");
    let msg = e.to_string();
    assert!(msg.contains("coupling_calib.txt") && msg.contains("1538") && msg.contains("1536"));
}

#[test]
fn coupling_truncated_file_is_rejected() {
    // Cut after 1000 values (a download stopped half way).
    let Some((_d, calib)) = edited_calib("coupling_calib.txt", |t| {
        let start = t.find("data:").expect("data line") + 5;
        let cut = t[start..]
            .match_indices(',')
            .nth(999)
            .map(|(i, _)| start + i)
            .expect("1000 values");
        t[..cut].to_string()
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "coupling truncated");
    assert!(e
        .to_string()
        .contains("`data` has 1000 values; expected 1536"));
}

#[test]
fn coupling_nan_is_rejected() {
    let Some((_d, calib)) = edited_calib("coupling_calib.txt", |t| {
        t.replacen("data:-10558,", "data:nan,", 1)
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "coupling NaN");
    assert!(e.to_string().contains("data[tx 0][rx 0][bin 0]"));
}

#[test]
fn coupling_num_rx_disagreeing_is_rejected() {
    let Some((_d, calib)) =
        edited_calib("coupling_calib.txt", |t| t.replace("num_rx:4", "num_rx:2"))
    else {
        return;
    };
    // 1536 values no longer fit 3 × 2 × 64 complex: the length check speaks first.
    let e = expect_err(io::load_calib(&calib), "coupling num_rx 2");
    assert!(e.to_string().contains("expected 768"));
}

#[test]
fn coupling_more_bins_than_samples_is_rejected() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", |t| {
        replace_line(
            t,
            "num_adc_samples_per_chirp",
            "num_adc_samples_per_chirp 32",
        )
    }) else {
        return;
    };
    let e = expect_err(io::load_calib(&calib), "64 coupling bins, 32 samples");
    assert!(e.to_string().contains("num_range_bins 64"));
}

#[test]
fn calib_folder_without_files_is_not_found() {
    let dir = tmp();
    let e = expect_err(io::load_calib(dir.path()), "empty folder");
    assert!(matches!(e, IoError::NotFound { .. }) && e.to_string().contains("single_chip"));
    let e = expect_err(io::load_calib(&dir.path().join("nope")), "absent folder");
    assert!(matches!(e, IoError::NotFound { .. }));
}

#[test]
fn calib_missing_antenna_file_is_named() {
    let Some((_d, calib)) = edited_calib("waveform_cfg.txt", str::to_string) else {
        return;
    };
    fs::remove_file(calib.join("antenna_cfg.txt")).expect("remove");
    let e = expect_err(io::load_calib(&calib), "no antenna_cfg");
    assert!(matches!(e, IoError::NotFound { ref path, .. } if path.ends_with("antenna_cfg.txt")));
}

#[test]
fn write_calib_refuses_inconsistent_sensor_and_leaves_nothing() {
    let dir = tmp();
    let out = dir.path().join("calib");
    let mut s = SensorConfig::coloradar();
    s.tx.pop();
    let e = expect_err(io::write_calib(&out, &s), "2 TX positions for 3 TX");
    assert!(matches!(e, IoError::Invalid { .. }));
    let mut s = SensorConfig::coloradar();
    s.coupling = Some(Coupling {
        range_bins: 4,
        data: vec![Complex32::new(f32::NAN, 0.0); 48],
    });
    expect_err(io::write_calib(&out, &s), "NaN coupling");
    assert_eq!(fs::read_dir(dir.path()).map(|d| d.count()).unwrap_or(99), 0);
}

#[test]
fn write_calib_refuses_non_empty_target() -> TestResult {
    let dir = tmp();
    fs::write(dir.path().join("keep.txt"), "mine")?;
    let e = expect_err(
        io::write_calib(dir.path(), &SensorConfig::coloradar()),
        "non-empty",
    );
    assert!(matches!(e, IoError::OutputExists { .. }));
    assert_eq!(fs::read_to_string(dir.path().join("keep.txt"))?, "mine");
    Ok(())
}

// ---------------------------------------------------------------- ColoRadar sequences

#[test]
fn sequence_round_trip_full_size_coloradar() -> TestResult {
    let Some(src) = fixture("coloradar-calib") else {
        return Ok(());
    };
    let sensor = io::load_calib(&src)?;
    let frames: Vec<AdcFrame> = (0..3).map(|i| counting_frame(&sensor, i)).collect();
    let times = [
        1_597_180_520.386_927_8,
        1_597_180_520.486_9,
        1_597_180_520.586_9,
    ];
    let input: Vec<(f64, &AdcFrame)> = times.iter().copied().zip(frames.iter()).collect();
    let dir = tmp();
    let seq_dir = dir.path().join("seq");
    io::write_sequence(&seq_dir, &sensor, &input)?;

    let f0 = seq_dir.join("single_chip/adc_samples/data/frame_0.bin");
    assert_eq!(fs::metadata(&f0)?.len(), 786_432);
    // File order is [tx][rx][chirp][sample][I,Q]: word 2·128 is tx 0, rx 0, chirp 1, sample 0.
    let bytes = fs::read(&f0)?;
    let word = |w: usize| i16::from_le_bytes([bytes[2 * w], bytes[2 * w + 1]]);
    assert_eq!(
        word(2 * 128),
        frames[0].data[frames[0].index(1, 0, 0, 0)][0]
    );
    assert_eq!(
        word(2 * 128 * 128),
        frames[0].data[frames[0].index(0, 0, 1, 0)][0]
    );

    let seq = io::open_sequence(&seq_dir, &sensor)?;
    assert_eq!(seq.len(), 3);
    assert_eq!(seq.timestamps(), &times);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(&seq.read_frame(i)?, f, "frame {i}");
    }
    assert_eq!(io::load_calib(&seq_dir.join("calib"))?, sensor);
    // The adc_samples folder itself is accepted too.
    assert_eq!(
        io::open_sequence(&seq_dir.join("single_chip/adc_samples"), &sensor)?.len(),
        3
    );
    Ok(())
}

/// A written 3-frame sequence of the small sensor.
fn small_sequence() -> (tempfile::TempDir, PathBuf, SensorConfig) {
    let s = small_sensor();
    let frames: Vec<AdcFrame> = (0..3).map(|i| counting_frame(&s, i)).collect();
    let input: Vec<(f64, &AdcFrame)> = frames
        .iter()
        .enumerate()
        .map(|(i, f)| (i as f64 * 0.1, f))
        .collect();
    let dir = tmp();
    let seq = dir.path().join("seq");
    io::write_sequence(&seq, &s, &input).expect("write the small sequence");
    (dir, seq, s)
}

fn data_dir(seq: &Path) -> PathBuf {
    seq.join("single_chip/adc_samples/data")
}

#[test]
fn sequence_wrong_frame_size_names_file() -> TestResult {
    let (_d, seq, s) = small_sequence();
    let f1 = data_dir(&seq).join("frame_1.bin");
    let mut bytes = fs::read(&f1)?;
    bytes.truncate(bytes.len() - 4);
    fs::write(&f1, bytes)?;
    let e = expect_err(io::open_sequence(&seq, &s), "truncated frame");
    match &e {
        IoError::Size { path, found, .. } => {
            assert!(path.ends_with("frame_1.bin"));
            assert_eq!(*found, s.frame_bytes() as u64 - 4);
        }
        other => panic!("wrong error {other:?}"),
    }
    assert!(e.to_string().contains(&s.frame_bytes().to_string()));
    Ok(())
}

#[test]
fn sequence_against_wrong_sensor_is_a_size_error() {
    let (_d, seq, _s) = small_sequence();
    let e = expect_err(
        io::open_sequence(&seq, &SensorConfig::coloradar()),
        "wrong sensor",
    );
    assert!(e.to_string().contains("786432"));
}

#[test]
fn sequence_missing_frames_are_listed() -> TestResult {
    let (_d, seq, s) = small_sequence();
    fs::remove_file(data_dir(&seq).join("frame_1.bin"))?;
    let e = expect_err(io::open_sequence(&seq, &s), "gap");
    assert!(
        matches!(e, IoError::MissingFrames { ref missing, highest: 2, .. } if missing == &[(1, 1)])
    );
    assert!(e.to_string().contains("missing frame files 1"));
    Ok(())
}

#[test]
fn a_stray_frame_with_a_huge_index_is_an_error_not_a_panic() -> TestResult {
    // Fuzzing found these: the gap list overflowed `highest + 1` or tried to allocate terabytes.
    for (name, count) in [
        (
            "frame_18446744073709551615.bin",
            "18446744073709551612 missing",
        ),
        ("frame_1000000000000.bin", "999999999997 missing"),
    ] {
        let (_d, seq, s) = small_sequence();
        fs::write(data_dir(&seq).join(name), b"")?;
        let e = expect_err(io::open_sequence(&seq, &s), name);
        let text = e.to_string();
        assert!(
            matches!(e, IoError::MissingFrames { ref missing, .. } if missing.len() == 1),
            "{text}"
        );
        assert!(text.contains(count), "{text}");
    }
    Ok(())
}

#[test]
fn sequence_extra_files_are_named() -> TestResult {
    let (_d, seq, s) = small_sequence();
    fs::write(data_dir(&seq).join("notes.txt"), "x")?;
    fs::copy(
        data_dir(&seq).join("frame_2.bin"),
        data_dir(&seq).join("frame_02.bin"),
    )?;
    let e = expect_err(io::open_sequence(&seq, &s), "extra");
    assert!(
        matches!(e, IoError::ExtraFiles { ref files, .. } if files == &["frame_02.bin", "notes.txt"])
    );
    Ok(())
}

#[test]
fn sequence_timestamp_count_mismatch_is_rejected() -> TestResult {
    let (_d, seq, s) = small_sequence();
    let ts = seq.join("single_chip/adc_samples/timestamps.txt");
    fs::write(&ts, "0\n0.1\n")?;
    let e = expect_err(io::open_sequence(&seq, &s), "2 times for 3 frames");
    assert!(matches!(
        e,
        IoError::TimestampCount {
            found: 2,
            expected: 3,
            ..
        }
    ));
    assert!(e.to_string().contains("timestamps.txt"));
    Ok(())
}

#[test]
fn sequence_nan_timestamp_is_rejected() -> TestResult {
    let (_d, seq, s) = small_sequence();
    fs::write(
        seq.join("single_chip/adc_samples/timestamps.txt"),
        "0\nnan\n0.2\n",
    )?;
    let e = expect_err(io::open_sequence(&seq, &s), "NaN time");
    assert!(matches!(e, IoError::Syntax { line: 2, .. }));
    Ok(())
}

#[test]
fn sequence_backwards_timestamp_is_rejected() -> TestResult {
    let (_d, seq, s) = small_sequence();
    fs::write(
        seq.join("single_chip/adc_samples/timestamps.txt"),
        "0\n0.2\n0.1\n",
    )?;
    let e = expect_err(io::open_sequence(&seq, &s), "backwards time");
    assert!(matches!(e, IoError::Syntax { line: 3, .. }));
    Ok(())
}

#[test]
fn sequence_missing_timestamps_is_not_found() -> TestResult {
    let (_d, seq, s) = small_sequence();
    fs::remove_file(seq.join("single_chip/adc_samples/timestamps.txt"))?;
    let e = expect_err(io::open_sequence(&seq, &s), "no timestamps");
    assert!(matches!(e, IoError::NotFound { ref path, .. } if path.ends_with("timestamps.txt")));
    Ok(())
}

#[test]
fn sequence_without_frames_is_rejected() -> TestResult {
    let (_d, seq, s) = small_sequence();
    for i in 0..3 {
        fs::remove_file(data_dir(&seq).join(format!("frame_{i}.bin")))?;
    }
    let e = expect_err(io::open_sequence(&seq, &s), "no frames");
    assert!(matches!(e, IoError::NotFound { .. }) && e.to_string().contains("frame_0.bin"));
    let e = expect_err(io::open_sequence(&seq.join("absent"), &s), "no folder");
    assert!(matches!(e, IoError::NotFound { .. }));
    Ok(())
}

#[test]
fn sequence_read_frame_checks_index_and_size() -> TestResult {
    let (_d, seq, s) = small_sequence();
    let opened = io::open_sequence(&seq, &s)?;
    expect_err(opened.read_frame(3), "index 3 of 3");
    fs::write(data_dir(&seq).join("frame_0.bin"), [0u8; 10])?;
    let e = expect_err(opened.read_frame(0), "shrunk after open");
    assert!(matches!(e, IoError::Size { found: 10, .. }));
    Ok(())
}

#[test]
fn write_sequence_rejects_bad_input_and_leaves_nothing() {
    let s = small_sensor();
    let good = counting_frame(&s, 0);
    let wrong = AdcFrame::zeros(s.samples, s.loops + 1, s.num_tx, s.num_rx);
    let dir = tmp();
    let out = dir.path().join("seq");
    let e = expect_err(
        io::write_sequence(&out, &s, &[(0.0, &good), (0.1, &wrong)]),
        "shape",
    );
    assert!(e.to_string().contains("frame 1"));
    let e = expect_err(
        io::write_sequence(&out, &s, &[(f64::NAN, &good)]),
        "NaN time",
    );
    assert!(e.to_string().contains("frame 0"));
    expect_err(io::write_sequence(&out, &s, &[]), "no frames");
    assert!(!out.exists());
    assert_eq!(fs::read_dir(dir.path()).map(|d| d.count()).unwrap_or(99), 0);
}

// ---------------------------------------------------------------- DCA1000

/// A plain DFT of one chirp, the way the pipeline's range stage does it (spec §3 step 0):
/// subtract the mean, apply a symmetric Blackman window, then `X[b] = Σ x[n]·exp(−j2πnb/N)`.
struct Dft {
    window: Vec<f64>,
    twiddle: Vec<Complex64>,
}

impl Dft {
    fn new(n: usize) -> Self {
        let m = (n - 1) as f64;
        Self {
            window: (0..n)
                .map(|i| {
                    let a = 2.0 * PI * i as f64 / m;
                    0.42 - 0.5 * a.cos() + 0.08 * (2.0 * a).cos()
                })
                .collect(),
            twiddle: (0..n)
                .map(|i| Complex64::from_polar(1.0, -2.0 * PI * i as f64 / n as f64))
                .collect(),
        }
    }

    fn bin(&self, x: &[[i16; 2]], b: usize) -> Complex64 {
        let n = x.len();
        let c = |s: &[i16; 2]| Complex64::new(f64::from(s[0]), f64::from(s[1]));
        let mean = x.iter().map(c).sum::<Complex64>() / n as f64;
        x.iter()
            .enumerate()
            .map(|(i, s)| (c(s) - mean) * self.window[i] * self.twiddle[(i * b) % n])
            .sum()
    }
}

#[test]
fn dca1000_fixture_reflector_at_bin_38_with_readme_phases() -> TestResult {
    let Some(dir) = fixture("ti-iwr6843-corner-reflector") else {
        return Ok(());
    };
    let sensor = io::load_calib(&dir)?;
    let frames = io::read_dca1000(&dir.join("adc_data_Raw_0.bin"), &sensor)?;
    assert_eq!(frames.len(), 1);
    let f = &frames[0];
    let n = sensor.samples;
    let dft = Dft::new(n);

    // Range profile: power over every chirp of every virtual antenna.
    let mut power = vec![0.0f64; n];
    for k in 0..sensor.loops {
        for t in 0..sensor.num_tx {
            for r in 0..sensor.num_rx {
                let start = f.index(k, t, r, 0);
                for (b, p) in power.iter_mut().enumerate() {
                    *p += dft.bin(&f.data[start..start + n], b).norm_sqr();
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| power[b].total_cmp(&power[a]));
    println!("strongest range bins {:?}", &order[..6]);
    assert_eq!(order[0], 38, "README: reflector at range bin 38");
    let mut next = [order[1], order[2]];
    next.sort();
    assert_eq!(next, [37, 39], "README: 37 and 39 next");

    // Phases at bin 38, summed over loops (static target), relative to TX0/RX0.
    let readme = [
        0.0, -4.0, 0.0, 17.0, 34.0, 30.0, 35.0, 52.0, 61.0, 56.0, 61.0, 78.0,
    ];
    let mut sum = [Complex64::new(0.0, 0.0); 12];
    let mut slow = vec![Complex64::new(0.0, 0.0); sensor.loops];
    for (k, s) in slow.iter_mut().enumerate() {
        for t in 0..3 {
            for r in 0..4 {
                let start = f.index(k, t, r, 0);
                let v = dft.bin(&f.data[start..start + n], 38);
                sum[t * 4 + r] += v;
                *s += v;
            }
        }
    }
    let mut measured = Vec::new();
    for (m, &want) in readme.iter().enumerate() {
        let deg = (sum[m] / sum[0]).arg().to_degrees();
        measured.push((deg * 10.0).round() / 10.0);
        // The README gives whole degrees (±0.5°); 1° leaves room for its FFT length/window
        // details (the range window is the pipeline's Blackman). A swapped TX or RX order moves some phase by ≥ 17°, a swapped I/Q moves the
        // peak to bin 218.
        assert!(
            (deg - want).abs() <= 1.0,
            "antenna {m}: {deg:.2}° vs README {want}°"
        );
    }
    println!("phases at bin 38: {measured:?}");

    // Strongest Doppler bin of the summed slow time is 0 (static reflector): checks loop order.
    let dop: Vec<f64> = (0..sensor.loops)
        .map(|d| {
            slow.iter()
                .enumerate()
                .fold(Complex64::new(0.0, 0.0), |a, (k, &v)| {
                    a + v * Complex64::from_polar(
                        1.0,
                        -2.0 * PI * (k * d) as f64 / sensor.loops as f64,
                    )
                })
                .norm_sqr()
        })
        .collect();
    let best = (0..sensor.loops).max_by(|&a, &b| dop[a].total_cmp(&dop[b]));
    assert_eq!(best, Some(0));
    Ok(())
}

#[test]
fn dca1000_interleave_is_i_i_q_q() -> TestResult {
    let s = SensorConfig {
        samples: 2,
        loops: 1,
        num_tx: 1,
        num_rx: 1,
        tx: vec![(0.0, 0.0)],
        rx: vec![(0.0, 0.0)],
        ..SensorConfig::coloradar()
    };
    let dir = tmp();
    let path = dir.path().join("cap.bin");
    let words: [i16; 4] = [1, 2, -3, -4];
    fs::write(
        &path,
        words
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect::<Vec<u8>>(),
    )?;
    let frames = io::read_dca1000(&path, &s)?;
    assert_eq!(frames[0].data, vec![[1, -3], [2, -4]]);
    Ok(())
}

#[test]
fn dca1000_round_trip_several_frames() -> TestResult {
    let s = small_sensor();
    let frames = [counting_frame(&s, 1), counting_frame(&s, 2)];
    let dir = tmp();
    let path = dir.path().join("adc_data.bin");
    io::write_dca1000(&path, &s, &[&frames[0], &frames[1]])?;
    assert_eq!(fs::metadata(&path)?.len(), 2 * s.frame_bytes() as u64);
    assert_eq!(io::read_dca1000(&path, &s)?, frames);
    Ok(())
}

#[test]
fn dca1000_size_not_a_multiple_reports_trailing_bytes() -> TestResult {
    let s = small_sensor();
    let dir = tmp();
    let path = dir.path().join("cap.bin");
    fs::write(&path, vec![0u8; 2 * s.frame_bytes() + 100])?;
    let e = expect_err(io::read_dca1000(&path, &s), "trailing bytes");
    let msg = e.to_string();
    assert!(matches!(e, IoError::Size { .. }));
    assert!(msg.contains("cap.bin") && msg.contains(&s.frame_bytes().to_string()));
    assert!(
        msg.contains("2 whole frames and 100 trailing bytes"),
        "{msg}"
    );
    fs::write(&path, [])?;
    expect_err(io::read_dca1000(&path, &s), "empty capture");
    Ok(())
}

#[test]
fn dca1000_fixture_with_wrong_sensor_is_rejected() {
    let Some(dir) = fixture("ti-iwr6843-corner-reflector") else {
        return;
    };
    // 786,432 bytes are one IWR6843 frame but 1.0 ColoRadar frame too: sizes alone cannot
    // tell, so pick a sensor whose frame size does not divide the file.
    let s = SensorConfig {
        loops: 100,
        ..SensorConfig::iwr6843_fixture()
    };
    let e = expect_err(
        io::read_dca1000(&dir.join("adc_data_Raw_0.bin"), &s),
        "100 loops",
    );
    assert!(e.to_string().contains("786432 bytes"));
}

#[test]
fn dca1000_odd_samples_and_missing_file_are_rejected() {
    let s = SensorConfig {
        samples: 7,
        ..small_sensor()
    };
    let dir = tmp();
    let e = expect_err(
        io::read_dca1000(&dir.path().join("x.bin"), &s),
        "odd samples",
    );
    assert!(e.to_string().contains("even"));
    let e = expect_err(
        io::read_dca1000(&dir.path().join("x.bin"), &small_sensor()),
        "absent",
    );
    assert!(matches!(e, IoError::NotFound { .. }));
}

// ---------------------------------------------------------------- point clouds

fn points(n: usize, seed: f64) -> Vec<PointRecord> {
    (0..n)
        .map(|i| {
            let f = i as f64 + seed;
            PointRecord {
                x: 1.0 + 0.37 * f,
                y: -2.5 + 0.11 * f,
                z: 0.013 * f - 0.2,
                doppler: -1.25 + 0.1 * f,
                intensity_db: 60.0 + f / 3.0,
                snr_db: 12.5 + f / 7.0,
                range_bin: 12 + i as u32,
                azimuth_bin: 90 + i as u32,
                elevation_bin: 50,
                doppler_bin: i as i32 - 3,
            }
        })
        .collect()
}

/// What the float32 formats keep of a record.
fn as_f32(p: &PointRecord) -> [f32; 5] {
    [
        p.x as f32,
        p.y as f32,
        p.z as f32,
        p.intensity_db as f32,
        p.doppler as f32,
    ]
}

#[test]
fn coloradar_pointclouds_round_trip() -> TestResult {
    let frames = [points(5, 0.0), Vec::new(), points(17, 0.5)];
    let times = [10.0, 10.1, 10.2];
    let input: Vec<(f64, &[PointRecord])> = times
        .iter()
        .copied()
        .zip(frames.iter().map(Vec::as_slice))
        .collect();
    let dir = tmp();
    let out = dir.path().join("out");
    io::write_coloradar_pointclouds(&out, &input)?;
    let data = out.join("single_chip/pointclouds/data");
    assert_eq!(
        fs::metadata(data.join("radar_pointcloud_0.bin"))?.len(),
        5 * 20
    );
    assert_eq!(fs::metadata(data.join("radar_pointcloud_1.bin"))?.len(), 0);
    // Layout: float32 LE x, y, z, intensity, doppler.
    let raw = fs::read(data.join("radar_pointcloud_2.bin"))?;
    let f =
        |k: usize| f32::from_le_bytes([raw[4 * k], raw[4 * k + 1], raw[4 * k + 2], raw[4 * k + 3]]);
    assert_eq!([f(0), f(1), f(2), f(3), f(4)], as_f32(&frames[2][0]));

    let back = io::read_coloradar_pointclouds(&out)?;
    assert_eq!(back.len(), 3);
    for ((t, pts), (want_t, want)) in back.iter().zip(times.iter().zip(&frames)) {
        assert_eq!(t, want_t);
        let got: Vec<[f32; 5]> = pts.iter().map(as_f32).collect();
        let want: Vec<[f32; 5]> = want.iter().map(as_f32).collect();
        assert_eq!(got, want);
    }
    Ok(())
}

#[test]
fn coloradar_pointcloud_writer_failure_leaves_nothing() -> TestResult {
    let dir = tmp();
    let out = dir.path().join("out");
    let mut w = io::ColoradarCloudWriter::create(&out)?;
    w.push(0.0, &points(3, 0.0))?;
    let mut bad = points(3, 0.0);
    bad[2].z = f64::NAN;
    let e = expect_err(w.push(0.1, &bad), "NaN z");
    assert!(e.to_string().contains("point 2") && e.to_string().contains("radar_pointcloud_1.bin"));
    drop(w);
    assert!(!out.exists());
    assert_eq!(
        fs::read_dir(dir.path())?.count(),
        0,
        "staging folder removed"
    );
    Ok(())
}

#[test]
fn coloradar_pointcloud_writer_rejects_backwards_time_and_existing_output() -> TestResult {
    let dir = tmp();
    let out = dir.path().join("out");
    let mut w = io::ColoradarCloudWriter::create(&out)?;
    w.push(1.0, &[])?;
    expect_err(w.push(0.5, &[]), "backwards");
    w.push(1.5, &[])?;
    w.finish()?;
    let e = expect_err(io::ColoradarCloudWriter::create(&out), "exists");
    assert!(matches!(e, IoError::OutputExists { .. }));
    Ok(())
}

#[test]
fn coloradar_bin_bad_size_and_nan_are_rejected() -> TestResult {
    let dir = tmp();
    let path = dir.path().join("radar_pointcloud_0.bin");
    fs::write(&path, [0u8; 42])?;
    let e = expect_err(io::read_coloradar_bin(&path), "42 bytes");
    assert!(e.to_string().contains("2 trailing bytes"));
    let mut bytes = vec![0u8; 40];
    bytes[24..28].copy_from_slice(&f32::NAN.to_le_bytes());
    fs::write(&path, bytes)?;
    let e = expect_err(io::read_coloradar_bin(&path), "NaN");
    assert!(e.to_string().contains("point 1"));
    Ok(())
}

#[test]
fn pointcloud_sequence_gaps_are_rejected() -> TestResult {
    let dir = tmp();
    let out = dir.path().join("out");
    let frames = [points(2, 0.0), points(2, 1.0), points(2, 2.0)];
    let input: Vec<(f64, &[PointRecord])> = frames
        .iter()
        .enumerate()
        .map(|(i, p)| (i as f64, p.as_slice()))
        .collect();
    io::write_coloradar_pointclouds(&out, &input)?;
    fs::remove_file(out.join("single_chip/pointclouds/data/radar_pointcloud_0.bin"))?;
    let e = expect_err(io::read_coloradar_pointclouds(&out), "missing cloud 0");
    assert!(matches!(e, IoError::MissingFrames { ref missing, .. } if missing == &[(0, 0)]));
    Ok(())
}

#[test]
fn csv_round_trips_exactly() -> TestResult {
    let pts = points(9, 0.25);
    let dir = tmp();
    let path = dir.path().join("cloud.csv");
    io::write_csv(&path, &pts)?;
    let text = fs::read_to_string(&path)?;
    assert_eq!(text.lines().next(), Some(CSV_HEADER));
    assert_eq!(
        CSV_HEADER,
        "x,y,z,intensity_db,doppler,snr_db,range_bin,azimuth_bin,elevation_bin,doppler_bin"
    );
    assert_eq!(text.lines().count(), 10);
    assert_eq!(io::read_csv(&path)?, pts);
    Ok(())
}

#[test]
fn csv_malformed_inputs_are_rejected() -> TestResult {
    let dir = tmp();
    let path = dir.path().join("c.csv");
    let row = "1,2,3,0.5,60,12,20,90,50,-3";
    for (body, line, needle) in [
        (format!("x,y,z\n{row}\n"), 1, "header"),
        (format!("{CSV_HEADER}\n{row}\n1,2,3\n"), 3, "3 fields"),
        (
            format!("{CSV_HEADER}\n1,2,NaN,0.5,60,12,20,90,50,-3\n"),
            2,
            "z = `NaN`",
        ),
        (
            format!("{CSV_HEADER}\n1,2,3,0.5,60,12,-20,90,50,-3\n"),
            2,
            "range_bin",
        ),
        (
            format!("{CSV_HEADER}\n1,2,3,0.5,60,12,20,90,50,x\n"),
            2,
            "doppler_bin",
        ),
        (String::new(), 1, "empty"),
    ] {
        fs::write(&path, &body)?;
        let e = expect_err(io::read_csv(&path), needle);
        assert!(
            matches!(e, IoError::Syntax { line: l, .. } if l == line),
            "{needle}: {e:?}"
        );
        assert!(e.to_string().contains(needle), "{needle}: {e}");
    }
    Ok(())
}

#[test]
fn writer_with_nan_keeps_the_old_file() -> TestResult {
    let dir = tmp();
    let path = dir.path().join("cloud.csv");
    io::write_csv(&path, &points(2, 0.0))?;
    let before = fs::read(&path)?;
    let mut bad = points(2, 0.0);
    bad[1].snr_db = f64::INFINITY;
    let e = expect_err(io::write_csv(&path, &bad), "inf snr");
    assert!(e.to_string().contains("point 1: snr_db"));
    assert_eq!(fs::read(&path)?, before);
    bad[1].snr_db = 0.0;
    bad[0].x = 1e39; // finite f64, infinite as float32
    for r in [
        io::write_pcd(&dir.path().join("c.pcd"), &bad),
        io::write_ply(
            &dir.path().join("c.ply"),
            &bad,
            PlyEncoding::BinaryLittleEndian,
        ),
        io::write_coloradar_bin(&dir.path().join("c.bin"), &bad),
    ] {
        let e = expect_err(r, "x beyond float32");
        assert!(e.to_string().contains("point 0: x"));
    }
    assert_eq!(
        fs::read_dir(dir.path())?.count(),
        1,
        "only cloud.csv, no temporaries"
    );
    Ok(())
}

/// Split a file into its header (through the line `end`) and the binary body.
fn split_header<'a>(bytes: &'a [u8], end: &str) -> (Vec<String>, &'a [u8]) {
    let marker = format!("{end}\n");
    let pos = bytes
        .windows(marker.len())
        .position(|w| w == marker.as_bytes())
        .expect("header end marker");
    let header = std::str::from_utf8(&bytes[..pos + marker.len()]).expect("ASCII header");
    (
        header.lines().map(str::to_string).collect(),
        &bytes[pos + marker.len()..],
    )
}

/// The six-float rows (`x y z intensity doppler snr`) of a PCD or binary PLY body.
fn floats(body: &[u8]) -> Vec<[f32; 6]> {
    body.chunks_exact(24)
        .map(|c| {
            std::array::from_fn(|k| {
                f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
            })
        })
        .collect()
}

/// A point's six columns of PCD, PLY and MCAP, as f32.
fn as_f32_6(p: &PointRecord) -> [f32; 6] {
    [
        p.x as f32,
        p.y as f32,
        p.z as f32,
        p.intensity_db as f32,
        p.doppler as f32,
        p.snr_db as f32,
    ]
}

#[test]
fn pcd_is_pcl_binary_with_six_float_fields() -> TestResult {
    let pts = points(6, 0.0);
    let dir = tmp();
    let path = dir.path().join("cloud.pcd");
    io::write_pcd(&path, &pts)?;
    let bytes = fs::read(&path)?;
    let (header, body) = split_header(&bytes, "DATA binary");
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    for want in [
        "VERSION 0.7",
        "FIELDS x y z intensity doppler snr",
        "SIZE 4 4 4 4 4 4",
        "TYPE F F F F F F",
        "COUNT 1 1 1 1 1 1",
        "WIDTH 6",
        "HEIGHT 1",
        "POINTS 6",
        "DATA binary",
    ] {
        assert!(h.contains(&want), "PCD header lacks `{want}`: {h:?}");
    }
    assert_eq!(body.len(), 6 * 24);
    assert_eq!(floats(body), pts.iter().map(as_f32_6).collect::<Vec<_>>());
    Ok(())
}

#[test]
fn ply_binary_and_ascii_hold_the_points() -> TestResult {
    let pts = points(4, 0.5);
    let want: Vec<[f32; 6]> = pts.iter().map(as_f32_6).collect();
    let dir = tmp();
    let props = [
        "property float x",
        "property float y",
        "property float z",
        "property float intensity",
        "property float doppler",
        "property float snr",
    ];

    let bin = dir.path().join("cloud.ply");
    io::write_ply(&bin, &pts, PlyEncoding::BinaryLittleEndian)?;
    let bytes = fs::read(&bin)?;
    let (header, body) = split_header(&bytes, "end_header");
    assert_eq!(header[0], "ply");
    assert_eq!(header[1], "format binary_little_endian 1.0");
    assert!(header.contains(&"element vertex 4".to_string()));
    let p: Vec<&str> = header
        .iter()
        .filter(|l| l.starts_with("property"))
        .map(String::as_str)
        .collect();
    assert_eq!(p, props);
    assert_eq!(floats(body), want);

    let asc = dir.path().join("cloud_ascii.ply");
    io::write_ply(&asc, &pts, PlyEncoding::Ascii)?;
    let text = fs::read_to_string(&asc)?;
    let (header, body) = text.split_once("end_header\n").ok_or("no end_header")?;
    assert!(header.contains("format ascii 1.0\n"));
    let rows: Vec<[f32; 6]> = body
        .lines()
        .map(|l| {
            let v: Vec<f32> = l.split(' ').map(|t| t.parse().expect("float")).collect();
            [v[0], v[1], v[2], v[3], v[4], v[5]]
        })
        .collect();
    assert_eq!(rows, want);
    Ok(())
}

#[test]
fn absurd_sensor_sizes_are_rejected_without_overflow() {
    // 65,536 × 65,536 × 3 × 4 × 4 bytes would overflow nothing on 64 bits but is 206 GB a frame.
    let s = SensorConfig {
        samples: 65_536,
        loops: 65_536,
        ..SensorConfig::coloradar()
    };
    let dir = tmp();
    let e = expect_err(io::open_sequence(dir.path(), &s), "huge frame");
    assert!(e.to_string().contains("expected at most 1073741824 bytes"));
    let e = expect_err(
        io::read_dca1000(&dir.path().join("x.bin"), &s),
        "huge frame",
    );
    assert!(matches!(e, IoError::Invalid { .. }));
}

#[test]
fn mcap_holds_one_foxglove_point_cloud_per_frame_with_its_time() -> TestResult {
    use host_sim::io::mcap::{read_mcap, write_mcap, McapFrame, POINT_STRIDE};
    let frames = [points(5, 0.0), Vec::new(), points(3, 0.5)];
    let times = [1_600_000_000.25, 1_600_000_000.35, 1_600_000_000.45];
    let input: Vec<McapFrame<'_>> = frames
        .iter()
        .zip(times)
        .map(|(p, t)| McapFrame {
            time_s: t,
            points: p,
        })
        .collect();
    let dir = tmp();
    let path = dir.path().join("run.mcap");
    write_mcap(&path, &input)?;
    let back = read_mcap(&path)?;
    assert_eq!(back.len(), 3);
    assert_eq!(POINT_STRIDE, 24);
    for ((cloud, pts), t) in back.iter().zip(&frames).zip(times) {
        // f64 seconds → ns: exact to the f64 of the product, rounded.
        assert_eq!(cloud.log_time_ns, (t * 1e9).round() as u64);
        assert_eq!(
            cloud.points,
            pts.iter().map(as_f32_6).collect::<Vec<_>>(),
            "x y z intensity doppler snr, in that order"
        );
    }

    // A point that is not finite as f32, or a time MCAP cannot hold, is an error naming the
    // frame; nothing is written.
    let mut bad = points(2, 0.0);
    bad[1].snr_db = f64::NAN;
    let bad_path = dir.path().join("bad.mcap");
    let e = expect_err(
        write_mcap(
            &bad_path,
            &[McapFrame {
                time_s: 0.0,
                points: &bad,
            }],
        ),
        "snr",
    );
    assert!(e.to_string().contains("frame 0, point 1"), "{e}");
    let e = expect_err(
        write_mcap(
            &bad_path,
            &[McapFrame {
                time_s: -1.0,
                points: &frames[0],
            }],
        ),
        "timestamp",
    );
    assert!(e.to_string().contains("frame 0"), "{e}");
    assert!(!bad_path.exists());

    // Not an MCAP file: an error naming it.
    std::fs::write(&bad_path, b"not mcap")?;
    let e = expect_err(read_mcap(&bad_path), "not MCAP");
    assert!(e.to_string().contains("bad.mcap"), "{e}");
    Ok(())
}
