// Closest points of a Scene: placed meshes under every transform a Scene accepts, triangle kinds
// and spheres, against brute force over every world-space triangle and sphere.
#include <doctest/doctest.h>
#include <isin/isin.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "support/solids.hpp"
#include "support/wide.hpp"

namespace {

using LD = long double;

// The world-space surfaces of a scene, in long double from the same T inputs: each triangle of
// each placement (M·v + d), the loose triangles and the spheres, with what the scene calls them.
template <class T>
struct Reference {
    struct Tri {
        isin::Vertex<LD> v[3];
        std::uint32_t geometry, primitive;
    };
    struct Ball {
        isin::Vertex<LD> center;
        LD radius;
        std::uint32_t geometry, primitive;
    };
    std::vector<Tri> tris;
    std::vector<Ball> balls;
    isin::Box<LD> box;

    void place(const isin::Mesh<T>& mesh, const isin::Transform<T>& to_world, std::uint32_t geometry) {
        for (std::size_t i = 0; i < mesh.size(); ++i) {
            const isin::Triangle<T> t = mesh.triangle(i);
            if (!isin::Bvh<T>::bounds(t).usable()) continue;
            Tri w{{to_ld(to_world, t.v0), to_ld(to_world, t.v1), to_ld(to_world, t.v2)}, geometry, std::uint32_t(i)};
            for (const auto& v : w.v) box.grow(v);
            tris.push_back(w);
        }
    }
    static isin::Vertex<LD> to_ld(const isin::Transform<T>& m, const isin::Vertex<T>& v) {
        LD out[3];
        for (int r = 0; r < 3; ++r)
            out[r] = LD(m.m[r][0]) * LD(v.x) + LD(m.m[r][1]) * LD(v.y) + LD(m.m[r][2]) * LD(v.z) +
                     LD(isin::component(m.d, r));
        return {out[0], out[1], out[2]};
    }
    LD distance(const isin::Vertex<T>& pt) const {
        const auto p = wide(pt);
        LD best = std::numeric_limits<LD>::infinity();
        for (const auto& t : tris) {
            const auto q = isin::detail::closest_on_triangle(p, t.v[0], t.v[1], t.v[2]);
            best = std::min(best, std::sqrt(isin::dot(q.gap, q.gap)));
        }
        for (const auto& b : balls) best = std::min(best, std::fabs(isin::length(p - b.center) - b.radius));
        return best;
    }
    LD diagonal() const { return isin::length(box.hi - box.lo); }
};

template <class T>
LD tolerance() {
    return sizeof(T) == sizeof(float) ? LD(2e-6) : LD(1e-12);
}

// The distance within the goal of brute force's, and the point on the surface it names, at that
// distance from p.
template <class T>
void check_hit(const isin::ScenePointHit<T>& hit, const Reference<T>& ref, const isin::Vertex<T>& p) {
    const LD expected = ref.distance(p);
    const LD diag = ref.diagonal();
    REQUIRE(hit);
    CHECK(std::fabs(LD(hit.distance) - expected) <= tolerance<T>() * diag);
    const LD room = tolerance<T>() * diag + LD(8) * LD(std::numeric_limits<T>::epsilon()) * isin::max_abs(wide(p));
    CHECK(std::fabs(isin::length(wide(hit.point) - wide(p)) - expected) <= room);
    bool named = false;
    for (const auto& t : ref.tris)
        if (t.geometry == hit.geometry && t.primitive == hit.primitive) {
            const auto on = isin::detail::closest_on_triangle(wide(hit.point), t.v[0], t.v[1], t.v[2]);
            CHECK(std::sqrt(isin::dot(on.gap, on.gap)) <= room);
            named = true;
        }
    for (const auto& b : ref.balls)
        if (b.geometry == hit.geometry && b.primitive == hit.primitive) {
            CHECK(std::fabs(isin::length(wide(hit.point) - b.center) - b.radius) <= room);
            named = true;
        }
    CHECK(named);
}

// A scene of every kind of placement: the mesh where it stands, turned and moved, scaled
// uniformly, scaled non-uniformly, sheared, mirrored; spheres (enough for their Bvh) and loose
// triangles (too few for one).
template <class T>
struct Fixture {
    isin::Scene<T, isin::Sphere, isin::Triangle> scene;
    Reference<T> ref;
    std::vector<isin::Vertex<T>> centres; // of each placement

