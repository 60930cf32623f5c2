// Polygons into triangles (io/polygon.hpp): the fan for convex polygons, ear clipping for
// concave ones and keyholes in any plane and either winding, defined results for degenerate
// input, and retriangulate_fans on a reader's index buffer.
#include <isin/io/polygon.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <utility>
#include <vector>

namespace {

using Tris = std::vector<std::array<std::uint32_t, 3>>;
using P2 = std::array<double, 2>;
using Shape = std::vector<P2>; // a polygon in its own plane, as (s, t)

const double pi = 3.14159265358979323846;

/// Shoelace: signed area of a polygon in its plane (positive counter-clockwise).
double shoelace(const Shape& s) {
    double a2 = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
        const P2& p = s[i];
        const P2& q = s[(i + 1) % s.size()];
        a2 += p[0] * q[1] - q[0] * p[1]; // shoelace: Σ x_i y_i+1 − x_i+1 y_i
    }
    return a2 / 2;
}

Shape reversed(Shape s) {
    std::reverse(s.begin(), s.end());
    return s;
}

/// A plane through `origin` spanned by the orthonormal u, v: (s, t) ↦ origin + s·u + t·v.
struct Plane {
    const char* name;
    std::array<double, 3> origin, u, v;
};

// Normals u × v: +z, +x, +y, (1, −2, 2)/3 (a tie of y and z), (2, 3, 6)/7.
// clang-format off
const Plane planes[] = {
    {"xy",                   {0, 0, 0},     {1, 0, 0},                  {0, 1, 0}},
    {"yz",                   {3, -1, 2},    {0, 1, 0},                  {0, 0, 1}},
    {"zx",                   {0, 5, 0},     {0, 0, 1},                  {1, 0, 0}},
    {"tilted, |N_y| = |N_z|", {0.5, -2, 1},  {2.0 / 3, 2.0 / 3, 1.0 / 3}, {-2.0 / 3, 1.0 / 3, 2.0 / 3}},
    {"tilted",               {-1, 4, 0.25}, {3.0 / 7, -6.0 / 7, 2.0 / 7}, {6.0 / 7, 2.0 / 7, -3.0 / 7}},
};
// clang-format on

template <class T>
std::vector<isin::Vertex<T>> embed(const Shape& s, const Plane& pl) {
    std::vector<isin::Vertex<T>> c;
    for (const P2& p : s) {
        double xyz[3];
        for (std::size_t k = 0; k < 3; ++k) xyz[k] = pl.origin[k] + p[0] * pl.u[k] + p[1] * pl.v[k];
        c.push_back({static_cast<T>(xyz[0]), static_cast<T>(xyz[1]), static_cast<T>(xyz[2])});
    }
    return c;
}

isin::Vec3d widen(const isin::Vec3f& p) { return {double(p.x), double(p.y), double(p.z)}; }
isin::Vec3d widen(const isin::Vec3d& p) { return p; }

/// Newell normal in double (twice the vector area).
template <class T>
isin::Vec3d newell(const std::vector<isin::Vertex<T>>& c) {
    isin::Vec3d N{0, 0, 0};
    for (std::size_t i = 0; i < c.size(); ++i) N += isin::cross(widen(c[i]), widen(c[(i + 1) % c.size()]));
    return N;
}

template <class T>
Tris triangulate(const std::vector<isin::Vertex<T>>& c) {
    Tris out;
    isin::detail::triangulate_polygon(c.data(), c.size(), out);
    return out;
}

/// count − 2 triangles with corner numbers below count.
void check_count(const Tris& tris, std::size_t count) {
    REQUIRE(tris.size() == count - 2);
    for (const auto& t : tris)
        for (const std::uint32_t i : t) REQUIRE(i < count);
}

