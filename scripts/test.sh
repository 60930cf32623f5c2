#!/usr/bin/env bash
# Quick start, command 2: installs what is missing, then builds and runs the whole test suite
# three times — g++ and clang++ with warnings as errors, and clang++ with AddressSanitizer and
# UndefinedBehaviorSanitizer — then the stability and BVH tests once more with g++ and clang++ at -O0 and
# at -O3 -march=native (their guarantees must survive any FMA contraction), and ends with
# ctest's summary (set -e stops at the first configuration that fails).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc)
for cxx in g++ clang++; do
  for flags in "-O0" "-O3 -march=native"; do
    dir="build/stability-$cxx${flags// /}"
    echo "== isin: stability tests, $cxx $flags" >&2
    cmake -S . -B "$dir" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=None \
      -DCMAKE_CXX_FLAGS="$flags" -DISIN_WERROR=ON -DISIN_BUILD_EXAMPLES=OFF >/dev/null
    cmake --build "$dir" -j"$jobs" --target test_stability test_bvh
    ctest --test-dir "$dir" -R '^(test_stability|test_bvh)$' --output-on-failure
  done
done
for preset in gcc clang sanitize; do
  echo "== isin: $preset" >&2
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j"$jobs"
  ctest --preset "$preset" -j"$jobs"
done
