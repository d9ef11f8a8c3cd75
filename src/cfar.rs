//! Stage 2: 2-D OS-CFAR with a 3×3 local-maximum rule on the range–azimuth map.
//!
//! For a cell under test (CUT) the training cells are the window of half-widths
//! `guard + train` around it minus the guard window, truncated at the map's edges (never
//! wrapped) and at the processed range window. The noise level is the `⌈q·n⌉`-th smallest of
//! the `n` training values; the CUT is a detection when it exceeds `α · level` and is a local
//! maximum of its 3×3 neighbourhood (ties broken towards the lower index, so a plateau gives
//! one detection). Only local maxima are tested, which gives the same detections as testing
//! every cell at a fraction of the cost.
//!
//! Loading floor: diagonal loading `δ_b` of range bin `b` bounds its Capon spectrum from
//! below, `P(θ) ≥ δ_b / D` (because `(R + δI)⁻¹ ≼ I/δ`), and with a strong target `δ_b` is a
//! fixed fraction of that target's power. The whole row then sits on a flat ridge whose
//! ripples are local maxima; training cells from quieter neighbouring rows would put the
//! order statistic below the ridge and declare the ripples detections. The noise level of a
//! cell is therefore never taken below its row's floor: `level = max(order statistic,
//! floor[b])`. Noise-limited rows are unaffected (there `δ_b / D ≪ σ² / D`).

use crate::config::CfarParams;

/// Capacity of the training-cell scratch buffer: the largest `n` a configuration may ask for.
pub const MAX_TRAINING_CELLS: usize = 1024;

/// One detection on the range–azimuth map.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Detection {
    /// Range bin.
    pub range_bin: u16,
    /// Azimuth grid bin.
    pub azimuth_bin: u16,
    /// Capon power of the cell, linear.
    pub power: f32,
    /// CFAR noise level (the order statistic or the row's loading floor, before α), linear.
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
                azimuth_bin: 0,
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

    /// The detections, in map order (range bin, then azimuth bin) unless an overflow
    /// replaced entries.
    pub fn as_slice(&self) -> &[Detection] {
        &self.items[..self.len]
    }

    /// Add `d`; when full, it replaces the weakest entry if stronger. Either way one
    /// detection is lost and counted in `overflow`.
    pub fn push(&mut self, d: Detection) {
        if self.len < DET {
            self.items[self.len] = d;
            self.len += 1;
            return;
        }
        self.overflow += 1;
        let mut weakest = None;
        for (i, it) in self.items.iter().enumerate() {
            if weakest.is_none_or(|(_, p)| it.power < p) {
                weakest = Some((i, it.power));
            }
        }
        if let Some((i, p)) = weakest {
            if d.power > p {
                self.items[i] = d;
            }
        }
    }
}

impl<const DET: usize> Default for Detections<DET> {
    fn default() -> Self {
        Self::new()
    }
}

/// Run OS-CFAR over rows `first..=last` of `map` (linear power, `map[range][azimuth]`), with
/// the per-row lower bound `floor` of the noise level (see the module docs).
pub fn detect<const N: usize, const NAZ: usize, const DET: usize>(
    map: &[[f32; NAZ]; N],
    floor: &[f32; N],
    first: usize,
    last: usize,
    p: &CfarParams,
    scratch: &mut [f32; MAX_TRAINING_CELLS],
    out: &mut Detections<DET>,
) {
    out.clear();
    let last = last.min(N.saturating_sub(1));
    let edge = usize::from(p.edge_skip_azimuth);
    if first > last || 2 * edge >= NAZ {
        return;
    }
    let alpha = libm::powf(10.0, p.threshold_db / 10.0);
    let (gr, ga) = (usize::from(p.guard_range), usize::from(p.guard_azimuth));
    let (wr, wa) = (
        gr + usize::from(p.train_range),
        ga + usize::from(p.train_azimuth),
    );
    for b in first..=last {
        for i in edge..(NAZ - edge) {
            let cut = map[b][i];
            if !(cut > 0.0) || !is_local_max(map, first, last, b, i) {
                continue;
            }
            let mut n = 0;
            for rb in b.saturating_sub(wr).max(first)..=(b + wr).min(last) {
                for ai in i.saturating_sub(wa)..=(i + wa).min(NAZ - 1) {
                    if rb.abs_diff(b) <= gr && ai.abs_diff(i) <= ga {
                        continue;
                    }
                    if n < MAX_TRAINING_CELLS {
                        scratch[n] = map[rb][ai];
                        n += 1;
                    }
                }
            }
            if n == 0 {
                continue;
            }
            let k = ceil_index(p.quantile, n);
            let (_, &mut order, _) = scratch[..n].select_nth_unstable_by(k, f32::total_cmp);
            let level = order.max(floor[b]);
            if cut > alpha * level {
                out.push(Detection {
                    range_bin: b as u16,
                    azimuth_bin: i as u16,
                    power: cut,
                    level,
                });
            }
        }
    }
}

/// Zero-based index of the `⌈q·n⌉`-th smallest of `n ≥ 1` values, clamped to `0..n`
/// (shared with the range–Doppler CFAR).
pub(crate) fn ceil_index(q: f32, n: usize) -> usize {
    let k = libm::ceilf(q * n as f32);
    let k = if k.is_finite() { k as usize } else { n };
    k.clamp(1, n) - 1
}

/// `map[b][i]` is the maximum of its 3×3 neighbourhood (inside rows `first..=last`); equal
/// neighbours at a lower index win, so a flat plateau yields one maximum.
fn is_local_max<const N: usize, const NAZ: usize>(
    map: &[[f32; NAZ]; N],
    first: usize,
    last: usize,
    b: usize,
    i: usize,
) -> bool {
    let v = map[b][i];
    for rb in b.saturating_sub(1).max(first)..=(b + 1).min(last) {
        for ai in i.saturating_sub(1)..=(i + 1).min(NAZ - 1) {
            if (rb, ai) == (b, i) {
                continue;
            }
            let u = map[rb][ai];
            let earlier = (rb, ai) < (b, i);
            if u > v || (earlier && u == v) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_index_follows_the_spec() {
        assert_eq!(ceil_index(0.75, 280), 209);
        assert_eq!(ceil_index(0.75, 1), 0);
        assert_eq!(ceil_index(1.0, 10), 9);
        assert_eq!(ceil_index(0.01, 10), 0);
    }

    #[test]
    fn plateau_gives_one_detection_and_edges_do_not_wrap() {
        let mut map = [[1.0f32; 32]; 16];
        map[8][10] = 100.0;
        map[8][11] = 100.0;
        // A target at the last azimuth column must not see the first column as a neighbour.
        map[4][0] = 50.0;
        let mut scratch = [0.0; MAX_TRAINING_CELLS];
        let mut out = Detections::<8>::new();
        let p = CfarParams {
            edge_skip_azimuth: 0,
            ..CfarParams::DEFAULT
        };
        detect(&map, &[0.0; 16], 0, 15, &p, &mut scratch, &mut out);
        let cells: [(u16, u16); 2] = [(4, 0), (8, 10)];
        assert_eq!(out.as_slice().len(), 2);
        for (d, c) in out.as_slice().iter().zip(cells.iter()) {
            assert_eq!((d.range_bin, d.azimuth_bin), *c);
            assert_eq!(d.level, 1.0);
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
}
