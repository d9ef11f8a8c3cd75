//! FMCW simulator with ground truth: scenes → raw ADC frames (`spec/pipeline.md` §2).
//!
//! - [`render`]: [`render_frame`] turns point [`Scatterer`]s into one [`AdcFrame`].
//! - [`scene`]: [`Scene`] files (TOML) with the sensor trajectory and the objects, and the
//!   amplitude and surface model.
//! - `world` (private): surface sampling, visibility and the world → radar transform.
//! - [`truth`]: [`FrameTruth`] per frame and [`write_truth`].
//!
//! - [`trajectory`]: 6-DoF rig motion ([`trajectory::Trajectory`]) and the sensor mounts.
//! - [`imu`]: the simulated IMU ([`imu::simulate_imu`]).
//!
//! Data flow of [`Simulation::frame`]: rig pose at `i / frame_rate`, carried to the radar's
//! mount → every object placed in the radar frame (scatterers with their motion relative to
//! the radar to second order, and truth) → [`try_render_frame`] with the frame's own noise
//! generator. Every random choice follows from the scene seed, so a frame depends only on
//! `(scene, sensor, index)`.
//!
//! ```
//! use host_sim::{sensor::SensorConfig, sim::{simulate, Scene}};
//!
//! let frames = simulate(&Scene::builtin_demo(), &SensorConfig::coloradar(), 1).unwrap();
//! let corner = &frames[0].truth.objects[0];
//! assert!(corner.visible && (corner.range_m - 4.08).abs() < 0.01);
//! ```

pub mod imu;
pub mod render;
pub mod scene;
pub mod trajectory;
pub mod truth;
mod world;

use std::path::{Path, PathBuf};

use rand::{rngs::StdRng, SeedableRng};

pub use render::{check_sensor, render_frame, try_render_frame, Scatterer};
pub use scene::{load_scene, Multipath, Object, ObjectKind, Scene, SurfaceModel};
pub use truth::{write_truth, FrameTruth, ObjectTruth, SensorPose};

use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;

/// Stream of the per-frame noise generators.
const NOISE_STREAM: u64 = 0x4E4F_4953;

/// What went wrong while loading a scene or simulating.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A scene file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A scene file is not valid TOML or does not match the scene layout.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A scene value is out of range.
    #[error("scene {scene}: {problem}")]
    Scene {
        /// The file or the scene name.
        scene: String,
        /// Which value and why.
        problem: String,
    },
    /// The sensor description cannot be rendered.
    #[error("sensor: {problem}")]
    Sensor {
        /// Which value and why.
        problem: String,
    },
    /// A scatterer list or noise level cannot be rendered.
    #[error("render: {problem}")]
    Render {
        /// Which value and why.
        problem: String,
    },
}

/// One simulated frame.
#[derive(Clone, Debug)]
pub struct SimFrame {
    /// Frame index.
    pub index: usize,
    /// Start time, s.
    pub time_s: f64,
    /// Raw ADC samples.
    pub adc: AdcFrame,
    /// What the frame shows.
    pub truth: FrameTruth,
}

/// A scene bound to a sensor, with its surfaces sampled: renders any frame on demand.
#[derive(Clone, Debug)]
pub struct Simulation {
    scene: Scene,
    sensor: SensorConfig,
    max_range_m: f64,
    objects: Vec<world::Prepared>,
}

