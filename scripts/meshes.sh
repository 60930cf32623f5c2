#!/usr/bin/env bash
# Regenerates isin's mesh study: isin's Bvh against Embree 3 (benchmark-only dependency) on five
# generated meshes at 1920×1080, 1 and 2 threads, then Mrays/s against triangle count, drawn to
# docs/scaling.{svg,png}. Prints the tables; exits non-zero if isin and Embree disagree.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh libembree-dev gnuplot-nox
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target vs_embree scaling
./build/bench/benchmarks/vs_embree "$@"
./build/bench/benchmarks/scaling --csv docs/scaling.csv
gnuplot -e "data='docs/scaling.csv'; out='docs/scaling'" benchmarks/scaling.gp
echo "wrote docs/scaling.{csv,svg,png}"
