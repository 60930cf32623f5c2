// Build scratch memory: a build given no BuildContext leaves nothing mapped once its Bvh is gone;
// one given a context gives its blocks back to it, the next build takes them again, and the
// context frees them. Kept blocks by exact size, up to a limit.
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include <cstddef>
#include <cstdint>
#include <thread>
#include <vector>

namespace {

// A grid of 2·k·k triangles over [0, 1]² (z = a gentle bump): k = 160 gives the build blocks of
// 2 MiB and more (its primitives alone: 51,200 of 64 bytes or more).
template <class T>
isin::Mesh<T> grid(int k) {
    isin::Mesh<T> m;
    for (int j = 0; j <= k; ++j)
        for (int i = 0; i <= k; ++i) {
            const T x = T(i) / T(k), y = T(j) / T(k);
            m.positions.push_back({x, y, T(0.1) * x * (T(1) - x) + T(0.05) * y});
        }
    const auto at = [k](int i, int j) { return std::uint32_t(j * (k + 1) + i); };
    for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
            m.indices.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            m.indices.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return m;
}

// Hits of a few hundred rays straight down onto the grid, as (triangle, t) pairs.
template <class T>
std::vector<std::pair<std::uint32_t, T>> hits_of(const isin::Bvh<T>& bvh) {
    std::vector<std::pair<std::uint32_t, T>> out;
    for (int j = 0; j < 20; ++j)
        for (int i = 0; i < 20; ++i) {
            const isin::Ray<T> ray{{(T(i) + T(0.37)) / T(20), (T(j) + T(0.61)) / T(20), T(1)}, {T(0), T(0), T(-1)}};
            const auto h = bvh.intersect(ray);
            out.emplace_back(h ? h.primitive : ~0u, h ? h.t : T(-1));
        }
    return out;
}

std::size_t mapped_now() { return isin::detail::mapped_blocks().bytes.load(); }
std::size_t maps_so_far() { return isin::detail::mapped_blocks().maps.load(); }

} // namespace

TEST_CASE_TEMPLATE("BuildContext: a build without one keeps nothing once its Bvh is gone", T, float, double) {
    const auto mesh = grid<T>(160);
    const std::size_t before = mapped_now(), maps = maps_so_far();
    {
        const isin::Bvh<T> bvh(mesh);
        CHECK(hits_of(bvh).size() == 400);
    }
    if (isin::detail::maps_huge_pages) CHECK(maps_so_far() > maps); // the build had blocks of its own
    CHECK(mapped_now() == before);
}

TEST_CASE_TEMPLATE("BuildContext: a rebuild takes the blocks the build before gave back; freed with the context", T,
                   float, double) {
    const auto mesh = grid<T>(160);
    const isin::Bvh<T> plain(mesh);
    const auto expected = hits_of(plain);
    const std::size_t before = mapped_now();
    {
        isin::BuildContext context;
        isin::BvhOptions options;
        options.context = &context;
        CHECK(context.kept_bytes() == 0);
        std::size_t maps = maps_so_far();
        std::size_t first_maps = 0, kept = 0;
        {
            const isin::Bvh<T> bvh(mesh, options);
            first_maps = maps_so_far() - maps;
            kept = context.kept_bytes();
            CHECK(hits_of(bvh) == expected);
        }
        if (isin::detail::maps_huge_pages) {
            CHECK(kept >= isin::detail::huge_page_bytes);
            CHECK(mapped_now() == before + kept); // the scratch, held by the context; the Bvh's own blocks freed
        }
        for (int round = 0; round < 3; ++round) {
            maps = maps_so_far();
            const isin::Bvh<T> bvh(mesh, options);
            CHECK(hits_of(bvh) == expected);
            CHECK(context.kept_bytes() == kept); // the same blocks, back again
            if (isin::detail::maps_huge_pages) CHECK(maps_so_far() - maps < first_maps);
        }
        context.release();
        CHECK(context.kept_bytes() == 0);
        CHECK(mapped_now() == before);
        const isin::Bvh<T> again(mesh, options); // still usable after release()
        CHECK(hits_of(again) == expected);
    }
    CHECK(mapped_now() == before); // freed with the context
}

