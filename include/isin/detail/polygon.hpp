#pragma once
/// isin — private: polygons into triangles for the mesh readers.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "../vec.hpp"

namespace isin::detail {

/// A polygon of `count` ≥ 3 corners c0 … c(count−1) that a reader stored as its fan: triangle k
/// (k = 0 … count−3) is indices[first + k] = (c0, c(k+1), c(k+2)).
struct FanRun {
    std::size_t first = 0;
    std::size_t count = 0;
};

/// Appends count − 2 triangles covering the polygon corners[0 … count) to `out`, as corner
/// numbers (0 … count−1), each with the polygon's winding. STUB: the fan (0, k+1, k+2).
template <class T>
void triangulate_polygon(const Vertex<T>* corners, std::size_t count, std::vector<std::array<std::uint32_t, 3>>& out) {
    (void)corners;
    for (std::size_t k = 0; k + 2 < count; ++k)
        out.push_back({0u, static_cast<std::uint32_t>(k + 1), static_cast<std::uint32_t>(k + 2)});
}

/// Replaces the fan of each run by triangulate_polygon's triangles of the same polygon (the same
/// number of triangles, in the same slots). STUB: keeps the fans.
template <class T>
void retriangulate_fans(const std::vector<Vertex<T>>& positions, std::vector<std::array<std::uint32_t, 3>>& indices,
                        const std::vector<FanRun>& runs) {
    (void)positions;
    (void)indices;
    (void)runs;
}

} // namespace isin::detail
