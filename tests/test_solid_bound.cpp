// Solid::winding_number_bounded: the fast winding number's error bound (far-field truncation of
// Barill et al. 2018, and rounding) against the exact winding number in long double.
#include <doctest/doctest.h>
#include <isin/solid.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "support/solids.hpp"

namespace {

using LD = long double;

// The exact winding number of `mesh` at p, in long double from the same T inputs: the reference.
template <class T>
LD exact_winding(const isin::Mesh<T>& mesh, const isin::Vertex<T>& p) {
    const isin::Vertex<LD> q{LD(p.x), LD(p.y), LD(p.z)};
    LD sum = 0;
    for (std::size_t i = 0; i < mesh.size(); ++i) {
        const isin::Triangle<T> t = mesh.triangle(i);
        const auto wide = [](const isin::Vertex<T>& v) { return isin::Vertex<LD>{LD(v.x), LD(v.y), LD(v.z)}; };
        sum += isin::solid_angle(q, isin::Triangle<LD>{wide(t.v0), wide(t.v1), wide(t.v2)});
    }
    return sum / (4 * 3.14159265358979323846264338327950288L);
}

// Random points of the box [lo, hi]³, and points over random triangles of `mesh` (a random
// point of the triangle moved along its normal by ±h for each h of `heights`).
template <class T>
std::vector<isin::Vertex<T>> probe_points(const isin::Mesh<T>& mesh, double lo, double hi, int n_box, int n_near,
                                          const std::vector<double>& heights, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> box(lo, hi), unit(0, 1);
    std::vector<isin::Vertex<T>> points;
    for (int i = 0; i < n_box; ++i) points.push_back({T(box(rng)), T(box(rng)), T(box(rng))});
    std::uniform_int_distribution<std::size_t> pick(0, mesh.size() - 1);
    for (int i = 0; i < n_near; ++i) {
        const isin::Triangle<T> t = mesh.triangle(pick(rng));
        double s = unit(rng), r = unit(rng);
        if (s + r > 1) s = 1 - s, r = 1 - r;
        const auto to_d = [](const isin::Vertex<T>& v) {
            return isin::Vertex<double>{double(v.x), double(v.y), double(v.z)};
        };
        const isin::Vertex<double> v0 = to_d(t.v0), v1 = to_d(t.v1), v2 = to_d(t.v2);
        const isin::Vertex<double> on = v0 + s * (v1 - v0) + r * (v2 - v0);
        const isin::Vertex<double> n = isin::normalize(isin::cross(v1 - v0, v2 - v0));
        for (const double h : heights)
            for (const double side : {-1.0, 1.0}) {
                const isin::Vertex<double> q = on + side * h * n;
                points.push_back({T(q.x), T(q.y), T(q.z)});
            }
    }
    return points;
}

// Checks the bound on every point for each beta; returns, per beta, the sum of the truncation
// bounds over the points.
template <class T>
std::vector<double> check_bound(const isin::Mesh<T>& mesh, const std::vector<isin::Vertex<T>>& points,
                                const std::vector<T>& betas) {
    const isin::Solid<T> solid{mesh};
    std::vector<double> truncations(betas.size(), 0.0);
    std::size_t exceeded = 0, differ = 0, negative = 0;
    for (const auto& p : points) {
        const LD ref = exact_winding(mesh, p);
        for (std::size_t j = 0; j < betas.size(); ++j) {
            const isin::WindingNumber<T> w = solid.winding_number_bounded(p, betas[j]);
            const T fast = solid.winding_number(p, betas[j]);
            if (!(w.value == fast)) ++differ; // the same walk, bit for bit
            if (!(std::fabs(LD(w.value) - ref) <= LD(w.error_bound))) ++exceeded;
            if (!(w.truncation >= T(0) && w.truncation <= w.error_bound)) ++negative;
            truncations[j] += double(w.truncation);
        }
    }
    CHECK(exceeded == 0);
    CHECK(differ == 0);
    CHECK(negative == 0);
    return truncations;
}

template <class T>
void check_mesh(const isin::Mesh<T>& mesh, double lo, double hi, double diag, std::uint64_t seed) {
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    const auto points = probe_points(mesh, lo, hi, 40, 15, {1e-2 * diag, 1e-3 * diag, 1e-5 * diag}, seed);
    const std::vector<T> betas{T(1), T(1.5), T(2), T(4), T(16), inf, nan};
    const std::vector<double> truncation = check_bound(mesh, points, betas);
    // The truncation bound falls as beta grows, and is 0 for an exact sum.
    CHECK(truncation[4] < truncation[2]);
    CHECK(truncation[3] < truncation[2]);
    CHECK(truncation[5] == 0.0);
    CHECK(truncation[6] == 0.0);
}

} // namespace

