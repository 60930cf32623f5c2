#pragma once
/// isin — rectangular area lights (beyond the note, which has point lights only): a RectLight
/// shades as the mean of point lights of its colour spread over its rectangle (§7 per point, §9
/// per shadow ray). The renderer estimates that mean from stratified samples, jittered by a hash
/// of the shading point's coordinates: the same picture every run, whatever the threads, tiles or
/// bands, and independent noise from pixel to pixel.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "color.hpp"
#include "ray.hpp"
#include "shading.hpp"
#include "vec.hpp"

namespace isin {

/// The strata of `samples` stratified samples over a rectangle with edges of lengths |edge_u|
/// and |edge_v|: nu × nv = samples cells, nv the largest divisor of samples up to √samples (so
/// 16 → 4 × 4, 8 → 4 × 2, a prime p → p × 1), the longer edge divided more often.
struct LightStrata {
    int nu = 1, nv = 1;
};

/// LightStrata for `samples` ≥ 1 (values below 1 count as 1) over edges of lengths lu and lv.
template <class T>
[[nodiscard]] inline LightStrata light_strata(int samples, T lu, T lv) noexcept {
    const int n = samples < 1 ? 1 : samples;
    int small = 1;
    for (int d = 1; d * d <= n; ++d)
        if (n % d == 0) small = d;
    const int large = n / small;
    return lu >= lv ? LightStrata{large, small} : LightStrata{small, large};
}

namespace detail {
// splitmix64's finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mix.
[[nodiscard]] inline std::uint64_t mix64(std::uint64_t z) noexcept {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// The bits of a coordinate (float or double) as an integer, for hashing.
template <class T>
[[nodiscard]] inline std::uint64_t coordinate_bits(T x) noexcept {
    using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
    static_assert(sizeof(T) == sizeof(Bits), "float or double");
    Bits bits;
    std::memcpy(&bits, &x, sizeof x);
    return std::uint64_t(bits);
}
} // namespace detail

/// The seed of a shading point's light samples: a hash of its coordinates' bits and the light's
/// index, so that a point gets the same samples whoever shades it (threads, tiles, bands).
template <class T>
[[nodiscard]] inline std::uint64_t light_seed(const Vertex<T>& point, std::size_t light) noexcept {
    std::uint64_t h = detail::mix64(detail::coordinate_bits(point.x) + 0x9E3779B97F4A7C15ull * (light + 1));
    h = detail::mix64(h ^ detail::coordinate_bits(point.y));
    return detail::mix64(h ^ detail::coordinate_bits(point.z));
}

/// Sample k (0 ≤ k < nu·nv) of the multi-jittered set seeded by `seed` (Chiu, Shirley, Wang
/// 1994): in stratum (i, j) = (k mod nu, k div nu) of the nu × nv grid, and moreover the nu·nv
/// samples' u fall in distinct 1/(nu·nv) strata and so do their v (an edge across the rectangle
/// cuts off a well-stratified share): u = (i + (σ_i(j) + ξ1)/nv)/nu, v = (j + (τ_j(i) + ξ2)/nu)/nv,
/// σ_i, τ_j rotations by hashes of seed and i or j, ξ1, ξ2 in [0,1) from a hash of seed and k.
template <class T>
[[nodiscard]] inline Vertex<T> light_sample(const RectLight<T>& light, const LightStrata& strata, std::uint64_t seed,
                                            int k) noexcept {
    const auto index = [](int x) { return static_cast<std::uint64_t>(static_cast<unsigned>(x)) + 1u; };
    const int i = k % strata.nu, j = k / strata.nu;
    const std::uint64_t r = detail::mix64(seed + 0x9E3779B97F4A7C15ull * index(k));
    const std::uint64_t nu = index(strata.nu) - 1u, nv = index(strata.nv) - 1u;
    const std::uint64_t sigma = (index(j) - 1u + detail::mix64(seed ^ (0xD1B54A32D192ED03ull * index(i)))) % nv;
    const std::uint64_t tau = (index(i) - 1u + detail::mix64(seed ^ (0x8CB92BA72F3D8DD7ull * index(j)))) % nu;
    constexpr T unit = T(1) / T(16777216); // 2^-24: 24 random bits each, exact in float
    const T xi1 = T(r >> 40) * unit, xi2 = T((r >> 8) & 0xFFFFFFu) * unit;
    const T u = (T(i) + (T(sigma) + xi1) / T(strata.nv)) / T(strata.nu);
    const T v = (T(j) + (T(tau) + xi2) / T(strata.nu)) / T(strata.nv);
    return light.corner + u * light.edge_u + v * light.edge_v;
}

/// What shading a point under an area light needs: the point, where its shadow rays start, its
/// unit normal N and direction to the eye V (both on the side lit), and its Phong inputs (§7).
template <class T>
struct LitPoint {
    Vertex<T> point, from, N, V;
    T kd, ks, shininess;
    Color<T> object, highlight;
};

/// Corner c (0 … 3) of a RectLight: corner, corner + edge_u, corner + edge_v, the far one.
template <class T>
[[nodiscard]] inline Vertex<T> light_corner(const RectLight<T>& light, int c) noexcept {
    return light.corner + ((c & 1) ? light.edge_u : Vertex<T>{}) + ((c & 2) ? light.edge_v : Vertex<T>{});
}

/// How a RectLight is sampled at one point.
struct LightSampling {
    int samples = 16;     ///< stratified samples over the rectangle
    bool adaptive = true; ///< shadow rays to the four corners first, to the samples only if they disagree
    bool shadows = true;  ///< cast shadow rays (§9); without, every sample is visible
    bool opaque = true;   ///< nothing in the scene is transparent: shadow rays through `occluded`
};

/// Whether rect_light_term traces shadow rays to the corners first (LightSampling::adaptive with
/// shadows and 8 samples or more).
[[nodiscard]] inline bool corners_first(const LightSampling& s) noexcept {
    return s.adaptive && s.shadows && s.samples >= 8;
}

/// The mean over the rectangle of `light` of a PointLight's Phong term (§7) at p, shadows
/// included (§9), estimated from s.samples stratified samples seeded by `seed`: the colour it adds
/// to p's local colour. Shadow rays go to `scene` as a stream (occluded, or transmittance unless
/// s.opaque); `shadow_rays` counts them. With s.adaptive (and 8 samples or more) the shadow rays
/// to the rectangle's four corners are traced first, and when they agree the samples take their
/// value without rays (as POV-Ray's adaptive area lights): exact outside penumbrae, but an
/// occluder that hides none or all of the corners and not the rest from p is missed.
/// `corners`, where given, holds what the shadow rays from p.from to the four corners found
/// (1 − blocked, or their transmittance): traced by the caller with other points' (a stream).
template <class T, class SceneT>
[[nodiscard]] Color<T> rect_light_term(const SceneT& scene, const RectLight<T>& light, const LitPoint<T>& p,
                                       std::uint64_t seed, const LightSampling& s, std::uint64_t& shadow_rays,
                                       const T* corners = nullptr) {
    const LightStrata strata = light_strata(s.samples, length(light.edge_u), length(light.edge_v));
    const int n = strata.nu * strata.nv;
    // A highlight term below 2^-24 of ks is left out: cos^shininess < 2^-24 where cos < 2^(-24/shininess).
    const T min_cos = p.shininess > T(0) ? std::exp2(T(-24) / p.shininess) : T(2);
    constexpr int chunk = 64; // samples per stream of shadow rays
    Ray<T> rays[chunk];
    T n_dot_l[chunk], spec[chunk], one[chunk], through[chunk];
    std::uint8_t blocked[chunk];
    for (T& t : one) t = T(1);
    T diffuse_sum = T(0), specular_sum = T(0);
    // Adds every sample's term, with its shadow ray or, where `assumed` ≥ 0, that visibility.
    const auto shade = [&](T assumed) {
        for (int k0 = 0; k0 < n;) {
            int m = 0;
            for (; k0 < n && m < chunk; ++k0) {
                const Vertex<T> q = light_sample(light, strata, seed, k0);
                const Vertex<T> d = q - p.point;
                const T len2 = dot(d, d);
                if (!(len2 > T(0))) continue;
                const Vertex<T> L = d / std::sqrt(len2);
                const T c = dot(p.N, L);               // §7: N·L
                if (!(c > T(0))) continue;             // §7: facing away → unlit, no shadow ray needed
                const Vertex<T> Rf = reflect(-L, p.N); // §7: Rf = d − 2(d·N)N with d = −L
                const T cosine = dot(Rf, p.V);
                n_dot_l[m] = c;
                spec[m] = cosine > min_cos ? specular_power(cosine, p.shininess) : T(0); // §7: cos^shininess
                rays[m++] = {p.from, q - p.from};
            }
            if (m == 0) continue;
            if (assumed >= T(0) || !s.shadows) {
                const T v = s.shadows ? assumed : T(1);
                for (int i = 0; i < m; ++i) through[i] = v;
            } else { // §9: a ray towards the sample; anything nearer than it shadows
                shadow_rays += std::uint64_t(m);
                if (s.opaque) {
                    scene.occluded(rays, std::size_t(m), one, blocked);
                    for (int i = 0; i < m; ++i) through[i] = blocked[i] ? T(0) : T(1);
                } else {
                    scene.transmittance(rays, std::size_t(m), one, through);
                }
            }
            for (int i = 0; i < m; ++i) diffuse_sum += through[i] * n_dot_l[i], specular_sum += through[i] * spec[i];
        }
    };
    if (!corners_first(LightSampling{n, s.adaptive, s.shadows, s.opaque})) {
        shade(T(-1));
    } else {
        // §9: shadow rays to the rectangle's four corners first; where they agree, the samples
        // take their value (exact for one straight occluding edge, which cuts the rectangle by a line).
        if (corners) {
            for (int c = 0; c < 4; ++c) through[c] = corners[c];
        } else {
            for (int c = 0; c < 4; ++c) rays[c] = {p.from, light_corner(light, c) - p.from};
            shadow_rays += 4u;
            if (s.opaque) {
                scene.occluded(rays, 4u, one, blocked);
                for (int c = 0; c < 4; ++c) through[c] = blocked[c] ? T(0) : T(1);
            } else {
                scene.transmittance(rays, 4u, one, through);
            }
        }
        const bool agree = through[0] == through[1] && through[0] == through[2] && through[0] == through[3];
        if (agree && through[0] == T(0)) return {T(0), T(0), T(0)}; // umbra: every sample shadowed
        shade(agree ? through[0] : T(-1));
    }
    const T scale = T(1) / T(n); // the mean over the samples
    return (p.kd * diffuse_sum * p.object + p.ks * specular_sum * p.highlight) * light.color *
           scale; // §7: kd·diffuse + ks·specular, averaged
}

} // namespace isin
