#!/usr/bin/env bash
# Build the firmware and run one image under QEMU, printing its output lines.
#   firmware/run.sh [coloradar|iwr6843|coloradar-fft|iwr6843-fft] [an386|an500]
# coloradar, iwr6843: the DBE chain; the -fft images: the FFT baseline chain on the same frame.
# an386 = Cortex-M4F (the budget's board), an500 = Cortex-M7. Needs qemu-system-arm and
# `rustup target add thumbv7em-none-eabihf`; ../shared beside the repository for the TI capture.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
preset="${1:-coloradar}"
board="${2:-an386}"
case "$preset" in
    coloradar|iwr6843|coloradar-fft|iwr6843-fft) ;;
    *) echo "unknown image '$preset' (coloradar, iwr6843, coloradar-fft, iwr6843-fft)" >&2; exit 2 ;;
esac
case "$board" in
    an386) machine=mps2-an386; cpu=cortex-m4 ;;
    an500) machine=mps2-an500; cpu=cortex-m7 ;;
    *) echo "unknown board '$board' (an386, an500)" >&2; exit 2 ;;
esac
frame="$repo/firmware/target/frames/coloradar.frame"
(cd "$repo" && cargo run --quiet -p host-sim --example fw_frame -- "$frame")
# The same flags as host_sim::firmware::build (source paths remapped: a path-independent image).
sep=$'\x1f'
export CARGO_ENCODED_RUSTFLAGS="-C${sep}link-arg=-Tlink.x${sep}--remap-path-prefix=$repo=/dbe-radar${sep}--remap-path-prefix=${CARGO_HOME:-$HOME/.cargo}=/cargo"
(cd "$repo/firmware" && DBE_FW_COLORADAR_FRAME="$frame" cargo build --release --quiet)
# -icount shift=0,sleep=off: 1 guest instruction = 1 ns of virtual time, reproducibly (README.md).
exec qemu-system-arm -machine "$machine" -cpu "$cpu" -icount shift=0,sleep=off \
    -semihosting-config enable=on,target=native -nographic -monitor none -serial none \
    -kernel "$repo/firmware/target/thumbv7em-none-eabihf/release/$preset"
