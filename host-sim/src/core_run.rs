//! Running the core (`dbe_radar`) on host data, as the firmware would: chirp by chirp.
//!
//! The core's array sizes are compile-time constants, so a sensor must match one of the
//! compiled [`Preset`]s. A [`CoreRunner`] holds the configured frontend and chain (any
//! [`dbe_radar::Chain`]) and their heap-allocated cube, workspace and point cloud (megabyte-sized values never touch a thread's stack), and
//! turns one [`AdcFrame`] into a [`CoreOutput`].

use std::fmt;
use std::time::{Duration, Instant};

use dbe_radar::cube::CubeStorage;
use dbe_radar::Chain as DbeChain;
use dbe_radar::{Complex32, ConfigError, Cube, Dbe, Detection, FrameError, FrameStats};
use dbe_radar::{FftChain, FftParams, FftWorkspace, Frontend, Params, PointCloud, Workspace};

use crate::cloud::PointRecord;
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;

/// A compiled array size of the core: `(samples, loops, TX, RX)` with the chains' common
/// grids (188 azimuth, 101 elevation bins), 128 detections and 256 points per frame, and an
/// 8-element azimuth line. Every size of [`dbe_radar::ti_frame_sizes!`] is compiled: 64–512
/// samples × 16–256 loops (powers of two) × 3 TX (AWR1843 / IWR6843 class: line + elevation
/// row) or 2 TX (AWR1642 / IWR1443 class: a line, azimuth-only points), all with 4 RX. Two of
/// them carry the names of their firmware images: [`Preset::COLORADAR`] and [`Preset::IWR6843`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Preset {
    samples: u16,
    loops: u16,
    tx: u8,
    rx: u8,
}

/// Sizes of a preset: `(samples, loops, tx, rx)`.
type Sizes = (usize, usize, usize, usize);

/// The chains' grids and capacities, the same for every host preset (those of
/// `dbe_radar::presets::coloradar`).
mod grid {
    pub use dbe_radar::presets::coloradar::{
        AZIMUTH as LINE, AZIMUTH_BINS, DETECTIONS, ELEVATION_BINS, POINTS, RX,
    };
}

macro_rules! preset_list {
    ($(($n:literal, $k:literal, $tx:literal))*) => {
        [$(Preset::of($n, $k, $tx)),*]
    };
}

impl Preset {
    /// `dbe_radar::presets::coloradar`: 128 samples, 128 loops, 3 TX × 4 RX.
    pub const COLORADAR: Preset = Preset::of(128, 128, 3);
    /// `dbe_radar::presets::iwr6843`: 256 samples, 64 loops, 3 TX × 4 RX.
    pub const IWR6843: Preset = Preset::of(256, 64, 3);
    /// The presets that have firmware images (`firmware/`, the budget).
    pub const FIRMWARE: [Preset; 2] = [Preset::COLORADAR, Preset::IWR6843];
    /// Every compiled preset.
    pub const ALL: [Preset; 40] = dbe_radar::ti_frame_sizes!(preset_list);

    /// The preset of `samples × loops`, `tx` TX × 4 RX (sizes up to 65,535 and 255: the
    /// compiled ones are far smaller).
    const fn of(samples: usize, loops: usize, tx: usize) -> Self {
        Preset {
            samples: samples as u16,
            loops: loops as u16,
            tx: tx as u8,
            rx: grid::RX as u8,
        }
    }

    /// The preset's name: `coloradar`, `iwr6843`, else `ti-<samples>x<loops>-<tx>tx`.
    pub fn name(self) -> String {
        match self {
            Preset::COLORADAR => "coloradar".into(),
            Preset::IWR6843 => "iwr6843".into(),
            p => format!("ti-{}x{}-{}tx", p.samples, p.loops, p.tx),
        }
    }

    /// `(samples, loops, tx, rx)` of the preset.
    pub const fn sizes(self) -> Sizes {
        (
            self.samples as usize,
            self.loops as usize,
            self.tx as usize,
            self.rx as usize,
        )
    }

