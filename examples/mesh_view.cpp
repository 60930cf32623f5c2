// Renders a mesh (Wavefront OBJ or PLY) with the note's Phong shading and shadows, on a
// checkerboard floor, the camera framed automatically; optional backface culling (§11); frames
// of an orbit around it, and bands of rows (pieces a job scheduler runs apart: README).
// Build: c++ -std=c++17 -O2 -DISIN_IMPLEMENTATION -I include examples/mesh_view.cpp -o mesh_view
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include <isin/isin.hpp>

#include "options.hpp"

namespace {

constexpr int orbit_frames = 120; // one turn around the mesh: 120 frames, 3° each

const char* usage = "usage: mesh_view MESH.obj|MESH.ply [--output mesh_view.png] [--width 800] [--height 450]\n"
                    "                 [--threads N] [--samples N] [--cull none|dot|projected] [--frames A..B]\n"
                    "                 [--tile I/N]\n"
                    "Renders the mesh with Phong shading, two lights with shadows and a floor; the camera (the\n"
                    "note's pinhole: a 16×9 plane at distance 10) is placed to frame the whole mesh. The mesh\n"
                    "is traced through a BVH. --cull drops backfaces from primary rays. --frames A..B renders\n"
                    "frames A to B of an orbit around the mesh (3° a frame, 120 a turn; frame 0 is the still\n"
                    "picture), each to OUTPUT with its number: a %d or %04d in it is replaced, else _NNNN goes\n"
                    "before the extension. --tile I/N renders band I (from 0) of N bands of rows only, exactly\n"
                    "those rows of the whole picture: merge_tiles stacks them.\n";

[[noreturn]] void fail(const std::string& why) { example::fail("mesh_view", why, usage); }

} // namespace

int main(int argc, char** argv) {
    std::string mesh_path;
    example::Options o;
    o.output = "mesh_view.png";
    isin::RenderOptions opt;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (example::common_option(i, argc, argv, o, usage)) continue;
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
        } else if (!a.empty() && a[0] == '-')
            fail("unknown option '" + a + "'");
        else if (mesh_path.empty())
            mesh_path = a;
        else
            fail("one mesh at a time");
    }
    if (mesh_path.empty()) fail("no mesh given");
    example::finish(o, argv[0], usage, 1000000);
    opt.threads = o.threads;
    opt.samples = o.samples;
    try {
        const auto triangles = isin::load_mesh<float>(mesh_path);
        if (triangles.empty()) throw std::runtime_error("'" + mesh_path + "' has no triangles");
        // Frame the bounding sphere of the mesh: the note's plane (half height 4.5 at distance
        // 10) subtends atan(0.45), so the sphere fits at distance r / sin(atan(0.45)), plus 15%.
        isin::Vec3f lo = triangles[0].v0, hi = lo;
        for (const auto& t : triangles)
            for (const auto& p : {t.v0, t.v1, t.v2})
                lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)},
                hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
        const isin::Vec3f centre = (lo + hi) * 0.5f;
        const float radius = std::max(0.5f * isin::length(hi - lo), 1e-6f);
        const float distance = 1.15f * radius / std::sin(std::atan(0.45f));
        const isin::Vec3f view = isin::normalize(isin::Vec3f{0.45f, 0.5f, -1.0f}); // from the mesh to frame 0's eye
        const isin::Vec3f eye = centre + distance * view;

        isin::Scene<float, isin::Triangle, isin::TexturedTriangle> scene;
        scene.background = {0.05f, 0.07f, 0.12f};
        scene.texture_filter = isin::Filter::nearest;
        isin::Material<float> surface;
        surface.color = isin::from_rgb8<float>(200, 170, 120);
        surface.ka = 0.15f, surface.kd = 0.65f, surface.ks = 0.2f, surface.shininess = 40.0f; // §7
        scene.add_mesh(triangles, scene.add_material(surface));
        // A floor just under the mesh, 8 radii wide, in a checkerboard of radius-sized squares.
        isin::Material<float> floor;
        floor.ka = 0.2f, floor.kd = 0.75f, floor.ks = 0.05f;
        floor.texture = scene.add_texture(isin::Checkerboard<float>{isin::from_rgb8<float>(225, 225, 215),
                                                                    isin::from_rgb8<float>(70, 80, 100), 8, 8});
        const float y = lo.y - 1e-3f * radius, r4 = 4.0f * radius;
        scene.add_textured_rectangle({centre.x - r4, y, centre.z - r4}, {centre.x - r4, y, centre.z + r4},
                                     {centre.x + r4, y, centre.z - r4}, scene.add_material(floor));
        scene.add_light({centre + radius * isin::Vec3f{-2.5f, 4.0f, -1.5f}, {0.8f, 0.8f, 0.75f}}); // §9
        scene.add_light({eye + radius * isin::Vec3f{1.0f, 0.5f, 0.0f}, {0.35f, 0.35f, 0.4f}});

        const int first = o.frames.given() ? o.frames.first : 0, last = o.frames.given() ? o.frames.last : 0;
        for (int frame = first; frame <= last; ++frame) {
            // The orbit: the eye turned about the vertical through the centre (frame 0 exactly the still's).
            const double angle = 2 * 3.141592653589793 * (frame % orbit_frames) / orbit_frames;
            const float c = float(std::cos(angle)), s = float(std::sin(angle));
            const isin::Vec3f around{view.x * c + view.z * s, view.y, view.z * c - view.x * s};
            const auto camera = isin::Camera<float>::look_at(o.width, o.height, centre + distance * around, centre);
            const std::string output = o.frames.given() ? example::frame_path(o.output, frame) : o.output;
            isin::RenderStats stats;
            const isin::Image image = example::render_tile(scene, camera, o, opt, &stats);
            isin::write_image(image, output);
            std::printf("%s: %zu triangles, %d×%d, %.1f ms, %.1f Mrays/s\n", output.c_str(), triangles.size(),
                        image.width(), image.height(), stats.seconds * 1e3, stats.mrays_per_second());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "mesh_view: %s\n", e.what());
        return 1;
    }
    return 0;
}
