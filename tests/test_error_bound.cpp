// Rounding-error bounds of hit points (pbrt-v4 §6.8): the exact surface lies within each bound.
#include <isin/error_bound.hpp>
#include <isin/sphere.hpp>
#include <isin/triangle.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <type_traits>

namespace {

using L = long double;

isin::Vertex<L> wide(const isin::Vertex<float>& a) { return {L(a.x), L(a.y), L(a.z)}; }
isin::Vertex<L> wide(const isin::Vertex<double>& a) { return {L(a.x), L(a.y), L(a.z)}; }

// Distance of p from the plane of `tri` (long double, from the exact vertices), and the largest
// distance the error box around p allows along the plane's unit normal, |n|·error.
template <class T>
void plane_distance(const isin::Triangle<T>& tri, const isin::BoundedPoint<T>& p, L& distance, L& allowed) {
    const auto n = isin::normalize(isin::cross(wide(tri.v1) - wide(tri.v0), wide(tri.v2) - wide(tri.v0)));
    distance = std::fabs(isin::dot(n, wide(p.point) - wide(tri.v0)));
    allowed = std::fabs(n.x) * L(p.error.x) + std::fabs(n.y) * L(p.error.y) + std::fabs(n.z) * L(p.error.z);
}

} // namespace

TEST_CASE_TEMPLATE("γₙ = n·u/(1 − n·u), u = ε/2 (pbrt-v4 §6.8.1)", T, float, double) {
    constexpr T u = std::numeric_limits<T>::epsilon() / T(2);
    CHECK(isin::rounding_gamma<T>(1) == u / (T(1) - u));
    CHECK(isin::rounding_gamma<T>(7) == T(7) * u / (T(1) - T(7) * u));
    CHECK(isin::rounding_gamma<T>(7) > T(7) * u);
    CHECK(isin::rounding_gamma<T>(0) == T(0));
}

TEST_CASE_TEMPLATE("hit_point on triangles: the plane lies within the bound, from 1e-3 to 1e6 in size and "
                   "distance, eyes up to 1e3 sizes away",
                   T, float, double) {
    std::mt19937_64 rng(15);
    const auto uni = [&](double lo, double hi) { return lo + (hi - lo) * double(rng() >> 11) * 0x1p-53; };
    int hits = 0, outside = 0;
    L worst = 0; // distance / allowed
    for (double size : {1e-3, 1.0, 1e3})
        for (double far : {0.0, 1e3, 1e6})
            for (double eye_distance : {3.0, 1e3}) {
                if (std::is_same_v<T, float> && far > 1e4 * size) continue; // below float's resolution
                for (int i = 0; i < 300; ++i) {
                    const isin::Vertex<double> base{far * 0.6 + uni(-1, 1) * size, -far * 0.3 + uni(-1, 1) * size,
                                                    far * 0.74 + uni(-1, 1) * size};
                    const auto corner = [&] {
                        return isin::Vertex<T>{T(base.x + uni(-1, 1) * size), T(base.y + uni(-1, 1) * size),
                                               T(base.z + uni(-1, 1) * size)};
                    };
                    const isin::Triangle<T> tri{corner(), corner(), corner()};
                    const auto N = isin::normalize(isin::normal(tri));
                    const isin::Vertex<T> centre = (tri.v0 + tri.v1 + tri.v2) / T(3);
                    const isin::Vertex<T> eye = centre + T(eye_distance * size) * N;
                    const isin::Vertex<T> aim =
                        tri.v0 + T(uni(0, 0.5)) * (tri.v1 - tri.v0) + T(uni(0, 0.5)) * (tri.v2 - tri.v0);
                    const isin::Ray<T> ray{eye, aim - eye};
                    for (const auto& h : {isin::intersect_moller_trumbore(ray, tri),
                                          isin::intersect_watertight(ray, tri), isin::intersect_area(ray, tri)}) {
                        if (!h) continue;
                        ++hits;
                        const auto p = isin::hit_point(ray, tri, h);
                        L distance, allowed;
                        plane_distance(tri, p, distance, allowed);
                        outside += !(distance <= allowed);
                        if (allowed > 0) worst = std::max(worst, distance / allowed);
                    }
                }
            }
    MESSAGE("triangle hit points: largest plane distance = " << double(worst) << " of the bound");
    CHECK(hits > 3000);
    CHECK(outside == 0);
}

