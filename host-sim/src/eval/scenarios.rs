//! The simulated experiments: synthetic point targets with exact truth, noise-only frames and
//! the scene files, each frame run through a list of chain variants.
//!
//! Every random choice (target placement, phases, noise) follows from the configuration's seed
//! and the trial's indices, so a run is reproducible whatever the thread count.

use std::f64::consts::TAU;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use dbe_radar::presets::coloradar as p;
use dbe_radar::Waveform;

use super::bench::{Bench, Buffers, ChainOutput};
use super::chamfer::{chamfer_with_tree, voxel_downsample, KdTree, P3};
use super::crb::{angle_variances, SnapshotModel, Source, Unknown};
use super::snr::{db_to_linear, SnrModel};
use super::EvalError;
use crate::cloud::PointRecord;
use crate::sensor::SensorConfig;
use crate::sim::truth::look;
use crate::sim::{try_render_frame, ObjectKind, Scatterer, Scene, Simulation, SurfaceModel};

/// A point within this distance (m) of a point target detects it; a point farther than this
/// from every truth point (target or surface sample) is a false point ([`crate::score`]).
pub use crate::score::MATCH_RADIUS_M;
/// Range tolerance of the resolution test, range bins.
pub const RESOLUTION_RANGE_BINS: f64 = 2.0;

/// Constants of the ColoRadar preset the experiments need.
#[derive(Clone, Debug)]
pub struct Context {
    /// The simulated sensor.
    pub sensor: SensorConfig,
    /// SNR definition and ADC noise.
    pub snr: SnrModel,
    /// The full 12-element snapshot model (CRB).
    pub array: SnapshotModel,
    /// The 8-element azimuth line (CRB).
    pub line: SnapshotModel,
    /// Metres per range bin.
    pub range_bin_m: f64,
    /// m/s per unit of Doppler phase per loop: `λ/(4π·T_loop)`.
    pub mps_per_omega: f64,
    /// Mean chirp start time of a frame, s: truth is placed there.
    pub t_mid_s: f64,
}

impl Context {
    /// The ColoRadar preset with ADC noise `noise_std` (LSB per I and Q).
    pub fn coloradar(noise_std: f64) -> Result<Self, EvalError> {
        let w = Waveform::COLORADAR;
        let array = SnapshotModel::coloradar()?;
        let t_loop = w.loop_period_s(p::TX);
        let sensor = SensorConfig::coloradar();
        let t_mid_s = crate::score::mid_frame_s(&sensor);
        Ok(Self {
            sensor,
            snr: SnrModel::coloradar(noise_std),
            line: array.first(p::AZIMUTH),
            array,
            range_bin_m: w.range_bin_m(p::SAMPLES),
            mps_per_omega: w.wavelength_m(p::SAMPLES) / (4.0 * std::f64::consts::PI * t_loop),
            t_mid_s,
        })
    }
}

/// A synthetic point target moving radially (its direction is constant during the frame).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Target {
    /// Range at the frame's mean chirp time, m.
    pub range_m: f64,
    /// Azimuth φ, degrees (positive to the right, −y).
    pub azimuth_deg: f64,
    /// Elevation θ, degrees.
    pub elevation_deg: f64,
    /// Radial velocity, m/s, positive receding.
    pub radial_velocity_mps: f64,
    /// ADC amplitude, LSB.
    pub amplitude: f64,
    /// Phase φ0, rad.
    pub phase: f64,
}

impl Target {
    /// Unit direction `u` (spec §2: μ = −u_y = cos θ·sin φ, ν = u_z = sin θ).
    pub fn direction(&self) -> P3 {
        let (phi, theta) = (
            self.azimuth_deg.to_radians(),
            self.elevation_deg.to_radians(),
        );
        [
            theta.cos() * phi.cos(),
            -theta.cos() * phi.sin(),
            theta.sin(),
        ]
    }

    /// Position at the mean chirp time, m.
    pub fn position(&self) -> P3 {
        self.direction().map(|u| u * self.range_m)
    }

