//! Scene files: the sensor trajectory, noise, seed and the objects of a simulated sequence.
//!
//! A scene is TOML (see `host-sim/scenes/*.toml`). Coordinates are a world frame that is the
//! radar frame at the trajectory's start pose when that pose is the origin with yaw 0:
//! x forward, y left, z up, metres. Every table denies unknown keys, so a misspelt key is an
//! error that names it.
//!
//! ```toml
//! name = "example"
//! seed = 7                 # scatterer phases, jitter and noise all follow from it
//! frame_rate_hz = 10.0     # default 10
//! noise_std = 8.0          # LSB per I and per Q, default 8
//! radar_constant = 200.0   # LSB of a 1 m² target at 1 m, default 200
//!
//! [sensor]                 # static, constant velocity (+ yaw rate), or `waypoints`
//! velocity = [1.2, 0.0, 0.0]
//!
//! [[objects]]
//! kind = "point"           # point | rectangle (alias wall, plane) | box | pole
//! position = [5.0, 0.0, 0.0]
//! rcs_m2 = 10.0            # or `amplitude` in LSB (no range falloff)
//! ```
//!
//! # Amplitude model
//!
//! The radar equation gives a received power ∝ σ / R⁴, so a point target of radar cross
//! section σ (m²) at range R (m) has the sample amplitude `A = radar_constant · √σ / R²`
//! (LSB), evaluated at the frame start. A point target given by `amplitude` keeps that value at
//! every range.
//!
//! A surface is many scatterers with independent uniform random phases, each standing for the
//! patch of area `dA = area / count` around it, with the cross section
//! `σ_i = reflectivity · dA · cos^p(θ_i)` (`reflectivity` is σ⁰ in m²/m², θ_i the incidence
//! angle, `p = incidence_exponent`, 2 = Lambert's law for radar). Random phases add in power,
//! so the expected power of a surface patch is `Σ σ_i = σ⁰ · area · cos^p` whatever the
//! sampling density: the density changes the speckle, not the brightness.
//!
//! # Realistic surfaces (`[surfaces]`, all off by default)
//!
//! Real walls are mostly specular, their edges and corners bright, and a floor doubles what
//! stands on it. The scene's `[surfaces]` table ([`SurfaceModel`]) adds, for every surface:
//!
//! - a specular lobe beside the diffuse floor:
//!   `σ⁰(θ) = reflectivity · (diffuse · cos^p θ + specular · exp(−θ² / 2w²))`, `w =
//!   specular_width_deg` (a rough wall's lobe: the scatterers keep independent phases, so the
//!   lobe adds power, not the coherent flash of a polished plate);
//! - line scatterers along every edge of a rectangle or box (`edge_rcs_m2_per_m`, spaced like
//!   the surface's scatterers) and a point scatterer at every vertex (`corner_rcs_m2`), seen
//!   when a face they bound faces the radar (rectangles: always) and nothing else hides them;
//! - `[surfaces.multipath]`: the floor-bounce ghost by the image method. Every scatterer above
//!   the horizontal plane `z = plane_z_m` (default: the lowest horizontal rectangle of the
//!   scene) gets an image mirrored in it, with the amplitude of a scatterer there times `Γ²`
//!   (`Γ = reflection`: the path radar → floor → scatterer → floor → radar bounces twice, each
//!   bounce `−Γ`, so the ghost keeps the scatterer's phase). The image moves with the mirrored
//!   velocity. The two one-bounce paths
//!   (radar → scatterer → floor → radar and back) are not modelled; neither is anything the
//!   ghost path would cross, nor whether the floor rectangle extends under the bounce point.
//!
//! Ghosts, edges and corners carry no extra ground truth: edges and corners lie on the surfaces
//! already sampled, and a ghost is a false point by construction, as in a real recording
//! scored against LiDAR. [`SurfaceModel::realistic`] is the set `dbe eval` uses.
//!
//! A scatterer or ground-truth point is seen when it is inside the field of view at the frame
//! start (`x > 0`, |azimuth| ≤ `azimuth_deg`, |elevation| ≤ `elevation_deg`,
//! `min_range_m ≤ R ≤ max_range_m`), faces the radar (rectangles are two-sided; boxes and poles
//! are solids seen from outside, a pole's caps are not sampled) and, when `occlusion` is on,
//! no other rectangle, box or pole blocks the line of sight. Multipath is modelled only as the
//! optional floor ghost above.

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use super::imu::ImuSpec;
pub use super::trajectory::{Interpolation, Mount, Pose, Trajectory, Waypoint};
use super::SimError;

