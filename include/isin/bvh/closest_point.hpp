#pragma once
/// isin — the closest point of a Bvh's triangles to a point: a walk of the tree nearest box
/// first, inside a sphere around the point that shrinks to each closer triangle found (boxes
/// farther than the sphere are skipped), each leaf's triangles by Ericson's regions
/// (point_hit.hpp). Bvh::closest_point calls it, and Scene::closest_point for each placed mesh.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "../detail/parallel.hpp"
#include "../point_hit.hpp"
#include "../simd/lanes.hpp"
#include "../simd/sqrt.hpp"
#include "tree.hpp"
#include "triangles.hpp"

namespace isin {
namespace detail {

/// Squared distances from p to 8 boxes given by their corners axis by axis (a node's children:
/// +∞ for an empty slot; NaN for a NaN p): per axis the gap max(lo − p, p − hi, 0), each max
/// std::max's (the first unless the second is larger). In lane vectors: GCC leaves the same
/// loop over 8 floats scalar.
template <class T>
ISIN_DETAIL_INLINE void box_distances(const T (&lo)[3][8], const T (&hi)[3][8], const T (&p)[3], T (&d2)[8]) noexcept {
#if ISIN_VECTOR_EXTENSIONS
    using V = L8<T>;
    V sum = V{}, l, h;
    for (int a = 0; a < 3; ++a) {
        std::memcpy(&l, lo[a], sizeof l);
        std::memcpy(&h, hi[a], sizeof h);
        const V below = l - p[a], above = p[a] - h;
        const V out = below < above ? above : below;
        const V gap = out < V{} ? V{} : out;
        sum += gap * gap;
    }
    std::memcpy(d2, &sum, sizeof d2);
#else
    for (int k = 0; k < 8; ++k) d2[k] = T(0);
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 8; ++k) {
            const T gap = std::max(std::max(lo[a][k] - p[a], p[a] - hi[a][k]), T(0));
            d2[k] += gap * gap;
        }
#endif
}

/// Squared distances from p to the boxes of a block's 8 triangles (all lanes, padding too).
template <class T>
ISIN_DETAIL_INLINE void triangle_box_distances(const TriangleBlock<T>& b, const T (&p)[3], T (&d2)[8]) noexcept {
    alignas(8 * sizeof(T)) T lo[3][8], hi[3][8];
#if ISIN_VECTOR_EXTENSIONS
    using V = L8<T>;
    V c0, c1, c2;
    for (int a = 0; a < 3; ++a) {
        std::memcpy(&c0, b.v[0][a], sizeof c0);
        std::memcpy(&c1, b.v[1][a], sizeof c1);
        std::memcpy(&c2, b.v[2][a], sizeof c2);
        const V lo01 = c1 < c0 ? c1 : c0, hi01 = c0 < c1 ? c1 : c0;
        const V l = c2 < lo01 ? c2 : lo01, h = hi01 < c2 ? c2 : hi01;
        std::memcpy(lo[a], &l, sizeof l);
        std::memcpy(hi[a], &h, sizeof h);
    }
#else
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 8; ++k) {
            const T c0 = b.v[0][a][k], c1 = b.v[1][a][k], c2 = b.v[2][a][k];
            lo[a][k] = std::min(std::min(c0, c1), c2), hi[a][k] = std::max(std::max(c0, c1), c2);
        }
#endif
    box_distances(lo, hi, p, d2);
}

