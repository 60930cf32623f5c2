#pragma once
// Seeded mesh generators for isin's BVH benchmarks (vs_embree.cpp, scaling.cpp). Every mesh is
// placed in front of the note's camera (eye at the origin looking along +Z; at distance z the
// view spans x ∈ ±0.8z, y ∈ ±0.45z) and fills a good part of the view. Closed meshes and the
// terrain are wound clockwise seen from outside (above), so isin::normal() points outwards.
// Generated in double, rounded to T once per vertex: vertices shared by neighbouring triangles
// are bit-identical, so the closed meshes are watertight.
//
//   icosphere(level)     20·4^level triangles (6 → 81,920; 8 → 1,310,720), radius 15 at z = 40
//   trefoil()            knot tube, 1000 × 150 quads → 300,000 triangles, around z = 45
//   terrain()            value-noise height field, 500 × 500 quads → 500,000 triangles
//   random_soup(n)       n small triangles scattered through the view, z ∈ [25, 65]
//   from_file(path)      a PLY or OBJ file (isin::load_mesh), framed to fill the view around z = 45
#include <isin/isin.hpp>

#include "../tests/support/secondary.hpp"
#include "../tests/support/workloads.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace meshes {

using V3 = isin::Vertex<double>;

/// A uniform double in [lo, hi) from a std::mt19937_64 (whose output the standard fixes, unlike
/// the distributions'), so a seed gives the same mesh with every standard library.
inline double uniform(std::mt19937_64& rng, double lo, double hi) {
    return lo + (hi - lo) * double(rng() >> 11) * 0x1p-53;
}

template <class T>
isin::Vertex<T> to(const V3& p) {
    return {T(p.x), T(p.y), T(p.z)};
}

/// The triangle a, b, c, wound so that its normal points along `outside` (b and c swapped if not).
template <class T>
isin::Triangle<T> oriented(const V3& a, const V3& b, const V3& c, const V3& outside) {
    const bool flip = isin::dot(isin::cross(b - a, c - a), outside) < 0.0;
    return flip ? isin::Triangle<T>{to<T>(a), to<T>(c), to<T>(b)} : isin::Triangle<T>{to<T>(a), to<T>(b), to<T>(c)};
}

/// Icosahedron subdivided `level` times: 20·4^level triangles, closed, faces outwards
/// (workloads::icosphere, shared with the accuracy study and the tests).
template <class T>
std::vector<isin::Triangle<T>> icosphere(int level, V3 centre = {0, 0, 40}, double radius = 15) {
    return workloads::icosphere<T>(centre, radius, level);
}

/// A tube of radius 0.45 (before scaling) swept along the trefoil knot, `segments` along the curve
/// × `sides` around: 2·segments·sides triangles (workloads::trefoil, shared with the secondary-ray
/// study and its tests).
template <class T>
std::vector<isin::Triangle<T>> trefoil(int segments = 1000, int sides = 150, V3 centre = {0, 0, 45},
                                       double scale = 5.4) {
    return workloads::trefoil<T>(segments, sides, centre, scale);
}

namespace detail {
inline std::uint32_t hash(std::int64_t x, std::int64_t z, std::uint32_t seed) {
    std::uint64_t h = std::uint64_t(x) * 0x9E3779B97F4A7C15u ^ std::uint64_t(z) * 0xC2B2AE3D27D4EB4Fu ^ seed;
    h ^= h >> 33, h *= 0xFF51AFD7ED558CCDu, h ^= h >> 33, h *= 0xC4CEB9FE1A85EC53u, h ^= h >> 33;
    return std::uint32_t(h);
}
// Value noise in [−1, 1]: random values on the integer lattice, smoothly interpolated.
inline double value_noise(double x, double z, std::uint32_t seed) {
    const double fx = std::floor(x), fz = std::floor(z);
    const auto ix = std::int64_t(fx), iz = std::int64_t(fz);
    const auto lattice = [&](std::int64_t dx, std::int64_t dz) {
        return double(hash(ix + dx, iz + dz, seed)) * (2.0 / 4294967295.0) - 1.0;
    };
    const double sx = x - fx, sz = z - fz;
    const double wx = sx * sx * (3 - 2 * sx), wz = sz * sz * (3 - 2 * sz);
    const double a = lattice(0, 0) + wx * (lattice(1, 0) - lattice(0, 0));
    const double b = lattice(0, 1) + wx * (lattice(1, 1) - lattice(0, 1));
    return a + wz * (b - a);
}
} // namespace detail

