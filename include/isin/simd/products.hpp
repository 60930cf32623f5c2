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

// A register type V with intrinsics prefix_op_suffix: the same six operations for each.
#define ISIN_SIMD_LANE_OPERATIONS(V, prefix, suffix)                                                                   \
    ISIN_SIMD_INLINE V lane_mul(V a, V b) noexcept { return prefix##_mul_##suffix(a, b); }                             \
    ISIN_SIMD_INLINE V lane_add(V a, V b) noexcept { return prefix##_add_##suffix(a, b); }                             \
    ISIN_SIMD_INLINE V lane_sub(V a, V b) noexcept { return prefix##_sub_##suffix(a, b); }                             \
    ISIN_SIMD_INLINE V lane_fmsub(V a, V b, V c) noexcept { return prefix##_fmsub_##suffix(a, b, c); }                 \
    ISIN_SIMD_INLINE V lane_fma(V a, V b, V c) noexcept { return prefix##_fmadd_##suffix(a, b, c); }                   \
    ISIN_SIMD_INLINE V lane_fnmadd(V a, V b, V c) noexcept { return prefix##_fnmadd_##suffix(a, b, c); }
#if defined(__AVX2__) && defined(__FMA__) && !defined(ISIN_FORCE_PURE)
ISIN_SIMD_LANE_OPERATIONS(__m256, _mm256, ps)
ISIN_SIMD_LANE_OPERATIONS(__m256d, _mm256, pd)
#if defined(__AVX512F__)
ISIN_SIMD_LANE_OPERATIONS(__m512, _mm512, ps)
#endif
#endif
#undef ISIN_SIMD_LANE_OPERATIONS

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
