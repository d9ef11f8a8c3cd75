//! `cargo xtask profile`: where a firmware image's guest instructions go, function by function.
//!
//! The budget times stages; this attributes every executed instruction to a source function,
//! to choose what to speed up (issue 13). Method:
//!
//! 1. the image is built as the budget builds it, plus full debug info (`debug = 2`; the code
//!    is the same, only its layout may move), into `firmware/target/profile`;
//! 2. QEMU runs it with `-d exec,nochain,in_asm`: every translated block is logged once with
//!    its instructions (`IN:`), every execution of a block as a `Trace` line with its host
//!    address and guest PC; the log is read from QEMU's standard error as it comes, never
//!    written to disk (a frame logs some 3 GB);
//! 3. the first `Trace` after an `IN:` listing names the host address of that translation, so
//!    each execution counts once for every instruction address of its block;
//! 4. `arm-none-eabi-addr2line -f -i` names every address's chain of inlined functions; each
//!    counts for the innermost function of the core crate (`dbe_radar::…`) in that chain, else
//!    the outermost one. Instructions the optimiser interleaves count for the function their
//!    line belongs to, so neighbouring inlined helpers share their loop's count roughly.
//!
//! The clock calibration loop (`cortex_m::asm::delay`) and the stack painting
//! (`dbe_firmware::stack`) are left out; setup, the frame and the printing are in. Counts are
//! QEMU's, so they agree with the budget's only to within its per-block accounting.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::*;

/// The addr2line of the cross binutils (Debian package `binutils-arm-none-eabi`, pulled in by
/// `gcc-arm-none-eabi`).
const ADDR2LINE: &str = "arm-none-eabi-addr2line";

/// Functions whose instructions are not the chain's: the clock calibration's delay loop and
/// the stack painting.
const EXCLUDED: [&str; 2] = ["cortex_m::asm::delay", "dbe_firmware::stack"];

/// Executions per guest instruction address.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct PcCounts {
    /// Guest instruction address → times executed.
    pub by_pc: HashMap<u32, u64>,
}

impl PcCounts {
    /// Every instruction counted.
    pub fn total(&self) -> u64 {
        self.by_pc.values().sum()
    }
}

/// Read a QEMU `-d exec,nochain,in_asm` log (see the module docs): each block execution counts
/// once for every instruction of the block's translation.
pub fn count_log(log: impl BufRead) -> std::io::Result<PcCounts> {
    // Host address of a translation → its instruction addresses and executions so far.
    let mut blocks: HashMap<String, (Vec<u32>, u64)> = HashMap::new();
    let mut counts = PcCounts::default();
    let flush = |pcs: &[u32], n: u64, counts: &mut PcCounts| {
        for &pc in pcs {
            *counts.by_pc.entry(pc).or_default() += n;
        }
    };
    // The block being listed, then the one waiting for its first execution (which names its
    // host address).
    let (mut listing, mut pending): (Option<Vec<u32>>, Option<Vec<u32>>) = (None, None);
    for line in log.lines() {
        let line = line?;
        if let Some(rest) = line.strip_prefix("Trace ") {
            // `Trace 0: 0x7f9d18000100 [00800408/00000400/00000110/ff020200] Reset`
            let mut fields = rest.split_whitespace();
            let (Some(_), Some(host), Some(flags)) = (fields.next(), fields.next(), fields.next())
            else {
                continue;
            };
            if let Some(pcs) = pending.take() {
                // A new translation at this host address: the old one's executions are final.
                if let Some((old, n)) = blocks.insert(host.to_owned(), (pcs, 0)) {
                    flush(&old, n, &mut counts);
                }
            }
            match blocks.get_mut(host) {
                Some((_, n)) => *n += 1,
                None => {
                    // Never listed: count its first instruction only.
                    if let Some(pc) = flags
                        .trim_start_matches('[')
                        .split('/')
                        .nth(1)
                        .and_then(|pc| u32::from_str_radix(pc, 16).ok())
                    {
                        *counts.by_pc.entry(pc).or_default() += 1;
                    }
                }
            }
        } else if line.starts_with("IN:") {
            listing = Some(Vec::new());
        } else if let Some(pcs) = listing.as_mut() {
            if let Some(addr) = line.strip_prefix("0x") {
                if let Some(pc) = addr
                    .split(':')
                    .next()
                    .and_then(|a| u32::from_str_radix(a, 16).ok())
                {
                    pcs.push(pc);
                }
            } else if line.trim().is_empty() {
                pending = listing.take();
            }
        }
    }
    for (pcs, n) in blocks.values() {
        flush(pcs, *n, &mut counts);
    }
    Ok(counts)
}

