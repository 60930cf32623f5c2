// Mrays/s against triangle count, one thread: where does a BVH start to beat brute force?
//
// Meshes: random soups of 1, 2, 4, …, 128 triangles (seeded, spread across the view, sized so
// that a good part of the rays hit) and icospheres of levels 0…8 (20 … 1,310,720 triangles,
// radius 15 at z = 40). Rays: one primary ray per pixel of the note's camera at 480×270.
// Methods, closest hit:
//   watertight  a plain loop over isin::intersect_watertight (one test at a time)
//   batch       isin::TriangleBatch<float>::nearest (Möller–Trumbore, vectorised)
//   bvh         isin::Bvh<float>::intersect
//   embree      Embree 3 rtcIntersect1 (RTC_BUILD_QUALITY_MEDIUM), when built with Embree
// Brute force is skipped above --brute-max triangles (default 20480); where rays × triangles
// would exceed 1e8 it traces every k-th image row only (the figure is still rays per second).
// Each figure is the median of --repeats timings, each at least ~30 ms long (a timing repeats
// the frame when one frame is shorter). FTZ/DAZ are set (Embree's recommendation) for all.
// Results are cross-checked against the bvh on the same rays (hits and Σt within 1e-4; the
// batch uses a different test, so rays through edges may differ).
//
// Run: build/…/benchmarks/scaling [--csv scaling.csv] [--repeats N] [--width W --height H]
//      (built with -march=native). CSV columns: method,triangles,mrays.
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <isin/batch.hpp>
#include <isin/bvh.hpp>
#include <isin/camera.hpp>
#include <isin/triangle.hpp>

#include "meshes.hpp"

#if ISIN_HAVE_EMBREE
#include "embree_scene.hpp"
#endif

namespace {

using Clock = std::chrono::steady_clock;
using Tri = isin::Triangle<float>;
constexpr double not_measured = std::numeric_limits<double>::quiet_NaN();

struct Totals {
    std::uint64_t hits = 0;
    double sum_t = 0;
};

struct Case {
    std::string series;
    std::vector<Tri> tris;
};

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double relative(double a, double b) { return std::fabs(a - b) / std::max({std::fabs(a), std::fabs(b), 1.0}); }

// Traces rows 0, stride, 2·stride, … of the image; `nearest(ray, t)` says whether the ray hits
// and sets t to the nearest hit.

template <class F>
Totals trace(const isin::Camera<float>& camera, int stride, F&& nearest) {
    Totals acc;
    for (int y = 0; y < camera.height(); y += stride)
        for (int x = 0; x < camera.width(); ++x) {
            float t = 0;
            if (nearest(camera.primary_ray(float(x), float(y)), t)) ++acc.hits, acc.sum_t += double(t);
        }
    return acc;
}

// Median Mrays/s of `repeats` timings, each repeating the frame until it lasts ≥ 30 ms.
template <class F>
double mrays(const isin::Camera<float>& camera, int stride, int repeats, F&& nearest, Totals& totals) {
    const double rays = double(camera.width()) * double((camera.height() + stride - 1) / stride);
    auto t0 = Clock::now();
    totals = trace(camera, stride, nearest); // warm-up, and the frame's time
    const double once = std::chrono::duration<double>(Clock::now() - t0).count();
    const int frames = std::max(1, int(std::ceil(0.03 / std::max(once, 1e-9))));
    std::vector<double> rate;
    for (int r = 0; r < repeats; ++r) {
        t0 = Clock::now();
        for (int f = 0; f < frames; ++f) totals = trace(camera, stride, nearest);
        rate.push_back(rays * frames / std::chrono::duration<double>(Clock::now() - t0).count() * 1e-6);
    }
    return median(rate);
}

} // namespace

