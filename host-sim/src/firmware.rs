//! The firmware harness: build `firmware/` for the Cortex-M4F, run it under QEMU, read what it
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

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::fmt::Write as _;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use dbe_radar::FrameStats;
use rand::SeedableRng;

use crate::cloud::PointRecord;
use crate::core_run::{Chain, Preset};
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;
use crate::sim::Scatterer;

/// The firmware's Rust target.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// The QEMU system emulator for Arm.
pub const QEMU: &str = "qemu-system-arm";

/// First line of the generated block in `memory-layout.md`.
pub const BLOCK_BEGIN: &str = "<!-- budget:begin -->";

/// Last line of the generated block in `memory-layout.md`.
pub const BLOCK_END: &str = "<!-- budget:end -->";

/// The command that regenerates `docs/budget.json` and the block (printed in stale-check
/// messages and in the block itself).
pub const UPDATE_COMMAND: &str = "cargo run -p host-sim --example fw_budget";

/// Longest a single QEMU run may take before it is killed (a hung firmware).
const RUN_TIMEOUT: Duration = Duration::from_secs(600);

/// Seed of the simulated ColoRadar frame's noise.
const COLORADAR_SEED: u64 = 5;

/// What can go wrong while building, running or measuring the firmware.
#[derive(Debug, thiserror::Error)]
pub enum FirmwareError {
    /// A tool the harness needs is not installed.
    #[error("{tool} is not available: {hint}")]
    ToolMissing {
        /// The tool (`qemu-system-arm`, the `thumbv7em-none-eabihf` target, …).
        tool: String,
        /// How to install it.
        hint: String,
    },
    /// A file could not be read or written.
    #[error("{}: cannot {op}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was attempted.
        op: &'static str,
        /// The cause.
        source: std::io::Error,
    },
    /// An input file has the wrong size or content.
    #[error("{}: {message}", path.display())]
    BadInput {
        /// The file.
        path: PathBuf,
        /// What was expected.
        message: String,
    },
    /// A command failed.
    #[error("`{command}` failed ({status}):\n{stderr}")]
    Command {
        /// The command line.
        command: String,
        /// Exit status, or "timed out".
        status: String,
        /// The tail of its standard error.
        stderr: String,
    },
    /// The firmware's output is not what it prints on success.
    #[error("firmware output, line {line}: {message}")]
    Output {
        /// 1-based line number (0: the output as a whole).
        line: usize,
        /// What was expected.
        message: String,
    },
    /// The ELF lacks a section or symbol the budget needs.
    #[error("{}: {message}", path.display())]
    Elf {
        /// The ELF file.
        path: PathBuf,
        /// What is missing or malformed.
        message: String,
    },
    /// The TI capture could not be read.
    #[error(transparent)]
    Read(#[from] crate::io::IoError),
    /// The simulator could not render the ColoRadar frame.
    #[error("simulating the ColoRadar frame: {0}")]
    Simulation(String),
    /// `memory-layout.md` has no well-formed budget block.
    #[error("{}: {message}", path.display())]
    Block {
        /// The Markdown file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

fn io_err(path: &Path, op: &'static str) -> impl FnOnce(std::io::Error) -> FirmwareError {
    let path = path.to_path_buf();
    move |source| FirmwareError::Io { path, op, source }
}

/// A QEMU board the firmware runs on. Both have 4 MiB of code SSRAM at 0 and 4 MiB of data
/// SSRAM at `0x2000_0000` (see `firmware/memory.x`), so one image runs on either.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Board {
    /// MPS2 AN386, Cortex-M4F: the board the budget is measured on.
    An386,
    /// MPS2 AN500, Cortex-M7.
    An500,
}

impl Board {
    /// QEMU's `-machine` name.
    pub const fn machine(self) -> &'static str {
        match self {
            Board::An386 => "mps2-an386",
            Board::An500 => "mps2-an500",
        }
    }

    /// QEMU's `-cpu` name.
    pub const fn cpu(self) -> &'static str {
        match self {
            Board::An386 => "cortex-m4",
            Board::An500 => "cortex-m7",
        }
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

    /// Where the simulated ColoRadar frame is written for `build.rs`.
    pub fn coloradar_frame_file(&self) -> PathBuf {
        self.firmware()
            .join("target")
            .join("frames")
            .join("coloradar.frame")
    }

    /// The firmware ELF of `image`.
    pub fn elf(&self, image: Image) -> PathBuf {
        self.firmware()
            .join("target")
            .join(TARGET)
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
    let has_target = sysroot.is_some_and(|s| s.join("lib/rustlib").join(TARGET).is_dir());
    if !has_target {
        return Err(FirmwareError::ToolMissing {
            tool: format!("the {TARGET} Rust target"),
            hint: format!("rustup target add {TARGET}"),
        });
    }
    Ok(())
}

/// First line of `program --version`-style output, or "unknown".
fn version_line(program: &str, args: &[&str], dir: &Path) -> String {
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
// Frames

/// The scatterers of the simulated ColoRadar frame: `(range m, azimuth °, elevation °, range
/// rate m/s, amplitude LSB)`, each moving radially. Chosen to exercise every stage: static and moving targets (the
/// moving ones need TDM compensation), both azimuth signs up to 50°, elevations from −10° to
/// +12°, ranges from 3 m to 12 m.
pub const COLORADAR_SCATTERERS: [(f64, f64, f64, f64, f64); 6] = [
    (3.0, 12.0, 6.0, 0.0, 300.0),
    (5.2, -25.0, -10.0, 1.5, 300.0),
    (6.5, 0.0, 0.0, -0.7, 500.0),
    (7.9, 35.0, 3.0, -1.5, 300.0),
    (10.5, -5.0, 12.0, 0.0, 300.0),
    (12.0, 50.0, -5.0, 2.0, 200.0),
];

/// Noise standard deviation of the simulated frame, LSB on I and on Q.
pub const COLORADAR_NOISE_STD: f64 = 5.0;

/// The simulated ColoRadar frame the firmware embeds: [`COLORADAR_SCATTERERS`] (random phases)
/// in white noise of [`COLORADAR_NOISE_STD`], rendered by [`crate::sim::try_render_frame`]
/// from a fixed seed. Same inputs, same frame.
pub fn coloradar_frame() -> Result<AdcFrame, FirmwareError> {
    use rand::Rng;
    let sensor = SensorConfig::coloradar();
    let mut rng = rand::rngs::StdRng::seed_from_u64(COLORADAR_SEED);
    let scatterers: Vec<Scatterer> = COLORADAR_SCATTERERS
        .iter()
        .map(|&(range, az_deg, el_deg, range_rate, amplitude)| {
            // Spec §2 angles: μ = sin φ·cos θ (towards −y), ν = sin θ.
            let (phi, theta) = (az_deg.to_radians(), el_deg.to_radians());
            let (mu, nu) = (phi.sin() * theta.cos(), theta.sin());
            let u = [(1.0 - mu * mu - nu * nu).sqrt(), -mu, nu];
            Scatterer {
                position: u.map(|c| range * c),
                velocity: u.map(|c| range_rate * c),
                amplitude,
                phase: rng.gen::<f64>() * std::f64::consts::TAU,
            }
        })
        .collect();
    crate::sim::try_render_frame(&sensor, &scatterers, COLORADAR_NOISE_STD, &mut rng)
        .map_err(|e| FirmwareError::Simulation(e.to_string()))
}

/// The TI DCA1000 capture (one frame) as an [`AdcFrame`] of the IWR6843 fixture's sizes.
pub fn iwr6843_frame(capture: &Path) -> Result<AdcFrame, FirmwareError> {
    let mut frames = crate::io::read_dca1000(capture, &SensorConfig::iwr6843_fixture())?;
    match (frames.pop(), frames.is_empty()) {
        (Some(frame), true) => Ok(frame),
        _ => Err(FirmwareError::BadInput {
            path: capture.to_path_buf(),
            message: format!("expected one frame, found {}", frames.len() + 1),
        }),
    }
}

/// The frame's bytes as the firmware embeds them: `AdcFrame` order, int16 LE, I then Q.
pub fn frame_bytes(frame: &AdcFrame) -> Vec<u8> {
    frame
        .data
        .iter()
        .flat_map(|[i, q]| {
            let (i, q) = (i.to_le_bytes(), q.to_le_bytes());
            [i[0], i[1], q[0], q[1]]
        })
        .collect()
}

/// Write the simulated ColoRadar frame ([`coloradar_frame`]) to `path` for `build.rs`, unless
/// the file already holds it (then the firmware is not rebuilt). Returns the frame.
pub fn write_coloradar_frame(path: &Path) -> Result<AdcFrame, FirmwareError> {
    let frame = coloradar_frame()?;
    write_if_changed(path, &frame_bytes(&frame))?;
    Ok(frame)
}

/// Write `bytes` to `path` unless it already holds them (an unchanged file keeps its mtime,
/// so cargo does not rebuild the firmware); written through a temporary and a rename.
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<(), FirmwareError> {
    if std::fs::read(path).is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io_err(dir, "create directory"))?;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(io_err(&tmp, "write"))?;
    std::fs::rename(&tmp, path).map_err(io_err(path, "rename into place"))
}

// ---------------------------------------------------------------------------------------------
// Build and run

/// Run `cmd`, killing it after `timeout`; its stdout on success.
fn run_command(mut cmd: Command, timeout: Duration) -> Result<String, FirmwareError> {
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

/// Write the ColoRadar frame where `build.rs` reads it and build every firmware binary
/// (`cargo build --release` in `firmware/`). Returns the frame that was embedded.
pub fn build(layout: &Layout) -> Result<AdcFrame, FirmwareError> {
    check_tools()?;
    let capture = layout.iwr6843_capture();
    if !capture.is_file() {
        return Err(FirmwareError::BadInput {
            path: capture,
            message: "the TI fixture is missing (../shared beside the repository)".into(),
        });
    }
    let file = layout.coloradar_frame_file();
    let frame = write_coloradar_frame(&file)?;
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.args(["build", "--release", "--quiet"])
        .current_dir(layout.firmware())
        .env("DBE_FW_COLORADAR_FRAME", &file)
        .env("DBE_SHARED_DIR", &layout.shared)
        .env("CARGO_ENCODED_RUSTFLAGS", firmware_rustflags(&layout.repo))
        // The host build's settings must not leak into the cross build.
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS");
    run_command(cmd, Duration::from_secs(1800))?;
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

/// Run the firmware image `image` on `board`; its standard output.
pub fn run(layout: &Layout, image: Image, board: Board) -> Result<String, FirmwareError> {
    let elf = layout.elf(image);
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

// ---------------------------------------------------------------------------------------------
// Output

/// One CFAR detection as the firmware printed it (`D` line): the core's
/// [`dbe_radar::Detection`], whose `column` is the azimuth bin (DBE chain) or the natural
/// Doppler FFT bin (FFT chain).
pub type FwDetection = dbe_radar::Detection;

/// Everything one firmware run printed.
#[derive(Clone, Debug, PartialEq)]
pub struct FirmwareRun {
    /// Preset name (the core preset: `coloradar`, `iwr6843`).
    pub preset: String,
    /// The chain that ran: the header's `chain` field (`fft`), DBE when absent.
    pub chain: Chain,
    /// `(samples, loops, tx, rx)`.
    pub sizes: (usize, usize, usize, usize),
    /// Instructions per tick of the instruction clock, from the calibration.
    pub instructions_per_tick: u64,
    /// CFAR detections (`D` lines): on the range–azimuth map (DBE chain) or the range–Doppler
    /// map (FFT chain).
    pub detections: Vec<FwDetection>,
    /// Points (`P` lines), `f32` values widened exactly to `f64`.
    pub points: Vec<PointRecord>,
    /// Frame statistics.
    pub stats: FrameStats,
    /// Instructions per stage (DBE: `range_fft_per_chirp`, `ingest`, `azimuth_capon`, `cfar`,
    /// `elevation_doppler`, `process`, `total`, `setup`, …; FFT: `doppler_fft`, `rd_cfar` and
    /// `angles` instead of the three DBE stages).
    pub stages: BTreeMap<String, u64>,
    /// Stack peak up to and including the chain's setup, bytes.
    pub stack_setup: u64,
    /// Stack peak of the per-frame work (ingest + process) after setup, bytes.
    pub stack_frame: u64,
}

fn field<T: std::str::FromStr>(
    tokens: &[&str],
    i: usize,
    line: usize,
    what: &str,
) -> Result<T, FirmwareError> {
    tokens
        .get(i)
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| FirmwareError::Output {
            line,
            message: format!("expected {what} as field {i}, got {:?}", tokens.get(i)),
        })
}

/// A point line (`P`): ten fields after the tag.
fn parse_point(t: &[&str], line: usize) -> Result<PointRecord, FirmwareError> {
    if t.len() != 11 {
        return Err(FirmwareError::Output {
            line,
            message: format!("a point line has 11 fields, this one {}", t.len()),
        });
    }
    let f = |i: usize, what: &str| field::<f32>(t, i, line, what).map(f64::from);
    Ok(PointRecord {
        range_bin: field(t, 1, line, "range bin")?,
        azimuth_bin: field(t, 2, line, "azimuth bin")?,
        elevation_bin: field(t, 3, line, "elevation bin")?,
        doppler_bin: field(t, 4, line, "Doppler bin")?,
        x: f(5, "x")?,
        y: f(6, "y")?,
        z: f(7, "z")?,
        doppler: f(8, "velocity")?,
        intensity_db: f(9, "power dB")?,
        snr_db: f(10, "SNR dB")?,
    })
}

/// Parse the firmware's output (format: `firmware/src/lib.rs`). Fails unless the run printed
/// its header (with its `chain`), calibration, statistics and stages and ended with `E ok`.
pub fn parse_output(text: &str) -> Result<FirmwareRun, FirmwareError> {
    let mut run = FirmwareRun {
        preset: String::new(),
        chain: Chain::Dbe,
        sizes: (0, 0, 0, 0),
        instructions_per_tick: 0,
        detections: Vec::new(),
        points: Vec::new(),
        stats: FrameStats::default(),
        stages: BTreeMap::new(),
        stack_setup: 0,
        stack_frame: 0,
    };
    let (mut header, mut stats, mut end) = (false, false, false);
    for (idx, raw) in text.lines().enumerate() {
        let line = idx + 1;
        let t: Vec<&str> = raw.split_whitespace().collect();
        let f = |i: usize, what: &str| field::<f32>(&t, i, line, what);
        let tag = t.first().copied();
        match tag {
            None => {}
            Some("H") => {
                let named = |key: &str| -> Result<usize, FirmwareError> {
                    let pos = t
                        .iter()
                        .position(|x| *x == key)
                        .ok_or(FirmwareError::Output {
                            line,
                            message: format!("header lacks `{key}`"),
                        })?;
                    field(&t, pos + 1, line, key)
                };
                run.preset = field(&t, 2, line, "preset name")?;
                run.chain = match t.iter().position(|x| *x == "chain") {
                    None => {
                        return Err(FirmwareError::Output {
                            line,
                            message: "header lacks `chain`".to_string(),
                        })
                    }
                    Some(pos) => match t.get(pos + 1).copied() {
                        Some("dbe") => Chain::Dbe,
                        Some("fft") => Chain::Fft,
                        other => {
                            return Err(FirmwareError::Output {
                                line,
                                message: format!("unknown chain {other:?} (dbe, fft)"),
                            })
                        }
                    },
                };
                run.sizes = (
                    named("samples")?,
                    named("loops")?,
                    named("tx")?,
                    named("rx")?,
                );
                header = true;
            }
            Some("C") => {
                let instructions: u64 = field(&t, 1, line, "calibration instructions")?;
                let ticks: u64 = field(&t, 2, line, "calibration ticks")?;
                run.instructions_per_tick = field(&t, 3, line, "instructions per tick")?;
                // Two readings, each ±1 tick: the ratio must be the printed integer.
                let per = run.instructions_per_tick;
                if per == 0 || instructions.abs_diff(per * ticks) > 2 * per {
                    return Err(FirmwareError::Output {
                        line,
                        message: format!(
                            "calibration: {instructions} instructions in {ticks} ticks is not \
                             {per} per tick"
                        ),
                    });
                }
            }
            Some("D") => run.detections.push(FwDetection {
                range_bin: field(&t, 1, line, "range bin")?,
                column: field(&t, 2, line, "column")?,
                power: f(3, "power")?,
                level: f(4, "level")?,
            }),
            Some("P") => run.points.push(parse_point(&t, line)?),
            Some("F") => {
                run.stats = FrameStats {
                    detections: field(&t, 1, line, "detections")?,
                    detection_overflow: field(&t, 2, line, "detection overflow")?,
                    points: field(&t, 3, line, "points")?,
                    point_overflow: field(&t, 4, line, "point overflow")?,
                    skipped_range_bins: field(&t, 5, line, "skipped range bins")?,
                    detections_without_point: field(&t, 6, line, "detections without point")?,
                };
                stats = true;
            }
            Some("S") => {
                let name: String = field(&t, 1, line, "stage name")?;
                let instructions: u64 = field(&t, 2, line, "instructions")?;
                run.stages.insert(name, instructions);
            }
            Some("M") => {
                let bytes: u64 = field(&t, 2, line, "bytes")?;
                match t.get(1).copied() {
                    Some("stack_setup") => run.stack_setup = bytes,
                    Some("stack_frame") => run.stack_frame = bytes,
                    other => {
                        return Err(FirmwareError::Output {
                            line,
                            message: format!("unknown memory figure {other:?}"),
                        })
                    }
                }
            }
            Some("E") => end = t.get(1) == Some(&"ok"),
            Some("X") => {
                return Err(FirmwareError::Output {
                    line,
                    message: format!("the firmware failed: {}", t[1..].join(" ")),
                })
            }
            // Anything else (a panic message, QEMU's own chatter) is not the firmware's format.
            Some(_) => {
                return Err(FirmwareError::Output {
                    line,
                    message: format!("unexpected line {raw:?}"),
                })
            }
        }
    }
    let missing = [
        (header, "the header (H)"),
        (run.instructions_per_tick > 0, "the calibration (C)"),
        (stats, "the frame statistics (F)"),
        (run.stages.contains_key("total"), "the stage costs (S)"),
        (run.stack_frame > 0, "the stack peaks (M)"),
        (end, "the end marker (E ok)"),
    ];
    if let Some((_, what)) = missing.iter().find(|(ok, _)| !ok) {
        return Err(FirmwareError::Output {
            line: 0,
            message: format!("no {what}; the run was cut short"),
        });
    }
    let detections = run.detections.len();
    if run.points.len() != run.stats.points as usize || detections != run.stats.detections as usize
    {
        return Err(FirmwareError::Output {
            line: 0,
            message: format!(
                "{} points and {} detections printed, statistics say {} and {}",
                run.points.len(),
                detections,
                run.stats.points,
                run.stats.detections
            ),
        });
    }
    Ok(run)
}

// ---------------------------------------------------------------------------------------------
// ELF

/// One named static buffer of the firmware image.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Buffer {
    /// The `static`'s name in the firmware (`CUBE`, `WORKSPACE`, …; `other` for the rest).
    pub symbol: String,
    /// What it holds.
    pub what: String,
    /// Section (`.bss`, `.data`).
    pub section: String,
    /// Bytes.
    pub bytes: u64,
}

/// Memory of one firmware image, from its ELF.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ElfMemory {
    /// Section sizes of the allocated sections, bytes.
    pub sections: BTreeMap<String, u64>,
    /// Static RAM by buffer (every `.data`/`.bss` byte is in exactly one entry).
    pub buffers: Vec<Buffer>,
    /// Bytes of the embedded test frame (`FRAME` in `.rodata`).
    pub frame_bytes: u64,
}

impl ElfMemory {
    fn section(&self, name: &str) -> u64 {
        self.sections.get(name).copied().unwrap_or(0)
    }

    /// `.data + .bss + .uninit`.
    pub fn static_ram(&self) -> u64 {
        self.section(".data") + self.section(".bss") + self.section(".uninit")
    }

    /// What the image puts in code memory besides the test frame: vector table, `.text`,
    /// `.rodata` without the frame, and the initial values of `.data`.
    pub fn flash(&self) -> u64 {
        self.section(".vector_table") + self.section(".text") + self.section(".rodata")
            - self.frame_bytes
            + self.section(".data")
    }
}

/// The statics every image names (`firmware/src/lib.rs`, `image!`), and what they hold.
const STATICS: [(&str, &str); 6] = [
    ("CUBE", "radar cube (`CubeStorage`)"),
    (
        "WORKSPACE",
        "the chain's workspace: range bin in flight, map (DBE: range–azimuth, FFT: range–Doppler), CFAR",
    ),
    (
        "CHAIN",
        "the chain: tables and parameters (DBE: steering tables; FFT: twiddles, beamscan table)",
    ),
    (
        "FRONTEND",
        "`Frontend`: range window, coupling table, array layout",
    ),
    ("CLOUD", "`PointCloud`"),
    ("DMA_CHIRP", "one-chirp DMA buffer"),
];

/// The statics an image names, and what they hold (the same for both chains).
pub const fn named_statics() -> &'static [(&'static str, &'static str)] {
    &STATICS
}

