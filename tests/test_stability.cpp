// Stability where methods fail (issue 4): the workloads of benchmarks/accuracy_vs_speed, with the
// behaviour each method is documented to have pinned down — guarantees (watertight never leaks,
// isin's sphere test never self-intersects) and known failures (the note's absolute ε), so that
// a change that silently fixes or worsens either is noticed. CI builds this file with g++ and
// clang++, at -O0 and at -O3 -march=native: the guarantees must hold under any FMA contraction.
#include <isin/isin.hpp>

#include <doctest/doctest.h>

#include "common/workloads.hpp"
#include "approx.hpp"

#include <cmath>
#include <limits>
#include <type_traits>

namespace {

// Rays aimed at shared edges and vertices of a closed mesh from the front: how many find no
// triangle at the aimed-at distance (leak).
template <class T, class Test>
int leaks(const workloads::MeshCase<T>& m, Test test) {
    int n = 0;
    for (const auto& ray : m.rays) {
        bool found = false;
        for (const auto& tri : m.mesh) {
            const auto h = test(ray, tri);
            if (h && std::fabs(double(h.t) - workloads::mesh_ray_distance) <= 1e-3 * workloads::mesh_ray_distance) {
                found = true;
                break;
            }
        }
        n += !found;
    }
    return n;
}

struct Errors {
    int false_hits = 0, false_misses = 0, n = 0;
};

// Judged by construction (aimed inside or outside with a 5% margin): only where T can represent
// the geometry to far better than that margin.
template <class T, class Test>
Errors judge(const std::vector<workloads::TriangleCase<T>>& cases, Test test) {
    Errors e;
    for (const auto& c : cases) {
        const bool hit = bool(test(c.ray, c.tri));
        ++e.n;
        e.false_hits += hit && c.expect == workloads::Expect::miss;
        e.false_misses += !hit && c.expect == workloads::Expect::hit;
    }
    return e;
}

template <class T>
isin::Hit<T> watertight(const isin::Ray<T>& r, const isin::Triangle<T>& t) {
    return isin::intersect_watertight(r, t);
}
template <class T>
isin::Hit<T> moller_trumbore(const isin::Ray<T>& r, const isin::Triangle<T>& t) {
    return isin::intersect_moller_trumbore(r, t);
}
template <class T>
isin::Hit<T> area_relative(const isin::Ray<T>& r, const isin::Triangle<T>& t) {
    return isin::intersect_area(r, t);
}
template <class T>
isin::Hit<T> area_note(const isin::Ray<T>& r, const isin::Triangle<T>& t) {
    return isin::intersect_area(r, t, T(0.005));
}

// isin's exact-at-any-scale triangle tests, for the loops below.
template <class T>
using TriangleTest = isin::Hit<T> (*)(const isin::Ray<T>&, const isin::Triangle<T>&);
template <class T>
const TriangleTest<T> exact_tests[] = {watertight<T>, moller_trumbore<T>, area_relative<T>};

} // namespace

TEST_CASE_TEMPLATE("stability, edges: the watertight test never leaks on a closed mesh", T, float, double) {
    const auto sphere = workloads::closed_sphere_edges<T>(1500);
    const auto grid = workloads::grid_edges<T>(1500);
    CHECK(leaks(sphere, watertight<T>) == 0);
    CHECK(leaks(grid, watertight<T>) == 0);
    // isin's scale-relative area test does not leak either (its tolerance is a hair wide).
    CHECK(leaks(sphere, area_relative<T>) == 0);
    CHECK(leaks(grid, area_relative<T>) == 0);
}

TEST_CASE_TEMPLATE("stability, edges: Möller–Trumbore leaks through shared edges (known failure)", T, float, double) {
    // Measured: about 19% of rays aimed exactly at edges and vertices find no triangle, in float
    // and double, with g++ and clang++. Pinned to a band so a change in either direction shows.
    const auto sphere = workloads::closed_sphere_edges<T>(1500);
    const double rate = double(leaks(sphere, moller_trumbore<T>)) / 1500.0;
    MESSAGE("Möller–Trumbore leak rate on the closed sphere: " << rate);
    CHECK(rate > 0.05);
    CHECK(rate < 0.40);
}

TEST_CASE_TEMPLATE("stability, restart: isin's sphere test never self-intersects, r = 1e-3…1e6", T, float, double) {
    for (double r : {1e-3, 1e-1, 1e1, 1e3, 1e6})
        for (double offset : {0.0, 1e3, 1e6}) {
            if (offset * double(std::numeric_limits<T>::epsilon()) > 1e-3 * r) continue; // not representable
            CAPTURE(r);
            CAPTURE(offset);
            int self_hits = 0, missed_exits = 0;
            for (const auto& c : workloads::sphere_restarts<T>(r, offset, 500)) {
                self_hits += bool(isin::intersect(c.outward, c.sphere));
                missed_exits += !isin::intersect(c.inward, c.sphere);
            }
            CHECK(self_hits == 0);
            CHECK(missed_exits == 0);
        }
}

