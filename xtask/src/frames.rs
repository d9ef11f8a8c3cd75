//! The frames the images embed: the simulated ColoRadar frame and the TI capture.

use std::path::Path;

use host_sim::frame::AdcFrame;
use host_sim::sensor::SensorConfig;
use host_sim::sim::Scatterer;
use rand::SeedableRng;

use crate::*;

/// Seed of the simulated ColoRadar frame's noise.
const COLORADAR_SEED: u64 = 5;

// ---------------------------------------------------------------------------------------------
// Frames

/// The scatterers of the simulated ColoRadar frame: `(range m, azimuth °, elevation °, range
/// rate m/s, amplitude LSB)`, each moving radially. Chosen to exercise every stage: static and moving targets (the
/// moving ones need TDM compensation), both azimuth signs up to 50°, elevations from −10° to
/// +12°, ranges from 3 m to 12 m.
pub const COLORADAR_SCATTERERS: [(f64, f64, f64, f64, f64); 6] = [
    (3.0, 12.0, 6.0, 0.0, 300.0),
    (5.2, -25.0, -10.0, 1.5, 300.0),
    (6.5, 0.0, 0.0, -0.7, 500.0),
    (7.9, 35.0, 3.0, -1.5, 300.0),
    (10.5, -5.0, 12.0, 0.0, 300.0),
    (12.0, 50.0, -5.0, 2.0, 200.0),
];

/// Noise standard deviation of the simulated frame, LSB on I and on Q.
pub const COLORADAR_NOISE_STD: f64 = 5.0;

/// The simulated ColoRadar frame the firmware embeds: [`COLORADAR_SCATTERERS`] (random phases)
/// in white noise of [`COLORADAR_NOISE_STD`], rendered by [`host_sim::sim::try_render_frame`]
/// from a fixed seed. Same inputs, same frame.
pub fn coloradar_frame() -> Result<AdcFrame, FirmwareError> {
    use rand::Rng;
    let sensor = SensorConfig::coloradar();
    let mut rng = rand::rngs::StdRng::seed_from_u64(COLORADAR_SEED);
    let scatterers: Vec<Scatterer> = COLORADAR_SCATTERERS
        .iter()
        .map(|&(range, az_deg, el_deg, range_rate, amplitude)| {
            // Spec §2 angles: μ = sin φ·cos θ (towards −y), ν = sin θ.
            let (phi, theta) = (az_deg.to_radians(), el_deg.to_radians());
            let (mu, nu) = (phi.sin() * theta.cos(), theta.sin());
            let u = [(1.0 - mu * mu - nu * nu).sqrt(), -mu, nu];
            Scatterer {
                position: u.map(|c| range * c),
                velocity: u.map(|c| range_rate * c),
                acceleration: [0.0; 3],
                amplitude,
                phase: rng.gen::<f64>() * std::f64::consts::TAU,
            }
        })
        .collect();
    host_sim::sim::try_render_frame(&sensor, &scatterers, COLORADAR_NOISE_STD, &mut rng)
        .map_err(|e| FirmwareError::Simulation(e.to_string()))
}

/// The TI DCA1000 capture (one frame) as an [`AdcFrame`] of the IWR6843 fixture's sizes.
pub fn iwr6843_frame(capture: &Path) -> Result<AdcFrame, FirmwareError> {
    let mut frames = host_sim::io::read_dca1000(capture, &SensorConfig::iwr6843_fixture())?;
    match (frames.pop(), frames.is_empty()) {
        (Some(frame), true) => Ok(frame),
        _ => Err(FirmwareError::BadInput {
            path: capture.to_path_buf(),
            message: format!("expected one frame, found {}", frames.len() + 1),
        }),
    }
}

/// The frame's bytes as the firmware embeds them: `AdcFrame` order, int16 LE, I then Q.
pub fn frame_bytes(frame: &AdcFrame) -> Vec<u8> {
    frame
        .data
        .iter()
        .flat_map(|[i, q]| {
            let (i, q) = (i.to_le_bytes(), q.to_le_bytes());
            [i[0], i[1], q[0], q[1]]
        })
        .collect()
}

/// Write the simulated ColoRadar frame ([`coloradar_frame`]) to `path` for `build.rs`, unless
/// the file already holds it (then the firmware is not rebuilt). Returns the frame.
pub fn write_coloradar_frame(path: &Path) -> Result<AdcFrame, FirmwareError> {
    let frame = coloradar_frame()?;
    write_if_changed(path, &frame_bytes(&frame))?;
    Ok(frame)
}

/// Write both frames the images embed into [`Layout::frames_dir`] (`coloradar.frame`,
/// simulated; `iwr6843.frame`, the TI capture read by [`host_sim::io::read_dca1000`]); returns
/// the ColoRadar frame. Unchanged files are left untouched.
pub fn write_frames(layout: &Layout) -> Result<AdcFrame, FirmwareError> {
    let capture = layout.iwr6843_capture();
    if !capture.is_file() {
        return Err(FirmwareError::BadInput {
            path: capture,
            message: "the TI fixture is missing (../shared beside the repository)".into(),
        });
    }
    let dir = layout.frames_dir();
    let iwr = iwr6843_frame(&capture)?;
    write_if_changed(&dir.join("iwr6843.frame"), &frame_bytes(&iwr))?;
    write_coloradar_frame(&dir.join("coloradar.frame"))
}

/// Write `bytes` to `path` unless it already holds them (an unchanged file keeps its mtime,
/// so cargo does not rebuild the firmware); written through a temporary and a rename.
pub(crate) fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<(), FirmwareError> {
    if std::fs::read(path).is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io_err(dir, "create directory"))?;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(io_err(&tmp, "write"))?;
    std::fs::rename(&tmp, path).map_err(io_err(path, "rename into place"))
}
