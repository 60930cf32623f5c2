#pragma once
/// isin — a bounding volume hierarchy over triangles: binned SAH build (multi-threaded where it
/// pays), collapsed to 8-wide nodes for the least SAH cost, ordered front-to-back traversal with
/// an 8-lane slab test,
/// leaves of up to 8 triangles tested 8 at a time by the watertight test (Woop, Benthin & Wald
/// 2013). Float and double. The SIMD width follows the compiler's target (SSE, AVX2, AVX-512)
/// through GCC/Clang vector extensions; other compilers get a portable scalar loop.
///
///     isin::Bvh<float> bvh{triangles};          // std::vector<isin::Triangle<float>>
///     if (auto h = bvh.intersect(ray)) use(h.t, h.u, h.v, h.primitive);
///     bool shadowed = bvh.occluded(shadow_ray, distance_to_light);
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "detail/parallel.hpp"
#include "ray.hpp"
#include "triangle.hpp"
#include "vec.hpp"

#if defined(__GNUC__) || defined(__clang__)
#define ISIN_VECTOR_EXTENSIONS 1
#else
#define ISIN_VECTOR_EXTENSIONS 0
#endif
#if defined(__AVX__)
#include <immintrin.h>
#endif
#if defined(__GNUC__) || defined(__clang__)
#define ISIN_DETAIL_COLD __attribute__((noinline, cold)) // a rare path kept out of the hot loop
#else
#define ISIN_DETAIL_COLD
#endif

namespace isin {

/// The nearest hit in a Bvh: t, barycentrics u, v (weights of V1, V2) and the index of the
/// triangle in the vector the Bvh was built from. A miss has t = +∞ and converts to false.
template <class T>
struct BvhHit {
    T t = std::numeric_limits<T>::infinity();
    T u = T(0), v = T(0);
    std::uint32_t primitive = ~std::uint32_t(0);
    explicit operator bool() const noexcept { return t < std::numeric_limits<T>::infinity(); }
};

/// Build options of a Bvh.
struct BvhOptions {
    int threads = 0;     ///< build threads; 0 = std::thread::hardware_concurrency()
    int leaf_size = 8;   ///< SAH leaves hold at most this many triangles (1…8)
};

namespace detail {

// Eight lanes of T as a GCC/Clang vector. Values of this type never cross a function boundary
// (that would depend on the target's vector ABI); all lane code is written inline.
#if ISIN_VECTOR_EXTENSIONS
template <class T> struct Lanes8 { typedef T type __attribute__((vector_size(8 * sizeof(T)))); };
template <class T> using L8 = typename Lanes8<T>::type;
#endif

template <class T>
struct Box {
    Vertex<T> lo{std::numeric_limits<T>::infinity(), std::numeric_limits<T>::infinity(), std::numeric_limits<T>::infinity()};
    Vertex<T> hi{-std::numeric_limits<T>::infinity(), -std::numeric_limits<T>::infinity(), -std::numeric_limits<T>::infinity()};
    void grow(const Vertex<T>& p) noexcept {
        lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
        hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    void grow(const Box& b) noexcept { // the union; an empty b (lo = +∞, hi = −∞) changes nothing
        lo = {std::min(lo.x, b.lo.x), std::min(lo.y, b.lo.y), std::min(lo.z, b.lo.z)};
        hi = {std::max(hi.x, b.hi.x), std::max(hi.y, b.hi.y), std::max(hi.z, b.hi.z)};
    }
    /// The SAH's measure of the surface: a quarter of the half area, from half extents, so that
    /// no box of finite coordinates gives NaN (an extent hi − lo would overflow for coordinates
    /// beyond ±max/2, and ∞·0 is NaN). Boxes wider than about √max (1.8e19 in float) measure +∞:
    /// their costs compare as unknown and the build splits them at the median. Only ratios of
    /// it matter. 0 for an empty box.
    using Area = T;
    [[nodiscard]] T area() const noexcept {
        const Vertex<T> e = hi * T(0.5) - lo * T(0.5);
        return e.x < T(0) ? T(0) : e.x * e.y + e.y * e.z + e.z * e.x;
    }
};

// A box as two 4-lane vectors (x, y, z, unused), so that growing it is two vector min/max: the
// binning loop's inner operation. Falls back to scalar lanes without vector extensions.
#if ISIN_VECTOR_EXTENSIONS
template <class T> struct Lanes4 { typedef T type __attribute__((vector_size(4 * sizeof(T)))); };
template <class T> using L4 = typename Lanes4<T>::type;
#else
template <class T> struct L4 {
    T v[4];
    T& operator[](int i) noexcept { return v[i]; }
    const T& operator[](int i) const noexcept { return v[i]; }
};
#endif
template <class T>
struct Box4 {
    L4<T> lo, hi;
    Box4() noexcept {
        for (int a = 0; a < 4; ++a) lo[a] = std::numeric_limits<T>::infinity(), hi[a] = -std::numeric_limits<T>::infinity();
    }
    void grow(const L4<T>& plo, const L4<T>& phi) noexcept {
#if ISIN_VECTOR_EXTENSIONS
        lo = lo < plo ? lo : plo;
        hi = hi > phi ? hi : phi;
#else
        for (int a = 0; a < 4; ++a) lo[a] = std::min(lo[a], plo[a]), hi[a] = std::max(hi[a], phi[a]);
#endif
    }
    void grow(const Box4& b) noexcept { grow(b.lo, b.hi); }
    [[nodiscard]] Box<T> box() const noexcept {
        Box<T> b;
        if (lo[0] <= hi[0]) b.lo = {lo[0], lo[1], lo[2]}, b.hi = {hi[0], hi[1], hi[2]};
        return b;
    }
};

// An allocator whose value-less construct() leaves trivial values uninitialised, so that
// resizing a vector that the build then fills in parallel does not first zero it serially.
template <class T>
struct UninitAllocator : std::allocator<T> {
    template <class U> struct rebind { using other = UninitAllocator<U>; };
    UninitAllocator() = default;
    template <class U> UninitAllocator(const UninitAllocator<U>&) noexcept {}
    template <class U> void construct(U* p) noexcept { ::new (static_cast<void*>(p)) U; }
    template <class U, class... A> void construct(U* p, A&&... a) { ::new (static_cast<void*>(p)) U(std::forward<A>(a)...); }
};

// A node of the binary SAH tree, before it is collapsed to 8-wide nodes.
template <class T>
struct BinaryNode {
    Box<T> box;
    std::unique_ptr<BinaryNode> left, right;
    std::uint32_t first = 0, count = 0; // a range of the build's primitive order
    // The collapse's plan (Bvh::plan): cost[j − 1] is the least SAH cost of this subtree as at
    // most j children of an 8-wide node; how[j − 1] says how: 0 one child (an 8-wide node, or
    // this leaf), `merged` one leaf holding the whole subtree, i in 1…7: i children from the
    // left subtree and up to j − i from the right. An 8-wide node made here takes wide_split
    // children from the left subtree and up to 8 − wide_split from the right.
    static constexpr std::uint8_t merged = 0xff;
    typename Box<T>::Area cost[8] = {};
    std::uint8_t how[8] = {};
    std::uint8_t wide_split = 1;
    [[nodiscard]] bool leaf() const noexcept { return !left; }
    [[nodiscard]] bool becomes_leaf() const noexcept { return !left || how[0] == merged; }
};

} // namespace detail

/// Bounding volume hierarchy over triangles; see the top of this header.
template <class T>
class Bvh {
    static_assert(std::is_floating_point_v<T>, "isin::Bvh needs float or double");

public:
    /// Builds over `triangles`; hits report indices into this vector. Zero-area and non-finite
    /// triangles are left out (no ray can hit them).
    explicit Bvh(const std::vector<Triangle<T>>& triangles, const BvhOptions& options = {}) {
        build(triangles, options);
    }

