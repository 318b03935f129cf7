#!/usr/bin/env python3
"""The paper's comparison, rerun on any folder of point clouds.

For every cloud, cluster count N and iteration count, runs `vsaqem reconstruct`,
Open3D 0.20's two native pipelines (bench/o3d_pipeline.py: Poisson and ball
pivoting, each decimated with Open3D's quadric decimation) and MeshLab's
(bench/meshlab_pipeline.py through PyMeshLab: screened Poisson at depths 8 and 10,
ball pivoting with repair and hole closing, each decimated with MeshLab's quadric
edge collapse), each as a whole process whose wall time, CPU time and peak RSS are
measured; scores every mesh with `vsaqem eval --json` (distances, topology, and
whether it is a valid solid); writes Markdown tables, JSON/CSV of every run, plots
and side-by-side pictures into the results folder.

    python bench/compare.py                       # everything in ../shared/data/clouds
    python bench/compare.py --models bunny,block --clusters 250 --iterations 5

Equal vertex count. vsaqem's splitting adds clusters where the error tolerance
asks for them, so `--clusters N` can give up to 2N vertices. By default
(`--o3d-target ours`) Open3D and MeshLab decimate to 2V triangles, V the largest
vertex count vsaqem gave for that cloud and N over the iteration counts, so their
meshes never have fewer vertices than the ones they are compared with.
`--o3d-target clusters` decimates to 2N triangles instead. Every table states which
was used.

Python is used only for benchmarks; nothing here is part of vsaqem.
"""

import argparse
import csv
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent

SYSTEMS_O3D = ["poisson", "bpa"]
SYSTEMS_ML = ["ml-poisson8", "ml-poisson10", "ml-bpa"]
# Every system other than ours, in table order.
SYSTEMS_OTHER = SYSTEMS_O3D + SYSTEMS_ML
LABEL = {"poisson": "Open3D Poisson", "bpa": "Open3D BPA", "ml-poisson8": "MeshLab Poisson d8",
         "ml-poisson10": "MeshLab Poisson d10", "ml-bpa": "MeshLab BPA"}
# The command line of each other system after the interpreter: pipeline, its options.
PIPELINE = {"poisson": ("o3d_pipeline.py", ["--method", "poisson"]),
            "bpa": ("o3d_pipeline.py", ["--method", "bpa"]),
            "ml-poisson8": ("meshlab_pipeline.py", ["--method", "poisson", "--depth", "8"]),
            "ml-poisson10": ("meshlab_pipeline.py", ["--method", "poisson", "--depth", "10"]),
            "ml-bpa": ("meshlab_pipeline.py", ["--method", "bpa"])}
# Panel labels in the pictures (vsaqem render prints the file name; long ones overlap).
TILE_NAME = {"poisson": "Poisson", "bpa": "BPA", "ml-poisson8": "ML-P8", "ml-poisson10": "ML-P10",
             "ml-bpa": "ML-BPA"}
# The derived row "MeshLab best": per model and N, the MeshLab mesh of lowest max distance.
ML_BEST = "MeshLab best"
# Up axis of the shared models for the pictures (y when not listed).
UP = {"block": "z", "bolt": "x", "gear": "z", "horse": "z", "kitten": "z", "rocker_arm": "x"}
PICTURE_MODELS = "bunny,bolt,gear"


def ours(it):
    return f"ours-{it}"


def label(system):
    if system.startswith("ours-"):
        it = int(system.split("-")[1])
        return f"ours, {it} iteration" + ("" if it == 1 else "s")
    return LABEL[system]


def log(msg):
    print(msg, flush=True)


# ---------------------------------------------------------------- measuring


TIME = Path("/usr/bin/time")


def run_measured(cmd, log_path, timeout):
    """Runs `cmd` as a child process; returns (returncode, wall s, cpu s, peak RSS kB,
    reason).

    The peak RSS is what GNU time reports for `cmd`: Linux keeps a process's RSS high
    mark across exec, so a child forked straight from this Python process would report
    the harness's own RSS (about 20 MB) if its real peak were lower. /usr/bin/time is
    small, so its child starts from about 2 MB. Wall time is measured here, CPU time
    (user + system, the command's and its children's) comes from wait4."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    tfile = log_path.with_suffix(".time")
    tfile.unlink(missing_ok=True)
    full = [TIME, "-f", "%M", "-o", tfile] + list(cmd)
    with open(log_path, "w") as out:
        out.write("$ " + " ".join(map(str, cmd)) + "\n")
        out.flush()
        t0 = time.perf_counter()
        p = subprocess.Popen([str(c) for c in full], stdout=out, stderr=subprocess.STDOUT,
                             stdin=subprocess.DEVNULL, start_new_session=True)
        timed_out = False
        while True:
            pid, status, ru = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() - t0 > timeout:
                timed_out = True
                os.killpg(p.pid, signal.SIGKILL)
                pid, status, ru = os.wait4(p.pid, 0)
                break
            time.sleep(0.005)
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
    cpu = ru.ru_utime + ru.ru_stime
    rss = None
    signalled = None
    try:
        for line in tfile.read_text().splitlines():
            if line.strip().isdigit():
                rss = int(line)
            elif "terminated by signal" in line:
                signalled = int(line.split()[-1])
    except OSError:
        pass
    reason = None
    if timed_out:
        reason = f"timeout after {timeout:.0f} s"
    elif signalled:
        reason = f"killed by {signal.Signals(signalled).name}"
    elif p.returncode != 0:
        reason = last_error(log_path) or f"exit code {p.returncode}"
    if rss is None and not reason:
        reason = f"no peak RSS from {TIME}"
    return p.returncode, wall, cpu, rss, reason


def last_error(log_path):
    """The last meaningful line of a failed process's output, shortened."""
    lines = [l.strip() for l in Path(log_path).read_text(errors="replace").splitlines()[1:]]
    lines = [l for l in lines if l and not l.startswith("Traceback")]
    if not lines:
        return None
    msg = lines[-1]
    for prefix in ("error: ", "SystemExit: "):
        if msg.startswith(prefix):
            msg = msg[len(prefix):]
    return msg if len(msg) <= 120 else msg[:117] + "..."


