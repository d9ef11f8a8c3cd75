//! The firmware on an emulated Cortex-M4F against the host core and the `f64` reference, on
//! the same frames; and its budget against `docs/budget.json`.
//!
//! One build and one QEMU run per preset is shared by all tests (`measured()`). Needs
//! `qemu-system-arm`, the `thumbv7em-none-eabihf` target and `../shared`: when one is missing
//! the tests fail with `CI=true` and are skipped with a message otherwise.
//!
//! # Tolerances, firmware vs host core
//!
//! Both run the same `f32` code; Rust never fuses or reorders floating-point operations, so
//! the only legitimate differences come from maths routines that the host build takes from
//! `std` (num-complex, nalgebra and glam are compiled with their `std` features there, `libm`
//! on the Cortex-M): `sin`/`cos` of the steering tables (`Complex::from_polar`), `hypot`. Each
//! is within 1 ulp of the other (6e-8 relative).
//!
//! - **Counts and bins** (detections, range/azimuth/elevation/Doppler bins, statistics): equal.
//!   A bin could only differ through a near-tie decision far closer than the measured
//!   agreement (bit-identical values today).
//! - **Positions and velocities**: `R = bin · Δr`, `μ`, `ν` come from tables computed in `f64`
//!   with `libm` on both sides and correctly rounded `f32` operations: 2 ulps.
//! - **Powers** (detection power and level, linear): a 1-ulp change of a steering entry moves
//!   a Capon power by at most the loaded covariance's condition number `≤ D/γ = 1200` times
//!   that, 7e-5 relative; the limit is [`POWER_RELATIVE`] = 1e-3 (the harness's margin), and
//!   `0.01 dB` for the dB values (a ratio of two such powers).
//!
//! Measured on both presets: bit-identical (every printed `f32` equal).

use std::sync::OnceLock;

use dbe_radar::cfar::Detection;
use dbe_radar::Params;
use host_sim::cloud::PointRecord;
use host_sim::core_run::{CoreOutput, CoreRunner, Preset};
use host_sim::firmware::{self, Board, FirmwareError, Layout, Measurement};
use host_sim::frame::AdcFrame;
use host_sim::harness;
use host_sim::reference::{self, ReferenceOptions};
use host_sim::sensor::SensorConfig;

/// Largest relative difference of a linear power (module docs).
const POWER_RELATIVE: f64 = 1e-3;
/// Largest difference of a dB value (module docs).
const DB: f64 = 0.01;
/// Largest difference of a position or velocity, in `f32` ulps of the value (module docs).
const POSITION_ULPS: f64 = 2.0;

struct Measured {
    layout: Layout,
    budget: firmware::Budget,
    measurements: Vec<Measurement>,
    coloradar: AdcFrame,
}

/// Skip (or fail under `CI=true`) when the tools or `../shared` are missing.
fn skip(why: &str) -> Option<&'static Measured> {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("firmware tests cannot run: {why}");
    }
    eprintln!("skipping the firmware tests: {why}");
    None
}

/// Build the firmware and run every preset once, for all tests.
fn measured() -> Option<&'static Measured> {
    static MEASURED: OnceLock<Result<Measured, String>> = OnceLock::new();
    let layout = Layout::this_repo();
    if let Err(e @ FirmwareError::ToolMissing { .. }) = firmware::check_tools() {
        return skip(&e.to_string());
    }
    if !layout.iwr6843_capture().is_file() {
        return skip(&format!(
            "{} is missing (../shared beside the repository)",
            layout.iwr6843_capture().display()
        ));
    }
    let result = MEASURED.get_or_init(|| {
        firmware::measure(&layout)
            .map(|(budget, measurements, coloradar)| Measured {
                layout: layout.clone(),
                budget,
                measurements,
                coloradar,
            })
            .map_err(|e| e.to_string())
    });
    match result {
        Ok(m) => Some(m),
        Err(e) => panic!("building or running the firmware failed: {e}"),
    }
}

impl Measured {
    fn get(&self, preset: Preset) -> &Measurement {
        self.measurements
            .iter()
            .find(|m| m.preset == preset)
            .unwrap_or_else(|| panic!("no measurement of {preset}"))
    }

    /// The sensor and the exact frame the firmware of `preset` embeds.
    fn input(&self, preset: Preset) -> (SensorConfig, AdcFrame) {
        match preset {
            Preset::ColoRadar => (SensorConfig::coloradar(), self.coloradar.clone()),
            Preset::Iwr6843 => (
                SensorConfig::iwr6843_fixture(),
                firmware::iwr6843_frame(&self.layout.iwr6843_capture())
                    .unwrap_or_else(|e| panic!("{e}")),
            ),
        }
    }
}

fn host_core(sensor: &SensorConfig, frame: &AdcFrame) -> CoreOutput {
    let mut runner =
        CoreRunner::new(sensor, Params::defaults(sensor.samples)).unwrap_or_else(|e| panic!("{e}"));
    runner.process(frame).unwrap_or_else(|e| panic!("{e}"))
}