    /// Nearest hit with t in (0, t_max), watertight: a ray through an edge shared by two
    /// triangles hits at least one of them. Any direction works (t in units of |direction|).
    [[nodiscard]] BvhHit<T> intersect(const Ray<T>& ray,
                                      T t_max = std::numeric_limits<T>::infinity()) const noexcept {
        BvhHit<T> best;
        best.t = t_max;
        traverse<false>(ray, best);
        if (!(best.t < t_max)) return BvhHit<T>{};
        return best;
    }

    /// True when any triangle is hit with t in (0, t_max): shadow rays; stops at the first hit.
    [[nodiscard]] bool occluded(const Ray<T>& ray, T t_max) const noexcept {
        BvhHit<T> any;
        any.t = t_max;
        return traverse<true>(ray, any);
    }

    /// Number of triangles the Bvh holds (after leaving out degenerate ones).
    [[nodiscard]] std::size_t size() const noexcept { return primitives_; }
    /// Number of 8-wide nodes and of leaf blocks.
    [[nodiscard]] std::size_t node_count() const noexcept { return nodes_.size(); }
    [[nodiscard]] std::size_t leaf_count() const noexcept { return blocks_.size(); }
    /// Levels of 8-wide nodes on the longest path from the root to a leaf (0 when empty). Never
    /// above depth_limit, whatever the triangles: the build splits at the median below a fixed
    /// depth, and primitives are counted in 32 bits.
    [[nodiscard]] int depth() const noexcept { return nodes_.empty() ? 0 : depth_below(0); }
    static constexpr int depth_limit = 40 + 32;

private:
    static constexpr std::uint32_t leaf_bit = 0x80000000u;
    static constexpr std::uint32_t empty_child = 0xffffffffu;
    // SAH costs per unit of box area of visiting an 8-wide node and of testing a leaf block.
    using Area = typename detail::Box<T>::Area;
    static constexpr Area node_cost = Area(1), leaf_cost = Area(1);

    // 8 children: boxes in structure-of-arrays order, child references (node index, or leaf
    // block index | leaf_bit, or empty_child whose box is empty: lo = +∞ > hi = −∞).
    struct alignas(64) Node {
        T lo[3][8], hi[3][8];
        std::uint32_t child[8];
    };
    // Up to 8 triangles, vertex-major, structure-of-arrays. Unused lanes (padding) repeat lane 0,
    // triangle and index: a hit there ties with lane 0's, which wins, so lane tests need no mask
    // for them, and their values are as trustworthy as lane 0's.
    struct alignas(64) Block {
        T v[3][3][8]; // [vertex][axis][lane]
        std::uint32_t primitive[8];
    };

    struct Prim {
        detail::L4<T> lo, hi, centroid; // lanes x, y, z, unused
        std::uint32_t index;
        [[nodiscard]] T center(int axis) const noexcept { return centroid[axis]; }
    };
    using Prims = std::vector<Prim, detail::UninitAllocator<Prim>>;

    // ---- build -------------------------------------------------------------------------
    void build(const std::vector<Triangle<T>>& triangles, const BvhOptions& options) {
        triangles_ = &triangles;
        const int threads = detail::thread_count(options.threads);
        // The primitives (box, centroid) of the triangles, in chunks; unusable triangles (not
        // finite, zero area) are marked and then left out.
        Prims prims(triangles.size());
        std::atomic<bool> unusable{false};
        detail::parallel_chunks(triangles.size(), threads, parallel_min, [&](std::size_t begin, std::size_t end) {
            bool skipped = false;
            for (std::size_t i = begin; i < end; ++i) {
                const Triangle<T>& tri = triangles[i];
                Prim& p = prims[i];
                p.index = empty_child;
                const Vertex<T> e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
                if (!is_finite(tri.v0) || !is_finite(tri.v1) || !is_finite(tri.v2) ||
                    detail::is_degenerate(e1, e2, cross(e1, e2))) {
                    skipped = true;
                    continue;
                }
                detail::Box<T> b;
                b.grow(tri.v0), b.grow(tri.v1), b.grow(tri.v2);
                for (int a = 0; a < 3; ++a) {
                    p.lo[a] = component(b.lo, a), p.hi[a] = component(b.hi, a);
                    p.centroid[a] = p.lo[a] * T(0.5) + p.hi[a] * T(0.5); // (lo + hi)/2 would overflow above max/2
                }
                p.lo[3] = p.hi[3] = p.centroid[3] = T(0);
                p.index = static_cast<std::uint32_t>(i);
            }
            if (skipped) unusable = true;
        });
        if (unusable)
            prims.erase(std::remove_if(prims.begin(), prims.end(), [](const Prim& p) { return p.index == empty_child; }),
                        prims.end());
        primitives_ = prims.size();
        nodes_.clear(), blocks_.clear();
        bound_ = T(0);
        if (prims.empty()) return;
        leaf_size_ = std::clamp(options.leaf_size, 1, 8);
        std::atomic<int> threads_left{threads - 1};
        detail::Box4<T> box, centroids;
        for (const Prim& p : prims) box.grow(p.lo, p.hi), centroids.grow(p.centroid, p.centroid);
        const detail::Box<T> root_box = box.box();
        bound_ = std::max(max_abs(root_box.lo), max_abs(root_box.hi));
        auto root = build_binary(prims, 0, static_cast<std::uint32_t>(prims.size()), root_box, centroids.box(), 0,
                                 threads_left);
        nodes_.reserve(prims.size() / 4 + 1);
        leaves_.clear();
        plan(*root);
        if (root->becomes_leaf()) { // a single leaf: a root node with one child
            nodes_.emplace_back();
            clear(nodes_[0]);
            set_child(0, 0, *root, add_block(*root));
        } else {
            collapse(*root);
        }
        // The leaves' triangles, gathered into blocks: the collapse's costly part, in chunks.
        blocks_.resize(leaves_.size());
        detail::parallel_chunks(leaves_.size(), threads, parallel_min, [&](std::size_t begin, std::size_t end) {
            for (std::size_t k = begin; k < end; ++k) fill_block(blocks_[k], prims, leaves_[k].first, leaves_[k].count);
        });
        leaves_ = {};
        triangles_ = nullptr;
    }