/// A scene: everything needed to simulate a sequence for a given sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name.
    #[serde(default)]
    pub name: String,
    /// What the scene shows.
    #[serde(default)]
    pub description: String,
    /// Seed of every random choice (scatterer phases, surface jitter, noise).
    #[serde(default)]
    pub seed: u64,
    /// Frame rate, Hz; frame `i` starts at `i / frame_rate_hz` s.
    #[serde(default = "default_frame_rate")]
    pub frame_rate_hz: f64,
    /// Standard deviation of the ADC noise on I and on Q, LSB.
    #[serde(default = "default_noise")]
    pub noise_std: f64,
    /// Amplitude of a 1 m² point target at 1 m, LSB (see the module docs).
    #[serde(default = "default_radar_constant")]
    pub radar_constant: f64,
    /// Spacing of the ground-truth surface samples, m.
    #[serde(default = "default_truth_spacing")]
    pub truth_spacing_m: f64,
    /// Whether surfaces hide what lies behind them.
    #[serde(default = "default_true")]
    pub occlusion: bool,
    /// What the radar sees.
    #[serde(default)]
    pub field_of_view: FieldOfView,
    /// How the rig's base frame moves (the radar's, unless `rig.radar` mounts it elsewhere).
    #[serde(default)]
    pub sensor: Trajectory,
    /// Where the radar and the IMU sit on the rig.
    #[serde(default, skip_serializing_if = "Rig::is_default")]
    pub rig: Rig,
    /// The simulated IMU.
    #[serde(default)]
    pub imu: ImuSpec,
    /// Realistic-surface options: specular lobe, edges, corners, floor multipath (off by
    /// default; see the module docs).
    #[serde(default, skip_serializing_if = "SurfaceModel::is_default")]
    pub surfaces: SurfaceModel,
    /// The objects, in `[[objects]]` tables; an object's id is its index here.
    #[serde(default)]
    pub objects: Vec<Object>,
}

fn default_frame_rate() -> f64 {
    10.0
}
fn default_noise() -> f64 {
    8.0
}
fn default_radar_constant() -> f64 {
    200.0
}
fn default_truth_spacing() -> f64 {
    0.1
}
fn default_true() -> bool {
    true
}

/// The sensors' mounts on the rig (ColoRadar's `calib/transforms/base_to_*.txt`); both
/// default to the base frame itself.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rig {
    /// The radar (`base_to_single_chip.txt`).
    #[serde(default)]
    pub radar: Mount,
    /// The IMU (`base_to_imu.txt`).
    #[serde(default)]
    pub imu: Mount,
}

impl Rig {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// How surfaces scatter beyond the diffuse `cos^p` law (module docs, "Realistic surfaces").
/// The default is exactly the diffuse model: no lobe, edges, corners or ghosts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceModel {
    /// Scale of the diffuse `cos^p` term (default 1).
    #[serde(default = "default_one")]
    pub diffuse: f64,
    /// Specular lobe at normal incidence, in units of the surface's `reflectivity` (default 0).
    #[serde(default)]
    pub specular: f64,
    /// Standard deviation of the Gaussian specular lobe in incidence angle, degrees (default 5).
    #[serde(default = "default_lobe_deg")]
    pub specular_width_deg: f64,
    /// Cross section per metre of every rectangle and box edge, m²/m (default 0).
    #[serde(default)]
    pub edge_rcs_m2_per_m: f64,
    /// Cross section of every rectangle and box vertex, m² (default 0).
    #[serde(default)]
    pub corner_rcs_m2: f64,
    /// Floor-bounce ghosts (default none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub multipath: Option<Multipath>,
}

/// The floor of [`SurfaceModel::multipath`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Multipath {
    /// Amplitude reflection coefficient `|Γ|` of the floor, 0..=1.
    pub reflection: f64,
    /// Height of the mirror plane in the world, m (default: the lowest horizontal rectangle).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane_z_m: Option<f64>,
}

fn default_one() -> f64 {
    1.0
}
fn default_lobe_deg() -> f64 {
    5.0
}

