//! The FFT baseline chain, IWR6843 preset (256 samples × 64 loops), on the `iwr6843` binary's
//! frame: the TI corner-reflector capture.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
use panic_semihosting as _;

use dbe_firmware::console::Console;
use dbe_firmware::{run_fft, say, FftBuffers, Preset};
use dbe_radar::presets::iwr6843 as p;
use dbe_radar::{AntennaGeometry, Waveform};

/// The frame the DBE binary embeds, from the same file in `OUT_DIR` (`build.rs`).
static FRAME: [u8; FRAME_BYTES] = *include_bytes!(concat!(env!("OUT_DIR"), "/iwr6843.frame"));

/// Bytes of one frame: the array type makes a wrong-sized file a compile error.
const FRAME_BYTES: usize = p::LOOPS * p::TX * p::RX * p::SAMPLES * 4;

#[entry]
fn main() -> ! {
    // As in the DBE binary: every buffer is zero or uninitialised at reset, so in `.bss`.
    // `FftChain` has no all-zero `const` constructor: its slot is uninitialised and
    // `run_fft` writes the chain into it.
    static mut FFT_CHAIN: MaybeUninit<p::FftChain> = MaybeUninit::uninit();
    static mut CUBE: p::CubeStorage = dbe_radar::cube::zero_storage();
    static mut DMA_CHIRP: p::Chirp = [[[0; 2]; p::SAMPLES]; p::RX];
    static mut FFT_WORKSPACE: p::FftWorkspace = p::FftWorkspace::new();
    static mut CLOUD: p::PointCloud = p::PointCloud::new();

    let mut con = Console::open();
    let preset = Preset {
        name: "iwr6843",
        waveform: Waveform::IWR6843_FIXTURE,
        geometry: AntennaGeometry::IWR6843_FIXTURE,
        frame: &FRAME,
    };
    let buffers = FftBuffers {
        chain: FFT_CHAIN,
        cube: CUBE,
        dma: DMA_CHIRP,
        work: FFT_WORKSPACE,
        cloud: CLOUD,
    };
    match run_fft(&mut con, &preset, buffers) {
        Ok(()) => debug::exit(debug::EXIT_SUCCESS),
        Err(e) => {
            say!(con, "X {e}");
            debug::exit(debug::EXIT_FAILURE);
        }
    }
    loop {
        cortex_m::asm::wfi();
    }
}
