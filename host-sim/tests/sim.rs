//! The FMCW simulator against the signal model of `spec/pipeline.md` §2, its scenes and its
//! ground truth. Tolerances come from the physics: int16 rounding (±0.5 LSB per I and Q), bin
//! widths, and the statistics of the number of samples averaged.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use host_sim::frame::AdcFrame;
use host_sim::sensor::SensorConfig;
use host_sim::sim::render::noiseless_chirp;
use host_sim::sim::{
    load_scene, render_frame, simulate, write_truth, FrameTruth, ObjectKind, Scatterer, Scene,
    SimError, Simulation,
};
use num_complex::Complex64;
use rand::{rngs::StdRng, Rng, SeedableRng};
use rustfft::FftPlanner;

const C: f64 = 299_792_458.0;

/// Radar-frame position at `range`, azimuth φ and elevation θ (degrees):
/// μ = sin φ·cos θ, ν = sin θ, x = R·√(1 − μ² − ν²), y = −R·μ, z = R·ν.
fn at(range: f64, az_deg: f64, el_deg: f64) -> [f64; 3] {
    let (mu, nu) = mu_nu(az_deg, el_deg);
    [
        range * (1.0 - mu * mu - nu * nu).sqrt(),
        -range * mu,
        range * nu,
    ]
}

fn mu_nu(az_deg: f64, el_deg: f64) -> (f64, f64) {
    let (phi, theta) = (az_deg.to_radians(), el_deg.to_radians());
    (phi.sin() * theta.cos(), theta.sin())
}

fn still(position: [f64; 3], amplitude: f64, phase: f64) -> Scatterer {
    Scatterer {
        position,
        velocity: [0.0; 3],
        acceleration: [0.0; 3],
        amplitude,
        phase,
    }
}

/// The carrier of the range phase: the first ADC sample's frequency `f_0 = f_start + S·t_adc`
/// (spec §2 as amended).
fn lambda(sensor: &SensorConfig) -> f64 {
    let w = &sensor.waveform;
    C / (w.start_frequency_hz + w.slope_hz_per_s * sensor.adc_start_time_s)
}

fn kappa(sensor: &SensorConfig) -> f64 {
    PI * sensor.waveform.center_frequency_hz(sensor.samples) / sensor.f_design_hz
}

/// The §2 formula written out literally, one term at a time: the oracle.
fn naive_sample(
    sensor: &SensorConfig,
    scatterers: &[Scatterer],
    k: usize,
    t: usize,
    r: usize,
    n: usize,
) -> Complex64 {
    let w = &sensor.waveform;
    let tc = w.idle_time_s + w.ramp_end_time_s;
    let tau = k as f64 * sensor.num_tx as f64 * tc + t as f64 * tc;
    let az = f64::from(sensor.tx[t].0) + f64::from(sensor.rx[r].0);
    let el = f64::from(sensor.tx[t].1) + f64::from(sensor.rx[r].1);
    let (lam, kap) = (lambda(sensor), kappa(sensor));
    scatterers
        .iter()
        .map(|s| {
            let p: Vec<f64> = (0..3)
                .map(|i| s.position[i] + s.velocity[i] * tau)
                .collect();
            let range = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            let (mu, nu) = (-p[1] / range, p[2] / range);
            let phase = 2.0 * PI * (2.0 * w.slope_hz_per_s * range / C) * n as f64
                / w.adc_sample_rate_hz
                + 4.0 * PI * range / lam
                - kap * (mu * az + nu * el)
                + s.phase;
            Complex64::from_polar(s.amplitude, phase)
        })
        .sum()
}

fn sample(frame: &AdcFrame, k: usize, t: usize, r: usize, n: usize) -> Complex64 {
    let [i, q] = frame.data[frame.index(k, t, r, n)];
    Complex64::new(f64::from(i), f64::from(q))
}

/// Range FFT (no window) of chirp (k, t), RX r.
fn range_fft(frame: &AdcFrame, k: usize, t: usize, r: usize) -> Vec<Complex64> {
    let mut x: Vec<Complex64> = (0..frame.samples)
        .map(|n| sample(frame, k, t, r, n))
        .collect();
    FftPlanner::new()
        .plan_fft_forward(frame.samples)
        .process(&mut x);
    x
}

fn argmax(x: &[Complex64]) -> usize {
    (0..x.len())
        .max_by(|&a, &b| x[a].norm_sqr().total_cmp(&x[b].norm_sqr()))
        .unwrap_or(0)
}

/// Wrap a phase to (−π, π].
fn wrap(p: f64) -> f64 {
    let w = p.rem_euclid(2.0 * PI);
    if w > PI {
        w - 2.0 * PI
    } else {
        w
    }
}

fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

#[test]
fn static_target_range_fft_peak_is_at_range_over_bin() {
    let sensor = SensorConfig::coloradar();
    let bin = sensor.waveform.range_bin_m(sensor.samples);
    // The unwindowed peak is the nearest integer bin to R / bin (scalloping never moves it).
    for (bins, expected) in [
        (48.0, 48),
        (60.3, 60),
        (60.7, 61),
        (20.49, 20),
        (100.0, 100),
    ] {
        let s = still(at(bins * bin, 20.0, -10.0), 1000.0, 0.7);
        let frame = render_frame(&sensor, &[s], 0.0, &mut rng(1));
        for (k, t, r) in [(0, 0, 0), (64, 1, 3), (127, 2, 2)] {
            let peak = argmax(&range_fft(&frame, k, t, r));
            assert_eq!(peak, expected, "R = {bins} bins, chirp ({k}, {t}), RX {r}");
        }
    }
}