    /// Whether the preset's array has an elevation row (3 TX); 2-TX arrays are a line and
    /// their points have elevation 0 (`dbe_radar::Frontend::MEASURES_ELEVATION`).
    pub const fn measures_elevation(self) -> bool {
        self.tx as usize * self.rx as usize > grid::LINE
    }

    /// Azimuth grid bins of the preset.
    pub const fn azimuth_bins(self) -> usize {
        grid::AZIMUTH_BINS
    }

    /// Elevation grid bins of the preset.
    pub const fn elevation_bins(self) -> usize {
        grid::ELEVATION_BINS
    }

    /// Detection capacity per frame of the preset.
    pub const fn detection_capacity(self) -> usize {
        grid::DETECTIONS
    }

    /// The preset whose sizes (samples, loops, TX, RX) match `sensor`; else an error naming
    /// the nearest ones.
    pub fn for_sensor(sensor: &SensorConfig) -> Result<Preset, CoreRunError> {
        let found = (sensor.samples, sensor.loops, sensor.num_tx, sensor.num_rx);
        Self::ALL
            .into_iter()
            .find(|p| p.sizes() == found)
            .ok_or_else(|| CoreRunError::NoPreset {
                found,
                nearest: Self::nearest(found),
            })
    }

    /// The presets closest to `sizes`: fewest octaves apart in samples plus loops, with TX
    /// and RX mismatches counted as an octave each; every preset at that distance.
    pub fn nearest(sizes: Sizes) -> Vec<Preset> {
        let octaves = |a: usize, b: usize| {
            let (a, b) = (a.max(1) as f64, b.max(1) as f64);
            (a.log2() - b.log2()).abs()
        };
        let distance = |p: &Preset| {
            let (n, k, tx, rx) = p.sizes();
            octaves(n, sizes.0)
                + octaves(k, sizes.1)
                + f64::from(u8::from(tx != sizes.2))
                + f64::from(u8::from(rx != sizes.3))
        };
        let best = Self::ALL.iter().map(distance).fold(f64::INFINITY, f64::min);
        Self::ALL
            .into_iter()
            .filter(|p| distance(p) <= best + 1e-9)
            .collect()
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (n, k, tx, rx) = self.sizes();
        write!(
            f,
            "{} ({n} samples, {k} loops, {tx} TX × {rx} RX)",
            self.name()
        )
    }
}

fn list(presets: &[Preset]) -> String {
    presets
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Why the core could not be set up or run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CoreRunError {
    /// No compiled preset has the sensor's sizes.
    #[error(
        "no compiled preset for {} samples, {} loops, {} TX × {} RX; nearest: {}. Presets \
         cover 64–512 samples × 16–256 loops (powers of two), 2 or 3 TX × 4 RX: configure the \
         radar to one of them (TI: profileCfg numAdcSamples, frameCfg numLoops)",
        found.0, found.1, found.2, found.3, list(nearest)
    )]
    NoPreset {
        /// The sensor's `(samples, loops, tx, rx)`.
        found: Sizes,
        /// The nearest compiled presets ([`Preset::nearest`]).
        nearest: Vec<Preset>,
    },
    /// The sensor's antenna lists do not fit the preset's TX × RX.
    #[error("sensor has {tx} TX and {rx} RX positions, the {preset} preset needs {} and {}", preset.sizes().2, preset.sizes().3)]
    Geometry {
        /// The preset.
        preset: Preset,
        /// TX positions given.
        tx: usize,
        /// RX positions given.
        rx: usize,
    },
    /// The channel gain table does not hold `tx · rx` values.
    #[error("channel gain calibration holds {found} values, {expected} expected ([tx][rx])")]
    ChannelGainsSize {
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// The coupling table does not hold `tx · rx · range_bins` values.
    #[error(
        "coupling calibration holds {found} values, {expected} expected ([tx][rx][range bin])"
    )]
    CouplingSize {
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// The core rejected the configuration.
    #[error("invalid configuration for the {preset} preset: {reason}")]
    Config {
        /// The preset.
        preset: Preset,
        /// The core's reason (in the message, not a `source`: printed once).
        reason: ConfigError,
    },
    /// The frame's sizes are not the runner's.
    #[error("frame is {} samples × {} loops × {} TX × {} RX with {} values, the runner expects {} × {} × {} × {} ({})",
        found.0, found.1, found.2, found.3, len, expected.0, expected.1, expected.2, expected.3, preset)]
    FrameShape {
        /// The runner's preset.
        preset: Preset,
        /// The preset's `(samples, loops, tx, rx)`.
        expected: Sizes,
        /// The frame's `(samples, loops, tx, rx)`.
        found: Sizes,
        /// `data.len()` of the frame.
        len: usize,
    },
    /// The core refused a chirp or the frame (cannot happen for a well-formed frame).
    #[error("core rejected the frame: {0}")]
    Frame(FrameError),
}

