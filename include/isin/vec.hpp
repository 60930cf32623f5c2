#pragma once
/// isin — vector algebra of note §2: the Vertex type, dot, cross, length, normalize, reflect.
#include <cmath>
#include <type_traits>

#include "simd/products.hpp"

namespace isin {

/// A point or direction in the note's left-handed frame (+X right, +Y up, +Z forward).
template <class T>
struct Vertex {
    static_assert(std::is_floating_point_v<T>, "isin::Vertex needs float, double or long double");
    T x, y, z;

    constexpr Vertex& operator+=(const Vertex& b) noexcept {
        x += b.x;
        y += b.y;
        z += b.z;
        return *this;
    }
    constexpr Vertex& operator-=(const Vertex& b) noexcept {
        x -= b.x;
        y -= b.y;
        z -= b.z;
        return *this;
    }
    constexpr Vertex& operator*=(T s) noexcept {
        x *= s;
        y *= s;
        z *= s;
        return *this;
    }
    constexpr Vertex& operator/=(T s) noexcept {
        x /= s;
        y /= s;
        z /= s;
        return *this;
    }
};

using Vec3f = Vertex<float>;
using Vec3d = Vertex<double>;

template <class T>
constexpr Vertex<T> operator+(const Vertex<T>& a, const Vertex<T>& b) noexcept {
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
constexpr Vertex<T> operator-(const Vertex<T>& a, const Vertex<T>& b) noexcept {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
constexpr Vertex<T> operator-(const Vertex<T>& a) noexcept {
    return {-a.x, -a.y, -a.z};
}
template <class T>
constexpr Vertex<T> operator+(const Vertex<T>& a) noexcept {
    return a;
}
template <class T>
constexpr Vertex<T> operator*(const Vertex<T>& a, T s) noexcept {
    return {a.x * s, a.y * s, a.z * s};
}
template <class T>
constexpr Vertex<T> operator*(T s, const Vertex<T>& a) noexcept {
    return {s * a.x, s * a.y, s * a.z};
}
template <class T>
constexpr Vertex<T> operator/(const Vertex<T>& a, T s) noexcept {
    return {a.x / s, a.y / s, a.z / s};
}
template <class T>
constexpr bool operator==(const Vertex<T>& a, const Vertex<T>& b) noexcept {
    return a.x == b.x && a.y == b.y && a.z == b.z;
}
template <class T>
constexpr bool operator!=(const Vertex<T>& a, const Vertex<T>& b) noexcept {
    return !(a == b);
}

/// Dot product (§2): R1·R2 = x1x2 + y1y2 + z1z2 = |R1||R2|cos β.
template <class T>
[[nodiscard]] constexpr T dot(const Vertex<T>& a, const Vertex<T>& b) noexcept {
    return a.x * b.x + a.y * b.y + a.z * b.z; // §2: R1·R2
}

/// Cross product (§2); in the left-handed frame +X × +Y = +Z.
template <class T>
[[nodiscard]] constexpr Vertex<T> cross(const Vertex<T>& a, const Vertex<T>& b) noexcept {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; // §2: R1 × R2
}

/// Length (§2): |R| = sqrt(x² + y² + z²).
template <class T>
[[nodiscard]] inline T length(const Vertex<T>& a) noexcept {
    return std::sqrt(dot(a, a)); // §2: |R|
}

/// Unit vector in the direction of `a` (§2: divide by the length). A zero, infinite or NaN
/// vector has no direction: the result is then (0,0,0), which every intersection test misses.
template <class T>
[[nodiscard]] inline Vertex<T> normalize(const Vertex<T>& a) noexcept {
    const T len = length(a);
    if (!(len > T(0)) || !std::isfinite(len)) return {T(0), T(0), T(0)};
    return a / len; // §2: R / |R|
}

/// Mirror direction `d` about the unit normal `n` (§7, §8): Rf = d − 2(d·n)n.
template <class T>
[[nodiscard]] constexpr Vertex<T> reflect(const Vertex<T>& d, const Vertex<T>& n) noexcept {
    return d - T(2) * dot(d, n) * n; // §8: Rd − 2(Rd·N)N
}

/// Component k (0 = x, 1 = y, 2 = z).
template <class T>
[[nodiscard]] constexpr T component(const Vertex<T>& a, int k) noexcept {
    return k == 0 ? a.x : (k == 1 ? a.y : a.z);
}

/// a·b − c·d with the sign always exact and the value within 2 ulps, whatever the compiler does
/// with floating point short of -ffast-math (it may fuse a plain `a*b - c*d` into one FMA, which
/// rounds the two products differently and can flip the sign of a near-zero result). float:
/// products of floats are exact in double. double: Kahan's algorithm with explicit std::fma
/// (hardware with -mfma or -march=native, a library call otherwise), as the Bvh's lanes compute
/// it (detail::lane_difference_of_products, simd/products.hpp).
template <class T>
[[nodiscard]] inline T difference_of_products(T a, T b, T c, T d) noexcept {
    if constexpr (sizeof(T) < sizeof(double)) {
        return T(double(a) * double(b) - double(c) * double(d));
    } else {
        return detail::lane_difference_of_products(a, b, c, d);
    }
}

/// True when every component is finite (no NaN, no infinity).
template <class T>
[[nodiscard]] inline bool is_finite(const Vertex<T>& a) noexcept {
    return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

/// The larger of a and b by plain comparisons (std::fmax is a library call on x86, and drops
/// NaN): a NaN in either is the result, so a magnitude built from a NaN stays NaN and the
/// NaN-rejecting tests that use it reject.
template <class T>
[[nodiscard]] constexpr T max_of(T a, T b) noexcept {
    return a < b || b != b ? b : a; // b != b: b is NaN
}

/// Largest absolute component (the max norm), a cheap magnitude for scale-relative tolerances;
/// NaN if any component is NaN.
template <class T>
[[nodiscard]] inline T max_abs(const Vertex<T>& a) noexcept {
    return max_of(std::fabs(a.x), max_of(std::fabs(a.y), std::fabs(a.z)));
}

} // namespace isin