/// The name a legacy-mangled Rust symbol ends with (`_ZN…4CUBE17h…E` → `CUBE`).
fn static_name(mangled: &str) -> Option<&str> {
    let mut rest = mangled.strip_prefix("_ZN")?;
    let mut parts = Vec::new();
    while let Some(first) = rest.chars().next() {
        if !first.is_ascii_digit() {
            break;
        }
        let digits = rest.chars().take_while(char::is_ascii_digit).count();
        let len: usize = rest[..digits].parse().ok()?;
        let ident = rest.get(digits..digits + len)?;
        parts.push(ident);
        rest = &rest[digits + len..];
    }
    // The last component is the hash `h0123…`.
    match parts.as_slice() {
        [.., name, hash] if hash.starts_with('h') => Some(name),
        [.., name] => Some(name),
        [] => None,
    }
}

/// Sections and named buffers ([`named_statics`]) of the firmware ELF at `path`.
pub fn elf_memory(path: &Path) -> Result<ElfMemory, FirmwareError> {
    let named_statics = named_statics();
    use object::{Object, ObjectSection, ObjectSymbol};
    let data = std::fs::read(path).map_err(io_err(path, "read the firmware ELF"))?;
    let bad = |message: String| FirmwareError::Elf {
        path: path.to_path_buf(),
        message,
    };
    let file = object::File::parse(&*data).map_err(|e| bad(format!("not an ELF: {e}")))?;
    let mut sections = BTreeMap::new();
    let mut index_name = BTreeMap::new();
    for s in file.sections() {
        let name = s.name().map_err(|e| bad(e.to_string()))?.to_string();
        if [
            ".vector_table",
            ".text",
            ".rodata",
            ".data",
            ".bss",
            ".uninit",
        ]
        .contains(&name.as_str())
        {
            sections.insert(name.clone(), s.size());
        }
        index_name.insert(s.index().0, name);
    }
    for needed in [".vector_table", ".text", ".bss"] {
        if !sections.contains_key(needed) {
            return Err(bad(format!("no {needed} section: not a cortex-m-rt image")));
        }
    }
    let mut named: BTreeMap<&str, Buffer> = BTreeMap::new();
    let mut frame_bytes = 0;
    for sym in file.symbols() {
        let Some(section) = sym.section_index().and_then(|i| index_name.get(&i.0)) else {
            continue;
        };
        let Some(name) = sym.name().ok().and_then(static_name) else {
            continue;
        };
        if section == ".rodata" && name == "FRAME" {
            frame_bytes = sym.size();
        }
        if section != ".data" && section != ".bss" {
            continue;
        }
        if let Some((symbol, what)) = named_statics.iter().find(|(s, _)| *s == name) {
            named.insert(
                symbol,
                Buffer {
                    symbol: (*symbol).into(),
                    what: (*what).into(),
                    section: section.clone(),
                    bytes: sym.size(),
                },
            );
        }
    }
    if frame_bytes == 0 {
        return Err(bad(
            "no FRAME symbol in .rodata (the embedded test frame)".into()
        ));
    }
    let mut buffers: Vec<Buffer> = named_statics
        .iter()
        .filter_map(|(s, _)| named.remove(s))
        .collect();
    if buffers.len() != named_statics.len() {
        let found: Vec<&str> = buffers.iter().map(|b| b.symbol.as_str()).collect();
        let expected: Vec<&str> = named_statics.iter().map(|(s, _)| *s).collect();
        return Err(bad(format!(
            "expected the statics {expected:?}, found {found:?}"
        )));
    }
    let memory = ElfMemory {
        sections,
        buffers: Vec::new(),
        frame_bytes,
    };
    let named_total: u64 = buffers.iter().map(|b| b.bytes).sum();
    buffers.push(Buffer {
        symbol: "other".into(),
        what: "everything else (runtime, semihosting, alignment)".into(),
        section: ".data/.bss".into(),
        bytes: memory.static_ram().saturating_sub(named_total),
    });
    Ok(ElfMemory { buffers, ..memory })
}

