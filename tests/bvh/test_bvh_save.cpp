// Saving a Bvh and loading it back (bvh/serialize.hpp, docs/bvh_format.md): a loaded Bvh holds the
// saved one's arrays bit for bit and answers every ray as it did; every damaged, truncated,
// hostile or foreign file is refused with a BvhFileError naming the file and what is wrong.
#include <isin/bvh/serialize.hpp>
#include <isin/scene.hpp>

#include <doctest/doctest.h>

#include "../support/workloads.hpp"
#include "../support/temp_dir.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <tuple>
#include <vector>

namespace {

using Bytes = std::vector<unsigned char>;

template <class T>
Bytes encode(const isin::Bvh<T>& bvh) {
    return isin::detail::BvhFile<T>::encode(bvh);
}

Bytes read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::uint64_t get64(const Bytes& b, std::size_t at) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | b[at + std::size_t(i)];
    return v;
}
void put64(Bytes& b, std::size_t at, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) b[at + std::size_t(i)] = static_cast<unsigned char>(v >> (8 * i));
}
void put32(Bytes& b, std::size_t at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) b[at + std::size_t(i)] = static_cast<unsigned char>(v >> (8 * i));
}
// Both checksums made right again after an edit: a file that is wrong only in what it says.
void reseal(Bytes& b) {
    using isin::detail::Xxh64;
    put64(b, 80, Xxh64::of(b.data(), 80));
    if (b.size() >= 96) put64(b, b.size() - 8, isin::detail::Xxh64x4::of(b.data(), b.size() - 8));
}

// The message of the BvhFileError that loading `b` throws ("" when it loads).
template <class T>
std::string refusal(const Bytes& b, std::size_t size, isin::ReadLimits limits = {}) {
    try {
        (void)isin::Bvh<T>::load_from_memory(b.data(), size, limits);
    } catch (const isin::BvhFileError& e) {
        return e.what();
    }
    return "";
}
template <class T>
std::string refusal(const Bytes& b) {
    return refusal<T>(b, b.size());
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

template <class T>
bool same_bits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}
template <class T>
bool same_hit(const isin::Hit<T>& a, const isin::Hit<T>& b) {
    return same_bits(a.t, b.t) && same_bits(a.u, b.u) && same_bits(a.v, b.v) && a.primitive == b.primitive;
}

// The arrays of two Bvhs, field by field (the padding of nodes and blocks is not theirs).
template <class T>
void check_same_arrays(const isin::Bvh<T>& a, const isin::Bvh<T>& b) {
    const auto& ta = a.tree();
    const auto& tb = b.tree();
    REQUIRE(ta.node_count() == tb.node_count());
    REQUIRE(ta.leaf_count() == tb.leaf_count());
    REQUIRE(ta.size() == tb.size());
    CHECK(a.depth() == b.depth());
    CHECK(a.memory() == b.memory());
    CHECK(same_bits(ta.bound(), tb.bound()));
    CHECK(same_bits(ta.leaf_scale(), tb.leaf_scale()));
    bool nodes = true, leaves = true, blocks = true;
    for (std::size_t i = 0; i < ta.node_count(); ++i) {
        const auto &x = ta.nodes()[i], &y = tb.nodes()[i];
        nodes &= std::memcmp(x.lo, y.lo, sizeof x.lo) == 0 && std::memcmp(x.hi, y.hi, sizeof x.hi) == 0 &&
                 std::memcmp(x.child, y.child, sizeof x.child) == 0;
    }
    for (std::size_t i = 0; i < ta.leaf_count(); ++i) {
        leaves &= ta.leaves()[i].first == tb.leaves()[i].first && ta.leaves()[i].count == tb.leaves()[i].count;
        blocks &= std::memcmp(a.blocks()[i].v, b.blocks()[i].v, sizeof a.blocks()[i].v) == 0 &&
                  std::memcmp(a.blocks()[i].primitive, b.blocks()[i].primitive, sizeof a.blocks()[i].primitive) == 0;
    }
    CHECK(nodes);
    CHECK(leaves);
    CHECK(blocks);
    CHECK(ta.primitives() == tb.primitives());
}

