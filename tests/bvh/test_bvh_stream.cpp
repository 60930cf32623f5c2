// Bvh's stream calls (bvh/packet.hpp behind them) give, ray for ray, the single-ray calls' results
// bit for bit: coherent tiles of camera rays (packets), random rays (one by one), and rays that
// break packets (NaN, zero direction, axis-parallel, −0.0, bad t_max) mixed into them.
#include <isin/bvh.hpp>

#include <doctest/doctest.h>

#include "../support/workloads.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace {

template <class T>
bool same_bits(T a, T b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

template <class T>
bool same_hit(const isin::Hit<T>& a, const isin::Hit<T>& b) {
    return same_bits(a.t, b.t) && same_bits(a.u, b.u) && same_bits(a.v, b.v) && a.primitive == b.primitive &&
           a.geometry == b.geometry;
}

#if defined(ISIN_DETAIL_TRIANGLE_PAIRS) // the helpers of the AVX-512 leaf tests' tests
/// A leaf block of `live` random triangles in front of the origin (z around 3·scale), each
/// coordinate `scale`·U(−1, 1); the rest padding (lane 0 again), indices 7k + 3.
template <class Rng>
isin::detail::TriangleBlock<float> random_block(Rng& rng, float scale, int live) {
    std::uniform_real_distribution<float> uni(-1, 1);
    isin::detail::TriangleBlock<float> b;
    for (int k = 0; k < 8; ++k) {
        for (int v = 0; v < 3; ++v)
            for (int a = 0; a < 3; ++a)
                b.v[v][a][k] = k < live ? scale * (uni(rng) + (a == 2 ? 3.0f : 0.0f)) : b.v[v][a][0];
        b.primitive[k] = k < live ? std::uint32_t(7 * k + 3) : b.primitive[0];
    }
    return b;
}

/// The centroid of the block's triangle k.
isin::Vertex<float> centroid(const isin::detail::TriangleBlock<float>& b, int k) {
    return {(b.v[0][0][k] + b.v[1][0][k] + b.v[2][0][k]) / 3, (b.v[0][1][k] + b.v[1][1][k] + b.v[2][1][k]) / 3,
            (b.v[0][2][k] + b.v[1][2][k] + b.v[2][2][k]) / 3};
}
#endif

/// Counts the rays whose stream results differ from the single-ray calls' (nearest hit, and
/// occlusion up to `limit`), through the array and the structure-of-arrays forms.
template <class T>
int stream_mismatches(const isin::Bvh<T>& bvh, const std::vector<isin::Ray<T>>& rays, const std::vector<T>& limit,
                      const isin::HitFilter& filter = {}) {
    const std::size_t n = rays.size();
    // Stale values in every field: the stream calls must write each one.
    const isin::Hit<T> stale{T(1), T(2), T(3), 4u, 5u};
    std::vector<isin::Hit<T>> hits(n, stale), hits_soa(n, stale), bounded(n, stale);
    std::vector<std::uint8_t> blocked(n, 7), blocked_soa(n, 7);
    bvh.intersect(rays.data(), n, hits.data(), filter);
    bvh.intersect(rays.data(), n, limit.data(), bounded.data(), filter);
    bvh.occluded(rays.data(), n, limit.data(), blocked.data(), filter);
    std::vector<T> c[6];
    for (const auto& r : rays)
        for (int a = 0; a < 3; ++a)
            c[a].push_back(isin::component(r.origin, a)), c[3 + a].push_back(isin::component(r.direction, a));
    const isin::RaysSoA<T> soa{c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data(), c[5].data()};
    bvh.intersect(soa, n, nullptr, hits_soa.data(), filter);
    bvh.occluded(soa, n, limit.data(), blocked_soa.data(), filter);
    int mismatches = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const auto one = bvh.intersect(rays[i], std::numeric_limits<T>::infinity(), filter);
        const auto one_bounded = bvh.intersect(rays[i], limit[i], filter);
        const std::uint8_t shadow = bvh.occluded(rays[i], limit[i], filter) ? 1 : 0;
        const bool ok = same_hit(hits[i], one) && same_hit(hits_soa[i], one) && same_hit(bounded[i], one_bounded) &&
                        blocked[i] == shadow && blocked_soa[i] == shadow;
        mismatches += !ok;
    }
    return mismatches;
}

/// Camera rays from `eye` through a w × h grid, ordered in 4×4 tiles (the packets).
template <class T>
std::vector<isin::Ray<T>> tiled_camera_rays(isin::Vertex<T> eye, T half_width, int w, int h) {
    std::vector<isin::Ray<T>> rays;
    for (int ty = 0; ty < h; ty += 4)
        for (int tx = 0; tx < w; tx += 4)
            for (int y = ty; y < ty + 4 && y < h; ++y)
                for (int x = tx; x < tx + 4 && x < w; ++x) {
                    const T px = (T(x) + T(0.5)) / T(w) * 2 - 1, py = (T(y) + T(0.5)) / T(h) * 2 - 1;
                    rays.push_back({eye, isin::normalize(isin::Vertex<T>{px * half_width, py * half_width, T(1)})});
                }
    return rays;
}

} // namespace

