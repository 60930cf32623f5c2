#pragma once
/// isin — scratch memory a caller holds across Bvh builds. A build given no context (the default)
/// frees all its scratch when it ends: the process keeps nothing beyond the Bvh. Given one
/// (BvhOptions::context), the build's large blocks go back to the context when it ends, and the
/// next build given the same context takes them again (same sizes: the same mesh, or one of the
/// same size) instead of the kernel mapping and zeroing fresh pages. The blocks are freed with the
/// context, or by release().
///
///     isin::BuildContext context;              // lives as long as the rebuild loop
///     isin::BvhOptions options;
///     options.context = &context;
///     for (;;) { move(triangles); bvh = isin::Bvh<float>(triangles, options); … }
#include <cstddef>

#include "../detail/huge_pages.hpp"

namespace isin {

/// Scratch memory kept between the Bvh builds given it, freed with it. Builds on several threads,
/// or several builds at once, may share one. Not copied or moved (builds refer to it).
class BuildContext {
public:
    /// Keeps at most `limit_bytes` of scratch between builds (a block past it is freed at once).
    explicit BuildContext(std::size_t limit_bytes = std::size_t(1) << 30) noexcept : kept_(limit_bytes) {}
    BuildContext(const BuildContext&) = delete;
    BuildContext& operator=(const BuildContext&) = delete;

    /// Bytes of scratch kept for the next build.
    [[nodiscard]] std::size_t kept_bytes() const noexcept { return kept_.bytes(); }
    /// Frees the kept scratch now (the context stays usable).
    void release() noexcept { kept_.release(); }
    /// The kept blocks, for the build (detail).
    [[nodiscard]] detail::KeptBlocks& kept_blocks() noexcept { return kept_; }

private:
    detail::KeptBlocks kept_;
};

} // namespace isin
