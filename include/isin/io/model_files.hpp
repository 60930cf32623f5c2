#pragma once
/// isin — private: the files a model names (.mtl files, textures), found and read through one
/// class. A name is looked up by its lexically normal path, then by the file's identity (device
/// and inode), so that every file is read once whatever its spelling; it is confined to the
/// allowed directories, compared as canonical paths (a symbolic link that leaves them counts as
/// leaving); every file read is recorded, in order.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "../read_limits.hpp"
#include "file.hpp"

namespace isin::detail {

/// What a model's file is read as; one file is read as one kind only.
enum class ModelFileKind : unsigned char { model, material, texture };

/// The files of one model: see the top of this header.
class ModelFiles {
public:
    static constexpr std::size_t none = static_cast<std::size_t>(-1);

    /// A file a model names: its id (one for every spelling of the file), or why it is refused.
    struct Found {
        std::size_t id = none;
        std::string why;
    };

    /// `model` is the model's file (id 0); files under its directory may be read, and under
    /// `roots`; with `anywhere`, any file.
    ModelFiles(const std::string& model, const std::vector<std::string>& roots, bool anywhere,
               const ReadLimits& file_limits, const ModelBudget& model_budget)
        : limits(file_limits), budget(model_budget), anywhere_(anywhere) {
        namespace fs = std::filesystem;
        std::error_code ec;
        fs::path dir = fs::absolute(fs::path(model), ec).parent_path();
        if (!ec) add_root(dir);
        for (const std::string& root : roots) add_root(root);
        paths_.push_back(model);
        kinds_.push_back(ModelFileKind::model);
        memo_.push_back(-1);
        const std::string key = identity(fs::path(model));
        if (!key.empty()) by_identity_.emplace(key, 0);
    }

    ReadLimits limits;                ///< for each file
    ModelBudget budget;               ///< for the whole model
    std::uint64_t mtl_bytes = 0;      ///< of ModelBudget::mtl_bytes, used
    std::uint64_t texture_pixels = 0; ///< of ModelBudget::texture_pixels, used
    std::vector<std::string> opened;  ///< every file read, in order

    /// The path file `id` is read from.
    [[nodiscard]] const std::string& path(std::size_t id) const { return paths_[id]; }
    /// The caller's note on file `id` (−1 until set): a texture's index, whether a .mtl was read.
    [[nodiscard]] int& memo(std::size_t id) { return memo_[id]; }

    /// Finds `name` as a model's file names it (relative to `dir`, or absolute) to be read as
    /// `kind`; `any_case`: a missing file may be found by its name in any letter case (files
    /// made on Windows).
    [[nodiscard]] Found find(const std::string& dir, const std::string& name, ModelFileKind kind, bool any_case) {
        namespace fs = std::filesystem;
        const fs::path lexical = (fs::path(dir) / fs::path(name)).lexically_normal();
        auto known = by_spelling_.find(lexical.string());
        if (known == by_spelling_.end())
            known = by_spelling_.emplace(lexical.string(), resolve(lexical, any_case, kind)).first;
        Found found = known->second;
        if (found.id != none && kinds_[found.id] != kind) {
            static const char* const kind_names[] = {"the model", "a material file", "a texture"};
            found = {none, "is " + std::string(kind_names[static_cast<int>(kinds_[found.id])]) + " already"};
        }
        return found;
    }

