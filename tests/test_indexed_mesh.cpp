// Computed vertex normals (isin::compute_normals): angle weighting after Thürmer & Wüthrich 1998,
// "Computing vertex normals from polygonal facets", on the side of the §2 face normal, and the
// vertex copies made at creases sharper than the crease angle.
#include <isin/indexed_mesh.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/solids.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

/// Tolerance for a unit normal (float: each face worked out in double, the sums in float).
template <class T>
double tol() {
    return sizeof(T) < sizeof(double) ? 1e-6 : 1e-12;
}

template <class T>
void check_near(const isin::Vertex<T>& got, const isin::Vertex<T>& want, double eps = tol<T>()) {
    CHECK(got.x == approx(want.x).epsilon(eps));
    CHECK(got.y == approx(want.y).epsilon(eps));
    CHECK(got.z == approx(want.z).epsilon(eps));
}

/// A vector worked out in double, in T.
template <class T>
isin::Vertex<T> in(const isin::Vertex<double>& a) {
    return {T(a.x), T(a.y), T(a.z)};
}

/// The §2 unit face normal N / |N| of triangle i.
template <class T>
isin::Vertex<T> unit_face_normal(const isin::Mesh<T>& mesh, std::size_t i) {
    return isin::normalize(isin::normal(mesh.triangle(i)));
}

/// Swaps V1 and V2 where N = (V1−V0) × (V2−V0) points towards `inside` (the solid's centre or axis).
template <class T>
void orient_outward(isin::Mesh<T>& mesh, const isin::Vertex<T>& inside) {
    for (std::size_t i = 0; i < mesh.size(); ++i) {
        const auto tri = mesh.triangle(i);
        const auto centroid = (tri.v0 + tri.v1 + tri.v2) / T(3);
        if (isin::dot(isin::normal(tri), centroid - inside) < T(0)) std::swap(mesh.indices[i][1], mesh.indices[i][2]);
    }
}

/// The cube [−1, 1]³ by index: 8 vertices (bit 0: x > 0, bit 1: y > 0, bit 2: z > 0), 12 triangles,
/// front faces outside. Each square is cut along the same diagonal, so some corners of a face touch
/// two of its triangles (45° each) and others one (90°): area weighting would tilt, angle weighting not.
template <class T>
isin::Mesh<T> cube() {
    isin::Mesh<T> mesh;
    for (std::uint32_t k = 0; k < 8; ++k)
        mesh.positions.push_back({k & 1 ? T(1) : T(-1), k & 2 ? T(1) : T(-1), k & 4 ? T(1) : T(-1)});
    for (std::uint32_t axis = 0; axis < 3; ++axis)
        for (std::uint32_t side = 0; side < 2; ++side) {
            const std::uint32_t a = 1u << ((axis + 1) % 3), b = 1u << ((axis + 2) % 3), s = side << axis;
            const std::uint32_t q0 = s, q1 = s | a, q2 = s | a | b, q3 = s | b; // a cycle round the square
            mesh.indices.push_back({q0, q1, q2});
            mesh.indices.push_back({q0, q2, q3});
        }
    orient_outward(mesh, {T(0), T(0), T(0)});
    return mesh;
}

/// An icosphere of radius 1 round the origin by index (each vertex once), front faces outside.
template <class T>
isin::Mesh<T> icosphere(int levels) {
    return solids::icosphere<T>(levels);
}

template <class T>
bool all_finite(const std::vector<isin::Vertex<T>>& normals) {
    for (const auto& n : normals)
        if (!isin::is_finite(n)) return false;
    return true;
}

} // namespace

TEST_CASE_TEMPLATE("T&W: a single triangle's vertex normals are its §2 unit normal N / |N|", T, float, double) {
    isin::Mesh<T> mesh; // §4 example 4a's triangle
    mesh.positions = {{0, 40, 120}, {30, -40, 60}, {-30, -40, 60}};
    mesh.indices = {{0, 1, 2}};
    isin::compute_normals(mesh);
    REQUIRE(mesh.normals.size() == 3);
    CHECK(mesh.positions.size() == 3);
    for (const auto& n : mesh.normals) check_near(n, unit_face_normal(mesh, 0));
    // §2: N = (V1−V0) × (V2−V0) = (0, 3600, −4800), |N| = 6000 (§4 example 4a: unit N, D = 72), towards the eye.
    check_near(mesh.normals[0], isin::Vertex<T>{T(0), T(0.6), T(-0.8)});
    CHECK_NOTHROW(mesh.validate());
}

