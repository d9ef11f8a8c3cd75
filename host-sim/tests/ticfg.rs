//! TI mmWave SDK `.cfg` files as sensor descriptions: what they give, and every setup the chains
//! cannot run refused with the line named.

use std::path::{Path, PathBuf};

use host_sim::io::ticfg::{load_ti_cfg, Board};
use host_sim::sensor::SensorConfig;

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn coloradar_cfg() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/coloradar_awr1843.cfg")
}

#[test]
fn the_coloradar_cfg_gives_coloradar_s_sensor() -> TestResult {
    let s = load_ti_cfg(&coloradar_cfg(), Board::Awr1843boost)?;
    let c = SensorConfig::coloradar();
    assert_eq!((s.samples, s.loops, s.num_tx, s.num_rx), (128, 128, 3, 4));
    // TDM order from the chirps' TX masks 1, 4, 2: TX0, TX2, TX1 = ColoRadar's antenna_cfg.
    assert_eq!(s.tx, c.tx);
    assert_eq!(s.rx, c.rx);
    assert_eq!(s.f_design_hz, c.f_design_hz);
    let (w, cw) = (s.waveform, c.waveform);
    // The .cfg's round numbers against the calibration file's, which are float32 roundings of
    // them (ramp end 1.99999994948e-05 s for 20 µs): within one f32 ulp, 2⁻²³ relative.
    for (a, b) in [
        (w.start_frequency_hz, cw.start_frequency_hz),
        (w.slope_hz_per_s, cw.slope_hz_per_s),
        (w.adc_sample_rate_hz, cw.adc_sample_rate_hz),
        (w.idle_time_s, cw.idle_time_s),
        (w.ramp_end_time_s, cw.ramp_end_time_s),
    ] {
        assert!(
            (a - b).abs() <= f64::from(f32::EPSILON) * b.abs(),
            "{a} vs {b}"
        );
    }
    assert!((s.adc_start_time_s - 6e-6).abs() < 1e-15);
    Ok(())
}

#[test]
fn a_two_tx_cfg_on_a_line_board_gives_the_awr1642_sensor() -> TestResult {
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/awr1642_2tx.cfg");
    let s = load_ti_cfg(&cfg, Board::Awr1642boost)?;
    let c = SensorConfig::awr1642();
    assert_eq!((s.samples, s.loops, s.num_tx, s.num_rx), (128, 128, 2, 4));
    assert_eq!((&s.tx, &s.rx, s.f_design_hz), (&c.tx, &c.rx, c.f_design_hz));
    assert!(!s.measures_elevation());
    // The AWR1843's TX0 and TX2 are the same line (azimuth 0 and 4): 2 TX, no elevation.
    let dir = tempfile::tempdir()?;
    let text = std::fs::read_to_string(&cfg)?;
    let line = dir.path().join("line.cfg");
    std::fs::write(
        &line,
        text.replace("channelCfg 15 3 0", "channelCfg 15 5 0")
            .replace("chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 4"),
    )?;
    let s = load_ti_cfg(&line, Board::Awr1843boost)?;
    assert_eq!((s.num_tx, &s.tx, s.measures_elevation()), (2, &c.tx, false));
    // A TX the board does not have is named.
    let err = load_ti_cfg(&line, Board::Awr1642boost)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        err.contains("TX2 (mask 4) does not exist on the awr1642boost (2 TX)"),
        "{err}"
    );
    Ok(())
}

#[test]
fn setups_the_chains_cannot_run_are_refused_naming_the_line() -> TestResult {
    let base = std::fs::read_to_string(coloradar_cfg())?;
    let dir = tempfile::tempdir()?;
    let cases = [
        (
            "chirpCfg 1 1 0 0 0 0 0 4",
            "chirpCfg 1 1 0 0 0 0 0 5",
            "one TX (mask 1, 2 or 4) per chirp",
        ),
        (
            "chirpCfg 1 1 0 0 0 0 0 4",
            "chirpCfg 1 1 0 0 0 0 0 1",
            "fires twice",
        ),
        (
            "chirpCfg 1 1 0 0 0 0 0 4",
            "chirpCfg 1 1 0 0 0.1 0 0 4",
            "chirp variations",
        ),
        ("channelCfg 15 7 0", "channelCfg 15 3 0", "not enabled"),
        ("adcCfg 2 1", "adcCfg 2 0", "real ADC output"),
        (
            "frameCfg 0 2 128 0 100 1 0",
            "frameCfg 0 3 128 0 100 1 0",
            "no chirpCfg defines",
        ),
        (
            "profileCfg 0 77 110 6 20",
            "profileCfg 0 77 110 16 20",
            "sampling ends",
        ),
        (
            "profileCfg 0 77 110 6 20 0 0 100 1 128 10666 0 0 30",
            "profileCfg 0 77 110 6 20 0 0 100",
            "expected at least 11",
        ),
        (
            "dfeDataOutputMode 1",
            "dfeDataOutputMode 3",
            "not advanced frames (advFrameCfg, subFrameCfg)",
        ),
        (
            "frameCfg 0 2 128 0 100 1 0",
            "advFrameCfg 2 0 0 1 0\nsubFrameCfg 0 0 0 3 128 100 0 1 1 100",
            "advFrameCfg: advanced frames",
        ),
    ];
    for (from, to, expected) in cases {
        let path = dir.path().join("bad.cfg");
        std::fs::write(&path, base.replace(from, to))?;
        let e = load_ti_cfg(&path, Board::Awr1843boost)
            .err()
            .ok_or_else(|| format!("{to}: accepted"))?
            .to_string();
        assert!(e.contains("bad.cfg") && e.contains(expected), "{to}: {e}");
    }
    let e = load_ti_cfg(&coloradar_cfg(), Board::Iwr6843aop)
        .err()
        .ok_or("aop accepted")?;
    assert!(e.to_string().contains("2-D virtual array"), "{e}");
    Ok(())
}

