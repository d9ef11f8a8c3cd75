//! The C API (`ffi/`): the checked-in header is what cbindgen makes of `ffi/src/lib.rs`; the
//! host C example (README's "Using the core from C") finds the TI capture's corner reflector
//! with the host core's points; the C firmware, built with `arm-none-eabi-gcc` against the
//! Cortex-M4F library and run under QEMU, prints the Rust firmware's points bit for bit.
//!
//! Needs `cc`, `arm-none-eabi-gcc` (Debian `gcc-arm-none-eabi libnewlib-arm-none-eabi`),
//! `qemu-system-arm`, the `thumbv7em-none-eabihf` target and `../shared`: when one is missing
//! the tests fail under `CI=true` (naming it) and are skipped with a message otherwise.

use dbe_radar::Params;
use host_sim::cloud::PointRecord;
use host_sim::core_run::CoreRunner;
use host_sim::sensor::SensorConfig;
use xtask::{self as firmware, Board, CPreset, FirmwareError, Image, Layout};

/// `Err(why)`: fail under CI, otherwise skip with a message.
fn require(check: Result<(), String>) -> bool {
    match check {
        Ok(()) => true,
        Err(why) if std::env::var("CI").is_ok_and(|v| v == "true") => {
            panic!("the C API tests cannot run: {why}")
        }
        Err(why) => {
            eprintln!("skipping: {why}");
            false
        }
    }
}

fn capture(layout: &Layout) -> Result<(), String> {
    let path = layout.iwr6843_capture();
    if path.is_file() {
        Ok(())
    } else {
        Err(format!(
            "{} is missing (../shared beside the repository)",
            path.display()
        ))
    }
}

fn tool(name: &str, hint: &str) -> Result<(), String> {
    match std::process::Command::new(name).arg("--version").output() {
        Ok(o) if o.status.success() => Ok(()),
        _ => Err(format!("{name} is not installed ({hint})")),
    }
}

#[test]
fn the_header_is_what_cbindgen_makes() {
    let layout = Layout::this_repo();
    let current = firmware::header_is_current(&layout).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        current,
        "{} is stale: run `cargo xtask header`",
        layout.header().display()
    );
}

/// One line of the example's output: bins, then x y z v power snr with 4, 4, 4, 3, 2, 2
/// decimals.
fn example_point(line: &str) -> PointRecord {
    let t: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(t.len(), 10, "a point line has 10 fields: {line:?}");
    let f = |i: usize| -> f64 { t[i].parse().unwrap_or_else(|_| panic!("{line:?}")) };
    let u = |i: usize| -> u32 { t[i].parse().unwrap_or_else(|_| panic!("{line:?}")) };
    PointRecord {
        range_bin: u(0),
        azimuth_bin: u(1),
        elevation_bin: u(2),
        doppler_bin: t[3].parse().unwrap_or_else(|_| panic!("{line:?}")),
        x: f(4),
        y: f(5),
        z: f(6),
        doppler: f(7),
        intensity_db: f(8),
        snr_db: f(9),
    }
}

#[test]
fn the_host_c_example_finds_the_corner_reflector_with_the_host_cores_points() {
    let layout = Layout::this_repo();
    if !require(capture(&layout).and(tool("cc", "apt-get install gcc"))) {
        return;
    }
    let exe = firmware::build_host_program(&layout, "example").unwrap_or_else(|e| panic!("{e}"));
    let out = firmware::run_host_program(&exe, &[&layout.iwr6843_capture()])
        .unwrap_or_else(|e| panic!("{e}"));
    let mut lines = out.lines();
    let summary = lines.next().expect("a summary line");
    let c_points: Vec<PointRecord> = lines.map(example_point).collect();

    // The host core on the same capture, through the project's DCA1000 reader.
    let sensor = SensorConfig::iwr6843_fixture();
    let frame =
        firmware::iwr6843_frame(&layout.iwr6843_capture()).unwrap_or_else(|e| panic!("{e}"));
    let host = CoreRunner::new(&sensor, Params::defaults(sensor.samples))
        .and_then(|mut r| r.process(&frame))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        summary,
        format!(
            "{} detections, {} points",
            host.stats.detections,
            host.points.len()
        )
    );
    assert_eq!(c_points.len(), host.points.len());
    for (c, h) in c_points.iter().zip(&host.points) {
        assert_eq!(
            (c.range_bin, c.azimuth_bin, c.elevation_bin, c.doppler_bin),
            (h.range_bin, h.azimuth_bin, h.elevation_bin, h.doppler_bin),
            "bins of {c:?} vs the host core's {h:?}"
        );
        // Printed with 4 (m), 3 (m/s) and 2 (dB) decimals: half a unit of the last one.
        for (what, a, b, half) in [
            ("x", c.x, h.x, 5e-5),
            ("y", c.y, h.y, 5e-5),
            ("z", c.z, h.z, 5e-5),
            ("v", c.doppler, h.doppler, 5e-4),
            ("power", c.intensity_db, h.intensity_db, 5e-3),
            ("snr", c.snr_db, h.snr_db, 5e-3),
        ] {
            assert!((a - b).abs() <= half + 1e-9, "{what}: C {a} vs host {b}");
        }
    }

    // The reflector (fixture README): the strongest point, range bin 38 ± 1, Doppler bin 0,
    // within 10° of boresight in azimuth and elevation.
    let strongest = c_points
        .iter()
        .max_by(|a, b| a.intensity_db.total_cmp(&b.intensity_db))
        .expect("the example prints points");
    let range = (strongest.x.powi(2) + strongest.y.powi(2) + strongest.z.powi(2)).sqrt();
    let azimuth = strongest.y.atan2(strongest.x).to_degrees();
    let elevation = (strongest.z / range).asin().to_degrees();
    assert!(
        (37..=39).contains(&strongest.range_bin)
            && strongest.doppler_bin == 0
            && azimuth.abs() < 10.0
            && elevation.abs() < 10.0,
        "the strongest point is not the reflector: {strongest:?} (azimuth {azimuth:.1}°, \
         elevation {elevation:.1}°)"
    );
}

