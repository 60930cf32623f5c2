#pragma once
/// isin — traversing a BvhTree with the caller's leaf test: ordered front-to-back for the
/// nearest hit, unordered for any hit or all hits, one 8-lane slab test per node.
///
///     float t_max = inf;   // the leaf lowers it to its nearest hit
///     isin::traverse<isin::Visit::nearest>(tree, ray, t_max, [&](std::uint32_t leaf, float& t) {
///         for (auto i : range of tree.leaves()[leaf]) { /* test primitive, lower t */ }
///         return false;   // true would stop the traversal
///     });
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "../detail/attributes.hpp"
#include "../ray.hpp"
#include "box.hpp"
#include "tree.hpp"

#if defined(__AVX__) && !defined(ISIN_FORCE_PURE)
#include <immintrin.h>
#define ISIN_DETAIL_SLABS_AVX 1
#endif

namespace isin {

/// How a traversal visits leaves: `nearest` front to back, skipping boxes entered beyond t_max,
/// which the leaf lowers to its nearest hit; `any` in no particular order (a first hit for
/// shadows, every hit for transmittance).
enum class Visit { nearest, any };

namespace detail {

template <class T>
struct SlabRay {
    T org[3], inv[3]; // inv is ±∞ for a ±0 direction component
    // inv·(1 + 2γ₃) for exit distances (Ize 2013, pbrt): however p·inv − o·inv is rounded
    // (inv, this product, the FMA or the difference and product: each at most u relative),
    // the exit distance comes out no smaller than the exact one, so rounding never drops a
    // box that the ray touches and the traversal stays as watertight as the triangle test.
    T inv_far[3];
    // o·inv raised by 4ε|o·inv| (entries come out no later) and o·inv_far lowered by
    // 4ε|o·inv_far| (exits no earlier): more than their own rounding can move a distance
    // computed as p·inv − o·inv in one FMA.
    T org_inv_near[3], org_inv_far[3];
    // byte offsets in a node of the entry and exit planes of each axis (lo or hi, by sign)
    std::size_t near_plane[3], far_plane[3];
    bool ok;
    // The slab test's form for this ray. Fast: p·inv − o·inv in one FMA, when no product can
    // overflow (every inv finite, |p|·|inv| and |o|·|inv| well below the largest T for every
    // p of the tree). Robust otherwise (a direction component 0 or tiny, coordinates near
    // the largest T): (p − o)·inv, which gives ±∞ but no NaN except 0·∞ for a ray in a slab's
    // plane, and that NaN is ignored by the min/max (the slab does not bound the ray).
    bool robust;
};

// 1 + 2γ₃, γ₃ = 3u/(1 − 3u): SlabRay::inv_far = inv·slab_widen (Ize 2013, pbrt).
template <class T>
inline constexpr T slab_widen = T(1) + T(2) * (T(3) * (std::numeric_limits<T>::epsilon() / 2) /
                                               (T(1) - T(3) * (std::numeric_limits<T>::epsilon() / 2)));
// SlabRay's allowance on o·inv, relative: 4ε.
template <class T>
inline constexpr T slab_allowance = T(4) * std::numeric_limits<T>::epsilon();

// SlabRay's byte offsets in a node of axis a's entry and exit planes: lo and hi for a direction
// component whose sign bit is clear, hi and lo for one whose sign bit is set (−0.0 too).
template <class T>
ISIN_DETAIL_INLINE void slab_planes(int a, bool negative, std::size_t& near, std::size_t& far) noexcept {
    using Node = typename BvhTree<T>::Node;
    const std::size_t lo = std::size_t(a) * sizeof(Node::lo[0]), hi = sizeof(Node::lo) + lo;
    near = negative ? hi : lo;
    far = negative ? lo : hi;
}

// Per-ray set-up, with as few branches as it can: most rays of a frame cost a few node
// visits, so this is a fair part of their time.
template <class T>
ISIN_DETAIL_INLINE SlabRay<T> prepare_slab(const Ray<T>& ray, T bound) noexcept {
    SlabRay<T> r;
    const Vertex<T>& o = ray.origin;
    const Vertex<T>& d = ray.direction;
    const T ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
    // x − x is 0 for a finite x and NaN otherwise
    const T finite = ((o.x - o.x) + (o.y - o.y)) + ((o.z - o.z) + (d.x - d.x)) + ((d.y - d.y) + (d.z - d.z));
    r.ok = (finite == T(0)) & (std::max(ax, std::max(ay, az)) > T(0));
    constexpr T no_overflow = std::numeric_limits<T>::max() / T(8);
    bool fast = true;
    for (int a = 0; a < 3; ++a) {
        const T da = component(d, a);
        r.org[a] = component(o, a);
        r.inv[a] = T(1) / da;
        r.inv_far[a] = r.inv[a] * slab_widen<T>;
        fast &= std::max(bound, std::fabs(r.org[a])) * std::fabs(r.inv_far[a]) < no_overflow; // false for ∞
        const T org_inv = r.org[a] * r.inv[a], org_inv_far = r.org[a] * r.inv_far[a];
        r.org_inv_near[a] = org_inv + slab_allowance<T> * std::fabs(org_inv);
        r.org_inv_far[a] = org_inv_far - slab_allowance<T> * std::fabs(org_inv_far);
        slab_planes<T>(a, std::signbit(da), r.near_plane[a], r.far_plane[a]);
    }
    r.robust = !fast;
    return r;
}

// The 8 lanes of a plane of `n` at byte `offset` (SlabRay::near_plane, far_plane).
template <class T, class Node>
inline const T* plane(const Node& n, std::size_t offset) noexcept {
    return reinterpret_cast<const T*>(reinterpret_cast<const char*>(&n) + offset);
}

// Slab test of the 8 children: bit k set when child k's box is entered before `t_far`.
// Exits are computed with SlabRay::inv_far, so that no rounding drops a box the ray touches.
// `robust` selects SlabRay::robust's form; the portable forms are always robust. Every
// max/min takes the slab's value first: a NaN there yields the other operand.
template <bool robust, class T>
ISIN_DETAIL_INLINE unsigned hit_children(const typename BvhTree<T>::Node& n, const SlabRay<T>& r, T t_far,
                                         T (&t_near)[8]) noexcept {
#if defined(ISIN_DETAIL_SLABS_AVX)
    if constexpr (sizeof(T) == sizeof(float)) { // 8 boxes in one 256-bit register per plane
        __m256 t0[3], t1[3];                    // entry and exit distances of each axis' slab
        // Axis by axis, written out: as a loop, g++ -O2 kept t0 and t1 on the stack.
        const auto slab = [&](int a) {
            const __m256 near_plane = _mm256_load_ps(plane<T>(n, r.near_plane[a]));
            const __m256 far_plane = _mm256_load_ps(plane<T>(n, r.far_plane[a]));
#if defined(__FMA__)
            if constexpr (!robust) {
                // p·inv − o·inv in one FMA; o·inv is rounded, so the entry subtracts and the
                // exit adds the per-ray allowance (prepare: org_inv_near / org_inv_far).
                t0[a] = _mm256_fmsub_ps(near_plane, _mm256_set1_ps(float(r.inv[a])),
                                        _mm256_set1_ps(float(r.org_inv_near[a])));
                t1[a] = _mm256_fmsub_ps(far_plane, _mm256_set1_ps(float(r.inv_far[a])),
                                        _mm256_set1_ps(float(r.org_inv_far[a])));
                return;
            }
#endif
            const __m256 org = _mm256_set1_ps(float(r.org[a]));
            t0[a] = _mm256_mul_ps(_mm256_sub_ps(near_plane, org), _mm256_set1_ps(float(r.inv[a])));
            t1[a] = _mm256_mul_ps(_mm256_sub_ps(far_plane, org), _mm256_set1_ps(float(r.inv_far[a])));
        };
        slab(0), slab(1), slab(2);
        __m256 tn, tf;
        if constexpr (robust) { // _mm256_max_ps(a, b) is b when either is NaN
            tn = _mm256_max_ps(t0[2], _mm256_max_ps(t0[1], _mm256_max_ps(t0[0], _mm256_setzero_ps())));
            tf = _mm256_min_ps(t1[2], _mm256_min_ps(t1[1], _mm256_min_ps(t1[0], _mm256_set1_ps(float(t_far)))));
        } else { // two levels of max / min, not three: this is the traversal's critical path
            tn = _mm256_max_ps(_mm256_max_ps(t0[0], t0[1]), _mm256_max_ps(t0[2], _mm256_setzero_ps()));
            tf = _mm256_min_ps(_mm256_min_ps(t1[0], t1[1]), _mm256_min_ps(t1[2], _mm256_set1_ps(float(t_far))));
        }
        _mm256_storeu_ps(reinterpret_cast<float*>(t_near), tn);
        return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)));
    }
