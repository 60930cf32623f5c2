#pragma once
/// isin — private: polygons into triangles for the mesh readers.
///
/// triangulate_polygon(corners, count, out) appends count − 2 triangles, as corner numbers:
///   - count 3: (0, 1, 2), nothing else is done and nothing allocated;
///   - convex in its plane (every turn to the left or straight, one turn around; checked in O(count)
///     without allocating): the fan (0, k+1, k+2), exactly as the readers always wrote it;
///   - otherwise ear clipping (Meisters 1975, "Polygons have ears"; Eberly, "Triangulation by Ear
///     Clipping") in the plane of the Newell normal: any simple polygon, convex or concave, and
///     "keyhole" polygons (a ring written as one polygon with a bridge: coincident edges, repeated
///     corner positions) come out as triangles of the polygon's winding whose areas add up to
///     the polygon's area.
/// A degenerate polygon (all corners on one line, repeated points, NaN or infinite coordinates)
/// or one that crosses itself (or is far from planar) still gets count − 2 triangles, never a
/// crash or a hang: the fan when there is no plane (Newell normal zero or not finite); else ear
/// clipping, which clips zero-area corners (spike tips, repeated points) as it meets them and,
/// when no ear is left, rescues itself (every zero-area corner; else the first ear counting only
/// corners strictly inside; else the first convex corner; else any corner).
///
/// Cost. The Newell normal and the convexity test are O(n). Ear clipping follows Eberly: every
/// corner is a candidate ear once, after that only the two neighbours of each clipped ear are
/// tested again (O(n) ear tests for a simple polygon). An ear test asks a kd-tree over the corners
/// (Bentley 1975; each node keeps the count and box of the blockers below it) for blockers in the
/// triangle: about log n for an ordinary polygon, so about O(n log n) in all (measured up to 200k
/// corners: ~30 steps a corner for a comb, ~55 for a spiral band or a keyhole ring). Long thin
/// triangles among many corners cost more (a star-shaped polygon with random radii: ~√n steps a
/// corner, over the budget from ~20k corners on), and degenerate or self-crossing polygons can
/// cost O(n²) and more, so every polygon gets a budget of ear_clipping_steps_per_corner · n +
/// ear_clipping_free_steps steps (a step: a corner, tree node or candidate looked at). When it is
/// spent, the corners still left become a fan: still count − 2 triangles, correct only where that
/// remainder is convex. A file therefore costs at most ~96 steps a corner plus O(n log n) sorting,
/// whatever its polygons: a polygon of a million corners stops after ~1e8 steps (a few seconds at
/// worst, when its corners are scattered in memory).
///
/// Numerics: orientation tests in the projected plane, in double for float input (long double for
/// long double), with a floating-point filter and difference_of_products behind it, so that each
/// sign is exact for the rounded coordinate differences (orient2d); the convexity test alone
/// allows for the input's rounding (is_convex_in_plane).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "../vec.hpp"

