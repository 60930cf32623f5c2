// Scenes: each kind's acceleration against the plain loop, transparent shadows through a Bvh,
// users' kinds, placed meshes (instances) against the same triangles moved into the world.
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/workloads.hpp"

#include <array>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace user {

/// A user's kind: an axis-aligned cube given by its centre and half side; it needs only these
/// four functions to live in a scene with a Bvh of its own.
template <class T>
struct Cube {
    isin::Vertex<T> center;
    T half;
};
template <class T>
isin::Hit<T> intersect_primitive(const isin::Ray<T>& ray, const Cube<T>& c, isin::TriangleMethod) noexcept {
    T t0 = T(0), t1 = std::numeric_limits<T>::infinity();
    for (int a = 0; a < 3; ++a) {
        const T o = isin::component(ray.origin, a), d = isin::component(ray.direction, a),
                c0 = isin::component(c.center, a);
        const T n = (c0 - c.half - o) / d, f = (c0 + c.half - o) / d;
        t0 = std::max(t0, std::min(n, f)), t1 = std::min(t1, std::max(n, f));
    }
    return t0 > T(0) && t0 <= t1 ? isin::Hit<T>::at(t0) : isin::Hit<T>::miss();
}
template <class T>
isin::Box<T> bounds(const Cube<T>& c) noexcept {
    isin::Box<T> b;
    b.grow(c.center - isin::Vertex<T>{c.half, c.half, c.half}),
        b.grow(c.center + isin::Vertex<T>{c.half, c.half, c.half});
    return b;
}
template <class T>
isin::Vertex<T> surface_normal(const Cube<T>&, const isin::Vertex<T>&, const isin::Hit<T>&) noexcept {
    return {0, 0, -1};
}
template <class T>
constexpr const isin::Triangle<T>* triangle_of(const Cube<T>&) noexcept {
    return nullptr;
}

} // namespace user

namespace {

template <class T>
std::vector<isin::Ray<T>> view_rays(int w, int h) {
    const isin::Camera<T> cam{w, h};
    std::vector<isin::Ray<T>> rays;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) rays.push_back(cam.primary_ray(T(x) + T(0.37), T(y) + T(0.61)));
    return rays;
}

} // namespace

TEST_CASE_TEMPLATE("scene: spheres and a user's kind through their Bvh find what the plain loop finds", T, float,
                   double) {
    isin::Scene<T, isin::Sphere, user::Cube> scene;
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    isin::Material<T> glass;
    glass.transparency = T(0.5);
    const auto m = scene.add_material({}), g = scene.add_material(glass);
    for (int i = 0; i < 3000; ++i)
        scene.add(isin::Sphere<T>{{T(uni(rng) * 30), T(uni(rng) * 17), T(40 + uni(rng) * 20)}, T(0.3 + 0.2 * uni(rng))},
                  i % 3 ? m : g);
    for (int i = 0; i < 500; ++i)
        scene.add(user::Cube<T>{{T(uni(rng) * 30), T(uni(rng) * 17), T(40 + uni(rng) * 20)}, T(0.4)}, i % 2 ? m : g);
    scene.commit();
    REQUIRE(scene.template has_bvh<isin::Sphere<T>>());
    REQUIRE(scene.template has_bvh<user::Cube<T>>());
    int hits = 0, differ = 0, shadow_differ = 0, partial = 0;
    for (const auto& ray : view_rays<T>(80, 45)) {
        scene.acceleration = isin::Acceleration::automatic;
        const auto a = scene.intersect(ray);
        const T ta = scene.transmittance(ray, T(100));
        scene.acceleration = isin::Acceleration::none;
        const auto b = scene.intersect(ray);
        const T tb = scene.transmittance(ray, T(100));
        hits += bool(b);
        differ += bool(a) != bool(b) || (a && (a.t != b.t || a.geometry != b.geometry || a.primitive != b.primitive));
        shadow_differ += std::fabs(double(ta) - double(tb)) > 1e-6; // the same factors, multiplied in another order
        partial += tb > T(0) && tb < T(1);
    }
    CHECK(hits > 1000);
    CHECK(differ == 0);
    CHECK(shadow_differ == 0);
    CHECK(partial > 20);
}

