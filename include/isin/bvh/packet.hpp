#pragma once
/// isin — tracing up to 16 coherent rays through a BvhTree together, with the caller's leaf test
/// (the packet form of traverse.hpp). Each node is tested once for the whole packet, by interval
/// arithmetic over the packet's origins and inverse directions (Boulos et al. 2007, "Packet-based
/// Whitted and distribution ray tracing"; Wald et al. 2007, "Ray tracing deformable scenes using
/// dynamic bounding volume hierarchies"): one 8-lane test like a single ray's, shared by 16 rays.
/// The interval test is conservative, so the packet visits every node any of its rays enters;
/// each child it lets in then takes the rays' own slab tests (traverse.hpp's fast form, lane by
/// lane on the rays), so that a child no ray enters is dropped (shadow rays from a patch of
/// surface spread their origins, and the interval test alone lets in many such children). Packets
/// whose rays share one origin (a pinhole camera's) take the rays' tests at leaves only.
/// Two packets that agree (camera rays of adjacent 4×4 tiles) may be walked together under one
/// interval test over both (walk_packets): one walk's node steps serve 32 rays.
/// Packets need AVX2 + FMA and float (ISIN_DETAIL_PACKETS); callers fall back to single rays
/// elsewhere, and for rays that are not coherent (make_packet says which).
#include <cstddef>
#include <cstdint>
#include <limits>

#include "../simd/avx512.hpp"
#include "traverse.hpp"
#include "tree.hpp"

#if defined(ISIN_DETAIL_SLABS_AVX) && defined(__AVX2__) && defined(__FMA__)
#define ISIN_DETAIL_PACKETS 1

namespace isin {
namespace detail {

/// The terms of a packet's interval test (packet_slab), for the rays of one packet or of two
/// traced together (walk_packets).
struct PacketBounds {
    // Per axis: the range of inv (inv_far), and each end times the origin that gives the
    // earliest entry (latest exit), less (plus) an absolute allowance for the rounding of both
    // the rays' own slab distances and the interval's.
    float inv_lo[3], inv_hi[3], far_lo[3], far_hi[3], entry_lo[3], entry_hi[3], exit_lo[3], exit_hi[3];
    std::size_t near_plane[3], far_plane[3]; // shared by every ray: one octant
    /// Every ray starts at the same point (a pinhole camera's rays): the interval test is then
    /// a frustum's, and the rays' own tests run only at leaves (walk_packets).
    bool one_origin = false;
    /// The least and greatest of the rays' origins' coordinates (0-2) and inverse directions'
    /// components (3-5).
    float lo[6], hi[6];
};

/// The slab constants of up to 16 rays (lanes = rays, SlabRay's fast form) and the intervals
/// the packet's node test works with.
struct alignas(64) RayPacket : PacketBounds {
    static constexpr int size = 16;
    alignas(64) float org[3][size], inv[3][size], org_inv_near[3][size], inv_far[3][size], org_inv_far[3][size];
    /// Per ray: hits count below this (the leaf lowers it); −1 for lanes not (or no longer) traced.
    float t_far[size];
    unsigned lanes = 0; // rays in the packet
    /// make_packet left the rays out because their origins lie too far apart
    /// (packet_origin_spread), though their directions agree.
    bool wide = false;
};

/// The cosine of the widest angle between the rays of a packet: beyond it rays go one by one
/// (the interval test of a packet spread wider lets in many nodes that few of its rays enter).
inline constexpr float packet_cone_cos = 0.995f;
/// The fewest rays a packet is worth: fewer go one by one (a packet's node steps cost about
/// what four rays' do).
inline constexpr int packet_min_rays = 4;
/// How far apart, in leaf sizes (BvhTree::leaf_scale), the origins of a packet's rays may lie
/// along any axis: a wider packet is a beam that its interval test and its rays' tests follow
/// through many nodes and leaves that few of its rays enter (the shadow rays of a random soup's
/// hits); coherent packets' origins lie well within 8 leaf sizes, so the limit spares them.
inline constexpr float packet_origin_spread = 8.0f;
/// A subtree that this many rays of a packet or fewer enter is traced by each of them alone
/// (the single-ray walk from its root): the packet's steps cost more than one ray's, and from 2
/// rays the coherent meshes lost more than the incoherent ones gained (docs/ideas.md).
inline constexpr int packet_single_rays = 1;

/// Rays [first, first + n) of an array, lane by lane into c (origin x, y, z, direction x, y,
/// z); lanes n..15 get ray `first` again (make_packet leaves them out).
inline void load_packet_rays(const Ray<float>* rays, std::size_t first, int n,
                             float (&c)[6][RayPacket::size]) noexcept {
    static_assert(sizeof(Ray<float>) == 6 * sizeof(float), "a Ray<float> is six floats");
#if defined(__AVX512F__)
    if (n == RayPacket::size) {
        // Sixteen rays are 48 pairs of floats: (ox, oy), (oz, dx), (dy, dz) of ray k are pairs
        // 3k, 3k + 1, 3k + 2. Each half of the packet (three registers of 8 pairs) is split into
        // its three pair kinds, then the halves' pairs into the six components.
        const double* d = reinterpret_cast<const double*>(rays + first);
        __m512d kind[2][3];
        for (int h = 0; h < 2; ++h) {
            const __m512d a0 = _mm512_loadu_pd(d + 24 * h), a1 = _mm512_loadu_pd(d + 24 * h + 8),
                          a2 = _mm512_loadu_pd(d + 24 * h + 16);
            kind[h][0] =
                _mm512_permutex2var_pd(_mm512_permutex2var_pd(a0, _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0), a1),
                                       _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13), a2);
            kind[h][1] =
                _mm512_permutex2var_pd(_mm512_permutex2var_pd(a0, _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0), a1),
                                       _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14), a2);
            kind[h][2] =
                _mm512_permutex2var_pd(_mm512_permutex2var_pd(a0, _mm512_setr_epi64(2, 5, 8, 11, 14, 0, 0, 0), a1),
                                       _mm512_setr_epi64(0, 1, 2, 3, 4, 9, 12, 15), a2);
        }
        const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
        const __m512i odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
        for (int k = 0; k < 3; ++k) {
            const __m512 lo = _mm512_castpd_ps(kind[0][k]), hi = _mm512_castpd_ps(kind[1][k]);
            _mm512_storeu_ps(c[2 * k], _mm512_permutex2var_ps(lo, even, hi));
            _mm512_storeu_ps(c[2 * k + 1], _mm512_permutex2var_ps(lo, odd, hi));
        }
        return;
    }
