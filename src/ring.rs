//! Ring split: the two returns of a vertical surface's range ring, found from how much weaker
//! the elevation row sees them than the azimuth line (beyond the paper; `Params::ring_split`).
//!
//! A vertical surface (a wall, a pole, a tree trunk) at horizontal distance `ρ` returns from
//! range `r` at the heights `±√(r² − ρ²)` about the radar: two scatterers with one direction
//! cosine `μ` across the array, one Doppler, and elevations `±ν₀` symmetric about the
//! horizon. A line plus one elevation row (`Δ` above it) measures elevation by one phase, so
//! the pair looks like one source at its midpoint, and the point is reported at the horizon,
//! nearer the boresight than either return: `√(1 − μ² − ν²)` is too large and the point's
//! `−u·v` reads a faster radar than its Doppler does, by `≈ ν₀²/(2·u_x)` of the speed, most
//! at wide azimuth. Measured on the simulated odometry sequences (`dbe eval`, odometry
//! section, *v_r scale*): the static points' radial velocities 0.979–0.994 of what their
//! directions imply, falling from 0.998 near boresight to 0.93 at 60–75° azimuth, in both
//! chains — the bias of the ego-velocity and the drift along the path.
//!
//! The row sees what the line sees, rotated and scaled. On the point's Doppler bin (the
//! TDM-compensated slow time of every antenna, windowed and transformed at the point's
//! fractional Doppler) and de-steered to its azimuth `μ` (`t_m = z_m·e^{+j·κ·μ·x_m}`), every
//! element of the line holds `A` and every element of the row `E = c·A` with
//! `c = Σ s_i·e^{−j·κ·Δ·ν_i} / Σ s_i`. One source gives `|c| = 1`. An equal pair at `ν̄ ± δ`
//! whose lower return has the phase `φ` against the upper gives
//! `c = e^{−j·κ·Δ·ν̄}·(cos κΔδ − tan(φ/2)·sin κΔδ)`: exactly `cos κΔδ` in phase, and for a
//! phase that is uniform over the pairs (two halves of a rough surface) spread around it
//! with `cos κΔδ` as its median (`tan(φ/2)` is Cauchy). So:
//!
//! ```text
//! means     : A = mean of the line's t_m, E = mean of the row's, c = E / A
//! noise     : σ² = (Σ_line |t_m − A|² + Σ_row |t_m − E|²) / (M − 2)   (what one direction
//!             does not explain: noise, and returns of other azimuths)
//! accept    : |c| ≤ MAX_RATIO, 1 − |c| ≥ SIGMAS·σ_c (σ_c² = σ²·(1/M_row + |c|²/M_line)/|A|²),
//!             |arg c| ≤ HORIZON_PHASE (the midpoint at the horizon: a ring, not a floor and a
//!             ceiling at one range)
//! split     : δ = acos(Re c) / (κ·Δ); the point becomes two at ±δ about the horizon (ν = 0)
//! ```
//!
//! Centre: a ring's two returns sit symmetric about the radar's height, the horizon of a level
//! radar, and the test admits only pairs whose `c` puts their midpoint there. So the pair is
//! split about the horizon, not about the elevation stage's `ν̄`. Two returns of unequal
//! strength `a_up`, `a_lo` (a wall cut off by the floor at one of its heights, two patches of a
//! rough surface) in phase give `c = cos κΔδ − j·β·sin κΔδ` with
//! `β = (a_up − a_lo)/(a_up + a_lo)`: its phase pulls `ν̄` towards the stronger return and its
//! modulus is above `cos κΔδ`, but its real part is `cos κΔδ` whatever `β`. Split about `ν̄` by
//! `acos|c|`, as this module first did, such a pair's two points sat on the stronger return's
//! side: on the simulated aspen sequence the upper points' mean radial-velocity residual was
//! −0.032 m/s and the lower points' 0.000, a vertical bias of the ego-velocity. Split about
//! the horizon by `acos(Re c)` instead (`dbe eval`, odometry section, `dbe[ring split = on]`
//! rows, 5 seeds): XYZ drift hallways 0.32 → 0.39 %, outdoors 1.07 → 1.06 %, aspen
//! 0.32 → 0.13 %, army 0.43 → 0.31 % (without the split 0.49, 1.56, 0.17, 0.31 %), vertical
//! ego-velocity RMSE 0.087 / 0.058 / 0.030 / 0.051 → 0.085 / 0.048 / 0.027 / 0.046 m/s; the
//! point clouds' false points per scene frame 1.26 → 1.29 (defaults sweep).
//! A radar tilted by `ψ` sees the centre at `ψ` (the horizon test bounds it to
//! `HORIZON_PHASE / (κ·Δ)`): both points move by `ψ` and the split widens by `Re c`'s factor
//! `cos κΔψ` (at 2° on a row half a wavelength up: 0.994).
//!
//! What this can and cannot do: two rows measure one complex ratio, and a pair about the
//! horizon has three unknowns (separation, phase, amplitude ratio), so a single pair's
//! separation is exact only in phase (whatever the amplitudes); otherwise it is too wide when
//! `Re c` falls below `cos κΔδ` and the pair is not split when `|c|` lies above `MAX_RATIO`. Over many ring returns the split points straddle the
//! surface's true heights instead of all sitting at the radar's, which is what the
//! ego-velocity needs (the *v_r scale* moves towards 1); a single split point can be several
//! degrees off in elevation. A single scatterer is never split (`|c| = 1` up to the noise the
//! test measures); a floor return has one height per range and direction.
//! Measured by `dbe eval` (defaults sweep and odometry section).
//!
//! Where the false points come from (`dbe eval`, one run each, not kept): comparing each row
//! element with the line element below it (same azimuth position, so returns of other azimuths at
//! one height cancel exactly) instead of the row's mean with the line's split more points, not
//! fewer: false points per scene frame 1.26 → 1.61 with the fit's residual as the noise, 1.32 with
//! the line's spread added; and no split below `|c| = 0.5` only 1.26 → 1.21. The false points are
//! the pairs whose separation the phase `φ` widens, not leakage from other azimuths; the line's
//! spread about one direction, which this test counts as noise, is what keeps a cluttered Doppler
//! bin from being split.
//!
//! Real arrays: `|c|` is the row's amplitude against the line's, so the split needs the two matched
//! in gain to a few per cent. The row is fed by a different TX channel than most of the line;
//! without per-channel gains (`Frontend::set_channel_gains`, a TI `.cfg`'s
//! `compRangeBiasAndRxChanPhase`) the frontend takes the array as matched: on elements matched well
//! enough that `σ_c` stays small, a row 0.7 dB (8 %) weaker than the line splits every clean point
//! at the horizon, by `±acos(0.92)/(κΔ)` (±7° on a row half a wavelength up). On the TI IWR6843
//! capture in `../shared/fixtures` the corner reflector (the only point that reaches the test,
//! printed from the f64 reference) has `|c|` = 1.05, its row 0.46 dB stronger than the line, and
//! `σ_c` = 0.14 from the elements' uncalibrated spread, so nothing splits there; a board whose row
//! is weaker could. Check a recording first: a corner reflector must stay one point with the split
//! on.

