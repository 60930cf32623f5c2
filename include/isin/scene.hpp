#pragma once
/// isin — scenes: the objects, materials and lights a ray tracer needs, and nearest-hit
/// visibility (note §3, §5) over them. A scene holds only the primitive kinds it names:
/// `Scene<float, Sphere>` compiles no triangle code, `Scene<double, Sphere, Triangle>` no
/// texture coordinates. The per-ray loops are plain loops over one vector per kind, no virtual calls.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "batch.hpp"
#include "bvh.hpp"
#include "color.hpp"
#include "hit.hpp"
#include "ray.hpp"
#include "shading.hpp"
#include "sphere.hpp"
#include "texture.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// A triangle carrying the note's texture mapping (§10): on the first triangle of a rectangle the
/// texel is (u·w, v·h), on the second ((1−u)·w, (1−v)·h); V0 is the right angle of each.
template <class T>
struct TexturedTriangle {
    Triangle<T> triangle;
    bool second = false;
};

/// Which ray–triangle test a scene uses for its triangles.
enum class TriangleMethod { moller_trumbore, area };

/// An object of a scene: a primitive and the index of its material.
template <class Shape>
struct Object {
    using shape_type = Shape;
    Shape shape;
    std::uint32_t material;
};

/// The nearest hit in a scene: t, barycentrics, and which object (kind = position of the
/// primitive kind in the scene's list, index = position in that kind's vector).
template <class T>
struct SceneHit {
    Hit<T> hit;
    std::size_t kind = 0;
    std::size_t index = 0;
    explicit operator bool() const noexcept { return bool(hit); }
};

/// Per-primitive customisation: how a ray meets it, its unit normal, its texture coordinates.
template <class T>
[[nodiscard]] inline Hit<T> intersect_primitive(const Ray<T>& ray, const Sphere<T>& sp,
                                                TriangleMethod) noexcept {
    return intersect(ray, sp);
}
template <class T>
[[nodiscard]] inline Hit<T> intersect_primitive(const Ray<T>& ray, const Triangle<T>& tri,
                                                TriangleMethod method) noexcept {
    return method == TriangleMethod::area ? intersect_area(ray, tri)
                                          : intersect_moller_trumbore(ray, tri);
}
template <class T>
[[nodiscard]] inline Hit<T> intersect_primitive(const Ray<T>& ray, const TexturedTriangle<T>& tri,
                                                TriangleMethod method) noexcept {
    return intersect_primitive(ray, tri.triangle, method);
}

template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const Sphere<T>& sp, const Vertex<T>& p, const Hit<T>&) noexcept {
    return normal_at(sp, p);
}
template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const Triangle<T>& tri, const Vertex<T>&, const Hit<T>&) noexcept {
    return normalize(normal(tri));
}
template <class T>
[[nodiscard]] inline Vertex<T> surface_normal(const TexturedTriangle<T>& tri, const Vertex<T>& p,
                                              const Hit<T>& h) noexcept {
    return surface_normal(tri.triangle, p, h);
}

/// The plain triangle of a triangle-like primitive (for culling); spheres have none.
template <class T> [[nodiscard]] constexpr const Triangle<T>* triangle_of(const Triangle<T>& t) noexcept { return &t; }
template <class T> [[nodiscard]] constexpr const Triangle<T>* triangle_of(const TexturedTriangle<T>& t) noexcept { return &t.triangle; }
template <class T> [[nodiscard]] constexpr const Triangle<T>* triangle_of(const Sphere<T>&) noexcept { return nullptr; }

/// Whether a primitive kind is a triangle (scenes then also keep it in a TriangleBatch).
template <class Shape> struct is_triangle_kind : std::false_type {};
template <class T> struct is_triangle_kind<Triangle<T>> : std::true_type {};
template <class T> struct is_triangle_kind<TexturedTriangle<T>> : std::true_type {};

namespace detail {
struct NoBatch {};
// What a scene keeps to speed up one triangle kind: the vectorised batch (always, it is cheap)
// and a BVH (built by commit() when the kind is large enough).
template <class T>
struct TriangleAcceleration {
    TriangleBatch<T> batch;
    std::shared_ptr<const Bvh<T>> bvh; // immutable once built: copies of the scene share it
    bool opaque = true;                // every triangle of the kind has transparency 0
};
template <class T, class Shape>
using BatchFor = std::conditional_t<is_triangle_kind<Shape>::value, TriangleAcceleration<T>, NoBatch>;
} // namespace detail

/// How a scene finds hits among the triangles of one kind ("model no more than a scene needs").
enum class Acceleration {
    automatic, ///< by size: one by one, TriangleBatch from batch_min, Bvh from bvh_min once committed
    none,      ///< one triangle after another
    batch,     ///< TriangleBatch: Möller–Trumbore over structure-of-arrays, vectorised
    bvh        ///< Bvh: 8-wide bounding volume hierarchy, watertight triangle test
};

