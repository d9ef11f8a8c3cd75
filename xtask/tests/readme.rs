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
