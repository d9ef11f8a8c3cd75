//! Readers and writers of recorded data, calibration and point clouds.
//!
//! | what | reader | writer | format |
//! |---|---|---|---|
//! | ColoRadar calibration | [`load_calib`] | [`write_calib`] | [`calib`] |
//! | ColoRadar raw sequence | [`open_sequence`] | [`write_sequence`] | [`coloradar`] |
//! | DCA1000 raw capture | [`read_dca1000`] | [`write_dca1000`] | [`dca1000`] |
//! | TI mmWave SDK `.cfg` + board | [`ticfg::load_ti_cfg`] | – | [`ticfg`] |
//! | ColoRadar IMU, ground truth, transforms | [`read_imu`], [`read_groundtruth`], [`load_transforms`] | [`write_imu`], [`write_transforms`] (poses: [`crate::sim::write_truth`]) | [`navigation`] |
//! | point clouds | [`read_coloradar_pointclouds`], [`read_csv`], … | [`write_coloradar_pointclouds`], [`write_csv`], [`write_pcd`], [`write_ply`], … | [`pointcloud`] |
//!
//! Every malformed input is an [`IoError`] that names the file and what was expected; no
//! reader panics on bad data.
//!
//! **No half-written output** ([`atomic`]): a single-file writer writes a hidden temporary
//! sibling and renames it over the target, so the target is either the old file or the complete
//! new one. A writer of a directory layout (sequence, calibration, point-cloud sequence) builds
//! the whole tree in a hidden sibling directory and renames it into place at the end; the target
//! directory must not exist yet (or be empty), and after any error it still does not exist (or
//! is still empty). A process killed mid-way can leave a hidden `.NAME.partial-*` or
//! `.NAME.tmp-*` sibling behind, never a partial target.

use std::fmt;
use std::path::{Path, PathBuf};

pub mod atomic;
pub mod calib;
pub mod coloradar;
pub mod dca1000;
pub mod mcap;
pub mod navigation;
pub mod pointcloud;
pub mod ticfg;

pub use atomic::{write_file_atomic, StagedDir};
pub use calib::{load_calib, write_calib};
pub use coloradar::{open_sequence, write_sequence, Sequence};
pub use dca1000::{read_dca1000, write_dca1000};
pub use navigation::{
    load_transforms, read_groundtruth, read_imu, write_imu, write_transforms, StampedPose,
    Transforms,
};
pub use pointcloud::{
    read_coloradar_bin, read_coloradar_pointclouds, read_csv, write_coloradar_bin,
    write_coloradar_pointclouds, write_csv, write_pcd, write_ply, ColoradarCloudWriter,
    PlyEncoding, CSV_HEADER,
};