namespace isin::detail {

/// A polygon of `count` ≥ 3 corners c0 … c(count−1) that a reader stored as its fan: triangle k
/// (k = 0 … count−3) is indices[first + k] = (c0, c(k+1), c(k+2)).
struct FanRun {
    std::size_t first = 0;
    std::size_t count = 0;
};

/// Ear clipping's budget: steps a corner, on top of ear_clipping_free_steps a polygon.
inline constexpr std::size_t ear_clipping_steps_per_corner = 96;
/// Ear clipping's budget: steps every polygon gets, so that small ones may be quadratic (256²).
inline constexpr std::size_t ear_clipping_free_steps = std::size_t(1) << 16;

/// The type orientation tests are computed in: at least double.
template <class T>
using PlaneReal = std::conditional_t<(sizeof(T) > sizeof(double)), T, double>;

/// A corner in the polygon's plane: (u, v) are two of x, y, z, ordered so that the polygon runs
/// counter-clockwise (positive area) when it winds around its Newell normal.
template <class R>
struct PlanePoint {
    R u, v;
};

template <class R>
[[nodiscard]] constexpr bool operator==(const PlanePoint<R>& a, const PlanePoint<R>& b) noexcept {
    return a.u == b.u && a.v == b.v;
}

/// Orientation of a, b, c: (b − a) × (c − a), positive when they turn counter-clockwise (left),
/// zero when collinear; NaN from NaN input. Its sign is the exact sign of that determinant of the
/// rounded differences: a filter (as in Shewchuk's adaptive predicates) returns the plain products'
/// difference when it is larger than their rounding error can be (8 ulps of |t1| + |t2|, which
/// also covers a compiler fusing them into one FMA), and difference_of_products otherwise.
template <class R>
[[nodiscard]] inline R orient2d(const PlanePoint<R>& a, const PlanePoint<R>& b, const PlanePoint<R>& c) noexcept {
    const R bu = b.u - a.u, bv = b.v - a.v, cu = c.u - a.u, cv = c.v - a.v;
    const R t1 = bu * cv, t2 = bv * cu;
    const R det = t1 - t2; // 2D cross (b−a)×(c−a)
    if (std::fabs(det) > R(8) * std::numeric_limits<R>::epsilon() * (std::fabs(t1) + std::fabs(t2))) return det;
    return difference_of_products(bu, cv, bv, cu); // near zero, NaN or overflow: exact sign
}

/// Which two axes make the polygon's plane (axis numbers as in component()); `valid` is false when
/// the Newell normal is zero or not finite (no plane: the caller writes the fan).
struct PlaneAxes {
    int u = 0;
    int v = 1;
    bool valid = false;
};

/// The polygon's plane by Newell's method: N = Σ (p_i − p_0) × (p_i+1 − p_0), twice its vector
/// area (translated to corner 0 for accuracy); the projection drops N's largest axis, and orders
/// the other two so that the projected polygon has positive area (mirrored when N points down).
template <class R, class T>
[[nodiscard]] PlaneAxes plane_axes(const Vertex<T>* corners, std::size_t count) noexcept {
    const auto widen = [](const Vertex<T>& p) { return Vertex<R>{R(p.x), R(p.y), R(p.z)}; };
    const Vertex<R> o = widen(corners[0]);
    Vertex<R> N{R(0), R(0), R(0)};
    Vertex<R> e_prev = widen(corners[1]) - o;
    for (std::size_t i = 2; i < count; ++i) {
        const Vertex<R> e = widen(corners[i]) - o;
        N += cross(e_prev, e); // Newell: Σ (p_i − p_0) × (p_i+1 − p_0)
        e_prev = e;
    }
    PlaneAxes axes;
    if (!is_finite(N)) return axes;
    const R ax = std::fabs(N.x), ay = std::fabs(N.y), az = std::fabs(N.z);
    const int k = (az >= ax && az >= ay) ? 2 : (ax >= ay ? 0 : 1); // drop the largest axis of N
    const R Nk = component(N, k);
    if (!(Nk != R(0))) return axes;
    // (u, v) = (y, z), (z, x) or (x, y) is right-handed about axis k, so the projected area has the
    // sign of N_k; swapped (mirrored) when that is negative, the polygon runs counter-clockwise.
    axes.u = (k + 1) % 3;
    axes.v = (k + 2) % 3;
    if (Nk < R(0)) std::swap(axes.u, axes.v);
    axes.valid = true;
    return axes;
}

/// Corner p in the plane of `axes`.
template <class R, class T>
[[nodiscard]] inline PlanePoint<R> plane_point(const Vertex<T>& p, const PlaneAxes& axes) noexcept {
    return {R(component(p, axes.u)), R(component(p, axes.v))};
}

/// Convexity test in the plane (after Schorn and Fisher, "Testing the convexity of a polygon",
/// Graphics Gems IV): every turn between successive edges of nonzero length is to the left or
/// straight ahead (not back), and the edges' u components change sign at most twice, i.e. the
/// edge direction turns around once. Repeated corners (zero-length edges) are stepped over. A turn
/// within the input's rounding (8 ulps of T, scaled by the corner's coordinates and edges) counts
/// as straight, so a convex polygon whose straight corners were rounded stays convex.
template <class R, class T>
[[nodiscard]] bool is_convex_in_plane(const Vertex<T>* corners, std::size_t count, const PlaneAxes& axes) noexcept {
    const auto norm = [](const PlanePoint<R>& p) { return max_of(std::fabs(p.u), std::fabs(p.v)); };
    // Left turn or straight ahead at corner p from edge d to edge e: d × e > 0, or d × e ≈ 0 with d·e > 0.
    const auto turns_left = [&norm](const PlanePoint<R>& p, const PlanePoint<R>& d, const PlanePoint<R>& e) {
        const R t = d.u * e.v - d.v * e.u; // 2D cross d × e (its rounding is far below tol)
        const R size = norm(d) + norm(e);
        const R tol = R(8) * R(std::numeric_limits<T>::epsilon()) * (norm(p) + size) * size; // rounding of T
        return t > tol || (t >= -tol && d.u * e.u + d.v * e.v > R(0));
    };
    PlanePoint<R> first{R(0), R(0)}, first_start{R(0), R(0)}, last{R(0), R(0)};
    bool have_edge = false;
    int first_sign = 0, last_sign = 0, sign_changes = 0;
    PlanePoint<R> p = plane_point<R>(corners[0], axes);
    for (std::size_t i = 1; i <= count; ++i) {
        const PlanePoint<R> q = plane_point<R>(corners[i == count ? 0 : i], axes);
        const PlanePoint<R> e{q.u - p.u, q.v - p.v}; // edge p → q
        if (e.u != R(0) || e.v != R(0)) {            // else a repeated corner: no direction
            if (!have_edge) {
                first = e, first_start = p, have_edge = true;
            } else if (!turns_left(p, last, e)) {
                return false;
            }
            last = e;
            const int s = (e.u > R(0)) - (e.u < R(0));
            if (s != 0) {
                if (first_sign == 0)
                    first_sign = s;
                else if (s != last_sign)
                    ++sign_changes;
                last_sign = s;
            }
        }
        p = q;
    }
    if (!have_edge || !turns_left(first_start, last, first)) return false;
    if (last_sign != first_sign) ++sign_changes; // around the end
    return sign_changes <= 2;
}

/// Ear clipping of a polygon already projected into its plane (counter-clockwise), with its
/// working storage: one object triangulates any number of polygons, reusing its buffers.
template <class R>
class EarClipper {
public:
    using Triangles = std::vector<std::array<std::uint32_t, 3>>;

