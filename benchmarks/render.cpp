// Renders the note's scene (examples/note_scene.hpp) at 800×450 and prints, for 1 and 2 threads
// and for recursion depth 1 (shadows + one level of reflection/refraction) and 4, the median
// wall time of several renders and the throughput in Mrays/s counting every ray: primary,
// shadow, reflection and refraction.
// Run: cmake --workflow --preset bench   (or build/bench/benchmarks/render [--repeats N])
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>

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
    return 0;
}
