#pragma once
/// isin — scenes: the objects, materials and lights a ray tracer needs, and nearest-hit
/// visibility (note §3, §5) over them. A scene holds only the primitive kinds it names:
/// `Scene<float, Sphere>` compiles no triangle code, `Scene<double, Sphere, Triangle>` no
/// texture coordinates. Each kind is a plain vector, tested one by one, as a vectorised batch
/// (triangles) or through a Bvh of its own once it is large; meshes are stored once with their
/// Bvh and placed any number of times (instances), found through a Bvh over the placements.
/// No virtual calls.
///
///     isin::Scene<float, isin::Sphere> scene;
///     auto dragon = scene.add_mesh(mesh, scene.add_material(gold)); // builds its Bvh, places it once
///     scene.add_instance(dragon, isin::Transform<float>::translation({30, 0, 0}));
///     scene.commit(); // optional: the first trace after a change builds what is missing, once
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "batch.hpp"
#include "bvh.hpp"
#include "bvh/shaft.hpp"
#include "color.hpp"
#include "detail/attributes.hpp"
#include "detail/compiled.hpp"
#include "detail/parallel.hpp"
#include "error_bound.hpp"
#include "hit.hpp"
#include "indexed_mesh.hpp"
#include "point_hit.hpp"
#include "primitive.hpp"
#include "ray.hpp"
#include "ray_lanes.hpp"
#include "shading.hpp"
#include "sphere.hpp"
#include "texture.hpp"
#include "transform.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// A placement of a mesh in a scene (add_mesh places it once, add_instance again).
struct InstanceId {
    std::uint32_t index;
};

/// The closest point of a Scene (Scene::closest_point): PointHit's fields, `primitive` the object's
/// index in its kind or the placed mesh's triangle, and `geometry` which holds it, as Hit's.
template <class T>
struct ScenePointHit : PointHit<T> {
    std::uint32_t geometry = PointHit<T>::none; ///< a kind's position, or kinds + i for placement i
};

namespace detail {
// The error of Scene::material and texture, kept out of line: they sit in every shading step.
[[noreturn]] ISIN_DETAIL_COLD inline void throw_missing(const char* what, long long index, std::size_t count) {
    throw std::out_of_range("isin::Scene: " + std::string(what) + " " + std::to_string(index) + " does not exist (" +
                            std::to_string(count) + " " + what + "s)");
}

// What a scene keeps to speed up one kind: the Bvh (triangle kinds: a triangle Bvh; others: a
// tree over the objects' boxes) or, for triangles of middling count, the batch. Immutable once
// built: copies of the scene share them.
template <class T, class Shape>
struct KindAcceleration {
    std::shared_ptr<const Bvh<T>> triangles;   // triangle kinds
    std::shared_ptr<const BvhTree<T>> objects; // other kinds
    std::shared_ptr<const TriangleBatch<T>> batch;
};

// f(i, triangle) for the objects of a triangle kind searched one by one (no Bvh), in order, but those a
// Bvh would leave out (Bvh::bounds not usable: zero-area or non-finite triangles); stops at the first
// f that returns true, and returns whether one did.
template <class T, class Objects, class F>
bool any_usable_triangle(const Objects& vec, F&& f) {
    for (std::size_t i = 0; i < vec.size(); ++i) {
        const Triangle<T>& tri = *triangle_of(vec[i].shape);
        if (Bvh<T>::bounds(tri).usable() && f(i, tri)) return true;
    }
    return false;
}

// Whether a scene changed since its accelerations were built, and the lock under which the first
// of several concurrent traces builds them. A copy takes the flag and a lock of its own.
struct CommitState {
    std::atomic<bool> stale{false};
    std::mutex lock;
    CommitState() = default;
    CommitState(const CommitState& o) noexcept : stale(o.stale.load(std::memory_order_acquire)) {}
    CommitState& operator=(const CommitState& o) noexcept {
        stale.store(o.stale.load(std::memory_order_acquire), std::memory_order_release);
        return *this;
    }
};
} // namespace detail

/// A scene of the primitive kinds `Shapes...` (each a template such as Sphere, Triangle,
/// TexturedTriangle, or a user's), in precision T, and of meshes placed by instances.
template <class T, template <class> class... Shapes>
class Scene {
    static_assert(std::is_floating_point_v<T>, "isin::Scene needs a floating-point type");
    static_assert(sizeof...(Shapes) > 0, "isin::Scene needs at least one primitive kind");

public:
    using value_type = T;
    static constexpr std::size_t kinds = sizeof...(Shapes);

    /// What a scene's intersect leaves out (backface culling for primary rays, note §11): the
    /// objects of each kind whose mask byte is non-zero, and the back faces of placed meshes
    /// seen from the ray's origin (§11 method 1 with the eye there: the Bvh's leaf test skips them).
    struct Culled {
        std::array<std::vector<std::uint8_t>, kinds> objects;
        bool mesh_backfaces = false;
    };

