#pragma once
/// isin — a triangle mesh by index: each vertex stored once, triangles as three vertex indices,
/// with optional per-vertex normals, texture coordinates and colours and per-triangle material ids. What a
/// Bvh builds from, what Scene::add_mesh stores once and places again with add_instance.
///
///     isin::Mesh<float> quad;
///     quad.positions = {{0, 0, 5}, {1, 0, 5}, {0, 1, 5}, {1, 1, 5}};
///     quad.indices = {{0, 2, 1}, {1, 2, 3}};      // clockwise seen from the eye: front faces (§2)
///     isin::compute_normals(quad);                 // smooth normals, split at creases sharper than 60°
///     isin::Bvh<float> bvh{quad};
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "color.hpp"
#include "detail/attributes.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// A triangle mesh by index; see the top of this header.
template <class T>
struct Mesh {
    static_assert(std::is_floating_point_v<T>, "isin::Mesh needs a floating-point type");
    std::vector<Vertex<T>> positions;                  ///< each vertex once
    std::vector<std::array<std::uint32_t, 3>> indices; ///< triangles: indices into positions (V0, V1, V2)
    std::vector<Vertex<T>> normals;                    ///< per vertex, or empty
    std::vector<std::array<T, 2>> uvs;                 ///< per vertex texture coordinates, or empty
    std::vector<std::uint32_t> material;               ///< per triangle material ids, or empty
    std::vector<Color<T>> colors;                      ///< per vertex colours (linear, [0, 1]), or empty

    /// Number of triangles.
    [[nodiscard]] std::size_t size() const noexcept { return indices.size(); }
    /// Triangle i; the caller guarantees i < size() and a valid mesh (see validate).
    [[nodiscard]] Triangle<T> triangle(std::size_t i) const noexcept {
        const auto& k = indices[i];
        return {positions[k[0]], positions[k[1]], positions[k[2]]};
    }

    /// The mesh of a triangle soup: three vertices for every triangle, in order.
    [[nodiscard]] static Mesh from_triangles(const std::vector<Triangle<T>>& triangles) {
        if (triangles.size() > (std::size_t(1) << 31) / 3)
            throw std::length_error("isin::Mesh::from_triangles: more than 2^31 vertices");
        Mesh mesh;
        mesh.positions.reserve(3 * triangles.size());
        mesh.indices.reserve(triangles.size());
        for (const Triangle<T>& tri : triangles) {
            const auto first = static_cast<std::uint32_t>(mesh.positions.size());
            mesh.positions.insert(mesh.positions.end(), {tri.v0, tri.v1, tri.v2});
            mesh.indices.push_back({first, first + 1, first + 2});
        }
        return mesh;
    }

    /// Throws std::invalid_argument naming the first problem: an index beyond positions, or an
    /// optional array (normals, uvs, colors: one per position; material: one per triangle) of another
    /// length. Coordinates are not checked: non-finite and zero-area triangles are never hit.
    void validate() const {
        const auto fail = [](const std::string& why) { throw std::invalid_argument("isin::Mesh: " + why); };
        for (std::size_t i = 0; i < indices.size(); ++i)
            for (const std::uint32_t k : indices[i])
                if (k >= positions.size())
                    fail("triangle " + std::to_string(i) + " refers to vertex " + std::to_string(k) + " of " +
                         std::to_string(positions.size()));
        if (!normals.empty() && normals.size() != positions.size())
            fail(std::to_string(normals.size()) + " normals for " + std::to_string(positions.size()) + " vertices");
        if (!uvs.empty() && uvs.size() != positions.size())
            fail(std::to_string(uvs.size()) + " uvs for " + std::to_string(positions.size()) + " vertices");
        if (!colors.empty() && colors.size() != positions.size())
            fail(std::to_string(colors.size()) + " colours for " + std::to_string(positions.size()) + " vertices");
        if (!material.empty() && material.size() != indices.size())
            fail(std::to_string(material.size()) + " material ids for " + std::to_string(indices.size()) +
                 " triangles");
    }
};

using Meshf = Mesh<float>;
using Meshd = Mesh<double>;

