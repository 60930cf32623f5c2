#pragma once
// The note's scene: the three triangles U, Y, Z of example 5a (note §5), a mirror sphere (§8), a
// glass sphere that refracts (§8), a checkerboard floor made of two right triangles (§10) and two
// lights that cast shadows (§9). Shared by examples/notes_scene, the render test and the benchmark.
#include <isin/isin.hpp>

#include "soft_lights.hpp"

namespace note_scene {

template <class T>
using Scene = isin::StandardScene<T>; // compiled once in isin::io (ISIN_COMPILED)

/// Builds the scene; `textured_floor = false` gives the floor a plain colour.
template <class T>
Scene<T> make(bool textured_floor = true) {
    Scene<T> scene;
    scene.background = {T(0.05), T(0.07), T(0.12)};
    scene.texture_filter = isin::Filter::nearest; // crisp checkerboard squares
    scene.ambient_light = {T(1), T(1), T(1)};
    auto matte = [&](int r, int g, int b) {
        isin::Material<T> m;
        m.color = isin::from_rgb8<T>(r, g, b);
        m.ka = T(0.15), m.kd = T(0.65), m.ks = T(0.2), m.shininess = T(40); // §7: ka + kd + ks = 1
        return scene.add_material(m);
    };
    // §5 example 5a: red U, green Y, blue Z.
    scene.add(isin::Triangle<T>{{0, 30, 40}, {40, -30, 120}, {-40, -30, 120}}, matte(255, 0, 0));
    scene.add(isin::Triangle<T>{{-50, 30, 124}, {50, 30, 124}, {0, -30, 44}}, matte(0, 255, 0));
    scene.add(isin::Triangle<T>{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}}, matte(0, 0, 255));

    isin::Material<T> mirror;
    mirror.color = isin::from_rgb8<T>(200, 200, 210);
    mirror.ka = T(0.1), mirror.kd = T(0.5), mirror.ks = T(0.4), mirror.shininess = T(80);
    mirror.reflectivity = T(0.6); // §8
    scene.add(isin::Sphere<T>{{-78, -10, 170}, 35}, scene.add_material(mirror));

    isin::Material<T> glass;
    glass.color = isin::from_rgb8<T>(230, 240, 255);
    glass.ka = T(0.05), glass.kd = T(0.25), glass.ks = T(0.7), glass.shininess = T(120);
    glass.reflectivity = T(0.1), glass.transparency = T(0.8), glass.ior = T(1.5); // §8: Snell
    scene.add(isin::Sphere<T>{{60, -29, 110}, 16}, scene.add_material(glass));

    isin::Material<T> floor;
    floor.color = isin::from_rgb8<T>(220, 220, 220);
    floor.ka = T(0.2), floor.kd = T(0.7), floor.ks = T(0.1), floor.shininess = T(10);
    if (textured_floor)
        floor.texture = scene.add_texture(
            isin::Checkerboard<T>{isin::from_rgb8<T>(235, 235, 225), isin::from_rgb8<T>(60, 70, 90), 40, 16});
    // §10: two right triangles, V0 at the right angle; the front face looks up (+Y).
    scene.add_textured_rectangle({-200, -45, 20}, {-200, -45, 1000}, {200, -45, 20}, scene.add_material(floor));

    // §9: both cast shadows: one high above, one low in front (it lights red U, which faces down).
    scene.add_light({{-60, 150, 40}, {T(0.75), T(0.75), T(0.72)}});
    scene.add_light({{80, -10, -30}, {T(0.55), T(0.52), T(0.48)}});
    return scene;
}

/// The scene with each point light replaced by a horizontal size × size RectLight of its colour
/// centred on it (soft shadows); size ≤ 0 leaves the point lights.
template <class T>
Scene<T> with_area_lights(Scene<T> scene, T size) {
    example::to_area_lights(scene, size);
    return scene;
}

} // namespace note_scene
