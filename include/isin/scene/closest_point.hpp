/// isin — private: Scene's closest points: over the placed meshes (each mesh's Bvh walked nearest
/// box first, bvh/closest_point.hpp), the triangle kinds and the spheres, with one sphere round
/// the point shrinking across all of them.
/// scene.hpp includes this file after the class, whose members it defines: included before
/// scene.hpp it holds nothing (and is included again by scene.hpp: `#pragma once` is inside the #if).
#if defined(ISIN_DETAIL_SCENE_CLASS)
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "../bvh/closest_point.hpp"
#include "../detail/parallel.hpp"

namespace isin {
namespace detail {

/// A placed mesh's triangles in the world for the closest-point walk (bvh/closest_point.hpp):
/// x ↦ M·x + d, p the query point in the world and scale2 ≤ σ_min(M)².
template <class T>
struct PlacedSpace {
    static constexpr bool moved = true;
    const Transform<T>& to_world;
    T p[3];
    T scale2;

    /// Lower bounds of the squared world distances from p to a node's 8 children (q: p in mesh
    /// space): the larger of scale2 times the mesh space's (|M·v| ≥ σ_min·|v|) and the distance
    /// to the world box of each moved box (centre M·c + d, half extents |M|·e), widened by a few
    /// ulps for rounding. An empty slot gives NaN (its centre is +∞ − ∞).
    void node_bounds(const typename BvhTree<T>::Node& n, const T (&q)[3], T (&d2)[8]) const noexcept {
        T mesh2[8];
        box_distances<T>(n.lo, n.hi, q, mesh2);
        alignas(8 * sizeof(T)) T lo[3][8], hi[3][8];
        const T eps4 = T(4) * std::numeric_limits<T>::epsilon();
        for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 8; ++k) {
                T c = component(to_world.d, r), e = T(0);
                for (int a = 0; a < 3; ++a) {
                    c += to_world.m[r][a] * ((n.lo[a][k] + n.hi[a][k]) * T(0.5));
                    e += std::fabs(to_world.m[r][a]) * ((n.hi[a][k] - n.lo[a][k]) * T(0.5));
                }
                const T reach = e + eps4 * (std::fabs(c) + e);
                lo[r][k] = c - reach, hi[r][k] = c + reach;
            }
        box_distances<T>(lo, hi, p, d2);
        for (int k = 0; k < 8; ++k) {
            const T scaled = mesh2[k] * scale2;
            d2[k] = d2[k] < scaled ? scaled : d2[k]; // a NaN world box stays NaN: skipped
        }
    }
    /// Block b's triangles moved to the world, into `out` (the same lanes and indices).
    [[nodiscard]] const TriangleBlock<T>& block(const TriangleBlock<T>& b, TriangleBlock<T>& out) const noexcept {
        for (int v = 0; v < 3; ++v)
            for (int r = 0; r < 3; ++r)
                for (int k = 0; k < 8; ++k)
                    out.v[v][r][k] = to_world.m[r][0] * b.v[v][0][k] + to_world.m[r][1] * b.v[v][1][k] +
                                     to_world.m[r][2] * b.v[v][2][k] + component(to_world.d, r);
        std::memcpy(out.primitive, b.primitive, sizeof out.primitive);
        return out;
    }
};

/// The smallest and largest eigenvalues of the symmetric 3×3 matrix `a` (overwritten), by
/// Jacobi's rotations (Golub & Van Loan §8.5): each eigenvalue within a few ulps of the largest.
inline void symmetric_eigen_range(double (&a)[3][3], double& lo, double& hi) noexcept {
    for (int sweep = 0; sweep < 12; ++sweep)
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                if (a[p][q] == 0.0) continue;
                const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]); // GVL: τ
                const double t = (theta >= 0.0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c; // GVL: c, s of J
                for (int k = 0; k < 3; ++k) {                             // A·J
                    const double kp = a[k][p], kq = a[k][q];
                    a[k][p] = c * kp - s * kq, a[k][q] = s * kp + c * kq;
                }
                for (int k = 0; k < 3; ++k) { // Jᵀ·(A·J)
                    const double pk = a[p][k], qk = a[q][k];
                    a[p][k] = c * pk - s * qk, a[q][k] = s * pk + c * qk;
                }
            }
    lo = std::min(std::min(a[0][0], a[1][1]), a[2][2]);
    hi = std::max(std::max(a[0][0], a[1][1]), a[2][2]);
}

