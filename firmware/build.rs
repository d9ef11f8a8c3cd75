//! Build script: put the board's memory map (`memory-an386.x`, or `memory-an505.x` for the
//! Armv8-M target) on the linker path as `memory.x` and embed one ADC frame per preset. (No
//! file of the package is called `memory.x`: the linker would find it in the package folder
//! before `OUT_DIR`.)
//!
//! The frames are made by the host tool, `cargo xtask frames` (the repository root), in the
//! order a DMA delivers them: loop → TX slot → RX → sample, `[I, Q]` as int16 little-endian:
//!
//! - `coloradar.frame`: a simulated ColoRadar frame (`xtask::frames::coloradar_frame`);
//! - `iwr6843.frame`: the TI capture `../shared/fixtures/ti-iwr6843-corner-reflector/`, read by
//!   the host crate's DCA1000 reader (`host_sim::io::read_dca1000`), the project's one
//!   de-interleaver.
//!
//! They are copied from the folder named by `DBE_FW_FRAMES` (default `target/frames` of this
//! crate) into `OUT_DIR`. Nothing here is committed: a missing or wrong-sized frame fails the
//! build with the path it expected and the command that makes it.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

/// ColoRadar preset: loops, TX, RX, samples.
const COLORADAR_SHAPE: (usize, usize, usize, usize) = (128, 3, 4, 128);
/// IWR6843 fixture: loops, TX, RX, samples (its README).
const IWR_SHAPE: (usize, usize, usize, usize) = (64, 3, 4, 256);

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let out = PathBuf::from(env::var("OUT_DIR").map_err(|_| "OUT_DIR is not set".to_string())?);
    let manifest = PathBuf::from(
        env::var("CARGO_MANIFEST_DIR").map_err(|_| "CARGO_MANIFEST_DIR is not set".to_string())?,
    );

    // Linker script: the MPS2 AN385/AN386/AN500 map for Armv7-M, the AN505's Secure aliases
    // for Armv8-M (the Cortex-M33 board); the clock's counter address follows (`mps2_tz`).
    println!("cargo:rustc-check-cfg=cfg(mps2_tz)");
    let target = env::var("TARGET").unwrap_or_default();
    let memory = if target.starts_with("thumbv8m") {
        println!("cargo:rustc-cfg=mps2_tz");
        "memory-an505.x"
    } else {
        "memory-an386.x"
    };
    fs::copy(manifest.join(memory), out.join("memory.x")).map_err(|e| {
        format!(
            "{}: cannot copy to OUT_DIR: {e}",
            manifest.join(memory).display()
        )
    })?;
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory-an386.x");
    println!("cargo:rerun-if-changed=memory-an505.x");
    println!("cargo:rerun-if-changed=build.rs");

    println!("cargo:rerun-if-env-changed=DBE_FW_FRAMES");
    let frames = match env::var_os("DBE_FW_FRAMES") {
        Some(dir) => PathBuf::from(dir),
        None => manifest.join("target").join("frames"),
    };
    for (name, shape) in [
        ("coloradar.frame", COLORADAR_SHAPE),
        ("iwr6843.frame", IWR_SHAPE),
    ] {
        let path = frames.join(name);
        println!("cargo:rerun-if-changed={}", path.display());
        let data = read_exact(&path, frame_bytes(shape))?;
        fs::write(out.join(name), &data)
            .map_err(|e| format!("{}: cannot write: {e}", out.join(name).display()))?;
    }
    Ok(())
}

fn frame_bytes((loops, tx, rx, samples): (usize, usize, usize, usize)) -> usize {
    loops * tx * rx * samples * 4
}

fn read_exact(path: &Path, bytes: usize) -> Result<Vec<u8>, String> {
    let hint = "make the frames with `cargo xtask frames` from the repository root";
    let data =
        fs::read(path).map_err(|e| format!("{}: cannot read: {e}; {hint}", path.display()))?;
    if data.len() != bytes {
        return Err(format!(
            "{}: expected a frame of {bytes} bytes, found {} bytes; {hint}",
            path.display(),
            data.len()
        ));
    }
    Ok(data)
}