    /// The scatterer at the frame start, placed so that it is at [`Self::position`] at
    /// `t_mid_s`.
    pub fn scatterer(&self, t_mid_s: f64) -> Scatterer {
        let u = self.direction();
        let r0 = self.range_m - self.radial_velocity_mps * t_mid_s;
        Scatterer {
            position: u.map(|x| x * r0),
            velocity: u.map(|x| x * self.radial_velocity_mps),
            acceleration: [0.0; 3],
            amplitude: self.amplitude,
            phase: self.phase,
        }
    }
}

/// Errors of one estimate against the truth.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Errors {
    /// Azimuth error, degrees.
    pub azimuth_deg: f64,
    /// Elevation error, degrees.
    pub elevation_deg: f64,
    /// Radial-velocity error, m/s.
    pub doppler_mps: f64,
    /// Range error, m.
    pub range_m: f64,
}

/// Range, azimuth φ and elevation θ (degrees) of a point.
pub fn point_angles(pt: &PointRecord) -> (f64, f64, f64) {
    let r = (pt.x * pt.x + pt.y * pt.y + pt.z * pt.z).sqrt();
    if r <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let (mu, nu) = (-pt.y / r, pt.z / r);
    let c = (1.0 - nu * nu).max(0.0).sqrt();
    let phi = if c > 0.0 {
        (mu / c).clamp(-1.0, 1.0).asin()
    } else {
        0.0
    };
    (r, phi.to_degrees(), nu.clamp(-1.0, 1.0).asin().to_degrees())
}

pub use crate::score::matched_point;

/// Errors of `pt` against a truth at `range_m`, `azimuth_deg`, `elevation_deg`, moving
/// radially at `radial_mps`.
pub fn errors_of(
    pt: &PointRecord,
    range_m: f64,
    azimuth_deg: f64,
    elevation_deg: f64,
    radial_mps: f64,
) -> Errors {
    let (r, az, el) = point_angles(pt);
    Errors {
        azimuth_deg: az - azimuth_deg,
        elevation_deg: el - elevation_deg,
        doppler_mps: pt.doppler - radial_mps,
        range_m: r - range_m,
    }
}

