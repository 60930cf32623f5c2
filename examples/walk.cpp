// Walks through the note's scene in a terminal (note §12): W/A/S/D move, ←/→ or J/L turn, ↑/↓ or
// I/K look up and down, P saves the view as PNG, Q quits. 24-bit colour, two pixels per
// character cell (upper half block), sized to the terminal; a coarse frame first while moving,
// full resolution when the camera stops. Headless: --script KEYS replays keys and writes PNGs.
// The camera is the note's (§3: eye, plane 9 high at distance 10) with square pixels at any size.
// Build: c++ -std=c++17 -O2 -DISIN_IMPLEMENTATION -I include examples/walk.cpp -o walk
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include "note_scene.hpp"
#include "options.hpp"

namespace {

constexpr float move_step = 4.0f;                        // units per W/A/S/D
constexpr float turn_step = 5.0f * 3.14159265f / 180.0f; // 5° per turn key

const char* usage = "usage: walk                                  interactive, in a terminal\n"
                    "       walk --script KEYS [--output last.png] [--frames DIR] [--width 320] [--height 180]\n"
                    "       walk --script KEYS --frames A..B [--output walk_%04d.png] [--tile I/N] [...]\n"
                    "       walk --benchmark [--width 160] [--height 180] [--frames N]\n"
                    "       common: [--threads N] [--help]\n"
                    "Walks through the note's scene (§12). Keys: W/A/S/D move, J/L (or ←/→) turn, I/K (or ↑/↓)\n"
                    "look up/down, P writes the view to walk_N.png, Q quits. --script replays KEYS (the same\n"
                    "letters; unknown characters are ignored) headlessly, writes the last frame to --output and,\n"
                    "with --frames DIR, every frame to DIR/frame_K.png; it prints the final pose. Frame 0 is the\n"
                    "start, frame K the view after the K-th key that moves: --frames A..B renders only frames A\n"
                    "to B, each to OUTPUT with its number (a %d or %04d in it is replaced, else _NNNN goes before\n"
                    "the extension). --tile I/N renders band I (from 0) of N bands of rows only (merge_tiles\n"
                    "stacks them). --benchmark renders --frames frames (default 60) while walking and prints\n"
                    "frames per second.\n";

// Applies one key to the camera; returns false for keys that do nothing.
bool apply_key(char key, isin::Camera<float>& cam) {
    // clang-format off: one line per key
    switch (key) {
    case 'w':
    case 'W': cam.move_forward(move_step); return true;
    case 's':
    case 'S': cam.move_backward(move_step); return true;
    case 'a':
    case 'A': cam.move_left(move_step); return true;
    case 'd':
    case 'D': cam.move_right(move_step); return true;
    case 'j':
    case 'J': cam.turn(-turn_step); return true;
    case 'l':
    case 'L': cam.turn(turn_step); return true;
    case 'i':
    case 'I': cam.turn(0.0f, turn_step); return true;
    case 'k':
    case 'K': cam.turn(0.0f, -turn_step); return true;
    default: return false;
    }
    // clang-format on
}

// The note's camera (§3: its plane 9 high at distance 10) with square pixels at any size: a
// terminal's cells or a script's --width × --height are not 16:9.
isin::Camera<float> walking_camera(int w, int h, const isin::Vec3f& position = {}, float yaw = 0, float pitch = 0) {
    isin::Camera<float> cam{w, h, position, yaw, pitch};
    cam.square_pixels();
    return cam;
}

// The same pose at another resolution.
isin::Camera<float> resized(const isin::Camera<float>& cam, int w, int h) {
    return walking_camera(w, h, cam.position(), cam.yaw(), cam.pitch());
}

void print_pose(const isin::Camera<float>& cam) {
    std::printf("pose: x=%.3f y=%.3f z=%.3f yaw=%.2f pitch=%.2f (degrees)\n", double(cam.position().x),
                double(cam.position().y), double(cam.position().z), double(cam.yaw()) * 180.0 / 3.141592653589793,
                double(cam.pitch()) * 180.0 / 3.141592653589793);
}

// ---- terminal ------------------------------------------------------------------------------
termios saved_termios;
std::atomic<bool> terminal_changed{false};

void restore_terminal() {
    if (!terminal_changed.exchange(false)) return;
    const char* leave = "\x1b[0m\x1b[?25h\x1b[?1049l"; // reset colours, show cursor, main screen
    ssize_t ignored = write(STDOUT_FILENO, leave, std::strlen(leave));
    (void)ignored;
    tcsetattr(STDIN_FILENO, TCSAFLUSH, &saved_termios);
}

extern "C" void on_signal(int sig) {
    restore_terminal();
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

// Keys without Enter: canonical mode and echo off; signals stay on so Ctrl-C still works.
void enter_raw_mode() {
    tcgetattr(STDIN_FILENO, &saved_termios);
    termios raw = saved_termios;
    raw.c_lflag &= ~tcflag_t(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    tcsetattr(STDIN_FILENO, TCSAFLUSH, &raw);
    terminal_changed = true;
    std::atexit(restore_terminal);
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGHUP, on_signal);
    std::fputs("\x1b[?1049h\x1b[?25l", stdout); // alternate screen, hide cursor
}

// Reads the keys waiting on stdin, waiting up to timeout_ms for the first; arrow keys
// (ESC [ A/B/C/D) become I/K/L/J.
std::string read_keys(int timeout_ms) {
    std::string keys;
    pollfd p{STDIN_FILENO, POLLIN, 0};
    if (poll(&p, 1, timeout_ms) <= 0) return keys;
    char buf[64];
    const ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
    for (ssize_t i = 0; i < n; ++i) {
        if (buf[i] == '\x1b' && i + 2 < n && buf[i + 1] == '[') {
            const char arrow = buf[i + 2];
            keys += arrow == 'A' ? 'i' : arrow == 'B' ? 'k' : arrow == 'C' ? 'l' : arrow == 'D' ? 'j' : '?';
            i += 2;
        } else {
            keys += buf[i];
        }
    }
    return keys;
}

// Draws an image of width × 2·rows pixels as rows of upper-half-block cells, then a status line.
void draw(const isin::Image& image, int scale, const std::string& status) {
    std::string out = "\x1b[H";
    out.reserve(std::size_t(image.width()) * std::size_t(image.height()) * 20 * std::size_t(scale * scale));
    const int w = image.width() * scale, h = image.height() * scale;
    char code[48];
    isin::Rgb8 fg{1, 2, 3}, bg{1, 2, 3};
    bool first = true;
    for (int y = 0; y + 1 < h; y += 2) {
        for (int x = 0; x < w; ++x) {
            const isin::Rgb8 top = image(x / scale, y / scale), bottom = image(x / scale, (y + 1) / scale);
            if (first || top != fg) {
                std::snprintf(code, sizeof code, "\x1b[38;2;%d;%d;%dm", top.r, top.g, top.b);
                out += code, fg = top;
            }
            if (first || bottom != bg) {
                std::snprintf(code, sizeof code, "\x1b[48;2;%d;%d;%dm", bottom.r, bottom.g, bottom.b);
                out += code, bg = bottom;
            }
            first = false;
            out += "\u2580"; // ▀: foreground = upper pixel, background = lower pixel
        }
        out += "\x1b[0m\r\n";
        first = true;
    }
    out += "\x1b[0m\x1b[K" + status;
    std::fwrite(out.data(), 1, out.size(), stdout);
    std::fflush(stdout);
}

int interactive(const note_scene::Scene<float>& scene, isin::RenderOptions opt) {
    if (!isatty(STDIN_FILENO) || !isatty(STDOUT_FILENO)) {
        std::fprintf(stderr, "walk: stdin and stdout must be a terminal for the interactive walk;\n"
                             "      for a headless walk use: walk --script WWDDA --output last.png\n");
        return 2;
    }
    winsize ws{};
    if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) != 0 || ws.ws_col < 8 || ws.ws_row < 4) ws.ws_col = 80, ws.ws_row = 24;
    const int width = std::min(int(ws.ws_col), 1000), height = 2 * std::min(int(ws.ws_row) - 1, 500);
    enter_raw_mode();
    isin::Camera<float> cam = walking_camera(width, height);
    int saved = 0;
    bool moving = false, dirty = true;
    std::string note;
    for (;;) {
        // Moving: a coarse frame (half resolution) at once; still: the full frame.
        if (dirty || moving) {
            const int scale = moving ? 2 : 1;
            const auto view = resized(cam, std::max(2, width / scale), std::max(2, height / scale));
            isin::RenderStats stats;
            const isin::Image image = isin::render(scene, view, opt, &stats);
            char status[256];
            std::snprintf(
                status, sizeof status,
                " %s %.1f ms, %.1f Mrays/s | pos %.0f %.0f %.0f | WASD move, ←→ turn, ↑↓ look, P png, Q quit %s",
                moving ? "coarse" : "full  ", stats.seconds * 1e3, stats.mrays_per_second(), double(cam.position().x),
                double(cam.position().y), double(cam.position().z), note.c_str());
            draw(image, scale, status);
            dirty = moving; // after a coarse frame, draw the full one once the camera stops
            moving = false;
        }
        const std::string keys = read_keys(dirty ? 60 : 250);
        for (const char k : keys) {
            if (k == 'q' || k == 'Q') {
                restore_terminal();
                print_pose(cam);
                return 0;
            }
            if (k == 'p' || k == 'P') {
                const std::string path = "walk_" + std::to_string(++saved) + ".png";
                try {
                    isin::write_png(isin::render(scene, resized(cam, 1280, 720), opt), path);
                    note = "| wrote " + path;
                } catch (const std::exception& e) {
                    note = std::string("| ") + e.what();
                }
                dirty = true;
            }
            if (apply_key(k, cam)) moving = true;
        }
    }
}

} // namespace