/// Normalised texture coordinates of a hit, or none: only textured triangles carry them (§10).
template <class T, class Shape>
[[nodiscard]] inline bool texture_coordinates(const Shape&, const Hit<T>&, std::array<T, 2>&) noexcept {
    return false;
}
template <class T>
[[nodiscard]] inline bool texture_coordinates(const TexturedTriangle<T>& tri, const Hit<T>& h,
                                              std::array<T, 2>& st) noexcept {
    st = note_texel(h.u, h.v, T(1), T(1), tri.second); // §10 with w = h = 1: normalised
    return true;
}

/// What a hit looks like to the shader: point, unit normal, material, texture coordinates.
template <class T>
struct SurfacePoint {
    Vertex<T> point;
    Vertex<T> normal;
    std::uint32_t material;
    bool has_texture_coordinates;
    std::array<T, 2> st;
};

/// A scene of the primitive kinds `Shapes...` (each a template such as Sphere, Triangle,
/// TexturedTriangle), in precision T.
template <class T, template <class> class... Shapes>
class Scene {
    static_assert(std::is_floating_point_v<T>, "isin::Scene needs a floating-point type");
    static_assert(sizeof...(Shapes) > 0, "isin::Scene needs at least one primitive kind");

public:
    using value_type = T;
    static constexpr std::size_t kinds = sizeof...(Shapes);

    std::vector<Material<T>> materials;
    std::vector<PointLight<T>> lights;
    std::vector<Texture<T>> textures;
    Filter texture_filter = Filter::bilinear;
    Color<T> background{T(0), T(0), T(0)};
    Color<T> ambient_light{T(1), T(1), T(1)}; // multiplies ka·colour (§7)
    TriangleMethod triangle_method = TriangleMethod::moller_trumbore;
    /// Triangle kinds with at least this many triangles are tested by the vectorised
    /// TriangleBatch (Möller–Trumbore only); smaller ones one by one. Measured on Zen 4, nearest
    /// hit of one ray: the batch wins from 4 triangles with -march=native (AVX-512) and from 4–8
    /// with plain -O3 (SSE2); on the note's scene (3 + 2 triangles) the scalar loop wins.
    std::size_t batch_min = 8;
    /// Triangle kinds with at least this many triangles get a Bvh when the scene is committed
    /// (add_mesh commits by itself). Measured crossover: see benchmarks/scaling and the README.
    std::size_t bvh_min = 64;
    /// Overrides the choice by size for every triangle kind. Bvh and batch apply to
    /// Möller–Trumbore scenes; the area test (triangle_method) always goes one by one.
    Acceleration acceleration = Acceleration::automatic;

    /// Adds a material; returns its index.
    std::uint32_t add_material(const Material<T>& m) {
        materials.push_back(m);
        return static_cast<std::uint32_t>(materials.size() - 1);
    }
    /// Adds a texture; returns its index for Material::texture.
    int add_texture(Texture<T> texture) {
        textures.push_back(std::move(texture));
        return static_cast<int>(textures.size() - 1);
    }
    /// Adds a point light.
    void add_light(const PointLight<T>& light) { lights.push_back(light); }

    /// Material `index`; throws std::out_of_range if it does not exist (materials is public and
    /// may have changed since an object was added).
    [[nodiscard]] const Material<T>& material(std::uint32_t index) const {
        if (index >= materials.size())
            throw std::out_of_range("isin::Scene: material " + std::to_string(index) + " does not exist (" +
                                    std::to_string(materials.size()) + " materials)");
        return materials[index];
    }
    /// Texture `index` (Material::texture); throws std::out_of_range if it does not exist.
    [[nodiscard]] const Texture<T>& texture(int index) const {
        if (index < 0 || std::size_t(index) >= textures.size())
            throw std::out_of_range("isin::Scene: texture " + std::to_string(index) + " does not exist (" +
                                    std::to_string(textures.size()) + " textures)");
        return textures[std::size_t(index)];
    }
    /// Checks that every object's material and every material's texture (when ≥ 0) exist;
    /// throws std::out_of_range naming the first that does not. render() calls it first.
    void validate() const {
        for (std::size_t i = 0; i < materials.size(); ++i)
            if (materials[i].texture >= 0 && std::size_t(materials[i].texture) >= textures.size())
                throw std::out_of_range("isin::Scene: material " + std::to_string(i) + " uses texture " +
                                        std::to_string(materials[i].texture) + ", which does not exist (" +
                                        std::to_string(textures.size()) + " textures)");
        for_each_kind([&](auto, const auto& vec) {
            for (std::size_t i = 0; i < vec.size(); ++i) (void)material(vec[i].material);
        });
    }

