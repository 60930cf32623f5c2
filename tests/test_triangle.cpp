// Note §4 (area test), §5 (nearest of three triangles), §10 (Möller–Trumbore barycentrics).
#include <isin/triangle.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace {

template <class T>
isin::Triangle<T> note_triangle_2b() {
    return {{0, 40, 120}, {30, -40, 60}, {-30, -40, 60}};
}

// The three triangles of example 5a, in the note's order: red U, green Y, blue Z.
template <class T>
std::array<isin::Triangle<T>, 3> note_triangles_5a() {
    return {{{{0, 30, 40}, {40, -30, 120}, {-40, -30, 120}},
             {{-50, 30, 124}, {50, 30, 124}, {0, -30, 44}},
             {{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}}}};
}

// Every triangle test isin offers, by name, so each case runs through all of them.
template <class T>
isin::Hit<T> run(const std::string& method, const isin::Ray<T>& ray, const isin::Triangle<T>& tri) {
    if (method == "area (note eps 0.005)") return isin::intersect_area(ray, tri, T(0.005));
    if (method == "area (scale-relative)") return isin::intersect_area(ray, tri);
    return isin::intersect_moller_trumbore(ray, tri);
}

const std::array<std::string, 3> methods{"area (note eps 0.005)", "area (scale-relative)", "moller-trumbore"};

} // namespace

TEST_CASE_TEMPLATE("§4 example 4a: plane D = 72 (unit N) or 432000 (raw N), t = 90, R = (0,0,90)", T, float, double) {
    const auto tri = note_triangle_2b<T>();
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    const auto N = isin::normal(tri);
    const auto unit_N = isin::normalize(N);
    CHECK(isin::plane_offset(unit_N, tri.v0) == approx(72));
    CHECK(isin::plane_offset(N, tri.v0) == T(432000));
    CHECK(isin::ray_plane_t(ray, unit_N, isin::plane_offset(unit_N, tri.v0)) == approx(90)); // −72 / −0.8
    CHECK(isin::ray_plane_t(ray, N, isin::plane_offset(N, tri.v0)) == T(90));
    CHECK(ray.at(T(90)) == isin::Vertex<T>{0, 0, 90});
}

TEST_CASE_TEMPLATE("§4 example 4a: S = 6000, s1 = 1500, s2 = 1500, s3 = 3000 → inside", T, float, double) {
    const auto tri = note_triangle_2b<T>();
    const auto a = isin::area_terms(tri, isin::Vertex<T>{0, 0, 90});
    CHECK(a.S == approx(6000));
    CHECK(a.s1 == approx(1500));
    CHECK(a.s2 == approx(1500));
    CHECK(a.s3 == approx(3000));
    CHECK(std::fabs(a.S - (a.s1 + a.s2 + a.s3)) <= T(0.005));
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    for (const auto& m : methods) {
        CAPTURE(m);
        const auto hit = run(m, ray, tri);
        REQUIRE(hit);
        CHECK(hit.t == approx(90));
        CHECK(hit.u == approx(0.25)); // s1 / S
        CHECK(hit.v == approx(0.25)); // s2 / S
    }
}

TEST_CASE_TEMPLATE("§4 plane: t < 0 is behind the ray, N·Rd = 0 is parallel — both miss", T, float, double) {
    const auto tri = note_triangle_2b<T>();
    const isin::Ray<T> backwards{{0, 0, 0}, {0, 0, -1}};
    const isin::Ray<T> parallel{{0, 0, 0}, {1, 0, 0}}; // N = (0,3600,−4800): N·(1,0,0) = 0
    CHECK(std::isnan(isin::ray_plane_t(parallel, isin::normal(tri), T(432000))));
    CHECK(isin::ray_plane_t(backwards, isin::normal(tri), T(432000)) == T(-90));
    for (const auto& m : methods) {
        CAPTURE(m);
        CHECK_FALSE(run(m, backwards, tri));
        CHECK_FALSE(run(m, parallel, tri));
    }
}

TEST_CASE_TEMPLATE("§5 example 5a: t_U = 80, t_Y = 84, t_Z = 77 → the pixel is blue (Z)", T, float, double) {
    const auto tris = note_triangles_5a<T>();
    const isin::Ray<T> ray{{0, 0, 0}, isin::normalize(isin::Vertex<T>{0, 0, 10})};
    const std::array<T, 3> expected{80, 84, 77};
    for (const auto& m : methods) {
        CAPTURE(m);
        int nearest = -1;
        T nearest_t = std::numeric_limits<T>::infinity();
        for (int i = 0; i < 3; ++i) {
            const auto hit = run(m, ray, tris[size_t(i)]);
            REQUIRE(hit);
            CHECK(hit.t == approx(expected[size_t(i)]));
            if (hit.t < nearest_t) nearest_t = hit.t, nearest = i;
        }
        CHECK(nearest == 2); // blue Z
    }
}

TEST_CASE_TEMPLATE("§10 Möller–Trumbore barycentrics: P = V0 + u(V1−V0) + v(V2−V0)", T, float, double) {
    const auto tris = note_triangles_5a<T>();
    const T chosen[][2] = {{T(0.2), T(0.3)}, {T(0.6), T(0.1)}, {T(0.05), T(0.9)}, {T(0.33), T(0.33)}};
    for (const auto& tri : tris)
        for (const auto& uv : chosen) {
            const auto P = tri.v0 + uv[0] * (tri.v1 - tri.v0) + uv[1] * (tri.v2 - tri.v0);
            const isin::Ray<T> ray{{0, 0, 0}, isin::normalize(P)};
            const auto hit = isin::intersect_moller_trumbore(ray, tri);
            REQUIRE(hit);
            CHECK(hit.u == approx(uv[0]).epsilon(1e-4));
            CHECK(hit.v == approx(uv[1]).epsilon(1e-4));
            CHECK(hit.t == approx(isin::length(P)).epsilon(1e-5));
            // The area test's u = s1/S, v = s2/S are the same barycentrics.
            const auto area = isin::intersect_area(ray, tri);
            REQUIRE(area);
            CHECK(area.u == approx(uv[0]).epsilon(1e-3));
            CHECK(area.v == approx(uv[1]).epsilon(1e-3));
        }
}

