//! Detection: one 2-D CFAR with a 3×3 local-maximum rule, for both chains' maps.
//!
//! The map is `map[range bin][column]` in linear power: the range–azimuth map of the DBE chain
//! (columns = azimuth bins, truncated at the grid's ends) or the range–Doppler map of the FFT
//! chain (columns = Doppler FFT bins in natural order, periodic). [`Columns`] says which.
//!
//! For a cell under test (CUT) the training cells are the window of half-widths
//! `guard + train` around it minus the guard window. Along range the window is truncated at
//! the processed range window (never wrapped: range bins 0 and `N − 1` are not neighbours).
//! Along the columns it is truncated at the map's edges ([`Columns::Truncated`]) or wraps
//! modulo the column count ([`Columns::Periodic`]: the Doppler FFT is periodic, so bin `K − 1`
//! is the neighbour of bin 0 and the 0 m/s ridge of static clutter gets a full window).
//!
//! Noise level: the mean of the `n` training values (cell averaging) or the `⌈q·n⌉`-th
//! smallest (ordered statistic), never below the row's floor when one is given (see below).
//! The CUT is a detection when it exceeds `α · level` and is the maximum of its 3×3
//! neighbourhood (equal neighbours at a lower `(row, column)` win, so a plateau gives one
//! detection). Only local maxima are tested, which gives the same detections as testing every
//! cell at a fraction of the cost.
//!
//! Window gate ([`CfarParams::window_gate_db`], off when 0): a detection must also lie within
//! that many dB of the strongest cell of its whole window (guard and training cells). An
//! ordered statistic ignores a strong neighbour by design; the gate bounds how far below one
//! a detection may lie, where on real hardware the neighbour's own range skirt lives.
//!
//! Loading floor (DBE chain): diagonal loading `δ_b` of range bin `b` bounds its Capon
//! spectrum from below, `P(θ) ≥ δ_b / D` (because `(R + δI)⁻¹ ≼ I/δ`), and with a strong
//! target `δ_b` is a fixed fraction of that target's power. The whole row then sits on a flat
//! ridge whose ripples are local maxima; training cells from quieter neighbouring rows would
//! put the order statistic below the ridge and declare the ripples detections. The noise
//! level of a cell is therefore never taken below its row's floor: `level = max(statistic,
//! floor[b])`. Noise-limited rows are unaffected (there `δ_b / D ≪ σ² / D`).

use crate::config::{finite, ConfigError, Param};

/// Capacity of the training-cell scratch buffer: the largest `n` a configuration may ask for.
pub const MAX_TRAINING_CELLS: usize = 1024;

/// Which noise-level estimator the CFAR uses.
///
/// `OrderStatistic` is the first variant so that an all-zero [`CfarParams`] (an unconfigured
/// chain in `.bss`) is a valid bit pattern of zeros.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CfarKind {
    /// Ordered statistic: the level is the `⌈q·n⌉`-th smallest of the `n` training cells.
    OrderStatistic {
        /// Quantile `q` in `(0, 1]`.
        quantile: f32,
    },
    /// Cell averaging: the level is the mean of the training cells (TI's mmWave SDK
    /// `CFAR-CA`, the classic FFT chain).
    CellAveraging,
}

/// How the column axis of a map behaves at its ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Columns {
    /// Windows stop at the first and last column; `edge_skip` columns at each end are never
    /// tested (an angle grid).
    Truncated,
    /// Column `C − 1` is the neighbour of column 0 (a Doppler spectrum); every column is
    /// tested.
    Periodic,
}

/// 2-D CFAR parameters (linear power).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CfarParams {
    /// Noise-level estimator.
    pub kind: CfarKind,
    /// Guard half-width along range, bins (excluded from training).
    pub guard_range: u8,
    /// Guard half-width along the columns (azimuth or Doppler bins).
    pub guard_cross: u8,
    /// Training half-width along range beyond the guard, bins.
    pub train_range: u8,
    /// Training half-width along the columns beyond the guard.
    pub train_cross: u8,
    /// Threshold factor α over the noise level, dB (`threshold = α · level`).
    pub threshold_db: f32,
    /// Columns skipped at each end of a [`Columns::Truncated`] map (no detection there).
    pub edge_skip: u8,
    /// Window gate, dB: a cell more than this below the strongest cell of its CFAR window
    /// (guard and training cells, the same truncation or wrap) is not a detection, whatever
    /// its level. `0` turns it off (the FFT chain's presets: CA-CFAR masks on its own).
    pub window_gate_db: f32,
}