impl Simulation {
    /// Validate `scene` against `sensor` and sample its surfaces.
    ///
    /// The default largest range is `N − 1` range bins: farther scatterers would alias onto
    /// the first bins of the complex beat spectrum. A given `max_range_m` must not exceed
    /// `N` bins.
    pub fn new(scene: &Scene, sensor: &SensorConfig) -> Result<Self, SimError> {
        let invalid = |problem: String| SimError::Scene {
            scene: scene.name.clone(),
            problem,
        };
        scene.validate().map_err(invalid)?;
        check_sensor(sensor)?;
        let bin = sensor.waveform.range_bin_m(sensor.samples);
        let max_range_m = match scene.field_of_view.max_range_m {
            None => bin * (sensor.samples as f64 - 1.0),
            Some(m) if m <= bin * sensor.samples as f64 => m,
            Some(m) => {
                return Err(invalid(format!(
                    "field_of_view.max_range_m ({m} m) exceeds the sensor's {} range bins \
                     ({:.3} m)",
                    sensor.samples,
                    bin * sensor.samples as f64
                )))
            }
        };
        if max_range_m <= scene.field_of_view.min_range_m {
            return Err(invalid(format!(
                "field_of_view.min_range_m ({}) must be below the largest range {max_range_m:.3} m",
                scene.field_of_view.min_range_m
            )));
        }
        Ok(Self {
            scene: scene.clone(),
            sensor: sensor.clone(),
            max_range_m,
            objects: world::prepare(scene),
        })
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Start time of frame `index`, s.
    pub fn time_s(&self, index: usize) -> f64 {
        index as f64 / self.scene.frame_rate_hz
    }

    /// The scatterers of frame `index` (radar frame at the frame start) and its ground truth.
    pub fn scatterers(&self, index: usize) -> (Vec<Scatterer>, FrameTruth) {
        let time_s = self.time_s(index);
        let base = self.scene.sensor.pose(time_s);
        let pose = base.mounted(&self.scene.rig.radar);
        let view = world::View::new(
            pose,
            time_s,
            &self.scene.field_of_view,
            self.max_range_m,
            self.scene.occlusion,
            world::Scattering::of(&self.scene),
            self.scene.radar_constant,
            &self.objects,
        );
        let mut scatterers = Vec::new();
        let objects = (0..self.objects.len())
            .map(|id| view.place(id, &mut scatterers))
            .collect();
        let truth = FrameTruth {
            index,
            time_s,
            sensor: pose.into(),
            base: base.into(),
            scatterers: scatterers.len(),
            objects,
        };
        (scatterers, truth)
    }

    /// Render frame `index` with its ground truth.
    pub fn frame(&self, index: usize) -> Result<SimFrame, SimError> {
        let (scatterers, truth) = self.scatterers(index);
        let mut rng = StdRng::seed_from_u64(render::mix(
            render::mix(self.scene.seed, NOISE_STREAM),
            index as u64,
        ));
        let adc = try_render_frame(&self.sensor, &scatterers, self.scene.noise_std, &mut rng)?;
        Ok(SimFrame {
            index,
            time_s: truth.time_s,
            adc,
            truth,
        })
    }
}

/// The IMU samples of `scene` over the `frames` frame periods of a simulated sequence (from 0
/// to `frames / frame_rate_hz` s).
pub fn scene_imu(scene: &Scene, frames: usize) -> Vec<imu::ImuSample> {
    let duration_s = frames as f64 / scene.frame_rate_hz;
    imu::simulate_imu(
        &scene.imu,
        &scene.sensor,
        &scene.rig.imu,
        duration_s,
        scene.seed,
    )
}

/// Write the navigation files of a simulated sequence of `frames` frames into `dir`:
/// `imu/` ([`scene_imu`]) and `calib/transforms/` (the scene's rig), in ColoRadar's layout
/// ([`crate::io::navigation`]). The ground-truth poses come with [`write_truth`].
pub fn write_navigation(
    dir: &Path,
    scene: &Scene,
    frames: usize,
) -> Result<(), crate::io::IoError> {
    crate::io::write_imu(dir, &scene_imu(scene, frames))?;
    crate::io::write_transforms(&dir.join("calib"), &scene.rig)
}

/// Simulate frames `0..frames` of `scene` as seen by `sensor`.
pub fn simulate(
    scene: &Scene,
    sensor: &SensorConfig,
    frames: usize,
) -> Result<Vec<SimFrame>, SimError> {
    let sim = Simulation::new(scene, sensor)?;
    (0..frames).map(|i| sim.frame(i)).collect()
}
