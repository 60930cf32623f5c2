#pragma once
/// isin — private: the renderer's streams: up to stream_rays rays traced together (trace_stream),
/// through the scene's stream calls and the lane passes of render/shade.hpp.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "../scene.hpp"
#include "options.hpp"
#include "shade.hpp"

namespace isin {
namespace detail {

// Secondary rays go as streams down to this depth, then one by one (trace()): each level keeps
// its rays' shading on the stack.
constexpr int stream_depth = 4;
// Rays traced together: the renderer's 8×8 blocks of pixels (four 4×4 tiles, the Bvh's packets),
// their shadow rays, and their reflected and transmitted rays.
constexpr int stream_rays = 64;

// §7, §9: the point lights' terms into the lanes of a stream's `count` shaded points (padded to
// `padded`), their shadow rays traced as streams.
template <class T, template <class> class... S>
ISIN_DETAIL_INLINE void point_lights_stream(const Scene<T, S...>& scene, T* lanes, int count, std::size_t padded,
                                            bool opaque, const RenderOptions& opt, RenderStats& stats) {
    constexpr int N = stream_rays;
    using Lanes = ShadingLanes<T>;
    constexpr std::size_t W = Lanes::width, stride = N;
    const T* from[3] = {lanes + Lanes::hx * stride, lanes + Lanes::hy * stride, lanes + Lanes::hz * stride};
    // §7, §9: the lights' terms, up to `slots` lights at a time, as many as fit their shadow rays
    // in one stream.
    const std::size_t lights = scene.lights.size();
    for (std::size_t first = 0; first < lights;) {
        Ray<T> shadow[N];
        T* visible_of[N]; // each shadow ray's lane, for what it finds
        int m = 0;
        std::size_t last = first;
        for (; last < lights && last - first < Lanes::slots && m + count <= N; ++last) {
            const std::size_t slot = last - first;
            const PointLight<T>& light = scene.lights[last];
            for (std::size_t k = 0; k < padded; k += W) light_direction_pass(lanes + k, stride, slot, light.position);
            const T* n_dot_l = lanes + Lanes::field(slot, Lanes::n_dot_l) * stride;
            T* visible = lanes + Lanes::field(slot, Lanes::visible) * stride;
            for (std::size_t k = 0; k < padded; ++k) visible[k] = T(0);
            for (std::size_t i = 0; i < std::size_t(count); ++i) {
                if (!(n_dot_l[i] > T(0))) continue; // §7: facing away → unlit, no shadow ray needed
                const Vertex<T> o{from[0][i], from[1][i], from[2][i]};
                visible_of[m] = visible + i, shadow[m++] = {o, light.position - o};
            }
        }
        T visible[N];
        if (!opt.shadows) {
            for (int i = 0; i < m; ++i) visible[i] = T(1);
        } else { // §9: a ray towards the light; anything nearer than the light shadows
            stats.shadow += std::uint64_t(m);
            T one[N];
            for (T& t : one) t = T(1);
            if (opaque) {
                std::uint8_t blocked[N];
                scene.occluded(shadow, std::size_t(m), one, blocked);
                for (int i = 0; i < m; ++i) visible[i] = blocked[i] ? T(0) : T(1);
            } else {
                scene.transmittance(shadow, std::size_t(m), one, visible);
            }
        }
        for (int i = 0; i < m; ++i) *visible_of[i] = visible[i];
        for (std::size_t light = first; light < last; ++light)
            for (std::size_t k = 0; k < padded; k += W)
                light_term_pass(lanes + k, stride, light - first, scene.lights[light].color);
        first = last;
    }
}

// §9: area light i's terms at the stream's points whose every sample gets its shadow ray (corners
// that disagree, or none traced: `corners`, where given, holds what corner c found from point k at
// corners[c·count + k]), by rect_light_terms_together for runs of consecutive such points whose
// origins lie within together_spread strata of each other: into term[k], known[k] set. The bits
// are rect_light_term's; the others are left to it.
template <class T, template <class> class... S>
void rect_light_runs(const Scene<T, S...>& scene, const T* lanes, int count, std::size_t i, const T* corners,
                     const LightSampling& sampling, RenderStats& stats, Color<T>* term, bool* known) {
    constexpr std::size_t stride = stream_rays;
    const RectLight<T>& light = scene.rect_lights[i];
    const LightStrata strata = light_strata(sampling.samples, length(light.edge_u), length(light.edge_v));
    const T reach =
        T(together_spread) * std::min(length(light.edge_u) / T(strata.nu), length(light.edge_v) / T(strata.nv));
    LitPoint<T> p[stream_rays];
    int member[stream_rays], members = 0;
    for (int k = 0; k < count; ++k) {
        T seen[4];
        if (corners) {
            for (int c = 0; c < 4; ++c) seen[c] = corners[std::size_t(c * count + k)];
            if (seen[1] == seen[0] && seen[2] == seen[0] && seen[3] == seen[0]) continue; // agree, whatever votes
        }
        p[members] = lit_point(lanes, stride, std::size_t(k));
        if (corners) {
            bool agree = true;
            if (corner_vote(light, p[members], seen, agree) < T(0) || agree) continue; // not every sample's ray
        }
        member[members++] = k;
    }
    for (int a = 0; a < members;) {
        Vertex<T> lo = p[a].from, hi = lo; // the run's origins' box
        int b = a + 1;
        for (; b < members && b - a < together_points; ++b) {
            const Vertex<T> f = p[b].from;
            const Vertex<T> l{std::min(lo.x, f.x), std::min(lo.y, f.y), std::min(lo.z, f.z)};
            const Vertex<T> h{std::max(hi.x, f.x), std::max(hi.y, f.y), std::max(hi.z, f.z)};
            if (!(std::max({h.x - l.x, h.y - l.y, h.z - l.z}) <= reach)) break;
            lo = l, hi = h;
        }
        if (b - a >= 2) { // one point alone: rect_light_term
            std::uint64_t seed[together_points];
            Color<T> out[together_points];
            for (int j = a; j < b; ++j) seed[j - a] = light_seed(p[j].point, i);
            rect_light_terms_together(scene, light, p + a, seed, b - a, sampling, stats.shadow, out);
            for (int j = a; j < b; ++j) term[member[j]] = out[j - a], known[member[j]] = true;
        }
        a = b;
    }
}

// §9: the area lights' terms into the lanes of a stream's `count` shaded points.
template <class T, template <class> class... S>
ISIN_DETAIL_INLINE void rect_lights_stream(const Scene<T, S...>& scene, T* lanes, int count, bool opaque,
                                           const RenderOptions& opt, RenderStats& stats) {
    constexpr int N = stream_rays;
    using Lanes = ShadingLanes<T>;
    constexpr std::size_t stride = N;
    const T* from[3] = {lanes + Lanes::hx * stride, lanes + Lanes::hy * stride, lanes + Lanes::hz * stride};
    if (!scene.rect_lights.empty()) {
        // §9: with adaptive sampling, the shadow rays to each area light's corners first, as a
        // stream per corner (coherent as a point light's), up to a few lights at a time.
        const LightSampling sampling{std::clamp(opt.light_samples, 1, RenderOptions::max_light_samples),
                                     opt.adaptive_light_samples, opt.shadows, opaque};
        constexpr std::size_t lights_at_once = 2;
        const std::size_t rect_lights = scene.rect_lights.size();
        for (std::size_t first = 0; first < rect_lights; first += lights_at_once) {
            const std::size_t last = std::min(rect_lights, first + lights_at_once);
            T corners[4 * lights_at_once * N];
            const bool traced = corners_first(sampling) && count > 0;
            if (traced) {
                Ray<T> corner_rays[4 * lights_at_once * N];
                T one[4 * lights_at_once * N];
                std::size_t m = 0;
                for (std::size_t i = first; i < last; ++i)
                    for (int c = 0; c < 4; ++c) {
                        const Vertex<T> q = light_corner(scene.rect_lights[i], c);
                        for (int k = 0; k < count; ++k) {
                            const Vertex<T> o{from[0][k], from[1][k], from[2][k]};
                            one[m] = T(1), corner_rays[m++] = {o, q - o};
                        }
                    }
                stats.shadow += std::uint64_t(m);
                if (opaque) {
                    std::uint8_t blocked[4 * lights_at_once * N];
                    scene.occluded(corner_rays, m, one, blocked);
                    for (std::size_t j = 0; j < m; ++j) corners[j] = blocked[j] ? T(0) : T(1);
                } else {
                    scene.transmittance(corner_rays, m, one, corners);
                }
            }
            // The terms of the points shaded together (rect_light_runs), light i's at (i − first)·count + k.
            Color<T> term[lights_at_once * N] = {};
            bool known[lights_at_once * N] = {};
            constexpr bool together = std::is_same_v<T, float>; // packets are float's
            if constexpr (together)
                for (std::size_t i = first; i < last && sampling.shadows; ++i)
                    rect_light_runs(scene, lanes, count, i,
                                    traced ? corners + 4 * (i - first) * std::size_t(count) : nullptr, sampling, stats,
                                    term + (i - first) * std::size_t(count), known + (i - first) * std::size_t(count));
            for (std::size_t i = 0; i < std::size_t(count); ++i)
                rect_lights_into_lanes(scene, lanes, stride, i, opaque, opt, stats, traced ? corners : nullptr,
                                       std::size_t(count), first, last, together ? term : nullptr,
                                       together ? known : nullptr);
        }
    }
}

// Up to stream_rays rays at `depth` (a block of primary rays at depth 0, which `skip` culls),
// each one's colour into out[] exactly as trace() computes it: the rays through the scene's
// stream intersect (packets), the shadow rays of all lights through the stream occluded when
// nothing in the scene is transparent (then transmittance is 0 or 1), else through the stream
// transmittance, and each point's lights added in the lights' order; the reflected and the
// transmitted rays as streams of their own.
template <class T, template <class> class... S>
void trace_stream(const Scene<T, S...>& scene, const Ray<T>* rays, int n, int depth, bool opaque,
                  const RenderOptions& opt, RenderStats& stats, const typename Scene<T, S...>::Culled* skip,
                  Color<T>* out) {
    constexpr int N = stream_rays;
    Hit<T> hits[N];
    scene.intersect(rays, std::size_t(n), hits, skip);
    // Each hit's surface into its lane, then the passes a register of lanes at a time.
    using Lanes = ShadingLanes<T>;
    constexpr std::size_t W = Lanes::width, stride = N;
    alignas(64) T lanes[Lanes::rows * stride];
    const Material<T>* material[N];
    int shaded[N] = {}, count = 0; // (zeroed: g++ warns of a pointer to an array not yet written)
    for (int k = 0; k < n; ++k) {
        if (hits[k])
            shaded[count++] = k;
        else
            out[k] = scene.background;
    }
    hits_into_lanes(scene, rays, hits, shaded, std::size_t(count), lanes, stride, material);
    const std::size_t padded = (std::size_t(count) + W - 1) / W * W;
    for (std::size_t k = std::size_t(count); k < padded; ++k) Lanes::clear(lanes, stride, k);
    for (std::size_t k = 0; k < padded; k += W) surface_pass(lanes + k, stride), side_pass(lanes + k, stride);
    point_lights_stream(scene, lanes, count, padded, opaque, opt, stats);
    rect_lights_stream(scene, lanes, count, opaque, opt, stats);
    // §8: the reflected and the transmitted rays of every point that has them, as two streams.
    Ray<T> next[2][N];
    int counts[2] = {0, 0}, slot[2][N];
    int mixed[N], mixes = 0; // the points with secondary rays, by lane
    T reflectance[N];        // their Fresnel reflectances, by ray
    for (int i = 0; i < count; ++i) {
        const int k = shaded[i];
        if (!has_secondary(*material[i], depth, opt)) {
            out[k] = Lanes::local(lanes, stride, std::size_t(i));
            continue;
        }
        const Secondary<T> sec =
            secondary_rays(rays[k], Lanes::shading(lanes, stride, std::size_t(i), *material[i]), stats);
        slot[0][k] = slot[1][k] = -1;
        if (sec.reflects) slot[0][k] = counts[0], next[0][counts[0]++] = sec.reflected;
        if (sec.transmits) slot[1][k] = counts[1], next[1][counts[1]++] = sec.transmitted;
        reflectance[k] = sec.reflectance;
        mixed[mixes++] = i;
    }
    if (mixes == 0) return;
    Color<T> back[2][N];
    for (int j = 0; j < 2; ++j) {
        if (counts[j] == 0) continue;
        if (depth + 1 < stream_depth)
            trace_stream(scene, next[j], counts[j], depth + 1, opaque, opt, stats, nullptr, back[j]);
        else
            for (int i = 0; i < counts[j]; ++i) back[j][i] = trace(scene, next[j][i], depth + 1, opt, stats);
    }
    for (int j = 0; j < mixes; ++j) {
        const int i = mixed[j], k = shaded[i];
        const Color<T> none{};
        out[k] = mix_secondary(*material[i], Lanes::local(lanes, stride, std::size_t(i)),
                               slot[0][k] >= 0 ? back[0][slot[0][k]] : none,
                               slot[1][k] >= 0 ? back[1][slot[1][k]] : none, reflectance[k]);
    }
}
} // namespace detail
} // namespace isin