impl Default for SurfaceModel {
    fn default() -> Self {
        Self {
            diffuse: 1.0,
            specular: 0.0,
            specular_width_deg: default_lobe_deg(),
            edge_rcs_m2_per_m: 0.0,
            corner_rcs_m2: 0.0,
            multipath: None,
        }
    }
}

impl SurfaceModel {
    /// The realistic set of `dbe eval`: the diffuse term 3 dB down, a specular lobe 10 dB
    /// above it at normal incidence (5° wide), edges of 0.1 m²/m (a 2.5 m wall edge is 7 dB
    /// above the wall's own patch in one resolution cell at 5 m), corners of 1 m² and a floor
    /// with `|Γ| = 0.6` (ghosts 9 dB below their scatterer at equal range).
    pub fn realistic() -> Self {
        Self {
            diffuse: 0.5,
            specular: 10.0,
            specular_width_deg: 5.0,
            edge_rcs_m2_per_m: 0.1,
            corner_rcs_m2: 1.0,
            multipath: Some(Multipath {
                reflection: 0.6,
                plane_z_m: None,
            }),
        }
    }

    /// Whether this is the plain diffuse model.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    fn validate(&self) -> Result<(), String> {
        non_negative("surfaces.diffuse", self.diffuse)?;
        non_negative("surfaces.specular", self.specular)?;
        in_range(
            "surfaces.specular_width_deg",
            self.specular_width_deg,
            0.0,
            90.0,
        )?;
        non_negative("surfaces.edge_rcs_m2_per_m", self.edge_rcs_m2_per_m)?;
        non_negative("surfaces.corner_rcs_m2", self.corner_rcs_m2)?;
        if let Some(m) = &self.multipath {
            if !(0.0..=1.0).contains(&m.reflection) {
                return Err(format!(
                    "surfaces.multipath.reflection must be in [0, 1], got {}",
                    m.reflection
                ));
            }
            if let Some(z) = m.plane_z_m {
                finite("surfaces.multipath.plane_z_m", z)?;
            }
        }
        Ok(())
    }
}

/// The visible region, in the radar frame at the frame start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldOfView {
    /// Largest |azimuth| φ, degrees (default 70, the DBE azimuth grid).
    #[serde(default = "default_fov_az")]
    pub azimuth_deg: f64,
    /// Largest |elevation| θ, degrees (default 25, the DBE elevation grid).
    #[serde(default = "default_fov_el")]
    pub elevation_deg: f64,
    /// Smallest range, m (default 0.3).
    #[serde(default = "default_min_range")]
    pub min_range_m: f64,
    /// Largest range, m; default `(N − 1)` range bins of the sensor (15.86 m for ColoRadar).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_range_m: Option<f64>,
}

fn default_fov_az() -> f64 {
    70.0
}
fn default_fov_el() -> f64 {
    25.0
}
fn default_min_range() -> f64 {
    0.3
}

impl Default for FieldOfView {
    fn default() -> Self {
        Self {
            azimuth_deg: default_fov_az(),
            elevation_deg: default_fov_el(),
            min_range_m: default_min_range(),
            max_range_m: None,
        }
    }
}

/// One object of the scene, tagged by `kind`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Object {
    /// A point target (corner reflector, small object).
    Point(PointTarget),
    /// A flat two-sided rectangle (wall, floor, fence, plate).
    #[serde(alias = "wall", alias = "plane")]
    Rectangle(Rectangle),
    /// A solid box rotated about z (car, cabinet, table block).
    #[serde(rename = "box")]
    Cuboid(Cuboid),
    /// A solid vertical cylinder (pole, post, tree trunk, pillar).
    Pole(Pole),
}

/// A point target; exactly one of `amplitude` and `rcs_m2` must be given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointTarget {
    /// Name in the ground truth (default `point_<id>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// World position at time 0, m.
    pub position: [f64; 3],
    /// World velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Fixed amplitude, LSB per sample, no range falloff.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// Radar cross section, m²: amplitude `radar_constant · √σ / R²`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rcs_m2: Option<f64>,
    /// Phase φ0, degrees (default: drawn from the scene seed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_deg: Option<f64>,
}

