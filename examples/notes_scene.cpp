// Renders the note's scene — triangles U, Y, Z of example 5a, a mirror sphere, a glass sphere, a
// checkerboard floor, two lights with shadows — to a PNG (or PPM); or frames of a camera path
// through it, or one band of rows of either (pieces a job scheduler runs apart: docs/rendering.md).
// Build: c++ -std=c++17 -O2 -DISIN_IMPLEMENTATION -I include examples/notes_scene.cpp -o notes_scene
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include "note_scene.hpp"
#include "options.hpp"

namespace {

constexpr int loop_frames = 240; // the camera path repeats every 240 frames (10 s at 24 frames/s)

/// The camera of frame `frame`: frame 0 is the note's (§3: eye at 0, 16×9 plane at z = 10); then
/// it sways 25 units left and right of it, turning up to 15° towards the middle, in a loop.
isin::Camera<float> path_camera(int width, int height, int frame) {
    const double phase = 2 * 3.141592653589793 * (frame % loop_frames) / loop_frames;
    const double sway = std::sin(phase);
    const isin::Vec3f eye{float(-25 * sway), 0.0f, float(10 * (1 - std::cos(phase)))};
    return isin::Camera<float>{width, height, eye, float(sway * 15 * 3.141592653589793 / 180), 0.0f};
}

} // namespace

int main(int argc, char** argv) {
    const char* usage = "usage: notes_scene [--width 800] [--height 450] [--output notes_scene.png] [--threads N]\n"
                        "                   [--samples N] [--frames A..B] [--tile I/N] [--area-light S]\n"
                        "                   [--light-samples N] [--uniform-light-samples] [--fresnel]\n"
                        "Renders the note's scene (triangles of example 5a, mirror and glass spheres, a textured\n"
                        "floor, two lights with shadows). --threads 0 uses every core; --samples N traces N×N\n"
                        "rays per pixel; the output format follows the extension (.png or .ppm).\n"
                        "--frames A..B renders frames A to B of a camera path (a 240-frame loop swaying across the\n"
                        "scene; frame 0 is the still picture), each to OUTPUT with its number: a %d or %04d in it\n"
                        "is replaced, else _NNNN goes before the extension. --tile I/N renders band I (from 0) of\n"
                        "N bands of rows only, exactly those rows of the whole picture: merge_tiles stacks them.\n"
                        "--area-light S replaces each light by an S×S rectangle (soft shadows), sampled\n"
                        "--light-samples N times per point (default 16; adaptive: more only in penumbrae, unless\n"
                        "--uniform-light-samples); --fresnel splits the glass's light by Fresnel's equations.\n";
    auto o = example::parse(argc, argv, usage, "notes_scene.png", 1000000, 1, true);
    try {
        auto scene = note_scene::make<float>();
        isin::RenderOptions opt;
        opt.progress = example::progress_bar();
        example::apply_lighting(scene, o, opt, 1.0f);
        opt.threads = o.threads;
        opt.samples = o.samples;
        const int first = o.frames.given() ? o.frames.first : 0, last = o.frames.given() ? o.frames.last : 0;
        for (int frame = first; frame <= last; ++frame) {
            const auto camera = path_camera(o.width, o.height, frame);
            const std::string output = o.frames.given() ? example::frame_path(o.output, frame) : o.output;
            isin::RenderStats stats;
            const isin::Image image = example::render_tile(scene, camera, o, opt, &stats);
            isin::write_image(image, output);
            std::printf("%s: %d×%d, %llu rays (%llu primary, %llu shadow, %llu reflection, %llu "
                        "refraction) in %.1f ms, %.1f Mrays/s\n",
                        output.c_str(), image.width(), image.height(), static_cast<unsigned long long>(stats.rays()),
                        static_cast<unsigned long long>(stats.primary), static_cast<unsigned long long>(stats.shadow),
                        static_cast<unsigned long long>(stats.reflection),
                        static_cast<unsigned long long>(stats.refraction), stats.seconds * 1e3,
                        stats.mrays_per_second());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "notes_scene: %s\n", e.what());
        return 1;
    }
    return 0;
}
