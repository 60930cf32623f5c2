// How tight Solid::winding_number_bounded's error bound is: for each beta, the bound over the
// actual error |fast − exact| (exact in long double from the same inputs), median and extremes,
// on the closed, holed and overlapping icospheres of benchmarks/queries.cpp, in float and double;
// and how many points contains() could not certify (|w − 1/2| ≤ bound).
// Run: build/bench/benchmarks/winding_bound [points]
#include <isin/solid.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "../tests/support/solids.hpp"

namespace {

using LD = long double;

template <class T>
LD exact_winding(const isin::Mesh<T>& mesh, const isin::Vertex<T>& p) {
    const auto wide = [](const isin::Vertex<T>& v) { return isin::Vertex<LD>{LD(v.x), LD(v.y), LD(v.z)}; };
    LD sum = 0;
    for (std::size_t i = 0; i < mesh.size(); ++i) {
        const isin::Triangle<T> t = mesh.triangle(i);
        sum += isin::solid_angle(wide(p), isin::Triangle<LD>{wide(t.v0), wide(t.v1), wide(t.v2)});
    }
    return sum / (4 * 3.14159265358979323846264338327950288L);
}

double quantile(std::vector<double> v, double q) {
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    return v[std::size_t(q * double(v.size() - 1))];
}

// Random points of the box [lo, hi]³ (half) and points 1e-3 of `diag` off random triangles (half).
template <class T>
std::vector<isin::Vertex<T>> points_of(const isin::Mesh<T>& mesh, double lo, double hi, double diag, int n) {
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> box(lo, hi), unit(0, 1);
    std::uniform_int_distribution<std::size_t> pick(0, mesh.size() - 1);
    std::vector<isin::Vertex<T>> points;
    for (int i = 0; i < n / 2; ++i) points.push_back({T(box(rng)), T(box(rng)), T(box(rng))});
    while (int(points.size()) < n) {
        const isin::Triangle<T> t = mesh.triangle(pick(rng));
        const auto to_d = [](const isin::Vertex<T>& v) {
            return isin::Vertex<double>{double(v.x), double(v.y), double(v.z)};
        };
        const isin::Vertex<double> v0 = to_d(t.v0), v1 = to_d(t.v1), v2 = to_d(t.v2);
        double s = unit(rng), r = unit(rng);
        if (s + r > 1) s = 1 - s, r = 1 - r;
        const isin::Vertex<double> n_ = isin::normalize(isin::cross(v1 - v0, v2 - v0));
        const isin::Vertex<double> q =
            v0 + s * (v1 - v0) + r * (v2 - v0) + (unit(rng) < 0.5 ? -1e-3 : 1e-3) * diag * n_;
        points.push_back({T(q.x), T(q.y), T(q.z)});
    }
    return points;
}

template <class T>
void study(const char* name, const isin::Mesh<T>& mesh, double lo, double hi, double diag, int n) {
    const isin::Solid<T> solid{mesh};
    const auto points = points_of(mesh, lo, hi, diag, n);
    std::vector<LD> ref;
    for (const auto& p : points) ref.push_back(exact_winding(mesh, p));
    const T inf = std::numeric_limits<T>::infinity();
    for (const T beta : {T(1), T(1.5), T(2), T(4), T(16), inf}) {
        std::vector<double> ratio, truncation_share, bound, actual;
        int exceeded = 0, infinite = 0, zero = 0, uncertain = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const isin::WindingNumber<T> w = solid.winding_number_bounded(points[i], beta);
            const double err = double(std::fabs(LD(w.value) - ref[i]));
            if (!(err <= double(w.error_bound))) ++exceeded;
            if (std::fabs(w.value - T(0.5)) <= w.error_bound) ++uncertain;
            if (!std::isfinite(w.error_bound)) {
                ++infinite;
                continue;
            }
            bound.push_back(double(w.error_bound)), actual.push_back(err);
            truncation_share.push_back(double(w.truncation / w.error_bound));
            if (err > 0)
                ratio.push_back(double(w.error_bound) / err);
            else
                ++zero;
        }
        std::printf("%-8s %-12s beta %-5g | bound/error median %9.3g  min %8.3g  max %9.3g | bound median %9.3g"
                    "  error median %9.3g | truncation share median %5.3f | exceeded %d, infinite %d, error 0 %d,"
                    " |w-1/2|<=bound %d of %zu\n",
                    sizeof(T) == 4 ? "float" : "double", name, double(beta), quantile(ratio, 0.5), quantile(ratio, 0.0),
                    quantile(ratio, 1.0), quantile(bound, 0.5), quantile(actual, 0.5), quantile(truncation_share, 0.5),
                    exceeded, infinite, zero, uncertain, points.size());
    }
}

template <class T>
void run(int n) {
    const auto sphere = solids::icosphere<T>(5, {0, 0, 0}, 1.0);
    const double diag = 2 * std::sqrt(3.0);
    study("closed", sphere, -1.1, 1.1, diag, n);
    study("holed", solids::with_holes(sphere, 0.02), -1.1, 1.1, diag, n);
    study("overlapping", solids::merged(sphere, solids::icosphere<T>(5, {0.8, 0.3, 0}, 1.0)), -1.2, 2.0, 3.6, n);
}

} // namespace

int main(int argc, char** argv) {
    const int n = argc > 1 ? std::max(2, std::atoi(argv[1])) : 1000;
    run<float>(n);
    run<double>(n);
}
