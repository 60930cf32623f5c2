#pragma once
/// isin — rectangular area lights (beyond the note, which has point lights only): a RectLight
/// shades as the mean of point lights of its colour spread over its rectangle (§7 per point, §9
/// per shadow ray). The renderer estimates that mean from stratified samples, jittered by a hash
/// of the shading point's coordinates: the same picture every run, whatever the threads, tiles or
/// bands, and independent noise from pixel to pixel. Samples are generated and shaded a register
/// of lanes at a time, with 32-bit hashes and no remainders.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "color.hpp"
#include "detail/attributes.hpp"
#include "simd/pack.hpp"
#include "ray.hpp"
#include "shading.hpp"
#include "vec.hpp"

namespace isin {

/// The strata of `samples` stratified samples over a rectangle with edges of lengths |edge_u|
/// and |edge_v|: nu × nv = samples cells, nv the largest divisor of samples up to √samples (so
/// 16 → 4 × 4, 8 → 4 × 2, a prime p → p × 1), the longer edge divided more often.
struct LightStrata {
    int nu = 1, nv = 1;
};

/// LightStrata for `samples` ≥ 1 (values below 1 count as 1) over edges of lengths lu and lv.
template <class T>
[[nodiscard]] inline LightStrata light_strata(int samples, T lu, T lv) noexcept {
    const int n = samples < 1 ? 1 : samples;
    int small = 1;
    for (int d = 1; d * d <= n; ++d)
        if (n % d == 0) small = d;
    const int large = n / small;
    return lu >= lv ? LightStrata{large, small} : LightStrata{small, large};
}

namespace detail {
// splitmix64's finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mix.
[[nodiscard]] inline std::uint64_t mix64(std::uint64_t z) noexcept {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// The bits of a coordinate (float or double) as an integer, for hashing.
template <class T>
[[nodiscard]] inline std::uint64_t coordinate_bits(T x) noexcept {
    using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
    static_assert(sizeof(T) == sizeof(Bits), "float or double");
    Bits bits;
    std::memcpy(&bits, &x, sizeof x);
    return std::uint64_t(bits);
}
} // namespace detail

/// The seed of a shading point's light samples: a hash of its coordinates' bits and the light's
/// index, so that a point gets the same samples whoever shades it (threads, tiles, bands).
template <class T>
[[nodiscard]] inline std::uint64_t light_seed(const Vertex<T>& point, std::size_t light) noexcept {
    std::uint64_t h = detail::mix64(detail::coordinate_bits(point.x) + 0x9E3779B97F4A7C15ull * (light + 1));
    h = detail::mix64(h ^ detail::coordinate_bits(point.y));
    return detail::mix64(h ^ detail::coordinate_bits(point.z));
}

namespace detail {
// lowbias32 (Wellons 2018): a 32-bit integer hash of two multiplies, for the samples' jitter.
[[nodiscard]] constexpr std::uint32_t hash32(std::uint32_t x) noexcept {
    x ^= x >> 16;
    x *= 0x7FEB352Du;
    x ^= x >> 15;
    x *= 0x846CA68Bu;
    return x ^ (x >> 16);
}

// x's top 16 bits scaled to [0, n) by a multiply and a shift (Lemire 2019): no remainder; n ≤ 65,536.
[[nodiscard]] constexpr std::uint32_t reduce16(std::uint32_t x, std::uint32_t n) noexcept {
    return ((x >> 16) * n) >> 16;
}

// The 32-bit seeds of one shading point's pattern: its jitter in u and v, its rotations.
struct PatternSeeds {
    std::uint32_t jitter_u, jitter_v, rotate_u, rotate_v;
};
[[nodiscard]] inline PatternSeeds pattern_seeds(std::uint64_t seed) noexcept {
    const auto low = std::uint32_t(seed), high = std::uint32_t(seed >> 32);
    return {low, high, hash32(low ^ 0x68E31DA4u), hash32(high ^ 0xB5297A4Du)};
}

// The (u, v) of sample k = i + j·nu of the multi-jittered set (Chiu, Shirley, Wang 1994):
// u = (i·nv + σ_i(j) + ξ1)/(nu·nv), v = (j·nu + τ_j(i) + ξ2)/(nu·nv), σ_i, τ_j rotations by
// hashes of i or j, ξ1, ξ2 in [0,1) with 24 bits from hashes of k; inv_n = 1/(nu·nv).
template <class T>
inline void sample_uv(const PatternSeeds& s, std::uint32_t nu, std::uint32_t nv, std::uint32_t i, std::uint32_t j,
                      std::uint32_t k, T inv_n, T& u, T& v) noexcept {
    std::uint32_t sigma = j + reduce16(hash32(s.rotate_u + i * 0x9E3779B9u), nv); // σ_i(j) = (j + h(i)) mod nv
    sigma -= sigma >= nv ? nv : 0u;
    std::uint32_t tau = i + reduce16(hash32(s.rotate_v + j * 0x9E3779B9u), nu); // τ_j(i) = (i + h(j)) mod nu
    tau -= tau >= nu ? nu : 0u;
    constexpr T unit = T(1) / T(16777216); // 2^-24: 24 random bits each, exact in float
    const T xi1 = T(hash32(s.jitter_u + k * 0x9E3779B9u) >> 8) * unit;
    const T xi2 = T(hash32(s.jitter_v ^ (k * 0x85EBCA6Bu)) >> 8) * unit;
    u = (T(i * nv + sigma) + xi1) * inv_n;
    v = (T(j * nu + tau) + xi2) * inv_n;
}
} // namespace detail

/// Sample k (0 ≤ k < nu·nv) of the multi-jittered set seeded by `seed` (Chiu, Shirley, Wang
/// 1994): in stratum (i, j) = (k mod nu, k div nu) of the nu × nv grid, and moreover the nu·nv
/// samples' u fall in distinct 1/(nu·nv) strata and so do their v (an edge across the rectangle
/// cuts off a well-stratified share): u = (i + (σ_i(j) + ξ1)/nv)/nu, v = (j + (τ_j(i) + ξ2)/nu)/nv,
/// σ_i, τ_j rotations by hashes of seed and i or j, ξ1, ξ2 in [0,1) from hashes of seed and k.
/// rect_light_term shades the same points, a register at a time.
template <class T>
[[nodiscard]] inline Vertex<T> light_sample(const RectLight<T>& light, const LightStrata& strata, std::uint64_t seed,
                                            int k) noexcept {
    const auto nu = std::uint32_t(strata.nu < 1 ? 1 : strata.nu), nv = std::uint32_t(strata.nv < 1 ? 1 : strata.nv);
    const auto kk = std::uint32_t(k < 0 ? 0 : k);
    T u, v;
    detail::sample_uv(detail::pattern_seeds(seed), nu, nv, kk % nu, kk / nu, kk, T(1) / T(nu * nv), u, v);
    return {detail::lane_fma(v, light.edge_v.x, detail::lane_fma(u, light.edge_u.x, light.corner.x)),
            detail::lane_fma(v, light.edge_v.y, detail::lane_fma(u, light.edge_u.y, light.corner.y)),
            detail::lane_fma(v, light.edge_v.z, detail::lane_fma(u, light.edge_u.z, light.corner.z))};
}

/// What shading a point under an area light needs: the point, where its shadow rays start, its
/// unit normal N and direction to the eye V (both on the side lit), and its Phong inputs (§7).
template <class T>
struct LitPoint {
    Vertex<T> point, from, N, V;
    T kd, ks, shininess;
    Color<T> object, highlight;
};

/// How a RectLight is sampled at one point.
struct LightSampling {
    int samples = 16; ///< stratified samples over the rectangle
    bool adaptive =
        true; ///< rays to the corners (and from 64 samples a quarter of them) first, the rest if they disagree
    bool shadows = true; ///< cast shadow rays (§9); without, every sample is visible
    bool opaque = true;  ///< nothing in the scene is transparent: shadow rays through `occluded`
};

/// Whether rect_light_term traces shadow rays to the corners first (LightSampling::adaptive with
/// shadows and 8 samples or more).
[[nodiscard]] inline bool corners_first(const LightSampling& s) noexcept {
    return s.adaptive && s.shadows && s.samples >= 8;
}

namespace detail {
/// c^e for e ≥ 1 by squaring (e's bits from the lowest): ⌊log2 e⌋ squarings and a multiply per
/// further set bit; a relative error of about e·ε (each squaring doubles the one before).
template <class V>
[[nodiscard]] V lane_power(V c, std::uint32_t e) noexcept {
    for (; (e & 1u) == 0u; e >>= 1) c = c * c;
    V result = c;
    for (e >>= 1; e; e >>= 1) {
        c = c * c;
        if (e & 1u) result = result * c;
    }
    return result;
}

/// The cosine below which a highlight term cos^shininess is under 2^-24 of ks and is left out; 2
/// (none counts) without a positive shininess.
template <class T>
[[nodiscard]] inline T least_highlight_cosine(T shininess) noexcept {
    return shininess > T(0) ? std::exp2(T(-24) / shininess) : T(2);
}

/// The shininess as an exponent for lane_power where it is a whole number from 1 to 4,096, else 0.
template <class T>
[[nodiscard]] inline std::uint32_t integral_power(T shininess) noexcept {
    return shininess >= T(1) && shininess <= T(4096) && shininess == std::floor(shininess) ? std::uint32_t(shininess)
                                                                                           : 0u;
}

/// The sum of a register's lanes, lane 0 first.
template <class T, class V>
[[nodiscard]] T lane_total(const V& lanes) noexcept {
    alignas(64) T a[LaneRegister<T>::width];
    store_lanes(lanes, a);
    T sum = T(0);
    for (const T x : a) sum += x;
    return sum;
}

/// What shadow rays 0 … count − 1 from a point let through, into visible[]: 1 or 0 past opaque
/// occluders (scene.occluded), else the scene's transmittance. `one` holds count ones.
template <class T, class SceneT>
void shadow_visibility(const SceneT& scene, const Ray<T>* rays, std::size_t count, bool opaque, const T* one,
                       T* visible) {
    if (!opaque) return scene.transmittance(rays, count, one, visible);
    std::uint8_t blocked[64];
    for (std::size_t first = 0; first < count; first += 64) {
        const std::size_t m = std::min<std::size_t>(64, count - first);
        scene.occluded(rays + first, m, one + first, blocked);
        for (std::size_t t = 0; t < m; ++t) visible[first + t] = blocked[t] ? T(0) : T(1);
    }
}

/// A walk over a u × v grid of strata (every step_u-th column and step_v-th row of a light's
/// strata), `size` at a time: by 8 × 8 blocks of four 4 × 4 tiles where u and v are multiples of
/// 8, by 4 × 4 tiles where they are multiples of 4, else row by row. So the 16 consecutive shadow
/// rays of a stream's packet go to a square patch of the light, and two in a row to an 8 × 4 one:
/// bundles narrower than rows across the light (on the knot of benchmarks/area_lights, 256
/// samples, 21-29% less time). Counted on from call to call, without divisions.
struct StrataWalk {
    std::uint32_t u, step_u, step_v;
    std::uint32_t side;         // 8, 4 or 1: the blocks' or tiles' side, or row by row
    std::uint32_t i = 0, j = 0; // the next block's, tile's or stratum's first column and row