/// The chain of inlined functions at each PC, innermost first, from `addr2line -f -i -C -a`.
pub fn parse_addr2line(output: &str) -> HashMap<u32, Vec<String>> {
    let mut chains: HashMap<u32, Vec<String>> = HashMap::new();
    let mut current: Option<u32> = None;
    // After an address line, function and location lines alternate.
    let mut is_function = true;
    for line in output.lines() {
        if let Some(hex) = line.strip_prefix("0x") {
            current = u32::from_str_radix(hex, 16).ok();
            is_function = true;
            if let Some(pc) = current {
                chains.entry(pc).or_default();
            }
        } else if let Some(pc) = current {
            if is_function {
                chains.entry(pc).or_default().push(line.to_owned());
            }
            is_function = !is_function;
        }
    }
    chains
}

/// Instructions per function: each PC's count goes to the innermost `dbe_radar` function of
/// its chain (else the outermost one: a soft-float routine rather than the integer helper
/// inlined into it); PCs inside the clock calibration and the stack painting are dropped.
/// Sorted by count, largest first.
pub fn attribute(counts: &PcCounts, chains: &HashMap<u32, Vec<String>>) -> Vec<(String, u64)> {
    let mut by_function: HashMap<String, u64> = HashMap::new();
    for (pc, &n) in &counts.by_pc {
        let chain = chains.get(pc).map(Vec::as_slice).unwrap_or(&[]);
        if chain.iter().any(|f| EXCLUDED.iter().any(|x| f.contains(x))) {
            continue;
        }
        let name = chain
            .iter()
            .find(|f| f.contains("dbe_radar::"))
            .or_else(|| chain.last())
            .map_or_else(|| format!("0x{pc:08x}"), |f| short_name(f));
        *by_function.entry(name).or_default() += n;
    }
    let mut rows: Vec<(String, u64)> = by_function.into_iter().collect();
    rows.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    rows
}

/// A function's demangled name without generic arguments (`Dbe<…>::resolve` →
/// `Dbe::resolve`; a qualified path keeps its `<… as …>`: `<Complex as FftValue>::times`).
fn short_name(f: &str) -> String {
    let qualified = f.starts_with('<');
    let mut out = String::new();
    let mut depth = 0usize;
    for c in f.chars() {
        match c {
            '<' => {
                depth += 1;
                if qualified && depth == 1 {
                    out.push(c);
                }
            }
            '>' => {
                if qualified && depth == 1 {
                    out.push(c);
                }
                depth = depth.saturating_sub(1);
            }
            _ if depth == 0 || (qualified && depth == 1) => out.push(c),
            _ => {}
        }
    }
    out
}

