//! What can go wrong while building, running or measuring the firmware.

use std::path::{Path, PathBuf};

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
    Read(#[from] host_sim::io::IoError),
    /// The simulator could not render the ColoRadar frame.
    #[error("simulating the ColoRadar frame: {0}")]
    Simulation(String),
    /// A command-line argument is not one the tool knows.
    #[error("{0}")]
    Usage(String),
    /// `memory-layout.md` has no well-formed budget block.
    #[error("{}: {message}", path.display())]
    Block {
        /// The Markdown file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

pub(crate) fn io_err(
    path: &Path,
    op: &'static str,
) -> impl FnOnce(std::io::Error) -> FirmwareError {
    let path = path.to_path_buf();
    move |source| FirmwareError::Io { path, op, source }
}
