//! Unit tests of the harness (no QEMU needed).

use crate::*;
use std::path::Path;

use crate::elf::static_name;
use host_sim::core_run::Chain;

use crate::Preset;
use host_sim::sensor::SensorConfig;

const GOOD: &str =
    "H preset iwr6843 chain dbe samples 256 loops 64 tx 3 rx 4 azimuth_bins 188 elevation_bins 101
C 40000000 1000001 40
D 38 88 1.5e6 2.5e4
P 38 88 47 0 3.6975238 0.26627824 -0.097073816 0 97.3333 15.095507
F 1 0 1 0 0 0 0
S ingest 18623621 465591
S total 67931052 1698278
M stack_setup 62004
M stack_frame 11192
E ok
";

#[test]
fn parses_a_complete_run() {
    let run = parse_output(GOOD).expect("a complete run parses");
    assert_eq!(run.preset, "iwr6843");
    assert_eq!(run.chain, Chain::Dbe);
    assert_eq!(run.sizes, (256, 64, 3, 4));
    assert_eq!(run.instructions_per_tick, 40);
    assert_eq!(run.points.len(), 1);
    assert_eq!(run.points[0].x, f64::from(3.697_523_8_f32));
    assert_eq!(run.points[0].elevation_bin, 47);
    assert_eq!(run.stages["total"], 67_931_052);
    assert_eq!((run.stack_setup, run.stack_frame), (62_004, 11_192));
}

const GOOD_FFT: &str =
        "H preset coloradar chain fft samples 128 loops 128 tx 3 rx 4 azimuth_bins 188 elevation_bins 101
C 40000000 1000000 40
D 24 0 12385211000000 1538180
P 24 109 62 0 2.919707 -0.602998 0.3132604 0 130.92903 69.05896
F 1 0 1 0 0 0 0
S ingest 27944560 698614
S total 48416080 1210402
M stack_setup 60380
M stack_frame 3768
E ok
";

#[test]
fn parses_an_fft_run_and_requires_the_chain() {
    let run = parse_output(GOOD_FFT).expect("a complete FFT run parses");
    assert_eq!((run.preset.as_str(), run.chain), ("coloradar", Chain::Fft));
    assert_eq!(
        run.detections,
        vec![FwDetection {
            range_bin: 24,
            column: 0,
            power: 12_385_211_000_000.0,
            level: 1_538_180.0,
        }]
    );
    assert_eq!(run.points.len(), 1);
    assert_eq!(run.points[0].z, f64::from(0.313_260_4_f32));
    let unknown = GOOD_FFT.replace("chain fft", "chain music");
    assert!(matches!(
        parse_output(&unknown),
        Err(FirmwareError::Output { line: 1, .. })
    ));
    let unnamed = GOOD_FFT.replace("chain fft ", "");
    assert!(matches!(
        parse_output(&unnamed),
        Err(FirmwareError::Output { line: 1, .. })
    ));
    // The detection count is checked against the `D` lines.
    let miscounted = GOOD_FFT.replace("F 1 0 1", "F 2 0 1");
    assert!(parse_output(&miscounted).is_err());
}

fn entry(image: Image, buffers: &[(&str, u64)], stages: &[(&str, u64)]) -> PresetBudget {
    PresetBudget {
        preset: image.name().into(),
        chain: chain_name(image.chain).into(),
        frame: "f".into(),
        detections: 2,
        points: 2,
        static_ram_bytes: buffers.iter().map(|b| b.1).sum(),
        buffers: buffers
            .iter()
            .map(|&(symbol, bytes)| Buffer {
                symbol: symbol.into(),
                what: "w".into(),
                section: ".bss".into(),
                bytes,
            })
            .collect(),
        stack_peak_bytes: 10,
        stack_peak_setup_bytes: 10,
        stack_peak_frame_bytes: 5,
        ram_total_bytes: 0,
        flash_bytes: 0,
        embedded_frame_bytes: 0,
        instructions_per_frame: stages.iter().find(|s| s.0 == "total").map_or(0, |s| s.1),
        instructions_per_stage: stages.iter().map(|&(k, v)| (k.into(), v)).collect(),
    }
}