/// A failure to read or write one of the project's files. Every variant names the file (or
/// directory) and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused an operation on `path`.
    #[error("{}: cannot {op}: {source}", path.display())]
    Os {
        /// File or directory concerned.
        path: PathBuf,
        /// What was attempted ("read", "create", "rename to …", …).
        op: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A line of a text file does not follow its format.
    #[error("{}:{line}: {message}", path.display())]
    Syntax {
        /// The text file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// A required key is absent from a `key value` file.
    #[error("{}: missing required key `{key}`", path.display())]
    MissingKey {
        /// The text file.
        path: PathBuf,
        /// The key that was expected.
        key: String,
    },
    /// A value is out of range, not finite, or disagrees with another file or with the sensor.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file (or output file) concerned.
        path: PathBuf,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A file or folder that must exist does not.
    #[error("{}: not found; expected {expected}", path.display())]
    NotFound {
        /// Where it was looked for.
        path: PathBuf,
        /// What should have been there.
        expected: String,
    },
    /// A binary file's size matches nothing the sensor allows.
    #[error("{}: {found} bytes, expected {expected}", path.display())]
    Size {
        /// The binary file.
        path: PathBuf,
        /// Its size, bytes.
        found: u64,
        /// The size (or rule) that was expected.
        expected: String,
    },
    /// Frame files are missing from a sequence: indices must run `0..count` without gaps.
    #[error("{}: missing frame files {}{} ({missing_count} missing; found {found} files, highest index {highest}; frames must be numbered 0..N without gaps)", dir.display(), IndexList(missing), if missing.len() >= MAX_LISTED_GAPS { ", …" } else { "" })]
    MissingFrames {
        /// The `data` directory.
        dir: PathBuf,
        /// The first [`MAX_LISTED_GAPS`] runs of missing indices, ascending, inclusive.
        missing: Vec<(usize, usize)>,
        /// Missing indices in all.
        missing_count: usize,
        /// Frame files found.
        found: usize,
        /// Highest index found.
        highest: usize,
    },
    /// A data directory holds files that are not `<prefix><i>.bin`.
    #[error("{}: unexpected entries {files:?}; expected only {expected}", dir.display())]
    ExtraFiles {
        /// The directory.
        dir: PathBuf,
        /// The unexpected names.
        files: Vec<String>,
        /// The file names that belong there.
        expected: String,
    },
    /// `timestamps.txt` does not have one line per frame.
    #[error("{}: {found} timestamps, expected {expected} (one per frame file)", path.display())]
    TimestampCount {
        /// The timestamps file.
        path: PathBuf,
        /// Timestamps read.
        found: usize,
        /// Frame files found.
        expected: usize,
    },
    /// The output target exists and is not empty; writers never merge into existing output.
    #[error("{}: already exists and is not empty; expected a new or empty directory", path.display())]
    OutputExists {
        /// The target.
        path: PathBuf,
    },
}

impl IoError {
    /// An [`IoError::Os`] for `path`.
    pub(crate) fn os(path: &Path, op: impl Into<String>, source: std::io::Error) -> Self {
        Self::Os {
            path: path.to_path_buf(),
            op: op.into(),
            source,
        }
    }

    /// An [`IoError::Invalid`] for `path`.
    pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> Self {
        Self::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// An [`IoError::Syntax`] for line `line` (1-based) of `path`.
    pub(crate) fn syntax(path: &Path, line: usize, message: impl Into<String>) -> Self {
        Self::Syntax {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }
}

/// Most runs of missing frame indices an error lists (a stray `frame_<huge>.bin` leaves one
/// run of up to 2⁶⁴ indices; listing stays bounded whatever the names).
pub const MAX_LISTED_GAPS: usize = 8;

/// Displays ascending inclusive runs of indices compactly: `3, 5-9, 12`.
struct IndexList<'a>(&'a [(usize, usize)]);

impl fmt::Display for IndexList<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, &(start, end)) in self.0.iter().enumerate() {
            if k > 0 {
                f.write_str(", ")?;
            }
            if end == start {
                write!(f, "{start}")?;
            } else {
                write!(f, "{start}-{end}")?;
            }
        }
        Ok(())
    }
}

/// Read a whole file, mapping failures to [`IoError::Os`] / [`IoError::NotFound`].
pub(crate) fn read_bytes(path: &Path, what: &str) -> Result<Vec<u8>, IoError> {
    let mut buf = Vec::new();
    read_bytes_into(path, what, &mut buf)?;
    Ok(buf)
}

/// [`read_bytes`] into `buf` (cleared first; its capacity is reused).
pub(crate) fn read_bytes_into(path: &Path, what: &str, buf: &mut Vec<u8>) -> Result<(), IoError> {
    use std::io::Read;
    buf.clear();
    std::fs::File::open(path)
        .and_then(|mut f| f.read_to_end(buf))
        .map(|_| ())
        .map_err(|e| not_found_or_os(path, what, "read", e))
}

/// Read a whole text file (UTF-8).
pub(crate) fn read_text(path: &Path, what: &str) -> Result<String, IoError> {
    let bytes = read_bytes(path, what)?;
    String::from_utf8(bytes).map_err(|e| {
        IoError::invalid(
            path,
            format!(
                "not UTF-8 text (invalid byte at offset {}); expected {what}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

pub(crate) fn not_found_or_os(path: &Path, what: &str, op: &str, e: std::io::Error) -> IoError {
    if e.kind() == std::io::ErrorKind::NotFound {
        IoError::NotFound {
            path: path.to_path_buf(),
            expected: what.to_string(),
        }
    } else {
        IoError::os(path, op, e)
    }
}

/// Text lines without comments: `(1-based line number, trimmed content)`, blank and `#` lines
/// dropped, trailing `# …` comments removed.
pub(crate) fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(i, line)| {
        let line = match line.find('#') {
            Some(p) => &line[..p],
            None => line,
        };
        let line = line.trim();
        (!line.is_empty()).then_some((i + 1, line))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_list_compresses_runs() {
        assert_eq!(
            IndexList(&[(1, 1), (3, 5), (9, 9)]).to_string(),
            "1, 3-5, 9"
        );
        assert_eq!(IndexList(&[]).to_string(), "");
    }

    #[test]
    fn content_lines_drop_comments() {
        let v: Vec<_> = content_lines("# a\n\nx 1 # c\n  y 2\n").collect();
        assert_eq!(v, vec![(3, "x 1"), (4, "y 2")]);
    }
}