    /// The corners, projected: the caller fills it, then calls run().
    std::vector<PlanePoint<R>> points;

    /// Appends points.size() − 2 triangles (corner numbers, counter-clockwise) to `out`. Needs ≥ 3
    /// finite points, fewer than 2^32.
    void run(Triangles& out) {
        const std::size_t n = points.size();
        setup(n);
        const std::size_t budget = ear_clipping_steps_per_corner * n + ear_clipping_free_steps;
        // Eberly: only the two neighbours of a clipped ear can change; every corner is a candidate
        // once, then the neighbours of each clip (queued last, so that ears along a chain alternate).
        std::uint32_t last = 0; // a corner still in the ring
        for (std::uint32_t i = 0; i < n; ++i) enqueue(i);
        while (remaining_ > 3 && steps_ <= budget) {
            if (head_ == queue_.size()) { // no candidate left: rescue, then every corner is one again
                last = rescue(last, out, budget);
                queue_.clear(), head_ = 0;
                std::uint32_t x = last;
                for (std::size_t k = 0; k < remaining_; ++k, x = next_[x]) enqueue(x);
                continue;
            }
            const auto [v, stamp] = queue_[head_++];
            ++steps_;
            if (stamp != stamp_[v] || !can_clip(v)) continue; // clipped, queued again later, or no ear
            const std::uint32_t a = prev_[v], c = next_[v];
            clip(v, out); // Meisters: clip an ear, the rest is again a polygon
            enqueue(a), enqueue(c);
            last = c;
        }
        // The last triangle, or (budget spent) the fan of what is left: (v, x, next x) in ring order.
        std::uint32_t x = next_[last];
        for (std::size_t k = 0; k + 2 < remaining_; ++k, x = next_[x]) out.push_back({last, x, next_[x]});
    }