#endif
    for (int k = 0; k < RayPacket::size; ++k) {
        const Ray<float>& r = rays[first + std::size_t(k < n ? k : 0)];
        c[0][k] = r.origin.x, c[1][k] = r.origin.y, c[2][k] = r.origin.z;
        c[3][k] = r.direction.x, c[4][k] = r.direction.y, c[5][k] = r.direction.z;
    }
}
/// The same from six arrays.
inline void load_packet_rays(const RaysSoA<float>& rays, std::size_t first, int n,
                             float (&c)[6][RayPacket::size]) noexcept {
    const float* const from[6] = {rays.ox, rays.oy, rays.oz, rays.dx, rays.dy, rays.dz};
    for (int a = 0; a < 6; ++a) {
        if (n == RayPacket::size) {
            _mm256_storeu_ps(c[a], _mm256_loadu_ps(from[a] + first));
            _mm256_storeu_ps(c[a] + 8, _mm256_loadu_ps(from[a] + first + 8));
        } else {
            for (int k = 0; k < RayPacket::size; ++k) c[a][k] = from[a][first + std::size_t(k < n ? k : 0)];
        }
    }
}

// The least and the greatest of 16 lanes (two registers).
inline float lanes_min(__m256 a, __m256 b) noexcept {
    const __m256 m = _mm256_min_ps(a, b);
    __m128 h = _mm_min_ps(_mm256_castps256_ps128(m), _mm256_extractf128_ps(m, 1));
    h = _mm_min_ps(h, _mm_movehl_ps(h, h));
    return _mm_cvtss_f32(_mm_min_ss(h, _mm_shuffle_ps(h, h, 1)));
}
inline float lanes_max(__m256 a, __m256 b) noexcept {
    const __m256 m = _mm256_max_ps(a, b);
    __m128 h = _mm_max_ps(_mm256_castps256_ps128(m), _mm256_extractf128_ps(m, 1));
    h = _mm_max_ps(h, _mm_movehl_ps(h, h));
    return _mm_cvtss_f32(_mm_max_ss(h, _mm_shuffle_ps(h, h, 1)));
}

/// The lanes of `c` (16 rays, as load_packet_rays fills it) whose origin and direction are
/// finite and whose direction is not zero (prepare_slab's `ok`), and the sign bits of the
/// directions' components (octant[axis], bit k for ray k).
inline unsigned rays_usable(const float (&c)[6][RayPacket::size], unsigned (&octant)[3]) noexcept {
#if defined(__AVX512F__)
    { // the 16 rays in one register
        const __m512 zero = _mm512_setzero_ps();
        __mmask16 ok = 0xffff;
        __m512 d_max = zero;
        for (int a = 0; a < 3; ++a) {
            const __m512 o = _mm512_loadu_ps(c[a]), d = _mm512_loadu_ps(c[3 + a]);
            ok &= _mm512_cmp_ps_mask(_mm512_add_ps(_mm512_sub_ps(o, o), _mm512_sub_ps(d, d)), zero, _CMP_EQ_OQ);
            d_max = max16(d_max, _mm512_abs_ps(d));
            octant[a] = _mm512_cmplt_epi32_mask(_mm512_castps_si512(d), _mm512_setzero_si512()); // sign bits
        }
        return ok & _mm512_cmp_ps_mask(d_max, zero, _CMP_GT_OQ);
    }
#endif
    const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)), zero = _mm256_setzero_ps();
    unsigned usable = 0;
    octant[0] = octant[1] = octant[2] = 0;
    for (int g = 0; g < RayPacket::size; g += 8) {
        __m256 ok = _mm256_castsi256_ps(_mm256_set1_epi32(-1)), d_max = zero;
        for (int a = 0; a < 3; ++a) {
            const __m256 o = _mm256_load_ps(c[a] + g), d = _mm256_load_ps(c[3 + a] + g);
            const __m256 finite =
                _mm256_cmp_ps(_mm256_add_ps(_mm256_sub_ps(o, o), _mm256_sub_ps(d, d)), zero, _CMP_EQ_OQ);
            ok = _mm256_and_ps(ok, finite);
            d_max = _mm256_max_ps(d_max, _mm256_and_ps(d, magnitude));
            octant[a] |= unsigned(_mm256_movemask_ps(d)) << g;
        }
        ok = _mm256_and_ps(ok, _mm256_cmp_ps(d_max, zero, _CMP_GT_OQ));
        usable |= unsigned(_mm256_movemask_ps(ok)) << g;
    }
    return usable;
}

