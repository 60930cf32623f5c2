// The stream calls of a Bvh and of a Scene on several threads (StreamOptions): the same results,
// bit for bit, for every thread count.
#include <isin/scene.hpp>

#include <doctest/doctest.h>

#include "support/workloads.hpp"

#include <cstring>
#include <random>
#include <vector>

namespace user {

// A user's kind (tested one ray at a time by each thread): a sphere.
template <class T>
struct Probe {
    isin::Sphere<T> sphere;
};
template <class T>
isin::Hit<T> intersect_primitive(const isin::Ray<T>& ray, const Probe<T>& p, isin::TriangleMethod) noexcept {
    return isin::intersect(ray, p.sphere);
}
template <class T>
isin::Box<T> bounds(const Probe<T>& p) noexcept {
    return isin::bounds(p.sphere);
}
template <class T>
isin::Vertex<T> surface_normal(const Probe<T>& p, const isin::Vertex<T>& point, const isin::Hit<T>&) noexcept {
    return isin::normal_at(p.sphere, point);
}
template <class T>
constexpr const isin::Triangle<T>* triangle_of(const Probe<T>&) noexcept {
    return nullptr;
}

} // namespace user

namespace {

// Camera rays of a 100×54 image (5,400: five blocks and a part), every fifth turned to a random
// direction so that packets and single rays both occur.
template <class T>
std::vector<isin::Ray<T>> stream_rays() {
    const isin::Camera<T> cam{100, 54};
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<isin::Ray<T>> rays;
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x) {
            auto ray = cam.primary_ray(T(x), T(y));
            if (rays.size() % 5 == 4)
                ray.direction = isin::normalize(isin::Vertex<T>{T(uni(rng)), T(uni(rng)), T(uni(rng) + 1.2)});
            rays.push_back(ray);
        }
    return rays;
}

template <class T>
bool same(const isin::Hit<T>& a, const isin::Hit<T>& b) {
    return std::memcmp(&a.t, &b.t, sizeof(T)) == 0 && std::memcmp(&a.u, &b.u, sizeof(T)) == 0 &&
           std::memcmp(&a.v, &b.v, sizeof(T)) == 0 && a.primitive == b.primitive && a.geometry == b.geometry;
}

template <class T>
int differ(const std::vector<isin::Hit<T>>& a, const std::vector<isin::Hit<T>>& b) {
    int n = 0;
    for (std::size_t i = 0; i < a.size(); ++i) n += !same(a[i], b[i]);
    return n;
}

// The rays as separate arrays (RaysSoA), kept alive by the vectors.
template <class T>
struct SoA {
    std::vector<T> c[6];
    explicit SoA(const std::vector<isin::Ray<T>>& rays) {
        for (const auto& r : rays) {
            c[0].push_back(r.origin.x), c[1].push_back(r.origin.y), c[2].push_back(r.origin.z);
            c[3].push_back(r.direction.x), c[4].push_back(r.direction.y), c[5].push_back(r.direction.z);
        }
    }
    [[nodiscard]] isin::RaysSoA<T> view() const {
        return {c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data(), c[5].data()};
    }
};

constexpr int thread_counts[] = {1, 2, 3, 0};

} // namespace

