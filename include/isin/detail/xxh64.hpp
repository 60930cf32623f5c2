#pragma once
/// isin — private: XXH64 (Yann Collet's xxHash, 64-bit form) fed in pieces, and Xxh64x4, four
/// XXH64 streams over interleaved 32-byte stripes: the checksums of Bvh files
/// (bvh/serialize.hpp, docs/bvh_format.md).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "../simd/lanes.hpp"

namespace isin {
namespace detail {

/// XXH64 (Yann Collet's xxHash, 64-bit form, as its specification defines it), fed in pieces:
/// the checksum of Bvh files. Four independent lanes of 8 bytes make it run at several bytes a
/// cycle, so checking a file costs little beside reading it.
class Xxh64 {
public:
    explicit Xxh64(std::uint64_t seed = 0) noexcept : v_{seed + p1 + p2, seed + p2, seed, seed - p1}, seed_(seed) {}

    /// Adds n bytes at p.
    void update(const unsigned char* p, std::size_t n) noexcept {
        total_ += n;
        if (buffered_ + n < 32) {
            if (n) std::memcpy(buffer_ + buffered_, p, n);
            buffered_ += n;
            return;
        }
        if (buffered_) {
            const std::size_t fill = 32 - buffered_;
            std::memcpy(buffer_ + buffered_, p, fill);
            stripe(buffer_);
            p += fill, n -= fill, buffered_ = 0;
        }
        std::uint64_t v0 = v_[0], v1 = v_[1], v2 = v_[2], v3 = v_[3];
        for (; n >= 32; p += 32, n -= 32) {
            v0 = round(v0, read64(p)), v1 = round(v1, read64(p + 8));
            v2 = round(v2, read64(p + 16)), v3 = round(v3, read64(p + 24));
        }
        v_[0] = v0, v_[1] = v1, v_[2] = v2, v_[3] = v3;
        if (n) std::memcpy(buffer_, p, n);
        buffered_ = n;
    }

    /// The checksum of everything added so far.
    [[nodiscard]] std::uint64_t digest() const noexcept {
        std::uint64_t h;
        if (total_ >= 32) {
            h = rotl(v_[0], 1) + rotl(v_[1], 7) + rotl(v_[2], 12) + rotl(v_[3], 18);
            for (const std::uint64_t v : v_) h = (h ^ round(0, v)) * p1 + p4;
        } else {
            h = seed_ + p5;
        }
        h += total_;
        const unsigned char* p = buffer_;
        std::size_t n = buffered_;
        for (; n >= 8; p += 8, n -= 8) h = rotl(h ^ round(0, read64(p)), 27) * p1 + p4;
        if (n >= 4) h = rotl(h ^ (std::uint64_t(read32(p)) * p1), 23) * p2 + p3, p += 4, n -= 4;
        for (; n; ++p, --n) h = rotl(h ^ (std::uint64_t(*p) * p5), 11) * p1;
        h ^= h >> 33, h *= p2, h ^= h >> 29, h *= p3, h ^= h >> 32;
        return h;
    }

    /// The checksum of n bytes at p.
    [[nodiscard]] static std::uint64_t of(const unsigned char* p, std::size_t n, std::uint64_t seed = 0) noexcept {
        Xxh64 h(seed);
        h.update(p, n);
        return h.digest();
    }

    /// A checksum (seed 0) whose lanes are `v` after `bytes` bytes, a multiple of 32, were added.
    [[nodiscard]] static Xxh64 resumed(const std::uint64_t* v, std::uint64_t bytes) noexcept {
        Xxh64 h;
        for (int i = 0; i < 4; ++i) h.v_[i] = v[i];
        h.total_ = bytes;
        return h;
    }

private:
    friend class Xxh64x4;
    static constexpr std::uint64_t p1 = 0x9E3779B185EBCA87u, p2 = 0xC2B2AE3D27D4EB4Fu, p3 = 0x165667B19E3779F9u,
                                   p4 = 0x85EBCA77C2B2AE63u, p5 = 0x27D4EB2F165667C5u;
    static std::uint64_t rotl(std::uint64_t x, int r) noexcept { return (x << r) | (x >> (64 - r)); }
    static std::uint64_t round(std::uint64_t acc, std::uint64_t lane) noexcept {
        return rotl(acc + lane * p2, 31) * p1; // XXH64: acc = rotl(acc + lane·P2, 31)·P1
    }
    static std::uint64_t read64(const unsigned char* p) noexcept {
        std::uint64_t v = 0;
        if (little_endian()) return std::memcpy(&v, p, 8), v; // one load: byte loops are not always merged
        for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
        return v;
    }
    static bool little_endian() noexcept {
        const std::uint32_t one = 1;
        unsigned char first;
        std::memcpy(&first, &one, 1);
        return first == 1;
    }
    static std::uint32_t read32(const unsigned char* p) noexcept {
        return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
    }
    void stripe(const unsigned char* p) noexcept {
        for (int i = 0; i < 4; ++i) v_[i] = round(v_[i], read64(p + 8 * i));
    }

