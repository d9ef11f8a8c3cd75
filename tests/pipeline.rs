//! End-to-end accuracy of the core on synthetic frames built from the spec §2 signal model.
//!
//! Tolerances ([`tolerance`]) are derived per target, in grid units: half a grid step (a grid
//! estimate of a truth between bins), plus the deterministic biases of these frames, plus
//! four standard deviations of the estimator's noise:
//!
//! - **range**: the truth is taken at the frame start, the estimate averages over the frame,
//!   so a target moving at `v` is `|v|·T_frame/2` farther on; the noise of a range-FFT peak
//!   summed over `M·K` = 1,536 chirps at ≥ 19 dB per chirp is below 0.01 bin (single-tone
//!   Cramér–Rao bound, ×2 for the Blackman main lobe), 0.04 bin as 4σ.
//! - **azimuth**: a TDM compensation with the integer Doppler bin would leave up to half a
//!   Doppler bin of slot phase, `2π·½·1/(K·TX)` = 0.008 rad between the two halves of the
//!   azimuth line (slots 0 and 1), a tilt of about 0.001 in μ (0.05°, 0.07 step); the chain
//!   compensates with the fractional Doppler, so this is an upper bound. The noise of an
//!   8-element Capon estimate at these SNRs is below 0.03° (4σ ≈ 0.15 step).
//! - **elevation**: the same residual between the elevation row (slot 2) and the azimuth
//!   elements it is compared with (slots 0 and 1, mean 1.5 slots) would be up to
//!   `2π·½·1.5/(K·TX)` = 0.012 rad, i.e. `Δν = 0.012/(κ·Δel)` = 0.0039 (0.22°, 0.45 step),
//!   with the integer bin (again an upper bound now); the 12-element CRB at 19 dB per chirp
//!   and `K` = 128 snapshots is σ_ν ≈ 0.0013 (0.08°, 4σ = 0.6 step). The targets sit on
//!   elevation bin centres, so a grid estimate is off by a whole number of steps: bias +
//!   noise can exceed the half step and land it exactly one step (0.5°) away, which the f32
//!   grid reports as 0.99999987 steps. That is why one estimate of
//!   `several_targets_in_one_frame_are_all_recovered` sat there while the compensation used
//!   the integer bin (0.26 bin residual at 0.4 m/s: 0.12° of bias); the bound
//!   (0.5 + 0.45 + 0.6 ≈ 1.55 steps) allows it.
//! - **Doppler**: this synthesis puts the carrier phase at `f_0` (spec §2 as amended), so a
//!   range bin's slow-time phase advances at `f_0 + S·(N − 1)/(2·fs)` (the window-centre beat
//!   term) against the `f_c` the chain converts with: velocities read `S/(2·fs·f_c)` = 0.006 %
//!   low, 6·10⁻⁵·|d| bins; the slow-time peak's noise over 12 antennas and 128 loops is below
//!   0.02 bin (4σ 0.08).

mod common;

use common::{dbe_for, id, storage, synth_phased, Target};
use dbe_radar::presets::coloradar as p;
use dbe_radar::{AntennaGeometry, CfarParams, Chain, Params, Point, Waveform};

const AZ_STEP_DEG: f64 = p::AZIMUTH_STEP_DEG;
const EL_STEP_DEG: f64 = p::ELEVATION_STEP_DEG;

struct Run {
    cloud: Box<p::PointCloud>,
    work: Box<p::Workspace>,
    dbe: p::Dbe,
}

fn run(targets: &[Target], noise: f64, seed: u64, params: Params) -> Run {
    run_phased(targets, None, noise, seed, params)
}

