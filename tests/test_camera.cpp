// Note §3: the ray R(t) = Ro + t·Rd and the pinhole camera with its 16×9 plane at z = 10.
#include <isin/camera.hpp>
#include <isin/sphere.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>
#include <stdexcept>
#include <utility>

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

TEST_CASE_TEMPLATE("§3 primary_rays: many rays at once are primary_ray's, bit for bit, whatever their lane", T, float,
                   double) {
    // A posed camera (so every component of right, up and forward counts), 37 points: a whole
    // register of lanes or more, then a partial one; sub-pixel positions, the corners, one far
    // outside the image and one NaN, which primary_ray turns into a zero direction.
    const isin::Camera<T> cam{640, 360, {3, -1, 2}, T(0.4), T(-0.2), T(0.1)};
    std::vector<T> x, y;
    for (int k = 0; k < 35; ++k) x.push_back(T(k * 17 % 640) + T(k % 4) / T(4)), y.push_back(T(k * 29 % 360) + T(0.5));
    x.push_back(std::numeric_limits<T>::max() / 2), y.push_back(T(2));
    x.push_back(std::numeric_limits<T>::quiet_NaN()), y.push_back(T(3));
    x[0] = T(0), y[0] = T(0), x[1] = T(639), y[1] = T(359);
    std::vector<isin::Ray<T>> rays(x.size());
    for (std::size_t n : {std::size_t(0), std::size_t(1), x.size()}) {
        for (auto& r : rays) r = {{T(-7), T(-7), T(-7)}, {T(-7), T(-7), T(-7)}};
        cam.primary_rays(x.data(), y.data(), n, rays.data());
        int same = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const isin::Ray<T> one = cam.primary_ray(x[k], y[k]);
            same += std::memcmp(&one, &rays[k], sizeof one) == 0;
        }
        CHECK(same == int(n));
        for (std::size_t k = n; k < rays.size(); ++k) CHECK(rays[k].origin.x == T(-7)); // nothing beyond n
    }
    CHECK(rays[35].direction == isin::Vertex<T>{0, 0, 0}); // GD not finite: no direction
    CHECK(rays[36].direction == isin::Vertex<T>{0, 0, 0});
    // Shifting the points by one lane changes no ray: each lane is computed alone.
    std::vector<isin::Ray<T>> shifted(x.size() + 1);
    std::vector<T> xs{T(5)}, ys{T(6)};
    xs.insert(xs.end(), x.begin(), x.end()), ys.insert(ys.end(), y.begin(), y.end());
    cam.primary_rays(xs.data(), ys.data(), xs.size(), shifted.data());
    CHECK(std::memcmp(shifted.data() + 1, rays.data(), rays.size() * sizeof rays[0]) == 0);
    // The directions are GD − eye normalised (the image points agree with the rays).
    for (std::size_t k = 0; k < 35; ++k) {
        const isin::Vertex<T> d = isin::normalize(cam.image_point(x[k], y[k]) - cam.position());
        CHECK(rays[k].direction.x == approx(d.x));
        CHECK(rays[k].direction.y == approx(d.y));
        CHECK(rays[k].direction.z == approx(d.z));
    }
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
}

TEST_CASE_TEMPLATE("look_at: a non-finite or coincident eye and target are errors, not a camera at the origin", T,
                   float, double) {
    const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
    const isin::Vertex<T> up{0, 1, 0};
    const std::pair<isin::Vertex<T>, isin::Vertex<T>> bad[] = {
        {{nan, 0, 0}, {0, 0, 60}},
        {{0, 0, 0}, {0, inf, 60}},
        {{1, 2, 3}, {1, 2, 3}},
        {{0, 0, -inf}, {0, 0, 0}},
        {{0, 0, 0}, {nan, nan, nan}},
        {{0, 0, std::numeric_limits<T>::max()}, {0, 0, -std::numeric_limits<T>::max()}}, // no finite direction
    };
    for (const auto& [eye, target] : bad) {
        CHECK_THROWS_AS((void)isin::Camera<T>::look_at(64, 36, eye, target), std::invalid_argument);
        CHECK_THROWS_AS((void)isin::Camera<T>::look_at(64, 36, eye, target, up, T(45)), std::invalid_argument);
    }
    CHECK_NOTHROW((void)isin::Camera<T>::look_at(64, 36, {0, 0, 0}, {0, T(1e-3), 0}));
}