/// Which of the core's chains turns frames into points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Chain {
    /// The DBE chain (Capon azimuth, OS-CFAR on the range–azimuth map, Capon elevation).
    #[default]
    Dbe,
    /// The FFT baseline chain (spec §4), with `FftParams::from_dbe` of the parameters.
    Fft,
}

/// The points of one frame, without the maps: [`CoreRunner::process_points`].
#[derive(Clone, Debug, PartialEq)]
pub struct FramePoints {
    /// The points.
    pub points: Vec<PointRecord>,
    /// The frame statistics.
    pub stats: FrameStats,
}

/// What the core produced for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct CoreOutput {
    /// The points.
    pub points: Vec<PointRecord>,
    /// The frame statistics.
    pub stats: FrameStats,
    /// Range–azimuth map, `ra_map[range bin][azimuth bin]`, linear (empty for the FFT chain).
    pub ra_map: Vec<Vec<f32>>,
    /// CFAR detections on the range–azimuth map (empty for the FFT chain, whose detections
    /// live on the range–Doppler map).
    pub detections: Vec<Detection>,
    /// Range–Doppler map of the FFT chain, `rd_map[range bin][d]`, linear `Σ_m |X_m[d]|²`, `d`
    /// the natural FFT index (bin 0 = 0 m/s, `d ≥ K/2` negative); rows outside the processed
    /// range window are zero (empty for the DBE chain, which has no such map).
    pub rd_map: Vec<Vec<f32>>,
}

/// The maps and detections of one frame, as [`CoreOutput`] reports them.
struct Inspected {
    ra_map: Vec<Vec<f32>>,
    detections: Vec<Detection>,
    rd_map: Vec<Vec<f32>>,
}

/// What the host runner needs of a chain beyond [`dbe_radar::Chain`]: building it from the
/// DBE parameters, a heap workspace, and the maps and detections a [`CoreOutput`] reports.
trait HostChain<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
>: DbeChain<N, K, TX, RX, M, AZ> + Sized
{
    /// The chain for frames of `frontend`, configured from the DBE parameters.
    fn build(
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: &Params,
    ) -> Result<Box<Self>, ConfigError>;
    /// A zeroed workspace on the heap.
    fn workspace() -> Box<Self::Workspace>;
    /// The range–azimuth map, detections and range–Doppler map a [`CoreOutput`] reports.
    fn inspect(work: &Self::Workspace) -> Inspected;
}

