#pragma once
/// isin — private: a register of lanes of T with the arithmetic of T (+ − × ÷, unary −,
/// comparisons into a mask), so that a formula written once as a template runs on one value or
/// on a whole register (ray_lanes.hpp's filters). The widest the target has: AVX-512 (16 floats,
/// 8 doubles) or AVX (8 floats, 4 doubles); none elsewhere or with ISIN_FORCE_PURE, where the
/// callers loop over single values (which optimising compilers may vectorise themselves).
/// Explicit registers, because GCC does not vectorise such loops at -O2 (its "very cheap" cost
/// model), the optimisation level of CMake's RelWithDebInfo and of most distributions' packages.
///
/// For one value the same functions are plain: lane_abs, lane_max, negate_where, lane_sqrt and
/// select (a where the mask holds, else b).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#if (defined(__AVX512F__) || defined(__AVX__)) && !defined(ISIN_FORCE_PURE)
#include <immintrin.h>

#include "avx512.hpp"
#endif

namespace isin {
namespace detail {

template <class T>
T lane_abs(T x) noexcept {
    return std::fabs(x);
}
template <class T>
T lane_max(T a, T b) noexcept {
    return a < b ? b : a; // std::max's choice
}
template <class T>
T negate_where(bool m, T x) noexcept {
    return m ? -x : x;
}
template <class T>
T lane_sqrt(T x) noexcept {
    return std::sqrt(x);
}
/// a·b + c, rounded once where the target has fused multiply-add (FMA) and twice where it has
/// not, for one value as for a register: a formula written with it for every product it adds
/// gives the same bits in both forms, whatever the compiler would have fused on its own.
template <class T>
T lane_fma(T a, T b, T c) noexcept {
#if defined(__FMA__)
    return std::fma(a, b, c);
#else
    return a * b + c;
#endif
}
template <class T>
T select(bool m, T a, T b) noexcept {
    return m ? a : b;
}

#if defined(__AVX512F__) && !defined(ISIN_FORCE_PURE)
#define ISIN_DETAIL_LANE_PACKS 1
/// A register's comparison result: bit k for lane k.
template <unsigned Full>
struct PackMask {
    unsigned m;
    [[nodiscard]] std::uint64_t bits() const noexcept { return m; }
    friend PackMask operator|(PackMask a, PackMask b) noexcept { return {a.m | b.m}; }
    friend PackMask operator&(PackMask a, PackMask b) noexcept { return {a.m & b.m}; }
    friend PackMask operator!(PackMask a) noexcept { return {~a.m & Full}; }
};

template <class T>
struct Pack;

template <>
struct Pack<float> {
    static constexpr int width = 16;
    using Mask = PackMask<0xffffu>;
    __m512 v;
    Pack(float x) noexcept : v(_mm512_set1_ps(x)) {} // NOLINT: implicit, as a float converts
    explicit Pack(__m512 r) noexcept : v(r) {}
    static Pack load(const float* p) noexcept { return Pack(_mm512_load_ps(p)); }
    void store(float* p) const noexcept { _mm512_store_ps(p, v); }
    /// The lanes, each in [0, 256), truncated to bytes at p (p[0 … 16)).
    void store_bytes(std::uint8_t* p) const noexcept {
        // the masked forms: g++ 12 warns of the plain ones' undefined sources (-Wmaybe-uninitialized)
        _mm512_mask_cvtepi32_storeu_epi8(p, 0xffff, _mm512_maskz_cvttps_epi32(0xffff, v));
    }
    friend Pack operator+(Pack a, Pack b) noexcept { return Pack(_mm512_add_ps(a.v, b.v)); }
    friend Pack operator-(Pack a, Pack b) noexcept { return Pack(_mm512_sub_ps(a.v, b.v)); }
    friend Pack operator*(Pack a, Pack b) noexcept { return Pack(_mm512_mul_ps(a.v, b.v)); }
    friend Pack operator/(Pack a, Pack b) noexcept { return Pack(_mm512_div_ps(a.v, b.v)); }
    friend Pack operator-(Pack a) noexcept { return negate_where(Mask{0xffffu}, a); }
    friend Mask operator<(Pack a, Pack b) noexcept { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LT_OQ)}; }
    friend Mask operator>(Pack a, Pack b) noexcept { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GT_OQ)}; }
    friend Mask operator<=(Pack a, Pack b) noexcept { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LE_OQ)}; }
    friend Mask operator>=(Pack a, Pack b) noexcept { return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GE_OQ)}; }
    friend Mask operator!=(Pack a, Pack b) noexcept {
        return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_NEQ_UQ)};
    } // NaN ≠ anything
    friend Pack lane_abs(Pack a) noexcept { return Pack(_mm512_abs_ps(a.v)); }
    friend Pack lane_max(Pack a, Pack b) noexcept { return Pack(max16(a.v, b.v)); }
    friend Pack lane_sqrt(Pack a) noexcept { return Pack(sqrt16(a.v)); }
    friend Pack lane_fma(Pack a, Pack b, Pack c) noexcept { return Pack(_mm512_fmadd_ps(a.v, b.v, c.v)); }
    friend Pack select(Mask m, Pack a, Pack b) noexcept { return Pack(_mm512_mask_blend_ps(__mmask16(m.m), b.v, a.v)); }
    friend Pack negate_where(Mask m, Pack a) noexcept {
        const __m512i x = _mm512_castps_si512(a.v);
        return Pack(_mm512_castsi512_ps(_mm512_mask_xor_epi32(x, __mmask16(m.m), x, _mm512_set1_epi32(INT32_MIN))));
    }
};

