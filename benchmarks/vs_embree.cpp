// isin's Bvh<float> against Embree 3 on the same triangles and the same rays.
//
// For each mesh of benchmarks/meshes.hpp: build both (Embree: RTC_BUILD_QUALITY_MEDIUM, one
// triangle geometry, per-triangle vertices + index buffer), then trace one primary ray per pixel
// of the note's camera (closest hit: isin `intersect`, Embree `rtcIntersect1` and, for reference,
// `rtcIntersect16` on 4×4-pixel tiles) and one shadow ray per lit primary hit towards a point
// light at (200, 300, −100) (any hit: isin `occluded`, Embree `rtcOccluded1`). Shadow rays are
// built once from isin's hits (origin moved off the surface by isin::offset_origin along the
// normal facing the eye; rays whose surface faces away from the light are not traced, as in a
// renderer) and traced by both libraries. Rays are split into bands of 4 image rows handed out
// to std::threads from a shared counter, identically for both libraries; every tracing thread
// sets FTZ/DAZ (Embree's documented recommendation), isin's threads included, so both run in
// the same floating-point mode. Figures are medians of --repeats runs, taken interleaved
// (isin, Embree, isin, Embree, …) so that drifts of this shared machine hit both alike. The
// k-th tracing thread of every measure is pinned to the k-th CPU the process may use (its
// affinity mask, e.g. from taskset), so a measure at one thread never lands on another core
// than the one before it, nor moves between cores half-way (--no-pin leaves it to the
// scheduler): on this project's 2-vCPU machine the two vCPUs ran the same rays up to 7% apart,
// and unpinned one-thread measures of one process moved between them from measure to measure.
//
// Build times: Embree sizes its thread pool once per process (a later device with threads=1
// still builds on every core), so each build time is measured in a fresh child process: this
// program re-executes itself with `--build-only --mesh M --threads N --library L`, which builds
// isin (BvhOptions::threads = N) or Embree (a device made with "threads=N") once untimed, then
// --repeats times, and prints the median and the CPU-time/wall-time ratio of the builds (≈ 1.0
// shows a build really ran on one thread), and the SAH cost of isin's tree (BvhTree::sah_cost:
// the nodes, leaves and triangles a ray through the root meets on average; the same on any
// thread count). Each library builds alone in its own process (a
// build's memory, freed or kept by the allocator, would change the other's page faults);
// `--library both` interleaves the two in one process.
//
// Cold and warm builds: the isin child times each build twice, interleaved: cold (no
// BuildContext: all scratch comes fresh from the kernel and goes back to it) and warm (one
// BuildContext held across the repeats: each build takes the blocks the one before gave back).
//
// Memory: for each mesh a child process per library (--memory-only) holds the triangles, builds
// once (isin: a Bvh<float>, no context; Embree: its scene), calls malloc_trim(0), and reports
// the growth of its resident set over the build (/proc/self/statm) and the peak during the build
// (VmHWM, reset through /proc/self/clear_refs just before); a third child builds isin with a
// BuildContext and keeps it, to show what the context holds.
//
// Meshes: the generated ones of meshes.hpp, and any PLY or OBJ file (--mesh FILE; isin's own
// loader), framed to fill the view as they do; the default list ends with the Stanford dragon
// when build/load_models/dragon_le.ply exists (scripts/dragon.sh fetches it).
//
// Checks: primary hit count and Σt of isin, Embree-1 and Embree-16 must agree to 1e-5 relative,
// and so must the number of occluded shadow rays; the program exits with status 1 otherwise.
// For reference it also prints the counts of Embree's robust mode (RTC_SCENE_FLAG_ROBUST, its
// watertight test), traced once and untimed: where Embree's default test leaks through shared
// edges its count differs from isin's, the robust one should not.
//
// Run: build/…/benchmarks/vs_embree [--mesh NAME] [--repeats N] [--threads-list 1,2]
//      [--width W --height H] [--csv FILE] [--stream-csv FILE] [--no-pin]   (built with -march=native)
#include <embree3/rtcore.h>

#include "embree_scene.hpp"
#include "embree_studies.hpp"
#include <pmmintrin.h>
#include <pthread.h>
#include <sched.h>
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <isin/bvh.hpp>
#include <isin/camera.hpp>
#include <isin/mesh.hpp>
#include <isin/offset.hpp>

#include "meshes.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using Tri = isin::Triangle<float>;
constexpr float inf = std::numeric_limits<float>::infinity();
constexpr double not_measured = std::numeric_limits<double>::quiet_NaN();
constexpr double tolerance = 1e-5;

struct Options {
    std::vector<std::string> meshes = meshes::names();
    int repeats = 5;
    std::vector<int> threads = {1, 2};
    int width = 1920, height = 1080;
    std::string csv;
    std::string stream_csv;                              // the stream table's rows (PacketBench), appended
    std::vector<std::string> studies = studies::names(); // after the meshes (embree_studies.hpp)
    bool build_only = false;                             // child mode: time the builds of one mesh with `build_threads`
    bool memory_only = false;                            // child mode: the memory of one build of one mesh
    int build_threads = 1;
    std::string build_library = "both"; // child mode: isin, embree or both
    std::string self;                   // this program, re-executed for the build times
    bool pin = true;                    // run_bands pins its threads (see the top of this file)
};

// The Stanford dragon (scripts/dragon.sh), in the default list when it is there.
constexpr const char* dragon = "build/load_models/dragon_le.ply";

// Whether run_bands pins its threads: Options::pin, set once before anything is traced.
bool pin_threads = true;

// The CPUs this process may run on (its affinity mask), lowest first; empty when unknown.
std::vector<std::size_t> allowed_cpus() {
    std::vector<std::size_t> cpus;
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0)
        for (std::size_t c = 0; c < CPU_SETSIZE; ++c)
            if (CPU_ISSET(c, &set)) cpus.push_back(c);
    return cpus;
}

// Pins the calling thread, the k-th of a measure, to the k-th allowed CPU (round robin). A
// refusal leaves the thread where the scheduler puts it: noisier, not wrong.
void pin_thread(int k) {
    static const std::vector<std::size_t> cpus = allowed_cpus();
    if (!pin_threads || cpus.empty()) return;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpus[std::size_t(k) % cpus.size()], &set);
    (void)pthread_setaffinity_np(pthread_self(), sizeof set, &set);
}

void set_fp_mode() { // Embree's recommendation for every thread that calls it
    // = _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON) + _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON),
    // spelled out because the DAZ macro trips -Wsign-conversion.
    _mm_setcsr(_mm_getcsr() | unsigned(_MM_FLUSH_ZERO_ON) | unsigned(_MM_DENORMALS_ZERO_ON));
}

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec) + double(u.ru_stime.tv_sec) +
           1e-6 * (double(u.ru_utime.tv_usec) + double(u.ru_stime.tv_usec));
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double relative(double a, double b) { return std::fabs(a - b) / std::max({std::fabs(a), std::fabs(b), 1.0}); }

