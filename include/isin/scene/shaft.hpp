/// isin — private: Scene's shaft test: whether anything it holds may meet the shaft from a point
/// to a RectLight (bvh/shaft.hpp), over every kind and each placed mesh in its own space.
/// scene.hpp includes this file after the class, whose members it defines: included before
/// scene.hpp it holds nothing (and is included again by scene.hpp: `#pragma once` is inside the #if).
#if defined(ISIN_DETAIL_SCENE_CLASS)
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "../bvh/shaft.hpp"

namespace isin {

template <class T, template <class> class... Shapes>
inline bool Scene<T, Shapes...>::shaft_clear(const Vertex<T>& from, const RectLight<T>& light) const {
    prepare();
    Vertex<T> v[8]; // the near end (the tip cut off), then the light's corners
    for (int c = 0; c < 4; ++c) {
        const Vertex<T> q = light_corner(light, c);
        v[c] = from + shaft_tip * (q - from), v[4 + c] = q;
    }
    const T exact[3] = {T(0), T(0), T(0)};
    const detail::Shaft<T> world = detail::Shaft<T>::hull(v, exact);
    if (!world.usable) return false;
    bool meets = false;
    for_each_kind([&](auto kind, const auto& vec) { meets = meets || kind_meets_shaft(kind, vec, world); });
    if (meets) return false;
    const auto placement = [&](std::uint32_t i) {
        const Instance& inst = instances_[i];
        const T box_lo[3] = {inst.box.lo.x, inst.box.lo.y, inst.box.lo.z};
        const T box_hi[3] = {inst.box.hi.x, inst.box.hi.y, inst.box.hi.z};
        if (!world.box_may_meet(box_lo, box_hi)) return false;
        const Bvh<T>& bvh = *meshes_[inst.mesh].bvh;
        if (inst.identity) return detail::triangles_may_meet(bvh.tree(), bvh.blocks(), world);
        Vertex<T> w[8]; // the shaft in mesh space (an affine map keeps the hull); error: what rounding adds
        T error[3] = {T(0), T(0), T(0)};
        for (int k = 0; k < 8; ++k) {
            w[k] = inst.to_object.point(v[k]);
            for (int r = 0; r < 3; ++r) {
                T terms = std::fabs(component(inst.to_object.d, r));
                for (int a = 0; a < 3; ++a) terms += std::fabs(inst.to_object.m[r][a] * component(v[k], a));
                error[r] = std::max(error[r], T(4) * std::numeric_limits<T>::epsilon() * terms);
            }
        }
        const detail::Shaft<T> local = detail::Shaft<T>::hull(w, error);
        return !local.usable || detail::triangles_may_meet(bvh.tree(), bvh.blocks(), local);
    };
    if (top_) {
        return !detail::tree_may_meet(*top_, world, [&](std::uint32_t leaf) {
            const auto& l = top_->leaves()[leaf];
            for (std::uint32_t j = l.first; j < l.first + l.count; ++j)
                if (placement(top_->primitives()[j])) return true;
            return false;
        });
    }
    for (std::size_t i = 0; i < instances_.size(); ++i)
        if (placement(static_cast<std::uint32_t>(i))) return false;
    return true;
}

template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline bool Scene<T, Shapes...>::kind_meets_shaft(Kind kind, const Objects& vec,
                                                  const detail::Shaft<T>& shaft) const noexcept {
    using Shape = typename Objects::value_type::shape_type;
    const auto& accel = std::get<kind>(accel_);
    if (vec.empty()) return false;
    if constexpr (is_triangle_kind<Shape>::value) {
        if (accel.triangles)
            return detail::triangles_may_meet(accel.triangles->tree(), accel.triangles->blocks(), shaft);
        return detail::any_usable_triangle<T>(
            vec, [&](std::size_t, const Triangle<T>& tri) { return shaft.triangle_may_meet(tri.v0, tri.v1, tri.v2); });
    } else {
        const auto meets = [&](std::uint32_t i) {
            if constexpr (std::is_same_v<Shape, Sphere<T>>) {
                return shaft.ball_may_meet(vec[i].shape.center, vec[i].shape.radius);
            } else if constexpr (detail::has_bounds<T, Shape>::value) {
                const Box<T> b = bounds(vec[i].shape);
                const T box_lo[3] = {b.lo.x, b.lo.y, b.lo.z}, box_hi[3] = {b.hi.x, b.hi.y, b.hi.z};
                return shaft.box_may_meet(box_lo, box_hi);
            } else {
                return true; // a kind without bounds may be anywhere
            }
        };
        if (accel.objects && !accel.objects->empty()) {
            const BvhTree<T>& tree = *accel.objects;
            return detail::tree_may_meet(tree, shaft, [&](std::uint32_t leaf) {
                const auto& l = tree.leaves()[leaf];
                for (std::uint32_t j = l.first; j < l.first + l.count; ++j)
                    if (meets(tree.primitives()[j])) return true;
                return false;
            });
        }
        for (std::size_t i = 0; i < vec.size(); ++i)
            if (meets(static_cast<std::uint32_t>(i))) return true;
        return false;
    }
}

} // namespace isin
#endif
