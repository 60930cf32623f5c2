// The renderer on the note's scene (§3, §5, §7–§11), scenes, and acne-free secondary rays.
#include <isin/render.hpp>

#include <doctest/doctest.h>

#include "support/approx.hpp"
#include "../examples/note_scene.hpp"
#include "support/workloads.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

bool is_blue(const isin::Rgb8& p) { return p.b > 3 * p.r && p.b > 3 * p.g && p.b > 100; }
int brightness(const isin::Rgb8& p) { return p.r + p.g + p.b; }

} // namespace

TEST_CASE("scene: a scene stores only the primitive kinds it names") {
    using Spheres = isin::Scene<float, isin::Sphere>;
    using Everything = isin::Scene<float, isin::Sphere, isin::Triangle, isin::TexturedTriangle>;
    static_assert(Spheres::kinds == 1 && Everything::kinds == 3);
    static_assert(sizeof(Spheres) < sizeof(Everything));
    static_assert(sizeof(isin::Object<isin::Sphere<float>>) == 5 * sizeof(float));
    Spheres scene;
    const auto m = scene.add_material({});
    scene.add(isin::Sphere<float>{{0, 0, 50}, 5}, m);
    CHECK(scene.size() == 1);
    CHECK_THROWS_AS(scene.add(isin::Sphere<float>{{0, 0, 50}, 5}, 7), std::out_of_range);
    const auto hit = scene.intersect(isin::Ray<float>{{0, 0, 0}, {0, 0, 1}});
    REQUIRE(hit);
    CHECK(hit.t == approx(45));
}

TEST_CASE_TEMPLATE("§5 scene: nearest hit of example 5a is blue Z at t = 77, both triangle methods", T, float, double) {
    auto scene = note_scene::make<T>();
    const isin::Ray<T> ray{{0, 0, 0}, {0, 0, 1}}; // through (0,0,10)
    for (auto method : {isin::TriangleMethod::moller_trumbore, isin::TriangleMethod::area}) {
        scene.triangle_method = method;
        const auto h = scene.intersect(ray);
        REQUIRE(h);
        CHECK(h.geometry == 1);  // isin::Triangle
        CHECK(h.primitive == 2); // blue Z
        CHECK(h.t == approx(77));
    }
}

TEST_CASE("§3 §5 render at 800×450: the pixels around GD = (0,0,10) show blue triangle Z") {
    const auto scene = note_scene::make<float>();
    const isin::Camera<float> cam{800, 450};
    isin::RenderOptions opt;
    const auto image = isin::render(scene, cam, opt);
    REQUIRE(image.width() == 800);
    REQUIRE(image.height() == 450);
    // GD = (0,0,10) falls between pixels 399/400 and 224/225 (16·x/799 − 8 = 0 at x = 399.5).
    for (int y : {224, 225})
        for (int x : {399, 400}) {
            CAPTURE(x);
            CAPTURE(y);
            const auto ray = cam.primary_ray(float(x), float(y));
            const auto h = scene.intersect(ray);
            REQUIRE(h);
            CHECK(h.primitive == 2);
            CHECK(is_blue(image(x, y)));
        }
}

TEST_CASE("§9 render: a floor pixel in a known shadow is darker than its lit neighbour") {
    const auto scene = note_scene::make<float>(false); // plain floor: shadow is the only change
    const isin::Camera<float> cam{800, 450};
    isin::RenderOptions opt;
    const auto image = isin::render(scene, cam, opt);
    // Find a floor pixel that an opaque object hides from the first light, and whose neighbour four
    // pixels to the right the light sees.
    auto light0_visible = [&](int x, int y, bool& on_floor) {
        const auto ray = cam.primary_ray(float(x), float(y));
        const auto h = scene.intersect(ray);
        on_floor = h && h.geometry == 2; // isin::TexturedTriangle: the floor
        if (!on_floor) return false;
        const auto p = isin::offset_origin(ray.at(h.t), isin::Vec3f{0, 1, 0});
        const auto& light = scene.lights[0].position;
        const auto& light1 = scene.lights[1].position;
        // Light 1 must see both pixels, so light 0 alone makes the difference.
        if (scene.transmittance({p, light1 - p}, 1.0f) < 1.0f) on_floor = false;
        const float through = scene.transmittance({p, light - p}, 1.0f);
        if (through > 0.0f && through < 1.0f) on_floor = false; // behind glass: partly lit
        return through == 1.0f;
    };
    int pairs = 0;
    for (int y = 300; y < 450 && pairs < 20; y += 3)
        for (int x = 0; x + 4 < 800 && pairs < 20; ++x) {
            bool floor_a = false, floor_b = false;
            const bool lit_a = light0_visible(x, y, floor_a);
            const bool lit_b = light0_visible(x + 4, y, floor_b);
            if (floor_a && floor_b && !lit_a && lit_b) {
                CAPTURE(x);
                CAPTURE(y);
                CHECK(brightness(image(x, y)) + 30 < brightness(image(x + 4, y)));
                ++pairs;
            }
        }
    CHECK(pairs >= 5); // the mirror sphere's and triangles' shadows do fall on the floor
}

TEST_CASE("render: float and double images of the note's scene differ in < 0.5% of pixels") {
    const isin::Camera<float> cam_f{800, 450};
    const isin::Camera<double> cam_d{800, 450};
    isin::RenderOptions opt;
    const auto f = isin::render(note_scene::make<float>(), cam_f, opt);
    const auto d = isin::render(note_scene::make<double>(), cam_d, opt);
    long differ = 0;
    for (int y = 0; y < 450; ++y)
        for (int x = 0; x < 800; ++x) {
            const auto a = f(x, y), b = d(x, y);
            differ += std::abs(a.r - b.r) > 1 || std::abs(a.g - b.g) > 1 || std::abs(a.b - b.b) > 1;
        }
    MESSAGE("float vs double: " << differ << " of 360000 pixels differ by more than one level");
    CHECK(double(differ) < 0.005 * 360000);
}