impl<
        const N: usize,
        const K: usize,
        const TX: usize,
        const RX: usize,
        const M: usize,
        const AZ: usize,
        const NAZ: usize,
        const NEL: usize,
        const DET: usize,
    > HostChain<N, K, TX, RX, M, AZ> for Dbe<N, K, TX, RX, M, AZ, NAZ, NEL, DET>
{
    fn build(
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: &Params,
    ) -> Result<Box<Self>, ConfigError> {
        let mut chain = Box::new(Self::unconfigured());
        chain.configure(frontend, *params)?;
        Ok(chain)
    }

    fn workspace() -> Box<Self::Workspace> {
        Box::new(Workspace::new())
    }

    fn inspect(work: &Self::Workspace) -> Inspected {
        Inspected {
            ra_map: work.range_azimuth().iter().map(|r| r.to_vec()).collect(),
            detections: work.detections().to_vec(),
            rd_map: Vec::new(),
        }
    }
}

impl<
        const N: usize,
        const K: usize,
        const TX: usize,
        const RX: usize,
        const M: usize,
        const AZ: usize,
        const NAZ: usize,
        const NEL: usize,
        const DET: usize,
    > HostChain<N, K, TX, RX, M, AZ> for FftChain<N, K, TX, RX, M, AZ, NAZ, NEL, DET>
{
    fn build(
        frontend: &Frontend<N, K, TX, RX, M, AZ>,
        params: &Params,
    ) -> Result<Box<Self>, ConfigError> {
        let mut chain = Box::new(Self::unconfigured());
        chain.configure(frontend, FftParams::from_dbe(params))?;
        Ok(chain)
    }

    fn workspace() -> Box<Self::Workspace> {
        Box::new(FftWorkspace::new())
    }

    fn inspect(work: &Self::Workspace) -> Inspected {
        Inspected {
            ra_map: Vec::new(),
            detections: Vec::new(),
            rd_map: work.range_doppler().iter().map(|r| r.to_vec()).collect(),
        }
    }
}

/// Wall time of one frame's stages ([`CoreRunner::process_timed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StageTimes {
    /// The chain's stage names (`dbe_radar::Chain::STAGES`).
    pub names: [&'static str; 3],
    /// Feeding the frame chirp by chirp through `Frontend::push_chirp`, and the frame check.
    pub ingest: Duration,
    /// The chain's three stages, in order.
    pub stages: [Duration; 3],
}

impl StageTimes {
    /// Ingest plus the three stages.
    pub fn total(&self) -> Duration {
        self.ingest + self.stages.iter().sum::<Duration>()
    }
}

/// The frontend, one chain and their buffers for one preset's sizes.
struct Engine<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const P: usize,
    C: HostChain<N, K, TX, RX, M, AZ>,
> {
    frontend: Box<Frontend<N, K, TX, RX, M, AZ>>,
    chain: Box<C>,
    params: Params,
    storage: Box<CubeStorage<N, K, M>>,
    work: Box<C::Workspace>,
    cloud: Box<PointCloud<P>>,
    /// The preset these sizes belong to (for the error of a frame of other sizes).
    preset: Preset,
    /// `SensorConfig::range_bias_m`, subtracted from every point's range.
    range_bias_m: f32,
}

