//! Validation harness: the core (`f32`, `no_std`) against the reference (`f64`), frame by frame.
//!
//! [`compare`] checks one frame:
//!
//! 1. **Range–azimuth map**: every cell within [`Tolerances::ra_relative`] (relative to the
//!    larger of the two values); the worst cell of each failing row is reported.
//! 2. **Detections**, cell for cell, with the same power and level within `ra_relative`. A
//!    cell found by one side only is *excused* when it is borderline on the reference map:
//!    its power is within [`Tolerances::borderline_relative`] of the CFAR threshold, or a
//!    3×3 neighbour is within that margin of it (the local-maximum decision could flip), or a
//!    capacity overflow cut near its power.
//! 3. **Points**, matched per (range, azimuth, elevation bin): positions within
//!    [`Tolerances::position_relative`], the same Doppler bin, velocity within
//!    [`Tolerances::doppler_bins`], intensity and SNR within [`Tolerances::db`]. A point found by one side only, or with another Doppler bin,
//!    is excused when it stems from a detection that differs or that the reference resolved
//!    through a near-tie ([`RefDetection::decision_margin`] below `borderline_relative`:
//!    Doppler argmax, azimuth climb, elevation peak status, count or floor).
//! 4. **Statistics**: skipped range bins equal; detection overflow equal unless excused
//!    detections explain it.
//!
//! Excusals are listed in [`FrameAgreement::excused`] with their reason; anything else is a
//! [`Mismatch`] and the frame does not match.
//!
//! # Why 1e-3
//!
//! The core computes in `f32`: the range FFT and `R = X·Xᴴ/K` carry relative errors of
//! ~1e-6 of the row's energy, and the Capon inverse amplifies them by at most the loaded
//! covariance's condition number, `≤ D/γ` (800 for the 8-element azimuth line, 1200 for the
//! 12-element array with γ = 0.01): ≤ ~1e-4 in the worst case. Measured: the largest relative
//! RA-map difference is 6.0e-5 on a synthetic ColoRadar frame (4 targets, static and
//! ±1.5 m/s) and 3.9e-5 on the TI IWR6843 capture; point intensities differ by < 1e-4 dB and
//! positions by < 1e-7 relative (< 2e-6 with sub-grid refinement, whose log-parabola vertices
//! divide power errors by the peak curvature). A margin of 1e-3 (0.0043 dB) is ten times the worst-case
//! bound, yet a thousand times smaller than any real algorithmic difference (a wrong window,
//! loading or bin shifts powers by percent or more). The dB tolerance, 0.01 dB, is the same
//! margin on a ratio of two powers (SNR = power / level: 2 × 0.0043 dB, rounded up).
//!
//! # The quantised cube
//!
//! The core stores its cube as 16-bit block floating point (one power-of-two step per chirp,
//! `dbe_radar::cube`), and the reference under [`ReferenceOptions::CORE_CONTRACT`] quantises
//! the same way. The `f32` and `f64` range FFTs differ by ~1e-6 of a chirp's peak, i.e. a few
//! hundredths of a step, so a few percent of the mantissas round to neighbouring steps on the
//! two sides. Such a ±1-step difference is a perturbation below the quantisation noise
//! itself, whose power per element is `step²/6`; a cell's power can move by about that much.
//! RA cells, detection powers and levels are therefore compared to within
//! `ra_relative · max(core, ref) + step_max²/6`, with `step_max` the largest step of the
//! frame ([`ReferenceOutput::cube_step_max`], 0 for an exact cube). Measured: the largest
//! relative RA difference becomes 1.7e-3 on the TI capture (a reflector 97 dB above the
//! cube's step) — within that bound, while detections and points still match exactly.

use std::collections::HashMap;
use std::fmt;
use std::time::{Duration, Instant};

use dbe_radar::Params;

