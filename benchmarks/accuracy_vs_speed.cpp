// isin's accuracy-against-speed study (issue 4): every ray–triangle and ray–sphere method, in
// float and double, on six seeded workloads, judged against the construction of each case or a
// __float128 reference, and timed on one core in the same run.
// Writes a detailed CSV (one row per method × precision × workload × parameter), a points CSV
// for the chart (one row per method × precision × workload group) and prints a summary.
// Run: bash scripts/accuracy.sh (builds, runs, draws docs/accuracy_vs_speed.{svg,png}).
// This file is built with -fno-tree-vectorize: the single-ray figures are one test at a time.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "batch_kernels.hpp"
#include "methods.hpp"
#include "../tests/support/workloads.hpp"

namespace {

using Q = __float128;
struct QV {
    Q x, y, z;
};
template <class T>
QV q(const isin::Vertex<T>& v) {
    return {Q(v.x), Q(v.y), Q(v.z)};
}
QV sub(QV a, QV b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Q dotq(QV a, QV b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
QV crossq(QV a, QV b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

struct Reference {
    bool hit;
    bool front; // the ray sees the clockwise (front) face: Rd·N < 0
    Q t;        // where the ray meets the triangle's plane
};

// The truth for a ray and a triangle, in __float128 from the exact float/double inputs: the
// three edge triple products agree in sign (inside) and the plane is ahead (t > 0).
template <class T>
Reference reference(const isin::Ray<T>& ray, const isin::Triangle<T>& tri) {
    const QV o = q(ray.origin), d = q(ray.direction);
    const QV a = sub(q(tri.v0), o), b = sub(q(tri.v1), o), c = sub(q(tri.v2), o);
    const Q e0 = dotq(d, crossq(b, c)), e1 = dotq(d, crossq(c, a)), e2 = dotq(d, crossq(a, b));
    const QV N = crossq(sub(q(tri.v1), q(tri.v0)), sub(q(tri.v2), q(tri.v0)));
    const Q denom = dotq(d, N);
    Reference r{false, denom < 0, 0};
    if (denom == 0) return r;
    r.t = dotq(a, N) / denom;
    const bool inside = (e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0);
    r.hit = inside && r.t > 0;
    return r;
}

struct Row {
    std::string group, method, precision, workload;
    double param = 0;
    long n = 0, false_hits = 0, false_misses = 0, leaks = 0, doubles = 0, self_hits = 0, missed_exits = 0;
    std::vector<double> t_errors;
    double ns = 0, ns_batch = 0, batch_agreement = 0;
    long errors() const { return false_hits + false_misses + leaks + self_hits + missed_exits; }
};

Row make_row(std::string group, std::string method, std::string precision, std::string workload, double param) {
    Row r;
    r.group = std::move(group), r.method = std::move(method), r.precision = std::move(precision);
    r.workload = std::move(workload), r.param = param;
    return r;
}

double quantile(std::vector<double> v, double p) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, size_t(p * double(v.size() - 1) + 0.5))];
}

template <class T>
const char* precision_name() {
    return sizeof(T) == 4 ? "float" : "double";
}

// A workload with its references computed once (they are slow: __float128 in software).
template <class T>
struct Judged {
    std::vector<workloads::TriangleCase<T>> cases;
    std::vector<Reference> refs;
};
template <class T>
Judged<T> with_references(std::vector<workloads::TriangleCase<T>> cases) {
    Judged<T> j{std::move(cases), {}};
    for (const auto& c : j.cases) j.refs.push_back(reference(c.ray, c.tri));
    return j;
}

// Judges a method against the exact answer for the actual (rounded) inputs: the reference. How a
// case was built (aimed inside or outside with a margin) only sets the mix of hits and misses.
template <template <class> class M, class T>
Row judge(const char* group, const char* workload, double param, const Judged<T>& j) {
    Row row = make_row(group, M<T>::name, precision_name<T>(), workload, param);
    for (size_t i = 0; i < j.cases.size(); ++i) {
        const auto& c = j.cases[i];
        const Reference& ref = j.refs[i];
        const bool expect = ref.hit && (!M<T>::culls || ref.front);
        const auto h = M<T>::test(c.ray, M<T>::prepare(c.tri));
        ++row.n;
        if (h && !expect) ++row.false_hits;
        if (!h && expect) ++row.false_misses;
        if (h && expect)
            row.t_errors.push_back(double(Q(h.t) > ref.t ? (Q(h.t) - ref.t) / ref.t : (ref.t - Q(h.t)) / ref.t));
    }
    return row;
}

// Closed meshes: rays aimed at shared edges and vertices from the front must find the surface
// there (leak: no triangle within 1e-3 of the aimed-at distance; double: more than one).
template <template <class> class M, class T>
Row judge_mesh(const char* workload, const workloads::MeshCase<T>& m) {
    Row row = make_row("edges", M<T>::name, precision_name<T>(), workload, double(m.mesh.size()));
    std::vector<typename M<T>::Data> data;
    for (const auto& tri : m.mesh) data.push_back(M<T>::prepare(tri));
    const double t_front = workloads::mesh_ray_distance;
    for (const auto& ray : m.rays) {
        int front_hits = 0;
        for (const auto& dd : data) {
            const auto h = M<T>::test(ray, dd);
            if (h && std::fabs(double(h.t) - t_front) <= 1e-3 * t_front) ++front_hits;
        }
        ++row.n;
        row.leaks += front_hits == 0;
        row.doubles += front_hits > 1;
    }
    return row;
}

// ns per test, one ray against a list of 64 triangles (in L1), median of `repeats`.
template <template <class> class M, class T>
double time_triangles(int repeats) {
    const workloads::TriangleTiming<T> timing;
    const auto& cases = timing.cases;
    std::vector<typename M<T>::Data> list;
    for (const auto& tri : timing.triangles) list.push_back(M<T>::prepare(tri));
    std::vector<double> ns;
    double checksum = 0;
    for (int r = 0; r < repeats; ++r) {
        const auto start = std::chrono::steady_clock::now();
        for (const auto& c : cases)
            for (const auto& d : list) {
                const auto h = M<T>::test(c.ray, d);
                if (h) checksum += double(h.t);
            }
        ns.push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() /
                     double(cases.size() * list.size()));
    }
    if (checksum == 42) std::printf(" ");
    return quantile(ns, 0.5);
}