impl CfarParams {
    /// The DBE chain's OS-CFAR on the range–azimuth map: guard 2 × 4, training 4 × 8 beyond
    /// the guard, q = 0.75 (spec §3), α = 2 dB, 4 edge bins skipped (spec §3), window gate
    /// 12 dB.
    ///
    /// α = 2 dB: the map is a candidate stage, the Doppler test and the Doppler agreement of
    /// [`crate::Params`] confirm its detections. A Capon estimate of white noise from K
    /// snapshots spreads by about `1/√(K − AZ + 1)` (9 % at K = 128, 13 % at K = 64), so
    /// α ≈ 1.3–1.7 dB over the 75 % order statistic already gives a per-cell false-alarm
    /// probability of 10⁻⁵ in white noise, and the Doppler test removes what passes (no
    /// false point on the evaluation's noise-only frames down to α = 1 dB). The evaluation's
    /// defaults sweep (`docs/eval/report.md`) measures the rest: 2 dB is the highest α at
    /// which the DBE chain gives at least the FFT chain's points per extended-scene frame,
    /// with fewer false points per scene frame than the FFT chain.
    ///
    /// Window gate 12 dB ([`Self::window_gate_db`]): real returns are wider in range than
    /// the window's main lobe. On the real TI corner-reflector capture (`dbe process`) the
    /// double bounce (range bin 75) spreads over bins 73–79, 14 dB below its peak three bins
    /// away, and OS-CFAR, built to ignore a strong neighbour, detects that skirt as points
    /// with a one-bin Doppler error from α = 2.5 dB down. With the gate the capture gives
    /// the reflector and its double and triple bounce, all static, at every α from 1 to 3 dB
    /// (plus one static point at 2.2 m from 1.5 dB down). The FFT chain's CA-CFAR has the
    /// same limit built in: one cell of its 144 training cells at `P` raises the level to
    /// `P/144`, so with α = 6 dB nothing 15.6 dB below `P` inside its window is detected.
    pub const RANGE_AZIMUTH: Self = Self {
        kind: CfarKind::OrderStatistic { quantile: 0.75 },
        guard_range: 2,
        guard_cross: 4,
        train_range: 4,
        train_cross: 8,
        threshold_db: 2.0,
        edge_skip: 4,
        window_gate_db: 12.0,
    };

    /// The FFT chain's CA-CFAR on the range–Doppler map: guard 2 × 2, training 4 × 4 beyond
    /// the guard (144 cells), α = 6 dB.
    ///
    /// Guard: the Blackman range main lobe reaches ±3 bins and the Hann Doppler main lobe ±2,
    /// so a target's own main lobe stays out of the training cells. Threshold: a white-noise
    /// cell of the map is a sum over 12 antennas of `|X|²`, a Gamma(12) variable, and
    /// `P(Gamma(12) > 12·α)` is 6e-5 at α = 4 dB, 1e-6 at 4.8 dB and 2e-10 at 6 dB. Measured on
    /// 117,760 noise-only cells of the ColoRadar preset (8 frames, CA-CFAR with the local
    /// maximum): 284 detections at 3 dB, 9 at 4 dB, 1 at 4.5 dB, none at 5 dB and above, i.e.
    /// the Gamma tail (the CA estimation loss and the local-maximum thinning roughly cancel).
    /// 6 dB leaves 1.2 dB of margin over the 1e-6 design point for noise that is not white.
    pub const RANGE_DOPPLER_CA: Self = Self {
        kind: CfarKind::CellAveraging,
        guard_range: 2,
        guard_cross: 2,
        train_range: 4,
        train_cross: 4,
        threshold_db: 6.0,
        edge_skip: 0,
        window_gate_db: 0.0,
    };

    /// OS-CFAR on the range–Doppler window of [`Self::RANGE_DOPPLER_CA`], q = 0.75 (as the DBE
    /// chain), α = 5 dB. The 75th percentile of Gamma(12)/12 is 1.19, 0.8 dB above the mean,
    /// so 5 dB over it is about the same threshold as 6 dB over the mean (measured on the same
    /// noise: 6 detections at 3.5 dB, none at 4 dB and above).
    pub const RANGE_DOPPLER_OS: Self = Self {
        kind: CfarKind::OrderStatistic { quantile: 0.75 },
        threshold_db: 5.0,
        ..Self::RANGE_DOPPLER_CA
    };

    /// Every field zero: the parameters of an unconfigured chain (all-zero bytes).
    pub(crate) const ZEROED: Self = Self {
        kind: CfarKind::OrderStatistic { quantile: 0.0 },
        guard_range: 0,
        guard_cross: 0,
        train_range: 0,
        train_cross: 0,
        threshold_db: 0.0,
        edge_skip: 0,
        window_gate_db: 0.0,
    };

    /// Training cells of a full (untruncated) window.
    pub const fn full_training_cells(&self) -> usize {
        let outer_r = 2 * (self.guard_range as usize + self.train_range as usize) + 1;
        let outer_c = 2 * (self.guard_cross as usize + self.train_cross as usize) + 1;
        let inner_r = 2 * self.guard_range as usize + 1;
        let inner_c = 2 * self.guard_cross as usize + 1;
        outer_r * outer_c - inner_r * inner_c
    }