impl<
        const N: usize,
        const K: usize,
        const TX: usize,
        const RX: usize,
        const M: usize,
        const AZ: usize,
        const P: usize,
        C: HostChain<N, K, TX, RX, M, AZ>,
    > Engine<N, K, TX, RX, M, AZ, P, C>
{
    fn new(
        preset: Preset,
        sensor: &SensorConfig,
        params: Params,
    ) -> Result<Box<Self>, CoreRunError> {
        let geometry_error = CoreRunError::Geometry {
            preset,
            tx: sensor.tx.len(),
            rx: sensor.rx.len(),
        };
        let geometry = dbe_radar::AntennaGeometry::<TX, RX> {
            tx: sensor
                .tx
                .clone()
                .try_into()
                .map_err(|_| geometry_error.clone())?,
            rx: sensor.rx.clone().try_into().map_err(|_| geometry_error)?,
            f_design_hz: sensor.f_design_hz,
        };
        let config = |reason| CoreRunError::Config { preset, reason };
        let mut frontend = Box::new(Frontend::unconfigured());
        frontend
            .configure(sensor.waveform, geometry, params.range_window)
            .map_err(config)?;
        if let Some(c) = &sensor.coupling {
            // The coupling table in the core's data order `[tx][rx]`, one slice per channel.
            let expected = TX * RX * c.range_bins;
            if c.data.len() != expected {
                return Err(CoreRunError::CouplingSize {
                    expected,
                    found: c.data.len(),
                });
            }
            let table: Vec<&[Complex32]> = c.data.chunks(c.range_bins.max(1)).collect();
            let per_tx: [[&[Complex32]; RX]; TX] = core::array::from_fn(|t| {
                core::array::from_fn(|r| table.get(t * RX + r).copied().unwrap_or(&[]))
            });
            frontend.set_coupling(&per_tx).map_err(config)?;
        }
        if let Some(g) = &sensor.channel_gains {
            if g.len() != TX * RX {
                return Err(CoreRunError::ChannelGainsSize {
                    expected: TX * RX,
                    found: g.len(),
                });
            }
            let per_tx: [[Complex32; RX]; TX] =
                core::array::from_fn(|t| core::array::from_fn(|r| g[t * RX + r]));
            frontend.set_channel_gains(&per_tx).map_err(config)?;
        }
        let chain = C::build(&frontend, &params).map_err(config)?;
        let storage: Box<CubeStorage<N, K, M>> =
            match vec![[[[0; 2]; M]; K]; N].into_boxed_slice().try_into() {
                Ok(storage) => storage,
                Err(_) => unreachable!("vec![_; N] holds exactly N range bins"),
            };
        Ok(Box::new(Self {
            frontend,
            chain,
            params,
            storage,
            work: C::workspace(),
            cloud: Box::new(PointCloud::new()),
            preset,
            range_bias_m: sensor.range_bias_m as f32,
        }))
    }

    /// Process `frame`, timing each stage on the wall clock: the points are left in the
    /// cloud, the maps in the workspace.
    fn run_timed(&mut self, frame: &AdcFrame) -> Result<StageTimes, CoreRunError> {
        let preset = self.preset;
        let start = Instant::now();
        let mut cube = Cube::new(&mut self.storage);
        for id in self.frontend.tdm_order() {
            let (k, t) = (usize::from(id.loop_index), usize::from(id.tx_slot));
            // The recording's chirp in place, as firmware passes its DMA buffer: a copy cost
            // 10–15 % of the ingest (issue 13).
            let rows: &[[[i16; 2]; N]] = bytemuck::try_cast_slice(frame.chirp(k, t))
                .map_err(|_| shape_error(preset, frame))?;
            let chirp: &[[[i16; 2]; N]; RX] =
                rows.try_into().map_err(|_| shape_error(preset, frame))?;
            self.frontend
                .push_chirp(&mut cube, id, chirp)
                .map_err(CoreRunError::Frame)?;
        }
        let checked = self.frontend.frame(&cube).map_err(CoreRunError::Frame)?;
        let t_ingest = start.elapsed();
        let t = Instant::now();
        self.chain.map(&checked, &mut self.work);
        let t_map = t.elapsed();
        let t = Instant::now();
        self.chain.detect(&mut self.work);
        let t_detect = t.elapsed();
        let t = Instant::now();
        self.chain.points(&checked, &mut self.work, &mut self.cloud);
        self.cloud.subtract_range_bias(self.range_bias_m);
        let t_points = t.elapsed();
        Ok(StageTimes {
            names: C::STAGES,
            ingest: t_ingest,
            stages: [t_map, t_detect, t_points],
        })
    }

    /// The points of the last frame.
    fn points(&self) -> FramePoints {
        FramePoints {
            points: self.cloud.points().iter().map(PointRecord::from).collect(),
            stats: self.cloud.stats,
        }
    }
}

