#pragma once
/// isin — private: whole-file reads and atomic writes, shared by the image and mesh files. Reads
/// take regular files only (never a device, pipe or socket: /dev/zero or a FIFO would grow or
/// hang) up to a size limit; failures come back as text, so that each caller throws its own
/// exception type naming the file.
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "../read_limits.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#define ISIN_DETAIL_POSIX_FILES 1
#else
#define ISIN_DETAIL_POSIX_FILES 0
#endif

namespace isin::detail {

/// The message of an errno value.
[[nodiscard]] inline std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

/// Why a file of `size` bytes is refused under `limits`, or "".
[[nodiscard]] inline std::string file_too_large(std::uintmax_t size, const ReadLimits& limits) {
    if (size <= limits.max_file_bytes) return "";
    return "is " + std::to_string(size) + " bytes, more than the limit of " + std::to_string(limits.max_file_bytes) +
           " (ReadLimits::max_file_bytes)";
}

#if ISIN_DETAIL_POSIX_FILES
/// A file descriptor closed on destruction.
class Descriptor {
public:
    explicit Descriptor(int fd = -1) noexcept : fd_(fd) {}
    Descriptor(const Descriptor&) = delete;
    Descriptor& operator=(const Descriptor&) = delete;
    ~Descriptor() { reset(); }
    [[nodiscard]] int get() const noexcept { return fd_; }
    /// Takes ownership of `fd`, closing the one held before.
    void adopt(int fd) noexcept {
        reset();
        fd_ = fd;
    }
    /// Closes it now; false (errno set) if close failed.
    bool reset() noexcept {
        const int fd = fd_;
        fd_ = -1;
        return fd < 0 || ::close(fd) == 0;
    }

private:
    int fd_;
};
#endif

/// Reads the whole file at `path` into `bytes` (a std::string or std::vector<unsigned char>).
/// Returns "" on success, else why not: "is a directory", "is not a regular file …", "is N bytes,
/// more than the limit …", "cannot open: …", "cannot read: …". Memory never exceeds the limit.
template <class Bytes>
[[nodiscard]] inline std::string read_whole_file(const std::string& path, Bytes& bytes, const ReadLimits& limits) {
    bytes.clear();
#if ISIN_DETAIL_POSIX_FILES
    // O_NONBLOCK: opening a FIFO must not wait for a writer (it is refused just below).
    const Descriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
    if (fd.get() < 0) return "cannot open: " + errno_text(errno);
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) return "cannot read: " + errno_text(errno);
    if (S_ISDIR(st.st_mode)) return "is a directory";
    if (!S_ISREG(st.st_mode)) return "is not a regular file (a device, pipe or socket)";
    std::string why = file_too_large(std::uintmax_t(st.st_size), limits);
    if (!why.empty()) return why;
    bytes.resize(static_cast<std::size_t>(st.st_size));
    std::size_t done = 0;
    for (;;) { // to the end of the file, which may have grown or shrunk since fstat
        if (done < bytes.size()) {
            const ssize_t n = ::read(fd.get(), &bytes[done], bytes.size() - done);
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) return "cannot read: " + errno_text(errno);
            if (n == 0) break;
            done += static_cast<std::size_t>(n);
            continue;
        }
        char more; // the buffer is full: is there more?
        const ssize_t n = ::read(fd.get(), &more, 1);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return "cannot read: " + errno_text(errno);
        if (n == 0) break;
        why = file_too_large(std::uintmax_t(done) + 1, limits);
        if (!why.empty()) return why;
        bytes.resize(static_cast<std::size_t>(
            std::min<std::uintmax_t>(limits.max_file_bytes, std::uintmax_t(done) + 1 + (std::uintmax_t(1) << 16))));
        bytes[done++] = static_cast<typename Bytes::value_type>(more);
    }
    bytes.resize(done);
    return "";
