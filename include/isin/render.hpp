#pragma once
/// isin — a Whitted-style renderer (note §3, §7–§11): primary rays per pixel, Phong shading with
/// shadow rays, recursive reflection and transmission, optional supersampling and backface
/// culling, multi-threaded over bands of rows traced in blocks of 8×8 pixels (streams of rays:
/// packets where the scene has Bvhs, rays × objects in lanes where it is small). Its options are
/// render/options.hpp's, its shading (trace) render/shade.hpp's, its streams render/stream.hpp's.
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

#include "area_light.hpp"
#include "camera.hpp"
#include "color.hpp"
#include "culling.hpp"
#include "detail/compiled.hpp"
#include "detail/parallel.hpp"
#include "image.hpp"
#include "offset.hpp"
#include "render/options.hpp"
#include "render/shade.hpp"
#include "render/stream.hpp"
#include "scene.hpp"
#include "shading.hpp"

namespace isin {

/// What primary rays leave out under `culling` (§11): per kind, the triangles that are backfaces
/// for the camera by the chosen method (spheres are never culled), and the back faces of placed
/// meshes, which the Bvh's leaf test skips as §11 method 1 with the eye at the ray's origin
/// (for triangles in front of the eye, method 2 decides alike).
template <class T, template <class> class... S>
[[nodiscard]] typename Scene<T, S...>::Culled backface_masks(const Scene<T, S...>& scene, const Camera<T>& cam,
                                                             Culling culling) {
    typename Scene<T, S...>::Culled culled;
    if (culling == Culling::none) return culled;
    culled.mesh_backfaces = true;
    scene.for_each_kind([&](auto kind, const auto& objects) {
        if (objects.empty() || !triangle_of(objects.front().shape)) return;
        auto& mask = culled.objects[kind];
        mask.resize(objects.size());
        for (std::size_t i = 0; i < objects.size(); ++i) {
            const Triangle<T>& tri = *triangle_of(objects[i].shape);
            mask[i] = culling == Culling::dot_product
                          ? is_backface(tri, cam.position())                                      // §11 method 1
                          : is_backface_projected(to_camera_space(cam, tri), cam.plane_distance); // §11 method 2
        }
    });
    return culled;
}

/// A band of image rows: [first, first + rows).
struct RowBand {
    int first = 0, rows = 0;
};

/// Band `index` of `count` equal bands of an image `height` rows tall: rows
/// [index·height/count, (index+1)·height/count), so the bands tile the image in order and differ
/// in size by one row at most. Throws std::invalid_argument unless 1 ≤ count ≤ height and
/// 0 ≤ index < count.
[[nodiscard]] inline RowBand row_band(int height, int index, int count) {
    if (count < 1 || count > height || index < 0 || index >= count)
        throw std::invalid_argument("isin::row_band: band " + std::to_string(index) + " of " + std::to_string(count) +
                                    " does not exist in an image " + std::to_string(height) + " rows tall");
    const auto edge = [&](int i) { return int(std::int64_t(i) * height / count); };
    return {edge(index), edge(index + 1) - edge(index)};
}

/// Renders rows [first_row, first_row + rows) of what `scene` looks like from `camera` into a
/// camera.width() × rows image: the same pixels, bit for bit, as those rows of a whole render,
/// so that bands rendered apart (other processes, other machines) can be stacked into the
/// picture (examples/merge_tiles). On opt.threads threads (fewer if some cannot be started).
/// Throws std::invalid_argument for samples outside [1, 16], light_samples outside
/// [1, max_light_samples], negative threads, max_depth outside
/// [0, max_depth_limit], rows outside the camera's; std::out_of_range for an object or
/// material whose material or texture does not exist (Scene::validate); and whatever a worker
/// threw (e.g. a user primitive, std::bad_alloc), once every worker has stopped.
template <class T, template <class> class... S>
[[nodiscard]] Image render_rows(const Scene<T, S...>& scene, const Camera<T>& camera, int first_row, int rows,
                                const RenderOptions& opt = {}, RenderStats* stats_out = nullptr) {
    if (opt.samples < 1 || opt.samples > 16)
        throw std::invalid_argument("isin::render: samples " + std::to_string(opt.samples) + " is outside [1, 16]");
    if (opt.threads < 0) throw std::invalid_argument("isin::render: threads must not be negative");
    if (opt.light_samples < 1 || opt.light_samples > RenderOptions::max_light_samples)
        throw std::invalid_argument("isin::render: light_samples " + std::to_string(opt.light_samples) +
                                    " is outside [1, " + std::to_string(RenderOptions::max_light_samples) + "]");
    if (opt.max_depth < 0 || opt.max_depth > RenderOptions::max_depth_limit)
        throw std::invalid_argument("isin::render: max_depth " + std::to_string(opt.max_depth) + " is outside [0, " +
                                    std::to_string(RenderOptions::max_depth_limit) + "]");
    if (first_row < 0 || rows < 1 || first_row > camera.height() - rows)
        throw std::invalid_argument("isin::render: rows " + std::to_string(first_row) + " + " + std::to_string(rows) +
                                    " are not within the camera's " + std::to_string(camera.height()));
    scene.validate();
    const auto start = std::chrono::steady_clock::now();
    const int W = camera.width(), N = opt.samples;
    Image image(W, rows);
    const auto masks = backface_masks(scene, camera, opt.culling);
    const auto* skip = opt.culling == Culling::none ? nullptr : &masks;

    // Bands of 8 rows, traced in blocks of 8×8 pixels ordered as four 4×4 tiles (the Bvh's
    // packets): 64 primary rays at a time, and their shadow rays, through the scene's stream calls.
    const int bands = (rows + 7) / 8;
    const int threads = std::min(detail::thread_count(opt.threads), bands);
    std::atomic<int> next_band{0}, rows_done{0};
    bool opaque = true; // nothing transparent: a shadow ray's transmittance is 0 or 1
    for (const Material<T>& m : scene.materials) opaque = opaque && m.transparency == T(0);
    std::vector<RenderStats> per_worker(static_cast<std::size_t>(threads)); // summed after the join: no lock

    auto work = [&](int worker, const detail::FirstError& error) {
        const bool reporter = worker == 0 && opt.progress;
        RenderStats local; // on the worker's own stack: no false sharing while counting
        for (int band; !error.failed() && (band = next_band.fetch_add(1)) < bands;) {
            const int row0 = 8 * band, band_rows = std::min(8, rows - row0);
            for (int x0 = 0; x0 < W; x0 += 8) {
                int at_x[detail::stream_rays], at_y[detail::stream_rays], n = 0; // the block's pixels, tile by tile
                for (int ty = 0; ty < band_rows; ty += 4)
                    for (int tx = x0; tx < std::min(x0 + 8, W); tx += 4)
                        for (int y = ty; y < std::min(ty + 4, band_rows); ++y)
                            for (int x = tx; x < std::min(tx + 4, W); ++x) at_x[n] = x, at_y[n++] = row0 + y;
                constexpr int values = 3 * detail::stream_rays;
                alignas(64) T sum[values]; // r, g, b of pixel k at 3k
                for (T& c : sum) c = T(0);
                for (int sy = 0; sy < N; ++sy)
                    for (int sx = 0; sx < N; ++sx) {
                        T px[detail::stream_rays], py[detail::stream_rays];
                        for (int k = 0; k < n; ++k) {
                            px[k] = T(at_x[k]) + (T(sx) + T(0.5)) / T(N) - T(0.5);
                            py[k] = T(first_row + at_y[k]) + (T(sy) + T(0.5)) / T(N) - T(0.5);
                        }
                        Ray<T> rays[detail::stream_rays];
                        camera.primary_rays(px, py, std::size_t(n), rays); // §3
                        local.primary += std::uint64_t(n);
                        Color<T> colour[detail::stream_rays];
                        detail::trace_stream(scene, rays, n, 0, opaque, opt, local, skip, colour);
                        for (int k = 0; k < n; ++k)
                            sum[3 * k] += colour[k].r, sum[3 * k + 1] += colour[k].g, sum[3 * k + 2] += colour[k].b;
                    }
                if (N > 1)
                    for (T& c : sum) c /= T(N * N); // the mean of the samples
                std::uint8_t bytes[values];         // in Rgb8's order
                if (opt.encoding == ColorEncoding::linear) {
                    to_bytes(sum, std::size_t(3 * n), bytes); // a register of channels at a time
                } else {
                    for (int k = 0; k < n; ++k) {
                        const Rgb8 p = to_rgb8(Color<T>{sum[3 * k], sum[3 * k + 1], sum[3 * k + 2]}, opt.encoding);
                        bytes[3 * k] = p.r, bytes[3 * k + 1] = p.g, bytes[3 * k + 2] = p.b;
                    }
                }
                static_assert(sizeof(Rgb8) == 3, "a pixel is its three bytes");
                for (int k = 0; k < n;) { // a tile's row of 4 pixels at once where it is whole
                    const int run = k + 3 < n && at_y[k + 3] == at_y[k] && at_x[k + 3] == at_x[k] + 3 ? 4 : 1;
                    std::memcpy(&image(at_x[k], at_y[k]), bytes + 3 * k, std::size_t(3 * run));
                    k += run;
                }
            }
            const int done = rows_done.fetch_add(band_rows) + band_rows;
            if (reporter && done < rows) opt.progress(done, rows);
        }
        per_worker[std::size_t(worker)] = local;
    };
    detail::run_workers(threads, work);
    if (opt.progress) opt.progress(rows, rows);
    RenderStats total;
    for (const RenderStats& s : per_worker) total += s;
    total.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stats_out) *stats_out = total;
    return image;
}