#[test]
fn static_target_phase_across_virtual_antennas_is_the_steering_vector() {
    let sensor = SensorConfig::coloradar();
    let bin = sensor.waveform.range_bin_m(sensor.samples);
    let kap = kappa(&sensor);
    let (amp, n) = (10_000.0, sensor.samples as f64);
    // On an integer bin the FFT peak is N·A·exp(j·ψ_m). Rounding moves each of the N
    // samples by at most √2/2 LSB, so |ΔX| ≤ N·√2/2 and each phase by at most
    // asin(√2/2 / A); a ratio of two peaks by twice that.
    let tol = 2.0 * (0.5f64.sqrt() / amp).asin();
    for (az, el) in [(23.0, 9.0), (-41.0, -17.0), (0.0, 0.0), (65.0, 20.0)] {
        let (mu, nu) = mu_nu(az, el);
        let s = still(at(40.0 * bin, az, el), amp, 1.1);
        let frame = render_frame(&sensor, &[s], 0.0, &mut rng(2));
        let x0 = range_fft(&frame, 0, 0, 0)[40];
        let pos = |t: usize, r: usize| {
            (
                f64::from(sensor.tx[t].0 + sensor.rx[r].0),
                f64::from(sensor.tx[t].1 + sensor.rx[r].1),
            )
        };
        let (az0, el0) = pos(0, 0);
        for t in 0..sensor.num_tx {
            for r in 0..sensor.num_rx {
                let x = range_fft(&frame, 0, t, r)[40];
                let (a, e) = pos(t, r);
                // a_m / a_0 = exp(−jκ(μ·Δaz + ν·Δel)).
                let expected = -kap * (mu * (a - az0) + nu * (e - el0));
                let err = wrap((x * x0.conj()).arg() - expected);
                assert!(
                    err.abs() <= tol,
                    "az {az}° el {el}°, TX {t} RX {r}: phase error {err:e} > {tol:e}"
                );
                assert!(
                    (x.norm() / (n * amp) - 1.0).abs() <= 0.5f64.sqrt() / amp,
                    "magnitude {}",
                    x.norm()
                );
            }
        }
    }
}

#[test]
fn moving_target_phase_advances_per_loop_and_per_tx_slot() {
    let sensor = SensorConfig::coloradar();
    let w = sensor.waveform;
    let (lam, kap) = (lambda(&sensor), kappa(&sensor));
    let (tc, t_loop) = (w.chirp_period_s(), w.loop_period_s(sensor.num_tx));
    let amp = 10_000.0;
    // Sample n = 0 carries exp(j(4πR(τ)/λ − κ(μ·az + ν·el) + φ0)) exactly; rounding moves
    // each phase by at most asin(√2/2 / A), a difference of two by twice that.
    let tol = 2.0 * (0.5f64.sqrt() / amp).asin();
    for (v, az, el) in [(1.5, 15.0, 5.0), (-2.0, -30.0, -12.0)] {
        let (mu, nu) = mu_nu(az, el);
        // Radial motion keeps the direction (μ, ν) constant.
        let u = at(1.0, az, el);
        let s = Scatterer {
            position: u.map(|x| 5.0 * x),
            velocity: u.map(|x| v * x),
            acceleration: [0.0; 3],
            amplitude: amp,
            phase: 0.3,
        };
        let frame = render_frame(&sensor, &[s], 0.0, &mut rng(3));
        let per_loop = 4.0 * PI * v * t_loop / lam;
        for r in 0..sensor.num_rx {
            for t in 0..sensor.num_tx {
                for k in 0..sensor.loops - 1 {
                    let d =
                        (sample(&frame, k + 1, t, r, 0) * sample(&frame, k, t, r, 0).conj()).arg();
                    let err = wrap(d - per_loop);
                    assert!(err.abs() <= tol, "v {v}: loop {k} TX {t} RX {r}: {err:e}");
                }
            }
            for k in [0, 77, sensor.loops - 1] {
                for t in 0..sensor.num_tx - 1 {
                    let (da, de) = (
                        f64::from(sensor.tx[t + 1].0 - sensor.tx[t].0),
                        f64::from(sensor.tx[t + 1].1 - sensor.tx[t].1),
                    );
                    let expected = 4.0 * PI * v * tc / lam - kap * (mu * da + nu * de);
                    let d =
                        (sample(&frame, k, t + 1, r, 0) * sample(&frame, k, t, r, 0).conj()).arg();
                    let err = wrap(d - expected);
                    assert!(
                        err.abs() <= tol,
                        "v {v}: loop {k} slot {t}→{}: {err:e}",
                        t + 1
                    );
                }
            }
        }
        // Range migration: the beat frequency follows R(τ) = R0 + v·τ. The mean of the
        // wrapped sample-to-sample phase steps telescopes to (ψ[N−1] − ψ[0]) / (N − 1), in
        // error by at most 2·asin(√2/2 / A) / (N − 1).
        let steps = (sensor.samples - 1) as f64;
        for k in [0, sensor.loops - 1] {
            let tau = k as f64 * t_loop;
            let expected = wrap(
                2.0 * PI * 2.0 * w.slope_hz_per_s * (5.0 + v * tau) / (C * w.adc_sample_rate_hz),
            );
            let measured: f64 = (0..sensor.samples - 1)
                .map(|n| (sample(&frame, k, 0, 0, n + 1) * sample(&frame, k, 0, 0, n).conj()).arg())
                .sum::<f64>()
                / steps;
            assert!(
                (measured - expected).abs() <= tol / steps,
                "v {v}, loop {k}: beat {measured} rad/sample, expected {expected}"
            );
        }
    }
}

