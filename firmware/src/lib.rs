//! dbe-radar on a Cortex-M4F: one chain on one embedded frame, with its resource budget
//! measured on the running image.
//!
//! Every image (`coloradar`, `iwr6843`, `coloradar-fft`, `iwr6843-fft`) is one line,
//! [`image!`]`(preset, chain, frame file)`, which declares the buffers as `static`s of the
//! `#[entry]` function (cortex-m-rt turns them into `&'static mut`, zero at reset, so in
//! `.bss`: no heap, no global allocator, no megabyte on the stack, nothing copied from flash)
//! and calls [`run`], generic over [`dbe_radar::Chain`]. One image per chain, not both chains
//! in one image: each image is what a product running that chain would flash, and its budget
//! is that chain's alone (a second chain sharing the core's code would change the inliner's
//! choices, and with them the first chain's instructions and flash). [`run`]
//!
//! 1. calibrates the instruction clock ([`clock`]),
//! 2. configures the frontend and the chain in place (setup),
//! 3. repaints the stack ([`stack`]), feeds the frame chirp by chirp in TDM order through a
//!    one-chirp "DMA" buffer, checks it into a [`dbe_radar::Frame`] and runs the chain's three
//!    stages one by one, timing each,
//! 4. prints everything as lines ([`console`]) and returns; the binary exits through
//!    semihosting with code 0 (any error: a message and a failure code).
//!
//! # Output lines (space separated; the host tool parses them)
//!
//! ```text
//! H preset <name> chain <dbe|fft> samples <N> loops <K> tx <TX> rx <RX> azimuth_bins <NAZ> elevation_bins <NEL>
//! C <instructions> <ticks> <per_tick>            instruction-clock calibration
//! D <range_bin> <column> <power> <level>         one CFAR detection (linear; column: azimuth
//!                                                bin for dbe, natural Doppler bin for fft)
//! P <range_bin> <az_bin> <el_bin> <doppler_bin> <x> <y> <z> <v> <power_db> <snr_db>
//! V <vx> <vy> <vz> <inliers> <points> <status>   the radar's velocity from the points (ego.rs)
//! F <detections> <detection_overflow> <points> <point_overflow> <skipped_range_bins> <detections_without_point> <doppler_rejected>
//! S <stage> <instructions> <ticks>               one stage's cost
//! M <what> <bytes>                               stack_setup, stack_frame
//! E ok                                           end of a complete run
//! X <message>                                    the run failed (then exit code 1)
//! ```
//!
//! Floats are printed with `Display`, the shortest text that parses back to the same `f32`.
//!
//! # Stages
//!
//! Each interval is quantised to one tick (40 instructions); `range_fft_per_chirp` is the
//! sum over the frame's chirps divided by their number.
//!
//! | stage | measured as |
//! |---|---|
//! | `range_fft_per_chirp`, `…_min`, `…_max` | `Frontend::push_chirp`, per chirp |
//! | `ingest` | Σ `push_chirp` over the frame, and `Frontend::frame` |
//! | `Chain::STAGES[0]` (`azimuth_capon` / `doppler_fft`) | `Chain::map` |
//! | `Chain::STAGES[1]` (`cfar` / `rd_cfar`) | `Chain::detect` |
//! | `Chain::STAGES[2]` (`elevation_doppler` / `angles`) | `Chain::points` |
//! | `process` | the sum of the three stages |
//! | `ego_velocity` | `EgoEstimator::estimate` on the frame's points (after `process`, not in `total`) |
//! | `total` | `ingest` + `process`: one frame |
//! | `ingest_from_spectra` | Σ `Frontend::push_range_spectra` over the frame: the ingest of a radar whose FFT accelerator computes the range spectra (each chirp's spectra computed untimed by `RangeFft` first; after the frame, not in `total`) |
//! | `total_from_spectra` | `ingest_from_spectra` + `process`: one frame with the range FFT off the core |
//! | `ingest_from_blocks` | Σ `Frontend::push_range_blocks` over the frame: the ingest of 16-bit spectra with an exponent, an FFT accelerator's fixed-point output (each chirp's mantissas and exponents copied untimed out of the cube first and fed back; after the frame, not in `total`) |
//! | `total_from_blocks` | `ingest_from_blocks` + `process`: one frame with a 16-bit range FFT off the core |
//! | `setup` | `Frontend::configure` + `Chain::configure` + `EgoEstimator::configure` (once, not per frame) |
#![no_std]
#![deny(unsafe_code)]

