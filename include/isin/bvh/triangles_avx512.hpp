#pragma once
/// isin — the AVX-512 form of the triangle leaves' tests (included by triangles.hpp): a block's
/// triangles against two rays at once (test_block_pair) and a packet's rays triangle by triangle
/// (test_block_rays), 16 lanes. Same results as the AVX2 and portable forms.
// Empty unless the target has AVX-512 F and DQ besides AVX2 and FMA (and ISIN_FORCE_PURE is not
// defined).
#if defined(__AVX2__) && defined(__FMA__) && !defined(ISIN_FORCE_PURE) && defined(__AVX512F__) && defined(__AVX512DQ__)
#include <immintrin.h>

#include <cstdint>
#include <limits>

#include "../detail/attributes.hpp"
#include "../simd/avx512.hpp"
#include "triangle_block.hpp"
#include "triangles_avx2.hpp" // test_block_avx2, for rays the pair test cannot take

namespace isin {
namespace detail {

#define ISIN_DETAIL_TRIANGLE_PAIRS 1

// Sixteen lanes of a ray and a triangle each: test_block_avx2's operations on them.
// `vertex(i, a)` gives the triangles' vertex i along the rays' axis a (0, 1, 2: kx, ky, kz).
// Written out vertex by vertex: as loops, g++ -O2 kept the coordinates in memory.
struct Sheared16 {
    __m512 z[3], U, V, W, det;
    template <class Vertex>
    Sheared16(const Vertex& vertex, __m512 ox, __m512 oy, __m512 oz, __m512 Sx, __m512 Sy) noexcept {
        __m512 x[3], y[3]; // as Sheared8
        const auto shear = [&](int i) {
            watertight_shear([&](int a) { return vertex(i, a); }, ox, oy, oz, Sx, Sy, x[i], y[i], z[i]);
        };
        shear(0), shear(1), shear(2);
        const auto e = watertight_edges(x[0], y[0], x[1], y[1], x[2], y[2], LaneDifferenceOfProducts{});
        U = e.U, V = e.V, W = e.W;
        det = _mm512_add_ps(_mm512_add_ps(U, V), W);
    }
    // test_block_avx2's trust: every edge function at least 2^-126 in magnitude, |det| < 2^126.
    unsigned trusted() const noexcept {
        const __m512 smallest = min16(min16(_mm512_abs_ps(U), _mm512_abs_ps(V)), _mm512_abs_ps(W));
        return unsigned(_mm512_cmp_ps_mask(smallest, _mm512_set1_ps(0x1p-126f), _CMP_GE_OQ)) &
               unsigned(_mm512_cmp_ps_mask(_mm512_abs_ps(det), _mm512_set1_ps(0x1p126f), _CMP_LT_OQ));
    }
    // finish8's first part: the lanes inside (clockwise, §2, or either way unless culling), det ≠ 0.
    template <bool cull>
    unsigned inside() const noexcept {
        const __m512 zero = _mm512_setzero_ps();
        unsigned ok = _mm512_cmp_ps_mask(min16(min16(U, V), W), zero, _CMP_GE_OQ);
        if constexpr (!cull) ok |= _mm512_cmp_ps_mask(max16(max16(U, V), W), zero, _CMP_LE_OQ);
        return ok & unsigned(_mm512_cmp_ps_mask(det, zero, _CMP_NEQ_OQ));
    }
    // finish8's second part: t (and 1/det, for u and v).
    __m512 t(__m512 Sz, __m512& inv_det) const noexcept {
        const __m512 t_scaled =
            watertight_t_det(U, V, W, _mm512_mul_ps(Sz, z[0]), _mm512_mul_ps(Sz, z[1]), _mm512_mul_ps(Sz, z[2]));
        inv_det = _mm512_div_ps(_mm512_set1_ps(1.0f), det);
        return _mm512_mul_ps(t_scaled, inv_det);
    }
    // The lanes with 0 < t < t_max.
    static unsigned ahead(__m512 t, __m512 t_max) noexcept {
        return unsigned(_mm512_cmp_ps_mask(t, _mm512_setzero_ps(), _CMP_GT_OQ)) &
               unsigned(_mm512_cmp_ps_mask(t, t_max, _CMP_LT_OQ));
    }
};

// Two rays' tests of one block at once, ray a in lanes 0-7 and ray b in lanes 8-15 of one
// AVX-512 register (a packet's rays that enter a leaf together): lane by lane the operations of
// test_block_avx2, so the same lanes hit with the same t, u, v, in half the instructions and
// branches. Rays whose shears permute the axes differently, and blocks test_block_avx2 would
// not trust for either ray, are tested one by one. Both rays must be ready(). Returns ray a's
// lanes in bits 0-7 and ray b's in bits 8-15.
template <bool cull, bool store>
inline unsigned test_block_pair(const TriangleBlock<float>& b, const TriangleRay<float>& ra,
                                const TriangleRay<float>& rb, float t_max_a, float t_max_b, LaneHits<float>& out_a,
                                LaneHits<float>& out_b) noexcept {
    const WatertightShear<float>&sa = ra.shear, &sb = rb.shear;
    const auto one_by_one = [&] {
        return test_block_avx2<cull, store>(b, ra, t_max_a, out_a) | test_block_avx2<cull, store>(b, rb, t_max_b, out_b)
                                                                         << 8;
    };
    if (sa.kx != sb.kx || sa.ky != sb.ky || sa.kz != sb.kz) return one_by_one();
    const auto both = [](float a, float c) {
        return _mm512_mask_blend_ps(0xff00, _mm512_set1_ps(a), _mm512_set1_ps(c));
    };
    const int axis[3] = {sa.kx, sa.ky, sa.kz};
    const Sheared16 e([&](int i, int a) { return load8_twice(b.v[i][axis[a]]); }, both(ra.org[sa.kx], rb.org[sa.kx]),
                      both(ra.org[sa.ky], rb.org[sa.ky]), both(ra.org[sa.kz], rb.org[sa.kz]), both(sa.Sx, sb.Sx),
                      both(sa.Sy, sb.Sy));
    if (e.trusted() != 0xffff) return one_by_one();
    unsigned ok = e.inside<cull>();
    if (!ok) return 0;
    __m512 inv_det;
    const __m512 t = e.t(both(sa.Sz, sb.Sz), inv_det);
    ok &= Sheared16::ahead(t, both(t_max_a, t_max_b));
    if (store && ok) {
        store_halves(t, out_a.t, out_b.t), store_halves(_mm512_mul_ps(e.V, inv_det), out_a.u, out_b.u);
        store_halves(_mm512_mul_ps(e.W, inv_det), out_a.v, out_b.v);
    }
    return ok;
}

/// Up to 16 rays in lanes whose shears permute the axes alike (kx, ky, kz): their origins and
/// shears along those axes, and their bounds.
struct ShearedRays {
    __m512 ox, oy, oz, Sx, Sy, Sz, t_max;
    int kx, ky, kz;
};
/// The nearest hit of each lane's ray in a block: t (∞ for none), u, v and the triangle's index.
struct BlockHitLanes {
    __m512 t, u, v;
    __m512i primitive;
};

// The rays `rays` (lanes of r) against the block's triangles `triangles` (lanes of the block)
// one by one, each triangle's coordinates broadcast over the rays: lane by lane the operations of
// test_block_avx2, so the same triangles hit with the same t, u, v; many rays entering a leaf
// together (a packet's) cost one test a triangle instead of one a ray. Triangles the skip mask
// names hit nothing. A ray for which test_block_avx2 would not trust one of these triangles (it
// then tests that one exactly) goes into `untrusted`, and its lane is left out of the result.
// Returns the rays that hit one of the triangles with 0 < t < t_max; with `nearest`, `out` gets
// each one's nearest (the least t, of equal t the lowest index: nearest_lane's choice).
template <bool cull, bool nearest>
inline unsigned test_block_rays(const TriangleBlock<float>& b, const ShearedRays& r, unsigned rays, unsigned triangles,
                                const std::uint8_t* skip, BlockHitLanes& out, unsigned& untrusted) noexcept {
    if constexpr (nearest) {
        out.t = _mm512_set1_ps(std::numeric_limits<float>::infinity());
        out.u = out.v = _mm512_setzero_ps();
        out.primitive = _mm512_setzero_si512();
    }
    unsigned hit = 0;
    const int axis[3] = {r.kx, r.ky, r.kz};
    unsigned doubtful = 0;
    for (; triangles; triangles &= triangles - 1) {
        const int k = lowest_bit(triangles);
        if (skip && skip[b.primitive[k]]) continue;
        const Sheared16 e([&](int i, int a) { return _mm512_set1_ps(b.v[i][axis[a]][k]); }, r.ox, r.oy, r.oz, r.Sx,
                          r.Sy);
        doubtful |= rays & ~e.trusted();
        unsigned ok = rays & e.inside<cull>();
        if (!ok) continue;
        __m512 inv_det;
        const __m512 t = e.t(r.Sz, inv_det);
        ok &= Sheared16::ahead(t, r.t_max);
        hit |= ok;
        if constexpr (nearest) {
            const __m512i index = _mm512_set1_epi32(int(b.primitive[k]));
            const __mmask16 nearer = __mmask16(ok & (unsigned(_mm512_cmp_ps_mask(t, out.t, _CMP_LT_OQ)) |
                                                     (unsigned(_mm512_cmp_ps_mask(t, out.t, _CMP_EQ_OQ)) &
                                                      unsigned(_mm512_cmplt_epu32_mask(index, out.primitive)))));
            out.t = _mm512_mask_mov_ps(out.t, nearer, t);
            out.u = _mm512_mask_mul_ps(out.u, nearer, e.V, inv_det);
            out.v = _mm512_mask_mul_ps(out.v, nearer, e.W, inv_det);
            out.primitive = _mm512_mask_mov_epi32(out.primitive, nearer, index);
        }
    }
    untrusted |= doubtful;
    return hit & ~doubtful;
}

} // namespace detail
} // namespace isin

#endif // AVX-512 F and DQ, AVX2 and FMA