TEST_CASE_TEMPLATE("scene: shadow rays through a transparent mesh take its Bvh and multiply what the plain loop does",
                   T, float, double) {
    // Before, one transparent triangle sent the whole kind's shadow rays to the one-by-one loop.
    const auto sphere = workloads::icosphere<T>({0, 0, 40}, 10.0, 3); // 1280 triangles, closed
    isin::Material<T> glass;
    glass.transparency = T(0.7);
    isin::Scene<T, isin::Triangle> meshed, loose;
    meshed.add_mesh(sphere, meshed.add_material(glass));
    const auto m = loose.add_material(glass);
    for (const auto& tri : sphere) loose.add(tri, m);
    loose.acceleration = isin::Acceleration::none;
    int through_two = 0, differ = 0;
    for (const auto& ray : view_rays<T>(64, 36)) {
        const T a = meshed.transmittance(ray, T(100)), b = loose.transmittance(ray, T(100));
        differ += std::fabs(double(a) - double(b)) > 1e-6;
        through_two += std::fabs(double(b) - 0.49) < 1e-6; // in and out of the glass sphere
    }
    CHECK(differ == 0);
    CHECK(through_two > 200);
}

TEST_CASE_TEMPLATE("scene: placed meshes (rotated, scaled, mirrored, moved) hit as their moved triangles do", T, float,
                   double) {
    // 320 triangles around (0, 0, −50), behind the eye, where add_mesh places it; each placement
    // first brings it to the origin.
    const auto sphere = workloads::icosphere<T>({0, 0, -50}, 3.0, 2);
    using X = isin::Transform<T>;
    const X home = X::translation({0, 0, 50});
    const std::vector<X> places = {X::translation({-10, 0, 40}) * home,
                                   X::translation({0, 0, 45}) * X::rotation({1, 1, 0}, T(0.8)) *
                                       X::scaling({2, T(0.6), 1}) * home,
                                   X::translation({10, 2, 40}) * X::scaling({-1, 1, 1}) * home, // mirrored
                                   X::translation({3, -6, 35}) * X::scaling(T(0.5)) * home};
    isin::Scene<T, isin::Triangle> placed, moved;
    const auto m = placed.add_material({});
    const auto id = placed.add_mesh(sphere, m);
    for (const X& place : places) placed.add_instance(id, place);
    placed.commit();
    CHECK(placed.instance_count() == 5); // add_mesh's placement and 4 more
    CHECK(placed.has_instance_bvh());
    // The same triangles moved into the world, each placement a mesh of its own.
    const auto mm = moved.add_material({});
    for (const X& place : places) {
        std::vector<isin::Triangle<T>> world;
        for (const auto& tri : sphere) world.push_back({place.point(tri.v0), place.point(tri.v1), place.point(tri.v2)});
        moved.add_mesh(world, mm);
    }
    moved.add_mesh(sphere, mm);
    moved.commit();
    int hits = 0, differ = 0, normal_differ = 0;
    for (const auto& ray : view_rays<T>(96, 54)) {
        const auto a = placed.intersect(ray), b = moved.intersect(ray);
        hits += bool(b);
        differ += bool(a) != bool(b) || (a && std::fabs(double(a.t) - double(b.t)) > 1e-4 * double(b.t));
        // the mirrored copy's world triangles are wound the other way: its normals differ in sign
        if (a && b)
            normal_differ +=
                std::fabs(isin::dot(placed.surface(ray, a).normal, moved.surface(ray, b).normal)) < T(0.999);
    }
    CHECK(hits > 150);
    CHECK(differ == 0);
    CHECK(normal_differ == 0);
    // Culling keeps each placement's outside, mirrored or not: the closed meshes look the same.
    isin::RenderOptions opt;
    placed.add_light({{0, 50, 0}});
    const isin::Camera<T> cam{96, 54};
    const auto plain = isin::render(placed, cam, opt);
    opt.culling = isin::Culling::dot_product;
    CHECK(isin::render(placed, cam, opt).pixels() == plain.pixels());
    CHECK_THROWS_AS(placed.add_instance(isin::MeshId{7}, X::identity()), std::out_of_range);
    CHECK_THROWS_AS(placed.add_instance(id, X::scaling({1, 0, 1})), std::invalid_argument);
}

