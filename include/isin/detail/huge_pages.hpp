#pragma once
/// isin — private: large blocks on huge pages (Linux transparent huge pages,
/// `madvise(MADV_HUGEPAGE)`; Embree does the same for its builds). The Bvh build writes every
/// byte of its arrays (primitives, nodes, leaf blocks) once, and with 4 KiB pages each page's
/// first write is a fault, a large share of a build's time (docs/performance.md); with 2 MiB
/// pages there are 512 times fewer. Where the kernel has them only on request ("madvise"
/// in /sys/kernel/mm/transparent_hugepage/enabled, the default of Debian and Ubuntu) nothing
/// else asks for them. Two ways: advise_huge_pages for a block that is already allocated (the
/// tree's vectors), and map_huge_pages / unmap_huge_pages for the build's own blocks of 2 MiB or
/// more (UninitAllocator), mapped on their own; a freed block is unmapped at once, or kept in the
/// KeptBlocks of the caller's BuildContext for its next build. Nothing is kept for the process.
/// Elsewhere, and for blocks under 2 MiB, nothing changes; a refusal changes nothing but the speed.
#include <cstddef>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <new>
#include <type_traits>
#include <utility>

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

#if defined(__linux__) && defined(MADV_HUGEPAGE)
inline constexpr bool maps_huge_pages = true;
#else
inline constexpr bool maps_huge_pages = false;
#endif
inline constexpr std::size_t huge_page_bytes = std::size_t(2) << 20;

// The size mapped for a block of `bytes`: whole 2 MiB pages. Rounding to small pages instead saves
// at most 2 MiB a block but leaves the block's last part on 4 KiB pages, whose faults cost more
// than the memory saved (docs/performance.md).
inline constexpr std::size_t mapped_bytes(std::size_t bytes) noexcept {
    return (bytes + huge_page_bytes - 1) & ~(huge_page_bytes - 1);
}

/// Bytes of the blocks map_huge_pages has mapped and not yet unmapped (kept ones included), and how
/// many times it asked the kernel for a block: what a build leaves behind, and whether a build
/// reused kept blocks (tests, benchmarks).
struct MappedBlocks {
    std::atomic<std::size_t> bytes{0};
    std::atomic<std::size_t> maps{0};
};
inline MappedBlocks& mapped_blocks() noexcept {
    static MappedBlocks counts;
    return counts;
}

inline void unmap_now(void* data, std::size_t size) noexcept;

/// Freed blocks kept for the next block of the same size, up to `limit` bytes in all: the builds
/// of a program that rebuilds (every frame, a scene's commits, a benchmark) then reuse the pages
/// of the build before, already on huge pages, instead of the kernel zeroing fresh ones and
/// the first writes faulting them in again. Blocks are kept
/// by exact size only, so a kept block never serves a smaller request; one that would pass the
/// limit or the capacity is unmapped. Owned by a BuildContext; its blocks are unmapped with it.
class KeptBlocks {
public:
    static constexpr int capacity = 256; // blocks of 2 MiB or more
    explicit KeptBlocks(std::size_t limit) noexcept : limit_(limit) {}
    KeptBlocks(const KeptBlocks&) = delete;
    KeptBlocks& operator=(const KeptBlocks&) = delete;
    ~KeptBlocks() { release(); }
    // A kept block of exactly `size` mapped bytes, or null.
    void* take(std::size_t size) noexcept {
        const std::lock_guard<std::mutex> lock(mutex_);
        for (int k = count_; k-- > 0;)
            if (blocks_[k].size == size) {
                void* const p = blocks_[k].data;
                blocks_[k] = blocks_[--count_];
                total_ -= size;
                return p;
            }
        return nullptr;
    }
    // Keeps the block (true) or leaves it to the caller to unmap (false: the limit or the capacity).
    bool keep(void* data, std::size_t size) noexcept {
        const std::lock_guard<std::mutex> lock(mutex_);
        if (count_ == capacity || size > limit_ - total_) return false;
        blocks_[count_++] = {data, size};
        total_ += size;
        return true;
    }
    // Unmaps every kept block.
    void release() noexcept {
        const std::lock_guard<std::mutex> lock(mutex_);
        for (int k = 0; k < count_; ++k) unmap_now(blocks_[k].data, blocks_[k].size);
        count_ = 0, total_ = 0;
    }
    [[nodiscard]] std::size_t bytes() const noexcept {
        const std::lock_guard<std::mutex> lock(mutex_);
        return total_;
    }
    [[nodiscard]] std::size_t limit() const noexcept { return limit_; }

private:
    struct Block {
        void* data;
        std::size_t size;
    };
    mutable std::mutex mutex_;
    Block blocks_[capacity] = {};
    int count_ = 0;
    std::size_t total_ = 0;
    std::size_t limit_;
};

