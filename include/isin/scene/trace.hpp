/// isin — private: Scene's single-ray members: nearest hit, occlusion and transmittance of one ray, kind by
/// kind and through the placed meshes (note §3, §5), and the surface at a hit.
/// scene.hpp includes this file after the class, whose members it defines: included before
/// scene.hpp it holds nothing (and is included again by scene.hpp: `#pragma once` is inside the #if).
#if defined(ISIN_DETAIL_SCENE_CLASS)
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace isin {

template <class T, template <class> class... Shapes>
inline Hit<T> Scene<T, Shapes...>::intersect(const Ray<T>& ray, T t_max, const Culled* culled) const {
    prepare();
    Hit<T> best;
    T t = t_max;
    for_each_kind([&](auto kind, const auto& vec) { nearest_of_kind(kind, vec, ray, culled, t, best); });
    if (!instances_.empty()) nearest_placement(ray, t, culled && culled->mesh_backfaces, best);
    return best;
}

template <class T, template <class> class... Shapes>
inline bool Scene<T, Shapes...>::occluded(const Ray<T>& ray, T t_max) const {
    prepare();
    bool hit = false;
    for_each_kind([&](auto kind, const auto& vec) {
        if (!hit) hit = occluded_by_kind(kind, vec, ray, t_max);
    });
    if (hit || instances_.empty()) return hit;
    T t = t_max;
    for_each_instance(ray, t, [&](std::uint32_t i, T&) {
        hit = meshes_[instances_[i].mesh].bvh->occluded(object_ray(instances_[i], ray), t_max);
        return hit;
    });
    return hit;
}

template <class T, template <class> class... Shapes>
inline T Scene<T, Shapes...>::transmittance(const Ray<T>& ray, T t_max) const {
    prepare();
    T through = T(1);
    for_each_kind([&](auto kind, const auto& vec) {
        if (through > T(0)) transmit_kind(kind, vec, ray, t_max, through);
    });
    if (!(through > T(0))) return T(0);
    if (!instances_.empty()) through *= placements_transmittance(ray, t_max);
    return through > T(0) ? through : T(0);
}

template <class T, template <class> class... Shapes>
inline SurfacePoint<T> Scene<T, Shapes...>::surface(const Ray<T>& ray, const Hit<T>& hit) const {
    SurfacePoint<T> sp{};
    sp.tint = {T(1), T(1), T(1)};
    if (hit.geometry >= kinds) { // a placed mesh
        const Instance& inst = instances_.at(hit.geometry - kinds);
        const Mesh<T>& mesh = *meshes_[inst.mesh].mesh;
        const auto& k = mesh.indices.at(hit.primitive);
        const Triangle<T> tri = mesh.triangle(hit.primitive);
        // §2 normal of the mesh's triangle (out of its clockwise face); the point from the
        // barycentrics in the mesh's own space (hit_point), then to the world with its bound.
        const Vertex<T> geometric = normal(tri);
        const BoundedPoint<T> local = detail::triangle_hit_point(tri, hit, geometric);
        const BoundedPoint<T> world = inst.identity ? local : inst.to_world.bounded_point(local);
        sp.point = world.point, sp.error = world.error;
        sp.shading_point = sp.point;
        // The normal to world space by the inverse transpose: out of the same side after any
        // transform, mirrors included.
        sp.normal = normalize(Transform<T>::normal(inst.to_object, geometric));
        sp.shading_normal = sp.normal;
        sp.material = meshes_[inst.mesh].material + (mesh.material.empty() ? 0 : mesh.material[hit.primitive]);
        const T b[3] = {T(1) - hit.u - hit.v, hit.u, hit.v}; // weights of V0, V1, V2
        sp.has_texture_coordinates = !mesh.uvs.empty();
        if (sp.has_texture_coordinates) {
            const auto &a = mesh.uvs[k[0]], &bb = mesh.uvs[k[1]], &c = mesh.uvs[k[2]];
            sp.st = {b[0] * a[0] + b[1] * bb[0] + b[2] * c[0], b[0] * a[1] + b[1] * bb[1] + b[2] * c[1]};
        }
        if (!mesh.colors.empty())
            sp.tint = b[0] * mesh.colors[k[0]] + b[1] * mesh.colors[k[1]] + b[2] * mesh.colors[k[2]];
        if (!mesh.normals.empty()) smooth_shading(sp, inst, mesh, k, b, tri, geometric, local.point, ray);
        return sp;
    }
    for_each_kind([&](auto kind, const auto& vec) {
        if (kind != hit.geometry) return;
        using Shape = typename std::decay_t<decltype(vec)>::value_type::shape_type;
        const auto& obj = vec.at(hit.primitive);
        if constexpr (is_triangle_kind<Shape>::value) { // what the renderer computes in lanes
            T p[3], e[3], n[3];
            detail::triangle_surface<T, T>(detail::vertices_of(*triangle_of(obj.shape)).data(), hit.u, hit.v, p, e, n);
            sp.point = {p[0], p[1], p[2]}, sp.error = {e[0], e[1], e[2]}, sp.normal = {n[0], n[1], n[2]};
        } else if constexpr (std::is_same_v<Shape, Sphere<T>>) { // hit_point and normal_at at once
            detail::sphere_surface(ray, obj.shape, hit.t, &sp.point, &sp.error, &sp.normal);
        } else {
            const BoundedPoint<T> p = hit_point(ray, obj.shape, hit);
            // component by component: g++ stored p float by float and copied it 8 bytes at a
            // time, a store-forwarding stall per hit (a fifth of the note's scene's shading)
            sp.point.x = p.point.x, sp.point.y = p.point.y, sp.point.z = p.point.z;
            sp.error.x = p.error.x, sp.error.y = p.error.y, sp.error.z = p.error.z;
            sp.normal = surface_normal(ray, obj.shape, sp.point, hit);
        }
        sp.shading_point = sp.point;
        sp.shading_normal = sp.normal;
        sp.material = obj.material;
        sp.has_texture_coordinates = texture_coordinates(obj.shape, hit, sp.st);
    });
    return sp;
}

// Shading normal and shadow-ray point of a hit on a mesh with vertex normals (see SurfacePoint).
// `b` are the barycentric weights of the triangle's vertices, `geometric` its §2 normal and `p`
// the hit point Σ b_i·P_i (object space). Vertex normals that are zero or not finite leave the
// geometric normal in place.
template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::smooth_shading(SurfacePoint<T>& sp, const Instance& inst, const Mesh<T>& mesh,
                                                const std::array<std::uint32_t, 3>& k, const T (&b)[3],
                                                const Triangle<T>& tri, const Vertex<T>& geometric, const Vertex<T>& p,
                                                const Ray<T>& ray) {
    const Vertex<T>* n[3] = {&mesh.normals[k[0]], &mesh.normals[k[1]], &mesh.normals[k[2]]};
    const Vertex<T> interpolated = b[0] * *n[0] + b[1] * *n[1] + b[2] * *n[2]; // Phong: blend the normals
    Vertex<T> shading = normalize(Transform<T>::normal(inst.to_object, interpolated));
    if (!is_finite(shading) || !(dot(shading, shading) > T(0.5))) return;
    if (dot(shading, sp.normal) < T(0)) shading = -shading; // authored against the winding: same side
    sp.shading_normal = shading;
    // Hanika's shading point, in object space: for each vertex P_i with normal n_i (turned to
    // the side the ray came from), t_i = (p − P_i) − min(0, (p − P_i)·n_i)·n_i, the vector from
    // P_i to p lifted onto P_i's tangent plane where p lies below it; p' = Σ b_i·(P_i + t_i).
    // As Σ b_i·P_i = p, p' = p + lift with lift = −Σ b_i·min(0, (p − P_i)·n_i)·n_i, added to
    // the point on the ray (p here only serves the dot products).
    const bool from_front = dot(geometric, inst.identity ? ray.direction : inst.to_object.vector(ray.direction)) < T(0);
    const Vertex<T> P[3] = {tri.v0, tri.v1, tri.v2};
    Vertex<T> lift{T(0), T(0), T(0)};
    for (int i = 0; i < 3; ++i) {
        Vertex<T> ni = *n[i];
        if ((dot(ni, geometric) < T(0)) == from_front) ni = -ni; // the normal on the ray's side
        const T len2 = dot(ni, ni);
        if (!(len2 > T(0)) || !std::isfinite(len2)) continue;
        ni = ni / std::sqrt(len2);
        const T below = std::min(T(0), dot(p - P[i], ni));
        lift = lift - (b[i] * below) * ni;
    }
    if (is_finite(lift)) sp.shading_point = sp.point + (inst.identity ? lift : inst.to_world.vector(lift));
}

// The nearest hit among the objects of kind `kind` (`vec`), nearer than t (which it lowers),
// into `best`, without those `culled` names.
template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline void Scene<T, Shapes...>::nearest_of_kind(Kind kind, const Objects& vec, const Ray<T>& ray, const Culled* culled,
                                                 T& t, Hit<T>& best) const {
    using Shape = typename Objects::value_type::shape_type;
    const auto take = [&](Hit<T> h) {
        if (!(h.t < t)) return;
        t = h.t, best = h;
        best.geometry = static_cast<std::uint32_t>(kind);
    };
    const std::uint8_t* mask = culled && !culled->objects[kind].empty() ? culled->objects[kind].data() : nullptr;
    const auto& accel = std::get<kind>(accel_);
    if constexpr (is_triangle_kind<Shape>::value) {
        if (accel.triangles && uses(Acceleration::bvh, kind, vec.size())) {
            HitFilter filter;
            filter.skip = mask;
            return take(accel.triangles->intersect(ray, t, filter));
        }
        if (accel.batch && !mask && uses(Acceleration::batch, kind, vec.size()))
            return take(accel.batch->nearest(ray, t));
    } else if (accel.objects && uses(Acceleration::bvh, kind, vec.size())) {
        return nearest_in_tree(*accel.objects, vec, kind, ray, mask, t, best);
    }
    one_by_one(vec, ray, mask, [&](std::size_t i, Hit<T> h) {
        h.primitive = static_cast<std::uint32_t>(i);
        take(h);
        return false;
    });
}

// Whether kind Shape's objects, where the Scene tests them one after another, take the exact
// test in lanes (hit_lanes, ray_lanes.hpp): the built-in kinds, triangles by Möller–Trumbore.
template <class T, template <class> class... Shapes>
template <class Shape>
inline bool Scene<T, Shapes...>::exact_in_lanes() const noexcept {
    if constexpr (!detail::has_lane_hits<T, Shape>::value)
        return false;
    else if constexpr (is_triangle_kind<Shape>::value)
        return triangle_method == TriangleMethod::moller_trumbore;
    else
        return true;
}

// Calls f(i, hit) for the objects of `vec` in order (but those `skip` names), with the hit of
// `ray` on each (OneRay), until f returns true.
template <class T, template <class> class... Shapes>
template <class Objects, class F>
inline void Scene<T, Shapes...>::one_by_one(const Objects& vec, const Ray<T>& ray, const std::uint8_t* skip,
                                            F&& f) const {
    OneRay one(*this, ray);
    for (std::size_t i = 0; i < vec.size(); ++i) {
        if (skip && skip[i]) continue;
        if (f(i, one.hit(vec[i].shape))) return;
    }
}

template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline bool Scene<T, Shapes...>::occluded_by_kind(Kind kind, const Objects& vec, const Ray<T>& ray, T t_max) const {
    using Shape = typename Objects::value_type::shape_type;
    const auto& accel = std::get<kind>(accel_);
    if constexpr (is_triangle_kind<Shape>::value) {
        if (accel.triangles && uses(Acceleration::bvh, kind, vec.size())) return accel.triangles->occluded(ray, t_max);
        if (accel.batch && uses(Acceleration::batch, kind, vec.size()))
            return accel.batch->nearest(ray, t_max).t < t_max;
    } else if (accel.objects && uses(Acceleration::bvh, kind, vec.size())) {
        T t = t_max;
        OneRay one(*this, ray);
        return traverse<Visit::any>(*accel.objects, ray, t, [&](std::uint32_t leaf, T&) {
            const auto& l = accel.objects->leaves()[leaf];
            for (std::uint32_t j = l.first; j < l.first + l.count; ++j)
                if (one.hit(vec[accel.objects->primitives()[j]].shape).t < t_max) return true;
            return false;
        });
    }
    bool blocked = false;
    one_by_one(vec, ray, nullptr, [&](std::size_t, const Hit<T>& h) { return blocked = h.t < t_max; });
    return blocked;
}

// Multiplies `through` (> 0) by the transparencies of the objects of kind `kind` that `ray`
// crosses before t_max, in their order, down to 0 at the first opaque one (transmittance).
template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline void Scene<T, Shapes...>::transmit_kind(Kind kind, const Objects& vec, const Ray<T>& ray, T t_max,
                                               T& through) const {
    using Shape = typename Objects::value_type::shape_type;
    // Multiplies in the transparency of material m; false once nothing gets through.
    const auto pass = [&](std::uint32_t m) {
        through *= material(m).transparency;
        return through > T(0);
    };
    const auto& accel = std::get<kind>(accel_);
    if constexpr (is_triangle_kind<Shape>::value) {
        if (accel.triangles && uses(Acceleration::bvh, kind, vec.size())) {
            accel.triangles->for_each_hit(ray, t_max,
                                          [&](std::uint32_t i, const Hit<T>&) { return pass(vec[i].material); });
            return;
        }
        if (accel.batch && uses(Acceleration::batch, kind, vec.size())) {
            accel.batch->each_hit(ray, t_max, [&](std::size_t i, T) { return pass(vec[i].material); });
            return;
        }
    } else if (accel.objects && uses(Acceleration::bvh, kind, vec.size())) {
        through *= tree_transmittance(*accel.objects, vec, ray, t_max);
        return;
    }
    one_by_one(vec, ray, nullptr,
               [&](std::size_t i, const Hit<T>& h) { return h.t < t_max && !pass(vec[i].material); });
}

// The nearest hit among the objects `vec` of kind `kind` through their Bvh, nearer than t
// (which it lowers), into `best`.
template <class T, template <class> class... Shapes>
template <class Objects>
inline void Scene<T, Shapes...>::nearest_in_tree(const BvhTree<T>& tree, const Objects& vec, std::size_t kind,
                                                 const Ray<T>& ray, const std::uint8_t* mask, T& t,
                                                 Hit<T>& best) const {
    OneRay one(*this, ray);
    traverse<Visit::nearest>(tree, ray, t, [&](std::uint32_t leaf, T&) {
        const auto& l = tree.leaves()[leaf];
        for (std::uint32_t j = l.first; j < l.first + l.count; ++j) {
            const std::uint32_t i = tree.primitives()[j];
            if (mask && mask[i]) continue;
            const Hit<T> h = one.hit(vec[i].shape);
            if (!(h.t < t)) continue;
            t = h.t, best = h;
            best.primitive = i, best.geometry = static_cast<std::uint32_t>(kind);
        }
        return false;
    });
}

template <class T, template <class> class... Shapes>
template <class Objects>
inline T Scene<T, Shapes...>::tree_transmittance(const BvhTree<T>& tree, const Objects& vec, const Ray<T>& ray,
                                                 T t_max) const {
    T through = T(1), t = t_max;
    OneRay one(*this, ray);
    traverse<Visit::any>(tree, ray, t, [&](std::uint32_t leaf, T&) {
        const auto& l = tree.leaves()[leaf];
        for (std::uint32_t j = l.first; j < l.first + l.count; ++j) {
            const std::uint32_t i = tree.primitives()[j];
            if (!(one.hit(vec[i].shape).t < t_max)) continue;
            through *= material(vec[i].material).transparency;
            if (!(through > T(0))) return true;
        }
        return false;
    });
    return through;
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::nearest_placement(const Ray<T>& ray, T& t, bool cull, Hit<T>& best) const noexcept {
    for_each_instance(ray, t, [&](std::uint32_t i, T&) {
        const Instance& inst = instances_[i];
        HitFilter filter;
        filter.cull_backfaces = cull; // in the mesh's own space: a mirrored copy keeps its outside
        const Hit<T> h = meshes_[inst.mesh].bvh->intersect(object_ray(inst, ray), t, filter);
        if (h.t < t) t = h.t, best = h, best.geometry = static_cast<std::uint32_t>(kinds + i);
        return false;
    });
}

template <class T, template <class> class... Shapes>
inline T Scene<T, Shapes...>::placements_transmittance(const Ray<T>& ray, T t_max) const {
    T through = T(1), t = t_max;
    for_each_instance(ray, t, [&](std::uint32_t i, T&) {
        const Instance& inst = instances_[i];
        const MeshEntry& m = meshes_[inst.mesh];
        return m.bvh->for_each_hit(object_ray(inst, ray), t_max, [&](std::uint32_t tri, const Hit<T>&) {
            through *= material(m.material + (m.mesh->material.empty() ? 0 : m.mesh->material[tri])).transparency;
            return through > T(0);
        });
    });
    return through;
}

template <class T, template <class> class... Shapes>
inline Ray<T> Scene<T, Shapes...>::object_ray(const Instance& inst, const Ray<T>& ray) noexcept {
    if (inst.identity) return ray;
    return {inst.to_object.point(ray.origin), inst.to_object.vector(ray.direction)};
}

// Calls visit(i, t_max) for each placement the ray may meet: through their Bvh when there is
// one, else all of them; visit returns true to stop.
template <class T, template <class> class... Shapes>
template <class Visit_>
inline void Scene<T, Shapes...>::for_each_instance(const Ray<T>& ray, T& t_max, Visit_&& visit) const {
    if (top_) {
        traverse<Visit::nearest>(*top_, ray, t_max, [&](std::uint32_t leaf, T& t) {
            const auto& l = top_->leaves()[leaf];
            for (std::uint32_t j = l.first; j < l.first + l.count; ++j)
                if (visit(top_->primitives()[j], t)) return true;
            return false;
        });
        return;
    }
    for (std::size_t i = 0; i < instances_.size(); ++i)
        if (visit(static_cast<std::uint32_t>(i), t_max)) return;
}

} // namespace isin
#endif
