//! The radar cube and its chirp-by-chirp ingestion bookkeeping.
//!
//! Layout: `cube[range bin][loop][row]` with rows in [`crate::config::ArrayLayout`] order, so
//! one range bin's `K × M` snapshot block is contiguous, the first `AZ` rows of each loop are
//! the azimuth line, and a chirp's RX channels (consecutive rows) land side by side: while a
//! frame is ingested, the cube lines being written are one or two per range bin (a few KiB,
//! cache-resident on a host) instead of one per range bin and row (`dbe bench`: host ingest
//! 0.99 → 0.74 ms per ColoRadar frame). The storage is caller-owned (a `static` on firmware,
//! a `Box` on a host), so no megabyte-sized value ever passes through the stack.
//!
//! Precision: block floating point per chirp. Each range-FFT output (one row, one loop) is
//! stored as complex i16 mantissas with one shared exponent `e` (in [`Cube`]), the smallest
//! that fits the chirp's largest component into ±32767: `x = mantissa · 2^e`. The error is at
//! most half a mantissa step, 2^(e−1), i.e. below 2⁻¹⁵ of the chirp's strongest bin per
//! component: 90 dB of dynamic range per chirp, against the ~75 dB between an int16 ADC's
//! full scale and its noise after the range FFT. This halves the cube against `Complex32`
//! (the AWR1843 itself stores its cube as complex i16).
//!
//! A cube is filled by [`crate::Frontend::push_chirp`]; when all `K · TX` chirps have arrived
//! in order, [`crate::Frontend::frame`] turns it into a [`Frame`], the checked input of both
//! chains, whose [`Frame::snapshots`] turns one range bin back into `f32`.

use core::fmt;

use num_complex::Complex32;

#[cfg(not(target_arch = "arm"))]
use crate::fft::Lanes;

/// One stored range-FFT value: `[re, im]` mantissas of its chirp's block exponent.
pub type CubeSample = [i16; 2];

/// One range bin's snapshots in `f32`: `M` rows × `K` loops (the bin in flight).
pub type Snapshots<const K: usize, const M: usize> = [[Complex32; K]; M];

/// Storage of a whole cube: `N` range bins of `K × M` mantissas (`[bin][loop][row]`).
pub type CubeStorage<const N: usize, const K: usize, const M: usize> = [[[CubeSample; M]; K]; N];

/// Zeroed cube storage, for `static` initialisation on firmware.
pub const fn zero_storage<const N: usize, const K: usize, const M: usize>() -> CubeStorage<N, K, M>
{
    [[[[0; 2]; M]; K]; N]
}

/// A block exponent `e` of range spectra computed off the core ([`crate::Frontend::push_range_blocks`]):
/// the spectrum is `mantissa · 2^e`. Valid from −125 to 112: `2^e` a normal `f32`, and every
/// mantissa times it finite (`2^15 · 2^112 = 2^127`); the cube's own exponents, of spectra
/// from i16 samples, lie far inside.
///
/// ```
/// use dbe_radar::cube::BlockExponent;
/// assert_eq!(BlockExponent::new(-3).map(BlockExponent::get), Some(-3));
/// assert!(BlockExponent::new(112).is_some() && BlockExponent::new(113).is_none());
/// assert!(BlockExponent::new(-125).is_some() && BlockExponent::new(-126).is_none());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BlockExponent(i8);

impl BlockExponent {
    /// The largest valid exponent.
    pub const MAX: i8 = 112;

    /// `e`, or `None` outside −125..=[`Self::MAX`].
    pub const fn new(e: i8) -> Option<Self> {
        match (e as i32) >= -EXPONENT_LIMIT && e <= Self::MAX {
            true => Some(Self(e)),
            false => None,
        }
    }

    /// The exponent.
    pub const fn get(self) -> i8 {
        self.0
    }

    /// `2^e`.
    pub fn factor(self) -> f32 {
        stored_pow2(self.0)
    }
}

/// Which chirp of a frame: loop index `k` and TDM slot (TX data index) `t`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ChirpId {
    /// Loop (slow-time) index, `0..K`.
    pub loop_index: u16,
    /// TX slot, `0..TX`.
    pub tx_slot: u8,
}

impl ChirpId {
    /// The `i`-th chirp of a frame in TDM order with `tx` slots: loop `i / tx`, slot
    /// `i % tx` (loop 0 slot 0, loop 0 slot 1, …, loop 1 slot 0, …), the order
    /// [`crate::Frontend::push_chirp`] takes. `tx = 0` gives loop 0 slot 0; the loop index
    /// wraps beyond `u16::MAX` (a frontend holds at most `i16::MAX` loops).
    pub const fn in_tdm_order(i: usize, tx: usize) -> Self {
        if tx == 0 {
            return Self {
                loop_index: 0,
                tx_slot: 0,
            };
        }
        Self {
            loop_index: (i / tx) as u16,
            tx_slot: (i % tx) as u8,
        }
    }
}

/// Every chirp of a frame of `loops` loops with `tx` TX slots, in TDM order
/// ([`ChirpId::in_tdm_order`] of `0..loops·tx`; [`crate::Frontend::tdm_order`] for a
/// frontend's own shape).
pub fn tdm_order(loops: usize, tx: usize) -> impl Iterator<Item = ChirpId> + Clone {
    (0..loops.saturating_mul(tx)).map(move |i| ChirpId::in_tdm_order(i, tx))
}

impl fmt::Display for ChirpId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "loop {} TX slot {}", self.loop_index, self.tx_slot)
    }
}

