//! `dbe eval` as a library: the Cramér–Rao bound against a numerical Fisher information, the
//! Chamfer distance's identities, and a `--quick`-sized evaluation checked for structure and
//! for physics that cannot hold by accident (bounds not beaten, grid floors, the DBE
//! detection threshold, TDM bias, coherent pairs in the FFT chain, the simulator's velocity
//! scale).

use std::sync::OnceLock;

use host_sim::eval::chamfer::{chamfer, voxel_downsample, P3};
use host_sim::eval::crb::{direction_cosine_crb, omega_crb, SnapshotModel, Source, Unknown};
use host_sim::eval::scenarios::{Pair, SCENES};
use host_sim::eval::tables::{AZIMUTH_STEP_DEG, EXTENDED_SCENES};
use host_sim::eval::{names, run_evaluation, write_report, EvalConfig, EvalError, Evaluation};
use num_complex::Complex64;

/// Relative difference.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// The bound from the inverse of the finite-difference Fisher information.
fn fd_crb(model: &SnapshotModel, s: &Source, unknowns: &[Unknown], noise: f64) -> Vec<f64> {
    let j = model.fisher_finite_difference(s, unknowns, noise, 1e-6);
    let inv = j
        .try_inverse()
        .expect("finite-difference Fisher information is invertible");
    inv.diagonal().iter().copied().collect()
}

#[test]
fn crb_closed_forms_match_the_finite_difference_fisher_information() -> Result<(), EvalError> {
    use Unknown::*;
    let full = SnapshotModel::coloradar()?;
    // Without TDM offsets the closed forms are exact.
    let mut flat = full.clone();
    flat.offset.iter_mut().for_each(|o| *o = 0.0);
    let line = flat.first(8);
    let noise = 2.5;
    for (mu, nu, omega, snr_db) in [
        (0.3, 0.15, 0.2, 10.0),
        (-0.6, -0.2, -1.1, 0.0),
        (0.0, 0.0, 0.0, 25.0),
    ] {
        let rho = 10f64.powf(snr_db / 10.0);
        let s = Source {
            mu,
            nu,
            omega,
            amplitude: Complex64::from_polar((rho * noise).sqrt(), 1.1),
        };
        let k = flat.loops;
        // The analytic Fisher information equals the finite-difference one.
        let unknowns = [Mu, Nu, Omega, AmplitudeRe, AmplitudeIm];
        let a = full.fisher(&s, &unknowns, noise);
        let d = full.fisher_finite_difference(&s, &unknowns, noise, 1e-6);
        for i in 0..5 {
            for j in 0..5 {
                let scale = (a[(i, i)] * a[(j, j)]).sqrt();
                assert!(
                    (a[(i, j)] - d[(i, j)]).abs() <= 1e-6 * scale,
                    "J[{i},{j}]: {} vs {}",
                    a[(i, j)],
                    d[(i, j)]
                );
            }
        }
        // Azimuth: 8-element line, CRB(μ) = 1/(84·ρ·K·κ²).
        let (var_mu, _) = direction_cosine_crb(rho, k, &line.az, &line.el, line.kappa);
        assert!(rel(var_mu, 1.0 / (84.0 * rho * k as f64 * line.kappa.powi(2))) < 1e-12);
        let fd = fd_crb(&line, &s, &[Mu, Omega, AmplitudeRe, AmplitudeIm], noise);
        assert!(rel(fd[0], var_mu) < 1e-6, "μ: {} vs {var_mu}", fd[0]);
        // Elevation: 12 elements, μ unknown too, CRB(ν) = 3/(16·ρ·K·κ²).
        let (_, var_nu) = direction_cosine_crb(rho, k, &flat.az, &flat.el, flat.kappa);
        assert!(rel(var_nu, 3.0 / (16.0 * rho * k as f64 * flat.kappa.powi(2))) < 1e-12);
        let fd = fd_crb(&flat, &s, &unknowns, noise);
        assert!(rel(fd[1], var_nu) < 1e-6, "ν: {} vs {var_nu}", fd[1]);
        // Doppler: CRB(ω) = 6/(ρ·M·K·(K² − 1)).
        let var_om = omega_crb(rho, 12, k);
        assert!(rel(fd[2], var_om) < 1e-6, "ω: {} vs {var_om}", fd[2]);
        // With the TDM offsets the exact bound moves by far less than 0.1 %.
        let exact = full.crb(&s, &unknowns, noise)?;
        assert!(
            rel(exact[1], var_nu) < 1e-3 && rel(exact[2], var_om) < 1e-3,
            "{exact:?}"
        );
        let exact = full
            .first(8)
            .crb(&s, &[Mu, Omega, AmplitudeRe, AmplitudeIm], noise)?;
        assert!(rel(exact[0], var_mu) < 1e-3, "{exact:?}");
    }
    // The line alone cannot see elevation: a singular information is a typed error.
    let s = Source {
        mu: 0.1,
        nu: 0.1,
        omega: 0.0,
        amplitude: Complex64::new(1.0, 0.0),
    };
    assert!(line_singular(&full.first(8), &s));
    Ok(())
}