template <>
struct Pack<double> {
    static constexpr int width = 8;
    using Mask = PackMask<0xffu>;
    __m512d v;
    Pack(double x) noexcept : v(_mm512_set1_pd(x)) {} // NOLINT: implicit, as a double converts
    explicit Pack(__m512d r) noexcept : v(r) {}
    static Pack load(const double* p) noexcept { return Pack(_mm512_load_pd(p)); }
    void store(double* p) const noexcept { _mm512_store_pd(p, v); }
    /// The lanes, each in [0, 256), truncated to bytes at p (p[0 … 8)).
    void store_bytes(std::uint8_t* p) const noexcept {
        const __m512i wide =
            _mm512_maskz_inserti64x4(0xff, _mm512_setzero_si512(), _mm512_maskz_cvttpd_epi32(0xff, v), 0);
        _mm512_mask_cvtepi32_storeu_epi8(p, 0xff, wide);
    }
    friend Pack operator+(Pack a, Pack b) noexcept { return Pack(_mm512_add_pd(a.v, b.v)); }
    friend Pack operator-(Pack a, Pack b) noexcept { return Pack(_mm512_sub_pd(a.v, b.v)); }
    friend Pack operator*(Pack a, Pack b) noexcept { return Pack(_mm512_mul_pd(a.v, b.v)); }
    friend Pack operator/(Pack a, Pack b) noexcept { return Pack(_mm512_div_pd(a.v, b.v)); }
    friend Pack operator-(Pack a) noexcept { return negate_where(Mask{0xffu}, a); }
    friend Mask operator<(Pack a, Pack b) noexcept { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_LT_OQ)}; }
    friend Mask operator>(Pack a, Pack b) noexcept { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_GT_OQ)}; }
    friend Mask operator<=(Pack a, Pack b) noexcept { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_LE_OQ)}; }
    friend Mask operator>=(Pack a, Pack b) noexcept { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_GE_OQ)}; }
    friend Mask operator!=(Pack a, Pack b) noexcept {
        return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_NEQ_UQ)};
    } // NaN ≠ anything
    friend Pack lane_abs(Pack a) noexcept { return Pack(_mm512_abs_pd(a.v)); }
    friend Pack lane_max(Pack a, Pack b) noexcept { return Pack(max8(a.v, b.v)); }
    friend Pack lane_sqrt(Pack a) noexcept { return Pack(sqrt8(a.v)); }
    friend Pack lane_fma(Pack a, Pack b, Pack c) noexcept { return Pack(_mm512_fmadd_pd(a.v, b.v, c.v)); }
    friend Pack select(Mask m, Pack a, Pack b) noexcept { return Pack(_mm512_mask_blend_pd(__mmask8(m.m), b.v, a.v)); }
    friend Pack negate_where(Mask m, Pack a) noexcept {
        const __m512i x = _mm512_castpd_si512(a.v);
        return Pack(_mm512_castsi512_pd(_mm512_mask_xor_epi64(x, __mmask8(m.m), x, _mm512_set1_epi64(INT64_MIN))));
    }
};