    /// Check the parameters for a map of `columns` columns of the given kind.
    pub(crate) fn validate(&self, columns: usize, kind: Columns) -> Result<(), ConfigError> {
        if let CfarKind::OrderStatistic { quantile } = self.kind {
            finite(f64::from(quantile), Param::CfarQuantile)?;
            if !(quantile > 0.0 && quantile <= 1.0) {
                return Err(ConfigError::OutOfRange(Param::CfarQuantile));
            }
        }
        finite(f64::from(self.threshold_db), Param::CfarThreshold)?;
        finite(f64::from(self.window_gate_db), Param::CfarWindowGate)?;
        if !(self.window_gate_db >= 0.0) {
            return Err(ConfigError::OutOfRange(Param::CfarWindowGate));
        }
        if (self.train_range == 0 && self.train_cross == 0)
            || self.full_training_cells() > MAX_TRAINING_CELLS
        {
            return Err(ConfigError::OutOfRange(Param::CfarWindow));
        }
        match kind {
            Columns::Truncated => {
                if 2 * usize::from(self.edge_skip) + 1 > columns {
                    return Err(ConfigError::OutOfRange(Param::CfarEdgeSkip));
                }
            }
            Columns::Periodic => {
                // A wrapped window must not cover a column twice.
                let extent =
                    2 * (usize::from(self.guard_cross) + usize::from(self.train_cross)) + 1;
                if extent > columns {
                    return Err(ConfigError::OutOfRange(Param::CfarWindow));
                }
            }
        }
        Ok(())
    }
}

/// One detection: a cell of a 2-D map.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Detection {
    /// Range bin (map row).
    pub range_bin: u16,
    /// Map column: the azimuth grid bin on the range–azimuth map (DBE chain), the Doppler FFT
    /// bin in natural order on the range–Doppler map (FFT chain; see
    /// [`crate::doppler::signed_bin`]).
    pub column: u16,
    /// Power of the cell, linear.
    pub power: f32,
    /// CFAR noise level (the statistic or the row's floor, before α), linear.
    pub level: f32,
}

/// A fixed-capacity list of detections; on overflow the strongest are kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detections<const DET: usize> {
    items: [Detection; DET],
    len: usize,
    /// Detections dropped because the list was full (the weakest ones).
    pub overflow: u32,
}

impl<const DET: usize> Detections<DET> {
    /// An empty list.
    pub const fn new() -> Self {
        Self {
            items: [Detection {
                range_bin: 0,
                column: 0,
                power: 0.0,
                level: 0.0,
            }; DET],
            len: 0,
            overflow: 0,
        }
    }

    /// Empty the list and the overflow count.
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflow = 0;
    }

    /// The detections, in map order (range bin, then column) unless an overflow replaced
    /// entries.
    pub fn as_slice(&self) -> &[Detection] {
        &self.items[..self.len]
    }

    /// Add `d`; when full, it replaces the weakest entry if stronger. Either way one
    /// detection is lost and counted in `overflow`.
    pub fn push(&mut self, d: Detection) {
        if let Some(slot) = self.items.get_mut(self.len) {
            *slot = d;
            self.len += 1;
            return;
        }
        self.overflow += 1;
        let mut weakest: Option<&mut Detection> = None;
        for it in self.items.iter_mut() {
            if weakest.as_ref().is_none_or(|w| it.power < w.power) {
                weakest = Some(it);
            }
        }
        if let Some(w) = weakest {
            if d.power > w.power {
                *w = d;
            }
        }
    }
}

impl<const DET: usize> Default for Detections<DET> {
    fn default() -> Self {
        Self::new()
    }
}

/// The rows a CFAR runs over and how its columns end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapShape {
    /// First processed row (range bin), inclusive.
    pub first: usize,
    /// Last processed row, inclusive.
    pub last: usize,
    /// The column axis.
    pub columns: Columns,
}

