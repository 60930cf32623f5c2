#pragma once
/// isin — private: checks of PNG and JPEG data before stb decodes it. Debian 12's stb_image 2.27
/// trusts what the files say: a JPEG Huffman table whose code counts sum past 256 writes past its
/// arrays, a scan may use a Huffman or quantisation table the file never defined (stb reads
/// uninitialised memory), truncated entropy-coded data decodes as zeros (a 665-byte JPEG becomes
/// 16384² invented pixels; a code cut by the data's end drives its bit count negative, a shift by
/// 32 or more), its DC arithmetic overflows int, and a PNG header alone decides how much is
/// allocated (a 69-byte PNG asks for 805 MB). These functions walk the file's structure and
/// refuse such files with a reason, and read the size from the header so that the pixel budget
/// is checked before any decoding. They allocate nothing in proportion to the input (PNG: at most one copy of it, see
/// check_png; progressive JPEG: 8 bytes per 8×8 block, see check_jpeg_scans).
#include <algorithm>
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "../read_limits.hpp"

namespace isin::detail {

/// Width and height of a checked image, or the reason it is refused.
struct ImageCheck {
    std::uint32_t width = 0, height = 0;
    std::string why; // "" when the data may be decoded
};

[[nodiscard]] inline std::uint32_t big_endian32(const unsigned char* p) noexcept {
    return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | std::uint32_t(p[3]);
}
[[nodiscard]] inline unsigned big_endian16(const unsigned char* p) noexcept { return unsigned(p[0]) << 8 | p[1]; }

/// "" if a width × height image is within the budget, else why not.
[[nodiscard]] inline std::string pixel_budget(std::uint64_t width, std::uint64_t height, const ReadLimits& limits) {
    if (width == 0 || height == 0)
        return "the image has no pixels (" + std::to_string(width) + "×" + std::to_string(height) + ")";
    if (width * height <= limits.max_pixels) return "";
    return "the image is " + std::to_string(width) + "×" + std::to_string(height) + " = " +
           std::to_string(width * height) + " pixels, more than the limit of " + std::to_string(limits.max_pixels) +
           " (ReadLimits::max_pixels)";
}

[[nodiscard]] inline bool is_png(const unsigned char* p, std::size_t n) noexcept {
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (n < 8) return false;
    for (int i = 0; i < 8; ++i)
        if (p[i] != signature[i]) return false;
    return true;
}

[[nodiscard]] inline bool is_jpeg(const unsigned char* p, std::size_t n) noexcept {
    return n >= 2 && p[0] == 0xff && p[1] == 0xd8;
}

/// Checks a PNG's chunk structure (PNG spec §5): every chunk complete up to IEND, IHDR first
/// (after Apple's CgBI, which stb accepts), the size within the budget, and enough compressed
/// data for that size — deflate expands at most 1032:1, so IDAT bytes × 1032 must reach the
/// image's pixel bytes. When the first IDAT chunks are empty (stb would copy 0 bytes from a null
/// pointer), `fixed` receives the data without them, to be decoded instead.
[[nodiscard]] inline ImageCheck check_png(const unsigned char* p, std::size_t n, const ReadLimits& limits,
                                          std::vector<unsigned char>& fixed) {
    ImageCheck c;
    std::size_t pos = 8;
    bool header = false, data_seen = false, end = false;
    std::uint64_t data_bytes = 0, bits_per_pixel = 1;
    std::vector<std::pair<std::size_t, std::size_t>> empty_leading; // [begin, end) of empty IDATs before data
    while (!end) {
        if (n - pos < 12) {
            c.why = "truncated PNG: chunk at byte " + std::to_string(pos) + " is incomplete (no IEND)";
            return c;
        }
        const std::uint32_t length = big_endian32(p + pos);
        const std::uint32_t type = big_endian32(p + pos + 4);
        if (length > 0x7fffffffu || n - pos - 12 < length) {
            c.why = "truncated PNG: chunk at byte " + std::to_string(pos) + " claims " + std::to_string(length) +
                    " bytes, " + std::to_string(n - pos - 12) + " follow";
            return c;
        }
        const unsigned char* data = p + pos + 8;
        const auto is = [type](const char* name) {
            return type == big_endian32(reinterpret_cast<const unsigned char*>(name));
        };
        if (!header && !is("CgBI")) {
            if (!is("IHDR") || length != 13) {
                c.why = "malformed PNG: the first chunk is not a 13-byte IHDR";
                return c;
            }
            header = true;
            c.width = big_endian32(data), c.height = big_endian32(data + 4);
            const unsigned depth = data[8], colour = data[9];
            const unsigned channels = colour == 2 ? 3 : colour == 4 ? 2 : colour == 6 ? 4 : 1;
            bits_per_pixel = std::uint64_t(channels) * (depth >= 1 && depth <= 16 ? depth : 1);
            c.why = pixel_budget(c.width, c.height, limits);
            if (!c.why.empty()) return c;
        } else if (is("IDAT")) {
            if (!header) break;
            data_bytes += length;
            if (length == 0 && !data_seen) empty_leading.emplace_back(pos, pos + 12);
            data_seen = data_seen || length > 0;
        } else if (is("IEND")) {
            end = true;
        }
        pos += 12 + std::size_t(length);
    }
    if (!header) {
        c.why = "malformed PNG: no IHDR chunk";
        return c;
    }
    if (!data_seen) {
        c.why = "malformed PNG: no image data (IDAT)";
        return c;
    }
    const std::uint64_t pixel_bytes = (std::uint64_t(c.width) * bits_per_pixel + 7) / 8 * c.height;
    constexpr std::uint64_t deflate_max_ratio = 1032;
    if (pixel_bytes / deflate_max_ratio > data_bytes + 16) {
        c.why = "truncated or corrupt PNG: " + std::to_string(data_bytes) + " bytes of compressed data cannot hold a " +
                std::to_string(c.width) + "×" + std::to_string(c.height) + " image";
        return c;
    }
    if (!empty_leading.empty()) {
        fixed.clear();
        fixed.reserve(n);
        std::size_t from = 0;
        for (const auto& [b, e] : empty_leading) fixed.insert(fixed.end(), p + from, p + b), from = e;
        fixed.insert(fixed.end(), p + from, p + n);
    }
    return c;
}

/// Where the entropy-coded data that starts at `pos` ends: `end` is the first byte of the marker
/// that ends it (T.81 B.1.1.5: FF, fill FFs, a code other than 00), `code` that marker's code,
/// `next` the byte after it; `end == n` when no marker follows.
struct JpegMarkerAt {
    std::size_t end, next;
    unsigned code;
};
[[nodiscard]] inline JpegMarkerAt next_jpeg_marker(const unsigned char* p, std::size_t n, std::size_t pos) noexcept {
    while (pos < n) {
        if (p[pos] != 0xff) {
            ++pos;
            continue;
        }
        std::size_t q = pos + 1;
        while (q < n && p[q] == 0xff) ++q;
        if (q < n && p[q] == 0x00) {
            pos = q + 1;
            continue;
        }
        return {pos, q < n ? q + 1 : n, q < n ? p[q] : 0u};
    }
    return {n, n, 0u};
}

/// Where a scan's entropy-coded data that starts at `pos` ends: the first marker after it other
/// than RSTn (the restart markers lie inside the data).
[[nodiscard]] inline JpegMarkerAt end_of_scan_data(const unsigned char* p, std::size_t n, std::size_t pos) noexcept {
    JpegMarkerAt at = next_jpeg_marker(p, n, pos);
    while (at.end < n && at.code >= 0xd0 && at.code <= 0xd7) at = next_jpeg_marker(p, n, at.next);
    return at;
}

/// A JPEG Huffman table as T.81 F.2.2.3 decodes it: per code length, the first and the last code
/// (-1: none of that length) and where that length's symbols start; `fast` looks up the codes of
/// at most 9 bits by the next 9 bits (length << 8 | symbol, 0 for a longer code).
struct JpegHuffman {
    std::int32_t min_code[17] = {}, max_code[17] = {-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1};
    unsigned first[17] = {};
    unsigned char values[256] = {};
    std::uint16_t fast[512] = {};
};

/// Builds `h` from a DHT table's 16 code counts (summing to at most 256) and its symbols; false
/// when the counts overfill the code space (T.81 C), a table stb refuses as well.
[[nodiscard]] inline bool build_jpeg_huffman(const unsigned char* counts, const unsigned char* symbols,
                                             JpegHuffman& h) noexcept {
    h = JpegHuffman{};
    std::int32_t code = 0;
    unsigned k = 0;
    for (unsigned length = 1; length <= 16; ++length) {
        const unsigned count = counts[length - 1];
        h.min_code[length] = code, h.first[length] = k;
        for (unsigned i = 0; i < count && length <= 9; ++i) {
            const unsigned from = unsigned(code + std::int32_t(i)) << (9 - length), to = from + (1u << (9 - length));
            for (unsigned j = from; j < to && j < 512; ++j) h.fast[j] = std::uint16_t(length << 8 | symbols[k + i]);
        }
        code += std::int32_t(count), k += count;
        if (code > (std::int32_t(1) << length)) return false;
        h.max_code[length] = count ? code - 1 : -1;
        code <<= 1;
    }
    std::copy(symbols, symbols + k, h.values);
    return true;
}

/// The bits of one restart interval of entropy-coded data, [p, end) with FF 00 read as FF: as
/// stb reads them, except that a read past `end` fails where stb would invent zero bits.
struct JpegBits {
    const unsigned char* p;
    const unsigned char* end;
    std::uint64_t buffer = 0; // the next `count` bits, from the top
    unsigned count = 0;

