#pragma once
/// isin — private: the AVX-512 operations whose plain intrinsics GCC 12 warns about, spelled
/// with full masks (the maskz forms): its _mm512_max_ps (and _pd), _mm512_min_ps, _mm512_sqrt_ps
/// (and _pd), _mm512_broadcast_f32x8
/// and the 256-bit halves of a register pass an uninitialised operand of their own
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

#if defined(__AVX512DQ__)
/// The 8 floats at `p` (32-byte aligned) in both halves of a register.
inline __m512 load8_twice(const float* p) noexcept { return _mm512_maskz_broadcast_f32x8(0xffff, _mm256_load_ps(p)); }
/// Stores the register's lanes 0-7 at `lo` and 8-15 at `hi`.
inline void store_halves(__m512 v, float* lo, float* hi) noexcept {
    _mm256_storeu_ps(lo, _mm512_maskz_extractf32x8_ps(0xff, v, 0));
    _mm256_storeu_ps(hi, _mm512_maskz_extractf32x8_ps(0xff, v, 1));
}
#endif

} // namespace detail
} // namespace isin
#endif
