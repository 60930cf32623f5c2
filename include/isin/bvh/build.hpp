#pragma once
/// isin — building a BvhTree: binned SAH over the primitives' boxes (8 bins, all axes, subtrees on
/// several threads), collapsed to 8-wide nodes for the least SAH cost (Ylitie, Karras & Laine
/// 2017). Any boxes build: empty and non-finite ones are left out, bins, centroids and areas
/// are computed so that no finite coordinate overflows, and the depth is bounded.
///
///     auto tree = isin::build_bvh<float>(spheres.size(), [&](std::size_t i) { return bounds(spheres[i]); });
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <condition_variable>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "../detail/attributes.hpp"
#include "../detail/compiled.hpp"
#include "../detail/huge_pages.hpp"
#include "../detail/parallel.hpp"
#include "box.hpp"
#include "tree.hpp"

namespace isin {
namespace detail {

// A node of the binary SAH tree, before it is collapsed to 8-wide nodes. Nodes live in their
// build thread's NodePool, which owns them: the children are plain pointers.
template <class T>
struct BinaryNode {
    Box<T> box;
    BinaryNode* left = nullptr;
    BinaryNode* right = nullptr;
    std::uint32_t first = 0, count = 0; // a range of the build's primitive order
    // The collapse's plan (BvhBuilder::plan): cost[j − 1] is the least SAH cost of this subtree as at
    // most j children of an 8-wide node; how[j − 1] says how: 0 one child (an 8-wide node, or
    // this leaf), `merged` one leaf holding the whole subtree, i in 1…7: i children from the
    // left subtree and up to j − i from the right. An 8-wide node made here takes wide_split
    // children from the left subtree and up to 8 − wide_split from the right.
    static constexpr std::uint8_t merged = 0xff;
    T cost[8] = {};
    std::uint8_t how[8] = {};
    std::uint8_t wide_split = 1;
    bool planned = false;      // cost, how and wide_split are set (BvhBuilder::plan)
    std::uint16_t builder = 0; // the build thread that made it, in its pool (collapse_subtrees: the one to collapse it)
    [[nodiscard]] bool leaf() const noexcept { return !left; }
    [[nodiscard]] bool becomes_leaf() const noexcept { return !left || how[0] == merged; }
};

// The binary nodes one build thread makes, in blocks it allocates and writes itself (bump
// allocation; all freed with the pool). Blocks double from about the thread's share of the
// nodes' expected number up to `largest`, so small builds stay small, and large ones get blocks
// of 2 MiB or more, mapped on huge pages of their own like the build's other arrays
// (UninitAllocator, detail/huge_pages.hpp); two malloc'ed nodes per split would sit on 4 KiB
// pages in each thread's own heap, handed back to the kernel between builds and faulted in again.
template <class T>
class alignas(64) NodePool { // 64: the build threads' pools never share a cache line
public:
    NodePool() = default;
    NodePool(const NodePool&) = delete;
    NodePool& operator=(const NodePool&) = delete;
    ~NodePool() {
        static_assert(std::is_trivially_destructible_v<BinaryNode<T>>, "nodes are freed with their blocks");
        for (const Block& b : blocks_) UninitAllocator<BinaryNode<T>>(kept_).deallocate(b.nodes, b.size);
    }
    // Sets the first block's size (nodes): about this thread's share; and where blocks come from
    // and go back to (a BuildContext's, or none).
    void expect(std::size_t nodes, KeptBlocks* kept) noexcept {
        next_size_ = std::clamp<std::size_t>(nodes, 64, largest);
        kept_ = kept;
    }
    // A new node, value-initialised (no children, not planned).
    BinaryNode<T>* make() {
        if (used_ == available_) grow();
        return ::new (static_cast<void*>(blocks_.back().nodes + used_++)) BinaryNode<T>();
    }

private:
    // Nodes in the largest blocks: 4 MiB, two whole huge pages (detail::mapped_bytes).
    static constexpr std::size_t largest = (std::size_t(4) << 20) / sizeof(BinaryNode<T>);
    struct Block {
        BinaryNode<T>* nodes;
        std::size_t size;
    };
    void grow() {
        if (blocks_.size() == blocks_.capacity()) // so that push_back cannot throw after the allocation
            blocks_.reserve(2 * blocks_.size() + 4);
        BinaryNode<T>* const nodes =
            UninitAllocator<BinaryNode<T>>(kept_).allocate(next_size_); // huge pages from 2 MiB
        blocks_.push_back({nodes, next_size_});
        used_ = 0, available_ = next_size_;
        next_size_ = std::min(largest, 2 * next_size_);
    }
    std::vector<Block> blocks_;
    std::size_t used_ = 0, available_ = 0, next_size_ = 64;
    KeptBlocks* kept_ = nullptr;
};

// Builds one BvhTree; its state (the primitives' boxes and centroids, the binary tree) ends with it.
template <class T>
class BvhBuilder {
public:
    using Node = typename BvhTree<T>::Node;
    static constexpr std::uint32_t leaf_bit = BvhTree<T>::leaf_bit;
    static constexpr std::uint32_t empty_child = BvhTree<T>::empty_child;