    /// Adds a primitive of one of the scene's kinds with a material index from add_material.
    /// Throws std::out_of_range for an unknown material.
    template <class Shape>
    void add(const Shape& shape, std::uint32_t material) {
        if (material >= materials.size())
            throw std::out_of_range("isin::Scene::add: material " + std::to_string(material) +
                                    " does not exist (" + std::to_string(materials.size()) +
                                    " materials)");
        constexpr std::size_t kind = index_of<Shape>();
        std::get<kind>(objects_).push_back({shape, material});
        if constexpr (is_triangle_kind<Shape>::value) {
            auto& accel = std::get<kind>(batches_);
            accel.batch.push_back(*triangle_of(shape));
            accel.bvh.reset(); // stale: commit() builds it again
        }
    }

    /// Adds a whole mesh (e.g. from load_mesh) with one material, then commits the scene so a
    /// large mesh gets its Bvh.
    void add_mesh(const std::vector<Triangle<T>>& triangles, std::uint32_t material) {
        for (const Triangle<T>& tri : triangles) add(tri, material);
        commit();
    }

    /// Builds a Bvh for every triangle kind that uses one (by acceleration and bvh_min). Call it
    /// after adding triangles one by one; until then the scene uses its other loops.
    void commit(const BvhOptions& options = {}) {
        for_each_kind([&](auto kind, const auto& vec) {
            if constexpr (is_triangle_kind<typename std::decay_t<decltype(vec)>::value_type::shape_type>::value) {
                auto& accel = std::get<kind>(batches_);
                accel.bvh.reset();
                accel.opaque = true;
                for (const auto& obj : vec) accel.opaque = accel.opaque && !(material(obj.material).transparency > T(0));
                if (!uses(Acceleration::bvh, vec.size())) return;
                std::vector<Triangle<T>> tris;
                tris.reserve(vec.size());
                for (const auto& obj : vec) tris.push_back(*triangle_of(obj.shape));
                accel.bvh = std::make_shared<const Bvh<T>>(tris, options);
            }
        });
    }

    /// Adds a textured rectangle as the note's two right triangles (§10): corner `v0` (the right
    /// angle, texel (0,0)), `v1` = texel (w,0), `v2` = texel (0,h); the fourth corner is v1 + v2 − v0.
    template <class S = TexturedTriangle<T>>
    void add_textured_rectangle(const Vertex<T>& v0, const Vertex<T>& v1, const Vertex<T>& v2,
                                std::uint32_t material) {
        const Vertex<T> v3 = v1 + v2 - v0;
        add(S{{v0, v1, v2}, false}, material);
        add(S{{v3, v2, v1}, true}, material);
    }

    /// The objects of one primitive kind.
    template <class Shape>
    [[nodiscard]] const std::vector<Object<Shape>>& objects() const noexcept {
        return std::get<std::vector<Object<Shape>>>(objects_);
    }
    /// Whether the triangle kind Shape currently has a Bvh (built by commit() or add_mesh).
    template <class Shape>
    [[nodiscard]] bool has_bvh() const noexcept {
        static_assert(is_triangle_kind<Shape>::value, "only triangle kinds get a Bvh");
        return bool(std::get<index_of<Shape>()>(batches_).bvh);
    }
    /// Number of objects of all kinds.
    [[nodiscard]] std::size_t size() const noexcept {
        return std::apply([](const auto&... v) { return (std::size_t(0) + ... + v.size()); }, objects_);
    }

    /// Nearest hit with t in (0, t_max) over all objects (§3, §5: the smallest t is visible).
    /// `skip`, if given, is one mask per kind (empty = none skipped): objects whose mask byte is
    /// non-zero are ignored — the renderer's backface culling for primary rays. Triangles tested
    /// by Möller–Trumbore go through the vectorised TriangleBatch, others one by one.
    [[nodiscard]] SceneHit<T> intersect(const Ray<T>& ray,
                                        T t_max = std::numeric_limits<T>::infinity(),
                                        const std::array<std::vector<std::uint8_t>, kinds>* skip = nullptr) const {
        SceneHit<T> best;
        best.hit.t = t_max;
        for_each_kind([&](auto kind, const auto& vec) {
            const std::uint8_t* mask = skip && !(*skip)[kind].empty() ? (*skip)[kind].data() : nullptr;
            if constexpr (is_triangle_kind<typename std::decay_t<decltype(vec)>::value_type::shape_type>::value) {
                const auto& accel = std::get<kind>(batches_);
                if (accel.bvh && uses(Acceleration::bvh, vec.size())) {
                    nearest_in_bvh(*accel.bvh, ray, mask, kind, best);
                    return;
                }
                if (!mask && uses(Acceleration::batch, vec.size())) {
                    if (const auto h = accel.batch.nearest(ray, best.hit.t)) best = {h.hit, kind, h.index};
                    return;
                }
            }
            for (std::size_t i = 0; i < vec.size(); ++i) {
                if (mask && mask[i]) continue;
                const Hit<T> h = intersect_primitive(ray, vec[i].shape, triangle_method);
                if (h.t < best.hit.t) best = {h, kind, i};
            }
        });
        if (!(best.hit.t < t_max)) return SceneHit<T>{};
        return best;
    }

