// libFuzzer target: isin::Bvh<float>::load_from_memory and isin::Bvh<double>::load_from_memory
// (bvh/serialize.hpp). isin::BvhFileError is the defined answer to bad data; anything else is a
// finding. Each input is loaded as it is, and again with its length field and both checksums
// made right (a mutation then reaches the checks of counts, indices and blocks, as a hostile
// file sealed with correct checksums would). A file that loads is traced, so that a tree the
// checks let through is also walked.
#include <isin/bvh/serialize.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace {

template <class T>
void load_and_trace(const std::uint8_t* data, std::size_t size) {
    try {
        const auto bvh = isin::Bvh<T>::load_from_memory(data, size);
        const isin::Box<T> box = bvh.tree().bounds();
        const isin::Ray<T> rays[3] = {{box.lo, box.hi - box.lo}, {box.hi, box.lo - box.hi}, {{0, 0, 0}, {1, 1, 1}}};
        for (const auto& ray : rays) {
            (void)bvh.intersect(ray);
            (void)bvh.occluded(ray, T(1));
            (void)bvh.for_each_hit(ray, T(1e30), [](std::uint32_t, const isin::Hit<T>&) { return true; });
        }
        isin::Hit<T> hits[3];
        bvh.intersect(rays, 3, hits);
    } catch (const isin::BvhFileError&) {}
}

void put64(std::uint8_t* p, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    load_and_trace<float>(data, size);
    load_and_trace<double>(data, size);
    if (size >= 96) { // the file's layout: docs/bvh_format.md
        std::vector<std::uint8_t> sealed(data, data + size);
        put64(&sealed[72], size);
        put64(&sealed[80], isin::detail::Xxh64::of(sealed.data(), 80));
        put64(&sealed[size - 8], isin::detail::Xxh64x4::of(sealed.data(), size - 8));
        load_and_trace<float>(sealed.data(), size);
        load_and_trace<double>(sealed.data(), size);
    }
    return 0;
}