#endif
#if ISIN_VECTOR_EXTENSIONS
    using V = detail::L8<T>;
    V tn = V{}, tf = V{} + t_far, near_plane, far_plane;
    for (int a = 0; a < 3; ++a) {
        std::memcpy(&near_plane, plane<T>(n, r.near_plane[a]), sizeof near_plane);
        std::memcpy(&far_plane, plane<T>(n, r.far_plane[a]), sizeof far_plane);
        const V near = (near_plane - r.org[a]) * r.inv[a], far = (far_plane - r.org[a]) * r.inv_far[a];
        tn = near > tn ? near : tn;
        tf = far < tf ? far : tf;
    }
    std::memcpy(t_near, &tn, sizeof t_near);
    const auto inside = tn <= tf;
    unsigned mask = 0;
    for (int k = 0; k < 8; ++k) mask |= unsigned(inside[k] != 0) << k;
    return mask;
#else
    unsigned mask = 0;
    for (int k = 0; k < 8; ++k) {
        T tn = T(0), tf = t_far;
        for (int a = 0; a < 3; ++a) {
            const T near = (plane<T>(n, r.near_plane[a])[k] - r.org[a]) * r.inv[a];
            const T far = (plane<T>(n, r.far_plane[a])[k] - r.org[a]) * r.inv_far[a];
            tn = near > tn ? near : tn;
            tf = far < tf ? far : tf;
        }
        t_near[k] = tn;
        mask |= unsigned(tn <= tf) << k;
    }
    return mask;
