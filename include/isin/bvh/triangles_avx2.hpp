#pragma once
/// isin — the AVX2 + FMA form of the triangle leaves' lane test (included by triangles.hpp when
/// the target has both, unless ISIN_FORCE_PURE). Same results as the portable forms, and
/// faster: in float, Kahan's difference of products on 8 lanes costs 4 operations an edge
/// function where exact products in double cost about 13.
// Empty unless the target has AVX2 and FMA (and ISIN_FORCE_PURE is not defined).
#if defined(__AVX2__) && defined(__FMA__) && !defined(ISIN_FORCE_PURE)
#include <immintrin.h>

#include <cstdint>
#include <limits>

#include "../detail/attributes.hpp"
#include "../simd/avx512.hpp"
#include "box.hpp"
#include "triangle_block.hpp"

#define ISIN_DETAIL_TRIANGLES_AVX2 1

namespace isin {
namespace detail {

// The 8 triangles of a block relative to the ray's origin, sheared onto its frame (WBW §3):
// x, y across the ray, z along it (not yet scaled by Sz).
struct Sheared8 {
    __m256 x[3], y[3], z[3];
    ISIN_DETAIL_INLINE Sheared8(const TriangleBlock<float>& b, const TriangleRay<float>& r) noexcept {
        const __m256 ox = _mm256_set1_ps(r.org[r.shear.kx]), oy = _mm256_set1_ps(r.org[r.shear.ky]);
        const __m256 oz = _mm256_set1_ps(r.org[r.shear.kz]);
        const __m256 Sx = _mm256_set1_ps(r.shear.Sx), Sy = _mm256_set1_ps(r.shear.Sy);
        for (int v = 0; v < 3; ++v)
            watertight_shear([&](int a) ISIN_DETAIL_LAMBDA_INLINE { return _mm256_load_ps(b.v[v][r.shear.axis(a)]); },
                             ox, oy, oz, Sx, Sy, x[v], y[v], z[v]);
    }
};

// Eight float lanes as two halves of four doubles.
struct Halves {
    __m256d lo, hi;
    explicit Halves(__m256 v) noexcept
        : lo(_mm256_cvtps_pd(_mm256_castps256_ps128(v))), hi(_mm256_cvtps_pd(_mm256_extractf128_ps(v, 1))) {}
};

// a·b − c·d on 8 float lanes exactly as difference_of_products<float> computes it: products of
// floats are exact in double, their difference is rounded once to double, then to float. No
// float product is formed, so nothing overflows or underflows on the way.
inline __m256 exact_difference_of_products8(const Halves& a, const Halves& b, const Halves& c,
                                            const Halves& d) noexcept {
    const __m128 lo = _mm256_cvtpd_ps(_mm256_fmsub_pd(a.lo, b.lo, _mm256_mul_pd(c.lo, d.lo)));
    const __m128 hi = _mm256_cvtpd_ps(_mm256_fmsub_pd(a.hi, b.hi, _mm256_mul_pd(c.hi, d.hi)));
    return _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
}

// The rest of the float test once U, V, W are known, as intersect_sheared: inside (all ≥ 0, or
// all ≤ 0 unless culling), det ≠ 0, t = (U·Az + V·Bz + W·Cz)/det in (0, t_max); u = V/det,
// v = W/det. Returns the lanes hit; fills `out` (when `store`) only when there are some.
template <bool cull, bool store>
ISIN_DETAIL_INLINE unsigned finish8(__m256 U, __m256 V, __m256 W, const __m256 (&z)[3], float Sz, float t_max,
                                    LaneHits<float>& out) noexcept {
    const __m256 zero = _mm256_setzero_ps();
    const __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), W);
    const __m256 front = _mm256_cmp_ps(_mm256_min_ps(_mm256_min_ps(U, V), W), zero, _CMP_GE_OQ); // clockwise (§2)
    __m256 ok = front;
    if constexpr (!cull)
        ok = _mm256_or_ps(front, _mm256_cmp_ps(_mm256_max_ps(_mm256_max_ps(U, V), W), zero, _CMP_LE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(det, zero, _CMP_NEQ_OQ));
    if (_mm256_testz_ps(ok, ok)) return 0; // most blocks end here, before the division
    const __m256 S = _mm256_set1_ps(Sz);
    const __m256 t_scaled =
        watertight_t_det(U, V, W, _mm256_mul_ps(S, z[0]), _mm256_mul_ps(S, z[1]), _mm256_mul_ps(S, z[2]));
    const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    const __m256 t = _mm256_mul_ps(t_scaled, inv_det);
    ok = _mm256_and_ps(
        ok, _mm256_and_ps(_mm256_cmp_ps(t, zero, _CMP_GT_OQ), _mm256_cmp_ps(t, _mm256_set1_ps(t_max), _CMP_LT_OQ)));
    const unsigned lanes = unsigned(_mm256_movemask_ps(ok));
    if (store && lanes)
        _mm256_storeu_ps(out.t, t), _mm256_storeu_ps(out.u, _mm256_mul_ps(V, inv_det)),
            _mm256_storeu_ps(out.v, _mm256_mul_ps(W, inv_det));
    return lanes;
}

// The edge functions U, V, W of the 8 sheared triangles by Kahan's algorithm in float, four
// operations each (test_block_avx2's fast form).
ISIN_DETAIL_INLINE auto kahan_edges8(const Sheared8& p) noexcept {
    return watertight_edges(p.x[0], p.y[0], p.x[1], p.y[1], p.x[2], p.y[2], LaneDifferenceOfProducts{});
}

// The lanes of a block test_block_avx2 does not trust (bits of `trusted` clear) tested with U,
// V, W as difference_of_products<float> (exact products in double): there each lane computes
// what intersect_sheared computes; the trusted lanes keep Kahan's U, V, W. So a triangle's
// result is its own: it does not depend on the other triangles of its block (a packet tests only
// the triangles its rays may reach, packet.hpp). It shears the block again rather than take
// test_block_avx2's registers: passing them makes the hot path store all nine to the stack
// (docs/performance.md).
template <bool cull, bool store>
ISIN_DETAIL_COLD unsigned test_block_exact(const TriangleBlock<float>& b, const TriangleRay<float>& r, unsigned trusted,
                                           float t_max, LaneHits<float>& out) noexcept {
    const Sheared8 p(b, r);
    const auto kahan = kahan_edges8(p);
    const __m256 keep = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
        _mm256_and_si256(_mm256_set1_epi32(int(trusted)), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128)),
        _mm256_setzero_si256()));
    const Halves X0(p.x[0]), Y0(p.y[0]), X1(p.x[1]), Y1(p.y[1]), X2(p.x[2]), Y2(p.y[2]);
    const auto exact = watertight_edges(X0, Y0, X1, Y1, X2, Y2, exact_difference_of_products8);
    return finish8<cull, store>(_mm256_blendv_ps(exact.U, kahan.U, keep), _mm256_blendv_ps(exact.V, kahan.V, keep),
                                _mm256_blendv_ps(exact.W, kahan.W, keep), p.z, r.shear.Sz, t_max, out);
}

