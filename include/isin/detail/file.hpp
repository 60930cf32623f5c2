#pragma once
/// isin — reading a whole file, shared by the image and mesh readers; failures come back as text
/// so each caller throws its own exception type naming the file.
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

namespace isin::detail {

/// The message of an errno value.
[[nodiscard]] inline std::string errno_text(int err) {
    return std::error_code(err, std::generic_category()).message();
}

/// Reads the whole file at `path` into `bytes` (a std::string or std::vector<unsigned char>).
/// Returns "" on success, else why not: "is a directory", "cannot open: …", "cannot read: …".
template <class Bytes>
[[nodiscard]] inline std::string read_whole_file(const std::string& path, Bytes& bytes) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return "is a directory";
    errno = 0;
    const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!file) return "cannot open: " + errno_text(errno);
    bytes.clear();
    char chunk[1 << 16];
    for (;;) {
        const std::size_t n = std::fread(chunk, 1, sizeof chunk, file.get());
        bytes.insert(bytes.end(), chunk, chunk + n);
        if (n < sizeof chunk) break;
    }
    if (std::ferror(file.get())) return "cannot read: " + errno_text(errno);
    return "";
}

} // namespace isin::detail