#elif defined(__AVX__) && !defined(ISIN_FORCE_PURE)
#define ISIN_DETAIL_LANE_PACKS 1
/// A register's comparison result (of floats, of doubles): all ones in the lanes where it holds.
template <class T>
struct PackMask;
template <>
struct PackMask<float> {
    __m256 m;
    [[nodiscard]] std::uint64_t bits() const noexcept { return std::uint64_t(unsigned(_mm256_movemask_ps(m))); }
    friend PackMask operator|(PackMask a, PackMask b) noexcept { return {_mm256_or_ps(a.m, b.m)}; }
    friend PackMask operator&(PackMask a, PackMask b) noexcept { return {_mm256_and_ps(a.m, b.m)}; }
    friend PackMask operator!(PackMask a) noexcept {
        return {_mm256_xor_ps(a.m, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))};
    }
};
template <>
struct PackMask<double> {
    __m256d m;
    [[nodiscard]] std::uint64_t bits() const noexcept { return std::uint64_t(unsigned(_mm256_movemask_pd(m))); }
    friend PackMask operator|(PackMask a, PackMask b) noexcept { return {_mm256_or_pd(a.m, b.m)}; }
    friend PackMask operator&(PackMask a, PackMask b) noexcept { return {_mm256_and_pd(a.m, b.m)}; }
    friend PackMask operator!(PackMask a) noexcept {
        return {_mm256_xor_pd(a.m, _mm256_castsi256_pd(_mm256_set1_epi64x(-1)))};
    }
};

template <class T>
struct Pack;

template <>
struct Pack<float> {
    static constexpr int width = 8;
    using Mask = PackMask<float>;
    __m256 v;
    Pack(float x) noexcept : v(_mm256_set1_ps(x)) {} // NOLINT: implicit, as a float converts
    explicit Pack(__m256 r) noexcept : v(r) {}
    static Pack load(const float* p) noexcept { return Pack(_mm256_load_ps(p)); }
    void store(float* p) const noexcept { _mm256_store_ps(p, v); }
    /// The lanes, each in [0, 256), truncated to bytes at p (p[0 … 8)).
    void store_bytes(std::uint8_t* p) const noexcept {
        const __m256i i = _mm256_cvttps_epi32(v);
        const __m128i words = _mm_packs_epi32(_mm256_castsi256_si128(i), _mm256_extractf128_si256(i, 1));
        _mm_storel_epi64(reinterpret_cast<__m128i*>(p), _mm_packus_epi16(words, words));
    }
    friend Pack operator+(Pack a, Pack b) noexcept { return Pack(_mm256_add_ps(a.v, b.v)); }
    friend Pack operator-(Pack a, Pack b) noexcept { return Pack(_mm256_sub_ps(a.v, b.v)); }
    friend Pack operator*(Pack a, Pack b) noexcept { return Pack(_mm256_mul_ps(a.v, b.v)); }
    friend Pack operator/(Pack a, Pack b) noexcept { return Pack(_mm256_div_ps(a.v, b.v)); }
    friend Pack operator-(Pack a) noexcept { return Pack(_mm256_xor_ps(a.v, _mm256_set1_ps(-0.0f))); }
    friend Mask operator<(Pack a, Pack b) noexcept { return {_mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ)}; }
    friend Mask operator>(Pack a, Pack b) noexcept { return {_mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ)}; }
    friend Mask operator<=(Pack a, Pack b) noexcept { return {_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)}; }
    friend Mask operator>=(Pack a, Pack b) noexcept { return {_mm256_cmp_ps(a.v, b.v, _CMP_GE_OQ)}; }
    friend Mask operator!=(Pack a, Pack b) noexcept { return {_mm256_cmp_ps(a.v, b.v, _CMP_NEQ_UQ)}; } // NaN ≠ anything
    friend Pack lane_abs(Pack a) noexcept { return Pack(_mm256_andnot_ps(_mm256_set1_ps(-0.0f), a.v)); }
    friend Pack lane_max(Pack a, Pack b) noexcept { return Pack(_mm256_max_ps(a.v, b.v)); }
    friend Pack lane_sqrt(Pack a) noexcept { return Pack(_mm256_sqrt_ps(a.v)); }