    std::vector<Material<T>> materials;
    std::vector<PointLight<T>> lights;
    std::vector<RectLight<T>> rect_lights; ///< area lights, shaded after the point lights
    std::vector<Texture<T>> textures;
    Filter texture_filter = Filter::bilinear;
    Color<T> background{T(0), T(0), T(0)};
    Color<T> ambient_light{T(1), T(1), T(1)}; // multiplies ka·colour (§7)
    TriangleMethod triangle_method = TriangleMethod::moller_trumbore;
    /// Triangle kinds with at least this many triangles are tested by the vectorised
    /// TriangleBatch (Möller–Trumbore only); smaller ones one by one. The crossover:
    /// docs/performance.md.
    std::size_t batch_min = 8;
    /// Triangle kinds with at least this many triangles get a Bvh when the scene is committed.
    /// The crossover: docs/meshes.md.
    std::size_t bvh_min = 64;
    /// Other kinds (spheres, users' kinds) with at least this many objects get a Bvh when the
    /// scene is committed. The crossover for spheres: docs/meshes.md.
    std::size_t shape_bvh_min = 8;
    /// Leaves of other kinds' Bvhs hold at most this many objects: they are tested one at a time
    /// (2 traced spheres fastest over the sizes measured: docs/performance.md).
    int shape_leaf_size = 2;
    /// Overrides the choice by size for every kind. Bvh and batch apply to Möller–Trumbore
    /// scenes; the area test (triangle_method) always goes one by one.
    Acceleration acceleration = Acceleration::automatic;

    /// Adds a material; returns its index.
    std::uint32_t add_material(const Material<T>& m);
    /// Adds a texture; returns its index for Material::texture.
    int add_texture(Texture<T> image);
    /// Adds a point light.
    void add_light(const PointLight<T>& light) { lights.push_back(light); }
    /// Adds a rectangular area light (a template, so that braced calls such as
    /// add_light({{0, 40, 0}}) still mean a PointLight).
    template <class L, std::enable_if_t<std::is_same_v<L, RectLight<T>>, int> = 0>
    void add_light(const L& light) {
        rect_lights.push_back(light);
    }

    /// Material `index`; throws std::out_of_range if it does not exist (materials is public and
    /// may have changed since an object was added).
    [[nodiscard]] const Material<T>& material(std::uint32_t index) const;
    /// Texture `index` (Material::texture); throws std::out_of_range if it does not exist.
    [[nodiscard]] const Texture<T>& texture(int index) const;
    /// Checks that every object's and mesh's materials and every material's texture (when ≥ 0)
    /// exist; throws std::out_of_range naming the first that does not. render() calls it first.
    void validate() const;

    /// Adds a primitive of one of the scene's kinds with a material index from add_material.
    /// Throws std::out_of_range for an unknown material. The kind's acceleration is rebuilt by
    /// the next commit() or, failing that, by the next trace (intersect, occluded, render, ...).
    template <class Shape>
    void add(const Shape& shape, std::uint32_t material_id);

    /// Stores `mesh` (once, however often it is placed), builds its Bvh and places it once, where
    /// it stands. Every triangle has `material`, or, when mesh.material is not empty, material +
    /// mesh.material[i] (ids relative to `material`). Returns the handle for add_instance.
    /// Throws std::invalid_argument for an invalid mesh (Mesh::validate), std::out_of_range for a
    /// material that does not exist. The Bvh over the placements is built by commit() or, failing
    /// that, by the next trace.
    MeshId add_mesh(Mesh<T> mesh, std::uint32_t material_id, const BvhOptions& options = {});
    /// Adds a triangle soup as a mesh (three vertices a triangle), as add_mesh(Mesh).
    MeshId add_mesh(const std::vector<Triangle<T>>& triangles, std::uint32_t material_id,
                    const BvhOptions& options = {});
    /// As add_mesh(mesh, material_id), with `bvh` a Bvh built before over this mesh (e.g.
    /// Bvh<T>::load of a file saved from mesh_bvh(id)): nothing is built, instances share it as
    /// usual. Throws std::invalid_argument unless `bvh` holds exactly the triangles of `mesh` that
    /// a ray can hit, each once, vertex for vertex (O(triangles), far cheaper than a build).
    MeshId add_mesh(Mesh<T> mesh, std::uint32_t material_id, Bvh<T> bvh);

    /// Places mesh `id` again, moved by `to_world` (any affine transform with det ≠ 0). Its faces
    /// keep their sides: the front is the mesh's clockwise side, also under a mirroring transform
    /// (whose world-space winding is reversed). Memory: a transform, not a copy of the mesh.
    /// Throws std::out_of_range for an unknown id, std::invalid_argument for a transform that is
    /// not finite or cannot be inverted.
    InstanceId add_instance(MeshId id, const Transform<T>& to_world);