    Fixture() {
        const auto material = scene.add_material({});
        const auto mesh = solids::icosphere<T>(2, {0.1, -0.2, 0.05}, 1.0);
        const auto id = scene.add_mesh(mesh, material);
        using Tf = isin::Transform<T>;
        Tf shear = Tf::identity();
        shear.m[0][1] = T(0.8), shear.m[2][0] = T(-0.6), shear.m[1][2] = T(0.3);
        const std::vector<Tf> places = {
            Tf::identity(),
            Tf::translation({T(4), T(0), T(0)}) * Tf::rotation({T(1), T(2), T(3)}, T(0.7)),
            Tf::translation({T(-4), T(1), T(0)}) * Tf::scaling(T(2.5)),
            Tf::translation({T(0), T(5), T(0)}) * Tf::rotation({T(0), T(1), T(1)}, T(1.1)) *
                Tf::scaling({T(3), T(0.4), T(1.5)}),
            Tf::translation({T(0), T(-5), T(1)}) * shear,
            Tf::translation({T(0), T(0), T(-5)}) * Tf::scaling({T(-1.5), T(1), T(0.7)}),
        };
        for (std::size_t i = 0; i < places.size(); ++i) {
            if (i > 0) scene.add_instance(id, places[i]);
            ref.place(mesh, places[i], std::uint32_t(2 + i));
            centres.push_back(places[i].point({T(0.1), T(-0.2), T(0.05)}));
        }
        std::mt19937_64 rng(17);
        std::uniform_real_distribution<double> u(-6, 6), r(0.2, 1.0);
        for (std::uint32_t i = 0; i < 12; ++i) {
            const isin::Sphere<T> s{{T(u(rng)), T(u(rng)), T(u(rng))}, T(r(rng))};
            scene.add(s, material);
            ref.balls.push_back({wide(s.center), LD(s.radius), 0, i});
            ref.box.grow(wide(s.center) - isin::Vertex<LD>{LD(s.radius), LD(s.radius), LD(s.radius)});
            ref.box.grow(wide(s.center) + isin::Vertex<LD>{LD(s.radius), LD(s.radius), LD(s.radius)});
            centres.push_back(s.center);
        }
        for (std::uint32_t i = 0; i < 3; ++i) {
            const T x = T(6 + 2 * i);
            const isin::Triangle<T> t{{x, T(0), T(0)}, {x, T(1), T(0.5)}, {x + T(0.5), T(0), T(1)}};
            scene.add(t, material);
            ref.tris.push_back({{wide(t.v0), wide(t.v1), wide(t.v2)}, 1, i});
            for (const auto& v : {t.v0, t.v1, t.v2}) ref.box.grow(wide(v));
        }
        scene.commit();
    }

    // Points all over the scene's box enlarged, near every placement and sphere, and on surfaces.
    std::vector<isin::Vertex<T>> points() const {
        std::vector<isin::Vertex<T>> out;
        std::mt19937_64 rng(23);
        std::uniform_real_distribution<double> x(double(ref.box.lo.x) - 1, double(ref.box.hi.x) + 1),
            y(double(ref.box.lo.y) - 1, double(ref.box.hi.y) + 1),
            z(double(ref.box.lo.z) - 1, double(ref.box.hi.z) + 1), near(-1.5, 1.5);
        for (int i = 0; i < 150; ++i) out.push_back({T(x(rng)), T(y(rng)), T(z(rng))});
        for (const auto& c : centres)
            for (int i = 0; i < 25; ++i) out.push_back(c + isin::Vertex<T>{T(near(rng)), T(near(rng)), T(near(rng))});
        for (std::size_t i = 0; i < ref.tris.size(); i += 37) { // on a face, an edge, a vertex
            const auto& t = ref.tris[i].v;
            const auto at = [](const isin::Vertex<LD>& v) { return isin::Vertex<T>{T(v.x), T(v.y), T(v.z)}; };
            out.push_back(at(t[0] + LD(0.3) * (t[1] - t[0]) + LD(0.3) * (t[2] - t[0])));
            out.push_back(at(t[0] + LD(0.5) * (t[2] - t[0])));
            out.push_back(at(t[1]));
        }
        out.push_back({T(200), T(-100), T(50)}); // far away
        return out;
    }
};

} // namespace