// ---------------------------------------------------------------------------------------------
// Computed vertex normals: Thürmer & Wüthrich 1998, "Computing vertex normals from polygonal
// facets" (T&W: each facet's unit normal weighted by its interior angle at the vertex), split at
// creases as VRML97's IndexedFaceSet creaseAngle does (faces adjacent across an edge smooth into
// each other when their normals differ by no more than the crease angle).
// ---------------------------------------------------------------------------------------------

namespace detail {

/// Root of corner i in a union–find forest over the corners of one vertex (path halving).
inline std::uint32_t fan_root(std::vector<std::uint32_t>& parent, std::uint32_t i) noexcept {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

/// Vertices with up to this many corners find shared edges by comparing all pairs, others by sorting.
inline constexpr std::uint32_t small_fan = 16;

/// A face of compute_normals in W: its corners V, unit normal n̂ = N / |N| and |N|.
template <class W>
struct NormalFacet {
    Vertex<W> V[3], n_hat;
    W len;
};

// compute_normals' arithmetic per face, per corner and per sum, out of line: its paths with and
// without creases call the same code, so they give the same bits whatever FMA contraction the
// compiler would choose at each call site (g++ -O3 -march=native contracted them differently).

/// §2 for a triangle's corners V0, V1, V2 (in W): fills F; false for a face with zero area or a
/// NaN, which contributes nothing.
template <class W>
ISIN_DETAIL_NOINLINE bool normal_facet(const Vertex<W>& V0, const Vertex<W>& V1, const Vertex<W>& V2,
                                       NormalFacet<W>& F) noexcept {
    F.V[0] = V0, F.V[1] = V1, F.V[2] = V2;
    const Vertex<W> N = cross(F.V[1] - F.V[0], F.V[2] - F.V[0]); // §2: N = (V1−V0) × (V2−V0), |N| = 2·area
    F.len = length(N);
    if (!(F.len > W(0)) || !std::isfinite(F.len)) return false;
    F.n_hat = N / F.len; // T&W: unit facet normal n̂ = N / |N|
    return true;
}
/// T&W: corner j's term α·n̂ of face F.
template <class W>
ISIN_DETAIL_NOINLINE Vertex<W> corner_term(const NormalFacet<W>& F, std::size_t j) noexcept {
    const Vertex<W> e1 = F.V[(j + 1) % 3] - F.V[j], e2 = F.V[(j + 2) % 3] - F.V[j];
    // T&W: α = angle between the two edges at the corner, there arccos(e1·e2 / |e1||e2|); here
    // atan2(|e1 × e2|, e1·e2) with |e1 × e2| = |N|: no roots, accurate near 0 and π.
    const W alpha = std::atan2(F.len, dot(e1, e2));
    return alpha * F.n_hat;
}
/// T&W: a vertex normal from its sum, Σ α·n̂ / |Σ α·n̂|.
template <class W>
ISIN_DETAIL_NOINLINE Vertex<W> unit_sum(const Vertex<W>& sum) noexcept {
    return normalize(sum);
}

} // namespace detail

namespace detail {

/// Throws as mesh.validate() does, its normals aside (compute_normals replaces them anyway).
template <class T>
void validate_but_normals(Mesh<T>& mesh) {
    std::vector<Vertex<T>> old;
    old.swap(mesh.normals);
    try {
        mesh.validate();
    } catch (...) {
        mesh.normals.swap(old);
        throw;
    }
    mesh.normals.swap(old);
}

/// compute_normals' faces of a mesh: each face of a float mesh in double, where
/// N = (V1−V0) × (V2−V0) can neither underflow nor overflow; terms and sums back in T.
template <class T>
struct NormalFaces {
    using W = std::conditional_t<sizeof(T) < sizeof(double), double, T>;
    using Facet = NormalFacet<W>;
    const Mesh<T>& mesh;

