#pragma once
/// isin — the packet and stream leaf code of Bvh<T> (triangle_bvh.hpp): the chunks of a stream
/// and their prefetches, the set-up of rays traced two at a time, and the packets of 16 coherent
/// rays (float with AVX2 + FMA): their start, sharing of a walk, leaf tests and results.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <new>
#include <type_traits>

#include "../detail/attributes.hpp"
#include "../hit.hpp"
#include "../ray.hpp"
#include "packet.hpp"
#include "traverse.hpp"
#include "tree.hpp"
#include "triangles.hpp"

namespace isin {

template <class T>
class Bvh;

namespace detail {

/// The packet and stream leaf code of Bvh<T>, its friend: static members taking the Bvh, which its
/// stream calls use (Bvh::stream, Bvh::trace_unpacked); `Filter` is HitFilter, declared after.
template <class T>
struct BvhPackets {
    using Owner = Bvh<T>;

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

    // Bvh::Prepared of ray first + k, one ray at a time.
    template <class Rays>
    static auto prepare_one(const Owner& bvh, const Rays& rays, std::size_t first) noexcept {
        return [&bvh, &rays, first](int k) {
            const Ray<T> ray = rays[first + std::size_t(k)];
            return typename Owner::Prepared{detail::prepare_slab(ray, bvh.tree_.bound()), detail::TriangleRay<T>(ray)};
        };
    }

#if defined(ISIN_DETAIL_PACKETS)
    // trace_rest with the rays' set-up made for all 16 at once, in lanes: slab terms (SlabLanes)
    // and watertight shears (set_shears): one ray at a time, the set-up is a tenth of an
    // incoherent ray's cost. The packet loads its own rays: a chunk that is one whole packet
    // needs no more.
    template <Visit visit, class Rays, class Filter>
    static void trace_rest_in_lanes(const Owner& bvh, const Rays& rays, std::size_t first, int n, unsigned rest,
                                    const float* t_max, Hit<float>* hits, std::uint8_t* blocked,
                                    const Filter& filter) noexcept {
        alignas(64) float c[6][detail::RayPacket::size];
        detail::load_packet_rays(rays, first, n, c);
        const detail::SlabLanes slabs(c, bvh.tree_.bound());
        detail::ShearLanes shears;
        detail::set_shears(c[3], c[4], c[5], shears);
        bvh.template trace_rest<visit>(rays, first, rest, t_max, hits, blocked, filter, [&](int k) {
            const Ray<float> ray{{c[0][k], c[1][k], c[2][k]}, {c[3][k], c[4][k], c[5][k]}};
            return typename Owner::Prepared{slabs.at(k),
                                            detail::TriangleRay<float>(ray, shears.at(k), (shears.usable >> k) & 1u)};
        });
    }

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
    static unsigned start_packet(const Owner& bvh, PacketTrace& s, const Rays& rays, std::size_t first, int n,
                                 const float* t_max) noexcept {
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
        const unsigned lanes = detail::make_packet(s.p, s.c, n, limit, bvh.tree_.bound(), bvh.tree_.leaf_scale());
        if (lanes && visit == Visit::nearest)
            for (int k = 0; k < size; ++k) s.nearest.set(k, Hit<float>{}); // no hit
        return lanes;
    }