// Rays at the triangles, from all around and from inside the mesh's box, with a few axis-parallel
// and zero directions.
template <class T>
std::vector<isin::Ray<T>> test_rays(const std::vector<isin::Triangle<T>>& tris, int n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<isin::Ray<T>> rays;
    for (int i = 0; i < n; ++i) {
        const auto& tri = tris[std::size_t(rng() % tris.size())];
        const double u = 0.5 * (uni(rng) + 1), v = 0.5 * (uni(rng) + 1) * (1 - u);
        const auto target = workloads::at_barycentric(tri, u, v);
        const isin::Vertex<double> origin{uni(rng) * 25, uni(rng) * 25, uni(rng) * 25};
        if (i % 97 == 0) {
            rays.push_back({workloads::point<T>(origin.x, origin.y, origin.z), {T(i % 2 ? 1 : -1), T(0), T(0)}});
        } else if (i % 211 == 0) {
            rays.push_back({workloads::point<T>(origin.x, origin.y, origin.z), {T(0), T(0), T(0)}});
        } else {
            rays.push_back(workloads::ray_towards<T>(origin, target));
        }
    }
    return rays;
}

// Every query of `loaded` answers as `saved` does, bit for bit.
template <class T>
void check_same_answers(const isin::Bvh<T>& saved, const isin::Bvh<T>& loaded, const std::vector<isin::Ray<T>>& rays) {
    std::size_t hits = 0, hit_differs = 0, culled_differs = 0, occluded_differs = 0, all_differs = 0;
    std::vector<T> t_max(rays.size());
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto& ray = rays[i];
        const isin::Hit<T> a = saved.intersect(ray), b = loaded.intersect(ray);
        hits += a ? 1u : 0u;
        hit_differs += same_hit(a, b) ? 0u : 1u;
        isin::HitFilter cull;
        cull.cull_backfaces = true;
        culled_differs += same_hit(saved.intersect(ray, T(40), cull), loaded.intersect(ray, T(40), cull)) ? 0u : 1u;
        t_max[i] = a ? a.t * T(0.75) + T(0.01) : T(30);
        occluded_differs += saved.occluded(ray, t_max[i]) != loaded.occluded(ray, t_max[i]) ? 1u : 0u;
        using Found = std::tuple<std::uint32_t, T, T, T>;
        std::vector<Found> fa, fb;
        (void)saved.for_each_hit(ray, std::numeric_limits<T>::infinity(), [&](std::uint32_t k, const isin::Hit<T>& h) {
            fa.emplace_back(k, h.t, h.u, h.v);
            return true;
        });
        (void)loaded.for_each_hit(ray, std::numeric_limits<T>::infinity(), [&](std::uint32_t k, const isin::Hit<T>& h) {
            fb.emplace_back(k, h.t, h.u, h.v);
            return true;
        });
        std::sort(fa.begin(), fa.end()), std::sort(fb.begin(), fb.end());
        bool same = fa.size() == fb.size();
        for (std::size_t k = 0; same && k < fa.size(); ++k)
            same = std::get<0>(fa[k]) == std::get<0>(fb[k]) && same_bits(std::get<1>(fa[k]), std::get<1>(fb[k])) &&
                   same_bits(std::get<2>(fa[k]), std::get<2>(fb[k])) &&
                   same_bits(std::get<3>(fa[k]), std::get<3>(fb[k]));
        all_differs += same ? 0u : 1u;
    }
    CHECK(hits > rays.size() / 3);
    CHECK(hit_differs == 0);
    CHECK(culled_differs == 0);
    CHECK(occluded_differs == 0);
    CHECK(all_differs == 0);
    std::vector<isin::Hit<T>> sa(rays.size()), sb(rays.size());
    saved.intersect(rays.data(), rays.size(), sa.data());
    loaded.intersect(rays.data(), rays.size(), sb.data());
    std::size_t stream_differs = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) stream_differs += same_hit(sa[i], sb[i]) ? 0u : 1u;
    CHECK(stream_differs == 0);
    std::vector<std::uint8_t> ba(rays.size()), bb(rays.size());
    saved.occluded(rays.data(), rays.size(), t_max.data(), ba.data());
    loaded.occluded(rays.data(), rays.size(), t_max.data(), bb.data());
    CHECK(ba == bb);
}

