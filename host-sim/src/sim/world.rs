//! Scene geometry: surfaces sampled into scatterers and ground-truth points, visibility
//! (field of view, facing, occlusion) and the world → radar transform of one frame.

use std::f64::consts::TAU;

use nalgebra::Vector3;
use rand::{rngs::StdRng, Rng, SeedableRng};

use super::render::{mix, Scatterer};
use super::scene::{
    norm, FieldOfView, Object, ObjectKind, Pose, Scene, SurfaceModel, SurfaceParams,
};
use super::truth::{look, ObjectTruth};

/// Stream of the surface-sampling generators (scatterer positions and phases).
const SURFACE_STREAM: u64 = 0x5355_5246;
/// Stream of the edge and corner generators (their own, so that switching them on leaves the
/// surface scatterers as they were).
const FEATURE_STREAM: u64 = 0x4544_4745;

/// An edge or corner scatterer ([`SurfaceModel`]), at time 0 in the world frame.
#[derive(Clone, Debug)]
pub(crate) struct Feature {
    /// Position, m.
    pub p: [f64; 3],
    /// Outward normals of the faces it bounds; seen when any of them faces the radar (empty:
    /// a two-sided rectangle's, always).
    pub faces: Vec<[f64; 3]>,
    /// Cross section, m².
    pub sigma: f64,
    /// Phase φ0, rad.
    pub phase: f64,
}

/// A sample of a surface at time 0 in the world frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample {
    /// Position, m.
    pub p: [f64; 3],
    /// Unit outward normal.
    pub n: [f64; 3],
    /// Area it stands for, m² (scatterers only).
    pub area: f64,
    /// Phase φ0, rad (scatterers only).
    pub phase: f64,
}

/// Geometry that can block a line of sight, at time 0 in the world frame.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Shape {
    /// Points block nothing.
    Point,
    /// Rectangle `origin + s·u + t·v`, unit normal `n`.
    Rect {
        origin: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        n: [f64; 3],
    },
    /// Box: centre, half sizes, yaw cos/sin.
    Box {
        center: [f64; 3],
        half: [f64; 3],
        cos: f64,
        sin: f64,
    },
    /// Vertical solid cylinder.
    Cylinder {
        base: [f64; 3],
        radius: f64,
        height: f64,
    },
}

/// What a point target scatters: a fixed amplitude or an RCS (validated: exactly one), and its
/// phase.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PointParams {
    pub amplitude: Option<f64>,
    pub rcs_m2: Option<f64>,
    pub phase: f64,
}

/// An object ready to be placed in frames.
#[derive(Clone, Debug)]
pub(crate) struct Prepared {
    pub name: String,
    pub kind: ObjectKind,
    pub velocity: [f64; 3],
    pub center: [f64; 3],
    /// Point targets only.
    pub point: Option<PointParams>,
    pub surface: Option<SurfaceParams>,
    /// Rectangles scatter from both faces.
    pub two_sided: bool,
    pub scatterers: Vec<Sample>,
    /// Edges and corners (empty unless the scene's [`SurfaceModel`] asks for them).
    pub features: Vec<Feature>,
    pub truth: Vec<Sample>,
    pub shape: Shape,
}