    void fill() noexcept {
        while (count <= 56 && p < end) {
            const unsigned char byte = *p++;
            if (byte == 0xff) { // the FF of FF (FF…) 00
                while (p < end && *p == 0xff) ++p;
                if (p < end) ++p;
            }
            buffer |= std::uint64_t(byte) << (56 - count);
            count += 8;
        }
    }
    /// Takes `n` bits (at most 32) into `v`; false if the data has fewer.
    [[nodiscard]] bool bits(unsigned n, std::uint32_t& v) noexcept {
        v = 0;
        if (n == 0) return true;
        if (count < n) fill();
        if (count < n) return false;
        v = std::uint32_t(buffer >> (64 - n));
        buffer <<= n, count -= n;
        return true;
    }
    /// Skips `n` bits; false if the data has fewer.
    [[nodiscard]] bool skip(unsigned n) noexcept {
        for (std::uint32_t v = 0; n > 0; n -= std::min(n, 32u))
            if (!bits(std::min(n, 32u), v)) return false;
        return true;
    }
    /// The next symbol; -1 for a code the table does not have, -2 past the end.
    [[nodiscard]] int decode(const JpegHuffman& h) noexcept {
        if (count < 16) fill();
        const std::uint32_t next = std::uint32_t(buffer >> 48); // 16 bits, zeros past the data
        unsigned length = h.fast[next >> 7] >> 8;
        int symbol = h.fast[next >> 7] & 0xff;
        if (length == 0) {
            for (length = 10; length <= 16; ++length)
                if (std::int32_t(next >> (16 - length)) <= h.max_code[length]) break;
            if (length > 16) return count < 16 ? -2 : -1;
            symbol = h.values[h.first[length] + unsigned(std::int32_t(next >> (16 - length)) - h.min_code[length])];
        }
        if (length > count) return -2;
        buffer <<= length, count -= length;
        return symbol;
    }
};

/// A frame's component as check_jpeg_scans tracks it.
struct JpegComponent {
    unsigned id = 0, h = 1, v = 1, tq = 0;
    bool dc_scanned = false;
    std::int64_t dc_pred = 0;             // stb's DC prediction, an int
    std::vector<std::bitset<64>> nonzero; // progressive: per block, in zig-zag order
};

/// A scan's component with its Huffman tables.
struct JpegScanComponent {
    JpegComponent* c;
    const JpegHuffman *dc, *ac;
};

/// One scan's entropy-coded data, block by block (check_jpeg_scans). Each step returns 0, or 1 past
/// the end of the data, 2 where stb refuses the data, 3 for a coefficient past stb's int (DC) or
/// short (AC).
struct JpegScanBlocks {
    JpegBits in;
    bool progressive;
    unsigned ss, se, ah, al;
    const std::int64_t* quant_dc; // the DC entry of each quantisation table
    std::uint32_t eob_run = 0;
    std::bitset<64> band{}; // the scan's coefficients, in zig-zag order

