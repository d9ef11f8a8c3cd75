//! `cargo xtask anchors`: the Python chains issue 13 compares the host figures with, timed on
//! the same simulated ColoRadar frames as `dbe bench`, on this machine, one thread each.
//!
//! ```text
//! python3 -m venv target/anchors/venv; pip install ANCHOR_PACKAGES
//! the authors' code at AUTHORS_COMMIT (--dbe-radar CHECKOUT, or git clone AUTHORS_REPO)
//! dbe simulate --scene host-sim/scenes/corridor.toml --frames 8 ──▶ target/anchors/corridor
//! xtask/anchors/anchors.py ──▶ the authors' DBE chain and OpenRadar's FFT chain, ms per frame
//! dbe bench (the built-in corridor: the same scene and frames) ──▶ ours, ms per frame
//! ──▶ docs/anchors.json
//! ```
//!
//! Not part of CI: it needs the authors' repository (not on PyPI) and a few minutes of pip.
//! README quotes `docs/anchors.json`, and `xtask/tests/readme.rs` keeps the two in step.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::{io_err, run_command, FirmwareError, Layout};

/// The authors' repository (the paper's Python code).
pub const AUTHORS_REPO: &str = "https://github.com/SenseRoboticsLab/DBE-Radar";
/// The authors' last commit (2025-05-16) when the anchors were first measured.
pub const AUTHORS_COMMIT: &str = "36263bff26ec18d5c5f490c0148df92cb5bb5649";
/// What pip installs into the anchors' environment: the authors' requirements that their
/// radar code imports (`numpy<2`: it uses `np.complex_`), and OpenRadar (whose package imports
/// scikit-learn).
pub const ANCHOR_PACKAGES: &[&str] = &[
    "numpy<2",
    "scipy",
    "matplotlib",
    "scikit-learn",
    "openradar==1.0.1",
];
/// Frames of the corridor timed per Python chain (`dbe bench` renders as many distinct ones).
pub const ANCHOR_FRAMES: usize = 8;
/// Frames `dbe bench` times per chain for the anchors.
pub const BENCH_FRAMES: usize = 50;
/// Frames of the corridor recording `dbe process` is timed on (issue 13's throughput goal).
pub const PROCESS_FRAMES: usize = 300;
/// Timed `dbe process` runs (after one untimed run that fills the page cache).
pub const PROCESS_RUNS: usize = 7;
/// The command that regenerates `docs/anchors.json`.
pub const ANCHORS_COMMAND: &str = "cargo xtask anchors";

/// One chain's time per frame.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ChainTime {
    /// `authors_dbe`, `openradar_fft`, `dbe`, `fft`.
    pub chain: String,
    /// What ran: repository, commit or version, function.
    pub code: String,
    /// Median wall time per frame (ms).
    pub median_ms: f64,
    /// Frames timed.
    pub frames: usize,
    /// Points per frame (mean), where the chain reports them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points_per_frame: Option<f64>,
}

/// `docs/anchors.json`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Anchors {
    /// How it was measured.
    pub method: String,
    /// The command that wrote it.
    pub command: String,
    /// The machine's CPU (`/proc/cpuinfo`'s model name).
    pub cpu: String,
    /// Python and its numerical packages.
    pub python: String,
    /// The Python chains.
    pub python_chains: Vec<ChainTime>,
    /// This project's chains (`dbe bench`).
    pub ours: Vec<ChainTime>,
    /// `dbe process` on a recording, all cores.
    pub process: ProcessThroughput,
}

/// Frames per second of `dbe process` (its `run.json`'s `frames_per_second`: reading,
/// processing and writing the ColoRadar point files, from the page cache).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ProcessThroughput {
    /// The command timed.
    pub command: String,
    /// Frames of the recording.
    pub frames: usize,
    /// Threads the machine offers (`std::thread::available_parallelism`).
    pub threads: usize,
    /// Frames per second of each timed run, in run order.
    pub runs: Vec<f64>,
    /// Their median.
    pub median_fps: f64,
}

impl Anchors {
    /// The chain named `name` among both lists.
    pub fn chain(&self, name: &str) -> Option<&ChainTime> {
        self.python_chains
            .iter()
            .chain(&self.ours)
            .find(|c| c.chain == name)
    }
}

/// `docs/anchors.json`.
pub fn anchors_json(layout: &Layout) -> PathBuf {
    layout.repo.join("docs").join("anchors.json")
}

/// Read `docs/anchors.json`.
pub fn read_anchors(path: &Path) -> Result<Anchors, FirmwareError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path, "read"))?;
    serde_json::from_str(&text).map_err(|e| FirmwareError::BadInput {
        path: path.to_path_buf(),
        message: format!("not an anchors file: {e}"),
    })
}

/// The frame row of `chain` in `dbe bench`'s table: `| dbe | **frame** (697 frames/s) | **1.435** | |`.
pub fn bench_frame_ms(table: &str, chain: &str) -> Option<f64> {
    table.lines().find_map(|line| {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        match cells.as_slice() {
            ["", c, stage, ms, ..] if *c == chain && stage.starts_with("**frame**") => {
                ms.trim_matches('*').parse().ok()
            }
            _ => None,
        }
    })
}