    /// Fraction of light that reaches along `ray` up to t_max: 1 when nothing is in the way, the
    /// product of the transparencies of the objects crossed otherwise (0 for an opaque one).
    [[nodiscard]] T transmittance(const Ray<T>& ray, T t_max) const {
        T through = T(1);
        for_each_kind([&](auto kind, const auto& vec) {
            if (!(through > T(0))) return;
            if constexpr (is_triangle_kind<typename std::decay_t<decltype(vec)>::value_type::shape_type>::value) {
                const auto& accel = std::get<kind>(batches_);
                if (accel.bvh && accel.opaque && uses(Acceleration::bvh, vec.size())) {
                    if (accel.bvh->occluded(ray, t_max)) through = T(0); // §9: any opaque hit shadows
                    return;
                }
                if (uses(Acceleration::batch, vec.size())) {
                    accel.batch.each_hit(ray, t_max, [&](std::size_t i, T) {
                        through *= material(vec[i].material).transparency;
                        return through > T(0);
                    });
                    return;
                }
            }
            for (std::size_t i = 0; i < vec.size() && through > T(0); ++i) {
                const Hit<T> h = intersect_primitive(ray, vec[i].shape, triangle_method);
                if (h.t < t_max) through *= material(vec[i].material).transparency;
            }
        });
        return through;
    }

    /// Point, normal, material and texture coordinates of a hit of `ray`.
    [[nodiscard]] SurfacePoint<T> surface(const Ray<T>& ray, const SceneHit<T>& sh) const {
        SurfacePoint<T> sp{};
        sp.point = ray.at(sh.hit.t);
        for_each_kind([&](auto kind, const auto& vec) {
            if (kind != sh.kind) return;
            const auto& obj = vec[sh.index];
            sp.normal = surface_normal(obj.shape, sp.point, sh.hit);
            sp.material = obj.material;
            sp.has_texture_coordinates = texture_coordinates(obj.shape, sh.hit, sp.st);
        });
        return sp;
    }

    /// Calls f(kind, vector) for each primitive kind, kind as a std::size_t constant.
    template <class F>
    void for_each_kind(F&& f) const {
        for_each_kind_impl(f, std::index_sequence_for<Shapes<T>...>{});
    }

private:
    // Whether a triangle kind of n triangles is tested with acceleration `a`.
    [[nodiscard]] bool uses(Acceleration a, std::size_t n) const noexcept {
        if (triangle_method != TriangleMethod::moller_trumbore) return false;
        if (acceleration != Acceleration::automatic) return acceleration == a;
        // Callers try the Bvh first; a kind whose Bvh is not built (yet) still gets the batch.
        return n >= (a == Acceleration::bvh ? bvh_min : batch_min);
    }

    // Nearest hit in a kind's Bvh. With a culling mask, a culled nearest hit is stepped over
    // (the ray restarts just past it) until an unculled one or a miss, at most 16 times.
    void nearest_in_bvh(const Bvh<T>& bvh, const Ray<T>& ray, const std::uint8_t* mask, std::size_t kind,
                        SceneHit<T>& best) const noexcept {
        T t0 = T(0);
        for (int step = 0; step < 16; ++step) {
            const Ray<T> part{t0 > T(0) ? ray.at(t0) : ray.origin, ray.direction};
            const BvhHit<T> h = bvh.intersect(part, best.hit.t - t0);
            if (!h) return;
            if (!mask || !mask[h.primitive]) {
                best = {Hit<T>{t0 + h.t, h.u, h.v}, kind, h.primitive};
                return;
            }
            t0 += h.t * (T(1) + T(64) * std::numeric_limits<T>::epsilon()) + std::numeric_limits<T>::min();
        }
    }

    template <class Shape, std::size_t I = 0>
    static constexpr std::size_t index_of() {
        static_assert(I < kinds, "isin::Scene::add: this scene does not hold that primitive kind");
        if constexpr (std::is_same_v<Shape, std::tuple_element_t<I, std::tuple<Shapes<T>...>>>) return I;
        else return index_of<Shape, I + 1>();
    }

    template <class F, std::size_t... I>
    void for_each_kind_impl(F& f, std::index_sequence<I...>) const {
        (f(std::integral_constant<std::size_t, I>{}, std::get<I>(objects_)), ...);
    }

    std::tuple<std::vector<Object<Shapes<T>>>...> objects_;
    std::tuple<detail::BatchFor<T, Shapes<T>>...> batches_; // triangle kinds only
};

} // namespace isin
