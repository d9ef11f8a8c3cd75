//! Raw ADC frames from point scatterers: the signal model of `spec/pipeline.md` §2.
//!
//! One ADC sample of virtual antenna `m = (t, r)`, loop `k`, sample `n` is
//!
//! ```text
//! Σ_s A_s · exp( j · [ 2π·(2·S·R_s/c)·n/fs + 4π·R_s·f_0/c − κ·(μ_s·az_m + ν_s·el_m) + φ0_s ] )
//! ```
//!
//! plus complex white Gaussian noise, rounded half away from zero and clipped to int16. `R_s`,
//! `μ_s = −u_y` and `ν_s = u_z` are taken at the start of the chirp, `τ = k·T_loop + t·Tc`,
//! from `P_s + V_s·τ + A_s·τ²/2` (the second-order expansion of the rig's motion at the frame
//! start: the radar pose is followed chirp by chirp, turns and accelerations included): range
//! migration, Doppler and the TDM-MIMO slot offset are all in the data. The range phase's
//! carrier is the frequency at the first ADC sample, `f_0 = f_start + S·t_adc` (spec §2 as
//! amended: with it a range bin's slow-time phase advances by `4π·ΔR/λ` at
//! `f_c = f_start + S·(N/fs)/2`, as on real data, and velocities come out unbiased), and
//! `κ = π·f_c / F_design`.
//!
//! Method: per chirp and RX the samples are a sum of complex exponentials
//! `Σ_s c_s·exp(j·ω_s·n)`, computed by a non-uniform FFT (kernel spreading onto a 2×
//! oversampled frequency grid, inverse FFT, deapodization) rather than term by term, which cuts
//! the work per scatterer and chirp from `N · RX` complex multiply–adds to [`KERNEL_WIDTH`]
//! kernel values. All phases are computed in f64 from the exact chirp-start geometry; the
//! summation error is below 1e-10 of `Σ_s A_s` (measured in `tests/sim.rs`), far below the
//! int16 rounding step.

use std::sync::Arc;

use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use rustfft::{Fft, FftPlanner};

use super::SimError;
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;
use dbe_radar::config::SPEED_OF_LIGHT;

/// One point scatterer, moving relative to the radar on a parabola during the frame:
/// `p(τ) = position + velocity·τ + acceleration·τ²/2`, τ from the frame start.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scatterer {
    /// Position in the radar frame at the frame start (x forward, y left, z up), m.
    pub position: [f64; 3],
    /// Velocity relative to the radar, in the radar frame, m/s.
    pub velocity: [f64; 3],
    /// Acceleration relative to the radar, in the radar frame, m/s² (the second-order term of
    /// the motion within the frame: a turning or accelerating rig; 0 for straight motion at
    /// constant velocity).
    #[serde(default)]
    pub acceleration: [f64; 3],
    /// Amplitude of the complex ADC sample, LSB per sample (the modulus `A`).
    pub amplitude: f64,
    /// Phase `φ0` of the scatterer, rad.
    pub phase: f64,
}

/// Waveform and geometry constants of one sensor, all f64, derived once per frame.
#[derive(Clone, Debug)]
pub(crate) struct Constants {
    /// Beat phase per sample per metre of range, `2π·2·S / (c·fs)`, rad/(m·sample).
    pub omega_per_m: f64,
    /// Carrier phase per metre of range, `4π·f_0 / c`, rad/m.
    pub carrier_per_m: f64,
    /// Phase per half-wavelength unit, `κ = π·f_c / F_design`, rad.
    pub kappa: f64,
    /// Chirp period `Tc`, s.
    pub chirp_s: f64,
    /// Loop period `T_loop = TX·Tc`, s.
    pub loop_s: f64,
    /// TX positions `(az, el)`, half-wavelength units.
    pub tx: Vec<(f64, f64)>,
    /// RX positions `(az, el)`, half-wavelength units.
    pub rx: Vec<(f64, f64)>,
}

