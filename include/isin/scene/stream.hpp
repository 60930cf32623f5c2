/// isin — private: Scene's stream members: intersect, occluded and transmittance over arrays of rays, in
/// chunks of stream_chunk rays, through the Bvhs' stream calls or rays × objects in lanes.
/// scene.hpp includes this file after the class, whose members it defines: included before
/// scene.hpp it holds nothing (and is included again by scene.hpp: `#pragma once` is inside the #if).
#if defined(ISIN_DETAIL_SCENE_CLASS)
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace isin {

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::intersect(const Ray<T>* rays, std::size_t count, Hit<T>* hits,
                                           const Culled* culled) const {
    stream_nearest(RayArray{rays}, count, hits, culled);
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::intersect(const RaysSoA<T>& rays, std::size_t count, Hit<T>* hits,
                                           const Culled* culled) const {
    stream_nearest([&rays](std::size_t i) { return rays[i]; }, count, hits, culled);
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::intersect(const Ray<T>* rays, std::size_t count, Hit<T>* hits, const Culled* culled,
                                           const StreamOptions& options) const {
    in_threads(count, options, [&](std::size_t first, std::size_t end) {
        stream_nearest(RayArray{rays + first}, end - first, hits + first, culled);
    });
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::intersect(const RaysSoA<T>& rays, std::size_t count, Hit<T>* hits,
                                           const Culled* culled, const StreamOptions& options) const {
    in_threads(count, options, [&](std::size_t first, std::size_t end) {
        stream_nearest([&rays, first](std::size_t i) { return rays[first + i]; }, end - first, hits + first, culled);
    });
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::occluded(const Ray<T>* rays, std::size_t count, const T* t_max,
                                          std::uint8_t* blocked) const {
    stream_occluded(RayArray{rays}, count, t_max, blocked);
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::occluded(const RaysSoA<T>& rays, std::size_t count, const T* t_max,
                                          std::uint8_t* blocked) const {
    stream_occluded([&rays](std::size_t i) { return rays[i]; }, count, t_max, blocked);
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::occluded(const Ray<T>* rays, std::size_t count, const T* t_max, std::uint8_t* blocked,
                                          const StreamOptions& options) const {
    in_threads(count, options, [&](std::size_t first, std::size_t end) {
        stream_occluded(RayArray{rays + first}, end - first, t_max + first, blocked + first);
    });
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::occluded(const RaysSoA<T>& rays, std::size_t count, const T* t_max,
                                          std::uint8_t* blocked, const StreamOptions& options) const {
    in_threads(count, options, [&](std::size_t first, std::size_t end) {
        stream_occluded([&rays, first](std::size_t i) { return rays[first + i]; }, end - first, t_max + first,
                        blocked + first);
    });
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::transmittance(const Ray<T>* rays, std::size_t count, const T* t_max, T* through,
                                               const StreamOptions& options) const {
    in_threads(count, options, [&](std::size_t first, std::size_t end) {
        transmittance(rays + first, end - first, t_max + first, through + first);
    });
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::transmittance(const Ray<T>* rays, std::size_t count, const T* t_max,
                                               T* through) const {
    prepare();
    RayLanes<T> lanes;
    RayLaneHits<T> exact;
    for (std::size_t first = 0; first < count; first += stream_chunk) {
        const std::size_t n = std::min(stream_chunk, count - first);
        const Ray<T>* r = rays + first;
        const T* limit = t_max + first;
        T* out = through + first;
        for (std::size_t k = 0; k < n; ++k) out[k] = T(1);
        bool lanes_set = false;
        for_each_kind([&](auto kind, const auto& vec) {
            if (!in_lanes(kind, vec, false)) {
                for (std::size_t k = 0; k < n; ++k)
                    if (out[k] > T(0)) transmit_kind(kind, vec, r[k], limit[k], out[k]);
                return;
            }
            if (!lanes_set) lanes.assign(r, n), lanes_set = true;
            std::uint64_t open = 0; // rays that light still gets through
            for (std::size_t k = 0; k < n; ++k) open |= std::uint64_t(out[k] > T(0)) << k;
            for (std::size_t i = 0; i < vec.size() && open; ++i)
                each_lane_hit(lanes, r, vec[i].shape, open, exact, [&](int k, const Hit<T>& h) {
                    if (!(h.t < limit[k])) return;
                    out[k] *= material(vec[i].material).transparency;
                    if (!(out[k] > T(0))) open &= ~(std::uint64_t(1) << k);
                });
        });
        for (std::size_t k = 0; k < n; ++k) {
            if (out[k] > T(0) && !instances_.empty()) out[k] *= placements_transmittance(r[k], limit[k]);
            if (!(out[k] > T(0))) out[k] = T(0);
        }
    }
}

// may_hit for a kind that has it; every ray for one that has not (in_lanes keeps such kinds
// out of the lanes: this only lets the stream loops compile for them).
template <class T, template <class> class... Shapes>
template <class Shape>
inline std::uint64_t Scene<T, Shapes...>::lane_filter(const RayLanes<T>& lanes, const Shape& shape) noexcept {
    if constexpr (detail::has_lane_filter<T, Shape>::value) {
        return may_hit(lanes, shape);
    } else {
        (void)shape;
        return all_rays(lanes.count);
    }
}

// Calls f(k, hit) for rays k of `open` (bits of the block `lanes` holds, rays[k]) that may hit
// `shape`, in order of k: those the exact test in lanes hits (hit_lanes) where the kind has it
// (exact_in_lanes, as one_by_one tests one ray), else those the kind's filter keeps (may_hit)
// with intersect_primitive's hit or miss. `exact` is scratch space.
template <class T, template <class> class... Shapes>
template <class Shape, class F>
inline void Scene<T, Shapes...>::each_lane_hit(const RayLanes<T>& lanes, const Ray<T>* rays, const Shape& shape,
                                               std::uint64_t open, RayLaneHits<T>& exact, F&& f) const {
    if constexpr (detail::has_lane_hits<T, Shape>::value) {
        if (exact_in_lanes<Shape>()) {
            for (std::uint64_t hit = hit_lanes(lanes, detail::lane_shape(shape), exact) & open; hit; hit &= hit - 1) {
                const int k = detail::lowest_bit(hit);
                f(k, Hit<T>::at(exact.t[k], exact.u[k], exact.v[k]));
            }
            return;
        }
    }
    (void)exact;
    for (std::uint64_t maybe = lane_filter(lanes, shape) & open; maybe; maybe &= maybe - 1) {
        const int k = detail::lowest_bit(maybe);
        f(k, intersect_primitive(rays[k], shape, triangle_method));
    }
}

// Whether the stream calls test kind `kind` rays × objects in lanes: where the single-ray
// calls test its objects one after another (no Bvh; no batch, which a mask turns off for
// nearest hits) and the kind has a lane filter (may_hit; triangles by Möller–Trumbore).
template <class T, template <class> class... Shapes>
template <class Kind, class Objects>
inline bool Scene<T, Shapes...>::in_lanes(Kind kind, const Objects& vec, bool masked) const noexcept {
    using Shape = typename Objects::value_type::shape_type;
    if constexpr (!detail::has_lane_filter<T, Shape>::value) {
        return false;
    } else {
        const auto& accel = std::get<kind>(accel_);
        if constexpr (is_triangle_kind<Shape>::value) {
            if (triangle_method != TriangleMethod::moller_trumbore) return false;
            if (accel.triangles && uses(Acceleration::bvh, kind, vec.size())) return false;
            return !(accel.batch && !masked && uses(Acceleration::batch, kind, vec.size()));
        } else {
            return !(accel.objects && uses(Acceleration::bvh, kind, vec.size()));
        }
    }
}

template <class T, template <class> class... Shapes>
template <class RayAt>
inline const Ray<T>* Scene<T, Shapes...>::chunk_of(const RayAt& ray_at, std::size_t first, std::size_t n,
                                                   Ray<T>* copy) {
    if constexpr (std::is_same_v<RayAt, RayArray>) {
        (void)n, (void)copy;
        return ray_at.rays + first;
    } else {
        for (std::size_t k = 0; k < n; ++k) copy[k] = ray_at(first + k);
        return copy;
    }
}

// The stream intersect: kind by kind as intersect does, so that each ray meets the same
// bounds in the same order and ends with the same hit.
template <class T, template <class> class... Shapes>
template <class RayAt>
inline void Scene<T, Shapes...>::stream_nearest(const RayAt& ray_at, std::size_t count, Hit<T>* hits,
                                                const Culled* culled) const {
    prepare();
    Ray<T> copy[stream_chunk];
    T t[stream_chunk];
    Hit<T> found[stream_chunk];
    RayLanes<T> lanes;
    RayLaneHits<T> exact;
    for (std::size_t first = 0; first < count; first += stream_chunk) {
        const std::size_t n = std::min(stream_chunk, count - first);
        const Ray<T>* rays = chunk_of(ray_at, first, n, copy);
        Hit<T>* best = hits + first;
        for (std::size_t k = 0; k < n; ++k) t[k] = std::numeric_limits<T>::infinity(), best[k] = Hit<T>{};
        bool lanes_set = false;
        for_each_kind([&](auto kind, const auto& vec) {
            using Shape = typename std::decay_t<decltype(vec)>::value_type::shape_type;
            const auto& accel = std::get<kind>(accel_);
            const std::uint8_t* mask =
                culled && !culled->objects[kind].empty() ? culled->objects[kind].data() : nullptr;
            if (in_lanes(kind, vec, mask != nullptr)) { // as nearest_of_kind's loop
                if (!lanes_set) lanes.assign(rays, n), lanes_set = true;
                for (std::size_t i = 0; i < vec.size(); ++i) {
                    if (mask && mask[i]) continue;
                    each_lane_hit(lanes, rays, vec[i].shape, all_rays(n), exact, [&](int k, const Hit<T>& h) {
                        if (!(h.t < t[k])) return;
                        // field by field: a whole-struct copy of h read it back from the stack
                        // wider than it had been stored, a store-forwarding stall per hit
                        t[k] = h.t, best[k].t = h.t, best[k].u = h.u, best[k].v = h.v;
                        best[k].primitive = static_cast<std::uint32_t>(i);
                        best[k].geometry = static_cast<std::uint32_t>(kind);
                    });
                }
                return;
            }
            if constexpr (is_triangle_kind<Shape>::value) {
                if (accel.triangles && uses(Acceleration::bvh, kind, vec.size())) {
                    HitFilter filter;
                    filter.skip = mask;
                    accel.triangles->intersect(rays, n, t, found, filter);
                    for (std::size_t k = 0; k < n; ++k)
                        if (found[k].t < t[k])
                            t[k] = found[k].t, best[k] = found[k], best[k].geometry = static_cast<std::uint32_t>(kind);
                    return;
                }
            }
            for (std::size_t k = 0; k < n; ++k) nearest_of_kind(kind, vec, rays[k], culled, t[k], best[k]);
        });
        if (instances_.empty()) continue;
        const bool cull = culled && culled->mesh_backfaces;
        if (instances_.size() == 1 && !top_) { // one placed mesh: its Bvh's stream call
            const Instance& inst = instances_[0];
            Ray<T> object[stream_chunk];
            for (std::size_t k = 0; k < n; ++k) object[k] = object_ray(inst, rays[k]);
            HitFilter filter;
            filter.cull_backfaces = cull;
            meshes_[inst.mesh].bvh->intersect(object, n, t, found, filter);
            for (std::size_t k = 0; k < n; ++k)
                if (found[k].t < t[k])
                    t[k] = found[k].t, best[k] = found[k], best[k].geometry = static_cast<std::uint32_t>(kinds);
            continue;
        }
        for (std::size_t k = 0; k < n; ++k) nearest_placement(rays[k], t[k], cull, best[k]);
    }
}

template <class T, template <class> class... Shapes>
template <class RayAt>
inline void Scene<T, Shapes...>::stream_occluded(const RayAt& ray_at, std::size_t count, const T* t_max,
                                                 std::uint8_t* blocked) const {
    prepare();
    Ray<T> copy[stream_chunk];
    T limit[stream_chunk];
    std::uint8_t hit[stream_chunk];
    RayLanes<T> lanes;
    RayLaneHits<T> exact;
    for (std::size_t first = 0; first < count; first += stream_chunk) {
        bool lanes_set = false;
        const std::size_t n = std::min(stream_chunk, count - first);
        const Ray<T>* rays = chunk_of(ray_at, first, n, copy);
        std::uint8_t* out = blocked + first;
        for (std::size_t k = 0; k < n; ++k) limit[k] = t_max[first + k], out[k] = 0;
        const auto through_bvh = [&](const Bvh<T>& bvh, const Ray<T>* r) {
            for (std::size_t k = 0; k < n; ++k)
                if (out[k]) limit[k] = T(0);
            bvh.occluded(r, n, limit, hit);
            for (std::size_t k = 0; k < n; ++k) out[k] |= hit[k];
        };
        for_each_kind([&](auto kind, const auto& vec) {
            using Shape = typename std::decay_t<decltype(vec)>::value_type::shape_type;
            const auto& accel = std::get<kind>(accel_);
            if constexpr (is_triangle_kind<Shape>::value) {
                if (accel.triangles && uses(Acceleration::bvh, kind, vec.size()))
                    return through_bvh(*accel.triangles, rays);
            }
            if (in_lanes(kind, vec, false)) { // as occluded_by_kind's loop
                if (!lanes_set) lanes.assign(rays, n), lanes_set = true;
                std::uint64_t open = 0; // rays not blocked yet
                for (std::size_t k = 0; k < n; ++k) open |= std::uint64_t(out[k] == 0) << k;
                for (std::size_t i = 0; i < vec.size() && open; ++i)
                    each_lane_hit(lanes, rays, vec[i].shape, open, exact, [&](int k, const Hit<T>& h) {
                        if (!(h.t < limit[k])) return;
                        out[k] = 1;
                        open &= ~(std::uint64_t(1) << k);
                    });
                return;
            }
            for (std::size_t k = 0; k < n; ++k)
                if (!out[k]) out[k] = occluded_by_kind(kind, vec, rays[k], limit[k]) ? 1 : 0;
        });
        if (instances_.empty()) continue;
        if (instances_.size() == 1 && !top_) {
            Ray<T> object[stream_chunk];
            for (std::size_t k = 0; k < n; ++k) object[k] = object_ray(instances_[0], rays[k]);
            through_bvh(*meshes_[instances_[0].mesh].bvh, object);
            continue;
        }
        for (std::size_t k = 0; k < n; ++k) {
            if (out[k]) continue;
            T t = limit[k];
            for_each_instance(rays[k], t, [&](std::uint32_t i, T&) {
                out[k] = meshes_[instances_[i].mesh].bvh->occluded(object_ray(instances_[i], rays[k]), limit[k]);
                return out[k] != 0;
            });
        }
    }
}

// f(first, end) over blocks of a stream of `count` rays on options.threads threads, once the
// scene is built (here, not by each thread).
template <class T, template <class> class... Shapes>
template <class F>
inline void Scene<T, Shapes...>::in_threads(std::size_t count, const StreamOptions& options, const F& f) const {
    prepare();
    detail::parallel_blocks(count, detail::thread_count(options.threads), StreamOptions::block, f);
}

} // namespace isin
#endif
