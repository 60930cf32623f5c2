#pragma once
/// isin — models from files as their authors meant them: meshes with normals, texture
/// coordinates and colours, their materials and textures, and the names of their parts.
///
///     isin::Model<float> spider = isin::load_model<float>("spider.obj");   // reads spider.mtl, its JPEGs
///     isin::Scene<float, isin::Triangle> scene;
///     isin::add_model(scene, spider);        // materials, textures, one mesh per group
///     scene.add_light({{0, 100, -100}});
///     scene.commit();                        // optional: else the first trace builds the Bvh over the groups
///     const auto cam = isin::Camera<float>::look_at(800, 450, {0, 40, -120}, {0, 0, 0}, {0, 1, 0}, 50.0f);
///     isin::write_image(isin::render(scene, cam), "spider.png"); // render.hpp, image_io.hpp
///
/// What is read:
///  - OBJ (isin's reader; the .mtl files through tinyobjloader): v, vt, vn, f (polygons of any size), g and o (each name a
///    mesh; the same name again adds to that mesh), usemtl, mtllib. Every distinct v/vt/vn
///    triple of a mesh is one vertex. The .mtl files (paths relative to the OBJ) give each
///    material: Kd → color, Ka → ambient_color, Ks → specular_color, Ns → shininess, d or Tr →
///    transparency, Ni → ior, illum 3–7 → reflectivity (the mean of Ks), map_Kd → an image
///    texture (path relative to the .mtl, '\' read as '/', options such as -s skipped; the
///    texture's colours replace Kd, as in §10). Weights: ka = kd = ks = 1, the colours carry them.
///  - PLY (isin's reader): positions, normals (nx ny nz), texture coordinates (s t, u v,
///    texture_u texture_v), colours (red green blue); ascii and binary in either byte order.
///  - Polygons are triangulated correctly (convex as fans, others by ear clipping in their plane).
/// A file's faces without a material use materials[0], a plain grey. A .mtl file or texture that
/// cannot be read is not an error: the model loads without it and `warnings` says so.
///
/// Files from strangers (docs/robustness.md): the .mtl files and textures a model names are read
/// only under its own directory (and ModelOptions::allowed_roots, or anywhere with
/// allow_any_file; symbolic links count where they point), each once whatever its spelling;
/// `files` lists them. ModelOptions::budget bounds the whole model.
///
/// Errors: as load_mesh (MeshError naming the file and line or offset; std::invalid_argument for
/// an unknown extension); an OBJ that is UTF-16 or binary is a MeshError saying so. A malformed
/// .mtl is a MeshError naming the .mtl. Declarations only: the code is in isin::io (or the
/// translation unit defining ISIN_IMPLEMENTATION), for T = float and double.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "indexed_mesh.hpp"
#include "mesh.hpp"
#include "bvh/tree.hpp"
#include "read_limits.hpp"
#include "shading.hpp"
#include "texture.hpp"

namespace isin {

/// Options of load_model.
struct ModelOptions {
    ReadLimits limits;                              ///< for the model, its .mtl files and textures
    ColorEncoding textures = ColorEncoding::linear; ///< how texture bytes map to intensities
    bool load_textures = true;                      ///< false: materials keep no textures
    bool compute_normals = false;                   ///< meshes without normals get computed ones
    double crease_angle_degrees = 60;               ///< for compute_normals (see isin::compute_normals)
    ModelBudget budget;                             ///< totals across the model and the files it names
    std::vector<std::string> allowed_roots;         ///< directories besides the model's own whose files it may read
    bool allow_any_file = false;                    ///< true: the model may name any file the process can read
};

/// A model from a file: see the top of this header.
template <class T>
struct Model {
    std::vector<Mesh<T>> meshes;             ///< one per OBJ group/object (file order), one for a PLY
    std::vector<std::string> names;          ///< each mesh's group/object name ("" for none)
    std::vector<Material<T>> materials;      ///< Mesh::material ids index these; [0] is the default
    std::vector<std::string> material_names; ///< as the .mtl names them; [0] is ""
    std::vector<Texture<T>> textures;        ///< Material::texture indexes these
    std::vector<std::string> texture_paths;  ///< the file each texture was read from
    std::vector<std::string> warnings;       ///< what was left out, and why
    std::vector<std::string> files;          ///< every file read for the model, once each, in order

    /// Triangles in all meshes.
    [[nodiscard]] std::size_t triangles() const noexcept {
        std::size_t n = 0;
        for (const Mesh<T>& m : meshes) n += m.size();
        return n;
    }
};

/// The model in an OBJ or PLY file (by extension, any letter case); see the top of this header.
template <class T>
[[nodiscard]] Model<T> load_model(const std::string& path, const ModelOptions& options = {});

/// The model in OBJ or PLY data in memory (`size` bytes at `data`), as load_model reads a file,
/// for data from a network or an archive: no .mtl file is read (mtllib lines give a warning),
/// errors name `name` in place of a file. The PLY mesh is named `name`.
template <class T>
[[nodiscard]] Model<T> load_model_from_memory(const void* data, std::size_t size, MeshFormat format,
                                              const std::string& name = "memory", const ModelOptions& options = {});

#define ISIN_DETAIL_MODEL_IO(T)                                                                                        \
    extern template Model<T> load_model<T>(const std::string&, const ModelOptions&);                                   \
    extern template Model<T> load_model_from_memory<T>(const void*, std::size_t, MeshFormat, const std::string&,       \
                                                       const ModelOptions&);
ISIN_DETAIL_MODEL_IO(float)
ISIN_DETAIL_MODEL_IO(double)
#undef ISIN_DETAIL_MODEL_IO

template <class T, template <class> class... Shapes>
class Scene;

/// Adds `model` to `scene` (include scene.hpp, or isin.hpp, to call it): its textures, its materials (texture indices moved along), and each
/// mesh placed once where it stands (Scene::add_mesh). Returns the meshes' ids, for
/// add_instance. Throws as add_mesh does.
template <class T, template <class> class... S>
std::vector<MeshId> add_model(Scene<T, S...>& scene, const Model<T>& model, const BvhOptions& options = {}) {
    const int first_texture = static_cast<int>(scene.textures.size());
    for (const Texture<T>& texture : model.textures) scene.add_texture(texture);
    const auto first_material = static_cast<std::uint32_t>(scene.materials.size());
    for (Material<T> m : model.materials) {
        if (m.texture >= 0) m.texture += first_texture;
        scene.add_material(m);
    }
    if (model.materials.empty()) scene.add_material(Material<T>{});
    std::vector<MeshId> ids;
    ids.reserve(model.meshes.size());
    for (const Mesh<T>& mesh : model.meshes)
        if (mesh.size() > 0) ids.push_back(scene.add_mesh(mesh, first_material, options));
    return ids;
}

} // namespace isin
