#pragma once
/// isin — the pinhole camera of note §3: eye, a 16×9 image plane at distance 10, primary rays.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

#include "simd/pack.hpp"
#include "ray.hpp"
#include "vec.hpp"

namespace isin {

/// Pinhole camera. By default it is the note's: eye at the origin looking along +Z, a 16×9 image
/// plane centred on the Z axis at z = 10, pixel (0,0) top-left. A pose (position, yaw about +Y,
/// pitch about the camera's right axis, roll about its view direction, radians, left-handed: yaw
/// +90° turns +Z into +X, roll +90° turns the image's up towards its old right) moves and turns
/// that whole rig; the plane keeps its size and distance. The note's plane has square pixels only
/// at 16:9 sizes; set_vertical_fov or square_pixels, and both look_at forms, give square pixels at
/// any width × height.
template <class T>
class Camera {
    static_assert(std::is_floating_point_v<T>, "isin::Camera needs a floating-point type");

public:
    /// Largest accepted image side, so that width × height × 4 bytes stays well inside memory.
    static constexpr int max_side = 1 << 15;

    /// The note's camera for a width × height image. Throws std::invalid_argument unless both
    /// sides are in [2, max_side] (the mapping divides by W − 1 and H − 1).
    Camera(int width, int height) : Camera(width, height, Vertex<T>{T(0), T(0), T(0)}, T(0), T(0)) {}

    /// A camera at `position`, turned by `yaw`, `pitch` and `roll` (radians), note's plane otherwise.
    Camera(int width, int height, const Vertex<T>& position, T yaw, T pitch, T roll = T(0))
        : width_(checked_side(width, "width")), height_(checked_side(height, "height")) {
        set_pose(position, yaw, pitch, roll);
    }

    /// A camera at `eye` turned to look at `target` (yaw and pitch from the direction; no roll),
    /// the note's 9-high plane at distance 10 with square pixels at any width × height (its
    /// width 9·(W−1)/(H−1)). Throws std::invalid_argument if eye or target is not finite, or if
    /// they coincide (or lie so close or so far apart that no direction between them is finite).
    [[nodiscard]] static Camera look_at(int width, int height, const Vertex<T>& eye, const Vertex<T>& target) {
        if (!is_finite(eye) || !is_finite(target))
            throw std::invalid_argument("isin::Camera::look_at: the eye or the target is not finite");
        const Vertex<T> d = normalize(target - eye);
        if (!is_finite(d) || !(dot(d, d) > T(0.5)))
            throw std::invalid_argument(
                "isin::Camera::look_at: the eye and the target coincide (no finite view direction)");
        const T yaw = std::atan2(d.x, d.z);                      // +Z → 0, +X → +90°
        const T pitch = std::asin(std::clamp(d.y, T(-1), T(1))); // up is positive
        Camera cam(width, height, eye, yaw, pitch);
        cam.square_pixels();
        return cam;
    }

    /// A camera at `eye` looking at `target` with `up` upwards in the image (any vector not along
    /// the view; the image's up is its part perpendicular to the view), with square pixels and
    /// `vfov_degrees` between the centres of the top and bottom rows (the note's camera has
    /// 2·atan(4.5/10) ≈ 48.46°). Throws std::invalid_argument unless 0 < vfov_degrees < 180, as
    /// the 4-argument look_at for eye and target, and if `up` is zero, not finite or along the view.
    [[nodiscard]] static Camera look_at(int width, int height, const Vertex<T>& eye, const Vertex<T>& target,
                                        const Vertex<T>& up, T vfov_degrees) {
        Camera cam = look_at(width, height, eye, target);
        cam.set_vertical_fov(vfov_degrees);
        // The roll that turns the level image's up (up0) towards `up` about the view direction.
        const Vertex<T> right0{std::cos(cam.yaw_), T(0), -std::sin(cam.yaw_)};
        const Vertex<T> up0 = cross(cam.forward_, right0);
        const Vertex<T> across = up - dot(up, cam.forward_) * cam.forward_; // `up` in the image plane
        const T x = dot(across, right0), y = dot(across, up0), eps = std::numeric_limits<T>::epsilon();
        if (!is_finite(up) || !(x * x + y * y > T(64) * eps * eps * dot(up, up))) // NaN, zero or along the view
            throw std::invalid_argument("isin::Camera::look_at: the up vector is zero, not finite or along the view");
        cam.set_pose(cam.position_, cam.yaw_, cam.pitch_, std::atan2(x, y));
        return cam;
    }