/// Signed area of triangle (a, b, c) in the polygon's plane, seen as the triangulation sees it:
/// along the largest axis k of the polygon's Newell normal N, A = ((b − a) × (c − a))_k / (2 N̂_k).
/// For a planar polygon that is the area along N̂. Float corners of a tilted plane are rounded off
/// it, and a long sliver may then tip over along N̂ by a rounding error: this measures it as the
/// projection (which decides the triangles) sees it.
double area_in_plane(const isin::Vec3d& a, const isin::Vec3d& b, const isin::Vec3d& c, const isin::Vec3d& N) {
    const isin::Vec3d t = isin::cross(b - a, c - a);
    const double ax = std::fabs(N.x), ay = std::fabs(N.y), az = std::fabs(N.z);
    const int k = (az >= ax && az >= ay) ? 2 : (ax >= ay ? 0 : 1);
    return isin::component(t, k) / (2 * isin::component(N, k));
}

/// A triangulation of a simple polygon: count − 2 triangles, none turned against the polygon's
/// Newell normal (zero area allowed), areas adding up to `area`. With no triangle turned over,
/// every point is covered as often as the polygon winds around it: the triangles tile it.
template <class T>
void check_tiles(const std::vector<isin::Vertex<T>>& c, const Tris& tris, double area) {
    check_count(tris, c.size());
    const isin::Vec3d N = isin::normalize(newell(c));
    const double tol = (sizeof(T) == sizeof(float) ? 1e-5 : 1e-11) * std::fabs(area);
    double sum = 0, sum_abs = 0, most_negative = 0;
    for (const auto& t : tris) {
        const double A = area_in_plane(widen(c[t[0]]), widen(c[t[1]]), widen(c[t[2]]), N);
        sum += A;
        sum_abs += std::fabs(A);
        most_negative = std::min(most_negative, A);
    }
    CHECK(most_negative >= -tol);
    CHECK(sum == doctest::Approx(area).epsilon(sizeof(T) == sizeof(float) ? 1e-4 : 1e-9));
    CHECK(sum_abs == doctest::Approx(area).epsilon(sizeof(T) == sizeof(float) ? 1e-4 : 1e-9));
}

/// Ear clips in every plane and both windings, checking the tiling against the shoelace area.
template <class T>
void check_all_planes(const Shape& s) {
    const double area = std::fabs(shoelace(s));
    for (const Plane& pl : planes)
        for (const bool reverse : {false, true}) {
            const doctest::String plane = pl.name;
            CAPTURE(plane);
            CAPTURE(reverse);
            const auto c = embed<T>(reverse ? reversed(s) : s, pl);
            check_tiles(c, triangulate(c), area);
        }
}

// ---- Shapes (counter-clockwise) ----

Shape l_shape() { return {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}; }

Shape star(std::size_t points, double r_out, double r_in) {
    Shape s;
    for (std::size_t i = 0; i < 2 * points; ++i) {
        const double a = pi * double(i) / double(points), r = i % 2 ? r_in : r_out;
        s.push_back({r * std::cos(a), r * std::sin(a)});
    }
    return s;
}

/// A comb of `teeth` unit-wide teeth 1 high on a base 1 high, 4·teeth corners: area 3·teeth − 1.
Shape comb(std::size_t teeth) {
    const double W = double(2 * teeth - 1);
    Shape s{{0, 0}, {W, 0}};
    for (std::size_t k = teeth; k-- > 0;) {
        const double x = double(2 * k);
        s.push_back({x + 1, 2});
        s.push_back({x, 2});
        if (k > 0) s.push_back({x, 1}), s.push_back({x - 1, 1});
    }
    return s;
}

/// A band wound as a spiral (Archimedes r = 0.2 + 0.1·θ/π, 0.1 wide), `turns` times round, out
/// along its outer edge, back along its inner one.
Shape spiral(double turns, std::size_t steps) {
    Shape outer, inner;
    for (std::size_t i = 0; i <= steps; ++i) {
        const double a = 2 * pi * turns * double(i) / double(steps), r = 0.2 + 0.1 * a / pi;
        outer.push_back({(r + 0.1) * std::cos(a), (r + 0.1) * std::sin(a)});
        inner.push_back({r * std::cos(a), r * std::sin(a)});
    }
    Shape s = outer;
    s.insert(s.end(), inner.rbegin(), inner.rend());
    return s;
}