    // Parallel loops of the build take chunks of at least this many items, and a subtree gets
    // a thread of its own from this many primitives on.
    static constexpr std::size_t parallel_min = 32768;
    static constexpr std::uint32_t subtree_thread_min = 65536;
    // The binary build splits by SAH down to this depth, and at the median below it, so the tree
    // is at most sah_depth + 32 levels deep for any input (the traversal stack is sized by it).
    static constexpr int sah_depth = depth_limit - 32;
    static constexpr int bins = 8; // 16 or 32 trace no faster on the vs_embree meshes and build 20-40% slower

    // Where a centroid falls among the bins of each axis: ⌊(c − lo)·bins·(1 − ε)/extent⌋, computed
    // from halves (0.5c − 0.5lo) so that no finite coordinates overflow, at most bins − 1. An axis whose extent is 0, or so small that the scale overflows (subnormal
    // noise), has scale 0 and is not binned.
    struct Binning {
        T half_lo[3], scale[3];
        Binning(const detail::Box<T>& centroids) noexcept {
            for (int a = 0; a < 3; ++a) {
                half_lo[a] = component(centroids.lo, a) * T(0.5);
                const T half_extent = component(centroids.hi, a) * T(0.5) - half_lo[a];
                const T s = T(bins) * (T(1) - std::numeric_limits<T>::epsilon()) / half_extent;
                scale[a] = half_extent > T(0) && s < std::numeric_limits<T>::infinity() ? s : T(0);
            }
        }
        [[nodiscard]] bool any() const noexcept { return scale[0] > T(0) || scale[1] > T(0) || scale[2] > T(0); }
        [[nodiscard]] int bin(const Prim& p, int a) const noexcept {
            // The centroids lie within the bounds the scale came from, so f is in [0, bins] (no
            // NaN, no overflow: scale is finite and the difference at most the half extent); the
            // integer is clamped because rounding can reach bins itself.
            const int i = int((p.centroid[a] * T(0.5) - half_lo[a]) * scale[a]);
            return i < bins ? i : bins - 1;
        }
    };

    // Binary SAH build of prims[first, first + count), whose box and centroid bounds the caller
    // knows. One pass bins the centroids on all three axes; the sweep gives the children's boxes
    // and centroid bounds, so no level re-reads its primitives for them. Below sah_depth, or when
    // no axis can be binned (all centroids within rounding of each other), it splits at the
    // median of the widest axis, which bounds the depth (and so the traversal stack) for any input.
    std::unique_ptr<detail::BinaryNode<T>> build_binary(Prims& prims, std::uint32_t first,
                                                        std::uint32_t count, const detail::Box<T>& box,
                                                        const detail::Box<T>& centroids, int depth,
                                                        std::atomic<int>& threads_left) {
        auto node = std::make_unique<detail::BinaryNode<T>>();
        node->box = box, node->first = first, node->count = count;
        if (count <= 2 && count <= std::uint32_t(leaf_size_)) return node;

        struct Bin {
            detail::Box4<T> box, centroids;
            std::uint32_t n = 0;
        };
        Bin bin[3][bins];
        const Binning binning(centroids);
        const bool binned = depth < sah_depth && binning.any();
        if (binned)
            for (std::uint32_t i = first; i < first + count; ++i) {
                const Prim& p = prims[i];
                for (int a = 0; a < 3; ++a) {
                    Bin& b = bin[a][binning.bin(p, a)];
                    b.box.grow(p.lo, p.hi), b.centroids.grow(p.centroid, p.centroid), ++b.n;
                }
            }
        // Sweep: cost = Σ area · count over the two sides.
        Area best_cost = std::numeric_limits<Area>::infinity(), best_areas = best_cost;
        int best_axis = -1, best_split = 0;
        for (int a = 0; a < 3 && binned; ++a) {
            if (!(binning.scale[a] > T(0))) continue;
            Area right_area[bins];
            std::uint32_t right_n[bins];
            detail::Box<T> acc;
            std::uint32_t acc_n = 0;
            for (int b = bins - 1; b > 0; --b)
                acc.grow(bin[a][b].box.box()), acc_n += bin[a][b].n, right_area[b] = acc.area(), right_n[b] = acc_n;
            acc = {}, acc_n = 0;
            for (int b = 0; b < bins - 1; ++b) {
                acc.grow(bin[a][b].box.box()), acc_n += bin[a][b].n;
                if (acc_n == 0 || right_n[b + 1] == 0) continue;
                const Area cost = acc.area() * Area(acc_n) + right_area[b + 1] * Area(right_n[b + 1]);
                if (cost < best_cost) best_cost = cost, best_axis = a, best_split = b, best_areas = acc.area() + right_area[b + 1];
            }
        }
        // Up to leaf_size triangles cost one 8-lane test as a leaf, as each child would: split
        // only when the two children's boxes together have well under this box's area (the
        // ratio measured on the vs_embree meshes: 0.5 to 0.7 trace alike, 1.0 builds 40% longer
        // for no gain, per-triangle SAH costs likewise).
        constexpr Area split_area_ratio = Area(0.6);
        if (count <= std::uint32_t(leaf_size_) && !(best_areas < split_area_ratio * box.area())) return node;

        std::uint32_t mid = first;
        detail::Box<T> left_box, right_box, left_centroids, right_centroids;
        if (best_axis >= 0) {
            const int a = best_axis;
            for (int b = 0; b < bins; ++b) {
                detail::Box<T>& side = b <= best_split ? left_box : right_box;
                detail::Box<T>& side_c = b <= best_split ? left_centroids : right_centroids;
                if (bin[a][b].n) side.grow(bin[a][b].box.box()), side_c.grow(bin[a][b].centroids.box());
            }
            const auto middle = std::partition(prims.begin() + first, prims.begin() + first + count, [&](const Prim& p) {
                return binning.bin(p, a) <= best_split; // the binning's own rule: the sweep's counts
            });
            mid = static_cast<std::uint32_t>(middle - prims.begin());
        }
        if (mid == first || mid == first + count) { // deep, or no axis binned: the median of the widest axis
            const Vertex<T> extent = centroids.hi * T(0.5) - centroids.lo * T(0.5);
            const int a = extent.x >= extent.y ? (extent.x >= extent.z ? 0 : 2) : (extent.y >= extent.z ? 1 : 2);
            mid = first + count / 2;
            std::nth_element(prims.begin() + first, prims.begin() + mid, prims.begin() + first + count,
                             [a](const Prim& p, const Prim& q) { return p.centroid[a] < q.centroid[a]; });
            detail::Box4<T> lb, lc, rb, rc;
            for (std::uint32_t i = first; i < mid; ++i) lb.grow(prims[i].lo, prims[i].hi), lc.grow(prims[i].centroid, prims[i].centroid);
            for (std::uint32_t i = mid; i < first + count; ++i) rb.grow(prims[i].lo, prims[i].hi), rc.grow(prims[i].centroid, prims[i].centroid);
            left_box = lb.box(), left_centroids = lc.box(), right_box = rb.box(), right_centroids = rc.box();
        }

        const std::uint32_t left_count = mid - first, right_count = count - left_count;
        const auto build_left = [&] {
            node->left = build_binary(prims, first, left_count, left_box, left_centroids, depth + 1, threads_left);
        };
        const auto build_right = [&] {
            node->right = build_binary(prims, mid, right_count, right_box, right_centroids, depth + 1, threads_left);
        };
        if (count >= subtree_thread_min && threads_left.fetch_sub(1) > 0) { // a large subtree on its own thread
            detail::fork_join(build_left, build_right);
            threads_left.fetch_add(1);
        } else {
            if (count >= subtree_thread_min) threads_left.fetch_add(1); // undo the failed claim
            build_left();
            build_right();
        }
        return node;
    }