pub mod clock;
pub mod console;
pub mod stack;

use core::fmt;

use dbe_radar::cube::CubeStorage;
use dbe_radar::{
    AntennaGeometry, BlockExponent, Chain, ChirpId, ConfigError, Cube, EgoEstimator, EgoParams,
    FrameError, Frontend, PointCloud, Waveform,
};

use console::Console;

/// Declare one firmware image: `image!(preset, Chain, "frame file")` runs chain `Chain` of
/// `dbe_radar::presets::preset` (`Dbe` or `FftChain`, with the preset's default parameters) on
/// the frame `build.rs` wrote to `OUT_DIR` under that name.
#[macro_export]
macro_rules! image {
    ($preset:ident, $chain:ident, $params:ident, $frame:literal) => {
        use cortex_m_semihosting::debug;
        use dbe_radar::presets::$preset as p;
        use panic_semihosting as _;

        /// Bytes of one frame: the array type makes a wrong-sized file a compile error.
        const FRAME_BYTES: usize = p::LOOPS * p::TX * p::RX * p::SAMPLES * 4;

        /// The embedded frame, written to `OUT_DIR` by `build.rs`.
        static FRAME: [u8; FRAME_BYTES] = *include_bytes!(concat!(env!("OUT_DIR"), "/", $frame));

        #[cortex_m_rt::entry]
        fn main() -> ! {
            // cortex-m-rt hands each of these out once as `&'static mut`; all are zero at
            // reset, so they live in `.bss`: nothing is copied from flash and nothing big
            // touches the stack.
            static mut FRONTEND: p::Frontend = p::Frontend::unconfigured();
            static mut CHAIN: p::$chain = p::$chain::unconfigured();
            static mut CUBE: p::CubeStorage = dbe_radar::cube::zero_storage();
            static mut DMA_CHIRP: p::Chirp = [[[0; 2]; p::SAMPLES]; p::RX];
            static mut WORKSPACE: <p::$chain as dbe_radar::Chain<
                { p::SAMPLES },
                { p::LOOPS },
                { p::TX },
                { p::RX },
                { p::VIRTUAL },
                { p::AZIMUTH },
            >>::Workspace = <<p::$chain as dbe_radar::Chain<
                { p::SAMPLES },
                { p::LOOPS },
                { p::TX },
                { p::RX },
                { p::VIRTUAL },
                { p::AZIMUTH },
            >>::Workspace>::new();
            static mut CLOUD: p::PointCloud = p::PointCloud::new();
            static mut EGO: p::EgoEstimator = p::EgoEstimator::unconfigured();

            let mut con = $crate::console::Console::open();
            let preset = $crate::Preset {
                name: stringify!($preset),
                waveform: p::WAVEFORM,
                geometry: p::GEOMETRY,
                frame: &FRAME,
                azimuth_bins: p::AZIMUTH_BINS,
                elevation_bins: p::ELEVATION_BINS,
            };
            let buffers = $crate::Buffers {
                frontend: FRONTEND,
                chain: CHAIN,
                cube: CUBE,
                dma: DMA_CHIRP,
                work: WORKSPACE,
                cloud: CLOUD,
                ego: EGO,
            };
            match $crate::run(&mut con, &preset, p::$params(), buffers) {
                Ok(()) => debug::exit(debug::EXIT_SUCCESS),
                Err(e) => {
                    $crate::say!(con, "X {e}");
                    debug::exit(debug::EXIT_FAILURE);
                }
            }
            loop {
                cortex_m::asm::wfi();
            }
        }
    };
}

/// One preset's fixed inputs.
pub struct Preset<const TX: usize, const RX: usize> {
    /// Name printed in the header (`coloradar`, `iwr6843`).
    pub name: &'static str,
    /// Chirp waveform.
    pub waveform: Waveform,
    /// Antenna geometry.
    pub geometry: AntennaGeometry<TX, RX>,
    /// The embedded frame: loop → TX slot → RX → sample, `[I, Q]` int16 little-endian.
    pub frame: &'static [u8],
    /// Azimuth grid bins (printed in the header).
    pub azimuth_bins: usize,
    /// Elevation grid bins (printed in the header).
    pub elevation_bins: usize,
}

