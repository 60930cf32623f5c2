#pragma once
/// isin — colours: linear RGB in [0,1] for shading, 8-bit RGB for images.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "simd/pack.hpp"

namespace isin {

/// Linear RGB colour; 1 is full intensity. Values above 1 are allowed while shading and
/// clamped when written to an 8-bit image.
template <class T>
struct Color {
    static_assert(std::is_floating_point_v<T>, "isin::Color needs a floating-point type");
    T r, g, b;

    constexpr Color& operator+=(const Color& c) noexcept {
        r += c.r;
        g += c.g;
        b += c.b;
        return *this;
    }
    constexpr Color& operator*=(T s) noexcept {
        r *= s;
        g *= s;
        b *= s;
        return *this;
    }
};

using Colorf = Color<float>;
using Colord = Color<double>;

template <class T>
constexpr Color<T> operator+(const Color<T>& a, const Color<T>& b) noexcept {
    return {a.r + b.r, a.g + b.g, a.b + b.b};
}
template <class T>
constexpr Color<T> operator-(const Color<T>& a, const Color<T>& b) noexcept {
    return {a.r - b.r, a.g - b.g, a.b - b.b};
}
/// Component-wise product: a surface colour lit by a light colour.
template <class T>
constexpr Color<T> operator*(const Color<T>& a, const Color<T>& b) noexcept {
    return {a.r * b.r, a.g * b.g, a.b * b.b};
}
template <class T>
constexpr Color<T> operator*(const Color<T>& a, T s) noexcept {
    return {a.r * s, a.g * s, a.b * s};
}
template <class T>
constexpr Color<T> operator*(T s, const Color<T>& a) noexcept {
    return {s * a.r, s * a.g, s * a.b};
}
template <class T>
constexpr Color<T> operator/(const Color<T>& a, T s) noexcept {
    return {a.r / s, a.g / s, a.b / s};
}
template <class T>
constexpr bool operator==(const Color<T>& a, const Color<T>& b) noexcept {
    return a.r == b.r && a.g == b.g && a.b == b.b;
}
template <class T>
constexpr bool operator!=(const Color<T>& a, const Color<T>& b) noexcept {
    return !(a == b);
}

/// An 8-bit RGB pixel, as stored in images and in the note's examples, e.g. red (255,0,0).
struct Rgb8 {
    std::uint8_t r, g, b;
};
constexpr bool operator==(const Rgb8& a, const Rgb8& b) noexcept { return a.r == b.r && a.g == b.g && a.b == b.b; }
constexpr bool operator!=(const Rgb8& a, const Rgb8& b) noexcept { return !(a == b); }

/// The colour of an 8-bit pixel: each channel / 255.
template <class T>
[[nodiscard]] constexpr Color<T> from_rgb8(int r, int g, int b) noexcept {
    return {T(r) / T(255), T(g) / T(255), T(b) / T(255)};
}

namespace detail {
/// to_byte's value before it is truncated to a byte, for one channel (V = T) or a register of
/// them: 0 for NaN and c ≤ 0, 255 for c ≥ 1, else c·255 + 0.5 (lane_fma's rounding).
template <class T, class V = T>
[[nodiscard]] V byte_before_truncation(V c) noexcept {
    return select(c > T(0), select(c < T(1), lane_fma(c, V(T(255)), V(T(0.5))), V(T(255))), V(T(0)));
}
} // namespace detail

/// One channel in [0,1] to 0…255, rounded to nearest; NaN becomes 0, out-of-range values clamp.
template <class T>
[[nodiscard]] inline std::uint8_t to_byte(T c) noexcept {
    return static_cast<std::uint8_t>(detail::byte_before_truncation<T>(c));
}

/// to_byte of values[0 … n) into bytes[0 … n), a register of values at a time where the target
/// has them (simd/pack.hpp); the same bytes. `values` is aligned to 64 bytes.
template <class T>
void to_bytes(const T* values, std::size_t n, std::uint8_t* bytes) noexcept {
    using R = detail::LaneRegister<T>;
    std::size_t i = 0;
    for (; i + R::width <= n; i += R::width)
        detail::store_bytes<T>(detail::byte_before_truncation<T>(R::load(values + i)), bytes + i);
    for (; i < n; ++i) bytes[i] = to_byte(values[i]);
}

/// A colour as an 8-bit pixel (clamped, rounded).
template <class T>
[[nodiscard]] inline Rgb8 to_rgb8(const Color<T>& c) noexcept {
    return {to_byte(c.r), to_byte(c.g), to_byte(c.b)};
}

/// How 8-bit values relate to the linear intensities isin shades with: `linear` (byte / 255, the
/// note's convention and isin's default) or `srgb` (the sRGB transfer curve of IEC 61966-2-1,
/// which PNG and JPEG files from cameras and paint programs assume).
enum class ColorEncoding { linear, srgb };

/// Linear intensity of an sRGB-encoded value c in [0, 1] (IEC 61966-2-1): c / 12.92 up to
/// 0.04045, ((c + 0.055) / 1.055)^2.4 above.
template <class T>
[[nodiscard]] inline T srgb_to_linear(T c) noexcept {
    return c <= T(0.04045) ? c / T(12.92) : std::pow((c + T(0.055)) / T(1.055), T(2.4));
}

/// sRGB encoding of a linear intensity c in [0, 1] (IEC 61966-2-1): 12.92·c up to 0.0031308,
/// 1.055·c^(1/2.4) − 0.055 above. NaN and values ≤ 0 give 0, values ≥ 1 give 1.
template <class T>
[[nodiscard]] inline T linear_to_srgb(T c) noexcept {
    if (!(c > T(0))) return T(0);
    if (!(c < T(1))) return T(1);
    return c <= T(0.0031308) ? T(12.92) * c : T(1.055) * std::pow(c, T(1) / T(2.4)) - T(0.055);
}

/// A colour as an 8-bit pixel in `encoding` (clamped, rounded).
template <class T>
[[nodiscard]] inline Rgb8 to_rgb8(const Color<T>& c, ColorEncoding encoding) noexcept {
    if (encoding == ColorEncoding::linear) return to_rgb8(c);
    return {to_byte(linear_to_srgb(c.r)), to_byte(linear_to_srgb(c.g)), to_byte(linear_to_srgb(c.b))};
}

} // namespace isin
