#!/usr/bin/env bash
# Runs every fuzz target for SECONDS (default 60) each, one after the other
# (one core at a time: no -jobs/-workers; FUZZ_LANES=N runs N targets at
# once, one core each), from fuzz/corpus/<target> (kept,
# gitignored) and the seeds of seed.sh, then prints each target's runs,
# coverage (cov: edges) and features (ft:) from libFuzzer's final line; the
# whole output of each is in fuzz/logs/<target>.log.
# Exits 1 when a target crashed, timed out (-timeout, seconds an input may
# take: 20, reconstruct 60) or ran out of memory; the input is then in fuzz/artifacts/<target>/.
#
# Needs only stable Rust: cargo-fuzz is installed when missing, and the
# sanitizer flags take `cargo +nightly` when a nightly toolchain is installed,
# else RUSTC_BOOTSTRAP=1 on the default one.
#   bash fuzz/run.sh 60                # every target, 60 s each
#   bash fuzz/run.sh 300 reconstruct   # one target
#   FUZZ_TIMEOUT=300 nice -n 19 bash fuzz/run.sh 3600   # long runs beside other work
#   FUZZ_NICE=10 bash fuzz/run.sh 60   # build at the normal priority, fuzz at nice 10
#   FUZZ_OPT_LEVEL=1 bash fuzz/run.sh 30   # the targets built at opt-level 1 (CI)
#   FUZZ_LANES=2 bash fuzz/run.sh 30   # two targets at a time (CI)
#   setsid env FUZZ_NICE=10 FUZZ_NICE_SESSION=1 bash fuzz/run.sh 30   # its session niced too
set -euo pipefail
cd "$(dirname "$0")"
seconds=${1:-60}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(ply pcd text mesh las e57 args eval reconstruct)
fi

if ! cargo fuzz --version >/dev/null 2>&1; then
  cargo install cargo-fuzz --locked
fi
if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
  fuzz=(cargo +nightly fuzz)
else
  export RUSTC_BOOTSTRAP=1
  fuzz=(cargo fuzz)
fi
echo "using: ${fuzz[*]} ($("${fuzz[@]}" --version))"

bash seed.sh
# FUZZ_OPT_LEVEL: the targets' optimisation level (cargo-fuzz's release
# profile otherwise: 3, one codegen unit). The instrumentation, AddressSanitizer
# and the debug assertions are the same at any level. At 1 the build took 223
# CPU-s against 307 on the idle machine, and the fuzzers ran about as many
# inputs (15 s from the seeds: eval 799 against 859, args 14,354 against
# 9,994; the sanitizer's and the coverage's costs do not shrink with -O3).
# Set after seed.sh: its release build of the host is the one the caller's
# steps use.
if [ -n "${FUZZ_OPT_LEVEL:-}" ]; then
  export CARGO_PROFILE_RELEASE_OPT_LEVEL=$FUZZ_OPT_LEVEL
fi
"${fuzz[@]}" build
echo "the targets built at $SECONDS s"
# The fuzzers (started after this) inherit the lowered priority; the build had
# the caller's.
if [ -n "${FUZZ_NICE:-}" ]; then
  renice -n "$FUZZ_NICE" -p $$ >/dev/null
  # FUZZ_NICE_SESSION=1 (a run in a session of its own, as CI's): the
  # session's scheduling group takes the value too. Where the kernel groups
  # processes by session (sched_autogroup_enabled), it shares the CPU
  # between the groups first, and a nice value counts only within one.
  if [ "${FUZZ_NICE_SESSION:-}" = 1 ]; then
    echo "$FUZZ_NICE" >/proc/self/autogroup 2>/dev/null || true
  fi
fi

# One target: its summary line into logs/<target>.summary (a failure is
# written there, where the list at the end finds it).
fuzz_one() {
  local t=$1
  mkdir -p "corpus/$t" "artifacts/$t" logs
  # Not in artifacts/: cargo fuzz names the newest file there as the failing input.
  local log="logs/$t.log"
  local start=$SECONDS
  local status=0
  # An input may take 20 s; reconstruct's 60: it runs core twice under
  # AddressSanitizer, and 150 random points in a cube at the default node
  # limit take 1.4 s a run without it (the selection on a dense candidate
  # graph; fuzz/REPORT.md), 8 s in all with it, more on a loaded machine.
  # FUZZ_TIMEOUT sets one limit for all: libFuzzer's limit is wall time, and
  # a fuzzer started at a low priority on a busy machine can wait longer than
  # that for the CPU (its timeouts then replay in a few seconds).
  local limit=20
  if [ "$t" = reconstruct ]; then limit=60; fi
  limit=${FUZZ_TIMEOUT:-$limit}
  "${fuzz[@]}" run "$t" "corpus/$t" "seeds/$t" -- \
    -max_total_time="$seconds" -timeout="$limit" -print_final_stats=1 >"$log" 2>&1 || status=$?
  local took=$((SECONDS - start))
  local done_line runs cov
  done_line=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -1 || true)
  runs=$(grep -oE 'stat::number_of_executed_units:[[:space:]]*[0-9]+' "$log" | grep -oE '[0-9]+$' || echo '?')
  cov=$(sed -nE 's/.* cov: ([0-9]+) ft: ([0-9]+) corp: ([0-9]+).*/cov \1  ft \2  corpus \3/p' <<<"$done_line")
  if [ "$status" -ne 0 ] || [ -z "$done_line" ]; then
    cov="FAILED (exit $status), see fuzz/$log and fuzz/artifacts/$t/"
    grep -E 'panicked|ERROR|SUMMARY|Test unit written' "$log" | head -5 || true
  fi
  printf '%-12s %5d s  %10s runs  %s\n' "$t" "$took" "$runs" "$cov" | tee "logs/$t.summary"
}

# FUZZ_LANES (default 1): how many targets fuzz at once, each lane taking the
# next target of the list when its last one ends. The 30 s a target are wall
# time: CI's two lanes take half the wall time of one (their CPU is what the
# machine has to spare, at FUZZ_NICE), and a lane is one core, no more.
lanes=${FUZZ_LANES:-1}
mkdir -p logs
for t in "${targets[@]}"; do rm -f "logs/$t.summary"; done
queue=logs/.queue
echo 0 >"$queue"
next_target() {
  # The queue's counter, read and advanced under a lock.
  (
    flock 9
    local n
    n=$(<"$queue")
    echo $((n + 1)) >"$queue"
    echo "$n"
  ) 9>"$queue.lock"
}
lane() {
  local n
  while n=$(next_target) && [ "$n" -lt ${#targets[@]} ]; do
    fuzz_one "${targets[$n]}"
  done
}
lane_pids=()
for ((l = 0; l < lanes; l++)); do
  lane &
  lane_pids+=($!)
done
# A lane's status says nothing the summaries do not: a target that failed
# wrote so, and one that never ran left no line.
for p in "${lane_pids[@]}"; do wait "$p" || true; done

failed=()
summary=()
for t in "${targets[@]}"; do
  line=$(cat "logs/$t.summary" 2>/dev/null || echo "$t: did not run")
  summary+=("$line")
  case $line in *FAILED* | *"did not run"*) failed+=("$t") ;; esac
done
rm -f "$queue" "$queue.lock"

echo
echo "fuzzing, $seconds s a target:"
printf '%s\n' "${summary[@]}"
if [ ${#failed[@]} -ne 0 ]; then
  echo "FAIL: ${failed[*]}"
  exit 1
fi
