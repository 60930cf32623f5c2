// Note §6: the geometric ray–sphere test, and §8's restart-on-the-surface problem.
#include <isin/sphere.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <cmath>
#include <limits>
#include <random>

TEST_CASE_TEMPLATE("§6 miss behind: s < 0 and l2 > r2", T, float, double) {
    const isin::Sphere<T> sp{{0, 0, -20}, 5};
    CHECK_FALSE(isin::intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}, sp));
}

TEST_CASE_TEMPLATE("§6 miss aside: m2 > r2", T, float, double) {
    const isin::Sphere<T> sp{{10, 0, 50}, 5};
    CHECK_FALSE(isin::intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}, sp));
    // Tangent rays graze the sphere: m2 = r2 exactly is a hit at the touching point.
    const auto tangent = isin::intersect(isin::Ray<T>{{5, 0, 0}, {0, 0, 1}}, sp);
    REQUIRE(tangent);
    CHECK(tangent.t == approx(50));
}

TEST_CASE_TEMPLATE("§6 hit from outside: t = s − q", T, float, double) {
    const isin::Sphere<T> sp{{0, 0, 50}, 5};
    const auto hit = isin::intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}, sp);
    REQUIRE(hit);
    CHECK(hit.t == approx(45)); // s = 50, q = 5
    // Off-centre: s = 50·0.8 = 40, m2 = 2500 − 1600 = 900 > 25 → aside; closer sphere does hit.
    const isin::Sphere<T> near_sp{{0, 30, 40}, 10};
    const auto off = isin::intersect(isin::Ray<T>{{0, 0, 0}, {0, T(0.6), T(0.8)}}, near_sp);
    REQUIRE(off);
    CHECK(off.t == approx(40)); // centre on the ray: s = 50, q = 10
}

TEST_CASE_TEMPLATE("§6 hit from inside: t = s + q", T, float, double) {
    const isin::Sphere<T> sp{{0, 0, 50}, 5};
    const auto from_centre = isin::intersect(isin::Ray<T>{{0, 0, 50}, {0, 0, 1}}, sp);
    REQUIRE(from_centre);
    CHECK(from_centre.t == approx(5));
    const auto from_front = isin::intersect(isin::Ray<T>{{0, 0, 47}, {0, 0, 1}}, sp);
    REQUIRE(from_front);
    CHECK(from_front.t == approx(8)); // s = 3, q = 5
    const auto looking_back = isin::intersect(isin::Ray<T>{{0, 0, 53}, {0, 0, -1}}, sp);
    REQUIRE(looking_back);
    CHECK(looking_back.t == approx(8)); // s = 3, q = 5
    const auto s_negative = isin::intersect(isin::Ray<T>{{0, 0, 53}, {0, 0, 1}}, sp);
    REQUIRE(s_negative);
    CHECK(s_negative.t == approx(2)); // s = −3, q = 5
}

TEST_CASE_TEMPLATE("§6 a non-unit direction measures t in multiples of |Rd|", T, float, double) {
    const isin::Sphere<T> sp{{0, 0, 50}, 5};
    const auto hit = isin::intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 2}}, sp);
    REQUIRE(hit);
    CHECK(hit.t == approx(22.5));
}

// §8: a secondary ray starts at a hit point, which lies on the surface only to rounding. Reflected
// (outward) it must not hit its own sphere at t ≈ 0; continuing inward it must reach the far side.
// Primary rays from the eye hit spheres of radius r at 3r…1e3·r; the exact far-side distance is
// computed in long double.
TEST_CASE_TEMPLATE("§6/§8 ray restarted on the surface (hit_point, no offset): no self-hit, far side found, "
                   "r = 1e-2…1e4, eyes 3r…1e3 r away, sphere or eye at the origin",
                   T, float, double) {
    std::mt19937 rng(20261123);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (T r : {T(1e-2), T(1), T(1e4)})
        for (T distance : {T(3), T(100), T(1e3)})
            for (bool eye_at_origin : {true, false}) {
                CAPTURE(r);
                CAPTURE(distance);
                CAPTURE(eye_at_origin);
                const isin::Vertex<T> eye{0, 0, eye_at_origin ? T(0) : -distance * r};
                const isin::Sphere<T> sp{{T(0.3) * r, T(-0.2) * r, eye_at_origin ? distance * r : T(0)}, r};
                int self_hits = 0, missed_exits = 0, bad_chords = 0, primaries = 0;
                for (int i = 0; i < 1000; ++i) {
                    const isin::Vertex<T> aim{sp.center.x + T(uni(rng)) * r, sp.center.y + T(uni(rng)) * r,
                                              sp.center.z};
                    const isin::Ray<T> primary{eye, isin::normalize(aim - eye)};
                    const auto hit = isin::intersect(primary, sp);
                    if (!hit) continue;
                    ++primaries;
                    const auto P = isin::hit_point(primary, sp, hit).point;
                    const auto N = isin::normal_at(sp, P);
                    const isin::Ray<T> reflected{P, isin::reflect(primary.direction, N)};
                    if (const auto h = isin::intersect(reflected, sp)) ++self_hits;
                    const isin::Ray<T> inward{P, primary.direction};
                    const auto exit = isin::intersect(inward, sp);
                    if (!exit) {
                        ++missed_exits;
                        continue;
                    }
                    // Exact chord of the line through P along the direction: 2·(C − P)·Rd.
                    using L = long double;
                    const L chord = 2 * ((L(sp.center.x) - L(P.x)) * L(primary.direction.x) +
                                         (L(sp.center.y) - L(P.y)) * L(primary.direction.y) +
                                         (L(sp.center.z) - L(P.z)) * L(primary.direction.z));
                    if (chord > L(1e-3) * L(r) && std::fabs(L(exit.t) - chord) > L(1e-2) * L(r)) ++bad_chords;
                }
                CHECK(primaries > 500);
                CHECK(self_hits == 0);
                CHECK(missed_exits == 0);
                CHECK(bad_chords == 0);
            }
}

