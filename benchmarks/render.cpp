// Renders the note's scene (examples/note_scene.hpp) at 800×450 and prints, for 1 and 2 threads
// and for recursion depth 1 (shadows + one level of reflection/refraction) and 4, the median
// wall time of several renders and the throughput in Mrays/s counting every ray: primary,
// shadow, reflection and refraction. Then the cost of smooth shading: a 300k-triangle trefoil
// knot rendered flat and with vertex normals (the shading normal and the shadow-terminator point
// of every hit), renders interleaved, and of sRGB output.
// Run: cmake --workflow --preset bench   (or build/bench/benchmarks/render [--repeats N])
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <unordered_map>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>

#include "meshes.hpp"
#include "note_scene.hpp"

namespace {

template <class T>
void run(int threads, int depth, int repeats) {
    const auto scene = note_scene::make<T>();
    const isin::Camera<T> camera{800, 450};
    isin::RenderOptions opt;
    opt.threads = threads;
    opt.max_depth = depth;
    std::vector<double> ms;
    isin::RenderStats stats;
    unsigned checksum = 0;
    for (int i = 0; i < repeats; ++i) {
        const isin::Image image = isin::render(scene, camera, opt, &stats);
        ms.push_back(stats.seconds * 1e3);
        for (const auto& p : image.pixels()) checksum = checksum * 31u + p.r + p.g + p.b;
    }
    std::sort(ms.begin(), ms.end());
    const double median = ms[ms.size() / 2];
    std::printf("%-7s %7d %5d %10.1f %10.1f %10.1f %12llu %10.2f   %08x\n", sizeof(T) == 4 ? "float" : "double",
                threads, depth, median, ms.front(), ms.back(), static_cast<unsigned long long>(stats.rays()),
                double(stats.rays()) / median * 1e-3, checksum);
}

/// The triangles as a mesh whose corners at the same position share a vertex (what smooth
/// normals need).
isin::Mesh<float> weld(const std::vector<isin::Triangle<float>>& triangles) {
    isin::Mesh<float> mesh;
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> at; // hash of the position → vertices
    for (const auto& t : triangles) {
        std::array<std::uint32_t, 3> k{};
        int c = 0;
        for (const auto& p : {t.v0, t.v1, t.v2}) {
            std::uint32_t bits[3];
            std::memcpy(bits, &p, sizeof bits);
            const std::uint64_t h = (std::uint64_t(bits[0]) * 0x9E3779B97F4A7C15ull) ^
                                    (std::uint64_t(bits[1]) * 0xC2B2AE3D27D4EB4Full) ^ bits[2];
            auto& list = at[h];
            std::uint32_t found = UINT32_MAX;
            for (const std::uint32_t v : list)
                if (mesh.positions[v] == p) found = v;
            if (found == UINT32_MAX) {
                found = std::uint32_t(mesh.positions.size());
                mesh.positions.push_back(p);
                list.push_back(found);
            }
            k[std::size_t(c++)] = found;
        }
        mesh.indices.push_back(k);
    }
    return mesh;
}

/// Smooth shading's cost: the knot flat, then with vertex normals, then smooth with sRGB output.
void smooth_shading(int threads, int repeats) {
    isin::Mesh<float> mesh = weld(meshes::trefoil<float>());
    isin::Scene<float, isin::Sphere> flat, smooth;
    for (auto* scene : {&flat, &smooth}) {
        if (scene == &smooth) isin::compute_normals(mesh, 60.0);
        isin::Material<float> gold;
        gold.color = {0.8f, 0.6f, 0.2f};
        gold.ka = 0.1f, gold.kd = 0.6f, gold.ks = 0.3f, gold.shininess = 50;
        scene->add_mesh(mesh, scene->add_material(gold));
        scene->add_light({{-60, 80, -40}});
        scene->add_light({{50, 30, -80}, {0.4f, 0.4f, 0.4f}});
        scene->commit();
    }
    const isin::Camera<float> camera{800, 450};
    isin::RenderOptions opt;
    opt.threads = threads;
    opt.max_depth = 1;
    std::vector<double> ms[3];
    for (int i = 0; i < repeats; ++i)
        for (int k = 0; k < 3; ++k) {
            isin::RenderStats stats;
            opt.encoding = k == 2 ? isin::ColorEncoding::srgb : isin::ColorEncoding::linear;
            (void)isin::render(k == 0 ? flat : smooth, camera, opt, &stats);
            ms[k].push_back(stats.seconds * 1e3);
        }
    double median[3];
    for (int k = 0; k < 3; ++k) {
        std::sort(ms[k].begin(), ms[k].end());
        median[k] = ms[k][ms[k].size() / 2];
    }
    std::printf("trefoil %zu triangles, %zu vertices, %d thread(s): flat %.1f ms, smooth %.1f ms (%.3f×), "
                "smooth + sRGB %.1f ms (%.3f×)\n",
                mesh.size(), mesh.positions.size(), threads, median[0], median[1], median[1] / median[0], median[2],
                median[2] / median[0]);
}

/// The renderer without tiles: each pixel's rays traced one by one (trace()), rows
/// handed to `threads` threads from a shared counter. For an A/B in one process.
template <class S>
isin::Image render_per_pixel(const S& scene, const isin::Camera<typename S::value_type>& camera, int threads,
                             const isin::RenderOptions& opt, double& seconds) {
    using T = typename S::value_type;
    const auto start = std::chrono::steady_clock::now();
    isin::Image image(camera.width(), camera.height());
    std::atomic<int> next{0};
    auto work = [&] {
        isin::RenderStats stats;
        for (int y; (y = next.fetch_add(1)) < camera.height();)
            for (int x = 0; x < camera.width(); ++x)
                image(x, y) =
                    isin::to_rgb8(isin::trace(scene, camera.primary_ray(T(x), T(y)), 0, opt, stats), opt.encoding);
    };
    std::vector<std::thread> pool;
    for (int i = 1; i < threads; ++i) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return image;
}

/// Renders `scene` with isin::render (8×8 blocks of 4×4 tiles, stream calls: packets where the scene has Bvhs)
/// and with render_per_pixel, interleaved; prints both medians, their ratio, and whether the
/// pictures are the same bit for bit.
template <class S>
void tiles_against_pixels(const char* name, const S& scene, int threads, int depth, int repeats) {
    const isin::Camera<typename S::value_type> camera{800, 450};
    isin::RenderOptions opt;
    opt.threads = threads;
    opt.max_depth = depth;
    std::vector<double> tiles, pixels;
    bool same = true;
    for (int i = 0; i < repeats; ++i) {
        isin::RenderStats stats;
        const isin::Image a = isin::render(scene, camera, opt, &stats);
        tiles.push_back(stats.seconds * 1e3);
        double s = 0;
        const isin::Image b = render_per_pixel(scene, camera, threads, opt, s);
        pixels.push_back(s * 1e3);
        same = same && a.pixels() == b.pixels();
    }
    std::sort(tiles.begin(), tiles.end());
    std::sort(pixels.begin(), pixels.end());
    const double t = tiles[tiles.size() / 2], p = pixels[pixels.size() / 2];
    std::printf("%-22s %7d %5d %10.1f %10.1f %8.2fx   %s\n", name, threads, depth, t, p, p / t,
                same ? "same pixels" : "PIXELS DIFFER");
}

/// A mesh scene: the trefoil knot (300k triangles, one placed mesh) on a floor, two lights.
isin::Scene<float, isin::Sphere, isin::Triangle> knot_scene() {
    isin::Scene<float, isin::Sphere, isin::Triangle> scene;
    isin::Material<float> gold, floor;
    gold.color = {0.8f, 0.6f, 0.2f};
    gold.ka = 0.1f, gold.kd = 0.6f, gold.ks = 0.3f, gold.shininess = 50;
    floor.color = {0.7f, 0.7f, 0.7f};
    scene.add_mesh(isin::Mesh<float>::from_triangles(meshes::trefoil<float>()), scene.add_material(gold));
    const auto f = scene.add_material(floor);
    scene.add(isin::Triangle<float>{{-400, -60, -100}, {-400, -60, 800}, {400, -60, -100}}, f);
    scene.add(isin::Triangle<float>{{400, -60, 800}, {400, -60, -100}, {-400, -60, 800}}, f);
    scene.add_light({{-60, 80, -40}});
    scene.add_light({{50, 30, -80}, {0.4f, 0.4f, 0.4f}});
    scene.commit();
    return scene;
}

/// Soft shadows' cost: the note's scene with its point lights, then with each replaced by a 2×2
/// RectLight at `samples` samples, uniform and adaptive (renders interleaved, medians); prints the
/// times, the ratios to the point lights and the shadow rays.
void area_lights(int threads, int samples, int repeats) {
    const auto points = note_scene::make<float>();
    const auto rects = note_scene::with_area_lights(note_scene::make<float>(), 2.0f);
    const isin::Camera<float> camera{800, 450};
    isin::RenderOptions opt;
    opt.threads = threads;
    opt.light_samples = samples;
    std::vector<double> ms[3];
    std::uint64_t shadow[3] = {};
    for (int i = 0; i < repeats; ++i)
        for (int k = 0; k < 3; ++k) {
            isin::RenderStats stats;
            opt.adaptive_light_samples = k == 2;
            (void)isin::render(k == 0 ? points : rects, camera, opt, &stats);
            ms[k].push_back(stats.seconds * 1e3);
            shadow[k] = stats.shadow;
        }
    double median[3];
    for (int k = 0; k < 3; ++k) {
        std::sort(ms[k].begin(), ms[k].end());
        median[k] = ms[k][ms[k].size() / 2];
    }
    std::printf("%7d %7d %10.1f %10.1f (%5.2fx) %10.1f (%5.2fx) %12llu %12llu %12llu\n", threads, samples, median[0],
                median[1], median[1] / median[0], median[2], median[2] / median[0],
                static_cast<unsigned long long>(shadow[0]), static_cast<unsigned long long>(shadow[1]),
                static_cast<unsigned long long>(shadow[2]));
}

} // namespace