    struct Prim {
        L4<T> lo, hi, centroid; // lanes x, y, z, unused
        std::uint32_t index;
        std::uint8_t bin[3]; // its bin on each axis, in the node being split (kept for the partition)
    };
    using Prims = std::vector<Prim, UninitAllocator<Prim>>;

    template <class BoxOf>
    BvhTree<T> build(std::size_t n, const BoxOf& box_of, const BvhOptions& options) {
        if (n >= std::size_t(empty_child)) throw std::length_error("isin::build_bvh: more than 2^32 - 2 primitives");
        const int threads = thread_count(options.threads);
        // The primitives (box, centroid), in chunks; unusable boxes (empty, not finite) are
        // marked and then left out.
        // The bounds of the boxes and of their centroids come from the same pass, chunk by chunk.
        KeptBlocks* const kept = options.context ? &options.context->kept_blocks() : nullptr;
        Prims prims(n, UninitAllocator<Prim>(kept));
        std::atomic<bool> unusable{false};
        Box4<T> box, centroids;
        std::mutex merging;
        parallel_chunks(n, threads, parallel_min, [&](std::size_t begin, std::size_t end) {
            bool skipped = false;
            Box4<T> chunk_box, chunk_centroids;
            for (std::size_t i = begin; i < end; ++i) {
                const Box<T> b = box_of(i);
                Prim& p = prims[i];
                p.index = static_cast<std::uint32_t>(i);
                if (!b.usable()) {
                    p.index = empty_child;
                    skipped = true;
                    continue;
                }
                for (int a = 0; a < 3; ++a) {
                    p.lo[a] = component(b.lo, a), p.hi[a] = component(b.hi, a);
                    p.centroid[a] = p.lo[a] * T(0.5) + p.hi[a] * T(0.5); // (lo + hi)/2 would overflow above max/2
                }
                p.lo[3] = p.hi[3] = p.centroid[3] = T(0);
                chunk_box.grow(p.lo, p.hi), chunk_centroids.grow(p.centroid, p.centroid);
            }
            if (skipped) unusable = true;
            const std::lock_guard<std::mutex> lock(merging);
            box.grow(chunk_box), centroids.grow(chunk_centroids);
        });
        if (unusable)
            prims.erase(
                std::remove_if(prims.begin(), prims.end(), [](const Prim& p) { return p.index == empty_child; }),
                prims.end());
        if (prims.empty()) return std::move(tree_);
        leaf_size_ = std::clamp(options.leaf_size, 1, 8);
        const Box<T> root_box = box.box();
        tree_.bound_ = std::max(max_abs(root_box.lo), max_abs(root_box.hi));
        threads_ = std::min(threads, 0xffff); // BinaryNode::builder: a pool for each
        pools_ = std::vector<NodePool<T>>(std::size_t(threads_));
        for (auto& pool : pools_) pool.expect(prims.size() / std::size_t(threads_), kept);
        BinaryNode<T>* const root = pools_[0].make();
        root->box = root_box, root->count = static_cast<std::uint32_t>(prims.size());
        build_binary(prims, {root, centroids.box(), 0});
        reserve_huge_pages(tree_.nodes_, prims.size() / 4 + 1);
        reserve_huge_pages(tree_.leaves_, prims.size() / 2 + 1);
        plan(*root);
        Wide tree{tree_.nodes_, tree_.leaves_};
        if (root->becomes_leaf() || threads_ <= 1 || root->count < parallel_min) {
            if (root->becomes_leaf()) { // a single leaf: a root node with one child
                tree.nodes.emplace_back();
                clear(tree.nodes[0]);
                set_child(tree, 0, 0, *root, add_leaf(tree, *root));
            } else {
                collapse(tree, *root);
            }
            size_order(prims.size()); // after the collapse: see collapse_subtrees
            fill_order(prims, 0, static_cast<std::uint32_t>(prims.size()));
        } else {
            std::vector<Subtree> subtrees;
            collapse(tree, *root, &subtrees);
            size_order(prims.size());
            collapse_subtrees(prims, subtrees); // fills the primitive order too
        }
        tree_.measure_leaf_scale();
        return std::move(tree_);
    }

private:
    // Parallel loops of the build take chunks of at least this many items; the binary build's
    // work queue holds subtrees from this many primitives on (smaller ones are built at once).
    static constexpr std::size_t parallel_min = 32768;
    static constexpr std::uint32_t task_min = 4096;
    // Nodes of this many primitives or more (the first levels) are binned on every thread.
    static constexpr std::uint32_t parallel_bin_min = 131072;
    // The binary build splits by SAH down to this depth, and at the median below it, so the tree
    // is at most sah_depth + 32 levels deep for any input (the traversal stack is sized by it).
    static constexpr int sah_depth = BvhTree<T>::depth_limit - 32;
    static constexpr int bins = 8; // more bins trace no faster and build slower (docs/performance.md)
    // Ranges of this many primitives or more are binned into two sets of bins, alternate
    // primitives, merged after (the same bins): neighbours in a coherent mesh often fall in the
    // same bins, and with one set each bin's update waits for the one before. Small nodes' extra
    // set of bins costs more than it saves (docs/performance.md).
    static constexpr std::uint32_t two_bin_sets_min = 1024;
    // The partition looks at the sides of this many first primitives of a node, and goes
    // without branches when a quarter of neighbours or more change side (see split): faster on a
    // random soup, alike where the plain partition's branches predict well (docs/performance.md).
    static constexpr std::uint32_t coin_toss_sample = 32;

