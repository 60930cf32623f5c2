#!/usr/bin/env bash
# What including isin costs a user: compile times (medians of N runs, default 5) of
#   isin.hpp      a file that only includes <isin/isin.hpp>
#   notes_scene   examples/notes_scene.cpp (builds the note's scene, a StandardScene, renders,
#                 writes a PNG; the file code, the scene's members and its renderer come from
#                 isin::io, compiled once elsewhere)
#   mesh_view     examples/mesh_view.cpp (loads a model into a StandardScene, renders it)
#   io-1, -2, -3  the three files of isin::io, compiled once per program (on as many cores as
#                 there are): the file code with stb and tinyobjloader and the Bvh builder;
#                 StandardScene<float> and its renderer; the same for double
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
# isin::io's three files, as CMake writes them (include/isin/detail/compiled.hpp)
printf '#define ISIN_IMPLEMENTATION\n#define ISIN_COMPILED_PART 1\n#include <isin/isin.hpp>\n' > "$work/io1.cpp"
printf '#define ISIN_COMPILED_PART 2\n#include <isin/isin.hpp>\n' > "$work/io2.cpp"
printf '#define ISIN_COMPILED_PART 3\n#include <isin/isin.hpp>\n' > "$work/io3.cpp"
declare -A sources=([isin.hpp]="$work/isin_only.cpp" [notes_scene]=examples/notes_scene.cpp
                    [mesh_view]=examples/mesh_view.cpp [io-1]="$work/io1.cpp" [io-2]="$work/io2.cpp"
                    [io-3]="$work/io3.cpp")
median() { sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
printf '%-12s %-8s %-4s %9s %9s %10s\n' file compiler opt "median s" "peak MB" "lines"
for name in isin.hpp notes_scene mesh_view io-1 io-2 io-3; do
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
