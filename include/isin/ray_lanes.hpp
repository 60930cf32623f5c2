#pragma once
/// isin — many rays against one primitive at once: rays × primitives in lanes, for scenes too
/// small for a Bvh (the note's 5 triangles and 2 spheres). `may_hit` runs a primitive's test
/// for every ray of a RayLanes block, a register of rays at a time (AVX-512 or AVX, written
/// once for one ray or a register: detail/lane_pack.hpp; a branch-free loop elsewhere), and
/// answers, ray by ray, whether the primitive's own scalar test could hit: a conservative
/// filter, never a verdict. A ray the filter drops is certain to miss; a ray it keeps is tested
/// by the scalar function, whose hit is then the result — so the stream calls of a Scene return
/// the single-ray calls' hits bit for bit, however the compiler rounds or fuses either loop.
///
/// How conservative: the lanes compute the same quantities as the scalar test, in the same
/// precision. Each is a dot product of a cross product (or a sphere's distances), whose rounding
/// error is bounded by a small multiple of the magnitudes involved (γₙ, Higham §3.1; pbrt-v4
/// §6.8.1): a lane drops a ray only when a quantity is beyond the scalar test's threshold by more
/// than twice that bound (both computations may be off by it, in opposite directions), and
/// keeps every ray whose arithmetic met a NaN or an infinity.
///
///     isin::RayLanes<float> lanes;
///     lanes.assign(rays, n);                                     // up to RayLanes::capacity rays
///     const std::uint64_t maybe = isin::may_hit(lanes, triangle); // bit k: ray k may hit
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "detail/lane_pack.hpp"
#include "error_bound.hpp"
#include "ray.hpp"
#include "sphere.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// Up to `capacity` rays as six arrays, padded with zero rays to whole blocks of `block` lanes
/// (what one pass of the vectorised loops covers), and each ray's largest direction component.
template <class T>
struct RayLanes {
    static_assert(std::is_floating_point_v<T>, "isin::RayLanes needs a floating-point type");
    static constexpr std::size_t capacity = 64; ///< rays per block: the bits of may_hit's answer
    static constexpr std::size_t block = 64 / sizeof(T);
    std::size_t count = 0;  ///< rays held, ≤ capacity
    std::size_t padded = 0; ///< count rounded up to whole blocks
    alignas(64) T ox[capacity], oy[capacity], oz[capacity];
    alignas(64) T dx[capacity], dy[capacity], dz[capacity];
    alignas(64) T dmax[capacity]; ///< max |Rd| component

    /// Holds rays[0 … n) (n is cut to capacity).
    template <class RayAt>
    void assign_with(const RayAt& ray_at, std::size_t n) noexcept {
        count = std::min(n, capacity);
        padded = (count + block - 1) / block * block;
        for (std::size_t k = 0; k < padded; ++k) {
            const Ray<T> r = k < count ? ray_at(k) : Ray<T>{{T(0), T(0), T(0)}, {T(0), T(0), T(0)}};
            ox[k] = r.origin.x, oy[k] = r.origin.y, oz[k] = r.origin.z;
            dx[k] = r.direction.x, dy[k] = r.direction.y, dz[k] = r.direction.z;
            using std::max;
            dmax[k] = max(max(std::fabs(dx[k]), std::fabs(dy[k])), std::fabs(dz[k]));
        }
    }
    void assign(const Ray<T>* rays, std::size_t n) noexcept {
        assign_with([rays](std::size_t k) { return rays[k]; }, n);
    }

    /// A lane's flag where there are no registers of lanes: an integer as wide as T, so that the
    /// loops that set flags vectorise at the width of T where the compiler does it (with bytes it
    /// would take 64 rays per pass, more than a tile has).
    using Flag = std::conditional_t<sizeof(T) == 4, std::int32_t, std::int64_t>;