TEST_CASE_TEMPLATE("Scene::closest_point against brute force: every transform, spheres, triangles", T, float, double) {
    const Fixture<T> f;
    std::vector<std::size_t> per_geometry(2 + 6, 0);
    for (const auto& p : f.points()) {
        const auto hit = f.scene.closest_point(p);
        check_hit(hit, f.ref, p);
        if (hit.geometry < per_geometry.size()) ++per_geometry[hit.geometry];
    }
    for (std::size_t g = 0; g < per_geometry.size(); ++g) {
        CAPTURE(g);
        CHECK(per_geometry[g] > 10); // every kind and placement answers some points
    }
}

TEST_CASE_TEMPLATE("Scene::closest_point: max_distance, empty scenes, NaN and infinite points", T, float, double) {
    const Fixture<T> f;
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    std::size_t checked = 0;
    for (const auto& p : f.points()) {
        const auto hit = f.scene.closest_point(p);
        if (!(hit.distance > T(1e-3))) continue;
        CHECK_FALSE(f.scene.closest_point(p, hit.distance * T(0.99))); // nothing within: the miss
        const auto again = f.scene.closest_point(p, hit.distance * T(1.01));
        CHECK(again.distance == hit.distance);
        CHECK(again.geometry == hit.geometry);
        CHECK(again.primitive == hit.primitive);
        ++checked;
    }
    CHECK(checked > 100);
    const auto miss = f.scene.closest_point({T(200), T(0), T(0)}, T(1));
    CHECK_FALSE(miss);
    CHECK(miss.distance == inf);
    CHECK(miss.geometry == isin::PointHit<T>::none);
    CHECK(miss.primitive == isin::PointHit<T>::none);
    CHECK_FALSE(f.scene.closest_point({nan, T(0), T(0)}));
    CHECK_FALSE(f.scene.closest_point({T(0), inf, T(0)}));
    CHECK_FALSE(f.scene.closest_point({T(0), T(0), T(0)}, nan));
    CHECK_FALSE(f.scene.closest_point({T(0), T(0), T(0)}, T(-1)));

    isin::Scene<T, isin::Sphere> empty;
    CHECK_FALSE(empty.closest_point({T(0), T(0), T(0)}));
    const auto material = empty.add_material({});
    empty.add_mesh(std::vector<isin::Triangle<T>>{}, material); // a placed mesh with no triangles
    CHECK_FALSE(empty.closest_point({T(0), T(0), T(0)}));
    empty.add(isin::Sphere<T>{{T(0), T(0), T(0)}, T(2)}, material); // one sphere, no Bvh: from its centre, r away
    const auto centre = empty.closest_point({T(0), T(0), T(0)});
    REQUIRE(centre);
    CHECK(centre.distance == T(2));
    CHECK(centre.geometry == 0);
    CHECK(centre.primitive == 0);
    CHECK(empty.closest_point({T(0), T(3), T(0)}).point.y == T(2));
}

TEST_CASE_TEMPLATE("Scene::closest_point: the array form answers as one by one", T, float, double) {
    const Fixture<T> f;
    auto points = f.points();
    points.push_back({std::numeric_limits<T>::quiet_NaN(), T(0), T(0)});
    for (int threads : {0, 1, 2}) {
        std::vector<isin::ScenePointHit<T>> out(points.size());
        f.scene.closest_point(points.data(), points.size(), out.data(), threads);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const auto one = f.scene.closest_point(points[i]);
            differ += !(out[i].distance == one.distance || (!out[i] && !one)) || out[i].geometry != one.geometry ||
                      out[i].primitive != one.primitive || !(out[i].point == one.point);
        }
        CHECK(differ == 0);
        CHECK_FALSE(out.back());
    }
}