TEST_CASE("render: threads, supersampling and culling options") {
    const auto scene = note_scene::make<float>();
    const isin::Camera<float> cam{160, 90};
    isin::RenderOptions opt;
    opt.threads = 1;
    isin::RenderStats one_stats, two_stats;
    const auto one = isin::render(scene, cam, opt, &one_stats);
    opt.threads = 2;
    const auto two = isin::render(scene, cam, opt, &two_stats);
    CHECK(one.pixels() == two.pixels()); // deterministic whatever the thread count
    CHECK(one_stats.primary == 160 * 90);
    CHECK(one_stats.rays() == two_stats.rays());
    CHECK(one_stats.shadow > 0);
    CHECK(one_stats.reflection > 0);
    CHECK(one_stats.refraction > 0);
    opt.samples = 3;
    isin::RenderStats ss;
    const auto smooth = isin::render(scene, cam, opt, &ss);
    CHECK(ss.primary == 9 * 160 * 90);
    CHECK(smooth.pixels() != one.pixels());
    // Every face of the note's scene faces the eye, so culling changes nothing here…
    opt.samples = 1;
    for (auto c : {isin::Culling::dot_product, isin::Culling::projected}) {
        opt.culling = c;
        CHECK(isin::render(scene, cam, opt).pixels() == one.pixels());
    }
    opt.culling = isin::Culling::none;
    opt.samples = 0;
    CHECK_THROWS_AS((void)isin::render(scene, cam, opt), std::invalid_argument);
    opt.samples = 1;
    opt.threads = -1;
    CHECK_THROWS_AS((void)isin::render(scene, cam, opt), std::invalid_argument);
}

TEST_CASE("camera: a sphere in the middle of a 400×400, 300×600 or 600×300 image is round") {
    isin::Scene<float, isin::Sphere> scene;
    scene.add(isin::Sphere<float>{{0, 0, 50}, 10}, scene.add_material({}));
    scene.add_light({{0, 0, 0}});
    isin::RenderOptions opt;
    for (const auto& size : {std::pair{400, 400}, std::pair{300, 600}, std::pair{600, 300}}) {
        const int w = size.first;
        const int h = size.second;
        CAPTURE(w);
        CAPTURE(h);
        const auto cam = isin::Camera<float>::look_at(w, h, {0, 0, 0}, {0, 0, 50}, {0, 1, 0}, 45.0f);
        const isin::Image image = isin::render(scene, cam, opt);
        int left = w, right = -1, top = h, bottom = -1;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                if (image(x, y) != isin::to_rgb8(scene.background))
                    left = std::min(left, x), right = std::max(right, x), top = std::min(top, y),
                    bottom = std::max(bottom, y);
        const int across = right - left + 1, down = bottom - top + 1;
        CHECK(across > 40);
        CHECK(std::abs(across - down) <= 1); // round, not stretched
        // The note's 16×9 plane stretches it: 3.6× at 300×600 (the cube).
        const isin::Camera<float> note{w, h, {0, 0, 0}, 0.0f, 0.0f};
        const isin::Image stretched = isin::render(scene, note, opt);
        int note_across = 0, note_down = 0;
        for (int x = 0; x < w; ++x) note_across += stretched(x, h / 2) != isin::to_rgb8(scene.background);
        for (int y = 0; y < h; ++y) note_down += stretched(w / 2, y) != isin::to_rgb8(scene.background);
        if (w != h * 16 / 9) CHECK(std::abs(note_across - note_down) > 2);
    }
}

TEST_CASE("row_band: N bands tile the rows in order, sizes within one row; bad bands throw") {
    for (const int height : {2, 9, 90, 451, 32768})
        for (const int count : {1, 2, 7, 9, 64}) {
            if (count > height) {
                CHECK_THROWS_AS((void)isin::row_band(height, 0, count), std::invalid_argument);
                continue;
            }
            int next = 0, smallest = height, largest = 0;
            for (int i = 0; i < count; ++i) {
                const isin::RowBand band = isin::row_band(height, i, count);
                CHECK(band.first == next);
                next += band.rows;
                smallest = std::min(smallest, band.rows), largest = std::max(largest, band.rows);
            }
            CHECK(next == height);
            CHECK(smallest >= 1);
            CHECK(largest - smallest <= 1);
        }
    CHECK(isin::row_band(90, 3, 7).first == 38); // ⌊3·90/7⌋
    CHECK(isin::row_band(90, 3, 7).rows == 13);  // ⌊4·90/7⌋ − 38
    CHECK_THROWS_AS((void)isin::row_band(90, 7, 7), std::invalid_argument);
    CHECK_THROWS_AS((void)isin::row_band(90, -1, 7), std::invalid_argument);
    CHECK_THROWS_AS((void)isin::row_band(90, 0, 0), std::invalid_argument);
}

TEST_CASE("render_rows: bands rendered apart and stacked are the whole render, bit for bit") {
    const auto scene = note_scene::make<float>();
    isin::Camera<float> cam{96, 54, {3, 1, -2}, 0.2f, -0.05f};
    isin::RenderOptions opt;
    opt.samples = 2;
    opt.culling = isin::Culling::projected;
    opt.threads = 2;
    isin::RenderStats whole_stats;
    const isin::Image whole = isin::render(scene, cam, opt, &whole_stats);
    for (const int count : {1, 2, 5, 54}) {
        CAPTURE(count);
        std::vector<isin::Image> bands;
        isin::RenderStats sum;
        for (int i = 0; i < count; ++i) {
            opt.threads = 1 + i % 2;
            const isin::RowBand band = isin::row_band(cam.height(), i, count);
            isin::RenderStats stats;
            bands.push_back(isin::render_rows(scene, cam, band.first, band.rows, opt, &stats));
            CHECK(bands.back().height() == band.rows);
            CHECK(stats.primary == std::uint64_t(4 * 96 * band.rows));
            sum += stats;
        }
        CHECK(isin::stack_rows(bands).pixels() == whole.pixels());
        CHECK(sum.rays() == whole_stats.rays()); // the same rays, only split
    }
    // One row in the middle is that row of the whole image.
    const isin::Image row = isin::render_rows(scene, cam, 27, 1, opt);
    CHECK(std::equal(row.pixels().begin(), row.pixels().end(), whole.pixels().begin() + 27 * 96));
    for (const auto& [first, rows] : {std::pair{-1, 2}, std::pair{0, 0}, std::pair{53, 2}, std::pair{0, 55}})
        CHECK_THROWS_AS((void)isin::render_rows(scene, cam, first, rows, opt), std::invalid_argument);
}

