// A slice of a model's signed distance field as a picture: isin::Solid's signed_distance on a
// plane through the middle of the model's box (z = its centre), blue inside, orange outside,
// darker bands every 1/20 of the box's largest side, black on the surface.
// Usage: sdf_slice [model.obj|model.ply] [out.png] [pixels (the larger side, default 512)]
// Without a model: two overlapping cubes stored as one mesh (a union one-ray parity gets wrong).
#include <isin/isin.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

// The 12 triangles of the cube [lo, hi]³ (a 3-vector of lows and highs), front faces outside.
void add_cube(std::vector<isin::Triangle<float>>& out, isin::Vertex<float> lo, isin::Vertex<float> hi) {
    const auto corner = [&](int i) {
        return isin::Vertex<float>{i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
    };
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    const isin::Vertex<float> centre = 0.5f * (lo + hi);
    for (const auto& q : quads)
        for (const auto& t : {isin::Triangle<float>{corner(q[0]), corner(q[1]), corner(q[2])},
                              isin::Triangle<float>{corner(q[0]), corner(q[2]), corner(q[3])}})
            out.push_back(isin::dot(isin::normal(t), t.v0 - centre) > 0 ? t : isin::Triangle<float>{t.v0, t.v2, t.v1});
}

} // namespace

int main(int argc, char** argv) try {
    const std::string out = argc > 2 ? argv[2] : "sdf_slice.png";
    const int side = argc > 3 ? std::atoi(argv[3]) : 512;
    if (side < 2 || side > 4096) throw std::invalid_argument("pixels must be in [2, 4096]");
    std::vector<isin::Triangle<float>> tris;
    if (argc > 1) {
        tris = isin::load_mesh<float>(argv[1]);
    } else {
        add_cube(tris, {-1, -1, -1}, {0.5f, 0.5f, 0.5f});
        add_cube(tris, {-0.2f, -0.4f, -0.7f}, {1.2f, 1, 0.7f});
    }
    const isin::Solid<float> solid{isin::Mesh<float>::from_triangles(tris)};
    isin::Box<float> box;
    for (const auto& t : tris) box.grow(t.v0), box.grow(t.v1), box.grow(t.v2);
    if (!box.usable()) throw std::invalid_argument("the model has no usable triangles");
    const isin::Vertex<float> size = box.hi - box.lo, centre = 0.5f * (box.lo + box.hi);
    const float extent = 1.1f * std::max(size.x, size.y), band = std::max({size.x, size.y, size.z}) / 20;
    const int w = size.x >= size.y ? side : std::max(2, int(float(side) * size.x / size.y));
    const int h = size.x >= size.y ? std::max(2, int(float(side) * size.y / size.x)) : side;
    std::vector<isin::Vertex<float>> points;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            points.push_back({centre.x + extent * ((float(x) + 0.5f) / float(std::max(w, h)) -
                                                   0.5f * float(w) / float(std::max(w, h))),
                              centre.y - extent * ((float(y) + 0.5f) / float(std::max(w, h)) -
                                                   0.5f * float(h) / float(std::max(w, h))),
                              centre.z});
    std::vector<float> d(points.size());
    solid.signed_distance(points.data(), points.size(), d.data());
    isin::Image image(w, h);
    const float pixel = extent / float(std::max(w, h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float v = d[std::size_t(y) * std::size_t(w) + std::size_t(x)];
            const float shade = 0.75f + 0.25f * std::cos(6.2831853f * v / band); // bands every `band`
            const auto c = [&](float r, float g, float b) {
                return isin::Rgb8{std::uint8_t(255 * r * shade), std::uint8_t(255 * g * shade),
                                  std::uint8_t(255 * b * shade)};
            };
            image.at(x, y) = std::fabs(v) < pixel ? isin::Rgb8{0, 0, 0}
                             : v < 0              ? c(0.25f, 0.45f, 0.9f)
                                                  : c(0.95f, 0.6f, 0.25f);
        }
    isin::write_png(image, out);
    std::printf("%s: %d×%d, slice z = %g, %zu triangles\n", out.c_str(), w, h, double(centre.z), tris.size());
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "sdf_slice: %s\n", e.what());
    return 1;
}
