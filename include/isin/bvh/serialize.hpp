#pragma once
/// isin — saving a Bvh to a file and loading it back without building (docs/bvh_format.md):
/// Bvh<T>::save, Bvh<T>::load and Bvh<T>::load_from_memory. The file holds what traversal reads
/// (nodes, leaves, primitive order, leaf blocks) as little-endian arrays in the one layout every
/// code path reads (8-wide nodes, 8-lane blocks), after a header and its own checksum, and ends
/// with a checksum (four XXH64 streams, Xxh64x4) of every byte before it. Loading trusts
/// nothing: sizes are checked against the file's length before anything is allocated, and the
/// checksum and every index, count and reference of the tree (each checked in bounds as it is
/// read) before the Bvh is returned.
///
///     isin::Bvh<float> bvh{mesh};
///     bvh.save("model.bvh");                                   // once
///     auto loaded = isin::Bvh<float>::load("model.bvh");       // at every start: same hits
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "../io/file.hpp"
#include "../read_limits.hpp"
#include "../detail/xxh64.hpp"
#include "../simd/lanes.hpp"
#include "triangle_bvh.hpp"

namespace isin {

/// A Bvh file that cannot be written or read: what() names the file and says what is wrong
/// (truncated, wrong precision, wrong version, checksum, index out of range, …).
class BvhFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

namespace detail {

/// Whether this host stores numbers little-endian, as Bvh files do.
[[nodiscard]] inline bool host_little_endian() noexcept {
    const std::uint32_t one = 1;
    unsigned char first;
    std::memcpy(&first, &one, 1);
    return first == 1;
}

/// Reverses the bytes of each of `count` words of `size` bytes at p (4 or 8): host order ↔
/// little-endian on a big-endian host.
inline void swap_words(unsigned char* p, std::size_t count, std::size_t size) noexcept {
    for (std::size_t i = 0; i < count; ++i, p += size)
        for (std::size_t a = 0, b = size - 1; a < b; ++a, --b) std::swap(p[a], p[b]);
}

/// What BvhFile::decode reads from: bytes in memory.
struct MemorySource {
    const unsigned char* p;
    std::size_t left;
    std::string error; // always empty: running out is truncation
    /// The next n bytes into `to`; false when fewer are left.
    bool read(void* to, std::size_t n) noexcept {
        if (n > left) return false;
        if (n) std::memcpy(to, p, n);
        p += n, left -= n;
        return true;
    }
};

#if ISIN_DETAIL_POSIX_FILES
/// What BvhFile::decode reads from: an open file, read straight into the Bvh's arrays (no copy of
/// the whole file is held).
struct FileSource {
    int fd;
    std::string error; // why a read failed, or empty when the file ended
    /// The next n bytes into `to`; false when the file ends first or a read fails.
    bool read(void* to, std::size_t n) {
        auto* b = static_cast<unsigned char*>(to);
        while (n) {
            const ssize_t got = ::read(fd, b, n);
            if (got < 0 && errno == EINTR) continue;
            if (got < 0) error = "cannot read: " + errno_text(errno);
            if (got <= 0) return false;
            b += got, n -= std::size_t(got);
        }
        return true;
    }
};
#endif

/// The file of a Bvh<T> (docs/bvh_format.md): its encoder and its checking decoder.
template <class T>
class BvhFile {
public:
    using Tree = BvhTree<T>;
    using Node = typename Tree::Node;
    using Leaf = typename Tree::Leaf;
    using Block = typename TriangleBlocks<T>::Block;

    static constexpr char magic[8] = {'i', 's', 'i', 'n', '-', 'b', 'v', 'h'};
    static constexpr std::uint32_t version = 2;
    static constexpr std::size_t header_bytes = 88, checksum_bytes = 8;
    // A record holds a struct's fields in order, without the padding alignas adds at its end.
    static constexpr std::size_t node_bytes = 48 * sizeof(T) + 32, leaf_bytes = 8, primitive_bytes = 4,
                                 block_bytes = 72 * sizeof(T) + 32;
    static_assert(offsetof(Node, hi) == 24 * sizeof(T) && offsetof(Node, child) == 48 * sizeof(T));
    static_assert(offsetof(Block, primitive) == 72 * sizeof(T) && sizeof(Leaf) == leaf_bytes);

