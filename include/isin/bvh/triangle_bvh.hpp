#pragma once
/// isin — Bvh<T>: a BvhTree over triangles with their blocks, and the leaf tests for the nearest
/// hit, any hit and every hit, with backface culling and a skip mask as filters of the leaf test.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include "../detail/attributes.hpp"
#include "../hit.hpp"
#include "../indexed_mesh.hpp"
#include "../point_hit.hpp"
#include "../ray.hpp"
#include "../read_limits.hpp"
#include "../triangle.hpp"
#include "build.hpp"
#include "closest_point.hpp"
#include "crossings.hpp"
#include "packet.hpp"
#include "traverse.hpp"
#include "tree.hpp"
#include "triangles.hpp"

namespace isin {

/// Which form of its code the Bvh was compiled to for float rays (a build's flags choose, and
/// ISIN_FORCE_PURE turns every vector form off): the node test ("avx+fma", "avx", "vector
/// extensions" or "portable") and the triangle leaf ("avx2+fma", "vector extensions" or
/// "portable"), and the stream calls' ("16 rays, avx2+fma": packets; or "single rays"). For logs
/// and tests that a build takes the path it was meant to.
struct BvhCodePaths {
    const char* slabs;
    const char* leaf;
    const char* packets;
};
inline constexpr BvhCodePaths bvh_code_paths {
#if defined(ISIN_DETAIL_SLABS_AVX) && defined(__FMA__)
    "avx+fma",
#elif defined(ISIN_DETAIL_SLABS_AVX)
    "avx",
#elif ISIN_VECTOR_EXTENSIONS
    "vector extensions",
#else
    "portable",
#endif
#if defined(ISIN_DETAIL_TRIANGLES_AVX2)
        "avx2+fma",
#elif ISIN_VECTOR_EXTENSIONS
        "vector extensions",
#else
        "portable",
#endif
#if defined(ISIN_DETAIL_PACKETS)
        "16 rays, avx2+fma",
#else
        "single rays",
#endif
};

/// Which hits of a triangle Bvh count, beyond t in (0, t_max).
struct HitFilter {
    /// Front faces only: clockwise seen from the ray's origin (§2), i.e. §11 method 1 with the
    /// eye at the origin: a triangle whose normal points away from it is skipped.
    bool cull_backfaces = false;
    /// When set, a triangle with skip[index] ≠ 0 is ignored (e.g. culled by §11 method 2).
    const std::uint8_t* skip = nullptr;
};

/// How a stream call (Bvh's or Scene's intersect, occluded, transmittance over many rays) shares
/// its rays among threads. The results are the same, bit for bit, for any thread count.
struct StreamOptions {
    /// Threads tracing the stream: 1 (the default, as the calls without options) is the calling
    /// thread alone, as suits a call made from a renderer's or a job system's own workers; 0 is
    /// every core (std::thread::hardware_concurrency(), as RenderOptions::threads).
    int threads = 1;
    /// Rays a thread takes at a time: a multiple of 64, so that every packet and chunk of rays is
    /// the one a single thread would form.
    static constexpr std::size_t block = 1024;
};

/// Bounding volume hierarchy over triangles: binned SAH, 8-wide nodes, leaves of up to 8
/// triangles tested 8 at a time by the watertight test. Float and double.
template <class T>
class Bvh {
    static_assert(std::is_floating_point_v<T>, "isin::Bvh needs float or double");

public:
    static constexpr int depth_limit = BvhTree<T>::depth_limit;

    /// Builds over `triangles`; hits report indices into this vector. Zero-area and non-finite
    /// triangles are left out (no ray can hit them).
    explicit Bvh(const std::vector<Triangle<T>>& triangles, const BvhOptions& options = {})
        : Bvh(
              triangles.size(), [&triangles](std::size_t i) { return triangles[i]; }, options) {}

    /// Builds over the triangles of `mesh`; hits report triangle indices. Throws
    /// std::invalid_argument for an invalid mesh (Mesh::validate).
    explicit Bvh(const Mesh<T>& mesh, const BvhOptions& options = {})
        : Bvh((mesh.validate(), mesh.size()), [&mesh](std::size_t i) { return mesh.triangle(i); }, options) {}

    /// Builds over n triangles given by `triangle_of(i)`.
    template <class TriangleOf>
    Bvh(std::size_t n, const TriangleOf& triangle_of, const BvhOptions& options)
        : tree_(build_bvh<T>(
              n, [&](std::size_t i) { return bounds(triangle_of(i)); }, options)),
          blocks_(tree_, triangle_of, detail::thread_count(options.threads)) {}

    /// Nearest hit with t in (0, t_max), watertight: a ray through an edge shared by two
    /// triangles hits at least one of them. Any direction works (t in units of |direction|).
    /// The hit's `primitive` is the triangle's index; of triangles hit at the same t, the lowest
    /// index (whatever the order of the tree).
    [[nodiscard]] Hit<T> intersect(const Ray<T>& ray, T t_max = std::numeric_limits<T>::infinity(),
                                   const HitFilter& filter = {}) const noexcept {
        Hit<T> best;
        T t = t_max;
        detail::TriangleRay<T> r(ray);
        with_cull(filter, [&](auto cull) {
            traverse<Visit::nearest>(tree_, ray, t, nearest_leaf<decltype(cull)::value>(r, best, filter.skip));
        });
        return best;
    }

    /// True when any triangle is hit with t in (0, t_max): shadow rays; stops at the first hit.
    [[nodiscard]] bool occluded(const Ray<T>& ray, T t_max, const HitFilter& filter = {}) const noexcept {
        if (filter.skip)
            return for_each_hit(
                ray, t_max, [](std::uint32_t, const Hit<T>&) { return false; }, filter);
        T t = t_max;
        detail::TriangleRay<T> r(ray);
        return with_cull(
            filter, [&](auto cull) { return traverse<Visit::any>(tree_, ray, t, any_leaf<decltype(cull)::value>(r)); });
    }

