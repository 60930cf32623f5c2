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
#include <utility>
#include <vector>

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
    [[nodiscard]] T half_area() const noexcept {
        const Vertex<T> e = hi - lo;
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
    T cost[8] = {};
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

private:
    static constexpr std::uint32_t leaf_bit = 0x80000000u;
    static constexpr std::uint32_t empty_child = 0xffffffffu;
    // SAH costs per unit of box area of visiting an 8-wide node and of testing a leaf block.
    static constexpr T node_cost = T(1), leaf_cost = T(1);

    // 8 children: boxes in structure-of-arrays order, child references (node index, or leaf
    // block index | leaf_bit, or empty_child whose box is empty: lo = +∞ > hi = −∞).
    struct alignas(64) Node {
        T lo[3][8], hi[3][8];
        std::uint32_t child[8];
    };
    // Up to 8 triangles, vertex-major, structure-of-arrays; unused lanes are all-zero triangles
    // (their edge functions are 0, det = 0: never hit).
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
        const int hw = int(std::thread::hardware_concurrency());
        const int threads = std::max(1, options.threads > 0 ? options.threads : hw);
        // The primitives (box, centroid) of the triangles, in chunks; unusable triangles (not
        // finite, zero area) are marked and then left out.
        Prims prims(triangles.size());
        std::atomic<bool> unusable{false};
        parallel_chunks(triangles.size(), threads, [&](int, std::size_t begin, std::size_t end) {
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
                    p.centroid[a] = (p.lo[a] + p.hi[a]) * T(0.5);
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
        if (prims.empty()) return;
        leaf_size_ = std::clamp(options.leaf_size, 1, 8);
        std::atomic<int> threads_left{threads - 1};
        detail::Box4<T> box, centroids;
        for (const Prim& p : prims) box.grow(p.lo, p.hi), centroids.grow(p.centroid, p.centroid);
        auto root = build_binary(prims, 0, static_cast<std::uint32_t>(prims.size()), box.box(), centroids.box(), 0,
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
        parallel_chunks(leaves_.size(), threads, [&](int, std::size_t begin, std::size_t end) {
            for (std::size_t k = begin; k < end; ++k) fill_block(blocks_[k], prims, leaves_[k].first, leaves_[k].count);
        });
        leaves_ = {};
        triangles_ = nullptr;
    }

    // Runs f(part, begin, end) over [0, n) cut into up to `threads` parts of at least 32768
    // items, part 0 on this thread; if a thread cannot be started, its part runs here too.
    template <class F>
    static void parallel_chunks(std::size_t n, int threads, const F& f) {
        const std::size_t parts = std::max<std::size_t>(1, std::min(std::size_t(threads), n / 32768));
        const std::size_t chunk = (n + parts - 1) / std::max<std::size_t>(parts, 1);
        std::vector<std::thread> workers;
        std::size_t next = 1; // the first part not handed to a worker
        try {
            for (; next < parts; ++next)
                workers.emplace_back(f, int(next), std::min(n, next * chunk), std::min(n, (next + 1) * chunk));
        } catch (...) { // no more threads: the remaining parts run here
        }
        f(0, std::size_t(0), std::min(n, chunk));
        for (std::size_t k = next; k < parts; ++k) f(int(k), std::min(n, k * chunk), std::min(n, (k + 1) * chunk));
        for (std::thread& w : workers) w.join();
    }

    // Binary SAH build of prims[first, first + count), whose box and centroid bounds the caller
    // knows. One pass bins the centroids on all three axes (8 bins); the sweep gives the
    // children's boxes and centroid bounds, so no level re-reads its primitives for them. Past
    // depth 40 it splits at the median of the widest axis, which bounds the depth (and so the
    // traversal stack) for any input.
    std::unique_ptr<detail::BinaryNode<T>> build_binary(Prims& prims, std::uint32_t first,
                                                        std::uint32_t count, const detail::Box<T>& box,
                                                        const detail::Box<T>& centroids, int depth,
                                                        std::atomic<int>& threads_left) {
        auto node = std::make_unique<detail::BinaryNode<T>>();
        node->box = box, node->first = first, node->count = count;
        if (count <= 2 && count <= std::uint32_t(leaf_size_)) return node;

        constexpr int bins = 8; // 16 or 32 trace no faster on the vs_embree meshes and build 20-40% slower
        struct Bin {
            detail::Box4<T> box, centroids;
            std::uint32_t n = 0;
        };
        Bin bin[3][bins];
        const Vertex<T> extent = centroids.hi - centroids.lo;
        T scale[3], lo[3];
        for (int a = 0; a < 3; ++a) {
            const T e = component(extent, a);
            scale[a] = e > T(0) ? T(bins) * (T(1) - std::numeric_limits<T>::epsilon()) / e : T(0);
            lo[a] = component(centroids.lo, a);
        }
        const bool binned = depth < 40 && (extent.x > T(0) || extent.y > T(0) || extent.z > T(0));
        if (binned)
            for (std::uint32_t i = first; i < first + count; ++i) {
                const Prim& p = prims[i];
                for (int a = 0; a < 3; ++a) {
                    Bin& b = bin[a][int((p.centroid[a] - lo[a]) * scale[a])];
                    b.box.grow(p.lo, p.hi), b.centroids.grow(p.centroid, p.centroid), ++b.n;
                }
            }
        // Sweep: cost = Σ area · count over the two sides.
        T best_cost = std::numeric_limits<T>::infinity(), best_areas = best_cost;
        int best_axis = -1, best_split = 0;
        for (int a = 0; a < 3 && binned; ++a) {
            if (!(scale[a] > T(0))) continue;
            T right_area[bins];
            std::uint32_t right_n[bins];
            detail::Box<T> acc;
            std::uint32_t acc_n = 0;
            for (int b = bins - 1; b > 0; --b)
                acc.grow(bin[a][b].box.box()), acc_n += bin[a][b].n, right_area[b] = acc.half_area(), right_n[b] = acc_n;
            acc = {}, acc_n = 0;
            for (int b = 0; b < bins - 1; ++b) {
                acc.grow(bin[a][b].box.box()), acc_n += bin[a][b].n;
                if (acc_n == 0 || right_n[b + 1] == 0) continue;
                const T cost = acc.half_area() * T(acc_n) + right_area[b + 1] * T(right_n[b + 1]);
                if (cost < best_cost) best_cost = cost, best_axis = a, best_split = b, best_areas = acc.half_area() + right_area[b + 1];
            }
        }
        // Up to leaf_size triangles cost one 8-lane test as a leaf, as each child would: split
        // only when the two children's boxes together have well under this box's area (the
        // ratio measured on the vs_embree meshes: 0.5 to 0.7 trace alike, 1.0 builds 40% longer
        // for no gain, per-triangle SAH costs likewise).
        constexpr T split_area_ratio = T(0.6);
        if (count <= std::uint32_t(leaf_size_) && !(best_areas < split_area_ratio * box.half_area())) return node;

        std::uint32_t mid;
        detail::Box<T> left_box, right_box, left_centroids, right_centroids;
        if (best_axis >= 0) {
            const int a = best_axis;
            for (int b = 0; b < bins; ++b) {
                detail::Box<T>& side = b <= best_split ? left_box : right_box;
                detail::Box<T>& side_c = b <= best_split ? left_centroids : right_centroids;
                if (bin[a][b].n) side.grow(bin[a][b].box.box()), side_c.grow(bin[a][b].centroids.box());
            }
            const auto middle = std::partition(prims.begin() + first, prims.begin() + first + count, [&](const Prim& p) {
                return int((p.centroid[a] - lo[a]) * scale[a]) <= best_split;
            });
            mid = static_cast<std::uint32_t>(middle - prims.begin());
        } else { // deep, or all centroids coincide: split at the median of the widest axis
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
        if (count > 65536 && threads_left.fetch_sub(1) > 0) { // a large subtree on its own thread
            std::unique_ptr<detail::BinaryNode<T>> left;
            std::thread worker([&] {
                left = build_binary(prims, first, left_count, left_box, left_centroids, depth + 1, threads_left);
            });
            node->right = build_binary(prims, mid, right_count, right_box, right_centroids, depth + 1, threads_left);
            worker.join();
            node->left = std::move(left);
            threads_left.fetch_add(1);
        } else {
            threads_left.fetch_add(count > 65536 ? 1 : 0); // undo the failed claim
            node->left = build_binary(prims, first, left_count, left_box, left_centroids, depth + 1, threads_left);
            node->right = build_binary(prims, mid, right_count, right_box, right_centroids, depth + 1, threads_left);
        }
        return node;
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

    // Block `b` holds the triangles of prims[first, first + count); unused lanes are zero.
    void fill_block(Block& b, const Prims& prims, std::uint32_t first, std::uint32_t count) const noexcept {
        for (int k = 0; k < 8; ++k) {
            const bool used = std::uint32_t(k) < count;
            const std::uint32_t index = used ? prims[first + std::uint32_t(k)].index : empty_child;
            const Triangle<T>* tri = used ? &(*triangles_)[index] : nullptr;
            const Vertex<T> zero{};
            const Vertex<T>* vs[3] = {used ? &tri->v0 : &zero, used ? &tri->v1 : &zero, used ? &tri->v2 : &zero};
            for (int v = 0; v < 3; ++v)
                for (int a = 0; a < 3; ++a) b.v[v][a][k] = component(*vs[v], a);
            b.primitive[k] = index;
        }
    }

    // Plans the collapse of the binary tree into 8-wide nodes for the least SAH cost, visiting
    // a node costing `node_cost` and testing a leaf block `leaf_cost` per unit of box area
    // (Ylitie, Karras & Laine 2017, §3.1, with whole subtrees of up to leaf_size triangles
    // allowed to become one leaf). Fills BinaryNode::cost, how and wide_split, bottom-up.
    void plan(detail::BinaryNode<T>& n) const {
        const T area = n.box.half_area();
        if (n.leaf()) {
            for (int j = 0; j < 8; ++j) n.cost[j] = leaf_cost * area, n.how[j] = 0;
            return;
        }
        plan(*n.left), plan(*n.right);
        T wide = std::numeric_limits<T>::infinity();
        for (int i = 1; i < 8; ++i) {
            const T c = n.left->cost[i - 1] + n.right->cost[7 - i];
            if (c < wide) wide = c, n.wide_split = std::uint8_t(i);
        }
        wide += node_cost * area;
        n.cost[0] = wide, n.how[0] = 0;
        if (n.count <= std::uint32_t(leaf_size_) && leaf_cost * area <= wide) n.cost[0] = leaf_cost * area, n.how[0] = n.merged;
        for (int j = 2; j <= 8; ++j) {
            n.cost[j - 1] = n.cost[0], n.how[j - 1] = n.how[0];
            for (int i = 1; i < j; ++i) {
                const T c = n.left->cost[i - 1] + n.right->cost[j - i - 1];
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
        T org[3], inv[3];
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
    };

    // Per-ray set-up, with as few branches as it can: most rays of a frame cost a few node
    // visits, so this is a fair part of their time.
    static RayData prepare(const Ray<T>& ray) noexcept {
        RayData r;
        const Vertex<T>& o = ray.origin;
        const Vertex<T>& d = ray.direction;
        r.dir = d;
        const T ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
        // x − x is 0 for a finite x and NaN otherwise
        const T finite = ((o.x - o.x) + (o.y - o.y)) + ((o.z - o.z) + (d.x - d.x)) + ((d.y - d.y) + (d.z - d.z));
        r.ok = (finite == T(0)) & (std::max(ax, std::max(ay, az)) > T(0));
        constexpr T tiny = sizeof(T) == 4 ? T(1e-18) : T(1e-150);
        constexpr T u = std::numeric_limits<T>::epsilon() / 2, widen = T(1) + T(2) * (T(3) * u / (T(1) - T(3) * u));
        for (int a = 0; a < 3; ++a) {
            const T da = component(d, a);
            const T safe = std::copysign(std::max(std::fabs(da), tiny), da); // ±0 → ±tiny: no 0·∞ = NaN
            r.org[a] = component(o, a);
            r.inv[a] = T(1) / safe;
            r.inv_far[a] = r.inv[a] * widen;
            const T org_inv = r.org[a] * r.inv[a], org_inv_far = r.org[a] * r.inv_far[a];
            constexpr T allowance = T(4) * std::numeric_limits<T>::epsilon();
            r.org_inv_near[a] = org_inv + allowance * std::fabs(org_inv);
            r.org_inv_far[a] = org_inv_far - allowance * std::fabs(org_inv_far);
            const bool near_is_lo = !std::signbit(safe);
            const std::size_t lo = std::size_t(a) * sizeof(Node::lo[0]), hi = sizeof(Node::lo) + lo;
            r.near_plane[a] = near_is_lo ? lo : hi;
            r.far_plane[a] = near_is_lo ? hi : lo;
        }
        return r;
    }

    // The 8 lanes of a plane of `n` at byte `offset` (RayData::near_plane, far_plane).
    static const T* plane(const Node& n, std::size_t offset) noexcept {
        return reinterpret_cast<const T*>(reinterpret_cast<const char*>(&n) + offset);
    }

    // Slab test of the 8 children: bit k set when child k's box is entered before `t_far`.
    // Exits are computed with RayData::inv_far, so that no rounding drops a box the ray touches.
    static unsigned hit_children(const Node& n, const RayData& r, T t_far, T (&t_near)[8]) noexcept {
#if defined(__AVX__)
        if constexpr (sizeof(T) == sizeof(float)) { // 8 boxes in one 256-bit register per plane
            __m256 t0[3], t1[3]; // entry and exit distances of each axis' slab
            for (int a = 0; a < 3; ++a) {
                const __m256 near_plane = _mm256_load_ps(plane(n, r.near_plane[a]));
                const __m256 far_plane = _mm256_load_ps(plane(n, r.far_plane[a]));
#if defined(__FMA__)
                // p·inv − o·inv in one FMA; o·inv is rounded, so the entry subtracts and the exit
                // adds the per-ray allowance (prepare: org_inv_near / org_inv_far).
                t0[a] = _mm256_fmsub_ps(near_plane, _mm256_set1_ps(float(r.inv[a])), _mm256_set1_ps(float(r.org_inv_near[a])));
                t1[a] = _mm256_fmsub_ps(far_plane, _mm256_set1_ps(float(r.inv_far[a])), _mm256_set1_ps(float(r.org_inv_far[a])));
#else
                const __m256 org = _mm256_set1_ps(float(r.org[a]));
                t0[a] = _mm256_mul_ps(_mm256_sub_ps(near_plane, org), _mm256_set1_ps(float(r.inv[a])));
                t1[a] = _mm256_mul_ps(_mm256_sub_ps(far_plane, org), _mm256_set1_ps(float(r.inv_far[a])));
#endif
            }
            // two levels of max / min, not three: this is the traversal's critical path
            const __m256 tn = _mm256_max_ps(_mm256_max_ps(t0[0], t0[1]), _mm256_max_ps(t0[2], _mm256_setzero_ps()));
            const __m256 tf = _mm256_min_ps(_mm256_min_ps(t1[0], t1[1]), _mm256_min_ps(t1[2], _mm256_set1_ps(float(t_far))));
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
            tn = tn > near ? tn : near;
            tf = tf < far ? tf : far;
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
                tn = std::max(tn, (plane(n, r.near_plane[a])[k] - r.org[a]) * r.inv[a]);
                tf = std::min(tf, (plane(n, r.far_plane[a])[k] - r.org[a]) * r.inv_far[a]);
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
            if (b.primitive[k] == empty_child) break;
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
    // a·b − c·d on 8 float lanes, sign exact: Kahan's difference of products with explicit FMA.
    static __m256 difference_of_products8(__m256 a, __m256 b, __m256 c, __m256 d) noexcept {
        const __m256 cd = _mm256_mul_ps(c, d);
        const __m256 error = _mm256_fmsub_ps(c, d, cd);  // c·d − cd, exact
        const __m256 ab_minus_cd = _mm256_fmsub_ps(a, b, cd);
        return _mm256_sub_ps(ab_minus_cd, error);
    }

    // The watertight test on 8 float lanes with AVX2 and FMA (WBW §3). U, V, W have exact signs
    // (difference_of_products8), so the test stays watertight; padding lanes have det = 0.
    static bool hit_block_avx2(const Block& b, const RayData& r, BvhHit<T>& best) noexcept {
        const __m256 ox = _mm256_set1_ps(float(r.org[r.shear.kx])), oy = _mm256_set1_ps(float(r.org[r.shear.ky]));
        const __m256 oz = _mm256_set1_ps(float(r.org[r.shear.kz]));
        const __m256 Sx = _mm256_set1_ps(float(r.shear.Sx)), Sy = _mm256_set1_ps(float(r.shear.Sy));
        __m256 x[3], y[3], pz[3];
        for (int v = 0; v < 3; ++v) {
            pz[v] = _mm256_sub_ps(_mm256_load_ps(b.v[v][r.shear.kz]), oz);
            x[v] = _mm256_fnmadd_ps(Sx, pz[v], _mm256_sub_ps(_mm256_load_ps(b.v[v][r.shear.kx]), ox)); // WBW: Ax = A[kx] − Sx·A[kz]
            y[v] = _mm256_fnmadd_ps(Sy, pz[v], _mm256_sub_ps(_mm256_load_ps(b.v[v][r.shear.ky]), oy));
        }
        const __m256 U = difference_of_products8(x[2], y[1], y[2], x[1]);  // WBW: U = Cx·By − Cy·Bx
        const __m256 V = difference_of_products8(x[0], y[2], y[0], x[2]);  // WBW: V = Ax·Cy − Ay·Cx
        const __m256 W = difference_of_products8(x[1], y[0], y[1], x[0]);  // WBW: W = Bx·Ay − By·Ax
        const __m256 zero = _mm256_setzero_ps();
        // Inside: U, V, W all ≥ 0 or all ≤ 0. A NaN passes here and fails det ≠ 0 (ordered) below.
        const __m256 lowest = _mm256_min_ps(_mm256_min_ps(U, V), W), highest = _mm256_max_ps(_mm256_max_ps(U, V), W);
        const __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), W);
        __m256 ok = _mm256_and_ps(_mm256_or_ps(_mm256_cmp_ps(lowest, zero, _CMP_GE_OQ), _mm256_cmp_ps(highest, zero, _CMP_LE_OQ)),
                                  _mm256_cmp_ps(det, zero, _CMP_NEQ_OQ));
        if (_mm256_testz_ps(ok, ok)) return false; // most blocks end here, before the division
        const __m256 Sz = _mm256_set1_ps(float(r.shear.Sz));
        const __m256 t_scaled = _mm256_mul_ps(Sz, _mm256_fmadd_ps(W, pz[2], _mm256_fmadd_ps(V, pz[1], _mm256_mul_ps(U, pz[0]))));
        const __m256 t = _mm256_div_ps(t_scaled, det);
        ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(t, zero, _CMP_GT_OQ), _mm256_cmp_ps(t, _mm256_set1_ps(float(best.t)), _CMP_LT_OQ)));
        if (_mm256_testz_ps(ok, ok)) return false;
        // Horizontal minimum of the hits, then its lane.
        const __m256 cand = _mm256_blendv_ps(_mm256_set1_ps(std::numeric_limits<float>::infinity()), t, ok);
        __m256 m = _mm256_min_ps(cand, _mm256_permute_ps(cand, 0xB1));
        m = _mm256_min_ps(m, _mm256_permute_ps(m, 0x4E));
        m = _mm256_min_ps(m, _mm256_permute2f128_ps(m, m, 0x01));
        const unsigned lanes = unsigned(_mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(cand, m, _CMP_EQ_OQ), ok)));
        const int k = lowest_bit(lanes);
        alignas(32) float tv[8], uv[8], vv[8], dv[8];
        _mm256_store_ps(tv, t), _mm256_store_ps(uv, V), _mm256_store_ps(vv, W), _mm256_store_ps(dv, det);
        best.t = tv[k];
        best.u = uv[k] / dv[k];
        best.v = vv[k] / dv[k];
        best.primitive = b.primitive[k];
        return true;
    }
#endif

#if defined(__AVX2__) && defined(__FMA__)
    // a·b − c·d on 4 double lanes, sign exact (as difference_of_products8).
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
        for (int half = 0; half < 8 && b.primitive[half] != empty_child; half += 4) {
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
            const __m256d t_scaled = _mm256_mul_pd(_mm256_set1_pd(double(r.shear.Sz)),
                                                   _mm256_fmadd_pd(W, pz[2], _mm256_fmadd_pd(V, pz[1], _mm256_mul_pd(U, pz[0]))));
            const __m256d t = _mm256_div_pd(t_scaled, det);
            ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(t, zero, _CMP_GT_OQ), _mm256_cmp_pd(t, _mm256_set1_pd(double(best.t)), _CMP_LT_OQ)));
            const unsigned lanes = unsigned(_mm256_movemask_pd(ok));
            if (!lanes) continue;
            alignas(32) double tv[4], uv[4], vv[4], dv[4];
            _mm256_store_pd(tv, t), _mm256_store_pd(uv, V), _mm256_store_pd(vv, W), _mm256_store_pd(dv, det);
            int k = -1;
            for (int l = 0; l < 4; ++l)
                if (((lanes >> l) & 1u) && (k < 0 || tv[l] < tv[k])) k = l;
            best.t = T(tv[k]), best.u = T(uv[k] / dv[k]), best.v = T(vv[k] / dv[k]);
            best.primitive = b.primitive[half + k];
            found = true;
        }
        return found;
    }