/// SplitMix64 of a seed and a stream: independent seeds per trial.
pub fn mix(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Seed of trial `(tag, a, b)` under `seed`.
pub fn trial_seed(seed: u64, tag: u64, a: u64, b: u64) -> u64 {
    mix(mix(mix(seed, tag), a), b)
}

/// Run `f` over `jobs` in parallel with per-thread [`Buffers`], keeping the input order; the
/// first error wins.
pub(super) fn par_run<J, T, F>(jobs: &[J], f: F) -> Result<Vec<T>, EvalError>
where
    J: Sync,
    T: Send,
    F: Fn(&J, &mut Buffers) -> Result<T, EvalError> + Sync,
{
    jobs.par_iter()
        .map_init(Buffers::new, |buf, job| f(job, buf))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Single target
// ---------------------------------------------------------------------------------------------

/// One single-target trial.
#[derive(Clone, Debug)]
pub struct SingleTrial {
    /// Snapshot SNR, dB.
    pub snr_db: f64,
    /// The target.
    pub target: Target,
    /// Cramér–Rao bounds (variances) of azimuth and elevation (rad²) and radial velocity
    /// ((m/s)²) for this target.
    pub crb: [f64; 3],
    /// Per variant (indexed like the bench's variants).
    pub outcomes: Vec<Outcome>,
}

/// What one variant made of one target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// The variant did not run on this frame.
    NotRun,
    /// No point within [`MATCH_RADIUS_M`] of the target.
    Missed,
    /// The errors of the matched point.
    Hit(Errors),
}

impl Outcome {
    /// The errors, when the target was detected.
    pub fn errors(&self) -> Option<&Errors> {
        match self {
            Outcome::Hit(e) => Some(e),
            _ => None,
        }
    }
}

/// The single-target trial `(snr_db, seed)`: range on a bin centre in bins 16..=100,
/// azimuth uniform in ±40°, elevation in ±15°, radial velocity in ±1 m/s, random phase.
pub fn single_target(ctx: &Context, snr_db: f64, seed: u64) -> Target {
    let mut rng = StdRng::seed_from_u64(seed);
    let bin = rng.gen_range(16..=100) as f64;
    Target {
        range_m: bin * ctx.range_bin_m,
        azimuth_deg: rng.gen_range(-40.0..40.0),
        elevation_deg: rng.gen_range(-15.0..15.0),
        radial_velocity_mps: rng.gen_range(-1.0..1.0),
        amplitude: ctx.snr.amplitude(snr_db),
        phase: rng.gen_range(0.0..TAU),
    }
}

/// The bounds `[var φ, var θ, var v]` for target `t` at snapshot SNR `snr_db`: azimuth from
/// the 8-element line, elevation and Doppler from the 12-element array, every other
/// parameter unknown, TDM offsets included ([`super::crb`]).
pub fn target_crb(ctx: &Context, t: &Target, snr_db: f64) -> Result<[f64; 3], EvalError> {
    let u = t.direction();
    let (mu, nu) = (-u[1], u[2]);
    let noise = ctx.snr.snapshot_noise_power();
    let amp = (db_to_linear(snr_db) * noise).sqrt();
    let omega = t.radial_velocity_mps / ctx.mps_per_omega;
    let src = Source {
        mu,
        nu,
        omega,
        amplitude: num_complex::Complex64::from_polar(amp, t.phase),
    };
    use Unknown::*;
    let line = ctx
        .line
        .crb(&src, &[Mu, Omega, AmplitudeRe, AmplitudeIm], noise)?;
    let full = ctx
        .array
        .crb(&src, &[Mu, Nu, Omega, AmplitudeRe, AmplitudeIm], noise)?;
    let (var_phi, var_theta) = angle_variances(mu, nu, line[0], full[1]);
    Ok([
        var_phi,
        var_theta,
        full[2] * ctx.mps_per_omega * ctx.mps_per_omega,
    ])
}

/// What the single-target sweep runs: `trials` per SNR; variants `which` everywhere plus
/// `extra` at the SNRs in `extra_snr_db`.
#[derive(Clone, Copy, Debug)]
pub struct SinglePlan<'a> {
    /// SNRs, dB.
    pub snr_db: &'a [f64],
    /// Trials per SNR.
    pub trials: usize,
    /// Variants run on every trial.
    pub which: &'a [usize],
    /// Variants run at the SNRs in `extra_snr_db` only.
    pub extra: &'a [usize],
    /// SNRs at which `extra` runs, dB.
    pub extra_snr_db: &'a [f64],
}

/// Run the single-target trials of `plan`.
pub fn run_single(
    ctx: &Context,
    bench: &Bench,
    seed: u64,
    plan: &SinglePlan<'_>,
) -> Result<Vec<SingleTrial>, EvalError> {
    let SinglePlan {
        snr_db,
        trials,
        which,
        extra,
        extra_snr_db,
    } = *plan;
    let jobs: Vec<(usize, usize)> = (0..snr_db.len())
        .flat_map(|s| (0..trials).map(move |t| (s, t)))
        .collect();
    par_run(&jobs, |&(s, i), buf| {
        let snr = snr_db[s];
        let target = single_target(ctx, snr, trial_seed(seed, 1, s as u64, i as u64));
        let mut rng = StdRng::seed_from_u64(trial_seed(seed, 2, s as u64, i as u64));
        let frame = try_render_frame(
            &ctx.sensor,
            &[target.scatterer(ctx.t_mid_s)],
            ctx.snr.noise_std,
            &mut rng,
        )?;
        let mut run: Vec<usize> = which.to_vec();
        if extra_snr_db.iter().any(|&e| (e - snr).abs() < 1e-9) {
            run.extend_from_slice(extra);
        }
        let outs = bench.run(&frame, &run, buf)?;
        let mut outcomes = vec![Outcome::NotRun; bench.variants().len()];
        let pos = target.position();
        for (&v, out) in run.iter().zip(&outs) {
            if let Some(out) = out {
                outcomes[v] = match matched_point(&out.points, &pos) {
                    Some(pt) => Outcome::Hit(errors_of(
                        pt,
                        target.range_m,
                        target.azimuth_deg,
                        target.elevation_deg,
                        target.radial_velocity_mps,
                    )),
                    None => Outcome::Missed,
                };
            }
        }
        Ok(SingleTrial {
            snr_db: snr,
            crb: target_crb(ctx, &target, snr)?,
            target,
            outcomes,
        })
    })
}

