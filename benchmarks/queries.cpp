// Geometric queries side by side in one process, one thread:
//  1. closest points: isin's Bvh::closest_point against Embree's rtcPointQuery with a
//     closest-point callback (Ericson's regions, as Embree's closest_point tutorial) and, when
//     built with CGAL, CGAL's AABB_tree::closest_point_and_primitive; random points in the
//     mesh's box enlarged 10%, the same points for all, checksums of the distances;
//  2. inside/outside: one-ray parity, the majority of three rays, Solid's fast winding number at
//     several beta and the exact winding number, on a closed icosphere, the same with 2% of its
//     triangles removed and two overlapping closed spheres stored as one mesh: wrong answers
//     (points at least 1e-3 of the diagonal from the surface) against time per point.
// Each run times every method once, in turn, and each figure is the median over the runs. The
// Stanford dragon is measured too when build/load_models/dragon_le.ply exists (scripts/dragon.sh).
// Run: bash scripts/queries.sh (taskset -c 1, Release, -march=native).
#include <isin/isin.hpp>

#include <embree3/rtcore.h>
#include <xmmintrin.h>

#if defined(ISIN_HAVE_CGAL)
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#endif

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "../tests/support/solids.hpp"
#include "embree_scene.hpp"
#include "meshes.hpp"

