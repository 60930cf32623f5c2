// Images and their files: sizes, pixel access, PPM/PNG/JPEG, atomic writes, error messages.
#include <isin/image_io.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/temp_dir.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__unix__) || defined(__APPLE__)
#include <csignal>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#define ISIN_TEST_POSIX 1
#else
#define ISIN_TEST_POSIX 0
#endif

namespace fs = std::filesystem;

namespace {

/// Names in `dir`, sorted.
std::vector<std::string> listing(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

std::vector<unsigned char> file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void put_file(const std::string& path, const std::string& content) {
    std::ofstream out(path, std::ios::binary);
    out << content;
}

/// The what() of the E thrown by f, or "" (and a failed check) if none was thrown.
template <class E, class F>
std::string thrown(F f) {
    try {
        f();
    } catch (const E& e) {
        return e.what();
    } catch (...) {
        FAIL("threw the wrong exception type");
        return "";
    }
    FAIL("did not throw");
    return "";
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// A small image whose every pixel differs: (x·40, y·60, 255 − x − y).
isin::Image gradient(int w, int h) {
    isin::Image image(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            image(x, y) = {static_cast<std::uint8_t>(x * 40 % 256), static_cast<std::uint8_t>(y * 60 % 256),
                           static_cast<std::uint8_t>(255 - x - y)};
    return image;
}

} // namespace

TEST_CASE("Image: sides outside [1, 32768] throw std::invalid_argument naming the value") {
    CHECK(contains(thrown<std::invalid_argument>([] { isin::Image(0, 5); }), "width 0"));
    CHECK(contains(thrown<std::invalid_argument>([] { isin::Image(-3, 5); }), "width -3"));
    CHECK(contains(thrown<std::invalid_argument>([] { isin::Image(5, 0); }), "height 0"));
    CHECK(contains(thrown<std::invalid_argument>([] { isin::Image(5, 32769); }), "height 32769"));
    CHECK_NOTHROW(isin::Image(1, 1));
}

TEST_CASE("Image: fill colour, row-major layout from the top, checked and unchecked access") {
    isin::Image image(3, 2, {1, 2, 3});
    CHECK(image.width() == 3);
    CHECK(image.height() == 2);
    REQUIRE(image.pixels().size() == 6);
    for (const auto& p : image.pixels()) CHECK(p == isin::Rgb8{1, 2, 3});
    image(2, 1) = {9, 8, 7};
    image.at(1, 0) = {4, 5, 6};
    CHECK(image.data()[1 * 3 + 2] == isin::Rgb8{9, 8, 7}); // pixel (x, y) at y·width + x
    CHECK(image.data()[1] == isin::Rgb8{4, 5, 6});
    const isin::Image& c = image;
    CHECK(c.at(2, 1) == isin::Rgb8{9, 8, 7});
    CHECK(c(1, 0) == isin::Rgb8{4, 5, 6});
    CHECK_THROWS_AS((void)image.at(3, 0), std::out_of_range);
    CHECK_THROWS_AS((void)image.at(0, 2), std::out_of_range);
    CHECK_THROWS_AS((void)c.at(-1, 0), std::out_of_range);
    CHECK(contains(thrown<std::out_of_range>([&] { (void)c.at(0, -1); }), "(0, -1)"));
}

TEST_CASE("stack_rows: images one above the other, first on top; bad sets throw") {
    isin::Image top(3, 1, {1, 2, 3}), middle(3, 2, {4, 5, 6}), bottom(3, 1, {7, 8, 9});
    middle(2, 1) = {10, 11, 12};
    const isin::Image all = isin::stack_rows({top, middle, bottom});
    CHECK(all.width() == 3);
    CHECK(all.height() == 4);
    CHECK(all(0, 0) == isin::Rgb8{1, 2, 3});
    CHECK(all(1, 1) == isin::Rgb8{4, 5, 6});
    CHECK(all(2, 2) == isin::Rgb8{10, 11, 12});
    CHECK(all(0, 3) == isin::Rgb8{7, 8, 9});
    CHECK(isin::stack_rows({middle}).pixels() == middle.pixels());
    CHECK_THROWS_AS((void)isin::stack_rows({}), std::invalid_argument);
    CHECK_THROWS_WITH_AS((void)isin::stack_rows({top, isin::Image(4, 1)}), "isin::stack_rows: widths differ (3 and 4)",
                         std::invalid_argument);
    const isin::Image tall(1, isin::Image::max_side);
    CHECK_THROWS_AS((void)isin::stack_rows({tall, isin::Image(1, 1)}), std::invalid_argument);
}

TEST_CASE("write_ppm: binary P6 header, then RGB bytes row by row from the top") {
    TempDir dir{"isin-test-image-"};
    isin::Image image(2, 2);
    image(0, 0) = {255, 0, 0};
    image(1, 0) = {0, 255, 0};
    image(0, 1) = {0, 0, 255};
    image(1, 1) = {10, 20, 30};
    isin::write_ppm(image, dir / "a.ppm");
    const std::string header = "P6\n2 2\n255\n";
    std::vector<unsigned char> expected(header.begin(), header.end());
    for (int b : {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30}) expected.push_back(static_cast<unsigned char>(b));
    CHECK(file_bytes(dir / "a.ppm") == expected);
    CHECK(listing(dir.path) == std::vector<std::string>{"a.ppm"}); // no temporary left

    const isin::Image back = isin::read_image(dir / "a.ppm");
    CHECK(back.width() == 2);
    CHECK(back.height() == 2);
    CHECK(back.pixels() == image.pixels());
}

TEST_CASE("read_image: PPM with comments and maxval 15 or 65535 is scaled to 0…255") {
    TempDir dir{"isin-test-image-"};
    put_file(dir / "c.ppm",
             std::string("P6 # comment\n# more\n2 1\n15\n") + '\x0f' + '\x00' + '\x05' + '\x07' + '\x0f' + '\x00');
    const isin::Image a = isin::read_image(dir / "c.ppm");
    REQUIRE(a.width() == 2);
    REQUIRE(a.height() == 1);
    CHECK(a(0, 0) == isin::Rgb8{255, 0, 85});
    CHECK(a(1, 0) == isin::Rgb8{119, 255, 0}); // 7·255/15 = 119

    put_file(dir / "w.ppm", std::string("P6\n1 1\n65535\n") + '\xff' + '\xff' + '\x80' + '\x00' + '\x00' + '\x00');
    const isin::Image b = isin::read_image(dir / "w.ppm");
    CHECK(b(0, 0) == isin::Rgb8{255, 128, 0});
}

TEST_CASE("write_png then read_image gives the identical pixels") {
    TempDir dir{"isin-test-image-"};
    const isin::Image image = gradient(7, 5);
    isin::write_png(image, dir / "g.png");
    const auto bytes = file_bytes(dir / "g.png");
    REQUIRE(bytes.size() > 8);
    CHECK(bytes[1] == 'P'); // PNG signature \x89 P N G
    CHECK(bytes[2] == 'N');
    CHECK(bytes[3] == 'G');
    const isin::Image back = isin::read_image(dir / "g.png");
    CHECK(back.width() == 7);
    CHECK(back.height() == 5);
    CHECK(back.pixels() == image.pixels());
    CHECK(listing(dir.path) == std::vector<std::string>{"g.png"});
}

// An 8×8 JPEG of the flat colour (200, 100, 50), quality 90, made once with stbi_write_jpg
// (whose encoder trips UBSan, so it is not run here).
// clang-format off
const unsigned char flat_jpeg[] = {
    0xff, 0xd8, 0xff, 0xe0, 0x00, 0x10, 0x4a, 0x46, 0x49, 0x46, 0x00, 0x01, 0x01, 0x00, 0x00, 0x01,
    0x00, 0x01, 0x00, 0x00, 0xff, 0xdb, 0x00, 0x84, 0x00, 0x03, 0x02, 0x02, 0x03, 0x02, 0x02, 0x03,
    0x03, 0x03, 0x03, 0x04, 0x03, 0x03, 0x04, 0x05, 0x08, 0x05, 0x05, 0x04, 0x04, 0x05, 0x0a, 0x07,
    0x07, 0x06, 0x08, 0x0c, 0x0a, 0x0c, 0x0c, 0x0b, 0x0a, 0x0b, 0x0b, 0x0d, 0x0e, 0x12, 0x10, 0x0d,
    0x0e, 0x11, 0x0e, 0x0b, 0x0b, 0x10, 0x16, 0x10, 0x11, 0x13, 0x14, 0x15, 0x15, 0x15, 0x0c, 0x0f,
    0x17, 0x18, 0x16, 0x14, 0x18, 0x12, 0x14, 0x15, 0x14, 0x01, 0x03, 0x04, 0x04, 0x05, 0x04, 0x05,
    0x09, 0x05, 0x05, 0x09, 0x14, 0x0d, 0x0b, 0x0d, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14,
    0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14,
    0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14,
    0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0x14, 0xff, 0xc0, 0x00, 0x11, 0x08, 0x00,
    0x08, 0x00, 0x08, 0x03, 0x01, 0x22, 0x00, 0x02, 0x11, 0x01, 0x03, 0x11, 0x01, 0xff, 0xc4, 0x01,
    0xa2, 0x00, 0x00, 0x01, 0x05, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0a, 0x0b, 0x10, 0x00,
    0x02, 0x01, 0x03, 0x03, 0x02, 0x04, 0x03, 0x05, 0x05, 0x04, 0x04, 0x00, 0x00, 0x01, 0x7d, 0x01,
    0x02, 0x03, 0x00, 0x04, 0x11, 0x05, 0x12, 0x21, 0x31, 0x41, 0x06, 0x13, 0x51, 0x61, 0x07, 0x22,
    0x71, 0x14, 0x32, 0x81, 0x91, 0xa1, 0x08, 0x23, 0x42, 0xb1, 0xc1, 0x15, 0x52, 0xd1, 0xf0, 0x24,
    0x33, 0x62, 0x72, 0x82, 0x09, 0x0a, 0x16, 0x17, 0x18, 0x19, 0x1a, 0x25, 0x26, 0x27, 0x28, 0x29,
    0x2a, 0x34, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48, 0x49, 0x4a,
    0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68, 0x69, 0x6a,
    0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89, 0x8a,
    0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6, 0xa7, 0xa8,
    0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3, 0xc4, 0xc5, 0xc6,
    0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda, 0xe1, 0xe2, 0xe3,
    0xe4, 0xe5, 0xe6, 0xe7, 0xe8, 0xe9, 0xea, 0xf1, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8, 0xf9,
    0xfa, 0x01, 0x00, 0x03, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0a, 0x0b, 0x11, 0x00,
    0x02, 0x01, 0x02, 0x04, 0x04, 0x03, 0x04, 0x07, 0x05, 0x04, 0x04, 0x00, 0x01, 0x02, 0x77, 0x00,
    0x01, 0x02, 0x03, 0x11, 0x04, 0x05, 0x21, 0x31, 0x06, 0x12, 0x41, 0x51, 0x07, 0x61, 0x71, 0x13,
    0x22, 0x32, 0x81, 0x08, 0x14, 0x42, 0x91, 0xa1, 0xb1, 0xc1, 0x09, 0x23, 0x33, 0x52, 0xf0, 0x15,
    0x62, 0x72, 0xd1, 0x0a, 0x16, 0x24, 0x34, 0xe1, 0x25, 0xf1, 0x17, 0x18, 0x19, 0x1a, 0x26, 0x27,
    0x28, 0x29, 0x2a, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48, 0x49,
    0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68, 0x69,
    0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x82, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88,
    0x89, 0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6,
    0xa7, 0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3, 0xc4,
    0xc5, 0xc6, 0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda, 0xe2,
    0xe3, 0xe4, 0xe5, 0xe6, 0xe7, 0xe8, 0xe9, 0xea, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8, 0xf9,
    0xfa, 0xff, 0xda, 0x00, 0x0c, 0x03, 0x01, 0x00, 0x02, 0x11, 0x03, 0x11, 0x00, 0x3f, 0x00, 0xab,
    0x45, 0x14, 0x57, 0xe1, 0xe7, 0xf4, 0x81, 0xff, 0xd9};
// clang-format on

TEST_CASE("read_image: a JPEG decodes to RGB (a flat colour survives the lossy coding)") {
    TempDir dir{"isin-test-image-"};
    put_file(dir / "f.jpg", std::string(std::begin(flat_jpeg), std::end(flat_jpeg)));
    const isin::Image back = isin::read_image(dir / "f.jpg");
    REQUIRE(back.width() == 8);
    REQUIRE(back.height() == 8);
    for (const auto& p : back.pixels()) {
        CHECK(std::abs(p.r - 200) <= 3);
        CHECK(std::abs(p.g - 100) <= 3);
        CHECK(std::abs(p.b - 50) <= 3);
    }
}

TEST_CASE("write_image: format by extension in any case; other extensions throw invalid_argument") {
    TempDir dir{"isin-test-image-"};
    const isin::Image image = gradient(3, 3);
    isin::write_image(image, dir / "x.PpM");
    CHECK(file_bytes(dir / "x.PpM").at(1) == '6');
    isin::write_image(image, dir / "y.PNG");
    CHECK(isin::read_image(dir / "y.PNG").pixels() == image.pixels());
    CHECK(contains(thrown<std::invalid_argument>([&] { isin::write_image(image, dir / "z.jpg"); }), "z.jpg"));
    CHECK_THROWS_AS(isin::write_image(image, dir / "noext"), std::invalid_argument);
    CHECK_THROWS_AS(isin::write_image(image, dir / "png"), std::invalid_argument);
    CHECK(listing(dir.path) == std::vector<std::string>{"x.PpM", "y.PNG"});
}

TEST_CASE("writing into a missing directory throws runtime_error naming the path, leaves nothing") {
    TempDir dir{"isin-test-image-"};
    const isin::Image image = gradient(2, 2);
    const std::string target = dir / "missing/out.ppm";
    CHECK(contains(thrown<std::runtime_error>([&] { isin::write_ppm(image, target); }), target));
    CHECK_THROWS_AS(isin::write_image(image, dir / "missing/out.png"), std::runtime_error);
    CHECK(listing(dir.path).empty());
}

TEST_CASE("writing onto an existing directory throws runtime_error, removes its temporary") {
    TempDir dir{"isin-test-image-"};
    fs::create_directory(dir.path / "sub");
    const isin::Image image = gradient(2, 2);
    CHECK(contains(thrown<std::runtime_error>([&] { isin::write_ppm(image, dir / "sub"); }), dir / "sub"));
    CHECK_THROWS_AS(isin::write_png(image, dir / "sub"), std::runtime_error);
    CHECK(listing(dir.path) == std::vector<std::string>{"sub"});
    CHECK(fs::is_directory(dir.path / "sub"));
    CHECK(listing(dir.path / "sub").empty());
}

TEST_CASE("overwriting a good file replaces it whole; no temporary stays behind") {
    TempDir dir{"isin-test-image-"};
    isin::write_ppm(gradient(4, 4), dir / "o.ppm");
    const isin::Image second(3, 2, {7, 7, 7});
    isin::write_ppm(second, dir / "o.ppm");
    CHECK(isin::read_image(dir / "o.ppm").pixels() == second.pixels());
    CHECK(listing(dir.path) == std::vector<std::string>{"o.ppm"});
}

#if ISIN_TEST_POSIX
TEST_CASE("a write failing midway (file size limit) leaves the old file untouched, no temporary") {
    TempDir dir{"isin-test-image-"};
    const std::string target = dir / "good.ppm";
    isin::write_ppm(gradient(4, 4), target);
    const auto before = file_bytes(target);

    // Files may grow to 1000 bytes; the new image needs 30 015. Works as root too.
    rlimit old_limit{};
    REQUIRE(getrlimit(RLIMIT_FSIZE, &old_limit) == 0);
    rlimit small = old_limit;
    small.rlim_cur = 1000;
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
    REQUIRE(setrlimit(RLIMIT_FSIZE, &small) == 0);
    std::string message;
    try {
        isin::write_ppm(isin::Image(100, 100, {1, 2, 3}), target);
    } catch (const std::runtime_error& e) {
        message = e.what();
    }
    setrlimit(RLIMIT_FSIZE, &old_limit);
    std::signal(SIGXFSZ, old_handler);

    CHECK(contains(message, target));
    CHECK(file_bytes(target) == before);
    CHECK(listing(dir.path) == std::vector<std::string>{"good.ppm"});
}

TEST_CASE("writing into a read-only directory throws runtime_error and leaves nothing") {
    if (geteuid() == 0) {
        MESSAGE("skipped: running as root, permissions do not stop writes");
        return;
    }
    TempDir dir{"isin-test-image-"};
    fs::create_directory(dir.path / "ro");
    fs::permissions(dir.path / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    CHECK_THROWS_AS(isin::write_ppm(gradient(2, 2), dir / "ro/out.ppm"), std::runtime_error);
    fs::permissions(dir.path / "ro", fs::perms::owner_all);
    CHECK(listing(dir.path / "ro").empty());
}
#endif

TEST_CASE("read_image: missing, garbage, truncated or directory paths throw naming the path") {
    TempDir dir{"isin-test-image-"};
    const std::string missing = dir / "nothing.png";
    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(missing); }), missing));

    const std::string garbage = dir / "garbage.png";
    put_file(garbage, "this is not an image at all");
    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(garbage); }), garbage));

    const std::string empty = dir / "empty.png";
    put_file(empty, "");
    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(empty); }), empty));

    const std::string truncated = dir / "short.ppm";
    put_file(truncated, "P6\n4 4\n255\nabc");
    const std::string why = thrown<std::runtime_error>([&] { (void)isin::read_image(truncated); });
    CHECK(contains(why, truncated));
    CHECK(contains(why, "truncated"));

    const std::string huge = dir / "huge.ppm";
    put_file(huge, "P6\n40000 1\n255\n");
    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(huge); }), huge));

    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(dir.path.string()); }), dir.path.string()));
}

// ---- hardening: hostile files, limits, in-memory decoding, names ----------------------------------

namespace {

std::string repro(const std::string& name) { return std::string(ISIN_TEST_DATA_DIR) + "/repro/" + name; }

/// The bytes of a PNG of `image` made by write_png.
std::vector<unsigned char> png_of(const isin::Image& image, const TempDir& dir) {
    isin::write_png(image, dir / "made.png");
    return file_bytes(dir / "made.png");
}

bool same_pixels(const isin::Image& a, const isin::Image& b) {
    return a.width() == b.width() && a.height() == b.height() &&
           std::equal(a.pixels().begin(), a.pixels().end(), b.pixels().begin(),
                      [](const isin::Rgb8& p, const isin::Rgb8& q) { return p.r == q.r && p.g == q.g && p.b == q.b; });
}

} // namespace

TEST_CASE("read_image: the hardening reproducers are refused with a reason, none decodes past its data") {
    // D2: stb 2.27 wrote past a Huffman table (code counts summing to 289), used Huffman and
    // quantisation tables the file never defined (uninitialised memory: a crash after a primer,
    // different pixels on every run). D3: a 69-byte PNG asked for 805 MB, a 665-byte JPEG decoded
    // as 16384² invented pixels. D4: an AC magnitude (a 16-bit code, then 10 bits) that straddled
    // the EOI marker drove stb's bit count to -8, a shift by 32 in stbi__grow_buffer_unsafe
    // (UBSan); the primer of D2 took 122 of its 143 blocks from past its data; two DC differences
    // of 32767 times a 16-bit quantiser of 65535 overflowed stb's int. Each is now refused before
    // stb sees it.
    const struct {
        const char* file;
        const char* why;
    } cases[] = {{"jpeg_dht_sum_over_256.jpg", "more than 256"},
                 {"jpeg_uninit_huffman.jpg", "Huffman table that is not defined"},
                 {"jpeg_no_dqt_uninitialized.jpg", "quantisation table that is not defined"},
                 {"jpeg_16384x16384_from_665B.jpg", "cannot code"},
                 {"jpeg_ac_past_the_data_shift32.jpg", "ends inside a block"},
                 {"jpeg_uninit_huffman_primer.jpg", "ends inside a block"},
                 {"jpeg_dc_times_quantiser_overflow.jpg", "coefficient out of range"},
                 {"png_16384x16384_69B.png", "cannot hold"},
                 {"png_memcpy_null_len0.png", "truncated PNG"}};
    // A valid JPEG first, so that the refused files would find its tables in reused memory.
    (void)isin::read_image_from_memory(flat_jpeg, sizeof flat_jpeg);
    for (const auto& c : cases) {
        CAPTURE(std::string(c.file));
        const std::string why = thrown<std::runtime_error>([&] { (void)isin::read_image(repro(c.file)); });
        CHECK(contains(why, c.file));
        CHECK(contains(why, c.why));
    }
}

TEST_CASE("read_image: a pixel budget from the header, before decoding (ReadLimits::max_pixels)") {
    TempDir dir{"isin-test-image-"};
    isin::write_png(gradient(40, 30), dir / "a.png");
    isin::ReadLimits small;
    small.max_pixels = 40 * 30 - 1;
    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(dir / "a.png", small); }), "max_pixels"));
    small.max_pixels = 40 * 30;
    CHECK(isin::read_image(dir / "a.png", small).width() == 40);
    put_file(dir / "a.ppm", "P6\n40 30\n255\n" + std::string(40 * 30 * 3, 'x'));
    small.max_pixels = 100;
    CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image(dir / "a.ppm", small); }), "max_pixels"));
}

TEST_CASE("read_image: truncated PNG and JPEG data are errors, not images padded with zeros") {
    TempDir dir{"isin-test-image-"};
    const std::vector<unsigned char> png = png_of(gradient(64, 64), dir);
    const std::string jpeg(std::begin(flat_jpeg), std::end(flat_jpeg));
    for (std::size_t cut : {std::size_t(20), png.size() / 2, png.size() - 12, png.size() - 1}) {
        CAPTURE(cut);
        CHECK_THROWS_AS((void)isin::read_image_from_memory(png.data(), cut), std::runtime_error);
    }
    for (std::size_t cut : {std::size_t(4), jpeg.size() / 2, jpeg.size() - 2, jpeg.size() - 1}) {
        CAPTURE(cut);
        CHECK_THROWS_AS((void)isin::read_image_from_memory(jpeg.data(), cut), std::runtime_error);
    }
    // Entropy-coded data cut short with its EOI kept: stb would decode zeros past the data (and,
    // at some cuts, shift by 32 or more), so every cut is refused.
    const std::size_t data_end = jpeg.size() - 2; // the 8 bytes of the scan end at EOI
    for (std::size_t drop = 1; drop <= 7; ++drop) {
        CAPTURE(drop);
        const std::string cut = jpeg.substr(0, data_end - drop) + "\xff\xd9";
        CHECK(contains(thrown<std::runtime_error>([&] { (void)isin::read_image_from_memory(cut.data(), cut.size()); }),
                       "ends inside a block"));
    }
}

TEST_CASE("read_image: a PNG whose first IDAT chunks are empty decodes (stb is given them left out)") {
    // stb 2.27 copied 0 bytes from a null pointer for an empty first IDAT (undefined behaviour
    // that UBSan reports); such chunks are legal PNG and carry nothing.
    TempDir dir{"isin-test-image-"};
    const isin::Image image = gradient(7, 5);
    std::vector<unsigned char> png = png_of(image, dir);
    std::size_t idat = 8;
    while (idat + 8 <= png.size() && std::string(png.begin() + long(idat) + 4, png.begin() + long(idat) + 8) != "IDAT")
        idat += 12 + (std::size_t(png[idat]) << 24 | std::size_t(png[idat + 1]) << 16 |
                      std::size_t(png[idat + 2]) << 8 | png[idat + 3]);
    REQUIRE(idat + 8 <= png.size());
    const unsigned char empty_idat[12] = {0, 0, 0, 0, 'I', 'D', 'A', 'T', 0x35, 0xaf, 0x06, 0x1e};
    png.insert(png.begin() + long(idat), std::begin(empty_idat), std::end(empty_idat));
    png.insert(png.begin() + long(idat), std::begin(empty_idat), std::end(empty_idat));
    CHECK(same_pixels(isin::read_image_from_memory(png.data(), png.size()), image));
}

TEST_CASE("read_image_from_memory decodes what read_image decodes, and names its source") {
    TempDir dir{"isin-test-image-"};
    const isin::Image image = gradient(9, 4);
    const std::vector<unsigned char> png = png_of(image, dir);
    CHECK(same_pixels(isin::read_image_from_memory(png.data(), png.size()), image));
    isin::write_ppm(image, dir / "a.ppm");
    const std::vector<unsigned char> ppm = file_bytes(dir / "a.ppm");
    CHECK(same_pixels(isin::read_image_from_memory(ppm.data(), ppm.size()), image));
    const std::string jpeg(std::begin(flat_jpeg), std::end(flat_jpeg));
    put_file(dir / "f.jpg", jpeg);
    CHECK(same_pixels(isin::read_image_from_memory(jpeg.data(), jpeg.size()), isin::read_image(dir / "f.jpg")));
    CHECK(
        contains(thrown<std::runtime_error>([&] { (void)isin::read_image_from_memory("GIF89a", 6, {}, "upload #3"); }),
                 "'upload #3'"));
    CHECK_THROWS_AS((void)isin::read_image_from_memory(nullptr, 100), std::runtime_error);
}

#if ISIN_TEST_POSIX
TEST_CASE("read_image refuses devices, pipes and links to them at once, and files over the size limit") {
    // D10: reading /dev/zero grew until the OOM killer; a FIFO would block for ever.
    TempDir dir{"isin-test-image-"};
    CHECK(contains(thrown<std::runtime_error>([] { (void)isin::read_image("/dev/zero"); }), "not a regular file"));
    fs::create_symlink("/dev/zero", dir.path / "zero.png");
    CHECK(
        contains(thrown<std::runtime_error>([&] { (void)isin::read_image(dir / "zero.png"); }), "not a regular file"));
    REQUIRE(::mkfifo((dir / "fifo.ppm").c_str(), 0600) == 0);
    CHECK(
        contains(thrown<std::runtime_error>([&] { (void)isin::read_image(dir / "fifo.ppm"); }), "not a regular file"));
    isin::write_ppm(gradient(8, 8), dir / "a.ppm");
    isin::ReadLimits limits;
    limits.max_file_bytes = 100; // the file is 8·8·3 + 11 = 203 bytes
    const std::string why = thrown<std::runtime_error>([&] { (void)isin::read_image(dir / "a.ppm", limits); });
    CHECK(contains(why, "203 bytes"));
    CHECK(contains(why, "max_file_bytes"));
    limits.max_file_bytes = 203;
    CHECK(isin::read_image(dir / "a.ppm", limits).width() == 8);
}

