// Rectangular area lights: the mean of point lights over a rectangle, estimated from stratified
// samples (convergence to dense quadrature, penumbrae, determinism across threads and bands).
#include <isin/area_light.hpp>
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace {

// A white diffuse floor (kd = 1, no ambient or highlight) at y = −10 under a 20 × 20 RectLight at
// y = 20; with `edge`, an opaque plane at y = 10 over x < 0 throws a penumbra along x ≈ 0.
template <class T>
struct FloorScene {
    static constexpr T floor_y = T(-10), light_y = T(20), occluder_y = T(10);
    isin::Scene<T, isin::Triangle> scene;
    isin::RectLight<T> light{{-10, light_y, 50}, {20, 0, 0}, {0, 0, 20}, {T(0.9), T(0.9), T(0.9)}};
    bool edge;
    explicit FloorScene(bool with_edge) : edge(with_edge) {
        isin::Material<T> white;
        white.ka = T(0), white.kd = T(1), white.ks = T(0);
        const auto m = scene.add_material(white);
        scene.add(isin::Triangle<T>{{-500, floor_y, 0}, {-500, floor_y, 500}, {500, floor_y, 0}}, m);
        scene.add(isin::Triangle<T>{{500, floor_y, 500}, {500, floor_y, 0}, {-500, floor_y, 500}}, m);
        if (edge) {
            scene.add(isin::Triangle<T>{{-900, occluder_y, -500}, {0, occluder_y, 900}, {0, occluder_y, -500}}, m);
            scene.add(isin::Triangle<T>{{-900, occluder_y, -500}, {-900, occluder_y, 900}, {0, occluder_y, 900}}, m);
        }
        scene.add_light(light);
    }
    // The mean over the rectangle of kd·(N·L)·colour·visibility at floor point P, by the midpoint
    // rule on gu × gv points; visibility in closed form (the occluder's edge is the line x = 0).
    [[nodiscard]] double exact(const isin::Vertex<T>& P, int gu = 1024, int gv = 16) const {
        double sum = 0;
        const double h = (double(occluder_y) - double(P.y)) / (double(light_y) - double(P.y));
        for (int j = 0; j < gv; ++j)
            for (int i = 0; i < gu; ++i) {
                const double qx = double(light.corner.x) + (i + 0.5) / gu * double(light.edge_u.x);
                const double qz = double(light.corner.z) + (j + 0.5) / gv * double(light.edge_v.z);
                const double dx = qx - double(P.x), dy = double(light_y) - double(P.y), dz = qz - double(P.z);
                if (edge && double(P.x) + (qx - double(P.x)) * h < 0) continue; // §9: behind the occluder
                sum += dy / std::sqrt(dx * dx + dy * dy + dz * dz);             // §7: N·L with N = +y
            }
        return sum / (double(gu) * gv) * double(light.color.r);
    }
};

// Per pixel of a render of `fs` (w × h, the note's camera at the origin looking along +z, tilted
// down), the difference in levels between its red byte and 255·exact at its floor point.
template <class T>
std::vector<double> errors(const FloorScene<T>& fs, int w, int h, const isin::RenderOptions& opt) {
    const isin::Camera<T> camera{w, h, {0, 0, 0}, T(0), T(-0.6)};
    const isin::Image image = isin::render(fs.scene, camera, opt);
    std::vector<double> out;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const isin::Ray<T> ray = camera.primary_ray(T(x), T(y));
            const auto hit = fs.scene.intersect(ray);
            if (!hit || !(ray.direction.y < T(0))) continue;
            const isin::Vertex<T> P = ray.origin + hit.t * ray.direction;
            if (std::abs(double(P.y) - double(fs.floor_y)) > 1e-3) continue; // the occluder, seen from below
            out.push_back(double(image(x, y).r) - 255 * fs.exact(P));
        }
    return out;
}

// FloorScene with an opaque rectangle [x0, x1] × [z0, z1] at y = 10; by default a bar 2 wide along z
// under the light's middle: from the floor below it hides a strip of the light across its whole
// depth, and none of its corners.
template <class T>
struct BarScene : FloorScene<T> {
    explicit BarScene(T x0 = -1, T x1 = 1, T z0 = -500, T z1 = 900) : FloorScene<T>(false) {
        const auto m = this->scene.add_material(isin::Material<T>{});
        this->scene.add(isin::Triangle<T>{{x0, 10, z0}, {x0, 10, z1}, {x1, 10, z0}}, m);
        this->scene.add(isin::Triangle<T>{{x1, 10, z1}, {x1, 10, z0}, {x0, 10, z1}}, m);
    }
};