    /// One block of the scan's component `c`, at `b` in its block grid.
    [[nodiscard]] int block(const JpegScanComponent& c, std::size_t b) noexcept {
        if (!progressive || ss == 0) return dc_block(c, b); // DC, then (baseline) the AC coefficients
        std::bitset<64>& nz = c.c->nonzero[b];
        if (ah == 0) return first_ac_block(c, nz); // first AC scan of the band
        return refine_ac_block(c, nz);
    }

    /// The DC coefficient, then (baseline) the AC coefficients.
    [[nodiscard]] int dc_block(const JpegScanComponent& c, std::size_t b) noexcept {
        std::uint32_t v = 0;
        if (progressive && ah != 0) return in.bits(1, v) ? 0 : 1; // DC refinement: one bit
        if (progressive) c.c->nonzero[b].reset();
        const int t = in.decode(*c.dc);
        if (t < -1) return 1;
        if (t < 0 || t > 15) return 2;
        if (!in.bits(unsigned(t), v)) return 1;
        const std::int64_t diff =
            t == 0 || v >> (t - 1) ? std::int64_t(v) : std::int64_t(v) - (std::int64_t(1) << t) + 1;
        c.c->dc_pred += diff; // then times the quantiser (baseline) or 2^Al (progressive), in int
        const std::int64_t scaled = c.c->dc_pred * (progressive ? std::int64_t(1) << al : quant_dc[c.c->tq]);
        if (c.c->dc_pred < INT32_MIN || c.c->dc_pred > INT32_MAX || scaled < INT32_MIN || scaled > INT32_MAX) return 3;
        for (unsigned k = 1; !progressive && k < 64;) {
            const int rs = in.decode(*c.ac);
            if (rs < -1) return 1;
            if (rs < 0) return 2;
            if ((rs & 15) == 0) {
                if (rs != 0xf0) break;
                k += 16;
            } else {
                k += unsigned(rs >> 4) + 1;
                if (!in.bits(unsigned(rs & 15), v)) return 1;
            }
        }
        return 0;
    }

