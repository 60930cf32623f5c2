#!/usr/bin/env bash
# Regenerates isin's accuracy-against-speed study: builds the benchmarks (Release,
# -march=native), runs benchmarks/accuracy_vs_speed on one core, and draws the chart with
# gnuplot: docs/accuracy_vs_speed.csv, docs/accuracy_vs_speed_points.csv,
# docs/accuracy_vs_speed.svg and docs/accuracy_vs_speed.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh gnuplot-nox
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target accuracy_vs_speed
taskset -c 0 ./build/bench/benchmarks/accuracy_vs_speed --repeats "${REPEATS:-9}" \
  --csv docs/accuracy_vs_speed.csv --points docs/accuracy_vs_speed_points.csv
gnuplot -e "points='docs/accuracy_vs_speed_points.csv'; out='docs/accuracy_vs_speed'" benchmarks/accuracy_vs_speed.gp
echo "wrote docs/accuracy_vs_speed.{csv,svg,png} and docs/accuracy_vs_speed_points.csv"
