// The vectorised Möller–Trumbore batch agrees with the scalar test (§10), and scenes that use it.
#include <isin/batch.hpp>
#include <isin/scene.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <limits>
#include <random>
#include <vector>

TEST_CASE_TEMPLATE("§10 TriangleBatch: same nearest hit, u, v as scalar Möller–Trumbore", T, float, double) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (std::size_t n : {std::size_t(1), std::size_t(5), std::size_t(16), std::size_t(17), std::size_t(100)}) {
        std::vector<isin::Triangle<T>> tris;
        for (std::size_t i = 0; i < n; ++i) {
            const isin::Vertex<T> c{T(uni(rng) * 8), T(uni(rng) * 4.5), T(20 + uni(rng) * 5)};
            tris.push_back({c, c + T(4) * isin::Vertex<T>{T(uni(rng)), T(uni(rng)), T(uni(rng))},
                            c + T(4) * isin::Vertex<T>{T(uni(rng)), T(uni(rng)), T(uni(rng))}});
        }
        tris.push_back({{1, 1, 30}, {1, 1, 30}, {2, 2, 30}}); // zero area: never hit
        const isin::TriangleBatch<T> batch(tris);
        REQUIRE(batch.size() == n + 1);
        int hits = 0, agree = 0;
        for (int r = 0; r < 2000; ++r) {
            const isin::Ray<T> ray{{0, 0, 0}, isin::normalize(isin::Vertex<T>{T(uni(rng) * 8), T(uni(rng) * 4.5), 10})};
            std::size_t best = 0;
            isin::Hit<T> ref;
            for (std::size_t i = 0; i < tris.size(); ++i) {
                const auto h = isin::intersect_moller_trumbore(ray, tris[i]);
                if (h.t < ref.t) ref = h, best = i;
            }
            const auto got = batch.nearest(ray);
            CHECK(bool(got) == bool(ref));
            if (!ref || !got) continue;
            ++hits;
            agree += got.primitive == best && double(got.t) == approx(ref.t).epsilon(1e-5) &&
                     double(got.u) == approx(ref.u).epsilon(1e-4) && double(got.v) == approx(ref.v).epsilon(1e-4);
        }
        CAPTURE(n);
        CHECK(agree == hits);
        if (n >= 16) CHECK(hits > 100);
    }
}

TEST_CASE_TEMPLATE("TriangleBatch: t_max, each_hit, bad rays", T, float, double) {
    const std::vector<isin::Triangle<T>> tris{{{-1, -1, 10}, {1, -1, 10}, {0, 1, 10}},
                                              {{-1, -1, 20}, {1, -1, 20}, {0, 1, 20}}};
    const isin::TriangleBatch<T> batch(tris);
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    CHECK(batch.nearest(ray).primitive == 0);
    CHECK(batch.nearest(ray).t == approx(10));
    CHECK_FALSE(batch.nearest(ray, T(5)));
    std::vector<std::size_t> seen;
    batch.each_hit(ray, T(100), [&](std::size_t i, T) {
        seen.push_back(i);
        return true;
    });
    CHECK(seen == std::vector<std::size_t>{0, 1});
    seen.clear();
    batch.each_hit(ray, T(100), [&](std::size_t i, T) {
        seen.push_back(i);
        return false;
    });
    CHECK(seen.size() == 1);
    const T nan = std::numeric_limits<T>::quiet_NaN();
    CHECK_FALSE(batch.nearest(isin::Ray<T>{{nan, 0, 0}, {0, 0, 1}}));
    CHECK_FALSE(batch.nearest(isin::Ray<T>{{0, 0, 0}, {0, 0, 0}}));
    CHECK_FALSE(isin::TriangleBatch<T>{}.nearest(ray));
}

TEST_CASE_TEMPLATE("scene: batch and one-by-one triangle loops find the same hits", T, float, double) {
    isin::Scene<T, isin::Triangle> scene;
    const auto m = scene.add_material({});
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (int i = 0; i < 40; ++i) {
        const isin::Vertex<T> c{T(uni(rng) * 8), T(uni(rng) * 4.5), T(20 + uni(rng) * 5)};
        scene.add(isin::Triangle<T>{c, c + isin::Vertex<T>{T(uni(rng)), T(uni(rng)), 0},
                                    c + isin::Vertex<T>{T(uni(rng)), T(uni(rng)), T(uni(rng))}},
                  m);
    }
    scene.commit(); // 40 ≥ batch_min: the batch
    REQUIRE_FALSE(scene.template has_bvh<isin::Triangle<T>>());
    int differ = 0;
    for (int r = 0; r < 1000; ++r) {
        const isin::Ray<T> ray{{0, 0, 0}, isin::normalize(isin::Vertex<T>{T(uni(rng) * 8), T(uni(rng) * 4.5), 10})};
        scene.acceleration = isin::Acceleration::automatic;
        const auto a = scene.intersect(ray);
        const T ta = scene.transmittance(ray, T(100));
        scene.acceleration = isin::Acceleration::none;
        const auto b = scene.intersect(ray);
        const T tb = scene.transmittance(ray, T(100));
        differ += bool(a) != bool(b) || (a && a.primitive != b.primitive) || ta != tb;
    }
    CHECK(differ == 0);
}

TEST_CASE_TEMPLATE("TriangleBatch::reserve adds no triangle and loses none, before or after push_back", T, float,
                   double) {
    // Triangle i lies across the +Z axis at z = 10 + i.
    const auto across = [](int i) {
        const T z = T(10 + i);
        return isin::Triangle<T>{{-1, -1, z}, {1, -1, z}, {0, 1, z}};
    };
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    isin::TriangleBatch<T> batch;
    batch.reserve(100);
    CHECK(batch.empty());
    CHECK(batch.size() == 0);
    CHECK_FALSE(batch.nearest(ray));
    for (int i = 0; i < 3; ++i) batch.push_back(across(i));
    batch.reserve(1);   // below the size
    batch.reserve(200); // beyond what was reserved
    REQUIRE(batch.size() == 3);
    for (int i = 3; i < 40; ++i) batch.push_back(across(i)); // across block boundaries
    REQUIRE(batch.size() == 40);
    std::vector<std::size_t> seen;
    int wrong_t = 0;
    batch.each_hit(ray, T(100), [&](std::size_t i, T t) {
        seen.push_back(i);
        wrong_t += t != T(10) + T(i);
        return true;
    });
    REQUIRE(seen.size() == 40);
    for (std::size_t i = 0; i < seen.size(); ++i) CHECK(seen[i] == i);
    CHECK(wrong_t == 0);
    CHECK(batch.nearest(ray).primitive == 0);
    CHECK(batch.nearest(ray).t == T(10));
}