fn run_phased(
    targets: &[Target],
    phases: Option<&[f64]>,
    noise: f64,
    seed: u64,
    params: Params,
) -> Run {
    let (frontend, dbe) = dbe_for(Waveform::COLORADAR, AntennaGeometry::COLORADAR, params).unwrap();
    let chirps = synth_phased::<{ p::SAMPLES }, { p::LOOPS }, { p::TX }, { p::RX }>(
        &Waveform::COLORADAR,
        &AntennaGeometry::COLORADAR,
        targets,
        phases,
        noise,
        seed,
    );
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    for (i, c) in chirps.iter().enumerate() {
        frontend.push_chirp(&mut cube, id(i, p::TX), c).unwrap();
    }
    let mut work = Box::new(p::Workspace::new());
    let mut cloud = Box::new(p::PointCloud::new());
    dbe.process(&frontend.frame(&cube).unwrap(), &mut work, &mut cloud);
    Run { cloud, work, dbe }
}

/// Grid-unit errors of point `pt` against target `t`: (range bins, az steps, el steps, Doppler bins).
fn errors(r: &Run, pt: &Point, t: &Target) -> (f64, f64, f64, f64) {
    let (mu, nu) = t.mu_nu();
    let range = common::norm(t.pos);
    let v = radial_velocity(t);
    let mu_est = f64::from(r.dbe.azimuth_grid()[usize::from(pt.azimuth_bin)]);
    let nu_est = f64::from(r.dbe.elevation_grid()[usize::from(pt.elevation_bin)]);
    (
        (f64::from(pt.range_bin) - range / f64::from(r.dbe.range_bin_m())).abs(),
        (mu_est.asin() - mu.asin()).to_degrees().abs() / AZ_STEP_DEG,
        (nu_est.asin() - nu.asin()).to_degrees().abs() / EL_STEP_DEG,
        (f64::from(pt.doppler_bin) - v / f64::from(r.dbe.doppler_bin_mps())).abs(),
    )
}

/// The point closest to `t` in range/azimuth grid units.
fn nearest<'a>(r: &'a Run, t: &Target) -> Option<&'a Point> {
    r.cloud.points().iter().min_by(|a, b| {
        let ea = errors(r, a, t);
        let eb = errors(r, b, t);
        (ea.0 + ea.1).total_cmp(&(eb.0 + eb.1))
    })
}

/// Radial velocity of `t` at the frame start, m/s.
fn radial_velocity(t: &Target) -> f64 {
    (t.pos[0] * t.vel[0] + t.pos[1] * t.vel[1] + t.pos[2] * t.vel[2]) / common::norm(t.pos)
}

/// The largest error (range bins, az steps, el steps, Doppler bins) the physics allows for a
/// grid estimate of `t` (module docs).
fn tolerance(t: &Target) -> (f64, f64, f64, f64) {
    let w = Waveform::COLORADAR;
    let v = radial_velocity(t);
    let frame_s = (p::LOOPS * p::TX) as f64 * w.chirp_period_s();
    let migration = v.abs() * frame_s / 2.0 / w.range_bin_m(p::SAMPLES);
    let doppler_bins = v.abs() / w.doppler_bin_mps(p::SAMPLES, p::LOOPS, p::TX);
    let model = w.slope_hz_per_s / (2.0 * w.adc_sample_rate_hz * w.center_frequency_hz(p::SAMPLES));
    (
        0.5 + migration + 0.04,
        0.5 + 0.07 + 0.15,
        0.5 + 0.45 + 0.6,
        0.5 + model * doppler_bins + 0.08,
    )
}

fn assert_recovered(r: &Run, t: &Target) {
    let pt = nearest(r, t).unwrap_or_else(|| panic!("no points for {t:?}"));
    let e = errors(r, pt, t);
    let tol = tolerance(t);
    assert!(
        e.0 <= tol.0 && e.1 <= tol.1 && e.2 <= tol.2 && e.3 <= tol.3,
        "target {t:?}: errors (range bins, az steps, el steps, Doppler bins) = {e:?} over \
         {tol:?}, point {pt:?}"
    );
}

