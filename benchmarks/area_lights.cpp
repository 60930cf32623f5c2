// Soft shadows' accuracy against speed: a scene lit by S×S RectLights, rendered at W×H with
// light_samples 1 … 256, uniform and adaptive, and 1×1, 2×2, 4×4 pixel samples; for each, the
// render's CPU time (median of R renders, 1 thread) and the RMS error in levels (of 255, over all
// channels) against a converged reference (default 4,096 uniform light samples and 8×8 pixel
// samples: --reference, --reference-pixels), read from --reference-file where it exists, else
// rendered (on --threads threads) and written there; and light_rms_levels, the error against the
// same pixel samples with the reference's light samples (the light sampling's own error, kept in
// F.pixels<P>.ppm). CSV to stdout (docs/area_lights.csv).
//   --scene note   the note's scene, each point light replaced by an S×S RectLight
//   --scene knot   a 19,200-triangle trefoil knot (a mesh) on a floor under an S×S RectLight
//   --rms a b      prints the RMS difference in levels of two pictures (PNG, PPM) and stops
// Run: bash scripts/area_light_chart.sh (the chart), or
//      taskset -c 1 build/bench/benchmarks/area_lights [--scene note|knot] [--width 96] [--height 54]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

#include "meshes.hpp"
#include "note_scene.hpp"

namespace {

double rms_levels(const isin::Image& a, const isin::Image& b) {
    double sum = 0;
    const auto& p = a.pixels();
    const auto& q = b.pixels();
    if (p.size() != q.size() || p.empty()) return -1;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const double dr = double(p[i].r) - q[i].r, dg = double(p[i].g) - q[i].g, db = double(p[i].b) - q[i].b;
        sum += dr * dr + dg * dg + db * db;
    }
    return std::sqrt(sum / (3.0 * double(p.size())));
}

using KnotScene = isin::Scene<float, isin::Sphere, isin::Triangle>;

/// A mesh scene: a trefoil knot (200 × 48 quads, 19,200 triangles) on a grey floor, under a
/// size × size RectLight up and to the left and a dim one in front.
KnotScene knot_scene(float size) {
    KnotScene scene;
    isin::Material<float> gold, floor;
    gold.color = {0.8f, 0.6f, 0.2f};
    gold.ka = 0.1f, gold.kd = 0.6f, gold.ks = 0.3f, gold.shininess = 50;
    floor.color = {0.7f, 0.7f, 0.7f};
    floor.ka = 0.1f, floor.kd = 0.9f, floor.ks = 0;
    scene.add_mesh(isin::Mesh<float>::from_triangles(meshes::trefoil<float>(200, 48, {0, 0, 60}, 5.4)),
                   scene.add_material(gold));
    const auto f = scene.add_material(floor);
    scene.add(isin::Triangle<float>{{-400, -20, -100}, {-400, -20, 800}, {400, -20, -100}}, f);
    scene.add(isin::Triangle<float>{{400, -20, 800}, {400, -20, -100}, {-400, -20, 800}}, f);
    scene.ambient_light = {1, 1, 1};
    scene.add_light(isin::RectLight<float>{{-30 - size / 2, 45, 40 - size / 2}, {size, 0, 0}, {0, 0, size}, {1, 1, 1}});
    scene.add_light(
        isin::RectLight<float>{{20 - size / 4, 10, 0}, {size / 2, 0, 0}, {0, size / 2, 0}, {0.3f, 0.3f, 0.3f}});
    scene.commit();
    return scene;
}

struct Args {
    std::string scene = "note", reference_file;
    int width = 96, height = 54, repeats = 3, reference_samples = 4096, reference_pixels = 8, threads = 1;
    int max_light = 256;
    float size = 20;
};