// The triangle workloads of one precision, references included.
template <class T>
struct TriangleWorkloads {
    Judged<T> random = with_references(workloads::random_pairs<T>(20000));
    std::vector<std::pair<double, Judged<T>>> grazing, sizes, offsets, slivers;
    workloads::MeshCase<T> sphere = workloads::closed_sphere_edges<T>(3000), grid = workloads::grid_edges<T>(3000);
    TriangleWorkloads() {
        for (double angle : {1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7})
            grazing.emplace_back(angle, with_references(workloads::grazing<T>(angle, 2000)));
        for (double size : {1e-4, 1e-2, 1.0, 1e2, 1e4, 1e6})
            sizes.emplace_back(size, with_references(workloads::scaled<T>(size, 0.0, 2000)));
        for (double offset : {1.0, 1e3, 1e5, 1e7})
            offsets.emplace_back(offset, with_references(workloads::scaled<T>(1.0, offset, 2000)));
        for (double aspect : {1e1, 1e2, 1e3, 1e4, 1e5, 1e6})
            slivers.emplace_back(aspect, with_references(workloads::slivers<T>(aspect, 2000)));
    }
};

template <template <class> class M, class T>
void triangle_method(std::vector<Row>& rows, const TriangleWorkloads<T>& w, int repeats, double ns_override = 0) {
    const double ns = ns_override > 0 ? ns_override : time_triangles<M, T>(repeats);
    const BatchResult b = ns_override > 0 ? BatchResult{} : batch_triangle_method(M<T>::name, sizeof(T) == 4, repeats);
    std::vector<Row> mine;
    mine.push_back(judge<M, T>("random", "random", 0, w.random));
    for (const auto& [angle, j] : w.grazing) mine.push_back(judge<M, T>("grazing", "grazing-angle", angle, j));
    for (const auto& [size, j] : w.sizes) mine.push_back(judge<M, T>("scale", "scale-size", size, j));
    for (const auto& [offset, j] : w.offsets) mine.push_back(judge<M, T>("scale", "scale-offset", offset, j));
    for (const auto& [aspect, j] : w.slivers) mine.push_back(judge<M, T>("sliver", "sliver-aspect", aspect, j));
    mine.push_back(judge_mesh<M, T>("closed-sphere", w.sphere));
    mine.push_back(judge_mesh<M, T>("flat-grid", w.grid));
    for (auto& r : mine) r.ns = ns, r.ns_batch = b.ns, r.batch_agreement = b.agreement, rows.push_back(r);
}

