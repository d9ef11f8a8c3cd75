//! The budget: measurement, `docs/budget.json`, the Markdown block of `memory-layout.md`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use host_sim::core_run::Chain;

use crate::Preset;
use host_sim::frame::AdcFrame;

use crate::*;
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
    /// The images on every core: instructions per frame and the clock 10 frames per second
    /// need under a stated cycles-per-instruction assumption.
    #[serde(default)]
    pub cores: Vec<CoreBudget>,
}

/// One core the images ran on.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CoreBudget {
    /// The core (`Cortex-M4F`, `Cortex-M7`).
    pub core: String,
    /// QEMU board and CPU it was measured on.
    pub board: String,
    /// The images' Rust target.
    pub target: String,
    /// Assumed cycles per instruction of this chain's code on this core (not measured:
    /// QEMU models no pipeline; see [`CORES`]).
    pub assumed_cpi: f64,
    /// Why that CPI.
    pub cpi_basis: String,
    /// Instructions per frame of each image on this core (image name → count).
    pub instructions_per_frame: BTreeMap<String, u64>,
    /// Clock for 10 frames per second: instructions × 10 × CPI, MHz (image name → MHz).
    pub clock_mhz_for_10_fps: BTreeMap<String, f64>,
    /// The images of this core's own build (image name → figures), when its target is not
    /// the Cortex-M4F's (the Cortex-M33); empty when the core runs the M4F's images.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub images: BTreeMap<String, CoreImage>,
}

/// One image built for a core's own target: memory and instructions, measured as the M4F's.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CoreImage {
    /// Static RAM (`.data + .bss`), bytes.
    pub static_ram_bytes: u64,
    /// Stack peak over the run, bytes.
    pub stack_peak_bytes: u64,
    /// Code memory without the embedded test frame, bytes.
    pub flash_bytes: u64,
    /// Instructions per stage.
    pub instructions_per_stage: BTreeMap<String, u64>,
}

/// The cores of the budget: board, and the CPI assumed for the chains' code (FPU and
/// load-heavy loops, zero-wait memory). Cortex-M4F: single-issue 3-stage pipeline, FPU
/// arithmetic 1 cycle, loads 2 (1 when pipelined), VDIV/VSQRT 14, taken branches 2–4: 1.25.
/// Cortex-M7: dual-issue 6-stage pipeline with TCM, about 1.5× the M4's work per cycle
/// (Arm's CoreMark/MHz, 5.01 vs 3.42): 0.75 (rounded to the safe side of 1.25 / 1.47).
/// Cortex-M33: 3-stage pipeline with limited dual issue of 16-bit instructions, the M4F's FPU
/// timings, about 1.18× the M4's work per cycle (CoreMark/MHz 4.02 vs 3.42): 1.1 (the safe
/// side of 1.25 / 1.18 = 1.06).
pub const CORES: [(&str, Board, f64, &str); 3] = [
    (
        "Cortex-M4F",
        Board::An386,
        1.25,
        "single-issue, FPU ops 1 cycle, loads 2 (1 pipelined), VDIV/VSQRT 14, taken branches 2–4; zero-wait memory",
    ),
    (
        "Cortex-M7",
        Board::An500,
        0.75,
        "dual-issue, ~1.5× the M4's work per cycle (CoreMark/MHz 5.01 vs 3.42); TCM, no cache misses",
    ),
    (
        "Cortex-M33",
        Board::An505,
        1.1,
        "limited dual issue, the M4F's FPU timings, ~1.18× the M4's work per cycle (CoreMark/MHz 4.02 vs 3.42); zero-wait memory",
    ),
];

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
            "simulated (xtask::frames::coloradar_frame): {} point scatterers, noise σ = {} LSB",
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
    let mut cores = Vec::new();
    for (core, board, cpi, basis) in CORES {
        let mut counts = BTreeMap::new();
        let mut images = BTreeMap::new();
        for m in &measurements {
            let n = if board == Board::An386 {
                m.budget.instructions_per_frame
            } else {
                let run = parse_output(&run(layout, m.image, board)?)?;
                // Points bit for bit: another core (M7) or another build of the same code
                // for another ISA (M33) must not change a number.
                if run.points != m.run.points || run.stats != m.run.stats {
                    return Err(FirmwareError::Output {
                        line: 0,
                        message: format!("{} on {core}: points differ from the M4F's", m.image),
                    });
                }
                if board.target() != TARGET {
                    let elf = elf_memory(&layout.elf_for(m.image, board.target()))?;
                    images.insert(
                        m.image.name().to_string(),
                        CoreImage {
                            static_ram_bytes: elf.static_ram(),
                            stack_peak_bytes: run.stack_setup.max(run.stack_frame),
                            flash_bytes: elf.flash(),
                            instructions_per_stage: run.stages.clone(),
                        },
                    );
                }
                run.stages.get("total").copied().unwrap_or(0)
            };
            counts.insert(m.image.name().to_string(), n);
        }
        cores.push(CoreBudget {
            core: core.into(),
            board: format!("{} ({})", board.machine(), board.cpu()),
            target: board.target().into(),
            assumed_cpi: cpi,
            cpi_basis: basis.into(),
            clock_mhz_for_10_fps: counts
                .iter()
                .map(|(k, &n)| (k.clone(), clock_mhz(n, cpi)))
                .collect(),
            instructions_per_frame: counts,
            images,
        });
    }
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
        cores,
    };
    Ok((budget, measurements, frame))
}

