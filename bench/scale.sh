#!/usr/bin/env bash
# Time and memory against the number of points, beside Open3D: installs what it
# needs as bench/compare.sh does, then runs bench/scale.py with the arguments
# given, e.g.
#
#   bash bench/scale.sh                                        # bunny to 10M points
#   bash bench/scale.sh --sizes 100000,1000000 --threads 1,2 --open3d-max 300000
#   bash bench/scale.sh --aarch64 target/aarch64-unknown-linux-musl/release/vsaqem
#
# Writes bench/results/scale.md. Environment: VENV, PYTHON as for compare.sh.
set -euo pipefail
source "$(dirname "$0")/setup.sh"
exec "$VENV/bin/python" bench/scale.py "$@"
