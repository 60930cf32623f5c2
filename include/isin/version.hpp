#pragma once
/// isin's version, MAJOR.MINOR.PATCH (semantic versioning; CHANGELOG.md says what each one brings).
/// CMakeLists.txt reads its project version from these three lines, so the two never differ.
#define ISIN_VERSION_MAJOR 0
#define ISIN_VERSION_MINOR 2
#define ISIN_VERSION_PATCH 0
/// The version as one number, MAJOR·10000 + MINOR·100 + PATCH, for `#if ISIN_VERSION >= 200`.
#define ISIN_VERSION (ISIN_VERSION_MAJOR * 10000 + ISIN_VERSION_MINOR * 100 + ISIN_VERSION_PATCH)
#define ISIN_DETAIL_VERSION_TEXT(x) #x
#define ISIN_DETAIL_VERSION_PART(x) ISIN_DETAIL_VERSION_TEXT(x)
/// The version as text, "MAJOR.MINOR.PATCH".
#define ISIN_VERSION_STRING                                                                                            \
    ISIN_DETAIL_VERSION_PART(ISIN_VERSION_MAJOR)                                                                       \
    "." ISIN_DETAIL_VERSION_PART(ISIN_VERSION_MINOR) "." ISIN_DETAIL_VERSION_PART(ISIN_VERSION_PATCH)
