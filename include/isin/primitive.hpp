#pragma once
/// isin — what a primitive kind is to a scene (note §5): an Object (a primitive and its
/// material), the customisation points a kind defines (intersect_primitive, bounds,
/// surface_normal, triangle_of; hit_point, texture_coordinates and may_hit optional) with the
/// built-in kinds' (Sphere, Triangle, TexturedTriangle), TriangleMethod, Acceleration, and
/// SurfacePoint, what a hit looks like to the shader.
#include <array>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>

#include "bvh/triangle_bvh.hpp"
#include "color.hpp"
#include "error_bound.hpp"
#include "hit.hpp"
#include "ray.hpp"
#include "ray_lanes.hpp"
#include "sphere.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// A triangle carrying the note's texture mapping (§10): on the first triangle of a rectangle the
/// texel is (u·w, v·h), on the second ((1−u)·w, (1−v)·h); V0 is the right angle of each.
template <class T>
struct TexturedTriangle {
    Triangle<T> triangle;
    bool second = false;
};

/// Which ray–triangle test a scene uses for its triangles.
enum class TriangleMethod { moller_trumbore, area };

/// An object of a scene: a primitive and the index of its material.
template <class Shape>
struct Object {
    using shape_type = Shape;
    Shape shape;
    std::uint32_t material;
};

// ---- per-kind customisation points ---------------------------------------------------------------
// A kind of primitive needs `intersect_primitive(ray, shape, TriangleMethod)` (a Hit), `bounds(shape)`
// (a Box, for its Bvh; a kind without is tested one by one), `surface_normal(shape, point, hit)` (unit) and `triangle_of(shape)` (its
// plain triangle for culling, or nullptr); texture_coordinates and hit_point are optional. A user's kind defines
// them in its own namespace (found by argument-dependent lookup), as tests/test_render.cpp does.

template <class T>
[[nodiscard]] inline Hit<T> intersect_primitive(const Ray<T>& ray, const Sphere<T>& sp, TriangleMethod) noexcept {
    return intersect(ray, sp);
}
template <class T>
[[nodiscard]] inline Hit<T> intersect_primitive(const Ray<T>& ray, const Triangle<T>& tri,
                                                TriangleMethod method) noexcept {
    return method == TriangleMethod::area ? intersect_area(ray, tri) : intersect_moller_trumbore(ray, tri);
}
template <class T>
[[nodiscard]] inline Hit<T> intersect_primitive(const Ray<T>& ray, const TexturedTriangle<T>& tri,
                                                TriangleMethod method) noexcept {
    return intersect_primitive(ray, tri.triangle, method);
}

/// The box of a sphere: empty for an empty sphere (radius zero, negative or not finite).
template <class T>
[[nodiscard]] inline Box<T> bounds(const Sphere<T>& sp) noexcept {
    Box<T> b;
    if (!(sp.radius > T(0)) || !(sp.radius < std::numeric_limits<T>::infinity())) return b;
    const Vertex<T> r{sp.radius, sp.radius, sp.radius};
    b.grow(sp.center - r), b.grow(sp.center + r);
    return b;
}
/// The box of a triangle (empty for one no ray can hit).
template <class T>
[[nodiscard]] inline Box<T> bounds(const Triangle<T>& tri) noexcept {
    return Bvh<T>::bounds(tri);
}
template <class T>
[[nodiscard]] inline Box<T> bounds(const TexturedTriangle<T>& tri) noexcept {
    return bounds(tri.triangle);
}

/// The hit point of a primitive with its error bound (optional customisation point): spheres and
/// triangles rebuild it on the surface (sphere.hpp, triangle.hpp); a kind without its own takes
/// Ro + t·Rd with a generous bound (error_bound.hpp, point_on_ray).
template <class T, class Shape>
[[nodiscard]] inline BoundedPoint<T> hit_point(const Ray<T>& ray, const Shape&, const Hit<T>& hit) noexcept {
    return point_on_ray(ray.origin, ray.direction, hit.t);
}
template <class T>
[[nodiscard]] inline BoundedPoint<T> hit_point(const Ray<T>& ray, const TexturedTriangle<T>& tri,
                                               const Hit<T>& hit) noexcept {
    return hit_point(ray, tri.triangle, hit);
}

template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const Sphere<T>& sp, const Vertex<T>& p, const Hit<T>&) noexcept {
    return normal_at(sp, p);
}
/// The unit normal of a hit given its ray (optional customisation point): by default
/// surface_normal(shape, point, hit); spheres take it from the ray (normal_at(ray, sphere, hit)),
/// right where the hit point's own rounding is not.
template <class T, class Shape>
[[nodiscard]] inline Vertex<T> surface_normal(const Ray<T>&, const Shape& shape, const Vertex<T>& p,
                                              const Hit<T>& hit) noexcept {
    return surface_normal(shape, p, hit);
}
template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const Ray<T>& ray, const Sphere<T>& sp, const Vertex<T>&,
                                              const Hit<T>& hit) noexcept {
    return normal_at(ray, sp, hit);
}
template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const Triangle<T>& tri, const Vertex<T>&, const Hit<T>&) noexcept {
    return normalize(normal(tri));
}
template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const TexturedTriangle<T>& tri, const Vertex<T>& p,
                                              const Hit<T>& h) noexcept {
    return surface_normal(tri.triangle, p, h);
}

