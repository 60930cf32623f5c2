#pragma once
/// isin — whether anything may meet a shaft: the convex hull of eight points, the part of the
/// pyramid from a point to a parallelogram beyond its tip (Haines & Wallace 1994, "Shaft
/// culling for efficient ray-cast radiosity"). Tested by separating axes (Gottschalk, Lin,
/// Manocha 1996): the hull's extent along x, y, z and its faces' normals against boxes,
/// triangles and spheres, and each triangle's own normal. Conservative: "may meet" wherever the
/// axes left out (edge × edge) or rounding could separate them. Scene::shaft_clear walks a Bvh
/// with it (walk_nearest_by, bvh/closest_point.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "../vec.hpp"
#include "closest_point.hpp"
#include "tree.hpp"
#include "triangles.hpp"

namespace isin {
namespace detail {

/// The convex hull of a shaft's 8 corners: its extent along 8 axes (x, y, z, the normal of its
/// two parallel ends and those of its four sides), each widened by the rounding of projections.
template <class T>
struct Shaft {
    static constexpr int axes = 8;
    T n[axes][3]; // the axes (the end faces' normal and the sides' need not be unit)
    T lo[axes], hi[axes];
    T x[3][8];      // the corners, axis by axis
    T magnitude[3]; // per coordinate, the largest |corner| with the error of placing the corners
    bool usable = false;

    /// The hull of corners v[0 … 3] (the near end, a parallelogram: p, p + u, p + v, p + u + v)
    /// and v[4 … 7] (the far end, in the same order); `error[a]` bounds how far rounding moved
    /// coordinate a of any corner (0 where they are exact). Not usable when a corner is not finite.
    static Shaft hull(const Vertex<T> (&v)[8], const T (&error)[3]) noexcept {
        Shaft s;
        for (int a = 0; a < 3; ++a) {
            s.magnitude[a] = error[a];
            for (int k = 0; k < 8; ++k) {
                s.x[a][k] = component(v[k], a);
                const T m = std::fabs(s.x[a][k]) + error[a];
                if (!(m < std::numeric_limits<T>::infinity())) return s; // NaN or ∞: not usable
                s.magnitude[a] = std::max(s.magnitude[a], m);
            }
        }
        // The faces' normals: the ends' from their edges, the side through near corners i, j from
        // that edge and the one joining corner i to the far end (any axis separates soundly: the
        // hull's extent along it is measured, not assumed).
        const Vertex<T> normals[axes] = {{T(1), T(0), T(0)},
                                         {T(0), T(1), T(0)},
                                         {T(0), T(0), T(1)},
                                         cross(v[5] - v[4], v[6] - v[4]),
                                         cross(v[1] - v[0], v[4] - v[0]),
                                         cross(v[3] - v[2], v[6] - v[2]),
                                         cross(v[2] - v[0], v[4] - v[0]),
                                         cross(v[3] - v[1], v[5] - v[1])};
        for (int a = 0; a < axes; ++a) {
            s.n[a][0] = normals[a].x, s.n[a][1] = normals[a].y, s.n[a][2] = normals[a].z;
            T low = std::numeric_limits<T>::infinity(), high = -low;
            for (int k = 0; k < 8; ++k) {
                const T d = s.n[a][0] * s.x[0][k] + s.n[a][1] * s.x[1][k] + s.n[a][2] * s.x[2][k];
                low = std::min(low, d), high = std::max(high, d);
            }
            // Rounding in these projections, and the corners' own error along the axis.
            const T slack = s.reach(a, s.magnitude) + std::fabs(s.n[a][0]) * error[0] +
                            std::fabs(s.n[a][1]) * error[1] + std::fabs(s.n[a][2]) * error[2];
            s.lo[a] = low - slack, s.hi[a] = high + slack; // NaN where a product overflowed: never separates
        }
        s.usable = true;
        return s;
    }

    /// How far rounding can move a projection on axis a of points whose coordinates are at most
    /// m[0 … 2] in magnitude (16 ε: the three products, their sum and the corners' own error).
    [[nodiscard]] T reach(int a, const T (&m)[3]) const noexcept {
        constexpr T eps = std::numeric_limits<T>::epsilon();
        return T(16) * eps * (std::fabs(n[a][0]) * m[0] + std::fabs(n[a][1]) * m[1] + std::fabs(n[a][2]) * m[2]);
    }

    /// Whether the box [lo, hi] may meet the hull (an empty or NaN box does not).
    [[nodiscard]] bool box_may_meet(const T (&box_lo)[3], const T (&box_hi)[3]) const noexcept {
        T centre[3], half[3], m[3];
        for (int a = 0; a < 3; ++a) {
            if (!(box_lo[a] <= box_hi[a]) || box_hi[a] < lo[a] || box_lo[a] > hi[a]) return false;
            centre[a] = T(0.5) * (box_lo[a] + box_hi[a]), half[a] = T(0.5) * (box_hi[a] - box_lo[a]);
            m[a] = std::max(magnitude[a], std::max(std::fabs(box_lo[a]), std::fabs(box_hi[a])));
        }
        for (int a = 3; a < axes; ++a) {
            const T c = n[a][0] * centre[0] + n[a][1] * centre[1] + n[a][2] * centre[2];
            const T e = std::fabs(n[a][0]) * half[0] + std::fabs(n[a][1]) * half[1] + std::fabs(n[a][2]) * half[2];
            const T slack = reach(a, m);
            if (c - e > hi[a] + slack || c + e < lo[a] - slack) return false; // NaN: no separation
        }
        return true;
    }