TEST_CASE_TEMPLATE("§11 render: both culling methods drop a triangle turned away from the eye", T, float, double) {
    // Blue triangle Z of example 5a with two vertices swapped (counter-clockwise: a backface),
    // in front of a red wall.
    isin::Scene<T, isin::Triangle> scene;
    isin::Material<T> blue, red;
    blue.color = isin::from_rgb8<T>(0, 0, 255);
    red.color = isin::from_rgb8<T>(255, 0, 0);
    scene.add(isin::Triangle<T>{{-30, 0, 37}, {30, -40, 117}, {30, 40, 117}}, scene.add_material(blue));
    const auto wall = scene.add_material(red);
    scene.add(isin::Triangle<T>{{-500, -500, 300}, {-500, 500, 300}, {500, -500, 300}}, wall);
    scene.add(isin::Triangle<T>{{500, 500, 300}, {500, -500, 300}, {-500, 500, 300}}, wall);
    scene.add_light({{0, 0, 0}});
    const isin::Camera<T> cam{81, 45};
    isin::RenderOptions opt;
    const auto seen = isin::render(scene, cam, opt)(40, 22);
    CHECK(seen.b > 0);
    CHECK(seen.r == 0);
    for (auto c : {isin::Culling::dot_product, isin::Culling::projected}) {
        opt.culling = c;
        const auto culled = isin::render(scene, cam, opt)(40, 22);
        CHECK(culled.r > 0);
        CHECK(culled.b == 0);
    }
}

TEST_CASE_TEMPLATE("§10 render: an image texture on a rectangle of two right triangles lands the "
                   "right way up",
                   T, float, double) {
    // A 2×2 texture: red, green on the top row; blue, white below. The rectangle faces the eye:
    // V0 top-left (texel (0,0)), V1 top-right (texel (w,0)), V2 bottom-left (texel (0,h)).
    isin::Image texels(2, 2);
    texels(0, 0) = {255, 0, 0};
    texels(1, 0) = {0, 255, 0};
    texels(0, 1) = {0, 0, 255};
    texels(1, 1) = {255, 255, 255};
    isin::Scene<T, isin::TexturedTriangle> scene;
    isin::Material<T> m;
    m.ka = T(1), m.kd = T(0), m.ks = T(0); // ambient only: the pixel is the texel colour
    m.texture = scene.add_texture(isin::ImageTexture<T>(texels));
    scene.texture_filter = isin::Filter::nearest;
    scene.add_textured_rectangle({-20, 20, 50}, {20, 20, 50}, {-20, -20, 50}, scene.add_material(m));
    const isin::Camera<T> cam{64, 36};
    isin::RenderOptions opt;
    const auto image = isin::render(scene, cam, opt);
    CHECK(image(24, 10) == isin::Rgb8{255, 0, 0});     // upper left
    CHECK(image(40, 10) == isin::Rgb8{0, 255, 0});     // upper right
    CHECK(image(24, 26) == isin::Rgb8{0, 0, 255});     // lower left
    CHECK(image(40, 26) == isin::Rgb8{255, 255, 255}); // lower right
    CHECK(image(1, 1) == isin::Rgb8{0, 0, 0});         // background
}

TEST_CASE_TEMPLATE("scene: a placed mesh (its Bvh) and the same triangles one by one agree on hits, shadows, culling",
                   T, float, double) {
    const auto sphere = workloads::icosphere<T>({0, 0, 40}, 10.0, 3); // 1280 triangles, closed
    isin::Scene<T, isin::Triangle> meshed, loose;
    meshed.add_mesh(sphere, meshed.add_material({}));
    const auto m = loose.add_material({});
    for (const auto& tri : sphere) loose.add(tri, m);
    loose.acceleration = isin::Acceleration::none; // Möller–Trumbore one by one
    for (auto* scene : {&meshed, &loose}) scene->add_light({{0, 100, 0}});
    const isin::Camera<T> cam{64, 36};
    int differ = 0, hits = 0, shadow_differ = 0;
    for (int y = 0; y < 36; ++y)
        for (int x = 0; x < 64; ++x) {
            const auto ray = cam.primary_ray(T(x), T(y));
            const auto a = meshed.intersect(ray);
            const auto b = loose.intersect(ray);
            hits += bool(b);
            differ += bool(a) != bool(b) || (a && std::fabs(double(a.t) - double(b.t)) > 1e-4 * double(b.t));
            if (!b) continue;
            CHECK(a.geometry == 1); // kinds + 0: the first placement
            const auto p = isin::offset_origin(ray.at(b.t), loose.surface(ray, b).normal);
            CHECK(double(isin::dot(meshed.surface(ray, a).normal, loose.surface(ray, b).normal)) ==
                  approx(1.0).epsilon(1e-4));
            const isin::Ray<T> shadow{p, loose.lights[0].position - p};
            shadow_differ += meshed.transmittance(shadow, T(1)) != loose.transmittance(shadow, T(1));
        }
    CHECK(hits > 300);
    CHECK(differ == 0);
    CHECK(shadow_differ == 0);
    // Culling through the Bvh's leaf test: a closed mesh seen from outside looks the same with and
    // without (its back faces are hidden anyway), and the same as the one-by-one culled scene.
    isin::RenderOptions opt;
    const auto plain = isin::render(meshed, cam, opt);
    opt.culling = isin::Culling::dot_product;
    CHECK(isin::render(meshed, cam, opt).pixels() == plain.pixels());
    // Adding a triangle to a kind drops its acceleration until the next commit.
    loose.acceleration = isin::Acceleration::automatic;
    loose.commit();
    CHECK(loose.template has_bvh<isin::Triangle<T>>());
    loose.add(sphere[0], 0);
    CHECK_FALSE(loose.template has_bvh<isin::Triangle<T>>());
    loose.commit();
    CHECK(loose.template has_bvh<isin::Triangle<T>>());
}