    /// The bytes of `bvh`'s file.
    [[nodiscard]] static std::vector<unsigned char> encode(const Bvh<T>& bvh) {
        const Tree& tree = bvh.tree_;
        const std::uint64_t nodes = tree.nodes_.size(), leaves = tree.leaves_.size(),
                            primitives = tree.primitives_.size();
        std::vector<unsigned char> out(std::size_t(file_bytes(nodes, leaves, primitives)));
        unsigned char* p = out.data();
        std::memcpy(p, magic, 8);
        put32(p + 8, version);
        put32(p + 12, std::uint32_t(header_bytes));
        put32(p + 16, std::uint32_t(sizeof(T)));
        put32(p + 20, 8); // children a node
        put32(p + 24, 8); // triangles a block
        put32(p + 28, std::uint32_t(tree.depth()));
        put64(p + 32, nodes);
        put64(p + 40, leaves);
        put64(p + 48, primitives);
        put_double(p + 56, double(tree.bound_));
        put_double(p + 64, double(tree.leaf_scale_));
        put64(p + 72, out.size());
        put64(p + 80, Xxh64::of(p, 80));
        p += header_bytes;
        for (const Node& n : tree.nodes_) p = put_record(p, &n, node_bytes, 48);
        p = put_array(p, tree.leaves_.data(), leaves * leaf_bytes);
        p = put_array(p, tree.primitives_.data(), primitives * primitive_bytes);
        for (std::size_t k = 0; k < leaves; ++k) p = put_record(p, &bvh.blocks_[k], block_bytes, 72);
        put64(p, Xxh64x4::of(out.data(), out.size() - checksum_bytes));
        return out;
    }

    // What a file's header says, once checked against itself and the file's size.
    struct Header {
        std::uint32_t depth;
        std::uint64_t nodes, leaves, primitives;
        double bound, leaf_scale;
    };
    /// The header in `data` (header_bytes, or `size` if fewer) of a file of `size` bytes, checked:
    /// magic, version, its checksum, precision, widths, counts, depth and length; throws fail(what).
    template <class Fail>
    [[nodiscard]] static Header check_header(const unsigned char* data, std::uint64_t size, const Fail& fail) {
        if (size < 12 || std::memcmp(data, magic, 8) != 0)
            throw fail(size < 12 && std::memcmp(data, magic, std::min<std::size_t>(size, 8)) == 0
                           ? "truncated: " + std::to_string(size) + " bytes, less than a header"
                           : "is not a Bvh file (its first 8 bytes are not \"isin-bvh\")");
        if (get32(data + 8) != version)
            throw fail("has format version " + std::to_string(get32(data + 8)) + "; this isin reads version " +
                       std::to_string(version));
        if (size < header_bytes)
            throw fail("truncated: " + std::to_string(size) + " bytes, less than its header's " +
                       std::to_string(header_bytes));
        if (get64(data + 80) != Xxh64::of(data, 80)) throw fail("checksum mismatch in its header (a damaged file)");
        if (get32(data + 12) != header_bytes)
            throw fail("has a header of " + std::to_string(get32(data + 12)) + " bytes; version " +
                       std::to_string(version) + " has " + std::to_string(header_bytes));
        if (get32(data + 16) != sizeof(T))
            throw fail("wrong precision: it holds a Bvh<" + precision_name(get32(data + 16)) + ">, not a Bvh<" +
                       precision_name(sizeof(T)) + ">");
        if (get32(data + 20) != 8 || get32(data + 24) != 8)
            throw fail("has nodes of " + std::to_string(get32(data + 20)) + " children and blocks of " +
                       std::to_string(get32(data + 24)) + " triangles; every code path of this isin reads 8 and 8");
        const std::uint32_t depth = get32(data + 28);
        const std::uint64_t nodes = get64(data + 32), leaves = get64(data + 40), primitives = get64(data + 48);
        // References are 31 bits (leaf_bit), leaf ranges 32; an empty tree has nothing at all.
        if (nodes >= Tree::leaf_bit || leaves >= Tree::leaf_bit || primitives > 0xffffffffu)
            throw fail("count out of range: " + std::to_string(nodes) + " nodes, " + std::to_string(leaves) +
                       " leaves, " + std::to_string(primitives) + " primitives");
        if ((nodes == 0) != (leaves == 0) || (nodes == 0) != (primitives == 0) || (nodes == 0) != (depth == 0))
            throw fail("inconsistent counts: " + std::to_string(nodes) + " nodes, " + std::to_string(leaves) +
                       " leaves, " + std::to_string(primitives) + " primitives, depth " + std::to_string(depth));
        if (depth > std::uint32_t(Tree::depth_limit))
            throw fail("depth " + std::to_string(depth) + " is beyond the limit of " +
                       std::to_string(Tree::depth_limit));
        const std::uint64_t expected = file_bytes(nodes, leaves, primitives);
        if (get64(data + 72) != expected)
            throw fail("its header gives a length of " + std::to_string(get64(data + 72)) + " bytes, its counts " +
                       std::to_string(expected));
        if (size < expected)
            throw fail("truncated: " + std::to_string(size) + " of " + std::to_string(expected) + " bytes");
        if (size > expected)
            throw fail("has " + std::to_string(size - expected) + " bytes after its end (" + std::to_string(expected) +
                       " bytes)");
        const double bound = get_double(data + 56), leaf_scale = get_double(data + 64);
        if (!(double(T(bound)) == bound && bound >= 0.0) || !(double(T(leaf_scale)) == leaf_scale && leaf_scale >= 0.0))
            throw fail("bound or leaf scale out of range");
        return {depth, nodes, leaves, primitives, bound, leaf_scale};
    }

