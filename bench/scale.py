#!/usr/bin/env python3
"""How vsaqem's time and memory grow with the input, beside Open3D's.

    bash bench/scale.sh [--sizes 100000,300000,1000000,3000000,10000000]
                        [--threads 1,2] [--open3d-max 1000000] [--aarch64 BIN]

Inputs: the shared bunny cloud as it is (34,834 points), and the shared bunny
mesh (`../shared/data/bunny.ply`) resampled uniformly by Open3D to each size
(seed 1; random order, as a resampling or a merged scan gives them), written to
`bench/out/scale/`. Every run reconstructs at 1,000 clusters as its own
process; its wall time and peak RSS are measured from outside (wait4), the time
per stage read from vsaqem's JSON report. Open3D's pipelines (bench/o3d_pipeline.py:
normals, orientation, Poisson or ball pivoting, quadric decimation to our vertex
count) run beside ours up to `--open3d-max` points, each with a 600 s limit; the
table shows the faster. With `--aarch64 BIN` the static aarch64 build runs
under qemu-aarch64-static (one thread) up to `--aarch64-max` points, as a ratio
to the x86-64 single-thread time: emulation, not a Raspberry Pi.

Writes bench/results/scale.md and prints it. Python is for benchmarks only.
"""

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
SHARED = REPO.parent / "shared" / "data"
STAGES = ["read", "clean", "neighbours", "quadrics", "clustering", "candidates",
          "scoring", "selection", "output"]


def measure(cmd, timeout):
    """Run `cmd`; (wall s, peak RSS MB, exit status or None on timeout). The
    peak RSS is GNU time's: a child forked from this process would report this
    process's memory (Open3D's, once imported) as its own."""
    rss_file = BENCH / "out" / "scale" / "rss.txt"
    start = time.perf_counter()
    try:
        p = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", rss_file, *cmd],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=timeout)
    except subprocess.TimeoutExpired:
        return timeout, None, None
    wall = time.perf_counter() - start
    if p.returncode != 0:
        print(f"  failed ({p.returncode}): {' '.join(map(str, cmd))}\n"
              f"{p.stderr.decode(errors='replace')}", file=sys.stderr)
    rss = int(rss_file.read_text().split()[-1]) / 1024
    return wall, rss, p.returncode


def resampled(n, work):
    """The bunny mesh resampled to `n` points (cached)."""
    out = work / f"bunny_{n}.ply"
    if not out.exists():
        # In a process of its own, so that this one never holds Open3D.
        subprocess.run([sys.executable, "-c", RESAMPLE, str(SHARED / "bunny.ply"), str(n),
                        str(out)], check=True)
    return out


RESAMPLE = """
import sys
import numpy as np
import open3d as o3d
src, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
o3d.utility.random.seed(1)
pts = np.asarray(o3d.io.read_triangle_mesh(src).sample_points_uniformly(n).points, dtype="<f4")
with open(out + ".tmp", "wb") as f:
    f.write(b"ply\\nformat binary_little_endian 1.0\\nelement vertex %d\\n"
            b"property float x\\nproperty float y\\nproperty float z\\nend_header\\n" % n)
    f.write(pts.tobytes())
import os
os.rename(out + ".tmp", out)
"""


def ours(binary, cloud, threads, work, timeout, wrapper=()):
    tag = f"{cloud.stem}_{threads}{'_qemu' if wrapper else ''}"
    report = work / f"report_{tag}.json"
    mesh = work / f"mesh_{tag}.ply"
    cmd = [*wrapper, binary, "reconstruct", "-q", cloud, "--clusters", "1000",
           "--threads", str(threads), "-o", mesh, "--report", report]
    wall, rss, code = measure(cmd, timeout)
    if code != 0:
        return None
    r = json.loads(report.read_text())
    return {"wall": wall, "rss": rss, "stages": r["time_ms"], "vertices": r["vertices"],
            "arena": r["arena_peak_bytes"], "points": r["points"]}


