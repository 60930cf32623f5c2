#pragma once
/// isin — Möller–Trumbore over many triangles at once: a structure-of-arrays batch whose inner
/// loop has no branches, so the compiler vectorises it (SSE at -O3, AVX2/AVX-512 with
/// -march=native). Same formula as `intersect_moller_trumbore` (note §10), with the division
/// taken for every lane instead of on the hit path only.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "hit.hpp"
#include "ray.hpp"
#include "triangle.hpp"
#include "vec.hpp"

namespace isin {

/// Triangles stored as V0, E1 = V1−V0, E2 = V2−V0 in separate arrays, padded to whole blocks.
/// Zero-area triangles are stored with zero edges, so every ray misses them (as in the scalar test).
template <class T>
class TriangleBatch {
    static_assert(std::is_floating_point_v<T>, "isin::TriangleBatch needs a floating-point type");

public:
    /// Lanes per block: one 64-byte cache line of each array.
    static constexpr std::size_t block = 64 / sizeof(T);

    TriangleBatch() = default;
    explicit TriangleBatch(const std::vector<Triangle<T>>& triangles) {
        reserve(triangles.size());
        for (const auto& tri : triangles) push_back(tri);
    }

    void reserve(std::size_t n) {
        for (auto* a : arrays()) a->reserve(padded(n));
    }
    void push_back(const Triangle<T>& tri) {
        if (size_ % block == 0)
            for (auto* a : arrays()) a->resize(a->size() + block, T(0));
        Vertex<T> e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
        if (detail::is_degenerate(e1, e2, cross(e1, e2))) e1 = e2 = Vertex<T>{T(0), T(0), T(0)};
        const std::size_t i = size_++;
        v0x_[i] = tri.v0.x, v0y_[i] = tri.v0.y, v0z_[i] = tri.v0.z;
        e1x_[i] = e1.x, e1y_[i] = e1.y, e1z_[i] = e1.z;
        e2x_[i] = e2.x, e2y_[i] = e2.y, e2z_[i] = e2.z;
    }
    [[nodiscard]] std::size_t size() const noexcept { return size_; }
    [[nodiscard]] bool empty() const noexcept { return size_ == 0; }

    /// Nearest hit with t in (0, t_max), two-sided; miss if none. `primitive` is the index of
    /// the triangle in the batch.
    [[nodiscard]] Hit<T> nearest(const Ray<T>& ray, T t_max = std::numeric_limits<T>::infinity()) const noexcept {
        Hit<T> best;
        T t_best = t_max;
        T t[block], u[block], v[block];
        for (std::size_t base = 0; base < size_; base += block) {
            test_block(ray, base, t_best, t, u, v);
            for (std::size_t k = 0; k < block; ++k)
                if (t[k] < t_best) t_best = t[k], best = {t[k], u[k], v[k], static_cast<std::uint32_t>(base + k)};
        }
        return best;
    }

    /// Calls f(index, t) for every triangle hit with t in (0, t_max), in index order; stops
    /// early when f returns false.
    template <class F>
    void each_hit(const Ray<T>& ray, T t_max, F&& f) const {
        T t[block], u[block], v[block];
        for (std::size_t base = 0; base < size_; base += block) {
            test_block(ray, base, t_max, t, u, v);
            for (std::size_t k = 0; k < block; ++k)
                if (t[k] < t_max && !f(base + k, t[k])) return;
        }
    }

private:
    // One block of Möller–Trumbore (§10), branch-free: a miss leaves t = +∞ in its lane.
    void test_block(const Ray<T>& ray, std::size_t base, T t_max, T* __restrict t_out, T* __restrict u_out,
                    T* __restrict v_out) const noexcept {
        const T ox = ray.origin.x, oy = ray.origin.y, oz = ray.origin.z;
        const T dx = ray.direction.x, dy = ray.direction.y, dz = ray.direction.z;
        const T* __restrict v0x = v0x_.data() + base;
        const T* __restrict v0y = v0y_.data() + base;
        const T* __restrict v0z = v0z_.data() + base;
        const T* __restrict e1x = e1x_.data() + base;
        const T* __restrict e1y = e1y_.data() + base;
        const T* __restrict e1z = e1z_.data() + base;
        const T* __restrict e2x = e2x_.data() + base;
        const T* __restrict e2y = e2y_.data() + base;
        const T* __restrict e2z = e2z_.data() + base;
        constexpr T inf = std::numeric_limits<T>::infinity();
        for (std::size_t k = 0; k < block; ++k) {
            const T px = dy * e2z[k] - dz * e2y[k]; // MT: P = Rd × E2
            const T py = dz * e2x[k] - dx * e2z[k];
            const T pz = dx * e2y[k] - dy * e2x[k];
            const T det = e1x[k] * px + e1y[k] * py + e1z[k] * pz;        // MT: det = E1·P
            const T inv = T(1) / det;                                     // ±∞ or NaN when det = 0
            const T sx = ox - v0x[k], sy = oy - v0y[k], sz = oz - v0z[k]; // MT: S = Ro − V0
            const T u = (sx * px + sy * py + sz * pz) * inv;              // MT: u = S·P / det
            const T qx = sy * e1z[k] - sz * e1y[k];                       // MT: Q = S × E1
            const T qy = sz * e1x[k] - sx * e1z[k];
            const T qz = sx * e1y[k] - sy * e1x[k];
            const T v = (dx * qx + dy * qy + dz * qz) * inv;              // MT: v = Rd·Q / det
            const T tt = (e2x[k] * qx + e2y[k] * qy + e2z[k] * qz) * inv; // MT: t = E2·Q / det
            const bool hit = (u >= T(0)) & (v >= T(0)) & (u + v <= T(1)) & (tt > T(0)) & (tt < t_max);
            t_out[k] = hit ? tt : inf;
            u_out[k] = u;
            v_out[k] = v;
        }
    }

    [[nodiscard]] static std::size_t padded(std::size_t n) noexcept { return (n + block - 1) / block * block; }
    std::array<std::vector<T>*, 9> arrays() noexcept {
        return {&v0x_, &v0y_, &v0z_, &e1x_, &e1y_, &e1z_, &e2x_, &e2y_, &e2z_};
    }

    std::vector<T> v0x_, v0y_, v0z_, e1x_, e1y_, e1z_, e2x_, e2y_, e2z_;
    std::size_t size_ = 0;
};

} // namespace isin
