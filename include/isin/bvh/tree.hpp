#pragma once
/// isin — the hierarchy of a Bvh, and nothing else: 8-wide nodes (children's boxes in
/// structure-of-arrays order) and leaves, each a range of primitive indices. It knows no
/// primitive: traversal (traverse.hpp) hands each leaf to the caller's leaf test, and the build
/// (build.hpp) is a separate object whose state ends with it.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "box.hpp"
#include "build_context.hpp"

namespace isin {

namespace detail {
template <class T>
class BvhBuilder;
template <class T>
class BvhFile;
} // namespace detail

/// Build options of a Bvh.
struct BvhOptions {
    int threads = 0;                 ///< build threads; 0 = std::thread::hardware_concurrency()
    int leaf_size = 8;               ///< SAH leaves hold at most this many primitives (1…8)
    BuildContext* context = nullptr; ///< scratch kept across builds (BuildContext); null: none kept
};

/// What a tree costs a ray by the surface area heuristic (Goldsmith & Salmon 1987; MacDonald &
/// Booth 1990): for a ray that enters the root's box, from directions spread uniformly, the
/// expected number of 8-wide nodes it visits, of leaves it tests and of primitives in them. A box
/// inside the root's is entered with probability (its surface area) / (the root's). Lower is
/// better for the same primitives; `cost` weighs them (the build's plan weighs a node and a leaf
/// alike: cost(1, 1, 0)).
struct BvhCost {
    double node_visits = 0, leaf_visits = 0, primitive_tests = 0;
    [[nodiscard]] double cost(double per_node, double per_leaf, double per_primitive) const noexcept {
        return per_node * node_visits + per_leaf * leaf_visits + per_primitive * primitive_tests;
    }
};

/// A bounding volume hierarchy over primitives known only by their boxes; see the top of this
/// header.
template <class T>
class BvhTree {
    static_assert(std::is_floating_point_v<T>, "isin::BvhTree needs float or double");

public:
    /// Levels of 8-wide nodes on the longest path; never above this, whatever the input (the
    /// build splits at the median below a fixed depth, and primitives are counted in 32 bits).
    static constexpr int depth_limit = 40 + 32;
    /// A child reference: a node index, a leaf index | leaf_bit, or empty_child.
    static constexpr std::uint32_t leaf_bit = 0x80000000u;
    static constexpr std::uint32_t empty_child = 0xffffffffu;

    /// 8 children: boxes in structure-of-arrays order and references; an empty slot has an empty
    /// box (lo = +∞ > hi = −∞). A child node's index is larger than its parent's.
    struct alignas(64) Node {
        T lo[3][8], hi[3][8];
        std::uint32_t child[8];
    };
    /// A leaf: primitives()[first, first + count), count in 1…8.
    struct Leaf {
        std::uint32_t first, count;
    };
    /// The tree's arrays: blocks of 2 MiB or more on huge pages of their own, unmapped with the
    /// tree; resized without zeroing, since the build and the loader write every element.
    template <class V>
    using Array = std::vector<V, detail::UninitAllocator<V>>;

    /// Number of primitives in the tree (those with usable boxes).
    [[nodiscard]] std::size_t size() const noexcept { return primitives_.size(); }
    [[nodiscard]] bool empty() const noexcept { return nodes_.empty(); }
    [[nodiscard]] std::size_t node_count() const noexcept { return nodes_.size(); }
    [[nodiscard]] std::size_t leaf_count() const noexcept { return leaves_.size(); }
    /// Levels of 8-wide nodes on the longest path from the root to a leaf (0 when empty).
    [[nodiscard]] int depth() const noexcept { return nodes_.empty() ? 0 : depth_below(0); }

    [[nodiscard]] const Array<Node>& nodes() const noexcept { return nodes_; }
    [[nodiscard]] const Array<Leaf>& leaves() const noexcept { return leaves_; }
    /// Primitive indices, leaf after leaf.
    [[nodiscard]] const Array<std::uint32_t>& primitives() const noexcept { return primitives_; }
    /// The largest |coordinate| of any box: traversal checks with it whether a ray's slab
    /// products can overflow.
    [[nodiscard]] T bound() const noexcept { return bound_; }
    /// The size of a typical leaf: the geometric mean over the leaves of their box's largest
    /// extent (0 when the tree is empty; +∞ when an extent overflows). Packets of rays whose
    /// origins lie many of these apart visit more nodes together than their rays would alone
    /// (make_packet). Kept by the build and by refit.
    [[nodiscard]] T leaf_scale() const noexcept { return leaf_scale_; }

    /// The union of all boxes (empty when the tree is).
    [[nodiscard]] Box<T> bounds() const noexcept {
        Box<T> b;
        if (nodes_.empty()) return b;
        for (int k = 0; k < 8; ++k) b.grow(child_box(nodes_[0], k));
        return b;
    }