/// The error of a frame whose sizes are not `preset`'s.
fn shape_error(preset: Preset, frame: &AdcFrame) -> CoreRunError {
    CoreRunError::FrameShape {
        preset,
        expected: preset.sizes(),
        found: (frame.samples, frame.loops, frame.tx, frame.rx),
        len: frame.data.len(),
    }
}

/// One preset's engine behind a pointer: what [`CoreRunner`] needs of it.
trait Run: Send {
    fn params(&self) -> &Params;
    /// Process `frame` (of the engine's sizes), timing each stage.
    fn run_timed(&mut self, frame: &AdcFrame) -> Result<StageTimes, CoreRunError>;
    /// The points of the last frame.
    fn points(&self) -> FramePoints;
    /// The maps and detections of the last frame.
    fn inspect(&self) -> Inspected;
}

impl<
        const N: usize,
        const K: usize,
        const TX: usize,
        const RX: usize,
        const M: usize,
        const AZ: usize,
        const P: usize,
        C: HostChain<N, K, TX, RX, M, AZ> + Send,
    > Run for Engine<N, K, TX, RX, M, AZ, P, C>
where
    C::Workspace: Send,
{
    fn params(&self) -> &Params {
        &self.params
    }

    fn run_timed(&mut self, frame: &AdcFrame) -> Result<StageTimes, CoreRunError> {
        Engine::run_timed(self, frame)
    }

    fn points(&self) -> FramePoints {
        Engine::points(self)
    }

    fn inspect(&self) -> Inspected {
        C::inspect(&self.work)
    }
}

/// `build(preset, chain, sensor, params)`: the engine of every size of
/// [`dbe_radar::ti_frame_sizes!`], for either chain.
macro_rules! engine_builder {
    ($(($n:literal, $k:literal, $tx:literal))*) => {
        fn build(
            preset: Preset,
            chain: Chain,
            sensor: &SensorConfig,
            params: Params,
        ) -> Result<Box<dyn Run>, CoreRunError> {
            use grid::{AZIMUTH_BINS as NAZ, DETECTIONS as DET, ELEVATION_BINS as NEL};
            use grid::{LINE as AZ, POINTS as P, RX};
            match (preset.sizes(), chain) {
                $(
                    (($n, $k, $tx, RX), Chain::Dbe) => {
                        type C = Dbe<$n, $k, $tx, RX, { $tx * RX }, AZ, NAZ, NEL, DET>;
                        let e = Engine::<$n, $k, $tx, RX, { $tx * RX }, AZ, P, C>::new(
                            preset, sensor, params,
                        )?;
                        Ok(e)
                    }
                    (($n, $k, $tx, RX), Chain::Fft) => {
                        type C = FftChain<$n, $k, $tx, RX, { $tx * RX }, AZ, NAZ, NEL, DET>;
                        let e = Engine::<$n, $k, $tx, RX, { $tx * RX }, AZ, P, C>::new(
                            preset, sensor, params,
                        )?;
                        Ok(e)
                    }
                )*
                (found, _) => Err(CoreRunError::NoPreset {
                    found,
                    nearest: Preset::nearest(found),
                }),
            }
        }
    };
}

dbe_radar::ti_frame_sizes!(engine_builder);

/// The core configured for one sensor, with its buffers on the heap.
pub struct CoreRunner {
    preset: Preset,
    engine: Box<dyn Run>,
}

impl fmt::Debug for CoreRunner {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CoreRunner")
            .field("preset", &self.preset)
            .finish_non_exhaustive()
    }
}

impl CoreRunner {
    /// Configure the core for `sensor` (its preset, waveform, geometry and coupling, when
    /// present) with `params`.
    pub fn new(sensor: &SensorConfig, params: Params) -> Result<Self, CoreRunError> {
        Self::with_chain(sensor, params, Chain::Dbe)
    }

    /// [`Self::new`] for either chain; the FFT chain uses `FftParams::from_dbe(&params)`.
    pub fn with_chain(
        sensor: &SensorConfig,
        params: Params,
        chain: Chain,
    ) -> Result<Self, CoreRunError> {
        let preset = Preset::for_sensor(sensor)?;
        let engine = build(preset, chain, sensor, params)?;
        Ok(Self { preset, engine })
    }

