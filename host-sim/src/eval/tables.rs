//! Aggregation: the raw trials into the report's tables ([`Evaluation`]). The goals, the
//! headline and the defaults recommendation are judged from these tables in [`super::goals`];
//! rendering is [`super::report`].

use std::time::Instant;

use serde::Serialize;

use super::bench::Bench;
use super::crb::{direction_cosine_crb, omega_crb, Source, Unknown};
use super::scenarios::{Context, Pair, PairTrial, SceneFile, SceneFrame, SingleTrial, SCENES};
use super::snr::db_to_linear;
use super::{names, sweep_name, EvalConfig, EvalError, SweepValue};

/// Azimuth grid step of the DBE and FFT chains, degrees (188 bins over ±70°).
pub const AZIMUTH_STEP_DEG: f64 = dbe_radar::presets::coloradar::AZIMUTH_STEP_DEG;
/// Elevation grid step of the DBE chain, degrees (101 bins over ±25°).
pub const ELEVATION_STEP_DEG: f64 = dbe_radar::presets::coloradar::ELEVATION_STEP_DEG;
/// Number of extended scenes in the Chamfer goal (the first entries of [`SCENES`]): four
/// scenes, plain and with realistic surfaces.
pub const EXTENDED_SCENES: usize = 8;

/// Accuracy of one variant at one SNR.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AccuracyRow {
    /// Snapshot SNR, dB.
    pub snr_db: f64,
    /// The same as per-ADC-sample SNR, dB.
    pub adc_snr_db: f64,
    /// Variant.
    pub variant: String,
    /// Trials run.
    pub trials: usize,
    /// Trials with a point within 0.6 m.
    pub detected: usize,
    /// `detected / trials`.
    pub detection_rate: f64,
    /// Azimuth RMSE over detected trials, degrees.
    pub az_rmse_deg: Option<f64>,
    /// Elevation RMSE, degrees.
    pub el_rmse_deg: Option<f64>,
    /// Radial-velocity RMSE, m/s.
    pub doppler_rmse_mps: Option<f64>,
    /// Mean azimuth error, degrees.
    pub az_bias_deg: Option<f64>,
    /// Mean elevation error, degrees.
    pub el_bias_deg: Option<f64>,
    /// Mean radial-velocity error, m/s.
    pub doppler_bias_mps: Option<f64>,
    /// Least-squares slope of the radial-velocity error against the true radial velocity
    /// (a velocity scale error), dimensionless.
    pub doppler_scale: Option<f64>,
    /// Root-mean CRB of azimuth over all trials at this SNR, degrees.
    pub crb_az_deg: f64,
    /// Root-mean CRB of elevation, degrees.
    pub crb_el_deg: f64,
    /// Root-mean CRB of radial velocity, m/s.
    pub crb_doppler_mps: f64,
}

/// Resolution probability of one variant in one case.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResolutionRow {
    /// Pair kind.
    pub pair: Pair,
    /// Separation, degrees.
    pub separation_deg: f64,
    /// SNR of each target, dB.
    pub snr_db: f64,
    /// Variant.
    pub variant: String,
    /// Trials.
    pub trials: usize,
    /// Trials resolved.
    pub resolved: usize,
    /// `resolved / trials`.
    pub probability: f64,
    /// Elevation RMSE of the two points of resolved trials, degrees.
    pub el_rmse_deg: Option<f64>,
}

/// Noise-only points of one variant.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoiseRow {
    /// Variant.
    pub variant: String,
    /// Frames.
    pub frames: usize,
    /// Mean points per frame (all false).
    pub false_points_per_frame: f64,
    /// Frames with at least one point.
    pub frames_with_points: usize,
}

/// Chamfer distance of one variant on one scene at one resolution.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChamferRow {
    /// Scene.
    pub scene: String,
    /// Voxel resolution, m.
    pub resolution_m: f64,
    /// Variant.
    pub variant: String,
    /// Frames averaged (frames with an empty cloud are left out and counted below).
    pub frames: usize,
    /// Frames whose cloud was empty.
    pub empty_frames: usize,
    /// Mean Chamfer distance, m.
    pub chamfer_m: Option<f64>,
    /// Mean accuracy term (cloud → truth), m.
    pub accuracy_m: Option<f64>,
    /// Mean completeness term (truth → cloud), m.
    pub completeness_m: Option<f64>,
}

