// Mesh files: OBJ (through tinyobjloader) and PLY (ASCII, binary little- and big-endian) to
// triangles, fan triangulation and winding, PLY vertex attributes, and the errors for broken or
// hostile files.
#include <isin/mesh.hpp>
#include <isin/io/ply.hpp> // parse_ply_mesh: the whole Mesh a PLY file gives

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/temp_dir.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

/// The what() of the E thrown by f, or "" (and a failed check) if none was thrown.
template <class E = isin::MeshError, class F>
std::string thrown(F f) {
    try {
        f();
    } catch (const E& e) {
        return e.what();
    } catch (const std::exception& e) {
        FAIL("threw the wrong exception type: " << e.what());
        return "";
    }
    FAIL("did not throw");
    return "";
}

doctest::String str(const std::string& s) { return s.c_str(); }

/// Bytes of a binary PLY body, values in the host's order (checked to be little-endian).
struct Bytes {
    std::string data;
    template <class V>
    Bytes& put(V v) {
        char b[sizeof v];
        std::memcpy(b, &v, sizeof v);
        data.append(b, sizeof v);
        return *this;
    }
};

bool host_is_little_endian() {
    const std::uint16_t one = 1;
    unsigned char first = 0;
    std::memcpy(&first, &one, 1);
    return first == 1;
}

template <class T>
isin::Vertex<T> V(double x, double y, double z) {
    return {static_cast<T>(x), static_cast<T>(y), static_cast<T>(z)};
}

template <class T>
void check_triangle(const isin::Triangle<T>& t, const isin::Vertex<T>& a, const isin::Vertex<T>& b,
                    const isin::Vertex<T>& c) {
    CHECK(t.v0 == a);
    CHECK(t.v1 == b);
    CHECK(t.v2 == c);
}

// A quad, a triangle and a pentagon, all counter-clockwise seen from +z, then the triangle
// again reversed. Every coordinate is exact in binary.
const char* const polygons_obj = "# quad, triangle, pentagon\n"
                                 "v 0 0 0\n"
                                 "v 2 0 0\n"
                                 "v 2 2 0\n"
                                 "v 0 2 0\n"
                                 "v 5 0 1.5\n"
                                 "v 6 0 1.5\n"
                                 "v 5 1 1.5\n"
                                 "v 10 0 -0.5\n"
                                 "v 11 0 -0.5\n"
                                 "v 11.5 1 -0.5\n"
                                 "v 10.5 2 -0.5\n"
                                 "v 9.5 1 -0.5\n"
                                 "f 1 2 3 4\n"
                                 "f 5 6 7\n"
                                 "f 8 9 10 11 12\n"
                                 "f 7 6 5\n";

// Four vertices with normals, colours; a quad and a triangle; an edge element to skip.
const char* const ascii_ply = "ply\n"
                              "format ascii 1.0\n"
                              "comment written by test_mesh\n"
                              "obj_info nothing\n"
                              "element vertex 5\n"
                              "property float x\n"
                              "property float nx\n"
                              "property float y\n"
                              "property float z\n"
                              "property float ny\n"
                              "property float nz\n"
                              "property uchar red\n"
                              "property uchar green\n"
                              "property uchar blue\n"
                              "element face 2\n"
                              "property list uchar int vertex_indices\n"
                              "element edge 1\n"
                              "property int vertex1\n"
                              "property int vertex2\n"
                              "end_header\n"
                              "0 0 0 0 0 1 255 0 0\n"
                              "2 0 0 0 0 1 0 255 0\n"
                              "2 0 2 0 0 1 0 0 255\n"
                              "0 0 2 0 0 1 10 20 30\n"
                              "1 0 1 3.25 0 1 1 2 3\n"
                              "4 0 1 2 3\n"
                              "3 0 4 1\n"
                              "0 1\n";

/// Header lines joined with '\n', ending with end_header.
std::string header(std::initializer_list<const char*> lines) {
    std::string h;
    for (const char* l : lines) h += std::string(l) + "\n";
    return h + "end_header\n";
}

} // namespace

TEST_CASE_TEMPLATE("OBJ: quad, triangle, pentagon become fans (v0, vi, vi+1) with exact coordinates", T, float,
                   double) {
    TempDir dir{"isin-test-mesh-"};
    const auto tris = isin::load_obj<T>(dir.put("polygons.obj", polygons_obj));
    REQUIRE(tris.size() == 2 + 1 + 3 + 1);
    check_triangle(tris[0], V<T>(0, 0, 0), V<T>(2, 0, 0), V<T>(2, 2, 0));
    check_triangle(tris[1], V<T>(0, 0, 0), V<T>(2, 2, 0), V<T>(0, 2, 0));
    check_triangle(tris[2], V<T>(5, 0, 1.5), V<T>(6, 0, 1.5), V<T>(5, 1, 1.5));
    check_triangle(tris[3], V<T>(10, 0, -0.5), V<T>(11, 0, -0.5), V<T>(11.5, 1, -0.5));
    check_triangle(tris[4], V<T>(10, 0, -0.5), V<T>(11.5, 1, -0.5), V<T>(10.5, 2, -0.5));
    check_triangle(tris[5], V<T>(10, 0, -0.5), V<T>(10.5, 2, -0.5), V<T>(9.5, 1, -0.5));
    check_triangle(tris[6], V<T>(5, 1, 1.5), V<T>(6, 0, 1.5), V<T>(5, 0, 1.5));
    // Winding kept: every piece of a counter-clockwise polygon has its normal along +z, the
    // reversed triangle along −z.
    for (std::size_t i = 0; i < 6; ++i) {
        const auto N = isin::normal(tris[i]);
        CHECK(N.x == T(0));
        CHECK(N.y == T(0));
        CHECK(N.z > T(0));
    }
    CHECK(isin::normal(tris[6]).z < T(0));
}

TEST_CASE_TEMPLATE("OBJ: negative indices, v/vt/vn forms, groups, usemtl and a missing .mtl", T, float, double) {
    TempDir dir{"isin-test-mesh-"};
    const std::string obj = "mtllib missing.mtl\n"
                            "v 0 0 0\n"
                            "v 1 0 0\n"
                            "v 0 1 0\n"
                            "vt 0 0\n"
                            "vt 1 0\n"
                            "vt 0 1\n"
                            "vn 0 0 1\n"
                            "f -3/-3/-1 -2/-2/-1 -1/-1/-1\n"
                            "g second\n"
                            "usemtl nothing\n"
                            "v 0 0 1\n"
                            "v 1 0 1 1.0\n"         // with w
                            "v 0 1 1 0.5 0.5 0.5\n" // with a colour
                            "f 4//1 5//1 6//1\n"
                            "o object\n"
                            "s 1\n"
                            "f 4/1 5/2 6/3\n"
                            "f -3/1/1 5/2/1 -1/3/1\n"
                            "\tf  1  2\t3  \n";
    const auto tris = isin::load_obj<T>(dir.put("forms.obj", obj));
    REQUIRE(tris.size() == 5);
    check_triangle(tris[0], V<T>(0, 0, 0), V<T>(1, 0, 0), V<T>(0, 1, 0));
    for (std::size_t i = 1; i < 4; ++i) check_triangle(tris[i], V<T>(0, 0, 1), V<T>(1, 0, 1), V<T>(0, 1, 1));
    check_triangle(tris[4], V<T>(0, 0, 0), V<T>(1, 0, 0), V<T>(0, 1, 0));
}

TEST_CASE("OBJ: a face may name vertices defined later in the file; CRLF line ends work") {
    TempDir dir{"isin-test-mesh-"};
    const auto tris = isin::load_obj<double>(dir.put("forward.obj", "f 1 2 3\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\n"));
    REQUIRE(tris.size() == 1);
    check_triangle(tris[0], V<double>(0, 0, 0), V<double>(1, 0, 0), V<double>(0, 1, 0));
}

