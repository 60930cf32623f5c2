#pragma once
/// isin — Solid<T>: inside/outside and signed distance of a triangle mesh by its generalized
/// winding number (Jacobson, Kavan & Sorkine-Hornung, "Robust Inside-Outside Segmentation using
/// Generalized Winding Numbers", 2013): the solid angle the mesh subtends at p over 4π, exactly
/// 1 inside and 0 outside a closed mesh whose front faces are outside (isin::normal points
/// out), and a smooth, meaningful value on meshes with holes, overlaps and self-intersections
/// (2 where two closed parts overlap; about 1/2 at a hole). Made fast by the far-field
/// expansion of Barill, Dickson, Schmidt, Levin & Jacobson, "Fast Winding Numbers for Soups and
/// Clouds" (2018) over the nodes of the Solid's Bvh: a node's child (or a leaf's triangle) seen
/// from farther than beta times its radius counts as one dipole, 8 children in lanes.
///
///     isin::Solid<float> solid{mesh};
///     if (solid.contains(p)) ...;            // winding number ≥ 1/2
///     float d = solid.signed_distance(p);    // negative inside
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "simd/sqrt.hpp"
#include "bvh/triangle_bvh.hpp"
#include "detail/attributes.hpp"
#include "detail/parallel.hpp"
#include "indexed_mesh.hpp"
#include "point_hit.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// The winding number at a point with a bound on its error: |value − w(p)| ≤ error_bound, w(p)
/// the exact generalized winding number of the solid's triangles (docs/queries.md, "the bound").
template <class T>
struct WindingNumber {
    static_assert(std::is_floating_point_v<T>, "isin::WindingNumber needs float or double");
    T value;       ///< the fast winding number, the same as Solid::winding_number(p, beta)
    T error_bound; ///< truncation + rounding, ≥ 0; +∞ for a non-finite p
    T truncation;  ///< the far field's part of error_bound; 0 when every triangle is summed exactly
};

namespace detail {

/// Van Oosterom & Strackee's numerator and denominator for triangle (v0, v1, v2) seen from p,
/// and |a||b||c| (the scale of their rounding errors).
template <class T>
struct VosTerms {
    T num, den, abc;
};

template <class T>
[[nodiscard]] inline VosTerms<T> vos_terms(const Vertex<T>& p, const Triangle<T>& tri) noexcept {
    const Vertex<T> a = tri.v0 - p, b = tri.v1 - p, c = tri.v2 - p;
    const T la = length(a), lb = length(b), lc = length(c);
    const T abc = la * lb * lc;
    const T num = dot(a, cross(b, c));                                    // VOS: a·(b×c)
    const T den = abc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb; // VOS: denominator
    return {num, den, abc};
}

} // namespace detail

/// The solid angle of triangle (a, b, c) seen from p, signed (positive where p sees its back
/// side: isin::normal points away from p), by Van Oosterom & Strackee (1983):
/// tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|), a, b, c relative to p.
/// In (−2π, 2π]; NaN for NaN input.
template <class T>
[[nodiscard]] inline T solid_angle(const Vertex<T>& p, const Triangle<T>& tri) noexcept {
    const detail::VosTerms<T> t = detail::vos_terms(p, tri);
    return T(2) * std::atan2(t.num, t.den); // VOS: Ω = 2·atan2(num, den)
}

/// A closed (or not quite closed) triangle mesh as a solid: winding number, inside/outside,
/// signed distance. Holds a Bvh of the triangles (for distances and crossings) and, for each of
/// its nodes, the dipoles of the 8 children (the far field of the winding number). Zero-area and
/// non-finite triangles are left out (they subtend no solid angle).
template <class T>
class Solid {
    static_assert(std::is_floating_point_v<T>, "isin::Solid needs float or double");

public:
    /// Builds from `mesh` (Mesh::validate: std::invalid_argument for an invalid one). `beta`:
    /// the far-field's accuracy (a cluster of radius r counts as one dipole beyond beta·r from
    /// p; larger is more accurate and slower; +∞ gives the exact sum over every triangle).
    explicit Solid(const Mesh<T>& mesh, T beta = T(2), const BvhOptions& options = {})
        : bvh_(mesh, options), beta_(beta) {
        build_far_field();
    }