/// Lower bounds of the squared distances from p to a block's 8 triangles (all lanes, padding
/// too): the larger of the distance to each triangle's box and to its plane, |(p − V0)·N|/|N|,
/// the latter less a bound on its rounding error and on that of the exact test, so that it
/// never exceeds the distance closest_on_triangle computes. Overflow and NaN leave the box's.
template <class T>
ISIN_DETAIL_INLINE void triangle_lower_bounds(const TriangleBlock<T>& b, const T (&p)[3], T (&d2)[8]) noexcept {
    triangle_box_distances(b, p, d2);
    T s[8], nn[8], scale2[8], scale[8];
    for (int k = 0; k < 8; ++k) {
        const T ex = b.v[1][0][k] - b.v[0][0][k], ey = b.v[1][1][k] - b.v[0][1][k], ez = b.v[1][2][k] - b.v[0][2][k];
        const T fx = b.v[2][0][k] - b.v[0][0][k], fy = b.v[2][1][k] - b.v[0][1][k], fz = b.v[2][2][k] - b.v[0][2][k];
        const T ax = p[0] - b.v[0][0][k], ay = p[1] - b.v[0][1][k], az = p[2] - b.v[0][2][k];
        const T nx = ey * fz - ez * fy, ny = ez * fx - ex * fz, nz = ex * fy - ey * fx; // §2: N = (V1−V0) × (V2−V0)
        s[k] = ax * nx + ay * ny + az * nz;                                             // (p − V0)·N
        nn[k] = nx * nx + ny * ny + nz * nz;
        const T e2 = ex * ex + ey * ey + ez * ez, f2 = fx * fx + fy * fy + fz * fz;
        scale2[k] = (ax * ax + ay * ay + az * az + e2 + f2) * e2 * f2; // ≥ ((|p − V0| + |E|+|F|)·|E||F|)²/3
    }
    sqrt8(scale2, scale);
    const T eps = std::numeric_limits<T>::epsilon();
#if ISIN_VECTOR_EXTENSIONS // in lane vectors: GCC keeps the division under the condition, one lane at a time
    using V = L8<T>;
    V sv, nv, sc, box;
    std::memcpy(&sv, s, sizeof sv), std::memcpy(&nv, nn, sizeof nv);
    std::memcpy(&sc, scale, sizeof sc), std::memcpy(&box, d2, sizeof box);
    const V gap = (sv < V{} ? -sv : sv) - T(32) * eps * sc;
    const V t = gap < V{} ? V{} : gap;
    const auto slanted = nv > V{};
    const V plane = slanted ? t * t / (slanted ? nv : V{} + T(1)) * (T(1) - T(16) * eps) : V{};
    const V bound = box < plane ? plane : box; // a NaN plane leaves the box's
    std::memcpy(d2, &bound, sizeof d2);
#else
    for (int k = 0; k < 8; ++k) {
        const T t = std::max(std::fabs(s[k]) - T(32) * eps * scale[k], T(0));
        const T plane2 = nn[k] > T(0) ? t * t / nn[k] * (T(1) - T(16) * eps) : T(0);
        d2[k] = std::max(d2[k], plane2); // a NaN plane2 leaves the box's
    }
#endif
}

/// Walks `tree` nearest child first: bound(node, d2) gives lower bounds of the squared distances
/// to a node's 8 children (NaN or +∞ for an empty slot); calls leaf(index) for each leaf within
/// `reach2`, which the leaf may lower (children beyond it are then skipped).
template <class T, class Bound, class Leaf>
ISIN_DETAIL_INLINE void walk_nearest_by(const BvhTree<T>& tree, Bound&& bound, const T& reach2, Leaf&& leaf) noexcept {
    using Tree = BvhTree<T>;
    struct Entry {
        T d2;
        std::uint32_t ref;
    };
    Entry stack[Tree::depth_limit * 7 + 8];
    int top = 0;
    stack[top++] = {T(0), 0};
    while (top > 0) {
        const Entry e = stack[--top];
        if (e.d2 > reach2) continue; // the sphere shrank below this box since it was pushed
        if (!(e.ref & Tree::leaf_bit)) {
            const typename Tree::Node& n = tree.nodes()[e.ref];
            T d2[8];
            bound(n, d2);
            // Pushed farthest first (insertion into the stack's top), so the nearest box is
            // walked first and shrinks the sphere; empty slots (+∞) and NaN fail the test.
            const int base = top;
            for (int k = 0; k < 8; ++k) {
                if (!(d2[k] <= reach2)) continue;
                int j = top++;
                for (; j > base && stack[j - 1].d2 < d2[k]; --j) stack[j] = stack[j - 1];
                stack[j] = {d2[k], n.child[k]};
            }
            continue;
        }
        leaf(e.ref & ~Tree::leaf_bit);
    }
}

/// walk_nearest_by with the distances from the point q to the children's boxes.
template <class T, class Leaf>
ISIN_DETAIL_INLINE void walk_nearest(const BvhTree<T>& tree, const T (&q)[3], const T& reach2, Leaf&& leaf) noexcept {
    walk_nearest_by(
        tree,
        [&q](const typename BvhTree<T>::Node& n, T(&d2)[8])
            ISIN_DETAIL_LAMBDA_INLINE { box_distances<T>(n.lo, n.hi, q, d2); },
        reach2, static_cast<Leaf&&>(leaf));
}

