// Saving and loading a Bvh (bvh/serialize.hpp) against building it: for each mesh and precision,
// medians over --runs runs of
//   build       isin::Bvh<T>(triangles) on 1 thread and on 2 threads (wall and process CPU time)
//   save        bvh.save(path) (wall: encode, write, fsync, rename)
//   load        Bvh<T>::load(path), the file in the page cache (wall and CPU: read, checksum, checks)
//   memory      Bvh<T>::load_from_memory from a buffer holding the file (wall and CPU)
//   again       load three more times in a row, each Bvh freed before the next (the load alone,
//               without the build's and the buffer's frees changing where its memory comes from)
// and the file's size against Bvh::memory(). The loaded Bvh is checked against the built one on
// 100k rays (hits and the bits of t): "same" or a count of differing rays.
//
// Meshes: the 1.3M icosphere of meshes.hpp, and every PLY or OBJ path given (the dragon:
// bash scripts/dragon.sh fetches it into build/load_models/dragon_le.ply).
// Run: taskset -c 0,1 build/…/benchmarks/bvh_save [--runs N] [--dir DIR] [--double] [PATH…]
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <isin/bvh.hpp>
#include <isin/bvh/serialize.hpp>
#include <isin/mesh.hpp>

#include "meshes.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Minor page faults of the process so far (first touches of fresh pages).
double page_faults() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_minflt);
}

struct Timing {
    std::vector<double> wall, cpu, faults;
    void add(Clock::time_point start, double cpu_start, double faults_start) {
        wall.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        cpu.push_back(1e3 * (cpu_seconds() - cpu_start));
        faults.push_back(page_faults() - faults_start);
    }
};

// Times f() once into t.
template <class F>
void timed(Timing& t, F&& f) {
    const double c = cpu_seconds(), faults = page_faults();
    const auto start = Clock::now();
    f();
    t.add(start, c, faults);
}

// Rays through the mesh's box from around it: how many of them two Bvhs answer differently.
template <class T>
std::size_t differing_rays(const isin::Bvh<T>& a, const isin::Bvh<T>& b, std::size_t& hits) {
    const isin::Box<T> box = a.tree().bounds();
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const auto inside = [&] {
        const auto at = [&](T lo, T hi) { return T(double(lo) + uni(rng) * (double(hi) - double(lo))); };
        return isin::Vertex<T>{at(box.lo.x, box.hi.x), at(box.lo.y, box.hi.y), at(box.lo.z, box.hi.z)};
    };
    std::size_t differ = 0;
    hits = 0;
    for (int i = 0; i < 100000; ++i) {
        const isin::Vertex<T> from = inside() * T(3) - (box.lo + box.hi) * T(1), to = inside();
        const isin::Ray<T> ray{from, to - from};
        const isin::Hit<T> x = a.intersect(ray), y = b.intersect(ray);
        hits += x ? 1u : 0u;
        const bool same = std::memcmp(&x.t, &y.t, sizeof(T)) == 0 && x.primitive == y.primitive &&
                          a.occluded(ray, T(0.5)) == b.occluded(ray, T(0.5));
        differ += same ? 0u : 1u;
    }
    return differ;
}

