#pragma once
// Named, seeded workload generators for isin's accuracy-against-speed study (issue 4), shared by
// benchmarks/accuracy_vs_speed.cpp and tests/test_stability.cpp. Cases built by construction
// carry their true answer (aimed inside with a margin: must hit; outside with a margin: must
// miss; at an edge or vertex: either, but a closed mesh must be hit once).
#include <isin/isin.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace workloads {

enum class Expect { hit, miss, either };

template <class T>
struct TriangleCase {
    isin::Ray<T> ray;
    isin::Triangle<T> tri;
    Expect expect;
};

template <class T>
struct MeshCase {
    std::vector<isin::Triangle<T>> mesh;
    std::vector<isin::Ray<T>> rays; // each aimed at a shared edge or vertex, 3 away, from the front
};

/// The distance at which a mesh ray reaches the surface it was aimed at (3, as built).
constexpr double mesh_ray_distance = 3.0;

template <class T>
struct SphereCase {
    isin::Sphere<T> sphere;
    isin::Ray<T> outward; // restarted on the surface, leaving: must not hit (t ≈ 0 is a self-hit)
    isin::Ray<T> inward;  // restarted on the surface, entering: must hit the far side
};

using Rng = std::mt19937_64;

inline double uniform(Rng& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

template <class T>
isin::Vertex<T> point(double x, double y, double z) {
    return {T(x), T(y), T(z)};
}

template <class T>
isin::Vertex<T> random_unit(Rng& rng) {
    for (;;) {
        const double x = uniform(rng, -1, 1), y = uniform(rng, -1, 1), z = uniform(rng, -1, 1);
        const double n = x * x + y * y + z * z;
        if (n > 1e-4 && n <= 1) return point<T>(x / std::sqrt(n), y / std::sqrt(n), z / std::sqrt(n));
    }
}

// A vertex in double, exactly (every float is a double).
template <class T>
isin::Vertex<double> to_double(const isin::Vertex<T>& p) {
    return {double(p.x), double(p.y), double(p.z)};
}

// Barycentric point of a triangle, computed in double from the (rounded) vertices.
template <class T>
isin::Vertex<double> at_barycentric(const isin::Triangle<T>& tri, double u, double v) {
    return to_double(tri.v0) + u * (to_double(tri.v1) - to_double(tri.v0)) +
           v * (to_double(tri.v2) - to_double(tri.v0));
}

// A ray from `origin` towards the target point (direction normalised in double).
template <class T>
isin::Ray<T> ray_towards(const isin::Vertex<double>& origin, const isin::Vertex<double>& target) {
    const auto d = isin::normalize(target - origin);
    return {point<T>(origin.x, origin.y, origin.z), point<T>(d.x, d.y, d.z)};
}

// Points aimed at with a margin: inside (all barycentrics ≥ margin) or outside one edge by margin.
inline void inside_barycentrics(Rng& rng, double margin, double& u, double& v) {
    do {
        u = uniform(rng, margin, 1 - 2 * margin);
        v = uniform(rng, margin, 1 - 2 * margin);
    } while (u + v > 1 - margin);
}
inline void outside_barycentrics(Rng& rng, double margin, double& u, double& v) {
    const int edge = int(uniform(rng, 0, 3));
    const double s = uniform(rng, 0.1, 0.9);
    if (edge == 0)
        u = s, v = -margin; // beyond edge V0V1
    else if (edge == 1)
        u = -margin, v = s; // beyond edge V0V2
    else
        u = s * (1 + margin), v = (1 - s) * (1 + margin); // beyond edge V1V2
}

// Workload 1, "random": random triangles in [−1,1]³, rays from random origins 2–4 away aimed at
// barycentrics in [−0.25, 1.25] (about half hit); the truth comes from the reference test.
template <class T>
std::vector<TriangleCase<T>> random_pairs(int n, std::uint64_t seed = 1) {
    Rng rng(seed);
    std::vector<TriangleCase<T>> cases;
    for (int i = 0; i < n; ++i) {
        isin::Triangle<T> tri{point<T>(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)),
                              point<T>(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)),
                              point<T>(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1))};
        const auto target = at_barycentric(tri, uniform(rng, -0.25, 1.25), uniform(rng, -0.25, 1.25));
        const auto dir = random_unit<double>(rng);
        const auto origin = target + uniform(rng, 2, 4) * dir;
        cases.push_back({ray_towards<T>(origin, target), tri, Expect::either});
    }
    return cases;
}