TEST_CASE_TEMPLATE("bad input: zero/negative/NaN radius, NaN/inf rays, zero direction miss", T, float, double) {
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    const isin::Ray<T> ok{{0, 0, 0}, {0, 0, 1}};
    REQUIRE(isin::intersect(ok, isin::Sphere<T>{{0, 0, 50}, 5}));
    for (T radius : {T(0), T(-5), nan, -inf}) CHECK_FALSE(isin::intersect(ok, isin::Sphere<T>{{0, 0, 50}, radius}));
    CHECK_FALSE(isin::intersect(ok, isin::Sphere<T>{{0, nan, 50}, 5}));
    CHECK_FALSE(isin::intersect(ok, isin::Sphere<T>{{0, 0, inf}, 5}));
    const isin::Sphere<T> sp{{0, 0, 50}, 5};
    const isin::Ray<T> bad_rays[] = {
        {{nan, 0, 0}, {0, 0, 1}}, {{0, 0, 0}, {0, nan, 1}}, {{0, 0, inf}, {0, 0, 1}},
        {{0, 0, 0}, {0, 0, inf}}, {{0, 0, 0}, {0, 0, 0}},   {{0, 0, 50}, {0, 0, 0}},
    };
    for (const auto& ray : bad_rays) CHECK_FALSE(isin::intersect(ray, sp));
    // An infinite radius is not a sphere either: no finite hit.
    CHECK_FALSE(isin::intersect(ok, isin::Sphere<T>{{0, 0, 50}, inf}));
}

TEST_CASE_TEMPLATE("the comparison tests: textbook quadratic and Ray Tracing Gems ch. 7 give §6's answers", T, float,
                   double) {
    const isin::Sphere<T> sp{{0, 0, 50}, 5};
    const isin::Ray<T> ahead{{0, 0, 0}, {0, 0, 1}}, inside{{0, 0, 50}, {0, 0, 1}}, aside{{10, 0, 0}, {0, 0, 1}},
        behind{{0, 0, 60}, {0, 0, 1}}, scaled{{0, 0, 0}, {0, 0, 2}};
    for (const auto& test : {&isin::intersect_quadratic<T>, &isin::intersect_rtg<T>}) {
        CHECK(test(ahead, sp).t == approx(45));    // §6: outside → s − q
        CHECK(test(inside, sp).t == approx(5));    // §6: inside → s + q
        CHECK_FALSE(test(aside, sp));              // §6: m2 > r2
        CHECK_FALSE(test(behind, sp));             // §6: behind
        CHECK(test(scaled, sp).t == approx(22.5)); // t in multiples of |Rd|
        CHECK_FALSE(test(ahead, isin::Sphere<T>{{0, 0, 50}, 0}));
        CHECK_FALSE(test(isin::Ray<T>{{0, 0, 0}, {0, 0, 0}}, sp));
    }
    // Far from the centre of a small sphere, the quadratic's discriminant cancels where the RTG
    // form (and isin's) does not: a ray 0.999 r from the centre of r = 1e-3 at 1e4 away in float.
    if constexpr (sizeof(T) == sizeof(float)) {
        const isin::Sphere<T> small{{0, 0, T(1e4)}, T(1e-3)};
        const isin::Ray<T> grazing{{T(0.999e-3), 0, 0}, {0, 0, 1}};
        CHECK(isin::intersect_rtg(grazing, small));
        CHECK(isin::intersect(grazing, small));
    }
}

