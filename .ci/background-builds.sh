#!/usr/bin/env bash
# Builds that .ci/run starts in the background, so that they use the cores its
# own steps leave idle (single-threaded tests, the MIP oracle, linking) instead
# of running one after the other at the end:
#   a64: (from the toolchain step) the static aarch64 musl CLI and the aarch64 test binaries (cargo test
#        --release --no-run, core's and some of the host's; the list of executables in a64-tests.json), then
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

# .ci/run starts each part in a session of its own (setsid: a failed run kills
# it whole). Where the kernel groups processes by session for scheduling
# (sched_autogroup_enabled, as on this machine), it shares the CPU between
# the groups first and a nice value counts only within one: a part at nice
# 5 got as much as the steps in front (ci35). The session's group takes the
# part's nice value.
echo "$(nice)" >/proc/self/autogroup 2>/dev/null || true

# The host's test files run under qemu (see the a64 part).
QEMU_HOST_TESTS="closed_streams io_hostile memory_cli formats eval"

if [ "$part" = a64 ]; then

(
  set -euo pipefail
  export CARGO_TARGET_DIR="$PWD/target/a64"
  cargo build --release -p vsaqem --target aarch64-unknown-linux-musl
  # The tests in release too: they share the CLI's compiled dependencies
  # (the test profile built them all again: 311 CPU-s against 213, on two
  # cores beside the steps in front), and run as fast under qemu.
  # Core's tests, the host's unit tests and the host's test files where the
  # target can change the outcome (QEMU_HOST_TESTS): musl, the C library the
  # static CLI links (stdio on closed streams, the allocator under --memory),
  # the readers and writers, eval's exact predicates. The others check the
  # CLI's arguments, messages, reports and output files, code that is the
  # same on every target, and took 578 of the 1,470 s of qemu (ci31).
  # threads_cli is among them: the aarch64 smoke step (.ci/run) compares a
  # generated shape on 1, 2, 3 and 8 threads, both partitions, with x86-64's
  # bytes instead (qemu on x86-64 runs the guest's threads with the host's
  # stronger memory order, so no run here could show an ordering bug).
  cargo test --release --no-run --message-format=json-render-diagnostics \
    -p vsaqem-core --target aarch64-unknown-linux-musl >"$dir/a64-tests.json"
  host_tests=()
  for t in $QEMU_HOST_TESTS; do host_tests+=(--test "$t"); done
  cargo test --release --no-run --message-format=json-render-diagnostics \
    -p vsaqem --lib --bins "${host_tests[@]}" --target aarch64-unknown-linux-musl >>"$dir/a64-tests.json"
) >"$dir/a64.log" 2>&1
status=$?
{ echo "the a64 build took $SECONDS s, its user and system CPU-s:"; times; } >>"$dir/a64.log"
# Then the tests under qemu, at the part's nice 5 (.ci/run): begun here, at
# about a third of the run, they use what the steps in front leave of the
# cores (beside the fuzzers, also at nice 5) instead of running after them
# (ci27: 345 s at the end). Their pid file is there before a64.rc, for bg_wait.
echo $$ >"$dir/a64-tests.pid"
echo "$status" >"$dir/a64.rc"
(
  set -euo pipefail
  [ "$status" -eq 0 ]
  export CARGO_TARGET_DIR="$PWD/target/a64"
  a64=$CARGO_TARGET_DIR/aarch64-unknown-linux-musl/release/vsaqem
  if "$a64" --version >/dev/null 2>&1; then
    python3 .ci/qemu-tests.py "$dir/a64-tests.json" 2
  else
    only=()
    skipped=()
    for t in $QEMU_HOST_TESTS; do
      f=host/tests/$t.rs
      if grep -qE 'CARGO_BIN_EXE|\bbin\(\)|run_with_report' "$f"; then skipped+=("$f"); else only+=(--test "$t"); fi
    done
    echo "skipped under qemu: ${skipped[*]} (they start the aarch64 vsaqem binary as a"
    echo "  child process, and this kernel cannot exec it: binfmt_misc is unavailable)"
    cargo test --release -p vsaqem-core --target aarch64-unknown-linux-musl
    cargo test --release -p vsaqem --target aarch64-unknown-linux-musl --lib --bins "${only[@]}"
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
  # The module at opt-level 1 (maturin builds cargo's release profile; the
  # environment reaches it through pip): 129 CPU-s against 192 at 3 on the
  # idle machine, and its tests, small clouds, took 2.3 s either way. What
  # they check, the module's results against the CLI's bytes (an -O3 build),
  # holds at every level: Rust does not contract or reorder floating point.
  CARGO_PROFILE_RELEASE_OPT_LEVEL=1 \
    "$dir/venv/bin/pip" install -q --disable-pip-version-check ./bindings/python pytest
  cd bindings/python
  cargo fmt -- --check
  cargo clippy --release -- -D warnings
) >"$dir/py.log" 2>&1
status=$?
{ echo "the Python build took $SECONDS s, its user and system CPU-s:"; times; } >>"$dir/py.log"
echo "$status" >"$dir/py.rc"
fi
