// Note §10: texel coordinates on a rectangle's two triangles; checkerboard and image textures.
#include <isin/image_io.hpp>
#include <isin/texture.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/temp_dir.hpp"

#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>

namespace {

template <class T>
void check_color(const isin::Color<T>& c, double r, double g, double b) {
    CHECK(c.r == approx(r));
    CHECK(c.g == approx(g));
    CHECK(c.b == approx(b));
}

/// 2×2 image, row 0 on top: red, green / blue, white.
isin::Image quad() {
    isin::Image image(2, 2);
    image(0, 0) = {255, 0, 0};
    image(1, 0) = {0, 255, 0};
    image(0, 1) = {0, 0, 255};
    image(1, 1) = {255, 255, 255};
    return image;
}

} // namespace

TEST_CASE_TEMPLATE("§10 note_texel: u = 0.25, v = 0.5 on 64×32 → (16, 16) and (48, 16)", T, float, double) {
    const auto first = isin::note_texel(T(0.25), T(0.5), T(64), T(32), false);
    CHECK(first[0] == T(16)); // §10: (u·w, v·h)
    CHECK(first[1] == T(16));
    const auto second = isin::note_texel(T(0.25), T(0.5), T(64), T(32), true);
    CHECK(second[0] == T(48)); // §10: ((1−u)·w, (1−v)·h)
    CHECK(second[1] == T(16));
    // The right-angle corner V0 is texel (0, 0) on the first triangle, (w, h) on the second.
    const auto c1 = isin::note_texel(T(0), T(0), T(64), T(32), false);
    const auto c2 = isin::note_texel(T(0), T(0), T(64), T(32), true);
    CHECK(c1 == std::array<T, 2>{0, 0});
    CHECK(c2 == std::array<T, 2>{64, 32});
    static_assert(isin::note_texel(T(1), T(1), T(2), T(2), false)[0] == T(2), "constexpr");
}

TEST_CASE_TEMPLATE("Checkerboard: a in square (0,0), alternating; width/height count squares", T, float, double) {
    const isin::Color<T> black{0, 0, 0}, white{1, 1, 1};
    const isin::Checkerboard<T> board{white, black, 4, 2};
    CHECK(board.width() == T(4));
    CHECK(board.height() == T(2));
    // Square (i, j) spans s ∈ [i/4, (i+1)/4), t ∈ [j/2, (j+1)/2); sample its middle.
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 4; ++i) {
            const T s = (T(i) + T(0.5)) / T(4), t = (T(j) + T(0.5)) / T(2);
            const auto expected = (i + j) % 2 == 0 ? white : black;
            CHECK(board.sample(s, t, isin::Filter::nearest) == expected);
            CHECK(board.sample(s, t, isin::Filter::bilinear) == expected); // a texel centre
            CHECK(board.square(i, j) == expected);
        }
    CHECK(board.square(-1, 0) == black);
    CHECK(board.square(-1, -1) == white);
    // note_texel with the board's size gives square coordinates: u = 0.6, v = 0.3 → (2.4, 0.6).
    const auto xy = isin::note_texel(T(0.6), T(0.3), board.width(), board.height(), false);
    CHECK(board.sample(xy[0] / board.width(), xy[1] / board.height(), isin::Filter::nearest) == white);
    // Halfway between two squares' centres, bilinear blends them equally.
    check_color(board.sample(T(0.25), T(0.25), isin::Filter::bilinear), 0.5, 0.5, 0.5);
    // Fewer than one square counts as one.
    const isin::Checkerboard<T> flat{white, black, 0, -2};
    CHECK(flat.width() == T(1));
    CHECK(flat.sample(T(0.9), T(0.7), isin::Filter::bilinear) == white);
}

TEST_CASE_TEMPLATE("ImageTexture 2×2: nearest picks the texel, bilinear averages at the centre", T, float, double) {
    const isin::ImageTexture<T> tex(quad());
    CHECK(tex.width() == T(2));
    CHECK(tex.height() == T(2));
    using isin::Filter;
    // Row 0 is the top, addressed by t = 0.
    check_color(tex.sample(T(0.1), T(0.1), Filter::nearest), 1, 0, 0);
    check_color(tex.sample(T(0.9), T(0.1), Filter::nearest), 0, 1, 0);
    check_color(tex.sample(T(0.1), T(0.9), Filter::nearest), 0, 0, 1);
    check_color(tex.sample(T(0.9), T(0.9), Filter::nearest), 1, 1, 1);
    check_color(tex.sample(T(0.49), T(0.51), Filter::nearest), 0, 0, 1);
    // Bilinear: exact at texel centres, the average of all four at the middle.
    check_color(tex.sample(T(0.25), T(0.25), Filter::bilinear), 1, 0, 0);
    check_color(tex.sample(T(0.75), T(0.75), Filter::bilinear), 1, 1, 1);
    check_color(tex.sample(T(0.5), T(0.5), Filter::bilinear), 0.5, 0.5, 0.5);
    check_color(tex.sample(T(0.5), T(0.25), Filter::bilinear), 0.5, 0.5, 0); // red–green midpoint
    check_color(tex.sample(T(0.375), T(0.25), Filter::bilinear), 0.75, 0.25, 0);
    // Bytes become linear colours: byte / 255, no gamma.
    const isin::ImageTexture<T> grey(isin::Image(1, 1, {51, 102, 255}));
    check_color(grey.sample(T(0.5), T(0.5), Filter::bilinear), 0.2, 0.4, 1);
    CHECK(tex.texel(1, 0) == isin::Color<T>{0, 1, 0});
}