TEST_CASE("OBJ and PLY without faces give an empty mesh, not an error") {
    TempDir dir{"isin-test-mesh-"};
    CHECK(isin::load_obj<float>(dir.put("empty.obj", "")).empty());
    CHECK(isin::load_obj<float>(dir.put("points.obj", "# only vertices\nv 0 0 0\nv 1 1 1\n")).empty());
    CHECK(isin::load_ply<float>(
              dir.put("points.ply", header({"ply", "format ascii 1.0", "element vertex 1", "property float x",
                                            "property float y", "property float z"}) +
                                        "1 2 3\n"))
              .empty());
    CHECK(isin::load_ply<float>(dir.put("nothing.ply", header({"ply", "format binary_little_endian 1.0"}))).empty());
}

TEST_CASE_TEMPLATE("PLY ascii: extra vertex properties and elements are skipped, quads become fans", T, float, double) {
    TempDir dir{"isin-test-mesh-"};
    const auto tris = isin::load_ply<T>(dir.put("mesh.ply", ascii_ply));
    REQUIRE(tris.size() == 3);
    check_triangle(tris[0], V<T>(0, 0, 0), V<T>(2, 0, 0), V<T>(2, 2, 0));
    check_triangle(tris[1], V<T>(0, 0, 0), V<T>(2, 2, 0), V<T>(0, 2, 0));
    check_triangle(tris[2], V<T>(0, 0, 0), V<T>(1, 1, 3.25), V<T>(2, 0, 0));
    CHECK(isin::normal(tris[0]).z > T(0));
    CHECK(isin::normal(tris[1]).z > T(0));
}

TEST_CASE_TEMPLATE("PLY binary little-endian: float/int32/uint8 data, lists skipped byte-exactly", T, float, double) {
    if (!host_is_little_endian()) {
        MESSAGE("skipped: the test writes the binary body in the host's byte order");
        return;
    }
    TempDir dir{"isin-test-mesh-"};
    std::string file = header({"ply",
                               "format binary_little_endian 1.0",
                               "comment a camera first, to skip",
                               "element camera 1",
                               "property double fov",
                               "property list uchar short ids",
                               "element vertex 5",
                               "property float x",
                               "property float y",
                               "property float z",
                               "property float nx",
                               "property float ny",
                               "property float nz",
                               "property uchar red",
                               "property uchar green",
                               "property uchar blue",
                               "element material 2",
                               "property list int float values",
                               "property ushort id",
                               "element face 2",
                               "property uchar flags",
                               "property list uchar int vertex_indices",
                               "property int8 tag"});
    Bytes b;
    b.put(0.75).put(std::uint8_t{3}).put(std::int16_t{-1}).put(std::int16_t{7}).put(std::int16_t{9});
    const float xyz[5][3] = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {1, 1, 3.25f}};
    for (const auto& p : xyz) {
        b.put(p[0]).put(p[1]).put(p[2]).put(0.0f).put(0.0f).put(1.0f);
        b.put(std::uint8_t{255}).put(std::uint8_t{128}).put(std::uint8_t{0});
    }
    b.put(std::int32_t{2}).put(0.5f).put(0.25f).put(std::uint16_t{1});
    b.put(std::int32_t{0}).put(std::uint16_t{2});
    b.put(std::uint8_t{0}).put(std::uint8_t{4});
    for (std::int32_t i : {0, 1, 2, 3}) b.put(i);
    b.put(std::int8_t{-5});
    b.put(std::uint8_t{1}).put(std::uint8_t{3});
    for (std::int32_t i : {0, 4, 1}) b.put(i);
    b.put(std::int8_t{6});
    file += b.data;

    const auto tris = isin::load_ply<T>(dir.put("mesh.ply", file));
    REQUIRE(tris.size() == 3);
    check_triangle(tris[0], V<T>(0, 0, 0), V<T>(2, 0, 0), V<T>(2, 2, 0));
    check_triangle(tris[1], V<T>(0, 0, 0), V<T>(2, 2, 0), V<T>(0, 2, 0));
    check_triangle(tris[2], V<T>(0, 0, 0), V<T>(1, 1, 3.25), V<T>(2, 0, 0));
    CHECK(isin::normal(tris[1]).z > T(0));
}

TEST_CASE_TEMPLATE("PLY binary: double and int16 coordinates, uint indices, a 200-gon", T, float, double) {
    if (!host_is_little_endian()) return;
    TempDir dir{"isin-test-mesh-"};
    std::string file =
        header({"ply", "format binary_little_endian 1.0", "element vertex 200", "property double z", "property int16 x",
                "property float64 y", "element face 1", "property list ushort uint vertex_index"});
    Bytes b;
    for (int i = 0; i < 200; ++i) b.put(0.5 * i).put(static_cast<std::int16_t>(-i)).put(1e-3);
    b.put(std::uint16_t{200});
    for (std::uint32_t i = 0; i < 200; ++i) b.put(i);
    const auto tris = isin::load_ply<T>(dir.put("gon.ply", file + b.data));
    REQUIRE(tris.size() == 198);
    check_triangle(tris[0], V<T>(0, 1e-3, 0), V<T>(-1, 1e-3, 0.5), V<T>(-2, 1e-3, 1));
    check_triangle(tris[197], V<T>(0, 1e-3, 0), V<T>(-198, 1e-3, 99), V<T>(-199, 1e-3, 99.5));
}

// ---- PLY: byte orders, vertex attributes, header tolerance, polygons, limits --------------------

namespace {

/// Bytes of a binary PLY body in the byte order `big` names, whatever the host's.
struct OrderedBytes {
    bool big = false;
    std::string data;
    template <class V>
    OrderedBytes& put(V v) {
        char b[sizeof v];
        std::memcpy(b, &v, sizeof v);
        if (host_is_little_endian() == big) std::reverse(b, b + sizeof v);
        data.append(b, sizeof v);
        return *this;
    }
};

/// The whole Mesh of PLY bytes (what load_model returns; load_ply keeps only the triangles).
template <class T>
isin::Mesh<T> ply_mesh(const std::string& bytes) {
    return isin::detail::parse_ply_mesh<T>("isin::load_ply", "memory", bytes);
}

template <class T>
void check_same_mesh(const isin::Mesh<T>& a, const isin::Mesh<T>& b) {
    CHECK(a.positions == b.positions);
    CHECK(a.indices == b.indices);
    CHECK(a.normals == b.normals);
    CHECK(a.uvs == b.uvs);
    CHECK(a.colors == b.colors);
    CHECK(a.material == b.material);
}

/// Sum of the triangles' areas, each counted positive.
template <class T>
T unsigned_area(const isin::Mesh<T>& mesh) {
    T sum = 0;
    for (std::size_t i = 0; i < mesh.size(); ++i) sum += isin::length(isin::normal(mesh.triangle(i))) / T(2);
    return sum;
}

// Five vertices (float x, double y, int16 z, float normal, float s t, uchar colour), a skipped
// element with a uint8-counted int16 list, a quad and a triangle. Every value is exact in binary.
struct PlyTestVertex {
    float x;
    double y;
    std::int16_t z;
    float nx, ny, nz, s, t;
    std::uint8_t red, green, blue;
};
// clang-format off
const PlyTestVertex ply_test_vertices[5] = {
    {0, 0,    0,    0,    0,     1,     0,   0,    255, 0,   0},
    {2, 0,    0,    1,    0,     0,     1,   0,    0,   255, 0},
    {2, 2,    0,    0,   -1,     0,     1,   1,    0,   0,   255},
    {0, 2,    0,    0.5f, 0.5f,  0.5f,  0,   1,    10,  20,  30},
    {1, 1.25, -300, 0.75f, 0,   -0.25f, 0.5f, 0.25f, 128, 64, 1}};
// clang-format on

/// That mesh as `format` (ascii, binary_little_endian or binary_big_endian).
std::string ply_test_file(const std::string& format) {
    const std::string format_line = "format " + format + " 1.0";
    std::string file = header({"ply", format_line.c_str(), "element vertex 5", "property float x", "property double y",
                               "property int16 z", "property float nx", "property float ny", "property float nz",
                               "property float s", "property float t", "property uchar red", "property uchar green",
                               "property uchar blue", "element edge 2", "property list uint8 int16 ids",
                               "property ushort id", "element face 2", "property list uint8 int vertex_indices"});
    if (format == "ascii") {
        for (const PlyTestVertex& v : ply_test_vertices) {
            std::ostringstream line;
            line << v.x << ' ' << v.y << ' ' << v.z << ' ' << v.nx << ' ' << v.ny << ' ' << v.nz << ' ' << v.s << ' '
                 << v.t << ' ' << int(v.red) << ' ' << int(v.green) << ' ' << int(v.blue) << '\n';
            file += line.str();
        }
        return file + "2 -1 7 300\n0 65535\n4 0 1 2 3\n3 0 4 1\n";
    }
    OrderedBytes b{format == "binary_big_endian", {}};
    for (const PlyTestVertex& v : ply_test_vertices)
        b.put(v.x).put(v.y).put(v.z).put(v.nx).put(v.ny).put(v.nz).put(v.s).put(v.t).put(v.red).put(v.green).put(
            v.blue);
    b.put(std::uint8_t{2}).put(std::int16_t{-1}).put(std::int16_t{7}).put(std::uint16_t{300});
    b.put(std::uint8_t{0}).put(std::uint16_t{65535});
    b.put(std::uint8_t{4});
    for (std::int32_t i : {0, 1, 2, 3}) b.put(i);
    b.put(std::uint8_t{3});
    for (std::int32_t i : {0, 4, 1}) b.put(i);
    return file + b.data;
}

} // namespace