    static Vertex<W> wide(const Vertex<T>& a) noexcept { return Vertex<W>{W(a.x), W(a.y), W(a.z)}; }
    static Vertex<T> narrow(const Vertex<W>& a) noexcept { return Vertex<T>{T(a.x), T(a.y), T(a.z)}; }
    /// Face f (§2), computed where needed, not stored.
    bool facet(std::size_t f, Facet& F) const noexcept {
        const Triangle<T> tri = mesh.triangle(f);
        return normal_facet(wide(tri.v0), wide(tri.v1), wide(tri.v2), F);
    }
    /// Corner j's term.
    Vertex<T> term(const Facet& F, std::size_t j) const noexcept { return narrow(corner_term(F, j)); }
    /// A sum made unit.
    Vertex<W> unit(const Vertex<T>& sum) const noexcept { return unit_sum(wide(sum)); }
};

/// compute_normals without creases: one fan per vertex.
template <class T>
[[nodiscard]] std::vector<Vertex<T>> smooth_normals(const NormalFaces<T>& faces) {
    const Mesh<T>& mesh = faces.mesh;
    const std::size_t nV = mesh.positions.size(), nF = mesh.indices.size();
    std::vector<Vertex<T>> normals(nV, Vertex<T>{T(0), T(0), T(0)});
    typename NormalFaces<T>::Facet F{};
    for (std::size_t f = 0; f < nF; ++f)
        if (faces.facet(f, F))
            for (std::size_t j = 0; j < 3; ++j) normals[mesh.indices[f][j]] += faces.term(F, j); // T&W: Σ α·n̂
    for (Vertex<T>& n : normals) n = faces.narrow(faces.unit(n)); // T&W: Σ α·n̂ / |Σ α·n̂|
    return normals;
}

/// compute_normals with creases: the fans around each vertex, the copies they need and their normals.
template <class T>
struct FanSplit {
    using U32 = std::uint32_t;
    using W = typename NormalFaces<T>::W;
    static constexpr std::size_t max_u32 = std::numeric_limits<U32>::max();
    static constexpr U32 none = std::numeric_limits<U32>::max();

    NormalFaces<T> faces;
    W cos_limit;                            // adjacent faces join when n̂f·n̂g ≥ cos θ
    std::vector<U32> start, fan;            // the corners at v: fan[start[v] .. start[v+1])
    std::vector<Vertex<T>> normals;         // per vertex, then per copy
    std::vector<U32> copy_of;               // original vertex of each copy
    std::vector<std::pair<U32, U32>> moved; // (corner, copy) for the corners that move

    std::vector<U32> corner, parent, label, nb; // per valid corner at the vertex (nb: its other two vertices)
    std::vector<U32> cluster, merged, keep;     // root → fan, fan → kept fan, kept fans
    std::vector<Vertex<W>> fn;                  // per valid corner at the vertex: its face's n̂
    std::vector<Vertex<T>> terms;               // per valid corner at the vertex: α·n̂
    std::vector<std::uint64_t> edges;           // (other vertex << 32 | corner), for large fans
    std::vector<Vertex<T>> sum;                 // per fan of the vertex

    FanSplit(const NormalFaces<T>& faces_, W cos_limit_)
        : faces(faces_), cos_limit(cos_limit_), normals(faces_.mesh.positions.size(), Vertex<T>{T(0), T(0), T(0)}) {
        sort_corners();
    }

    /// Counting sort of the corners c = 3f + j by vertex: fan[start[v] .. start[v+1]) are the corners at
    /// v in increasing c, so sums run in face order as in smooth_normals.
    void sort_corners() {
        const Mesh<T>& mesh = faces.mesh;
        const std::size_t nV = mesh.positions.size(), nF = mesh.indices.size();
        start.assign(nV + 1, 0);
        for (const auto& tri : mesh.indices)
            for (const U32 v : tri) ++start[v];
        for (std::size_t v = 1; v < nV; ++v) start[v] += start[v - 1]; // end of each vertex's corners
        if (nV > 0) start[nV] = start[nV - 1];
        fan.resize(3 * nF);
        for (std::size_t c = 3 * nF; c-- > 0;) fan[--start[mesh.indices[c / 3][c % 3]]] = U32(c); // now start of each
    }