TEST_CASE_TEMPLATE("Repeat wrapping: s = 1.25 and −0.75 read like 0.25; edges blend across", T, float, double) {
    const isin::ImageTexture<T> tex(quad());
    for (const auto f : {isin::Filter::nearest, isin::Filter::bilinear}) {
        CHECK(tex.sample(T(1.25), T(0.25), f) == tex.sample(T(0.25), T(0.25), f));
        CHECK(tex.sample(T(-0.75), T(0.25), f) == tex.sample(T(0.25), T(0.25), f));
        CHECK(tex.sample(T(0.25), T(-0.25), f) == tex.sample(T(0.25), T(0.75), f));
        CHECK(tex.sample(T(1000.75), T(3.25), f) == tex.sample(T(0.75), T(0.25), f));
    }
    // At s = 0 the nearest texel centres are the last column (wrapped) and the first.
    check_color(tex.sample(T(0), T(0.25), isin::Filter::bilinear), 0.5, 0.5, 0);
    check_color(tex.sample(T(0), T(0), isin::Filter::bilinear), 0.5, 0.5, 0.5);
    // A tiny negative s wraps to just below 1: the last column.
    check_color(tex.sample(T(-1e-30), T(0.25), isin::Filter::nearest), 0, 1, 0);
    const isin::Checkerboard<T> board{{1, 1, 1}, {0, 0, 0}, 2, 2};
    CHECK(board.sample(T(-0.25), T(0.25), isin::Filter::nearest) == isin::Color<T>{0, 0, 0});
}

TEST_CASE_TEMPLATE("NaN or infinite coordinates read texel (0, 0), for both filters", T, float, double) {
    const isin::ImageTexture<T> tex(quad());
    const isin::Checkerboard<T> board{{1, 0, 0}, {0, 0, 1}, 3, 3};
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    for (const auto f : {isin::Filter::nearest, isin::Filter::bilinear}) {
        CHECK(tex.sample(nan, T(0.9), f) == isin::Color<T>{1, 0, 0});
        CHECK(tex.sample(T(0.9), nan, f) == isin::Color<T>{1, 0, 0});
        CHECK(tex.sample(inf, -inf, f) == isin::Color<T>{1, 0, 0});
        CHECK(board.sample(nan, nan, f) == isin::Color<T>{1, 0, 0});
    }
}

TEST_CASE_TEMPLATE("Texture variant: sample() dispatches to whichever texture it holds", T, float, double) {
    const isin::Texture<T> board = isin::Checkerboard<T>{{1, 1, 1}, {0, 0, 0}, 2, 2};
    const isin::Texture<T> image = isin::ImageTexture<T>(quad());
    CHECK(isin::sample(board, T(0.75), T(0.25), isin::Filter::nearest) == isin::Color<T>{0, 0, 0});
    check_color(isin::sample(image, T(0.5), T(0.5), isin::Filter::bilinear), 0.5, 0.5, 0.5);
    static_assert(noexcept(isin::sample(board, T(0), T(0), isin::Filter::nearest)));
}

TEST_CASE_TEMPLATE("ImageTexture::load reads a file; a missing file throws naming it", T, float, double) {
    TempDir dir{"isin-test-texture-"};
    const std::string path = dir / "quad.ppm";
    isin::write_ppm(quad(), path);
    const auto tex = isin::ImageTexture<T>::load(path);
    check_color(tex.sample(T(0.25), T(0.75), isin::Filter::nearest), 0, 0, 1);
    const std::string missing = dir / "missing.png";
    std::string message;
    try {
        (void)isin::ImageTexture<T>::load(missing);
    } catch (const std::runtime_error& e) {
        message = e.what();
    }
    CHECK(message.find(missing) != std::string::npos);
}

TEST_CASE_TEMPLATE("Checkerboard: height counts rows, at least one; square's parity holds for any int i, j", T, float,
                   double) {
    const isin::Color<T> a{1, 0, 0}, b{0, 0, 1};
    CHECK(isin::Checkerboard<T>{a, b, 3, 5}.height() == T(5));
    CHECK(isin::Checkerboard<T>{a, b, 3, 0}.height() == T(1));
    CHECK(isin::Checkerboard<T>{a, b, -4, -7}.width() == T(1));
    CHECK(isin::Checkerboard<T>{a, b, -4, -7}.height() == T(1));
    const isin::Checkerboard<T> board{a, b, 3, 5};
    CHECK(board.square(-3, 1) == a);  // i + j = −2
    CHECK(board.square(-3, -4) == b); // −7
    CHECK(board.square(2, -5) == b);  // −3
    // i + j would overflow an int here (undefined; the sanitizer build would report it): the colour
    // still follows the parity of the true sum.
    constexpr int big = std::numeric_limits<int>::max(), small = std::numeric_limits<int>::min();
    CHECK(board.square(big, 1) == a);     // 2^31 is even
    CHECK(board.square(big, big) == a);   // 2^32 − 2
    CHECK(board.square(small, 0) == a);   // −2^31
    CHECK(board.square(small, big) == b); // −1
    CHECK(board.square(small, -1) == b);  // −2^31 − 1
    CHECK(board.square(small, small) == a);
    // 3 × 5 squares: t = 0.5 is row 2; s = 0.1 is column 0 (2 + 0 even: a), s = 0.5 column 1 (odd: b).
    CHECK(board.sample(T(0.1), T(0.5), isin::Filter::nearest) == a);
    CHECK(board.sample(T(0.5), T(0.5), isin::Filter::nearest) == b);
}
