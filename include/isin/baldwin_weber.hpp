#pragma once
/// isin — ray–triangle intersection by a precomputed coordinate transform (Baldwin & Weber,
/// "Fast Ray-Triangle Intersections by Coordinate Transformation", JCGT 5(3), 2016), beyond the
/// note: 12 numbers per triangle map world space to the triangle's (u, v, w) frame, in which the
/// plane is w = 0 and the triangle is u ≥ 0, v ≥ 0, u + v ≤ 1.
#include <limits>

#include "hit.hpp"
#include "ray.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// The precomputed transform: rows for u, v, w, each a 3-vector and an offset.
template <class T>
struct BaldwinWeberTriangle {
    static_assert(std::is_floating_point_v<T>, "isin::BaldwinWeberTriangle needs a floating-point type");
    Vertex<T> row_u, row_v, row_w;
    T off_u, off_v, off_w;
};

/// Precomputes the transform of a triangle. With the axis k of the normal's largest component,
/// P − V0 = u·E1 + v·E2 + w·ê_k, so u = ((E2 × ê_k)·(P − V0))/N_k, v = ((ê_k × E1)·(P − V0))/N_k,
/// w = (N·(P − V0))/N_k. A zero-area triangle gets an all-zero transform, which every ray misses.
template <class T>
[[nodiscard]] inline BaldwinWeberTriangle<T> baldwin_weber_transform(const Triangle<T>& tri) noexcept {
    const Vertex<T> e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0, N = cross(e1, e2);
    BaldwinWeberTriangle<T> bw{};
    if (detail::is_degenerate(e1, e2, N)) return bw;
    const T nx = std::fabs(N.x), ny = std::fabs(N.y), nz = std::fabs(N.z);
    const int k = nx > ny ? (nx > nz ? 0 : 2) : (ny > nz ? 1 : 2);
    const Vertex<T> axis{T(k == 0), T(k == 1), T(k == 2)};
    const T inv_Nk = T(1) / component(N, k);
    bw.row_u = cross(e2, axis) * inv_Nk;
    bw.row_v = cross(axis, e1) * inv_Nk;
    bw.row_w = N * inv_Nk;
    bw.off_u = -dot(bw.row_u, tri.v0);
    bw.off_v = -dot(bw.row_v, tri.v0);
    bw.off_w = -dot(bw.row_w, tri.v0);
    return bw;
}

/// Baldwin–Weber test: t where w(Ro + t·Rd) = 0, then u and v of that point. Two-sided.
template <class T>
[[nodiscard]] inline Hit<T> intersect_baldwin_weber(const Ray<T>& ray, const BaldwinWeberTriangle<T>& bw) noexcept {
    const T w_origin = dot(bw.row_w, ray.origin) + bw.off_w; // BW: w of Ro
    const T w_direction = dot(bw.row_w, ray.direction);      // BW: dw/dt
    const T t = -w_origin / w_direction;                     // BW: w(t) = 0
    if (!(t > T(0)) || !(t < std::numeric_limits<T>::infinity())) return Hit<T>::miss();
    const Vertex<T> P = ray.at(t);
    const T u = dot(bw.row_u, P) + bw.off_u;
    const T v = dot(bw.row_v, P) + bw.off_v;
    if (!(u >= T(0) && v >= T(0) && u + v <= T(1))) return Hit<T>::miss();
    return Hit<T>::at(t, u, v);
}

/// Convenience: precompute and test in one call (pays the precomputation on every call).
template <class T>
[[nodiscard]] inline Hit<T> intersect_baldwin_weber(const Ray<T>& ray, const Triangle<T>& tri) noexcept {
    return intersect_baldwin_weber(ray, baldwin_weber_transform(tri));
}

} // namespace isin
