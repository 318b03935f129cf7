#!/usr/bin/env bash
# validity.sh [CLUSTERS...]: reconstruct every shared cloud at each cluster count
# (default 250 500 1000 2000) with the release build, judge each mesh with
# `vsaqem eval` (exact self-intersections, coincident vertices, folds, bubbles,
# genus) and print one row per run, then the counts. Environment: VSAQEM (binary,
# default target/release/vsaqem), CLOUDS (default ../shared/data/clouds), OUT
# (meshes and reports, default a temporary folder).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${VSAQEM:-target/release/vsaqem}
clouds=${CLOUDS:-../shared/data/clouds}
out=${OUT:-$(mktemp -d)}
mkdir -p "$out"
counts=${*:-250 500 1000 2000}
[ -x "$bin" ] || cargo build --release -q -p vsaqem
[ -d "$clouds" ] || { echo "skipped: $clouds not found"; exit 0; }
printf '%-14s %5s %5s %5s %5s %6s %5s %5s %5s %-10s %-5s %7s %7s\n' model N V bnd euler selfx coinc fold bub genus valid max% p99%
for f in "$clouds"/*.ply; do
  m=$(basename "$f" .ply)
  for c in $counts; do
    "$bin" reconstruct -q "$f" --clusters "$c" -o "$out/$m-$c.ply" --report "$out/$m-$c.json" > /dev/null
    "$bin" eval --json "$f" "$out/$m-$c.ply" > "$out/$m-$c.eval.json"
    python3 - "$out/$m-$c.eval.json" "$m" "$c" <<'PY'
import json, sys
e = json.load(open(sys.argv[1])); m, c = sys.argv[2], sys.argv[3]
t, v, d = e["topology"], e["validity"], e["point_to_mesh"]["distance"]
g = ",".join(map(str, v["genus"])) or "-"
print(f'{m:14s} {c:>5s} {t["vertices"]:5d} {t["boundary_edges"]:5d} {t["euler"]:5d} {v["self_intersecting_pairs"]:6d} '
      f'{v["coincident_vertices"]:5d} {v["folded_edges"]:5d} {v["bubbles"]:5d} {g:10s} {"yes" if v["valid_solid"] else "no":5s} '
      f'{100 * d["max_relative"]:7.3f} {100 * d["p99_relative"]:7.3f}')
PY
  done
done | tee "$out/table.txt"
awk '{n++; if ($11 == "yes") v++; s += $6; c += $7} END {printf "%d runs: %d valid solids; %d self-intersecting pairs, %d coincident vertices in all\n", n, v, s, c}' "$out/table.txt"
echo "meshes and reports: $out"