/// MHz for 10 frames per second of `instructions` per frame at `cpi` cycles each, rounded to
/// whole MHz (the assumption is not finer than that).
pub fn clock_mhz(instructions: u64, cpi: f64) -> f64 {
    (instructions as f64 * 10.0 * cpi / 1e6).round()
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
        (
            "ego_velocity",
            "ego-velocity from the points (`EgoEstimator`, not in the frame)",
        ),
        ("total", "**per frame** (ingest + process)"),
        (
            "ingest_from_spectra",
            "ingest from range spectra of an FFT accelerator (`push_range_spectra`, all K·TX chirps)",
        ),
        (
            "total_from_spectra",
            "per frame with the range FFT off the core (ingest from spectra + process)",
        ),
        (
            "ingest_from_blocks",
            "ingest from 16-bit range spectra with an exponent (`push_range_blocks`, all K·TX chirps)",
        ),
        (
            "total_from_blocks",
            "per frame with a 16-bit range FFT off the core (ingest from blocks + process)",
        ),
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
        (
            "ego_velocity",
            "ego-velocity from the points (`EgoEstimator`, not in the frame)",
        ),
        ("total", "**per frame** (ingest + process)"),
        (
            "ingest_from_spectra",
            "ingest from range spectra of an FFT accelerator (`push_range_spectra`, all K·TX chirps)",
        ),
        (
            "total_from_spectra",
            "per frame with the range FFT off the core (ingest from spectra + process)",
        ),
        (
            "ingest_from_blocks",
            "ingest from 16-bit range spectra with an exponent (`push_range_blocks`, all K·TX chirps)",
        ),
        (
            "total_from_blocks",
            "per frame with a 16-bit range FFT off the core (ingest from blocks + process)",
        ),
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
    if !budget.cores.is_empty() {
        cores_table(&mut s, budget);
    }
    s
}

