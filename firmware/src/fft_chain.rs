//! The FFT baseline chain (spec §4, `dbe_radar::fft_pipeline`) on the same embedded frame,
//! measured the same way as the DBE chain ([`crate::run`]), in its own binaries
//! (`coloradar-fft`, `iwr6843-fft`).
//!
//! Own binaries rather than a second chain in the DBE images: the DBE images, and so the DBE
//! budget, stay exactly as they are (a second user of the shared core code in the same image
//! can change the inliner's choices, and with them the DBE chain's flash, stack and
//! instruction counts; see `README.md`), and each image is what a product running one chain
//! would flash. Both chains fill
//! the same `Cube` with the same `range::ingest` (`FftChain::push_chirp` is
//! `Dbe::push_chirp`), so the FFT image's `ingest` is the DBE image's, and what running both
//! chains on one cube adds to a DBE image is this image's `FFT_CHAIN` and `FFT_WORKSPACE`
//! statics and its `process` instructions.
//!
//! [`run_fft`]:
//!
//! 1. calibrates the instruction clock,
//! 2. builds the chain with a CFAR threshold no cell passes, feeds the frame and processes it
//!    (stage split, measurement only),
//! 3. builds the real chain ([`dbe_radar::FftChain::new`] returns the chain by value, ~27 KB;
//!    it is written into a `MaybeUninit` static by a never-inlined function, so the value's
//!    stack copies belong to setup, not to the frame), repaints the stack, feeds the frame
//!    again and processes it,
//! 4. prints everything and returns.
//!
//! # Output lines
//!
//! As the DBE binaries' (crate docs), except:
//!
//! ```text
//! H preset <name> chain fft samples <N> loops <K> tx <TX> rx <RX> azimuth_bins <NAZ> elevation_bins <NEL>
//! R <range_bin> <doppler_bin> <power> <level>   one range–Doppler CFAR detection (linear)
//! Q <range_bin> <az_bin> <el_bin> <doppler_bin> <x> <y> <z> <v> <power_db> <snr_db>
//! ```
//!
//! `Q` lines are the FFT chain's points, in the `P` lines' format; a run prints either `P`/`D`
//! lines (DBE, no `chain` field) or `Q`/`R` lines (`chain fft`), never both.
//!
//! # Stages
//!
//! | stage | measured as |
//! |---|---|
//! | `range_fft_per_chirp`, `…_min`, `…_max`, `ingest` | as the DBE chain (`FftChain::push_chirp`) |
//! | `doppler_fft` | `process`(no detection) − `rd_cfar::detect`(no detection) |
//! | `rd_cfar` | `rd_cfar::detect`(no detection) |
//! | `angles` | `process`(real) − `process`(no detection): per-detection Doppler bin, TDM, beamscan, elevation |
//! | `process` | `process`(real) |
//! | `total` | `ingest` + `process`: one frame |
//! | `setup` | `FftChain::new` written into its static (once, not per frame) |
//!
//! `doppler_fft` also holds the clearing of the range–Doppler map and the frame check;
//! `angles` holds the CFAR's pushes into the detection list. The CFAR tests only local
//! maxima, whatever the threshold, so the silent run's CFAR does the same work as the real
//! one but for those pushes.

use core::mem::MaybeUninit;

use dbe_radar::cfar::MAX_TRAINING_CELLS;
use dbe_radar::cube::CubeStorage;
use dbe_radar::fft_pipeline::{rd_cfar, RdDetections};
use dbe_radar::{
    ChirpId, ConfigError, Cube, FftChain, FftParams, FftWorkspace, FrameError, PointCloud,
};

use crate::console::Console;
use crate::{clock, load_chirp, say, stack, Failure, Ingest, Preset, NO_DETECTION_DB};

/// The `'static` buffers an FFT binary owns, one `static` each so the ELF names every one.
pub struct FftBuffers<
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
    /// Room for the chain (tables and parameters), built at run time. `MaybeUninit`: the
    /// chain has no all-zero `const` constructor, and an uninitialised static is in `.bss`.
    pub chain: &'a mut MaybeUninit<FftChain<N, K, TX, RX, M, AZ, NAZ, NEL>>,
    /// Radar cube storage.
    pub cube: &'a mut CubeStorage<N, M, K>,
    /// The one-chirp buffer a DMA would fill.
    pub dma: &'a mut [[[i16; 2]; N]; RX],
    /// Per-frame workspace (range–Doppler map, CFAR, detections).
    pub work: &'a mut FftWorkspace<N, M, K, DET>,
    /// Output points.
    pub cloud: &'a mut PointCloud<P>,
}

