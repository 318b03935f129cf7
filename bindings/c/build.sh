#!/usr/bin/env bash
# bindings/c/build.sh: regenerate include/vsaqem.h from src/lib.rs (cbindgen,
# installed when missing) and build the C library for this machine
# (target/release/libvsaqem.a and .so) and, when its Rust target is installed,
# for a Cortex-M4F (target/thumbv7em-none-eabihf/release/libvsaqem.a).
set -euo pipefail
cd "$(dirname "$0")"
CBINDGEN_VERSION=0.29.4
if ! cbindgen --version 2>/dev/null | grep -q "$CBINDGEN_VERSION"; then
  cargo install cbindgen --locked --version "$CBINDGEN_VERSION"
fi
cbindgen --config cbindgen.toml --output include/vsaqem.h
cargo build --release
if rustup target list --installed 2>/dev/null | grep -q thumbv7em-none-eabihf; then
  cargo rustc --release --target thumbv7em-none-eabihf --crate-type staticlib
fi
