#pragma once
/// isin — limits on what the readers accept from files and memory, which may come from strangers:
/// larger inputs are refused with a clear error before anything in proportion to them is
/// allocated.
#include <cstdint>

namespace isin {

/// Limits of read_image, load_mesh and their in-memory forms.
struct ReadLimits {
    /// Files larger than this are refused before they are read (4 GiB).
    std::uint64_t max_file_bytes = std::uint64_t(1) << 32;
    /// Images whose header declares more pixels are refused before decoding (2^28 = 16384²: the
    /// largest textures in use; decoding may take up to ~8 bytes a pixel on the way).
    std::uint64_t max_pixels = std::uint64_t(1) << 28;
};

/// Totals across one model and every file it names (load_model), checked before the work each
/// would take: what is over a texture or .mtl budget is left out with a warning, meshes or
/// vertices over theirs are a MeshError.
struct ModelBudget {
    std::uint64_t texture_pixels = std::uint64_t(1) << 28; ///< decoded pixels of all textures (16384²)
    std::uint64_t mtl_bytes = std::uint64_t(1) << 26;      ///< bytes of all .mtl files read (64 MiB)
    std::uint64_t materials = std::uint64_t(1) << 20;      ///< materials of all .mtl files
    std::uint64_t meshes = std::uint64_t(1) << 20;         ///< distinct group and object names
    std::uint64_t vertices = std::uint64_t(1) << 28;       ///< vertices of all meshes
};

} // namespace isin