#[test]
fn single_static_targets_are_recovered_within_one_grid_step() {
    let cases = [
        (3.0, 0.0, 0.0),
        (5.2, 20.0, 5.0),
        (7.7, -35.0, -8.0),
        (10.1, 50.0, 12.0),
        (12.6, -10.0, 18.0),
    ];
    for (seed, &(range, az, el)) in cases.iter().enumerate() {
        let t = Target::polar(range, az, el, 0.0, 40.0);
        let r = run(&[t], 20.0, seed as u64, Params::defaults(p::SAMPLES));
        assert_recovered(&r, &t);
        // The RA map exposed for plotting peaks at the detected cell.
        let map = r.work.range_azimuth();
        let (mut best, mut cell) = (0.0f32, (0, 0));
        for (b, row) in map.iter().enumerate() {
            for (i, &v) in row.iter().enumerate() {
                if v > best {
                    (best, cell) = (v, (b, i));
                }
            }
        }
        // The strongest detection (at α = 2 dB the map also has noise candidates, which the
        // Doppler test drops).
        let d = r
            .work
            .detections()
            .iter()
            .max_by(|a, b| a.power.total_cmp(&b.power))
            .copied()
            .unwrap_or_default();
        assert_eq!(cell, (usize::from(d.range_bin), usize::from(d.column)));
    }
}

#[test]
fn several_targets_in_one_frame_are_all_recovered() {
    // The two targets at 6.5 m share a range bin; different radial velocities make them
    // non-coherent over the K snapshots, which the 12-element Capon stage needs.
    let ts = [
        Target::polar(4.0, -25.0, 3.0, 0.0, 40.0),
        Target::polar(6.5, 15.0, -6.0, 0.4, 30.0),
        Target::polar(6.5, 45.0, 10.0, -0.8, 30.0),
        Target::polar(11.0, 0.0, 0.0, 0.0, 50.0),
    ];
    let r = run(&ts, 20.0, 11, Params::defaults(p::SAMPLES));
    for t in &ts {
        assert_recovered(&r, t);
    }
}

/// Two static targets in one range bin are coherent (identical snapshots up to noise).
/// Forward–backward averaging decorrelates them on the azimuth line, so both are detected at
/// the right range and azimuth; their beams share one Doppler, so both are resolved on the
/// FBSS rectangle (`dbe_radar::subarray`) and get their elevations too, within the tolerance
/// of a single target. With the coherent path off (the paper's chain: the 12-element Capon
/// without averaging) Capon's signal cancellation puts at least one elevation far off.
#[test]
fn coherent_pair_in_one_range_bin_gets_azimuth_and_elevation() {
    let ts = [
        Target::polar(6.5, 15.0, -6.0, 0.0, 30.0),
        Target::polar(6.5, 45.0, 10.0, 0.0, 30.0),
    ];
    let r = run(&ts, 20.0, 12, Params::defaults(p::SAMPLES));
    for t in &ts {
        assert_recovered(&r, t);
    }
    let paper = Params {
        coherent_doppler_bins: 0.0,
        ..Params::defaults(p::SAMPLES)
    };
    let r = run(&ts, 20.0, 12, paper);
    let worst = ts
        .iter()
        .map(|t| nearest(&r, t).map_or(f64::INFINITY, |pt| errors(&r, pt, t).2))
        .fold(0.0, f64::max);
    assert!(
        worst * EL_STEP_DEG > 2.0,
        "full array: worst elevation error {worst} steps"
    );
}