use crate::cloud::PointRecord;
use crate::core_run::{CoreOutput, CoreRunError, CoreRunner, Preset};
use crate::frame::AdcFrame;
use crate::reference::{
    self, cfar_cell, relative_gap, CfarLevel, RefDetection, ReferenceError, ReferenceOptions,
    ReferenceOutput,
};
use crate::sensor::SensorConfig;

/// Agreement tolerances (see the module docs for their derivation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// Largest relative difference of an RA-map cell, a detection's power or level.
    pub ra_relative: f64,
    /// A decision (threshold, local maximum, argmax, peak rule) whose compared values are
    /// closer than this, relatively, may go either way in `f32`.
    pub borderline_relative: f64,
    /// Largest `‖p_core − p_ref‖ / ‖p_ref‖` of a matched point.
    pub position_relative: f64,
    /// Largest difference of a matched point's intensity or SNR, dB.
    pub db: f64,
    /// Largest difference of a matched point's velocity, Doppler bins (only sub-grid
    /// refinement makes it differ from the bin's value).
    pub doppler_bins: f64,
}

impl Tolerances {
    /// 1e-3 relative, 0.01 dB, 1e-3 Doppler bins (module docs).
    pub const DEFAULT: Self = Self {
        ra_relative: 1e-3,
        borderline_relative: 1e-3,
        position_relative: 1e-3,
        db: 0.01,
        doppler_bins: 1e-3,
    };
}

impl Default for Tolerances {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A point's bins: the key points are matched by.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PointKey {
    /// Range bin.
    pub range_bin: u32,
    /// Azimuth grid bin.
    pub azimuth_bin: u32,
    /// Elevation grid bin.
    pub elevation_bin: u32,
}

impl PointKey {
    fn of(p: &PointRecord) -> Self {
        Self {
            range_bin: p.range_bin,
            azimuth_bin: p.azimuth_bin,
            elevation_bin: p.elevation_bin,
        }
    }
}

impl fmt::Display for PointKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "point (range {}, azimuth {}, elevation {})",
            self.range_bin, self.azimuth_bin, self.elevation_bin
        )
    }
}

/// One disagreement between core and reference.
#[derive(Clone, Debug, PartialEq)]
pub enum Mismatch {
    /// The RA maps have different shapes (`[range bins, azimuth bins]`).
    MapShape {
        /// Core shape.
        core: (usize, usize),
        /// Reference shape.
        reference: (usize, usize),
    },
    /// The worst RA cell of a row differs beyond the tolerance.
    RaCell {
        /// Range bin.
        range_bin: usize,
        /// Azimuth bin.
        azimuth_bin: usize,
        /// Core power.
        core: f64,
        /// Reference power.
        reference: f64,
    },
    /// A detection only the core has.
    DetectionOnlyInCore {
        /// Range bin.
        range_bin: usize,
        /// Azimuth bin.
        azimuth_bin: usize,
    },
    /// A detection only the reference has.
    DetectionOnlyInReference {
        /// Range bin.
        range_bin: usize,
        /// Azimuth bin.
        azimuth_bin: usize,
    },
    /// A matched detection's power or level differs.
    DetectionValue {
        /// Range bin.
        range_bin: usize,
        /// Azimuth bin.
        azimuth_bin: usize,
        /// `power` or `level`.
        field: &'static str,
        /// Core value.
        core: f64,
        /// Reference value.
        reference: f64,
    },
    /// A point only the core has.
    PointOnlyInCore(PointKey),
    /// A point only the reference has.
    PointOnlyInReference(PointKey),
    /// A matched point's position differs.
    PointPosition {
        /// The point.
        key: PointKey,
        /// Core `[x, y, z]`, m.
        core: [f64; 3],
        /// Reference `[x, y, z]`, m.
        reference: [f64; 3],
    },
    /// A matched point's Doppler bin differs.
    PointDoppler {
        /// The point.
        key: PointKey,
        /// Core signed bin.
        core: i32,
        /// Reference signed bin.
        reference: i32,
    },
    /// A matched point's velocity, intensity or SNR differs.
    PointValue {
        /// The point.
        key: PointKey,
        /// `doppler`, `intensity_db` or `snr_db`.
        field: &'static str,
        /// Core value.
        core: f64,
        /// Reference value.
        reference: f64,
    },
    /// A frame statistic differs.
    Stat {
        /// Which statistic.
        field: &'static str,
        /// Core value.
        core: usize,
        /// Reference value.
        reference: usize,
    },
}