// ---- Embree ------------------------------------------------------------------------------------

RTCDevice new_device(int threads) {
    const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : std::string();
    RTCDevice device = rtcNewDevice(config.c_str());
    if (!device) {
        std::fprintf(stderr, "rtcNewDevice(\"%s\") failed\n", config.c_str());
        std::exit(3);
    }
    rtcSetDeviceErrorFunction(device, embree_scene::on_error, nullptr);
    return device;
}

// ---- the frame: bands of 4 rows over threads -----------------------------------------------------

struct Totals {
    std::uint64_t hits = 0;
    double sum_t = 0;
};

// Calls band(b, totals_b) for every band b across `threads` std::threads (FTZ/DAZ set in each,
// each pinned: pin_thread); returns the wall time and the totals, summed in band order (the same
// for any thread count).
template <class Band>
Totals run_bands(int bands, int threads, double& seconds, Band&& band) {
    std::vector<Totals> per(std::size_t(std::max(bands, 0)));
    std::atomic<int> next{0};
    const auto worker = [&](int k) {
        pin_thread(k);
        set_fp_mode();
        for (int b; (b = next.fetch_add(1, std::memory_order_relaxed)) < bands;) band(b, per[std::size_t(b)]);
    };
    const auto t0 = Clock::now();
    std::vector<std::thread> pool;
    for (int i = 0; i < threads; ++i) pool.emplace_back(worker, i);
    for (auto& t : pool) t.join();
    seconds = since(t0);
    Totals total;
    for (const Totals& p : per) total.hits += p.hits, total.sum_t += p.sum_t;
    return total;
}

struct ShadowRay {
    isin::Ray<float> ray;
    float t_max;
};

struct Bench {
    const Options& opt;
    isin::Camera<float> camera;
    int bands;
    const isin::Bvh<float>& bvh;
    RTCScene scene;
    std::vector<ShadowRay> shadow;
    std::vector<std::size_t> shadow_begin; // per band: first shadow ray; bands + 1 entries

    Bench(const Options& o, const isin::Bvh<float>& b, RTCScene s, const std::vector<Tri>& tris)
        : opt(o), camera(o.width, o.height), bands((o.height + 3) / 4), bvh(b), scene(s) {
        const isin::Vertex<float> light{200.0f, 300.0f, -100.0f};
        shadow_begin.push_back(0);
        for (int band = 0; band < bands; ++band) {
            for (int y = 4 * band; y < std::min(4 * band + 4, opt.height); ++y)
                for (int x = 0; x < opt.width; ++x) {
                    const isin::Ray<float> ray = camera.primary_ray(float(x), float(y));
                    const isin::Hit<float> hit = bvh.intersect(ray);
                    if (!hit) continue;
                    isin::Vertex<float> n = isin::normalize(isin::normal(tris[hit.primitive]));
                    if (isin::dot(n, ray.direction) > 0.0f) n = -n; // the side the eye sees
                    const isin::Vertex<float> origin = isin::offset_origin(ray.at(hit.t), n, isin::max_abs(ray.origin));
                    const isin::Vertex<float> to_light = light - origin;
                    if (!(isin::dot(n, to_light) > 0.0f)) continue; // faces away from the light
                    const float distance = isin::length(to_light);
                    shadow.push_back({{origin, to_light / distance}, distance});
                }
            shadow_begin.push_back(shadow.size());
        }
    }

    Totals isin_primary(int threads, double& s) const {
        return run_bands(bands, threads, s, [&](int band, Totals& out) {
            Totals acc;
            for (int y = 4 * band; y < std::min(4 * band + 4, opt.height); ++y)
                for (int x = 0; x < opt.width; ++x) {
                    const isin::Hit<float> hit = bvh.intersect(camera.primary_ray(float(x), float(y)));
                    if (hit) ++acc.hits, acc.sum_t += double(hit.t);
                }
            out = acc;
        });
    }

    Totals embree1_primary(int threads, double& s) const { return embree1_primary(threads, s, scene); }
    Totals embree1_primary(int threads, double& s, RTCScene target) const {
        return run_bands(bands, threads, s, [&](int band, Totals& out) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            Totals acc;
            for (int y = 4 * band; y < std::min(4 * band + 4, opt.height); ++y)
                for (int x = 0; x < opt.width; ++x) {
                    const isin::Ray<float> ray = camera.primary_ray(float(x), float(y));
                    RTCRayHit rh;
                    rh.ray.org_x = ray.origin.x, rh.ray.org_y = ray.origin.y, rh.ray.org_z = ray.origin.z;
                    rh.ray.dir_x = ray.direction.x, rh.ray.dir_y = ray.direction.y, rh.ray.dir_z = ray.direction.z;
                    rh.ray.tnear = 0.0f, rh.ray.tfar = inf, rh.ray.time = 0.0f;
                    rh.ray.mask = ~0u, rh.ray.id = 0, rh.ray.flags = 0;
                    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID, rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                    rtcIntersect1(target, &context, &rh);
                    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) ++acc.hits, acc.sum_t += double(rh.ray.tfar);
                }
            out = acc;
        });
    }

    Totals embree16_primary(int threads, double& s) const {
        return run_bands(bands, threads, s, [&](int band, Totals& out) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT; // primary rays of a 4×4 tile
            Totals acc;
            RTCRayHit16 rh;
            alignas(64) int valid[16];
            for (int x0 = 0; x0 < opt.width; x0 += 4) {
                for (int k = 0; k < 16; ++k) {
                    const int x = x0 + k % 4, y = 4 * band + k / 4;
                    valid[k] = x < opt.width && y < opt.height ? -1 : 0;
                    const isin::Ray<float> ray =
                        camera.primary_ray(float(std::min(x, opt.width - 1)), float(std::min(y, opt.height - 1)));
                    rh.ray.org_x[k] = ray.origin.x, rh.ray.org_y[k] = ray.origin.y, rh.ray.org_z[k] = ray.origin.z;
                    rh.ray.dir_x[k] = ray.direction.x, rh.ray.dir_y[k] = ray.direction.y,
                    rh.ray.dir_z[k] = ray.direction.z;
                    rh.ray.tnear[k] = 0.0f, rh.ray.tfar[k] = inf, rh.ray.time[k] = 0.0f;
                    rh.ray.mask[k] = ~0u, rh.ray.id[k] = 0, rh.ray.flags[k] = 0;
                    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID, rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                }
                rtcIntersect16(valid, scene, &context, &rh);
                for (int k = 0; k < 16; ++k)
                    if (valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID)
                        ++acc.hits, acc.sum_t += double(rh.ray.tfar[k]);
            }
            out = acc;
        });
    }

    Totals isin_shadow(int threads, double& s) const {
        return run_bands(bands, threads, s, [&](int band, Totals& out) {
            Totals acc;
            for (std::size_t i = shadow_begin[std::size_t(band)]; i < shadow_begin[std::size_t(band) + 1]; ++i)
                if (bvh.occluded(shadow[i].ray, shadow[i].t_max)) ++acc.hits;
            out = acc;
        });
    }

    Totals embree1_shadow(int threads, double& s) const { return embree1_shadow(threads, s, scene); }
    Totals embree1_shadow(int threads, double& s, RTCScene target) const {
        return run_bands(bands, threads, s, [&](int band, Totals& out) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            Totals acc;
            for (std::size_t i = shadow_begin[std::size_t(band)]; i < shadow_begin[std::size_t(band) + 1]; ++i) {
                const ShadowRay& r = shadow[i];
                RTCRay ray;
                ray.org_x = r.ray.origin.x, ray.org_y = r.ray.origin.y, ray.org_z = r.ray.origin.z;
                ray.dir_x = r.ray.direction.x, ray.dir_y = r.ray.direction.y, ray.dir_z = r.ray.direction.z;
                ray.tnear = 0.0f, ray.tfar = r.t_max, ray.time = 0.0f;
                ray.mask = ~0u, ray.id = 0, ray.flags = 0;
                rtcOccluded1(target, &context, &ray);
                if (ray.tfar < 0.0f) ++acc.hits; // Embree sets tfar = −∞ when occluded
            }
            out = acc;
        });
    }
};

