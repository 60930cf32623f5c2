#pragma once
/// isin — 8-bit RGB images in memory: what render() returns and ImageTexture reads. Files (PNG,
/// JPEG, PPM) are image_io.hpp's.
///
/// Pixel (0,0) is the top-left corner, x grows to the right, y downwards, rows stored top first.
/// Bad sizes throw std::invalid_argument naming the value; at() throws std::out_of_range.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "color.hpp"

namespace isin {

static_assert(sizeof(Rgb8) == 3, "isin::Image hands its pixels to encoders as packed RGB bytes");

/// A width × height image of 8-bit RGB pixels, row 0 at the top.
class Image {
public:
    /// Largest accepted side, as for the camera: 32768.
    static constexpr int max_side = 1 << 15;

    /// An image filled with `fill`. Throws std::invalid_argument unless both sides are in
    /// [1, max_side]; the message names the bad value.
    Image(int width, int height, Rgb8 fill = {0, 0, 0})
        : width_(checked_side(width, "width")), height_(checked_side(height, "height")),
          pixels_(std::size_t(width_) * std::size_t(height_), fill) {}

    [[nodiscard]] int width() const noexcept { return width_; }
    [[nodiscard]] int height() const noexcept { return height_; }

    /// Pixel (x, y), checked: throws std::out_of_range unless 0 ≤ x < width and 0 ≤ y < height.
    [[nodiscard]] Rgb8& at(int x, int y) { return pixels_[checked_index(x, y)]; }
    [[nodiscard]] const Rgb8& at(int x, int y) const { return pixels_[checked_index(x, y)]; }

    /// Pixel (x, y), unchecked: the caller guarantees 0 ≤ x < width and 0 ≤ y < height.
    [[nodiscard]] Rgb8& operator()(int x, int y) noexcept { return pixels_[index(x, y)]; }
    [[nodiscard]] const Rgb8& operator()(int x, int y) const noexcept { return pixels_[index(x, y)]; }

    /// All width × height pixels, row by row from the top (pixel (x, y) at y·width + x).
    [[nodiscard]] Rgb8* data() noexcept { return pixels_.data(); }
    [[nodiscard]] const Rgb8* data() const noexcept { return pixels_.data(); }
    [[nodiscard]] const std::vector<Rgb8>& pixels() const noexcept { return pixels_; }

private:
    static int checked_side(int side, const char* what) {
        if (side < 1 || side > max_side)
            throw std::invalid_argument(std::string("isin::Image: ") + what + " " + std::to_string(side) +
                                        " is outside [1, " + std::to_string(max_side) + "]");
        return side;
    }
    [[nodiscard]] std::size_t index(int x, int y) const noexcept {
        return std::size_t(y) * std::size_t(width_) + std::size_t(x);
    }
    [[nodiscard]] std::size_t checked_index(int x, int y) const {
        if (x < 0 || x >= width_ || y < 0 || y >= height_)
            throw std::out_of_range("isin::Image::at: pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                    ") is outside the " + std::to_string(width_) + "×" + std::to_string(height_) +
                                    " image");
        return index(x, y);
    }

    int width_, height_;
    std::vector<Rgb8> pixels_;
};

/// The images one above the other, the first on top: the bands of a picture rendered apart
/// (render_rows) put back together. Throws std::invalid_argument if there are none, if their
/// widths differ, or if the heights add up to more than Image::max_side.
[[nodiscard]] inline Image stack_rows(const std::vector<Image>& bands) {
    if (bands.empty()) throw std::invalid_argument("isin::stack_rows: no images");
    long long height = 0;
    for (const Image& b : bands) {
        if (b.width() != bands[0].width())
            throw std::invalid_argument("isin::stack_rows: widths differ (" + std::to_string(bands[0].width()) +
                                        " and " + std::to_string(b.width()) + ")");
        height += b.height();
    }
    if (height > Image::max_side)
        throw std::invalid_argument("isin::stack_rows: " + std::to_string(height) + " rows in all, more than " +
                                    std::to_string(Image::max_side));
    Image out(bands[0].width(), int(height));
    Rgb8* at = out.data();
    for (const Image& b : bands)
        for (const Rgb8& p : b.pixels()) *at++ = p;
    return out;
}

} // namespace isin