// ---------------------------------------------------------------------------------------------
// Budget

/// Largest flash difference [`stale`] treats as the same build. Source paths are remapped
/// ([`firmware_rustflags`]), but cargo's crate hashes still include the checkout's path, and
/// they change the linker's function order and so a few bytes of alignment padding: 8 bytes
/// measured between two checkouts of one commit. Any real code change moves the instruction
/// counts or the static RAM too, which stay exact.
pub const FLASH_TOLERANCE_BYTES: u64 = 64;

/// The measured budget of every preset: the content of `docs/budget.json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Budget {
    /// How the numbers were obtained.
    pub method: String,
    /// The command that regenerates this file.
    pub command: String,
    /// QEMU board and CPU.
    pub board: String,
    /// `qemu-system-arm --version`, first line.
    pub qemu: String,
    /// `rustc -V` of the firmware build: instruction counts depend on the compiler.
    pub rustc: String,
    /// The firmware's release profile.
    pub profile: String,
    /// Instructions per tick of the instruction clock (calibrated).
    pub instructions_per_tick: u64,
    /// One entry per image ([`Image::ALL`] order): the DBE images, then the FFT ones.
    pub presets: Vec<PresetBudget>,
}

/// The measured budget of one image (a preset and a chain).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PresetBudget {
    /// The image's name ([`Image::name`]: `coloradar`, `iwr6843`, `coloradar-fft`,
    /// `iwr6843-fft`).
    pub preset: String,
    /// The chain it runs ([`chain_name`]: `dbe`, `fft`).
    pub chain: String,
    /// The frame processed.
    pub frame: String,
    /// Detections and points of that frame (context for the per-detection stages).
    pub detections: u32,
    /// Points of that frame.
    pub points: u32,
    /// Static RAM (`.data + .bss`), bytes.
    pub static_ram_bytes: u64,
    /// Static RAM by buffer.
    pub buffers: Vec<Buffer>,
    /// Stack peak over the whole run, bytes.
    pub stack_peak_bytes: u64,
    /// Stack peak up to and including the setup (`Frontend::configure` + the chain's
    /// `configure`), bytes.
    pub stack_peak_setup_bytes: u64,
    /// Stack peak of one frame (ingest + process) after setup, bytes.
    pub stack_peak_frame_bytes: u64,
    /// `static_ram_bytes + stack_peak_bytes`.
    pub ram_total_bytes: u64,
    /// Code memory without the embedded test frame: vector table + `.text` + `.rodata` +
    /// `.data` initial values, bytes.
    pub flash_bytes: u64,
    /// The embedded test frame (test input in `.rodata`, not part of a product image), bytes.
    pub embedded_frame_bytes: u64,
    /// `instructions_per_stage["total"]`: ingest + process of one frame.
    pub instructions_per_frame: u64,
    /// Instructions per stage.
    pub instructions_per_stage: BTreeMap<String, u64>,
}