    /// The tree's SAH cost (BvhCost; all 0 for an empty tree). The root node counts 1; a root box
    /// without area (all boxes one point, or on one line) counts every node and leaf as visited.
    /// Areas are taken in double from half extents scaled by the root's, so no finite box
    /// overflows. O(nodes), no allocation.
    [[nodiscard]] BvhCost sah_cost() const noexcept {
        BvhCost c;
        if (nodes_.empty()) return c;
        const Box<T> root = bounds();
        const double scale = std::max({half_extent(root, 0), half_extent(root, 1), half_extent(root, 2)});
        const double root_area = scale > 0.0 ? scaled_area(root, scale) : 0.0;
        c.node_visits = 1.0;
        for (const Node& n : nodes_)
            for (int k = 0; k < 8; ++k) {
                const std::uint32_t ref = n.child[k];
                if (ref == empty_child) continue;
                const double p = root_area > 0.0 ? std::min(1.0, scaled_area(child_box(n, k), scale) / root_area) : 1.0;
                if (ref & leaf_bit) {
                    c.leaf_visits += p;
                    c.primitive_tests += p * double(leaves_[ref & ~leaf_bit].count);
                } else {
                    c.node_visits += p;
                }
            }
        return c;
    }

    /// Refit: recomputes every box from `box_of(primitive)` (a Box<T>), keeping the topology —
    /// for primitives that moved. Cost O(n), no allocation; the tree stays correct whatever the
    /// new boxes (a primitive whose box became empty or non-finite is simply never entered), but
    /// its quality falls as primitives move away from where it was built.
    template <class BoxOf>
    void refit(BoxOf&& box_of) {
        bound_ = T(0);
        for (std::size_t i = nodes_.size(); i-- > 0;) { // children before parents (larger indices)
            Node& n = nodes_[i];
            for (int k = 0; k < 8; ++k) {
                const std::uint32_t c = n.child[k];
                if (c == empty_child) continue;
                Box<T> b;
                if (c & leaf_bit) {
                    const Leaf& leaf = leaves_[c & ~leaf_bit];
                    for (std::uint32_t j = 0; j < leaf.count; ++j) {
                        const Box<T> p = box_of(primitives_[leaf.first + j]);
                        if (p.usable()) b.grow(p);
                    }
                } else {
                    for (int m = 0; m < 8; ++m) b.grow(child_box(nodes_[c], m));
                }
                set_box(n, k, b);
                if (b.lo.x <= b.hi.x) bound_ = std::max(bound_, std::max(max_abs(b.lo), max_abs(b.hi)));
            }
        }
        measure_leaf_scale();
    }

private:
    friend class detail::BvhBuilder<T>;
    friend class detail::BvhFile<T>; // loads a saved tree (serialize.hpp)

    [[nodiscard]] static Box<T> child_box(const Node& n, int k) noexcept {
        Box<T> b;
        b.lo = {n.lo[0][k], n.lo[1][k], n.lo[2][k]}, b.hi = {n.hi[0][k], n.hi[1][k], n.hi[2][k]};
        return b;
    }
    // sah_cost's measure: Box::area's, in double, from half extents divided by `scale` (the
    // root's largest half extent, so every box of the tree measures at most 3 and none overflows).
    [[nodiscard]] static double half_extent(const Box<T>& b, int a) noexcept {
        return double(component(b.hi, a)) * 0.5 - double(component(b.lo, a)) * 0.5;
    }
    [[nodiscard]] static double scaled_area(const Box<T>& b, double scale) noexcept {
        const double x = half_extent(b, 0) / scale, y = half_extent(b, 1) / scale, z = half_extent(b, 2) / scale;
        return x * y + y * z + z * x;
    }
    static void set_box(Node& n, int k, const Box<T>& b) noexcept {
        for (int a = 0; a < 3; ++a) n.lo[a][k] = component(b.lo, a), n.hi[a][k] = component(b.hi, a);
    }
    // leaf_scale_ from the leaves' boxes (their parents' child slots), in double: log2 of each
    // largest extent, averaged. Leaves whose boxes are empty (refit) or points do not count.
    void measure_leaf_scale() noexcept {
        double log_sum = 0.0;
        std::size_t counted = 0;
        for (const Node& n : nodes_)
            for (int k = 0; k < 8; ++k) {
                if (n.child[k] == empty_child || !(n.child[k] & leaf_bit)) continue;
                double extent = 0.0;
                for (int a = 0; a < 3; ++a) extent = std::max(extent, double(n.hi[a][k]) - double(n.lo[a][k]));
                if (extent > 0.0) log_sum += std::log2(extent), ++counted; // 0 for a point and an empty box (−∞ − ∞)
            }
        leaf_scale_ = counted ? T(std::exp2(log_sum / double(counted))) : T(0);
    }
    [[nodiscard]] int depth_below(std::uint32_t node) const noexcept {
        int deepest = 0;
        for (const std::uint32_t c : nodes_[node].child)
            if (c != empty_child && !(c & leaf_bit)) deepest = std::max(deepest, depth_below(c));
        return deepest + 1;
    }

    Array<Node> nodes_;
    Array<Leaf> leaves_;
    Array<std::uint32_t> primitives_;
    T bound_ = T(0);
    T leaf_scale_ = T(0);
};

} // namespace isin
