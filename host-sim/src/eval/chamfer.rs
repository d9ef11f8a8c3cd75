//! Chamfer distance between point clouds, voxel downsampling and nearest-neighbour search.
//!
//! **Chamfer distance** (symmetric mean of nearest-neighbour distances), of a cloud `P`
//! against a reference `T`, both non-empty:
//!
//! ```text
//! CD(P, T) = ½ · ( mean_{p ∈ P} min_{t ∈ T} |p − t|  +  mean_{t ∈ T} min_{p ∈ P} |t − p| )
//! ```
//!
//! in metres. The first term ("accuracy") says how far the points are from the surfaces,
//! the second ("completeness") how much of the surfaces the points cover. Identical clouds
//! give 0; a cloud shifted by `d` against itself gives `d` as long as `d` is below half the
//! spacing of its points.
//!
//! **Voxel downsampling** at resolution `r` replaces the points of each occupied cube
//! `[i·r, (i+1)·r) × [j·r, …) × [k·r, …)` by their centroid (as Open3D's
//! `voxel_down_sample`), so a dense reference and a sparse cloud are compared at the same
//! spatial resolution. The output is ordered by voxel index, so it is deterministic.

use std::collections::BTreeMap;

/// A 3-D point, m.
pub type P3 = [f64; 3];

/// The centroid of the points in each occupied voxel of side `voxel` (m), ordered by voxel
/// index. A non-positive or non-finite `voxel` returns the points unchanged; non-finite
/// points are dropped.
pub fn voxel_downsample(points: &[P3], voxel: f64) -> Vec<P3> {
    let finite: Vec<P3> = points
        .iter()
        .copied()
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    if !(voxel.is_finite() && voxel > 0.0) {
        return finite;
    }
    let mut cells: BTreeMap<[i64; 3], ([f64; 3], usize)> = BTreeMap::new();
    for p in &finite {
        let key = p.map(|v| (v / voxel).floor() as i64);
        let e = cells.entry(key).or_insert(([0.0; 3], 0));
        for (s, v) in e.0.iter_mut().zip(p) {
            *s += v;
        }
        e.1 += 1;
    }
    cells
        .values()
        .map(|(s, n)| s.map(|v| v / *n as f64))
        .collect()
}

/// A static k-d tree over 3-D points for exact nearest-neighbour queries.
#[derive(Clone, Debug)]
pub struct KdTree {
    points: Vec<P3>,
    /// Implicit tree over `points`: the median of each index range splits on `axis`.
    axis: Vec<u8>,
}

impl KdTree {
    /// Build the tree (the points are reordered internally; non-finite points are dropped).
    pub fn new(points: &[P3]) -> Self {
        let mut pts: Vec<P3> = points
            .iter()
            .copied()
            .filter(|p| p.iter().all(|v| v.is_finite()))
            .collect();
        let mut axis = vec![0u8; pts.len()];
        build(&mut pts, &mut axis);
        Self { points: pts, axis }
    }

    /// Points in the tree.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the tree is empty.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Distance from `q` to the nearest point, or `None` for an empty tree.
    pub fn nearest_distance(&self, q: &P3) -> Option<f64> {
        self.nearest(q).map(|(_, d)| d)
    }

    /// The nearest point to `q` and its distance, or `None` for an empty tree.
    pub fn nearest(&self, q: &P3) -> Option<(P3, f64)> {
        if self.points.is_empty() {
            return None;
        }
        let mut best = (f64::INFINITY, 0);
        self.search(0, self.points.len(), q, &mut best);
        Some((self.points[best.1], best.0.sqrt()))
    }

    /// Search `lo..hi` for `q`; `best` is (squared distance, index) of the nearest so far.
    fn search(&self, lo: usize, hi: usize, q: &P3, best: &mut (f64, usize)) {
        if lo >= hi {
            return;
        }
        let mid = lo + (hi - lo) / 2;
        let p = &self.points[mid];
        let d2 = dist2(p, q);
        if d2 < best.0 {
            *best = (d2, mid);
        }
        let a = usize::from(self.axis[mid]);
        let diff = q[a] - p[a];
        let (near, far) = if diff < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.search(near.0, near.1, q, best);
        if diff * diff < best.0 {
            self.search(far.0, far.1, q, best);
        }
    }
}