/// Run the CFAR over rows `shape.first..=shape.last` of `map` (linear power), with the
/// optional per-row lower bound `floor` of the noise level (module docs). `p` should have
/// passed validation; other values are clamped, never a panic.
pub fn detect<const N: usize, const C: usize, const DET: usize>(
    map: &[[f32; C]; N],
    floor: Option<&[f32; N]>,
    shape: MapShape,
    p: &CfarParams,
    scratch: &mut [f32; MAX_TRAINING_CELLS],
    out: &mut Detections<DET>,
) {
    out.clear();
    let (first, last) = (shape.first, shape.last.min(N.saturating_sub(1)));
    let periodic = shape.columns == Columns::Periodic;
    let edge = if periodic {
        0
    } else {
        usize::from(p.edge_skip)
    };
    if first > last || C == 0 || 2 * edge >= C {
        return;
    }
    let alpha = libm::powf(10.0, p.threshold_db / 10.0);
    let gr = usize::from(p.guard_range);
    let wr = gr + usize::from(p.train_range);
    let (mut gc, mut wc) = (
        usize::from(p.guard_cross),
        usize::from(p.guard_cross) + usize::from(p.train_cross),
    );
    if periodic {
        // Clamped so that the wrapped window never covers a column twice.
        let half = (C - 1) / 2;
        gc = gc.min(half);
        wc = wc.min(half);
    }
    let averaging = p.kind == CfarKind::CellAveraging;
    // 0 (off) unless the gate is configured.
    let gate = if p.window_gate_db > 0.0 {
        libm::powf(10.0, p.window_gate_db / 10.0)
    } else {
        0.0
    };
    let window = Window {
        first,
        last,
        periodic,
        guard: (gr, gc),
        outer: (wr, wc),
    };
    for b in first..=last {
        // The level is never below the row's floor, so a cell at or below α · floor cannot be
        // a detection: an exact test that spares most noise cells of the DBE map the window.
        let bound = floor.map_or(0.0, |f| alpha * f[b]).max(0.0);
        let Some(row) = map.get(b) else {
            continue;
        };
        for i in candidates(row, edge, C - edge, bound) {
            let cut = row[i];
            if !is_local_max(map, first, last, periodic, b, i) {
                continue;
            }
            let (mut n, mut sum) = (0usize, 0.0f32);
            window.for_each_run(map, b, i, |run| {
                if averaging {
                    for &v in run {
                        sum += v;
                    }
                }
                n += run.len();
                true
            });
            if n == 0 {
                continue;
            }
            let statistic = match p.kind {
                CfarKind::CellAveraging => sum / n as f32,
                CfarKind::OrderStatistic { quantile } => {
                    let k = ceil_index(quantile, n);
                    // `cut > α · v_(k)` (the (k+1)-th smallest) holds exactly when at least
                    // k + 1 training values have `cut > α · v` (`α · v` is monotone in v), so
                    // the CUT fails as soon as n − k values do not: most local maxima of the
                    // noise fail within a part of their window (issue 13). Only a detection
                    // needs the selection, for its level.
                    let (mut not_below, fail) = (0usize, n - k);
                    window.for_each_run(map, b, i, |run| {
                        for &v in run {
                            not_below += usize::from(!(cut > alpha * v));
                        }
                        not_below < fail
                    });
                    if not_below >= fail {
                        continue;
                    }
                    let mut m = 0;
                    window.for_each_run(map, b, i, |run| {
                        if let Some(s) = scratch.get_mut(m..m + run.len()) {
                            s.copy_from_slice(run);
                        }
                        m += run.len();
                        true
                    });
                    // Map powers are ≥ 0 (a NaN or negative value counts as 0 here), and for
                    // non-negative floats the bit patterns order as the values: an integer
                    // compare instead of `total_cmp`'s.
                    let key = |v: &f32| if *v > 0.0 { v.to_bits() } else { 0 };
                    let (_, &mut order, _) = scratch[..n].select_nth_unstable_by_key(k, key);
                    order.max(0.0)
                }
            };
            let level = match floor {
                Some(f) => statistic.max(f[b]),
                None => statistic,
            };
            if !(cut > alpha * level) {
                continue;
            }
            // The window gate (module docs): only a detection pays for its window's maximum.
            if gate > 0.0 && gate * cut < window_max(map, first, last, periodic, b, i, wr, wc) {
                continue;
            }
            out.push(Detection {
                range_bin: b as u16,
                column: i as u16,
                power: cut,
                level,
            });
        }
    }
}

/// The columns `from..to` of `row` that may be local maxima above `bound`, ascending: on a
/// host in blocks of 64 whose candidates are a bit mask from one branch-free pass
/// ([`row_candidates`]; issue 13: a branch per cell of a noisy row mispredicts); on a Cortex-M,
/// which has no branch predictor to miss and pays per instruction, every column above
/// `bound` (most cells of a DBE map lie below their row's loading floor).
#[inline(always)]
fn candidates<const C: usize>(
    row: &[f32; C],
    from: usize,
    to: usize,
    bound: f32,
) -> impl Iterator<Item = usize> + '_ {
    #[cfg(not(target_arch = "arm"))]
    {
        let (mut next, mut base, mut bits) = (from, from, 0u64);
        core::iter::from_fn(move || {
            while bits == 0 {
                if next >= to {
                    return None;
                }
                let end = (next + 64).min(to);
                (base, bits) = (next, row_candidates(row, next, end, bound));
                next = end;
            }
            let i = base + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            Some(i)
        })
    }
    #[cfg(target_arch = "arm")]
    {
        (from..to.min(C)).filter(move |&i| row[i] > bound)
    }
}

/// Bit `j` set when column `from + j` of `row` may be a local maximum above `bound`: it
/// exceeds `bound` and neither row neighbour beats it (the left one when it is ≥, at a lower
/// column; the right one when it is >; `is_local_max`'s rule). A necessary condition only
/// (the other rows, the wrapped neighbours of a periodic row's ends are not looked at), so
/// `is_local_max` decides; `to − from ≤ 64`.
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn row_candidates<const C: usize>(row: &[f32; C], from: usize, to: usize, bound: f32) -> u64 {
    let mut bits = 0u64;
    for (j, i) in (from..to.min(C)).enumerate() {
        let v = row[i];
        let left = row.get(i.wrapping_sub(1)).is_some_and(|&l| l >= v);
        let right = row.get(i + 1).is_some_and(|&r| r > v);
        bits |= u64::from(v > bound && !left && !right) << j;
    }
    bits
}

