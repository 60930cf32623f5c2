// Renders the note's scene (examples/note_scene.hpp) at 800×450 and prints, for 1 and 2 threads
// and for recursion depth 1 (shadows + one level of reflection/refraction) and 4, the median
// wall time of several renders and the throughput in Mrays/s counting every ray: primary,
// shadow, reflection and refraction. Then the cost of smooth shading: a 300k-triangle trefoil
// knot rendered flat and with vertex normals (the shading normal and the shadow-terminator point
// of every hit), renders interleaved, and of sRGB output.
// Run: cmake --workflow --preset bench   (or build/bench/benchmarks/render [--repeats N])
#include <algorithm>
#include <array>
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
    opt.progress = false;
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
    opt.progress = false;
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

} // namespace

int main(int argc, char** argv) {
    int repeats = 9;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc)
            repeats = std::max(1, std::atoi(argv[++i]));
        else {
            std::printf("usage: render [--repeats N]\nTimes the note's scene at 800×450 (median of N renders).\n");
            return std::strcmp(argv[i], "--help") == 0 ? 0 : 2;
        }
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
    std::printf("\nsmooth shading (vertex normals, shadow rays from the shading point) against flat, median of %d "
                "interleaved renders, 800×450, depth 1\n",
                repeats);
    for (int threads : {1, 2}) smooth_shading(threads, repeats);
    return 0;
}