/// Compare a render with the oracle: every sample must be the oracle rounded half away from
/// zero and clipped, except where the oracle lies within 1e-6 LSB of a rounding boundary
/// (the renderer's summation error is ~1e-10 of ΣA, see the next test).
fn assert_matches_oracle(sensor: &SensorConfig, scatterers: &[Scatterer], what: &str) -> usize {
    let frame = render_frame(sensor, scatterers, 0.0, &mut rng(4));
    let mut clipped = 0;
    for k in 0..sensor.loops {
        for t in 0..sensor.num_tx {
            for r in 0..sensor.num_rx {
                for n in 0..sensor.samples {
                    let v = naive_sample(sensor, scatterers, k, t, r, n);
                    let got = frame.data[frame.index(k, t, r, n)];
                    for (x, g) in [(v.re, got[0]), (v.im, got[1])] {
                        let expected = x.round().clamp(-32768.0, 32767.0);
                        if expected.abs() >= 32767.0 {
                            clipped += 1;
                        }
                        let boundary = ((x.abs().fract()) - 0.5).abs() < 1e-6;
                        assert!(
                            f64::from(g) == expected
                                || (boundary && (f64::from(g) - x).abs() < 0.6),
                            "{what}: chirp ({k}, {t}) RX {r} n {n}: got {g}, oracle {x}"
                        );
                    }
                }
            }
        }
    }
    clipped
}

#[test]
fn rendering_matches_the_literal_formula_with_rounding_and_clipping() {
    let mut sensor = SensorConfig::coloradar();
    sensor.loops = 3;
    let scatterers = [
        // Receding, approaching, tangential (direction changes), static, and one so strong
        // that most samples clip.
        Scatterer {
            position: at(3.3, 10.0, 4.0),
            velocity: [1.1, 0.2, -0.1],
            acceleration: [0.0; 3],
            amplitude: 700.0,
            phase: 0.1,
        },
        Scatterer {
            position: at(9.87, -50.0, -20.0),
            velocity: [-2.0, 0.5, 0.0],
            acceleration: [0.0; 3],
            amplitude: 2500.5,
            phase: 2.0,
        },
        Scatterer {
            position: [6.0, 0.0, 1.0],
            velocity: [0.0, 8.0, 0.0],
            acceleration: [0.0; 3],
            amplitude: 90.0,
            phase: -1.0,
        },
        still(at(14.2, 60.0, 24.0), 33.3, 4.0),
        still(at(0.9, -5.0, 0.0), 60_000.0, 0.0),
    ];
    let clipped = assert_matches_oracle(&sensor, &scatterers, "ColoRadar");
    assert!(
        clipped > 1000,
        "the strong scatterer must clip: {clipped} clipped values"
    );

    // Odd sizes, non-integer antenna positions, another waveform.
    let odd = SensorConfig {
        samples: 100,
        loops: 3,
        num_tx: 2,
        num_rx: 3,
        waveform: dbe_radar::Waveform::IWR6843_FIXTURE,
        tx: vec![(0.0, 0.0), (2.7, 0.6)],
        rx: vec![(0.0, 0.0), (1.13, 0.0), (2.2, -0.3)],
        f_design_hz: 60.0e9,
        coupling: None,
        channel_gains: None,
        range_bias_m: 0.0,
        adc_start_time_s: 4.0e-6,
    };
    assert_matches_oracle(&odd, &scatterers[..4], "odd sensor");

    // Fewer samples than the spreading kernel is wide.
    let tiny = SensorConfig {
        samples: 5,
        loops: 2,
        num_tx: 1,
        num_rx: 1,
        tx: vec![(0.0, 0.0)],
        rx: vec![(0.0, 0.0)],
        ..odd
    };
    assert_matches_oracle(&tiny, &scatterers[..4], "tiny sensor");
}

#[test]
fn summation_error_is_below_1e_10_of_the_amplitude_sum() {
    let sensor = SensorConfig::coloradar();
    let mut g = rng(5);
    // Ranges up to 20 m: beyond the 16 m of the range bins the beat frequency wraps.
    let scatterers: Vec<Scatterer> = (0..300)
        .map(|_| Scatterer {
            position: at(
                g.gen_range(0.2..20.0),
                g.gen_range(-80.0..80.0),
                g.gen_range(-40.0..40.0),
            ),
            velocity: [
                g.gen_range(-3.0..3.0),
                g.gen_range(-1.0..1.0),
                g.gen_range(-1.0..1.0),
            ],
            acceleration: [0.0; 3],
            amplitude: g.gen_range(0.1..100.0),
            phase: g.gen_range(0.0..2.0 * PI),
        })
        .collect();
    let total: f64 = scatterers.iter().map(|s| s.amplitude).sum();
    let mut worst: f64 = 0.0;
    for (k, t) in [(0, 0), (61, 1), (127, 2)] {
        let got = noiseless_chirp(&sensor, &scatterers, k, t).expect("valid chirp");
        for r in 0..sensor.num_rx {
            for n in 0..sensor.samples {
                let err = (got[r * sensor.samples + n]
                    - naive_sample(&sensor, &scatterers, k, t, r, n))
                .norm();
                worst = worst.max(err);
            }
        }
    }
    println!(
        "worst summation error {worst:e} LSB = {:e} of ΣA",
        worst / total
    );
    assert!(worst / total < 1e-10, "worst {worst:e} of ΣA {total}");
}