TEST_CASE_TEMPLATE("PLY binary big-endian: float, double, int16 data and uint8 list counts read as little-endian "
                   "and ASCII do",
                   T, float, double) {
    const isin::Mesh<T> big = ply_mesh<T>(ply_test_file("binary_big_endian"));
    const isin::Mesh<T> little = ply_mesh<T>(ply_test_file("binary_little_endian"));
    const isin::Mesh<T> ascii = ply_mesh<T>(ply_test_file("ascii"));
    REQUIRE(big.positions.size() == 5);
    REQUIRE(big.size() == 3);
    check_same_mesh(big, little);
    check_same_mesh(big, ascii);
    CHECK(big.positions[4] == V<T>(1, 1.25, -300));
    CHECK(big.indices[2] == std::array<std::uint32_t, 3>{0, 4, 1}); // the triangle after the quad's two
    CHECK(unsigned_area(big) == doctest::Approx(4 + 0.5 * std::sqrt(600.0 * 600.0 + 2.5 * 2.5))); // quad + triangle

    // The same bytes through the file loaders: big-endian is read, not refused.
    TempDir dir{"isin-test-mesh-"};
    const auto tris = isin::load_ply<T>(dir.put("big.ply", ply_test_file("binary_big_endian")));
    REQUIRE(tris.size() == 3);
    check_triangle(tris[2], V<T>(0, 0, 0), V<T>(1, 1.25, -300), V<T>(2, 0, 0));
    CHECK(isin::load_mesh<T>(dir.put("empty.ply", "ply\nformat binary_big_endian 1.0\nend_header\n")).empty());
}

TEST_CASE_TEMPLATE("PLY big-endian: errors name the same offsets as little-endian", T, float, double) {
    for (const bool big : {false, true}) {
        CAPTURE(big);
        const std::string h = header({"ply", big ? "format binary_big_endian 1.0" : "format binary_little_endian 1.0",
                                      "element vertex 2", "property float x", "property float y", "property float z",
                                      "element face 1", "property list ushort uint vertex_indices"});
        OrderedBytes b{big, {}};
        b.put(0.0f).put(1.0f).put(2.0f).put(3.0f).put(std::numeric_limits<float>::quiet_NaN()).put(5.0f);
        CHECK(str(thrown([&] { (void)ply_mesh<T>(h + b.data); })) ==
              doctest::Contains(str("offset " + std::to_string(h.size() + 16) + ": vertex[1]: coordinate y is NaN")));
        OrderedBytes ok{big, {}};
        for (int i = 0; i < 6; ++i) ok.put(static_cast<float>(i));
        ok.put(std::uint16_t{3}).put(std::uint32_t{0}).put(std::uint32_t{1}).put(std::uint32_t{258});
        CHECK(
            str(thrown([&] { (void)ply_mesh<T>(h + ok.data); })) ==
            doctest::Contains(str("offset " + std::to_string(h.size() + 24 + 2 + 8) + ": face[0]: vertex index 258")));
    }
}

TEST_CASE_TEMPLATE("PLY vertex normals, texture coordinates and uchar colours fill the Mesh, ASCII and binary", T,
                   float, double) {
    for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
        CAPTURE(format);
        const isin::Mesh<T> mesh = ply_mesh<T>(ply_test_file(format));
        REQUIRE(mesh.normals.size() == 5);
        REQUIRE(mesh.uvs.size() == 5);
        REQUIRE(mesh.colors.size() == 5);
        CHECK(mesh.material.empty());
        for (std::size_t i = 0; i < 5; ++i) {
            const PlyTestVertex& v = ply_test_vertices[i];
            CHECK(mesh.positions[i] == isin::Vertex<T>{T(v.x), T(v.y), T(v.z)});
            CHECK(mesh.normals[i] == isin::Vertex<T>{T(v.nx), T(v.ny), T(v.nz)});
            CHECK(mesh.uvs[i] == std::array<T, 2>{T(v.s), T(v.t)});
            // uchar channels are divided by 255 (isin's linear convention for bytes)
            CHECK(mesh.colors[i] == isin::Color<T>{static_cast<T>(v.red / 255.0), static_cast<T>(v.green / 255.0),
                                                   static_cast<T>(v.blue / 255.0)});
        }
        CHECK(mesh.colors[0] == isin::Color<T>{1, 0, 0});
        CHECK_NOTHROW(mesh.validate());
    }
}