    /// Vertex v: union its valid corners whose faces share an edge there (the same other vertex) and
    /// differ by at most θ, then merge fans that agree within θ; each fan left is one normal. The fan of
    /// the first corner keeps the vertex, the others become copies nV, nV + 1, ... in order; degenerate
    /// corners stay with the vertex.
    void split_vertex(std::size_t v) {
        const Mesh<T>& mesh = faces.mesh;
        const std::size_t nV = mesh.positions.size();
        typename NormalFaces<T>::Facet F{};
        corner.clear(), nb.clear(), fn.clear(), terms.clear();
        for (U32 i = start[v]; i < start[v + 1]; ++i) {
            const U32 c = fan[i];
            if (!faces.facet(c / 3, F)) continue;
            const auto& tri = mesh.indices[c / 3];
            corner.push_back(c), nb.push_back(tri[(c + 1) % 3]), nb.push_back(tri[(c + 2) % 3]);
            fn.push_back(F.n_hat), terms.push_back(faces.term(F, c % 3));
        }
        const U32 k = U32(corner.size());
        if (k == 0) return;
        parent.resize(k), label.resize(k), merged.resize(k);
        std::iota(parent.begin(), parent.end(), U32(0));
        join_smooth_corners(k);
        // Fans: the components, numbered by their first corner, each with its sum (T&W: Σ α·n̂).
        cluster.assign(k, none);
        sum.clear();
        for (U32 i = 0; i < k; ++i) {
            const U32 root = fan_root(parent, i);
            if (cluster[root] == none) {
                cluster[root] = U32(sum.size());
                sum.push_back(Vertex<T>{T(0), T(0), T(0)});
            }
            label[i] = cluster[root];
            sum[label[i]] += terms[i]; // T&W: Σ α·n̂ over the fan
        }
        // Fans that share no smooth edge but agree within θ all the same (the arcs of a fan with gaps, a
        // bowtie of one surface) merge, each into the first kept fan whose accumulated normal is that close.
        keep.clear();
        for (U32 m = 0; m < U32(sum.size()); ++m) {
            const Vertex<W> n_m = faces.unit(sum[m]);
            U32 q = 0;
            while (q < keep.size() && !(dot(faces.unit(sum[keep[q]]), n_m) >= cos_limit)) ++q;
            if (q < keep.size())
                sum[keep[q]] += sum[m];
            else
                keep.push_back(m);
            merged[m] = q;
        }
        const std::size_t first_copy = nV + copy_of.size();
        if (keep.size() > 1 && first_copy + keep.size() - 2 > max_u32)
            throw std::length_error("isin::compute_normals: more than 2^32 vertices after splitting");
        for (U32 i = 0; i < k; ++i)
            if (const U32 m = merged[label[i]]; m > 0) moved.emplace_back(corner[i], U32(first_copy + m - 1));
        normals[v] = faces.narrow(faces.unit(sum[0])); // T&W: Σ α·n̂ / |Σ α·n̂|
        for (std::size_t q = 1; q < keep.size(); ++q) {
            copy_of.push_back(U32(v));
            normals.push_back(faces.narrow(faces.unit(sum[keep[q]])));
        }
    }

    /// Unites the first k valid corners at a vertex whose faces share an edge there and differ by at most θ.
    void join_smooth_corners(U32 k) {
        const auto join = [&](U32 i, U32 j) {
            if (dot(fn[i], fn[j]) >= cos_limit) // VRML97 creaseAngle: n̂f·n̂g ≥ cos θ, smooth across the edge
                parent[fan_root(parent, i)] = fan_root(parent, j);
        };
        if (k <= small_fan) {
            for (U32 i = 0; i < k; ++i)
                for (U32 j = i + 1; j < k; ++j)
                    if (nb[2 * i] == nb[2 * j] || nb[2 * i] == nb[2 * j + 1] || nb[2 * i + 1] == nb[2 * j] ||
                        nb[2 * i + 1] == nb[2 * j + 1])
                        join(i, j);
        } else {
            edges.clear();
            for (U32 i = 0; i < 2 * k; ++i) edges.push_back(std::uint64_t(nb[i]) << 32 | i / 2);
            std::sort(edges.begin(), edges.end());
            // A run shares one edge: two corners on a manifold, quadratic only in the faces on one edge.
            for (std::size_t r = 0, s = 0; r < edges.size(); r = s) {
                while (s < edges.size() && edges[s] >> 32 == edges[r] >> 32) ++s;
                for (std::size_t p = r; p < s; ++p)
                    for (std::size_t q = p + 1; q < s; ++q) join(U32(edges[p] & max_u32), U32(edges[q] & max_u32));
            }
        }
    }

