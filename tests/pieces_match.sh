#!/usr/bin/env bash
# Pictures rendered in pieces (--tile I/N bands merged by merge_tiles, --frames A..B, and
# scripts/render_parallel.sh) must equal, byte for byte, the same pictures rendered whole.
#   tests/pieces_match.sh EXAMPLES_DIR WORK_DIR CASE     (CASE: notes_scene mesh_view walk parallel)
# Exit status 77 (ctest: skipped) when GNU parallel is missing for the parallel case.
set -euo pipefail
bin=$1 work=$2/pieces_$3
rm -rf "$work" && mkdir -p "$work" && cd "$work"
same() { cmp "$1" "$2" || { echo "FAIL: $1 and $2 differ" >&2; exit 1; }; echo "same: $1 $2"; }
differ() { if cmp -s "$1" "$2"; then echo "FAIL: $1 and $2 should differ" >&2; exit 1; fi; }
case $3 in
notes_scene) # bands of unequal sizes (90 rows in 7), threads 2 whole and 1 per band
  "$bin/notes_scene" --width 160 --height 90 --threads 2 --output whole.ppm
  for i in 0 1 2 3 4 5 6; do "$bin/notes_scene" --width 160 --height 90 --threads 1 --tile $i/7 --output band$i.ppm; done
  "$bin/merge_tiles" merged.ppm band{0..6}.ppm --height 90
  same whole.ppm merged.ppm
  # frame 0 of the camera path is the still picture; frame 1 is not; a band of a frame is its rows
  "$bin/notes_scene" --width 160 --height 90 --frames 0..1 --output frame%d.ppm
  same whole.ppm frame0.ppm
  differ frame0.ppm frame1.ppm
  "$bin/notes_scene" --width 160 --height 90 --frames 1..1 --tile 0/2 --output top.ppm
  "$bin/notes_scene" --width 160 --height 90 --frames 1..1 --tile 1/2 --output bottom.ppm
  "$bin/merge_tiles" frame1_merged.ppm top_0001.ppm bottom_0001.ppm
  same frame1.ppm frame1_merged.ppm
  # a missing band is caught
  if "$bin/merge_tiles" short.ppm band0.ppm band1.ppm --height 90 2>/dev/null; then echo "FAIL: a missing band went unnoticed" >&2; exit 1; fi
  # tiles out of order (bands of 12 and 13 rows swapped), of another width or from another split are refused
  refused() { if "$bin/merge_tiles" "$@" 2>refused.txt; then echo "FAIL: merge_tiles $* was accepted" >&2; exit 1; fi
              grep -q "$expect" refused.txt || { echo "FAIL: merge_tiles $* did not say '$expect'" >&2; cat refused.txt >&2; exit 1; }; }
  expect="out of order" refused swapped.ppm band1.ppm band0.ppm band{2..6}.ppm
  expect="out of order" refused swapped.ppm band{1..6}.ppm band0.ppm
  "$bin/notes_scene" --width 120 --height 90 --threads 1 --tile 6/7 --output narrow6.ppm
  expect="wide" refused mixed.ppm band{0..5}.ppm narrow6.ppm
  "$bin/notes_scene" --width 160 --height 90 --threads 1 --tile 0/2 --output half0.ppm
  expect="out of order" refused mixed.ppm half0.ppm band{4..6}.ppm
  [ ! -e swapped.ppm ] && [ ! -e mixed.ppm ] || { echo "FAIL: a refused merge wrote its output" >&2; exit 1; } ;;
mesh_view) # PNG bands of a BVH-traced mesh with projected culling; orbit frames
  printf 'v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n' > cube.obj
  "$bin/mesh_view" cube.obj --width 96 --height 54 --cull projected --output whole.png
  for i in 0 1 2; do "$bin/mesh_view" cube.obj --width 96 --height 54 --cull projected --tile $i/3 --output band$i.png; done
  "$bin/merge_tiles" merged.png band0.png band1.png band2.png --height 54
  same whole.png merged.png
  "$bin/mesh_view" cube.obj --width 96 --height 54 --cull projected --frames 0..30 --output orbit.png
  same whole.png orbit_0000.png
  differ orbit_0000.png orbit_0030.png ;;
walk) # frames of a scripted walk, whole and in bands
  "$bin/walk" --script WWDDJJ --width 160 --height 90 --frames 0..6 --output walk%d.ppm
  "$bin/walk" --script WWDDJJ --width 160 --height 90 --output last.ppm
  same last.ppm walk6.ppm
  "$bin/walk" --script WWDDJJ --width 160 --height 90 --frames 3..3 --tile 0/2 --output top%d.ppm
  "$bin/walk" --script WWDDJJ --width 160 --height 90 --frames 3..3 --tile 1/2 --output bottom%d.ppm
  "$bin/merge_tiles" merged.ppm top3.ppm bottom3.ppm
  same walk3.ppm merged.ppm ;;
parallel) # the script, as a scheduler would run it (here: this machine)
  command -v parallel >/dev/null || { echo "GNU parallel is not installed: skipped"; exit 77; }
  script=$(dirname "$0")/../scripts/render_parallel.sh
  "$bin/notes_scene" --width 160 --height 90 --frames 0..2 --output whole%d.png
  bash "$script" --tiles 4 --frames 0..2 --output pieces%d.png -- "$bin/notes_scene" --width 160 --height 90
  for f in 0 1 2; do same whole$f.png pieces$f.png; done
  bash "$script" --tiles 3 --sshlogin 2/: --shared-fs --output still.png -- "$bin/notes_scene" --width 160 --height 90
  same whole0.png still.png ;;
*) echo "unknown case '$3'" >&2; exit 2 ;;
esac