namespace {

using Clock = std::chrono::steady_clock;

// Embree's closest-point callback: Ericson's ClosestPtPointTriangle on the primitive, and the
// query's radius shrunk to each closer point (as Embree's closest_point tutorial).
struct EmbreeClosest {
    const std::vector<isin::Triangle<float>>* tris;
    float distance;
    unsigned primitive;
};

isin::Vertex<float> ericson(const isin::Vertex<float>& p, const isin::Vertex<float>& a, const isin::Vertex<float>& b,
                            const isin::Vertex<float>& c) {
    const auto ab = b - a, ac = c - a, ap = p - a;
    const float d1 = isin::dot(ab, ap), d2 = isin::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const auto bp = p - b;
    const float d3 = isin::dot(ab, bp), d4 = isin::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const auto cp = p - c;
    const float d5 = isin::dot(ab, cp), d6 = isin::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const float vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
    const float vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
    const float va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    const float denom = 1 / (va + vb + vc);
    return a + (vb * denom) * ab + (vc * denom) * ac;
}

bool embree_closest(RTCPointQueryFunctionArguments* args) {
    auto* r = static_cast<EmbreeClosest*>(args->userPtr);
    const auto& t = (*r->tris)[args->primID];
    const isin::Vertex<float> q{args->query->x, args->query->y, args->query->z};
    const float d = isin::length(ericson(q, t.v0, t.v1, t.v2) - q);
    if (d < args->query->radius) {
        args->query->radius = d;
        r->distance = d, r->primitive = args->primID;
        return true;
    }
    return false;
}

std::vector<isin::Vertex<float>> box_points(const std::vector<isin::Triangle<float>>& tris, int n, std::uint64_t seed) {
    isin::Box<float> b;
    for (const auto& t : tris) b.grow(t.v0), b.grow(t.v1), b.grow(t.v2);
    const auto grow = 0.05f * (b.hi - b.lo); // 10% larger: 5% on each side
    std::mt19937_64 rng(seed);
    std::vector<isin::Vertex<float>> points;
    for (int i = 0; i < n; ++i) {
        const auto u = [&](float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(rng); };
        points.push_back({u(b.lo.x - grow.x, b.hi.x + grow.x), u(b.lo.y - grow.y, b.hi.y + grow.y),
                          u(b.lo.z - grow.z, b.hi.z + grow.z)});
    }
    return points;
}

void closest_points(const std::string& name, const std::vector<isin::Triangle<float>>& tris, RTCDevice device, int n,
                    int runs) {
    const auto points = box_points(tris, n, 42);
    const isin::Bvh<float> bvh{tris};
    RTCScene scene = embree_scene::make(device, tris);
#if defined(ISIN_HAVE_CGAL)
    using K = CGAL::Simple_cartesian<double>;
    using Iterator = std::vector<K::Triangle_3>::const_iterator;
    using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Iterator>>>;
    std::vector<K::Triangle_3> cgal_tris;
    for (const auto& t : tris)
        cgal_tris.emplace_back(K::Point_3(t.v0.x, t.v0.y, t.v0.z), K::Point_3(t.v1.x, t.v1.y, t.v1.z),
                               K::Point_3(t.v2.x, t.v2.y, t.v2.z));
    Tree tree(cgal_tris.cbegin(), cgal_tris.cend());
    tree.accelerate_distance_queries();
#endif
    // Each run times every method once, one after the other, so that a change of load on the
    // shared machine falls on all of them; figures are medians over the runs.
    std::vector<isin::PointHit<float>> hits(points.size());
    std::vector<std::string> methods = {"isin", "isin-stream", "embree"};
#if defined(ISIN_HAVE_CGAL)
    methods.push_back("cgal");
#endif
    std::vector<std::vector<double>> seconds(methods.size());
    std::vector<double> sums(methods.size());
    for (int r = 0; r < runs; ++r)
        for (std::size_t m = 0; m < methods.size(); ++m) {
            double sum = 0;
            const auto t0 = Clock::now();
            if (methods[m] == "isin") {
                for (const auto& p : points) sum += double(bvh.closest_point(p).distance);
            } else if (methods[m] == "isin-stream") {
                bvh.closest_point(points.data(), points.size(), hits.data(), 1);
                for (const auto& h : hits) sum += double(h.distance);
            } else if (methods[m] == "embree") {
                for (const auto& p : points) {
                    RTCPointQuery q{};
                    q.x = p.x, q.y = p.y, q.z = p.z, q.time = 0, q.radius = std::numeric_limits<float>::infinity();
                    RTCPointQueryContext context;
                    rtcInitPointQueryContext(&context);
                    EmbreeClosest e{&tris, std::numeric_limits<float>::infinity(), RTC_INVALID_GEOMETRY_ID};
                    rtcPointQuery(scene, &q, &context, embree_closest, &e);
                    sum += double(e.distance);
                }
            } else {
#if defined(ISIN_HAVE_CGAL)
                for (const auto& p : points) {
                    const K::Point_3 q(p.x, p.y, p.z);
                    sum += std::sqrt(CGAL::squared_distance(q, tree.closest_point_and_primitive(q).first));
                }
#endif
            }
            seconds[m].push_back(std::chrono::duration<double>(Clock::now() - t0).count());
            sums[m] = sum;
        }
    rtcReleaseScene(scene);
    for (std::size_t m = 0; m < methods.size(); ++m) {
        std::sort(seconds[m].begin(), seconds[m].end());
        std::printf("closest,%s,%zu,%d,%s,%.0f,%.9g\n", name.c_str(), tris.size(), n, methods[m].c_str(),
                    n / seconds[m][seconds[m].size() / 2], sums[m]);
    }
    std::fflush(stdout);
}

// Inside/outside methods: each one's wrong answers against `truth` and its time per point (the
// median over `runs` runs; each run takes the points in chunks of `chunk` and times every method
// on each chunk in turn, so that a change of load on the shared machine falls on all of them),
// and in each run its throughput over the first method's (one-ray parity).
constexpr std::size_t chunk = 100;
struct InsideMethod {
    std::string name;
    std::function<bool(const isin::Vertex<float>&)> f;
};
void inside_methods(const std::string& mesh, const std::vector<InsideMethod>& methods,
                    const std::vector<isin::Vertex<float>>& points, const std::vector<bool>& truth, int runs) {
    std::vector<std::vector<double>> seconds(methods.size());
    std::vector<std::size_t> wrong(methods.size());
    for (int r = 0; r < runs; ++r) {
        for (std::size_t m = 0; m < methods.size(); ++m) seconds[m].push_back(0), wrong[m] = 0;
        for (std::size_t begin = 0; begin < points.size(); begin += chunk)
            for (std::size_t m = 0; m < methods.size(); ++m) {
                const std::size_t end = std::min(points.size(), begin + chunk);
                std::size_t w = 0;
                const auto t0 = Clock::now();
                for (std::size_t i = begin; i < end; ++i) w += methods[m].f(points[i]) != truth[i];
                seconds[m].back() += std::chrono::duration<double>(Clock::now() - t0).count();
                wrong[m] += w;
            }
    }
    for (std::size_t m = 0; m < methods.size(); ++m) {
        std::string ratios;
        for (std::size_t r = 0; r < seconds[m].size(); ++r)
            ratios += (r ? " " : "") + std::to_string(seconds[0][r] / seconds[m][r]).substr(0, 4);
        std::vector<double> s = seconds[m];
        std::sort(s.begin(), s.end());
        std::printf("inside,%s,%s,%zu,%zu,%.4g,%s\n", mesh.c_str(), methods[m].name.c_str(), points.size(), wrong[m],
                    s[s.size() / 2] / double(points.size()) * 1e9, ratios.c_str());
    }
    std::fflush(stdout);
}

void inside_outside(const std::string& name, const isin::Mesh<float>& mesh, const std::vector<isin::Mesh<float>>& parts,
                    int n, int runs) {
    // Points at least 1e-3 of the diagonal from every part's (closed) surface; truth: inside some
    // part, by the parity of exact crossings of that closed part.
    std::vector<isin::Bvh<float>> closed;
    for (const auto& p : parts) closed.emplace_back(p);
    std::vector<isin::Triangle<float>> all;
    for (const auto& p : parts)
        for (std::size_t i = 0; i < p.size(); ++i) all.push_back(p.triangle(i));
    isin::Box<float> box;
    for (const auto& t : all) box.grow(t.v0), box.grow(t.v1), box.grow(t.v2);
    const float diag = isin::length(box.hi - box.lo);
    std::vector<isin::Vertex<float>> points;
    std::vector<bool> truth;
    for (const auto& p : box_points(all, 4 * n, 9)) {
        if (int(points.size()) == n) break;
        bool near = false, inside = false;
        for (const auto& b : closed) {
            near = near || b.closest_point(p, 1e-3f * diag);
            inside = inside || b.count_hits(isin::Ray<float>{p, {0.31f, 0.83f, -0.47f}}) % 2 == 1;
        }
        if (near) continue;
        points.push_back(p), truth.push_back(inside);
    }
    const isin::Solid<float> solid{mesh};
    const isin::Bvh<float>& bvh = solid.bvh();
    const isin::Vertex<float> dirs[3] = {{0.57f, -0.22f, 0.79f}, {-0.64f, 0.71f, 0.29f}, {0.12f, 0.35f, -0.93f}};
    std::vector<InsideMethod> methods = {{"one-ray parity",
                                          [&](const isin::Vertex<float>& p) {
                                              return bvh.count_hits({p, dirs[0]}) % 2 == 1;
                                          }},
                                         {"majority of three rays", [&](const isin::Vertex<float>& p) {
                                              int odd = 0;
                                              for (const auto& d : dirs) odd += int(bvh.count_hits({p, d}) % 2);
                                              return odd >= 2;
                                          }}};
    for (const float beta : {1.0f, 1.5f, 2.0f, 3.0f, 4.0f})
        methods.push_back(
            {"fast winding beta=" + std::to_string(beta).substr(0, 3),
             [&solid, beta](const isin::Vertex<float>& p) { return solid.winding_number(p, beta) >= 0.5f; }});
    inside_methods(name, methods, points, truth, runs);
    inside_methods(
        name,
        {methods[0],
         {"exact winding", [&](const isin::Vertex<float>& p) { return solid.winding_number_exact(p) >= 0.5f; }}},
        points, truth, 1);
}

// contains (beta = 2) against one-ray parity on a mesh whose truth is not known (a scan):
// time per point only, the two timed in turn on each chunk of points; points of the enlarged
// box at least 1e-3 of the diagonal from the surface.
void inside_timing(const std::string& name, const isin::Mesh<float>& mesh, int n, int runs) {
    const isin::Solid<float> solid{mesh};
    const isin::Bvh<float>& bvh = solid.bvh();
    std::vector<isin::Triangle<float>> all;
    for (std::size_t i = 0; i < mesh.size(); ++i) all.push_back(mesh.triangle(i));
    isin::Box<float> box;
    for (const auto& t : all) box.grow(t.v0), box.grow(t.v1), box.grow(t.v2);
    const float diag = isin::length(box.hi - box.lo);
    std::vector<isin::Vertex<float>> points;
    for (const auto& p : box_points(all, 4 * n, 9))
        if (int(points.size()) < n && !bvh.closest_point(p, 1e-3f * diag)) points.push_back(p);
    std::vector<double> parity, contains;
    std::size_t odd = 0, in = 0;
    for (int r = 0; r < runs; ++r) {
        odd = 0, in = 0;
        parity.push_back(0), contains.push_back(0);
        for (std::size_t begin = 0; begin < points.size(); begin += chunk) {
            const std::size_t end = std::min(points.size(), begin + chunk);
            auto t0 = Clock::now();
            for (std::size_t i = begin; i < end; ++i) odd += bvh.count_hits({points[i], {0.57f, -0.22f, 0.79f}}) % 2;
            parity.back() += std::chrono::duration<double>(Clock::now() - t0).count();
            t0 = Clock::now();
            for (std::size_t i = begin; i < end; ++i) in += solid.contains(points[i]);
            contains.back() += std::chrono::duration<double>(Clock::now() - t0).count();
        }
    }
    const double np = double(points.size()) * 1e-9;
    std::string ratios;
    for (std::size_t r = 0; r < parity.size(); ++r)
        ratios += (r ? " " : "") + std::to_string(parity[r] / contains[r]).substr(0, 4);
    std::sort(parity.begin(), parity.end()), std::sort(contains.begin(), contains.end());
    std::printf("inside,%s,one-ray parity,%zu,-,%.4g,\n", name.c_str(), points.size(), parity[parity.size() / 2] / np);
    std::printf("inside,%s,fast winding beta=2.0,%zu,-,%.4g,%s\n", name.c_str(), points.size(),
                contains[contains.size() / 2] / np, ratios.c_str());
    std::printf("inside,%s,inside by parity %zu by contains %zu,%zu,-,-,\n", name.c_str(), odd, in, points.size());
    std::fflush(stdout);
}

} // namespace