/// Sample every object of `scene` once; the same samples (and phases) serve every frame.
pub(crate) fn prepare(scene: &Scene) -> Vec<Prepared> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(id, object)| {
            let mut rng = StdRng::seed_from_u64(mix(mix(scene.seed, SURFACE_STREAM), id as u64));
            let mut features = FeatureSampler::new(
                &scene.surfaces,
                mix(mix(scene.seed, FEATURE_STREAM), id as u64),
            );
            let mut prepared = Prepared {
                name: object.name(id),
                kind: object.kind(),
                velocity: object.velocity(),
                center: object.center(),
                point: None,
                surface: object.surface(),
                two_sided: false,
                scatterers: Vec::new(),
                features: Vec::new(),
                truth: Vec::new(),
                shape: Shape::Point,
            };
            let spacing = scene.truth_spacing_m;
            match object {
                Object::Point(o) => {
                    let phase = match o.phase_deg {
                        Some(p) => p.to_radians(),
                        None => rng.gen::<f64>() * TAU,
                    };
                    prepared.point = Some(PointParams {
                        amplitude: o.amplitude,
                        rcs_m2: o.rcs_m2,
                        phase,
                    });
                }
                Object::Rectangle(o) => {
                    let n = unit(cross(o.edge_u, o.edge_v));
                    prepared.two_sided = true;
                    prepared.shape = Shape::Rect {
                        origin: o.origin,
                        u: o.edge_u,
                        v: o.edge_v,
                        n,
                    };
                    let face = Face {
                        origin: o.origin,
                        u: o.edge_u,
                        v: o.edge_v,
                        n,
                    };
                    face.sample(o.density, &mut rng, &mut prepared.scatterers);
                    face.grid(spacing, &mut prepared.truth);
                    let corners = [
                        o.origin,
                        add(o.origin, o.edge_u),
                        add(add(o.origin, o.edge_u), o.edge_v),
                        add(o.origin, o.edge_v),
                    ];
                    for k in 0..4 {
                        let (a, b) = (corners[k], corners[(k + 1) % 4]);
                        features.edge(a, b, o.density, &[], &mut prepared.features);
                        features.corner(a, &[], &mut prepared.features);
                    }
                }
                Object::Cuboid(o) => {
                    let (sin, cos) = o.yaw_deg.to_radians().sin_cos();
                    let half = o.size.map(|s| 0.5 * s);
                    prepared.shape = Shape::Box {
                        center: o.center,
                        half,
                        cos,
                        sin,
                    };
                    let axes = [[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]];
                    for a in 0..3 {
                        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                        for sign in [1.0, -1.0] {
                            let face = Face {
                                origin: std::array::from_fn(|i| {
                                    o.center[i] + sign * half[a] * axes[a][i]
                                        - half[b] * axes[b][i]
                                        - half[c] * axes[c][i]
                                }),
                                u: axes[b].map(|x| 2.0 * half[b] * x),
                                v: axes[c].map(|x| 2.0 * half[c] * x),
                                n: axes[a].map(|x| sign * x),
                            };
                            face.sample(o.density, &mut rng, &mut prepared.scatterers);
                            face.grid(spacing, &mut prepared.truth);
                        }
                    }
                    // Vertex `s` sits at centre + Σ s_a·half_a·axis_a; an edge joins two vertices
                    // differing in one sign, and bounds the two faces of its other two signs.
                    let vertex = |sg: [f64; 3]| -> [f64; 3] {
                        std::array::from_fn(|i| {
                            o.center[i] + (0..3).map(|a| sg[a] * half[a] * axes[a][i]).sum::<f64>()
                        })
                    };
                    let normal = |a: usize, sign: f64| axes[a].map(|x| sign * x);
                    for code in 0..8u32 {
                        let sg: [f64; 3] =
                            std::array::from_fn(|a| if code >> a & 1 == 1 { 1.0 } else { -1.0 });
                        let faces: Vec<[f64; 3]> = (0..3).map(|a| normal(a, sg[a])).collect();
                        features.corner(vertex(sg), &faces, &mut prepared.features);
                        for a in 0..3 {
                            if sg[a] < 0.0 {
                                let mut other = sg;
                                other[a] = 1.0;
                                let faces: Vec<[f64; 3]> = (0..3)
                                    .filter(|&b| b != a)
                                    .map(|b| normal(b, sg[b]))
                                    .collect();
                                features.edge(
                                    vertex(sg),
                                    vertex(other),
                                    o.density,
                                    &faces,
                                    &mut prepared.features,
                                );
                            }
                        }
                    }
                }
                Object::Pole(o) => {
                    prepared.shape = Shape::Cylinder {
                        base: o.base,
                        radius: o.radius,
                        height: o.height,
                    };
                    let d = 1.0 / o.density.sqrt();
                    let circumference = TAU * o.radius;
                    let (na, nh) = (cells(circumference, d).max(3), cells(o.height, d));
                    let area = circumference * o.height / (na * nh) as f64;
                    for i in 0..na {
                        for j in 0..nh {
                            let a = TAU * (i as f64 + rng.gen::<f64>()) / na as f64;
                            let h = o.height * (j as f64 + rng.gen::<f64>()) / nh as f64;
                            let phase = rng.gen::<f64>() * TAU;
                            prepared
                                .scatterers
                                .push(pole_sample(o.base, o.radius, a, h, area, phase));
                        }
                    }
                    let (na, nh) = (
                        cells(circumference, spacing).max(3),
                        cells(o.height, spacing),
                    );
                    for i in 0..na {
                        for j in 0..nh {
                            let a = TAU * (i as f64 + 0.5) / na as f64;
                            let h = o.height * (j as f64 + 0.5) / nh as f64;
                            prepared
                                .truth
                                .push(pole_sample(o.base, o.radius, a, h, 0.0, 0.0));
                        }
                    }
                }
            }
            prepared
        })
        .collect()
}