TEST_CASE_TEMPLATE("Bvh stream: coherent camera tiles give the single-ray hits bit for bit", T, float, double) {
    const auto tris = workloads::triangle_soup<T>(5000, 11, 1.5);
    const isin::Bvh<T> bvh{tris};
    for (const T half_width : {T(0.05), T(0.6), T(2)}) { // narrow to wide fields of view
        CAPTURE(half_width);
        const auto rays = tiled_camera_rays<T>({T(0.3), T(-0.2), T(-25)}, half_width, 64, 48);
        std::vector<T> limit(rays.size());
        for (std::size_t i = 0; i < rays.size(); ++i) limit[i] = T(15) + T(i % 23); // some blocked, some not
        std::size_t hit = 0;
        for (const auto& r : rays) hit += bool(bvh.intersect(r));
        CHECK(hit > rays.size() / 20);
        CHECK(stream_mismatches(bvh, rays, limit) == 0);
        isin::HitFilter cull;
        cull.cull_backfaces = true;
        CHECK(stream_mismatches(bvh, rays, limit, cull) == 0);
        std::vector<std::uint8_t> skip(tris.size());
        for (std::size_t i = 0; i < skip.size(); i += 3) skip[i] = 1;
        isin::HitFilter skipping;
        skipping.skip = skip.data();
        CHECK(stream_mismatches(bvh, rays, limit, skipping) == 0);
    }
}

TEST_CASE_TEMPLATE("Bvh stream: random rays, shadow rays from hit points and counts that are not 16s", T, float,
                   double) {
    const auto tris = workloads::triangle_soup<T>(3000, 5, 1.5);
    const isin::Bvh<T> bvh{tris};
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<isin::Ray<T>> rays;
    std::vector<T> limit;
    for (int i = 0; i < 2000; ++i) {
        const isin::Vertex<T> o{T(uni(rng) * 12), T(uni(rng) * 12), T(uni(rng) * 12)};
        rays.push_back({o, isin::Vertex<T>{T(uni(rng)), T(uni(rng)), T(uni(rng))}});
        limit.push_back(T(1 + 20 * (uni(rng) + 1)));
    }
    CHECK(stream_mismatches(bvh, rays, limit) == 0);
    // Shadow rays from the hits of a camera tile towards one light: coherent, origins apart.
    const auto camera = tiled_camera_rays<T>({0, 0, T(-25)}, T(0.5), 32, 32);
    std::vector<isin::Ray<T>> shadows;
    std::vector<T> one;
    const isin::Vertex<T> light{T(5), T(30), T(-10)};
    for (const auto& r : camera) {
        const auto h = bvh.intersect(r);
        const isin::Vertex<T> p = h ? r.at(h.t * T(0.999)) : r.at(T(20));
        shadows.push_back({p, light - p});
        one.push_back(T(1));
    }
    CHECK(stream_mismatches(bvh, shadows, one) == 0);
    for (std::size_t n :
         {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(15), std::size_t(17), std::size_t(33)}) {
        CAPTURE(n);
        const std::vector<isin::Ray<T>> some(camera.begin(), camera.begin() + std::ptrdiff_t(n));
        const std::vector<T> some_limit(one.begin(), one.begin() + std::ptrdiff_t(n));
        CHECK(stream_mismatches(bvh, some, some_limit) == 0);
    }
}

TEST_CASE("Bvh stream: SlabLanes gives prepare_slab's terms, 16 rays at once") {
#if defined(ISIN_DETAIL_PACKETS)
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    const float tiny = std::numeric_limits<float>::min();
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<float> uni(-1, 1);
    int checked = 0, robust = 0, not_ok = 0, wrong = 0;
    for (int round = 0; round < 50; ++round) {
        std::vector<isin::Ray<float>> rays(16);
        for (auto& r : rays) r = {{20 * uni(rng), 20 * uni(rng), 20 * uni(rng)}, {uni(rng), uni(rng), uni(rng)}};
        // some rays of every kind: zero, NaN, infinite, −0.0 and tiny components, a zero direction
        rays[1].direction.x = 0.0f, rays[2].direction.y = -0.0f, rays[3].direction.z = tiny;
        rays[4].direction.x = -tiny, rays[5].origin.y = nan, rays[6].direction.z = inf;
        rays[7].direction = {0.0f, -0.0f, 0.0f}, rays[8].origin.x = 1e30f;
        alignas(64) float c[6][16];
        isin::detail::load_packet_rays(rays.data(), 0, 16, c);
        const float bound = 30.0f;
        const isin::detail::SlabLanes lanes(c, bound);
        for (int k = 0; k < 16; ++k) {
            const auto want = isin::detail::prepare_slab(rays[std::size_t(k)], bound);
            const auto got = lanes.at(k);
            ++checked, robust += want.robust, not_ok += !want.ok;
            bool same = got.ok == want.ok;
            if (want.ok) {
                same = same && got.robust == want.robust;
                for (int a = 0; a < 3; ++a) {
                    same = same && same_bits(got.org[a], want.org[a]) && same_bits(got.inv[a], want.inv[a]) &&
                           same_bits(got.inv_far[a], want.inv_far[a]) && got.near_plane[a] == want.near_plane[a] &&
                           got.far_plane[a] == want.far_plane[a];
                    if (!want.robust) // the allowance added in one rounding or two: within an ulp
                        same = same &&
                               std::fabs(got.org_inv_near[a] - want.org_inv_near[a]) <=
                                   std::fabs(want.org_inv_near[a]) * 1.2e-7f &&
                               std::fabs(got.org_inv_far[a] - want.org_inv_far[a]) <=
                                   std::fabs(want.org_inv_far[a]) * 1.2e-7f;
                }
            }
            wrong += !same;
        }
    }
    CHECK(robust >= 150);
    CHECK(not_ok >= 150);
    CHECK(wrong == 0);
    CHECK(checked == 800);
#endif
}