    /// The bits of rays [0, count) set where keep[k] is non-zero.
    [[nodiscard]] std::uint64_t bits(const Flag* keep) const noexcept {
        std::uint64_t m = 0;
        for (std::size_t k = 0; k < padded; ++k) m |= std::uint64_t(keep[k] != 0) << k;
        return count == capacity ? m : m & ((std::uint64_t(1) << count) - 1);
    }
};

namespace detail {
/// The allowance of the lane filters: 2·(bound on a dot of a cross product's rounding, 6·γ₆ of its
/// magnitudes, see below), with a margin of 8/3, and a floor for products that underflow.
template <class T>
constexpr T lane_allowance = T(32) * rounding_gamma<T>(6);
template <class T>
constexpr T lane_floor = T(64) * std::numeric_limits<T>::min();
} // namespace detail

namespace detail {
/// The bits of the rays of `lanes` that `keep(ox, oy, oz, dx, dy, dz, dmax)` keeps: a register of
/// lanes at a time where the target has them (lane_pack.hpp), else ray by ray.
template <class T, class Keep>
[[nodiscard]] std::uint64_t filter_lanes(const RayLanes<T>& lanes, const Keep& keep) noexcept {
#if defined(ISIN_DETAIL_LANE_PACKS)
    using P = Pack<T>;
    static_assert(RayLanes<T>::block % P::width == 0, "a block of lanes is whole registers");
    std::uint64_t m = 0;
    for (std::size_t k = 0; k < lanes.padded; k += P::width)
        m |= keep(P::load(lanes.ox + k), P::load(lanes.oy + k), P::load(lanes.oz + k), P::load(lanes.dx + k),
                  P::load(lanes.dy + k), P::load(lanes.dz + k), P::load(lanes.dmax + k))
                 .bits()
             << k;
    return lanes.count == RayLanes<T>::capacity ? m : m & ((std::uint64_t(1) << lanes.count) - 1);
#else
    alignas(64) typename RayLanes<T>::Flag flags[RayLanes<T>::capacity] = {};
    for (std::size_t i = 0; i < lanes.padded; ++i)
        flags[i] = keep(lanes.ox[i], lanes.oy[i], lanes.oz[i], lanes.dx[i], lanes.dy[i], lanes.dz[i], lanes.dmax[i]);
    return lanes.bits(flags);
#endif
}
} // namespace detail

/// Whether each ray of `lanes` may hit `tri` by `intersect_moller_trumbore` (bit k for ray k):
/// clear only where that test certainly misses. The lanes compute Möller–Trumbore's det, u·det,
/// v·det and t·det as the scalar test does (note §10); each is a·(b × c) of vectors whose
/// components are at most A, B, C in magnitude, computed with an error of at most
/// 6·(γ₃(1 + γ₂) + γ₂)·ABC ≤ 6γ₆·ABC. A ray is dropped when |det| exceeds its allowance (so both
/// computations see the same sign) and u, v, u + v or t is outside by more than theirs.
template <class T>
[[nodiscard]] inline std::uint64_t may_hit(const RayLanes<T>& lanes, const Triangle<T>& tri) noexcept {
    const Vertex<T> e1 = tri.v1 - tri.v0; // the scalar test's edges, bit for bit
    const Vertex<T> e2 = tri.v2 - tri.v0;
    const T E1 = max_abs(e1), E2 = max_abs(e2);
    const T k = detail::lane_allowance<T>, floor = detail::lane_floor<T>;
    const T k_det = k * E1 * E2;
    const T v0x = tri.v0.x, v0y = tri.v0.y, v0z = tri.v0.z;
    // One ray (V = T) or a register of rays (V = detail::Pack<T>); the same arithmetic.
    return detail::filter_lanes(lanes, [&](auto ox, auto oy, auto oz, auto dx, auto dy, auto dz, auto D) {
        using detail::lane_abs, detail::lane_max, detail::negate_where;
        const auto px = dy * e2.z - dz * e2.y; // MT: P = Rd × E2
        const auto py = dz * e2.x - dx * e2.z;
        const auto pz = dx * e2.y - dy * e2.x;
        const auto det = e1.x * px + e1.y * py + e1.z * pz;     // MT: det = E1·P
        const auto sx = ox - v0x, sy = oy - v0y, sz = oz - v0z; // MT: S = Ro − V0
        const auto U = sx * px + sy * py + sz * pz;             // MT: u·det = S·P
        const auto qx = sy * e1.z - sz * e1.y;                  // MT: Q = S × E1
        const auto qy = sz * e1.x - sx * e1.z;
        const auto qz = sx * e1.y - sy * e1.x;
        const auto V = dx * qx + dy * qy + dz * qz;       // MT: v·det = Rd·Q
        const auto W = e2.x * qx + e2.y * qy + e2.z * qz; // MT: t·det = E2·Q
        const auto S = lane_max(lane_max(lane_abs(sx), lane_abs(sy)), lane_abs(sz));
        const auto tol_det = k_det * D + floor, tol_u = k * S * D * E2 + floor;
        const auto tol_v = k * S * D * E1 + floor, tol_t = k * S * E1 * E2 + floor;
        const auto negative = det < T(0);
        const auto abs_det = lane_abs(det), u = negate_where(negative, U), v = negate_where(negative, V),
                   t = negate_where(negative, W);
        const auto sum_slack = T(4) * std::numeric_limits<T>::epsilon() * (lane_abs(u) + lane_abs(v) + abs_det);
        // Comparisons that a NaN fails keep the ray.
        const auto out =
            (u < -tol_u) | (v < -tol_v) | (t < -tol_t) | (u + v > abs_det + (tol_u + tol_v + tol_det + sum_slack));
        return !((abs_det > tol_det) & out);
    });
}

