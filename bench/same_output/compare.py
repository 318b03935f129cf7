#!/usr/bin/env python3
"""compare.py A B: compare two snapshot.sh folders. Meshes, cluster files and
pictures byte for byte; JSON reports field by field without timings and file
paths; text without the time line. Prints DIFF or MISSING per file, then
ALL IDENTICAL or the count that differ (exit 1)."""
import json, os, re, sys
a, b = sys.argv[1:3]
DROP = {"time_ms", "output", "mesh_file", "input", "cloud_file", "timings", "time"}
def norm(path, root):
    t = open(path, "rb").read()
    t = t.replace(root.encode(), b"X")
    t = re.sub(rb"exit \d+\n$", b"", t)
    try:
        if not t.strip(): return t
        def strip(o):
            if isinstance(o, dict): return {k: strip(v) for k, v in o.items() if k not in DROP}
            if isinstance(o, list): return [strip(v) for v in o]
            return o
        return json.dumps(strip(json.loads(t)), sort_keys=False).encode()
    except Exception:
        return b"\n".join(l for l in t.split(b"\n") if not re.match(rb"\s*time\s", l))
bad = 0
names = sorted(os.listdir(a))
for n in names:
    g = os.path.join(b, n)
    if not os.path.exists(g): print("MISSING", n); bad += 1; continue
    if norm(os.path.join(a, n), a) != norm(g, b): print("DIFF", n); bad += 1
print("ALL IDENTICAL" if not bad else f"{bad} DIFFER", f"({len(names)} files)")
sys.exit(1 if bad else 0)