impl fmt::Display for Mismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Mismatch::MapShape { core, reference } => write!(
                f,
                "RA map shape: core {}×{}, reference {}×{}",
                core.0, core.1, reference.0, reference.1
            ),
            Mismatch::RaCell {
                range_bin,
                azimuth_bin,
                core,
                reference,
            } => write!(
                f,
                "RA cell ({range_bin}, {azimuth_bin}): core {core:.6e}, reference {reference:.6e} (relative {:.2e})",
                relative_gap(*core, *reference)
            ),
            Mismatch::DetectionOnlyInCore {
                range_bin,
                azimuth_bin,
            } => write!(f, "detection ({range_bin}, {azimuth_bin}) only in the core"),
            Mismatch::DetectionOnlyInReference {
                range_bin,
                azimuth_bin,
            } => write!(
                f,
                "detection ({range_bin}, {azimuth_bin}) only in the reference"
            ),
            Mismatch::DetectionValue {
                range_bin,
                azimuth_bin,
                field,
                core,
                reference,
            } => write!(
                f,
                "detection ({range_bin}, {azimuth_bin}) {field}: core {core:.6e}, reference {reference:.6e}"
            ),
            Mismatch::PointOnlyInCore(k) => write!(f, "{k} only in the core"),
            Mismatch::PointOnlyInReference(k) => write!(f, "{k} only in the reference"),
            Mismatch::PointPosition {
                key,
                core,
                reference,
            } => write!(
                f,
                "{key} position: core {core:?} m, reference {reference:?} m"
            ),
            Mismatch::PointDoppler {
                key,
                core,
                reference,
            } => write!(
                f,
                "{key} Doppler bin: core {core}, reference {reference}"
            ),
            Mismatch::PointValue {
                key,
                field,
                core,
                reference,
            } => write!(f, "{key} {field}: core {core}, reference {reference}"),
            Mismatch::Stat {
                field,
                core,
                reference,
            } => write!(f, "{field}: core {core}, reference {reference}"),
        }
    }
}

/// Why a difference is tolerated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Borderline {
    /// The cell's power is within the margin of the CFAR threshold or of the window gate
    /// (`gap` relative).
    Threshold {
        /// `|P − α·level| / max(P, α·level)` (or the same gap to the gate) on the reference
        /// map.
        gap: f64,
    },
    /// A 3×3 neighbour is within the margin of the cell (the local maximum could move).
    LocalMaximum {
        /// The deciding relative gap on the reference map.
        gap: f64,
    },
    /// The detection list overflowed and the cell's power is at the cut.
    Capacity,
    /// The reference resolved the detection through a near-tie decision.
    Decision {
        /// [`RefDetection::decision_margin`].
        gap: f64,
    },
    /// The point stems from a detection that differs (reported on its own).
    FromDetection {
        /// Range bin of that detection.
        range_bin: usize,
        /// Azimuth bin of that detection.
        azimuth_bin: usize,
    },
}

impl fmt::Display for Borderline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Borderline::Threshold { gap } => write!(f, "power within {gap:.1e} of the threshold"),
            Borderline::LocalMaximum { gap } => {
                write!(f, "3×3 neighbour within {gap:.1e} (local-maximum tie)")
            }
            Borderline::Capacity => write!(f, "at the detection-capacity cut"),
            Borderline::Decision { gap } => write!(f, "near-tie decision ({gap:.1e})"),
            Borderline::FromDetection {
                range_bin,
                azimuth_bin,
            } => write!(f, "from differing detection ({range_bin}, {azimuth_bin})"),
        }
    }
}