    /// Steps the last run() took (see the top of this file); more than the budget: it fanned the rest.
    [[nodiscard]] std::size_t steps() const noexcept { return steps_; }

private:
    /// A node of the kd-tree over all corners: its corners are order_[begin … end), `active` of
    /// them blockers now, and the box bounds those blockers (when there are any). Children of node
    /// i: 2i+1, 2i+2; a leaf has at most leaf_size corners. Unused slots have begin = end = 0.
    struct Node {
        R u_lo, v_lo, u_hi, v_hi;
        std::uint32_t begin, end, active;
    };
    static constexpr std::uint32_t leaf_size = 8;

    std::vector<std::uint32_t> prev_, next_; // the ring of corners not yet clipped
    std::vector<std::uint8_t> twin_;         // 1: another corner has the same position
    std::vector<std::uint32_t> order_;       // corners sorted by position, then in kd-tree order
    std::vector<std::uint32_t> slot_;        // where corner i stands in order_
    std::vector<PlanePoint<R>> tree_points_; // points[order_[k]], for leaves read in a row
    std::vector<std::uint8_t> tree_active_;  // 1: corner order_[k] is a blocker now (see is_blocker)
    std::vector<std::uint32_t> leaf_of_;     // the kd-tree leaf of each corner
    std::vector<Node> nodes_;
    std::vector<std::array<std::uint32_t, 3>> build_; // (node, begin, end) still to build
    std::vector<std::uint32_t> stack_;                // nodes still to look at in a query
    std::vector<std::array<std::uint32_t, 2>> queue_; // candidate ears: (corner, its stamp then)
    std::vector<std::uint32_t> stamp_;                // a corner's newest place in the queue; clipped: none
    std::size_t head_ = 0;                            // queue_[head_ …] are still to test
    std::size_t remaining_ = 0, steps_ = 0;

    static constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();

    void enqueue(std::uint32_t i) {
        if (stamp_[i] == none) return;
        queue_.push_back({i, ++stamp_[i]});
    }

    [[nodiscard]] R turn(std::uint32_t i) const noexcept {
        return orient2d(points[prev_[i]], points[i], points[next_[i]]);
    }

    /// For a corner that turns by zero: whether it goes on straight ahead (a corner on a line),
    /// rather than back (the tip of a spike) or nowhere (a repeated point).
    [[nodiscard]] bool goes_ahead(std::uint32_t i) const noexcept {
        const PlanePoint<R>&a = points[prev_[i]], &b = points[i], &c = points[next_[i]];
        return (b.u - a.u) * (c.u - b.u) + (b.v - a.v) * (c.v - b.v) > R(0); // (b − a)·(c − b) > 0
    }

    /// Whether corner i can stand inside an ear's triangle, so ear tests must look at it: a reflex
    /// corner (the classic test), a corner that turns back or has a zero-length edge, a NaN turn,
    /// and every corner whose position another corner shares (keyholes: the bridge's ends). A
    /// straight corner on a line needs no look: a triangle that holds it holds a reflex one too.
    [[nodiscard]] bool is_blocker(std::uint32_t i) const noexcept {
        if (twin_[i]) return true;
        const R t = turn(i);
        if (t > R(0)) return false;
        if (t == R(0)) return !goes_ahead(i);
        return true; // reflex or NaN
    }

