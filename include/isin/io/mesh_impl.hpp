#pragma once
/// isin — private: the code of mesh.hpp, compiled where ISIN_IMPLEMENTATION is defined (one
/// translation unit of a program, or CMake's isin::io), for T = float and double.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <new>
#include <unordered_map>
#include <utility>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "../image_io.hpp"
#include "../mesh.hpp"
#include "../model.hpp"
#include "../read_limits.hpp"
#include "../triangle.hpp"
#include "image_impl.hpp"
#include "model_files.hpp"
#include "mtl.hpp"
#include "obj.hpp"
#include "parse.hpp"
#include "ply.hpp"

namespace isin {

namespace detail {

template <class T>
[[nodiscard]] std::vector<Triangle<T>> triangles_of(const Mesh<T>& mesh) {
    std::vector<Triangle<T>> out;
    out.reserve(mesh.size());
    for (std::size_t i = 0; i < mesh.size(); ++i) out.push_back(mesh.triangle(i));
    return out;
}

} // namespace detail

namespace detail {

#if ISIN_HAVE_TINYOBJLOADER

/// An OBJ vertex: its v, vt and vn indices (−1: none), as one key.
struct ObjVertexKey {
    std::int32_t v, vt, vn;
    bool operator==(const ObjVertexKey& o) const noexcept { return v == o.v && vt == o.vt && vn == o.vn; }
};
struct ObjVertexKeyHash {
    std::size_t operator()(const ObjVertexKey& k) const noexcept {
        std::uint64_t h = static_cast<std::uint32_t>(k.v);
        h = h * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint32_t>(k.vt);
        h = h * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint32_t>(k.vn);
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};

/// Builds the meshes of an OBJ: one per part (group or object name with faces), vertices shared
/// within a mesh when their v/vt/vn triples agree, polygons triangulated.
template <class T>
inline void obj_build_meshes(const char* who, const std::string& name, const ObjCollector<T>& c, Model<T>& model) {
    const std::size_t parts = c.part_names.size();
    std::vector<std::size_t> faces_in(parts + 1, 0); // counting sort of faces by part, file order kept
    for (const auto& f : c.faces) ++faces_in[f.part + 1];
    for (std::size_t p = 0; p < parts; ++p) faces_in[p + 1] += faces_in[p];
    std::vector<std::size_t> order(c.faces.size()), first_corner(c.faces.size());
    {
        std::vector<std::size_t> next(faces_in.begin(), faces_in.end() - 1);
        std::size_t at = 0;
        for (std::size_t f = 0; f < c.faces.size(); ++f) {
            first_corner[f] = at;
            at += c.faces[f].corners;
            order[next[c.faces[f].part]++] = f;
        }
    }
    std::size_t meshes = 0;
    for (std::size_t p = 0; p < parts; ++p) meshes += faces_in[p] != faces_in[p + 1] ? std::size_t(1) : std::size_t(0);
    model.meshes.reserve(meshes);
    model.names.reserve(meshes);
    bool any_material = false;
    for (const auto& f : c.faces) any_material = any_material || f.material >= 0;

    // A vertex is a distinct v/vt/vn triple of its part. Most positions come with one vt/vn pair:
    // the first is kept in a table by position, only further pairs go into a hash map.
    constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
    struct FirstUse {
        std::int32_t vt, vn;
        std::uint32_t local; // the part's vertex, or none
    };
    std::vector<FirstUse> first(c.vertices.size(), FirstUse{-1, -1, none});
    std::unordered_map<ObjVertexKey, std::uint32_t, ObjVertexKeyHash> more;
    std::vector<std::uint32_t> local;
    std::vector<FanRun> runs;
    std::uint64_t vertices = 0; // in all meshes
    for (std::size_t p = 0; p < parts; ++p) {
        if (faces_in[p] == faces_in[p + 1]) continue;
        Mesh<T> mesh;
        bool has_uv = false, has_normal = false;
        std::size_t corners = 0;
        for (std::size_t i = faces_in[p]; i < faces_in[p + 1]; ++i)
            for (std::uint32_t k = 0; k < c.faces[order[i]].corners; ++k, ++corners) {
                const auto& corner = c.corners[first_corner[order[i]] + k];
                has_uv = has_uv || corner.vt >= 0;
                has_normal = has_normal || corner.vn >= 0;
            }
        mesh.indices.reserve(corners - 2 * (faces_in[p + 1] - faces_in[p]));
        more.clear();
        runs.clear();
        for (std::size_t i = faces_in[p]; i < faces_in[p + 1]; ++i) {
            const auto& face = c.faces[order[i]];
            local.resize(face.corners);
            for (std::uint32_t k = 0; k < face.corners; ++k) {
                const auto& corner = c.corners[first_corner[order[i]] + k];
                const auto next = static_cast<std::uint32_t>(mesh.positions.size());
                FirstUse& use = first[static_cast<std::size_t>(corner.v)];
                std::uint32_t slot = next;
                if (use.local == none)
                    use = {corner.vt, corner.vn, next};
                else if (use.vt == corner.vt && use.vn == corner.vn)
                    slot = use.local;
                else
                    slot = more.try_emplace({corner.v, corner.vt, corner.vn}, next).first->second;
                if (slot == next) {
                    if (++vertices > c.max_vertices)
                        throw mesh_error(who, name,
                                         "the meshes have more than " + std::to_string(c.max_vertices) +
                                             " vertices (ModelBudget::vertices)");
                    mesh.positions.push_back(c.vertices[static_cast<std::size_t>(corner.v)]);
                    if (has_uv)
                        mesh.uvs.push_back(corner.vt >= 0 ? c.uvs[static_cast<std::size_t>(corner.vt)]
                                                          : std::array<T, 2>{T(0), T(0)});
                    if (has_normal) // a corner without a normal: zero, read as "use the face's normal"
                        mesh.normals.push_back(corner.vn >= 0 ? c.normals[static_cast<std::size_t>(corner.vn)]
                                                              : Vertex<T>{T(0), T(0), T(0)});
                }
                local[k] = slot;
            }
            const std::size_t before = mesh.indices.size();
            obj_add_fan(mesh.indices, runs, local.data(), face.corners);
            if (any_material)
                mesh.material.insert(mesh.material.end(), mesh.indices.size() - before,
                                     static_cast<std::uint32_t>(face.material + 1));
        }
        for (std::size_t i = faces_in[p]; i < faces_in[p + 1]; ++i) // reset the table for the next part
            for (std::uint32_t k = 0; k < c.faces[order[i]].corners; ++k)
                first[static_cast<std::size_t>(c.corners[first_corner[order[i]] + k].v)].local = none;
        retriangulate_fans(mesh.positions, mesh.indices, runs);
        model.meshes.push_back(std::move(mesh));
        model.names.push_back(c.part_names[p]);
    }
}

/// The texture `name` of material `m` (a .mtl's map_Kd, relative to `dir`), read and decoded
/// once whatever its spelling, within the model's budget; its index, or −1 with a warning.
template <class T>
[[nodiscard]] int obj_texture(ModelFiles& files, const std::string& dir, std::string name, const std::string& m,
                              const ModelOptions& options, Model<T>& model, std::vector<std::string>& warnings) {
    std::replace(name.begin(), name.end(), '\\', '/');
    const std::string what = "texture '" + name.substr(0, 200) + "' of material '" + m.substr(0, 80) + "'";
    const ModelFiles::Found found = files.find(dir, name, ModelFileKind::texture, true);
    if (found.id == ModelFiles::none) {
        warnings.push_back(what + ": " + found.why);
        return -1;
    }
    int& index = files.memo(found.id);
    if (index != -1) return index < 0 ? -1 : index; // decoded before, or refused before (−2)
    index = -2;
    const std::string& path = files.path(found.id);
    const std::uint64_t left =
        files.budget.texture_pixels - std::min(files.budget.texture_pixels, files.texture_pixels);
    ReadLimits limits = options.limits;
    const bool budget_bounds = left < limits.max_pixels;
    if (budget_bounds) limits.max_pixels = left;
    try {
        std::string why;
        const auto decode = [&] { // the file's bytes freed once decoded
            std::vector<unsigned char> bytes;
            why = files.read(found.id, bytes);
            return why.empty() ? read_image_from_memory(bytes.data(), bytes.size(), limits, path) : Image(1, 1);
        };
        const Image image = decode();
        if (!why.empty()) {
            warnings.push_back(what + ": '" + path + "': " + why);
            return -1;
        }
        files.texture_pixels += std::uint64_t(image.width()) * std::uint64_t(image.height());
        model.textures.emplace_back(ImageTexture<T>(image, options.textures));
        model.texture_paths.push_back(path);
        index = static_cast<int>(model.textures.size() - 1);
    } catch (const std::bad_alloc&) {
        warnings.push_back(what + ": '" + path + "': out of memory while decoding");
    } catch (const std::exception& e) {
        warnings.push_back(what + ": " + e.what() +
                           (budget_bounds ? " (" + std::to_string(left) + " pixels left of ModelBudget::texture_pixels)"
                                          : std::string()));
    }
    return index < 0 ? -1 : index;
}

template <class T>
[[nodiscard]] Model<T> parse_obj_model(const char* who, const std::string& path, std::string_view text,
                                       const ModelOptions& options, ModelFiles* files) {
    ObjCollector<T> c;
    c.max_parts = options.budget.meshes;
    c.max_vertices = options.budget.vertices;
    const std::size_t slash = path.find_last_of('/');
    obj_collect<T>(who, path, text, c, slash == std::string::npos ? "" : path.substr(0, slash + 1), true, files);
    Model<T> model;
    obj_build_meshes(who, path, c, model);
    Material<T> fallback;
    fallback.color = {T(0.8), T(0.8), T(0.8)};
    model.materials.push_back(fallback);
    model.material_names.emplace_back();
    for (std::size_t i = 0; i < c.materials.size(); ++i) {
        const tobj::material_t& t = c.materials[i];
        Material<T> m = mtl_material<T>(t);
        if (files && options.load_textures && !t.diffuse_texname.empty())
            m.texture = obj_texture(*files, i < c.material_dirs.size() ? c.material_dirs[i] : "", t.diffuse_texname,
                                    t.name, options, model, c.warnings);
        model.materials.push_back(m);
        model.material_names.push_back(t.name);
    }
    model.warnings = std::move(c.warnings);
    return model;
}

#endif // ISIN_HAVE_TINYOBJLOADER

template <class T>
[[nodiscard]] Model<T> parse_ply_model(const char* who, const std::string& path, std::string_view file,
                                       const ModelOptions& options) {
    const PlyHeader h = ply_parse_header(who, path, file);
    if (h.vertex_count > options.budget.vertices)
        throw mesh_error(who, path,
                         std::to_string(h.vertex_count) + " vertices, more than the limit of " +
                             std::to_string(options.budget.vertices) + " (ModelBudget::vertices)");
    Model<T> model;
    model.meshes.push_back(parse_ply_mesh<T>(who, path, file));
    model.names.push_back(std::filesystem::path(path).stem().string());
    std::size_t clamped = 0; // Mesh keeps colours in [0, 1]; float properties may hold anything
    for (Color<T>& color : model.meshes.back().colors) {
        const Color<T> kept = color;
        color = {std::clamp(color.r, T(0), T(1)), std::clamp(color.g, T(0), T(1)), std::clamp(color.b, T(0), T(1))};
        clamped += (kept.r != color.r || kept.g != color.g || kept.b != color.b) ? 1 : 0;
    }
    if (clamped > 0) model.warnings.push_back(std::to_string(clamped) + " vertex colours outside [0, 1] clamped to it");
    Material<T> fallback;
    fallback.color = {T(0.8), T(0.8), T(0.8)};
    model.materials.push_back(fallback);
    model.material_names.emplace_back();
    return model;
}

[[nodiscard]] inline std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& ch : ext)
        if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
    return ext;
}

} // namespace detail

