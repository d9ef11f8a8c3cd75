//! Points: the one place both chains turn a range and a direction into a [`Point`], the point
//! cloud of one frame and its statistics.

use glam::Vec3;

/// One output point (spec §3 step 5).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Point {
    /// Position in the radar frame (x forward, y left, z up), m.
    pub position: Vec3,
    /// Radial velocity, m/s, positive = receding.
    pub velocity_mps: f32,
    /// Capon spectrum power at the point's direction (12-element covariance), dB of
    /// range-FFT units squared.
    pub power_db: f32,
    /// Range–azimuth map power over the CFAR noise level (the order statistic), dB.
    pub snr_db: f32,
    /// Range bin.
    pub range_bin: u16,
    /// Azimuth grid bin (after TDM refinement, when on).
    pub azimuth_bin: u16,
    /// Elevation grid bin.
    pub elevation_bin: u16,
    /// Signed Doppler bin, `−K/2 .. K/2`.
    pub doppler_bin: i16,
}

impl Point {
    /// A point at `range_m` in the direction with cosines `μ` (azimuth, `−u_y`) and `ν`
    /// (elevation, `u_z`): `x = R·√(1 − μ² − ν²)`, `y = −R·μ`, `z = R·ν` (spec §2), every
    /// other field zero. `None` when `μ² + ν² ≥ 1` (no such direction) or either is NaN.
    ///
    /// ```
    /// let p = dbe_radar::Point::at(2.0, 0.6, 0.0).unwrap();
    /// assert!((p.position.x - 1.6).abs() < 1e-6 && (p.position.y + 1.2).abs() < 1e-6);
    /// assert!(dbe_radar::Point::at(2.0, 0.8, 0.6).is_none());
    /// ```
    pub fn at(range_m: f32, mu: f32, nu: f32) -> Option<Self> {
        let cos2 = 1.0 - mu * mu - nu * nu;
        if !(cos2 > 0.0) {
            return None;
        }
        Some(Self {
            position: Vec3::new(range_m * libm::sqrtf(cos2), -range_m * mu, range_m * nu),
            ..Self::default()
        })
    }
}

/// `10·log10(power)` of a linear power, floored at the smallest positive `f32` (a point's
/// `power_db`).
pub(crate) fn power_db(power: f32) -> f32 {
    10.0 * libm::log10f(power.max(f32::MIN_POSITIVE))
}

/// Per-frame statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct FrameStats {
    /// CFAR detections kept (after overflow handling).
    pub detections: u32,
    /// Detections dropped because the detection list was full.
    pub detection_overflow: u32,
    /// Points written.
    pub points: u32,
    /// Points dropped because the point list was full.
    pub point_overflow: u32,
    /// Range bins skipped because their covariance was not positive definite.
    pub skipped_range_bins: u32,
    /// Detections that gave no point (no interior elevation peak, every direction invalid, or
    /// no direction whose Doppler agrees with the detection's, `Params::doppler_agreement_bins`).
    pub detections_without_point: u32,
    /// Detections whose azimuth beam failed the Doppler test (DBE chain,
    /// `Params::doppler_test_db`): no slow-time peak above the beam's noise.
    pub doppler_rejected: u32,
}

/// A fixed-capacity point cloud.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointCloud<const P: usize> {
    points: [Point; P],
    len: usize,
    /// Statistics of the frame that produced the points.
    pub stats: FrameStats,
}

impl<const P: usize> PointCloud<P> {
    /// An empty cloud.
    pub const fn new() -> Self {
        Self {
            points: [Point {
                position: Vec3::ZERO,
                velocity_mps: 0.0,
                power_db: 0.0,
                snr_db: 0.0,
                range_bin: 0,
                azimuth_bin: 0,
                elevation_bin: 0,
                doppler_bin: 0,
            }; P],
            len: 0,
            stats: FrameStats {
                detections: 0,
                detection_overflow: 0,
                points: 0,
                point_overflow: 0,
                skipped_range_bins: 0,
                detections_without_point: 0,
                doppler_rejected: 0,
            },
        }
    }

    /// The points.
    pub fn points(&self) -> &[Point] {
        &self.points[..self.len]
    }

    /// The points, to amend in place (the DBE chain's joint elevation fit).
    pub(crate) fn points_mut(&mut self) -> &mut [Point] {
        &mut self.points[..self.len]
    }

    /// Forget the points and statistics (the first thing a chain's point stage does; a
    /// caller does it for a frame it could not process, so no stale points remain).
    pub fn clear(&mut self) {
        self.len = 0;
        self.stats = FrameStats::default();
    }

    /// Subtract a range bias: every point moves along its direction by `−bias_m` (TI's
    /// `compRangeBiasAndRxChanPhase` range term, the metres the radar's RF delays add to every
    /// measured range; the chains' ranges are range bins times the bin size). A point whose
    /// range would not stay positive is removed and no longer counted in `stats.points`. A
    /// bias of 0, or one that is not finite, changes nothing.
    pub fn subtract_range_bias(&mut self, bias_m: f32) {
        if bias_m == 0.0 || !bias_m.is_finite() {
            return;
        }
        let mut kept = 0;
        for i in 0..self.len {
            let mut p = self.points[i];
            let r = p.position.length();
            if !(r - bias_m > 0.0) {
                continue;
            }
            p.position *= (r - bias_m) / r;
            self.points[kept] = p;
            kept += 1;
        }
        let removed = self.len - kept;
        self.len = kept;
        self.stats.points = self.stats.points.saturating_sub(removed as u32);
    }

    /// Add `p`, or count it in `point_overflow` when the cloud is full.
    pub(crate) fn push(&mut self, p: Point) {
        if self.len < P {
            self.points[self.len] = p;
            self.len += 1;
            self.stats.points += 1;
        } else {
            self.stats.point_overflow += 1;
        }
    }
}

impl<const P: usize> Default for PointCloud<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// `10·log10(a / b)`, the SNR of a point; 0 unless both are positive.
pub(crate) fn ratio_db(a: f32, b: f32) -> f32 {
    if a > 0.0 && b > 0.0 {
        10.0 * libm::log10f(a / b)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_range_bias_moves_points_along_their_direction_and_drops_those_it_passes() {
        let mut cloud = PointCloud::<4>::new();
        let (far, near) = (Point::at(2.0, 0.6, 0.1), Point::at(0.05, 0.0, 0.0));
        for p in [far, near].into_iter().flatten() {
            cloud.push(Point {
                velocity_mps: 0.5,
                ..p
            });
        }
        let before = cloud.points()[0].position;
        cloud.subtract_range_bias(f32::NAN);
        cloud.subtract_range_bias(0.0);
        assert_eq!(
            (cloud.points().len(), cloud.points()[0].position),
            (2, before)
        );
        cloud.subtract_range_bias(0.1);
        assert_eq!((cloud.points().len(), cloud.stats.points), (1, 1));
        let p = cloud.points()[0];
        assert!((p.position.length() - 1.9).abs() < 1e-6, "{p:?}");
        assert!((p.position.normalize() - before.normalize()).length() < 1e-6);
        assert_eq!(p.velocity_mps, 0.5);
    }
}