/// A vertical surface's range ring (`Params::ring_split`, off by default): two returns at one
/// range, azimuth and radial velocity, ±`el` about the horizon, equal or the lower 4 dB
/// weaker. In phase, the ring split gives a point within the elevation tolerance of each (its
/// `Re c` is exactly `cos κΔδ`, and the pair is split about the horizon, not about the
/// elevation stage's estimate, which the stronger return pulls towards itself); without it
/// the chain reports one point near the horizon. With it, a single target at any elevation
/// is still one point.
#[test]
fn an_in_phase_ring_pair_is_split_into_its_two_heights() {
    let (range, az, v) = (7.3, 35.0, 1.2);
    let on = Params {
        ring_split: true,
        ..Params::defaults(p::SAMPLES)
    };
    for (el, lower_db) in [(9.0, 40.0), (13.0, 40.0), (11.0, 36.0)] {
        let ts = [
            Target::polar(range, az, el, v, 40.0),
            Target::polar(range, az, -el, v, lower_db),
        ];
        let phases = [0.4, 0.4];
        let r = run_phased(&ts, Some(&phases), 20.0, 31, on);
        assert_eq!(r.cloud.points().len(), 2, "±{el}°: {:?}", r.cloud.points());
        for t in &ts {
            let tol = tolerance(t);
            let found = r.cloud.points().iter().any(|pt| {
                let e = errors(&r, pt, t);
                e.0 <= tol.0 && e.1 <= tol.1 && e.2 <= tol.2 && e.3 <= tol.3
            });
            assert!(
                found,
                "{t:?}: no point within {tol:?} in {:?}",
                r.cloud.points()
            );
        }
        let r = run_phased(&ts, Some(&phases), 20.0, 31, Params::defaults(p::SAMPLES));
        let [pt] = r.cloud.points() else {
            panic!("±{el}° without the split: {:?}", r.cloud.points());
        };
        let nu = f64::from(r.dbe.elevation_grid()[usize::from(pt.elevation_bin)]);
        assert!(nu.asin().to_degrees().abs() <= 1.55 * EL_STEP_DEG, "{pt:?}");
    }
    for (seed, el) in [(32u64, -12.0), (33, 0.0), (34, 6.0), (35, 15.0)] {
        let t = Target::polar(range, az, el, v, 40.0);
        let r = run(&[t], 20.0, seed, on);
        assert_eq!(r.cloud.points().len(), 1, "{el}°: {:?}", r.cloud.points());
        assert_recovered(&r, &t);
    }
}

#[test]
fn moving_targets_are_recovered_with_tdm_compensation() {
    for (seed, v) in [(21u64, 1.5), (22, -1.5), (23, 1.0), (24, -0.6)] {
        let t = Target::polar(6.0, 12.0, 9.0, v, 40.0);
        let r = run(&[t], 20.0, seed, Params::defaults(p::SAMPLES));
        assert_recovered(&r, &t);
    }
}

#[test]
fn without_tdm_compensation_a_1_mps_target_gets_its_elevation_wrong() {
    let t = Target::polar(6.0, 10.0, 0.0, 1.0, 40.0);
    let params = Params {
        tdm_compensation: false,
        ..Params::defaults(p::SAMPLES)
    };
    let r = run(&[t], 20.0, 31, params);
    let pt = nearest(&r, &t).expect("a point");
    let el_err_deg = errors(&r, pt, &t).2 * EL_STEP_DEG;
    assert!(el_err_deg > 10.0, "elevation error only {el_err_deg}°");
    // The same frame with compensation is within one grid step.
    let r = run(&[t], 20.0, 31, Params::defaults(p::SAMPLES));
    assert_recovered(&r, &t);
}

/// In noise a Capon range–azimuth cell estimated from `K` snapshots on an `AZ`-element line
/// is `σ²/AZ` times a Gamma variable of shape `K − AZ + 1` = 121 (unit mean, spread
/// 1/√121 = 9 %; forward–backward averaging only narrows it). A false detection needs a cell
/// above α = 8 dB (6.3×) its neighbours' 75 % order statistic (≈ 1.06), i.e. 5.7 times its
/// mean: the Gamma(121) tail there is below 10⁻¹⁵⁰, against 20,520 cells per frame. The
/// expected number of false points is zero to any precision, so zero is asserted.
#[test]
fn noise_only_frames_give_no_points() {
    for seed in 40..44 {
        let r = run(&[], 20.0, seed, Params::defaults(p::SAMPLES));
        assert_eq!(
            r.cloud.points().len(),
            0,
            "false points: {:?}",
            r.cloud.stats
        );
        assert_eq!(r.cloud.stats.skipped_range_bins, 0);
    }
}

