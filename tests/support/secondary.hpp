#pragma once
// The secondary-ray workload of isin's accuracy study (issue 15, point 4), shared by
// benchmarks/offsets.cpp and tests/test_stability.cpp: where shadow, reflected and refracted rays
// start, for each offset method side by side, on the same primary hits.
//
// Scenes, in float and double, at scale s ∈ {1e-3, 1, 1e3} and centred D ∈ {0, 1e3, 1e4, 1e6} from
// the origin (along (0.36, −0.48, 0.8)), seen from an eye 4, 100 or 1000 object radii away (in a
// random direction per primary ray):
//   trefoil  the knot tube of benchmarks/meshes.hpp, 96 × 12 quads (2,304 triangles) spanning
//            about 2s: strands shadow each other; traced with an isin::Bvh
//   bumpy    an icosphere (level 4, 5,120 triangles) of radius s with smooth radial bumps of
//            up to ±30%: concave edges, occluders right next to the surface
//   spheres  a sphere of radius r = s (or 64 float ulps of D wide, "64ulp") and 8 pebbles of
//            0.15–0.3 r floating 0.2–5% of their radius above it, on the side of the light
// For each primary hit: a shadow ray towards a point light (when the light is in front of the
// surface), the reflected ray, and on the large sphere the refracted ray (index 1.5, inward: it
// must hit the far side, about 1.5–2 r away). Each method works with the normal its pipeline has,
// for the light's side, the directions and the side it offsets to: isin's methods the triangle's
// geometric normal, or on spheres isin::normal_at(sphere, Ro + t·Rd) for none and fixed (the old
// pipeline) and isin::normal_at(ray, sphere, hit) otherwise (the renderer's); pbrt-v4 its
// object-space normal pHit/r.
//
// Offset methods (Offset):
//   none            Ro + t·Rd, the raw hit point
//   hit_point       isin::hit_point, no offset (barycentric or reprojected point; isin's sphere
//                   test's on-surface band is made for restarts from it)
//   fixed           isin::offset_origin(Ro + t·Rd, n, max|Ro|), the old rule, as the renderer did
//   error_bound     isin::offset_ray_origin(isin::hit_point(…)) and isin::shadow_ray: isin's new rule
//   pbrt_v4         a reference written here from pbrt-v4 (interaction.h, ray.h OffsetRayOrigin,
//                   shapes.h): triangles by barycentrics + γ7; spheres in object space (centre at
//                   0), reprojected with γ5, then moved by the translation with its error
//   wachter_binder  Ray Tracing Gems ch. 6 (Wächter & Binder): hit_point's point (barycentric, as
//                   the chapter recommends; reprojected for spheres) moved along the normal by
//                   int(256·n) ulps per component (|p| < 1/32: by n/65536); float only — not
//                   applicable to double
//
// Metrics per case and method (OffsetStats): self-hits (a reflected or shadow ray that hits the
// primitive it starts on — the same triangle, the same sphere; a refracted ray that hits its sphere
// at t < chord/2: the entry side), refraction failures (no hit at all, or beyond 1.5 chords),
// lost occlusions (shadow rays that a reference finds blocked while the method's ray is not: the
// reference leaves from the exact hit point — computed in long double from the primary ray and
// the hit triangle or sphere — and is tested in long double against the scene without the start
// primitive; a mesh's candidates come from a double Bvh along the slightly lengthened segment),
// false occlusions (the method's shadow ray blocked by another primitive where the
// reference is not), and offset size |origin − exact hit point| in diagonals of the start object's
// bounding box (a triangle mesh's; a sphere's own, 2√3·r): median and maximum.
//
// Float cannot place some of these objects at all; those cases are skipped (representable()):
// meshes under 1024 float ulps of D across (s = 1e-3 at 1e3, 1e4 and 1e6; s = 1 at 1e6: their
// triangles would be a few ulps wide) and spheres under 16 float ulps of D across (r = 1e-3 at
// 1e4 and 1e6). "64ulp" spheres exist only for D > 0.
#include <isin/isin.hpp>

#include "workloads.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

