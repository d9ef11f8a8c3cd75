//! `dbe`: run the DBE radar chain on recordings, simulate scenes, validate and plot.

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Digital Beamforming Enhanced radar processing for single-chip 4D FMCW radars.
#[derive(Parser, Debug)]
#[command(name = "dbe", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Turn recorded frames (ColoRadar sequence or DCA1000 capture) into point clouds.
    Process(cli::process::ProcessArgs),
    /// Simulate a scene into a ColoRadar-layout sequence with calibration and ground truth.
    Simulate(cli::simulate::SimulateArgs),
    /// Check the core (fed chirp by chirp) against the f64 reference, frame by frame.
    Validate(cli::validate::ValidateArgs),
    /// Plot one frame: range–azimuth and range–Doppler maps, point cloud (top and side views).
    Plot(cli::plot::PlotArgs),
    /// Simulate the built-in scene, process, validate, measure accuracy and plot.
    Demo(cli::demo::DemoArgs),
    /// Compare the DBE and FFT chains with each other and the Cramér–Rao bound on simulated
    /// scenes; write a report (Markdown, CSV, PNG, JSON).
    Eval(cli::eval::EvalArgs),
    /// Time every stage of both chains on simulated ColoRadar frames (one thread).
    Bench(cli::bench::BenchArgs),
    /// Radar-inertial odometry on a ColoRadar sequence (radar ego-velocity + IMU, error-state
    /// EKF); trajectory in TUM format, evaluated against ground truth when the sequence has it.
    Odometry(cli::odometry::OdometryArgs),
    /// Measure a corner reflector at boresight: the per-channel gain and phase factors and the
    /// range bias of a TI `.cfg`'s `compRangeBiasAndRxChanPhase`.
    Calibrate(cli::calibrate::CalibrateArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Process(a) => cli::process::run(a),
        Command::Simulate(a) => cli::simulate::run(a),
        Command::Validate(a) => cli::validate::run(a),
        Command::Plot(a) => cli::plot::run(a),
        Command::Demo(a) => cli::demo::run(a),
        Command::Eval(a) => cli::eval::run(a),
        Command::Bench(a) => cli::bench::run(a),
        Command::Odometry(a) => cli::odometry::run(a),
        Command::Calibrate(a) => cli::calibrate::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if cli::closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", cli::error_line(&e));
            ExitCode::FAILURE
        }
    }
}