    [[nodiscard]] int depth_below(std::uint32_t node) const noexcept {
        int deepest = 0;
        for (const std::uint32_t c : nodes_[node].child)
            if (c != empty_child && !(c & leaf_bit)) deepest = std::max(deepest, depth_below(c));
        return deepest + 1;
    }

    static void clear(Node& n) noexcept {
        for (int a = 0; a < 3; ++a)
            for (int k = 0; k < 8; ++k) n.lo[a][k] = std::numeric_limits<T>::infinity(), n.hi[a][k] = -std::numeric_limits<T>::infinity();
        for (auto& c : n.child) c = empty_child;
    }

    void set_child(std::size_t node, int slot, const detail::BinaryNode<T>& child, std::uint32_t ref) {
        Node& n = nodes_[node];
        for (int a = 0; a < 3; ++a) n.lo[a][slot] = component(child.box.lo, a), n.hi[a][slot] = component(child.box.hi, a);
        n.child[slot] = ref;
    }

    // A leaf block for the range of `leaf`; its triangles are filled in after the collapse.
    std::uint32_t add_block(const detail::BinaryNode<T>& leaf) {
        leaves_.push_back({leaf.first, leaf.count});
        return static_cast<std::uint32_t>(leaves_.size() - 1) | leaf_bit;
    }

    // Block `b` holds the triangles of prims[first, first + count); unused lanes repeat lane 0
    // (Block: padding).
    void fill_block(Block& b, const Prims& prims, std::uint32_t first, std::uint32_t count) const noexcept {
        for (int k = 0; k < 8; ++k) {
            const std::uint32_t index = prims[first + (std::uint32_t(k) < count ? std::uint32_t(k) : 0u)].index;
            const Triangle<T>& tri = (*triangles_)[index];
            const Vertex<T>* vs[3] = {&tri.v0, &tri.v1, &tri.v2};
            for (int v = 0; v < 3; ++v)
                for (int a = 0; a < 3; ++a) b.v[v][a][k] = component(*vs[v], a);
            b.primitive[k] = index;
        }
    }

    // Whether lane k of a block is padding: a repeat of lane 0 (no triangle is in a leaf twice).
    static bool padding(const Block& b, int k) noexcept { return k > 0 && b.primitive[k] == b.primitive[0]; }

    // Plans the collapse of the binary tree into 8-wide nodes for the least SAH cost, visiting
    // a node costing `node_cost` and testing a leaf block `leaf_cost` per unit of box area
    // (Ylitie, Karras & Laine 2017, §3.1, with whole subtrees of up to leaf_size triangles
    // allowed to become one leaf). Fills BinaryNode::cost, how and wide_split, bottom-up.
    void plan(detail::BinaryNode<T>& n) const {
        const Area area = n.box.area();
        if (n.leaf()) {
            for (int j = 0; j < 8; ++j) n.cost[j] = leaf_cost * area, n.how[j] = 0;
            return;
        }
        plan(*n.left), plan(*n.right);
        Area wide = std::numeric_limits<Area>::infinity();
        for (int i = 1; i < 8; ++i) {
            const Area c = n.left->cost[i - 1] + n.right->cost[7 - i];
            if (c < wide) wide = c, n.wide_split = std::uint8_t(i);
        }
        wide += node_cost * area;
        n.cost[0] = wide, n.how[0] = 0;
        if (n.count <= std::uint32_t(leaf_size_) && leaf_cost * area <= wide) n.cost[0] = leaf_cost * area, n.how[0] = n.merged;
        for (int j = 2; j <= 8; ++j) {
            n.cost[j - 1] = n.cost[0], n.how[j - 1] = n.how[0];
            for (int i = 1; i < j; ++i) {
                const Area c = n.left->cost[i - 1] + n.right->cost[j - i - 1];
                if (c < n.cost[j - 1]) n.cost[j - 1] = c, n.how[j - 1] = std::uint8_t(i);
            }
        }
    }

    // The children `plan` chose for subtree `n` given `slots` places.
    static void gather(const detail::BinaryNode<T>& n, int slots, std::vector<const detail::BinaryNode<T>*>& kids) {
        const int how = n.how[slots - 1];
        if (how == 0 || how == n.merged) {
            kids.push_back(&n);
        } else {
            gather(*n.left, how, kids);
            gather(*n.right, slots - how, kids);
        }
    }

    // Makes the 8-wide node that `plan` chose for binary node `bin` (inner), and its subtree.
    std::uint32_t collapse(const detail::BinaryNode<T>& bin) {
        const std::size_t index = nodes_.size();
        nodes_.emplace_back();
        clear(nodes_[index]);
        std::vector<const detail::BinaryNode<T>*> kids;
        gather(*bin.left, bin.wide_split, kids);
        gather(*bin.right, 8 - bin.wide_split, kids);
        for (std::size_t k = 0; k < kids.size(); ++k) {
            const std::uint32_t ref = kids[k]->becomes_leaf() ? add_block(*kids[k]) : collapse(*kids[k]);
            set_child(index, int(k), *kids[k], ref);
        }
        return static_cast<std::uint32_t>(index);
    }

    // ---- traversal ---------------------------------------------------------------------
    struct RayData {
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
        Vertex<T> dir;
        // byte offsets in a Node of the entry and exit planes of each axis (lo or hi, by sign)
        std::size_t near_plane[3], far_plane[3];
        detail::WatertightShear<T> shear; // set when the ray reaches its first leaf
        bool ok;
        // The slab test's form for this ray. Fast: p·inv − o·inv in one FMA, when no product can
        // overflow (every inv finite, |p|·|inv| and |o|·|inv| well below the largest T for every
        // p of the tree). Robust otherwise (a direction component 0 or tiny, coordinates near
        // the largest T): (p − o)·inv, which gives ±∞ but no NaN except 0·∞ for a ray in a slab's
        // plane, and that NaN is ignored by the min/max (the slab does not bound the ray).
        bool robust;
    };