/// prepare_slab's fast-form terms of the 16 rays of `c` (in one AVX-512 register where there is
/// one, else eight lanes at a time), by its rules
/// (so as conservative; o·inv's allowance is added in one FMA): origin, inv, inv_far and the
/// raised and lowered o·inv. Returns the lanes whose products cannot overflow (prepare_slab's
/// `robust` is false for them).
inline unsigned slab_lanes(const float (&c)[6][RayPacket::size], float bound, float (&org)[3][RayPacket::size],
                           float (&inv)[3][RayPacket::size], float (&inv_far)[3][RayPacket::size],
                           float (&org_inv_near)[3][RayPacket::size],
                           float (&org_inv_far)[3][RayPacket::size]) noexcept {
    constexpr float widen = slab_widen<float>, allowance = slab_allowance<float>;
#if defined(__AVX512F__)
    { // the 16 rays in one register
        const __m512 no_overflow = _mm512_set1_ps(std::numeric_limits<float>::max() / 8.0f);
        __mmask16 ok = 0xffff;
        for (int a = 0; a < 3; ++a) {
            const __m512 o = _mm512_loadu_ps(c[a]), d = _mm512_loadu_ps(c[3 + a]);
            const __m512 i = _mm512_div_ps(_mm512_set1_ps(1.0f), d), i_far = _mm512_mul_ps(i, _mm512_set1_ps(widen));
            // max(bound, |o|)·|inv_far| below max/8 (false for an infinite inv)
            ok &=
                _mm512_cmp_ps_mask(_mm512_mul_ps(max16(_mm512_abs_ps(o), _mm512_set1_ps(bound)), _mm512_abs_ps(i_far)),
                                   no_overflow, _CMP_LT_OQ);
            const __m512 o_i = _mm512_mul_ps(o, i), o_i_far = _mm512_mul_ps(o, i_far);
            _mm512_store_ps(org[a], o);
            _mm512_store_ps(inv[a], i);
            _mm512_store_ps(inv_far[a], i_far);
            _mm512_store_ps(org_inv_near[a], _mm512_fmadd_ps(_mm512_set1_ps(allowance), _mm512_abs_ps(o_i), o_i));
            _mm512_store_ps(org_inv_far[a],
                            _mm512_fnmadd_ps(_mm512_set1_ps(allowance), _mm512_abs_ps(o_i_far), o_i_far));
        }
        return ok;
    }
#endif
    const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 no_overflow = _mm256_set1_ps(std::numeric_limits<float>::max() / 8.0f);
    unsigned fast = 0;
    for (int g = 0; g < RayPacket::size; g += 8) {
        __m256 ok = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
        for (int a = 0; a < 3; ++a) {
            const __m256 o = _mm256_load_ps(c[a] + g), d = _mm256_load_ps(c[3 + a] + g);
            const __m256 i = _mm256_div_ps(_mm256_set1_ps(1.0f), d), i_far = _mm256_mul_ps(i, _mm256_set1_ps(widen));
            // max(bound, |o|)·|inv_far| below max/8 (false for an infinite inv)
            ok = _mm256_and_ps(
                ok, _mm256_cmp_ps(_mm256_mul_ps(_mm256_max_ps(_mm256_and_ps(o, magnitude), _mm256_set1_ps(bound)),
                                                _mm256_and_ps(i_far, magnitude)),
                                  no_overflow, _CMP_LT_OQ));
            const __m256 o_i = _mm256_mul_ps(o, i), o_i_far = _mm256_mul_ps(o, i_far);
            _mm256_store_ps(org[a] + g, o);
            _mm256_store_ps(inv[a] + g, i);
            _mm256_store_ps(inv_far[a] + g, i_far);
            _mm256_store_ps(org_inv_near[a] + g,
                            _mm256_fmadd_ps(_mm256_set1_ps(allowance), _mm256_and_ps(o_i, magnitude), o_i));
            _mm256_store_ps(org_inv_far[a] + g,
                            _mm256_fnmadd_ps(_mm256_set1_ps(allowance), _mm256_and_ps(o_i_far, magnitude), o_i_far));
        }
        fast |= unsigned(_mm256_movemask_ps(ok)) << g;
    }
    return fast;
}

/// The SlabRay of each of 16 rays, made at once (rays_usable, slab_lanes): for the rays of a
/// stream that no packet takes, traced one by one or two at a time.
struct alignas(64) SlabLanes {
    float org[3][RayPacket::size], inv[3][RayPacket::size], inv_far[3][RayPacket::size],
        org_inv_near[3][RayPacket::size], org_inv_far[3][RayPacket::size];
    unsigned negative[3]; // the directions' sign bits
    unsigned usable, fast;
    SlabLanes(const float (&c)[6][RayPacket::size], float bound) noexcept
        : usable(rays_usable(c, negative)), fast(slab_lanes(c, bound, org, inv, inv_far, org_inv_near, org_inv_far)) {}
    /// Ray k's terms, as prepare_slab gives them (but for o·inv's one rounding fewer).
    SlabRay<float> at(int k) const noexcept {
        SlabRay<float> r;
        for (int a = 0; a < 3; ++a) {
            r.org[a] = org[a][k], r.inv[a] = inv[a][k], r.inv_far[a] = inv_far[a][k];
            r.org_inv_near[a] = org_inv_near[a][k], r.org_inv_far[a] = org_inv_far[a][k];
            slab_planes<float>(a, (negative[a] >> k) & 1u, r.near_plane[a], r.far_plane[a]);
        }
        r.ok = (usable >> k) & 1u;
        r.robust = !((fast >> k) & 1u);
        return r;
    }
};

// make_packet's parts, each for the 16 rays in one AVX-512 register where there is one, else
// eight lanes at a time.

