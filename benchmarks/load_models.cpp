// Model loading: isin::load_model<float> and isin::load_mesh<float> against assimp's
// Assimp::Importer::ReadFile on the same files, in time and in peak memory.
//
// Loaders, each on every file:
//   isin::load_model<float>   meshes by index; an OBJ vertex is each distinct v/vt/vn triple of
//                             a group, a PLY vertex each vertex of the file (textures not decoded
//                             unless --textures: assimp never decodes them)
//   isin::load_mesh<float>    a triangle soup (three positions per triangle)
//   assimp T+J                ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices)
//   assimp T                  ReadFile(path, aiProcess_Triangulate)
// Which assimp run is comparable to load_model is the one that ends with the same number of
// vertices: on OBJ that is T+J (assimp's OBJ importer gives every face corner its own vertex and
// JoinIdenticalVertices shares equal ones again, as isin shares equal v/vt/vn triples), on PLY
// assimp keeps the file's vertices as isin does, so plain T is (J would also merge vertices the
// file repeats). The summary at the end uses the run with load_model's vertex count, T+J if
// neither has it (an OBJ of positions only: J also merges repeated positions), and says which.
//
// Time: in this process, a first untimed pass (page cache warm, geometry read off), then
// --rounds rounds (default 5) of all four loaders, interleaved and in a rotated order each round,
// so that the drifts of a shared machine hit all alike: medians of wall-clock and thread CPU
// time (user + system; every loader runs on the calling thread, so CPU time is the figure that
// other processes on a shared machine disturb least), the spread (max − min) / median of the CPU
// times, and isin / assimp as the median of the per-round ratios of CPU time. Only the loading
// call is timed: the Importer is made before, results are freed after the clock stops.
// Geometry: triangles, vertices and the total area (Σ ½|(V1−V0) × (V2−V0)|, in double) from each
// loader, to show that both read the same surface.
// Peak memory: each loader runs in a child process (this program re-executed with the hidden
// option `--child LOADER FILE`); its ru_maxrss from wait4, minus that of a child that loads
// nothing, is the loader's peak (MiB, median of --memory-rounds children, default 3; 0: none).
// A forked child's ru_maxrss also counts the parent's resident pages at fork time, so all
// children run first, while this process is still small.
//
// Files: those given, else the dragon files scripts/load_models.sh makes in --data DIR (default
// build/load_models): dragon_{ascii,le,be}.ply and dragon_{vn,v}.obj (Stanford dragon, 871,414
// triangles); --all-testmodels adds the OBJ and PLY files of Debian's assimp-testmodels
// (/usr/share/assimp/models/{OBJ,PLY}); files a loader refuses say so in their row.
//
// Run: scripts/load_models.sh [options], or
//      build/…/benchmarks/load_models [--rounds N] [--memory-rounds N] [--data DIR]
//                                     [--all-testmodels] [--textures] [FILE…]   (-march=native)
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <isin/mesh.hpp>
#include <isin/model.hpp>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace {

constexpr double no_value = std::numeric_limits<double>::quiet_NaN();

enum class Loader { none, isin_model, isin_mesh, assimp_join, assimp_triangulate };
constexpr std::array<Loader, 4> loaders = {Loader::isin_model, Loader::isin_mesh, Loader::assimp_join,
                                           Loader::assimp_triangulate};

/// Name on the command line (--child) and label in the tables.
const char* key(Loader l) {
    switch (l) {
    case Loader::none: return "none";
    case Loader::isin_model: return "isin-model";
    case Loader::isin_mesh: return "isin-mesh";
    case Loader::assimp_join: return "assimp-tj";
    case Loader::assimp_triangulate: return "assimp-t";
    }
    return "";
}
const char* label(Loader l) {
    switch (l) {
    case Loader::none: return "(nothing)";
    case Loader::isin_model: return "isin::load_model<float>";
    case Loader::isin_mesh: return "isin::load_mesh<float>";
    case Loader::assimp_join: return "assimp T+J";
    case Loader::assimp_triangulate: return "assimp T";
    }
    return "";
}
std::optional<Loader> loader_named(const std::string& name) {
    for (Loader l :
         {Loader::none, Loader::isin_model, Loader::isin_mesh, Loader::assimp_join, Loader::assimp_triangulate})
        if (name == key(l)) return l;
    return std::nullopt;
}

