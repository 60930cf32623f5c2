#pragma once
/// isin — robust starting points for secondary rays (shadow, reflection, refraction rays).
#include <cmath>
#include <limits>

#include "detail/attributes.hpp"
#include "simd/pack.hpp"
#include "error_bound.hpp"
#include "ray.hpp"
#include "vec.hpp"

namespace isin {

/// The simple rule, for note-level code that has only a point: a point just off a surface at hit point p, on the side the unit normal n points to, from which
/// secondary rays start without hitting the same surface at t ≈ 0 ("shadow acne", §9).
/// Scale-aware: p carries a rounding error of a few ε times the largest coordinate involved in
/// computing it — p's own, or `scale`, the magnitude of the ray origin it was reached from — so
/// it moves by 256ε times that (never less than 256ε/32, so that points at the origin move too).
/// A fixed distance instead (1e-4, say) is too small far from the origin and too large for small
/// objects. Returns p unchanged when p or n is not finite.
/// Its cost (the secondary-ray study, scripts/offsets.sh, docs/accuracy.md): origins move orders
/// of magnitude further than `offset_ray_origin`'s, shadow rays lose occluders far from the origin
/// in float, and refracted rays start beyond thin spheres. Prefer `offset_ray_origin` with a
/// `hit_point`.
template <class T>
[[nodiscard]] inline Vertex<T> offset_origin(const Vertex<T>& p, const Vertex<T>& n, T scale = T(0)) noexcept {
    if (!is_finite(p) || !is_finite(n)) return p;
    constexpr T eps = std::numeric_limits<T>::epsilon();
    const T magnitude = max_of(max_of(max_abs(p), scale), T(1) / T(32));
    return p + (T(256) * eps * magnitude) * n;
}

namespace detail {
/// offset_ray_origin's move (pbrt-v4 §6.8.6) for one point or a register of lanes (V = T or
/// LaneRegister's V), rounded alike in both (lane_dot, lane_fma): (x, y, z) moves along the unit
/// normal n (already turned to the side the ray leaves by) by d = |n|·error to
/// (x, y, z) + d·n; (ox, oy, oz) = d·n, whose signs step_off follows.
template <class T, class V>
ISIN_DETAIL_INLINE void offset_lanes(V& x, V& y, V& z, const V& ex, const V& ey, const V& ez, const V& nx, const V& ny,
                                     const V& nz, V& ox, V& oy, V& oz) noexcept {
    const V d = lane_dot(lane_abs(nx), lane_abs(ny), lane_abs(nz), ex, ey, ez); // pbrt-v4: d = |n|·δp
    ox = d * nx, oy = d * ny, oz = d * nz;
    x = lane_fma(d, nx, x), y = lane_fma(d, ny, y), z = lane_fma(d, nz, z);
}
/// The origin from offset_lanes' moved point po and move o: each moved coordinate one ulp further
/// from p (pbrt-v4: the sum may have rounded towards it); p itself where anything in p, its error
/// or n was not finite (po is then not finite, or NaN).
template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE Vertex<T> step_off(const Vertex<T>& p, const Vertex<T>& po,
                                                    const Vertex<T>& o) noexcept {
    if (!(std::fabs(po.x) + std::fabs(po.y) + std::fabs(po.z) < std::numeric_limits<T>::infinity())) return p;
    return {step_away(po.x, o.x), step_away(po.y, o.y), step_away(po.z, o.z)};
}
} // namespace detail

/// Where a secondary ray leaving a surface point p (with its error bound) in direction w starts:
/// p moved along the unit geometric normal n, to the side w points to, by d = |n|·error — the
/// distance from p to the plane through the farthest corner of p's error box — then each moved
/// coordinate rounded one ulp further away from p (pbrt-v4 §6.8.6, OffsetRayOrigin). The exact
/// surface point lies in the box, so the origin is strictly on w's side of the surface, by as little
/// as rounding allows. Returns p.point when p, its error or n is not finite.
template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE Vertex<T> offset_ray_origin(const BoundedPoint<T>& p, const Vertex<T>& n,
                                                             const Vertex<T>& w) noexcept {
    const Vertex<T> side = dot(w, n) < T(0) ? -n : n; // pbrt-v4: along n, to w's side
    T x = p.point.x, y = p.point.y, z = p.point.z, ox, oy, oz;
    detail::offset_lanes<T, T>(x, y, z, p.error.x, p.error.y, p.error.z, side.x, side.y, side.z, ox, oy, oz);
    return detail::step_off(p.point, {x, y, z}, {ox, oy, oz});
}

/// A secondary ray from surface point p (unit geometric normal n) in direction w, starting at
/// offset_ray_origin(p, n, w) (pbrt-v4 SpawnRay).
template <class T>
[[nodiscard]] inline Ray<T> spawn_ray(const BoundedPoint<T>& p, const Vertex<T>& n, const Vertex<T>& w) noexcept {
    return {offset_ray_origin(p, n, w), w};
}

/// A shadow ray and the t below which a hit blocks it.
template <class T>
struct ShadowRay {
    Ray<T> ray;
    T t_max;
};

/// The shadow ray from surface point p (unit geometric normal n) towards a point light at `to`
/// (an exact point): origin offset_ray_origin(p, n, to − p), direction to − origin, so the light
/// sits at t = 1 to within the rounding of that difference; t_max = 1 − γ₂ keeps a surface through
/// the light itself from counting.
template <class T>
[[nodiscard]] inline ShadowRay<T> shadow_ray(const BoundedPoint<T>& p, const Vertex<T>& n,
                                             const Vertex<T>& to) noexcept {
    const Vertex<T> o = offset_ray_origin(p, n, to - p.point);
    return {{o, to - o}, T(1) - rounding_gamma<T>(2)};
}

/// The shadow ray between two surface points, from p (unit normal n) to q (unit normal nq): both
/// ends moved off their surfaces by their error bounds, towards each other (pbrt-v4 SpawnRayTo).
/// A triangle test finds q's own surface at t = 1 only to its rounding of the plane distance there,
/// ~γ·|d| along the normal, which the ray covers in γ/cos θ of t (θ between d and nq); so t_max is
/// 1 − γ₁₆/cos θ, where pbrt-v4 takes a fixed 1 − 10⁻⁴. q's surface then never blocks the ray.
template <class T>
[[nodiscard]] inline ShadowRay<T> shadow_ray(const BoundedPoint<T>& p, const Vertex<T>& n, const BoundedPoint<T>& q,
                                             const Vertex<T>& nq) noexcept {
    const Vertex<T> o = offset_ray_origin(p, n, q.point - p.point);
    const Vertex<T> target = offset_ray_origin(q, nq, o - q.point);
    const Vertex<T> d = target - o;
    const T cos_theta = std::fabs(dot(nq, d)) / length(d);
    const T t_max = T(1) - rounding_gamma<T>(16) / cos_theta;
    return {{o, d}, t_max > T(0) ? t_max : T(0)};
}

} // namespace isin
