#!/usr/bin/env bash
# One command for the comparison with Open3D: installs what it needs (system
# libraries, a Python venv with bench/requirements.txt), builds vsaqem in release
# and runs bench/compare.py with the arguments given, e.g.
#
#   bash bench/compare.sh                                   # all clouds in ../shared/data/clouds
#   bash bench/compare.sh --models bunny,block --clusters 250 --iterations 5
#   bash bench/compare.sh --clouds ~/scans --out ~/scans/results
#
# Environment: VENV (default bench/.venv), PYTHON (default python3, 3.11 tested).
set -euo pipefail
source "$(dirname "$0")/setup.sh"
exec "$VENV/bin/python" bench/compare.py "$@"