#if defined(__FMA__)
    friend Pack lane_fma(Pack a, Pack b, Pack c) noexcept { return Pack(_mm256_fmadd_ps(a.v, b.v, c.v)); }
#else
    friend Pack lane_fma(Pack a, Pack b, Pack c) noexcept { return a * b + c; }
#endif
    friend Pack select(Mask m, Pack a, Pack b) noexcept { return Pack(_mm256_blendv_ps(b.v, a.v, m.m)); }
    friend Pack negate_where(Mask m, Pack a) noexcept {
        return Pack(_mm256_xor_ps(a.v, _mm256_and_ps(m.m, _mm256_set1_ps(-0.0f))));
    }
};

template <>
struct Pack<double> {
    static constexpr int width = 4;
    using Mask = PackMask<double>;
    __m256d v;
    Pack(double x) noexcept : v(_mm256_set1_pd(x)) {} // NOLINT: implicit, as a double converts
    explicit Pack(__m256d r) noexcept : v(r) {}
    static Pack load(const double* p) noexcept { return Pack(_mm256_load_pd(p)); }
    void store(double* p) const noexcept { _mm256_store_pd(p, v); }
    /// The lanes, each in [0, 256), truncated to bytes at p (p[0 … 4)).
    void store_bytes(std::uint8_t* p) const noexcept {
        const __m128i words = _mm_packs_epi32(_mm256_cvttpd_epi32(v), _mm_setzero_si128());
        const int bytes = _mm_cvtsi128_si32(_mm_packus_epi16(words, words));
        std::memcpy(p, &bytes, 4);
    }
    friend Pack operator+(Pack a, Pack b) noexcept { return Pack(_mm256_add_pd(a.v, b.v)); }
    friend Pack operator-(Pack a, Pack b) noexcept { return Pack(_mm256_sub_pd(a.v, b.v)); }
    friend Pack operator*(Pack a, Pack b) noexcept { return Pack(_mm256_mul_pd(a.v, b.v)); }
    friend Pack operator/(Pack a, Pack b) noexcept { return Pack(_mm256_div_pd(a.v, b.v)); }
    friend Pack operator-(Pack a) noexcept { return Pack(_mm256_xor_pd(a.v, _mm256_set1_pd(-0.0))); }
    friend Mask operator<(Pack a, Pack b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ)}; }
    friend Mask operator>(Pack a, Pack b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_GT_OQ)}; }
    friend Mask operator<=(Pack a, Pack b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_LE_OQ)}; }
    friend Mask operator>=(Pack a, Pack b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ)}; }
    friend Mask operator!=(Pack a, Pack b) noexcept { return {_mm256_cmp_pd(a.v, b.v, _CMP_NEQ_UQ)}; } // NaN ≠ anything
    friend Pack lane_abs(Pack a) noexcept { return Pack(_mm256_andnot_pd(_mm256_set1_pd(-0.0), a.v)); }
    friend Pack lane_max(Pack a, Pack b) noexcept { return Pack(_mm256_max_pd(a.v, b.v)); }
    friend Pack lane_sqrt(Pack a) noexcept { return Pack(_mm256_sqrt_pd(a.v)); }
#if defined(__FMA__)
    friend Pack lane_fma(Pack a, Pack b, Pack c) noexcept { return Pack(_mm256_fmadd_pd(a.v, b.v, c.v)); }
#else
    friend Pack lane_fma(Pack a, Pack b, Pack c) noexcept { return a * b + c; }