int main(int argc, char** argv) {
    _mm_setcsr(_mm_getcsr() | 0x8040u); // flush to zero, denormals are zero (as Embree's docs ask)
    const int n = argc > 1 ? std::atoi(argv[1]) : 20000;
    const int runs = argc > 2 ? std::atoi(argv[2]) : 5;
    RTCDevice device = rtcNewDevice("threads=1");
    rtcSetDeviceErrorFunction(device, embree_scene::on_error, nullptr);
    std::printf("kind,mesh,triangles,points,method,points_per_s,checksum\n");
    for (const std::string name : {"icosphere-80k", "trefoil-300k"})
        closest_points(name, meshes::make<float>(name), device, n, runs);
    // The Stanford dragon when scripts/dragon.sh has fetched it (or the file given as argument 3).
    const std::string dragon = argc > 3 ? argv[3] : "build/load_models/dragon_le.ply";
    std::vector<isin::Triangle<float>> dragon_tris;
    if (std::FILE* f = std::fopen(dragon.c_str(), "rb")) {
        std::fclose(f);
        dragon_tris = isin::load_mesh<float>(dragon);
        closest_points("dragon-871k", dragon_tris, device, n, runs);
    }
    rtcReleaseDevice(device);

    std::printf("kind,mesh,method,points,wrong,ns_per_point,throughput_over_parity_each_run\n");
    const auto a = solids::icosphere<float>(5, {0, 0, 0}, 1.0), b = solids::icosphere<float>(5, {0.8, 0.3, 0}, 1.0);
    inside_outside("closed icosphere 20k", a, {a}, n / 4, runs);
    inside_outside("icosphere 20k, 2% removed", solids::with_holes(a, 0.02), {a}, n / 4, runs);
    inside_outside("two overlapping icospheres 41k", solids::merged(a, b), {a, b}, n / 4, runs);
    if (!dragon_tris.empty()) inside_timing("dragon 871k", isin::Mesh<float>::from_triangles(dragon_tris), n / 4, runs);
}