namespace workloads {

// ---------------------------------------------------------------------------------------------
// Seeded numbers, the same with every standard library

/// A uniform double in [lo, hi) from a std::mt19937_64 (whose output the standard fixes, unlike
/// the distributions'), as benchmarks/meshes.hpp does.
inline double portable_uniform(Rng& rng, double lo, double hi) {
    return lo + (hi - lo) * double(rng() >> 11) * 0x1p-53;
}

/// A random unit vector (uniform on the sphere), from portable_uniform.
inline isin::Vertex<double> portable_unit(Rng& rng) {
    for (;;) {
        const isin::Vertex<double> v{portable_uniform(rng, -1, 1), portable_uniform(rng, -1, 1),
                                     portable_uniform(rng, -1, 1)};
        const double n = isin::dot(v, v);
        if (n > 1e-4 && n <= 1) return v / std::sqrt(n);
    }
}

/// The spacing of floats at |x| (0 at x = 0).
inline double float_ulp(double x) {
    const float f = std::fabs(float(x));
    return f > 0.0f ? double(std::nextafter(f, std::numeric_limits<float>::infinity()) - f) : 0.0;
}

// ---------------------------------------------------------------------------------------------
// The meshes

/// The triangle a, b, c wound so that its normal points along `outside`.
template <class T>
isin::Triangle<T> oriented_triangle(const isin::Vertex<double>& a, const isin::Vertex<double>& b,
                                    const isin::Vertex<double>& c, const isin::Vertex<double>& outside) {
    const auto to = [](const isin::Vertex<double>& p) { return point<T>(p.x, p.y, p.z); };
    const bool flip = isin::dot(isin::cross(b - a, c - a), outside) < 0.0;
    return flip ? isin::Triangle<T>{to(a), to(c), to(b)} : isin::Triangle<T>{to(a), to(b), to(c)};
}

/// A tube of radius 0.45 (before scaling) swept along the trefoil knot
/// p(s) = (sin s + 2 sin 2s, cos s − 2 cos 2s, −sin 3s), with the Frenet frame (the curvature
/// never vanishes on this curve; the frame is periodic, so the tube closes). `segments` along the
/// curve × `sides` around: 2·segments·sides triangles, closed, faces outwards. Strands stay ≥ 1.2
/// apart and the radius of curvature is ≥ 1.28, so the tube does not intersect itself.
/// Generated in double, rounded to T once per vertex (shared vertices are bit-identical).
template <class T>
std::vector<isin::Triangle<T>> trefoil(int segments = 1000, int sides = 150, isin::Vertex<double> centre = {0, 0, 45},
                                       double scale = 5.4) {
    using V3 = isin::Vertex<double>;
    const double pi = 3.14159265358979323846, r = 0.45;
    const auto n_seg = std::size_t(segments), n_side = std::size_t(sides);
    std::vector<V3> ring_centre(n_seg), grid(n_seg * n_side);
    for (std::size_t i = 0; i < n_seg; ++i) {
        const double s = 2 * pi * double(i) / double(segments);
        const V3 p{std::sin(s) + 2 * std::sin(2 * s), std::cos(s) - 2 * std::cos(2 * s) + 0.47, -std::sin(3 * s)};
        const V3 d1{std::cos(s) + 4 * std::cos(2 * s), -std::sin(s) + 4 * std::sin(2 * s), -3 * std::cos(3 * s)};
        const V3 d2{-std::sin(s) - 8 * std::sin(2 * s), -std::cos(s) + 8 * std::cos(2 * s), 9 * std::sin(3 * s)};
        const V3 tangent = isin::normalize(d1), binormal = isin::normalize(isin::cross(d1, d2));
        const V3 normal = isin::cross(binormal, tangent);
        ring_centre[i] = centre + scale * p;
        for (std::size_t j = 0; j < n_side; ++j) {
            const double a = 2 * pi * double(j) / double(sides);
            grid[i * n_side + j] = centre + scale * (p + r * (std::cos(a) * normal + std::sin(a) * binormal));
        }
    }
    std::vector<isin::Triangle<T>> out;
    out.reserve(2 * n_seg * n_side);
    for (std::size_t i = 0; i < n_seg; ++i) {
        const std::size_t i1 = (i + 1) % n_seg;
        const V3 axis = 0.5 * (ring_centre[i] + ring_centre[i1]);
        for (std::size_t j = 0; j < n_side; ++j) {
            const std::size_t j1 = (j + 1) % n_side;
            const V3 &a = grid[i * n_side + j], &b = grid[i1 * n_side + j], &c = grid[i1 * n_side + j1],
                     &d = grid[i * n_side + j1];
            out.push_back(oriented_triangle<T>(a, b, c, (a + b + c) / 3.0 - axis));
            out.push_back(oriented_triangle<T>(a, c, d, (a + c + d) / 3.0 - axis));
        }
    }
    return out;
}

/// An icosphere (subdivided `levels` times) of radius r around c whose radius varies smoothly by
/// up to ±`amplitude`·r: a sum of four seeded plane waves over the direction. Star-shaped, so it
/// stays closed and faces outwards; bumps give concave edges and occluders next to the surface.
template <class T>
std::vector<isin::Triangle<T>> bumpy_sphere(const isin::Vertex<double>& c, double r, int levels, double amplitude = 0.3,
                                            std::uint64_t seed = 17) {
    Rng rng(seed);
    isin::Vertex<double> axis[4];
    double frequency[4], phase[4];
    for (int k = 0; k < 4; ++k) {
        axis[k] = portable_unit(rng);
        frequency[k] = portable_uniform(rng, 4, 9);
        phase[k] = portable_uniform(rng, 0, 6.283185307179586);
    }
    const auto bump = [&](const isin::Vertex<double>& u) {
        double h = 0;
        for (int k = 0; k < 4; ++k) h += 0.25 * std::sin(frequency[k] * isin::dot(axis[k], u) + phase[k]);
        return 1 + amplitude * h;
    };
    const auto move = [&](const isin::Vertex<double>& u) {
        const auto p = c + (r * bump(u)) * u;
        return point<T>(p.x, p.y, p.z);
    };
    std::vector<isin::Triangle<T>> out;
    for (const auto& t : icosphere<double>({0, 0, 0}, 1.0, levels)) out.push_back({move(t.v0), move(t.v1), move(t.v2)});
    return out;
}

// ---------------------------------------------------------------------------------------------
// pbrt-v4's rule, written here from its source (a reference for isin's, not isin's code)

namespace pbrt_v4 {

/// pbrt's gamma(n) = n·u / (1 − n·u), u = ε/2 (util/math.h, MachineEpsilon).
template <class T>
constexpr T gamma(int n) {
    constexpr T u = std::numeric_limits<T>::epsilon() * T(0.5);
    return (T(n) * u) / (T(1) - T(n) * u);
}

/// pbrt's Point3fi as midpoint and half-width per component, with the surface's unit normal as
/// pbrt computes it (for spheres in object space, so its direction is as precise as the radius).
template <class T>
struct Point3i {
    isin::Vertex<T> p, error;
    isin::Vertex<T> n{};
};

/// ray.h, OffsetRayOrigin: to the corner of the error box along n, on w's side, then each moved
/// coordinate one float further away.
template <class T>
isin::Vertex<T> offset_ray_origin(const Point3i<T>& pi, const isin::Vertex<T>& n, const isin::Vertex<T>& w) {
    const T d = std::fabs(n.x) * pi.error.x + std::fabs(n.y) * pi.error.y + std::fabs(n.z) * pi.error.z;
    isin::Vertex<T> offset = d * n;
    if (isin::dot(w, n) < T(0)) offset = -offset;
    T po[3] = {pi.p.x + offset.x, pi.p.y + offset.y, pi.p.z + offset.z};
    const T off[3] = {offset.x, offset.y, offset.z};
    for (int i = 0; i < 3; ++i) {
        if (off[i] > T(0))
            po[i] = std::nextafter(po[i], std::numeric_limits<T>::infinity());
        else if (off[i] < T(0))
            po[i] = std::nextafter(po[i], -std::numeric_limits<T>::infinity());
    }
    return {po[0], po[1], po[2]};
}

/// shapes.h, Triangle::InteractionFromIntersection: pHit = b0·p0 + b1·p1 + b2·p2,
/// pError = γ7·(|b0·p0| + |b1·p1| + |b2·p2|).
/// n = normalize(cross(p0 − p2, p1 − p2)), the geometric normal.
template <class T>
Point3i<T> triangle_point(const isin::Triangle<T>& tri, T b1, T b2) {
    const T b0 = T(1) - b1 - b2;
    const isin::Vertex<T> q0 = b0 * tri.v0, q1 = b1 * tri.v1, q2 = b2 * tri.v2;
    const auto a = [](const isin::Vertex<T>& v) {
        return isin::Vertex<T>{std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)};
    };
    return {q0 + q1 + q2, gamma<T>(7) * (a(q0) + a(q1) + a(q2)),
            isin::normalize(isin::cross(tri.v0 - tri.v2, tri.v1 - tri.v2))};
}

/// shapes.h, Sphere: the ray taken to object space (the inverse translation, its origin moved
/// along d to the edge of its error box, transform.h ApplyInverse), the hit point there
/// reprojected onto the sphere about 0 with pError = γ5·|pHit|, then taken back by the
/// translation with the error of transform.h's Point3fi transform:
/// (γ3 + 1)·pError + γ3·(|pHit| + |C|); the normal is pHit/r, from object space (a translation
/// leaves it unchanged). `t` is the hit's t on the world ray (pbrt finds the same t in object
/// space to within rounding, which the reprojection makes irrelevant).
template <class T>
Point3i<T> sphere_point(const isin::Ray<T>& ray, const isin::Sphere<T>& sp, T t) {
    const auto a = [](const isin::Vertex<T>& v) {
        return isin::Vertex<T>{std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)};
    };
    const isin::Vertex<T>& o = ray.origin;
    const isin::Vertex<T>& d = ray.direction;
    isin::Vertex<T> oo = o - sp.center;                                  // objectFromRender(o)
    const isin::Vertex<T> o_error = gamma<T>(3) * (a(o) + a(sp.center)); // exact point through a transform
    const T dt = isin::dot(a(d), o_error) / isin::dot(d, d);
    oo = oo + dt * d;                      // to the edge of the error box
    isin::Vertex<T> p = oo + (t - dt) * d; // pHit in object space
    p = (sp.radius / isin::length(p)) * p; // refine: reproject
    const isin::Vertex<T> p_error = gamma<T>(5) * a(p);
    const isin::Vertex<T> world = p + sp.center; // renderFromObject(pHit)
    return {world, (gamma<T>(3) + T(1)) * p_error + gamma<T>(3) * (a(p) + a(sp.center)), isin::normalize(p)};
}

