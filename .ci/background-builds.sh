#!/usr/bin/env bash
# Builds that .ci/run starts in the background, so that they use the cores its
# own steps leave idle (single-threaded tests, the MIP oracle, linking) instead
# of running one after the other at the end:
#   a64: (from the toolchain step) the static aarch64 musl CLI and the aarch64 test binaries (cargo test
#        --release --no-run; the list of executables in a64-tests.json), then
#        those tests under qemu (.ci/qemu-tests.py; a64-tests.log), in their own
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
# Then the tests under qemu, at nice 5: begun here, at about a third of the
# run, they use what the steps in front leave of the cores (the fuzzers' share,
# at nice 10) instead of running after them (ci27: 345 s at the end). Their
# pid file is there before a64.rc, for bg_wait.
echo $$ >"$dir/a64-tests.pid"
echo "$status" >"$dir/a64.rc"
(
  set -euo pipefail
  [ "$status" -eq 0 ]
  export CARGO_TARGET_DIR="$PWD/target/a64"
  a64=$CARGO_TARGET_DIR/aarch64-unknown-linux-musl/release/vsaqem
  if "$a64" --version >/dev/null 2>&1; then
    nice -n 5 python3 .ci/qemu-tests.py "$dir/a64-tests.json" 2
  else
    only=()
    skipped=()
    for f in host/tests/*.rs; do
      if grep -qE 'CARGO_BIN_EXE|\bbin\(\)|run_with_report' "$f"; then skipped+=("$f"); else only+=(--test "$(basename "$f" .rs)"); fi
    done
    echo "skipped under qemu: ${skipped[*]} (they start the aarch64 vsaqem binary as a"
    echo "  child process, and this kernel cannot exec it: binfmt_misc is unavailable)"
    nice -n 5 cargo test --release -p vsaqem-core --target aarch64-unknown-linux-musl
    nice -n 5 cargo test --release -p vsaqem --target aarch64-unknown-linux-musl --lib --bins "${only[@]}"
  fi
) >"$dir/a64-tests.log" 2>&1
status=$?
echo "the a64 build and tests took $SECONDS s" >>"$dir/a64-tests.log"
echo "$status" >"$dir/a64-tests.rc"
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
