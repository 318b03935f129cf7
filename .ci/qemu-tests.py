#!/usr/bin/env python3
"""Runs the aarch64 test binaries under qemu-aarch64-static for .ci/run.

Usage: qemu-tests.py LISTING WORKERS

LISTING is the JSON that `cargo test --release --no-run --message-format=json`
printed for the aarch64 target (.ci/background-builds.sh writes it). Each test
binary runs as cargo would run it (through qemu, in its package's directory),
WORKERS at a time, the longest first, and then the doc tests through cargo
(the runner in .cargo/config.toml). Each one's output is printed whole, in the
listing's order, with its wall time; the exit status is 1 when any failed.
"""
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

# Seconds under qemu in CI (ci27, 2026-12-02, two at a time on two cores),
# for the order only: the longest start first so that the two workers end
# together. A binary not named here is taken as short.
SECONDS = {
    ("vsaqem_core", "lib"): 116,
    ("vsaqem", "lib"): 41,
    ("closed_streams", "test"): 34,
    ("formats", "test"): 31,
    ("clustering", "test"): 15,
}

# Tests left to the native run. eval.rs's pile of copied faces checks the work
# limit of `vsaqem eval`'s self-intersection test, integer counting on the host
# side: 4.4 s natively, 180 s under qemu (ci27), alone a third of this step.
SKIP = {
    ("eval", "test"): ["--skip", "a_pile_of_copied_faces_is_judged_in_bounded_time_with_a_lower_bound"],
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
    out.append(
        {
            "name": "doc tests of vsaqem-core and vsaqem",
            "cwd": os.getcwd(),
            "argv": "cargo test --release -p vsaqem-core -p vsaqem "
            "--target aarch64-unknown-linux-musl --doc".split(),
            "seconds": 10,
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
    print(f"{len(todo) - 1} test binaries and the doc tests, {workers} at a time", flush=True)
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
