// A user's program: includes the umbrella header and nothing else of isin's.
#include <isin/isin.hpp>

#include <cstdio>

int main() {
    const isin::Camera<float> cam{800, 450};
    const isin::Triangle<float> blue{{-30, 0, 37}, {30, 40, 117}, {30, -40, 117}};
    const auto hit = isin::intersect_moller_trumbore(cam.primary_ray(399.5f, 224.5f), blue);
    std::printf("t = %.1f\n", static_cast<double>(hit.t));
    return hit && hit.t > 76.9f && hit.t < 77.1f ? 0 : 1;
}
