#pragma once
/// isin — affine transforms: where a placed copy of a mesh (Scene::add_instance) stands.
/// x' = M·x + d with a 3×3 matrix M (rotation, uniform or non-uniform scale, shear) and a
/// translation d. Normals go by the inverse transpose of M.
///
///     auto place = isin::Transform<float>::translation({0, -1, 40}) *
///                  isin::Transform<float>::rotation({0, 1, 0}, 0.5f) * isin::Transform<float>::scaling(2);
///     isin::Vec3f p = place.point({1, 0, 0});   // scaled, then rotated, then moved
#include <cmath>
#include <type_traits>

#include "error_bound.hpp"
#include "vec.hpp"

namespace isin {

/// An affine transform x' = M·x + d; see the top of this header.
template <class T>
struct Transform {
    static_assert(std::is_floating_point_v<T>, "isin::Transform needs a floating-point type");
    T m[3][3] = {{T(1), T(0), T(0)}, {T(0), T(1), T(0)}, {T(0), T(0), T(1)}}; ///< M, row by row
    Vertex<T> d{T(0), T(0), T(0)};                                            ///< the translation

    /// The identity.
    [[nodiscard]] static constexpr Transform identity() noexcept { return {}; }
    /// Moves by `offset`.
    [[nodiscard]] static constexpr Transform translation(const Vertex<T>& offset) noexcept {
        Transform t;
        t.d = offset;
        return t;
    }
    /// Scales by `s` along every axis.
    [[nodiscard]] static constexpr Transform scaling(T s) noexcept { return scaling(Vertex<T>{s, s, s}); }
    /// Scales by s.x, s.y, s.z along the axes (non-uniform; a negative factor mirrors).
    [[nodiscard]] static constexpr Transform scaling(const Vertex<T>& s) noexcept {
        Transform t;
        t.m[0][0] = s.x, t.m[1][1] = s.y, t.m[2][2] = s.z;
        return t;
    }
    /// Turns by `radians` about `axis` (any length but 0): Rodrigues' matrix
    /// cos θ·I + sin θ·[a]× + (1 − cos θ)·a aᵀ. A quarter turn about +Y takes +Z to +X.
    [[nodiscard]] static Transform rotation(const Vertex<T>& axis, T radians) noexcept {
        const Vertex<T> a = normalize(axis);
        const T c = std::cos(radians), s = std::sin(radians), k = T(1) - c;
        Transform t;
        t.m[0][0] = c + k * a.x * a.x, t.m[0][1] = k * a.x * a.y - s * a.z, t.m[0][2] = k * a.x * a.z + s * a.y;
        t.m[1][0] = k * a.y * a.x + s * a.z, t.m[1][1] = c + k * a.y * a.y, t.m[1][2] = k * a.y * a.z - s * a.x;
        t.m[2][0] = k * a.z * a.x - s * a.y, t.m[2][1] = k * a.z * a.y + s * a.x, t.m[2][2] = c + k * a.z * a.z;
        return t;
    }

    /// M·p + d: where the point p goes.
    [[nodiscard]] constexpr Vertex<T> point(const Vertex<T>& p) const noexcept { return vector(p) + d; }
    /// Where a point with an error bound goes, and its bound: the rounding of M·p + d, γ₄·(|M|·|p| +
    /// |d|), plus the incoming error carried through, (1 + γ₄)·|M|·error (pbrt-v4 §6.8.6).
    [[nodiscard]] BoundedPoint<T> bounded_point(const BoundedPoint<T>& p) const noexcept {
        const Vertex<T> a = abs(p.point), e = p.error;
        const auto row = [&](int i, const Vertex<T>& v) {
            return std::fabs(m[i][0]) * v.x + std::fabs(m[i][1]) * v.y + std::fabs(m[i][2]) * v.z;
        };
        const Vertex<T> rounding{row(0, a) + std::fabs(d.x), row(1, a) + std::fabs(d.y), row(2, a) + std::fabs(d.z)};
        const Vertex<T> carried{row(0, e), row(1, e), row(2, e)};
        return {point(p.point), rounding_gamma<T>(4) * rounding + (T(1) + rounding_gamma<T>(4)) * carried};
    }
    /// M·v: where the direction (or difference of points) v goes.
    [[nodiscard]] constexpr Vertex<T> vector(const Vertex<T>& v) const noexcept {
        return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
    }
    /// The transform that applies `inner` first, then this one.
    [[nodiscard]] constexpr Transform operator*(const Transform& inner) const noexcept {
        Transform t;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                t.m[i][j] = m[i][0] * inner.m[0][j] + m[i][1] * inner.m[1][j] + m[i][2] * inner.m[2][j];
        t.d = point(inner.d);
        return t;
    }
    /// det M: 0 for a transform that flattens space, negative for one that mirrors it (and with it
    /// turns clockwise triangles anticlockwise).
    [[nodiscard]] constexpr T determinant() const noexcept {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    }
    /// The inverse (by the adjugate); a transform with det M = 0 has none: every entry is then
    /// non-finite, and so is everything it maps.
    [[nodiscard]] constexpr Transform inverse() const noexcept {
        const T inv = T(1) / determinant();
        Transform t;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
                t.m[i][j] = (m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]) * inv; // cofactor, transposed
            }
        t.d = -t.vector(d);
        return t;
    }
    /// Where a surface normal n goes: (M⁻¹)ᵀ·n, not normalised. `inverse` is this transform's
    /// inverse (kept by whoever maps many normals).
    [[nodiscard]] static constexpr Vertex<T> normal(const Transform& inverse, const Vertex<T>& n) noexcept {
        return {inverse.m[0][0] * n.x + inverse.m[1][0] * n.y + inverse.m[2][0] * n.z,
                inverse.m[0][1] * n.x + inverse.m[1][1] * n.y + inverse.m[2][1] * n.z,
                inverse.m[0][2] * n.x + inverse.m[1][2] * n.y + inverse.m[2][2] * n.z};
    }
    /// True when this is exactly the identity.
    [[nodiscard]] constexpr bool is_identity() const noexcept {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (m[i][j] != (i == j ? T(1) : T(0))) return false;
        return d.x == T(0) && d.y == T(0) && d.z == T(0);
    }
};

using Transformf = Transform<float>;
using Transformd = Transform<double>;

} // namespace isin