/// Run everything and write `docs/anchors.json`; the anchors.
pub fn measure(layout: &Layout, dbe_radar: Option<&Path>) -> Result<Anchors, FirmwareError> {
    let work = layout.repo.join("target").join("anchors");
    std::fs::create_dir_all(&work).map_err(io_err(&work, "create"))?;
    let long = Duration::from_secs(1800);

    // Python with the packages.
    let venv = work.join("venv");
    let python = venv.join("bin").join("python");
    if !python.exists() {
        let mut cmd = Command::new("python3");
        cmd.args(["-m", "venv"]).arg(&venv);
        run_command(cmd, long)?;
    }
    let mut pip = Command::new(&python);
    pip.args(["-m", "pip", "install", "--quiet"])
        .args(ANCHOR_PACKAGES);
    run_command(pip, long)?;

    // The authors' code.
    let checkout = match dbe_radar {
        Some(p) => p.to_path_buf(),
        None => {
            let dir = work.join("DBE-Radar");
            if !dir.exists() {
                let mut clone = Command::new("git");
                clone.args(["clone", "--quiet", AUTHORS_REPO]).arg(&dir);
                run_command(clone, long)?;
            }
            let mut checkout = Command::new("git");
            checkout
                .arg("-C")
                .arg(&dir)
                .args(["checkout", "--quiet", AUTHORS_COMMIT]);
            run_command(checkout, long)?;
            dir
        }
    };
    if !checkout.join("core").join("radar.py").is_file() {
        return Err(FirmwareError::BadInput {
            path: checkout,
            message: format!("not a checkout of {AUTHORS_REPO} (no core/radar.py)"),
        });
    }
    // What was run: the checkout's own commit when it is a git checkout (a `--dbe-radar` folder
    // may be at another one), else the expected one, marked as not verified.
    let commit = {
        let mut head = Command::new("git");
        head.arg("-C").arg(&checkout).args(["rev-parse", "HEAD"]);
        match checkout.join(".git").exists() {
            true => run_command(head, long)?
                .trim()
                .chars()
                .take(7)
                .collect::<String>(),
            false => format!("{} (not a git checkout: unverified)", &AUTHORS_COMMIT[..7]),
        }
    };

    // The frames, and our figures on the same scene.
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut build = Command::new(&cargo);
    build.current_dir(&layout.repo).args([
        "build",
        "--release",
        "--quiet",
        "-p",
        "host-sim",
        "--bin",
        "dbe",
    ]);
    run_command(build, long)?;
    let dbe = layout.repo.join("target").join("release").join("dbe");
    let seq = simulate_corridor(&dbe, layout, &work.join("corridor"), ANCHOR_FRAMES, long)?;

    let python_json = work.join("python.json");
    let mut script = Command::new(&python);
    script
        .arg(layout.repo.join("xtask").join("anchors").join("anchors.py"))
        .arg("--seq")
        .arg(&seq)
        .arg("--calib")
        .arg(
            layout
                .shared
                .join("fixtures")
                .join("coloradar-calib")
                .join("single_chip"),
        )
        .arg("--dbe-radar")
        .arg(&checkout)
        .args(["--commit", &commit, "--out"])
        .arg(&python_json);
    run_command(script, long)?;
    let py: PythonRun = {
        let text = std::fs::read_to_string(&python_json).map_err(io_err(&python_json, "read"))?;
        serde_json::from_str(&text).map_err(|e| FirmwareError::BadInput {
            path: python_json.clone(),
            message: format!("unexpected output of anchors.py: {e}"),
        })?
    };

    let mut bench = Command::new(&dbe);
    bench.args(["bench", "--frames", &BENCH_FRAMES.to_string()]);
    let table = run_command(bench, long)?;
    let ours = ["dbe", "fft"]
        .into_iter()
        .map(|chain| {
            let ms = bench_frame_ms(&table, chain).ok_or_else(|| FirmwareError::Output {
                line: 0,
                message: format!("`dbe bench` printed no frame row for `{chain}`:\n{table}"),
            })?;
            Ok(ChainTime {
                chain: chain.into(),
                code: format!("dbe-radar, `dbe bench --frames {BENCH_FRAMES}`, {chain} chain"),
                median_ms: ms,
                frames: BENCH_FRAMES,
                points_per_frame: None,
            })
        })
        .collect::<Result<Vec<_>, FirmwareError>>()?;

    let process = time_process(&dbe, layout, &work, long)?;

    let anchors = Anchors {
        method: format!(
            "simulated corridor frames (host-sim/scenes/corridor.toml, the `dbe bench` default), \
             ColoRadar preset; every chain on one thread (BLAS threads pinned to 1), median wall \
             time per frame; the Python chains over {ANCHOR_FRAMES} frames after one warm-up, \
             ours over {BENCH_FRAMES} after two"
        ),
        command: ANCHORS_COMMAND.into(),
        cpu: cpu_model(),
        python: format!(
            "Python {}, numpy {}, scipy {}",
            py.python, py.numpy, py.scipy
        ),
        python_chains: py
            .chains
            .into_iter()
            .map(|c| ChainTime {
                chain: c.chain,
                code: c.code,
                median_ms: c.median_ms,
                frames: c.frames,
                points_per_frame: Some(c.points_per_frame),
            })
            .collect(),
        ours,
        process,
    };
    let path = anchors_json(layout);
    let text = serde_json::to_string_pretty(&anchors).expect("plain data serialises") + "\n";
    std::fs::write(&path, text).map_err(io_err(&path, "write"))?;
    Ok(anchors)
}