TEST_CASE_TEMPLATE("Bvh stream: rays that need the robust slab test (tiny direction components) among random rays", T,
                   float, double) {
    // A component of the least normal value: 1/d is 2^(max exponent − 1), so its products with
    // the scene's coordinates overflow and the ray takes the robust slab form, two at a time or
    // alone.
    const auto tris = workloads::triangle_soup<T>(3000, 6, 1.5);
    const isin::Bvh<T> bvh{tris};
    const T tiny = std::numeric_limits<T>::min();
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<isin::Ray<T>> rays;
    std::vector<T> limit;
    int robust = 0, hits = 0;
    for (int i = 0; i < 1600; ++i) {
        const isin::Vertex<T> o{T(uni(rng) * 12), T(uni(rng) * 12), T(uni(rng) * 12)};
        isin::Vertex<T> d{T(uni(rng)), T(uni(rng)), T(uni(rng))};
        if (i % 3 != 0) { // two of three rays: one component tiny (of either sign)
            const T sign = uni(rng) < 0 ? T(-1) : T(1);
            (i % 3 == 1 ? d.x : d.z) = sign * tiny;
        }
        rays.push_back({o, d});
        limit.push_back(T(30));
        robust += isin::detail::prepare_slab(rays.back(), bvh.tree().bound()).robust;
        hits += bool(bvh.intersect(rays.back()));
    }
    CHECK(robust > 1000);
    CHECK(hits > 300);
    CHECK(stream_mismatches(bvh, rays, limit) == 0);
}

TEST_CASE_TEMPLATE("Bvh stream: NaN, infinite, zero, axis-parallel and −0.0 rays inside packets", T, float, double) {
    const auto tris = workloads::triangle_soup<T>(2000, 8, 1.5);
    const isin::Bvh<T> bvh{tris};
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    auto rays = tiled_camera_rays<T>({0, 0, T(-25)}, T(0.4), 32, 16);
    std::vector<T> limit(rays.size(), T(40));
    // Spoil one ray of every other packet, a different way each time.
    const isin::Ray<T> bad[] = {{{nan, 0, 0}, {0, 0, 1}},
                                {{0, 0, T(-25)}, {0, 0, 0}},
                                {{0, 0, T(-25)}, {nan, 0, 1}},
                                {{inf, 0, T(-25)}, {0, 0, 1}},
                                {{0, 0, T(-25)}, {0, 0, 1}},
                                {{0, 0, T(-25)}, {T(-0.0), T(0.0), 1}},
                                {{T(1), T(2), T(-25)}, {0, 1, 0}},
                                {{0, 0, T(-25)}, {0, 0, T(-1)}},
                                {{0, 0, T(-25)}, {T(1e-30), 0, T(1)}},
                                {{T(3), T(1), T(40)}, {T(-0.1), T(0.05), T(-1)}}};
    std::size_t k = 0;
    for (std::size_t i = 5; i < rays.size(); i += 32, ++k) rays[i] = bad[k % std::size(bad)];
    // Bad bounds: 0, negative, NaN, infinite.
    limit[7] = 0, limit[40] = T(-1), limit[73] = nan, limit[100] = inf;
    CHECK(stream_mismatches(bvh, rays, limit) == 0);
    // Every ray of a packet axis-parallel, and every ray pointing the same way.
    std::vector<isin::Ray<T>> parallel;
    for (int i = 0; i < 64; ++i)
        parallel.push_back({{T(-5 + (i % 8) * 1.3), T(-5 + (i / 8) * 1.3), T(-25)}, {T(-0.0), 0, T(1)}});
    CHECK(stream_mismatches(bvh, parallel, std::vector<T>(parallel.size(), inf)) == 0);
}

TEST_CASE_TEMPLATE("Bvh stream: a closed mesh hit at its shared edges and vertices as by single rays (no leak)", T,
                   float, double) {
    for (const auto& m : {workloads::closed_sphere_edges<T>(3000), workloads::grid_edges<T>(3000)}) {
        const isin::Bvh<T> bvh{m.mesh};
        std::vector<isin::Hit<T>> hits(m.rays.size());
        bvh.intersect(m.rays.data(), m.rays.size(), hits.data());
        int leaks = 0, mismatches = 0;
        for (std::size_t i = 0; i < m.rays.size(); ++i) {
            leaks += !hits[i] ||
                     std::fabs(double(hits[i].t) - workloads::mesh_ray_distance) > 1e-3 * workloads::mesh_ray_distance;
            mismatches += !same_hit(hits[i], bvh.intersect(m.rays[i]));
        }
        CHECK(leaks == 0);
        CHECK(mismatches == 0);
    }
}

