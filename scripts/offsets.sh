#!/usr/bin/env bash
# Regenerates isin's secondary-ray study (issue 15): builds the benchmarks (Release,
# -march=native), runs benchmarks/offsets (six offset methods on the workloads of
# tests/support/secondary.hpp, float and double) and draws the chart with gnuplot:
# docs/offsets.csv, docs/offsets.txt (the printed tables), docs/offsets.svg and docs/offsets.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh gnuplot-nox
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target offsets
./build/bench/benchmarks/offsets --primaries "${PRIMARIES:-2000}" --csv docs/offsets.csv | tee docs/offsets.txt
gnuplot -e "data='docs/offsets.csv'; out='docs/offsets'" benchmarks/offsets.gp
echo "wrote docs/offsets.{csv,txt,svg,png}"
