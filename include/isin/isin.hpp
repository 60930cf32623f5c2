#pragma once
/// isin — a header-only C++17 ray tracer built from the lecture note "Işın İzleme".
///
/// Usage:
///     #include <isin/isin.hpp>
///     isin::Camera<float> cam{800, 450};                         // note §3: eye at 0, 16×9 at z = 10
///     isin::Triangle<float> blue{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}};
///     isin::Sphere<float> ball{{0, 0, 60}, 5};
///     isin::Ray<float> ray = cam.primary_ray(399.5f, 224.5f);    // through GD = (0, 0, 10)
///     if (auto h = isin::intersect_moller_trumbore(ray, blue))   // §10: t and barycentrics u, v
///         std::printf("t = %g, u = %g, v = %g\n", h.t, h.u, h.v);
///     if (auto h = isin::intersect(ray, ball)) std::printf("sphere at t = %g\n", h.t); // §6
///
/// Headers, one concept each: vec (§2), ray (§3), hit, camera (§3), triangle (§4, §10), sphere (§6).
#include "camera.hpp"
#include "hit.hpp"
#include "ray.hpp"
#include "sphere.hpp"
#include "triangle.hpp"
#include "vec.hpp"
