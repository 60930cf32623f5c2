#!/usr/bin/env bash
# The renderer's accuracy-against-speed chart for soft shadows (docs/area_lights.md): for the
# note's scene with 20 × 20 RectLights and for a mesh scene (a trefoil knot on a floor), RMS error
# against render time for light_samples 1 … 1,024, uniform and adaptive, pixel samples 1×1 … 4×4,
# against a reference of 4,096 light samples and 8×8 pixel samples at 80 × 45 (rendered once on
# both cores and kept in build/chart/reference_*.ppm; delete them after changing the renderer).
# Writes docs/area_lights.csv and docs/area_lights_chart.png (python3-matplotlib), and prints
# adaptive against uniform at equal error (scripts/area_light_equal_error.py). Times are CPU times.
# Needs: cmake --preset bench && cmake --build build/bench --target area_lights
# Usage: bash scripts/area_light_chart.sh [width=80] [height=45] [repeats=3] [max light samples=1024]
set -euo pipefail
cd "$(dirname "$0")/.."
width=${1:-80}
height=${2:-45}
repeats=${3:-3}
most=${4:-1024}
bin=build/bench/benchmarks/area_lights
[[ -x $bin ]] || { echo "build $bin first (cmake --preset bench; cmake --build build/bench --target area_lights)" >&2; exit 1; }
mkdir -p build/chart
for scene in note knot; do # the references on both cores, once
    ref=build/chart/reference_${scene}_${width}x${height}.ppm
    [[ -f $ref ]] || nice "$bin" --scene "$scene" --width "$width" --height "$height" --threads 2 \
        --reference-file "$ref" --max-light-samples 1 --repeats 1 > /dev/null
done
{
    taskset -c 1 "$bin" --scene note --width "$width" --height "$height" --repeats "$repeats" \
        --max-light-samples "$most" --reference-file "build/chart/reference_note_${width}x${height}.ppm"
    taskset -c 1 "$bin" --scene knot --width "$width" --height "$height" --repeats "$repeats" \
        --max-light-samples "$most" --reference-file "build/chart/reference_knot_${width}x${height}.ppm" | tail -n +2
} > docs/area_lights.csv
py=python3
"$py" -c "import matplotlib" 2> /dev/null || py=/usr/bin/python3 # Debian's python3-matplotlib
"$py" scripts/area_light_chart.py docs/area_lights.csv docs/area_lights_chart.png
"$py" scripts/area_light_equal_error.py docs/area_lights.csv
