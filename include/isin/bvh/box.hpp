#pragma once
/// isin — axis-aligned boxes: what a Bvh is built from (a primitive's bounds) and what its nodes
/// hold; plus the lane types the build and traversal use.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <type_traits>
#include <utility>

#include "../detail/huge_pages.hpp"
#include "../vec.hpp"

// ISIN_FORCE_PURE: no vector extensions and no intrinsics anywhere in the Bvh (the portable
// scalar forms, for compilers without them and to test those forms).
#if (defined(__GNUC__) || defined(__clang__)) && !defined(ISIN_FORCE_PURE)
#define ISIN_VECTOR_EXTENSIONS 1
#else
#define ISIN_VECTOR_EXTENSIONS 0
#endif

namespace isin {

/// An axis-aligned box [lo, hi]; the default box is empty (lo = +∞ > hi = −∞). The bounds of a
/// primitive for a Bvh.
template <class T>
struct Box {
    static_assert(std::is_floating_point_v<T>, "isin::Box needs a floating-point type");
    Vertex<T> lo{std::numeric_limits<T>::infinity(), std::numeric_limits<T>::infinity(),
                 std::numeric_limits<T>::infinity()};
    Vertex<T> hi{-std::numeric_limits<T>::infinity(), -std::numeric_limits<T>::infinity(),
                 -std::numeric_limits<T>::infinity()};

    /// Grows to take in p.
    void grow(const Vertex<T>& p) noexcept {
        lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
        hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    /// Grows to the union; an empty b changes nothing.
    void grow(const Box& b) noexcept {
        lo = {std::min(lo.x, b.lo.x), std::min(lo.y, b.lo.y), std::min(lo.z, b.lo.z)};
        hi = {std::max(hi.x, b.hi.x), std::max(hi.y, b.hi.y), std::max(hi.z, b.hi.z)};
    }
    /// True when the box holds at least one point and every bound is finite: a Bvh takes only
    /// such boxes (primitives with others are left out).
    [[nodiscard]] bool usable() const noexcept {
        return lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z && is_finite(lo) && is_finite(hi);
    }
    /// The SAH's measure of the surface: a quarter of the half area, from half extents, so that
    /// no box of finite coordinates gives NaN (an extent hi − lo would overflow for coordinates
    /// beyond ±max/2, and ∞·0 is NaN). Boxes wider than about √max (1.8e19 in float) measure +∞:
    /// their costs compare as unknown and the build splits them at the median. Only ratios of it
    /// matter. 0 for an empty box.
    [[nodiscard]] T area() const noexcept { return area_of_half_extents(hi * T(0.5) - lo * T(0.5)); }
    /// area() of the box whose half extents hi/2 − lo/2 are e (an empty box's are negative).
    [[nodiscard]] static T area_of_half_extents(const Vertex<T>& e) noexcept {
        return e.x < T(0) ? T(0) : e.x * e.y + e.y * e.z + e.z * e.x;
    }
};

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

// A box as two 4-lane vectors (x, y, z, unused), so that growing it is two vector min/max: the
// binning loop's inner operation. Falls back to scalar lanes without vector extensions.
template <class T>
struct Box4 {
    L4<T> lo, hi;
    Box4() noexcept {
        for (int a = 0; a < 4; ++a)
            lo[a] = std::numeric_limits<T>::infinity(), hi[a] = -std::numeric_limits<T>::infinity();
    }
    void grow(const L4<T>& plo, const L4<T>& phi) noexcept {
#if ISIN_VECTOR_EXTENSIONS
        lo = lo < plo ? lo : plo;
        hi = hi > phi ? hi : phi;
#else
        for (int a = 0; a < 4; ++a) lo[a] = std::min(lo[a], plo[a]), hi[a] = std::max(hi[a], phi[a]);
#endif
    }
    void grow(const Box4& b) noexcept { grow(b.lo, b.hi); }
    /// box().area(), straight from the lanes (the build's sweep takes 14 per axis and node).
    [[nodiscard]] T area() const noexcept {
        return Box<T>::area_of_half_extents(
            {hi[0] * T(0.5) - lo[0] * T(0.5), hi[1] * T(0.5) - lo[1] * T(0.5), hi[2] * T(0.5) - lo[2] * T(0.5)});
    }
    [[nodiscard]] Box<T> box() const noexcept {
        Box<T> b;
        if (lo[0] <= hi[0]) b.lo = {lo[0], lo[1], lo[2]}, b.hi = {hi[0], hi[1], hi[2]};
        return b;
    }
};

// An allocator whose value-less construct() leaves trivial values uninitialised, so that
// resizing a vector that the build then fills in parallel does not first zero it serially; its
// blocks of 2 MiB or more are mapped on their own, on huge pages (detail/huge_pages.hpp), and
// taken from and given back to `kept` (a BuildContext's) when it is set.
template <class T>
struct UninitAllocator : std::allocator<T> {
    KeptBlocks* kept = nullptr;
    T* allocate(std::size_t n) {
        if (mapped(n)) return static_cast<T*>(map_huge_pages(n * sizeof(T), kept));
        return std::allocator<T>::allocate(n);
    }
    void deallocate(T* p, std::size_t n) noexcept {
        if (mapped(n)) return unmap_huge_pages(p, n * sizeof(T), kept);
        std::allocator<T>::deallocate(p, n);
    }
    // Whether a block of n values is mapped on its own: one rule for allocate and deallocate.
    static constexpr bool mapped(std::size_t n) noexcept {
        return maps_huge_pages && n <= std::size_t(-1) / 2 / sizeof(T) && n * sizeof(T) >= huge_page_bytes;
    }
    template <class U>
    struct rebind {
        using other = UninitAllocator<U>;
    };
    using is_always_equal = std::false_type; // blocks go back to the `kept` they came from
    using propagate_on_container_copy_assignment = std::true_type;
    using propagate_on_container_move_assignment = std::true_type;
    using propagate_on_container_swap = std::true_type;
    UninitAllocator() = default;
    explicit UninitAllocator(KeptBlocks* k) noexcept : kept(k) {}
    template <class U>
    UninitAllocator(const UninitAllocator<U>& o) noexcept : kept(o.kept) {}
    template <class U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... A>
    void construct(U* p, A&&... a) {
        ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
    }
    template <class U>
    friend bool operator==(const UninitAllocator& a, const UninitAllocator<U>& b) noexcept {
        return a.kept == b.kept;
    }
    template <class U>
    friend bool operator!=(const UninitAllocator& a, const UninitAllocator<U>& b) noexcept {
        return a.kept != b.kept;
    }
};

} // namespace detail
} // namespace isin