fn line_singular(line: &SnapshotModel, s: &Source) -> bool {
    line.crb(
        s,
        &[
            Unknown::Mu,
            Unknown::Nu,
            Unknown::AmplitudeRe,
            Unknown::AmplitudeIm,
        ],
        1.0,
    )
    .is_err()
}

#[test]
fn chamfer_of_identical_clouds_is_zero_and_of_a_shifted_cloud_is_the_shift() {
    // A 5 × 5 × 3 grid of 1 m spacing.
    let mut cloud: Vec<P3> = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..3 {
                cloud.push([i as f64, j as f64 - 2.0, 0.5 * k as f64 + 0.25]);
            }
        }
    }
    let same = chamfer(&cloud, &cloud).expect("non-empty");
    assert_eq!(
        (same.distance, same.accuracy, same.completeness),
        (0.0, 0.0, 0.0)
    );
    for (d, dir) in [
        (0.1, [1.0, 0.0, 0.0]),
        (0.2, [0.6, -0.8, 0.0]),
        (0.05, [0.48, 0.6, 0.64]),
    ] {
        let shifted: Vec<P3> = cloud
            .iter()
            .map(|p| std::array::from_fn(|i| p[i] + d * dir[i]))
            .collect();
        let c = chamfer(&shifted, &cloud).expect("non-empty");
        assert!(
            (c.distance - d).abs() < 1e-12 && (c.accuracy - d).abs() < 1e-12,
            "{c:?}"
        );
    }
    // One-sided coverage: a single point of the grid against the whole grid.
    let c = chamfer(&cloud[..1], &cloud).expect("non-empty");
    assert_eq!(c.accuracy, 0.0);
    assert!(c.completeness > 1.0);
    assert!(chamfer(&[], &cloud).is_none());
    // Downsampling a cloud that is already coarser than the voxel changes nothing.
    assert_eq!(voxel_downsample(&cloud, 0.2).len(), cloud.len());
    // One voxel holding the whole (non-negative) cloud gives its centroid.
    let positive: Vec<P3> = cloud.iter().map(|p| [p[0], p[1] + 2.0, p[2]]).collect();
    let one = voxel_downsample(&positive, 10.0);
    assert_eq!(one.len(), 1);
    for (got, want) in one[0].iter().zip([2.0, 2.0, 0.75]) {
        assert!((got - want).abs() < 1e-12, "{:?}", one[0]);
    }
}

#[test]
fn an_empty_configuration_is_a_typed_error() {
    let mut c = EvalConfig::quick();
    c.snr_db.clear();
    assert!(matches!(
        run_evaluation(&c, &|_| {}),
        Err(EvalError::Setup(_))
    ));
    let mut c = EvalConfig::quick();
    c.resolutions_m = vec![0.1, f64::NAN];
    assert!(matches!(
        run_evaluation(&c, &|_| {}),
        Err(EvalError::Setup(_))
    ));
}

/// The quick evaluation, run once for all tests below, and the progress lines it printed.
fn quick() -> &'static Evaluation {
    &quick_run().0
}