// A soup with triangles the build leaves out (zero area, NaN), so that indices have gaps.
template <class T>
std::vector<isin::Triangle<T>> soup_with_gaps(int n, std::uint64_t seed) {
    auto tris = workloads::triangle_soup<T>(n, seed);
    for (std::size_t i = 0; i < tris.size(); i += 37) tris[i].v2 = tris[i].v1;
    for (std::size_t i = 5; i < tris.size(); i += 101) tris[i].v0.x = std::numeric_limits<T>::quiet_NaN();
    return tris;
}

// A small Bvh's file, for the tests that damage it byte by byte.
template <class T>
Bytes small_file() {
    const auto tris = workloads::icosphere<T>({0.5, -0.25, 2}, 1.5, 1); // 80 triangles
    isin::BvhOptions options;
    options.leaf_size = 4;
    return encode(isin::Bvh<T>(tris, options));
}

} // namespace

TEST_CASE("XXH64 as its specification gives it, whole or in pieces") {
    using isin::detail::Xxh64;
    const auto of = [](const std::string& s) {
        return Xxh64::of(reinterpret_cast<const unsigned char*>(s.data()), s.size());
    };
    CHECK(of("") == 0xEF46DB3751D8E999u);
    CHECK(of("abc") == 0x44BC2CF5AD770999u);
    CHECK(of("Nobody inspects the spammish repetition") == 0xFBCEA83C8A378BF1u);
    std::string text;
    for (int i = 0; i < 300; ++i) text += char('a' + i % 23);
    const std::uint64_t whole = of(text);
    for (std::size_t piece : {1u, 3u, 8u, 31u, 32u, 33u, 100u}) {
        Xxh64 h;
        for (std::size_t at = 0; at < text.size(); at += piece)
            h.update(reinterpret_cast<const unsigned char*>(text.data()) + at, std::min(piece, text.size() - at));
        CHECK(h.digest() == whole);
    }
}

TEST_CASE("the four-stream checksum is XXH64 of four XXH64 streams over interleaved stripes, whole or in pieces") {
    using isin::detail::Xxh64;
    using isin::detail::Xxh64x4;
    // Its definition (docs/bvh_format.md), from the stripes gathered stream by stream.
    const auto defined = [](const Bytes& b) {
        Bytes streams[4], digests(32);
        for (std::size_t at = 0; at < b.size(); at += 32)
            streams[at / 32 % 4].insert(streams[at / 32 % 4].end(), b.begin() + std::ptrdiff_t(at),
                                        b.begin() + std::ptrdiff_t(std::min(b.size(), at + 32)));
        for (std::size_t j = 0; j < 4; ++j) put64(digests, 8 * j, Xxh64::of(streams[j].data(), streams[j].size()));
        return Xxh64::of(digests.data(), 32);
    };
    std::mt19937 random(7);
    for (const std::size_t size : {0u, 1u, 31u, 32u, 33u, 64u, 96u, 127u, 128u, 129u, 200u, 255u, 256u, 1000u, 4099u}) {
        Bytes b(size);
        for (auto& c : b) c = static_cast<unsigned char>(random());
        const std::uint64_t whole = defined(b);
        CHECK(Xxh64x4::of(b.data(), b.size()) == whole);
        for (const std::size_t piece : {1u, 7u, 32u, 100u, 128u, 300u}) {
            Xxh64x4 h;
            for (std::size_t at = 0; at < size; at += piece) h.update(b.data() + at, std::min(piece, size - at));
            CHECK(h.digest() == whole);
        }
        for (const std::size_t record : {8u, 224u, 320u, 416u}) { // records with a check after each
            Xxh64x4 h;
            h.update(b.data(), std::min<std::size_t>(size, 88));
            const std::size_t count = (size - std::min<std::size_t>(size, 88)) / record;
            std::size_t seen = 0;
            h.update_each(b.data() + std::min<std::size_t>(size, 88), count, record, [&](std::size_t k) {
                CHECK(k == seen);
                ++seen;
            });
            CHECK(seen == count);
            const std::size_t at = std::min<std::size_t>(size, 88) + count * record;
            h.update(b.data() + at, size - at);
            CHECK(h.digest() == whole);
        }
    }
    CHECK(Xxh64x4::of(nullptr, 0) != Xxh64::of(nullptr, 0)); // not XXH64 of the bytes themselves
}

