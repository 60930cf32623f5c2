#!/usr/bin/env bash
# Closest points against Embree's rtcPointQuery and CGAL's AABB_tree, and the inside/outside
# methods' wrong answers against time per point (docs/queries.md): builds the `queries`
# benchmark (Release, -march=native) and runs it RUNS times (default 3), each a fresh process
# pinned to CPU 1, one thread. Usage: RUNS=3 scripts/queries.sh [points] [repeats] [dragon.ply]
# The Stanford dragon is measured when build/load_models/dragon_le.ply exists (scripts/dragon.sh
# fetches it). Writes each run's CSV to build/bench/queries-run*.csv.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-3}
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "queries.sh: RUNS must be a positive integer" >&2; exit 2; }
bash scripts/deps.sh libembree-dev
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target queries
for ((run = 1; run <= runs; ++run)); do
  echo "run $run of $runs" >&2
  taskset -c 1 ./build/bench/benchmarks/queries "$@" | tee "build/bench/queries-run$run.csv"
done