TEST_CASE("scene: a thousand placements of a mesh hold one mesh; twenty meshes cost twenty builds") {
    const auto sphere = workloads::icosphere<float>({0, 0, 0}, 1.0, 3); // 1280 triangles
    isin::Scene<float, isin::Sphere> scene;
    const auto id = scene.add_mesh(sphere, scene.add_material({}));
    const std::size_t one = scene.memory();
    for (int i = 0; i < 1000; ++i)
        scene.add_instance(id,
                           isin::Transform<float>::translation({float(i % 40) * 3 - 60, float(i / 40) * 3 - 36, 100}));
    scene.commit();
    const std::size_t thousand = scene.memory();
    CHECK(thousand < one + 1000 * 400); // a placement: two transforms, a box, its share of the placements' Bvh
    CHECK(scene.intersect(isin::Ray<float>{{0, 0, 0}, {0, 0, 1}}));
    // The mesh in 20 groups: the same hits as in one.
    isin::Scene<float, isin::Sphere> one_mesh, groups;
    one_mesh.add_mesh(sphere, one_mesh.add_material({}));
    const auto m = groups.add_material({});
    for (std::size_t g = 0; g < 20; ++g)
        groups.add_mesh(
            std::vector<isin::Triangle<float>>(sphere.begin() + long(g * 64), sphere.begin() + long(g * 64 + 64)), m);
    groups.commit();
    int differ = 0;
    for (const auto& ray : view_rays<float>(64, 36)) {
        const isin::Ray<float> r{ray.origin - isin::Vertex<float>{0, 0, 5}, ray.direction};
        const auto a = one_mesh.intersect(r), b = groups.intersect(r);
        differ += bool(a) != bool(b) || (a && a.t != b.t);
    }
    CHECK(differ == 0);
}

TEST_CASE_TEMPLATE("scene: objects<Shape>() lists one kind's objects in the order added, as hits index them", T, float,
                   double) {
    isin::Scene<T, isin::Sphere, isin::Triangle, isin::TexturedTriangle> scene;
    const auto red = scene.add_material({}), blue = scene.add_material({});
    CHECK(scene.template objects<isin::Sphere<T>>().empty());
    scene.add(isin::Sphere<T>{{0, 0, 50}, 5}, red);
    scene.add(isin::Triangle<T>{{5, 0, 10}, {6, 0, 10}, {5, 1, 10}}, blue);
    scene.add(isin::Sphere<T>{{0, 0, 30}, 2}, blue);
    scene.add_textured_rectangle({10, 0, 20}, {14, 0, 20}, {10, 2, 20}, red);
    const auto& spheres = scene.template objects<isin::Sphere<T>>();
    REQUIRE(spheres.size() == 2);
    CHECK(spheres[0].shape.center == isin::Vertex<T>{0, 0, 50});
    CHECK(spheres[0].shape.radius == T(5));
    CHECK(spheres[0].material == red);
    CHECK(spheres[1].shape.center == isin::Vertex<T>{0, 0, 30});
    CHECK(spheres[1].material == blue);
    const auto& triangles = scene.template objects<isin::Triangle<T>>();
    REQUIRE(triangles.size() == 1);
    CHECK(triangles[0].shape.v2 == isin::Vertex<T>{5, 1, 10});
    CHECK(triangles[0].material == blue);
    // The rectangle's two right triangles (§10): V0 at the right angle of each, v3 = v1 + v2 − v0.
    const auto& rectangle = scene.template objects<isin::TexturedTriangle<T>>();
    REQUIRE(rectangle.size() == 2);
    CHECK_FALSE(rectangle[0].shape.second);
    CHECK(rectangle[0].shape.triangle.v0 == isin::Vertex<T>{10, 0, 20});
    CHECK(rectangle[1].shape.second);
    CHECK(rectangle[1].shape.triangle.v0 == isin::Vertex<T>{14, 2, 20});
    CHECK(rectangle[1].material == red);
    CHECK(scene.size() == 5);
    // A hit names the kind (geometry) and the index into that kind's objects (primitive).
    const auto hit = scene.intersect(isin::Ray<T>{{0, 0, 0}, {0, 0, 1}});
    REQUIRE(hit);
    CHECK(hit.geometry == 0);
    REQUIRE(hit.primitive == 1);
    CHECK(hit.t == approx(28));
    CHECK(spheres[hit.primitive].shape.radius == T(2));
}