TEST_CASE_TEMPLATE("a loaded Bvh of a soup answers every ray as the saved one", T, float, double) {
    const auto tris = soup_with_gaps<T>(3000, 11);
    const isin::Bvh<T> saved(tris);
    const TempDir dir("isin-bvh-save-");
    const std::string path = dir / "soup.bvh";
    saved.save(path);
    const isin::Bvh<T> loaded = isin::Bvh<T>::load(path);
    check_same_arrays(saved, loaded);
    check_same_answers(saved, loaded, test_rays(tris, 3000, 12));
    const Bytes bytes = read_file(path);
    CHECK(bytes == encode(saved));
    check_same_arrays(saved, isin::Bvh<T>::load_from_memory(bytes.data(), bytes.size()));
    CHECK(double(bytes.size()) <= 1.15 * double(saved.memory()));
}

TEST_CASE_TEMPLATE("a loaded Bvh of a Mesh answers every ray as the saved one", T, float, double) {
    const auto tris = workloads::icosphere<T>({1, 2, 3}, 6, 4);
    const auto mesh = isin::Mesh<T>::from_triangles(tris);
    isin::BvhOptions options;
    options.threads = 2;
    const isin::Bvh<T> saved(mesh, options);
    const TempDir dir("isin-bvh-save-");
    saved.save(dir / "mesh.bvh");
    saved.save(dir / "mesh.bvh"); // replaces it
    const auto loaded = isin::Bvh<T>::load(dir / "mesh.bvh");
    check_same_arrays(saved, loaded);
    check_same_answers(saved, loaded, test_rays(tris, 3000, 13));
}

TEST_CASE_TEMPLATE("an empty Bvh and a one-leaf Bvh round-trip", T, float, double) {
    std::vector<isin::Triangle<T>> none{{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}}; // zero area: left out
    const isin::Bvh<T> empty(none);
    const Bytes file = encode(empty);
    CHECK(file.size() == 96);
    const auto loaded = isin::Bvh<T>::load_from_memory(file.data(), file.size());
    CHECK(loaded.size() == 0);
    CHECK(!loaded.intersect(isin::Ray<T>{{0, 0, -1}, {0, 0, 1}}));
    const isin::Bvh<T> one(std::vector<isin::Triangle<T>>{{{-1, -1, 2}, {0, 1, 2}, {1, -1, 2}}});
    const Bytes file1 = encode(one);
    const auto loaded1 = isin::Bvh<T>::load_from_memory(file1.data(), file1.size());
    check_same_arrays(one, loaded1);
    CHECK(loaded1.intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}).t == T(2));
}

TEST_CASE_TEMPLATE("a Bvh file truncated at any byte is refused as truncated", T, float, double) {
    const Bytes file = small_file<T>();
    REQUIRE(file.size() > 1000);
    CHECK(contains(refusal<T>(file, 0), "is empty"));
    std::size_t wrong = 0;
    for (std::size_t n = 1; n < file.size(); ++n) wrong += contains(refusal<T>(file, n), "truncated") ? 0u : 1u;
    CHECK(wrong == 0);
    CHECK(refusal<T>(file).empty());
    Bytes longer = file;
    longer.push_back(0);
    CHECK(contains(refusal<T>(longer), "after its end"));
}

TEST_CASE_TEMPLATE("a Bvh file with any one bit flipped is refused", T, float, double) {
    const Bytes file = small_file<T>();
    Bytes damaged = file;
    std::size_t loaded = 0, tried = 0;
    // Every bit of the header and of the checksum; in between, every bit of every fifth byte.
    for (std::size_t at = 0; at < file.size(); ++at) {
        if (at >= 88 && at + 8 < file.size() && at % 5 != 0) continue;
        for (int bit = 0; bit < 8; ++bit, ++tried) {
            damaged[at] = static_cast<unsigned char>(file[at] ^ (1u << bit));
            loaded += refusal<T>(damaged).empty() ? 1u : 0u;
            damaged[at] = file[at];
        }
    }
    CHECK(tried > 3000);
    CHECK(loaded == 0);
    damaged[200] ^= 1u;
    CHECK(contains(refusal<T>(damaged), "checksum mismatch"));
    damaged = file;
    damaged[40] ^= 1u;
    CHECK(contains(refusal<T>(damaged), "checksum mismatch in its header"));
}