/// A tolerated difference and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Excused {
    /// The difference.
    pub mismatch: Mismatch,
    /// Why it is tolerated.
    pub reason: Borderline,
}

/// The verdict on one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameAgreement {
    /// Largest relative difference of an RA-map cell (`|c − r| / max(|c|, |r|)`).
    pub ra_max_relative_error: f64,
    /// Detections of the core.
    pub detections_core: usize,
    /// Detections of the reference.
    pub detections_reference: usize,
    /// Detections found by both (same cell).
    pub detections_matched: usize,
    /// Points of the core.
    pub points_core: usize,
    /// Points of the reference.
    pub points_reference: usize,
    /// Points found by both (same bins; values checked).
    pub points_matched: usize,
    /// Detections that spec §3.2 read literally (no loading floor) would add on the
    /// reference map: the size of the spec/core CFAR discrepancy in this frame (0 when the
    /// reference already ran the spec's rule).
    pub spec_level_extra_detections: usize,
    /// Tolerated differences.
    pub excused: Vec<Excused>,
    /// Differences beyond the tolerances.
    pub mismatches: Vec<Mismatch>,
}

impl FrameAgreement {
    /// No mismatch (excused differences allowed).
    pub fn is_match(&self) -> bool {
        self.mismatches.is_empty()
    }
}

impl fmt::Display for FrameAgreement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: detections {}/{}/{} (core/ref/matched), points {}/{}/{}, RA max rel err {:.1e}, {} excused, {} mismatches",
            if self.is_match() { "match" } else { "MISMATCH" },
            self.detections_core,
            self.detections_reference,
            self.detections_matched,
            self.points_core,
            self.points_reference,
            self.points_matched,
            self.ra_max_relative_error,
            self.excused.len(),
            self.mismatches.len()
        )
    }
}

/// [`compare_with`] at [`Tolerances::DEFAULT`].
pub fn compare(core: &CoreOutput, reference: &ReferenceOutput, params: &Params) -> FrameAgreement {
    compare_with(core, reference, params, &Tolerances::DEFAULT)
}

/// Compare one frame's core output with the reference's (module docs). `params` are the
/// parameters both ran with.
pub fn compare_with(
    core: &CoreOutput,
    reference: &ReferenceOutput,
    params: &Params,
    tol: &Tolerances,
) -> FrameAgreement {
    let mut out = FrameAgreement {
        ra_max_relative_error: 0.0,
        detections_core: core.detections.len(),
        detections_reference: reference.detections.len(),
        detections_matched: 0,
        points_core: core.points.len(),
        points_reference: reference.points.len(),
        points_matched: 0,
        spec_level_extra_detections: 0,
        excused: Vec::new(),
        mismatches: Vec::new(),
    };
    compare_maps(core, reference, tol, &mut out);
    let differing = compare_detections(core, reference, params, tol, &mut out);
    compare_points(core, reference, params, tol, &differing, &mut out);
    compare_stats(core, reference, &differing, &mut out);
    if reference.options.cfar_level == CfarLevel::LoadingFloor {
        let cells: Vec<(usize, usize)> = reference
            .detections
            .iter()
            .map(|d| (d.range_bin, d.azimuth_bin))
            .collect();
        let (spec, _) = reference::detect(&reference.ra_map, None, params, usize::MAX);
        out.spec_level_extra_detections = spec
            .iter()
            .filter(|d| !cells.contains(&(d.range_bin, d.azimuth_bin)))
            .count();
    }
    out
}

/// `err ≤ limit`; a NaN error is never within.
fn within(err: f64, limit: f64) -> bool {
    err <= limit
}

fn shape<T>(map: &[Vec<T>]) -> (usize, usize) {
    (map.len(), map.first().map_or(0, Vec::len))
}