/// pbrt's shadow rays stop at t = 1 − ShadowEpsilon (integrators.h, Unoccluded).
template <class T>
constexpr T shadow_t_max = T(1) - T(0.0001);

} // namespace pbrt_v4

/// Ray Tracing Gems ch. 6 (Wächter & Binder, "A Fast and Robust Method for Avoiding
/// Self-Intersection"), offset_ray: each coordinate of p moved by int(256·n) ulps, in integer
/// arithmetic on its bits, towards n's side; within 1/32 of the origin by n/65536 instead.
/// n: unit normal on the side the ray leaves to.
inline isin::Vertex<float> wachter_binder_offset(const isin::Vertex<float>& p, const isin::Vertex<float>& n) {
    constexpr float origin = 1.0f / 32.0f, float_scale = 1.0f / 65536.0f, int_scale = 256.0f;
    const auto one = [&](float pc, float nc) {
        const auto of = static_cast<std::int32_t>(int_scale * nc);
        std::int32_t bits;
        std::memcpy(&bits, &pc, sizeof bits);
        bits += pc < 0.0f ? -of : of;
        float moved;
        std::memcpy(&moved, &bits, sizeof moved);
        return std::fabs(pc) < origin ? pc + float_scale * nc : moved;
    };
    return {one(p.x, n.x), one(p.y, n.y), one(p.z, n.z)};
}