    // Where a centroid falls among the bins of each axis: ⌊(c − lo)·bins·(1 − ε)/extent⌋, computed
    // from halves (0.5c − 0.5lo) so that no finite coordinates overflow, at most bins − 1. An axis whose extent is 0, or so small that the scale overflows (subnormal
    // noise), has scale 0 and is not binned.
    struct Binning {
        T half_lo[3], scale[3];
        Binning(const Box<T>& centroids) noexcept {
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

    struct Bin {
        Box4<T> box;
        std::uint32_t n = 0;
    };
    struct Bins {
        Bin at[3][bins];
        void merge(const Bins& o) noexcept {
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < bins; ++b) {
                    Bin& x = at[a][b];
                    const Bin& y = o.at[a][b];
                    if (!y.n) continue;
                    x.box.grow(y.box.lo, y.box.hi), x.n += y.n;
                }
        }
    };

    // A node of the binary build still to split: its box, first and count are set; the bounds
    // of its primitives' centroids, and its depth.
    struct Pending {
        BinaryNode<T>* node;
        Box<T> centroids;
        int depth;
    };

    // split's binning: the centroids of prims[first, first + count) into `bin` on every axis
    // (each primitive keeps its bins, for the partition).
    ISIN_DETAIL_INLINE void bin_node(Prims& prims, std::uint32_t first, std::uint32_t count, const Binning& binning,
                                     Bins& bin) const {
        const auto bin_one = [&](Prim& p, Bins& into) {
            for (int a = 0; a < 3; ++a) {
                const int k = binning.bin(p, a);
                p.bin[a] = static_cast<std::uint8_t>(k);
                Bin& b = into.at[a][k];
                b.box.grow(p.lo, p.hi), ++b.n;
            }
        };
        const auto bin_range = [&](std::uint32_t begin, std::uint32_t end, Bins& into) {
            std::uint32_t i = begin;
            if (end - begin >= two_bin_sets_min) { // alternate primitives into two sets, merged after
                Bins other;
                for (; end - i >= 2; i += 2) bin_one(prims[i], into), bin_one(prims[i + 1], other);
                into.merge(other);
            }
            for (; i < end; ++i) bin_one(prims[i], into);
        };
        if (threads_ > 1 && count >= parallel_bin_min) {
            // The first splits, before the queue has work for every thread: binned in chunks
            // on all threads, the chunks' bins merged.
            std::mutex merging;
            parallel_chunks(count, threads_, parallel_min, [&](std::size_t begin, std::size_t end) {
                Bins part;
                bin_range(first + std::uint32_t(begin), first + std::uint32_t(end), part);
                const std::lock_guard<std::mutex> lock(merging);
                bin.merge(part);
            });
        } else {
            bin_range(first, first + count, bin);
        }
    }

