#pragma once
// Command-line parsing shared by the examples: option values checked with a clear message and
// exit status 2, and the common --width, --height, --output, --threads, --samples, --help, and
// the pieces a job scheduler can run apart: --tile I/N (a band of rows) and --frames A..B (frames
// of a camera path).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

#include <isin/image_io.hpp>
#include <isin/render.hpp>

#include "soft_lights.hpp"

namespace example {

/// Prints "PROGRAM: why" and the usage to stderr and exits with status 2.
[[noreturn]] inline void fail(const char* program, const std::string& why, const char* usage) {
    std::fprintf(stderr, "%s: %s\n%s", program, why.c_str(), usage);
    std::exit(2);
}

/// A progress bar on stderr for RenderOptions::progress: drawn when stderr is a terminal, once the
/// render has taken a second, at most every 100 ms; none otherwise.
inline std::function<void(int, int)> progress_bar() {
#if defined(__unix__) || defined(__APPLE__)
    if (!isatty(STDERR_FILENO)) return {};
#else
    return {};
#endif
    struct Bar {
        std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now(), last = start;
        bool shown = false;
    };
    auto bar = std::make_shared<Bar>(); // the callback is copied into the options
    return [bar](int done, int rows) {
        const auto now = std::chrono::steady_clock::now();
        if (done >= rows) {
            if (bar->shown) std::fprintf(stderr, "\r[%s] 100%%\n", "########################################");
            return;
        }
        if (now - bar->start < std::chrono::seconds(1) || now - bar->last < std::chrono::milliseconds(100)) return;
        bar->last = now, bar->shown = true;
        const int filled = 40 * done / rows;
        std::fprintf(stderr, "\r[%.*s%*s] %3d%%", filled, "########################################", 40 - filled, "",
                     100 * done / rows);
        std::fflush(stderr);
    };
}

/// The value after option argv[i] (i moves onto it); fails if there is none.
inline std::string string_option(int& i, int argc, char** argv, const char* usage) {
    if (i + 1 >= argc) fail(argv[0], std::string(argv[i]) + " needs a value", usage);
    return argv[++i];
}

/// `text` as an integer in [lo, hi]; fails naming the option otherwise.
inline int to_integer(const std::string& text, const std::string& option, int lo, int hi, const char* program,
                      const char* usage) {
    char* end = nullptr;
    const long v = std::strtol(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || v < lo || v > hi)
        fail(program,
             option + " must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + text +
                 "'",
             usage);
    return int(v);
}

/// The integer in [lo, hi] after option argv[i] (i moves onto it); fails otherwise.
inline int integer_option(int& i, int argc, char** argv, int lo, int hi, const char* usage) {
    const std::string option = argv[i];
    return to_integer(string_option(i, argc, argv, usage), option, lo, hi, argv[0], usage);
}

/// Fails (status 2) at once if a width × height image cannot be written to `path` (unknown
/// extension, too large for the PNG encoder), rather than after the rendering.
inline void check_output(const char* program, const std::string& path, int width, int height, const char* usage) {
    try {
        isin::check_image_output(path, width, height);
    } catch (const std::invalid_argument& e) {
        fail(program, e.what(), usage);
    }
}

/// --tile I/N: band I (from 0) of N bands of rows (isin::row_band); N = 1 is the whole image.
struct Tile {
    int index = 0, count = 1;
    [[nodiscard]] bool whole() const { return count == 1; }
};

/// Parses "I/N" with 1 ≤ N ≤ height and 0 ≤ I < N; fails (status 2) otherwise.
inline Tile to_tile(const std::string& text, int height, const char* program, const char* usage) {
    const std::size_t slash = text.find('/');
    if (slash == std::string::npos) fail(program, "--tile takes I/N (band I of N, from 0), got '" + text + "'", usage);
    const int count = to_integer(text.substr(slash + 1), "--tile's N", 1, height, program, usage);
    return {to_integer(text.substr(0, slash), "--tile's I", 0, count - 1, program, usage), count};
}

/// --frames A..B: frames A to B (inclusive, from 0) of an example's camera path.
struct FrameRange {
    int first = 0, last = -1;
    [[nodiscard]] bool given() const { return last >= first; }
};

/// Whether `text` has the form of a frame range: digits, "..", digits (so "../frames" is not one).
inline bool is_frame_range(const std::string& text) {
    const std::size_t dots = text.find("..");
    const auto digits = [&](std::size_t from, std::size_t to) {
        if (from >= to) return false;
        for (std::size_t k = from; k < to; ++k)
            if (text[k] < '0' || text[k] > '9') return false;
        return true;
    };
    return dots != std::string::npos && digits(0, dots) && digits(dots + 2, text.size());
}

/// Parses "A..B" with 0 ≤ A ≤ B ≤ max_frame; fails (status 2) otherwise.
inline FrameRange to_frame_range(const std::string& text, int max_frame, const char* program, const char* usage) {
    const std::size_t dots = text.find("..");
    if (dots == std::string::npos) fail(program, "--frames takes A..B, got '" + text + "'", usage);
    const int first = to_integer(text.substr(0, dots), "--frames' A", 0, max_frame, program, usage);
    return {first, to_integer(text.substr(dots + 2), "--frames' B", first, max_frame, program, usage)};
}

/// The file of frame `frame` for the output `pattern`: its "%d" or "%0Nd" (N a digit) replaced by
/// the number, or, without one, "_NNNN" (four digits at least) put before the extension.
inline std::string frame_path(const std::string& pattern, int frame) {
    char number[32];
    const std::size_t percent = pattern.find('%');
    if (percent != std::string::npos) {
        std::size_t end = percent + 1;
        int digits = 1;
        if (end + 1 < pattern.size() && pattern[end] == '0' && pattern[end + 1] >= '1' && pattern[end + 1] <= '9')
            digits = pattern[end + 1] - '0', end += 2;
        if (end < pattern.size() && pattern[end] == 'd') {
            std::snprintf(number, sizeof number, "%0*d", digits, frame);
            return pattern.substr(0, percent) + number + pattern.substr(end + 1);
        }
    }
    std::snprintf(number, sizeof number, "_%04d", frame);
    const std::size_t slash = pattern.find_last_of('/'), dot = pattern.find_last_of('.');
    const std::size_t at =
        dot != std::string::npos && (slash == std::string::npos || dot > slash) ? dot : pattern.size();
    return pattern.substr(0, at) + number + pattern.substr(at);
}

struct Options {
    int width = 800, height = 450, threads = 0, samples = 1;
    std::string output;
    std::string tile_text, frames_text; // read once the height is known (options come in any order)
    Tile tile;
    FrameRange frames;
    double area_light = 0;       // --area-light: side of the RectLights replacing the point lights (0: none)
    int light_samples = 16;      // --light-samples
    bool uniform_lights = false; // --uniform-light-samples: no adaptive sampling
    bool fresnel = false;        // --fresnel: transparent materials split light by Fresnel's equations
};

/// Reads option argv[i] into `o` if it is one of the lighting options (--area-light SIZE,
/// --light-samples N, --uniform-light-samples, --fresnel); returns false for any other.
inline bool lighting_option(int& i, int argc, char** argv, Options& o, const char* usage) {
    const std::string a = argv[i];
    if (a == "--area-light") {
        const std::string text = string_option(i, argc, argv, usage);
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !(v >= 0 && v <= 1e6))
            fail(argv[0], "--area-light must be a size in [0, 1e6], got '" + text + "'", usage);
        o.area_light = v;
    } else if (a == "--light-samples")
        o.light_samples = integer_option(i, argc, argv, 1, isin::RenderOptions::max_light_samples, usage);
    else if (a == "--uniform-light-samples")
        o.uniform_lights = true;
    else if (a == "--fresnel")
        o.fresnel = true;
    else
        return false;
    return true;
}