fn pole_sample(base: [f64; 3], radius: f64, a: f64, h: f64, area: f64, phase: f64) -> Sample {
    let (s, c) = a.sin_cos();
    Sample {
        p: [base[0] + radius * c, base[1] + radius * s, base[2] + h],
        n: [c, s, 0.0],
        area,
        phase,
    }
}

/// Samples the edges and corners of one object ([`SurfaceModel`]); does nothing for the
/// parts the model leaves at 0.
struct FeatureSampler {
    edge_rcs_m2_per_m: f64,
    corner_rcs_m2: f64,
    rng: StdRng,
}

impl FeatureSampler {
    fn new(model: &SurfaceModel, seed: u64) -> Self {
        Self {
            edge_rcs_m2_per_m: model.edge_rcs_m2_per_m,
            corner_rcs_m2: model.corner_rcs_m2,
            rng: StdRng::seed_from_u64(seed),
        }
    }

    /// Line scatterers on the segment `a`–`b`, one per cell of side ≤ 1/√density (the
    /// surface's own spacing), each standing for its cell's length.
    fn edge(
        &mut self,
        a: [f64; 3],
        b: [f64; 3],
        density: f64,
        faces: &[[f64; 3]],
        out: &mut Vec<Feature>,
    ) {
        if self.edge_rcs_m2_per_m <= 0.0 {
            return;
        }
        let d = sub(b, a);
        let n = cells(norm(d), 1.0 / density.sqrt());
        let sigma = self.edge_rcs_m2_per_m * norm(d) / n as f64;
        for i in 0..n {
            let s = (i as f64 + self.rng.gen::<f64>()) / n as f64;
            out.push(Feature {
                p: add(a, d.map(|x| x * s)),
                faces: faces.to_vec(),
                sigma,
                phase: self.rng.gen::<f64>() * TAU,
            });
        }
    }

    /// A point scatterer at vertex `p`.
    fn corner(&mut self, p: [f64; 3], faces: &[[f64; 3]], out: &mut Vec<Feature>) {
        if self.corner_rcs_m2 <= 0.0 {
            return;
        }
        out.push(Feature {
            p,
            faces: faces.to_vec(),
            sigma: self.corner_rcs_m2,
            phase: self.rng.gen::<f64>() * TAU,
        });
    }
}

/// Cells of size at most `d` covering `length`, at least one.
fn cells(length: f64, d: f64) -> usize {
    ((length / d).ceil() as usize).max(1)
}

/// A flat rectangular face with its outward normal.
struct Face {
    origin: [f64; 3],
    u: [f64; 3],
    v: [f64; 3],
    n: [f64; 3],
}

impl Face {
    /// Jittered-grid scatterers: one uniform random point per cell of side ≤ 1/√density.
    fn sample(&self, density: f64, rng: &mut StdRng, out: &mut Vec<Sample>) {
        let d = 1.0 / density.sqrt();
        let (nu, nv) = (cells(norm(self.u), d), cells(norm(self.v), d));
        let area = norm(self.u) * norm(self.v) / (nu * nv) as f64;
        for i in 0..nu {
            for j in 0..nv {
                let s = (i as f64 + rng.gen::<f64>()) / nu as f64;
                let t = (j as f64 + rng.gen::<f64>()) / nv as f64;
                let phase = rng.gen::<f64>() * TAU;
                out.push(Sample {
                    p: std::array::from_fn(|k| self.origin[k] + s * self.u[k] + t * self.v[k]),
                    n: self.n,
                    area,
                    phase,
                });
            }
        }
    }

