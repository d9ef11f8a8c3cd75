//! The tools, the images and boards, `cargo build` of `firmware/`, and QEMU runs.

use std::ffi::OsString;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use host_sim::core_run::Chain;
use host_sim::frame::AdcFrame;

use crate::*;

/// Longest a single QEMU run may take before it is killed (a hung firmware).
const RUN_TIMEOUT: Duration = Duration::from_secs(600);

/// A QEMU board the firmware runs on. The AN386 and AN500 have 4 MiB of code SSRAM at 0 and
/// 4 MiB of data SSRAM at `0x2000_0000` (see `firmware/memory-an386.x`), so one `thumbv7em` image
/// runs on either; the AN505 (Armv8-M) runs its own build, linked at the Secure aliases of the
/// same two 4 MiB memories (`firmware/memory-an505.x`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Board {
    /// MPS2 AN386, Cortex-M4F: the board the budget is measured on.
    An386,
    /// MPS2 AN500, Cortex-M7.
    An500,
    /// MPS2 AN505, Cortex-M33 (the `thumbv8m.main-none-eabihf` build).
    An505,
}

impl Board {
    /// Every board, as `cargo xtask firmware --board` names them.
    pub const ALL: [Board; 3] = [Board::An386, Board::An500, Board::An505];

    /// QEMU's `-machine` name.
    pub const fn machine(self) -> &'static str {
        match self {
            Board::An386 => "mps2-an386",
            Board::An500 => "mps2-an500",
            Board::An505 => "mps2-an505",
        }
    }

    /// QEMU's `-cpu` name.
    pub const fn cpu(self) -> &'static str {
        match self {
            Board::An386 => "cortex-m4",
            Board::An500 => "cortex-m7",
            Board::An505 => "cortex-m33",
        }
    }

    /// The Rust target of the images this board runs.
    pub const fn target(self) -> &'static str {
        match self {
            Board::An386 | Board::An500 => TARGET,
            Board::An505 => TARGET_V8M,
        }
    }

    /// The name `cargo xtask firmware --board` takes: `an386`, `an500`, `an505`.
    pub fn short_name(self) -> &'static str {
        self.machine().trim_start_matches("mps2-")
    }

    /// QEMU's arguments to run `elf` on this board, deterministically (see the module docs).
    pub fn qemu_args(self, elf: &Path) -> Vec<OsString> {
        let mut args: Vec<OsString> = [
            "-machine",
            self.machine(),
            "-cpu",
            self.cpu(),
            "-icount",
            "shift=0,sleep=off",
            "-semihosting-config",
            "enable=on,target=native",
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            "none",
            "-kernel",
        ]
        .iter()
        .map(OsString::from)
        .collect();
        args.push(elf.as_os_str().to_owned());
        args
    }
}

/// A core preset with firmware images (`firmware/src/bin/`): the host presets
/// [`host_sim::core_run::Preset::COLORADAR`] and [`host_sim::core_run::Preset::IWR6843`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// `dbe_radar::presets::coloradar`: 128 samples, 128 loops, 3 TX × 4 RX.
    ColoRadar,
    /// `dbe_radar::presets::iwr6843`: 256 samples, 64 loops, 3 TX × 4 RX.
    Iwr6843,
}

impl Preset {
    /// Every preset with firmware images.
    pub const ALL: [Preset; 2] = [Preset::ColoRadar, Preset::Iwr6843];

    /// The host preset of the same sizes.
    pub const fn host(self) -> host_sim::core_run::Preset {
        match self {
            Preset::ColoRadar => host_sim::core_run::Preset::COLORADAR,
            Preset::Iwr6843 => host_sim::core_run::Preset::IWR6843,
        }
    }

    /// The preset's name (`coloradar`, `iwr6843`), as the firmware prints it.
    pub const fn name(self) -> &'static str {
        match self {
            Preset::ColoRadar => "coloradar",
            Preset::Iwr6843 => "iwr6843",
        }
    }

    /// `(samples, loops, tx, rx)`.
    pub const fn sizes(self) -> (usize, usize, usize, usize) {
        self.host().sizes()
    }

    /// Azimuth grid bins.
    pub const fn azimuth_bins(self) -> usize {
        self.host().azimuth_bins()
    }

    /// Elevation grid bins.
    pub const fn elevation_bins(self) -> usize {
        self.host().elevation_bins()
    }

    /// Detection capacity per frame.
    pub const fn detection_capacity(self) -> usize {
        self.host().detection_capacity()
    }
}

impl std::fmt::Display for Preset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.host().fmt(f)
    }
}

/// One firmware image: a preset's sizes and the chain it runs (a binary of `firmware/`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Image {
    /// The core preset (array sizes, waveform, geometry, embedded frame).
    pub preset: Preset,
    /// The chain the image runs.
    pub chain: Chain,
}

