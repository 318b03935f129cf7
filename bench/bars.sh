#!/bin/bash
# bench/bars.sh [BIN] [ROUNDS]: issue 13's two bars on the bunny at 1,000
# clusters in one measurement: whole-process wall time of Open3D's
# ball-pivoting pipeline (bench/o3d_pipeline.py --method bpa: normals,
# orientation, BPA, quadric decimation), of BIN --threads 1 and of BIN
# --threads 2, and the machine's ceiling (two BIN --threads 1 runs at once,
# as in threads.sh), run in a turning order, ROUNDS (default 8) of each.
# Prints medians, Open3D / two threads (the bar: 20x) and one thread / two
# (the bar: 1.7x). BIN defaults to target/release/vsaqem (built first by
# bench/setup.sh, which also makes the venv with Open3D). Needs
# ../shared/data/clouds/bunny.ply; skips without it.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CLOUD=$ROOT/../shared/data/clouds/bunny.ply
[ -f "$CLOUD" ] || { echo "skipped: $CLOUD not found" >&2; exit 0; }
BIN=${1:-}
R=${2:-8}
source "$ROOT/bench/setup.sh" >&2
BIN=${BIN:-$ROOT/target/release/vsaqem}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
# Each kind takes each place in a round as often as the others: the run
# after a long one (Open3D's) or after the pair found the machine in
# another state than the run before it.
orders=("o3d t1 t2 pair" "t1 t2 pair o3d" "t2 pair o3d t1" "pair o3d t1 t2")
for i in $(seq "$R"); do
  for tag in ${orders[$((i % 4))]}; do
    s=$(date +%s.%N)
    case $tag in
      o3d) "$VENV/bin/python" "$ROOT/bench/o3d_pipeline.py" --method bpa "$CLOUD" \
             "$OUT/o3d.ply" 1000 >/dev/null 2>"$OUT/o3d.err" \
           || { echo "Open3D's pipeline failed:" >&2; cat "$OUT/o3d.err" >&2; exit 1; };;
      t1) "$BIN" reconstruct "$CLOUD" --clusters 1000 --threads 1 -q -o "$OUT/t1.ply" >/dev/null;;
      t2) "$BIN" reconstruct "$CLOUD" --clusters 1000 --threads 2 -q -o "$OUT/t2.ply" >/dev/null;;
      pair)
        "$BIN" reconstruct "$CLOUD" --clusters 1000 --threads 1 -q -o "$OUT/a.ply" >/dev/null &
        "$BIN" reconstruct "$CLOUD" --clusters 1000 --threads 1 -q -o "$OUT/b.ply" >/dev/null
        wait;;
    esac
    e=$(date +%s.%N)
    echo "$tag $(echo "$e - $s" | bc)"
  done
done | python3 "$ROOT/bench/medians.py" o3d t1 t2 pair -- "o3d/t2:bar 20" "t1/t2:bar 1.7"