// Spheres: rays restarted on the surface (secondary rays) for radii 1e-3…1e6, centres up to 1e6
// from the origin (skipped where the precision cannot place a point on the sphere at all).
template <template <class> class M, class T>
void sphere_method(std::vector<Row>& rows, int repeats) {
    std::vector<Row> mine;
    for (double r : {1e-3, 1e-1, 1e1, 1e3, 1e6})
        for (double offset : {0.0, 1e3, 1e6}) {
            if (offset * double(std::numeric_limits<T>::epsilon()) > 1e-3 * r) continue;
            Row row = make_row("restart", M<T>::name, precision_name<T>(),
                               "restart-r1e" + std::to_string(int(std::log10(r))) +
                                   (offset > 0 ? "-offset1e" + std::to_string(int(std::log10(offset))) : "-offset0"),
                               r);
            for (const auto& c : workloads::sphere_restarts<T>(r, offset, 2000)) {
                ++row.n;
                if (M<T>::test(c.outward, c.sphere)) ++row.self_hits; // the exact answer: no hit
                const auto h = M<T>::test(c.inward, c.sphere);
                if (!h) {
                    ++row.missed_exits;
                    continue;
                }
                // exact far side along the inward ray: t = 2 (C − P)·d / (d·d)
                const QV cp = sub(q(c.sphere.center), q(c.inward.origin)), d = q(c.inward.direction);
                const Q t = 2 * dotq(cp, d) / dotq(d, d);
                if (t > 0) row.t_errors.push_back(double((Q(h.t) > t ? Q(h.t) - t : t - Q(h.t)) / t));
            }
            mine.push_back(row);
        }
    // Timing: one ray against 64 spheres (about half hit), median of `repeats`.
    const auto list = workloads::timing_spheres<T>();
    const auto rays = workloads::timing_rays<T>();
    std::vector<double> ns;
    double checksum = 0;
    for (int rep = 0; rep < repeats; ++rep) {
        const auto start = std::chrono::steady_clock::now();
        for (const auto& ray : rays)
            for (const auto& s : list)
                if (const auto h = M<T>::test(ray, s)) checksum += double(h.t);
        ns.push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() /
                     double(rays.size() * list.size()));
    }
    if (checksum == 42) std::printf(" ");
    const BatchResult b = batch_sphere_method(M<T>::name, sizeof(T) == 4, repeats);
    for (auto& r : mine)
        r.ns = quantile(ns, 0.5), r.ns_batch = b.ns, r.batch_agreement = b.agreement, rows.push_back(r);
}

template <class T>
void all_methods(std::vector<Row>& rows, int repeats) {
    const TriangleWorkloads<T> w;
    triangle_method<methods::AreaNote, T>(rows, w, repeats);
    triangle_method<methods::AreaRelative, T>(rows, w, repeats);
    triangle_method<methods::MollerTrumbore, T>(rows, w, repeats);
    triangle_method<methods::MollerTrumboreCull, T>(rows, w, repeats);
    triangle_method<methods::Watertight, T>(rows, w, repeats);
    triangle_method<methods::BaldwinWeber, T>(rows, w, repeats);
    triangle_method<methods::MollerTrumboreBatch, T>(
        rows, w, repeats, sizeof(T) == 4 ? batch_ns_per_test_mt_float(repeats) : batch_ns_per_test_mt_double(repeats));
    sphere_method<methods::SphereNote, T>(rows, repeats);
    sphere_method<methods::SphereNoteFix, T>(rows, repeats);
    sphere_method<methods::SphereIsin, T>(rows, repeats);
    sphere_method<methods::SphereQuadratic, T>(rows, repeats);
    sphere_method<methods::SphereRtg, T>(rows, repeats);
}

} // namespace

