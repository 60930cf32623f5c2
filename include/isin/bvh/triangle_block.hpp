#pragma once
/// isin — the record of a Bvh leaf's triangles (a block of up to 8, structure-of-arrays), the
/// per-ray state the leaf tests share, and their hits: what triangles.hpp and each ISA's leaf
/// test (triangles_avx2.hpp) are written over.
#include <cstdint>

#include "../ray.hpp"
#include "../triangle.hpp"
#include "../vec.hpp"

namespace isin {
namespace detail {

/// Up to 8 triangles, vertex-major, structure-of-arrays, and their indices. Unused lanes
/// (padding) repeat lane 0, triangle and index: a hit there ties with lane 0's, which wins the
/// tie, so lane tests need no mask for them; all-hits callers drop them (is_padding).
template <class T>
struct alignas(64) TriangleBlock {
    T v[3][3][8]; // [vertex][axis][lane]
    std::uint32_t primitive[8];
};

/// Whether lane k of a block is padding: a repeat of lane 0 (no triangle is in a leaf twice).
template <class T>
[[nodiscard]] inline bool is_padding(const TriangleBlock<T>& b, int k) noexcept {
    return k > 0 && b.primitive[k] == b.primitive[0];
}
/// The lanes of a block before its padding: its triangles.
template <class T>
[[nodiscard]] inline int live_lanes(const TriangleBlock<T>& b) noexcept {
    int k = 1;
    while (k < 8 && !is_padding(b, k)) ++k;
    return k;
}

/// The triangle leaves' per-ray state: the origin and the watertight shear, set up when the ray
/// reaches its first leaf (most rays of a frame that miss never do).
template <class T>
struct TriangleRay {
    T org[3];
    Vertex<T> dir;
    WatertightShear<T> shear;
    bool sheared = false, usable = false;

    explicit TriangleRay(const Ray<T>& ray) noexcept
        : org{ray.origin.x, ray.origin.y, ray.origin.z}, dir(ray.direction) {}
    /// A ray whose shear was set already (a packet's, for all its rays at once), and whether
    /// set() succeeded.
    TriangleRay(const Ray<T>& ray, const WatertightShear<T>& s, bool ok) noexcept
        : org{ray.origin.x, ray.origin.y, ray.origin.z}, dir(ray.direction), shear(s), sheared(true), usable(ok) {}
    /// Sets the shear on first use; false for a zero direction (no hit then; nor with NaN).
    bool ready() noexcept {
        if (!sheared) sheared = true, usable = shear.set(dir);
        return usable;
    }
};

/// The hits of one block: t and barycentrics of each lane whose bit test_block returns.
template <class T>
struct LaneHits {
    T t[8], u[8], v[8];
};

} // namespace detail
} // namespace isin