    /// Builds what the sizes call for: a Bvh or batch for each kind (by acceleration, bvh_min,
    /// shape_bvh_min, batch_min) and the Bvh over the placed meshes, with `options` (kept for
    /// later builds). Optional: the first trace after a change (add, add_mesh, add_instance)
    /// builds what is missing, once, even when several threads start tracing at the same time;
    /// commit() lets the build happen before, e.g. outside a timed render. Adding N meshes costs
    /// N mesh builds (in add_mesh) and one cheap build here, not N rebuilds of everything.
    void commit(const BvhOptions& options = {});
    /// Whether nothing changed since the accelerations were last built (by commit() or a trace).
    [[nodiscard]] bool committed() const noexcept { return !commit_state_.stale.load(std::memory_order_acquire); }

    /// Adds a textured rectangle as the note's two right triangles (§10): corner `v0` (the right
    /// angle, texel (0,0)), `v1` = texel (w,0), `v2` = texel (0,h); the fourth corner is v1 + v2 − v0.
    template <class S = TexturedTriangle<T>>
    void add_textured_rectangle(const Vertex<T>& v0, const Vertex<T>& v1, const Vertex<T>& v2,
                                std::uint32_t material_id);

    /// The objects of one primitive kind.
    template <class Shape>
    [[nodiscard]] const std::vector<Object<Shape>>& objects() const noexcept {
        return std::get<std::vector<Object<Shape>>>(objects_);
    }
    /// Whether the kind Shape currently has a Bvh (built by commit() or the first trace after a change).
    template <class Shape>
    [[nodiscard]] bool has_bvh() const noexcept {
        const auto& accel = std::get<index_of<Shape>()>(accel_);
        return accel.triangles || accel.objects;
    }
    /// Whether the placements have a Bvh over them (built as has_bvh's, from two placements on).
    [[nodiscard]] bool has_instance_bvh() const noexcept { return bool(top_); }
    /// Number of objects of all kinds (placed meshes not counted).
    [[nodiscard]] std::size_t size() const noexcept {
        return std::apply([](const auto&... v) { return (std::size_t(0) + ... + v.size()); }, objects_);
    }
    [[nodiscard]] std::size_t mesh_count() const noexcept { return meshes_.size(); } ///< meshes stored by add_mesh
    [[nodiscard]] std::size_t instance_count() const noexcept { return instances_.size(); } ///< placements of meshes
    /// The stored mesh `id` and its Bvh.
    [[nodiscard]] const Mesh<T>& mesh(MeshId id) const { return *meshes_.at(id.index).mesh; }
    [[nodiscard]] const Bvh<T>& mesh_bvh(MeshId id) const { return *meshes_.at(id.index).bvh; }
    /// Bytes held by the stored meshes, their Bvhs, the placements and their Bvh, the kinds'
    /// objects and accelerations (not materials, lights or textures).
    [[nodiscard]] std::size_t memory() const noexcept;

    /// Nearest hit with t in (0, t_max) over all objects and placed meshes (§3, §5: the smallest
    /// t is visible). The hit's `geometry` says where: a kind (its position in the scene's list)
    /// for an object, whose index is `primitive`; kinds + i for placement i of a mesh, whose
    /// triangle is `primitive`. `culled`, if given, leaves out what it names (the renderer's
    /// backface culling for primary rays). Throws only what a user's kind throws, or what building
    /// a changed scene throws (std::bad_alloc): every trace call first builds what a change since
    /// the last commit() dropped (see commit).
    [[nodiscard]] Hit<T> intersect(const Ray<T>& ray, T t_max = std::numeric_limits<T>::infinity(),
                                   const Culled* culled = nullptr) const;

    /// Nearest hits of a stream of rays: hits[i] = intersect(rays[i], ∞, culled) for i < count, the
    /// same hits bit for bit. Triangle kinds with a Bvh, and a scene's one placed mesh, take the
    /// rays through the Bvh's stream call (16 coherent rays as a packet: order them in 4×4 tiles
    /// of pixels); everything else goes one ray at a time.
    void intersect(const Ray<T>* rays, std::size_t count, Hit<T>* hits, const Culled* culled = nullptr) const;
    /// As above, the rays as separate arrays.
    void intersect(const RaysSoA<T>& rays, std::size_t count, Hit<T>* hits, const Culled* culled = nullptr) const;
    /// Both stream intersects with the rays shared among options.threads threads (StreamOptions;
    /// the forms above use the calling thread alone): the same hits for any thread count.
    void intersect(const Ray<T>* rays, std::size_t count, Hit<T>* hits, const Culled* culled,
                   const StreamOptions& options) const;
    void intersect(const RaysSoA<T>& rays, std::size_t count, Hit<T>* hits, const Culled* culled,
                   const StreamOptions& options) const;

    /// True when any object or placed mesh is hit with t in (0, t_max), whatever its material:
    /// a shadow ray in a scene of opaque objects (transmittance weighs transparent ones).
    [[nodiscard]] bool occluded(const Ray<T>& ray, T t_max) const;
    /// Shadow rays of a stream: blocked[i] = occluded(rays[i], t_max[i]) (1 or 0) for i < count;
    /// packets as for the stream intersect.
    void occluded(const Ray<T>* rays, std::size_t count, const T* t_max, std::uint8_t* blocked) const;
    /// As above, the rays as separate arrays.
    void occluded(const RaysSoA<T>& rays, std::size_t count, const T* t_max, std::uint8_t* blocked) const;
    /// Both stream occluded calls with the rays shared among options.threads threads.
    void occluded(const Ray<T>* rays, std::size_t count, const T* t_max, std::uint8_t* blocked,
                  const StreamOptions& options) const;
    void occluded(const RaysSoA<T>& rays, std::size_t count, const T* t_max, std::uint8_t* blocked,
                  const StreamOptions& options) const;