    /// The Bvh in the `size` bytes `source` holds (MemorySource, FileSource), a file named `name`
    /// in messages; throws BvhFileError. The file's parts are read straight into the Bvh's arrays
    /// (padded records through a buffer of one piece), each piece summed and checked in cache.
    template <class Source>
    [[nodiscard]] static Bvh<T> decode(Source& source, std::uint64_t size, const std::string& name,
                                       const ReadLimits& limits) {
        const auto fail = [&name](const std::string& what) {
            return BvhFileError("isin Bvh file " + name + ": " + what);
        };
        if (!detail::file_too_large(size, limits).empty()) throw fail(detail::file_too_large(size, limits));
        if (size == 0) throw fail("is empty");
        unsigned char data[header_bytes] = {};
        const auto read = [&](void* to, std::size_t n) {
            if (!source.read(to, n)) throw fail(source.error.empty() ? "truncated while it was read" : source.error);
        };
        read(data, std::size_t(std::min<std::uint64_t>(size, header_bytes)));
        const Header h = check_header(data, size, fail);
        const std::uint32_t depth = h.depth;
        const std::uint64_t nodes = h.nodes, leaves = h.leaves, primitives = h.primitives;
        const double bound = h.bound, leaf_scale = h.leaf_scale;

        Bvh<T> bvh;
        Tree& tree = bvh.tree_;
        auto& blocks = bvh.blocks_.blocks_;
        Xxh64x4 sum;
        sum.update(data, header_bytes);
        Checker checker(bvh, std::size_t(nodes), std::size_t(leaves), depth);
        const bool swap = !host_little_endian();
        // Each part is read a piece at a time, and each piece is summed, put in host order and
        // checked while it is in cache: one pass over the Bvh's memory in all. A piece is about
        // 128 KiB: well inside a core's L2, and few enough read calls that their cost is small.
        const auto piece = [](std::size_t bytes) { return std::max<std::size_t>(1, (std::size_t(1) << 17) / bytes); };
        // Records of `bytes` each straight into `array`, whose elements have no padding beyond them;
        // each(i) checks record i as soon as it is summed.
        const auto read_straight = [&](void* array, std::size_t count, std::size_t bytes, std::size_t words,
                                       auto&& each) {
            for (std::size_t i = 0; i < count;) {
                const std::size_t end = std::min(count, i + piece(bytes)), first = i;
                unsigned char* const to = static_cast<unsigned char*>(array) + i * bytes;
                read(to, (end - i) * bytes);
                if (swap) {
                    sum.update(to, (end - i) * bytes);
                    swap_words(to, (end - i) * bytes / words, words);
                    for (; i < end; ++i) each(i);
                } else {
                    sum.update_each(to, end - i, bytes, [&](std::size_t k) { each(first + k); });
                    i = end;
                }
            }
        };
        // Records of `bytes` each through a buffer of one piece, each handed to each(record, index).
        std::vector<unsigned char> buffer;
        const auto read_padded = [&](std::size_t count, std::size_t bytes, auto&& each) {
            buffer.resize(std::min(count, piece(bytes)) * bytes);
            for (std::size_t i = 0; i < count;) {
                const std::size_t end = std::min(count, i + piece(bytes)), first = i;
                read(buffer.data(), (end - i) * bytes);
                sum.update_each(buffer.data(), end - i, bytes,
                                [&](std::size_t k) { each(buffer.data() + k * bytes, first + k); });
                i = end;
            }
        };
        // Arrays of uint32 checked later (leaves and primitives, by the blocks' check).
        const auto read_words = [&](void* array, std::size_t bytes) {
            for (std::size_t i = 0; i < bytes;) {
                const std::size_t n = std::min(bytes - i, std::size_t(1) << 17);
                unsigned char* const to = static_cast<unsigned char*>(array) + i;
                read(to, n);
                sum.update(to, n);
                if (swap) swap_words(to, n / 4, 4);
                i += n;
            }
        };
        // On huge pages where the kernel has them, as the build's arrays (huge_pages.hpp); the
        // arrays' allocator leaves them unwritten until they are read into.
        // An array of 1 MiB or more is given a huge page's capacity at least (as the build's, which
        // it reserves larger than they end): its first writes then fault once, not 4 KiB at a time.
        const auto reserve = [](auto& array, std::size_t n) {
            const std::size_t huge = detail::huge_page_bytes / sizeof(*array.data());
            detail::reserve_huge_pages(array, n >= huge / 2 ? std::max(n, huge) : n);
        };
        reserve(tree.nodes_, std::size_t(nodes));
        reserve(tree.leaves_, std::size_t(leaves));
        reserve(tree.primitives_, std::size_t(primitives));
        tree.nodes_.resize(std::size_t(nodes));
        read_padded(std::size_t(nodes), node_bytes, [&](const unsigned char* p, std::size_t i) {
            get_record(&tree.nodes_[i], p, node_bytes, 48);
            checker.node(i);
        });
        tree.leaves_.resize(std::size_t(leaves));
        read_words(tree.leaves_.data(), std::size_t(leaves) * leaf_bytes);
        tree.primitives_.resize(std::size_t(primitives));
        read_words(tree.primitives_.data(), std::size_t(primitives) * primitive_bytes);
        blocks.resize(std::size_t(leaves));
        if (sizeof(Block) == block_bytes && !swap)
            read_straight(blocks.data(), std::size_t(leaves), block_bytes, 1, [&](std::size_t l) { checker.block(l); });
        else
            read_padded(std::size_t(leaves), block_bytes, [&](const unsigned char* p, std::size_t l) {
                get_record(&blocks[l], p, block_bytes, 72);
                checker.block(l);
            });
        unsigned char stored[checksum_bytes];
        read(stored, checksum_bytes);
        if (sum.digest() != get64(stored)) throw fail("checksum mismatch (a damaged file)");
        tree.bound_ = T(bound), tree.leaf_scale_ = T(leaf_scale);
        const std::string wrong = checker.finish();
        if (!wrong.empty()) throw fail(wrong);
        return bvh;
    }

private:
    // The length of a file of these counts (each below 2³², so no overflow).
    static std::uint64_t file_bytes(std::uint64_t nodes, std::uint64_t leaves, std::uint64_t primitives) noexcept {
        return header_bytes + nodes * node_bytes + leaves * (leaf_bytes + block_bytes) + primitives * primitive_bytes +
               checksum_bytes;
    }

