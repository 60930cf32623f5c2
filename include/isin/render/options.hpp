#pragma once
/// isin — the options of render and render_rows (RenderOptions: threads, samples, depth,
/// shadows, culling, progress, encoding, area-light samples) and the statistics of a render.
#include <cstdint>
#include <functional>

#include "../color.hpp"

namespace isin {

/// Which backface test culls triangles for primary rays (§11); shadow, reflected and refracted
/// rays always see both faces.
enum class Culling { none, dot_product, projected };

/// Options of `render`.
struct RenderOptions {
    int threads = 0;                 ///< worker threads; 0 = std::thread::hardware_concurrency()
    int samples = 1;                 ///< N×N rays per pixel (1 = the note's one ray per pixel)
    int max_depth = 4;               ///< longest chain of reflected/transmitted rays, 0 … max_depth_limit
    bool shadows = true;             ///< cast shadow rays (§9)
    Culling culling = Culling::none; ///< backface culling for primary rays (§11)
    /// Called as rows finish, with the rows done and the rows to render (last with both equal, on
    /// the calling thread); earlier calls come from one worker thread. Empty: no calls. The library
    /// prints nothing itself (the examples print a bar: examples/options.hpp).
    std::function<void(int rows_done, int rows)> progress;
    /// How the image's bytes encode the linear intensities shaded: byte = 255·intensity, the
    /// note's arithmetic (default), or sRGB, what screens and image viewers expect (pair it with
    /// textures decoded from sRGB: ModelOptions::textures, ImageTexture's encoding).
    ColorEncoding encoding = ColorEncoding::linear;
    /// Stratified samples per area light (RectLight) per shading point, 1 … max_light_samples.
    int light_samples = 16;
    /// Area lights' shadow rays to the four corners first (from 64 samples on, then to a quarter
    /// of the samples spread over the light), to all samples only where those disagree (a
    /// penumbra); false traces every sample's shadow ray.
    bool adaptive_light_samples = true;
    /// The largest light_samples.
    static constexpr int max_light_samples = 65536;
    /// The largest max_depth: trace() recurses once per bounce, and this many levels fit any
    /// thread's stack (as POV-Ray's max_trace_level, whose limit is also 256).
    static constexpr int max_depth_limit = 256;
};

/// Rays a render traced, by kind, and its wall time.
struct RenderStats {
    std::uint64_t primary = 0, shadow = 0, reflection = 0, refraction = 0;
    double seconds = 0;
    [[nodiscard]] std::uint64_t rays() const noexcept { return primary + shadow + reflection + refraction; }
    [[nodiscard]] double mrays_per_second() const noexcept { return seconds > 0 ? double(rays()) / seconds * 1e-6 : 0; }
    RenderStats& operator+=(const RenderStats& o) noexcept {
        primary += o.primary;
        shadow += o.shadow;
        reflection += o.reflection;
        refraction += o.refraction;
        return *this;
    }
};

} // namespace isin