// ---- hardening: failed threads, worker exceptions, bad indices, depth ------------------------------

#include "support/without_threads.hpp"

namespace user {

/// A user's primitive kind: a sphere whose intersection throws when it is hit.
template <class T>
struct Trap {
    isin::Sphere<T> sphere;
};
template <class T>
isin::Hit<T> intersect_primitive(const isin::Ray<T>& ray, const Trap<T>& trap, isin::TriangleMethod) {
    const isin::Hit<T> h = isin::intersect(ray, trap.sphere);
    if (h) throw std::runtime_error("the trap was hit");
    return h;
}
template <class T>
isin::Vertex<T> surface_normal(const Trap<T>& trap, const isin::Vertex<T>& p, const isin::Hit<T>&) {
    return isin::normal_at(trap.sphere, p);
}
template <class T>
constexpr const isin::Triangle<T>* triangle_of(const Trap<T>&) noexcept {
    return nullptr;
}

} // namespace user

TEST_CASE("render: threads that cannot start leave their rows to the others, same picture (D4)") {
    const auto scene = note_scene::make<float>();
    const isin::Camera<float> cam{64, 36};
    isin::RenderOptions opt;
    opt.threads = 1;
    const isin::Image reference = isin::render(scene, cam, opt);
    opt.threads = 4;
    const WithoutThreads result =
        without_threads([&] { return isin::render(scene, cam, opt).pixels() == reference.pixels(); });
    if (result == WithoutThreads::not_run)
        MESSAGE("not run: threads still start in a child under RLIMIT_NPROC = 0");
    else
        CHECK(result == WithoutThreads::passed); // before: std::terminate (joinable threads destroyed)
}

TEST_CASE("render: an exception thrown in a worker (a user primitive) reaches the caller (D4)") {
    isin::Scene<float, isin::Sphere, user::Trap> scene;
    const auto m = scene.add_material({});
    scene.add(isin::Sphere<float>{{-3, 0, 20}, 2}, m);
    scene.add(user::Trap<float>{{{3, 0, 20}, 2}}, m);
    scene.add_light({{0, 10, 0}});
    isin::RenderOptions opt;
    for (int threads : {1, 2, 3}) {
        opt.threads = threads;
        CHECK_THROWS_WITH_AS((void)isin::render(scene, isin::Camera<float>{48, 27}, opt), "the trap was hit",
                             std::runtime_error);
    }
}

TEST_CASE(
    "render and trace: a material or texture that does not exist is std::out_of_range, not a heap overflow (D5)") {
    isin::Scene<float, isin::TexturedTriangle, isin::Sphere> scene;
    isin::Material<float> textured;
    textured.texture = 5; // no textures at all
    const auto m = scene.add_material(textured);
    scene.add_textured_rectangle({-10, -10, 20}, {10, -10, 20}, {-10, 10, 20}, m);
    isin::RenderOptions opt;
    const isin::Camera<float> cam{32, 18};
    CHECK_THROWS_AS((void)isin::render(scene, cam, opt), std::out_of_range);
    isin::RenderStats stats;
    const isin::Ray<float> ahead{{0, 0, 0}, {0, 0, 1}};
    CHECK_THROWS_AS((void)isin::trace(scene, ahead, 0, opt, stats), std::out_of_range);
    scene.materials[0].texture = scene.add_texture(isin::Checkerboard<float>{});
    CHECK_NOTHROW((void)isin::render(scene, cam, opt));
    scene.materials.clear(); // the rectangle's material is gone
    CHECK_THROWS_AS((void)isin::render(scene, cam, opt), std::out_of_range);
    CHECK_THROWS_AS((void)isin::trace(scene, ahead, 0, opt, stats), std::out_of_range);
}

TEST_CASE("render: max_depth is bounded; at the bound two facing mirrors render on every thread (D6)") {
    // Two mirrors facing each other across the eye: every primary ray bounces to max_depth.
    isin::Scene<float, isin::Triangle> scene;
    isin::Material<float> mirror;
    mirror.reflectivity = 0.999f;
    const auto m = scene.add_material(mirror);
    const float s = 1e6f; // wide enough that no ray leaves them in 256 bounces
    scene.add(isin::Triangle<float>{{-s, -s, 10}, {-s, s, 10}, {s, -s, 10}}, m);
    scene.add(isin::Triangle<float>{{s, -s, 10}, {-s, s, 10}, {s, s, 10}}, m);
    scene.add(isin::Triangle<float>{{-s, -s, -10}, {s, -s, -10}, {-s, s, -10}}, m);
    scene.add(isin::Triangle<float>{{s, -s, -10}, {s, s, -10}, {-s, s, -10}}, m);
    scene.add_light({{0, 0, 0}});
    isin::RenderOptions opt;
    opt.threads = 2;
    const isin::Camera<float> cam{16, 9};
    opt.max_depth = 20000; // overflowed the stack
    CHECK_THROWS_AS((void)isin::render(scene, cam, opt), std::invalid_argument);
    opt.max_depth = -1;
    CHECK_THROWS_AS((void)isin::render(scene, cam, opt), std::invalid_argument);
    opt.max_depth = isin::RenderOptions::max_depth_limit;
    isin::RenderStats stats;
    (void)isin::render(scene, cam, opt, &stats);
    CHECK(stats.reflection == std::uint64_t(16 * 9) * std::uint64_t(isin::RenderOptions::max_depth_limit));
    CHECK_THROWS_AS((void)isin::trace(scene, isin::Ray<float>{{0, 0, 0}, {0, 0, 1}},
                                      isin::RenderOptions::max_depth_limit + 1, opt, stats),
                    std::invalid_argument);
}