impl Constants {
    pub(crate) fn new(sensor: &SensorConfig) -> Self {
        let w = &sensor.waveform;
        let f_c = w.center_frequency_hz(sensor.samples);
        let pos = |v: &[(f32, f32)]| {
            v.iter()
                .map(|&(a, e)| (f64::from(a), f64::from(e)))
                .collect::<Vec<_>>()
        };
        Self {
            omega_per_m: 2.0 * std::f64::consts::PI * 2.0 * w.slope_hz_per_s
                / (SPEED_OF_LIGHT * w.adc_sample_rate_hz),
            carrier_per_m: 4.0 * std::f64::consts::PI * sensor.first_sample_frequency_hz()
                / SPEED_OF_LIGHT,
            kappa: std::f64::consts::PI * f_c / sensor.f_design_hz,
            chirp_s: w.chirp_period_s(),
            loop_s: w.loop_period_s(sensor.num_tx),
            tx: pos(&sensor.tx),
            rx: pos(&sensor.rx),
        }
    }
}

/// Check that `sensor` describes a frame the simulator can render.
///
/// Sizes must be non-zero, `tx` / `rx` must hold `num_tx` / `num_rx` finite positions, the
/// waveform values must be finite and positive (idle time ≥ 0) and `F_design` positive.
pub fn check_sensor(sensor: &SensorConfig) -> Result<(), SimError> {
    let bad = |problem: String| Err(SimError::Sensor { problem });
    if sensor.samples == 0 || sensor.loops == 0 || sensor.num_tx == 0 || sensor.num_rx == 0 {
        return bad(format!(
            "sizes must be non-zero, got samples {} loops {} tx {} rx {}",
            sensor.samples, sensor.loops, sensor.num_tx, sensor.num_rx
        ));
    }
    if sensor.tx.len() != sensor.num_tx || sensor.rx.len() != sensor.num_rx {
        return bad(format!(
            "expected {} TX and {} RX positions, got {} and {}",
            sensor.num_tx,
            sensor.num_rx,
            sensor.tx.len(),
            sensor.rx.len()
        ));
    }
    if sensor
        .tx
        .iter()
        .chain(&sensor.rx)
        .any(|&(a, e)| !a.is_finite() || !e.is_finite())
    {
        return bad("antenna positions must be finite".into());
    }
    let w = &sensor.waveform;
    for (name, v) in [
        ("adc_sample_rate_hz", w.adc_sample_rate_hz),
        ("slope_hz_per_s", w.slope_hz_per_s),
        ("start_frequency_hz", w.start_frequency_hz),
        ("ramp_end_time_s", w.ramp_end_time_s),
        ("f_design_hz", sensor.f_design_hz),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return bad(format!("{name} must be finite and positive, got {v}"));
        }
    }
    if !(w.idle_time_s.is_finite() && w.idle_time_s >= 0.0) {
        return bad(format!(
            "idle_time_s must be finite and ≥ 0, got {}",
            w.idle_time_s
        ));
    }
    Ok(())
}

/// Check that a scatterer list and noise level can be rendered: all values finite,
/// amplitudes and `noise_std` non-negative.
fn check_inputs(scatterers: &[Scatterer], noise_std: f64) -> Result<(), SimError> {
    if !(noise_std.is_finite() && noise_std >= 0.0) {
        return Err(SimError::Render {
            problem: format!("noise_std must be finite and ≥ 0, got {noise_std}"),
        });
    }
    for (i, s) in scatterers.iter().enumerate() {
        let finite = s
            .position
            .iter()
            .chain(&s.velocity)
            .chain([&s.amplitude, &s.phase])
            .all(|v| v.is_finite());
        if !finite || s.amplitude < 0.0 {
            return Err(SimError::Render {
                problem: format!(
                    "scatterer {i} must have finite values and amplitude ≥ 0, got {s:?}"
                ),
            });
        }
    }
    Ok(())
}

/// Render one frame; see the module docs for the model.
///
/// `noise_std` is the standard deviation of the Gaussian noise on I and on Q separately, LSB.
/// The rng is drawn once (one `u64` that seeds the noise of every chirp), so the output is
/// a function of the inputs and the rng state only, whatever the rayon thread count.
/// Scatterers closer than 1 µm to the radar have no direction and are skipped.
///
/// # Panics
///
/// When [`try_render_frame`] fails: an inconsistent `sensor` (see [`check_sensor`]), a
/// non-finite scatterer value, a negative amplitude or a negative `noise_std`.
pub fn render_frame(
    sensor: &SensorConfig,
    scatterers: &[Scatterer],
    noise_std: f64,
    rng: &mut impl Rng,
) -> AdcFrame {
    match try_render_frame(sensor, scatterers, noise_std, rng) {
        Ok(frame) => frame,
        Err(e) => panic!("render_frame: {e}"),
    }
}