// A closed icosphere (radius r around c), every face clockwise seen from outside.
template <class T>
std::vector<isin::Triangle<T>> icosphere(const isin::Vertex<double>& c, double r, int levels) {
    const double p = 1.6180339887498949;
    std::vector<isin::Vertex<double>> v{{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
                                        {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
    const int f[20][3] = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                          {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                          {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    std::vector<isin::Triangle<double>> tris;
    for (const auto& face : f)
        tris.push_back({isin::normalize(v[size_t(face[0])]), isin::normalize(v[size_t(face[1])]),
                        isin::normalize(v[size_t(face[2])])});
    for (int l = 0; l < levels; ++l) {
        std::vector<isin::Triangle<double>> finer;
        for (const auto& t : tris) {
            const auto a = isin::normalize(t.v0 + t.v1), b = isin::normalize(t.v1 + t.v2),
                       d = isin::normalize(t.v2 + t.v0);
            finer.insert(finer.end(), {{t.v0, a, d}, {a, t.v1, b}, {d, b, t.v2}, {a, b, d}});
        }
        tris.swap(finer);
    }
    std::vector<isin::Triangle<T>> out;
    for (auto& t : tris) {
        if (isin::dot(isin::normal(t), t.v0) < 0) std::swap(t.v1, t.v2);
        auto w = [&](const isin::Vertex<double>& q) {
            const auto s = c + r * q;
            return point<T>(s.x, s.y, s.z);
        };
        out.push_back({w(t.v0), w(t.v1), w(t.v2)});
    }
    return out;
}

// Rays aimed exactly (in T) at a vertex or at a point of an edge of the mesh, computed from the
// mesh's own (rounded) vertices, from `distance` away on the front side of the triangle the
// target was taken from, at least 0.2 (cosine) off its plane — so the ray really enters there.
template <class T>
std::vector<isin::Ray<T>> rays_at_edges(const std::vector<isin::Triangle<T>>& mesh, double distance, int n,
                                        std::uint64_t seed) {
    Rng rng(seed);
    std::vector<isin::Ray<T>> rays;
    while (int(rays.size()) < n) {
        const auto& tri = mesh[size_t(uniform(rng, 0, double(mesh.size())))];
        const isin::Vertex<T>* vs[3] = {&tri.v0, &tri.v1, &tri.v2};
        const int k = int(uniform(rng, 0, 3));
        const double s = uniform(rng, 0, 1) < 0.25 ? 0.0 : uniform(rng, 0, 1); // 1 in 4 at a vertex
        const isin::Vertex<double> target = to_double(*vs[k]) + s * (to_double(*vs[(k + 1) % 3]) - to_double(*vs[k]));
        const auto N = isin::normalize(
            isin::normal(isin::Triangle<double>{to_double(tri.v0), to_double(tri.v1), to_double(tri.v2)}));
        const auto dir = random_unit<double>(rng);
        if (isin::dot(dir, N) < 0.2) continue; // front side, not grazing
        rays.push_back(ray_towards<T>(target + distance * dir, target));
    }
    return rays;
}

// Workload 2a: a closed icosphere (1280 triangles, radius 1 around (0.3, −0.2, 0.1)).
template <class T>
MeshCase<T> closed_sphere_edges(int n, std::uint64_t seed = 2) {
    const isin::Vertex<double> c{0.3, -0.2, 0.1};
    MeshCase<T> m{icosphere<T>(c, 1.0, 3), {}};
    m.rays = rays_at_edges(m.mesh, 3.0, n, seed);
    return m;
}

// Workload 2b: a flat 16×16 grid of unit squares (two triangles each) in the plane z = 0.37,
// rays at random angles aimed at its inner (shared) edges and vertices.
template <class T>
MeshCase<T> grid_edges(int n, std::uint64_t seed = 3) {
    MeshCase<T> m;
    const double z = 0.37, x0 = -8.1, y0 = -7.9;
    for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 16; ++i) {
            const auto a = point<T>(x0 + i, y0 + j, z), b = point<T>(x0 + i + 1, y0 + j, z);
            const auto c = point<T>(x0 + i, y0 + j + 1, z), d = point<T>(x0 + i + 1, y0 + j + 1, z);
            m.mesh.push_back({a, c, b});
            m.mesh.push_back({b, c, d});
        }
    // Only squares away from the border, so every targeted edge is shared by two triangles.
    std::vector<isin::Triangle<T>> inner;
    for (int j = 1; j < 15; ++j)
        for (int i = 1; i < 15; ++i)
            inner.insert(inner.end(), {m.mesh[size_t(2 * (16 * j + i))], m.mesh[size_t(2 * (16 * j + i) + 1)]});
    m.rays = rays_at_edges(inner, 3.0, n, seed);
    return m;
}

// Workload 3, "grazing": a triangle of size 1 in the plane y = 0.3, rays at `angle` (radians)
// to the plane aimed at interior points (margin 5%), so every one must hit.
template <class T>
std::vector<TriangleCase<T>> grazing(double angle, int n, std::uint64_t seed = 4) {
    Rng rng(seed);
    std::vector<TriangleCase<T>> cases;
    const isin::Triangle<T> tri{point<T>(-0.4, 0.3, 0.1), point<T>(0.6, 0.3, -0.2), point<T>(0.1, 0.3, 0.9)};
    for (int i = 0; i < n; ++i) {
        double u, v;
        inside_barycentrics(rng, 0.05, u, v);
        const auto target = at_barycentric(tri, u, v);
        const double phi = uniform(rng, 0, 6.283185307179586);
        const isin::Vertex<double> dir{std::cos(angle) * std::cos(phi), std::sin(angle),
                                       std::cos(angle) * std::sin(phi)};
        cases.push_back({ray_towards<T>(target + 2.0 * dir, target), tri, Expect::hit});
    }
    return cases;
}

// Workload 4, "scale": a random well-shaped triangle of side `size`, translated `offset` from
// the origin; rays from 3·size away, half aimed inside (margin 5%), half outside (by 5%).
template <class T>
std::vector<TriangleCase<T>> scaled(double size, double offset, int n, std::uint64_t seed = 5) {
    Rng rng(seed);
    std::vector<TriangleCase<T>> cases;
    const isin::Vertex<double> o{offset * 0.6, offset * -0.48, offset * 0.64};
    for (int i = 0; i < n; ++i) {
        const auto a =
            o + size * isin::Vertex<double>{uniform(rng, -0.1, 0.1), uniform(rng, -0.1, 0.1), uniform(rng, -0.1, 0.1)};
        const auto b = a + size * isin::Vertex<double>{1, uniform(rng, -0.2, 0.2), uniform(rng, -0.2, 0.2)};
        const auto c = a + size * isin::Vertex<double>{uniform(rng, 0.2, 0.6), 1, uniform(rng, -0.2, 0.2)};
        const isin::Triangle<T> tri{point<T>(a.x, a.y, a.z), point<T>(b.x, b.y, b.z), point<T>(c.x, c.y, c.z)};
        const bool in = i % 2 == 0;
        double u, v;
        if (in)
            inside_barycentrics(rng, 0.05, u, v);
        else
            outside_barycentrics(rng, 0.05, u, v);
        const auto target = at_barycentric(tri, u, v);
        auto dir = random_unit<double>(rng);
        const auto N = isin::normalize(isin::cross(b - a, c - a));
        if (std::fabs(isin::dot(dir, N)) < 0.3) dir = isin::normalize(dir + N); // not grazing
        cases.push_back({ray_towards<T>(target + 3 * size * dir, target), tri, in ? Expect::hit : Expect::miss});
    }
    return cases;
}

// Workload 5, "sliver": triangles of length 1 and width 1/aspect; rays aimed inside (margin 5%
// of the width) and outside (by 5%), from 2 away.
template <class T>
std::vector<TriangleCase<T>> slivers(double aspect, int n, std::uint64_t seed = 6) {
    Rng rng(seed);
    std::vector<TriangleCase<T>> cases;
    for (int i = 0; i < n; ++i) {
        const isin::Vertex<double> a{uniform(rng, -0.5, 0.5), uniform(rng, -0.5, 0.5), uniform(rng, -0.5, 0.5)};
        const auto along = random_unit<double>(rng);
        auto across = isin::normalize(isin::cross(along, random_unit<double>(rng)));
        const auto b = a + along, c = a + 0.5 * along + (1.0 / aspect) * across;
        const isin::Triangle<T> tri{point<T>(a.x, a.y, a.z), point<T>(b.x, b.y, b.z), point<T>(c.x, c.y, c.z)};
        const bool in = i % 2 == 0;
        double u, v;
        if (in)
            inside_barycentrics(rng, 0.05, u, v);
        else
            outside_barycentrics(rng, 0.05, u, v);
        const auto target = at_barycentric(tri, u, v);
        auto dir = isin::normalize(isin::cross(along, across) + 0.5 * random_unit<double>(rng));
        cases.push_back({ray_towards<T>(target + 2.0 * dir, target), tri, in ? Expect::hit : Expect::miss});
    }
    return cases;
}

// Workload 6, "restart": spheres of radius r centred `offset` from the origin, seen from an eye
// 4r from the centre; each hit point is restarted outward (mirror direction: must not hit) and
// inward (straight on: must hit the far side).
template <class T>
std::vector<SphereCase<T>> sphere_restarts(double r, double offset, int n, std::uint64_t seed = 7) {
    Rng rng(seed);
    std::vector<SphereCase<T>> cases;
    const isin::Sphere<T> sp{point<T>(offset * 0.36, offset * -0.48, offset * 0.8), T(r)};
    const isin::Vertex<double> c{double(sp.center.x), double(sp.center.y), double(sp.center.z)};
    while (int(cases.size()) < n) {
        const auto eye = c + 4 * r * random_unit<double>(rng);
        const auto aim = c + 0.95 * r * random_unit<double>(rng);
        const auto primary = ray_towards<T>(eye, aim);
        const auto h = isin::intersect(primary, sp);
        if (!h) continue;
        const auto P = primary.at(h.t);
        const auto N = isin::normal_at(sp, P);
        cases.push_back({sp, {P, isin::reflect(primary.direction, N)}, {P, primary.direction}});
    }
    return cases;
}

// Timing workload for triangles: 2048 random rays (random_pairs, seed 11) each tested against
// the same 64 triangles (the first 64 of those pairs), the same for the one-at-a-time and the
// batch figures.
template <class T>
struct TriangleTiming {
    std::vector<TriangleCase<T>> cases = random_pairs<T>(2048, 11);
    std::vector<isin::Triangle<T>> triangles{};
    TriangleTiming() {
        for (std::size_t i = 0; i < 64; ++i) triangles.push_back(cases[i].tri);
    }
};

// Timing workload for spheres: 64 spheres in front of the eye and 2048 rays from the origin
// (about half hit), the same for the one-at-a-time and the batch figures.
template <class T>
std::vector<isin::Sphere<T>> timing_spheres(std::uint64_t seed = 12) {
    Rng rng(seed);
    std::vector<isin::Sphere<T>> list;
    for (int i = 0; i < 64; ++i)
        list.push_back(
            {point<T>(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, 4, 6)), T(uniform(rng, 0.2, 0.6))});
    return list;
}
template <class T>
std::vector<isin::Ray<T>> timing_rays(std::uint64_t seed = 13) {
    Rng rng(seed);
    std::vector<isin::Ray<T>> rays;
    for (int i = 0; i < 2048; ++i)
        rays.push_back({{0, 0, 0}, isin::normalize(point<T>(uniform(rng, -0.25, 0.25), uniform(rng, -0.25, 0.25), 1))});
    return rays;
}

/// n random triangles: centres uniform in [−10, 10]³, corners within ±`size` of them on each axis.
template <class T>
std::vector<isin::Triangle<T>> triangle_soup(int n, std::uint64_t seed, double size = 0.8) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<isin::Triangle<T>> tris;
    for (int i = 0; i < n; ++i) {
        const isin::Vertex<double> c{uni(rng) * 10, uni(rng) * 10, uni(rng) * 10};
        auto p = [&](double s) {
            return isin::Vertex<T>{T(c.x + s * uni(rng)), T(c.y + s * uni(rng)), T(c.z + s * uni(rng))};
        };
        tris.push_back({p(size), p(size), p(size)});
    }
    return tris;
}

} // namespace workloads