/// Where a walk's triangles stand: in the tree's own space (the Bvh's query). A map that moves
/// them (`moved`) also gives node_bounds(node, q, d2) from the tree-space point q, and
/// block(b, scratch), the block's triangles moved (into scratch).
template <class T>
struct SameSpace {
    static constexpr bool moved = false;
    [[nodiscard]] const TriangleBlock<T>& block(const TriangleBlock<T>& b, TriangleBlock<T>&) const noexcept {
        return b;
    }
};

/// The triangle closest so far in a walk: its squared distance `best2` (the sphere's squared
/// radius, which starts at a bound), where it is on its triangle, and its block and lane.
template <class T>
struct NearestTriangle {
    T best2;
    TrianglePoint<T> found{};
    std::uint32_t primitive = PointHit<T>::none, leaf = 0;
    int lane = -1;
};

/// Tests block `b` (leaf `leaf`'s triangles) against p (`q`: the same, as an array), lowering
/// n.best2.
template <class T>
ISIN_DETAIL_INLINE void nearest_in_leaf(const TriangleBlock<T>& b, std::uint32_t leaf, const T (&q)[3],
                                        const Vertex<T>& p, NearestTriangle<T>& n) noexcept {
    T box2[8]; // lower bounds of the 8 triangles' squared distances: the exact test only where they are in reach
    triangle_lower_bounds(b, q, box2);
    for (int k = 0, live = live_lanes(b); k < live; ++k) {
        if (!(box2[k] <= n.best2)) continue;
        const Vertex<T> v0{b.v[0][0][k], b.v[0][1][k], b.v[0][2][k]};
        const Vertex<T> v1{b.v[1][0][k], b.v[1][1][k], b.v[1][2][k]};
        const Vertex<T> v2{b.v[2][0][k], b.v[2][1][k], b.v[2][2][k]};
        const TrianglePoint<T> t = closest_on_triangle(p, v0, v1, v2);
        const T d2 = dot(t.gap, t.gap);
        if (d2 < n.best2 || (d2 == n.best2 && b.primitive[k] < n.primitive))
            n.best2 = d2, n.found = t, n.primitive = b.primitive[k], n.leaf = leaf, n.lane = k;
    }
}

/// Walks the tree for the triangle closest to p within √n.best2 (lowered as closer ones are
/// found), its triangles placed by `map`; `q_tree` is p in the tree's space.
template <class T, class Map>
ISIN_DETAIL_INLINE void nearest_triangle(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks,
                                         const Vertex<T>& q_tree, const Vertex<T>& p, const Map& map,
                                         NearestTriangle<T>& n) noexcept {
    const T q[3] = {q_tree.x, q_tree.y, q_tree.z};
    if constexpr (Map::moved) {
        const T pw[3] = {p.x, p.y, p.z};
        TriangleBlock<T> scratch;
        walk_nearest_by(
            tree,
            [&](const typename BvhTree<T>::Node& node, T(&d2)[8])
                ISIN_DETAIL_LAMBDA_INLINE { map.node_bounds(node, q, d2); },
            n.best2,
            [&](std::uint32_t leaf)
                ISIN_DETAIL_LAMBDA_INLINE { nearest_in_leaf(map.block(blocks[leaf], scratch), leaf, pw, p, n); });
    } else {
        walk_nearest(tree, q, n.best2, [&](std::uint32_t leaf) ISIN_DETAIL_LAMBDA_INLINE {
            nearest_in_leaf(blocks[leaf], leaf, q, p, n);
        });
    }
}

/// The PointHit a walk found (a miss when nothing): the point on the triangle placed by `map`.
template <class T, class Map>
[[nodiscard]] PointHit<T> point_hit_of(const TriangleBlocks<T>& blocks, const Map& map,
                                       const NearestTriangle<T>& n) noexcept {
    PointHit<T> best;
    if (n.lane < 0) return best; // nothing within the start radius
    TriangleBlock<T> scratch;
    const TriangleBlock<T>& b = map.block(blocks[n.leaf], scratch);
    const int k = n.lane;
    const Triangle<T> tri{{b.v[0][0][k], b.v[0][1][k], b.v[0][2][k]},
                          {b.v[1][0][k], b.v[1][1][k], b.v[1][2][k]},
                          {b.v[2][0][k], b.v[2][1][k], b.v[2][2][k]}};
    best.point = triangle_point(tri, n.found.u, n.found.v);
    best.distance = std::sqrt(n.best2);
    best.primitive = n.primitive;
    best.u = n.found.u, best.v = n.found.v;
    return best;
}

