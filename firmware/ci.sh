#!/usr/bin/env bash
# CI for the firmware (called by .ci/run): format and lints of the firmware crate, then the
# budget check (builds the firmware for both targets, runs the images under QEMU, compares with
# docs/budget.json and memory-layout.md). The firmware-vs-host comparison is
# xtask/tests/firmware.rs, run by `cargo test --workspace`.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
(cd "$repo" && cargo xtask frames)
cd "$repo/firmware"
cargo fmt --check
cargo clippy --release --quiet -- -D warnings
cargo clippy --release --quiet --target thumbv8m.main-none-eabihf -- -D warnings
"$repo/firmware/budget.sh" --check
# The per-function profile (README, Performance) keeps working: one image, a short table.
(cd "$repo" && cargo xtask profile coloradar --top 5)