// ---------------------------------------------------------------------------------------------
// Two targets
// ---------------------------------------------------------------------------------------------

/// Whether the two targets of a resolution trial are coherent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pair {
    /// Both static: the same Doppler, a fixed phase difference over the frame.
    Coherent,
    /// Radial velocities 0.25 … 1 m/s apart (6 … 26 Doppler bins).
    NonCoherent,
}

impl Pair {
    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Pair::Coherent => "coherent",
            Pair::NonCoherent => "non-coherent",
        }
    }
}

/// Two equal targets `separation_deg` apart in azimuth at one range (a bin centre in bins
/// 24..=90), centred at a random azimuth in ±25°, a common elevation in ±10°, random phases.
pub fn two_targets(
    ctx: &Context,
    separation_deg: f64,
    pair: Pair,
    snr_db: f64,
    seed: u64,
) -> [Target; 2] {
    let mut rng = StdRng::seed_from_u64(seed);
    let bin = rng.gen_range(24..=90) as f64;
    let centre: f64 = rng.gen_range(-25.0..25.0);
    let el = rng.gen_range(-10.0..10.0);
    let (v1, v2) = match pair {
        Pair::Coherent => (0.0, 0.0),
        Pair::NonCoherent => {
            let v1: f64 = rng.gen_range(-1.0..1.0);
            let dv = rng.gen_range(0.25..1.0);
            (v1, if v1 > 0.0 { v1 - dv } else { v1 + dv })
        }
    };
    let amplitude = ctx.snr.amplitude(snr_db);
    let mut make = |az: f64, v: f64| Target {
        range_m: bin * ctx.range_bin_m,
        azimuth_deg: az,
        elevation_deg: el,
        radial_velocity_mps: v,
        amplitude,
        phase: rng.gen_range(0.0..TAU),
    };
    [
        make(centre - 0.5 * separation_deg, v1),
        make(centre + 0.5 * separation_deg, v2),
    ]
}

/// Whether `points` resolve `targets`: every point within [`RESOLUTION_RANGE_BINS`] of the
/// targets' range is assigned to the target nearer in azimuth, and each target needs a point
/// of its own closer than half the separation.
pub fn resolved(points: &[PointRecord], targets: &[Target; 2], range_bin_m: f64) -> bool {
    resolve(points, targets, range_bin_m).is_some()
}

/// [`resolved`], with the elevation errors (degrees) of each target's point nearest in
/// azimuth when resolved.
pub fn resolve(
    points: &[PointRecord],
    targets: &[Target; 2],
    range_bin_m: f64,
) -> Option<[f64; 2]> {
    let sep = (targets[1].azimuth_deg - targets[0].azimuth_deg).abs();
    let mut best: [Option<(f64, f64)>; 2] = [None, None];
    for pt in points {
        let (r, az, el) = point_angles(pt);
        if (r - targets[0].range_m).abs() > RESOLUTION_RANGE_BINS * range_bin_m {
            continue;
        }
        let d = [
            (az - targets[0].azimuth_deg).abs(),
            (az - targets[1].azimuth_deg).abs(),
        ];
        let i = usize::from(d[1] < d[0]);
        if d[i] < 0.5 * sep && best[i].is_none_or(|(bd, _)| d[i] < bd) {
            best[i] = Some((d[i], el - targets[i].elevation_deg));
        }
    }
    match best {
        [Some(a), Some(b)] => Some([a.1, b.1]),
        _ => None,
    }
}