    // Whether packets a and b (both made) may share one walk (walk_packets), and then `box`, the
    // bounds of both: their rays point into one octant, their first rays' directions lie within
    // packet_cone_cos of each other and their origins within packet_origin_spread leaf sizes
    // along each axis, as make_packet asks of one packet's rays.
    static bool packets_share(const Owner& bvh, const PacketTrace& a, const PacketTrace& b,
                              detail::PacketBounds& box) noexcept {
        bool negative[3];
        for (int axis = 0; axis < 3; ++axis) {
            if (a.p.near_plane[axis] != b.p.near_plane[axis]) return false;
            negative[axis] = !detail::packet_positive(a.p, axis);
        }
        const int i = detail::lowest_bit(a.p.lanes), j = detail::lowest_bit(b.p.lanes);
        if (!((detail::packet_cone<false>(b.c, a.c, i) >> j) & 1u)) return false;
        float lo[6], hi[6];
        for (int k = 0; k < 6; ++k) lo[k] = std::min(a.p.lo[k], b.p.lo[k]), hi[k] = std::max(a.p.hi[k], b.p.hi[k]);
        if (!detail::origins_close(lo, hi, bvh.tree_.leaf_scale())) return false;
        detail::set_packet_bounds(box, lo, hi, negative, bvh.tree_.bound());
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
    template <Visit visit, bool culls, class Filter>
    static auto packet_leaf(const Owner& bvh, PacketTrace& s, const Filter& filter) noexcept {
        return [&bvh, &s, &filter](std::uint32_t leaf, unsigned active) {
            detail::TriangleRay<float>* const tri = s.tri.lane;
            const auto& c = s.c;
            float(&t_far)[16] = s.p.t_far;
            if (!s.shears_made) detail::set_shears(c[3], c[4], c[5], s.shears), s.shears_made = true;
            unsigned done = 0;
#if defined(ISIN_DETAIL_TRIANGLE_PAIRS)
            active = rays_in_lanes<culls, visit>(bvh.blocks_[leaf], s.p, s.shears, active, t_far, s.nearest,
                                                 filter.skip, done);
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
                const auto& block = bvh.blocks_[leaf];
                detail::LaneHits<float> hk, hj;
                const unsigned both = detail::test_block_pair<culls, visit == Visit::nearest>(
                    block, tri[k], tri[j], t_far[k], t_far[j], hk, hj);
                const unsigned lk = Owner::skip_lanes(block, both & 0xffu, filter.skip),
                               lj = Owner::skip_lanes(block, both >> 8, filter.skip);
                if constexpr (visit == Visit::nearest) {
                    const auto keep_block = [&block](const detail::LaneHits<float>& h, unsigned l) {
                        return
                            [&block, &h, l](Hit<float>& best, float& t) { Owner::keep_nearest(block, l, h, t, best); };
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
                        bvh.template take_nearest<culls>(leaf, tri[k], t, best, filter.skip);
                    });
                } else {
                    detail::LaneHits<float> unused;
                    if (filter.skip ? bvh.template lanes_hit<culls>(leaf, tri[k], t_far[k], unused, filter.skip) != 0
                                    : tri[k].ready() && detail::test_block<culls, false>(bvh.blocks_[leaf], tri[k],
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
    template <Visit visit, class Rays, class Filter>
    ISIN_DETAIL_NOINLINE static void trace_packets(const Owner& bvh, const Rays& rays, const std::size_t (&first)[2],
                                                   const int (&n)[2], const float* t_max, Hit<float>* hits,
                                                   std::uint8_t* blocked, const Filter& filter, unsigned (&packed)[2],
                                                   bool (&wide)[2]) noexcept {
        PacketTrace s[2];
        for (int i = 0; i < 2; ++i) {
            packed[i] = n[i] > 1 ? start_packet<visit>(bvh, s[i], rays, first[i], n[i], t_max) : 0u;
            wide[i] = n[i] > 1 && !packed[i] && s[i].p.wide;
        }
        if (!packed[0] && !packed[1]) return;
        Owner::with_cull(filter, [&](auto cull) {
            constexpr bool culls = decltype(cull)::value;
            auto leaf_a = packet_leaf<visit, culls>(bvh, s[0], filter);
            auto leaf_b = packet_leaf<visit, culls>(bvh, s[1], filter);
            const auto soon = [&bvh](std::uint32_t leaf) { prefetch_block(bvh, leaf); };
            detail::PacketBounds box;
            if (packed[0] && packed[1] && packets_share(bvh, s[0], s[1], box)) {
                detail::RayPacket* const ps[2] = {&s[0].p, &s[1].p};
                detail::walk_packets<visit>(
                    bvh.tree_, ps, box,
                    [&](std::uint32_t leaf, unsigned active) {
                        unsigned done = 0;
                        if (active & 0xffffu) done = leaf_a(leaf, active & 0xffffu);
                        if (active >> 16) done |= leaf_b(leaf, active >> 16) << 16;
                        return done;
                    },
                    soon);
                return;
            }
            if (packed[0]) detail::walk_packet<visit>(bvh.tree_, s[0].p, leaf_a, soon);
            if (packed[1]) detail::walk_packet<visit>(bvh.tree_, s[1].p, leaf_b, soon);
        });
        for (int i = 0; i < 2; ++i)
            if (packed[i]) finish_packet<visit>(s[i], packed[i], first[i], hits, blocked);
    }

    // Asks the cache for leaf `leaf`'s triangles (all five lines of its block): walk_packets
    // tells of each leaf some ray enters when it tests the leaf's parent.
    static void prefetch_block(const Owner& bvh, std::uint32_t leaf) noexcept {
        detail::prefetch_lines(&bvh.blocks_[leaf], sizeof(typename TriangleBlocks<T>::Block));
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
                _mm512_mask_storeu_ps(t_far, keep, _mm512_mul_ps(nearest.t, _mm512_set1_ps(Owner::tie_room)));
            } else {
                done |= hit;
            }
        }
        return one_by_one;
    }
#endif
#endif
};

} // namespace detail
} // namespace isin
