#pragma once
/// isin — triangle meshes from files: Wavefront OBJ and PLY (isin's own readers; tinyobjloader
/// reads the .mtl files of load_model). Declarations only: the code, with tinyobjloader's, is
/// compiled once, in the translation unit
/// that defines ISIN_IMPLEMENTATION before including isin, or in CMake's isin::io library; it is
/// there for T = float and double.
///
/// Usage:
///     std::vector<isin::Triangle<float>> tris = isin::load_mesh<float>("bunny.ply");
///     for (const auto& tri : tris) scene.add(tri, material);
///
/// What is read: vertex positions and polygonal faces only (isin::load_model, model.hpp, reads
/// normals, texture coordinates, colours, groups and materials as well). A convex polygon
/// v0 v1 … vn−1 becomes the fan (v0, vi, vi+1), i = 1 … n−2; any other (concave, or not planar)
/// is cut into n−2 triangles by ear clipping in its plane; either way the winding, and with it the
/// side `normal()` points to, is kept. Lines, points and other PLY elements and properties are
/// ignored. A file without faces is not an error: the result is an empty vector.
///
/// Error policy: a file that cannot be read or is malformed throws isin::MeshError (a
/// std::runtime_error) whose what() names the file and where the problem is: "line N" for OBJ
/// and ASCII PLY, "offset N" (bytes from the start of the file) for binary PLY. Checked: missing
/// or unreadable file, malformed numbers, truncated data, faces with fewer than 3 vertices,
/// vertex indices out of range (OBJ: 1…n, or −1…−k relative to the k vertices read so far;
/// 0 is invalid; positive indices may refer to vertices defined later), NaN or infinite
/// coordinates, coordinates outside the range of T (1e300 into float). Hostile PLY input is
/// safe: counts are checked against the bytes left before anything is reserved, and memory
/// stays proportional to the file size. An unknown extension in load_mesh throws
/// std::invalid_argument; load_obj without tinyobjloader throws std::runtime_error.
///
/// OBJ coordinates are read exactly (std::from_chars: the nearest T of the decimal text), every
/// number's syntax checked ("1,5", "nan" or "abc" are errors, not 0); the exponent and length
/// limits that tinyobjloader's parser needed are kept, so files behave as before.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "read_limits.hpp"
#include "triangle.hpp"

namespace isin {

/// A mesh file that cannot be read or is malformed; what() names the file and the line or byte
/// offset of the problem.
class MeshError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A mesh file format, for the in-memory loader.
enum class MeshFormat { obj, ply };

/// Triangles of a Wavefront OBJ file (`v` and `f` statements; polygons triangulated, winding kept).
/// UTF-16 or binary data is a MeshError saying so.
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line.
template <class T>
[[nodiscard]] std::vector<Triangle<T>> load_obj(const std::string& path, const ReadLimits& limits = {});

/// Triangles of a PLY file: ascii or binary (little- or big-endian) 1.0, positions from vertex x,
/// y, z (any scalar type), polygons from face vertex_indices (or vertex_index), triangulated with
/// their winding kept.
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line (ASCII) or byte offset (binary).
template <class T>
[[nodiscard]] std::vector<Triangle<T>> load_ply(const std::string& path, const ReadLimits& limits = {});

/// Triangles of OBJ or PLY data in memory (`size` bytes at `data`), as load_obj / load_ply read
/// a file: for meshes that arrive over a network or from an archive, with no temporary file.
/// Errors are MeshError naming `name` in place of a file.
template <class T>
[[nodiscard]] std::vector<Triangle<T>> load_mesh_from_memory(const void* data, std::size_t size, MeshFormat format,
                                                             const std::string& name = "memory");

/// Triangles of an OBJ or PLY file, chosen by the extension (.obj, .ply, any letter case).
/// Throws std::invalid_argument naming the path for any other extension, else as load_obj/ply.
template <class T>
[[nodiscard]] std::vector<Triangle<T>> load_mesh(const std::string& path, const ReadLimits& limits = {});

#define ISIN_DETAIL_MESH_IO(T)                                                                                         \
    extern template std::vector<Triangle<T>> load_obj<T>(const std::string&, const ReadLimits&);                       \
    extern template std::vector<Triangle<T>> load_ply<T>(const std::string&, const ReadLimits&);                       \
    extern template std::vector<Triangle<T>> load_mesh_from_memory<T>(const void*, std::size_t, MeshFormat,            \
                                                                      const std::string&);                             \
    extern template std::vector<Triangle<T>> load_mesh<T>(const std::string&, const ReadLimits&);
ISIN_DETAIL_MESH_IO(float)
ISIN_DETAIL_MESH_IO(double)
#undef ISIN_DETAIL_MESH_IO

} // namespace isin