    void setup(std::size_t n) {
        remaining_ = n;
        steps_ = 0;
        prev_.resize(n);
        next_.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            prev_[i] = static_cast<std::uint32_t>(i == 0 ? n - 1 : i - 1);
            next_[i] = static_cast<std::uint32_t>(i + 1 == n ? 0 : i + 1);
        }
        // Twins: sort by position, mark runs of equal positions.
        order_.resize(n);
        for (std::size_t i = 0; i < n; ++i) order_[i] = static_cast<std::uint32_t>(i);
        std::sort(order_.begin(), order_.end(), [this](std::uint32_t a, std::uint32_t b) {
            return points[a].u < points[b].u || (points[a].u == points[b].u && points[a].v < points[b].v);
        });
        twin_.assign(n, 0);
        for (std::size_t k = 1; k < n; ++k)
            if (points[order_[k]] == points[order_[k - 1]]) twin_[order_[k]] = twin_[order_[k - 1]] = 1;
        queue_.clear();
        head_ = 0;
        stamp_.assign(n, 0);
        build_tree(n);
        slot_.resize(n);
        tree_points_.resize(n);
        tree_active_.resize(n);
        for (std::uint32_t k = 0; k < n; ++k) {
            slot_[order_[k]] = k;
            tree_points_[k] = points[order_[k]];
            tree_active_[k] = is_blocker(order_[k]) ? 1 : 0;
        }
        for (std::size_t node = nodes_.size(); node-- > 0;) refit(static_cast<std::uint32_t>(node), true);
    }