    // Why the tree and blocks of a decoded Bvh are not a Bvh's, found a piece at a time as decode
    // reads them (nodes first, then the blocks after the leaves and primitives), the first reason
    // kept: every reference inside its arrays, each node and leaf reached exactly once from the
    // root down (children after their parent, so no cycle), no deeper than `depth` and the
    // traversal stack, empty slots with the empty box (which no ray enters, so no walk follows
    // them), the root's bounds as the header's bound, each block holding its leaf's primitives,
    // padded as the build pads.
    class Checker {
    public:
        Checker(const Bvh<T>& bvh, std::size_t nodes, std::size_t leaves, std::uint32_t depth)
            : bvh_(bvh), level_(nodes, 0), reached_(leaves, 0), depth_(depth) {
            if (nodes) level_[0] = 1;
        }

        // Checks node i, after those before it.
        void node(std::size_t i) {
            if (!wrong_.empty()) return;
            const Node& n = bvh_.tree_.nodes_[i];
            const std::size_t nodes = level_.size(), leaves = reached_.size();
            if (!level_[i])
                return set("index out of range: node " + std::to_string(i) + " is not reached from the root");
            deepest_ = std::max<std::uint32_t>(deepest_, level_[i]);
            for (int k = 0; k < 8; ++k) {
                const std::uint32_t c = n.child[k];
                if (c == Tree::empty_child) { // never entered only with the empty box: traversal relies on it
                    if (!empty_box(n, k))
                        return set("node " + std::to_string(i) + " child " + std::to_string(k) +
                                   " is empty, its box not");
                    continue;
                }
                const auto at = [&] { return "node " + std::to_string(i) + " child " + std::to_string(k); };
                if (c & Tree::leaf_bit) {
                    const std::uint32_t leaf = c & ~Tree::leaf_bit;
                    if (leaf >= leaves)
                        return set("index out of range: " + at() + " is leaf " + std::to_string(leaf) + " of " +
                                   std::to_string(leaves));
                    if (reached_[leaf]++) return set(at() + ": leaf " + std::to_string(leaf) + " reached twice");
                } else {
                    if (c <= i || c >= nodes)
                        return set("index out of range: " + at() + " is node " + std::to_string(c) + " (after " +
                                   std::to_string(i) + ", before " + std::to_string(nodes) + ")");
                    if (level_[c]) return set(at() + ": node " + std::to_string(c) + " reached twice");
                    if (level_[i] >= depth_) return set(at() + ": deeper than the depth of " + std::to_string(depth_));
                    level_[c] = std::uint8_t(level_[i] + 1);
                }
            }
        }

