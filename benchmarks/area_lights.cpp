// Soft shadows' accuracy against speed: the note's scene with each point light replaced by an
// S×S RectLight, rendered at W×H with light_samples 1 … 64, uniform and adaptive, and 1×1, 2×2,
// 4×4 pixel samples; for each, the render time (median of R renders, 1 thread) and the RMS error
// in levels (of 255, over all channels) against a reference render (default 256 uniform light
// samples and 4×4 pixel samples: --reference, --reference-pixels). CSV to stdout
// (docs/area_lights.csv, tabled in docs/area_lights.md).
// Run: taskset -c 1 build/bench/benchmarks/area_lights [--width 160] [--height 90] [--size 20]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "note_scene.hpp"

namespace {

double rms_levels(const isin::Image& a, const isin::Image& b) {
    double sum = 0;
    const auto& p = a.pixels();
    const auto& q = b.pixels();
    for (std::size_t i = 0; i < p.size(); ++i) {
        const double dr = double(p[i].r) - q[i].r, dg = double(p[i].g) - q[i].g, db = double(p[i].b) - q[i].b;
        sum += dr * dr + dg * dg + db * db;
    }
    return std::sqrt(sum / (3.0 * double(p.size())));
}

} // namespace

int main(int argc, char** argv) {
    int width = 160, height = 90, repeats = 1, reference_samples = 256, reference_pixels = 4;
    float size = 20;
    for (int i = 1; i < argc; ++i) {
        const auto value = [&] { return i + 1 < argc ? std::atof(argv[++i]) : 0.0; };
        if (std::strcmp(argv[i], "--width") == 0)
            width = std::max(8, int(value()));
        else if (std::strcmp(argv[i], "--height") == 0)
            height = std::max(8, int(value()));
        else if (std::strcmp(argv[i], "--size") == 0)
            size = float(value());
        else if (std::strcmp(argv[i], "--repeats") == 0)
            repeats = std::max(1, int(value()));
        else if (std::strcmp(argv[i], "--reference") == 0)
            reference_samples = std::max(1, int(value()));
        else if (std::strcmp(argv[i], "--reference-pixels") == 0)
            reference_pixels = std::min(16, std::max(1, int(value())));
        else {
            std::printf("usage: area_lights [--width W] [--height H] [--size S] [--repeats R] [--reference N]\n"
                        "                   [--reference-pixels P]\n");
            return std::strcmp(argv[i], "--help") == 0 ? 0 : 2;
        }
    }
    const auto scene = note_scene::with_area_lights(note_scene::make<float>(), size);
    const auto points = note_scene::make<float>();
    const isin::Camera<float> camera{width, height};
    isin::RenderOptions opt;
    opt.threads = 1;
    opt.samples = reference_pixels;
    opt.light_samples = reference_samples;
    opt.adaptive_light_samples = false;
    isin::RenderStats stats;
    const isin::Image reference = isin::render(scene, camera, opt, &stats);
    std::fprintf(stderr, "reference: %d light samples, %dx%d pixel samples, %.1f s\n", reference_samples,
                 reference_pixels, reference_pixels, stats.seconds);
    std::printf("method,pixel_samples,light_samples,ms,rms_levels,shadow_rays\n");
    const auto measure = [&](const char* method, const auto& s, int pixel, int light, bool adaptive) {
        opt.samples = pixel, opt.light_samples = light, opt.adaptive_light_samples = adaptive;
        std::vector<double> ms;
        isin::Image image(1, 1);
        for (int r = 0; r < repeats; ++r) {
            image = isin::render(s, camera, opt, &stats);
            ms.push_back(stats.seconds * 1e3);
        }
        std::sort(ms.begin(), ms.end());
        std::printf("%s,%d,%d,%.2f,%.3f,%llu\n", method, pixel, light, ms[ms.size() / 2], rms_levels(image, reference),
                    static_cast<unsigned long long>(stats.shadow));
        std::fflush(stdout);
    };
    for (int pixel : {1, 2, 4}) {
        measure("point", points, pixel, 1, false);
        for (int light : {1, 4, 16, 64}) {
            measure("uniform", scene, pixel, light, false);
            measure("adaptive", scene, pixel, light, true);
        }
    }
    return 0;
}
