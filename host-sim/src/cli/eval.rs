//! `dbe eval`: compare the DBE chain with the FFT chain and the Cramér–Rao bound on simulated
//! scenes with exact ground truth, and write a report.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use host_sim::eval::{run_evaluation, write_report, EvalConfig};
use host_sim::io::StagedDir;

/// Arguments of `dbe eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Output folder (must not exist or be empty): report.md, CSV tables, PNG charts,
    /// summary.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Fewer Monte-Carlo trials and frames: the same code paths in seconds instead of minutes.
    #[arg(long)]
    pub quick: bool,
    /// Seed of every random draw.
    #[arg(long, default_value_t = 2025)]
    pub seed: u64,
}

/// `dbe eval`.
pub fn run(args: &EvalArgs) -> Result<()> {
    let start = Instant::now();
    let mut config = if args.quick {
        EvalConfig::quick()
    } else {
        EvalConfig::full()
    };
    config.seed = args.seed;
    let staged = StagedDir::new(&args.out)?;
    let eval = run_evaluation(&config, &|line: &str| eprintln!("{line}"))?;
    write_report(&eval, staged.path())
        .with_context(|| format!("writing the report into {}", args.out.display()))?;
    staged.commit()?;
    outln!(
        "done in {:.1} s → {}",
        start.elapsed().as_secs_f64(),
        args.out.display()
    )?;
    Ok(())
}
