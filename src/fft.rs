//! Complex FFT of a compile-time size: radix-4 decimation in time (when `log2 N` is odd, a
//! radix-2 stage first, fused with the first radix-4 stage into one radix-8 pass), twiddles
//! from one table computed at compile time.
//!
//! Normalisation: none. `X[k] = Σ_n x[n] · exp(−j·2π·k·n/N)`, bins in natural order
//! (bin 0 = DC, bin `N/2..N` the negative frequencies, not fftshifted).
//!
//! [`fft_from`] reads its input through a function of the sample index, in bit-reversed
//! order, inside the first butterfly pass: the caller's conversion, DC removal and window
//! (range FFT) or window (Doppler FFT) cost no pass of their own, and no permutation pass
//! is needed. Per radix-4 butterfly: 3 complex multiplies and 8 complex additions, against
//! 4 and 8 for two radix-2 stages, and half the passes over the buffer (issue 13: on the
//! Cortex-M4F the ColoRadar range FFT with its window and DC removal took 8,520
//! instructions per chirp and antenna when it replaced `microfft`'s radix-2 at 10,160; the
//! fused radix-8 first pass took the whole ingest of a chirp, store included, from 43,687 to
//! 40,929 instructions, `cargo xtask budget`).
//!
//! Twiddles: `W^i = e^{−j2πi/MAX_FFT_SIZE}` for `i < MAX_FFT_SIZE`, evaluated in `f64` by a
//! `const fn` (Taylor series on the first octant, symmetry for the rest) and rounded to
//! `f32`, so the table sits in flash (4 KiB), costs no setup and no RAM; an `N`-point
//! transform reads every `MAX_FFT_SIZE / N`-th entry.

use core::ops::{Add, Sub};

use num_complex::Complex32;

/// Largest FFT size (samples per chirp or loops per frame) the table covers.
pub const MAX_FFT_SIZE: usize = 512;

/// `W^i = e^{−j2πi/MAX_FFT_SIZE}`, `i = 0..MAX_FFT_SIZE`.
static TWIDDLES: [Complex32; MAX_FFT_SIZE] = twiddle_table();

/// `(sin x, cos x)` for `|x| ≤ π/4` by their Taylor series to the 22nd/23rd power (the
/// next term is below 10⁻²⁴ there).
const fn sin_cos_octant(x: f64) -> (f64, f64) {
    let x2 = x * x;
    let (mut s, mut c) = (0.0f64, 0.0f64);
    let mut n = 12;
    // Horner from the highest terms: sin = x(1 − x²/(2·3)(1 − x²/(4·5)(…))), cos alike.
    while n > 0 {
        let (ns, nc) = (
            (2 * n) as f64 * (2 * n + 1) as f64,
            (2 * n - 1) as f64 * (2 * n) as f64,
        );
        s = 1.0 - x2 / ns * s;
        c = 1.0 - x2 / nc * c;
        n -= 1;
    }
    (x * s, c)
}

/// The twiddle table, from the first octant by symmetry.
const fn twiddle_table() -> [Complex32; MAX_FFT_SIZE] {
    let mut t = [Complex32::new(0.0, 0.0); MAX_FFT_SIZE];
    let eighth = MAX_FFT_SIZE / 8;
    let mut i = 0;
    while i < MAX_FFT_SIZE {
        // Angle 2πi/MAX = q·π/2 + r with r in [−π/4, π/4].
        let quarter = MAX_FFT_SIZE / 4;
        let mut q = i / quarter;
        let mut rem = (i % quarter) as i64;
        if rem > eighth as i64 {
            rem -= quarter as i64;
            q += 1;
        }
        let r = core::f64::consts::TAU * rem as f64 / MAX_FFT_SIZE as f64;
        let (s, c) = sin_cos_octant(r);
        // cos and sin of q·π/2 + r.
        let (cos, sin) = match q % 4 {
            0 => (c, s),
            1 => (-s, c),
            2 => (-c, -s),
            _ => (s, -c),
        };
        // e^{−jθ} = cos θ − j sin θ.
        t[i] = Complex32::new(cos as f32, -sin as f32);
        i += 1;
    }
    t
}

/// What the FFT transforms: one complex number ([`Complex32`]), or the same bin of `L`
/// independent transforms side by side ([`Lanes`]).
///
/// The transform only adds, subtracts, multiplies by a twiddle and by `−j`; an
/// implementation must do exactly the `f32` operations of [`Complex32`]'s, in its order, per
/// lane, so that every lane of a [`Lanes`] transform is bit-identical to the transform of
/// that lane alone.
pub trait FftValue: Copy + Add<Output = Self> + Sub<Output = Self> {
    /// `self · w` (a complex product, `num_complex`'s formula).
    fn times(self, w: Complex32) -> Self;
    /// `(self + (−j)·b, self − (−j)·b)`.
    fn plus_minus_neg_j(self, b: Self) -> (Self, Self);
    /// `(−j)·self = (im, −re)`: `self.times(−j)` up to the sign of an exact zero.
    fn times_neg_j(self) -> Self;
}