    /// Nearest hits of a stream of rays: hits[i] = intersect(rays[i], ∞, filter) for i < count,
    /// the same hits bit for bit. Rays are taken 16 at a time; 16 consecutive rays that start
    /// close together and point the same way (a 4×4 tile of camera rays, shadow rays from such a
    /// tile towards one light) are traced as one packet (float with AVX2 + FMA), faster than
    /// one by one, and two such packets in a row that also agree with each other share one walk;
    /// rays that are not go two at a time with their walks interleaved (traverse_pair).
    void intersect(const Ray<T>* rays, std::size_t count, Hit<T>* hits, const HitFilter& filter = {}) const noexcept {
        intersect(rays, count, nullptr, hits, filter);
    }
    /// As above with a bound per ray: hits[i] = intersect(rays[i], t_max[i], filter).
    void intersect(const Ray<T>* rays, std::size_t count, const T* t_max, Hit<T>* hits,
                   const HitFilter& filter = {}) const noexcept {
        stream<Visit::nearest>(rays, count, t_max, hits, nullptr, filter);
    }
    /// As above, the rays as separate arrays (RaysSoA); t_max may be null (no bound).
    void intersect(const RaysSoA<T>& rays, std::size_t count, const T* t_max, Hit<T>* hits,
                   const HitFilter& filter = {}) const noexcept {
        stream<Visit::nearest>(rays, count, t_max, hits, nullptr, filter);
    }
    /// Shadow rays of a stream: blocked[i] = occluded(rays[i], t_max[i], filter) (1 or 0) for
    /// i < count; packets as for intersect.
    void occluded(const Ray<T>* rays, std::size_t count, const T* t_max, std::uint8_t* blocked,
                  const HitFilter& filter = {}) const noexcept {
        stream<Visit::any>(rays, count, t_max, nullptr, blocked, filter);
    }
    /// As above, the rays as separate arrays.
    void occluded(const RaysSoA<T>& rays, std::size_t count, const T* t_max, std::uint8_t* blocked,
                  const HitFilter& filter = {}) const noexcept {
        stream<Visit::any>(rays, count, t_max, nullptr, blocked, filter);
    }

    /// The stream calls above with the rays shared among options.threads threads (StreamOptions).
    void intersect(const Ray<T>* rays, std::size_t count, Hit<T>* hits, const HitFilter& filter,
                   const StreamOptions& options) const {
        stream_in_threads<Visit::nearest>(rays, count, nullptr, hits, nullptr, filter, options);
    }
    void intersect(const Ray<T>* rays, std::size_t count, const T* t_max, Hit<T>* hits, const HitFilter& filter,
                   const StreamOptions& options) const {
        stream_in_threads<Visit::nearest>(rays, count, t_max, hits, nullptr, filter, options);
    }
    void intersect(const RaysSoA<T>& rays, std::size_t count, const T* t_max, Hit<T>* hits, const HitFilter& filter,
                   const StreamOptions& options) const {
        stream_in_threads<Visit::nearest>(rays, count, t_max, hits, nullptr, filter, options);
    }
    void occluded(const Ray<T>* rays, std::size_t count, const T* t_max, std::uint8_t* blocked, const HitFilter& filter,
                  const StreamOptions& options) const {
        stream_in_threads<Visit::any>(rays, count, t_max, nullptr, blocked, filter, options);
    }
    void occluded(const RaysSoA<T>& rays, std::size_t count, const T* t_max, std::uint8_t* blocked,
                  const HitFilter& filter, const StreamOptions& options) const {
        stream_in_threads<Visit::any>(rays, count, t_max, nullptr, blocked, filter, options);
    }

    /// Calls f(index, hit) for every triangle hit with t in (0, t_max), once each, in no
    /// particular order; f returns true to go on, false to stop. Returns true when f stopped it.
    /// Transmittance through transparent triangles: multiply, stop at an opaque one.
    template <class F>
    bool for_each_hit(const Ray<T>& ray, T t_max, F&& f, const HitFilter& filter = {}) const {
        T t = t_max;
        detail::TriangleRay<T> r(ray);
        return with_cull(filter, [&](auto cull) {
            return traverse<Visit::any>(tree_, ray, t, [&](std::uint32_t leaf, T& t_far) {
                detail::LaneHits<T> hits;
                unsigned lanes = lanes_hit<decltype(cull)::value>(leaf, r, t_far, hits, filter.skip);
                const auto& block = blocks_[leaf];
                for (; lanes; lanes &= lanes - 1) {
                    const int k = detail::lowest_bit(lanes);
                    if (detail::is_padding(block, k)) continue;
                    if (!f(block.primitive[k], Hit<T>{hits.t[k], hits.u[k], hits.v[k], block.primitive[k]}))
                        return true;
                }
                return false;
            });
        });
    }

    /// The closest point of the triangles to p within max_distance (closest_point.hpp); a miss
    /// when none is, or for a NaN or infinite p.
    [[nodiscard]] PointHit<T> closest_point(const Vertex<T>& p,
                                            T max_distance = std::numeric_limits<T>::infinity()) const noexcept {
        return detail::closest_point(tree_, blocks_, p, max_distance);
    }
    /// out[i] = closest_point(points[i]) for i < count, on up to `threads` threads (0 = every core).
    void closest_point(const Vertex<T>* points, std::size_t count, PointHit<T>* out, int threads = 0) const {
        detail::closest_points(tree_, blocks_, points, count, out, threads);
    }
    /// How many times the ray crosses the triangles with t in (0, t_max), a crossing through a
    /// shared edge or vertex once (crossings.hpp): even from outside a closed mesh.
    [[nodiscard]] std::size_t count_hits(const Ray<T>& ray,
                                         T t_max = std::numeric_limits<T>::infinity()) const noexcept {
        return detail::count_crossings(tree_, blocks_, ray, t_max);
    }

    /// Updates the Bvh after the triangles moved (same count, same order): the boxes and blocks
    /// are recomputed, the tree's shape kept. Far cheaper than a rebuild; the tree gets slower to
    /// trace the further the triangles move from where it was built. Triangles left out at the
    /// build (zero-area, non-finite) stay out.
    void refit(const std::vector<Triangle<T>>& triangles, int threads = 0) {
        refit_with([&triangles](std::size_t i) { return triangles[i]; }, threads);
    }
    /// As refit(triangles), for a mesh whose positions changed (same indices).
    void refit(const Mesh<T>& mesh, int threads = 0) {
        mesh.validate();
        refit_with([&mesh](std::size_t i) { return mesh.triangle(i); }, threads);
    }

