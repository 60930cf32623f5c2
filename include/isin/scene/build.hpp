/// isin — private: Scene's build machinery: commit, and the builds of each kind's acceleration and of the
/// placements' Bvh, once, by commit() or by the first trace after a change.
/// scene.hpp includes this file after the class, whose members it defines: included before
/// scene.hpp it holds nothing (and is included again by scene.hpp: `#pragma once` is inside the #if).
#if defined(ISIN_DETAIL_SCENE_CLASS)
#pragma once
#include <atomic>
#include <memory>
#include <mutex>

namespace isin {

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::commit(const BvhOptions& options) {
    commit_options_ = options;
    build(false);
    commit_state_.stale.store(false, std::memory_order_release);
}

// Builds each kind's acceleration and the placements' Bvh with commit_options_; with
// only_missing, just those a change dropped (the others are still right).
template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::build(bool only_missing) const {
    const BvhOptions& options = commit_options_;
    for_each_kind([&](auto kind, const auto& vec) {
        using Shape = typename std::decay_t<decltype(vec)>::value_type::shape_type;
        auto& accel = std::get<kind>(accel_);
        if (only_missing && (accel.triangles || accel.objects || accel.batch)) return;
        accel = {};
        if (uses(Acceleration::bvh, kind, vec.size())) {
            if constexpr (is_triangle_kind<Shape>::value)
                accel.triangles = std::make_shared<const Bvh<T>>(
                    vec.size(), [&vec](std::size_t i) { return *triangle_of(vec[i].shape); }, options);
            else if constexpr (detail::has_bounds<T, Shape>::value) {
                BvhOptions small_leaves = options;
                small_leaves.leaf_size = shape_leaf_size;
                accel.objects = std::make_shared<const BvhTree<T>>(build_bvh<T>(
                    vec.size(), [&vec](std::size_t i) { return bounds(vec[i].shape); }, small_leaves));
            }
        } else if constexpr (is_triangle_kind<Shape>::value) {
            if (uses(Acceleration::batch, kind, vec.size())) {
                auto batch = std::make_shared<TriangleBatch<T>>();
                batch->reserve(vec.size());
                for (const auto& obj : vec) batch->push_back(*triangle_of(obj.shape));
                accel.batch = std::move(batch);
            }
        }
    });
    if (only_missing && top_) return;
    top_.reset();
    if (instances_.size() > 1) {
        BvhOptions one_per_leaf = options; // each placement's own box is tested before its mesh is entered
        one_per_leaf.leaf_size = 1;
        top_ = std::make_shared<const BvhTree<T>>(build_bvh<T>(
            instances_.size(), [this](std::size_t i) { return instances_[i].box; }, one_per_leaf));
    }
}

// Builds what a change since the last build dropped, once: the first of several concurrent
// traces builds it, the others wait for it; then every trace sees the built scene.
template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::prepare() const {
    if (!commit_state_.stale.load(std::memory_order_acquire)) return;
    prepare_locked();
}

template <class T, template <class> class... Shapes>
void Scene<T, Shapes...>::prepare_locked() const { // not `inline`: declared ISIN_DETAIL_COLD (noinline)
    const std::lock_guard<std::mutex> hold(commit_state_.lock);
    if (!commit_state_.stale.load(std::memory_order_relaxed)) return;
    build(true);
    commit_state_.stale.store(false, std::memory_order_release);
}

template <class T, template <class> class... Shapes>
inline bool Scene<T, Shapes...>::uses(Acceleration a, std::size_t kind, std::size_t n) const noexcept {
    if (triangle_method != TriangleMethod::moller_trumbore) return false;
    if (acceleration != Acceleration::automatic) return acceleration == a;
    if (a == Acceleration::batch) return triangle_kind(kind) && n >= batch_min;
    return n >= (triangle_kind(kind) ? bvh_min : shape_bvh_min);
}

} // namespace isin
#endif