int main(int argc, char** argv) {
    int width = 480, height = 270, repeats = 5;
    std::size_t brute_max = 20480;
    std::string csv_path;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has_value = i + 1 < argc;
        if (a == "--csv" && has_value)
            csv_path = argv[++i];
        else if (a == "--repeats" && has_value)
            repeats = std::max(1, std::atoi(argv[++i]));
        else if (a == "--width" && has_value)
            width = std::clamp(std::atoi(argv[++i]), 2, 32768);
        else if (a == "--height" && has_value)
            height = std::clamp(std::atoi(argv[++i]), 2, 32768);
        else if (a == "--brute-max" && has_value)
            brute_max = std::size_t(std::max(0, std::atoi(argv[++i])));
        else {
            std::printf(
                "usage: scaling [--csv FILE] [--repeats N] [--width W] [--height H] [--brute-max TRIANGLES]\n"
                "Mrays/s (one thread, note's camera, default 480x270 primary rays) against triangle count\n"
                "for brute force (watertight loop, TriangleBatch), isin's Bvh and Embree rtcIntersect1;\n"
                "random soups of 1..128 triangles and icospheres of levels 0..8. CSV: method,triangles,mrays.\n");
            return a == "--help" || a == "-h" ? 0 : 2;
        }
    }
    // = _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON) + _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON),
    // spelled out because the DAZ macro trips -Wsign-conversion.
    _mm_setcsr(_mm_getcsr() | unsigned(_MM_FLUSH_ZERO_ON) | unsigned(_MM_DENORMALS_ZERO_ON));

    std::vector<Case> cases;
    for (std::size_t n = 1; n <= 128; n *= 2)
        cases.push_back(
            {"soup", meshes::random_soup<float>(n, 1000 + n, std::min(25.0, 60.0 / std::sqrt(double(n))), 30, 50)});
    for (int level = 0; level <= 8; ++level) cases.push_back({"icosphere", meshes::icosphere<float>(level)});

    const isin::Camera<float> camera{width, height};
    const char* methods[] = {"watertight", "batch", "bvh", "embree"};
#if ISIN_HAVE_EMBREE
    RTCDevice device = rtcNewDevice(nullptr);
    rtcSetDeviceErrorFunction(device, embree_scene::on_error, nullptr);
    const bool have_embree = true;
#else
    const bool have_embree = false;