    StrataWalk(std::uint32_t grid_u, std::uint32_t grid_v, std::uint32_t every_u = 1,
               std::uint32_t every_v = 1) noexcept
        : u(grid_u), step_u(every_u), step_v(every_v), side(grid_u % 8 == 0 && grid_v % 8 == 0   ? 8u
                                                            : grid_u % 4 == 0 && grid_v % 4 == 0 ? 4u
                                                                                                 : 1u) {}

    /// The next `count` strata (at most 64, and 64 but for the last call) into column[] and row[],
    /// in the light's strata (the grid's scaled by the steps).
    void next(int count, std::uint32_t* column, std::uint32_t* row) noexcept {
        if (side == 1) {
            for (int k = 0; k < count; ++k) {
                column[k] = i * step_u, row[k] = j * step_v;
                if (++i == u) i = 0, ++j;
            }
            return;
        }
        for (int k = 0; k < count; k += int(side * side)) { // a block (side 8) or tile (side 4)
            const int end = std::min(count - k, int(side * side));
            for (int w = 0; w < end; ++w)
                column[k + w] = (i + within_u[w]) * step_u, row[k + w] = (j + within_v[w]) * step_v;
            if ((i += side) == u) i = 0, j += side;
        }
    }

    // The place of stratum w of a block in it: its tile (bits 4 and 5 of w), then within the tile.
    static constexpr std::uint32_t within_u[64] = {0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 4, 5, 6, 7, 4, 5,
                                                   6, 7, 4, 5, 6, 7, 4, 5, 6, 7, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3,
                                                   0, 1, 2, 3, 4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7};
    static constexpr std::uint32_t within_v[64] = {0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 0, 0, 0, 0, 1, 1,
                                                   1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 6, 6, 6, 6,
                                                   7, 7, 7, 7, 4, 4, 4, 4, 5, 5, 5, 5, 6, 6, 6, 6, 7, 7, 7, 7};
};

/// A chunk of an area light's samples at one shading point, shaded a register at a time: their
/// strata, points q, N·L (0 where unlit or past the last sample), Rf·V, highlight terms and
/// visibility (filled by the caller).
template <class T>
struct LightSampleChunk {
    static constexpr int size = 64; // samples per stream of shadow rays, a multiple of every register width
    static_assert(size % int(LaneRegister<T>::width) == 0, "whole registers");
    alignas(64) T u[size], v[size], qx[size], qy[size], qz[size], n_dot_l[size], cosine[size], spec[size],
        through[size];
    std::uint32_t column[size], row[size], index[size];