TEST_CASE_TEMPLATE("PLY texture coordinates: s/t, u/v, texture_u/texture_v, texture_s/texture_t; the first pair in "
                   "the header wins",
                   T, float, double) {
    const char* const pairs[4][2] = {{"s", "t"}, {"u", "v"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
    for (const auto& pair : pairs) {
        for (const bool binary : {false, true}) {
            CAPTURE(pair[0]);
            CAPTURE(binary);
            const std::string u = std::string("property float ") + pair[0],
                              v = std::string("property double ") + pair[1];
            // the coordinates between x, y, z and in either order: v before u
            std::string file =
                header({"ply", binary ? "format binary_little_endian 1.0" : "format ascii 1.0", "element vertex 2",
                        "property float x", v.c_str(), "property float y", u.c_str(), "property float z"});
            if (binary) {
                OrderedBytes b{false, {}};
                b.put(1.0f).put(0.75).put(2.0f).put(0.5f).put(3.0f);
                b.put(4.0f).put(-2.5).put(5.0f).put(1.25f).put(6.0f);
                file += b.data;
            } else {
                file += "1 0.75 2 0.5 3\n4 -2.5 5 1.25 6\n";
            }
            const isin::Mesh<T> mesh = ply_mesh<T>(file);
            REQUIRE(mesh.uvs.size() == 2);
            CHECK(mesh.uvs[0] == std::array<T, 2>{T(0.5), T(0.75)});
            CHECK(mesh.uvs[1] == std::array<T, 2>{T(1.25), T(-2.5)});
            CHECK(mesh.positions[1] == V<T>(4, 5, 6));
            CHECK(mesh.normals.empty());
            CHECK(mesh.colors.empty());
        }
    }
    // Two complete pairs: the one met first in the header (texture_u/texture_v), not the first of the list above.
    const isin::Mesh<T> both =
        ply_mesh<T>(header({"ply", "format ascii 1.0", "element vertex 1", "property float x", "property float y",
                            "property float z", "property float texture_u", "property float s", "property float t",
                            "property float texture_v"}) +
                    "0 0 0 0.25 7 8 0.5\n");
    REQUIRE(both.uvs.size() == 1);
    CHECK(both.uvs[0] == std::array<T, 2>{T(0.25), T(0.5)});
    // A lone u (its v missing) is no texture coordinate: skipped.
    CHECK(ply_mesh<T>(header({"ply", "format ascii 1.0", "element vertex 1", "property float x", "property float u",
                              "property float y", "property float z", "property float t"}) +
                      "1 2 3 4 5\n")
              .uvs.empty());
}

TEST_CASE_TEMPLATE("PLY colours: float taken as is, ushort divided by 65535, alpha ignored", T, float, double) {
    for (const bool binary : {false, true}) {
        CAPTURE(binary);
        std::string file =
            header({"ply", binary ? "format binary_big_endian 1.0" : "format ascii 1.0", "element vertex 2",
                    "property float x", "property float y", "property float z", "property float red",
                    "property double green", "property ushort blue", "property uchar alpha"});
        if (binary) {
            OrderedBytes b{true, {}};
            b.put(0.0f).put(0.0f).put(0.0f).put(0.25f).put(1.0).put(std::uint16_t{65535}).put(std::uint8_t{7});
            b.put(1.0f).put(0.0f).put(0.0f).put(0.0f).put(0.5).put(std::uint16_t{0}).put(std::uint8_t{255});
            file += b.data;
        } else {
            file += "0 0 0 0.25 1 65535 7\n1 0 0 0 0.5 0 255\n";
        }
        const isin::Mesh<T> mesh = ply_mesh<T>(file);
        REQUIRE(mesh.colors.size() == 2);
        CHECK(mesh.colors[0] == isin::Color<T>{T(0.25), T(1), T(1)});
        CHECK(mesh.colors[1] == isin::Color<T>{T(0), T(0.5), T(0)});
    }
}

TEST_CASE("PLY: partial normals (nx, ny only) and partial colours are ignored, the positions read") {
    const isin::Mesh<double> mesh =
        ply_mesh<double>(header({"ply", "format ascii 1.0", "element vertex 3", "property float x", "property float y",
                                 "property float z", "property float nx", "property float ny", "property uchar red",
                                 "property uchar green", "element face 1", "property list uchar int vertex_indices"}) +
                         "0 0 0 0 1 1 2\n1 0 0 0 1 3 4\n0 1 0 0 1 5 6\n3 0 1 2\n");
    CHECK(mesh.normals.empty());
    CHECK(mesh.colors.empty());
    CHECK(mesh.uvs.empty());
    REQUIRE(mesh.positions.size() == 3);
    CHECK(mesh.positions[2] == V<double>(0, 1, 0));
    CHECK(mesh.size() == 1);
    // nz as a list is no normal component either
    CHECK(ply_mesh<float>(
              header({"ply", "format ascii 1.0", "element vertex 1", "property float x", "property float y",
                      "property float z", "property float nx", "property float ny", "property list uchar float nz"}) +
              "0 0 0 1 0 2 0.5 0.5\n")
              .normals.empty());
}

TEST_CASE_TEMPLATE("PLY: NaN, infinite and out-of-range attributes become 0 (a zero normal: no usable normal)", T,
                   float, double) {
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    const std::string h = header({"ply", "format ascii 1.0", "element vertex 5", "property float x", "property float y",
                                  "property float z", "property double nx", "property double ny", "property double nz",
                                  "property double u", "property double v", "property double red",
                                  "property double green", "property double blue"});
    const std::string ascii = h + "0 0 0  nan 0 1      0.5 0.5   0.5 0.5 0.5\n"
                                  "1 0 0  0 0 1        inf 0.5   0.5 0.5 -inf\n"
                                  "0 1 0  0 1e999 1    0.5 NaN   1e-999 0.5 0.5\n"
                                  "1 1 0  1e300 0 0    -1e300 0  0.25 1e300 0\n"
                                  "2 2 0  0 0 -1       0.125 1   1 1 1\n";
    OrderedBytes b{true, {}};
    const double values[5][8] = {{nan, 0, 1, 0.5, 0.5, 0.5, 0.5, 0.5},
                                 {0, 0, 1, inf, 0.5, 0.5, 0.5, -inf},
                                 {0, inf, 1, 0.5, nan, 0, 0.5, 0.5},
                                 {1e300, 0, 0, -1e300, 0, 0.25, 1e300, 0},
                                 {0, 0, -1, 0.125, 1, 1, 1, 1}};
    const float xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 2, 0}};
    for (int i = 0; i < 5; ++i) {
        for (const float c : xyz[i]) b.put(c);
        for (const double a : values[i]) b.put(a);
    }
    std::string big = h;
    big.replace(big.find("ascii"), 5, "binary_big_endian");
    for (const std::string& file : {ascii, big + b.data}) {
        const isin::Mesh<T> mesh = ply_mesh<T>(file);
        REQUIRE(mesh.normals.size() == 5);
        const isin::Vertex<T> zero{0, 0, 0};
        CHECK(mesh.normals[0] == zero); // NaN component
        CHECK(mesh.normals[1] == V<T>(0, 0, 1));
        CHECK(mesh.normals[2] == zero); // infinite component
        CHECK(mesh.uvs[0] == std::array<T, 2>{T(0.5), T(0.5)});
        CHECK(mesh.uvs[1] == std::array<T, 2>{T(0), T(0)});
        CHECK(mesh.uvs[2] == std::array<T, 2>{T(0), T(0)});
        CHECK(mesh.colors[1] == isin::Color<T>{0, 0, 0});
        CHECK(mesh.colors[2] == isin::Color<T>{0, T(0.5), T(0.5)}); // 1e-999 underflows to 0: a fine value
        if (std::is_same_v<T, float>) {                             // 1e300 does not fit a float
            CHECK(mesh.normals[3] == zero);
            CHECK(mesh.uvs[3] == std::array<T, 2>{T(0), T(0)});
            CHECK(mesh.colors[3] == isin::Color<T>{0, 0, 0});
        } else {
            CHECK(mesh.normals[3] == V<T>(1e300, 0, 0));
            CHECK(mesh.uvs[3] == std::array<T, 2>{T(-1e300), T(0)});
            CHECK(mesh.colors[3] == isin::Color<T>{T(0.25), T(1e300), T(0)});
        }
        CHECK(mesh.normals[4] == V<T>(0, 0, -1));
        CHECK(mesh.uvs[4] == std::array<T, 2>{T(0.125), T(1)});
        CHECK(mesh.colors[4] == isin::Color<T>{1, 1, 1});
    }
    // Positions stay strict.
    std::string one = h;
    one.replace(one.find("vertex 5"), 8, "vertex 1");
    CHECK(str(thrown([&] { (void)ply_mesh<T>(one + "0 nan 0 0 0 1 0 0 0 0 0\n"); })) ==
          doctest::Contains("line 16: vertex[0]: coordinate y is NaN"));
}

