//! `cargo xtask`: the firmware harness: build `firmware/` for the Cortex-M4F, run it under QEMU, read what it
//! prints, measure its memory from the ELF, and keep `docs/budget.json` and the budget block of
//! `memory-layout.md` in step with the measurement.
//!
//! ```text
//! frames ──▶ cargo build --release (firmware/, thumbv7em-none-eabihf) ──▶ ELF per Image
//!   coloradar: simulated here, written to firmware/target/frames/, embedded by build.rs
//!   iwr6843:   the TI capture in ../shared, de-interleaved by build.rs
//! ELF ──▶ qemu-system-arm -machine mps2-an386 -icount shift=0,sleep=off ──▶ lines ──▶ FirmwareRun
//! ELF ──▶ section and symbol sizes ──▶ ElfMemory
//! FirmwareRun + ElfMemory ──▶ PresetBudget ──▶ docs/budget.json, memory-layout.md block
//! ```
//!
//! # Images
//!
//! One image ([`Image`]) per preset and chain: `coloradar` and `iwr6843` run the DBE chain,
//! `coloradar-fft` and `iwr6843-fft` the FFT baseline chain on the same embedded frame. Each
//! is measured on its own and is one entry of the budget (`preset` is the image's name,
//! `chain` the chain), so the FFT chain never changes a DBE figure. Both chains ingest with
//! the same `Frontend` into the same `Cube`; what the FFT chain adds to a DBE image running
//! both on one cube is its `CHAIN` and `WORKSPACE` statics and its `process` stage.
//!
//! # Instruction counts
//!
//! With `-icount shift=0` QEMU's virtual clock advances exactly 1 ns per guest instruction, and
//! the firmware times each stage with the MPS2 FPGA's 25 MHz counter: 1 tick = 40
//! instructions, checked at run time against a delay loop of known length (see
//! `firmware/src/clock.rs`). `sleep=off` is needed for reproducible numbers: with QEMU 7.2's
//! default the virtual clock runs on host time until the guest's first instruction, which
//! shifts the tick phase by a random amount and every count by ±1 tick from run to run.
//! Counts are guest instructions, not cycles: QEMU models no pipeline, cache or wait state.
//!
//! # Modules, one job each
//!
//! | module | job |
//! |---|---|
//! | [`image`] | the tools, the images and boards, `cargo build` of `firmware/`, QEMU runs |
//! | [`frames`] | the frames the images embed (simulated ColoRadar, the TI capture) |
//! | [`protocol`] | parsing what an image prints ([`FirmwareRun`]) |
//! | [`elf`] | section and static sizes from the ELF ([`ElfMemory`]) |
//! | [`budget`] | measurement → `docs/budget.json` → the Markdown block, staleness checks |
//! | [`anchors`] | the Python chains issue 13 compares with, timed beside `dbe bench` (`docs/anchors.json`) |
//! | [`ffi`] | the C API: header (cbindgen), static libraries, the host and Cortex-M4F C programs |

pub mod anchors;
pub mod budget;
pub mod elf;
mod error;
pub mod ffi;
pub mod frames;
pub mod image;
pub mod profile;
pub mod protocol;

pub use budget::*;
pub use elf::*;
pub(crate) use error::io_err;
pub use error::FirmwareError;
pub use ffi::*;
pub(crate) use frames::write_if_changed;
pub use frames::*;
pub use image::*;
pub(crate) use image::{run_command, version_line};
pub use protocol::*;

/// The firmware's Rust target (Cortex-M4F and M7 images).
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The Rust target of the Cortex-M33 (Armv8-M Mainline) images, run on [`Board::An505`].
pub const TARGET_V8M: &str = "thumbv8m.main-none-eabihf";

/// The QEMU system emulator for Arm.
pub const QEMU: &str = "qemu-system-arm";

/// First line of the generated block in `memory-layout.md`.
pub const BLOCK_BEGIN: &str = "<!-- budget:begin -->";

/// Last line of the generated block in `memory-layout.md`.
pub const BLOCK_END: &str = "<!-- budget:end -->";

/// The command that regenerates `docs/budget.json` and the block (printed in stale-check
/// messages and in the block itself).
pub const UPDATE_COMMAND: &str = "cargo xtask budget";

#[cfg(test)]
mod tests;
