#!/usr/bin/env bash
# Quick start, command 2: installs what is missing, then builds and runs the whole test suite
# three times — g++ and clang++ with warnings as errors, and clang++ with AddressSanitizer and
# UndefinedBehaviorSanitizer — and ends with ctest's summary (set -e stops at the first preset that fails).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc)
for preset in gcc clang sanitize; do
  echo "== isin: $preset" >&2
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j"$jobs"
  ctest --preset "$preset" -j"$jobs"
done
