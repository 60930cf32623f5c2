// Geometric queries side by side in one process, one thread:
//  1. closest points: isin's Bvh::closest_point against Embree's rtcPointQuery with a
//     closest-point callback (Ericson's regions, as Embree's closest_point tutorial) and, when
//     built with CGAL, CGAL's AABB_tree::closest_point_and_primitive; random points in the
//     mesh's box enlarged 10%, the same points for all, checksums of the distances;
//  2. inside/outside: one-ray parity, the majority of three rays, Solid's fast winding number at
//     several beta and the exact winding number, on a closed icosphere, the same with 2% of its
//     triangles removed and two overlapping closed spheres stored as one mesh: wrong answers
//     (points at least 1e-3 of the diagonal from the surface) against time per point.
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

// Median seconds of `runs` calls of f.
double median_seconds(int runs, const std::function<void()>& f) {
    std::vector<double> s;
    for (int r = 0; r < runs; ++r) {
        const auto t0 = Clock::now();
        f();
        s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    std::sort(s.begin(), s.end());
    return s[s.size() / 2];
}

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
    double sum_isin = 0, sum_embree = 0;
    const double t_isin = median_seconds(runs, [&] {
        sum_isin = 0;
        for (const auto& p : points) sum_isin += double(bvh.closest_point(p).distance);
    });
    RTCScene scene = embree_scene::make(device, tris);
    const double t_embree = median_seconds(runs, [&] {
        sum_embree = 0;
        for (const auto& p : points) {
            RTCPointQuery q{};
            q.x = p.x, q.y = p.y, q.z = p.z, q.time = 0, q.radius = std::numeric_limits<float>::infinity();
            RTCPointQueryContext context;
            rtcInitPointQueryContext(&context);
            EmbreeClosest r{&tris, std::numeric_limits<float>::infinity(), RTC_INVALID_GEOMETRY_ID};
            rtcPointQuery(scene, &q, &context, embree_closest, &r);
            sum_embree += double(r.distance);
        }
    });
    rtcReleaseScene(scene);
    std::printf("closest,%s,%zu,%d,isin,%.0f,%.9g\n", name.c_str(), tris.size(), n, n / t_isin, sum_isin);
    std::printf("closest,%s,%zu,%d,embree,%.0f,%.9g\n", name.c_str(), tris.size(), n, n / t_embree, sum_embree);
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
    double sum_cgal = 0;
    const double t_cgal = median_seconds(runs, [&] {
        sum_cgal = 0;
        for (const auto& p : points) {
            const K::Point_3 q(p.x, p.y, p.z);
            sum_cgal += std::sqrt(CGAL::squared_distance(q, tree.closest_point_and_primitive(q).first));
        }
    });
    std::printf("closest,%s,%zu,%d,cgal,%.0f,%.9g\n", name.c_str(), tris.size(), n, n / t_cgal, sum_cgal);
#endif
    std::fflush(stdout);
}

// One inside/outside method: its wrong answers against `truth` and its time per point.
void inside_method(const std::string& mesh, const std::string& method, const std::vector<isin::Vertex<float>>& points,
                   const std::vector<bool>& truth, int runs, const std::function<bool(const isin::Vertex<float>&)>& f) {
    std::size_t wrong = 0;
    const double t = median_seconds(runs, [&] {
        wrong = 0;
        for (std::size_t i = 0; i < points.size(); ++i) wrong += f(points[i]) != truth[i];
    });
    std::printf("inside,%s,%s,%zu,%zu,%.4g\n", mesh.c_str(), method.c_str(), points.size(), wrong,
                t / double(points.size()) * 1e9);
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
    inside_method(name, "one-ray parity", points, truth, runs, [&](const isin::Vertex<float>& p) {
        return bvh.count_hits({p, dirs[0]}) % 2 == 1;
    });
    inside_method(name, "majority of three rays", points, truth, runs, [&](const isin::Vertex<float>& p) {
        int odd = 0;
        for (const auto& d : dirs) odd += int(bvh.count_hits({p, d}) % 2);
        return odd >= 2;
    });
    for (const float beta : {1.0f, 1.5f, 2.0f, 3.0f, 4.0f})
        inside_method(name, "fast winding beta=" + std::to_string(beta).substr(0, 3), points, truth, runs,
                      [&](const isin::Vertex<float>& p) { return solid.winding_number(p, beta) >= 0.5f; });
    inside_method(name, "exact winding", points, truth, 1,
                  [&](const isin::Vertex<float>& p) { return solid.winding_number_exact(p) >= 0.5f; });
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
    rtcReleaseDevice(device);

    std::printf("kind,mesh,method,points,wrong,ns_per_point\n");
    const auto a = solids::icosphere<float>(5, {0, 0, 0}, 1.0), b = solids::icosphere<float>(5, {0.8, 0.3, 0}, 1.0);
    inside_outside("closed icosphere 20k", a, {a}, n / 4, runs);
    inside_outside("icosphere 20k, 2% removed", solids::with_holes(a, 0.02), {a}, n / 4, runs);
    inside_outside("two overlapping icospheres 41k", solids::merged(a, b), {a, b}, n / 4, runs);
}
