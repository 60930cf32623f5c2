// Note §7 (Phong: ambient, diffuse, specular) and §8 (refraction by Snell's law).
#include <isin/shading.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <vector>

TEST_CASE_TEMPLATE("§7 example 7a: L = (0,0.8,−0.6), coefficient 0.8, red (255,0,0) → (204,0,0)", T, float, double) {
    const isin::Vertex<T> light{0, 40, 0}, N{0, 1, 0}, P{0, 0, 30};
    const auto L = isin::normalize(light - P);
    CHECK(L.x == approx(0));
    CHECK(L.y == approx(0.8));
    CHECK(L.z == approx(-0.6));
    CHECK(isin::diffuse_coefficient(N, L) == approx(0.8));
    const auto red = isin::from_rgb8<T>(255, 0, 0);
    CHECK(isin::to_rgb8(isin::diffuse(N, L, red)) == isin::Rgb8{204, 0, 0});
}

TEST_CASE_TEMPLATE("§7 diffuse: a surface facing away from the light is unlit (coefficient 0)", T, float, double) {
    const isin::Vertex<T> N{0, -1, 0};
    const auto L = isin::normalize(isin::Vertex<T>{0, 40, -30});
    CHECK(isin::dot(N, L) == approx(-0.8));
    CHECK(isin::diffuse_coefficient(N, L) == T(0));
    CHECK(isin::to_rgb8(isin::diffuse(N, L, isin::from_rgb8<T>(255, 0, 0))) == isin::Rgb8{0, 0, 0});
}

// By hand: light (0,40,0), N = (0,1,0), P = (0,0,30) as in 7a, eye at (0,30,60).
// L = (0,0.8,−0.6); d = −L = (0,−0.8,0.6); Rf = d − 2(d·N)N = (0,0.8,0.6);
// V = normalize((0,30,60) − P) = (0,1,1)/√2; cos = (0.8 + 0.6)/√2 = 0.98994949;
// shininess 10: 0.98994949^10 = 0.90392080.
TEST_CASE_TEMPLATE("§7 specular by hand: Rf = (0,0.8,0.6), cos = 1.4/√2, cos^10 = 0.9039208", T, float, double) {
    const isin::Vertex<T> N{0, 1, 0}, P{0, 0, 30};
    const auto L = isin::normalize(isin::Vertex<T>{0, 40, 0} - P);
    const auto V = isin::normalize(isin::Vertex<T>{0, 30, 60} - P);
    const auto Rf = isin::reflect(-L, N);
    CHECK(Rf.y == approx(0.8));
    CHECK(Rf.z == approx(0.6));
    CHECK(isin::specular_coefficient(N, L, V, T(10)) == approx(0.9039208).epsilon(1e-5));
    // Seen from the eye at the origin the mirror direction points away: no highlight (cos < 0).
    const auto V0 = isin::normalize(isin::Vertex<T>{0, 0, 0} - P);
    CHECK(isin::dot(Rf, V0) == approx(-0.6));
    CHECK(isin::specular_coefficient(N, L, V0, T(10)) == T(0));
}

TEST_CASE_TEMPLATE("§7 ambient: object colour × coefficient", T, float, double) {
    const auto c = isin::ambient(isin::from_rgb8<T>(255, 100, 0), T(0.2));
    CHECK(isin::to_rgb8(c) == isin::Rgb8{51, 20, 0});
}

