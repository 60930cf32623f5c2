#pragma once
/// isin — spheres and the geometric ray–sphere test of note §6.
#include <cmath>
#include <limits>

#include "detail/attributes.hpp"
#include "simd/pack.hpp"
#include "error_bound.hpp"
#include "hit.hpp"
#include "ray.hpp"
#include "vec.hpp"

namespace isin {

/// A sphere; a zero, negative or NaN radius is an empty sphere that every ray misses.
template <class T>
struct Sphere {
    static_assert(std::is_floating_point_v<T>, "isin::Sphere needs a floating-point type");
    Vertex<T> center;
    T radius;
};

using Spheref = Sphere<float>;
using Sphered = Sphere<double>;

/// Outward unit normal of the sphere at a point p on its surface.
template <class T>
[[nodiscard]] inline Vertex<T> normal_at(const Sphere<T>& sp, const Vertex<T>& p) noexcept {
    return normalize(p - sp.center);
}

/// P − C for the point P = Ro + t·Rd of a ray, as (Ro − C) + t·Rd: rounded at the scale of the
/// eye's distance from the sphere, not at |P| — for a sphere a few ulps across far from the
/// origin, P itself is rounded by a good part of the radius.
template <class T>
[[nodiscard]] inline Vertex<T> offset_from_center(const Ray<T>& ray, const Sphere<T>& sp, T t) noexcept {
    const Vertex<T> oc = ray.origin - sp.center;
    return {detail::lane_fma(t, ray.direction.x, oc.x), detail::lane_fma(t, ray.direction.y, oc.y),
            detail::lane_fma(t, ray.direction.z, oc.z)};
}

namespace detail {
/// A sphere hit's surface for one value (V = T) or a register of lanes (simd/pack.hpp), rounded
/// alike in both (lane_fma, lane_dot): from the ray's origin o and direction d, the sphere's
/// centre c and radius r and the hit's t, the offset from the centre P − C = (o − c) + t·d
/// (offset_from_center), the unit normal along it (normal_at), and hit_point's point
/// C + r·(P − C)/|P − C| with its bound γ₅·|P − C| + γ₁·|P| (pbrt-v4 §6.8.5: reprojection).
template <class T, class V>
ISIN_DETAIL_INLINE void sphere_surface(const V (&o)[3], const V (&d)[3], const V (&c)[3], const V& r, const V& t,
                                       V (&p)[3], V (&error)[3], V (&n)[3]) noexcept {
    const V pl[3] = {lane_fma(t, d[0], o[0] - c[0]), lane_fma(t, d[1], o[1] - c[1]), lane_fma(t, d[2], o[2] - c[2])};
    n[0] = pl[0], n[1] = pl[1], n[2] = pl[2];
    const V scale = r / lane_normalize<T>(n[0], n[1], n[2]); // r / |P − C|
    for (int i = 0; i < 3; ++i) {
        const V q = scale * pl[i]; // pbrt-v4: reproject onto the sphere
        p[i] = c[i] + q;
        error[i] = lane_fma(V(rounding_gamma<T>(5)), lane_abs(q), V(rounding_gamma<T>(1)) * lane_abs(p[i]));
    }
}
/// sphere_surface for one ray, sphere and t.
template <class T>
ISIN_DETAIL_INLINE void sphere_surface(const Ray<T>& ray, const Sphere<T>& sp, T t, Vertex<T>* point, Vertex<T>* error,
                                       Vertex<T>* normal) noexcept {
    const T o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
    const T d[3] = {ray.direction.x, ray.direction.y, ray.direction.z};
    const T c[3] = {sp.center.x, sp.center.y, sp.center.z};
    T p[3], e[3], n[3];
    sphere_surface<T, T>(o, d, c, sp.radius, t, p, e, n);
    if (point) *point = {p[0], p[1], p[2]};
    if (error) *error = {e[0], e[1], e[2]};
    if (normal) *normal = {n[0], n[1], n[2]};
}
} // namespace detail

/// Outward unit normal of the sphere where `ray` hits it: from offset_from_center, so that it is
/// right to the eye's distance, not to |P| (normal_at(sp, P) is off by up to ulp(|C|)/r radians,
/// enough to make a grazing ray look as if it came from inside a tiny far sphere).
template <class T>
[[nodiscard]] inline Vertex<T> normal_at(const Ray<T>& ray, const Sphere<T>& sp, const Hit<T>& hit) noexcept {
    Vertex<T> n;
    detail::sphere_surface<T>(ray, sp, hit.t, nullptr, nullptr, &n);
    return n;
}

/// Bound on the error of a point that `hit_point` puts on the sphere: γ₅·r from the reprojection
/// onto the sphere about its centre, γ₁·(|C|∞ + r) from adding the centre back (pbrt-v4 §6.8.5),
/// per component.
template <class T>
[[nodiscard]] inline T surface_point_error(const Sphere<T>& sp) noexcept {
    return rounding_gamma<T>(6) * sp.radius + rounding_gamma<T>(1) * max_abs(sp.center);
}

/// Half-width, in l2 − r2 (l2 = |C − Ro|²), of the band around the surface in which a ray origin
/// counts as lying on the sphere: where a point from `hit_point` may lie (within √3·e of the
/// surface, e = surface_point_error), l2 − r2 ≈ 2r·√3·e, plus the rounding of l2 − r2 itself,
/// γ₆·(l2 + r2). From the error bounds (pbrt-v4 §6.8), not a fixed multiple: it does not grow with
/// the distance of the eye the hit point was seen from, and is a few ulps wide in float. This
/// replaces the note's absolute `l2 > r2 + 0.001` (§8), which is 1000× too wide at r = 1e-3 and
/// below the rounding of l2 at r = 1e4.
template <class T>
[[nodiscard]] inline T surface_band(const Sphere<T>& sp, T l2) noexcept {
    const T e = T(1.7320508075688772) * surface_point_error(sp); // √3·e: the error box's diagonal
    const T r2 = sp.radius * sp.radius;
    return e * (T(2) * sp.radius + e) + rounding_gamma<T>(6) * (l2 + r2);
}

/// The hit point of a sphere hit: Ro + t·Rd moved radially onto the sphere, C + r·(P − C)/|P − C|,
/// and its error bound (pbrt-v4 §6.8.5: reprojection). Its error depends on the sphere alone, not
/// on how far the ray came from; restarting a ray from it, raw, is what `surface_band` expects.
template <class T>
[[nodiscard]] inline BoundedPoint<T> hit_point(const Ray<T>& ray, const Sphere<T>& sp, const Hit<T>& hit) noexcept {
    BoundedPoint<T> p;
    detail::sphere_surface<T>(ray, sp, hit.t, &p.point, &p.error, nullptr); // pbrt-v4: reproject onto the sphere
    return p;
}

namespace detail {
/// §6's steps for a ray and a sphere, in units of |Rd|² = a (any non-zero direction; 1 for the
/// note's unit Rd): l = C − Ro, the closest approach s = l·Rd/a, l2 = l·l, r2 = r²; `ok` is false
/// for a zero, infinite or NaN direction or radius (nothing is met).
template <class T>
struct SphereApproach {
    Vertex<T> l;
    T inv_a = T(0), s = T(0), l2 = T(0), r2 = T(0);
    bool ok = false;
    /// §6: m2 = l2 − s², computed as |l − s·Rd|² (Ray Tracing Gems ch. 7): the squared distance
    /// from C to the ray's line, without l2 − s²'s cancellation far from a small sphere.
    [[nodiscard]] T squared_miss(const Vertex<T>& Rd) const noexcept {
        const Vertex<T> m = l - s * Rd;
        return dot(m, m);
    }
    /// §6: q = √(r2 − m2), half the chord (the roots are s ± q), where m2 ≤ r2.
    [[nodiscard]] T half_chord(T m2) const noexcept { return std::sqrt((r2 - m2) * inv_a); }
    /// The product of the roots, t_near · t_far = (l2 − r2)/a: the root that would cancel as it over the other.
    [[nodiscard]] T root_product() const noexcept { return (l2 - r2) * inv_a; }
};

template <class T>
[[nodiscard]] inline SphereApproach<T> sphere_approach(const Ray<T>& ray, const Sphere<T>& sp) noexcept {
    SphereApproach<T> h;
    const Vertex<T>& Rd = ray.direction;
    const T a = dot(Rd, Rd);
    if (!(a > T(0)) || !(a < std::numeric_limits<T>::infinity())) return h;
    if (!(sp.radius > T(0)) || !(sp.radius < std::numeric_limits<T>::infinity())) return h;
    h.inv_a = T(1) / a;
    h.l = sp.center - ray.origin; // §6: l = C − Ro
    h.s = dot(h.l, Rd) * h.inv_a; // §6: s = l·Rd (closest approach)
    h.l2 = dot(h.l, h.l);         // §6: l2 = l·l
    h.r2 = sp.radius * sp.radius; // §6: r2 = r²
    h.ok = true;
    return h;
}
} // namespace detail

/// Geometric ray–sphere test of note §6, isin's default. Nearest hit with t > 0, t in units of
/// |direction| (any non-zero direction works; the note's unit Rd gives its numbers exactly).
/// Departures from the note, each for accuracy:
/// - m2 is computed as |l − s·Rd|² rather than l2 − s² (Ray Tracing Gems ch. 7), which cancels
///   catastrophically when the ray passes far from the centre of a small sphere;
/// - an origin within `surface_band` of the surface is on the sphere: it leaves (miss) if the ray
///   points outward (s ≤ 0), else it crosses to the far side (t = s + q). No t ≈ 0 self-hit at
///   any radius, unlike the note's `l2 > r2 + 0.001`;
/// - the root that would cancel (s − q when s ≈ q) is taken from the product of the roots,
///   t_near · t_far = (l2 − r2) / |Rd|².
template <class T>
[[nodiscard]] inline Hit<T> intersect(const Ray<T>& ray, const Sphere<T>& sp) noexcept {
    const detail::SphereApproach<T> h = detail::sphere_approach(ray, sp);
    if (!h.ok) return Hit<T>::miss();
    if (h.s < T(0) && h.l2 > h.r2) return Hit<T>::miss(); // §6: behind an outside (or leaving) origin
    const T m2 = h.squared_miss(ray.direction);
    if (!(m2 <= h.r2)) return Hit<T>::miss(); // §6: m2 > r2 → passes aside; NaN → miss
    const T q = h.half_chord(m2), c = h.root_product();
    T t;
    if (std::fabs(h.l2 - h.r2) <= surface_band(sp, h.l2)) { // §8 fix, scale-relative: on the surface
        if (!(h.s > T(0))) return Hit<T>::miss();           // leaving the sphere: no self-hit
        t = h.s + q;                                        // entering: the far side
    } else if (h.l2 > h.r2) {                               // §6: origin outside (s ≥ 0 here)
        t = c / (h.s + q);                                  // §6: t = s − q, without cancellation
    } else {
        t = h.s >= T(0) ? h.s + q : c / (h.s - q); // §6: origin inside → t = s + q
    }
    return t > T(0) && t < std::numeric_limits<T>::infinity() ? Hit<T>::at(t) : Hit<T>::miss();
}

/// The note's geometric test exactly as written (§6), for comparison: the origin is outside when
/// l2 > r2 (or, with `outside_margin`, when l2 > r2 + margin — the note's §8 fix, 0.001), and
/// m2 = l2 − s². Needs a unit direction. A ray restarted on the surface may hit it again at t ≈ 0.
/// Only the guards that keep bad input defined (zero direction or radius, NaN) are added.
template <class T>
[[nodiscard]] inline Hit<T> intersect_note(const Ray<T>& ray, const Sphere<T>& sp, T outside_margin = T(0)) noexcept {
    if (!(dot(ray.direction, ray.direction) > T(0)) || !(sp.radius > T(0))) return Hit<T>::miss();
    const Vertex<T> l = sp.center - ray.origin;     // §6: l = C − Ro
    const T s = dot(l, ray.direction);              // §6: s = l·Rd
    const T l2 = dot(l, l);                         // §6: l2 = l·l
    const T r2 = sp.radius * sp.radius;             // §6: r2 = r²
    const bool outside = l2 > r2 + outside_margin;  // §8: l2 > r2 (+ 0.001)
    if (s < T(0) && outside) return Hit<T>::miss(); // §6: behind
    const T m2 = l2 - s * s;                        // §6: m2 = l2 − s²
    if (!(m2 <= r2)) return Hit<T>::miss();         // §6: m2 > r2 → miss
    const T q = std::sqrt(r2 - m2);                 // §6: q = √(r2 − m2)
    const T t = outside ? s - q : s + q;            // §6: outside → s − q, inside → s + q
    return t > T(0) && t < std::numeric_limits<T>::infinity() ? Hit<T>::at(t) : Hit<T>::miss();
}

/// The textbook quadratic, for comparison: |Ro + t·Rd − C|² = r², i.e. a t² + b t + c = 0 with
/// a = Rd·Rd, b = 2 (Ro − C)·Rd, c = |Ro − C|² − r²; nearest root t > 0.
template <class T>
[[nodiscard]] inline Hit<T> intersect_quadratic(const Ray<T>& ray, const Sphere<T>& sp) noexcept {
    if (!(sp.radius > T(0))) return Hit<T>::miss();
    const Vertex<T> oc = ray.origin - sp.center;
    const T a = dot(ray.direction, ray.direction);
    const T b = T(2) * dot(oc, ray.direction);
    const T c = dot(oc, oc) - sp.radius * sp.radius;
    const T disc = b * b - T(4) * a * c; // discriminant
    if (!(disc >= T(0)) || !(a > T(0))) return Hit<T>::miss();
    const T root = std::sqrt(disc);
    const T t0 = (-b - root) / (T(2) * a), t1 = (-b + root) / (T(2) * a);
    const T t = t0 > T(0) ? t0 : t1;
    return t > T(0) && t < std::numeric_limits<T>::infinity() ? Hit<T>::at(t) : Hit<T>::miss();
}

/// The improved-precision test of Ray Tracing Gems ch. 7 (Haines, Günther & Akenine-Möller,
/// "Precision Improvements for Ray/Sphere Intersection", 2019), for comparison: the discriminant
/// from |f − (f·Rd/a)·Rd|² (f = Ro − C), and the root that would cancel taken as c/q.
template <class T>
[[nodiscard]] inline Hit<T> intersect_rtg(const Ray<T>& ray, const Sphere<T>& sp) noexcept {
    if (!(sp.radius > T(0))) return Hit<T>::miss();
    const Vertex<T> f = ray.origin - sp.center;
    const T a = dot(ray.direction, ray.direction);
    if (!(a > T(0))) return Hit<T>::miss();
    const T b = -dot(f, ray.direction);              // RTG: b′ = −f·d
    const Vertex<T> g = f + (b / a) * ray.direction; // RTG: f − (f·d/a)·d
    const T r2 = sp.radius * sp.radius;
    const T delta = r2 - dot(g, g); // RTG: Δ/(4a) = r² − |g|²
    if (!(delta >= T(0))) return Hit<T>::miss();
    const T c = dot(f, f) - r2;
    const T q = b + std::copysign(std::sqrt(a * delta), b);
    const T ta = c / q, tb = q / a; // RTG: t0 = c/q, t1 = q/a
    const T t_near = ta < tb ? ta : tb, t_far = ta < tb ? tb : ta;
    const T t = t_near > T(0) ? t_near : t_far;
    return t > T(0) && t < std::numeric_limits<T>::infinity() ? Hit<T>::at(t) : Hit<T>::miss();
}

} // namespace isin