#endif
    friend Pack select(Mask m, Pack a, Pack b) noexcept { return Pack(_mm256_blendv_pd(b.v, a.v, m.m)); }
    friend Pack negate_where(Mask m, Pack a) noexcept {
        return Pack(_mm256_xor_pd(a.v, _mm256_and_pd(m.m, _mm256_set1_pd(-0.0))));
    }
};
#endif

/// The lanes where a comparison of one value holds: bit 0.
inline std::uint64_t lane_bits(bool m) noexcept { return m ? 1u : 0u; }
inline std::uint64_t lane_bits(int m) noexcept { return m != 0 ? 1u : 0u; } // bool & bool
#if defined(ISIN_DETAIL_LANE_PACKS)
template <class M>
std::uint64_t lane_bits(const M& m) noexcept {
    return m.bits();
}
#endif

/// A register of lanes as passes over arrays of T take one: Pack<T> where the target has
/// registers of lanes, else a single value.
template <class T>
struct LaneRegister {
#if defined(ISIN_DETAIL_LANE_PACKS)
    using V = Pack<T>;
    static constexpr std::size_t width = V::width;
    static V load(const T* p) noexcept { return V::load(p); }
    static void store(const V& v, T* p) noexcept { v.store(p); }
#else
    using V = T;
    static constexpr std::size_t width = 1;
    static V load(const T* p) noexcept { return *p; }
    static void store(V v, T* p) noexcept { *p = v; }
#endif
};

/// A value of T (V = T) or a register of lanes (V = LaneRegister's) at p, and back.
template <class T, class V>
V load_lanes(const T* p) noexcept {
    if constexpr (std::is_same_v<V, T>)
        return *p;
    else
        return LaneRegister<T>::load(p);
}
template <class T, class V>
void store_lanes(const V& v, T* p) noexcept {
    if constexpr (std::is_same_v<V, T>)
        *p = v;
    else
        LaneRegister<T>::store(v, p);
}

/// A value (V = T) or a register of lanes, each in [0, 256), truncated to bytes at p (as
/// static_cast<std::uint8_t> truncates).
template <class T, class V>
void store_bytes(const V& v, std::uint8_t* p) noexcept {
    if constexpr (std::is_same_v<V, T>)
        *p = static_cast<std::uint8_t>(v);
    else
        v.store_bytes(p);
}

/// x·y − z·w with the rounding lane_fma gives it.
template <class V>
V lane_cross_term(V x, V y, V z, V w) noexcept {
    return lane_fma(x, y, -(z * w));
}
/// a·b of vectors in components, (ax·bx + ay·by) + az·bz as dot() (vec.hpp) sums it, each
/// product added as lane_fma adds it.
template <class V>
V lane_dot(V ax, V ay, V az, V bx, V by, V bz) noexcept {
    return lane_fma(az, bz, lane_fma(ay, by, ax * bx));
}

/// The three components of a vector of one value or of a register of lanes.
template <class V>
struct LaneVector {
    V x, y, z;
};

/// reflect() (vec.hpp, §7: d − 2(d·N)N) of the vectors (dx, dy, dz) about (nx, ny, nz), of one
/// value or a register of lanes; each product added as lane_fma adds it.
template <class T, class V>
LaneVector<V> lane_reflect(V dx, V dy, V dz, V nx, V ny, V nz) noexcept {
    const V twice = T(2) * lane_dot(dx, dy, dz, nx, ny, nz);
    return {lane_fma(-twice, nx, dx), lane_fma(-twice, ny, dy), lane_fma(-twice, nz, dz)};
}

/// normalize() (vec.hpp, §2: R / |R|) of the vectors (x, y, z) of one value or a register of
/// lanes, with lane_dot's rounding: (0, 0, 0) where the length is 0 or not finite. Returns the
/// length |R| it divided by.
template <class T, class V>
V lane_normalize(V& x, V& y, V& z) noexcept {
    const V len = lane_sqrt(lane_dot(x, y, z, x, y, z)); // §2: |R|
    const auto has_direction = (len > T(0)) & (len < std::numeric_limits<T>::infinity());
    x = select(has_direction, x / len, V(T(0)));
    y = select(has_direction, y / len, V(T(0)));
    z = select(has_direction, z / len, V(T(0)));
    return len;
}

} // namespace detail
} // namespace isin