TEST_CASE("RenderStats: rays() adds the four kinds in 64 bits; mrays_per_second is rays / seconds / 10⁶, 0 untimed") {
    isin::RenderStats stats;
    CHECK(stats.rays() == 0);
    CHECK(stats.mrays_per_second() == 0.0);
    stats.primary = 3000000000u;
    stats.shadow = 2000000000u;
    stats.reflection = 700000000u;
    stats.refraction = 300000000u;
    CHECK(stats.rays() == 6000000000u);     // beyond 32 bits
    CHECK(stats.mrays_per_second() == 0.0); // seconds = 0: no rate rather than ∞
    stats.seconds = 2.5;
    CHECK(stats.mrays_per_second() == doctest::Approx(2400));
    stats.refraction = 0;
    stats.seconds = 0.5;
    CHECK(stats.rays() == 5700000000u);
    CHECK(stats.mrays_per_second() == doctest::Approx(11400));
    // A render's own stats: its rays over its wall time.
    const auto scene = note_scene::make<float>();
    isin::RenderOptions opt;
    isin::RenderStats measured;
    (void)isin::render(scene, isin::Camera<float>{32, 18}, opt, &measured);
    REQUIRE(measured.seconds > 0);
    CHECK(measured.rays() == measured.primary + measured.shadow + measured.reflection + measured.refraction);
    CHECK(measured.rays() > 32u * 18u);
    CHECK(measured.mrays_per_second() == doctest::Approx(double(measured.rays()) / measured.seconds / 1e6));
}

namespace {
/// Whether every pixel of render(scene, cam, opt) is the trace() of its camera rays, as the
/// renderer computed pixels before its tiles: the packets change no pixel.
template <class S>
bool render_is_trace_per_pixel(const S& scene, const isin::Camera<typename S::value_type>& cam,
                               const isin::RenderOptions& opt) {
    using T = typename S::value_type;
    const isin::Image image = isin::render(scene, cam, opt);
    const auto masks = isin::backface_masks(scene, cam, opt.culling);
    const auto* skip = opt.culling == isin::Culling::none ? nullptr : &masks;
    isin::RenderStats stats;
    const int N = opt.samples;
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x) {
            isin::Color<T> sum{T(0), T(0), T(0)};
            for (int sy = 0; sy < N; ++sy)
                for (int sx = 0; sx < N; ++sx) {
                    const T px = T(x) + (T(sx) + T(0.5)) / T(N) - T(0.5);
                    const T py = T(y) + (T(sy) + T(0.5)) / T(N) - T(0.5);
                    sum += isin::trace(scene, cam.primary_ray(px, py), 0, opt, stats, skip);
                }
            const isin::Rgb8 p = isin::to_rgb8(sum / T(N * N), opt.encoding), q = image(x, y);
            if (p.r != q.r || p.g != q.g || p.b != q.b) return false;
        }
    return true;
}
} // namespace

TEST_CASE_TEMPLATE("render: blocks of 8×8 pixels through the stream calls give each pixel trace()'s colour", T, float,
                   double) {
    isin::RenderOptions opt;
    opt.threads = 2;
    // The note's scene (glass: shadow rays one by one) at a size that leaves partial tiles.
    const auto note = note_scene::make<T>();
    const isin::Camera<T> small{101, 58};
    CHECK(render_is_trace_per_pixel(note, small, opt));
    opt.samples = 2, opt.culling = isin::Culling::projected;
    CHECK(render_is_trace_per_pixel(note, small, opt));
    opt.samples = 1, opt.culling = isin::Culling::none;
    // Two facing mirrors, half glass: rays bounce to max_depth, past the depth where secondary
    // rays stop going as streams (detail::stream_depth) and go one by one.
    isin::Scene<T, isin::Triangle> mirrors;
    isin::Material<T> mirror;
    mirror.reflectivity = T(0.6), mirror.transparency = T(0.3), mirror.color = {T(0.2), T(0.5), T(0.9)};
    const auto mm = mirrors.add_material(mirror);
    const T side = 1000;
    mirrors.add(isin::Triangle<T>{{-side, -side, 10}, {-side, side, 10}, {side, -side, 10}}, mm);
    mirrors.add(isin::Triangle<T>{{side, -side, 10}, {-side, side, 10}, {side, side, 10}}, mm);
    mirrors.add(isin::Triangle<T>{{-side, -side, -10}, {side, -side, -10}, {-side, side, -10}}, mm);
    mirrors.add(isin::Triangle<T>{{side, -side, -10}, {side, side, -10}, {-side, side, -10}}, mm);
    mirrors.add_light({{1, 2, 0}});
    opt.max_depth = isin::detail::stream_depth + 3;
    isin::RenderStats stats;
    (void)isin::render(mirrors, isin::Camera<T>{13, 7}, opt, &stats);
    CHECK(stats.reflection >= std::uint64_t(13 * 7 * opt.max_depth));
    CHECK(render_is_trace_per_pixel(mirrors, isin::Camera<T>{13, 7}, opt));
    opt.max_depth = 4;
    // An opaque scene with a placed mesh and a Bvh kind: packets for primary and shadow rays.
    isin::Scene<T, isin::Sphere, isin::Triangle> opaque;
    isin::Material<T> matte;
    matte.color = {T(0.8), T(0.7), T(0.6)};
    const auto m = opaque.add_material(matte);
    opaque.add_mesh(isin::Mesh<T>::from_triangles(workloads::icosphere<T>({0, 0, 60}, 14.0, 3)), m);
    for (const auto& tri : workloads::icosphere<T>({-20, 8, 50}, 6.0, 2)) opaque.add(tri, m);
    opaque.add(isin::Sphere<T>{{18, -6, 45}, 5}, m);
    opaque.add(isin::Triangle<T>{{-200, -20, 0}, {-200, -20, 400}, {200, -20, 0}}, m); // the floor
    opaque.add(isin::Triangle<T>{{200, -20, 400}, {200, -20, 0}, {-200, -20, 400}}, m);
    opaque.add_light({{-40, 60, 10}});
    opaque.add_light({{50, 20, -20}, {T(0.4), T(0.4), T(0.4)}});
    opaque.commit();
    const isin::Camera<T> cam{96, 54};
    opt.samples = 1, opt.culling = isin::Culling::none;
    CHECK(render_is_trace_per_pixel(opaque, cam, opt));
    opt.culling = isin::Culling::dot_product;
    CHECK(render_is_trace_per_pixel(opaque, cam, opt));
    opt.shadows = false;
    CHECK(render_is_trace_per_pixel(opaque, cam, opt));
}

