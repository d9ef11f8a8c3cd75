//! All-or-nothing output: files and directory trees appear complete or not at all.
//!
//! Guarantees (on the same file system, which a sibling temporary always is):
//! - [`write_file_atomic`]: the target is either untouched or the complete new content. The data
//!   goes to a hidden sibling `.NAME.tmp-PID-N`, is flushed to disk, then renamed over `NAME`.
//! - [`StagedDir`]: a directory tree is built in a hidden sibling `.NAME.partial-PID-N` and
//!   renamed to `NAME` by [`StagedDir::commit`]. The target must not exist or be an empty
//!   directory, both when staging starts and at commit; an existing non-empty target is an
//!   [`IoError::OutputExists`] and is never merged into or replaced. Dropping an uncommitted
//!   `StagedDir` (an error return or a panic) deletes the staging tree. An empty target whose
//!   parent refuses a sibling (a read-only container mount point) is staged inside itself
//!   ([`StagedDir::inside`]).
//!
//! A process killed by a signal or a power cut can leave a hidden temporary sibling behind; the
//! target itself is never partial. The next write to the same target removes such leftovers
//! of its own name whose process no longer runs (on Linux, where `/proc` tells; elsewhere they
//! stay). Parent directories of the target are created as needed and are not removed on
//! failure.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::IoError;

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A hidden sibling name for `target`: `.NAME.<tag>-PID-N`.
fn sibling(target: &Path, tag: &str) -> Result<PathBuf, IoError> {
    let name = target.file_name().ok_or_else(|| {
        IoError::invalid(
            target,
            "output path has no file name; expected a path like DIR/NAME",
        )
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let hidden = format!(
        ".{}.{tag}-{}-{n}",
        name.to_string_lossy(),
        std::process::id()
    );
    Ok(target.with_file_name(hidden))
}

/// Whether process `pid` is known to have ended (Linux: no `/proc/PID`); `false` when this
/// cannot be told.
fn process_ended(pid: u32) -> bool {
    cfg!(target_os = "linux")
        && Path::new("/proc").is_dir()
        && !Path::new("/proc").join(pid.to_string()).exists()
}

/// Remove `.NAME.<tag>-PID-N` siblings of `target` left by processes that have ended (a run
/// killed mid-way). Best effort: what cannot be listed or removed stays.
fn remove_stale_siblings(target: &Path, tag: &str) {
    let (Some(name), Some(parent)) = (target.file_name(), target.parent()) else {
        return;
    };
    let parent = if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    };
    let prefix = format!(".{}.{tag}-", name.to_string_lossy());
    let Ok(entries) = fs::read_dir(parent) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if pid != std::process::id() && process_ended(pid) {
            let path = entry.path();
            let _ = if path.is_dir() {
                fs::remove_dir_all(&path)
            } else {
                fs::remove_file(&path)
            };
        }
    }
}

/// Parent directory of `target` (`.` for a bare name), created if missing.
fn ensure_parent(target: &Path) -> Result<(), IoError> {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => {
            fs::create_dir_all(p).map_err(|e| IoError::os(p, "create directory", e))
        }
        _ => Ok(()),
    }
}

