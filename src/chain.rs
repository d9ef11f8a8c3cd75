//! The [`Chain`] trait: what the DBE chain ([`crate::Dbe`]) and the FFT baseline
//! ([`crate::FftChain`]) have in common, so that firmware runners, host runners and
//! benchmarks are written once.
//!
//! A chain turns a checked [`Frame`] into points in three stages, each a method a caller can
//! run and time on its own; [`Chain::process`] is their composition:
//!
//! ```text
//! map     : Frame → the map detection runs on      (DBE: range–azimuth Capon; FFT: range–Doppler)
//! detect  : map → detections                       (cfar.rs, one 2-D CFAR for both)
//! points  : Frame + detections → PointCloud        (DBE: TDM, elevation sweep, Doppler; FFT: angles)
//! ```
//!
//! The stages communicate through the chain's workspace only, so running them one by one
//! gives exactly what `process` gives.

use crate::cfar::Detection;
use crate::config::ConfigError;
use crate::cube::Frame;
use crate::frontend::Frontend;
use crate::points::PointCloud;

/// A processing chain over frames of `N` samples, `K` loops, `TX × RX = M` virtual antennas
/// of which `AZ` form the azimuth line (one order of const parameters across the crate).
pub trait Chain<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
>
{
    /// The chain's name in reports (`"dbe"`, `"fft"`).
    const NAME: &'static str;
    /// Names of the three stages, in order, as the firmware budget reports them.
    const STAGES: [&'static str; 3];
    /// Runtime parameters.
    type Params: Copy;
    /// Per-frame state between stages (maps, CFAR scratch, detections).
    type Workspace;

    /// Validate `params` and compute the chain's tables for frames filled by `frontend`, in
    /// place. On error `self` is unchanged.
    fn configure(
        &mut self,
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: Self::Params,
    ) -> Result<(), ConfigError>;

    /// Stage 1: the map detection runs on.
    fn map(&self, frame: &Frame<'_, N, K, M>, work: &mut Self::Workspace);

    /// Stage 2: detections on the map.
    fn detect(&self, work: &mut Self::Workspace);

    /// Stage 3: one or more points per detection, and the frame's statistics.
    fn points<const P: usize>(
        &self,
        frame: &Frame<'_, N, K, M>,
        work: &mut Self::Workspace,
        out: &mut PointCloud<P>,
    );

    /// The detections of the last frame.
    fn detections(work: &Self::Workspace) -> &[Detection];

    /// The whole chain on one frame. Never fails and never panics.
    fn process<const P: usize>(
        &self,
        frame: &Frame<'_, N, K, M>,
        work: &mut Self::Workspace,
        out: &mut PointCloud<P>,
    ) {
        self.map(frame, work);
        self.detect(work);
        self.points(frame, work, out);
    }
}