TEST_CASE_TEMPLATE("a Bvh file of the other precision, version or layout is refused, saying so", T, float, double) {
    using Other = std::conditional_t<std::is_same_v<T, float>, double, float>;
    const Bytes file = small_file<T>();
    const std::string other = refusal<Other>(file);
    CHECK(contains(other, "wrong precision"));
    CHECK(
        contains(other, std::is_same_v<T, float> ? "Bvh<float>, not a Bvh<double>" : "Bvh<double>, not a Bvh<float>"));
    Bytes b = file;
    put32(b, 8, 1); // the format before the four-stream checksum
    CHECK(contains(refusal<T>(b), "has format version 1; this isin reads version 2"));
    put32(b, 8, 3);
    CHECK(contains(refusal<T>(b), "has format version 3"));
    b = file;
    put32(b, 24, 16);
    reseal(b);
    CHECK(contains(refusal<T>(b), "blocks of 16 triangles"));
    b = file;
    b[0] = 'I';
    CHECK(contains(refusal<T>(b), "is not a Bvh file"));
}

TEST_CASE_TEMPLATE("extreme counts in a Bvh file are refused before anything is allocated", T, float, double) {
    const Bytes file = small_file<T>();
    for (const std::size_t field : {32u, 40u, 48u}) {
        for (const std::uint64_t count :
             {std::uint64_t(0x7fffffff), std::uint64_t(0xffffffff), std::uint64_t(1) << 40, ~std::uint64_t(0)}) {
            Bytes b = file;
            put64(b, field, count);
            reseal(b);
            CHECK(!refusal<T>(b).empty());
            // The same with the length field agreeing: now only the file's real length tells.
            const std::uint64_t nodes = get64(b, 32), leaves = get64(b, 40), primitives = get64(b, 48);
            if (nodes < 0x80000000u && leaves < 0x80000000u && primitives <= 0xffffffffu) {
                const std::uint64_t node_bytes = 48 * sizeof(T) + 32, block_bytes = 72 * sizeof(T) + 32;
                put64(b, 72, 96 + nodes * node_bytes + leaves * (8 + block_bytes) + primitives * 4);
                reseal(b);
                CHECK(contains(refusal<T>(b), "truncated"));
            }
        }
    }
}

TEST_CASE_TEMPLATE("a Bvh file whose tree is wrong but sealed is refused: every index is checked", T, float, double) {
    const Bytes file = small_file<T>();
    const std::uint64_t nodes = get64(file, 32), leaves = get64(file, 40), primitives = get64(file, 48);
    REQUIRE(nodes >= 2);
    const std::size_t node_bytes = 48 * sizeof(T) + 32;
    const std::size_t child0 = 88 + 48 * sizeof(T); // node 0's child references
    const std::size_t leaves_at = 88 + std::size_t(nodes) * node_bytes;
    const std::size_t primitives_at = leaves_at + std::size_t(leaves) * 8;
    const std::size_t blocks_at = primitives_at + std::size_t(primitives) * 4;
    const auto edited = [&](std::size_t at, std::uint32_t value) {
        Bytes b = file;
        put32(b, at, value);
        reseal(b);
        return refusal<T>(b);
    };
    CHECK(contains(edited(child0, 0x80000000u + std::uint32_t(leaves)), "index out of range"));
    CHECK(contains(edited(child0, 0x7ffffff0u), "index out of range"));
    CHECK(contains(edited(child0 + node_bytes, 1), "index out of range")); // node 1 → itself: a cycle
    CHECK(contains(edited(child0 + node_bytes, 0), "index out of range")); // back to the root
    CHECK(contains(edited(leaves_at, 0xfffffffeu), "index out of range"));
    CHECK(contains(edited(leaves_at + 4, 0), "index out of range"));
    CHECK(contains(edited(leaves_at + 4, 9), "index out of range"));
    CHECK(contains(edited(primitives_at, 123456), "not its leaf's"));
    CHECK(contains(edited(blocks_at + 72 * sizeof(T), 123456), "not its leaf's"));
    { // an empty child slot with a box a ray can enter
        Bytes b = file;
        std::size_t node = std::size_t(nodes), slot = 0;
        for (std::size_t i = 0; i < nodes && node == nodes; ++i)
            for (std::size_t k = 0; k < 8; ++k)
                if ((get64(b, child0 + i * node_bytes + 4 * k) & 0xffffffffu) == 0xffffffffu) {
                    node = i, slot = k;
                    break;
                }
        REQUIRE(node < nodes);
        const T zero = 0;
        for (std::size_t a = 0; a < 6; ++a) // lo[0..2] then hi[0..2] of the slot
            std::memcpy(&b[88 + node * node_bytes + (a * 8 + slot) * sizeof(T)], &zero, sizeof(T));
        reseal(b);
        CHECK(contains(refusal<T>(b), "is empty, its box not"));
    }
    CHECK(contains(edited(28, 1), "depth"));
    CHECK(contains(edited(28, 200), "depth"));
    // Two references to one node: the second is refused.
    Bytes b = file;
    std::uint32_t refs[8];
    std::memcpy(refs, &b[child0], sizeof refs);
    int node_ref = -1;
    for (int k = 0; k < 8; ++k)
        if (refs[k] != 0xffffffffu && !(refs[k] & 0x80000000u)) node_ref = k;
    REQUIRE(node_ref >= 0);
    for (int k = 0; k < 8; ++k)
        if (k != node_ref && refs[k] != 0xffffffffu) put32(b, child0 + 4 * std::size_t(k), refs[node_ref]);
    reseal(b);
    CHECK(contains(refusal<T>(b), "reached twice"));
}

