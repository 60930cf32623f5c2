#pragma once
/// isin — Solid<T>: inside/outside and signed distance of a triangle mesh by its generalized
/// winding number (Jacobson, Kavan & Sorkine-Hornung, "Robust Inside-Outside Segmentation using
/// Generalized Winding Numbers", 2013): the solid angle the mesh subtends at p over 4π, exactly
/// 1 inside and 0 outside a closed mesh whose front faces are outside (isin::normal points
/// out), and a smooth, meaningful value on meshes with holes, overlaps and self-intersections
/// (2 where two closed parts overlap; about 1/2 at a hole). Made fast by the far-field
/// expansion of Barill, Dickson, Schmidt, Levin & Jacobson, "Fast Winding Numbers for Soups and
/// Clouds" (2018): a cluster of triangles seen from farther than beta times its radius counts
/// as one dipole.
///
///     isin::Solid<float> solid{mesh};
///     if (solid.contains(p)) ...;            // winding number ≥ 1/2
///     float d = solid.signed_distance(p);    // negative inside
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numeric>
#include <type_traits>
#include <vector>

#include "bvh/triangle_bvh.hpp"
#include "detail/parallel.hpp"
#include "indexed_mesh.hpp"
#include "point_hit.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// The solid angle of triangle (a, b, c) seen from p, signed (positive where p sees its back
/// side: isin::normal points away from p), by Van Oosterom & Strackee (1983):
/// tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|), a, b, c relative to p.
/// In (−2π, 2π]; NaN for NaN input.
template <class T>
[[nodiscard]] inline T solid_angle(const Vertex<T>& p, const Triangle<T>& tri) noexcept {
    const Vertex<T> a = tri.v0 - p, b = tri.v1 - p, c = tri.v2 - p;
    const T la = length(a), lb = length(b), lc = length(c);
    const T num = dot(a, cross(b, c));                                             // VOS: a·(b×c)
    const T den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb; // VOS: denominator
    return T(2) * std::atan2(num, den);                                            // VOS: Ω = 2·atan2(num, den)
}

/// A closed (or not quite closed) triangle mesh as a solid: winding number, inside/outside,
/// signed distance. Holds its own copy of the triangles, a cluster tree for the winding number
/// and a Bvh for distances. Non-finite triangles are left out.
template <class T>
class Solid {
    static_assert(std::is_floating_point_v<T>, "isin::Solid needs float or double");

public:
    /// Builds from `mesh` (Mesh::validate: std::invalid_argument for an invalid one). `beta`:
    /// the far-field's accuracy (a cluster of radius r counts as one dipole beyond beta·r from
    /// p; larger is more accurate and slower; +∞ gives the exact sum over every triangle).
    explicit Solid(const Mesh<T>& mesh, T beta = T(2), const BvhOptions& options = {})
        : bvh_(mesh, options), beta_(beta) {
        for (std::size_t i = 0; i < mesh.size(); ++i) {
            const Triangle<T> t = mesh.triangle(i);
            if (is_finite(t.v0) && is_finite(t.v1) && is_finite(t.v2)) triangles_.push_back(t);
        }
        if (!triangles_.empty()) build(0, triangles_.size());
    }

    /// The generalized winding number at p by the far-field expansion with this solid's beta:
    /// 1 inside a closed mesh, 0 outside, up to the expansion's error (see docs/queries.md).
    [[nodiscard]] T winding_number(const Vertex<T>& p) const noexcept { return winding_number(p, beta_); }
    /// The same with another accuracy `beta` (+∞: exact).
    [[nodiscard]] T winding_number(const Vertex<T>& p, T beta) const noexcept;
    /// The exact generalized winding number: Σ solid_angle / 4π over every triangle, O(n).
    [[nodiscard]] T winding_number_exact(const Vertex<T>& p) const noexcept {
        T sum = T(0);
        for (const Triangle<T>& t : triangles_) sum += solid_angle(p, t);
        return sum / (T(4) * pi);
    }
    /// True when p is inside: winding_number(p) ≥ 1/2 (false for NaN p).
    [[nodiscard]] bool contains(const Vertex<T>& p) const noexcept { return winding_number(p) >= T(0.5); }
    /// Distance to the closest point of the surface, negative inside (contains); +∞ for an
    /// empty mesh, NaN for a NaN or infinite p.
    [[nodiscard]] T signed_distance(const Vertex<T>& p) const noexcept {
        if (!is_finite(p)) return std::numeric_limits<T>::quiet_NaN();
        const T d = bvh_.closest_point(p).distance;
        return contains(p) ? -d : d;
    }
    /// out[i] = contains(p[i]) (1 or 0) for i < n, on up to `threads` threads (0 = every core).
    void contains(const Vertex<T>* p, std::size_t n, std::uint8_t* out, int threads = 0) const {
        detail::parallel_chunks(n, detail::thread_count(threads), 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i) out[i] = contains(p[i]) ? 1 : 0;
        });
    }
    /// out[i] = signed_distance(p[i]) for i < n, on up to `threads` threads.
    void signed_distance(const Vertex<T>* p, std::size_t n, T* out, int threads = 0) const {
        detail::parallel_chunks(n, detail::thread_count(threads), 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i) out[i] = signed_distance(p[i]);
        });
    }

    /// The Bvh of the distances (closest_point, count_hits, intersect).
    [[nodiscard]] const Bvh<T>& bvh() const noexcept { return bvh_; }
    /// The far-field accuracy given at construction.
    [[nodiscard]] T beta() const noexcept { return beta_; }
    /// Number of triangles the winding number sums over.
    [[nodiscard]] std::size_t size() const noexcept { return triangles_.size(); }