TEST_CASE_TEMPLATE("§8 surface_band: from the error bounds, √3e·(2r + √3e) + γ₆(l2 + r2), growing with the scene's "
                   "scale as l2 − r2 does",
                   T, float, double) {
    const isin::Sphere<T> sp{{0, -50, 20}, 5};
    const T e = isin::rounding_gamma<T>(6) * T(5) + isin::rounding_gamma<T>(1) * T(50);
    CHECK(isin::surface_point_error(sp) == approx(e));
    const T se = std::sqrt(T(3)) * e;
    CHECK(isin::surface_band(sp, T(25)) == approx(se * (T(10) + se) + isin::rounding_gamma<T>(6) * T(50)));
    // The whole scene scaled by s: l2 − r2 scales by s², and so does the band (to rounding).
    const T band = isin::surface_band(sp, T(26));
    for (T s : {T(1024), T(1) / T(1024)}) {
        CAPTURE(s);
        const isin::Sphere<T> scaled{sp.center * s, sp.radius * s};
        CHECK(isin::surface_band(scaled, T(26) * s * s) == approx(band * s * s));
    }
    // Unlike the note's fixed 0.001: a small fraction of r² at r = 1e-3 (where 0.001 is 1000 r²) …
    const isin::Sphere<T> tiny{{0, 0, T(0.01)}, T(1e-3)};
    CHECK(isin::surface_band(tiny, T(1e-6)) < T(1e-3) * tiny.radius * tiny.radius);
    // … above the rounding of l2 = |C − Ro|² = 1e8 at r = 1e4 …
    const isin::Sphere<T> huge{{0, 0, T(2e4)}, T(1e4)};
    const T l2 = T(1e8), ulp = std::nextafter(l2, std::numeric_limits<T>::infinity()) - l2;
    CHECK(isin::surface_band(huge, l2) > T(4) * ulp);
    // … and within two ulps of the hit point's coordinates, not 64ε·|C| as a fixed multiple gave: a
    // sphere of r = 1 at 1e3 has a band narrower than 2r·2·ulp(1e3) (the fixed multiple: ~60× that in float).
    const T ulp_1e3 = std::nextafter(T(1e3), T(2e3)) - T(1e3);
    CHECK(isin::surface_band(isin::Sphere<T>{{0, 0, T(1e3)}, 1}, T(1)) < T(2) * T(2) * ulp_1e3);
}

TEST_CASE_TEMPLATE("§8 surface_band: hit points (hit_point) and surface points rounded to T lie inside it, points "
                   "64 of their error bounds off do not, r = 1e-3…1e4, eyes 4r…1e3 r away",
                   T, float, double) {
    using L = long double;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (T r : {T(1e-3), T(1), T(1e4)})
        for (T eye_distance : {T(4), T(100), T(1e3)}) {
            CAPTURE(r);
            CAPTURE(eye_distance);
            const isin::Sphere<T> sp{{T(3) * r, T(-2) * r, T(10) * r}, r};
            const T r2 = sp.radius * sp.radius;
            const auto l2_of = [&](const isin::Vertex<T>& P) { // as intersect computes it
                const auto l = sp.center - P;
                return isin::dot(l, l);
            };
            const auto inside_band = [&](const isin::Vertex<T>& P) {
                const T l2 = l2_of(P);
                return std::fabs(l2 - r2) <= isin::surface_band(sp, l2);
            };
            // The point at distance `radius` from the centre along unit n, rounded once to T.
            const auto at = [&](const isin::Vertex<L>& n, L radius) {
                return isin::Vertex<T>{T(L(sp.center.x) + radius * n.x), T(L(sp.center.y) + radius * n.y),
                                       T(L(sp.center.z) + radius * n.z)};
            };
            int hits = 0, hits_outside = 0, surface_outside = 0, off_inside = 0;
            for (int i = 0; i < 500; ++i) {
                // A hit point seen from the eye, where a secondary ray starts.
                const auto dir = isin::normalize(isin::Vertex<T>{T(uni(rng)), T(uni(rng)), T(-1)});
                const isin::Vertex<T> eye = sp.center + (eye_distance * r) * dir;
                const isin::Vertex<T> aim{sp.center.x + T(uni(rng)) * r / 2, sp.center.y + T(uni(rng)) * r / 2,
                                          sp.center.z};
                const isin::Ray<T> ray{eye, aim - eye};
                if (const auto hit = isin::intersect(ray, sp)) {
                    ++hits;
                    hits_outside += !inside_band(isin::hit_point(ray, sp, hit).point);
                }
                // A point of the surface rounded to T, and points 64 error bounds off it along the normal.
                const auto n = isin::normalize(isin::Vertex<L>{L(uni(rng)), L(uni(rng)), L(uni(rng))});
                const auto Q = at(n, L(r));
                surface_outside += !inside_band(Q);
                const L delta = L(64) * L(isin::surface_point_error(sp));
                for (L side : {L(1), L(-1)}) off_inside += inside_band(at(n, L(r) + side * delta));
            }
            CHECK(hits > 300);
            CHECK(hits_outside == 0);
            CHECK(surface_outside == 0);
            CHECK(off_inside == 0);
        }
}