    /// Ground-truth points at the centres of a regular grid of cells of side ≤ `spacing`.
    fn grid(&self, spacing: f64, out: &mut Vec<Sample>) {
        let (nu, nv) = (cells(norm(self.u), spacing), cells(norm(self.v), spacing));
        for i in 0..nu {
            for j in 0..nv {
                let s = (i as f64 + 0.5) / nu as f64;
                let t = (j as f64 + 0.5) / nv as f64;
                out.push(Sample {
                    p: std::array::from_fn(|k| self.origin[k] + s * self.u[k] + t * self.v[k]),
                    n: self.n,
                    area: 0.0,
                    phase: 0.0,
                });
            }
        }
    }
}

/// Distance before a line-of-sight endpoint within which nothing counts as blocking, m.
const OCCLUSION_MARGIN_M: f64 = 1e-3;

/// The scene-wide scattering law of [`SurfaceModel`], ready for [`View::place`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scattering {
    diffuse: f64,
    specular: f64,
    /// `1 / (2 w²)` of the specular lobe, rad⁻².
    lobe: f64,
    /// Mirror plane height (m) and ghost amplitude factor `Γ²`.
    ghost: Option<(f64, f64)>,
}

impl Scattering {
    pub(crate) fn of(scene: &Scene) -> Self {
        let m = &scene.surfaces;
        let w = m.specular_width_deg.to_radians();
        Self {
            diffuse: m.diffuse,
            specular: m.specular,
            lobe: 0.5 / (w * w),
            ghost: m
                .multipath
                .as_ref()
                .zip(scene.floor_z_m())
                .map(|(mp, z)| (z, mp.reflection * mp.reflection)),
        }
    }

    /// `σ⁰(θ) / reflectivity` at incidence cosine `c` for the `cos^p` exponent `p`.
    fn law(&self, c: f64, p: f64) -> f64 {
        let diffuse = self.diffuse * c.powf(p);
        if self.specular == 0.0 {
            return diffuse;
        }
        let theta = c.min(1.0).acos();
        diffuse + self.specular * (-self.lobe * theta * theta).exp()
    }
}

/// What a scatterer returns: a cross section (amplitude `radar_constant · √σ / R²`) or a fixed
/// amplitude.
#[derive(Clone, Copy, Debug)]
enum Strength {
    Rcs(f64),
    Amplitude(f64),
}

/// The world seen from one sensor pose at one instant.
pub(crate) struct View<'a> {
    /// The radar's kinematic state.
    pub pose: Pose,
    pub time_s: f64,
    min_range: f64,
    max_range: f64,
    sin_az: f64,
    sin_el: f64,
    occlusion: bool,
    scattering: Scattering,
    radar_constant: f64,
    objects: &'a [Prepared],
}