/// Renders `scene` as seen by `camera` into a camera.width() × camera.height() image: all rows
/// of render_rows, which says what it throws.
template <class T, template <class> class... S>
[[nodiscard]] Image render(const Scene<T, S...>& scene, const Camera<T>& camera, const RenderOptions& opt = {},
                           RenderStats* stats_out = nullptr) {
    return render_rows(scene, camera, 0, camera.height(), opt, stats_out);
}

} // namespace isin

// The renderer of StandardScene<float> and <double> comes from isin::io where ISIN_COMPILED is
// defined (detail/compiled.hpp).
#if defined(ISIN_COMPILED)
#define ISIN_DETAIL_RENDER(T, HERE)                                                                                    \
    HERE template isin::Image isin::render_rows(const isin::StandardScene<T>&, const isin::Camera<T>&, int, int,       \
                                                const isin::RenderOptions&, isin::RenderStats*);                       \
    HERE template isin::Image isin::render(const isin::StandardScene<T>&, const isin::Camera<T>&,                      \
                                           const isin::RenderOptions&, isin::RenderStats*);
ISIN_DETAIL_RENDER(float, ISIN_DETAIL_COMPILED_FLOAT)
ISIN_DETAIL_RENDER(double, ISIN_DETAIL_COMPILED_DOUBLE)
#undef ISIN_DETAIL_RENDER
#endif