#else
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (!ec && std::filesystem::is_directory(status)) return "is a directory";
    if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        return "is not a regular file (a device, pipe or socket)";
    errno = 0;
    const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!file) return "cannot open: " + errno_text(errno);
    char chunk[1 << 16];
    for (;;) {
        const std::size_t n = std::fread(chunk, 1, sizeof chunk, file.get());
        std::string why = file_too_large(std::uintmax_t(bytes.size()) + n, limits);
        if (!why.empty()) return why;
        bytes.insert(bytes.end(), chunk, chunk + n);
        if (n < sizeof chunk) break;
    }
    if (std::ferror(file.get())) return "cannot read: " + errno_text(errno);
    return "";
#endif
}

[[nodiscard]] inline unsigned long process_id() noexcept {
#if ISIN_DETAIL_POSIX_FILES
    return static_cast<unsigned long>(::getpid());
#else
    return 0;
#endif
}

/// A name for a temporary file next to the target: short (under 40 bytes), so that it fits
/// wherever the target's own name fits; unique within this process and, by the process id,
/// mostly across processes (creation is exclusive anyway).
[[nodiscard]] inline std::string temporary_name() {
    static std::atomic<unsigned long> counter{0};
    return ".isin-" + std::to_string(process_id()) + "-" + std::to_string(counter.fetch_add(1)) + ".tmp";
}

/// Writes `bytes` to `path` atomically: to a temporary file in the same directory, flushed to
/// disk, then renamed onto `path`; on any failure the temporary is removed and an existing file
/// at `path` is left as it was. Returns "" or why not. The temporary's name is short and is used
/// relative to the directory, so every name the file system accepts for `path` works.
[[nodiscard]] inline std::string write_file_atomically(const std::string& path,
                                                       const std::vector<unsigned char>& bytes) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return "is a directory";
    const std::filesystem::path target(path);
    const std::filesystem::path name = target.filename();
    if (name.empty() || name == "." || name == "..") return "is not a file name";
    std::filesystem::path dir = target.parent_path();
    if (dir.empty()) dir = ".";
#if ISIN_DETAIL_POSIX_FILES
#if defined(O_PATH)
    const Descriptor dir_fd(::open(dir.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC));
#else
    const Descriptor dir_fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
#endif
    if (dir_fd.get() < 0) return "cannot open its directory: " + errno_text(errno);
    std::string tmp;
    Descriptor out;
    for (int attempt = 0;; ++attempt) {
        tmp = temporary_name();
        out.adopt(::openat(dir_fd.get(), tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666));
        if (out.get() >= 0) break;
        if (errno != EEXIST || attempt >= 100)
            return "cannot create a temporary file in its directory: " + errno_text(errno);
    }
    const auto fail = [&](const char* what, int err) {
        out.reset();
        ::unlinkat(dir_fd.get(), tmp.c_str(), 0);
        return std::string(what) + errno_text(err);
    };
    for (std::size_t done = 0; done < bytes.size();) {
        const ssize_t n = ::write(out.get(), bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return fail("cannot write: ", n < 0 ? errno : EIO);
        done += static_cast<std::size_t>(n);
    }
    if (::fsync(out.get()) != 0 && errno != EINVAL && errno != EROFS) return fail("cannot write: ", errno);
    if (!out.reset()) return fail("cannot write: ", errno);
    if (::renameat(dir_fd.get(), tmp.c_str(), dir_fd.get(), name.c_str()) != 0)
        return fail("cannot replace it: ", errno);
    return "";
#else
    const std::filesystem::path tmp = dir / temporary_name();
    {
        errno = 0;
        const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(tmp.string().c_str(), "wb"),
                                                                   &std::fclose);
        if (!file) return "cannot create a temporary file in its directory: " + errno_text(errno);
        if ((!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file.get()) != bytes.size()) ||
            std::fflush(file.get()) != 0) {
            std::filesystem::remove(tmp, ec);
            return "cannot write: " + errno_text(errno);
        }
    }
    std::filesystem::rename(tmp, target, ec);
    if (ec) {
        std::error_code ignored;
        std::filesystem::remove(tmp, ignored);
        return "cannot replace it: " + ec.message();
    }
    return "";
#endif
}

} // namespace isin::detail
