//! `cargo xtask`: the firmware's build, run and budget commands (alias in `.cargo/config.toml`).
//!
//! ```sh
//! cargo xtask budget                 # build, run every image under QEMU, write the budget
//! cargo xtask budget --check         # exit 1 when docs/budget.json or memory-layout.md is stale
//! cargo xtask budget --render        # re-render the block of memory-layout.md from the JSON
//! cargo xtask firmware coloradar     # build and run one image, print its output lines
//! cargo xtask firmware iwr6843 --board an500
//! cargo xtask frames                 # write the frames the images embed (firmware/target/frames)
//! cargo xtask header                 # regenerate ffi/dbe_radar.h (cbindgen); --check: exit 1 if stale
//! cargo xtask c-example              # build ffi/c/example.c, run it on the TI capture
//! cargo xtask c-firmware coloradar   # build the C firmware (arm-none-eabi-gcc), run it on QEMU
//! cargo xtask profile coloradar      # instructions per function of one image (QEMU exec log)
//! cargo xtask anchors --dbe-radar DIR # time the authors' Python and OpenRadar beside `dbe bench`
//! ```

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use xtask::{Board, FirmwareError, Image, Layout};

/// Build, run and measure the dbe-radar firmware.
#[derive(Parser)]
#[command(name = "cargo xtask")]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Measure every image on QEMU and write (or check) docs/budget.json and memory-layout.md.
    Budget {
        /// Compare instead of writing; exit 1 when anything is stale.
        #[arg(long)]
        check: bool,
        /// No measurement: only the Markdown block from docs/budget.json.
        #[arg(long)]
        render: bool,
    },
    /// Build the firmware and run one image under QEMU, printing its output lines.
    Firmware {
        /// The image: coloradar, iwr6843 (DBE chain), coloradar-fft, iwr6843-fft.
        #[arg(default_value = "coloradar")]
        image: String,
        /// The board: an386 (Cortex-M4F, the budget's), an500 (Cortex-M7) or an505 (Cortex-M33).
        #[arg(long, default_value = "an386")]
        board: String,
    },
    /// Write the frames the images embed into firmware/target/frames (read by its build.rs).
    Frames,
    /// Regenerate the C API header ffi/dbe_radar.h from ffi/src/lib.rs (cbindgen).
    Header {
        /// Compare instead of writing; exit 1 when the header is stale.
        #[arg(long)]
        check: bool,
    },
    /// Build the host C example (ffi/c/example.c) and run it on the TI capture.
    CExample,
    /// Instructions per source function of one image on the Cortex-M4F (QEMU's execution log,
    /// addr2line): where the budget's stages spend them.
    Profile {
        /// The image: coloradar, iwr6843 (DBE chain), coloradar-fft, iwr6843-fft.
        #[arg(default_value = "coloradar")]
        image: String,
        /// Rows of the table.
        #[arg(long, default_value_t = 40)]
        top: usize,
    },
    /// Time the Python chains issue 13 compares with (the authors' DBE chain, OpenRadar's FFT
    /// chain) and `dbe bench` on the same simulated frames; write docs/anchors.json.
    Anchors {
        /// A checkout of the authors' code (github.com/SenseRoboticsLab/DBE-Radar); without it
        /// the repository is cloned into target/anchors.
        #[arg(long)]
        dbe_radar: Option<std::path::PathBuf>,
    },
    /// Build the C firmware (ffi/c/firmware, arm-none-eabi-gcc) and run it on QEMU's Cortex-M4F.
    CFirmware {
        /// The frame: coloradar (simulated) or iwr6843 (the TI capture).
        #[arg(default_value = "coloradar")]
        preset: String,
    },
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(args.command) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(command: Command) -> Result<bool, FirmwareError> {
    let layout = Layout::this_repo();
    match command {
        Command::Budget { check, render } => budget(&layout, check, render),
        Command::Firmware { image, board } => {
            let image = Image::ALL
                .into_iter()
                .find(|i| i.name() == image)
                .ok_or_else(|| usage(format!("unknown image `{image}` ({})", image_names())))?;
            let board = Board::ALL
                .into_iter()
                .find(|b| b.short_name() == board)
                .ok_or_else(|| usage(format!("unknown board `{board}` (an386, an500, an505)")))?;
            xtask::check_tools()?;
            xtask::build(&layout)?;
            print!("{}", xtask::run(&layout, image, board)?);
            Ok(true)
        }
        Command::Profile { image, top } => {
            let image = Image::ALL
                .into_iter()
                .find(|i| i.name() == image)
                .ok_or_else(|| usage(format!("unknown image `{image}` ({})", image_names())))?;
            print!("{}", xtask::profile::profile(&layout, image, top)?);
            Ok(true)
        }
        Command::Anchors { dbe_radar } => {
            let anchors = xtask::anchors::measure(&layout, dbe_radar.as_deref())?;
            print!("{}", xtask::anchors::render(&anchors));
            println!("{}", xtask::anchors::anchors_json(&layout).display());
            Ok(true)
        }
        Command::Frames => {
            xtask::write_frames(&layout)?;
            println!("{}", layout.frames_dir().display());
            Ok(true)
        }
        Command::Header { check: true } => {
            if xtask::header_is_current(&layout)? {
                println!("header: {} is up to date", layout.header().display());
                Ok(true)
            } else {
                eprintln!(
                    "stale: {} differs from what cbindgen makes of ffi/src/lib.rs; run `cargo xtask header`",
                    layout.header().display()
                );
                Ok(false)
            }
        }
        Command::Header { check: false } => {
            println!("{}", xtask::write_header(&layout)?.display());
            Ok(true)
        }
        Command::CExample => {
            let exe = xtask::build_host_program(&layout, "example")?;
            print!(
                "{}",
                xtask::run_host_program(&exe, &[&layout.iwr6843_capture()])?
            );
            Ok(true)
        }
        Command::CFirmware { preset } => {
            let preset = match preset.as_str() {
                "coloradar" => xtask::CPreset::Coloradar,
                "iwr6843" => xtask::CPreset::Iwr6843,
                other => {
                    return Err(usage(format!(
                        "unknown preset `{other}` (coloradar, iwr6843)"
                    )))
                }
            };
            let elf = xtask::build_c_firmware(&layout, preset)?;
            print!("{}", xtask::run_c_firmware(&elf)?);
            Ok(true)
        }
    }
}