/// Render one frame like [`render_frame`], returning an error instead of panicking.
pub fn try_render_frame(
    sensor: &SensorConfig,
    scatterers: &[Scatterer],
    noise_std: f64,
    rng: &mut impl Rng,
) -> Result<AdcFrame, SimError> {
    check_sensor(sensor)?;
    check_inputs(scatterers, noise_std)?;
    let c = Constants::new(sensor);
    let noise_seed: u64 = rng.gen();
    let (samples, rx, tx) = (sensor.samples, sensor.num_rx, sensor.num_tx);
    let nufft = Nufft::new(samples);
    let active: Vec<&Scatterer> = scatterers.iter().filter(|s| s.amplitude > 0.0).collect();

    let mut frame = AdcFrame::zeros(samples, sensor.loops, tx, rx);
    frame
        .data
        .par_chunks_mut(rx * samples)
        .enumerate()
        .for_each_init(
            || Scratch::new(&nufft, rx),
            |scratch, (chirp, out)| {
                let (k, t) = (chirp / tx, chirp % tx);
                let tau = k as f64 * c.loop_s + t as f64 * c.chirp_s;
                scratch.grid.fill(0.0);
                for s in &active {
                    scratch.spread(&nufft, &c, t, tau, s);
                }
                scratch.finish(&nufft);
                let mut noise = rand::rngs::StdRng::seed_from_u64(mix(noise_seed, chirp as u64));
                scratch.write(out, noise_std, &mut noise);
            },
        );
    Ok(frame)
}

/// The noiseless, unrounded samples of chirp (`loop_index`, `tx_slot`): `rx · samples`
/// values, RX-major, exactly what [`render_frame`] adds noise to and rounds.
pub fn noiseless_chirp(
    sensor: &SensorConfig,
    scatterers: &[Scatterer],
    loop_index: usize,
    tx_slot: usize,
) -> Result<Vec<Complex64>, SimError> {
    check_sensor(sensor)?;
    check_inputs(scatterers, 0.0)?;
    if loop_index >= sensor.loops || tx_slot >= sensor.num_tx {
        return Err(SimError::Render {
            problem: format!(
                "chirp (loop {loop_index}, TX {tx_slot}) outside {} loops × {} TX",
                sensor.loops, sensor.num_tx
            ),
        });
    }
    let c = Constants::new(sensor);
    let nufft = Nufft::new(sensor.samples);
    let mut scratch = Scratch::new(&nufft, sensor.num_rx);
    let tau = loop_index as f64 * c.loop_s + tx_slot as f64 * c.chirp_s;
    for s in scatterers.iter().filter(|s| s.amplitude > 0.0) {
        scratch.spread(&nufft, &c, tx_slot, tau, s);
    }
    scratch.finish(&nufft);
    Ok(scratch.result)
}

/// Width of the spreading kernel, grid points. The "exponential of semicircle" kernel with
/// 2× oversampling reaches a relative error near `10^−(W−1)` (Barnett, Magland, af Klinteberg,
/// "A parallel non-uniform fast Fourier transform library based on an exponential of
/// semicircle kernel", SIAM J. Sci. Comput. 2019, §4); the measured error is in `tests/sim.rs`.
pub const KERNEL_WIDTH: usize = 12;
/// Shape `β = 2.30·W` of the kernel for oversampling 2 (same paper).
const KERNEL_BETA: f64 = 2.30 * KERNEL_WIDTH as f64;
/// Oversampling of the spreading grid.
const OVERSAMPLING: usize = 2;

/// `exp(β·(√(1 − z²) − 1))` on `|z| < 1`, else 0.
fn kernel(z: f64) -> f64 {
    if z.abs() < 1.0 {
        (KERNEL_BETA * ((1.0 - z * z).sqrt() - 1.0)).exp()
    } else {
        0.0
    }
}