template <class T>
void measure(const std::string& name, const std::vector<isin::Triangle<T>>& tris, int runs, const std::string& dir) {
    const std::string path = dir + "/bvh_save_" + (sizeof(T) == 4 ? "float" : "double") + ".bvh";
    Timing build1, build, save, load, memory, again;
    std::size_t file_bytes = 0, held = 0, differ = 0, hits = 0;
    for (int run = 0; run < runs; ++run) {
        std::vector<isin::Bvh<T>> built;
        built.reserve(1);
        timed(build1, [&] { isin::Bvh<T> one(tris, isin::BvhOptions{1}); });
        timed(build, [&] { built.emplace_back(tris, isin::BvhOptions{2}); });
        const isin::Bvh<T>& bvh = built[0];
        timed(save, [&] { bvh.save(path); });
        std::vector<isin::Bvh<T>> loaded;
        loaded.reserve(2);
        timed(load, [&] { loaded.push_back(isin::Bvh<T>::load(path)); });
        std::ifstream in(path, std::ios::binary);
        const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        timed(memory, [&] { loaded.push_back(isin::Bvh<T>::load_from_memory(bytes.data(), bytes.size())); });
        for (int k = 0; k < 3; ++k) timed(again, [&] { (void)isin::Bvh<T>::load(path); });
        file_bytes = bytes.size(), held = bvh.memory();
        if (run == 0) {
            std::size_t h2 = 0;
            differ = differing_rays(bvh, loaded[0], hits) + differing_rays(bvh, loaded[1], h2);
        }
    }
    std::filesystem::remove(path);
    const double b1_cpu = median(build1.cpu), b_wall = median(build.wall), b_cpu = median(build.cpu);
    const double l_wall = median(load.wall), l_cpu = median(load.cpu);
    std::printf("%-16s %-6s %9zu  build 1 thread %7.1f ms (cpu %7.1f), 2 threads %7.1f ms (cpu %7.1f)  save %6.1f ms  "
                "load %6.1f ms (cpu %6.1f, %.0f page faults) = %.3fx build cpu 1 thread, %.3fx 2 threads, %.3fx wall 2 "
                "threads  "
                "from memory %6.1f ms (cpu %6.1f)  again %6.1f ms (cpu %6.1f = %.3fx build cpu 1 thread)  file %6.1f "
                "MB = %.3fx memory %6.1f MB  rays %s (%zu hits)\n",
                name.c_str(), sizeof(T) == 4 ? "float" : "double", tris.size(), median(build1.wall), b1_cpu, b_wall,
                b_cpu, median(save.wall), l_wall, l_cpu, median(load.faults), l_cpu / b1_cpu, l_cpu / b_cpu,
                l_wall / b_wall, median(memory.wall), median(memory.cpu), median(again.wall), median(again.cpu),
                median(again.cpu) / b1_cpu, double(file_bytes) / 1e6, double(file_bytes) / double(held),
                double(held) / 1e6, differ ? (std::to_string(differ) + " differ").c_str() : "same", hits);
    std::fflush(stdout);
}

} // namespace

int main(int argc, char** argv) try {
    int runs = 7;
    bool doubles = false;
    std::string dir = std::filesystem::temp_directory_path().string();
    std::vector<std::string> paths;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--runs" && i + 1 < argc)
            runs = std::max(1, std::atoi(argv[++i]));
        else if (a == "--dir" && i + 1 < argc)
            dir = argv[++i];
        else if (a == "--double")
            doubles = true;
        else if (a == "--help" || a == "-h") {
            std::printf("usage: bvh_save [--runs N] [--dir DIR] [--double] [MESH.ply|MESH.obj ...]\n"
                        "  save and load each mesh's Bvh (and a generated 1.3M-triangle icosphere) in DIR,\n"
                        "  and print the load's and save's CPU time against the build's\n");
            return 0;
        } else if (!a.empty() && a[0] == '-') {
            std::fprintf(stderr, "bvh_save: unknown option %s (--help lists them)\n", a.c_str());
            return 2;
        } else
            paths.push_back(a);
    }
    std::printf("isin Bvh save/load against build, medians of %d runs, code paths: slabs %s, leaf %s\n", runs,
                isin::bvh_code_paths.slabs, isin::bvh_code_paths.leaf);
    for (const std::string& path : paths) {
        const std::string name = std::filesystem::path(path).stem().string();
        measure<float>(name, isin::load_mesh<float>(path), runs, dir);
        if (doubles) measure<double>(name, isin::load_mesh<double>(path), runs, dir);
    }
    measure<float>("icosphere-1.3M", meshes::make<float>("icosphere-1.3M"), runs, dir);
    if (doubles) measure<double>("icosphere-1.3M", meshes::make<double>("icosphere-1.3M"), runs, dir);
} catch (const std::exception& e) {
    std::fprintf(stderr, "bvh_save: %s\n", e.what());
    return 1;
}