#[test]
fn markdown_keeps_each_chain_in_its_own_table() {
    let budget = Budget {
        method: String::new(),
        command: UPDATE_COMMAND.into(),
        board: String::new(),
        qemu: String::new(),
        rustc: String::new(),
        profile: String::new(),
        instructions_per_tick: 40,
        presets: vec![
            entry(
                Image::dbe(Preset::ColoRadar),
                &[("CUBE", 1000), ("CHAIN", 300), ("other", 0)],
                &[("elevation_doppler", 600), ("total", 5000)],
            ),
            entry(
                Image::fft(Preset::ColoRadar),
                &[("CUBE", 1000), ("CHAIN", 200), ("WORKSPACE", 70)],
                &[("angles", 100), ("process", 2000), ("total", 4000)],
            ),
        ],
        cores: vec![CoreBudget {
            core: "Cortex-M7".into(),
            board: "b".into(),
            target: TARGET.into(),
            assumed_cpi: 0.75,
            cpi_basis: "why".into(),
            instructions_per_frame: [
                ("coloradar".to_string(), 5000),
                ("coloradar-fft".to_string(), 4000),
            ]
            .into_iter()
            .collect(),
            clock_mhz_for_10_fps: [
                ("coloradar".to_string(), 0.0),
                ("coloradar-fft".to_string(), 0.0),
            ]
            .into_iter()
            .collect(),
            images: Default::default(),
        }],
    };
    let md = render_markdown(&budget);
    // The per-core table: one column per image, count and clock per cell.
    assert!(
        md.contains("| core, QEMU board | assumed CPI | `coloradar` | `coloradar-fft` |"),
        "{md}"
    );
    assert!(
        md.contains("| Cortex-M7, b | 0.75 | 0.0 M → 0 MHz | 0.0 M → 0 MHz |"),
        "{md}"
    );
    assert!(
        md.contains("| memory (bytes) | coloradar | coloradar-fft |"),
        "{md}"
    );
    // A buffer an image lacks is a dash; `other` comes last.
    assert!(md.contains("| `CHAIN`: w | 300 | 200 |"), "{md}");
    assert!(md.contains("| `WORKSPACE`: w | — | 70 |"), "{md}");
    let other = md.find("| `other`").expect("other row");
    assert!(md.find("| `WORKSPACE`").is_some_and(|i| i < other), "{md}");
    // Separate instruction tables with their own per-detection rows.
    assert!(
        md.contains("| instructions, DBE chain | coloradar |"),
        "{md}"
    );
    assert!(
        md.contains("| instructions, FFT chain | coloradar-fft |"),
        "{md}"
    );
    assert!(
        md.contains("| stages 3–5 per detection (÷ detections) | 300 |"),
        "{md}"
    );
    assert!(
        md.contains("| stage 3 per detection (÷ detections) | 50 |"),
        "{md}"
    );
    // Both chains on one cube: the DBE image + the FFT image's CHAIN + WORKSPACE, and its frame
    // + the FFT `process`.
    assert!(
            md.contains("`coloradar` + 270 = 1,570 bytes of static RAM, a frame 5,000 + 2,000 = 7,000 instructions"),
            "{md}"
        );
}

#[test]
fn the_clock_for_10_fps_is_instructions_times_10_times_cpi() {
    // 29.4 M instructions at CPI 1.25: 367.5 MHz, rounded to whole MHz.
    assert_eq!(clock_mhz(29_400_000, 1.25), 368.0);
    assert_eq!(clock_mhz(16_000_000, 1.25), 200.0);
    assert_eq!(clock_mhz(0, 0.75), 0.0);
}

#[test]
fn image_names_are_the_binaries() {
    let names: Vec<&str> = Image::ALL.iter().map(|i| i.name()).collect();
    assert_eq!(
        names,
        ["coloradar", "iwr6843", "coloradar-fft", "iwr6843-fft"]
    );
    let layout = Layout::this_repo();
    for image in Image::ALL {
        let bin = layout
            .firmware()
            .join("src")
            .join("bin")
            .join(format!("{}.rs", image.name().replace('-', "_")));
        assert!(bin.is_file(), "{image}: no {}", bin.display());
    }
}

