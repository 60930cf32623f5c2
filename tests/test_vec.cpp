// Note §2: vector algebra, and §11a's normals.
#include <isin/vec.hpp>
#include <isin/triangle.hpp>

#include <doctest/doctest.h>

#include "approx.hpp"

#include <cmath>
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