    /// A block of the first AC scan of the band.
    [[nodiscard]] int first_ac_block(const JpegScanComponent& c, std::bitset<64>& nz) noexcept {
        std::uint32_t v = 0;
        if (eob_run) return --eob_run, 0;
        unsigned k = ss;
        do {
            const int rs = in.decode(*c.ac);
            if (rs < -1) return 1;
            if (rs < 0) return 2;
            const unsigned r = unsigned(rs) >> 4, bits = unsigned(rs) & 15;
            if (bits == 0) {
                if (r < 15) {
                    if (!in.bits(r, v)) return 1;
                    eob_run = (std::uint32_t(1) << r) + v - 1;
                    break;
                }
                k += 16;
            } else {
                k += r;
                if (!in.bits(bits, v)) return 1;
                const std::uint32_t magnitude = v >> (bits - 1) ? v : (std::uint32_t(1) << bits) - 1 - v;
                if ((magnitude << al) > 32767) return 3; // stb keeps coefficients in 16 bits
                nz.set(std::min(k, 63u));                // stb puts a run past the block on its last coefficient
                ++k;
            }
        } while (k <= se);
        return 0;
    }

    /// A block of a refinement AC scan.
    [[nodiscard]] int refine_ac_block(const JpegScanComponent& c, std::bitset<64>& nz) noexcept {
        std::uint32_t v = 0;
        if (eob_run) { // refinement: a correction bit for each non-zero coefficient of the band
            --eob_run;
            return in.skip(unsigned((nz & band).count())) ? 0 : 1;
        }
        unsigned k = ss;
        do {
            const int rs = in.decode(*c.ac);
            if (rs < -1) return 1;
            if (rs < 0) return 2;
            unsigned r = unsigned(rs) >> 4;
            const unsigned bits = unsigned(rs) & 15;
            if (bits == 0 && r < 15) {
                if (!in.bits(r, v)) return 1;
                eob_run = (std::uint32_t(1) << r) - 1 + v;
                r = 64;
            } else if (bits != 0) {
                if (bits != 1) return 2;
                if (!in.bits(1, v)) return 1;
            }
            while (k <= se) {
                const unsigned z = k++;
                if (nz.test(z)) {
                    if (!in.bits(1, v)) return 1;
                } else if (r == 0) {
                    if (bits) nz.set(z);
                    break;
                } else {
                    --r;
                }
            }
        } while (k <= se);
        return 0;
    }
};

/// The frame and tables of a JPEG as check_jpeg_scans reads them, segment by segment.
struct JpegScanCheck {
    JpegHuffman tables[2][4];
    unsigned restart_interval = 0, width = 0, height = 0, components = 0, h_max = 1, v_max = 1;
    std::int64_t quant_dc[4] = {}; // the DC entry of each quantisation table
    bool progressive = false;
    JpegComponent comp[4];