/// What a loader read: triangles, vertices (0 for a soup) and their total area.
struct Geometry {
    std::size_t triangles = 0, vertices = 0;
    double area = 0;
};

double area(const isin::Vertex<double>& a, const isin::Vertex<double>& b, const isin::Vertex<double>& c) {
    return 0.5 * isin::length(isin::cross(b - a, c - a)); // §2: |N| = 2·area
}
isin::Vertex<double> wide(const isin::Vertex<float>& p) { return {double(p.x), double(p.y), double(p.z)}; }
isin::Vertex<double> wide(const aiVector3D& p) { return {double(p.x), double(p.y), double(p.z)}; }

Geometry summarize(const isin::Model<float>& model) {
    Geometry g;
    for (const isin::Mesh<float>& mesh : model.meshes) {
        g.vertices += mesh.positions.size();
        g.triangles += mesh.size();
        for (const auto& k : mesh.indices)
            g.area += area(wide(mesh.positions[k[0]]), wide(mesh.positions[k[1]]), wide(mesh.positions[k[2]]));
    }
    return g;
}
Geometry summarize(const std::vector<isin::Triangle<float>>& soup) {
    Geometry g;
    g.triangles = soup.size();
    for (const auto& t : soup) g.area += area(wide(t.v0), wide(t.v1), wide(t.v2));
    return g;
}
/// Triangles of all meshes (assimp keeps points and lines as faces of 1 or 2 indices: skipped).
Geometry summarize(const aiScene& scene) {
    Geometry g;
    for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
        const aiMesh& mesh = *scene.mMeshes[m];
        g.vertices += mesh.mNumVertices;
        for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
            const aiFace& face = mesh.mFaces[f];
            if (face.mNumIndices != 3) continue;
            ++g.triangles;
            g.area += area(wide(mesh.mVertices[face.mIndices[0]]), wide(mesh.mVertices[face.mIndices[1]]),
                           wide(mesh.mVertices[face.mIndices[2]]));
        }
    }
    return g;
}

/// One load: seconds of the loading call alone (wall clock and this thread's CPU time, user and
/// system: all four loaders run on the calling thread), what it read, or why it failed.
struct Run {
    double wall = 0, cpu = 0;
    Geometry geometry;
    std::string error;
};

/// Wall clock and thread CPU time from its making to stop().
class Stopwatch {
public:
    Stopwatch() : wall_(std::chrono::steady_clock::now()), cpu_(thread_cpu()) {}
    void stop(Run& run) const {
        run.cpu = thread_cpu() - cpu_;
        run.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_).count();
    }

private:
    static double thread_cpu() {
        timespec ts{};
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
        return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
    }
    std::chrono::steady_clock::time_point wall_;
    double cpu_;
};

Run load(Loader loader, const std::string& file, const isin::ModelOptions& options) {
    Run run;
    try {
        switch (loader) {
        case Loader::none: break;
        case Loader::isin_model: {
            const Stopwatch clock;
            const isin::Model<float> model = isin::load_model<float>(file, options);
            clock.stop(run);
            run.geometry = summarize(model);
            break;
        }
        case Loader::isin_mesh: {
            const Stopwatch clock;
            const std::vector<isin::Triangle<float>> soup = isin::load_mesh<float>(file, options.limits);
            clock.stop(run);
            run.geometry = summarize(soup);
            break;
        }
        case Loader::assimp_join:
        case Loader::assimp_triangulate: {
            const unsigned flags = loader == Loader::assimp_join
                                       ? unsigned(aiProcess_Triangulate | aiProcess_JoinIdenticalVertices)
                                       : unsigned(aiProcess_Triangulate);
            Assimp::Importer importer;
            const Stopwatch clock;
            const aiScene* scene = importer.ReadFile(file, flags);
            clock.stop(run);
            if (!scene) {
                run.error = importer.GetErrorString();
                if (run.error.empty()) run.error = "failed";
            } else {
                run.geometry = summarize(*scene);
            }
            break;
        }
        }
    } catch (const std::exception& e) {
        run.error = e.what();
    }
    return run;
}

