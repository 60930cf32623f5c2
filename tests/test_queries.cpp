// Geometric queries beyond the first hit: closest points (Ericson §5.1.5 by a Bvh walk), exact
// crossing counts, inside/outside by the generalized winding number, signed distances.
#include <doctest/doctest.h>
#include <isin/isin.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "support/solids.hpp"
#include "support/wide.hpp"
#include "support/workloads.hpp"

namespace {

using LD = long double;

// The distance from p to the nearest triangle of `tris` (of those a Bvh keeps, non-degenerate,
// unless `all`), in long double from the same T inputs: the reference for closest_point.
template <class T>
LD brute_distance(const std::vector<isin::Triangle<T>>& tris, const isin::Vertex<T>& p, bool all = false) {
    LD best = std::numeric_limits<LD>::infinity();
    for (const auto& t : tris) {
        if (!all && !isin::Bvh<T>::bounds(t).usable()) continue;
        const auto q = isin::detail::closest_on_triangle(wide(p), wide(t.v0), wide(t.v1), wide(t.v2));
        best = std::min(best, std::sqrt(isin::dot(q.gap, q.gap)));
    }
    return best;
}

template <class T>
LD diagonal(const std::vector<isin::Triangle<T>>& tris) {
    isin::Box<T> b;
    for (const auto& t : tris) b.grow(t.v0), b.grow(t.v1), b.grow(t.v2);
    return isin::length(wide(b.hi) - wide(b.lo));
}

template <class T>
std::vector<isin::Triangle<T>> triangles_of(const isin::Mesh<T>& m) {
    std::vector<isin::Triangle<T>> out;
    for (std::size_t i = 0; i < m.size(); ++i) out.push_back(m.triangle(i));
    return out;
}

// Within 2e-6 (float) or 1e-12 (double) of the diagonal, as the closest-point goal asks.
template <class T>
LD tolerance() {
    return sizeof(T) == sizeof(float) ? LD(2e-6) : LD(1e-12);
}

// Checks bvh.closest_point(p) against brute force: the distance, the point at that distance from
// p and on the reported triangle.
template <class T>
void check_closest(const isin::Bvh<T>& bvh, const std::vector<isin::Triangle<T>>& tris, const isin::Vertex<T>& p,
                   LD diag) {
    const isin::PointHit<T> hit = bvh.closest_point(p);
    REQUIRE(hit);
    const LD ref = brute_distance(tris, p);
    CHECK(std::fabs(LD(hit.distance) - ref) <= tolerance<T>() * diag);
    REQUIRE(hit.primitive < tris.size());
    const auto& t = tris[hit.primitive];
    const auto on = isin::detail::closest_on_triangle(wide(hit.point), wide(t.v0), wide(t.v1), wide(t.v2));
    // The reported point: on its triangle, and where the distance says, up to its own rounding.
    const LD point_room =
        tolerance<T>() * diag + LD(4) * LD(std::numeric_limits<T>::epsilon()) * isin::max_abs(wide(p));
    CHECK(std::sqrt(isin::dot(on.gap, on.gap)) <= point_room);
    CHECK(std::fabs(isin::length(wide(hit.point) - wide(p)) - ref) <= point_room);
    const isin::Vertex<T> rebuilt = t.v0 + hit.u * (t.v1 - t.v0) + hit.v * (t.v2 - t.v0);
    CHECK(isin::length(wide(rebuilt) - wide(hit.point)) <= point_room);
}

} // namespace

