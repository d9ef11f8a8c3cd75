//! The firmware on an emulated Cortex-M4F against the host core and the `f64` reference, on
//! the same frames; and its budget against `docs/budget.json`.
//!
//! Four images (`firmware::Image::ALL`): the DBE chain (`coloradar`, `iwr6843`) and the FFT
//! baseline chain (`coloradar-fft`, `iwr6843-fft`) on the same embedded frames. One build and
//! one QEMU run per image is shared by all tests (`measured()`). Needs
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
//!   agreement (below).
//! - **Positions and velocities**: `R = bin · Δr`, `μ`, `ν` come from tables computed in `f64`
//!   with `libm` on both sides and correctly rounded `f32` operations: 2 ulps.
//! - **Powers** (detection power and level, linear): a 1-ulp change of a steering entry moves
//!   a Capon power by at most the loaded covariance's condition number `≤ D/γ = 1200` times
//!   that, 7e-5 relative; the limit is [`POWER_RELATIVE`] = 1e-3 (the harness's margin), and
//!   `0.01 dB` for the dB values (a ratio of two such powers).
//!
//! Measured: bit-identical but for one value, the power of the ColoRadar target moving at
//! −0.70 m/s (TDM-compensated, so through `from_polar`): 83.820869 dB on the firmware,
//! 83.820877 dB on the host.
//!
//! # Tolerances, FFT-chain firmware vs host FFT chain
//!
//! The FFT chain calls `libm` explicitly for every function its points go through (`atan2f`,
//! `sqrtf`, `asinf`, `log10f`; grids, windows and twiddles from `f64` `libm`), so the one
//! routine that differs between the builds is `Complex32::from_polar` (`std`'s `sinf`/`cosf`
//! on the host, `libm`'s on the Cortex-M), in the beamscan table and in the TDM factors
//! `exp(−j·2π·d'·t/(K·TX))` of each detection.
//!
//! - **Counts and bins**: equal, as for the DBE chain (with sub-grid refinement off, the
//!   beamscan table only decides which grid bin wins).
//! - **y = −R·μ, velocity, powers and SNR**: the DBE rules (2 ulps, 0.01 dB): they depend on
//!   grid tables and the range–Doppler map, not on `from_polar`.
//! - **z = R·ν and x = R·√(1 − μ² − ν²)**: ν = ψ/(κ·Δel), ψ the phase of `Σ x_line·conj(x_el)`
//!   over the TDM-compensated cell. Each `cos`/`sin` is within 1 ulp (≤ 2⁻²⁴ for |v| ≤ 1) of
//!   the exact value in either build, so a factor differs by at most 2·√2·2⁻²⁴ < 2⁻²² = ε
//!   between builds, a relative change of ε of a row's value, ≤ 2ε of a pair product and of
//!   its phase. The sum's phase moves by ≤ 2ε·Σ|tᵢ|/|Σtᵢ| ≤ 4ε while the pair products agree
//!   in phase within ±60° (a detected target: each carries κ·Δel·ν), so
//!   |Δν| ≤ δν = 4ε/(κ·Δel) (3·10⁻⁷ for ColoRadar), |Δz| ≤ R·δν and, to first order,
//!   |Δx| ≤ |z/x|·R·δν, on top of the 2 ulps of the value. A static detection (d' = 0) has
//!   factors of exactly 1 in both builds: no slack.
//!
//! Measured: bit-identical but for one value, `z` of the same moving ColoRadar target:
//! 0.011560149 m on the firmware, 0.011560172 m on the host, 2.3·10⁻⁸ m apart (25 ulps of
//! the value, 1.2 % of its slack R·δν = 1.9·10⁻⁶ m): a plain 2-ulp rule would fail there.

use std::sync::OnceLock;

use dbe_radar::config::ArrayLayout;
use dbe_radar::{AntennaGeometry, Params};
use host_sim::cloud::PointRecord;
use host_sim::core_run::{Chain, CoreOutput, CoreRunner};
use host_sim::frame::AdcFrame;
use host_sim::harness;
use host_sim::reference::{self, ReferenceOptions};
use host_sim::sensor::SensorConfig;
use xtask::{self as firmware, Board, FirmwareError, Image, Layout, Measurement, Preset};

