#pragma once
/// isin — the closest point of a Bvh's triangles to a point: a walk of the tree nearest box
/// first, inside a sphere around the point that shrinks to each closer triangle found (boxes
/// farther than the sphere are skipped), each leaf's triangles by Ericson's regions
/// (point_hit.hpp). Bvh::closest_point calls it.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "../detail/parallel.hpp"
#include "../point_hit.hpp"
#include "tree.hpp"
#include "triangles.hpp"

namespace isin {
namespace detail {

/// Squared distances from p to the 8 child boxes of a node (+∞ for an empty slot, NaN for a NaN
/// p): per axis the gap max(lo − p, p − hi, 0).
template <class T>
ISIN_DETAIL_INLINE void box_distances(const typename BvhTree<T>::Node& n, const T (&p)[3], T (&d2)[8]) noexcept {
    for (int k = 0; k < 8; ++k) d2[k] = T(0);
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 8; ++k) {
            const T below = n.lo[a][k] - p[a], above = p[a] - n.hi[a][k];
            const T gap = std::max(std::max(below, above), T(0));
            d2[k] += gap * gap;
        }
}

/// Squared distances from p to the boxes of a block's 8 triangles (all lanes, padding too).
template <class T>
ISIN_DETAIL_INLINE void triangle_box_distances(const TriangleBlock<T>& b, const T (&p)[3], T (&d2)[8]) noexcept {
    for (int k = 0; k < 8; ++k) d2[k] = T(0);
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 8; ++k) {
            const T lo = std::min(std::min(b.v[0][a][k], b.v[1][a][k]), b.v[2][a][k]);
            const T hi = std::max(std::max(b.v[0][a][k], b.v[1][a][k]), b.v[2][a][k]);
            const T gap = std::max(std::max(lo - p[a], p[a] - hi), T(0));
            d2[k] += gap * gap;
        }
}

/// The closest point of the tree's triangles to p within max_distance (PointHit; a miss when
/// none, or for a NaN or infinite p). Of triangles at the same distance, the lowest index.
template <class T>
[[nodiscard]] PointHit<T> closest_point(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks, const Vertex<T>& p,
                                        T max_distance) noexcept {
    PointHit<T> best;
    if (tree.empty() || !is_finite(p) || !(max_distance >= T(0))) return best;
    using Tree = BvhTree<T>;
    const T q[3] = {p.x, p.y, p.z};
    T best2 = max_distance * max_distance; // the sphere's squared radius; +∞ for no bound
    TrianglePoint<T> found{};
    std::uint32_t found_primitive = PointHit<T>::none;
    std::uint32_t found_leaf = 0;
    int found_lane = -1;

    struct Entry {
        T d2;
        std::uint32_t ref;
    };
    Entry stack[Tree::depth_limit * 7 + 8];
    int top = 0;
    stack[top++] = {T(0), 0};
    while (top > 0) {
        const Entry e = stack[--top];
        if (e.d2 > best2) continue; // the sphere shrank below this box since it was pushed
        if (!(e.ref & Tree::leaf_bit)) {
            const typename Tree::Node& n = tree.nodes()[e.ref];
            T d2[8];
            box_distances<T>(n, q, d2);
            // Pushed farthest first (insertion into the stack's top), so the nearest box is
            // walked first and shrinks the sphere; empty slots (+∞) and NaN fail the test.
            const int base = top;
            for (int k = 0; k < 8; ++k) {
                if (!(d2[k] <= best2)) continue;
                int j = top++;
                for (; j > base && stack[j - 1].d2 < d2[k]; --j) stack[j] = stack[j - 1];
                stack[j] = {d2[k], n.child[k]};
            }
            continue;
        }
        const std::uint32_t leaf = e.ref & ~Tree::leaf_bit;
        const typename TriangleBlocks<T>::Block& b = blocks[leaf];
        T box2[8]; // squared distances to the 8 triangles' boxes: the exact test only where they are in reach
        triangle_box_distances(b, q, box2);
        for (int k = 0, live = live_lanes(b); k < live; ++k) {
            if (!(box2[k] <= best2)) continue;
            const Vertex<T> v0{b.v[0][0][k], b.v[0][1][k], b.v[0][2][k]};
            const Vertex<T> v1{b.v[1][0][k], b.v[1][1][k], b.v[1][2][k]};
            const Vertex<T> v2{b.v[2][0][k], b.v[2][1][k], b.v[2][2][k]};
            const TrianglePoint<T> t = closest_on_triangle(p, v0, v1, v2);
            const T d2 = dot(t.gap, t.gap);
            if (d2 < best2 || (d2 == best2 && b.primitive[k] < found_primitive)) {
                best2 = d2, found = t, found_primitive = b.primitive[k], found_leaf = leaf, found_lane = k;
            }
        }
    }
    if (found_lane < 0) return best;
    const typename TriangleBlocks<T>::Block& b = blocks[found_leaf];
    const int k = found_lane;
    const Triangle<T> tri{{b.v[0][0][k], b.v[0][1][k], b.v[0][2][k]},
                          {b.v[1][0][k], b.v[1][1][k], b.v[1][2][k]},
                          {b.v[2][0][k], b.v[2][1][k], b.v[2][2][k]}};
    best.point = triangle_point(tri, found.u, found.v);
    best.distance = std::sqrt(best2);
    best.primitive = found_primitive;
    best.u = found.u, best.v = found.v;
    return best;
}

/// closest_point for points[0, count) into out[0, count), on up to `threads` threads (0 = every
/// core); chunks of 256 points, the same answers as one by one.
template <class T>
void closest_points(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks, const Vertex<T>* points, std::size_t count,
                    PointHit<T>* out, int threads) {
    parallel_chunks(count, thread_count(threads), 256, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i)
            out[i] = closest_point(tree, blocks, points[i], std::numeric_limits<T>::infinity());
    });
}

} // namespace detail
} // namespace isin
