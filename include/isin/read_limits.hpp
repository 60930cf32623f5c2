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

} // namespace isin
