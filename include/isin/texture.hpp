#pragma once
/// isin — texture mapping of note §10: texel coordinates on a rectangle's two right triangles,
/// a procedural checkerboard and image textures, sampled nearest or bilinear with repeat wrapping.
///
/// Every texture T has `width()`, `height()` (in texels) and
/// `sample(s, t, Filter) noexcept` at normalised coordinates s = x / width, t = y / height. s and
/// t repeat (1.25 reads like 0.25, −0.25 like 0.75); a NaN or infinite coordinate reads texel
/// (0, 0). Texel row 0 is the top row of the image, addressed by t = 0. sample() never allocates.
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "color.hpp"
#include "image.hpp"
#include "image_io.hpp"

namespace isin {

/// Texel coordinates (§10) of Möller–Trumbore barycentrics (u, v) on a w × h texture spread over
/// a rectangle made of two right triangles, V0 at the right angle: (u·w, v·h) on the first,
/// ((1−u)·w, (1−v)·h) on the second. In pixels; divide by w and h for sample().
template <class T>
[[nodiscard]] constexpr std::array<T, 2> note_texel(T u, T v, T w, T h, bool second_triangle) noexcept {
    static_assert(std::is_floating_point_v<T>, "isin::note_texel needs a floating-point type");
    if (second_triangle) return {(T(1) - u) * w, (T(1) - v) * h}; // §10: ((1−u)·w, (1−v)·h)
    return {u * w, v * h};                                        // §10: (u·w, v·h)
}

/// How a texture is read between texel centres.
enum class Filter {
    nearest,  ///< the texel containing the point: (floor(s·w), floor(t·h))
    bilinear, ///< 4-tap blend of the nearest texel centres (centres at +0.5), repeat wrapping
};

namespace detail {

/// s wrapped into [0, 1) (repeat); non-finite s is the caller's business.
template <class T>
[[nodiscard]] inline T wrap_unit(T s) noexcept {
    const T f = s - std::floor(s);
    // s = −1e−30 wraps to 1 − 1e−30, which rounds to 1: keep it in the last texel, below 1.
    return f < T(1) ? f : T(1) - std::numeric_limits<T>::epsilon() / T(2);
}

/// i wrapped into [0, n) (repeat).
[[nodiscard]] constexpr int wrap_index(int i, int n) noexcept {
    const int r = i % n;
    return r < 0 ? r + n : r;
}

/// Samples a w × h texel grid given by `texel(x, y)` at normalised (s, t); see the top comment.
template <class T, class Texel>
[[nodiscard]] inline Color<T> filter_texels(int w, int h, T s, T t, Filter filter, const Texel& texel) noexcept {
    if (!std::isfinite(s) || !std::isfinite(t)) return texel(0, 0);
    s = wrap_unit(s);
    t = wrap_unit(t);
    if (filter == Filter::nearest) {
        const int x = static_cast<int>(s * T(w)); // s ≥ 0: truncation is floor(s·w)
        const int y = static_cast<int>(t * T(h));
        return texel(x < w ? x : w - 1, y < h ? y : h - 1); // s·w may round up to w
    }
    const T x = s * T(w) - T(0.5); // texel x is centred at x + 0.5
    const T y = t * T(h) - T(0.5);
    const T x0 = std::floor(x), y0 = std::floor(y);
    const T fx = x - x0, fy = y - y0;
    const int i0 = wrap_index(static_cast<int>(x0), w), i1 = wrap_index(static_cast<int>(x0) + 1, w);
    const int j0 = wrap_index(static_cast<int>(y0), h), j1 = wrap_index(static_cast<int>(y0) + 1, h);
    return (T(1) - fx) * (T(1) - fy) * texel(i0, j0) + fx * (T(1) - fy) * texel(i1, j0) +
           (T(1) - fx) * fy * texel(i0, j1) + fx * fy * texel(i1, j1);
}

} // namespace detail

/// A procedural checkerboard of squares_u × squares_v squares, colour `a` in the top-left square.
/// It samples like a squares_u × squares_v image, one texel per square; fewer than 1 square
/// counts as 1.
template <class T>
struct Checkerboard {
    static_assert(std::is_floating_point_v<T>, "isin::Checkerboard needs a floating-point type");
    Color<T> a, b;
    int squares_u = 8, squares_v = 8;