#[test]
fn noise_has_the_requested_std_per_i_and_q() {
    let sensor = SensorConfig::coloradar();
    let sigma = 10.0;
    let frame = render_frame(&sensor, &[], sigma, &mut rng(6));
    let n = frame.data.len() as f64;
    let mean = |c: usize| frame.data.iter().map(|v| f64::from(v[c])).sum::<f64>() / n;
    let (mi, mq) = (mean(0), mean(1));
    let var = |c: usize, m: f64| {
        frame
            .data
            .iter()
            .map(|v| (f64::from(v[c]) - m).powi(2))
            .sum::<f64>()
            / n
    };
    let (si, sq) = (var(0, mi).sqrt(), var(1, mq).sqrt());
    let cov = frame
        .data
        .iter()
        .map(|v| (f64::from(v[0]) - mi) * (f64::from(v[1]) - mq))
        .sum::<f64>()
        / n;
    // Rounding adds a uniform error of variance 1/12; the sample std of n Gaussian values has
    // relative standard error 1/√(2n) (0.16 % here); allow 5 standard errors.
    let expected = (sigma * sigma + 1.0 / 12.0).sqrt();
    for (name, s) in [("I", si), ("Q", sq)] {
        assert!(
            (s / expected - 1.0).abs() < 5.0 / (2.0 * n).sqrt(),
            "{name} std {s}, expected {expected}"
        );
    }
    for m in [mi, mq] {
        assert!(m.abs() < 5.0 * sigma / n.sqrt(), "mean {m}");
    }
    let rho = cov / (si * sq);
    assert!(rho.abs() < 5.0 / n.sqrt(), "I/Q correlation {rho}");
    // Chirps get independent noise: neighbouring chirps are uncorrelated too.
    let half = frame.data.len() / 2;
    let cross = (0..half)
        .map(|i| f64::from(frame.data[i][0]) * f64::from(frame.data[i + half][0]))
        .sum::<f64>()
        / half as f64
        / (si * si);
    assert!(
        cross.abs() < 5.0 / (half as f64).sqrt(),
        "first/second half correlation {cross}"
    );
}

#[test]
fn invalid_render_inputs_are_errors() {
    let sensor = SensorConfig::coloradar();
    let ok = still([5.0, 0.0, 0.0], 1.0, 0.0);
    let try_render = |s: &SensorConfig, sc: &[Scatterer], noise: f64| {
        host_sim::sim::try_render_frame(s, sc, noise, &mut rng(0))
    };
    assert!(try_render(&sensor, &[ok], 1.0).is_ok());
    let mut nan = ok;
    nan.position[1] = f64::NAN;
    let e = try_render(&sensor, &[ok, nan], 1.0).expect_err("NaN position");
    assert!(e.to_string().contains("scatterer 1"), "{e}");
    let mut negative = ok;
    negative.amplitude = -1.0;
    assert!(try_render(&sensor, &[negative], 1.0).is_err());
    let e = try_render(&sensor, &[ok], -1.0).expect_err("negative noise");
    assert!(e.to_string().contains("noise_std"), "{e}");
    let mut bad = sensor.clone();
    bad.rx.pop();
    let e = try_render(&bad, &[ok], 1.0).expect_err("3 RX positions for 4 RX");
    assert!(
        matches!(e, SimError::Sensor { .. }) && e.to_string().contains("RX"),
        "{e}"
    );
}

#[test]
fn rendering_is_deterministic_for_a_seed_whatever_the_thread_count() {
    let sensor = SensorConfig::coloradar();
    let scene = Scene::builtin_demo();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool")
            .install(|| simulate(&scene, &sensor, 2).expect("demo simulates"))
    };
    let (one, three) = (run(1), run(3));
    for (a, b) in one.iter().zip(&three) {
        assert_eq!(a.adc, b.adc, "frame {}", a.index);
        assert_eq!(a.truth, b.truth, "frame {}", a.index);
    }
    assert_ne!(one[0].adc, one[1].adc, "frames differ (motion and noise)");
    let mut other = scene.clone();
    other.seed += 1;
    let changed = simulate(&other, &sensor, 1).expect("demo simulates");
    assert_ne!(changed[0].adc, one[0].adc, "another seed gives other data");
    // render_frame alone: the same rng state gives the same frame.
    let s = [still([4.0, 1.0, 0.0], 50.0, 0.0)];
    assert_eq!(
        render_frame(&sensor, &s, 5.0, &mut rng(9)),
        render_frame(&sensor, &s, 5.0, &mut rng(9))
    );
}

#[test]
fn every_shipped_scene_parses_and_every_object_is_seen() {
    let sensor = SensorConfig::coloradar();
    let max_range = sensor.waveform.range_bin_m(sensor.samples) * (sensor.samples as f64 - 1.0);
    let mut names: Vec<String> = Vec::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir(scenes_dir())
        .expect("host-sim/scenes exists")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    entries.sort();
    for path in &entries {
        let scene = load_scene(path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            Some(scene.name.as_str()),
            path.file_stem().and_then(|s| s.to_str()),
            "scene name matches the file name"
        );
        names.push(scene.name.clone());
        let sim = Simulation::new(&scene, &sensor).unwrap_or_else(|e| panic!("{e}"));
        let mut seen = vec![false; scene.objects.len()];
        for i in [0, 20, 49] {
            let (scatterers, truth) = sim.scatterers(i);
            assert!(!scatterers.is_empty(), "{}: frame {i} is empty", scene.name);
            for s in &scatterers {
                let r = s.position.iter().map(|x| x * x).sum::<f64>().sqrt();
                assert!(
                    r <= max_range && s.position[0] > 0.0,
                    "{}: {s:?}",
                    scene.name
                );
                assert!(
                    s.amplitude < 2000.0,
                    "{}: amplitude {}",
                    scene.name,
                    s.amplitude
                );
            }
            for o in &truth.objects {
                seen[o.id] |= o.visible;
            }
        }
        for (id, seen) in seen.iter().enumerate() {
            assert!(
                seen,
                "{}: object {} never visible in frames 0, 20, 49",
                scene.name, id
            );
        }
        let frame = sim.frame(0).unwrap_or_else(|e| panic!("{e}"));
        let clipped = frame
            .adc
            .data
            .iter()
            .filter(|v| v.iter().any(|x| *x == i16::MAX || *x == i16::MIN))
            .count();
        assert_eq!(clipped, 0, "{}: clipped samples", scene.name);
    }
    for expected in [
        "single_target",
        "two_targets",
        "moving_sensor",
        "corridor",
        "outdoor_poles_walls",
        "cluttered_room",
        "parking_lot",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "missing scene {expected}"
        );
    }
}