/// The `'static` buffers an image owns, one `static` each so the ELF names every one.
pub struct Buffers<
    'a,
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const P: usize,
    const E: usize,
    C: Chain<N, K, TX, RX, M, AZ>,
> {
    /// The frontend, unconfigured (all-zero bytes, so in `.bss`), configured at run time.
    pub frontend: &'a mut Frontend<N, K, TX, RX, M, AZ>,
    /// The chain, unconfigured, configured in place at run time.
    pub chain: &'a mut C,
    /// Radar cube storage.
    pub cube: &'a mut CubeStorage<N, K, M>,
    /// The one-chirp buffer a DMA would fill.
    pub dma: &'a mut [[[i16; 2]; N]; RX],
    /// Per-frame workspace.
    pub work: &'a mut C::Workspace,
    /// Output points.
    pub cloud: &'a mut PointCloud<P>,
    /// The ego-velocity stage (unconfigured, configured at run time).
    pub ego: &'a mut EgoEstimator<E>,
}

/// Why a run failed.
#[derive(Debug)]
pub enum Failure {
    /// The embedded frame has the wrong size.
    FrameSize {
        /// Bytes expected for the preset.
        expected: usize,
        /// Bytes embedded.
        found: usize,
    },
    /// The frontend or the chain rejected the configuration.
    Config(ConfigError),
    /// Ingestion rejected the frame.
    Frame(FrameError),
    /// `push_range_spectra` or `push_range_blocks` left another cube than `push_chirp` did.
    SpectraCube,
    /// The instruction clock does not count whole instructions per tick.
    Clock(clock::Calibration),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::FrameSize { expected, found } => write!(
                f,
                "embedded frame has {found} bytes, the preset expects {expected}"
            ),
            Failure::Clock(c) => write!(
                f,
                "{} instructions took {} ticks: not an instruction clock (run QEMU with -icount shift=0,sleep=off)",
                c.instructions, c.ticks
            ),
            Failure::Config(e) => write!(f, "configuration rejected: {e}"),
            Failure::Frame(e) => write!(f, "frame rejected: {e}"),
            Failure::SpectraCube => write!(
                f,
                "ingesting the range spectra or blocks left another cube than ingesting the chirps"
            ),
        }
    }
}

impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Self {
        Failure::Config(e)
    }
}

impl From<FrameError> for Failure {
    fn from(e: FrameError) -> Self {
        Failure::Frame(e)
    }
}

/// Copy chirp (`k`, `t`) of `frame` into the DMA buffer, as a DMA would.
fn load_chirp<const N: usize, const TX: usize, const RX: usize>(
    frame: &[u8],
    k: usize,
    t: usize,
    dma: &mut [[[i16; 2]; N]; RX],
) {
    let start = (k * TX + t) * RX * N * 4;
    let bytes = frame.get(start..start + RX * N * 4).unwrap_or(&[]);
    let mut words = bytes
        .chunks_exact(2)
        .map(|b| i16::from_le_bytes([b[0], b[1]]));
    for rx in dma.iter_mut() {
        for s in rx.iter_mut() {
            *s = [words.next().unwrap_or(0), words.next().unwrap_or(0)];
        }
    }
}

/// Configure the frontend and the chain in place (no chain-sized value on the stack). Never
/// inlined, so its temporaries belong to a frame popped before the per-frame work.
#[inline(never)]
fn configure<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    C: Chain<N, K, TX, RX, M, AZ>,
>(
    frontend: &mut Frontend<N, K, TX, RX, M, AZ>,
    chain: &mut C,
    preset: &Preset<TX, RX>,
    params: C::Params,
    range_window: dbe_radar::window::WindowKind,
) -> Result<(), ConfigError> {
    frontend.configure(preset.waveform, preset.geometry, range_window)?;
    chain.configure(frontend, params)
}

/// Ticks of a whole frame's ingestion, fed chirp by chirp.
struct Ingest {
    ticks: u64,
    chirp_min: u32,
    chirp_max: u32,
}