// The float test with U, V, W by Kahan's algorithm in float (kahan_edges8). Its sign is exact,
// so each lane decides as the exact test does, unless a product over- or underflowed float:
// then det is not finite or an edge function is below 2^-126 in magnitude (exact zeros
// included), and that lane is tested exactly (test_block_exact; D7: a vertex at 2e38).
template <bool cull, bool store>
ISIN_DETAIL_INLINE unsigned test_block_avx2(const TriangleBlock<float>& b, const TriangleRay<float>& r, float t_max,
                                            LaneHits<float>& out) noexcept {
    const Sheared8 p(b, r);
    const auto e = kahan_edges8(p);
    const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 smallest = _mm256_min_ps(_mm256_min_ps(_mm256_and_ps(e.U, magnitude), _mm256_and_ps(e.V, magnitude)),
                                          _mm256_and_ps(e.W, magnitude));
    const __m256 det = _mm256_add_ps(_mm256_add_ps(e.U, e.V), e.W);
    const __m256 trusted =
        _mm256_and_ps(_mm256_cmp_ps(smallest, _mm256_set1_ps(0x1p-126f), _CMP_GE_OQ),
                      _mm256_cmp_ps(_mm256_and_ps(det, magnitude), _mm256_set1_ps(0x1p126f), _CMP_LT_OQ));
    const unsigned trusted_lanes = unsigned(_mm256_movemask_ps(trusted));
    if (trusted_lanes != 0xffu) return test_block_exact<cull, store>(b, r, trusted_lanes, t_max, out);
    return finish8<cull, store>(e.U, e.V, e.W, p.z, r.shear.Sz, t_max, out);
}