    /// Fraction of light that reaches along `ray` up to t_max: 1 when nothing is in the way, the
    /// product of the transparencies of the objects crossed otherwise (0 for an opaque one, at
    /// which it stops). Every kind and placed mesh goes through its Bvh's all-hits traversal.
    [[nodiscard]] T transmittance(const Ray<T>& ray, T t_max) const;
    /// Shadow rays of a stream: through[i] = transmittance(rays[i], t_max[i]) for i < count, the
    /// same values bit for bit. Kinds too small for a Bvh are tested rays × objects in lanes
    /// (ray_lanes.hpp), the rest ray by ray. With `options`, the rays shared among options.threads
    /// threads (StreamOptions; without, the calling thread alone): the same values for any count.
    void transmittance(const Ray<T>* rays, std::size_t count, const T* t_max, T* through,
                       const StreamOptions& options) const;
    void transmittance(const Ray<T>* rays, std::size_t count, const T* t_max, T* through) const;

    /// The closest point to p within max_distance of the placed meshes (exact in the world under any
    /// transform), the triangle kinds and the spheres; other kinds are skipped (docs/queries.md).
    /// A miss (false) when nothing is within reach, for a NaN or infinite p, or a NaN max_distance.
    [[nodiscard]] ScenePointHit<T> closest_point(const Vertex<T>& p,
                                                 T max_distance = std::numeric_limits<T>::infinity()) const;
    /// out[i] = closest_point(points[i]) for i < count, on up to `threads` threads (0 = every core).
    void closest_point(const Vertex<T>* points, std::size_t count, ScenePointHit<T>* out, int threads = 0) const;
    /// How many times the ray crosses the placed meshes, the triangle kinds and the spheres with t
    /// in (0, t_max), each mesh's shared edges and vertices once: even from outside closed ones.
    [[nodiscard]] std::size_t count_hits(const Ray<T>& ray, T t_max = std::numeric_limits<T>::infinity()) const;
    /// The part of a shaft near its point that shaft_clear leaves out: the first 2⁻¹⁰ of the way.
    static constexpr T shaft_tip = T(1) / T(1024);
    /// Whether nothing the Scene holds can meet the shaft from `from` to `light`'s parallelogram
    /// (the convex hull of `from` and its corners), less its tip (the first shaft_tip of the way,
    /// where the surface `from` lies on is): then no shadow ray from `from` to the light is blocked.
    /// Conservative (Haines & Wallace's shaft culling, bvh/shaft.hpp): false where unsure, and for
    /// kinds without bounds, a non-finite `from` or light.
    [[nodiscard]] bool shaft_clear(const Vertex<T>& from, const RectLight<T>& light) const;

    /// Point, normals, material, texture coordinates and colour of a hit of `ray`.
    [[nodiscard]] SurfacePoint<T> surface(const Ray<T>& ray, const Hit<T>& hit) const;

    /// Calls f(kind, vector) for each primitive kind, kind as a std::size_t constant.
    template <class F>
    void for_each_kind(F&& f) const {
        for_each_kind_impl(f, std::index_sequence_for<Shapes<T>...>{});
    }

private:
    struct MeshEntry {
        std::shared_ptr<const Mesh<T>> mesh; // shared by copies of the scene
        std::shared_ptr<const Bvh<T>> bvh;
        std::uint32_t material = 0, largest_material_id = 0;
    };
    struct Instance {
        std::uint32_t mesh = 0;
        Transform<T> to_world, to_object;
        bool identity = true;
        Box<T> box; // in the world
        // Closest points: M = s·R up to rounding (`similar`, scale2 = s²), else scale2 ≤ σ_min(M)²
        bool similar = true;
        T scale2 = T(1);
    };