/// Terrain: a height field over an n × n grid of quads (2 triangles each) covering x ∈ [−90, 90],
/// z ∈ [20, 120], on a ground that rises with z (y = −16 + 0.3(z − 20)) so that it fills the
/// lower ~60% of the view; 6 octaves of seeded value noise (hills of ±10 or so, steep enough to
/// cast shadows from the benchmark's light). Faces point up.
template <class T>
std::vector<isin::Triangle<T>> terrain(int n = 500, std::uint32_t seed = 7) {
    const auto m = std::size_t(n) + 1;
    std::vector<V3> grid(m * m);
    for (std::size_t j = 0; j < m; ++j)
        for (std::size_t i = 0; i < m; ++i) {
            const double x = -90 + 180 * double(i) / double(n), z = 20 + 100 * double(j) / double(n);
            double h = 0, amplitude = 14, frequency = 1.0 / 25;
            for (std::uint32_t octave = 0; octave < 6; ++octave, amplitude *= 0.5, frequency *= 2)
                h += amplitude * detail::value_noise(x * frequency, z * frequency, seed + 101 * octave);
            grid[j * m + i] = {x, -16 + 0.3 * (z - 20) + h, z};
        }
    std::vector<isin::Triangle<T>> out;
    out.reserve(2 * std::size_t(n) * std::size_t(n));
    const V3 up{0, 1, 0};
    for (std::size_t j = 0; j + 1 < m; ++j)
        for (std::size_t i = 0; i + 1 < m; ++i) {
            const V3 &p00 = grid[j * m + i], &p10 = grid[j * m + i + 1], &p01 = grid[(j + 1) * m + i],
                     &p11 = grid[(j + 1) * m + i + 1];
            out.push_back(oriented<T>(p00, p01, p11, up));
            out.push_back(oriented<T>(p00, p11, p10, up));
        }
    return out;
}

/// `count` triangles with vertices within ±size of a centre; the centres are uniform in depth
/// z ∈ [z_lo, z_hi] and across the view (x ∈ ±0.75z, y ∈ ±0.42z). Default: ~60% of the primary
/// rays of the note's camera hit one.
template <class T>
std::vector<isin::Triangle<T>> random_soup(std::size_t count, std::uint64_t seed = 2024, double size = 0.22,
                                           double z_lo = 25, double z_hi = 65) {
    std::mt19937_64 rng(seed);
    std::vector<isin::Triangle<T>> out;
    out.reserve(count);
    for (std::size_t k = 0; k < count; ++k) {
        const double z = uniform(rng, z_lo, z_hi);
        const V3 c{uniform(rng, -0.75, 0.75) * z, uniform(rng, -0.42, 0.42) * z, z};
        V3 p[3];
        for (V3& q : p) q = c + V3{uniform(rng, -size, size), uniform(rng, -size, size), uniform(rng, -size, size)};
        out.push_back({to<T>(p[0]), to<T>(p[1]), to<T>(p[2])});
    }
    return out;
}

/// A mesh file's triangles (isin::load_mesh: PLY or OBJ), scaled and moved as a whole so that its box
/// is centred at (0, 0, 45) and fills 85% of the view's width or height there, as the generated
/// meshes do. In double, rounded to T once per vertex: shared vertices stay bit-identical.
template <class T>
std::vector<isin::Triangle<T>> from_file(const std::string& path) {
    const std::vector<isin::Triangle<double>> in = isin::load_mesh<double>(path);
    isin::Box<double> box;
    for (const auto& t : in) box.grow(t.v0), box.grow(t.v1), box.grow(t.v2);
    if (in.empty() || !(box.lo.x <= box.hi.x)) throw std::invalid_argument("no triangles in '" + path + "'");
    const V3 centre = box.lo * 0.5 + box.hi * 0.5, extent = box.hi - box.lo;
    const double z = 45, fill = 0.85; // the view spans x ∈ ±0.8z, y ∈ ±0.45z at depth z
    const double scale =
        std::min(fill * 1.6 * z / std::max(extent.x, 1e-300), fill * 0.9 * z / std::max(extent.y, 1e-300));
    const auto place = [&](const V3& p) { return to<T>((p - centre) * scale + V3{0, 0, z}); };
    std::vector<isin::Triangle<T>> out;
    out.reserve(in.size());
    for (const auto& t : in) out.push_back({place(t.v0), place(t.v1), place(t.v2)});
    return out;
}

/// Whether a vs_embree mesh name is a file (it names a .ply or .obj) rather than a generated mesh.
inline bool is_file(const std::string& name) {
    const auto ends = [&](const char* e) {
        const std::string x(e);
        return name.size() > x.size() && name.compare(name.size() - x.size(), x.size(), x) == 0;
    };
    return ends(".ply") || ends(".obj") || ends(".PLY") || ends(".OBJ");
}

/// The name a table gives a mesh: a file's name without its folders.
inline std::string label(const std::string& name) {
    return is_file(name) ? name.substr(name.find_last_of('/') == std::string::npos ? 0 : name.find_last_of('/') + 1)
                         : name;
}

/// The meshes of the vs_embree benchmark, by name.
inline const std::vector<std::string>& names() {
    static const std::vector<std::string> list = {"icosphere-80k", "icosphere-1.3M", "trefoil-300k", "terrain-500k",
                                                  "soup-200k"};
    return list;
}

template <class T>
std::vector<isin::Triangle<T>> make(const std::string& name) {
    if (name == "icosphere-80k") return icosphere<T>(6);
    if (name == "icosphere-1.3M") return icosphere<T>(8);
    if (name == "trefoil-300k") return trefoil<T>();
    if (name == "terrain-500k") return terrain<T>();
    if (name == "soup-200k") return random_soup<T>(200000);
    if (is_file(name)) return from_file<T>(name);
    throw std::invalid_argument("unknown mesh '" + name + "'");
}

} // namespace meshes