        // Checks leaf l and its block, after every node, leaf and primitive is read.
        void block(std::size_t l) {
            if (!wrong_.empty()) return;
            const Tree& tree = bvh_.tree_;
            const std::size_t primitives = tree.primitives_.size();
            if (!reached_[l])
                return set("index out of range: leaf " + std::to_string(l) + " is not reached from the root");
            const Leaf& leaf = tree.leaves_[l];
            if (leaf.count < 1 || leaf.count > 8 || leaf.first > primitives || primitives - leaf.first < leaf.count)
                return set("index out of range: leaf " + std::to_string(l) + " holds primitives [" +
                           std::to_string(leaf.first) + ", +" + std::to_string(leaf.count) + ") of " +
                           std::to_string(primitives));
            if (!holds(bvh_.blocks_[l], tree.primitives_.data() + leaf.first, leaf.count, primitives - leaf.first))
                return set("block " + std::to_string(l) + " is not its leaf's (its primitives or padding differ)");
        }

        // The first reason found, or the checks that need the whole tree.
        [[nodiscard]] std::string finish() const {
            if (!wrong_.empty() || level_.empty()) return wrong_;
            if (deepest_ != depth_)
                return "depth " + std::to_string(deepest_) + ", its header says " + std::to_string(depth_);
            const Tree& tree = bvh_.tree_;
            const Box<T> root = tree.bounds();
            if (T(std::max(max_abs(root.lo), max_abs(root.hi))) != tree.bound_ && root.lo.x <= root.hi.x)
                return "its bound is not its root's";
            return "";
        }

    private:
        void set(std::string why) { wrong_ = std::move(why); }