/// Scattering properties shared by all surfaces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceParams {
    /// σ⁰ at normal incidence, m²/m².
    pub reflectivity: f64,
    /// Scatterers per m².
    pub density: f64,
    /// Exponent `p` of the `cos^p(θ)` incidence law.
    pub incidence_exponent: f64,
}

fn default_reflectivity() -> f64 {
    0.1
}
fn default_density() -> f64 {
    30.0
}
fn default_incidence_exponent() -> f64 {
    2.0
}

/// The rectangle `origin + s·edge_u + t·edge_v`, `s, t ∈ [0, 1]`, edges perpendicular.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rectangle {
    /// Name in the ground truth (default `rectangle_<id>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// One corner at time 0, m.
    pub origin: [f64; 3],
    /// First edge from `origin`, m.
    pub edge_u: [f64; 3],
    /// Second edge from `origin`, perpendicular to `edge_u`, m.
    pub edge_v: [f64; 3],
    /// World velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// σ⁰ at normal incidence, m²/m² (default 0.1).
    #[serde(default = "default_reflectivity")]
    pub reflectivity: f64,
    /// Scatterers per m² (default 30).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Exponent of the `cos^p` incidence law (default 2).
    #[serde(default = "default_incidence_exponent")]
    pub incidence_exponent: f64,
}

/// A box of `size` (length along its x, width along its y, height) centred at `center`,
/// rotated by `yaw_deg` about z.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cuboid {
    /// Name in the ground truth (default `box_<id>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Centre at time 0, m.
    pub center: [f64; 3],
    /// Edge lengths `[x, y, z]` in the box frame, m.
    pub size: [f64; 3],
    /// Rotation about z, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// World velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// σ⁰ at normal incidence, m²/m² (default 0.1).
    #[serde(default = "default_reflectivity")]
    pub reflectivity: f64,
    /// Scatterers per m² (default 30).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Exponent of the `cos^p` incidence law (default 2).
    #[serde(default = "default_incidence_exponent")]
    pub incidence_exponent: f64,
}

/// A vertical cylinder standing on `base` (centre of its bottom).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pole {
    /// Name in the ground truth (default `pole_<id>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Centre of the bottom at time 0, m.
    pub base: [f64; 3],
    /// Radius, m.
    pub radius: f64,
    /// Height, m.
    pub height: f64,
    /// World velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// σ⁰ at normal incidence, m²/m² (default 0.1).
    #[serde(default = "default_reflectivity")]
    pub reflectivity: f64,
    /// Scatterers per m² (default 30).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Exponent of the `cos^p` incidence law (default 2).
    #[serde(default = "default_incidence_exponent")]
    pub incidence_exponent: f64,
}

/// The kind of an object, as written in the ground truth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// [`PointTarget`].
    Point,
    /// [`Rectangle`].
    Rectangle,
    /// [`Cuboid`].
    Box,
    /// [`Pole`].
    Pole,
}

impl Object {
    /// The object's kind.
    pub fn kind(&self) -> ObjectKind {
        match self {
            Object::Point(_) => ObjectKind::Point,
            Object::Rectangle(_) => ObjectKind::Rectangle,
            Object::Cuboid(_) => ObjectKind::Box,
            Object::Pole(_) => ObjectKind::Pole,
        }
    }

    /// The object's name, or `<kind>_<id>` when the scene gives none.
    pub fn name(&self, id: usize) -> String {
        let given = match self {
            Object::Point(o) => &o.name,
            Object::Rectangle(o) => &o.name,
            Object::Cuboid(o) => &o.name,
            Object::Pole(o) => &o.name,
        };
        match given {
            Some(n) => n.clone(),
            None => format!("{}_{id}", kind_str(self.kind())),
        }
    }

    /// World velocity, m/s.
    pub fn velocity(&self) -> [f64; 3] {
        match self {
            Object::Point(o) => o.velocity,
            Object::Rectangle(o) => o.velocity,
            Object::Cuboid(o) => o.velocity,
            Object::Pole(o) => o.velocity,
        }
    }

    /// Scattering properties of a surface; `None` for a point target.
    pub fn surface(&self) -> Option<SurfaceParams> {
        let p = |reflectivity, density, incidence_exponent| SurfaceParams {
            reflectivity,
            density,
            incidence_exponent,
        };
        match self {
            Object::Point(_) => None,
            Object::Rectangle(o) => Some(p(o.reflectivity, o.density, o.incidence_exponent)),
            Object::Cuboid(o) => Some(p(o.reflectivity, o.density, o.incidence_exponent)),
            Object::Pole(o) => Some(p(o.reflectivity, o.density, o.incidence_exponent)),
        }
    }

