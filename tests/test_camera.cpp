// Note §3: the ray R(t) = Ro + t·Rd and the pinhole camera with its 16×9 plane at z = 10.
#include <isin/camera.hpp>

#include <doctest/doctest.h>

#include "approx.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

TEST_CASE_TEMPLATE("§3 ray: R(t) = Ro + t·Rd", T, float, double) {
    const isin::Ray<T> ray{{1, 2, 3}, {0, T(0.6), T(0.8)}};
    CHECK(ray.at(T(0)) == ray.origin);
    const auto p = ray.at(T(10));
    CHECK(p.x == approx(1));
    CHECK(p.y == approx(8));
    CHECK(p.z == approx(11));
}

TEST_CASE_TEMPLATE("§3 example 3a: pixel (0,0) → (−8,4.5,10), pixel (799,449) → (8,−4.5,10)", T, float, double) {
    const isin::Camera<T> cam{800, 450};
    CHECK(cam.image_point(T(0), T(0)) == isin::Vertex<T>{-8, T(4.5), 10});
    CHECK(cam.image_point(T(799), T(449)) == isin::Vertex<T>{8, T(-4.5), 10});
}

TEST_CASE_TEMPLATE("§3 GD(x,y) = (16·x/(W−1) − 8, 4.5 − 9·y/(H−1), 10) for any W×H", T, float, double) {
    const isin::Camera<T> cam{1920, 1080};
    for (int y : {0, 17, 540, 1079})
        for (int x : {0, 3, 960, 1919}) {
            const auto gd = cam.image_point(T(x), T(y));
            CHECK(gd.x == approx(16.0 * x / 1919.0 - 8.0));
            CHECK(gd.y == approx(4.5 - 9.0 * y / 1079.0));
            CHECK(gd.z == T(10));
        }
}

TEST_CASE_TEMPLATE("§3 primary ray: Ro = eye, Rd = normalize(GD − eye)", T, float, double) {
    const isin::Camera<T> cam{800, 450};
    const auto ray = cam.primary_ray(T(0), T(0));
    CHECK(ray.origin == isin::Vertex<T>{0, 0, 0});
    const T len = std::sqrt(T(64) + T(20.25) + T(100));
    CHECK(ray.direction.x == approx(-8 / len));
    CHECK(ray.direction.y == approx(T(4.5) / len));
    CHECK(ray.direction.z == approx(10 / len));
    // The centre of the plane (between pixels 399 and 400, 224 and 225) looks straight down +Z.
    const auto centre = cam.primary_ray(T(399.5), T(224.5));
    CHECK(centre.direction.x == approx(0));
    CHECK(centre.direction.y == approx(0));
    CHECK(centre.direction.z == approx(1));
}

TEST_CASE_TEMPLATE("§3 a posed camera moves and turns the whole rig (left-handed, +Y up)", T, float, double) {
    const T half_pi = T(1.5707963267948966);
    const isin::Camera<T> cam{800, 450, {5, 1, -2}, half_pi, T(0)};
    // Yaw +90° turns forward +Z into +X and right +X into −Z.
    CHECK(cam.forward().x == approx(1));
    CHECK(cam.forward().z == approx(0).epsilon(1e-6));
    CHECK(cam.right().z == approx(-1));
    CHECK(cam.up().y == approx(1));
    const auto gd = cam.image_point(T(399.5), T(224.5));
    CHECK(gd.x == approx(15));
    CHECK(gd.y == approx(1));
    CHECK(gd.z == approx(-2));
    // Pitch up 90° from rest looks along +Y.
    const isin::Camera<T> up{800, 450, {0, 0, 0}, T(0), half_pi};
    CHECK(up.forward().y == approx(1));
    CHECK(isin::length(up.up()) == approx(1));
}

TEST_CASE("§3 bad image sizes are rejected with a clear error") {
    CHECK_THROWS_AS(isin::Camera<float>(1, 450), std::invalid_argument);
    CHECK_THROWS_AS(isin::Camera<float>(800, 0), std::invalid_argument);
    CHECK_THROWS_AS(isin::Camera<double>(-800, 450), std::invalid_argument);
    CHECK_THROWS_AS(isin::Camera<double>(800, 1 << 20), std::invalid_argument);
    CHECK_THROWS_WITH(isin::Camera<double>(0, 450), doctest::Contains("width 0"));
    CHECK_NOTHROW(isin::Camera<float>(2, 2));
}

TEST_CASE("§3 a non-finite pose is ignored") {
    isin::Camera<double> cam{800, 450};
    cam.set_pose({std::nan(""), 0, 0}, 0, 0);
    CHECK(cam.position() == isin::Vec3d{0, 0, 0});
    cam.set_pose({1, 2, 3}, HUGE_VAL, 0);
    CHECK(cam.position() == isin::Vec3d{0, 0, 0});
}