// ---- build times (child process) -----------------------------------------------------------------

// ---- many rays at once: isin's stream calls against Embree's packets ---------------------------

// printf into a string (the packet table is printed after the main one).
template <class... A>
void appendf(std::string& out, const char* format, A... args) {
    char line[1024];
    std::snprintf(line, sizeof line, format, args...);
    out += line;
}

// Fills lanes [0, n) of an Embree packet of N rays from isin rays (lanes ≥ n invalid).
template <int N, class RayN>
void to_embree(const isin::Ray<float>* rays, const float* t_max, int n, RayN& r, int* valid) {
    for (int k = 0; k < N; ++k) {
        const isin::Ray<float>& ray = rays[k < n ? k : 0];
        valid[k] = k < n ? -1 : 0;
        r.org_x[k] = ray.origin.x, r.org_y[k] = ray.origin.y, r.org_z[k] = ray.origin.z;
        r.dir_x[k] = ray.direction.x, r.dir_y[k] = ray.direction.y, r.dir_z[k] = ray.direction.z;
        r.tnear[k] = 0.0f, r.tfar[k] = t_max ? t_max[k < n ? k : 0] : inf, r.time[k] = 0.0f;
        r.mask[k] = ~0u, r.id[k] = 0, r.flags[k] = 0;
    }
}

// The same rays for both libraries, each set in the order a renderer would make them: camera
// rays in 4×4-pixel tiles (16 consecutive rays = one tile = one packet), shadow rays of those
// hits towards the light (same order, so also coherent), and one diffuse bounce per hit
// (cosine-distributed about the normal: incoherent).
struct PacketBench {
    std::vector<isin::Ray<float>> primary, shadow, diffuse;
    std::vector<float> shadow_t_max;
    const isin::Bvh<float>& bvh;
    RTCScene scene;
    static constexpr std::size_t job = 1024; // rays handed to a thread at a time

    PacketBench(const Options& opt, const isin::Bvh<float>& b, RTCScene s, const std::vector<Tri>& tris)
        : bvh(b), scene(s) {
        const isin::Camera<float> camera(opt.width, opt.height);
        const isin::Vertex<float> light{200.0f, 300.0f, -100.0f};
        std::uint64_t state = 0x9E3779B97F4A7C15ull;
        const auto uniform = [&state] { // xorshift64*, in [0, 1)
            state ^= state >> 12, state ^= state << 25, state ^= state >> 27;
            return float((state * 0x2545F4914F6CDD1Dull) >> 40) * 0x1p-24f;
        };
        for (int ty = 0; ty + 4 <= opt.height; ty += 4)
            for (int tx = 0; tx + 4 <= opt.width; tx += 4)
                for (int k = 0; k < 16; ++k)
                    primary.push_back(camera.primary_ray(float(tx + k % 4), float(ty + k / 4)));
        std::vector<isin::Hit<float>> hits(primary.size());
        bvh.intersect(primary.data(), primary.size(), hits.data());
        for (std::size_t i = 0; i < primary.size(); ++i) {
            if (!hits[i]) continue;
            const isin::Ray<float>& ray = primary[i];
            isin::Vertex<float> n = isin::normalize(isin::normal(tris[hits[i].primitive]));
            if (isin::dot(n, ray.direction) > 0.0f) n = -n; // the side the eye sees
            const isin::Vertex<float> origin = isin::offset_origin(ray.at(hits[i].t), n, isin::max_abs(ray.origin));
            const isin::Vertex<float> to_light = light - origin;
            if (isin::dot(n, to_light) > 0.0f) {
                const float distance = isin::length(to_light);
                shadow.push_back({origin, to_light / distance});
                shadow_t_max.push_back(distance);
            }
            // Cosine-weighted about n (Malley): a point on the unit disc lifted to the hemisphere.
            const float r = std::sqrt(uniform()), phi = 6.2831853f * uniform();
            const isin::Vertex<float> a =
                std::fabs(n.x) > 0.5f ? isin::Vertex<float>{0, 1, 0} : isin::Vertex<float>{1, 0, 0};
            const isin::Vertex<float> u = isin::normalize(isin::cross(a, n)), v = isin::cross(n, u);
            const float z = std::sqrt(std::max(0.0f, 1.0f - r * r));
            diffuse.push_back({origin, isin::normalize(r * std::cos(phi) * u + r * std::sin(phi) * v + z * n)});
        }
    }

    // Runs `trace(first, count, totals)` over jobs of `rays` on `threads` threads.
    template <class Trace>
    static Totals over(std::size_t rays, int threads, double& seconds, Trace&& trace) {
        const int jobs = int((rays + job - 1) / job);
        return run_bands(jobs, threads, seconds, [&](int j, Totals& out) {
            const std::size_t first = std::size_t(j) * job;
            trace(first, std::min(job, rays - first), out);
        });
    }

