//! The two compiled presets: array sizes as types, defaults as values.

use crate::config::{AntennaGeometry, Params, Waveform};

/// TI AWR1843BOOST as recorded in ColoRadar: 128 samples, 128 loops, 3 TX × 4 RX.
pub mod coloradar {
    use super::*;

    /// Samples per chirp = range bins.
    pub const SAMPLES: usize = 128;
    /// Loops (chirps per TX) per frame.
    pub const LOOPS: usize = 128;
    /// TX antennas (TDM slots).
    pub const TX: usize = 3;
    /// RX antennas.
    pub const RX: usize = 4;
    /// Virtual antennas.
    pub const VIRTUAL: usize = TX * RX;
    /// Azimuth-line elements (the other `VIRTUAL − AZIMUTH` = 4 form the elevation row).
    pub const AZIMUTH: usize = 8;
    /// Azimuth grid bins over ±70° (the paper's Table I).
    pub const AZIMUTH_BINS: usize = 188;
    /// Elevation grid bins over ±25° (0.5° steps).
    pub const ELEVATION_BINS: usize = 101;
    /// Detection capacity per frame.
    pub const DETECTIONS: usize = 128;
    /// Point capacity per frame (up to 2 elevation peaks per detection).
    pub const POINTS: usize = 256;

    /// The configured chain.
    pub type Dbe =
        crate::Dbe<SAMPLES, LOOPS, TX, RX, VIRTUAL, AZIMUTH, AZIMUTH_BINS, ELEVATION_BINS>;
    /// Cube storage (caller-owned).
    pub type CubeStorage = crate::cube::CubeStorage<SAMPLES, VIRTUAL, LOOPS>;
    /// A cube over borrowed storage.
    pub type Cube<'a> = crate::cube::Cube<'a, SAMPLES, VIRTUAL, LOOPS>;
    /// Workspace.
    pub type Workspace = crate::Workspace<SAMPLES, VIRTUAL, LOOPS, AZIMUTH_BINS, DETECTIONS>;
    /// Output.
    pub type PointCloud = crate::PointCloud<POINTS>;
    /// One chirp of all RX as the ADC delivers it.
    pub type Chirp = [[[i16; 2]; SAMPLES]; RX];

    /// The chain with ColoRadar's waveform, geometry and the spec's defaults.
    pub fn dbe() -> Result<Dbe, crate::ConfigError> {
        Dbe::new(
            Waveform::COLORADAR,
            AntennaGeometry::COLORADAR,
            Params::defaults(SAMPLES),
        )
    }

    /// The FFT baseline chain (spec §4) with the same sizes and grids.
    pub type FftChain =
        crate::FftChain<SAMPLES, LOOPS, TX, RX, VIRTUAL, AZIMUTH, AZIMUTH_BINS, ELEVATION_BINS>;
    /// The FFT chain's workspace (range–Doppler map `SAMPLES·LOOPS·4` bytes).
    pub type FftWorkspace = crate::FftWorkspace<SAMPLES, VIRTUAL, LOOPS, DETECTIONS>;

    /// The FFT chain with ColoRadar's waveform, geometry and defaults
    /// ([`crate::FftParams::defaults`]).
    pub fn fft_chain() -> Result<FftChain, crate::ConfigError> {
        FftChain::new(
            Waveform::COLORADAR,
            AntennaGeometry::COLORADAR,
            crate::FftParams::defaults(SAMPLES),
        )
    }
}

/// The TI IWR6843 + DCA1000 fixture: 256 samples, 64 loops, 3 TX × 4 RX.
pub mod iwr6843 {
    use super::*;

    /// Samples per chirp = range bins.
    pub const SAMPLES: usize = 256;
    /// Loops per frame.
    pub const LOOPS: usize = 64;
    /// TX antennas.
    pub const TX: usize = 3;
    /// RX antennas.
    pub const RX: usize = 4;
    /// Virtual antennas.
    pub const VIRTUAL: usize = TX * RX;
    /// Azimuth-line elements.
    pub const AZIMUTH: usize = 8;
    /// Azimuth grid bins.
    pub const AZIMUTH_BINS: usize = 188;
    /// Elevation grid bins.
    pub const ELEVATION_BINS: usize = 101;
    /// Detection capacity per frame.
    pub const DETECTIONS: usize = 128;
    /// Point capacity per frame.
    pub const POINTS: usize = 256;

    /// The configured chain.
    pub type Dbe =
        crate::Dbe<SAMPLES, LOOPS, TX, RX, VIRTUAL, AZIMUTH, AZIMUTH_BINS, ELEVATION_BINS>;
    /// Cube storage (caller-owned).
    pub type CubeStorage = crate::cube::CubeStorage<SAMPLES, VIRTUAL, LOOPS>;
    /// A cube over borrowed storage.
    pub type Cube<'a> = crate::cube::Cube<'a, SAMPLES, VIRTUAL, LOOPS>;
    /// Workspace.
    pub type Workspace = crate::Workspace<SAMPLES, VIRTUAL, LOOPS, AZIMUTH_BINS, DETECTIONS>;
    /// Output.
    pub type PointCloud = crate::PointCloud<POINTS>;
    /// One chirp of all RX.
    pub type Chirp = [[[i16; 2]; SAMPLES]; RX];

    /// The chain with the fixture's (partly assumed) waveform, inferred geometry and defaults.
    pub fn dbe() -> Result<Dbe, crate::ConfigError> {
        Dbe::new(
            Waveform::IWR6843_FIXTURE,
            AntennaGeometry::IWR6843_FIXTURE,
            Params::defaults(SAMPLES),
        )
    }

    /// The FFT baseline chain (spec §4) with the same sizes and grids.
    pub type FftChain =
        crate::FftChain<SAMPLES, LOOPS, TX, RX, VIRTUAL, AZIMUTH, AZIMUTH_BINS, ELEVATION_BINS>;
    /// The FFT chain's workspace (range–Doppler map `SAMPLES·LOOPS·4` bytes).
    pub type FftWorkspace = crate::FftWorkspace<SAMPLES, VIRTUAL, LOOPS, DETECTIONS>;

    /// The FFT chain with the fixture's (partly assumed) waveform, inferred geometry and
    /// defaults ([`crate::FftParams::defaults`]).
    pub fn fft_chain() -> Result<FftChain, crate::ConfigError> {
        FftChain::new(
            Waveform::IWR6843_FIXTURE,
            AntennaGeometry::IWR6843_FIXTURE,
            crate::FftParams::defaults(SAMPLES),
        )
    }
}