    /// A DHT, DQT, DRI or SOF segment's body s of `size` bytes: "" or why it is refused.
    [[nodiscard]] std::string segment(unsigned marker, const unsigned char* s, std::size_t size) {
        if (marker == 0xc4) {
            for (std::size_t k = 0; k < size;) {
                std::size_t codes = 0;
                for (int i = 1; i <= 16; ++i) codes += s[k + std::size_t(i)];
                if (!build_jpeg_huffman(s + k + 1, s + k + 17, tables[s[k] >> 4][s[k] & 15]))
                    return "corrupt JPEG: a Huffman table has more codes of some length than fit";
                k += 17 + codes;
            }
        } else if (marker == 0xdb) {
            for (std::size_t k = 0; k < size; k += 1 + (s[k] >> 4 ? 128 : 64))
                quant_dc[s[k] & 15] = s[k] >> 4 ? std::int64_t(big_endian16(s + k + 1)) : s[k + 1];
        } else if (marker == 0xdd) {
            if (size != 2) return "malformed JPEG: bad DRI segment";
            restart_interval = big_endian16(s);
        } else if (marker == 0xc0 || marker == 0xc1 || marker == 0xc2) {
            progressive = marker == 0xc2;
            height = big_endian16(s + 1), width = big_endian16(s + 3), components = s[5];
            for (unsigned i = 0; i < components; ++i) {
                comp[i].id = s[6 + 3 * i], comp[i].h = s[7 + 3 * i] >> 4u, comp[i].v = s[7 + 3 * i] & 15u;
                comp[i].tq = s[8 + 3 * i];
                if (comp[i].h < 1 || comp[i].h > 4 || comp[i].v < 1 || comp[i].v > 4)
                    return "malformed JPEG: bad sampling factors in the frame header";
                h_max = std::max(h_max, comp[i].h), v_max = std::max(v_max, comp[i].v);
            }
        }
        return "";
    }