/// Why a frame cannot be processed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// A chirp arrived out of TDM order: one was missing, repeated or reordered.
    OutOfOrder {
        /// The chirp that was due.
        expected: ChirpId,
        /// The chirp that arrived.
        got: ChirpId,
    },
    /// More chirps than a frame holds arrived before the frame was processed.
    TooManyChirps,
    /// The frame was processed before all its chirps arrived.
    Incomplete {
        /// Chirps received.
        received: u32,
        /// Chirps a frame holds (`K · TX`).
        expected: u32,
    },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::OutOfOrder { expected, got } => {
                write!(f, "chirp out of order: expected {expected}, got {got}")
            }
            FrameError::TooManyChirps => write!(f, "more chirps than a frame holds"),
            FrameError::Incomplete { received, expected } => {
                write!(
                    f,
                    "incomplete frame: {received} of {expected} chirps received"
                )
            }
        }
    }
}

impl core::error::Error for FrameError {}

/// A radar cube being filled chirp by chirp.
#[derive(Debug)]
pub struct Cube<'a, const N: usize, const K: usize, const M: usize> {
    bins: &'a mut CubeStorage<N, K, M>,
    /// Block exponent of each chirp: `exponent[row][loop]`.
    exponent: [[i8; K]; M],
    received: u32,
    error: Option<FrameError>,
}

impl<'a, const N: usize, const K: usize, const M: usize> Cube<'a, N, K, M> {
    /// Wrap caller-owned storage; the cube starts empty, waiting for loop 0, slot 0.
    pub fn new(bins: &'a mut CubeStorage<N, K, M>) -> Self {
        Self {
            bins,
            exponent: [[0; K]; M],
            received: 0,
            error: None,
        }
    }

    /// Start a new frame: forget the chirps received and any ingestion error.
    pub fn begin_frame(&mut self) {
        self.received = 0;
        self.error = None;
    }

    /// The stored mantissas (see the module docs for their scale).
    pub fn mantissas(&self) -> &CubeStorage<N, K, M> {
        self.bins
    }

    /// The block exponent of every stored chirp, `[row][loop]`: row `r` of loop `k` is
    /// `mantissas()[bin][k][r] · 2^exponents()[r][k]`.
    pub fn exponents(&self) -> &[[i8; K]; M] {
        &self.exponent
    }

    /// Chirps received in order so far in this frame.
    pub fn received(&self) -> u32 {
        self.received
    }

    /// The complete frame, when all `K · tx` chirps arrived in order, else why not.
    pub(crate) fn frame(&self, tx: usize) -> Result<Frame<'_, N, K, M>, FrameError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let expected = (K * tx) as u32;
        if self.received != expected {
            return Err(FrameError::Incomplete {
                received: self.received,
                expected,
            });
        }
        // A row whose chirps all have one exponent (the usual case: a chirp's peak is a
        // steady return or the TX–RX leakage) decodes without a multiply, see
        // `Frame::leading_snapshots_factored`.
        let uniform = core::array::from_fn(|row| {
            let exps = &self.exponent[row];
            let first = exps.first().copied().unwrap_or(0);
            exps.iter().all(|&e| e == first).then_some(first)
        });
        Ok(Frame {
            bins: self.bins,
            exponent: &self.exponent,
            uniform,
        })
    }

    /// Check `id` against the TDM order for `tx` slots; on success the caller writes the chirp
    /// into the loop index returned. A wrong chirp poisons the frame until [`Self::begin_frame`].
    pub(crate) fn accept(&mut self, id: ChirpId, tx: usize) -> Option<usize> {
        if self.error.is_some() || tx == 0 {
            return None;
        }
        let total = (K * tx) as u32;
        if self.received >= total {
            self.error = Some(FrameError::TooManyChirps);
            return None;
        }
        let expected = ChirpId::in_tdm_order(self.received as usize, tx);
        if id != expected {
            self.error = Some(FrameError::OutOfOrder { expected, got: id });
            return None;
        }
        self.received += 1;
        Some(usize::from(id.loop_index))
    }

    /// Store the range spectrum of row `row`, loop `k` with its block exponent. Always inlined:
    /// `push_chirp` and `push_range_spectra` each keep their own copy, so that calling
    /// both does not change `push_chirp`'s code (on the Cortex-M4F a shared copy cost it
    /// 425 instructions per chirp, `cargo xtask budget`).
    #[inline(always)]
    pub(crate) fn store(&mut self, row: usize, k: usize, spectrum: &[Complex32; N]) {
        if row >= M || k >= K {
            return;
        }
        let peak = f32::from_bits(peak_magnitude_bits(spectrum));
        if !peak.is_finite() {
            // An infinite component (only from an absurd coupling table; a NaN cannot arise
            // from i16 samples and finite tables): exponent 0, the checked quantiser
            // (saturating, NaN → 0).
            self.exponent[row][k] = 0;
            for (bin, v) in self.bins.iter_mut().zip(spectrum.iter()) {
                bin[k][row] = [quantise(v.re), quantise(v.im)];
            }
            return;
        }
        let e = block_exponent(peak);
        self.exponent[row][k] = e as i8;
        // Every |component| · 2^−e is now ≤ 32767 (e never clamps from above: a finite f32
        // is below 32767 · 2^125), so the rounding needs no saturation. Indices were checked
        // once above, so the loop is a strided store with no checks.
        match rounding_magic(e) {
            Some(magic) => {
                for (bin, v) in self.bins.iter_mut().zip(spectrum.iter()) {
                    bin[k][row] = [round_scaled(v.re, magic), round_scaled(v.im, magic)];
                }
            }
            None => {
                let scale = pow2(-e);
                for (bin, v) in self.bins.iter_mut().zip(spectrum.iter()) {
                    bin[k][row] = [round_small(v.re * scale), round_small(v.im * scale)];
                }
            }
        }
    }
}

