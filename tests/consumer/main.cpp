// A user's program: includes the umbrella header and nothing else of isin's; follows the README.
// Its file code comes from isin::io (CMake), isin-io (pkg-config) or -DISIN_IMPLEMENTATION.
#include <isin/isin.hpp>

#include <cstdio>
#include <vector>

int main(int argc, char** argv) {
    const isin::Camera<float> cam{32, 18};
    const isin::Triangle<float> blue{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}};
    const auto hit = isin::intersect_moller_trumbore(cam.primary_ray(15.5f, 8.5f), blue);
    std::printf("t = %.1f\n", static_cast<double>(hit.t));

    isin::StandardScene<float> scene; // its members and renderer from isin::io where linked (ISIN_COMPILED)
    isin::Material<float> red;
    red.color = isin::from_rgb8<float>(255, 0, 0);
    scene.add(blue, scene.add_material(red));
    scene.add(isin::Sphere<float>{{0, 0, 60}, 5}, scene.add_material({}));
    scene.add_light({{0, 40, 0}});
    isin::RenderOptions opt;
    opt.threads = 2;
    const isin::Image image = isin::render(scene, cam, opt);
    const isin::Rgb8 centre = image(16, 9); // the white sphere at t = 55, in front of the triangle
    int red_pixels = 0;
    for (const auto& p : image.pixels()) red_pixels += p.r > 0 && p.g == 0 && p.b == 0;
    std::printf("centre pixel (%d, %d, %d), %d red pixels\n", centre.r, centre.g, centre.b, red_pixels);
    const bool sphere = centre.r > 0 && centre.r == centre.g && centre.g == centre.b;
    // A Bvh of its own: its builder comes from isin::io / isin-io (ISIN_COMPILED) or is compiled here.
    const isin::Bvh<float> bvh(std::vector<isin::Triangle<float>>{blue});
    const bool bvh_hit = bvh.intersect(cam.primary_ray(15.5f, 8.5f)).primitive == 0;
    if (argc > 1) { // the file code: write and read back
        isin::write_image(image, argv[1]);
        if (isin::read_image(argv[1]).pixels() != image.pixels()) return 1;
    }
    return hit && hit.t > 76.9f && hit.t < 77.1f && sphere && red_pixels > 20 && bvh_hit ? 0 : 1;
}