#endif
}

// One ray's walk through the tree a step at a time: a step tests a node's children and pushes
// them, or calls a leaf; then, when that gives no next node, pops the next entry entered before
// t_max. walk runs one walker to its end; traverse_pair interleaves two.
// The ray's slab terms are read through a reference: each node's test then broadcasts them from
// memory (a load µop), where a copy held in registers is broadcast by a shuffle µop per term.
template <Visit visit, bool robust, class T, class Leaf>
struct Walker {
    using Node = typename BvhTree<T>::Node;
    static constexpr std::uint32_t leaf_bit = BvhTree<T>::leaf_bit;
    struct Entry {
        std::uint32_t ref;
        T t;
    };
    const Node* nodes;
    const SlabRay<T>& r;
    T& t_max;
    Leaf& leaf;
    std::uint32_t ref;                            // the node or leaf being visited
    int top = 0;                                  // entries on the stack
    bool stopped = false;                         // a leaf stopped the walk
    Entry stack[7 * BvhTree<T>::depth_limit + 1]; // 7 entries a level at most

    Walker(const BvhTree<T>& tree, const SlabRay<T>& ray, T& t, Leaf& l, std::uint32_t root) noexcept
        : nodes(tree.nodes().data()), r(ray), t_max(t), leaf(l), ref(root) {}

    // One step; false when the walk is over (the stack is empty, or a leaf stopped it).
    ISIN_DETAIL_INLINE bool step() {
        constexpr bool any_hit = visit == Visit::any;
        if (ref & leaf_bit) {
            if (leaf(ref & ~leaf_bit, t_max)) return !(stopped = true);
        } else {
            const Node& n = nodes[ref];
            T t_near[8];
            unsigned mask = hit_children<robust>(n, r, t_max, t_near);
            if (mask) {
                int k = lowest_bit(mask);
                mask &= mask - 1;
                if (!mask) { // one child: go on with it directly
                    ref = n.child[k];
                    return true;
                }
                if (any_hit) { // any hit will do: no ordering, push the others as they come
                    const std::uint32_t first_child = n.child[k];
                    while (mask) {
                        k = lowest_bit(mask);
                        mask &= mask - 1;
                        stack[top++] = {n.child[k], t_near[k]};
                    }
                    ref = first_child;
                    return true;
                }
                // Two: push the farther, visit the nearer (the common case, no loop).
                const Entry c0{n.child[k], t_near[k]};
                k = lowest_bit(mask);
                mask &= mask - 1;
                const Entry c1{n.child[k], t_near[k]};
                if (!mask) {
                    const bool near0 = c0.t < c1.t;
                    stack[top++] = near0 ? c1 : c0;
                    ref = near0 ? c0.ref : c1.ref;
                    return true;
                }
                // More: push all, sort them on the stack farthest first, visit the nearest.
                const int first = top;
                stack[top++] = c0, stack[top++] = c1;
                while (mask) {
                    k = lowest_bit(mask);
                    mask &= mask - 1;
                    stack[top++] = {n.child[k], t_near[k]};
                }
                for (int i = first + 1; i < top; ++i) { // insertion sort, descending t
                    const Entry c = stack[i];
                    int j = i;
                    while (j > first && stack[j - 1].t < c.t) stack[j] = stack[j - 1], --j;
                    stack[j] = c;
                }
                ref = stack[--top].ref;
                return true;
            }
        }
        // Pop the next entry that is entered before the nearest hit so far.
        for (;;) {
            if (top == 0) return false;
            const Entry e = stack[--top];
            if (e.t < t_max) {
                ref = e.ref;
                return true;
            }
        }
    }
};