namespace detail {
/// What load_model does once the file is parsed: normals computed where asked for.
template <class T>
void finish_model(Model<T>& model, const ModelOptions& options) {
    if (options.compute_normals)
        for (Mesh<T>& mesh : model.meshes)
            if (mesh.normals.empty()) compute_normals(mesh, static_cast<T>(options.crease_angle_degrees));
}
[[noreturn]] inline void throw_no_tinyobjloader(const char* who, const std::string& name) {
    throw std::runtime_error(std::string(who) + ": '" + name +
                             "': reading OBJ needs tinyobjloader "
                             "(Debian/Ubuntu: install libtinyobjloader-dev); PLY works without it");
}
} // namespace detail

template <class T>
Model<T> load_model(const std::string& path, const ModelOptions& options) {
    static_assert(std::is_floating_point_v<T>, "isin::load_model needs a floating-point type");
    const char* who = "isin::load_model";
    const std::string ext = detail::lower_extension(path);
    if (ext != ".ply" && ext != ".obj")
        throw std::invalid_argument(std::string(who) + ": '" + path + "': unknown extension '" + ext +
                                    "' (use .obj or .ply)");
#if !ISIN_HAVE_TINYOBJLOADER
    if (ext == ".obj") detail::throw_no_tinyobjloader(who, path);
#endif
    try {
        detail::ModelFiles files(path, options.allowed_roots, options.allow_any_file, options.limits, options.budget);
        Model<T> model;
        {
            std::string bytes;
            const std::string why = files.read(0, bytes);
            if (!why.empty()) throw detail::mesh_error(who, path, why);
#if ISIN_HAVE_TINYOBJLOADER
            if (ext == ".obj")
                model = detail::parse_obj_model<T>(who, path, bytes, options, &files);
            else
#endif
                model = detail::parse_ply_model<T>(who, path, bytes, options);
        }
        detail::finish_model(model, options);
        model.files = std::move(files.opened);
        return model;
    } catch (const std::bad_alloc&) {
        throw detail::mesh_error(who, path, "out of memory while reading the model");
    }
}

