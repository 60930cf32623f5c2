#pragma once
// Batch (structure-of-arrays) versions of every ray–triangle and ray–sphere method, for the
// accuracy-against-speed study: the same formulas as the scalar functions in include/isin/, with
// every early return turned into a select so the compiler can vectorise the loop over the batch.
// Each writes t (or +∞ for a miss) per element. benchmarks/batch_timing.cpp times them and checks
// that they decide exactly like the scalar methods.
#include <isin/isin.hpp>

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

/// A batch loop's median ns per test, and the fraction of cases it decides as the scalar
/// method does (defined in batch_timing.cpp, used by accuracy_vs_speed.cpp).
struct BatchResult {
    double ns = 0;
    double agreement = 0;
};
BatchResult batch_triangle_method(const char* method, bool is_float, int repeats);
BatchResult batch_sphere_method(const char* method, bool is_float, int repeats);
double batch_ns_per_test_mt_float(int repeats);
double batch_ns_per_test_mt_double(int repeats);

namespace batch {

template <class T>
struct Triangles {
    std::vector<T> x0, y0, z0, x1, y1, z1, x2, y2, z2;
    explicit Triangles(const std::vector<isin::Triangle<T>>& tris) {
        for (const auto& t : tris) {
            x0.push_back(t.v0.x), y0.push_back(t.v0.y), z0.push_back(t.v0.z);
            x1.push_back(t.v1.x), y1.push_back(t.v1.y), z1.push_back(t.v1.z);
            x2.push_back(t.v2.x), y2.push_back(t.v2.y), z2.push_back(t.v2.z);
        }
    }
    std::size_t size() const { return x0.size(); }
};

template <class T>
struct Spheres {
    std::vector<T> cx, cy, cz, r;
    explicit Spheres(const std::vector<isin::Sphere<T>>& s) {
        for (const auto& x : s)
            cx.push_back(x.center.x), cy.push_back(x.center.y), cz.push_back(x.center.z), r.push_back(x.radius);
    }
    std::size_t size() const { return r.size(); }
};

template <class T>
constexpr T inf = std::numeric_limits<T>::infinity();
template <class T>
inline T mx(T a, T b) {
    return a < b ? b : a;
}
template <class T>
inline T ab(T a) {
    return a < T(0) ? -a : a;
}

// §10 Möller–Trumbore, optionally culling (det ≤ 0); the division on every lane.
template <class T, bool cull>
void moller_trumbore(const isin::Ray<T>& ray, const Triangles<T>& b, T* __restrict out) {
    const T ox = ray.origin.x, oy = ray.origin.y, oz = ray.origin.z, dx = ray.direction.x, dy = ray.direction.y,
            dz = ray.direction.z;
    for (std::size_t i = 0; i < b.size(); ++i) {
        const T e1x = b.x1[i] - b.x0[i], e1y = b.y1[i] - b.y0[i], e1z = b.z1[i] - b.z0[i];
        const T e2x = b.x2[i] - b.x0[i], e2y = b.y2[i] - b.y0[i], e2z = b.z2[i] - b.z0[i];
        const T px = dy * e2z - dz * e2y, py = dz * e2x - dx * e2z, pz = dx * e2y - dy * e2x;
        const T det = e1x * px + e1y * py + e1z * pz;
        const T inv = T(1) / det;
        const T sx = ox - b.x0[i], sy = oy - b.y0[i], sz = oz - b.z0[i];
        const T u = (sx * px + sy * py + sz * pz) * inv;
        const T qx = sy * e1z - sz * e1y, qy = sz * e1x - sx * e1z, qz = sx * e1y - sy * e1x;
        const T v = (dx * qx + dy * qy + dz * qz) * inv;
        const T t = (e2x * qx + e2y * qy + e2z * qz) * inv;
        const bool ok = (cull ? det > T(0) : det != T(0)) & (u >= T(0)) & (u <= T(1)) & (v >= T(0)) & (u + v <= T(1)) &
                        (t > T(0)) & (t < inf<T>);
        out[i] = ok ? t : inf<T>;
    }
}

// Watertight (Woop, Benthin & Wald 2013), the shear per ray, exact-sign edge functions.
template <class T>
void watertight(const isin::Ray<T>& ray, const Triangles<T>& b, T* __restrict out) {
    const auto& d = ray.direction;
    const T ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
    const int kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
    const T dzc = isin::component(d, kz);
    if (dzc < T(0)) std::swap(kx, ky);
    const T Sx = isin::component(d, kx) / dzc, Sy = isin::component(d, ky) / dzc, Sz = T(1) / dzc;
    const std::vector<T>* v[3][3] = {{&b.x0, &b.y0, &b.z0}, {&b.x1, &b.y1, &b.z1}, {&b.x2, &b.y2, &b.z2}};
    const T* X[3];
    const T* Y[3];
    const T* Z[3];
    for (int k = 0; k < 3; ++k) X[k] = v[k][kx]->data(), Y[k] = v[k][ky]->data(), Z[k] = v[k][kz]->data();
    const T ox = isin::component(ray.origin, kx), oy = isin::component(ray.origin, ky),
            oz = isin::component(ray.origin, kz);
    for (std::size_t i = 0; i < b.size(); ++i) {
        const T Az = Z[0][i] - oz, Bz = Z[1][i] - oz, Cz = Z[2][i] - oz;
        const T Ax = X[0][i] - ox - Sx * Az, Ay = Y[0][i] - oy - Sy * Az;
        const T Bx = X[1][i] - ox - Sx * Bz, By = Y[1][i] - oy - Sy * Bz;
        const T Cx = X[2][i] - ox - Sx * Cz, Cy = Y[2][i] - oy - Sy * Cz;
        const T U = isin::difference_of_products(Cx, By, Cy, Bx);
        const T V = isin::difference_of_products(Ax, Cy, Ay, Cx);
        const T W = isin::difference_of_products(Bx, Ay, By, Ax);
        const bool neg = (U < T(0)) | (V < T(0)) | (W < T(0)), pos = (U > T(0)) | (V > T(0)) | (W > T(0));
        const T det = U + V + W;
        const T t = (U * (Sz * Az) + V * (Sz * Bz) + W * (Sz * Cz)) / det;
        const bool ok = !(neg & pos) & (det != T(0)) & (t > T(0)) & (t < inf<T>);
        out[i] = ok ? t : inf<T>;
    }
}

// Baldwin & Weber 2016: 12 precomputed coefficients per triangle.
template <class T>
struct Transforms {
    std::vector<T> c[12];
    explicit Transforms(const std::vector<isin::Triangle<T>>& tris) {
        for (const auto& t : tris) {
            const auto bw = isin::baldwin_weber_transform(t);
            const T v[12] = {bw.row_u.x, bw.row_u.y, bw.row_u.z, bw.off_u,   bw.row_v.x, bw.row_v.y,
                             bw.row_v.z, bw.off_v,   bw.row_w.x, bw.row_w.y, bw.row_w.z, bw.off_w};
            for (int k = 0; k < 12; ++k) c[k].push_back(v[k]);
        }
    }
    std::size_t size() const { return c[0].size(); }
};
template <class T>
void baldwin_weber(const isin::Ray<T>& ray, const Transforms<T>& b, T* __restrict out) {
    const T ox = ray.origin.x, oy = ray.origin.y, oz = ray.origin.z, dx = ray.direction.x, dy = ray.direction.y,
            dz = ray.direction.z;
    for (std::size_t i = 0; i < b.size(); ++i) {
        const T wo = b.c[8][i] * ox + b.c[9][i] * oy + b.c[10][i] * oz + b.c[11][i];
        const T wd = b.c[8][i] * dx + b.c[9][i] * dy + b.c[10][i] * dz;
        const T t = -wo / wd;
        const T px = ox + t * dx, py = oy + t * dy, pz = oz + t * dz;
        const T u = b.c[0][i] * px + b.c[1][i] * py + b.c[2][i] * pz + b.c[3][i];
        const T v = b.c[4][i] * px + b.c[5][i] * py + b.c[6][i] * pz + b.c[7][i];
        const bool ok = (t > T(0)) & (t < inf<T>)&(u >= T(0)) & (v >= T(0)) & (u + v <= T(1));
        out[i] = ok ? t : inf<T>;
    }
}

// §4 area test: the note's absolute ε (relative = false), or isin's default (V0's frame, 8ε·(S + L·M)).
template <class T, bool relative>
void area(const isin::Ray<T>& ray, const Triangles<T>& b, T* __restrict out, T epsilon) {
    constexpr T eps = std::numeric_limits<T>::epsilon();
    const T dx = ray.direction.x, dy = ray.direction.y, dz = ray.direction.z;
    for (std::size_t i = 0; i < b.size(); ++i) {
        const T x0 = b.x0[i], y0 = b.y0[i], z0 = b.z0[i];
        // relative: everything relative to V0; note: absolute coordinates
        const T bx = relative ? T(0) : x0, by = relative ? T(0) : y0, bz = relative ? T(0) : z0;
        const T ox = ray.origin.x - (relative ? x0 : T(0)), oy = ray.origin.y - (relative ? y0 : T(0)),
                oz = ray.origin.z - (relative ? z0 : T(0));
        const T e1x = b.x1[i] - x0, e1y = b.y1[i] - y0, e1z = b.z1[i] - z0;
        const T e2x = b.x2[i] - x0, e2y = b.y2[i] - y0, e2z = b.z2[i] - z0;
        const T Nx = e1y * e2z - e1z * e2y, Ny = e1z * e2x - e1x * e2z, Nz = e1x * e2y - e1y * e2x;
        const T D = -(Nx * bx + Ny * by + Nz * bz);
        const T t = -(Nx * ox + Ny * oy + Nz * oz + D) / (Nx * dx + Ny * dy + Nz * dz);
        const T Rx = ox + t * dx, Ry = oy + t * dy, Rz = oz + t * dz;
        const T ax = Rx - bx, ay = Ry - by, az = Rz - bz; // R − V0
        const T S = std::sqrt(Nx * Nx + Ny * Ny + Nz * Nz);
        const T c1x = ay * e2z - az * e2y, c1y = az * e2x - ax * e2z, c1z = ax * e2y - ay * e2x;
        const T c2x = e1y * az - e1z * ay, c2y = e1z * ax - e1x * az, c2z = e1x * ay - e1y * ax;
        const T fx = bx + e1x - Rx, fy = by + e1y - Ry, fz = bz + e1z - Rz; // V1 − R
        const T gx = bx + e2x - Rx, gy = by + e2y - Ry, gz = bz + e2z - Rz; // V2 − R
        const T c3x = fy * gz - fz * gy, c3y = fz * gx - fx * gz, c3z = fx * gy - fy * gx;
        const T s = std::sqrt(c1x * c1x + c1y * c1y + c1z * c1z) + std::sqrt(c2x * c2x + c2y * c2y + c2z * c2z) +
                    std::sqrt(c3x * c3x + c3y * c3y + c3z * c3z);
        const T L = mx(mx(mx(ab(e1x), ab(e1y)), ab(e1z)), mx(mx(ab(e2x), ab(e2y)), ab(e2z)));
        const T M = mx(mx(mx(ab(Rx), ab(Ry)), ab(Rz)), mx(mx(ab(ox), ab(oy)), ab(oz)));
        const T tol = relative ? T(8) * eps * (S + L * M) : epsilon;
        const T Nm = mx(mx(ab(Nx), ab(Ny)), ab(Nz));
        const bool nondegenerate =
            Nm > T(8) * eps * mx(mx(ab(e1x), ab(e1y)), ab(e1z)) * mx(mx(ab(e2x), ab(e2y)), ab(e2z));
        const bool ok = nondegenerate & (t > T(0)) & (t < inf<T>)&(ab(S - s) <= tol);
        out[i] = ok ? t : inf<T>;
    }
}

// Spheres: the note's test (margin 0: as written; 0.001: its §8 fix), isin's default, the textbook
// quadratic and Ray Tracing Gems ch. 7.
enum class SphereMethod { note, note_fix, isin, quadratic, rtg };

template <class T, SphereMethod m>
void spheres(const isin::Ray<T>& ray, const Spheres<T>& b, T* __restrict out) {
    constexpr T eps = std::numeric_limits<T>::epsilon();
    const T ox = ray.origin.x, oy = ray.origin.y, oz = ray.origin.z, dx = ray.direction.x, dy = ray.direction.y,
            dz = ray.direction.z;
    const T a = dx * dx + dy * dy + dz * dz, inv_a = T(1) / a;
    const T omax = mx(mx(ab(ox), ab(oy)), ab(oz));
    for (std::size_t i = 0; i < b.size(); ++i) {
        const T r = b.r[i], r2 = r * r;
        const T lx = b.cx[i] - ox, ly = b.cy[i] - oy, lz = b.cz[i] - oz; // l = C − Ro
        const T l2 = lx * lx + ly * ly + lz * lz;
        T t;
        bool ok;
        if constexpr (m == SphereMethod::note || m == SphereMethod::note_fix) {
            const T s = lx * dx + ly * dy + lz * dz;
            const bool outside = l2 > r2 + (m == SphereMethod::note_fix ? T(0.001) : T(0)); // §8 fix
            const T m2 = l2 - s * s, q = std::sqrt(mx(r2 - m2, T(0)));
            t = outside ? s - q : s + q;
            ok = !((s < T(0)) & outside) & (m2 <= r2);
        } else if constexpr (m == SphereMethod::isin) {
            const T s = (lx * dx + ly * dy + lz * dz) * inv_a;
            const T mxx = lx - s * dx, myy = ly - s * dy, mzz = lz - s * dz;
            const T m2 = mxx * mxx + myy * myy + mzz * mzz;
            const T q = std::sqrt(mx(r2 - m2, T(0)) * inv_a), c = (l2 - r2) * inv_a;
            const T band = T(64) * eps * r * (r + mx(mx(ab(b.cx[i]), ab(b.cy[i])), ab(b.cz[i])) + omax);
            const bool on = ab(l2 - r2) <= band, outside = l2 > r2;
            const T t_on = s > T(0) ? s + q : inf<T>;
            const T t_out = c / (s + q);
            const T t_in = s >= T(0) ? s + q : c / (s - q);
            t = on ? t_on : (outside ? t_out : t_in);
            ok = !((s < T(0)) & outside) & (m2 <= r2);
        } else if constexpr (m == SphereMethod::quadratic) {
            const T bq = -T(2) * (lx * dx + ly * dy + lz * dz), c = l2 - r2;
            const T disc = bq * bq - T(4) * a * c, root = std::sqrt(mx(disc, T(0)));
            const T t0 = (-bq - root) / (T(2) * a), t1 = (-bq + root) / (T(2) * a);
            t = t0 > T(0) ? t0 : t1;
            ok = disc >= T(0);
        } else {                                      // rtg
            const T bq = lx * dx + ly * dy + lz * dz; // b′ = −f·d with f = Ro − C = −l
            const T gx = -lx + (bq * inv_a) * dx, gy = -ly + (bq * inv_a) * dy, gz = -lz + (bq * inv_a) * dz;
            const T delta = r2 - (gx * gx + gy * gy + gz * gz), c = l2 - r2;
            const T q = bq + std::copysign(std::sqrt(mx(a * delta, T(0))), bq);
            const T ta = c / q, tb = q / a;
            const T tn = ta < tb ? ta : tb, tf = ta < tb ? tb : ta;
            t = tn > T(0) ? tn : tf;
            ok = delta >= T(0);
        }
        ok = ok & (r > T(0)) & (t > T(0)) & (t < inf<T>);
        out[i] = ok ? t : inf<T>;
    }
}

} // namespace batch
