#pragma once
/// isin — many rays against one primitive at once: rays × primitives in lanes, for scenes too
/// small for a Bvh (the note's 5 triangles and 2 spheres), a register of rays at a time
/// (AVX-512 or AVX, written once for one ray or a register: simd/pack.hpp; one ray at a
/// time elsewhere). Two kinds of test:
/// - `hit_lanes`, for triangles (Möller–Trumbore) and spheres (§6): the exact test, each lane
///   deciding and computing t, u, v with intersect_moller_trumbore's and intersect's operations,
///   every product added through lane_fma (fused where the target has FMA, never where it has
///   not). Without FMA the results are the scalar tests' bit for bit; with it, a compiler may fuse
///   the scalar tests otherwise, so a Scene runs these kernels for one ray too, on plain values:
///   its stream calls return the single-ray calls' hits bit for bit.
/// - `may_hit`, a conservative filter for any primitive (a customisation point of user kinds):
///   whether the primitive's own scalar test could hit, never a verdict. A ray the filter drops
///   is certain to miss; a ray it keeps is tested by the scalar function, whose hit is then the
///   result — the same bits however the compiler rounds or fuses either loop.
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
///     isin::RayLaneHits<float> hits;
///     const std::uint64_t hit = isin::hit_lanes(lanes, triangle, hits); // bit k: ray k hits at hits.t[k]
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "detail/attributes.hpp"
#include "simd/pack.hpp"
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

    /// Holds rays[0 … n) (n is cut to capacity); lanes past them hold zeros.
    void assign(const Ray<T>* rays, std::size_t n) noexcept {
        count = std::min(n, capacity);
        padded = (count + block - 1) / block * block;
        std::size_t k = 0;
#if defined(__AVX512F__) && !defined(ISIN_FORCE_PURE)
        // whole registers of rays transposed in registers (avx512.hpp), rays being six T each
        static_assert(sizeof(Ray<T>) == 6 * sizeof(T) && block * sizeof(T) == 64, "transpose6's layout");
        for (; k + block <= count; k += block) {
            T* const out[6] = {ox + k, oy + k, oz + k, dx + k, dy + k, dz + k};
            detail::transpose6(&rays[k].origin.x, out);
        }
#endif
        for (; k < count; ++k) {
            ox[k] = rays[k].origin.x, oy[k] = rays[k].origin.y, oz[k] = rays[k].origin.z;
            dx[k] = rays[k].direction.x, dy[k] = rays[k].direction.y, dz[k] = rays[k].direction.z;
        }
        for (; k < padded; ++k) ox[k] = oy[k] = oz[k] = dx[k] = dy[k] = dz[k] = T(0);
        using std::max;
        for (std::size_t i = 0; i < padded; ++i)
            dmax[i] = max(max(std::fabs(dx[i]), std::fabs(dy[i])), std::fabs(dz[i]));
    }

    /// Holds ray_at(0 … n) (n is cut to capacity), for rays that are not an array of Ray.
    template <class RayAt>
    void assign_with(const RayAt& ray_at, std::size_t n) noexcept {
        Ray<T> rays[capacity];
        count = std::min(n, capacity);
        for (std::size_t k = 0; k < count; ++k) rays[k] = ray_at(k);
        assign(rays, count);
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
/// lanes at a time where the target has them (simd/pack.hpp), else ray by ray.
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

/// The hits of the rays of a RayLanes block on one primitive (hit_lanes): t (+∞ where a ray
/// misses), u and v as Hit has them.
template <class T>
struct RayLaneHits {
    alignas(64) T t[RayLanes<T>::capacity], u[RayLanes<T>::capacity], v[RayLanes<T>::capacity];
};

namespace detail {
/// A register of rays (V = LaneRegister's): lanes k … k + width of a RayLanes block, or one ray
/// in every lane; or one ray (V = T).
template <class T, class V = typename LaneRegister<T>::V>
struct RayRegister {
    V ox, oy, oz, dx, dy, dz;
    RayRegister(const RayLanes<T>& lanes, std::size_t k) noexcept
        : ox(load(lanes.ox + k)), oy(load(lanes.oy + k)), oz(load(lanes.oz + k)), dx(load(lanes.dx + k)),
          dy(load(lanes.dy + k)), dz(load(lanes.dz + k)) {}
    explicit RayRegister(const Ray<T>& ray) noexcept
        : ox(ray.origin.x), oy(ray.origin.y), oz(ray.origin.z), dx(ray.direction.x), dy(ray.direction.y),
          dz(ray.direction.z) {}

private:
    static V load(const T* p) noexcept { return load_lanes<T, V>(p); }
};

/// is_degenerate for a triangle's edges, the normal e1 × e2 rounded as lane_fma rounds: the
/// register and the one-value forms of the kernels below take the same decision.
template <class T>
bool degenerate_triangle(const Vertex<T>& e1, const Vertex<T>& e2) noexcept {
    const Vertex<T> n{lane_cross_term(e1.y, e2.z, e1.z, e2.y), lane_cross_term(e1.z, e2.x, e1.x, e2.z),
                      lane_cross_term(e1.x, e2.y, e1.y, e2.x)}; // §2: e1 × e2
    return is_degenerate(e1, e2, n);
}
/// surface_band's part that does not depend on the ray, (√3·e)·(2r + √3·e) for the sphere's
/// surface_point_error e, rounded as lane_fma rounds (as degenerate_triangle).
template <class T>
T surface_band_of_sphere(const Sphere<T>& sp) noexcept {
    const T error = lane_fma(rounding_gamma<T>(6), sp.radius, rounding_gamma<T>(1) * max_abs(sp.center));
    const T e = T(1.7320508075688772) * error; // surface_band's √3·e
    return e * lane_fma(T(2), sp.radius, e);
}

/// Möller–Trumbore (note §10) for a register of rays or one ray, deciding and computing as
/// intersect_moller_trumbore (rounding each a·b + c as lane_fma does), without culling, for a
/// triangle with edges e1, e2 from v0 (a degenerate one, checked as there on the hit path only,
/// is never hit). Returns the lanes hit (bit 0 for the first) and stores their t, u, v (the
/// other lanes' are unspecified); leaves early when no lane can hit. Every product it adds
/// goes through lane_fma, so one ray and a register of rays get the same bits.
template <class T, class V>
std::uint64_t moller_trumbore_register(const RayRegister<T, V>& r, const Vertex<T>& v0, const Vertex<T>& e1,
                                       const Vertex<T>& e2, T* t_out, T* u_out, T* v_out) noexcept {
    const V ex(e2.x), ey(e2.y), ez(e2.z);
    const V px = lane_cross_term(r.dy, ez, r.dz, ey); // MT: P = Rd × E2
    const V py = lane_cross_term(r.dz, ex, r.dx, ez);
    const V pz = lane_cross_term(r.dx, ey, r.dy, ex);
    const V det = lane_dot(V(e1.x), V(e1.y), V(e1.z), px, py, pz); // MT: det = E1·P
    const V sign = select(det < T(0), V(T(-1)), V(T(1)));
    const V abs_det = det * sign;
    const V sx = r.ox - V(v0.x), sy = r.oy - V(v0.y), sz = r.oz - V(v0.z); // MT: S = Ro − V0
    const V U = lane_dot(sx, sy, sz, px, py, pz) * sign;                   // MT: u = S·P / det
    auto hit = (det != T(0)) & (U >= T(0)) & (U <= abs_det);
    if (lane_bits(hit) == 0) return 0;
    const V qx = lane_cross_term(sy, V(e1.z), sz, V(e1.y)); // MT: Q = S × E1
    const V qy = lane_cross_term(sz, V(e1.x), sx, V(e1.z));
    const V qz = lane_cross_term(sx, V(e1.y), sy, V(e1.x));
    const V Vd = lane_dot(r.dx, r.dy, r.dz, qx, qy, qz) * sign; // MT: v = Rd·Q / det
    const V tt = lane_dot(ex, ey, ez, qx, qy, qz) * sign;       // MT: t = E2·Q / det
    hit = hit & (Vd >= T(0)) & (U + Vd <= abs_det) & (tt > T(0));
    if (lane_bits(hit) == 0 || degenerate_triangle(e1, e2)) return 0;
    const V inv_det = T(1) / abs_det;
    const V t = tt * inv_det;
    hit = hit & (t > T(0)) & (t < std::numeric_limits<T>::infinity());
    store_lanes(t, t_out), store_lanes(U * inv_det, u_out), store_lanes(Vd * inv_det, v_out);
    return lane_bits(hit);
}

/// The §6 sphere test for a register of rays or one ray, deciding and computing as
/// intersect(ray, sphere) (rounding as lane_fma does), for a sphere of finite positive radius
/// (the caller checks). As moller_trumbore_register: the lanes hit, their t (u = v = 0) stored;
/// surface_band's part that does not depend on the ray is computed past the early exit.
template <class T, class V>
std::uint64_t sphere_register(const RayRegister<T, V>& r, const Sphere<T>& sp, T* t_out, T* u_out, T* v_out) noexcept {
    constexpr T inf = std::numeric_limits<T>::infinity();
    const V a = lane_dot(r.dx, r.dy, r.dz, r.dx, r.dy, r.dz);
    const V inv_a = T(1) / a; // 1 for the note's unit Rd
    const V lx = V(sp.center.x) - r.ox, ly = V(sp.center.y) - r.oy, lz = V(sp.center.z) - r.oz; // §6: l = C − Ro
    const V s = lane_dot(lx, ly, lz, r.dx, r.dy, r.dz) * inv_a;                                 // §6: s = l·Rd
    const V l2 = lane_dot(lx, ly, lz, lx, ly, lz);                                              // §6: l2 = l·l
    const T r2 = sp.radius * sp.radius;                                                         // §6: r2 = r²
    const V mx = lane_fma(-s, r.dx, lx), my = lane_fma(-s, r.dy, ly), mz = lane_fma(-s, r.dz, lz);
    const V m2 = lane_dot(mx, my, mz, mx, my, mz); // §6: m2 = |l − s·Rd|²
    const auto outside = l2 > r2;
    const auto ahead = !((s < T(0)) & outside); // §6: not behind an origin outside
    auto hit = (a > T(0)) & (a < inf) & ahead & (m2 <= r2);
    if (lane_bits(hit) == 0) return 0;
    const T band0 = surface_band_of_sphere(sp);
    const V q = lane_sqrt((V(r2) - m2) * inv_a); // §6: q = √(r2 − m2)
    const V c = (l2 - V(r2)) * inv_a;            // t_near · t_far
    const auto on_surface = lane_abs(l2 - V(r2)) <= lane_fma(V(rounding_gamma<T>(6)), l2 + V(r2), V(band0));
    const V inside_t = select(s >= T(0), s + q, c / (s - q));                      // §6: t = s + q
    const V t = select(on_surface, s + q, select(outside, c / (s + q), inside_t)); // §6, §8 fix
    const auto not_leaving = (s > T(0)) | !on_surface; // §8 fix: from the surface, only inwards
    hit = hit & not_leaving & (t > T(0)) & (t < inf);
    store_lanes(t, t_out), store_lanes(V(T(0)), u_out), store_lanes(V(T(0)), v_out);
    return lane_bits(hit);
}

/// The exact test of a register of rays (or of one ray) on a triangle (Möller–Trumbore, without
/// culling) or a sphere (§6): the lanes hit, their t, u, v stored at t, u, v.
template <class T, class V>
std::uint64_t hit_register(const RayRegister<T, V>& r, const Triangle<T>& tri, T* t, T* u, T* v) noexcept {
    return moller_trumbore_register(r, tri.v0, tri.v1 - tri.v0, tri.v2 - tri.v0, t, u, v);
}
template <class T, class V>
std::uint64_t hit_register(const RayRegister<T, V>& r, const Sphere<T>& sp, T* t, T* u, T* v) noexcept {
    if (!(sp.radius > T(0)) || !(sp.radius < std::numeric_limits<T>::infinity())) return 0;
    return sphere_register(r, sp, t, u, v);
}
} // namespace detail

/// The hits of every ray of `lanes` on `shape` (bit k: ray k hits, at out.t[k] with out.u[k],
/// out.v[k]; nothing is said of the lanes missed), for triangles by Möller–Trumbore without
/// culling and spheres by §6: intersect_moller_trumbore's and intersect's decisions and
/// quantities, a register of rays at a time. The Scene runs the same kernels for one ray on plain
/// values (detail::hit_register on a RayRegister<T, T>), with the same bits.
template <class T, class Shape>
auto hit_lanes(const RayLanes<T>& lanes, const Shape& shape, RayLaneHits<T>& out) noexcept
    -> decltype(detail::hit_register(std::declval<const detail::RayRegister<T>&>(), shape, out.t, out.u, out.v)) {
    std::uint64_t hits = 0;
    for (std::size_t k = 0; k < lanes.padded; k += detail::LaneRegister<T>::width)
        hits |= detail::hit_register(detail::RayRegister<T>(lanes, k), shape, out.t + k, out.u + k, out.v + k) << k;
    return lanes.count == RayLanes<T>::capacity ? hits : hits & ((std::uint64_t(1) << lanes.count) - 1);
}

} // namespace isin