/// Peak resident memory in KiB (ru_maxrss) of this program re-executed as `--child loader file`;
/// −1 if the child failed.
long child_peak_kib(Loader loader, const std::string& file, bool textures) {
    std::vector<std::string> args = {"load_models", "--child", key(loader), file};
    if (textures) args.emplace_back("--textures");
    std::fflush(stdout);
    const pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        const int null = open("/dev/null", O_WRONLY); // the child's error is in the table already
        if (null >= 0) dup2(null, 2);
        std::vector<char*> argv;
        for (std::string& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        execv("/proc/self/exe", argv.data());
        _exit(127);
    }
    int status = 0;
    rusage usage{};
    if (wait4(pid, &status, 0, &usage) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1;
    return usage.ru_maxrss;
}

/// The hidden child mode: load once, touch the result, exit 0 (1 on failure).
int child_main(Loader loader, const std::string& file, const isin::ModelOptions& options) {
    const Run run = load(loader, file, options);
    if (!run.error.empty()) {
        std::fprintf(stderr, "load_models --child %s %s: %s\n", key(loader), file.c_str(), run.error.c_str());
        return 1;
    }
    return run.geometry.triangles == std::size_t(-1) ? 2 : 0; // keeps the summary alive
}

double median(std::vector<double> v) {
    if (v.empty()) return no_value;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Everything measured on one file, per loader (indexed as `loaders`).
struct FileResult {
    std::string file;
    std::array<Run, 4> first;                     // the untimed pass: geometry or error
    std::array<std::vector<double>, 4> wall, cpu; // seconds, one per timed round
    std::array<double, 4> peak_mib{no_value, no_value, no_value, no_value};
};

std::size_t index_of(Loader l) {
    return static_cast<std::size_t>(std::find(loaders.begin(), loaders.end(), l) - loaders.begin());
}

/// The assimp run comparable to load_model: the one with load_model's vertex count (T first, the
/// cheaper); T+J if neither has it.
Loader comparable(const FileResult& r) {
    const std::size_t v = r.first[index_of(Loader::isin_model)].geometry.vertices;
    if (r.first[index_of(Loader::assimp_triangulate)].geometry.vertices == v) return Loader::assimp_triangulate;
    return Loader::assimp_join;
}

/// (max − min) / median of the timed rounds, in %: how noisy the median is.
double spread(const std::vector<double>& v) {
    if (v.empty()) return no_value;
    const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
    return 100 * (*hi - *lo) / median(v);
}

/// Median over the rounds of a[k] / b[k]: loads of one round ran seconds apart, so a drift of the
/// machine cancels better than in the ratio of the medians.
double round_ratio(const std::vector<double>& a, const std::vector<double>& b) {
    std::vector<double> q;
    for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k) q.push_back(a[k] / b[k]);
    return median(q);
}

/// q with two decimals, "-" if it is not a positive number.
std::string decimals(double q) {
    if (!(q > 0) || !std::isfinite(q)) return "-";
    char s[32];
    std::snprintf(s, sizeof s, "%.2f", q);
    return s;
}

/// MiB with one decimal, "-" if not measured.
std::string mib(double m) {
    if (!std::isfinite(m)) return "-";
    char s[32];
    std::snprintf(s, sizeof s, "%.1f", m);
    return s;
}

void print_file(const FileResult& r) {
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(r.file, ec);
    std::printf("\n%s (%.1f MB)\n", r.file.c_str(), ec ? 0.0 : double(bytes) / 1e6);
    std::printf("  %-24s %9s %9s %11s %9s %9s %6s %6s %6s %8s %6s %6s\n", "loader", "triangles", "vertices",
                "total area", "wall ms", "CPU ms", "spread", "/T+J", "/T", "peak MiB", "/T+J", "/T");
    const std::size_t tj = index_of(Loader::assimp_join), t = index_of(Loader::assimp_triangulate);
    for (std::size_t i = 0; i < loaders.size(); ++i) {
        const Run& first = r.first[i];
        if (!first.error.empty()) {
            std::printf("  %-24s error: %.160s\n", label(loaders[i]), first.error.c_str());
            continue;
        }
        const bool is_isin = i < tj;
        const std::string vertices =
            loaders[i] == Loader::isin_mesh ? "(soup)" : std::to_string(first.geometry.vertices);
        std::printf("  %-24s %9zu %9s %11.6g %9.1f %9.1f %5.0f%% %6s %6s %8s %6s %6s\n", label(loaders[i]),
                    first.geometry.triangles, vertices.c_str(), first.geometry.area, 1e3 * median(r.wall[i]),
                    1e3 * median(r.cpu[i]), spread(r.cpu[i]),
                    is_isin ? decimals(round_ratio(r.cpu[i], r.cpu[tj])).c_str() : "",
                    is_isin ? decimals(round_ratio(r.cpu[i], r.cpu[t])).c_str() : "", mib(r.peak_mib[i]).c_str(),
                    is_isin ? decimals(r.peak_mib[i] / r.peak_mib[tj]).c_str() : "",
                    is_isin ? decimals(r.peak_mib[i] / r.peak_mib[t]).c_str() : "");
    }
    const Run& model = r.first[index_of(Loader::isin_model)];
    const Run& peer = r.first[index_of(comparable(r))];
    if (model.error.empty() && peer.error.empty()) {
        const double rel = std::abs(model.geometry.area - peer.geometry.area) / std::max(peer.geometry.area, 1e-300);
        std::printf("  same geometry as %s: %s (triangles %s, area differs by %.1e relative)\n", label(comparable(r)),
                    model.geometry.triangles == peer.geometry.triangles && rel < 1e-5 ? "yes" : "NO",
                    model.geometry.triangles == peer.geometry.triangles ? "equal" : "differ", rel);
    }
}

void print_summary(const std::vector<FileResult>& results) {
    std::printf(
        "\nSummary: isin::load_model<float> against the comparable assimp run (the one with its vertex count;\n"
        "T+J where neither has it): CPU ms; ratios isin / assimp, those of time medians of the per-round ratios\n");
    std::printf("  %-28s %-10s %9s %9s %9s %9s %8s %8s %9s\n", "file", "assimp", "isin ms", "asmp ms", "CPU ratio",
                "wall rat.", "isin MiB", "asmp MiB", "MiB ratio");
    for (const FileResult& r : results) {
        const Loader peer = comparable(r);
        const std::size_t m = index_of(Loader::isin_model), p = index_of(peer);
        if (!r.first[m].error.empty() || !r.first[p].error.empty()) continue;
        std::printf("  %-28s %-10s %9.1f %9.1f %9s %9s %8s %8s %9s\n",
                    std::filesystem::path(r.file).filename().string().c_str(), label(peer), 1e3 * median(r.cpu[m]),
                    1e3 * median(r.cpu[p]), decimals(round_ratio(r.cpu[m], r.cpu[p])).c_str(),
                    decimals(round_ratio(r.wall[m], r.wall[p])).c_str(), mib(r.peak_mib[m]).c_str(),
                    mib(r.peak_mib[p]).c_str(), decimals(r.peak_mib[m] / r.peak_mib[p]).c_str());
    }
}

} // namespace