/// `dbe simulate` of `frames` frames of the corridor scene (`dbe bench`'s) into `seq`,
/// replacing what is there; `seq`.
fn simulate_corridor(
    dbe: &Path,
    layout: &Layout,
    seq: &Path,
    frames: usize,
    timeout: Duration,
) -> Result<PathBuf, FirmwareError> {
    if seq.exists() {
        std::fs::remove_dir_all(seq).map_err(io_err(seq, "remove"))?;
    }
    let scene = layout
        .repo
        .join("host-sim")
        .join("scenes")
        .join("corridor.toml");
    let mut simulate = Command::new(dbe);
    simulate
        .arg("simulate")
        .arg("--scene")
        .arg(scene)
        .args(["--frames", &frames.to_string(), "--out"])
        .arg(seq);
    run_command(simulate, timeout)?;
    Ok(seq.to_path_buf())
}

/// `dbe process` on [`PROCESS_FRAMES`] simulated corridor frames, [`PROCESS_RUNS`] times.
fn time_process(
    dbe: &Path,
    layout: &Layout,
    work: &Path,
    timeout: Duration,
) -> Result<ProcessThroughput, FirmwareError> {
    let seq = simulate_corridor(
        dbe,
        layout,
        &work.join("corridor-process"),
        PROCESS_FRAMES,
        timeout,
    )?;
    let out = work.join("process-out");
    let mut runs = Vec::with_capacity(PROCESS_RUNS);
    for run in 0..=PROCESS_RUNS {
        if out.exists() {
            std::fs::remove_dir_all(&out).map_err(io_err(&out, "remove"))?;
        }
        let mut process = Command::new(dbe);
        process.arg("process").arg(&seq).arg("--out").arg(&out);
        run_command(process, timeout)?;
        let record = out.join("run.json");
        let text = std::fs::read_to_string(&record).map_err(io_err(&record, "read"))?;
        let fps = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| {
                v.get("frames_per_second")
                    .and_then(serde_json::Value::as_f64)
            })
            .ok_or_else(|| FirmwareError::BadInput {
                path: record.clone(),
                message: "no number `frames_per_second`".into(),
            })?;
        // Run 0 fills the page cache and is not counted.
        if run > 0 {
            runs.push(fps);
        }
    }
    std::fs::remove_dir_all(&out).map_err(io_err(&out, "remove"))?;
    let mut sorted = runs.clone();
    sorted.sort_by(f64::total_cmp);
    Ok(ProcessThroughput {
        command: format!("dbe process <{PROCESS_FRAMES} corridor frames> --out <dir> (DBE chain, ColoRadar point files)"),
        frames: PROCESS_FRAMES,
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        median_fps: sorted[sorted.len() / 2],
        runs,
    })
}

/// The table `cargo xtask anchors` prints.
pub fn render(a: &Anchors) -> String {
    let mut s = format!(
        "{}\n{}\n\n| chain | ms per frame |\n|---|---:|\n",
        a.cpu, a.python
    );
    for c in a.python_chains.iter().chain(&a.ours) {
        s += &format!("| {} ({}) | {:.3} |\n", c.chain, c.code, c.median_ms);
    }
    s += &format!(
        "\n`dbe process`, {} frames, {} threads: median {:.0} frames/s over {:?}\n",
        a.process.frames, a.process.threads, a.process.median_fps, a.process.runs
    );
    s
}

/// What `anchors.py` writes.
#[derive(Deserialize)]
struct PythonRun {
    python: String,
    numpy: String,
    scipy: String,
    chains: Vec<PythonChain>,
}

#[derive(Deserialize)]
struct PythonChain {
    chain: String,
    code: String,
    frames: usize,
    median_ms: f64,
    points_per_frame: f64,
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frame_row_of_each_chain_is_found() {
        let table = "| chain | stage | ms | share |\n|---|---|---:|---:|\n\
                     | dbe | cfar | 0.130 | 9 % |\n\
                     | dbe | **frame** (697 frames/s) | **1.435** | |\n\
                     | fft | **frame** (704 frames/s) | **1.420** | |\n";
        assert_eq!(bench_frame_ms(table, "dbe"), Some(1.435));
        assert_eq!(bench_frame_ms(table, "fft"), Some(1.420));
        assert_eq!(bench_frame_ms(table, "other"), None);
        assert_eq!(bench_frame_ms("| dbe | cfar | 0.130 | 9 % |", "dbe"), None);
    }
}