// t_far = lane < n ? t_max : −1; returns the lanes with t_far > 0.
inline unsigned packet_t_far_from(const float (&t_max)[RayPacket::size], int n,
                                  float (&t_far)[RayPacket::size]) noexcept {
#if defined(__AVX512F__)
    const __m512 t = _mm512_mask_blend_ps(__mmask16((1u << n) - 1u), _mm512_set1_ps(-1.0f), _mm512_loadu_ps(t_max));
    _mm512_store_ps(t_far, t);
    return _mm512_cmp_ps_mask(t, _mm512_setzero_ps(), _CMP_GT_OQ);
#else
    unsigned reach = 0;
    for (int g = 0; g < RayPacket::size; g += 8) {
        const __m256 within = _mm256_castsi256_ps(
            _mm256_cmpgt_epi32(_mm256_set1_epi32(n - g), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
        const __m256 t = _mm256_blendv_ps(_mm256_set1_ps(-1.0f), _mm256_loadu_ps(t_max + g), within);
        _mm256_store_ps(t_far + g, t);
        reach |= unsigned(_mm256_movemask_ps(_mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_GT_OQ))) << g;
    }
    return reach;
#endif
}

// The lanes of `c` whose direction d lies within packet_cone_cos of d0, the direction of lane
// `first` of `c0`: d·d0 ≥ cos·|d|·|d0|. make_packet tests a chunk's rays against its first ray
// (c0 is c: `same`); packets_share, one packet's first ray against the other's (one rule for
// both).
template <bool same>
ISIN_DETAIL_INLINE unsigned packet_cone(const float (&c)[6][RayPacket::size], const float (&c0)[6][RayPacket::size],
                                        int first) noexcept {
#if defined(__AVX512F__)
    // d0 and |d0| from their lanes (permutes), not as scalars loaded from `c0` with a scalar
    // square root, which would wait for a store and a load through memory.
    const __m512i at = _mm512_set1_epi32(first);
    const auto length = [](__m512 x, __m512 y, __m512 z) {
        return sqrt16(_mm512_fmadd_ps(z, z, _mm512_fmadd_ps(y, y, _mm512_mul_ps(x, x))));
    };
    const __m512 dx = _mm512_loadu_ps(c[3]), dy = _mm512_loadu_ps(c[4]), dz = _mm512_loadu_ps(c[5]);
    const __m512 d0x = permute16(at, _mm512_loadu_ps(c0[3])), d0y = permute16(at, _mm512_loadu_ps(c0[4])),
                 d0z = permute16(at, _mm512_loadu_ps(c0[5]));
    const __m512 len = length(dx, dy, dz);
    __m512 len0;
    if constexpr (same)
        len0 = permute16(at, len); // lane `first` of len
    else
        len0 = length(d0x, d0y, d0z);
    const __m512 d_d0 = _mm512_fmadd_ps(dz, d0z, _mm512_fmadd_ps(dy, d0y, _mm512_mul_ps(dx, d0x)));
    const __m512 cos_len0 = _mm512_mul_ps(_mm512_set1_ps(packet_cone_cos), len0);
    return _mm512_cmp_ps_mask(d_d0, _mm512_mul_ps(cos_len0, len), _CMP_GE_OQ);
#else
    const float d0x = c0[3][first], d0y = c0[4][first], d0z = c0[5][first];
    const float cos_len0 = packet_cone_cos * std::sqrt(d0x * d0x + d0y * d0y + d0z * d0z);
    unsigned cone = 0;
    for (int g = 0; g < RayPacket::size; g += 8) {
        const __m256 dx = _mm256_load_ps(c[3] + g), dy = _mm256_load_ps(c[4] + g), dz = _mm256_load_ps(c[5] + g);
        const __m256 dd = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
        const __m256 d_d0 = _mm256_fmadd_ps(
            dz, _mm256_set1_ps(d0z), _mm256_fmadd_ps(dy, _mm256_set1_ps(d0y), _mm256_mul_ps(dx, _mm256_set1_ps(d0x))));
        const __m256 bound_cos = _mm256_mul_ps(_mm256_set1_ps(cos_len0), _mm256_sqrt_ps(dd));
        cone |= unsigned(_mm256_movemask_ps(_mm256_cmp_ps(d_d0, bound_cos, _CMP_GE_OQ))) << g;
    }
    return cone;
#endif
}

// Over the lanes `in`: the least (lo) and greatest (hi) of the origins' coordinates (v = 0-2)
// and of the inverse directions' components (v = 3-5). t_far of the other lanes becomes −1.
inline void packet_ranges(RayPacket& p, const float (&c)[6][RayPacket::size], unsigned in, float (&lo)[6],
                          float (&hi)[6]) noexcept {
    const float* const v[6] = {c[0], c[1], c[2], p.inv[0], p.inv[1], p.inv[2]};
#if defined(__AVX512F__)
    // Twelve least values at once: the greatest are the negated least of the negated values.
    // Four registers are halved together (two 256-bit shuffles, then two 128-bit ones, a min
    // each), then each 128-bit block within itself. The shuffles are the maskz forms with full
    // masks, as in avx512.hpp (GCC 12 warns of the plain ones' undefined operand).
    const __mmask16 m = __mmask16(in);
    _mm512_store_ps(p.t_far, _mm512_mask_blend_ps(m, _mm512_set1_ps(-1.0f), _mm512_load_ps(p.t_far)));
    const __m512 pos_inf = _mm512_set1_ps(std::numeric_limits<float>::infinity());
    const __m512i sign = _mm512_set1_epi32(std::numeric_limits<std::int32_t>::min());
    __m512 x[12];
    for (int k = 0; k < 6; ++k) {
        const __m512 a = _mm512_loadu_ps(v[k]);
        x[k] = _mm512_mask_blend_ps(m, pos_inf, a);
        x[6 + k] =
            _mm512_mask_blend_ps(m, pos_inf, _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a), sign)));
    }
    alignas(64) float least[3][16];
    for (int g = 0; g < 3; ++g) {
        const __m512* a = x + 4 * g;
        const __m512 ab = min16(_mm512_maskz_shuffle_f32x4(0xffff, a[0], a[1], 0x44),
                                _mm512_maskz_shuffle_f32x4(0xffff, a[0], a[1], 0xee));
        const __m512 cd = min16(_mm512_maskz_shuffle_f32x4(0xffff, a[2], a[3], 0x44),
                                _mm512_maskz_shuffle_f32x4(0xffff, a[2], a[3], 0xee));
        __m512 r =
            min16(_mm512_maskz_shuffle_f32x4(0xffff, ab, cd, 0x88), _mm512_maskz_shuffle_f32x4(0xffff, ab, cd, 0xdd));
        r = min16(r, _mm512_maskz_permute_ps(0xffff, r, 0xb1));
        r = min16(r, _mm512_maskz_permute_ps(0xffff, r, 0x4e));
        _mm512_store_ps(least[g], r); // the four values at lanes 0, 4, 8, 12
    }
    for (int k = 0; k < 6; ++k) lo[k] = least[k / 4][4 * (k % 4)], hi[k] = -least[(6 + k) / 4][4 * ((6 + k) % 4)];
