//! README's figures come from the files the measuring commands write: a change of the budget
//! (`firmware/budget.sh` → `docs/budget.json`) fails here until README is updated with it.

use xtask::{self as firmware, thousands, Layout};

fn readme() -> String {
    let path = Layout::this_repo()
        .memory_layout()
        .with_file_name("README.md");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_resources_table_is_the_measured_budget() {
    let layout = Layout::this_repo();
    let budget = firmware::read_budget(&layout.budget_json()).unwrap_or_else(|e| panic!("{e}"));
    let p = budget
        .presets
        .iter()
        .find(|p| p.preset == "coloradar" && p.chain == "dbe")
        .expect("the budget holds the ColoRadar DBE image");
    let bytes = |symbol: &str| {
        p.buffers
            .iter()
            .find(|b| b.symbol == symbol)
            .map(|b| thousands(b.bytes))
            .unwrap_or_else(|| panic!("no {symbol} in the budget"))
    };
    let expected = [
        format!(
            "| static RAM (cube {} + workspace {} + chain tables {} + frontend {} + points {} + \
             DMA buffer {} + ego-velocity {} + other {}) | {} B |",
            bytes("CUBE"),
            bytes("WORKSPACE"),
            bytes("CHAIN"),
            bytes("FRONTEND"),
            bytes("CLOUD"),
            bytes("DMA_CHIRP"),
            bytes("EGO"),
            bytes("other"),
            thousands(p.static_ram_bytes)
        ),
        format!(
            "| peak stack (setup / one frame) | {} / {} B |",
            thousands(p.stack_peak_setup_bytes),
            thousands(p.stack_peak_frame_bytes)
        ),
        format!(
            "| RAM total: fits the AWR1843's 1 MiB radar-cube memory | {} B |",
            thousands(p.ram_total_bytes)
        ),
        format!("| flash | {} B |", thousands(p.flash_bytes)),
        format!(
            "| instructions per frame (guest instructions, not cycles) | {:.1} M |",
            p.instructions_per_frame as f64 / 1e6
        ),
    ];
    let text = readme();
    for line in &expected {
        assert!(
            text.contains(line.as_str()),
            "README lacks the measured line\n{line}"
        );
    }
    assert!(p.ram_total_bytes <= 1 << 20, "the 1 MiB claim");
}

/// README's Performance paragraph quotes the ColoRadar frame stage by stage for both chains.
#[test]
fn the_performance_figures_are_the_measured_budget() {
    let layout = Layout::this_repo();
    let budget = firmware::read_budget(&layout.budget_json()).unwrap_or_else(|e| panic!("{e}"));
    let image = |chain: &str| {
        budget
            .presets
            .iter()
            .find(|p| p.preset.starts_with("coloradar") && p.chain == chain)
            .unwrap_or_else(|| panic!("the budget holds the ColoRadar {chain} image"))
    };
    let (dbe, fft) = (image("dbe"), image("fft"));
    let stage = |name: &str| {
        let n = dbe
            .instructions_per_stage
            .get(name)
            .unwrap_or_else(|| panic!("no stage {name} in the budget"));
        format!("{:.1} M", *n as f64 / 1e6)
    };
    let ego = dbe
        .instructions_per_stage
        .get("ego_velocity")
        .expect("the ego-velocity stage is measured");
    let expected = format!(
        "the DBE chain takes {:.1} M (ingest {}, azimuth Capon {}, CFAR {}, elevation + Doppler {}), \
         the FFT chain {:.1} M; the ego-velocity stage after the points adds {} on that frame ({} points).",
        dbe.instructions_per_frame as f64 / 1e6,
        stage("ingest"),
        stage("azimuth_capon"),
        stage("cfar"),
        stage("elevation_doppler"),
        fft.instructions_per_frame as f64 / 1e6,
        thousands(*ego),
        dbe.points,
    );
    // With the range FFT on an accelerator (`push_range_spectra`).
    let from_spectra = |p: &firmware::PresetBudget, name: &str| {
        *p.instructions_per_stage
            .get(name)
            .unwrap_or_else(|| panic!("no stage {name} in the budget"))
    };
    let ingest = from_spectra(dbe, "ingest_from_spectra");
    // ColoRadar: 128 loops × 3 TX.
    let chirps = 128 * 3;
    let spectra = format!(
        "the ingest from spectra costs {:.1} M instructions per ColoRadar frame ({} per chirp, \
         the block-float store), so the DBE chain's frame is {:.1} M and the FFT chain's {:.1} M",
        ingest as f64 / 1e6,
        thousands(ingest / chirps),
        from_spectra(dbe, "total_from_spectra") as f64 / 1e6,
        from_spectra(fft, "total_from_spectra") as f64 / 1e6,
    );
    // From 16-bit spectra with an exponent (`push_range_blocks`).
    let blocks = from_spectra(dbe, "ingest_from_blocks");
    let blocks = format!(
        "From such blocks the ingest costs {:.2} M instructions per ColoRadar frame ({} per \
         chirp), so the DBE chain's frame is {:.1} M and the FFT chain's {:.1} M",
        blocks as f64 / 1e6,
        thousands(blocks / chirps),
        from_spectra(dbe, "total_from_blocks") as f64 / 1e6,
        from_spectra(fft, "total_from_blocks") as f64 / 1e6,
    );
    // README wraps its lines: compare with whitespace runs as single spaces.
    let flat = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    for expected in [expected, spectra, blocks] {
        assert!(
            flat(&readme()).contains(&flat(&expected)),
            "README's Performance paragraph lacks the measured figures\n{expected}"
        );
    }
}

/// README's table of the Python anchors is `docs/anchors.json` (`cargo xtask anchors`).
#[test]
fn the_anchor_table_is_the_measured_one() {
    let layout = Layout::this_repo();
    let path = xtask::anchors::anchors_json(&layout);
    let anchors = xtask::anchors::read_anchors(&path).unwrap_or_else(|e| panic!("{e}"));
    let chain = |name: &str| {
        anchors
            .chain(name)
            .unwrap_or_else(|| panic!("{} has no chain `{name}`", path.display()))
            .median_ms
    };
    // Python in ms to three significant figures, ours to two decimals, the ratio of the
    // unrounded medians to three significant figures (no decimals from 100 up).
    let python = |ms: f64| {
        if ms >= 100.0 {
            format!("{ms:.0} ms")
        } else {
            format!("{ms:.1} ms")
        }
    };
    let ratio = |r: f64| {
        if r >= 100.0 {
            format!("{r:.0}×")
        } else {
            format!("{r:.1}×")
        }
    };
    let row = |python_chain: &str, ours: &str| {
        let (p, o) = (chain(python_chain), chain(ours));
        format!("| {} | {o:.2} ms | {} |", python(p), ratio(p / o))
    };
    let points = |name: &str| {
        anchors
            .chain(name)
            .and_then(|c| c.points_per_frame)
            .unwrap_or_else(|| panic!("{} has no point count of `{name}`", path.display()))
    };
    let text = readme();
    let flat = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    let counts = format!(
        "the authors' chain gives {:.0} points per frame",
        points("authors_dbe")
    );
    let openradar = format!(
        "OpenRadar's {:.1} with its demo's thresholds",
        points("openradar_fft")
    );
    let pr = &anchors.process;
    let (lo, hi) = pr
        .runs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &r| {
            (lo.min(r), hi.max(r))
        });
    let process = format!(
        "The same command times `dbe process` on {} simulated corridor frames (DBE chain, \
         ColoRadar point files written and flushed, the recording in the page cache, {} \
         threads): median {:.0} frames/s over {} runs ({lo:.0}–{hi:.0})",
        pr.frames,
        pr.threads,
        pr.median_fps,
        pr.runs.len()
    );
    for expected in [counts, openradar, process] {
        assert!(
            flat(&text).contains(&expected),
            "README lacks the measured point count\n{expected}"
        );
    }
    for expected in [row("authors_dbe", "dbe"), row("openradar_fft", "fft")] {
        assert!(
            text.contains(&expected),
            "README's anchor table lacks the measured row end\n{expected}\n(from {}; run `{}`)",
            path.display(),
            xtask::anchors::ANCHORS_COMMAND
        );
    }
}

/// README's "Using the core from C" shows `ffi/c/example.c` complete, as it is.
#[test]
fn the_c_example_in_readme_is_the_tested_program() {
    let layout = Layout::this_repo();
    let path = layout.ffi().join("c").join("example.c");
    let program =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let block = format!("```c\n{program}```");
    assert!(
        readme().contains(&block),
        "README's C program differs from {}",
        path.display()
    );
}
