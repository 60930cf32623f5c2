#pragma once
/// isin — bounds on rounding errors (pbrt-v4, 4th ed. §6.8): γₙ, and points that carry a bound on
/// how far the exact point they stand for may lie from them.
///
///     const isin::BoundedPoint<float> p = isin::hit_point(ray, tri, hit); // p.point ± p.error
///     isin::Ray<float> shadow{isin::offset_ray_origin(p, N, to_light), to_light}; // offset.hpp
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "detail/attributes.hpp"
#include "vec.hpp"

namespace isin {

/// γₙ = n·u / (1 − n·u) with u = ε/2, the unit roundoff: (1 ± u)ⁿ lies within 1 ± γₙ, so a result
/// of n rounded operations in a row is off by at most γₙ times its exact value (Higham, "Accuracy
/// and Stability of Numerical Algorithms", §3.1; pbrt-v4 §6.8.1).
template <class T>
[[nodiscard]] constexpr T rounding_gamma(int n) noexcept {
    static_assert(std::is_floating_point_v<T>, "isin::rounding_gamma needs a floating-point type");
    constexpr T u = std::numeric_limits<T>::epsilon() / T(2);
    return T(n) * u / (T(1) - T(n) * u);
}

namespace detail {
/// c one ulp further in the direction of `towards`'s sign (c unchanged when towards is 0): the
/// magnitude's bits grow by one where c and towards share a sign, shrink by one where not. Branch
/// free; c must be finite (offset_ray_origin checks its input, and c = p + offset stays finite
/// unless p is within an offset of the largest T, where the step gives ±∞).
template <class T>
[[nodiscard]] ISIN_DETAIL_INLINE T step_away(T c, T towards) noexcept {
    using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
    if (c == T(0)) c = std::copysign(T(0), towards); // ±0 steps to ±denorm_min
    Bits bits;
    std::memcpy(&bits, &c, sizeof c);
    const Bits step = towards != T(0) ? Bits(1) : Bits(0);
    bits = std::signbit(c) == std::signbit(towards) ? bits + step : bits - step;
    std::memcpy(&c, &bits, sizeof c);
    return c;
}
} // namespace detail

/// The next representable value above v (below v with `down`), as pbrt-v4's NextFloatUp/Down: by
/// the bits (detail::step_away), a few instructions where std::nextafter is a library call; −0 and
/// +0 step alike; infinities and NaN come back unchanged.
template <class T>
[[nodiscard]] inline T next_float(T v, bool down = false) noexcept {
    static_assert(std::numeric_limits<T>::is_iec559, "IEEE 754 float or double");
    if (!(std::fabs(v) < std::numeric_limits<T>::infinity())) return v;
    return detail::step_away(v, down ? T(-1) : T(1));
}

/// A point computed in floating point, and a bound on its error: the exact point it stands for lies
/// in the box point ± error (component by component). pbrt-v4's Point3fi. Hit points of every
/// primitive come as one (`hit_point`); secondary rays start off the box (`offset_ray_origin`).
template <class T>
struct BoundedPoint {
    static_assert(std::is_floating_point_v<T>, "isin::BoundedPoint needs a floating-point type");
    Vertex<T> point;
    Vertex<T> error; ///< ≥ 0 in each component; +∞ when nothing is known
};

/// The component-wise absolute value |a|.
template <class T>
[[nodiscard]] inline Vertex<T> abs(const Vertex<T>& a) noexcept {
    return {std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)};
}

/// The point Ro + t·Rd of a ray that met some surface at t, with a bound for primitives that have
/// no `hit_point` of their own. t's own error is unknown here, so the bound is a generous multiple
/// of the magnitudes involved, 64ε·(|Ro| + |t·Rd|) per component: the margin isin's fixed rule
/// (`offset_origin`) gives, not the tight bound of a surface's own reconstruction.
template <class T>
[[nodiscard]] inline BoundedPoint<T> point_on_ray(const Vertex<T>& origin, const Vertex<T>& direction, T t) noexcept {
    constexpr T eps = std::numeric_limits<T>::epsilon();
    const Vertex<T> step = t * direction;
    return {origin + step, (T(64) * eps) * (abs(origin) + abs(step))};
}

} // namespace isin
