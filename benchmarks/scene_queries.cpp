// Scene::closest_point against the Bvh's own closest_point on the same mesh (the 20k icosphere)
// and the same points relative to it (random in its box enlarged 20%), one placement per scene:
// the mesh where it stands, turned, scaled uniformly (mesh-space walk), scaled non-uniformly
// and sheared (world-space bounds and triangles). Each run times every case once, in turn;
// figures are medians over the runs, as ratios to the Bvh's time in the same process.
// Run: taskset -c 1 build/bench/benchmarks/scene_queries [points] [runs]
#include <isin/isin.hpp>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "../tests/support/solids.hpp"

namespace {

using Clock = std::chrono::steady_clock;

constexpr std::size_t cases = 6;
const char* const names[cases] = {
    "Bvh", "Scene, identity", "Scene, rotation", "Scene, scale 2.5", "Scene, scale (3, 0.4, 1.5)", "Scene, shear"};

// Where case c places the mesh (far from the identity placement add_mesh makes).
template <class T>
isin::Transform<T> place(std::size_t c) {
    using Tf = isin::Transform<T>;
    const Tf far = Tf::translation({T(100), T(0), T(0)});
    Tf shear = Tf::identity();
    shear.m[0][1] = T(0.8), shear.m[2][0] = T(-0.6), shear.m[1][2] = T(0.3);
    switch (c) {
    case 2: return far * Tf::rotation({T(1), T(2), T(3)}, T(0.7));
    case 3: return far * Tf::scaling(T(2.5));
    case 4: return far * Tf::rotation({T(0), T(1), T(1)}, T(1.1)) * Tf::scaling({T(3), T(0.4), T(1.5)});
    case 5: return far * shear;
    default: return Tf::identity();
    }
}

template <class T>
void run(const char* precision, std::size_t n, int runs) {
    const auto mesh = solids::icosphere<T>(5, {0.1, 0.2, -0.1}, 1.0);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-1.2, 1.2);
    std::vector<isin::Vertex<T>> local(n);
    for (auto& p : local) p = {T(u(rng)), T(u(rng)), T(u(rng))};
    const isin::Bvh<T> bvh{mesh};
    std::vector<isin::Scene<T, isin::Sphere>> scenes(cases);
    for (std::size_t c = 1; c < cases; ++c) {
        const auto id = scenes[c].add_mesh(mesh, scenes[c].add_material({}));
        if (c > 1) scenes[c].add_instance(id, place<T>(c));
        scenes[c].commit();
    }
    std::vector<double> ns[cases], ratio[cases];
    double sum[cases] = {};
    for (int r = 0; r < runs; ++r) {
        double this_run[cases];
        for (std::size_t c = 0; c < cases; ++c) {
            const isin::Transform<T> to = place<T>(c);
            const auto t0 = Clock::now();
            double s = 0;
            for (const auto& q : local) {
                const isin::Vertex<T> p = to.point(q);
                s += double(c == 0 ? bvh.closest_point(p).distance : scenes[c].closest_point(p).distance);
            }
            this_run[c] = std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / double(n);
            sum[c] = s;
        }
        for (std::size_t c = 0; c < cases; ++c)
            ns[c].push_back(this_run[c]), ratio[c].push_back(this_run[c] / this_run[0]);
    }
    const auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return v[v.size() / 2];
    };
    std::printf("%s, %zu points, %d runs (medians; checksum: sum of distances)\n", precision, n, runs);
    for (std::size_t c = 0; c < cases; ++c)
        std::printf("  %-28s %9.1f ns/point  %6.3fx the Bvh  (%.3f-%.3f)  checksum %.6g\n", names[c], median(ns[c]),
                    median(ratio[c]), *std::min_element(ratio[c].begin(), ratio[c].end()),
                    *std::max_element(ratio[c].begin(), ratio[c].end()), sum[c]);
}

} // namespace

int main(int argc, char** argv) {
    const std::size_t n = argc > 1 ? std::size_t(std::atol(argv[1])) : 20000;
    const int runs = argc > 2 ? std::atoi(argv[2]) : 5;
    run<float>("float", n, runs);
    run<double>("double", n, runs);
}