    /// Number of triangles the Bvh holds (after leaving out degenerate ones).
    [[nodiscard]] std::size_t size() const noexcept { return tree_.size(); }
    /// Number of 8-wide nodes and of leaf blocks.
    [[nodiscard]] std::size_t node_count() const noexcept { return tree_.node_count(); }
    [[nodiscard]] std::size_t leaf_count() const noexcept { return tree_.leaf_count(); }
    /// Levels of 8-wide nodes on the longest path (≤ depth_limit).
    [[nodiscard]] int depth() const noexcept { return tree_.depth(); }
    /// The hierarchy and the blocks, for callers with their own leaf tests.
    [[nodiscard]] const BvhTree<T>& tree() const noexcept { return tree_; }
    [[nodiscard]] const TriangleBlocks<T>& blocks() const noexcept { return blocks_; }
    /// Bytes held (nodes, leaves, indices, blocks).
    [[nodiscard]] std::size_t memory() const noexcept {
        return tree_.node_count() * sizeof(typename BvhTree<T>::Node) +
               tree_.leaf_count() * sizeof(typename BvhTree<T>::Leaf) + tree_.size() * sizeof(std::uint32_t) +
               blocks_.size() * sizeof(typename TriangleBlocks<T>::Block);
    }

    /// Writes the Bvh to the file `path` (docs/bvh_format.md), atomically; throws BvhFileError (a
    /// std::runtime_error) naming the file. File code: compiled in the ISIN_IMPLEMENTATION file
    /// (isin::io), or include bvh/serialize.hpp to compile it where it is called.
    void save(const std::string& path) const;
    /// The Bvh saved in the file `path`, checked (sizes, checksum, every index) and not rebuilt;
    /// throws BvhFileError naming the file and what is wrong. Defined in bvh/serialize.hpp.
    [[nodiscard]] static Bvh load(const std::string& path, ReadLimits limits = {});
    /// As load, from `size` bytes at `data` (a file the caller read or mapped), which it copies.
    [[nodiscard]] static Bvh load_from_memory(const void* data, std::size_t size, ReadLimits limits = {});

    /// The box of a triangle; empty for one no ray can hit (non-finite or zero area), which the
    /// build leaves out.
    [[nodiscard]] static Box<T> bounds(const Triangle<T>& tri) noexcept {
        Box<T> b;
        const Vertex<T> e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
        if (!is_finite(tri.v0) || !is_finite(tri.v1) || !is_finite(tri.v2) ||
            detail::is_degenerate(e1, e2, cross(e1, e2)))
            return b;
        b.grow(tri.v0), b.grow(tri.v1), b.grow(tri.v2);
        return b;
    }

private:
    friend class detail::BvhFile<T>; // save and load (serialize.hpp)
    Bvh() = default;

    // Rays [first, …) of a stream.
    [[nodiscard]] static const Ray<T>* rays_from(const Ray<T>* rays, std::size_t first) noexcept {
        return rays + first;
    }
    [[nodiscard]] static RaysSoA<T> rays_from(const RaysSoA<T>& r, std::size_t first) noexcept {
        return {r.ox + first, r.oy + first, r.oz + first, r.dx + first, r.dy + first, r.dz + first};
    }

    // stream() over blocks of the rays taken in turn by options.threads threads.
    template <Visit visit, class Rays>
    void stream_in_threads(const Rays& rays, std::size_t count, const T* t_max, Hit<T>* hits, std::uint8_t* blocked,
                           const HitFilter& filter, const StreamOptions& options) const {
        detail::parallel_blocks(count, detail::thread_count(options.threads), StreamOptions::block,
                                [&](std::size_t first, std::size_t end) {
                                    stream<visit>(rays_from(rays, first), end - first, t_max ? t_max + first : nullptr,
                                                  hits ? hits + first : nullptr, blocked ? blocked + first : nullptr,
                                                  filter);
                                });
    }

    // f(std::true_type{}) when the filter culls back faces, f(std::false_type{}) otherwise: each
    // leaf test is compiled both ways, so that no walk tests the flag at its leaves.
    template <class F>
    static decltype(auto) with_cull(const HitFilter& filter, F&& f) {
        return filter.cull_backfaces ? f(std::true_type{}) : f(std::false_type{});
    }

    // The leaf test of a nearest-hit walk: the leaf's nearest hit into `best` (take_nearest).
    template <bool cull>
    auto nearest_leaf(detail::TriangleRay<T>& r, Hit<T>& best, const std::uint8_t* skip) const noexcept {
        return [this, &r, &best, skip](std::uint32_t leaf, T& t_far) ISIN_DETAIL_LAMBDA_INLINE {
            take_nearest<cull>(leaf, r, t_far, best, skip);
            return false;
        };
    }
    // The leaf test of an any-hit walk without a skip mask: true (stop) when the leaf is hit.
    template <bool cull>
    auto any_leaf(detail::TriangleRay<T>& r) const noexcept {
        return [this, &r](std::uint32_t leaf, T& t_far) ISIN_DETAIL_LAMBDA_INLINE {
            detail::LaneHits<T> unused;
            return r.ready() && detail::test_block<cull, false>(blocks_[leaf], r, t_far, unused) != 0;
        };
    }

