#pragma once
/// isin — private: asks the kernel to back a large block with huge pages (Linux transparent huge
/// pages, `madvise(MADV_HUGEPAGE)`; Embree does the same for its builds). The Bvh build writes
/// every byte of its arrays (primitives, nodes, leaf blocks) once, and with 4 KiB pages each
/// page's first write is a fault: on this project's virtual machine, a third of the one-thread
/// build time of a 1.3M-triangle mesh (vs_embree --build-only: 1180 → 710 ms with huge pages); with
/// 2 MiB pages there are 512 times fewer. Where the kernel
/// has them only on request ("madvise" in /sys/kernel/mm/transparent_hugepage/enabled, the
/// default of Debian and Ubuntu) nothing else asks for them. Elsewhere, and for blocks under
/// 2 MiB, it does nothing; a refusal changes nothing but the speed.
#include <cstddef>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace isin::detail {

/// Advises huge pages for the whole 4 KiB pages inside [data, data + bytes), before they are
/// first written (pages already touched keep their size until the kernel merges them).
inline void advise_huge_pages([[maybe_unused]] const void* data, [[maybe_unused]] std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr std::uintptr_t page = 4096, huge = std::uintptr_t(2) << 20;
    if (bytes < huge) return;
    const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + page - 1) & ~(page - 1);
    const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(page - 1);
    if (end > begin) (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#endif
}

/// v.reserve(n), its block advised for huge pages before anything is written to it.
template <class Vector>
void reserve_huge_pages(Vector& v, std::size_t n) {
    v.reserve(n);
    advise_huge_pages(v.data(), v.capacity() * sizeof(*v.data()));
}

} // namespace isin::detail