/// The closest point of sphere `s`'s surface to p (a surface, as a mesh's: ||p − C| − r| away,
/// along p − C; from the centre itself, toward +x). A miss for a non-finite sphere.
template <class T>
[[nodiscard]] PointHit<T> closest_on_sphere(const Sphere<T>& s, const Vertex<T>& p) noexcept {
    PointHit<T> hit;
    const T r = std::fabs(s.radius);
    if (!is_finite(s.center) || !std::isfinite(r)) return hit;
    const Vertex<T> D = p - s.center;
    const T l = length(D);
    if (!(l < std::numeric_limits<T>::infinity())) return hit;
    hit.distance = std::fabs(l - r); // beyond the note: | |p − C| − r |
    hit.point = l > T(0) ? s.center + (r / l) * D
                         : s.center + Vertex<T>{r, T(0), T(0)}; // beyond the note: C + r·(p − C)/|p − C|
    return hit;
}

} // namespace detail

template <class T, template <class> class... Shapes>
inline ScenePointHit<T> Scene<T, Shapes...>::closest_point(const Vertex<T>& p, T max_distance) const {
    prepare();
    ScenePointHit<T> best;
    if (!is_finite(p) || !(max_distance >= T(0))) return best;
    T best2 = max_distance * max_distance; // the sphere round p, shared by every object
    for_each_kind([&](auto kind, const auto& vec) { closest_of_kind(kind, vec, p, best2, best); });
    if (!top_ || top_->empty()) {
        for (std::size_t i = 0; i < instances_.size(); ++i)
            closest_in_placement(static_cast<std::uint32_t>(i), p, best2, best);
        return best;
    }
    const T q[3] = {p.x, p.y, p.z};
    detail::walk_nearest(*top_, q, best2, [&](std::uint32_t leaf) { // placements nearest world box first
        const auto& l = top_->leaves()[leaf];
        for (std::uint32_t j = l.first; j < l.first + l.count; ++j)
            closest_in_placement(top_->primitives()[j], p, best2, best);
    });
    return best;
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::closest_point(const Vertex<T>* points, std::size_t count, ScenePointHit<T>* out,
                                               int threads) const {
    prepare();
    detail::parallel_chunks(count, detail::thread_count(threads), 256, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) out[i] = closest_point(points[i]);
    });
}

// M = s·R when the eigenvalues of MᵀM agree to rounding (then distances scale by s exactly, up to
// that rounding); else scale2 is a lower bound on σ_min(M)² = λ_min(MᵀM), less Jacobi's error,
// and never below 1/‖M⁻¹‖_F² (σ_min(M) = 1/‖M⁻¹‖₂ ≥ 1/‖M⁻¹‖_F), both less a margin for rounding.
template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::measure_stretch(Instance& inst) noexcept {
    double a[3][3], inverse2 = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            a[i][j] = 0.0; // MᵀM
            for (int k = 0; k < 3; ++k) a[i][j] += double(inst.to_world.m[k][i]) * double(inst.to_world.m[k][j]);
            inverse2 += double(inst.to_object.m[i][j]) * double(inst.to_object.m[i][j]);
        }
    double lo = 0.0, hi = 0.0;
    detail::symmetric_eigen_range(a, lo, hi);
    const double eps = double(std::numeric_limits<T>::epsilon());
    inst.similar = hi - lo <= 8.0 * eps * hi;
    if (inst.similar) {
        inst.scale2 = T(0.5 * (lo + hi));
        return;
    }
    const double jacobi = lo - 64.0 * std::numeric_limits<double>::epsilon() * hi; // λ_min, less Jacobi's error
    const double bound = std::max(jacobi, inverse2 > 0.0 ? 1.0 / inverse2 : 0.0) * (1.0 - 64.0 * eps);
    inst.scale2 = std::isfinite(bound) && bound > 0.0 ? T(bound) : T(0);
}