/// A target 56 dB (amplitude 2000) or 68 dB (8000) above the noise after the range FFT lifts
/// its whole range row to the diagonal-loading floor, and leaks through DC removal into the
/// bins around DC; neither the ridge's ripples nor the leakage may become points.
#[test]
fn a_strong_target_gives_no_ridge_of_false_points() {
    for (seed, az, amp) in [
        (50u64, 12.0, 2000.0),
        (51, -40.0, 8000.0),
        (52, 60.0, 8000.0),
    ] {
        let t = Target::polar(6.0, az, 9.0, 0.0, amp);
        let r = run(&[t], 20.0, seed, Params::defaults(p::SAMPLES));
        assert_recovered(&r, &t);
        for pt in r.cloud.points() {
            let e = errors(&r, pt, &t);
            assert!(e.0 <= 1.0 && e.1 <= 2.0, "false point {pt:?} for {t:?}");
        }
    }
}

/// Sub-grid refinement on off-grid targets: RMS errors in grid units (range bins, azimuth
/// steps, elevation steps, Doppler bins) must shrink with refinement, and for range,
/// azimuth and Doppler (high SNR, estimator noise well below a step) fall below the grid's
/// own quantisation error, 1/√12 ≈ 0.29 of a step for a uniformly placed target. Elevation
/// rests on a one-unit aperture, whose noise is comparable to the 0.5° step.
#[test]
fn subgrid_refinement_beats_grid_quantisation() {
    let mut sum = [[0.0f64; 4]; 2];
    let mut n = 0usize;
    for seed in 0..24u64 {
        let s = seed as f64;
        let t = Target::polar(
            4.0 + 0.37 * s,
            -50.0 + 4.3 * s,
            -15.0 + 1.3 * s,
            -1.8 + 0.16 * s,
            60.0,
        );
        for (k, subgrid) in [false, true].into_iter().enumerate() {
            let params = Params {
                subgrid,
                ..Params::defaults(p::SAMPLES)
            };
            let r = run(&[t], 20.0, 100 + seed, params);
            let pt = nearest(&r, &t)
                .unwrap_or_else(|| panic!("seed {seed}: no point, {:?}", r.cloud.stats));
            // Truth at mid-frame: the estimates average over the K loops.
            let half = p::LOOPS as f64 * 3.0 * Waveform::COLORADAR.chirp_period_s() / 2.0;
            let mid = Target {
                pos: [0, 1, 2].map(|i| t.pos[i] + t.vel[i] * half),
                ..t
            };
            let (mu, nu) = mid.mu_nu();
            let range = common::norm(mid.pos);
            let v = (t.pos[0] * t.vel[0] + t.pos[1] * t.vel[1] + t.pos[2] * t.vel[2]) / range;
            let pos = pt.position.as_dvec3();
            let r_est = pos.length();
            let (mu_est, nu_est) = (-pos.y / r_est, pos.z / r_est);
            let e = [
                (r_est - range) / f64::from(r.dbe.range_bin_m()),
                (mu_est.asin() - mu.asin()).to_degrees() / AZ_STEP_DEG,
                (nu_est.asin() - nu.asin()).to_degrees() / EL_STEP_DEG,
                (f64::from(pt.velocity_mps) - v) / f64::from(r.dbe.doppler_bin_mps()),
            ];
            for (acc, x) in sum[k].iter_mut().zip(e.iter()) {
                *acc += x * x;
            }
        }
        n += 1;
    }
    let rms = |k: usize| sum[k].map(|s| (s / n as f64).sqrt());
    let (grid, refined) = (rms(0), rms(1));
    println!(
        "RMS error in grid units (range, az, el, Doppler): grid {grid:.3?}, refined {refined:.3?}"
    );
    for (q, (g, f)) in grid.iter().zip(refined.iter()).enumerate() {
        assert!(*f < *g, "grid {grid:?}, refined {refined:?}");
        assert!(q == 2 || *f < 0.29, "grid {grid:?}, refined {refined:?}");
    }
    // README quotes these figures (its "Sub-grid refinement" item).
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let flat = readme.split_whitespace().collect::<Vec<_>>().join(" ");
    let quoted = format!(
        "it cuts the RMS error from {:.2} to {:.2} range bins, {:.2} to {:.2} azimuth steps, {:.2} to {:.2} elevation steps and {:.2} to {:.2} Doppler bins",
        grid[0], refined[0], grid[1], refined[1], grid[2], refined[2], grid[3], refined[3]
    );
    assert!(
        flat.contains(&quoted),
        "README lacks the measured figures:\n{quoted}"
    );
}