TEST_CASE("PLY: unknown header lines after the format line are skipped (obj_info, Blender's, made-up ones)") {
    const std::string file = "ply\n"
                             "format ascii 1.0\n"
                             "comment made by hand\n"
                             "obj_info num_cols 2\n"
                             "blender_export_settings foo\n"
                             "element vertex 3\n"
                             "property float x\n"
                             "my_exporter_note vertices are in metres\n"
                             "property float y\n"
                             "property float z\n"
                             "element face 1\n"
                             "\n"
                             "property list uchar int vertex_indices\n"
                             "end_header\n"
                             "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const isin::Mesh<float> mesh = ply_mesh<float>(file);
    REQUIRE(mesh.positions.size() == 3);
    CHECK(mesh.positions[1] == V<float>(1, 0, 0));
    REQUIRE(mesh.size() == 1);
    CHECK(mesh.indices[0] == std::array<std::uint32_t, 3>{0, 1, 2});
    TempDir dir{"isin-test-mesh-"};
    CHECK(isin::load_ply<double>(dir.put("blender.ply", file)).size() == 1);
    // A misspelt keyword is one of them, so what follows it belongs to the element before.
    CHECK(str(thrown([&] {
              (void)ply_mesh<float>("ply\nformat ascii 1.0\nelemnt vertex 1\nproperty float x\n"
                                    "end_header\n");
          })) == doctest::Contains("line 4: property before any element"));
}

TEST_CASE("PLY face lists: any integer count type, any integer index type, either byte order") {
    const char* const types[] = {"char", "uchar", "short", "ushort", "int", "uint", "int8", "uint32"};
    for (const char* count : types) {
        for (const char* index : types) {
            for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
                CAPTURE(count);
                CAPTURE(index);
                CAPTURE(format);
                const std::string format_line = std::string("format ") + format + " 1.0";
                const std::string list = std::string("property list ") + count + " " + index + " vertex_index";
                std::string file =
                    header({"ply", format_line.c_str(), "element face 1", list.c_str(), "element vertex 4",
                            "property uchar x", "property uchar y", "property uchar z"});
                const auto put = [&](OrderedBytes& b, const char* type, int v) {
                    const std::string t = type;
                    if (t == "char" || t == "int8") b.put(static_cast<std::int8_t>(v));
                    if (t == "uchar") b.put(static_cast<std::uint8_t>(v));
                    if (t == "short") b.put(static_cast<std::int16_t>(v));
                    if (t == "ushort") b.put(static_cast<std::uint16_t>(v));
                    if (t == "int") b.put(static_cast<std::int32_t>(v));
                    if (t == "uint" || t == "uint32") b.put(static_cast<std::uint32_t>(v));
                };
                if (std::string(format) == "ascii") {
                    file += "4 3 2 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
                } else {
                    OrderedBytes b{std::string(format) == "binary_big_endian", {}};
                    put(b, count, 4);
                    for (const int i : {3, 2, 1, 0}) put(b, index, i);
                    for (const int c : {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}) b.put(static_cast<std::uint8_t>(c));
                    file += b.data;
                }
                const isin::Mesh<double> mesh = ply_mesh<double>(file);
                REQUIRE(mesh.size() == 2);
                CHECK(mesh.positions[2] == V<double>(1, 1, 0));
                CHECK(unsigned_area(mesh) == 1.0);
                for (std::size_t i = 0; i < 2; ++i) CHECK(isin::normal(mesh.triangle(i)).z < 0.0); // clockwise kept
            }
        }
    }
}

TEST_CASE_TEMPLATE("PLY: concave L-shaped hexagons (faces before vertices) become triangles of their area", T, float,
                   double) {
    // Each L is counter-clockwise seen from +z and listed from a corner whose fan folds over the
    // reflex corner (1,1). The first has no three corners on a line: every piece has area > 0.
    // The second, (0,0) (2,0) (2,1) (1,1) (1,2) (0,2) from (2,1), has (0,2), (1,1), (2,0) on one
    // line: a zero-area piece along it still adds up.
    struct Case {
        float corners[6][2];
        double area, fan_area; // the polygon's, and the sum of its fan's unsigned areas
        bool strict;
    };
    const Case cases[2] = {{{{3, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}, {3, 0}}, 4, 6, true},
                           {{{2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}}, 3, 4, false}};
    const std::string h_ascii =
        header({"ply", "format ascii 1.0", "element face 1", "property list uchar int vertex_indices",
                "element vertex 6", "property float x", "property float y", "property float z"});
    std::string h_big = h_ascii;
    h_big.replace(h_big.find("ascii"), 5, "binary_big_endian");
    for (const Case& c : cases) {
        std::ostringstream ascii;
        ascii << h_ascii << "6 0 1 2 3 4 5\n";
        OrderedBytes b{true, {}};
        b.put(std::uint8_t{6});
        for (std::int32_t i = 0; i < 6; ++i) b.put(i);
        for (const auto& p : c.corners) {
            ascii << p[0] << ' ' << p[1] << " 0\n";
            b.put(p[0]).put(p[1]).put(0.0f);
        }
        for (const std::string& file : {ascii.str(), h_big + b.data}) {
            CAPTURE(c.area);
            const isin::Mesh<T> mesh = ply_mesh<T>(file);
            REQUIRE(mesh.size() == 4);
            CHECK(unsigned_area(mesh) == doctest::Approx(c.area).epsilon(1e-6)); // the fan would give fan_area
            CHECK(c.fan_area != c.area);
            for (std::size_t i = 0; i < mesh.size(); ++i) {
                CAPTURE(i);
                const T z = isin::normal(mesh.triangle(i)).z; // the polygon's winding
                if (c.strict)
                    CHECK(z > T(0));
                else
                    CHECK(z >= T(0));
            }
        }
    }
}

TEST_CASE("PLY: more than 2^32 - 1 vertices is a MeshError naming the count, before any data is read") {
    for (const char* format : {"format ascii 1.0", "format binary_little_endian 1.0", "format binary_big_endian 1.0"}) {
        CAPTURE(format);
        const std::string h = header(
            {"ply", format, "element vertex 4294967296", "property float x", "property float y", "property float z"});
        const std::string why = thrown([&] { (void)ply_mesh<float>(h + std::string(64, '\0')); });
        CHECK(str(why) == doctest::Contains("line 3: element 'vertex' declares 4294967296 vertices"));
        CHECK(str(why) == doctest::Contains("2^32 - 1"));
        // 2^32 - 1 itself passes this check, then fails the one on the bytes that follow
        const std::string h1 = header(
            {"ply", format, "element vertex 4294967295", "property float x", "property float y", "property float z"});
        CHECK(str(thrown([&] { (void)ply_mesh<float>(h1 + std::string(64, '\0')); })) ==
              doctest::Contains("truncated"));
    }
    CHECK(str(thrown([&] {
              (void)ply_mesh<double>(
                  header({"ply", "format binary_big_endian 1.0", "element vertex 18446744073709551615",
                          "property uchar x", "property uchar y", "property uchar z"}));
          })) == doctest::Contains("18446744073709551615 vertices"));
}

TEST_CASE("load_mesh: chooses the reader by extension, in any letter case") {
    TempDir dir{"isin-test-mesh-"};
    CHECK(isin::load_mesh<float>(dir.put("a.obj", polygons_obj)).size() == 7);
    CHECK(isin::load_mesh<double>(dir.put("B.OBJ", polygons_obj)).size() == 7);
    // The content must match the extension: a PLY named .obj is read as OBJ (no faces there).
    CHECK(isin::load_mesh<float>(dir.put("e.obj", ascii_ply)).empty());
    CHECK(isin::load_mesh<float>(dir.put("c.ply", ascii_ply)).size() == 3);
    CHECK(isin::load_mesh<double>(dir.put("D.PlY", ascii_ply)).size() == 3);
    const std::string stl = dir.put("f.stl", "solid x\n");
    CHECK_THROWS_WITH_AS((void)isin::load_mesh<float>(stl), doctest::Contains(str(stl)), std::invalid_argument);
    CHECK_THROWS_AS((void)isin::load_mesh<float>(dir.put("obj", polygons_obj)), std::invalid_argument);
    CHECK_THROWS_AS((void)isin::load_mesh<float>(dir.put("g.obj.txt", polygons_obj)), std::invalid_argument);
}