/// Per core: the images' instructions per frame (measured on that core's board) and the clock
/// that 10 frames per second need under the core's assumed CPI (derived, not measured).
fn cores_table(s: &mut String, budget: &Budget) {
    let _ = writeln!(
        s,
        "\nPer core: instructions per frame measured on that core's QEMU board (the Cortex-M4F \
         and M7 run the same `{TARGET}` images, so their counts agree; the Cortex-M33 runs its \
         own `{TARGET_V8M}` build, below), and the clock 10 frames per second need, **derived** \
         as instructions × 10 × an assumed cycles per instruction (CPI; QEMU models no \
         pipeline, so cycles are not measured); each cell is instructions per frame → MHz for \
         10 frames per second. Every core's points equal the M4F's bit for bit.\n"
    );
    let names: Vec<&str> = budget.presets.iter().map(|p| p.preset.as_str()).collect();
    let _ = writeln!(
        s,
        "| core, QEMU board | assumed CPI | {} |",
        names
            .iter()
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    let _ = writeln!(s, "|---|---:|{}", "---:|".repeat(names.len()));
    for c in &budget.cores {
        let cells: Vec<String> = names
            .iter()
            .map(|n| {
                let i = c.instructions_per_frame.get(*n).copied().unwrap_or(0);
                let mhz = c.clock_mhz_for_10_fps.get(*n).copied().unwrap_or(0.0);
                format!("{:.1} M → {mhz:.0} MHz", i as f64 / 1e6)
            })
            .collect();
        let _ = writeln!(
            s,
            "| {}, {} | {} | {} |",
            c.core,
            c.board,
            c.assumed_cpi,
            cells.join(" | ")
        );
    }
    s.push('\n');
    for c in &budget.cores {
        let _ = writeln!(s, "- {} CPI {}: {}.", c.core, c.assumed_cpi, c.cpi_basis);
    }
    for c in budget.cores.iter().filter(|c| !c.images.is_empty()) {
        core_images_table(s, c, &names);
    }
}

/// The figures of a core's own build (`CoreBudget::images`), one column per image.
fn core_images_table(s: &mut String, c: &CoreBudget, names: &[&str]) {
    let _ = writeln!(
        s,
        "\n{} (`{}`, its own build of the same images on {}): memory and instructions, \
         measured as above.\n",
        c.core, c.target, c.board
    );
    let _ = writeln!(s, "| {} | {} |", c.core, names.join(" | "));
    let _ = writeln!(s, "|---|{}", "---:|".repeat(names.len()));
    let mut row = |label: &str, cell: &dyn Fn(&CoreImage) -> u64| {
        let cells: Vec<String> = names
            .iter()
            .map(|n| c.images.get(*n).map_or("–".into(), |i| thousands(cell(i))))
            .collect();
        let _ = writeln!(s, "| {label} | {} |", cells.join(" | "));
    };
    row("static RAM (bytes)", &|i| i.static_ram_bytes);
    row("stack peak (bytes)", &|i| i.stack_peak_bytes);
    row("flash without the test frame (bytes)", &|i| i.flash_bytes);
    for (label, stage) in [
        ("setup (instructions, once)", "setup"),
        ("ingest: all K·TX chirps (instructions)", "ingest"),
        ("`process` (instructions)", "process"),
        ("**per frame** (instructions)", "total"),
    ] {
        row(label, &|i| {
            i.instructions_per_stage.get(stage).copied().unwrap_or(0)
        });
    }
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

/// Whether two `qemu-system-arm --version` lines name the same upstream QEMU: equal up to the
/// first space-separated token after "version" (`7.2.22`), whatever the distribution's package
/// revision in parentheses (Debian rebuilds the same source as `…+b2`, `…+b3`, and a fresh CI
/// machine gets whichever is current). Instruction counts under `-icount` follow the upstream
/// translator; a different upstream version is still a difference.
pub fn same_qemu(a: &str, b: &str) -> bool {
    let upstream = |v: &str| -> Option<String> {
        let mut words = v.split_whitespace();
        words.by_ref().find(|w| *w == "version")?;
        words.next().map(str::to_string)
    };
    a == b || upstream(a).is_some_and(|x| Some(x) == upstream(b))
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
    // differently (see the constant), and a QEMU of the same upstream version is the same
    // emulator (see `same_qemu`); compare everything else exactly.
    let adjusted = measured.map(|m| {
        let mut m = m.clone();
        if let Some(old) = committed.as_ref() {
            if same_qemu(&m.qemu, &old.qemu) {
                m.qemu = old.qemu.clone();
            }
            for (p, q) in m.presets.iter_mut().zip(old.presets.iter()) {
                if p.preset == q.preset
                    && p.flash_bytes.abs_diff(q.flash_bytes) <= FLASH_TOLERANCE_BYTES
                {
                    p.flash_bytes = q.flash_bytes;
                }
            }
            for (c, d) in m.cores.iter_mut().zip(old.cores.iter()) {
                for (name, img) in c.images.iter_mut() {
                    let Some(o) = d.images.get(name) else {
                        continue;
                    };
                    if img.flash_bytes.abs_diff(o.flash_bytes) <= FLASH_TOLERANCE_BYTES {
                        img.flash_bytes = o.flash_bytes;
                    }
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