/// `Params::paper` is the defaults without this crate's additions, and every addition is off.
#[test]
fn the_papers_chain_is_the_defaults_without_the_additions() {
    let (paper, d) = (Params::paper(p::SAMPLES), Params::defaults(p::SAMPLES));
    assert!(!paper.tdm_compensation && !paper.spatial_smoothing && !paper.subgrid);
    assert_eq!(
        (
            paper.coherent_doppler_bins,
            paper.doppler_test_db,
            paper.doppler_agreement_bins
        ),
        (0.0, 0.0, 0.0)
    );
    assert_eq!(paper.cfar.window_gate_db, 0.0);
    let restored = Params {
        cfar: CfarParams {
            window_gate_db: d.cfar.window_gate_db,
            ..paper.cfar
        },
        tdm_compensation: d.tdm_compensation,
        coherent_doppler_bins: d.coherent_doppler_bins,
        doppler_test_db: d.doppler_test_db,
        doppler_agreement_bins: d.doppler_agreement_bins,
        subgrid: d.subgrid,
        coherent_split: d.coherent_split,
        ..paper
    };
    assert!(!paper.coherent_split && d.coherent_split);
    assert!(!paper.ring_split && !d.ring_split);
    assert_eq!(restored, d);
}

/// The accelerator tests' frame and frontends: two targets with noise on the ColoRadar preset,
/// the default DBE chain, and the plain frontend with a calibrated copy (a coupling bump at the
/// first bins and a gain per channel).
fn accelerator_fixture() -> (Vec<p::Chirp>, Params, p::Frontend, p::Frontend, p::Dbe) {
    use dbe_radar::Complex32;
    let targets = [
        Target::polar(4.0, 10.0, 5.0, 0.8, 30.0),
        Target::polar(9.0, -25.0, -8.0, -1.1, 20.0),
    ];
    let chirps = synth_phased::<{ p::SAMPLES }, { p::LOOPS }, { p::TX }, { p::RX }>(
        &Waveform::COLORADAR,
        &AntennaGeometry::COLORADAR,
        &targets,
        None,
        5.0,
        3,
    );
    let params = Params::defaults(p::SAMPLES);
    let (plain, dbe) = dbe_for(Waveform::COLORADAR, AntennaGeometry::COLORADAR, params).unwrap();
    let bump: [Complex32; 16] =
        core::array::from_fn(|b| Complex32::new(900.0 / (1.0 + b as f32), -40.0));
    let coupling = [[&bump[..]; p::RX]; p::TX];
    let gains: [[Complex32; p::RX]; p::TX] = core::array::from_fn(|t| {
        core::array::from_fn(|r| Complex32::from_polar(1.0 + 0.05 * r as f32, 0.1 * t as f32))
    });
    let mut calibrated = plain.clone();
    calibrated.set_coupling(&coupling).unwrap();
    calibrated.set_channel_gains(&gains).unwrap();
    (chirps, params, plain, calibrated, dbe)
}

