// Note §2: vector algebra, and §11a's normals.
#include <isin/vec.hpp>
#include <isin/triangle.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <cmath>
#include <cstring>
#include <limits>

template <class T>
static void check_vertex(const isin::Vertex<T>& a, T x, T y, T z) {
    CHECK(a.x == approx(x));
    CHECK(a.y == approx(y));
    CHECK(a.z == approx(z));
}

TEST_CASE_TEMPLATE("§2 operators: + − (binary, unary), V·s, s·V, V/s", T, float, double) {
    const isin::Vertex<T> a{1, 2, 3}, b{4, -5, 6};
    CHECK(a + b == isin::Vertex<T>{5, -3, 9});
    CHECK(a - b == isin::Vertex<T>{-3, 7, -3});
    CHECK(-a == isin::Vertex<T>{-1, -2, -3});
    CHECK(+a == a);
    CHECK(a * T(2) == isin::Vertex<T>{2, 4, 6});
    CHECK(T(2) * a == isin::Vertex<T>{2, 4, 6});
    CHECK(b / T(2) == isin::Vertex<T>{2, T(-2.5), 3});
    isin::Vertex<T> c = a;
    c += b;
    c -= a;
    c *= T(3);
    c /= T(3);
    CHECK(c == b);
}

TEST_CASE_TEMPLATE("§2 dot and cross products, left-handed frame", T, float, double) {
    const isin::Vertex<T> x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
    CHECK(isin::cross(x, y) == z); // +X × +Y = +Z (forward)
    CHECK(isin::cross(y, z) == x);
    CHECK(isin::cross(z, x) == y);
    CHECK(isin::dot(isin::Vertex<T>{1, 2, 3}, isin::Vertex<T>{4, -5, 6}) == T(12));
    CHECK(isin::cross(isin::Vertex<T>{1, 2, 3}, isin::Vertex<T>{4, -5, 6}) == isin::Vertex<T>{27, 6, -13});
}

TEST_CASE_TEMPLATE("§2 example 2a: |(0,6,8)| = 10, normalized (0, 0.6, 0.8) of length 1", T, float, double) {
    const isin::Vertex<T> R{0, 6, 8};
    CHECK(isin::length(R) == T(10));
    const auto n = isin::normalize(R);
    check_vertex(n, T(0), T(0.6), T(0.8));
    CHECK(isin::length(n) == approx(1));
}

TEST_CASE_TEMPLATE("§2 example 2b: triangle normal N = (0,3600,−4800), unit (0,0.6,−0.8)", T, float, double) {
    const isin::Triangle<T> tri{{0, 40, 120}, {30, -40, 60}, {-30, -40, 60}};
    CHECK(tri.v1 - tri.v0 == isin::Vertex<T>{30, -80, -60});
    CHECK(tri.v2 - tri.v0 == isin::Vertex<T>{-30, -80, -60});
    const auto N = isin::normal(tri);
    CHECK(N == isin::Vertex<T>{0, 3600, -4800});
    check_vertex(isin::normalize(N), T(0), T(0.6), T(-0.8));
}

TEST_CASE_TEMPLATE("§11 example 11a: vertex order flips the normal (0,6400,0) ↔ (0,−6400,0)", T, float, double) {
    const isin::Triangle<T> first{{0, 0, 40}, {40, 0, -40}, {-40, 0, -40}};
    const isin::Triangle<T> reordered{{40, 0, -40}, {0, 0, 40}, {-40, 0, -40}};
    CHECK(isin::normal(first) == isin::Vertex<T>{0, 6400, 0});
    CHECK(isin::normalize(isin::normal(first)) == isin::Vertex<T>{0, 1, 0});
    CHECK(isin::normal(reordered) == isin::Vertex<T>{0, -6400, 0});
    CHECK(isin::normalize(isin::normal(reordered)) == isin::Vertex<T>{0, -1, 0});
}

TEST_CASE_TEMPLATE("§8 reflect: d − 2(d·n)n mirrors about the normal", T, float, double) {
    const isin::Vertex<T> d = isin::normalize(isin::Vertex<T>{1, -1, 0});
    const auto r = isin::reflect(d, isin::Vertex<T>{0, 1, 0});
    check_vertex(r, d.x, -d.y, T(0));
    CHECK(isin::length(r) == approx(1));
}

TEST_CASE_TEMPLATE("§2 bad input: normalize of zero, infinite or NaN vectors is (0,0,0)", T, float, double) {
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    const isin::Vertex<T> zero{0, 0, 0};
    CHECK(isin::normalize(zero) == zero);
    CHECK(isin::normalize(isin::Vertex<T>{inf, 0, 0}) == zero);
    CHECK(isin::normalize(isin::Vertex<T>{nan, 1, 0}) == zero);
    CHECK_FALSE(isin::is_finite(isin::Vertex<T>{1, nan, 0}));
    CHECK(isin::is_finite(isin::Vertex<T>{1, 2, 3}));
}