int main(int argc, char** argv) {
    int repeats = 9;
    bool area_only = false;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc)
            repeats = std::max(1, std::atoi(argv[++i]));
        else if (std::strcmp(argv[i], "--area-lights") == 0)
            area_only = true;
        else {
            std::printf("usage: render [--repeats N] [--area-lights]\nTimes the note's scene at 800×450 (median of N "
                        "renders); --area-lights times its soft shadows only.\n");
            return std::strcmp(argv[i], "--help") == 0 ? 0 : 2;
        }
    }
    const auto soft_shadows = [&] {
        std::printf("\nsoft shadows: the note's scene, 800x450, point lights against 2x2 RectLights, median of %d "
                    "interleaved renders\n%7s %7s %10s %20s %20s %12s %12s %12s\n",
                    repeats, "threads", "samples", "points ms", "uniform ms", "adaptive ms", "shadow rays", "uniform",
                    "adaptive");
        for (int samples : {4, 16, 64}) area_lights(1, samples, repeats);
        area_lights(2, 16, repeats);
    };
    if (area_only) {
        soft_shadows();
        return 0;
    }
    std::printf("note's scene, 800×450, one ray per pixel, %d renders each, %u hardware threads\n", repeats,
                std::thread::hardware_concurrency());
    std::printf("%-7s %7s %5s %10s %10s %10s %12s %10s   %s\n", "type", "threads", "depth", "median ms", "min ms",
                "max ms", "rays", "Mrays/s", "checksum");
    for (int depth : {1, 4})
        for (int threads : {1, 2}) {
            run<float>(threads, depth, repeats);
            run<double>(threads, depth, repeats);
        }
    std::printf("\nthe renderer's 8x8 blocks through the stream calls against each pixel traced alone (the renderer "
                "before packets), 800x450, median of %d interleaved renders\n%-22s %7s %5s %10s %10s %9s\n",
                repeats, "scene", "threads", "depth", "tiles ms", "pixels ms", "speed-up");
    const auto knot = knot_scene();
    for (int threads : {1, 2}) {
        tiles_against_pixels("note's scene (float)", note_scene::make<float>(), threads, 1, repeats);
        tiles_against_pixels("trefoil 300k (float)", knot, threads, 1, repeats);
    }
    std::printf("\nsmooth shading (vertex normals, shadow rays from the shading point) against flat, median of %d "
                "interleaved renders, 800×450, depth 1\n",
                repeats);
    for (int threads : {1, 2}) smooth_shading(threads, repeats);
    soft_shadows();
    return 0;
}
