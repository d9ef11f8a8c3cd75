//! The C API (`ffi/`): its header, its static library for the host and the Cortex-M4F, and
//! the two C programs that use it.
//!
//! ```text
//! ffi/src/lib.rs ──cbindgen (ffi/cbindgen.toml)──▶ ffi/dbe_radar.h (checked in; `header --check`)
//! ffi/ ──cargo build --release [--target thumbv7em-none-eabihf]──▶ libdbe_radar_ffi.a
//! ffi/c/{example,errors}.c + host library ──cc──▶ ffi/target/c/…   (the TI capture; error paths)
//! ffi/c/firmware/*.c + frame ──arm-none-eabi-gcc──▶ ELF ──QEMU mps2-an386──▶ lines
//! ```

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use crate::*;

/// The Arm bare-metal C compiler (Debian `gcc-arm-none-eabi`, with `libnewlib-arm-none-eabi`).
pub const ARM_GCC: &str = "arm-none-eabi-gcc";

/// Longest a library or C build may take.
const BUILD_TIMEOUT: Duration = Duration::from_secs(1800);

/// Which frame a C firmware embeds: the presets the Rust firmware has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CPreset {
    /// ColoRadar preset, the simulated frame.
    Coloradar,
    /// IWR6843 preset, the TI capture.
    Iwr6843,
}

impl CPreset {
    /// Name as in the Rust firmware's images.
    pub const fn name(self) -> &'static str {
        match self {
            CPreset::Coloradar => "coloradar",
            CPreset::Iwr6843 => "iwr6843",
        }
    }
}

impl Layout {
    /// `ffi/`.
    pub fn ffi(&self) -> PathBuf {
        self.repo.join("ffi")
    }

    /// The checked-in header.
    pub fn header(&self) -> PathBuf {
        self.ffi().join("dbe_radar.h")
    }

    /// Where the C programs are built.
    pub fn ffi_build(&self) -> PathBuf {
        self.ffi().join("target").join("c")
    }
}

/// The header cbindgen makes from `ffi/src/lib.rs` with `ffi/cbindgen.toml`.
pub fn generate_header(layout: &Layout) -> Result<String, FirmwareError> {
    let dir = layout.ffi();
    let config_path = dir.join("cbindgen.toml");
    let config =
        cbindgen::Config::from_file(&config_path).map_err(|message| FirmwareError::BadInput {
            path: config_path.clone(),
            message,
        })?;
    let bindings = cbindgen::Builder::new()
        .with_crate(&dir)
        .with_config(config)
        .generate()
        .map_err(|e| FirmwareError::BadInput {
            path: dir.join("src").join("lib.rs"),
            message: format!("cbindgen: {e}"),
        })?;
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).map_err(|e| FirmwareError::BadInput {
        path: layout.header(),
        message: format!("cbindgen wrote non-UTF-8: {e}"),
    })
}

/// Whether the checked-in header is what cbindgen makes now.
pub fn header_is_current(layout: &Layout) -> Result<bool, FirmwareError> {
    let path = layout.header();
    let current = std::fs::read_to_string(&path).map_err(io_err(&path, "read"))?;
    Ok(current == generate_header(layout)?)
}

/// Write the header (only when it changed).
pub fn write_header(layout: &Layout) -> Result<PathBuf, FirmwareError> {
    let path = layout.header();
    write_if_changed(&path, generate_header(layout)?.as_bytes())?;
    Ok(path)
}

/// `cargo build --release` of `ffi/` for `target` (`None`: the host); the static library.
pub fn build_library(layout: &Layout, target: Option<&str>) -> Result<PathBuf, FirmwareError> {
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.args(["build", "--release", "--quiet"])
        .current_dir(layout.ffi())
        .env("CARGO_ENCODED_RUSTFLAGS", remap_flags(&layout.repo))
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS");
    let mut dir = layout.ffi().join("target");
    if let Some(t) = target {
        cmd.args(["--target", t]);
        dir = dir.join(t);
    }
    run_command(cmd, BUILD_TIMEOUT)?;
    let lib = dir.join("release").join("libdbe_radar_ffi.a");
    if !lib.is_file() {
        return Err(FirmwareError::BadInput {
            path: lib,
            message: "cargo build succeeded but wrote no static library".into(),
        });
    }
    Ok(lib)
}

