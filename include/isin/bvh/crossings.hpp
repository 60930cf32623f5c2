#pragma once
/// isin — exact crossing counts: how many times a ray crosses a Bvh's triangles, each crossing
/// once even where the ray passes exactly through an edge or a vertex shared by several
/// triangles. Bvh::count_hits calls it.
///
/// The watertight test (Woop, Benthin & Wald 2013) counts a point on an edge as inside both
/// triangles that share it, so counting its hits counts such a crossing twice. Here each edge
/// function of the sheared triangle that is exactly 0 takes the sign it would have for the ray
/// moved by (ε, ε²) in the sheared plane, ε → 0 (a symbolic perturbation, the "top-left rule"
/// of rasterisation): the sign of its gradient's x, or of its y when x is 0. Edge functions are
/// computed with an exact sign from the sheared vertices, which every triangle that shares a
/// vertex computes alike, so the two triangles of an edge see it with exactly opposite values
/// and gradients: a ray through the edge is inside exactly one of two triangles it crosses
/// between, and inside both or neither of two that fold back (a silhouette). The count is then
/// the crossing count of the moved ray, even from outside a closed mesh.
#include <cstddef>
#include <cstdint>
#include <limits>

#include "../ray.hpp"
#include "../triangle.hpp"
#include "traverse.hpp"
#include "tree.hpp"
#include "triangles.hpp"

namespace isin {
namespace detail {

/// The sign (−1, 0, +1) of an edge function E at the ray moved by (ε, ε²): E's own when E ≠ 0,
/// else its gradient's (gx, gy), x first.
template <class T>
[[nodiscard]] inline int perturbed_sign(T E, T gx, T gy) noexcept {
    if (E != T(0)) return E > T(0) ? 1 : (E < T(0) ? -1 : 0); // NaN: 0 (no crossing)
    if (gx != T(0)) return gx > T(0) ? 1 : -1;
    return gy > T(0) ? 1 : (gy < T(0) ? -1 : 0);
}

/// Whether the ray (its shear `s`) crosses triangle A, B, C (vertices relative to its origin)
/// with t in (0, t_max), by the watertight test's edge functions (intersect_sheared) with the
/// perturbation above.
template <class T>
[[nodiscard]] inline bool crosses(const Vertex<T>& A, const Vertex<T>& B, const Vertex<T>& C,
                                  const WatertightShear<T>& s, T t_max) noexcept {
    const ShearedTriangle<T> e(A, B, C, s);
    // E(q) for the ray at q in the sheared plane: U(q) = U + qx·(Cy − By) + qy·(Bx − Cx), etc.
    const int su = perturbed_sign(e.U, e.Cy - e.By, e.Bx - e.Cx);
    const int sv = perturbed_sign(e.V, e.Ay - e.Cy, e.Cx - e.Ax);
    const int sw = perturbed_sign(e.W, e.By - e.Ay, e.Ax - e.Bx);
    if (su == 0 || su != sv || su != sw) return false;
    const T det = e.U + e.V + e.W;
    if (!(det != T(0))) return false;      // the ray lies in the triangle's plane: no crossing
    const T t = e.t_det(A, B, C, s) / det; // WBW: t = (U·Az + V·Bz + W·Cz)/det
    return t > T(0) && t < t_max;
}

/// The number of the tree's triangles the ray crosses with t in (0, t_max) (crosses above).
template <class T>
[[nodiscard]] std::size_t count_crossings(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks, const Ray<T>& ray,
                                          T t_max) noexcept {
    WatertightShear<T> shear;
    if (!shear.set(ray.direction)) return 0;
    std::size_t count = 0;
    T t = t_max;
    traverse<Visit::any>(tree, ray, t, [&](std::uint32_t leaf, T&) {
        const TriangleBlock<T>& b = blocks[leaf];
        for (int k = 0, live = live_lanes(b); k < live; ++k) {
            Vertex<T> p[3]; // the vertices relative to the origin, as test_block_scalar
            for (int v = 0; v < 3; ++v) p[v] = Vertex<T>{b.v[v][0][k], b.v[v][1][k], b.v[v][2][k]} - ray.origin;
            if (crosses(p[0], p[1], p[2], shear, t_max)) ++count;
        }
        return false;
    });
    return count;
}

} // namespace detail
} // namespace isin
