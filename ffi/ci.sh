#!/usr/bin/env bash
# CI checks of the C API crate (its own workspace, so the root's fmt and clippy do not see it):
# format, lints for the host and the Cortex-M4F, docs. Its header and C programs are tested by
# `cargo test -p xtask --test ffi` (part of `cargo test --workspace`).
set -euo pipefail
cd "$(dirname "$0")"
cargo fmt --check
cargo clippy --release --quiet -- -D warnings
cargo clippy --release --quiet --target thumbv7em-none-eabihf -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet
