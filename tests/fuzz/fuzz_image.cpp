// libFuzzer target: isin::read_image_from_memory (PNG and JPEG through stb behind isin's checks,
// PPM) with the default limits. A std::runtime_error is the defined answer to bad data; any
// other exception, a crash, a sanitizer report, a hang or an allocation beyond libFuzzer's
// limits is a finding.
#include <isin/image_io.hpp>
#include <isin/io/image_impl.hpp> // the file code, and stb, compiled here

#include <cstddef>
#include <cstdint>
#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)isin::read_image_from_memory(data, size);
    } catch (const std::runtime_error&) {}
    return 0;
}