    std::uint64_t v_[4];
    std::uint64_t seed_;
    std::uint64_t total_ = 0;
    unsigned char buffer_[32] = {};
    std::size_t buffered_ = 0;
};

/// The checksum of Bvh files from version 2: four XXH64 streams over interleaved stripes. The bytes
/// are cut into stripes of 32 (the last may be shorter); stream j (0…3) is XXH64 (seed 0) of
/// stripes j, j + 4, j + 8, …; the checksum is XXH64 (seed 0) of the four streams' checksums as
/// 32 little-endian bytes. One XXH64 stream waits on its chain of multiplies; four independent
/// ones keep a core's multipliers busy (16 lanes), with the same result on every code path.
class Xxh64x4 {
public:
    Xxh64x4() noexcept {
        for (int j = 0; j < 4; ++j) {
            const Xxh64 start;
            for (int i = 0; i < 4; ++i) v_[4 * j + i] = start.v_[i];
        }
    }

    /// Adds n bytes at p.
    void update(const unsigned char* p, std::size_t n) noexcept {
        total_ += n;
        if (buffered_ + n < 128) {
            if (n) std::memcpy(buffer_ + buffered_, p, n);
            buffered_ += n;
            return;
        }
        if (buffered_) {
            const std::size_t fill = 128 - buffered_;
            std::memcpy(buffer_ + buffered_, p, fill);
            rows(v_, buffer_, 1);
            p += fill, n -= fill, buffered_ = 0;
        }
        rows(v_, p, n / 128);
        p += n / 128 * 128, n %= 128;
        if (n) std::memcpy(buffer_, p, n);
        buffered_ = n;
    }

    /// Adds `count` records of `bytes` each at p, calling each(k) once the whole 128-byte rows of
    /// record k are added, so that the caller's work on a record runs beside the multiplies.
    template <class Each>
    void update_each(const unsigned char* p, std::size_t count, std::size_t bytes, Each&& each) {
        const std::size_t n = count * bytes, head = buffered_ ? std::min<std::size_t>(128 - buffered_, n) : 0;
        update(p, head); // completes the buffer, or takes all
        std::size_t at = head;
        for (std::size_t k = 0; k < count; ++k) {
            const std::size_t end = (k + 1) * bytes, full = end >= at + 128 ? (end - at) / 128 : 0;
            rows(v_, p + at, full);
            at += 128 * full;
            each(k);
        }
        total_ += at - head;
        update(p + at, n - at); // less than a row
    }

    /// The checksum of everything added so far.
    [[nodiscard]] std::uint64_t digest() const noexcept {
        const std::uint64_t rows = total_ / 128;
        unsigned char streams[32];
        for (std::size_t j = 0; j < 4; ++j) {
            Xxh64 h = Xxh64::resumed(v_ + 4 * j, 32 * rows);
            const std::size_t from = std::min<std::size_t>(buffered_, 32 * j);
            h.update(buffer_ + from, std::min<std::size_t>(buffered_, 32 * j + 32) - from);
            const std::uint64_t d = h.digest();
            for (std::size_t i = 0; i < 8; ++i) streams[8 * j + i] = static_cast<unsigned char>(d >> (8 * i));
        }
        return Xxh64::of(streams, 32);
    }

    /// The checksum of n bytes at p.
    [[nodiscard]] static std::uint64_t of(const unsigned char* p, std::size_t n) noexcept {
        Xxh64x4 h;
        h.update(p, n);
        return h.digest();
    }

private:
    // `count` rows of 128 bytes: a stripe for each stream, lane i of the 16 taking bytes 8i…8i + 7
    // of a row. GCC keeps 16 scalar lanes in general registers and spills them between records, so
    // with AVX-512 (vpmullq, vprolq) the lanes are four vectors; without it, 64-bit lane multiplies
    // are emulated and slower than scalar ones.
    static void rows(std::uint64_t* v, const unsigned char* p, std::size_t count) noexcept {
#if ISIN_VECTOR_EXTENSIONS && defined(__AVX512DQ__) && defined(__AVX512VL__)
        if (Xxh64::little_endian()) {
            using V = L4<std::uint64_t>;
            V a[4];
            std::memcpy(a, v, sizeof a);
            for (; count; --count, p += 128)
                for (int j = 0; j < 4; ++j) {
                    V x;
                    std::memcpy(&x, p + 32 * j, sizeof x);
                    a[j] += x * Xxh64::p2; // XXH64: acc = rotl(acc + lane·P2, 31)·P1
                    a[j] = ((a[j] << 31) | (a[j] >> 33)) * Xxh64::p1;
                }
            std::memcpy(v, a, sizeof a);
            return;
        }
#endif
        for (; count; --count, p += 128)
            for (int i = 0; i < 16; ++i) v[i] = Xxh64::round(v[i], Xxh64::read64(p + 8 * i));
    }

    std::uint64_t v_[16];
    std::uint64_t total_ = 0;
    unsigned char buffer_[128] = {};
    std::size_t buffered_ = 0;
};

} // namespace detail
} // namespace isin