/// The training window of the CFAR around a cell: rows `first..=last` of the map, columns
/// truncated or wrapped, guard and outer half-widths `(range, cross)`.
#[derive(Clone, Copy, Debug)]
struct Window {
    first: usize,
    last: usize,
    periodic: bool,
    guard: (usize, usize),
    outer: (usize, usize),
}

impl Window {
    /// Call `f` with each run of training cells around `(b, i)`, row by row and each row's
    /// columns in ascending order (the order of the CA sum), at most [`MAX_TRAINING_CELLS`]
    /// cells in all (the rest of the window is ignored), until `f` returns `false`.
    #[inline(always)]
    fn for_each_run<const N: usize, const C: usize>(
        &self,
        map: &[[f32; C]; N],
        b: usize,
        i: usize,
        mut f: impl FnMut(&[f32]) -> bool,
    ) {
        let ((gr, gc), (wr, wc)) = (self.guard, self.outer);
        let mut n = 0usize;
        for rb in b.saturating_sub(wr).max(self.first)..=(b + wr).min(self.last) {
            let Some(row) = map.get(rb) else {
                return;
            };
            // Offsets −wc..=wc from the CUT, without the guard's on the guard rows.
            let offsets = if rb.abs_diff(b) <= gr {
                [
                    (-(wc as isize), -(gc as isize) - 1),
                    (gc as isize + 1, wc as isize),
                ]
            } else {
                [(-(wc as isize), wc as isize), (1, 0)]
            };
            for (lo, hi) in offsets {
                for cols in column_runs::<C>(i, lo, hi, self.periodic) {
                    let run = row.get(cols).unwrap_or(&[]);
                    let run = &run[..run.len().min(MAX_TRAINING_CELLS - n)];
                    n += run.len();
                    if !f(run) {
                        return;
                    }
                }
            }
        }
    }
}

/// The columns at offsets `lo..=hi` from column `i`, as at most two ascending runs of a row
/// of `C` columns: wrapped (the second run is the part past the end, continued from column
/// 0), or clipped to the row when the columns are truncated. Empty when `lo > hi`.
fn column_runs<const C: usize>(
    i: usize,
    lo: isize,
    hi: isize,
    periodic: bool,
) -> [core::ops::Range<usize>; 2] {
    let (c, i) = (C as isize, i as isize);
    if lo > hi {
        return [0..0, 0..0];
    }
    let (start, end) = (i + lo, i + hi + 1);
    if !periodic {
        let clip = |x: isize| x.clamp(0, c) as usize;
        return [clip(start)..clip(end), 0..0];
    }
    // Offsets are clamped to within half a row, so start > −C and end ≤ 2C.
    let start = start.rem_euclid(c);
    let len = (end - (i + lo)).min(c);
    if start + len <= c {
        [start as usize..(start + len) as usize, 0..0]
    } else {
        [start as usize..C, 0..(start + len - c) as usize]
    }
}

/// The largest value of the window of half-widths `wr` × `wc` around `(b, i)` (rows
/// `first..=last`; columns truncated or wrapped). Kept out of line: it runs per detection
/// only, and inlined into the cell loop it cost the FFT chain's CFAR (gate off) 2 %.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn window_max<const N: usize, const C: usize>(
    map: &[[f32; C]; N],
    first: usize,
    last: usize,
    periodic: bool,
    b: usize,
    i: usize,
    wr: usize,
    wc: usize,
) -> f32 {
    let mut best = 0.0f32;
    for row in map
        .get(b.saturating_sub(wr).max(first)..=(b + wr).min(last))
        .unwrap_or(&[])
    {
        for cols in column_runs::<C>(i, -(wc as isize), wc as isize, periodic) {
            for &v in row.get(cols).unwrap_or(&[]) {
                // `f32::max` up to a NaN (skipped either way: `best` starts at 0 and never
                // becomes one) and the sign of a zero, but one MAXPS per four cells on a host
                // and no `fmaxf` call on a Cortex-M.
                best = if v > best { v } else { best };
            }
        }
    }
    best
}

/// Zero-based index of the `⌈q·n⌉`-th smallest of `n ≥ 1` values, clamped to `0..n`.
pub(crate) fn ceil_index(q: f32, n: usize) -> usize {
    let k = libm::ceilf(q * n as f32);
    let k = if k.is_finite() { k as usize } else { n };
    k.clamp(1, n) - 1
}