#[test]
fn rejects_truncated_and_failed_runs() {
    let cut = GOOD.replace("E ok\n", "");
    assert!(matches!(
        parse_output(&cut),
        Err(FirmwareError::Output { line: 0, .. })
    ));
    let failed = GOOD.replace("E ok", "X frame rejected: incomplete frame");
    assert!(matches!(
        parse_output(&failed),
        Err(FirmwareError::Output { line: 10, .. })
    ));
    let panic = format!("{GOOD}panicked at src/lib.rs:1:1\n");
    assert!(parse_output(&panic).is_err());
    let short = GOOD.replace(" 15.095507", "");
    assert!(matches!(
        parse_output(&short),
        Err(FirmwareError::Output { line: 4, .. })
    ));
    let miscounted = GOOD.replace("F 1 0 1", "F 1 0 2");
    assert!(parse_output(&miscounted).is_err());
    let bad_clock = GOOD.replace("C 40000000 1000001 40", "C 40000000 1000100 40");
    assert!(parse_output(&bad_clock).is_err());
}

#[test]
fn static_names_come_from_legacy_mangling() {
    assert_eq!(
        static_name("_ZN7iwr684329__cortex_m_rt_main_trampoline4CUBE17hc1c6bbef8d5319e6E"),
        Some("CUBE")
    );
    assert_eq!(
        static_name("_ZN9coloradar5FRAME17h0123456789abcdefE"),
        Some("FRAME")
    );
    assert_eq!(static_name("_stack_start"), None);
}

#[test]
fn block_is_spliced_between_the_markers_only() {
    let doc = "# T\n\nbefore\n<!-- budget:begin -->\nold\n<!-- budget:end -->\nafter\n";
    let p = Path::new("memory-layout.md");
    let new = splice_block(doc, "| a |\n", p).expect("markers present");
    assert_eq!(
        new,
        "# T\n\nbefore\n<!-- budget:begin -->\n| a |\n<!-- budget:end -->\nafter\n"
    );
    assert_eq!(splice_block(&new, "| a |", p).expect("idempotent"), new);
    assert!(splice_block("no markers", "x", p).is_err());
    assert!(splice_block("<!-- budget:begin -->\nx", "x", p).is_err());
}

#[test]
fn the_capture_must_hold_one_frame() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("cap.bin");
    let one = vec![0u8; SensorConfig::iwr6843_fixture().frame_bytes()];
    std::fs::write(&path, &one).expect("write");
    assert!(iwr6843_frame(&path).is_ok());
    std::fs::write(&path, [one.clone(), one].concat()).expect("write");
    assert!(matches!(
        iwr6843_frame(&path),
        Err(FirmwareError::BadInput { .. })
    ));
    std::fs::write(&path, [0u8; 100]).expect("write");
    assert!(matches!(iwr6843_frame(&path), Err(FirmwareError::Read(_))));
}

#[test]
fn simulated_frame_is_reproducible() {
    let a = coloradar_frame().expect("renders");
    let b = coloradar_frame().expect("renders");
    assert_eq!(a, b);
    assert_eq!(
        frame_bytes(&a).len(),
        SensorConfig::coloradar().frame_bytes()
    );
}

#[test]
fn thousands_separators() {
    assert_eq!(thousands(0), "0");
    assert_eq!(thousands(999), "999");
    assert_eq!(thousands(1_000), "1,000");
    assert_eq!(thousands(1_572_864), "1,572,864");
}

#[test]
fn a_distribution_rebuild_of_one_qemu_is_the_same_emulator() {
    use crate::budget::same_qemu;
    let b2 = "QEMU emulator version 7.2.22 (Debian 1:7.2+dfsg-7+deb12u18+b2)";
    let b3 = "QEMU emulator version 7.2.22 (Debian 1:7.2+dfsg-7+deb12u18+b3)";
    assert!(same_qemu(b2, b3));
    assert!(same_qemu("", ""));
    assert!(!same_qemu(
        b2,
        "QEMU emulator version 8.2.2 (Debian 1:8.2.2+ds-0ubuntu1)"
    ));
    assert!(!same_qemu(b2, ""));
    assert!(!same_qemu("no version here", "no version there"));
}