/// Sums of complex exponentials `f[n] = Σ_s c_s·exp(j·ω_s·n)`, `n = 0..N`, by a type-1
/// non-uniform FFT: spread every `c_s·exp(j·ω_s·⌊N/2⌋)` onto a grid of `M ≥ 2N` frequencies with
/// the kernel, one inverse FFT, divide by the kernel's transform. Cost per term: W kernel
/// values and `W · RX` real multiply–adds instead of `N · RX` complex ones.
struct Nufft {
    /// Samples N.
    samples: usize,
    /// Grid size M = max(2N, 2W).
    grid: usize,
    /// ⌊N/2⌋: output n is frequency index `n − half`.
    half: usize,
    /// `1 / D(n − half)`, D the kernel's discrete transform.
    deapod: Vec<f64>,
    /// Inverse FFT of length M.
    fft: Arc<dyn Fft<f64>>,
}

impl Nufft {
    fn new(samples: usize) -> Self {
        // At least 2W points, so one fold of the W-row padding wraps every kernel tail.
        let grid = (OVERSAMPLING * samples).max(2 * KERNEL_WIDTH);
        let half = samples / 2;
        let h = std::f64::consts::TAU / grid as f64;
        let w2 = (KERNEL_WIDTH / 2) as isize;
        let deapod = (0..samples)
            .map(|n| {
                let kf = n as f64 - half as f64;
                let d: f64 = (-w2..=w2)
                    .map(|l| kernel(l as f64 / w2 as f64) * (kf * l as f64 * h).cos())
                    .sum();
                1.0 / d
            })
            .collect();
        Self {
            samples,
            grid,
            half,
            deapod,
            fft: FftPlanner::new().plan_fft_inverse(grid),
        }
    }
}

/// Per-thread buffers of one chirp.
struct Scratch {
    /// Spreading grid `[M + 2W][rx][re, im]`: grid point `l` lives at row `l + W`.
    grid: Vec<f64>,
    /// RX count.
    rx: usize,
    /// Coefficients of the current scatterer, `[rx][re, im]`.
    coef: Vec<f64>,
    /// Phases of the current scatterer's RX coefficients, and their sines and cosines.
    phases: Vec<f64>,
    sin: Vec<f64>,
    cos: Vec<f64>,
    /// Kernel weights of the current scatterer.
    weights: [f64; KERNEL_WIDTH],
    /// One RX row for the FFT.
    line: Vec<Complex64>,
    /// FFT scratch.
    fft_scratch: Vec<Complex64>,
    /// The chirp before noise and rounding, `[rx][n]`.
    result: Vec<Complex64>,
}

impl Scratch {
    fn new(nufft: &Nufft, rx: usize) -> Self {
        Self {
            grid: vec![0.0; (nufft.grid + 2 * KERNEL_WIDTH) * 2 * rx],
            rx,
            coef: vec![0.0; 2 * rx],
            phases: vec![0.0; rx],
            sin: vec![0.0; rx],
            cos: vec![0.0; rx],
            weights: [0.0; KERNEL_WIDTH],
            line: vec![Complex64::default(); nufft.grid],
            fft_scratch: vec![Complex64::default(); nufft.fft.get_inplace_scratch_len()],
            result: vec![Complex64::default(); rx * nufft.samples],
        }
    }