fn relative(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

fn within_ulps(fw: f64, host: f64, ulps: f64) -> bool {
    (fw - host).abs() <= ulps * f64::from(f32::EPSILON) * fw.abs().max(host.abs())
}

fn assert_points_agree(preset: Preset, fw: &[PointRecord], host: &[PointRecord]) {
    assert_eq!(fw.len(), host.len(), "{preset}: point count");
    for (i, (f, h)) in fw.iter().zip(host).enumerate() {
        let bins = |p: &PointRecord| (p.range_bin, p.azimuth_bin, p.elevation_bin, p.doppler_bin);
        assert_eq!(bins(f), bins(h), "{preset}: point {i} bins");
        for (what, a, b) in [
            ("x", f.x, h.x),
            ("y", f.y, h.y),
            ("z", f.z, h.z),
            ("velocity", f.doppler, h.doppler),
        ] {
            assert!(
                within_ulps(a, b, POSITION_ULPS),
                "{preset}: point {i} {what}: firmware {a}, host {b}"
            );
        }
        for (what, a, b) in [
            ("power", f.intensity_db, h.intensity_db),
            ("SNR", f.snr_db, h.snr_db),
        ] {
            assert!(
                (a - b).abs() <= DB,
                "{preset}: point {i} {what}: firmware {a} dB, host {b} dB"
            );
        }
    }
}

#[test]
fn firmware_output_equals_the_host_core_on_the_same_frame() {
    let Some(m) = measured() else { return };
    for preset in Preset::ALL {
        let fw = &m.get(preset).run;
        let (sensor, frame) = m.input(preset);
        let host = host_core(&sensor, &frame);
        assert_eq!(fw.stats, host.stats, "{preset}: frame statistics");
        assert_eq!(fw.detections.len(), host.detections.len(), "{preset}");
        for (f, h) in fw.detections.iter().zip(&host.detections) {
            assert_eq!(
                (f.range_bin, f.azimuth_bin),
                (h.range_bin, h.azimuth_bin),
                "{preset}: detection cell"
            );
            for (what, a, b) in [("power", f.power, h.power), ("level", f.level, h.level)] {
                let e = relative(f64::from(a), f64::from(b));
                assert!(
                    e <= POWER_RELATIVE,
                    "{preset}: detection ({}, {}) {what}: firmware {a}, host {b}",
                    f.range_bin,
                    f.azimuth_bin
                );
            }
        }
        assert_points_agree(preset, &fw.points, &host.points);
        eprintln!(
            "{preset}: {} detections, {} points, equal to the host core",
            fw.detections.len(),
            fw.points.len()
        );
    }
}

#[test]
fn firmware_agrees_with_the_f64_reference() {
    let Some(m) = measured() else { return };
    for preset in Preset::ALL {
        let fw = &m.get(preset).run;
        let (sensor, frame) = m.input(preset);
        let params = Params::defaults(sensor.samples);
        let reference = reference::process_frame_with(
            &frame,
            &sensor,
            &params,
            preset.azimuth_bins(),
            preset.elevation_bins(),
            preset.detection_capacity(),
            &ReferenceOptions::CORE_CONTRACT,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        // The firmware prints detections and points but not its 24–48 k-cell RA map; the map
        // compared here is the host core's, which the test above ties to the firmware's
        // detections.
        let firmware_output = CoreOutput {
            points: fw.points.clone(),
            stats: fw.stats,
            ra_map: host_core(&sensor, &frame).ra_map,
            detections: fw
                .detections
                .iter()
                .map(|d| Detection {
                    range_bin: d.range_bin,
                    azimuth_bin: d.azimuth_bin,
                    power: d.power,
                    level: d.level,
                })
                .collect(),
        };
        let agreement = harness::compare(&firmware_output, &reference, &params);
        assert!(
            agreement.is_match(),
            "{preset}: firmware vs reference: {agreement}\n{:#?}",
            agreement.mismatches
        );
        assert!(
            agreement.points_matched >= 1 && agreement.points_matched + 1 >= fw.points.len(),
            "{preset}: only {} of {} firmware points matched the reference",
            agreement.points_matched,
            fw.points.len()
        );
        eprintln!("{preset}: firmware vs reference: {agreement}");
    }
}

#[test]
fn firmware_finds_the_scene() {
    let Some(m) = measured() else { return };
    // ColoRadar: every simulated scatterer gives a point within one range bin and two grid bins
    // of its true azimuth and elevation (the grid steps are 0.75° and 0.5°).
    let fw = &m.get(Preset::ColoRadar).run;
    let wf = dbe_radar::Waveform::COLORADAR;
    let range_bin = wf.range_bin_m(128);
    let doppler_bin = wf.doppler_bin_mps(128, 128, 3);
    for &(r, az, el, v, _) in &firmware::COLORADAR_SCATTERERS {
        let az_bin = (az + 70.0) / (140.0 / 187.0);
        let el_bin = (el + 25.0) / 0.5;
        let found = fw.points.iter().any(|p| {
            (f64::from(p.range_bin) - r / range_bin).abs() <= 1.0
                && (f64::from(p.azimuth_bin) - az_bin).abs() <= 2.0
                && (f64::from(p.elevation_bin) - el_bin).abs() <= 2.0
                && (p.doppler - v).abs() <= doppler_bin
        });
        assert!(
            found,
            "no firmware point near the scatterer at {r} m, az {az}°, el {el}°, {v} m/s: {:#?}",
            fw.points
        );
    }
    // IWR6843 capture (fixture README): the corner reflector's range-FFT peak is bin 38 and it
    // sits near boresight (|azimuth|, |elevation| < 10°), static.
    let fw = &m.get(Preset::Iwr6843).run;
    let reflector = fw
        .points
        .iter()
        .find(|p| p.range_bin.abs_diff(38) <= 1)
        .unwrap_or_else(|| panic!("no point at range bin 38: {:#?}", fw.points));
    let az_deg = -70.0 + f64::from(reflector.azimuth_bin) * 140.0 / 187.0;
    let el_deg = -25.0 + f64::from(reflector.elevation_bin) * 0.5;
    assert!(az_deg.abs() < 10.0 && el_deg.abs() < 10.0, "{reflector:?}");
    assert_eq!(reflector.doppler_bin, 0, "{reflector:?}");
}

#[test]
fn cortex_m7_runs_the_same_instructions() {
    let Some(m) = measured() else { return };
    // Same image, same ISA: the AN500's Cortex-M7 executes the same instruction stream.
    let text =
        firmware::run(&m.layout, Preset::Iwr6843, Board::An500).unwrap_or_else(|e| panic!("{e}"));
    let m7 = firmware::parse_output(&text).unwrap_or_else(|e| panic!("{e}"));
    let m4 = &m.get(Preset::Iwr6843).run;
    assert_eq!(&m7, m4, "mps2-an500 (Cortex-M7) differs from mps2-an386");
}

#[test]
fn static_buffers_have_the_sizes_of_the_core_types() {
    use dbe_radar::presets::{coloradar as c, iwr6843 as i};
    let Some(m) = measured() else { return };
    // Host `size_of` (64-bit) vs the ELF (32-bit): arrays are identical, every `usize` length
    // field is 4 bytes shorter on the Cortex-M.
    let host = |preset: Preset| -> [(&str, usize); 5] {
        match preset {
            Preset::ColoRadar => [
                ("CUBE", size_of::<c::CubeStorage>()),
                ("WORKSPACE", size_of::<c::Workspace>()),
                ("DBE", size_of::<c::Dbe>()),
                ("CLOUD", size_of::<c::PointCloud>()),
                ("DMA_CHIRP", size_of::<c::Chirp>()),
            ],
            Preset::Iwr6843 => [
                ("CUBE", size_of::<i::CubeStorage>()),
                ("WORKSPACE", size_of::<i::Workspace>()),
                ("DBE", size_of::<i::Dbe>()),
                ("CLOUD", size_of::<i::PointCloud>()),
                ("DMA_CHIRP", size_of::<i::Chirp>()),
            ],
        }
    };
    for preset in Preset::ALL {
        let budget = &m.get(preset).budget;
        for (symbol, host_bytes) in host(preset) {
            let elf = budget
                .buffers
                .iter()
                .find(|b| b.symbol == symbol)
                .unwrap_or_else(|| panic!("{preset}: no {symbol} in the budget"))
                .bytes;
            let host_bytes = host_bytes as u64;
            assert!(
                elf <= host_bytes && host_bytes - elf <= 16,
                "{preset}: {symbol} is {elf} bytes in the ELF, {host_bytes} on the host"
            );
        }
        let named: u64 = budget.buffers.iter().map(|b| b.bytes).sum();
        assert_eq!(named, budget.static_ram_bytes, "{preset}: buffers add up");
        assert_eq!(
            budget.embedded_frame_bytes, 786_432,
            "{preset}: frame bytes"
        );
        assert!(
            budget.stack_peak_frame_bytes > 0 && budget.stack_peak_setup_bytes > 0,
            "{preset}: stack peaks measured"
        );
        let stages = &budget.instructions_per_stage;
        assert_eq!(
            stages["ingest"] + stages["process"],
            budget.instructions_per_frame,
            "{preset}: total = ingest + process"
        );
        assert_eq!(
            stages["azimuth_capon"] + stages["cfar"] + stages["elevation_doppler"],
            stages["process"],
            "{preset}: the stages add up to process"
        );
    }
}

#[test]
fn budget_json_and_memory_layout_are_up_to_date() {
    let Some(m) = measured() else { return };
    let problems = firmware::stale(&m.layout, Some(&m.budget)).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        problems.is_empty(),
        "the committed budget is stale; run `{}`:\n{}",
        firmware::UPDATE_COMMAND,
        problems.join("\n")
    );
}
