// Stacks bands of rows rendered apart (--tile I/N of notes_scene, mesh_view, walk --script) into
// one image, the first band on top: bit for bit the picture a single render makes. Refuses tiles
// of different widths, and tiles whose heights are not those of bands 0, 1, ... of N in turn.
// Build: c++ -std=c++17 -O2 -DISIN_IMPLEMENTATION -I include examples/merge_tiles.cpp -o merge_tiles
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include <isin/image.hpp>
#include <isin/image_io.hpp>
#include <isin/isin.hpp> // with ISIN_IMPLEMENTATION: the file code too
#include <isin/render.hpp>

#include "options.hpp"

int main(int argc, char** argv) {
    const char* usage = "usage: merge_tiles OUTPUT TILE_0 TILE_1 ... [--height H]\n"
                        "Writes the tiles (PNG or PPM bands of rows of equal width, band 0 first, as --tile 0/N,\n"
                        "1/N, ... wrote them) one above the other to OUTPUT (.png or .ppm). With --height H it\n"
                        "fails unless the bands add up to H rows (a missing or repeated band). Fails when the\n"
                        "tiles differ in width, or when tile K is not as tall as band K of N of the whole\n"
                        "(isin::row_band): tiles out of order or from another render. Bands of equal height\n"
                        "(a height that N divides) cannot be told apart by size: give them in order.\n";
    std::vector<std::string> paths;
    int expected_height = 0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") {
            std::fputs(usage, stdout);
            return 0;
        } else if (a == "--height")
            expected_height = example::integer_option(i, argc, argv, 1, 32768, usage);
        else if (a.size() > 1 && a[0] == '-')
            example::fail(argv[0], "unknown option '" + a + "'", usage);
        else
            paths.push_back(a);
    }
    if (paths.size() < 2) example::fail(argv[0], "needs an output and at least one tile", usage);
    try {
        std::vector<isin::Image> bands;
        int rows = 0;
        for (std::size_t k = 1; k < paths.size(); ++k) {
            bands.push_back(isin::read_image(paths[k]));
            const isin::Image& band = bands.back();
            if (band.width() != bands[0].width())
                throw std::runtime_error("tile " + std::to_string(k - 1) + " (" + paths[k] + ") is " +
                                         std::to_string(band.width()) + " pixels wide, tile 0 (" + paths[1] + ") " +
                                         std::to_string(bands[0].width()) + ": not from the same render");
            rows += band.height();
        }
        const int count = int(bands.size());
        if (count > rows)
            throw std::runtime_error(std::to_string(count) + " tiles of " + std::to_string(rows) +
                                     " rows in all: not bands of one render");
        for (int k = 0; k < count; ++k) {
            const int expected = isin::row_band(rows, k, count).rows; // what --tile k/count wrote
            const isin::Image& band = bands[std::size_t(k)];
            if (band.height() != expected)
                throw std::runtime_error("tile " + std::to_string(k) + " (" + paths[std::size_t(k) + 1] + ") has " +
                                         std::to_string(band.height()) + " rows, but band " + std::to_string(k) +
                                         " of " + std::to_string(count) + " of a " + std::to_string(rows) +
                                         "-row image has " + std::to_string(expected) +
                                         ": tiles out of order, missing or from another render");
        }
        const isin::Image image = isin::stack_rows(bands);
        if (expected_height != 0 && image.height() != expected_height)
            throw std::runtime_error("the tiles have " + std::to_string(image.height()) + " rows, not " +
                                     std::to_string(expected_height));
        isin::check_image_output(paths[0], image.width(), image.height());
        isin::write_image(image, paths[0]);
        std::printf("%s: %d×%d from %zu tiles\n", paths[0].c_str(), image.width(), image.height(), bands.size());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "merge_tiles: %s\n", e.what());
        return 1;
    }
    return 0;
}
