#pragma once
// vs_embree's scene studies (issue: acceleration for real scenes), each isin against Embree 3 in
// the same process on the same rays, one tracing thread, medians of interleaved repeats:
//   spheres       n random spheres (1 … 10⁶) in view: isin's Scene (a sphere Bvh once n ≥
//                 shape_bvh_min; also one by one, for the crossover) against Embree's native sphere
//                 points and against Embree user geometry calling isin's sphere test
//   instances     1000 placements of an 82k-triangle icosphere (rotated, scaled): Scene::add_instance
//                 against Embree instance geometry; memory of each
//   transparency  shadow rays through the trefoil knot, opaque and glass (transmittance through
//                 its Bvh's all-hits traversal): isin's cost of glass over opaque
//   refit         an icosphere animated for 10 frames: Bvh::refit against a rebuild and against
//                 Embree's refit (RTC_BUILD_QUALITY_REFIT, rtcUpdateGeometryBuffer + commit);
//                 trace speed after the 10 refits against a fresh build
//   groups        the trefoil knot added as 20 meshes and committed, against one add_mesh
//   memory        each benchmark mesh (vertices shared by index) in a Scene against Embree's
//                 allocations for the same index and vertex buffers (its memory monitor)
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <isin/camera.hpp>
#include <isin/offset.hpp>
#include <isin/scene.hpp>

#include "embree_scene.hpp"
#include "meshes.hpp"

namespace studies {

using Clock = std::chrono::steady_clock;
using Ray = isin::Ray<float>;

struct Config {
    int width = 960, height = 540, repeats = 5;
};

inline double median_of(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}
inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Bytes Embree holds, from its memory monitor (registered on the device by vs_embree).
inline std::atomic<long long> embree_bytes{0};
inline bool embree_monitor(void*, ssize_t bytes, bool) {
    embree_bytes += bytes;
    return true;
}

inline std::vector<Ray> primary_rays(const Config& cfg) {
    const isin::Camera<float> cam{cfg.width, cfg.height};
    std::vector<Ray> rays;
    rays.reserve(std::size_t(cfg.width) * std::size_t(cfg.height));
    for (int y = 0; y < cfg.height; ++y)
        for (int x = 0; x < cfg.width; ++x) rays.push_back(cam.primary_ray(float(x), float(y)));
    return rays;
}

struct Pass {
    std::uint64_t hits = 0;
    double sum_t = 0;
};

// Rays through each tracer in turn, `repeats` times; Mrays/s medians (in `mrays`) and the last
// pass's totals.
inline void race(const std::vector<Ray>& rays, int repeats,
                 const std::vector<std::function<float(const Ray&)>>& tracers, std::vector<double>& mrays,
                 std::vector<Pass>& totals) {
    std::vector<std::vector<double>> s(tracers.size());
    totals.assign(tracers.size(), {});
    for (int rep = 0; rep < repeats; ++rep)
        for (std::size_t k = 0; k < tracers.size(); ++k) {
            Pass p;
            const auto t0 = Clock::now();
            for (const Ray& r : rays) {
                const float t = tracers[k](r);
                if (t < std::numeric_limits<float>::infinity()) ++p.hits, p.sum_t += double(t);
            }
            s[k].push_back(seconds_since(t0));
            totals[k] = p;
        }
    mrays.clear();
    for (const auto& v : s) mrays.push_back(double(rays.size()) / median_of(v) * 1e-6);
}

inline RTCRayHit embree_ray(const Ray& r) {
    RTCRayHit rh{};
    rh.ray.org_x = r.origin.x, rh.ray.org_y = r.origin.y, rh.ray.org_z = r.origin.z;
    rh.ray.dir_x = r.direction.x, rh.ray.dir_y = r.direction.y, rh.ray.dir_z = r.direction.z;
    rh.ray.tnear = 0, rh.ray.tfar = std::numeric_limits<float>::infinity(), rh.ray.mask = ~0u;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    return rh;
}
inline float embree_nearest(RTCScene scene, const Ray& r) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh = embree_ray(r);
    rtcIntersect1(scene, &context, &rh);
    return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? std::numeric_limits<float>::infinity() : rh.ray.tfar;
}