/// A ring as one polygon: the outer boundary (counter-clockwise, corner 0 first), back to its
/// corner 0, across the bridge to the hole's corner 0, round the hole clockwise, back to its
/// corner 0 (and across the bridge again to close): outer.size() + hole.size() + 2 corners.
Shape keyhole(const Shape& outer, const Shape& hole) {
    Shape s = outer;
    s.push_back(outer[0]);
    s.push_back(hole[0]);
    for (std::size_t i = hole.size() - 1; i > 0; --i) s.push_back(hole[i]);
    s.push_back(hole[0]);
    return s;
}

Shape square(double lo, double hi) { return {{lo, lo}, {hi, lo}, {hi, hi}, {lo, hi}}; }

/// A star-shaped polygon: `n` corners around the origin, corner i at a random angle in
/// 2π[i, i + 0.9)/n (corner 0 at angle 0: less than half a turn between neighbours) and a random
/// radius in [r_lo, r_hi], so always simple.
Shape random_star(std::mt19937& rng, std::size_t n, double r_lo, double r_hi) {
    std::uniform_real_distribution<double> jitter(0, 0.9), radius(r_lo, r_hi);
    Shape s;
    for (std::size_t i = 0; i < n; ++i) {
        const double a = 2 * pi * (double(i) + (i == 0 ? 0 : jitter(rng))) / double(n), r = radius(rng);
        s.push_back({r * std::cos(a), r * std::sin(a)});
    }
    return s;
}

} // namespace