    /// Whether the triangle p0, p1, p2 may meet the hull: its box, then its own normal, then the
    /// hull's faces' normals.
    [[nodiscard]] bool triangle_may_meet(const Vertex<T>& p0, const Vertex<T>& p1, const Vertex<T>& p2) const noexcept {
        T m[3];
        for (int a = 0; a < 3; ++a) {
            const T c0 = component(p0, a), c1 = component(p1, a), c2 = component(p2, a);
            const T low = std::min(c0, std::min(c1, c2)), high = std::max(c0, std::max(c1, c2));
            if (!(high >= lo[a] && low <= hi[a])) return false; // NaN: no triangle to meet
            m[a] = std::max(magnitude[a], std::max(std::fabs(low), std::fabs(high)));
        }
        const Vertex<T> normal = cross(p1 - p0, p2 - p0);
        const T w[3] = {normal.x, normal.y, normal.z};
        const auto project = [&](const T(&axis)[3], const Vertex<T>& p) {
            return axis[0] * p.x + axis[1] * p.y + axis[2] * p.z;
        };
        constexpr T eps = std::numeric_limits<T>::epsilon();
        const T own = T(16) * eps * (std::fabs(w[0]) * m[0] + std::fabs(w[1]) * m[1] + std::fabs(w[2]) * m[2]);
        const T t0 = project(w, p0), t1 = project(w, p1), t2 = project(w, p2);
        const T t_lo = std::min(t0, std::min(t1, t2)) - own, t_hi = std::max(t0, std::max(t1, t2)) + own;
        bool below = true, above = true; // every corner of the hull on one side of the triangle's plane
        for (int k = 0; k < 8; ++k) {
            const T d = w[0] * x[0][k] + w[1] * x[1][k] + w[2] * x[2][k];
            below = below && d < t_lo, above = above && d > t_hi;
        }
        if (below || above) return false;
        for (int a = 3; a < axes; ++a) {
            const T d0 = project(n[a], p0), d1 = project(n[a], p1), d2 = project(n[a], p2);
            const T slack = reach(a, m);
            if (std::max(d0, std::max(d1, d2)) < lo[a] - slack || std::min(d0, std::min(d1, d2)) > hi[a] + slack)
                return false;
        }
        return true;
    }

    /// Whether the ball about `centre` of radius r may meet the hull (its box, then the faces' normals).
    [[nodiscard]] bool ball_may_meet(const Vertex<T>& centre, T r) const noexcept {
        const T c[3] = {centre.x, centre.y, centre.z};
        const T box_lo[3] = {c[0] - r, c[1] - r, c[2] - r}, box_hi[3] = {c[0] + r, c[1] + r, c[2] + r};
        if (!box_may_meet(box_lo, box_hi)) return false;
        T m[3];
        for (int a = 0; a < 3; ++a) m[a] = std::max(magnitude[a], std::fabs(c[a]) + std::fabs(r));
        for (int a = 3; a < axes; ++a) {
            const T d = n[a][0] * c[0] + n[a][1] * c[1] + n[a][2] * c[2];
            const T e = std::fabs(r) * std::sqrt(n[a][0] * n[a][0] + n[a][1] * n[a][1] + n[a][2] * n[a][2]);
            const T slack = reach(a, m) + T(4) * std::numeric_limits<T>::epsilon() * e;
            if (d + e < lo[a] - slack || d - e > hi[a] + slack) return false;
        }
        return true;
    }
};

/// Whether anything in `tree` may meet the shaft: its boxes walked (walk_nearest_by, every box
/// that may meet it), leaf(index) saying whether that leaf's primitives may; stops at the first.
template <class T, class Leaf>
[[nodiscard]] bool tree_may_meet(const BvhTree<T>& tree, const Shaft<T>& shaft, Leaf&& leaf) noexcept {
    if (tree.empty()) return false;
    T reach = T(0); // 0 while nothing is found: boxes that may meet the shaft are at "distance" 0
    walk_nearest_by(
        tree,
        [&](const typename BvhTree<T>::Node& node, T(&d2)[8]) {
            for (int k = 0; k < 8; ++k) {
                const T box_lo[3] = {node.lo[0][k], node.lo[1][k], node.lo[2][k]};
                const T box_hi[3] = {node.hi[0][k], node.hi[1][k], node.hi[2][k]};
                d2[k] = shaft.box_may_meet(box_lo, box_hi) ? T(0) : std::numeric_limits<T>::infinity();
            }
        },
        reach,
        [&](std::uint32_t index) {
            if (leaf(index)) reach = T(-1); // found: every box left is beyond reach
        });
    return reach < T(0);
}

/// Whether any triangle of a Bvh's tree and blocks may meet the shaft.
template <class T>
[[nodiscard]] bool triangles_may_meet(const BvhTree<T>& tree, const TriangleBlocks<T>& blocks,
                                      const Shaft<T>& shaft) noexcept {
    return tree_may_meet(tree, shaft, [&](std::uint32_t index) {
        const TriangleBlock<T>& b = blocks[index];
        for (int k = 0, live = live_lanes(b); k < live; ++k)
            if (shaft.triangle_may_meet({b.v[0][0][k], b.v[0][1][k], b.v[0][2][k]},
                                        {b.v[1][0][k], b.v[1][1][k], b.v[1][2][k]},
                                        {b.v[2][0][k], b.v[2][1][k], b.v[2][2][k]}))
                return true;
        return false;
    });
}

} // namespace detail
} // namespace isin