/// Largest relative difference of a linear power (module docs).
const POWER_RELATIVE: f64 = 1e-3;
/// Largest difference of a dB value (module docs).
const DB: f64 = 0.01;
/// Largest difference of a position or velocity, in `f32` ulps of the value (module docs).
const POSITION_ULPS: f64 = 2.0;
/// ε of the FFT-chain rule: the largest difference of a TDM factor between the builds
/// (module docs).
const TDM_FACTOR_EPS: f64 = 1.0 / (1u64 << 22) as f64;

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
    fn get(&self, image: Image) -> &Measurement {
        self.measurements
            .iter()
            .find(|m| m.image == image)
            .unwrap_or_else(|| panic!("no measurement of {image}"))
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
    host_chain(sensor, frame, Chain::Dbe)
}

/// The host core's `chain` on `frame`, with the firmware's parameters (`Params::defaults`;
/// the FFT chain takes `FftParams::from_dbe` of them, which is the firmware's
/// `FftParams::defaults`).
fn host_chain(sensor: &SensorConfig, frame: &AdcFrame, chain: Chain) -> CoreOutput {
    let mut runner = CoreRunner::with_chain(sensor, Params::defaults(sensor.samples), chain)
        .unwrap_or_else(|e| panic!("{e}"));
    runner.process(frame).unwrap_or_else(|e| panic!("{e}"))
}

/// κ·Δel of `sensor`: the elevation pair phase per unit of ν (both presets have 3 TX × 4 RX
/// and an 8-element azimuth line).
fn elevation_phase_per_nu(sensor: &SensorConfig) -> f64 {
    use dbe_radar::presets::coloradar as c;
    let geometry = AntennaGeometry::<{ c::TX }, { c::RX }> {
        tx: sensor
            .tx
            .clone()
            .try_into()
            .unwrap_or_else(|_| panic!("3 TX")),
        rx: sensor
            .rx
            .clone()
            .try_into()
            .unwrap_or_else(|_| panic!("4 RX")),
        f_design_hz: sensor.f_design_hz,
    };
    let layout = ArrayLayout::<{ c::TX }, { c::RX }, { c::VIRTUAL }>::new(&geometry, c::AZIMUTH)
        .unwrap_or_else(|e| panic!("{e}"));
    let kappa = std::f64::consts::PI * sensor.waveform.center_frequency_hz(sensor.samples)
        / sensor.f_design_hz;
    kappa * f64::from(layout.el[c::AZIMUTH])
}