    // intersect(a, limit_a, filter) and intersect(b, limit_b, filter) into hit_a and hit_b, the
    // two walks interleaved (traverse_pair), from the rays' slab terms (sa, sb) and leaf states
    // (ra, rb); a non-empty tree.
    void intersect_pair(const detail::SlabRay<T>& sa, detail::TriangleRay<T>& ra, T limit_a,
                        const detail::SlabRay<T>& sb, detail::TriangleRay<T>& rb, T limit_b, const HitFilter& filter,
                        Hit<T>& hit_a, Hit<T>& hit_b) const noexcept {
        Hit<T> best_a, best_b;
        with_cull(filter, [&](auto cull) {
            constexpr bool c = decltype(cull)::value;
            auto leaf_a = nearest_leaf<c>(ra, best_a, filter.skip);
            auto leaf_b = nearest_leaf<c>(rb, best_b, filter.skip);
            detail::walk_pair<Visit::nearest>(tree_, sa, limit_a, leaf_a, sb, limit_b, leaf_b);
        });
        hit_a = best_a, hit_b = best_b;
    }
    // occluded(a, limit_a, filter) in bit 0 and occluded(b, limit_b, filter) in bit 1, the two
    // walks interleaved, as intersect_pair; the filter has no skip mask.
    unsigned occluded_pair(const detail::SlabRay<T>& sa, detail::TriangleRay<T>& ra, T limit_a,
                           const detail::SlabRay<T>& sb, detail::TriangleRay<T>& rb, T limit_b,
                           const HitFilter& filter) const noexcept {
        return with_cull(filter, [&](auto cull) {
            constexpr bool c = decltype(cull)::value;
            auto leaf_a = any_leaf<c>(ra);
            auto leaf_b = any_leaf<c>(rb);
            return detail::walk_pair<Visit::any>(tree_, sa, limit_a, leaf_a, sb, limit_b, leaf_b);
        });
    }

    // The nearest hit of leaf `leaf` into `best` when it is nearer than best, or ties with it
    // with a lower index. The traversal's bound then stays a little beyond the hit (2⁻¹⁶ of
    // its t): a box's computed entry and a triangle's computed t each round a few ulps their own
    // way, and every triangle that ties with the hit must still be tested, whatever the order
    // the leaves come in, for the lowest index to win on every path (single rays and packets).
    template <bool cull>
    ISIN_DETAIL_INLINE void take_nearest(std::uint32_t leaf, detail::TriangleRay<T>& r, T& t_far, Hit<T>& best,
                                         const std::uint8_t* skip) const noexcept {
        detail::LaneHits<T> hits;
        const unsigned lanes = lanes_hit<cull>(leaf, r, t_far, hits, skip);
        if (lanes) keep_nearest(blocks_[leaf], lanes, hits, t_far, best);
    }
    // take_nearest once the lanes hit (≠ 0) and their hits are known.
    static void keep_nearest(const typename TriangleBlocks<T>::Block& block, unsigned lanes,
                             const detail::LaneHits<T>& hits, T& t_far, Hit<T>& best) noexcept {
        const int k = detail::nearest_lane(lanes, hits, block);
        keep_nearest(Hit<T>{hits.t[k], hits.u[k], hits.v[k], block.primitive[k]}, t_far, best);
    }
    // The same for a block's nearest hit `hit`.
    static void keep_nearest(const Hit<T>& hit, T& t_far, Hit<T>& best) noexcept {
        if (hit.t > best.t || (hit.t == best.t && hit.primitive > best.primitive)) return;
        best = hit;
        t_far = best.t * tie_room;
    }
    // The traversal's bound over a hit's t: t·(1 + 2⁻¹⁶), one rounding (take_nearest).
    static constexpr T tie_room = T(1) + T(0x1p-16);

    // The rays first + k of a chunk of a stream (k in `rest`, n rays from `first`) that no packet
    // took: nearest hits (visit = nearest, into hits) or occlusion (into blocked), two at a time
    // (traverse_pair), their set-up made in lanes where there are packets (trace_rest_in_lanes).
    template <Visit visit, class Rays>
    void trace_unpacked(const Rays& rays, std::size_t first, int n, unsigned rest, const T* t_max, Hit<T>* hits,
                        std::uint8_t* blocked, const HitFilter& filter) const noexcept {
#if defined(ISIN_DETAIL_PACKETS)
        if constexpr (std::is_same_v<T, float>) {
            if ((rest & (rest - 1)) && !tree_.empty()) {
                trace_rest_in_lanes<visit>(rays, first, n, rest, t_max, hits, blocked, filter);
                return;
            }
        }
#endif
        (void)n;
        trace_rest<visit>(rays, first, rest, t_max, hits, blocked, filter, prepare_one(rays, first));
    }

#if defined(ISIN_DETAIL_PACKETS)
    // trace_rest with the rays' set-up made for all 16 at once, in lanes: slab terms (SlabLanes)
    // and watertight shears (set_shears): one ray at a time, the set-up is a tenth of an
    // incoherent ray's cost. The packet loads its own rays: a chunk that is one whole packet
    // needs no more.
    template <Visit visit, class Rays>
    void trace_rest_in_lanes(const Rays& rays, std::size_t first, int n, unsigned rest, const float* t_max,
                             Hit<float>* hits, std::uint8_t* blocked, const HitFilter& filter) const noexcept {
        alignas(64) float c[6][detail::RayPacket::size];
        detail::load_packet_rays(rays, first, n, c);
        const detail::SlabLanes slabs(c, tree_.bound());
        detail::ShearLanes shears;
        detail::set_shears(c[3], c[4], c[5], shears);
        trace_rest<visit>(rays, first, rest, t_max, hits, blocked, filter, [&](int k) {
            const Ray<float> ray{{c[0][k], c[1][k], c[2][k]}, {c[3][k], c[4][k], c[5][k]}};
            return Prepared{slabs.at(k), detail::TriangleRay<float>(ray, shears.at(k), (shears.usable >> k) & 1u)};
        });
    }
#endif
    // A ray's slab terms and leaf state, made before its walk.
    struct Prepared {
        detail::SlabRay<T> slab;
        detail::TriangleRay<T> tri;
    };
    // Prepared of ray first + k, one ray at a time.
    template <class Rays>
    auto prepare_one(const Rays& rays, std::size_t first) const noexcept {
        return [this, &rays, first](int k) {
            const Ray<T> ray = rays[first + std::size_t(k)];
            return Prepared{detail::prepare_slab(ray, tree_.bound()), detail::TriangleRay<T>(ray)};
        };
    }
    // The rays first + k of the stream for k in `rest`, two at a time, their walks interleaved
    // (intersect_pair, occluded_pair), the last one alone; `prepared(k)` gives ray first + k's
    // Prepared. With a skip mask, shadow rays go one by one (for_each_hit).
    template <Visit visit, class Rays, class Prepare>
    void trace_rest(const Rays& rays, std::size_t first, unsigned rest, const T* t_max, Hit<T>* hits,
                    std::uint8_t* blocked, const HitFilter& filter, const Prepare& prepared) const noexcept {
        const auto limit = [t_max](std::size_t i) { return t_max ? t_max[i] : std::numeric_limits<T>::infinity(); };
        while (rest) {
            const int k = detail::lowest_bit(rest);
            const std::size_t i = first + std::size_t(k);
            rest &= rest - 1;
            const bool pair = rest && (visit == Visit::nearest || !filter.skip) && !tree_.empty();
            if (!pair) {
                if constexpr (visit == Visit::nearest)
                    hits[i] = intersect(rays[i], limit(i), filter);
                else
                    blocked[i] = occluded(rays[i], limit(i), filter) ? 1 : 0;
                continue;
            }
            const int m = detail::lowest_bit(rest);
            const std::size_t j = first + std::size_t(m);
            rest &= rest - 1;
            Prepared a = prepared(k), b = prepared(m);
            if constexpr (visit == Visit::nearest) {
                intersect_pair(a.slab, a.tri, limit(i), b.slab, b.tri, limit(j), filter, hits[i], hits[j]);
            } else {
                const unsigned both = occluded_pair(a.slab, a.tri, limit(i), b.slab, b.tri, limit(j), filter);
                blocked[i] = both & 1u ? 1 : 0, blocked[j] = both & 2u ? 1 : 0;
            }
        }
    }

#if defined(ISIN_DETAIL_PACKETS)
    // A packet's nearest hits, lane by lane: rays_in_lanes keeps 16 at a time (keep_nearest in
    // lanes), the other leaf paths one (`keep`). They go to the caller's array when the packet is
    // done.
    struct alignas(64) NearestLanes {
        float t[16], u[16], v[16];
        std::uint32_t primitive[16];
        Hit<float> at(int k) const noexcept { return Hit<float>{t[k], u[k], v[k], primitive[k]}; }
        void set(int k, const Hit<float>& h) noexcept {
            t[k] = h.t, u[k] = h.u, v[k] = h.v, primitive[k] = h.primitive;
        }
        // keep_nearest on lane k with the hits `take(hit, t_far)` keeps.
        template <class Take>
        void keep(int k, float& t_far, const Take& take) noexcept {
            Hit<float> best = at(k);
            take(best, t_far);
            set(k, best);
        }
    };

