#pragma once
/// isin — the closest point of a triangle to a point (Ericson, "Real-Time Collision Detection",
/// 2005, §5.1.5), and PointHit, the answer of every closest-point query (a Bvh's, a Solid's).
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// The point of a surface closest to a query point: where it is, how far, on which triangle
/// (`primitive`, as Hit's) and where on it (barycentrics u, v: P = V0 + u(V1−V0) + v(V2−V0)).
/// Nothing found (no triangle, none within the query's max_distance, NaN input) has
/// distance = +∞ and converts to false.
template <class T>
struct PointHit {
    static_assert(std::is_floating_point_v<T>, "isin::PointHit needs a floating-point type");
    static constexpr std::uint32_t none = ~std::uint32_t(0);
    Vertex<T> point{T(0), T(0), T(0)};
    T distance = std::numeric_limits<T>::infinity();
    std::uint32_t primitive = none;
    T u = T(0), v = T(0);

    /// True when a point was found (distance finite).
    constexpr explicit operator bool() const noexcept { return distance < std::numeric_limits<T>::infinity(); }
};

namespace detail {

/// The closest point of triangle (a, b, c) to p as barycentrics (u of b, v of c) and the vector
/// from it to p (`gap`, whose length is the distance), all taken from the differences p − a,
/// p − b, p − c, b − a, c − a, c − b: exact near the triangle when coordinates are large, so the
/// distance keeps the triangle's scale, not the coordinates'.
template <class T>
struct TrianglePoint {
    T u, v;
    Vertex<T> gap;
};

/// The closest point of segment a + s·(b − a), s in [0, 1], to a point at `ap` = p − a.
template <class T>
[[nodiscard]] inline T segment_parameter(const Vertex<T>& ap, const Vertex<T>& ab) noexcept {
    const T num = dot(ap, ab), den = dot(ab, ab);
    if (!(num > T(0)) || !(den > T(0))) return T(0); // before a, a point-like segment, or NaN
    return num >= den ? T(1) : num / den;
}

/// Ericson §5.1.5 (ClosestPtPointTriangle) by Voronoi regions: vertices, then edges, then the
/// face. Under rounding (and any FMA contraction of the dot products) a point near a region's
/// border may be given the neighbouring region, whose formula then still yields a point of the
/// triangle and a distance within rounding of the true one: each parameter is clamped by the
/// region's own conditions, and the face region, when its barycentrics come out negative or its
/// denominator is not positive (degenerate and sliver triangles), is replaced by the nearest of
/// the three edges' closest points.
template <class T>
[[nodiscard]] inline TrianglePoint<T> closest_on_triangle(const Vertex<T>& p, const Vertex<T>& a, const Vertex<T>& b,
                                                          const Vertex<T>& c) noexcept {
    const Vertex<T> ab = b - a, ac = c - a, ap = p - a;
    const T d1 = dot(ab, ap), d2 = dot(ac, ap);            // Ericson: d1 = ab·ap, d2 = ac·ap
    if (d1 <= T(0) && d2 <= T(0)) return {T(0), T(0), ap}; // Ericson: vertex region A
    const Vertex<T> bp = p - b;
    const T d3 = dot(ab, bp), d4 = dot(ac, bp);             // Ericson: d3 = ab·bp, d4 = ac·bp
    if (d3 >= T(0) && d4 <= d3) return {T(1), T(0), bp};    // Ericson: vertex region B
    const T vc = difference_of_products(d1, d4, d3, d2);    // Ericson: vc = d1·d4 − d3·d2, exact sign
    if (vc <= T(0) && d1 >= T(0) && d3 <= T(0)) {           // Ericson: edge region AB
        const T s = d1 - d3 > T(0) ? d1 / (d1 - d3) : T(0); // Ericson: v = d1/(d1 − d3), in [0, 1]
        return {s, T(0), ap - s * ab};
    }
    const Vertex<T> cp = p - c;
    const T d5 = dot(ab, cp), d6 = dot(ac, cp);             // Ericson: d5 = ab·cp, d6 = ac·cp
    if (d6 >= T(0) && d5 <= d6) return {T(0), T(1), cp};    // Ericson: vertex region C
    const T vb = difference_of_products(d5, d2, d1, d6);    // Ericson: vb = d5·d2 − d1·d6
    if (vb <= T(0) && d2 >= T(0) && d6 <= T(0)) {           // Ericson: edge region AC
        const T s = d2 - d6 > T(0) ? d2 / (d2 - d6) : T(0); // Ericson: w = d2/(d2 − d6)
        return {T(0), s, ap - s * ac};
    }
    const T va = difference_of_products(d3, d6, d5, d4); // Ericson: va = d3·d6 − d5·d4
    const T e = d4 - d3, f = d5 - d6;
    if (va <= T(0) && e >= T(0) && f >= T(0)) {        // Ericson: edge region BC
        const T s = e + f > T(0) ? e / (e + f) : T(0); // Ericson: w = (d4 − d3)/((d4 − d3) + (d5 − d6))
        return {T(1) - s, s, bp - s * (c - b)};
    }
    const T denom = va + vb + vc;
    if (va >= T(0) && vb >= T(0) && vc >= T(0) && denom > T(0)) { // Ericson: face region
        const T v = vb / denom, w = vc / denom;                   // Ericson: v = vb/(va+vb+vc), w = vc/(…)
        return {v, w, ap - v * ab - w * ac};
    }
    // Rounding left no region (a degenerate or sliver triangle, or NaN): the nearest edge point.
    const Vertex<T> bc = c - b;
    const T s_ab = segment_parameter(ap, ab), s_ac = segment_parameter(ap, ac), s_bc = segment_parameter(bp, bc);
    const TrianglePoint<T> on_ab{s_ab, T(0), ap - s_ab * ab}, on_ac{T(0), s_ac, ap - s_ac * ac},
        on_bc{T(1) - s_bc, s_bc, bp - s_bc * bc};
    const T g_ab = dot(on_ab.gap, on_ab.gap), g_ac = dot(on_ac.gap, on_ac.gap), g_bc = dot(on_bc.gap, on_bc.gap);
    if (g_ab <= g_ac && g_ab <= g_bc) return on_ab;
    return g_ac <= g_bc ? on_ac : on_bc;
}

/// The point of `tri` a TrianglePoint names: V0 + u(V1−V0) + v(V2−V0), exactly a vertex at one.
template <class T>
[[nodiscard]] inline Vertex<T> triangle_point(const Triangle<T>& tri, T u, T v) noexcept {
    if (u == T(0) && v == T(0)) return tri.v0;
    if (u == T(1) && v == T(0)) return tri.v1;
    if (u == T(0) && v == T(1)) return tri.v2;
    if (u + v == T(1)) return tri.v1 + v * (tri.v2 - tri.v1); // edge V1V2: from its own end
    return tri.v0 + u * (tri.v1 - tri.v0) + v * (tri.v2 - tri.v0);
}

} // namespace detail

/// The closest point of triangle `tri` to `p` (Ericson §5.1.5), exact up to rounding for any
/// triangle, degenerate and sliver ones too; `primitive` is PointHit::none. A NaN or infinite
/// point or vertex, or a distance that overflows, gives the miss (distance +∞).
template <class T>
[[nodiscard]] inline PointHit<T> closest_point(const Vertex<T>& p, const Triangle<T>& tri) noexcept {
    PointHit<T> hit;
    if (!is_finite(tri.v0) || !is_finite(tri.v1) || !is_finite(tri.v2)) return hit;
    const detail::TrianglePoint<T> q = detail::closest_on_triangle(p, tri.v0, tri.v1, tri.v2);
    const T d2 = dot(q.gap, q.gap);
    if (!(d2 < std::numeric_limits<T>::infinity())) return hit; // NaN or overflow: nothing found
    hit.point = detail::triangle_point(tri, q.u, q.v);
    hit.distance = std::sqrt(d2);
    hit.u = q.u, hit.v = q.v;
    return hit;
}

} // namespace isin