TEST_CASE("Bvh stream: packets of rays grazing a triangle's corner, within rounding of its box, as single rays") {
    // Sixteen rays from one point towards a triangle's vertex, each moved off it by a few ulps:
    // the watertight test hits some of them although the exact ray passes just outside the
    // triangle (and its box), in a leaf whose box a second, farther triangle widens. A packet
    // tests only the triangles whose boxes its rays come near (the margin of make_packet must
    // cover this rounding): it must find the same hits.
    // Half the trials far from the world's origin, where o·inv rounds by far more than the rays'
    // distances do: with make_packet's margin set to 0, 8 rays of those trials got other hits
    // than alone, none of the trials near the origin.
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<float> uni(-1, 1);
    int outside = 0, mismatches = 0;
    for (int trial = 0; trial < 800; ++trial) {
        const isin::Vertex<float> shift = trial < 400 ? isin::Vertex<float>{} : isin::Vertex<float>{1000, -700, 500};
        const isin::Vertex<float> o = shift + isin::Vertex<float>{uni(rng), uni(rng), uni(rng)};
        const isin::Vertex<float> v = shift + isin::Vertex<float>{8 * uni(rng), 8 * uni(rng), 20 + 5 * uni(rng)};
        // v is the box's corner of greatest x, y and z
        const auto back_off = [&] {
            return v - isin::Vertex<float>{3 * std::fabs(uni(rng)), 3 * std::fabs(uni(rng)), std::fabs(uni(rng))};
        };
        const isin::Vertex<float> a = back_off(), b = back_off();
        const isin::Vertex<float> back = shift + isin::Vertex<float>{0, 0, 40};
        const std::vector<isin::Triangle<float>> tris{{v, a, b},
                                                      {back + isin::Vertex<float>{-60, -60, 0},
                                                       back + isin::Vertex<float>{60, -60, 0},
                                                       back + isin::Vertex<float>{0, 60, 0}}};
        const isin::Bvh<float> bvh{tris};
        std::vector<isin::Ray<float>> rays;
        for (int k = 0; k < 16; ++k) {
            isin::Vertex<float> target = v;
            for (int c = 0; c < 3; ++c) {
                float& x = c == 0 ? target.x : c == 1 ? target.y : target.z;
                for (int step = int(rng() % 6) - 1; step > 0; --step) x = std::nextafter(x, 1e30f);
            }
            rays.push_back({o, target - o});
        }
        const std::vector<float> limit(rays.size(), 1e4f);
        mismatches += stream_mismatches(bvh, rays, limit);
        for (const auto& r : rays) { // hits of the first triangle the exact test misses
            const isin::Ray<double> exact{workloads::to_double(r.origin), workloads::to_double(r.direction)};
            const isin::Triangle<double> t0{workloads::to_double(v), workloads::to_double(a), workloads::to_double(b)};
            const auto h = bvh.intersect(r);
            outside += h && h.primitive == 0 && !isin::intersect_watertight(exact, t0);
        }
    }
    MESSAGE(outside, " hits on rays the exact test says miss the triangle");
    CHECK(mismatches == 0);
    CHECK(outside > 20); // not vacuous: rays within rounding of the triangle
}

TEST_CASE_TEMPLATE("Bvh: of triangles hit at the same t the lowest index wins, single rays and packets alike", T, float,
                   double) {
    // 40 copies of one quad's triangles spread over the array: every hit is a tie.
    std::vector<isin::Triangle<T>> tris;
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    const isin::Triangle<T> a{{-4, -4, 0}, {-4, 4, 0}, {4, -4, 0}}, b{{4, 4, 0}, {4, -4, 0}, {-4, 4, 0}};
    std::vector<std::uint32_t> first_a, first_b;
    for (int i = 0; i < 200; ++i) {
        const int pick = int((uni(rng) + 1) * 3);
        if (pick == 0) {
            tris.push_back(a);
        } else if (pick == 1) {
            tris.push_back(b);
        } else {
            const isin::Vertex<T> c{T(uni(rng) * 20), T(uni(rng) * 20), T(5 + uni(rng))};
            tris.push_back({c, c + isin::Vertex<T>{0, 1, 0}, c + isin::Vertex<T>{1, 0, 0}});
        }
    }
    std::uint32_t lowest_a = 0, lowest_b = 0;
    const auto same = [](const isin::Triangle<T>& x, const isin::Triangle<T>& y) {
        return x.v0 == y.v0 && x.v1 == y.v1 && x.v2 == y.v2;
    };
    while (!same(tris[lowest_a], a)) ++lowest_a;
    while (!same(tris[lowest_b], b)) ++lowest_b;
    const isin::Bvh<T> bvh{tris};
    const auto rays = tiled_camera_rays<T>({T(0.1), T(0.2), T(-10)}, T(0.3), 16, 16);
    std::vector<isin::Hit<T>> hits(rays.size());
    bvh.intersect(rays.data(), rays.size(), hits.data());
    int wrong = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto one = bvh.intersect(rays[i]);
        REQUIRE(one);
        wrong += !same_hit(one, hits[i]);
        wrong += one.primitive != lowest_a && one.primitive != lowest_b;
    }
    CHECK(wrong == 0);
}

TEST_CASE("Bvh stream: camera tiles form full packets where packets are compiled, random rays none") {
    const std::string path = isin::bvh_code_paths.packets;
    MESSAGE("stream calls: ", path);
#if defined(ISIN_DETAIL_PACKETS)
    CHECK(path == "16 rays, avx2+fma");
    const auto load = [](const isin::Ray<float>* rays, float(&c)[6][16]) {
        for (int k = 0; k < 16; ++k)
            for (int a = 0; a < 3; ++a)
                c[a][k] = isin::component(rays[k].origin, a), c[3 + a][k] = isin::component(rays[k].direction, a);
    };
    alignas(32) float c[6][16];
    float t_max[16];
    for (float& t : t_max) t = std::numeric_limits<float>::infinity();
    const auto tiles = tiled_camera_rays<float>({0, 0, -25}, 0.6f, 64, 48);
    int full = 0;
    for (std::size_t i = 0; i < tiles.size(); i += 16) {
        load(tiles.data() + i, c);
        isin::detail::RayPacket p;
        full += isin::detail::make_packet(p, c, 16, t_max, 100.0f, 1.0f) == 0xffffu;
    }
    CHECK(full == int(tiles.size() / 16));
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<float> uni(-1, 1);
    std::vector<isin::Ray<float>> random(16);
    int formed = 0;
    for (int i = 0; i < 100; ++i) {
        for (auto& r : random) r = {{uni(rng), uni(rng), uni(rng)}, {uni(rng), uni(rng), uni(rng)}};
        load(random.data(), c);
        isin::detail::RayPacket p;
        formed += isin::detail::make_packet(p, c, 16, t_max, 100.0f, 1.0f) != 0;
    }
    CHECK(formed == 0);
#else
    CHECK(path == "single rays");
#endif
}