TEST_CASE_TEMPLATE("§7 the lights' terms in lanes: phong_light's value for each point, the same bits in any lane", T,
                   float, double) {
    using Lanes = isin::detail::ShadingLanes<T>;
    constexpr std::size_t W = Lanes::width, N = 64;
    std::mt19937 rng(7);
    std::uniform_real_distribution<T> coord(T(-50), T(50)), unit(T(0), T(1));
    const auto direction = [&] { return isin::normalize(isin::Vertex<T>{coord(rng), coord(rng), coord(rng)}); };
    std::vector<isin::Material<T>> materials(N);
    struct Point {
        const isin::Material<T>* m;
        isin::Vertex<T> point, Ns, V;
        isin::Color<T> object, local;
    };
    std::vector<Point> points(N);
    for (std::size_t i = 0; i < N; ++i) {
        isin::Material<T>& m = materials[i];
        m.kd = unit(rng), m.ks = unit(rng), m.shininess = T(1) + T(120) * unit(rng);
        m.specular_color = {unit(rng), unit(rng), unit(rng)};
        Point& s = points[i];
        s.m = &m;
        s.point = {coord(rng), coord(rng), coord(rng)};
        s.Ns = direction(), s.V = direction();
        if (i % 5 == 0) s.V = isin::reflect(-isin::normalize(isin::Vertex<T>{0, 60, 0} - s.point), s.Ns); // highlight
        s.object = {unit(rng), unit(rng), unit(rng)};
        s.local = {unit(rng), unit(rng), unit(rng)};
    }
    points[3].point = {0, 60, 0}; // at the light: no direction, unlit
    const isin::PointLight<T> light{{0, 60, 0}, {T(0.9), T(0.8), T(0.7)}};
    // All 64 points in one set of lanes, light visible in part.
    alignas(64) T lanes[Lanes::rows * N];
    const auto set = [](T* at, std::size_t stride, std::size_t k, const Point& s) {
        Lanes::set_lit(at, stride, k, s.point, s.Ns, s.V, *s.m, s.object, s.local);
    };
    for (std::size_t i = 0; i < N; ++i) set(lanes, N, i, points[i]);
    for (std::size_t k = 0; k < N; k += W) isin::detail::light_direction_pass(lanes + k, N, 0, light.position);
    T* visible = lanes + Lanes::field(0, Lanes::visible) * N;
    for (std::size_t i = 0; i < N; ++i) visible[i] = i % 7 == 0 ? T(0) : i % 3 == 0 ? T(0.5) : T(1);
    for (std::size_t k = 0; k < N; k += W) isin::detail::light_term_pass(lanes + k, N, 0, light.color);
    int lit = 0, highlights = 0, same_bits = 0;
    for (std::size_t i = 0; i < N; ++i) {
        const Point& s = points[i];
        // The scalar formulas (shading.hpp).
        const isin::Vertex<T> L = isin::normalize(light.position - s.point);
        const T n_dot_l = isin::dot(s.Ns, L);
        isin::Color<T> expected = s.local;
        if (n_dot_l > T(0) && visible[i] > T(0))
            expected += visible[i] * isin::phong_light(*s.m, s.object, s.Ns, L, s.V, light.color), ++lit;
        if (n_dot_l > T(0) && isin::specular_coefficient(s.Ns, L, s.V, s.m->shininess) > T(0.5)) ++highlights;
        const isin::Color<T> got = Lanes::local(lanes, N, i);
        const T tolerance = sizeof(T) == 4 ? T(2e-5) : T(1e-13); // pow's exponent up to 121 magnifies rounding
        CHECK(std::fabs(got.r - expected.r) <= tolerance);
        CHECK(std::fabs(got.g - expected.g) <= tolerance);
        CHECK(std::fabs(got.b - expected.b) <= tolerance);
        // The same point alone, one value per field, as trace() computes it: the same bits.
        T one[Lanes::rows];
        set(one, 1, 0, s);
        isin::detail::light_direction_pass<T, T>(one, 1, 0, light.position);
        one[Lanes::field(0, Lanes::visible)] = visible[i];
        isin::detail::light_term_pass<T, T>(one, 1, 0, light.color);
        const isin::Color<T> alone = Lanes::local(one, 1, 0);
        same_bits += std::memcmp(&alone, &got, sizeof got) == 0;
    }
    CHECK(same_bits == int(N));
    CHECK(lit > 10); // the test saw lit points, highlights and unlit ones
    CHECK(lit < int(N) - 10);
    CHECK(highlights > 3);
    CHECK(Lanes::local(lanes, N, 3) == points[3].local);
}