struct Summary {
    double mean = 0, rms = 0, worst = 0;
    std::size_t n = 0;
};
Summary summarise(const std::vector<double>& e) {
    Summary s;
    for (const double d : e) s.mean += d, s.rms += d * d, s.worst = std::max(s.worst, std::abs(d));
    s.n = e.size();
    if (s.n) s.mean /= double(s.n), s.rms = std::sqrt(s.rms / double(s.n));
    return s;
}

} // namespace

TEST_CASE("RectLight: braced add_light calls still add PointLights; a RectLight goes to rect_lights") {
    isin::Scene<float, isin::Sphere> scene;
    scene.add_light({{0, 40, 0}});
    scene.add_light({{1, 2, 3}, {0.5f, 0.5f, 0.5f}});
    CHECK(scene.lights.size() == 2);
    CHECK(scene.rect_lights.empty());
    CHECK(scene.lights[0].position == isin::Vec3f{0, 40, 0});
    scene.add_light(isin::RectLight<float>{{-1, 10, -1}, {2, 0, 0}, {0, 0, 2}});
    CHECK(scene.lights.size() == 2);
    REQUIRE(scene.rect_lights.size() == 1);
    CHECK(scene.rect_lights[0].edge_u == isin::Vec3f{2, 0, 0});
}

TEST_CASE("light_strata: nu × nv = samples, nv the largest divisor up to √samples, the longer edge divided more") {
    CHECK(isin::light_strata(16, 1.0, 1.0).nu == 4);
    CHECK(isin::light_strata(16, 1.0, 1.0).nv == 4);
    CHECK(isin::light_strata(8, 2.0, 1.0).nu == 4);
    CHECK(isin::light_strata(8, 2.0, 1.0).nv == 2);
    CHECK(isin::light_strata(8, 1.0, 2.0).nu == 2);
    CHECK(isin::light_strata(7, 1.0, 1.0).nu * isin::light_strata(7, 1.0, 1.0).nv == 7);
    CHECK(isin::light_strata(4096, 1.0, 1.0).nu == 64);
    CHECK(isin::light_strata(0, 1.0, 1.0).nu * isin::light_strata(0, 1.0, 1.0).nv == 1);
}

TEST_CASE_TEMPLATE("light_sample: sample k lies in stratum k; the same seed gives the same point", T, float, double) {
    const isin::RectLight<T> light{{1, 2, 3}, {4, 0, 0}, {0, 0, 2}};
    const auto strata = isin::light_strata(12, T(4), T(2)); // 4 × 3
    REQUIRE(strata.nu == 4);
    for (std::uint64_t seed : {1ull, 99ull, 0xFFFFFFFFFFFFull})
        for (int k = 0; k < 12; ++k) {
            const isin::Vertex<T> q = isin::light_sample(light, strata, seed, k);
            const T u = (q.x - T(1)) / T(4), v = (q.z - T(3)) / T(2);
            CHECK(u * T(4) >= T(k % 4) - T(1e-5));
            CHECK(u * T(4) <= T(k % 4 + 1) + T(1e-5));
            CHECK(v * T(3) >= T(k / 4) - T(1e-5));
            CHECK(v * T(3) <= T(k / 4 + 1) + T(1e-5));
            CHECK(q == isin::light_sample(light, strata, seed, k));
        }
}