    // A packet of a stream being traced: its rays lane by lane, the packet, the leaves' state of
    // its rays and their nearest hits.
    struct PacketTrace {
        static constexpr int size = detail::RayPacket::size;
        alignas(64) float c[6][size]; // the rays, lane by lane (make_packet tells incoherent ones first)
        detail::RayPacket p;
        // The leaves' state of a ray is made when it reaches its first leaf (no constructor runs
        // for the others: most rays of a frame that miss never do).
        union LeafRays {
            detail::TriangleRay<float> lane[size];
            LeafRays() noexcept {}
        } tri;
        unsigned made = 0;         // the lanes of tri constructed
        detail::ShearLanes shears; // all the rays' shears at once, when the first leaf is reached
        bool shears_made = false;
        NearestLanes nearest;
    };

    // Sets up `s` for the rays [first, first + n) of a stream (n ≥ 2): returns the rays
    // make_packet takes (s.p.lanes; 0 for none, and then s.p.wide tells whether their origins
    // lay too far apart).
    template <Visit visit, class Rays>
    unsigned start_packet(PacketTrace& s, const Rays& rays, std::size_t first, int n,
                          const float* t_max) const noexcept {
        constexpr int size = PacketTrace::size;
        detail::load_packet_rays(rays, first, n, s.c);
        alignas(32) float limit[detail::RayPacket::size];
        if (!t_max) {
            _mm256_store_ps(limit, _mm256_set1_ps(std::numeric_limits<float>::infinity()));
            _mm256_store_ps(limit + 8, _mm256_set1_ps(std::numeric_limits<float>::infinity()));
        } else if (n == size) {
            _mm256_store_ps(limit, _mm256_loadu_ps(t_max + first));
            _mm256_store_ps(limit + 8, _mm256_loadu_ps(t_max + first + 8));
        } else {
            for (int k = 0; k < size; ++k) limit[k] = t_max[first + std::size_t(k < n ? k : 0)];
        }
        const unsigned lanes = detail::make_packet(s.p, s.c, n, limit, tree_.bound(), tree_.leaf_scale());
        if (lanes && visit == Visit::nearest)
            for (int k = 0; k < size; ++k) s.nearest.set(k, Hit<float>{}); // no hit
        return lanes;
    }

    // Whether packets a and b (both made) may share one walk (walk_packets), and then `box`, the
    // bounds of both: their rays point into one octant, their first rays' directions lie within
    // packet_cone_cos of each other and their origins within packet_origin_spread leaf sizes
    // along each axis, as make_packet asks of one packet's rays.
    bool packets_share(const PacketTrace& a, const PacketTrace& b, detail::PacketBounds& box) const noexcept {
        bool negative[3];
        for (int axis = 0; axis < 3; ++axis) {
            if (a.p.near_plane[axis] != b.p.near_plane[axis]) return false;
            negative[axis] = !detail::packet_positive(a.p, axis);
        }
        const int i = detail::lowest_bit(a.p.lanes), j = detail::lowest_bit(b.p.lanes);
        if (!((detail::packet_cone<false>(b.c, a.c, i) >> j) & 1u)) return false;
        float lo[6], hi[6];
        for (int k = 0; k < 6; ++k) lo[k] = std::min(a.p.lo[k], b.p.lo[k]), hi[k] = std::max(a.p.hi[k], b.p.hi[k]);
        if (!detail::origins_close(lo, hi, tree_.leaf_scale())) return false;
        detail::set_packet_bounds(box, lo, hi, negative, tree_.bound());
        return true;
    }

