// libFuzzer target: the PLY reader through isin::load_mesh_from_memory (float) and
// isin::load_model_from_memory (double, normals computed). isin::MeshError is the defined answer
// to bad data; anything else is a finding.
#include <isin/mesh.hpp>
#include <isin/model.hpp>
#include <isin/io/mesh_impl.hpp> // the file code, with stb and tinyobjloader, compiled here

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)isin::load_mesh_from_memory<float>(data, size, isin::MeshFormat::ply);
    } catch (const isin::MeshError&) {}
    try { // the whole model (groups, materials named, normals, uvs, colours), normals computed
        isin::ModelOptions options;
        options.compute_normals = true;
        (void)isin::load_model_from_memory<double>(data, size, isin::MeshFormat::ply, "fuzz", options);
    } catch (const isin::MeshError&) {}
    return 0;
}