fn ingest<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
>(
    frontend: &Frontend<N, K, TX, RX, M, AZ>,
    cube: &mut Cube<'_, N, K, M>,
    dma: &mut [[[i16; 2]; N]; RX],
    frame: &[u8],
) -> Result<Ingest, FrameError> {
    let mut total = Ingest {
        ticks: 0,
        chirp_min: u32::MAX,
        chirp_max: 0,
    };
    cube.begin_frame();
    // The TDM order (`Frontend::tdm_order`) as two counted loops: iterating
    // `frontend.tdm_order()` here cost 355 more instructions per chirp on the Cortex-M4F
    // (`cargo xtask budget`, 2026-12-08).
    for k in 0..K {
        for t in 0..TX {
            load_chirp::<N, TX, RX>(frame, k, t, dma);
            let id = ChirpId {
                loop_index: k as u16,
                tx_slot: t as u8,
            };
            // Firmware learns a chirp's id at run time (from its DMA interrupt): the opaque
            // id keeps the compiler from specialising `push_chirp` on these loop counters
            // (which saved it 223 instructions per chirp that no real firmware gets).
            let id = core::hint::black_box(id);
            let (dt, r) = clock::time(|| frontend.push_chirp(cube, id, dma));
            r?;
            total.ticks += u64::from(dt);
            total.chirp_min = total.chirp_min.min(dt);
            total.chirp_max = total.chirp_max.max(dt);
        }
    }
    Ok(total)
}

/// FNV-1a over the cube's mantissas: the check that two ingestions left the same cube.
#[inline(never)]
fn cube_digest<const N: usize, const K: usize, const M: usize>(cube: &Cube<'_, N, K, M>) -> u32 {
    let mut h = 0x811c_9dc5u32;
    for v in cube.mantissas().iter().flatten().flatten().flatten() {
        h = (h ^ u32::from(*v as u16)).wrapping_mul(0x0100_0193);
    }
    h
}