/// closest_point (below) with the sphere's squared radius starting at `start2` (max_distance²,
/// or less: a bound known to hold the answer).
template <class T>
[[nodiscard]] PointHit<T> closest_point_within(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks,
                                               const Vertex<T>& p, T start2) noexcept {
    NearestTriangle<T> n{start2};
    nearest_triangle(tree, blocks, p, p, SameSpace<T>{}, n);
    return point_hit_of(blocks, SameSpace<T>{}, n);
}

/// The closest point of the tree's triangles to p within max_distance (PointHit; a miss when
/// none, or for a NaN or infinite p). Of triangles at the same distance, the lowest index.
template <class T>
[[nodiscard]] PointHit<T> closest_point(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks, const Vertex<T>& p,
                                        T max_distance) noexcept {
    if (tree.empty() || !is_finite(p) || !(max_distance >= T(0))) return PointHit<T>{};
    return closest_point_within(tree, blocks, p, max_distance * max_distance);
}

/// The position of p along a Morton (Z-order) curve through `box`, 10 bits an axis; NaN and
/// points outside the box clamp to its faces.
template <class T>
[[nodiscard]] inline std::uint32_t morton_code(const Vertex<T>& p, const Box<T>& box) noexcept {
    std::uint32_t code = 0;
    const T c[3] = {p.x, p.y, p.z}, lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
    for (int a = 0; a < 3; ++a) {
        const T x = hi[a] > lo[a] ? (c[a] - lo[a]) / (hi[a] - lo[a]) * T(1023) : T(0);
        auto cell = static_cast<std::uint32_t>(x >= T(0) ? std::min(x, T(1023)) : T(0)); // NaN: 0
        cell = (cell | (cell << 16)) & 0x030000ffu;                                      // spread the 10 bits two apart
        cell = (cell | (cell << 8)) & 0x0300f00fu;
        cell = (cell | (cell << 4)) & 0x030c30c3u;
        cell = (cell | (cell << 2)) & 0x09249249u;
        code |= cell << a;
    }
    return code;
}

/// The indices 0 … count − 1 of `points` in Morton order through their (finite points') box;
/// NaN and infinite points anywhere.
template <class T>
[[nodiscard]] std::vector<std::size_t> morton_order(const Vertex<T>* points, std::size_t count) {
    Box<T> box;
    for (std::size_t i = 0; i < count; ++i)
        if (is_finite(points[i])) box.grow(points[i]);
    std::vector<std::pair<std::uint32_t, std::size_t>> keyed(count);
    for (std::size_t i = 0; i < count; ++i) keyed[i] = {morton_code(points[i], box), i};
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::size_t> order(count);
    for (std::size_t i = 0; i < count; ++i) order[i] = keyed[i].second;
    return order;
}

/// closest_point for points[0, count) into out[0, count), on up to `threads` threads (0 = every
/// core), the same answers as one by one. The points are taken in Morton order, and each
/// query's sphere starts at the distance from its point to the previous point's answer (which
/// bounds its own), a little enlarged for rounding; when that finds nothing, the query is
/// repeated without the bound, so no answer depends on the order.
template <class T>
void closest_points(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks, const Vertex<T>* points, std::size_t count,
                    PointHit<T>* out, int threads) {
    const T inf = std::numeric_limits<T>::infinity();
    const std::vector<std::size_t> order = morton_order(points, count);
    parallel_chunks(count, thread_count(threads), 256, [&](std::size_t begin, std::size_t end) {
        const PointHit<T>* previous = nullptr;
        for (std::size_t j = begin; j < end; ++j) {
            const std::size_t i = order[j];
            const Vertex<T>& p = points[i];
            if (tree.empty() || !is_finite(p)) {
                out[i] = PointHit<T>{};
                continue;
            }
            T start2 = inf;
            if (previous != nullptr && *previous) {
                // |p − q| bounds p's distance; q (the neighbour's answer) is rounded to T, and the
                // walk's own distances carry rounding too: 1e-3 relative and a few ulps of the
                // coordinates keep the answer inside.
                const Vertex<T> q = previous->point;
                const T slack = T(64) * std::numeric_limits<T>::epsilon() * (max_abs(p) + max_abs(q));
                const T d = length(p - q) * T(1.001) + slack;
                start2 = d * d;
            }
            out[i] = closest_point_within(tree, blocks, p, start2);
            if (!out[i] && start2 < inf) out[i] = closest_point_within(tree, blocks, p, inf);
            previous = &out[i];
        }
    });
}

} // namespace detail
} // namespace isin