    /// Square pixels with `vfov_degrees` between the centres of the top and bottom rows: the plane,
    /// at its distance, gets height 2·d·tan(vfov/2) and width height·(W−1)/(H−1). Throws
    /// std::invalid_argument unless 0 < vfov_degrees < 180.
    void set_vertical_fov(T vfov_degrees) {
        if (!(vfov_degrees > T(0) && vfov_degrees < T(180)))
            throw std::invalid_argument("isin::Camera: vertical field of view " + std::to_string(vfov_degrees) +
                                        "° is outside (0°, 180°)");
        plane_height = T(2) * plane_distance * std::tan(vfov_degrees * T(3.14159265358979323846) / T(360));
        square_pixels();
    }
    /// Square pixels keeping the plane's height: its width becomes height·(W−1)/(H−1) (the note's
    /// 9-high plane at 800×450: 16.02 wide, not 16).
    void square_pixels() noexcept { plane_width = plane_height * T(width_ - 1) / T(height_ - 1); }
    /// The vertical field of view in degrees, between the centres of the top and bottom rows.
    [[nodiscard]] T vertical_fov() const noexcept {
        return T(2) * std::atan(plane_height / (T(2) * plane_distance)) * T(180) / T(3.14159265358979323846);
    }

    /// Moves and turns the camera. Non-finite values are ignored (the pose stays as it was).
    void set_pose(const Vertex<T>& position, T yaw, T pitch, T roll = T(0)) noexcept {
        if (!is_finite(position) || !std::isfinite(yaw) || !std::isfinite(pitch) || !std::isfinite(roll)) return;
        position_ = position;
        yaw_ = yaw;
        pitch_ = pitch;
        roll_ = roll;
        const T cy = std::cos(yaw), sy = std::sin(yaw), cp = std::cos(pitch), sp = std::sin(pitch);
        forward_ = {sy * cp, sp, cy * cp};
        const Vertex<T> right0{cy, T(0), -sy};
        const Vertex<T> up0 = cross(forward_, right0); // left-handed: right × up = forward
        if (roll == T(0)) {
            right_ = right0, up_ = up0;
            return;
        }
        const T cr = std::cos(roll), sr = std::sin(roll);
        right_ = cr * right0 - sr * up0;
        up_ = sr * right0 + cr * up0;
    }

    /// Walking (note §12, keys W/S and A/D): a step along the heading in the horizontal plane
    /// (yaw only, so looking up or down does not make W fly), or sideways along the camera's
    /// right vector. Negative steps go the other way; non-finite steps are ignored.
    void move_forward(T step) noexcept { set_pose(position_ + step * heading(), yaw_, pitch_, roll_); }
    void move_backward(T step) noexcept { move_forward(-step); }
    void move_right(T step) noexcept { set_pose(position_ + step * right_, yaw_, pitch_, roll_); }
    void move_left(T step) noexcept { move_right(-step); }
    /// Turns by `yaw` (radians, positive turns right: +Z towards +X) and `pitch` (positive looks
    /// up); pitch stays within ±89° so that the view never flips over.
    void turn(T yaw, T pitch = T(0)) noexcept {
        const T limit = T(1.5533430342749532); // 89°
        set_pose(position_, yaw_ + yaw, std::clamp(pitch_ + pitch, -limit, limit), roll_);
    }
    /// The horizontal direction the camera faces: (sin yaw, 0, cos yaw).
    [[nodiscard]] Vertex<T> heading() const noexcept { return {std::sin(yaw_), T(0), std::cos(yaw_)}; }

    [[nodiscard]] int width() const noexcept { return width_; }
    [[nodiscard]] int height() const noexcept { return height_; }
    [[nodiscard]] const Vertex<T>& position() const noexcept { return position_; }
    [[nodiscard]] T yaw() const noexcept { return yaw_; }
    [[nodiscard]] T pitch() const noexcept { return pitch_; }
    [[nodiscard]] T roll() const noexcept { return roll_; }
    [[nodiscard]] const Vertex<T>& forward() const noexcept { return forward_; }
    [[nodiscard]] const Vertex<T>& right() const noexcept { return right_; }
    [[nodiscard]] const Vertex<T>& up() const noexcept { return up_; }

