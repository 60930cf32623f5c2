// Prints the numbers of every worked example of the note "Işın İzleme", computed by isin.
// Build: c++ -std=c++17 -I include examples/worked_examples.cpp -o worked_examples
#include <isin/isin.hpp>

#include <cstdio>
#include <cstring>

namespace {

using V = isin::Vec3d;

// Prints a label padded to 32 columns; counts UTF-8 characters, not bytes.
void label_column(const char* label) {
    int columns = 0;
    for (const char* c = label; *c; ++c) columns += (static_cast<unsigned char>(*c) & 0xC0) != 0x80;
    std::printf("  %s%*s", label, columns < 32 ? 32 - columns : 0, "");
}
void print(const char* label, const V& v) {
    label_column(label);
    std::printf("(%g, %g, %g)\n", v.x, v.y, v.z);
}
void print(const char* label, double s) {
    label_column(label);
    std::printf("%g\n", s);
}

template <class Intersect>
void nearest_of_5a(const char* method, Intersect intersect) {
    const isin::Triangled tris[] = {{{0, 30, 40}, {40, -30, 120}, {-40, -30, 120}},
                                    {{-50, 30, 124}, {50, 30, 124}, {0, -30, 44}},
                                    {{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}}};
    const char* names[] = {"red U", "green Y", "blue Z"};
    const isin::Rayd ray{{0, 0, 0}, isin::normalize(V{0, 0, 10})};
    int nearest = -1;
    double nearest_t = 0;
    std::printf("  %s:", method);
    for (int i = 0; i < 3; ++i) {
        const auto hit = intersect(ray, tris[i]);
        std::printf("  t_%c = %g", names[i][std::strlen(names[i]) - 1], hit.t);
        if (hit && (nearest < 0 || hit.t < nearest_t)) nearest = i, nearest_t = hit.t;
    }
    std::printf("  → the pixel is %s\n", nearest >= 0 ? names[nearest] : "background");
}

} // namespace

int main(int argc, char** argv) {
    if (argc > 1) {
        const bool help = std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0;
        std::fprintf(help ? stdout : stderr,
                     "usage: worked_examples [--help]\n"
                     "Prints the worked examples of the note (§2–§6, §11) as computed by isin.\n");
        return help ? 0 : 2;
    }
    std::printf("§2 example 2a\n");
    print("|(0,6,8)|", isin::length(V{0, 6, 8}));
    print("normalize(0,6,8)", isin::normalize(V{0, 6, 8}));

    std::printf("§2 example 2b\n");
    const isin::Triangled tri{{0, 40, 120}, {30, -40, 60}, {-30, -40, 60}};
    print("V1 − V0", tri.v1 - tri.v0);
    print("V2 − V0", tri.v2 - tri.v0);
    print("N = (V1−V0) × (V2−V0)", isin::normal(tri));
    print("normalize(N)", isin::normalize(isin::normal(tri)));

    std::printf("§3 example 3a (800×450)\n");
    const isin::Camera<double> cam{800, 450};
    print("GD(0,0)", cam.image_point(0, 0));
    print("GD(799,449)", cam.image_point(799, 449));

    std::printf("§4 example 4a\n");
    const isin::Rayd ray{{0, 0, 0}, {0, 0, 1}};
    const V unit_N = isin::normalize(isin::normal(tri));
    print("D (unit N)", isin::plane_offset(unit_N, tri.v0));
    print("D (raw N)", isin::plane_offset(isin::normal(tri), tri.v0));
    const double t = isin::ray_plane_t(ray, unit_N, isin::plane_offset(unit_N, tri.v0));
    print("t", t);
    print("R", ray.at(t));
    const auto a = isin::area_terms(tri, ray.at(t));
    std::printf("  S = %g, s1 = %g, s2 = %g, s3 = %g → %s\n", a.S, a.s1, a.s2, a.s3,
                isin::intersect_area(ray, tri, 0.005) ? "inside" : "outside");

    std::printf("§5 example 5a\n");
    nearest_of_5a("area test (ε = 0.005)",
                  [](const isin::Rayd& r, const isin::Triangled& tr) { return isin::intersect_area(r, tr, 0.005); });
    nearest_of_5a("Möller–Trumbore     ", [](const isin::Rayd& r, const isin::Triangled& tr) {
        return isin::intersect_moller_trumbore(r, tr);
    });

    std::printf("§6 ray–sphere (centre (0,0,50), r = 5)\n");
    const isin::Sphered sp{{0, 0, 50}, 5};
    print("from the eye along +Z: t", isin::intersect(ray, sp).t);
    print("from the centre: t", isin::intersect(isin::Rayd{{0, 0, 50}, {0, 0, 1}}, sp).t);

    std::printf("§11 example 11a\n");
    const isin::Triangled first{{0, 0, 40}, {40, 0, -40}, {-40, 0, -40}};
    const isin::Triangled reordered{{40, 0, -40}, {0, 0, 40}, {-40, 0, -40}};
    print("N, first order", isin::normal(first));
    print("N, reordered", isin::normal(reordered));
    return 0;
}