/// The watertight shears of 16 rays (a packet's), lane by lane what WatertightShear::set
/// computes: the axes in k[0..2] (kx, ky, kz), Sx, Sy, Sz in S[0..2], and in `usable` the lanes
/// whose set() would succeed (d[kz] != 0: true for NaN, as there).
struct ShearLanes {
    alignas(64) float S[3][16];
    alignas(64) std::int32_t k[3][16];
    unsigned usable = 0;
    WatertightShear<float> at(int lane) const noexcept {
        WatertightShear<float> s;
        s.kx = k[0][lane], s.ky = k[1][lane], s.kz = k[2][lane];
        s.Sx = S[0][lane], s.Sy = S[1][lane], s.Sz = S[2][lane];
        return s;
    }
};

/// Fills `out` from 16 directions (x, y, z lane by lane, 32-byte aligned), eight lanes at a time.
inline void set_shears(const float* x, const float* y, const float* z, ShearLanes& out) noexcept {
    const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)), zero = _mm256_setzero_ps();
    const __m256i i0 = _mm256_setzero_si256(), i1 = _mm256_set1_epi32(1), i2 = _mm256_set1_epi32(2);
    out.usable = 0;
    for (int g = 0; g < 16; g += 8) {
        const __m256 dx = _mm256_load_ps(x + g), dy = _mm256_load_ps(y + g), dz = _mm256_load_ps(z + g);
        const __m256 ax = _mm256_and_ps(dx, magnitude), ay = _mm256_and_ps(dy, magnitude),
                     az = _mm256_and_ps(dz, magnitude);
        // kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2), as set()
        const __m256 x_over_y = _mm256_cmp_ps(ax, ay, _CMP_GT_OQ);
        const __m256 z_is_x = _mm256_and_ps(x_over_y, _mm256_cmp_ps(ax, az, _CMP_GT_OQ));
        const __m256 z_is_y = _mm256_andnot_ps(x_over_y, _mm256_cmp_ps(ay, az, _CMP_GT_OQ));
        // the components along kz, kx, ky before the swap: kz = 0 → (x; y, z), 1 → (y; z, x), 2 → (z; x, y)
        const __m256 along = _mm256_blendv_ps(_mm256_blendv_ps(dz, dy, z_is_y), dx, z_is_x);
        __m256 across_x = _mm256_blendv_ps(_mm256_blendv_ps(dx, dz, z_is_y), dy, z_is_x);
        __m256 across_y = _mm256_blendv_ps(_mm256_blendv_ps(dy, dx, z_is_y), dz, z_is_x);
        __m256i kz = _mm256_blendv_epi8(_mm256_blendv_epi8(i2, i1, _mm256_castps_si256(z_is_y)), i0,
                                        _mm256_castps_si256(z_is_x));
        __m256i kx = _mm256_blendv_epi8(_mm256_blendv_epi8(i0, i2, _mm256_castps_si256(z_is_y)), i1,
                                        _mm256_castps_si256(z_is_x));
        __m256i ky = _mm256_blendv_epi8(_mm256_blendv_epi8(i1, i0, _mm256_castps_si256(z_is_y)), i2,
                                        _mm256_castps_si256(z_is_x));
        // d[kz] < 0: kx and ky swap (the winding stays clockwise)
        const __m256 negative = _mm256_cmp_ps(along, zero, _CMP_LT_OQ);
        const __m256 swapped_x = _mm256_blendv_ps(across_x, across_y, negative);
        across_y = _mm256_blendv_ps(across_y, across_x, negative), across_x = swapped_x;
        const __m256i swapped_kx = _mm256_blendv_epi8(kx, ky, _mm256_castps_si256(negative));
        ky = _mm256_blendv_epi8(ky, kx, _mm256_castps_si256(negative)), kx = swapped_kx;
        _mm256_store_ps(out.S[0] + g, _mm256_div_ps(across_x, along)); // WBW: shear
        _mm256_store_ps(out.S[1] + g, _mm256_div_ps(across_y, along));
        _mm256_store_ps(out.S[2] + g, _mm256_div_ps(_mm256_set1_ps(1.0f), along));
        _mm256_store_si256(reinterpret_cast<__m256i*>(out.k[0] + g), kx);
        _mm256_store_si256(reinterpret_cast<__m256i*>(out.k[1] + g), ky);
        _mm256_store_si256(reinterpret_cast<__m256i*>(out.k[2] + g), kz);
        out.usable |= unsigned(_mm256_movemask_ps(_mm256_cmp_ps(along, zero, _CMP_NEQ_UQ))) << g; // set(): d[kz] != 0
    }
}