TEST_CASE_TEMPLATE("Scene::closest_point on a StandardScene: textured triangles, spheres, a placed mesh", T, float,
                   double) {
    isin::StandardScene<T> scene;
    Reference<T> ref;
    const auto material = scene.add_material({});
    scene.add_textured_rectangle({T(0), T(-3), T(0)}, {T(2), T(-3), T(0)}, {T(0), T(-3), T(2)}, material);
    const isin::Vertex<T> v0{T(0), T(-3), T(0)}, v1{T(2), T(-3), T(0)}, v2{T(0), T(-3), T(2)}, v3 = v1 + v2 - v0;
    ref.tris.push_back({{wide(v0), wide(v1), wide(v2)}, 2, 0});
    ref.tris.push_back({{wide(v3), wide(v2), wide(v1)}, 2, 1});
    scene.add(isin::Sphere<T>{{T(1), T(3), T(1)}, T(0.5)}, material);
    ref.balls.push_back({{LD(1), LD(3), LD(1)}, LD(0.5), 0, 0});
    const auto mesh = solids::icosphere<T>(1, {0, 0, 0}, 1.0);
    const auto id = scene.add_mesh(mesh, material);
    ref.place(mesh, isin::Transform<T>::identity(), 3);
    const auto squash =
        isin::Transform<T>::translation({T(-3), T(1), T(0)}) * isin::Transform<T>::scaling({T(2), T(0.5), T(1)});
    scene.add_instance(id, squash);
    ref.place(mesh, squash, 4);
    ref.box.grow(isin::Vertex<LD>{LD(-6), LD(-4), LD(-2)}), ref.box.grow(isin::Vertex<LD>{LD(3), LD(4), LD(3)});
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> u(-6, 4);
    for (int i = 0; i < 200; ++i) {
        const isin::Vertex<T> p{T(u(rng)), T(u(rng)), T(u(rng))};
        check_hit(scene.closest_point(p), ref, p);
    }
    const auto above = scene.closest_point({T(1), T(-2.75), T(0.5)}); // over the rectangle's first triangle
    CHECK(above.geometry == 2);
    CHECK(above.primitive == 0);
    CHECK(above.distance == doctest::Approx(0.25));
}

namespace {

// Brute force's crossing count of a ray with the reference's surfaces, t in (0, t_max), in long
// double (Möller–Trumbore per triangle, both roots per sphere); `clear` is false when a crossing
// lies so near an edge, a tangent, t = 0 or t_max that rounding may decide it.
template <class T>
std::size_t reference_crossings(const Reference<T>& ref, const isin::Ray<T>& ray, T t_max, bool& clear) {
    const auto o = wide(ray.origin), d = wide(ray.direction);
    const LD tm = LD(t_max), margin = LD(1e-4);
    const auto near_end = [&](LD t) { return std::fabs(t) < margin || std::fabs(t - tm) < margin * (LD(1) + tm); };
    std::size_t count = 0;
    clear = true;
    for (const auto& tri : ref.tris) {
        const auto e1 = tri.v[1] - tri.v[0], e2 = tri.v[2] - tri.v[0], pv = isin::cross(d, e2);
        const LD det = isin::dot(e1, pv);
        if (std::fabs(det) < LD(1e-12)) continue; // parallel to the plane: never a crossing here
        const auto s = o - tri.v[0], qv = isin::cross(s, e1);
        const LD u = isin::dot(s, pv) / det, v = isin::dot(d, qv) / det, t = isin::dot(e2, qv) / det;
        const LD edge = std::min({u, v, LD(1) - u - v});
        if (std::fabs(edge) < margin && t > -margin && t < tm + margin) clear = false;
        if (edge > 0 && t > 0 && t < tm) count += 1, clear = clear && !near_end(t);
    }
    for (const auto& b : ref.balls) {
        const auto l = b.center - o;
        const LD a = isin::dot(d, d), s = isin::dot(l, d) / a, m2 = isin::dot(l, l) - s * s * a;
        const LD disc = (b.radius * b.radius - m2) / a;
        if (std::fabs(disc) < margin) clear = false;
        if (disc <= 0) continue;
        for (const LD t : {s - std::sqrt(disc), s + std::sqrt(disc)})
            if (t > 0 && t < tm)
                count += 1, clear = clear && !near_end(t);
            else if (near_end(t))
                clear = false;
    }
    return count;
}

} // namespace

TEST_CASE_TEMPLATE("Scene::count_hits against brute force: every transform, spheres, triangles", T, float, double) {
    const Fixture<T> f;
    std::mt19937_64 rng(41);
    std::uniform_real_distribution<double> u(-9, 9), dir(-1, 1), len(0.5, 12);
    std::size_t compared = 0, crossings = 0;
    for (int i = 0; i < 400; ++i) {
        const isin::Vertex<T> o{T(u(rng)), T(u(rng)), T(u(rng))}, jitter{T(dir(rng)), T(dir(rng)), T(dir(rng))};
        const isin::Ray<T> ray{o, i % 4 < 2 ? f.centres[std::size_t(i) % f.centres.size()] + jitter - o : jitter};
        const T t_max = i % 2 ? std::numeric_limits<T>::infinity() : T(len(rng));
        bool clear = true;
        const std::size_t expected = reference_crossings(f.ref, ray, t_max, clear);
        if (!clear) continue;
        CAPTURE(i);
        CHECK(f.scene.count_hits(ray, t_max) == expected);
        ++compared, crossings += expected;
    }
    CHECK(compared > 350);
    CHECK(crossings > 300); // the rays do cross things
}