/// Order `pts` into an implicit k-d tree: the median of every range splits on the axis of
/// largest spread, recorded in `axis`.
fn build(pts: &mut [P3], axis: &mut [u8]) {
    if pts.len() <= 1 {
        return;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts.iter() {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let a = (0..3)
        .max_by(|&x, &y| (hi[x] - lo[x]).total_cmp(&(hi[y] - lo[y])))
        .unwrap_or(0);
    let mid = pts.len() / 2;
    pts.select_nth_unstable_by(mid, |x, y| x[a].total_cmp(&y[a]));
    axis[mid] = a as u8;
    let (left, rest) = pts.split_at_mut(mid);
    let (laxis, raxis) = axis.split_at_mut(mid);
    build(left, laxis);
    build(&mut rest[1..], &mut raxis[1..]);
}

fn dist2(a: &P3, b: &P3) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// Mean distance from each point of `from` to its nearest neighbour in `to`; `None` when
/// either is empty.
pub fn mean_nearest_distance(from: &[P3], to: &KdTree) -> Option<f64> {
    if from.is_empty() {
        return None;
    }
    let mut sum = 0.0;
    for p in from {
        sum += to.nearest_distance(p)?;
    }
    Some(sum / from.len() as f64)
}

/// The Chamfer distance of a cloud against a reference and its two terms, m.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Chamfer {
    /// `½ · (accuracy + completeness)`.
    pub distance: f64,
    /// Mean distance from the cloud's points to the reference.
    pub accuracy: f64,
    /// Mean distance from the reference's points to the cloud.
    pub completeness: f64,
}

/// The Chamfer distance of `cloud` against `reference` (module docs); `None` when either is
/// empty.
pub fn chamfer(cloud: &[P3], reference: &[P3]) -> Option<Chamfer> {
    chamfer_with_tree(cloud, reference, &KdTree::new(reference))
}

/// [`chamfer`] with a prebuilt tree of `reference` (reused across clouds).
pub fn chamfer_with_tree(cloud: &[P3], reference: &[P3], tree: &KdTree) -> Option<Chamfer> {
    let accuracy = mean_nearest_distance(cloud, tree)?;
    let completeness = mean_nearest_distance(reference, &KdTree::new(cloud))?;
    Some(Chamfer {
        distance: 0.5 * (accuracy + completeness),
        accuracy,
        completeness,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn kd_tree_matches_brute_force() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let pts: Vec<P3> = (0..500)
            .map(|_| {
                [
                    rng.gen_range(-5.0..5.0),
                    rng.gen_range(-5.0..5.0),
                    rng.gen_range(-1.0..1.0),
                ]
            })
            .collect();
        let tree = KdTree::new(&pts);
        for _ in 0..300 {
            let q: P3 = [
                rng.gen_range(-6.0..6.0),
                rng.gen_range(-6.0..6.0),
                rng.gen_range(-2.0..2.0),
            ];
            let brute = pts
                .iter()
                .map(|p| dist2(p, &q))
                .fold(f64::INFINITY, f64::min)
                .sqrt();
            let got = tree.nearest_distance(&q).unwrap_or(f64::NAN);
            assert!((got - brute).abs() < 1e-12, "{got} vs {brute}");
        }
    }

    #[test]
    fn voxel_centroids() {
        let pts = [[0.01, 0.01, 0.01], [0.03, 0.03, 0.03], [0.51, 0.0, 0.0]];
        let v = voxel_downsample(&pts, 0.1);
        assert_eq!(v.len(), 2);
        assert!((v[0][0] - 0.02).abs() < 1e-12);
        assert_eq!(voxel_downsample(&pts, 0.0).len(), 3);
    }
}