template <class SceneT, class PointsT>
int run(const Args& a, const SceneT& scene, const PointsT* points) {
    const isin::Camera<float> camera{a.width, a.height};
    isin::RenderOptions opt;
    isin::RenderStats stats;
    isin::Image reference(1, 1);
    if (!a.reference_file.empty()) {
        if (std::ifstream(a.reference_file).good()) reference = isin::read_image(a.reference_file);
    }
    if (reference.width() != a.width || reference.height() != a.height) {
        opt.threads = a.threads;
        opt.samples = a.reference_pixels;
        opt.light_samples = a.reference_samples;
        opt.adaptive_light_samples = false;
        reference = isin::render(scene, camera, opt, &stats);
        std::fprintf(stderr, "reference: %d light samples, %dx%d pixel samples, %d thread(s), %.1f s\n",
                     a.reference_samples, a.reference_pixels, a.reference_pixels, a.threads, stats.seconds);
        if (!a.reference_file.empty()) isin::write_ppm(reference, a.reference_file);
    }
    // The light samples' own error: against the same pixel samples with reference_samples light
    // samples (the pixels' aliasing cancels), one reference a pixel-sample count, kept beside F.
    isin::Image light_reference[5] = {isin::Image(1, 1), isin::Image(1, 1), isin::Image(1, 1), isin::Image(1, 1),
                                      isin::Image(1, 1)};
    for (int pixel : {1, 2, 4}) {
        const std::string file =
            a.reference_file.empty() ? std::string() : a.reference_file + ".pixels" + std::to_string(pixel) + ".ppm";
        isin::Image& ref = light_reference[pixel];
        if (!file.empty() && std::ifstream(file).good()) ref = isin::read_image(file);
        if (ref.width() == a.width && ref.height() == a.height) continue;
        opt.threads = a.threads;
        opt.samples = pixel;
        opt.light_samples = a.reference_samples;
        opt.adaptive_light_samples = false;
        ref = isin::render(scene, camera, opt, &stats);
        if (!file.empty()) isin::write_ppm(ref, file);
    }
    opt.threads = 1;
    std::printf("scene,method,pixel_samples,light_samples,ms,rms_levels,shadow_rays,light_rms_levels\n");
    const auto measure = [&](const char* method, const auto& s, int pixel, int light, bool adaptive) {
        opt.samples = pixel, opt.light_samples = light, opt.adaptive_light_samples = adaptive;
        std::vector<double> ms;
        isin::Image image(1, 1);
        for (int r = 0; r < a.repeats; ++r) { // CPU time: what a shared machine's other processes leave out
            const std::clock_t start = std::clock();
            image = isin::render(s, camera, opt, &stats);
            ms.push_back(double(std::clock() - start) * 1e3 / CLOCKS_PER_SEC);
        }
        std::sort(ms.begin(), ms.end());
        std::printf("%s,%s,%d,%d,%.2f,%.3f,%llu,%.3f\n", a.scene.c_str(), method, pixel, light, ms[ms.size() / 2],
                    rms_levels(image, reference), static_cast<unsigned long long>(stats.shadow),
                    rms_levels(image, light_reference[pixel]));
        std::fflush(stdout);
    };
    for (int pixel : {1, 2, 4}) {
        if (points) measure("point", *points, pixel, 1, false);
        for (int light = 1; light <= a.max_light; light *= 4) {
            measure("uniform", scene, pixel, light, false);
            if (light >= 8) measure("adaptive", scene, pixel, light, true); // below 8: the same as uniform
        }
    }
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        const auto value = [&] { return i + 1 < argc ? std::atof(argv[++i]) : 0.0; };
        const auto text = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
        if (std::strcmp(argv[i], "--width") == 0)
            a.width = std::clamp(int(value()), 8, 4096);
        else if (std::strcmp(argv[i], "--height") == 0)
            a.height = std::clamp(int(value()), 8, 4096);
        else if (std::strcmp(argv[i], "--size") == 0)
            a.size = float(value());
        else if (std::strcmp(argv[i], "--repeats") == 0)
            a.repeats = std::clamp(int(value()), 1, 100);
        else if (std::strcmp(argv[i], "--reference") == 0)
            a.reference_samples = std::clamp(int(value()), 1, isin::RenderOptions::max_light_samples);
        else if (std::strcmp(argv[i], "--reference-pixels") == 0)
            a.reference_pixels = std::clamp(int(value()), 1, 16);
        else if (std::strcmp(argv[i], "--reference-file") == 0)
            a.reference_file = text();
        else if (std::strcmp(argv[i], "--threads") == 0)
            a.threads = std::clamp(int(value()), 0, 256);
        else if (std::strcmp(argv[i], "--max-light-samples") == 0)
            a.max_light = std::clamp(int(value()), 1, 4096);
        else if (std::strcmp(argv[i], "--scene") == 0)
            a.scene = text();
        else if (std::strcmp(argv[i], "--rms") == 0 && i + 2 < argc) {
            const isin::Image x = isin::read_image(argv[i + 1]), y = isin::read_image(argv[i + 2]);
            std::printf("%.3f\n", rms_levels(x, y));
            return 0;
        } else {
            std::printf("usage: area_lights [--scene note|knot] [--width W] [--height H] [--size S] [--repeats R]\n"
                        "                   [--reference N] [--reference-pixels P] [--reference-file F] [--threads T]\n"
                        "                   [--max-light-samples N] | --rms a.png b.png\n");
            return std::strcmp(argv[i], "--help") == 0 ? 0 : 2;
        }
    }
    if (a.scene == "knot") {
        const KnotScene scene = knot_scene(a.size);
        return run<KnotScene, KnotScene>(a, scene, nullptr);
    }
    const auto scene = note_scene::with_area_lights(note_scene::make<float>(), a.size);
    const auto points = note_scene::make<float>();
    return run(a, scene, &points);
}