TEST_CASE_TEMPLATE("look_at: square pixels in both forms, a sphere ahead renders round; the note's camera is kept", T,
                   float, double) {
    const isin::Sphere<T> ball{{0, 0, 50}, 10};
    for (const auto& size : {std::pair<int, int>{400, 400}, {120, 40}, {36, 64}}) {
        const int w = size.first, h = size.second;
        CAPTURE(w);
        CAPTURE(h);
        for (const bool with_up : {false, true}) {
            const auto cam = with_up ? isin::Camera<T>::look_at(w, h, {0, 0, 0}, {0, 0, 1}, {0, 1, 0}, T(40))
                                     : isin::Camera<T>::look_at(w, h, {0, 0, 0}, {0, 0, 1});
            const T across = isin::length(cam.image_point(T(1), T(0)) - cam.image_point(T(0), T(0)));
            const T down = isin::length(cam.image_point(T(0), T(1)) - cam.image_point(T(0), T(0)));
            CHECK(across == approx(down).epsilon(1e-5));
            // The sphere's extent along the middle row and the middle column, in pixels.
            int wide = 0, tall = 0;
            for (int x = 0; x < w; ++x) wide += bool(isin::intersect(cam.primary_ray(T(x), T(h - 1) / 2), ball));
            for (int y = 0; y < h; ++y) tall += bool(isin::intersect(cam.primary_ray(T(w - 1) / 2, T(y)), ball));
            CHECK(wide > 2);
            CHECK(std::abs(wide - tall) <= 1);
        }
    }
    const isin::Camera<T> note{800, 450};
    CHECK(note.plane_width == T(16));
    CHECK(note.plane_height == T(9));
    CHECK(note.plane_distance == T(10));
    CHECK(note.image_point(T(0), T(0)) == isin::Vertex<T>{-8, T(4.5), 10}); // §3: top-left GD
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

namespace {
/// Distance between the plane points of two pixels.
template <class T>
T spacing(const isin::Camera<T>& cam, T x0, T y0, T x1, T y1) {
    return isin::length(cam.image_point(x1, y1) - cam.image_point(x0, y0));
}
} // namespace

TEST_CASE_TEMPLATE("look_at with up and field of view: square pixels at any size, the note's plane otherwise", T, float,
                   double) {
    for (const auto& size : {std::pair{300, 600}, std::pair{400, 400}, std::pair{1920, 1080}, std::pair{7, 2}}) {
        const int w = size.first;
        const int h = size.second;
        CAPTURE(w);
        CAPTURE(h);
        const auto cam = isin::Camera<T>::look_at(w, h, {1, 2, -30}, {0, 0, 0}, {0, 1, 0}, T(40));
        const T across = spacing(cam, T(0), T(0), T(w - 1), T(0)) / T(w - 1);
        const T down = spacing(cam, T(0), T(0), T(0), T(h - 1)) / T(h - 1);
        CHECK(across == approx(down)); // square pixels
        CHECK(cam.vertical_fov() == approx(40));
        // The top and bottom row centres subtend the field of view at the eye.
        const auto top = isin::normalize(cam.image_point(T(w - 1) / 2, T(0)) - cam.position());
        const auto bottom = isin::normalize(cam.image_point(T(w - 1) / 2, T(h - 1)) - cam.position());
        CHECK(std::acos(isin::dot(top, bottom)) * T(180) / T(3.141592653589793) == approx(40).epsilon(1e-4));
        // The centre ray goes to the target.
        const auto centre = cam.primary_ray(T(w - 1) / 2, T(h - 1) / 2).direction;
        const auto to_target = isin::normalize(isin::Vertex<T>{0, 0, 0} - cam.position());
        CHECK(isin::dot(centre, to_target) == approx(1));
    }
    // The note's camera keeps its 16×9 plane: its pixels are square only at 16:9.
    const isin::Camera<T> note{300, 600};
    CHECK(note.plane_width == T(16));
    CHECK(note.plane_height == T(9));
    CHECK(spacing(note, T(0), T(0), T(299), T(0)) / T(299) > T(3) * spacing(note, T(0), T(0), T(0), T(599)) / T(599));
    // square_pixels keeps the height; the note's camera then sees 2·atan(0.45) vertically.
    isin::Camera<T> squared{300, 600};
    squared.square_pixels();
    CHECK(squared.plane_height == T(9));
    CHECK(squared.plane_width == approx(T(9) * T(299) / T(599)));
    CHECK(squared.vertical_fov() == approx(2 * std::atan(0.45) * 180 / 3.141592653589793));
}

TEST_CASE_TEMPLATE("look_at's up vector rolls the image; a useless up keeps it level; bad fields of view throw", T,
                   float, double) {
    // Looking along +Z with up = +X: the image's top is towards +X, its right towards −Y.
    const auto cam = isin::Camera<T>::look_at(101, 101, {0, 0, 0}, {0, 0, 10}, {1, 0, 0}, T(60));
    CHECK(cam.up().x == approx(1));
    CHECK(cam.right().y == approx(-1));
    CHECK(cam.roll() == approx(3.141592653589793 / 2));
    const auto top = cam.image_point(T(50), T(0)), centre = cam.image_point(T(50), T(50));
    CHECK(top.x - centre.x > T(1));
    // The right-handedness of the image stays: right × up = forward (left-handed frame, §2).
    const auto f = isin::cross(cam.right(), cam.up());
    CHECK(f.z == approx(1));
    // An up with a part along the view: only its part across counts.
    const auto tilted = isin::Camera<T>::look_at(101, 101, {0, 0, 0}, {0, 0, 10}, {0, 1, 5}, T(60));
    CHECK(tilted.up().y == approx(1));
    CHECK(tilted.roll() == approx(0).epsilon(1e-6));
    // Up along the view, zero or not finite: no image up to take, an error.
    for (const isin::Vertex<T> up : {isin::Vertex<T>{0, 0, 3}, isin::Vertex<T>{0, 0, -1}, isin::Vertex<T>{0, 0, 0},
                                     isin::Vertex<T>{std::numeric_limits<T>::quiet_NaN(), 1, 0},
                                     isin::Vertex<T>{0, std::numeric_limits<T>::infinity(), 0}})
        CHECK_THROWS_AS((void)isin::Camera<T>::look_at(101, 101, {0, 0, 0}, {0, 0, 10}, up, T(60)),
                        std::invalid_argument);
    // Walking keeps the roll.
    auto walker = cam;
    walker.turn(T(0.1));
    CHECK(walker.roll() == approx(3.141592653589793 / 2));
    for (const T bad : {T(0), T(180), T(-5), T(400), std::numeric_limits<T>::quiet_NaN()})
        CHECK_THROWS_AS((void)isin::Camera<T>::look_at(10, 10, {0, 0, 0}, {0, 0, 1}, {0, 1, 0}, bad),
                        std::invalid_argument);
}
