// isin's secondary-ray study (issue 15, point 4): where shadow, reflected and refracted rays start,
// for six offset methods side by side on the same primary hits — the raw hit point, isin's
// hit_point unmoved, the old fixed rule (offset_origin), isin's error-bound rule
// (offset_ray_origin on hit_point), pbrt-v4's rule re-implemented, and Wächter & Binder's
// integer-ulp offset (float only) — on the workloads of tests/support/secondary.hpp: a trefoil
// knot and a bumpy icosphere (Bvh), spheres with pebbles; s from 1e-3 to 1e3, 0 to 1e6 from the
// origin, eyes 4 to 1000 radii away; float and double.
// Prints a summary (per precision, scene, distance and method), the refraction table and the
// totals per precision, distance and method, and
// writes one CSV row per case and method (--csv). Run: bash scripts/offsets.sh (builds, runs,
// draws docs/offsets.{svg,png}).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "../tests/support/secondary.hpp"

namespace {

using workloads::CaseResult;
using workloads::Offset;

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}

template <class T>
void run_all(std::vector<CaseResult>& results, std::vector<std::string>& skipped, int primaries) {
    for (const auto& c : workloads::secondary_cases()) {
        if (!workloads::representable<T>(c)) {
            char line[96];
            std::snprintf(line, sizeof line, "%s, size %s, D = %g (every eye)", workloads::scene_name(c.scene),
                          c.size_label.c_str(), c.distance);
            if (std::find(skipped.begin(), skipped.end(), line) == skipped.end()) skipped.push_back(line);
            continue;
        }
        results.push_back(workloads::evaluate<T>(c, primaries));
    }
}

void write_csv(const std::vector<CaseResult>& results, const std::string& path) {
    FILE* f = std::fopen(path.c_str(), "w");
    if (!f) {
        std::perror(path.c_str());
        std::exit(1);
    }
    std::fprintf(f, "scene,size,size_label,distance,eye,precision,method,applicable,primaries,shadow_rays,reflected_"
                    "rays,refracted_rays,self_hits,shadow_self_hits,reflection_self_hits,refraction_entry_hits,"
                    "refraction_failures,reference_occluded,lost_occlusions,false_occlusions,median_offset,max_"
                    "offset\n");
    for (const auto& r : results)
        for (Offset m : workloads::all_offsets) {
            const auto& s = r[m];
            std::fprintf(f, "%s,%.9g,%s,%g,%g,%s,%s,%d,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%.6g,%.6g\n",
                         workloads::scene_name(r.c.scene), r.c.size, r.c.size_label.c_str(), r.c.distance, r.c.eye,
                         r.precision, workloads::offset_name(m), s.applicable ? 1 : 0, r.primaries, s.shadow_rays,
                         s.reflected_rays, s.refracted_rays, s.self_hits(), s.shadow_self_hits, s.reflection_self_hits,
                         s.refraction_entry_hits, s.refraction_failures, s.reference_occluded, s.lost_occlusions,
                         s.false_occlusions, s.median_offset, s.max_offset);
        }
    std::fclose(f);
}

// Summary: per precision, scene, distance and method, summed over sizes and eyes; the offset
// columns are the median and the maximum of the cases' medians and maxima.
void print_summary(const std::vector<CaseResult>& results) {
    struct Agg {
        long rays = 0, self = 0, lost = 0, reference = 0, false_occ = 0, refracted = 0, refraction_failures = 0;
        std::vector<double> medians;
        double max = 0;
        bool applicable = true;
    };
    std::map<std::tuple<std::string, int, double, int>, Agg> agg; // precision, scene, D, method
    for (const auto& r : results)
        for (Offset m : workloads::all_offsets) {
            const auto& s = r[m];
            auto& a = agg[{r.precision, int(r.c.scene), r.c.distance, int(m)}];
            a.applicable = s.applicable;
            a.rays += s.rays(), a.self += s.self_hits(), a.lost += s.lost_occlusions;
            a.reference += s.reference_occluded, a.false_occ += s.false_occlusions;
            a.refracted += s.refracted_rays, a.refraction_failures += s.refraction_failures;
            a.medians.push_back(s.median_offset);
            a.max = std::max(a.max, s.max_offset);
        }
    std::printf("Secondary rays, summed over sizes (1e-3, 1, 1e3, 64ulp) and eyes (4, 100, 1000 radii).\n"
                "self: self-hits (shadow + reflected + refracted entry side); lost: shadow rays the long double\n"
                "reference finds blocked that are not (of 'blocked'); false: blocked where the reference is not;\n"
                "refr. fail: refracted rays that miss the far side; offset: |origin - exact point| in object\n"
                "diagonals, median of the cases' medians and largest maximum.\n\n");
    std::printf("%-6s %-8s %6s %-15s %8s %7s %7s %8s %6s %11s %10s %10s\n", "type", "scene", "D", "method", "rays",
                "self", "lost", "blocked", "false", "refr. fail", "offset med", "offset max");
    for (const auto& [key, a] : agg) {
        const auto& [precision, scene, D, method] = key;
        const char* name = workloads::offset_name(Offset(method));
        if (!a.applicable) {
            std::printf("%-6s %-8s %6g %-15s %s\n", precision.c_str(), workloads::scene_name(workloads::Scene(scene)),
                        D, name, "n/a: Wachter-Binder's constants are for float only");
            continue;
        }
        char refr[32] = "-";
        if (a.refracted > 0) std::snprintf(refr, sizeof refr, "%ld/%ld", a.refraction_failures, a.refracted);
        std::printf("%-6s %-8s %6g %-15s %8ld %7ld %7ld %8ld %6ld %11s %10.3g %10.3g\n", precision.c_str(),
                    workloads::scene_name(workloads::Scene(scene)), D, name, a.rays, a.self, a.lost, a.reference,
                    a.false_occ, refr, median(a.medians), a.max);
    }
}

