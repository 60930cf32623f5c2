#pragma once
/// isin — private: the renderer's shading (note §7–§9): trace() for one ray, and the same
/// shading as passes over lanes of shaded points, for the streams of render/stream.hpp.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "options.hpp"
#include "../area_light.hpp"
#include "../camera.hpp"
#include "../color.hpp"
#include "../culling.hpp"
#include "../detail/compiled.hpp"
#include "../detail/parallel.hpp"
#include "../image.hpp"
#include "../offset.hpp"
#include "../scene.hpp"
#include "../shading.hpp"

namespace isin {

namespace detail {
[[noreturn]] ISIN_DETAIL_COLD inline void throw_too_deep(int depth) {
    throw std::invalid_argument("isin::trace: depth " + std::to_string(depth) + " is beyond max_depth_limit");
}
} // namespace detail

namespace detail {
// What a shaded point's reflected and transmitted rays need (§8), and its colour so far.
template <class T>
struct Shading {
    const Material<T>* m;
    Color<T> local;
    Vertex<T> point, error, Nf, Ns, above;
    bool entering;
};

// A stream's shaded points as lanes (trace()'s one point as one lane): lane k of field f is at
// lanes[f·stride + k]. Each hit's surface is written into its lane (hits_into_lanes,
// surface_pass), then side_pass turns the normals to the ray's side and places the secondary
// rays' origins, and the light passes add each light's Phong terms (§7). The renderer's streams
// (up to stream_rays points) run the passes a register of lanes at a time (simd/pack.hpp),
// trace() on its one point; both round alike (lane_fma), so a point gets the same colour bit
// for bit.
template <class T>
struct ShadingLanes : LaneRegister<T> {
    // clang-format off
    enum Field : std::size_t {
        px, py, pz,         // the hit point
        nx, ny, nz,         // the shading normal; on the ray's side after side_pass (Ns), lights it
        vx, vy, vz,         // the ray's direction; towards the eye after side_pass (V)
        kd, ks, shininess,  // the material's Phong weights
        cr, cg, cb,         // the surface's colour (object)
        sr, sg, sb,         // the highlight's
        lr, lg, lb,         // the local colour so far: the ambient term, then each light's
        ex, ey, ez,         // the hit point's error bound
        gx, gy, gz,         // the geometric normal; on the ray's side after side_pass (Nf)
        hx, hy, hz,         // the shading point; after side_pass where shadow rays start
        ax, ay, az,         // after side_pass: where reflected rays start (above the surface)
        front,              // after side_pass: 1 where the ray enters through the front face, else 0
        ox, oy, oz,         // side_pass's scratch: the move to `above`,
        qx, qy, qz,         // the point moved for shadow rays,
        wx, wy, wz,         // and that move
        fields
    };
    // clang-format on
    enum PerLight : std::size_t { lx, ly, lz, n_dot_l, visible, per_light };
    static constexpr std::size_t slots = 4; // lights at a time
    static constexpr std::size_t rows = fields + slots * per_light;
    // surface_pass's input, in the light slots' rows (the lights come after it): a triangle hit's
    // vertices V0, V1, V2 (x y z each) and barycentrics, or a sphere hit's centre, radius, ray
    // origin and t; and 1 in is_triangle or is_sphere where the lane holds one.
    enum TriangleField : std::size_t { v0x = fields, tu = fields + 9, tv, is_triangle, is_sphere, primitive_end };
    enum SphereField : std::size_t { cx = v0x, radius = v0x + 3, rox = v0x + 4, t = tu };
    static_assert(primitive_end <= rows, "surface_pass's rows fit the light slots'");
    // Field f of light slot `slot`.
    static constexpr std::size_t field(std::size_t slot, PerLight f) noexcept { return fields + slot * per_light + f; }

