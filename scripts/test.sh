#!/usr/bin/env bash
# Quick start, command 2. Installs what is missing, then:
#   bash scripts/test.sh         the quick check: the whole unit suite built once (g++, -O1,
#                                warnings as errors) and run, without the tests that build
#                                programs of their own (label integration); 3.5 minutes on 2 cores.
#   bash scripts/test.sh --all   what CI runs (.ci/run), about 35 minutes on 2 cores:
#  1. checks the layout of every C++ file (scripts/format.sh --check, .clang-format) and of the
#     headers (scripts/layout_check.py: include cycles, folders, lengths; also a unit test);
#  2. runs the stability, BVH, query and lane-filter tests (and the BVH stream and, at -march=native, vertex-normal tests) with g++ and clang++ at -O0 and at -O3 -march=native
#     (their guarantees must survive any FMA contraction), on the portable path with no vector
#     extension or intrinsic (-DISIN_FORCE_PURE=ON), on the AVX path without FMA (g++ -mavx
#     -mno-fma) and on AVX2 + FMA without AVX-512 (clang++ -march=haswell: the packets' AVX2 form);
#  3. runs the whole test suite three times, warnings as errors: g++ (preset gcc), clang++ with
#     AddressSanitizer and UndefinedBehaviorSanitizer (sanitize), clang++ with ThreadSanitizer
#     (tsan). The tsan preset is the clang preset's build (RelWithDebInfo, warnings as errors)
#     with ThreadSanitizer, so it also stands for it: one whole-suite build fewer keeps CI within
#     its time on 2 cores;
#  4. compiles the benchmarks (against Embree: libembree-dev; load_models against assimp:
#     libassimp-dev), warnings as errors, without running them;
#  5. fuzzes the file readers (scripts/fuzz.sh, ISIN_FUZZ_SECONDS per target (at most), default 30; 0
#     skips it).
# set -e stops at the first step that fails.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)
case "${1:-}" in
  --all) ;;
  "")
    bash scripts/deps.sh
    echo "== isin: the unit tests (g++ -O1, warnings as errors); scripts/test.sh --all runs what CI runs" >&2
    cmake -S . -B build/quick -DCMAKE_CXX_COMPILER=g++ -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS=-O1 \
      -DISIN_WERROR=ON -DISIN_BUILD_EXAMPLES=OFF >/dev/null
    cmake --build build/quick -j"$jobs"
    ctest --test-dir build/quick -j"$jobs" --output-on-failure --label-exclude integration
    exit 0
    ;;
  *)
    echo "usage: bash scripts/test.sh [--all]" >&2
    exit 2
    ;;
esac
bash scripts/deps.sh clang-format parallel libembree-dev libassimp-dev
bash scripts/format.sh --check
python3 scripts/layout_check.py
# compiler | flags | extra CMake arguments
configurations=(
  "g++|-O0|" "g++|-O3 -march=native|" "clang++|-O0|" "clang++|-O3 -march=native|"
  "g++|-O2|-DISIN_FORCE_PURE=ON" "clang++|-O3 -march=native|-DISIN_FORCE_PURE=ON"
  "g++|-O2 -mavx -mno-fma|" "clang++|-O3 -march=haswell|"
)
for configuration in "${configurations[@]}"; do
  IFS='|' read -r cxx flags extra <<<"$configuration"
  dir="build/stability-$cxx${flags// /}${extra:+-pure}"
  echo "== isin: stability and BVH tests, $cxx $flags $extra" >&2
  cmake -S . -B "$dir" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="$flags" \
    -DISIN_WERROR=ON -DISIN_BUILD_EXAMPLES=OFF $extra >/dev/null
  # the stream tests where packets are compiled: on AVX-512 (native) and on AVX2 + FMA alone
  # (haswell); and not at all (g++ -O0). The portable and AVX-without-FMA paths trace streams
  # one ray at a time, as at -O0, which the presets' runs cover
  stream=test_bvh_stream
  case "$cxx $flags $extra" in *FORCE_PURE* | *mno-fma* | "clang++ -O0 ") stream= ;; esac
  # the vertex-normal tests where FMA may be contracted (-march=native); elsewhere the presets' runs
  normals=
  case "$flags" in *march=native*) normals=test_indexed_mesh ;; esac
  extra_tests="$stream${stream:+${normals:+ }}$normals"
  cmake --build "$dir" -j"$jobs" --target test_stability test_bvh test_queries test_ray_lanes $extra_tests
  ctest --test-dir "$dir" -R "^(test_stability|test_bvh|test_queries|test_ray_lanes${extra_tests:+|${extra_tests// /|}})\$" --output-on-failure
done
for preset in gcc sanitize tsan; do
  echo "== isin: $preset" >&2
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j"$jobs"
  ctest --preset "$preset" -j"$jobs"
done
echo "== isin: benchmarks compile (not run)" >&2
cmake -S . -B build/ci-benchmarks -DCMAKE_CXX_COMPILER=g++ -DCMAKE_BUILD_TYPE=Release -DISIN_WERROR=ON \
  -DISIN_BUILD_BENCHMARKS=ON -DISIN_BUILD_TESTS=OFF -DISIN_BUILD_EXAMPLES=OFF >/dev/null
cmake --build build/ci-benchmarks -j"$jobs"
fuzz_seconds=${ISIN_FUZZ_SECONDS:-30}
if [ "$fuzz_seconds" != 0 ]; then
  bash scripts/fuzz.sh "$fuzz_seconds"
fi