TEST_CASE_TEMPLATE("light_sample: multi-jittered, the u of the N samples in N distinct strata, and their v", T, float,
                   double) {
    const isin::RectLight<T> light{{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
    for (int n : {16, 12, 7, 64}) {
        const auto strata = isin::light_strata(n, T(1), T(1));
        std::vector<int> u_count(std::size_t(n), 0), v_count(std::size_t(n), 0);
        for (int k = 0; k < n; ++k) {
            const isin::Vertex<T> q = isin::light_sample(light, strata, 12345u, k);
            ++u_count[std::size_t(std::min(n - 1, int(q.x * T(n))))];
            ++v_count[std::size_t(std::min(n - 1, int(q.z * T(n))))];
        }
        CAPTURE(n);
        CHECK(*std::min_element(u_count.begin(), u_count.end()) == 1);
        CHECK(*std::min_element(v_count.begin(), v_count.end()) == 1);
    }
}

TEST_CASE_TEMPLATE("RectLight on a diffuse floor: every pixel within 1 level of dense quadrature at 256 samples", T,
                   float, double) {
    const FloorScene<T> fs(false);
    isin::RenderOptions opt;
    opt.light_samples = 256;
    for (bool adaptive : {false, true}) {
        opt.adaptive_light_samples = adaptive;
        const Summary s = summarise(errors(fs, 32, 18, opt));
        CAPTURE(adaptive);
        CHECK(s.n > 100);
        CHECK(s.worst <= 1.0);
    }
}

TEST_CASE_TEMPLATE("RectLight penumbra behind an edge: mean ≤ 0.5, RMS ≤ 1.5, worst ≤ 6 levels at 256 samples; "
                   "every pixel within 2 at 1,024",
                   T, float, double) {
    const FloorScene<T> fs(true);
    isin::RenderOptions opt;
    opt.adaptive_light_samples = false;
    opt.light_samples = 256;
    const Summary s = summarise(errors(fs, 32, 18, opt));
    CHECK(s.n > 100);
    CHECK(std::abs(s.mean) <= 0.5);
    CHECK(s.rms <= 1.5);
    CHECK(s.worst <= 6.0);
    opt.light_samples = 1024;
    CHECK(summarise(errors(fs, 32, 18, opt)).worst <= 2.0);
    opt.adaptive_light_samples = true; // the edge hides a corner from every penumbra point: adaptive is exact too
    CHECK(summarise(errors(fs, 32, 18, opt)).worst <= 2.0);
}

TEST_CASE_TEMPLATE("rect_light_term: the penumbra's RMS error falls at least as fast as samples^-1/2", T, float,
                   double) {
    const FloorScene<T> fs(true);
    // Floor points across the penumbra (x from −12 to 12).
    std::vector<isin::Vertex<T>> points;
    for (int i = 0; i < 64; ++i) points.push_back({T(-12) + T(24) * T(i) / T(63), fs.floor_y, T(60)});
    std::vector<double> exact;
    for (const auto& P : points) exact.push_back(fs.exact(P));
    double previous = 0;
    for (int samples : {4, 16, 64, 256}) {
        double sum = 0;
        std::uint64_t rays = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const isin::LitPoint<T> p{points[i], points[i] + isin::Vertex<T>{0, T(1e-3), 0},
                                      {0, 1, 0}, {0, 1, 0},
                                      T(1),      T(0),
                                      T(1),      {1, 1, 1},
                                      {1, 1, 1}};
            isin::LightSampling s;
            s.samples = samples, s.adaptive = false;
            const auto c = isin::rect_light_term(fs.scene, fs.light, p, isin::light_seed(points[i], 0), s, rays);
            sum += (double(c.r) - exact[i]) * (double(c.r) - exact[i]);
        }
        const double rms = std::sqrt(sum / double(points.size()));
        CAPTURE(samples);
        CAPTURE(rms);
        if (previous > 0) CHECK(rms <= previous / 2 * 1.05); // 4× the samples: at least half the error
        previous = rms;
    }
}

TEST_CASE_TEMPLATE("rect_light_term: from 64 samples, adaptive probes find an occluder that hides no corner", T, float,
                   double) {
    const BarScene<T> fs;
    int same = 0;
    double adaptive_sum = 0, uniform_sum = 0, open_sum = 0;
    const int points = 64;
    for (int i = 0; i < points; ++i) {
        const isin::Vertex<T> P{T(-3) + T(6) * T(i) / T(points - 1), fs.floor_y, T(60)};
        const isin::LitPoint<T> p{
            P, P + isin::Vertex<T>{0, T(1e-3), 0}, {0, 1, 0}, {0, 1, 0}, T(1), T(0), T(1), {1, 1, 1}, {1, 1, 1}};
        std::uint64_t rays = 0;
        isin::LightSampling s;
        s.samples = 64;
        const auto seed = isin::light_seed(P, 0);
        const auto adaptive = isin::rect_light_term(fs.scene, fs.light, p, seed, s, rays);
        s.adaptive = false;
        const auto uniform = isin::rect_light_term(fs.scene, fs.light, p, seed, s, rays);
        s.shadows = false;
        const auto open = isin::rect_light_term(fs.scene, fs.light, p, seed, s, rays);
        same += adaptive.r == uniform.r;
        adaptive_sum += double(adaptive.r), uniform_sum += double(uniform.r), open_sum += double(open.r);
    }
    CAPTURE(same);
    CHECK(uniform_sum < 0.95 * open_sum); // the bar shadows
    CHECK(same >= points * 9 / 10);       // where the probes see it, every sample is traced: uniform's bits
    CHECK(std::abs(adaptive_sum - uniform_sum) < 0.01 * uniform_sum);
}

TEST_CASE_TEMPLATE("rect_light_terms_together: each point's rect_light_term, bit for bit and ray for ray", T, float,
                   double) {
    const FloorScene<T> fs(true); // the edge x = 0 at y = 10 crosses the light from every point below
    constexpr int G = isin::together_points;
    for (const int samples : {1, 7, 16, 64, 256})
        for (const bool opaque : {true, false}) {
            CAPTURE(samples);
            CAPTURE(opaque);
            isin::LitPoint<T> p[G];
            std::uint64_t seed[G];
            for (int j = 0; j < G; ++j) {
                const isin::Vertex<T> P{T(-6) + T(12) * T(j) / T(G - 1), fs.floor_y, T(60) + T(0.1) * T(j)};
                const T shininess = j % 2 ? T(7.5) : T(20); // std::pow, then lane_power
                p[j] = {P,         P + isin::Vertex<T>{0, T(1e-3), 0},
                        {0, 1, 0}, {0, 1, 0},
                        T(0.8),    T(0.5),
                        shininess, {1, T(0.5), T(0.25)},
                        {1, 1, 1}};
                seed[j] = isin::light_seed(P, 0);
            }
            isin::LightSampling s;
            s.samples = samples, s.adaptive = false, s.opaque = opaque;
            isin::Color<T> together[G];
            std::uint64_t together_rays = 0, own_rays = 0;
            isin::rect_light_terms_together(fs.scene, fs.light, p, seed, G, s, together_rays, together);
            int shadowed = 0, compared = 0;
            for (int j = 0; j < G; ++j) {
                const auto own = isin::rect_light_term(fs.scene, fs.light, p[j], seed[j], s, own_rays);
                CHECK(together[j].r == own.r);
                CHECK(together[j].g == own.g);
                CHECK(together[j].b == own.b);
                shadowed += own.r < together[G - 1].r;
                // With corners first: where they disagree, every sample's ray, as without.
                isin::LightSampling adaptive = s;
                adaptive.adaptive = true;
                isin::Ray<T> rays[4];
                T one[4] = {1, 1, 1, 1}, seen[4];
                for (int c = 0; c < 4; ++c) rays[c] = {p[j].from, isin::light_corner(fs.light, c) - p[j].from};
                isin::detail::shadow_visibility(fs.scene, rays, 4, opaque, one, seen);
                bool agree = true;
                if (!isin::corners_first(adaptive) || isin::detail::corner_vote(fs.light, p[j], seen, agree) < T(0) ||
                    agree)
                    continue;
                std::uint64_t rays_after_corners = 0;
                const auto after =
                    isin::rect_light_term(fs.scene, fs.light, p[j], seed[j], adaptive, rays_after_corners, seen);
                CHECK(after.r == together[j].r);
                CHECK(after.b == together[j].b);
                ++compared;
            }
            CHECK(together_rays == own_rays);
            if (samples > 1) CHECK(shadowed >= G / 4); // the edge hides part of the light from the left points
            if (samples >= 8) CHECK(compared >= G / 2);
        }
}

TEST_CASE("StrataWalk: every stratum once; 16 in a row fill a 4 × 4 square where the grid allows") {
    const std::uint32_t grids[][2] = {{1, 1},  {4, 4},  {8, 8},  {16, 16}, {32, 32}, {64, 64}, {16, 8},
                                      {8, 16}, {12, 4}, {4, 12}, {7, 3},   {5, 1},   {24, 8},  {10, 10}};
    for (const auto& g : grids)
        for (std::uint32_t step : {1u, 2u}) {
            const std::uint32_t gu = g[0], gv = g[1], n = gu * gv;
            CAPTURE(gu);
            CAPTURE(gv);
            CAPTURE(step);
            std::vector<int> visits(n, 0);
            std::uint32_t column[64], row[64];
            bool squares = true;
            isin::detail::StrataWalk walk(gu, gv, step, step);
            for (std::uint32_t t0 = 0; t0 < n; t0 += 64) {
                const int count = int(std::min<std::uint32_t>(64, n - t0));
                walk.next(count, column, row);
                for (int k = 0; k < count; ++k) {
                    REQUIRE(column[k] % step == 0);
                    REQUIRE(row[k] % step == 0);
                    REQUIRE(column[k] / step < gu);
                    REQUIRE(row[k] / step < gv);
                    ++visits[column[k] / step + row[k] / step * gu];
                }
                for (int k = 0; k + 16 <= count; k += 16) { // a packet's strata: within 4 × 4 of the grid
                    const auto [i_lo, i_hi] = std::minmax_element(column + k, column + k + 16);
                    const auto [j_lo, j_hi] = std::minmax_element(row + k, row + k + 16);
                    squares = squares && *i_hi - *i_lo == 3 * step && *j_hi - *j_lo == 3 * step;
                }
            }
            CHECK(std::count(visits.begin(), visits.end(), 1) == int(n));
            if (gu % 4 == 0 && gv % 4 == 0) CHECK(squares);
        }
}

TEST_CASE_TEMPLATE("rect_light_term: a penumbra found by the probes reuses every probe, up to 1,024 samples", T, float,
                   double) {
    // From P a patch hides part of the light's far quarter (u about 0.7 to 0.85, v 0.75 to 0.9) and
    // none of its corners: the corners see the light, and only the last probes disagree (from 256
    // samples: at 64 the probes may all miss a patch this small).
    const BarScene<T> fs(T(2.8), T(4.7), T(63.4), T(65.3));
    const isin::Vertex<T> P{T(0.3), fs.floor_y, T(60)};
    const isin::LitPoint<T> p{
        P, P + isin::Vertex<T>{0, T(1e-3), 0}, {0, 1, 0}, {0, 1, 0}, T(1), T(0), T(1), {1, 1, 1}, {1, 1, 1}};
    for (int samples : {256, 1024}) {
        CAPTURE(samples);
        isin::LightSampling s;
        s.samples = samples;
        std::uint64_t adaptive_rays = 0, uniform_rays = 0;
        const auto seed = isin::light_seed(P, 0);
        const auto adaptive = isin::rect_light_term(fs.scene, fs.light, p, seed, s, adaptive_rays);
        s.adaptive = false;
        const auto uniform = isin::rect_light_term(fs.scene, fs.light, p, seed, s, uniform_rays);
        CHECK(uniform_rays == std::uint64_t(samples));
        CHECK(adaptive_rays == std::uint64_t(samples) + 4u); // the corners, then each sample once
        CHECK(double(adaptive.r) < 0.99 * fs.exact(P));      // the patch shadows
        CHECK(adaptive.r == doctest::Approx(double(uniform.r)).epsilon(1e-5));
    }
}

TEST_CASE_TEMPLATE("RectLight renders: the same pixels on 1 and 2 threads, in bands, and as trace() gives them", T,
                   float, double) {
    FloorScene<T> fs(true);
    isin::Material<T> shiny;
    shiny.kd = T(0.5), shiny.ks = T(0.5), shiny.shininess = T(20);
    fs.scene.add(isin::Triangle<T>{{-5, -9, 40}, {5, -9, 40}, {0, 5, 45}}, fs.scene.add_material(shiny));
    const isin::Camera<T> camera{40, 24, {0, 0, 0}, T(0), T(-0.5)};
    isin::RenderOptions opt;
    opt.light_samples = 16;
    for (bool adaptive : {false, true}) {
        opt.adaptive_light_samples = adaptive;
        opt.threads = 1;
        const isin::Image one = isin::render(fs.scene, camera, opt);
        opt.threads = 2;
        const isin::Image two = isin::render(fs.scene, camera, opt);
        CHECK(one.pixels() == two.pixels());
        CHECK(one.pixels() == isin::render(fs.scene, camera, opt).pixels());
        int differ = 0;
        for (int b = 0; b < 3; ++b) {
            const isin::RowBand band = isin::row_band(24, b, 3);
            const isin::Image part = isin::render_rows(fs.scene, camera, band.first, band.rows, opt);
            for (int y = 0; y < band.rows; ++y)
                for (int x = 0; x < 40; ++x) differ += part(x, y) != one(x, band.first + y);
        }
        CHECK(differ == 0);
        isin::RenderStats stats;
        int lit = 0;
        for (int y = 0; y < 24; ++y)
            for (int x = 0; x < 40; ++x) {
                const auto c = isin::trace(fs.scene, camera.primary_ray(T(x), T(y)), 0, opt, stats);
                CHECK(isin::to_rgb8(c) == one(x, y));
                lit += one(x, y).r > 0;
            }
        CHECK(lit > 100);
    }
}

TEST_CASE("render: light_samples outside [1, max_light_samples] throws") {
    FloorScene<float> fs(false);
    const isin::Camera<float> camera{8, 8};
    isin::RenderOptions opt;
    for (int bad : {0, -3, isin::RenderOptions::max_light_samples + 1}) {
        opt.light_samples = bad;
        CHECK_THROWS_AS((void)isin::render(fs.scene, camera, opt), std::invalid_argument);
    }
    opt.light_samples = 1;
    CHECK_NOTHROW((void)isin::render(fs.scene, camera, opt));
}

namespace {
// The unshadowed mean over `light` of kd·N·L + ks·(Rf·V)^n at p (the red channel, colours 1), by the
// midpoint rule on g × g points in double.
template <class T>
double unshadowed_mean(const isin::RectLight<T>& light, const isin::LitPoint<T>& p, int g = 512) {
    double sum = 0;
    const auto d = [](T x) { return double(x); };
    const double nv = d(p.N.x) * d(p.V.x) + d(p.N.y) * d(p.V.y) + d(p.N.z) * d(p.V.z);
    const double R[3] = {2 * nv * d(p.N.x) - d(p.V.x), 2 * nv * d(p.N.y) - d(p.V.y), 2 * nv * d(p.N.z) - d(p.V.z)};
    for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
            const double u = (i + 0.5) / g, v = (j + 0.5) / g;
            double L[3] = {d(light.corner.x) + u * d(light.edge_u.x) + v * d(light.edge_v.x) - d(p.point.x),
                           d(light.corner.y) + u * d(light.edge_u.y) + v * d(light.edge_v.y) - d(p.point.y),
                           d(light.corner.z) + u * d(light.edge_u.z) + v * d(light.edge_v.z) - d(p.point.z)};
            const double len = std::sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
            for (double& x : L) x /= len;
            const double nl = L[0] * d(p.N.x) + L[1] * d(p.N.y) + L[2] * d(p.N.z); // §7: N·L
            const double c = L[0] * R[0] + L[1] * R[1] + L[2] * R[2];              // §7: Rf·V = L·R
            if (nl > 0) sum += d(p.kd) * nl + (c > 0 ? d(p.ks) * std::pow(c, d(p.shininess)) : 0.0);
        }
    return sum / (double(g) * g);
}
} // namespace

