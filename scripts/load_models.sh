#!/usr/bin/env bash
# isin's model loading against assimp (benchmarks/load_models.cpp): installs what is missing
# (libassimp-dev, assimp-testmodels), fetches the Stanford dragon once and writes it as ASCII,
# binary little- and big-endian PLY and as two OBJs into build/load_models/ (scripts/dragon.sh),
# builds the benchmark in Release with -march=native (the bench preset) and runs it on those five
# files. Arguments go to the benchmark, e.g. --rounds 7, --all-testmodels, or files in place of
# the dragon's.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh libassimp-dev assimp-testmodels
bash scripts/dragon.sh
data=build/load_models
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target load_models
./build/bench/benchmarks/load_models --data "$data" "$@"