template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline void Scene<T, Shapes...>::closest_of_kind(Kind kind, const Objects& vec, const Vertex<T>& p, T& best2,
                                                 ScenePointHit<T>& best) const noexcept {
    using Shape = typename Objects::value_type::shape_type;
    const auto take = [&](const PointHit<T>& h, std::uint32_t i) {
        static_cast<PointHit<T>&>(best) = h;
        best.primitive = i, best.geometry = static_cast<std::uint32_t>(kind());
    };
    if constexpr (is_triangle_kind<Shape>::value) {
        const auto& accel = std::get<kind>(accel_);
        if (accel.triangles) { // a Bvh over the kind's triangles, whatever triangle_method is
            const Bvh<T>& bvh = *accel.triangles;
            detail::NearestTriangle<T> n{best2};
            if (!bvh.tree().empty())
                detail::nearest_triangle(bvh.tree(), bvh.blocks(), p, p, detail::SameSpace<T>{}, n);
            if (n.lane < 0) return;
            best2 = n.best2;
            const PointHit<T> h = detail::point_hit_of(bvh.blocks(), detail::SameSpace<T>{}, n);
            return take(h, h.primitive);
        }
        (void)detail::any_usable_triangle<T>(vec, [&](std::size_t i, const Triangle<T>& tri) {
            const PointHit<T> h = isin::closest_point(p, tri);
            const T d2 = h.distance * h.distance;
            if (d2 < best2 || (d2 == best2 && !best)) best2 = d2, take(h, static_cast<std::uint32_t>(i));
            return false;
        });
    } else if constexpr (std::is_same_v<Shape, Sphere<T>>) {
        const auto visit = [&](std::uint32_t i) {
            const PointHit<T> h = detail::closest_on_sphere(vec[i].shape, p);
            const T d2 = h.distance * h.distance;
            if (d2 < best2 || (d2 == best2 && !best && h)) best2 = d2, take(h, i);
        };
        const auto& accel = std::get<kind>(accel_);
        if (accel.objects && !accel.objects->empty()) { // spheres nearest box first
            const BvhTree<T>& tree = *accel.objects;
            const T q[3] = {p.x, p.y, p.z};
            detail::walk_nearest(tree, q, best2, [&](std::uint32_t leaf) {
                const auto& l = tree.leaves()[leaf];
                for (std::uint32_t j = l.first; j < l.first + l.count; ++j) visit(tree.primitives()[j]);
            });
            return;
        }
        for (std::size_t i = 0; i < vec.size(); ++i) visit(static_cast<std::uint32_t>(i));
    }
    // Other kinds (users' shapes) have no closest point here: skipped.
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::closest_in_placement(std::uint32_t i, const Vertex<T>& p, T& best2,
                                                      ScenePointHit<T>& best) const noexcept {
    const Instance& inst = instances_[i];
    const Bvh<T>& bvh = *meshes_[inst.mesh].bvh;
    T box2 = T(0); // the squared distance to the placement's world box
    for (int a = 0; a < 3; ++a) {
        const T c = component(p, a),
                gap = std::max(std::max(component(inst.box.lo, a) - c, c - component(inst.box.hi, a)), T(0));
        box2 += gap * gap;
    }
    if (bvh.tree().empty() || !(box2 <= best2)) return; // out of reach (an empty box: NaN or +∞)
    PointHit<T> h;
    if (inst.similar) { // distances scale by s: the mesh's own walk on p in mesh space
        const Vertex<T> q_mesh = inst.identity ? p : inst.to_object.point(p);
        detail::NearestTriangle<T> n{inst.identity ? best2 : best2 / inst.scale2};
        detail::nearest_triangle(bvh.tree(), bvh.blocks(), q_mesh, q_mesh, detail::SameSpace<T>{}, n);
        if (n.lane < 0) return;
        h = detail::point_hit_of(bvh.blocks(), detail::SameSpace<T>{}, n);
        if (!inst.identity) {
            best2 = std::min(best2, n.best2 * inst.scale2);
            h.point = inst.to_world.point(h.point);
            h.distance = std::sqrt(n.best2 * inst.scale2);
        } else {
            best2 = n.best2;
        }
    } else { // nodes bounded in the world and by σ_min, each leaf's triangles moved to the world
        const detail::PlacedSpace<T> world{inst.to_world, {p.x, p.y, p.z}, inst.scale2};
        detail::NearestTriangle<T> n{best2};
        detail::nearest_triangle(bvh.tree(), bvh.blocks(), inst.to_object.point(p), p, world, n);
        if (n.lane < 0) return;
        best2 = n.best2;
        h = detail::point_hit_of(bvh.blocks(), world, n);
    }
    static_cast<PointHit<T>&>(best) = h;
    best.geometry = static_cast<std::uint32_t>(kinds + i);
}

} // namespace isin
#endif