/// Build the chain into `slot`. Never inlined: `FftChain::new` returns the chain by value,
/// and its copies on the stack belong to this frame, popped before the per-frame work.
#[inline(never)]
fn build<
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
    slot: &'s mut MaybeUninit<FftChain<N, K, TX, RX, M, AZ, NAZ, NEL>>,
    preset: &Preset<TX, RX>,
    params: FftParams,
) -> Result<&'s mut FftChain<N, K, TX, RX, M, AZ, NAZ, NEL>, ConfigError> {
    let chain = FftChain::new(preset.waveform, preset.geometry, params)?;
    Ok(slot.write(chain))
}

/// [`crate::ingest`] through `FftChain::push_chirp`. A copy rather than one function over
/// both chains: making the DBE image's `ingest` generic changed its inlining, and with it
/// the DBE budget (measured: −1 % ingest instructions, −10 KB flash for IWR6843).
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
    chain: &FftChain<N, K, TX, RX, M, AZ, NAZ, NEL>,
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
            let (dt, r) = clock::time(|| chain.push_chirp(cube, id, dma));
            r?;
            total.ticks += u64::from(dt);
            total.chirp_min = total.chirp_min.min(dt);
            total.chirp_max = total.chirp_max.max(dt);
        }
    }
    Ok(total)
}

/// The stage split (module docs): ticks of `process` with `silent` parameters (a threshold no
/// cell passes), and of `rd_cfar::detect` alone with that threshold on the map it left. Never
/// inlined: the CFAR's scratch and detection list (measurement only) live in this frame.
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
    chain: &FftChain<N, K, TX, RX, M, AZ, NAZ, NEL>,
    silent: &FftParams,
    cube: &mut Cube<'_, N, M, K>,
    dma: &mut [[[i16; 2]; N]; RX],
    work: &mut FftWorkspace<N, M, K, DET>,
    cloud: &mut PointCloud<P>,
    frame: &[u8],
) -> Result<(u32, u32), Failure> {
    ingest(chain, cube, dma, frame)?;
    let (t_silent, r) = clock::time(|| chain.process(cube, work, cloud));
    r?;
    if cloud.stats.detections != 0 {
        return Err(Failure::DetectionsInSilentRun(cloud.stats.detections));
    }
    let mut scratch = [0.0f32; MAX_TRAINING_CELLS];
    let mut detections = RdDetections::<DET>::new();
    let first = usize::from(silent.range_first);
    let last = usize::from(silent.range_last).min(N - 1);
    let (t_cfar, ()) = clock::time(|| {
        rd_cfar::detect(
            work.range_doppler(),
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

/// Process the preset's frame with the FFT chain, print points, stats and the measured
/// budget (module docs).
pub fn run_fft<
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
    b: FftBuffers<'_, N, K, TX, RX, M, AZ, NAZ, NEL, DET, P>,
) -> Result<(), Failure> {
    let expected = N * K * TX * RX * 4;
    if preset.frame.len() != expected {
        return Err(Failure::FrameSize {
            expected,
            found: preset.frame.len(),
        });
    }
    // Nothing is printed until every measurement is done (see `crate::run`).
    let cal = clock::calibrate();
    if !cal.is_exact() {
        return Err(Failure::Clock(cal));
    }

    let params = FftParams::defaults(N);

    // Measurement only: the chain with a threshold no cell passes.
    let mut silent = params;
    silent.cfar.threshold_db = NO_DETECTION_DB;
    let (t_silent, t_cfar) = {
        let chain = build(b.chain, preset, silent)?;
        let mut cube = Cube::new(&mut *b.cube);
        silent_split(
            chain,
            &silent,
            &mut cube,
            b.dma,
            b.work,
            b.cloud,
            preset.frame,
        )?
    };

    // The real chain: setup, then one frame on a freshly painted stack.
    let (t_setup, chain) = clock::time(|| build(b.chain, preset, params));
    let chain = chain?;
    let stack_setup = stack::peak_bytes();
    stack::repaint();
    let mut cube = Cube::new(&mut *b.cube);
    let ingest = ingest(chain, &mut cube, b.dma, preset.frame)?;
    let (t_full, r) = clock::time(|| chain.process(&cube, b.work, b.cloud));
    r?;
    let stack_frame = stack::peak_bytes();

    say!(
        con,
        "H preset {} chain fft samples {N} loops {K} tx {TX} rx {RX} azimuth_bins {NAZ} elevation_bins {NEL}",
        preset.name
    );
    say!(con, "C {} {} {}", cal.instructions, cal.ticks, cal.per_tick);
    for d in b.work.detections() {
        say!(
            con,
            "R {} {} {} {}",
            d.range_bin,
            d.doppler_bin,
            d.power,
            d.level
        );
    }
    for p in b.cloud.points() {
        say!(
            con,
            "Q {} {} {} {} {} {} {} {} {} {}",
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
        ("doppler_fft", i(t_silent.saturating_sub(t_cfar))),
        ("rd_cfar", i(t_cfar)),
        ("angles", i(t_full.saturating_sub(t_silent))),
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