/// Build `image` with debug info, run it on the Cortex-M4F board with QEMU's execution log,
/// and print the instructions of the `top` largest functions.
pub fn profile(layout: &Layout, image: Image, top: usize) -> Result<String, FirmwareError> {
    check_tools()?;
    if Command::new(ADDR2LINE)
        .arg("--version")
        .stdout(Stdio::null())
        .status()
        .map_or(true, |s| !s.success())
    {
        return Err(FirmwareError::ToolMissing {
            tool: ADDR2LINE.into(),
            hint: "apt-get install binutils-arm-none-eabi".into(),
        });
    }
    write_frames(layout)?;
    let dir = layout.firmware().join("target/profile");
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.args(["build", "--release", "--quiet", "--target", TARGET, "--bin"])
        .arg(image.name())
        .current_dir(layout.firmware())
        .env("DBE_FW_FRAMES", layout.frames_dir())
        .env("CARGO_ENCODED_RUSTFLAGS", firmware_rustflags(&layout.repo))
        .env("CARGO_PROFILE_RELEASE_DEBUG", "2")
        .env("CARGO_TARGET_DIR", &dir)
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS");
    run_command(cmd, std::time::Duration::from_secs(1800))?;
    let elf = dir.join(TARGET).join("release").join(image.name());

    let (counts, output) = run_logged(&elf)?;
    let mut pcs: Vec<u32> = counts.by_pc.keys().copied().collect();
    pcs.sort_unstable();
    let chains = symbolize(&elf, &pcs)?;
    let rows = attribute(&counts, &chains);
    let total: u64 = rows.iter().map(|r| r.1).sum();

    let mut text = format!(
        "{image} on {board}: {total} guest instructions outside the clock calibration and the \
         stack painting (setup, one frame, printing); the firmware's own stage lines:\n",
        board = Board::An386.machine()
    );
    for line in output.lines().filter(|l| l.starts_with("S ")) {
        text.push_str(&format!("  {line}\n"));
    }
    text.push_str(
        "\n| instructions | share | function (innermost of the core crate) |\n|---:|---:|---|\n",
    );
    for (name, n) in rows.iter().take(top) {
        text.push_str(&format!(
            "| {n} | {:.1} % | `{name}` |\n",
            100.0 * *n as f64 / total.max(1) as f64
        ));
    }
    Ok(text)
}

/// Run `elf` under QEMU with its execution log on QEMU's standard error, read as it comes;
/// the counts and the firmware's standard output (read on a thread of its own, so that
/// neither pipe can fill up and stall QEMU).
fn run_logged(elf: &Path) -> Result<(PcCounts, String), FirmwareError> {
    let mut args = Board::An386.qemu_args(elf);
    args.extend(["-d", "exec,nochain,in_asm"].map(Into::into));
    let mut child = Command::new(QEMU)
        .args(&args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(io_err(Path::new(QEMU), "start"))?;
    let (Some(mut stdout), Some(stderr)) = (child.stdout.take(), child.stderr.take()) else {
        return Err(FirmwareError::Usage("QEMU's pipes were not opened".into()));
    };
    let output = std::thread::spawn(move || {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut stdout, &mut text).map(|_| text)
    });
    let counts = count_log(BufReader::with_capacity(1 << 20, stderr))
        .map_err(io_err(Path::new(QEMU), "read the log of"));
    let status = child.wait().map_err(io_err(Path::new(QEMU), "wait for"))?;
    let stdout = output
        .join()
        .map_err(|_| FirmwareError::Usage("reading QEMU's output panicked".into()))?
        .map_err(io_err(Path::new(QEMU), "read the output of"))?;
    let counts = counts?;
    if !status.success() || !stdout.lines().any(|l| l == "E ok") {
        return Err(FirmwareError::Command {
            command: format!("{QEMU} … {}", elf.display()),
            status: status.to_string(),
            stderr: stdout,
        });
    }
    Ok((counts, stdout))
}