TEST_CASE_TEMPLATE("Bvh stream calls: the same hits and shadows on 1, 2, 3 threads and every core", T, float, double) {
    auto triangles = workloads::icosphere<T>({-6, 0, 40}, 10.0, 3);
    for (const auto& t : workloads::icosphere<T>({9, 3, 60}, 8.0, 2)) triangles.push_back(t);
    const isin::Bvh<T> bvh(triangles);
    const auto rays = stream_rays<T>();
    const std::size_t n = rays.size();
    const SoA<T> soa(rays);
    std::vector<T> t_max(n);
    for (std::size_t i = 0; i < n; ++i) t_max[i] = T(30 + int(i % 40)); // some shadows end before the spheres
    std::vector<isin::Hit<T>> one(n), bounded_one(n);
    std::vector<std::uint8_t> blocked_one(n);
    bvh.intersect(rays.data(), n, one.data());
    bvh.intersect(rays.data(), n, t_max.data(), bounded_one.data());
    bvh.occluded(rays.data(), n, t_max.data(), blocked_one.data());
    int hits = 0;
    for (const auto& h : one) hits += bool(h);
    REQUIRE(hits > 500);
    for (const int threads : thread_counts) {
        CAPTURE(threads);
        isin::StreamOptions opt;
        opt.threads = threads;
        std::vector<isin::Hit<T>> found(n), bounded(n), from_soa(n);
        std::vector<std::uint8_t> blocked(n, 7), blocked_soa(n, 7);
        bvh.intersect(rays.data(), n, found.data(), {}, opt);
        bvh.intersect(rays.data(), n, t_max.data(), bounded.data(), {}, opt);
        bvh.intersect(soa.view(), n, t_max.data(), from_soa.data(), {}, opt);
        bvh.occluded(rays.data(), n, t_max.data(), blocked.data(), {}, opt);
        bvh.occluded(soa.view(), n, t_max.data(), blocked_soa.data(), {}, opt);
        CHECK(differ(found, one) == 0);
        CHECK(differ(bounded, bounded_one) == 0);
        CHECK(differ(from_soa, bounded_one) == 0);
        CHECK(blocked == blocked_one);
        CHECK(blocked_soa == blocked_one);
        // Back-face culling passes through to every thread.
        isin::HitFilter cull;
        cull.cull_backfaces = true;
        std::vector<isin::Hit<T>> culled_one(n), culled(n);
        bvh.intersect(rays.data(), n, culled_one.data(), cull);
        bvh.intersect(rays.data(), n, culled.data(), cull, opt);
        CHECK(differ(culled, culled_one) == 0);
    }
    // Nothing to trace: nothing touched.
    bvh.intersect(rays.data(), 0, one.data(), {}, isin::StreamOptions{2});
}

TEST_CASE_TEMPLATE("Scene stream calls: the same results on 1, 2, 3 threads and every core", T, float, double) {
    isin::Scene<T, isin::Sphere, isin::Triangle, user::Probe> scene;
    const auto m = scene.add_material({});
    isin::Material<T> glass;
    glass.transparency = T(0.6);
    const auto g = scene.add_material(glass);
    scene.add_mesh(workloads::icosphere<T>({-6, 0, 40}, 10.0, 3), m);
    scene.add_mesh(workloads::icosphere<T>({9, 3, 60}, 8.0, 2), g);
    for (int i = 0; i < 12; ++i) scene.add(isin::Sphere<T>{{T(-20 + 4 * i), T(-6), T(35)}, T(1.5)}, i % 2 ? g : m);
    for (const auto& t : workloads::icosphere<T>({0, 8, 50}, 4.0, 2)) scene.add(t, g);
    scene.add(user::Probe<T>{{{T(14), T(-3), T(30)}, T(3)}}, m);
    const auto rays = stream_rays<T>();
    const std::size_t n = rays.size();
    const SoA<T> soa(rays);
    std::vector<T> t_max(n);
    for (std::size_t i = 0; i < n; ++i) t_max[i] = T(30 + int(i % 40));
    std::vector<isin::Hit<T>> one(n);
    std::vector<std::uint8_t> blocked_one(n);
    std::vector<T> through_one(n);
    scene.intersect(rays.data(), n, one.data());
    scene.occluded(rays.data(), n, t_max.data(), blocked_one.data());
    scene.transmittance(rays.data(), n, t_max.data(), through_one.data());
    for (const int threads : thread_counts) {
        CAPTURE(threads);
        isin::StreamOptions opt;
        opt.threads = threads;
        std::vector<isin::Hit<T>> found(n), from_soa(n);
        std::vector<std::uint8_t> blocked(n, 7), blocked_soa(n, 7);
        std::vector<T> through(n, T(-1));
        scene.intersect(rays.data(), n, found.data(), nullptr, opt);
        scene.intersect(soa.view(), n, from_soa.data(), nullptr, opt);
        scene.occluded(rays.data(), n, t_max.data(), blocked.data(), opt);
        scene.occluded(soa.view(), n, t_max.data(), blocked_soa.data(), opt);
        scene.transmittance(rays.data(), n, t_max.data(), through.data(), opt);
        CHECK(differ(found, one) == 0);
        CHECK(differ(from_soa, one) == 0);
        CHECK(blocked == blocked_one);
        CHECK(blocked_soa == blocked_one);
        CHECK(std::memcmp(through.data(), through_one.data(), n * sizeof(T)) == 0);
    }
}