/// The plain triangle of a triangle-like primitive (for culling); spheres have none.
template <class T>
[[nodiscard]] constexpr const Triangle<T>* triangle_of(const Triangle<T>& t) noexcept {
    return &t;
}
template <class T>
[[nodiscard]] constexpr const Triangle<T>* triangle_of(const TexturedTriangle<T>& t) noexcept {
    return &t.triangle;
}
template <class T>
[[nodiscard]] constexpr const Triangle<T>* triangle_of(const Sphere<T>&) noexcept {
    return nullptr;
}

/// Which rays of a block may hit the primitive (optional customisation point, ray_lanes.hpp): a
/// kind that has it (and no hit_lanes) is tested rays × primitives in lanes by the stream calls of
/// a scene too small for its Bvh, each kept ray then by intersect_primitive. Textured triangles
/// as their triangle.
template <class T>
[[nodiscard]] inline std::uint64_t may_hit(const RayLanes<T>& lanes, const TexturedTriangle<T>& tri) noexcept {
    return may_hit(lanes, tri.triangle);
}

namespace detail {
// The shape the exact test in lanes (hit_lanes, ray_lanes.hpp) takes for a primitive: textured
// triangles as their triangle.
template <class T>
const Triangle<T>& lane_shape(const TexturedTriangle<T>& tri) noexcept {
    return tri.triangle;
}
template <class Shape>
const Shape& lane_shape(const Shape& shape) noexcept {
    return shape;
}

template <class T, class Shape, class = void>
struct has_lane_filter : std::false_type {};
template <class T, class Shape>
struct has_lane_filter<T, Shape,
                       std::void_t<decltype(may_hit(std::declval<const RayLanes<T>&>(), std::declval<const Shape&>()))>>
    : std::true_type {};
// Whether kind Shape has a box (bounds), which its Bvh needs: a kind without is tested one by one.
template <class T, class Shape, class = void>
struct has_bounds : std::false_type {};
template <class T, class Shape>
struct has_bounds<T, Shape, std::void_t<decltype(bounds(std::declval<const Shape&>()))>> : std::true_type {};
// Whether the built-in kinds' exact test in lanes (ray_lanes.hpp) tests kind Shape.
template <class T, class Shape, class = void>
struct has_lane_hits : std::false_type {};
template <class T, class Shape>
struct has_lane_hits<T, Shape,
                     std::void_t<decltype(hit_register(std::declval<const RayRegister<T, T>&>(),
                                                       lane_shape(std::declval<const Shape&>()), std::declval<T*>(),
                                                       std::declval<T*>(), std::declval<T*>()))>> : std::true_type {};
} // namespace detail

/// Whether a primitive kind is a triangle: a Bvh of it tests blocks of 8 with the watertight
/// test, and a TriangleBatch can hold it.
template <class Shape>
struct is_triangle_kind : std::false_type {};
template <class T>
struct is_triangle_kind<Triangle<T>> : std::true_type {};
template <class T>
struct is_triangle_kind<TexturedTriangle<T>> : std::true_type {};

/// How a scene finds hits among the objects of one kind ("model no more than a scene needs").
enum class Acceleration {
    automatic, ///< by size, once built (commit() or the first trace): a Bvh from bvh_min (triangles) or shape_bvh_min, TriangleBatch from batch_min
    none,      ///< one object after another
    batch,     ///< triangles: TriangleBatch, Möller–Trumbore over structure-of-arrays, vectorised
    bvh        ///< a Bvh of the kind (triangles: watertight test on blocks of 8)
};

/// Normalised texture coordinates of a hit, or none: only textured triangles carry them (§10).
template <class T, class Shape>
[[nodiscard]] inline bool texture_coordinates(const Shape&, const Hit<T>&, std::array<T, 2>&) noexcept {
    return false;
}
template <class T>
[[nodiscard]] inline bool texture_coordinates(const TexturedTriangle<T>& tri, const Hit<T>& h,
                                              std::array<T, 2>& st) noexcept {
    st = note_texel(h.u, h.v, T(1), T(1), tri.second); // §10 with w = h = 1: normalised
    return true;
}

/// What a hit looks like to the shader: point, unit geometric normal, the shading normal and
/// point of smooth (Phong) shading, material, texture coordinates and vertex colour.
template <class T>
struct SurfacePoint {
    /// The hit point, rebuilt on the surface where the primitive can (a triangle's barycentrics,
    /// a sphere's reprojection: `hit_point`), and the bound on its error: the exact surface point
    /// lies within point ± error. Secondary rays start at offset_ray_origin({point, error}, …).
    Vertex<T> point;
    Vertex<T> error;
    Vertex<T> normal; ///< the surface's own (geometric) unit normal, out of its front face
    /// Unit normal for lighting: interpolated from a mesh's vertex normals by the hit's
    /// barycentrics (Phong 1975), out of the same side as `normal`; else `normal`.
    Vertex<T> shading_normal;
    /// Where shadow rays start: the point moved off a smooth mesh's flat triangle towards the
    /// curved surface its vertex normals describe, on the side the ray came from (Hanika, "Hacking
    /// the shadow terminator", Ray Tracing Gems II ch. 4), which removes the dark facets where
    /// light meets shadow; else `point`.
    Vertex<T> shading_point;
    std::uint32_t material;
    bool has_texture_coordinates;
    std::array<T, 2> st;
    Color<T> tint; ///< vertex colour interpolated by the barycentrics (white without colours)
};

} // namespace isin