// The mesh with its shared vertices found again (the generators round each shared vertex to the
// same floats), so that both libraries get index and vertex buffers as from a model file.
inline isin::Mesh<float> indexed(const std::vector<isin::Triangle<float>>& tris) {
    isin::Mesh<float> mesh;
    std::map<std::tuple<float, float, float>, std::uint32_t> seen;
    for (const auto& t : tris) {
        std::array<std::uint32_t, 3> k{};
        const isin::Vertex<float>* v[3] = {&t.v0, &t.v1, &t.v2};
        for (int i = 0; i < 3; ++i) {
            const auto key = std::make_tuple(v[i]->x, v[i]->y, v[i]->z);
            auto it = seen.find(key);
            if (it == seen.end()) {
                it = seen.emplace(key, std::uint32_t(mesh.positions.size())).first;
                mesh.positions.push_back(*v[i]);
            }
            k[std::size_t(i)] = it->second;
        }
        mesh.indices.push_back(k);
    }
    return mesh;
}

// An Embree geometry for `mesh`, with the build quality asked (the scene's is MEDIUM).
inline RTCGeometry embree_geometry(RTCDevice device, const isin::Mesh<float>& mesh,
                                   RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, quality);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), mesh.positions.size()));
    auto* i = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), mesh.indices.size()));
    for (std::size_t k = 0; k < mesh.positions.size(); ++k)
        v[3 * k] = mesh.positions[k].x, v[3 * k + 1] = mesh.positions[k].y, v[3 * k + 2] = mesh.positions[k].z;
    for (std::size_t k = 0; k < mesh.indices.size(); ++k)
        for (std::size_t a = 0; a < 3; ++a) i[3 * k + a] = mesh.indices[k][a];
    rtcCommitGeometry(g);
    return g;
}
inline RTCScene embree_scene_of(RTCDevice device, const isin::Mesh<float>& mesh) {
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry g = embree_geometry(device, mesh);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

inline void check(bool ok, const char* what, bool& all_ok) {
    if (!ok) std::printf("  MISMATCH: %s\n", what);
    all_ok = all_ok && ok;
}
inline bool close(double a, double b, double tolerance) {
    return std::fabs(a - b) <= tolerance * std::max({std::fabs(a), std::fabs(b), 1.0});
}

// ---- spheres -----------------------------------------------------------------------------------

inline void spheres(RTCDevice device, const Config& cfg, bool& all_ok) {
    std::printf("\nspheres: n random spheres in view, %dx%d primary rays, Mrays/s (isin Scene: Bvh from %zu spheres)\n",
                cfg.width, cfg.height, isin::Scene<float, isin::Sphere>{}.shape_bvh_min);
    std::printf("%9s | %7s %7s %7s | %7s %7s | %6s %6s\n", "spheres", "isin", "1 by 1", "Bvh", "E-point", "E-user",
                "/point", "/user");
    const auto rays = primary_rays(cfg);
    for (const std::size_t n :
         {std::size_t(1), std::size_t(4), std::size_t(8), std::size_t(16), std::size_t(64), std::size_t(256),
          std::size_t(1000), std::size_t(10000), std::size_t(100000), std::size_t(1000000)}) {
        std::mt19937_64 rng(n);
        const auto uni = [&](double lo, double hi) { return meshes::uniform(rng, lo, hi); };
        // in the view of the note's camera: x ∈ ±0.8z, y ∈ ±0.45z, z ∈ [30, 60]; radii so that about
        // half of the rays hit something whatever n is
        const double r = 9.0 / std::cbrt(double(n));
        std::vector<isin::Sphere<float>> balls;
        for (std::size_t i = 0; i < n; ++i) {
            const double z = uni(30, 60);
            balls.push_back(
                {{float(uni(-0.8, 0.8) * z), float(uni(-0.45, 0.45) * z), float(z)}, float(r * uni(0.5, 1.0))});
        }
        isin::Scene<float, isin::Sphere> scene;
        const auto m = scene.add_material({});
        for (const auto& b : balls) scene.add(b, m);
        scene.commit();
        isin::Scene<float, isin::Sphere> loose = scene, tree = scene;
        loose.acceleration = isin::Acceleration::none;
        tree.acceleration = isin::Acceleration::bvh;
        tree.commit();

        RTCScene points = rtcNewScene(device);
        {
            RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
            auto* v = static_cast<float*>(
                rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), n));
            for (std::size_t i = 0; i < n; ++i)
                v[4 * i] = balls[i].center.x, v[4 * i + 1] = balls[i].center.y, v[4 * i + 2] = balls[i].center.z,
                      v[4 * i + 3] = balls[i].radius;
            rtcCommitGeometry(g);
            rtcAttachGeometry(points, g);
            rtcReleaseGeometry(g);
            rtcCommitScene(points);
        }
        RTCScene user = rtcNewScene(device);
        {
            RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
            rtcSetGeometryUserPrimitiveCount(g, unsigned(n));
            rtcSetGeometryUserData(g, &balls);
            rtcSetGeometryBoundsFunction(
                g,
                [](const RTCBoundsFunctionArguments* a) {
                    const auto& s =
                        (*static_cast<const std::vector<isin::Sphere<float>>*>(a->geometryUserPtr))[a->primID];
                    a->bounds_o->lower_x = s.center.x - s.radius, a->bounds_o->lower_y = s.center.y - s.radius,
                    a->bounds_o->lower_z = s.center.z - s.radius;
                    a->bounds_o->upper_x = s.center.x + s.radius, a->bounds_o->upper_y = s.center.y + s.radius,
                    a->bounds_o->upper_z = s.center.z + s.radius;
                },
                nullptr);
            rtcSetGeometryIntersectFunction(g, [](const RTCIntersectFunctionNArguments* a) {
                if (!a->valid[0]) return;
                const auto& s = (*static_cast<const std::vector<isin::Sphere<float>>*>(a->geometryUserPtr))[a->primID];
                RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(a->rayhit);
                const Ray ray{{rh->ray.org_x, rh->ray.org_y, rh->ray.org_z},
                              {rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z}};
                const auto h = isin::intersect(ray, s);
                if (!(h.t < rh->ray.tfar) || !(h.t > rh->ray.tnear)) return;
                rh->ray.tfar = h.t;
                rh->hit.geomID = a->geomID, rh->hit.primID = a->primID;
                rh->hit.Ng_x = 0, rh->hit.Ng_y = 0, rh->hit.Ng_z = -1, rh->hit.u = rh->hit.v = 0;
            });
            rtcCommitGeometry(g);
            rtcAttachGeometry(user, g);
            rtcReleaseGeometry(g);
            rtcCommitScene(user);
        }
        std::vector<std::function<float(const Ray&)>> tracers = {
            [&](const Ray& ray) { return scene.intersect(ray).t; },
            [&](const Ray& ray) { return embree_nearest(points, ray); },
            [&](const Ray& ray) { return embree_nearest(user, ray); }};
        if (n <= 1000) {
            tracers.push_back([&](const Ray& ray) { return loose.intersect(ray).t; });
            tracers.push_back([&](const Ray& ray) { return tree.intersect(ray).t; });
        }
        std::vector<double> mr;
        std::vector<Pass> tot;
        race(rays, n >= 100000 ? 3 : cfg.repeats, tracers, mr, tot);
        const double one_by_one = n <= 1000 ? mr[3] : std::nan(""), always_bvh = n <= 1000 ? mr[4] : std::nan("");
        std::printf("%9zu | %7.2f %7.2f %7.2f | %7.2f %7.2f | %6.2f %6.2f   hits %llu / %llu / %llu\n", n, mr[0],
                    one_by_one, always_bvh, mr[1], mr[2], mr[0] / mr[1], mr[0] / mr[2],
                    static_cast<unsigned long long>(tot[0].hits), static_cast<unsigned long long>(tot[1].hits),
                    static_cast<unsigned long long>(tot[2].hits));
        std::fflush(stdout);
        // Embree's own sphere test rounds differently at the silhouettes; user geometry runs isin's.
        check(tot[0].hits == tot[2].hits && close(tot[0].sum_t, tot[2].sum_t, 1e-6),
              "spheres: isin and Embree user geometry", all_ok);
        check(close(double(tot[0].hits), double(tot[1].hits), 1e-3), "spheres: isin and Embree points", all_ok);
        if (n <= 1000) check(tot[0].hits == tot[3].hits, "spheres: Bvh and one by one", all_ok);
        rtcReleaseScene(points);
        rtcReleaseScene(user);
    }
}