    Totals isin_stream(const std::vector<isin::Ray<float>>& rays, int threads, double& s) const {
        return over(rays.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            isin::Hit<float> hits[job];
            bvh.intersect(rays.data() + first, n, hits);
            for (std::size_t i = 0; i < n; ++i)
                if (hits[i]) ++out.hits, out.sum_t += double(hits[i].t);
        });
    }
    Totals isin_single(const std::vector<isin::Ray<float>>& rays, int threads, double& s) const {
        return over(rays.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            for (std::size_t i = first; i < first + n; ++i)
                if (const isin::Hit<float> h = bvh.intersect(rays[i])) ++out.hits, out.sum_t += double(h.t);
        });
    }
    Totals isin_occluded(int threads, double& s) const {
        return over(shadow.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            std::uint8_t blocked[job];
            bvh.occluded(shadow.data() + first, n, shadow_t_max.data() + first, blocked);
            for (std::size_t i = 0; i < n; ++i) out.hits += blocked[i];
        });
    }
    Totals isin_occluded_single(int threads, double& s) const {
        return over(shadow.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            for (std::size_t i = first; i < first + n; ++i) out.hits += bvh.occluded(shadow[i], shadow_t_max[i]);
        });
    }
    Totals embree1(const std::vector<isin::Ray<float>>& rays, int threads, double& s) const {
        return over(rays.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            for (std::size_t i = first; i < first + n; ++i) {
                RTCRayHit rh;
                rh.ray.org_x = rays[i].origin.x, rh.ray.org_y = rays[i].origin.y, rh.ray.org_z = rays[i].origin.z;
                rh.ray.dir_x = rays[i].direction.x, rh.ray.dir_y = rays[i].direction.y,
                rh.ray.dir_z = rays[i].direction.z;
                rh.ray.tnear = 0.0f, rh.ray.tfar = inf, rh.ray.time = 0.0f;
                rh.ray.mask = ~0u, rh.ray.id = 0, rh.ray.flags = 0;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID, rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(scene, &context, &rh);
                if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) ++out.hits, out.sum_t += double(rh.ray.tfar);
            }
        });
    }
    // rtcIntersect8 / rtcIntersect16 on consecutive rays; `coherent` sets Embree's hint.
    template <int N, class RayHitN>
    Totals embree_n(const std::vector<isin::Ray<float>>& rays, bool coherent, int threads, double& s) const {
        return over(rays.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            if (coherent) context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            alignas(64) RayHitN rh;
            alignas(64) int valid[static_cast<std::size_t>(N)];
            for (std::size_t i = first; i < first + n; i += N) {
                const int m = int(std::min<std::size_t>(N, first + n - i));
                to_embree<N>(rays.data() + i, nullptr, m, rh.ray, valid);
                for (int k = 0; k < N; ++k)
                    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID, rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                if constexpr (N == 8)
                    rtcIntersect8(valid, scene, &context, &rh);
                else
                    rtcIntersect16(valid, scene, &context, &rh);
                for (int k = 0; k < m; ++k)
                    if (rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) ++out.hits, out.sum_t += double(rh.ray.tfar[k]);
            }
        });
    }
    // rtcOccluded16 on consecutive shadow rays; `coherent` sets Embree's hint (rays of one tile
    // towards one light are coherent: an Embree user sets it; the column without it is beside it).
    Totals embree_occluded16(bool coherent, int threads, double& s) const {
        using RayN = RTCRay16;
        constexpr int N = 16;
        return over(shadow.size(), threads, s, [&](std::size_t first, std::size_t n, Totals& out) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            if (coherent) context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            alignas(64) RayN r;
            alignas(64) int valid[static_cast<std::size_t>(N)];
            for (std::size_t i = first; i < first + n; i += N) {
                const int m = int(std::min<std::size_t>(N, first + n - i));
                to_embree<N>(shadow.data() + i, shadow_t_max.data() + i, m, r, valid);
                rtcOccluded16(valid, scene, &context, &r);
                for (int k = 0; k < m; ++k) out.hits += r.tfar[k] < 0.0f; // −∞ when occluded
            }
        });
    }

    // One table row per thread count (and one CSV row, when `csv`); false when a count or sum
    // disagrees.
    bool run(const std::string& name, const Options& opt, std::string& out, std::FILE* csv) const {
        bool ok = true;
        for (const int threads : opt.threads) {
            enum {
                primary_stream,
                primary_single,
                primary_e8,
                primary_e16,
                shadow_stream,
                shadow_single,
                shadow_e16_incoherent,
                shadow_e16,
                diffuse_stream,
                diffuse_single,
                diffuse_e1,
                diffuse_e16,
                measures
            };
            std::vector<double> sec[measures];
            Totals tot[measures];
            // Interleaved, and each group's order turned by one every repeat: a measure that
            // always came right after the other library's would always start with its caches.
            const auto measure = [&](int m, double& t) -> Totals {
                switch (m) {
                case primary_stream: return isin_stream(primary, threads, t);
                case primary_single: return isin_single(primary, threads, t);
                case primary_e8: return embree_n<8, RTCRayHit8>(primary, true, threads, t);
                case primary_e16: return embree_n<16, RTCRayHit16>(primary, true, threads, t);
                case shadow_stream: return isin_occluded(threads, t);
                case shadow_single: return isin_occluded_single(threads, t);
                case shadow_e16_incoherent: return embree_occluded16(false, threads, t);
                case shadow_e16: return embree_occluded16(true, threads, t);
                case diffuse_stream: return isin_stream(diffuse, threads, t);
                case diffuse_single: return isin_single(diffuse, threads, t);
                case diffuse_e1: return embree1(diffuse, threads, t);
                default: return embree_n<16, RTCRayHit16>(diffuse, false, threads, t);
                }
            };
            for (int rep = 0; rep < opt.repeats; ++rep)
                for (int group = 0; group < measures; group += 4)
                    for (int j = 0; j < 4; ++j) {
                        const int m = group + (j + rep) % 4;
                        double t = 0;
                        tot[m] = measure(m, t), sec[m].push_back(t);
                    }
            double mrays[measures];
            for (int m = 0; m < measures; ++m) {
                const double rays = double(m < shadow_stream    ? primary.size()
                                           : m < diffuse_stream ? shadow.size()
                                                                : diffuse.size());
                mrays[m] = rays / median(sec[m]) * 1e-6;
            }
            // The goals' ratios: camera and shadow streams ÷ Embree's 16-ray packets, diffuse ÷ rtcIntersect1.
            const double ratio[3] = {mrays[primary_stream] / mrays[primary_e16],
                                     mrays[shadow_stream] / mrays[shadow_e16],
                                     mrays[diffuse_stream] / mrays[diffuse_e1]};
            appendf(out,
                    "%-15s %3d | %6.2f %6.2f %6.2f %6.2f %6.2f | %6.2f %6.2f %6.2f %6.2f %6.2f | %6.2f %6.2f %6.2f "
                    "%6.2f %6.2f\n",
                    name.c_str(), threads, mrays[primary_stream], mrays[primary_single], mrays[primary_e8],
                    mrays[primary_e16], ratio[0], mrays[shadow_stream], mrays[shadow_single],
                    mrays[shadow_e16_incoherent], mrays[shadow_e16], ratio[1], mrays[diffuse_stream],
                    mrays[diffuse_single], mrays[diffuse_e1], mrays[diffuse_e16], ratio[2]);
            if (csv) {
                std::fprintf(csv, "%s,%d", name.c_str(), threads);
                for (int m = 0; m < measures; ++m) std::fprintf(csv, ",%.4f", mrays[m]);
                std::fprintf(csv, ",%.4f,%.4f,%.4f,%d,%d,%d\n", ratio[0], ratio[1], ratio[2], opt.repeats,
                             opt.width / 4 * 4, opt.height / 4 * 4);
                std::fflush(csv);
            }
            // The stream equals isin's single rays exactly; Embree agrees to the tolerance.
            const auto same = [](const Totals& a, const Totals& b) { return a.hits == b.hits && a.sum_t == b.sum_t; };
            const auto close = [](const Totals& a, const Totals& b) {
                return relative(double(a.hits), double(b.hits)) <= tolerance && relative(a.sum_t, b.sum_t) <= tolerance;
            };
            const bool row_ok =
                same(tot[primary_stream], tot[primary_single]) && same(tot[shadow_stream], tot[shadow_single]) &&
                same(tot[diffuse_stream], tot[diffuse_single]) && close(tot[primary_stream], tot[primary_e16]) &&
                close(tot[primary_stream], tot[primary_e8]) && close(tot[shadow_stream], tot[shadow_e16]) &&
                close(tot[shadow_stream], tot[shadow_e16_incoherent]) && close(tot[diffuse_stream], tot[diffuse_e1]) &&
                close(tot[diffuse_stream], tot[diffuse_e16]);
            if (!row_ok)
                appendf(out,
                        "  MISMATCH %s: primary hits %llu/%llu/%llu/%llu, occluded %llu/%llu/%llu/%llu, diffuse hits "
                        "%llu/%llu/%llu/%llu (stream/single/E-8, E-16 without COHERENT or E-1/E-16)\n",
                        name.c_str(), static_cast<unsigned long long>(tot[primary_stream].hits),
                        static_cast<unsigned long long>(tot[primary_single].hits),
                        static_cast<unsigned long long>(tot[primary_e8].hits),
                        static_cast<unsigned long long>(tot[primary_e16].hits),
                        static_cast<unsigned long long>(tot[shadow_stream].hits),
                        static_cast<unsigned long long>(tot[shadow_single].hits),
                        static_cast<unsigned long long>(tot[shadow_e16_incoherent].hits),
                        static_cast<unsigned long long>(tot[shadow_e16].hits),
                        static_cast<unsigned long long>(tot[diffuse_stream].hits),
                        static_cast<unsigned long long>(tot[diffuse_single].hits),
                        static_cast<unsigned long long>(tot[diffuse_e1].hits),
                        static_cast<unsigned long long>(tot[diffuse_e16].hits));
            ok = ok && row_ok;
        }
        return ok;
    }
};