TEST_CASE_TEMPLATE("T&W: a flat quad (clockwise from the eye) has the normal (0, 0, −1) everywhere", T, float, double) {
    for (const T crease : {T(0), T(60), T(180)}) {
        CAPTURE(crease);
        isin::Mesh<T> quad; // the example at the top of indexed_mesh.hpp
        quad.positions = {{0, 0, 5}, {1, 0, 5}, {0, 1, 5}, {1, 1, 5}};
        quad.indices = {{0, 2, 1}, {1, 2, 3}};
        isin::compute_normals(quad, crease);
        CHECK(quad.positions.size() == 4); // coplanar faces stay together even at 0°
        REQUIRE(quad.normals.size() == 4);
        for (const auto& n : quad.normals) check_near(n, isin::Vertex<T>{T(0), T(0), T(-1)});
    }
}

TEST_CASE_TEMPLATE("Crease 60°: a cube stays faceted, 24 vertices, each normal its face's", T, float, double) {
    isin::Mesh<T> mesh = cube<T>();
    const auto corners = mesh.positions;
    isin::compute_normals(mesh, T(60));
    CHECK_NOTHROW(mesh.validate());
    CHECK(mesh.size() == 12);
    REQUIRE(mesh.positions.size() == 24);
    REQUIRE(mesh.normals.size() == 24);
    for (std::size_t i = 0; i < mesh.size(); ++i)
        for (const std::uint32_t k : mesh.indices[i]) CHECK(mesh.normals[k] == unit_face_normal(mesh, i));
    for (const auto& corner : corners) { // each corner three times (three faces)
        int copies = 0;
        for (const auto& p : mesh.positions) copies += p == corner ? 1 : 0;
        CHECK(copies == 3);
    }
    for (std::size_t k = 0; k < 8; ++k) CHECK(mesh.positions[k] == corners[k]); // originals keep their index
}

TEST_CASE_TEMPLATE("Crease 180°: a cube's 8 normals lie on the diagonals, (±1, ±1, ±1) / √3", T, float, double) {
    // T&W: each face adds α·n̂ with α = 90° in all, whether from one triangle (90°) or two (45° + 45°);
    // area weighting would count the faces cut at that corner twice.
    isin::Mesh<T> mesh = cube<T>();
    isin::compute_normals(mesh, T(180));
    CHECK_NOTHROW(mesh.validate());
    REQUIRE(mesh.positions.size() == 8);
    REQUIRE(mesh.normals.size() == 8);
    const T s = T(1) / std::sqrt(T(3));
    for (std::size_t k = 0; k < 8; ++k) {
        const auto& n = mesh.normals[k];
        CHECK(std::fabs(n.x) == std::fabs(n.y)); // exactly: π/4 + π/4 = π/2 in floating point
        CHECK(std::fabs(n.y) == std::fabs(n.z));
        check_near(n, mesh.positions[k] * s); // outwards, on the side of the faces' §2 normals
    }
}

