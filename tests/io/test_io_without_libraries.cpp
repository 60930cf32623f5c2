// The file code built without stb and tinyobjloader, as a user may choose (ISIN_HAVE_STB and
// ISIN_HAVE_TINYOBJLOADER defined to 0; without that choice a missing library is a compile-time
// error naming its Debian package): PPM and PLY still work, PNG, JPEG and OBJ say what to install.
#define ISIN_HAVE_STB 0
#define ISIN_HAVE_TINYOBJLOADER 0
#include <isin/image_io.hpp>
#include <isin/io/image_impl.hpp>
#include <isin/io/mesh_impl.hpp>
#include <isin/mesh.hpp>

#include <doctest/doctest.h>

#include "../support/temp_dir.hpp"

#include <stdexcept>
#include <string>

TEST_CASE("without stb: PPM reads and writes, PNG and JPEG throw runtime_error naming libstb-dev") {
    TempDir dir{"isin-test-noio-"};
    const isin::Image image(3, 2, {10, 20, 30});
    isin::write_ppm(image, dir / "a.ppm");
    CHECK(isin::read_image(dir / "a.ppm").pixels() == image.pixels());
    CHECK_THROWS_WITH_AS(isin::write_png(image, dir / "a.png"), doctest::Contains("libstb-dev"), std::runtime_error);
    const unsigned char png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    CHECK_THROWS_AS((void)isin::read_image_from_memory(png_signature, sizeof png_signature), std::runtime_error);
}

TEST_CASE("without tinyobjloader: PLY loads, OBJ throws runtime_error naming libtinyobjloader-dev") {
    TempDir dir{"isin-test-noio-"};
    const std::string ply =
        dir.put("t.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                         "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    CHECK(isin::load_mesh<float>(ply).size() == 1);
    const std::string obj = dir.put("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THROWS_WITH_AS((void)isin::load_obj<float>(obj), doctest::Contains("libtinyobjloader-dev"),
                         std::runtime_error);
    CHECK_THROWS_WITH_AS((void)isin::load_mesh<double>(obj), doctest::Contains(obj.c_str()), std::runtime_error);
}
