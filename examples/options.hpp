#pragma once
// Command-line parsing shared by the examples: option values checked with a clear message and
// exit status 2, and the common --width, --height, --output, --threads, --samples, --help.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

#include <isin/image_io.hpp>

namespace example {

/// Prints "PROGRAM: why" and the usage to stderr and exits with status 2.
[[noreturn]] inline void fail(const char* program, const std::string& why, const char* usage) {
    std::fprintf(stderr, "%s: %s\n%s", program, why.c_str(), usage);
    std::exit(2);
}

/// The value after option argv[i] (i moves onto it); fails if there is none.
inline std::string string_option(int& i, int argc, char** argv, const char* usage) {
    if (i + 1 >= argc) fail(argv[0], std::string(argv[i]) + " needs a value", usage);
    return argv[++i];
}

/// `text` as an integer in [lo, hi]; fails naming the option otherwise.
inline int to_integer(const std::string& text, const std::string& option, int lo, int hi, const char* program,
                      const char* usage) {
    char* end = nullptr;
    const long v = std::strtol(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || v < lo || v > hi)
        fail(program, option + " must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                          "], got '" + text + "'",
             usage);
    return int(v);
}

/// The integer in [lo, hi] after option argv[i] (i moves onto it); fails otherwise.
inline int integer_option(int& i, int argc, char** argv, int lo, int hi, const char* usage) {
    const std::string option = argv[i];
    return to_integer(string_option(i, argc, argv, usage), option, lo, hi, argv[0], usage);
}

/// Fails (status 2) at once if a width × height image cannot be written to `path` (unknown
/// extension, too large for the PNG encoder), rather than after the rendering.
inline void check_output(const char* program, const std::string& path, int width, int height, const char* usage) {
    try {
        isin::check_image_output(path, width, height);
    } catch (const std::invalid_argument& e) {
        fail(program, e.what(), usage);
    }
}

struct Options {
    int width = 800, height = 450, threads = 0, samples = 1;
    std::string output;
};

/// Parses --width, --height, --threads, --samples, --output and --help; `usage` is printed for
/// --help (to stdout, status 0) and on errors (stderr, status 2). The output must take an image
/// `width_factor`·width × height (check_output).
inline Options parse(int argc, char** argv, const char* usage, const std::string& default_output,
                     int width_factor = 1) {
    Options o;
    o.output = default_output;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") {
            std::fputs(usage, stdout);
            std::exit(0);
        } else if (a == "--width") o.width = integer_option(i, argc, argv, 2, 32768, usage);
        else if (a == "--height") o.height = integer_option(i, argc, argv, 2, 32768, usage);
        else if (a == "--threads") o.threads = integer_option(i, argc, argv, 0, 1024, usage);
        else if (a == "--samples") o.samples = integer_option(i, argc, argv, 1, 16, usage);
        else if (a == "--output" || a == "-o") o.output = string_option(i, argc, argv, usage);
        else fail(argv[0], "unknown option '" + a + "'", usage);
    }
    check_output(argv[0], o.output, width_factor * o.width, o.height, usage);
    return o;
}

} // namespace example