impl<'a> View<'a> {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        pose: Pose,
        time_s: f64,
        fov: &FieldOfView,
        max_range: f64,
        occlusion: bool,
        scattering: Scattering,
        radar_constant: f64,
        objects: &'a [Prepared],
    ) -> Self {
        Self {
            pose,
            time_s,
            min_range: fov.min_range_m,
            max_range,
            sin_az: fov.azimuth_deg.to_radians().sin(),
            sin_el: fov.elevation_deg.to_radians().sin(),
            occlusion,
            scattering,
            radar_constant,
            objects,
        }
    }

    /// World point → radar frame.
    pub(crate) fn to_radar(&self, w: [f64; 3]) -> [f64; 3] {
        self.pose.to_body(Vector3::from(w)).into()
    }

    /// World velocity `v` of a point at radar-frame position `p` → its velocity and
    /// acceleration relative to the radar, in the radar frame ([`Pose::relative_velocity`],
    /// [`Pose::relative_acceleration`]).
    pub(crate) fn relative_motion(&self, v: [f64; 3], p: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let (v, p) = (Vector3::from(v), Vector3::from(p));
        (
            self.pose.relative_velocity(v, p).into(),
            self.pose.relative_acceleration(v, p).into(),
        )
    }

    /// Whether radar-frame point `p` is inside the field of view.
    pub(crate) fn in_fov(&self, p: [f64; 3]) -> bool {
        let r = norm(p);
        if !(r >= self.min_range && r <= self.max_range) || p[0] <= 0.0 {
            return false;
        }
        let (mu, nu) = (-p[1] / r, p[2] / r);
        nu.abs() <= self.sin_el && mu.abs() <= self.sin_az * (1.0 - nu * nu).sqrt()
    }

    /// Whether any surface other than object `skip` blocks the line from the sensor to the
    /// world point `w`.
    pub(crate) fn occluded(&self, w: [f64; 3], skip: usize) -> bool {
        if !self.occlusion {
            return false;
        }
        let s: [f64; 3] = self.pose.position.into();
        let d = sub(w, s);
        let len = norm(d);
        if len <= OCCLUSION_MARGIN_M {
            return false;
        }
        let t_max = 1.0 - OCCLUSION_MARGIN_M / len;
        self.objects.iter().enumerate().any(|(id, o)| {
            id != skip && {
                let off = o.velocity.map(|v| v * self.time_s);
                blocks(&o.shape, off, s, d, t_max)
            }
        })
    }

    /// Cosine of the incidence angle at a surface sample now at world position `w`, or
    /// `None` when the sample faces away.
    fn incidence(&self, w: [f64; 3], n: [f64; 3], two_sided: bool) -> Option<f64> {
        let to_radar = sub(self.pose.position.into(), w);
        let c = dot(n, to_radar) / norm(to_radar);
        let c = if two_sided { c.abs() } else { c };
        (c > 0.0).then_some(c)
    }

    /// Emit the scatterer at world position `w`, radar-frame position `p` (already known to be
    /// seen) moving with world velocity `v`, and its floor ghost when the scene has one;
    /// returns the ghosts emitted.
    fn emit(
        &self,
        w: [f64; 3],
        p: [f64; 3],
        v: [f64; 3],
        strength: Strength,
        phase: f64,
        out: &mut Vec<Scatterer>,
    ) -> usize {
        let amplitude = |p: [f64; 3]| match strength {
            Strength::Rcs(sigma) => self.radar_constant * sigma.sqrt() / dot(p, p),
            Strength::Amplitude(a) => a,
        };
        let mut push = |p: [f64; 3], v: [f64; 3], gain: f64| {
            let (velocity, acceleration) = self.relative_motion(v, p);
            out.push(Scatterer {
                position: p,
                velocity,
                acceleration,
                amplitude: gain * amplitude(p),
                phase,
            });
        };
        push(p, v, 1.0);
        let Some((z, gain)) = self.scattering.ghost else {
            return 0;
        };
        if !(w[2] > z && self.pose.position.z > z && gain > 0.0) {
            return 0;
        }
        let image = self.to_radar([w[0], w[1], 2.0 * z - w[2]]);
        if !self.in_fov(image) {
            return 0;
        }
        push(image, [v[0], v[1], -v[2]], gain);
        1
    }

    /// Scatterers (with their ghosts) and ground truth of object `id`.
    pub(crate) fn place(&self, id: usize, out: &mut Vec<Scatterer>) -> ObjectTruth {
        let o = &self.objects[id];
        let off = o.velocity.map(|v| v * self.time_s);
        let center_w = add(o.center, off);
        let center = self.to_radar(center_w);
        let (velocity, _) = self.relative_motion(o.velocity, center);
        let before = out.len();
        let mut ghosts = 0;
        let mut surface_points = Vec::new();
        let visible;
        if let Some(point) = o.point {
            visible = self.in_fov(center) && !self.occluded(center_w, id);
            if visible {
                let strength = match point.amplitude {
                    Some(a) => Strength::Amplitude(a),
                    None => Strength::Rcs(point.rcs_m2.unwrap_or(0.0)),
                };
                ghosts += self.emit(center_w, center, o.velocity, strength, point.phase, out);
            }
        } else {
            let params = o.surface.unwrap_or(SurfaceParams {
                reflectivity: 0.0,
                density: 1.0,
                incidence_exponent: 0.0,
            });
            for s in &o.scatterers {
                let w = add(s.p, off);
                let p = self.to_radar(w);
                if !self.in_fov(p) {
                    continue;
                }
                let Some(c) = self.incidence(w, s.n, o.two_sided) else {
                    continue;
                };
                if self.occluded(w, id) {
                    continue;
                }
                let sigma = params.reflectivity
                    * s.area
                    * self.scattering.law(c, params.incidence_exponent);
                ghosts += self.emit(w, p, o.velocity, Strength::Rcs(sigma), s.phase, out);
            }
            for f in &o.features {
                let w = add(f.p, off);
                let faces = f.faces.is_empty()
                    || f.faces
                        .iter()
                        .any(|&n| self.incidence(w, n, false).is_some());
                let p = self.to_radar(w);
                if faces && self.in_fov(p) && !self.occluded(w, id) {
                    ghosts += self.emit(w, p, o.velocity, Strength::Rcs(f.sigma), f.phase, out);
                }
            }
            for s in &o.truth {
                let w = add(s.p, off);
                let p = self.to_radar(w);
                if self.in_fov(p)
                    && self.incidence(w, s.n, o.two_sided).is_some()
                    && !self.occluded(w, id)
                {
                    surface_points.push(p.map(|v| (v * 1000.0).round() / 1000.0));
                }
            }
            visible = !surface_points.is_empty();
        }
        let l = look(center, velocity);
        ObjectTruth {
            id,
            name: o.name.clone(),
            kind: o.kind,
            position: center,
            velocity,
            range_m: l.range_m,
            mu: l.mu,
            nu: l.nu,
            azimuth_deg: l.azimuth_deg,
            elevation_deg: l.elevation_deg,
            radial_velocity_mps: l.radial_velocity_mps,
            visible,
            scatterers: out.len() - before - ghosts,
            ghosts,
            surface_points,
        }
    }
}

