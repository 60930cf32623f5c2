#pragma once
// Soft shadows for the examples: each point light of a scene replaced by a horizontal square
// RectLight of its colour centred on it.
#include <isin/shading.hpp>

namespace example {

/// Replaces every point light of `scene` by a horizontal size × size RectLight of its colour
/// centred on it; size ≤ 0 (or NaN) leaves the point lights.
template <class SceneT, class T>
void to_area_lights(SceneT& scene, T size) {
    if (!(size > T(0))) return;
    for (const auto& light : scene.lights)
        scene.add_light(isin::RectLight<T>{light.position - isin::Vertex<T>{size / T(2), T(0), size / T(2)},
                                           {size, T(0), T(0)},
                                           {T(0), T(0), size},
                                           light.color});
    scene.lights.clear();
}

} // namespace example
