// Baldwin & Weber's precomputed-transform ray–triangle test: the note's worked examples through it,
// its transform, barycentrics, two-sidedness and bad input.
#include <isin/baldwin_weber.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <limits>

TEST_CASE_TEMPLATE("Baldwin–Weber: the transform maps V0, V1, V2 to (u, v, w) = (0,0,0), (1,0,0), (0,1,0)", T, float,
                   double) {
    const isin::Triangle<T> tri{{0, 40, 120}, {30, -40, 60}, {-30, -40, 60}}; // §2's triangle
    const auto bw = isin::baldwin_weber_transform(tri);
    const auto uvw = [&](const isin::Vertex<T>& p) {
        return isin::Vertex<T>{isin::dot(bw.row_u, p) + bw.off_u, isin::dot(bw.row_v, p) + bw.off_v,
                               isin::dot(bw.row_w, p) + bw.off_w};
    };
    const isin::Vertex<T> corners[3][2] = {{tri.v0, {0, 0, 0}}, {tri.v1, {1, 0, 0}}, {tri.v2, {0, 1, 0}}};
    for (const auto& c : corners) {
        const auto got = uvw(c[0]);
        CHECK(double(got.x) == approx(double(c[1].x)).scale(1).epsilon(1e-5));
        CHECK(double(got.y) == approx(double(c[1].y)).scale(1).epsilon(1e-5));
        CHECK(double(got.z) == approx(double(c[1].z)).scale(1).epsilon(1e-5));
    }
    // A zero-area triangle gets the all-zero transform: every ray misses.
    const auto flat = isin::baldwin_weber_transform(isin::Triangle<T>{{0, 0, 5}, {1, 1, 5}, {2, 2, 5}});
    CHECK(flat.row_w.x == T(0));
    CHECK_FALSE(isin::intersect_baldwin_weber(isin::Ray<T>{{1, 1, 0}, {0, 0, 1}}, flat));
}

TEST_CASE_TEMPLATE("Baldwin–Weber §4/§5: example 4a hits at t = 90, example 5a's nearest is blue Z at 77", T, float,
                   double) {
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    const auto h = isin::intersect_baldwin_weber(ray, isin::Triangle<T>{{0, 40, 120}, {30, -40, 60}, {-30, -40, 60}});
    REQUIRE(h);
    CHECK(h.t == approx(90));
    const isin::Triangle<T> U{{0, 30, 40}, {40, -30, 120}, {-40, -30, 120}},
        Y{{-50, 30, 124}, {50, 30, 124}, {0, -30, 44}}, Z{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}};
    CHECK(isin::intersect_baldwin_weber(ray, U).t == approx(80));
    CHECK(isin::intersect_baldwin_weber(ray, Y).t == approx(84));
    CHECK(isin::intersect_baldwin_weber(ray, Z).t == approx(77));
}

TEST_CASE_TEMPLATE("Baldwin–Weber: barycentrics as Möller–Trumbore's, both sides, misses outside and behind", T, float,
                   double) {
    const isin::Triangle<T> tri{{-1, -1, 10}, {2, -1, 12}, {-1, 3, 9}};
    const auto bw = isin::baldwin_weber_transform(tri);
    for (const T u : {T(0.1), T(0.3)})
        for (const T v : {T(0.2), T(0.5)}) {
            const isin::Vertex<T> p = tri.v0 + u * (tri.v1 - tri.v0) + v * (tri.v2 - tri.v0);
            const isin::Ray<T> front{{0, 0, 0}, p}, back{{0, 0, 30}, p - isin::Vertex<T>{0, 0, 30}};
            for (const auto& ray : {front, back}) { // two-sided
                const auto h = isin::intersect_baldwin_weber(ray, bw);
                const auto mt = isin::intersect_moller_trumbore(ray, tri);
                REQUIRE(h);
                CHECK(h.t == approx(mt.t).epsilon(1e-4));
                CHECK(h.u == approx(u).epsilon(1e-4));
                CHECK(h.v == approx(v).epsilon(1e-4));
            }
        }
    CHECK_FALSE(isin::intersect_baldwin_weber(isin::Ray<T>{{5, 5, 0}, {0, 0, 1}}, bw));  // outside
    CHECK_FALSE(isin::intersect_baldwin_weber(isin::Ray<T>{{0, 0, 20}, {0, 0, 1}}, bw)); // behind
    const T nan = std::numeric_limits<T>::quiet_NaN();
    CHECK_FALSE(isin::intersect_baldwin_weber(isin::Ray<T>{{nan, 0, 0}, {0, 0, 1}}, bw));
    CHECK_FALSE(isin::intersect_baldwin_weber(isin::Ray<T>{{0, 0, 0}, {0, 0, 0}}, bw));
    CHECK_FALSE(isin::intersect_baldwin_weber(isin::Ray<T>{{0, 0, 0}, {1, 0, 0}}, bw)); // parallel to nothing it meets
}