template <class T>
Model<T> load_model_from_memory(const void* data, std::size_t size, MeshFormat format, const std::string& name,
                                const ModelOptions& options) {
    static_assert(std::is_floating_point_v<T>, "isin::load_model needs a floating-point type");
    const char* who = "isin::load_model";
    const std::string_view bytes(data ? static_cast<const char*>(data) : "", data ? size : 0);
#if !ISIN_HAVE_TINYOBJLOADER
    if (format == MeshFormat::obj) detail::throw_no_tinyobjloader(who, name);
#endif
    try {
        Model<T> model;
#if ISIN_HAVE_TINYOBJLOADER
        if (format == MeshFormat::obj)
            model = detail::parse_obj_model<T>(who, name, bytes, options, nullptr);
        else
#endif
            model = detail::parse_ply_model<T>(who, name, bytes, options);
        detail::finish_model(model, options);
        return model;
    } catch (const std::bad_alloc&) {
        throw detail::mesh_error(who, name, "out of memory while reading the model");
    }
}

/// Triangles of a Wavefront OBJ file (`v` and `f` statements; polygons triangulated, winding kept).
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line; std::runtime_error without tinyobjloader.
template <class T>
std::vector<Triangle<T>> load_obj(const std::string& path, const ReadLimits& limits) {
    const char* who = "isin::load_obj";
    try {
        return detail::parse_obj<T>(who, path, detail::mesh_read_file(who, path, limits));
    } catch (const std::bad_alloc&) {
        throw detail::mesh_error(who, path, "out of memory while reading the mesh");
    }
}

