// Models from files (load_model, add_model): OBJ with .mtl materials and textures, groups,
// normals, uvs, correct polygons, UTF-16 and binary files refused; PLY attributes; smooth shading
// (shading normal, the shadow-terminator fix) and sRGB output.
#include <isin/image_io.hpp>
#include <isin/model.hpp>
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/workloads.hpp"
#include "support/temp_dir.hpp"

#include <cmath>
#include <filesystem>
#include <cstdint>
#include <string>
#include <vector>

namespace {

template <class T>
T area(const isin::Mesh<T>& mesh) {
    T sum = T(0);
    for (std::size_t i = 0; i < mesh.size(); ++i) sum += isin::length(isin::normal(mesh.triangle(i))) / T(2);
    return sum;
}

/// What f throws, as text ("" if nothing).
template <class F>
std::string thrown(F&& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

// A house of two groups: a "walls" quad and an L-shaped (concave) hexagon "floor", with uvs and
// normals, two materials from a .mtl beside it and a texture in a subfolder named with '\'.
const char* const house_obj = "# two groups\n"
                              "mtllib house.mtl\n"
                              "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\n" // L: area 3
                              "v 0 0 5\nv 4 0 5\nv 4 3 5\nv 0 3 5\n"                   // quad: area 12
                              "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                              "vn 0 0 -1\nvn 0 0 1\n"
                              "g floor\nusemtl Brick\n"
                              "f 1/1/1 6/4/1 5/3/1 4/3/1 3/3/1 2/2/1\n"
                              "g walls\nusemtl Glass\n"
                              "f 7/1/2 10/4/2 9/3/2 8/2/2\n";
const char* const house_mtl = "newmtl Brick\n"
                              "Ka 0.1 0.2 0.3\nKd 0.5 0.25 0.125\nKs 0.2 0.2 0.2\nNs 40\n"
                              "map_Kd -s 1 1 1 textures\\Brick.png\n"
                              "newmtl Glass\n"
                              "Kd 0.9 0.9 0.9\nKs 0.3 0.6 0.9\nNs 200\nd 0.25\nNi 1.5\nillum 7\n";

void write_texture(const std::string& path) {
    isin::Image tex(2, 1);
    tex(0, 0) = {255, 0, 0};
    tex(1, 0) = {128, 128, 128};
    isin::write_png(tex, path);
}

} // namespace

TEST_CASE_TEMPLATE("load_model OBJ: groups as meshes, materials from the .mtl, a texture, uvs, normals", T, float,
                   double) {
    TempDir dir("isin-model-");
    std::filesystem::create_directories(dir.path / "textures");
    write_texture(dir / "textures/brick.png"); // named Brick.png in the .mtl: found in any letter case
    dir.put("house.mtl", house_mtl);
    const auto model = isin::load_model<T>(dir.put("house.obj", house_obj));
    CAPTURE(model.warnings.size());
    CHECK(model.warnings.empty());
    REQUIRE(model.meshes.size() == 2);
    CHECK(model.names[0] == "floor");
    CHECK(model.names[1] == "walls");
    const auto& floor = model.meshes[0];
    const auto& walls = model.meshes[1];
    floor.validate();
    walls.validate();
    // The concave hexagon: 4 triangles of its own area (a fan from corner 1 would cover 3.5).
    CHECK(floor.size() == 4);
    CHECK(area(floor) == approx(T(3)));
    CHECK(walls.size() == 2);
    CHECK(area(walls) == approx(T(12)));
    // Every v/vt/vn triple once: the hexagon's six corners (vt 3 thrice, with three positions).
    CHECK(floor.positions.size() == 6);
    CHECK(floor.uvs.size() == 6);
    REQUIRE(floor.normals.size() == 6);
    CHECK(floor.normals[0] == isin::Vertex<T>{0, 0, -1});
    CHECK(walls.normals[0] == isin::Vertex<T>{0, 0, 1});
    CHECK(walls.uvs[1] == std::array<T, 2>{0, 1}); // second corner: vt 4
    // Materials: [0] the default, then the .mtl's in order; each triangle names its own.
    REQUIRE(model.materials.size() == 3);
    CHECK(model.material_names[1] == "Brick");
    CHECK(model.material_names[2] == "Glass");
    CHECK(floor.material == std::vector<std::uint32_t>(4, 1));
    CHECK(walls.material == std::vector<std::uint32_t>(2, 2));
    const auto& brick = model.materials[1];
    CHECK(brick.color.g == approx(T(0.25)));
    CHECK(brick.ambient_color.b == approx(T(0.3)));
    CHECK(brick.specular_color.r == approx(T(0.2)));
    CHECK(brick.shininess == approx(T(40)));
    CHECK(brick.transparency == T(0));
    CHECK(brick.reflectivity == T(0)); // illum 2 (default): no mirror
    const auto& glass = model.materials[2];
    CHECK(glass.transparency == approx(T(0.75)));
    CHECK(glass.ior == approx(T(1.5)));
    CHECK(glass.reflectivity == approx(T(0.6))); // illum 7: the mean of Ks
    CHECK(glass.texture == -1);
    REQUIRE(brick.texture == 0);
    REQUIRE(model.textures.size() == 1);
    CHECK(model.texture_paths[0].find("brick.png") != std::string::npos);
    const auto red = isin::sample(model.textures[0], T(0.25), T(0.5), isin::Filter::nearest);
    CHECK(red.r == T(1));
    CHECK(red.g == T(0));

    // Into a scene: materials and textures appended after what it has, ids moved along.
    isin::Scene<T, isin::Sphere> scene;
    scene.add_material({});
    scene.add_texture(isin::Checkerboard<T>{});
    const auto ids = isin::add_model(scene, model);
    CHECK(ids.size() == 2);
    CHECK(scene.materials.size() == 4);
    CHECK(scene.materials[2].texture == 1);
    CHECK(scene.textures.size() == 2);
    scene.validate();
    // A ray down onto the walls' quad from behind it (z > 5) sees the glass material.
    const isin::Ray<T> ray{{1, 1, 10}, {0, 0, -1}};
    const auto hit = scene.intersect(ray);
    REQUIRE(hit);
    CHECK(scene.surface(ray, hit).material == 3);
}

TEST_CASE("load_model OBJ: sRGB textures decode to linear intensities") {
    TempDir dir("isin-model-");
    std::filesystem::create_directories(dir.path / "textures");
    write_texture(dir / "textures/Brick.png");
    dir.put("house.mtl", house_mtl);
    isin::ModelOptions options;
    options.textures = isin::ColorEncoding::srgb;
    const auto model = isin::load_model<double>(dir.put("house.obj", house_obj), options);
    REQUIRE(model.textures.size() == 1);
    const auto grey = isin::sample(model.textures[0], 0.75, 0.5, isin::Filter::nearest);
    CHECK(grey.r == approx(std::pow((128.0 / 255 + 0.055) / 1.055, 2.4))); // 0.2158…
    CHECK(isin::srgb_to_linear(isin::linear_to_srgb(0.3)) == approx(0.3));
    CHECK(isin::linear_to_srgb(0.001) == approx(0.01292));
    CHECK(isin::to_rgb8(isin::Color<double>{0.5, 0, 1}, isin::ColorEncoding::srgb) == isin::Rgb8{188, 0, 255});
    options.load_textures = false;
    CHECK(isin::load_model<double>(dir / "house.obj", options).materials[1].texture == -1);
}

TEST_CASE("load_model OBJ: a missing .mtl or texture is a warning, the geometry still loads") {
    TempDir dir("isin-model-");
    auto model = isin::load_model<float>(dir.put("house.obj", house_obj));
    CHECK(model.triangles() == 6);
    REQUIRE(model.warnings.size() >= 1);
    CHECK(model.warnings[0].find("house.mtl") != std::string::npos);
    dir.put("house.mtl", house_mtl); // names textures\Brick.png, which is not there
    model = isin::load_model<float>(dir / "house.obj");
    REQUIRE(model.warnings.size() == 1);
    CHECK(model.warnings[0].find("Brick.png") != std::string::npos);
    CHECK(model.materials[1].texture == -1);
    CHECK(model.materials.size() == 3);
}

TEST_CASE("load_model OBJ: UTF-16 and binary files are clear errors; a UTF-8 byte order mark is skipped") {
    TempDir dir("isin-model-");
    const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::string utf16le = "\xff\xfe", utf16be = "\xfe\xff", no_bom;
    for (char ch : text) {
        utf16le += ch, utf16le += '\0';
        utf16be += '\0', utf16be += ch;
        no_bom += ch, no_bom += '\0';
    }
    for (const auto& content : {utf16le, utf16be, no_bom}) {
        const std::string why = thrown([&] { (void)isin::load_model<float>(dir.put("u16.obj", content)); });
        CHECK(why.find("UTF-16") != std::string::npos);
        CHECK(thrown([&] { (void)isin::load_mesh<float>(dir / "u16.obj"); }).find("UTF-16") != std::string::npos);
    }
    const std::string why = thrown([&] {
        (void)isin::load_model<float>(dir.put("bin.obj", std::string("v 0 0 0\n\x7f"
                                                                     "ELF\0\0\1",
                                                                     15)));
    });
    CHECK(why.find("binary data (a NUL byte at offset 12)") != std::string::npos);
    CHECK(isin::load_model<float>(dir.put("bom.obj", "\xef\xbb\xbf" + text)).triangles() == 1);
}

TEST_CASE_TEMPLATE("load_model OBJ: shared vertices, same group name twice, non-planar polygon, no material", T, float,
                   double) {
    TempDir dir("isin-model-");
    const auto model = isin::load_model<T>(dir.put("parts.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nv 0.5 0.5 3\n"
                                                                "o a\nf 1 2 3 4\n"  // non-planar quad
                                                                "o b\nf 1 2 5\n"    // a second object
                                                                "o a\nf 3 4 5\n")); // back to the first
    REQUIRE(model.meshes.size() == 2);
    CHECK(model.names[0] == "a");
    CHECK(model.meshes[0].size() == 3); // the quad's 2 and one more
    CHECK(model.meshes[0].positions.size() == 5);
    CHECK(model.meshes[0].material.empty()); // no usemtl anywhere: materials[0] for all
    CHECK(model.meshes[0].normals.empty());
    CHECK(model.meshes[1].size() == 1);
    CHECK(model.meshes[1].positions.size() == 3); // only what its faces use
    CHECK(model.materials.size() == 1);
    CHECK(model.warnings.empty());

    // A position used with two normals is two vertices; the same v/vn pair again is the same one.
    const auto corner = isin::load_model<T>(dir.put("corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                                                                  "vn 0 0 1\nvn 1 0 0\n"
                                                                  "f 1//1 2//1 3//1\nf 1//2 3//2 4//2\n"
                                                                  "f 1//1 3//1 2//1\nf 4//2 3//2 1//2\n"));
    REQUIRE(corner.meshes.size() == 1);
    CHECK(corner.meshes[0].positions.size() == 6);
    CHECK(corner.meshes[0].indices[2] == std::array<std::uint32_t, 3>{0, 2, 1});
    CHECK(corner.meshes[0].indices[3] == std::array<std::uint32_t, 3>{5, 4, 3});
    CHECK(corner.meshes[0].normals[3] == isin::Vertex<T>{1, 0, 0});

    isin::ModelOptions options;
    options.compute_normals = true;
    const auto smooth = isin::load_model<T>(dir / "parts.obj", options);
    CHECK(smooth.meshes[0].normals.size() == smooth.meshes[0].positions.size());
    smooth.meshes[0].validate();
}

TEST_CASE_TEMPLATE("load_model_from_memory reads what load_model reads, without .mtl files", T, float, double) {
    TempDir dir("isin-model-");
    const std::string text = house_obj;
    const auto model = isin::load_model_from_memory<T>(text.data(), text.size(), isin::MeshFormat::obj, "house");
    const auto from_file = isin::load_model<T>(dir.put("house.obj", house_obj));
    REQUIRE(model.meshes.size() == 2);
    CHECK(model.meshes[0].indices == from_file.meshes[0].indices);
    CHECK(model.meshes[1].positions == from_file.meshes[1].positions);
    CHECK(model.names == from_file.names);
    REQUIRE(model.warnings.size() >= 1); // mtllib: not read from memory
    CHECK(model.warnings[0].find("line 2: mtllib") != std::string::npos);
    CHECK(model.materials.size() == 1);
    const std::string bad = "v 0 0 0\nf 1 2 3\n";
    CHECK_THROWS_WITH_AS((void)isin::load_model_from_memory<T>(bad.data(), bad.size(), isin::MeshFormat::obj, "net"),
                         doctest::Contains("'net': line 2"), isin::MeshError);
    const std::string ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0\n0 1 0\n1 0 0\n3 0 1 2\n";
    isin::ModelOptions options;
    options.compute_normals = true;
    const auto tile = isin::load_model_from_memory<T>(ply.data(), ply.size(), isin::MeshFormat::ply, "tile", options);
    CHECK(tile.names[0] == "tile");
    CHECK(tile.meshes[0].normals.size() == 3);
}

TEST_CASE("load_model: errors name the file; an unknown extension is std::invalid_argument") {
    TempDir dir("isin-model-");
    CHECK_THROWS_AS((void)isin::load_model<float>(dir.put("x.stl", "solid")), std::invalid_argument);
    const std::string why = thrown([&] { (void)isin::load_model<float>(dir.put("bad.obj", "v 0 0 0\nf 1 2 3\n")); });
    CHECK(why.find("bad.obj") != std::string::npos);
    CHECK(why.find("line 2") != std::string::npos);
    const std::string vt = thrown([&] {
        (void)isin::load_model<float>(dir.put("vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n"));
    });
    CHECK(vt.find("texture coordinate index 2 is out of range") != std::string::npos);
    // A .mtl whose number tinyobjloader's parser must not see is a clear error naming the .mtl.
    dir.put("m.mtl", "newmtl a\nKd 1e-2147483648 0 0\n");
    const std::string mtl = thrown(
        [&] { (void)isin::load_model<float>(dir.put("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")); });
    CHECK(mtl.find("m.mtl") != std::string::npos);
    CHECK(mtl.find("exponent") != std::string::npos);
    CHECK_THROWS_AS((void)isin::load_model<float>(dir / "none.obj"), isin::MeshError);
}

TEST_CASE("load_model PLY: one mesh named after the file, with its normals, uvs and colours") {
    TempDir dir("isin-model-");
    const auto model = isin::load_model<float>(dir.put("Tile.ply", "ply\nformat ascii 1.0\n"
                                                                   "element vertex 3\nproperty float x\n"
                                                                   "property float y\nproperty float z\n"
                                                                   "property float nx\nproperty float ny\n"
                                                                   "property float nz\nproperty float u\n"
                                                                   "property float v\nproperty uchar red\n"
                                                                   "property uchar green\nproperty uchar blue\n"
                                                                   "element face 1\n"
                                                                   "property list uchar int vertex_indices\n"
                                                                   "end_header\n"
                                                                   "0 0 0 0 0 -1 0 0 255 0 0\n"
                                                                   "0 1 0 0 0 -1 0 1 0 255 0\n"
                                                                   "1 0 0 0 0 -1 1 0 0 0 255\n"
                                                                   "3 0 1 2\n"));
    REQUIRE(model.meshes.size() == 1);
    CHECK(model.names[0] == "Tile");
    const auto& mesh = model.meshes[0];
    CHECK(mesh.size() == 1);
    CHECK(mesh.normals.size() == 3);
    CHECK(mesh.uvs.size() == 3);
    REQUIRE(mesh.colors.size() == 3);
    CHECK(mesh.colors[1].g == 1.0f);
    CHECK(model.materials.size() == 1);

    // The vertex colour tints the material's: the hit's colour is the blend of the corners'.
    isin::Scene<float, isin::Sphere> scene;
    isin::add_model(scene, model);
    const isin::Ray<float> ray{{0.25f, 0.25f, -1}, {0, 0, 1}};
    const auto hit = scene.intersect(ray);
    REQUIRE(hit);
    const auto sp = scene.surface(ray, hit);
    CHECK(sp.tint.r == approx(0.5f));
    CHECK(sp.tint.g == approx(0.25f));
    CHECK(sp.tint.b == approx(0.25f));
    CHECK(sp.shading_normal == isin::Vertex<float>{0, 0, -1});
}

TEST_CASE_TEMPLATE("smooth shading: the shading normal blends the vertex normals; flat meshes keep theirs", T, float,
                   double) {
    isin::Mesh<T> mesh;
    mesh.positions = {{0, 0, 5}, {0, 1, 5}, {1, 0, 5}}; // clockwise from the eye: front faces −z
    mesh.indices = {{0, 1, 2}};
    isin::Scene<T, isin::Sphere> flat_scene;
    flat_scene.add_mesh(mesh, flat_scene.add_material({}));
    const isin::Ray<T> ray{{T(0.25), T(0.5), 0}, {0, 0, 1}};
    const auto flat = flat_scene.surface(ray, flat_scene.intersect(ray));
    CHECK(flat.shading_normal == flat.normal);
    CHECK(flat.shading_point == flat.point);

    mesh.normals = {
        isin::normalize(isin::Vertex<T>{-1, 0, -1}), {0, 0, -1}, isin::normalize(isin::Vertex<T>{1, 0, -1})};
    isin::Scene<T, isin::Sphere> scene;
    scene.add_mesh(mesh, scene.add_material({}));
    const auto hit = scene.intersect(ray);
    REQUIRE(hit);
    const auto sp = scene.surface(ray, hit);
    // Barycentrics: u = 0.5 (V1), v = 0.25 (V2), 0.25 for V0.
    CHECK(hit.u == approx(T(0.5)));
    const auto blend =
        isin::normalize(T(0.25) * mesh.normals[0] + T(0.5) * mesh.normals[1] + T(0.25) * mesh.normals[2]);
    CHECK(sp.shading_normal.x == approx(blend.x));
    CHECK(sp.shading_normal.z == approx(blend.z));
    CHECK(sp.normal == isin::Vertex<T>{0, 0, -1});
    // The normals spread outwards, as on a sphere: the shading point lies off the triangle on
    // the side the ray came from (−z), never behind it.
    CHECK(sp.shading_point.z < sp.point.z);
    // Placed again, turned and moved: the same, in the world.
    const auto place = isin::Transform<T>::translation({10, 0, 0});
    const auto id = isin::MeshId{0};
    scene.add_instance(id, place);
    const isin::Ray<T> moved{{T(10.25), T(0.5), 0}, {0, 0, 1}};
    const auto sp2 = scene.surface(moved, scene.intersect(moved));
    CHECK(sp2.shading_normal.x == approx(blend.x));
    CHECK(sp2.shading_point.z == approx(sp.shading_point.z));
}

TEST_CASE("smooth shading: the shading point lets lit facets of a coarse sphere see the light (no terminator)") {
    // A coarse icosphere (320 facets) with exact sphere normals, lit from far away along +x: on
    // facets that the smooth normal turns towards the light but whose plane faces away, a shadow
    // ray from the hit point enters the sphere at once; from the shading point most get out.
    const auto tris = workloads::icosphere<double>({0, 0, 0}, 1.0, 2);
    auto mesh = isin::Mesh<double>::from_triangles(tris);
    for (const auto& p : mesh.positions) mesh.normals.push_back(isin::normalize(p));
    isin::Scene<double, isin::Sphere> scene;
    scene.add_mesh(mesh, scene.add_material({}));
    const isin::Vertex<double> light{1e4, 0, 0};
    int lit_flat = 0, lit_smooth = 0, terminator = 0;
    for (int i = 0; i < 200; ++i)
        for (int j = 0; j < 200; ++j) { // rays from −z near the terminator (x = 0)
            const isin::Ray<double> ray{{-0.3 + 0.6 * i / 200.0, -1 + 2 * j / 200.0, -5}, {0, 0, 1}};
            const auto hit = scene.intersect(ray);
            if (!hit) continue;
            const auto sp = scene.surface(ray, hit);
            const auto L = isin::normalize(light - sp.point);
            if (!(isin::dot(sp.shading_normal, L) > 0.02) || isin::dot(sp.normal, L) > 0) continue;
            ++terminator; // lit by the smooth normal, facing away by the facet's
            const auto from = [&](const isin::Vertex<double>& p) {
                const auto o = isin::offset_origin(p, sp.normal, 5.0);
                return scene.transmittance(isin::Ray<double>{o, light - o}, 1.0) > 0;
            };
            lit_flat += from(sp.point);
            lit_smooth += from(sp.shading_point);
        }
    CAPTURE(terminator);
    CAPTURE(lit_flat);
    CAPTURE(lit_smooth);
    REQUIRE(terminator > 100);
    CHECK(lit_flat < terminator / 100);         // measured: 0 of 1976
    CHECK(lit_smooth >= terminator * 99 / 100); // measured: all 1976
}

TEST_CASE("render: sRGB output encodes the same intensities with the sRGB curve") {
    isin::Scene<float, isin::Sphere> scene;
    isin::Material<float> grey;
    grey.color = {0.5f, 0.5f, 0.5f};
    grey.ka = 1, grey.kd = 0, grey.ks = 0; // ambient only: the colour itself
    scene.add(isin::Sphere<float>{{0, 0, 50}, 20}, scene.add_material(grey));
    const isin::Camera<float> cam(16, 9);
    isin::RenderOptions opt;
    opt.threads = 1;
    const auto linear = isin::render(scene, cam, opt);
    opt.encoding = isin::ColorEncoding::srgb;
    const auto srgb = isin::render(scene, cam, opt);
    CHECK(linear(8, 4).r == 128);
    CHECK(srgb(8, 4).r == 188);
    CHECK(srgb(0, 0).r == 0);
}

// Models from strangers: every file a model names read once whatever its spelling, confined to
// the allowed directories, within the model's budget.
namespace {

/// `n` distinct spellings of the relative path `name` ("./" or ".//" per bit of i, then name).
std::vector<std::string> spellings(int n, int bits, const std::string& name) {
    std::vector<std::string> out;
    for (int i = 0; i < n; ++i) {
        std::string s;
        for (int b = 0; b < bits; ++b) s += ((i >> b) & 1) ? ".//" : "./";
        out.push_back(s + name);
    }
    return out;
}

/// How many of `files` end with `name`.
std::size_t count_ending(const std::vector<std::string>& files, const std::string& name) {
    std::size_t n = 0;
    for (const std::string& f : files)
        n += f.size() >= name.size() && f.compare(f.size() - name.size(), name.size(), name) == 0;
    return n;
}

/// Whether any of `texts` contains `part`.
bool any_contains(const std::vector<std::string>& texts, const std::string& part) {
    for (const std::string& t : texts)
        if (t.find(part) != std::string::npos) return true;
    return false;
}

const char* const textured_triangle = "v 0 0 5\nv 1 0 5\nv 0 1 5\nvt 0 0\nvt 1 0\nvt 0 1\n";

} // namespace

TEST_CASE_TEMPLATE("load_model: a texture named by 100 spellings, a hard link and its absolute path is decoded once", T,
                   float, double) {
    TempDir dir("isin-model-");
    write_texture(dir / "big.png");
    std::filesystem::create_hard_link(dir / "big.png", dir / "same.png");
    std::string mtl;
    const auto names = spellings(100, 7, "big.png");
    for (std::size_t i = 0; i < names.size(); ++i)
        mtl += "newmtl m" + std::to_string(i) + "\nmap_Kd " + names[i] + "\n";
    mtl += "newmtl linked\nmap_Kd same.png\nnewmtl absolute\nmap_Kd " +
           std::filesystem::absolute(dir / "big.png").string() + "\nnewmtl upper\nmap_Kd BIG.PNG\n";
    dir.put("model.mtl", mtl);
    const auto model = isin::load_model<T>(
        dir.put("model.obj", std::string("mtllib model.mtl\n") + textured_triangle + "usemtl m0\nf 1/1 2/2 3/3\n"));
    CHECK(model.warnings.empty());
    CHECK(model.textures.size() == 1); // decoded once
    REQUIRE(model.materials.size() == 104);
    for (std::size_t i = 1; i < model.materials.size(); ++i) CHECK(model.materials[i].texture == 0);
    REQUIRE(model.files.size() == 3); // the OBJ, the .mtl, the texture: each opened once
    CHECK(count_ending(model.files, "model.obj") == 1);
    CHECK(count_ending(model.files, "model.mtl") == 1);
    CHECK(count_ending(model.files, "big.png") + count_ending(model.files, "same.png") == 1);
}

TEST_CASE("load_model: a .mtl named by 100 spellings on mtllib lines is read once") {
    TempDir dir("isin-model-");
    std::string mtl;
    for (int i = 0; i < 50; ++i) mtl += "newmtl m" + std::to_string(i) + "\nKd 0.5 0.5 0.5\n";
    dir.put("amp.mtl", mtl);
    std::string obj;
    for (const std::string& s : spellings(100, 7, "amp.mtl")) obj += "mtllib " + s + "\n";
    obj += "mtllib model.obj\n"; // the model itself: refused as a material file, not read again
    const auto model = isin::load_model<float>(dir.put("model.obj", obj + textured_triangle + "usemtl m1\nf 1 2 3\n"));
    CHECK(model.materials.size() == 51);
    CHECK(model.meshes.size() == 1);
    CHECK(model.files.size() == 2);
    CHECK(count_ending(model.files, "amp.mtl") == 1);
    CHECK(count_ending(model.files, "model.obj") == 1);
    CHECK(any_contains(model.warnings, "is the model already"));
}

TEST_CASE("load_model: 20k group names make 20k meshes, each with its name; ModelBudget::meshes bounds them") {
    TempDir dir("isin-model-");
    std::string obj = "v 0 0 5\nv 1 0 5\nv 0 1 5\n";
    for (int i = 0; i < 20000; ++i) obj += "g group" + std::to_string(i) + "\nf 1 2 3\n";
    obj += "g group7\nf 3 2 1\n"; // a name again adds to its mesh
    const std::string path = dir.put("groups.obj", obj);
    const auto model = isin::load_model<float>(path);
    REQUIRE(model.meshes.size() == 20000);
    CHECK(model.names[0] == "group0");
    CHECK(model.names[19999] == "group19999");
    CHECK(model.meshes[7].size() == 2);
    CHECK(model.meshes[8].size() == 1);
    isin::ModelOptions options;
    options.budget.meshes = 1000;
    const std::string why = thrown([&] { (void)isin::load_model<float>(path, options); });
    CHECK(why.find("groups.obj") != std::string::npos);
    CHECK(why.find("ModelBudget::meshes") != std::string::npos);
    CHECK_THROWS_AS((void)isin::load_model<float>(path, options), isin::MeshError);
    options.budget.meshes = 20000;
    CHECK(isin::load_model<float>(path, options).meshes.size() == 20000);
}

TEST_CASE("load_model: files outside the model's directory are refused unless allowed, symbolic links too") {
    TempDir top("isin-model-");
    std::filesystem::create_directories(top.path / "model" / "sub");
    std::filesystem::create_directories(top.path / "outside");
    write_texture(top / "outside/secret.png");
    top.put("outside/other.mtl", "newmtl other\nKd 1 0 0\n");
    std::filesystem::create_symlink(top.path / "outside" / "secret.png", top.path / "model" / "link.png");
    std::filesystem::create_directory_symlink(top.path / "outside", top.path / "model" / "linked_dir");
    write_texture(top / "model/sub/inside.png");
    const std::string absolute_secret = std::filesystem::absolute(top.path / "outside" / "secret.png").string();
    top.put("model/model.mtl", "newmtl up\nmap_Kd ../outside/secret.png\n"
                               "newmtl absolute\nmap_Kd " +
                                   absolute_secret +
                                   "\n"
                                   "newmtl link\nmap_Kd link.png\n"
                                   "newmtl dir\nmap_Kd linked_dir/secret.png\n"
                                   "newmtl system\nmap_Kd /etc/hostname\n"
                                   "newmtl inside\nmap_Kd sub/../sub/inside.png\n");
    const std::string obj = top.put("model/model.obj", std::string("mtllib model.mtl\nmtllib ../outside/other.mtl\n") +
                                                           textured_triangle + "usemtl inside\nf 1/1 2/2 3/3\n");
    auto model = isin::load_model<float>(obj);
    REQUIRE(model.materials.size() == 7); // other.mtl left out
    CHECK(model.textures.size() == 1);
    CHECK(model.materials[6].texture == 0); // inside
    for (std::size_t i = 1; i <= 5; ++i) CHECK(model.materials[i].texture == -1);
    CHECK(model.files.size() == 3); // model.obj, model.mtl, inside.png
    for (const std::string& f : model.files) {
        CHECK(f.find("outside") == std::string::npos);
        CHECK(f.find("hostname") == std::string::npos);
    }
    CHECK(model.warnings.size() == 6);
    CHECK(any_contains(model.warnings, "other.mtl"));
    CHECK(any_contains(model.warnings, "ModelOptions::allowed_roots"));

    isin::ModelOptions options; // the outside directory allowed: its files are read once each
    options.allowed_roots = {(top.path / "outside").string()};
    model = isin::load_model<float>(obj, options);
    CHECK(model.materials.size() == 8);
    CHECK(model.textures.size() == 2); // secret.png by four names, inside.png
    for (std::size_t i = 1; i <= 4; ++i) CHECK(model.materials[i].texture == model.materials[1].texture);
    CHECK(model.materials[5].texture == -1); // /etc/hostname
    CHECK(count_ending(model.files, "secret.png") == 1);

    options.allowed_roots.clear();
    options.allow_any_file = true;
    model = isin::load_model<float>(obj, options);
    CHECK(model.textures.size() == 2);
    CHECK(model.materials[1].texture >= 0);
}

TEST_CASE("load_model: ModelBudget leaves out textures and .mtl files over it, refuses meshes over it") {
    TempDir dir("isin-model-");
    write_texture(dir / "a.png"); // 2 pixels each
    write_texture(dir / "b.png");
    dir.put("model.mtl", "newmtl a\nmap_Kd a.png\nnewmtl b\nmap_Kd b.png\nnewmtl b2\nmap_Kd ./b.png\n");
    dir.put("more.mtl", "newmtl c\nKd 1 1 1\n");
    const std::string obj = dir.put("model.obj", std::string("mtllib model.mtl\nmtllib ./more.mtl x\n") +
                                                     textured_triangle + "f 1/1 2/2 3/3\n");
    isin::ModelOptions options;
    options.budget.texture_pixels = 3;
    auto model = isin::load_model<float>(obj, options);
    CHECK(model.textures.size() == 1);
    CHECK(model.materials[2].texture == -1);
    CHECK(model.materials[3].texture == -1); // refused once, left out again
    CHECK(count_ending(model.files, "b.png") == 1);
    CHECK(any_contains(model.warnings, "ModelBudget::texture_pixels"));

    options = {};
    options.budget.mtl_bytes = 60; // model.mtl has 69 bytes
    model = isin::load_model<float>(obj, options);
    CHECK(model.materials.size() == 2); // more.mtl only
    CHECK(any_contains(model.warnings, "ModelBudget::mtl_bytes"));
    CHECK(count_ending(model.files, "model.mtl") == 0); // refused before it is read

    options = {};
    options.budget.materials = 1; // model.mtl's three left out, more.mtl's one read
    model = isin::load_model<float>(obj, options);
    REQUIRE(model.materials.size() == 2);
    CHECK(model.material_names[1] == "c");
    CHECK(any_contains(model.warnings, "ModelBudget::materials"));

    options = {};
    options.budget.vertices = 2;
    CHECK_THROWS_AS((void)isin::load_model<float>(obj, options), isin::MeshError);
    CHECK(thrown([&] { (void)isin::load_model<float>(obj, options); }).find("ModelBudget::vertices") !=
          std::string::npos);
    const std::string ply = dir.put("tri.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                               "property float y\nproperty float z\nelement face 1\n"
                                               "property list uchar int vertex_indices\nend_header\n"
                                               "0 0 0\n0 1 0\n1 0 0\n3 0 1 2\n");
    CHECK_THROWS_AS((void)isin::load_model<float>(ply, options), isin::MeshError);
    options.budget.vertices = 3;
    CHECK(isin::load_model<float>(ply, options).triangles() == 1);
}

TEST_CASE_TEMPLATE("load_model PLY: float vertex colours outside [0, 1] are clamped, with a warning", T, float,
                   double) {
    TempDir dir("isin-model-");
    const auto model = isin::load_model<T>(dir.put("c.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"
                                                            "property float x\nproperty float y\nproperty float z\n"
                                                            "property float red\nproperty float green\n"
                                                            "property float blue\nelement face 1\n"
                                                            "property list uchar int vertex_indices\nend_header\n"
                                                            "0 0 0 2.0 -0.5 0.5\n0 1 0 0.25 0.5 1\n"
                                                            "1 0 0 1e30 0 0\n3 0 1 2\n"));
    REQUIRE(model.meshes[0].colors.size() == 3);
    const auto& c = model.meshes[0].colors;
    CHECK(c[0].r == T(1));
    CHECK(c[0].g == T(0));
    CHECK(c[0].b == T(0.5));
    CHECK(c[1].r == T(0.25));
    CHECK(c[2].r == T(1));
    REQUIRE(model.warnings.size() == 1);
    CHECK(model.warnings[0].find("2 vertex colours") != std::string::npos);
}