    /// Texels across and down: the number of squares, so that note_texel gives square coordinates.
    [[nodiscard]] T width() const noexcept { return T(columns()); }
    [[nodiscard]] T height() const noexcept { return T(rows()); }

    /// Colour of square (i, j), i across, j down from the top: a when i + j is even, else b.
    [[nodiscard]] Color<T> square(int i, int j) const noexcept { return parity(i, j) == 0 ? a : b; }

    /// The colour at normalised (s, t), repeating.
    [[nodiscard]] Color<T> sample(T s, T t, Filter filter) const noexcept {
        return detail::filter_texels(columns(), rows(), s, t, filter, [this](int i, int j) { return square(i, j); });
    }

private:
    [[nodiscard]] int columns() const noexcept { return squares_u > 0 ? squares_u : 1; }
    [[nodiscard]] int rows() const noexcept { return squares_v > 0 ? squares_v : 1; }
    [[nodiscard]] static int parity(int i, int j) noexcept {
        return (i % 2 + j % 2 + 4) % 2; // parity of i + j, also for negative i, j
    }
};

/// A texture made from an Image: texel = byte / 255 per channel (ColorEncoding::linear, the
/// note's convention and the default), or the sRGB curve decoded to linear intensities
/// (ColorEncoding::srgb: what photographs and painted textures hold; use it with
/// RenderOptions::encoding = srgb).
template <class T>
class ImageTexture {
    static_assert(std::is_floating_point_v<T>, "isin::ImageTexture needs a floating-point type");

public:
    /// Copies and converts `image`.
    explicit ImageTexture(const Image& image, ColorEncoding encoding = ColorEncoding::linear)
        : width_(image.width()), height_(image.height()), encoding_(encoding) {
        std::array<T, 256> value{}; // the 256 byte values decoded once
        for (int i = 0; i < 256; ++i)
            value[std::size_t(i)] = encoding == ColorEncoding::srgb ? srgb_to_linear(T(i) / T(255)) : T(i) / T(255);
        texels_.reserve(image.pixels().size());
        for (const Rgb8& p : image.pixels()) texels_.push_back({value[p.r], value[p.g], value[p.b]});
    }
    /// Loads a PNG, JPEG or PPM file via read_image; throws as read_image does.
    [[nodiscard]] static ImageTexture load(const std::string& path, const ReadLimits& limits = {},
                                           ColorEncoding encoding = ColorEncoding::linear) {
        return ImageTexture(read_image(path, limits), encoding);
    }
    /// How the bytes were decoded.
    [[nodiscard]] ColorEncoding encoding() const noexcept { return encoding_; }
    [[nodiscard]] T width() const noexcept { return T(width_); }
    [[nodiscard]] T height() const noexcept { return T(height_); }

    /// Texel (x, y), row 0 at the top; the caller guarantees 0 ≤ x < width, 0 ≤ y < height.
    [[nodiscard]] const Color<T>& texel(int x, int y) const noexcept {
        return texels_[std::size_t(y) * std::size_t(width_) + std::size_t(x)];
    }

    /// The colour at normalised (s, t), repeating; t = 0 is the top row.
    [[nodiscard]] Color<T> sample(T s, T t, Filter filter) const noexcept {
        return detail::filter_texels(width_, height_, s, t, filter, [this](int x, int y) { return texel(x, y); });
    }

private:
    int width_, height_;
    ColorEncoding encoding_;
    std::vector<Color<T>> texels_;
};

/// Any texture; a closed set, dispatched without virtual functions.
template <class T>
using Texture = std::variant<Checkerboard<T>, ImageTexture<T>>;

/// Samples whichever texture `texture` holds at normalised (s, t); black if it holds none
/// (valueless after a throwing assignment).
template <class T>
[[nodiscard]] Color<T> sample(const Texture<T>& texture, T s, T t, Filter filter) noexcept {
    if (texture.valueless_by_exception()) return {T(0), T(0), T(0)};
    return std::visit([&](const auto& tex) { return tex.sample(s, t, filter); }, texture);
}

} // namespace isin
