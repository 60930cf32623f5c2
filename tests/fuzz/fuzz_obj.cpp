// libFuzzer target: the OBJ reader through isin::load_mesh_from_memory (float) and
// isin::load_model_from_memory (double, normals computed). isin::MeshError is the defined answer
// to bad data; anything else is a finding.
#define ISIN_IMPLEMENTATION // the file code, and stb, compiled here
#include <isin/mesh.hpp>
#include <isin/model.hpp>

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)isin::load_mesh_from_memory<float>(data, size, isin::MeshFormat::obj);
    } catch (const isin::MeshError&) {}
    try { // the whole model (groups, materials named, normals, uvs, colours), normals computed
        isin::ModelOptions options;
        options.compute_normals = true;
        (void)isin::load_model_from_memory<double>(data, size, isin::MeshFormat::obj, "fuzz", options);
    } catch (const isin::MeshError&) {}
    return 0;
}
