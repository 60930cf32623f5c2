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
#include "triangle_packets.hpp"
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
    friend struct detail::BvhPackets<T>;
    using Packets = detail::BvhPackets<T>; // the packet and stream leaf code (triangle_packets.hpp)
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
                Packets::template trace_rest_in_lanes<visit>(*this, rays, first, n, rest, t_max, hits, blocked, filter);
                return;
            }
        }
#endif
        (void)n;
        trace_rest<visit>(rays, first, rest, t_max, hits, blocked, filter, Packets::prepare_one(*this, rays, first));
    }

    // A ray's slab terms and leaf state, made before its walk.
    struct Prepared {
        detail::SlabRay<T> slab;
        detail::TriangleRay<T> tri;
    };
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
            if (first + Packets::prefetch_ahead < count)
                Packets::prefetch_chunk(rays, first + Packets::prefetch_ahead, count, t_max);
            // One chunk, or two that try packets.
            const int n = chunk_size(first);
            std::size_t firsts[2] = {first, first + std::size_t(n)};
            int sizes[2] = {n, 0};
            unsigned packed[2] = {0, 0};
            bool wide[2] = {false, false}, tried = false;
#if defined(ISIN_DETAIL_PACKETS)
            if constexpr (std::is_same_v<T, float>) {
                if (wait == 0 && !tree_.empty()) {
                    if (firsts[1] + Packets::prefetch_ahead < count)
                        Packets::prefetch_chunk(rays, firsts[1] + Packets::prefetch_ahead, count, t_max);
                    sizes[1] = chunk_size(firsts[1]);
                    Packets::template trace_packets<visit>(*this, rays, firsts, sizes, t_max, hits, blocked, filter,
                                                           packed, wide);
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