    /// The preset in use.
    pub fn preset(&self) -> Preset {
        self.preset
    }

    /// The processing parameters.
    pub fn params(&self) -> &Params {
        self.engine.params()
    }

    /// Feed `frame` chirp by chirp in TDM order (loop 0 slot 0, loop 0 slot 1, …) through
    /// `push_chirp`, then process it. A frame of other sizes is an error.
    pub fn process(&mut self, frame: &AdcFrame) -> Result<CoreOutput, CoreRunError> {
        self.process_timed(frame).map(|(out, _)| out)
    }

    /// [`Self::process`], with the wall time of every stage.
    pub fn process_timed(
        &mut self,
        frame: &AdcFrame,
    ) -> Result<(CoreOutput, StageTimes), CoreRunError> {
        self.check_shape(frame)?;
        let times = self.engine.run_timed(frame)?;
        let FramePoints { points, stats } = self.engine.points();
        let Inspected {
            ra_map,
            detections,
            rd_map,
        } = self.engine.inspect();
        let out = CoreOutput {
            points,
            stats,
            ra_map,
            detections,
            rd_map,
        };
        Ok((out, times))
    }

    /// [`Self::process`] without copying out the maps and detections: what a run that keeps
    /// only the points needs (`dbe process`, the odometry; about 100 kB less to allocate and
    /// copy per ColoRadar frame).
    pub fn process_points(&mut self, frame: &AdcFrame) -> Result<FramePoints, CoreRunError> {
        self.check_shape(frame)?;
        self.engine.run_timed(frame)?;
        Ok(self.engine.points())
    }