        // Whether block b holds the `count` primitives at `own`, pairwise distinct, in its first
        // lanes, and its other lanes repeat lane 0 bit for bit (branch-free: it runs on every block).
        // `own` has `room` ≥ count primitives readable. In lane vectors: GCC keeps the loops over
        // `count` lanes scalar, a lane at a time.
        [[nodiscard]] static bool holds(const Block& b, const std::uint32_t* own, std::uint32_t count,
                                        [[maybe_unused]] std::size_t room) noexcept {
            using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
#if ISIN_VECTOR_EXTENSIONS
            using U = L8<std::uint32_t>;
            using M = L8<std::int32_t>;                                                       // a lane mask of U
            using WideM = L8<std::conditional_t<sizeof(T) == 4, std::int32_t, std::int64_t>>; // of Bits
            const M index = {0, 1, 2, 3, 4, 5, 6, 7};
            const M live = index < std::int32_t(count);
            U p, o = {};
            std::memcpy(&p, b.primitive, sizeof p);
            if (room >= 8)
                std::memcpy(&o, own, sizeof o);
            else
                std::memcpy(&o, own, count * sizeof *own);
            M bad = ((p != o) & live) | ((p != p[0]) & ~live); // its leaf's primitives, then lane 0's
            // Pairwise distinct: each lane against the lanes 1…4 after it (mod 8) covers every pair.
            U q;
            M l;
            rotate<1>(p, q), rotate<1>(live, l), bad |= (p == q) & live & l;
            rotate<2>(p, q), rotate<2>(live, l), bad |= (p == q) & live & l;
            rotate<3>(p, q), rotate<3>(live, l), bad |= (p == q) & live & l;
            rotate<4>(p, q), rotate<4>(live, l), bad |= (p == q) & live & l;
            const WideM pad = __builtin_convertvector(~live, WideM);
            WideM wrong = {};
            for (int r = 0; r < 9; ++r) { // the padding repeats lane 0 bit for bit
                L8<Bits> x;
                std::memcpy(&x, b.v[r / 3][r % 3], sizeof x);
                wrong |= (x != x[0]) & pad;
            }
            return !any_lane(bad | __builtin_convertvector(wrong, M));
#else
            // Masks of lanes: those before the padding, and those whose primitive is lane 0's.
            const unsigned live = (1u << count) - 1u;
            unsigned first = 0, wrong = 0;
            for (std::uint32_t k = 0; k < 8; ++k) first |= unsigned(b.primitive[k] == b.primitive[0]) << k;
            wrong |= unsigned((first & live) != 1u) | unsigned((first | live) != 0xffu);
            for (std::uint32_t k = 0; k < count; ++k) wrong |= unsigned(b.primitive[k] != own[k]);
            for (std::uint32_t k = 2; k < count; ++k)
                for (std::uint32_t j = 1; j < k; ++j) wrong |= unsigned(b.primitive[j] == b.primitive[k]);
            const auto bits = [&b](int r, std::uint32_t k) {
                Bits x;
                std::memcpy(&x, &b.v[r / 3][r % 3][k], sizeof x);
                return x;
            };
            for (std::uint32_t k = count; k < 8; ++k)
                for (int r = 0; r < 9; ++r) wrong |= unsigned(bits(r, k) != bits(r, 0));
            return wrong == 0;
#endif
        }
#if ISIN_VECTOR_EXTENSIONS
        // out = v with lane k taken from lane (k + r) mod 8 (by reference: vectors never cross a
        // function boundary by value, whose ABI depends on the target).
        template <int r, class V>
        static void rotate(const V& v, V& out) noexcept {
#if defined(__clang__)
            out = __builtin_shufflevector(v, v, r % 8, (r + 1) % 8, (r + 2) % 8, (r + 3) % 8, (r + 4) % 8, (r + 5) % 8,
                                          (r + 6) % 8, (r + 7) % 8);
#else
            using I = L8<std::int32_t>;
            out = __builtin_shuffle(
                v, I{r % 8, (r + 1) % 8, (r + 2) % 8, (r + 3) % 8, (r + 4) % 8, (r + 5) % 8, (r + 6) % 8, (r + 7) % 8});
#endif
        }
        // Whether any lane of a mask vector is set.
        template <class V>
        [[nodiscard]] static bool any_lane(const V& v) noexcept {
            std::uint64_t w[sizeof(V) / 8], all = 0;
            std::memcpy(w, &v, sizeof w);
            for (const std::uint64_t x : w) all |= x;
            return all != 0;
        }
#endif

        const Bvh<T>& bvh_;
        std::vector<std::uint8_t> level_, reached_;
        std::uint32_t depth_, deepest_ = 0;
        std::string wrong_;
    };

    // Whether child slot k of n has the empty box the build gives an empty slot (lo = +∞, hi = −∞).
    [[nodiscard]] static bool empty_box(const Node& n, int k) noexcept {
        constexpr T inf = std::numeric_limits<T>::infinity();
        bool empty = true;
        for (int a = 0; a < 3; ++a) empty &= n.lo[a][k] == inf && n.hi[a][k] == -inf;
        return empty;
    }

    [[nodiscard]] static std::string precision_name(std::uint32_t bytes) {
        return bytes == 4 ? "float" : bytes == 8 ? "double" : std::to_string(bytes) + "-byte reals";
    }