TEST_CASE_TEMPLATE("convex polygons give the fan (0, k+1, k+2) exactly", T, float, double) {
    const Shape hexagon = {{0, 0}, {2, 0}, {3, 1}, {2, 2}, {0, 2}, {-1, 1}};
    const Shape with_straight = {{0, 0}, {1, 0}, {2, 0}, {2, 2}, {1, 2}, {0, 2}, {0, 1}};
    const Shape with_repeat = {{0, 0}, {1, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (const Shape& s : {square(0, 1), hexagon, with_straight, with_repeat, star(1, 1, 1)})
        for (const Plane& pl : planes)
            for (const bool reverse : {false, true}) {
                const auto c = embed<T>(reverse ? reversed(s) : s, pl);
                const Tris tris = triangulate(c);
                REQUIRE(tris.size() == c.size() - 2);
                for (std::uint32_t k = 0; k < tris.size(); ++k) {
                    CHECK(tris[k][0] == 0u);
                    CHECK(tris[k][1] == k + 1);
                    CHECK(tris[k][2] == k + 2);
                }
            }
}

TEST_CASE_TEMPLATE("a triangle is (0, 1, 2); fewer than three corners give nothing", T, float, double) {
    const std::vector<isin::Vertex<T>> c = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    Tris out;
    isin::detail::triangulate_polygon(c.data(), 3, out);
    REQUIRE(out.size() == 1);
    CHECK(out[0] == std::array<std::uint32_t, 3>{0, 1, 2});
    isin::detail::triangulate_polygon(c.data(), 2, out);
    isin::detail::triangulate_polygon(c.data(), 0, out);
    CHECK(out.size() == 1);
}

TEST_CASE_TEMPLATE("concave quads: the diagonal from the reflex corner", T, float, double) {
    // Reflex corner 1 or 3: the fan's diagonal 0–2 would run outside.
    const Shape dart1 = {{0, 0}, {1, 1}, {2, 0}, {1, 3}};
    const Shape dart3 = {{0, 0}, {2, 0}, {1, 3}, {1, 1}};
    check_all_planes<T>(dart1);
    check_all_planes<T>(dart3);
    check_all_planes<T>(reversed(dart1));
    CHECK(triangulate(embed<T>(dart1, planes[0])) == Tris{{1, 2, 3}, {1, 3, 0}});
    CHECK(triangulate(embed<T>(dart3, planes[4])) == Tris{{3, 0, 1}, {3, 1, 2}});
}

TEST_CASE_TEMPLATE("concave polygons: L-shape, star, comb, spiral tile the polygon", T, float, double) {
    SUBCASE("L-shape") { check_all_planes<T>(l_shape()); }
    SUBCASE("star") { check_all_planes<T>(star(7, 1, 0.3)); }
    SUBCASE("comb") { check_all_planes<T>(comb(12)); }
    SUBCASE("spiral") { check_all_planes<T>(spiral(3, 120)); }
    SUBCASE("every rotation of the L-shape's corners") {
        Shape s = l_shape();
        for (std::size_t r = 0; r < s.size(); ++r) {
            std::rotate(s.begin(), s.begin() + 1, s.end());
            check_all_planes<T>(s);
        }
    }
}

TEST_CASE_TEMPLATE("keyholes: a square ring, a star ring, bridged from other corners", T, float, double) {
    const Shape ring = keyhole(square(0, 4), square(1, 3));
    CHECK(shoelace(ring) == doctest::Approx(12));
    check_all_planes<T>(ring);
    Shape s = ring;
    for (std::size_t r = 0; r < s.size(); ++r) { // the same ring, starting at every corner
        std::rotate(s.begin(), s.begin() + 1, s.end());
        check_all_planes<T>(s);
    }
    check_all_planes<T>(keyhole(star(6, 2, 1.2), star(5, 0.8, 0.3)));
    // Two holes, each with its own bridge from the outer square.
    const Shape two = {{0, 0}, {6, 0}, {6, 4}, {4, 3}, {5, 3}, {5, 1}, {4, 1}, {4, 3},
                       {6, 4}, {0, 4}, {1, 3}, {2, 3}, {2, 1}, {1, 1}, {1, 3}, {0, 4}};
    CHECK(shoelace(two) == doctest::Approx(24 - 2 - 2));
    check_all_planes<T>(two);
}

TEST_CASE_TEMPLATE("random star-shaped polygons and random keyholes tile (seeded)", T, float, double) {
    std::mt19937 rng(20240611);
    std::uniform_int_distribution<std::size_t> corners(4, 120);
    for (int i = 0; i < 60; ++i) {
        CAPTURE(i);
        check_all_planes<T>(random_star(rng, corners(rng), 0.1, 1.0));
    }
    for (int i = 0; i < 40; ++i) { // ≥ 16 outer corners: its edges keep outside radius 0.55, the hole inside 0.4
        CAPTURE(i);
        const Shape outer = random_star(rng, std::max<std::size_t>(corners(rng), 16), 0.6, 1.0);
        const Shape hole = random_star(rng, corners(rng), 0.1, 0.4);
        check_all_planes<T>(keyhole(outer, hole));
    }
}

TEST_CASE_TEMPLATE("non-planar polygons: count − 2 triangles, corners in range", T, float, double) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> coordinate(-1, 1);
    // A star whose corners go up and down, a saddle, random points.
    std::vector<isin::Vertex<T>> crown, saddle, random;
    const Shape s = star(8, 1, 0.4);
    for (std::size_t i = 0; i < s.size(); ++i) crown.push_back({T(s[i][0]), T(s[i][1]), T(i % 3 == 0 ? 0.5 : -0.2)});
    for (int i = 0; i < 6; ++i) saddle.push_back({T(std::cos(pi * i / 3)), T(std::sin(pi * i / 3)), T(i % 2 ? 1 : -1)});
    for (int i = 0; i < 50; ++i) random.push_back({T(coordinate(rng)), T(coordinate(rng)), T(coordinate(rng))});
    for (const auto* c : {&crown, &saddle, &random}) check_count(triangulate(*c), c->size());
    // A crown that stays close to its plane still tiles its projection.
    std::vector<isin::Vertex<T>> wavy;
    for (std::size_t i = 0; i < s.size(); ++i) wavy.push_back({T(s[i][0]), T(s[i][1]), T(i % 2 ? 0.01 : -0.01)});
    const Tris tris = triangulate(wavy);
    check_count(tris, wavy.size());
    for (const auto& t : tris) {
        const auto N = isin::cross(wavy[t[1]] - wavy[t[0]], wavy[t[2]] - wavy[t[0]]);
        CHECK(N.z >= T(0));
    }
}

TEST_CASE_TEMPLATE("degenerate polygons: count − 2 triangles with valid corners, no crash", T, float, double) {
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    const T huge = std::numeric_limits<T>::max() / T(4);
    using C = std::vector<isin::Vertex<T>>;
    const C collinear = {{0, 0, 0}, {1, 0, 0}, {3, 0, 0}, {2, 0, 0}, {1.5, 0, 0}};
    const C same(7, isin::Vertex<T>{1, 2, 3});
    const C with_nan = {{0, 0, 0}, {2, 0, 0}, {nan, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
    const C triangle_nan = {{nan, nan, nan}, {1, 0, 0}, {0, 1, 0}};
    const C with_inf = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, inf, 0}, {1, 2, 0}, {0, 2, 0}};
    const C with_huge = {{0, 0, 0}, {huge, 0, 0}, {huge, huge, 0}, {1, 1, 0}, {-huge, huge, 0}};
    const C bowtie = {{0, 0, 0}, {1, 1, 0}, {1, 0, 0}, {0, 1, 0}};
    const C bowtie6 = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {2, 2, 0}, {3, 1, 0}, {-1, 1, 0}};
    const C pentagram = {
        {1, 0, 0}, {T(-0.81), T(0.59), 0}, {T(0.31), T(-0.95), 0}, {T(0.31), T(0.95), 0}, {T(-0.81), T(-0.59), 0}};
    const C spike = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 5, 0}, {1, 1, 0}, {0, 1, 0}};
    const C repeats = {{0, 0, 0}, {0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
    for (const C* c : {&collinear, &same, &with_nan, &triangle_nan, &with_inf, &with_huge, &bowtie, &bowtie6,
                       &pentagram, &spike, &repeats})
        check_count(triangulate(*c), c->size());
    // Zero-area parts do not spoil the rest: a rectangle with a spike out, one with a crack in, the
    // L-shape with repeated corners.
    const C crack = {{0, 0, 0}, {4, 0, 0}, {4, 2, 0}, {2, 2, 0}, {2, 1, 0}, {2, 2, 0}, {0, 2, 0}};
    check_tiles(spike, triangulate(spike), 2.0);
    check_tiles(crack, triangulate(crack), 8.0);
    check_tiles(repeats, triangulate(repeats), 3.0);
    // Appends: what is in `out` stays.
    Tris out = {{7, 8, 9}};
    isin::detail::triangulate_polygon(with_nan.data(), with_nan.size(), out);
    CHECK(out.size() == 1 + with_nan.size() - 2);
    CHECK(out[0] == std::array<std::uint32_t, 3>{7, 8, 9});
}

TEST_CASE_TEMPLATE("large polygons: a comb of 100 000 corners tiles within the budget; a random star of 100 000 "
                   "and 20 000 random points (crossing itself) give count − 2 triangles",
                   T, float, double) {
    const Shape s = comb(25000);
    const auto c = embed<T>(s, planes[3]);
    isin::detail::EarClipper<isin::detail::PlaneReal<T>> clipper;
    Tris tris;
    isin::detail::triangulate_polygon(c.data(), c.size(), tris, clipper);
    check_count(tris, c.size());
    // Within the budget, so ear clipping did it all.
    CHECK(clipper.steps() <= isin::detail::ear_clipping_steps_per_corner * c.size());
    check_tiles(c, tris, shoelace(s));
    std::mt19937 rng(3);
    const auto r = embed<T>(random_star(rng, 100000, 0.5, 1.0), planes[0]);
    tris.clear();
    isin::detail::triangulate_polygon(r.data(), r.size(), tris, clipper);
    check_count(tris, r.size());
    std::uniform_real_distribution<double> coordinate(0, 1);
    Shape scattered;
    for (int i = 0; i < 20000; ++i) scattered.push_back({coordinate(rng), coordinate(rng)});
    const auto p = embed<T>(scattered, planes[4]);
    tris.clear();
    isin::detail::triangulate_polygon(p.data(), p.size(), tris, clipper);
    check_count(tris, p.size());
}

TEST_CASE_TEMPLATE("retriangulate_fans: two runs in an index buffer; bad runs are left alone", T, float, double) {
    // Vertices: an L-shape (0 … 5, concave), a square (6 … 9), a lone triangle (10 … 12).
    std::vector<isin::Vertex<T>> positions = embed<T>(l_shape(), planes[0]);
    for (const auto& p : embed<T>(square(5, 6), planes[0])) positions.push_back(p);
    for (const auto& p : embed<T>({{0, 5}, {1, 5}, {0, 6}}, planes[0])) positions.push_back(p);
    // The L-shape starting at its corner 3 (reflex: its fan is wrong), the square, the triangle.
    const std::vector<std::uint32_t> l_corners = {3, 4, 5, 0, 1, 2};
    Tris indices = {{10, 11, 12}};
    for (std::uint32_t k = 0; k < 4; ++k) indices.push_back({l_corners[0], l_corners[k + 1], l_corners[k + 2]});
    indices.push_back({6, 7, 8});
    indices.push_back({6, 8, 9});
    const Tris before = indices;
    const std::vector<isin::detail::FanRun> runs = {{1, 6}, {5, 4}};
    isin::detail::retriangulate_fans(positions, indices, runs);
    REQUIRE(indices.size() == before.size());
    CHECK(indices[0] == before[0]);
    CHECK(indices[5] == before[5]); // the square is convex: its fan stays
    CHECK(indices[6] == before[6]);
    // The L-shape's slots now tile it, with the same global corners.
    std::vector<isin::Vertex<T>> l;
    for (const std::uint32_t i : l_corners) l.push_back(positions[i]);
    Tris local;
    for (std::size_t k = 1; k < 5; ++k) {
        std::array<std::uint32_t, 3> t{};
        for (std::size_t j = 0; j < 3; ++j) {
            const auto at = std::find(l_corners.begin(), l_corners.end(), indices[k][j]);
            REQUIRE(at != l_corners.end());
            t[j] = static_cast<std::uint32_t>(at - l_corners.begin());
        }
        local.push_back(t);
    }
    CHECK(!std::equal(indices.begin() + 1, indices.begin() + 5, before.begin() + 1)); // not the fan
    check_tiles(l, local, 3.0);
    // Runs that are not what FanRun says change nothing and do not crash.
    const Tris good = indices;
    Tris broken = before;
    broken[3][0] = 99; // not a fan any more
    std::vector<isin::Vertex<T>> few(positions.begin(), positions.begin() + 3);
    const std::vector<isin::detail::FanRun> bad = {
        {6, 4}, {100, 6}, {1, 100}, {1, std::numeric_limits<std::size_t>::max()}, {1, 2}, {0, 3}};
    isin::detail::retriangulate_fans(positions, indices, bad);
    CHECK(indices == good);
    Tris copy = broken;
    isin::detail::retriangulate_fans(positions, copy, runs); // the L's run is broken: only the square
    CHECK(copy == broken);
    copy = before;
    isin::detail::retriangulate_fans(few, copy, runs); // corners outside positions
    CHECK(copy == before);
}
