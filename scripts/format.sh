#!/usr/bin/env bash
# Lays out every C++ file of isin with clang-format (.clang-format; Debian's clang-format 14):
#   scripts/format.sh           rewrites the files in place
#   scripts/format.sh --check   changes nothing, fails listing the files that are not laid out
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "format: needs clang-format (Debian: apt-get install clang-format)" >&2; exit 2; }
mapfile -t files < <(git ls-files '*.hpp' '*.cpp' '*.h' 2>/dev/null || find include tests examples benchmarks -name '*.[ch]pp')
if [ "${1:-}" = --check ]; then
  if ! out=$(clang-format --dry-run --Werror "${files[@]}" 2>&1); then
    grep 'code should be clang-formatted' <<<"$out" | cut -d: -f1 | sort -u | sed 's/^/not laid out: /' >&2
    echo "format: run bash scripts/format.sh" >&2
    exit 1
  fi
  echo "format: ${#files[@]} files laid out as .clang-format says" >&2
else
  clang-format -i "${files[@]}"
fi
