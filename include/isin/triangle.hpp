#pragma once
/// isin — triangles: the normal of note §2 and the ray–triangle tests of §4 (area test) and §10
/// (Möller–Trumbore).
#include <algorithm>
#include <array>
#include <limits>
#include <utility>

#include "detail/attributes.hpp"
#include "simd/pack.hpp"
#include "simd/products.hpp"
#include "error_bound.hpp"
#include "hit.hpp"
#include "ray.hpp"
#include "vec.hpp"

namespace isin {

/// A triangle V0, V1, V2. Its front face is the one whose vertices run clockwise as seen by the
/// viewer (left-handed frame); `normal()` points out of it.
template <class T>
struct Triangle {
    static_assert(std::is_floating_point_v<T>, "isin::Triangle needs a floating-point type");
    Vertex<T> v0, v1, v2;
};

using Trianglef = Triangle<float>;
using Triangled = Triangle<double>;

/// Raw, unnormalised triangle normal (§2): N = (V1−V0) × (V2−V0); |N| is twice the area.
template <class T>
[[nodiscard]] constexpr Vertex<T> normal(const Triangle<T>& tri) noexcept {
    return cross(tri.v1 - tri.v0, tri.v2 - tri.v0); // §2: N = (V1−V0) × (V2−V0)
}

/// Offset D of the plane A x + B y + C z + D = 0 with normal (A,B,C) = N through V0 (§4).
template <class T>
[[nodiscard]] constexpr T plane_offset(const Vertex<T>& N, const Vertex<T>& V0) noexcept {
    return -dot(N, V0); // §4: D = −N·V0
}

/// Ray parameter where the ray meets the plane A x + B y + C z + D = 0 with (A,B,C) = N
/// (§4): t = −(N·Ro + D) / (N·Rd). NaN when the ray is parallel to the plane.
template <class T>
[[nodiscard]] constexpr T ray_plane_t(const Ray<T>& ray, const Vertex<T>& N, T D) noexcept {
    const T NdotRd = dot(N, ray.direction);
    if (NdotRd == T(0)) return std::numeric_limits<T>::quiet_NaN(); // §4: N·Rd = 0 → parallel
    return -(dot(N, ray.origin) + D) / NdotRd;                      // §4: t = −(N·Ro + D) / (N·Rd)
}

/// The four parallelogram areas of the §4 area test for a point R on the triangle's plane.
template <class T>
struct AreaTerms {
    T S, s1, s2, s3;
};

/// e1 = V1−V0, e2 = V2−V0 and N = e1 × e2 are passed in because the callers already have them.
template <class T>
[[nodiscard]] inline AreaTerms<T> area_terms(const Triangle<T>& tri, const Vertex<T>& e1, const Vertex<T>& e2,
                                             const Vertex<T>& N, const Vertex<T>& R) noexcept {
    return {length(N),                              // §4: S  = |(V1−V0)×(V2−V0)|
            length(cross(R - tri.v0, e2)),          // §4: s1 = |(R−V0)×(V2−V0)|
            length(cross(e1, R - tri.v0)),          // §4: s2 = |(V1−V0)×(R−V0)|
            length(cross(tri.v1 - R, tri.v2 - R))}; // §4: s3 = |(V1−R)×(V2−R)|
}

/// The §4 areas for a point R, from the triangle alone.
template <class T>
[[nodiscard]] inline AreaTerms<T> area_terms(const Triangle<T>& tri, const Vertex<T>& R) noexcept {
    const Vertex<T> e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
    return area_terms(tri, e1, e2, cross(e1, e2), R);
}

namespace detail {
/// True when the edges e1, e2 span no area: |e1 × e2| lies within the rounding noise of the cross
/// product (sin of the angle between the edges below ~8ε). Scale-free, overflow-free in max norm.
/// Always inlined: clang -O2 called it from Möller–Trumbore's hit path, which slowed the note's
/// scene (docs/performance.md).
template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE bool is_degenerate(const Vertex<T>& e1, const Vertex<T>& e2,
                                                    const Vertex<T>& N) noexcept {
    constexpr T eps = std::numeric_limits<T>::epsilon();
    return !(max_abs(N) > T(8) * eps * max_abs(e1) * max_abs(e2)); // NaN → degenerate
}

/// Shared body of both area tests; `tolerance(S, R, e1, e2, ray)` gives the allowed |S − (s1+s2+s3)|.
template <class T, class Tolerance>
[[nodiscard]] inline Hit<T> intersect_area_with(const Ray<T>& ray, const Triangle<T>& tri,
                                                Tolerance tolerance) noexcept {
    const Vertex<T> e1 = tri.v1 - tri.v0;
    const Vertex<T> e2 = tri.v2 - tri.v0;
    const Vertex<T> N = cross(e1, e2); // §4: (A,B,C) = N
    if (detail::is_degenerate(e1, e2, N)) return Hit<T>::miss();
    const T D = isin::plane_offset(N, tri.v0);
    const T t = isin::ray_plane_t(ray, N, D);
    if (!(t > T(0)) || !(t < std::numeric_limits<T>::infinity())) return Hit<T>::miss(); // §4: t ≤ 0 → behind
    const Vertex<T> R = ray.at(t);                                                       // §3: R = Ro + t·Rd
    const AreaTerms<T> a = isin::area_terms(tri, e1, e2, N, R);
    if (!(std::fabs(a.S - (a.s1 + a.s2 + a.s3)) <= tolerance(a.S, R, e1, e2, ray))) // §4: |S − Σs| ≤ ε
        return Hit<T>::miss();
    return Hit<T>::at(t, a.s1 / a.S, a.s2 / a.S); // u = s1/S weighs V1, v = s2/S weighs V2
}

} // namespace detail

/// Area test of note §4 with the note's absolute tolerance, exactly as written: inside when
/// |S − (s1+s2+s3)| ≤ epsilon (the note uses 0.005, in squared length units). Being absolute,
/// it accepts whole neighbourhoods of tiny triangles and rejects hits on huge or far-away ones.
template <class T>
[[nodiscard]] inline Hit<T> intersect_area(const Ray<T>& ray, const Triangle<T>& tri, T epsilon) noexcept {
    return detail::intersect_area_with(
        ray, tri,
        [epsilon](T, const Vertex<T>&, const Vertex<T>&, const Vertex<T>&, const Ray<T>&) { return epsilon; });
}

/// Area test of note §4, isin's default: the same formulas, two departures for accuracy.
/// - It works in V0's frame (ray origin Ro − V0, vertices 0, E1, E2; t, u, v are unchanged), so
///   R and R − Vi are rounded at the triangle's scale, not at its distance from the origin.
/// - The allowed |S − (s1+s2+s3)| is 8ε·(S + L·M), ε the machine epsilon of T: S covers the
///   rounding of the areas, L·M that of R (L the longest edge, M the magnitude of R and of the
///   local ray origin). So 1e-3 and 1e5 triangles, near and far from the origin, behave alike.
template <class T>
[[nodiscard]] inline Hit<T> intersect_area(const Ray<T>& ray, const Triangle<T>& tri) noexcept {
    const Ray<T> local{ray.origin - tri.v0, ray.direction};
    const Triangle<T> local_tri{{T(0), T(0), T(0)}, tri.v1 - tri.v0, tri.v2 - tri.v0};
    return detail::intersect_area_with(
        local, local_tri, [](T S, const Vertex<T>& R, const Vertex<T>& e1, const Vertex<T>& e2, const Ray<T>& r) {
            constexpr T eps = std::numeric_limits<T>::epsilon();
            const T L = max_of(max_abs(e1), max_abs(e2));
            const T M = max_of(max_abs(R), max_abs(r.origin));
            return T(8) * eps * (S + L * M);
        });
}

/// Möller–Trumbore ray–triangle test (Möller & Trumbore 1997; note §10) with barycentrics u, v:
/// P = V0 + u(V1−V0) + v(V2−V0). Two-sided unless `cull_backfaces`, which keeps only front faces
/// (clockwise seen from the ray origin, N·Rd < 0, i.e. det > 0). No absolute ε: det = 0 is the
/// parallel case, and a zero-area triangle is rejected on the hit path by a scale-free test.
template <class T>
[[nodiscard]] inline Hit<T> intersect_moller_trumbore(const Ray<T>& ray, const Triangle<T>& tri,
                                                      bool cull_backfaces = false) noexcept {
    const Vertex<T> e1 = tri.v1 - tri.v0;
    const Vertex<T> e2 = tri.v2 - tri.v0;
    const Vertex<T> p = cross(ray.direction, e2);                               // MT: P = Rd × E2
    const T det = dot(e1, p);                                                   // MT: det = E1·P = −N·Rd
    if (cull_backfaces ? !(det > T(0)) : !(det != T(0))) return Hit<T>::miss(); // §11: det ≤ 0 → backface
    // u, v, t are compared scaled by |det|; the division waits for the hit path.
    const T sign = det < T(0) ? T(-1) : T(1);
    const T abs_det = det * sign;
    const Vertex<T> s = ray.origin - tri.v0; // MT: S = Ro − V0
    const T U = dot(s, p) * sign;            // MT: u = S·P / det
    if (!(U >= T(0) && U <= abs_det)) return Hit<T>::miss();
    const Vertex<T> q = cross(s, e1);         // MT: Q = S × E1
    const T V = dot(ray.direction, q) * sign; // MT: v = Rd·Q / det
    if (!(V >= T(0) && U + V <= abs_det)) return Hit<T>::miss();
    const T tt = dot(e2, q) * sign; // MT: t = E2·Q / det
    if (!(tt > T(0))) return Hit<T>::miss();
    const T inv_det = T(1) / abs_det;
    const T t = tt * inv_det;
    if (!(t > T(0)) || !(t < std::numeric_limits<T>::infinity())) return Hit<T>::miss();
    if (detail::is_degenerate(e1, e2, cross(e1, e2))) return Hit<T>::miss(); // hit path only
    const T u = U * inv_det, v = V * inv_det;
    return Hit<T>::at(t, u, v);
}

namespace detail {

/// The watertight test's per-ray part (WBW §3): kz is the dominant axis of the direction; kx, ky
/// follow it cyclically, swapped when d[kz] < 0 so that the winding (and with it the sign of U,
/// V, W) is kept; S shears the ray onto +z.
template <class T>
struct WatertightShear {
    // Set by set(); the defaults (the +z shear) only keep every path defined for the compiler's
    // flow analysis (GCC 12 -O3 saw the Bvh's lazily sheared rays as maybe uninitialised).
    int kx = 0, ky = 1, kz = 2;
    T Sx = T(0), Sy = T(0), Sz = T(1);

