#!/usr/bin/env bash
# Measure the firmware budget and regenerate docs/budget.json and the budget block of
# memory-layout.md; `--check` only compares and exits 1 when either is stale; `--render`
# re-renders the block from docs/budget.json without measuring. Same as `cargo xtask budget`.
#   firmware/budget.sh [--render] [--check]
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
# From the repository root: firmware/.cargo/config.toml would make cargo build the tool for
# the Cortex-M target.
cd "$repo"
exec cargo xtask budget "$@"
