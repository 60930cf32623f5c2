#pragma once
/// isin — the ray of note §3: R(t) = Ro + t·Rd.
#include <cstddef>

#include "vec.hpp"

namespace isin {

/// A ray from `origin` along `direction`. The note takes Rd as a unit vector; every isin test also
/// accepts a non-unit direction and then measures t in multiples of |direction|.
template <class T>
struct Ray {
    static_assert(std::is_floating_point_v<T>, "isin::Ray needs a floating-point type");
    Vertex<T> origin, direction;

    /// The point at parameter t (§3): R(t) = Ro + t·Rd.
    [[nodiscard]] constexpr Vertex<T> at(T t) const noexcept {
        return origin + t * direction; // §3: Ro + t·Rd
    }
};

/// Rays kept as six arrays (structure of arrays), for the stream calls of Bvh and Scene: ray i
/// starts at (ox[i], oy[i], oz[i]) and goes along (dx[i], dy[i], dz[i]).
template <class T>
struct RaysSoA {
    static_assert(std::is_floating_point_v<T>, "isin::RaysSoA needs a floating-point type");
    const T *ox, *oy, *oz, *dx, *dy, *dz;
    /// Ray i.
    [[nodiscard]] constexpr Ray<T> operator[](std::size_t i) const noexcept {
        return {{ox[i], oy[i], oz[i]}, {dx[i], dy[i], dz[i]}};
    }
};

using Rayf = Ray<float>;
using Rayd = Ray<double>;

} // namespace isin
