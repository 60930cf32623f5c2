// §9: shadow rays must not hit the surface they start on ("acne"), at any distance from the origin.
#include <isin/offset.hpp>
#include <isin/sphere.hpp>
#include <isin/triangle.hpp>

#include <doctest/doctest.h>

#include "approx.hpp"

#include <limits>
#include <random>
#include <type_traits>

namespace {

// Shadow rays from hit points on a triangle (size `size`, `far` from the origin, seen from an eye
// nearby) towards a light on the eye's side; returns how many hit the triangle itself.
struct Count {
    int hits = 0, acne = 0;
};

template <class T>
Count triangle_acne(T far, T size, bool offset, int rays) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const isin::Vertex<T> base{far, T(0.37) * far, T(-0.61) * far};
    const isin::Triangle<T> tri{base, base + isin::Vertex<T>{size, T(0.2) * size, T(0.9) * size},
                                base + isin::Vertex<T>{T(-0.3) * size, size, T(0.1) * size}};
    const auto N = isin::normalize(isin::normal(tri));
    const auto centre = (tri.v0 + tri.v1 + tri.v2) / T(3);
    const auto eye = centre + T(3) * size * isin::normalize(N + isin::Vertex<T>{T(0.3), 0, 0});
    const auto light = centre + T(10) * size * isin::normalize(N + isin::Vertex<T>{0, T(-0.4), T(0.2)});
    Count c;
    for (int i = 0; i < rays; ++i) {
        T u = T(uni(rng)), v = T(uni(rng));
        if (u + v > T(1)) u = T(1) - u, v = T(1) - v;
        const auto aim = tri.v0 + u * (tri.v1 - tri.v0) + v * (tri.v2 - tri.v0);
        const isin::Ray<T> primary{eye, isin::normalize(aim - eye)};
        const auto h = isin::intersect_moller_trumbore(primary, tri);
        if (!h) continue;
        ++c.hits;
        const auto P = primary.at(h.t);
        const auto origin = offset ? isin::offset_origin(P, N) : P;
        const isin::Ray<T> shadow{origin, light - origin};
        c.acne += bool(isin::intersect_moller_trumbore(shadow, tri)) || bool(isin::intersect_area(shadow, tri));
    }
    return c;
}

template <class T>
Count sphere_acne(T far, T r, int rays) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    const isin::Sphere<T> sp{{far, T(-0.5) * far, T(0.8) * far}, r};
    const isin::Vertex<T> eye = sp.center + isin::Vertex<T>{0, 0, T(-4) * r};
    const isin::Vertex<T> light = sp.center + isin::Vertex<T>{T(6) * r, T(6) * r, T(-6) * r};
    Count c;
    for (int i = 0; i < rays; ++i) {
        const auto aim = sp.center + isin::Vertex<T>{T(uni(rng)) * r, T(uni(rng)) * r, 0};
        const isin::Ray<T> primary{eye, isin::normalize(aim - eye)};
        const auto h = isin::intersect(primary, sp);
        if (!h) continue;
        const auto P = primary.at(h.t);
        const auto N = isin::normal_at(sp, P);
        if (isin::dot(N, light - P) <= T(0)) continue; // faces away: no shadow ray is cast
        ++c.hits;
        const auto origin = isin::offset_origin(P, N);
        c.acne += bool(isin::intersect(isin::Ray<T>{origin, light - origin}, sp));
    }
    return c;
}

} // namespace

TEST_CASE_TEMPLATE("§9 offset_origin: no shadow acne on flat triangles, 1 to 1e6 from the origin", T, float, double) {
    for (T far : {T(0), T(1), T(1e3), T(1e6)})
        for (T size : {T(1e-2), T(1), T(1e2)}) {
            if (std::is_same_v<T, float> && far > T(1e4) * size) continue; // below float's resolution
            CAPTURE(far);
            CAPTURE(size);
            const Count c = triangle_acne(far, size, true, 2000);
            CHECK(c.hits > 1900);
            CHECK(c.acne == 0);
        }
    // Without the offset the same rays do self-shadow (this is what the offset is for).
    const Count naive = triangle_acne(T(1e3), T(1), false, 2000);
    MESSAGE("shadow rays from the bare hit point, 1e3 from the origin: " << naive.acne << " of " << naive.hits
                                                                         << " hit");
    CHECK(naive.acne > 0);
}

TEST_CASE_TEMPLATE("§9 offset_origin: no shadow acne on spheres, r = 1e-2…1e4, far from the origin", T, float, double) {
    for (T far : {T(0), T(1e3), T(1e5)})
        for (T r : {T(1e-2), T(1), T(1e4)}) {
            if (std::is_same_v<T, float> && far / r > T(1e6)) continue; // below float's resolution
            CAPTURE(far);
            CAPTURE(r);
            const Count c = sphere_acne(far, r, 2000);
            CHECK(c.hits > 500);
            CHECK(c.acne == 0);
        }
}

TEST_CASE_TEMPLATE("offset_origin moves along the normal, scale-aware, finite", T, float, double) {
    const isin::Vertex<T> n{0, 1, 0};
    const auto near = isin::offset_origin(isin::Vertex<T>{0, 0, 0}, n);
    CHECK(near.y > T(0));
    CHECK(near.y < T(1e-4));
    // A point reached from a far ray origin carries that origin's rounding: it moves further.
    CHECK(isin::offset_origin(isin::Vertex<T>{0, 0, 0}, n, T(1e6)).y > T(1e6) * std::numeric_limits<T>::epsilon());
    const auto far = isin::offset_origin(isin::Vertex<T>{0, T(1e6), 0}, n);
    CHECK(far.y > T(1e6));
    CHECK(far.y - T(1e6) < T(1e6) * T(1e-3));
    const auto down = isin::offset_origin(isin::Vertex<T>{0, T(-5), 0}, n);
    CHECK(down.y > T(-5));
    const auto nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(isin::offset_origin(isin::Vertex<T>{1, 2, 3}, isin::Vertex<T>{nan, 0, 0}) == isin::Vertex<T>{1, 2, 3});
}