TEST_CASE_TEMPLATE("T&W vs area weighting: a 90° ridge between a 90° and a 45° corner", T, float, double) {
    // P = (0,0,0) has 90° in face PAB (n̂ = +z) and 45° in face PBC (n̂ = +x):
    // T&W: (π/2)(0,0,1) + (π/4)(1,0,0) ∝ (1, 0, 2) / √5; area weighting (both areas ½) would give (1, 0, 1) / √2.
    // B = (0,1,0) has 45° in PAB and 90° in PBC: (2, 0, 1) / √5.
    const auto ridge = [] {
        isin::Mesh<T> mesh;
        mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 1, 1}}; // P, A, B, C
        mesh.indices = {{0, 1, 2}, {0, 2, 3}};
        return mesh;
    };
    const T r5 = std::sqrt(T(5));
    for (const T crease : {T(100), T(180)}) { // 100°: through the fans; 180°: no fans
        CAPTURE(crease);
        isin::Mesh<T> mesh = ridge();
        check_near(unit_face_normal(mesh, 0), isin::Vertex<T>{T(0), T(0), T(1)});
        check_near(unit_face_normal(mesh, 1), isin::Vertex<T>{T(1), T(0), T(0)});
        isin::compute_normals(mesh, crease);
        REQUIRE(mesh.positions.size() == 4);
        check_near(mesh.normals[0], isin::Vertex<T>{T(1) / r5, T(0), T(2) / r5});
        check_near(mesh.normals[1], isin::Vertex<T>{T(0), T(0), T(1)});
        check_near(mesh.normals[2], isin::Vertex<T>{T(2) / r5, T(0), T(1) / r5});
        check_near(mesh.normals[3], isin::Vertex<T>{T(1), T(0), T(0)});
    }
    isin::Mesh<T> mesh = ridge();
    isin::compute_normals(mesh, T(60)); // 90° > 60°: P and B get a copy each
    CHECK_NOTHROW(mesh.validate());
    REQUIRE(mesh.positions.size() == 6);
    for (std::size_t i = 0; i < mesh.size(); ++i)
        for (const std::uint32_t k : mesh.indices[i]) CHECK(mesh.normals[k] == unit_face_normal(mesh, i));
    CHECK(mesh.indices[0] == std::array<std::uint32_t, 3>{0, 1, 2}); // the first face keeps the originals
    CHECK(mesh.indices[1] == std::array<std::uint32_t, 3>{4, 5, 3}); // copies of P and B, in vertex order
    CHECK(mesh.positions[4] == mesh.positions[0]);
    CHECK(mesh.positions[5] == mesh.positions[2]);
}

TEST_CASE_TEMPLATE("Crease 60°: a fine icosphere stays one smooth surface, normals near radial", T, float, double) {
    isin::Mesh<T> mesh = icosphere<T>(3); // 1280 triangles, 642 vertices
    REQUIRE(mesh.size() == 1280);
    isin::compute_normals(mesh);
    CHECK(mesh.positions.size() == 642);
    REQUIRE(mesh.normals.size() == 642);
    for (std::size_t k = 0; k < 642; ++k) {
        CHECK(isin::length(mesh.normals[k]) == approx(T(1)).epsilon(tol<T>()));
        CHECK(isin::dot(mesh.normals[k], mesh.positions[k]) > T(0.9999)); // outwards, within 0.8°
    }
    isin::Mesh<T> smooth = icosphere<T>(3);
    isin::compute_normals(smooth, T(180)); // the path without fans sums in the same order
    CHECK(smooth.normals == mesh.normals);
}

TEST_CASE_TEMPLATE("Crease 60°: a cone's apex stays one vertex though its faces span 120° (creases are edges)", T,
                   float, double) {
    // VRML97 creaseAngle: adjacent faces (15° apart here) smooth into each other; faces that meet only at
    // the apex are not compared, so the apex is not cut along an arbitrary line.
    const std::uint32_t n = 24;
    const double half_angle = 3.14159265358979323846 / 6; // 30°: opposite faces differ by 120°
    isin::Mesh<T> mesh;
    mesh.positions.push_back({T(0), T(1.0 / std::tan(half_angle)), T(0)}); // apex above the unit rim
    for (std::uint32_t i = 0; i < n; ++i) {
        const double phi = 2 * 3.14159265358979323846 * i / n;
        mesh.positions.push_back({T(std::cos(phi)), T(0), T(std::sin(phi))});
    }
    for (std::uint32_t i = 0; i < n; ++i) mesh.indices.push_back({0, 1 + i, 1 + (i + 1) % n});
    for (std::size_t i = 0; i < mesh.size(); ++i) { // outwards from the axis
        const auto tri = mesh.triangle(i);
        const auto c = (tri.v0 + tri.v1 + tri.v2) / T(3);
        if (isin::dot(isin::normal(tri), isin::Vertex<T>{c.x, T(0), c.z}) < T(0))
            std::swap(mesh.indices[i][1], mesh.indices[i][2]);
    }
    isin::compute_normals(mesh, T(60));
    CHECK_NOTHROW(mesh.validate());
    CHECK(mesh.positions.size() == std::size_t(n + 1));
    check_near(mesh.normals[0], isin::Vertex<T>{T(0), T(1), T(0)}); // by symmetry: the axis
    isin::compute_normals(mesh, T(10)); // 15° apart: every edge a crease, the apex one copy per face
    CHECK(mesh.positions.size() == std::size_t(n + 1 + (n - 1) + n));
}

