/// isin — private: Scene's crossing counts: how many times a ray crosses the surfaces a Scene
/// holds (the placed meshes, the triangle kinds and the spheres), each mesh's through shared
/// edges and vertices once (bvh/crossings.hpp).
/// scene.hpp includes this file after the class, whose members it defines: included before
/// scene.hpp it holds nothing (and is included again by scene.hpp: `#pragma once` is inside the #if).
#if defined(ISIN_DETAIL_SCENE_CLASS)
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "../bvh/crossings.hpp"
#include "../sphere.hpp"

namespace isin {
namespace detail {

/// How many times the ray crosses sphere `sp`'s surface with t in (0, t_max): the roots of
/// |Ro + t·Rd − C|² = r² (§6's s ± q), 0 for a ray that only touches it (q = 0) or misses.
template <class T>
[[nodiscard]] std::size_t sphere_crossings(const Ray<T>& ray, const Sphere<T>& sp, T t_max) noexcept {
    const SphereApproach<T> h = sphere_approach(ray, sp);
    if (!h.ok) return 0;
    const T m2 = h.squared_miss(ray.direction);
    if (!(m2 < h.r2)) return 0; // §6: passes aside (or only touches); NaN: none
    const T q = h.half_chord(m2);
    const T t_far = h.s + q,
            t_near = h.s > T(0) ? h.root_product() / t_far : h.s - q; // §6: s − q, without cancellation
    return std::size_t(t_near > T(0) && t_near < t_max) + std::size_t(t_far > T(0) && t_far < t_max);
}

} // namespace detail

template <class T, template <class> class... Shapes>
inline std::size_t Scene<T, Shapes...>::count_hits(const Ray<T>& ray, T t_max) const {
    prepare();
    if (!(t_max > T(0)) || !is_finite(ray.origin) || !is_finite(ray.direction)) return 0;
    std::size_t count = 0;
    for_each_kind([&](auto kind, const auto& vec) { count += count_hits_of_kind(kind, vec, ray, t_max); });
    T t = t_max; // never lowered: every placement the ray enters is counted
    for_each_instance(ray, t, [&](std::uint32_t i, T&) {
        count += meshes_[instances_[i].mesh].bvh->count_hits(object_ray(instances_[i], ray), t_max);
        return false;
    });
    return count;
}

template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline std::size_t Scene<T, Shapes...>::count_hits_of_kind(Kind kind, const Objects& vec, const Ray<T>& ray,
                                                           T t_max) const noexcept {
    using Shape = typename Objects::value_type::shape_type;
    const auto& accel = std::get<kind>(accel_);
    std::size_t count = 0;
    if constexpr (is_triangle_kind<Shape>::value) {
        if (accel.triangles) return accel.triangles->count_hits(ray, t_max); // whatever triangle_method is
        detail::WatertightShear<T> shear;
        if (!shear.set(ray.direction)) return 0;
        (void)detail::any_usable_triangle<T>(vec, [&](std::size_t, const Triangle<T>& tri) {
            count += detail::crosses(tri.v0 - ray.origin, tri.v1 - ray.origin, tri.v2 - ray.origin, shear, t_max);
            return false;
        });
    } else if constexpr (std::is_same_v<Shape, Sphere<T>>) {
        if (accel.objects && !accel.objects->empty()) { // the spheres whose boxes the ray enters
            T t = t_max;
            traverse<Visit::any>(*accel.objects, ray, t, [&](std::uint32_t leaf, T&) {
                const auto& l = accel.objects->leaves()[leaf];
                for (std::uint32_t j = l.first; j < l.first + l.count; ++j)
                    count += detail::sphere_crossings(ray, vec[accel.objects->primitives()[j]].shape, t_max);
                return false;
            });
            return count;
        }
        for (std::size_t i = 0; i < vec.size(); ++i) count += detail::sphere_crossings(ray, vec[i].shape, t_max);
    }
    // Other kinds (users' shapes) have no crossing count here: skipped.
    return count;
}

} // namespace isin
#endif