/// A block of its own for `bytes` ≥ huge_page_bytes (where maps_huge_pages): one of the same size
/// from `kept` (when given), or mapped from the kernel, aligned to 2 MiB and advised for huge pages
/// before anything is written to it; freed with unmap_huge_pages. Its contents are undefined.
/// Throws std::bad_alloc when the kernel has no memory for it. Why not malloc and
/// advise_huge_pages: after the first block of a size is freed, glibc serves the next ones from
/// its heaps (its mmap threshold adapts), whose pages were written before and so stay 4 KiB;
/// from the second build on, the build's arrays would have small pages.
inline void* map_huge_pages([[maybe_unused]] std::size_t bytes, [[maybe_unused]] KeptBlocks* kept = nullptr) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr std::uintptr_t huge = huge_page_bytes;
    if (bytes > std::size_t(-1) / 2) throw std::bad_alloc();
    // Whole huge pages, from a 2 MiB boundary that lies within the mapping's first 2 MiB.
    const std::size_t size = mapped_bytes(bytes);
    if (kept)
        if (void* const p = kept->take(size)) return p;
    void* const map = mmap(nullptr, size + huge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (map == MAP_FAILED) throw std::bad_alloc();
    const auto at = reinterpret_cast<std::uintptr_t>(map), aligned = (at + huge - 1) & ~(huge - 1);
    if (aligned > at) (void)munmap(map, aligned - at);                                                   // the head
    if (at + huge > aligned) (void)munmap(reinterpret_cast<void*>(aligned + size), at + huge - aligned); // the tail
    (void)madvise(reinterpret_cast<void*>(aligned), size, MADV_HUGEPAGE);
    mapped_blocks().bytes += size, ++mapped_blocks().maps;
    return reinterpret_cast<void*>(aligned);
#else
    throw std::bad_alloc(); // not called: maps_huge_pages is false
#endif
}
/// Frees a block of map_huge_pages: kept in `kept` (when given and it has room), or unmapped.
inline void unmap_huge_pages([[maybe_unused]] void* data, [[maybe_unused]] std::size_t bytes,
                             [[maybe_unused]] KeptBlocks* kept = nullptr) noexcept {
    const std::size_t size = mapped_bytes(bytes);
    if (kept && kept->keep(data, size)) return;
    unmap_now(data, size);
}
inline void unmap_now([[maybe_unused]] void* data, [[maybe_unused]] std::size_t size) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    (void)munmap(data, size);
    mapped_blocks().bytes -= size;
#endif
}

/// v.reserve(n), its block advised for huge pages before anything is written to it.
template <class Vector>
void reserve_huge_pages(Vector& v, std::size_t n) {
    v.reserve(n);
    advise_huge_pages(v.data(), v.capacity() * sizeof(*v.data()));
}

// An allocator whose value-less construct() leaves trivial values uninitialised, so that
// resizing a vector that the build then fills in parallel does not first zero it serially; its
// blocks of 2 MiB or more are mapped on their own, on huge pages (map_huge_pages above), and
// taken from and given back to `kept` (a BuildContext's) when it is set.
template <class T>
struct UninitAllocator : std::allocator<T> {
    KeptBlocks* kept = nullptr;
    T* allocate(std::size_t n) {
        if (mapped(n)) return static_cast<T*>(map_huge_pages(n * sizeof(T), kept));
        return std::allocator<T>::allocate(n);
    }
    void deallocate(T* p, std::size_t n) noexcept {
        if (mapped(n)) return unmap_huge_pages(p, n * sizeof(T), kept);
        std::allocator<T>::deallocate(p, n);
    }
    // Whether a block of n values is mapped on its own: one rule for allocate and deallocate.
    static constexpr bool mapped(std::size_t n) noexcept {
        return maps_huge_pages && n <= std::size_t(-1) / 2 / sizeof(T) && n * sizeof(T) >= huge_page_bytes;
    }
    template <class U>
    struct rebind {
        using other = UninitAllocator<U>;
    };
    using is_always_equal = std::false_type; // blocks go back to the `kept` they came from
    using propagate_on_container_copy_assignment = std::true_type;
    using propagate_on_container_move_assignment = std::true_type;
    using propagate_on_container_swap = std::true_type;
    UninitAllocator() = default;
    explicit UninitAllocator(KeptBlocks* k) noexcept : kept(k) {}
    template <class U>
    UninitAllocator(const UninitAllocator<U>& o) noexcept : kept(o.kept) {}
    template <class U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... A>
    void construct(U* p, A&&... a) {
        ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
    }
    template <class U>
    friend bool operator==(const UninitAllocator& a, const UninitAllocator<U>& b) noexcept {
        return a.kept == b.kept;
    }
    template <class U>
    friend bool operator!=(const UninitAllocator& a, const UninitAllocator<U>& b) noexcept {
        return a.kept != b.kept;
    }
};

} // namespace isin::detail