TEST_CASE_TEMPLATE("Crease 60°: coplanar fans that meet only at a vertex (a bowtie) agree, so they merge", T, float,
                   double) {
    // Two half-disc fans of m triangles round vertex 0, both N = +z, sharing no edge there.
    for (const std::uint32_t m : {1u, 9u}) {
        CAPTURE(m);
        isin::Mesh<T> mesh;
        mesh.positions.push_back({T(0), T(0), T(0)});
        for (std::uint32_t half = 0; half < 2; ++half) {
            const auto first = static_cast<std::uint32_t>(mesh.positions.size());
            for (std::uint32_t i = 0; i <= m; ++i) {
                const double phi = 3.14159265358979323846 * (half + (0.05 + 0.9 * i / m));
                mesh.positions.push_back({T(std::cos(phi)), T(std::sin(phi)), T(0)});
            }
            for (std::uint32_t i = 0; i < m; ++i) mesh.indices.push_back({0, first + i, first + i + 1});
        }
        const std::size_t n = mesh.positions.size();
        for (std::size_t i = 0; i < mesh.size(); ++i) CHECK(unit_face_normal(mesh, i) == isin::Vertex<T>{0, 0, 1});
        const auto indices = mesh.indices;
        isin::compute_normals(mesh, T(60));
        CHECK_NOTHROW(mesh.validate());
        CHECK(mesh.positions.size() == n);
        CHECK(mesh.indices == indices);
        for (const auto& normal : mesh.normals) CHECK(normal == isin::Vertex<T>{T(0), T(0), T(1)});
    }
}

TEST_CASE_TEMPLATE("Crease 60°: a bowtie 30° apart merges into the angle-weighted mean; at 20° it splits", T, float,
                   double) {
    // Triangle A: 90° at vertex 0, n̂ = +z; triangle B: 90° at vertex 0, n̂ = (sin 30°, 0, cos 30°); no
    // shared edge. Merged, T&W gives (π/2)·n̂A + (π/2)·n̂B ∝ (sin 15°, 0, cos 15°).
    const T s30 = T(0.5), c30 = std::sqrt(T(3)) / T(2);
    const auto bowtie = [&] {
        isin::Mesh<T> mesh;
        mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-c30, 0, s30}, {0, -1, 0}};
        mesh.indices = {{0, 1, 2}, {0, 3, 4}};
        return mesh;
    };
    isin::Mesh<T> mesh = bowtie();
    check_near(unit_face_normal(mesh, 1), isin::Vertex<T>{s30, T(0), c30});
    isin::compute_normals(mesh, T(60));
    CHECK_NOTHROW(mesh.validate());
    CHECK(mesh.positions.size() == 5);
    CHECK(mesh.indices == bowtie().indices);
    const double r15 = 15 * 3.14159265358979323846 / 180;
    check_near(mesh.normals[0], isin::Vertex<T>{T(std::sin(r15)), T(0), T(std::cos(r15))});
    mesh = bowtie();
    isin::compute_normals(mesh, T(20));
    CHECK(mesh.positions.size() == 6);
    check_near(mesh.normals[0], isin::Vertex<T>{T(0), T(0), T(1)});
    check_near(mesh.normals[5], isin::Vertex<T>{s30, T(0), c30});
}