impl<const N: usize, const K: usize, const M: usize> Cube<'_, N, K, M> {
    /// Store row `row`, loop `k` as given: `mantissas` with the exponent `e` (no rounding;
    /// a mantissa of −32768, which [`Self::store`] never writes, is kept as it is).
    #[inline(always)]
    pub(crate) fn store_mantissas(
        &mut self,
        row: usize,
        k: usize,
        mantissas: &[CubeSample; N],
        e: BlockExponent,
    ) {
        if row >= M || k >= K {
            return;
        }
        self.exponent[row][k] = e.get();
        for (bin, m) in self.bins.iter_mut().zip(mantissas.iter()) {
            bin[k][row] = *m;
        }
    }
}

#[cfg(not(target_arch = "arm"))]
impl<const N: usize, const K: usize, const M: usize> Cube<'_, N, K, M> {
    /// [`Self::store`] of one chirp's `L` channels at once, lane `l` of `spectra` the spectrum
    /// of row `rows[l]`: bit-identical to `L` calls of `store` (the same `f32` operations per
    /// lane), with the peaks, exponents and roundings of all lanes side by side (SIMD on a
    /// host) and one pass over the range bins.
    pub(crate) fn store_lanes<const L: usize>(
        &mut self,
        rows: &[u8; L],
        k: usize,
        spectra: &[Lanes<L>; N],
    ) {
        const ABS: u32 = 0x7fff_ffff;
        // Four independent maximum chains per lane (real and imaginary parts of even and odd
        // bins), merged at the end: the maximum is exact in any order, and one chain through
        // all 2N components waits on each compare's latency. `if a > m { a } else { m }` is
        // one MAXPS per lane group on a host and ignores a NaN, which `nan` records instead
        // (it takes the chirp to the checked path below, as a NaN peak would).
        let abs = |x: f32| f32::from_bits(x.to_bits() & ABS);
        let mut chains = [[0f32; L]; 4];
        let mut nan = [false; L];
        let mut fold = |c: usize, x: &[f32; L]| {
            for l in 0..L {
                let a = abs(x[l]);
                chains[c][l] = if a > chains[c][l] { a } else { chains[c][l] };
                nan[l] |= a.is_nan();
            }
        };
        for pair in spectra.chunks_exact(2) {
            fold(0, &pair[0].re);
            fold(1, &pair[0].im);
            fold(2, &pair[1].re);
            fold(3, &pair[1].im);
        }
        for v in spectra.chunks_exact(2).remainder() {
            fold(0, &v.re);
            fold(1, &v.im);
        }
        let peak: [u32; L] = core::array::from_fn(|l| {
            let m = chains.iter().map(|c| c[l].to_bits()).fold(0, u32::max);
            if nan[l] {
                f32::NAN.to_bits()
            } else {
                m
            }
        });
        let all_finite = peak.iter().all(|&p| f32::from_bits(p).is_finite());
        let exponents: [i32; L] = core::array::from_fn(|l| block_exponent(f32::from_bits(peak[l])));
        let magic: [Option<f32>; L] = core::array::from_fn(|l| rounding_magic(exponents[l]));
        if k >= K
            || rows.iter().any(|&r| usize::from(r) >= M)
            || !all_finite
            || magic.iter().any(Option::is_none)
        {
            // Off the cube, an infinite component or an absurd exponent: one row at a time,
            // checked.
            for (l, &row) in rows.iter().enumerate() {
                let spectrum: [Complex32; N] = core::array::from_fn(|n| spectra[n].lane(l));
                self.store(usize::from(row), k, &spectrum);
            }
            return;
        }
        for l in 0..L {
            self.exponent[usize::from(rows[l])][k] = exponents[l] as i8;
        }
        let magic: [f32; L] = core::array::from_fn(|l| magic[l].unwrap_or(ROUNDING_MAGIC));
        // When the chirp's channels are consecutive rows (ColoRadar's layout), a bin's `L`
        // values are one run, rounded and written side by side.
        let first = rows.first().map_or(0, |&r| usize::from(r));
        if rows
            .iter()
            .enumerate()
            .all(|(l, &r)| usize::from(r) == first + l)
            && first + L <= M
        {
            for (bin, v) in self.bins.iter_mut().zip(spectra.iter()) {
                let run: [CubeSample; L] = core::array::from_fn(|l| {
                    [
                        round_scaled(v.re[l], magic[l]),
                        round_scaled(v.im[l], magic[l]),
                    ]
                });
                bin[k][first..first + L].copy_from_slice(&run);
            }
            return;
        }
        for (bin, v) in self.bins.iter_mut().zip(spectra.iter()) {
            let at = &mut bin[k];
            for l in 0..L {
                at[usize::from(rows[l])] = [
                    round_scaled(v.re[l], magic[l]),
                    round_scaled(v.im[l], magic[l]),
                ];
            }
        }
    }
}