TEST_CASE_TEMPLATE(
    "side_pass: the normals on the ray's side and offset_ray_origin's origins, the same bits in any lane", T, float,
    double) {
    using Lanes = isin::detail::ShadingLanes<T>;
    constexpr std::size_t W = Lanes::width, N = 64;
    std::mt19937 rng(11);
    std::uniform_real_distribution<T> coord(T(-50), T(50)), small(T(0), T(1e-4));
    const auto direction = [&] { return isin::normalize(isin::Vertex<T>{coord(rng), coord(rng), coord(rng)}); };
    struct Point {
        isin::Vertex<T> point, error, normal, shading_normal, shading_point, d;
    };
    std::vector<Point> points(N);
    for (std::size_t i = 0; i < N; ++i) {
        Point& s = points[i];
        s.point = {coord(rng), coord(rng), coord(rng)};
        s.error = {small(rng), small(rng), small(rng)};
        s.normal = direction(), s.d = direction();
        // flat (shading normal = normal, shading point = point) or smooth (its own of both)
        s.shading_normal = i % 3 == 0 ? direction() : s.normal;
        s.shading_point = i % 4 == 0 ? s.point + T(0.01) * s.normal : s.point;
    }
    const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    points[5].point.x = inf;             // a point that is not finite: the origins are the point
    points[9].error.y = nan;             // nor its bound
    points[13].normal = {nan, nan, nan}; // nor the normal
    alignas(64) T lanes[Lanes::rows * N];
    const auto set = [](T* at, std::size_t stride, std::size_t k, const Point& s) {
        Lanes::clear(at, stride, k);
        Lanes::set(at, stride, k, Lanes::px, s.point), Lanes::set(at, stride, k, Lanes::ex, s.error);
        Lanes::set(at, stride, k, Lanes::gx, s.normal), Lanes::set(at, stride, k, Lanes::nx, s.shading_normal);
        Lanes::set(at, stride, k, Lanes::hx, s.shading_point), Lanes::set(at, stride, k, Lanes::vx, s.d);
    };
    for (std::size_t i = 0; i < N; ++i) set(lanes, N, i, points[i]);
    for (std::size_t k = 0; k < N; k += W) isin::detail::side_pass(lanes + k, N);
    int same_bits = 0, entering = 0, lifted = 0;
    const auto bits_equal = [](const isin::Vertex<T>& a, const isin::Vertex<T>& b) {
        return std::memcmp(&a, &b, sizeof a) == 0;
    };
    for (std::size_t i = 0; i < N; ++i) {
        CAPTURE(i);
        const Point& s = points[i];
        const isin::Vertex<T> Nf = Lanes::vertex(lanes, N, i, Lanes::gx), Ns = Lanes::vertex(lanes, N, i, Lanes::nx);
        const bool front = lanes[Lanes::front * N + i] != T(0);
        entering += front;
        if (i != 13) {
            // The sides as the scalar formulas decide them (far from grazing: the rays are random).
            CHECK(front == (isin::dot(s.normal, s.d) < T(0)));
            CHECK(Nf == (front ? s.normal : -s.normal));
            CHECK(Ns == (isin::dot(s.shading_normal, Nf) < T(0) ? -s.shading_normal : s.shading_normal));
        }
        CHECK(Lanes::vertex(lanes, N, i, Lanes::vx) == -s.d);
        // Above: offset_ray_origin's origin to Nf's side, bit for bit; shadow rays from it on flat
        // surfaces, else from the shading point with one more rounding in its bound.
        const isin::Vertex<T> above = isin::offset_ray_origin({s.point, s.error}, Nf, Nf);
        CHECK(bits_equal(Lanes::vertex(lanes, N, i, Lanes::ax), above));
        const bool flat = s.shading_point == s.point;
        lifted += !flat;
        const isin::Vertex<T> from = Lanes::vertex(lanes, N, i, Lanes::hx);
        if (flat) {
            CHECK(bits_equal(from, above));
        } else { // Hanika's lift: the shading point's bound is the point's plus γ₁·|shading point|
            const T g1 = isin::rounding_gamma<T>(1);
            const isin::Vertex<T>& q = s.shading_point;
            const isin::Vertex<T> bound{isin::detail::lane_fma(g1, std::fabs(q.x), s.error.x),
                                        isin::detail::lane_fma(g1, std::fabs(q.y), s.error.y),
                                        isin::detail::lane_fma(g1, std::fabs(q.z), s.error.z)};
            CHECK(bits_equal(from, isin::offset_ray_origin({q, bound}, Nf, Nf)));
            if (i != 13) CHECK(isin::dot(from - q, Nf) > T(0));
        }
        if (i == 5 || i == 9 || i == 13) CHECK(bits_equal(Lanes::vertex(lanes, N, i, Lanes::ax), s.point));
        // The same point alone, one value per field: the same bits.
        T one[Lanes::rows];
        set(one, 1, 0, s);
        isin::detail::side_pass<T, T>(one, 1);
        bool same = true;
        for (std::size_t f = 0; f < Lanes::ox; ++f)
            same = same && std::memcmp(&one[f], &lanes[f * N + i], sizeof(T)) == 0;
        same_bits += same;
    }
    CHECK(same_bits == int(N));
    CHECK(entering > 10); // both sides and both kinds of shading point were seen
    CHECK(entering < int(N) - 10);
    CHECK(lifted > 10);
}