TEST_CASE_TEMPLATE("Crease 60°: two folded fans touching at a vertex stay apart though two of their faces agree", T,
                   float, double) {
    // Fan F: f1 (80° at vertex 0, n̂ at ψ = −50° in the xz plane) folds along +y onto f (10°, ψ = 0°);
    // fan G: g (10°, ψ = 5°) folds along −y onto g1 (80°, ψ = 55°). Each fold is 50° < 60°, F and G share
    // no edge; f and g agree within 5°, but F ∝ 80°·n̂(−50°) + 10°·n̂(0°) and G ∝ 10°·n̂(5°) + 80°·n̂(55°)
    // lie 94.87° apart: vertex 0 gets one copy. s = 8 cuts each 80° wedge into 8 triangles: 18 corners at
    // vertex 0, past detail::small_fan, so the shared edges are found by sorting.
    const double deg = 3.14159265358979323846 / 180;
    const auto n_hat = [](double psi) { return isin::Vertex<double>{std::sin(psi), 0, std::cos(psi)}; };
    const auto u = [](double psi) { return isin::Vertex<double>{std::cos(psi), 0, -std::sin(psi)}; };
    const isin::Vertex<double> y{0, 1, 0};
    for (const std::uint32_t s : {1u, 8u}) {
        CAPTURE(s);
        isin::Mesh<T> mesh;
        const auto add = [&](const isin::Vertex<double>& p) {
            mesh.positions.push_back({T(p.x), T(p.y), T(p.z)});
            return static_cast<std::uint32_t>(mesh.positions.size() - 1);
        };
        const std::uint32_t o = add({0, 0, 0}), b = add(y), e = add(-1.0 * y);
        // f1: from b, 80° towards +u(−50°), as s triangles (0, a_i+1, a_i) with a_0 = b.
        std::uint32_t prev = b;
        for (std::uint32_t i = 1; i <= s; ++i) {
            const double t = 80 * deg * i / s;
            const std::uint32_t a = add(std::cos(t) * y + std::sin(t) * u(-50 * deg));
            mesh.indices.push_back({o, a, prev});
            prev = a;
        }
        mesh.indices.push_back({o, b, add(std::cos(10 * deg) * y - std::sin(10 * deg) * u(0))});        // f
        mesh.indices.push_back({o, add(-std::cos(10 * deg) * y - std::sin(10 * deg) * u(5 * deg)), e}); // g
        prev = e;
        for (std::uint32_t i = 1; i <= s; ++i) { // g1: from e, 80° towards +u(55°)
            const double t = 80 * deg * i / s;
            const std::uint32_t h = add(-std::cos(t) * y + std::sin(t) * u(55 * deg));
            mesh.indices.push_back({o, prev, h});
            prev = h;
        }
        const std::size_t n = mesh.positions.size();
        const double eps = sizeof(T) < sizeof(double) ? 1e-5 : 1e-12; // positions rounded to float
        for (std::size_t i = 0; i < s; ++i) check_near(unit_face_normal(mesh, i), in<T>(n_hat(-50 * deg)), eps);
        check_near(unit_face_normal(mesh, s), in<T>(n_hat(0)), eps);
        check_near(unit_face_normal(mesh, s + 1), in<T>(n_hat(5 * deg)), eps);
        for (std::size_t i = s + 2; i < mesh.size(); ++i)
            check_near(unit_face_normal(mesh, i), in<T>(n_hat(55 * deg)), eps);

        isin::compute_normals(mesh, T(60));
        CHECK_NOTHROW(mesh.validate());
        REQUIRE(mesh.positions.size() == n + 1);
        for (std::size_t i = 0; i < mesh.size(); ++i) CHECK(mesh.indices[i][0] == (i <= s ? o : n));
        const auto F = isin::normalize(80 * deg * n_hat(-50 * deg) + 10 * deg * n_hat(0));
        const auto G = isin::normalize(10 * deg * n_hat(5 * deg) + 80 * deg * n_hat(55 * deg));
        check_near(mesh.normals[o], in<T>(F), eps);
        check_near(mesh.normals[n], in<T>(G), eps);
        CHECK(std::acos(double(isin::dot(mesh.normals[o], mesh.normals[n]))) / deg ==
              doctest::Approx(94.8698).epsilon(1e-5));
    }
}

