// Fresnel's equations for a dielectric (fresnel_reflectance, fresnel_dielectric) and the renderer's
// glass with Material::fresnel: closed forms at normal incidence, Brewster's angle, total internal
// reflection, energy conservation, and a glass slab's transmission.
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"

#include <cmath>

TEST_CASE_TEMPLATE("Fresnel at normal incidence: R = ((n − 1)/(n + 1))², from either side", T, float, double) {
    for (const T n : {T(1.33), T(1.5), T(2.4)}) {
        const T expected = (n - T(1)) / (n + T(1)) * ((n - T(1)) / (n + T(1)));
        CHECK(isin::fresnel_dielectric(T(1), T(1) / n) == approx(expected).epsilon(1e-5));
        CHECK(isin::fresnel_dielectric(T(-1), n) == approx(expected).epsilon(1e-5)); // leaving the glass
        const auto r = isin::fresnel_reflectance(T(1), T(1) / n);
        CHECK(r.s == approx(r.p).epsilon(1e-5)); // no plane of incidence: both alike
    }
    CHECK(isin::fresnel_dielectric(T(1), T(1)) == T(0)); // ior 1: nothing reflected
}

TEST_CASE_TEMPLATE("Fresnel at Brewster's angle tan θB = n2/n1: no p-polarised reflection, s-polarised left", T, float,
                   double) {
    for (const T n : {T(1.33), T(1.5), T(2.4)}) {
        const T cos_b = std::cos(std::atan(n)); // entering
        const auto r = isin::fresnel_reflectance(cos_b, T(1) / n);
        CHECK(std::abs(r.p) < T(1e-6));
        CHECK(r.s > T(0.01));
        const T cos_b_inside = std::cos(std::atan(T(1) / n)); // leaving
        CHECK(std::abs(isin::fresnel_reflectance(cos_b_inside, n).p) < T(1e-6));
    }
}

TEST_CASE_TEMPLATE("Fresnel: total internal reflection reflects everything; grazing incidence reflects everything", T,
                   float, double) {
    const T n = T(1.5), critical = std::sqrt(T(1) - T(1) / (n * n)); // cos of the critical angle
    CHECK(isin::fresnel_dielectric(critical * T(0.99), n) == T(1));
    CHECK(isin::fresnel_dielectric(T(0.1), n) == T(1));
    CHECK(isin::fresnel_dielectric(critical * T(1.01), n) < T(1));
    CHECK(isin::fresnel_dielectric(T(0), T(1) / n) == approx(1).epsilon(1e-6));
    const T nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(isin::fresnel_dielectric(nan, n) == T(1)); // defined, in [0, 1]
    CHECK(isin::fresnel_dielectric(T(0.5), nan) == T(1));
}

TEST_CASE_TEMPLATE("Fresnel: R + T = 1 for each polarisation, T from the transmission amplitudes", T, float, double) {
    for (const T n : {T(1.33), T(1.5)})
        for (const T eta : {T(1) / n, n})
            for (int k = 1; k <= 20; ++k) {
                const T c1 = T(k) / T(20), sin2_t = eta * eta * (T(1) - c1 * c1);
                if (!(sin2_t < T(1))) continue;
                const T c2 = std::sqrt(T(1) - sin2_t);
                // Fresnel: t_s = 2 n1 cos θ1/(n1 cos θ1 + n2 cos θ2), t_p = 2 n1 cos θ1/(n2 cos θ1 + n1 cos θ2),
                // T = (n2 cos θ2)/(n1 cos θ1)·t²; with n2 = 1, n1 = eta.
                const T ts = T(2) * eta * c1 / (eta * c1 + c2), tp = T(2) * eta * c1 / (c1 + eta * c2);
                const T factor = c2 / (eta * c1);
                const auto r = isin::fresnel_reflectance(c1, eta);
                CAPTURE(c1);
                CHECK(r.s + factor * ts * ts == approx(1).epsilon(1e-5));
                CHECK(r.p + factor * tp * tp == approx(1).epsilon(1e-5));
            }
}