#else
    const __m256 in8[2] = {
        _mm256_castsi256_ps(_mm256_cmpgt_epi32(
            _mm256_and_si256(_mm256_set1_epi32(int(in)), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128)),
            _mm256_setzero_si256())),
        _mm256_castsi256_ps(_mm256_cmpgt_epi32(
            _mm256_and_si256(_mm256_set1_epi32(int(in >> 8)), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128)),
            _mm256_setzero_si256()))};
    const __m256 pos_inf = _mm256_set1_ps(std::numeric_limits<float>::infinity()),
                 neg_inf = _mm256_set1_ps(-std::numeric_limits<float>::infinity());
    for (int g = 0; g < 2; ++g)
        _mm256_store_ps(p.t_far + 8 * g,
                        _mm256_blendv_ps(_mm256_set1_ps(-1.0f), _mm256_load_ps(p.t_far + 8 * g), in8[g]));
    for (int k = 0; k < 6; ++k) {
        lo[k] = lanes_min(_mm256_blendv_ps(pos_inf, _mm256_load_ps(v[k]), in8[0]),
                          _mm256_blendv_ps(pos_inf, _mm256_load_ps(v[k] + 8), in8[1]));
        hi[k] = lanes_max(_mm256_blendv_ps(neg_inf, _mm256_load_ps(v[k]), in8[0]),
                          _mm256_blendv_ps(neg_inf, _mm256_load_ps(v[k] + 8), in8[1]));
    }
#endif
}

/// Whether origins whose coordinates lie in [lo, hi] (lo[0-2], hi[0-2], as PacketBounds::lo,
/// hi) are close enough for one packet: within packet_origin_spread leaf sizes (`leaf_scale`)
/// along each axis (false for NaN, an overflowed range).
inline bool origins_close(const float (&lo)[6], const float (&hi)[6], float leaf_scale) noexcept {
    for (int a = 0; a < 3; ++a)
        if (!(hi[a] - lo[a] <= packet_origin_spread * leaf_scale)) return false;
    return true;
}

/// The interval test's terms of rays whose origins' coordinates and inverse directions'
/// components lie in [lo, hi] (as PacketBounds::lo, hi), all in the octant `negative` gives
/// (per axis, whether their directions point towards −axis), in a tree of bound `bound`.
inline void set_packet_bounds(PacketBounds& b, const float (&lo)[6], const float (&hi)[6], const bool (&negative)[3],
                              float bound) noexcept {
    constexpr float widen = slab_widen<float>;
    b.one_origin = true;
    for (int k = 0; k < 6; ++k) b.lo[k] = lo[k], b.hi[k] = hi[k];
    for (int a = 0; a < 3; ++a) {
        const bool positive = !negative[a];
        slab_planes<float>(a, negative[a], b.near_plane[a], b.far_plane[a]);
        // Entry (p − o)·inv is least at the largest p − o along the direction's sign: the
        // farthest-forward origin; the exit is greatest at the farthest-back one.
        b.one_origin = b.one_origin && lo[a] == hi[a];
        const float entry_org = positive ? hi[a] : lo[a], exit_org = positive ? lo[a] : hi[a];
        b.inv_lo[a] = lo[3 + a], b.inv_hi[a] = hi[3 + a];
        // inv_far = inv·widen rounded, monotonic in inv (widen > 0): its least and greatest
        // are those of inv times widen, bit for bit.
        b.far_lo[a] = b.inv_lo[a] * widen, b.far_hi[a] = b.inv_hi[a] * widen;
        // Each ray's fast slab distance p·inv − o·inv is within 6ε(|p| + |o|)|inv| of the exact
        // one (prepare_slab's allowance included); the interval's p·inv − (o·inv ± margin), in
        // one FMA from these terms, within 2ε(|p| + |o|)|inv| + ε·margin of (p − o)·inv ∓ margin
        // (three roundings); |p| ≤ the tree's bound. A triangle the watertight test says a ray
        // hits lies within 2.5ε(|p| + |o|) of the ray across it (its sheared vertices round by
        // at most 5u of their distance from o, triangles_avx2.hpp), so the ray passes that near
        // the triangle's box (the packet's triangle filter, triangle_bvh.hpp). 32ε covers all
        // of it with room.
        const float o_max = std::max(std::fabs(lo[a]), std::fabs(hi[a]));
        const float inv_max = std::max(std::fabs(b.far_lo[a]), std::fabs(b.far_hi[a]));
        const float margin = 32 * std::numeric_limits<float>::epsilon() * (bound + o_max) * inv_max;
        b.entry_lo[a] = entry_org * b.inv_lo[a] + margin, b.entry_hi[a] = entry_org * b.inv_hi[a] + margin;
        b.exit_lo[a] = exit_org * b.far_lo[a] - margin, b.exit_hi[a] = exit_org * b.far_hi[a] - margin;
    }
}