/// The block exponent of a chirp whose largest component is `peak` (finite, ≥ 0): the
/// smallest `e` with `peak · 2^−e ≤ 32767`. Writing `peak/32767 = f · 2^e` with `f ∈ [½, 1)`
/// (frexp), `e` is the float's biased exponent − 126; 0 for a zero chirp.
#[inline]
fn block_exponent(peak: f32) -> i32 {
    if peak > 0.0 {
        let biased = ((peak / 32767.0).to_bits() >> 23) & 0xff;
        (biased as i32 - 126).clamp(-EXPONENT_LIMIT, EXPONENT_LIMIT)
    } else {
        0
    }
}

/// A complete, in-order frame: the checked input of both chains' `process` (which is then
/// infallible). Made by [`crate::Frontend::frame`]; it borrows the cube, so the cube cannot
/// change while a frame of it is processed.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'c, const N: usize, const K: usize, const M: usize> {
    bins: &'c CubeStorage<N, K, M>,
    exponent: &'c [[i8; K]; M],
    /// Per row: its exponent when all its chirps share one, else `None`.
    uniform: [Option<i8>; M],
}

impl<const N: usize, const K: usize, const M: usize> Frame<'_, N, K, M> {
    /// Range bin `b` as `f32` snapshots (all zero for `b ≥ N`).
    pub fn snapshots(&self, b: usize, out: &mut Snapshots<K, M>) {
        self.leading_snapshots(b, M, out);
    }

    /// The first `rows` rows of range bin `b` as `f32` snapshots (all zero for `b ≥ N`);
    /// the other rows of `out` are left as they are. The azimuth stage needs only the
    /// azimuth line, the first `AZ` rows.
    // Out of line on a microcontroller: both FFT-chain stages call it, and inlined twice it
    // costs 6 KB of flash for no measurable instruction.
    #[cfg_attr(target_arch = "arm", inline(never))]
    pub fn leading_snapshots(&self, b: usize, rows: usize, out: &mut Snapshots<K, M>) {
        let Some(bin) = self.bins.get(b) else {
            for o in out.iter_mut().take(rows) {
                *o = [Complex32::new(0.0, 0.0); K];
            }
            return;
        };
        for (r, (o, exps)) in out
            .iter_mut()
            .zip(self.exponent.iter())
            .take(rows)
            .enumerate()
        {
            decode_row(bin, r, exps, o);
        }
    }

    /// [`Self::leading_snapshots`] with the block exponent factored out of every row whose
    /// chirps share one: row `i` of `out` is the decoded row times `1 / f[i]`, `f` returned
    /// (`f[i] = 2^e` for such a row, decoded as bare mantissas with no multiply; 1 for a row
    /// whose chirps have different exponents, decoded as usual).
    ///
    /// Multiplying by a power of two commutes with `f32` rounding (away from overflow and
    /// subnormals, which block exponents within ±125 of data from i16 samples do not reach),
    /// so the covariance of `out` with entry `(i, j)` multiplied by `f[i]` and then `f[j]`
    /// ([`crate::covariance::scale_rows`]) is bit-identical to the covariance of the decoded
    /// snapshots, and the azimuth stage decodes its rows with a conversion per component only
    /// (issue 13).
    pub fn leading_snapshots_factored(
        &self,
        b: usize,
        rows: usize,
        out: &mut Snapshots<K, M>,
    ) -> [f32; M] {
        let mut factor = [1.0f32; M];
        let Some(bin) = self.bins.get(b) else {
            self.leading_snapshots(b, rows, out);
            return factor;
        };
        for (r, ((o, exps), (f, uniform))) in out
            .iter_mut()
            .zip(self.exponent.iter())
            .zip(factor.iter_mut().zip(self.uniform.iter()))
            .take(rows)
            .enumerate()
        {
            match uniform {
                // `r < M`: `out` has `M` rows.
                Some(e) if r < M => {
                    *f = stored_pow2(*e);
                    for (v, snapshot) in o.iter_mut().zip(bin.iter()) {
                        let m = snapshot[r];
                        *v = Complex32::new(f32::from(m[0]), f32::from(m[1]));
                    }
                }
                _ => decode_row(bin, r, exps, o),
            }
        }
        factor
    }
}

