"""What bench/o3d_pipeline.py and bench/meshlab_pipeline.py share: their common
arguments, the clock of their steps and the --info file compare.py reads. Benchmarks
only, not part of vsaqem."""

import argparse
import json
import time


def arguments(doc):
    """A parser of the arguments both pipelines take; each adds its own."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--method", choices=["poisson", "bpa"], required=True)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("n", type=int, help="target vertex count (2N triangles)")
    ap.add_argument("--depth", type=int, default=8, help="Poisson octree depth (8)")
    ap.add_argument("--trim", type=float, default=0.02,
                    help="Poisson: remove vertices below this density quantile (0.02)")
    ap.add_argument("--info", help="write step times and counts here as JSON")
    return ap


class Steps:
    """`info`, the run's counts for --info, with `steps_s`: seconds per named step,
    each from the end of the one before (the first from construction)."""

    def __init__(self, method, n):
        self.info = {"method": method, "n": n, "steps_s": {}}
        self.t = time.perf_counter()

    def done(self, name):
        now = time.perf_counter()
        self.info["steps_s"][name] = round(now - self.t, 4)
        self.t = now

    def write(self, path):
        """Writes `info` as JSON to `path` when one was given."""
        if path:
            with open(path, "w") as f:
                json.dump(self.info, f, indent=1)