fn image_names() -> String {
    Image::ALL.map(|i| i.name()).join(", ")
}

fn usage(message: String) -> FirmwareError {
    FirmwareError::Usage(message)
}

fn budget(layout: &Layout, check: bool, render: bool) -> Result<bool, FirmwareError> {
    let measured = if render {
        None
    } else {
        let (budget, _, _) = xtask::measure(layout)?;
        for p in &budget.presets {
            println!(
                "{:>13}: static RAM {} B, stack peak {} B, flash {} B, {} instructions/frame",
                p.preset,
                xtask::thousands(p.static_ram_bytes),
                xtask::thousands(p.stack_peak_bytes),
                xtask::thousands(p.flash_bytes),
                xtask::thousands(p.instructions_per_frame)
            );
        }
        Some(budget)
    };
    if check {
        let problems = xtask::stale(layout, measured.as_ref())?;
        if problems.is_empty() {
            println!("budget: docs/budget.json and memory-layout.md are up to date");
            return Ok(true);
        }
        for p in &problems {
            eprintln!("stale: {p}");
        }
        eprintln!("run `{}` and commit the result", xtask::UPDATE_COMMAND);
        return Ok(false);
    }
    let budget = match measured {
        Some(b) => b,
        None => xtask::read_budget(&layout.budget_json())?,
    };
    for path in xtask::write_budget(layout, &budget)? {
        println!("wrote {}", path.display());
    }
    Ok(true)
}