fn compare_maps(
    core: &CoreOutput,
    reference: &ReferenceOutput,
    tol: &Tolerances,
    out: &mut FrameAgreement,
) {
    let (cs, rs) = (shape(&core.ra_map), shape(&reference.ra_map));
    let ragged = core.ra_map.iter().any(|r| r.len() != cs.1)
        || reference.ra_map.iter().any(|r| r.len() != rs.1);
    if cs != rs || ragged {
        out.mismatches.push(Mismatch::MapShape {
            core: cs,
            reference: rs,
        });
        return;
    }
    let floor = reference.cube_step_max.powi(2) / 6.0;
    for (b, (crow, rrow)) in core.ra_map.iter().zip(&reference.ra_map).enumerate() {
        let mut worst: Option<(usize, f64, f64, f64)> = None;
        for (i, (&c, &r)) in crow.iter().zip(rrow).enumerate() {
            let c = f64::from(c);
            let e = relative_gap(c, r);
            let e = if e.is_nan() { f64::INFINITY } else { e };
            out.ra_max_relative_error = out.ra_max_relative_error.max(e);
            let within = (c - r).abs() <= tol.ra_relative * c.abs().max(r.abs()) + floor;
            if !within && worst.is_none_or(|w| e > w.3) {
                worst = Some((i, c, r, e));
            }
        }
        if let Some((i, c, r, _)) = worst {
            out.mismatches.push(Mismatch::RaCell {
                range_bin: b,
                azimuth_bin: i,
                core: c,
                reference: r,
            });
        }
    }
}

/// Why a detection cell present on one side only may legitimately differ, judged on the
/// reference map.
fn detection_borderline(
    reference: &ReferenceOutput,
    params: &Params,
    tol: &Tolerances,
    cut: Option<f64>,
    b: usize,
    i: usize,
) -> Option<Borderline> {
    let floor = match reference.options.cfar_level {
        CfarLevel::OrderStatistic => 0.0,
        CfarLevel::LoadingFloor => reference.loading_floor.get(b).copied().unwrap_or(0.0),
    };
    let power = reference.ra_map.get(b)?.get(i).copied()?;
    let test = cfar_cell(&reference.ra_map, params, b, i, floor);
    let gap = relative_gap(power, test.threshold);
    if test.threshold.is_finite() && gap < tol.borderline_relative {
        return Some(Borderline::Threshold { gap });
    }
    let gap = relative_gap(power, test.gate);
    if test.gate > 0.0 && gap < tol.borderline_relative {
        return Some(Borderline::Threshold { gap });
    }
    if test.local_max_margin < tol.borderline_relative {
        return Some(Borderline::LocalMaximum {
            gap: test.local_max_margin,
        });
    }
    if cut.is_some_and(|c| power <= c * (1.0 + tol.borderline_relative)) {
        return Some(Borderline::Capacity);
    }
    None
}