TEST_CASE_TEMPLATE("§7 Phong: ka·ambient + kd·diffuse + ks·specular with ka + kd + ks = 1", T, float, double) {
    isin::Material<T> m;
    m.color = isin::from_rgb8<T>(255, 0, 0);
    m.ka = T(0.1), m.kd = T(0.6), m.ks = T(0.3), m.shininess = T(10);
    CHECK(m.ka + m.kd + m.ks == approx(1));
    const isin::Vertex<T> N{0, 1, 0}, P{0, 0, 30};
    const auto L = isin::normalize(isin::Vertex<T>{0, 40, 0} - P);
    const auto V = isin::normalize(isin::Vertex<T>{0, 30, 60} - P);
    const isin::Color<T> white{1, 1, 1};
    const auto lit = isin::ambient(m.color, m.ka) + isin::phong_light(m, m.color, N, L, V, white);
    // red: 0.1 + 0.6·0.8 + 0.3·0.9039208 = 0.8511762; green, blue: 0.3·0.9039208 = 0.2711762
    CHECK(lit.r == approx(0.8511762).epsilon(1e-5));
    CHECK(lit.g == approx(0.2711762).epsilon(1e-5));
    CHECK(lit.b == approx(0.2711762).epsilon(1e-5));
    // A coloured light tints diffuse and specular alike.
    const auto blue_light = isin::phong_light(m, m.color, N, L, V, isin::Color<T>{0, 0, 1});
    CHECK(blue_light.r == T(0));
    CHECK(blue_light.b == approx(0.2711762).epsilon(1e-5));
    // Facing away from the light: no diffuse and no specular.
    CHECK(isin::phong_light(m, m.color, -N, L, V, white) == isin::Color<T>{0, 0, 0});
}

TEST_CASE_TEMPLATE("§8 refraction by Snell's law: n1 sin θ1 = n2 sin θ2, total internal reflection", T, float, double) {
    const isin::Vertex<T> n{0, 1, 0};
    // Normal incidence goes straight through.
    const auto straight = isin::refract(isin::Vertex<T>{0, -1, 0}, n, T(1) / T(1.5));
    REQUIRE(straight);
    CHECK(straight->y == approx(-1));
    // 45° from air into glass (1.5): sin θ2 = sin 45° / 1.5 = 0.47140452.
    const auto d = isin::normalize(isin::Vertex<T>{1, -1, 0});
    const auto into_glass = isin::refract(d, n, T(1) / T(1.5));
    REQUIRE(into_glass);
    CHECK(isin::length(*into_glass) == approx(1));
    CHECK(into_glass->x == approx(0.47140452));
    CHECK(into_glass->y < T(0));
    // From glass to air at 45°: 1.5 · sin 45° = 1.06 > 1 → total internal reflection.
    CHECK_FALSE(isin::refract(d, n, T(1.5)));
    // The critical angle is asin(1/1.5): sin θ1 = 0.7 lies past it, 0.66 just inside.
    const T past = T(0.7), inside = T(0.66);
    CHECK_FALSE(isin::refract(isin::Vertex<T>{past, -std::sqrt(1 - past * past), 0}, n, T(1.5)));
    CHECK(isin::refract(isin::Vertex<T>{inside, -std::sqrt(1 - inside * inside), 0}, n, T(1.5)));
}

TEST_CASE_TEMPLATE("to_byte: [0,1] to 0…255 rounded to nearest; out of range clamps; NaN is 0", T, float, double) {
    CHECK(isin::to_byte(T(0)) == 0);
    CHECK(isin::to_byte(T(1)) == 255);
    CHECK(isin::to_byte(T(0.5)) == 128); // 127.5 rounds up
    CHECK(isin::to_byte(T(0.8)) == 204); // example 7a's red × 0.8
    for (int i = 0; i <= 255; ++i) {
        CAPTURE(i);
        CHECK(int(isin::to_byte(T(i) / T(255))) == i); // every byte survives from_rgb8's / 255
        CHECK(int(isin::to_byte((T(i) - T(0.45)) / T(255))) == (i > 0 ? i : 0));
        CHECK(int(isin::to_byte((T(i) + T(0.45)) / T(255))) == i);
        if (i < 255) CHECK(int(isin::to_byte((T(i) + T(0.55)) / T(255))) == i + 1);
    }
    CHECK(isin::to_byte(T(1) - std::numeric_limits<T>::epsilon()) == 255);
    CHECK(isin::to_byte(std::numeric_limits<T>::denorm_min()) == 0);
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(isin::to_byte(T(-0.3)) == 0);
    CHECK(isin::to_byte(-inf) == 0);
    CHECK(isin::to_byte(T(1.7)) == 255);
    CHECK(isin::to_byte(T(1e30)) == 255);
    CHECK(isin::to_byte(inf) == 255);
    CHECK(isin::to_byte(nan) == 0);
    CHECK(isin::to_byte(-nan) == 0);
    CHECK(isin::to_rgb8(isin::Color<T>{T(0.5), T(2), nan}) == isin::Rgb8{128, 255, 0});
}