    // Per-ray set-up, with as few branches as it can: most rays of a frame cost a few node
    // visits, so this is a fair part of their time.
    RayData prepare(const Ray<T>& ray) const noexcept {
        RayData r;
        const Vertex<T>& o = ray.origin;
        const Vertex<T>& d = ray.direction;
        r.dir = d;
        const T ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
        // x − x is 0 for a finite x and NaN otherwise
        const T finite = ((o.x - o.x) + (o.y - o.y)) + ((o.z - o.z) + (d.x - d.x)) + ((d.y - d.y) + (d.z - d.z));
        r.ok = (finite == T(0)) & (std::max(ax, std::max(ay, az)) > T(0));
        constexpr T u = std::numeric_limits<T>::epsilon() / 2, widen = T(1) + T(2) * (T(3) * u / (T(1) - T(3) * u));
        constexpr T no_overflow = std::numeric_limits<T>::max() / T(8);
        bool fast = true;
        for (int a = 0; a < 3; ++a) {
            const T da = component(d, a);
            r.org[a] = component(o, a);
            r.inv[a] = T(1) / da;
            r.inv_far[a] = r.inv[a] * widen;
            fast &= std::max(bound_, std::fabs(r.org[a])) * std::fabs(r.inv_far[a]) < no_overflow; // false for ∞
            const T org_inv = r.org[a] * r.inv[a], org_inv_far = r.org[a] * r.inv_far[a];
            constexpr T allowance = T(4) * std::numeric_limits<T>::epsilon();
            r.org_inv_near[a] = org_inv + allowance * std::fabs(org_inv);
            r.org_inv_far[a] = org_inv_far - allowance * std::fabs(org_inv_far);
            const bool near_is_lo = !std::signbit(da);
            const std::size_t lo = std::size_t(a) * sizeof(Node::lo[0]), hi = sizeof(Node::lo) + lo;
            r.near_plane[a] = near_is_lo ? lo : hi;
            r.far_plane[a] = near_is_lo ? hi : lo;
        }
        r.robust = !fast;
        return r;
    }

    // The 8 lanes of a plane of `n` at byte `offset` (RayData::near_plane, far_plane).
    static const T* plane(const Node& n, std::size_t offset) noexcept {
        return reinterpret_cast<const T*>(reinterpret_cast<const char*>(&n) + offset);
    }

    // Slab test of the 8 children: bit k set when child k's box is entered before `t_far`.
    // Exits are computed with RayData::inv_far, so that no rounding drops a box the ray touches.
    // `robust` selects RayData::robust's form; the portable forms are always robust. Every
    // max/min takes the slab's value first: a NaN there yields the other operand.
    template <bool robust>
    static unsigned hit_children(const Node& n, const RayData& r, T t_far, T (&t_near)[8]) noexcept {
#if defined(__AVX__)
        if constexpr (sizeof(T) == sizeof(float)) { // 8 boxes in one 256-bit register per plane
            __m256 t0[3], t1[3]; // entry and exit distances of each axis' slab
            for (int a = 0; a < 3; ++a) {
                const __m256 near_plane = _mm256_load_ps(plane(n, r.near_plane[a]));
                const __m256 far_plane = _mm256_load_ps(plane(n, r.far_plane[a]));
#if defined(__FMA__)
                if constexpr (!robust) {
                    // p·inv − o·inv in one FMA; o·inv is rounded, so the entry subtracts and the
                    // exit adds the per-ray allowance (prepare: org_inv_near / org_inv_far).
                    t0[a] = _mm256_fmsub_ps(near_plane, _mm256_set1_ps(float(r.inv[a])), _mm256_set1_ps(float(r.org_inv_near[a])));
                    t1[a] = _mm256_fmsub_ps(far_plane, _mm256_set1_ps(float(r.inv_far[a])), _mm256_set1_ps(float(r.org_inv_far[a])));
                    continue;
                }
#endif
                const __m256 org = _mm256_set1_ps(float(r.org[a]));
                t0[a] = _mm256_mul_ps(_mm256_sub_ps(near_plane, org), _mm256_set1_ps(float(r.inv[a])));
                t1[a] = _mm256_mul_ps(_mm256_sub_ps(far_plane, org), _mm256_set1_ps(float(r.inv_far[a])));
            }
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
        V tn = V{} , tf = V{} + t_far, near_plane, far_plane;
        for (int a = 0; a < 3; ++a) {
            std::memcpy(&near_plane, plane(n, r.near_plane[a]), sizeof near_plane);
            std::memcpy(&far_plane, plane(n, r.far_plane[a]), sizeof far_plane);
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
                const T near = (plane(n, r.near_plane[a])[k] - r.org[a]) * r.inv[a];
                const T far = (plane(n, r.far_plane[a])[k] - r.org[a]) * r.inv_far[a];
                tn = near > tn ? near : tn;
                tf = far < tf ? far : tf;
            }
            t_near[k] = tn;
            mask |= unsigned(tn <= tf) << k;
        }
        return mask;
#endif
    }

    static int lowest_bit(unsigned mask) noexcept {
#if ISIN_VECTOR_EXTENSIONS
        return __builtin_ctz(mask);
#else
        int k = 0;
        while (!((mask >> k) & 1u)) ++k;
        return k;
#endif
    }

