#!/usr/bin/env bash
# Quick start, command 1: installs what is missing, builds isin's examples (Release), runs the
# main example.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
cmake --preset release >/dev/null
cmake --build --preset release -j"$(nproc)" --target worked_examples
./build/release/examples/worked_examples "$@"
