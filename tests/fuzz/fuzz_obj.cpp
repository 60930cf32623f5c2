// libFuzzer target: the OBJ reader (isin's checks, then tinyobjloader) through
// isin::load_mesh_from_memory in float and double. isin::MeshError is the defined answer to bad
// data; anything else is a finding.
#define ISIN_IMPLEMENTATION // the file code, and stb, compiled here
#include <isin/mesh.hpp>

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)isin::load_mesh_from_memory<float>(data, size, isin::MeshFormat::obj);
    } catch (const isin::MeshError&) {}
    try {
        (void)isin::load_mesh_from_memory<double>(data, size, isin::MeshFormat::obj);
    } catch (const isin::MeshError&) {}
    return 0;
}
