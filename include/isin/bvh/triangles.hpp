#pragma once
/// isin — triangles in a Bvh's leaves: one block of up to 8 triangles per leaf, stored
/// structure-of-arrays, and the watertight test (Woop, Benthin & Wald 2013) on all 8 lanes at
/// once. The lane test is written once over the compiler's vector lanes, with one ISA
/// specialisation where it is faster (AVX2 + FMA, triangles_avx2.hpp), and a scalar
/// loop for double without AVX2 and for compilers without vector extensions. Every form
/// computes, lane by lane, what detail::intersect_sheared computes, so a Bvh hits exactly the
/// triangles intersect_watertight hits.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "../detail/attributes.hpp"
#include "../detail/parallel.hpp"
#include "../ray.hpp"
#include "../triangle.hpp"
#include "../vec.hpp"
#include "box.hpp"
#include "tree.hpp"
#include "triangle_block.hpp"

namespace isin {
namespace detail {

/// The watertight test of one lane at a time: intersect_sheared with the ray's shear; the build
/// left degenerate triangles out. Returns the lanes hit with 0 < t < t_max.
template <bool cull, class T>
[[nodiscard]] inline unsigned test_block_scalar(const TriangleBlock<T>& b, const TriangleRay<T>& r, T t_max,
                                                LaneHits<T>& out) noexcept {
    unsigned lanes = 0;
    const Vertex<T> o{r.org[0], r.org[1], r.org[2]};
    for (int k = 0, n = live_lanes(b); k < n; ++k) {
        Vertex<T> p[3]; // the vertices relative to the origin
        for (int v = 0; v < 3; ++v) p[v] = Vertex<T>{b.v[v][0][k], b.v[v][1][k], b.v[v][2][k]} - o;
        const Hit<T> h = intersect_sheared(p[0], p[1], p[2], r.shear, cull);
        if (!(h.t < t_max)) continue;
        out.t[k] = h.t, out.u[k] = h.u, out.v[k] = h.v;
        lanes |= 1u << k;
    }
    return lanes;
}

#if ISIN_VECTOR_EXTENSIONS
/// The watertight test on 8 float lanes with the compiler's vector extensions, step for step as
/// intersect_sheared: U, V, W as difference_of_products<float> (exact products in double,
/// rounded to float), then det, t and the barycentrics in float.
template <bool cull>
[[nodiscard]] inline unsigned test_block_lanes(const TriangleBlock<float>& b, const TriangleRay<float>& r, float t_max,
                                               LaneHits<float>& out) noexcept {
    using V = L8<float>;
    using D = L8<double>;
    V x[3], y[3], z[3]; // sheared vertices relative to the origin: x, y in the ray's frame, z along it
    for (int v = 0; v < 3; ++v) {
        V px, py, pz;
        std::memcpy(&px, b.v[v][r.shear.kx], sizeof px);
        std::memcpy(&py, b.v[v][r.shear.ky], sizeof py);
        std::memcpy(&pz, b.v[v][r.shear.kz], sizeof pz);
        px -= r.org[r.shear.kx], py -= r.org[r.shear.ky], pz -= r.org[r.shear.kz];
        x[v] = px - r.shear.Sx * pz; // WBW: Ax = A[kx] − Sx·A[kz]
        y[v] = py - r.shear.Sy * pz;
        z[v] = r.shear.Sz * pz; // WBW: Az = Sz·A[kz]
    }
    const D X0 = __builtin_convertvector(x[0], D), Y0 = __builtin_convertvector(y[0], D);
    const D X1 = __builtin_convertvector(x[1], D), Y1 = __builtin_convertvector(y[1], D);
    const D X2 = __builtin_convertvector(x[2], D), Y2 = __builtin_convertvector(y[2], D);
    const V U = __builtin_convertvector(X2 * Y1 - Y2 * X1, V);  // WBW: U = Cx·By − Cy·Bx (exact products)
    const V Vv = __builtin_convertvector(X0 * Y2 - Y0 * X2, V); // WBW: V = Ax·Cy − Ay·Cx
    const V W = __builtin_convertvector(X1 * Y0 - Y1 * X0, V);  // WBW: W = Bx·Ay − By·Ax
    const V det = U + Vv + W;
    const V inv_det = 1.0f / det;                                // lanes with det = 0 give ±∞ or NaN: rejected below
    const V t = (U * z[0] + Vv * z[1] + W * z[2]) * inv_det;     // WBW: t = (U·Az + V·Bz + W·Cz)/det
    const auto front = (U >= 0.0f) & (Vv >= 0.0f) & (W >= 0.0f); // clockwise seen from the origin (§2)
    const auto inside = cull ? front : front | ((U <= 0.0f) & (Vv <= 0.0f) & (W <= 0.0f));
    const auto ok = inside & (det != 0.0f) & (t > 0.0f) & (t < t_max);
    unsigned lanes = 0;
    for (int k = 0; k < 8; ++k) lanes |= unsigned(ok[k] != 0) << k;
    if (!lanes) return 0;
    const V u = Vv * inv_det, v = W * inv_det;
    std::memcpy(out.t, &t, sizeof t), std::memcpy(out.u, &u, sizeof u), std::memcpy(out.v, &v, sizeof v);
    return lanes;
}
#endif

} // namespace detail
} // namespace isin