def evaluate(vsaqem, cloud, mesh, timeout):
    """`vsaqem eval --json`; returns (dict, None) or (None, reason)."""
    try:
        r = subprocess.run([str(vsaqem), "eval", "--json", str(cloud), str(mesh)],
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"eval: timeout after {timeout:.0f} s"
    if r.returncode != 0:
        msg = (r.stderr.strip().splitlines() or [f"exit code {r.returncode}"])[-1]
        return None, "eval: " + msg.removeprefix("error: ")
    return json.loads(r.stdout), None


# ---------------------------------------------------------------- one run


def run_one(a, model, cloud, system, n, o3d_n, work):
    """Runs one system on one cloud; returns its record (never raises)."""
    rec = {"model": model, "system": system, "clusters": n, "status": "failed"}
    d = work / model
    mesh = d / f"{system}_{n}.ply"
    log_path = d / f"{system}_{n}.log"
    if system.startswith("ours-"):
        it = int(system.split("-")[1])
        report = d / f"{system}_{n}.json"
        cmd = [a.vsaqem, "reconstruct", "-q", cloud, "-o", mesh, "--clusters", n,
               "--iterations", it, "--report", report]
        rec["iterations"] = it
    else:
        report = d / f"{system}_{n}.info.json"
        script, opts = PIPELINE[system]
        cmd = [a.python, BENCH / script, *opts, cloud, mesh, o3d_n, "--info", report]
        rec["target_vertices"] = o3d_n
        rec["target_faces"] = 2 * o3d_n
    for f in (mesh, report):
        f.unlink(missing_ok=True)
    try:
        code, wall, cpu, rss, reason = run_measured(cmd, log_path, a.timeout)
        rec.update(wall_s=wall, cpu_s=cpu)
        if rss is not None:
            rec["max_rss_kb"] = rss
        if reason:
            rec["reason"] = reason.replace(f"{cloud}: ", "")
            return rec
        if report.exists():
            rec["report"] = json.loads(report.read_text())
        if not mesh.exists():
            rec["reason"] = "no mesh written"
            return rec
        ev, reason = evaluate(a.vsaqem, cloud, mesh, a.timeout)
        if reason:
            rec["reason"] = reason.replace(f"{cloud}: ", "").replace(f"{mesh}: ", "")
            return rec
        rec["eval"] = ev
        rec["mesh"] = str(mesh)
        rec["status"] = "ok"
    except Exception as e:  # the harness goes on whatever one run does
        rec["reason"] = f"harness: {type(e).__name__}: {e}"
    return rec


def brief(rec):
    if rec["status"] != "ok":
        return f"FAILED: {rec.get('reason')}"
    ev = rec["eval"]
    topo = ev["topology"]
    return (f"{rec['wall_s']:.2f} s, {rec['max_rss_kb'] / 1024:.0f} MB, "
            f"{topo['vertices']} v, max {100 * ev['point_to_mesh']['distance']['max_relative']:.2f} %"
            f"{', closed manifold' if topo['closed_manifold'] else ''}"
            f"{', valid solid' if valid_solid(rec) else ''}")


# ---------------------------------------------------------------- the run


def machine_info():
    info = {"platform": platform.platform(), "python": platform.python_version(),
            "cpus": os.cpu_count()}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                info["cpu"] = line.split(":", 1)[1].strip()
                break
        info["mem_gb"] = round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (OSError, ValueError):
        pass
    try:
        info["vsaqem_commit"] = subprocess.run(
            ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True).stdout.strip()
    except OSError:
        pass
    try:
        from importlib.metadata import version
        info["open3d"] = version("open3d")
    except Exception:
        info["open3d"] = "not installed"
    try:
        from importlib.metadata import version
        info["pymeshlab"] = version("pymeshlab")
    except Exception:
        info["pymeshlab"] = "not installed"
    return info


def run_all(a, models, work, previous):
    """Runs every system on every model and cluster count. `previous` maps
    (model, system, clusters, target vertices) to an earlier record of another
    system that is reused instead of run (`--reuse-others`)."""
    records = []
    total = len(models) * len(a.clusters) * (len(a.iterations) + len(SYSTEMS_OTHER))
    k = 0
    for model, cloud in models:
        for n in a.clusters:
            mine = []
            for it in a.iterations:
                k += 1
                rec = run_one(a, model, cloud, ours(it), n, None, work)
                log(f"[{k}/{total}] {model} N={n} {label(ours(it))}: {brief(rec)}")
                records.append(rec)
                mine.append(rec)
            verts = [r["eval"]["topology"]["vertices"] for r in mine if r["status"] == "ok"]
            o3d_n = max(verts) if a.o3d_target == "ours" and verts else n
            for system in SYSTEMS_OTHER:
                k += 1
                rec = previous.get((model, system, n, o3d_n))
                if rec is None:
                    rec = run_one(a, model, cloud, system, n, o3d_n, work)
                    how = ""
                else:
                    how = ", reused"
                log(f"[{k}/{total}] {model} N={n} {label(system)} (target {2 * o3d_n} faces"
                    f"{how}): {brief(rec)}")
                records.append(rec)
    return records


# ---------------------------------------------------------------- tables


def pct(x):
    return f"{100 * x:.2f}"


def max_rel(rec):
    return rec["eval"]["point_to_mesh"]["distance"]["max_relative"]


def valid_solid(rec):
    """`vsaqem eval`'s verdict: closed manifold, no self-intersecting pair, coincident
    vertex, fold, bubble or degenerate face."""
    return rec["eval"].get("validity", {}).get("valid_solid", False)


def solid_mark(rec):
    """`✓` for a valid solid, `*` for a closed manifold that is not one, else nothing."""
    if valid_solid(rec):
        return "✓"
    return "*" if rec["eval"]["topology"]["closed_manifold"] else ""


MARKS = ("`✓` marks a valid solid (closed manifold, no self-intersecting faces, coincident "
         "vertices, folds or bubbles: `vsaqem eval`'s `valid_solid`), `*` a closed manifold "
         "that is not one")


def best_of(idx, model, n, systems):
    """The run of lowest max distance among `systems` for (model, n), or None."""
    ok = [x for s in systems if (x := idx.get((model, s, n))) and x["status"] == "ok"]
    return min(ok, key=max_rel) if ok else None


def short(system):
    """A MeshLab system's label without "MeshLab ", for the derived row."""
    return LABEL[system].removeprefix("MeshLab ")


def cell(rec, fmt):
    if rec is None:
        return "not run"
    if rec["status"] != "ok":
        return f"failed: {rec.get('reason', '?')}".replace("|", "/")
    return fmt(rec)


def index(records):
    return {(r["model"], r["system"], r["clusters"]): r for r in records}


def systems_of(a):
    return SYSTEMS_OTHER + [ours(it) for it in a.iterations]


def table(a, model, idx, fmt, ml_best=False):
    """Rows: systems; columns: cluster counts (the paper's Tables 1-3). With `ml_best`,
    a derived row after MeshLab's: its mesh of lowest max distance per column."""
    cols = a.clusters
    head = "| | " + " | ".join(f"{n}C" for n in cols) + " |\n|---|" + "---:|" * len(cols) + "\n"
    rows = []
    for s in systems_of(a):
        cells = [cell(idx.get((model, s, n)), fmt) for n in cols]
        rows.append(f"| {label(s)} | " + " | ".join(cells) + " |")
        if ml_best and s == SYSTEMS_ML[-1]:
            best = [best_of(idx, model, n, SYSTEMS_ML) for n in cols]
            cells = [f"{fmt(b)} ({short(b['system'])})" if b else "all failed" for b in best]
            rows.append(f"| {ML_BEST} | " + " | ".join(cells) + " |")
    return head + "\n".join(rows) + "\n"


def max_table(a, model, idx):
    return table(a, model, idx, lambda r: pct(max_rel(r)) + solid_mark(r), ml_best=True)


def model_table(a, model, points, idx):
    """The paper's layout (Tables 1-3) plus vertex count, time and memory."""

    out = [f"# {model} ({points:,} points)\n",
           "Maximum distance from the input points to the output mesh, % of the input's "
           "bounding-box diagonal (lower is better; `vsaqem eval`, exact point-triangle "
           "distances); " + MARKS + ". Columns: clusters asked of vsaqem (`--clusters`).\n",
           max_table(a, model, idx),
           "\nVertices of each mesh (Open3D and MeshLab decimated to 2V triangles, V = "
           + ("the largest vertex count vsaqem gave in the column" if a.o3d_target == "ours"
              else "N") + "); " + MARKS + ":\n",
           table(a, model, idx, lambda r: f"{r['eval']['topology']['vertices']}" + solid_mark(r)),
           "\nWhole-process wall time, s:\n",
           table(a, model, idx, lambda r: f"{r['wall_s']:.2f}"),
           "\nWhole-process peak RSS, MB:\n",
           table(a, model, idx, lambda r: f"{r['max_rss_kb'] / 1024:.1f}")]
    return "\n".join(out)


SUMMARY_HEAD = ("| model | N | system | vertices | max % | mean % | Chamfer % | watertight "
                "| non-manifold vertices | valid solid | genus | time s | CPU s | peak RSS MB |\n"
                "|---|---:|---|---:|---:|---:|---:|---|---:|---|---|---:|---:|---:|\n")


def validity_text(ev):
    """"yes", or "no" with what fails beyond the watertight column."""
    v = ev.get("validity")
    if v is None:
        return "?"
    if v["valid_solid"]:
        return "yes"
    why = [f"{v[k]} {k.replace('_', ' ')}" for k in
           ("self_intersecting_pairs", "coincident_vertices", "folded_edges", "bubbles") if v[k]]
    return "no" + (f" ({', '.join(why)})" if why else "")


def genus_text(ev):
    g = ev.get("validity", {}).get("genus")
    if g is None:
        return "?"
    return "[" + ", ".join(map(str, g[:5])) + (f", +{len(g) - 5}" if len(g) > 5 else "") + "]"


def summary_rows(a, models, idx):
    rows = []
    for model, _ in models:
        for n in a.clusters:
            for s in systems_of(a):
                r = idx.get((model, s, n))
                if r is None:
                    continue
                t = f"{r['wall_s']:.2f}" if "wall_s" in r else ""
                c = f"{r['cpu_s']:.2f}" if "cpu_s" in r else ""
                m = f"{r['max_rss_kb'] / 1024:.1f}" if "max_rss_kb" in r else ""
                if r["status"] != "ok":
                    why = r.get("reason", "?").replace("|", "/")
                    rows.append(f"| {model} | {n} | {label(s)} | failed: {why} | | | | | | | | "
                                f"{t} | {c} | {m} |")
                    continue
                ev = r["eval"]
                d = ev["point_to_mesh"]["distance"]
                topo = ev["topology"]
                wt = "yes" if topo["closed_manifold"] else (
                    f"no ({topo['boundary_edges']} boundary edges"
                    + (f", {topo['non_manifold_edges']} non-manifold edges"
                       if topo["non_manifold_edges"] else "") + ")")
                rows.append(f"| {model} | {n} | {label(s)} | {topo['vertices']} | "
                            f"{pct(d['max_relative'])} | {pct(d['mean_relative'])} | "
                            f"{pct(ev['chamfer_relative'])} | {wt} | "
                            f"{topo['non_manifold_vertices']} | {validity_text(ev)} | "
                            f"{genus_text(ev)} | {t} | {c} | {m} |")
    return SUMMARY_HEAD + "\n".join(rows) + "\n"


def goal(a, models, idx):
    """The issue's goal, checked pair by pair at the default 5 iterations (or the
    middle iteration count run)."""
    it = 5 if 5 in a.iterations else a.iterations[len(a.iterations) // 2]
    me = ours(it)
    pairs = []
    for model, _ in models:
        for n in a.clusters:
            r = idx.get((model, me, n))
            o3d = [idx.get((model, s, n)) for s in SYSTEMS_O3D]
            o3d_ok = [x for x in o3d if x and x["status"] == "ok"]
            p = {"model": model, "n": n, "ours_ok": bool(r and r["status"] == "ok")}
            if p["ours_ok"]:
                p["ours_max"] = max_rel(r)
                p["ours_uncovered"] = r.get("report", {}).get("uncovered_points")
                p["ours_watertight"] = r["eval"]["topology"]["closed_manifold"]
            if o3d_ok:
                best = min(o3d_ok, key=max_rel)
                p["o3d_best"] = best["system"]
                p["o3d_max"] = max_rel(best)
            p["o3d_watertight"] = {x["system"]: x["eval"]["topology"]["closed_manifold"]
                                   for x in o3d_ok}
            ml = best_of(idx, model, n, SYSTEMS_ML)
            if ml:
                p["ml_best"] = ml["system"]
                p["ml_max"] = max_rel(ml)
            p["ours_valid"] = p["ours_ok"] and valid_solid(r)
            p["valid"] = {s: valid_solid(x) for s in SYSTEMS_OTHER
                          if (x := idx.get((model, s, n))) and x["status"] == "ok"}
            p["ml_win"] = p["ours_ok"] and ("ml_max" not in p or p["ours_max"] <= p["ml_max"])
            if p["ours_ok"] and "max_rss_kb" in r:
                ran = [x for x in o3d_ok if "max_rss_kb" in x]
                if ran:
                    p["time_ratio"] = min(x["wall_s"] for x in ran) / r["wall_s"]
                    p["cpu_ratio"] = min(x["cpu_s"] for x in ran) / max(r["cpu_s"], 1e-9)
                    p["rss_ratio"] = min(x["max_rss_kb"] for x in ran) / r["max_rss_kb"]
            if p["ours_ok"]:
                p["win"] = "o3d_max" not in p or p["ours_max"] <= p["o3d_max"]
            else:
                p["win"] = False
            pairs.append(p)
    return it, pairs


def goal_table(it, pairs):
    head = ("| model | N | ours max % | best Open3D max % | at or below | best MeshLab max % "
            "| at or below | ours: points in clusters the mesh leaves out | ours watertight "
            "| Poisson / BPA watertight | valid solids: ours / Open3D / MeshLab "
            "| time ratio | peak RSS ratio |\n"
            "|---|---:|---:|---:|---|---:|---|---:|---|---|---|---:|---:|\n")
    rows = []
    for p in pairs:
        o = f"{pct(p['o3d_max'])} ({LABEL[p['o3d_best']].split()[1]})" if "o3d_max" in p else "both failed"
        ml = f"{pct(p['ml_max'])} ({short(p['ml_best'])})" if "ml_max" in p else "all failed"
        wt = " / ".join(("yes" if p["o3d_watertight"][s] else "no")
                        if s in p["o3d_watertight"] else "failed" for s in SYSTEMS_O3D)

        def solids(systems):
            ran = [p["valid"][s] for s in systems if s in p["valid"]]
            return f"{sum(ran)} of {len(ran)}"
        valid = (f"{'yes' if p['ours_valid'] else 'no'} / {solids(SYSTEMS_O3D)} / "
                 f"{solids(SYSTEMS_ML)}")
        rows.append(
            f"| {p['model']} | {p['n']} | {pct(p['ours_max']) if p['ours_ok'] else 'failed'} | {o} | "
            f"{'yes' if p['win'] else '**no**'} | {ml} | {'yes' if p['ml_win'] else '**no**'} | "
            f"{p.get('ours_uncovered', '')} | "
            f"{('yes' if p['ours_watertight'] else '**no**') if p['ours_ok'] else ''} | {wt} | "
            f"{valid} | "
            + (f"{p['time_ratio']:.1f}x | {p['rss_ratio']:.1f}x |" if "time_ratio" in p else " | |"))
    return head + "\n".join(rows) + "\n"


def wins_at(a, models, idx, it):
    """(pairs where ours at `it` iterations is at or below Open3D's best, pairs)."""
    win = n = 0
    for model, _ in models:
        for c in a.clusters:
            n += 1
            r = idx.get((model, ours(it), c))
            o = [x for s in SYSTEMS_O3D if (x := idx.get((model, s, c))) and x["status"] == "ok"]
            if r and r["status"] == "ok" and (not o or max_rel(r) <= min(map(max_rel, o))):
                win += 1
    return win, n


def goal_text(it, pairs, per_it=None):
    n = len(pairs)
    if n == 0:
        return "No (model, cluster count) pair was run.\n"
    wins = sum(p["win"] for p in pairs)
    ours_wt = sum(1 for p in pairs if p.get("ours_watertight"))
    o3d_not = [p for p in pairs if not any(p["o3d_watertight"].values())]
    ours_wt_where = sum(1 for p in o3d_not if p.get("ours_watertight"))
    tr = sorted(p["time_ratio"] for p in pairs if "time_ratio" in p)
    cr = sorted(p["cpu_ratio"] for p in pairs if "cpu_ratio" in p)
    mr = sorted(p["rss_ratio"] for p in pairs if "rss_ratio" in p)

    def spread(v):
        return f"{v[0]:.1f}x to {v[-1]:.1f}x (median {v[len(v) // 2]:.1f}x)" if v else "n/a"

    lines = [
        f"Ours at {it} iterations against Open3D's better pipeline of the two in each pair "
        f"(time and memory: against Open3D's cheaper pipeline).\n",
        f"- Maximum distance at or below Open3D's best: {wins} of {n} pairs "
        f"({100 * wins / n:.0f} %; goal 80 %) -> **{'met' if wins >= 0.8 * n else 'not met'}**"
        + (" (other iteration counts: " + ", ".join(
            f"{w} of {m} at {i}" for i, (w, m) in per_it.items() if i != it) + ")"
           if per_it and len(per_it) > 1 else "") + ".",
        f"- Maximum distance at or below MeshLab's best of its three pipelines: "
        f"{sum(p['ml_win'] for p in pairs)} of {n} pairs.",
        f"- Valid solids (`vsaqem eval`: closed manifold, no self-intersecting faces, coincident "
        f"vertices, folds or bubbles): ours {sum(p['ours_valid'] for p in pairs)} of {n}; "
        + "; ".join(f"{label(s)} {sum(p['valid'].get(s, False) for p in pairs)} of "
                    f"{sum(s in p['valid'] for p in pairs)}" for s in SYSTEMS_OTHER) + ".",
        f"- Our meshes closed and manifold: {ours_wt} of {n} pairs; of the {len(o3d_not)} pairs "
        f"where neither Open3D mesh is, ours is in {ours_wt_where}.",
        f"- Whole-process wall time, Open3D / ours: {spread(tr)}; CPU time: {spread(cr)}. "
        f"At least 10x in {sum(t >= 10 for t in tr)} of {len(tr)} pairs -> "
        f"**{'met' if tr and tr[0] >= 10 else 'not met'}**.",
        f"- Peak RSS, Open3D / ours: {spread(mr)}. At least 20x in "
        f"{sum(m >= 20 for m in mr)} of {len(mr)} pairs -> "
        f"**{'met' if mr and mr[0] >= 20 else 'not met'}**.",
    ]
    losses = [p for p in pairs if not p["win"]]
    if losses:
        lines.append("- Pairs where our maximum distance is larger: " + ", ".join(
            f"{p['model']} {p['n']} ("
            + (f"{pct(p['ours_max'])} vs {pct(p['o3d_max'])} %" if p["ours_ok"] else "ours failed")
            + ")" for p in losses) + ".")
    return "\n".join(lines) + "\n"


REPORT_KEYS = ("points", "clusters", "initial_clusters", "splits", "passes",
               "max_error_relative", "solver_optimal", "solver_gap", "solver_nodes", "vertices",
               "faces", "boundary_edges", "components", "holes_filled", "holes_left",
               "uncovered_clusters", "uncovered_points", "time_ms", "arena_peak_bytes",
               # Open3D's and MeshLab's --info
               "steps_s", "poisson_vertices", "bpa_radii", "surface_faces", "bpa_faces",
               "normals_flipped")


def slim_record(r):
    """What runs.json keeps of a run: the relative distances, topology, our report's
    counts and stage times, Open3D's step times."""
    out = {k: v for k, v in r.items() if k not in ("eval", "report", "mesh")}
    if "report" in r:
        out["report"] = {k: r["report"][k] for k in REPORT_KEYS if k in r["report"]}
    if "eval" in r:
        ev = r["eval"]
        d = ev["point_to_mesh"]["distance"]
        out["eval"] = {
            "points": ev["points"], "diagonal": ev["diagonal"],
            "point_to_mesh": {k: d[k] for k in ("max_relative", "mean_relative", "rms_relative",
                                                "p99_relative")} | {"far": ev["point_to_mesh"]["far"]},
            "mesh_to_points": {k: ev["mesh_to_points"][k] for k in ("max_relative", "mean_relative")},
            "chamfer_relative": ev["chamfer_relative"],
            "hausdorff_relative": ev["hausdorff_relative"],
            "topology": ev["topology"],
            "validity": ev.get("validity"),
            "min_angle_p5": ev.get("quality", {}).get("min_angle_p5")}
    return slim(out)


def slim(x):
    """Floats to 5 significant digits, for a results file that diffs and stays small."""
    if isinstance(x, float):
        return float(f"{x:.5g}")
    if isinstance(x, dict):
        return {k: slim(v) for k, v in x.items()
                if k not in ("mesh", "input", "output", "points_file", "mesh_file")}
    if isinstance(x, (list, tuple)):
        return [slim(v) for v in x]
    return x


def per_model(a, models, idx, it):
    """One row per model: the goal's quantities over its cluster counts."""
    me = ours(it)

    def rng(v, fmt):
        v = [x for x in v if x is not None]
        if not v:
            return "-"
        lo, hi = min(v), max(v)
        return fmt(lo) if fmt(lo) == fmt(hi) else f"{fmt(lo)}-{fmt(hi)}"

    head = (f"| model | points | ours ({it} it.) max % at " + " / ".join(map(str, a.clusters))
            + " | best Open3D max % | ours at or below | best MeshLab max % "
            "| watertight: ours / Poisson / BPA | valid solids: ours / Open3D / MeshLab "
            "| wall s: ours / Open3D | peak RSS MB: ours / Open3D |\n"
            "|---|---:|---|---|---|---|---|---|---|---|\n")
    rows = []
    for model, _ in models:
        mine = [idx.get((model, me, n)) for n in a.clusters]
        best, wins, o3d_t, o3d_m = [], 0, [], []
        ml_best = [best_of(idx, model, n, SYSTEMS_ML) for n in a.clusters]
        solids = {"ours": 0, "o3d": 0, "ml": 0}
        for n in a.clusters:
            for key, systems in (("ours", [me]), ("o3d", SYSTEMS_O3D), ("ml", SYSTEMS_ML)):
                solids[key] += sum(valid_solid(x) for s in systems
                                   if (x := idx.get((model, s, n))) and x["status"] == "ok")
        wt = {s: 0 for s in [me] + SYSTEMS_O3D}
        pts = next((r["eval"]["points"] for r in mine if r and r.get("eval")), 0)
        for n, r in zip(a.clusters, mine):
            o = [x for s in SYSTEMS_O3D if (x := idx.get((model, s, n))) and x["status"] == "ok"]
            best.append(min(map(max_rel, o)) if o else None)
            if r and r["status"] == "ok" and (not o or max_rel(r) <= best[-1]):
                wins += 1
            for x in o + ([r] if r and r["status"] == "ok" else []):
                wt[x["system"]] += x["eval"]["topology"]["closed_manifold"]
            o3d_t += [x["wall_s"] for x in o]
            o3d_m += [x["max_rss_kb"] / 1024 for x in o if "max_rss_kb" in x]
        ok = [r for r in mine if r and r["status"] == "ok"]
        cells = [pct(max_rel(r)) if r and r["status"] == "ok" else "failed" for r in mine]
        nb = len(a.clusters)
        rows.append(
            f"| {model} | {pts:,} | {' / '.join(cells)} | "
            f"{' / '.join(pct(b) if b is not None else 'failed' for b in best)} | {wins} of {nb} | "
            f"{' / '.join(pct(max_rel(b)) if b else 'failed' for b in ml_best)} | "
            f"{wt[me]} / {wt['poisson']} / {wt['bpa']} of {nb} | "
            f"{solids['ours']} of {nb} / {solids['o3d']} of {len(SYSTEMS_O3D) * nb} / "
            f"{solids['ml']} of {len(SYSTEMS_ML) * nb} | "
            f"{rng([r['wall_s'] for r in ok], lambda x: f'{x:.1f}')} / {rng(o3d_t, lambda x: f'{x:.1f}')} | "
            f"{rng([r['max_rss_kb'] / 1024 for r in ok if 'max_rss_kb' in r], lambda x: f'{x:.0f}')} / "
            f"{rng(o3d_m, lambda x: f'{x:.0f}')} |")
    return head + "\n".join(rows) + "\n"


def write_csv(path, records):
    fields = ["model", "clusters", "system", "status", "reason", "vertices", "faces",
              "max_rel", "mean_rel", "p99_rel", "chamfer_rel", "hausdorff_rel",
              "closed_manifold", "boundary_edges", "non_manifold_edges",
              "non_manifold_vertices", "components", "valid_solid", "self_intersecting_pairs",
              "coincident_vertices", "folded_edges", "bubbles", "genus", "handles",
              "wall_s", "cpu_s", "max_rss_kb"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in records:
            row = {k: r.get(k) for k in ("model", "clusters", "system", "status", "reason",
                                         "wall_s", "cpu_s", "max_rss_kb")}
            if r["status"] == "ok":
                ev = r["eval"]
                d = ev["point_to_mesh"]["distance"]
                t = ev["topology"]
                row.update(vertices=t["vertices"], faces=t["faces"],
                           max_rel=d["max_relative"], mean_rel=d["mean_relative"],
                           p99_rel=d["p99_relative"], chamfer_rel=ev["chamfer_relative"],
                           hausdorff_rel=ev["hausdorff_relative"],
                           closed_manifold=t["closed_manifold"],
                           boundary_edges=t["boundary_edges"],
                           non_manifold_edges=t["non_manifold_edges"],
                           non_manifold_vertices=t["non_manifold_vertices"],
                           components=t["components"])
                v = ev.get("validity")
                if v:
                    row.update(valid_solid=v["valid_solid"],
                               self_intersecting_pairs=v["self_intersecting_pairs"],
                               coincident_vertices=v["coincident_vertices"],
                               folded_edges=v["folded_edges"], bubbles=v["bubbles"],
                               genus=" ".join(map(str, v["genus"])), handles=v["handles"])
            w.writerow(row)


# ---------------------------------------------------------------- plots


def save_fig(fig, path):
    """Saves a figure as a palette PNG (plots have few colours; a tenth of the bytes)."""
    import io
    from PIL import Image
    buf = io.BytesIO()
    fig.savefig(buf, dpi=80, format="png")
    buf.seek(0)
    Image.open(buf).convert("RGB").quantize(colors=64, method=Image.Quantize.MEDIANCUT).save(
        path, optimize=True)


STAGES = {"clustering": ("neighbours", "quadrics", "clustering"),
          "meshing": ("candidates", "scoring", "selection", "output"),
          "input/output": ("read", "validate", "write")}


def plots(a, models, idx, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [m for m, _ in models]
    ncol = min(5, len(names))
    nrow = (len(names) + ncol - 1) // ncol
    files = []

    # Time per stage vs iterations (the paper's Figures 11-13), from our reports.
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.8 * nrow), squeeze=False)
    colours = {"clustering": "#4c72b0", "meshing": "#dd8452", "input/output": "#999999"}
    for ax, model in zip(axes.flat, names):
        x, ticks, tick_labels = 0, [], []
        for n in a.clusters:
            for it in a.iterations:
                r = idx.get((model, ours(it), n))
                tm = (r or {}).get("report", {}).get("time_ms")
                if tm:
                    bottom = 0
                    for stage, keys in STAGES.items():
                        v = sum(tm.get(k, 0) for k in keys) / 1000
                        ax.bar(x, v, bottom=bottom, color=colours[stage], width=0.8,
                               label=stage if (x == 0) else None)
                        bottom += v
                else:
                    ax.text(x, 0, "x", ha="center", va="bottom", color="red")
                ticks.append(x)
                tick_labels.append(str(it))
                x += 1
            x += 0.6
        ax.set_xticks(ticks, tick_labels, fontsize=6)
        ax.set_title(model, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.set_ylabel("s", fontsize=7)
    for ax in axes.flat[len(names):]:
        ax.axis("off")
    h, l = axes.flat[0].get_legend_handles_labels()
    fig.legend(h, l, loc="lower center", ncol=3, fontsize=8)
    fig.suptitle("vsaqem reconstruct: time per stage vs iterations (bar groups: "
                 + ", ".join(f"{n}" for n in a.clusters) + " clusters)", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.95))
    files.append(out / "time_per_stage.png")
    save_fig(fig, files[-1])
    plt.close(fig)

    # Peak RSS and wall time per system (largest over the cluster counts).
    systems = systems_of(a)
    sys_colours = ["#c44e52", "#8172b2", "#e1812c", "#937860", "#da8bc3", "#55a868", "#4c72b0",
                   "#64b5cd", "#2b4c7e"]
    for key, unit, scale, fname, title in (
            ("max_rss_kb", "MB", 1 / 1024, "peak_memory.png", "whole-process peak RSS"),
            ("wall_s", "s", 1, "time.png", "whole-process wall time")):
        fig, ax = plt.subplots(figsize=(max(6, 1.1 * len(names) + 2), 4.0))
        w = 0.8 / len(systems)
        for j, s in enumerate(systems):
            vals = []
            for model in names:
                v = [r[key] for n in a.clusters
                     if (r := idx.get((model, s, n))) and key in r]
                vals.append(max(v) * scale if v else 0)
            ax.bar([i + (j - (len(systems) - 1) / 2) * w for i in range(len(names))], vals, w,
                   label=label(s), color=sys_colours[j % len(sys_colours)])
        ax.set_yscale("log")
        ax.set_xticks(range(len(names)), names, rotation=30, fontsize=8)
        ax.set_ylabel(unit)
        ax.set_title(f"{title} per system (largest over {', '.join(map(str, a.clusters))} clusters)",
                     fontsize=10)
        ax.legend(fontsize=7, ncol=len(systems), loc="upper center", bbox_to_anchor=(0.5, -0.28))
        ax.grid(axis="y", which="both", alpha=0.3)
        fig.tight_layout()
        files.append(out / fname)
        save_fig(fig, files[-1])
        plt.close(fig)

    # Error vs clusters (the paper's Figures 17-20).
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.8 * nrow), squeeze=False)
    for ax, model in zip(axes.flat, names):
        top = 0
        for j, s in enumerate(systems):
            xs, ys, fx = [], [], []
            for n in a.clusters:
                r = idx.get((model, s, n))
                if r and r["status"] == "ok":
                    xs.append(n)
                    ys.append(100 * max_rel(r))
                elif r:
                    fx.append(n)
            top = max([top] + ys)
            c = sys_colours[j % len(sys_colours)]
            ax.plot(xs, ys, "o-", ms=3, color=c, label=label(s))
            if fx:
                ax.plot(fx, [0] * len(fx), "x", color=c, ms=7, mew=2, clip_on=False)
        ax.set_title(model, fontsize=9)
        ax.set_xscale("log")
        ax.set_xticks(a.clusters, [str(n) for n in a.clusters], fontsize=7)
        ax.minorticks_off()
        ax.set_ylim(0, top * 1.1 + 1e-9)
        ax.tick_params(labelsize=7)
        ax.set_ylabel("max distance, % diag", fontsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(names):]:
        ax.axis("off")
    h, l = axes.flat[0].get_legend_handles_labels()
    fig.legend(h, l, loc="lower center", ncol=len(systems), fontsize=8)
    fig.suptitle("maximum distance from the input points to the mesh vs clusters "
                 "(x on the axis: failed)", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.95))
    files.append(out / "error_vs_clusters.png")
    save_fig(fig, files[-1])
    plt.close(fig)
    return files


