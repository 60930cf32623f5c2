// Stability where methods fail (issue 4): the workloads of benchmarks/accuracy_vs_speed (and of
// benchmarks/offsets for secondary rays, issue 15), with the behaviour each method is documented
// to have pinned down — guarantees (watertight never leaks, isin's sphere test never
// self-intersects) and known failures (the note's absolute ε), so that a change that silently
// fixes or worsens either is noticed. CI builds this file with g++ and clang++, at -O0 and at
// -O3 -march=native: the guarantees must hold under any FMA contraction.
#include <isin/isin.hpp>

#include <doctest/doctest.h>

#include "support/workloads.hpp"
#include "support/secondary.hpp"
#include "support/approx.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

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

// Secondary rays (issue 15): the workloads of tests/support/secondary.hpp — a trefoil knot and a
// bumpy icosphere through a Bvh, spheres with pebbles; s = 1e-3…1e3, 0…1e6 from the origin, eyes
// 4…1000 radii away — with the first 1000 of benchmarks/offsets' 2000 primary rays per case.
namespace {

using workloads::Offset;

constexpr int offset_primaries = 1000;

// Every case T can represent, evaluated once per precision (all the offset tests share them).
template <class T>
const std::vector<workloads::CaseResult>& offset_results() {
    static const std::vector<workloads::CaseResult> results = [] {
        std::vector<workloads::CaseResult> r;
        for (const auto& c : workloads::secondary_cases())
            if (workloads::representable<T>(c)) r.push_back(workloads::evaluate<T>(c, offset_primaries));
        return r;
    }();
    return results;
}

std::string describe(const workloads::CaseResult& r) {
    char text[128];
    std::snprintf(text, sizeof text, "%s, size %s, D = %g, eye %g radii, %s", workloads::scene_name(r.c.scene),
                  r.c.size_label.c_str(), r.c.distance, r.c.eye, r.precision);
    return text;
}

// A sphere case outside the study's list (the examples of issue 15).
template <class T>
workloads::CaseResult sphere_case(double r, double distance, double eye) {
    char label[32];
    std::snprintf(label, sizeof label, "%g", r);
    return workloads::evaluate<T>({workloads::Scene::spheres, r, distance, eye, label}, offset_primaries);
}

// Whether a sphere case's large sphere is at least 64 float ulps of its distance wide.
bool wide_in_float(const workloads::SecondaryCase& c) {
    return 2 * c.size >= 64 * workloads::float_ulp(c.distance) * (1 - 1e-12);
}

double refraction_failure_rate(const workloads::OffsetStats& s) {
    return double(s.refraction_failures + s.refraction_entry_hits) / double(s.refracted_rays);
}

} // namespace

TEST_CASE_TEMPLATE("stability, offsets: error_bound never self-hits, on every workload", T, float, double) {
    // Issue 15's goal. With the normal taken from the hit point, normalize(P − C) with P rounded at
    // |C|, float failed it on 4 sphere cases (5 reflected rays from pebbles 8–30 float ulps wide hit
    // at grazing angles: the normal was off by ~ulp(|C|)/r, the eye seemed behind the surface);
    // hit_point and normal_at(ray, sphere, hit) now work from (Ro − C) + t·Rd, as pbrt-v4 works in
    // the sphere's object space.
    for (const auto& r : offset_results<T>()) {
        CAPTURE(describe(r));
        const auto& e = r[Offset::error_bound];
        CHECK(r.primaries > offset_primaries / 2);
        CHECK(e.shadow_self_hits == 0);
        CHECK(e.reflection_self_hits == 0);
        CHECK(e.refraction_entry_hits == 0);
        // the reference it is measured against: pbrt-v4's rule, re-implemented
        CHECK(r[Offset::pbrt_v4].self_hits() == 0);
    }
}

TEST_CASE_TEMPLATE("stability, offsets: error_bound loses no more shadow occlusions than pbrt-v4", T, float, double) {
    long eb = 0, pbrt = 0, blocked = 0;
    for (const auto& r : offset_results<T>()) {
        CAPTURE(describe(r));
        CHECK(r[Offset::error_bound].lost_occlusions <= r[Offset::pbrt_v4].lost_occlusions);
        eb += r[Offset::error_bound].lost_occlusions, pbrt += r[Offset::pbrt_v4].lost_occlusions;
        blocked += r[Offset::error_bound].reference_occluded;
    }
    MESSAGE("lost occlusions of " << blocked << " blocked shadow rays: error_bound " << eb << ", pbrt_v4 " << pbrt);
    CHECK(blocked > 1000); // the workloads do shadow
}

TEST_CASE_TEMPLATE("stability, offsets: error_bound's offsets are within 2x of pbrt-v4's (median)", T, float, double) {
    double lo = 1e300, hi = 0;
    for (const auto& r : offset_results<T>()) {
        CAPTURE(describe(r));
        const double eb = r[Offset::error_bound].median_offset, pbrt = r[Offset::pbrt_v4].median_offset;
        CHECK(eb <= 2 * pbrt);
        CHECK(eb >= 0.5 * pbrt);
        lo = std::min(lo, eb / pbrt), hi = std::max(hi, eb / pbrt);
    }
    MESSAGE("median offset, error_bound / pbrt_v4: " << lo << " … " << hi);
}

