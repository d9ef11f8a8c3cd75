//! Measure the firmware's resource budget and keep `docs/budget.json` and the budget block of
//! `memory-layout.md` up to date.
//!
//! ```sh
//! cargo run -p host-sim --example fw_budget              # build, run under QEMU, write both
//! cargo run -p host-sim --example fw_budget -- --check   # fail (exit 1) when either is stale
//! cargo run -p host-sim --example fw_budget -- render    # re-render the block from the JSON
//! cargo run -p host-sim --example fw_budget -- render --check
//! ```
//!
//! Measures every firmware image (`host_sim::firmware::Image::ALL`: the DBE chain and the FFT
//! chain per preset). Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target
//! (`firmware/README.md`).

use std::process::ExitCode;

use clap::Parser;
use host_sim::firmware::{self, FirmwareError, Layout};

/// Firmware budget: measure on QEMU, write or check docs/budget.json and memory-layout.md.
#[derive(Parser)]
#[command(name = "fw_budget")]
struct Args {
    /// `render`: no measurement, only the Markdown block from docs/budget.json.
    mode: Option<Mode>,
    /// Compare instead of writing; exit 1 when anything is stale.
    #[arg(long)]
    check: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Mode {
    /// Only re-render the block from docs/budget.json.
    Render,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("fw_budget: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &Args) -> Result<bool, FirmwareError> {
    let layout = Layout::this_repo();
    let measured = match args.mode {
        Some(Mode::Render) => None,
        None => {
            let (budget, _, _) = firmware::measure(&layout)?;
            for p in &budget.presets {
                println!(
                    "{:>13}: static RAM {} B, stack peak {} B, flash {} B, {} instructions/frame",
                    p.preset,
                    firmware::thousands(p.static_ram_bytes),
                    firmware::thousands(p.stack_peak_bytes),
                    firmware::thousands(p.flash_bytes),
                    firmware::thousands(p.instructions_per_frame)
                );
            }
            Some(budget)
        }
    };
    if args.check {
        let problems = firmware::stale(&layout, measured.as_ref())?;
        if problems.is_empty() {
            println!("budget: docs/budget.json and memory-layout.md are up to date");
            return Ok(true);
        }
        for p in &problems {
            eprintln!("stale: {p}");
        }
        eprintln!("run `{}` and commit the result", firmware::UPDATE_COMMAND);
        return Ok(false);
    }
    let budget = match measured {
        Some(b) => b,
        None => firmware::read_budget(&layout.budget_json())?,
    };
    for path in firmware::write_budget(&layout, &budget)? {
        println!("wrote {}", path.display());
    }
    Ok(true)
}