// ---- instances ---------------------------------------------------------------------------------

inline void instances(RTCDevice device, const Config& cfg, bool& all_ok) {
    const auto tris = meshes::icosphere<float>(6); // 81,920 triangles, radius 15 around (0, 0, 40)
    const isin::Mesh<float> mesh = indexed(tris);
    using X = isin::Transform<float>;
    const X home = X::translation({0, 0, -40}); // the mesh around the origin
    std::vector<X> places;
    std::mt19937_64 rng(7);
    const auto uni = [&](double lo, double hi) { return float(meshes::uniform(rng, lo, hi)); };
    for (int i = 0; i < 1000; ++i) { // a 10×10×10 lattice in view, each turned and sized at random
        const float z = 60 + 12 * float(i / 100);
        places.push_back(
            X::translation({(float(i % 10) - 4.5f) * 0.16f * z, (float((i / 10) % 10) - 4.5f) * 0.09f * z, z}) *
            X::rotation({uni(-1, 1), uni(-1, 1), uni(-1, 1)}, uni(0, 3)) * X::scaling(uni(0.08f, 0.2f)) * home);
    }
    auto t0 = Clock::now();
    isin::Scene<float, isin::Sphere> scene;
    const auto id = scene.add_mesh(mesh, scene.add_material({}));
    const double mesh_s = seconds_since(t0);
    t0 = Clock::now();
    for (const X& p : places) scene.add_instance(id, p);
    scene.commit();
    const double place_s = seconds_since(t0);

    const long long before = embree_bytes;
    t0 = Clock::now();
    RTCScene object = embree_scene_of(device, mesh);
    RTCScene world = rtcNewScene(device);
    rtcSetSceneBuildQuality(world, RTC_BUILD_QUALITY_MEDIUM);
    // isin's add_mesh placed the mesh once where it stands (around z = 40, in view): Embree too
    RTCGeometry self = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(self, object);
    rtcCommitGeometry(self);
    rtcAttachGeometry(world, self);
    rtcReleaseGeometry(self);
    for (const X& p : places) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, object);
        const float xfm[12] = {p.m[0][0], p.m[1][0], p.m[2][0], p.m[0][1], p.m[1][1], p.m[2][1],
                               p.m[0][2], p.m[1][2], p.m[2][2], p.d.x,     p.d.y,     p.d.z}; // column-major 3×4
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
        rtcCommitGeometry(g);
        rtcAttachGeometry(world, g);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(world);
    const double embree_s = seconds_since(t0);
    const long long embree_mem = embree_bytes - before;

    const auto rays = primary_rays(cfg);
    std::vector<double> mr;
    std::vector<Pass> tot;
    race(rays, cfg.repeats,
         {[&](const Ray& r) { return scene.intersect(r).t; }, [&](const Ray& r) { return embree_nearest(world, r); }},
         mr, tot);
    std::printf("\ninstances: 1001 placements of an 81,920-triangle icosphere, %dx%d primary rays\n", cfg.width,
                cfg.height);
    std::printf("  isin %.2f Mrays/s, Embree %.2f (isin/Embree %.2f); hits %llu / %llu; build: isin mesh %.1f ms + "
                "placements %.1f ms, Embree %.1f ms; memory: isin %.1f MB, Embree %.1f MB\n",
                mr[0], mr[1], mr[0] / mr[1], static_cast<unsigned long long>(tot[0].hits),
                static_cast<unsigned long long>(tot[1].hits), mesh_s * 1e3, place_s * 1e3, embree_s * 1e3,
                double(scene.memory()) / 1e6, double(embree_mem) / 1e6);
    check(close(double(tot[0].hits), double(tot[1].hits), 1e-4) && close(tot[0].sum_t, tot[1].sum_t, 1e-4),
          "instances: isin and Embree", all_ok);
    rtcReleaseScene(world);
    rtcReleaseScene(object);
}