    // Setup (below the class).
    /// add_mesh with the mesh's Bvh from make_bvh(stored mesh).
    template <class MakeBvh>
    MeshId add_mesh_entry(Mesh<T> mesh, std::uint32_t material_id, MakeBvh&& make_bvh);
    /// Throws std::invalid_argument unless `bvh` was built over `mesh` (add_mesh with a Bvh).
    static void check_built_over(const Bvh<T>& bvh, const Mesh<T>& mesh);
    /// The world box of a mesh box moved by `to_world`: the box of its 8 moved corners.
    [[nodiscard]] static Box<T> world_box(const Box<T>& b, const Transform<T>& to_world) noexcept;
    /// Bytes held by a tree over objects.
    [[nodiscard]] static std::size_t tree_memory(const BvhTree<T>& tree) noexcept {
        return tree.node_count() * sizeof(typename BvhTree<T>::Node) +
               tree.leaf_count() * sizeof(typename BvhTree<T>::Leaf) + tree.size() * sizeof(std::uint32_t);
    }
    /// The position of kind Shape in the scene's list.
    template <class Shape, std::size_t I = 0>
    static constexpr std::size_t index_of() {
        static_assert(I < kinds, "isin::Scene::add: this scene does not hold that primitive kind");
        if constexpr (std::is_same_v<Shape, std::tuple_element_t<I, std::tuple<Shapes<T>...>>>)
            return I;
        else
            return index_of<Shape, I + 1>();
    }
    /// for_each_kind over the kinds I.
    template <class F, std::size_t... I>
    void for_each_kind_impl(F& f, std::index_sequence<I...>) const {
        (f(std::integral_constant<std::size_t, I>{}, std::get<I>(objects_)), ...);
    }

    // Building the accelerations (scene/build.hpp).
    /// Builds each kind's acceleration and the placements' Bvh (only_missing: those a change dropped).
    void build(bool only_missing) const;
    /// Builds what a change since the last build dropped, once, whichever trace comes first.
    void prepare() const;
    /// prepare's build, under the lock.
    ISIN_DETAIL_COLD void prepare_locked() const;
    /// Whether kind `kind` of n objects is tested with acceleration `a`.
    [[nodiscard]] bool uses(Acceleration a, std::size_t kind, std::size_t n) const noexcept;
    /// Whether kind `kind` is a triangle kind.
    [[nodiscard]] static constexpr bool triangle_kind(std::size_t kind) noexcept {
        constexpr bool is[] = {is_triangle_kind<Shapes<T>>::value...};
        return is[kind];
    }

    // One ray (scene/trace.hpp).
    /// Shading normal and shadow-ray point of a hit on a mesh with vertex normals.
    static void smooth_shading(SurfacePoint<T>& sp, const Instance& inst, const Mesh<T>& mesh,
                               const std::array<std::uint32_t, 3>& k, const T (&b)[3], const Triangle<T>& tri,
                               const Vertex<T>& geometric, const Vertex<T>& p, const Ray<T>& ray);
    /// The nearest hit among kind `kind`'s objects nearer than t (lowered), into `best`.
    template <class Kind, class Objects>
    void nearest_of_kind(Kind kind, const Objects& vec, const Ray<T>& ray, const Culled* culled, T& t,
                         Hit<T>& best) const;
    /// Whether kind Shape's objects, tested one after another, take the exact test in lanes.
    template <class Shape>
    [[nodiscard]] bool exact_in_lanes() const noexcept;

    // One ray's tests of single objects: hit(shape) is the ray's hit on it (or a miss), by the
    // exact test of the lanes (ray_lanes.hpp) run on plain values where the kind has it
    // (exact_in_lanes) — the same bits as the stream calls' registers — else intersect_primitive.
    class OneRay {
    public:
        OneRay(const Scene& scene, const Ray<T>& ray) noexcept : scene_(scene), ray_(ray), ray_register_(ray) {}
        template <class Shape>
        Hit<T> hit(const Shape& shape) {
            if constexpr (detail::has_lane_hits<T, Shape>::value) {
                if (scene_.exact_in_lanes<Shape>()) {
                    T t, u, v;
                    if (!detail::hit_register(ray_register_, detail::lane_shape(shape), &t, &u, &v))
                        return Hit<T>::miss();
                    return Hit<T>::at(t, u, v);
                }
            }
            return intersect_primitive(ray_, shape, scene_.triangle_method);
        }

    private:
        const Scene& scene_;
        const Ray<T>& ray_;
        detail::RayRegister<T, T> ray_register_; // one ray, one value per coordinate
    };

    /// Calls f(i, hit) for the objects of `vec` in order (but those `skip` names) until f is true.
    template <class Objects, class F>
    void one_by_one(const Objects& vec, const Ray<T>& ray, const std::uint8_t* skip, F&& f) const;
    /// Whether any object of kind `kind` is hit with t in (0, t_max).
    template <class Kind, class Objects>
    bool occluded_by_kind(Kind kind, const Objects& vec, const Ray<T>& ray, T t_max) const;
    /// Multiplies `through` by the transparencies of kind `kind`'s objects crossed before t_max.
    template <class Kind, class Objects>
    void transmit_kind(Kind kind, const Objects& vec, const Ray<T>& ray, T t_max, T& through) const;
    /// The nearest hit among `vec` of kind `kind` through their Bvh, nearer than t, into `best`.
    template <class Objects>
    void nearest_in_tree(const BvhTree<T>& tree, const Objects& vec, std::size_t kind, const Ray<T>& ray,
                         const std::uint8_t* mask, T& t, Hit<T>& best) const;
    /// The fraction of light that gets through the objects `vec` up to t_max, through their Bvh.
    template <class Objects>
    T tree_transmittance(const BvhTree<T>& tree, const Objects& vec, const Ray<T>& ray, T t_max) const;
    /// The nearest hit in a placed mesh nearer than t (which it lowers), into `best`.
    void nearest_placement(const Ray<T>& ray, T& t, bool cull, Hit<T>& best) const noexcept;
    /// The fraction of light that gets through the placed meshes up to t_max.
    T placements_transmittance(const Ray<T>& ray, T t_max) const;
    /// The ray in placement `inst`'s mesh space: same t for the same point (affine map).
    [[nodiscard]] static Ray<T> object_ray(const Instance& inst, const Ray<T>& ray) noexcept;
    /// Calls visit(i, t_max) for each placement the ray may meet, until visit returns true.
    template <class Visit_>
    void for_each_instance(const Ray<T>& ray, T& t_max, Visit_&& visit) const;

