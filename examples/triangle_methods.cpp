// Renders the note's scene twice — triangles by the area test (§4) and by Möller–Trumbore (§10) —
// side by side into one image, and prints how many pixels differ.
// Build: c++ -std=c++17 -O2 -DISIN_IMPLEMENTATION -I include examples/triangle_methods.cpp -o triangle_methods
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "note_scene.hpp"
#include "options.hpp"

int main(int argc, char** argv) {
    const char* usage = "usage: triangle_methods [--width 800] [--height 450] [--output triangle_methods.png]\n"
                        "                        [--threads N]\n"
                        "Renders the note's scene with the area test (left) and Möller–Trumbore (right) into one\n"
                        "(2·width)×height image and prints the number of pixels that differ, and by how much.\n";
    const auto o = example::parse(argc, argv, usage, "triangle_methods.png", -1, 2); // writes (2·width)×height
    try {
        auto scene = note_scene::make<float>();
        const isin::Camera<float> camera{o.width, o.height};
        isin::RenderOptions opt;
        opt.threads = o.threads;
        opt.samples = o.samples;
        isin::RenderStats area_stats, mt_stats;
        scene.triangle_method = isin::TriangleMethod::area;
        const isin::Image area = isin::render(scene, camera, opt, &area_stats);
        scene.triangle_method = isin::TriangleMethod::moller_trumbore;
        const isin::Image mt = isin::render(scene, camera, opt, &mt_stats);

        isin::Image both(2 * o.width, o.height);
        long differ = 0, differ_more = 0;
        for (int y = 0; y < o.height; ++y)
            for (int x = 0; x < o.width; ++x) {
                const isin::Rgb8 a = area(x, y), m = mt(x, y);
                both(x, y) = a;
                both(o.width + x, y) = m;
                const int d = std::abs(a.r - m.r) + std::abs(a.g - m.g) + std::abs(a.b - m.b);
                differ += d > 0;
                differ_more += d > 6;
            }
        isin::write_image(both, o.output);
        const double pixels = double(o.width) * o.height;
        std::printf("%s: area test %.1f ms, Möller–Trumbore %.1f ms (ratio %.2f)\n", o.output.c_str(),
                    area_stats.seconds * 1e3, mt_stats.seconds * 1e3, area_stats.seconds / mt_stats.seconds);
        std::printf("pixels that differ: %ld of %.0f (%.4f%%); by more than 2 levels a channel: %ld\n", differ, pixels,
                    100.0 * double(differ) / pixels, differ_more);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "triangle_methods: %s\n", e.what());
        return 1;
    }
    return 0;
}