// ---------------------------------------------------------------------------------------------
// Cases and results

enum class Offset { none, hit_point, fixed, error_bound, pbrt_v4, wachter_binder };
constexpr int offset_count = 6;
constexpr std::array<Offset, offset_count> all_offsets = {
    Offset::none, Offset::hit_point, Offset::fixed, Offset::error_bound, Offset::pbrt_v4, Offset::wachter_binder};

inline const char* offset_name(Offset m) {
    switch (m) {
    case Offset::none: return "none";
    case Offset::hit_point: return "hit_point";
    case Offset::fixed: return "fixed";
    case Offset::error_bound: return "error_bound";
    case Offset::pbrt_v4: return "pbrt_v4";
    case Offset::wachter_binder: return "wachter_binder";
    }
    return "?";
}

enum class Scene { trefoil, bumpy, spheres };

inline const char* scene_name(Scene s) {
    switch (s) {
    case Scene::trefoil: return "trefoil";
    case Scene::bumpy: return "bumpy";
    case Scene::spheres: return "spheres";
    }
    return "?";
}

/// One workload: a scene at a size, a distance from the origin and an eye distance.
struct SecondaryCase {
    Scene scene;
    double size;     ///< meshes: s (the object spans about 2s); spheres: the large sphere's radius
    double distance; ///< D: the object's centre is D·(0.36, −0.48, 0.8)
    double eye;      ///< eye distance from the centre, in object radii (half the box diagonal; r)
    std::string size_label;
};

/// The direction in which scenes are moved away from the origin (a unit vector).
inline isin::Vertex<double> away_direction() { return {0.36, -0.48, 0.8}; }

/// Every case of the study (both precisions; representable<T> says which float skips).
inline std::vector<SecondaryCase> secondary_cases() {
    std::vector<SecondaryCase> cases;
    const double distances[] = {0.0, 1e3, 1e4, 1e6}, eyes[] = {4.0, 100.0, 1000.0};
    const std::pair<double, const char*> sizes[] = {{1e-3, "1e-3"}, {1.0, "1"}, {1e3, "1e3"}};
    for (Scene scene : {Scene::trefoil, Scene::bumpy, Scene::spheres}) {
        for (double D : distances)
            for (double eye : eyes) {
                for (const auto& [s, label] : sizes) cases.push_back({scene, s, D, eye, label});
                // the smallest float sphere the study covers: 64 float ulps of D across
                if (scene == Scene::spheres && D > 0) cases.push_back({scene, 32 * float_ulp(D), D, eye, "64ulp"});
            }
    }
    return cases;
}

/// Whether T can place the case's object at all (see the top of this file).
template <class T>
bool representable(const SecondaryCase& c) {
    if (!std::is_same_v<T, float>) return true;
    const double ulp = float_ulp(c.distance);
    if (c.scene == Scene::spheres) return 2 * c.size >= 16 * ulp;
    return 2 * c.size >= 1024 * ulp;
}

/// What one offset method did on one case.
struct OffsetStats {
    bool applicable = true; ///< false: Wächter–Binder in double
    long shadow_rays = 0, reflected_rays = 0, refracted_rays = 0;
    long shadow_self_hits = 0, reflection_self_hits = 0, refraction_entry_hits = 0;
    long refraction_failures = 0;
    long reference_occluded = 0; ///< shadow rays the reference finds blocked
    long lost_occlusions = 0, false_occlusions = 0;
    double median_offset = 0, max_offset = 0; ///< in diagonals of the start object's box
    std::vector<double> offsets{};            ///< every origin's offset (emptied by finish())