    // Closest points (scene/closest_point.hpp).
    /// Sets inst.similar and inst.scale2 from inst.to_world (once, when the placement is added).
    static void measure_stretch(Instance& inst) noexcept;
    /// The closest point of kind `kind`'s objects within √best2 (lowered), into `best`.
    template <class Kind, class Objects>
    void closest_of_kind(Kind kind, const Objects& vec, const Vertex<T>& p, T& best2,
                         ScenePointHit<T>& best) const noexcept;
    /// The closest point of placement i within √best2 (lowered), into `best`.
    void closest_in_placement(std::uint32_t i, const Vertex<T>& p, T& best2, ScenePointHit<T>& best) const noexcept;
    // Crossing counts (scene/count_hits.hpp).
    /// The crossings of kind `kind`'s objects with t in (0, t_max).
    template <class Kind, class Objects>
    std::size_t count_hits_of_kind(Kind kind, const Objects& vec, const Ray<T>& ray, T t_max) const noexcept;
    // Shafts (scene/shaft.hpp).
    /// Whether any of kind `kind`'s objects may meet the shaft.
    template <class Kind, class Objects>
    [[nodiscard]] bool kind_meets_shaft(Kind kind, const Objects& vec, const detail::Shaft<T>& shaft) const noexcept;

    // Streams of rays (scene/stream.hpp).
    /// The rays of a stream given as one array: read in place (the other forms are copied).
    struct RayArray {
        const Ray<T>* rays;
        Ray<T> operator()(std::size_t i) const noexcept { return rays[i]; }
    };
    // Rays of a stream are taken this many at a time (their state lives on the stack).
    static constexpr std::size_t stream_chunk = 64;
    static_assert(stream_chunk <= RayLanes<T>::capacity, "a chunk of rays fits one block of lanes");

    /// may_hit for a kind that has it; every ray for one that has not.
    template <class Shape>
    [[nodiscard]] static std::uint64_t lane_filter(const RayLanes<T>& lanes, const Shape& shape) noexcept;
    /// The bits of rays [0, n) of a block.
    [[nodiscard]] static std::uint64_t all_rays(std::size_t n) noexcept {
        return n >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << n) - 1;
    }
    /// Calls f(k, hit) for the rays k of `open` that hit `shape` (or may hit it), in order of k.
    template <class Shape, class F>
    void each_lane_hit(const RayLanes<T>& lanes, const Ray<T>* rays, const Shape& shape, std::uint64_t open,
                       RayLaneHits<T>& exact, F&& f) const;
    /// Whether the stream calls test kind `kind` rays × objects in lanes.
    template <class Kind, class Objects>
    [[nodiscard]] bool in_lanes(Kind kind, const Objects& vec, bool masked) const noexcept;
    /// rays[first, first + n) of a stream: in place for an array, else copied into `copy`.
    template <class RayAt>
    static const Ray<T>* chunk_of(const RayAt& ray_at, std::size_t first, std::size_t n, Ray<T>* copy);
    /// The stream intersect: kind by kind as intersect does, each ray ending with the same hit.
    template <class RayAt>
    void stream_nearest(const RayAt& ray_at, std::size_t count, Hit<T>* hits, const Culled* culled) const;
    /// The stream occluded: a ray already blocked goes on with t_max = 0 (nothing to find).
    template <class RayAt>
    void stream_occluded(const RayAt& ray_at, std::size_t count, const T* t_max, std::uint8_t* blocked) const;
    /// f(first, end) over blocks of a stream on options.threads threads, once the scene is built.
    template <class F>
    void in_threads(std::size_t count, const StreamOptions& options, const F& f) const;

    std::tuple<std::vector<Object<Shapes<T>>>...> objects_;
    // built by commit() or the first trace after a change (prepare)
    mutable std::tuple<detail::KindAcceleration<T, Shapes<T>>...> accel_;
    std::vector<MeshEntry> meshes_;
    std::vector<Instance> instances_;
    mutable std::shared_ptr<const BvhTree<T>> top_; // over instances_' boxes, from two placements on
    mutable detail::CommitState commit_state_;
    BvhOptions commit_options_; // of the last commit(), for the builds of later traces
};

