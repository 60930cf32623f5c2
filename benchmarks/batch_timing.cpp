// Batch timing for accuracy_vs_speed: Möller–Trumbore over a structure-of-arrays TriangleBatch,
// vectorised by the compiler (this file is built with vectorisation on). Same rays and the same
// 64 triangles as the single-ray figures.
#include <algorithm>
#include <chrono>
#include <vector>

#include "workloads.hpp"

namespace {
template <class T>
double batch_ns(int repeats) {
    const auto cases = workloads::random_pairs<T>(2048, 11);
    std::vector<isin::Triangle<T>> list;
    for (size_t i = 0; i < 64; ++i) list.push_back(cases[i].tri);
    const isin::TriangleBatch<T> batch(list);
    std::vector<double> ns;
    double checksum = 0;
    for (int r = 0; r < repeats; ++r) {
        const auto start = std::chrono::steady_clock::now();
        for (const auto& c : cases)
            batch.each_hit(c.ray, std::numeric_limits<T>::infinity(), [&](std::size_t, T t) { checksum += double(t); return true; });
        ns.push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() /
                     double(cases.size() * list.size()));
    }
    std::sort(ns.begin(), ns.end());
    return checksum == 42 ? 0 : ns[ns.size() / 2];
}
} // namespace

double batch_ns_per_test_mt_float(int repeats) { return batch_ns<float>(repeats); }
double batch_ns_per_test_mt_double(int repeats) { return batch_ns<double>(repeats); }