TEST_CASE_TEMPLATE("stability, restart: the note's sphere test and its +0.001 fix (known failures)", T, float, double) {
    struct Count {
        int self_hits = 0, bad_exits = 0;
    };
    auto count = [](double r, T margin) {
        Count c;
        for (const auto& k : workloads::sphere_restarts<T>(r, 0.0, 500)) {
            c.self_hits += bool(isin::intersect_note(k.outward, k.sphere, margin));
            const auto exit = isin::intersect_note(k.inward, k.sphere, margin);
            c.bad_exits += !exit || double(exit.t) < 1e-3 * r; // no far side, or t ≈ 0 instead
        }
        return c;
    };
    // As written: restarted rays, outward and inward alike, are misread about half the time.
    const Count plain = count(1.0, T(0));
    CHECK(plain.self_hits > 100);
    CHECK(plain.bad_exits > 100);
    // The fix reads an on-surface origin as inside: right for the refracted (inward) ray the
    // note meant it for, at r = 1 and at r = 1e-3 …
    CHECK(count(1.0, T(0.001)).bad_exits == 0);
    CHECK(count(1e-3, T(0.001)).bad_exits == 0);
    // … wrong for the reflected (outward) ray, which then hits its own sphere at t ≈ 0 …
    CHECK(count(1.0, T(0.001)).self_hits > 100);
    // … useless in float from r = 1e3, where 0.001 is below the rounding of l2 …
    if (std::is_same_v<T, float>)
        CHECK(count(1e3, T(0.001)).bad_exits > 100);
    else
        CHECK(count(1e3, T(0.001)).bad_exits == 0);
    // … and for small spheres 0.001 is a band hundreds of radii thick: a ray from 2r away counts
    // as starting inside and reports the far side.
    const isin::Sphere<T> tiny{{0, 0, T(0.002)}, T(0.001)};
    const isin::Ray<T> from_outside{{0, 0, 0}, {0, 0, 1}};
    CHECK(isin::intersect_note(from_outside, tiny, T(0.001)).t == approx(0.003));
    CHECK(isin::intersect_note(from_outside, tiny).t == approx(0.001));
    CHECK(isin::intersect(from_outside, tiny).t == approx(0.001));
}

TEST_CASE_TEMPLATE("stability, scale: isin's tests are exact from 1e-4 to 1e6 in size, 1e7 away", T, float, double) {
    for (double size : {1e-4, 1e-2, 1.0, 1e2, 1e4, 1e6}) {
        CAPTURE(size);
        const auto cases = workloads::scaled<T>(size, 0.0, 1000);
        for (auto test : exact_tests<T>) {
            const auto e = judge(cases, test);
            CHECK(e.false_hits == 0);
            CHECK(e.false_misses == 0);
        }
    }
    // Far from the origin, while the precision still places a unit triangle to 1e-3 of its size.
    for (double offset : {1.0, 1e3, 1e5, 1e7}) {
        if (offset * double(std::numeric_limits<T>::epsilon()) > 1e-3) continue;
        CAPTURE(offset);
        const auto cases = workloads::scaled<T>(1.0, offset, 1000);
        for (auto test : exact_tests<T>) {
            const auto e = judge(cases, test);
            CHECK(e.false_hits == 0);
            CHECK(e.false_misses == 0);
        }
    }
}

TEST_CASE_TEMPLATE("stability, scale: the note's absolute ε = 0.005 fails on small triangles, and "
                   "in float on large ones (known failure)",
                   T, float, double) {
    // Small: every ray aimed 5% outside a triangle of size 1e-4 or 1e-2 is accepted (the whole
    // neighbourhood lies within ε). Size 1 is where ε = 0.005 was chosen: no error.
    for (double size : {1e-4, 1e-2}) {
        const auto e = judge(workloads::scaled<T>(size, 0.0, 1000), area_note<T>);
        CHECK(e.false_hits == 500);
    }
    const auto fine = judge(workloads::scaled<T>(1.0, 0.0, 1000), area_note<T>);
    CHECK(fine.false_hits + fine.false_misses == 0);
    // Large: in float the areas' rounding exceeds 0.005 and about half the hits are lost; in
    // double (16 digits) the note's ε still holds at size 1e6.
    const auto large = judge(workloads::scaled<T>(1e4, 0.0, 1000), area_note<T>);
    if (std::is_same_v<T, float>) {
        CHECK(large.false_misses > 100);
    } else {
        CHECK(large.false_misses == 0);
    }
}

TEST_CASE_TEMPLATE("stability, grazing: rays down to 1e-7 rad off the plane still hit", T, double) {
    for (double angle : {1e-1, 1e-3, 1e-5, 1e-7}) {
        CAPTURE(angle);
        const auto cases = workloads::grazing<T>(angle, 1000);
        for (auto test : exact_tests<T>) CHECK(judge(cases, test).false_misses == 0);
    }
}