/// One resolution trial.
#[derive(Clone, Debug)]
pub struct PairTrial {
    /// Separation, degrees.
    pub separation_deg: f64,
    /// Coherent or not.
    pub pair: Pair,
    /// Snapshot SNR of each target, dB.
    pub snr_db: f64,
    /// Per variant: `None` when not run, else `Some(None)` when not resolved and
    /// `Some(Some(elevation errors))` when resolved.
    pub resolved: Vec<Option<Option<[f64; 2]>>>,
}

/// A resolution case: separation, pair kind, SNR.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairCase {
    /// Separation, degrees.
    pub separation_deg: f64,
    /// Coherent or not.
    pub pair: Pair,
    /// Snapshot SNR of each target, dB.
    pub snr_db: f64,
    /// Whether the extra variants run on this case too.
    pub extra: bool,
}

/// Run `trials` resolution trials per case.
pub fn run_pairs(
    ctx: &Context,
    bench: &Bench,
    seed: u64,
    cases: &[PairCase],
    trials: usize,
    which: &[usize],
    extra: &[usize],
) -> Result<Vec<PairTrial>, EvalError> {
    let jobs: Vec<(usize, usize)> = (0..cases.len())
        .flat_map(|c| (0..trials).map(move |t| (c, t)))
        .collect();
    par_run(&jobs, |&(c, i), buf| {
        let case = cases[c];
        // The seed depends on the trial index and the pair kind only, so every separation
        // and SNR sees the same placements and phases (paired comparison).
        let kind = match case.pair {
            Pair::Coherent => 0,
            Pair::NonCoherent => 1,
        };
        let targets = two_targets(
            ctx,
            case.separation_deg,
            case.pair,
            case.snr_db,
            trial_seed(seed, 3, kind, i as u64),
        );
        let mut rng = StdRng::seed_from_u64(trial_seed(seed, 4, c as u64, i as u64));
        let scat = targets.map(|t| t.scatterer(ctx.t_mid_s));
        let frame = try_render_frame(&ctx.sensor, &scat, ctx.snr.noise_std, &mut rng)?;
        let mut run: Vec<usize> = which.to_vec();
        if case.extra {
            run.extend_from_slice(extra);
        }
        let outs = bench.run(&frame, &run, buf)?;
        let mut res = vec![None; bench.variants().len()];
        for (&v, out) in run.iter().zip(&outs) {
            if let Some(out) = out {
                res[v] = Some(resolve(&out.points, &targets, ctx.range_bin_m));
            }
        }
        Ok(PairTrial {
            separation_deg: case.separation_deg,
            pair: case.pair,
            snr_db: case.snr_db,
            resolved: res,
        })
    })
}

// ---------------------------------------------------------------------------------------------
// Noise only
// ---------------------------------------------------------------------------------------------

/// Points per variant (`None` when not run) of `frames` noise-only frames.
pub fn run_noise(
    ctx: &Context,
    bench: &Bench,
    seed: u64,
    frames: usize,
    which: &[usize],
) -> Result<Vec<Vec<Option<usize>>>, EvalError> {
    let jobs: Vec<usize> = (0..frames).collect();
    par_run(&jobs, |&i, buf| {
        let mut rng = StdRng::seed_from_u64(trial_seed(seed, 5, i as u64, 0));
        let frame = try_render_frame(&ctx.sensor, &[], ctx.snr.noise_std, &mut rng)?;
        let outs = bench.run(&frame, which, buf)?;
        let mut n = vec![None; bench.variants().len()];
        for (&v, out) in which.iter().zip(&outs) {
            n[v] = out.as_ref().map(|o: &ChainOutput| o.points.len());
        }
        Ok(n)
    })
}

// ---------------------------------------------------------------------------------------------
// Scenes
// ---------------------------------------------------------------------------------------------

/// A built-in scene file (embedded at compile time from `host-sim/scenes/`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFile {
    /// Scene name (the file stem, `_realistic` appended for [`Self::realistic`]).
    pub name: &'static str,
    /// TOML text.
    pub text: &'static str,
    /// Run with [`SurfaceModel::realistic`] (specular lobe, edges, corners, floor ghosts)
    /// when the file sets no `[surfaces]` of its own.
    pub realistic: bool,
}

