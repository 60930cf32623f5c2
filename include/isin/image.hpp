#pragma once
/// isin — 8-bit RGB images and their files: PNG (via stb), binary PPM (no dependency), JPEG read.
///
/// Pixel (0,0) is the top-left corner, x grows to the right, y downwards, rows stored top first.
///
/// Error policy:
///  - Every failure throws an exception derived from std::exception; the file functions name the
///    path in the message. Bad sizes and unknown extensions: std::invalid_argument; a pixel
///    outside the image through at(): std::out_of_range; anything to do with files (cannot
///    open, cannot create, unwritable directory, path is a directory, disk full, undecodable or
///    truncated data, stb missing): std::runtime_error.
///  - Writing is atomic: the whole file is encoded in memory, written to a temporary file next
///    to the target ("<path>.tmp-<pid>-<n>"), flushed to disk, then renamed onto the target. If
///    anything fails, the temporary is removed and an existing target is left untouched, so a
///    file at `path` is either the old one or the complete new one, never a partial one.
///    Replacing a file gives it default permissions; a symbolic link at `path` is replaced, not
///    followed.
///  - PNG writing and PNG/JPEG reading need stb (Debian: libstb-dev); without it (ISIN_HAVE_STB
///    is 0) they throw std::runtime_error saying so, while PPM reading and writing still work.
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "color.hpp"
#include "detail/file.hpp"
#include "detail/stb.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#elif defined(_WIN32)
#include <process.h>
#endif

namespace isin {

static_assert(sizeof(Rgb8) == 3, "isin::Image hands its pixels to encoders as packed RGB bytes");

/// A width × height image of 8-bit RGB pixels, row 0 at the top.
class Image {
public:
    /// Largest accepted side, as for the camera: 32768.
    static constexpr int max_side = 1 << 15;

    /// An image filled with `fill`. Throws std::invalid_argument unless both sides are in
    /// [1, max_side]; the message names the bad value.
    Image(int width, int height, Rgb8 fill = {0, 0, 0})
        : width_(checked_side(width, "width")), height_(checked_side(height, "height")),
          pixels_(std::size_t(width_) * std::size_t(height_), fill) {}

    [[nodiscard]] int width() const noexcept { return width_; }
    [[nodiscard]] int height() const noexcept { return height_; }

    /// Pixel (x, y), checked: throws std::out_of_range unless 0 ≤ x < width and 0 ≤ y < height.
    [[nodiscard]] Rgb8& at(int x, int y) { return pixels_[checked_index(x, y)]; }
    [[nodiscard]] const Rgb8& at(int x, int y) const { return pixels_[checked_index(x, y)]; }

    /// Pixel (x, y), unchecked: the caller guarantees 0 ≤ x < width and 0 ≤ y < height.
    [[nodiscard]] Rgb8& operator()(int x, int y) noexcept { return pixels_[index(x, y)]; }
    [[nodiscard]] const Rgb8& operator()(int x, int y) const noexcept { return pixels_[index(x, y)]; }

    /// All width × height pixels, row by row from the top (pixel (x, y) at y·width + x).
    [[nodiscard]] Rgb8* data() noexcept { return pixels_.data(); }
    [[nodiscard]] const Rgb8* data() const noexcept { return pixels_.data(); }
    [[nodiscard]] const std::vector<Rgb8>& pixels() const noexcept { return pixels_; }

private:
    static int checked_side(int side, const char* what) {
        if (side < 1 || side > max_side)
            throw std::invalid_argument(std::string("isin::Image: ") + what + " " +
                                        std::to_string(side) + " is outside [1, " +
                                        std::to_string(max_side) + "]");
        return side;
    }
    [[nodiscard]] std::size_t index(int x, int y) const noexcept {
        return std::size_t(y) * std::size_t(width_) + std::size_t(x);
    }
    [[nodiscard]] std::size_t checked_index(int x, int y) const {
        if (x < 0 || x >= width_ || y < 0 || y >= height_)
            throw std::out_of_range("isin::Image::at: pixel (" + std::to_string(x) + ", " +
                                    std::to_string(y) + ") is outside the " +
                                    std::to_string(width_) + "×" + std::to_string(height_) +
                                    " image");
        return index(x, y);
    }