TEST_CASE_TEMPLATE("Crease 0°: coplanar faces of a tilted plane stay together despite rounding", T, float, double) {
    // A fan of 12 triangles round (0.3, 0.7, ·) in the plane x + 2y + 3z = 1: the unit normals agree only
    // to rounding, which the few-ulp slack of the crease test absorbs.
    isin::Mesh<T> mesh;
    const auto on_plane = [](double x, double y) { return isin::Vertex<T>{T(x), T(y), T((1 - x - 2 * y) / 3)}; };
    mesh.positions.push_back(on_plane(0.3, 0.7));
    const std::uint32_t n = 12;
    for (std::uint32_t i = 0; i < n; ++i) {
        const double phi = 2 * 3.14159265358979323846 * i / n, r = 0.37 + 0.11 * (i % 3);
        mesh.positions.push_back(on_plane(0.3 + r * std::cos(phi), 0.7 + r * std::sin(phi)));
        mesh.indices.push_back({0, 1 + i, 1 + (i + 1) % n});
    }
    isin::compute_normals(mesh, T(0));
    CHECK(mesh.positions.size() == n + 1);
    const T r14 = std::sqrt(T(14));
    for (const auto& normal : mesh.normals) check_near(normal, isin::Vertex<T>{T(1) / r14, T(2) / r14, T(3) / r14});
}

TEST_CASE_TEMPLATE("Crease split copies uvs and colours, keeps material ids; validate passes", T, float, double) {
    isin::Mesh<T> mesh = cube<T>();
    const auto uv_of = [](const isin::Vertex<T>& p) { return std::array<T, 2>{p.x + T(2) * p.y, p.z}; };
    const auto color_of = [](const isin::Vertex<T>& p) {
        return isin::Color<T>{(p.x + T(1)) / T(2), (p.y + T(1)) / T(4), (p.z + T(1)) / T(8)};
    };
    for (const auto& p : mesh.positions) mesh.uvs.push_back(uv_of(p)), mesh.colors.push_back(color_of(p));
    for (std::uint32_t i = 0; i < 12; ++i) mesh.material.push_back(i / 2);
    mesh.normals = {{T(1), T(0), T(0)}}; // stale and of the wrong length: replaced
    isin::compute_normals(mesh);
    CHECK_NOTHROW(mesh.validate());
    REQUIRE(mesh.positions.size() == 24);
    REQUIRE(mesh.uvs.size() == 24);
    REQUIRE(mesh.colors.size() == 24);
    REQUIRE(mesh.normals.size() == 24);
    for (std::size_t k = 0; k < 24; ++k) {
        CHECK(mesh.uvs[k] == uv_of(mesh.positions[k]));
        const auto c = mesh.colors[k], want = color_of(mesh.positions[k]);
        CHECK((c.r == want.r && c.g == want.g && c.b == want.b));
    }
    for (std::uint32_t i = 0; i < 12; ++i) CHECK(mesh.material[i] == i / 2);
}