def fmt(x, unit="s"):
    if x is None:
        return "–"
    return f"{x:.2f}" if unit == "s" else f"{x:.0f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="100000,300000,1000000,3000000,10000000")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--open3d-max", type=int, default=1_000_000)
    ap.add_argument("--aarch64", type=Path)
    ap.add_argument("--aarch64-max", type=int, default=300_000)
    ap.add_argument("--vsaqem", type=Path, default=REPO / "target/release/vsaqem")
    ap.add_argument("--timeout", type=float, default=600)
    ap.add_argument("--out", type=Path, default=BENCH / "results" / "scale.md")
    a = ap.parse_args()
    work = BENCH / "out" / "scale"
    work.mkdir(parents=True, exist_ok=True)
    bunny = SHARED / "clouds" / "bunny.ply"
    if not bunny.exists():
        print(f"skipped: {bunny} not found (the shared data sits beside the repository)")
        return 0
    threads = [int(t) for t in a.threads.split(",")]
    clouds = [bunny] + [resampled(int(n), work) for n in a.sizes.split(",") if n]
    rows = []
    for cloud in clouds:
        row = {"cloud": cloud}
        for t in threads:
            row[t] = ours(a.vsaqem, cloud, t, work, a.timeout)
            r = row[t]
            print(f"{cloud.name} --threads {t}: " + (
                f"{r['wall']:.2f} s, {r['rss']:.0f} MB" if r else "failed"), flush=True)
        base = row[threads[0]]
        n = base["points"] if base else 0
        row["n"] = n
        if base and n <= a.open3d_max:
            best = None
            for method in ("bpa", "poisson"):
                cmd = [sys.executable, BENCH / "o3d_pipeline.py", "--method", method, cloud,
                       work / f"o3d_{method}_{cloud.stem}.ply", str(base["vertices"])]
                wall, rss, code = measure(cmd, a.timeout)
                print(f"{cloud.name} Open3D {method}: " + (
                    f"{wall:.2f} s, {rss:.0f} MB" if code == 0 else "timeout or failure"), flush=True)
                if code == 0 and (best is None or wall < best[1]):
                    best = (method, wall, rss)
            row["o3d"] = best
        if a.aarch64 and base and n <= a.aarch64_max:
            r = ours(a.aarch64, cloud, 1, work, a.timeout * 10, wrapper=("qemu-aarch64-static",))
            row["a64"] = r
            print(f"{cloud.name} aarch64 under qemu: " + (f"{r['wall']:.2f} s" if r else "failed"),
                  flush=True)
        rows.append(row)
    write(a, rows, threads)
    return 0


def write(a, rows, threads):
    t0 = threads[0]
    bunny = rows[0][t0]
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    lines = [
        "# Scaling: time and memory against the number of points",
        "",
        f"`bash bench/scale.sh` at {commit}: 1,000 clusters, whole process, one run each "
        "(this shared 2-core machine: wall times are noisy to about 10 %). The bunny is the "
        "shared cloud; the larger inputs are the bunny mesh resampled uniformly (random "
        "order). Open3D: the faster of its ball-pivoting and Poisson pipelines "
        "(bench/o3d_pipeline.py), to the same vertex count.",
        "",
        "| points | " + " | ".join(f"{t} thread{'s' if t > 1 else ''}: wall s (x bunny) | peak RSS MB"
                                    for t in threads)
        + " | arena peak B/point | Open3D wall s (peak RSS MB) |",
        "|---:|" + "---:|---:|" * len(threads) + "---:|---|",
    ]
    for row in rows:
        cells = [f"{row['n']:,}"]
        for t in threads:
            r = row[t]
            if r:
                x = r["wall"] / bunny["wall"] if bunny else None
                cells += [f"{r['wall']:.2f} ({x:.1f}x)" if x else fmt(r["wall"]), fmt(r["rss"], "MB")]
            else:
                cells += ["failed", "–"]
        r = row[t0]
        cells.append(f"{r['arena'] / r['points']:.1f}" if r else "–")
        o = row.get("o3d")
        cells.append(f"{o[1]:.2f} ({o[2]:.0f}, {o[0]})" if o else "not run")
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", f"Time per stage, s ({t0} thread{'s' if t0 > 1 else ''}):", "",
              "| points | " + " | ".join(STAGES) + " |", "|---:|" + "---:|" * len(STAGES)]
    for row in rows:
        r = row[t0]
        if r:
            lines.append(f"| {row['n']:,} | " + " | ".join(
                f"{r['stages'].get(s, 0) / 1000:.2f}" for s in STAGES) + " |")
    a64 = [row for row in rows if row.get("a64") and row.get(t0)]
    if a64:
        lines += ["", "aarch64 musl build under qemu-aarch64-static user emulation, one thread, as "
                  "a multiple of the x86-64 single-thread wall time (emulation: not a Raspberry Pi's "
                  "time):", "", "| points | aarch64 / x86-64 |", "|---:|---:|"]
        for row in a64:
            lines.append(f"| {row['n']:,} | {row['a64']['wall'] / row[t0]['wall']:.1f} |")
    text = "\n".join(lines) + "\n"
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(text)
    print(text)


if __name__ == "__main__":
    sys.exit(main())