fn relative(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

/// `ulps` `f32` ulps (relative steps of `f32::EPSILON`) of the larger of `a` and `b`.
fn ulps_of(a: f64, b: f64, ulps: f64) -> f64 {
    ulps * f64::from(f32::EPSILON) * a.abs().max(b.abs())
}

/// Points equal within the module docs' rules; `slack(point)` is the extra absolute slack of
/// `(x, z)` in metres (zero for the DBE chain).
fn assert_points_agree(
    image: Image,
    fw: &[PointRecord],
    host: &[PointRecord],
    slack: &dyn Fn(&PointRecord) -> (f64, f64),
) {
    assert_eq!(fw.len(), host.len(), "{image}: point count");
    for (i, (f, h)) in fw.iter().zip(host).enumerate() {
        let bins = |p: &PointRecord| (p.range_bin, p.azimuth_bin, p.elevation_bin, p.doppler_bin);
        assert_eq!(bins(f), bins(h), "{image}: point {i} bins");
        let (slack_x, slack_z) = slack(h);
        for (what, a, b, extra) in [
            ("x", f.x, h.x, slack_x),
            ("y", f.y, h.y, 0.0),
            ("z", f.z, h.z, slack_z),
            ("velocity", f.doppler, h.doppler, 0.0),
        ] {
            assert!(
                (a - b).abs() <= ulps_of(a, b, POSITION_ULPS) + extra,
                "{image}: point {i} {what}: firmware {a}, host {b} (slack {extra:e} m)"
            );
        }
        for (what, a, b) in [
            ("power", f.intensity_db, h.intensity_db),
            ("SNR", f.snr_db, h.snr_db),
        ] {
            assert!(
                (a - b).abs() <= DB,
                "{image}: point {i} {what}: firmware {a} dB, host {b} dB"
            );
        }
    }
}

#[test]
fn firmware_output_equals_the_host_core_on_the_same_frame() {
    let Some(m) = measured() else { return };
    for preset in Preset::ALL {
        let image = Image::dbe(preset);
        let fw = &m.get(image).run;
        assert_eq!(fw.chain, Chain::Dbe, "{image}");
        let (sensor, frame) = m.input(preset);
        let host = host_core(&sensor, &frame);
        assert_eq!(fw.stats, host.stats, "{preset}: frame statistics");
        assert_eq!(fw.detections.len(), host.detections.len(), "{preset}");
        // The ego-velocity stage on the host's points gives the firmware's verdict.
        let points: Vec<dbe_radar::Point> = host.points.iter().map(PointRecord::to_point).collect();
        let mut ego = Box::new(dbe_radar::EgoEstimator::<128>::unconfigured());
        ego.configure(dbe_radar::EgoParams::DEFAULT)
            .expect("valid defaults");
        let host_ego = ego.estimate(&points);
        let fw_ego = fw
            .ego
            .as_ref()
            .expect("the firmware prints its ego-velocity");
        assert_eq!(
            fw_ego.status,
            host_ego.status.name(),
            "{preset}: ego status"
        );
        assert_eq!(
            (fw_ego.inliers, fw_ego.points),
            (host_ego.inliers, host_ego.points),
            "{preset}: ego counts"
        );
        for (f, h) in fw.detections.iter().zip(&host.detections) {
            assert_eq!(
                (f.range_bin, f.column),
                (h.range_bin, h.column),
                "{preset}: detection cell"
            );
            for (what, a, b) in [("power", f.power, h.power), ("level", f.level, h.level)] {
                let e = relative(f64::from(a), f64::from(b));
                assert!(
                    e <= POWER_RELATIVE,
                    "{preset}: detection ({}, {}) {what}: firmware {a}, host {b}",
                    f.range_bin,
                    f.column
                );
            }
        }
        assert_points_agree(image, &fw.points, &host.points, &|_| (0.0, 0.0));
        eprintln!(
            "{image}: {} detections, {} points, equal to the host core",
            fw.detections.len(),
            fw.points.len()
        );
    }
}

#[test]
fn fft_firmware_output_equals_the_host_fft_chain_on_the_same_frame() {
    let Some(m) = measured() else { return };
    for preset in Preset::ALL {
        let image = Image::fft(preset);
        let fw = &m.get(image).run;
        assert_eq!(fw.chain, Chain::Fft, "{image}");
        let (sensor, frame) = m.input(preset);
        let host = host_chain(&sensor, &frame, Chain::Fft);
        assert_eq!(fw.stats, host.stats, "{image}: frame statistics");
        assert_eq!(
            fw.detections.len(),
            host.stats.detections as usize,
            "{image}: range–Doppler detections printed"
        );
        // Every point comes from a detection of its range and Doppler bin.
        for p in &fw.points {
            assert!(
                fw.detections.iter().any(|d| {
                    // The natural FFT index as a signed bin (spec §2).
                    let (loops, column) = (preset.sizes().1 as i32, i32::from(d.column));
                    let doppler = if column < loops / 2 {
                        column
                    } else {
                        column - loops
                    };
                    (u32::from(d.range_bin), doppler) == (p.range_bin, p.doppler_bin)
                }),
                "{image}: no detection for the point {p:?}"
            );
        }
        let dnu = 4.0 * TDM_FACTOR_EPS / elevation_phase_per_nu(&sensor);
        let slack = |p: &PointRecord| {
            if p.doppler_bin == 0 {
                return (0.0, 0.0);
            }
            let range = (p.x * p.x + p.y * p.y + p.z * p.z).sqrt();
            let dz = range * dnu;
            (dz * (p.z / p.x).abs(), dz)
        };
        assert_points_agree(image, &fw.points, &host.points, &slack);
        eprintln!(
            "{image}: {} detections, {} points, equal to the host core's FFT chain (δν = {dnu:.1e})",
            fw.detections.len(),
            fw.points.len()
        );
    }
}

#[test]
fn firmware_agrees_with_the_f64_reference() {
    let Some(m) = measured() else { return };
    for preset in Preset::ALL {
        let fw = &m.get(Image::dbe(preset)).run;
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
            detections: fw.detections.clone(),
            rd_map: Vec::new(),
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
    for chain in [Chain::Dbe, Chain::Fft] {
        // ColoRadar: every simulated scatterer gives a point within one range bin, two grid
        // bins of its true azimuth and elevation (the grid steps are 0.75° and 0.5°) and one
        // Doppler bin. Both chains report on the same grids; the FFT chain's elevation bin is
        // the nearest to its continuous ν.
        let image = Image {
            preset: Preset::ColoRadar,
            chain,
        };
        let fw = &m.get(image).run;
        let wf = dbe_radar::Waveform::COLORADAR;
        let range_bin = wf.range_bin_m(128);
        let doppler_bin = wf.doppler_bin_mps(128, 128, 3);
        for &(r, az, el, v, _) in &firmware::COLORADAR_SCATTERERS {
            use dbe_radar::presets::coloradar as c;
            let az_bin = (az - c::AZIMUTH_FIRST_DEG) / c::AZIMUTH_STEP_DEG;
            let el_bin = (el - c::ELEVATION_FIRST_DEG) / c::ELEVATION_STEP_DEG;
            let found = fw.points.iter().any(|p| {
                (f64::from(p.range_bin) - r / range_bin).abs() <= 1.0
                    && (f64::from(p.azimuth_bin) - az_bin).abs() <= 2.0
                    && (f64::from(p.elevation_bin) - el_bin).abs() <= 2.0
                    && (p.doppler - v).abs() <= doppler_bin
            });
            assert!(
                found,
                "{image}: no point near the scatterer at {r} m, az {az}°, el {el}°, {v} m/s: {:#?}",
                fw.points
            );
        }
        // IWR6843 capture (fixture README): the corner reflector's range-FFT peak is bin 38
        // and it sits near boresight (|azimuth|, |elevation| < 10°), static.
        let image = Image {
            preset: Preset::Iwr6843,
            chain,
        };
        let fw = &m.get(image).run;
        let reflector = fw
            .points
            .iter()
            .find(|p| p.range_bin.abs_diff(38) <= 1)
            .unwrap_or_else(|| panic!("{image}: no point at range bin 38: {:#?}", fw.points));
        use dbe_radar::presets::iwr6843 as i;
        let az_deg = i::AZIMUTH_FIRST_DEG + f64::from(reflector.azimuth_bin) * i::AZIMUTH_STEP_DEG;
        let el_deg =
            i::ELEVATION_FIRST_DEG + f64::from(reflector.elevation_bin) * i::ELEVATION_STEP_DEG;
        assert!(
            az_deg.abs() < 10.0 && el_deg.abs() < 10.0,
            "{image}: {reflector:?}"
        );
        assert_eq!(reflector.doppler_bin, 0, "{image}: {reflector:?}");
    }
}

#[test]
fn cortex_m7_runs_the_same_instructions() {
    let Some(m) = measured() else { return };
    // Same image, same ISA: the AN500's Cortex-M7 executes the same instruction stream.
    for image in [Image::dbe(Preset::Iwr6843), Image::fft(Preset::Iwr6843)] {
        let text = firmware::run(&m.layout, image, Board::An500).unwrap_or_else(|e| panic!("{e}"));
        let m7 = firmware::parse_output(&text).unwrap_or_else(|e| panic!("{e}"));
        let m4 = &m.get(image).run;
        assert_eq!(
            &m7, m4,
            "{image}: mps2-an500 (Cortex-M7) differs from mps2-an386"
        );
    }
}

#[test]
fn the_cortex_m33_build_gives_the_same_points_and_frame_statistics() {
    let Some(m) = measured() else { return };
    // Another target (Armv8-M Mainline), the same code: every number of the output is the
    // M4F's; only the instruction counts and the code differ.
    for image in Image::ALL {
        let text = firmware::run(&m.layout, image, Board::An505).unwrap_or_else(|e| panic!("{e}"));
        let m33 = firmware::parse_output(&text).unwrap_or_else(|e| panic!("{e}"));
        let m4 = &m.get(image).run;
        assert_eq!(m33.points, m4.points, "{image}: points on mps2-an505");
        assert_eq!(
            m33.detections, m4.detections,
            "{image}: detections on mps2-an505"
        );
        assert_eq!(m33.stats, m4.stats, "{image}: statistics on mps2-an505");
        assert!(m33.stages.get("total").is_some_and(|&n| n > 0), "{image}");
    }
}

#[test]
fn static_buffers_have_the_sizes_of_the_core_types() {
    use dbe_radar::presets::{coloradar as c, iwr6843 as i};
    let Some(m) = measured() else { return };
    // Host `size_of` (64-bit) vs the ELF (32-bit): arrays are identical, every `usize` length
    // field is 4 bytes shorter on the Cortex-M (plus the padding that follows it).
    let host = |image: Image| -> [(&str, usize); 7] {
        match (image.preset, image.chain) {
            (Preset::ColoRadar, Chain::Dbe) => [
                ("CUBE", size_of::<c::CubeStorage>()),
                ("WORKSPACE", size_of::<c::Workspace>()),
                ("CHAIN", size_of::<c::Dbe>()),
                ("FRONTEND", size_of::<c::Frontend>()),
                ("CLOUD", size_of::<c::PointCloud>()),
                ("DMA_CHIRP", size_of::<c::Chirp>()),
                ("EGO", size_of::<c::EgoEstimator>()),
            ],
            (Preset::Iwr6843, Chain::Dbe) => [
                ("CUBE", size_of::<i::CubeStorage>()),
                ("WORKSPACE", size_of::<i::Workspace>()),
                ("CHAIN", size_of::<i::Dbe>()),
                ("FRONTEND", size_of::<i::Frontend>()),
                ("CLOUD", size_of::<i::PointCloud>()),
                ("DMA_CHIRP", size_of::<i::Chirp>()),
                ("EGO", size_of::<i::EgoEstimator>()),
            ],
            (Preset::ColoRadar, Chain::Fft) => [
                ("CUBE", size_of::<c::CubeStorage>()),
                ("WORKSPACE", size_of::<c::FftWorkspace>()),
                ("CHAIN", size_of::<c::FftChain>()),
                ("FRONTEND", size_of::<c::Frontend>()),
                ("CLOUD", size_of::<c::PointCloud>()),
                ("DMA_CHIRP", size_of::<c::Chirp>()),
                ("EGO", size_of::<c::EgoEstimator>()),
            ],
            (Preset::Iwr6843, Chain::Fft) => [
                ("CUBE", size_of::<i::CubeStorage>()),
                ("WORKSPACE", size_of::<i::FftWorkspace>()),
                ("CHAIN", size_of::<i::FftChain>()),
                ("FRONTEND", size_of::<i::Frontend>()),
                ("CLOUD", size_of::<i::PointCloud>()),
                ("DMA_CHIRP", size_of::<i::Chirp>()),
                ("EGO", size_of::<i::EgoEstimator>()),
            ],
        }
    };
    for image in Image::ALL {
        let budget = &m.get(image).budget;
        assert_eq!(budget.preset, image.name());
        assert_eq!(budget.chain, firmware::chain_name(image.chain));
        for (symbol, host_bytes) in host(image) {
            let buffer = budget
                .buffers
                .iter()
                .find(|b| b.symbol == symbol)
                .unwrap_or_else(|| panic!("{image}: no {symbol} in the budget"));
            let (elf, host_bytes) = (buffer.bytes, host_bytes as u64);
            assert!(
                elf <= host_bytes && host_bytes - elf <= 16,
                "{image}: {symbol} is {elf} bytes in the ELF, {host_bytes} on the host"
            );
            // All-zero (or uninitialised) at reset: no flash image of any buffer.
            assert_eq!(buffer.section, ".bss", "{image}: {symbol}");
        }
        let named: u64 = budget.buffers.iter().map(|b| b.bytes).sum();
        assert_eq!(named, budget.static_ram_bytes, "{image}: buffers add up");
        assert_eq!(budget.embedded_frame_bytes, 786_432, "{image}: frame bytes");
        assert!(
            budget.stack_peak_frame_bytes > 0 && budget.stack_peak_setup_bytes > 0,
            "{image}: stack peaks measured"
        );
        let stages = &budget.instructions_per_stage;
        assert_eq!(
            stages["ingest"] + stages["process"],
            budget.instructions_per_frame,
            "{image}: total = ingest + process"
        );
        let parts: &[&str] = match image.chain {
            Chain::Dbe => &["azimuth_capon", "cfar", "elevation_doppler"],
            Chain::Fft => &["doppler_fft", "rd_cfar", "angles"],
        };
        assert_eq!(
            parts.iter().map(|k| stages[*k]).sum::<u64>(),
            stages["process"],
            "{image}: the stages add up to process"
        );
    }
    // The ColoRadar DBE image meets the 1 MiB goal (issue 5) on its own.
    let coloradar = &m.get(Image::dbe(Preset::ColoRadar)).budget;
    assert!(
        coloradar.ram_total_bytes <= 1 << 20,
        "ColoRadar DBE: {} bytes of RAM",
        coloradar.ram_total_bytes
    );
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