TEST_CASE_TEMPLATE("Degenerate and NaN triangles contribute nothing: no NaN, zero where no valid face", T, float,
                   double) {
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    for (const T crease : {T(60), T(180)}) {
        CAPTURE(crease);
        isin::Mesh<T> mesh;
        mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {nan, 0, 0}, {inf, 1, 0}, {5, 5, 5}};
        mesh.indices = {{0, 1, 2},           // the one valid face: N = +z
                        {0, 1, 3},           // collinear: zero area
                        {0, 0, 2},           // a repeated vertex
                        {1, 2, 4},           // NaN
                        {2, 1, 5}};          // infinity
        isin::compute_normals(mesh, crease); // vertex 6: in no face
        CHECK_NOTHROW(mesh.validate());
        CHECK(mesh.positions.size() == 7); // degenerate corners never split a vertex
        REQUIRE(mesh.normals.size() == 7);
        CHECK(all_finite(mesh.normals));
        for (std::size_t k = 0; k < 3; ++k) CHECK(mesh.normals[k] == isin::Vertex<T>{T(0), T(0), T(1)});
        for (std::size_t k = 3; k < 7; ++k) CHECK(mesh.normals[k] == isin::Vertex<T>{T(0), T(0), T(0)});
    }
    // Finite but huge: |N| overflows for double (the face then counts as degenerate), not for float
    // (its corners are computed in double).
    const T M = std::numeric_limits<T>::max() / T(2);
    for (const T crease : {T(60), T(180)}) {
        CAPTURE(crease);
        isin::Mesh<T> huge; // a flat quad in the plane x + y + z = M
        huge.positions = {{M, 0, 0}, {0, M, 0}, {0, 0, M}, {M, M, -M}};
        huge.indices = {{0, 1, 2}, {1, 0, 3}};
        isin::compute_normals(huge, crease);
        CHECK(huge.positions.size() == 4);
        REQUIRE(huge.normals.size() == 4);
        CHECK(all_finite(huge.normals));
        const T expected = sizeof(T) < sizeof(double) ? T(1) : T(0);
        for (const auto& n : huge.normals) CHECK(isin::length(n) == approx(expected).epsilon(tol<T>()));
    }
}

TEST_CASE_TEMPLATE("Stability: tiny (1e-25) and huge (1e25) triangles get normals (float faces computed in double)", T,
                   float, double) {
    for (const T scale : {T(1e-25), T(1e25)}) {
        CAPTURE(scale);
        isin::Mesh<T> mesh;
        mesh.positions = {{0, 0, 0}, {scale, 0, 0}, {0, scale, 0}, {scale, scale, scale}};
        mesh.indices = {{0, 1, 2}, {2, 1, 3}};
        isin::compute_normals(mesh, T(180));
        REQUIRE(mesh.normals.size() == 4);
        for (const auto& n : mesh.normals) CHECK(isin::length(n) == approx(T(1)).epsilon(tol<T>()));
        CHECK(mesh.normals[0] == isin::Vertex<T>{T(0), T(0), T(1)});
    }
}

TEST_CASE_TEMPLATE("A mesh with no triangles: every vertex gets a zero normal", T, float, double) {
    for (const T crease : {T(60), T(180)}) {
        isin::Mesh<T> empty;
        isin::compute_normals(empty, crease);
        CHECK(empty.normals.empty());
        CHECK_NOTHROW(empty.validate());
        isin::Mesh<T> points;
        points.positions = {{1, 2, 3}, {4, 5, 6}};
        isin::compute_normals(points, crease);
        REQUIRE(points.normals.size() == 2);
        for (const auto& n : points.normals) CHECK(n == isin::Vertex<T>{T(0), T(0), T(0)});
    }
}

TEST_CASE_TEMPLATE("An invalid mesh or a NaN angle throws and leaves the mesh as it was", T, float, double) {
    isin::Mesh<T> mesh = cube<T>();
    mesh.normals = {{T(1), T(0), T(0)}};
    mesh.indices.push_back({0, 1, 8}); // vertex 8 of 8
    const auto before = mesh.indices;
    CHECK_THROWS_AS(isin::compute_normals(mesh), std::invalid_argument);
    CHECK(mesh.indices == before);
    CHECK(mesh.positions.size() == 8);
    CHECK(mesh.normals.size() == 1);
    mesh.indices.pop_back();
    mesh.uvs = {{T(0), T(0)}}; // one uv for eight vertices
    CHECK_THROWS_AS(isin::compute_normals(mesh), std::invalid_argument);
    mesh.uvs.clear();
    CHECK_THROWS_AS(isin::compute_normals(mesh, std::numeric_limits<T>::quiet_NaN()), std::invalid_argument);
    CHECK(mesh.normals.size() == 1);
}

TEST_CASE("compute_normals: a float mesh takes a double angle (the angle is not deduced)") {
    isin::Meshf mesh = cube<float>();
    isin::compute_normals(mesh, 30.0);
    CHECK(mesh.positions.size() == 24);
    isin::Meshd meshd = cube<double>();
    isin::compute_normals(meshd, 200.0);
    CHECK(meshd.positions.size() == 8);
}