    /// The generalized winding number at p by the far-field expansion with this solid's beta:
    /// 1 inside a closed mesh, 0 outside, up to the expansion's error (see docs/queries.md).
    [[nodiscard]] T winding_number(const Vertex<T>& p) const noexcept { return winding_number(p, beta_); }
    /// The same with another accuracy `beta` (+∞: exact).
    [[nodiscard]] T winding_number(const Vertex<T>& p, T beta) const noexcept { return walk<false>(p, beta).value; }
    /// The winding number at p with this solid's beta and a bound on its error (far-field
    /// truncation and floating-point rounding); `value` is winding_number(p), bit for bit.
    [[nodiscard]] WindingNumber<T> winding_number_bounded(const Vertex<T>& p) const noexcept {
        return walk<true>(p, beta_);
    }
    /// The same with another accuracy `beta` (+∞ or NaN: exact, truncation 0).
    [[nodiscard]] WindingNumber<T> winding_number_bounded(const Vertex<T>& p, T beta) const noexcept {
        return walk<true>(p, beta);
    }
    /// The exact generalized winding number: Σ solid_angle / 4π over every triangle, O(n).
    [[nodiscard]] T winding_number_exact(const Vertex<T>& p) const noexcept {
        T sum = T(0);
        const TriangleBlocks<T>& blocks = bvh_.blocks();
        for (std::size_t i = 0; i < blocks.size(); ++i)
            for (int k = 0, live = detail::live_lanes(blocks[i]); k < live; ++k)
                sum += solid_angle(p, lane(blocks[i], k));
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
    /// out[i] = contains(p[i]) (1 or 0) for i < n, on up to `threads` threads (0 = every core);
    /// the points are taken in Morton order, so that neighbours share the nodes they visit.
    void contains(const Vertex<T>* p, std::size_t n, std::uint8_t* out, int threads = 0) const {
        const std::vector<std::size_t> order = detail::morton_order(p, n);
        detail::parallel_chunks(n, detail::thread_count(threads), 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t j = begin; j < end; ++j) out[order[j]] = contains(p[order[j]]) ? 1 : 0;
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
    [[nodiscard]] std::size_t size() const noexcept { return bvh_.tree().size(); }

private:
    static constexpr T pi = T(3.14159265358979323846);
    static constexpr T u = std::numeric_limits<T>::epsilon() / 2; // unit roundoff
    static constexpr T inf = std::numeric_limits<T>::infinity();
    using Tree = BvhTree<T>;

    // The far field of a node's 8 children, in lanes: each child's dipole (the sum of its
    // triangles' area vectors, placed at their area-weighted centroid `c`), the squared
    // radius of a ball round c holding every vertex, and the spread of its normals,
    // S = Σ areaᵢ·|nᵢ − m| with m = Σ aᵢ / Σ areaᵢ (rounded up; the error bound's S). An empty
    // slot has a zero dipole and spread and an infinite radius (never far, never entered).
    struct alignas(64) FarField {
        T c[3][8], a[3][8], r2[8], spread[8];
    };

    // What a bounded walk adds up, in 4π·w units: the far field's truncation bound, the scale
    // of the dipoles' rounding (Σ A/d², leaves' (2A + |e|² + |f|²)/d²) and of the nodes' alone
    // (their stored a's error), the exact solid angles' rounding bounds and Σ|Ω|, and the
    // number of terms summed.
    struct Tally {
        T truncation = T(0), dipole_scale = T(0), node_scale = T(0), exact_rounding = T(0), exact_abs = T(0),
          terms = T(0);
    };

    // The most a cluster's dipole can be off its triangles' solid angles, K(y) = y/|y|³, r its
    // ball's radius, d the distance from p to the ball's centre c (the area-weighted centroid),
    // S the spread of its normals about m, |Σ aᵢ| = |m|·Σ areaᵢ: the part n − m is off by at
    // most S·max_{|x−c|≤r} |K(x−p) − K(c−p)| = S·(1/(d−r)² − 1/d²), the part m, whose first-order
    // term is 0 about the centroid, by |Σ aᵢ|·(1/(d−r)² − 1/d² − 2r/d³). d moved down and r up
    // by their rounding; +∞ unless d > r.
    [[nodiscard]] static T truncation_bound(T S, T am, T d, T r) noexcept {
        if (!(S + am > T(0))) return T(0);
        const T dl = d * (T(1) - T(4) * u), ru = r * (T(1) + T(16) * u) + T(4) * u * d;
        if (!(dl > ru)) return inf;
        const T g = dl - ru;
        const T first = ru * (T(2) * dl - ru) / ((dl * dl) * (g * g));                   // r(2d−r)/(d²(d−r)²)
        const T second = ru * ru * (T(3) * dl - T(2) * ru) / ((dl * dl * dl) * (g * g)); // r²(3d−2r)/(d³(d−r)²)
        const T bound = S * first + am * second;
        return bound == bound ? bound : inf;
    }

    // The most a computed solid angle can be off (first order in u, constants rounded up):
    // |δnum| + |δden| ≤ 72u·|a||b||c| moves (den, num) by at most D, which turns atan2 by at most
    // (π/2)·D/|(den, num)| unless the disc of radius D reaches the cut (num = 0, den ≤ 0) or the
    // origin (then 4π); atan2 within 2 ulps.
    [[nodiscard]] static T angle_rounding(const detail::VosTerms<T>& t) noexcept {
        const T D = T(72) * u * t.abc;
        const T R = std::sqrt(t.num * t.num + t.den * t.den);
        const T to_cut = t.den > T(0) ? R : std::fabs(t.num);
        if (!(to_cut > D)) return T(4) * pi;
        return pi * D / R + T(8) * pi * u; // |ΔΩ| ≤ 2·arcsin(D/R) + 2·(2 ulps of π)
    }

    [[nodiscard]] static Triangle<T> lane(const detail::TriangleBlock<T>& b, int k) noexcept {
        return {{b.v[0][0][k], b.v[0][1][k], b.v[0][2][k]},
                {b.v[1][0][k], b.v[1][1][k], b.v[1][2][k]},
                {b.v[2][0][k], b.v[2][1][k], b.v[2][2][k]}};
    }

    // When a cluster counts as its dipole: its centre farther than beta·(its ball's radius) from
    // p (beta2 = beta² ≥ 1: outside the ball), and d2 above √(smallest normal), so that the
    // dipole's d2·√d2 cannot underflow to 0.
    struct FarTest {
        T beta2, floor = T(1) / std::sqrt(T(1) / std::numeric_limits<T>::min());
        [[nodiscard]] bool operator()(T d2, T r2) const noexcept {
            return (d2 > beta2 * r2) & (d2 > floor); // Barill: far field beyond beta·r
        }
    };

    // Σ over 8 lanes of the dipole terms of the lanes whose `far` is 1 (those of 0 add 0),
    // branch-free so that compilers vectorise it: Barill: 4π·w ≈ (a·n)·(c − p)/|c − p|³, with
    // r = c − p and d2 = |r|².
    [[nodiscard]] static T dipoles(const T (&ax)[8], const T (&ay)[8], const T (&az)[8], const T (&rx)[8],
                                   const T (&ry)[8], const T (&rz)[8], const T (&d2)[8], const T (&far)[8]) noexcept {
        T d[8], term[8];
        detail::sqrt8(d2, d);
        for (int k = 0; k < 8; ++k) {
            const T num = ax[k] * rx[k] + ay[k] * ry[k] + az[k] * rz[k]; // Barill: (a·n)·(c − p)
            const T den = d2[k] * d[k];                                  // Barill: |c − p|³
            term[k] = (far[k] * num) / (far[k] * den + (T(1) - far[k]));
        }
        T sum = T(0);
        for (int k = 0; k < 8; ++k) sum += term[k];
        return sum;
    }

    // 4π·w of one leaf's triangles at p: each triangle seen from beyond beta·(its radius) as its
    // own dipole (centred on its centroid), the others by their exact solid angle. Bounded: adds
    // each term's truncation and rounding to `tally`.
    // Out of line: inlined into the walk, it costs the walk more instructions than the call saves.
    template <bool Bounded>
    [[nodiscard]] ISIN_DETAIL_NOINLINE static T leaf_sum(const detail::TriangleBlock<T>& b, const Vertex<T>& p,
                                                         const FarTest& is_far, Tally* tally) noexcept {
        const int live = detail::live_lanes(b);
        T ax[8], ay[8], az[8], rx[8], ry[8], rz[8], d2[8], far[8], r2s[8], ws[8];
        for (int k = 0; k < 8; ++k) {
            const T x0 = b.v[0][0][k], y0 = b.v[0][1][k], z0 = b.v[0][2][k];
            const T ex = b.v[1][0][k] - x0, ey = b.v[1][1][k] - y0, ez = b.v[1][2][k] - z0;
            const T fx = b.v[2][0][k] - x0, fy = b.v[2][1][k] - y0, fz = b.v[2][2][k] - z0;
            ax[k] = T(0.5) * (ey * fz - ez * fy); // Barill: area vector ½ (V1−V0)×(V2−V0)
            ay[k] = T(0.5) * (ez * fx - ex * fz);
            az[k] = T(0.5) * (ex * fy - ey * fx);
            const T gx = (ex + fx) / T(3), gy = (ey + fy) / T(3), gz = (ez + fz) / T(3); // centroid − V0
            const T r2 = std::max({gx * gx + gy * gy + gz * gz,
                                   (ex - gx) * (ex - gx) + (ey - gy) * (ey - gy) + (ez - gz) * (ez - gz),
                                   (fx - gx) * (fx - gx) + (fy - gy) * (fy - gy) + (fz - gz) * (fz - gz)});
            rx[k] = (x0 - p.x) + gx, ry[k] = (y0 - p.y) + gy, rz[k] = (z0 - p.z) + gz;
            d2[k] = rx[k] * rx[k] + ry[k] * ry[k] + rz[k] * rz[k];
            far[k] = T((k < live) & is_far(d2[k], r2));
            if constexpr (Bounded) r2s[k] = r2, ws[k] = (ex * ex + ey * ey + ez * ez) + (fx * fx + fy * fy + fz * fz);
        }
        T sum = dipoles(ax, ay, az, rx, ry, rz, d2, far);
        if constexpr (Bounded) {
            tally->terms += T(8);
            for (int k = 0; k < live; ++k) {
                if (far[k] == T(0)) continue;
                // The area from rounded edges e, f: off by at most 1.25u·(|e|² + |f|²).
                const T A =
                    std::sqrt(ax[k] * ax[k] + ay[k] * ay[k] + az[k] * az[k]) * (T(1) + T(4) * u) + T(2) * u * ws[k];
                tally->truncation +=
                    truncation_bound(T(0), A, std::sqrt(d2[k]), std::sqrt(r2s[k])); // one normal: S = 0
                tally->dipole_scale += (T(2) * A + ws[k]) / d2[k]; // A again: the rounded centroid's first-order term
            }
        }
        for (int k = 0; k < live; ++k) {
            if (far[k] != T(0)) continue;
            if constexpr (Bounded) {
                const detail::VosTerms<T> t = detail::vos_terms(p, lane(b, k));
                const T omega = T(2) * std::atan2(t.num, t.den); // VOS: Ω = 2·atan2(num, den), as solid_angle
                sum += omega;
                tally->exact_rounding += angle_rounding(t);
                tally->exact_abs += std::fabs(omega);
                tally->terms += T(1);
            } else {
                sum += solid_angle(p, lane(b, k));
            }
        }
        return sum;
    }

    // The far-field walk: the winding number and, when Bounded, its error bound.
    template <bool Bounded>
    [[nodiscard]] WindingNumber<T> walk(const Vertex<T>& p, T beta) const noexcept;

    // Each node's FarField from its children's, children first (a child node's index is larger
    // than its parent's); sums in double. A ball's radius is bounded by the smaller of the
    // farthest corner of the child's box and the farthest of its children's balls.
    void build_far_field() {
        const auto& nodes = bvh_.tree().nodes();
        const TriangleBlocks<T>& blocks = bvh_.blocks();
        far_.assign(nodes.size(), FarField{});
        std::vector<double> areas(8 * nodes.size()); // Σ triangle areas of each child, 8 a node
        // For the error bound, each child's: Σ areas rounded up, how far its stored a may be from
        // the exact Σ of its area vectors (rounding to T at every level below, double sums), the
        // spread of its normals rounded up, and how far its stored c may be from its centroid.
        std::vector<double> uppers(8 * nodes.size()), errs(8 * nodes.size()), spreads(8 * nodes.size()),
            cerrs(8 * nodes.size());
        constexpr double ud = std::numeric_limits<double>::epsilon() / 2;
        double worst = 0, worst_c = 0; // the largest errs / uppers and cerrs
        // The mean normal Σ aᵢ / Σ areaᵢ of child m of node j as stored, and how far it may be off.
        const auto mean = [&](std::size_t j, int m, Vertex<double>& n) {
            const std::size_t at = 8 * j + std::size_t(m);
            const double total = areas[at];
            if (!(total > 0)) return n = Vertex<double>{0, 0, 0}, 2.0;
            n = Vertex<double>{double(far_[j].a[0][m]), double(far_[j].a[1][m]), double(far_[j].a[2][m])} / total;
            return (errs[at] + (uppers[at] - total)) / total;
        };
        for (std::size_t i = nodes.size(); i-- > 0;) {
            FarField& f = far_[i];
            for (int k = 0; k < 8; ++k) {
                const std::uint32_t ref = nodes[i].child[k];
                Vertex<double> a{0, 0, 0}, weighted{0, 0, 0};
                double total = 0, r = 0, upper = 0, err = 0;
                const Vertex<double> lo{double(nodes[i].lo[0][k]), double(nodes[i].lo[1][k]),
                                        double(nodes[i].lo[2][k])};
                const Vertex<double> hi{double(nodes[i].hi[0][k]), double(nodes[i].hi[1][k]),
                                        double(nodes[i].hi[2][k])};
                Vertex<double> c = 0.5 * lo + 0.5 * hi;
                if (ref == Tree::empty_child) {
                    const std::size_t at = 8 * i + std::size_t(k);
                    areas[at] = uppers[at] = errs[at] = spreads[at] = cerrs[at] = 0;
                    for (int axis = 0; axis < 3; ++axis) f.c[axis][k] = f.a[axis][k] = T(0);
                    f.r2[k] = std::numeric_limits<T>::infinity();
                    f.spread[k] = T(0);
                    continue;
                }
                if (ref & Tree::leaf_bit) {
                    leaf_dipole(blocks[ref & ~Tree::leaf_bit], a, total, c, r, err);
                    upper = total + err;
                } else {
                    const FarField& g = far_[ref];
                    for (int m = 0; m < 8; ++m) {
                        a += Vertex<double>{double(g.a[0][m]), double(g.a[1][m]), double(g.a[2][m])};
                        total += areas[8 * std::size_t(ref) + std::size_t(m)];
                        weighted += areas[8 * std::size_t(ref) + std::size_t(m)] *
                                    Vertex<double>{double(g.c[0][m]), double(g.c[1][m]), double(g.c[2][m])};
                        upper += uppers[8 * std::size_t(ref) + std::size_t(m)];
                        err += errs[8 * std::size_t(ref) + std::size_t(m)];
                    }
                    err += 8 * ud * upper;
                    if (total > 0) c = weighted / total;
                    c = to_double(to_t(c));
                    double by_balls = 0;
                    for (int m = 0; m < 8; ++m) {
                        if (nodes[ref].child[m] == Tree::empty_child) continue;
                        const Vertex<double> cm{double(g.c[0][m]), double(g.c[1][m]), double(g.c[2][m])};
                        by_balls = std::max(by_balls, length(cm - c) + std::sqrt(double(g.r2[m])));
                    }
                    const Vertex<double> corner{std::max(c.x - lo.x, hi.x - c.x), std::max(c.y - lo.y, hi.y - c.y),
                                                std::max(c.z - lo.z, hi.z - c.z)};
                    r = std::min(by_balls, length(corner));
                }
                f.c[0][k] = T(c.x), f.c[1][k] = T(c.y), f.c[2][k] = T(c.z);
                f.a[0][k] = T(a.x), f.a[1][k] = T(a.y), f.a[2][k] = T(a.z);
                f.r2[k] = T(r * r * (1 + 1e-6)); // rounded up: the ball holds every vertex after rounding to T
                err += double(u) * length(Vertex<double>{double(f.a[0][k]), double(f.a[1][k]), double(f.a[2][k])});
                err *= 1 + 1e-6;
                areas[8 * i + std::size_t(k)] = total, uppers[8 * i + std::size_t(k)] = upper;
                errs[8 * i + std::size_t(k)] = err;
                if (upper > 0) worst = std::max(worst, err / upper);
                // The spread about the stored mean normal, plus how far that may be from the exact one.
                Vertex<double> n{0, 0, 0};
                const double dn = mean(i, k, n);
                double spread = 0, cerr = 0;
                if (ref & Tree::leaf_bit) {
                    const detail::TriangleBlock<T>& b = blocks[ref & ~Tree::leaf_bit];
                    for (int m = 0, live = detail::live_lanes(b); m < live; ++m) {
                        const Vertex<double> N = area_vector(lane(b, m));
                        spread += length(N - length(N) * n); // areaᵢ·|nᵢ − m|
                    }
                    spread += 2 * err; // each N from rounded edges, twice
                } else {
                    for (int m = 0; m < 8; ++m) {
                        const std::size_t at = 8 * std::size_t(ref) + std::size_t(m);
                        Vertex<double> nm{0, 0, 0};
                        const double dnm = mean(ref, m, nm);
                        spread += spreads[at] + uppers[at] * (length(nm - n) + dnm); // |nᵢ − m| ≤ |nᵢ − mₘ| + |mₘ − m|
                        cerr = std::max(cerr, cerrs[at]);
                    }
                }
                spread = std::min(2 * upper, (spread + upper * dn + 20 * ud * upper) * (1 + 1e-6));
                // The centroid from weights off by at most upper − total, each centroid within 2r.
                cerr += (total > 0 ? 2 * (upper - total) * 2 * r / total : 2 * r) + 10 * ud * (length(c) + r) +
                        double(u) * length(c);
                cerr = std::min(cerr, r) * (1 + 1e-6); // the centroid lies in the ball
                spreads[8 * i + std::size_t(k)] = spread, cerrs[8 * i + std::size_t(k)] = cerr;
                f.spread[k] = T(spread);
                if (double(f.spread[k]) < spread) f.spread[k] = std::nextafter(f.spread[k], inf);
                worst_c = std::max(worst_c, cerr);
            }
        }
        a_error_ = T(worst * (1 + 1e-3));
        c_error_ = T(worst_c * (1 + 1e-3));
    }

    // A leaf's dipole for build_far_field, in double: the sum `a` of its area vectors, their
    // total area, the area-weighted centroid `c` (kept as is when the area is 0) rounded to T as
    // the walk uses it, the radius r of the ball round c holding every vertex, and how far the
    // computed a may be from the exact sum (`err`).
    static void leaf_dipole(const detail::TriangleBlock<T>& b, Vertex<double>& a, double& total, Vertex<double>& c,
                            double& r, double& err) noexcept {
        constexpr double ud = std::numeric_limits<double>::epsilon() / 2;
        const int live = detail::live_lanes(b);
        Vertex<double> weighted{0, 0, 0};
        for (int m = 0; m < live; ++m) {
            const Triangle<T> t = lane(b, m);
            const Vertex<double> v0 = to_double(t.v0), v1 = to_double(t.v1), v2 = to_double(t.v2);
            const Vertex<double> N = area_vector(t);
            a += N, total += length(N), weighted += length(N) * ((v0 + v1 + v2) / 3.0);
            err += 2.5 * ud * length(v1 - v0) * length(v2 - v0); // N from rounded edges
        }
        err += 8 * ud * (total + err);       // the sums of 8
        if (total > 0) c = weighted / total; // Barill: the area-weighted centroid
        c = to_double(to_t(c));              // the ball is round the centre the walk uses
        double r2 = 0;
        for (int m = 0; m < live; ++m) {
            const Triangle<T> t = lane(b, m);
            for (const Vertex<T>& v : {t.v0, t.v1, t.v2}) r2 = std::max(r2, dot(to_double(v) - c, to_double(v) - c));
        }
        r = std::sqrt(r2);
    }

    // Barill et al.: a triangle's area vector ½ (v1 − v0) × (v2 − v0), in double.
    [[nodiscard]] static Vertex<double> area_vector(const Triangle<T>& t) noexcept {
        const Vertex<double> v0 = to_double(t.v0);
        return 0.5 * cross(to_double(t.v1) - v0, to_double(t.v2) - v0);
    }

    [[nodiscard]] static Vertex<double> to_double(const Vertex<T>& v) noexcept {
        return {double(v.x), double(v.y), double(v.z)};
    }
    [[nodiscard]] static Vertex<T> to_t(const Vertex<double>& v) noexcept { return {T(v.x), T(v.y), T(v.z)}; }

    Bvh<T> bvh_;
    T beta_;
    std::vector<FarField> far_; // one per node of bvh_'s tree
    T a_error_ = T(0);          // the largest |stored a − exact Σ area vectors| / area of a child
    T c_error_ = T(0);          // the largest distance of a stored c from its exact centroid
};

template <class T>
template <bool Bounded>
WindingNumber<T> Solid<T>::walk(const Vertex<T>& p, T beta) const noexcept {
    if (far_.empty()) return {T(0), T(0), T(0)};
    if (!is_finite(p)) return {std::numeric_limits<T>::quiet_NaN(), inf, inf};
    const auto& nodes = bvh_.tree().nodes();
    const TriangleBlocks<T>& blocks = bvh_.blocks();
    const FarTest is_far{std::max(beta * beta, T(1))}; // NaN stays NaN: nothing is far, the sum is exact
    T sum = T(0);                                      // solid angles, over 4π at the end
    Tally tally;
    std::uint32_t stack[Tree::depth_limit * 7 + 8];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const std::uint32_t i = stack[--top];
        const FarField& f = far_[i];
        T rx[8], ry[8], rz[8], d2[8], far[8];
        for (int k = 0; k < 8; ++k) {
            rx[k] = f.c[0][k] - p.x, ry[k] = f.c[1][k] - p.y, rz[k] = f.c[2][k] - p.z;
            d2[k] = rx[k] * rx[k] + ry[k] * ry[k] + rz[k] * rz[k];
            far[k] = T(is_far(d2[k], f.r2[k])); // an empty slot never is (infinite radius)
        }
        sum += dipoles(f.a[0], f.a[1], f.a[2], rx, ry, rz, d2, far);
        if constexpr (Bounded) {
            tally.terms += T(8);
            for (int k = 0; k < 8; ++k) {
                if (far[k] == T(0)) continue;
                // Σ areaᵢ ≤ S + |Σ aᵢ|, and the stored a is within a_error_·Σ areaᵢ of Σ aᵢ.
                const T S = f.spread[k],
                        am = std::sqrt(f.a[0][k] * f.a[0][k] + f.a[1][k] * f.a[1][k] + f.a[2][k] * f.a[2][k]);
                const T A = a_error_ < T(0.5) ? (S + am) * (T(1) + T(4) * u) / (T(1) - a_error_) : inf;
                const T at = am * (T(1) + T(4) * u) + a_error_ * A, d = std::sqrt(d2[k]);
                const T dl = d * (T(1) - T(4) * u), r = std::sqrt(f.r2[k]);
                const T by_spread = truncation_bound(S, at, d, r) +
                                    at * T(2) * c_error_ / (dl * dl * dl); // c off the centroid: |Σ aᵢ|·‖DK‖·|δc|
                const T by_area = truncation_bound(A, T(0), d, r); // all of it as n − m: A·(1/(d−r)² − 1/d²)
                tally.truncation += by_spread < by_area ? by_spread : by_area;
                tally.dipole_scale += A / d2[k];
                tally.node_scale += A / d2[k];
            }
        }
        for (int k = 0; k < 8; ++k) {
            const std::uint32_t ref = nodes[i].child[k];
            if (far[k] != T(0) || ref == Tree::empty_child) continue;
            if (ref & Tree::leaf_bit)
                sum += leaf_sum<Bounded>(blocks[ref & ~Tree::leaf_bit], p, is_far, &tally);
            else
                stack[top++] = ref;
        }
    }
    const T value = sum / (T(4) * pi);
    if constexpr (!Bounded) {
        return {value, T(0), T(0)};
    } else {
        // Recursive summation of n terms: off by at most γ_n·Σ|terms| (Higham, Accuracy and
        // Stability of Numerical Algorithms, §4.2); each dipole within 16u of its scale.
        const T nu = tally.terms * u;
        const T gamma = nu < T(0.5) ? nu / (T(1) - nu) : inf;
        const T rounding = T(16) * u * tally.dipole_scale + a_error_ * tally.node_scale + tally.exact_rounding +
                           gamma * (tally.dipole_scale + tally.exact_abs);
        const T up = T(1) + T(2) * gamma + T(32) * u; // the bound's own rounding, upwards
        const T truncation = tally.truncation / (T(4) * pi) * up;
        const T bound = ((tally.truncation + rounding) / (T(4) * pi) + T(2) * u * std::fabs(value)) * up;
        return {value, bound == bound ? bound : inf, truncation == truncation ? truncation : inf};
    }
}

} // namespace isin