TEST_CASE_TEMPLATE("BuildContext: builds on two threads at once share one context", T, float, double) {
    const auto mesh = grid<T>(160);
    const auto expected = hits_of(isin::Bvh<T>(mesh));
    const std::size_t before = mapped_now();
    {
        isin::BuildContext context;
        isin::BvhOptions options;
        options.context = &context;
        options.threads = 2;
        bool same[2] = {false, false};
        std::vector<std::thread> threads;
        for (int k = 0; k < 2; ++k)
            threads.emplace_back([&, k] {
                bool all = true;
                for (int round = 0; round < 3; ++round) all = all && hits_of(isin::Bvh<T>(mesh, options)) == expected;
                same[k] = all;
            });
        for (auto& t : threads) t.join();
        CHECK(same[0]);
        CHECK(same[1]);
        if (isin::detail::maps_huge_pages) CHECK(context.kept_bytes() > 0);
    }
    CHECK(mapped_now() == before);
}

TEST_CASE_TEMPLATE("BuildContext: a scene's add_mesh and commit take it; the scene traces as without", T, float,
                   double) {
    const auto mesh = grid<T>(160);
    isin::StandardScene<T> plain, held;
    isin::BuildContext context;
    isin::BvhOptions options;
    options.context = &context;
    const auto m0 = plain.add_material({}), m1 = held.add_material({});
    (void)plain.add_mesh(mesh, m0);
    (void)held.add_mesh(mesh, m1, options);
    if (isin::detail::maps_huge_pages) CHECK(context.kept_bytes() > 0);
    plain.commit();
    held.commit(options);
    for (int i = 0; i < 50; ++i) {
        const isin::Ray<T> ray{{T(i) / T(50) + T(0.003), T(0.4), T(1)}, {T(0), T(0.1), T(-1)}};
        const auto a = plain.intersect(ray), b = held.intersect(ray);
        CHECK(bool(a) == bool(b));
        if (a && b) CHECK(a.t == b.t);
    }
}

TEST_CASE("KeptBlocks: freed blocks kept for the next block of their size, up to a limit") {
    const std::size_t mib = std::size_t(1) << 20;
    alignas(64) static unsigned char tokens[80]; // stand-ins for blocks: only their addresses count
    const std::size_t limit = 128 * mib;
    isin::detail::KeptBlocks kept(limit);
    CHECK(kept.take(2 * mib) == nullptr);
    REQUIRE(kept.keep(tokens + 0, 2 * mib));
    REQUIRE(kept.keep(tokens + 1, 4 * mib));
    REQUIRE(kept.keep(tokens + 2, 2 * mib));
    CHECK(kept.bytes() == 8 * mib);
    CHECK(kept.take(6 * mib) == nullptr);    // exact sizes only: never a larger block
    CHECK(kept.take(2 * mib) == tokens + 2); // the last kept first (its pages the most recent)
    CHECK(kept.take(2 * mib) == tokens + 0);
    CHECK(kept.take(2 * mib) == nullptr);
    CHECK(kept.take(4 * mib) == tokens + 1);
    CHECK(kept.bytes() == 0);
    // The limit: blocks up to it are kept, the next is left to its owner to unmap.
    std::size_t total = 0;
    int n = 0;
    while (total + 2 * mib <= limit) {
        REQUIRE(kept.keep(tokens + n++, 2 * mib));
        total += 2 * mib;
    }
    CHECK_FALSE(kept.keep(tokens + 70, 2 * mib));
    CHECK_FALSE(kept.keep(tokens + 71, limit + 2 * mib));
    for (int k = 0; k < n; ++k) CHECK(kept.take(2 * mib) != nullptr);
    CHECK(kept.take(2 * mib) == nullptr); // empty: its destructor unmaps nothing
    // Through the allocator: a block freed and one of its size asked for again, written whole.
    isin::detail::KeptBlocks blocks(limit);
    isin::detail::UninitAllocator<unsigned char> alloc(&blocks);
    for (int round = 0; round < 3; ++round) {
        unsigned char* const p = alloc.allocate(6 * mib - 5);
        p[0] = 1, p[6 * mib - 6] = 2;
        CHECK(p[0] + p[6 * mib - 6] == 3);
        alloc.deallocate(p, 6 * mib - 5);
        if (isin::detail::maps_huge_pages) CHECK(blocks.bytes() == 6 * mib);
    }
}