// The leaves the ray enters from node `root` on, as traverse. Returns true when a leaf stopped it.
template <Visit visit, bool robust, class T, class Leaf>
bool walk(const BvhTree<T>& tree, const SlabRay<T>& r, T& t_max, Leaf& leaf, std::uint32_t root = 0) {
    Walker<visit, robust, T, Leaf> w(tree, r, t_max, leaf, root);
    while (w.step()) {}
    return w.stopped;
}

// walk in the slab test's form the ray needs.
template <Visit visit, class T, class Leaf>
bool walk_ray(const BvhTree<T>& tree, const SlabRay<T>& r, T& t_max, Leaf& leaf) {
    return r.robust ? walk<visit, true>(tree, r, t_max, leaf) : walk<visit, false>(tree, r, t_max, leaf);
}

// traverse_pair from the rays' slab terms (a non-empty tree): bit 0 when leaf_a stopped ray a,
// bit 1 when leaf_b stopped ray b. Each walker's node test (hit_children) and the Bvh's leaf
// tests are always inlined: in this loop of two walkers g++ 12 called them out of line, and the
// calls cost the pairs all they gain over one ray at a time. How much g++ inlines depends on the
// translation unit (in a large one it called lanes_hit, Sheared8, finish8 and skip_lanes from
// the nearest-hit pairs), so the leaf tests are forced inline down to their lane arithmetic
// (test_block's comment lists them).
template <Visit visit, class T, class LeafA, class LeafB>
unsigned walk_pair(const BvhTree<T>& tree, const SlabRay<T>& a, T& t_a, LeafA& leaf_a, const SlabRay<T>& b, T& t_b,
                   LeafB& leaf_b) {
    const bool go_a = a.ok && t_a > T(0), go_b = b.ok && t_b > T(0);
    if (go_a && go_b && !a.robust && !b.robust) {
        Walker<visit, false, T, LeafA> wa(tree, a, t_a, leaf_a, 0);
        Walker<visit, false, T, LeafB> wb(tree, b, t_b, leaf_b, 0);
        bool on_a = true, on_b = true;
        while (on_a && on_b) on_a = wa.step(), on_b = wb.step();
        while (on_a) on_a = wa.step();
        while (on_b) on_b = wb.step();
        return (wa.stopped ? 1u : 0u) | (wb.stopped ? 2u : 0u);
    }
    const bool stopped_a = go_a && walk_ray<visit>(tree, a, t_a, leaf_a);
    const bool stopped_b = go_b && walk_ray<visit>(tree, b, t_b, leaf_b);
    return (stopped_a ? 1u : 0u) | (stopped_b ? 2u : 0u);
}

} // namespace detail

/// Visits the leaves of `tree` whose boxes the ray enters with t in (0, t_max), calling
/// `leaf(leaf_index, t_max)` for each (a BvhTree::leaves() index); the leaf returns true to
/// stop the traversal, and may lower t_max (a nearest-hit search does) so that farther boxes are
/// skipped. Returns true when a leaf stopped it. Any direction works (t in units of
/// |direction|); a ray with a NaN or infinite origin or direction, or a zero direction, visits
/// nothing. Box tests are conservative: rounding never skips a box the ray touches, so a
/// watertight leaf test stays watertight. Exceptions from the leaf pass through.
template <Visit visit, class T, class Leaf>
bool traverse(const BvhTree<T>& tree, const Ray<T>& ray, T& t_max, Leaf&& leaf) {
    if (tree.empty() || !(t_max > T(0))) return false;
    const detail::SlabRay<T> r = detail::prepare_slab(ray, tree.bound());
    if (!r.ok) return false;
    return detail::walk_ray<visit>(tree, r, t_max, leaf);
}

/// traverse for two rays at once, their steps interleaved: each ray visits the same leaves in
/// the same order as alone, with the same results, but the two chains of dependent node loads
/// overlap (for rays that go their own ways: a bounce off a surface, rays of a shuffled stream).
/// Returns bit 0 when leaf_a stopped ray a, bit 1 when leaf_b stopped ray b.
template <Visit visit, class T, class LeafA, class LeafB>
unsigned traverse_pair(const BvhTree<T>& tree, const Ray<T>& ray_a, T& t_a, LeafA&& leaf_a, const Ray<T>& ray_b, T& t_b,
                       LeafB&& leaf_b) {
    if (tree.empty()) return 0;
    return detail::walk_pair<visit>(tree, detail::prepare_slab(ray_a, tree.bound()), t_a, leaf_a,
                                    detail::prepare_slab(ray_b, tree.bound()), t_b, leaf_b);
}

} // namespace isin