TEST_CASE_TEMPLATE("scene: mesh_count, mesh(id) and mesh_bvh(id): each mesh stored once, in its own space", T, float,
                   double) {
    isin::Scene<T, isin::Sphere> scene;
    const auto m = scene.add_material({});
    CHECK(scene.mesh_count() == 0);
    auto ball = workloads::icosphere<T>({0, 0, 40}, 10.0, 1); // 80 triangles around (0, 0, 40)
    ball.push_back({{1, 1, 1}, {2, 2, 2}, {3, 3, 3}});        // zero area: in the mesh, not in its Bvh
    const auto a = scene.add_mesh(ball, m);
    CHECK(scene.mesh_count() == 1);
    const isin::Mesh<T>* stored = &scene.mesh(a);
    CHECK(scene.mesh(a).size() == 81);
    CHECK(scene.mesh(a).triangle(80).v2 == isin::Vertex<T>{3, 3, 3});
    CHECK(scene.mesh_bvh(a).size() == 80);
    // Placing it again stores no new mesh and moves nothing in it.
    scene.add_instance(a, isin::Transform<T>::translation({100, 0, 0}));
    scene.add_instance(a, isin::Transform<T>::translation({-100, 0, 0}));
    CHECK(scene.mesh_count() == 1);
    CHECK(scene.instance_count() == 3);
    CHECK(&scene.mesh(a) == stored);
    const auto box = scene.mesh_bvh(a).tree().bounds();
    CHECK(box.lo.z == approx(30).epsilon(0.02)); // the mesh where it stands, not the placements
    CHECK(box.hi.x == approx(10).epsilon(0.02));
    const auto b = scene.add_mesh(std::vector<isin::Triangle<T>>{{{-1, -1, 5}, {0, 1, 5}, {1, -1, 5}}}, m);
    CHECK(b.index == 1);
    CHECK(scene.mesh_count() == 2);
    CHECK(scene.instance_count() == 4);
    CHECK(scene.mesh(b).size() == 1);
    CHECK(scene.mesh_bvh(b).size() == 1);
    scene.commit();
    // A ray at the copy moved to x = 100: the scene hits it, the mesh's own Bvh (at x = 0) does not.
    const isin::Ray<T> at_copy{{100, 0, 0}, {0, 0, 1}};
    const auto hit = scene.intersect(at_copy);
    REQUIRE(hit);
    CHECK(hit.t == approx(30).epsilon(0.02));
    CHECK_FALSE(scene.mesh_bvh(a).intersect(at_copy));
    // Down the axis: each Bvh alone finds its own mesh; in the scene the triangle at z = 5 hides the ball.
    const isin::Ray<T> axis{{0, 0, 0}, {0, 0, 1}};
    CHECK(scene.mesh_bvh(a).intersect(axis).t == approx(30).epsilon(0.02));
    CHECK(scene.mesh_bvh(b).intersect(axis).t == approx(5));
    CHECK(scene.intersect(axis).t == approx(5));
}

