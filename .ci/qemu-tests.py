#!/usr/bin/env python3
"""Runs the aarch64 test binaries under qemu-aarch64-static for .ci/run.

Usage: qemu-tests.py LISTING WORKERS

LISTING is the JSON that `cargo test --release --no-run --message-format=json`
printed for the aarch64 target (.ci/background-builds.sh writes it). Each test
binary runs as cargo would run it (through qemu, in its package's directory),
WORKERS at a time, the longest first. Each one's output is printed whole, in
the listing's order, with its wall time; the exit status is 1 when any failed.

The doc tests do not run here: core's one example runs in the native test
run, and under qemu the step compiled both crates' documentation for it, 38
CPU-s on the idle machine (24 s of wall time, 2026-12-02), for no check the
unit tests do not make on this target.
"""
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

# Seconds under qemu in CI (ci27, 2026-12-02, two at a time on two cores;
# the two unit-test binaries scaled by what SKIP took out of them on the idle
# machine), for the order only: the longest start first so that the two
# workers end together. A binary not named here is taken as short.
SECONDS = {
    ("vsaqem_core", "lib"): 43,
    ("vsaqem", "lib"): 11,
    ("closed_streams", "test"): 34,
    ("formats", "test"): 31,
    ("clustering", "test"): 15,
}

# Tests left to the native run. Each is a randomised or exhaustive comparison
# of integer and IEEE arithmetic (the same on every target: Rust does not
# contract or reorder floating point) whose time under qemu bought no check
# the other tests do not make here; natively they take seconds.
# eval.rs's pile of copied faces, and its twin among the host's unit tests,
# check the work limit of `vsaqem eval`'s self-intersection test: 4.4 s
# natively, 180 s under qemu (ci27), alone a third of this step; the unit
# test 34 s under qemu on the idle machine (2026-12-02).
# Core's four comparisons of the facet selection with brute force and with
# itself (random instances, groups beside a lane, node limits): 82 of the
# 131 CPU-s core's unit tests took under qemu on the idle machine
# (2026-12-02). The selection on this target is still checked whole by the
# smoke step's byte comparisons with x86-64 (the bunny, and a generated shape
# on 1, 2, 3 and 8 threads).
SELECT = "meshing::select::tests::"
SKIP = {
    ("eval", "test"): ["--skip", "a_pile_of_copied_faces_is_judged_in_bounded_time_with_a_lower_bound"],
    ("vsaqem", "lib"): [
        "--skip",
        "eval::intersect::tests::a_pile_of_copies_stops_the_test_with_a_lower_bound",
    ],
    ("vsaqem_core", "lib"): [
        arg
        for name in [
            "balls_searched_in_groups_beside_a_lane_give_the_selection_of_balls_in_turn",
            "matches_brute_force_with_random_at_most_one_groups",
            "node_limits_still_give_feasible_selections_with_honest_bounds",
            "matches_brute_force_on_small_random_instances",
        ]
        for arg in ["--skip", SELECT + name]
    ],
}


def jobs(listing):
    out = []
    for line in open(listing):
        if not line.startswith("{"):
            continue
        m = json.loads(line)
        if m.get("reason") != "compiler-artifact" or not m.get("executable"):
            continue
        if not m["profile"]["test"]:
            continue
        t = m["target"]
        key = (t["name"], t["kind"][0])
        out.append(
            {
                "name": t["src_path"],
                "cwd": os.path.dirname(m["manifest_path"]),
                "argv": ["qemu-aarch64-static", m["executable"]] + SKIP.get(key, []),
                "seconds": SECONDS.get(key, 1),
            }
        )
    return out


def run(job):
    start = time.monotonic()
    p = subprocess.run(
        job["argv"], cwd=job["cwd"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT
    )
    return p.returncode, p.stdout.decode(errors="replace"), time.monotonic() - start


def main():
    listing, workers = sys.argv[1], int(sys.argv[2])
    todo = jobs(listing)
    print(f"{len(todo)} test binaries, {workers} at a time", flush=True)
    order = sorted(range(len(todo)), key=lambda i: -todo[i]["seconds"])
    with ThreadPoolExecutor(workers) as pool:
        done = dict(zip(order, pool.map(run, (todo[i] for i in order))))
    failed = []
    for i, job in enumerate(todo):
        status, text, seconds = done[i]
        print(f"     Running {job['name']} ({' '.join(job['argv'])}): {seconds:.0f} s")
        print(text, end="", flush=True)
        if status != 0:
            failed.append(job["name"])
    if failed:
        print("FAIL: aarch64 tests:", ", ".join(failed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