    [[nodiscard]] long self_hits() const { return shadow_self_hits + reflection_self_hits + refraction_entry_hits; }
    [[nodiscard]] long rays() const { return shadow_rays + reflected_rays + refracted_rays; }
    void finish() {
        if (!offsets.empty()) {
            auto mid = offsets.begin() + std::ptrdiff_t(offsets.size() / 2);
            std::nth_element(offsets.begin(), mid, offsets.end());
            median_offset = *mid;
            max_offset = *std::max_element(offsets.begin(), offsets.end());
        }
        offsets = {};
    }
};

/// The methods' results on one case in one precision.
struct CaseResult {
    SecondaryCase c;
    const char* precision;
    long primaries = 0; ///< primary rays that hit
    std::array<OffsetStats, offset_count> methods{};
    [[nodiscard]] const OffsetStats& operator[](Offset m) const { return methods[std::size_t(m)]; }
    [[nodiscard]] OffsetStats& operator[](Offset m) { return methods[std::size_t(m)]; }
};

// ---------------------------------------------------------------------------------------------
// Long double references

using LD = long double;
using V3L = isin::Vertex<long double>;

template <class T>
V3L to_ld(const isin::Vertex<T>& v) {
    return {LD(v.x), LD(v.y), LD(v.z)};
}

/// Where a ray meets a triangle's plane, in long double from the exact T inputs.
template <class T>
V3L exact_plane_point(const isin::Ray<T>& ray, const isin::Triangle<T>& tri) {
    const V3L o = to_ld(ray.origin), d = to_ld(ray.direction), a = to_ld(tri.v0);
    const V3L n = isin::cross(to_ld(tri.v1) - a, to_ld(tri.v2) - a);
    const LD t = isin::dot(a - o, n) / isin::dot(d, n);
    return o + t * d;
}

/// The roots of |P + t·w − C|² = r², long double (Ray Tracing Gems ch. 7's form); false if the
/// line misses.
inline bool sphere_roots(const V3L& P, const V3L& w, const V3L& C, LD r, LD& t0, LD& t1) {
    const V3L f = P - C;
    const LD a = isin::dot(w, w), b = -isin::dot(f, w);
    const V3L g = f + (b / a) * w;
    const LD delta = r * r - isin::dot(g, g);
    if (!(delta >= 0)) return false;
    const LD c = isin::dot(f, f) - r * r;
    const LD q = b + std::copysign(std::sqrt(a * delta), b);
    const LD ta = c / q, tb = q / a;
    t0 = std::min(ta, tb), t1 = std::max(ta, tb);
    return true;
}

/// Whether the segment P → Q crosses the triangle (edges included) at a t in (0, 1), long double.
template <class T>
bool segment_crosses(const V3L& P, const V3L& Q, const isin::Triangle<T>& tri) {
    const V3L a = to_ld(tri.v0), b = to_ld(tri.v1), c = to_ld(tri.v2);
    const V3L n = isin::cross(b - a, c - a), w = Q - P;
    const LD denom = isin::dot(w, n);
    if (denom == 0) return false;
    const LD t = isin::dot(a - P, n) / denom;
    if (!(t > 0 && t < 1)) return false;
    const V3L X = P + t * w;
    return isin::dot(isin::cross(b - a, X - a), n) >= 0 && isin::dot(isin::cross(c - b, X - b), n) >= 0 &&
           isin::dot(isin::cross(a - c, X - c), n) >= 0;
}

// ---------------------------------------------------------------------------------------------
// The evaluation

/// A primary hit, with everything the methods start from. Each method uses one normal for
/// everything (which side is lit, the reflected and refracted directions, the side it offsets
/// to): the normal its pipeline has.
template <class T>
struct PrimaryHit {
    isin::Ray<T> ray;
    T t;
    std::uint32_t index;           ///< the triangle or sphere hit
    V3L exact;                     ///< the exact hit point (long double)
    V3L exact_normal;              ///< its unit normal (long double; for the refracted chord)
    isin::Vertex<T> raw;           ///< Ro + t·Rd
    isin::BoundedPoint<T> bounded; ///< isin::hit_point
    pbrt_v4::Point3i<T> pbrt;      ///< pbrt-v4's point, error and normal
    isin::Vertex<T> N;             ///< isin's unit normal at hit_point (normal_at; a triangle's own)
    isin::Vertex<T> N_raw;         ///< isin's unit normal at Ro + t·Rd, as the renderer had it
    double diagonal;               ///< of the start object's box

    /// The normal method m works with, on the eye's side.
    [[nodiscard]] const isin::Vertex<T>& normal(Offset m) const {
        return m == Offset::none || m == Offset::fixed ? N_raw : m == Offset::pbrt_v4 ? pbrt.n : N;
    }
    /// The point method m takes for the surface point (for the light's side).
    [[nodiscard]] const isin::Vertex<T>& base(Offset m) const {
        return m == Offset::none || m == Offset::fixed ? raw : m == Offset::pbrt_v4 ? pbrt.p : bounded.point;
    }
};

