#!/bin/bash
# bench/threads.sh BASE NEW [ROUNDS]: whole-process wall time on the bunny at
# 1,000 clusters for BASE, NEW --threads 1 and NEW --threads 2, run
# alternately; prints medians and ratios. Needs ../shared/data/clouds/bunny.ply.
set -euo pipefail
BASE=$1; NEW=$2; R=${3:-10}
CLOUD=$(dirname "$0")/../../shared/data/clouds/bunny.ply
[ -f "$CLOUD" ] || { echo "skipped: $CLOUD not found" >&2; exit 0; }
for i in $(seq "$R"); do
  for tag in base t1 t2; do
    case $tag in
      base) cmd=("$BASE" reconstruct);;
      t1) cmd=("$NEW" reconstruct --threads 1);;
      t2) cmd=("$NEW" reconstruct --threads 2);;
    esac
    s=$(date +%s.%N)
    "${cmd[@]}" "$CLOUD" --clusters 1000 -q -o /tmp/threads_bench.ply >/dev/null
    e=$(date +%s.%N)
    echo "$tag $(echo "$e - $s" | bc)"
  done
done | python3 -c "
import sys, statistics as st, collections
d = collections.defaultdict(list)
for l in sys.stdin:
    b, t = l.split(); d[b].append(float(t))
m = {k: st.median(v) for k, v in d.items()}
for k in ('base', 't1', 't2'): print(k, 'median %.3f s' % m[k], 'n', len(d[k]))
print('t1/base %.3f  t2/base %.3f  t1/t2 %.3f' % (m['t1']/m['base'], m['t2']/m['base'], m['t1']/m['t2']))"