#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
impl<const N: usize, const K: usize, const M: usize> Frame<'_, N, K, M> {
    /// Every chirp's `2^e` for the first `rows` rows, in the split layout
    /// (`crate::covariance::Split`: `[loop][row / 4][row % 4]`, zero past the rows): the
    /// multipliers of [`Self::leading_split`], the same for every range bin of the frame.
    /// `false`, `out` untouched, for more rows than the layout holds.
    pub(crate) fn chirp_scales(&self, rows: usize, out: &mut crate::covariance::Split<K>) -> bool {
        use crate::covariance::{LANES, LANE_BLOCKS};
        let rows = rows.min(M);
        if rows.div_ceil(LANES) > LANE_BLOCKS {
            return false;
        }
        for (k, blocks) in out.iter_mut().enumerate() {
            for (blk, lanes) in blocks.iter_mut().enumerate() {
                for (l, v) in lanes.iter_mut().enumerate() {
                    let m = blk * LANES + l;
                    *v = match self.exponent.get(m).and_then(|e| e.get(k)) {
                        Some(&e) if m < rows => stored_pow2(e),
                        _ => 0.0,
                    };
                }
            }
        }
        true
    }

    /// The first rows of range bin `b` decoded straight into the split layout the host's
    /// covariance sums from (`crate::covariance::SplitRows`): each mantissa times its chirp's
    /// `scales` entry ([`Self::chirp_scales`] for as many rows), so the same values as
    /// [`Self::leading_snapshots`], read loop by loop in the cube's `[loop][row]` order with no
    /// `f32` snapshot block in between (issue 13: decoding and transposing were two passes of
    /// the azimuth stage). Only the blocks holding the first `rows` rows are written; lanes
    /// past the rows in them are zero. A bin off the cube is all zero.
    pub(crate) fn leading_split(
        &self,
        b: usize,
        rows: usize,
        scales: &crate::covariance::Split<K>,
        out: &mut crate::covariance::SplitRows<K>,
    ) {
        use crate::covariance::{LANES, LANE_BLOCKS};
        let blocks = rows.min(M).div_ceil(LANES).min(LANE_BLOCKS);
        let Some(bin) = self.bins.get(b) else {
            *out = crate::covariance::SplitRows::ZERO;
            return;
        };
        for (((re, im), snapshot), scale) in out
            .re
            .iter_mut()
            .zip(out.im.iter_mut())
            .zip(bin.iter())
            .zip(scales.iter())
        {
            // Whole blocks of four rows as fixed-size chunks (the compiler vectorises them),
            // a block the cube's rows do not fill lane by lane; a zero scale clears a lane.
            let mut chunks = snapshot.chunks_exact(LANES);
            for (((re, im), chunk), scale) in re
                .iter_mut()
                .zip(im.iter_mut())
                .zip(&mut chunks)
                .zip(scale.iter())
                .take(blocks)
            {
                for (((r, i), s), f) in re.iter_mut().zip(im.iter_mut()).zip(chunk).zip(scale) {
                    *r = f32::from(s[0]) * f;
                    *i = f32::from(s[1]) * f;
                }
            }
            let whole = M / LANES;
            if let (Some(re), Some(im), Some(scale)) =
                (re.get_mut(whole), im.get_mut(whole), scale.get(whole))
            {
                if whole < blocks {
                    for (l, ((r, i), f)) in re.iter_mut().zip(im.iter_mut()).zip(scale).enumerate()
                    {
                        let s = chunks.remainder().get(l).copied().unwrap_or([0, 0]);
                        *r = f32::from(s[0]) * f;
                        *i = f32::from(s[1]) * f;
                    }
                }
            }
        }
    }
}

/// Row `r` of one range bin's mantissas times their chirps' `2^e`, as `f32` (zeros for a row
/// off the bin).
#[inline(always)]
fn decode_row<const K: usize, const M: usize>(
    bin: &[[CubeSample; M]; K],
    r: usize,
    exps: &[i8; K],
    out: &mut [Complex32; K],
) {
    if r >= M {
        *out = [Complex32::new(0.0, 0.0); K];
        return;
    }
    for ((v, snapshot), &e) in out.iter_mut().zip(bin.iter()).zip(exps.iter()) {
        let m = snapshot[r];
        let scale = stored_pow2(e);
        *v = Complex32::new(f32::from(m[0]) * scale, f32::from(m[1]) * scale);
    }
}

/// The bit pattern of the largest `|re|`, `|im|` of `spectrum`: for non-negative floats the
/// order of the bit patterns as integers is the order of the values, so the peak is an
/// integer maximum over the patterns with the sign bit cleared, which needs no float compare
/// chain (2.1× faster on the host, issue 13). Infinity's pattern is above every finite one
/// and a NaN's above infinity's, so a spectrum with either has a non-finite peak (which
/// [`Cube::store`] takes to its checked path).
#[inline]
fn peak_magnitude_bits<const N: usize>(spectrum: &[Complex32; N]) -> u32 {
    // The patterns shifted left by one: the shift drops the sign bit and keeps the order of
    // the other 31, and on the Cortex-M4 it folds into the compare and the conditional move
    // (four instructions per component instead of five with a mask).
    let mut peak = 0u32;
    for v in spectrum.iter() {
        peak = peak.max(v.re.to_bits() << 1).max(v.im.to_bits() << 1);
    }
    peak >> 1
}

/// Block exponents stay within ±125, so `2^e` and `2^−e` are normal `f32` values.
const EXPONENT_LIMIT: i32 = 125;

/// `2^e` for `|e| ≤ 126`, built from its bits (no libm call on the hot path).
#[inline]
fn pow2(e: i32) -> f32 {
    f32::from_bits(((e.clamp(-126, 127) + 127) as u32) << 23)
}

/// `1.5 · 2²³`: adding it to an `|x| < 2²²` leaves `x` rounded to an integer (ties to even,
/// the FPU's rounding) in the low mantissa bits.
const ROUNDING_MAGIC: f32 = 12_582_912.0;

/// `2^e` of a stored block exponent (`|e| ≤ 125`, [`EXPONENT_LIMIT`]): its bits, with no
/// clamp (an add, a shift and a move per snapshot element).
#[inline]
fn stored_pow2(e: i8) -> f32 {
    f32::from_bits(((i32::from(e) + 127) as u32) << 23)
}

/// The largest block exponent whose [`rounding_magic`] is a finite `f32`.
const MAGIC_LIMIT: i32 = 104;

/// `1.5 · 2^(23+e)` for `−125 ≤ e ≤ MAGIC_LIMIT` (a normal `f32`, from its bits), else `None`.
#[inline]
fn rounding_magic(e: i32) -> Option<f32> {
    (-EXPONENT_LIMIT..=MAGIC_LIMIT)
        .contains(&e)
        .then(|| f32::from_bits((((23 + e + 127) as u32) << 23) | 0x0040_0000))
}

