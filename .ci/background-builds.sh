#!/usr/bin/env bash
# Builds that .ci/run starts in the background, so that they use the cores its
# own steps leave idle (single-threaded tests, the MIP oracle, linking) instead
# of running one after the other at the end:
#   a64: (from the toolchain step) the static aarch64 musl CLI and the aarch64 test binaries (cargo test
#        --release --no-run; the list of executables in a64-tests.json), in their own
#        target directory target/a64, so that no cargo run here waits for the
#        lock of target/ that the main steps hold while they compile, nor they
#        for it;
#   py:  (from the MIP oracle's step, which keeps one core busy) the Python module installed into a fresh venv (pip, its own target
#        directory bindings/python/target), and its fmt and clippy.
# The part writes DIR/<part>.log and then DIR/<part>.rc (its exit status),
# which .ci/run waits for and prints where these steps used to run.
# Usage: bash .ci/background-builds.sh DIR a64|py
set -uo pipefail
cd "$(dirname "$0")/.."
dir=$1
part=$2

if [ "$part" = a64 ]; then

(
  set -euo pipefail
  export CARGO_TARGET_DIR="$PWD/target/a64"
  cargo build --release -p vsaqem --target aarch64-unknown-linux-musl
  # The tests in release too: they share the CLI's compiled dependencies
  # (the test profile built them all again: 311 CPU-s against 213, on two
  # cores beside the steps in front), and run as fast under qemu.
  cargo test --release --no-run --message-format=json-render-diagnostics \
    -p vsaqem-core -p vsaqem --target aarch64-unknown-linux-musl >"$dir/a64-tests.json"
) >"$dir/a64.log" 2>&1
status=$?
{ echo "the a64 build took $SECONDS s, its user and system CPU-s:"; times; } >>"$dir/a64.log"
echo "$status" >"$dir/a64.rc"
fi

if [ "$part" = py ]; then

(
  set -euo pipefail
  python3 -m venv "$dir/venv"
  "$dir/venv/bin/pip" install -q --disable-pip-version-check ./bindings/python pytest
  cd bindings/python
  cargo fmt -- --check
  cargo clippy --release -- -D warnings
) >"$dir/py.log" 2>&1
status=$?
{ echo "the Python build took $SECONDS s, its user and system CPU-s:"; times; } >>"$dir/py.log"
echo "$status" >"$dir/py.rc"
fi