/// Whether `shape`, shifted by `off`, meets the segment `s + t·d`, `0 < t < t_max`.
fn blocks(shape: &Shape, off: [f64; 3], s: [f64; 3], d: [f64; 3], t_max: f64) -> bool {
    const T_MIN: f64 = 1e-9;
    match *shape {
        Shape::Point => false,
        Shape::Rect { origin, u, v, n } => {
            let denom = dot(n, d);
            if denom.abs() < 1e-12 {
                return false;
            }
            let o = add(origin, off);
            let t = dot(n, sub(o, s)) / denom;
            if !(t > T_MIN && t < t_max) {
                return false;
            }
            let x = sub(add(s, d.map(|x| x * t)), o);
            let a = dot(x, u) / dot(u, u);
            let b = dot(x, v) / dot(v, v);
            (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)
        }
        Shape::Box {
            center,
            half,
            cos,
            sin,
        } => {
            let q = sub(s, add(center, off));
            let local = |x: [f64; 3]| [cos * x[0] + sin * x[1], -sin * x[0] + cos * x[1], x[2]];
            let (q, e) = (local(q), local(d));
            let (mut lo, mut hi) = (T_MIN, t_max);
            for i in 0..3 {
                if e[i].abs() < 1e-15 {
                    if q[i].abs() > half[i] {
                        return false;
                    }
                } else {
                    let t1 = (-half[i] - q[i]) / e[i];
                    let t2 = (half[i] - q[i]) / e[i];
                    lo = lo.max(t1.min(t2));
                    hi = hi.min(t1.max(t2));
                }
            }
            lo < hi
        }
        Shape::Cylinder {
            base,
            radius,
            height,
        } => {
            let q = sub(s, add(base, off));
            let (mut lo, mut hi) = (T_MIN, t_max);
            // Height slab.
            if d[2].abs() < 1e-15 {
                if q[2] < 0.0 || q[2] > height {
                    return false;
                }
            } else {
                let t1 = -q[2] / d[2];
                let t2 = (height - q[2]) / d[2];
                lo = lo.max(t1.min(t2));
                hi = hi.min(t1.max(t2));
            }
            // Inside the circle: a·t² + b·t + c ≤ 0.
            let a = d[0] * d[0] + d[1] * d[1];
            let b = 2.0 * (q[0] * d[0] + q[1] * d[1]);
            let c = q[0] * q[0] + q[1] * q[1] - radius * radius;
            if a < 1e-15 {
                if c > 0.0 {
                    return false;
                }
            } else {
                let disc = b * b - 4.0 * a * c;
                if disc <= 0.0 {
                    return false;
                }
                let root = disc.sqrt();
                lo = lo.max((-b - root) / (2.0 * a));
                hi = hi.min((-b + root) / (2.0 * a));
            }
            lo < hi
        }
    }
}

pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = norm(a);
    a.map(|x| x / l)
}