    // Watertight test of the (up to) 8 triangles of a block; updates `best` with the nearest.
    // Returns true when a hit nearer than best.t was found.
    static bool hit_block(const Block& b, const RayData& r, BvhHit<T>& best) noexcept {
#if defined(__AVX2__) && defined(__FMA__)
        if constexpr (sizeof(T) == sizeof(float)) return hit_block_avx2(b, r, best);
        else return hit_block_avx2_double(b, r, best);
#endif
#if ISIN_VECTOR_EXTENSIONS
        if constexpr (sizeof(T) == sizeof(float)) return hit_block_lanes(b, r, best);
#endif
        // One triangle at a time: intersect_watertight's per-triangle part with the ray's shear
        // set up once per ray; the build left degenerate triangles out.
        bool found = false;
        const Vertex<T> o{r.org[0], r.org[1], r.org[2]};
        for (int k = 0; k < 8; ++k) {
            if (padding(b, k)) break;
            Vertex<T> p[3]; // the vertices relative to the origin
            for (int v = 0; v < 3; ++v) p[v] = Vertex<T>{b.v[v][0][k], b.v[v][1][k], b.v[v][2][k]} - o;
            const Hit<T> h = detail::intersect_sheared(p[0], p[1], p[2], r.shear, false);
            if (!(h.t < best.t)) continue;
            best.t = h.t, best.u = h.u, best.v = h.v, best.primitive = b.primitive[k];
            found = true;
        }
        return found;
    }

#if defined(__AVX2__) && defined(__FMA__)
    // The 8 triangles of a block relative to the ray's origin, sheared onto its frame (WBW §3):
    // x, y across the ray, z along it (not yet scaled by Sz).
    struct Sheared8 {
        __m256 x[3], y[3], z[3];
        Sheared8(const Block& b, const RayData& r) noexcept {
            const __m256 ox = _mm256_set1_ps(float(r.org[r.shear.kx])), oy = _mm256_set1_ps(float(r.org[r.shear.ky]));
            const __m256 oz = _mm256_set1_ps(float(r.org[r.shear.kz]));
            const __m256 Sx = _mm256_set1_ps(float(r.shear.Sx)), Sy = _mm256_set1_ps(float(r.shear.Sy));
            for (int v = 0; v < 3; ++v) {
                z[v] = _mm256_sub_ps(_mm256_load_ps(b.v[v][r.shear.kz]), oz);
                x[v] = _mm256_fnmadd_ps(Sx, z[v], _mm256_sub_ps(_mm256_load_ps(b.v[v][r.shear.kx]), ox)); // WBW: Ax = A[kx] − Sx·A[kz]
                y[v] = _mm256_fnmadd_ps(Sy, z[v], _mm256_sub_ps(_mm256_load_ps(b.v[v][r.shear.ky]), oy));
            }
        }
    };

    // Eight float lanes as two halves of four doubles.
    struct Halves {
        __m256d lo, hi;
        explicit Halves(__m256 v) noexcept
            : lo(_mm256_cvtps_pd(_mm256_castps256_ps128(v))), hi(_mm256_cvtps_pd(_mm256_extractf128_ps(v, 1))) {}
    };

    // a·b − c·d on 8 float lanes exactly as difference_of_products<float> computes it: products of
    // floats are exact in double, their difference is rounded once to double, then to float. No
    // float product is formed, so nothing overflows or underflows on the way: the sign is exact
    // for all finite lanes and each lane equals the scalar function's result.
    static __m256 difference_of_products8(const Halves& a, const Halves& b, const Halves& c, const Halves& d) noexcept {
        const __m128 lo = _mm256_cvtpd_ps(_mm256_fmsub_pd(a.lo, b.lo, _mm256_mul_pd(c.lo, d.lo)));
        const __m128 hi = _mm256_cvtpd_ps(_mm256_fmsub_pd(a.hi, b.hi, _mm256_mul_pd(c.hi, d.hi)));
        return _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
    }

    // The watertight test on 8 float lanes with AVX2 and FMA (WBW §3), step for step as
    // detail::intersect_sheared: U, V, W as difference_of_products<float>, then det, t and the
    // barycentrics in float, so that each lane decides as intersect_watertight does (up to the
    // compiler's contraction of the scalar code). hit_block_avx2 is the same test with a faster
    // U, V, W; it comes here for the blocks where that could err.
    ISIN_DETAIL_COLD static bool hit_block_exact(const Block& b, const RayData& r, BvhHit<T>& best) noexcept {
        const Sheared8 p(b, r);
        const Halves X0(p.x[0]), Y0(p.y[0]), X1(p.x[1]), Y1(p.y[1]), X2(p.x[2]), Y2(p.y[2]);
        const __m256 U = difference_of_products8(X2, Y1, Y2, X1); // WBW: U = Cx·By − Cy·Bx
        const __m256 V = difference_of_products8(X0, Y2, Y0, X2); // WBW: V = Ax·Cy − Ay·Cx
        const __m256 W = difference_of_products8(X1, Y0, Y1, X0); // WBW: W = Bx·Ay − By·Ax
        const __m256 zero = _mm256_setzero_ps();
        // Inside: U, V, W all ≥ 0 or all ≤ 0. A NaN passes here and fails det ≠ 0 (ordered) below.
        const __m256 lowest = _mm256_min_ps(_mm256_min_ps(U, V), W), highest = _mm256_max_ps(_mm256_max_ps(U, V), W);
        const __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), W);
        __m256 ok = _mm256_and_ps(_mm256_or_ps(_mm256_cmp_ps(lowest, zero, _CMP_GE_OQ), _mm256_cmp_ps(highest, zero, _CMP_LE_OQ)),
                                  _mm256_cmp_ps(det, zero, _CMP_NEQ_OQ));
        if (_mm256_testz_ps(ok, ok)) return false;
        return nearest_lane(b, U, V, W, det, p.z, r, ok, best);
    }
#endif

#if defined(__AVX2__) && defined(__FMA__)
    // a·b − c·d on 8 float lanes by Kahan's algorithm with FMA: the sign is exact unless a
    // product overflows or underflows float (then the result is not finite, or tiny).
    static __m256 kahan_difference_of_products8(__m256 a, __m256 b, __m256 c, __m256 d) noexcept {
        const __m256 cd = _mm256_mul_ps(c, d);
        const __m256 error = _mm256_fmsub_ps(c, d, cd);  // c·d − cd, exact
        return _mm256_sub_ps(_mm256_fmsub_ps(a, b, cd), error);
    }

