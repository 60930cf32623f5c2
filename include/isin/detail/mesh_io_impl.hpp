#pragma once
/// isin — private: the code of mesh.hpp, compiled where ISIN_IMPLEMENTATION is defined (one
/// translation unit of a program, or CMake's isin::io), for T = float and double.
#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "../mesh.hpp"
#include "../read_limits.hpp"
#include "../triangle.hpp"
#include "mesh_text.hpp"
#include "obj_impl.hpp"
#include "ply_impl.hpp"

namespace isin {

namespace detail {

template <class T>
[[nodiscard]] std::vector<Triangle<T>> parse_ply(const char* who, const std::string& name, std::string_view file) {
    const Mesh<T> mesh = parse_ply_mesh<T>(who, name, file);
    std::vector<Triangle<T>> out;
    out.reserve(mesh.size());
    for (std::size_t i = 0; i < mesh.size(); ++i) out.push_back(mesh.triangle(i));
    return out;
}

} // namespace detail

/// Triangles of a Wavefront OBJ file (`v` and `f` statements; polygons as fans, winding kept).
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line; std::runtime_error without tinyobjloader.
template <class T>
std::vector<Triangle<T>> load_obj(const std::string& path, const ReadLimits& limits) {
    const char* who = "isin::load_obj";
    return detail::parse_obj<T>(who, path, detail::mesh_read_file(who, path, limits));
}

/// Triangles of a PLY file: ascii or binary_little_endian 1.0, positions from vertex x, y, z
/// (any scalar type), polygons from face vertex_indices (or vertex_index) as fans, winding kept.
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line (ASCII) or byte offset (binary).
template <class T>
std::vector<Triangle<T>> load_ply(const std::string& path, const ReadLimits& limits) {
    const char* who = "isin::load_ply";
    return detail::parse_ply<T>(who, path, detail::mesh_read_file(who, path, limits));
}

/// Triangles of OBJ or PLY data in memory (`size` bytes at `data`), as load_obj / load_ply read
/// a file: for meshes that arrive over a network or from an archive, with no temporary file.
/// Errors are MeshError naming `name` in place of a file.
template <class T>
std::vector<Triangle<T>> load_mesh_from_memory(const void* data, std::size_t size, MeshFormat format,
                                               const std::string& name) {
    const std::string_view bytes(data ? static_cast<const char*>(data) : "", data ? size : 0);
    return format == MeshFormat::obj ? detail::parse_obj<T>("isin::load_obj", name, bytes)
                                     : detail::parse_ply<T>("isin::load_ply", name, bytes);
}

/// Triangles of an OBJ or PLY file, chosen by the extension (.obj, .ply, any letter case).
/// Throws std::invalid_argument naming the path for any other extension, else as load_obj/ply.
template <class T>
std::vector<Triangle<T>> load_mesh(const std::string& path, const ReadLimits& limits) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& ch : ext)
        if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
    if (ext == ".obj") return load_obj<T>(path, limits);
    if (ext == ".ply") return load_ply<T>(path, limits);
    throw std::invalid_argument("isin::load_mesh: '" + path + "': unknown extension '" + ext + "' (use .obj or .ply)");
}

#define ISIN_DETAIL_MESH_IO(T)                                                                                         \
    template std::vector<Triangle<T>> load_obj<T>(const std::string&, const ReadLimits&);                              \
    template std::vector<Triangle<T>> load_ply<T>(const std::string&, const ReadLimits&);                              \
    template std::vector<Triangle<T>> load_mesh_from_memory<T>(const void*, std::size_t, MeshFormat,                   \
                                                               const std::string&);                                    \
    template std::vector<Triangle<T>> load_mesh<T>(const std::string&, const ReadLimits&);
ISIN_DETAIL_MESH_IO(float)
ISIN_DETAIL_MESH_IO(double)
#undef ISIN_DETAIL_MESH_IO

} // namespace isin