/// Whether each ray of `lanes` may hit `sp` by `intersect` (note §6; bit k for ray k): clear only
/// where that test certainly misses — the ray passes aside (m² > r² by more than the allowance)
/// or the sphere is behind an origin outside it. s = l·Rd/|Rd|² is off by at most
/// γ₈·Σ|lᵢ·Rdᵢ|/|Rd|², l² by γ₃·l², m² = |l − s·Rd|² by about 36ε·l² (|s·Rd| ≤ |l|); each
/// allowance is twice that with a margin.
template <class T>
[[nodiscard]] inline std::uint64_t may_hit(const RayLanes<T>& lanes, const Sphere<T>& sp) noexcept {
    const T cx = sp.center.x, cy = sp.center.y, cz = sp.center.z;
    const T r2 = sp.radius * sp.radius;
    const T k = detail::lane_allowance<T>, floor = detail::lane_floor<T>;
    constexpr T g8 = rounding_gamma<T>(8), eps = std::numeric_limits<T>::epsilon();
    return detail::filter_lanes(lanes, [&](auto ox, auto oy, auto oz, auto dx, auto dy, auto dz, auto) {
        using detail::lane_abs;
        const auto a = dx * dx + dy * dy + dz * dz;
        const auto inv_a = T(1) / a;
        const auto lx = cx - ox, ly = cy - oy, lz = cz - oz;  // §6: l = C − Ro
        const auto s = (lx * dx + ly * dy + lz * dz) * inv_a; // §6: s = l·Rd
        const auto l2 = lx * lx + ly * ly + lz * lz;          // §6: l2 = l·l
        const auto mx = lx - s * dx, my = ly - s * dy, mz = lz - s * dz;
        const auto m2 = mx * mx + my * my + mz * mz; // §6: m2 = |l − s·Rd|²
        const auto ld = lane_abs(lx * dx) + lane_abs(ly * dy) + lane_abs(lz * dz);
        const auto tol_s = T(4) * g8 * ld * inv_a + floor;
        const auto tol_l2 = T(8) * eps * l2 + floor;
        const auto tol_m2 = k * (l2 + r2) + floor;
        const auto aside = m2 > r2 + tol_m2;
        const auto behind = (s < -tol_s) & (l2 > r2 + tol_l2);
        return !(aside | behind);
    });
}

} // namespace isin