/// Re-ingest the cube's frame chirp by chirp in TDM order: `push(cube, id)` prepares chirp
/// `id` untimed and returns the ticks of its timed push; then [`Frontend::frame`] (timed).
/// The cube must come out with the digest `before`, `push_chirp`'s (else
/// [`Failure::SpectraCube`]). Returns the ticks of the pushes and the frame check.
#[inline(always)]
fn reingest<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
>(
    frontend: &Frontend<N, K, TX, RX, M, AZ>,
    cube: &mut Cube<'_, N, K, M>,
    before: u32,
    mut push: impl FnMut(&mut Cube<'_, N, K, M>, ChirpId) -> Result<u32, FrameError>,
) -> Result<u64, Failure> {
    let mut ticks = 0u64;
    cube.begin_frame();
    for k in 0..K {
        for t in 0..TX {
            let id = ChirpId {
                loop_index: k as u16,
                tx_slot: t as u8,
            };
            // Opaque, as a chirp's id is to real firmware (`ingest`).
            ticks += u64::from(push(cube, core::hint::black_box(id))?);
        }
    }
    let (dt, r) = clock::time(|| frontend.frame(cube).map(|_| ()));
    r?;
    ticks += u64::from(dt);
    if cube_digest(cube) != before {
        return Err(Failure::SpectraCube);
    }
    Ok(ticks)
}

/// Ticks of the frame's ingestion from range spectra ([`Frontend::push_range_spectra`]), as
/// a radar whose FFT accelerator computes them would feed the core: each chirp's spectra are
/// computed first, untimed, by the frontend's `RangeFft` ([`reingest`]). Never inlined: its
/// spectra buffer (`RX·N·8` bytes) is on a stack frame of its own, after the frame's peak was
/// measured.
#[inline(never)]
fn ingest_spectra<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
>(
    frontend: &Frontend<N, K, TX, RX, M, AZ>,
    cube: &mut Cube<'_, N, K, M>,
    dma: &mut [[[i16; 2]; N]; RX],
    frame: &[u8],
    before: u32,
) -> Result<u64, Failure> {
    let fft = dbe_radar::range::RangeFft::<N>::new(frontend.range_window());
    let mut spectra = [[dbe_radar::Complex32::new(0.0, 0.0); N]; RX];
    reingest(frontend, cube, before, |cube, id| {
        let (k, t) = (usize::from(id.loop_index), usize::from(id.tx_slot));
        load_chirp::<N, TX, RX>(frame, k, t, dma);
        for (s, samples) in spectra.iter_mut().zip(dma.iter()) {
            fft.process(samples, s);
        }
        let (dt, r) = clock::time(|| frontend.push_range_spectra(cube, id, &spectra));
        r.map(|()| dt)
    })
}

/// Ticks of the frame's ingestion from 16-bit range spectra with an exponent
/// ([`Frontend::push_range_blocks`]): each chirp's mantissas and exponents are copied out of
/// the cube first, untimed, and fed back ([`reingest`]: the cube must come out unchanged);
/// `tests/pipeline.rs` (`range_blocks_…`) proves on the host that such blocks fill a
/// bit-identical cube from an empty one. Without calibrations the call stores the mantissas
/// as they are, so its cost does not depend on the values.
#[inline(never)]
fn ingest_blocks<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
>(
    frontend: &Frontend<N, K, TX, RX, M, AZ>,
    cube: &mut Cube<'_, N, K, M>,
    blocks: &mut [[[i16; 2]; N]; RX],
    before: u32,
) -> Result<u64, Failure> {
    let layout = frontend.layout().row_of;
    reingest(frontend, cube, before, |cube, id| {
        let (k, t) = (usize::from(id.loop_index), usize::from(id.tx_slot));
        let mut exponents = [BlockExponent::default(); RX];
        let rows = layout.get(t).copied().unwrap_or([0; RX]);
        for ((b, e), &row) in blocks.iter_mut().zip(exponents.iter_mut()).zip(rows.iter()) {
            let row = usize::from(row);
            for (v, bin) in b.iter_mut().zip(cube.mantissas().iter()) {
                *v = bin[k][row];
            }
            let stored = cube.exponents().get(row).and_then(|e| e.get(k)).copied();
            *e = stored.and_then(BlockExponent::new).unwrap_or_default();
        }
        let (dt, r) = clock::time(|| frontend.push_range_blocks(cube, id, blocks, &exponents));
        r.map(|()| dt)
    })
}

/// `f()` in a function of its own: each call site instantiates one, never inlined into its
/// caller, with `f`'s body inlined into it (a measured stage, out of [`run`]).
#[inline(never)]
fn out_of_line<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// The range window of a chain's parameters (both chains carry the frontend's).
pub trait RangeWindow {
    /// The range window the frontend must use.
    fn range_window(&self) -> dbe_radar::window::WindowKind;
}

impl RangeWindow for dbe_radar::Params {
    fn range_window(&self) -> dbe_radar::window::WindowKind {
        self.range_window
    }
}

impl RangeWindow for dbe_radar::FftParams {
    fn range_window(&self) -> dbe_radar::window::WindowKind {
        self.range_window
    }
}

/// Configure, process the preset's frame stage by stage, print points, stats and the
/// measured budget.
pub fn run<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const P: usize,
    const E: usize,
    C: Chain<N, K, TX, RX, M, AZ>,
>(
    con: &mut Console,
    preset: &Preset<TX, RX>,
    params: C::Params,
    b: Buffers<'_, N, K, TX, RX, M, AZ, P, E, C>,
) -> Result<(), Failure>
where
    C::Params: RangeWindow,
{
    let expected = N * K * TX * RX * 4;
    if preset.frame.len() != expected {
        return Err(Failure::FrameSize {
            expected,
            found: preset.frame.len(),
        });
    }
    // Nothing is printed until every measurement is done: a semihosting call stops the
    // guest, and QEMU's virtual clock may move relative to the instruction count meanwhile.
    let cal = clock::calibrate();
    if !cal.is_exact() {
        return Err(Failure::Clock(cal));
    }

    // Setup, then one frame on a freshly painted stack, each stage timed on its own.
    let window = params.range_window();
    let (t_setup, r) = clock::time(|| {
        configure(b.frontend, b.chain, preset, params, window)?;
        b.ego.configure(EgoParams::DEFAULT)
    });
    r?;
    let (frontend, chain) = (&*b.frontend, &*b.chain);
    let stack_setup = stack::peak_bytes();
    stack::repaint();
    let mut cube = Cube::new(&mut *b.cube);
    let mut ingest = ingest(frontend, &mut cube, b.dma, preset.frame)?;
    let (t_check, frame) = clock::time(|| frontend.frame(&cube));
    let frame = frame?;
    ingest.ticks += u64::from(t_check);
    // Each stage out of line: what LLVM inlines into this function must not depend on how
    // many other measurements it makes, or its stack frame and the image's flash move with
    // them.
    let (t_map, ()) = clock::time(|| out_of_line(|| chain.map(&frame, b.work)));
    let (t_detect, ()) = clock::time(|| out_of_line(|| chain.detect(b.work)));
    let (t_points, ()) = clock::time(|| out_of_line(|| chain.points(&frame, b.work, b.cloud)));
    let (t_ego, ego) = clock::time(|| out_of_line(|| b.ego.estimate(b.cloud.points())));
    let stack_frame = stack::peak_bytes();
    // `push_chirp`'s cube, which both ingestions below must leave as it is.
    let digest = cube_digest(&cube);
    let from_spectra = ingest_spectra(frontend, &mut cube, b.dma, preset.frame, digest)?;
    let from_blocks = ingest_blocks(frontend, &mut cube, b.dma, digest)?;

    say!(
        con,
        "H preset {} chain {} samples {N} loops {K} tx {TX} rx {RX} azimuth_bins {} elevation_bins {}",
        preset.name,
        C::NAME,
        preset.azimuth_bins,
        preset.elevation_bins
    );
    say!(con, "C {} {} {}", cal.instructions, cal.ticks, cal.per_tick);
    for d in C::detections(b.work) {
        say!(
            con,
            "D {} {} {} {}",
            d.range_bin,
            d.column,
            d.power,
            d.level
        );
    }
    for p in b.cloud.points() {
        say!(
            con,
            "P {} {} {} {} {} {} {} {} {} {}",
            p.range_bin,
            p.azimuth_bin,
            p.elevation_bin,
            p.doppler_bin,
            p.position.x,
            p.position.y,
            p.position.z,
            p.velocity_mps,
            p.power_db,
            p.snr_db
        );
    }
    say!(
        con,
        "V {} {} {} {} {} {}",
        ego.velocity.x,
        ego.velocity.y,
        ego.velocity.z,
        ego.inliers,
        ego.points,
        ego.status
    );
    let s = &b.cloud.stats;
    say!(
        con,
        "F {} {} {} {} {} {} {}",
        s.detections,
        s.detection_overflow,
        s.points,
        s.point_overflow,
        s.skipped_range_bins,
        s.detections_without_point,
        s.doppler_rejected
    );

    let chirps = (K * TX) as u64;
    let i = |ticks: u32| (cal.instructions(u64::from(ticks)), u64::from(ticks));
    let per_chirp = (
        cal.instructions(ingest.ticks) / chirps,
        ingest.ticks / chirps,
    );
    let process = u64::from(t_map) + u64::from(t_detect) + u64::from(t_points);
    let [map, detect, points] = C::STAGES;
    let stages: [(&str, (u64, u64)); 15] = [
        ("setup", i(t_setup)),
        ("range_fft_per_chirp", per_chirp),
        ("range_fft_chirp_min", i(ingest.chirp_min)),
        ("range_fft_chirp_max", i(ingest.chirp_max)),
        ("ingest", (cal.instructions(ingest.ticks), ingest.ticks)),
        (map, i(t_map)),
        (detect, i(t_detect)),
        (points, i(t_points)),
        ("process", (cal.instructions(process), process)),
        ("ego_velocity", i(t_ego)),
        (
            "total",
            (
                cal.instructions(ingest.ticks + process),
                ingest.ticks + process,
            ),
        ),
        (
            "ingest_from_spectra",
            (cal.instructions(from_spectra), from_spectra),
        ),
        (
            "total_from_spectra",
            (
                cal.instructions(from_spectra + process),
                from_spectra + process,
            ),
        ),
        (
            "ingest_from_blocks",
            (cal.instructions(from_blocks), from_blocks),
        ),
        (
            "total_from_blocks",
            (
                cal.instructions(from_blocks + process),
                from_blocks + process,
            ),
        ),
    ];
    for (name, (instructions, ticks)) in stages {
        say!(con, "S {name} {instructions} {ticks}");
    }
    say!(con, "M stack_setup {stack_setup}");
    say!(con, "M stack_frame {stack_frame}");
    say!(con, "E ok");
    Ok(())
}
