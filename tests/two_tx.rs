//! Arrays without an elevation row (2 TX × 4 RX on one line, `AZ = M` = 8: AWR1642/IWR1443
//! class, `presets::awr1642`): both chains run and give azimuth-only points, `z = 0`, with
//! the azimuth and Doppler accuracy of the 3-TX array's line (the same 8 elements).
//!
//! Tolerances as in `tests/pipeline.rs` (half a grid step plus the bias and 4σ noise bounds
//! derived there): range 0.54 bin + migration, azimuth 0.72 step, Doppler 0.58 bin + the
//! carrier model term. A target off the horizon (θ ≠ 0) is seen by a line at its direction
//! cosine μ = cos θ · sin φ, which the point keeps (`y = −R·μ`); its elevation is not
//! measured, so `z` is exactly 0.

mod common;

use common::{id, storage, synth, Target};
use dbe_radar::presets::awr1642 as p;
use dbe_radar::{Chain, Point};

/// Grid-unit errors (range bins, azimuth steps, Doppler bins) of `pt` against `t`.
fn errors(pt: &Point, t: &Target, range_bin_m: f64, doppler_bin_mps: f64) -> (f64, f64, f64) {
    let (mu, _) = t.mu_nu();
    let range = common::norm(t.pos);
    let mu_est = -f64::from(pt.position.y) / f64::from(pt.position.length());
    let v = (t.pos[0] * t.vel[0] + t.pos[1] * t.vel[1] + t.pos[2] * t.vel[2]) / range;
    (
        (f64::from(pt.position.length()) / range_bin_m - range / range_bin_m).abs(),
        (mu_est.asin() - mu.asin()).to_degrees().abs() / p::AZIMUTH_STEP_DEG,
        (f64::from(pt.velocity_mps) - v).abs() / doppler_bin_mps,
    )
}

fn cloud<
    C: Chain<{ p::SAMPLES }, { p::LOOPS }, { p::TX }, { p::RX }, { p::VIRTUAL }, { p::AZIMUTH }>,
>(
    frontend: &p::Frontend,
    chain: &C,
    work: &mut C::Workspace,
    targets: &[Target],
    seed: u64,
) -> Box<p::PointCloud> {
    let chirps = synth::<{ p::SAMPLES }, { p::LOOPS }, { p::TX }, { p::RX }>(
        &p::WAVEFORM,
        &p::GEOMETRY,
        targets,
        20.0,
        seed,
    );
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    for (i, c) in chirps.iter().enumerate() {
        frontend.push_chirp(&mut cube, id(i, p::TX), c).unwrap();
    }
    let mut out = Box::new(p::PointCloud::new());
    chain.process(&frontend.frame(&cube).unwrap(), work, &mut out);
    out
}

#[test]
fn both_chains_give_azimuth_only_points_on_a_line_array() {
    const { assert!(!p::Frontend::MEASURES_ELEVATION) };
    let frontend = p::frontend().unwrap();
    let dbe = p::dbe(&frontend).unwrap();
    let fft = p::fft_chain(&frontend).unwrap();
    let (range_bin_m, doppler_bin_mps) = (
        f64::from(frontend.range_bin_m()),
        f64::from(frontend.doppler_bin_mps()),
    );
    let w = p::WAVEFORM;
    let cases = [
        (3.0, 0.0, 0.0, 0.0),
        (5.2, 20.0, 0.0, 0.6),
        (7.7, -35.0, 8.0, -1.1),
        (10.1, 50.0, -12.0, 0.0),
    ];
    let mut dbe_work = Box::new(p::Workspace::new());
    let mut fft_work = Box::new(p::FftWorkspace::new());
    for (seed, &(range, az, el, v)) in cases.iter().enumerate() {
        let t = Target::polar(range, az, el, v, 40.0);
        let frame_s = (p::LOOPS * p::TX) as f64 * w.chirp_period_s();
        let migration = v.abs() * frame_s / 2.0 / range_bin_m;
        let model =
            w.slope_hz_per_s / (2.0 * w.adc_sample_rate_hz * w.center_frequency_hz(p::SAMPLES));
        let tol = (
            0.54 + migration,
            0.72,
            0.58 + model * v.abs() / doppler_bin_mps,
        );
        let clouds = [
            (
                "dbe",
                cloud(&frontend, &dbe, &mut dbe_work, &[t], seed as u64),
            ),
            (
                "fft",
                cloud(&frontend, &fft, &mut fft_work, &[t], seed as u64),
            ),
        ];
        for (name, c) in &clouds {
            let best = c
                .points()
                .iter()
                .min_by(|a, b| {
                    let (ea, eb) = (
                        errors(a, &t, range_bin_m, doppler_bin_mps),
                        errors(b, &t, range_bin_m, doppler_bin_mps),
                    );
                    (ea.0 + ea.1).total_cmp(&(eb.0 + eb.1))
                })
                .unwrap_or_else(|| panic!("{name}: no point for {t:?}"));
            let e = errors(best, &t, range_bin_m, doppler_bin_mps);
            assert!(
                e.0 <= tol.0 && e.1 <= tol.1 && e.2 <= tol.2,
                "{name}, target {t:?}: errors (range bins, az steps, Doppler bins) {e:?} over {tol:?}, point {best:?}"
            );
            // Not measured: exactly on the horizon, labelled with the bin of ν = 0.
            for pt in c.points() {
                assert_eq!(pt.position.z, 0.0, "{name}: {pt:?}");
                assert_eq!(
                    usize::from(pt.elevation_bin),
                    p::ELEVATION_BINS / 2,
                    "{name}"
                );
            }
        }
    }
}

#[test]
fn a_coherent_static_pair_on_a_line_array_gets_its_azimuths_and_zero_doppler() {
    // Two static targets in one range bin are coherent. The FB-averaged line separates them
    // 30° apart on the map; without an elevation row there is no rectangle to resolve them
    // on, so their Doppler weights come from the FB-averaged line too (on the raw covariance
    // each weight cancelled its own target: both points read 2.1 m/s, noise's Doppler).
    let frontend = p::frontend().unwrap();
    let dbe = p::dbe(&frontend).unwrap();
    let ts = [
        Target::polar(6.5, 15.0, 0.0, 0.0, 30.0),
        Target::polar(6.5, 45.0, 0.0, 0.0, 30.0),
    ];
    let mut work = Box::new(p::Workspace::new());
    let c = cloud(&frontend, &dbe, &mut work, &ts, 12);
    let (range_bin_m, doppler_bin_mps) = (
        f64::from(frontend.range_bin_m()),
        f64::from(frontend.doppler_bin_mps()),
    );
    for t in &ts {
        let ok = c.points().iter().any(|pt| {
            let e = errors(pt, t, range_bin_m, doppler_bin_mps);
            e.0 <= 0.54 && e.1 <= 0.72 && e.2 <= 0.58
        });
        assert!(ok, "{t:?} not among {:?}", c.points());
    }
}