TEST_CASE("§2 the vector algebra is usable in constant expressions") {
    constexpr isin::Vec3d a{1, 2, 3}, b{4, 5, 6};
    static_assert(isin::dot(a, b) == 32.0);
    static_assert(isin::cross(a, b) == isin::Vec3d{-3, 6, -3});
    static_assert(isin::reflect(isin::Vec3d{0, -1, 0}, isin::Vec3d{0, 1, 0}) == isin::Vec3d{0, 1, 0});
    CHECK(true);
}

namespace {

/// a·b − c·d = 1 exactly, with c·d just above a half-ulp point: rounded alone it becomes larger
/// than a·b (found by search; every factor and product is an integer, exact in T's significand).
template <class T>
struct CancellingProducts;
template <>
struct CancellingProducts<float> {
    static constexpr float a = 11013, b = 13724, c = 12289, d = 12299; // a·b = 151142412 (ulp 8)
};
template <>
struct CancellingProducts<double> {
    static constexpr double a = 201313046, b = 201341453, c = 201327891, d = 201326607; // ulp 8
};

/// x rounded to T and stored, so that the compiler cannot fuse it into a later addition.
template <class T>
T stored(T x) {
    volatile T v = x;
    return v;
}

} // namespace

TEST_CASE_TEMPLATE("difference_of_products: a·b − c·d on ordinary values", T, float, double) {
    CHECK(isin::difference_of_products(T(3), T(4), T(2), T(5)) == T(2));
    CHECK(isin::difference_of_products(T(2), T(5), T(3), T(4)) == T(-2));
    CHECK(isin::difference_of_products(T(-3), T(4), T(2), T(-5)) == T(-2));
    CHECK(isin::difference_of_products(T(1.5), T(-2), T(0), T(7)) == T(-3));
    CHECK(isin::difference_of_products(T(0.1), T(0.3), T(0.2), T(0.7)) == approx(0.03 - 0.14));
    // §2 example 2b: z of E1 × E2 = 30·(−80) − (−80)·(−30) = −4800.
    CHECK(isin::difference_of_products(T(30), T(-80), T(-80), T(-30)) == T(-4800));
}

TEST_CASE_TEMPLATE("difference_of_products: exact sign where a fused or a plain a·b − c·d gets it wrong", T, float,
                   double) {
    using P = CancellingProducts<T>;
    const T a = P::a, b = P::b, c = P::c, d = P::d;
    // The traps: a compiler that fuses a·b − c·d into fma(a, b, −round(c·d)) gets −2 or −4 (wrong
    // sign); one that rounds both products gets 0 or −4 (the difference cancelled away).
    REQUIRE(std::fma(a, b, -stored(c * d)) < T(0));
    REQUIRE(stored(a * b) - stored(c * d) <= T(0));
    CHECK(isin::difference_of_products(a, b, c, d) == T(1));
    CHECK(isin::difference_of_products(c, d, a, b) == T(-1));
    CHECK(isin::difference_of_products(b, a, d, c) == T(1));
    // Equal products: exactly 0, where a fused form leaves the rounding error of a·a.
    const T x = T(1) + std::ldexp(T(1), -(std::numeric_limits<T>::digits / 2 + 1));
    REQUIRE(std::fma(x, x, -stored(x * x)) != T(0));
    CHECK(isin::difference_of_products(x, x, x, x) == T(0));
    // 1 + 2^-k squared minus (1 + 2^-(k-1)): the 2^-2k that rounding a·b alone would lose.
    const T h = x - T(1);
    CHECK(isin::difference_of_products(x, x, T(1) + T(2) * h, T(1)) == h * h);
}