/// Path-remapping flags (as the firmware's: the library does not embed where it was built).
fn remap_flags(repo: &Path) -> String {
    firmware_rustflags(repo)
        .split('\x1f')
        .filter(|f| f.starts_with("--remap-path-prefix"))
        .collect::<Vec<_>>()
        .join("\x1f")
}

/// Check that a C compiler for `tool` is installed.
fn check_compiler(tool: &str, hint: &str) -> Result<(), FirmwareError> {
    let ok = Command::new(tool)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        Ok(())
    } else {
        Err(FirmwareError::ToolMissing {
            tool: tool.into(),
            hint: hint.into(),
        })
    }
}

/// Build the host C program `ffi/c/<program>.c` against the host library: `example` (the
/// program README shows) or `errors` (every error path of the API).
pub fn build_host_program(layout: &Layout, program: &str) -> Result<PathBuf, FirmwareError> {
    check_compiler("cc", "apt-get install gcc")?;
    let lib = build_library(layout, None)?;
    let out_dir = layout.ffi_build();
    std::fs::create_dir_all(&out_dir).map_err(io_err(&out_dir, "create"))?;
    let exe = out_dir.join(program);
    let mut cmd = Command::new("cc");
    cmd.args([
        "-std=c11",
        "-O2",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-pedantic",
    ])
    .arg("-I")
    .arg(layout.ffi())
    .arg(layout.ffi().join("c").join(format!("{program}.c")))
    .arg(&lib)
    .args(["-lm", "-o"])
    .arg(&exe);
    run_command(cmd, BUILD_TIMEOUT)?;
    Ok(exe)
}

/// Run a host C program with `args`; its standard output (an error unless it exits 0).
pub fn run_host_program(exe: &Path, args: &[&Path]) -> Result<String, FirmwareError> {
    let mut cmd = Command::new(exe);
    cmd.args(args);
    run_command(cmd, Duration::from_secs(120))
}

/// Build the C firmware for `preset` (the Rust firmware's frame of that preset, made by
/// [`write_frames`]) against the Cortex-M4F library; the ELF.
pub fn build_c_firmware(layout: &Layout, preset: CPreset) -> Result<PathBuf, FirmwareError> {
    check_compiler(
        ARM_GCC,
        "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi",
    )?;
    check_tools()?;
    write_frames(layout)?;
    let lib = build_library(layout, Some(TARGET))?;
    let src = layout.ffi().join("c").join("firmware");
    let out_dir = layout.ffi_build();
    std::fs::create_dir_all(&out_dir).map_err(io_err(&out_dir, "create"))?;
    let elf = out_dir.join(format!("c-firmware-{}.elf", preset.name()));
    let frame = layout.frames_dir().join(format!("{}.frame", preset.name()));
    let mut cmd = Command::new(ARM_GCC);
    cmd.args([
        "-mcpu=cortex-m4",
        "-mthumb",
        "-mfloat-abi=hard",
        "-mfpu=fpv4-sp-d16",
        "-std=c11",
        "-O2",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-ffunction-sections",
        "-fdata-sections",
        "-nostartfiles",
        "--specs=nano.specs",
        "--specs=nosys.specs",
        // snprintf's %g.
        "-u",
        "_printf_float",
        "-Wl,--gc-sections",
    ])
    .arg(format!("-DDBE_FRAME=\"{}\"", frame.display()))
    .args(match preset {
        CPreset::Coloradar => &[][..],
        CPreset::Iwr6843 => &["-DDBE_C_IWR6843"][..],
    })
    .arg("-I")
    .arg(layout.ffi())
    .arg("-T")
    .arg(src.join("link.ld"))
    .arg(src.join("startup.c"))
    .arg(src.join("main.c"))
    .arg(src.join("frame.S"))
    .arg(&lib)
    .args(["-lm", "-o"])
    .arg(&elf);
    run_command(cmd, BUILD_TIMEOUT)?;
    Ok(elf)
}

/// Run a C firmware ELF on QEMU's Cortex-M4F board; its output lines.
pub fn run_c_firmware(elf: &Path) -> Result<String, FirmwareError> {
    let mut cmd = Command::new(QEMU);
    cmd.args(Board::An386.qemu_args(elf));
    run_command(cmd, Duration::from_secs(600))
}
