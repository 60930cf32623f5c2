#pragma once
/// isin — axis-aligned boxes: what a Bvh is built from (a primitive's bounds) and what its nodes
/// hold; the build's four-lane box (the lane types are simd/lanes.hpp's).
#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <type_traits>
#include <utility>

#include "../detail/huge_pages.hpp"
#include "../simd/lanes.hpp"
#include "../vec.hpp"

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

} // namespace detail
} // namespace isin