    // The packet's results into the caller's arrays: the nearest hits, or whether each ray is
    // blocked (it left the packet). A whole packet's hits go by four 4×4 transposes (t, u, v
    // and primitive of a hit in one 128-bit store) rather than field by field, or five 512-bit
    // stores with a permute each (slower: docs/ideas.md).
    template <Visit visit>
    static void finish_packet(const PacketTrace& s, unsigned lanes, std::size_t first, Hit<float>* hits,
                              std::uint8_t* blocked) noexcept {
#if defined(__AVX512F__)
        if constexpr (visit == Visit::nearest) {
            if (lanes == 0xffffu) { // the 16 hits' t, u, v and primitive in 16 stores (store_quads)
                static_assert(sizeof(Hit<float>) == 5 * sizeof(float) && std::is_standard_layout_v<Hit<float>>,
                              "Hit<float> is t, u, v, primitive, geometry");
                const __m512 fields[4] = {_mm512_load_ps(s.nearest.t), _mm512_load_ps(s.nearest.u),
                                          _mm512_load_ps(s.nearest.v),
                                          _mm512_castsi512_ps(_mm512_load_si512(s.nearest.primitive))};
                Hit<float>* const out = hits + first;
                detail::store_quads(fields, [out](int k) { return &out[k].t; });
                for (int k = 0; k < 16; ++k) out[k].geometry = Hit<float>::none;
                return;
            }
        }
#endif
        for (; lanes; lanes &= lanes - 1) {
            const int k = detail::lowest_bit(lanes);
            if constexpr (visit == Visit::nearest)
                hits[first + std::size_t(k)] = s.nearest.at(k);
            else
                blocked[first + std::size_t(k)] = (s.p.lanes >> k) & 1u ? 0 : 1;
        }
    }

    // The leaf test of packet `s`'s walk (walk_packets): the rays `active` against leaf `leaf`,
    // in lanes where they can be (rays_in_lanes), else two or one at a time.
    template <Visit visit, bool culls>
    auto packet_leaf(PacketTrace& s, const HitFilter& filter) const noexcept {
        return [this, &s, &filter](std::uint32_t leaf, unsigned active) {
            detail::TriangleRay<float>* const tri = s.tri.lane;
            const auto& c = s.c;
            float(&t_far)[16] = s.p.t_far;
            if (!s.shears_made) detail::set_shears(c[3], c[4], c[5], s.shears), s.shears_made = true;
            unsigned done = 0;
#if defined(ISIN_DETAIL_TRIANGLE_PAIRS)
            active =
                rays_in_lanes<culls, visit>(blocks_[leaf], s.p, s.shears, active, t_far, s.nearest, filter.skip, done);
#endif
            for (unsigned fresh = active & ~s.made; fresh; fresh &= fresh - 1) {
                const int k = detail::lowest_bit(fresh);
                new (tri + k)
                    detail::TriangleRay<float>(Ray<float>{{c[0][k], c[1][k], c[2][k]}, {c[3][k], c[4][k], c[5][k]}},
                                               s.shears.at(k), (s.shears.usable >> k) & 1u);
            }
            s.made |= active;
#if defined(ISIN_DETAIL_TRIANGLE_PAIRS)
            // Two rays at a time in one register while two are left (test_block_pair).
            for (unsigned rest = active; rest & (rest - 1);) {
                const int k = detail::lowest_bit(rest);
                rest &= rest - 1;
                const int j = detail::lowest_bit(rest);
                rest &= rest - 1;
                if (!tri[k].ready() || !tri[j].ready()) continue; // no hit for either (single: the same)
                active &= ~(1u << k | 1u << j);
                const auto& block = blocks_[leaf];
                detail::LaneHits<float> hk, hj;
                const unsigned both = detail::test_block_pair<culls, visit == Visit::nearest>(
                    block, tri[k], tri[j], t_far[k], t_far[j], hk, hj);
                const unsigned lk = skip_lanes(block, both & 0xffu, filter.skip),
                               lj = skip_lanes(block, both >> 8, filter.skip);
                if constexpr (visit == Visit::nearest) {
                    const auto keep_block = [&block](const detail::LaneHits<float>& h, unsigned l) {
                        return [&block, &h, l](Hit<float>& best, float& t) { keep_nearest(block, l, h, t, best); };
                    };
                    if (lk) s.nearest.keep(k, t_far[k], keep_block(hk, lk));
                    if (lj) s.nearest.keep(j, t_far[j], keep_block(hj, lj));
                } else {
                    done |= (lk ? 1u << k : 0u) | (lj ? 1u << j : 0u);
                }
            }
#endif
            for (; active; active &= active - 1) {
                const int k = detail::lowest_bit(active);
                if constexpr (visit == Visit::nearest) {
                    s.nearest.keep(k, t_far[k], [&](Hit<float>& best, float& t) {
                        take_nearest<culls>(leaf, tri[k], t, best, filter.skip);
                    });
                } else {
                    detail::LaneHits<float> unused;
                    if (filter.skip ? lanes_hit<culls>(leaf, tri[k], t_far[k], unused, filter.skip) != 0
                                    : tri[k].ready() && detail::test_block<culls, false>(blocks_[leaf], tri[k],
                                                                                         t_far[k], unused) != 0)
                        done |= 1u << k;
                }
            }
            return done;
        };
    }