namespace {
// A glass slab (z from 10 to 12, faces turned outwards, ior 1.5, Material::fresnel, no local
// colour) in front of a wall of ambient white at z = 50 (colour 1 wherever a ray meets it), on a
// black background.
template <class T>
isin::Scene<T, isin::Triangle> slab_scene(bool fresnel) {
    isin::Scene<T, isin::Triangle> scene;
    isin::Material<T> glass;
    glass.ka = glass.kd = glass.ks = T(0);
    glass.transparency = T(1), glass.ior = T(1.5), glass.fresnel = fresnel;
    isin::Material<T> wall;
    wall.ka = T(1), wall.kd = wall.ks = T(0);
    const auto g = scene.add_material(glass), w = scene.add_material(wall);
    const T s = T(1000);
    const auto quad = [&](T z, bool towards_plus_z, std::uint32_t m) {
        const isin::Vertex<T> a{-s, -s, z}, b{-s, s, z}, c{s, -s, z}, d{s, s, z};
        if (towards_plus_z)
            scene.add(isin::Triangle<T>{a, c, b}, m), scene.add(isin::Triangle<T>{d, b, c}, m);
        else
            scene.add(isin::Triangle<T>{a, b, c}, m), scene.add(isin::Triangle<T>{d, c, b}, m);
    };
    quad(T(10), false, g);
    quad(T(12), true, g);
    quad(T(50), false, w);
    return scene;
}
} // namespace

TEST_CASE_TEMPLATE("Material::fresnel: a glass slab transmits (1 − R)²(1 + R² + …) head-on and at 60°, to the depth "
                   "traced",
                   T, float, double) {
    const auto scene = slab_scene<T>(true);
    for (const T degrees : {T(0), T(60)}) {
        const T a = degrees * T(3.14159265358979) / T(180);
        const isin::Ray<T> ray{{0, 0, 0}, {std::sin(a), 0, std::cos(a)}};
        const T R = isin::fresnel_dielectric(std::cos(a), T(1) / T(1.5)); // the same R inside (reciprocity)
        CHECK(isin::fresnel_dielectric(std::sqrt(T(1) - std::sin(a) * std::sin(a) / T(2.25)), T(1.5)) ==
              approx(R).epsilon(1e-4));
        for (int depth : {2, 4, 6}) {
            isin::RenderOptions opt;
            opt.max_depth = depth;
            isin::RenderStats stats;
            const isin::Color<T> c = isin::trace(scene, ray, 0, opt, stats);
            double expected = 0; // each round trip inside the slab costs two more levels
            for (int k = 0; 2 + 2 * k <= depth; ++k) expected += std::pow(double(R), 2 * k);
            expected *= (1 - double(R)) * (1 - double(R));
            CAPTURE(degrees);
            CAPTURE(depth);
            CHECK(std::abs(255 * double(c.r) - 255 * expected) <= 2.0);
            CHECK(double(c.r) == approx(expected).epsilon(1e-4));
        }
    }
    // Without fresnel the fixed weights stay: transparency 1 lets everything through.
    isin::RenderOptions opt;
    isin::RenderStats stats;
    const auto fixed = slab_scene<T>(false);
    CHECK(isin::trace(fixed, isin::Ray<T>{{0, 0, 0}, {0, 0, 1}}, 0, opt, stats).r == approx(1).epsilon(1e-5));
}

TEST_CASE_TEMPLATE("Material::fresnel: render's streams give trace()'s colours", T, float, double) {
    const auto scene = slab_scene<T>(true);
    const isin::Camera<T> camera{24, 16, {0, 0, 0}, T(0.6), T(0)};
    isin::RenderOptions opt;
    opt.threads = 1;
    const isin::Image image = isin::render(scene, camera, opt);
    isin::RenderStats stats;
    int lit = 0;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 24; ++x) {
            CHECK(isin::to_rgb8(isin::trace(scene, camera.primary_ray(T(x), T(y)), 0, opt, stats)) == image(x, y));
            lit += image(x, y).r > 100;
        }
    CHECK(lit > 300);
}