    int width_, height_;
    std::vector<Rgb8> pixels_;
};

namespace detail {

[[nodiscard]] inline std::runtime_error file_error(const char* who, const std::string& path,
                                                   const std::string& why) {
    return std::runtime_error(std::string(who) + ": '" + path + "': " + why);
}

[[nodiscard]] inline unsigned long process_id() noexcept {
#if defined(__unix__) || defined(__APPLE__)
    return static_cast<unsigned long>(::getpid());
#elif defined(_WIN32)
    return static_cast<unsigned long>(::_getpid());
#else
    return 0;
#endif
}

/// A temporary file that is removed unless committed.
struct TempFile {
    std::string name;
    std::FILE* file = nullptr;
    bool committed = false;

    TempFile() = default;
    TempFile(const TempFile&) = delete;
    TempFile& operator=(const TempFile&) = delete;
    ~TempFile() {
        if (file) std::fclose(file);
        if (!committed && !name.empty()) std::remove(name.c_str());
    }
};

/// Writes `bytes` to `path` atomically (see the error policy at the top of this header).
inline void write_file_atomically(const char* who, const std::string& path,
                                  const std::vector<unsigned char>& bytes) {
    static std::atomic<unsigned long> counter{0};
#if defined(_WIN32)
    const char* mode = "wb";
#else
    const char* mode = "wbx"; // exclusive: never reuse somebody else's file
#endif
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw file_error(who, path, "is a directory");
    TempFile tmp;
    for (int attempt = 0;; ++attempt) {
        const std::string candidate = path + ".tmp-" + std::to_string(process_id()) + "-" +
                                      std::to_string(counter.fetch_add(1));
        errno = 0;
        tmp.file = std::fopen(candidate.c_str(), mode);
        if (tmp.file) {
            tmp.name = candidate;
            break;
        }
        const int err = errno;
        if (err != EEXIST || attempt >= 100)
            throw file_error(who, path, "cannot create the temporary file '" + candidate +
                                            "': " + errno_text(err));
    }
    const auto write_error = [&](int err) {
        return file_error(who, path, "cannot write '" + tmp.name + "': " + errno_text(err));
    };
    if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), tmp.file) != bytes.size())
        throw write_error(errno);
    if (std::fflush(tmp.file) != 0) throw write_error(errno);
#if defined(__unix__) || defined(__APPLE__)
    if (::fsync(::fileno(tmp.file)) != 0 && errno != EINVAL && errno != EROFS) throw write_error(errno);
#endif
    const int closed = std::fclose(tmp.file);
    const int close_errno = errno;
    tmp.file = nullptr;
    if (closed != 0) throw write_error(close_errno);
    std::filesystem::rename(tmp.name, path, ec);
    if (ec) throw file_error(who, path, "cannot replace it: " + ec.message());
    tmp.committed = true;
}

/// The whole file at `path`; throws std::runtime_error naming `path`.
[[nodiscard]] inline std::vector<unsigned char> read_file(const char* who, const std::string& path) {
    std::vector<unsigned char> bytes;
    const std::string why = read_whole_file(path, bytes);
    if (!why.empty()) throw file_error(who, path, why);
    return bytes;
}

