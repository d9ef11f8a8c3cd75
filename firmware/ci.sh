#!/usr/bin/env bash
# CI for the firmware (called by .ci/run): format and lints of the firmware crate, then the
# budget check (builds the firmware, runs all four images under QEMU, compares with
# docs/budget.json and memory-layout.md). The firmware-vs-host comparison is
# host-sim/tests/firmware.rs, run by `cargo test --workspace`.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
frame="$repo/firmware/target/frames/coloradar.frame"
(cd "$repo" && cargo run --quiet -p host-sim --example fw_frame -- "$frame")
cd "$repo/firmware"
cargo fmt --check
DBE_FW_COLORADAR_FRAME="$frame" cargo clippy --release --quiet -- -D warnings
"$repo/firmware/budget.sh" --check