#[test]
fn every_error_path_of_the_c_api_returns_its_status() {
    if !require(tool("cc", "apt-get install gcc")) {
        return;
    }
    let layout = Layout::this_repo();
    let exe = firmware::build_host_program(&layout, "errors").unwrap_or_else(|e| panic!("{e}"));
    // The program exits 1 naming the first check that failed (then this is an error).
    let out = firmware::run_host_program(&exe, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert!(out.starts_with("ok "), "{out}");
}

/// A `P` line: its four bins and its six values as `f32` bit patterns.
type PointLine = (Vec<i64>, Vec<u32>);

/// The `P`, `V` and `F` lines of a run, `P` values parsed as `f32` (bit patterns compared).
fn point_lines(out: &str) -> (Vec<PointLine>, Vec<String>) {
    let mut points = Vec::new();
    let mut other = Vec::new();
    for line in out.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.first() {
            Some(&"P") => {
                assert_eq!(t.len(), 11, "{line:?}");
                let bins = t[1..5]
                    .iter()
                    .map(|v| v.parse().unwrap_or_else(|_| panic!("{line:?}")))
                    .collect();
                let values = t[5..]
                    .iter()
                    .map(|v| {
                        v.parse::<f32>()
                            .unwrap_or_else(|_| panic!("{line:?}"))
                            .to_bits()
                    })
                    .collect();
                points.push((bins, values));
            }
            Some(&"V") => {
                // Velocity as f32 bits, counts and status as text.
                let mut v: Vec<String> = t[1..4]
                    .iter()
                    .map(|x| {
                        x.parse::<f32>()
                            .unwrap_or_else(|_| panic!("{line:?}"))
                            .to_bits()
                            .to_string()
                    })
                    .collect();
                v.extend(t[4..].iter().map(|s| s.to_string()));
                other.push(format!("V {}", v.join(" ")));
            }
            Some(&"F") => other.push(line.to_string()),
            _ => {}
        }
    }
    (points, other)
}

#[test]
fn the_c_firmware_prints_the_rust_firmwares_points() {
    let layout = Layout::this_repo();
    let firmware_tools = firmware::check_tools().map_err(|e| e.to_string());
    if !require(capture(&layout).and(firmware_tools).and(tool(
        firmware::ARM_GCC,
        "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi",
    ))) {
        return;
    }
    firmware::build(&layout).unwrap_or_else(|e| panic!("{e}"));
    for (preset, image) in [
        (CPreset::Coloradar, Image::ALL[0]),
        (CPreset::Iwr6843, Image::ALL[1]),
    ] {
        assert_eq!(image.name(), preset.name(), "image order of Image::ALL");
        let rust = firmware::run(&layout, image, Board::An386).unwrap_or_else(|e| panic!("{e}"));
        let c = firmware::build_c_firmware(&layout, preset)
            .and_then(|elf| firmware::run_c_firmware(&elf))
            .unwrap_or_else(|e: FirmwareError| panic!("{e}"));
        assert!(
            c.lines().any(|l| l == "E ok"),
            "the C firmware did not finish:\n{c}"
        );
        let (c_points, c_other) = point_lines(&c);
        let (rust_points, rust_other) = point_lines(&rust);
        assert!(
            !rust_points.is_empty(),
            "{}: the Rust firmware printed no point",
            preset.name()
        );
        assert_eq!(c_points, rust_points, "{}: points differ", preset.name());
        assert_eq!(
            c_other,
            rust_other,
            "{}: ego-velocity or statistics differ",
            preset.name()
        );
    }
}
