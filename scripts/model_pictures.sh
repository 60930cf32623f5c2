#!/usr/bin/env bash
# The pictures of models in docs/meshes.md and the README, rendered by mesh_view
#   docs/spider.png        assimp-testmodels' spider.obj (5 materials, 5 JPEG textures), sRGB
#   docs/dragon.png        the Stanford dragon (871,414 triangles), normals computed, smooth shading
#   docs/dragon_flat.png   a close-up of the dragon's brow, one normal per triangle (--flat)
#   docs/dragon_smooth.png the same close-up, smooth shading (--smooth 60)
# Installs what is missing (assimp-testmodels through scripts/deps.sh; the dragon once through
# scripts/dragon.sh, into build/load_models/); nothing is downloaded at build time.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh assimp-testmodels
bash scripts/dragon.sh
cmake --preset release >/dev/null
cmake --build --preset release -j"$(nproc)" --target mesh_view
view=build/release/examples/mesh_view
dragon=build/load_models/dragon_le.ply
mkdir -p docs
"$view" /usr/share/assimp/models/OBJ/spider.obj --srgb --smooth 60 --size 800x450 --samples 2 \
  --eye -180,150,-280 --target -20,-22,-5 --fov 36 --output docs/spider.png
"$view" "$dragon" --smooth 60 --size 800x600 --samples 2 \
  --eye -0.072,0.25,-0.34 --target -0.018,0.112,-0.005 --fov 38 --output docs/dragon.png
close_up=(--size 400x300 --samples 2 --eye "-0.13,0.21,-0.13" --target "-0.08,0.17,-0.01" --fov 9)
"$view" "$dragon" --flat "${close_up[@]}" --output docs/dragon_flat.png
"$view" "$dragon" --smooth 60 "${close_up[@]}" --output docs/dragon_smooth.png
