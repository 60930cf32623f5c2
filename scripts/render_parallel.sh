#!/usr/bin/env bash
# Renders a picture, or frames of an animation, as independent pieces run by GNU parallel (Debian
# package `parallel`) on this machine or across machines (--sshlogin), then assembles each
# picture with merge_tiles: bit for bit what one render makes. A piece is one band of rows of
# one frame: PROGRAM ARGS [--frames F..F] --tile I/N --output DIR/piece_F_I.ppm, for any PROGRAM
# that takes --tile, --frames and --output (examples notes_scene, mesh_view, walk --script).
#
#   scripts/render_parallel.sh [--tiles N] [--frames A..B] [--sshlogin LOGINS [--shared-fs]]
#                              [--jobs J] [--merge PATH] --output OUT -- PROGRAM [ARGS...]
#
#   --tiles N        bands of rows per picture (default 8)
#   --frames A..B    frames A to B of PROGRAM's camera path; OUT must then hold a %d or %0Nd
#                    that takes the frame number (e.g. frames/f_%04d.png)
#   --sshlogin L     GNU parallel's --sshlogin: e.g. ':,4/alice@node1,bob@node2' (':' is this
#                    machine); default this machine only. PROGRAM, merge_tiles and every file
#                    ARGS name must exist at the same paths on every machine (a shared file
#                    system, or GNU parallel's --basefile given through the PARALLEL environment
#                    variable); relative paths are relative to the home directory there. Pieces
#                    are written under $TMPDIR (or /tmp) there, come back by rsync (--return)
#                    and are removed there (--cleanup).
#   --shared-fs      the machines share this directory's file system: pieces are written to a
#                    temporary directory in it, and nothing is copied
#   --jobs J         pieces at once per machine (default: its cores); unless ARGS set --threads,
#                    each piece runs on one thread
#   --merge PATH     merge_tiles to use (default: next to PROGRAM, else on PATH)
#   --output OUT     the picture (or frame pattern), .png or .ppm
set -euo pipefail
usage() { sed -n '8,26p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
tiles=8 frames="" sshlogin="" shared=0 jobs="" merge="" output=""
while [ $# -gt 0 ]; do
  case "$1" in
    --tiles) tiles=${2:?--tiles needs a value}; shift 2 ;;
    --frames) frames=${2:?--frames needs a value}; shift 2 ;;
    --sshlogin|-S) sshlogin=${2:?--sshlogin needs a value}; shift 2 ;;
    --shared-fs) shared=1; shift ;;
    --jobs|-j) jobs=${2:?--jobs needs a value}; shift 2 ;;
    --merge) merge=${2:?--merge needs a value}; shift 2 ;;
    --output|-o) output=${2:?--output needs a value}; shift 2 ;;
    --help|-h) usage ;;
    --) shift; break ;;
    *) echo "render_parallel: unknown option '$1'" >&2; usage ;;
  esac
done
[ $# -ge 1 ] || { echo "render_parallel: no PROGRAM after --" >&2; usage; }
[ -n "$output" ] || { echo "render_parallel: --output is required" >&2; usage; }
[[ "$tiles" =~ ^[1-9][0-9]*$ ]] || { echo "render_parallel: --tiles takes a positive integer" >&2; exit 2; }
command -v parallel >/dev/null || { echo "render_parallel: needs GNU parallel (Debian: apt-get install parallel)" >&2; exit 2; }
program=$1; shift
[[ "$program" == */* ]] && program=$(cd "$(dirname "$program")" && pwd)/$(basename "$program")
if [ -z "$merge" ]; then
  if [[ "$program" == */* ]] && [ -x "$(dirname "$program")/merge_tiles" ]; then merge=$(dirname "$program")/merge_tiles
  else merge=$(command -v merge_tiles) || { echo "render_parallel: no merge_tiles; give --merge PATH" >&2; exit 2; }
  fi
fi
if [ -n "$frames" ]; then
  [[ "$frames" =~ ^([0-9]+)\.\.([0-9]+)$ ]] || { echo "render_parallel: --frames takes A..B" >&2; exit 2; }
  first=$((10#${BASH_REMATCH[1]})) last=$((10#${BASH_REMATCH[2]}))
  [ "$first" -le "$last" ] || { echo "render_parallel: --frames A..B needs A <= B" >&2; exit 2; }
  placeholder=${output//[^%]/}
  [[ ${#placeholder} == 1 && "$output" =~ %(0[1-9])?d ]] ||
    { echo "render_parallel: with --frames, --output needs one %d or %0Nd for the frame number" >&2; exit 2; }
fi
args=("$@")
[[ " ${args[*]} " == *" --threads "* ]] || args+=(--threads 1)

if [ "$shared" = 1 ]; then pieces=$(mktemp -d "$PWD/.isin-pieces.XXXXXX")
else pieces=$(mktemp -d "${TMPDIR:-/tmp}/isin-pieces.XXXXXX")
fi
trap 'rm -rf "$pieces"' EXIT
# One piece: {1} the frame ('-' for a still), {2} the band; it writes $pieces/tile{2}_frame{1}.ppm
# (with --frames the program puts the frame number into the %d itself).
if [ -n "$frames" ]; then frame_list=$(seq "$first" "$last"); frame_option='--frames {1}..{1}' name='tile{2}_frame%d.ppm'
else frame_list=-; frame_option='' name='tile{2}_frame{1}.ppm'
fi
q_pieces=$(printf '%q' "$pieces")
command_line="mkdir -p $q_pieces && $(printf '%q ' "$program" "${args[@]}") $frame_option --tile {2}/$tiles --output $q_pieces/$name"
options=(--halt now,fail=1 --wd .)
[ -n "$jobs" ] && options+=(-j "$jobs")
if [ -n "$sshlogin" ]; then
  options+=(--sshlogin "$sshlogin")
  [ "$shared" = 1 ] || options+=(--return "$pieces/tile{2}_frame{1}.ppm" --cleanup)
fi
start=$(date +%s%N)
parallel "${options[@]}" "$command_line" ::: $frame_list ::: $(seq 0 $((tiles - 1))) >/dev/null ||
  { echo "render_parallel: a piece failed (its message is above)" >&2; exit 1; }
for frame in $frame_list; do
  if [ "$frame" = - ]; then target=$output; else target=$(printf "$output" "$frame"); fi
  bands=()
  for ((t = 0; t < tiles; ++t)); do bands+=("$pieces/tile${t}_frame$frame.ppm"); done
  "$merge" "$target" "${bands[@]}"
  rm -f "${bands[@]}"
done
echo "render_parallel: $(echo "$frame_list" | wc -w) picture(s) of $tiles tiles in $((($(date +%s%N) - start) / 1000000)) ms" >&2