TEST_CASE_TEMPLATE("to_bytes gives to_byte's bytes, a register of channels at a time, for any count", T, float,
                   double) {
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    std::vector<T> values = {T(0),
                             -T(0),
                             T(1),
                             T(0.5),
                             T(0.8),
                             T(-0.3),
                             T(1.7),
                             T(1e30),
                             inf,
                             -inf,
                             nan,
                             -nan,
                             std::numeric_limits<T>::denorm_min(),
                             std::numeric_limits<T>::min(),
                             T(1) - std::numeric_limits<T>::epsilon(),
                             T(1) + std::numeric_limits<T>::epsilon()};
    for (int i = 0; i <= 256; ++i) { // where c·255 + 0.5 is an integer, and the values beside it
        const T edge = (T(i) - T(0.5)) / T(255);
        T below = edge, above = edge;
        for (int step = 0; step < 4; ++step) {
            below = std::nextafter(below, -inf), above = std::nextafter(above, inf);
            values.push_back(below), values.push_back(above);
        }
        values.push_back(edge), values.push_back(T(i) / T(255));
    }
    std::mt19937 rng(11);
    std::uniform_real_distribution<T> near(T(-0.1), T(1.1));
    std::uniform_int_distribution<std::uint64_t> any_bits;
    for (int i = 0; i < 20000; ++i) values.push_back(near(rng));
    for (int i = 0; i < 2000; ++i) {
        const std::uint64_t bits = any_bits(rng);
        T x;
        std::memcpy(&x, &bits, sizeof x); // any T, NaNs and infinities among them
        values.push_back(x);
    }
    for (const std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(7), std::size_t(15), std::size_t(16),
                                std::size_t(17), std::size_t(33), values.size()}) {
        CAPTURE(n);
        const std::size_t size = (n * sizeof(T) + 63) / 64 * 64 + 64; // to_bytes reads 64-byte aligned values
        const std::unique_ptr<T, decltype(&std::free)> in(static_cast<T*>(std::aligned_alloc(64, size)), &std::free);
        REQUIRE(in);
        std::copy(values.begin(), values.begin() + std::ptrdiff_t(n), in.get());
        std::vector<std::uint8_t> out(n + 1, 77); // one byte past the count, which must stay
        isin::to_bytes(in.get(), n, out.data());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < n; ++i) differ += out[i] != isin::to_byte(in.get()[i]);
        CHECK(differ == 0);
        CHECK(out[n] == 77);
    }
}

TEST_CASE_TEMPLATE("§7 specular_power is std::pow bit for bit, also where cos^shininess underflows (no pow there)", T,
                   float, double) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<T> exponent(T(-160), T(0)), shine(T(0), T(400));
    const T tiny = std::numeric_limits<T>::denorm_min();
    int same = 0, zeros = 0, subnormal = 0, n = 0;
    const auto check = [&](T c, T s) {
        const T want = c > T(0) ? std::pow(c, s) : T(0), got = isin::specular_power(c, s);
        same += std::memcmp(&want, &got, sizeof got) == 0, ++n;
        zeros += got == T(0) && c > T(0);
        subnormal += got > T(0) && got < std::numeric_limits<T>::min();
    };
    for (int i = 0; i < 200000; ++i) check(std::exp2(exponent(rng)), shine(rng));
    // around the shortcut's edge: c^s near the smallest subnormal and a quarter of it
    const T edge = T(std::numeric_limits<T>::min_exponent - std::numeric_limits<T>::digits); // log2 of denorm_min
    for (int i = 0; i < 20000; ++i) {
        const T s = T(1) + shine(rng), target = edge + T(4) * (exponent(rng) / T(160) + T(0.5)); // ±2 around it
        check(std::exp2(target / s), s);
    }
    for (const T c : {tiny, T(2) * tiny, std::numeric_limits<T>::min(), T(0.5), T(1), T(0), -T(0.5)})
        for (const T s :
             {T(0), T(1), T(2), T(40), std::numeric_limits<T>::infinity(), std::numeric_limits<T>::quiet_NaN()})
            check(c, s);
    CHECK(same == n);
    CHECK(zeros > 1000); // the shortcut's cases were met, and pow's subnormal results beside them
    CHECK(subnormal > 100);
}