    /// Reference point at time 0 (point position, rectangle / box / pole centre), m.
    pub fn center(&self) -> [f64; 3] {
        match self {
            Object::Point(o) => o.position,
            Object::Rectangle(o) => {
                std::array::from_fn(|i| o.origin[i] + 0.5 * (o.edge_u[i] + o.edge_v[i]))
            }
            Object::Cuboid(o) => o.center,
            Object::Pole(o) => [o.base[0], o.base[1], o.base[2] + 0.5 * o.height],
        }
    }

    /// Surface area, m² (0 for a point target).
    pub fn area(&self) -> f64 {
        match self {
            Object::Point(_) => 0.0,
            Object::Rectangle(o) => norm(o.edge_u) * norm(o.edge_v),
            Object::Cuboid(o) => {
                let [a, b, c] = o.size;
                2.0 * (a * b + b * c + a * c)
            }
            Object::Pole(o) => 2.0 * std::f64::consts::PI * o.radius * o.height,
        }
    }
}

pub(crate) fn kind_str(kind: ObjectKind) -> &'static str {
    match kind {
        ObjectKind::Point => "point",
        ObjectKind::Rectangle => "rectangle",
        ObjectKind::Box => "box",
        ObjectKind::Pole => "pole",
    }
}

pub(crate) fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Most surface scatterers a scene may sample (before visibility culling).
pub const MAX_SCATTERERS: f64 = 2.0e6;
/// Most ground-truth surface samples a scene may hold (before visibility culling).
pub const MAX_TRUTH_POINTS: f64 = 5.0e6;