/// `addr2line -f -i -C -a` of `pcs` in `elf`, addresses on its standard input.
fn symbolize(elf: &Path, pcs: &[u32]) -> Result<HashMap<u32, Vec<String>>, FirmwareError> {
    let input: String = pcs.iter().map(|pc| format!("0x{pc:x}\n")).collect();
    let path: PathBuf =
        std::env::temp_dir().join(format!("dbe-profile-{}.txt", std::process::id()));
    std::fs::write(&path, input).map_err(io_err(&path, "write"))?;
    let stdin = std::fs::File::open(&path).map_err(io_err(&path, "open"))?;
    let out = Command::new(ADDR2LINE)
        .args(["-f", "-i", "-C", "-a", "-e"])
        .arg(elf)
        .stdin(stdin)
        .output()
        .map_err(io_err(Path::new(ADDR2LINE), "run"))?;
    let _ = std::fs::remove_file(&path);
    if !out.status.success() {
        return Err(FirmwareError::Command {
            command: format!("{ADDR2LINE} -e {}", elf.display()),
            status: out.status.to_string(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        });
    }
    Ok(parse_addr2line(&String::from_utf8_lossy(&out.stdout)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Instructions come from each translation's listing, executions from the `Trace` lines,
    /// and a re-translation at the same host address counts for its own instructions from then
    /// on.
    #[test]
    fn each_execution_counts_for_every_instruction_of_its_block() {
        let log = "\
----------------
IN: Reset
0x00000400:  f023 fc64  bl       #0x23ccc

Trace 0: 0x7f0000000100 [00800408/00000400/00000110/ff020200] Reset
----------------
IN: loop
0x0000040a:  4281       cmp      r1, r0
0x0000040c:  d001       beq      #0x412
0x0000040e:  c004       stm      r0!, {r2}

Trace 0: 0x7f0000000200 [00800408/0000040a/00000110/ff020200] loop
Trace 0: 0x7f0000000200 [00800408/0000040a/00000110/ff020200] loop
Trace 0: 0x7f0000000100 [00800408/00000400/00000110/ff020200] Reset
----------------
IN: other
0x00000500:  4281       cmp      r1, r0
0x00000502:  d001       beq      #0x412

Trace 0: 0x7f0000000100 [00800408/00000500/00000110/ff020200] other
Trace 0: 0x7f0000000100 [00800408/00000500/00000110/ff020200] other
";
        let counts = count_log(log.as_bytes()).expect("in memory");
        // Reset's one instruction twice; the loop's three instructions twice; the block that
        // took over Reset's host address: its two instructions twice.
        assert_eq!(counts.by_pc.get(&0x400), Some(&2));
        for pc in [0x40a, 0x40c, 0x40e] {
            assert_eq!(counts.by_pc.get(&pc), Some(&2), "{pc:x}");
        }
        assert_eq!(counts.by_pc.get(&0x500), Some(&2));
        assert_eq!(counts.by_pc.get(&0x502), Some(&2));
        assert_eq!(counts.total(), 12);
    }

    /// Inlined chains are read innermost first; a PC counts for the innermost core-crate
    /// function, the calibration loop is dropped, generic arguments are cut.
    #[test]
    fn pcs_go_to_the_innermost_core_function() {
        let out = "\
0x00000400
core::ptr::read_volatile
/rustc/ptr.rs:1
dbe_radar::cube::Cube<_, _, _>::store
/src/cube.rs:200
coloradar::main
/src/bin/coloradar.rs:3
0x00000500
cortex_m::asm::delay
/cortex-m/asm.rs:10
dbe_firmware::clock::calibrate
/src/clock.rs:5
0x00000600
__adddf3
??:0
";
        let chains = parse_addr2line(out);
        assert_eq!(chains[&0x400].len(), 3);
        assert_eq!(
            short_name("<num_complex::Complex<f32> as dbe_radar::fft::FftValue>::times"),
            "<num_complex::Complex as dbe_radar::fft::FftValue>::times"
        );
        let counts = PcCounts {
            by_pc: HashMap::from([(0x400, 10), (0x500, 1000), (0x600, 7), (0x700, 1)]),
        };
        let rows = attribute(&counts, &chains);
        assert_eq!(
            rows,
            vec![
                ("dbe_radar::cube::Cube::store".to_owned(), 10),
                ("__adddf3".to_owned(), 7),
                ("0x00000700".to_owned(), 1),
            ]
        );
    }
}