TEST_CASE_TEMPLATE("§10 texture_coordinates: (u, v) on a rectangle's first triangle, (1−u, 1−v) on its second; other "
                   "kinds have none",
                   T, float, double) {
    const isin::Triangle<T> tri{{0, 0, 10}, {4, 0, 10}, {0, 2, 10}};
    const auto hit = isin::Hit<T>::at(T(10), T(0.25), T(0.5));
    std::array<T, 2> st{T(-1), T(-1)};
    CHECK(isin::texture_coordinates(isin::TexturedTriangle<T>{tri, false}, hit, st));
    CHECK(st == std::array<T, 2>{T(0.25), T(0.5)});
    CHECK(isin::texture_coordinates(isin::TexturedTriangle<T>{tri, true}, hit, st));
    CHECK(st == std::array<T, 2>{T(0.75), T(0.5)});
    st = {T(-1), T(-1)};
    CHECK_FALSE(isin::texture_coordinates(tri, hit, st));
    CHECK_FALSE(isin::texture_coordinates(isin::Sphere<T>{{0, 0, 10}, 1}, hit, st));
    CHECK(st == std::array<T, 2>{T(-1), T(-1)}); // untouched
}

namespace {
template <class T>
bool same_scene_hit(const isin::Hit<T>& a, const isin::Hit<T>& b) {
    return std::memcmp(&a.t, &b.t, sizeof a.t) == 0 && std::memcmp(&a.u, &b.u, sizeof a.u) == 0 &&
           std::memcmp(&a.v, &b.v, sizeof a.v) == 0 && a.primitive == b.primitive && a.geometry == b.geometry;
}

/// Rays of view_rays in 4×4 tiles, with some bad ones mixed in.
template <class T>
std::vector<isin::Ray<T>> tiled_view_rays(int w, int h) {
    const auto rays = view_rays<T>(w, h);
    std::vector<isin::Ray<T>> tiled;
    for (int ty = 0; ty < h; ty += 4)
        for (int tx = 0; tx < w; tx += 4)
            for (int y = ty; y < std::min(ty + 4, h); ++y)
                for (int x = tx; x < std::min(tx + 4, w); ++x) tiled.push_back(rays[std::size_t(y * w + x)]);
    const T nan = std::numeric_limits<T>::quiet_NaN();
    for (std::size_t i = 3; i < tiled.size(); i += 41)
        tiled[i].direction = i % 2 ? isin::Vertex<T>{} : isin::Vertex<T>{nan, 0, 1};
    return tiled;
}

/// Counts the rays whose stream results differ from the single-ray calls'.
template <class S>
int scene_stream_mismatches(const S& scene, const std::vector<isin::Ray<typename S::value_type>>& rays,
                            const typename S::Culled* culled = nullptr) {
    using T = typename S::value_type;
    std::vector<isin::Hit<T>> hits(rays.size());
    std::vector<T> limit(rays.size());
    std::vector<std::uint8_t> blocked(rays.size(), 9);
    std::vector<T> through(rays.size(), T(-1));
    for (std::size_t i = 0; i < rays.size(); ++i) limit[i] = T(20) + T(i % 37) * T(3);
    scene.intersect(rays.data(), rays.size(), hits.data(), culled);
    scene.occluded(rays.data(), rays.size(), limit.data(), blocked.data());
    scene.transmittance(rays.data(), rays.size(), limit.data(), through.data());
    int mismatches = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto one = scene.intersect(rays[i], std::numeric_limits<T>::infinity(), culled);
        mismatches += !same_scene_hit(hits[i], one);
        const bool shadow = scene.occluded(rays[i], limit[i]);
        mismatches += blocked[i] != (shadow ? 1 : 0);
        const T light = scene.transmittance(rays[i], limit[i]);
        mismatches += std::memcmp(&through[i], &light, sizeof light) != 0;
        // occluded is "anything in the way": what transmittance sees through nothing transparent
        mismatches += shadow != (scene.transmittance(rays[i], limit[i]) < T(1));
    }
    return mismatches;
}
} // namespace

