#pragma once
/// isin — private: the code of image_io.hpp, compiled where ISIN_IMPLEMENTATION is defined (one
/// translation unit of a program, or CMake's isin::io).
#include <cerrno>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <new>
#include <string>
#include <system_error>
#include <vector>

#include "../image.hpp"
#include "../image_io.hpp"
#include "../read_limits.hpp"
#include "file.hpp"
#include "image_check.hpp"
#include "stb.hpp"

namespace isin {

namespace detail {

[[nodiscard]] inline std::runtime_error file_error(const char* who, const std::string& path, const std::string& why) {
    return std::runtime_error(std::string(who) + ": '" + path + "': " + why);
}

/// Writes `bytes` to `path` atomically (see the error policy at the top of this header).
inline void write_file(const char* who, const std::string& path, const std::vector<unsigned char>& bytes) {
    const std::string why = write_file_atomically(path, bytes);
    if (!why.empty()) throw file_error(who, path, why);
}

/// Binary PPM (P6, maxval 255) of `image`.
[[nodiscard]] inline std::vector<unsigned char> encode_ppm(const Image& image) {
    const std::string header =
        "P6\n" + std::to_string(image.width()) + " " + std::to_string(image.height()) + "\n255\n";
    std::vector<unsigned char> bytes(header.begin(), header.end());
    bytes.reserve(header.size() + image.pixels().size() * 3);
    for (const Rgb8& p : image.pixels()) {
        bytes.push_back(p.r);
        bytes.push_back(p.g);
        bytes.push_back(p.b);
    }
    return bytes;
}

/// Decodes a binary PPM (P6, maxval 1…65535, '#' comments in the header); samples are scaled
/// to 0…255. Throws std::runtime_error naming `name` on malformed or truncated data, or when the
/// size is beyond limits.max_pixels.
[[nodiscard]] inline Image decode_ppm(const unsigned char* bytes, std::size_t size, const std::string& name,
                                      const ReadLimits& limits) {
    const char* who = "isin::read_image";
    const std::string& path = name;
    std::size_t pos = 2; // after "P6"
    const auto is_space = [](unsigned char c) {
        return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
    };
    const auto number = [&](const char* what, long max) -> long {
        for (;;) { // whitespace and comments before the token
            if (pos < size && is_space(bytes[pos])) {
                ++pos;
            } else if (pos < size && bytes[pos] == '#') {
                while (pos < size && bytes[pos] != '\n' && bytes[pos] != '\r') ++pos;
            } else {
                break;
            }
        }
        long value = 0;
        const std::size_t start = pos;
        while (pos < size && bytes[pos] >= '0' && bytes[pos] <= '9') {
            value = value * 10 + (bytes[pos] - '0');
            if (value > max)
                throw file_error(who, path, std::string("PPM ") + what + " is larger than " + std::to_string(max));
            ++pos;
        }
        if (pos == start || value < 1) throw file_error(who, path, std::string("malformed PPM header: bad ") + what);
        return value;
    };
    const int w = int(number("width", Image::max_side));
    const int h = int(number("height", Image::max_side));
    const long maxval = number("maxval", 65535);
    if (pos >= size || !is_space(bytes[pos]))
        throw file_error(who, path, "malformed PPM header: no whitespace after maxval");
    ++pos;
    const std::string why = pixel_budget(std::uint64_t(w), std::uint64_t(h), limits);
    if (!why.empty()) throw file_error(who, path, why);
    const std::size_t sample_size = maxval < 256 ? 1 : 2;
    const std::size_t needed = std::size_t(w) * std::size_t(h) * 3 * sample_size;
    if (size - pos < needed)
        throw file_error(who, path,
                         "truncated PPM: " + std::to_string(needed) + " bytes of pixels expected, " +
                             std::to_string(size - pos) + " found");
    Image image(w, h);
    const auto sample = [&]() -> std::uint8_t {
        long s = bytes[pos++];
        if (sample_size == 2) s = s * 256 + bytes[pos++];
        if (s > maxval) s = maxval;
        return static_cast<std::uint8_t>((s * 255 + maxval / 2) / maxval); // round to nearest
    };
    Rgb8* out = image.data();
    for (std::size_t i = 0, n = std::size_t(w) * std::size_t(h); i < n; ++i) {
        out[i].r = sample();
        out[i].g = sample();
        out[i].b = sample();
    }
    return image;
}

} // namespace detail

/// Writes `image` as a binary PPM (P6, maxval 255), atomically. Throws std::runtime_error.
void write_ppm(const Image& image, const std::string& path) {
    detail::write_file("isin::write_ppm", path, detail::encode_ppm(image));
}

namespace detail {

enum class ImageFormat { png, ppm };

/// The format write_image uses for `path` (by extension, any case); throws std::invalid_argument.
[[nodiscard]] inline ImageFormat output_format(const char* who, const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (ext == ".png") return ImageFormat::png;
    if (ext == ".ppm") return ImageFormat::ppm;
    throw std::invalid_argument(std::string(who) + ": '" + path + "': unknown extension '" + ext +
                                "' (use .png or .ppm)");
}

/// Whether stb's PNG encoder takes a width × height image: it counts bytes in int, so the
/// filtered rows, (3·width + 1)·height bytes, must stay under 2^30.
[[nodiscard]] inline bool png_encodable(int width, int height) noexcept {
    return (std::size_t(width) * 3 + 1) * std::size_t(height) < (std::size_t(1) << 30);
}

[[nodiscard]] inline std::string png_too_large(int width, int height) {
    return "image too large for the PNG encoder (" + std::to_string(width) + "×" + std::to_string(height) +
           ": (3·width + 1)·height must stay under 2^30)";
}

} // namespace detail

/// Writes `image` as an 8-bit RGB PNG, atomically. Throws std::runtime_error, also when stb is
/// missing or the image is too large for stb's encoder (check_image_output tells beforehand).
void write_png(const Image& image, const std::string& path) {
    const char* who = "isin::write_png";
#if ISIN_HAVE_STB
    if (!detail::png_encodable(image.width(), image.height()))
        throw detail::file_error(who, path, detail::png_too_large(image.width(), image.height()));
    struct Sink {
        std::vector<unsigned char> bytes;
        bool failed = false;
    } sink;
    const auto append = [](void* context, void* data, int size) {
        auto* s = static_cast<Sink*>(context);
        if (s->failed || size <= 0) return;
        try {
            const auto* p = static_cast<const unsigned char*>(data);
            s->bytes.insert(s->bytes.end(), p, p + size);
        } catch (...) { // no exception may cross stb's C code
            s->failed = true;
        }
    };
    const int ok =
        stbi_write_png_to_func(append, &sink, image.width(), image.height(), 3, image.data(), image.width() * 3);
    if (!ok || sink.failed) throw detail::file_error(who, path, "PNG encoding failed (out of memory)");
    detail::write_file(who, path, sink.bytes);
#else
    (void)image;
    throw detail::file_error(who, path,
                             "writing PNG needs the stb headers (Debian/Ubuntu: "
                             "install libstb-dev); PPM works without them");
#endif
}

/// Writes `image` in the format named by the extension of `path`: ".png" or ".ppm", in any
/// letter case. Throws std::invalid_argument for any other extension, else as write_png/ppm.
void write_image(const Image& image, const std::string& path) {
    if (detail::output_format("isin::write_image", path) == detail::ImageFormat::png) return write_png(image, path);
    write_ppm(image, path);
}

/// Throws std::invalid_argument if write_image could not write a width × height image to
/// `path` whatever the file system says: an unknown extension, or a PNG too large for the
/// encoder. Call it before long work whose result goes there.
void check_image_output(const std::string& path, int width, int height) {
    const char* who = "isin::check_image_output";
    if (detail::output_format(who, path) == detail::ImageFormat::png && !detail::png_encodable(width, height))
        throw std::invalid_argument(std::string(who) + ": '" + path + "': " + detail::png_too_large(width, height));
}

/// Decodes PNG, JPEG (via stb) or binary PPM (P6, built in) data as 8-bit RGB; the format is
/// told by the content. Safe on hostile data: the structure is checked first (see
/// io/image_check.hpp), the size from the header against limits.max_pixels before any
/// decoding, and truncated data is an error. Throws std::runtime_error naming `name` and the
/// reason (stb's failure reason for PNG/JPEG it refuses).
Image read_image_from_memory(const void* data, std::size_t size, const ReadLimits& limits,
                             const std::string& name) try {
    const char* who = "isin::read_image";
    const auto* bytes = static_cast<const unsigned char*>(data);
    if (!bytes) size = 0;
    if (size >= 2 && bytes[0] == 'P' && bytes[1] == '6') return detail::decode_ppm(bytes, size, name, limits);
    std::vector<unsigned char> fixed; // a PNG without its empty leading IDAT chunks, if it has any
    detail::ImageCheck check;
    if (detail::is_png(bytes, size))
        check = detail::check_png(bytes, size, limits, fixed);
    else if (detail::is_jpeg(bytes, size))
        check = detail::check_jpeg(bytes, size, limits);
    else
        throw detail::file_error(who, name, "not a PNG, JPEG or binary PPM image");
    if (!check.why.empty()) throw detail::file_error(who, name, check.why);
    if (check.width > std::uint32_t(Image::max_side) || check.height > std::uint32_t(Image::max_side))
        throw detail::file_error(who, name,
                                 "image size " + std::to_string(check.width) + "×" + std::to_string(check.height) +
                                     " is not supported (sides up to " + std::to_string(Image::max_side) + ")");
#if ISIN_HAVE_STB
    if (!fixed.empty()) bytes = fixed.data(), size = fixed.size();
    if (size > std::size_t(INT_MAX)) throw detail::file_error(who, name, "data too large for the decoder");
    int w = 0, h = 0, channels = 0;
    std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
        stbi_load_from_memory(bytes, static_cast<int>(size), &w, &h, &channels, 3), &stbi_image_free);
    if (!pixels) {
        const char* reason = stbi_failure_reason();
        throw detail::file_error(who, name, std::string("cannot decode: ") + (reason ? reason : "unknown error"));
    }
    if (std::uint32_t(w) != check.width || std::uint32_t(h) != check.height)
        throw detail::file_error(who, name, "decoded size differs from the header's");
    Image image(w, h);
    Rgb8* out = image.data();
    const stbi_uc* in = pixels.get();
    for (std::size_t i = 0, n = std::size_t(w) * std::size_t(h); i < n; ++i)
        out[i] = Rgb8{in[3 * i], in[3 * i + 1], in[3 * i + 2]};
    return image;
#else
    throw detail::file_error(who, name,
                             "not a binary PPM; reading PNG or JPEG needs the stb "
                             "headers (Debian/Ubuntu: install libstb-dev)");
#endif
} catch (const std::bad_alloc&) { // stb's allocations fail as null, ours as bad_alloc
    throw detail::file_error("isin::read_image", name, "out of memory while decoding");
}

/// Reads a PNG, JPEG or binary PPM file as read_image_from_memory does; only regular files of
/// at most limits.max_file_bytes are read. Throws std::runtime_error naming `path`.
Image read_image(const std::string& path, const ReadLimits& limits) {
    std::vector<unsigned char> bytes;
    std::string why;
    try {
        why = detail::read_whole_file(path, bytes, limits);
    } catch (const std::bad_alloc&) {
        why = "out of memory while reading";
    }
    if (!why.empty()) throw detail::file_error("isin::read_image", path, why);
    return read_image_from_memory(bytes.data(), bytes.size(), limits, path);
}

} // namespace isin