impl FftValue for Complex32 {
    #[inline(always)]
    fn times(self, w: Complex32) -> Self {
        self * w
    }

    #[inline(always)]
    fn plus_minus_neg_j(self, b: Self) -> (Self, Self) {
        // −j·b = (b.im, −b.re).
        (
            Complex32::new(self.re + b.im, self.im - b.re),
            Complex32::new(self.re - b.im, self.im + b.re),
        )
    }

    #[inline(always)]
    fn times_neg_j(self) -> Self {
        Complex32::new(self.im, -self.re)
    }
}

/// The same bin of `L` transforms, real and imaginary parts in separate arrays: on a core
/// with SIMD registers (`L = 4`: SSE, NEON) each operation is one vector instruction, so `L`
/// transforms cost about one (the host's range FFT of a chirp's 4 RX channels; issue 13).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lanes<const L: usize> {
    /// Real parts, one per transform.
    pub re: [f32; L],
    /// Imaginary parts, one per transform.
    pub im: [f32; L],
}

impl<const L: usize> Lanes<L> {
    /// All lanes zero.
    pub const ZERO: Self = Self {
        re: [0.0; L],
        im: [0.0; L],
    };

    /// Lane `l` as a complex number (`l < L`).
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Complex32 {
        Complex32::new(self.re[l], self.im[l])
    }
}

impl<const L: usize> Add for Lanes<L> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, b: Self) -> Self {
        for l in 0..L {
            self.re[l] += b.re[l];
            self.im[l] += b.im[l];
        }
        self
    }
}

impl<const L: usize> Sub for Lanes<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, b: Self) -> Self {
        for l in 0..L {
            self.re[l] -= b.re[l];
            self.im[l] -= b.im[l];
        }
        self
    }
}

impl<const L: usize> FftValue for Lanes<L> {
    #[inline(always)]
    fn times(self, w: Complex32) -> Self {
        let mut out = self;
        for l in 0..L {
            out.re[l] = self.re[l] * w.re - self.im[l] * w.im;
            out.im[l] = self.re[l] * w.im + self.im[l] * w.re;
        }
        out
    }

    #[inline(always)]
    fn plus_minus_neg_j(self, b: Self) -> (Self, Self) {
        let (mut p, mut m) = (self, self);
        for l in 0..L {
            p.re[l] = self.re[l] + b.im[l];
            p.im[l] = self.im[l] - b.re[l];
            m.re[l] = self.re[l] - b.im[l];
            m.im[l] = self.im[l] + b.re[l];
        }
        (p, m)
    }

    #[inline(always)]
    fn times_neg_j(self) -> Self {
        let mut out = self;
        for l in 0..L {
            out.re[l] = self.im[l];
            out.im[l] = -self.re[l];
        }
        out
    }
}

/// Bit reversal of `i` over `bits` bits (`1 ≤ bits ≤ 31`).
#[inline(always)]
fn reverse(i: usize, bits: u32) -> usize {
    ((i as u32).reverse_bits() >> (32 - bits)) as usize
}

/// Transform `buf` in place.
///
/// `N` must be a power of two from 2 to [`MAX_FFT_SIZE`]; anything else is a compile error.
///
/// ```
/// use num_complex::Complex32;
/// let mut x = [Complex32::new(1.0, 0.0); 8];
/// dbe_radar::fft::fft_in_place(&mut x);
/// assert!((x[0].re - 8.0).abs() < 1e-6 && x[1].norm() < 1e-6);
/// ```
pub fn fft_in_place<const N: usize>(buf: &mut [Complex32; N]) {
    let x = *buf;
    fft_from(buf, |n| x[n & (N - 1)]);
}