fn quick_run() -> &'static (Evaluation, Vec<String>) {
    static EVAL: OnceLock<(Evaluation, Vec<String>)> = OnceLock::new();
    EVAL.get_or_init(|| {
        let lines = std::sync::Mutex::new(Vec::new());
        let progress = |line: &str| {
            if let Ok(mut l) = lines.lock() {
                l.push(line.to_string());
            }
        };
        match run_evaluation(&EvalConfig::quick(), &progress) {
            Ok(e) => (e, lines.into_inner().unwrap_or_default()),
            Err(e) => panic!("quick evaluation failed: {e}"),
        }
    })
}

#[test]
fn quick_report_has_every_file_and_the_headline_table() -> Result<(), Box<dyn std::error::Error>> {
    let e = quick();
    let dir = tempfile::tempdir()?;
    write_report(e, dir.path())?;
    for f in [
        "report.md",
        "summary.json",
        "accuracy.csv",
        "resolution.csv",
        "noise_only.csv",
        "chamfer.csv",
        "scenes.csv",
        "defaults.csv",
        "odometry.csv",
        "azimuth_rmse.png",
        "elevation_rmse.png",
        "doppler_rmse.png",
        "detection_rate.png",
        "resolution.png",
        "chamfer_corridor.png",
    ] {
        let meta = std::fs::metadata(dir.path().join(f))?;
        assert!(meta.len() > 100, "{f} is {} bytes", meta.len());
    }
    let png = std::fs::read(dir.path().join("azimuth_rmse.png"))?;
    assert_eq!(&png[1..4], b"PNG");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("summary.json"))?)?;
    let cd = json["chamfer"]
        .as_array()
        .ok_or("summary.json has no chamfer array")?;
    assert_eq!(cd.len(), EXTENDED_SCENES * e.config.resolutions_m.len());
    for entry in cd {
        for key in ["scene", "resolution", "dbe", "fft"] {
            assert!(entry.get(key).is_some(), "{entry}");
        }
        // The FFT chain has points on every extended scene.
        assert!(
            entry["fft"].as_f64().is_some_and(|v| v > 0.0 && v < 10.0),
            "{entry}"
        );
    }
    let md = std::fs::read_to_string(dir.path().join("report.md"))?;
    // The paper's protocol on sequence maps, beside the symmetric one on the same maps: one
    // entry per scene and τ (per scene and resolution), each chain finite where it has a map.
    let scenes = host_sim::eval::scenarios::SCENES.len();
    let taus = host_sim::eval::maps::TAUS_M;
    for (key, per_scene, x) in [
        ("chamfer_paper", taus.len(), "tau"),
        ("chamfer_map", e.config.resolutions_m.len(), "resolution"),
    ] {
        let rows = json[key]
            .as_array()
            .ok_or(format!("summary.json has no {key}"))?;
        assert_eq!(rows.len(), scenes * per_scene, "{key}");
        for r in rows {
            for k in ["scene", x, "dbe", "fft"] {
                assert!(r.get(k).is_some(), "{key}: {r}");
            }
            // Bounded by the metrics' definitions: CD(τ) ≤ 2τ; the symmetric distance of maps
            // of the same scene is below the scene's size.
            let bound = if key == "chamfer_paper" {
                2.0 * r[x].as_f64().unwrap_or(0.0) + 1e-12
            } else {
                20.0
            };
            let v = r["fft"]
                .as_f64()
                .ok_or(format!("{key}: no FFT value in {r}"))?;
            assert!((0.0..=bound).contains(&v), "{key}: {r}");
        }
    }
    assert!(md.contains("## Chamfer distance on sequence maps"));
    // Per object on the same maps: every scene has its objects; the points assigned to them
    // are at most the map's (a point farther than the correspondence radius goes to none),
    // and an object's share of the completeness term is its samples' part of its mean
    // distance.
    let objects = json["map_objects"].as_array().ok_or("no map_objects")?;
    for size in json["map_sizes"].as_array().ok_or("no map_sizes")? {
        let scene = size["scene"].as_str().unwrap_or_default();
        let of: Vec<_> = objects.iter().filter(|o| o["scene"] == scene).collect();
        assert!(!of.is_empty(), "no object rows for {scene}");
        let samples: f64 = of.iter().filter_map(|o| o["truth_points"].as_f64()).sum();
        for chain in ["dbe", "fft"] {
            let assigned: u64 = of
                .iter()
                .filter_map(|o| o[format!("{chain}_points")].as_u64())
                .sum();
            let map = size[format!("{chain}_points")].as_u64().unwrap_or(0);
            assert!(assigned <= map, "{scene} {chain}: {assigned} > {map}");
            for o in &of {
                let (Some(d), Some(share), Some(n)) = (
                    o[format!("{chain}_distance_m")].as_f64(),
                    o[format!("{chain}_share_m")].as_f64(),
                    o["truth_points"].as_f64(),
                ) else {
                    assert_eq!(map, 0, "{scene} {chain}: no distance with a map: {o}");
                    continue;
                };
                assert!((share - d * n / samples).abs() < 1e-9, "{o}");
            }
        }
    }
    assert!(md.contains("Where the completeness term differs"));
    // Realistic surfaces: every extended scene plain and realistic, both chains measured, and
    // each comparison listed with the scenes where it holds.
    assert!(md.contains("## Realistic surfaces: what changes"));
    let rows = json["surfaces"].as_array().ok_or("no surfaces")?;
    assert_eq!(rows.len(), EXTENDED_SCENES);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r["realistic"].as_bool(), Some(i % 2 == 1), "{r}");
        assert!(r["points"][1].as_f64().is_some_and(|p| p > 0.0), "{r}");
    }
    let conclusions = json["surface_conclusions"]
        .as_array()
        .ok_or("no conclusions")?;
    assert_eq!(conclusions.len(), 6);
    // Four point-cloud goals (issue 4), the sequence maps' Chamfer and density (issue 10),
    // four odometry goals (issue 9).
    let goals = json["goals"].as_array().ok_or("no goals")?;
    assert_eq!(goals.len(), 10);
    // The sequence maps' goal, recounted from the rows: cells of the extended scenes where
    // the DBE value is below the FFT one.
    let extended: Vec<&str> = SCENES[..EXTENDED_SCENES].iter().map(|s| s.name).collect();
    let count = |key: &str, dbe: &str, fft: &str| {
        let rows = json[key].as_array().into_iter().flatten();
        let ext: Vec<_> = rows
            .filter(|r| r["scene"].as_str().is_some_and(|s| extended.contains(&s)))
            .collect();
        let wins = ext
            .iter()
            .filter(|r| matches!((r[dbe].as_f64(), r[fft].as_f64()), (Some(d), Some(f)) if d < f))
            .count();
        (wins, ext.len())
    };
    let map_goal = goals
        .iter()
        .find(|g| {
            g["goal"]
                .as_str()
                .is_some_and(|s| s.contains("sequence maps"))
        })
        .ok_or("no sequence-map Chamfer goal")?;
    let detail = map_goal["detail"].as_str().unwrap_or_default();
    let mut all = true;
    for (what, key, dbe, fft, per_scene) in [
        ("exact poses", "chamfer_paper", "dbe", "fft", taus.len()),
        (
            "after ICP",
            "chamfer_paper",
            "dbe_icp",
            "fft_icp",
            taus.len(),
        ),
        (
            "symmetric distance",
            "chamfer_map",
            "dbe",
            "fft",
            e.config.resolutions_m.len(),
        ),
    ] {
        let (wins, total) = count(key, dbe, fft);
        assert_eq!(total, EXTENDED_SCENES * per_scene, "{key}");
        all &= wins == total;
        let text = format!("{what}: DBE below FFT in {wins} of {total} cells");
        assert!(detail.contains(&text), "{text} not in: {detail}");
    }
    assert_eq!(map_goal["met"].as_bool(), Some(all), "{detail}");
    assert_eq!(
        json["odometry"].as_array().map(Vec::len),
        Some(host_sim::eval::odometry::SEQUENCES.len() * 3)
    );
    for h in [
        "## Definitions",
        "## Angle accuracy",
        "## Two-target resolution",
        "## Chamfer distance",
        "## Radar-inertial odometry",
        "## Goals",
        "## Defaults",
    ] {
        assert!(md.contains(h), "report.md lacks {h}");
    }
    // Every main variant has a row at every SNR.
    for v in [
        names::DBE,
        names::FFT,
        names::DBE_GRID,
        names::FFT_GRID,
        names::DBE_NO_TDM,
        names::FFT_NO_TDM,
    ] {
        for &s in &e.config.snr_db {
            let r = e.accuracy_at(v, s).ok_or(format!("no row {v} {s}"))?;
            assert_eq!(r.trials, e.config.trials_per_snr);
        }
    }
    assert!(!e.defaults.is_empty() && e.recommendations.len() == 12);
    // A report never overwrites an unrelated folder's summary half-way: writing twice works.
    write_report(e, dir.path())?;
    Ok(())
}