    // Binary SAH split of node prims[first, first + count), whose box and centroid bounds the
    // caller knows: into two children (true; `left` and `right` then name them) or none (a
    // leaf). One pass bins the centroids on all three axes; the sweep gives the children's boxes
    // and centroid bounds, so no level re-reads its primitives for them. Below sah_depth, or when
    // no axis can be binned (all centroids within rounding of each other), it splits at the
    // median of the widest axis, which bounds the depth (and so the traversal stack) for any input.
    bool split(Prims& prims, const Pending& at, Pending& left, Pending& right) {
        BinaryNode<T>* const node = at.node;
        const std::uint32_t first = node->first, count = node->count;
        const Box<T>& box = node->box;
        const Box<T>& centroids = at.centroids;
        const int depth = at.depth;
        if (count <= 2 && count <= std::uint32_t(leaf_size_)) return false;

        Bins bin;
        const Binning binning(centroids);
        const bool binned = depth < sah_depth && binning.any();
        if (binned) bin_node(prims, first, count, binning, bin);
        // Sweep: cost = Σ area · count over the two sides.
        T best_cost = std::numeric_limits<T>::infinity(), best_areas = best_cost;
        int best_axis = -1, best_split = 0;
        std::uint32_t best_left_count = 0; // primitives on the left of the best split
        for (int a = 0; a < 3 && binned; ++a) {
            if (!(binning.scale[a] > T(0))) continue;
            const Bin* const axis = bin.at[a];
            T right_area[bins];
            std::uint32_t right_n[bins];
            Box4<T> acc; // grown bin by bin as two vector min/max
            std::uint32_t acc_n = 0;
            for (int b = bins - 1; b > 0; --b)
                acc.grow(axis[b].box), acc_n += axis[b].n, right_area[b] = acc.area(), right_n[b] = acc_n;
            acc = {}, acc_n = 0;
            for (int b = 0; b < bins - 1; ++b) {
                acc.grow(axis[b].box), acc_n += axis[b].n;
                if (acc_n == 0 || right_n[b + 1] == 0) continue;
                const T left_area = acc.area();
                const T cost = left_area * T(acc_n) + right_area[b + 1] * T(right_n[b + 1]);
                if (cost < best_cost)
                    best_cost = cost, best_axis = a, best_split = b, best_areas = left_area + right_area[b + 1],
                    best_left_count = acc_n;
            }
        }
        // Up to leaf_size triangles cost one 8-lane test as a leaf, as each child would: split
        // only when the two children's boxes together have well under this box's area (the
        // ratio: the middle of the range whose trees trace alike, docs/performance.md).
        constexpr T split_area_ratio = T(0.6);
        if (count <= std::uint32_t(leaf_size_) && !(best_areas < split_area_ratio * box.area())) return false;

        std::uint32_t mid = first;
        Box<T> left_box, right_box, left_centroids, right_centroids;
        if (best_axis >= 0) {
            const int a = best_axis;
            for (int b = 0; b < bins; ++b)
                if (bin.at[a][b].n) (b <= best_split ? left_box : right_box).grow(bin.at[a][b].box.box());
            // The partition, by the bins the binning gave (so the sweep's counts), finds the
            // children's centroid bounds on the way: each primitive is tested once.
            const auto goes_left = [&](const Prim& p) { return p.bin[a] <= best_split; };
            Box4<T> side[2]; // the centroid bounds of the left and the right child
            // Where the first primitives' sides change often (a soup's triangles in random
            // order), the branches of a plain partition would mispredict half the time.
            std::uint32_t changes = 0;
            if (count >= coin_toss_sample)
                for (std::uint32_t k = first + 1; k < first + coin_toss_sample; ++k)
                    changes += goes_left(prims[k]) != goes_left(prims[k - 1]) ? 1u : 0u;
            if (changes >= coin_toss_sample / 4) {
                mid = first + best_left_count;
                partition_without_branches(prims, first, mid, first + count, goes_left, side);
            } else {
                std::uint32_t i = first, j = first + count;
                for (;;) {
                    while (i < j && goes_left(prims[i])) side[0].grow(prims[i].centroid, prims[i].centroid), ++i;
                    while (i < j && !goes_left(prims[j - 1])) --j, side[1].grow(prims[j].centroid, prims[j].centroid);
                    if (i == j) break;
                    std::swap(prims[i], prims[j - 1]);
                    side[0].grow(prims[i].centroid, prims[i].centroid), ++i;
                    --j, side[1].grow(prims[j].centroid, prims[j].centroid);
                }
                mid = i;
            }
            left_centroids = side[0].box(), right_centroids = side[1].box();
        }
        if (mid == first || mid == first + count) { // deep, or no axis binned: the median of the widest axis
            const Vertex<T> extent = centroids.hi * T(0.5) - centroids.lo * T(0.5);
            const int a = extent.x >= extent.y ? (extent.x >= extent.z ? 0 : 2) : (extent.y >= extent.z ? 1 : 2);
            mid = first + count / 2;
            select_median(prims, first, count, a);
            Box4<T> lb, lc, rb, rc;
            for (std::uint32_t i = first; i < mid; ++i)
                lb.grow(prims[i].lo, prims[i].hi), lc.grow(prims[i].centroid, prims[i].centroid);
            for (std::uint32_t i = mid; i < first + count; ++i)
                rb.grow(prims[i].lo, prims[i].hi), rc.grow(prims[i].centroid, prims[i].centroid);
            left_box = lb.box(), left_centroids = lc.box(), right_box = rb.box(), right_centroids = rc.box();
        }

        NodePool<T>& pool = pools_[node->builder];
        node->left = pool.make();
        node->right = pool.make();
        node->left->builder = node->right->builder = node->builder;
        node->left->box = left_box, node->left->first = first, node->left->count = mid - first;
        node->right->box = right_box, node->right->first = mid, node->right->count = first + count - mid;
        left = {node->left, left_centroids, depth + 1};
        right = {node->right, right_centroids, depth + 1};
        return true;
    }