/// A scene of every built-in kind. Its members and its renderer (render.hpp) are compiled once,
/// for float and double, in isin::io (ISIN_COMPILED, detail/compiled.hpp): a file that uses it
/// compiles the scene's setup, not its traversals; any other list of kinds is compiled where it
/// is used.
template <class T>
using StandardScene = Scene<T, Sphere, Triangle, TexturedTriangle>;

// Setup: materials, textures, objects, meshes and their placements.

template <class T, template <class> class... Shapes>
inline std::uint32_t Scene<T, Shapes...>::add_material(const Material<T>& m) {
    materials.push_back(m);
    return static_cast<std::uint32_t>(materials.size() - 1);
}

template <class T, template <class> class... Shapes>
inline int Scene<T, Shapes...>::add_texture(Texture<T> image) {
    textures.push_back(std::move(image));
    return static_cast<int>(textures.size() - 1);
}

template <class T, template <class> class... Shapes>
inline const Material<T>& Scene<T, Shapes...>::material(std::uint32_t index) const {
    if (index >= materials.size()) detail::throw_missing("material", index, materials.size());
    return materials[index];
}

template <class T, template <class> class... Shapes>
inline const Texture<T>& Scene<T, Shapes...>::texture(int index) const {
    if (index < 0 || std::size_t(index) >= textures.size()) detail::throw_missing("texture", index, textures.size());
    return textures[std::size_t(index)];
}

template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::validate() const {
    for (std::size_t i = 0; i < materials.size(); ++i)
        if (materials[i].texture >= 0 && std::size_t(materials[i].texture) >= textures.size())
            throw std::out_of_range("isin::Scene: material " + std::to_string(i) + " uses texture " +
                                    std::to_string(materials[i].texture) + ", which does not exist (" +
                                    std::to_string(textures.size()) + " textures)");
    for_each_kind([&](auto, const auto& vec) {
        for (std::size_t i = 0; i < vec.size(); ++i) (void)material(vec[i].material);
    });
    for (const MeshEntry& m : meshes_) (void)material(m.material + m.largest_material_id);
}

template <class T, template <class> class... Shapes>
template <class Shape>
inline void Scene<T, Shapes...>::add(const Shape& shape, std::uint32_t material_id) {
    (void)material(material_id);
    constexpr std::size_t kind = index_of<Shape>();
    std::get<kind>(objects_).push_back({shape, material_id});
    std::get<kind>(accel_) = {};
    commit_state_.stale.store(true, std::memory_order_relaxed);
}

template <class T, template <class> class... Shapes>
inline MeshId Scene<T, Shapes...>::add_mesh(Mesh<T> mesh, std::uint32_t material_id, const BvhOptions& options) {
    return add_mesh_entry(std::move(mesh), material_id,
                          [&options](const Mesh<T>& m) { return std::make_shared<const Bvh<T>>(m, options); });
}

template <class T, template <class> class... Shapes>
inline MeshId Scene<T, Shapes...>::add_mesh(const std::vector<Triangle<T>>& triangles, std::uint32_t material_id,
                                            const BvhOptions& options) {
    return add_mesh(Mesh<T>::from_triangles(triangles), material_id, options);
}

template <class T, template <class> class... Shapes>
inline MeshId Scene<T, Shapes...>::add_mesh(Mesh<T> mesh, std::uint32_t material_id, Bvh<T> bvh) {
    return add_mesh_entry(std::move(mesh), material_id, [&bvh](const Mesh<T>& m) {
        check_built_over(bvh, m);
        return std::make_shared<const Bvh<T>>(std::move(bvh));
    });
}

template <class T, template <class> class... Shapes>
inline InstanceId Scene<T, Shapes...>::add_instance(MeshId id, const Transform<T>& to_world) {
    if (id.index >= meshes_.size())
        throw std::out_of_range("isin::Scene::add_instance: mesh " + std::to_string(id.index) + " does not exist");
    const T det = to_world.determinant();
    Instance inst;
    inst.mesh = id.index;
    inst.to_world = to_world;
    inst.to_object = to_world.inverse();
    bool finite = std::isfinite(det) && det != T(0);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) finite = finite && std::isfinite(inst.to_object.m[i][j]);
    if (!finite || !is_finite(to_world.d) || !is_finite(inst.to_object.d))
        throw std::invalid_argument("isin::Scene::add_instance: the transform is not finite or cannot be inverted");
    inst.identity = to_world.is_identity();
    measure_stretch(inst);
    inst.box = world_box(meshes_[id.index].bvh->tree().bounds(), to_world);
    instances_.push_back(inst);
    top_.reset(); // stale: commit() or the next trace builds it again
    commit_state_.stale.store(true, std::memory_order_relaxed);
    return InstanceId{static_cast<std::uint32_t>(instances_.size() - 1)};
}

template <class T, template <class> class... Shapes>
template <class S>
inline void Scene<T, Shapes...>::add_textured_rectangle(const Vertex<T>& v0, const Vertex<T>& v1, const Vertex<T>& v2,
                                                        std::uint32_t material_id) {
    const Vertex<T> v3 = v1 + v2 - v0;
    add(S{{v0, v1, v2}, false}, material_id);
    add(S{{v3, v2, v1}, true}, material_id);
}