int main(int argc, char** argv) {
    int rounds = 5, memory_rounds = 3;
    bool all_testmodels = false;
    std::string data = "build/load_models";
    isin::ModelOptions options;
    options.load_textures = false;
    std::vector<std::string> files;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has_value = i + 1 < argc;
        if (a == "--child" && i + 2 < argc) {
            const auto loader = loader_named(argv[i + 1]);
            const std::string file = argv[i + 2];
            for (int j = i + 3; j < argc; ++j)
                options.load_textures = options.load_textures || argv[j] == std::string("--textures");
            if (!loader) return 2;
            return child_main(*loader, file, options);
        } else if (a == "--rounds" && has_value) {
            rounds = std::max(1, std::atoi(argv[++i]));
        } else if (a == "--memory-rounds" && has_value) {
            memory_rounds = std::max(0, std::atoi(argv[++i]));
        } else if (a == "--data" && has_value) {
            data = argv[++i];
        } else if (a == "--all-testmodels") {
            all_testmodels = true;
        } else if (a == "--textures") {
            options.load_textures = true;
        } else if (!a.empty() && a[0] != '-') {
            files.push_back(a);
        } else {
            std::fprintf(stderr, "usage: load_models [--rounds N] [--memory-rounds N] [--data DIR] [--all-testmodels] "
                                 "[--textures] [FILE…]\n");
            return a == "--help" || a == "-h" ? 0 : 2;
        }
    }
    if (files.empty()) {
        for (const char* name :
             {"dragon_ascii.ply", "dragon_le.ply", "dragon_be.ply", "dragon_vn.obj", "dragon_v.obj"}) {
            const std::string path = data + "/" + name;
            if (std::filesystem::exists(path))
                files.push_back(path);
            else
                std::fprintf(stderr, "load_models: %s is missing (scripts/load_models.sh makes it)\n", path.c_str());
        }
    }
    if (all_testmodels) {
        for (const char* dir : {"/usr/share/assimp/models/OBJ", "/usr/share/assimp/models/PLY"}) {
            std::vector<std::string> found;
            std::error_code ec;
            for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
                std::string ext = entry.path().extension().string();
                std::transform(ext.begin(), ext.end(), ext.begin(),
                               [](unsigned char c) { return char(std::tolower(c)); });
                if (ext == ".obj" || ext == ".ply") found.push_back(entry.path().string());
            }
            if (ec)
                std::fprintf(stderr, "load_models: %s: %s (apt install assimp-testmodels)\n", dir,
                             ec.message().c_str());
            std::sort(found.begin(), found.end());
            files.insert(files.end(), found.begin(), found.end());
        }
    }
    if (files.empty()) return 1;

    std::vector<FileResult> results(files.size());
    for (std::size_t f = 0; f < files.size(); ++f) results[f].file = files[f];

    // Peak memory first, while this process is small (see the top of this file).
    double baseline_mib = no_value;
    if (memory_rounds > 0) {
        std::vector<double> base;
        for (int k = 0; k < memory_rounds; ++k) base.push_back(double(child_peak_kib(Loader::none, files[0], false)));
        baseline_mib = median(base) / 1024;
        for (FileResult& r : results)
            for (std::size_t i = 0; i < loaders.size(); ++i) {
                std::vector<double> peaks;
                for (int k = 0; k < memory_rounds; ++k) {
                    const long kib = child_peak_kib(loaders[i], r.file, options.load_textures);
                    if (kib < 0) break;
                    peaks.push_back(double(kib) / 1024 - baseline_mib);
                }
                if (!peaks.empty()) r.peak_mib[i] = median(peaks);
            }
    }

    // Time: an untimed pass, then interleaved rounds in a rotated order.
    for (FileResult& r : results) {
        for (std::size_t i = 0; i < loaders.size(); ++i) r.first[i] = load(loaders[i], r.file, options);
        for (int round = 0; round < rounds; ++round)
            for (std::size_t k = 0; k < loaders.size(); ++k) {
                const std::size_t i = (k + std::size_t(round)) % loaders.size();
                if (!r.first[i].error.empty()) continue;
                const Run run = load(loaders[i], r.file, options);
                r.wall[i].push_back(run.wall);
                r.cpu[i].push_back(run.cpu);
            }
    }

    std::printf("load_models: %d rounds (medians; the loading call only: wall and CPU time of this thread; spread ="
                " (max − min) / median of CPU time); peak memory = child's ru_maxrss − baseline child's %.1f MiB"
                " (median of %d)\n",
                rounds, baseline_mib, memory_rounds);
    std::printf("T+J = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices, T = aiProcess_Triangulate; "
                "/T+J, /T = isin / assimp (CPU time: median of the per-round ratios; memory);\ntextures %s\n",
                options.load_textures ? "decoded by isin" : "not decoded");
    for (const FileResult& r : results) print_file(r);
    print_summary(results);
    return 0;
}