/// Detection and accuracy of one variant on one scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneRow {
    /// Scene.
    pub scene: String,
    /// Variant.
    pub variant: String,
    /// Frames.
    pub frames: usize,
    /// Mean truth points per frame.
    pub truth_points_per_frame: f64,
    /// Mean points per frame.
    pub points_per_frame: f64,
    /// Mean false points per frame.
    pub false_points_per_frame: f64,
    /// Visible point targets over all frames.
    pub targets: usize,
    /// Of which detected.
    pub detected: usize,
    /// `detected / targets` (`None` without targets).
    pub detection_rate: Option<f64>,
    /// Azimuth RMSE of detected point targets, degrees.
    pub az_rmse_deg: Option<f64>,
    /// Elevation RMSE, degrees.
    pub el_rmse_deg: Option<f64>,
    /// Radial-velocity RMSE, m/s.
    pub doppler_rmse_mps: Option<f64>,
}

/// The closed-form CRB against the exact inverse of the Fisher information (with TDM
/// offsets and unknown Doppler), at one source.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrbCheck {
    /// Source used (μ, ν, ω) and SNR (dB).
    pub at: (f64, f64, f64, f64),
    /// Relative difference of var μ (8-element line).
    pub mu: f64,
    /// Relative difference of var ν (12 elements).
    pub nu: f64,
    /// Relative difference of var ω (12 elements).
    pub omega: f64,
}

/// One row of the defaults sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DefaultsRow {
    /// Parameter name.
    pub parameter: String,
    /// Value.
    pub value: String,
    /// Whether this is the core's default.
    pub is_default: bool,
    /// Variant name.
    pub variant: String,
    /// Detection rate of one target at each sweep SNR.
    pub detection_rate: Vec<Option<f64>>,
    /// Azimuth RMSE at each sweep SNR, degrees.
    pub az_rmse_deg: Vec<Option<f64>>,
    /// Elevation RMSE at each sweep SNR, degrees.
    pub el_rmse_deg: Vec<Option<f64>>,
    /// Resolution probability per sweep separation, non-coherent pair.
    pub resolve_non_coherent: Vec<Option<f64>>,
    /// Resolution probability per sweep separation, coherent pair.
    pub resolve_coherent: Vec<Option<f64>>,
    /// False points per noise-only frame.
    pub noise_false_points: Option<f64>,
    /// False points per scene frame (all scenes).
    pub scene_false_points: Option<f64>,
    /// Point-target detection rate over all scenes.
    pub scene_detection_rate: Option<f64>,
    /// Mean points per frame on the extended scenes.
    pub scene_points: Option<f64>,
    /// Mean Chamfer distance at the sweep's resolution over the extended-scene frames where
    /// both this variant and the default have points, m.
    pub chamfer_m: Option<f64>,
    /// The default's mean over the same frames, m.
    pub chamfer_default_m: Option<f64>,
    /// Frames in that paired mean.
    pub chamfer_frames: usize,
}

/// A goal of the issue and whether the evaluation meets it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Goal {
    /// The goal.
    pub goal: String,
    /// Met or not.
    pub met: bool,
    /// The numbers, and why when missed.
    pub detail: String,
}

/// One headline Chamfer entry: both chains' defaults on one scene at one resolution.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChamferHeadline {
    /// Scene.
    pub scene: String,
    /// Voxel resolution, m.
    pub resolution: f64,
    /// DBE chain, m.
    pub dbe: Option<f64>,
    /// FFT chain, m.
    pub fft: Option<f64>,
    /// DBE chain on the grid (no sub-grid refinement), m.
    pub dbe_grid: Option<f64>,
    /// FFT chain on the grid, m.
    pub fft_grid: Option<f64>,
}