    // Lane k holds nothing: zeros, which no light lights (N·L = 0).
    static void clear(T* lanes, std::size_t stride, std::size_t k) noexcept {
        for (std::size_t f = 0; f < rows; ++f) lanes[f * stride + k] = T(0);
    }
    // Sets a vector's three fields from f on.
    static void set(T* lanes, std::size_t stride, std::size_t k, std::size_t f, const Vertex<T>& v) noexcept {
        lanes[f * stride + k] = v.x, lanes[(f + 1) * stride + k] = v.y, lanes[(f + 2) * stride + k] = v.z;
    }
    static void set(T* lanes, std::size_t stride, std::size_t k, std::size_t f, const Color<T>& c) noexcept {
        lanes[f * stride + k] = c.r, lanes[(f + 1) * stride + k] = c.g, lanes[(f + 2) * stride + k] = c.b;
    }
    // Field f of lanes [a, b) set to one value; a vector's or a colour's three fields from f on.
    static void fill(T* lanes, std::size_t stride, std::size_t a, std::size_t b, std::size_t f, T value) noexcept {
        if (b == a + 1) { // one lane (trace()'s, a run of one) without the vectorised loop's set-up
            lanes[f * stride + a] = value;
            return;
        }
        for (std::size_t k = a; k < b; ++k) lanes[f * stride + k] = value;
    }
    static void fill(T* lanes, std::size_t stride, std::size_t a, std::size_t b, std::size_t f,
                     const Vertex<T>& v) noexcept {
        fill(lanes, stride, a, b, f, v.x), fill(lanes, stride, a, b, f + 1, v.y), fill(lanes, stride, a, b, f + 2, v.z);
    }
    static void fill(T* lanes, std::size_t stride, std::size_t a, std::size_t b, std::size_t f,
                     const Color<T>& c) noexcept {
        fill(lanes, stride, a, b, f, c.r), fill(lanes, stride, a, b, f + 1, c.g), fill(lanes, stride, a, b, f + 2, c.b);
    }
    // The vector in the three fields from f on.
    static Vertex<T> vertex(const T* lanes, std::size_t stride, std::size_t k, std::size_t f) noexcept {
        return {lanes[f * stride + k], lanes[(f + 1) * stride + k], lanes[(f + 2) * stride + k]};
    }
    // What the lights need of lane k (for points set by hand, as the tests do): the point, the
    // normal that lights it, the direction to the eye, the material, colour and local colour.
    static void set_lit(T* lanes, std::size_t stride, std::size_t k, const Vertex<T>& point, const Vertex<T>& Ns,
                        const Vertex<T>& V, const Material<T>& m, const Color<T>& object,
                        const Color<T>& local) noexcept {
        set(lanes, stride, k, px, point), set(lanes, stride, k, nx, Ns), set(lanes, stride, k, vx, V);
        lanes[kd * stride + k] = m.kd, lanes[ks * stride + k] = m.ks, lanes[shininess * stride + k] = m.shininess;
        set(lanes, stride, k, cr, object), set(lanes, stride, k, sr, m.specular_color),
            set(lanes, stride, k, lr, local);
    }
    // The local colour of lane k.
    static Color<T> local(const T* lanes, std::size_t stride, std::size_t k) noexcept {
        return {lanes[lr * stride + k], lanes[lg * stride + k], lanes[lb * stride + k]};
    }
    // Lane k (after side_pass and the lights) as what its secondary rays need; m its material.
    static Shading<T> shading(const T* lanes, std::size_t stride, std::size_t k, const Material<T>& m) noexcept {
        return {&m,
                local(lanes, stride, k),
                vertex(lanes, stride, k, px),
                vertex(lanes, stride, k, ex),
                vertex(lanes, stride, k, gx),
                vertex(lanes, stride, k, nx),
                vertex(lanes, stride, k, ax),
                lanes[front * stride + k] != T(0)};
    }
};

// The colour of a surface (§7): the texture at st where its material has one and the hit has
// texture coordinates, else the material's colour; times the vertex colour `tint`.
template <class T, template <class> class... S>
Color<T> surface_colour(const Scene<T, S...>& scene, const Material<T>& m, bool has_st, const std::array<T, 2>& st,
                        const Color<T>& tint) {
    return tint * (m.texture >= 0 && has_st
                       ? sample(scene.texture(m.texture), st[0], st[1], m.texture_filter.value_or(scene.texture_filter))
                       : m.color);
}

// The surface's colour `object` and its ambient term (§7) into lanes [a, b).
template <class T, template <class> class... S>
void colour_into_lanes(const Scene<T, S...>& scene, const Material<T>& m, const Color<T>& object, T* lanes,
                       std::size_t stride, std::size_t a, std::size_t b) noexcept {
    using Lanes = ShadingLanes<T>;
    const Color<T> ambient = m.ka * m.ambient_color * object * scene.ambient_light; // §7: ambient
    Lanes::fill(lanes, stride, a, b, Lanes::cr, object);
    Lanes::fill(lanes, stride, a, b, Lanes::lr, ambient);
}

// The hits of rays[at[i]] (hits[at[i]], each a hit) into lanes i < count, a run of hits on one
// primitive at a time: what the primitive and its material give the whole run (its vertices or
// centre and radius, the material's weights and highlight, the colour where it has no texture)
// is written once per row, what each hit has of its own (barycentrics, a sphere's ray origin
// and t, texture colour, the ray's direction) lane by lane. On the scene's own triangle kinds
// surface_pass computes the surface from the vertices and barycentrics, on its spheres from the
// sphere, the ray's origin and t (as Scene::surface does: triangle_surface, sphere_surface); on
// anything else (user kinds, placed meshes) the surface is Scene::surface's. material[i] is
// lane i's material.
template <class T, template <class> class... S>
ISIN_DETAIL_NOINLINE void hits_into_lanes(const Scene<T, S...>& scene, const Ray<T>* rays, const Hit<T>* hits,
                                          const int* at, std::size_t count, T* lanes, std::size_t stride,
                                          const Material<T>** material) {
    using Lanes = ShadingLanes<T>;
    const auto row = [&](std::size_t f) { return lanes + f * stride; };
    for (std::size_t a = 0; a < count;) {
        const Hit<T>& first = hits[at[a]];
        std::size_t b = a + 1;
        while (b < count && hits[at[b]].geometry == first.geometry && hits[at[b]].primitive == first.primitive) ++b;
        // The material's weights and highlight, and each ray's direction.
        const auto material_into_lanes = [&](const Material<T>& m, std::size_t lo, std::size_t hi) {
            Lanes::fill(lanes, stride, lo, hi, Lanes::kd, m.kd);
            Lanes::fill(lanes, stride, lo, hi, Lanes::ks, m.ks);
            Lanes::fill(lanes, stride, lo, hi, Lanes::shininess, m.shininess);
            Lanes::fill(lanes, stride, lo, hi, Lanes::sr, m.specular_color);
            for (std::size_t k = lo; k < hi; ++k)
                material[k] = &m, Lanes::set(lanes, stride, k, Lanes::vx, rays[at[k]].direction);
        };
        bool own_kind = false;
        scene.for_each_kind([&](auto kind, const auto& vec) {
            using Shape = typename std::decay_t<decltype(vec)>::value_type::shape_type;
            constexpr bool triangle = is_triangle_kind<Shape>::value, sphere = std::is_same_v<Shape, Sphere<T>>;
            if constexpr (triangle || sphere) {
                if (kind != first.geometry) return;
                own_kind = true;
                const auto& obj = vec.at(first.primitive);
                if constexpr (triangle) {
                    const std::array<T, 9> v = vertices_of(*triangle_of(obj.shape));
                    for (std::size_t f = 0; f < 9; ++f) Lanes::fill(lanes, stride, a, b, Lanes::v0x + f, v[f]);
                    for (std::size_t k = a; k < b; ++k)
                        row(Lanes::tu)[k] = hits[at[k]].u, row(Lanes::tv)[k] = hits[at[k]].v;
                } else {
                    Lanes::fill(lanes, stride, a, b, Lanes::cx, obj.shape.center);
                    Lanes::fill(lanes, stride, a, b, Lanes::radius, obj.shape.radius);
                    for (std::size_t f = Lanes::rox + 3; f < Lanes::t; ++f) Lanes::fill(lanes, stride, a, b, f, T(0));
                    Lanes::fill(lanes, stride, a, b, Lanes::tv, T(0));
                    for (std::size_t k = a; k < b; ++k)
                        Lanes::set(lanes, stride, k, Lanes::rox, rays[at[k]].origin), row(Lanes::t)[k] = hits[at[k]].t;
                }
                Lanes::fill(lanes, stride, a, b, Lanes::is_triangle, triangle ? T(1) : T(0));
                Lanes::fill(lanes, stride, a, b, Lanes::is_sphere, sphere ? T(1) : T(0));
                const Material<T>& m = scene.material(obj.material);
                material_into_lanes(m, a, b);
                const Color<T> white{T(1), T(1), T(1)};
                std::array<T, 2> st{};
                if (m.texture < 0 || !texture_coordinates(obj.shape, first, st)) { // one colour for the run
                    colour_into_lanes(scene, m, surface_colour(scene, m, false, st, white), lanes, stride, a, b);
                    return;
                }
                for (std::size_t k = a; k < b; ++k) {
                    const bool has_st = texture_coordinates(obj.shape, hits[at[k]], st);
                    colour_into_lanes(scene, m, surface_colour(scene, m, has_st, st, white), lanes, stride, k, k + 1);
                }
            }
        });
        if (!own_kind) {
            for (std::size_t k = a; k < b; ++k) {
                const SurfacePoint<T> sp = scene.surface(rays[at[k]], hits[at[k]]);
                for (std::size_t f = Lanes::v0x; f < Lanes::primitive_end; ++f) row(f)[k] = T(0);
                Lanes::set(lanes, stride, k, Lanes::px, sp.point);
                Lanes::set(lanes, stride, k, Lanes::ex, sp.error);
                Lanes::set(lanes, stride, k, Lanes::gx, sp.normal);
                Lanes::set(lanes, stride, k, Lanes::nx, sp.shading_normal);
                Lanes::set(lanes, stride, k, Lanes::hx, sp.shading_point);
                const Material<T>& m = scene.material(sp.material);
                material_into_lanes(m, k, k + 1);
                colour_into_lanes(scene, m, surface_colour(scene, m, sp.has_texture_coordinates, sp.st, sp.tint), lanes,
                                  stride, k, k + 1);
            }
        }
        a = b;
    }
}

// For the register of lanes at p (or the one point at p, V = T): the surfaces of the lanes that
// hold triangle or sphere hits (hits_into_lanes), as Scene::surface computes them
// (triangle_surface, sphere_surface): the point and its bound, the unit normal, which is also
// the shading normal, and the point, which is also the shading point.
template <class T, class V = typename LaneRegister<T>::V>
ISIN_DETAIL_NOINLINE void surface_pass(T* p, std::size_t stride) noexcept {
    using Lanes = ShadingLanes<T>;
    const auto at = [&](std::size_t f) { return load_lanes<T, V>(p + f * stride); };
    const auto surface = [&](const auto& mask, const V(&point)[3], const V(&error)[3], const V(&normal)[3]) {
        const auto put = [&](std::size_t f, const V& value) {
            store_lanes(select(mask, value, at(f)), p + f * stride);
        };
        for (std::size_t c = 0; c < 3; ++c) {
            put(Lanes::px + c, point[c]), put(Lanes::hx + c, point[c]), put(Lanes::ex + c, error[c]);
            put(Lanes::gx + c, normal[c]), put(Lanes::nx + c, normal[c]);
        }
    };
    const std::size_t s = Lanes::v0x;
    const V v[9] = {at(s), at(s + 1), at(s + 2), at(s + 3), at(s + 4), at(s + 5), at(s + 6), at(s + 7), at(s + 8)};
    V point[3] = {v[0], v[0], v[0]}, error[3] = {v[0], v[0], v[0]}, normal[3] = {v[0], v[0], v[0]};
    const auto triangle = at(Lanes::is_triangle) != T(0);
    if (lane_bits(triangle) != 0) {
        triangle_surface<T>(v, at(Lanes::tu), at(Lanes::tv), point, error, normal);
        surface(triangle, point, error, normal);
    }
    const auto sphere = at(Lanes::is_sphere) != T(0);
    if (lane_bits(sphere) != 0) {
        const V centre[3] = {v[0], v[1], v[2]}, origin[3] = {v[4], v[5], v[6]};
        const V direction[3] = {at(Lanes::vx), at(Lanes::vy), at(Lanes::vz)}; // the ray's, before side_pass
        sphere_surface<T>(origin, direction, centre, v[3], at(Lanes::t), point, error, normal);
        surface(sphere, point, error, normal);
    }
}

// For the register of lanes at p (V = LaneRegister's) or the one point at p (V = T): the
// geometric and the shading normal turned to the side the ray came from (Nf, Ns: equal on flat
// surfaces), the direction to the eye (§7: V = −Rd), and where secondary rays start, off the
// surface by the hit point's error bound (pbrt-v4 §6.8.6, offset_ray_origin): above it for
// reflected rays and, from the shading point, for shadow rays (Hanika's lift adds one rounding
// to the point's error). Refracted rays start below it (secondary_rays).
template <class T, class V = typename LaneRegister<T>::V>
ISIN_DETAIL_NOINLINE void side_pass(T* p, std::size_t stride) noexcept {
    using Lanes = ShadingLanes<T>;
    constexpr std::size_t W = std::is_same_v<V, T> ? 1 : LaneRegister<T>::width;
    const auto at = [&](std::size_t f) { return load_lanes<T, V>(p + f * stride); };
    const auto put = [&](std::size_t f, const V& v) { store_lanes(v, p + f * stride); };
    const V dx = at(Lanes::vx), dy = at(Lanes::vy), dz = at(Lanes::vz);
    const auto entering = lane_dot(at(Lanes::gx), at(Lanes::gy), at(Lanes::gz), dx, dy, dz) < T(0);
    put(Lanes::front, select(entering, V(T(1)), V(T(0))));
    const V fx = negate_where(!entering, at(Lanes::gx)), fy = negate_where(!entering, at(Lanes::gy)),
            fz = negate_where(!entering, at(Lanes::gz)); // Nf: the normal on the ray's side
    put(Lanes::gx, fx), put(Lanes::gy, fy), put(Lanes::gz, fz);
    const V sx = at(Lanes::nx), sy = at(Lanes::ny), sz = at(Lanes::nz);
    const auto away = lane_dot(sx, sy, sz, fx, fy, fz) < T(0); // Ns on Nf's side
    put(Lanes::nx, negate_where(away, sx)), put(Lanes::ny, negate_where(away, sy)),
        put(Lanes::nz, negate_where(away, sz));
    put(Lanes::vx, -dx), put(Lanes::vy, -dy), put(Lanes::vz, -dz); // §7: towards the eye
    const V ex = at(Lanes::ex), ey = at(Lanes::ey), ez = at(Lanes::ez);
    V x = at(Lanes::px), y = at(Lanes::py), z = at(Lanes::pz), ox = x, oy = x, oz = x;
    offset_lanes<T, V>(x, y, z, ex, ey, ez, fx, fy, fz, ox, oy, oz);
    put(Lanes::ax, x), put(Lanes::ay, y), put(Lanes::az, z), put(Lanes::ox, ox), put(Lanes::oy, oy), put(Lanes::oz, oz);
    const V hx = at(Lanes::hx), hy = at(Lanes::hy), hz = at(Lanes::hz);
    const T g1 = rounding_gamma<T>(1);
    x = hx, y = hy, z = hz;
    offset_lanes<T, V>(x, y, z, lane_fma(V(g1), lane_abs(hx), ex), lane_fma(V(g1), lane_abs(hy), ey),
                       lane_fma(V(g1), lane_abs(hz), ez), fx, fy, fz, ox, oy, oz);
    put(Lanes::qx, x), put(Lanes::qy, y), put(Lanes::qz, z), put(Lanes::wx, ox), put(Lanes::wy, oy), put(Lanes::wz, oz);
    for (std::size_t k = 0; k < W; ++k) { // each moved coordinate one ulp further (step_off), lane by lane
        const Vertex<T> point = Lanes::vertex(p, stride, k, Lanes::px),
                        shading = Lanes::vertex(p, stride, k, Lanes::hx);
        const Vertex<T> above =
            step_off(point, Lanes::vertex(p, stride, k, Lanes::ax), Lanes::vertex(p, stride, k, Lanes::ox));
        Lanes::set(p, stride, k, Lanes::ax, above);
        Lanes::set(p, stride, k, Lanes::hx,
                   shading == point ? above
                                    : step_off(shading, Lanes::vertex(p, stride, k, Lanes::qx),
                                               Lanes::vertex(p, stride, k, Lanes::wx)));
    }
}

// §7 for the register of lanes at p (V = LaneRegister's) or the one point at p (V = T): the unit
// direction L from each point to the light (as normalize(): none, 0, where light − point has no
// length or is not finite) and N·L, into `slot`. Each product it adds goes through lane_fma,
// so one point and a register of them get the same bits.
template <class T, class V = typename LaneRegister<T>::V>
ISIN_DETAIL_NOINLINE void light_direction_pass(T* p, std::size_t stride, std::size_t slot,
                                               const Vertex<T>& light) noexcept {
    using Lanes = ShadingLanes<T>;
    const auto at = [&](std::size_t f) { return load_lanes<T, V>(p + f * stride); };
    V x = V(light.x) - at(Lanes::px), y = V(light.y) - at(Lanes::py), z = V(light.z) - at(Lanes::pz);
    lane_normalize<T>(x, y, z);
    store_lanes(x, p + Lanes::field(slot, Lanes::lx) * stride);
    store_lanes(y, p + Lanes::field(slot, Lanes::ly) * stride);
    store_lanes(z, p + Lanes::field(slot, Lanes::lz) * stride);
    const V n_dot_l = lane_dot(at(Lanes::nx), at(Lanes::ny), at(Lanes::nz), x, y, z); // §7: N·L
    store_lanes(n_dot_l, p + Lanes::field(slot, Lanes::n_dot_l) * stride);
}

// §7 for the register of lanes (or the one point) at p: where N·L > 0 and some of the light in
// `slot` gets through, the local colour gains visible·(kd·(N·L)·object +
// ks·specular_power(Rf·V)·highlight)·light, Rf the mirror of −L about N (phong_light's terms, in
// its order, each product added through lane_fma).
template <class T, class V = typename LaneRegister<T>::V>
ISIN_DETAIL_NOINLINE void light_term_pass(T* p, std::size_t stride, std::size_t slot, const Color<T>& light) noexcept {
    using Lanes = ShadingLanes<T>;
    constexpr std::size_t W = std::is_same_v<V, T> ? 1 : LaneRegister<T>::width;
    const auto at = [&](std::size_t f) { return load_lanes<T, V>(p + f * stride); };
    const auto of_light = [&](typename Lanes::PerLight f) { return p + Lanes::field(slot, f) * stride; };
    const V nx = at(Lanes::nx), ny = at(Lanes::ny), nz = at(Lanes::nz);
    const V lx = load_lanes<T, V>(of_light(Lanes::lx)), ly = load_lanes<T, V>(of_light(Lanes::ly)),
            lz = load_lanes<T, V>(of_light(Lanes::lz));
    const V n_dot_l = load_lanes<T, V>(of_light(Lanes::n_dot_l)), visible = load_lanes<T, V>(of_light(Lanes::visible));
    // §7: Rf = d − 2(d·N)N with d = −L, and its cosine with V
    const auto [rx, ry, rz] = lane_reflect<T>(-lx, -ly, -lz, nx, ny, nz);
    alignas(64) T cosine[W], shine[W], spec[W];
    store_lanes(lane_dot(rx, ry, rz, at(Lanes::vx), at(Lanes::vy), at(Lanes::vz)), cosine);
    store_lanes(at(Lanes::shininess), shine);
    store_lanes(V(T(0)), spec);
    const auto counts = (n_dot_l > T(0)) & (visible > T(0));
    for (std::uint64_t m = lane_bits(counts); m; m &= m - 1) { // cos^shininess (std::pow) where the term counts
        const auto k = std::size_t(lowest_bit(m));
        spec[k] = specular_power(cosine[k], shine[k]);
    }
    const V diffuse = at(Lanes::kd) * n_dot_l, specular = at(Lanes::ks) * load_lanes<T, V>(spec);
    const auto add = [&](std::size_t sum, std::size_t object, std::size_t highlight, T colour) {
        const V term = lane_fma(diffuse, at(object), specular * at(highlight)) * V(colour);
        store_lanes(select(counts, lane_fma(visible, term, at(sum)), at(sum)), p + sum * stride);
    };
    add(Lanes::lr, Lanes::cr, Lanes::sr, light.r);
    add(Lanes::lg, Lanes::cg, Lanes::sg, light.g);
    add(Lanes::lb, Lanes::cb, Lanes::sb, light.b);
}

template <class T, template <class> class... S>
Color<T> end_shading(const Scene<T, S...>& scene, const Ray<T>& ray, const Shading<T>& s, int depth,
                     const RenderOptions& opt, RenderStats& stats);

// What shading the point in lane k under an area light needs (after side_pass).
template <class T>
[[nodiscard]] LitPoint<T> lit_point(const T* lanes, std::size_t stride, std::size_t k) noexcept {
    using Lanes = ShadingLanes<T>;
    const auto at = [&](std::size_t f) { return lanes[f * stride + k]; };
    return {Lanes::vertex(lanes, stride, k, Lanes::px),
            Lanes::vertex(lanes, stride, k, Lanes::hx),
            Lanes::vertex(lanes, stride, k, Lanes::nx),
            Lanes::vertex(lanes, stride, k, Lanes::vx),
            at(Lanes::kd),
            at(Lanes::ks),
            at(Lanes::shininess),
            {at(Lanes::cr), at(Lanes::cg), at(Lanes::cb)},
            {at(Lanes::sr), at(Lanes::sg), at(Lanes::sb)}};
}

// The scene's area lights at the point in lane k (after side_pass), added to its local colour
// after the point lights', in the lights' order: the same bits for a lane of a stream and for
// trace()'s one point.
// Lights [first, last) only; `corners` (where given): light i's corner c seen from lane k, at
// corners[(4(i − first) + c)·corner_stride + k].
template <class T, template <class> class... S>
void rect_lights_into_lanes(const Scene<T, S...>& scene, T* lanes, std::size_t stride, std::size_t k, bool opaque,
                            const RenderOptions& opt, RenderStats& stats, const T* corners = nullptr,
                            std::size_t corner_stride = 0, std::size_t first = 0, std::size_t last = SIZE_MAX,
                            const Color<T>* term = nullptr, const bool* known = nullptr) {
    using Lanes = ShadingLanes<T>;
    const LitPoint<T> p = lit_point(lanes, stride, k);
    const LightSampling sampling{std::clamp(opt.light_samples, 1, RenderOptions::max_light_samples),
                                 opt.adaptive_light_samples, opt.shadows, opaque};
    Color<T> sum = Lanes::local(lanes, stride, k);
    for (std::size_t i = first; i < std::min(last, scene.rect_lights.size()); ++i) {
        if (known && known[(i - first) * corner_stride + k]) {
            sum += term[(i - first) * corner_stride + k];
            continue;
        }
        T seen[4];
        if (corners)
            for (std::size_t c = 0; c < 4; ++c) seen[c] = corners[(4 * (i - first) + c) * corner_stride + k];
        sum += rect_light_term(scene, scene.rect_lights[i], p, light_seed(p.point, i), sampling, stats.shadow,
                               corners ? seen : nullptr);
    }
    Lanes::set(lanes, stride, k, Lanes::lr, sum);
}
} // namespace detail

/// The colour seen along `ray` (unit direction): nearest hit (§5), Phong with shadows (§7, §9),
/// reflection and transmission (§8) up to `max_depth`. `skip` culls objects (primary rays only).
template <class T, template <class> class... S>
[[nodiscard]] Color<T> trace(const Scene<T, S...>& scene, const Ray<T>& ray, int depth, const RenderOptions& opt,
                             RenderStats& stats, const typename Scene<T, S...>::Culled* skip = nullptr) {
    if (depth > RenderOptions::max_depth_limit)
        detail::throw_too_deep(depth); // render() checks opt.max_depth; this bounds direct calls too
    const Hit<T> sh = scene.intersect(ray, std::numeric_limits<T>::infinity(), skip);
    if (!sh) return scene.background;
    // The point as one lane, through the passes the renderer's streams run a register at a time
    // (the same bits): its surface and sides, then the lights one at a time.
    using Lanes = detail::ShadingLanes<T>;
    T lanes[Lanes::rows];
    const Material<T>* material = nullptr;
    const int only = 0;
    detail::hits_into_lanes(scene, &ray, &sh, &only, 1, lanes, 1, &material);
    const Material<T>& m = *material;
    detail::surface_pass<T, T>(lanes, 1);
    detail::side_pass<T, T>(lanes, 1);
    const Vertex<T> from = Lanes::vertex(lanes, 1, 0, Lanes::hx); // where shadow rays start
    const T& n_dot_l = lanes[Lanes::field(0, Lanes::n_dot_l)];
    T& visible = lanes[Lanes::field(0, Lanes::visible)];
    for (const PointLight<T>& light : scene.lights) {
        detail::light_direction_pass<T, T>(lanes, 1, 0, light.position);
        if (!(n_dot_l > T(0))) continue; // §7: facing away → unlit, no shadow ray needed
        visible = T(1);
        if (opt.shadows) { // §9: a ray towards the light; anything nearer than the light shadows
            ++stats.shadow;
            visible = scene.transmittance(Ray<T>{from, light.position - from}, T(1));
        }
        detail::light_term_pass<T, T>(lanes, 1, 0, light.color);
    }
    if (!scene.rect_lights.empty()) {
        bool opaque = true;
        for (const Material<T>& mat : scene.materials) opaque = opaque && mat.transparency == T(0);
        detail::rect_lights_into_lanes(scene, lanes, 1, 0, opaque, opt, stats);
    }
    const detail::Shading<T> s = Lanes::shading(lanes, 1, 0, m);
    return detail::end_shading(scene, ray, s, depth, opt, stats);
}

namespace detail {
// The reflected and transmitted rays of a shaded point (§8), where its material has them.
template <class T>
struct Secondary {
    bool reflects = false, transmits = false;
    Ray<T> reflected, transmitted;
    T reflectance = T(0); // with Material::fresnel: the Fresnel reflectance R at this point
};

template <class T>
Secondary<T> secondary_rays(const Ray<T>& ray, const Shading<T>& s, RenderStats& stats) noexcept {
    const Material<T>& m = *s.m;
    const Vertex<T>& d = ray.direction;
    Secondary<T> out;
    const bool fresnel = m.fresnel && m.transparency > T(0);
    if (fresnel) out.reflectance = fresnel_dielectric(dot(d, s.Nf), s.entering ? T(1) / m.ior : m.ior);
    if (m.reflectivity > T(0) || (fresnel && out.reflectance > T(0))) { // §8: Rd − 2(Rd·N)N from the hit point
        ++stats.reflection;
        Vertex<T> mirrored = reflect(d, s.Ns);
        if (!(dot(mirrored, s.Nf) > T(0))) mirrored = reflect(d, s.Nf); // a shading normal must not send it inside
        out.reflects = true, out.reflected = {s.above, mirrored};
    }
    if (m.transparency > T(0) && !(fresnel && out.reflectance >= T(1))) { // §8: straight through or bent by Snell's law
        Vertex<T> dir = d;
        bool reflected = false;
        if (m.ior != T(1)) {
            const T eta = s.entering ? T(1) / m.ior : m.ior; // n1/n2
            if (const auto r = refract(d, s.Nf, eta))
                dir = normalize(*r);
            else
                dir = reflect(d, s.Nf), reflected = true; // total internal reflection
        }
        ++stats.refraction;
        const Vertex<T> origin =
            reflected ? s.above : offset_ray_origin(BoundedPoint<T>{s.point, s.error}, s.Nf, -s.Nf);
        out.transmits = true, out.transmitted = {origin, dir};
    }
    return out;
}

// Whether a shaded point at `depth` sends secondary rays (else its colour is its local colour).
template <class T>
bool has_secondary(const Material<T>& m, int depth, const RenderOptions& opt) noexcept {
    return depth < opt.max_depth && (m.reflectivity > T(0) || m.transparency > T(0));
}

// The colour of a point with secondary rays: its local colour and what they brought back (§8).
template <class T>
Color<T> mix_secondary(const Material<T>& m, const Color<T>& local, const Color<T>& reflected,
                       const Color<T>& transmitted, T reflectance) noexcept {
    if (m.fresnel && m.transparency > T(0)) { // Fresnel: R·reflected + (1 − R)·transmitted
        const T share = std::min(T(1), m.reflectivity + m.transparency);
        return (T(1) - share) * local + share * (reflectance * reflected + (T(1) - reflectance) * transmitted);
    }
    Color<T> result = std::max(T(0), T(1) - m.reflectivity - m.transparency) * local;
    if (m.reflectivity > T(0)) result += m.reflectivity * reflected;
    if (m.transparency > T(0)) result += m.transparency * transmitted;
    return result;
}

// The shaded point's colour: its local colour, and the reflected and transmitted rays (§8).
template <class T, template <class> class... S>
Color<T> end_shading(const Scene<T, S...>& scene, const Ray<T>& ray, const Shading<T>& s, int depth,
                     const RenderOptions& opt, RenderStats& stats) {
    if (!has_secondary(*s.m, depth, opt)) return s.local;
    const Secondary<T> next = secondary_rays(ray, s, stats);
    Color<T> reflected{}, transmitted{};
    if (next.reflects) reflected = trace(scene, next.reflected, depth + 1, opt, stats);
    if (next.transmits) transmitted = trace(scene, next.transmitted, depth + 1, opt, stats);
    return mix_secondary(*s.m, s.local, reflected, transmitted, next.reflectance);
}
} // namespace detail

} // namespace isin