TEST_CASE_TEMPLATE("Ericson 5.1.5: closest point of one triangle, region by region", T, float, double) {
    const isin::Triangle<T> tri{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};
    struct Case {
        isin::Vertex<T> p, expect;
        T distance;
    };
    const Case cases[] = {
        {{1, 1, 3}, {1, 1, 0}, 3},                   // face
        {{-1, -2, 0}, {0, 0, 0}, T(std::sqrt(5.0))}, // vertex V0
        {{6, -1, 0}, {4, 0, 0}, T(std::sqrt(5.0))},  // vertex V1
        {{0, 7, 4}, {0, 4, 0}, 5},                   // vertex V2
        {{2, -3, 4}, {2, 0, 0}, 5},                  // edge V0V1
        {{-3, 2, 0}, {0, 2, 0}, 3},                  // edge V0V2
        {{3, 3, 0}, {2, 2, 0}, T(std::sqrt(2.0))},   // edge V1V2
        {{2, 0, 0}, {2, 0, 0}, 0},                   // on an edge
        {{4, 0, 0}, {4, 0, 0}, 0},                   // on a vertex
    };
    for (const Case& c : cases) {
        const auto hit = isin::closest_point(c.p, tri);
        REQUIRE(hit);
        CHECK(hit.distance == doctest::Approx(double(c.distance)).epsilon(1e-6));
        CHECK(hit.point.x == doctest::Approx(double(c.expect.x)));
        CHECK(hit.point.y == doctest::Approx(double(c.expect.y)));
        CHECK(hit.point.z == doctest::Approx(double(c.expect.z)));
        CHECK(hit.primitive == isin::PointHit<T>::none);
    }
}

