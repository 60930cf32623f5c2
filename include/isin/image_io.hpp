#pragma once
/// isin — image files: PNG (via stb), binary PPM (no dependency), JPEG read. Declarations only:
/// the code, with stb's, is compiled once, in the translation unit that defines
/// ISIN_IMPLEMENTATION before including isin (the stb convention), or in CMake's isin::io
/// library. So an including file pays for no decoder, no <filesystem>.
///
/// Error policy:
///  - Every failure throws an exception derived from std::exception; the file functions name the
///    path in the message. Bad sizes and unknown extensions: std::invalid_argument; a pixel
///    outside the image through at(): std::out_of_range; anything to do with files (cannot
///    open, cannot create, unwritable directory, path is a directory, disk full, undecodable or
///    truncated data, stb missing): std::runtime_error.
///  - Writing is atomic: the whole file is encoded in memory, written to a temporary file in the
///    target's directory (".isin-<pid>-<n>.tmp", short, so any name the file system accepts for
///    the target works), flushed to disk, then renamed onto the target. If anything fails, the
///    temporary is removed and an existing target is left untouched, so a file at `path` is
///    either the old one or the complete new one, never a partial one. Replacing a file gives it
///    default permissions; a symbolic link at `path` is replaced, not followed.
///  - Reading takes regular files only (not devices, pipes or sockets) of at most
///    ReadLimits::max_file_bytes, and images of at most ReadLimits::max_pixels, checked from the
///    header before decoding; PNG and JPEG structure is checked before stb sees the data
///    (io/image_check.hpp), and truncated data is an error.
///  - PNG writing and PNG/JPEG reading need stb (Debian: libstb-dev); without it (ISIN_HAVE_STB
///    is 0) they throw std::runtime_error saying so, while PPM reading and writing still work.
#include <cstddef>
#include <string>

#include "image.hpp"
#include "read_limits.hpp"

namespace isin {

/// Writes `image` as a binary PPM (P6, maxval 255), atomically. Throws std::runtime_error.
void write_ppm(const Image& image, const std::string& path);

/// Writes `image` as an 8-bit RGB PNG, atomically. Throws std::runtime_error, also when the
/// image is too large for stb's encoder (check_image_output tells beforehand).
void write_png(const Image& image, const std::string& path);

/// Writes `image` in the format named by the extension of `path`: ".png" or ".ppm", in any
/// letter case. Throws std::invalid_argument for any other extension, else as write_png/ppm.
void write_image(const Image& image, const std::string& path);

/// Throws std::invalid_argument if write_image could not write a width × height image to
/// `path` whatever the file system says: an unknown extension, or a PNG too large for the
/// encoder. Call it before long work whose result goes there.
void check_image_output(const std::string& path, int width, int height);

/// Decodes PNG, JPEG (via stb) or binary PPM (P6, built in) data as 8-bit RGB; the format is
/// told by the content. Safe on hostile data: the structure is checked first (see
/// io/image_check.hpp), the size from the header against limits.max_pixels before any
/// decoding, and truncated data is an error. Throws std::runtime_error naming `name` and the
/// reason (stb's failure reason for PNG/JPEG it refuses).
[[nodiscard]] Image read_image_from_memory(const void* data, std::size_t size, const ReadLimits& limits = {},
                                           const std::string& name = "memory");

/// Reads a PNG, JPEG or binary PPM file as read_image_from_memory does; only regular files of
/// at most limits.max_file_bytes are read. Throws std::runtime_error naming `path`.
[[nodiscard]] Image read_image(const std::string& path, const ReadLimits& limits = {});

} // namespace isin