void packet_header(const Options& opt, std::string& out) {
    appendf(out,
            "\nmany rays at once, Mrays/s (median of %d, interleaved): isin's stream calls (16 consecutive rays = one "
            "packet) against Embree's packets on the same rays, %dx%d\n"
            "primary: 4x4-pixel tiles; shadow: the tiles' hits towards the light; diffuse: one cosine-weighted "
            "bounce per hit (incoherent)\nEmbree's packets carry RTC_INTERSECT_CONTEXT_FLAG_COHERENT but for E-16i "
            "(shadow rays without it) and the diffuse E-16\n",
            opt.repeats, opt.width / 4 * 4, opt.height / 4 * 4);
    appendf(out, "%-15s %3s | %6s %6s %6s %6s %6s | %6s %6s %6s %6s %6s | %6s %6s %6s %6s %6s\n", "mesh", "thr",
            "stream", "isin-1", "E-8", "E-16", "s/E16", "occl.", "isin-1", "E-16i", "E-16", "s/E16", "stream", "isin-1",
            "E-1", "E-16", "s/E1");
}

int build_only(const Options& opt) {
    set_fp_mode();
    const std::vector<Tri> tris = meshes::make<float>(opt.meshes.front());
    RTCDevice device = new_device(opt.build_threads);
    isin::BvhOptions bo;
    bo.threads = opt.build_threads;
    std::vector<double> isin_ms, embree_ms, isin_cpu, embree_cpu, warm_ms;
    isin::BuildContext context; // held across the warm builds
    isin::BvhOptions warm = bo;
    warm.context = &context;
    std::size_t check = 0;
    isin::BvhCost sah;
    const bool isin = opt.build_library != "embree", embree = opt.build_library != "isin";
    for (int rep = -1; rep < opt.repeats; ++rep) { // rep −1: warm-up (Embree's thread pool, page faults)
        double c0 = cpu_seconds();
        auto t0 = Clock::now();
        if (isin) {
            const isin::Bvh<float> bvh{tris, bo};
            const double s = since(t0), c = cpu_seconds() - c0;
            check += bvh.node_count();
            if (rep < 0) sah = bvh.tree().sah_cost(); // the tree's quality, untimed
            if (rep >= 0) isin_ms.push_back(1e3 * s), isin_cpu.push_back(c / s);
            t0 = Clock::now();
            const isin::Bvh<float> again{tris, warm};
            if (rep >= 0) warm_ms.push_back(1e3 * since(t0));
            check += again.node_count();
        }
        if (!embree) continue;
        c0 = cpu_seconds();
        t0 = Clock::now();
        RTCScene scene = embree_scene::make(device, tris);
        const double s = since(t0), c = cpu_seconds() - c0;
        if (rep >= 0) embree_ms.push_back(1e3 * s), embree_cpu.push_back(c / s);
        rtcReleaseScene(scene);
    }
    rtcReleaseDevice(device);
    const auto or_none = [](const std::vector<double>& v) { return v.empty() ? not_measured : median(v); };
    std::printf("BUILD %.3f %.3f %.3f %.3f %zu %.6f %.6f %.6f %.3f\n", or_none(isin_ms), or_none(isin_cpu),
                or_none(embree_ms), or_none(embree_cpu), check, sah.node_visits, sah.leaf_visits, sah.primitive_tests,
                or_none(warm_ms));
    return 0;
}

// ---- memory (child process) ------------------------------------------------------------------------

// The resident set of this process, in bytes (/proc/self/statm), or NaN.
double resident_bytes() {
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return not_measured;
    unsigned long long size = 0, resident = 0;
    const bool ok = std::fscanf(f, "%llu %llu", &size, &resident) == 2;
    std::fclose(f);
    return ok ? double(resident) * double(sysconf(_SC_PAGESIZE)) : not_measured;
}

// The peak resident set (VmHWM) in bytes, or NaN.
double peak_resident_bytes() {
    std::FILE* f = std::fopen("/proc/self/status", "r");
    if (!f) return not_measured;
    char line[256];
    double peak = not_measured;
    while (std::fgets(line, sizeof line, f)) {
        unsigned long long kb = 0;
        if (std::sscanf(line, "VmHWM: %llu kB", &kb) == 1) peak = 1024.0 * double(kb);
    }
    std::fclose(f);
    return peak;
}

// Resets VmHWM to the current resident set; false where the kernel does not allow it.
bool reset_peak() {
    std::FILE* f = std::fopen("/proc/self/clear_refs", "w");
    if (!f) return false;
    const bool ok = std::fputs("5", f) >= 0;
    return std::fclose(f) == 0 && ok;
}