TEST_CASE("Bvh stream: rays whose origins lie many leaf sizes apart form no packet, with the same results") {
    // Parallel rays towards +z from a row of points 4 apart (60.5 in all), through a grid of
    // small triangles: the even rays hit one, the odd ones pass beside it.
    std::vector<isin::Triangle<float>> tris;
    for (int i = 0; i < 70; ++i)
        for (int j = 0; j < 4; ++j) {
            const float x = float(i - 24), y = float(j - 2);
            tris.push_back({{x, y, 10.0f}, {x, y + 0.5f, 10.0f}, {x + 0.5f, y, 10.0f}});
        }
    const isin::Bvh<float> bvh(tris);
    const float leaf_scale = bvh.tree().leaf_scale();
    REQUIRE(leaf_scale > 0.0f);
    std::vector<isin::Ray<float>> rays;
    for (int k = 0; k < 16; ++k)
        rays.push_back({{4.0f * float(k) - 22.0f + (k % 2 ? 0.5f : 0.0f), 0.0f, 0.0f}, {0.01f, 0.02f, 1.0f}});
#if defined(ISIN_DETAIL_PACKETS)
    alignas(32) float c[6][16];
    float t_max[16];
    for (int k = 0; k < 16; ++k) {
        t_max[k] = 20.0f;
        for (int a = 0; a < 3; ++a)
            c[a][k] = isin::component(rays[std::size_t(k)].origin, a),
            c[3 + a][k] = isin::component(rays[std::size_t(k)].direction, a);
    }
    isin::detail::RayPacket p;
    // 60.5 apart along x: a packet for leaves of 60.5 / 8 and more, none below
    const float spread = 60.5f / isin::detail::packet_origin_spread;
    CHECK(isin::detail::make_packet(p, c, 16, t_max, 100.0f, spread) == 0xffffu);
    CHECK_FALSE(p.wide);
    CHECK(isin::detail::make_packet(p, c, 16, t_max, 100.0f, spread * 0.99f) == 0u);
    CHECK(p.wide);
    REQUIRE(leaf_scale < spread); // this grid's leaves: the stream below traces the rays alone
    CHECK(isin::detail::make_packet(p, c, 16, t_max, 100.0f, leaf_scale) == 0u);
    CHECK(p.wide);
    // Rays of other directions are not wide: they are not coherent at all.
    for (int k = 0; k < 16; ++k)
        c[3][k] = std::cos(0.7f * float(k)), c[4][k] = std::sin(0.7f * float(k)), c[5][k] = 0.2f;
    CHECK(isin::detail::make_packet(p, c, 16, t_max, 100.0f, spread) == 0u);
    CHECK_FALSE(p.wide);
#endif
    std::vector<float> t_far(rays.size(), 20.0f);
    std::vector<std::uint8_t> blocked(rays.size());
    std::vector<isin::Hit<float>> hits(rays.size());
    bvh.occluded(rays.data(), rays.size(), t_far.data(), blocked.data());
    bvh.intersect(rays.data(), rays.size(), hits.data());
    int wrong = 0, hit = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto one = bvh.intersect(rays[i]);
        hit += bool(one);
        wrong += !same_hit(one, hits[i]) + (blocked[i] != (bvh.occluded(rays[i], 20.0f) ? 1 : 0));
    }
    CHECK(hit == 8);
    CHECK(wrong == 0);
}