TEST_CASE_TEMPLATE("rect_light_term: where the corners see the whole light, Gauss–Legendre gives its mean", T, float,
                   double) {
    const FloorScene<T> fs(false);
    int smooth = 0, rough = 0;
    for (int samples : {16, 64, 256})
        for (int i = 0; i < 24; ++i) {
            // Floor points under and beside the light, seen from above at varied angles; a highlight of
            // shininess 20 (or none, or 200: too narrow for the rule where it points at the light).
            const isin::Vertex<T> P{T(-40) + T(80) * T(i % 8) / T(7), fs.floor_y, T(20) + T(15) * T(i / 8)};
            isin::Vertex<T> V{T(0.3) * T(i % 3) - T(0.3), T(1), T(0.2) * T(i % 5) - T(0.4)};
            V = V / isin::length(V);
            const T ks = i % 4 == 3 ? T(0) : T(0.5), shininess = i % 4 == 2 ? T(200) : T(20);
            const isin::LitPoint<T> p{
                P, P + isin::Vertex<T>{0, T(1e-3), 0}, {0, 1, 0}, V, T(0.5), ks, shininess, {1, 1, 1}, {1, 1, 1}};
            const T min_cos = std::exp2(T(-24) / shininess);
            const int order = isin::detail::smooth_order(fs.light, p, ks != T(0), min_cos, samples);
            isin::LightSampling s;
            s.samples = samples;
            std::uint64_t rays = 0;
            const auto adaptive = isin::rect_light_term(fs.scene, fs.light, p, isin::light_seed(P, 0), s, rays);
            CAPTURE(samples);
            CAPTURE(i);
            CHECK(rays ==
                  4u); // the corners only: from 64 samples the shaft to the light is clear (the floor is below it)
            if (order == 0) {
                ++rough;
                s.adaptive = false; // no quadrature: the samples, as uniform shades them where all are lit
                rays = 0;
                CHECK(adaptive.r == isin::rect_light_term(fs.scene, fs.light, p, isin::light_seed(P, 0), s, rays).r);
                continue;
            }
            ++smooth;
            const double exact = unshadowed_mean(fs.light, p) * double(fs.light.color.r);
            CHECK(std::abs(double(adaptive.r) - exact) <= 1e-4 * 0.9 + (sizeof(T) == 4 ? 2e-6 : 0.0));
        }
    CHECK(smooth > 24); // the rule applies to most points here, and not to all
    CHECK(rough > 6);
}