TEST_CASE_TEMPLATE("a sealed Bvh file whose leaf blocks are not their leaves' is refused, in every piece read", T,
                   float, double) {
    const Bytes file = encode(isin::Bvh<T>(soup_with_gaps<T>(3000, 11))); // leaf blocks in several pieces
    const std::uint64_t nodes = get64(file, 32), leaves = get64(file, 40), primitives = get64(file, 48);
    const std::size_t leaves_at = 88 + std::size_t(nodes) * (48 * sizeof(T) + 32);
    const std::size_t primitives_at = leaves_at + std::size_t(leaves) * 8;
    const std::size_t blocks_at = primitives_at + std::size_t(primitives) * 4, block_bytes = 72 * sizeof(T) + 32;
    REQUIRE(leaves * block_bytes > (std::size_t(1) << 17));
    REQUIRE(refusal<T>(file).empty());
    const auto lane_at = [&](std::size_t leaf, std::size_t k) {
        return blocks_at + leaf * block_bytes + 72 * sizeof(T) + 4 * k;
    };
    std::size_t padded = 0, checked = 0;
    for (std::size_t leaf = 0; leaf < leaves; leaf += 37) {
        const std::uint32_t first = std::uint32_t(get64(file, leaves_at + 8 * leaf)),
                            count = std::uint32_t(get64(file, leaves_at + 8 * leaf + 4));
        const auto primitive = [&](std::size_t k) { return std::uint32_t(get64(file, lane_at(leaf, k))); };
        const auto refused = [&](Bytes b) {
            reseal(b);
            return contains(refusal<T>(b), "block " + std::to_string(leaf) + " is not its leaf's");
        };
        Bytes b = file;
        put32(b, lane_at(leaf, count - 1), primitive(count - 1) + 1); // a lane not its leaf's primitive
        CHECK(refused(b));
        if (count >= 2) { // a live lane that repeats lane 0 (taken for padding), in the block and the leaf
            b = file;
            put32(b, lane_at(leaf, 1), primitive(0));
            put32(b, primitives_at + 4 * (std::size_t(first) + 1), primitive(0));
            CHECK(refused(b));
        }
        if (count >= 3) { // two live lanes alike
            b = file;
            put32(b, lane_at(leaf, 2), primitive(1));
            put32(b, primitives_at + 4 * (std::size_t(first) + 2), primitive(1));
            CHECK(refused(b));
        }
        for (std::uint32_t j = 1; j + 1 < count; ++j) { // the last live lane as each other one: every distance
            b = file;
            put32(b, lane_at(leaf, count - 1), primitive(j));
            put32(b, primitives_at + 4 * (std::size_t(first) + count - 1), primitive(j));
            CHECK(refused(b));
        }
        if (count < 8) { // padding that is not lane 0: its primitive, then each of its reals by one bit
            ++padded;
            b = file;
            put32(b, lane_at(leaf, 7), primitive(0) + 1);
            CHECK(refused(b));
            for (std::size_t r = 0; r < 9; ++r) {
                b = file;
                b[blocks_at + leaf * block_bytes + (r * 8 + 7) * sizeof(T)] ^= 1;
                CHECK(refused(b));
            }
        }
        ++checked;
    }
    CHECK(checked > 10);
    CHECK(padded > 0);
    // A damaged file is called damaged, even when what it holds is also wrong.
    Bytes b = file;
    put32(b, lane_at(std::size_t(leaves) - 1, 0), 123456);
    reseal(b);
    b[100] ^= 4;
    CHECK(contains(refusal<T>(b), "checksum mismatch"));
}

