#pragma once
/// isin — the result of an intersection test.
#include <cstdint>
#include <limits>
#include <type_traits>

namespace isin {

/// Where a ray meets a primitive: distance `t` along the ray (in units of |direction|), the
/// barycentrics `u`, `v` (P = V0 + u(V1−V0) + v(V2−V0), note §10) where the method gives them,
/// else 0, and which primitive it is where the caller has more than one. The one result type of
/// every test: a single-primitive kernel, a TriangleBatch, a Bvh and a Scene. A miss has
/// t = +∞ and converts to false; hits compare by t (nearest first).
template <class T>
struct Hit {
    static_assert(std::is_floating_point_v<T>, "isin::Hit needs a floating-point type");
    static constexpr std::uint32_t none = ~std::uint32_t(0);
    T t = std::numeric_limits<T>::infinity();
    T u = T(0);
    T v = T(0);
    /// Index of the primitive: in the triangles or mesh a Bvh was built from, in a batch, in a
    /// scene kind's objects or a placed mesh's triangles. `none` from single-primitive tests.
    std::uint32_t primitive = none;
    /// Which geometry of a Scene holds it (Scene::intersect); `none` elsewhere.
    std::uint32_t geometry = none;

    /// True for a hit: t is finite (a miss keeps t = +∞).
    constexpr explicit operator bool() const noexcept { return t < std::numeric_limits<T>::infinity(); }

    /// The miss value.
    [[nodiscard]] static constexpr Hit miss() noexcept { return Hit{}; }
    /// A hit at t with barycentrics u, v.
    [[nodiscard]] static constexpr Hit at(T t_hit, T u_hit = T(0), T v_hit = T(0)) noexcept {
        return Hit{t_hit, u_hit, v_hit};
    }
};

} // namespace isin