impl PresetBudget {
    /// Combine the output and the ELF of `image`.
    pub fn new(image: Image, run: &FirmwareRun, elf: &ElfMemory, frame: &str) -> Self {
        let stack_peak = run.stack_setup.max(run.stack_frame);
        Self {
            preset: image.name().into(),
            chain: chain_name(image.chain).into(),
            frame: frame.into(),
            detections: run.stats.detections,
            points: run.stats.points,
            static_ram_bytes: elf.static_ram(),
            buffers: elf.buffers.clone(),
            stack_peak_bytes: stack_peak,
            stack_peak_setup_bytes: run.stack_setup,
            stack_peak_frame_bytes: run.stack_frame,
            ram_total_bytes: elf.static_ram() + stack_peak,
            flash_bytes: elf.flash(),
            embedded_frame_bytes: elf.frame_bytes,
            instructions_per_frame: run.stages.get("total").copied().unwrap_or(0),
            instructions_per_stage: run.stages.clone(),
        }
    }
}

/// What each preset's firmware processes.
fn frame_description(preset: Preset) -> String {
    match preset {
        Preset::ColoRadar => format!(
            "simulated (host_sim::firmware::coloradar_frame): {} point scatterers, noise σ = {} LSB",
            COLORADAR_SCATTERERS.len(),
            COLORADAR_NOISE_STD
        ),
        Preset::Iwr6843 => {
            "TI IWR6843 + DCA1000 capture, corner reflector (shared fixture)".to_string()
        }
    }
}