/// Write `contents` to `path` atomically: a temporary sibling, flushed, then renamed over
/// `path`. On error the temporary is removed and `path` is untouched.
pub fn write_file_atomic(path: &Path, contents: &[u8]) -> Result<(), IoError> {
    ensure_parent(path)?;
    remove_stale_siblings(path, "tmp");
    let tmp = sibling(path, "tmp")?;
    let result = (|| {
        let mut f = fs::File::create(&tmp).map_err(|e| IoError::os(&tmp, "create", e))?;
        f.write_all(contents)
            .map_err(|e| IoError::os(&tmp, "write", e))?;
        f.sync_all().map_err(|e| IoError::os(&tmp, "flush", e))?;
        drop(f);
        fs::rename(&tmp, path)
            .map_err(|e| IoError::os(&tmp, format!("rename to {}", path.display()), e))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Fail unless `target` is absent or an empty directory.
fn check_target_free(target: &Path) -> Result<(), IoError> {
    match fs::symlink_metadata(target) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(IoError::os(target, "inspect", e)),
        Ok(meta) if meta.is_dir() => {
            let mut entries = fs::read_dir(target).map_err(|e| IoError::os(target, "list", e))?;
            if entries.next().is_none() {
                Ok(())
            } else {
                Err(IoError::OutputExists {
                    path: target.to_path_buf(),
                })
            }
        }
        Ok(_) => Err(IoError::OutputExists {
            path: target.to_path_buf(),
        }),
    }
}

/// A directory tree under construction in a hidden sibling of its target; see the module docs.
///
/// Write everything under [`StagedDir::path`], then call [`StagedDir::commit`].
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    /// Staging inside the (empty) target instead of beside it: its parent is not writable.
    inside: bool,
    committed: bool,
}

impl StagedDir {
    /// Start staging `target`, which must not exist or be an empty directory.
    pub fn new(target: &Path) -> Result<Self, IoError> {
        check_target_free(target)?;
        ensure_parent(target)?;
        remove_stale_siblings(target, "partial");
        let staging = sibling(target, "partial")?;
        match fs::create_dir(&staging) {
            Ok(()) => Ok(Self {
                target: target.to_path_buf(),
                staging,
                inside: false,
                committed: false,
            }),
            // An empty target whose parent is read-only (a container's mount point): stage
            // inside it.
            Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && target.is_dir() => {
                Self::inside(target)
            }
            Err(e) => Err(IoError::os(&staging, "create directory", e)),
        }
    }

    /// Stage inside the empty directory `target`, in a hidden `.partial-PID-N`, for a target
    /// whose parent cannot take a sibling. [`Self::commit`] then moves the entries up one by
    /// one: the target holds only the hidden staging folder until then, and a run killed
    /// during the moves can leave it part-filled (the one weaker guarantee of this case).
    pub fn inside(target: &Path) -> Result<Self, IoError> {
        check_target_free(target)?;
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let staging = target.join(format!(".partial-{}-{n}", std::process::id()));
        fs::create_dir(&staging).map_err(|e| IoError::os(&staging, "create directory", e))?;
        Ok(Self {
            target: target.to_path_buf(),
            staging,
            inside: true,
            committed: false,
        })
    }

    /// The staging directory: write the tree here.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The final location.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Move the finished tree to the target. Fails (and deletes the staging tree) if the target
    /// has become non-empty meanwhile.
    pub fn commit(mut self) -> Result<(), IoError> {
        if self.inside {
            return self.commit_inside();
        }
        check_target_free(&self.target)?;
        if self.target.is_dir() {
            // An empty directory: rename(2) would replace it on Linux but not everywhere.
            fs::remove_dir(&self.target)
                .map_err(|e| IoError::os(&self.target, "replace empty directory", e))?;
        }
        fs::rename(&self.staging, &self.target).map_err(|e| {
            IoError::os(
                &self.staging,
                format!("rename to {}", self.target.display()),
                e,
            )
        })?;
        self.committed = true;
        Ok(())
    }
}

impl StagedDir {
    /// [`Self::commit`] of a tree staged inside its target: the target must hold nothing but
    /// the staging folder; its entries move up, then it goes.
    fn commit_inside(mut self) -> Result<(), IoError> {
        let entries =
            fs::read_dir(&self.target).map_err(|e| IoError::os(&self.target, "list", e))?;
        for entry in entries {
            let entry = entry.map_err(|e| IoError::os(&self.target, "list", e))?;
            if entry.path() != self.staging {
                return Err(IoError::OutputExists {
                    path: self.target.clone(),
                });
            }
        }
        let staged =
            fs::read_dir(&self.staging).map_err(|e| IoError::os(&self.staging, "list", e))?;
        for entry in staged {
            let entry = entry.map_err(|e| IoError::os(&self.staging, "list", e))?;
            let to = self.target.join(entry.file_name());
            fs::rename(entry.path(), &to).map_err(|e| {
                IoError::os(&entry.path(), format!("rename to {}", to.display()), e)
            })?;
        }
        fs::remove_dir(&self.staging).map_err(|e| IoError::os(&self.staging, "remove", e))?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.staging);
        }
    }
}

/// Create `dir` (and parents) inside a staging tree.
pub(crate) fn create_dir(dir: &Path) -> Result<(), IoError> {
    fs::create_dir_all(dir).map_err(|e| IoError::os(dir, "create directory", e))
}

/// Write a new file inside a staging tree and flush it to disk before returning: the tree's
/// commit (a rename) is the atomic step, so the file needs no temporary sibling of its own,
/// and once committed its content is on disk. Fails if `path` exists.
pub fn write_file_synced(path: &Path, contents: &[u8]) -> Result<(), IoError> {
    let mut f = fs::File::create_new(path).map_err(|e| IoError::os(path, "create", e))?;
    f.write_all(contents)
        .map_err(|e| IoError::os(path, "write", e))?;
    f.sync_all().map_err(|e| IoError::os(path, "flush", e))
}