private:
    static constexpr T pi = T(3.14159265358979323846);
    static constexpr std::size_t leaf_size = 8;

    // A cluster of triangles_[first, first + count): its dipole (the sum of its triangles' area
    // vectors, placed at their area-weighted centroid) and the radius of a ball round that
    // centroid holding every vertex. Children: `left` and left + 1 … (index of the right
    // child in `right`); a leaf has count ≤ leaf_size and no children.
    struct Cluster {
        Vertex<T> centre, area;
        T radius;
        std::uint32_t first, count, right;
    };

    // Clusters by median split of the centroids on their longest axis, depth first (a node's
    // left child follows it); returns its index.
    std::uint32_t build(std::size_t first, std::size_t end) {
        const auto index = static_cast<std::uint32_t>(clusters_.size());
        clusters_.push_back({});
        Vertex<T> area{T(0), T(0), T(0)}, weighted{T(0), T(0), T(0)};
        Box<T> box;
        for (std::size_t i = first; i < end; ++i) {
            const Triangle<T>& t = triangles_[i];
            const Vertex<T> N = T(0.5) * normal(t); // Barill: area vector a·n = ½ (V1−V0)×(V2−V0)
            const Vertex<T> centroid = (t.v0 + t.v1 + t.v2) / T(3);
            area += N;
            weighted += length(N) * centroid;
            box.grow(centroid);
        }
        T total = T(0);
        for (std::size_t i = first; i < end; ++i) total += length(normal(triangles_[i])) * T(0.5);
        // Barill: the expansion's centre is the area-weighted centroid (the box's centre for no area).
        const Vertex<T> centre = total > T(0) ? weighted / total : T(0.5) * (box.lo + box.hi);
        T r2 = T(0);
        for (std::size_t i = first; i < end; ++i)
            for (const Vertex<T>& v : {triangles_[i].v0, triangles_[i].v1, triangles_[i].v2})
                r2 = std::max(r2, dot(v - centre, v - centre));
        Cluster c{centre, area, std::sqrt(r2), std::uint32_t(first), std::uint32_t(end - first), 0};
        if (end - first > leaf_size) {
            int axis = 0;
            const Vertex<T> extent = box.hi - box.lo;
            if (extent.y > component(extent, axis)) axis = 1;
            if (extent.z > component(extent, axis)) axis = 2;
            const std::size_t mid = first + (end - first) / 2;
            std::nth_element(triangles_.begin() + std::ptrdiff_t(first), triangles_.begin() + std::ptrdiff_t(mid),
                             triangles_.begin() + std::ptrdiff_t(end),
                             [axis](const Triangle<T>& x, const Triangle<T>& y) {
                                 return component(x.v0 + x.v1 + x.v2, axis) < component(y.v0 + y.v1 + y.v2, axis);
                             });
            build(first, mid);
            c.right = build(mid, end);
        }
        clusters_[index] = c;
        return index;
    }

    Bvh<T> bvh_;
    T beta_;
    std::vector<Triangle<T>> triangles_; // in cluster order
    std::vector<Cluster> clusters_;      // depth first, the root first
};

template <class T>
T Solid<T>::winding_number(const Vertex<T>& p, T beta) const noexcept {
    if (clusters_.empty()) return T(0);
    if (!is_finite(p)) return std::numeric_limits<T>::quiet_NaN();
    T sum = T(0); // solid angles, over 4π at the end
    std::uint32_t stack[2 * 64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Cluster& c = clusters_[stack[--top]];
        const Vertex<T> r = c.centre - p;
        const T d2 = dot(r, r);
        if (d2 > beta * beta * c.radius * c.radius) { // Barill: far field beyond beta·radius
            const T d = std::sqrt(d2);
            sum += dot(c.area, r) / (d2 * d); // Barill: dipole term 4π·w ≈ (a·n)·(c − p)/|c − p|³
            continue;
        }
        if (c.right == 0) {
            for (std::uint32_t i = c.first; i < c.first + c.count; ++i) sum += solid_angle(p, triangles_[i]);
            continue;
        }
        const auto self = static_cast<std::uint32_t>(&c - clusters_.data());
        stack[top++] = c.right;
        stack[top++] = self + 1;
    }
    return sum / (T(4) * pi);
}

} // namespace isin