    // Puts the primitives of prims[first, first + count) whose centroids lie below the median on
    // axis a first (the median at first + count / 2). The selection runs over (coordinate, place)
    // pairs and then moves each primitive once along its cycle: std::nth_element over Prim itself
    // passes a 32-byte-aligned Prim by value in its heap fallback, which g++ reports as an ABI note.
    static void select_median(Prims& prims, std::uint32_t first, std::uint32_t count, int a) {
        std::vector<std::pair<T, std::uint32_t>> keys(count);
        for (std::uint32_t i = 0; i < count; ++i) keys[i] = {T(prims[first + i].centroid[a]), i};
        std::nth_element(keys.begin(), keys.begin() + count / 2, keys.end());
        for (std::uint32_t i = 0; i < count; ++i) { // place i takes the primitive from place keys[i].second
            if (keys[i].second == i) continue;
            Prim held = prims[first + i];
            std::uint32_t j = i;
            while (keys[j].second != i) {
                const std::uint32_t from = keys[j].second;
                prims[first + j] = prims[first + from];
                keys[j].second = j;
                j = from;
            }
            prims[first + j] = held;
            keys[j].second = j;
        }
    }

    // Partitions prims[first, end) so that the primitives `goes_left` takes, of which there are
    // mid − first, come first, and grows side[0] and side[1] by the centroids of either side,
    // without a branch on any primitive's side: misplaced primitives of each side are listed a
    // block at a time and swapped in pairs (Edelkamp & Weiß, "BlockQuicksort: Avoiding Branch
    // Mispredictions in Quicksort", 2016). Each side holds as many misplaced primitives as the
    // other, so the lists pair up; the loop also ends should they not (no progress).
    template <class GoesLeft>
    static void partition_without_branches(Prims& prims, std::uint32_t first, std::uint32_t mid, std::uint32_t end,
                                           const GoesLeft& goes_left, Box4<T> (&side)[2]) {
        constexpr std::uint32_t block = 64;
        std::uint32_t misplaced[2][block], listed[2] = {0, 0}, swapped[2] = {0, 0};
        std::uint32_t next[2] = {first, mid};
        const std::uint32_t stop[2] = {mid, end};
        const auto list = [&](int s) { // the next block of side s: its misplaced primitives
            listed[s] = swapped[s] = 0;
            const std::uint32_t last = std::min(stop[s], next[s] + block);
            for (std::uint32_t k = next[s]; k < last; ++k) {
                const Prim& p = prims[k];
                const int to = goes_left(p) ? 0 : 1;
                misplaced[s][listed[s]] = k, listed[s] += to != s ? 1 : 0;
                side[to].grow(p.centroid, p.centroid);
            }
            next[s] = last;
        };
        for (;;) {
            bool progress = false;
            for (int s = 0; s < 2; ++s)
                if (swapped[s] == listed[s] && next[s] < stop[s]) list(s), progress = true;
            const std::uint32_t pairs = std::min(listed[0] - swapped[0], listed[1] - swapped[1]);
            for (std::uint32_t k = 0; k < pairs; ++k)
                std::swap(prims[misplaced[0][swapped[0] + k]], prims[misplaced[1][swapped[1] + k]]);
            swapped[0] += pairs, swapped[1] += pairs;
            if (pairs == 0 && !progress) return;
        }
    }