impl SceneFile {
    /// The scene, with the realistic surfaces when asked for (validated again by
    /// [`Simulation::new`]).
    pub fn scene(&self) -> Result<Scene, EvalError> {
        let mut scene = Scene::from_toml_str(self.text, self.name)?;
        if self.realistic && scene.surfaces.is_default() {
            scene.surfaces = SurfaceModel::realistic();
        }
        Ok(scene)
    }

    /// The scene file this one is the realistic-surface twin of (itself when plain).
    pub fn base_name(&self) -> &'static str {
        self.name
            .strip_suffix(REALISTIC_SUFFIX)
            .unwrap_or(self.name)
    }
}

/// Suffix of the realistic-surface twin of an extended scene.
pub const REALISTIC_SUFFIX: &str = "_realistic";

/// A [`SceneFile`] (for constant tables).
pub const fn scene_file(name: &'static str, text: &'static str, realistic: bool) -> SceneFile {
    SceneFile {
        name,
        text,
        realistic,
    }
}

const CORRIDOR: &str = include_str!("../../scenes/corridor.toml");
const OUTDOOR: &str = include_str!("../../scenes/outdoor_poles_walls.toml");
const CLUTTERED: &str = include_str!("../../scenes/cluttered_room.toml");
const PARKING: &str = include_str!("../../scenes/parking_lot.toml");

/// The extended scenes of the Chamfer table (the paper's Table II layout), then the same four
/// with realistic surfaces (the first [`super::tables::EXTENDED_SCENES`] entries), then the
/// moving-sensor scene.
pub const SCENES: [SceneFile; 9] = [
    scene_file("corridor", CORRIDOR, false),
    scene_file("outdoor_poles_walls", OUTDOOR, false),
    scene_file("cluttered_room", CLUTTERED, false),
    scene_file("parking_lot", PARKING, false),
    scene_file("corridor_realistic", CORRIDOR, true),
    scene_file("outdoor_poles_walls_realistic", OUTDOOR, true),
    scene_file("cluttered_room_realistic", CLUTTERED, true),
    scene_file("parking_lot_realistic", PARKING, true),
    scene_file(
        "moving_sensor",
        include_str!("../../scenes/moving_sensor.toml"),
        false,
    ),
];

/// Metrics of one variant on one scene frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneFrameMetrics {
    /// Points.
    pub points: usize,
    /// Points farther than [`MATCH_RADIUS_M`] from every truth point.
    pub false_points: usize,
    /// Chamfer distance per resolution (`None` for an empty cloud), m.
    pub chamfer: Vec<Option<super::chamfer::Chamfer>>,
    /// Per visible point target (scene object name): errors of the matched point, if any.
    pub targets: Vec<(String, Option<Errors>)>,
    /// The points in the world frame (the sensor's true pose at the frame start), for the
    /// sequence maps of [`super::maps`].
    pub cloud_world: Vec<P3>,
}

/// One scene frame.
#[derive(Clone, Debug)]
pub struct SceneFrame {
    /// Scene name.
    pub scene: &'static str,
    /// Frame index.
    pub index: usize,
    /// Truth points (all visible surface samples and point targets).
    pub truth_points: usize,
    /// Those truth points in the world frame (as [`SceneFrameMetrics::cloud_world`]).
    pub truth_world: Vec<P3>,
    /// The scene object each truth point belongs to, an index into [`Self::objects`].
    pub truth_object: Vec<usize>,
    /// The frame's scene objects by name (the frame truth's order).
    pub objects: Vec<String>,
    /// Per variant, `None` when not run.
    pub metrics: Vec<Option<SceneFrameMetrics>>,
}

/// Frame indices `j · span / frames` for `j = 0..frames` (evenly over `span` frames).
pub fn frame_indices(frames: usize, span: usize) -> Vec<usize> {
    (0..frames).map(|j| j * span / frames.max(1)).collect()
}