/// `map[b][i]` is the maximum of its 3×3 neighbourhood (rows `first..=last`; columns
/// truncated or wrapped); an equal neighbour at a lower `(row, column)` wins, so a flat
/// plateau yields one maximum.
fn is_local_max<const N: usize, const C: usize>(
    map: &[[f32; C]; N],
    first: usize,
    last: usize,
    periodic: bool,
    b: usize,
    i: usize,
) -> bool {
    let v = map[b][i];
    let neighbours = if periodic {
        [Some((i + C - 1) % C), Some(i), Some((i + 1) % C)]
    } else {
        [i.checked_sub(1), Some(i), Some(i + 1).filter(|&c| c < C)]
    };
    let beats = |rb: usize, ai: usize| {
        let u = map[rb][ai];
        u > v || (u == v && (rb, ai) < (b, i))
    };
    // The row's own neighbours first: along a smooth spectrum most cells already lose there.
    if neighbours
        .into_iter()
        .flatten()
        .any(|ai| ai != i && beats(b, ai))
    {
        return false;
    }
    for rb in b.saturating_sub(1).max(first)..=(b + 1).min(last) {
        if rb == b {
            continue;
        }
        if neighbours.into_iter().flatten().any(|ai| beats(rb, ai)) {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run<const N: usize, const C: usize>(
        map: &[[f32; C]; N],
        p: &CfarParams,
        columns: Columns,
    ) -> Detections<8> {
        let mut scratch = [0.0; MAX_TRAINING_CELLS];
        let mut out = Detections::<8>::new();
        let shape = MapShape {
            first: 0,
            last: N - 1,
            columns,
        };
        detect(map, None, shape, p, &mut scratch, &mut out);
        out
    }

    fn cells(out: &Detections<8>) -> Vec<(u16, u16)> {
        out.as_slice()
            .iter()
            .map(|d| (d.range_bin, d.column))
            .collect()
    }

    #[test]
    fn ceil_index_follows_the_spec() {
        assert_eq!(ceil_index(0.75, 280), 209);
        assert_eq!(ceil_index(0.75, 1), 0);
        assert_eq!(ceil_index(1.0, 10), 9);
        assert_eq!(ceil_index(0.01, 10), 0);
    }

    #[test]
    fn plateau_gives_one_detection_and_truncated_edges_do_not_wrap() {
        let mut map = [[1.0f32; 32]; 16];
        map[8][10] = 100.0;
        map[8][11] = 100.0;
        // A target at the first azimuth column must not see the last column as a neighbour.
        map[4][0] = 50.0;
        map[4][31] = 60.0;
        let p = CfarParams {
            edge_skip: 0,
            ..CfarParams::RANGE_AZIMUTH
        };
        let out = run(&map, &p, Columns::Truncated);
        assert_eq!(cells(&out), [(4, 0), (4, 31), (8, 10)]);
        for d in out.as_slice() {
            assert_eq!(d.level, 1.0);
        }
        // The edge skip removes both edge targets.
        let out = run(&map, &CfarParams::RANGE_AZIMUTH, Columns::Truncated);
        assert_eq!(cells(&out), [(8, 10)]);
    }

    #[test]
    fn periodic_columns_wrap_and_rows_do_not() {
        // A peak split over columns C−1 and 0 (a static target's ridge straddles the FFT's
        // wrap) is one detection, at the lower index.
        let mut map = [[1.0f32; 16]; 16];
        map[8][15] = 100.0;
        map[8][0] = 100.0;
        // A peak at row 0 must not see row 15 as a neighbour.
        map[0][5] = 50.0;
        map[15][5] = 60.0;
        for p in [CfarParams::RANGE_DOPPLER_CA, CfarParams::RANGE_DOPPLER_OS] {
            let out = run(&map, &p, Columns::Periodic);
            assert_eq!(cells(&out), [(0, 5), (8, 0), (15, 5)], "{p:?}");
        }
    }

    #[test]
    fn training_window_wraps_on_periodic_columns() {
        // Training cells at columns C−3..C−6 (the wrapped side) carry a high level: the CUT at
        // column 0 must see it, so it is not a detection under CA-CFAR.
        let mut map = [[1.0f32; 32]; 16];
        for row in map.iter_mut() {
            for d in 26..=29 {
                row[d] = 40.0;
            }
        }
        map[8][0] = 30.0;
        let out = run(&map, &CfarParams::RANGE_DOPPLER_CA, Columns::Periodic);
        // Level = (4 columns · 13 rows · 40 + the rest · 1) / 144 ≈ 15: 30 < 4·15.
        assert!(out.as_slice().iter().all(|d| d.column != 0));
        // On a truncated map the same CUT sees none of it (and is not skipped: edge 0).
        let out = run(&map, &CfarParams::RANGE_DOPPLER_CA, Columns::Truncated);
        assert!(out.as_slice().iter().any(|d| d.column == 0));
        // The same CUT with an unwrapped level of 1 is detected.
        let mut flat = [[1.0f32; 32]; 16];
        flat[8][0] = 30.0;
        let out = run(&flat, &CfarParams::RANGE_DOPPLER_CA, Columns::Periodic);
        assert_eq!(out.as_slice().len(), 1);
        assert_eq!(out.as_slice()[0].level, 1.0);
    }

    #[test]
    fn ca_level_is_the_mean_and_os_level_the_order_statistic() {
        let mut map = [[0.0f32; 32]; 32];
        for (b, row) in map.iter_mut().enumerate() {
            for (d, v) in row.iter_mut().enumerate() {
                // Distinct, bounded values: 1.0 .. 2.0.
                *v = 1.0 + ((b * 32 + d) % 97) as f32 / 97.0;
            }
        }
        map[16][10] = 1000.0;
        let mut vals = Vec::new();
        for rb in 10..=22usize {
            for dd in 4..=16usize {
                if rb.abs_diff(16) <= 2 && dd.abs_diff(10) <= 2 {
                    continue;
                }
                vals.push(map[rb][dd]);
            }
        }
        assert_eq!(vals.len(), 144);
        let mean = vals.iter().sum::<f32>() / 144.0;
        vals.sort_by(f32::total_cmp);
        let os = vals[107]; // ⌈0.75·144⌉ = 108th smallest.
        let find = |out: &Detections<8>| {
            *out.as_slice()
                .iter()
                .find(|d| (d.range_bin, d.column) == (16, 10))
                .expect("the peak is detected")
        };
        for columns in [Columns::Periodic, Columns::Truncated] {
            let ca = find(&run(&map, &CfarParams::RANGE_DOPPLER_CA, columns));
            assert!((ca.level - mean).abs() < 1e-5 * mean);
            let os_det = find(&run(&map, &CfarParams::RANGE_DOPPLER_OS, columns));
            assert_eq!(os_det.level, os);
        }
    }

    #[test]
    fn the_row_floor_bounds_the_level() {
        let mut map = [[1.0f32; 32]; 16];
        map[8][10] = 100.0;
        let mut floor = [0.0f32; 16];
        floor[8] = 20.0;
        let mut scratch = [0.0; MAX_TRAINING_CELLS];
        let mut out = Detections::<8>::new();
        let shape = MapShape {
            first: 0,
            last: 15,
            columns: Columns::Truncated,
        };
        let p = CfarParams {
            threshold_db: 8.0,
            ..CfarParams::RANGE_AZIMUTH
        };
        detect(&map, Some(&floor), shape, &p, &mut scratch, &mut out);
        // 100 < 10^0.8 · 20 = 126: the floor, not the training cells (level 1), decides.
        assert!(out.as_slice().is_empty());
        floor[8] = 10.0;
        detect(&map, Some(&floor), shape, &p, &mut scratch, &mut out);
        assert_eq!(out.as_slice().len(), 1);
        assert_eq!(out.as_slice()[0].level, 10.0);
    }

    #[test]
    fn the_window_gate_drops_a_skirt_below_a_strong_neighbour() {
        // A strong cell (10⁴) and, 3 rows and 4 columns away inside its window, a weak local
        // maximum (200, 23 dB over the floor of 1, 17 dB below the strong cell).
        let mut map = [[1.0f32; 40]; 24];
        map[8][16] = 1.0e4;
        map[11][20] = 200.0;
        let gated = CfarParams {
            window_gate_db: 12.0,
            ..CfarParams::RANGE_AZIMUTH
        };
        let found = |map: &[[f32; 40]; 24], p: &CfarParams| cells(&run(map, p, Columns::Truncated));
        assert_eq!(found(&map, &gated), vec![(8, 16)]);
        // Within the gate (17 dB < 20 dB), or with the gate off, it stays.
        let wide = CfarParams {
            window_gate_db: 20.0,
            ..gated
        };
        let off = CfarParams {
            window_gate_db: 0.0,
            ..gated
        };
        assert_eq!(found(&map, &wide), vec![(8, 16), (11, 20)]);
        assert_eq!(found(&map, &off), vec![(8, 16), (11, 20)]);
        // Outside the window (2 + 4 = 6 rows), the strong cell does not gate it.
        map[11][20] = 1.0;
        map[15][20] = 200.0;
        assert_eq!(found(&map, &gated), vec![(8, 16), (15, 20)]);
        // A negative or non-finite gate is refused.
        for bad in [-1.0, f32::NAN, f32::INFINITY] {
            let p = CfarParams {
                window_gate_db: bad,
                ..gated
            };
            assert!(p.validate(40, Columns::Truncated).is_err(), "{bad}");
        }
    }

    #[test]
    fn overflow_keeps_the_strongest() {
        let mut list = Detections::<2>::new();
        for (i, p) in [3.0, 1.0, 5.0, 2.0].iter().enumerate() {
            list.push(Detection {
                range_bin: i as u16,
                power: *p,
                ..Detection::default()
            });
        }
        let mut kept: [f32; 2] = [list.as_slice()[0].power, list.as_slice()[1].power];
        kept.sort_by(f32::total_cmp);
        assert_eq!(kept, [3.0, 5.0]);
        assert_eq!(list.overflow, 2);
    }

    /// The module docs' CFAR cell by cell, with nothing skipped: every cell in the edges is
    /// tested against its 3×3 neighbourhood and a sorted training window.
    fn plain_detect<const N: usize, const C: usize>(
        map: &[[f32; C]; N],
        floor: Option<&[f32; N]>,
        shape: MapShape,
        p: &CfarParams,
    ) -> Vec<Detection> {
        let periodic = shape.columns == Columns::Periodic;
        let edge = if periodic {
            0
        } else {
            usize::from(p.edge_skip)
        };
        let (gr, tr) = (p.guard_range as isize, p.train_range as isize);
        let (gc, tc) = (p.guard_cross as isize, p.train_cross as isize);
        let alpha = libm::powf(10.0, p.threshold_db / 10.0);
        let gate = libm::powf(10.0, p.window_gate_db / 10.0);
        let rows = shape.first as isize..=shape.last as isize;
        let column = |c: isize| match periodic {
            true => Some(c.rem_euclid(C as isize) as usize),
            false => (0..C as isize).contains(&c).then_some(c as usize),
        };
        let mut out = Vec::new();
        for b in shape.first..=shape.last {
            for i in edge..C - edge {
                let v = map[b][i];
                let mut local_max = true;
                for db in -1..=1isize {
                    for dc in -1..=1isize {
                        let rb = b as isize + db;
                        let Some(ci) = column(i as isize + dc) else {
                            continue;
                        };
                        if (db, dc) == (0, 0) || !rows.contains(&rb) {
                            continue;
                        }
                        let u = map[rb as usize][ci];
                        if u > v || (u == v && (rb as usize, ci) < (b, i)) {
                            local_max = false;
                        }
                    }
                }
                let (mut train, mut window_max) = (Vec::new(), 0.0f32);
                for db in -(gr + tr)..=gr + tr {
                    for dc in -(gc + tc)..=gc + tc {
                        let rb = b as isize + db;
                        let Some(ci) = column(i as isize + dc) else {
                            continue;
                        };
                        if !rows.contains(&rb) {
                            continue;
                        }
                        let u = map[rb as usize][ci];
                        window_max = window_max.max(u);
                        if db.abs() > gr || dc.abs() > gc {
                            train.push(u);
                        }
                    }
                }
                if !local_max || train.is_empty() {
                    continue;
                }
                let statistic = match p.kind {
                    CfarKind::CellAveraging => train.iter().sum::<f32>() / train.len() as f32,
                    CfarKind::OrderStatistic { quantile } => {
                        train.sort_by(f32::total_cmp);
                        train[ceil_index(quantile, train.len())]
                    }
                };
                let level = floor.map_or(statistic, |f| statistic.max(f[b]));
                let gated = p.window_gate_db > 0.0 && gate * v < window_max;
                if v > alpha * level && !gated {
                    out.push(Detection {
                        range_bin: b as u16,
                        column: i as u16,
                        power: v,
                        level,
                    });
                }
            }
        }
        out
    }

    #[test]
    fn detections_are_those_of_the_plain_cell_by_cell_cfar() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(13);
        let (mut total, mut maps) = (0, 0);
        for trial in 0..400 {
            // Exponential noise on a coarse grid of values (ties and plateaus happen), a few
            // strong cells; columns past 64 exercise the column blocks.
            let mut map = [[0.0f32; 150]; 24];
            for row in map.iter_mut() {
                for v in row.iter_mut() {
                    let e: f32 = -libm::logf(1.0 - rng.gen::<f32>());
                    *v = libm::roundf(e * 4.0) / 4.0;
                }
            }
            for _ in 0..rng.gen_range(0..6) {
                let (b, i) = (rng.gen_range(0..24), rng.gen_range(0..150));
                map[b][i] = rng.gen_range(2.0..40.0f32);
            }
            let floor: [f32; 24] = core::array::from_fn(|_| rng.gen_range(0.0..1.5f32));
            let columns = match trial % 2 {
                0 => Columns::Truncated,
                _ => Columns::Periodic,
            };
            let p = CfarParams {
                kind: match trial % 3 {
                    2 => CfarKind::CellAveraging,
                    _ => CfarKind::OrderStatistic {
                        quantile: rng.gen_range(0.3..1.0),
                    },
                },
                threshold_db: rng.gen_range(0.5..6.0),
                window_gate_db: [0.0, 6.0, 12.0][trial % 3],
                edge_skip: (trial % 5) as u8,
                ..CfarParams::RANGE_AZIMUTH
            };
            let shape = MapShape {
                first: trial % 4,
                last: 23 - trial % 3,
                columns,
            };
            let floor = (trial % 4 != 0).then_some(&floor);
            let mut scratch = [0.0; MAX_TRAINING_CELLS];
            let mut out = Detections::<512>::new();
            detect(&map, floor, shape, &p, &mut scratch, &mut out);
            let want = plain_detect(&map, floor, shape, &p);
            assert_eq!(out.as_slice(), &want[..], "trial {trial}");
            total += want.len();
            maps += usize::from(!want.is_empty());
        }
        // The comparison is not vacuous: most maps have detections.
        assert!(
            maps > 300 && total > 1000,
            "{maps} maps, {total} detections"
        );
    }
}