    // The binary tree below `at`, on this thread.
    void build_subtree(Prims& prims, const Pending& at) {
        Pending left, right;
        if (!split(prims, at, left, right)) return;
        build_subtree(prims, left);
        build_subtree(prims, right);
    }

    // The binary tree below `root` on up to threads_ threads: subtrees of task_min primitives
    // or more wait in a shared queue (last in, first out: depth first), any idle thread takes the
    // next, so both cores stay busy however unevenly SAH splits; smaller ones are built at once.
    // Threads that cannot start leave their share to the others (run_workers); an exception in
    // one (no memory) stops the others and reaches the caller.
    void build_binary(Prims& prims, const Pending& root) {
        if (threads_ <= 1 || root.node->count < 2 * task_min) return build_subtree(prims, root);
        std::mutex mutex;
        std::condition_variable changed;
        std::vector<Pending> queue{root};
        int working = 0;     // threads splitting or building a subtree taken from the queue
        bool failed = false; // a thread threw: the others stop
        run_workers(threads_, [&](int worker, const FirstError&) {
            std::unique_lock<std::mutex> lock(mutex);
            for (;;) {
                changed.wait(lock, [&] { return !queue.empty() || working == 0 || failed; });
                if (queue.empty() || failed) return changed.notify_all(); // all done (or stopped)
                const Pending at = queue.back();
                queue.pop_back();
                ++working;
                lock.unlock();
                at.node->builder = std::uint16_t(worker); // < threads_ ≤ 0xffff
                Pending left, right;
                bool has_children = false;
                try {
                    if (at.node->count >= task_min)
                        has_children = split(prims, at, left, right);
                    else
                        build_subtree(prims, at), plan(*at.node); // planned here, on this thread
                } catch (...) {
                    lock.lock();
                    --working, failed = true;
                    changed.notify_all();
                    throw; // run_workers records it for the caller
                }
                lock.lock();
                --working;
                if (has_children) queue.push_back(right), queue.push_back(left);
                changed.notify_all();
            }
        });
    }

    static void clear(Node& n) noexcept {
        for (int a = 0; a < 3; ++a)
            for (int k = 0; k < 8; ++k)
                n.lo[a][k] = std::numeric_limits<T>::infinity(), n.hi[a][k] = -std::numeric_limits<T>::infinity();
        for (auto& c : n.child) c = empty_child;
    }

    // The 8-wide nodes and leaves a collapse makes: the tree's own, or a subtree's.
    struct Wide {
        typename BvhTree<T>::template Array<Node>& nodes;
        typename BvhTree<T>::template Array<typename BvhTree<T>::Leaf>& leaves;
    };

    static void set_child(Wide& out, std::size_t node, int slot, const BinaryNode<T>& child, std::uint32_t ref) {
        Node& n = out.nodes[node];
        for (int a = 0; a < 3; ++a)
            n.lo[a][slot] = component(child.box.lo, a), n.hi[a][slot] = component(child.box.hi, a);
        n.child[slot] = ref;
    }