    /// Places the samples of the next m strata of `walk` (StrataWalk::next), padded to `padded`
    /// lanes: their points q, N·L and Rf·V.
    ISIN_DETAIL_INLINE void place(const RectLight<T>& light, const LitPoint<T>& p, const PatternSeeds& seeds,
                                  std::uint32_t nu, std::uint32_t nv, T inv_n, StrataWalk& walk, int m,
                                  int padded) noexcept {
        walk.next(m, column, row);
        for (int k = m; k < padded; ++k) column[k] = row[k] = 0; // past the last sample: any stratum
        for (int k = 0; k < padded; ++k) {
            index[k] = column[k] + row[k] * nu;
            sample_uv(seeds, nu, nv, column[k], row[k], index[k], inv_n, u[k], v[k]);
        }
        points(light, p, padded);
        for (int k = m; k < padded; ++k) n_dot_l[k] = T(0); // past the last sample
    }

    /// The points q = corner + u·edge_u + v·edge_v of samples 0 … padded − 1, their N·L and Rf·V.
    ISIN_DETAIL_INLINE void points(const RectLight<T>& light, const LitPoint<T>& p, int padded) noexcept {
        using V = typename LaneRegister<T>::V;
        using detail::lane_fma, detail::select;
        constexpr int W = int(LaneRegister<T>::width);
        const auto load = [](const T* a) { return load_lanes<T, V>(a); };
        for (int b = 0; b < padded; b += W) { // §7 a register of samples at a time, as light_sample places them
            const V su = load(u + b), sv = load(v + b);
            const V x = lane_fma(sv, V(light.edge_v.x), lane_fma(su, V(light.edge_u.x), V(light.corner.x)));
            const V y = lane_fma(sv, V(light.edge_v.y), lane_fma(su, V(light.edge_u.y), V(light.corner.y)));
            const V z = lane_fma(sv, V(light.edge_v.z), lane_fma(su, V(light.edge_u.z), V(light.corner.z)));
            store_lanes(x, qx + b), store_lanes(y, qy + b), store_lanes(z, qz + b);
            V lx = x - V(p.point.x), ly = y - V(p.point.y), lz = z - V(p.point.z);
            (void)lane_normalize<T>(lx, ly, lz);                            // §2: L = (q − P)/|q − P|, or 0
            const V c = lane_dot(V(p.N.x), V(p.N.y), V(p.N.z), lx, ly, lz); // §7: N·L
            // §7: Rf = d − 2(d·N)N with d = −L, and its cosine with V
            const auto [rx, ry, rz] = lane_reflect<T>(-lx, -ly, -lz, V(p.N.x), V(p.N.y), V(p.N.z));
            store_lanes(lane_dot(rx, ry, rz, V(p.V.x), V(p.V.y), V(p.V.z)), cosine + b);
            store_lanes(select(c > T(0), c, V(T(0))), n_dot_l + b); // §7: facing away → unlit
        }
    }