// ---- transparency -------------------------------------------------------------------------------

inline void transparency(const Config& cfg, bool& all_ok) {
    const auto tris = meshes::trefoil<float>();
    isin::Material<float> opaque, glass;
    glass.transparency = 0.6f;
    isin::Scene<float, isin::Sphere> solid, clear;
    solid.add_mesh(tris, solid.add_material(opaque));
    clear.add_mesh(tris, clear.add_material(glass));
    // Shadow rays from the primary hits on the knot towards a light behind it, as in vs_embree.
    const isin::Vertex<float> light{200.0f, 300.0f, 100.0f};
    std::vector<std::pair<Ray, float>> shadow;
    for (const Ray& ray : primary_rays(cfg)) {
        const auto h = solid.intersect(ray);
        if (!h) continue;
        isin::Vertex<float> n = solid.surface(ray, h).normal;
        if (isin::dot(n, ray.direction) > 0) n = -n;
        const auto o = isin::offset_origin(ray.at(h.t), n, isin::max_abs(ray.origin));
        shadow.push_back({{o, light - o}, 1.0f});
    }
    std::vector<double> s[2];
    double sum[2] = {0, 0};
    for (int rep = 0; rep < cfg.repeats; ++rep)
        for (int k = 0; k < 2; ++k) {
            const auto& scene = k ? clear : solid;
            sum[k] = 0;
            const auto t0 = Clock::now();
            for (const auto& [ray, t_max] : shadow) sum[k] += double(scene.transmittance(ray, t_max));
            s[k].push_back(seconds_since(t0));
        }
    const double opaque_mrays = double(shadow.size()) / median_of(s[0]) * 1e-6,
                 glass_mrays = double(shadow.size()) / median_of(s[1]) * 1e-6;
    std::printf("\ntransparency: %zu shadow rays through the 300k-triangle trefoil knot: opaque %.2f Mrays/s, glass "
                "(transparency 0.6, every crossing multiplied) %.2f Mrays/s: glass costs %.2f× opaque; light through: "
                "opaque %.0f, glass %.1f\n",
                shadow.size(), opaque_mrays, glass_mrays, opaque_mrays / glass_mrays, sum[0], sum[1]);
    check(sum[1] >= sum[0], "transparency: glass lets through at least what opaque does", all_ok);
}