# ---------------------------------------------------------------- pictures


def read_ply_points(path):
    """x y z of a binary little-endian PLY of float vertices (the shared clouds'
    format); other clouds are read with Open3D."""
    import numpy as np
    raw = Path(path).read_bytes()
    end = raw.find(b"end_header\n")
    header = raw[:end].decode(errors="replace").split("\n") if end > 0 else []
    props = [l.split()[-1] for l in header if l.startswith("property")]
    if (end > 0 and "format binary_little_endian 1.0" in header
            and all("float" in l for l in header if l.startswith("property"))
            and sum(l.startswith("element") for l in header) == 1 and props[:3] == ["x", "y", "z"]):
        data = np.frombuffer(raw[end + 11:], dtype="<f4")
        return data.reshape(-1, len(props))[:, :3].astype(np.float64)
    import open3d as o3d
    return np.asarray(o3d.io.read_point_cloud(str(path)).points)


def used_bounds(meshes):
    """Bounding box of the vertices the faces of `meshes` use (what vsaqem render
    frames several meshes by)."""
    import numpy as np
    import open3d as o3d
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for m in meshes:
        mesh = o3d.io.read_triangle_mesh(str(m))
        v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
        if len(t):
            u = v[np.unique(t)]
            lo, hi = np.minimum(lo, u.min(0)), np.maximum(hi, u.max(0))
    return lo, hi