int main(int argc, char** argv) {
    std::string script, output = "last.png", frames_dir, tile_text;
    std::string frames_value; // --frames: a count with --benchmark, a range or a directory with --script
    bool scripted = false, benchmark = false, output_given = false;
    int width = 0, height = 0, frames = 60;
    example::FrameRange range;
    isin::RenderOptions opt;
    auto fail = [&](const std::string& why) { example::fail("walk", why, usage); };
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") {
            std::fputs(usage, stdout);
            return 0;
        } else if (a == "--script")
            script = example::string_option(i, argc, argv, usage), scripted = true;
        else if (a == "--output" || a == "-o")
            output = example::string_option(i, argc, argv, usage), output_given = true;
        else if (a == "--frames")
            frames_value = example::string_option(i, argc, argv, usage);
        else if (a == "--tile")
            tile_text = example::string_option(i, argc, argv, usage);
        else if (a == "--width")
            width = example::integer_option(i, argc, argv, 2, 8192, usage);
        else if (a == "--height")
            height = example::integer_option(i, argc, argv, 2, 8192, usage);
        else if (a == "--threads")
            opt.threads = example::integer_option(i, argc, argv, 0, 1024, usage);
        else if (a == "--benchmark")
            benchmark = true;
        else
            fail("unknown option '" + a + "'");
    }
    // Read once every option is known, whatever their order.
    if (benchmark) {
        if (!frames_value.empty()) frames = example::to_integer(frames_value, "--frames", 1, 100000, "walk", usage);
        if (!tile_text.empty()) fail("--tile goes with --script");
    } else if (!scripted) {
        if (!frames_value.empty() || !tile_text.empty()) fail("--frames and --tile go with --script");
    }
    // The scripted walk: frame 0 is the start, frame k the pose after the k-th key that moves.
    isin::Camera<float> start = walking_camera(width ? width : (benchmark ? 160 : 320), height ? height : 180);
    std::vector<isin::Camera<float>> poses{start};
    for (const char k : script)
        if (apply_key(k, start)) poses.push_back(start);
    example::Tile tile;
    if (scripted && !benchmark) {
        if (!tile_text.empty()) tile = example::to_tile(tile_text, start.height(), "walk", usage);
        if (example::is_frame_range(frames_value)) {
            range = example::to_frame_range(frames_value, int(poses.size()) - 1, "walk", usage);
            if (!output_given) output = "walk_%04d.png";
        } else {
            frames_dir = frames_value;
        }
        const int rows = isin::row_band(start.height(), tile.index, tile.count).rows;
        example::check_output("walk", range.given() ? example::frame_path(output, range.first) : output, start.width(),
                              rows, usage);
    }
    const auto scene = note_scene::make<float>();
    try {
        if (benchmark) {
            isin::Camera<float> cam = poses[0];
            std::vector<double> ms;
            std::uint64_t rays = 0;
            for (int f = 0; f < frames; ++f) {
                apply_key("wwdjsalk"[f % 8], cam);
                isin::RenderStats stats;
                (void)isin::render(scene, cam, opt, &stats);
                ms.push_back(stats.seconds * 1e3), rays += stats.rays();
            }
            std::sort(ms.begin(), ms.end());
            const double median = ms[ms.size() / 2];
            std::printf("%d×%d pixels, %d frames, threads %d: median %.2f ms per frame = %.1f frames/s, %.1f Mrays/s\n",
                        cam.width(), cam.height(), frames, opt.threads, median, 1e3 / median,
                        double(rays) / double(frames) / median * 1e-3);
            return 0;
        }
        if (scripted) {
            const isin::RowBand band = isin::row_band(start.height(), tile.index, tile.count);
            auto frame_image = [&](std::size_t f) {
                return isin::render_rows(scene, poses[f], band.first, band.rows, opt);
            };
            if (range.given()) {
                for (int f = range.first; f <= range.last; ++f) {
                    const std::string path = example::frame_path(output, f);
                    isin::write_image(frame_image(std::size_t(f)), path);
                    std::printf("%s: frame %d of %zu\n", path.c_str(), f, poses.size() - 1);
                }
                print_pose(poses[std::size_t(range.last)]);
                return 0;
            }
            const isin::Image first = frame_image(0);
            isin::Image last = first;
            for (std::size_t f = 1; f < poses.size(); ++f) {
                last = frame_image(f);
                if (!frames_dir.empty()) isin::write_png(last, frames_dir + "/frame_" + std::to_string(f) + ".png");
            }
            isin::write_image(last, output);
            long differ = 0;
            for (std::size_t i = 0; i < first.pixels().size(); ++i) differ += first.pixels()[i] != last.pixels()[i];
            print_pose(poses.back());
            std::printf("%s: last frame differs from the first in %ld of %zu pixels\n", output.c_str(), differ,
                        first.pixels().size());
            return 0;
        }
        return interactive(scene, opt);
    } catch (const std::exception& e) {
        restore_terminal();
        std::fprintf(stderr, "walk: %s\n", e.what());
        return 1;
    }
}