#[test]
fn no_estimator_beats_the_cramer_rao_bound() {
    let e = quick();
    let mut checked = 0;
    for r in e.accuracy.iter().filter(|r| r.detected >= 8) {
        // 0.7: the RMSE of 8–16 trials scatters by about 1/√(2n) ≈ 20 %.
        for (rmse, crb, what) in [
            (r.az_rmse_deg, r.crb_az_deg, "azimuth"),
            (r.el_rmse_deg, r.crb_el_deg, "elevation"),
            (r.doppler_rmse_mps, r.crb_doppler_mps, "velocity"),
        ] {
            let rmse = rmse.unwrap_or(f64::NAN);
            assert!(
                rmse >= 0.7 * crb,
                "{} at {} dB: {what} RMSE {rmse} below the CRB {crb}",
                r.variant,
                r.snr_db
            );
            checked += 1;
        }
        // The bound scales as 1/√ρ: CRB·√ρ is the same at every SNR.
        let rho = 10f64.powf(r.snr_db / 10.0);
        let first = &e.accuracy[0];
        let rho0 = 10f64.powf(first.snr_db / 10.0);
        assert!(
            rel(
                r.crb_doppler_mps * rho.sqrt(),
                first.crb_doppler_mps * rho0.sqrt()
            ) < 1e-9
        );
    }
    assert!(checked > 60, "{checked}");
}

