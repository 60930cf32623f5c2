// Batch timings for accuracy_vs_speed: every method's structure-of-arrays loop (batch_kernels.hpp),
// vectorised by the compiler (this file is built with vectorisation on), on the same rays and
// the same 64 triangles or spheres as the single-ray figures; and how often each batch loop
// decides exactly like the scalar method (hit or miss) on the random and restart workloads.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

#include "batch_kernels.hpp"
#include "../tests/support/workloads.hpp"

namespace {

template <class F>
double median_ns(int repeats, std::size_t tests, F&& run) {
    std::vector<double> ns;
    for (int r = 0; r < repeats; ++r) {
        const auto start = std::chrono::steady_clock::now();
        run();
        ns.push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() /
                     double(tests));
    }
    std::sort(ns.begin(), ns.end());
    return ns[ns.size() / 2];
}

template <class T>
isin::Hit<T> scalar_triangle(const std::string& m, const isin::Ray<T>& r, const isin::Triangle<T>& t) {
    if (m == "area-note") return isin::intersect_area(r, t, T(0.005));
    if (m == "area-relative") return isin::intersect_area(r, t);
    if (m == "moller-trumbore") return isin::intersect_moller_trumbore(r, t);
    if (m == "moller-trumbore-cull") return isin::intersect_moller_trumbore(r, t, true);
    if (m == "watertight") return isin::intersect_watertight(r, t);
    return isin::intersect_baldwin_weber(r, t);
}

template <class T>
void batch_triangle(const std::string& m, const isin::Ray<T>& r, const batch::Triangles<T>& b,
                    const batch::Transforms<T>& bw, T* out) {
    if (m == "area-note")
        batch::area<T, false>(r, b, out, T(0.005));
    else if (m == "area-relative")
        batch::area<T, true>(r, b, out, T(0));
    else if (m == "moller-trumbore")
        batch::moller_trumbore<T, false>(r, b, out);
    else if (m == "moller-trumbore-cull")
        batch::moller_trumbore<T, true>(r, b, out);
    else if (m == "watertight")
        batch::watertight(r, b, out);
    else
        batch::baldwin_weber(r, bw, out);
}

template <class T>
BatchResult triangles(const std::string& m, int repeats) {
    const workloads::TriangleTiming<T> timing;
    const auto& cases = timing.cases;
    const auto& list = timing.triangles;
    const batch::Triangles<T> b(list);
    const batch::Transforms<T> bw(list);
    T out[64];
    double checksum = 0;
    BatchResult res;
    res.ns = median_ns(repeats, cases.size() * list.size(), [&] {
        for (const auto& c : cases) {
            batch_triangle(m, c.ray, b, bw, out);
            for (T t : out) checksum += t < batch::inf<T> ? double(t) : 0.0;
        }
    });
    // Agreement, case by case (a batch of one), on the random workload.
    const auto judge = workloads::random_pairs<T>(20000);
    long same = 0;
    for (const auto& c : judge) {
        const std::vector<isin::Triangle<T>> one{c.tri};
        T t[1];
        batch_triangle(m, c.ray, batch::Triangles<T>(one), batch::Transforms<T>(one), t);
        same += bool(t[0] < batch::inf<T>) == bool(scalar_triangle(m, c.ray, c.tri));
    }
    res.agreement = double(same) / double(judge.size()) + (checksum == 42 ? 1 : 0);
    return res;
}

template <class T>
isin::Hit<T> scalar_sphere(batch::SphereMethod m, const isin::Ray<T>& r, const isin::Sphere<T>& s) {
    switch (m) {
    case batch::SphereMethod::note: return isin::intersect_note(r, s);
    case batch::SphereMethod::note_fix: return isin::intersect_note(r, s, T(0.001));
    case batch::SphereMethod::isin: return isin::intersect(r, s);
    case batch::SphereMethod::quadratic: return isin::intersect_quadratic(r, s);
    default: return isin::intersect_rtg(r, s);
    }
}

template <class T>
void batch_spheres(batch::SphereMethod m, const isin::Ray<T>& r, const batch::Spheres<T>& b, T* out) {
    switch (m) {
    case batch::SphereMethod::note: batch::spheres<T, batch::SphereMethod::note>(r, b, out); break;
    case batch::SphereMethod::note_fix: batch::spheres<T, batch::SphereMethod::note_fix>(r, b, out); break;
    case batch::SphereMethod::isin: batch::spheres<T, batch::SphereMethod::isin>(r, b, out); break;
    case batch::SphereMethod::quadratic: batch::spheres<T, batch::SphereMethod::quadratic>(r, b, out); break;
    default: batch::spheres<T, batch::SphereMethod::rtg>(r, b, out);
    }
}

template <class T>
BatchResult spheres(batch::SphereMethod m, int repeats) {
    const auto list = workloads::timing_spheres<T>();
    const auto rays = workloads::timing_rays<T>();
    const batch::Spheres<T> b(list);
    T out[64];
    double checksum = 0;
    BatchResult res;
    res.ns = median_ns(repeats, rays.size() * list.size(), [&] {
        for (const auto& r : rays) {
            batch_spheres(m, r, b, out);
            for (T t : out) checksum += t < batch::inf<T> ? double(t) : 0.0;
        }
    });
    // Agreement on the timing rays and on restarted rays (outward and inward) at several radii.
    long same = 0, n = 0;
    auto check = [&](const isin::Ray<T>& r, const isin::Sphere<T>& s) {
        const std::vector<isin::Sphere<T>> one{s};
        T t[1];
        batch_spheres(m, r, batch::Spheres<T>(one), t);
        same += bool(t[0] < batch::inf<T>) == bool(scalar_sphere(m, r, s));
        ++n;
    };
    for (std::size_t i = 0; i < 256; ++i)
        for (const auto& s : list) check(rays[i], s);
    for (double radius : {1e-3, 1.0, 1e3})
        for (const auto& c : workloads::sphere_restarts<T>(radius, 0.0, 500))
            check(c.outward, c.sphere), check(c.inward, c.sphere);
    res.agreement = double(same) / double(n) + (checksum == 42 ? 1 : 0);
    return res;
}

} // namespace

BatchResult batch_triangle_method(const char* method, bool is_float, int repeats) {
    return is_float ? triangles<float>(method, repeats) : triangles<double>(method, repeats);
}

BatchResult batch_sphere_method(const char* method, bool is_float, int repeats) {
    const std::string m = method;
    const auto which = m == "sphere-note"        ? batch::SphereMethod::note
                       : m == "sphere-note-fix"  ? batch::SphereMethod::note_fix
                       : m == "sphere-isin"      ? batch::SphereMethod::isin
                       : m == "sphere-quadratic" ? batch::SphereMethod::quadratic
                                                 : batch::SphereMethod::rtg;
    return is_float ? spheres<float>(which, repeats) : spheres<double>(which, repeats);
}

double batch_ns_per_test_mt_float(int repeats) { return triangles<float>("moller-trumbore", repeats).ns; }
double batch_ns_per_test_mt_double(int repeats) { return triangles<double>("moller-trumbore", repeats).ns; }