    static void put32(unsigned char* p, std::uint32_t v) noexcept {
        for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
    }
    static void put64(unsigned char* p, std::uint64_t v) noexcept {
        for (int i = 0; i < 8; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
    }
    static void put_double(unsigned char* p, double x) noexcept {
        std::uint64_t v;
        std::memcpy(&v, &x, 8);
        put64(p, v);
    }
    [[nodiscard]] static std::uint32_t get32(const unsigned char* p) noexcept {
        std::uint32_t v = 0;
        for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
        return v;
    }
    [[nodiscard]] static std::uint64_t get64(const unsigned char* p) noexcept {
        std::uint64_t v = 0;
        for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
        return v;
    }
    [[nodiscard]] static double get_double(const unsigned char* p) noexcept {
        const std::uint64_t v = get64(p);
        double x;
        std::memcpy(&x, &v, 8);
        return x;
    }
    // A record: `reals` values of T, then 8 uint32 (Node, Block), little-endian.
    static void swap_record(void* record, std::size_t reals) noexcept {
        auto* b = static_cast<unsigned char*>(record);
        swap_words(b, reals, sizeof(T));
        swap_words(b + reals * sizeof(T), 8, 4);
    }
    static unsigned char* put_record(unsigned char* p, const void* record, std::size_t bytes, std::size_t reals) {
        std::memcpy(p, record, bytes);
        if (!host_little_endian()) swap_record(p, reals);
        return p + bytes;
    }
    static void get_record(void* record, const unsigned char* p, std::size_t bytes, std::size_t reals) noexcept {
        std::memcpy(record, p, bytes);
        if (!host_little_endian()) swap_record(record, reals);
    }
    // Arrays of uint32 (leaves, primitives; swapped here, and by decode after the sum).
    static unsigned char* put_array(unsigned char* p, const void* array, std::size_t bytes) {
        if (bytes) std::memcpy(p, array, bytes);
        if (!host_little_endian()) swap_words(p, bytes / 4, 4);
        return p + bytes;
    }
};

} // namespace detail

template <class T>
void Bvh<T>::save(const std::string& path) const {
    const std::vector<unsigned char> bytes = detail::BvhFile<T>::encode(*this);
    const std::string why = detail::write_file_atomically(path, bytes);
    if (!why.empty()) throw BvhFileError("isin Bvh file " + path + ": " + why);
}

template <class T>
Bvh<T> Bvh<T>::load(const std::string& path, ReadLimits limits) {
    const auto fail = [&path](const std::string& why) { return BvhFileError("isin Bvh file " + path + ": " + why); };
#if ISIN_DETAIL_POSIX_FILES
    // As read_whole_file (io/file.hpp): regular files only, the size limit before any read.
    const detail::Descriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
    if (fd.get() < 0) throw fail("cannot open: " + detail::errno_text(errno));
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) throw fail("cannot read: " + detail::errno_text(errno));
    if (S_ISDIR(st.st_mode)) throw fail("is a directory");
    if (!S_ISREG(st.st_mode)) throw fail("is not a regular file (a device, pipe or socket)");
    detail::FileSource source{fd.get(), {}};
    return detail::BvhFile<T>::decode(source, std::uint64_t(st.st_size), path, limits);
#else
    std::vector<unsigned char> bytes;
    const std::string why = detail::read_whole_file(path, bytes, limits);
    if (!why.empty()) throw fail(why);
    detail::MemorySource source{bytes.data(), bytes.size(), {}};
    return detail::BvhFile<T>::decode(source, bytes.size(), path, limits);
#endif
}

template <class T>
Bvh<T> Bvh<T>::load_from_memory(const void* data, std::size_t size, ReadLimits limits) {
    if (!data && size) throw BvhFileError("isin Bvh file (memory): null data of " + std::to_string(size) + " bytes");
    detail::MemorySource source{static_cast<const unsigned char*>(data), size, {}};
    return detail::BvhFile<T>::decode(source, size, "(memory)", limits);
}

} // namespace isin

#if defined(ISIN_IMPLEMENTATION)
// The file that compiles isin's file code compiles these too, for users who include isin.hpp alone.
template void isin::Bvh<float>::save(const std::string&) const;
template isin::Bvh<float> isin::Bvh<float>::load(const std::string&, isin::ReadLimits);
template isin::Bvh<float> isin::Bvh<float>::load_from_memory(const void*, std::size_t, isin::ReadLimits);
template void isin::Bvh<double>::save(const std::string&) const;
template isin::Bvh<double> isin::Bvh<double>::load(const std::string&, isin::ReadLimits);
template isin::Bvh<double> isin::Bvh<double>::load_from_memory(const void*, std::size_t, isin::ReadLimits);
#endif