#[test]
fn angle_errors_shrink_with_snr_down_to_the_grid_floor() {
    let e = quick();
    let at = |v: &str, s: f64| e.accuracy_at(v, s).unwrap_or_else(|| panic!("{v} {s}"));
    // Sub-grid FFT azimuth and FFT elevation (continuous) fall with SNR.
    let (lo, hi) = (at(names::FFT, -5.0), at(names::FFT, 30.0));
    let az = (
        lo.az_rmse_deg.unwrap_or(0.0),
        hi.az_rmse_deg.unwrap_or(f64::INFINITY),
    );
    assert!(az.0 > 3.0 * az.1, "azimuth {az:?}");
    let el = (
        lo.el_rmse_deg.unwrap_or(0.0),
        hi.el_rmse_deg.unwrap_or(f64::INFINITY),
    );
    assert!(el.0 > 4.0 * el.1, "elevation {el:?}");
    // On the grid, at 30 dB, both chains sit on the azimuth quantisation floor step/√12.
    let floor = AZIMUTH_STEP_DEG / 12f64.sqrt();
    for v in [names::DBE_GRID, names::FFT_GRID] {
        let r = at(v, 30.0).az_rmse_deg.unwrap_or(f64::NAN);
        assert!(
            r > 0.6 * floor && r < 1.6 * floor,
            "{v}: {r} vs floor {floor}"
        );
    }
}

#[test]
fn doppler_errors_are_the_bin_quantisation_and_the_velocity_scale_of_the_model() {
    let e = quick();
    let bin = dbe_radar::Waveform::COLORADAR.doppler_bin_mps(128, 128, 3);
    // Spec §2 (amended) puts the range phase's carrier at the first sample, f_0; the range-FFT
    // bin's phase centre is the window centre (N − 1)/2, so the slow-time phase advances at
    // f_0 + S·(N − 1)/(2·fs) = f_c − S/(2·fs): a scale of −S/(2·fs·f_c) = −λ/(4·N·Δr).
    let w = dbe_radar::Waveform::COLORADAR;
    let predicted = -w.wavelength_m(128) / (4.0 * 128.0 * w.range_bin_m(128));
    assert!((predicted + 6.04e-5).abs() < 1e-6, "{predicted}");
    for s in [10.0, 20.0, 30.0] {
        // On the grid both chains are quantised to one Doppler bin.
        for v in [names::DBE_GRID, names::FFT_GRID] {
            let r = e
                .accuracy_at(v, s)
                .and_then(|r| r.doppler_rmse_mps)
                .unwrap_or(f64::NAN);
            // Quantisation (bin/√12) and the scale error (≈ 6·10⁻⁵ · 0.58 m/s RMS) add.
            let expected = ((bin * bin / 12.0) + (predicted * 0.577).powi(2)).sqrt();
            assert!(
                r > 0.6 * expected && r < 1.6 * expected,
                "{v} {s} dB: {r} vs {expected}"
            );
        }
        let slope = e
            .accuracy_at(names::FFT, s)
            .and_then(|r| r.doppler_scale)
            .unwrap_or(f64::NAN);
        assert!(
            (slope - predicted).abs() < 0.003,
            "scale at {s} dB: {slope} vs {predicted}"
        );
    }
}

