// The lane filters (ray_lanes.hpp) keep every ray that the scalar tests hit — rays through edges
// and vertices, rays that start on the surface (secondary rays), grazing and parallel rays, bad
// rays — and drop the rays that clearly miss. Built by CI with both compilers at -O0 and
// -O3 -march=native, where the scalar loop and the vectorised one may fuse differently.
#include <isin/ray_lanes.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
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

/// Trial `trial`'s triangle (sizes and distances from the origin over 7 and 6 decades, now and
/// then degenerate) and rays that make the tests hard into `rays`: through points on its edges,
/// at its vertices, just inside or outside an edge (a few ulps of the barycentrics) and anywhere,
/// from an eye, from the surface, along the plane, with a tiny direction, from far away; then a
/// zero direction, NaN and infinite ones.
template <class T>
isin::Triangle<T> hard_triangle_rays(std::mt19937& rng, int trial, std::vector<isin::Ray<T>>& rays) {
    std::uniform_real_distribution<long double> unit(0.0L, 1.0L);
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    const T size = T(std::pow(10.0, -3 + trial % 7)), offset = T(std::pow(10.0, -2 + (trial / 7) % 6));
    isin::Triangle<T> tri = random_triangle<T>(rng, size, offset);
    if (trial % 50 == 7) tri.v2 = tri.v0 + (tri.v1 - tri.v0) * T(0.5); // degenerate: a segment
    const isin::Vertex<T> eye = tri.v0 + random_point<T>(rng, T(4) * size);
    for (int k = 0; k < 150; ++k) {
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
    return tri;
}

/// Trial `trial`'s sphere (radii and distances over 7 and 6 decades, now and then of radius 0)
/// and rays that make the §6 test hard into `rays`: tangent, just inside or outside a tangent,
/// from the surface (secondary rays), from inside, head on and away.
template <class T>
isin::Sphere<T> hard_sphere_rays(std::mt19937& rng, int trial, std::vector<isin::Ray<T>>& rays) {
    std::uniform_real_distribution<T> unit(T(-1), T(1));
    const T r = T(std::pow(10.0, -3 + trial % 7)), offset = T(std::pow(10.0, -2 + (trial / 7) % 6));
    const isin::Sphere<T> sp{random_point<T>(rng, offset), trial % 60 == 5 ? T(0) : r};
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
    return sp;
}

} // namespace

