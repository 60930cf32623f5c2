#pragma once
/// isin — eight square roots at once (the point queries: bvh/closest_point.hpp, solid.hpp),
/// at once, in AVX registers where the target has them (a plain std::sqrt may set errno, so
/// compilers do not vectorise it), one by one elsewhere; the same correctly rounded results.
#include <cmath>

#if defined(__AVX__) && !defined(ISIN_FORCE_PURE)
#include <immintrin.h>
#endif

namespace isin {
namespace detail {

/// out[k] = √x[k] for the 8 lanes (NaN for a negative or NaN x[k]).
inline void sqrt8(const float (&x)[8], float (&out)[8]) noexcept {
#if defined(__AVX__) && !defined(ISIN_FORCE_PURE)
    _mm256_storeu_ps(out, _mm256_sqrt_ps(_mm256_loadu_ps(x)));
#else
    for (int k = 0; k < 8; ++k) out[k] = std::sqrt(x[k]);
#endif
}
/// out[k] = √x[k] for the 8 lanes (NaN for a negative or NaN x[k]).
inline void sqrt8(const double (&x)[8], double (&out)[8]) noexcept {
#if defined(__AVX__) && !defined(ISIN_FORCE_PURE)
    _mm256_storeu_pd(out, _mm256_sqrt_pd(_mm256_loadu_pd(x)));
    _mm256_storeu_pd(out + 4, _mm256_sqrt_pd(_mm256_loadu_pd(x + 4)));
#else
    for (int k = 0; k < 8; ++k) out[k] = std::sqrt(x[k]);
#endif
}

} // namespace detail
} // namespace isin