    /// A frame of other sizes than the preset's is an error.
    fn check_shape(&self, frame: &AdcFrame) -> Result<(), CoreRunError> {
        let expected = self.preset.sizes();
        let found = (frame.samples, frame.loops, frame.tx, frame.rx);
        let (n, k, tx, rx) = expected;
        if found != expected || frame.data.len() != n * k * tx * rx {
            return Err(shape_error(self.preset, frame));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_sizes_name_the_nearest_presets() {
        let mut sensor = SensorConfig::coloradar();
        sensor.loops = 48;
        let err = Preset::for_sensor(&sensor).err().map(|e| e.to_string());
        let text = err.unwrap_or_default();
        // 48 loops lie 0.58 octave above 32 and 0.42 below 64: 64 is nearer.
        assert!(text.contains("48 loops"), "{text}");
        assert!(
            text.contains("nearest: ti-128x64-3tx (128 samples, 64 loops, 3 TX × 4 RX)."),
            "{text}"
        );
        assert!(text.contains("64–512 samples × 16–256 loops"), "{text}");
        // Presets at the same distance are all named.
        let tie = Preset::nearest((128, 128, 4, 4));
        assert_eq!(tie, vec![Preset::of(128, 128, 3), Preset::of(128, 128, 2)]);
        // Every listed preset is found by its sizes and has a distinct name.
        let mut names: Vec<String> = Preset::ALL.iter().map(|p| p.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), Preset::ALL.len());
        assert_eq!(Preset::COLORADAR.name(), "coloradar");
        assert!(
            !Preset::of(128, 128, 2).measures_elevation() && Preset::IWR6843.measures_elevation()
        );
    }

    #[test]
    fn every_preset_runs_a_zero_frame_with_both_chains() -> Result<(), CoreRunError> {
        for p in Preset::ALL {
            let (n, k, tx, rx) = p.sizes();
            let base = if tx == 2 {
                SensorConfig::awr1642()
            } else {
                SensorConfig::coloradar()
            };
            let sensor = SensorConfig {
                samples: n,
                loops: k,
                ..base
            };
            for chain in [Chain::Dbe, Chain::Fft] {
                let mut runner = CoreRunner::with_chain(&sensor, Params::defaults(n), chain)?;
                assert_eq!(runner.preset(), p);
                let out = runner.process(&AdcFrame::zeros(n, k, tx, rx))?;
                assert!(out.points.is_empty(), "{p} {chain:?}");
            }
        }
        Ok(())
    }

    #[test]
    fn a_frame_of_the_wrong_size_is_an_error() -> Result<(), CoreRunError> {
        let sensor = SensorConfig::coloradar();
        let mut runner = CoreRunner::new(&sensor, Params::defaults(128))?;
        assert_eq!(runner.preset(), Preset::COLORADAR);
        let frame = AdcFrame::zeros(256, 64, 3, 4);
        assert!(matches!(
            runner.process(&frame),
            Err(CoreRunError::FrameShape { .. })
        ));
        let mut short = AdcFrame::zeros(128, 128, 3, 4);
        short.data.pop();
        assert!(matches!(
            runner.process(&short),
            Err(CoreRunError::FrameShape { .. })
        ));
        // A zero frame runs (no positive-definite covariance: every processed bin skipped).
        let out = runner.process(&AdcFrame::zeros(128, 128, 3, 4))?;
        let p = runner.params();
        let processed = u32::from(p.range_last - p.range_first) + 1;
        assert_eq!(out.stats.skipped_range_bins, processed);
        assert!(out.points.is_empty());
        Ok(())
    }

    #[test]
    fn both_chains_find_the_same_target() -> Result<(), CoreRunError> {
        // One static scatterer at range bin 40 on boresight, rendered by hand (spec §2).
        let sensor = SensorConfig::coloradar();
        let mut frame = AdcFrame::zeros(128, 128, 3, 4);
        for k in 0..128 {
            for t in 0..3 {
                for r in 0..4 {
                    for n in 0..128 {
                        let ph = 2.0 * std::f64::consts::PI * 40.0 * n as f64 / 128.0;
                        let i = frame.index(k, t, r, n);
                        frame.data[i] = [
                            (300.0 * ph.cos()) as i16 + (n % 3) as i16,
                            (300.0 * ph.sin()) as i16,
                        ];
                    }
                }
            }
        }
        let params = Params::defaults(128);
        for chain in [Chain::Dbe, Chain::Fft] {
            let mut runner = CoreRunner::with_chain(&sensor, params, chain)?;
            let out = runner.process(&frame)?;
            // Without the maps, the same points and statistics.
            let lean = runner.process_points(&frame)?;
            assert_eq!((&lean.points, lean.stats), (&out.points, out.stats));
            assert!(matches!(
                runner.process_points(&AdcFrame::zeros(256, 64, 3, 4)),
                Err(CoreRunError::FrameShape { .. })
            ));
            let hit = out.points.iter().find(|p| p.range_bin == 40);
            assert!(
                hit.is_some_and(|p| p.y.abs() < 0.2 && p.doppler_bin == 0),
                "{chain:?}: {:?}",
                out.points
            );
            assert_eq!(out.ra_map.is_empty(), chain == Chain::Fft);
            assert_eq!(out.rd_map.is_empty(), chain == Chain::Dbe);
            if chain == Chain::Fft {
                // The static target's energy is in Doppler bin 0 of its range bin.
                let row = &out.rd_map[40];
                let peak = (0..row.len()).max_by(|&a, &b| row[a].total_cmp(&row[b]));
                assert_eq!((out.rd_map.len(), row.len(), peak), (128, 128, Some(0)));
            }
        }
        Ok(())
    }

    #[test]
    fn bad_parameters_are_a_readable_error() {
        let mut params = Params::defaults(128);
        params.loading = -1.0;
        let err = CoreRunner::new(&SensorConfig::coloradar(), params).map(|_| ());
        let text = err.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            text.contains("coloradar") && text.contains("loading"),
            "{text}"
        );
    }
}