    // The watertight test on 8 float lanes with AVX2 and FMA, as hit_block_exact but with U, V, W
    // by Kahan's algorithm in float, four operations each instead of products in double. Its sign
    // is exact, so each lane decides as the exact test does, unless a product over- or
    // underflowed float: then det is not finite or an edge function is below 2^-100 in magnitude
    // (exact zeros included), and the block is handed to hit_block_exact (D7: a vertex at 2e38).
    static bool hit_block_avx2(const Block& b, const RayData& r, BvhHit<T>& best) noexcept {
        const Sheared8 p(b, r);
        const __m256 U = kahan_difference_of_products8(p.x[2], p.y[1], p.y[2], p.x[1]); // WBW: U = Cx·By − Cy·Bx
        const __m256 V = kahan_difference_of_products8(p.x[0], p.y[2], p.y[0], p.x[2]); // WBW: V = Ax·Cy − Ay·Cx
        const __m256 W = kahan_difference_of_products8(p.x[1], p.y[0], p.y[1], p.x[0]); // WBW: W = Bx·Ay − By·Ax
        const __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), W);
        const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
        const __m256 smallest = _mm256_min_ps(_mm256_min_ps(_mm256_and_ps(U, magnitude), _mm256_and_ps(V, magnitude)),
                                              _mm256_and_ps(W, magnitude));
        const __m256 trusted = _mm256_and_ps(_mm256_cmp_ps(smallest, _mm256_set1_ps(0x1p-126f), _CMP_GE_OQ),
                                             _mm256_cmp_ps(_mm256_and_ps(det, magnitude), _mm256_set1_ps(0x1p126f), _CMP_LT_OQ));
        if (!_mm256_testc_ps(trusted, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))) return hit_block_exact(b, r, best);
        const __m256 zero = _mm256_setzero_ps();
        // Inside: U, V, W all ≥ 0 or all ≤ 0.
        const __m256 lowest = _mm256_min_ps(_mm256_min_ps(U, V), W), highest = _mm256_max_ps(_mm256_max_ps(U, V), W);
        __m256 ok = _mm256_and_ps(_mm256_or_ps(_mm256_cmp_ps(lowest, zero, _CMP_GE_OQ), _mm256_cmp_ps(highest, zero, _CMP_LE_OQ)),
                                  _mm256_cmp_ps(det, zero, _CMP_NEQ_OQ));
        if (_mm256_testz_ps(ok, ok)) return false; // most blocks end here, before the division
        return nearest_lane(b, U, V, W, det, p.z, r, ok, best);
    }

    // The hits among the lanes of `ok` (inside, det ≠ 0): t = (U·Az + V·Bz + W·Cz)/det with
    // Az = Sz·A[kz] (WBW, as detail::intersect_sheared computes it), kept when 0 < t < best.t; the
    // nearest goes into `best`, ties to the lowest lane.
    static bool nearest_lane(const Block& b, __m256 U, __m256 V, __m256 W, __m256 det, const __m256 (&pz)[3],
                             const RayData& r, __m256 ok, BvhHit<T>& best) noexcept {
        const __m256 zero = _mm256_setzero_ps();
        const __m256 Sz = _mm256_set1_ps(float(r.shear.Sz));
        const __m256 t_scaled = _mm256_fmadd_ps(W, _mm256_mul_ps(Sz, pz[2]),
                                                _mm256_fmadd_ps(V, _mm256_mul_ps(Sz, pz[1]),
                                                                _mm256_mul_ps(U, _mm256_mul_ps(Sz, pz[0])))); // WBW: t·det
        const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
        const __m256 t = _mm256_mul_ps(t_scaled, inv_det);
        ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(t, zero, _CMP_GT_OQ), _mm256_cmp_ps(t, _mm256_set1_ps(float(best.t)), _CMP_LT_OQ)));
        if (_mm256_testz_ps(ok, ok)) return false;
        // Horizontal minimum of the hits, then its lane.
        const __m256 cand = _mm256_blendv_ps(_mm256_set1_ps(std::numeric_limits<float>::infinity()), t, ok);
        __m256 m = _mm256_min_ps(cand, _mm256_permute_ps(cand, 0xB1));
        m = _mm256_min_ps(m, _mm256_permute_ps(m, 0x4E));
        m = _mm256_min_ps(m, _mm256_permute2f128_ps(m, m, 0x01));
        const unsigned lanes = unsigned(_mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(cand, m, _CMP_EQ_OQ), ok)));
        const int k = lowest_bit(lanes);
        alignas(32) float tv[8], uv[8], vv[8], iv[8];
        _mm256_store_ps(tv, t), _mm256_store_ps(uv, V), _mm256_store_ps(vv, W), _mm256_store_ps(iv, inv_det);
        best.t = tv[k];
        best.u = uv[k] * iv[k];
        best.v = vv[k] * iv[k];
        best.primitive = b.primitive[k];
        return true;
    }
#endif

#if defined(__AVX2__) && defined(__FMA__)
    // a·b − c·d on 4 double lanes as difference_of_products<double> (Kahan's algorithm, FMA).
    static __m256d difference_of_products4(__m256d a, __m256d b, __m256d c, __m256d d) noexcept {
        const __m256d cd = _mm256_mul_pd(c, d);
        const __m256d error = _mm256_fmsub_pd(c, d, cd); // c·d − cd, exact
        return _mm256_sub_pd(_mm256_fmsub_pd(a, b, cd), error);
    }

    // The watertight test on the 8 double lanes of a block as two halves of 4 (AVX2 and FMA),
    // as hit_block_avx2; a half whose first lane is padding is skipped.
    static bool hit_block_avx2_double(const Block& b, const RayData& r, BvhHit<T>& best) noexcept {
        const __m256d ox = _mm256_set1_pd(double(r.org[r.shear.kx])), oy = _mm256_set1_pd(double(r.org[r.shear.ky]));
        const __m256d oz = _mm256_set1_pd(double(r.org[r.shear.kz]));
        const __m256d Sx = _mm256_set1_pd(double(r.shear.Sx)), Sy = _mm256_set1_pd(double(r.shear.Sy));
        const __m256d zero = _mm256_setzero_pd();
        bool found = false;
        for (int half = 0; half < 8 && !padding(b, half); half += 4) {
            __m256d x[3], y[3], pz[3];
            for (int v = 0; v < 3; ++v) {
                const double* lanes[3] = {b.v[v][r.shear.kx] + half, b.v[v][r.shear.ky] + half, b.v[v][r.shear.kz] + half};
                pz[v] = _mm256_sub_pd(_mm256_load_pd(lanes[2]), oz);
                x[v] = _mm256_fnmadd_pd(Sx, pz[v], _mm256_sub_pd(_mm256_load_pd(lanes[0]), ox)); // WBW: Ax = A[kx] − Sx·A[kz]
                y[v] = _mm256_fnmadd_pd(Sy, pz[v], _mm256_sub_pd(_mm256_load_pd(lanes[1]), oy));
            }
            const __m256d U = difference_of_products4(x[2], y[1], y[2], x[1]); // WBW: U = Cx·By − Cy·Bx
            const __m256d V = difference_of_products4(x[0], y[2], y[0], x[2]); // WBW: V = Ax·Cy − Ay·Cx
            const __m256d W = difference_of_products4(x[1], y[0], y[1], x[0]); // WBW: W = Bx·Ay − By·Ax
            const __m256d lowest = _mm256_min_pd(_mm256_min_pd(U, V), W), highest = _mm256_max_pd(_mm256_max_pd(U, V), W);
            const __m256d det = _mm256_add_pd(_mm256_add_pd(U, V), W);
            __m256d ok = _mm256_and_pd(_mm256_or_pd(_mm256_cmp_pd(lowest, zero, _CMP_GE_OQ), _mm256_cmp_pd(highest, zero, _CMP_LE_OQ)),
                                       _mm256_cmp_pd(det, zero, _CMP_NEQ_OQ));
            if (_mm256_testz_pd(ok, ok)) continue;
            const __m256d Sz = _mm256_set1_pd(double(r.shear.Sz));
            const __m256d t_scaled = _mm256_fmadd_pd(W, _mm256_mul_pd(Sz, pz[2]),
                                                     _mm256_fmadd_pd(V, _mm256_mul_pd(Sz, pz[1]),
                                                                     _mm256_mul_pd(U, _mm256_mul_pd(Sz, pz[0])))); // WBW: t·det
            const __m256d inv_det = _mm256_div_pd(_mm256_set1_pd(1.0), det);
            const __m256d t = _mm256_mul_pd(t_scaled, inv_det);
            ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(t, zero, _CMP_GT_OQ), _mm256_cmp_pd(t, _mm256_set1_pd(double(best.t)), _CMP_LT_OQ)));
            const unsigned lanes = unsigned(_mm256_movemask_pd(ok));
            if (!lanes) continue;
            alignas(32) double tv[4], uv[4], vv[4], iv[4];
            _mm256_store_pd(tv, t), _mm256_store_pd(uv, V), _mm256_store_pd(vv, W), _mm256_store_pd(iv, inv_det);
            int k = -1;
            for (int l = 0; l < 4; ++l)
                if (((lanes >> l) & 1u) && (k < 0 || tv[l] < tv[k])) k = l;
            best.t = T(tv[k]), best.u = T(uv[k] * iv[k]), best.v = T(vv[k] * iv[k]);
            best.primitive = b.primitive[half + k];
            found = true;
        }
        return found;
    }