/// Write a file inside a staging tree (atomicity comes from the tree's rename).
pub(crate) fn write_plain(path: &Path, contents: &[u8]) -> Result<(), IoError> {
    fs::write(path, contents).map_err(|e| IoError::os(path, "write", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staging_inside_an_empty_target_commits_or_leaves_it_empty() -> Result<(), IoError> {
        // What `StagedDir::new` falls back to when the target's parent refuses a sibling
        // (a read-only mount point; not reproducible here, where tests may run as root).
        let tmp = tempfile::tempdir().map_err(|e| IoError::os(Path::new("tmp"), "create", e))?;
        let target = tmp.path().join("mnt");
        fs::create_dir(&target).map_err(|e| IoError::os(&target, "create", e))?;
        {
            let s = StagedDir::inside(&target)?;
            assert_eq!(s.path().parent(), Some(target.as_path()));
            write_plain(&s.path().join("a.txt"), b"a")?;
        }
        assert_eq!(fs::read_dir(&target).map(|d| d.count()).unwrap_or(99), 0);
        let s = StagedDir::inside(&target)?;
        create_dir(&s.path().join("sub"))?;
        write_plain(&s.path().join("sub/b.txt"), b"b")?;
        write_plain(&s.path().join("a.txt"), b"a")?;
        s.commit()?;
        let mut names: Vec<String> = fs::read_dir(&target)
            .map_err(|e| IoError::os(&target, "list", e))?
            .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
            .collect();
        names.sort();
        assert_eq!(names, ["a.txt", "sub"]);
        assert_eq!(
            fs::read(target.join("sub/b.txt")).ok().as_deref(),
            Some(&b"b"[..])
        );
        // A non-empty target is refused, and something appearing meanwhile fails the commit.
        assert!(matches!(
            StagedDir::inside(&target),
            Err(IoError::OutputExists { .. })
        ));
        let other = tmp.path().join("other");
        fs::create_dir(&other).map_err(|e| IoError::os(&other, "create", e))?;
        let s = StagedDir::inside(&other)?;
        write_plain(&other.join("intruder"), b"x")?;
        assert!(matches!(s.commit(), Err(IoError::OutputExists { .. })));
        Ok(())
    }

    #[test]
    fn a_synced_file_is_new_complete_and_never_replaces_one() -> Result<(), IoError> {
        let tmp = tempfile::tempdir().map_err(|e| IoError::os(Path::new("tmp"), "create", e))?;
        let s = StagedDir::new(&tmp.path().join("out"))?;
        let path = s.path().join("frame_0.csv");
        write_file_synced(&path, b"x,y\n1,2\n")?;
        assert_eq!(fs::read(&path).ok().as_deref(), Some(&b"x,y\n1,2\n"[..]));
        // No temporary sibling is left beside it.
        assert_eq!(fs::read_dir(s.path()).map(|d| d.count()).unwrap_or(99), 1);
        // A second write of the same frame is an error naming the file, and keeps the first.
        let err = write_file_synced(&path, b"other").err();
        assert!(
            err.as_ref()
                .is_some_and(|e| e.to_string().contains("frame_0.csv")),
            "{err:?}"
        );
        assert_eq!(fs::read(&path).ok().as_deref(), Some(&b"x,y\n1,2\n"[..]));
        s.commit()?;
        assert!(tmp.path().join("out").join("frame_0.csv").is_file());
        Ok(())
    }

    #[test]
    fn staged_dir_commits_or_vanishes() -> Result<(), IoError> {
        let tmp = tempfile::tempdir().map_err(|e| IoError::os(Path::new("tmp"), "create", e))?;
        let target = tmp.path().join("out");
        {
            let s = StagedDir::new(&target)?;
            write_plain(&s.path().join("a.txt"), b"a")?;
            // dropped without commit
        }
        assert!(!target.exists());
        assert_eq!(fs::read_dir(tmp.path()).map(|d| d.count()).unwrap_or(99), 0);
        let s = StagedDir::new(&target)?;
        write_plain(&s.path().join("a.txt"), b"a")?;
        s.commit()?;
        assert_eq!(
            fs::read(target.join("a.txt")).ok().as_deref(),
            Some(&b"a"[..])
        );
        assert!(matches!(
            StagedDir::new(&target),
            Err(IoError::OutputExists { .. })
        ));
        Ok(())
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn leftovers_of_killed_runs_are_removed_by_the_next_run() -> Result<(), IoError> {
        let tmp = tempfile::tempdir().map_err(|e| IoError::os(Path::new("tmp"), "create", e))?;
        let target = tmp.path().join("out");
        // A pid above the kernel's maximum (2²²) never runs; this process's own is alive.
        let dead = tmp.path().join(".out.partial-4194400-0");
        let alive = tmp
            .path()
            .join(format!(".out.partial-{}-99", std::process::id()));
        let other = tmp.path().join(".other.partial-4194400-0");
        for d in [&dead, &alive, &other] {
            create_dir(&d.join("single_chip"))?;
            write_plain(&d.join("single_chip/x.bin"), b"x")?;
        }
        let s = StagedDir::new(&target)?;
        s.commit()?;
        assert!(!dead.exists(), "a dead run's staging tree stays");
        assert!(
            alive.exists() && other.exists(),
            "a live run's or another target's is removed"
        );
        Ok(())
    }
}