/// Applies the lighting options to `scene` and `opt`: point lights to RectLights of side
/// o.area_light·scale, the light samples, Fresnel on every transparent material.
template <class SceneT, class T>
void apply_lighting(SceneT& scene, const Options& o, isin::RenderOptions& opt, T scale) {
    to_area_lights(scene, T(o.area_light) * scale);
    opt.light_samples = o.light_samples;
    opt.adaptive_light_samples = !o.uniform_lights;
    if (o.fresnel)
        for (auto& m : scene.materials) m.fresnel = m.transparency > T(0);
}

/// Reads option argv[i] into `o` if it is one of the common ones (--width, --height, --threads,
/// --samples, --output, --help, and with `pieces` --tile and --frames); returns false for any
/// other.
inline bool common_option(int& i, int argc, char** argv, Options& o, const char* usage, bool pieces = true) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
        std::fputs(usage, stdout);
        std::exit(0);
    } else if (a == "--width")
        o.width = integer_option(i, argc, argv, 2, 32768, usage);
    else if (a == "--height")
        o.height = integer_option(i, argc, argv, 2, 32768, usage);
    else if (a == "--threads")
        o.threads = integer_option(i, argc, argv, 0, 1024, usage);
    else if (a == "--samples")
        o.samples = integer_option(i, argc, argv, 1, 16, usage);
    else if (a == "--output" || a == "-o")
        o.output = string_option(i, argc, argv, usage);
    else if (pieces && a == "--tile")
        o.tile_text = string_option(i, argc, argv, usage);
    else if (pieces && a == "--frames")
        o.frames_text = string_option(i, argc, argv, usage);
    else
        return false;
    return true;
}