/// Everything the report shows.
#[derive(Clone, Debug, Serialize)]
pub struct Evaluation {
    /// The configuration.
    pub config: EvalConfig,
    /// Variant names, in bench order.
    pub variants: Vec<String>,
    /// Headline Chamfer table (`summary.json`'s `chamfer`).
    pub chamfer: Vec<ChamferHeadline>,
    /// Single-target accuracy.
    pub accuracy: Vec<AccuracyRow>,
    /// Resolution.
    pub resolution: Vec<ResolutionRow>,
    /// Noise-only frames.
    pub noise: Vec<NoiseRow>,
    /// Chamfer distance, all variants.
    pub chamfer_all: Vec<ChamferRow>,
    /// The paper's Chamfer protocol on each scene's accumulated map ([`super::maps`]).
    pub chamfer_paper: Vec<super::maps::PaperChamferRow>,
    /// The symmetric mean Chamfer distance on the same maps.
    pub chamfer_map: Vec<super::maps::MapChamferRow>,
    /// Sizes of those maps and the ICP correction.
    pub map_sizes: Vec<super::maps::MapSize>,
    /// Per scene object: the maps' points on it and its part of their completeness.
    pub map_objects: Vec<super::maps::ObjectCoverage>,
    /// The extended scenes with plain and realistic surfaces side by side
    /// ([`super::surfaces`]).
    pub surfaces: Vec<super::surfaces::SurfaceRow>,
    /// Which chain comparisons hold on which scenes with each surface model.
    pub surface_conclusions: Vec<super::surfaces::Conclusion>,
    /// Scenes: detection, false points, point-target accuracy.
    pub scenes: Vec<SceneRow>,
    /// CRB: closed form vs exact.
    pub crb_check: CrbCheck,
    /// Defaults sweep.
    pub defaults: Vec<DefaultsRow>,
    /// Resolution of the sweep's Chamfer column, m.
    pub defaults_resolution_m: f64,
    /// Recommendation per swept parameter.
    pub recommendations: Vec<(String, String)>,
    /// Radar-inertial odometry, one row per sequence, seed and chain.
    pub odometry: Vec<super::odometry::OdometryRow>,
    /// Odometry per sequence and chain over the seeds (the paper's Table III layout).
    pub odometry_summary: Vec<super::odometry::OdometrySummary>,
    /// Goals.
    pub goals: Vec<Goal>,
    /// The headline numbers (detection thresholds, RMSEs at 20 dB, resolution at 8°, mean
    /// Chamfer distances, moving-sensor elevation), gathered for `summary.json`.
    pub headline: serde_json::Value,
    /// Wall time per stage, s.
    pub timings: Vec<(String, f64)>,
    /// Total wall time, s.
    pub wall_time_s: f64,
    /// Rayon threads used.
    pub threads: usize,
}

fn rms<I: IntoIterator<Item = f64>>(it: I) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for v in it {
        s += v * v;
        n += 1;
    }
    (n > 0).then(|| (s / n as f64).sqrt())
}

pub(super) fn mean<I: IntoIterator<Item = f64>>(it: I) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for v in it {
        s += v;
        n += 1;
    }
    (n > 0).then(|| s / n as f64)
}