/// The FFT of `x(0), …, x(N − 1)` into `out`; `x` is called once per index, with indices
/// `< N` in bit-reversed order.
///
/// `N` must be a power of two from 2 to [`MAX_FFT_SIZE`]; anything else is a compile error.
///
/// ```
/// use num_complex::Complex32;
/// // A windowed real ramp, windowing fused into the transform.
/// let (w, v) = ([0.5f32; 4], [1.0f32, 2.0, 3.0, 4.0]);
/// let mut out = [Complex32::new(0.0, 0.0); 4];
/// dbe_radar::fft::fft_from(&mut out, |n| Complex32::new(v[n & 3] * w[n & 3], 0.0));
/// assert_eq!(out[0], Complex32::new(5.0, 0.0));
/// assert_eq!(out[1], Complex32::new(-1.0, 1.0));
/// ```
#[inline]
pub fn fft_from<T: FftValue, const N: usize>(out: &mut [T; N], x: impl Fn(usize) -> T) {
    const { assert!(N.is_power_of_two() && N >= 2 && N <= MAX_FFT_SIZE) };
    let bits = N.trailing_zeros();
    let l = if N == 2 {
        let (a, b) = (x(0), x(1));
        out[0] = a + b;
        out[1] = a - b;
        2
    } else if bits % 2 == 1 {
        first_radix8_pass(out, &x, bits);
        8
    } else {
        // One radix-4 stage without twiddles: positions i..i + 4 hold
        // x(r), x(r + N/2), x(r + N/4), x(r + 3N/4).
        for (i, quad) in out.chunks_exact_mut(4).enumerate() {
            let r = reverse(4 * i, bits);
            let (a0, a2, a1, a3) = (x(r), x(r + N / 2), x(r + N / 4), x(r + 3 * N / 4));
            let [y0, y1, y2, y3] = butterfly4(a0, a1, a2, a3);
            quad.copy_from_slice(&[y0, y1, y2, y3]);
        }
        4
    };
    radix4_stages(out, l);
}

/// The first two stages of an odd-`log2 N` transform (`N ≥ 8`) in one pass, eight outputs at a
/// time held in registers: a radix-2 stage (pair `i` = `x(r) ± x(r + N/2)`, `r = rev(2i)`)
/// and the radix-4 stage of length-2 sub-transforms, whose twiddles are `W_8^{m·k}`, `k < 2`.
/// Its `k = 0` butterfly has only unit twiddles and its `k = 1` butterfly the factor
/// `W_8^2 = −j` for residue 2, which are not multiplied: the same values as the two separate
/// stages up to the sign of an exact zero, with one pass over the buffer fewer (issue 13).
#[inline(always)]
fn first_radix8_pass<T: FftValue, const N: usize>(
    out: &mut [T; N],
    x: &impl Fn(usize) -> T,
    bits: u32,
) {
    // W_8^1 and W_8^3 (the table's `W^{MAX/8}`, `W^{3·MAX/8}`).
    let (w1, w3) = (TWIDDLES[MAX_FFT_SIZE / 8], TWIDDLES[3 * MAX_FFT_SIZE / 8]);
    for (g, oct) in out.chunks_exact_mut(8).enumerate() {
        // Pair `4g + j` reads `rev(8g + 2j) = rev(8g) + rev(2j)` (the bits of `2j` lie below
        // those of `8g`, so they reverse to disjoint positions): one bit reversal per group,
        // the offsets `rev(2j)` = 0, N/4, N/8, 3N/8 constants.
        let base = reverse(8 * g, bits);
        let pair = |offset: usize| {
            let r = base + offset;
            let (a, b) = (x(r), x(r + N / 2));
            (a + b, a - b)
        };
        let (p0, p1, p2, p3) = (pair(0), pair(N / 4), pair(N / 8), pair(3 * N / 8));
        // Blocks of the length-8 group hold residues 0, 2, 1, 3 (see `radix4_stages`).
        let [y0, y2, y4, y6] = butterfly4(p0.0, p2.0, p1.0, p3.0);
        let [y1, y3, y5, y7] = butterfly4(p0.1, p2.1.times(w1), p1.1.times_neg_j(), p3.1.times(w3));
        oct.copy_from_slice(&[y0, y1, y2, y3, y4, y5, y6, y7]);
    }
}

/// The 4-point DFT `X[q] = Σ_m t_m · (−j)^{mq}`.
#[inline(always)]
fn butterfly4<T: FftValue>(t0: T, t1: T, t2: T, t3: T) -> [T; 4] {
    let (s02, d02, s13, d13) = (t0 + t2, t0 - t2, t1 + t3, t1 - t3);
    let (p, m) = d02.plus_minus_neg_j(d13);
    [s02 + s13, p, s02 - s13, m]
}