    /// A kd-tree (Bentley 1975) over all corners: split at the median of the box's longer side.
    void build_tree(std::size_t n) {
        std::size_t depth = 0;
        while ((std::size_t(leaf_size) << depth) < n) ++depth;
        nodes_.assign((std::size_t(2) << depth) - 1, Node{}); // a complete tree of that depth
        leaf_of_.resize(n);
        build_.clear();
        build_.push_back({0, 0, static_cast<std::uint32_t>(n)});
        while (!build_.empty()) {
            const auto [node, begin, end] = build_.back();
            build_.pop_back();
            nodes_[node].begin = begin, nodes_[node].end = end;
            if (end - begin <= leaf_size) {
                for (std::uint32_t k = begin; k < end; ++k) leaf_of_[order_[k]] = node;
                continue;
            }
            PlanePoint<R> lo = points[order_[begin]], hi = lo;
            for (std::uint32_t k = begin; k < end; ++k) {
                const PlanePoint<R>& p = points[order_[k]];
                lo = {std::min(lo.u, p.u), std::min(lo.v, p.v)};
                hi = {std::max(hi.u, p.u), std::max(hi.v, p.v)};
            }
            const std::uint32_t mid = begin + (end - begin) / 2;
            const bool along_u = hi.u - lo.u >= hi.v - lo.v;
            std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                             [this, along_u](std::uint32_t a, std::uint32_t b) {
                                 return along_u ? points[a].u < points[b].u : points[a].v < points[b].v;
                             });
            build_.push_back({2 * node + 1, begin, mid});
            build_.push_back({2 * node + 2, mid, end});
        }
    }

    /// Sets the box of a node to that of its blockers, from its corners (a leaf) or its children;
    /// with `count`, counts them too. Returns whether the box changed.
    bool refit(std::uint32_t node, bool count) noexcept {
        Node& N = nodes_[node];
        ++steps_;
        if (N.end == 0) return false; // unused slot
        const Node before = N;
        std::uint32_t active = 0;
        const auto grow = [&N, &active](R u_lo, R v_lo, R u_hi, R v_hi) {
            if (active++ == 0) N.u_lo = u_lo, N.v_lo = v_lo, N.u_hi = u_hi, N.v_hi = v_hi;
            N.u_lo = std::min(N.u_lo, u_lo), N.v_lo = std::min(N.v_lo, v_lo);
            N.u_hi = std::max(N.u_hi, u_hi), N.v_hi = std::max(N.v_hi, v_hi);
        };
        if (N.end - N.begin <= leaf_size) {
            steps_ += N.end - N.begin;
            for (std::uint32_t k = N.begin; k < N.end; ++k)
                if (tree_active_[k]) grow(tree_points_[k].u, tree_points_[k].v, tree_points_[k].u, tree_points_[k].v);
        } else {
            for (const std::uint32_t child : {2 * node + 1, 2 * node + 2}) {
                const Node& C = nodes_[child];
                if (C.active != 0) grow(C.u_lo, C.v_lo, C.u_hi, C.v_hi);
            }
            if (count) active = nodes_[2 * node + 1].active + nodes_[2 * node + 2].active;
        }
        if (count) N.active = active;
        return N.u_lo != before.u_lo || N.v_lo != before.v_lo || N.u_hi != before.u_hi || N.v_hi != before.v_hi;
    }

    /// Makes corner i a blocker or not, keeping the counts and boxes of its kd-tree leaf and the
    /// nodes above (boxes only up to the first that stays the same).
    void set_active(std::uint32_t i, bool on) noexcept {
        std::uint8_t& active = tree_active_[slot_[i]];
        if ((active != 0) == on) return;
        active = on ? 1 : 0;
        bool boxes = true;
        for (std::uint32_t node = leaf_of_[i];; node = (node - 1) / 2) {
            nodes_[node].active += on ? 1u : std::numeric_limits<std::uint32_t>::max(); // ±1, wrapping
            if (boxes) boxes = refit(node, false) || nodes_[node].active == (on ? 1u : 0u);
            if (node == 0) break;
        }
    }

    /// Clips corner b: appends the triangle (a, b, c) and joins a to c; a and c turn anew.
    void clip(std::uint32_t b, Triangles& out) {
        const std::uint32_t a = prev_[b], c = next_[b];
        out.push_back({a, b, c});
        next_[a] = c;
        prev_[c] = a;
        stamp_[b] = none;
        set_active(b, false);
        --remaining_;
        set_active(a, is_blocker(a));
        set_active(c, is_blocker(c));
    }

    /// Whether the boundary at corner q, which stands where corner x of the triangle (x, x1, x2)
    /// does (counter-clockwise), enters the triangle: an edge of q strictly inside the wedge at x
    /// from x→x1 to x→x2, or q's edges lying on both of the wedge's sides (a fold: the triangle is
    /// doubled back on itself). A neighbour at x too gives no direction: counted as entering.
    [[nodiscard]] bool enters(std::uint32_t q, std::uint32_t x, std::uint32_t x1, std::uint32_t x2) const noexcept {
        const PlanePoint<R>&X = points[x], &Y0 = points[prev_[q]], &Y1 = points[next_[q]];
        const PlanePoint<R>&X1 = points[x1], &X2 = points[x2];
        if ((Y0 == X1 && Y1 == X2) || (Y0 == X2 && Y1 == X1)) return true; // fold
        for (const PlanePoint<R>* Y : {&Y0, &Y1}) {
            if (*Y == X) return true;
            if (orient2d(X, X1, *Y) > R(0) && orient2d(X, X2, *Y) < R(0)) return true; // inside the wedge
        }
        return false;
    }

    /// Whether blocker q (at P) spoils the ear (a, b, c): q inside the triangle (closed, or open
    /// when `open`), or, standing on one of its corners, with an edge entering it.
    [[nodiscard]] bool blocks(std::uint32_t q, const PlanePoint<R>& P, std::uint32_t a, std::uint32_t b,
                              std::uint32_t c, bool open) const noexcept {
        if (q == a || q == b || q == c) return false;
        if (P == points[a]) return enters(q, a, b, c);
        if (P == points[b]) return enters(q, b, c, a);
        if (P == points[c]) return enters(q, c, a, b);
        const R s = orient2d(points[a], points[b], P); // point in triangle: left of all three edges
        const R t = orient2d(points[b], points[c], P);
        const R r = orient2d(points[c], points[a], P);
        return open ? (s > R(0) && t > R(0) && r > R(0)) : (s >= R(0) && t >= R(0) && r >= R(0));
    }

    /// Whether the whole box of `node` lies right of the line p → q: its corner farthest to the
    /// left is, by the same orientation test the corners get (so no corner in it can be missed).
    [[nodiscard]] static bool right_of(const PlanePoint<R>& p, const PlanePoint<R>& q, const Node& node) noexcept {
        const PlanePoint<R> far_left{q.v > p.v ? node.u_lo : node.u_hi, q.u > p.u ? node.v_hi : node.v_lo};
        return orient2d(p, q, far_left) < R(0);
    }

    /// Ear test (Eberly §2): b is convex and no blocker spoils the triangle (prev b, b, next b);
    /// the kd-tree skips nodes with no blocker, or whose box misses the triangle.
    [[nodiscard]] bool is_ear(std::uint32_t b, bool open) {
        const std::uint32_t a = prev_[b], c = next_[b];
        const PlanePoint<R>&A = points[a], &B = points[b], &C = points[c];
        if (!(orient2d(A, B, C) > R(0))) return false; // reflex, straight or NaN: no ear
        const R u_lo = std::min({A.u, B.u, C.u}), u_hi = std::max({A.u, B.u, C.u});
        const R v_lo = std::min({A.v, B.v, C.v}), v_hi = std::max({A.v, B.v, C.v});
        stack_.clear();
        stack_.push_back(0);
        while (!stack_.empty()) {
            const Node& N = nodes_[stack_.back()];
            const std::uint32_t node = stack_.back();
            stack_.pop_back();
            ++steps_;
            if (N.active == 0 || N.u_hi < u_lo || N.u_lo > u_hi || N.v_hi < v_lo || N.v_lo > v_hi) continue;
            if (right_of(A, B, N) || right_of(B, C, N) || right_of(C, A, N)) continue;
            if (N.end - N.begin > leaf_size) {
                stack_.push_back(2 * node + 1);
                stack_.push_back(2 * node + 2);
                continue;
            }
            steps_ += N.end - N.begin;
            for (std::uint32_t k = N.begin; k < N.end; ++k)
                if (tree_active_[k] && blocks(order_[k], tree_points_[k], a, b, c, open)) return false;
        }
        return true;
    }

    /// Whether corner v may be clipped now: an ear, or a corner of zero area that is not on a
    /// straight line (a spike's tip, a repeated point), whose triangle changes neither the area
    /// nor the shape and whose removal untangles the rest.
    [[nodiscard]] bool can_clip(std::uint32_t v) {
        if (turn(v) == R(0)) return !goes_ahead(v);
        return is_ear(v, false);
    }

    /// No ear among the candidates (a degenerate, weakly simple or self-crossing polygon, or
    /// rounding): clips at least one corner, unless the budget is spent, and returns a corner still
    /// in the ring.
    /// 1. Every zero-area corner (straight, turning back, repeated): its triangle changes neither
    ///    area nor shape. 2. The first ear when only blockers strictly inside count. 3. The first
    ///    convex corner (its triangle may overlap others). 4. Corner v.
    std::uint32_t rescue(std::uint32_t v, Triangles& out, std::size_t budget) {
        bool clipped = false;
        std::uint32_t u = v;
        for (std::size_t k = 0, m = remaining_; k < m && remaining_ > 3; ++k) {
            const std::uint32_t w = next_[u];
            ++steps_;
            if (turn(u) == R(0)) clip(u, out), clipped = true;
            u = w;
        }
        if (clipped || remaining_ <= 3) return u;
        for (std::size_t k = 0, m = remaining_; k < m && steps_ <= budget; ++k, u = next_[u]) {
            ++steps_;
            if (!is_ear(u, true)) continue;
            const std::uint32_t c = next_[u];
            clip(u, out);
            return c;
        }
        if (steps_ > budget) return u;
        for (std::size_t k = 0, m = remaining_; k < m; ++k, u = next_[u]) {
            ++steps_;
            if (!(turn(u) > R(0))) continue;
            const std::uint32_t c = next_[u];
            clip(u, out);
            return c;
        }
        const std::uint32_t c = next_[u];
        clip(u, out);
        return c;
    }
};

