#pragma once
/// isin — a triangle mesh by index: each vertex stored once, triangles as three vertex indices,
/// with optional per-vertex normals, texture coordinates and colours and per-triangle material ids. What a
/// Bvh builds from, what Scene::add_mesh stores once and places again with add_instance.
///
///     isin::Mesh<float> quad;
///     quad.positions = {{0, 0, 5}, {1, 0, 5}, {0, 1, 5}, {1, 1, 5}};
///     quad.indices = {{0, 2, 1}, {1, 2, 3}};      // clockwise seen from the eye: front faces (§2)
///     isin::Bvh<float> bvh{quad};
#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "color.hpp"
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

} // namespace isin