    /// Spread scatterer `s` for the chirp of TX slot `t` starting at `tau`.
    fn spread(&mut self, nufft: &Nufft, c: &Constants, t: usize, tau: f64, s: &Scatterer) {
        let half_tau2 = 0.5 * tau * tau;
        let p: [f64; 3] = std::array::from_fn(|i| {
            s.position[i] + s.velocity[i] * tau + s.acceleration[i] * half_tau2
        });
        let range = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        if range < 1e-6 {
            return;
        }
        let (mu, nu) = (-p[1] / range, p[2] / range);
        // Beat phase per sample, reduced to [0, 2π): n is an integer.
        let x = (c.omega_per_m * range).rem_euclid(std::f64::consts::TAU);

        let (tx_az, tx_el) = c.tx[t];
        let base = c.carrier_per_m * range + s.phase + x * nufft.half as f64
            - c.kappa * (mu * tx_az + nu * tx_el);
        for (ph, &(rx_az, rx_el)) in self.phases.iter_mut().zip(&c.rx) {
            *ph = base - c.kappa * (mu * rx_az + nu * rx_el);
        }
        sin_cos(&self.phases, &mut self.sin, &mut self.cos);
        for ((cf, sin), cos) in self.coef.chunks_exact_mut(2).zip(&self.sin).zip(&self.cos) {
            cf[0] = s.amplitude * cos;
            cf[1] = s.amplitude * sin;
        }

        // Grid position in grid steps, and the first grid point the kernel touches.
        let xg = x * nufft.grid as f64 / std::f64::consts::TAU;
        let w2 = (KERNEL_WIDTH / 2) as f64;
        let l0 = (xg - w2).ceil();
        // |z| ≤ 1 by the choice of l0; z = −1 exactly gives exp(−β) ≈ 1e-12 instead of 0.
        for (j, w) in self.weights.iter_mut().enumerate() {
            let z = (l0 + j as f64 - xg) / w2;
            *w = KERNEL_BETA * ((1.0 - z * z).max(0.0).sqrt() - 1.0);
        }
        exp_neg(&mut self.weights);
        // Row of grid point l0: l0 ≥ −W/2 and l0 + W ≤ M + W/2 + 1 keep it inside the padding.
        let row0 = (l0 as isize + KERNEL_WIDTH as isize) as usize;
        let width = 2 * self.rx;
        let rows = &mut self.grid[row0 * width..(row0 + KERNEL_WIDTH) * width];
        for (row, &w) in rows.chunks_exact_mut(width).zip(&self.weights) {
            for (g, &cf) in row.iter_mut().zip(&self.coef) {
                *g += w * cf;
            }
        }
    }

    /// Fold the padding, transform and deapodize into `result`.
    fn finish(&mut self, nufft: &Nufft) {
        let (m, pad, width) = (nufft.grid, KERNEL_WIDTH, 2 * self.rx);
        for p in 0..pad {
            for i in 0..width {
                self.grid[(p + m) * width + i] += self.grid[p * width + i];
                self.grid[(p + pad) * width + i] += self.grid[(p + m + pad) * width + i];
            }
        }
        for (r, chirp) in self.result.chunks_exact_mut(nufft.samples).enumerate() {
            for (l, v) in self.line.iter_mut().enumerate() {
                let at = (l + pad) * width + 2 * r;
                *v = Complex64::new(self.grid[at], self.grid[at + 1]);
            }
            nufft
                .fft
                .process_with_scratch(&mut self.line, &mut self.fft_scratch);
            for (n, o) in chirp.iter_mut().enumerate() {
                *o = self.line[(n + m - nufft.half) % m] * nufft.deapod[n];
            }
        }
    }

    /// Add noise to `result`, round, clip and store it.
    fn write(&self, out: &mut [[i16; 2]], noise_std: f64, rng: &mut impl Rng) {
        for (o, v) in out.iter_mut().zip(&self.result) {
            let (mut i, mut q) = (v.re, v.im);
            if noise_std > 0.0 {
                let (ni, nq): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
                i += noise_std * ni;
                q += noise_std * nq;
            }
            *o = [to_i16(i), to_i16(q)];
        }
    }
}

/// Nearest integer of `v` for |v| < 2^51 (ties to even), without a libm call: adding and
/// removing 1.5·2^52 leaves no fraction bits.
#[inline(always)]
fn round_small(v: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    (v + MAGIC) - MAGIC
}

/// `exp(y)` in place for `−700 ≤ y ≤ 0` (the kernel's range; clamped), relative error below
/// 1e-15. Each step runs over the whole slice, so the steps of different values overlap and
/// vectorise, where libm's `exp` is one call (and one dependency chain) per value.
#[inline(always)]
fn exp_neg(y: &mut [f64]) {
    const LN2_HI: f64 = 0.6931471803691238;
    const LN2_LO: f64 = 1.9082149292705877e-10;
    // 1/k!, k = 13 down to 0: Taylor on |r| ≤ ln2/2, truncation 0.347^14/14! < 2e-18.
    const INV_FACT: [f64; 14] = [
        1.0 / 6_227_020_800.0,
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        1.0 / 2.0,
        1.0,
        1.0,
    ];
    const LANES: usize = 16;
    for chunk in y.chunks_mut(LANES) {
        let (mut k, mut r, mut p) = ([0.0; LANES], [0.0; LANES], [INV_FACT[0]; LANES]);
        for ((v, k), r) in chunk.iter().zip(&mut k).zip(&mut r) {
            let v = v.clamp(-700.0, 0.0);
            *k = round_small(v * std::f64::consts::LOG2_E);
            *r = (v - *k * LN2_HI) - *k * LN2_LO;
        }
        for &c in &INV_FACT[1..] {
            for (p, r) in p.iter_mut().zip(&r) {
                *p = *p * r + c;
            }
        }
        for ((v, p), k) in chunk.iter_mut().zip(&p).zip(&k) {
            *v = p * f64::from_bits(((*k as i64 + 1023) as u64) << 52);
        }
    }
}