#endif

#if ISIN_VECTOR_EXTENSIONS
    // The same test on 8 float lanes at once (WBW §3). The edge functions U, V, W are products of
    // floats formed in double, where they are exact: their signs are right whatever the
    // compiler contracts, so the test stays watertight; det and t follow in double.
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
            z[v] = float(r.shear.Sz) * pz;
        }
        const D X0 = __builtin_convertvector(x[0], D), Y0 = __builtin_convertvector(y[0], D);
        const D X1 = __builtin_convertvector(x[1], D), Y1 = __builtin_convertvector(y[1], D);
        const D X2 = __builtin_convertvector(x[2], D), Y2 = __builtin_convertvector(y[2], D);
        const D U = X2 * Y1 - Y2 * X1;             // WBW: U = Cx·By − Cy·Bx (exact products)
        const D Vv = X0 * Y2 - Y0 * X2;            // WBW: V = Ax·Cy − Ay·Cx
        const D W = X1 * Y0 - Y1 * X0;             // WBW: W = Bx·Ay − By·Ax
        const D det = U + Vv + W;
        const D t_scaled = U * __builtin_convertvector(z[0], D) + Vv * __builtin_convertvector(z[1], D) +
                           W * __builtin_convertvector(z[2], D);
        const D t = t_scaled / det;                // lanes with det = 0 give ±∞ or NaN: rejected below
        const auto inside = ((U >= 0.0) & (Vv >= 0.0) & (W >= 0.0)) | ((U <= 0.0) & (Vv <= 0.0) & (W <= 0.0));
        const auto ok = inside & (det != 0.0) & (t > 0.0) & (t < double(best.t)); // padding: det = 0
        const D candidates = ok ? t : D{} + std::numeric_limits<double>::infinity();
        double t_win = candidates[0];
        for (int k = 1; k < 8; ++k) t_win = candidates[k] < t_win ? candidates[k] : t_win; // horizontal min
        if (!(t_win < double(best.t))) return false;
        int winner = 0;
        while (candidates[winner] != t_win) ++winner;
        const float t_hit = float(t_win);
        if (!(t_hit < best.t)) return false; // rounding to float reached best.t
        best.t = t_hit;
        best.u = float(Vv[winner] / det[winner]);
        best.v = float(W[winner] / det[winner]);
        best.primitive = b.primitive[winner];
        return true;
    }
#endif

    template <bool any_hit>
    bool traverse(const Ray<T>& ray, BvhHit<T>& best) const noexcept {
        if (nodes_.empty()) return false;
        RayData r = prepare(ray);
        if (!r.ok || !(best.t > T(0))) return false;
        bool sheared = false;
        struct Entry {
            std::uint32_t ref;
            T t;
        };
        Entry stack[8 * 64]; // the build bounds the depth by ~40 + log2(n): 7 entries a level
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
                unsigned mask = hit_children(n, r, best.t, t_near);
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
    int leaf_size_ = 8;
    const std::vector<Triangle<T>>* triangles_ = nullptr; // during the build only
    struct Range {
        std::uint32_t first, count;
    };
    std::vector<Range> leaves_; // during the build only: the prims of each block
};

} // namespace isin