    /// Axis a of the sheared frame (0, 1, 2: kx, ky, kz).
    [[nodiscard]] int axis(int a) const noexcept { return a == 0 ? kx : (a == 1 ? ky : kz); }

    /// Sets the shear for direction d; false (and no shear) for a zero direction. A direction
    /// with NaN along kz gets NaN shears, with which no triangle is hit (t is NaN).
    bool set(const Vertex<T>& d) noexcept {
        const T ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
        kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
        kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
        const T dz = component(d, kz);
        if (!(dz != T(0))) return false; // zero direction
        if (dz < T(0)) std::swap(kx, ky);
        Sx = component(d, kx) / dz, Sy = component(d, ky) / dz, Sz = T(1) / dz; // WBW: shear
        return true;
    }
};

/// The three 2D edge functions U, V, W of a sheared triangle (WBW §3), of one value or a
/// register of lanes.
template <class L>
struct WatertightEdges {
    L U, V, W;
};

// The watertight test's formulas written once for the Bvh's ISA forms (triangles_avx2.hpp,
// triangles_avx512.hpp); ShearedTriangle below is their one-value form.

/// Vertex p of a register of triangles (`p(a)`: its components along the ray's axis a = 0, 1, 2,
/// kx, ky, kz) relative to the ray's origin o, sheared onto the ray's frame (WBW §3): x, y
/// across the ray, z along it (not yet scaled by Sz).
template <class L, class Component>
ISIN_DETAIL_INLINE void watertight_shear(const Component& p, L ox, L oy, L oz, L Sx, L Sy, L& x, L& y, L& z) noexcept {
    z = lane_sub(p(2), oz);
    x = lane_fnmadd(Sx, z, lane_sub(p(0), ox)); // WBW: Ax = A[kx] − Sx·A[kz]
    y = lane_fnmadd(Sy, z, lane_sub(p(1), oy)); // WBW: Ay = A[ky] − Sy·A[kz]
}

/// The edge functions of sheared vertices A, B, C (x, y of each), each a·b − c·d by
/// `difference` with an exact sign (difference_of_products, lane_difference_of_products or the
/// exact products of the lanes); the result takes the type `difference` returns.
template <class L, class Difference>
ISIN_DETAIL_INLINE auto watertight_edges(const L& Ax, const L& Ay, const L& Bx, const L& By, const L& Cx, const L& Cy,
                                         Difference difference) noexcept {
    using E = decltype(difference(Cx, By, Cy, Bx));
    return WatertightEdges<E>{difference(Cx, By, Cy, Bx),  // WBW: U = Cx·By − Cy·Bx
                              difference(Ax, Cy, Ay, Cx),  // WBW: V = Ax·Cy − Ay·Cx
                              difference(Bx, Ay, By, Ax)}; // WBW: W = Bx·Ay − By·Ax
}

/// t·det (WBW §3): the edge functions weighting the vertices' depths Az, Bz, Cz along the ray
/// (Az = Sz·A[kz]), each product added as lane_fma adds it.
template <class L>
ISIN_DETAIL_INLINE L watertight_t_det(L U, L V, L W, L Az, L Bz, L Cz) noexcept {
    return lane_fma(W, Cz, lane_fma(V, Bz, lane_mul(U, Az))); // WBW: t·det = U·Az + V·Bz + W·Cz
}

/// Triangle A, B, C (vertices relative to the ray's origin) sheared onto the ray's frame (WBW
/// §3): the vertices across the ray, and the three 2D edge functions, each with an exact sign.
template <class T>
struct ShearedTriangle {
    T Ax, Ay, Bx, By, Cx, Cy;
    T U, V, W;

