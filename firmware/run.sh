#!/usr/bin/env bash
# Build the firmware and run one image under QEMU, printing its output lines. Same as
# `cargo xtask firmware IMAGE --board BOARD`.
#   firmware/run.sh [coloradar|iwr6843|coloradar-fft|iwr6843-fft] [an386|an500]
# coloradar, iwr6843: the DBE chain; the -fft images: the FFT baseline chain on the same frame.
# an386 = Cortex-M4F (the budget's board), an500 = Cortex-M7. Needs qemu-system-arm and
# `rustup target add thumbv7em-none-eabihf`; ../shared beside the repository for the TI capture.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
cd "$repo"
exec cargo xtask firmware "${1:-coloradar}" --board "${2:-an386}"