use num_complex::Complex32;

/// Largest `|c|` split: `cos(π/8)`, pairs at least `±π/(8·κ·Δ)` apart in `ν` (±7.2° on a row
/// half a wavelength above the line). Nearer pairs move a point by less than the elevation
/// error the point already has at the SNRs of extended surfaces, and calibration errors of
/// real arrays reach a few per cent of `|c|`.
pub const MAX_RATIO: f32 = 0.923_879_5;
/// Largest `|arg c|`, radians: the pair's midpoint within `HORIZON_PHASE / (κ·Δ)` of the
/// horizon (3.6° on a row half a wavelength above the line), which allows for the tilt of a
/// handheld or vehicle rig.
pub const HORIZON_PHASE: f32 = 0.2;
/// `1 − |c|` must exceed this many standard deviations of `|c|`.
pub const SIGMAS: f32 = 3.0;

const ZERO: Complex32 = Complex32::new(0.0, 0.0);

/// The phase half-separation `κ·Δ·δ` of the pair in the de-steered Doppler-bin snapshot `t`
/// (the line's `line` elements first, then the row's), or `None` when it is not a ring pair
/// (module docs). Never panics; non-finite input gives `None`.
pub fn half_phase<const M: usize>(t: &[Complex32; M], line: usize) -> Option<f32> {
    if line < 2 || M < line + 2 {
        return None;
    }
    let (l, r) = t.split_at(line);
    let mean = |v: &[Complex32]| v.iter().fold(ZERO, |s, x| s + x) / v.len() as f32;
    let (a, e) = (mean(l), mean(r));
    let spread = |v: &[Complex32], m: Complex32| v.iter().map(|x| (x - m).norm_sqr()).sum::<f32>();
    let noise = (spread(l, a) + spread(r, e)) / (M - 2) as f32;
    let a2 = a.norm_sqr();
    if !(a2 > 0.0 && noise.is_finite()) {
        return None;
    }
    let c = e / a;
    let size = c.norm();
    let sigma = libm::sqrtf(noise * (1.0 / r.len() as f32 + size * size / l.len() as f32) / a2);
    let horizon = libm::fabsf(libm::atan2f(c.im, c.re));
    (size <= MAX_RATIO && 1.0 - size >= SIGMAS * sigma && horizon <= HORIZON_PHASE)
        .then(|| libm::acosf(c.re))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Line of 8 at positions 0..8 and a row of 4 at 2..6, `Δ` = half a wavelength (`κ·Δ = π`
    /// in phase per unit ν), sources `(amplitude, ν)` at one azimuth, de-steered.
    fn snapshot(sources: &[(f32, f32)], noise: &[Complex32; 12]) -> [Complex32; 12] {
        core::array::from_fn(|m| {
            let row = m >= 8;
            let s: Complex32 = sources
                .iter()
                .map(|&(a, nu)| {
                    let ph = if row {
                        -core::f32::consts::PI * nu
                    } else {
                        0.0
                    };
                    Complex32::from_polar(a, ph)
                })
                .sum();
            s + noise[m]
        })
    }

    fn noise(seed: u32, sigma: f32) -> [Complex32; 12] {
        let mut state = seed;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        core::array::from_fn(|_| Complex32::new(next(), next()) * (sigma * 3.46))
    }

    #[test]
    fn an_equal_pair_in_phase_about_the_horizon_is_split_at_its_separation() {
        for nu0 in [0.15f32, 0.25, 0.35] {
            let t = snapshot(&[(1.0, nu0), (1.0, -nu0)], &[ZERO; 12]);
            let h = half_phase(&t, 8).expect("split");
            assert!(
                (h / core::f32::consts::PI - nu0).abs() < 1e-5,
                "ν₀ {nu0}: {h}"
            );
        }
    }

    /// About the horizon and in phase, `Re c = cos κΔδ` whatever the two amplitudes; the
    /// imaginary part is the amplitude difference (module docs, "Centre").
    #[test]
    fn an_unequal_pair_in_phase_about_the_horizon_is_split_at_its_separation() {
        for (nu0, lower) in [(0.2f32, 0.7f32), (0.3, 1.3), (0.25, 0.85)] {
            let t = snapshot(&[(1.0, nu0), (lower, -nu0)], &[ZERO; 12]);
            let h = half_phase(&t, 8).expect("split");
            assert!(
                (h / core::f32::consts::PI - nu0).abs() < 1e-5,
                "ν₀ {nu0}, lower {lower}: {h}"
            );
        }
    }

    #[test]
    fn out_of_phase_the_split_follows_the_real_factor_of_c() {
        // c = cos θ − tan(φ/2)·sin θ, θ = κΔδ, φ the lower return's phase: φ = −90° gives
        // |c| > 1 (no split), φ = +90° a split at acos(cos θ − sin θ) > θ (module docs).
        let (nu0, pi) = (0.15f32, core::f32::consts::PI);
        let quadrature = |phi: f32| -> [Complex32; 12] {
            let (a, b) = (
                snapshot(&[(1.0, nu0)], &[ZERO; 12]),
                snapshot(&[(1.0, -nu0)], &[ZERO; 12]),
            );
            core::array::from_fn(|m| a[m] + b[m] * Complex32::from_polar(1.0, phi))
        };
        assert_eq!(half_phase(&quadrature(-pi / 2.0), 8), None);
        let theta = pi * nu0;
        let h = half_phase(&quadrature(pi / 2.0), 8).expect("split");
        assert!((h - libm::acosf(theta.cos() - theta.sin())).abs() < 1e-4 && h > theta);
    }

    #[test]
    fn a_single_source_or_a_near_pair_is_not_split() {
        for nu in [-0.3f32, 0.0, 0.05, 0.3] {
            let t = snapshot(&[(1.0, nu)], &noise(7, 0.05));
            assert_eq!(half_phase(&t, 8), None, "ν {nu}");
        }
        // ±0.1: |c| = cos(0.1π) = 0.95 > MAX_RATIO.
        let t = snapshot(&[(1.0, 0.1), (1.0, -0.1)], &[ZERO; 12]);
        assert_eq!(half_phase(&t, 8), None);
    }

    #[test]
    fn a_pair_off_the_horizon_or_lost_in_noise_is_not_split() {
        // Floor and ceiling: midpoint at ν = 0.2 (phase 0.63 rad).
        let t = snapshot(&[(1.0, 0.45), (1.0, -0.05)], &[ZERO; 12]);
        assert_eq!(half_phase(&t, 8), None);
        // An equal ring pair whose |c| deficit is within the noise.
        let t = snapshot(&[(1.0, 0.15), (1.0, -0.15)], &noise(3, 0.6));
        assert_eq!(half_phase(&t, 8), None);
    }

    #[test]
    fn degenerate_input_is_not_split() {
        assert_eq!(half_phase(&[ZERO; 12], 8), None);
        let mut t = snapshot(&[(1.0, 0.2), (1.0, -0.2)], &[ZERO; 12]);
        t[3] = Complex32::new(f32::NAN, 0.0);
        assert_eq!(half_phase(&t, 8), None);
        assert_eq!(half_phase(&t, 1), None);
        assert_eq!(half_phase(&[Complex32::new(1.0, 0.0); 3], 2), None);
    }
}