TEST_CASE("Bvh packets: two packets walked as one offer each ray every leaf its own walk enters") {
#if defined(ISIN_DETAIL_PACKETS)
    // Pairs of adjacent 4×4 tiles of camera rays, from one eye and (shadow rays' case) from
    // origins scattered about it, walked together under their joint interval test
    // (walk_packets, as the stream calls do): every leaf a ray's own walk enters (no hit lowers
    // t_far here, so that is every leaf along the ray) must be offered to that ray. And each
    // leaf offered to two rays or more must have been named to the walk's cache hint (`soon`)
    // before, by its index (a subtree one ray enters alone is walked by the single-ray walk,
    // which gives no hints).
    const auto tris = workloads::triangle_soup<float>(4000, 9, 1.5);
    const isin::Bvh<float> bvh{tris};
    const auto& tree = bvh.tree();
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<float> jitter(-0.05f, 0.05f);
    for (const bool scattered : {false, true}) {
        CAPTURE(scattered);
        auto rays = tiled_camera_rays<float>({0.3f, -0.2f, -25}, 0.6f, 64, 48);
        if (scattered)
            for (auto& r : rays) r.origin = r.origin + isin::Vertex<float>{jitter(rng), jitter(rng), jitter(rng)};
        float t_max[16];
        for (float& t : t_max) t = std::numeric_limits<float>::infinity();
        int pairs = 0, entered = 0, missed = 0, unhinted = 0, hints = 0, bad_hints = 0;
        for (std::size_t first = 0; first + 32 <= rays.size(); first += 32) {
            alignas(64) float c[2][6][16];
            isin::detail::RayPacket p[2];
            bool made = true;
            for (std::size_t j = 0; j < 2; ++j) {
                for (std::size_t k = 0; k < 16; ++k)
                    for (int a = 0; a < 3; ++a)
                        c[j][a][k] = isin::component(rays[first + 16 * j + k].origin, a),
                        c[j][3 + a][k] = isin::component(rays[first + 16 * j + k].direction, a);
                made = made &&
                       isin::detail::make_packet(p[j], c[j], 16, t_max, tree.bound(), tree.leaf_scale()) == 0xffffu;
            }
            if (!made) continue;
            bool negative[3];
            for (int a = 0; a < 3; ++a) negative[a] = !isin::detail::packet_positive(p[0], a);
            if (negative[0] != !isin::detail::packet_positive(p[1], 0) ||
                negative[1] != !isin::detail::packet_positive(p[1], 1) ||
                negative[2] != !isin::detail::packet_positive(p[1], 2))
                continue; // other octants: the stream calls walk them one by one
            float lo[6], hi[6];
            for (int v = 0; v < 6; ++v)
                lo[v] = std::min(p[0].lo[v], p[1].lo[v]), hi[v] = std::max(p[0].hi[v], p[1].hi[v]);
            isin::detail::PacketBounds box;
            isin::detail::set_packet_bounds(box, lo, hi, negative, tree.bound());
            CHECK(box.one_origin == !scattered);
            std::vector<std::set<std::uint32_t>> offered(32);
            isin::detail::RayPacket* const both[2] = {&p[0], &p[1]};
            std::set<std::uint32_t> hinted;
            isin::detail::walk_packets<isin::Visit::nearest>(
                tree, both, box,
                [&](std::uint32_t leaf, unsigned active) {
                    unhinted += isin::detail::bit_count(active) > 1 && !hinted.count(leaf);
                    for (; active; active &= active - 1)
                        offered[std::size_t(isin::detail::lowest_bit(active))].insert(leaf);
                    return 0u;
                },
                [&](std::uint32_t leaf) {
                    ++hints;
                    bad_hints += leaf >= tree.leaf_count();
                    hinted.insert(leaf);
                });
            ++pairs;
            for (std::size_t k = 0; k < 32; ++k) {
                float t = std::numeric_limits<float>::infinity();
                isin::traverse<isin::Visit::nearest>(tree, rays[first + k], t, [&](std::uint32_t leaf, float&) {
                    ++entered;
                    missed += !offered[k].count(leaf);
                    return false;
                });
            }
        }
        CHECK(pairs > 40);
        CHECK(entered > 1000);
        CHECK(missed == 0);
        CHECK(hints > 1000);
        CHECK(bad_hints == 0);
        CHECK(unhinted == 0);
    }
#endif
}

TEST_CASE("Bvh packets: two rays' block test in one register gives each ray's own test bit for bit") {
#if defined(ISIN_DETAIL_TRIANGLE_PAIRS)
    using Block = isin::detail::TriangleBlock<float>;
    using Ray = isin::detail::TriangleRay<float>;
    using Hits = isin::detail::LaneHits<float>;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<float> uni(-1, 1);
    // Scales: ordinary, and products below 2^-126 or beyond 2^126 (blocks test_block_avx2 does
    // not trust, tested one by one).
    const float scales[] = {1.0f, 1.0f, 1.0f, 1e-22f, 1e21f};
    int compared = 0, hit_lanes = 0, differing_axes = 0;
    for (int i = 0; i < 4000; ++i) {
        const float s = scales[i % 5];
        const Block b = random_block(rng, s, 8);
        // Ray a towards a lane's centroid; ray b near it (a packet's neighbour) or anywhere.
        const int aim = int(rng() % 8);
        const isin::Vertex<float> c = centroid(b, aim);
        const isin::Vertex<float> o{s * 0.1f * uni(rng), s * 0.1f * uni(rng), s * 0.1f * uni(rng)};
        const isin::Vertex<float> jitter{0.02f * uni(rng), 0.02f * uni(rng), 0.02f * uni(rng)};
        const isin::Vertex<float> d = c - o, d2 = i % 7 == 0 ? isin::Vertex<float>{uni(rng), uni(rng), uni(rng)}
                                                             : d + jitter * (s * 3.0f);
        Ray ra({o, d}), rb({o + jitter * s, d2});
        if (!ra.ready() || !rb.ready()) continue;
        differing_axes += ra.shear.kz != rb.shear.kz || ra.shear.kx != rb.shear.kx;
        const float inf = std::numeric_limits<float>::infinity();
        const float t_a = i % 3 ? inf : 0.9f, t_b = i % 4 ? inf : 0.95f;
        const auto check = [&](auto cull) {
            constexpr bool culls = decltype(cull)::value;
            Hits pa, pb, sa, sb;
            const unsigned pair = isin::detail::test_block_pair<culls, true>(b, ra, rb, t_a, t_b, pa, pb);
            const unsigned one =
                isin::detail::test_block<culls>(b, ra, t_a, sa) | isin::detail::test_block<culls>(b, rb, t_b, sb) << 8;
            Hits unused_a, unused_b;
            CHECK(isin::detail::test_block_pair<culls, false>(b, ra, rb, t_a, t_b, unused_a, unused_b) == one);
            CHECK(pair == one);
            for (int k = 0; k < 16; ++k) {
                if (!((one >> k) & 1u)) continue;
                const Hits &p = k < 8 ? pa : pb, &q = k < 8 ? sa : sb;
                const int l = k % 8;
                CHECK((same_bits(p.t[l], q.t[l]) && same_bits(p.u[l], q.u[l]) && same_bits(p.v[l], q.v[l])));
                ++hit_lanes;
            }
            ++compared;
        };
        check(std::false_type{});
        check(std::true_type{});
    }
    MESSAGE(compared, " pairs compared, ", hit_lanes, " lanes hit, ", differing_axes, " pairs with different shears");
    CHECK(hit_lanes > 1000); // the comparison is not vacuous: many lanes hit
    CHECK(differing_axes > 50);
#else
    MESSAGE("two rays in one register need AVX-512 F+DQ: not compiled here");
#endif
}