/// Sets up `p` from the rays in `c` (origin x, y, z, direction x, y, z; lane k = ray k < n ≤ 16)
/// and their bounds t_max[0, n) (all 16 are read; lanes from n on are left out). First the
/// packet: the rays with a finite, non-zero direction and t_max > 0 that share the first such
/// ray's octant and lie within packet_cone_cos of its direction; then their slab constants by
/// prepare_slab's rules (so as conservative), dropping any whose products could overflow
/// (prepare_slab's robust form).
/// Returns the rays in the packet (p.lanes), at least packet_min_rays, or 0; the others are for
/// the single-ray path. 0 also when the packet's origins lie more than packet_origin_spread
/// leaf sizes (`leaf_scale`) apart along an axis; p.wide tells that case.
inline unsigned make_packet(RayPacket& p, const float (&c)[6][RayPacket::size], int n,
                            const float (&t_max)[RayPacket::size], float bound, float leaf_scale) noexcept {
    p.wide = false;
    // The rays that may join, and their octants (sign bits): cheap tests first, so that an
    // incoherent stream costs little here.
    unsigned octant[3];
    const unsigned usable = rays_usable(c, octant) & packet_t_far_from(t_max, n, p.t_far);
    if (!(usable & (usable - 1))) return 0; // fewer than two
    const int first = lowest_bit(usable);
    unsigned lanes = usable;
    for (int a = 0; a < 3; ++a) lanes &= (octant[a] >> first) & 1u ? octant[a] : ~octant[a];
    if (!(lanes & (lanes - 1))) return 0;
    lanes &= packet_cone<true>(c, c, first);
    if (bit_count(lanes) < packet_min_rays) return 0;
    // The slab constants, as prepare_slab's fast form; a lane whose products could overflow
    // leaves the packet.
    lanes &= slab_lanes(c, bound, p.org, p.inv, p.inv_far, p.org_inv_near, p.org_inv_far);
    if (bit_count(lanes) < packet_min_rays) return 0;
    // Lanes outside the packet: never entered (t_far < 0), and out of the intervals.
    float lo[6], hi[6];
    packet_ranges(p, c, lanes, lo, hi);
    if (!origins_close(lo, hi, leaf_scale)) { // a wide beam (or an overflow)
        p.wide = true;
        return 0;
    }
    p.lanes = lanes;
    bool negative[3];
    for (int a = 0; a < 3; ++a) negative[a] = (octant[a] >> first) & 1u;
    set_packet_bounds(p, lo, hi, negative, bound);
    return lanes;
}

// One axis of packet_hit_boxes: the entry and exit bounds of the boxes' slabs (planes near and
// far) raise tn and lower tf. A function, always inlined with packet_hit_boxes and
// packet_hit_children: written as a lambda, g++ left it out of line once the stream code around
// walk_packet grew, which slowed camera rays (docs/performance.md).
// The entry (p − o)·inv − margin is least at one end of inv's range (the sign of p − o says
// which), the exit greatest at one end of inv_far's: each end in one FMA, p·inv − (o·inv ±
// margin) with the parenthesis made by make_packet.
ISIN_DETAIL_INLINE void packet_slab(const PacketBounds& p, int a, __m256 near, __m256 far, __m256& tn,
                                    __m256& tf) noexcept {
    const __m256 entry =
        _mm256_min_ps(_mm256_fmsub_ps(near, _mm256_set1_ps(p.inv_lo[a]), _mm256_set1_ps(p.entry_lo[a])),
                      _mm256_fmsub_ps(near, _mm256_set1_ps(p.inv_hi[a]), _mm256_set1_ps(p.entry_hi[a])));
    const __m256 exit = _mm256_max_ps(_mm256_fmsub_ps(far, _mm256_set1_ps(p.far_lo[a]), _mm256_set1_ps(p.exit_lo[a])),
                                      _mm256_fmsub_ps(far, _mm256_set1_ps(p.far_hi[a]), _mm256_set1_ps(p.exit_hi[a])));
    tn = _mm256_max_ps(tn, entry);
    tf = _mm256_min_ps(tf, exit);
}

/// The interval slab test of 8 boxes for the whole packet, each box given per axis by its plane
/// the packet's rays enter through (near: lo where the packet's direction is positive, hi
/// elsewhere) and the one they leave through (far), as `planes(a, near, far)` sets them: bit k
/// set when some ray of the packet may enter box k, or pass within the margin of it, before
/// `t_far`; `t_near` gets a lower bound of the rays' entry distances. The margin (make_packet) is
/// an absolute allowance along each axis of 32ε·(bound + |o|), far more than the rays' own slab
/// tests and the interval products round.
template <class Planes>
ISIN_DETAIL_INLINE unsigned packet_hit_boxes(const Planes& planes, const PacketBounds& p, float t_far,
                                             __m256& t_near) noexcept {
    __m256 tn = _mm256_setzero_ps(), tf = _mm256_set1_ps(t_far), near, far;
    // Axis by axis, written out: as a loop over arrays of planes, g++ -O2 kept them on the stack.
    planes(0, near, far), packet_slab(p, 0, near, far, tn, tf);
    planes(1, near, far), packet_slab(p, 1, near, far, tn, tf);
    planes(2, near, far), packet_slab(p, 2, near, far, tn, tf);
    t_near = tn;
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)));
}

/// packet_hit_boxes on a node's 8 children: every child a ray of the packet enters is set.
ISIN_DETAIL_INLINE unsigned packet_hit_children(const BvhTree<float>::Node& n, const PacketBounds& p, float t_far,
                                                float (&t_near)[8]) noexcept {
    __m256 tn;
    const unsigned mask = packet_hit_boxes(
        [&](int a, __m256& near, __m256& far) {
            near = _mm256_load_ps(plane<float>(n, p.near_plane[a]));
            far = _mm256_load_ps(plane<float>(n, p.far_plane[a]));
        },
        p, t_far, tn);
    _mm256_storeu_ps(t_near, tn);
    return mask;
}

/// Whether the packet's rays travel towards +axis `a` (its near planes are the boxes' lo).
inline bool packet_positive(const PacketBounds& p, int a) noexcept {
    return p.near_plane[a] < sizeof(BvhTree<float>::Node::lo);
}