/// Triangles of a PLY file: ascii or binary (either byte order) 1.0, positions from vertex x, y, z
/// (any scalar type), polygons from face vertex_indices (or vertex_index), triangulated with
/// their winding kept.
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line (ASCII) or byte offset (binary).
template <class T>
std::vector<Triangle<T>> load_ply(const std::string& path, const ReadLimits& limits) {
    const char* who = "isin::load_ply";
    try {
        Mesh<T> mesh;
        {
            const std::string bytes = detail::mesh_read_file(who, path, limits); // freed before the triangles are made
            mesh = detail::parse_ply_mesh<T>(who, path, bytes);
        }
        return detail::triangles_of(mesh);
    } catch (const std::bad_alloc&) {
        throw detail::mesh_error(who, path, "out of memory while reading the mesh");
    }
}

/// Triangles of OBJ or PLY data in memory (`size` bytes at `data`), as load_obj / load_ply read
/// a file: for meshes that arrive over a network or from an archive, with no temporary file.
/// Errors are MeshError naming `name` in place of a file.
template <class T>
std::vector<Triangle<T>> load_mesh_from_memory(const void* data, std::size_t size, MeshFormat format,
                                               const std::string& name) {
    const std::string_view bytes(data ? static_cast<const char*>(data) : "", data ? size : 0);
    const char* who = format == MeshFormat::obj ? "isin::load_obj" : "isin::load_ply";
    try {
        return format == MeshFormat::obj ? detail::parse_obj<T>(who, name, bytes)
                                         : detail::triangles_of(detail::parse_ply_mesh<T>(who, name, bytes));
    } catch (const std::bad_alloc&) {
        throw detail::mesh_error(who, name, "out of memory while reading the mesh");
    }
}

/// Triangles of an OBJ or PLY file, chosen by the extension (.obj, .ply, any letter case).
/// Throws std::invalid_argument naming the path for any other extension, else as load_obj/ply.
template <class T>
std::vector<Triangle<T>> load_mesh(const std::string& path, const ReadLimits& limits) {
    const std::string ext = detail::lower_extension(path);
    if (ext == ".obj") return load_obj<T>(path, limits);
    if (ext == ".ply") return load_ply<T>(path, limits);
    throw std::invalid_argument("isin::load_mesh: '" + path + "': unknown extension '" + ext + "' (use .obj or .ply)");
}

#define ISIN_DETAIL_MESH_IO(T)                                                                                         \
    template std::vector<Triangle<T>> load_obj<T>(const std::string&, const ReadLimits&);                              \
    template std::vector<Triangle<T>> load_ply<T>(const std::string&, const ReadLimits&);                              \
    template std::vector<Triangle<T>> load_mesh_from_memory<T>(const void*, std::size_t, MeshFormat,                   \
                                                               const std::string&);                                    \
    template std::vector<Triangle<T>> load_mesh<T>(const std::string&, const ReadLimits&);                             \
    template Model<T> load_model<T>(const std::string&, const ModelOptions&);                                          \
    template Model<T> load_model_from_memory<T>(const void*, std::size_t, MeshFormat, const std::string&,              \
                                                const ModelOptions&);
ISIN_DETAIL_MESH_IO(float)
ISIN_DETAIL_MESH_IO(double)
#undef ISIN_DETAIL_MESH_IO

} // namespace isin