// Child mode: one build of one mesh by one library (isin, isin-context or embree), the threads
// and the library's first build (its pools, isin's and Embree's thread start-up) before the
// measure; prints the resident set's growth after the build and malloc_trim(0), and its peak.
int memory_only(const Options& opt) {
    set_fp_mode();
    const std::vector<Tri> tris = meshes::make<float>(opt.meshes.front());
    const std::vector<Tri> small(tris.begin(), tris.begin() + std::ptrdiff_t(std::min<std::size_t>(tris.size(), 1000)));
    const bool embree = opt.build_library == "embree";
    isin::BvhOptions bo;
    bo.threads = opt.build_threads;
    isin::BuildContext context;
    if (opt.build_library == "isin-context") bo.context = &context;
    RTCDevice device = embree ? new_device(opt.build_threads) : nullptr;
    if (embree)
        rtcReleaseScene(embree_scene::make(device, small));
    else
        (void)isin::Bvh<float>(small, bo).node_count();
    malloc_trim(0);
    const double before = resident_bytes();
    const bool peak_known = reset_peak();
    std::size_t check = 0;
    RTCScene scene = nullptr;
    std::unique_ptr<isin::Bvh<float>> bvh;
    if (embree)
        scene = embree_scene::make(device, tris);
    else
        bvh = std::make_unique<isin::Bvh<float>>(tris, bo), check = bvh->node_count();
    const double peak = peak_known ? peak_resident_bytes() - before : not_measured;
    malloc_trim(0);
    const double growth = resident_bytes() - before;
    std::printf("MEMORY %.0f %.0f %zu\n", growth, peak, check);
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
    return 0;
}

struct Memory {
    double isin = not_measured, isin_peak = not_measured, held = not_measured, embree = not_measured,
           embree_peak = not_measured;
};

// The memory of one build of `mesh` on `threads` threads, each library in a child process of its own.
Memory child_memory(const Options& opt, const std::string& mesh, int threads) {
    Memory m;
    for (const std::string library : {"isin", "isin-context", "embree"}) {
        const std::string command = "'" + opt.self + "' --memory-only --mesh '" + mesh + "' --threads " +
                                    std::to_string(threads) + " --library " + library;
        FILE* pipe = popen(command.c_str(), "r");
        if (!pipe) return m;
        char line[512];
        double growth = not_measured, peak = not_measured;
        while (std::fgets(line, sizeof line, pipe)) {
            unsigned long long check = 0;
            if (std::sscanf(line, "MEMORY %lf %lf %llu", &growth, &peak, &check) != 3) std::fputs(line, stderr);
        }
        if (pclose(pipe) != 0) std::fprintf(stderr, "memory child failed: %s\n", command.c_str());
        if (library == "isin")
            m.isin = growth, m.isin_peak = peak;
        else if (library == "isin-context")
            m.held = growth;
        else
            m.embree = growth, m.embree_peak = peak;
    }
    return m;
}

struct BuildTimes {
    double isin_ms = not_measured, isin_cpu = not_measured, embree_ms = not_measured, embree_cpu = not_measured;
    double isin_warm_ms = not_measured; // with a BuildContext held across the builds
    isin::BvhCost sah; // isin's tree: expected nodes, leaves and triangles a ray through the root meets
};

// The build times of `mesh` on `threads` threads: each library in a child process of its own.
BuildTimes child_build(const Options& opt, const std::string& mesh, int threads) {
    BuildTimes b;
    for (const std::string library : {"isin", "embree"}) {
        const std::string command = "'" + opt.self + "' --build-only --mesh '" + mesh + "' --threads " +
                                    std::to_string(threads) + " --repeats " + std::to_string(opt.repeats) +
                                    " --library " + library;
        FILE* pipe = popen(command.c_str(), "r");
        if (!pipe) return b;
        char line[512];
        BuildTimes child;
        while (std::fgets(line, sizeof line, pipe)) {
            unsigned long long check = 0;
            if (std::sscanf(line, "BUILD %lf %lf %lf %lf %llu %lf %lf %lf %lf", &child.isin_ms, &child.isin_cpu,
                            &child.embree_ms, &child.embree_cpu, &check, &child.sah.node_visits, &child.sah.leaf_visits,
                            &child.sah.primitive_tests, &child.isin_warm_ms) != 9)
                std::fputs(line, stderr);
        }
        if (pclose(pipe) != 0) std::fprintf(stderr, "build child failed: %s\n", command.c_str());
        if (library == "isin")
            b.isin_ms = child.isin_ms, b.isin_cpu = child.isin_cpu, b.sah = child.sah,
            b.isin_warm_ms = child.isin_warm_ms;
        else
            b.embree_ms = child.embree_ms, b.embree_cpu = child.embree_cpu;
    }
    return b;
}

// ---- main ------------------------------------------------------------------------------------------

std::vector<int> parse_list(const char* s) {
    std::vector<int> out;
    for (const char* p = s; *p;) {
        char* end = nullptr;
        const long v = std::strtol(p, &end, 10);
        if (end == p) throw std::invalid_argument(std::string("bad --threads-list '") + s + "'");
        if (v >= 1 && v <= 256) out.push_back(int(v));
        p = *end == ',' ? end + 1 : end;
        if (*end && *end != ',') throw std::invalid_argument(std::string("bad --threads-list '") + s + "'");
    }
    return out;
}

void usage(FILE* f) {
    std::fprintf(
        f,
        "usage: vs_embree [--mesh NAME|FILE|none] [--repeats N] [--threads-list 1,2] [--width W] [--height H] [--csv "
        "FILE]\n"
        "                 [--stream-csv FILE] [--studies all|none|spheres,instances,transparency,refit,groups,memory]\n"
        "                 [--no-pin]\n"
        "isin's Bvh<float> against Embree %d.%d.%d (RTC_BUILD_QUALITY_MEDIUM) on the same triangles and rays:\n"
        "build times (each thread count in a fresh child process), primary rays of the note's camera\n"
        "(isin intersect, rtcIntersect1, rtcIntersect16 on 4x4 tiles) and shadow rays (occluded,\n"
        "rtcOccluded1); medians of N runs (default 5). Meshes:",
        RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH);
    for (const auto& m : meshes::names()) std::fprintf(f, " %s", m.c_str());
    std::fprintf(f,
                 ", and %s when it exists (scripts/dragon.sh);\n"
                 "or any .ply/.obj FILE, framed to fill the view. Builds: isin cold (no BuildContext) and warm (one\n"
                 "held across the repeats); memory: resident-set growth after one build and malloc_trim(0), and its\n"
                 "peak during the build, each library in a child process.\n"
                 "--csv appends one row per mesh and thread count of the first table, --stream-csv one of the\n"
                 "stream table (Mrays/s and the three ratios; scripts/streams.sh takes medians over runs). Then the "
                 "scene studies of\n"
                 "benchmarks/embree_studies.hpp (at half the width and height): spheres against Embree's points and\n"
                 "user geometry, instances, transparent shadows, refit, a mesh in 20 groups, memory. Exit status 1\n"
                 "when the libraries' hit counts or sums of t differ by more than 1e-5 (relative).\n"
                 "Each measure's k-th thread runs pinned to the k-th CPU the process may use; --no-pin leaves\n"
                 "the threads to the scheduler.\n",
                 dragon);
}