fn write_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write temp scene");
    path
}

#[test]
fn malformed_scenes_give_errors_naming_the_file_and_the_problem() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        (
            "typo.toml",
            r#"[[objects]]
kind = "wall"
origin = [5.0, 1.0, 0.0]
edge_u = [0.0, -2.0, 0.0]
edge_v = [0.0, 0.0, 1.0]
densty = 3.0
"#,
            "densty",
        ),
        (
            "negative.toml",
            r#"[[objects]]
kind = "pole"
name = "p"
base = [5.0, 1.0, 0.0]
radius = 0.1
height = 2.0
density = -3.0
"#,
            "objects[0] (p): density must be finite and positive",
        ),
        (
            "missing.toml",
            r#"[[objects]]
kind = "point"
rcs_m2 = 1.0
"#,
            "missing field `position`",
        ),
        (
            "both.toml",
            r#"[[objects]]
kind = "point"
position = [5.0, 0.0, 0.0]
rcs_m2 = 1.0
amplitude = 3.0
"#,
            "exactly one of amplitude and rcs_m2",
        ),
        (
            "skew.toml",
            r#"[[objects]]
kind = "rectangle"
origin = [5.0, 1.0, 0.0]
edge_u = [0.0, -2.0, 0.0]
edge_v = [0.0, 1.0, 1.0]
"#,
            "perpendicular",
        ),
        (
            "kind.toml",
            r#"[[objects]]
kind = "sphere"
position = [5.0, 0.0, 0.0]
"#,
            "sphere",
        ),
        (
            "waypoints.toml",
            r#"[[sensor.waypoints]]
time_s = 1.0
position = [0.0, 0.0, 0.0]
[[sensor.waypoints]]
time_s = 1.0
position = [1.0, 0.0, 0.0]
"#,
            "sensor.waypoints[1].time_s",
        ),
        (
            "rate.toml",
            "frame_rate_hz = 0.0\n",
            "frame_rate_hz must be finite and positive",
        ),
        ("syntax.toml", "seed = [1, 2\n", "line 1"),
        (
            "duplicate.toml",
            r#"[[objects]]
kind = "point"
name = "a"
position = [5.0, 0.0, 0.0]
amplitude = 1.0
[[objects]]
kind = "point"
name = "a"
position = [6.0, 0.0, 0.0]
amplitude = 1.0
"#,
            "duplicate name",
        ),
    ];
    for (file, text, needle) in cases {
        let path = write_scene(dir.path(), file, text);
        let err = load_scene(&path).expect_err(file).to_string();
        assert!(
            err.contains(file),
            "{file}: error does not name the file: {err}"
        );
        assert!(
            err.contains(needle),
            "{file}: error does not say {needle:?}: {err}"
        );
    }
    let missing = dir.path().join("absent.toml");
    let err = load_scene(&missing).expect_err("absent file");
    assert!(matches!(err, SimError::Io { .. }) && err.to_string().contains("absent.toml"));

    // Sensor-dependent checks happen when the scene meets the sensor.
    let mut far = Scene::builtin_demo();
    far.field_of_view.max_range_m = Some(30.0);
    let err = Simulation::new(&far, &SensorConfig::coloradar()).expect_err("30 m > 16 m");
    assert!(err.to_string().contains("max_range_m"), "{err}");
}