TEST_CASE_TEMPLATE("ray lanes: may_hit keeps every ray Möller–Trumbore hits: through edges and vertices, from the "
                   "surface, grazing, degenerate",
                   T, float, double) {
    std::mt19937 rng(7);
    Tally total;
    for (int trial = 0; trial < 300; ++trial) {
        std::vector<isin::Ray<T>> rays;
        const isin::Triangle<T> tri = hard_triangle_rays<T>(rng, trial, rays);
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
    Tally total;
    for (int trial = 0; trial < 300; ++trial) {
        std::vector<isin::Ray<T>> rays;
        const isin::Sphere<T> sp = hard_sphere_rays<T>(rng, trial, rays);
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

namespace {
/// How hit_lanes (the exact test in lanes) compares with the scalar test `scalar` on `rays`.
struct Agreement {
    long rays = 0, hits = 0, same_bits = 0, other_decision = 0, far_off = 0, moved = 0;
};

/// Runs hit_lanes on `rays` in blocks (the last partial) and compares each ray's verdict, t, u, v
/// with `scalar(ray)`: bit for bit (same_bits), a different hit or miss (other_decision), or both
/// hits with t more than `tolerance`·t apart, or u or v more than `tolerance` (far_off). Also tests each ray
/// alone, one value per coordinate (detail::hit_register on a RayRegister<T, T>, as the Scene's
/// single-ray calls do): a result other than its lane's in the block is `moved`.
template <class T, class Shape, class Scalar>
void agree(const std::vector<isin::Ray<T>>& rays, const Shape& shape, const Scalar& scalar, T tolerance,
           Agreement& out) {
    isin::RayLanes<T> lanes;
    isin::RayLaneHits<T> found;
    for (std::size_t first = 0; first < rays.size(); first += isin::RayLanes<T>::capacity) {
        const std::size_t n = std::min(isin::RayLanes<T>::capacity, rays.size() - first);
        lanes.assign(rays.data() + first, n);
        const std::uint64_t hit = isin::hit_lanes(lanes, shape, found);
        if (n < 64) CHECK((hit >> n) == 0);
        for (std::size_t k = 0; k < n; ++k) {
            const isin::Ray<T>& ray = rays[first + k];
            const bool lane_hit = (hit >> k) & 1u;
            const isin::Hit<T> h = scalar(ray);
            T t1 = T(0), u1 = T(0), v1 = T(0);
            const bool alone_hit =
                isin::detail::hit_register(isin::detail::RayRegister<T, T>(ray), shape, &t1, &u1, &v1);
            out.moved += alone_hit != lane_hit || (lane_hit && (std::memcmp(&t1, &found.t[k], sizeof(T)) ||
                                                                std::memcmp(&u1, &found.u[k], sizeof(T)) ||
                                                                std::memcmp(&v1, &found.v[k], sizeof(T))));
            out.rays += 1, out.hits += bool(h);
            if (lane_hit != bool(h)) {
                ++out.other_decision;
                continue;
            }
            if (!lane_hit) {
                ++out.same_bits;
                continue;
            }
            const T t = found.t[k], u = found.u[k], v = found.v[k];
            out.same_bits += t == h.t && u == h.u && v == h.v;
            // t relative to itself; u and v, in [0, 1], relative to 1
            const bool t_off = std::fabs(t - h.t) > tolerance * std::fabs(h.t);
            out.far_off += t_off || std::fabs(u - h.u) > tolerance || std::fabs(v - h.v) > tolerance;
        }
    }
}
} // namespace

TEST_CASE_TEMPLATE("ray lanes: hit_lanes is Möller–Trumbore and the §6 sphere test in lanes: the same bits in any "
                   "lane, the scalar tests' bits where nothing fuses, their verdicts and values where a ray is clear",
                   T, float, double) {
    // The hard rays (through edges, vertices, tangents, from the surface, grazing, bad).
    std::mt19937 tri_rng(7), sphere_rng(11);
    Agreement tris, spheres;
    const T tolerance = sizeof(T) == 4 ? T(1e-4) : T(1e-12);
    for (int trial = 0; trial < 300; ++trial) {
        std::vector<isin::Ray<T>> rays;
        const isin::Triangle<T> tri = hard_triangle_rays<T>(tri_rng, trial, rays);
        agree(
            rays, tri, [&](const isin::Ray<T>& r) { return isin::intersect_moller_trumbore(r, tri); }, tolerance, tris);
        rays.clear();
        const isin::Sphere<T> sp = hard_sphere_rays<T>(sphere_rng, trial, rays);
        agree(
            rays, sp, [&](const isin::Ray<T>& r) { return isin::intersect(r, sp); }, tolerance, spheres);
    }
    for (const Agreement* a : {&tris, &spheres}) {
        CAPTURE(a->rays);
        CAPTURE(a->hits);
        CAPTURE(a->same_bits);
        CAPTURE(a->other_decision);
        CHECK(a->hits > a->rays / 10);
        CHECK(a->moved == 0); // a ray's result does not depend on its lane or the rays beside it
#if !defined(__FMA__)
        CHECK(a->same_bits == a->rays); // nothing can fuse: the same operations, the same bits
#endif
    }
    // Clear rays: through points at least 1% of the way inside or outside a triangle's edges (or
    // a sphere's outline), from an eye a few sizes away, the shape at most 10 sizes from the
    // origin (farther, the rounding of its coordinates is a larger part of its size). Whatever the
    // compiler fuses, the lanes decide as the scalar tests and agree on t, u, v to a few ulps.
    std::mt19937 rng(3);
    std::uniform_real_distribution<long double> unit(0.0L, 1.0L);
    Agreement clear_tris, clear_spheres;
    for (int trial = 0; trial < 200; ++trial) {
        const T size = T(std::pow(10.0, -2 + trial % 5)), offset = size * T(1 + 9 * (trial / 5 % 2));
        const isin::Triangle<T> tri = random_triangle<T>(rng, size, offset);
        const isin::Vertex<T> eye = tri.v0 + random_point<T>(rng, T(4) * size);
        std::vector<isin::Ray<T>> rays;
        for (int k = 0; k < 100; ++k) {
            long double b1 = 0.01L + 0.97L * unit(rng), b2 = (0.98L - b1) * unit(rng) + 0.01L; // inside
            if (k % 3 == 0) b1 = -0.01L - unit(rng);                                           // outside
            rays.push_back({eye, at_barycentrics(tri, b1, b2) - eye});
        }
        agree(
            rays, tri, [&](const isin::Ray<T>& r) { return isin::intersect_moller_trumbore(r, tri); }, tolerance,
            clear_tris);
        const isin::Sphere<T> sp{random_point<T>(rng, offset), size};
        rays.clear();
        for (int k = 0; k < 100; ++k) {
            const isin::Vertex<T> n = isin::normalize(random_point<T>(rng, T(1)));
            const isin::Vertex<T> side = isin::normalize(isin::cross(n, random_point<T>(rng, T(1))));
            const T aside = k % 3 == 0 ? T(1.01) + T(unit(rng)) : T(0.99) * T(unit(rng));
            rays.push_back({sp.center + aside * size * side + T(10) * size * n, -n});
        }
        agree(
            rays, sp, [&](const isin::Ray<T>& r) { return isin::intersect(r, sp); }, tolerance, clear_spheres);
    }
    for (const Agreement* a : {&clear_tris, &clear_spheres}) {
        CAPTURE(a->rays);
        CAPTURE(a->hits);
        CAPTURE(a->same_bits);
        CHECK(a->hits > a->rays / 2);
        CHECK(a->other_decision == 0);
        CHECK(a->far_off == 0);
        CHECK(a->moved == 0);
    }
}

TEST_CASE_TEMPLATE(
    "ray lanes: assign holds each ray in its lane, zeros past them, and each largest direction component", T, float,
    double) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<T> coord(T(-100), T(100));
    std::vector<isin::Ray<T>> rays(80);
    for (isin::Ray<T>& r : rays) r = {{coord(rng), coord(rng), coord(rng)}, {coord(rng), coord(rng), coord(rng)}};
    rays[3].direction.y = -std::numeric_limits<T>::infinity();
    rays[20].origin.z = std::numeric_limits<T>::quiet_NaN();
    isin::RayLanes<T> lanes;
    constexpr std::size_t B = isin::RayLanes<T>::block;
    for (const std::size_t n : {std::size_t(0), std::size_t(1), B - 1, B, B + 1, 2 * B + 3, std::size_t(63),
                                std::size_t(64), std::size_t(80)}) {
        for (const std::size_t first : {std::size_t(0), std::size_t(1)}) { // whole registers at any address
            CAPTURE(n);
            CAPTURE(first);
            const std::size_t count = std::min(n, rays.size() - first);
            lanes.assign(rays.data() + first, count);
            CHECK(lanes.count == std::min(count, isin::RayLanes<T>::capacity));
            CHECK(lanes.padded % B == 0);
            CHECK(lanes.padded >= lanes.count);
            CHECK(lanes.padded < lanes.count + B);
            bool same = true, zeros = true;
            for (std::size_t k = 0; k < lanes.padded; ++k) {
                const T got[6] = {lanes.ox[k], lanes.oy[k], lanes.oz[k], lanes.dx[k], lanes.dy[k], lanes.dz[k]};
                if (k < lanes.count) {
                    const isin::Ray<T>& r = rays[first + k];
                    const T want[6] = {r.origin.x, r.origin.y, r.origin.z, r.direction.x, r.direction.y, r.direction.z};
                    same = same && std::memcmp(got, want, sizeof got) == 0;
                    using std::max;
                    same =
                        same && lanes.dmax[k] == max(max(std::fabs(want[3]), std::fabs(want[4])), std::fabs(want[5]));
                } else {
                    for (const T g : got) zeros = zeros && g == T(0);
                    zeros = zeros && lanes.dmax[k] == T(0);
                }
            }
            CHECK(same);
            CHECK(zeros);
            // assign_with, for rays given one by one: the same lanes
            isin::RayLanes<T> other;
            other.assign_with([&](std::size_t k) { return rays[first + k]; }, count);
            CHECK(other.count == lanes.count);
            CHECK(other.padded == lanes.padded);
            const auto bytes = lanes.padded * sizeof(T);
            CHECK((std::memcmp(other.ox, lanes.ox, bytes) == 0 && std::memcmp(other.oy, lanes.oy, bytes) == 0 &&
                   std::memcmp(other.oz, lanes.oz, bytes) == 0 && std::memcmp(other.dx, lanes.dx, bytes) == 0 &&
                   std::memcmp(other.dy, lanes.dy, bytes) == 0 && std::memcmp(other.dz, lanes.dz, bytes) == 0 &&
                   std::memcmp(other.dmax, lanes.dmax, bytes) == 0));
        }
    }
}