impl Image {
    /// Every image, in budget order: the DBE images, then the FFT ones.
    pub const ALL: [Image; 4] = [
        Image::dbe(Preset::ColoRadar),
        Image::dbe(Preset::Iwr6843),
        Image::fft(Preset::ColoRadar),
        Image::fft(Preset::Iwr6843),
    ];

    /// The DBE image of `preset`.
    pub const fn dbe(preset: Preset) -> Self {
        Self {
            preset,
            chain: Chain::Dbe,
        }
    }

    /// The FFT-chain image of `preset`.
    pub const fn fft(preset: Preset) -> Self {
        Self {
            preset,
            chain: Chain::Fft,
        }
    }

    /// The binary's name, also the budget entry's `preset`: `coloradar`, `coloradar-fft`, ….
    pub const fn name(self) -> &'static str {
        match (self.preset, self.chain) {
            (Preset::ColoRadar, Chain::Dbe) => "coloradar",
            (Preset::Iwr6843, Chain::Dbe) => "iwr6843",
            (Preset::ColoRadar, Chain::Fft) => "coloradar-fft",
            (Preset::Iwr6843, Chain::Fft) => "iwr6843-fft",
        }
    }
}

impl std::fmt::Display for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The chain's name in the firmware's output and the budget: `dbe`, `fft`.
pub const fn chain_name(chain: Chain) -> &'static str {
    match chain {
        Chain::Dbe => "dbe",
        Chain::Fft => "fft",
    }
}

/// Where things are: the repository, its `firmware/` crate and the shared fixtures.
#[derive(Clone, Debug)]
pub struct Layout {
    /// Repository root (holds `Cargo.toml`, `firmware/`, `docs/`, `memory-layout.md`).
    pub repo: PathBuf,
    /// `../shared` beside the repository (fixtures).
    pub shared: PathBuf,
}

impl Layout {
    /// The layout around this crate's manifest directory (`host-sim/`).
    pub fn from_host_sim_manifest(manifest_dir: &Path) -> Self {
        let repo = manifest_dir
            .parent()
            .map_or_else(|| PathBuf::from(".."), Path::to_path_buf);
        let shared = repo.join("..").join("shared");
        Self { repo, shared }
    }

    /// The layout of the repository this crate was built in.
    pub fn this_repo() -> Self {
        Self::from_host_sim_manifest(Path::new(env!("CARGO_MANIFEST_DIR")))
    }

    /// `firmware/`.
    pub fn firmware(&self) -> PathBuf {
        self.repo.join("firmware")
    }

    /// The TI capture the IWR6843 firmware embeds.
    pub fn iwr6843_capture(&self) -> PathBuf {
        self.shared
            .join("fixtures")
            .join("ti-iwr6843-corner-reflector")
            .join("adc_data_Raw_0.bin")
    }

    /// Where the frames the images embed are written for `build.rs` (`DBE_FW_FRAMES`).
    pub fn frames_dir(&self) -> PathBuf {
        self.firmware().join("target").join("frames")
    }

    /// The firmware ELF of `image` (the `thumbv7em` build, Cortex-M4F and M7).
    pub fn elf(&self, image: Image) -> PathBuf {
        self.elf_for(image, TARGET)
    }

    /// The firmware ELF of `image` built for the Rust `target`.
    pub fn elf_for(&self, image: Image, target: &str) -> PathBuf {
        self.firmware()
            .join("target")
            .join(target)
            .join("release")
            .join(image.name())
    }

    /// `docs/budget.json`.
    pub fn budget_json(&self) -> PathBuf {
        self.repo.join("docs").join("budget.json")
    }

    /// `memory-layout.md`.
    pub fn memory_layout(&self) -> PathBuf {
        self.repo.join("memory-layout.md")
    }
}

/// Check that QEMU and the Cortex-M target are installed.
pub fn check_tools() -> Result<(), FirmwareError> {
    let qemu = Command::new(QEMU)
        .arg("--version")
        .stdin(Stdio::null())
        .output();
    if !qemu.is_ok_and(|o| o.status.success()) {
        return Err(FirmwareError::ToolMissing {
            tool: QEMU.into(),
            hint: "apt-get install qemu-system-arm".into(),
        });
    }
    let sysroot = Command::new("rustc")
        .args(["--print", "sysroot"])
        .current_dir(Layout::this_repo().firmware())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    for target in [TARGET, TARGET_V8M] {
        let has_target = sysroot
            .as_ref()
            .is_some_and(|s| s.join("lib/rustlib").join(target).is_dir());
        if !has_target {
            return Err(FirmwareError::ToolMissing {
                tool: format!("the {target} Rust target"),
                hint: format!("rustup target add {target}"),
            });
        }
    }
    Ok(())
}