#include "triangles_avx2.hpp"   // the AVX2 + FMA form, where the target has both
#include "triangles_avx512.hpp" // the AVX-512 form of pairs and packets, where the target has it

namespace isin {
namespace detail {

/// The watertight test of a block: the lanes hit with 0 < t < t_max (front faces only when
/// `cull`), their t, u, v in `out` unless `store` is false (then `out` may or may not be written:
/// a caller that wants to know only whether anything is hit). The ray must be ready().
// Forced inline (ISIN_DETAIL_INLINE), as is everything it runs on the hot path — Sheared8,
// kahan_edges8, finish8, test_block_avx2 and the formulas of triangle.hpp they run — and the Bvh's
// lanes_hit and skip_lanes, so that every walk runs the leaf test in its own loop whatever else
// the translation unit holds (walk_pair's comment); test_block_exact stays out of line (cold).
template <bool cull, bool store = true, class T>
[[nodiscard]] ISIN_DETAIL_INLINE unsigned test_block(const TriangleBlock<T>& b, const TriangleRay<T>& r, T t_max,
                                                     LaneHits<T>& out) noexcept {
#if defined(ISIN_DETAIL_TRIANGLES_AVX2)
    return test_block_avx2<cull, store>(b, r, t_max, out);
#else
#if ISIN_VECTOR_EXTENSIONS
    if constexpr (sizeof(T) == sizeof(float)) return test_block_lanes<cull>(b, r, t_max, out);
#endif
    return test_block_scalar<cull>(b, r, t_max, out);
#endif
}

/// The lane with the least t among `lanes` (≠ 0): the nearest hit; of equal t, the lowest
/// primitive index, so that the nearest hit does not depend on the order leaves are visited in.
template <class T>
[[nodiscard]] inline int nearest_lane(unsigned lanes, const LaneHits<T>& hits, const TriangleBlock<T>& b) noexcept {
    int best = -1;
    for (; lanes; lanes &= lanes - 1) {
        const int k = lowest_bit(lanes);
        if (best < 0 || hits.t[k] < hits.t[best] || (hits.t[k] == hits.t[best] && b.primitive[k] < b.primitive[best]))
            best = k;
    }
    return best;
}

} // namespace detail

/// The triangles of a BvhTree's leaves: block k holds leaf k's triangles. Built from any source
/// of triangles by index (`triangle_of(i)` gives Triangle<T> i), refitted the same way.
template <class T>
class TriangleBlocks {
public:
    using Block = detail::TriangleBlock<T>;

    TriangleBlocks() = default;
    /// One block per leaf of `tree`, filled on up to `threads` threads.
    template <class TriangleOf>
    TriangleBlocks(const BvhTree<T>& tree, const TriangleOf& triangle_of, int threads) {
        blocks_.resize(tree.leaf_count());
        refit(tree, triangle_of, threads);
    }
    /// Copies the triangles again (after their vertices moved; the tree is unchanged).
    template <class TriangleOf>
    void refit(const BvhTree<T>& tree, const TriangleOf& triangle_of, int threads) {
        detail::parallel_chunks(blocks_.size(), threads, 4096, [&](std::size_t begin, std::size_t end) {
            for (std::size_t k = begin; k < end; ++k) fill(blocks_[k], tree, tree.leaves()[k], triangle_of);
        });
    }

    [[nodiscard]] const Block& operator[](std::size_t leaf) const noexcept { return blocks_[leaf]; }
    [[nodiscard]] std::size_t size() const noexcept { return blocks_.size(); }

private:
    friend class detail::BvhFile<T>; // loads saved blocks (serialize.hpp)

    template <class TriangleOf>
    static void fill(Block& b, const BvhTree<T>& tree, const typename BvhTree<T>::Leaf& leaf,
                     const TriangleOf& triangle_of) {
        for (std::uint32_t k = 0; k < 8; ++k) {
            const std::uint32_t index = tree.primitives()[leaf.first + (k < leaf.count ? k : 0u)];
            const Triangle<T> tri = triangle_of(index);
            const Vertex<T>* vs[3] = {&tri.v0, &tri.v1, &tri.v2};
            for (int v = 0; v < 3; ++v)
                for (int a = 0; a < 3; ++a) b.v[v][a][k] = component(*vs[v], a);
            b.primitive[k] = index;
        }
    }

    std::vector<Block, detail::UninitAllocator<Block>> blocks_; // filled in parallel
};

} // namespace isin