/// Where method m starts a ray leaving the hit in direction w.
template <class T>
isin::Vertex<T> secondary_origin(Offset m, const PrimaryHit<T>& h, const isin::Vertex<T>& w) {
    const isin::Vertex<T>& n = h.normal(m);
    const isin::Vertex<T> side = isin::dot(w, n) < T(0) ? -n : n; // the normal on w's side
    switch (m) {
    case Offset::none: return h.raw;
    case Offset::hit_point: return h.bounded.point;
    case Offset::fixed: return isin::offset_origin(h.raw, side, isin::max_abs(h.ray.origin));
    case Offset::error_bound: return isin::offset_ray_origin(h.bounded, n, w);
    case Offset::pbrt_v4: return pbrt_v4::offset_ray_origin(h.pbrt, n, w);
    case Offset::wachter_binder:
        if constexpr (std::is_same_v<T, float>) return wachter_binder_offset(h.bounded.point, side);
        break;
    }
    return h.raw;
}

template <class T>
double offset_in_diagonals(const isin::Vertex<T>& origin, const PrimaryHit<T>& h) {
    return double(isin::length(to_ld(origin) - h.exact)) / h.diagonal;
}

/// The secondary rays of one primary hit for every method. World gives nearest(ray, t_max) →
/// {hit, index, t} and reference_blocked(exact point, start index); refract_sphere: also the
/// refracted ray, tested against that sphere.
template <class T, class World>
void secondary_rays(const World& world, const PrimaryHit<T>& h, const isin::Sphere<T>* refract_sphere,
                    CaseResult& result) {
    const isin::Vertex<T>& L = world.light;
    int reference = -1; // the reference's verdict, once asked for: 0 clear, 1 blocked
    for (Offset m : all_offsets) {
        OffsetStats& s = result[m];
        if (m == Offset::wachter_binder && !std::is_same_v<T, float>) {
            s.applicable = false;
            continue;
        }
        const isin::Vertex<T>& n = h.normal(m);
        // reflected ray: any hit on the start primitive is a self-hit (a convex primitive's
        // reflected ray cannot meet it again)
        {
            const isin::Vertex<T> reflected = isin::reflect(h.ray.direction, n);
            const isin::Vertex<T> o = secondary_origin(m, h, reflected);
            const auto f = world.nearest(isin::Ray<T>{o, reflected}, std::numeric_limits<T>::infinity());
            ++s.reflected_rays;
            s.reflection_self_hits += f.hit && f.index == h.index;
            s.offsets.push_back(offset_in_diagonals(o, h));
        }
        if (isin::dot(n, L - h.base(m)) > T(0)) { // the light is in front: a shadow ray
            if (reference < 0) reference = world.reference_blocked(h.exact, h.index) ? 1 : 0;
            const bool reference_blocked = reference == 1;
            isin::Ray<T> ray;
            T t_max;
            if (m == Offset::error_bound) {
                const auto sr = isin::shadow_ray(h.bounded, n, L);
                ray = sr.ray, t_max = sr.t_max;
            } else if (m == Offset::pbrt_v4) {
                const auto o = pbrt_v4::offset_ray_origin(h.pbrt, n, L - h.pbrt.p); // SpawnRayTo
                ray = {o, L - o}, t_max = pbrt_v4::shadow_t_max<T>;
            } else {
                const auto o = secondary_origin(m, h, L - h.base(m));
                ray = {o, L - o}, t_max = T(1) - isin::rounding_gamma<T>(2);
            }
            const auto f = world.nearest(ray, t_max);
            ++s.shadow_rays;
            s.reference_occluded += reference_blocked;
            if (f.hit && f.index == h.index)
                ++s.shadow_self_hits;
            else if (f.hit && !reference_blocked)
                ++s.false_occlusions;
            else if (!f.hit && reference_blocked)
                ++s.lost_occlusions;
            s.offsets.push_back(offset_in_diagonals(ray.origin, h));
        }
        if (refract_sphere) { // index 1 → 1.5: never total internal reflection
            const isin::Vertex<T> refracted = isin::normalize(*isin::refract(h.ray.direction, n, T(1) / T(1.5)));
            const double chord =
                double(LD(-2) * LD(refract_sphere->radius) * isin::dot(to_ld(refracted), h.exact_normal));
            const isin::Vertex<T> o = secondary_origin(m, h, refracted);
            const auto f = isin::intersect(isin::Ray<T>{o, refracted}, *refract_sphere);
            ++s.refracted_rays;
            if (!f || double(f.t) > 1.5 * chord)
                ++s.refraction_failures;
            else if (double(f.t) < 0.5 * chord)
                ++s.refraction_entry_hits;
            s.offsets.push_back(offset_in_diagonals(o, h));
        }
    }
}

