#!/usr/bin/env bash
# Quick start, command 1: installs what is missing, builds every example (Release) into
# build/release/examples/ and runs the main one: the note's scene rendered at 800×450 to
# notes_scene.png in the current directory. Extra arguments go to notes_scene (see --help).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
bash "$repo/scripts/deps.sh"
(cd "$repo" && cmake --preset release >/dev/null &&
  cmake --build --preset release -j"$(nproc)" --target isin_examples)
"$repo/build/release/examples/notes_scene" "$@"
