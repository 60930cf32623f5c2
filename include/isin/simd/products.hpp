#pragma once
/// isin — private: a·b − c·d by Kahan's algorithm written once (lane_difference_of_products), for
/// one value and for each ISA's registers (8 and 16 floats, 4 doubles), over the fused operations
/// it takes: lane_mul, lane_add, lane_fmsub (a·b − c) and lane_fnmadd (c − a·b), each rounded
/// once, with an overload per type; and for the registers lane_sub and lane_fma (a·b + c, as
/// pack.hpp's for one value), which the watertight test's lane forms take (triangle.hpp).
#include <cmath>
#include <type_traits>

#include "pack.hpp" // lane_fma of one value and of a Pack

#if defined(__AVX2__) && defined(__FMA__) && !defined(ISIN_FORCE_PURE)
#include <immintrin.h>
#endif

// Forced inline when optimising (detail/attributes.hpp's ISIN_DETAIL_INLINE, which simd/ may not
// include): the leaf tests' hot loops call these.
#if (defined(__GNUC__) || defined(__clang__)) && defined(__OPTIMIZE__)
#define ISIN_SIMD_INLINE inline __attribute__((always_inline))
#else
#define ISIN_SIMD_INLINE inline
#endif

namespace isin {
namespace detail {

// One value (float, double, long double): std::fma, fused always (an instruction with FMA, a
// library call otherwise).
template <class T, std::enable_if_t<std::is_floating_point_v<T>, int> = 0>
ISIN_SIMD_INLINE T lane_mul(T a, T b) noexcept {
    return a * b;
}
template <class T, std::enable_if_t<std::is_floating_point_v<T>, int> = 0>
ISIN_SIMD_INLINE T lane_add(T a, T b) noexcept {
    return a + b;
}
template <class T, std::enable_if_t<std::is_floating_point_v<T>, int> = 0>
ISIN_SIMD_INLINE T lane_fmsub(T a, T b, T c) noexcept {
    return std::fma(a, b, -c);
}
template <class T, std::enable_if_t<std::is_floating_point_v<T>, int> = 0>
ISIN_SIMD_INLINE T lane_fnmadd(T a, T b, T c) noexcept {
    return std::fma(-a, b, c);
}

#if defined(__AVX2__) && defined(__FMA__) && !defined(ISIN_FORCE_PURE)
ISIN_SIMD_INLINE __m256 lane_mul(__m256 a, __m256 b) noexcept { return _mm256_mul_ps(a, b); }
ISIN_SIMD_INLINE __m256d lane_mul(__m256d a, __m256d b) noexcept { return _mm256_mul_pd(a, b); }
ISIN_SIMD_INLINE __m256 lane_add(__m256 a, __m256 b) noexcept { return _mm256_add_ps(a, b); }
ISIN_SIMD_INLINE __m256d lane_add(__m256d a, __m256d b) noexcept { return _mm256_add_pd(a, b); }
ISIN_SIMD_INLINE __m256 lane_sub(__m256 a, __m256 b) noexcept { return _mm256_sub_ps(a, b); }
ISIN_SIMD_INLINE __m256d lane_sub(__m256d a, __m256d b) noexcept { return _mm256_sub_pd(a, b); }
ISIN_SIMD_INLINE __m256 lane_fmsub(__m256 a, __m256 b, __m256 c) noexcept { return _mm256_fmsub_ps(a, b, c); }
ISIN_SIMD_INLINE __m256d lane_fmsub(__m256d a, __m256d b, __m256d c) noexcept { return _mm256_fmsub_pd(a, b, c); }
ISIN_SIMD_INLINE __m256 lane_fma(__m256 a, __m256 b, __m256 c) noexcept { return _mm256_fmadd_ps(a, b, c); }
ISIN_SIMD_INLINE __m256d lane_fma(__m256d a, __m256d b, __m256d c) noexcept { return _mm256_fmadd_pd(a, b, c); }
ISIN_SIMD_INLINE __m256 lane_fnmadd(__m256 a, __m256 b, __m256 c) noexcept { return _mm256_fnmadd_ps(a, b, c); }
ISIN_SIMD_INLINE __m256d lane_fnmadd(__m256d a, __m256d b, __m256d c) noexcept { return _mm256_fnmadd_pd(a, b, c); }
#if defined(__AVX512F__)
ISIN_SIMD_INLINE __m512 lane_mul(__m512 a, __m512 b) noexcept { return _mm512_mul_ps(a, b); }
ISIN_SIMD_INLINE __m512 lane_add(__m512 a, __m512 b) noexcept { return _mm512_add_ps(a, b); }
ISIN_SIMD_INLINE __m512 lane_sub(__m512 a, __m512 b) noexcept { return _mm512_sub_ps(a, b); }
ISIN_SIMD_INLINE __m512 lane_fmsub(__m512 a, __m512 b, __m512 c) noexcept { return _mm512_fmsub_ps(a, b, c); }
ISIN_SIMD_INLINE __m512 lane_fma(__m512 a, __m512 b, __m512 c) noexcept { return _mm512_fmadd_ps(a, b, c); }
ISIN_SIMD_INLINE __m512 lane_fnmadd(__m512 a, __m512 b, __m512 c) noexcept { return _mm512_fnmadd_ps(a, b, c); }
#endif
#endif

/// a·b − c·d by Kahan's algorithm with fused multiply-subtract (Jeannerod, Louvet & Muller,
/// "Further analysis of Kahan's algorithm for the accurate computation of 2×2 determinants",
/// Math. Comp. 82, 2013): within 2 ulps, so its sign is exact unless a product over- or
/// underflows. One value or a register, the same bits in each.
template <class V>
ISIN_SIMD_INLINE V lane_difference_of_products(V a, V b, V c, V d) noexcept {
    const V cd = lane_mul(c, d);
    const V error = lane_fnmadd(c, d, cd);        // Kahan: e = cd − c·d, exact
    return lane_add(lane_fmsub(a, b, cd), error); // Kahan: (a·b − cd) + e
}

/// lane_difference_of_products as a function object, for the callers that take one.
struct LaneDifferenceOfProducts {
    template <class V>
    ISIN_SIMD_INLINE V operator()(V a, V b, V c, V d) const noexcept {
        return lane_difference_of_products(a, b, c, d);
    }
};

} // namespace detail
} // namespace isin
