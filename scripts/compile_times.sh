#!/usr/bin/env bash
# What including isin costs a user: compile times (medians of N runs, default 5) of
#   isin.hpp      a file that only includes <isin/isin.hpp>
#   notes_scene   examples/notes_scene.cpp (builds the note's scene, a StandardScene, renders,
#                 writes a PNG; the file code, the scene's members and its renderer come from
#                 isin::io, compiled once elsewhere)
#   mesh_view     examples/mesh_view.cpp (loads a model into a StandardScene, renders it)
#   io            the one file that compiles isin::io (ISIN_IMPLEMENTATION: the file code with stb
#                 and tinyobjloader, the Bvh builder, StandardScene and its renderer)
# with g++ and clang++ at -O0 and -O2 (-std=c++17, compile only), plus preprocessed lines and
# the compiler's peak memory; then the first two with g++ and isin.hpp precompiled (what CMake's
# target_precompile_headers(app PRIVATE <isin/isin.hpp>) does). Examples are compiled as CMake's
# isin::io users are (ISIN_COMPILED). Usage: scripts/compile_times.sh [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf '#include <isin/isin.hpp>\nint main() { return 0; }\n' > "$work/isin_only.cpp"
printf '#define ISIN_IMPLEMENTATION\n#include <isin/isin.hpp>\n' > "$work/io.cpp" # as CMake's isin::io
declare -A sources=([isin.hpp]="$work/isin_only.cpp" [notes_scene]=examples/notes_scene.cpp
                    [mesh_view]=examples/mesh_view.cpp [io]="$work/io.cpp")
median() { sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
printf '%-12s %-8s %-4s %9s %9s %10s\n' file compiler opt "median s" "peak MB" "lines"
for name in isin.hpp notes_scene mesh_view io; do
  src=${sources[$name]}
  for cxx in g++ clang++; do
    lines=$($cxx -std=c++17 -DISIN_COMPILED -E -I include "$src" | grep -vc '^#' || true)
    for opt in -O0 -O2; do
      times=() peak=0
      for ((r = 0; r < runs; ++r)); do
        out=$( { /usr/bin/time -f '%e %M' $cxx -std=c++17 $opt -DISIN_COMPILED -I include -c "$src" -o "$work/out.o"; } 2>&1 | tail -1)
        times+=("${out% *}")
        kb=${out#* }
        [ "$kb" -gt "$peak" ] && peak=$kb
      done
      printf '%-12s %-8s %-4s %9s %9d %10d\n' "$name" "$cxx" "$opt" "$(printf '%s\n' "${times[@]}" | median)" $((peak / 1024)) "$lines"
    done
  done
done
# Precompiled as CMake's target_precompile_headers does it: a header that includes isin.hpp,
# compiled once, force-included into each file.
printf '#include <isin/isin.hpp>\n' > "$work/isin_pch.hpp"
for opt in -O0 -O2; do
  g++ -std=c++17 $opt -DISIN_COMPILED -I include -x c++-header "$work/isin_pch.hpp" -o "$work/isin_pch.hpp.gch"
  for name in isin.hpp notes_scene; do
    src=${sources[$name]}
    times=()
    for ((r = 0; r < runs; ++r)); do
      times+=("$( { /usr/bin/time -f '%e' g++ -std=c++17 $opt -DISIN_COMPILED -Winvalid-pch -I include -include "$work/isin_pch.hpp" -c "$src" -o "$work/out.o"; } 2>&1 | tail -1)")
    done
    printf '%-12s %-8s %-4s %9s %9s %10s\n' "$name" "g++ pch" "$opt" "$(printf '%s\n' "${times[@]}" | median)" - -
  done
done