/// One measured image: the run's output and the budget entry.
#[derive(Clone, Debug)]
pub struct Measurement {
    /// The image.
    pub image: Image,
    /// What the firmware printed.
    pub run: FirmwareRun,
    /// Its budget entry.
    pub budget: PresetBudget,
}

/// Build the firmware, run every image on the AN386 and measure the budget. Also returns the
/// simulated ColoRadar frame that was embedded.
pub fn measure(layout: &Layout) -> Result<(Budget, Vec<Measurement>, AdcFrame), FirmwareError> {
    let frame = build(layout)?;
    let mut measurements = Vec::new();
    for image in Image::ALL {
        let text = run(layout, image, Board::An386)?;
        let run = parse_output(&text)?;
        let preset = image.preset;
        if run.preset != preset.name() || run.sizes != preset.sizes() || run.chain != image.chain {
            return Err(FirmwareError::Output {
                line: 1,
                message: format!(
                    "the {image} binary reports preset {} with sizes {:?}, chain {}",
                    run.preset,
                    run.sizes,
                    chain_name(run.chain)
                ),
            });
        }
        let elf = elf_memory(&layout.elf(image))?;
        let budget = PresetBudget::new(image, &run, &elf, &frame_description(preset));
        measurements.push(Measurement { image, run, budget });
    }
    let per_tick = measurements
        .first()
        .map_or(0, |m| m.run.instructions_per_tick);
    let fw = layout.firmware();
    let budget = Budget {
        method: "QEMU -icount shift=0,sleep=off (1 guest instruction = 1 ns of virtual time); \
                 stages timed with the MPS2 FPGA 25 MHz counter, calibrated against a delay \
                 loop of known length; static RAM and flash from the ELF; stack peak by \
                 painting"
            .into(),
        command: UPDATE_COMMAND.into(),
        board: format!("{} ({})", Board::An386.machine(), Board::An386.cpu()),
        qemu: version_line(QEMU, &["--version"], &fw),
        rustc: version_line("rustc", &["-V"], &fw),
        profile: "release: opt-level 3, fat LTO, codegen-units 1, panic abort".into(),
        instructions_per_tick: per_tick,
        presets: measurements.iter().map(|m| m.budget.clone()).collect(),
    };
    Ok((budget, measurements, frame))
}

/// `1234567` → `1,234,567`.
pub fn thousands(v: u64) -> String {
    let s = v.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// `bytes` in KiB or MiB with one decimal.
fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1024.0 * 1024.0 {
        format!("{:.2} MiB", b / (1024.0 * 1024.0))
    } else {
        format!("{:.1} KiB", b / 1024.0)
    }
}

/// Rows of an instruction table: stage keys and labels, then the stage whose cost is also
/// shown per detection (in a row right after it) and that row's label.
type StageRows = (
    &'static [(&'static str, &'static str)],
    &'static str,
    &'static str,
);

/// The DBE chain's instruction table.
const DBE_STAGES: StageRows = (
    &[
        (
            "range_fft_per_chirp",
            "range FFT per chirp (`push_chirp`, mean)",
        ),
        ("range_fft_chirp_max", "range FFT per chirp, worst"),
        ("ingest", "ingest: all K·TX chirps"),
        ("azimuth_capon", "azimuth covariances + Capon (stage 1)"),
        ("cfar", "OS-CFAR (stage 2)"),
        (
            "elevation_doppler",
            "TDM compensation + elevation + Doppler (stages 3–5)",
        ),
        ("process", "`process` (stages 1–5)"),
        ("total", "**per frame** (ingest + process)"),
        (
            "setup",
            "setup: `Frontend::configure` + `Dbe::configure` (once)",
        ),
    ],
    "elevation_doppler",
    "stages 3–5 per detection (÷ detections)",
);

/// The FFT chain's instruction table.
const FFT_STAGES: StageRows = (
    &[
        (
            "range_fft_per_chirp",
            "range FFT per chirp (`push_chirp`, mean)",
        ),
        ("range_fft_chirp_max", "range FFT per chirp, worst"),
        ("ingest", "ingest: all K·TX chirps"),
        (
            "doppler_fft",
            "Doppler FFTs + non-coherent sum, RD map (stage 1)",
        ),
        (
            "rd_cfar",
            "CA-CFAR + 3×3 local maximum on the RD map (stage 2)",
        ),
        (
            "angles",
            "Doppler bin + TDM compensation + beamscan + elevation (stage 3)",
        ),
        ("process", "`process` (stages 1–3)"),
        ("total", "**per frame** (ingest + process)"),
        (
            "setup",
            "setup: `Frontend::configure` + `FftChain::configure` (once)",
        ),
    ],
    "angles",
    "stage 3 per detection (÷ detections)",
);

/// One table row: its label and how to fill a column's cell.
type Row<'a> = (String, &'a dyn Fn(&PresetBudget) -> String);

