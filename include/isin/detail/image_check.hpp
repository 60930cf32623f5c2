#pragma once
/// isin — private: checks of PNG and JPEG data before stb decodes it. Debian 12's stb_image 2.27
/// trusts what the files say: a JPEG Huffman table whose code counts sum past 256 writes past its
/// arrays, a scan may use a Huffman or quantisation table the file never defined (stb reads
/// uninitialised memory), truncated entropy-coded data decodes as zeros (a 665-byte JPEG becomes
/// 16384² invented pixels), and a PNG header alone decides how much is allocated (a 69-byte PNG
/// asks for 805 MB). These functions walk the file's structure and refuse such files with a
/// reason, and read the size from the header so that the pixel budget is checked before any
/// decoding. They allocate nothing in proportion to the input (PNG: at most one copy of it, see
/// check_png).
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

/// Checks a JPEG's marker structure (ITU T.81 Annex B) as stb's baseline and progressive decoder
/// will read it: Huffman tables of at most 256 codes, every table a scan (or, progressive, the
/// final dequantisation) uses defined before it, the size within the budget, an EOI marker at the
/// end (truncated data is an error), and at least one bit of entropy-coded data for every 8×8
/// block of the full-resolution component (no block is coded in fewer).
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
            while (pos < n) {
                if (p[pos] != 0xff) {
                    ++pos;
                    continue;
                }
                std::size_t q = pos + 1;
                while (q < n && p[q] == 0xff) ++q; // FF FF … 00 is a stuffed FF, FF FF … xx the marker xx
                if (q < n && (p[q] == 0x00 || (p[q] >= 0xd0 && p[q] <= 0xd7))) {
                    pos = q + 1;
                    continue;
                }
                break;
            }
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
    return c;
}

} // namespace isin::detail