/// Which rays of the packet enter child `k` of `n` before their own t_far: hit_children's fast
/// form, lane by lane, on the rays instead of the children (the rays' test of a leaf's box).
ISIN_DETAIL_INLINE unsigned packet_rays_entering(const BvhTree<float>::Node& n, int k, const RayPacket& p) noexcept {
#if defined(__AVX512F__)
    { // the 16 rays in one register
        __m512 t0[3], t1[3];
        for (int a = 0; a < 3; ++a) {
            t0[a] = _mm512_fmsub_ps(_mm512_set1_ps(plane<float>(n, p.near_plane[a])[k]), _mm512_load_ps(p.inv[a]),
                                    _mm512_load_ps(p.org_inv_near[a]));
            t1[a] = _mm512_fmsub_ps(_mm512_set1_ps(plane<float>(n, p.far_plane[a])[k]), _mm512_load_ps(p.inv_far[a]),
                                    _mm512_load_ps(p.org_inv_far[a]));
        }
        const __m512 tn = max16(max16(t0[0], t0[1]), max16(t0[2], _mm512_setzero_ps()));
        const __m512 tf = min16(min16(t1[0], t1[1]), min16(t1[2], _mm512_load_ps(p.t_far)));
        return unsigned(_mm512_cmp_ps_mask(tn, tf, _CMP_LE_OQ));
    }
#endif
    unsigned rays = 0;
    __m256 near_plane[3], far_plane[3];
    for (int a = 0; a < 3; ++a) {
        near_plane[a] = _mm256_set1_ps(plane<float>(n, p.near_plane[a])[k]);
        far_plane[a] = _mm256_set1_ps(plane<float>(n, p.far_plane[a])[k]);
    }
    for (int g = 0; g < RayPacket::size; g += 8) {
        if (!((p.lanes >> g) & 0xffu)) continue; // no ray left in these lanes
        __m256 t0[3], t1[3];
        for (int a = 0; a < 3; ++a) {
            t0[a] = _mm256_fmsub_ps(near_plane[a], _mm256_load_ps(p.inv[a] + g), _mm256_load_ps(p.org_inv_near[a] + g));
            t1[a] =
                _mm256_fmsub_ps(far_plane[a], _mm256_load_ps(p.inv_far[a] + g), _mm256_load_ps(p.org_inv_far[a] + g));
        }
        const __m256 tn = _mm256_max_ps(_mm256_max_ps(t0[0], t0[1]), _mm256_max_ps(t0[2], _mm256_setzero_ps()));
        const __m256 tf = _mm256_min_ps(_mm256_min_ps(t1[0], t1[1]), _mm256_min_ps(t1[2], _mm256_load_ps(p.t_far + g)));
        rays |= unsigned(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ))) << g;
    }
    return rays;
}

// The largest t_far of the rays still traced.
inline float packet_t_far(const RayPacket& p) noexcept {
    const __m256 m = _mm256_max_ps(_mm256_load_ps(p.t_far), _mm256_load_ps(p.t_far + 8));
    __m128 h = _mm_max_ps(_mm256_castps256_ps128(m), _mm256_extractf128_ps(m, 1));
    h = _mm_max_ps(h, _mm_movehl_ps(h, h));
    h = _mm_max_ss(h, _mm_shuffle_ps(h, h, 1));
    return _mm_cvtss_f32(h);
}

/// Ray k of packet p as a single ray's slab terms (walk_packets: a ray that goes on alone).
ISIN_DETAIL_INLINE SlabRay<float> packet_slab_ray(const RayPacket& p, int k) noexcept {
    SlabRay<float> r;
    for (int a = 0; a < 3; ++a) {
        r.org[a] = p.org[a][k], r.inv[a] = p.inv[a][k], r.inv_far[a] = p.inv_far[a][k];
        r.org_inv_near[a] = p.org_inv_near[a][k], r.org_inv_far[a] = p.org_inv_far[a][k];
        r.near_plane[a] = p.near_plane[a], r.far_plane[a] = p.far_plane[a];
    }
    r.ok = true, r.robust = false;
    return r;
}

/// Sorts the walk's entries stack[first, top) by descending t (insertion sort: a node's few
/// children), so that the nearest is popped first.
template <class Entry>
ISIN_DETAIL_INLINE void sort_entries(Entry* stack, int first, int top) noexcept {
    for (int i = first + 1; i < top; ++i) {
        const Entry c = stack[i];
        int j = i;
        while (j > first && stack[j - 1].t < c.t) stack[j] = stack[j - 1], --j;
        stack[j] = c;
    }
}

/// walk_packets' default `soon`: no hint.
struct NoLeafHint {
    void operator()(std::uint32_t) const noexcept {}
};