/// First line of `program --version`-style output, or "unknown".
pub(crate) fn version_line(program: &str, args: &[&str], dir: &Path) -> String {
    Command::new(program)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .ok()
        .and_then(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .next()
                .map(str::to_owned)
        })
        .unwrap_or_else(|| "unknown".into())
}

// ---------------------------------------------------------------------------------------------
// Build and run

/// Run `cmd`, killing it after `timeout`; its stdout on success.
pub(crate) fn run_command(mut cmd: Command, timeout: Duration) -> Result<String, FirmwareError> {
    let line = format!("{cmd:?}");
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| FirmwareError::Command {
            command: line.clone(),
            status: "could not start".into(),
            stderr: e.to_string(),
        })?;
    // Drain both pipes on threads so a chatty child never blocks on a full pipe.
    let mut out = child.stdout.take();
    let mut err = child.stderr.take();
    let out_t = std::thread::spawn(move || {
        let mut s = Vec::new();
        if let Some(o) = out.as_mut() {
            let _ = o.read_to_end(&mut s);
        }
        s
    });
    let err_t = std::thread::spawn(move || {
        let mut s = Vec::new();
        if let Some(e) = err.as_mut() {
            let _ = e.read_to_end(&mut s);
        }
        s
    });
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Some(status),
            Ok(None) if start.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(_) => break None,
        }
    };
    let stdout = out_t.join().unwrap_or_default();
    let stderr = err_t.join().unwrap_or_default();
    let stderr = String::from_utf8_lossy(&stderr);
    let tail: String = {
        let lines: Vec<&str> = stderr.lines().collect();
        lines[lines.len().saturating_sub(40)..].join("\n")
    };
    match status {
        Some(s) if s.success() => Ok(String::from_utf8_lossy(&stdout).into_owned()),
        Some(s) => Err(FirmwareError::Command {
            command: line,
            status: s.to_string(),
            stderr: format!("{tail}\n{}", tail_of(&String::from_utf8_lossy(&stdout))),
        }),
        None => Err(FirmwareError::Command {
            command: line,
            status: format!("timed out after {} s", timeout.as_secs()),
            stderr: tail,
        }),
    }
}

/// The last lines of `text`.
fn tail_of(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(10)..].join("\n")
}

/// Write the ColoRadar frame where `build.rs` reads it and build every firmware binary for
/// both targets (`cargo build --release --target T` in `firmware/`: [`TARGET`] for the
/// Cortex-M4F and M7, [`TARGET_V8M`] for the Cortex-M33). Returns the frame that was embedded.
pub fn build(layout: &Layout) -> Result<AdcFrame, FirmwareError> {
    check_tools()?;
    let frame = write_frames(layout)?;
    for target in [TARGET, TARGET_V8M] {
        let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
        cmd.args(["build", "--release", "--quiet", "--target", target])
            .current_dir(layout.firmware())
            .env("DBE_FW_FRAMES", layout.frames_dir())
            .env("CARGO_ENCODED_RUSTFLAGS", firmware_rustflags(&layout.repo))
            // The host build's settings must not leak into the cross build.
            .env_remove("CARGO_TARGET_DIR")
            .env_remove("CARGO_BUILD_TARGET")
            .env_remove("RUSTFLAGS");
        run_command(cmd, Duration::from_secs(1800))?;
    }
    Ok(frame)
}

/// Rust flags of the firmware build, `\x1f`-separated for `CARGO_ENCODED_RUSTFLAGS` (which
/// replaces `firmware/.cargo/config.toml`'s, so the linker script is repeated here).
///
/// Panic locations embed source paths in the image, so the same commit built in two checkouts
/// would differ in flash size by a few bytes per path character. The repository and cargo's
/// home (registry sources) are remapped to fixed names, making the measured budget
/// independent of where the repository and cargo live.
pub fn firmware_rustflags(repo: &Path) -> String {
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")));
    let mut flags = vec![
        "-C".to_string(),
        "link-arg=-Tlink.x".to_string(),
        format!("--remap-path-prefix={}=/dbe-radar", repo.display()),
    ];
    if let Some(home) = cargo_home {
        flags.push(format!("--remap-path-prefix={}=/cargo", home.display()));
    }
    flags.join("\x1f")
}

/// Run the firmware image `image` (its build for the board's target) on `board`; its
/// standard output.
pub fn run(layout: &Layout, image: Image, board: Board) -> Result<String, FirmwareError> {
    let elf = layout.elf_for(image, board.target());
    if !elf.is_file() {
        return Err(FirmwareError::BadInput {
            path: elf,
            message: "firmware ELF missing: build it first (firmware::build)".into(),
        });
    }
    let mut cmd = Command::new(QEMU);
    cmd.args(board.qemu_args(&elf));
    run_command(cmd, RUN_TIMEOUT)
}