TEST_CASE_TEMPLATE("hit_point on spheres: the surface lies within the bound and within surface_point_error, "
                   "eyes up to 1e3 r away",
                   T, float, double) {
    std::mt19937_64 rng(16);
    const auto uni = [&](double lo, double hi) { return lo + (hi - lo) * double(rng() >> 11) * 0x1p-53; };
    int hits = 0, outside = 0, beyond_sphere_bound = 0;
    for (double r : {1e-3, 1.0, 1e4})
        for (double far : {0.0, 1e3, 1e6})
            for (double eye_distance : {4.0, 100.0, 1e3}) {
                if (std::is_same_v<T, float> && far > 1e6 * r) continue;
                const isin::Sphere<T> sp{{T(far * 0.6), T(-far * 0.3), T(far * 0.74)}, T(r)};
                for (int i = 0; i < 300; ++i) {
                    const isin::Vertex<double> dir =
                        isin::normalize(isin::Vertex<double>{uni(-1, 1), uni(-1, 1), uni(-1, 1)});
                    const isin::Vertex<T> eye{T(double(sp.center.x) + eye_distance * r * dir.x),
                                              T(double(sp.center.y) + eye_distance * r * dir.y),
                                              T(double(sp.center.z) + eye_distance * r * dir.z)};
                    const isin::Vertex<T> aim{sp.center.x + T(uni(-0.7, 0.7) * r), sp.center.y + T(uni(-0.7, 0.7) * r),
                                              sp.center.z + T(uni(-0.7, 0.7) * r)};
                    const isin::Ray<T> ray{eye, aim - eye};
                    const auto h = isin::intersect(ray, sp);
                    if (!h) continue;
                    ++hits;
                    const auto p = isin::hit_point(ray, sp, h);
                    const auto c = wide(sp.center);
                    const auto d = wide(p.point) - c;
                    const L off = std::fabs(isin::length(d) - L(sp.radius)); // ≥ the distance to the surface
                    const auto n = isin::normalize(d);
                    const L allowed =
                        std::fabs(n.x) * L(p.error.x) + std::fabs(n.y) * L(p.error.y) + std::fabs(n.z) * L(p.error.z);
                    outside += !(off <= allowed * (1 + L(1e-3)));
                    beyond_sphere_bound += !(L(isin::max_abs(p.error)) <= L(isin::surface_point_error(sp)));
                }
            }
    CHECK(hits > 5000);
    CHECK(outside == 0);
    CHECK(beyond_sphere_bound == 0);
}

TEST_CASE_TEMPLATE("hit_point: misses and non-finite input give non-finite points, no trap", T, float, double) {
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}};
    const isin::Sphere<T> sp{{0, 0, 5}, 1};
    const auto p = isin::hit_point(ray, sp, isin::Hit<T>::miss());
    CHECK(!isin::is_finite(p.point));
    const isin::Triangle<T> tri{{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
    const auto nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(!isin::is_finite(isin::hit_point(ray, tri, isin::Hit<T>::at(1, nan, 0)).point));
    const auto q = isin::point_on_ray(ray.origin, ray.direction, T(2));
    CHECK(q.point == isin::Vertex<T>{0, 0, 2});
    CHECK(q.error.z > T(0));
}

TEST_CASE_TEMPLATE("next_float steps one ulp, as std::nextafter, through zero and at the ends", T, float, double) {
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    for (T v : {T(1), T(-1), T(0), T(-0.0), T(1e-30), T(-3.5e7), std::numeric_limits<T>::denorm_min(),
                -std::numeric_limits<T>::denorm_min(), std::numeric_limits<T>::max(), -std::numeric_limits<T>::max()}) {
        CAPTURE(v);
        CHECK(isin::next_float(v) == std::nextafter(v, inf));
        CHECK(isin::next_float(v, true) == std::nextafter(v, -inf));
    }
    CHECK(isin::next_float(inf) == inf);
    CHECK(isin::next_float(-inf, true) == -inf);
    CHECK(std::isnan(isin::next_float(nan)));
}
