// The BVH agrees with a brute-force loop over the watertight test, stays watertight through
// traversal, and handles axis-parallel directions, −0.0, NaN and degenerate input.
#include <isin/bvh.hpp>

#include <doctest/doctest.h>

#include "approx.hpp"
#include "../benchmarks/workloads.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace {

template <class T>
isin::BvhHit<T> brute_force(const std::vector<isin::Triangle<T>>& tris, const isin::Ray<T>& ray,
                            T t_max = std::numeric_limits<T>::infinity()) {
    isin::BvhHit<T> best;
    best.t = t_max;
    for (std::size_t i = 0; i < tris.size(); ++i) {
        const auto h = isin::intersect_watertight(ray, tris[i]);
        if (h.t < best.t) best = {h.t, h.u, h.v, std::uint32_t(i)};
    }
    return best.t < t_max ? best : isin::BvhHit<T>{};
}

template <class T>
std::vector<isin::Triangle<T>> random_soup(int n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<isin::Triangle<T>> tris;
    for (int i = 0; i < n; ++i) {
        const isin::Vertex<double> c{uni(rng) * 10, uni(rng) * 10, uni(rng) * 10};
        auto p = [&](double s) { return isin::Vertex<T>{T(c.x + s * uni(rng)), T(c.y + s * uni(rng)), T(c.z + s * uni(rng))}; };
        tris.push_back({p(0.8), p(0.8), p(0.8)});
    }
    return tris;
}

} // namespace

TEST_CASE_TEMPLATE("BVH: nearest hit and any-hit agree with the brute-force watertight loop", T, float,
                   double) {
    for (int n : {1, 7, 8, 9, 100, 3000}) {
        CAPTURE(n);
        const auto tris = random_soup<T>(n, std::uint64_t(n));
        const isin::Bvh<T> bvh{tris};
        CHECK(bvh.size() == tris.size());
        std::mt19937_64 rng(99);
        std::uniform_real_distribution<double> uni(-1.0, 1.0);
        int hits = 0, mismatches = 0;
        for (int r = 0; r < 2000; ++r) {
            const isin::Ray<T> ray{{T(uni(rng) * 15), T(uni(rng) * 15), T(-20)},
                                   isin::normalize(isin::Vertex<T>{T(uni(rng) * 0.5), T(uni(rng) * 0.5), 1})};
            const auto a = bvh.intersect(ray), b = brute_force(tris, ray);
            hits += bool(b);
            // The BVH's 8-lane kernel rounds differently from the scalar test (t to ~1 ulp); a
            // different triangle is fine only at the same t (a tie at a shared edge).
            const bool same_t = a && b && std::fabs(double(a.t) - double(b.t)) <= 1e-5 * double(b.t);
            if (bool(a) != bool(b) || (a && (!same_t))) ++mismatches;
            if (a && b && a.primitive == b.primitive) {
                CHECK(a.u == approx(b.u).epsilon(1e-4));
                CHECK(a.v == approx(b.v).epsilon(1e-4));
            }
            const T limit = b ? b.t * T(1.001) : T(100); // just past the nearest hit
            CHECK(bvh.occluded(ray, limit) == bool(brute_force(tris, ray, limit)));
        }
        CHECK(mismatches == 0);
        if (n >= 100) CHECK(hits > 20);
    }
}

TEST_CASE_TEMPLATE("BVH: rays at the shared edges and vertices of a closed mesh never leak", T, float,
                   double) {
    for (const auto& m : {workloads::closed_sphere_edges<T>(3000), workloads::grid_edges<T>(3000)}) {
        const isin::Bvh<T> bvh{m.mesh};
        int leaks = 0;
        for (const auto& ray : m.rays) {
            const auto h = bvh.intersect(ray);
            leaks += !h || std::fabs(double(h.t) - workloads::mesh_ray_distance) > 1e-3 * workloads::mesh_ray_distance;
        }
        CHECK(leaks == 0);
    }
}