def points_tile(points, lo, hi, up, size, title):
    """An image of the bare points, with vsaqem render's iso camera (orthographic,
    azimuth 35 deg, elevation 25 deg, the box's corners filling 88 % of the tile),
    darker further back. `vsaqem render` draws points only over a mesh, so the input
    tile is drawn here."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from PIL import Image

    sign = -1.0 if up.startswith("-") else 1.0
    ax_i = "xyz".index(up[-1])
    u = np.zeros(3); u[ax_i] = sign
    r = np.zeros(3); r[1 if ax_i == 0 else 0] = 1.0
    f = np.cross(r, u)
    az, el = np.radians(35), np.radians(25)
    eye = np.cos(el) * (np.cos(az) * f + np.sin(az) * r) + np.sin(el) * u
    eye /= np.linalg.norm(eye)
    right = np.cross(u, eye); right /= np.linalg.norm(right)
    upv = np.cross(eye, right)
    c = 0.5 * (lo + hi)
    corners = np.array([[hi[k] if (i >> k) & 1 else lo[k] for k in range(3)] for i in range(8)])
    proj = lambda p: np.stack([(p - c) @ right, (p - c) @ upv, (p - c) @ eye], axis=1)
    cq = proj(corners)
    mn, mx = cq[:, :2].min(0), cq[:, :2].max(0)
    w, h = size
    band = 24
    scale = min(0.88 * w / max(mx[0] - mn[0], 1e-12), 0.88 * h / max(mx[1] - mn[1], 1e-12))
    step = max(1, len(points) // 12000)
    q = proj(points[::step])
    order = np.argsort(q[:, 2])
    q = q[order]
    sx = 0.5 * w + scale * (q[:, 0] - 0.5 * (mn[0] + mx[0]))
    sy = 0.5 * h - scale * (q[:, 1] - 0.5 * (mn[1] + mx[1])) + band
    depth = (q[:, 2] - q[:, 2].min()) / max(np.ptp(q[:, 2]), 1e-12)
    col = np.outer(0.3 + 0.7 * depth, [215, 25, 35]) / 255
    dpi = 100
    fig = plt.figure(figsize=(w / dpi, (h + band) / dpi), dpi=dpi)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, w); ax.set_ylim(h + band, 0); ax.axis("off")
    ax.scatter(sx, sy, s=1.0, c=np.clip(col, 0, 1), marker=".", linewidths=0)
    ax.text(w / 2, 14, title, ha="center", va="center", fontsize=10, family="monospace")
    fig.canvas.draw()
    img = Image.frombuffer("RGBA", fig.canvas.get_width_height(), fig.canvas.buffer_rgba()).convert("RGB")
    plt.close(fig)
    return img


def picture(a, model, cloud, idx, work, out):
    """Like the paper's Figures 5-10: input points on the left, one row per system,
    cluster counts rising to the right. All meshes go through one `vsaqem render` call
    so they share one framing; the strip is then cut into tiles and laid out."""
    from PIL import Image, ImageDraw, ImageFont

    w, h = a.tile
    band = 24  # vsaqem render's label band: 7-pixel glyphs at scale 2 plus padding
    rows = [ours(it) for it in a.iterations] + SYSTEMS_OTHER
    tmp = work / model / "picture"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    names, where = [], []
    for i, s in enumerate(rows):
        for j, n in enumerate(a.clusters):
            r = idx.get((model, s, n))
            if r and r["status"] == "ok":
                name = f"{TILE_NAME.get(s, s)} {n}"
                link = tmp / f"{name}.ply"
                link.symlink_to(Path(r["mesh"]).resolve())
                names.append(link)
                where.append((i, j))
    if not names:
        return None
    strip = tmp / "strip.png"
    cmd = [a.vsaqem, "render", *names, "-o", strip, "--size", f"{w}x{h}",
           "--up", UP.get(model, "y")]
    if len(names) == 1:  # one mesh: no label band, own framing
        names.append(names[0])
        where.append(where[0])
        cmd.insert(3, names[0])
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if r.returncode != 0:
        log(f"  picture {model}: vsaqem render failed: {r.stderr.strip()}")
        return None
    strip_img = Image.open(strip).convert("RGB")
    tw, th = w, h + band
    canvas = Image.new("RGB", ((len(a.clusters) + 1) * tw + 150, len(rows) * th), "white")
    draw = ImageDraw.Draw(canvas)
    font = ImageFont.load_default(size=15)
    lo, hi = used_bounds(names)
    pts = read_ply_points(cloud)
    canvas.paste(points_tile(pts, lo, hi, UP.get(model, "y"), (w, h), "INPUT POINTS"), (150, 0))
    for k, (i, j) in enumerate(where):
        tile = strip_img.crop((k * tw, 0, (k + 1) * tw, th))
        canvas.paste(tile, (150 + (j + 1) * tw, i * th))
    for i, s in enumerate(rows):
        draw.text((8, i * th + th // 2), label(s), fill="black", font=font)
        for j, n in enumerate(a.clusters):
            rec = idx.get((model, s, n))
            if rec and rec["status"] != "ok":
                draw.text((150 + (j + 1) * tw + 10, i * th + th // 2),
                          f"{n}: failed", fill=(200, 0, 0), font=font)
    path = out / f"picture_{model}.png"
    canvas.quantize(colors=48, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(
        path, optimize=True)
    shutil.rmtree(tmp, ignore_errors=True)
    return path


# ---------------------------------------------------------------- main


def parse_list(s, conv=str):
    return [conv(x) for x in s.split(",") if x.strip()]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--clouds", type=Path, default=REPO.parent / "shared/data/clouds",
                    help="folder of point clouds (.ply/.xyz/.pcd); default ../shared/data/clouds")
    ap.add_argument("--models", type=parse_list, help="comma-separated file stems (default: all)")
    ap.add_argument("--clusters", type=lambda s: parse_list(s, int), default=[250, 500, 1000, 2000],
                    help="comma-separated cluster counts (250,500,1000,2000)")
    ap.add_argument("--iterations", type=lambda s: parse_list(s, int), default=[1, 5, 20],
                    help="comma-separated iteration counts of vsaqem (1,5,20)")
    ap.add_argument("--o3d-target", choices=["ours", "clusters"], default="ours",
                    help="Open3D and MeshLab decimate to 2x our largest vertex count (ours) or to "
                         "2N (clusters)")
    ap.add_argument("--out", type=Path, default=BENCH / "results", help="results folder")
    ap.add_argument("--work", type=Path, default=BENCH / "out/compare",
                    help="meshes, reports and logs (not committed)")
    ap.add_argument("--vsaqem", type=Path, default=REPO / "target/release/vsaqem")
    ap.add_argument("--python", type=Path, default=Path(sys.executable),
                    help="interpreter with Open3D and PyMeshLab for their pipelines")
    ap.add_argument("--timeout", type=float, default=600, help="seconds per process (600)")
    ap.add_argument("--pictures", type=parse_list, default=parse_list(PICTURE_MODELS),
                    help=f"models to draw side by side ({PICTURE_MODELS}; '' for none)")
    ap.add_argument("--tile", type=lambda s: tuple(map(int, s.split("x"))), default=(200, 200),
                    help="picture tile size WxH (200x200)")
    ap.add_argument("--reuse-others", action="store_true",
                    help="run ours, but take Open3D's and MeshLab's runs from the last run's "
                         "records in --work where one decimated to the same vertex count "
                         "succeeded (their meshes depend only on that; times are then that run's)")
    ap.add_argument("--reuse", action="store_true",
                    help="do not run anything: redo tables, plots and pictures from the last run's "
                         "records in --work")
    a = ap.parse_args()
    a.clusters = sorted(set(a.clusters))
    a.iterations = sorted(set(a.iterations))

    if not TIME.exists():
        sys.exit(f"error: {TIME} not found: install GNU time (`apt-get install -y time`)")
    if not a.vsaqem.exists():
        sys.exit(f"error: {a.vsaqem} not found: build it with `cargo build --release -p vsaqem`")
    if not a.clouds.is_dir():
        sys.exit(f"error: {a.clouds}: no such folder of point clouds")
    found = {p.stem: p for p in sorted(a.clouds.iterdir())
             if p.suffix.lower() in (".ply", ".xyz", ".xyzn", ".pcd", ".pts", ".txt")}
    names = a.models or sorted(found)
    missing = [m for m in names if m not in found]
    if missing:
        sys.exit(f"error: not in {a.clouds}: {', '.join(missing)} (have: {', '.join(found)})")
    models = [(m, found[m]) for m in names]
    a.out.mkdir(parents=True, exist_ok=True)
    work = a.work.resolve()
    work.mkdir(parents=True, exist_ok=True)

    info = machine_info()
    info["load_before"] = os.getloadavg()
    info["started"] = time.strftime("%Y-%m-%d %H:%M:%S")
    log(f"vsaqem compare: {len(models)} models x clusters {a.clusters} x "
        f"(ours at {a.iterations} iterations + {', '.join(map(label, SYSTEMS_OTHER))}); "
        f"load {info['load_before']}")
    saved = work / "records.json"
    if a.reuse:
        if not saved.exists():
            sys.exit(f"error: --reuse: {saved} not found (run without --reuse first)")
        old = json.loads(saved.read_text())
        info = old["machine"]
        want = {(m, s, n) for m, _ in models for s in systems_of(a) for n in a.clusters}
        records = [r for r in old["records"] if (r["model"], r["system"], r["clusters"]) in want]
        log(f"reusing {len(records)} runs of {info['started']} from {saved}")
    else:
        previous = {}
        if a.reuse_others and saved.exists():
            for r in json.loads(saved.read_text())["records"]:
                if r["system"] in SYSTEMS_OTHER and r["status"] == "ok":
                    previous[(r["model"], r["system"], r["clusters"], r["target_vertices"])] = r
            info["reused_from"] = json.loads(saved.read_text())["machine"].get("started")
        t0 = time.perf_counter()
        records = run_all(a, models, work, previous)
        info["run_s"] = time.perf_counter() - t0
        info["load_after"] = os.getloadavg()
        info["command"] = " ".join(x if x and " " not in x else repr(x) for x in sys.argv[1:])
        saved.write_text(json.dumps({"machine": info, "records": records}))
    idx = index(records)

    points = {}
    for m, p in models:
        r = next((r for r in records if r["model"] == m and r.get("eval")), None)
        points[m] = r["eval"]["points"] if r else 0
    for m, _ in models:
        (a.out / f"{m}.md").write_text(model_table(a, m, points[m], idx))
    it, pairs = goal(a, models, idx)
    settings = {"clouds": str(a.clouds), "models": names, "clusters": a.clusters,
                "iterations": a.iterations, "o3d_target": a.o3d_target,
                "open3d_pipeline": "normals: estimate_normals KNN 20 + "
                "orient_normals_consistent_tangent_plane(20); Poisson depth 8, vertices below "
                "the 2 % density quantile removed; BPA radii r, 2r with r = 3 x mean "
                "nearest-neighbour distance; simplify_quadric_decimation to 2V triangles",
                "meshlab_pipeline": "normals: compute_normal_for_point_clouds k 15, 2 smoothing "
                "iterations, oriented coherently (flipped as a whole if inward on average); "
                "Poisson: screened Poisson depth 8 or 10, vertices below the 2 % density (vertex "
                "quality) quantile removed; BPA: ball pivoting at radii r, 2r, 4r with r = mean "
                "nearest-neighbour distance, non-manifold edges and vertices repaired, holes of up "
                "to 100 edges closed; quadric edge collapse to 2V triangles (quality threshold "
                "0.3, preserve normals, preserve topology, optimal placement)",
                "vsaqem": "reconstruct --clusters N --iterations I, defaults otherwise (seed 1)"}
    with open(a.out / "runs.json", "w") as f:
        f.write('{"machine": ' + json.dumps(slim(info)) + ',\n"settings": ' + json.dumps(settings)
                + ',\n"runs": [\n' + ",\n".join(json.dumps(slim_record(r)) for r in records) + "\n]}\n")
    write_csv(a.out / "runs.csv", records)

    pics = []
    for m in a.pictures:
        if m in dict(models):
            try:
                p = picture(a, m, dict(models)[m], idx, work, a.out)
            except Exception as e:
                log(f"  picture {m} failed: {type(e).__name__}: {e}")
                p = None
            if p:
                pics.append(p)
                log(f"wrote {p}")
    try:
        plot_files = plots(a, models, idx, a.out)
    except Exception as e:
        log(f"plots failed: {type(e).__name__}: {e}")
        plot_files = []

    cmdline = "python bench/compare.py " + info.get("command", "")
    load = info["load_before"]
    summary = [
        "# vsaqem vs Open3D 0.20 and MeshLab (PyMeshLab)\n",
        f"Regenerate: `bash bench/compare.sh` (or `{cmdline.strip()}` in the venv it makes). "
        f"Run {info['started']} on {info.get('cpu', '?')} ({info['cpus']} cores, "
        f"{info.get('mem_gb', '?')} GB), vsaqem {info.get('vsaqem_commit', '?')}, "
        f"Open3D {info['open3d']}, PyMeshLab {info.get('pymeshlab', '?')}, Python {info['python']}; "
        f"the whole run took "
        f"{info['run_s'] / 60:.1f} min; load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} "
        f"at the start, {info['load_after'][0]:.2f} at the end (2 = both cores busy).\n",
        "Open3D: " + settings["open3d_pipeline"].replace("2V", "2V" if a.o3d_target == "ours" else "2N")
        + (" (V: the largest vertex count vsaqem gave for the same cloud and N)." if a.o3d_target == "ours"
           else "."),
        "MeshLab: " + settings["meshlab_pipeline"].replace("2V", "2V" if a.o3d_target == "ours" else "2N")
        + "; \"MeshLab best\" is, per model and N, the MeshLab mesh of lowest max distance.",
        "vsaqem: `reconstruct --clusters N --iterations I`, other parameters at their defaults "
        "(seed 1; splitting may add up to N clusters). Every system is timed as a whole process "
        "(wall and CPU time; peak RSS as GNU time reports it); every mesh is scored by `vsaqem eval` "
        "against its input cloud. Distances are % of the cloud's bounding-box diagonal; "
        "watertight = closed, edge- and vertex-manifold, consistently oriented; valid solid = "
        "watertight with no self-intersecting faces (exact test), coincident vertices, folds, "
        "bubbles or degenerate faces.\n",
        "## Against the goal\n",
        goal_text(it, pairs, {i: wins_at(a, models, idx, i) for i in a.iterations}),
        "Per model (Open3D: both pipelines; watertight counts are of the cluster counts):\n",
        per_model(a, models, idx, it),
        "\nPer model and cluster count (ratios: Open3D's cheaper pipeline over ours):\n",
        goal_table(it, pairs),
        "\n## Maximum distance per model (the paper's Tables 1-3)\n",
        "Per model, with vertex counts, times and memory: "
        + ", ".join(f"[{m}]({m}.md)" for m, _ in models) + ".\n",
    ]
    for m, _ in models:
        summary.append(f"### {m}\n\n" + max_table(a, m, idx))
    summary += ["## Every run\n", summary_rows(a, models, idx),
                "\n## Plots and pictures\n"]
    for f in plot_files + pics:
        summary.append(f"![{f.stem}]({f.name})\n")
    (a.out / "README.md").write_text("\n".join(summary))
    fails = [r for r in records if r["status"] != "ok"]
    log(f"done in {info['run_s'] / 60:.1f} min: {len(records)} runs, {len(fails)} failed; "
        f"results in {a.out}")
    for r in fails:
        log(f"  failed: {r['model']} N={r['clusters']} {label(r['system'])}: {r.get('reason')}")


if __name__ == "__main__":
    main()
