#pragma once
/// isin — backface culling (note §11) by dot product and by projected cross product.
#include <array>

#include "camera.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// Method 1 (§11): a triangle is a backface for `eye` when (eye − V0)·N < 0, N = (V1−V0)×(V2−V0).
template <class T>
[[nodiscard]] constexpr bool is_backface(const Triangle<T>& tri, const Vertex<T>& eye) noexcept {
    return dot(eye - tri.v0, normal(tri)) < T(0); // §11: (eye − V)·N < 0 → backface
}

/// Perspective projection onto the image plane at distance d by similar triangles (§11):
/// x' = d·x/z, y' = d·y/z, for a point in camera space (eye at 0 looking along +Z).
template <class T>
[[nodiscard]] constexpr std::array<T, 2> project(const Vertex<T>& p, T d) noexcept {
    return {d * p.x / p.z, d * p.y / p.z}; // §11: x' = d·x/z, y' = d·y/z
}

/// Method 2 (§11): project the camera-space vertices onto the plane at distance d; the Z
/// component of the cross product of the projected edges is > 0 for a backface (the projected
/// vertices run counter-clockwise). Needs every vertex in front of the eye (z > 0); for a
/// triangle that reaches behind the eye the projection is meaningless and method 1 decides.
template <class T>
[[nodiscard]] constexpr bool is_backface_projected(const Triangle<T>& tri, T d = T(10)) noexcept {
    if (!(tri.v0.z > T(0) && tri.v1.z > T(0) && tri.v2.z > T(0))) return is_backface(tri, Vertex<T>{T(0), T(0), T(0)});
    const auto p0 = project(tri.v0, d), p1 = project(tri.v1, d), p2 = project(tri.v2, d);
    const T ax = p1[0] - p0[0], ay = p1[1] - p0[1], bx = p2[0] - p0[0], by = p2[1] - p0[1];
    return ax * by - ay * bx > T(0); // §11: Z of the projected cross product > 0 → backface
}

/// A world-space point in the camera's frame (eye at 0, +X right, +Y up, +Z forward).
template <class T>
[[nodiscard]] inline Vertex<T> to_camera_space(const Camera<T>& cam, const Vertex<T>& p) noexcept {
    const Vertex<T> q = p - cam.position();
    return {dot(q, cam.right()), dot(q, cam.up()), dot(q, cam.forward())};
}

/// A world-space triangle in the camera's frame.
template <class T>
[[nodiscard]] inline Triangle<T> to_camera_space(const Camera<T>& cam, const Triangle<T>& tri) noexcept {
    return {to_camera_space(cam, tri.v0), to_camera_space(cam, tri.v1), to_camera_space(cam, tri.v2)};
}

} // namespace isin