    /// Reads file `id` whole into `bytes` (at most `max_bytes`, and limits.max_file_bytes); ""
    /// or why not. The one place a model's files are opened.
    template <class Bytes>
    [[nodiscard]] std::string read(std::size_t id, Bytes& bytes, std::uint64_t max_bytes = ~std::uint64_t(0)) {
        ReadLimits capped = limits;
        if (max_bytes < capped.max_file_bytes) capped.max_file_bytes = max_bytes;
        opened.push_back(paths_[id]);
        return read_whole_file(paths_[id], bytes, capped);
    }

private:
    /// A key for the file `path` names (device and inode where the system has them, else its
    /// canonical path); "" if it cannot be told.
    [[nodiscard]] static std::string identity(const std::filesystem::path& path) {
#if ISIN_DETAIL_POSIX_FILES
        struct stat st {};
        if (::stat(path.c_str(), &st) != 0) return "";
        return std::to_string(static_cast<unsigned long long>(st.st_dev)) + ":" +
               std::to_string(static_cast<unsigned long long>(st.st_ino));
#else
        std::error_code ec;
        const std::filesystem::path c = std::filesystem::canonical(path, ec);
        return ec ? std::string() : c.string();
#endif
    }

    void add_root(const std::filesystem::path& root) {
        std::error_code ec;
        const std::filesystem::path c = std::filesystem::canonical(root, ec);
        if (!ec) roots_.push_back(c);
    }

    /// Whether canonical path `c` lies under an allowed directory.
    [[nodiscard]] bool allowed(const std::filesystem::path& c) const {
        if (anywhere_) return true;
        for (const std::filesystem::path& root : roots_) {
            auto f = c.begin();
            bool inside = true;
            for (auto r = root.begin(); inside && r != root.end(); ++r, ++f) inside = f != c.end() && *f == *r;
            if (inside) return true;
        }
        return false;
    }

    [[nodiscard]] Found resolve(const std::filesystem::path& lexical, bool any_case, ModelFileKind kind) {
        namespace fs = std::filesystem;
        std::error_code ec;
        fs::path c = fs::weakly_canonical(lexical, ec); // symbolic links resolved as far as the path exists
        if (ec) return {none, "cannot be resolved: " + ec.message()};
        const char* const outside = "is outside the directories the model may read (ModelOptions::allowed_roots)";
        if (!allowed(c)) return {none, outside};
        if (!fs::exists(c, ec) && any_case) {
            c = any_case_match(c);
            if (c.empty()) return {none, "not found"};
            c = fs::canonical(c, ec);
            if (ec) return {none, "cannot be resolved: " + ec.message()};
            if (!allowed(c)) return {none, outside};
        }
        const std::string key = identity(c);
        if (key.empty()) return {none, "not found"};
        const auto [at, added] = by_identity_.emplace(key, paths_.size());
        if (added) {
            paths_.push_back(c.string());
            kinds_.push_back(kind);
            memo_.push_back(-1);
        }
        return {at->second, ""};
    }

    /// A file in `c`'s directory whose name matches c's in any letter case, or "".
    [[nodiscard]] std::filesystem::path any_case_match(const std::filesystem::path& c) {
        const auto lower = [](std::string s) {
            for (char& ch : s)
                if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
            return s;
        };
        const std::filesystem::path dir = c.parent_path();
        auto listing = listings_.find(dir.string());
        if (listing == listings_.end()) { // each directory listed once, its first 100000 entries
            listing = listings_.emplace(dir.string(), std::unordered_map<std::string, std::string>()).first;
            std::error_code ec;
            std::filesystem::directory_iterator it(dir, ec), end;
            for (int seen = 0; !ec && it != end && seen < 100000; it.increment(ec), ++seen) {
                const std::string file = it->path().filename().string();
                listing->second.emplace(lower(file), file);
            }
        }
        const auto match = listing->second.find(lower(c.filename().string()));
        return match == listing->second.end() ? std::filesystem::path() : dir / match->second;
    }

    bool anywhere_;
    std::vector<std::filesystem::path> roots_;
    std::vector<std::string> paths_;
    std::vector<ModelFileKind> kinds_;
    std::vector<int> memo_;
    std::unordered_map<std::string, std::size_t> by_identity_;
    std::unordered_map<std::string, Found> by_spelling_;
    std::unordered_map<std::string, std::unordered_map<std::string, std::string>> listings_;
};

} // namespace isin::detail
