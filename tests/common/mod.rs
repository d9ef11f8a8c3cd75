//! Test-only frame synthesis from the spec §2 signal model, independent of the core's DSP.
#![allow(dead_code)]

use dbe_radar::config::SPEED_OF_LIGHT;
use dbe_radar::presets::coloradar as p;
use dbe_radar::{AntennaGeometry, ChirpId, ConfigError, Params, Waveform};
use rand::{Rng, SeedableRng};

/// A point scatterer: position (m) at the frame start, velocity (m/s), amplitude (LSB).
#[derive(Clone, Copy, Debug)]
pub struct Target {
    pub pos: [f64; 3],
    pub vel: [f64; 3],
    pub amp: f64,
}

impl Target {
    /// A static target at range `r`, azimuth `az_deg` (φ), elevation `el_deg` (θ), moving
    /// radially at `v` (m/s, positive receding).
    pub fn polar(r: f64, az_deg: f64, el_deg: f64, v: f64, amp: f64) -> Self {
        let (az, el) = (az_deg.to_radians(), el_deg.to_radians());
        // μ = −u_y = cos θ · sin φ, ν = u_z = sin θ (spec §2).
        let u = [el.cos() * az.cos(), -el.cos() * az.sin(), el.sin()];
        Self {
            pos: [r * u[0], r * u[1], r * u[2]],
            vel: [v * u[0], v * u[1], v * u[2]],
            amp,
        }
    }

    /// μ, ν of the target at the frame start.
    pub fn mu_nu(&self) -> (f64, f64) {
        let r = norm(self.pos);
        (-self.pos[1] / r, self.pos[2] / r)
    }
}

pub fn norm(p: [f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

/// A frame's chirps in TDM order: `chirps[k·TX + t][r][n] = [I, Q]`; every target's carrier
/// phase drawn at random.
pub fn synth<const N: usize, const K: usize, const TX: usize, const RX: usize>(
    w: &Waveform,
    g: &AntennaGeometry<TX, RX>,
    targets: &[Target],
    noise_std: f64,
    seed: u64,
) -> Vec<[[[i16; 2]; N]; RX]> {
    synth_phased::<N, K, TX, RX>(w, g, targets, None, noise_std, seed)
}

/// [`synth`] with the targets' carrier phases given (radians, one per target) instead of
/// drawn.
pub fn synth_phased<const N: usize, const K: usize, const TX: usize, const RX: usize>(
    w: &Waveform,
    g: &AntennaGeometry<TX, RX>,
    targets: &[Target],
    given: Option<&[f64]>,
    noise_std: f64,
    seed: u64,
) -> Vec<[[[i16; 2]; N]; RX]> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let fc = w.start_frequency_hz + w.slope_hz_per_s * (N as f64 / w.adc_sample_rate_hz) / 2.0;
    // Spec §2 (amended): the range phase's carrier is the first sample's frequency f_0, which
    // is f_start here (the core's waveform has no ADC start time, i.e. t_adc = 0).
    let lambda = SPEED_OF_LIGHT / w.start_frequency_hz;
    let kappa = std::f64::consts::PI * fc / g.f_design_hz;
    let tc = w.idle_time_s + w.ramp_end_time_s;
    let t_loop = TX as f64 * tc;
    let phases: Vec<f64> = match given {
        Some(p) => {
            assert_eq!(p.len(), targets.len(), "one phase per target");
            p.to_vec()
        }
        None => targets
            .iter()
            .map(|_| rng.gen_range(0.0..std::f64::consts::TAU))
            .collect(),
    };
    let mut out = vec![[[[0i16; 2]; N]; RX]; K * TX];
    for k in 0..K {
        for t in 0..TX {
            let tau = k as f64 * t_loop + t as f64 * tc;
            let chirp = &mut out[k * TX + t];
            for (r, rx) in chirp.iter_mut().enumerate() {
                let az = f64::from(g.tx[t].0 + g.rx[r].0);
                let el = f64::from(g.tx[t].1 + g.rx[r].1);
                let mut acc = vec![(0.0f64, 0.0f64); N];
                for (tg, phi0) in targets.iter().zip(phases.iter()) {
                    let p = [
                        tg.pos[0] + tg.vel[0] * tau,
                        tg.pos[1] + tg.vel[1] * tau,
                        tg.pos[2] + tg.vel[2] * tau,
                    ];
                    let range = norm(p);
                    let (mu, nu) = (-p[1] / range, p[2] / range);
                    let beat = 2.0 * w.slope_hz_per_s * range / SPEED_OF_LIGHT;
                    let base = 4.0 * std::f64::consts::PI * range / lambda
                        - kappa * (mu * az + nu * el)
                        + phi0;
                    for (n, a) in acc.iter_mut().enumerate() {
                        let ph =
                            std::f64::consts::TAU * beat * n as f64 / w.adc_sample_rate_hz + base;
                        a.0 += tg.amp * ph.cos();
                        a.1 += tg.amp * ph.sin();
                    }
                }
                for (s, a) in rx.iter_mut().zip(acc.iter()) {
                    let i = a.0 + noise_std * gauss(&mut rng);
                    let q = a.1 + noise_std * gauss(&mut rng);
                    *s = [quantise(i), quantise(q)];
                }
            }
        }
    }
    out
}

fn quantise(x: f64) -> i16 {
    x.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}

fn gauss(rng: &mut impl Rng) -> f64 {
    // Box–Muller.
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Chirp id of the `i`-th chirp in TDM order.
pub fn id(i: usize, tx: usize) -> ChirpId {
    ChirpId::in_tdm_order(i, tx)
}

/// Heap storage for a cube (never on the test thread's stack).
pub fn storage<const N: usize, const K: usize, const M: usize>(
) -> Box<dbe_radar::cube::CubeStorage<N, K, M>> {
    let v = vec![[[[0i16; 2]; M]; K]; N];
    match v.into_boxed_slice().try_into() {
        Ok(b) => b,
        Err(_) => unreachable!("length is N"),
    }
}

/// The ColoRadar-preset frontend and DBE chain for `w`, `g` and `params`: the frontend's
/// error if it rejects the sensor, else the chain's.
pub fn dbe_for(
    w: Waveform,
    g: AntennaGeometry<3, 4>,
    params: Params,
) -> Result<(p::Frontend, p::Dbe), ConfigError> {
    let frontend = p::Frontend::new(w, g, params.range_window)?;
    let dbe = p::Dbe::new(&frontend, params)?;
    Ok((frontend, dbe))
}
