#!/usr/bin/env bash
# Writes the fuzz targets' seed inputs into fuzz/seeds/<target>/, made from
# core's generated shapes by host/examples/fuzz_seeds.rs (nothing of
# ../shared/data, and no binary committed): clouds in every format the
# readers take, core's meshes of them, command lines, eval and reconstruct
# inputs in those targets' layouts.
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf fuzz/seeds
cargo run --release -q -p vsaqem --example fuzz_seeds -- fuzz/seeds