/// Run `frames` frames (evenly over the first `span`) of each scene through `which`.
pub fn run_scenes(
    ctx: &Context,
    bench: &Bench,
    scenes: &[SceneFile],
    frames: usize,
    span: usize,
    resolutions: &[f64],
    which: &[usize],
) -> Result<Vec<SceneFrame>, EvalError> {
    let sims: Vec<(&'static str, Simulation)> = scenes
        .iter()
        .map(|s| Ok((s.name, Simulation::new(&s.scene()?, &ctx.sensor)?)))
        .collect::<Result<_, EvalError>>()?;
    let jobs: Vec<(usize, usize)> = (0..sims.len())
        .flat_map(|s| frame_indices(frames, span).into_iter().map(move |i| (s, i)))
        .collect();
    par_run(&jobs, |&(s, index), buf| {
        let (name, sim) = &sims[s];
        let frame = sim.frame(index)?;
        // Truth at the frame's mean chirp time (the estimates average over the frame): every
        // point of an object moves with the object's relative velocity at its centre.
        let t = ctx.t_mid_s;
        let mut truth: Vec<P3> = Vec::new();
        let mut truth_object = Vec::new();
        let mut point_targets = Vec::new();
        for (k, o) in frame.truth.objects.iter().enumerate() {
            if !o.visible {
                continue;
            }
            let shift = |q: &P3| std::array::from_fn(|i| q[i] + o.velocity[i] * t);
            if o.kind == ObjectKind::Point {
                let at: P3 = shift(&o.position);
                truth.push(at);
                point_targets.push((o.name.clone(), at, look(at, o.velocity)));
            } else {
                truth.extend(o.surface_points.iter().map(shift));
            }
            truth_object.resize(truth.len(), k);
        }
        let full_tree = KdTree::new(&truth);
        let to_world = world_transform(&frame.truth.sensor);
        let refs: Vec<(Vec<P3>, KdTree)> = resolutions
            .iter()
            .map(|&r| {
                let d = voxel_downsample(&truth, r);
                let t = KdTree::new(&d);
                (d, t)
            })
            .collect();
        let outs = bench.run(&frame.adc, which, buf)?;
        let mut metrics = vec![None; bench.variants().len()];
        for (&v, out) in which.iter().zip(&outs) {
            let Some(out) = out else { continue };
            let cloud: Vec<P3> = out.points.iter().map(|pt| [pt.x, pt.y, pt.z]).collect();
            let false_points = cloud
                .iter()
                .filter(|q| {
                    full_tree
                        .nearest_distance(q)
                        .is_none_or(|d| d > MATCH_RADIUS_M)
                })
                .count();
            let chamfer = resolutions
                .iter()
                .zip(&refs)
                .map(|(&r, (d, t))| chamfer_with_tree(&voxel_downsample(&cloud, r), d, t))
                .collect();
            let targets = point_targets
                .iter()
                .map(|(name, at, l)| {
                    let e = matched_point(&out.points, at).map(|pt| {
                        errors_of(
                            pt,
                            l.range_m,
                            l.azimuth_deg,
                            l.elevation_deg,
                            l.radial_velocity_mps,
                        )
                    });
                    (name.clone(), e)
                })
                .collect();
            metrics[v] = Some(SceneFrameMetrics {
                points: cloud.len(),
                false_points,
                chamfer,
                targets,
                cloud_world: cloud.iter().map(&to_world).collect(),
            });
        }
        Ok(SceneFrame {
            scene: name,
            index,
            truth_points: truth.len(),
            truth_world: truth.iter().map(&to_world).collect(),
            truth_object,
            objects: frame.truth.objects.iter().map(|o| o.name.clone()).collect(),
            metrics,
        })
    })
}

/// The map `p ↦ R·p + t` from the sensor frame into the world frame for a sensor `pose`
/// (`orientation` = body → world quaternion `[qx, qy, qz, qw]`).
pub fn world_transform(pose: &crate::sim::SensorPose) -> impl Fn(&P3) -> P3 {
    let [qx, qy, qz, qw] = pose.orientation;
    let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(qw, qx, qy, qz));
    let t = nalgebra::Vector3::from(pose.position);
    move |p: &P3| {
        let w = q * nalgebra::Vector3::from(*p) + t;
        [w.x, w.y, w.z]
    }
}