/// One Markdown table: a header over `cols`, then one row per `(label, cell)`.
fn table(s: &mut String, first: &str, cols: &[&PresetBudget], rows: &[Row<'_>]) {
    let names: Vec<&str> = cols.iter().map(|p| p.preset.as_str()).collect();
    let _ = writeln!(s, "| {first} | {} |", names.join(" | "));
    let _ = writeln!(s, "|---|{}", "---:|".repeat(names.len()));
    for (label, f) in rows {
        let cells: Vec<String> = cols.iter().map(|p| f(p)).collect();
        let _ = writeln!(s, "| {label} | {} |", cells.join(" | "));
    }
}

/// The instruction table of `cols` (one chain's images) with `stages`' rows.
fn stage_table(s: &mut String, first: &str, cols: &[&PresetBudget], stages: StageRows) {
    let (rows, per_detection, per_detection_label) = stages;
    let cell = |key: &'static str| {
        move |p: &PresetBudget| {
            p.instructions_per_stage
                .get(key)
                .map_or("—".into(), |v| thousands(*v))
        }
    };
    let per_det = move |p: &PresetBudget| match (
        p.instructions_per_stage.get(per_detection),
        u64::from(p.detections),
    ) {
        (Some(v), d) if d > 0 => thousands(v / d),
        _ => "—".into(),
    };
    let cells: Vec<_> = rows.iter().map(|(key, _)| cell(key)).collect();
    let mut table_rows: Vec<Row<'_>> = Vec::new();
    for ((key, label), f) in rows.iter().zip(&cells) {
        table_rows.push(((*label).to_string(), f));
        if *key == per_detection {
            table_rows.push((per_detection_label.into(), &per_det));
        }
    }
    table(s, first, cols, &table_rows);
}

/// The Markdown tables of the budget block (without the marker lines).
pub fn render_markdown(budget: &Budget) -> String {
    let mut s = String::new();
    let all: Vec<&PresetBudget> = budget.presets.iter().collect();
    let of_chain = |chain: Chain| -> Vec<&PresetBudget> {
        all.iter()
            .copied()
            .filter(|p| p.chain == chain_name(chain))
            .collect()
    };
    let (dbe, fft) = (of_chain(Chain::Dbe), of_chain(Chain::Fft));
    let _ = writeln!(
        s,
        "Generated by `{}` from `docs/budget.json`; do not edit by hand.\n",
        budget.command
    );
    let _ = writeln!(
        s,
        "Measured on {} under {}, firmware built by {} ({}). Instruction counts are guest \
         instructions (QEMU `-icount shift=0,sleep=off`: 1 instruction = 1 ns of virtual time; \
         the MPS2 FPGA counter ticks every {} instructions, calibrated against a delay loop of \
         known length), not cycles.\n",
        budget.board, budget.qemu, budget.rustc, budget.profile, budget.instructions_per_tick
    );
    let _ = writeln!(
        s,
        "One image per preset and chain: `X` runs the DBE chain, `X-fft` the FFT baseline chain \
         on the same embedded frame (each measured on its own, so neither changes the other's \
         figures).\n"
    );
    for p in &budget.presets {
        let _ = writeln!(
            s,
            "- `{}`: {}; {} detections, {} points.",
            p.preset, p.frame, p.detections, p.points
        );
    }
    s.push('\n');

    // Every named buffer of any image, in first-seen order, `other` last.
    let mut symbols: Vec<(String, String)> = Vec::new();
    for b in all.iter().flat_map(|p| p.buffers.iter()) {
        if b.symbol != "other" && !symbols.iter().any(|(sym, _)| *sym == b.symbol) {
            symbols.push((b.symbol.clone(), b.what.clone()));
        }
    }
    if let Some(b) = all
        .iter()
        .flat_map(|p| p.buffers.iter())
        .find(|b| b.symbol == "other")
    {
        symbols.push((b.symbol.clone(), b.what.clone()));
    }
    let buffer_cells: Vec<_> = symbols
        .iter()
        .map(|(symbol, _)| {
            move |p: &PresetBudget| {
                p.buffers
                    .iter()
                    .find(|b| &b.symbol == symbol)
                    .map_or("—".into(), |b| thousands(b.bytes))
            }
        })
        .collect();
    let mut rows: Vec<Row<'_>> = symbols
        .iter()
        .zip(&buffer_cells)
        .map(|((symbol, what), f)| {
            (
                format!("`{symbol}`: {what}"),
                f as &dyn Fn(&PresetBudget) -> String,
            )
        })
        .collect();
    let static_ram = |p: &PresetBudget| format!("**{}**", thousands(p.static_ram_bytes));
    let setup = |p: &PresetBudget| thousands(p.stack_peak_setup_bytes);
    let frame = |p: &PresetBudget| thousands(p.stack_peak_frame_bytes);
    let ram = |p: &PresetBudget| {
        format!(
            "**{}** ({})",
            thousands(p.ram_total_bytes),
            human(p.ram_total_bytes)
        )
    };
    let flash = |p: &PresetBudget| {
        format!(
            "**{}** ({})",
            thousands(p.flash_bytes),
            human(p.flash_bytes)
        )
    };
    let embedded = |p: &PresetBudget| thousands(p.embedded_frame_bytes);
    rows.push(("**static RAM** (`.data` + `.bss`)".into(), &static_ram));
    rows.push((
        "stack peak, setup (`Frontend::configure` + the chain's `configure`)".into(),
        &setup,
    ));
    rows.push(("stack peak, one frame (ingest + process)".into(), &frame));
    rows.push(("**RAM total** (static + stack peak)".into(), &ram));
    rows.push((
        "**flash** (vectors + `.text` + `.rodata` + `.data` image, without the test frame)".into(),
        &flash,
    ));
    rows.push((
        "embedded test frame (`.rodata`, test input only)".into(),
        &embedded,
    ));
    table(&mut s, "memory (bytes)", &all, &rows);
    s.push('\n');

    // Both chains on one cube: a DBE image plus the FFT chain's own statics (derived).
    let both: Vec<String> = dbe
        .iter()
        .filter_map(|d| {
            let f = fft
                .iter()
                .find(|f| f.preset == format!("{}-fft", d.preset))?;
            let own: u64 = f
                .buffers
                .iter()
                .filter(|b| b.symbol == "CHAIN" || b.symbol == "WORKSPACE")
                .map(|b| b.bytes)
                .sum();
            Some(format!(
                "`{}` + {} = {} bytes of static RAM, a frame {} + {} = {} instructions",
                d.preset,
                thousands(own),
                thousands(d.static_ram_bytes + own),
                thousands(d.instructions_per_frame),
                thousands(
                    f.instructions_per_stage
                        .get("process")
                        .copied()
                        .unwrap_or(0)
                ),
                thousands(
                    d.instructions_per_frame
                        + f.instructions_per_stage
                            .get("process")
                            .copied()
                            .unwrap_or(0)
                )
            ))
        })
        .collect();
    if !both.is_empty() {
        let _ = writeln!(
            s,
            "Both chains on one cube (derived from the rows above, not measured as one image): \
             the DBE image plus the FFT image's `CHAIN` + `WORKSPACE`, and the FFT chain's `process` \
             on the cube the DBE chain ingested: {}.\n",
            both.join("; ")
        );
    }

    if !dbe.is_empty() {
        stage_table(&mut s, "instructions, DBE chain", &dbe, DBE_STAGES);
    }
    if !fft.is_empty() {
        s.push('\n');
        stage_table(&mut s, "instructions, FFT chain", &fft, FFT_STAGES);
    }
    s
}

