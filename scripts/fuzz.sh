#!/usr/bin/env bash
# Fuzzes isin's file readers with libFuzzer (clang, -fsanitize=fuzzer,address,undefined):
# read_image_from_memory (PNG, JPEG, PPM), the PLY and the OBJ reader (load_mesh_from_memory),
# load_model on an OBJ, its .mtl and a texture written to a temporary directory, and
# Bvh<T>::load_from_memory (saved Bvhs).
#   bash scripts/fuzz.sh [SECONDS]      (default 45 per target)
# Builds the targets in build/fuzz, writes seed corpora there (tests/fuzz/make_seeds, plus
# progressive and restart-marker JPEGs made by jpegtran, plus the reproducers of
# tests/data/repro), runs each target for SECONDS, then replays every corpus file and every
# reproducer once. Prints libFuzzer's figures; exits non-zero on any finding (crash, sanitizer
# report, leak, hang over 10 s, allocation over 2 GB), whose input libFuzzer leaves in build/fuzz.
set -euo pipefail
seconds=${1:-45}
cd "$(dirname "$0")/.."
bash scripts/deps.sh libjpeg-turbo-progs
dir=build/fuzz
cmake -S . -B "$dir" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo -DISIN_BUILD_FUZZERS=ON \
  -DISIN_BUILD_TESTS=OFF -DISIN_BUILD_EXAMPLES=OFF -DISIN_WERROR=ON >/dev/null
cmake --build "$dir" -j"$(nproc)"
corpus=$dir/corpus
rm -rf "$corpus"
"$dir/tests/fuzz/make_seeds" "$corpus"
for f in "$corpus"/image/jpeg*.jpg; do
  jpegtran -progressive "$f" > "${f%.jpg}-progressive.jpg"
  jpegtran -restart 1 -optimize "$f" > "${f%.jpg}-restart.jpg"
done
cp tests/data/repro/*.png tests/data/repro/*.jpg "$corpus/image/"
cp tests/data/repro/*.ply "$corpus/ply/"
cp tests/data/repro/*.obj "$corpus/obj/"
cp tests/data/repro/*.bvh "$corpus/bvh/"
cd "$dir"
run() { # run LOG ARGS…: libFuzzer's summary lines, or its whole report and failure
  local log=$1
  shift
  if ! "$@" > "$log" 2>&1; then
    tail -n 60 "$log"
    echo "== isin fuzz: FINDING (input left in $PWD)" >&2
    exit 1
  fi
  grep -E "^#[0-9]+.*(INITED|DONE)|stat::number_of_executed_units|stat::peak_rss_mb" "$log" || true
}
for target in image ply obj bvh; do
  dict=()
  [ -f "../../tests/fuzz/$target.dict" ] && dict=(-dict="../../tests/fuzz/$target.dict")
  echo "== isin fuzz: $target, ${seconds} s" >&2
  # A fixed seed and run count: CI repeats the same inputs (a slower machine stops earlier, on a
  # prefix of them); ISIN_FUZZ_SEED=0 and a larger ISIN_FUZZ_RUNS explore further by hand.
  run "fuzz_$target.log" "./tests/fuzz/fuzz_$target" -seed="${ISIN_FUZZ_SEED:-1}" -runs="${ISIN_FUZZ_RUNS:-200000}" \
    -max_total_time="$seconds" -timeout=10 -max_len=16384 -print_final_stats=1 "${dict[@]}" "corpus/$target"
  echo "== isin fuzz: $target, replaying the $(ls "corpus/$target" | wc -l) corpus files" >&2
  run "replay_$target.log" "./tests/fuzz/fuzz_$target" -runs=0 -timeout=10 "corpus/$target"
done
echo "== isin fuzz: no findings" >&2