/// Range spectra computed off the core (`push_range_spectra`, the path of a radar whose FFT
/// accelerator does the range FFT) fill the same cube as `push_chirp`, with and without the
/// coupling and channel-gain calibrations: same mantissas, same map, same points.
#[test]
fn range_spectra_from_an_accelerator_fill_the_same_cube() {
    use dbe_radar::range::RangeFft;
    use dbe_radar::{ChirpId, Complex32};
    let (chirps, params, plain, calibrated, dbe) = accelerator_fixture();
    let fft = RangeFft::<{ p::SAMPLES }>::new(params.range_window);
    for frontend in [&plain, &calibrated] {
        let dbe = dbe.clone();
        let process = |push: &dyn Fn(&mut p::Cube<'_>, ChirpId, &p::Chirp)| {
            let mut st = storage();
            let mut cube = p::Cube::new(&mut st);
            for (i, c) in chirps.iter().enumerate() {
                push(&mut cube, id(i, p::TX), c);
            }
            let mut work = Box::new(p::Workspace::new());
            let mut cloud = Box::new(p::PointCloud::new());
            dbe.process(&frontend.frame(&cube).unwrap(), &mut work, &mut cloud);
            (st, work, cloud)
        };
        let (st_a, work_a, cloud_a) =
            process(&|cube, id, c| frontend.push_chirp(cube, id, c).unwrap());
        let (st_b, work_b, cloud_b) = process(&|cube, id, c| {
            let spectra: [[Complex32; p::SAMPLES]; p::RX] = core::array::from_fn(|r| {
                let mut s = [Complex32::new(0.0, 0.0); p::SAMPLES];
                fft.process(&c[r], &mut s);
                s
            });
            frontend.push_range_spectra(cube, id, &spectra).unwrap()
        });
        assert!(st_a == st_b, "mantissas differ");
        let bits = |w: &p::Workspace| -> Vec<u32> {
            w.range_azimuth()
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect()
        };
        assert_eq!(bits(&work_a), bits(&work_b));
        assert_eq!(cloud_a.points(), cloud_b.points());
        assert!(cloud_a.points().len() >= 2, "{:?}", cloud_a.points());
    }
    // The TDM order rules are push_chirp's.
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    let zero = [[Complex32::new(0.0, 0.0); p::SAMPLES]; p::RX];
    assert!(plain
        .push_range_spectra(&mut cube, id(1, p::TX), &zero)
        .is_err());
    assert!(plain.frame(&cube).is_err());
}

