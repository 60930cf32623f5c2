#pragma once
/// isin — the pinhole camera of note §3: eye, a 16×9 image plane at distance 10, primary rays.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ray.hpp"
#include "vec.hpp"

namespace isin {

/// Pinhole camera. By default it is the note's: eye at the origin looking along +Z, a 16×9 image
/// plane centred on the Z axis at z = 10, pixel (0,0) top-left. A pose (position, yaw about +Y,
/// pitch about the camera's right axis, radians, left-handed: yaw +90° turns +Z into +X) moves and
/// turns that whole rig; the plane keeps its size and distance.
template <class T>
class Camera {
    static_assert(std::is_floating_point_v<T>, "isin::Camera needs a floating-point type");

public:
    /// Largest accepted image side, so that width × height × 4 bytes stays well inside memory.
    static constexpr int max_side = 1 << 15;

    /// The note's camera for a width × height image. Throws std::invalid_argument unless both
    /// sides are in [2, max_side] (the mapping divides by W − 1 and H − 1).
    Camera(int width, int height) : Camera(width, height, Vertex<T>{T(0), T(0), T(0)}, T(0), T(0)) {}

    /// A camera at `position`, turned by `yaw` and `pitch` (radians), note's plane otherwise.
    Camera(int width, int height, const Vertex<T>& position, T yaw, T pitch)
        : width_(checked_side(width, "width")), height_(checked_side(height, "height")) {
        set_pose(position, yaw, pitch);
    }

    /// A camera at `eye` turned to look at `target` (yaw and pitch from the direction; no roll).
    /// If eye and target coincide or are not finite, it looks along +Z.
    [[nodiscard]] static Camera look_at(int width, int height, const Vertex<T>& eye, const Vertex<T>& target) {
        const Vertex<T> d = normalize(target - eye);
        const T yaw = std::atan2(d.x, d.z);                      // +Z → 0, +X → +90°
        const T pitch = std::asin(std::clamp(d.y, T(-1), T(1))); // up is positive
        return Camera(width, height, eye, d == Vertex<T>{} ? T(0) : yaw, pitch);
    }

    /// Moves and turns the camera. Non-finite values are ignored (the pose stays as it was).
    void set_pose(const Vertex<T>& position, T yaw, T pitch) noexcept {
        if (!is_finite(position) || !std::isfinite(yaw) || !std::isfinite(pitch)) return;
        position_ = position;
        yaw_ = yaw;
        pitch_ = pitch;
        const T cy = std::cos(yaw), sy = std::sin(yaw), cp = std::cos(pitch), sp = std::sin(pitch);
        forward_ = {sy * cp, sp, cy * cp};
        right_ = {cy, T(0), -sy};
        up_ = cross(forward_, right_); // left-handed: right × up = forward
    }

    /// Walking (note §12, keys W/S and A/D): a step along the heading in the horizontal plane
    /// (yaw only, so looking up or down does not make W fly), or sideways along the camera's
    /// right vector. Negative steps go the other way; non-finite steps are ignored.
    void move_forward(T step) noexcept { set_pose(position_ + step * heading(), yaw_, pitch_); }
    void move_backward(T step) noexcept { move_forward(-step); }
    void move_right(T step) noexcept { set_pose(position_ + step * right_, yaw_, pitch_); }
    void move_left(T step) noexcept { move_right(-step); }
    /// Turns by `yaw` (radians, positive turns right: +Z towards +X) and `pitch` (positive looks
    /// up); pitch stays within ±89° so that the view never flips over.
    void turn(T yaw, T pitch = T(0)) noexcept {
        const T limit = T(1.5533430342749532); // 89°
        set_pose(position_, yaw_ + yaw, std::clamp(pitch_ + pitch, -limit, limit));
    }
    /// The horizontal direction the camera faces: (sin yaw, 0, cos yaw).
    [[nodiscard]] Vertex<T> heading() const noexcept { return {std::sin(yaw_), T(0), std::cos(yaw_)}; }

    [[nodiscard]] int width() const noexcept { return width_; }
    [[nodiscard]] int height() const noexcept { return height_; }
    [[nodiscard]] const Vertex<T>& position() const noexcept { return position_; }
    [[nodiscard]] T yaw() const noexcept { return yaw_; }
    [[nodiscard]] T pitch() const noexcept { return pitch_; }
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
        const T gx = plane_width * x / T(width_ - 1) - plane_width / T(2);     // §3: 16·x/(W−1) − 8
        const T gy = plane_height / T(2) - plane_height * y / T(height_ - 1);  // §3: 4.5 − 9·y/(H−1)
        return position_ + gx * right_ + gy * up_ + plane_distance * forward_; // §3: GD, z = 10
    }

    /// The primary ray through pixel (x, y) (§3): Ro = eye, Rd = normalize(GD − eye).
    [[nodiscard]] Ray<T> primary_ray(T x, T y) const noexcept {
        return {position_, normalize(image_point(x, y) - position_)}; // §3: Rd = (GD − eye)/|GD − eye|
    }

private:
    static int checked_side(int side, const char* what) {
        if (side < 2 || side > max_side)
            throw std::invalid_argument(std::string("isin::Camera: image ") + what + " " + std::to_string(side) +
                                        " is outside [2, " + std::to_string(max_side) + "]");
        return side;
    }

    int width_, height_;
    Vertex<T> position_{}, forward_{}, right_{}, up_{};
    T yaw_ = T(0), pitch_ = T(0);
};

} // namespace isin
