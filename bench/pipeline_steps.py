"""What bench/o3d_pipeline.py and bench/meshlab_pipeline.py share: the clock of their
steps and the --info file compare.py reads. Benchmarks only, not part of vsaqem."""

import json
import time


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
