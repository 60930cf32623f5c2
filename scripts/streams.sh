#!/usr/bin/env bash
# isin's stream calls against Embree's packets over several runs: runs `vs_embree --studies none`
# RUNS times (default 5), each a fresh process, and prints for every mesh and thread count the
# median and the range over the runs of the three ratios of vs_embree's stream table: camera rays
# ÷ rtcIntersect16, shadow rays ÷ rtcOccluded16, diffuse bounces ÷ rtcIntersect1 (each run's
# ratio: medians of --repeats interleaved measures, as vs_embree prints it). A machine shared with
# other tenants runs some processes 10-25% slower for a while, on one library more than on the
# other, so one run's ratio can fall a long way from the others (docs/performance.md, "How we measure").
# vs_embree pins each measure's threads to the CPUs the process may use (--no-pin
# passed through turns that off), so a one-thread measure no longer changes cores between
# measures or half-way through one.
# Usage: RUNS=5 scripts/streams.sh [vs_embree options, e.g. --threads-list 1 --repeats 7]
# Writes the runs' rows to build/bench/streams.csv and their tables to build/bench/streams-run*.txt;
# exits non-zero if isin and Embree disagree.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-5}
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "streams.sh: RUNS must be a positive integer" >&2; exit 2; }
bash scripts/deps.sh libembree-dev
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target vs_embree
csv=build/bench/streams.csv
rm -f "$csv"
for ((run = 1; run <= runs; ++run)); do
  echo "run $run of $runs" >&2
  log=build/bench/streams-run$run.txt
  if ! ./build/bench/benchmarks/vs_embree --studies none "$@" --stream-csv "$csv" >"$log"; then
    cat "$log"
    exit 1
  fi
done
echo "each run's ratios (stream / E-16 camera, shadow; stream / E-1 diffuse):"
awk -F, 'NR > 1 { printf "  %-15s %d thr: %.2f %.2f %.2f\n", $1, $2, $15, $16, $17 }' "$csv"
# One line per mesh, thread count, ratio and run; sorted, so each group's values come in order.
awk -F, 'NR > 1 { for (c = 15; c <= 17; ++c) print $1, $2, c, $c }' "$csv" | sort -k1,1 -k2,2n -k3,3n -k4,4g |
  awk '
    function flush() {
      if (n == 0) return
      med = n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
      cell[key, col] = sprintf("%.2f (%.2f-%.2f)", med, v[1], v[n])
      if (!(key in seen)) { seen[key] = 1; order[++keys] = key }
      n = 0
    }
    { if ($1 " " $2 != key || $3 != col) { flush(); key = $1 " " $2; col = $3 }; v[++n] = $4 }
    END {
      flush()
      printf "%-15s %3s | %-22s | %-22s | %-22s\n", "mesh", "thr", "camera / E-16", "shadow / O-16", "diffuse / E-1"
      for (i = 1; i <= keys; ++i) {
        split(order[i], k, " ")
        printf "%-15s %3d | %-22s | %-22s | %-22s\n", k[1], k[2], cell[order[i], 15], cell[order[i], 16],
               cell[order[i], 17]
      }
      print "median (least-greatest) over the runs"
    }'