/// Traces N packets (1 or 2) through `tree` together, nearest-first by the entry bounds of the
/// interval test (Visit::nearest) or in any order (Visit::any): ray k of packet i is ray
/// 16·i + k of the walk. The interval test is on `box`, which bounds the rays of all of them
/// (a packet's own, or set_packet_bounds over both packets' ranges). At a node, the interval
/// test picks the children some ray may enter, and each ray's own slab test keeps those that
/// one does (with the rays that do). At each leaf some of the rays enter, calls
/// `leaf(leaf_index, rays)` with the mask of those rays; the leaf lowers their t_far (nearest)
/// and returns the rays it is done with (any: they leave their packet). Stops when the stack is
/// empty or no ray is left.
/// The children some ray enters are asked of the cache when their parent is tested, before the
/// walk gets to them: a node's four lines, a leaf's data by `soon(leaf_index)` (the caller's
/// hint; not in a subtree that one ray walks alone): a packet's walk spends much of its time
/// waiting for the first load of a node or of a leaf's block.
template <Visit visit, std::size_t N, class Leaf, class Soon = NoLeafHint>
void walk_packets(const BvhTree<float>& tree, RayPacket* const (&ps)[N], const PacketBounds& box, Leaf&& leaf,
                  const Soon& soon = {}) {
    static_assert(N == 1 || N == 2, "one packet or two");
    using Node = BvhTree<float>::Node;
    constexpr std::uint32_t leaf_bit = BvhTree<float>::leaf_bit;
    struct Entry {
        std::uint32_t ref;
        float t;                    // no ray enters it before this
        unsigned rays;              // the rays that enter it (when it was pushed)
        std::uint32_t parent, slot; // where its box is: child `slot` of node `parent`
        std::uint32_t tested;       // the leaf calls before the rays' own tests gave `rays` (+ 1; 0: not tested)
    };
    const auto lanes = [&ps] { return N == 1 ? ps[0]->lanes : ps[0]->lanes | ps[N - 1]->lanes << 16; };
    const auto t_far_of_all = [&ps] {
        return N == 1 ? packet_t_far(*ps[0]) : std::max(packet_t_far(*ps[0]), packet_t_far(*ps[N - 1]));
    };
    // The rays that enter child k of n before their own t_far.
    const auto entering = [&ps](const Node& n, int k) {
        const unsigned a = packet_rays_entering(n, k, *ps[0]);
        return N == 1 ? a : a | packet_rays_entering(n, k, *ps[N - 1]) << 16;
    };
    // The rays `done` leave their packets.
    const auto leave = [&ps](unsigned done) {
        for (; done; done &= done - 1) {
            const int k = lowest_bit(done);
            RayPacket& p = *ps[std::size_t(k >> 4)];
            p.lanes &= ~(1u << (k & 15));
            p.t_far[k & 15] = -1.0f;
        }
    };
    Entry stack[7 * BvhTree<float>::depth_limit + 1];
    int top = 0;
    Entry e{0, 0.0f, lanes(), 0, 0, 0}; // the root node
    // Leaf calls so far (each may lower some t_far): a leaf's rays tested when it was pushed,
    // with no leaf call since, need no second test.
    std::uint32_t calls = 0;
    const Node* const nodes = tree.nodes().data();
    float t_packet = t_far_of_all();
    if (!(t_packet > 0.0f)) return;
    for (;;) {
        if (!(e.ref & leaf_bit) && bit_count(e.rays & lanes()) <= packet_single_rays) {
            for (unsigned rays = e.rays & lanes(); rays; rays &= rays - 1) { // each ray alone
                const int i = lowest_bit(rays), k = i & 15;
                RayPacket& p = *ps[std::size_t(i >> 4)];
                const SlabRay<float> r = packet_slab_ray(p, k);
                auto one = [&](std::uint32_t leaf_index, float&) {
                    return ((leaf(leaf_index, 1u << i) >> i) & 1u) != 0;
                };
                ++calls;
                if (walk<visit, false>(tree, r, p.t_far[k], one, e.ref)) leave(1u << i); // any: this ray is done
            }
            if (!lanes()) return;
            t_packet = t_far_of_all();
        } else if (e.ref & leaf_bit) {
            // Nearest: t_far fell since the entry was pushed, so the rays are tested again.
            const unsigned rays = visit == Visit::any || e.tested == calls + 1
                                      ? e.rays & lanes()
                                      : entering(nodes[e.parent], int(e.slot)) & lanes();
            if (rays) {
                ++calls;
                const unsigned done = leaf(e.ref & ~leaf_bit, rays);
                if (done) {
                    leave(done);
                    if (!lanes()) return;
                }
                t_packet = t_far_of_all();
            }
        } else {
            const Node& n = nodes[e.ref];
            float t_near[8];
            unsigned rays[8];
            unsigned mask = packet_hit_children(n, box, t_packet, t_near);
            // Each ray's own test: the children one enters. With one origin, inner children
            // take the interval test's word (a frustum's: one ray's entry is seldom dropped
            // where the packet's is not) and the rays' tests wait for the leaves, which saves
            // the rays' tests at every inner node.
            unsigned tested[8];
            const unsigned live = lanes();
            for (unsigned m = mask; m; m &= m - 1) {
                const int k = lowest_bit(m);
                const bool own = !box.one_origin || (n.child[k] & leaf_bit);
                rays[k] = own ? entering(n, k) & live : e.rays & live;
                tested[k] = own ? calls + 1 : 0;
                if (!rays[k])
                    mask &= ~(1u << k);
                else if (n.child[k] & leaf_bit)
                    soon(n.child[k] & ~leaf_bit);
                else
                    prefetch_lines(nodes + n.child[k], sizeof(Node));
            }
            if (mask) {
                int k = lowest_bit(mask);
                mask &= mask - 1;
                const std::uint32_t parent = e.ref;
                if (!mask) { // one child: go on with it
                    e = {n.child[k], t_near[k], rays[k], parent, std::uint32_t(k), tested[k]};
                    continue;
                }
                const int first = top;
                stack[top++] = {n.child[k], t_near[k], rays[k], parent, std::uint32_t(k), tested[k]};
                while (mask) {
                    k = lowest_bit(mask);
                    mask &= mask - 1;
                    stack[top++] = {n.child[k], t_near[k], rays[k], parent, std::uint32_t(k), tested[k]};
                }
                if constexpr (visit == Visit::nearest) sort_entries(stack, first, top);
                e = stack[--top];
                continue;
            }
        }
        for (;;) { // the next entry some ray may still reach
            if (top == 0) return;
            e = stack[--top];
            if (e.t < t_packet && (e.rays & lanes())) break;
        }
    }
}

/// One packet's walk (walk_packets): `leaf(leaf_index, rays)`, rays a mask of its lanes.
template <Visit visit, class Leaf, class Soon = NoLeafHint>
void walk_packet(const BvhTree<float>& tree, RayPacket& p, Leaf&& leaf, const Soon& soon = {}) {
    RayPacket* const ps[1] = {&p};
    walk_packets<visit>(tree, ps, p, leaf, soon);
}

} // namespace detail
} // namespace isin
#endif