template <class T>
struct Found {
    bool hit = false;
    std::uint32_t index = 0;
    T t = 0;
};

/// A triangle mesh with its Bvh (T, for the methods) and a double one (the reference's candidates).
template <class T>
struct MeshWorld {
    std::vector<isin::Triangle<T>> triangles;
    isin::Bvh<T> bvh;
    isin::Bvh<double> reference;
    isin::Vertex<T> light;

    static std::vector<isin::Triangle<double>> widened(const std::vector<isin::Triangle<T>>& tris) {
        std::vector<isin::Triangle<double>> out;
        for (const auto& t : tris)
            out.push_back({workloads::to_double(t.v0), workloads::to_double(t.v1), workloads::to_double(t.v2)});
        return out;
    }
    MeshWorld(std::vector<isin::Triangle<T>> tris, const isin::Vertex<T>& light_at)
        : triangles(std::move(tris)), bvh(triangles), reference(widened(triangles)), light(light_at) {}

    Found<T> nearest(const isin::Ray<T>& ray, T t_max) const {
        const auto h = bvh.intersect(ray, t_max);
        return {bool(h), h.primitive, h.t};
    }
    // Candidates from the double Bvh along the segment backed up by 1e-7 of its length (so that
    // rounding P to double loses none), each confirmed in long double from the exact point.
    bool reference_blocked(const V3L& P, std::uint32_t start) const {
        const V3L Lx = to_ld(light);
        const isin::Vertex<double> Pd{double(P.x), double(P.y), double(P.z)};
        const isin::Vertex<double> w = workloads::to_double(light) - Pd;
        bool blocked = false;
        (void)reference.for_each_hit(isin::Ray<double>{Pd - 1e-7 * w, w}, 1.0 + 2e-7,
                                     [&](std::uint32_t index, const isin::Hit<double>&) {
                                         if (index != start && segment_crosses(P, Lx, triangles[index])) blocked = true;
                                         return !blocked;
                                     });
        return blocked;
    }
};

/// Spheres: [0] the large one, then the pebbles.
template <class T>
struct SphereWorld {
    std::vector<isin::Sphere<T>> spheres;
    isin::Vertex<T> light;

    Found<T> nearest(const isin::Ray<T>& ray, T t_max) const {
        Found<T> best;
        best.t = t_max;
        for (std::size_t i = 0; i < spheres.size(); ++i) {
            const auto h = isin::intersect(ray, spheres[i]);
            if (h && h.t < best.t) best = {true, std::uint32_t(i), h.t};
        }
        return best;
    }
    bool reference_blocked(const V3L& P, std::uint32_t start) const {
        const V3L w = to_ld(light) - P;
        for (std::size_t i = 0; i < spheres.size(); ++i) {
            if (i == start) continue;
            LD t0, t1;
            if (sphere_roots(P, w, to_ld(spheres[i].center), LD(spheres[i].radius), t0, t1) && t1 > 0 && t0 < 1)
                return true;
        }
        return false;
    }
};

template <class T>
isin::Vertex<double> widen(const isin::Vertex<T>& p) {
    return {double(p.x), double(p.y), double(p.z)};
}

/// A mesh case: n primary rays from random eye positions aimed at random points of random
/// triangles.
template <class T>
CaseResult evaluate_mesh(const SecondaryCase& c, int n, std::uint64_t seed) {
    const isin::Vertex<double> centre = c.distance * away_direction();
    std::vector<isin::Triangle<T>> tris =
        c.scene == Scene::trefoil ? trefoil<T>(96, 12, centre, c.size / 3.5) : bumpy_sphere<T>(centre, c.size, 4);
    isin::Vertex<double> lo = widen(tris[0].v0), hi = lo;
    for (const auto& t : tris)
        for (const auto* v : {&t.v0, &t.v1, &t.v2}) {
            const auto p = widen(*v);
            lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
            hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
        }
    const double diagonal = isin::length(hi - lo);
    const auto L = centre + 0.75 * diagonal * isin::normalize(isin::Vertex<double>{0.3, 0.8, -0.5});
    const MeshWorld<T> world(std::move(tris), point<T>(L.x, L.y, L.z));

    CaseResult result{c, std::is_same_v<T, float> ? "float" : "double", 0, {}};
    Rng rng(seed);
    for (int i = 0; i < n; ++i) {
        const auto& target_tri = world.triangles[std::size_t(portable_uniform(rng, 0, double(world.triangles.size())))];
        double u = portable_uniform(rng, 0.02, 0.96), v = portable_uniform(rng, 0.02, 0.96);
        if (u + v > 0.98) u = 0.98 - u, v = 0.98 - v + 0.02; // fold back into the triangle
        const auto target = at_barycentric(target_tri, u, v);
        const auto eye = centre + (c.eye * 0.5 * diagonal) * portable_unit(rng);
        const auto primary = ray_towards<T>(eye, target);
        const auto hit = world.bvh.intersect(primary);
        if (!hit) continue;
        const auto& tri = world.triangles[hit.primitive];
        PrimaryHit<T> h{primary,
                        hit.t,
                        hit.primitive,
                        exact_plane_point(primary, tri),
                        {},
                        primary.at(hit.t),
                        isin::hit_point(primary, tri, hit),
                        pbrt_v4::triangle_point(tri, hit.u, hit.v),
                        isin::normalize(isin::normal(tri)),
                        {},
                        diagonal};
        if (isin::dot(h.N, primary.direction) > T(0)) h.N = -h.N; // the side the eye sees
        if (isin::dot(h.pbrt.n, primary.direction) > T(0)) h.pbrt.n = -h.pbrt.n;
        h.N_raw = h.N;
        ++result.primaries;
        secondary_rays<T>(world, h, nullptr, result);
    }
    for (auto& s : result.methods) s.finish();
    return result;
}

