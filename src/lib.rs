//! # dbe-radar
//!
//! The Digital Beamforming Enhanced (DBE) processing chain of Jiang et al., "Digital
//! Beamforming Enhanced Radar Odometry" (ICRA 2025), for single-chip 4D FMCW radars with
//! 3 TX × 4 RX (8 azimuth + 4 elevation virtual antennas), as an allocation-free `no_std`
//! library fed chirp by chirp:
//!
//! range FFT ([`range`], in the [`frontend`]) → Capon azimuth beamforming ([`capon`]) →
//! OS-CFAR on the range–azimuth map ([`cfar`]) → TDM-MIMO motion compensation ([`tdm`]) →
//! Capon elevation sweep ([`elevation`]) → Doppler FFT of the Capon-beamformed slow time
//! ([`doppler`]) → points ([`points`]) → the radar's own velocity ([`ego`], the odometry
//! input). [`pipeline`] shows the data flow on one screen;
//! [`fft_pipeline`] is the classic FFT chain it is compared against. Both are a [`Chain`].
//!
//! Shapes are const generics (see [`presets`]); waveform, geometry and thresholds are
//! runtime values validated once by [`Frontend::new`] and the chains' `configure`. A frame is
//! checked once ([`Frontend::frame`]: a [`FrameError`] names the chirp that was missing,
//! repeated or out of order); processing a [`Frame`] never allocates, never fails and never
//! panics.
//!
//! ```
//! use dbe_radar::{presets::coloradar as p, Chain};
//!
//! let frontend = p::frontend().unwrap();
//! let dbe = p::dbe(&frontend).unwrap();
//! let mut storage: Box<p::CubeStorage> =
//!     vec![[[[0; 2]; p::VIRTUAL]; p::LOOPS]; p::SAMPLES].try_into().unwrap();
//! let mut cube = p::Cube::new(&mut storage);
//! let mut work = Box::new(p::Workspace::new());
//! let mut cloud = Box::new(p::PointCloud::new());
//! let silence: p::Chirp = [[[0, 0]; p::SAMPLES]; p::RX];
//! for id in frontend.tdm_order() {
//!     frontend.push_chirp(&mut cube, id, &silence).unwrap();
//! }
//! dbe.process(&frontend.frame(&cube).unwrap(), &mut work, &mut cloud);
//! // An all-zero frame has no positive-definite covariance: every bin is skipped, no points.
//! assert_eq!(cloud.points().len(), 0);
//! assert_eq!(cloud.stats.skipped_range_bins, 114);
//! ```
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod capon;
pub mod cfar;
pub mod chain;
pub mod config;
pub mod covariance;
pub mod cube;
pub mod doppler;
pub mod ego;
pub mod elevation;
pub mod fft;
pub mod fft_pipeline;
pub mod frontend;
pub mod joint;
pub mod pipeline;
pub mod points;
pub mod presets;
pub mod range;
pub mod refine;
pub mod ring;
pub mod split;
pub mod subarray;
pub mod tdm;
pub mod window;

pub use cfar::{CfarKind, CfarParams, Detection};
pub use chain::Chain;
pub use config::{AntennaGeometry, ConfigError, Waveform};
pub use cube::{BlockExponent, ChirpId, Cube, Frame, FrameError};
pub use ego::{EgoEstimator, EgoParams, EgoStatus, EgoVelocity};
pub use elevation::ElevationParams;
pub use fft_pipeline::{FftChain, FftParams, FftWorkspace};
pub use frontend::Frontend;
pub use glam::Vec3;
pub use num_complex::Complex32;
pub use pipeline::{Dbe, Params, Workspace};
pub use points::{FrameStats, Point, PointCloud};