TEST_CASE_TEMPLATE("BVH: axis-parallel directions, −0.0, rays from inside boxes and on planes", T,
                   float, double) {
    // A grid of unit squares in z = 5 (front faces towards −z) and one wall x = 3.
    std::vector<isin::Triangle<T>> tris;
    for (int j = -4; j < 4; ++j)
        for (int i = -4; i < 4; ++i) {
            const T x = T(i), y = T(j);
            tris.push_back({{x, y, 5}, {x, y + 1, 5}, {x + 1, y, 5}});
            tris.push_back({{x + 1, y, 5}, {x, y + 1, 5}, {x + 1, y + 1, 5}});
        }
    tris.push_back({{3, -10, -10}, {3, 10, -10}, {3, 0, 10}});
    const isin::Bvh<T> bvh{tris};
    const T nz = -T(0);
    for (const isin::Vertex<T>& d : {isin::Vertex<T>{0, 0, 1}, isin::Vertex<T>{nz, 0, 1}, isin::Vertex<T>{0, nz, 1},
                                     isin::Vertex<T>{nz, nz, 1}}) {
        for (T x : {T(-3.5), T(0), T(0.5), T(1)})      // x = 0 and 1 lie on box planes and edges
            for (T y : {T(-2.25), T(0), T(2)}) {
                const isin::Ray<T> ray{{x, y, 0}, d};
                const auto h = bvh.intersect(ray);
                REQUIRE(h);
                CHECK(h.t == approx(5));
                CHECK(h.t == approx(brute_force(tris, ray).t).epsilon(1e-6));
            }
    }
    // Along +x from inside the grid's box: hits the wall at x = 3.
    const auto wall = bvh.intersect(isin::Ray<T>{{0, 0, 1}, {1, 0, 0}});
    REQUIRE(wall);
    CHECK(wall.t == approx(3));
    CHECK(wall.primitive == 128);
    // Along −z and +y from in front of the grid: nothing there.
    CHECK_FALSE(bvh.intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, -1}}));
    CHECK_FALSE(bvh.intersect(isin::Ray<T>{{-3.5, 0, 0}, {0, 1, nz}}));
    // t_max: the grid at t = 5 is beyond 4.
    CHECK_FALSE(bvh.intersect(isin::Ray<T>{{0.5, 0.5, 0}, {0, 0, 1}}, T(4)));
    CHECK_FALSE(bvh.occluded(isin::Ray<T>{{0.5, 0.5, 0}, {0, 0, 1}}, T(4)));
    CHECK(bvh.occluded(isin::Ray<T>{{0.5, 0.5, 0}, {0, 0, 1}}, T(6)));
}

TEST_CASE_TEMPLATE("BVH: bad rays and bad triangles are defined misses", T, float, double) {
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    std::vector<isin::Triangle<T>> tris{{{0, 0, 5}, {0, 1, 5}, {1, 0, 5}},     // good: index 0
                                        {{1, 1, 5}, {1, 1, 5}, {2, 2, 5}},     // zero area
                                        {{nan, 0, 5}, {0, 1, 5}, {1, 0, 5}},   // NaN
                                        {{0, 0, inf}, {0, 1, 5}, {1, 0, 5}},   // infinite
                                        {{0, 0, 7}, {0, 1, 7}, {1, 0, 7}}};    // good: index 4
    const isin::Bvh<T> bvh{tris};
    CHECK(bvh.size() == 2);
    const auto h = bvh.intersect(isin::Ray<T>{{T(0.2), T(0.2), 0}, {0, 0, 1}});
    REQUIRE(h);
    CHECK(h.primitive == 0);
    CHECK(h.t == approx(5));
    for (const isin::Ray<T>& ray : {isin::Ray<T>{{nan, 0, 0}, {0, 0, 1}}, isin::Ray<T>{{0, 0, 0}, {0, 0, 0}},
                                    isin::Ray<T>{{0, 0, 0}, {nan, 0, 1}}, isin::Ray<T>{{0, 0, -inf}, {0, 0, 1}}}) {
        CHECK_FALSE(bvh.intersect(ray));
        CHECK_FALSE(bvh.occluded(ray, T(100)));
    }
    const isin::Bvh<T> empty{std::vector<isin::Triangle<T>>{}};
    CHECK(empty.size() == 0);
    CHECK_FALSE(empty.intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}));
    CHECK_FALSE(empty.occluded(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}, T(10)));
}

TEST_CASE("BVH: one-thread and multi-thread builds give the same answers") {
    const auto tris = random_soup<float>(200000, 5);
    isin::BvhOptions one;
    one.threads = 1;
    isin::BvhOptions many;
    many.threads = 4;
    const isin::Bvh<float> a{tris, one}, b{tris, many};
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    int differ = 0;
    for (int r = 0; r < 2000; ++r) {
        const isin::Ray<float> ray{{float(uni(rng) * 15), float(uni(rng) * 15), -20.0f},
                                   isin::normalize(isin::Vertex<float>{float(uni(rng) * 0.5), float(uni(rng) * 0.5), 1})};
        const auto x = a.intersect(ray), y = b.intersect(ray);
        differ += x.t != y.t; // same triangles, same kernel: the same t (the tree may differ)
    }
    CHECK(differ == 0);
}

TEST_CASE_TEMPLATE("BVH build: a box grown by an empty box (an empty bin) is unchanged", T, float, double) {
    // Regression: growing by the corners of an empty box (lo = +inf, hi = -inf) made the box
    // infinite, so every SAH cost after an empty bin was infinite and good splits were skipped.
    isin::detail::Box<T> box;
    box.grow(isin::Vertex<T>{1, 2, 3});
    box.grow(isin::Vertex<T>{4, 5, 6});
    const T area = box.half_area();
    box.grow(isin::detail::Box<T>{});
    CHECK(box.lo.x == T(1));
    CHECK(box.hi.z == T(6));
    CHECK(box.half_area() == area);
    isin::detail::Box<T> empty;
    empty.grow(box);
    CHECK(empty.half_area() == area);
}