    // The packet part of stream() (float) for two consecutive chunks of up to 16 rays (chunk i:
    // rays [first[i], first[i] + n[i]), n[1] may be 0): each chunk's rays make_packet takes into
    // packed[i], and wide[i] when it took none because their origins lay too far apart
    // (RayPacket::wide). Two packets that packets_share says may go together are traced by one
    // walk (walk_packets), as 32 rays under one interval test: camera rays of two adjacent 4×4
    // tiles, or shadow rays from them towards one light.
    template <Visit visit, class Rays>
    ISIN_DETAIL_NOINLINE void trace_packets(const Rays& rays, const std::size_t (&first)[2], const int (&n)[2],
                                            const float* t_max, Hit<float>* hits, std::uint8_t* blocked,
                                            const HitFilter& filter, unsigned (&packed)[2],
                                            bool (&wide)[2]) const noexcept {
        PacketTrace s[2];
        for (int i = 0; i < 2; ++i) {
            packed[i] = n[i] > 1 ? start_packet<visit>(s[i], rays, first[i], n[i], t_max) : 0u;
            wide[i] = n[i] > 1 && !packed[i] && s[i].p.wide;
        }
        if (!packed[0] && !packed[1]) return;
        with_cull(filter, [&](auto cull) {
            constexpr bool culls = decltype(cull)::value;
            auto leaf_a = packet_leaf<visit, culls>(s[0], filter);
            auto leaf_b = packet_leaf<visit, culls>(s[1], filter);
            const auto soon = [this](std::uint32_t leaf) { prefetch_block(leaf); };
            detail::PacketBounds box;
            if (packed[0] && packed[1] && packets_share(s[0], s[1], box)) {
                detail::RayPacket* const ps[2] = {&s[0].p, &s[1].p};
                detail::walk_packets<visit>(
                    tree_, ps, box,
                    [&](std::uint32_t leaf, unsigned active) {
                        unsigned done = 0;
                        if (active & 0xffffu) done = leaf_a(leaf, active & 0xffffu);
                        if (active >> 16) done |= leaf_b(leaf, active >> 16) << 16;
                        return done;
                    },
                    soon);
                return;
            }
            if (packed[0]) detail::walk_packet<visit>(tree_, s[0].p, leaf_a, soon);
            if (packed[1]) detail::walk_packet<visit>(tree_, s[1].p, leaf_b, soon);
        });
        for (int i = 0; i < 2; ++i)
            if (packed[i]) finish_packet<visit>(s[i], packed[i], first[i], hits, blocked);
    }

    // Asks the cache for leaf `leaf`'s triangles (all five lines of its block): walk_packets
    // tells of each leaf some ray enters when it tests the leaf's parent.
    void prefetch_block(std::uint32_t leaf) const noexcept {
        detail::prefetch_lines(&blocks_[leaf], sizeof(typename TriangleBlocks<T>::Block));
    }

#if defined(ISIN_DETAIL_TRIANGLE_PAIRS)
    // The triangles of a block some ray of the packet may hit: the packet's interval test on each
    // triangle's box (packet_hit_boxes), whose margin covers how far from a triangle the
    // watertight test can find a hit (make_packet). A triangle's test does not depend on the
    // others of its block (triangles_avx2.hpp), so the rest need no test: on coherent meshes it
    // leaves about half of a block's triangles untested. Always inlined into the packet's leaf
    // test, whose loop a call would break.
    ISIN_DETAIL_INLINE static unsigned triangles_in_reach(const typename TriangleBlocks<float>::Block& block,
                                                          const detail::RayPacket& p) noexcept {
        const auto planes = [&](int a, __m256& near, __m256& far) {
            const __m256 v0 = _mm256_load_ps(block.v[0][a]), v1 = _mm256_load_ps(block.v[1][a]),
                         v2 = _mm256_load_ps(block.v[2][a]);
            const __m256 lo = _mm256_min_ps(_mm256_min_ps(v0, v1), v2), hi = _mm256_max_ps(_mm256_max_ps(v0, v1), v2);
            const bool positive = detail::packet_positive(p, a);
            near = positive ? lo : hi, far = positive ? hi : lo;
        };
        __m256 t_near;
        // Not the padding (is_padding: lanes after the first that repeat its triangle), in one compare.
        const unsigned padding = unsigned(_mm256_movemask_ps(
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(block.primitive)),
                                                   _mm256_set1_epi32(int(block.primitive[0]))))));
        return detail::packet_hit_boxes(planes, p, detail::packet_t_far(p), t_near) & ~(padding & 0xfeu);
    }

    // A packet's leaf with the rays in lanes, triangle by triangle (test_block_rays), a group of
    // rays whose shears permute the axes alike at a time (most packets are one group). A group
    // with fewer rays than half the block's triangles is left to the rays one by one (two per
    // register): small groups leave most lanes of a triangle-by-triangle test empty, and a
    // threshold of as many rays as triangles is slower on the large meshes.
    // Nearest hits go into `best` (keep_nearest in lanes) and lower t_far; occluded rays into
    // `done`. Returns the rays left for one by one: those groups, the rays some triangle's test
    // is not trusted for, and the rays without a shear.
    template <bool cull, Visit visit>
    static unsigned rays_in_lanes(const typename TriangleBlocks<float>::Block& block, const detail::RayPacket& p,
                                  const detail::ShearLanes& shears, unsigned active, float (&t_far)[16],
                                  NearestLanes& best, const std::uint8_t* skip, unsigned& done) noexcept {
        const unsigned triangles = triangles_in_reach(block, p);
        if (!triangles) return active & ~shears.usable; // no ray of the packet comes near one
        const int count = detail::bit_count(triangles);
        const __m512i kx = _mm512_load_si512(shears.k[0]), kz = _mm512_load_si512(shears.k[2]);
        unsigned one_by_one = active & ~shears.usable;
        for (unsigned rest = active & shears.usable; rest;) {
            const int first = detail::lowest_bit(rest);
            detail::ShearedRays r;
            r.kx = shears.k[0][first], r.ky = shears.k[1][first], r.kz = shears.k[2][first];
            const unsigned group = rest & _mm512_cmpeq_epi32_mask(kx, _mm512_set1_epi32(r.kx)) &
                                   _mm512_cmpeq_epi32_mask(kz, _mm512_set1_epi32(r.kz));
            rest &= ~group;
            if (2 * detail::bit_count(group) < count) {
                one_by_one |= group;
                continue;
            }
            r.ox = _mm512_load_ps(p.org[r.kx]), r.oy = _mm512_load_ps(p.org[r.ky]), r.oz = _mm512_load_ps(p.org[r.kz]);
            r.Sx = _mm512_load_ps(shears.S[0]), r.Sy = _mm512_load_ps(shears.S[1]), r.Sz = _mm512_load_ps(shears.S[2]);
            r.t_max = _mm512_load_ps(t_far);
            detail::BlockHitLanes nearest;
            const unsigned hit = detail::test_block_rays<cull, visit == Visit::nearest>(block, r, group, triangles,
                                                                                        skip, nearest, one_by_one);
            if constexpr (visit == Visit::nearest) {
                if (!hit) continue;
                // keep_nearest's rule lane by lane: nearer, or as near with an index no higher.
                const __m512 best_t = _mm512_load_ps(best.t);
                const __mmask16 keep = __mmask16(
                    hit & (unsigned(_mm512_cmp_ps_mask(nearest.t, best_t, _CMP_LT_OQ)) |
                           (unsigned(_mm512_cmp_ps_mask(nearest.t, best_t, _CMP_EQ_OQ)) &
                            unsigned(_mm512_cmple_epu32_mask(nearest.primitive, _mm512_load_si512(best.primitive))))));
                _mm512_mask_store_ps(best.t, keep, nearest.t), _mm512_mask_store_ps(best.u, keep, nearest.u);
                _mm512_mask_store_ps(best.v, keep, nearest.v);
                _mm512_mask_store_epi32(best.primitive, keep, nearest.primitive);
                _mm512_mask_storeu_ps(t_far, keep, _mm512_mul_ps(nearest.t, _mm512_set1_ps(tie_room)));
            } else {
                done |= hit;
            }
        }
        return one_by_one;
    }