    /// Commit: the reservations are the last steps that can throw, so a throw leaves the mesh as it was.
    void commit(Mesh<T>& mesh) {
        const std::size_t total = mesh.positions.size() + copy_of.size();
        mesh.positions.reserve(total);
        if (!mesh.uvs.empty()) mesh.uvs.reserve(total);
        if (!mesh.colors.empty()) mesh.colors.reserve(total);
        for (const U32 s : copy_of) {
            mesh.positions.push_back(mesh.positions[s]);
            if (!mesh.uvs.empty()) mesh.uvs.push_back(mesh.uvs[s]);
            if (!mesh.colors.empty()) mesh.colors.push_back(mesh.colors[s]);
        }
        for (const auto& [c, copy] : moved) mesh.indices[c / 3][c % 3] = copy;
        mesh.normals = std::move(normals);
    }
};

} // namespace detail

/// Replaces mesh.normals by angle-weighted vertex normals (Thürmer & Wüthrich 1998), unit, on the
/// front side of the §2 face normal N = (V1−V0) × (V2−V0) (clockwise seen from the viewer, left-handed).
/// Around each vertex, faces that share an edge there and whose normals differ by at most
/// crease_angle_degrees form one smooth fan; each further fan gets a copy of the vertex (position, uvs,
/// colours copied, indices rewritten), so a cube at 60° has 24 vertices. Fans that share no smooth edge
/// but whose normals agree within the angle (a fan with gaps, a bowtie) merge again, greedily in face
/// order. 180 or more never splits.
/// Zero-area and non-finite triangles contribute nothing; a vertex without a valid face gets (0,0,0).
/// Smoothing follows indices, not positions: vertices already split (e.g. at uv seams) stay apart.
/// Throws std::invalid_argument for a NaN angle or a mesh that fails validate() (its normals aside),
/// std::length_error past 2^32 vertices or corners; on any throw the mesh is unchanged.
/// The angle is not deduced, so a float mesh takes a double angle.
template <class T>
void compute_normals(Mesh<T>& mesh, std::common_type_t<T> crease_angle_degrees = T(60)) {
    using W = typename detail::NormalFaces<T>::W;
    if (std::isnan(crease_angle_degrees)) throw std::invalid_argument("isin::compute_normals: the crease angle is NaN");
    detail::validate_but_normals(mesh);
    constexpr std::size_t max_u32 = std::numeric_limits<std::uint32_t>::max();
    if (mesh.indices.size() > max_u32 / 3) throw std::length_error("isin::compute_normals: more than 2^32 corners");

    const detail::NormalFaces<T> faces{mesh};
    if (crease_angle_degrees >= T(180)) { // never split: one fan per vertex
        mesh.normals = detail::smooth_normals(faces);
        return;
    }

    // Adjacent faces join when n̂f·n̂g ≥ cos θ; the few-ulp slack keeps coplanar faces together even at 0°.
    const W pi = W(3.14159265358979323846264338327950288L);
    const W theta = std::max(W(crease_angle_degrees), W(0)) * pi / W(180);
    const W cos_limit = std::cos(theta) - W(8) * W(std::numeric_limits<T>::epsilon());

    detail::FanSplit<T> split(faces, cos_limit);
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) split.split_vertex(v);
    split.commit(mesh);
}

/// A mesh stored in a scene (Scene::add_mesh), to place again with add_instance.
struct MeshId {
    std::uint32_t index;
};

} // namespace isin