TEST_CASE_TEMPLATE("§3 look_at turns the camera towards a target", T, float, double) {
    const auto cam = isin::Camera<T>::look_at(800, 450, {0, 60, 80}, {0, 0, 0});
    const auto f = cam.forward();
    CHECK(f.x == approx(0).epsilon(1e-6));
    CHECK(f.y == approx(-0.6));
    CHECK(f.z == approx(-0.8));
    CHECK(isin::dot(cam.right(), f) == approx(0).epsilon(1e-6));
    CHECK(cam.up().y > T(0)); // no roll: up stays up
    const auto centre = cam.primary_ray(T(399.5), T(224.5));
    CHECK(centre.direction.y == approx(-0.6));
    const auto same = isin::Camera<T>::look_at(800, 450, {1, 2, 3}, {1, 2, 3});
    CHECK(same.forward() == isin::Vertex<T>{0, 0, 1});
}

TEST_CASE_TEMPLATE("§12 walking: W then S returns to the start", T, float, double) {
    isin::Camera<T> cam{160, 90, {1, 2, 3}, T(0.4), T(0.2)};
    const auto start = cam.position();
    cam.move_forward(T(2.5));
    CHECK(isin::length(cam.position() - start) == approx(2.5));
    CHECK(cam.position().y == approx(2)); // walking stays level, even when looking up
    cam.move_backward(T(2.5));
    CHECK(cam.position().x == approx(start.x));
    CHECK(cam.position().y == approx(start.y));
    CHECK(cam.position().z == approx(start.z));
    cam.move_right(T(1));
    cam.move_left(T(1));
    CHECK(isin::length(cam.position() - start) == approx(0).epsilon(1e-5));
}

TEST_CASE_TEMPLATE("§12 walking: D moves along +X when facing +Z, A along −X", T, float, double) {
    isin::Camera<T> cam{160, 90};
    cam.move_right(T(1));
    CHECK(cam.position() == isin::Vertex<T>{1, 0, 0});
    cam.move_left(T(3));
    CHECK(cam.position() == isin::Vertex<T>{-2, 0, 0});
    cam.move_forward(T(5));
    CHECK(cam.position() == isin::Vertex<T>{-2, 0, 5});
}

TEST_CASE_TEMPLATE("§12 turning: yaw by 90° turns +Z into +X; pitch is limited to ±89°", T, float, double) {
    isin::Camera<T> cam{160, 90};
    cam.turn(T(1.5707963267948966));
    CHECK(cam.forward().x == approx(1));
    CHECK(cam.forward().z == approx(0).epsilon(1e-6));
    cam.move_forward(T(2));
    CHECK(cam.position().x == approx(2));
    cam.turn(T(0), T(3));
    CHECK(cam.pitch() == approx(1.5533430342749532));
    CHECK(cam.up().y > T(0));
    cam.turn(T(0), T(-6));
    CHECK(cam.pitch() == approx(-1.5533430342749532));
}

TEST_CASE_TEMPLATE("§12 the note's pixel mapping is unchanged at rest and after a round trip", T, float, double) {
    isin::Camera<T> cam{800, 450};
    CHECK(cam.image_point(T(0), T(0)) == isin::Vertex<T>{-8, T(4.5), 10});
    cam.turn(T(0.3));
    cam.move_forward(T(4));
    cam.move_backward(T(4));
    cam.turn(T(-0.3));
    const auto gd = cam.image_point(T(799), T(449));
    CHECK(gd.x == approx(8));
    CHECK(gd.y == approx(-4.5));
    CHECK(gd.z == approx(10));
}

TEST_CASE_TEMPLATE("§12 heading: (sin yaw, 0, cos yaw), level whatever the pitch", T, float, double) {
    const isin::Camera<T> rest{160, 90};
    CHECK(rest.heading() == isin::Vertex<T>{0, 0, 1});
    const isin::Camera<T> cam{160, 90, {1, 2, 3}, T(0.4), T(0.7)};
    const auto h = cam.heading();
    CHECK(h.x == approx(std::sin(0.4)));
    CHECK(h.y == T(0));
    CHECK(h.z == approx(std::cos(0.4)));
    // The forward vector (sin yaw cos pitch, sin pitch, cos yaw cos pitch) without its pitch.
    CHECK(h.x * std::cos(T(0.7)) == approx(cam.forward().x));
    CHECK(h.z * std::cos(T(0.7)) == approx(cam.forward().z));
    // Turning changes it: yaw −90° faces −X, yaw 180° faces −Z; pitch leaves it level.
    isin::Camera<T> turning{160, 90};
    turning.turn(T(-1.5707963267948966), T(0.5));
    CHECK(turning.heading().x == approx(-1));
    CHECK(turning.heading().y == T(0));
    CHECK(turning.heading().z == approx(0).epsilon(1e-6));
    turning.turn(T(-1.5707963267948966), T(-1));
    CHECK(turning.heading().x == approx(0).epsilon(1e-6));
    CHECK(turning.heading().z == approx(-1));
    // A non-finite pose is ignored, and so the heading stays.
    isin::Camera<T> kept{160, 90, {0, 0, 0}, T(0.4), T(0)};
    kept.set_pose({0, 0, 0}, std::numeric_limits<T>::quiet_NaN(), T(0));
    CHECK(kept.heading().x == approx(std::sin(0.4)));
}