#[test]
fn dbe_candidates_on_its_map_and_its_doppler_test_detect_as_deep_as_the_fft_chain() {
    let e = quick();
    let pd = |v: &str, s: f64| e.accuracy_at(v, s).map_or(f64::NAN, |r| r.detection_rate);
    for s in [10.0, 20.0, 30.0] {
        assert_eq!(pd(names::DBE, s), 1.0, "{s} dB");
        assert_eq!(pd(names::FFT, s), 1.0, "{s} dB");
    }
    // At −5 dB per antenna the map's peak-to-floor ratio is 1 + 8ρ = 3.5 (5.5 dB), above
    // α = 2 dB, and the 8-element beam's Doppler peak stands K·8ρ/1.5 ≈ 23 dB over its median,
    // above the 12 dB test: the DBE chain detects there as the FFT chain does (which
    // integrates the 128 loops before its CFAR). At α = 12 dB and without the test it
    // detected nothing below 0 dB.
    assert_eq!(dbe_radar::CfarParams::RANGE_AZIMUTH.threshold_db, 2.0);
    for v in [names::DBE, names::FFT] {
        assert!(pd(v, -5.0) >= 0.75, "{v}: {}", pd(v, -5.0));
    }
    // Noise only: the default thresholds give (almost) no points.
    for r in e
        .noise
        .iter()
        .filter(|r| r.variant == names::DBE || r.variant == names::FFT)
    {
        assert!(r.false_points_per_frame <= 0.5, "{r:?}");
    }
}

#[test]
fn without_tdm_compensation_moving_targets_lose_their_elevation() {
    let e = quick();
    for (on, off) in [
        (names::DBE, names::DBE_NO_TDM),
        (names::FFT, names::FFT_NO_TDM),
    ] {
        let a = e
            .accuracy_at(on, 20.0)
            .and_then(|r| r.el_rmse_deg)
            .unwrap_or(f64::NAN);
        let b = e
            .accuracy_at(off, 20.0)
            .and_then(|r| r.el_rmse_deg)
            .unwrap_or(0.0);
        // About 11° per m/s of slot-phase bias, velocities uniform in ±1 m/s.
        assert!(b > 5.0 * a && b > 2.0, "{on}: {a}° vs {off}: {b}°");
    }
    let scene = |v: &str| e.scene_at("moving_sensor", v).and_then(|r| r.el_rmse_deg);
    assert!(
        scene(names::DBE).is_some_and(|v| v < 1.0),
        "{:?}",
        scene(names::DBE)
    );
}

#[test]
fn the_fft_chain_never_resolves_a_coherent_pair_and_always_a_doppler_separated_one() {
    let e = quick();
    let snr = e.config.resolution_snr_db;
    for &sep in &e.config.separations_deg {
        let p = |v: &str, pair| {
            e.resolution_at(v, pair, sep, snr)
                .map_or(f64::NAN, |r| r.probability)
        };
        // One range–Doppler cell, one point.
        assert_eq!(p(names::FFT, Pair::Coherent), 0.0, "{sep}°");
        assert!(p(names::FFT, Pair::NonCoherent) >= 0.9, "{sep}°");
    }
    // The DBE chain resolves a non-coherent pair far apart, and not one 2° apart (a seventh of
    // the Rayleigh width).
    let p = |sep| {
        e.resolution_at(names::DBE, Pair::NonCoherent, sep, snr)
            .map_or(f64::NAN, |r| r.probability)
    };
    assert!(p(20.0) >= 0.9, "{}", p(20.0));
    assert!(p(2.0) <= 0.25, "{}", p(2.0));
}