TEST_CASE_TEMPLATE("stability, offsets: error_bound refracts through spheres >= 64 float ulps wide, up to 1e6 away", T,
                   float, double) {
    int cases = 0;
    for (const auto& r : offset_results<T>()) {
        if (r.c.scene != workloads::Scene::spheres || (std::is_same_v<T, float> && !wide_in_float(r.c))) continue;
        CAPTURE(describe(r));
        const auto& e = r[Offset::error_bound];
        CHECK(e.refracted_rays > 100);
        CHECK(e.refraction_failures == 0);
        CHECK(e.refraction_entry_hits == 0);
        ++cases;
    }
    CHECK(cases >= 30);
    // issue 15's examples: r = 0.01 at 1e3 (328 float ulps wide), r = 10 at 1e6 (320)
    for (double eye : {4.0, 100.0}) {
        CAPTURE(eye);
        for (const auto& r : {sphere_case<T>(0.01, 1e3, eye), sphere_case<T>(10, 1e6, eye)}) {
            CAPTURE(describe(r));
            CHECK(r[Offset::error_bound].refraction_failures + r[Offset::error_bound].refraction_entry_hits == 0);
        }
    }
}

TEST_CASE_TEMPLATE("stability, offsets: isin's sphere test restarts raw from hit_point (known: tiny pebbles)", T, float,
                   double) {
    // Restarting a ray at isin::hit_point itself, with no offset, is what the sphere test's
    // on-surface band is made for: 0 self-hits in double; in float, grazing rays on the scenes'
    // pebbles (8–30 float ulps wide) do self-hit: the point is rounded at |C| to a good part of the
    // radius, and the direction, from the ray's normal, may point into the pebble as seen from it
    // (measured 36 of ~78,000 rays). Offset origins (error_bound) have none there. Refraction is
    // always right. Triangles have no such band: raw barycentric points self-hit ~25-33% of rays.
    long self = 0;
    for (const auto& r : offset_results<T>()) {
        if (r.c.scene != workloads::Scene::spheres) continue;
        CAPTURE(describe(r));
        const auto& h = r[Offset::hit_point];
        CHECK(h.refraction_failures + h.refraction_entry_hits == 0);
        self += h.self_hits();
    }
    MESSAGE("self-hits of rays restarted at hit_point on spheres: " << self);
    CHECK(self <= (std::is_same_v<T, float> ? 100 : 0));
}

TEST_CASE_TEMPLATE("stability, offsets: the old fixed rule, and raw restarts (known failures)", T, float, double) {
    constexpr bool is_float = std::is_same_v<T, float>;
    long fixed_lost = 0, eb_lost = 0, fixed_self = 0;
    for (const auto& r : offset_results<T>()) {
        CAPTURE(describe(r));
        const auto &f = r[Offset::fixed], &e = r[Offset::error_bound];
        fixed_lost += f.lost_occlusions, eb_lost += e.lost_occlusions, fixed_self += f.self_hits();
        // Its offsets: measured 55-120x error_bound's median from 1e3 out and 220-3200x at the
        // origin (more for distant eyes: it scales with |Ro|), in float and double alike.
        CHECK(f.median_offset >= (r.c.distance > 0 ? 40 : 150) * e.median_offset);
        // Refraction through small far spheres: the origin lands beyond the far side.
        if (r.c.scene == workloads::Scene::spheres && is_float && r.c.distance > 0 &&
            2 * r.c.size <= 64 * workloads::float_ulp(r.c.distance) * (1 + 1e-12)) // ≤ 64 ulps wide
            CHECK(refraction_failure_rate(f) > 0.95);
        if (r.c.scene == workloads::Scene::spheres && !is_float) CHECK(refraction_failure_rate(f) == 0);
    }
    // It never self-hits (its one virtue) …
    CHECK(fixed_self == 0);
    // … and loses occluders: in float measured ~1160 lost shadow occlusions against
    // error_bound's ~60; in double its offsets are tiny (1e-12…1e-5 diagonals) and lose none here
    // (1 per case of the 2000-ray benchmark on the 1e-3 bumpy sphere 1e6 away).
    MESSAGE("lost occlusions: fixed " << fixed_lost << ", error_bound " << eb_lost);
    if (is_float) {
        CHECK(fixed_lost > 500);
        CHECK(fixed_lost > 5 * eb_lost);
    } else {
        CHECK(fixed_lost <= 5);
    }
    // issue 15's examples: float refraction fails completely through r = 0.01 at 1e3 and r = 10
    // at 1e6; double refracts.
    for (double eye : {4.0, 100.0}) {
        CAPTURE(eye);
        for (const auto& r : {sphere_case<T>(0.01, 1e3, eye), sphere_case<T>(10, 1e6, eye)}) {
            CAPTURE(describe(r));
            if (is_float)
                CHECK(refraction_failure_rate(r[Offset::fixed]) > 0.95);
            else
                CHECK(refraction_failure_rate(r[Offset::fixed]) == 0);
        }
    }
    // Raw restarts from Ro + t·Rd: the hit point's error grows with the eye's distance, past the
    // sphere test's band; measured 13-19% of a sphere's secondary rays self-hit with the eye 100
    // or 1000 radii away (0.2% at 4), and ~33-50% on the meshes.
    long self = 0, rays = 0;
    for (const auto& r : offset_results<T>())
        if (r.c.scene == workloads::Scene::spheres && r.c.eye >= 100)
            self += r[Offset::none].self_hits(), rays += r[Offset::none].rays();
    CHECK(double(self) / double(rays) > 0.05);
    CHECK(double(self) / double(rays) < 0.40);
}