/// Read and validate a scene file.
///
/// Errors name the file and the problem: I/O, TOML syntax, unknown or missing keys, wrong
/// types (with line and column), and invalid values (see [`Scene::validate`]).
pub fn load_scene(path: &Path) -> Result<Scene, SimError> {
    let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let scene: Scene = toml::from_str(&text).map_err(|e| SimError::Parse {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    scene.validate().map_err(|problem| SimError::Scene {
        scene: path.display().to_string(),
        problem,
    })?;
    Ok(scene)
}

impl Scene {
    /// Parse and validate a scene from TOML text; `origin` names it in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, SimError> {
        let scene: Scene = toml::from_str(text).map_err(|e| SimError::Parse {
            path: origin.into(),
            message: e.to_string(),
        })?;
        scene.validate().map_err(|problem| SimError::Scene {
            scene: origin.to_string(),
            problem,
        })?;
        Ok(scene)
    }

    /// Check every value that does not depend on the sensor; the error says which one is
    /// wrong and why.
    pub fn validate(&self) -> Result<(), String> {
        positive("frame_rate_hz", self.frame_rate_hz)?;
        non_negative("noise_std", self.noise_std)?;
        positive("radar_constant", self.radar_constant)?;
        positive("truth_spacing_m", self.truth_spacing_m)?;
        let fov = &self.field_of_view;
        in_range("field_of_view.azimuth_deg", fov.azimuth_deg, 0.0, 90.0)?;
        in_range("field_of_view.elevation_deg", fov.elevation_deg, 0.0, 90.0)?;
        positive("field_of_view.min_range_m", fov.min_range_m)?;
        if let Some(max) = fov.max_range_m {
            positive("field_of_view.max_range_m", max)?;
            if max <= fov.min_range_m {
                return Err(format!(
                    "field_of_view.max_range_m ({max}) must exceed min_range_m ({})",
                    fov.min_range_m
                ));
            }
        }
        self.validate_trajectory()?;
        self.rig.radar.validate("rig.radar")?;
        self.rig.imu.validate("rig.imu")?;
        self.imu.validate()?;
        self.surfaces.validate()?;
        if self.surfaces.multipath.is_some() && self.floor_z_m().is_none() {
            return Err(
                "surfaces.multipath: the scene has no horizontal rectangle to bounce \
                        on; give plane_z_m"
                    .into(),
            );
        }
        let mut names = std::collections::HashSet::new();
        let (mut scatterers, mut truth) = (0.0, 0.0);
        for (id, object) in self.objects.iter().enumerate() {
            let name = object.name(id);
            let at = format!("objects[{id}] ({name})");
            validate_object(object).map_err(|e| format!("{at}: {e}"))?;
            if !names.insert(name.clone()) {
                return Err(format!("{at}: duplicate name {name:?}"));
            }
            if let Some(s) = object.surface() {
                scatterers += object.area() * s.density;
                truth += object.area() / (self.truth_spacing_m * self.truth_spacing_m);
            }
        }
        if scatterers > MAX_SCATTERERS {
            return Err(format!(
                "surfaces would be sampled into {scatterers:.0} scatterers, more than \
                 {MAX_SCATTERERS:.0}: lower the densities"
            ));
        }
        if truth > MAX_TRUTH_POINTS {
            return Err(format!(
                "surfaces would need {truth:.0} ground-truth points, more than \
                 {MAX_TRUTH_POINTS:.0}: raise truth_spacing_m"
            ));
        }
        Ok(())
    }

    /// Height of the multipath mirror plane: `surfaces.multipath.plane_z_m`, else the lowest
    /// horizontal rectangle (both edges in the x–y plane); `None` without multipath or floor.
    pub fn floor_z_m(&self) -> Option<f64> {
        let m = self.surfaces.multipath.as_ref()?;
        m.plane_z_m.or_else(|| {
            self.objects
                .iter()
                .filter_map(|o| match o {
                    Object::Rectangle(r) if r.edge_u[2] == 0.0 && r.edge_v[2] == 0.0 => {
                        Some(r.origin[2])
                    }
                    _ => None,
                })
                .reduce(f64::min)
        })
    }

    fn validate_trajectory(&self) -> Result<(), String> {
        let s = &self.sensor;
        if let Some(p) = s.position {
            finite3("sensor.position", p)?;
        }
        if let Some(v) = s.velocity {
            finite3("sensor.velocity", v)?;
        }
        if let Some(y) = s.yaw_deg {
            finite("sensor.yaw_deg", y)?;
        }
        if let Some(y) = s.yaw_rate_deg_s {
            finite("sensor.yaw_rate_deg_s", y)?;
        }
        if s.waypoints.is_empty() {
            return Ok(());
        }
        if s.position.is_some()
            || s.velocity.is_some()
            || s.yaw_deg.is_some()
            || s.yaw_rate_deg_s.is_some()
        {
            return Err(
                "sensor: give either waypoints or position/velocity/yaw_deg/yaw_rate_deg_s, \
                 not both"
                    .into(),
            );
        }
        for (i, w) in s.waypoints.iter().enumerate() {
            finite(&format!("sensor.waypoints[{i}].time_s"), w.time_s)?;
            finite3(&format!("sensor.waypoints[{i}].position"), w.position)?;
            finite(&format!("sensor.waypoints[{i}].yaw_deg"), w.yaw_deg)?;
            in_range(
                &format!("sensor.waypoints[{i}].pitch_deg"),
                w.pitch_deg.abs(),
                -1.0,
                89.0,
            )?;
            finite(&format!("sensor.waypoints[{i}].roll_deg"), w.roll_deg)?;
            if i > 0 && w.time_s <= s.waypoints[i - 1].time_s {
                return Err(format!(
                    "sensor.waypoints[{i}].time_s ({}) must be later than the previous \
                     waypoint's ({})",
                    w.time_s,
                    s.waypoints[i - 1].time_s
                ));
            }
        }
        Ok(())
    }
}

fn validate_object(object: &Object) -> Result<(), String> {
    finite3("velocity", object.velocity())?;
    if let Some(s) = object.surface() {
        non_negative("reflectivity", s.reflectivity)?;
        positive("density", s.density)?;
        non_negative("incidence_exponent", s.incidence_exponent)?;
    }
    match object {
        Object::Point(o) => {
            finite3("position", o.position)?;
            match (o.amplitude, o.rcs_m2) {
                (Some(a), None) => non_negative("amplitude", a)?,
                (None, Some(r)) => non_negative("rcs_m2", r)?,
                _ => return Err("give exactly one of amplitude and rcs_m2".into()),
            }
            if let Some(p) = o.phase_deg {
                finite("phase_deg", p)?;
            }
        }
        Object::Rectangle(o) => {
            finite3("origin", o.origin)?;
            finite3("edge_u", o.edge_u)?;
            finite3("edge_v", o.edge_v)?;
            let (a, b) = (norm(o.edge_u), norm(o.edge_v));
            if a <= 0.0 || b <= 0.0 {
                return Err("edge_u and edge_v must be non-zero".into());
            }
            let dot: f64 = (0..3).map(|i| o.edge_u[i] * o.edge_v[i]).sum();
            if dot.abs() > 1e-6 * a * b {
                return Err(format!(
                    "edge_u {:?} and edge_v {:?} must be perpendicular",
                    o.edge_u, o.edge_v
                ));
            }
        }
        Object::Cuboid(o) => {
            finite3("center", o.center)?;
            finite("yaw_deg", o.yaw_deg)?;
            for (i, v) in o.size.iter().enumerate() {
                positive(&format!("size[{i}]"), *v)?;
            }
        }
        Object::Pole(o) => {
            finite3("base", o.base)?;
            positive("radius", o.radius)?;
            positive("height", o.height)?;
        }
    }
    Ok(())
}

fn finite(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} must be finite, got {v}"))
    }
}

