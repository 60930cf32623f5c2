#pragma once
/// isin — a header-only C++17 ray tracer built from the lecture note "Işın İzleme".
///
/// Usage:
///     #include <isin/isin.hpp>
///     isin::Camera<float> cam{800, 450};                         // note §3: eye at 0, 16×9 at z = 10
///     isin::Triangle<float> blue{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}};
///     isin::Sphere<float> ball{{0, 0, 60}, 5};
///     isin::Ray<float> ray = cam.primary_ray(399.5f, 224.5f);    // through GD = (0, 0, 10)
///     if (auto h = isin::intersect_moller_trumbore(ray, blue))   // §10: t and barycentrics u, v
///         std::printf("t = %g, u = %g, v = %g\n", h.t, h.u, h.v);
///     if (auto h = isin::intersect(ray, ball)) std::printf("sphere at t = %g\n", h.t); // §6
///
/// Rendering a scene (see examples/note_scene.hpp for a complete one):
///     isin::Scene<float, isin::Sphere, isin::Triangle> scene;    // only the kinds it uses
///     auto red = scene.add_material({isin::from_rgb8<float>(255, 0, 0)});
///     scene.add(ball, red);
///     scene.add_light({{0, 40, 0}});
///     isin::write_png(isin::render(scene, cam), "out.png");     // §7 Phong, §9 shadows, §8
///
/// Files (image_io.hpp, mesh.hpp) are compiled once: in exactly one .cpp of the program write
///     #define ISIN_IMPLEMENTATION
///     #include <isin/isin.hpp>
/// (stb and tinyobjloader are compiled there), or link CMake's isin::io.
///
/// Headers, one concept each: vec (§2), ray (§3), hit, camera (§3), triangle (§4, §10),
/// sphere (§6), color, shading (§7, §8), offset (§9), culling (§11), texture (§10), image,
/// mesh (OBJ/PLY files), model (meshes with materials and textures from files), scene (§5),
/// render (§3–§11), point_hit and solid (closest points, inside/outside, signed distance).
#include "baldwin_weber.hpp"
#include "batch.hpp"
#include "bvh.hpp"
#include "camera.hpp"
#include "color.hpp"
#include "culling.hpp"
#include "hit.hpp"
#include "image.hpp"
#include "image_io.hpp"
#include "indexed_mesh.hpp"
#include "mesh.hpp"
#include "model.hpp"
#include "offset.hpp"
#include "point_hit.hpp"
#include "ray.hpp"
#include "read_limits.hpp"
#include "render.hpp"
#include "scene.hpp"
#include "shading.hpp"
#include "solid.hpp"
#include "sphere.hpp"
#include "texture.hpp"
#include "transform.hpp"
#include "triangle.hpp"
#include "vec.hpp"
#include "version.hpp"

// The file code (io/: the readers, the image files, stb, tinyobjloader) and Bvh::save, load and
// load_from_memory, compiled once: in the ISIN_IMPLEMENTATION file (CMake's isin::io), or, for
// the Bvh's, where bvh/serialize.hpp is included.
#if defined(ISIN_IMPLEMENTATION)
#include "bvh/serialize.hpp"
#include "io/image_impl.hpp"
#include "io/mesh_impl.hpp"
#endif