    /// The scan whose header s is, with its data from p[pos]: "" or why it is refused; pos past the
    /// scan's data.
    [[nodiscard]] std::string scan(const unsigned char* p, std::size_t n, std::size_t& pos, const unsigned char* s) {
        const char* const truncated = "truncated or corrupt JPEG: a scan's data ends inside a block";
        const unsigned count = s[0], ss = s[1 + 2 * count], se = s[2 + 2 * count];
        const unsigned ah = s[3 + 2 * count] >> 4, al = s[3 + 2 * count] & 15u;
        if (count < 1 || count > components) return "malformed JPEG: bad component count in a scan header";
        if (progressive ? (ss > se || se > 63 || ah > 13 || al > 13 || (ss == 0 && se != 0) || (ss != 0 && count != 1))
                        : (ss != 0 || ah != 0 || al != 0))
            return "corrupt JPEG: bad spectral selection or successive approximation in a scan header";
        const unsigned mcu_x = (width + 8 * h_max - 1) / (8 * h_max), mcu_y = (height + 8 * v_max - 1) / (8 * v_max);
        JpegScanComponent sc[4] = {};
        for (unsigned i = 0; i < count; ++i) {
            for (unsigned j = 0; j < components; ++j)
                if (comp[j].id == s[1 + 2 * i]) sc[i].c = &comp[j];
            const unsigned dc = s[2 + 2 * i] >> 4, ac = s[2 + 2 * i] & 15u;
            if (dc > 3 || ac > 3) return "malformed JPEG: bad Huffman table id in a scan header"; // stb's too
            sc[i].dc = &tables[0][dc], sc[i].ac = &tables[1][ac];
            if (progressive && sc[i].c->nonzero.empty())
                sc[i].c->nonzero.resize(std::size_t(mcu_x) * sc[i].c->h * mcu_y * sc[i].c->v);
            if (progressive && ss != 0 && !sc[i].c->dc_scanned)
                return "corrupt JPEG: an AC scan comes before the component's first DC scan";
        }
        // the data: one restart interval after another, each ended by an RSTn marker
        JpegMarkerAt at = next_jpeg_marker(p, n, pos);
        JpegScanBlocks blocks{JpegBits{p + pos, p + at.end}, progressive, ss, se, ah, al, quant_dc};
        for (JpegComponent& c : comp) c.dc_pred = 0;
        for (unsigned k = ss; k <= std::min(se, 63u); ++k) blocks.band.set(k);
        // the MCUs as stb orders them: a lone component's blocks row by row, else interleaved
        const JpegComponent& one = *sc[0].c;
        const std::size_t one_w = ((std::size_t(width) * one.h + h_max - 1) / h_max + 7) / 8;
        const std::size_t one_h = ((std::size_t(height) * one.v + v_max - 1) / v_max + 7) / 8;
        const std::size_t mcus = count == 1 ? one_w * one_h : std::size_t(mcu_x) * mcu_y;
        unsigned todo = restart_interval;
        for (std::size_t m = 0; m < mcus; ++m) {
            for (unsigned i = 0; i < count; ++i) {
                const JpegComponent& c = *sc[i].c;
                const std::size_t grid_w = std::size_t(mcu_x) * c.h;
                const unsigned bw = count == 1 ? 1 : c.h, bh = count == 1 ? 1 : c.v;
                const std::size_t x0 = count == 1 ? m % one_w : m % mcu_x * c.h;
                const std::size_t y0 = count == 1 ? m / one_w : m / mcu_x * c.v;
                for (unsigned y = 0; y < bh; ++y)
                    for (unsigned x = 0; x < bw; ++x)
                        if (const int r = blocks.block(sc[i], (y0 + y) * grid_w + x0 + x))
                            return r == 1   ? truncated
                                   : r == 2 ? "corrupt JPEG: bad Huffman-coded data in a scan"
                                            : "corrupt JPEG: a coefficient out of range";
            }
            if (restart_interval && --todo == 0 && m + 1 < mcus) { // the next interval, after RSTn
                if (at.end == n || at.code < 0xd0 || at.code > 0xd7)
                    return "truncated or corrupt JPEG: a scan has fewer restart intervals than its blocks need";
                const std::size_t from = at.next;
                at = next_jpeg_marker(p, n, from);
                blocks.in = JpegBits{p + from, p + at.end};
                blocks.eob_run = 0, todo = restart_interval;
                for (JpegComponent& k : comp) k.dc_pred = 0;
            }
        }
        if (progressive && ss == 0 && ah == 0)
            for (unsigned i = 0; i < count; ++i) sc[i].c->dc_scanned = true;
        pos = end_of_scan_data(p, n, at.end).end; // past the RSTn markers the scan did not need
        return "";
    }
};

/// Walks the entropy-coded data of every scan of a JPEG that check_jpeg's structural pass has
/// accepted, decoding its Huffman codes (T.81 F.2.2, G.1.2) as stb 2.27 parses them, without the
/// coefficients' values: "" if every restart interval holds all the bits its blocks take, else why
/// not. stb reads zero bits past the data instead of failing, and when a code or a magnitude
/// straddles the marker that ends the data its bit count goes negative (a shift by 32 or more in
/// stbi__grow_buffer_unsafe, undefined behaviour; fixed in stb 2.28); refusing truncated intervals
/// here keeps stb away from that state. For progressive files it keeps which coefficients are
/// non-zero (8 bytes a block, 1/16 of stb's coefficients), since refinement scans read one bit per
/// non-zero coefficient: AC scans must follow the component's first DC scan (before it stb reads
/// memory it never wrote) and coefficients must fit stb's 16 bits. It also refuses DC predictions
/// whose sum, or product with the quantiser (progressive: 2^Al), overflows stb's int (stb 2.28
/// checks both too).
[[nodiscard]] inline std::string check_jpeg_scans(const unsigned char* p, std::size_t n) {
    JpegScanCheck check;
    std::size_t pos = 2;
    for (;;) {
        while (pos < n && p[pos] != 0xff) ++pos;
        while (pos < n && p[pos] == 0xff) ++pos;
        if (pos >= n) return "";
        const unsigned marker = p[pos++];
        if (marker == 0xd9) return "";
        if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd8)) continue;
        const std::size_t length = big_endian16(p + pos); // within the data: check_jpeg's first pass
        const unsigned char* s = p + pos + 2;
        const std::size_t size = length - 2;
        pos += length;
        std::string why = marker == 0xda ? check.scan(p, n, pos, s) : check.segment(marker, s, size);
        if (!why.empty()) return why;
    }
}