#endif
#endif

    // The lanes of leaf `leaf` hit with 0 < t < t_max, without the skipped triangles.
    template <bool cull>
    ISIN_DETAIL_INLINE unsigned lanes_hit(std::uint32_t leaf, detail::TriangleRay<T>& r, T t_max,
                                          detail::LaneHits<T>& hits, const std::uint8_t* skip) const noexcept {
        if (!r.ready()) return 0;
        const auto& block = blocks_[leaf];
        return skip_lanes(block, detail::test_block<cull>(block, r, t_max, hits), skip);
    }
    // `lanes` of `block` without the triangles the skip mask names.
    ISIN_DETAIL_INLINE static unsigned skip_lanes(const typename TriangleBlocks<T>::Block& block, unsigned lanes,
                                                  const std::uint8_t* skip) noexcept {
        if (skip)
            for (unsigned rest = lanes; rest; rest &= rest - 1) {
                const int k = detail::lowest_bit(rest);
                if (skip[block.primitive[k]]) lanes &= ~(1u << k);
            }
        return lanes;
    }

    // How far ahead of the chunk being traced stream() asks for its rays: two pairs of chunks
    // (stream() takes a pair at a time): one pair ahead left shadow rays waiting for their loads.
    static constexpr std::size_t prefetch_ahead = 64;
    // Asks the cache for the 16 rays from `first` on (and their t_max): the chunks read them one
    // after the other, but each chunk's walk between the reads touches much other memory.
    static void prefetch_chunk(const Ray<T>* rays, std::size_t first, std::size_t count, const T* t_max) noexcept {
        const std::size_t end = std::min(count, first + 16);
        detail::prefetch_lines(rays + first, (end - first) * sizeof(Ray<T>));
        if (t_max) detail::prefetch(t_max + first), detail::prefetch(t_max + end - 1);
    }
    static void prefetch_chunk(const RaysSoA<T>& rays, std::size_t first, std::size_t count, const T* t_max) noexcept {
        const std::size_t last = std::min(count, first + 16) - 1;
        const T* const arrays[6] = {rays.ox, rays.oy, rays.oz, rays.dx, rays.dy, rays.dz};
        for (const T* a : arrays) detail::prefetch(a + first), detail::prefetch(a + last);
        if (t_max) detail::prefetch(t_max + first), detail::prefetch(t_max + last);
    }

    // Rays: const Ray<T>* or RaysSoA<T> (ray i is rays[i]), 16 at a time (a chunk); where
    // there are packets, two chunks at a time try to form one each (trace_packets), and the rays
    // no packet takes go two at a time (trace_unpacked).
    template <Visit visit, class Rays>
    void stream(const Rays& rays, std::size_t count, const T* t_max, Hit<T>* hits, std::uint8_t* blocked,
                const HitFilter& filter) const noexcept {
        // After a chunk of incoherent rays the next three do not try a packet, after two such
        // tries in a row the next seven, and so on up to 63: an incoherent stream mostly stays so.
        // Coherent rays start again from three, also when their origins were too far apart for a
        // packet: those are a few chunks at silhouettes, between chunks that form packets
        // (docs/performance.md).
        int wait = 0, backoff = 3;
        const auto chunk_size = [count](std::size_t first) {
            return first < count ? int(std::min<std::size_t>(16, count - first)) : 0;
        };
        for (std::size_t first = 0; first < count;) {
            if (first + prefetch_ahead < count) prefetch_chunk(rays, first + prefetch_ahead, count, t_max);
            // One chunk, or two that try packets.
            const int n = chunk_size(first);
            std::size_t firsts[2] = {first, first + std::size_t(n)};
            int sizes[2] = {n, 0};
            unsigned packed[2] = {0, 0};
            bool wide[2] = {false, false}, tried = false;
#if defined(ISIN_DETAIL_PACKETS)
            if constexpr (std::is_same_v<T, float>) {
                if (wait == 0 && !tree_.empty()) {
                    if (firsts[1] + prefetch_ahead < count)
                        prefetch_chunk(rays, firsts[1] + prefetch_ahead, count, t_max);
                    sizes[1] = chunk_size(firsts[1]);
                    trace_packets<visit>(rays, firsts, sizes, t_max, hits, blocked, filter, packed, wide);
                    tried = true;
                }
            }
#endif
            for (int i = 0; i < 2 && sizes[i] > 0; ++i) {
                trace_unpacked<visit>(rays, firsts[i], sizes[i], ((1u << sizes[i]) - 1u) & ~packed[i], t_max, hits,
                                      blocked, filter);
                if (!tried) {
                    if (wait > 0) --wait;
                } else if (packed[i] || wide[i]) { // coherent
                    wait = 0, backoff = 3;
                } else {
                    wait = backoff, backoff = std::min(2 * backoff + 1, 63);
                }
            }
            first = firsts[1] + std::size_t(sizes[1]);
        }
    }

    template <class TriangleOf>
    void refit_with(const TriangleOf& triangle_of, int threads) {
        blocks_.refit(tree_, triangle_of, detail::thread_count(threads));
        tree_.refit([&](std::uint32_t i) { return bounds(triangle_of(i)); });
    }

    BvhTree<T> tree_;
    TriangleBlocks<T> blocks_;
};

} // namespace isin
