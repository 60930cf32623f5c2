// Affine transforms for placed meshes: composition, inverse, normals, mirroring.
#include <isin/transform.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <cmath>
#include <random>

namespace {

template <class T>
void check_near(const isin::Vertex<T>& a, const isin::Vertex<T>& b, double eps = 1e-5) {
    CHECK(double(a.x) == approx(double(b.x)).epsilon(eps).scale(1));
    CHECK(double(a.y) == approx(double(b.y)).epsilon(eps).scale(1));
    CHECK(double(a.z) == approx(double(b.z)).epsilon(eps).scale(1));
}

} // namespace

TEST_CASE_TEMPLATE("Transform: translation, scaling, rotation and their composition (inner first)", T, float, double) {
    using X = isin::Transform<T>;
    const T quarter = T(std::acos(-1.0) / 2);
    check_near(X::rotation({0, 1, 0}, quarter).vector({0, 0, 1}), isin::Vertex<T>{1, 0, 0}); // +Z → +X about +Y
    check_near(X::rotation({0, 0, 3}, quarter).vector({1, 0, 0}), isin::Vertex<T>{0, 1, 0}); // axis length ignored
    const X place = X::translation({1, 2, 3}) * X::rotation({0, 1, 0}, quarter) * X::scaling({2, 3, 4});
    check_near(place.point({1, 1, 1}), isin::Vertex<T>{1 + 4, 2 + 3, 3 - 2}); // scaled (2,3,4), turned (4,3,−2), moved
    check_near(place.vector({1, 0, 0}), isin::Vertex<T>{0, 0, -2});           // directions are not moved
    CHECK(X::identity().is_identity());
    CHECK_FALSE(place.is_identity());
    CHECK(double(place.determinant()) == approx(24.0).epsilon(1e-5));
    CHECK(double(X::scaling({-1, 1, 1}).determinant()) == approx(-1.0));
}

TEST_CASE_TEMPLATE("Transform: the inverse undoes it; normals go by the inverse transpose and stay perpendicular", T,
                   float, double) {
    using X = isin::Transform<T>;
    const X m = X::translation({5, -1, 2}) * X::rotation({1, 2, 3}, T(0.7)) * X::scaling({2, T(0.5), 3});
    const X inv = m.inverse();
    check_near(inv.point(m.point({T(0.3), T(-2), T(7)})), isin::Vertex<T>{T(0.3), T(-2), T(7)}, 1e-4);
    check_near((m * inv).point({1, 2, 3}), isin::Vertex<T>{1, 2, 3}, 1e-4);
    // A plane through the origin with normal n holds e1, e2; after the transform, M·e1 and M·e2
    // are perpendicular to the moved normal (M⁻¹)ᵀ·n.
    const isin::Vertex<T> e1{1, 0, 0}, e2{0, 1, 1}, n = isin::cross(e1, e2);
    const isin::Vertex<T> moved = X::normal(inv, n);
    CHECK(double(isin::dot(moved, m.vector(e1))) == approx(0.0).scale(1).epsilon(1e-4));
    CHECK(double(isin::dot(moved, m.vector(e2))) == approx(0.0).scale(1).epsilon(1e-4));
    // A flat transform has no inverse: every entry is then non-finite.
    CHECK_FALSE(std::isfinite(X::scaling({1, 0, 1}).inverse().m[0][0]));
}

TEST_CASE_TEMPLATE("bounded_point: the exact image of every point of the error box lies within the new bound", T, float,
                   double) {
    using L = long double;
    std::mt19937_64 rng(42);
    const auto uni = [&](double lo, double hi) { return lo + (hi - lo) * double(rng() >> 11) * 0x1p-53; };
    int outside = 0;
    for (int i = 0; i < 2000; ++i) {
        const auto place = isin::Transform<T>::translation({T(uni(-1e3, 1e3)), T(uni(-1e3, 1e3)), T(uni(-1e3, 1e3))}) *
                           isin::Transform<T>::rotation({T(uni(-1, 1)), T(uni(-1, 1)), T(1)}, T(uni(0, 6))) *
                           isin::Transform<T>::scaling({T(uni(0.1, 10)), T(uni(0.1, 10)), T(uni(-10, -0.1))});
        const isin::BoundedPoint<T> p{{T(uni(-50, 50)), T(uni(-50, 50)), T(uni(-50, 50))},
                                      {T(uni(0, 1e-3)), T(uni(0, 1e-3)), T(0)}};
        const auto q = place.bounded_point(p);
        // A corner of p's box, mapped exactly (long double from the transform's own entries).
        for (int c = 0; c < 4; ++c) {
            const L x[3] = {L(p.point.x) + ((c & 1) ? L(p.error.x) : -L(p.error.x)),
                            L(p.point.y) + ((c & 2) ? L(p.error.y) : -L(p.error.y)), L(p.point.z)};
            for (int r = 0; r < 3; ++r) {
                const L exact = L(place.m[r][0]) * x[0] + L(place.m[r][1]) * x[1] + L(place.m[r][2]) * x[2] +
                                L(isin::component(place.d, r));
                outside += !(std::fabs(exact - L(isin::component(q.point, r))) <= L(isin::component(q.error, r)));
            }
        }
    }
    CHECK(outside == 0);
}