/// `doc` with the text between the [`BLOCK_BEGIN`] and [`BLOCK_END`] lines replaced by
/// `block`. `path` names the document in errors.
pub fn splice_block(doc: &str, block: &str, path: &Path) -> Result<String, FirmwareError> {
    let bad = |message: &str| FirmwareError::Block {
        path: path.to_path_buf(),
        message: message.into(),
    };
    let begin = doc
        .find(BLOCK_BEGIN)
        .ok_or_else(|| bad("no `<!-- budget:begin -->` line"))?;
    let body = begin + BLOCK_BEGIN.len();
    let end = doc[body..]
        .find(BLOCK_END)
        .map(|e| body + e)
        .ok_or_else(|| bad("no `<!-- budget:end -->` line after `<!-- budget:begin -->`"))?;
    if doc[end + BLOCK_END.len()..].contains(BLOCK_BEGIN) {
        return Err(bad("more than one budget block"));
    }
    Ok(format!(
        "{}\n{}{}",
        &doc[..body],
        block.trim_end_matches('\n').to_owned() + "\n",
        &doc[end..]
    ))
}

/// Read `docs/budget.json`.
pub fn read_budget(path: &Path) -> Result<Budget, FirmwareError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path, "read"))?;
    serde_json::from_str(&text).map_err(|e| FirmwareError::BadInput {
        path: path.to_path_buf(),
        message: format!("not a budget file: {e}"),
    })
}

/// `budget` as `docs/budget.json` holds it (pretty JSON, trailing newline).
pub fn budget_json(budget: &Budget) -> String {
    let mut s = serde_json::to_string_pretty(budget).unwrap_or_default();
    s.push('\n');
    s
}

/// Write `docs/budget.json` and the block of `memory-layout.md`; returns the files changed.
pub fn write_budget(layout: &Layout, budget: &Budget) -> Result<Vec<PathBuf>, FirmwareError> {
    let mut changed = Vec::new();
    let json = layout.budget_json();
    let text = budget_json(budget);
    if std::fs::read_to_string(&json).ok().as_deref() != Some(text.as_str()) {
        write_if_changed(&json, text.as_bytes())?;
        changed.push(json);
    }
    let md = layout.memory_layout();
    let doc = std::fs::read_to_string(&md).map_err(io_err(&md, "read"))?;
    let new = splice_block(&doc, &render_markdown(budget), &md)?;
    if new != doc {
        write_if_changed(&md, new.as_bytes())?;
        changed.push(md);
    }
    Ok(changed)
}

