#pragma once
/// isin — robust starting points for secondary rays (shadow, reflection, refraction rays).
#include <cmath>
#include <limits>

#include "vec.hpp"

namespace isin {

/// A point just off a surface at hit point p, on the side the unit normal n points to, from which
/// secondary rays start without hitting the same surface at t ≈ 0 ("shadow acne", §9).
/// Scale-aware: p carries a rounding error of a few ε times the largest coordinate involved in
/// computing it — p's own, or `scale`, the magnitude of the ray origin it was reached from — so
/// it moves by 256ε times that (never less than 256ε/32, so that points at the origin move too).
/// A fixed distance instead (1e-4, say) is too small far from the origin and too large for small
/// objects. Returns p unchanged when p or n is not finite.
template <class T>
[[nodiscard]] inline Vertex<T> offset_origin(const Vertex<T>& p, const Vertex<T>& n, T scale = T(0)) noexcept {
    if (!is_finite(p) || !is_finite(n)) return p;
    constexpr T eps = std::numeric_limits<T>::epsilon();
    const T magnitude = max_of(max_of(max_abs(p), scale), T(1) / T(32));
    return p + (T(256) * eps * magnitude) * n;
}

} // namespace isin
