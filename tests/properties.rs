//! Properties of the building blocks: covariance, Capon, OS-CFAR false-alarm rate.

use dbe_radar::capon::Capon;
use dbe_radar::cfar::{detect, Columns, Detections, MapShape, MAX_TRAINING_CELLS};
use dbe_radar::covariance::{covariance, forward_backward, load_diagonal, Matrix};
use dbe_radar::Complex32;
use dbe_radar::{CfarKind, CfarParams};
use rand::{Rng, SeedableRng};

fn random_snapshots<const M: usize, const K: usize>(seed: u64) -> Box<[[Complex32; K]; M]> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut x = Box::new([[Complex32::new(0.0, 0.0); K]; M]);
    for row in x.iter_mut() {
        for v in row.iter_mut() {
            *v = Complex32::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        }
    }
    x
}

fn steering<const D: usize>(phase_step: f32) -> [Complex32; D] {
    core::array::from_fn(|m| Complex32::from_polar(1.0, -phase_step * m as f32))
}

#[test]
fn covariance_is_hermitian_and_positive_definite() {
    let x = random_snapshots::<12, 128>(1);
    let mut r: Matrix<12> = [[Complex32::new(0.0, 0.0); 12]; 12];
    covariance(&x[..], &mut r);
    for i in 0..12 {
        assert_eq!(r[i][i].im, 0.0);
        for j in 0..12 {
            assert_eq!(r[i][j], r[j][i].conj());
        }
    }
    // Positive definite: a Cholesky factor exists, and xᴴRx > 0 for random x.
    assert!(Capon::new(&r).is_some());
    let mut fb: Matrix<8> = core::array::from_fn(|i| core::array::from_fn(|j| r[i][j]));
    forward_backward(&mut fb);
    for i in 0..8 {
        for j in 0..8 {
            assert!((fb[i][j] - fb[j][i].conj()).norm() < 1e-6);
        }
    }
}

#[test]
fn capon_weights_are_distortionless_and_power_matches_definition() {
    let x = random_snapshots::<8, 64>(2);
    let mut r: Matrix<8> = [[Complex32::new(0.0, 0.0); 8]; 8];
    covariance(&x[..], &mut r);
    let delta = load_diagonal(&mut r, 0.01);
    assert!(delta > 0.0);
    let capon = Capon::new(&r).expect("loaded covariance is positive definite");
    for step in [-2.5f32, -0.3, 0.0, 1.1, 3.0] {
        let a = steering::<8>(step);
        let w = capon.weight(&a);
        let wa: Complex32 = w.iter().zip(a.iter()).map(|(w, a)| w.conj() * a).sum();
        assert!((wa - Complex32::new(1.0, 0.0)).norm() < 1e-4, "wᴴa = {wa}");
        // P = 1/(aᴴR⁻¹a) = wᴴRw for the Capon weight.
        let rw: [Complex32; 8] = core::array::from_fn(|i| (0..8).map(|j| r[i][j] * w[j]).sum());
        let wrw: Complex32 = w.iter().zip(rw.iter()).map(|(w, v)| w.conj() * v).sum();
        let p = capon.power(&a);
        assert!((wrw.re - p).abs() < 1e-4 * p, "wᴴRw = {wrw}, P = {p}");
    }
}

#[test]
fn capon_rejects_a_singular_covariance() {
    let r: Matrix<4> = [[Complex32::new(0.0, 0.0); 4]; 4];
    assert!(Capon::new(&r).is_none());
    let mut nan = r;
    nan[0][0] = Complex32::new(f32::NAN, 0.0);
    assert!(Capon::new(&nan).is_none());
}

/// OS-CFAR on i.i.d. exponential (square-law Gaussian) noise: with `n` training cells and the
/// k-th order statistic, `Pfa = Π_{i=0}^{k−1} (n−i)/(n−i+α)` per tested cell (Rohling 1983).
/// The local-maximum rule can only remove detections and removes few at this α (a cell far
/// above the level rarely has a larger neighbour), so the measured rate must lie in
/// [0.7·Pfa, Pfa] up to 4 binomial standard deviations.
#[test]
fn os_cfar_false_alarm_rate_on_exponential_noise() {
    const N: usize = 64;
    const NAZ: usize = 188;
    let p = CfarParams {
        threshold_db: 8.0,
        edge_skip: 0,
        ..CfarParams::RANGE_AZIMUTH
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let mut map = Box::new([[0.0f32; NAZ]; N]);
    let mut scratch = Box::new([0.0f32; MAX_TRAINING_CELLS]);
    let mut out = Box::new(Detections::<4096>::new());
    let (mut alarms, mut tested) = (0usize, 0usize);
    // Only cells whose full training window fits are counted, so n is the same for all.
    let (wr, wa) = (
        usize::from(p.guard_range + p.train_range),
        usize::from(p.guard_cross + p.train_cross),
    );
    for _ in 0..200 {
        for row in map.iter_mut() {
            for v in row.iter_mut() {
                *v = -(rng.gen_range(f32::MIN_POSITIVE..1.0)).ln();
            }
        }
        let shape = MapShape {
            first: 0,
            last: N - 1,
            columns: Columns::Truncated,
        };
        detect(&map, None, shape, &p, &mut scratch, &mut out);
        alarms += out
            .as_slice()
            .iter()
            .filter(|d| {
                let (b, i) = (usize::from(d.range_bin), usize::from(d.column));
                b >= wr && b + wr < N && i >= wa && i + wa < NAZ
            })
            .count();
        tested += (N - 2 * wr) * (NAZ - 2 * wa);
    }
    let n = p.full_training_cells();
    let CfarKind::OrderStatistic { quantile } = p.kind else {
        unreachable!("the DBE chain's CFAR is an OS-CFAR")
    };
    let k = (quantile * n as f32).ceil() as usize;
    let alpha = 10f64.powf(f64::from(p.threshold_db) / 10.0);
    let pfa: f64 = (0..k)
        .map(|i| (n - i) as f64 / ((n - i) as f64 + alpha))
        .product();
    let measured = alarms as f64 / tested as f64;
    let sigma = (pfa * (1.0 - pfa) / tested as f64).sqrt();
    println!(
        "OS-CFAR: measured Pfa {measured:.3e}, theory {pfa:.3e}, {alarms} alarms in {tested} cells"
    );
    assert!(
        measured <= pfa + 4.0 * sigma && measured >= 0.7 * pfa - 4.0 * sigma,
        "measured Pfa {measured:.2e}, theory {pfa:.2e} (n = {n}, k = {k}, {tested} cells)"
    );
}