#endif
    std::FILE* csv = nullptr;
    if (!csv_path.empty()) {
        csv = std::fopen(csv_path.c_str(), "w");
        if (!csv) {
            std::fprintf(stderr, "cannot open %s\n", csv_path.c_str());
            return 2;
        }
        std::fprintf(csv, "method,triangles,mrays\n");
    }
    std::printf("Mrays/s, 1 thread, %dx%d primary rays of the note's camera, median of %d, FTZ/DAZ, -march=native%s\n",
                width, height, repeats, have_embree ? "" : " (built without Embree)");
    std::printf("%-10s %9s %8s %6s | %10s %10s %10s %10s | %s\n", "series", "triangles", "hit %", "row/k", "watertight",
                "batch", "bvh", "embree", "check vs bvh");
    struct Row {
        std::string series;
        std::size_t n;
        double m[4];
    };
    std::vector<Row> rows;
    bool ok = true;
    for (const Case& c : cases) {
        const std::size_t n = c.tris.size();
        Row row{c.series, n, {not_measured, not_measured, not_measured, not_measured}};
        const isin::Bvh<float> bvh{c.tris};
        const auto bvh_nearest = [&](const isin::Ray<float>& ray, float& t) {
            const isin::Hit<float> h = bvh.intersect(ray);
            t = h.t;
            return bool(h);
        };
        Totals bvh_full, tot;
        row.m[2] = mrays(camera, 1, repeats, bvh_nearest, bvh_full);
        std::string check;
        const auto compare = [&](const char* method, const Totals& mine, const Totals& ref) {
            const double d = std::max(relative(double(mine.hits), double(ref.hits)), relative(mine.sum_t, ref.sum_t));
            if (d > 1e-4) check += std::string(" ") + method + " differs by " + std::to_string(d);
            if (d > 1e-3) ok = false;
        };
        int stride = 0;
        if (n <= brute_max) {
            stride = std::max(1, int(std::ceil(double(width) * double(height) * double(n) / 1e8)));
            const Totals ref = stride == 1 ? bvh_full : trace(camera, stride, bvh_nearest);
            row.m[0] = mrays(
                camera, stride, repeats,
                [&](const isin::Ray<float>& ray, float& t) {
                    isin::Hit<float> best;
                    for (const Tri& tri : c.tris) {
                        const isin::Hit<float> h = isin::intersect_watertight(ray, tri);
                        if (h.t < best.t) best = h;
                    }
                    t = best.t;
                    return bool(best);
                },
                tot);
            compare("watertight", tot, ref);
            const isin::TriangleBatch<float> batch{c.tris};
            row.m[1] = mrays(
                camera, stride, repeats,
                [&](const isin::Ray<float>& ray, float& t) {
                    const isin::Hit<float> h = batch.nearest(ray);
                    t = h.t;
                    return bool(h);
                },
                tot);
            compare("batch", tot, ref);
        }
#if ISIN_HAVE_EMBREE
        RTCScene scene = embree_scene::make(device, c.tris);
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        row.m[3] = mrays(
            camera, 1, repeats,
            [&](const isin::Ray<float>& ray, float& t) {
                RTCRayHit rh;
                rh.ray.org_x = ray.origin.x, rh.ray.org_y = ray.origin.y, rh.ray.org_z = ray.origin.z;
                rh.ray.dir_x = ray.direction.x, rh.ray.dir_y = ray.direction.y, rh.ray.dir_z = ray.direction.z;
                rh.ray.tnear = 0.0f, rh.ray.tfar = std::numeric_limits<float>::infinity(), rh.ray.time = 0.0f;
                rh.ray.mask = ~0u, rh.ray.id = 0, rh.ray.flags = 0;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID, rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(scene, &context, &rh);
                t = rh.ray.tfar;
                return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            },
            tot);
        compare("embree", tot, bvh_full);
        rtcReleaseScene(scene);
#endif
        const auto cell = [](double v) {
            char text[32] = "-";
            if (std::isfinite(v)) std::snprintf(text, sizeof text, "%.4g", v);
            return std::string(text);
        };
        std::printf("%-10s %9zu %8.1f %6s | %10s %10s %10s %10s |%s\n", c.series.c_str(), n,
                    100.0 * double(bvh_full.hits) / (double(width) * double(height)),
                    stride ? std::to_string(stride).c_str() : "-", cell(row.m[0]).c_str(), cell(row.m[1]).c_str(),
                    cell(row.m[2]).c_str(), cell(row.m[3]).c_str(), check.empty() ? " OK" : check.c_str());
        std::fflush(stdout);
        if (csv)
            for (int m = 0; m < 4; ++m)
                if (std::isfinite(row.m[m])) std::fprintf(csv, "%s,%zu,%.4f\n", methods[m], n, row.m[m]);
        rows.push_back(row);
    }
#if ISIN_HAVE_EMBREE
    rtcReleaseDevice(device);
#endif
    if (csv) std::fclose(csv);

    // Crossover: the smallest triangle count from which on the Bvh beats a brute-force method at
    // every measured size of the series.
    std::printf("\ncrossover (Bvh faster than brute force at this and every larger measured size):\n");
    for (const char* series : {"soup", "icosphere"})
        for (int m = 0; m < 2; ++m) {
            std::size_t from = 0, largest = 0;
            bool measured = false;
            for (auto it = rows.rbegin(); it != rows.rend(); ++it) {
                if (it->series != series || !std::isfinite(it->m[m])) continue;
                if (!measured) largest = it->n, measured = true;
                if (it->m[2] > it->m[m])
                    from = it->n;
                else
                    break;
            }
            if (!measured) continue;
            if (from == 0)
                std::printf("  %-9s vs %-10s: brute force still faster at %zu triangles\n", series, methods[m],
                            largest);
            else
                std::printf("  %-9s vs %-10s: from %zu triangles\n", series, methods[m], from);
        }
    if (!ok) std::printf("MISMATCH: a method's hits or sum of t differ from the bvh's by more than 1e-3\n");
    return ok ? 0 : 1;
}
