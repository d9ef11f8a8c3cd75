//! dbe-radar on a Cortex-M4F: the whole DBE chain on one embedded frame, with its resource
//! budget measured on the running image. The FFT baseline chain runs on the same frames in
//! its own binaries (`coloradar-fft`, `iwr6843-fft`; [`fft_chain`]).
//!
//! Each DBE binary (`coloradar`, `iwr6843`) declares its buffers as `static`s of its
//! `#[entry]` function (cortex-m-rt turns them into `&'static mut`, zero or uninitialised, so
//! in `.bss`: no heap, no global allocator, no megabyte on the stack, nothing copied from
//! flash) and calls [`run`], which
//!
//! 1. calibrates the instruction clock ([`clock`]),
//! 2. feeds the frame chirp by chirp in TDM order through a one-chirp "DMA" buffer and
//!    processes it with a CFAR threshold no cell passes (measurement only, see below),
//! 3. configures the chain in place ([`dbe_radar::Dbe::configure`]), repaints the stack ([`stack`]), feeds
//!    the frame again and processes it,
//! 4. prints everything as lines ([`console`]) and returns; the binary exits through
//!    semihosting with code 0 (any error: a message and a failure code).
//!
//! # Output lines (space separated; the host tool parses them)
//!
//! ```text
//! H preset <name> samples <N> loops <K> tx <TX> rx <RX> azimuth_bins <NAZ> elevation_bins <NEL>
//! C <instructions> <ticks> <per_tick>            instruction-clock calibration
//! D <range_bin> <azimuth_bin> <power> <level>    one CFAR detection (linear)
//! P <range_bin> <az_bin> <el_bin> <doppler_bin> <x> <y> <z> <v> <power_db> <snr_db>
//! F <detections> <detection_overflow> <points> <point_overflow> <skipped_range_bins> <detections_without_point>
//! S <stage> <instructions> <ticks>               one stage's cost
//! M <what> <bytes>                               stack_setup, stack_frame
//! E ok                                           end of a complete run
//! X <message>                                    the run failed (then exit code 1)
//! ```
//!
//! Floats are printed with `Display`, the shortest text that parses back to the same `f32`.
//! The FFT binaries print `H … chain fft …`, `R` detections and `Q` points instead
//! ([`fft_chain`]).
//!
//! # Stages
//!
//! The core exposes the chain as `push_chirp` + `process`, so the stages inside `process` are
//! measured by difference on the same cube: `process` with an unreachable CFAR threshold
//! runs stage 1 (covariances + azimuth Capon) and the CFAR with no detection; a standalone
//! `cfar::detect` with the same threshold gives the CFAR part; `process` with the real
//! parameters adds elevation + Doppler for every detection. The CFAR's per-detection
//! bookkeeping (a push into the detection list) is counted under elevation + Doppler. The
//! standalone CFAR runs with a zero loading floor (the `Workspace` keeps the real one
//! private); the floor only decides which of two values a `max` keeps.
//!
//! Each interval is quantised to one tick (40 instructions); `range_fft_per_chirp` is the
//! sum over the frame's chirps divided by their number.
//!
//! | stage | measured as |
//! |---|---|
//! | `range_fft_per_chirp` | Σ `push_chirp` / (K·TX) |
//! | `ingest` | Σ `push_chirp` over the frame |
//! | `azimuth_capon` | `process`(no detection) − `cfar::detect`(no detection) |
//! | `cfar` | `cfar::detect`(no detection) |
//! | `elevation_doppler` | `process`(real) − `process`(no detection) |
//! | `process` | `process`(real) |
//! | `total` | `ingest` + `process`: one frame |
//! | `setup` | `Dbe::configure` (once, not per frame) |
#![no_std]
#![deny(unsafe_code)]

pub mod clock;
pub mod console;
pub mod fft_chain;
pub mod stack;

pub use fft_chain::{run_fft, FftBuffers};

use core::fmt;

use dbe_radar::cfar::{self, Detections, MAX_TRAINING_CELLS};
use dbe_radar::cube::CubeStorage;
use dbe_radar::{
    AntennaGeometry, ChirpId, ConfigError, Cube, Dbe, FrameError, Params, PointCloud, Waveform,
    Workspace,
};

use console::Console;