// `path` opened for appending, `header` written first when the file is empty; nullptr for no
// path, or (with a message) when it cannot be opened.
std::FILE* open_csv(const std::string& path, const char* header) {
    if (path.empty()) return nullptr;
    std::FILE* f = std::fopen(path.c_str(), "a");
    if (!f)
        std::fprintf(stderr, "cannot open %s\n", path.c_str());
    else if (std::ftell(f) == 0)
        std::fputs(header, f);
    return f;
}

int run(const Options& opt) {
    set_fp_mode();
    // --csv and --stream-csv: appended, with the header line when the file is new.
    std::FILE* csv = open_csv(opt.csv, "mesh,triangles,threads,build_isin_ms,build_embree_ms,isin_mrays,embree1_mrays,"
                                       "embree16_mrays,isin_over_embree1,shadow_isin_mrays,shadow_embree1_mrays,"
                                       "shadow_isin_over_embree1,width,height,build_isin_warm_ms\n");
    if (!opt.csv.empty() && !csv) return 2;
    std::FILE* stream_csv =
        open_csv(opt.stream_csv,
                 "mesh,threads,primary_stream,primary_isin1,primary_e8,primary_e16,shadow_stream,"
                 "shadow_isin1,shadow_e16_incoherent,shadow_e16,diffuse_stream,diffuse_isin1,diffuse_e1,diffuse_e16,"
                 "primary_over_e16,shadow_over_e16,diffuse_over_e1,repeats,width,height\n");
    if (!opt.stream_csv.empty() && !stream_csv) {
        if (csv) std::fclose(csv);
        return 2;
    }
    std::printf("isin Bvh<float> vs Embree %d.%d.%d (MEDIUM), %dx%d primary rays, light (200,300,-100), "
                "median of %d, %u hardware threads, FTZ/DAZ on in every tracing thread, -march=native\n",
                RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH, opt.width, opt.height, opt.repeats,
                std::thread::hardware_concurrency());
    std::printf("%-15s %9s %3s | %8s %8s | %6s %6s %6s %6s | %7s %6s %6s %6s\n", "", "", "", "build ms", "", "primary",
                "Mray/s", "", "", "shadow", "Mray/s", "", "");
    std::printf("%-15s %9s %3s | %8s %8s | %6s %6s %6s %6s | %7s %6s %6s %6s\n", "mesh", "triangles", "thr", "isin",
                "Embree", "isin", "E-1", "E-16", "isin/1", "rays", "isin", "E-1", "isin/1");
    bool all_ok = true;
    std::string packet_table;
    packet_header(opt, packet_table);
    RTCDevice device = new_device(0);
    rtcSetDeviceMemoryMonitorFunction(device, studies::embree_monitor, nullptr);
    for (const std::string& name : opt.meshes) {
        auto t0 = Clock::now();
        const std::vector<Tri> tris = meshes::make<float>(name);
        const double gen_s = since(t0);
        std::vector<BuildTimes> builds;
        for (int threads : opt.threads) builds.push_back(child_build(opt, name, threads));
        const Memory memory = child_memory(opt, name, opt.threads.front());
        const std::string shown = meshes::label(name);
        t0 = Clock::now();
        const isin::Bvh<float> bvh{tris};
        RTCScene scene = embree_scene::make(device, tris);
        const Bench bench(opt, bvh, scene, tris);
        const double setup_s = since(t0);

        Totals ref[3], shadow_ref[2];
        bool ok = true;
        for (std::size_t ti = 0; ti < opt.threads.size(); ++ti) {
            const int threads = opt.threads[ti];
            std::vector<double> s[5];
            Totals tot[5];
            for (int rep = 0; rep < opt.repeats; ++rep) {
                double sec = 0;
                tot[0] = bench.isin_primary(threads, sec), s[0].push_back(sec);
                tot[1] = bench.embree1_primary(threads, sec), s[1].push_back(sec);
                tot[2] = bench.embree16_primary(threads, sec), s[2].push_back(sec);
            }
            for (int rep = 0; rep < opt.repeats; ++rep) {
                double sec = 0;
                tot[3] = bench.isin_shadow(threads, sec), s[3].push_back(sec);
                tot[4] = bench.embree1_shadow(threads, sec), s[4].push_back(sec);
            }
            const double primary = double(opt.width) * double(opt.height), shadows = double(bench.shadow.size());
            double mrays[5];
            for (int m = 0; m < 5; ++m) mrays[m] = (m < 3 ? primary : shadows) / median(s[m]) * 1e-6;
            const BuildTimes& b = builds[ti];
            std::printf("%-15s %9zu %3d | %8.1f %8.1f | %6.2f %6.2f %6.2f %6.2f | %7zu %6.2f %6.2f %6.2f\n",
                        shown.c_str(), tris.size(), threads, b.isin_ms, b.embree_ms, mrays[0], mrays[1], mrays[2],
                        mrays[0] / mrays[1], bench.shadow.size(), mrays[3], mrays[4], mrays[3] / mrays[4]);
            std::fflush(stdout);
            if (csv)
                std::fprintf(csv, "%s,%zu,%d,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%d,%d,%.3f\n", shown.c_str(),
                             tris.size(), threads, b.isin_ms, b.embree_ms, mrays[0], mrays[1], mrays[2],
                             mrays[0] / mrays[1], mrays[3], mrays[4], mrays[3] / mrays[4], opt.width, opt.height,
                             b.isin_warm_ms);
            if (ti == 0) {
                for (int m = 0; m < 3; ++m) ref[m] = tot[m];
                for (int m = 0; m < 2; ++m) shadow_ref[m] = tot[3 + m];
            }
            // Results must not depend on the thread count.
            for (int m = 0; m < 3; ++m)
                ok = ok && tot[m].hits == ref[m].hits && relative(tot[m].sum_t, ref[m].sum_t) < 1e-12;
            for (int m = 0; m < 2; ++m) ok = ok && tot[3 + m].hits == shadow_ref[m].hits;
        }
        // Embree's robust (watertight) mode, traced once, untimed: where Embree's default test
        // leaks through shared edges, its hit count differs from isin's; this one should not.
        RTCScene robust = embree_scene::make(device, tris, RTC_SCENE_FLAG_ROBUST);
        double unused = 0;
        const Totals robust_primary = bench.embree1_primary(opt.threads.front(), unused, robust);
        const Totals robust_shadow = bench.embree1_shadow(opt.threads.front(), unused, robust);
        rtcReleaseScene(robust);
        const bool primary_ok = relative(double(ref[0].hits), double(ref[1].hits)) <= tolerance &&
                                relative(double(ref[0].hits), double(ref[2].hits)) <= tolerance &&
                                relative(ref[0].sum_t, ref[1].sum_t) <= tolerance &&
                                relative(ref[0].sum_t, ref[2].sum_t) <= tolerance;
        const bool shadow_ok = relative(double(shadow_ref[0].hits), double(shadow_ref[1].hits)) <= tolerance;
        ok = ok && primary_ok && shadow_ok;
        all_ok = all_ok && ok;
        std::printf(
            "  %s %s: hits isin %llu E-1 %llu E-16 %llu E-robust %llu (%.1f%% of rays); sum t isin %.9g E-1 %.9g"
            " E-16 %.9g E-robust %.9g; occluded isin %llu E-1 %llu E-robust %llu\n",
            ok ? "OK" : "MISMATCH", shown.c_str(), static_cast<unsigned long long>(ref[0].hits),
            static_cast<unsigned long long>(ref[1].hits), static_cast<unsigned long long>(ref[2].hits),
            static_cast<unsigned long long>(robust_primary.hits),
            100.0 * double(ref[0].hits) / (double(opt.width) * double(opt.height)), ref[0].sum_t, ref[1].sum_t,
            ref[2].sum_t, robust_primary.sum_t, static_cast<unsigned long long>(shadow_ref[0].hits),
            static_cast<unsigned long long>(shadow_ref[1].hits), static_cast<unsigned long long>(robust_shadow.hits));
        std::printf("  builds (child process each):");
        for (std::size_t ti = 0; ti < opt.threads.size(); ++ti)
            std::printf(" %d thr: isin %.1f ms cold, %.1f ms warm (cpu/wall %.2f; SAH: %.3f nodes, %.3f leaves, %.3f "
                        "triangles a ray), Embree %.1f ms (cpu/wall %.2f);",
                        opt.threads[ti], builds[ti].isin_ms, builds[ti].isin_warm_ms, builds[ti].isin_cpu,
                        builds[ti].sah.node_visits, builds[ti].sah.leaf_visits, builds[ti].sah.primitive_tests,
                        builds[ti].embree_ms, builds[ti].embree_cpu);
        const isin::BvhCost embree_sah = embree_scene::builder_sah(device, tris);
        std::printf(" Embree's builder (rtcBuildBVH, 8 wide, leaves of 1-8, blocks of 8) SAH: %.3f nodes, %.3f leaves, "
                    "%.3f triangles a ray;",
                    embree_sah.node_visits, embree_sah.leaf_visits, embree_sah.primitive_tests);
        std::printf(" mesh %.2f s, setup %.2f s\n", gen_s, setup_s);
        std::printf("  memory (%d thr, child process each, after the build and malloc_trim(0)): isin +%.1f MB (peak "
                    "+%.1f MB during the build), Embree +%.1f MB (peak +%.1f MB); isin / Embree %.2f (peak %.2f); "
                    "isin with its BuildContext still held +%.1f MB\n",
                    opt.threads.front(), memory.isin / 1e6, memory.isin_peak / 1e6, memory.embree / 1e6,
                    memory.embree_peak / 1e6, memory.isin / memory.embree, memory.isin_peak / memory.embree_peak,
                    memory.held / 1e6);
        std::fflush(stdout);
        all_ok = PacketBench(opt, bvh, scene, tris).run(shown, opt, packet_table, stream_csv) && all_ok;
        rtcReleaseScene(scene);
    }
    std::fputs(packet_table.c_str(), stdout);
    studies::Config cfg;
    cfg.width = std::max(2, opt.width / 2), cfg.height = std::max(2, opt.height / 2), cfg.repeats = opt.repeats;
    all_ok = studies::run(device, cfg, opt.studies) && all_ok;
    rtcReleaseDevice(device);
    if (csv) std::fclose(csv);
    if (stream_csv) std::fclose(stream_csv);
    std::printf("%s\n", all_ok ? "all checks OK" : "MISMATCH between isin and Embree (see above)");
    return all_ok ? 0 : 1;
}

} // namespace