#endif

#if ISIN_VECTOR_EXTENSIONS
    // The same test on 8 float lanes with the compiler's vector extensions, step for step as
    // detail::intersect_sheared: U, V, W as difference_of_products<float> (exact products in
    // double, rounded to float), then det, t and the barycentrics in float.
    static bool hit_block_lanes(const Block& b, const RayData& r, BvhHit<T>& best) noexcept {
        using V = detail::L8<float>;
        using D = detail::L8<double>;
        V x[3], y[3], z[3]; // sheared vertices relative to the origin: x, y in the ray's frame, z along it
        for (int v = 0; v < 3; ++v) {
            V px, py, pz;
            std::memcpy(&px, b.v[v][r.shear.kx], sizeof px);
            std::memcpy(&py, b.v[v][r.shear.ky], sizeof py);
            std::memcpy(&pz, b.v[v][r.shear.kz], sizeof pz);
            px -= float(r.org[r.shear.kx]), py -= float(r.org[r.shear.ky]), pz -= float(r.org[r.shear.kz]);
            x[v] = px - float(r.shear.Sx) * pz;           // WBW: Ax = A[kx] − Sx·A[kz]
            y[v] = py - float(r.shear.Sy) * pz;
            z[v] = float(r.shear.Sz) * pz;                // WBW: Az = Sz·A[kz]
        }
        const D X0 = __builtin_convertvector(x[0], D), Y0 = __builtin_convertvector(y[0], D);
        const D X1 = __builtin_convertvector(x[1], D), Y1 = __builtin_convertvector(y[1], D);
        const D X2 = __builtin_convertvector(x[2], D), Y2 = __builtin_convertvector(y[2], D);
        const V U = __builtin_convertvector(X2 * Y1 - Y2 * X1, V);  // WBW: U = Cx·By − Cy·Bx (exact products)
        const V Vv = __builtin_convertvector(X0 * Y2 - Y0 * X2, V); // WBW: V = Ax·Cy − Ay·Cx
        const V W = __builtin_convertvector(X1 * Y0 - Y1 * X0, V);  // WBW: W = Bx·Ay − By·Ax
        const V det = U + Vv + W;
        const V inv_det = 1.0f / det;              // lanes with det = 0 give ±∞ or NaN: rejected below
        const V t = (U * z[0] + Vv * z[1] + W * z[2]) * inv_det; // WBW: t = (U·Az + V·Bz + W·Cz)/det
        const auto inside = ((U >= 0.0f) & (Vv >= 0.0f) & (W >= 0.0f)) | ((U <= 0.0f) & (Vv <= 0.0f) & (W <= 0.0f));
        const auto ok = inside & (det != 0.0f) & (t > 0.0f) & (t < float(best.t));
        const V candidates = ok ? t : V{} + std::numeric_limits<float>::infinity();
        float t_win = candidates[0];
        for (int k = 1; k < 8; ++k) t_win = candidates[k] < t_win ? candidates[k] : t_win; // horizontal min
        if (!(t_win < best.t)) return false;
        int winner = 0;
        while (candidates[winner] != t_win) ++winner;
        best.t = t_win;
        best.u = Vv[winner] * inv_det[winner];
        best.v = W[winner] * inv_det[winner];
        best.primitive = b.primitive[winner];
        return true;
    }
#endif

    template <bool any_hit>
    bool traverse(const Ray<T>& ray, BvhHit<T>& best) const noexcept {
        if (nodes_.empty()) return false;
        RayData r = prepare(ray);
        if (!r.ok || !(best.t > T(0))) return false;
        return r.robust ? walk<any_hit, true>(r, best) : walk<any_hit, false>(r, best);
    }

    template <bool any_hit, bool robust>
    bool walk(RayData& r, BvhHit<T>& best) const noexcept {
        bool sheared = false;
        struct Entry {
            std::uint32_t ref;
            T t;
        };
        Entry stack[7 * (sah_depth + 32) + 1]; // 7 entries a level at most
        int top = 0;
        std::uint32_t ref = 0; // the node or leaf being visited
        bool hit = false;
        for (;;) {
            if (ref & leaf_bit) {
                // The leaves' set-up, the watertight shear, only for rays that reach a leaf: most
                // rays of a frame that miss never do (prepare has checked the direction).
                if (!sheared) r.shear.set(r.dir), sheared = true;
                if (hit_block(blocks_[ref & ~leaf_bit], r, best)) {
                    hit = true;
                    if (any_hit) return true;
                }
            } else {
                const Node& n = nodes_[ref];
                T t_near[8];
                unsigned mask = hit_children<robust>(n, r, best.t, t_near);
                if (mask) {
                    int k = lowest_bit(mask);
                    mask &= mask - 1;
                    if (!mask) { // one child: go on with it directly
                        ref = n.child[k];
                        continue;
                    }
                    if (any_hit) { // any hit will do: no ordering, push the others as they come
                        const std::uint32_t first_child = n.child[k];
                        while (mask) {
                            k = lowest_bit(mask);
                            mask &= mask - 1;
                            stack[top++] = {n.child[k], t_near[k]};
                        }
                        ref = first_child;
                        continue;
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
                        continue;
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
                    continue;
                }
            }
            // Pop the next entry that is entered before the nearest hit so far.
            for (;;) {
                if (top == 0) return hit;
                const Entry e = stack[--top];
                if (e.t < best.t) {
                    ref = e.ref;
                    break;
                }
            }
        }
    }

    std::vector<Node> nodes_;
    std::vector<Block, detail::UninitAllocator<Block>> blocks_; // filled in parallel after the collapse
    std::size_t primitives_ = 0;
    T bound_ = T(0); // largest |coordinate| of any box: whether a ray's slab products can overflow
    int leaf_size_ = 8;
    const std::vector<Triangle<T>>* triangles_ = nullptr; // during the build only
    struct Range {
        std::uint32_t first, count;
    };
    std::vector<Range> leaves_; // during the build only: the prims of each block
};

} // namespace isin