TEST_CASE_TEMPLATE("Ericson 5.1.5: degenerate and sliver triangles, NaN", T, float, double) {
    const T nan = std::numeric_limits<T>::quiet_NaN();
    // A segment (collinear vertices), a point, and a sliver 1e-7 wide: a point of the triangle at
    // the true distance.
    const isin::Triangle<T> segment{{0, 0, 0}, {2, 0, 0}, {1, 0, 0}};
    const auto s = isin::closest_point(isin::Vertex<T>{1.5, 1, 0}, segment);
    REQUIRE(s);
    CHECK(s.distance == doctest::Approx(1.0));
    CHECK(s.point.x == doctest::Approx(1.5));
    const isin::Triangle<T> point{{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
    const auto q = isin::closest_point(isin::Vertex<T>{1, 1, 4}, point);
    REQUIRE(q);
    CHECK(q.distance == doctest::Approx(3.0));
    const isin::Triangle<T> sliver{{0, 0, 0}, {1, T(1e-7), 0}, {2, 0, 0}};
    for (T x : {T(-1), T(0.25), T(1), T(1.75), T(3)}) {
        const isin::Vertex<T> p{x, T(0.5), T(0.5)};
        const auto h = isin::closest_point(p, sliver);
        REQUIRE(h);
        const LD ref = brute_distance(std::vector<isin::Triangle<T>>{sliver}, p, true);
        CHECK(std::fabs(LD(h.distance) - ref) <= LD(1e-6));
    }
    CHECK_FALSE(isin::closest_point(isin::Vertex<T>{nan, 0, 0}, sliver));
    CHECK_FALSE(isin::closest_point(isin::Vertex<T>{0, 0, 0}, isin::Triangle<T>{{nan, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
}

TEST_CASE_TEMPLATE("Bvh::closest_point against brute force: near, far, on vertices and edges", T, float, double) {
    const auto mesh = solids::icosphere<T>(3, {0.3, -0.2, 0.1}, 1.0);
    const auto tris = triangles_of(mesh);
    const isin::Bvh<T> bvh{mesh};
    const LD diag = diagonal(tris);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.6, 1.6);
    std::vector<isin::Vertex<T>> points;
    for (int i = 0; i < 300; ++i) points.push_back({T(u(rng)), T(u(rng)), T(u(rng))}); // the box enlarged
    for (int i = 0; i < 100; ++i) {                                                    // on the surface
        const auto& t = tris[size_t(i * 13) % tris.size()];
        points.push_back(t.v0);                                                     // a vertex
        points.push_back(t.v0 + T(0.5) * (t.v1 - t.v0));                            // an edge
        points.push_back(t.v0 + T(0.25) * (t.v1 - t.v0) + T(0.25) * (t.v2 - t.v0)); // inside
        const auto N = isin::normalize(isin::normal(t));
        points.push_back(t.v0 + T(1e-3) * N); // just off it
    }
    points.push_back({100, -50, 30}); // far away
    for (const auto& p : points) check_closest(bvh, tris, p, diag);

    // The array form answers the same, on any number of threads.
    std::vector<isin::PointHit<T>> out(points.size());
    bvh.closest_point(points.data(), points.size(), out.data());
    for (std::size_t i = 0; i < points.size(); ++i) {
        const auto one = bvh.closest_point(points[i]);
        CHECK(out[i].distance == one.distance);
        CHECK(out[i].primitive == one.primitive);
    }
    // On one thread every point follows its Morton neighbour, whose answer bounds its own: the
    // same answers, bit for bit, on points that are near each other (a dense grid round the
    // surface), on vertices and edges (ties between triangles), far away, and NaN.
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j)
            for (int k = 0; k < 12; ++k) points.push_back({T(-1.1 + 0.21 * i), T(-1.2 + 0.2 * j), T(-1.0 + 0.2 * k)});
    points.push_back({std::numeric_limits<T>::quiet_NaN(), 0, 0});
    points.push_back({0, std::numeric_limits<T>::infinity(), 0});
    out.resize(points.size());
    bvh.closest_point(points.data(), points.size(), out.data(), 1);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const auto one = bvh.closest_point(points[i]);
        differ += !(out[i].distance == one.distance || (!out[i] && !one)) || out[i].primitive != one.primitive ||
                  !(out[i].point == one.point) || out[i].u != one.u || out[i].v != one.v;
    }
    CHECK(differ == 0);
    CHECK_FALSE(out[out.size() - 1]);
    CHECK_FALSE(out[out.size() - 2]);
}

TEST_CASE_TEMPLATE("Bvh::closest_point: max_distance, far from the origin, NaN, empty", T, float, double) {
    const auto mesh = solids::icosphere<T>(2, {0, 0, 0}, 1.0);
    const isin::Bvh<T> bvh{mesh};
    const auto h = bvh.closest_point({0, 0, 3});
    REQUIRE(h);
    CHECK(h.distance == doctest::Approx(2.0).epsilon(1e-5));
    CHECK_FALSE(bvh.closest_point({0, 0, 3}, T(1.5)));                    // nothing within 1.5
    CHECK(bvh.closest_point({0, 0, 3}, T(2.5)).primitive == h.primitive); // within 2.5: the same
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    CHECK_FALSE(bvh.closest_point({nan, 0, 0}));
    CHECK_FALSE(bvh.closest_point({inf, 0, 0}));
    CHECK_FALSE(bvh.closest_point({0, 0, 0}, nan));
    CHECK_FALSE(isin::Bvh<T>{std::vector<isin::Triangle<T>>{}}.closest_point({0, 0, 0}));

    // 1e4 from the origin: distances keep the mesh's scale (differences near the mesh are exact).
    const auto far_mesh = solids::icosphere<T>(2, {1e4, -2e4, 3e4}, 1.0);
    const auto far_tris = triangles_of(far_mesh);
    const isin::Bvh<T> far_bvh{far_mesh};
    const LD diag = diagonal(far_tris);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    for (int i = 0; i < 200; ++i) {
        const isin::Vertex<T> p{T(1e4 + u(rng)), T(-2e4 + u(rng)), T(3e4 + u(rng))};
        check_closest(far_bvh, far_tris, p, diag);
    }
}

// Rays through vertices and edges of closed meshes cross each surface once: from outside, the
// count is even, and 2 for a convex mesh the ray passes through.
TEST_CASE_TEMPLATE("Bvh::count_hits: rays at shared vertices and edges of a closed icosphere", T, float, double) {
    const auto mesh = solids::icosphere<T>(3, {0.3, -0.2, 0.1}, 1.0);
    const auto tris = triangles_of(mesh);
    const isin::Bvh<T> bvh{mesh};
    const auto rays = workloads::rays_at_edges(tris, 3.0, 3000, 17);
    std::size_t twice = 0, other = 0, watertight_double_counts = 0;
    for (const auto& ray : rays) {
        const std::size_t n = bvh.count_hits(ray);
        (n == 2 ? twice : other) += 1;
        std::size_t hits = 0;
        (void)bvh.for_each_hit(ray, std::numeric_limits<T>::infinity(), [&](std::uint32_t, const isin::Hit<T>&) {
            ++hits;
            return true;
        });
        if (hits != 2) ++watertight_double_counts;
    }
    CHECK(twice == rays.size());
    CHECK(other == 0);
    MESSAGE("watertight hits not 2 on " << watertight_double_counts << " of " << rays.size() << " rays");
    // Aimed at the surface, stopping short of it: one crossing, from the far side none.
    const auto& ray = rays.front();
    CHECK(bvh.count_hits(ray, T(3) * T(1.0001)) == 1);
    CHECK(bvh.count_hits(ray, T(2.9)) == 0);
}

TEST_CASE_TEMPLATE("Bvh::count_hits: exact ties on a lattice cube, NaN and zero directions", T, float, double) {
    // Rays with exactly representable shears through lattice points: their edge functions are
    // exactly 0 at vertices and edges, the case the perturbation decides.
    const auto mesh = solids::lattice_cube<T>(4);
    const isin::Bvh<T> bvh{mesh};
    const int dirs[][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0},  {1, 1, 1},    {1, -1, 2},
                           {2, 1, 2}, {1, 2, -2}, {1, 1, 0}, {0, 2, -1}, {-1, -1, -1}, {2, 2, 1}};
    std::size_t rays = 0, wrong = 0, watertight_wrong = 0;
    for (const auto& d : dirs)
        for (int x = 1; x < 4; ++x)
            for (int y = 1; y < 4; ++y)
                for (int z = 1; z < 4; ++z)
                    for (int half = 0; half < 2; ++half) {
                        // Through an interior lattice point (or a half-way point), from outside.
                        const isin::Vertex<T> dir{T(d[0]), T(d[1]), T(d[2])};
                        const isin::Vertex<T> inner{T(x) + T(half) * T(0.5), T(y), T(z)};
                        const isin::Ray<T> ray{inner - T(8) * dir, dir};
                        const std::size_t n = bvh.count_hits(ray);
                        ++rays;
                        if (n != 2) ++wrong;
                        std::size_t hits = 0;
                        (void)bvh.for_each_hit(ray, std::numeric_limits<T>::infinity(),
                                               [&](std::uint32_t, const isin::Hit<T>&) { return ++hits, true; });
                        if (hits != 2) ++watertight_wrong;
                    }
    CHECK(wrong == 0);
    CHECK(watertight_wrong > 0); // the ties are there: counting watertight hits miscounts them
    MESSAGE(watertight_wrong << " of " << rays << " lattice rays miscounted by watertight hits");
    // Along a face (in its plane): no crossing through it; along an edge of the cube: none.
    CHECK(bvh.count_hits(isin::Ray<T>{{-1, 1, 0}, {1, 0, 0}}) % 2 == 0);
    CHECK(bvh.count_hits(isin::Ray<T>{{-1, 0, 0}, {1, 0, 0}}) % 2 == 0);
    const T nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(bvh.count_hits(isin::Ray<T>{{nan, 1, 1}, {1, 0, 0}}) == 0);
    CHECK(bvh.count_hits(isin::Ray<T>{{-1, 1, 1}, {0, 0, 0}}) == 0);
    CHECK(bvh.count_hits(isin::Ray<T>{{-1, 1, 1}, {1, 0, 0}}, nan) == 0);
}

TEST_CASE_TEMPLATE("Van Oosterom & Strackee: solid angles of an octant and of a cube's face", T, float, double) {
    // The triangle cutting the first octant's axes subtends 4π/8 from the origin, seen from the
    // side isin::normal points away from.
    const isin::Triangle<T> octant{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const T pi = T(3.14159265358979323846);
    CHECK(isin::solid_angle(isin::Vertex<T>{0, 0, 0}, octant) == doctest::Approx(double(pi / 2)).epsilon(1e-6));
    CHECK(isin::solid_angle(isin::Vertex<T>{0, 0, 0}, isin::Triangle<T>{octant.v0, octant.v2, octant.v1}) ==
          doctest::Approx(double(-pi / 2)).epsilon(1e-6));
    // A cube's face seen from its centre: 4π/6, two triangles.
    const isin::Vertex<T> c{T(0.5), T(0.5), T(0.5)};
    const T face = isin::solid_angle(c, isin::Triangle<T>{{0, 0, 1}, {1, 0, 1}, {1, 1, 1}}) +
                   isin::solid_angle(c, isin::Triangle<T>{{0, 0, 1}, {1, 1, 1}, {0, 1, 1}});
    CHECK(std::fabs(face) == doctest::Approx(double(4 * pi / 6)).epsilon(1e-6));
}

// Points of a closed mesh's box at least `margin` from its surface, with their truth by the
// exact winding number (of the closed meshes: which side of the surface).
template <class T>
std::vector<isin::Vertex<T>> away_from(const isin::Solid<T>& solid, double lo, double hi, double margin, int n,
                                       std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<isin::Vertex<T>> points;
    while (int(points.size()) < n) {
        const isin::Vertex<T> p{T(u(rng)), T(u(rng)), T(u(rng))};
        if (solid.bvh().closest_point(p).distance > T(margin)) points.push_back(p);
    }
    return points;
}

TEST_CASE_TEMPLATE("Jacobson 2013: the winding number is 1 inside and 0 outside a closed mesh", T, float, double) {
    const auto mesh = solids::icosphere<T>(3, {0.3, -0.2, 0.1}, 1.0);
    const isin::Solid<T> solid{mesh};
    const isin::Solid<T> exact{mesh, std::numeric_limits<T>::infinity()};
    const double diag = 2 * std::sqrt(3.0);
    const auto points = away_from(solid, -1.2, 1.4, 1e-3 * diag, 1500, 3);
    std::size_t wrong = 0, wrong_fast = 0;
    const T tol = sizeof(T) == sizeof(float) ? T(1e-4) : T(1e-10);
    for (const auto& p : points) {
        // The truth: the parity of exact crossings, along a direction no edge lines up with.
        const bool inside = solid.bvh().count_hits(isin::Ray<T>{p, {T(0.31), T(0.83), T(-0.47)}}) % 2 == 1;
        const T w = solid.winding_number_exact(p);
        if (std::fabs(w - (inside ? T(1) : T(0))) > tol) ++wrong;
        if (exact.winding_number(p) != exact.winding_number(p, std::numeric_limits<T>::infinity())) ++wrong;
        if (solid.contains(p) != inside) ++wrong_fast;
        CHECK(std::fabs(solid.winding_number(p) - w) < T(0.05)); // the far field's error at beta = 2
    }
    CHECK(wrong == 0);
    CHECK(wrong_fast == 0);
    // The array forms, and signed distances: negative inside, |d| the closest distance.
    std::vector<std::uint8_t> in(points.size());
    std::vector<T> sd(points.size());
    solid.contains(points.data(), points.size(), in.data());
    solid.signed_distance(points.data(), points.size(), sd.data());
    for (std::size_t i = 0; i < points.size(); ++i) {
        CHECK(bool(in[i]) == solid.contains(points[i]));
        CHECK((sd[i] < T(0)) == bool(in[i]));
        CHECK(std::fabs(sd[i]) == solid.bvh().closest_point(points[i]).distance);
    }
    // A lattice cube, 1e-3 inside and outside its faces, edges and corners.
    const isin::Solid<T> cube{solids::lattice_cube<T>(4)};
    CHECK(cube.contains({T(0.001), T(0.001), T(0.001)}));
    CHECK(cube.contains({T(3.999), T(2), T(0.001)}));
    CHECK_FALSE(cube.contains({T(-0.001), T(2), T(2)}));
    CHECK_FALSE(cube.contains({T(4.001), T(4.001), T(4.001)}));
    CHECK(cube.signed_distance({2, 2, 2}) == doctest::Approx(-2.0));
    CHECK(cube.signed_distance({2, 2, 7}) == doctest::Approx(3.0));
}

TEST_CASE_TEMPLATE("Jacobson 2013: overlapping spheres count 2, holes about 1/2, NaN and empty", T, float, double) {
    // Two overlapping closed spheres as one mesh: 2 in the overlap, still inside.
    const auto a = solids::icosphere<T>(3, {0, 0, 0}, 1.0), b = solids::icosphere<T>(3, {0.8, 0, 0}, 1.0);
    const isin::Solid<T> both{solids::merged(a, b)};
    CHECK(both.winding_number_exact({T(0.4), 0, 0}) == doctest::Approx(2.0).epsilon(1e-4));
    CHECK(both.winding_number({T(0.4), 0, 0}) == doctest::Approx(2.0).epsilon(1e-2));
    CHECK(both.contains({T(0.4), 0, 0}));
    CHECK(both.contains({T(-0.5), 0, 0}));
    CHECK_FALSE(both.contains({T(2.5), 0, 0}));
    // One-ray parity is wrong in the overlap (4 crossings from outside through both spheres).
    CHECK(both.bvh().count_hits(isin::Ray<T>{{T(0.4), 0, 0}, {1, 0, 0}}) == 2);

    // A sphere with 2% of its triangles removed: still inside and outside away from the holes.
    const isin::Solid<T> holed{solids::with_holes(solids::icosphere<T>(4, {0, 0, 0}, 1.0), 0.02)};
    CHECK(holed.contains({0, 0, 0}));
    CHECK(holed.winding_number({0, 0, 0}) == doctest::Approx(1.0).epsilon(0.05));
    CHECK_FALSE(holed.contains({2, 0, 0}));
    // Half a sphere: 1/2 at its centre.
    isin::Mesh<T> half;
    half.positions = a.positions;
    for (const auto& t : a.indices)
        if (a.positions[t[0]].z + a.positions[t[1]].z + a.positions[t[2]].z > T(0)) half.indices.push_back(t);
    const isin::Solid<T> cup{half};
    CHECK(cup.winding_number_exact({0, 0, 0}) == doctest::Approx(0.5).epsilon(0.02));

    // A soup of the same triangles (no shared vertices) has the same winding numbers.
    const isin::Solid<T> soup{isin::Mesh<T>::from_triangles(triangles_of(solids::merged(a, b)))};
    for (const isin::Vertex<T> p : {isin::Vertex<T>{T(0.4), 0, 0}, isin::Vertex<T>{T(-0.5), T(0.1), 0},
                                    isin::Vertex<T>{T(2.5), 0, 0}, isin::Vertex<T>{T(0.3), T(0.95), T(0.2)}}) {
        CHECK(soup.contains(p) == both.contains(p));
        CHECK(soup.winding_number(p) == doctest::Approx(double(both.winding_number_exact(p))).epsilon(0.02));
    }
    const T nan = std::numeric_limits<T>::quiet_NaN();
    // beta: NaN and +inf sum every triangle exactly; below 1 it counts as 1 (p outside the ball).
    for (const isin::Vertex<T> p : {isin::Vertex<T>{T(0.4), 0, 0}, isin::Vertex<T>{T(1.5), T(0.2), 0}}) {
        const T exact = both.winding_number_exact(p);
        CHECK(both.winding_number(p, nan) == doctest::Approx(double(exact)).epsilon(1e-5));
        CHECK(both.winding_number(p, T(1e6)) == doctest::Approx(double(exact)).epsilon(1e-5));
        CHECK(both.winding_number(p, T(0)) == both.winding_number(p, T(1)));
        CHECK(std::isfinite(both.winding_number(p, T(0))));
    }
    CHECK_FALSE(both.contains({nan, 0, 0}));
    CHECK(std::isnan(both.signed_distance({nan, 0, 0})));
    const isin::Solid<T> empty{isin::Mesh<T>{}};
    CHECK(empty.winding_number({0, 0, 0}) == 0);
    CHECK_FALSE(empty.contains({0, 0, 0}));
    CHECK(empty.signed_distance({0, 0, 0}) == std::numeric_limits<T>::infinity());
}
