#pragma once
/// isin — Phong shading (note §7), refraction by Snell's law (§8), materials and lights.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <type_traits>

#include "color.hpp"
#include "texture.hpp"
#include "vec.hpp"

namespace isin {

/// Surface properties. The note's Phong weights satisfy ka + kd + ks = 1 (§7); reflectivity and
/// transparency in [0,1] mix in the colour seen along the reflected and transmitted rays (§8):
/// final = (1 − reflectivity − transparency)·local + reflectivity·reflected + transparency·transmitted.
/// With ior = 1 a transparent surface lets the ray straight through, as the note says; any other
/// index of refraction bends it by Snell's law. `texture` indexes the scene's textures (−1: none).
/// Beyond the note: a highlight colour, an ambient colour and a texture filter of its own, for
/// materials from .mtl files (load_model); and `fresnel`, which splits a transparent surface's
/// reflected and transmitted light by the Fresnel equations instead of the fixed weights.
template <class T>
struct Material {
    static_assert(std::is_floating_point_v<T>, "isin::Material needs a floating-point type");
    Color<T> color{T(1), T(1), T(1)};
    T ka = T(0.1), kd = T(0.7), ks = T(0.2); // §7: ka + kd + ks = 1
    T shininess = T(32);                     // §7: specular exponent
    T reflectivity = T(0);                   // §8: weight of the reflected colour, [0,1]
    T transparency = T(0);                   // §8: weight of the transmitted colour, [0,1]
    T ior = T(1);                            // §8: index of refraction; 1 = straight through
    int texture = -1;                        // §10: index into the scene's textures, −1 = none
    /// Colour of the highlight (§7 uses white; a .mtl file's Ks).
    Color<T> specular_color{T(1), T(1), T(1)};
    /// Tint of the ambient term (§7: ka·object colour; white keeps the note's), a .mtl file's Ka.
    Color<T> ambient_color{T(1), T(1), T(1)};
    /// How this material's texture is read; none = the scene's texture_filter.
    std::optional<Filter> texture_filter;
    /// Where transparency > 0: the share reflectivity + transparency (at most 1) of the colour
    /// goes R·reflected + (1 − R)·transmitted, R the unpolarised Fresnel reflectance for `ior`
    /// at the ray's angle (fresnel_dielectric; 1 on total internal reflection).
    bool fresnel = false;
};

/// A point light with a colour (white by default).
template <class T>
struct PointLight {
    Vertex<T> position;
    Color<T> color{T(1), T(1), T(1)};
};

/// A rectangular area light: the parallelogram corner + u·edge_u + v·edge_v (u, v in [0,1]), a
/// light of `color` spread uniformly over it. It shades as the mean, over the rectangle, of what a
/// PointLight of its colour at each point would give (diffuse, specular and shadow); the renderer
/// estimates that mean from RenderOptions::light_samples stratified points. It is not seen by rays.
template <class T>
struct RectLight {
    static_assert(std::is_floating_point_v<T>, "isin::RectLight needs a floating-point type");
    Vertex<T> corner, edge_u, edge_v;
    Color<T> color{T(1), T(1), T(1)};
};

/// Corner c (0 … 3) of a RectLight: corner, corner + edge_u, corner + edge_v, the far one.
template <class T>
[[nodiscard]] inline Vertex<T> light_corner(const RectLight<T>& light, int c) noexcept {
    return light.corner + ((c & 1) ? light.edge_u : Vertex<T>{}) + ((c & 2) ? light.edge_v : Vertex<T>{});
}

/// Diffuse coefficient (§7): N·L for unit N and L (L from the point to the light); negative → 0.
template <class T>
[[nodiscard]] constexpr T diffuse_coefficient(const Vertex<T>& N, const Vertex<T>& L) noexcept {
    const T c = dot(N, L);      // §7: cos of the angle between N and L
    return c > T(0) ? c : T(0); // §7: facing away from the light → unlit
}

/// Diffuse colour (§7): coefficient × object colour.
template <class T>
[[nodiscard]] constexpr Color<T> diffuse(const Vertex<T>& N, const Vertex<T>& L, const Color<T>& object) noexcept {
    return diffuse_coefficient(N, L) * object; // §7: N·L × colour
}

/// The specular highlight's falloff (§7): cos^shininess for the cosine c of the angle between the
/// mirrored light direction and the eye's; 0 where c ≤ 0 (the highlight faces away) or is NaN.
template <class T>
[[nodiscard]] inline T specular_power(T c, T shininess) noexcept {
    if (!(c > T(0))) return T(0);
    // c < 2^b from c's exponent bits; where b·shininess ≤ −(the smallest subnormal's exponent + 3),
    // c^shininess is below a quarter of the smallest subnormal, which std::pow (error < 1 ulp)
    // rounds to 0: the same 0 without pow's underflow path (errno, a slow call per dark lane).
    if constexpr (std::numeric_limits<T>::is_iec559 && (sizeof(T) == 4 || sizeof(T) == 8)) {
        using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
        constexpr int mantissa = std::numeric_limits<T>::digits - 1, bias = std::numeric_limits<T>::max_exponent - 1;
        constexpr T never = T(std::numeric_limits<T>::min_exponent - mantissa - 4); // −152 (float), −1077 (double)
        Bits bits;
        std::memcpy(&bits, &c, sizeof c);
        const int b = int(bits >> mantissa) - bias + 1; // c < 2^b (also for subnormal c)
        if (T(b) * shininess <= never) return T(0);
    }
    return std::pow(c, shininess); // §7: cos^shininess
}

/// Specular coefficient (§7): reflect the light-to-surface direction −L about N
/// (Rf = d − 2(d·N)N), take its cosine with V (unit, towards the eye), raise it to `shininess`.
template <class T>
[[nodiscard]] inline T specular_coefficient(const Vertex<T>& N, const Vertex<T>& L, const Vertex<T>& V,
                                            T shininess) noexcept {
    const Vertex<T> Rf = reflect(-L, N);          // §7: Rf = d − 2(d·N)N with d = −L
    return specular_power(dot(Rf, V), shininess); // §7: cos(Rf, V)^shininess
}

/// Ambient colour (§7): object colour × a coefficient in [0,1].
template <class T>
[[nodiscard]] constexpr Color<T> ambient(const Color<T>& object, T coefficient) noexcept {
    return coefficient * object; // §7: ambient
}

/// One light's Phong contribution (§7) at a point with unit normal N, unit L towards the light
/// and unit V towards the eye: kd·diffuse + ks·specular, both tinted by the light's colour.
template <class T>
[[nodiscard]] inline Color<T> phong_light(const Material<T>& m, const Color<T>& object, const Vertex<T>& N,
                                          const Vertex<T>& L, const Vertex<T>& V, const Color<T>& light) noexcept {
    const T NdotL = diffuse_coefficient(N, L);
    if (NdotL <= T(0)) return {T(0), T(0), T(0)};
    return (m.kd * NdotL * object + m.ks * specular_coefficient(N, L, V, m.shininess) * m.specular_color) *
           light; // §7: kd·diffuse + ks·specular (a white highlight unless the material says otherwise)
}

/// Refracted direction by Snell's law (§8), n1 sin θ1 = n2 sin θ2, for a unit direction d and a
/// unit normal n facing against d (d·n ≤ 0); eta = n1 / n2. Empty on total internal reflection.
template <class T>
[[nodiscard]] inline std::optional<Vertex<T>> refract(const Vertex<T>& d, const Vertex<T>& n, T eta) noexcept {
    const T cos_i = -dot(d, n);
    const T sin2_t = eta * eta * (T(1) - cos_i * cos_i); // §8: sin²θ2 = (n1/n2)² sin²θ1
    if (!(sin2_t <= T(1))) return std::nullopt;          // §8: total internal reflection (or NaN)
    const T cos_t = std::sqrt(T(1) - sin2_t);
    return eta * d + (eta * cos_i - cos_t) * n;
}

/// Reflectances of a dielectric interface for the s- and p-polarised parts of the light.
template <class T>
struct FresnelReflectance {
    T s, p;
    /// Unpolarised light's reflectance: the mean of the two (Fresnel's equations).
    [[nodiscard]] T unpolarised() const noexcept { return (s + p) / T(2); }
};

/// Fresnel's equations for a dielectric interface (Hecht, Optics, §4.6): the s- and p-polarised
/// reflectances of light that meets it at cos θ1 = cos_i (its absolute value, clamped to 1) from
/// the side of index n1, eta = n1 / n2; both 1 on total internal reflection (and for NaN input).
template <class T>
[[nodiscard]] inline FresnelReflectance<T> fresnel_reflectance(T cos_i, T eta) noexcept {
    const T c1 = std::min(std::abs(cos_i), T(1));
    const T sin2_t = eta * eta * (T(1) - c1 * c1); // §8: sin²θ2 = (n1/n2)² sin²θ1
    if (!(sin2_t < T(1))) return {T(1), T(1)};     // §8: total internal reflection: all reflected
    const T c2 = std::sqrt(T(1) - sin2_t);
    const T rs = (eta * c1 - c2) / (eta * c1 + c2); // Fresnel: r_s = (n1 cos θ1 − n2 cos θ2)/(n1 cos θ1 + n2 cos θ2)
    const T rp = (eta * c2 - c1) / (eta * c2 + c1); // Fresnel: r_p = (n1 cos θ2 − n2 cos θ1)/(n1 cos θ2 + n2 cos θ1)
    return {rs * rs, rp * rp};                      // Fresnel: R = r²
}

/// Unpolarised Fresnel reflectance (Rs + Rp)/2 of a dielectric interface (fresnel_reflectance);
/// the transmitted share is 1 − R.
template <class T>
[[nodiscard]] inline T fresnel_dielectric(T cos_i, T eta) noexcept {
    return fresnel_reflectance(cos_i, eta).unpolarised();
}

} // namespace isin