// The key figures: per precision, distance and method, over every scene, size and eye.
void print_totals(const std::vector<CaseResult>& results) {
    struct Agg {
        long rays = 0, self = 0, lost = 0, reference = 0, refracted = 0, refraction_bad = 0;
        std::vector<double> medians;
        bool applicable = true;
    };
    std::map<std::tuple<std::string, double, int>, Agg> agg; // precision, D, method
    for (const auto& r : results)
        for (Offset m : workloads::all_offsets) {
            const auto& s = r[m];
            auto& a = agg[{r.precision, r.c.distance, int(m)}];
            a.applicable = s.applicable;
            a.rays += s.rays(), a.self += s.self_hits(), a.lost += s.lost_occlusions,
                a.reference += s.reference_occluded;
            a.refracted += s.refracted_rays, a.refraction_bad += s.refraction_failures + s.refraction_entry_hits;
            a.medians.push_back(s.median_offset);
        }
    std::printf("\nTotals over all scenes, sizes and eyes: self-hits, lost occlusions (of blocked), median of the\n"
                "cases' median offsets (object diagonals), refracted rays that do not reach the far side.\n\n");
    std::printf("%-6s %6s %-15s %8s %7s %13s %11s %12s\n", "type", "D", "method", "rays", "self", "lost/blocked",
                "offset med", "refr. bad");
    for (const auto& [key, a] : agg) {
        const auto& [precision, D, method] = key;
        if (!a.applicable) {
            std::printf("%-6s %6g %-15s %s\n", precision.c_str(), D, workloads::offset_name(Offset(method)),
                        "n/a (float only)");
            continue;
        }
        char lost[32], refr[32];
        std::snprintf(lost, sizeof lost, "%ld/%ld", a.lost, a.reference);
        std::snprintf(refr, sizeof refr, "%ld/%ld", a.refraction_bad, a.refracted);
        std::printf("%-6s %6g %-15s %8ld %7ld %13s %11.3g %12s\n", precision.c_str(), D,
                    workloads::offset_name(Offset(method)), a.rays, a.self, lost, median(a.medians), refr);
    }
}

// Refraction through the large sphere, per size and distance (summed over the eyes).
void print_refraction(const std::vector<CaseResult>& results) {
    std::map<std::tuple<std::string, std::string, double>, std::pair<double, std::vector<std::pair<long, long>>>> rows;
    for (const auto& r : results) {
        if (r.c.scene != workloads::Scene::spheres) continue;
        auto& row = rows[{r.precision, r.c.size_label, r.c.distance}];
        row.first = r.c.size;
        row.second.resize(workloads::offset_count);
        for (Offset m : workloads::all_offsets) {
            row.second[std::size_t(m)].first += r[m].refraction_failures + r[m].refraction_entry_hits;
            row.second[std::size_t(m)].second += r[m].refracted_rays;
        }
    }
    std::printf("\nRefracted rays through the large sphere that do not reach its far side (missed or entry side hit),\n"
                "of all refracted rays, summed over the eyes; width in float ulps of D.\n\n");
    std::printf("%-6s %-6s %6s %10s", "type", "r", "D", "ulps wide");
    for (Offset m : workloads::all_offsets) std::printf(" %15s", workloads::offset_name(m));
    std::printf("\n");
    for (const auto& [key, row] : rows) {
        const auto& [precision, label, D] = key;
        const double ulp = workloads::float_ulp(D);
        char width[32] = "-";
        if (ulp > 0) std::snprintf(width, sizeof width, "%.3g", 2 * row.first / ulp);
        std::printf("%-6s %-6s %6g %10s", precision.c_str(), label.c_str(), D, width);
        for (Offset m : workloads::all_offsets) {
            const auto& [bad, n] = row.second[std::size_t(m)];
            char cell[32];
            if (m == Offset::wachter_binder && precision == "double")
                std::snprintf(cell, sizeof cell, "n/a");
            else
                std::snprintf(cell, sizeof cell, "%ld/%ld", bad, n);
            std::printf(" %15s", cell);
        }
        std::printf("\n");
    }
}

} // namespace

int main(int argc, char** argv) {
    std::string csv = "offsets.csv";
    int primaries = 2000;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--csv") && i + 1 < argc)
            csv = argv[++i];
        else if (!std::strcmp(argv[i], "--primaries") && i + 1 < argc)
            primaries = std::max(1, std::atoi(argv[++i]));
        else {
            std::printf("usage: offsets [--csv FILE] [--primaries N]\n");
            return std::strcmp(argv[i], "--help") ? 2 : 0;
        }
    }
    std::vector<CaseResult> results;
    std::vector<std::string> skipped;
    run_all<float>(results, skipped, primaries);
    run_all<double>(results, skipped, primaries);
    write_csv(results, csv);
    print_summary(results);
    print_refraction(results);
    print_totals(results);
    std::printf("\nSkipped in float (the object is under 1024 (meshes) or 16 (spheres) float ulps of D across):\n");
    for (const auto& s : skipped) std::printf("  %s\n", s.c_str());
    std::printf("Wachter-Binder (RTG ch. 6) is float only: not applicable to the double rows.\n");
    std::printf("%d primary rays per case; wrote %s\n", primaries, csv.c_str());
    return 0;
}