TEST_CASE("missing or unreadable files throw MeshError naming the path") {
    TempDir dir{"isin-test-mesh-"};
    const std::string ply = (dir.path / "nothing.ply").string();
    const std::string a = thrown([&] { (void)isin::load_mesh<float>(ply); });
    CHECK(str(a) == doctest::Contains(str(ply)));
    CHECK(str(a) == doctest::Contains("cannot open"));
    const std::string d = thrown([&] { (void)isin::load_ply<double>(dir.path.string()); }); // a directory
    CHECK(str(d) == doctest::Contains(str(dir.path.string())));
    const std::string obj = (dir.path / "nothing.obj").string();
    CHECK(str(thrown([&] { (void)isin::load_obj<double>(obj); })) == doctest::Contains(str(obj)));
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(dir.path.string()); })) ==
          doctest::Contains(str(dir.path.string())));
    static_assert(std::is_base_of_v<std::runtime_error, isin::MeshError>);
}

TEST_CASE("OBJ: an index out of range names the file and the face's line") {
    TempDir dir{"isin-test-mesh-"};
    const std::string base = "v 0 0 0\nv 1 0 0\n# a comment\nv 0 1 0\n";
    const std::string too_big = dir.put("big.obj", base + "f 1 2 3\nf 1 2 4\n");
    std::string why = thrown([&] { (void)isin::load_obj<float>(too_big); });
    CHECK(str(why) == doctest::Contains(str(too_big)));
    CHECK(str(why) == doctest::Contains("line 6"));
    CHECK(str(why) == doctest::Contains("vertex index 4 is out of range"));

    const std::string too_far_back = dir.put("back.obj", base + "\n\nf -1 -2 -4\n");
    why = thrown([&] { (void)isin::load_obj<double>(too_far_back); });
    CHECK(str(why) == doctest::Contains("line 7"));
    CHECK(str(why) == doctest::Contains("-4"));

    // Relative indices count only the vertices read so far.
    const std::string early = dir.put("early.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(early); })) == doctest::Contains("line 3"));

    // Two faces out of range, a forward one first: the first in the file is named.
    const std::string two = dir.put("two.obj", base + "f 1 2 9\nf -9 1 2\n");
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(two); })) == doctest::Contains("line 5"));
    const std::string two_back = dir.put("two_back.obj", base + "f -9 1 2\nf 1 2 9\n");
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(two_back); })) == doctest::Contains("line 5"));

    const std::string crlf = dir.put("crlf.obj", "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\n\r\nf 1 2 9\r\n");
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(crlf); })) == doctest::Contains("line 5"));

    const std::string zero = dir.put("zero.obj", base + "f 0 1 2\n");
    why = thrown([&] { (void)isin::load_obj<float>(zero); });
    CHECK(str(why) == doctest::Contains("line 5"));
    CHECK(str(why) == doctest::Contains("index 0"));

    const std::string huge = dir.put("huge.obj", base + "f 1 2 4294967297\n"); // atoi would wrap it to 1
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(huge); })) == doctest::Contains("out of range"));
}

TEST_CASE("OBJ: faces with fewer than 3 vertices and malformed references throw with the line") {
    TempDir dir{"isin-test-mesh-"};
    const std::string base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    std::string why = thrown([&] { (void)isin::load_obj<float>(dir.put("two.obj", base + "f 1 2\n")); });
    CHECK(str(why) == doctest::Contains("line 4"));
    CHECK(str(why) == doctest::Contains("needs at least 3"));
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(dir.put("none.obj", base + "f \n")); })) ==
          doctest::Contains("line 4"));
    why = thrown([&] { (void)isin::load_obj<float>(dir.put("junk.obj", base + "f 1 2 x\n")); });
    CHECK(str(why) == doctest::Contains("line 4"));
    CHECK(str(why) == doctest::Contains("'x'"));
    CHECK_THROWS_AS((void)isin::load_obj<float>(dir.put("slash.obj", base + "f 1/ 2 3\n")), isin::MeshError);
    CHECK_THROWS_AS((void)isin::load_obj<float>(dir.put("four.obj", base + "f 1/1/1/1 2 3\n")), isin::MeshError);
    CHECK_THROWS_AS((void)isin::load_obj<float>(dir.put("trail.obj", base + "f 1 2 3 # c\n")), isin::MeshError);
}

TEST_CASE("OBJ: NaN, infinite, malformed or out-of-range coordinates throw with the line") {
    TempDir dir{"isin-test-mesh-"};
    const auto why = [&](const std::string& name, const std::string& text) {
        return str(thrown([&] { (void)isin::load_obj<float>(dir.put(name, text)); }));
    };
    CHECK(why("nan.obj", "v 0 0 0\nv nan 1 2\nv 1 1 1\nf 1 2 3\n") == doctest::Contains("line 2"));
    CHECK(why("nan2.obj", "v 0 0 0\nv 0 1 -NaN\n") == doctest::Contains("NaN"));
    CHECK(why("inf.obj", "\n\nv inf 0 0\n") == doctest::Contains("line 3"));
    CHECK(why("inf2.obj", "v 0 0 -Infinity\n") == doctest::Contains("infinite"));
    CHECK(why("abc.obj", "v 1 abc 3\n") == doctest::Contains("malformed number 'abc'"));
    CHECK(why("comma.obj", "v 0 0 0\nv 1,5 0 0\n") == doctest::Contains("line 2"));
    CHECK(why("short.obj", "v 1 2\n") == doctest::Contains("needs 3"));
    CHECK(why("e999.obj", "v 1e999 0 0\n") == doctest::Contains("out of range"));
    CHECK(why("e999.obj", "v 1e999 0 0\n") == doctest::Contains("line 1"));
    CHECK_NOTHROW((void)isin::load_obj<float>(dir.put("tiny.obj", "v 1e-999 0 0 # underflows to 0\n")));
}

TEST_CASE_TEMPLATE("OBJ: numbers tinyobjloader's arithmetic gets wrong are reread by isin", T, float, double) {
    TempDir dir{"isin-test-mesh-"};
    // tinyobjloader computes 0·5^500 = 0·inf = NaN for "0e500"; the text is a plain zero.
    const auto tris = isin::load_obj<T>(dir.put("zero.obj", "v 0e500 1 2\nv 1 0 0\nv -0.0e+999 1 0\nf 1 2 3\n"));
    REQUIRE(tris.size() == 1);
    check_triangle(tris[0], V<T>(0, 1, 2), V<T>(1, 0, 0), V<T>(0, 1, 0));
}

