#!/usr/bin/env bash
# snapshot.sh BIN OUTDIR: run BIN on every built-in sample and on every shared
# cloud at 250 and 1000 clusters (reconstruct meshes in PLY, OBJ and OFF, --report
# JSON, cluster files, eval JSON, a render), writing each output into OUTDIR.
# Two snapshots compared with compare.py show whether a change kept behaviour.
set -u
bin=$1; out=$2; mkdir -p "$out"
data=${VSAQEM_DATA:-"$(cd "$(dirname "$0")/../../.." && pwd)/shared/data/clouds"}
run() { # name args...
  local name=$1; shift
  "$bin" "$@" > "$out/$name.stdout" 2> "$out/$name.stderr"; echo "exit $?" >> "$out/$name.stdout"
}
for s in demo sphere torus box cylinder hemisphere tube wave holed-sphere scene; do
  run "rec_$s" reconstruct -q --sample $s -o "$out/rec_$s.ply" --report "$out/rec_$s.json"
  run "clu_$s" cluster -q --sample $s -o "$out/clu_$s.ply" --report "$out/clu_$s.json"
done
run rec_noisy reconstruct -q --sample sphere --noise 0.01 --outliers 2 --smooth 2 -o "$out/rec_noisy.ply" --report "$out/rec_noisy.json"
[ -d "$data" ] || echo "skipped: $data not found (shared clouds not snapshotted)" >&2
for f in "$data"/*.ply; do
  [ -e "$f" ] || continue
  m=$(basename $f .ply)
  for c in 250 1000; do
    run "rec_${m}_$c" reconstruct -q "$f" --clusters $c -o "$out/rec_${m}_$c.ply" --report "$out/rec_${m}_$c.json"
    run "clu_${m}_$c" cluster -q "$f" --clusters $c -o "$out/clu_${m}_$c.ply" --report "$out/clu_${m}_$c.json"
  done
  run "eval_$m" eval --json "$f" "$out/rec_${m}_1000.ply"
done
run rec_bunny_obj reconstruct -q $data/bunny.ply --refine-rounds 2 -o "$out/rec_bunny_r.obj" --report "$out/rec_bunny_r.json"
run rec_bunny_off reconstruct -q $data/bunny.ply --clusters 500 -o "$out/rec_bunny_r.off"
run render_bunny render "$out/rec_bunny_r.obj" -o "$out/render.png"
