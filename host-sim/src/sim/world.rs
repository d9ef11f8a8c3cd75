//! Scene geometry: surfaces sampled into scatterers and ground-truth points, visibility
//! (field of view, facing, occlusion) and the world → radar transform of one frame.

use std::f64::consts::TAU;

use nalgebra::Vector3;
use rand::{rngs::StdRng, Rng, SeedableRng};

use super::render::{mix, Scatterer};
use super::scene::{norm, FieldOfView, Object, ObjectKind, Pose, Scene, SurfaceParams};
use super::truth::{look, ObjectTruth};

/// Stream of the surface-sampling generators (scatterer positions and phases).
const SURFACE_STREAM: u64 = 0x5355_5246;

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
            let mut prepared = Prepared {
                name: object.name(id),
                kind: object.kind(),
                velocity: object.velocity(),
                center: object.center(),
                point: None,
                surface: object.surface(),
                two_sided: false,
                scatterers: Vec::new(),
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
    objects: &'a [Prepared],
}

impl<'a> View<'a> {
    pub(crate) fn new(
        pose: Pose,
        time_s: f64,
        fov: &FieldOfView,
        max_range: f64,
        occlusion: bool,
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

    /// Scatterers and ground truth of object `id`; `radar_constant` scales RCS to LSB.
    pub(crate) fn place(
        &self,
        id: usize,
        radar_constant: f64,
        out: &mut Vec<Scatterer>,
    ) -> ObjectTruth {
        let o = &self.objects[id];
        let off = o.velocity.map(|v| v * self.time_s);
        let center_w = add(o.center, off);
        let center = self.to_radar(center_w);
        let (velocity, acceleration) = self.relative_motion(o.velocity, center);
        let before = out.len();
        let mut surface_points = Vec::new();
        let visible;
        if let Some(point) = o.point {
            visible = self.in_fov(center) && !self.occluded(center_w, id);
            if visible {
                let r2 = dot(center, center);
                out.push(Scatterer {
                    position: center,
                    velocity,
                    acceleration,
                    amplitude: point.amplitude.unwrap_or_else(|| {
                        radar_constant * point.rcs_m2.unwrap_or(0.0).sqrt() / r2
                    }),
                    phase: point.phase,
                });
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
                let sigma = params.reflectivity * s.area * c.powf(params.incidence_exponent);
                let (velocity, acceleration) = self.relative_motion(o.velocity, p);
                out.push(Scatterer {
                    position: p,
                    velocity,
                    acceleration,
                    amplitude: radar_constant * sigma.sqrt() / dot(p, p),
                    phase: s.phase,
                });
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
            scatterers: out.len() - before,
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