    // A leaf for the range of binary leaf `leaf`.
    static std::uint32_t add_leaf(Wide& out, const BinaryNode<T>& leaf) {
        out.leaves.push_back({leaf.first, leaf.count});
        return static_cast<std::uint32_t>(out.leaves.size() - 1) | leaf_bit;
    }

    // Plans the collapse of the binary tree into 8-wide nodes for the least SAH cost, visiting
    // a node costing `node_cost` and testing a leaf block `leaf_cost` per unit of box area
    // (Ylitie, Karras & Laine 2017, §3.1, with whole subtrees of up to leaf_size primitives
    // allowed to become one leaf). Fills BinaryNode::cost, how and wide_split, bottom-up.
    // Subtrees that build_binary's threads planned as they finished them are skipped.
    void plan(BinaryNode<T>& n) const {
        if (n.planned) return;
        n.planned = true;
        const T area = n.box.area();
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
        if (n.count <= std::uint32_t(leaf_size_) && leaf_cost * area <= wide)
            n.cost[0] = leaf_cost * area, n.how[0] = n.merged;
        for (int j = 2; j <= 8; ++j) {
            n.cost[j - 1] = n.cost[0], n.how[j - 1] = n.how[0];
            for (int i = 1; i < j; ++i) {
                const T c = n.left->cost[i - 1] + n.right->cost[j - i - 1];
                if (c < n.cost[j - 1]) n.cost[j - 1] = c, n.how[j - 1] = std::uint8_t(i);
            }
        }
    }

    // The children `plan` chose for subtree `n` given `slots` places.
    static void gather(BinaryNode<T>& n, int slots, std::vector<BinaryNode<T>*>& kids) {
        const int how = n.how[slots - 1];
        if (how == 0 || how == n.merged) {
            kids.push_back(&n);
        } else {
            gather(*n.left, how, kids);
            gather(*n.right, slots - how, kids);
        }
    }

    // A child node of fewer than task_min primitives whose collapse is left for later
    // (collapse_subtrees): its parent's node and slot. One build thread made all of its binary
    // subtree (BinaryNode::builder).
    struct Subtree {
        BinaryNode<T>* bin;
        std::uint32_t parent;
        int slot;
    };

    // Makes the 8-wide node that `plan` chose for binary node `bin` (inner), and its subtree, in
    // depth-first order: a node, then the subtree of each child in turn. Given `later`, child
    // nodes of fewer than task_min primitives are listed there in this order, their slots left
    // empty, so that only the nodes above them are made (a few hundred).
    static std::uint32_t collapse(Wide& out, BinaryNode<T>& bin, std::vector<Subtree>* later = nullptr) {
        const std::size_t index = out.nodes.size();
        out.nodes.emplace_back();
        clear(out.nodes[index]);
        std::vector<BinaryNode<T>*> kids;
        gather(*bin.left, bin.wide_split, kids);
        gather(*bin.right, 8 - bin.wide_split, kids);
        for (std::size_t k = 0; k < kids.size(); ++k) {
            BinaryNode<T>& kid = *kids[k];
            std::uint32_t ref = empty_child;
            if (kid.becomes_leaf())
                ref = add_leaf(out, kid);
            else if (later && kid.count < task_min)
                later->push_back({&kid, std::uint32_t(index), int(k)});
            else
                ref = collapse(out, kid, later);
            set_child(out, index, int(k), kid, ref);
        }
        return static_cast<std::uint32_t>(index);
    }

    // The tree's primitive order: sized once (not zeroed), then filled range by range.
    void size_order(std::size_t n) {
        reserve_huge_pages(tree_.primitives_, n);
        tree_.primitives_.resize(n);
    }
    void fill_order(const Prims& prims, std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t i = first; i < first + count; ++i) tree_.primitives_[i] = prims[i].index;
    }