// The double test as two halves of 4 lanes, as intersect_sheared (whose difference_of_products
// is this same Kahan's algorithm); a half whose first lane is padding is skipped.
template <bool cull, bool store>
ISIN_DETAIL_INLINE unsigned test_block_avx2(const TriangleBlock<double>& b, const TriangleRay<double>& r, double t_max,
                                            LaneHits<double>& out) noexcept {
    const __m256d ox = _mm256_set1_pd(r.org[r.shear.kx]), oy = _mm256_set1_pd(r.org[r.shear.ky]);
    const __m256d oz = _mm256_set1_pd(r.org[r.shear.kz]);
    const __m256d Sx = _mm256_set1_pd(r.shear.Sx), Sy = _mm256_set1_pd(r.shear.Sy), Sz = _mm256_set1_pd(r.shear.Sz);
    const __m256d zero = _mm256_setzero_pd();
    unsigned lanes = 0;
    for (int half = 0; half < 8 && !is_padding(b, half); half += 4) {
        __m256d x[3], y[3], z[3];
        for (int v = 0; v < 3; ++v)
            watertight_shear([&](int a)
                                 ISIN_DETAIL_LAMBDA_INLINE { return _mm256_load_pd(b.v[v][r.shear.axis(a)] + half); },
                             ox, oy, oz, Sx, Sy, x[v], y[v], z[v]);
        const auto e = watertight_edges(x[0], y[0], x[1], y[1], x[2], y[2], LaneDifferenceOfProducts{});
        const __m256d U = e.U, V = e.V, W = e.W;
        const __m256d det = _mm256_add_pd(_mm256_add_pd(U, V), W);
        const __m256d front = _mm256_cmp_pd(_mm256_min_pd(_mm256_min_pd(U, V), W), zero, _CMP_GE_OQ); // clockwise (§2)
        __m256d ok = front;
        if constexpr (!cull)
            ok = _mm256_or_pd(front, _mm256_cmp_pd(_mm256_max_pd(_mm256_max_pd(U, V), W), zero, _CMP_LE_OQ));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(det, zero, _CMP_NEQ_OQ));
        if (_mm256_testz_pd(ok, ok)) continue;
        const __m256d t_scaled =
            watertight_t_det(U, V, W, _mm256_mul_pd(Sz, z[0]), _mm256_mul_pd(Sz, z[1]), _mm256_mul_pd(Sz, z[2]));
        const __m256d inv_det = _mm256_div_pd(_mm256_set1_pd(1.0), det);
        const __m256d t = _mm256_mul_pd(t_scaled, inv_det);
        ok = _mm256_and_pd(
            ok, _mm256_and_pd(_mm256_cmp_pd(t, zero, _CMP_GT_OQ), _mm256_cmp_pd(t, _mm256_set1_pd(t_max), _CMP_LT_OQ)));
        const unsigned half_lanes = unsigned(_mm256_movemask_pd(ok));
        if (!half_lanes) continue;
        if (!store) return half_lanes << half;
        _mm256_storeu_pd(out.t + half, t), _mm256_storeu_pd(out.u + half, _mm256_mul_pd(V, inv_det));
        _mm256_storeu_pd(out.v + half, _mm256_mul_pd(W, inv_det));
        lanes |= half_lanes << half;
    }
    return lanes;
}

} // namespace detail
} // namespace isin

#endif // AVX2 and FMA
