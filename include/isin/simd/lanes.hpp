#pragma once
/// isin — private: the lane types of the Bvh's build and traversal (eight and four lanes of T as
/// GCC/Clang vectors) and the bit helpers of their masks; ISIN_FORCE_PURE turns them all off.
#include <cstdint>
#include <type_traits>

// ISIN_FORCE_PURE: no vector extensions and no intrinsics anywhere in the Bvh (the portable
// scalar forms, for compilers without them and to test those forms).
#if (defined(__GNUC__) || defined(__clang__)) && !defined(ISIN_FORCE_PURE)
#define ISIN_VECTOR_EXTENSIONS 1
#else
#define ISIN_VECTOR_EXTENSIONS 0
#endif

namespace isin {
namespace detail {

/// Index of the lowest set bit of a non-zero mask (unsigned, or 64 bits).
template <class Mask>
inline int lowest_bit(Mask mask) noexcept {
    static_assert(std::is_same_v<Mask, unsigned> || std::is_same_v<Mask, std::uint64_t>, "a mask of 32 or 64 bits");
#if ISIN_VECTOR_EXTENSIONS
    if constexpr (sizeof(Mask) == 8)
        return __builtin_ctzll(mask);
    else
        return __builtin_ctz(mask);
#else
    int k = 0;
    while (!((mask >> k) & 1u)) ++k;
    return k;
#endif
}

/// Number of set bits of a mask.
inline int bit_count(unsigned mask) noexcept {
#if ISIN_VECTOR_EXTENSIONS
    return __builtin_popcount(mask);
#else
    int n = 0;
    for (; mask; mask &= mask - 1) ++n;
    return n;
#endif
}

// Eight and four lanes of T as GCC/Clang vectors. Values of these types never cross a function
// boundary (that would depend on the target's vector ABI); all lane code is written inline.
#if ISIN_VECTOR_EXTENSIONS
template <class T>
struct Lanes8 {
    typedef T type __attribute__((vector_size(8 * sizeof(T))));
};
template <class T>
using L8 = typename Lanes8<T>::type;
template <class T>
struct Lanes4 {
    typedef T type __attribute__((vector_size(4 * sizeof(T))));
};
template <class T>
using L4 = typename Lanes4<T>::type;
#else
template <class T>
struct L4 {
    T v[4];
    T& operator[](int i) noexcept { return v[i]; }
    const T& operator[](int i) const noexcept { return v[i]; }
};
#endif

} // namespace detail
} // namespace isin