/// Returns the detection cells that differ (excused or not), for point attribution.
fn compare_detections(
    core: &CoreOutput,
    reference: &ReferenceOutput,
    params: &Params,
    tol: &Tolerances,
    out: &mut FrameAgreement,
) -> Vec<(usize, usize)> {
    let core_cells: HashMap<(usize, usize), (f64, f64)> = core
        .detections
        .iter()
        .map(|d| {
            (
                (usize::from(d.range_bin), usize::from(d.column)),
                (f64::from(d.power), f64::from(d.level)),
            )
        })
        .collect();
    let ref_cells: HashMap<(usize, usize), &RefDetection> = reference
        .detections
        .iter()
        .map(|d| ((d.range_bin, d.azimuth_bin), d))
        .collect();
    // With an overflow on either side, the weakest kept power is where the capacity cut is.
    let overflowed = core.stats.detection_overflow > 0 || reference.detection_overflow > 0;
    let cut = overflowed.then(|| {
        let c = core_cells
            .values()
            .map(|v| v.0)
            .fold(f64::INFINITY, f64::min);
        let r = ref_cells
            .values()
            .map(|d| d.power)
            .fold(f64::INFINITY, f64::min);
        c.max(r)
    });
    let mut differing = Vec::new();
    let mut cells: Vec<(usize, usize)> =
        core_cells.keys().chain(ref_cells.keys()).copied().collect();
    cells.sort_unstable();
    cells.dedup();
    for (b, i) in cells {
        let mismatch = match (core_cells.get(&(b, i)), ref_cells.get(&(b, i))) {
            (Some(&(cp, cl)), Some(r)) => {
                out.detections_matched += 1;
                let floor = reference.cube_step_max.powi(2) / 6.0;
                for (field, c, rv) in [("power", cp, r.power), ("level", cl, r.level)] {
                    if (c - rv).abs() > tol.ra_relative * c.abs().max(rv.abs()) + floor {
                        out.mismatches.push(Mismatch::DetectionValue {
                            range_bin: b,
                            azimuth_bin: i,
                            field,
                            core: c,
                            reference: rv,
                        });
                    }
                }
                continue;
            }
            (Some(_), None) => Mismatch::DetectionOnlyInCore {
                range_bin: b,
                azimuth_bin: i,
            },
            (None, Some(_)) => Mismatch::DetectionOnlyInReference {
                range_bin: b,
                azimuth_bin: i,
            },
            (None, None) => continue,
        };
        differing.push((b, i));
        match detection_borderline(reference, params, tol, cut, b, i) {
            Some(reason) => out.excused.push(Excused { mismatch, reason }),
            None => out.mismatches.push(mismatch),
        }
    }
    differing
}

fn compare_points(
    core: &CoreOutput,
    reference: &ReferenceOutput,
    params: &Params,
    tol: &Tolerances,
    differing: &[(usize, usize)],
    out: &mut FrameAgreement,
) {
    let reach = if params.tdm_compensation {
        usize::from(params.tdm_azimuth_search)
    } else {
        0
    };
    // Why a point of this key may legitimately differ: it stems from a differing detection or
    // from one the reference resolved through a near-tie.
    let borderline = |key: &PointKey| -> Option<Borderline> {
        let (b, i) = (key.range_bin as usize, key.azimuth_bin as usize);
        if let Some(&(db, di)) = differing
            .iter()
            .find(|&&(db, di)| db == b && di.abs_diff(i) <= reach)
        {
            return Some(Borderline::FromDetection {
                range_bin: db,
                azimuth_bin: di,
            });
        }
        reference
            .detections
            .iter()
            .filter(|d| d.range_bin == b && d.azimuth_bin.abs_diff(i) <= reach)
            .map(|d| d.decision_margin)
            .filter(|&g| g < tol.borderline_relative)
            .reduce(f64::min)
            .map(|gap| Borderline::Decision { gap })
    };
    let record =
        |mismatch: Mismatch, key: &PointKey, out: &mut FrameAgreement| match borderline(key) {
            Some(reason) => out.excused.push(Excused { mismatch, reason }),
            None => out.mismatches.push(mismatch),
        };

    let mut by_key: HashMap<PointKey, (Vec<&PointRecord>, Vec<&PointRecord>)> = HashMap::new();
    for p in &core.points {
        by_key.entry(PointKey::of(p)).or_default().0.push(p);
    }
    for p in &reference.points {
        by_key.entry(PointKey::of(p)).or_default().1.push(p);
    }
    let mut keys: Vec<PointKey> = by_key.keys().copied().collect();
    keys.sort_unstable();
    for key in keys {
        let Some((mut cs, mut rs)) = by_key.remove(&key) else {
            continue;
        };
        // Pair equal Doppler bins first (one key can hold points of two detections).
        let mut pairs = Vec::new();
        rs.retain(
            |r| match cs.iter().position(|c| c.doppler_bin == r.doppler_bin) {
                Some(j) => {
                    pairs.push((cs.remove(j), *r));
                    false
                }
                None => true,
            },
        );
        let n = cs.len().min(rs.len());
        let (rest_c, rest_r) = (cs.split_off(n), rs.split_off(n));
        pairs.extend(cs.into_iter().zip(rs));
        for _ in rest_c {
            record(Mismatch::PointOnlyInCore(key), &key, out);
        }
        for _ in rest_r {
            record(Mismatch::PointOnlyInReference(key), &key, out);
        }
        for (c, r) in pairs {
            out.points_matched += 1;
            if c.doppler_bin != r.doppler_bin {
                record(
                    Mismatch::PointDoppler {
                        key,
                        core: c.doppler_bin,
                        reference: r.doppler_bin,
                    },
                    &key,
                    out,
                );
                continue;
            }
            let (pc, pr) = ([c.x, c.y, c.z], [r.x, r.y, r.z]);
            let err = pc
                .iter()
                .zip(&pr)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            let norm = pr.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !within(err, tol.position_relative * norm) {
                out.mismatches.push(Mismatch::PointPosition {
                    key,
                    core: pc,
                    reference: pr,
                });
            }
            let checks = [
                (
                    "doppler",
                    c.doppler,
                    r.doppler,
                    tol.doppler_bins * reference.doppler_bin_mps,
                ),
                ("intensity_db", c.intensity_db, r.intensity_db, tol.db),
                ("snr_db", c.snr_db, r.snr_db, tol.db),
            ];
            for (field, cv, rv, limit) in checks {
                if !within((cv - rv).abs(), limit) {
                    out.mismatches.push(Mismatch::PointValue {
                        key,
                        field,
                        core: cv,
                        reference: rv,
                    });
                }
            }
        }
    }
}