TEST_CASE_TEMPLATE("Scene::count_hits through the placed meshes' vertices and edges: even from outside", T, float,
                   double) {
    const Fixture<T> f;
    const isin::Vertex<T> from{T(-30), T(21), T(-17)}; // outside everything, off every axis
    const auto at = [](const isin::Vertex<LD>& v) { return isin::Vertex<T>{T(v.x), T(v.y), T(v.z)}; };
    std::size_t odd = 0, rays = 0, crossings = 0;
    for (std::size_t i = 0; i < f.ref.tris.size(); i += 3) {
        const auto& t = f.ref.tris[i];
        if (t.geometry < 2) continue; // the loose triangles are open surfaces
        for (const auto& aim : {t.v[0], t.v[1], (t.v[0] + t.v[1]) * LD(0.5), (t.v[1] + t.v[2]) * LD(0.5)}) {
            const isin::Ray<T> ray{from, at(aim) - from};
            std::size_t loose = 0; // crossings of the loose triangles, counted apart
            isin::detail::WatertightShear<T> shear;
            REQUIRE(shear.set(ray.direction));
            for (const auto& l : f.ref.tris)
                if (l.geometry == 1)
                    loose += isin::detail::crosses(at(l.v[0]) - from, at(l.v[1]) - from, at(l.v[2]) - from, shear,
                                                   std::numeric_limits<T>::infinity());
            const std::size_t n = f.scene.count_hits(ray);
            odd += (n - loose) % 2, ++rays, crossings += n;
        }
    }
    CHECK(rays > 500);
    CHECK(crossings >= 2 * rays); // each ray crosses at least the mesh it is aimed at
    CHECK(odd == 0);
}

TEST_CASE_TEMPLATE("Scene::count_hits: t_max, NaN rays, empty scenes, spheres without a Bvh", T, float, double) {
    const Fixture<T> f;
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    const isin::Vertex<T> centre{T(0.1), T(-0.2), T(0.05)};      // inside the mesh where it stands
    const isin::Ray<T> out{centre, {T(0.31), T(0.17), T(0.93)}}; // through no vertex or edge
    bool clear = true;
    const std::size_t leaving = reference_crossings(f.ref, out, T(1.5), clear);
    REQUIRE(clear);
    CHECK(leaving % 2 == 1); // from inside the mesh where it stands: an odd count
    CHECK(f.scene.count_hits(out, T(1.5)) == leaving);
    CHECK(f.scene.count_hits(out, T(0.5)) == 0); // not yet at the unit icosphere's surface
    CHECK(f.scene.count_hits(out, T(0)) == 0);
    CHECK(f.scene.count_hits(out, -inf) == 0);
    CHECK(f.scene.count_hits(out, nan) == 0);
    CHECK(f.scene.count_hits({{nan, T(0), T(0)}, {T(0), T(0), T(1)}}) == 0);
    CHECK(f.scene.count_hits({centre, {T(0), T(0), T(0)}}) == 0);
    CHECK(f.scene.count_hits({centre, {inf, T(0), T(0)}}) == 0);
    isin::Scene<T, isin::Sphere, isin::Triangle> empty;
    CHECK(empty.count_hits(out) == 0);
    const auto material = empty.add_material({});
    empty.add(isin::Sphere<T>{{T(0), T(0), T(5)}, T(2)}, material); // one sphere, no Bvh
    CHECK(empty.count_hits({{T(0), T(0), T(0)}, {T(0), T(0), T(1)}}) == 2);
    CHECK(empty.count_hits({{T(0), T(0), T(0)}, {T(0), T(0), T(1)}}, T(4)) == 1);
    CHECK(empty.count_hits({{T(0), T(0), T(5)}, {T(0), T(1), T(0)}}) == 1);  // from its centre
    CHECK(empty.count_hits({{T(2), T(0), T(0)}, {T(0), T(0), T(1)}}) == 0);  // touches it only
    CHECK(empty.count_hits({{T(0), T(0), T(0)}, {T(0), T(0), T(-1)}}) == 0); // away from it
}
