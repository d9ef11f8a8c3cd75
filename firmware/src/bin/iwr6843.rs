//! The DBE chain, IWR6843 preset (256 samples × 64 loops), on the TI corner-reflector capture.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
use panic_semihosting as _;

use dbe_firmware::console::Console;
use dbe_firmware::{run, say, Buffers, Preset};
use dbe_radar::presets::iwr6843 as p;
use dbe_radar::{AntennaGeometry, Waveform};

/// The TI capture, de-interleaved, written to `OUT_DIR` by `build.rs`.
static FRAME: [u8; FRAME_BYTES] = *include_bytes!(concat!(env!("OUT_DIR"), "/iwr6843.frame"));

/// Bytes of one frame: the array type makes a wrong-sized file a compile error.
const FRAME_BYTES: usize = p::LOOPS * p::TX * p::RX * p::SAMPLES * 4;

#[entry]
fn main() -> ! {
    // cortex-m-rt hands each of these out once as `&'static mut`; all are zero (or
    // uninitialised) at reset, so they live in `.bss`: nothing is copied from flash and nothing
    // big touches the stack.
    static mut DBE: p::Dbe = p::Dbe::unconfigured();
    static mut CUBE: p::CubeStorage = dbe_radar::cube::zero_storage();
    static mut DMA_CHIRP: p::Chirp = [[[0; 2]; p::SAMPLES]; p::RX];
    static mut WORKSPACE: p::Workspace = p::Workspace::new();
    static mut CLOUD: p::PointCloud = p::PointCloud::new();

    let mut con = Console::open();
    let preset = Preset {
        name: "iwr6843",
        waveform: Waveform::IWR6843_FIXTURE,
        geometry: AntennaGeometry::IWR6843_FIXTURE,
        frame: &FRAME,
    };
    let buffers = Buffers {
        dbe: DBE,
        cube: CUBE,
        dma: DMA_CHIRP,
        work: WORKSPACE,
        cloud: CLOUD,
    };
    match run(&mut con, &preset, buffers) {
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