fn point_scene(sensor: &str, objects: &str) -> Scene {
    Scene::from_toml_str(
        &format!("noise_std = 0.0\n{sensor}\n{objects}"),
        "test scene",
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn truth_gives_range_angles_and_radial_velocity_in_the_radar_frame() {
    let sensor = SensorConfig::coloradar();
    // Walking at 1.2 m/s towards a static target: it approaches (negative range rate).
    let scene = point_scene(
        "[sensor]\nvelocity = [1.2, 0.0, 0.0]",
        r#"[[objects]]
kind = "point"
name = "t"
position = [5.0, -1.0, 0.5]
rcs_m2 = 4.0
"#,
    );
    let sim = Simulation::new(&scene, &sensor).expect("valid");
    for i in [0, 10] {
        let (scatterers, truth) = sim.scatterers(i);
        let x = 5.0 - 1.2 * i as f64 / 10.0;
        let r = (x * x + 1.0 + 0.25f64).sqrt();
        let o = &truth.objects[0];
        assert_eq!(
            (o.kind, o.name.as_str(), o.visible),
            (ObjectKind::Point, "t", true)
        );
        assert!((o.range_m - r).abs() < 1e-12);
        assert!((o.mu - 1.0 / r).abs() < 1e-12 && (o.nu - 0.5 / r).abs() < 1e-12);
        // Azimuth is positive to the right (−y): atan(1/x); elevation asin(0.5/R).
        assert!((o.azimuth_deg - (1.0 / x).atan().to_degrees()).abs() < 1e-9);
        assert!((o.elevation_deg - (0.5 / r).asin().to_degrees()).abs() < 1e-9);
        assert!((o.radial_velocity_mps + 1.2 * x / r).abs() < 1e-12);
        assert!((truth.sensor.position[0] - 1.2 * i as f64 / 10.0).abs() < 1e-12);
        // Amplitude: radar_constant · √σ / R² = 200 · 2 / R².
        assert!((scatterers[0].amplitude - 400.0 / (r * r)).abs() < 1e-9);
        assert_eq!(scatterers[0].velocity, [-1.2, 0.0, 0.0]);
    }

    // A sensor yawed 90° left sees a target on the world +y axis straight ahead; turning left
    // at ω sweeps a static point at range x to the right: v_y = −ω·x.
    let scene = point_scene(
        "[sensor]\nyaw_deg = 90.0\nyaw_rate_deg_s = 10.0",
        r#"[[objects]]
kind = "point"
position = [0.0, 6.0, 0.0]
amplitude = 5.0
"#,
    );
    let (scatterers, truth) = Simulation::new(&scene, &sensor)
        .expect("valid")
        .scatterers(0);
    let p = truth.objects[0].position;
    assert!((p[0] - 6.0).abs() < 1e-12 && p[1].abs() < 1e-12 && p[2].abs() < 1e-12);
    let v = scatterers[0].velocity;
    assert!((v[1] + 10f64.to_radians() * 6.0).abs() < 1e-12 && v[0].abs() < 1e-12);
    let q = truth.sensor.orientation;
    assert!(
        (q[2] - 45f64.to_radians().sin()).abs() < 1e-12
            && (q[3] - 45f64.to_radians().cos()).abs() < 1e-12
    );

    // Outside the field of view (azimuth 80°) or behind: not visible, not rendered.
    let scene = point_scene(
        "",
        r#"[[objects]]
kind = "point"
position = [1.0, -5.67, 0.0]
amplitude = 5.0
[[objects]]
kind = "point"
position = [-4.0, 0.0, 0.0]
amplitude = 5.0
[[objects]]
kind = "point"
position = [4.0, 0.0, 2.0]
amplitude = 5.0
"#,
    );
    let (scatterers, truth) = Simulation::new(&scene, &sensor)
        .expect("valid")
        .scatterers(0);
    assert!(scatterers.is_empty(), "{scatterers:?}");
    assert!(truth.objects.iter().all(|o| !o.visible));
}

#[test]
fn surfaces_scatter_from_visible_faces_with_density_independent_power() {
    let sensor = SensorConfig::coloradar();
    let wall = |density: f64, seed: u64| {
        point_scene(
            &format!("seed = {seed}"),
            &format!(
                r#"[[objects]]
kind = "wall"
origin = [8.0, 3.0, -1.0]
edge_u = [0.0, -6.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
reflectivity = 0.1
density = {density}
"#
            ),
        )
    };
    // Σ A² = C² Σ σ_i / R_i⁴ does not depend on how finely the wall is sampled; the jitter
    // only moves each scatterer inside its cell (a relative spread of a few 1e-3 here).
    let power = |density: f64, seed: u64| {
        let (s, truth) = Simulation::new(&wall(density, seed), &sensor)
            .expect("valid")
            .scatterers(0);
        assert_eq!(truth.objects[0].scatterers, s.len());
        (
            s.iter().map(|s| s.amplitude * s.amplitude).sum::<f64>(),
            s.len(),
        )
    };
    let (p20, n20) = power(20.0, 1);
    let (p80, n80) = power(80.0, 2);
    // One scatterer per cell of side ≤ 1/√density: 27 × 9 and 54 × 18 cells on 6 m × 2 m.
    assert_eq!((n20, n80), (243, 972));
    assert!((p80 / p20 - 1.0).abs() < 0.02, "power {p20} vs {p80}");
    // Expected: C² σ⁰ ∫ cos²θ / R⁴ dA, by a fine midpoint sum over the wall.
    let mut expected = 0.0;
    let (nu, nv) = (600, 200);
    for i in 0..nu {
        for j in 0..nv {
            let (y, z) = (
                3.0 - 6.0 * (i as f64 + 0.5) / nu as f64,
                -1.0 + 2.0 * (j as f64 + 0.5) / nv as f64,
            );
            let r2 = 64.0 + y * y + z * z;
            let cos2 = 64.0 / r2;
            expected += 200.0 * 200.0 * 0.1 * cos2 / (r2 * r2) * (12.0 / (nu * nv) as f64);
        }
    }
    assert!(
        (p80 / expected - 1.0).abs() < 0.01,
        "power {p80}, expected {expected}"
    );

    // A box 6 m ahead: only the faces towards the radar scatter (none behind its front x).
    let scene = point_scene(
        "",
        r#"[[objects]]
kind = "box"
center = [6.0, 0.5, 0.0]
size = [1.0, 1.0, 1.0]
"#,
    );
    let (s, truth) = Simulation::new(&scene, &sensor)
        .expect("valid")
        .scatterers(0);
    assert!(!s.is_empty());
    // The side face at y = 0 is seen edge-on (cos θ = 0), top and bottom from below and
    // above their planes' wrong sides: all scatterers are on the front face x = 5.5.
    assert!(
        s.iter().all(|s| (s.position[0] - 5.5).abs() < 1e-9),
        "{s:?}"
    );
    let points = &truth.objects[0].surface_points;
    assert_eq!(
        points.len(),
        100,
        "10 × 10 truth cells of 0.1 m on the front face"
    );
    assert!(points.iter().all(|p| (p[0] - 5.5).abs() < 1e-3));

    // Occlusion: a wall hides the corner reflector and the pole behind it.
    let scene = point_scene(
        "",
        r#"[[objects]]
kind = "wall"
origin = [5.0, 2.0, -1.0]
edge_u = [0.0, -4.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
[[objects]]
kind = "point"
position = [8.0, 0.0, 0.0]
rcs_m2 = 10.0
[[objects]]
kind = "pole"
base = [9.0, 0.5, -1.0]
radius = 0.1
height = 1.5
"#,
    );
    let (s, truth) = Simulation::new(&scene, &sensor)
        .expect("valid")
        .scatterers(0);
    assert!(!truth.objects[1].visible && !truth.objects[2].visible);
    assert_eq!(s.len(), truth.objects[0].scatterers);
    let mut open = scene.clone();
    open.occlusion = false;
    let (_, truth) = Simulation::new(&open, &sensor)
        .expect("valid")
        .scatterers(0);
    assert!(truth.objects[1].visible && truth.objects[2].visible);
}

#[test]
fn truth_files_hold_every_frame_and_read_back() {
    let sensor = SensorConfig::coloradar();
    let frames = simulate(&Scene::builtin_demo(), &sensor, 3).expect("demo simulates");
    let dir = tempfile::tempdir().expect("temp dir");
    write_truth(dir.path(), &frames).expect("truth written");
    let gt = dir.path().join("groundtruth");
    for f in &frames {
        let text = std::fs::read_to_string(gt.join(format!("frame_{}.json", f.index)))
            .expect("frame file");
        let back: FrameTruth = serde_json::from_str(&text).expect("valid JSON");
        assert_eq!(back, f.truth);
        assert!((f.time_s - f.index as f64 * 0.1).abs() < 1e-12);
        let wall = back
            .objects
            .iter()
            .find(|o| o.name == "wall")
            .expect("wall");
        assert!(wall.visible && wall.surface_points.len() > 1000);
    }
    let poses = std::fs::read_to_string(gt.join("groundtruth_poses.txt")).expect("poses");
    let lines: Vec<Vec<f64>> = poses
        .lines()
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse().expect("number"))
                .collect()
        })
        .collect();
    assert_eq!(lines.len(), 3);
    assert!(lines.iter().all(|l| l.len() == 7));
    assert!((lines[2][0] - 0.24).abs() < 1e-12 && (lines[2][6] - 1.0).abs() < 1e-12);
    let stamps = std::fs::read_to_string(gt.join("timestamps.txt")).expect("timestamps");
    assert_eq!(
        stamps.lines().collect::<Vec<_>>(),
        ["0.000000", "0.100000", "0.200000"]
    );
}

/// The simulator and the core agree on every convention (range, μ sign, ν, Doppler sign,
/// TDM): a DBE point lands on each corner reflector of `moving_sensor`.
#[test]
fn dbe_core_finds_the_simulated_reflectors_where_the_truth_says() {
    use host_sim::core_run::CoreRunner;
    let sensor = SensorConfig::coloradar();
    let scene = load_scene(&scenes_dir().join("moving_sensor.toml")).expect("scene");
    let sim = Simulation::new(&scene, &sensor).expect("valid");
    let frame = sim.frame(10).expect("frame");
    let mut core =
        CoreRunner::new(&sensor, dbe_radar::Params::defaults(sensor.samples)).expect("core");
    let out = core.process(&frame.adc).expect("processed");
    let w = sensor.waveform;
    let bin = w.range_bin_m(sensor.samples);
    let doppler_bin = w.doppler_bin_mps(sensor.samples, sensor.loops, sensor.num_tx);
    for o in frame
        .truth
        .objects
        .iter()
        .filter(|o| o.kind == ObjectKind::Point)
    {
        // Within one range bin, 2° in azimuth and elevation (a few grid steps: Capon on a
        // 0.75° / 0.5° grid), one Doppler bin.
        let hit = out.points.iter().find(|p| {
            let r = (p.x * p.x + p.y * p.y + p.z * p.z).sqrt();
            let az = (-p.y / (p.x * p.x + p.y * p.y).sqrt()).asin().to_degrees();
            let el = (p.z / r).asin().to_degrees();
            (r - o.range_m).abs() <= bin
                && (az - o.azimuth_deg).abs() <= 2.0
                && (el - o.elevation_deg).abs() <= 2.0
                && (p.doppler - o.radial_velocity_mps).abs() <= doppler_bin
        });
        assert!(
            hit.is_some(),
            "{}: no point near R {:.2} az {:.1}° el {:.1}° v {:.2}; points: {:?}",
            o.name,
            o.range_m,
            o.azimuth_deg,
            o.elevation_deg,
            o.radial_velocity_mps,
            out.points
                .iter()
                .map(|p| (p.x, p.y, p.z, p.doppler))
                .collect::<Vec<_>>()
        );
    }
}

#[test]
fn scenes_serialise_back_to_toml_that_loads_to_the_same_scene() {
    let demo = Scene::builtin_demo();
    let text = toml::to_string(&demo).expect("scene serialises");
    let back = Scene::from_toml_str(&text, "serialised demo").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back, demo, "{text}");
    let corridor = load_scene(&scenes_dir().join("corridor.toml")).expect("corridor");
    let text = toml::to_string(&corridor).expect("scene serialises");
    assert_eq!(
        Scene::from_toml_str(&text, "serialised corridor").unwrap_or_else(|e| panic!("{e}")),
        corridor
    );
}