/// Once every option is read: parses --tile and --frames (the last frame at most max_frame)
/// and checks that the output (every frame's file) can take the image or band
/// (width_factor·width wide).
inline void finish(Options& o, const char* program, const char* usage, int max_frame, int width_factor = 1) {
    if (!o.tile_text.empty()) o.tile = to_tile(o.tile_text, o.height, program, usage);
    if (!o.frames_text.empty()) o.frames = to_frame_range(o.frames_text, max_frame, program, usage);
    const int rows = isin::row_band(o.height, o.tile.index, o.tile.count).rows;
    check_output(program, o.frames.given() ? frame_path(o.output, o.frames.first) : o.output, width_factor * o.width,
                 rows, usage);
}

/// Parses the common options (common_option, finish), --tile and --frames with frames up to
/// `max_frame` when it is ≥ 0; `usage` is printed for --help (to stdout, status 0) and on errors
/// (stderr, status 2). The output must take an image `width_factor`·width × height. With
/// `lighting`, the lighting options too (lighting_option).
inline Options parse(int argc, char** argv, const char* usage, const std::string& default_output, int max_frame = -1,
                     int width_factor = 1, bool lighting = false) {
    Options o;
    o.output = default_output;
    for (int i = 1; i < argc; ++i)
        if (!common_option(i, argc, argv, o, usage, max_frame >= 0) &&
            !(lighting && lighting_option(i, argc, argv, o, usage)))
            fail(argv[0], "unknown option '" + std::string(argv[i]) + "'", usage);
    finish(o, argv[0], usage, max_frame, width_factor);
    return o;
}

/// Renders what `camera` sees, or only the band of rows o.tile names.
template <class SceneT, class T>
isin::Image render_tile(const SceneT& scene, const isin::Camera<T>& camera, const Options& o,
                        const isin::RenderOptions& opt, isin::RenderStats* stats = nullptr) {
    const isin::RowBand band = isin::row_band(camera.height(), o.tile.index, o.tile.count);
    return isin::render_rows(scene, camera, band.first, band.rows, opt, stats);
}

} // namespace example