/// Radix-4 stages from sub-transforms of length `l` up to `N`. In bit-reversed order the four
/// length-`l` blocks of a `4l` group hold the sub-transforms of residues 0, 2, 1, 3.
#[inline(always)]
fn radix4_stages<T: FftValue, const N: usize>(buf: &mut [T; N], mut l: usize) {
    while l < N {
        let span = 4 * l;
        // W_{4l}^k = W^{k · MAX/(4l)}; 3k · MAX/(4l) < MAX for k < l.
        let step = MAX_FFT_SIZE / span;
        for group in buf.chunks_exact_mut(span) {
            let (q01, q23) = group.split_at_mut(2 * l);
            let (q0, q1) = q01.split_at_mut(l);
            let (q2, q3) = q23.split_at_mut(l);
            for (k, (((y0, y1), y2), y3)) in q0
                .iter_mut()
                .zip(q1.iter_mut())
                .zip(q2.iter_mut())
                .zip(q3.iter_mut())
                .enumerate()
            {
                // The mask is a no-op (the index is below MAX) that lets the compiler drop
                // the bounds checks.
                let w = |m: usize| TWIDDLES[(m * k * step) & (MAX_FFT_SIZE - 1)];
                // Block 1 holds residue 2, block 2 residue 1.
                let (t0, t2, t1, t3) = (*y0, y1.times(w(2)), y2.times(w(1)), y3.times(w(3)));
                [*y0, *y1, *y2, *y3] = butterfly4(t0, t1, t2, t3);
            }
        }
        l = span;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn naive_dft(x: &[Complex32]) -> [num_complex::Complex64; 512] {
        let n = x.len();
        let mut out = [num_complex::Complex64::new(0.0, 0.0); 512];
        for (k, o) in out.iter_mut().take(n).enumerate() {
            for (i, v) in x.iter().enumerate() {
                let ph = -2.0 * core::f64::consts::PI * (k * i % n) as f64 / n as f64;
                *o += num_complex::Complex64::new(v.re as f64, v.im as f64)
                    * num_complex::Complex64::from_polar(1.0, ph);
            }
        }
        out
    }

    fn check<const N: usize>(seed: u64) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut x = [Complex32::new(0.0, 0.0); N];
        for v in x.iter_mut() {
            *v = Complex32::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        }
        let reference = naive_dft(&x);
        fft_in_place(&mut x);
        // f32 radix-2 error grows like ε·log2(N)·‖x‖; ‖X‖∞ ≤ N, so 1e-5·N is generous but tight
        // enough to catch any wrong twiddle or ordering (those give O(1) errors).
        let tol = 1e-5 * N as f64;
        for k in 0..N {
            let d =
                (reference[k] - num_complex::Complex64::new(x[k].re as f64, x[k].im as f64)).norm();
            assert!(d < tol, "N={N} bin {k}: error {d}");
        }
    }

    #[test]
    fn the_twiddle_table_is_exact_to_f32_rounding() {
        for (i, w) in TWIDDLES.iter().enumerate() {
            let th = -core::f64::consts::TAU * i as f64 / MAX_FFT_SIZE as f64;
            let (c, s) = (libm::cos(th), libm::sin(th));
            // Rounded to nearest from an f64 accurate to ~1e-16: within half an f32 ulp of
            // the value (≤ 2^-25 for |v| ≤ 1), plus the f64 error.
            assert!((f64::from(w.re) - c).abs() <= 3.0e-8, "cos at {i}");
            assert!((f64::from(w.im) - s).abs() <= 3.0e-8, "sin at {i}");
        }
    }

    #[test]
    fn fft_from_reads_every_index_once() {
        let mut seen = [0u8; 64];
        let seen_cell = core::cell::RefCell::new(&mut seen);
        let mut out = [Complex32::new(0.0, 0.0); 64];
        fft_from(&mut out, |n| {
            seen_cell.borrow_mut()[n] += 1;
            Complex32::new(n as f32, 0.0)
        });
        assert!(seen.iter().all(|&c| c == 1));
    }

    #[test]
    fn every_lane_is_the_single_transform_bit_for_bit() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let x: [[Complex32; 128]; 4] = core::array::from_fn(|_| {
            core::array::from_fn(|_| {
                Complex32::new(rng.gen_range(-1e4..1e4), rng.gen_range(-1e4..1e4))
            })
        });
        let mut lanes = [Lanes::<4>::ZERO; 128];
        fft_from(&mut lanes, |n| Lanes {
            re: core::array::from_fn(|l| x[l][n & 127].re),
            im: core::array::from_fn(|l| x[l][n & 127].im),
        });
        for (l, xl) in x.iter().enumerate() {
            let mut single = *xl;
            fft_in_place(&mut single);
            for (n, (s, v)) in single.iter().zip(lanes.iter()).enumerate() {
                let v = v.lane(l);
                assert!(
                    s.re.to_bits() == v.re.to_bits() && s.im.to_bits() == v.im.to_bits(),
                    "lane {l} bin {n}: {s} vs {v}"
                );
            }
        }
    }

    #[test]
    fn every_size_matches_naive_dft() {
        check::<2>(1);
        check::<4>(2);
        check::<8>(3);
        check::<16>(4);
        check::<32>(5);
        check::<64>(6);
        check::<128>(7);
        check::<256>(8);
        check::<512>(9);
    }
}