TEST_CASE_TEMPLATE("Bvh files: empty, a directory, missing, too large, unwritable", T, float, double) {
    const TempDir dir("isin-bvh-save-");
    const auto message = [](const std::string& path, isin::ReadLimits limits = {}) {
        try {
            (void)isin::Bvh<T>::load(path, limits);
        } catch (const isin::BvhFileError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    const std::string empty = dir.put("empty.bvh", "");
    CHECK(contains(message(empty), "is empty"));
    CHECK(contains(message(empty), empty));
    CHECK(contains(message(dir.path.string()), "is a directory"));
    CHECK(contains(message(dir / "missing.bvh"), "cannot open"));
    CHECK(contains(message(dir / "missing.bvh"), "missing.bvh"));
    const isin::Bvh<T> bvh(workloads::icosphere<T>({0, 0, 0}, 1, 1));
    const std::string path = dir / "small.bvh";
    bvh.save(path);
    const auto size = std::filesystem::file_size(path);
    isin::ReadLimits limits;
    limits.max_file_bytes = size - 1;
    CHECK(contains(message(path, limits), "ReadLimits::max_file_bytes"));
    limits.max_file_bytes = size;
    CHECK(message(path, limits).empty());
    const Bytes bytes = read_file(path);
    CHECK(contains(refusal<T>(bytes, bytes.size(), isin::ReadLimits{size - 1, 1}), "max_file_bytes"));
    CHECK_THROWS_AS(bvh.save(dir / "no/such/dir/x.bvh"), isin::BvhFileError);
    CHECK_THROWS_AS(bvh.save(dir.path.string()), isin::BvhFileError);
    CHECK_THROWS_AS((void)isin::Bvh<T>::load_from_memory(nullptr, 10), isin::BvhFileError);
}

TEST_CASE_TEMPLATE("a scene takes a mesh with its saved Bvh, and refuses another mesh's", T, float, double) {
    const auto tris = workloads::icosphere<T>({0, 0, 6}, 2, 3);
    const TempDir dir("isin-bvh-save-");
    const std::string path = dir / "mesh.bvh";
    isin::Scene<T, isin::Sphere> built;
    const auto id = built.add_mesh(tris, built.add_material({}));
    built.add_instance(id, isin::Transform<T>::translation({3, 0, 2}));
    built.commit();
    built.mesh_bvh(id).save(path);

    isin::Scene<T, isin::Sphere> loaded;
    const auto mesh = isin::Mesh<T>::from_triangles(tris);
    const auto lid = loaded.add_mesh(mesh, loaded.add_material({}), isin::Bvh<T>::load(path));
    loaded.add_instance(lid, isin::Transform<T>::translation({3, 0, 2}));
    loaded.commit();
    check_same_arrays(built.mesh_bvh(id), loaded.mesh_bvh(lid));
    std::size_t hits = 0, differ = 0;
    for (const auto& ray : test_rays(tris, 2000, 21)) {
        const isin::Hit<T> a = built.intersect(ray), b = loaded.intersect(ray);
        hits += a ? 1u : 0u;
        differ += same_hit(a, b) ? 0u : 1u;
    }
    CHECK(hits > 500);
    CHECK(differ == 0);

    auto moved = mesh; // one vertex moved by one ulp: not the mesh the Bvh was built over
    moved.positions[5].x = std::nextafter(moved.positions[5].x, T(1e9));
    CHECK_THROWS_AS(loaded.add_mesh(moved, 0, isin::Bvh<T>::load(path)), std::invalid_argument);
    auto fewer = mesh;
    fewer.indices.pop_back();
    CHECK_THROWS_AS(loaded.add_mesh(fewer, 0, isin::Bvh<T>::load(path)), std::invalid_argument);
    auto more = mesh;
    more.indices.push_back({0, 1, 2});
    CHECK_THROWS_AS(loaded.add_mesh(more, 0, isin::Bvh<T>::load(path)), std::invalid_argument);
    CHECK(loaded.mesh_count() == 1);
}
