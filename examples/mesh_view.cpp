// Renders a model (Wavefront OBJ with its .mtl materials and textures, or PLY) with the note's
// Phong shading and shadows, smooth normals, on a checkerboard floor, the camera framed
// automatically or placed by options; optional backface culling (§11); frames of an orbit
// around it, and bands of rows (pieces a job scheduler runs apart: docs/rendering.md).
// Build: c++ -std=c++17 -O2 -DISIN_IMPLEMENTATION -I include examples/mesh_view.cpp -o mesh_view
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <isin/isin.hpp>

#include "options.hpp"

namespace {

constexpr int orbit_frames = 120; // one turn around the mesh: 120 frames, 3° each

const char* usage =
    "usage: mesh_view MODEL.obj|MODEL.ply [--output mesh_view.png] [--width 800] [--height 450] [--size WxH]\n"
    "                 [--eye X,Y,Z] [--target X,Y,Z] [--up X,Y,Z] [--fov DEGREES] [--srgb]\n"
    "                 [--smooth ANGLE | --flat] [--threads N] [--samples N] [--cull none|dot|projected]\n"
    "                 [--frames A..B] [--tile I/N] [--area-light S] [--light-samples N]\n"
    "                 [--uniform-light-samples] [--fresnel]\n"
    "Renders a model as its file describes it (isin::load_model): every group, the materials and\n"
    "textures of an OBJ's .mtl files, vertex normals (smooth Phong shading, with the fix for the\n"
    "shadow terminator), texture coordinates and PLY vertex colours; models without materials\n"
    "get a tan one. Two lights with shadows and a checkerboard floor; the mesh is traced\n"
    "through a BVH. The camera has square pixels at any size.\n"
    "  --size WxH        image size (as --width W --height H)\n"
    "  --eye, --target   camera position and the point it looks at (default: the model framed\n"
    "                    from above right, as far as it takes to fit it in the picture)\n"
    "  --up              the picture's up direction (default 0,1,0)\n"
    "  --fov DEGREES     vertical field of view (default 48.46, the note's 16×9 plane at 10)\n"
    "  --srgb            sRGB output, textures decoded from sRGB (default: the note's linear bytes)\n"
    "  --smooth ANGLE    compute normals for meshes without them; faces meeting at more than\n"
    "                    ANGLE degrees keep a sharp edge (e.g. 60)\n"
    "  --flat            ignore the file's normals: one normal per triangle\n"
    "  --cull            drops backfaces from primary rays (§11)\n"
    "  --frames A..B     frames A to B of an orbit about the target (3° a frame, 120 a turn; frame 0\n"
    "                    is the still picture), each to OUTPUT with its number: a %d or %04d in it is\n"
    "                    replaced, else _NNNN goes before the extension\n"
    "  --tile I/N        band I (from 0) of N bands of rows only, exactly those rows of the whole\n"
    "                    picture: merge_tiles stacks them\n"
    "  --area-light S    each light an S×S rectangle (S in radii of the model): soft shadows\n"
    "  --light-samples N samples per rectangle per point (default 16; adaptive: more only in\n"
    "                    penumbrae, unless --uniform-light-samples)\n"
    "  --fresnel         transparent materials split their light by Fresnel's equations\n";

[[noreturn]] void fail(const std::string& why) { example::fail("mesh_view", why, usage); }

/// "X,Y,Z" as a vector.
isin::Vec3f vector_option(int& i, int argc, char** argv) {
    const std::string text = example::string_option(i, argc, argv, usage);
    float v[3];
    char end = 0;
    if (std::sscanf(text.c_str(), "%f,%f,%f%c", &v[0], &v[1], &v[2], &end) != 3 || !std::isfinite(v[0]) ||
        !std::isfinite(v[1]) || !std::isfinite(v[2]))
        fail(std::string(argv[i - 1]) + " takes X,Y,Z (three finite numbers), not '" + text + "'");
    return {v[0], v[1], v[2]};
}

/// A number within [lo, hi].
float number_option(int& i, int argc, char** argv, float lo, float hi) {
    const std::string text = example::string_option(i, argc, argv, usage);
    char* end = nullptr;
    const float v = std::strtof(text.c_str(), &end);
    if (end == text.c_str() || *end != 0 || !(v >= lo && v <= hi))
        fail(std::string(argv[i - 1]) + " takes a number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
             "], not '" + text + "'");
    return v;
}

} // namespace