template <class T, template <class> class... Shapes>
inline std::size_t Scene<T, Shapes...>::memory() const noexcept {
    std::size_t bytes = instances_.capacity() * sizeof(Instance) + (top_ ? tree_memory(*top_) : 0);
    for (const MeshEntry& m : meshes_)
        bytes += m.bvh->memory() + m.mesh->positions.capacity() * sizeof(Vertex<T>) +
                 m.mesh->indices.capacity() * sizeof(m.mesh->indices[0]) +
                 m.mesh->normals.capacity() * sizeof(Vertex<T>) + m.mesh->uvs.capacity() * sizeof(m.mesh->uvs[0]) +
                 m.mesh->material.capacity() * sizeof(std::uint32_t);
    for_each_kind([&](auto kind, const auto& vec) {
        const auto& accel = std::get<kind>(accel_);
        bytes += vec.capacity() * sizeof(vec[0]);
        if (accel.triangles) bytes += accel.triangles->memory();
        if (accel.objects) bytes += tree_memory(*accel.objects);
        if (accel.batch) bytes += accel.batch->size() * 9 * sizeof(T);
    });
    return bytes;
}

template <class T, template <class> class... Shapes>
template <class MakeBvh>
inline MeshId Scene<T, Shapes...>::add_mesh_entry(Mesh<T> mesh, std::uint32_t material_id, MakeBvh&& make_bvh) {
    mesh.validate();
    MeshEntry entry;
    entry.largest_material_id =
        mesh.material.empty() ? 0 : *std::max_element(mesh.material.begin(), mesh.material.end());
    (void)material(material_id + entry.largest_material_id);
    entry.material = material_id;
    entry.mesh = std::make_shared<const Mesh<T>>(std::move(mesh));
    entry.bvh = make_bvh(*entry.mesh);
    meshes_.push_back(std::move(entry));
    const MeshId id{static_cast<std::uint32_t>(meshes_.size() - 1)};
    (void)add_instance(id, Transform<T>::identity());
    return id;
}

// Throws std::invalid_argument unless `bvh`'s blocks hold the triangles of `mesh` a ray can
// hit (Bvh::bounds usable), each once, with the same vertex bits.
template <class T, template <class> class... Shapes>
inline void Scene<T, Shapes...>::check_built_over(const Bvh<T>& bvh, const Mesh<T>& mesh) {
    const auto fail = [](const std::string& what) {
        return std::invalid_argument("isin::Scene::add_mesh: the Bvh is not this mesh's: " + what);
    };
    std::vector<bool> held(mesh.size(), false);
    for (std::size_t l = 0; l < bvh.leaf_count(); ++l) {
        const auto& block = bvh.blocks()[l];
        for (std::uint32_t k = 0; k < bvh.tree().leaves()[l].count; ++k) {
            const std::uint32_t i = block.primitive[k];
            if (i >= mesh.size() || held[i])
                throw fail("triangle " + std::to_string(i) + (i >= mesh.size() ? " is beyond the mesh" : " twice"));
            held[i] = true;
            const Triangle<T> tri = mesh.triangle(i);
            const Vertex<T>* vs[3] = {&tri.v0, &tri.v1, &tri.v2};
            for (int v = 0; v < 3; ++v)
                for (int a = 0; a < 3; ++a) {
                    const T x = component(*vs[v], a);
                    if (std::memcmp(&x, &block.v[v][a][k], sizeof(T)) != 0)
                        throw fail("triangle " + std::to_string(i) + " has other vertices");
                }
        }
    }
    for (std::size_t i = 0; i < mesh.size(); ++i)
        if (!held[i] && Bvh<T>::bounds(mesh.triangle(i)).usable())
            throw fail("triangle " + std::to_string(i) + " is missing");
}

template <class T, template <class> class... Shapes>
inline Box<T> Scene<T, Shapes...>::world_box(const Box<T>& b, const Transform<T>& to_world) noexcept {
    Box<T> w;
    if (!(b.lo.x <= b.hi.x)) return w;
    for (int c = 0; c < 8; ++c)
        w.grow(to_world.point({(c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y, (c & 4) ? b.hi.z : b.lo.z}));
    return w;
}

} // namespace isin

// The members behind the interface above; each of these files holds nothing without it.
#define ISIN_DETAIL_SCENE_CLASS
#include "scene/build.hpp"
#include "scene/trace.hpp"
#include "scene/stream.hpp"
#include "scene/closest_point.hpp"
#include "scene/count_hits.hpp"
#include "scene/shaft.hpp"

// StandardScene's members come from isin::io where ISIN_COMPILED is defined (detail/compiled.hpp).
#if defined(ISIN_COMPILED)
ISIN_DETAIL_COMPILED_FLOAT template class isin::Scene<float, isin::Sphere, isin::Triangle, isin::TexturedTriangle>;
ISIN_DETAIL_COMPILED_DOUBLE template class isin::Scene<double, isin::Sphere, isin::Triangle, isin::TexturedTriangle>;
#endif
