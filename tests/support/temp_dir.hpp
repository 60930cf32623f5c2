#pragma once
// A fresh, empty directory under the system temp directory for tests that write files; it is
// removed with its contents (permissions restored first) when the test ends.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <system_error>

struct TempDir {
    std::filesystem::path path;
    explicit TempDir(const std::string& prefix) {
        static int n = 0;
        std::random_device random;
        const auto stamp = std::to_string(random()) + "-" +
                           std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()) + "-" +
                           std::to_string(n++);
        path = std::filesystem::temp_directory_path() / (prefix + stamp);
        std::filesystem::remove_all(path);
        std::filesystem::create_directories(path);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        std::filesystem::permissions(path, std::filesystem::perms::owner_all, std::filesystem::perm_options::add, ec);
        std::filesystem::remove_all(path, ec);
    }
    /// The path of `name` in this directory.
    [[nodiscard]] std::string operator/(const std::string& name) const { return (path / name).string(); }
    /// Writes `content` to the file `name` in this directory; returns its path.
    std::string put(const std::string& name, const std::string& content) const {
        const std::string file = (path / name).string();
        std::ofstream out(file, std::ios::binary);
        out << content;
        return file;
    }
};
