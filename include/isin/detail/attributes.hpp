#pragma once
/// isin — private: function attributes, where the compiler has them.
///  - ISIN_DETAIL_COLD: a rare path (an error, a fallback) kept out of line, so that the hot
///    loop around it stays small.
///  - ISIN_DETAIL_INLINE: a function that must be inlined into its hot loop (a call there costs,
///    and compilers leave some out of loops that grow). Only when optimising: an -O0 build
///    (the tests' debug and sanitizer builds) gains nothing from it and compiles slower.
///  - ISIN_DETAIL_LAMBDA_INLINE: the same for a lambda, written after its parameter list.
///  - ISIN_DETAIL_NOINLINE: a large function kept out of its caller, whose own loop it would
///    otherwise crowd (the stream calls' single-ray loop).
/// And detail::prefetch and prefetch_lines, cache hints.
#include <cstddef>

#if defined(__GNUC__) || defined(__clang__)
#define ISIN_DETAIL_COLD __attribute__((noinline, cold))
#if defined(__OPTIMIZE__)
#define ISIN_DETAIL_INLINE inline __attribute__((always_inline))
#define ISIN_DETAIL_LAMBDA_INLINE __attribute__((always_inline))
#else
#define ISIN_DETAIL_INLINE inline
#define ISIN_DETAIL_LAMBDA_INLINE
#endif
#define ISIN_DETAIL_NOINLINE __attribute__((noinline))
#else
#define ISIN_DETAIL_COLD
#define ISIN_DETAIL_INLINE inline
#define ISIN_DETAIL_NOINLINE
#define ISIN_DETAIL_LAMBDA_INLINE
#endif

namespace isin {
namespace detail {
/// Asks the cache for the line holding `p` (a hint; nothing where the compiler has no builtin).
inline void prefetch(const void* p) noexcept {
#if defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(p);
#else
    (void)p;
#endif
}
/// prefetch for each 64-byte line from `p` on, over `bytes` bytes (a node, a leaf's block, a run
/// of rays).
inline void prefetch_lines(const void* p, std::size_t bytes) noexcept {
    const char* const from = static_cast<const char*>(p);
    for (std::size_t b = 0; b < bytes; b += 64) prefetch(from + b);
}
} // namespace detail
} // namespace isin