TEST_CASE("Bvh packets: a block's test with the rays in lanes gives each ray's own test bit for bit") {
#if defined(ISIN_DETAIL_TRIANGLE_PAIRS)
    using Block = isin::detail::TriangleBlock<float>;
    using Ray = isin::detail::TriangleRay<float>;
    using Hits = isin::detail::LaneHits<float>;
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<float> uni(-1, 1);
    // Ordinary scales, and products below 2^-126 or beyond 2^126 (triangles test_block_avx2 does
    // not trust for a ray: it then tests them exactly, and test_block_rays leaves those rays out).
    const float scales[] = {1.0f, 1.0f, 1.0f, 1e-22f, 1e21f};
    const float inf = std::numeric_limits<float>::infinity();
    int compared = 0, hit_rays = 0, untrusted_rays = 0, skipped = 0;
    for (int i = 0; i < 2000; ++i) {
        const float s = scales[i % 5];
        const int live = 1 + int(rng() % 8); // the rest is padding: lane 0 again
        Block b = random_block(rng, s, live);
        // Two triangles at the same place (ties in t: the lower index wins), now and then.
        if (live > 2 && i % 6 == 0)
            for (int v = 0; v < 3; ++v)
                for (int a = 0; a < 3; ++a) b.v[v][a][2] = b.v[v][a][1];
        // The triangles tested: all, or some (those a packet's rays may reach).
        const unsigned all = (1u << live) - 1u;
        const unsigned triangles = i % 3 == 0 ? all & unsigned(rng()) : all;
        std::uint8_t skip[64] = {};
        const bool skipping = i % 4 == 1;
        if (skipping)
            for (auto& m : skip) m = rng() % 3 == 0;
        // 16 rays towards a lane's centroid from one origin or spread ones, one of them from a
        // vertex (edge functions of zero: not trusted); their shears may permute the axes apart.
        const int aim = int(rng() % std::uint64_t(live));
        const isin::Vertex<float> c = centroid(b, aim);
        const isin::Vertex<float> o{s * 0.1f * uni(rng), s * 0.1f * uni(rng), s * 0.1f * uni(rng)};
        std::vector<Ray> rays;
        float t_max[16];
        for (int j = 0; j < 16; ++j) {
            const isin::Vertex<float> jitter{0.3f * uni(rng), 0.3f * uni(rng), 0.3f * uni(rng)};
            const isin::Vertex<float> corner{b.v[0][0][aim], b.v[0][1][aim], b.v[0][2][aim]};
            const isin::Vertex<float> origin = j == 5 ? corner : i % 2 ? o : o + jitter * (0.1f * s);
            const isin::Vertex<float> target = c + jitter * s;
            rays.emplace_back(isin::Ray<float>{origin, target - origin});
            t_max[j] = j % 3 ? inf : 0.9f + 0.1f * uni(rng);
        }
        // The group of ray 0's axes, as rays_in_lanes makes it.
        isin::detail::ShearedRays r;
        r.kx = rays[0].shear.kx, r.ky = rays[0].shear.ky, r.kz = rays[0].shear.kz;
        alignas(64) float lane[7][16];
        unsigned group = 0;
        for (int j = 0; j < 16; ++j) {
            Ray& q = rays[std::size_t(j)];
            if (q.ready() && q.shear.kx == r.kx && q.shear.ky == r.ky && q.shear.kz == r.kz) group |= 1u << j;
            lane[0][j] = q.org[r.kx], lane[1][j] = q.org[r.ky], lane[2][j] = q.org[r.kz];
            lane[3][j] = q.shear.Sx, lane[4][j] = q.shear.Sy, lane[5][j] = q.shear.Sz, lane[6][j] = t_max[j];
        }
        r.ox = _mm512_load_ps(lane[0]), r.oy = _mm512_load_ps(lane[1]), r.oz = _mm512_load_ps(lane[2]);
        r.Sx = _mm512_load_ps(lane[3]), r.Sy = _mm512_load_ps(lane[4]), r.Sz = _mm512_load_ps(lane[5]);
        r.t_max = _mm512_load_ps(lane[6]);
        const auto check = [&](auto cull) {
            constexpr bool culls = decltype(cull)::value;
            isin::detail::BlockHitLanes nearest, unused;
            unsigned untrusted = 0, untrusted_any = 0;
            const unsigned hit = isin::detail::test_block_rays<culls, true>(
                b, r, group, triangles, skipping ? skip : nullptr, nearest, untrusted);
            const unsigned any = isin::detail::test_block_rays<culls, false>(
                b, r, group, triangles, skipping ? skip : nullptr, unused, untrusted_any);
            CHECK(any == hit);
            CHECK(untrusted_any == untrusted);
            CHECK((hit & ~group) == 0);
            CHECK((untrusted & ~group) == 0);
            alignas(64) float t[16], u[16], v[16];
            alignas(64) std::uint32_t index[16];
            _mm512_store_ps(t, nearest.t), _mm512_store_ps(u, nearest.u), _mm512_store_ps(v, nearest.v);
            _mm512_store_si512(index, nearest.primitive);
            for (int j = 0; j < 16; ++j) {
                if (!((group >> j) & 1u)) continue;
                if ((untrusted >> j) & 1u) {
                    ++untrusted_rays;
                    continue;
                }
                Hits own;
                unsigned lanes = isin::detail::test_block<culls>(b, rays[std::size_t(j)], t_max[j], own) & triangles;
                for (int k = 0; k < 8; ++k)
                    if (skipping && skip[b.primitive[k]] && ((lanes >> k) & 1u)) lanes &= ~(1u << k), ++skipped;
                CHECK(((hit >> j) & 1u) == (lanes != 0));
                if (!lanes || !((hit >> j) & 1u)) continue;
                const int k = isin::detail::nearest_lane(lanes, own, b);
                CHECK((same_bits(t[j], own.t[k]) && same_bits(u[j], own.u[k]) && same_bits(v[j], own.v[k]) &&
                       index[j] == b.primitive[k]));
                ++hit_rays;
            }
            ++compared;
        };
        check(std::false_type{});
        check(std::true_type{});
    }
    MESSAGE(compared, " blocks compared, ", hit_rays, " rays hit, ", untrusted_rays, " rays not trusted, ", skipped,
            " hits skipped");
    CHECK(hit_rays > 5000); // not vacuous: many rays hit, some are not trusted, some hits skipped
    CHECK(untrusted_rays > 100);
    CHECK(skipped > 100);
#else
    MESSAGE("rays in lanes need AVX-512 F+DQ: not compiled here");
#endif
}