/// `(sin x, cos x)` of every `x[i]` into `sin[i]`, `cos[i]`: absolute error below 1e-15 for
/// |x| < 1.6e6 (Cody–Waite reduction by π/2 in three parts, fdlibm's kernel polynomials on
/// [−π/4, π/4]); libm beyond. Batched like [`exp_neg`].
#[inline(always)]
pub(crate) fn sin_cos(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    // π/2 = PIO2_1 + PIO2_2 + PIO2_3, the first two with 33 significant bits (fdlibm), so
    // n·PIO2_1 and n·PIO2_2 are exact for |n| < 2^20.
    const PIO2_1: f64 = 1.5707963267341256;
    const PIO2_2: f64 = 6.077100506303966e-11;
    const PIO2_3: f64 = 2.0222662487111665e-21;
    const S: [f64; 6] = [
        -0.16666666666666632,
        0.00833333333332249,
        -0.0001984126982985795,
        2.7557313707070068e-06,
        -2.5050760253406863e-08,
        1.58969099521155e-10,
    ];
    const C: [f64; 6] = [
        0.0416666666666666,
        -0.001388888888887411,
        2.480158728947673e-05,
        -2.7557314351390663e-07,
        2.087572321298175e-09,
        -1.1359647557788195e-11,
    ];
    for ((&x, so), co) in x.iter().zip(sin).zip(cos) {
        if !(x.abs() < 1.6e6) {
            (*so, *co) = x.sin_cos();
            continue;
        }
        let n = round_small(x * std::f64::consts::FRAC_2_PI);
        let r = ((x - n * PIO2_1) - n * PIO2_2) - n * PIO2_3;
        let z = r * r;
        let ps = S[0] + z * (S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5]))));
        let pc = C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5]))));
        let s = r + r * z * ps;
        let c = 1.0 - 0.5 * z + z * z * pc;
        // Quadrant q: (sin, cos) = (s, c), (c, −s), (−s, −c), (−c, s).
        let q = n as i64;
        let (a, b) = if q & 1 == 0 { (s, c) } else { (c, s) };
        *so = if q & 2 == 0 { a } else { -a };
        *co = if (q + 1) & 2 == 0 { b } else { -b };
    }
}

/// Round half away from zero and clip to the int16 range.
pub fn to_i16(v: f64) -> i16 {
    v.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}

/// SplitMix64 of `seed` and `stream`: independent seeds for per-chirp noise generators.
pub(crate) fn mix(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_matches_libm() {
        // Phases from −1e5 to 1e5 rad, as in rendering (4πR/λ ≈ 5e4 at 15 m), and beyond the
        // reduction's range (libm path).
        let x: Vec<f64> = (0..200_000)
            .map(|i| (i as f64 - 100_000.0) * 1.000_123_456_7)
            .chain([2.0e6, -3.3e7, 0.0, -0.0])
            .collect();
        let (mut s, mut c) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        sin_cos(&x, &mut s, &mut c);
        let mut worst: f64 = 0.0;
        for ((x, s), c) in x.iter().zip(&s).zip(&c) {
            let (es, ec) = x.sin_cos();
            worst = worst.max((s - es).abs()).max((c - ec).abs());
        }
        // Both sides reduce the same f64 x; what remains is polynomial and rounding error.
        assert!(worst < 1e-15, "worst {worst:e}");
    }

    #[test]
    fn exp_neg_matches_libm() {
        let y: Vec<f64> = (0..100_000)
            .map(|i| -(i as f64) * 3.0e-4 * 1.000_37)
            .collect();
        let mut e = y.clone();
        exp_neg(&mut e);
        let worst = y
            .iter()
            .zip(&e)
            .map(|(y, e)| (e / y.exp() - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-15, "worst relative {worst:e}");
    }
}