/// A sphere case: the large sphere, 8 pebbles above it towards the light; primary rays aimed at
/// the large sphere (40%), a pebble (30%) or the ground next to a pebble (30%).
template <class T>
CaseResult evaluate_spheres(const SecondaryCase& c, int n, std::uint64_t seed) {
    Rng rng(seed);
    const double r = c.size;
    const auto C = c.distance * away_direction();
    const isin::Vertex<T> Ct = point<T>(C.x, C.y, C.z);
    const isin::Vertex<double> Cd = widen(Ct);
    SphereWorld<T> world;
    world.spheres.push_back({Ct, T(r)});
    const auto to_light = isin::normalize(isin::Vertex<double>{0.5, 0.7, -0.5});
    const auto L = Cd + 4 * r * to_light;
    world.light = point<T>(L.x, L.y, L.z);
    std::vector<isin::Vertex<double>> contact;
    while (world.spheres.size() < 9) {
        const auto u = portable_unit(rng);
        const double ri = r * portable_uniform(rng, 0.15, 0.3), gap = ri * portable_uniform(rng, 0.002, 0.05);
        if (isin::dot(u, to_light) < 0.3) continue;
        const auto ci = Cd + (r + ri + gap) * u;
        bool apart = true;
        for (std::size_t j = 1; j < world.spheres.size(); ++j)
            apart = apart &&
                    isin::length(ci - widen(world.spheres[j].center)) > 1.1 * (ri + double(world.spheres[j].radius));
        if (!apart) continue;
        world.spheres.push_back({point<T>(ci.x, ci.y, ci.z), T(ri)});
        contact.push_back(Cd + r * u);
    }

    CaseResult result{c, std::is_same_v<T, float> ? "float" : "double", 0, {}};
    for (int i = 0; i < n; ++i) {
        const double pick = portable_uniform(rng, 0, 1);
        const std::size_t pebble = 1 + std::size_t(portable_uniform(rng, 0, 8));
        const auto& pb = world.spheres[pebble];
        isin::Vertex<double> target;
        if (pick < 0.4)
            target = Cd + 0.95 * r * portable_unit(rng);
        else if (pick < 0.7)
            target = widen(pb.center) + 0.95 * double(pb.radius) * portable_unit(rng);
        else
            target = contact[pebble - 1] + 0.5 * double(pb.radius) * portable_unit(rng);
        const auto eye = Cd + c.eye * r * portable_unit(rng);
        const auto primary = ray_towards<T>(eye, target);
        const auto hit = world.nearest(primary, std::numeric_limits<T>::infinity());
        if (!hit.hit) continue;
        const auto& sp = world.spheres[hit.index];
        LD t0, t1;
        if (!sphere_roots(to_ld(primary.origin), to_ld(primary.direction), to_ld(sp.center), LD(sp.radius), t0, t1))
            continue; // grazes: the exact ray misses
        const isin::Hit<T> isin_hit = isin::Hit<T>::at(hit.t);
        const auto bounded = isin::hit_point(primary, sp, isin_hit);
        const V3L exact = to_ld(primary.origin) + t0 * to_ld(primary.direction);
        const PrimaryHit<T> h{primary,
                              hit.t,
                              hit.index,
                              exact,
                              (exact - to_ld(sp.center)) / LD(sp.radius),
                              primary.at(hit.t),
                              bounded,
                              pbrt_v4::sphere_point(primary, sp, hit.t),
                              isin::normal_at(primary, sp, isin_hit), // outwards: every primary ray starts outside
                              isin::normal_at(sp, primary.at(hit.t)),
                              2 * 1.7320508075688772 * double(sp.radius)};
        ++result.primaries;
        secondary_rays<T>(world, h, hit.index == 0 ? &world.spheres[0] : nullptr, result);
    }
    for (auto& s : result.methods) s.finish();
    return result;
}

/// Runs one case with n primary rays.
template <class T>
CaseResult evaluate(const SecondaryCase& c, int n, std::uint64_t seed = 15) {
    return c.scene == Scene::spheres ? evaluate_spheres<T>(c, n, seed) : evaluate_mesh<T>(c, n, seed);
}

} // namespace workloads
