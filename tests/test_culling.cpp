// Note §11: backface culling by dot product (method 1) and by projected cross product (method 2).
#include <isin/camera.hpp>
#include <isin/culling.hpp>
#include <isin/shading.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "support/workloads.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace {

template <class T>
const isin::Triangle<T> first_11a{{0, 0, 40}, {40, 0, -40}, {-40, 0, -40}};
template <class T>
const isin::Triangle<T> reordered_11a{{40, 0, -40}, {0, 0, 40}, {-40, 0, -40}};

} // namespace

TEST_CASE_TEMPLATE("§11 example 11b: light (0,60,80), L = (0,0.6,0.8), diffuse 0.6 vs −0.6 (unlit)", T, float, double) {
    const isin::Vertex<T> light{0, 60, 80}, P{0, 0, 0};
    const auto L = isin::normalize(light - P);
    CHECK(L.y == approx(0.6));
    CHECK(L.z == approx(0.8));
    const auto N1 = isin::normalize(isin::normal(first_11a<T>));
    const auto N2 = isin::normalize(isin::normal(reordered_11a<T>));
    CHECK(isin::dot(N1, L) == approx(0.6));
    CHECK(isin::dot(N2, L) == approx(-0.6));
    CHECK(isin::diffuse_coefficient(N1, L) == approx(0.6));
    CHECK(isin::diffuse_coefficient(N2, L) == T(0)); // unlit
}

TEST_CASE_TEMPLATE("§11 method 1: (eye − V)·N < 0 → backface; eye (0,60,80) culls the reordered", T, float, double) {
    const isin::Vertex<T> eye{0, 60, 80};
    CHECK_FALSE(isin::is_backface(first_11a<T>, eye));
    CHECK(isin::is_backface(reordered_11a<T>, eye));
    // From below the plane the roles swap.
    CHECK(isin::is_backface(first_11a<T>, isin::Vertex<T>{0, -60, 80}));
}

TEST_CASE_TEMPLATE("§11 projection by similar triangles: x' = d·x/z, y' = d·y/z", T, float, double) {
    const auto p = isin::project(isin::Vertex<T>{4, 2, 20}, T(10));
    CHECK(p[0] == approx(2));
    CHECK(p[1] == approx(1));
    // Example 5a's red triangle seen from the eye: projected clockwise (Z of the cross < 0): front.
    const isin::Triangle<T> red{{0, 30, 40}, {40, -30, 120}, {-40, -30, 120}};
    CHECK_FALSE(isin::is_backface_projected(red));
    CHECK(isin::is_backface_projected(isin::Triangle<T>{red.v0, red.v2, red.v1}));
}

TEST_CASE_TEMPLATE("§11 method 2 at eye (0,60,80) looking at the origin agrees with method 1", T, float, double) {
    const auto cam = isin::Camera<T>::look_at(800, 450, {0, 60, 80}, {0, 0, 0});
    CHECK_FALSE(isin::is_backface_projected(isin::to_camera_space(cam, first_11a<T>)));
    CHECK(isin::is_backface_projected(isin::to_camera_space(cam, reordered_11a<T>)));
}

TEST_CASE_TEMPLATE("§11 both methods agree on every triangle of a closed mesh from many eyes", T, float, double) {
    const isin::Vertex<T> centre{3, -2, 50};
    const auto mesh = workloads::icosphere<T>({3, -2, 50}, 10.0, 2); // 320 triangles, closed
    REQUIRE(mesh.size() == 320);
    const isin::Vertex<T> eyes[] = {{0, 0, 0},   {0, 60, 80}, {40, -30, 10}, {-25, 5, 95},
                                    {3, 40, 50}, {60, 0, 50}, {3, -2, 20},   {-30, -30, 140}};
    for (const auto& eye : eyes) {
        CAPTURE(eye.x);
        CAPTURE(eye.z);
        const auto cam = isin::Camera<T>::look_at(800, 450, eye, centre);
        int back = 0, disagree = 0;
        for (const auto& tri : mesh) {
            const bool m1 = isin::is_backface(tri, eye);
            const bool m2 = isin::is_backface_projected(isin::to_camera_space(cam, tri), cam.plane_distance);
            back += m1;
            disagree += m1 != m2;
        }
        CHECK(disagree == 0);
        // A convex closed mesh seen from outside: a bit more than half its faces turn away.
        CHECK(back > 160);
        CHECK(back < 260);
    }
}