    ShearedTriangle(const Vertex<T>& A, const Vertex<T>& B, const Vertex<T>& C, const WatertightShear<T>& s) noexcept
        : Ax(component(A, s.kx) - s.Sx * component(A, s.kz)), // WBW: Ax = A[kx] − Sx·A[kz]
          Ay(component(A, s.ky) - s.Sy * component(A, s.kz)), Bx(component(B, s.kx) - s.Sx * component(B, s.kz)),
          By(component(B, s.ky) - s.Sy * component(B, s.kz)), Cx(component(C, s.kx) - s.Sx * component(C, s.kz)),
          Cy(component(C, s.ky) - s.Sy * component(C, s.kz)),
          U(difference_of_products(Cx, By, Cy, Bx)), // WBW: edge functions as watertight_edges, exact sign
          V(difference_of_products(Ax, Cy, Ay, Cx)), W(difference_of_products(Bx, Ay, By, Ax)) {}

    /// t·det: the edge functions weighting the vertices' depths along the ray (WBW: Az = Sz·A[kz]).
    [[nodiscard]] T t_det(const Vertex<T>& A, const Vertex<T>& B, const Vertex<T>& C,
                          const WatertightShear<T>& s) const noexcept {
        const T Az = s.Sz * component(A, s.kz), Bz = s.Sz * component(B, s.kz), Cz = s.Sz * component(C, s.kz);
        return U * Az + V * Bz + W * Cz; // WBW: t·det, as watertight_t_det where the compiler fuses
    }
};

/// The watertight test's per-triangle part (WBW §3) for vertices A, B, C relative to the ray's
/// origin; the caller rejects degenerate triangles (intersect_watertight on the hit path only,
/// Bvh at build time).
template <class T>
[[nodiscard]] inline Hit<T> intersect_sheared(const Vertex<T>& A, const Vertex<T>& B, const Vertex<T>& C,
                                              const WatertightShear<T>& s, bool cull_backfaces) noexcept {
    const ShearedTriangle<T> e(A, B, C, s);
    const T U = e.U, V = e.V, W = e.W;
    const bool any_negative = U < T(0) || V < T(0) || W < T(0);
    const bool any_positive = U > T(0) || V > T(0) || W > T(0);
    // Front faces (clockwise seen from the origin, §2) have U, V, W ≥ 0.
    if (cull_backfaces ? any_negative : (any_negative && any_positive)) return Hit<T>::miss();
    const T det = U + V + W;
    if (!(det != T(0))) return Hit<T>::miss();
    const T t_scaled = e.t_det(A, B, C, s);
    const T inv_det = T(1) / det;
    const T t = t_scaled * inv_det;
    if (!(t > T(0)) || !(t < std::numeric_limits<T>::infinity())) return Hit<T>::miss();
    return Hit<T>::at(t, V * inv_det, W * inv_det);
}

} // namespace detail

/// Watertight ray–triangle test (Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection",
/// JCGT 2(1), 2013), beyond the note: the ray is sheared so that it runs along +z, and the three
/// 2D edge functions U, V, W of the sheared vertices decide inside/outside. Each is computed by
/// `difference_of_products`, so its sign is exact: a ray through an edge shared by two triangles
/// is seen on the same side of it by both, and a closed mesh has no cracks. Barycentrics u = V/det
/// (weight of V1), v = W/det (weight of V2). Two-sided unless `cull_backfaces`.
template <class T>
[[nodiscard]] inline Hit<T> intersect_watertight(const Ray<T>& ray, const Triangle<T>& tri,
                                                 bool cull_backfaces = false) noexcept {
    detail::WatertightShear<T> shear;
    if (!shear.set(ray.direction)) return Hit<T>::miss();
    // Per triangle: vertices relative to the origin, sheared onto the ray's frame.
    const Hit<T> h =
        detail::intersect_sheared(tri.v0 - ray.origin, tri.v1 - ray.origin, tri.v2 - ray.origin, shear, cull_backfaces);
    if (!h) return h;
    const Vertex<T> e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
    if (detail::is_degenerate(e1, e2, cross(e1, e2))) return Hit<T>::miss(); // hit path only
    return h;
}

/// The hit point of a triangle hit, rebuilt from its barycentrics: P = b0·V0 + b1·V1 + b2·V2 with
/// b1 = u, b2 = v, b0 = 1 − u − v (every triangle test that gives u, v: area test, Möller–Trumbore,
/// watertight, a Bvh's hits with the caller's `triangles[hit.primitive]`; the ray is not used, it
/// is there so that every primitive's hit_point reads alike). Unlike Ro + t·Rd, whose error grows
/// with |Ro| and t, its bound depends on the triangle alone, per component the larger of
/// - γ₇·(|b0·V0| + |b1·V1| + |b2·V2|): the point's own rounding (pbrt-v4 §6.8.5), and
/// - γ₃₂·L³/|N|∞ (L the longest edge, N the §2 normal, in max norm): how far from the plane a
///   triangle test, computing from a ray origin on the triangle, may place it. pbrt-v4 adds a
///   conservative t > 0 to its test instead (§6.8.7), which here cost much of the Bvh's speed;
///   the margin matters only where |P| is below the triangle's size (near the origin).
namespace detail {
// The formulas below run on one value (V = T) or a register of lanes (V = simd/pack.hpp's), with
// the same roundings in both: maxima as std::max(a, b) (a < b ? b : a, no NaN checks: one maxss
// each, no branches), products added through lane_fma.
template <class T, class V>
ISIN_DETAIL_INLINE V larger_of(const V& a, const V& b) noexcept {
    return select(a < b, b, a);
}
template <class T, class V>
ISIN_DETAIL_INLINE V largest_magnitude(const V& x, const V& y, const V& z) noexcept {
    return larger_of<T>(larger_of<T>(lane_abs(x), lane_abs(y)), lane_abs(z));
}
/// The triangle test's margin of hit_point's bound, γ₃₂·L³/|N|∞ (L the longest edge in max norm),
/// from the vertices v (V0, V1, V2, x y z each) and |N|∞ of the §2 normal: the triangle's alone.
/// A NaN (0/0 from a triangle shrunk to a point, whose point is then exact) leaves the own bound.
template <class T, class V>
ISIN_DETAIL_INLINE V triangle_test_margin(const V* v, const V& largest_N) noexcept {
    const V L = larger_of<T>(larger_of<T>(largest_magnitude<T>(v[3] - v[0], v[4] - v[1], v[5] - v[2]),  // V1 − V0
                                          largest_magnitude<T>(v[6] - v[0], v[7] - v[1], v[8] - v[2])), // V2 − V0
                             largest_magnitude<T>(v[6] - v[3], v[7] - v[4], v[8] - v[5]));              // V2 − V1
    return V(rounding_gamma<T>(32)) * L * (L * L / largest_N); // γ₃₂·L³/|N|∞
}
/// hit_point's point and bound from the vertices v (V0, V1, V2, x y z each) and barycentrics u, w:
/// P = b0·V0 + b1·V1 + b2·V2 (b1 = u, b2 = w, b0 = 1 − u − w), and per component the larger of
/// γ₇·(|b0·V0| + |b1·V1| + |b2·V2|) (pbrt-v4 §6.8.5) and the test margin.
template <class T, class V>
ISIN_DETAIL_INLINE void barycentric_point(const V* v, const V& u, const V& w, const V& margin, V (&p)[3],
                                          V (&error)[3]) noexcept {
    const V b0 = V(T(1)) - u - w;
    for (int c = 0; c < 3; ++c) {
        const V p0 = b0 * v[c], p1 = u * v[3 + c], p2 = w * v[6 + c];
        p[c] = p0 + p1 + p2;
        const V own = V(rounding_gamma<T>(7)) * (lane_abs(p0) + lane_abs(p1) + lane_abs(p2));
        error[c] = larger_of<T>(own, margin);
    }
}
/// The vertices V0, V1, V2 as nine values, x y z each.
template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE std::array<T, 9> vertices_of(const Triangle<T>& tri) noexcept {
    return {{tri.v0.x, tri.v0.y, tri.v0.z, tri.v1.x, tri.v1.y, tri.v1.z, tri.v2.x, tri.v2.y, tri.v2.z}};
}
/// A triangle hit's surface, for one value or a register of lanes: hit_point's point and bound
/// (barycentric_point) and the unit §2 normal, normalize((V1 − V0) × (V2 − V0)).
template <class T, class V>
ISIN_DETAIL_INLINE void triangle_surface(const V* v, const V& u, const V& w, V (&p)[3], V (&error)[3],
                                         V (&n)[3]) noexcept {
    const V e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
    const V e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
    n[0] = lane_cross_term(e1[1], e2[2], e1[2], e2[1]); // §2: N = (V1−V0) × (V2−V0)
    n[1] = lane_cross_term(e1[2], e2[0], e1[0], e2[2]);
    n[2] = lane_cross_term(e1[0], e2[1], e1[1], e2[0]);
    barycentric_point<T>(v, u, w, triangle_test_margin<T>(v, largest_magnitude<T>(n[0], n[1], n[2])), p, error);
    lane_normalize<T>(n[0], n[1], n[2]);
}

/// hit_point's work, given the triangle's §2 normal N (callers that also need N compute it once).
template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE BoundedPoint<T> triangle_hit_point(const Triangle<T>& tri, const Hit<T>& hit,
                                                                    const Vertex<T>& N) noexcept {
    const std::array<T, 9> vertices = vertices_of(tri);
    const T* v = vertices.data();
    T p[3], error[3];
    barycentric_point<T>(v, hit.u, hit.v, triangle_test_margin<T>(v, largest_magnitude<T>(N.x, N.y, N.z)), p, error);
    return {{p[0], p[1], p[2]}, {error[0], error[1], error[2]}};
}
} // namespace detail

template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE BoundedPoint<T> hit_point(const Ray<T>&, const Triangle<T>& tri,
                                                           const Hit<T>& hit) noexcept {
    return detail::triangle_hit_point(tri, hit, normal(tri));
}

} // namespace isin