/// [`round_small`]`(x · 2^−e)` bit for bit, with `magic` = [`rounding_magic`]`(e)`: one add
/// and no multiply (issue 13). Scaling by a power of two commutes with rounding, so
/// `x + 1.5·2^(23+e)` is `(x·2^−e + 1.5·2^23)·2^e` rounded; both sums have the exponent of
/// their magic, so the difference of the bit patterns is the same integer. The magic's low
/// 22 bits are zero, so that difference's low 16 bits — the `i16` — are the sum's own: no
/// subtract either.
#[inline]
fn round_scaled(x: f32, magic: f32) -> i16 {
    (x + magic).to_bits() as i16
}

/// Round `|x| ≤ 32767.5` to the nearest integer, ties to even: one add, one move and one
/// subtract (no compare, no float-to-int conversion; `libm::roundf` is a slow software
/// routine on Cortex-M). Outside that range the result is meaningless; [`Cube::store`]
/// guarantees it.
#[inline]
fn round_small(x: f32) -> i16 {
    (x + ROUNDING_MAGIC).to_bits() as i16
}

/// Round half away from zero to an i16, saturating at ±32767 (NaN → 0): the checked path
/// of [`Cube::store`] for a spectrum with an infinite component.
#[inline]
fn quantise(x: f32) -> i16 {
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    (r as i32).clamp(-32767, 32767) as i16
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The order `tdm_order` lists is the one `accept` takes, chirp by chirp to the end of
    /// the frame, and nothing after it; no TX slots give no chirps and never divide by zero.
    #[test]
    fn tdm_order_is_the_order_the_cube_accepts() {
        const K: usize = 4;
        let mut storage = [[[[0i16; 2]; 6]; K]; 2];
        let mut cube = Cube::<2, K, 6>::new(&mut storage);
        let order: Vec<ChirpId> = tdm_order(K, 3).collect();
        assert_eq!(order.len(), K * 3);
        assert_eq!(
            order[5],
            ChirpId {
                loop_index: 1,
                tx_slot: 2
            }
        );
        for (i, &id) in order.iter().enumerate() {
            assert_eq!(id, ChirpId::in_tdm_order(i, 3));
            assert_eq!(cube.accept(id, 3), Some(usize::from(id.loop_index)), "{id}");
        }
        assert_eq!(cube.accept(ChirpId::in_tdm_order(K * 3, 3), 3), None);
        assert_eq!(tdm_order(K, 0).count(), 0);
        assert_eq!(ChirpId::in_tdm_order(7, 0), ChirpId::default());
    }

    /// The lanes store writes the same mantissas and exponents as one `store` per row, for
    /// spectra of very different scales, a zero one, and (the checked path) an infinite or a
    /// NaN component, on scattered and on consecutive rows.
    #[test]
    fn the_lanes_store_is_the_row_store_bit_for_bit() {
        const N: usize = 16;
        const K: usize = 2;
        const M: usize = 6;
        let scales = [3.0e4f32, 1.0e-3, 0.0, 7.5];
        let spectra: [Lanes<4>; N] = core::array::from_fn(|n| {
            let mut v = Lanes::<4>::ZERO;
            for (l, s) in scales.iter().enumerate() {
                let x = (n * 7 + l * 3) as f32;
                v.re[l] = s * libm::sinf(x) * (1.0 + 0.37 * l as f32);
                v.im[l] = s * libm::cosf(1.3 * x);
            }
            v
        });
        // Scattered rows, and consecutive ones (stored as one run per bin).
        for (rows, special) in [[5u8, 1, 3, 0], [2, 3, 4, 5]]
            .into_iter()
            .flat_map(|rows| [None, Some(f32::INFINITY), Some(f32::NAN)].map(|s| (rows, s)))
        {
            let mut spectra = spectra;
            if let Some(x) = special {
                spectra[3].im[2] = x;
            }
            let (mut a, mut b) = ([[[[0i16; 2]; M]; K]; N], [[[[0i16; 2]; M]; K]; N]);
            let (mut lanes, mut single) = (Cube::new(&mut a), Cube::new(&mut b));
            lanes.store_lanes(&rows, 1, &spectra);
            for (l, &row) in rows.iter().enumerate() {
                let spectrum: [Complex32; N] = core::array::from_fn(|n| spectra[n].lane(l));
                single.store(usize::from(row), 1, &spectrum);
            }
            let case = format!("rows {rows:?}, special {special:?}");
            assert_eq!(lanes.exponent, single.exponent, "{case}");
            assert_eq!(lanes.bins, single.bins, "{case}");
            assert!(lanes.bins.iter().any(|bin| bin[1][5] != [0, 0]), "{case}");
        }
    }

    #[test]
    fn the_integer_peak_is_the_float_peak() {
        let mut x = [Complex32::new(0.0, 0.0); 8];
        assert_eq!(peak_magnitude_bits(&x), 0);
        x[2] = Complex32::new(-3.5, 1.0);
        x[5] = Complex32::new(2.0, -7.25);
        let float_peak = x
            .iter()
            .fold(0.0f32, |p, v| p.max(v.re.abs()).max(v.im.abs()));
        assert_eq!(f32::from_bits(peak_magnitude_bits(&x)), float_peak);
        assert_eq!(float_peak, 7.25);
        x[7] = Complex32::new(f32::NEG_INFINITY, 0.0);
        assert_eq!(f32::from_bits(peak_magnitude_bits(&x)), f32::INFINITY);
        x[6] = Complex32::new(f32::NAN, 0.5);
        assert!(f32::from_bits(peak_magnitude_bits(&x)).is_nan());
    }

    #[test]
    fn round_small_rounds_to_nearest_ties_to_even() {
        for (x, r) in [
            (0.0f32, 0i16),
            (0.49, 0),
            (0.5, 0),
            (1.5, 2),
            (2.5, 2),
            (-2.5, -2),
            (-2.51, -3),
            (32767.0, 32767),
            (-32767.0, -32767),
            (32766.6, 32767),
            (-0.2, 0),
        ] {
            assert_eq!(round_small(x), r, "{x}");
        }
        // Everywhere else in range it is the nearest integer.
        let mut x = -32767.4f32;
        while x < 32767.4 {
            let r = f32::from(round_small(x));
            assert!((r - x).abs() <= 0.5, "{x} -> {r}");
            x += 0.37;
        }
    }

    #[test]
    fn an_infinite_component_saturates() {
        let mut storage = [[[[0i16; 2]; 1]; 1]; 4];
        let mut cube = Cube::<4, 1, 1>::new(&mut storage);
        let mut spectrum = [Complex32::new(3.0, -2.0); 4];
        spectrum[1] = Complex32::new(f32::INFINITY, 1e9);
        cube.store(0, 0, &spectrum);
        let m = cube.mantissas();
        assert_eq!(m[1][0][0], [32767, 32767]);
        assert_eq!(m[0][0][0], [3, -2]);
        assert_eq!(cube.exponent[0][0], 0);
    }

    #[test]
    fn pow2_and_quantise() {
        for e in -126..=127 {
            assert_eq!(pow2(e), libm::ldexpf(1.0, e));
        }
        for e in -EXPONENT_LIMIT..=EXPONENT_LIMIT {
            assert_eq!(stored_pow2(e as i8), libm::ldexpf(1.0, e));
        }
        assert_eq!(quantise(2.5), 3);
        assert_eq!(quantise(-2.5), -3);
        assert_eq!(quantise(2.49), 2);
        assert_eq!(quantise(1e9), 32767);
        assert_eq!(quantise(-1e9), -32767);
        assert_eq!(quantise(f32::NAN), 0);
    }

    #[test]
    fn block_exponent_fits_the_peak_and_keeps_15_bits() {
        let mut storage = [[[[0i16; 2]; 1]; 1]; 8];
        let mut cube = Cube::<8, 1, 1>::new(&mut storage);
        cube.received = 1;
        for peak in [0.3f32, 1.0, 32767.0, 32768.0, 123_456.7, 6.0e6] {
            let mut spectrum = [Complex32::new(0.0, 0.0); 8];
            spectrum[3] = Complex32::new(-peak, peak / 3.0);
            spectrum[5] = Complex32::new(peak / 1000.0, 0.0);
            cube.store(0, 0, &spectrum);
            let m = cube.mantissas()[3][0][0][0];
            // The largest component uses the top bit: |m| in (16383, 32767].
            assert!(m.unsigned_abs() > 16383, "peak {peak}: mantissa {m}");
            let mut out = [[Complex32::new(0.0, 0.0); 1]; 1];
            let frame = cube
                .frame(1)
                .expect("one chirp of one slot is a whole frame");
            for (b, v) in spectrum.iter().enumerate() {
                frame.snapshots(b, &mut out);
                let step = peak / 16384.0;
                assert!((out[0][0] - v).norm() <= step, "peak {peak}, bin {b}");
            }
        }
    }

    /// A whole one-slot frame of `K` chirps whose row `row`, loop `k` is a sinusoid pattern of
    /// amplitude `scale(row, k)`.
    fn scaled_rows_cube<const N: usize, const K: usize, const M: usize>(
        storage: &mut CubeStorage<N, K, M>,
        scale: impl Fn(usize, usize) -> f32,
    ) -> Cube<'_, N, K, M> {
        let mut cube = Cube::<N, K, M>::new(storage);
        for k in 0..K {
            for row in 0..M {
                let a = scale(row, k);
                let spectrum: [Complex32; N] = core::array::from_fn(|n| {
                    let x = (n * 5 + k * 3 + row) as f32;
                    Complex32::new(a * libm::sinf(x), a * libm::cosf(1.7 * x))
                });
                cube.store(row, k, &spectrum);
            }
        }
        cube.received = K as u32;
        cube
    }

    /// Every entry of `got` is `want`'s bit for bit.
    fn assert_same_bits<const D: usize>(
        want: &crate::covariance::Matrix<D>,
        got: &crate::covariance::Matrix<D>,
        what: &str,
    ) {
        for (w, g) in want.iter().flatten().zip(got.iter().flatten()) {
            assert_eq!(
                (w.re.to_bits(), w.im.to_bits()),
                (g.re.to_bits(), g.im.to_bits()),
                "{what}: {w} vs {g}"
            );
        }
    }

    /// The azimuth stage's decoding (exponent factored out of uniform rows, put back on the
    /// covariance) gives the decoded covariance bit for bit, for a uniform row, a row whose
    /// chirps have three different exponents, a zero row and an out-of-cube bin.
    #[test]
    fn factored_rows_give_the_decoded_covariance_bit_for_bit() {
        const N: usize = 4;
        const K: usize = 8;
        const M: usize = 4;
        let mut storage = zero_storage::<N, K, M>();
        // Row 0: one scale (one exponent); row 1: the scale changes by 2^±6 between loops;
        // row 2: another steady scale; row 3: all zero.
        let cube = scaled_rows_cube(&mut storage, |row, k| match row {
            0 => 1234.5,
            1 => [3.0e4f32, 470.0, 2.9e6][k % 3],
            2 => 0.75,
            _ => 0.0,
        });
        let frame = cube
            .frame(1)
            .expect("K chirps of one slot are a whole frame");
        assert!(frame.uniform[0].is_some());
        assert_eq!(frame.uniform[1], None);
        for b in 0..=N {
            let (mut decoded, mut factored) = ([[ZERO_C; K]; M], [[ZERO_C; K]; M]);
            frame.snapshots(b, &mut decoded);
            let f = frame.leading_snapshots_factored(b, M, &mut factored);
            let (mut want, mut got) = (
                crate::covariance::zero::<M>(),
                crate::covariance::zero::<M>(),
            );
            crate::covariance::covariance(&decoded[..], &mut want);
            crate::covariance::covariance(&factored[..], &mut got);
            crate::covariance::scale_rows(&mut got, &f);
            assert_same_bits(&want, &got, &format!("bin {b}"));
            if b < N {
                assert!(want[0][0].re > 0.0 && want[1][1].re > 0.0 && want[0][1].norm() > 0.0);
                assert_ne!(f[0], 1.0, "the uniform row's exponent is factored out");
            }
        }
    }

    /// The host's split decoding (each mantissa times its chirp's `2^e`, straight into the
    /// SIMD covariance's layout) gives the covariance of the decoded snapshots bit for bit: rows
    /// with one exponent, with changing exponents and all zero, 2 to 6 rows (a partial block
    /// from whole chunks and from the cube's last, short one), and a bin off the cube.
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    #[test]
    fn split_rows_give_the_decoded_covariance_bit_for_bit() {
        const N: usize = 3;
        const K: usize = 8;
        const M: usize = 6;
        let mut storage = zero_storage::<N, K, M>();
        let cube = scaled_rows_cube(&mut storage, |row, k| match row {
            0 => 1234.5,
            1 | 4 => [3.0e4f32, 470.0, 2.9e6][(k + row) % 3],
            2 => 0.75,
            3 => 0.0,
            _ => -88.0,
        });
        let frame = cube
            .frame(1)
            .expect("K chirps of one slot are a whole frame");
        assert_eq!(frame.uniform[1], None);
        for rows in 2..=M {
            let mut scales = crate::covariance::zero_split::<K>();
            assert!(frame.chirp_scales(rows, &mut scales));
            for b in 0..=N {
                let mut decoded = [[ZERO_C; K]; M];
                frame.snapshots(b, &mut decoded);
                let mut split = crate::covariance::SplitRows::<K>::ZERO;
                frame.leading_split(b, rows, &scales, &mut split);
                let (mut want, mut got) = (
                    crate::covariance::zero::<M>(),
                    crate::covariance::zero::<M>(),
                );
                crate::covariance::covariance(&decoded[..rows], &mut want);
                crate::covariance::covariance_of_split(&split, rows, &mut got);
                assert_same_bits(&want, &got, &format!("{rows} rows, bin {b}"));
                if b < N {
                    assert!(want[0][0].re > 0.0 && want[1][1].re > 0.0);
                }
            }
        }
    }

    /// The add-only rounding is the scale-then-round one bit for bit: every block exponent
    /// it serves, values up to the block's full scale, exact ties, tiny and signed-zero values.
    #[test]
    fn round_scaled_is_round_small_of_the_scaled_value() {
        let mut state = 12345u32;
        for e in -EXPONENT_LIMIT..=MAGIC_LIMIT {
            let magic = rounding_magic(e).expect("within the limit");
            let scale = pow2(-e);
            let unit = pow2(e);
            let check = |m: f32| {
                let x = m * unit;
                assert_eq!(
                    round_scaled(x, magic),
                    round_small(x * scale),
                    "e {e}, m {m}"
                );
            };
            for m in [
                0.0f32, -0.0, 0.5, -0.5, 1.5, 2.5, -2.5, 32767.0, -32767.0, 32766.5, 1e-30,
            ] {
                check(m);
            }
            for _ in 0..200 {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                check((state >> 8) as f32 / 256.0 - 32767.0);
            }
        }
        assert!(rounding_magic(MAGIC_LIMIT + 1).is_none());
        assert!(rounding_magic(-EXPONENT_LIMIT - 1).is_none());
    }

    /// An exponent beyond the add-only rounding's range takes the scaled path: the value is
    /// stored to its block's precision.
    #[test]
    fn a_huge_chirp_is_stored_on_the_scaled_path() {
        let mut storage = zero_storage::<8, 1, 1>();
        let mut cube = Cube::<8, 1, 1>::new(&mut storage);
        let mut spectrum = [Complex32::new(0.0, 0.0); 8];
        spectrum[2] = Complex32::new(1.0e36, -3.0e35);
        cube.store(0, 0, &spectrum);
        let e = i32::from(cube.exponent[0][0]);
        assert!(e > MAGIC_LIMIT);
        let m = cube.bins[2][0][0];
        assert!((f32::from(m[0]) - 1.0e36 * pow2(-e)).abs() <= 0.5, "{m:?}");
        assert!((f32::from(m[1]) + 3.0e35 * pow2(-e)).abs() <= 0.5, "{m:?}");
        assert!(m[0] > 16383);
    }

    const ZERO_C: Complex32 = Complex32::new(0.0, 0.0);
}
