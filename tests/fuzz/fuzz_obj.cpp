// libFuzzer target: the OBJ reader through isin::load_mesh_from_memory (float) and
// isin::load_model_from_memory (double, normals computed), and isin::load_model (float) on
// files in a temporary directory: the input split at "\n%%\n" into the OBJ (after a line
// "mtllib model.mtl"), model.mtl and tex.png, so that .mtl files and textures are read from
// files as an upload's would be. isin::MeshError is the defined answer to bad data; anything
// else is a finding.
#include <isin/mesh.hpp>
#include <isin/model.hpp>
#include <isin/io/mesh_impl.hpp> // the file code, with stb and tinyobjloader, compiled here

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

namespace {

std::string made_dir; // removed with its files when the process ends

/// A directory of this process's own under the system's temporary directory, made once.
const std::filesystem::path& fuzz_dir() {
    static const std::filesystem::path dir = [] {
        std::string pattern = (std::filesystem::temp_directory_path() / "isin-fuzz-obj-XXXXXX").string();
        if (!::mkdtemp(pattern.data())) std::abort();
        made_dir = pattern;
        std::atexit([] {
            std::error_code ec;
            std::filesystem::remove_all(made_dir, ec);
        });
        return std::filesystem::path(pattern);
    }();
    return dir;
}

/// Writes `bytes` to `path`, or removes the file when there are none.
void put(const std::filesystem::path& path, std::string_view bytes, bool present) {
    std::error_code ec;
    std::filesystem::remove(path, ec);
    if (!present) return;
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)isin::load_mesh_from_memory<float>(data, size, isin::MeshFormat::obj);
    } catch (const isin::MeshError&) {}
    try { // the whole model (groups, materials named, normals, uvs, colours), normals computed
        isin::ModelOptions options;
        options.compute_normals = true;
        (void)isin::load_model_from_memory<double>(data, size, isin::MeshFormat::obj, "fuzz", options);
    } catch (const isin::MeshError&) {}

    // The model from files: OBJ, its .mtl and a texture.
    std::string_view parts[3];
    bool present[3] = {true, false, false};
    std::string_view rest(reinterpret_cast<const char*>(data), size);
    for (int i = 0; i < 3; ++i) {
        const std::size_t at = i < 2 ? rest.find("\n%%\n") : std::string_view::npos;
        parts[i] = rest.substr(0, at);
        if (at == std::string_view::npos) break;
        rest.remove_prefix(at + 4);
        present[i + 1] = true;
    }
    const std::filesystem::path& dir = fuzz_dir();
    put(dir / "model.obj", "mtllib model.mtl\n" + std::string(parts[0]), true);
    put(dir / "model.mtl", parts[1], present[1]);
    put(dir / "tex.png", parts[2], present[2]);
    try {
        isin::ModelOptions options;
        options.budget.texture_pixels = 1 << 20; // small textures only: a fuzzer's run is short
        (void)isin::load_model<float>((dir / "model.obj").string(), options);
    } catch (const isin::MeshError&) {}
    return 0;
}