TEST_CASE("OBJ and PLY: 1e300 does not fit a float (line named) but loads as a double") {
    TempDir dir{"isin-test-mesh-"};
    const std::string obj = dir.put("big.obj", "v 0 0 0\nv 1 0 0\nv 1e300 1 0\nf 1 2 3\n");
    const std::string why = thrown([&] { (void)isin::load_obj<float>(obj); });
    CHECK(str(why) == doctest::Contains("line 3"));
    CHECK(str(why) == doctest::Contains("does not fit in float"));
    const auto tris = isin::load_obj<double>(obj);
    REQUIRE(tris.size() == 1);
    CHECK(tris[0].v2.x == doctest::Approx(1e300));

    const std::string ply = dir.put(
        "big.ply", header({"ply", "format ascii 1.0", "element vertex 3", "property double x", "property double y",
                           "property double z", "element face 1", "property list uchar int vertex_indices"}) +
                       "0 0 0\n1 0 0\n0 -1e300 0\n3 0 1 2\n");
    const std::string why_ply = thrown([&] { (void)isin::load_ply<float>(ply); });
    CHECK(str(why_ply) == doctest::Contains("line 12"));
    CHECK(str(why_ply) == doctest::Contains("does not fit in float"));
    CHECK(isin::load_ply<double>(ply).at(0).v2.y == doctest::Approx(-1e300));

    if (host_is_little_endian()) {
        const std::string bin =
            dir.put("big_bin.ply", header({"ply", "format binary_little_endian 1.0", "element vertex 1",
                                           "property double x", "property double y", "property double z"}) +
                                       Bytes{}.put(0.0).put(1e300).put(0.0).data);
        const std::string h = header({"ply", "format binary_little_endian 1.0", "element vertex 1", "property double x",
                                      "property double y", "property double z"});
        CHECK(str(thrown([&] { (void)isin::load_ply<float>(bin); })) ==
              doctest::Contains(str("offset " + std::to_string(h.size() + 8))));
    }
}

