#include <isin/isin.hpp>

#include <doctest/doctest.h>

#include <string>

TEST_CASE("the version macros are CMake's project version") {
    CHECK(std::string(ISIN_VERSION_STRING) == ISIN_TEST_PROJECT_VERSION);
    const std::string parts = std::to_string(ISIN_VERSION_MAJOR) + "." + std::to_string(ISIN_VERSION_MINOR) + "." +
                              std::to_string(ISIN_VERSION_PATCH);
    CHECK(parts == ISIN_TEST_PROJECT_VERSION);
    CHECK(ISIN_VERSION == ISIN_VERSION_MAJOR * 10000 + ISIN_VERSION_MINOR * 100 + ISIN_VERSION_PATCH);
}
