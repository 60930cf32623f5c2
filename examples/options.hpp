#pragma once
// Command-line parsing shared by the examples: --width, --height, --output, --threads and a few
// more, with --help; exits with status 2 and a message on a bad option.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace example {

struct Options {
    int width = 800, height = 450, threads = 0, samples = 1;
    std::string output;
    bool help = false;
};

/// Parses argv; `usage` is printed for --help (to stdout, status 0) and on errors (stderr, 2).
inline Options parse(int argc, char** argv, const char* usage, const std::string& default_output) {
    Options o;
    o.output = default_output;
    auto fail = [&](const std::string& why) {
        std::fprintf(stderr, "%s: %s\n%s", argv[0], why.c_str(), usage);
        std::exit(2);
    };
    auto number = [&](int& i, const char* name, int lo, int hi) {
        if (i + 1 >= argc) fail(std::string(name) + " needs a value");
        char* end = nullptr;
        const long v = std::strtol(argv[++i], &end, 10);
        if (*argv[i] == '\0' || *end != '\0' || v < lo || v > hi)
            fail(std::string(name) + " must be an integer in [" + std::to_string(lo) + ", " +
                 std::to_string(hi) + "], got '" + argv[i] + "'");
        return int(v);
    };
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") {
            std::fputs(usage, stdout);
            std::exit(0);
        } else if (a == "--width") o.width = number(i, "--width", 2, 32768);
        else if (a == "--height") o.height = number(i, "--height", 2, 32768);
        else if (a == "--threads") o.threads = number(i, "--threads", 0, 1024);
        else if (a == "--samples") o.samples = number(i, "--samples", 1, 16);
        else if (a == "--output" || a == "-o") {
            if (i + 1 >= argc) fail("--output needs a path");
            o.output = argv[++i];
        } else fail("unknown option '" + a + "'");
    }
    return o;
}

} // namespace example