TEST_CASE_TEMPLATE("§11 Möller–Trumbore backface culling keeps clockwise (front) faces only", T, float, double) {
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    for (const auto& tri : note_triangles_5a<T>()) {
        const isin::Triangle<T> flipped{tri.v0, tri.v2, tri.v1};
        const bool front = isin::dot(isin::normal(tri), ray.direction) < T(0);
        CHECK(bool(isin::intersect_moller_trumbore(ray, tri, true)) == front);
        CHECK(bool(isin::intersect_moller_trumbore(ray, flipped, true)) == !front);
        CHECK(isin::intersect_moller_trumbore(ray, tri));
        CHECK(isin::intersect_moller_trumbore(ray, flipped));
    }
}

// Example 4a's triangle scaled by `scale` about the origin, and rays from the origin at the centroid
// and at a point 1% of the triangle's size outside the edge V1V2.
TEST_CASE_TEMPLATE("§4 stability: scale-relative area test and MT work from size 1e-3 to 1e5", T, float, double) {
    for (T scale : {T(1e-5), T(1e-3), T(1), T(1e3)}) { // triangle sides 1e-3 … 1e5
        CAPTURE(scale);
        const auto base = note_triangle_2b<T>();
        const isin::Triangle<T> tri{base.v0 * scale, base.v1 * scale, base.v2 * scale};
        const auto centroid = (tri.v0 + tri.v1 + tri.v2) / T(3);
        const auto edge_mid = (tri.v1 + tri.v2) / T(2);
        const auto outside = edge_mid + (edge_mid - centroid) * T(0.03);
        const isin::Ray<T> in{{0, 0, 0}, isin::normalize(centroid)};
        const isin::Ray<T> out{{0, 0, 0}, isin::normalize(outside)};
        CHECK(isin::intersect_area(in, tri));
        CHECK_FALSE(isin::intersect_area(out, tri));
        CHECK(isin::intersect_moller_trumbore(in, tri));
        CHECK_FALSE(isin::intersect_moller_trumbore(out, tri));
    }
}

TEST_CASE_TEMPLATE("§4 known failure: the note's absolute ε = 0.005 swallows tiny triangles' "
                   "neighbourhoods",
                   T, float, double) {
    // A triangle of side ~1e-3 at z ≈ 0.1: a ray aimed a whole triangle-width outside an edge still
    // satisfies |S − Σs| ≤ 0.005, because every area is ~1e-6. The scale-relative default misses.
    const auto base = note_triangle_2b<T>();
    const T scale = T(1e-5);
    const isin::Triangle<T> tri{base.v0 * scale, base.v1 * scale, base.v2 * scale};
    const auto centroid = (tri.v0 + tri.v1 + tri.v2) / T(3);
    const auto far_outside = centroid + (tri.v1 - tri.v0) * T(2);
    const isin::Ray<T> ray{{0, 0, 0}, isin::normalize(far_outside)};
    CHECK(isin::intersect_area(ray, tri, T(0.005))); // documented false hit
    CHECK_FALSE(isin::intersect_area(ray, tri));
    CHECK_FALSE(isin::intersect_moller_trumbore(ray, tri));
}

TEST_CASE_TEMPLATE("bad input: NaN/inf rays, zero directions and degenerate triangles miss", T, float, double) {
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    const auto good = note_triangle_2b<T>();
    const isin::Ray<T> ok{{0, 0, 0}, {0, 0, 1}};
    const isin::Ray<T> bad_rays[] = {
        {{nan, 0, 0}, {0, 0, 1}}, {{0, 0, 0}, {0, nan, 1}}, {{0, 0, inf}, {0, 0, 1}},
        {{0, 0, 0}, {0, 0, inf}}, {{0, 0, 0}, {0, 0, 0}},   {{-inf, 0, 0}, {1, 0, 1}},
    };
    const isin::Triangle<T> bad_tris[] = {
        {{1, 1, 50}, {1, 1, 50}, {1, 1, 50}},      // a point
        {{-1, -1, 50}, {1, 1, 50}, {3, 3, 50}},    // collinear, through the ray
        {{0, -1, 40}, {0, 0, 50}, {0, 2, 70}},     // collinear, in a plane of the ray
        {{-1, -1, 50}, {1, -1, 50}, {1, 1, 50}},   // good …
        {{-1, -1, nan}, {1, -1, 50}, {1, 1, 50}},  // … with a NaN vertex
        {{-inf, -1, 50}, {1, -1, 50}, {1, 1, 50}}, // … with an infinite vertex
    };
    const isin::Ray<T> forward{{0, 0, 0}, {0, 0, 1}};
    for (const auto& m : methods) {
        CAPTURE(m);
        REQUIRE(run(m, ok, good));
        for (const auto& ray : bad_rays) CHECK_FALSE(run(m, ray, good));
        for (size_t i = 0; i < std::size(bad_tris); ++i) {
            CAPTURE(i);
            if (i == 3)
                CHECK(run(m, forward, bad_tris[i]));
            else
                CHECK_FALSE(run(m, forward, bad_tris[i]));
        }
    }
}