pub(super) fn same(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

impl Evaluation {
    /// Aggregate the raw trials.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        config: &EvalConfig,
        ctx: &Context,
        bench: &Bench,
        sweep: &[SweepValue],
        single: &[SingleTrial],
        pairs: &[PairTrial],
        noise: &[Vec<Option<usize>>],
        scenes: &[SceneFrame],
        odometry: Vec<super::odometry::OdometryRow>,
        timings: Vec<(String, f64)>,
        start: Instant,
    ) -> Result<Self, EvalError> {
        let variants: Vec<String> = bench.variants().iter().map(|v| v.name.clone()).collect();
        let accuracy = accuracy_rows(config, ctx, &variants, single);
        let resolution = resolution_rows(&variants, pairs);
        let noise = noise_rows(&variants, noise);
        let chamfer_all = chamfer_rows(config, &variants, scenes);
        let index = |name: &str| {
            bench
                .index(name)
                .ok_or_else(|| EvalError::Setup(format!("variant {name} missing")))
        };
        let (chamfer_paper, chamfer_map, map_sizes) = super::maps::map_rows(
            scenes,
            index(names::DBE)?,
            index(names::FFT)?,
            &config.resolutions_m,
        );
        let map_objects = super::maps::object_rows(scenes, index(names::DBE)?, index(names::FFT)?);
        let scene_rows = scene_rows(&variants, scenes);
        let chamfer = config
            .resolutions_m
            .iter()
            .flat_map(|&r| SCENES[..EXTENDED_SCENES].iter().map(move |s| (s.name, r)))
            .map(|(scene, r)| {
                let get = |v: &str| {
                    chamfer_all
                        .iter()
                        .find(|c| c.scene == scene && same(c.resolution_m, r) && c.variant == v)
                        .and_then(|c| c.chamfer_m)
                };
                ChamferHeadline {
                    scene: scene.to_string(),
                    resolution: r,
                    dbe: get(names::DBE),
                    fft: get(names::FFT),
                    dbe_grid: get(names::DBE_GRID),
                    fft_grid: get(names::FFT_GRID),
                }
            })
            .collect::<Vec<_>>();
        let crb_check = crb_check(ctx)?;
        let defaults_resolution_m = config
            .resolutions_m
            .iter()
            .copied()
            .find(|&r| same(r, 0.1))
            .unwrap_or(config.resolutions_m[0]);
        let defaults = sweep
            .iter()
            .map(|s| {
                defaults_row(
                    config,
                    s,
                    &variants,
                    &accuracy,
                    &resolution,
                    &noise,
                    &scene_rows,
                    scenes,
                    defaults_resolution_m,
                )
            })
            .collect::<Vec<_>>();
        let recommendations = super::goals::recommend(&defaults);
        let mut eval = Self {
            config: config.clone(),
            variants,
            chamfer,
            accuracy,
            resolution,
            noise,
            chamfer_all,
            chamfer_paper,
            chamfer_map,
            map_sizes,
            map_objects,
            surfaces: Vec::new(),
            surface_conclusions: Vec::new(),
            scenes: scene_rows,
            crb_check,
            defaults,
            defaults_resolution_m,
            recommendations,
            odometry_summary: super::odometry::summarise(&odometry, names::DBE, names::FFT),
            odometry,
            goals: Vec::new(),
            headline: serde_json::Value::Null,
            timings,
            wall_time_s: 0.0,
            threads: rayon::current_num_threads(),
        };
        eval.surfaces = super::surfaces::rows(&eval);
        eval.surface_conclusions = super::surfaces::conclusions(&eval.surfaces);
        eval.goals = super::goals::goals(&eval);
        eval.headline = super::goals::headline(&eval);
        eval.wall_time_s = start.elapsed().as_secs_f64();
        Ok(eval)
    }

    /// The accuracy row of `variant` at `snr_db`.
    pub fn accuracy_at(&self, variant: &str, snr_db: f64) -> Option<&AccuracyRow> {
        self.accuracy
            .iter()
            .find(|r| r.variant == variant && same(r.snr_db, snr_db))
    }

    /// The resolution row of `variant` for a case.
    pub fn resolution_at(
        &self,
        variant: &str,
        pair: Pair,
        separation_deg: f64,
        snr_db: f64,
    ) -> Option<&ResolutionRow> {
        self.resolution.iter().find(|r| {
            r.variant == variant
                && r.pair == pair
                && same(r.separation_deg, separation_deg)
                && same(r.snr_db, snr_db)
        })
    }

    /// The scene row of `variant` on `scene`.
    pub fn scene_at(&self, scene: &str, variant: &str) -> Option<&SceneRow> {
        self.scenes
            .iter()
            .find(|r| r.scene == scene && r.variant == variant)
    }

    /// Mean per-frame Chamfer distance of `variant` at the sweep's resolution over `scenes`
    /// (`None` unless every scene has one), m.
    pub fn mean_chamfer_over(&self, scenes: &[&SceneFile], variant: &str) -> Option<f64> {
        let cds: Option<Vec<f64>> = scenes
            .iter()
            .map(|s| {
                self.chamfer_at(s.name, self.defaults_resolution_m, variant)?
                    .chamfer_m
            })
            .collect();
        mean(cds?)
    }

    /// The CFAR α row of the defaults sweep (which holds the default) with the lowest
    /// [`Self::mean_chamfer_over`] `scenes`, and that mean.
    pub fn best_alpha_over(&self, scenes: &[&SceneFile]) -> Option<(&DefaultsRow, f64)> {
        self.defaults
            .iter()
            .filter(|r| r.parameter == super::SweepValue::CfarThreshold(0.0).parameter())
            .filter_map(|r| Some((r, self.mean_chamfer_over(scenes, &r.variant)?)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The Chamfer row of `variant` on `scene` at `resolution_m`.
    pub fn chamfer_at(&self, scene: &str, resolution_m: f64, variant: &str) -> Option<&ChamferRow> {
        self.chamfer_all.iter().find(|r| {
            r.scene == scene && same(r.resolution_m, resolution_m) && r.variant == variant
        })
    }
}

fn accuracy_rows(
    config: &EvalConfig,
    ctx: &Context,
    variants: &[String],
    single: &[SingleTrial],
) -> Vec<AccuracyRow> {
    let mut rows = Vec::new();
    for &snr in &config.snr_db {
        let trials: Vec<&SingleTrial> = single.iter().filter(|t| same(t.snr_db, snr)).collect();
        let crb = |i: usize| mean(trials.iter().map(|t| t.crb[i])).map_or(f64::NAN, f64::sqrt);
        let (crb_az, crb_el, crb_v) = (crb(0).to_degrees(), crb(1).to_degrees(), crb(2));
        for (v, name) in variants.iter().enumerate() {
            let ran: Vec<_> = trials
                .iter()
                .filter_map(|t| t.outcomes.get(v))
                .filter(|o| !matches!(o, super::scenarios::Outcome::NotRun))
                .collect();
            if ran.is_empty() {
                continue;
            }
            let hits: Vec<_> = ran.iter().filter_map(|o| o.errors()).collect();
            let pairs: Vec<(f64, f64)> = trials
                .iter()
                .filter_map(|t| {
                    Some((
                        t.target.radial_velocity_mps,
                        t.outcomes.get(v)?.errors()?.doppler_mps,
                    ))
                })
                .collect();
            let vv: f64 = pairs.iter().map(|p| p.0 * p.0).sum();
            let doppler_scale =
                (vv > 0.0).then(|| pairs.iter().map(|p| p.0 * p.1).sum::<f64>() / vv);
            rows.push(AccuracyRow {
                snr_db: snr,
                adc_snr_db: ctx.snr.adc_snr_db(snr),
                variant: name.clone(),
                trials: ran.len(),
                detected: hits.len(),
                detection_rate: hits.len() as f64 / ran.len() as f64,
                az_rmse_deg: rms(hits.iter().map(|e| e.azimuth_deg)),
                el_rmse_deg: rms(hits.iter().map(|e| e.elevation_deg)),
                doppler_rmse_mps: rms(hits.iter().map(|e| e.doppler_mps)),
                az_bias_deg: mean(hits.iter().map(|e| e.azimuth_deg)),
                el_bias_deg: mean(hits.iter().map(|e| e.elevation_deg)),
                doppler_bias_mps: mean(hits.iter().map(|e| e.doppler_mps)),
                doppler_scale,
                crb_az_deg: crb_az,
                crb_el_deg: crb_el,
                crb_doppler_mps: crb_v,
            });
        }
    }
    rows
}

fn resolution_rows(variants: &[String], pairs: &[PairTrial]) -> Vec<ResolutionRow> {
    let mut keys: Vec<(Pair, f64, f64)> = Vec::new();
    for t in pairs {
        if !keys
            .iter()
            .any(|k| k.0 == t.pair && same(k.1, t.separation_deg) && same(k.2, t.snr_db))
        {
            keys.push((t.pair, t.separation_deg, t.snr_db));
        }
    }
    let mut rows = Vec::new();
    for (pair, sep, snr) in keys {
        let trials: Vec<&PairTrial> = pairs
            .iter()
            .filter(|t| t.pair == pair && same(t.separation_deg, sep) && same(t.snr_db, snr))
            .collect();
        for (v, name) in variants.iter().enumerate() {
            let ran: Vec<Option<[f64; 2]>> = trials
                .iter()
                .filter_map(|t| t.resolved.get(v).copied().flatten())
                .collect();
            if ran.is_empty() {
                continue;
            }
            let resolved = ran.iter().filter(|r| r.is_some()).count();
            rows.push(ResolutionRow {
                pair,
                separation_deg: sep,
                snr_db: snr,
                variant: name.clone(),
                trials: ran.len(),
                resolved,
                probability: resolved as f64 / ran.len() as f64,
                el_rmse_deg: rms(ran.iter().flatten().flat_map(|e| e.iter().copied())),
            });
        }
    }
    rows
}

fn noise_rows(variants: &[String], noise: &[Vec<Option<usize>>]) -> Vec<NoiseRow> {
    variants
        .iter()
        .enumerate()
        .filter_map(|(v, name)| {
            let counts: Vec<usize> = noise
                .iter()
                .filter_map(|f| f.get(v).copied().flatten())
                .collect();
            (!counts.is_empty()).then(|| NoiseRow {
                variant: name.clone(),
                frames: counts.len(),
                false_points_per_frame: counts.iter().sum::<usize>() as f64 / counts.len() as f64,
                frames_with_points: counts.iter().filter(|&&c| c > 0).count(),
            })
        })
        .collect()
}

fn chamfer_rows(
    config: &EvalConfig,
    variants: &[String],
    scenes: &[SceneFrame],
) -> Vec<ChamferRow> {
    let mut rows = Vec::new();
    for s in &SCENES {
        let frames: Vec<&SceneFrame> = scenes.iter().filter(|f| f.scene == s.name).collect();
        for (ri, &r) in config.resolutions_m.iter().enumerate() {
            for (v, name) in variants.iter().enumerate() {
                let ms: Vec<_> = frames
                    .iter()
                    .filter_map(|f| f.metrics.get(v).and_then(|m| m.as_ref()))
                    .collect();
                if ms.is_empty() {
                    continue;
                }
                let cds: Vec<_> = ms
                    .iter()
                    .filter_map(|m| m.chamfer.get(ri).copied().flatten())
                    .collect();
                rows.push(ChamferRow {
                    scene: s.name.to_string(),
                    resolution_m: r,
                    variant: name.clone(),
                    frames: cds.len(),
                    empty_frames: ms.len() - cds.len(),
                    chamfer_m: mean(cds.iter().map(|c| c.distance)),
                    accuracy_m: mean(cds.iter().map(|c| c.accuracy)),
                    completeness_m: mean(cds.iter().map(|c| c.completeness)),
                });
            }
        }
    }
    rows
}

fn scene_rows(variants: &[String], scenes: &[SceneFrame]) -> Vec<SceneRow> {
    let mut rows = Vec::new();
    for s in &SCENES {
        let frames: Vec<&SceneFrame> = scenes.iter().filter(|f| f.scene == s.name).collect();
        for (v, name) in variants.iter().enumerate() {
            let ms: Vec<_> = frames
                .iter()
                .filter_map(|f| f.metrics.get(v).and_then(|m| m.as_ref()).map(|m| (f, m)))
                .collect();
            if ms.is_empty() {
                continue;
            }
            let n = ms.len() as f64;
            let targets: Vec<_> = ms.iter().flat_map(|(_, m)| m.targets.iter()).collect();
            let hits: Vec<_> = targets.iter().filter_map(|(_, e)| e.as_ref()).collect();
            rows.push(SceneRow {
                scene: s.name.to_string(),
                variant: name.clone(),
                frames: ms.len(),
                truth_points_per_frame: ms.iter().map(|(f, _)| f.truth_points as f64).sum::<f64>()
                    / n,
                points_per_frame: ms.iter().map(|(_, m)| m.points as f64).sum::<f64>() / n,
                false_points_per_frame: ms.iter().map(|(_, m)| m.false_points as f64).sum::<f64>()
                    / n,
                targets: targets.len(),
                detected: hits.len(),
                detection_rate: (!targets.is_empty())
                    .then(|| hits.len() as f64 / targets.len() as f64),
                az_rmse_deg: rms(hits.iter().map(|e| e.azimuth_deg)),
                el_rmse_deg: rms(hits.iter().map(|e| e.elevation_deg)),
                doppler_rmse_mps: rms(hits.iter().map(|e| e.doppler_mps)),
            });
        }
    }
    rows
}

/// Closed form (no TDM offsets) against the exact inverse (TDM offsets, unknown Doppler) at
/// μ = 0.3, ν = 0.15, v ≈ 0.8 m/s, 10 dB.
fn crb_check(ctx: &Context) -> Result<CrbCheck, EvalError> {
    let snr_db = 10.0;
    let noise = ctx.snr.snapshot_noise_power();
    let amp = (db_to_linear(snr_db) * noise).sqrt();
    let omega = 0.8 / ctx.mps_per_omega;
    let src = Source {
        mu: 0.3,
        nu: 0.15,
        omega,
        amplitude: num_complex::Complex64::from_polar(amp, 0.7),
    };
    use Unknown::*;
    let line = ctx
        .line
        .crb(&src, &[Mu, Omega, AmplitudeRe, AmplitudeIm], noise)?;
    let full = ctx
        .array
        .crb(&src, &[Mu, Nu, Omega, AmplitudeRe, AmplitudeIm], noise)?;
    let rho = db_to_linear(snr_db);
    let k = ctx.array.loops;
    let (mu_cf, _) = direction_cosine_crb(rho, k, &ctx.line.az, &ctx.line.el, ctx.line.kappa);
    let (_, nu_cf) = direction_cosine_crb(rho, k, &ctx.array.az, &ctx.array.el, ctx.array.kappa);
    let om_cf = omega_crb(rho, ctx.array.elements(), k);
    Ok(CrbCheck {
        at: (0.3, 0.15, omega, snr_db),
        mu: line[0] / mu_cf - 1.0,
        nu: full[1] / nu_cf - 1.0,
        omega: full[2] / om_cf - 1.0,
    })
}

#[allow(clippy::too_many_arguments)]
fn defaults_row(
    config: &EvalConfig,
    s: &SweepValue,
    variants: &[String],
    accuracy: &[AccuracyRow],
    resolution: &[ResolutionRow],
    noise: &[NoiseRow],
    scenes: &[SceneRow],
    frames: &[SceneFrame],
    chamfer_res: f64,
) -> DefaultsRow {
    let variant = sweep_name(s);
    let acc = |snr: f64| {
        accuracy
            .iter()
            .find(|r| r.variant == variant && same(r.snr_db, snr))
    };
    let res = |pair: Pair, sep: f64| {
        resolution
            .iter()
            .find(|r| {
                r.variant == variant
                    && r.pair == pair
                    && same(r.separation_deg, sep)
                    && same(r.snr_db, config.resolution_snr_db)
            })
            .map(|r| r.probability)
    };
    let sc: Vec<&SceneRow> = scenes.iter().filter(|r| r.variant == variant).collect();
    let (targets, detected) = sc
        .iter()
        .fold((0, 0), |(t, d), r| (t + r.targets, d + r.detected));
    let extended: Vec<&str> = SCENES[..EXTENDED_SCENES].iter().map(|s| s.name).collect();
    let me = variants.iter().position(|v| *v == variant);
    let def = variants.iter().position(|v| v == names::DBE);
    let ri = config
        .resolutions_m
        .iter()
        .position(|&r| same(r, chamfer_res));
    let mut paired = Vec::new();
    let mut points = Vec::new();
    if let (Some(me), Some(def), Some(ri)) = (me, def, ri) {
        for f in frames.iter().filter(|f| extended.contains(&f.scene)) {
            let get = |v: usize| f.metrics.get(v).and_then(|m| m.as_ref());
            if let Some(m) = get(me) {
                points.push(m.points as f64);
            }
            let cd = |v: usize| get(v).and_then(|m| m.chamfer.get(ri).copied().flatten());
            if let (Some(a), Some(b)) = (cd(me), cd(def)) {
                paired.push((a.distance, b.distance));
            }
        }
    }
    DefaultsRow {
        parameter: s.parameter().to_string(),
        value: s.value(),
        is_default: s.is_default(),
        detection_rate: config
            .sweep_snr_db
            .iter()
            .map(|&x| acc(x).map(|r| r.detection_rate))
            .collect(),
        az_rmse_deg: config
            .sweep_snr_db
            .iter()
            .map(|&x| acc(x).and_then(|r| r.az_rmse_deg))
            .collect(),
        el_rmse_deg: config
            .sweep_snr_db
            .iter()
            .map(|&x| acc(x).and_then(|r| r.el_rmse_deg))
            .collect(),
        resolve_non_coherent: config
            .sweep_separations_deg
            .iter()
            .map(|&x| res(Pair::NonCoherent, x))
            .collect(),
        resolve_coherent: config
            .sweep_separations_deg
            .iter()
            .map(|&x| res(Pair::Coherent, x))
            .collect(),
        noise_false_points: noise
            .iter()
            .find(|r| r.variant == variant)
            .map(|r| r.false_points_per_frame),
        scene_false_points: mean(sc.iter().map(|r| r.false_points_per_frame)),
        scene_detection_rate: (targets > 0).then(|| detected as f64 / targets as f64),
        scene_points: mean(points.iter().copied()),
        chamfer_m: mean(paired.iter().map(|p| p.0)),
        chamfer_default_m: mean(paired.iter().map(|p| p.1)),
        chamfer_frames: paired.len(),
        variant,
    }
}