TEST_CASE("Bvh packets: the shears of 16 rays at once are each ray's own, bit for bit") {
#if defined(ISIN_DETAIL_PACKETS)
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<float> uni(-1, 1);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // Random directions, then ties between the largest components (set() picks by strict
    // comparisons), signed zeros, NaN and zero directions.
    const float special[][3] = {{1, 1, 1},           {-1, 1, 1},   {1, -1, -1},    {0.5f, 0.5f, 0.1f},
                                {-0.5f, 0.5f, 0.1f}, {0.1f, 1, 1}, {0.1f, -1, 1},  {1, 0.1f, -1},
                                {0, 0, 1},           {0, 0, -1},   {-0.0f, 0, 1},  {0, -0.0f, -0.0f},
                                {0, 0, 0},           {nan, 1, 0},  {1, 0.5f, nan}, {1e-30f, -1e-30f, 1e-30f}};
    int compared = 0, unusable = 0;
    alignas(64) float d[3][16];
    for (int i = 0; i < 400; ++i) {
        for (int k = 0; k < 16; ++k)
            for (int a = 0; a < 3; ++a) d[a][k] = i == 0 ? special[k][a] : uni(rng) * (i % 3 == 0 ? 1e-20f : 1.0f);
        isin::detail::ShearLanes lanes;
        isin::detail::set_shears(d[0], d[1], d[2], lanes);
        for (int k = 0; k < 16; ++k) {
            isin::detail::WatertightShear<float> one;
            const bool ok = one.set({d[0][k], d[1][k], d[2][k]});
            CHECK(((lanes.usable >> k) & 1u) == unsigned(ok));
            if (!ok) {
                ++unusable;
                continue;
            }
            const isin::detail::WatertightShear<float> s = lanes.at(k);
            CHECK((s.kx == one.kx && s.ky == one.ky && s.kz == one.kz));
            CHECK((same_bits(s.Sx, one.Sx) && same_bits(s.Sy, one.Sy) && same_bits(s.Sz, one.Sz)));
            ++compared;
        }
    }
    CHECK(unusable == 2); // the two zero directions (NaN along kz passes set(), as d[kz] != 0)
    CHECK(compared == 400 * 16 - 2);
#else
    MESSAGE("packets are not compiled here");
#endif
}

TEST_CASE("Bvh packets: rays loaded lane by lane from arrays and from six arrays") {
#if defined(ISIN_DETAIL_PACKETS)
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<float> uni(-100, 100);
    std::vector<isin::Ray<float>> rays(37);
    for (auto& r : rays) r = {{uni(rng), uni(rng), uni(rng)}, {uni(rng), uni(rng), uni(rng)}};
    std::vector<float> c6[6];
    for (const auto& r : rays)
        for (int a = 0; a < 3; ++a)
            c6[a].push_back(isin::component(r.origin, a)), c6[3 + a].push_back(isin::component(r.direction, a));
    const isin::RaysSoA<float> soa{c6[0].data(), c6[1].data(), c6[2].data(), c6[3].data(), c6[4].data(), c6[5].data()};
    int wrong = 0;
    for (std::size_t first : {std::size_t(0), std::size_t(3), std::size_t(21)}) {
        for (int n : {16, 5, 1}) {
            alignas(64) float from_array[6][16], from_soa[6][16];
            isin::detail::load_packet_rays(rays.data(), first, n, from_array);
            isin::detail::load_packet_rays(soa, first, n, from_soa);
            for (int k = 0; k < 16; ++k) {
                const isin::Ray<float>& r = rays[first + std::size_t(k < n ? k : 0)];
                const float want[6] = {r.origin.x, r.origin.y, r.origin.z, r.direction.x, r.direction.y, r.direction.z};
                for (int a = 0; a < 6; ++a)
                    wrong += !same_bits(from_array[a][k], want[a]) + !same_bits(from_soa[a][k], want[a]);
            }
        }
    }
    CHECK(wrong == 0);
#else
    MESSAGE("packets are not compiled here");
#endif
}