int main(int argc, char** argv) {
    Options opt;
    bool mesh_given = false;
    try {
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            const auto value = [&]() -> const char* {
                if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
                return argv[++i];
            };
            if (a == "--help" || a == "-h") {
                usage(stdout);
                return 0;
            } else if (a == "--mesh") {
                const std::string m = value();
                if (m == "none")
                    opt.meshes.clear();
                else if (!meshes::is_file(m) &&
                         std::find(meshes::names().begin(), meshes::names().end(), m) == meshes::names().end())
                    throw std::invalid_argument("unknown mesh '" + m + "' (nor a .ply or .obj file)");
                else
                    opt.meshes = {m};
                mesh_given = true;
            } else if (a == "--studies") {
                const std::string list = value();
                opt.studies.clear();
                if (list == "all") opt.studies = studies::names();
                for (std::size_t b = 0; list != "all" && list != "none" && b <= list.size();) {
                    const std::size_t e = std::min(list.find(',', b), list.size());
                    const std::string name = list.substr(b, e - b);
                    if (std::find(studies::names().begin(), studies::names().end(), name) == studies::names().end())
                        throw std::invalid_argument("unknown study '" + name + "'");
                    opt.studies.push_back(name);
                    b = e + 1;
                }
            } else if (a == "--repeats")
                opt.repeats = std::max(1, std::atoi(value()));
            else if (a == "--threads-list")
                opt.threads = parse_list(value());
            else if (a == "--width")
                opt.width = std::atoi(value());
            else if (a == "--height")
                opt.height = std::atoi(value());
            else if (a == "--csv")
                opt.csv = value();
            else if (a == "--stream-csv")
                opt.stream_csv = value();
            else if (a == "--build-only")
                opt.build_only = true;
            else if (a == "--memory-only")
                opt.memory_only = true;
            else if (a == "--threads")
                opt.build_threads = std::max(1, std::atoi(value()));
            else if (a == "--library")
                opt.build_library = value();
            else if (a == "--no-pin")
                opt.pin = false;
            else
                throw std::invalid_argument("unknown option " + a);
        }
        if (opt.threads.empty()) throw std::invalid_argument("empty --threads-list");
        if (opt.width < 2 || opt.height < 2 || opt.width > isin::Camera<float>::max_side ||
            opt.height > isin::Camera<float>::max_side)
            throw std::invalid_argument("--width/--height outside [2, 32768]");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "vs_embree: %s\n", e.what());
        usage(stderr);
        return 2;
    }
    pin_threads = opt.pin;
    if (!mesh_given && access(dragon, R_OK) == 0) opt.meshes.push_back(dragon);
    try {
        if (opt.build_only) return build_only(opt);
        if (opt.memory_only) return memory_only(opt);
    } catch (const std::exception& e) { // a file that cannot be read
        std::fprintf(stderr, "vs_embree: %s\n", e.what());
        return 2;
    }
    char path[4096];
    const ssize_t len = readlink("/proc/self/exe", path, sizeof path - 1);
    opt.self = len > 0 ? std::string(path, std::size_t(len)) : std::string(argv[0]);
    try {
        return run(opt);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "vs_embree: %s\n", e.what());
        return 2;
    }
}