TEST_CASE_TEMPLATE("scene stream: every kind, a Bvh kind, one placed mesh or several, culled or not: the single-ray "
                   "hits and transmittances bit for bit",
                   T, float, double) {
    using X = isin::Transform<T>;
    const auto ball = workloads::icosphere<T>({0, 4, 50}, 8.0, 3); // 1280 triangles: a Bvh
    const auto rays = tiled_view_rays<T>(96, 56);
    for (int placements : {0, 1, 3}) {
        CAPTURE(placements);
        isin::Scene<T, isin::Sphere, isin::Triangle, isin::TexturedTriangle> scene;
        const auto m = scene.add_material({});
        isin::Material<T> glass;
        glass.transparency = T(0.6);
        const auto g = scene.add_material(glass);
        scene.add(isin::Sphere<T>{{-6, 2, 45}, 3}, g);
        scene.add(isin::Sphere<T>{{5, -3, 50}, T(2.5)}, m);
        for (const auto& tri : workloads::icosphere<T>({4, 3, 42}, 2.0, 2))
            scene.add(tri, m); // 320 triangles of the Triangle kind: its own Bvh
        scene.add_textured_rectangle({-30, -12, 20}, {-30, -12, 90}, {30, -12, 20}, g);
        if (placements > 0) {
            const auto id = scene.add_mesh(isin::Mesh<T>::from_triangles(ball), m);
            for (int k = 1; k < placements; ++k) scene.add_instance(id, X::translation({T(18 * k - 27), 0, 10}));
        }
        scene.commit();
        CHECK(scene.template has_bvh<isin::Triangle<T>>());
        std::size_t hit = 0, ball_hits = 0;
        for (const auto& ray : rays) {
            const auto h = scene.intersect(ray);
            hit += bool(h), ball_hits += h && h.geometry >= 3;
        }
        CHECK(hit > rays.size() / 4);
        CHECK((ball_hits > 50) == (placements > 0));
        CHECK(scene_stream_mismatches(scene, rays) == 0);
        const isin::Camera<T> cam{96, 56};
        const auto culled = isin::backface_masks(scene, cam, isin::Culling::dot_product);
        CHECK(scene_stream_mismatches(scene, rays, &culled) == 0);
    }
}

TEST_CASE_TEMPLATE("scene stream: a scene too small for a Bvh (rays × objects in lanes): the single-ray results bit "
                   "for bit, for camera rays and for secondary rays from the surfaces they hit",
                   T, float, double) {
    isin::Scene<T, isin::Sphere, isin::Triangle, isin::TexturedTriangle> scene; // the note's shapes (§5, §6, §10)
    const auto m = scene.add_material({});
    isin::Material<T> glass;
    glass.transparency = T(0.7);
    const auto g = scene.add_material(glass);
    scene.add(isin::Triangle<T>{{0, 30, 40}, {40, -30, 120}, {-40, -30, 120}}, m);
    scene.add(isin::Triangle<T>{{-50, 30, 124}, {50, 30, 124}, {0, -30, 44}}, g);
    scene.add(isin::Triangle<T>{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}}, m);
    scene.add(isin::Sphere<T>{{-78, -10, 170}, 35}, m);
    scene.add(isin::Sphere<T>{{60, -29, 110}, 16}, g);
    scene.add_textured_rectangle({-200, -45, 20}, {-200, -45, 1000}, {200, -45, 20}, m);
    scene.commit();
    CHECK_FALSE(scene.template has_bvh<isin::Triangle<T>>());
    CHECK_FALSE(scene.template has_bvh<isin::Sphere<T>>());
    const isin::Camera<T> cam{120, 68};
    std::vector<isin::Ray<T>> rays, secondary;
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x) rays.push_back(cam.primary_ray(T(x), T(y)));
    // From each hit: towards a light, mirrored, and on into the surface, each from the hit point
    // itself (no offset: the hardest case for a filter) and from the offset origin.
    const isin::Vertex<T> light{-60, 150, 40};
    for (const auto& ray : rays) {
        const auto h = scene.intersect(ray);
        if (!h) continue;
        const auto sp = scene.surface(ray, h);
        const isin::Vertex<T> N = isin::dot(sp.normal, ray.direction) < T(0) ? sp.normal : -sp.normal;
        const isin::Vertex<T> above = isin::offset_ray_origin({sp.point, sp.error}, N, N);
        for (const isin::Vertex<T>& from : {sp.point, above}) {
            secondary.push_back({from, light - from});
            secondary.push_back({from, isin::reflect(ray.direction, N)});
            secondary.push_back({from, ray.direction});
        }
    }
    CHECK(secondary.size() > rays.size() * 3);
    const isin::Vertex<T> zero{};
    for (std::size_t i = 5; i < secondary.size(); i += 97) secondary[i].direction = zero;
    CHECK(scene_stream_mismatches(scene, rays) == 0);
    CHECK(scene_stream_mismatches(scene, secondary) == 0);
    const auto culled = isin::backface_masks(scene, cam, isin::Culling::projected);
    CHECK(scene_stream_mismatches(scene, rays, &culled) == 0);
}