/// 16-bit range spectra with an exponent computed off the core (`push_range_blocks`, an FFT
/// accelerator's fixed-point output): the cube's own mantissas and exponents, fed back chirp
/// by chirp, fill a bit-identical cube (stored as they are); with the coupling and gain
/// calibrations on they are decoded and ingested as `push_range_spectra` ingests their
/// values; one fixed exponent for every chirp (an accelerator with a fixed output scale)
/// gives the same points' bins, its quantisation far below the noise.
#[test]
fn range_blocks_from_an_accelerator_fill_the_same_cube() {
    use dbe_radar::cube::{BlockExponent, CubeSample};
    use dbe_radar::range::RangeFft;
    use dbe_radar::{ChirpId, Complex32};
    type Blocks = [[CubeSample; p::SAMPLES]; p::RX];
    let (chirps, params, plain, calibrated, dbe) = accelerator_fixture();
    let rows = plain.layout().row_of;

    // The source: the plain frontend's own cube.
    let mut st_a = storage();
    let mut cube_a = p::Cube::new(&mut st_a);
    for (i, c) in chirps.iter().enumerate() {
        plain.push_chirp(&mut cube_a, id(i, p::TX), c).unwrap();
    }
    let exps_a = *cube_a.exponents();
    let chirp_blocks = |i: usize| -> (Blocks, [BlockExponent; p::RX]) {
        let (k, t) = (i / p::TX, i % p::TX);
        let row = |r: usize| usize::from(rows[t][r]);
        let m = core::array::from_fn(|r| core::array::from_fn(|b| st_a[b][k][row(r)]));
        let e = core::array::from_fn(|r| BlockExponent::new(exps_a[row(r)][k]).unwrap());
        (m, e)
    };
    let run = |frontend: &p::Frontend, push: &dyn Fn(&mut p::Cube<'_>, ChirpId, usize)| {
        let mut st = storage();
        let mut cube = p::Cube::new(&mut st);
        for i in 0..chirps.len() {
            push(&mut cube, id(i, p::TX), i);
        }
        let exps = *cube.exponents();
        let mut work = Box::new(p::Workspace::new());
        let mut cloud = Box::new(p::PointCloud::new());
        dbe.process(&frontend.frame(&cube).unwrap(), &mut work, &mut cloud);
        (st, exps, cloud)
    };
    let (cube_a, a_exps, cloud_a) = run(&plain, &|cube, id, i| {
        plain.push_chirp(cube, id, &chirps[i]).unwrap()
    });
    let (cube_b, b_exps, cloud_b) = run(&plain, &|cube, id, i| {
        let (m, e) = chirp_blocks(i);
        plain.push_range_blocks(cube, id, &m, &e).unwrap()
    });
    assert!(cube_a == cube_b && a_exps == b_exps, "copied cube differs");
    assert_eq!(cloud_a.points(), cloud_b.points());
    assert!(cloud_a.points().len() >= 2, "{:?}", cloud_a.points());

    // Calibrated: the blocks' decoded values through push_range_spectra, bit for bit.
    let (cube_c, c_exps, cloud_c) = run(&calibrated, &|cube, id, i| {
        let (m, e) = chirp_blocks(i);
        calibrated.push_range_blocks(cube, id, &m, &e).unwrap()
    });
    let (cube_d, d_exps, cloud_d) = run(&calibrated, &|cube, id, i| {
        let (m, e) = chirp_blocks(i);
        let spectra: [[Complex32; p::SAMPLES]; p::RX] = core::array::from_fn(|r| {
            let f = libm::ldexpf(1.0, i32::from(e[r].get()));
            core::array::from_fn(|b| {
                Complex32::new(f32::from(m[r][b][0]) * f, f32::from(m[r][b][1]) * f)
            })
        });
        calibrated.push_range_spectra(cube, id, &spectra).unwrap()
    });
    assert!(
        cube_c == cube_d && c_exps == d_exps,
        "calibrated cube differs"
    );
    assert_eq!(cloud_c.points(), cloud_d.points());
    assert!(cube_c != cube_a, "the calibrations changed nothing");

    // One fixed exponent for the whole frame: the largest any chirp needs.
    let fft = RangeFft::<{ p::SAMPLES }>::new(params.range_window);
    let fixed = BlockExponent::new(*exps_a.iter().flatten().max().unwrap()).unwrap();
    let (_, e_exps, cloud_e) = run(&plain, &|cube, id, i| {
        let f = libm::ldexpf(1.0, -i32::from(fixed.get()));
        let m: Blocks = core::array::from_fn(|r| {
            let mut s = [Complex32::new(0.0, 0.0); p::SAMPLES];
            fft.process(&chirps[i][r], &mut s);
            let q = |x: f32| (x * f).round().clamp(-32768.0, 32767.0) as i16;
            core::array::from_fn(|b| [q(s[b].re), q(s[b].im)])
        });
        plain
            .push_range_blocks(cube, id, &m, &[fixed; p::RX])
            .unwrap()
    });
    assert!(e_exps.iter().flatten().all(|&e| e == fixed.get()));
    let bins = |c: &p::PointCloud| -> Vec<[i32; 4]> {
        c.points()
            .iter()
            .map(|q| {
                let b = [q.range_bin, q.azimuth_bin, q.elevation_bin];
                [b[0].into(), b[1].into(), b[2].into(), q.doppler_bin.into()]
            })
            .collect()
    };
    assert_eq!(bins(&cloud_a), bins(&cloud_e));

    // Extreme mantissas at the largest exponent: a frame that processes (no panic).
    let extreme: Blocks = [[[i16::MIN, i16::MAX]; p::SAMPLES]; p::RX];
    let top = BlockExponent::new(BlockExponent::MAX).unwrap();
    let _ = run(&plain, &|cube, id, _| {
        plain
            .push_range_blocks(cube, id, &extreme, &[top; p::RX])
            .unwrap()
    });

    // The TDM order rules are push_chirp's.
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    let (m, e) = chirp_blocks(0);
    assert!(plain
        .push_range_blocks(&mut cube, id(1, p::TX), &m, &e)
        .is_err());
    assert!(plain.frame(&cube).is_err());
}