TEST_CASE_TEMPLATE("Barill 2018 bound: |fast − exact| ≤ error_bound on closed, holed, overlapping meshes", T, float,
                   double) {
    const auto sphere = solids::icosphere<T>(3, {0.3, -0.2, 0.1}, 1.0);
    SUBCASE("closed icosphere") { check_mesh(sphere, -1.2, 1.4, 2 * std::sqrt(3.0), 11); }
    SUBCASE("the same with 2% of its triangles removed") {
        check_mesh(solids::with_holes(sphere, 0.02), -1.2, 1.4, 2 * std::sqrt(3.0), 12);
    }
    SUBCASE("two overlapping icospheres as one mesh") {
        const auto both =
            solids::merged(solids::icosphere<T>(3, {0, 0, 0}, 1.0), solids::icosphere<T>(3, {0.8, 0, 0}, 1.0));
        check_mesh(both, -1.3, 2.1, 3.3, 13);
    }
    SUBCASE("a closed box 100 × 0.01 × 0.01: sliver triangles") {
        isin::Mesh<T> box = solids::lattice_cube<T>(1);
        for (auto& v : box.positions) v = isin::Vertex<T>{v.x * T(100), v.y * T(0.01), v.z * T(0.01)};
        check_mesh(box, -1.0, 101.0, 100.0, 15);
    }
    SUBCASE("a lattice cube 10^3 from the origin") {
        isin::Mesh<T> cube = solids::lattice_cube<T>(4);
        for (auto& v : cube.positions) v = v + isin::Vertex<T>{T(1000), T(-1000), T(1000)};
        check_mesh(cube, 999.5, 1004.5, 4 * std::sqrt(3.0), 14);
    }
}

TEST_CASE_TEMPLATE("Barill 2018 bound: nearly attained by two opposite facets, where the dipole is 0", T, float,
                   double) {
    // Two small facets with opposite normals at z = ±1 form one cluster whose area vectors cancel:
    // its dipole is 0, while the facets subtend ≈ s·(1/(d−1)² − 1/(d+1)²) from p = (0, 0, −d).
    // The bound A·(1/(d−r)² − 1/d²) (A = 2s, r ≈ 1) is then within 1/0.7 of the error.
    const T e = T(0.01);
    const isin::Mesh<T> pair = isin::Mesh<T>::from_triangles(std::vector<isin::Triangle<T>>{
        {{-e, -e, T(1)}, {e, -e, T(1)}, {0, e, T(1)}}, {{-e, -e, T(-1)}, {0, e, T(-1)}, {e, -e, T(-1)}}});
    const isin::Solid<T> solid{pair};
    const isin::Vertex<T> p{0, 0, T(-4)};
    const isin::WindingNumber<T> w = solid.winding_number_bounded(p, T(2));
    const LD ref = exact_winding(pair, p);
    const LD actual = std::fabs(LD(w.value) - ref);
    CHECK(std::fabs(double(w.value)) < 1e-12); // the cluster's dipole: Σ area vectors = 0
    CHECK(actual <= LD(w.error_bound));
    CHECK(actual > LD(0.7) * LD(w.error_bound)); // a bound half as large would be wrong here
    // Exact (beta = +∞): no truncation, the rounding alone.
    const isin::WindingNumber<T> exact = solid.winding_number_bounded(p, std::numeric_limits<T>::infinity());
    CHECK(exact.truncation == 0);
    CHECK(std::fabs(LD(exact.value) - ref) <= LD(exact.error_bound));
    CHECK(exact.error_bound < w.error_bound);
}

TEST_CASE_TEMPLATE("Barill 2018 bound: NaN and infinite points, empty solid, beta below 1", T, float, double) {
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    const isin::Solid<T> solid{solids::icosphere<T>(2)};
    for (const isin::Vertex<T> p : {isin::Vertex<T>{nan, 0, 0}, isin::Vertex<T>{0, inf, 0}}) {
        const isin::WindingNumber<T> w = solid.winding_number_bounded(p);
        CHECK(std::isnan(w.value));
        CHECK(w.error_bound == inf);
    }
    // beta below 1 counts as 1; the bound still holds (possibly +∞ where a ball nearly reaches p).
    const isin::Vertex<T> p{T(0.2), T(0.1), T(-0.3)};
    const isin::WindingNumber<T> low = solid.winding_number_bounded(p, T(0.25));
    const isin::WindingNumber<T> one = solid.winding_number_bounded(p, T(1));
    CHECK(low.value == one.value);
    CHECK(low.error_bound == one.error_bound);
    const isin::WindingNumber<T> none = isin::Solid<T>{isin::Mesh<T>{}}.winding_number_bounded(p);
    CHECK(none.value == 0);
    CHECK(none.error_bound == 0);
    CHECK(none.truncation == 0);
}