fn finite3(name: &str, v: [f64; 3]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{name} must be finite, got {v:?}"))
    }
}

fn positive(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be finite and positive, got {v}"))
    }
}

fn non_negative(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be finite and ≥ 0, got {v}"))
    }
}

fn in_range(name: &str, v: f64, lo: f64, hi: f64) -> Result<(), String> {
    if v.is_finite() && v > lo && v <= hi {
        Ok(())
    } else {
        Err(format!("{name} must be in ({lo}, {hi}], got {v}"))
    }
}

impl Scene {
    /// The radar's exact velocity in its own frame at time `t`, m/s: the rig's pose at `t`
    /// with the radar's mount (the ego-velocity truth).
    pub fn radar_velocity(&self, t: f64) -> nalgebra::Vector3<f64> {
        self.sensor.pose(t).mounted(&self.rig.radar).body_velocity()
    }

    /// The scene of `dbe demo`: four corner reflectors at different ranges, azimuths and
    /// elevations, a wall 14 m ahead and a pole, seen by a sensor walking forward at 1.2 m/s.
    pub fn builtin_demo() -> Self {
        let corner = |name: &str, position: [f64; 3], rcs_m2: f64| {
            Object::Point(PointTarget {
                name: Some(name.into()),
                position,
                velocity: [0.0; 3],
                amplitude: None,
                rcs_m2: Some(rcs_m2),
                phase_deg: None,
            })
        };
        Self {
            name: "demo".into(),
            description: "Four corner reflectors, a wall and a pole; sensor walking forward \
                          at 1.2 m/s"
                .into(),
            seed: 2025,
            frame_rate_hz: default_frame_rate(),
            noise_std: default_noise(),
            radar_constant: default_radar_constant(),
            truth_spacing_m: default_truth_spacing(),
            occlusion: true,
            field_of_view: FieldOfView::default(),
            sensor: Trajectory {
                velocity: Some([1.2, 0.0, 0.0]),
                ..Trajectory::default()
            },
            rig: Rig::default(),
            imu: ImuSpec::default(),
            surfaces: SurfaceModel::default(),
            objects: vec![
                corner("corner_4m", [4.0, 0.8, 0.0], 10.0),
                corner("corner_7m_right_up", [7.0, -2.5, 1.0], 20.0),
                corner("corner_10m_left_down", [10.0, 3.5, -1.0], 30.0),
                corner("corner_12m", [12.5, -1.0, 0.4], 30.0),
                Object::Rectangle(Rectangle {
                    name: Some("wall".into()),
                    origin: [14.5, 5.0, -1.2],
                    edge_u: [0.0, -10.0, 0.0],
                    edge_v: [0.0, 0.0, 3.0],
                    velocity: [0.0; 3],
                    reflectivity: 0.1,
                    density: 30.0,
                    incidence_exponent: 2.0,
                }),
                Object::Pole(Pole {
                    name: Some("pole".into()),
                    base: [8.5, 1.5, -1.2],
                    radius: 0.1,
                    height: 3.0,
                    velocity: [0.0; 3],
                    reflectivity: 0.5,
                    density: 60.0,
                    incidence_exponent: 2.0,
                }),
            ],
        }
    }
}