int main(int argc, char** argv) {
    std::string mesh_path;
    example::Options o;
    o.output = "mesh_view.png";
    isin::RenderOptions opt;
    opt.progress = example::progress_bar();
    isin::ModelOptions load;
    std::optional<isin::Vec3f> eye_option, target_option;
    isin::Vec3f up{0, 1, 0};
    float fov = float(2 * std::atan(0.45) * 180 / 3.141592653589793); // the note's plane: 4.5 over 10
    bool flat = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (example::common_option(i, argc, argv, o, usage) || example::lighting_option(i, argc, argv, o, usage))
            continue;
        if (a == "--cull") {
            const std::string c = example::string_option(i, argc, argv, usage);
            if (c == "none")
                opt.culling = isin::Culling::none;
            else if (c == "dot")
                opt.culling = isin::Culling::dot_product;
            else if (c == "projected")
                opt.culling = isin::Culling::projected;
            else
                fail("--cull takes none, dot or projected");
        } else if (a == "--size") {
            const std::string text = example::string_option(i, argc, argv, usage);
            int w = 0, h = 0;
            char end = 0;
            if (std::sscanf(text.c_str(), "%dx%d%c", &w, &h, &end) != 2 || w < 2 || h < 2 || w > 32768 || h > 32768)
                fail("--size takes WxH, each 2 to 32768, not '" + text + "'");
            o.width = w, o.height = h;
        } else if (a == "--eye")
            eye_option = vector_option(i, argc, argv);
        else if (a == "--target")
            target_option = vector_option(i, argc, argv);
        else if (a == "--up")
            up = vector_option(i, argc, argv);
        else if (a == "--fov")
            fov = number_option(i, argc, argv, 1.0f, 179.0f);
        else if (a == "--srgb") {
            opt.encoding = isin::ColorEncoding::srgb;
            load.textures = isin::ColorEncoding::srgb;
        } else if (a == "--smooth") {
            load.compute_normals = true;
            load.crease_angle_degrees = static_cast<double>(number_option(i, argc, argv, 0.0f, 180.0f));
        } else if (a == "--flat")
            flat = true;
        else if (!a.empty() && a[0] == '-')
            fail("unknown option '" + a + "'");
        else if (mesh_path.empty())
            mesh_path = a;
        else
            fail("one model at a time");
    }
    if (mesh_path.empty()) fail("no model given");
    if (flat && load.compute_normals) fail("--smooth and --flat exclude each other");
    example::finish(o, argv[0], usage, 1000000);
    opt.threads = o.threads;
    opt.samples = o.samples;
    try {
        isin::Model<float> model = isin::load_model<float>(mesh_path, load);
        for (const std::string& warning : model.warnings)
            std::fprintf(stderr, "mesh_view: warning: %s\n", warning.c_str());
        if (model.triangles() == 0) throw std::runtime_error("'" + mesh_path + "' has no triangles");
        bool own_materials = model.materials.size() > 1;
        for (const auto& mesh : model.meshes) own_materials = own_materials || !mesh.colors.empty();
        if (!own_materials) { // a tan surface (§7 weights), as mesh_view always had
            auto& surface = model.materials[0];
            surface.color = isin::from_rgb8<float>(200, 170, 120);
            surface.ka = 0.15f, surface.kd = 0.65f, surface.ks = 0.2f, surface.shininess = 40.0f;
        }
        isin::Vec3f lo{0, 0, 0}, hi{0, 0, 0};
        bool first_point = true;
        for (auto& mesh : model.meshes) {
            if (flat) mesh.normals.clear();
            for (const auto& k : mesh.indices) // the box of what is drawn (files may hold unused vertices)
                for (const std::uint32_t v : k) {
                    const isin::Vec3f& p = mesh.positions[v];
                    lo = first_point ? p : isin::Vec3f{std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
                    hi = first_point ? p : isin::Vec3f{std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
                    first_point = false;
                }
        }
        // Frame the bounding sphere: it fits at distance r / sin(a), a the smaller of the vertical
        // and horizontal half-angles of the view, plus 15%.
        isin::Vec3f centre = target_option ? *target_option : lo * 0.5f + hi * 0.5f; // no overflow near float's max
        const float radius = std::max(0.5f * isin::length(hi - lo), 1e-6f);
        const double half_v = 0.5 * static_cast<double>(fov) * 3.141592653589793 / 180;
        const double half_h = std::atan(std::tan(half_v) * (o.width - 1) / (o.height - 1));
        const float distance = float(1.15 * static_cast<double>(radius) / std::sin(std::min(half_v, half_h)));
        isin::Vec3f view = eye_option ? *eye_option - centre // from the target to the eye
                                      : distance * isin::normalize(isin::Vec3f{0.45f, 0.5f, -1.0f});
        if (!eye_option && !(isin::is_finite(centre) && isin::is_finite(centre + view))) {
            // A model near float's range cannot be framed from outside it: look at its centre (or
            // the origin) from as far as float reaches, which look_at accepts.
            std::fprintf(stderr, "mesh_view: the model is too large to frame in float; the camera stands inside it\n");
            if (!isin::is_finite(centre)) centre = {0, 0, 0};
            const isin::Vec3f direction = isin::normalize(isin::Vec3f{0.45f, 0.5f, -1.0f});
            float far = std::numeric_limits<float>::max();
            do far *= 0.5f;
            while (!isin::is_finite(centre + far * direction));
            view = far * direction;
        }

        isin::StandardScene<float> scene; // compiled once in isin::io (its sphere list stays empty)
        scene.background = {0.05f, 0.07f, 0.12f};
        scene.texture_filter = isin::Filter::bilinear;
        isin::add_model(scene, model);
        // A floor just under the model, 8 radii wide, in a checkerboard of radius-sized squares.
        isin::Material<float> floor;
        floor.ka = 0.2f, floor.kd = 0.75f, floor.ks = 0.05f;
        floor.texture_filter = isin::Filter::nearest; // crisp squares
        floor.texture = scene.add_texture(isin::Checkerboard<float>{isin::from_rgb8<float>(225, 225, 215),
                                                                    isin::from_rgb8<float>(70, 80, 100), 8, 8});
        const isin::Vec3f middle = (lo + hi) * 0.5f;
        const float y = lo.y - 1e-3f * radius, r4 = 4.0f * radius;
        scene.add_textured_rectangle({middle.x - r4, y, middle.z - r4}, {middle.x - r4, y, middle.z + r4},
                                     {middle.x + r4, y, middle.z - r4}, scene.add_material(floor));
        scene.add_light({middle + radius * isin::Vec3f{-2.5f, 4.0f, -1.5f}, {0.8f, 0.8f, 0.75f}}); // §9
        scene.add_light({centre + view + radius * isin::Vec3f{1.0f, 0.5f, 0.0f}, {0.35f, 0.35f, 0.4f}});
        example::apply_lighting(scene, o, opt, radius); // --area-light in radii of the model
        scene.commit();

        const int first = o.frames.given() ? o.frames.first : 0, last = o.frames.given() ? o.frames.last : 0;
        for (int frame = first; frame <= last; ++frame) {
            // The orbit: the eye turned about the vertical through the target (frame 0 exactly the still's).
            const double angle = 2 * 3.141592653589793 * (frame % orbit_frames) / orbit_frames;
            const float c = float(std::cos(angle)), s = float(std::sin(angle));
            const isin::Vec3f around{view.x * c + view.z * s, view.y, view.z * c - view.x * s};
            const auto camera = isin::Camera<float>::look_at(o.width, o.height, centre + around, centre, up, fov);
            const std::string output = o.frames.given() ? example::frame_path(o.output, frame) : o.output;
            isin::RenderStats stats;
            const isin::Image image = example::render_tile(scene, camera, o, opt, &stats);
            isin::write_image(image, output);
            std::printf("%s: %zu triangles in %zu meshes, %zu materials, %zu textures, %d×%d, %.1f ms, %.1f Mrays/s\n",
                        output.c_str(), model.triangles(), model.meshes.size(), model.materials.size(),
                        model.textures.size(), image.width(), image.height(), stats.seconds * 1e3,
                        stats.mrays_per_second());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "mesh_view: %s\n", e.what());
        return 1;
    }
    return 0;
}
