#pragma once
// Closed, holed and overlapping meshes by index for the geometric queries (closest points,
// crossing counts, inside/outside), shared by tests/test_queries.cpp and benchmarks/queries.cpp.
#include <isin/isin.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <random>
#include <utility>
#include <vector>

namespace solids {

/// An icosphere (subdivided `levels` times: 20·4^levels triangles) of radius r round c, each
/// vertex once, front faces outside (isin::normal points outwards).
template <class T>
isin::Mesh<T> icosphere(int levels, const isin::Vertex<double>& c = {0, 0, 0}, double r = 1) {
    const double p = 1.6180339887498949;
    std::vector<isin::Vertex<double>> v{{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
                                        {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
    for (auto& q : v) q = isin::normalize(q);
    std::vector<std::array<std::uint32_t, 3>> f{{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> middle;
        const auto mid = [&](std::uint32_t a, std::uint32_t b) {
            const auto key = std::make_pair(std::min(a, b), std::max(a, b));
            const auto it = middle.find(key);
            if (it != middle.end()) return it->second;
            v.push_back(isin::normalize(v[a] + v[b]));
            return middle[key] = static_cast<std::uint32_t>(v.size() - 1);
        };
        std::vector<std::array<std::uint32_t, 3>> finer;
        for (const auto& t : f) {
            const std::uint32_t a = mid(t[0], t[1]), b = mid(t[1], t[2]), d = mid(t[2], t[0]);
            finer.insert(finer.end(), {{t[0], a, d}, {a, t[1], b}, {d, b, t[2]}, {a, b, d}});
        }
        f.swap(finer);
    }
    isin::Mesh<T> mesh;
    for (const auto& q : v) {
        const auto s = c + r * q;
        mesh.positions.push_back({T(s.x), T(s.y), T(s.z)});
    }
    for (auto t : f) {
        const auto& a = v[t[0]];
        // Front faces outside: isin::normal, (v1 − v0) × (v2 − v0), points outwards.
        if (isin::dot(isin::cross(v[t[1]] - a, v[t[2]] - a), a) < 0) std::swap(t[1], t[2]);
        mesh.indices.push_back(t);
    }
    return mesh;
}

/// An axis-aligned cube [0, n]³ with every face cut into n×n unit squares of two triangles, each
/// vertex once, on integer coordinates: rays along exactly representable directions then pass
/// exactly through its vertices and edges.
template <class T>
isin::Mesh<T> lattice_cube(int n) {
    isin::Mesh<T> mesh;
    std::map<std::array<int, 3>, std::uint32_t> index;
    const auto at = [&](std::array<int, 3> q) {
        const auto it = index.find(q);
        if (it != index.end()) return it->second;
        mesh.positions.push_back({T(q[0]), T(q[1]), T(q[2])});
        return index[q] = static_cast<std::uint32_t>(mesh.positions.size() - 1);
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
                    const auto corner = [&](int di, int dj) {
                        std::array<int, 3> q{};
                        q[size_t(axis)] = side * n, q[size_t(a1)] = i + di, q[size_t(a2)] = j + dj;
                        return at(q);
                    };
                    std::uint32_t a = corner(0, 0), b = corner(1, 0), c = corner(1, 1), d = corner(0, 1);
                    mesh.indices.push_back({a, b, c});
                    mesh.indices.push_back({a, c, d});
                }
    // Front faces outside (isin::normal points away from the centre; the cube is convex).
    const isin::Vertex<T> centre{T(n) / 2, T(n) / 2, T(n) / 2};
    for (auto& t : mesh.indices) {
        const auto& p0 = mesh.positions[t[0]];
        if (isin::dot(isin::cross(mesh.positions[t[1]] - p0, mesh.positions[t[2]] - p0), p0 - centre) < 0)
            std::swap(t[1], t[2]);
    }
    return mesh;
}

/// `a` and `b` as one mesh (b's indices moved past a's vertices): e.g. two overlapping closed
/// spheres, which one-ray parity gets wrong where they overlap.
template <class T>
isin::Mesh<T> merged(const isin::Mesh<T>& a, const isin::Mesh<T>& b) {
    isin::Mesh<T> m = a;
    const auto base = static_cast<std::uint32_t>(a.positions.size());
    m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
    for (const auto& t : b.indices) m.indices.push_back({t[0] + base, t[1] + base, t[2] + base});
    return m;
}

/// `mesh` without a random `fraction` of its triangles (holes), seeded.
template <class T>
isin::Mesh<T> with_holes(const isin::Mesh<T>& mesh, double fraction, std::uint64_t seed = 7) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    isin::Mesh<T> m;
    m.positions = mesh.positions;
    for (const auto& t : mesh.indices)
        if (u(rng) >= fraction) m.indices.push_back(t);
    return m;
}

} // namespace solids