    /// Adds weight·(N·L) and weight·spec of samples 0 … padded − 1 to `diffuse` and `specular`, a
    /// register at a time (sample k in lane k mod the width).
    template <class V>
    ISIN_DETAIL_INLINE void add_weighted(const T* weight, V& diffuse, V& specular, int padded) const noexcept {
        constexpr int W = int(LaneRegister<T>::width);
        for (int b = 0; b < padded; b += W) {
            const V w = load_lanes<T, V>(weight + b);
            diffuse = lane_fma(w, load_lanes<T, V>(n_dot_l + b), diffuse);
            specular = lane_fma(w, load_lanes<T, V>(spec + b), specular);
        }
    }

    /// spec: each sample's cos^shininess where it can count (lit, and above min_cos), else 0;
    /// by squaring a register at a time where `power` (the whole shininess) is not 0.
    ISIN_DETAIL_INLINE void highlights(const LitPoint<T>& p, bool highlight, std::uint32_t power, T min_cos,
                                       int padded) noexcept {
        using V = typename LaneRegister<T>::V;
        using detail::select;
        constexpr int W = int(LaneRegister<T>::width);
        const auto load = [](const T* a) { return load_lanes<T, V>(a); };
        if (!highlight) {
            for (int k = 0; k < padded; ++k) spec[k] = T(0);
        } else if (power > 0u) { // §7: cos^shininess by squaring, a register at a time
            for (int b = 0; b < padded; b += W) {
                const V c = load(cosine + b);
                const auto counts = (load(n_dot_l + b) > T(0)) & (c > min_cos);
                store_lanes(select(counts, lane_power(select(counts, c, V(T(1))), power), V(T(0))), spec + b);
            }
        } else {
            for (int k = 0; k < padded; ++k) // §7: cos^shininess, where it can count
                spec[k] = through[k] > T(0) && n_dot_l[k] > T(0) && cosine[k] > min_cos
                              ? specular_power(cosine[k], p.shininess)
                              : T(0);
        }
    }
};

/// What the shadow rays to the probe samples found: the strata in even columns (and even rows where
/// nv > 1), a pu × pv grid, kept by their place in that grid (row by row) up to `kept` (every probe
/// up to 1,024 samples), −1 where not traced; a penumbra's pass reuses them.
template <class T>
struct ProbeRecord {
    static constexpr std::uint32_t kept = 256;
    std::uint32_t pu = 0, pv = 0, nv = 0;
    bool traced = false;
    T seen[kept];
    /// A walk over the probes.
    [[nodiscard]] StrataWalk walk() const noexcept { return {pu, pv, 2u, nv > 1 ? 2u : 1u}; }
    /// Forgets every probe (none traced yet) of nu × nv strata; returns how many there are.
    std::uint32_t start(std::uint32_t strata_u, std::uint32_t strata_v) noexcept {
        pu = (strata_u + 1) / 2, pv = strata_v > 1 ? (strata_v + 1) / 2 : 1u, nv = strata_v;
        traced = true;
        for (std::uint32_t o = 0; o < std::min(pu * pv, kept); ++o) seen[o] = T(-1);
        return pu * pv;
    }
    /// Where stratum (i, j) is a probe kept, its place; else `kept`.
    [[nodiscard]] std::uint32_t place(std::uint32_t i, std::uint32_t j) const noexcept {
        if (nv <= 1) j = 0;
        return ((i | j) & 1u) == 0u ? std::min(kept, i / 2 + j / 2 * pu) : kept;
    }
    void record(std::uint32_t i, std::uint32_t j, T found) noexcept {
        if (const std::uint32_t o = place(i, j); o < kept) seen[o] = found;
    }
    /// What the ray to stratum (i, j) found where it is a probe traced, else −1.
    [[nodiscard]] T found(std::uint32_t i, std::uint32_t j) const noexcept {
        const std::uint32_t o = traced ? place(i, j) : kept;
        return o < kept ? seen[o] : T(-1);
    }
};

/// §7: whether corner c of the light lies above p's horizon (N·L > 0 towards it).
template <class T>
[[nodiscard]] inline bool above_horizon(const RectLight<T>& light, const LitPoint<T>& p, int c) noexcept {
    return dot(p.N, light_corner(light, c) - p.point) > T(0); // §7: N·L > 0
}

/// Gauss–Legendre nodes and weights on [0, 1] of orders 3 and 4 (Abramowitz and Stegun 25.4.29):
/// exact for polynomials of degree 2·order − 1 in u and in v.
template <class T>
struct GaussLegendre {
    static constexpr T node3[3] = {T(0.1127016653792583), T(0.5), T(0.8872983346207417)};
    static constexpr T weight3[3] = {T(5) / T(18), T(8) / T(18), T(5) / T(18)};
    static constexpr T node4[4] = {T(0.06943184420297371), T(0.33000947820757187), T(0.6699905217924281),
                                   T(0.9305681557970263)};
    static constexpr T weight4[4] = {T(0.17392742256872692), T(0.3260725774312731), T(0.3260725774312731),
                                     T(0.17392742256872692)};
};

/// The order of the Gauss–Legendre rule that gives the unshadowed mean of a RectLight's Phong
/// term at p to about 10⁻⁴ of its scale (against a 400 × 400 midpoint rule, 2,500 random lights and
/// points), or 0 where the term is not smooth enough over the rectangle: a corner below p's
/// horizon (N·L's kink), a light larger than half its distance (r/d > ½, r the radius of the
/// sphere about the rectangle), or a highlight that can count and varies over the light
/// (r/d·√shininess above 1 for order 3, 1.5 for order 4, or shininess below 4: cosⁿ's kink at 0).
template <class T>
[[nodiscard]] inline int smooth_order(const RectLight<T>& light, const LitPoint<T>& p, bool highlight, T min_cos,
                                      int samples) noexcept {
    for (int c = 0; c < 4; ++c)
        if (!above_horizon(light, p, c)) return 0; // §7: N·L > 0 over the whole light
    const Vertex<T> centre = light.corner + T(0.5) * (light.edge_u + light.edge_v);
    const T r = T(0.5) * std::max(length(light.edge_u + light.edge_v), length(light.edge_u - light.edge_v));
    const Vertex<T> to = centre - p.point;
    const T d = length(to);
    if (!(r <= T(0.5) * d)) return 0;
    const int order = samples >= 32 ? 4 : 3;
    if (!highlight) return order;
    // §7: Rf·V = L·R with R = 2(N·V)N − V; over the cone about the light (half-angle α, sin α = r/d),
    // L·R ≤ cos(β − α), β the angle from R to the centre: below min_cos no sample's highlight counts.
    const Vertex<T> R = T(2) * dot(p.N, p.V) * p.N - p.V;
    const T sin_a = r / d, cos_a = std::sqrt(T(1) - sin_a * sin_a);
    const T cos_b = dot(R, to) / d, sin_b = std::sqrt(std::max(T(0), T(1) - cos_b * cos_b));
    if (cos_b < cos_a && cos_b * cos_a + sin_b * sin_a < min_cos) return order;
    const T y = sin_a * std::sqrt(p.shininess);
    return p.shininess >= T(4) && y <= (order == 4 ? T(1.5) : T(1)) ? order : 0;
}

/// §7 for an area light from its sums over samples (or quadrature nodes): kd·Σ(N·L)·object +
/// ks·Σ(highlight)·highlight colour, times the light's colour and `scale` (1/n, or a weight).
template <class T>
[[nodiscard]] inline Color<T> light_colour(const LitPoint<T>& p, const RectLight<T>& light, T diffuse, T specular,
                                           T scale) noexcept {
    return (p.kd * diffuse * p.object + p.ks * specular * p.highlight) * light.color *
           scale; // §7: kd·diffuse + ks·specular
}

/// §9: what the shadow rays to the four corners found (`seen`: 1 − blocked, or transmittance)
/// among the corners above p's horizon, −1 when none is (§7: below it a corner adds nothing, and
/// its ray meets p's own surface: it does not vote); `agree` becomes false when they differ.
template <class T>
[[nodiscard]] T corner_vote(const RectLight<T>& light, const LitPoint<T>& p, const T* seen, bool& agree) noexcept {
    T corner = T(-1);
    for (int c = 0; c < 4; ++c) {
        if (!above_horizon(light, p, c)) continue;
        if (corner < T(0)) corner = seen[c];
        agree = agree && seen[c] == corner;
    }
    return corner;
}

/// The unshadowed sums of N·L and of the highlight over `light` seen from p by the order × order
/// Gauss–Legendre rule (weights summing to 1), where smooth_order says it holds; in batch's lanes.
template <class T>
void quadrature_sums(LightSampleChunk<T>& batch, const RectLight<T>& light, const LitPoint<T>& p, int order,
                     bool highlight, std::uint32_t power, T min_cos, T& diffuse, T& specular) noexcept {
    using V = typename LaneRegister<T>::V;
    constexpr int W = int(LaneRegister<T>::width);
    const T* node = order == 4 ? GaussLegendre<T>::node4 : GaussLegendre<T>::node3;
    const T* weight = order == 4 ? GaussLegendre<T>::weight4 : GaussLegendre<T>::weight3;
    alignas(64) T w[LightSampleChunk<T>::size];
    const int m = order * order, padded = (m + W - 1) / W * W;
    for (int b = 0; b < order; ++b)
        for (int a = 0; a < order; ++a)
            batch.u[a + b * order] = node[a], batch.v[a + b * order] = node[b],
                            w[a + b * order] = weight[a] * weight[b];
    for (int k = m; k < padded; ++k) batch.u[k] = batch.v[k] = T(0.5), w[k] = T(0);
    batch.points(light, p, padded);
    for (int k = 0; k < padded; ++k) batch.through[k] = T(1);
    batch.highlights(p, highlight, power, min_cos, padded);
    V diffuse_sum = V(T(0)), specular_sum = V(T(0));
    batch.add_weighted(w, diffuse_sum, specular_sum, padded);
    diffuse = lane_total<T>(diffuse_sum), specular = lane_total<T>(specular_sum);
}

} // namespace detail

/// The mean over the rectangle of `light` of a PointLight's Phong term (§7) at p, shadows
/// included (§9), estimated from s.samples stratified samples seeded by `seed`: the colour it adds
/// to p's local colour. Shadow rays go to `scene` as a stream (occluded, or transmittance unless
/// s.opaque); `shadow_rays` counts them. With s.adaptive (and 8 samples or more) the shadow rays
/// to the rectangle's four corners are traced first. From 64 samples on, where all of them see the
/// light and nothing may meet the shaft from p to it (Scene::shaft_clear), every sample sees it:
/// exact, without more rays. Elsewhere (and from 64 samples on only there) the shadow rays to the
/// probe samples (the samples in even columns and rows of the strata, a quarter) follow; when all
/// agree the other samples take their value without rays (as POV-Ray's adaptive area lights):
/// exact outside penumbrae, but an occluder that hides none or all of the corners and probes and
/// not the rest from p is missed (the probes, spread over the rectangle, make that rarer as
/// samples grow; below 64 samples the corners alone decide).
/// Corners below p's horizon do not vote (their rays meet p's own surface; they add nothing).
/// Where they agree that the whole light is seen and its term is smooth over it
/// (detail::smooth_order), the mean comes from a 3 × 3 or 4 × 4 Gauss–Legendre rule, not the samples.
/// `corners`, where given, holds what the shadow rays from p.from to the four corners found
/// (1 − blocked, or their transmittance): traced by the caller with other points' (a stream).
template <class T, class SceneT>
[[nodiscard]] Color<T> rect_light_term(const SceneT& scene, const RectLight<T>& light, const LitPoint<T>& p,
                                       std::uint64_t seed, const LightSampling& s, std::uint64_t& shadow_rays,
                                       const T* corners = nullptr) {
    using V = typename detail::LaneRegister<T>::V;
    constexpr int W = int(detail::LaneRegister<T>::width);
    const LightStrata strata = light_strata(s.samples, length(light.edge_u), length(light.edge_v));
    const int n = strata.nu * strata.nv;
    const auto nu = std::uint32_t(strata.nu), nv = std::uint32_t(strata.nv);
    const T inv_n = T(1) / T(n);
    const detail::PatternSeeds seeds = detail::pattern_seeds(seed);
    const T min_cos = detail::least_highlight_cosine(p.shininess);
    const std::uint32_t power = detail::integral_power(p.shininess); // 0: std::pow, one sample at a time
    const bool highlight = p.ks != T(0); // without, the highlight sum is not needed (0·sum adds nothing)
    constexpr int chunk = detail::LightSampleChunk<T>::size;
    detail::LightSampleChunk<T> batch;
    constexpr auto room = std::size_t(chunk);
    alignas(64) T one[room], seen[room];
    Ray<T> rays[room];
    int ray_of[room]; // each shadow ray's sample
    for (T& t : one) t = T(1);
    V diffuse_sum = V(T(0)), specular_sum = V(T(0));
    detail::ProbeRecord<T> probes; // traced from 64 samples on
    // Shadow ray r goes from p towards sample k of the chunk.
    const auto aim = [&](int k, int& r) {
        ray_of[r] = k, rays[r++] = {p.from, Vertex<T>{batch.qx[k], batch.qy[k], batch.qz[k]} - p.from};
    };
    // Adds every sample's term, with its shadow ray or, where `assumed` ≥ 0, that visibility.
    const auto shade = [&](T assumed) {
        detail::StrataWalk walk(nu, nv);
        for (int k0 = 0; k0 < n; k0 += chunk) {
            const int m = std::min(chunk, n - k0), padded = (m + W - 1) / W * W;
            batch.place(light, p, seeds, nu, nv, inv_n, walk, m, padded);
            if (assumed >= T(0) || !s.shadows) {
                const T visible = s.shadows ? assumed : T(1);
                for (int k = 0; k < padded; ++k) batch.through[k] = visible;
            } else { // §9: a ray towards each lit sample (but probes already traced); anything nearer than it shadows
                int r = 0;
                for (int k = 0; k < padded; ++k) {
                    batch.through[k] = T(0);
                    if (!(batch.n_dot_l[k] > T(0))) continue;
                    const T found = probes.found(batch.column[k], batch.row[k]); // −1: not traced
                    if (found >= T(0))
                        batch.through[k] = found;
                    else
                        aim(k, r);
                }
                shadow_rays += std::uint64_t(r);
                detail::shadow_visibility(scene, rays, std::size_t(r), s.opaque, one, seen);
                for (int t = 0; t < r; ++t) batch.through[ray_of[t]] = seen[t];
            }
            batch.highlights(p, highlight, power, min_cos, padded);
            batch.add_weighted(batch.through, diffuse_sum, specular_sum, padded); // §9: the lit samples' terms
        }
    };
    // Below this many samples the probes cost more than the rays they save (one small stream a point).
    constexpr int probe_from = 64;
    if (!corners_first(LightSampling{n, s.adaptive, s.shadows, s.opaque})) {
        shade(T(-1));
    } else {
        // §9: shadow rays to the four corners first; from 64 samples, where they see the light, a clear shaft
        // (exact) or else the probes (a quarter) must agree; then the rest take their value.
        if (corners) {
            for (int c = 0; c < 4; ++c) seen[c] = corners[c];
        } else {
            for (int c = 0; c < 4; ++c) rays[c] = {p.from, light_corner(light, c) - p.from};
            shadow_rays += 4u;
            detail::shadow_visibility(scene, rays, 4u, s.opaque, one, seen);
        }
        bool agree = true;
        const T corner = detail::corner_vote(light, p, seen, agree);
        if (corner < T(0)) return {T(0), T(0), T(0)}; // §7: the whole light below p's horizon
        if (agree && n >= probe_from && !(corner == T(1) && scene.shaft_clear(p.from, light))) {
            // §9: whether the shadow rays to the probe samples all find `expected`; only the probes are placed.
            const auto probe_agrees = [&](T expected) {
                const std::uint32_t count = probes.start(nu, nv);
                detail::StrataWalk walk = probes.walk();
                for (std::uint32_t t0 = 0; t0 < count; t0 += std::uint32_t(chunk)) {
                    const int m = int(std::min(count - t0, std::uint32_t(chunk)));
                    batch.place(light, p, seeds, nu, nv, inv_n, walk, m, (m + W - 1) / W * W);
                    int r = 0;
                    for (int k = 0; k < m; ++k)
                        if (batch.n_dot_l[k] > T(0)) aim(k, r);
                    shadow_rays += std::uint64_t(r);
                    detail::shadow_visibility(scene, rays, std::size_t(r), s.opaque, one, seen);
                    bool same = true;
                    for (int t = 0; t < r; ++t) {
                        probes.record(batch.column[ray_of[t]], batch.row[ray_of[t]], seen[t]);
                        same = same && seen[t] == expected;
                    }
                    if (!same) return false;
                }
                return true;
            };
            agree = probe_agrees(corner);
        }
        if (agree && corner == T(0)) return {T(0), T(0), T(0)}; // umbra: every sample shadowed
        if (agree)
            if (const int order = detail::smooth_order(light, p, highlight, min_cos, n)) {
                T diffuse = T(0), specular = T(0);
                detail::quadrature_sums(batch, light, p, order, highlight, power, min_cos, diffuse, specular);
                return detail::light_colour(p, light, diffuse, specular, corner); // the mean, `corner` times
            }
        shade(agree ? corner : T(-1));
    }
    const T diffuse = detail::lane_total<T>(diffuse_sum), specular = detail::lane_total<T>(specular_sum);
    return detail::light_colour(p, light, diffuse, specular, inv_n); // averaged over the samples
}

/// Points that rect_light_terms_together shades at once: one packet's rays to a stratum.
inline constexpr int together_points = 16;
/// How far apart (in strata's widths) the points shaded together may lie: 2 lost nothing on the
/// knot of benchmarks/area_lights at 80 × 45 and gained as much as 1 and 4 at 800 × 450.
inline constexpr float together_spread = 2.0f;

/// rect_light_term for up to together_points points whose every sample gets its shadow ray (no
/// corners first, or corners that disagree): the same samples, sums and bits, but each sample's
/// rays from all the points traced together, so that a packet holds the rays to one stratum from
/// neighbouring points (a beam far narrower than one point's 4 × 4 strata where the points lie
/// within a few strata's width of each other: neighbouring pixels of a large picture).
template <class T, class SceneT>
void rect_light_terms_together(const SceneT& scene, const RectLight<T>& light, const LitPoint<T>* p,
                               const std::uint64_t* seed, int count, const LightSampling& s, std::uint64_t& shadow_rays,
                               Color<T>* out) {
    using V = typename detail::LaneRegister<T>::V;
    constexpr int W = int(detail::LaneRegister<T>::width), G = together_points;
    constexpr int chunk = detail::LightSampleChunk<T>::size;
    count = std::clamp(count, 0, G);
    const LightStrata strata = light_strata(s.samples, length(light.edge_u), length(light.edge_v));
    const int n = strata.nu * strata.nv;
    const auto nu = std::uint32_t(strata.nu), nv = std::uint32_t(strata.nv);
    const T inv_n = T(1) / T(n);
    constexpr auto points = std::size_t(G), lanes = std::size_t(W), room = points * std::size_t(chunk);
    detail::LightSampleChunk<T> batch[points];
    detail::PatternSeeds seeds[points];
    T min_cos[points];
    std::uint32_t power[points];
    alignas(64) T diffuse[points][lanes], specular[points][lanes]; // each point's sums (rect_light_term's registers)
    for (int j = 0; j < count; ++j) {
        seeds[j] = detail::pattern_seeds(seed[j]);
        min_cos[j] = detail::least_highlight_cosine(p[j].shininess);
        power[j] = detail::integral_power(p[j].shininess);
        for (int w = 0; w < W; ++w) diffuse[j][w] = specular[j][w] = T(0);
    }
    Ray<T> rays[room];
    alignas(64) T one[room], seen[room];
    int ray_of[room]; // each ray's point and sample: j·chunk + k
    for (T& t : one) t = T(1);
    detail::StrataWalk walk(nu, nv);
    for (int k0 = 0; k0 < n; k0 += chunk) {
        const int m = std::min(chunk, n - k0), padded = (m + W - 1) / W * W;
        const detail::StrataWalk start = walk;
        for (int j = 0; j < count; ++j) {
            walk = start;
            batch[j].place(light, p[j], seeds[j], nu, nv, inv_n, walk, m, padded);
        }
        int r = 0;
        for (int k = 0; k < padded; ++k) // §9: sample k's rays from every point, one after the other
            for (int j = 0; j < count; ++j) {
                detail::LightSampleChunk<T>& b = batch[j];
                b.through[k] = T(0);
                if (!(b.n_dot_l[k] > T(0))) continue;
                ray_of[r] = j * chunk + k, rays[r++] = {p[j].from, Vertex<T>{b.qx[k], b.qy[k], b.qz[k]} - p[j].from};
            }
        shadow_rays += std::uint64_t(r);
        detail::shadow_visibility(scene, rays, std::size_t(r), s.opaque, one, seen);
        for (int t = 0; t < r; ++t) batch[ray_of[t] / chunk].through[ray_of[t] % chunk] = seen[t];
        for (int j = 0; j < count; ++j) {
            detail::LightSampleChunk<T>& b = batch[j];
            b.highlights(p[j], p[j].ks != T(0), power[j], min_cos[j], padded);
            V d = detail::load_lanes<T, V>(diffuse[j]), sp = detail::load_lanes<T, V>(specular[j]);
            b.add_weighted(b.through, d, sp, padded);
            detail::store_lanes(d, diffuse[j]), detail::store_lanes(sp, specular[j]);
        }
    }
    for (int j = 0; j < count; ++j)
        out[j] = detail::light_colour(p[j], light, detail::lane_total<T>(detail::load_lanes<T, V>(diffuse[j])),
                                      detail::lane_total<T>(detail::load_lanes<T, V>(specular[j])), inv_n);
}

} // namespace isin