TEST_CASE_TEMPLATE("hits_into_lanes and surface_pass: Scene::surface's point, bound and normals, the hit's material, "
                   "colour and ray, bit for bit, in any lane, in runs of hits on one primitive or alone",
                   T, float, double) {
    using Lanes = isin::detail::ShadingLanes<T>;
    constexpr std::size_t W = Lanes::width, N = 64;
    isin::Scene<T, isin::Sphere, isin::Triangle, isin::TexturedTriangle> scene;
    std::mt19937 rng(13);
    std::uniform_real_distribution<T> coord(T(-20), T(20)), unit(T(0), T(1));
    // a material of its own for each primitive, half of the textured triangles' with a texture
    const auto checkers =
        scene.add_texture(isin::Checkerboard<T>{{T(0.9), T(0.8), T(0.1)}, {T(0.1), T(0.2), T(0.7)}, 7, 5});
    const auto material = [&](bool textured) {
        isin::Material<T> m;
        m.color = {unit(rng), unit(rng), unit(rng)};
        m.specular_color = {unit(rng), unit(rng), unit(rng)};
        m.ambient_color = {unit(rng), unit(rng), unit(rng)};
        m.ka = unit(rng), m.kd = unit(rng), m.ks = unit(rng), m.shininess = T(1) + T(100) * unit(rng);
        if (textured) m.texture = checkers;
        return scene.add_material(m);
    };
    scene.ambient_light = {T(0.9), T(0.7), T(0.8)};
    const auto point = [&] { return isin::Vertex<T>{coord(rng), coord(rng), T(40) + coord(rng)}; };
    for (int i = 0; i < 6; ++i) scene.add(isin::Triangle<T>{point(), point(), point()}, material(false));
    for (int i = 0; i < 4; ++i)
        scene.add(isin::TexturedTriangle<T>{{point(), point(), point()}, i % 2 == 1}, material(i != 3));
    scene.add(isin::Sphere<T>{{T(0), T(0), T(20)}, T(5)}, material(false)); // in front of most triangles
    std::vector<isin::Ray<T>> rays;
    std::vector<isin::Hit<T>> hits;
    for (int tries = 0; rays.size() < N && tries < 100000; ++tries) { // rays from the eye that hit
        const T spread = tries % 4 == 0 ? T(0.2) : T(1);              // a quarter of the rays towards the sphere
        const isin::Ray<T> r{{T(0), T(0), T(0)},
                             isin::normalize(isin::Vertex<T>{spread * coord(rng), spread * coord(rng), T(40)})};
        const isin::Hit<T> h = scene.intersect(r);
        if (h) rays.push_back(r), hits.push_back(h);
    }
    REQUIRE(rays.size() == N);
    const auto bits_equal = [](const auto& a, const auto& b) { return std::memcmp(&a, &b, sizeof a) == 0; };
    // Lane i holds hit at[i]: the hits as found (runs of one or two), then sorted by primitive
    // (long runs), then every other one reversed in each run's order.
    std::vector<int> at(N);
    for (std::size_t i = 0; i < N; ++i) at[i] = int(i);
    std::vector<std::vector<int>> orders{at};
    std::stable_sort(at.begin(), at.end(), [&](int a, int b) {
        return std::make_pair(hits[std::size_t(a)].geometry, hits[std::size_t(a)].primitive) <
               std::make_pair(hits[std::size_t(b)].geometry, hits[std::size_t(b)].primitive);
    });
    orders.push_back(at);
    std::reverse(at.begin(), at.end());
    orders.push_back(at);
    int longest_run = 0, textured = 0;
    for (const std::vector<int>& order : orders) {
        alignas(64) T lanes[Lanes::rows * N];
        const isin::Material<T>* materials[N] = {};
        isin::detail::hits_into_lanes(scene, rays.data(), hits.data(), order.data(), N, lanes, N, materials);
        for (std::size_t k = 0; k < N; k += W) isin::detail::surface_pass(lanes + k, N);
        int same = 0, triangles = 0;
        for (std::size_t i = 0, run = 0; i < N; ++i) {
            const std::size_t k = std::size_t(order[i]);
            run = i > 0 && hits[k].primitive == hits[std::size_t(order[i - 1])].primitive &&
                          hits[k].geometry == hits[std::size_t(order[i - 1])].geometry
                      ? run + 1
                      : 1;
            longest_run = std::max(longest_run, int(run));
            const isin::SurfacePoint<T> sp = scene.surface(rays[k], hits[k]);
            const isin::Material<T>& m = scene.material(sp.material);
            triangles += hits[k].geometry != 0;
            textured += m.texture >= 0;
            const isin::Color<T> object = sp.tint * (m.texture >= 0 ? isin::sample(scene.texture(m.texture), sp.st[0],
                                                                                   sp.st[1], scene.texture_filter)
                                                                    : m.color);
            const isin::Color<T> ambient = m.ka * m.ambient_color * object * scene.ambient_light;
            const auto matches = [&](const T* p, std::size_t stride, std::size_t j, const isin::Material<T>* mj) {
                const auto value = [&](std::size_t f) { return p[f * stride + j]; };
                const auto colour = [&](std::size_t f) { return isin::Color<T>{value(f), value(f + 1), value(f + 2)}; };
                return bits_equal(Lanes::vertex(p, stride, j, Lanes::px), sp.point) &&
                       bits_equal(Lanes::vertex(p, stride, j, Lanes::ex), sp.error) &&
                       bits_equal(Lanes::vertex(p, stride, j, Lanes::gx), sp.normal) &&
                       bits_equal(Lanes::vertex(p, stride, j, Lanes::nx), sp.shading_normal) &&
                       bits_equal(Lanes::vertex(p, stride, j, Lanes::hx), sp.shading_point) &&
                       bits_equal(Lanes::vertex(p, stride, j, Lanes::vx), rays[k].direction) && mj == &m &&
                       value(Lanes::kd) == m.kd && value(Lanes::ks) == m.ks && value(Lanes::shininess) == m.shininess &&
                       bits_equal(colour(Lanes::cr), object) && bits_equal(colour(Lanes::sr), m.specular_color) &&
                       bits_equal(colour(Lanes::lr), ambient);
            };
            T one[Lanes::rows]; // the same hit alone, as trace() shades it
            const isin::Material<T>* alone = nullptr;
            const int only = int(k);
            isin::detail::hits_into_lanes(scene, rays.data(), hits.data(), &only, 1, one, 1, &alone);
            isin::detail::surface_pass<T, T>(one, 1);
            same += matches(lanes, N, i, materials[i]) && matches(one, 1, 0, alone);
        }
        CHECK(same == int(N));
        CHECK(triangles > 20); // both kinds of hit were met
        CHECK(triangles < int(N) - 3);
    }
    CHECK(longest_run > 8); // runs of many hits on one primitive were met
    CHECK(textured > 6);    // and textured hits (with one colour each)
}

TEST_CASE("render: progress reports rows done, rising, ending once with every row, on any threads") {
    const auto scene = note_scene::make<float>();
    const isin::Camera<float> cam{160, 90};
    for (int threads : {1, 2, 3}) {
        CAPTURE(threads);
        std::vector<std::pair<int, int>> calls; // only worker 0 reports during the render, then the caller
        isin::RenderOptions opt;
        opt.threads = threads;
        opt.progress = [&](int done, int rows) { calls.emplace_back(done, rows); };
        const auto image = isin::render(scene, cam, opt);
        REQUIRE(!calls.empty());
        CHECK(calls.back() == std::pair<int, int>{90, 90});
        int last = 0, finals = 0;
        for (const auto& [done, rows] : calls) {
            CHECK(rows == 90);
            CHECK(done >= last);
            CHECK(done <= rows);
            finals += done == rows;
            last = done;
        }
        CHECK(finals == 1);
        isin::RenderOptions quiet; // no callback: the same picture
        quiet.threads = threads;
        CHECK(isin::render(scene, cam, quiet).pixels() == image.pixels());
    }
    isin::RenderOptions failing; // a callback's exception reaches the caller
    failing.threads = 2;
    failing.progress = [](int, int) { throw std::runtime_error("stop here"); };
    CHECK_THROWS_AS((void)isin::render(scene, cam, failing), std::runtime_error);
}