fn compare_stats(
    core: &CoreOutput,
    reference: &ReferenceOutput,
    differing: &[(usize, usize)],
    out: &mut FrameAgreement,
) {
    let skipped = core.stats.skipped_range_bins as usize;
    if skipped != reference.skipped_range_bins {
        out.mismatches.push(Mismatch::Stat {
            field: "skipped range bins",
            core: skipped,
            reference: reference.skipped_range_bins,
        });
    }
    let overflow = core.stats.detection_overflow as usize;
    if overflow.abs_diff(reference.detection_overflow) > differing.len() {
        out.mismatches.push(Mismatch::Stat {
            field: "detection overflow",
            core: overflow,
            reference: reference.detection_overflow,
        });
    }
    if core.stats.point_overflow > 0 {
        out.mismatches.push(Mismatch::Stat {
            field: "point overflow (the reference has no point capacity)",
            core: core.stats.point_overflow as usize,
            reference: 0,
        });
    }
}

/// Why validation could not run.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// The core could not be set up or rejected a frame.
    #[error(transparent)]
    Core(#[from] CoreRunError),
    /// The reference rejected the configuration or a frame.
    #[error("reference: {0}")]
    Reference(#[from] ReferenceError),
    /// Reading frame `frame` failed.
    #[error("reading frame {frame}: {source}")]
    Input {
        /// Zero-based frame index.
        frame: usize,
        /// The reader's error.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// The agreement of one frame and what it cost.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    /// The verdict.
    pub agreement: FrameAgreement,
    /// Wall time of the core (chirp ingestion + processing).
    pub core_time: Duration,
    /// Wall time of the reference.
    pub reference_time: Duration,
}

/// Runs core and reference side by side on frames of one sensor.
#[derive(Debug)]
pub struct Validator {
    runner: CoreRunner,
    sensor: SensorConfig,
    params: Params,
    tolerances: Tolerances,
}

impl Validator {
    /// Set up the core for `sensor` (its preset, coupling when present) and `params`.
    pub fn new(sensor: &SensorConfig, params: Params) -> Result<Self, HarnessError> {
        Ok(Self {
            runner: CoreRunner::new(sensor, params)?,
            sensor: sensor.clone(),
            params,
            tolerances: Tolerances::DEFAULT,
        })
    }

    /// Use `tolerances` instead of [`Tolerances::DEFAULT`].
    pub fn with_tolerances(mut self, tolerances: Tolerances) -> Self {
        self.tolerances = tolerances;
        self
    }

    /// The core preset in use.
    pub fn preset(&self) -> Preset {
        self.runner.preset()
    }

    /// Run both on `frame` (the reference under [`ReferenceOptions::CORE_CONTRACT`]) and
    /// compare.
    pub fn check(&mut self, frame: &AdcFrame) -> Result<FrameReport, HarnessError> {
        let preset = self.runner.preset();
        let t0 = Instant::now();
        let core = self.runner.process(frame)?;
        let core_time = t0.elapsed();
        let t0 = Instant::now();
        let reference = reference::process_frame_with(
            frame,
            &self.sensor,
            &self.params,
            preset.azimuth_bins(),
            preset.elevation_bins(),
            preset.detection_capacity(),
            &ReferenceOptions::CORE_CONTRACT,
        )?;
        let reference_time = t0.elapsed();
        Ok(FrameReport {
            agreement: compare_with(&core, &reference, &self.params, &self.tolerances),
            core_time,
            reference_time,
        })
    }
}

/// Validate every frame of `frames` (as a reader yields them) for `sensor` and `params`.
/// Stops at the first frame that cannot be read or processed.
pub fn validate_frames<I, E>(
    frames: I,
    sensor: &SensorConfig,
    params: &Params,
) -> Result<Vec<FrameReport>, HarnessError>
where
    I: IntoIterator<Item = Result<AdcFrame, E>>,
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    let mut validator = Validator::new(sensor, *params)?;
    frames
        .into_iter()
        .enumerate()
        .map(|(index, frame)| {
            let frame = frame.map_err(|e| HarnessError::Input {
                frame: index,
                source: e.into(),
            })?;
            validator.check(&frame)
        })
        .collect()
}

/// A per-frame agreement table (one line per frame, then the mismatches and excusals of each
/// frame that has any, and a count of matching frames), frames numbered from 0.
pub fn format_table(reports: &[FrameReport]) -> String {
    let indexed: Vec<(usize, &FrameReport)> = reports.iter().enumerate().collect();
    table(&indexed)
}

/// [`format_table`] with each report's own frame index (e.g. for `--frames 100..200`).
pub fn format_indexed_table(reports: &[(usize, FrameReport)]) -> String {
    let indexed: Vec<(usize, &FrameReport)> = reports.iter().map(|(i, r)| (*i, r)).collect();
    table(&indexed)
}

fn table(reports: &[(usize, &FrameReport)]) -> String {
    use fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>6} {:>8} {:>13} {:>13} {:>10} {:>7} {:>7} {:>9} {:>9}",
        "frame",
        "verdict",
        "det c/r/m",
        "pts c/r/m",
        "RA relerr",
        "excused",
        "spec+",
        "core ms",
        "ref ms"
    );
    for &(i, r) in reports {
        let a = &r.agreement;
        let _ = writeln!(
            s,
            "{:>6} {:>8} {:>13} {:>13} {:>10.1e} {:>7} {:>7} {:>9.1} {:>9.1}",
            i,
            if a.is_match() { "match" } else { "MISMATCH" },
            format!(
                "{}/{}/{}",
                a.detections_core, a.detections_reference, a.detections_matched
            ),
            format!(
                "{}/{}/{}",
                a.points_core, a.points_reference, a.points_matched
            ),
            a.ra_max_relative_error,
            a.excused.len(),
            a.spec_level_extra_detections,
            r.core_time.as_secs_f64() * 1e3,
            r.reference_time.as_secs_f64() * 1e3,
        );
    }
    for &(i, r) in reports {
        for m in &r.agreement.mismatches {
            let _ = writeln!(s, "frame {i}: MISMATCH {m}");
        }
        for e in &r.agreement.excused {
            let _ = writeln!(s, "frame {i}: excused {} ({})", e.mismatch, e.reason);
        }
    }
    let matched = reports
        .iter()
        .filter(|(_, r)| r.agreement.is_match())
        .count();
    let _ = writeln!(s, "{matched} of {} frames match", reports.len());
    s
}
