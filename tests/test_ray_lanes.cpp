// The lane filters (ray_lanes.hpp) keep every ray that the scalar tests hit — rays through edges
// and vertices, rays that start on the surface (secondary rays), grazing and parallel rays, bad
// rays — and drop the rays that clearly miss. Built by CI with both compilers at -O0 and
// -O3 -march=native, where the scalar loop and the vectorised one may fuse differently.
#include <isin/ray_lanes.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace {

template <class T>
isin::Vertex<T> random_point(std::mt19937& rng, T scale) {
    std::uniform_real_distribution<T> u(-scale, scale);
    return {u(rng), u(rng), u(rng)};
}

/// A point of the triangle by barycentrics (b1, b2), computed in long double and rounded once.
template <class T>
isin::Vertex<T> at_barycentrics(const isin::Triangle<T>& t, long double b1, long double b2) {
    const long double b0 = 1.0L - b1 - b2;
    auto c = [&](int a) {
        const auto x = [&](const isin::Vertex<T>& v) { return static_cast<long double>(isin::component(v, a)); };
        return T(b0 * x(t.v0) + b1 * x(t.v1) + b2 * x(t.v2));
    };
    return {c(0), c(1), c(2)};
}

struct Tally {
    long hits = 0, lost = 0, kept = 0, rays = 0;
};

/// Runs may_hit on `rays` (in blocks of the lanes' capacity, the last one partial) and checks
/// each against the scalar test `hit(ray)`: a hit the filter dropped is `lost`.
template <class T, class Shape, class Hit>
void tally(const std::vector<isin::Ray<T>>& rays, const Shape& shape, const Hit& hit, Tally& out) {
    isin::RayLanes<T> lanes;
    for (std::size_t first = 0; first < rays.size(); first += isin::RayLanes<T>::capacity) {
        const std::size_t n = std::min(isin::RayLanes<T>::capacity, rays.size() - first);
        lanes.assign(rays.data() + first, n);
        const std::uint64_t maybe = isin::may_hit(lanes, shape);
        if (n < 64) CHECK((maybe >> n) == 0); // no bits beyond the rays held
        for (std::size_t k = 0; k < n; ++k) {
            const bool h = hit(rays[first + k]), kept = (maybe >> k) & 1u;
            out.rays += 1, out.hits += h, out.kept += kept, out.lost += h && !kept;
        }
    }
}

template <class T>
isin::Triangle<T> random_triangle(std::mt19937& rng, T size, T offset) {
    const isin::Vertex<T> c = random_point<T>(rng, offset);
    return {c + random_point<T>(rng, size), c + random_point<T>(rng, size), c + random_point<T>(rng, size)};
}

} // namespace

TEST_CASE_TEMPLATE("ray lanes: may_hit keeps every ray Möller–Trumbore hits: through edges and vertices, from the "
                   "surface, grazing, degenerate",
                   T, float, double) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<long double> unit(0.0L, 1.0L);
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    Tally total;
    for (int trial = 0; trial < 300; ++trial) {
        const T size = T(std::pow(10.0, -3 + trial % 7)), offset = T(std::pow(10.0, -2 + (trial / 7) % 6));
        isin::Triangle<T> tri = random_triangle<T>(rng, size, offset);
        if (trial % 50 == 7) tri.v2 = tri.v0 + (tri.v1 - tri.v0) * T(0.5); // degenerate: a segment
        std::vector<isin::Ray<T>> rays;
        const isin::Vertex<T> eye = tri.v0 + random_point<T>(rng, T(4) * size);
        for (int k = 0; k < 150; ++k) {
            // Points on an edge (one barycentric exactly 0), at a vertex, just inside or outside
            // an edge (by a few ulps of the barycentrics), and anywhere.
            long double b1 = unit(rng), b2 = unit(rng) * (1.0L - b1);
            const long double nudge = (k % 5 - 2) * static_cast<long double>(std::numeric_limits<T>::epsilon());
            switch (k % 6) {
            case 0: b1 = 0.0L + nudge; break;
            case 1: b2 = 0.0L + nudge; break;
            case 2: b2 = 1.0L - b1 + nudge; break;
            case 3: b1 = k % 4 == 3 ? 1.0L : 0.0L, b2 = 0.0L; break; // a vertex
            default: break;
            }
            const isin::Vertex<T> p = at_barycentrics(tri, b1, b2);
            rays.push_back({eye, p - eye});                                  // from the eye
            rays.push_back({p, random_point<T>(rng, T(1))});                 // from the surface
            rays.push_back({p - (tri.v1 - tri.v0) * T(2), tri.v1 - tri.v0}); // along the plane
            rays.push_back({eye, (p - eye) * T(1e-30)});                     // tiny direction
            rays.push_back({eye * T(1e3), p - eye * T(1e3)});                // from far away
        }
        rays.push_back({eye, {0, 0, 0}});
        rays.push_back({eye, {nan, 1, 0}});
        rays.push_back({{nan, 0, 0}, {0, 0, 1}});
        rays.push_back({eye, {inf, 1, 0}});
        tally(
            rays, tri, [&](const isin::Ray<T>& r) { return bool(isin::intersect_moller_trumbore(r, tri)); }, total);
    }
    CAPTURE(total.rays);
    CAPTURE(total.hits);
    CHECK(total.hits > total.rays / 10); // the rays do meet the triangles
    CHECK(total.lost == 0);
}