/// Checks a JPEG's marker structure (ITU T.81 Annex B) as stb's baseline and progressive decoder
/// will read it: Huffman tables of at most 256 codes, every table a scan (or, progressive, the
/// final dequantisation) uses defined before it, the size within the budget, an EOI marker at the
/// end (truncated data is an error), and at least one bit of entropy-coded data for every 8×8
/// block of the full-resolution component (no block is coded in fewer); then every scan's data
/// must hold all the bits its blocks take (check_jpeg_scans).
[[nodiscard]] inline ImageCheck check_jpeg(const unsigned char* p, std::size_t n, const ReadLimits& limits) {
    ImageCheck c;
    bool quant[4] = {}, huffman[2][4] = {}, frame = false, progressive = false;
    struct Component {
        unsigned id, tq;
    } comp[4] = {};
    unsigned components = 0;
    std::uint64_t entropy_bytes = 0;
    std::size_t pos = 2;
    const auto fail = [&](const std::string& why) {
        c.why = why;
        return c;
    };
    for (;;) {
        while (pos < n && p[pos] != 0xff) ++pos; // stb skips padding between segments
        while (pos < n && p[pos] == 0xff) ++pos; // fill bytes
        if (pos >= n) return fail("truncated JPEG: no EOI marker");
        const unsigned marker = p[pos++];
        if (marker == 0xd9) break;                                          // EOI
        if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd8)) continue; // TEM, RSTn, SOI: no length
        if (n - pos < 2) return fail("truncated JPEG: marker segment at byte " + std::to_string(pos - 2));
        const std::size_t length = big_endian16(p + pos);
        if (length < 2 || n - pos < length)
            return fail("truncated JPEG: marker segment at byte " + std::to_string(pos - 2) + " claims " +
                        std::to_string(length) + " bytes, " + std::to_string(n - pos) + " follow");
        const unsigned char* s = p + pos + 2;
        const std::size_t size = length - 2;
        pos += length;
        if (marker == 0xc4) { // DHT
            for (std::size_t k = 0; k < size;) {
                if (size - k < 17) return fail("malformed JPEG: DHT segment is cut short");
                const unsigned table_class = s[k] >> 4, id = s[k] & 15;
                if (table_class > 1 || id > 3) return fail("malformed JPEG: bad DHT table id");
                std::size_t codes = 0;
                for (int i = 1; i <= 16; ++i) codes += s[k + std::size_t(i)];
                if (codes > 256)
                    return fail("corrupt JPEG: a Huffman table has " + std::to_string(codes) + " codes, more than 256");
                if (size - k - 17 < codes) return fail("malformed JPEG: DHT segment is cut short");
                huffman[table_class][id] = true;
                k += 17 + codes;
            }
        } else if (marker == 0xdb) { // DQT
            for (std::size_t k = 0; k < size;) {
                const unsigned precision = s[k] >> 4, id = s[k] & 15;
                if (precision > 1 || id > 3) return fail("malformed JPEG: bad DQT table id");
                const std::size_t table = precision ? 128 : 64;
                if (size - k - 1 < table) return fail("malformed JPEG: DQT segment is cut short");
                quant[id] = true;
                k += 1 + table;
            }
        } else if (marker == 0xc0 || marker == 0xc1 || marker == 0xc2) { // SOF: baseline, extended, progressive
            if (frame) return fail("malformed JPEG: second frame header");
            if (size < 6) return fail("malformed JPEG: frame header is cut short");
            frame = true;
            progressive = marker == 0xc2;
            c.height = big_endian16(s + 1), c.width = big_endian16(s + 3);
            components = s[5];
            if (components < 1 || components > 4 || size < 6 + 3 * std::size_t(components))
                return fail("malformed JPEG: bad component count in the frame header");
            for (unsigned i = 0; i < components; ++i) {
                comp[i] = {s[6 + 3 * i], s[8 + 3 * i]};
                if (comp[i].tq > 3) return fail("malformed JPEG: bad quantisation table id in the frame header");
            }
            c.why = pixel_budget(c.width, c.height, limits);
            if (!c.why.empty()) return c;
        } else if (marker == 0xda) { // SOS, then entropy-coded data up to the next marker
            if (!frame) return fail("malformed JPEG: scan before the frame header");
            if (size < 1 || size < 4 + 2 * std::size_t(s[0])) return fail("malformed JPEG: scan header is cut short");
            const unsigned count = s[0];
            const unsigned spectral_start = s[1 + 2 * count], approximation_high = s[3 + 2 * count] >> 4;
            for (unsigned i = 0; i < count; ++i) {
                const unsigned id = s[1 + 2 * i], dc = s[2 + 2 * i] >> 4, ac = s[2 + 2 * i] & 15u;
                const Component* k = nullptr;
                for (unsigned j = 0; j < components; ++j)
                    if (comp[j].id == id) k = &comp[j];
                if (!k) return fail("malformed JPEG: scan of a component the frame does not have");
                const bool needs_dc = !progressive || (spectral_start == 0 && approximation_high == 0);
                const bool needs_ac = !progressive || spectral_start != 0;
                if ((needs_dc && (dc > 3 || !huffman[0][dc])) || (needs_ac && (ac > 3 || !huffman[1][ac])))
                    return fail("corrupt JPEG: a scan uses a Huffman table that is not defined");
                if (!progressive && !quant[k->tq])
                    return fail("corrupt JPEG: a scan uses a quantisation table that is not defined");
            }
            const std::size_t start = pos;
            pos = end_of_scan_data(p, n, pos).end;
            entropy_bytes += pos - start;
        } else if (!(marker == 0xdd || marker == 0xdc || (marker >= 0xe0 && marker <= 0xef) || marker == 0xfe)) {
            return fail("unsupported JPEG: marker 0x" +
                        std::string{"0123456789ABCDEF"[marker >> 4], "0123456789ABCDEF"[marker & 15]} +
                        " (lossless, hierarchical and arithmetic-coded JPEG are not read)");
        }
    }
    if (!frame) return fail("malformed JPEG: no frame header");
    if (progressive)
        for (unsigned i = 0; i < components; ++i)
            if (!quant[comp[i].tq]) return fail("corrupt JPEG: a component's quantisation table is not defined");
    const std::uint64_t blocks = (std::uint64_t(c.width) + 7) / 8 * ((std::uint64_t(c.height) + 7) / 8);
    if (entropy_bytes * 8 < blocks)
        return fail("truncated or corrupt JPEG: " + std::to_string(entropy_bytes) +
                    " bytes of image data cannot code the " + std::to_string(blocks) + " blocks of a " +
                    std::to_string(c.width) + "×" + std::to_string(c.height) + " image");
    c.why = check_jpeg_scans(p, n);
    return c;
}

} // namespace isin::detail
