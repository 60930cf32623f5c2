#pragma once
/// isin — private: the AVX-512 operations whose plain intrinsics GCC 12 warns about, spelled
/// with full masks (the maskz forms): its _mm512_max_ps (and _pd), _mm512_min_ps, _mm512_sqrt_ps
/// (and _pd), _mm512_broadcast_f32x8, _mm512_unpacklo/hi_ps (and _pd), _mm512_extractf32x4_ps,
/// _mm512_permutexvar_ps and the 256-bit halves of a register pass an uninitialised operand of their own
/// (-Wuninitialized, -Wmaybe-uninitialized). Same instructions.
#if defined(__AVX512F__)
#include <immintrin.h>

namespace isin {
namespace detail {

inline __m512 max16(__m512 a, __m512 b) noexcept { return _mm512_maskz_max_ps(0xffff, a, b); }
inline __m512 min16(__m512 a, __m512 b) noexcept { return _mm512_maskz_min_ps(0xffff, a, b); }
inline __m512d max8(__m512d a, __m512d b) noexcept { return _mm512_maskz_max_pd(0xff, a, b); }
inline __m512 sqrt16(__m512 a) noexcept { return _mm512_maskz_sqrt_ps(0xffff, a); }
inline __m512d sqrt8(__m512d a) noexcept { return _mm512_maskz_sqrt_pd(0xff, a); }
inline __m512 unpacklo16(__m512 a, __m512 b) noexcept { return _mm512_maskz_unpacklo_ps(0xffff, a, b); }
inline __m512 unpackhi16(__m512 a, __m512 b) noexcept { return _mm512_maskz_unpackhi_ps(0xffff, a, b); }
inline __m512d unpacklo8(__m512d a, __m512d b) noexcept { return _mm512_maskz_unpacklo_pd(0xff, a, b); }
inline __m512d unpackhi8(__m512d a, __m512d b) noexcept { return _mm512_maskz_unpackhi_pd(0xff, a, b); }
/// Lane k of the result is lane index[k] of a.
inline __m512 permute16(__m512i index, __m512 a) noexcept { return _mm512_maskz_permutexvar_ps(0xffff, index, a); }

/// Four fields of 16 records at once: record k's fields 0-3 (a[0-3] lane k) are stored as four
/// floats at `at(k)`, unaligned. A 4×4 transpose in each 128-bit block (two unpacks, then two
/// more), then one 128-bit store per record.
template <class At>
inline void store_quads(const __m512 (&a)[4], const At& at) noexcept {
    const __m512d lo01 = _mm512_castps_pd(unpacklo16(a[0], a[1])), hi01 = _mm512_castps_pd(unpackhi16(a[0], a[1])),
                  lo23 = _mm512_castps_pd(unpacklo16(a[2], a[3])), hi23 = _mm512_castps_pd(unpackhi16(a[2], a[3]));
    // r[i], 128-bit block j: record 4j + i
    const __m512 r[4] = {_mm512_castpd_ps(unpacklo8(lo01, lo23)), _mm512_castpd_ps(unpackhi8(lo01, lo23)),
                         _mm512_castpd_ps(unpacklo8(hi01, hi23)), _mm512_castpd_ps(unpackhi8(hi01, hi23))};
    for (int i = 0; i < 4; ++i) {
        _mm_storeu_ps(at(i), _mm512_maskz_extractf32x4_ps(0xf, r[i], 0));
        _mm_storeu_ps(at(4 + i), _mm512_maskz_extractf32x4_ps(0xf, r[i], 1));
        _mm_storeu_ps(at(8 + i), _mm512_maskz_extractf32x4_ps(0xf, r[i], 2));
        _mm_storeu_ps(at(12 + i), _mm512_maskz_extractf32x4_ps(0xf, r[i], 3));
    }
}

#if defined(__AVX512DQ__)
/// The 8 floats at `p` (32-byte aligned) in both halves of a register.
inline __m512 load8_twice(const float* p) noexcept { return _mm512_maskz_broadcast_f32x8(0xffff, _mm256_load_ps(p)); }
/// Stores the register's lanes 0-7 at `lo` and 8-15 at `hi`.
inline void store_halves(__m512 v, float* lo, float* hi) noexcept {
    _mm256_storeu_ps(lo, _mm512_maskz_extractf32x8_ps(0xff, v, 0));
    _mm256_storeu_ps(hi, _mm512_maskz_extractf32x8_ps(0xff, v, 1));
}
#endif

/// Six registers of W = 64 / sizeof(T) lanes from W records of six T at `p` (rays: origin x, y,
/// z, direction x, y, z): out[c] lane j = p[6j + c]. Component c of record j sits in the pair of
/// loaded registers (2q, 2q + 1) with q = (6j + c) / (2W), at (6j + c) mod 2W: one two-register
/// permute per pair, blended by pair.
inline void transpose6(const float* p, float* const (&out)[6]) noexcept {
    __m512 a[6];
    for (int i = 0; i < 6; ++i) a[i] = _mm512_loadu_ps(p + 16 * i);
    for (int c = 0; c < 6; ++c) {
        alignas(64) int index[16];
        unsigned mid = 0, high = 0;
        for (int j = 0; j < 16; ++j) {
            const int at = 6 * j + c;
            index[j] = at & 31;
            mid |= unsigned(at >> 5 == 1) << j, high |= unsigned(at >> 5 == 2) << j;
        }
        const __m512i idx = _mm512_load_si512(index);
        __m512 r = _mm512_permutex2var_ps(a[0], idx, a[1]);
        r = _mm512_mask_blend_ps(__mmask16(mid), r, _mm512_permutex2var_ps(a[2], idx, a[3]));
        r = _mm512_mask_blend_ps(__mmask16(high), r, _mm512_permutex2var_ps(a[4], idx, a[5]));
        _mm512_storeu_ps(out[c], r);
    }
}
inline void transpose6(const double* p, double* const (&out)[6]) noexcept {
    __m512d a[6];
    for (int i = 0; i < 6; ++i) a[i] = _mm512_loadu_pd(p + 8 * i);
    for (int c = 0; c < 6; ++c) {
        alignas(64) long long index[8];
        unsigned mid = 0, high = 0;
        for (int j = 0; j < 8; ++j) {
            const int at = 6 * j + c;
            index[j] = at & 15;
            mid |= unsigned(at >> 4 == 1) << j, high |= unsigned(at >> 4 == 2) << j;
        }
        const __m512i idx = _mm512_load_si512(index);
        __m512d r = _mm512_permutex2var_pd(a[0], idx, a[1]);
        r = _mm512_mask_blend_pd(__mmask8(mid), r, _mm512_permutex2var_pd(a[2], idx, a[3]));
        r = _mm512_mask_blend_pd(__mmask8(high), r, _mm512_permutex2var_pd(a[4], idx, a[5]));
        _mm512_storeu_pd(out[c], r);
    }
}

} // namespace detail
} // namespace isin
#endif