#[test]
fn scene_points_lie_on_the_surfaces() {
    let e = quick();
    for s in [
        "corridor",
        "outdoor_poles_walls",
        "cluttered_room",
        "parking_lot",
    ] {
        let r = e.scene_at(s, names::FFT).unwrap_or_else(|| panic!("{s}"));
        assert!(
            r.truth_points_per_frame > 1000.0 && r.points_per_frame > 1.0,
            "{r:?}"
        );
        for v in [names::DBE, names::FFT] {
            // Points are within the match radius of a surface on average.
            if let Some(a) = e.chamfer_at(s, 0.1, v).and_then(|c| c.accuracy_m) {
                assert!(a < 0.6, "{s} {v}: {a}");
            }
        }
    }
    // The exact CRB and the closed form agree.
    let k = &e.crb_check;
    assert!(
        k.mu.abs() < 1e-3 && k.nu.abs() < 1e-3 && k.omega.abs() < 1e-3,
        "{k:?}"
    );
}

#[test]
fn the_odometry_section_runs_both_chains_on_every_sequence() {
    let e = quick();
    let seqs = host_sim::eval::odometry::SEQUENCES;
    // The DBE chain, the FFT chain and the DBE chain with the ring split.
    let ring = host_sim::eval::sweep_name(&host_sim::eval::SweepValue::RingSplit(true));
    assert_eq!(e.odometry.len(), seqs.len() * 3);
    for s in &seqs {
        for v in [names::DBE, names::FFT, ring.as_str()] {
            let r = e
                .odometry
                .iter()
                .find(|r| r.sequence == s.name && r.variant == v)
                .unwrap_or_else(|| panic!("{} {v}: no row", s.name));
            assert!(r.failure.is_none(), "{} {v}: {:?}", s.name, r.failure);
            let t = r
                .errors
                .as_ref()
                .unwrap_or_else(|| panic!("{} {v}: no errors", s.name));
            // The quick run's 60 frames: 2 s at rest, then 4 s walking at about 1 m/s.
            assert_eq!(t.matched, 60);
            assert!(t.path_length_m > 2.0 && t.path_length_m < 6.0, "{t:?}");
            // Sanity, not the goal: a filter that lost the frames or the extrinsics is off by
            // tens of per cent; an ego-velocity that mixed up axes by more than 2.5 Doppler bins.
            assert!(t.drift.xyz_pct < 20.0, "{} {v}: {t:?}", s.name);
            if r.ego.frames_compared > 0 {
                assert!(r.ego.rmse_mps[0] < 0.1, "{} {v}: {:?}", s.name, r.ego);
            }
            // Cut 1 s into the walk, the same frames start the filter in motion (a run that
            // started at rest after the cut would have no figure).
            let moving = r
                .xyz_pct_moving_start
                .unwrap_or_else(|| panic!("{} {v}: no moving start", s.name));
            eprintln!("{} {v}: moving start {moving:.2} %", s.name);
            assert!(moving < 20.0, "{} {v}: {moving} %", s.name);
            // After the 1 s start the rig stands until 2 s: the frames measured at 1.025 …
            // 1.925 s (and the walk's first, its points still slow) read standstills, and each
            // with one before it gives a zero-rate update, the IMU at rest: 1 to 10, none
            // rejected. The ablation without them ran from rest and in motion.
            let u = &r.updates;
            assert!(
                (1..=10).contains(&u.zero_rate) && u.zero_rate_rejected == 0,
                "{} {v}: {u:?}",
                s.name
            );
            assert!(
                r.xyz_pct_without_zero_rate.iter().all(Option::is_some),
                "{} {v}: {:?}",
                s.name,
                r.xyz_pct_without_zero_rate
            );
            // The stamp test ran both ways, and its radar velocities, stamped 50 ms early,
            // moved the time-offset estimate up from the exact stamps' (4 s of walking).
            assert!(r.xyz_pct_stamp_test.iter().all(Option::is_some), "{r:?}");
            let (exact, early) = (r.time_offset_s, r.time_offset_stamp_test_s);
            assert!(
                matches!((exact, early), (Some(a), Some(b)) if b > a),
                "{} {v}: time offset {exact:?}, stamped early {early:?}",
                s.name
            );
            // The velocity-scale ablation ran, and the estimate stayed within its 3 % prior's
            // 4σ of 1 (the simulated radar has no Doppler scale error; its points' directions
            // read a per cent or two slow).
            assert!(r.fixed_scale.iter().all(Option::is_some), "{r:?}");
            assert!(
                r.velocity_scale.is_some_and(|k| (k - 1.0).abs() < 0.12),
                "{} {v}: velocity scale {:?}",
                s.name,
                r.velocity_scale
            );
        }
    }
    // The FFT chain's dense points give an estimate on every moving frame of every sequence.
    for r in e.odometry.iter().filter(|r| r.variant == names::FFT) {
        assert!(r.ego.estimated_while_moving_pct > 95.0, "{r:?}");
    }
    let summary = &e.odometry_summary;
    assert_eq!(summary.len(), seqs.len() * 3);
    // The relative errors (10/20/30 % of the path) are in every row: a filter that ran has
    // sub-trajectories of each length, and their end errors are not all zero.
    for s in summary {
        assert!(
            s.relative_pct.iter().all(|x| x.is_finite() && *x > 0.0),
            "{} {}: relative {:?}",
            s.sequence,
            s.variant,
            s.relative_pct
        );
    }
    assert!(summary
        .iter()
        .filter(|s| s.variant == names::DBE)
        .all(|s| s.xyz_pct_minus_fft.is_some()));
    for goal in [
        "ego-velocity RMSE",
        "estimate on ≥ 98 %",
        "drifts less than FFT-fed",
        "XYZ drift ≤ 1.5 %",
    ] {
        assert!(
            e.goals.iter().any(|g| g.goal.contains(goal)),
            "goal {goal} missing"
        );
    }
    // The section reports its progress, one line per sequence and seed, in order.
    let lines: Vec<&String> = quick_run()
        .1
        .iter()
        .filter(|l| l.contains("odometry") && l.contains(" seed "))
        .collect();
    let runs = seqs.len() * e.config.odometry_seeds;
    assert_eq!(lines.len(), runs, "{lines:?}");
    for (i, line) in lines.iter().enumerate() {
        let s = &seqs[i / e.config.odometry_seeds];
        assert!(
            line.contains(&format!("odometry {}/{runs}: {} seed ", i + 1, s.name)),
            "{line}"
        );
    }
    // The paper's four first, then their realistic-surface twins in the same order; the goals
    // judge the four and name the twins only after them.
    let paper = host_sim::eval::odometry::PAPER_SEQUENCES;
    for (i, s) in seqs.iter().enumerate() {
        assert_eq!(s.realistic, i >= paper, "{}", s.name);
        assert_eq!(s.base_name(), seqs[i % paper].name, "{}", s.name);
        assert_eq!(s.text, seqs[i % paper].text, "{}", s.name);
    }
    let drift = e
        .goals
        .iter()
        .find(|g| g.goal.contains("XYZ drift ≤ 1.5 %"))
        .expect("the drift goal");
    let (judged, twins) = drift
        .detail
        .split_once("; with realistic surfaces (not part of the goal): ")
        .unwrap_or_else(|| panic!("no twins in {}", drift.detail));
    for (i, s) in seqs.iter().enumerate() {
        let named = format!("{} ", s.name);
        let in_judged = judged.split(", ").any(|x| x.starts_with(&named));
        let in_twins = twins.split(", ").any(|x| x.starts_with(&named));
        assert_eq!(
            (in_judged, in_twins),
            (i < paper, i >= paper),
            "{}",
            drift.detail
        );
    }
    // The twins run the realistic surfaces; the paper's four their scenes' own (none set).
    for (i, s) in seqs.iter().enumerate() {
        let scene = s.scene().expect("the shipped sequence parses");
        assert_eq!(!scene.surfaces.is_default(), i >= paper, "{}", s.name);
    }
}