    /// Size of the image plane (16 × 9 in the note) and its distance from the eye (10).
    T plane_width = T(16);
    T plane_height = T(9);
    T plane_distance = T(10);

    /// The image-plane point GD of pixel (x, y) (§3): (16·x/(W−1) − 8, 4.5 − 9·y/(H−1), 10) in
    /// the camera's frame, moved to world space by the pose. Fractional x, y address sub-pixels.
    [[nodiscard]] Vertex<T> image_point(T x, T y) const noexcept {
        T out[6];
        rays_pass(x, y, out);
        return {out[0], out[1], out[2]};
    }

    /// The primary ray through pixel (x, y) (§3): Ro = eye, Rd = normalize(GD − eye).
    [[nodiscard]] Ray<T> primary_ray(T x, T y) const noexcept {
        T out[6];
        rays_pass(x, y, out);
        return {position_, {out[3], out[4], out[5]}};
    }

    /// The primary rays through the points (x[k], y[k]) of the image, k < n: out[k] =
    /// primary_ray(x[k], y[k]), the same bits, computed a register of lanes at a time.
    void primary_rays(const T* x, const T* y, std::size_t n, Ray<T>* out) const noexcept {
        using R = detail::LaneRegister<T>;
        constexpr std::size_t W = R::width;
        for (std::size_t first = 0; first < n; first += W) {
            const std::size_t m = std::min(W, n - first);
            alignas(64) T xs[W] = {}, ys[W] = {}, lanes[6][W];
            for (std::size_t k = 0; k < m; ++k) xs[k] = x[first + k], ys[k] = y[first + k];
            typename R::V v[6] = {T(0), T(0), T(0), T(0), T(0), T(0)};
            rays_pass(R::load(xs), R::load(ys), v);
            for (std::size_t c = 0; c < 6; ++c) R::store(v[c], lanes[c]);
            for (std::size_t k = 0; k < m; ++k) out[first + k] = {position_, {lanes[3][k], lanes[4][k], lanes[5][k]}};
        }
    }

private:
    // §3 for one image point (V = T) or a register of them (V = LaneRegister's): the image-plane
    // point GD of (x, y) into out[0 … 2] and the unit direction from the eye towards it into
    // out[3 … 5]. Each product it adds goes through lane_fma, so that image_point, primary_ray
    // and primary_rays give the same bits.
    template <class V>
    void rays_pass(V x, V y, V* out) const noexcept {
        using detail::lane_fma;
        const V gx = V(plane_width) * x / V(T(width_ - 1)) - V(plane_width / T(2));    // §3: 16·x/(W−1) − 8
        const V gy = V(plane_height / T(2)) - V(plane_height) * y / V(T(height_ - 1)); // §3: 4.5 − 9·y/(H−1)
        // §3: GD = eye + gx·right + gy·up + 10·forward (z = 10 for the note's camera)
        const V d(plane_distance);
        out[0] = lane_fma(d, V(forward_.x), lane_fma(gy, V(up_.x), lane_fma(gx, V(right_.x), V(position_.x))));
        out[1] = lane_fma(d, V(forward_.y), lane_fma(gy, V(up_.y), lane_fma(gx, V(right_.y), V(position_.y))));
        out[2] = lane_fma(d, V(forward_.z), lane_fma(gy, V(up_.z), lane_fma(gx, V(right_.z), V(position_.z))));
        out[3] = out[0] - V(position_.x), out[4] = out[1] - V(position_.y), out[5] = out[2] - V(position_.z);
        detail::lane_normalize<T>(out[3], out[4], out[5]); // §3: Rd = (GD − eye)/|GD − eye|
    }

    static int checked_side(int side, const char* what) {
        if (side < 2 || side > max_side)
            throw std::invalid_argument(std::string("isin::Camera: image ") + what + " " + std::to_string(side) +
                                        " is outside [2, " + std::to_string(max_side) + "]");
        return side;
    }

    int width_, height_;
    Vertex<T> position_{}, forward_{}, right_{}, up_{};
    T yaw_ = T(0), pitch_ = T(0), roll_ = T(0);
};

} // namespace isin