/// Binary PPM (P6, maxval 255) of `image`.
[[nodiscard]] inline std::vector<unsigned char> encode_ppm(const Image& image) {
    const std::string header = "P6\n" + std::to_string(image.width()) + " " +
                               std::to_string(image.height()) + "\n255\n";
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
/// to 0…255. Throws std::runtime_error naming `path` on malformed or truncated data.
[[nodiscard]] inline Image decode_ppm(const std::vector<unsigned char>& bytes,
                                      const std::string& path) {
    const char* who = "isin::read_image";
    std::size_t pos = 2; // after "P6"
    const auto is_space = [](unsigned char c) {
        return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
    };
    const auto number = [&](const char* what, long max) -> long {
        for (;;) { // whitespace and comments before the token
            if (pos < bytes.size() && is_space(bytes[pos])) {
                ++pos;
            } else if (pos < bytes.size() && bytes[pos] == '#') {
                while (pos < bytes.size() && bytes[pos] != '\n' && bytes[pos] != '\r') ++pos;
            } else {
                break;
            }
        }
        long value = 0;
        const std::size_t start = pos;
        while (pos < bytes.size() && bytes[pos] >= '0' && bytes[pos] <= '9') {
            value = value * 10 + (bytes[pos] - '0');
            if (value > max)
                throw file_error(who, path, std::string("PPM ") + what + " is larger than " +
                                                std::to_string(max));
            ++pos;
        }
        if (pos == start || value < 1)
            throw file_error(who, path, std::string("malformed PPM header: bad ") + what);
        return value;
    };
    const int w = int(number("width", Image::max_side));
    const int h = int(number("height", Image::max_side));
    const long maxval = number("maxval", 65535);
    if (pos >= bytes.size() || !is_space(bytes[pos]))
        throw file_error(who, path, "malformed PPM header: no whitespace after maxval");
    ++pos;
    const std::size_t sample_size = maxval < 256 ? 1 : 2;
    const std::size_t needed = std::size_t(w) * std::size_t(h) * 3 * sample_size;
    if (bytes.size() - pos < needed)
        throw file_error(who, path, "truncated PPM: " + std::to_string(needed) +
                                        " bytes of pixels expected, " +
                                        std::to_string(bytes.size() - pos) + " found");
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
inline void write_ppm(const Image& image, const std::string& path) {
    detail::write_file_atomically("isin::write_ppm", path, detail::encode_ppm(image));
}

/// Writes `image` as an 8-bit RGB PNG, atomically. Throws std::runtime_error, also when stb is
/// missing or the image is too large for stb's encoder ((3·width + 1)·height ≥ 2^30 bytes).
inline void write_png(const Image& image, const std::string& path) {
    const char* who = "isin::write_png";
#if ISIN_HAVE_STB
    const std::size_t raw = (std::size_t(image.width()) * 3 + 1) * std::size_t(image.height());
    if (raw >= (std::size_t(1) << 30)) // stb's encoder counts bytes in int
        throw detail::file_error(who, path, "image too large for the PNG encoder (" +
                                                std::to_string(image.width()) + "×" +
                                                std::to_string(image.height()) + ")");
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
    const int ok = stbi_write_png_to_func(append, &sink, image.width(), image.height(), 3,
                                          image.data(), image.width() * 3);
    if (!ok || sink.failed) throw detail::file_error(who, path, "PNG encoding failed (out of memory)");
    detail::write_file_atomically(who, path, sink.bytes);
#else
    (void)image;
    throw detail::file_error(who, path, "writing PNG needs the stb headers (Debian/Ubuntu: "
                                        "install libstb-dev); PPM works without them");
#endif
}

/// Writes `image` in the format named by the extension of `path`: ".png" or ".ppm", in any
/// letter case. Throws std::invalid_argument for any other extension, else as write_png/ppm.
inline void write_image(const Image& image, const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (ext == ".png") return write_png(image, path);
    if (ext == ".ppm") return write_ppm(image, path);
    throw std::invalid_argument("isin::write_image: '" + path + "': unknown extension '" + ext +
                                "' (use .png or .ppm)");
}

/// Reads a PNG, JPEG (via stb) or binary PPM (P6, built in) file as 8-bit RGB; the format is
/// told by the content, not the name. Throws std::runtime_error naming `path` and the reason
/// (stb's failure reason for PNG/JPEG).
[[nodiscard]] inline Image read_image(const std::string& path) {
    const char* who = "isin::read_image";
    const std::vector<unsigned char> bytes = detail::read_file(who, path);
    if (bytes.size() >= 2 && bytes[0] == 'P' && bytes[1] == '6') return detail::decode_ppm(bytes, path);
#if ISIN_HAVE_STB
    if (bytes.size() > std::size_t(INT_MAX)) throw detail::file_error(who, path, "file too large");
    int w = 0, h = 0, channels = 0;
    std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
        stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &channels, 3),
        &stbi_image_free);
    if (!pixels) {
        const char* reason = stbi_failure_reason();
        throw detail::file_error(who, path, std::string("cannot decode: ") +
                                                (reason ? reason : "unknown error"));
    }
    if (w < 1 || h < 1 || w > Image::max_side || h > Image::max_side)
        throw detail::file_error(who, path, "image size " + std::to_string(w) + "×" +
                                                std::to_string(h) + " is not supported");
    Image image(w, h);
    Rgb8* out = image.data();
    const stbi_uc* in = pixels.get();
    for (std::size_t i = 0, n = std::size_t(w) * std::size_t(h); i < n; ++i)
        out[i] = Rgb8{in[3 * i], in[3 * i + 1], in[3 * i + 2]};
    return image;
#else
    throw detail::file_error(who, path, "not a binary PPM; reading PNG or JPEG needs the stb "
                                        "headers (Debian/Ubuntu: install libstb-dev)");
#endif
}

} // namespace isin
