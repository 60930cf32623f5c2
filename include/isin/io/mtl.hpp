#pragma once
/// isin — private: MTL, the material files of OBJ models. Each .mtl file an OBJ names is read once
/// through ModelFiles, within the model's budget, its numbers checked by isin, then parsed by
/// tinyobjloader (ObjMaterialReader); each material it defines becomes an isin Material
/// (mtl_material; model.hpp gives the mapping).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <istream>
#include <map>
#include <string>
#include <system_error>

#include "../color.hpp"
#include "../shading.hpp"
#include "model_files.hpp"
#include "parse.hpp"
#include "tinyobj.hpp"

namespace isin {

namespace detail {

#if ISIN_HAVE_TINYOBJLOADER

// Internal linkage, as tinyobjloader's types in it (see tinyobj.hpp).
namespace {

/// Reads .mtl files for tinyobjloader through ModelFiles (each file once, confined, within the
/// limits and the model's budget) with isin's number checks; a file that cannot be read or is
/// over the budget is a warning, a malformed one an error. Its materials, their names and
/// directories and its warnings go into `collector` (an ObjCollector, io/obj.hpp).
template <class Collector>
class ObjMaterialReader {
public:
    ObjMaterialReader(std::string dir, ModelFiles& files, Collector& collector)
        : dir_(std::move(dir)), files_(files), c_(collector) {}

    std::string error; // the first malformed .mtl, as a message naming it

    /// Reads the .mtl file `name` (relative to the OBJ's directory) unless it was read before;
    /// true if it is read, now or before.
    bool read(const std::string& name) {
        const ModelFiles::Found found = files_.find(dir_, name, ModelFileKind::material, false);
        if (found.id == ModelFiles::none) {
            c_.warnings.push_back("material file '" + (dir_ + name).substr(0, 200) + "': " + found.why);
            return false;
        }
        int& read_before = files_.memo(found.id);
        if (read_before >= 0) return read_before == 1;
        read_before = 0;
        const std::string& path = files_.path(found.id);
        const std::uint64_t left = files_.budget.mtl_bytes - std::min(files_.budget.mtl_bytes, files_.mtl_bytes);
        std::error_code ec;
        const std::uintmax_t size = std::filesystem::file_size(path, ec);
        if (!ec && size > left) {
            c_.warnings.push_back("material file '" + path + "': " + std::to_string(size) + " bytes, more than the " +
                                  std::to_string(left) + " left of ModelBudget::mtl_bytes; left out");
            return false;
        }
        std::string text;
        const std::string why = files_.read(found.id, text, left);
        if (!why.empty()) {
            c_.warnings.push_back("material file '" + path + "': " + why);
            return false;
        }
        files_.mtl_bytes += text.size();
        // tinyobjloader's number parser must not see what isin refuses in OBJ text (see
        // obj_unsafe_number); other malformed numbers it reads as 0, as assimp does.
        std::string unsafe;
        std::uint64_t newmtl = 0; // materials the file defines, for the budget
        obj_for_each_line(text, [&](std::size_t line, const char* b, const char* e) {
            const char *tb = nullptr, *te = nullptr;
            for (bool first = true; obj_token(b, e, tb, te); first = false) {
                if (first && te - tb == 6 && std::memcmp(tb, "newmtl", 6) == 0) ++newmtl;
                const std::string bad = obj_unsafe_number(tb, te);
                if (!bad.empty()) {
                    unsafe = "line " + std::to_string(line) + ": " + bad;
                    return false;
                }
            }
            return true;
        });
        if (!unsafe.empty()) {
            if (error.empty()) error = "'" + path + "': " + unsafe;
            return false;
        }
        const std::uint64_t max_materials = files_.budget.materials;
        if (newmtl > max_materials - std::min<std::uint64_t>(max_materials, c_.materials.size())) {
            c_.warnings.push_back(
                "material file '" + path + "': " + std::to_string(newmtl) + " materials, more than the " +
                std::to_string(max_materials - std::min<std::uint64_t>(max_materials, c_.materials.size())) +
                " left of ModelBudget::materials; left out");
            return false;
        }
        ObjTextBuf buf(text);
        std::istream in(&buf);
        std::string warn, err;
        std::map<std::string, int> names; // tinyobjloader's map of this file's names (first of a name kept)
        const std::size_t before = c_.materials.size();
        tobj::LoadMtl(&names, &c_.materials, &in, &warn, &err);
        for (std::size_t i = before; i < c_.materials.size(); ++i)
            c_.material_ids.emplace(c_.materials[i].name, static_cast<int>(i));
        const std::size_t slash = path.find_last_of('/');
        c_.material_dirs.resize(c_.materials.size(), slash == std::string::npos ? "" : path.substr(0, slash + 1));
        read_before = 1;
        return true;
    }

private:
    std::string dir_;
    ModelFiles& files_;
    Collector& c_;
};

} // namespace

/// A colour from a .mtl file: non-finite or negative channels read as 0.
template <class T>
[[nodiscard]] inline Color<T> mtl_color(const tobj::real_t* c) noexcept {
    const auto channel = [](tobj::real_t x) {
        const auto v = static_cast<double>(x);
        return std::isfinite(v) && v > 0 ? static_cast<T>(std::min(v, 1e6)) : T(0);
    };
    return {channel(c[0]), channel(c[1]), channel(c[2])};
}

/// isin's material for a .mtl material (see model.hpp for the mapping).
template <class T>
[[nodiscard]] inline Material<T> mtl_material(const tobj::material_t& t) {
    Material<T> m;
    m.color = mtl_color<T>(t.diffuse);
    m.ambient_color = mtl_color<T>(t.ambient);
    m.specular_color = mtl_color<T>(t.specular);
    m.ka = m.kd = m.ks = T(1); // the colours carry the weights
    const auto shininess = static_cast<double>(t.shininess);
    m.shininess = std::isfinite(shininess) && shininess > 0 ? static_cast<T>(std::min(shininess, 1e4)) : T(0);
    const auto dissolve = static_cast<double>(t.dissolve);
    m.transparency = std::isfinite(dissolve) ? T(1) - static_cast<T>(std::clamp(dissolve, 0.0, 1.0)) : T(0);
    const auto ior = static_cast<double>(t.ior);
    m.ior = std::isfinite(ior) && ior > 0 && ior < 100 ? static_cast<T>(ior) : T(1);
    if (t.illum >= 3 && t.illum <= 7) // ray-traced reflection (3–7 in the MTL specification)
        m.reflectivity = std::min(T(1), (m.specular_color.r + m.specular_color.g + m.specular_color.b) / T(3));
    return m;
}

#endif // ISIN_HAVE_TINYOBJLOADER

} // namespace detail

} // namespace isin
