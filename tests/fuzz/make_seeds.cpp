// Writes the seed corpora of isin's fuzz targets (scripts/fuzz.sh): valid files of every form the
// readers take, small, so that libFuzzer starts from deep inside each format.
//   make_seeds DIR   →   DIR/image (PNG of every colour type and depth, interlaced or not, JPEG,
//                        PPM), DIR/ply (ASCII and binary, every property type), DIR/obj (one a model
//                        with its .mtl and texture, for fuzz_obj), DIR/bvh (saved Bvhs, float and double)
#include <isin/bvh/serialize.hpp>
#include <isin/image_io.hpp>
#include <isin/io/image_impl.hpp> // the file code, and stb, compiled here

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace {

using Bytes = std::vector<unsigned char>;
std::mt19937 rng(12345);

void save(const std::filesystem::path& path, const Bytes& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}
void save(const std::filesystem::path& path, const std::string& text) { save(path, Bytes(text.begin(), text.end())); }

std::uint32_t crc32(const unsigned char* p, std::size_t n) {
    std::uint32_t c = 0xffffffffu;
    for (std::size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
}

void put32(Bytes& b, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<unsigned char>(v >> s));
}

void chunk(Bytes& png, const char* type, const Bytes& data) {
    put32(png, std::uint32_t(data.size()));
    const std::size_t start = png.size();
    png.insert(png.end(), type, type + 4);
    png.insert(png.end(), data.begin(), data.end());
    put32(png, crc32(png.data() + start, png.size() - start));
}

/// A PNG of random pixels: any colour type and bit depth, Adam7 interlaced or not, rows with
/// each filter type in turn.
Bytes png(int w, int h, int colour, int depth, bool interlaced) {
    const int channels = colour == 2 ? 3 : colour == 4 ? 2 : colour == 6 ? 4 : 1;
    Bytes raw;
    const auto rows = [&](int pw, int ph) {
        if (pw <= 0 || ph <= 0) return;
        const int row_bytes = (pw * channels * depth + 7) / 8;
        for (int y = 0; y < ph; ++y) {
            raw.push_back(static_cast<unsigned char>(y % 5)); // filter
            for (int i = 0; i < row_bytes; ++i) raw.push_back(static_cast<unsigned char>(rng()));
        }
    };
    if (!interlaced) {
        rows(w, h);
    } else {
        const int x0[7] = {0, 4, 0, 2, 0, 1, 0}, y0[7] = {0, 0, 4, 0, 2, 0, 1};
        const int dx[7] = {8, 8, 4, 4, 2, 2, 1}, dy[7] = {8, 8, 8, 4, 4, 2, 2};
        for (int p = 0; p < 7; ++p) rows((w - x0[p] + dx[p] - 1) / dx[p], (h - y0[p] + dy[p] - 1) / dy[p]);
    }
    int compressed_size = 0;
    unsigned char* z = stbi_zlib_compress(raw.data(), int(raw.size()), &compressed_size, 8);
    Bytes out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    Bytes ihdr;
    put32(ihdr, std::uint32_t(w)), put32(ihdr, std::uint32_t(h));
    ihdr.insert(ihdr.end(), {static_cast<unsigned char>(depth), static_cast<unsigned char>(colour), 0, 0,
                             static_cast<unsigned char>(interlaced)});
    chunk(out, "IHDR", ihdr);
    if (colour == 3) {
        Bytes palette(3 * (std::size_t(1) << depth));
        for (auto& b : palette) b = static_cast<unsigned char>(rng());
        chunk(out, "PLTE", palette);
        chunk(out, "tRNS", Bytes{128}); // one alpha value: fits the smallest palette (2 entries)
    }
    chunk(out, "tEXt", Bytes{'k', 0, 'v'});
    const std::size_t half = std::size_t(compressed_size) / 2; // two IDAT chunks
    chunk(out, "IDAT", Bytes(z, z + half));
    chunk(out, "IDAT", Bytes(z + half, z + compressed_size));
    chunk(out, "IEND", {});
    STBIW_FREE(z);
    return out;
}

Bytes jpeg(int w, int h, int channels, int quality) {
    Bytes pixels(std::size_t(w) * std::size_t(h) * std::size_t(channels));
    for (std::size_t i = 0; i < pixels.size(); ++i)
        pixels[i] = static_cast<unsigned char>((i * 7 + (i / 13) * 31) % 256);
    Bytes out;
    stbi_write_jpg_to_func(
        [](void* context, void* data, int size) {
            auto* o = static_cast<Bytes*>(context);
            const auto* p = static_cast<const unsigned char*>(data);
            o->insert(o->end(), p, p + size);
        },
        &out, w, h, channels, pixels.data(), quality);
    return out;
}

template <class V>
void put_le(std::string& s, V v) {
    unsigned char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    s.append(reinterpret_cast<const char*>(b), sizeof v);
}

template <class T>
void save_bvhs(const std::filesystem::path& dir, const std::string& precision) {
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    const auto soup = [&](int n, double size) {
        std::vector<isin::Triangle<T>> tris;
        for (int i = 0; i < n; ++i) {
            const double c[3] = {uni(rng) * 4, uni(rng) * 4, uni(rng) * 4};
            const auto p = [&] {
                return isin::Vertex<T>{T(c[0] + size * uni(rng)), T(c[1] + size * uni(rng)), T(c[2] + size * uni(rng))};
            };
            tris.push_back({p(), p(), p()});
        }
        return tris;
    };
    isin::BvhOptions small_leaves;
    small_leaves.leaf_size = 1;
    isin::Bvh<T>(soup(0, 1)).save((dir / (precision + "-empty.bvh")).string());
    isin::Bvh<T>(soup(1, 1)).save((dir / (precision + "-one.bvh")).string());
    isin::Bvh<T>(soup(12, 0.5)).save((dir / (precision + "-few.bvh")).string());
    isin::Bvh<T>(soup(20, 0.3), small_leaves).save((dir / (precision + "-deep.bvh")).string());
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_seeds DIR\n");
        return 2;
    }
    const std::filesystem::path dir = argv[1];
    for (const char* sub : {"image", "ply", "obj", "bvh"}) std::filesystem::create_directories(dir / sub);

    // Images: PNG of every colour type × allowed depth, plain and interlaced; JPEG; PPM.
    const struct {
        int colour, depths[5];
    } types[] = {{0, {1, 2, 4, 8, 16}}, {2, {8, 16}}, {3, {1, 2, 4, 8}}, {4, {8, 16}}, {6, {8, 16}}};
    int n = 0;
    for (const auto& t : types)
        for (int depth : t.depths) {
            if (depth == 0) continue;
            for (bool interlaced : {false, true}) {
                save(dir / "image" / ("png" + std::to_string(n) + ".png"),
                     png(5 + n % 7, 3 + n % 5, t.colour, depth, interlaced));
                ++n;
            }
        }
    for (int channels : {1, 3})
        for (int quality : {10, 60, 95})
            save(dir / "image" / ("jpeg" + std::to_string(channels) + "-" + std::to_string(quality) + ".jpg"),
                 jpeg(17, 9, channels, quality));
    save(dir / "image" / "small.ppm", std::string("P6\n# a comment\n2 2\n255\n") + std::string(12, '\x7f'));
    save(dir / "image" / "deep.ppm", std::string("P6 1 2 65535\n") + std::string(12, '\x10'));

    // PLY: ASCII and binary little-endian; every property type; lists; other elements.
    const std::string ply_header = "ply\nformat ascii 1.0\ncomment seed\nobj_info x\nelement vertex 4\n"
                                   "property float x\nproperty double y\nproperty int z\nproperty uchar red\n"
                                   "element face 2\nproperty list uchar int vertex_indices\n"
                                   "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
    save(dir / "ply" / "ascii.ply", ply_header + "0 0 0 1\n1 0 0 2\n0 1 0 3\n1 1 1e-3 4\n3 0 1 2\n4 0 1 3 2\n0 1\n");
    std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nproperty short nx\nelement face 1\nproperty list ushort uint vertex_index\n"
                      "property list uchar float texcoord\nend_header\n";
    const float xyz[3][3] = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
    for (const auto& v : xyz) put_le(bin, v[0]), put_le(bin, v[1]), put_le(bin, v[2]), put_le(bin, std::int16_t(-7));
    put_le(bin, std::uint16_t(3));
    for (std::uint32_t i : {0u, 1u, 2u}) put_le(bin, i);
    put_le(bin, std::uint8_t(2)), put_le(bin, 0.5f), put_le(bin, 0.25f);
    save(dir / "ply" / "binary.ply", bin);
    std::string types_ply =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty char a\nproperty uchar b\n"
        "property int16 c\nproperty uint16 d\nproperty int32 e\nproperty uint32 f\nproperty float64 x\n"
        "property float32 y\nproperty double z\nelement face 1\nproperty list uint8 int32 vertex_indices\nend_header\n";
    for (int v = 0; v < 3; ++v) {
        put_le(types_ply, std::int8_t(-1)), put_le(types_ply, std::uint8_t(1)), put_le(types_ply, std::int16_t(-2));
        put_le(types_ply, std::uint16_t(2)), put_le(types_ply, std::int32_t(-3)), put_le(types_ply, std::uint32_t(3));
        put_le(types_ply, double(v == 1)), put_le(types_ply, float(v == 2)), put_le(types_ply, 0.0);
    }
    put_le(types_ply, std::uint8_t(3));
    for (std::int32_t i : {0, 1, 2}) put_le(types_ply, i);
    save(dir / "ply" / "types.ply", types_ply);
    save(dir / "ply" / "big_endian.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 0\nproperty float x\n"
                                         "property float y\nproperty float z\nend_header\n");

    // OBJ: polygons, every reference form, negative and forward indices, groups, materials.
    save(dir / "obj" / "cube.obj", "# cube\nmtllib cube.mtl\no cube\nv -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n"
                                   "v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 -1\n"
                                   "g front\nusemtl red\nf 1/1/1 4/2/1 3/3/1 2/1/1\nf 5//1 6//1 7//1 8//1\ns off\n"
                                   "g back\nf 1/1 2/2 6/3 5/1\nf -1 -2 -3\nf 4 8 7 3\n");
    save(dir / "obj" / "numbers.obj", "v 1.5e+3 -2.25E-2 .5\r\nv 0e500 1e-400 +3.\r\nv 1 2 3 1\r\nf 1 2 3\r\n");
    { // a model in three parts (fuzz_obj writes them as files): OBJ, its .mtl, a texture
        const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\ng a\nusemtl m\nf 1/1 2/2 3/3\n"
                                 "\n%%\nnewmtl m\nKd 1 0.5 0\nmap_Kd ./tex.png\nnewmtl n\nmap_Kd .//tex.png\n\n%%\n";
        Bytes model(text.begin(), text.end());
        const Bytes texture = png(3, 2, 2, 8, false);
        model.insert(model.end(), texture.begin(), texture.end());
        save(dir / "obj" / "model.obj", model);
    }
    save(dir / "obj" / "forward.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 3\nvp 0.5 0.5\n");

    // Bvh files (Bvh::save): empty, one triangle, a few leaves, and a tree of several levels.
    save_bvhs<float>(dir / "bvh", "float");
    save_bvhs<double>(dir / "bvh", "double");
    std::printf("seeds written to %s\n", dir.string().c_str());
    return 0;
}