#[test]
fn comp_range_bias_and_rx_chan_phase_gives_the_bias_and_the_channel_gains() -> TestResult {
    let base = std::fs::read_to_string(coloradar_cfg())?;
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("comp.cfg");
    // 12 pairs, one per physical TX–RX pair (TX·4 + RX): (Re, Im) = (1 − i/32, i/64). The
    // ColoRadar .cfg fires TX0, TX2, TX1: slot 1 takes TX2's pairs 8..12, slot 2 TX1's 4..8.
    let pairs: Vec<String> = (0..12)
        .map(|i| format!("{} {}", 1.0 - f64::from(i) / 32.0, f64::from(i) / 64.0))
        .collect();
    let line = format!("compRangeBiasAndRxChanPhase 0.07 {}", pairs.join(" "));
    std::fs::write(
        &path,
        base.replace("lowPower 0 0", &format!("{line}\nlowPower 0 0")),
    )?;
    let s = load_ti_cfg(&path, Board::Awr1843boost)?;
    assert_eq!(s.range_bias_m, 0.07);
    let gains = s.channel_gains.ok_or("no channel gains")?;
    assert_eq!(gains.len(), 12);
    for (v, g) in gains.iter().enumerate() {
        let (slot, rx) = (v / 4, v % 4);
        let i = [0, 2, 1][slot] * 4 + rx;
        let (re, im) = (1.0 - i as f32 / 32.0, i as f32 / 64.0);
        assert_eq!((g.re, g.im), (re, im), "slot {slot} RX{rx}");
    }
    // RX0 and RX2 only (channelCfg 5): each slot takes its TX's pairs of those two.
    std::fs::write(
        &path,
        base.replace("lowPower 0 0", &line)
            .replace("channelCfg 15 7 0", "channelCfg 5 7 0"),
    )?;
    let gains = load_ti_cfg(&path, Board::Awr1843boost)?
        .channel_gains
        .ok_or("no channel gains")?;
    let expected: Vec<usize> = vec![0, 2, 8, 10, 4, 6];
    let got: Vec<usize> = gains
        .iter()
        .map(|g| (g.im * 64.0).round() as usize)
        .collect();
    assert_eq!(got, expected);

    // The identity (TI's default line) is no calibration at all.
    let identity = format!("compRangeBiasAndRxChanPhase 0.0{}", " 1 0".repeat(12));
    std::fs::write(&path, base.replace("lowPower 0 0", &identity))?;
    let s = load_ti_cfg(&path, Board::Awr1843boost)?;
    assert_eq!((s.range_bias_m, s.channel_gains), (0.0, None));

    // Too few values, or a zero factor, are refused naming the line.
    for (text, expected) in [
        (
            format!("compRangeBiasAndRxChanPhase 0.0{}", " 1 0".repeat(11)),
            "for each of the 12 TX–RX pairs of the awr1843boost",
        ),
        (
            format!("compRangeBiasAndRxChanPhase 0.0{} 0 0", " 1 0".repeat(11)),
            "the factor of TX2 RX3 is 0",
        ),
    ] {
        std::fs::write(&path, base.replace("lowPower 0 0", &text))?;
        let e = load_ti_cfg(&path, Board::Awr1843boost)
            .err()
            .ok_or_else(|| format!("{text}: accepted"))?
            .to_string();
        assert!(e.contains("comp.cfg") && e.contains(expected), "{e}");
    }
    Ok(())
}