// ---- refit -------------------------------------------------------------------------------------

inline void refit(RTCDevice device, const Config& cfg, bool& all_ok) {
    for (int level : {6, 8}) {
        const isin::Mesh<float> rest = indexed(meshes::icosphere<float>(level));
        isin::Mesh<float> mesh = rest;
        // Frame f: every vertex pushed along its direction from the centre by a wave.
        const auto animate = [&](int f) {
            for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
                const auto d = rest.positions[i] - isin::Vertex<float>{0, 0, 40};
                const float w = 1 + 0.15f * std::sin(0.3f * d.y + 0.6f * float(f));
                mesh.positions[i] = isin::Vertex<float>{0, 0, 40} + d * w;
            }
        };
        isin::Bvh<float> bvh{mesh};
        RTCScene scene = rtcNewScene(device);
        rtcSetSceneFlags(scene, RTC_SCENE_FLAG_DYNAMIC);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
        RTCGeometry g = embree_geometry(device, mesh, RTC_BUILD_QUALITY_REFIT);
        rtcAttachGeometry(scene, g);
        rtcCommitScene(scene);
        std::vector<double> isin_refit, isin_build, embree_refit;
        for (int f = 1; f <= 10; ++f) {
            animate(f);
            auto t0 = Clock::now();
            bvh.refit(mesh);
            isin_refit.push_back(seconds_since(t0));
            t0 = Clock::now();
            const isin::Bvh<float> rebuilt{mesh};
            isin_build.push_back(seconds_since(t0));
            t0 = Clock::now();
            auto* v = static_cast<float*>(rtcGetGeometryBufferData(g, RTC_BUFFER_TYPE_VERTEX, 0));
            for (std::size_t k = 0; k < mesh.positions.size(); ++k)
                v[3 * k] = mesh.positions[k].x, v[3 * k + 1] = mesh.positions[k].y, v[3 * k + 2] = mesh.positions[k].z;
            rtcUpdateGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0);
            rtcCommitGeometry(g);
            rtcCommitScene(scene);
            embree_refit.push_back(seconds_since(t0));
        }
        const isin::Bvh<float> fresh{mesh};
        const auto rays = primary_rays(cfg);
        std::vector<double> mr;
        std::vector<Pass> tot;
        race(rays, cfg.repeats,
             {[&](const Ray& r) { return bvh.intersect(r).t; }, [&](const Ray& r) { return fresh.intersect(r).t; },
              [&](const Ray& r) { return embree_nearest(scene, r); }},
             mr, tot);
        std::printf(
            "\nrefit: %zu-triangle icosphere, 10 frames of a wave: isin refit %.2f ms, rebuild %.2f ms (%.1f× the "
            "refit), Embree refit %.2f ms (medians); after 10 refits isin traces %.2f Mrays/s, %.2f× a fresh "
            "build's %.2f, Embree after its refits %.2f\n",
            mesh.size(), median_of(isin_refit) * 1e3, median_of(isin_build) * 1e3,
            median_of(isin_build) / median_of(isin_refit), median_of(embree_refit) * 1e3, mr[0], mr[0] / mr[1], mr[1],
            mr[2]);
        check(tot[0].hits == tot[1].hits && close(tot[0].sum_t, tot[1].sum_t, 1e-9), "refit: refitted and rebuilt Bvh",
              all_ok);
        check(close(double(tot[0].hits), double(tot[2].hits), 1e-4), "refit: isin and Embree", all_ok);
        rtcReleaseGeometry(g);
        rtcReleaseScene(scene);
    }
}