TEST_CASE_TEMPLATE("ray lanes: may_hit keeps every ray the §6 sphere test hits: tangent, from the surface, from inside",
                   T, float, double) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<T> unit(T(-1), T(1));
    Tally total;
    for (int trial = 0; trial < 300; ++trial) {
        const T r = T(std::pow(10.0, -3 + trial % 7)), offset = T(std::pow(10.0, -2 + (trial / 7) % 6));
        const isin::Sphere<T> sp{random_point<T>(rng, offset), trial % 60 == 5 ? T(0) : r};
        std::vector<isin::Ray<T>> rays;
        for (int k = 0; k < 150; ++k) {
            const isin::Vertex<T> n = isin::normalize(isin::Vertex<T>{unit(rng), unit(rng), unit(rng)});
            const isin::Vertex<T> on = sp.center + r * n; // on the surface, rounded
            const isin::Vertex<T> tangent = isin::normalize(isin::cross(n, isin::Vertex<T>{unit(rng), 1, unit(rng)}));
            const T near = T(1) + T(k % 7 - 3) * std::numeric_limits<T>::epsilon();
            rays.push_back({on - T(5) * r * tangent, tangent});                       // tangent
            rays.push_back({sp.center + near * r * n - T(5) * r * tangent, tangent}); // just in or out
            rays.push_back({on, random_point<T>(rng, T(1))});                         // from the surface
            rays.push_back({sp.center + T(0.3) * r * n, random_point<T>(rng, T(1))}); // from inside
            rays.push_back({on + T(100) * r * n, -n});                                // head on
            rays.push_back({on + T(100) * r * n, n});                                 // away
        }
        tally(
            rays, sp, [&](const isin::Ray<T>& ray) { return bool(isin::intersect(ray, sp)); }, total);
    }
    CAPTURE(total.rays);
    CAPTURE(total.hits);
    CHECK(total.hits > total.rays / 4);
    CHECK(total.lost == 0);
}

TEST_CASE_TEMPLATE("ray lanes: may_hit drops rays that clearly miss (1% outside a triangle, 1% beside a sphere)", T,
                   float, double) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<long double> unit(0.0L, 1.0L);
    Tally tri_total, sphere_total;
    for (int trial = 0; trial < 100; ++trial) {
        const T size = T(std::pow(10.0, -2 + trial % 5)), offset = T(std::pow(10.0, -1 + (trial / 5) % 4));
        const isin::Triangle<T> tri = random_triangle<T>(rng, size, offset);
        const isin::Vertex<T> eye = tri.v0 + random_point<T>(rng, T(4) * size);
        std::vector<isin::Ray<T>> rays;
        for (int k = 0; k < 64; ++k) {
            const long double b1 = -0.01L, b2 = unit(rng);
            rays.push_back({eye, at_barycentrics(tri, k % 2 ? b1 : b2, k % 2 ? b2 : b1) - eye});
        }
        tally(
            rays, tri, [&](const isin::Ray<T>& r) { return bool(isin::intersect_moller_trumbore(r, tri)); }, tri_total);
        const isin::Sphere<T> sp{random_point<T>(rng, offset), size};
        rays.clear();
        for (int k = 0; k < 64; ++k) {
            const isin::Vertex<T> n = isin::normalize(random_point<T>(rng, T(1)));
            const isin::Vertex<T> side = isin::normalize(isin::cross(n, random_point<T>(rng, T(1))));
            rays.push_back({sp.center + T(1.01) * size * side + T(10) * size * n, -n}); // passes 1% aside
        }
        tally(
            rays, sp, [&](const isin::Ray<T>& ray) { return bool(isin::intersect(ray, sp)); }, sphere_total);
    }
    CHECK(tri_total.hits == 0);
    CHECK(sphere_total.hits == 0);
    CHECK(tri_total.kept == 0);
    CHECK(sphere_total.kept == 0);
}