/// `[surfaces]`: the specular lobe scales each scatterer by the law of the module docs, edges
/// and corners add their cross sections where a face they bound is seen, and the floor ghost
/// is the mirror image at `Γ²` of the amplitude, moving with the mirrored velocity.
#[test]
fn realistic_surfaces_add_a_specular_lobe_edges_corners_and_floor_ghosts() {
    let sensor = SensorConfig::coloradar();
    let wall = r#"[[objects]]
kind = "wall"
origin = [8.0, 3.0, -1.0]
edge_u = [0.0, -6.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
reflectivity = 0.1
density = 20.0
"#;
    let scatterers = |surfaces: &str, objects: &str| {
        Simulation::new(&point_scene(surfaces, objects), &sensor)
            .expect("valid")
            .scatterers(0)
    };
    // σ of a scatterer from its amplitude: A = C·√σ / R² with C = 200.
    let sigma = |s: &Scatterer| {
        let r2: f64 = s.position.iter().map(|x| x * x).sum();
        (s.amplitude * r2 / 200.0).powi(2)
    };
    let (plain, _) = scatterers("", wall);
    assert_eq!(plain.len(), 243);

    // Specular lobe: the same scatterers (same positions, phases), each scaled by
    // (diffuse·cos²θ + specular·exp(−θ²/2w²)) / cos²θ.
    let (lobe, _) = scatterers(
        "[surfaces]\ndiffuse = 0.5\nspecular = 10.0\nspecular_width_deg = 4.0",
        wall,
    );
    assert_eq!(lobe.len(), plain.len());
    let w = 4f64.to_radians();
    for (a, b) in plain.iter().zip(&lobe) {
        assert_eq!((a.position, a.phase), (b.position, b.phase));
        let r: f64 = a.position.iter().map(|x| x * x).sum::<f64>().sqrt();
        let c = a.position[0] / r; // the wall's normal is x
        let theta = c.acos();
        let law = (0.5 * c * c + 10.0 * (-theta * theta / (2.0 * w * w)).exp()) / (c * c);
        assert!((sigma(b) / sigma(a) / law - 1.0).abs() < 1e-9);
    }
    // At 8 m a 6 m wide wall spans ±20.6°: within 0.5 m of its centre (θ ≤ 5°) the lobe makes
    // it ≥ 0.5 + 10·e^(−25/32) = 5.1× brighter; beyond 2.5 m (θ ≥ 17°) the diffuse half is
    // left (≤ 0.5 + 10·e^(−9) ≈ 0.5×).
    let part = |s: &[Scatterer], inner: bool| {
        s.iter()
            .filter(|s| {
                (s.position[1].abs() < 0.5) == inner && (s.position[1].abs() > 2.5) != inner
            })
            .map(sigma)
            .sum::<f64>()
    };
    assert!(part(&lobe, true) > 5.0 * part(&plain, true));
    assert!(part(&lobe, false) < 0.51 * part(&plain, false));

    // Edges and corners of a rectangle: all of them seen (two-sided), after the surface
    // scatterers, which stay as they were; Σσ = 0.1 m²/m × 16 m of perimeter + 4 × 1 m².
    let (features, truth) = scatterers(
        "[surfaces]\nedge_rcs_m2_per_m = 0.1\ncorner_rcs_m2 = 1.0",
        wall,
    );
    assert_eq!(&features[..plain.len()], &plain[..]);
    let added: f64 = features[plain.len()..].iter().map(sigma).sum();
    assert!((added - (0.1 * 16.0 + 4.0)).abs() < 1e-9, "Σσ = {added}");
    assert_eq!(truth.objects[0].scatterers, features.len());
    assert_eq!(truth.objects[0].ghosts, 0);

    // A box 6 m ahead shows only its front face (see the surface test above): the edges and
    // corners of that face, nothing behind it. 1 m edges at density 30: 6 samples each.
    let (boxed, _) = scatterers(
        "[surfaces]\nedge_rcs_m2_per_m = 0.1\ncorner_rcs_m2 = 1.0",
        "[[objects]]\nkind = \"box\"\ncenter = [6.0, 0.5, 0.0]\nsize = [1.0, 1.0, 1.0]\n",
    );
    assert_eq!(boxed.len(), 36 + 4 * 6 + 4);
    assert!(boxed.iter().all(|s| (s.position[0] - 5.5).abs() < 1e-9));
    let corners = boxed
        .iter()
        .filter(|s| (sigma(s) - 1.0).abs() < 1e-9)
        .count();
    assert_eq!(corners, 4);

    // Floor ghost: a target at z = 0 over a floor at z = −1 has an image at z = −2, Γ² = 0.25
    // of the amplitude a scatterer there would have, with the mirrored velocity; the floor's
    // own scatterers lie on the mirror plane and have none.
    let objects = r#"[[objects]]
kind = "point"
name = "t"
position = [6.0, 0.0, 0.0]
velocity = [-1.0, 0.0, 0.3]
rcs_m2 = 4.0
[[objects]]
kind = "plane"
name = "floor"
origin = [1.0, -3.0, -1.0]
edge_u = [10.0, 0.0, 0.0]
edge_v = [0.0, 6.0, 0.0]
reflectivity = 0.01
density = 5.0
"#;
    let (ghosted, truth) = scatterers("[surfaces.multipath]\nreflection = 0.5", objects);
    let (real, ghost) = (&ghosted[0], &ghosted[1]);
    assert_eq!(real.position, [6.0, 0.0, 0.0]);
    assert!((ghost.position[2] + 2.0).abs() < 1e-12 && (ghost.position[0] - 6.0).abs() < 1e-12);
    let expected = 0.25 * 200.0 * 2.0 / 40.0;
    assert!(
        (ghost.amplitude - expected).abs() < 1e-12,
        "{}",
        ghost.amplitude
    );
    assert!((ghost.velocity[2] + 0.3).abs() < 1e-12 && (ghost.velocity[0] + 1.0).abs() < 1e-12);
    assert_eq!(
        (truth.objects[0].scatterers, truth.objects[0].ghosts),
        (1, 1)
    );
    assert_eq!(truth.objects[1].ghosts, 0);
    assert_eq!(truth.scatterers, ghosted.len());

    // Bad values are refused with the key named.
    for (surfaces, needle) in [
        ("[surfaces]\nspecular = -1.0", "surfaces.specular"),
        (
            "[surfaces]\nspecular_width_deg = 0.0",
            "surfaces.specular_width_deg",
        ),
        (
            "[surfaces.multipath]\nreflection = 1.5",
            "surfaces.multipath.reflection",
        ),
        ("[surfaces]\nspecularity = 1.0", "specularity"),
    ] {
        let e = Scene::from_toml_str(&format!("{surfaces}\n{objects}"), "bad").unwrap_err();
        assert!(e.to_string().contains(needle), "{surfaces}: {e}");
    }
    let e = Scene::from_toml_str("[surfaces.multipath]\nreflection = 0.5\n", "bare").unwrap_err();
    assert!(e.to_string().contains("plane_z_m"), "{e}");
    let with_plane = "[surfaces.multipath]\nreflection = 0.5\nplane_z_m = -1.0\n";
    assert!(Scene::from_toml_str(with_plane, "plane").is_ok());
}