TEST_CASE_TEMPLATE("scene: surface points carry error bounds that hold the exact surface (spheres, triangles, placed "
                   "meshes far from the origin)",
                   T, float, double) {
    using L = long double;
    using X = isin::Transform<T>;
    const T far = T(2000);
    const auto ico = workloads::icosphere<T>({0, 0, 0}, 2.0, 2);
    isin::Scene<T, isin::Sphere, isin::Triangle> scene;
    const auto m = scene.add_material({});
    scene.add(isin::Sphere<T>{{far - 6, far, far}, 2}, m);
    scene.add(isin::Triangle<T>{{far + 4, far - 3, far - 1}, {far + 4, far + 3, far - 1}, {far + 9, far - 3, far + 1}},
              m);
    const auto id = scene.add_mesh(ico, m);
    const X place = X::translation({far, far + 6, far}) * X::rotation({1, 2, 3}, T(0.7)) * X::scaling({1, 2, T(0.5)});
    scene.add_instance(id, place);
    scene.commit();
    const isin::Vertex<T> eye{far, far, far - 40};
    std::mt19937_64 rng(3);
    const auto uni = [&](double lo, double hi) { return T(lo + (hi - lo) * double(rng() >> 11) * 0x1p-53); };
    // |n|·error ≥ the distance from the surface (n the unit normal there, in long double).
    const auto within = [](const isin::Vertex<L>& n, L distance, const isin::Vertex<T>& e) {
        return std::fabs(distance) <= std::fabs(n.x) * L(e.x) + std::fabs(n.y) * L(e.y) + std::fabs(n.z) * L(e.z);
    };
    const auto wide = [](const isin::Vertex<T>& a) { return isin::Vertex<L>{L(a.x), L(a.y), L(a.z)}; };
    int kinds[3] = {0, 0, 0}, outside = 0;
    for (int i = 0; i < 3000; ++i) {
        const isin::Ray<T> ray{eye, isin::Vertex<T>{uni(-12, 12), uni(-6, 12), T(40)}};
        const auto h = scene.intersect(ray);
        if (!h) continue;
        const auto sp = scene.surface(ray, h);
        if (h.geometry == 0) { // the sphere
            const auto d = wide(sp.point) - isin::Vertex<L>{L(far - 6), L(far), L(far)};
            outside += !within(isin::normalize(d), isin::length(d) - 2, sp.error);
        } else {
            isin::Triangle<T> tri{
                {far + 4, far - 3, far - 1}, {far + 4, far + 3, far - 1}, {far + 9, far - 3, far + 1}};
            isin::Vertex<L> v[3] = {wide(tri.v0), wide(tri.v1), wide(tri.v2)};
            if (h.geometry != 1) { // the placed mesh: its triangle moved exactly
                const auto& t = ico[h.primitive];
                const isin::Vertex<T>* src[3] = {&t.v0, &t.v1, &t.v2};
                for (int k = 0; k < 3; ++k) {
                    L c[3];
                    for (int r = 0; r < 3; ++r)
                        c[r] = L(place.m[r][0]) * L(src[k]->x) + L(place.m[r][1]) * L(src[k]->y) +
                               L(place.m[r][2]) * L(src[k]->z) + L(isin::component(place.d, r));
                    v[k] = {c[0], c[1], c[2]};
                }
            }
            const auto n = isin::normalize(isin::cross(v[1] - v[0], v[2] - v[0]));
            outside += !within(n, isin::dot(n, wide(sp.point) - v[0]), sp.error);
        }
        ++kinds[std::min<std::uint32_t>(h.geometry, 2)];
    }
    CHECK(kinds[0] > 100);
    CHECK(kinds[1] > 100);
    CHECK(kinds[2] > 100);
    CHECK(outside == 0);
}