/// The fan (0, k+1, k+2), k = 0 … count−3.
inline void append_fan(std::size_t count, std::vector<std::array<std::uint32_t, 3>>& out) {
    for (std::size_t k = 0; k + 2 < count; ++k)
        out.push_back({0u, static_cast<std::uint32_t>(k + 1), static_cast<std::uint32_t>(k + 2)});
}

/// triangulate_polygon with the ear clipper's storage supplied (reused across polygons).
template <class T>
void triangulate_polygon(const Vertex<T>* corners, std::size_t count, std::vector<std::array<std::uint32_t, 3>>& out,
                         EarClipper<PlaneReal<T>>& clipper) {
    using R = PlaneReal<T>;
    if (count < 3 || count > std::numeric_limits<std::uint32_t>::max()) return; // corner numbers are 32-bit
    if (count == 3) {
        out.push_back({0u, 1u, 2u});
        return;
    }
    const PlaneAxes axes = plane_axes<R>(corners, count);
    if (!axes.valid || is_convex_in_plane<R>(corners, count, axes)) return append_fan(count, out);
    if (count == 4) { // a simple quad turning right at one corner r only: the diagonal from r
        PlanePoint<R> q[4];
        for (int i = 0; i < 4; ++i) q[i] = plane_point<R>(corners[i], axes);
        int reflex = -1, convex = 0;
        for (int i = 0; i < 4; ++i) {
            const R t = orient2d(q[(i + 3) % 4], q[i], q[(i + 1) % 4]);
            if (t < R(0)) reflex = i;
            convex += t > R(0) ? 1 : 0;
        }
        if (convex == 3 && reflex >= 0) {
            const auto r = static_cast<std::uint32_t>(reflex);
            out.push_back({r, (r + 1) % 4, (r + 2) % 4});
            out.push_back({r, (r + 2) % 4, (r + 3) % 4});
            return;
        }
    }
    clipper.points.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
        clipper.points[i] = plane_point<R>(corners[i], axes);
        if (!std::isfinite(clipper.points[i].u) || !std::isfinite(clipper.points[i].v)) return append_fan(count, out);
    }
    clipper.run(out);
}

