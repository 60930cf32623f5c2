// A scene changed since its last commit() builds what it needs at its first trace, once, on
// any number of threads at the same time: the same picture as a committed scene, through the
// same Bvhs.
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include "support/workloads.hpp"

#include <atomic>
#include <thread>
#include <vector>

namespace {

// Spheres and loose triangles enough for a Bvh each, and two placed meshes (a Bvh over them).
template <class T>
void fill(isin::Scene<T, isin::Sphere, isin::Triangle>& scene) {
    const auto m = scene.add_material({});
    for (int i = 0; i < 20; ++i) scene.add(isin::Sphere<T>{{T(-30 + 3 * i), T(-8), T(60)}, T(1.2)}, m);
    for (const auto& tri : workloads::icosphere<T>({-12, 6, 50}, 6.0, 2)) scene.add(tri, m); // 320 triangles
    scene.add_mesh(workloads::icosphere<T>({12, 6, 50}, 6.0, 2), m);
    scene.add_mesh(workloads::icosphere<T>({0, 14, 70}, 5.0, 1), m);
    scene.add_light({{0, 100, 0}});
}

template <class T>
std::vector<isin::Ray<T>> camera_rays(const isin::Camera<T>& cam) {
    std::vector<isin::Ray<T>> rays;
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x) rays.push_back(cam.primary_ray(T(x), T(y)));
    return rays;
}

} // namespace

TEST_CASE_TEMPLATE("scene: rendered without commit(), the same picture as committed, through the Bvhs", T, float,
                   double) {
    isin::Scene<T, isin::Sphere, isin::Triangle> committed, lazy;
    fill(committed);
    fill(lazy);
    committed.commit();
    CHECK(committed.committed());
    CHECK_FALSE(lazy.committed());
    CHECK_FALSE(lazy.template has_bvh<isin::Sphere<T>>());
    CHECK_FALSE(lazy.template has_bvh<isin::Triangle<T>>());
    CHECK_FALSE(lazy.has_instance_bvh());

    const isin::Camera<T> cam{64, 36};
    isin::RenderOptions opt;
    opt.threads = 2;
    const isin::Image a = isin::render(committed, cam, opt);
    const isin::Image b = isin::render(lazy, cam, opt);
    CHECK(a.pixels() == b.pixels());
    CHECK(lazy.committed());
    CHECK(lazy.template has_bvh<isin::Sphere<T>>());
    CHECK(lazy.template has_bvh<isin::Triangle<T>>());
    CHECK(lazy.has_instance_bvh());

    // One more sphere: only the spheres' Bvh is dropped, and the next trace builds it again.
    lazy.add(isin::Sphere<T>{{0, 0, 200}, 1}, 0);
    CHECK_FALSE(lazy.committed());
    CHECK_FALSE(lazy.template has_bvh<isin::Sphere<T>>());
    CHECK(lazy.template has_bvh<isin::Triangle<T>>());
    (void)lazy.occluded(cam.primary_ray(T(1), T(1)), T(1));
    CHECK(lazy.committed());
    CHECK(lazy.template has_bvh<isin::Sphere<T>>());

    // A placement drops the Bvh over the placements; a stream call builds it again.
    lazy.add_instance(isin::MeshId{0}, isin::Transform<T>::translation({0, 0, 400}));
    CHECK_FALSE(lazy.has_instance_bvh());
    const auto rays = camera_rays(cam);
    std::vector<isin::Hit<T>> hits(rays.size());
    lazy.intersect(rays.data(), rays.size(), hits.data());
    CHECK(lazy.has_instance_bvh());
}

TEST_CASE_TEMPLATE("scene: a copy of a changed scene builds its own, the original stays as it was", T, float, double) {
    isin::Scene<T, isin::Sphere, isin::Triangle> scene;
    fill(scene);
    auto copy = scene;
    CHECK_FALSE(copy.committed());
    (void)copy.intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}});
    CHECK(copy.committed());
    CHECK(copy.template has_bvh<isin::Sphere<T>>());
    CHECK_FALSE(scene.committed());
    CHECK_FALSE(scene.template has_bvh<isin::Sphere<T>>());
}

TEST_CASE_TEMPLATE("scene: concurrent first traces of a changed scene build it once and agree", T, float, double) {
    isin::Scene<T, isin::Sphere, isin::Triangle> reference, scene;
    fill(reference);
    fill(scene);
    reference.commit();
    const isin::Camera<T> cam{48, 27};
    const auto rays = camera_rays(cam);
    std::vector<isin::Hit<T>> expected(rays.size());
    for (std::size_t i = 0; i < rays.size(); ++i) expected[i] = reference.intersect(rays[i]);

    constexpr int threads = 4;
    std::vector<std::vector<isin::Hit<T>>> found(threads, std::vector<isin::Hit<T>>(rays.size()));
    std::atomic<int> ready{0};
    std::vector<std::thread> workers;
    for (int w = 0; w < threads; ++w)
        workers.emplace_back([&, w] {
            ready.fetch_add(1);
            while (ready.load() < threads) std::this_thread::yield(); // start together
            if (w % 2 == 0) {
                for (std::size_t i = 0; i < rays.size(); ++i) found[std::size_t(w)][i] = scene.intersect(rays[i]);
            } else {
                scene.intersect(rays.data(), rays.size(), found[std::size_t(w)].data());
            }
        });
    for (auto& t : workers) t.join();
    CHECK(scene.committed());
    CHECK(scene.template has_bvh<isin::Triangle<T>>());
    for (int w = 0; w < threads; ++w) {
        int differ = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const auto& h = found[std::size_t(w)][i];
            differ += !(h.t == expected[i].t || (!h && !expected[i])) || h.primitive != expected[i].primitive ||
                      h.geometry != expected[i].geometry;
        }
        CHECK(differ == 0);
    }
}