TEST_CASE("writing works for every name the file system takes: a 255-byte name, no temporary left") {
    // D9: the temporary was "<path>.tmp-<pid>-<n>", longer than the name, so names of 244–255
    // bytes failed with "File name too long".
    TempDir dir{"isin-test-image-"};
    for (std::size_t length : {std::size_t(5), std::size_t(244), std::size_t(255)}) {
        const std::string name = std::string(length - 4, 'n') + ".png";
        isin::write_image(gradient(3, 3), dir / name);
        CHECK(same_pixels(isin::read_image(dir / name), gradient(3, 3)));
        const std::string ppm = std::string(length - 4, 'p') + ".ppm";
        isin::write_ppm(gradient(3, 3), dir / ppm);
        CHECK(fs::file_size(dir / ppm) == 3 * 3 * 3 + 11);
    }
    CHECK(listing(dir.path).size() == 6);
}
#endif

TEST_CASE("check_image_output: the format and size write_image would refuse, before any rendering") {
    // D11: a 32768×10923 render ran two minutes, then failed in the PNG encoder.
    CHECK_NOTHROW(isin::check_image_output("a.png", 32768, 10922));
    CHECK(contains(thrown<std::invalid_argument>([] { isin::check_image_output("a.png", 32768, 10923); }),
                   "too large for the PNG encoder"));
    CHECK_NOTHROW(isin::check_image_output("a.PPM", 32768, 32768));
    CHECK(contains(thrown<std::invalid_argument>([] { isin::check_image_output("a.gif", 10, 10); }),
                   "unknown extension"));
}