    // Collapses the subtrees that collapse(…, later) left, on threads_ threads. Each thread takes
    // the subtrees it built first, while their nodes are in its core's cache and its own pool,
    // then any left over. Each subtree
    // gets nodes and leaves of its own, appended in the list's order with their references moved
    // by the nodes and leaves before it, and the same thread fills the subtree's range of the
    // primitive order. (One thread collapses depth first instead, and sizes the order after
    // the collapse: done this way, its next builds' arrays came back fresh from the kernel.)
    void collapse_subtrees(const Prims& prims, std::vector<Subtree>& subtrees) {
        Wide tree{tree_.nodes_, tree_.leaves_};
        for (const auto& leaf : tree.leaves)
            fill_order(prims, leaf.first, leaf.count); // the leaves made so far: above the subtrees
        using Leaf = typename BvhTree<T>::Leaf;
        struct Part {
            typename BvhTree<T>::template Array<Node> nodes;
            typename BvhTree<T>::template Array<Leaf> leaves;
        };
        std::vector<Part> parts(subtrees.size());
        const auto workers = std::size_t(threads_);
        std::vector<std::vector<std::size_t>> built_by(workers); // the subtrees each thread made
        for (std::size_t i = 0; i < subtrees.size(); ++i)
            built_by[std::min<std::size_t>(subtrees[i].bin->builder, workers - 1)].push_back(i);
        const std::unique_ptr<std::atomic<std::size_t>[]> next(new std::atomic<std::size_t>[workers]());
        run_workers(threads_, [&](int worker, const FirstError& error) {
            for (std::size_t round = 0; round < workers; ++round) { // its own subtrees, then others' left over
                const std::size_t w = (std::size_t(worker) + round) % workers;
                for (std::size_t k; !error.failed() && (k = next[w].fetch_add(1)) < built_by[w].size();) {
                    const std::size_t i = built_by[w][k];
                    Part& part = parts[i];
                    part.nodes.reserve(subtrees[i].bin->count / 16 + 1);
                    part.leaves.reserve(subtrees[i].bin->count / 4 + 1);
                    Wide out{part.nodes, part.leaves};
                    collapse(out, *subtrees[i].bin);
                    fill_order(prims, subtrees[i].bin->first, subtrees[i].bin->count);
                }
            }
        });
        for (std::size_t i = 0; i < subtrees.size(); ++i) {
            const auto node_offset = static_cast<std::uint32_t>(tree.nodes.size());
            const auto leaf_offset = static_cast<std::uint32_t>(tree.leaves.size());
            for (Node n : parts[i].nodes) {
                for (std::uint32_t& c : n.child)
                    if (c != empty_child) c += (c & leaf_bit) ? leaf_offset : node_offset;
                tree.nodes.push_back(n);
            }
            tree.leaves.insert(tree.leaves.end(), parts[i].leaves.begin(), parts[i].leaves.end());
            tree.nodes[subtrees[i].parent].child[subtrees[i].slot] = node_offset;
            parts[i] = Part(); // freed once appended
        }
    }

    BvhTree<T> tree_;
    std::vector<NodePool<T>> pools_; // the binary nodes, a pool for each build thread
    int leaf_size_ = 8;
    int threads_ = 1;
    // SAH costs per unit of box area of visiting an 8-wide node and of testing a leaf.
    static constexpr T node_cost = T(1), leaf_cost = T(1);
};

} // namespace detail

/// Builds a BvhTree over primitives 0 … n−1 whose boxes `box_of(i)` gives (a Box<T>; called once
/// for each, from several threads at once). Primitives with empty or non-finite boxes are left
/// out. Throws std::bad_alloc when memory runs out (also in a build thread), std::length_error
/// for 2^32 − 1 primitives or more.
template <class T, class BoxOf>
[[nodiscard]] BvhTree<T> build_bvh(std::size_t n, BoxOf&& box_of, const BvhOptions& options = {}) {
    return detail::BvhBuilder<T>().build(n, box_of, options);
}

/// Builds a BvhTree over primitives with these boxes (index = primitive).
template <class T>
[[nodiscard]] BvhTree<T> build_bvh(const std::vector<Box<T>>& boxes, const BvhOptions& options = {}) {
    return build_bvh<T>(
        boxes.size(), [&boxes](std::size_t i) { return boxes[i]; }, options);
}

} // namespace isin

// The builder's core for float and double (binning, the binary tree, the collapse) comes from
// isin::io where ISIN_COMPILED is defined (detail/compiled.hpp), rather than being compiled in
// every file that builds a Bvh: about a second of -O2 compile time per file. Only the gather of
// each caller's boxes (build_bvh's box_of) is compiled where it is called.
#if defined(ISIN_COMPILED)
ISIN_DETAIL_COMPILED_BUILDER template class isin::detail::BvhBuilder<float>;
ISIN_DETAIL_COMPILED_BUILDER template class isin::detail::BvhBuilder<double>;
#endif
