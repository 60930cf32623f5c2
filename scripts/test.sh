#!/usr/bin/env bash
# Quick start, command 2: installs what is missing, then runs the stability and BVH tests with
# g++ and clang++ at -O0 and at -O3 -march=native (their guarantees must survive any FMA
# contraction), the whole test suite four times — g++ and clang++ with warnings as errors,
# clang++ with AddressSanitizer and UndefinedBehaviorSanitizer, clang++ with ThreadSanitizer —
# and fuzzes the file readers (scripts/fuzz.sh, ISIN_FUZZ_SECONDS per target, default 45;
# 0 skips it). set -e stops at the first configuration that fails.
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
for preset in gcc clang sanitize tsan; do
  echo "== isin: $preset" >&2
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j"$jobs"
  ctest --preset "$preset" -j"$jobs"
done
fuzz_seconds=${ISIN_FUZZ_SECONDS:-45}
if [ "$fuzz_seconds" != 0 ]; then
  bash scripts/fuzz.sh "$fuzz_seconds"
fi