/// CFAR threshold that no cell of a Capon map passes (α = 10³⁰): the "no detection" run.
const NO_DETECTION_DB: f32 = 300.0;

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
}

/// The `'static` buffers a binary owns, one `static` each so the ELF names every one.
pub struct Buffers<
    'a,
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
    const DET: usize,
    const P: usize,
> {
    /// The chain, `Dbe::unconfigured()` (all-zero bytes, so its `static` is in `.bss`),
    /// configured in place at run time.
    pub dbe: &'a mut Dbe<N, K, TX, RX, M, AZ, NAZ, NEL>,
    /// Radar cube storage.
    pub cube: &'a mut CubeStorage<N, M, K>,
    /// The one-chirp buffer a DMA would fill.
    pub dma: &'a mut [[[i16; 2]; N]; RX],
    /// Per-frame workspace.
    pub work: &'a mut Workspace<N, M, K, NAZ, DET>,
    /// Output points.
    pub cloud: &'a mut PointCloud<P>,
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
    /// The chain (`Dbe::configure`, `FftChain::new`) rejected the configuration.
    Config(ConfigError),
    /// Ingestion or processing rejected the frame.
    Frame(FrameError),
    /// The instruction clock does not count whole instructions per tick.
    Clock(clock::Calibration),
    /// The "no detection" run detected something: its stage split would be wrong.
    DetectionsInSilentRun(u32),
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
            Failure::DetectionsInSilentRun(n) => write!(
                f,
                "{n} detections with a {NO_DETECTION_DB} dB CFAR threshold: stage split invalid"
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

/// Configure the chain in place (`Dbe::configure`: no chain-sized value on the stack). Never
/// inlined, so its temporaries belong to a frame popped before the per-frame work.
#[inline(never)]
fn configure<
    's,
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
>(
    dbe: &'s mut Dbe<N, K, TX, RX, M, AZ, NAZ, NEL>,
    preset: &Preset<TX, RX>,
    params: Params,
) -> Result<&'s mut Dbe<N, K, TX, RX, M, AZ, NAZ, NEL>, ConfigError> {
    dbe.configure(preset.waveform, preset.geometry, params)?;
    Ok(dbe)
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
    const NAZ: usize,
    const NEL: usize,
>(
    dbe: &Dbe<N, K, TX, RX, M, AZ, NAZ, NEL>,
    cube: &mut Cube<'_, N, M, K>,
    dma: &mut [[[i16; 2]; N]; RX],
    frame: &[u8],
) -> Result<Ingest, FrameError> {
    let mut total = Ingest {
        ticks: 0,
        chirp_min: u32::MAX,
        chirp_max: 0,
    };
    cube.begin_frame();
    for k in 0..K {
        for t in 0..TX {
            load_chirp::<N, TX, RX>(frame, k, t, dma);
            let id = ChirpId {
                loop_index: k as u16,
                tx_slot: t as u8,
            };
            let (dt, r) = clock::time(|| dbe.push_chirp(cube, id, dma));
            r?;
            total.ticks += u64::from(dt);
            total.chirp_min = total.chirp_min.min(dt);
            total.chirp_max = total.chirp_max.max(dt);
        }
    }
    Ok(total)
}

/// The stage split (module docs): ticks of `process` with `silent` parameters (a threshold no
/// cell passes), and of `cfar::detect` alone with that threshold on the map it left. Never
/// inlined: the CFAR's scratch, floor and detection list (measurement only) live in this
/// frame, popped before the per-frame stack is measured, so they add nothing to static RAM.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn silent_split<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
    const DET: usize,
    const P: usize,
>(
    dbe: &Dbe<N, K, TX, RX, M, AZ, NAZ, NEL>,
    silent: &Params,
    cube: &mut Cube<'_, N, M, K>,
    dma: &mut [[[i16; 2]; N]; RX],
    work: &mut Workspace<N, M, K, NAZ, DET>,
    cloud: &mut PointCloud<P>,
    frame: &[u8],
) -> Result<(u32, u32), Failure> {
    ingest(dbe, cube, dma, frame)?;
    let (t_silent, r) = clock::time(|| dbe.process(cube, work, cloud));
    r?;
    if cloud.stats.detections != 0 {
        return Err(Failure::DetectionsInSilentRun(cloud.stats.detections));
    }
    let mut scratch = [0.0f32; MAX_TRAINING_CELLS];
    let floor = [0.0f32; N];
    let mut detections = Detections::<DET>::new();
    let first = usize::from(silent.range_first);
    let last = usize::from(silent.range_last).min(N - 1);
    let (t_cfar, ()) = clock::time(|| {
        cfar::detect(
            work.range_azimuth(),
            &floor,
            first,
            last,
            &silent.cfar,
            &mut scratch,
            &mut detections,
        )
    });
    let n = detections.as_slice().len() as u32;
    if n != 0 {
        return Err(Failure::DetectionsInSilentRun(n));
    }
    Ok((t_silent, t_cfar))
}

/// Process the preset's frame, print points, stats and the measured budget.
pub fn run<
    const N: usize,
    const K: usize,
    const TX: usize,
    const RX: usize,
    const M: usize,
    const AZ: usize,
    const NAZ: usize,
    const NEL: usize,
    const DET: usize,
    const P: usize,
>(
    con: &mut Console,
    preset: &Preset<TX, RX>,
    b: Buffers<'_, N, K, TX, RX, M, AZ, NAZ, NEL, DET, P>,
) -> Result<(), Failure> {
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

    let params = Params::defaults(N);

    // Measurement only: the chain with a threshold no cell passes.
    let mut silent = params;
    silent.cfar.threshold_db = NO_DETECTION_DB;
    let (t_silent, t_cfar) = {
        let dbe = configure(b.dbe, preset, silent)?;
        let mut cube = Cube::new(&mut *b.cube);
        silent_split(
            dbe,
            &silent,
            &mut cube,
            b.dma,
            b.work,
            b.cloud,
            preset.frame,
        )?
    };

    // The real chain: setup, then one frame on a freshly painted stack.
    let (t_setup, dbe) = clock::time(|| configure(b.dbe, preset, params));
    let dbe = dbe?;
    let stack_setup = stack::peak_bytes();
    stack::repaint();
    let mut cube = Cube::new(&mut *b.cube);
    let ingest = ingest(dbe, &mut cube, b.dma, preset.frame)?;
    let (t_full, r) = clock::time(|| dbe.process(&cube, b.work, b.cloud));
    r?;
    let stack_frame = stack::peak_bytes();

    say!(
        con,
        "H preset {} samples {N} loops {K} tx {TX} rx {RX} azimuth_bins {NAZ} elevation_bins {NEL}",
        preset.name
    );
    say!(con, "C {} {} {}", cal.instructions, cal.ticks, cal.per_tick);
    for d in b.work.detections() {
        say!(
            con,
            "D {} {} {} {}",
            d.range_bin,
            d.azimuth_bin,
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
    let s = &b.cloud.stats;
    say!(
        con,
        "F {} {} {} {} {} {}",
        s.detections,
        s.detection_overflow,
        s.points,
        s.point_overflow,
        s.skipped_range_bins,
        s.detections_without_point
    );

    let chirps = (K * TX) as u64;
    let (t_silent, t_cfar, t_full) = (u64::from(t_silent), u64::from(t_cfar), u64::from(t_full));
    let i = |ticks: u64| (cal.instructions(ticks), ticks);
    let per_chirp = (
        cal.instructions(ingest.ticks) / chirps,
        ingest.ticks / chirps,
    );
    let stages: [(&str, (u64, u64)); 10] = [
        ("setup", i(u64::from(t_setup))),
        ("range_fft_per_chirp", per_chirp),
        ("range_fft_chirp_min", i(u64::from(ingest.chirp_min))),
        ("range_fft_chirp_max", i(u64::from(ingest.chirp_max))),
        ("ingest", i(ingest.ticks)),
        ("azimuth_capon", i(t_silent.saturating_sub(t_cfar))),
        ("cfar", i(t_cfar)),
        ("elevation_doppler", i(t_full.saturating_sub(t_silent))),
        ("process", i(t_full)),
        ("total", i(ingest.ticks + t_full)),
    ];
    for (name, (instructions, ticks)) in stages {
        say!(con, "S {name} {instructions} {ticks}");
    }
    say!(con, "M stack_setup {stack_setup}");
    say!(con, "M stack_frame {stack_frame}");
    say!(con, "E ok");
    Ok(())
}