TEST_CASE("PLY: a huge count in the header with little data throws at once, allocating nothing big") {
    TempDir dir{"isin-test-mesh-"};
    const auto begin = std::chrono::steady_clock::now();
    const std::string ascii =
        dir.put("huge.ply",
                header({"ply", "format ascii 1.0", "element vertex 4000000000", "property float x", "property float y",
                        "property float z", "element face 4000000000", "property list uchar int vertex_indices"}) +
                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    std::string why = thrown([&] { (void)isin::load_ply<float>(ascii); });
    CHECK(str(why) == doctest::Contains("truncated"));
    CHECK(str(why) == doctest::Contains("4000000000"));

    const std::string h = header({"ply", "format binary_little_endian 1.0", "element vertex 4000000000",
                                  "property float x", "property float y", "property float z"});
    const std::string binary = dir.put("huge_bin.ply", h + std::string(36, '\0'));
    why = thrown([&] { (void)isin::load_ply<double>(binary); });
    CHECK(str(why) == doctest::Contains(str("truncated at offset " + std::to_string(h.size()))));
    CHECK(str(why) == doctest::Contains("4000000000"));

    // A face claiming 4e9 indices, with 12 bytes behind it.
    const std::string hf =
        header({"ply", "format binary_little_endian 1.0", "element vertex 3", "property uchar x", "property uchar y",
                "property uchar z", "element face 1", "property list uint int vertex_indices"});
    const std::string list =
        dir.put("huge_list.ply",
                hf + std::string(9, '\0') + Bytes{}.put(std::uint32_t{4000000000u}).data + std::string(12, '\0'));
    why = thrown([&] { (void)isin::load_ply<float>(list); });
    CHECK(str(why) == doctest::Contains(str("truncated at offset " + std::to_string(hf.size() + 9 + 4))));

    // And a list to skip that claims 4e9 items.
    const std::string ha = header({"ply", "format ascii 1.0", "element junk 1", "property list uint int v"});
    CHECK(str(thrown([&] { (void)isin::load_ply<float>(dir.put("skip.ply", ha + "4000000000 1 2 3\n")); })) ==
          doctest::Contains("truncated"));
    CHECK(std::chrono::steady_clock::now() - begin < std::chrono::seconds(5));
}

TEST_CASE("PLY: an index out of range names the line (ASCII) or byte offset (binary)") {
    TempDir dir{"isin-test-mesh-"};
    const std::string h = header({"ply", "format ascii 1.0", "element vertex 4", "property float x", "property float y",
                                  "property float z", "element face 2", "property list uchar int vertex_indices"});
    const std::string ascii = dir.put("range.ply", h + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n\n3 0 2 4\n");
    std::string why = thrown([&] { (void)isin::load_ply<float>(ascii); });
    CHECK(str(why) == doctest::Contains(str(ascii)));
    CHECK(str(why) == doctest::Contains("line 16"));
    CHECK(str(why) == doctest::Contains("vertex index 4 is out of range"));
    CHECK(str(thrown([&] {
              (void)isin::load_ply<float>(dir.put("neg.ply", h + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                                                                 "3 0 -1 2\n3 0 1 2\n"));
          })) == doctest::Contains("line 14"));

    if (host_is_little_endian()) {
        const std::string hb = header({"ply", "format binary_little_endian 1.0", "element vertex 3", "property float x",
                                       "property float y", "property float z", "element face 1",
                                       "property list uchar int vertex_indices"});
        Bytes b;
        for (int i = 0; i < 9; ++i) b.put(static_cast<float>(i));
        b.put(std::uint8_t{3}).put(std::int32_t{0}).put(std::int32_t{1}).put(std::int32_t{3});
        why = thrown([&] { (void)isin::load_ply<float>(dir.put("range_bin.ply", hb + b.data)); });
        CHECK(str(why) == doctest::Contains(str("offset " + std::to_string(hb.size() + 36 + 1 + 8))));
        CHECK(str(why) == doctest::Contains("out of range"));
    }
}

TEST_CASE("PLY: truncated data throws 'truncated at offset N' (binary) or at a line (ASCII)") {
    TempDir dir{"isin-test-mesh-"};
    const std::string hb =
        header({"ply", "format binary_little_endian 1.0", "element vertex 3", "property float x", "property float y",
                "property float z", "element face 1", "property list uchar int vertex_indices"});
    Bytes b;
    for (int i = 0; i < 9; ++i) b.put(static_cast<float>(i));
    b.put(std::uint8_t{3}).put(std::int32_t{0}).put(std::int32_t{1}).put(std::int32_t{2});
    CHECK(isin::load_ply<float>(dir.put("whole.ply", hb + b.data)).size() == 1);
    // Cut inside the face's index list, then inside the second vertex.
    std::string why = thrown([&] { (void)isin::load_ply<float>(dir.put("cut1.ply", hb + b.data.substr(0, 46))); });
    CHECK(str(why) == doctest::Contains(str("truncated at offset " + std::to_string(hb.size() + 37))));
    why = thrown([&] { (void)isin::load_ply<float>(dir.put("cut2.ply", hb + b.data.substr(0, 18))); });
    CHECK(str(why) == doctest::Contains("truncated at offset"));

    const std::string ha =
        header({"ply", "format ascii 1.0", "element vertex 3", "property float x", "property float y",
                "property float z", "element face 1", "property list uchar int vertex_indices"});
    why = thrown([&] { (void)isin::load_ply<float>(dir.put("cut.ply", ha + "0 0 0\n1 0 0\n0 1 0\n3 0 1")); });
    CHECK(str(why) == doctest::Contains("truncated at line 13"));
    why = thrown([&] { (void)isin::load_ply<float>(dir.put("extra.ply", ha + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n7\n")); });
    CHECK(str(why) == doctest::Contains("line 14"));
    CHECK(str(why) == doctest::Contains("unexpected data"));
}

TEST_CASE("PLY: bad headers and unsupported formats throw with the line") {
    TempDir dir{"isin-test-mesh-"};
    const auto why = [&](const std::string& name, const std::string& text) {
        return str(thrown([&] { (void)isin::load_ply<float>(dir.put(name, text)); }));
    };
    CHECK(why("magic.ply", "plx\nformat ascii 1.0\nend_header\n") == doctest::Contains("not a PLY file"));
    CHECK(why("empty.ply", "") == doctest::Contains("not a PLY file"));
    CHECK(why("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n") ==
          doctest::Contains("line 4: unknown property type 'flaot'"));
    CHECK(why("end.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n") ==
          doctest::Contains("end_header"));
    CHECK(why("count.ply", "ply\nformat ascii 1.0\nelement vertex -5\nend_header\n") ==
          doctest::Contains("line 3: bad element count"));
    CHECK(why("orphan.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n") == doctest::Contains("line 3"));
    // Unknown keywords are skipped after the format line (see the test of Blender's line), not before.
    CHECK(why("keyword.ply", "ply\nelemnt vertex 1\nformat ascii 1.0\nend_header\n") ==
          doctest::Contains("line 2: unknown header keyword 'elemnt' before the format line"));
    CHECK(why("noformat.ply", "ply\nelement vertex 0\nend_header\n") == doctest::Contains("format"));
    CHECK(why("version.ply", "ply\nformat ascii 2.0\nend_header\n") == doctest::Contains("line 2"));
    CHECK(why("noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                         "end_header\n1 2\n") == doctest::Contains("line 3: element 'vertex' has no property z"));
    CHECK(why("floatidx.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar float vertex_indices\n"
                              "end_header\n") == doctest::Contains("line 4"));
    CHECK(why("middle.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n") ==
          doctest::Contains("line 2: unknown PLY format 'binary_middle_endian'"));
    CHECK(why("format.ply", "ply\nformat ascii\nend_header\n") == doctest::Contains("line 2: malformed format line"));
    CHECK(why("element.ply", "ply\nformat ascii 1.0\nelement vertex\nend_header\n") ==
          doctest::Contains("line 3: malformed element line"));
    CHECK(why("property.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float\nend_header\n") ==
          doctest::Contains("line 4: malformed property line"));
    CHECK(why("list.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar vertex_indices\nend_header\n") ==
          doctest::Contains("line 4: malformed property list line"));
    CHECK(why("end_header.ply", "ply\nformat ascii 1.0\nend_header now\n") ==
          doctest::Contains("line 3: malformed end_header line"));
}

TEST_CASE("PLY: NaN coordinates, short faces and malformed numbers throw with their position") {
    TempDir dir{"isin-test-mesh-"};
    const std::string ha =
        header({"ply", "format ascii 1.0", "element vertex 3", "property float x", "property float y",
                "property float z", "element face 1", "property list uchar int vertex_indices"});
    const auto why = [&](const std::string& name, const std::string& text) {
        return str(thrown([&] { (void)isin::load_ply<double>(dir.put(name, text)); }));
    };
    CHECK(why("nan.ply", ha + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n") == doctest::Contains("line 11"));
    CHECK(why("nan.ply", ha + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n") == doctest::Contains("NaN"));
    CHECK(why("inf.ply", ha + "0 0 0\n1 0 0\n0 1 -inf\n3 0 1 2\n") == doctest::Contains("infinite"));
    CHECK(why("short.ply", ha + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n") == doctest::Contains("needs at least 3"));
    CHECK(why("dots.ply", ha + "0 0 0\n1.2.3 0 0\n0 1 0\n3 0 1 2\n") == doctest::Contains("line 11"));
    CHECK(why("uchar.ply", ha + "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n") == doctest::Contains("out of range"));
    if (host_is_little_endian()) {
        const std::string hb = header({"ply", "format binary_little_endian 1.0", "element vertex 2", "property float x",
                                       "property float y", "property float z"});
        Bytes b;
        b.put(0.0f).put(0.0f).put(0.0f).put(1.0f).put(std::numeric_limits<float>::quiet_NaN()).put(0.0f);
        const doctest::String w = why("nan_bin.ply", hb + b.data);
        CHECK(w == doctest::Contains(str("offset " + std::to_string(hb.size() + 16))));
        CHECK(w == doctest::Contains("NaN"));
    }
}

// ---- hardening -----------------------------------------------------------------------------------

TEST_CASE("OBJ: exponents tinyobjloader's guard lets overflow are refused, on v, vn and vt lines (D8)") {
    // Its exponent accumulates in an int guarded one step too late: "1e-2147483648" overflowed
    // it (undefined behaviour). isin took the number (it underflows to 0) and did not look at
    // vn/vt lines at all.
    const std::string data = ISIN_TEST_DATA_DIR;
    CHECK(str(thrown([&] { (void)isin::load_obj<float>(data + "/repro/obj_exponent_overflow.obj"); })) ==
          doctest::Contains("line 1: exponent"));
    CHECK(str(thrown([&] { (void)isin::load_obj<double>(data + "/repro/obj_exponent_overflow_fuzzer.obj"); })) ==
          doctest::Contains("exponent"));
    TempDir dir{"isin-test-mesh-"};
    const auto why = [&](const std::string& name, const std::string& text) {
        return str(thrown([&] { (void)isin::load_obj<float>(dir.put(name, text)); }));
    };
    CHECK(why("vn.obj", "v 0 0 0\nvn 0 1e-2147483648 0\n") == doctest::Contains("line 2: exponent"));
    CHECK(why("vt.obj", "vt 1E+99999999999 0\n") == doctest::Contains("exponent"));
    CHECK(why("long.obj", "v 0 0 0." + std::string(5000, '1') + "\n") == doctest::Contains("longer than"));
    CHECK(why("vtindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/99999999999 2 3\n") == doctest::Contains("out of range"));
    CHECK(why("vnindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//-99999999999 2 3\n") ==
          doctest::Contains("out of range"));
    // nine significant exponent digits (and any number of leading zeros) are fine
    const auto tris = isin::load_obj<float>(dir.put("ok.obj", "v 0 0 1e-000000000000999999999\nvn 0 0 1e-999999999\n"
                                                              "v 1 0 0\nv 0 1 0\nf 1 2 3\n"));
    REQUIRE(tris.size() == 1);
    CHECK(tris[0].v0.z == 0.0f);
}

TEST_CASE_TEMPLATE("load_mesh_from_memory reads what load_mesh reads, naming its source in errors", T, float, double) {
    TempDir dir{"isin-test-mesh-"};
    const std::string ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const auto from_file = isin::load_mesh<T>(dir.put("a.ply", ply));
    const auto from_memory = isin::load_mesh_from_memory<T>(ply.data(), ply.size(), isin::MeshFormat::ply);
    REQUIRE(from_memory.size() == 1);
    CHECK(from_memory[0].v1.x == from_file[0].v1.x);
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n";
    CHECK(isin::load_mesh_from_memory<T>(obj.data(), obj.size(), isin::MeshFormat::obj).size() == 2);
    const std::string bad = "v 0 0 0\nf 1 2 3\n";
    CHECK(str(thrown([&] {
              (void)isin::load_mesh_from_memory<T>(bad.data(), bad.size(), isin::MeshFormat::obj, "socket 7");
          })) == doctest::Contains("'socket 7': line 2"));
    CHECK(str(thrown([&] { (void)isin::load_mesh_from_memory<T>(nullptr, 10, isin::MeshFormat::ply); })) ==
          doctest::Contains("not a PLY file"));
}

#if defined(__unix__) || defined(__APPLE__)
TEST_CASE("load_mesh refuses devices, pipes and links to them at once, and files over the size limit (D10)") {
    TempDir dir{"isin-test-mesh-"};
    fs::create_symlink("/dev/zero", dir.path / "zero.ply");
    CHECK(str(thrown([&] { (void)isin::load_mesh<float>(dir / "zero.ply"); })) ==
          doctest::Contains("not a regular file"));
    CHECK(str(thrown([&] { (void)isin::load_ply<float>("/dev/urandom"); })) == doctest::Contains("not a regular file"));
    const std::string obj = dir.put("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    isin::ReadLimits limits;
    limits.max_file_bytes = 10;
    CHECK(str(thrown([&] { (void)isin::load_mesh<float>(obj, limits); })) == doctest::Contains("max_file_bytes"));
}
#endif