int main(int argc, char** argv) {
    std::string csv = "accuracy_vs_speed.csv", points = "accuracy_vs_speed_points.csv";
    int repeats = 7;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--csv") && i + 1 < argc)
            csv = argv[++i];
        else if (!std::strcmp(argv[i], "--points") && i + 1 < argc)
            points = argv[++i];
        else if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc)
            repeats = std::max(1, std::atoi(argv[++i]));
        else {
            std::printf("usage: accuracy_vs_speed [--csv FILE] [--points FILE] [--repeats N]\n");
            return std::strcmp(argv[i], "--help") ? 2 : 0;
        }
    }
    std::vector<Row> rows;
    all_methods<float>(rows, repeats);
    all_methods<double>(rows, repeats);

    FILE* f = std::fopen(csv.c_str(), "w");
    if (!f) {
        std::perror(csv.c_str());
        return 1;
    }
    std::fprintf(f, "group,method,precision,workload,param,n,ns_per_test,false_hits,false_misses,leaks,doubles,self_"
                    "hits,missed_exits,t_err_median,t_err_p999,ns_per_test_batch,batch_agreement\n");
    for (const auto& r : rows)
        std::fprintf(f, "%s,%s,%s,%s,%g,%ld,%.3f,%ld,%ld,%ld,%ld,%ld,%ld,%.3g,%.3g,%.3f,%.6f\n", r.group.c_str(),
                     r.method.c_str(), r.precision.c_str(), r.workload.c_str(), r.param, r.n, r.ns, r.false_hits,
                     r.false_misses, r.leaks, r.doubles, r.self_hits, r.missed_exits, quantile(r.t_errors, 0.5),
                     quantile(r.t_errors, 0.999), r.ns_batch, r.batch_agreement);
    std::fclose(f);

    // One point per method × precision × group: error rate over the whole group.
    struct Agg {
        double ns = 0, ns_batch = 0, agreement = 0;
        long n = 0, errors = 0;
        std::vector<double> t;
    };
    std::map<std::string, Agg> agg;
    for (const auto& r : rows) {
        auto& a = agg[r.group + "," + r.method + "," + r.precision];
        a.ns = r.ns, a.ns_batch = r.ns_batch, a.agreement = r.batch_agreement, a.n += r.n, a.errors += r.errors();
        a.t.insert(a.t.end(), r.t_errors.begin(), r.t_errors.end());
    }
    FILE* p = std::fopen(points.c_str(), "w");
    if (!p) {
        std::perror(points.c_str());
        return 1;
    }
    std::fprintf(
        p, "group,method,precision,ns_per_test,n,errors,error_rate,t_err_p999,ns_per_test_batch,batch_agreement\n");
    std::printf("%-8s %-21s %-6s %8s %8s %8s %9s %11s\n", "group", "method", "type", "ns/test", "batch ns", "tests",
                "errors", "t err p99.9");
    for (const auto& [key, a] : agg) {
        std::fprintf(p, "%s,%.3f,%ld,%ld,%.6g,%.3g,%.3f,%.6f\n", key.c_str(), a.ns, a.n, a.errors,
                     double(a.errors) / double(a.n), quantile(a.t, 0.999), a.ns_batch, a.agreement);
        std::string k = key;
        for (auto& ch : k)
            if (ch == ',') ch = ' ';
        char g[32], m[32], t[16];
        std::sscanf(k.c_str(), "%31s %31s %15s", g, m, t);
        std::printf("%-8s %-21s %-6s %8.2f %8.2f %8ld %9ld %11.2g\n", g, m, t, a.ns, a.ns_batch, a.n, a.errors,
                    quantile(a.t, 0.999));
    }
    std::fclose(p);
    return 0;
}