// ---- groups and memory ---------------------------------------------------------------------------

inline void groups(const Config& cfg, bool& all_ok) {
    const auto tris = meshes::trefoil<float>();
    std::vector<double> one, twenty;
    isin::Scene<float, isin::Sphere> whole, parts;
    for (int rep = 0; rep < cfg.repeats; ++rep) {
        auto t0 = Clock::now();
        whole = {};
        whole.add_mesh(tris, whole.add_material({}));
        whole.commit();
        one.push_back(seconds_since(t0));
        t0 = Clock::now();
        parts = {};
        const auto m = parts.add_material({});
        const std::size_t step = (tris.size() + 19) / 20;
        for (std::size_t g = 0; g < tris.size(); g += step)
            parts.add_mesh(std::vector<isin::Triangle<float>>(tris.begin() + long(g),
                                                              tris.begin() + long(std::min(tris.size(), g + step))),
                           m);
        parts.commit();
        twenty.push_back(seconds_since(t0));
    }
    const auto rays = primary_rays(cfg);
    std::vector<double> mr;
    std::vector<Pass> tot;
    race(rays, cfg.repeats,
         {[&](const Ray& r) { return whole.intersect(r).t; }, [&](const Ray& r) { return parts.intersect(r).t; }}, mr,
         tot);
    std::printf("\ngroups: the 300k-triangle trefoil knot as one mesh: %.1f ms; as 20 meshes: %.1f ms (%.2f×); traced "
                "%.2f and %.2f Mrays/s\n",
                median_of(one) * 1e3, median_of(twenty) * 1e3, median_of(twenty) / median_of(one), mr[0], mr[1]);
    check(tot[0].hits == tot[1].hits, "groups: one mesh and 20", all_ok);
}

inline void memory(RTCDevice device) {
    std::printf("\nmemory: each benchmark mesh by index (vertices shared) in a Scene, against Embree's allocations "
                "for the same buffers and its BVH\n");
    for (const std::string& name : meshes::names()) {
        const isin::Mesh<float> mesh = indexed(meshes::make<float>(name));
        isin::Scene<float, isin::Sphere> scene;
        scene.add_mesh(mesh, scene.add_material({}));
        const long long before = embree_bytes;
        RTCScene embree = embree_scene_of(device, mesh);
        const long long embree_mem = embree_bytes - before;
        const std::size_t mesh_bytes =
            mesh.positions.size() * sizeof(mesh.positions[0]) + mesh.indices.size() * sizeof(mesh.indices[0]);
        std::printf(
            "  %-15s %8zu triangles %8zu vertices: isin %7.1f MB (mesh %.1f + Bvh %.1f), Embree %7.1f MB: %.2f×\n",
            name.c_str(), mesh.size(), mesh.positions.size(), double(scene.memory()) / 1e6, double(mesh_bytes) / 1e6,
            double(scene.mesh_bvh(isin::MeshId{0}).memory()) / 1e6, double(embree_mem) / 1e6,
            double(scene.memory()) / double(embree_mem));
        rtcReleaseScene(embree);
    }
}

inline const std::vector<std::string>& names() {
    static const std::vector<std::string> list = {"spheres", "instances", "transparency", "refit", "groups", "memory"};
    return list;
}

/// Runs the studies in `which`; false when a check failed.
inline bool run(RTCDevice device, const Config& cfg, const std::vector<std::string>& which) {
    bool ok = true;
    const auto wants = [&](const char* s) { return std::find(which.begin(), which.end(), s) != which.end(); };
    if (wants("spheres")) spheres(device, cfg, ok);
    if (wants("instances")) instances(device, cfg, ok);
    if (wants("transparency")) transparency(cfg, ok);
    if (wants("refit")) refit(device, cfg, ok);
    if (wants("groups")) groups(cfg, ok);
    if (wants("memory")) memory(device);
    std::fflush(stdout);
    return ok;
}

} // namespace studies