/// Appends count − 2 triangles covering the polygon corners[0 … count) to `out`, as corner
/// numbers (0 … count−1), each with the polygon's winding (about its Newell normal): the fan
/// (0, k+1, k+2) for a convex polygon, ear clipping otherwise (see the top of this file). Nothing
/// for count < 3 or count ≥ 2^32.
template <class T>
void triangulate_polygon(const Vertex<T>* corners, std::size_t count, std::vector<std::array<std::uint32_t, 3>>& out) {
    EarClipper<PlaneReal<T>> clipper; // allocates only when ear clipping is needed
    triangulate_polygon(corners, count, out, clipper);
}

/// Replaces the fan of each run by triangulate_polygon's triangles of the same polygon (the same
/// number of triangles, in the same slots), as indices into `positions`. Runs that are not what
/// FanRun says (outside `indices`, not a fan, a corner outside `positions`, count < 4 or ≥ 2^32)
/// are checked for and left as they are.
template <class T>
void retriangulate_fans(const std::vector<Vertex<T>>& positions, std::vector<std::array<std::uint32_t, 3>>& indices,
                        const std::vector<FanRun>& runs) {
    std::vector<Vertex<T>> corners;
    std::vector<std::uint32_t> ids;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    EarClipper<PlaneReal<T>> clipper;
    for (const FanRun& run : runs) {
        const std::size_t n = run.count;
        if (n < 4 || n > std::numeric_limits<std::uint32_t>::max()) continue;
        if (run.first > indices.size() || n - 2 > indices.size() - run.first) continue;
        // Corners from the fan: c0 = t0[0], c1 = t0[1], c2 = t0[2], c(k+2) = tk[2].
        const std::array<std::uint32_t, 3>* fan = indices.data() + run.first;
        ids.assign({fan[0][0], fan[0][1]});
        bool is_fan = true;
        for (std::size_t k = 0; k + 2 < n && is_fan; ++k) {
            is_fan = fan[k][0] == ids[0] && fan[k][1] == ids[k + 1];
            ids.push_back(fan[k][2]);
        }
        if (!is_fan) continue;
        corners.clear();
        for (const std::uint32_t id : ids) {
            if (id >= positions.size()) break;
            corners.push_back(positions[id]);
        }
        if (corners.size() != n) continue;
        triangles.clear();
        triangulate_polygon(corners.data(), n, triangles, clipper);
        if (triangles.size() != n - 2) continue; // cannot happen: count − 2 triangles always
        for (std::size_t k = 0; k + 2 < n; ++k)
            indices[run.first + k] = {ids[triangles[k][0]], ids[triangles[k][1]], ids[triangles[k][2]]};
    }
}

} // namespace isin::detail