/// Differences between the committed budget and a measured one, one line each; empty when
/// `docs/budget.json` and the block are up to date.
pub fn stale(layout: &Layout, measured: Option<&Budget>) -> Result<Vec<String>, FirmwareError> {
    let mut problems = Vec::new();
    let json = layout.budget_json();
    let committed = match read_budget(&json) {
        Ok(b) => Some(b),
        Err(e) => {
            problems.push(e.to_string());
            None
        }
    };
    // Flash within FLASH_TOLERANCE_BYTES of the committed figure is the same build laid out
    // differently (see the constant); compare everything else exactly.
    let adjusted = measured.map(|m| {
        let mut m = m.clone();
        if let Some(old) = committed.as_ref() {
            for (p, q) in m.presets.iter_mut().zip(old.presets.iter()) {
                if p.preset == q.preset
                    && p.flash_bytes.abs_diff(q.flash_bytes) <= FLASH_TOLERANCE_BYTES
                {
                    p.flash_bytes = q.flash_bytes;
                }
            }
        }
        m
    });
    let measured = adjusted.as_ref();
    if let (Some(old), Some(new)) = (committed.as_ref(), measured) {
        let (a, b) = (budget_json(old), budget_json(new));
        for (i, (x, y)) in a.lines().zip(b.lines()).enumerate() {
            if x != y {
                problems.push(format!(
                    "{}:{}: committed `{}`, measured `{}`",
                    json.display(),
                    i + 1,
                    x.trim(),
                    y.trim()
                ));
            }
        }
        if a.lines().count() != b.lines().count() {
            problems.push(format!(
                "{}: {} lines committed, {} measured",
                json.display(),
                a.lines().count(),
                b.lines().count()
            ));
        }
    }
    if let Some(budget) = measured.or(committed.as_ref()) {
        let md = layout.memory_layout();
        let doc = std::fs::read_to_string(&md).map_err(io_err(&md, "read"))?;
        if splice_block(&doc, &render_markdown(budget), &md)? != doc {
            problems.push(format!(
                "{}: the budget block differs from {}",
                md.display(),
                if measured.is_some() {
                    "the measurement"
                } else {
                    "docs/budget.json"
                }
            ));
        }
    }
    Ok(problems)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str =
        "H preset iwr6843 chain dbe samples 256 loops 64 tx 3 rx 4 azimuth_bins 188 elevation_bins 101
C 40000000 1000001 40
D 38 88 1.5e6 2.5e4
P 38 88 47 0 3.6975238 0.26627824 -0.097073816 0 97.3333 15.095507
F 1 0 1 0 0 0
S ingest 18623621 465591
S total 67931052 1698278
M stack_setup 62004
M stack_frame 11192
E ok
";

    #[test]
    fn parses_a_complete_run() {
        let run = parse_output(GOOD).expect("a complete run parses");
        assert_eq!(run.preset, "iwr6843");
        assert_eq!(run.chain, Chain::Dbe);
        assert_eq!(run.sizes, (256, 64, 3, 4));
        assert_eq!(run.instructions_per_tick, 40);
        assert_eq!(run.points.len(), 1);
        assert_eq!(run.points[0].x, f64::from(3.697_523_8_f32));
        assert_eq!(run.points[0].elevation_bin, 47);
        assert_eq!(run.stages["total"], 67_931_052);
        assert_eq!((run.stack_setup, run.stack_frame), (62_004, 11_192));
    }

    const GOOD_FFT: &str =
        "H preset coloradar chain fft samples 128 loops 128 tx 3 rx 4 azimuth_bins 188 elevation_bins 101
C 40000000 1000000 40
D 24 0 12385211000000 1538180
P 24 109 62 0 2.919707 -0.602998 0.3132604 0 130.92903 69.05896
F 1 0 1 0 0 0
S ingest 27944560 698614
S total 48416080 1210402
M stack_setup 60380
M stack_frame 3768
E ok
";

    #[test]
    fn parses_an_fft_run_and_requires_the_chain() {
        let run = parse_output(GOOD_FFT).expect("a complete FFT run parses");
        assert_eq!((run.preset.as_str(), run.chain), ("coloradar", Chain::Fft));
        assert_eq!(
            run.detections,
            vec![FwDetection {
                range_bin: 24,
                column: 0,
                power: 12_385_211_000_000.0,
                level: 1_538_180.0,
            }]
        );
        assert_eq!(run.points.len(), 1);
        assert_eq!(run.points[0].z, f64::from(0.313_260_4_f32));
        let unknown = GOOD_FFT.replace("chain fft", "chain music");
        assert!(matches!(
            parse_output(&unknown),
            Err(FirmwareError::Output { line: 1, .. })
        ));
        let unnamed = GOOD_FFT.replace("chain fft ", "");
        assert!(matches!(
            parse_output(&unnamed),
            Err(FirmwareError::Output { line: 1, .. })
        ));
        // The detection count is checked against the `D` lines.
        let miscounted = GOOD_FFT.replace("F 1 0 1", "F 2 0 1");
        assert!(parse_output(&miscounted).is_err());
    }

    fn entry(image: Image, buffers: &[(&str, u64)], stages: &[(&str, u64)]) -> PresetBudget {
        PresetBudget {
            preset: image.name().into(),
            chain: chain_name(image.chain).into(),
            frame: "f".into(),
            detections: 2,
            points: 2,
            static_ram_bytes: buffers.iter().map(|b| b.1).sum(),
            buffers: buffers
                .iter()
                .map(|&(symbol, bytes)| Buffer {
                    symbol: symbol.into(),
                    what: "w".into(),
                    section: ".bss".into(),
                    bytes,
                })
                .collect(),
            stack_peak_bytes: 10,
            stack_peak_setup_bytes: 10,
            stack_peak_frame_bytes: 5,
            ram_total_bytes: 0,
            flash_bytes: 0,
            embedded_frame_bytes: 0,
            instructions_per_frame: stages.iter().find(|s| s.0 == "total").map_or(0, |s| s.1),
            instructions_per_stage: stages.iter().map(|&(k, v)| (k.into(), v)).collect(),
        }
    }

    #[test]
    fn markdown_keeps_each_chain_in_its_own_table() {
        let budget = Budget {
            method: String::new(),
            command: UPDATE_COMMAND.into(),
            board: String::new(),
            qemu: String::new(),
            rustc: String::new(),
            profile: String::new(),
            instructions_per_tick: 40,
            presets: vec![
                entry(
                    Image::dbe(Preset::ColoRadar),
                    &[("CUBE", 1000), ("CHAIN", 300), ("other", 0)],
                    &[("elevation_doppler", 600), ("total", 5000)],
                ),
                entry(
                    Image::fft(Preset::ColoRadar),
                    &[("CUBE", 1000), ("CHAIN", 200), ("WORKSPACE", 70)],
                    &[("angles", 100), ("process", 2000), ("total", 4000)],
                ),
            ],
        };
        let md = render_markdown(&budget);
        assert!(
            md.contains("| memory (bytes) | coloradar | coloradar-fft |"),
            "{md}"
        );
        // A buffer an image lacks is a dash; `other` comes last.
        assert!(md.contains("| `CHAIN`: w | 300 | 200 |"), "{md}");
        assert!(md.contains("| `WORKSPACE`: w | — | 70 |"), "{md}");
        let other = md.find("| `other`").expect("other row");
        assert!(md.find("| `WORKSPACE`").is_some_and(|i| i < other), "{md}");
        // Separate instruction tables with their own per-detection rows.
        assert!(
            md.contains("| instructions, DBE chain | coloradar |"),
            "{md}"
        );
        assert!(
            md.contains("| instructions, FFT chain | coloradar-fft |"),
            "{md}"
        );
        assert!(
            md.contains("| stages 3–5 per detection (÷ detections) | 300 |"),
            "{md}"
        );
        assert!(
            md.contains("| stage 3 per detection (÷ detections) | 50 |"),
            "{md}"
        );
        // Both chains on one cube: the DBE image + the FFT image's CHAIN + WORKSPACE, and its frame
        // + the FFT `process`.
        assert!(
            md.contains("`coloradar` + 270 = 1,570 bytes of static RAM, a frame 5,000 + 2,000 = 7,000 instructions"),
            "{md}"
        );
    }

    #[test]
    fn image_names_are_the_binaries() {
        let names: Vec<&str> = Image::ALL.iter().map(|i| i.name()).collect();
        assert_eq!(
            names,
            ["coloradar", "iwr6843", "coloradar-fft", "iwr6843-fft"]
        );
        let layout = Layout::this_repo();
        for image in Image::ALL {
            let bin = layout
                .firmware()
                .join("src")
                .join("bin")
                .join(format!("{}.rs", image.name().replace('-', "_")));
            assert!(bin.is_file(), "{image}: no {}", bin.display());
        }
    }

    #[test]
    fn rejects_truncated_and_failed_runs() {
        let cut = GOOD.replace("E ok\n", "");
        assert!(matches!(
            parse_output(&cut),
            Err(FirmwareError::Output { line: 0, .. })
        ));
        let failed = GOOD.replace("E ok", "X frame rejected: incomplete frame");
        assert!(matches!(
            parse_output(&failed),
            Err(FirmwareError::Output { line: 10, .. })
        ));
        let panic = format!("{GOOD}panicked at src/lib.rs:1:1\n");
        assert!(parse_output(&panic).is_err());
        let short = GOOD.replace(" 15.095507", "");
        assert!(matches!(
            parse_output(&short),
            Err(FirmwareError::Output { line: 4, .. })
        ));
        let miscounted = GOOD.replace("F 1 0 1", "F 1 0 2");
        assert!(parse_output(&miscounted).is_err());
        let bad_clock = GOOD.replace("C 40000000 1000001 40", "C 40000000 1000100 40");
        assert!(parse_output(&bad_clock).is_err());
    }

    #[test]
    fn static_names_come_from_legacy_mangling() {
        assert_eq!(
            static_name("_ZN7iwr684329__cortex_m_rt_main_trampoline4CUBE17hc1c6bbef8d5319e6E"),
            Some("CUBE")
        );
        assert_eq!(
            static_name("_ZN9coloradar5FRAME17h0123456789abcdefE"),
            Some("FRAME")
        );
        assert_eq!(static_name("_stack_start"), None);
    }

    #[test]
    fn block_is_spliced_between_the_markers_only() {
        let doc = "# T\n\nbefore\n<!-- budget:begin -->\nold\n<!-- budget:end -->\nafter\n";
        let p = Path::new("memory-layout.md");
        let new = splice_block(doc, "| a |\n", p).expect("markers present");
        assert_eq!(
            new,
            "# T\n\nbefore\n<!-- budget:begin -->\n| a |\n<!-- budget:end -->\nafter\n"
        );
        assert_eq!(splice_block(&new, "| a |", p).expect("idempotent"), new);
        assert!(splice_block("no markers", "x", p).is_err());
        assert!(splice_block("<!-- budget:begin -->\nx", "x", p).is_err());
    }

    #[test]
    fn the_capture_must_hold_one_frame() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("cap.bin");
        let one = vec![0u8; SensorConfig::iwr6843_fixture().frame_bytes()];
        std::fs::write(&path, &one).expect("write");
        assert!(iwr6843_frame(&path).is_ok());
        std::fs::write(&path, [one.clone(), one].concat()).expect("write");
        assert!(matches!(
            iwr6843_frame(&path),
            Err(FirmwareError::BadInput { .. })
        ));
        std::fs::write(&path, [0u8; 100]).expect("write");
        assert!(matches!(iwr6843_frame(&path), Err(FirmwareError::Read(_))));
    }

    #[test]
    fn simulated_frame_is_reproducible() {
        let a = coloradar_frame().expect("renders");
        let b = coloradar_frame().expect("renders");
        assert_eq!(a, b);
        assert_eq!(
            frame_bytes(&a).len(),
            SensorConfig::coloradar().frame_bytes()
        );
    }

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1_000), "1,000");
        assert_eq!(thousands(1_572_864), "1,572,864");
    }
}