TEST_CASE_TEMPLATE("lane_difference_of_products: Kahan's algorithm, the same bits in every lane form", T, float,
                   double) {
    using P = CancellingProducts<T>;
    const T x = T(1) + std::ldexp(T(1), -(std::numeric_limits<T>::digits / 2 + 1));
    // a, b, c, d lane by lane: the cancelling products, equal products, zeros of either sign,
    // ordinary values, an overflowing product.
    const T big = std::numeric_limits<T>::max();
    const T a[8] = {P::a, P::c, x, T(-0.0), T(0), T(0.1), T(30), big};
    const T b[8] = {P::b, P::d, x, T(1), T(1), T(0.3), T(-80), T(2)};
    const T c[8] = {P::c, P::a, x, T(0), T(-0.0), T(0.2), T(-80), T(1)};
    const T d[8] = {P::d, P::b, x, T(1), T(1), T(0.7), T(-30), T(1)};
    T one[8];
    for (int k = 0; k < 8; ++k) one[k] = isin::detail::lane_difference_of_products(a[k], b[k], c[k], d[k]);
    CHECK(one[0] == T(1)); // the exact sign where a plain or fused form gets it wrong
    CHECK(one[1] == T(-1));
    CHECK(one[2] == T(0));
    CHECK(one[3] == T(0));
    CHECK(one[4] == T(0));
    CHECK(one[6] == T(-4800));
    CHECK(!std::isfinite(one[7]));
    if constexpr (std::is_same_v<T, double>) { // the double form is difference_of_products' own
        for (int k = 0; k < 8; ++k) {
            const T reference = isin::difference_of_products(a[k], b[k], c[k], d[k]);
            CHECK(std::memcmp(&one[k], &reference, sizeof(T)) == 0);
        }
    }
#if defined(__AVX2__) && defined(__FMA__) && !defined(ISIN_FORCE_PURE)
    T lanes[8];
    if constexpr (std::is_same_v<T, float>) {
        _mm256_storeu_ps(lanes, isin::detail::lane_difference_of_products(_mm256_loadu_ps(a), _mm256_loadu_ps(b),
                                                                          _mm256_loadu_ps(c), _mm256_loadu_ps(d)));
    } else {
        for (int h = 0; h < 8; h += 4)
            _mm256_storeu_pd(lanes + h,
                             isin::detail::lane_difference_of_products(_mm256_loadu_pd(a + h), _mm256_loadu_pd(b + h),
                                                                       _mm256_loadu_pd(c + h), _mm256_loadu_pd(d + h)));
    }
    for (int k = 0; k < 8; ++k) CHECK(std::memcmp(&lanes[k], &one[k], sizeof(T)) == 0);
#if defined(__AVX512F__)
    if constexpr (std::is_same_v<T, float>) {
        alignas(64) T a16[16], b16[16], c16[16], d16[16], wide[16];
        for (int k = 0; k < 16; ++k) a16[k] = a[k % 8], b16[k] = b[k % 8], c16[k] = c[k % 8], d16[k] = d[k % 8];
        _mm512_store_ps(wide, isin::detail::lane_difference_of_products(_mm512_load_ps(a16), _mm512_load_ps(b16),
                                                                        _mm512_load_ps(c16), _mm512_load_ps(d16)));
        for (int k = 0; k < 16; ++k) CHECK(std::memcmp(&wide[k], &one[k % 8], sizeof(T)) == 0);
    }
#endif
#endif
}

TEST_CASE_TEMPLATE("max_of: the larger of two values; a NaN in either is the result", T, float, double) {
    CHECK(isin::max_of(T(2), T(3)) == T(3));
    CHECK(isin::max_of(T(3), T(2)) == T(3));
    CHECK(isin::max_of(T(-1), T(-5)) == T(-1));
    CHECK(isin::max_of(T(-7), T(-7)) == T(-7));
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(isin::max_of(T(1), inf) == inf);
    CHECK(isin::max_of(-inf, T(1)) == T(1));
    CHECK(std::isnan(isin::max_of(T(4), nan)));
    CHECK(std::isnan(isin::max_of(nan, T(4))));
    CHECK(std::isnan(isin::max_of(nan, -inf)));
    static_assert(isin::max_of(T(1), T(2)) == T(2), "constexpr");
}

TEST_CASE_TEMPLATE("max_abs: the largest |component|, whichever component holds it", T, float, double) {
    CHECK(isin::max_abs(isin::Vertex<T>{-7, 3, 5}) == T(7));
    CHECK(isin::max_abs(isin::Vertex<T>{1, -2, T(0.5)}) == T(2));
    CHECK(isin::max_abs(isin::Vertex<T>{0, 0, -9}) == T(9));
    CHECK(isin::max_abs(isin::Vertex<T>{0, 0, 0}) == T(0));
    CHECK(isin::max_abs(isin::Vertex<T>{T(-0.0), 0, 0}) == T(0));
    const T inf = std::numeric_limits<T>::infinity();
    CHECK(isin::max_abs(isin::Vertex<T>{1, -inf, 2}) == inf);
    const T nan = std::numeric_limits<T>::quiet_NaN(); // NaN wherever it is: the magnitude is unknown
    CHECK(std::isnan(isin::max_abs(isin::Vertex<T>{nan, 1, 2})));
    CHECK(std::isnan(isin::max_abs(isin::Vertex<T>{1, nan, 2})));
    CHECK(std::isnan(isin::max_abs(isin::Vertex<T>{1, 2, nan})));
    CHECK(isin::max_abs(isin::Vertex<T>{T(1e30), T(-1e-30), T(3)}) == T(1e30));
}
