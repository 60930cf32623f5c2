#!/usr/bin/env bash
# The build table of docs/performance.md: isin's and Embree's build times (RTC_BUILD_QUALITY_MEDIUM) of each
# benchmark mesh on 1 and 2 threads, each library alone in a child process of its own
# (`vs_embree --build-only`), the two libraries' processes alternated; prints the median of 5
# processes of 5 builds each, and the cores kept busy (CPU time / wall time).
# Usage: scripts/builds.sh [mesh …]   (default: the five benchmark meshes)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh libembree-dev
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target vs_embree >/dev/null
run=./build/bench/benchmarks/vs_embree
meshes=("$@")
[ ${#meshes[@]} -gt 0 ] || meshes=(icosphere-80k icosphere-1.3M trefoil-300k terrain-500k soup-200k)
median() { printf '%s\n' "$@" | sort -g | sed -n "$((($# + 1) / 2))p"; }
printf '%-15s %3s | %9s %5s | %9s %5s | %5s\n' mesh thr "isin ms" busy "Embree ms" busy ratio
for mesh in "${meshes[@]}"; do
    for threads in 1 2; do
        isin_ms=() isin_busy=() embree_ms=() embree_busy=()
        for _ in 1 2 3 4 5; do  # 5: a process that lands on a core the host keeps busy is one of 5
            # BUILD isin_ms isin_busy embree_ms embree_busy …
            read -r _ ms busy _ < <("$run" --build-only --mesh "$mesh" --threads "$threads" --library isin --repeats 5)
            isin_ms+=("$ms") isin_busy+=("$busy")
            read -r _ _ _ ms busy _ < <("$run" --build-only --mesh "$mesh" --threads "$threads" --library embree --repeats 5)
            embree_ms+=("$ms") embree_busy+=("$busy")
        done
        i=$(median "${isin_ms[@]}") e=$(median "${embree_ms[@]}")
        printf '%-15s %3d | %9.1f %5.2f | %9.1f %5.2f | %5.2f\n' "$mesh" "$threads" "$i" \
            "$(median "${isin_busy[@]}")" "$e" "$(median "${embree_busy[@]}")" "$(awk -v a="$i" -v b="$e" 'BEGIN { print a / b }')"
    done
done
