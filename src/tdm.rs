//! TDM-MIMO motion compensation (beyond the paper; on by default in both chains).
//!
//! TX slot `t` fires `t·Tc` after slot 0 of its loop, so a target moving at radial velocity `v`
//! adds the phase `4π·v·t·Tc/λ` to every row of slot `t`. With `v = d·λ/(2·K·TX·Tc)` for a
//! Doppler of `d` bins this is `2π·d·t/(K·TX)`, and the rows are compensated by multiplying
//! row `m` (slot `t_m`) with `exp(−j·2π·d·t_m/(K·TX))`: on the covariance as `D·R·Dᴴ`
//! ([`crate::covariance::rotate_rows`], DBE chain), on one Doppler cell as `x_m·d_m` (FFT
//! chain). Without it a target at 1 m/s gets its elevation wrong by more than 10° on
//! ColoRadar's waveform.
//!
//! The DBE chain takes `d` from the Doppler FFT of the azimuth Capon beam of the detection
//! (see [`crate::Dbe`]), the FFT chain from its range–Doppler detection.

use num_complex::Complex32;

/// The compensation `exp(−j·2π·d·t_m/(K·TX))` of every row, for a Doppler of `doppler_bins`
/// (signed, may be fractional) and the TDM slot `slots[m]` of each row.
pub fn rotation<const K: usize, const TX: usize, const M: usize>(
    slots: &[u8; M],
    doppler_bins: f32,
) -> [Complex32; M] {
    let per_slot = -core::f32::consts::TAU * doppler_bins / (K * TX) as f32;
    let phase = |slot: f32| Complex32::from_polar(1.0, per_slot * slot);
    // One sine and cosine per slot, not per row: `libm`'s `sinf`/`cosf` work in `f64`, which
    // a Cortex-M4F emulates in software (about 14,000 instructions for the 12 rows of a
    // 3 × 4 array; issue 13). Rows of one slot get the same value as before, bit for bit.
    let by_slot: [Complex32; TX] = core::array::from_fn(|t| phase(t as f32));
    let mut rot = [Complex32::new(1.0, 0.0); M];
    for (o, &slot) in rot.iter_mut().zip(slots.iter()) {
        *o = match by_slot.get(usize::from(slot)) {
            Some(&r) => r,
            None => phase(f32::from(slot)),
        };
    }
    rot
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One phase per slot gives every row the value of its own `from_polar`, bit for bit,
    /// a slot number beyond `TX` included (computed directly).
    #[test]
    fn per_slot_phases_are_the_per_row_phases() {
        let slots = [0u8, 0, 1, 1, 2, 2, 0, 2, 1, 5];
        for d in [-63.7f32, -1.0, 0.0, 0.25, 17.5, 64.0] {
            let rot = rotation::<128, 3, 10>(&slots, d);
            let per_slot = -core::f32::consts::TAU * d / (128 * 3) as f32;
            for (r, &s) in rot.iter().zip(slots.iter()) {
                let want = Complex32::from_polar(1.0, per_slot * f32::from(s));
                assert_eq!(
                    (r.re.to_bits(), r.im.to_bits()),
                    (want.re.to_bits(), want.im.to_bits())
                );
            }
        }
    }
}
