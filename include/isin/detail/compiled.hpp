#pragma once
/// isin — private: what isin::io compiles once. Where ISIN_COMPILED is defined (CMake's isin::io
/// and pkg-config's isin-io set it for their users), the Bvh builder (bvh/build.hpp),
/// StandardScene<float> and <double> (scene.hpp) and their renderer (render.hpp) are explicitly
/// instantiated in isin::io and declared `extern` everywhere else, so that no other file compiles
/// them again. They run as isin::io was compiled (its flags, e.g. -march): give it the program's.
/// Without ISIN_COMPILED every file compiles what it uses, as header-only code does.
///
/// The file that defines ISIN_IMPLEMENTATION compiles all three parts; CMake's isin::io compiles
/// each in a file of its own, so that several cores share them: ISIN_COMPILED_PART 1 (with
/// ISIN_IMPLEMENTATION: the file code and the Bvh builder), 2 (StandardScene<float> and its
/// renderer), 3 (the same for double).
#if !defined(ISIN_COMPILED_PART)
#if defined(ISIN_IMPLEMENTATION)
#define ISIN_DETAIL_COMPILED_BUILDER
#define ISIN_DETAIL_COMPILED_FLOAT
#define ISIN_DETAIL_COMPILED_DOUBLE
#else
#define ISIN_DETAIL_COMPILED_BUILDER extern
#define ISIN_DETAIL_COMPILED_FLOAT extern
#define ISIN_DETAIL_COMPILED_DOUBLE extern
#endif
#else
#if ISIN_COMPILED_PART == 1
#define ISIN_DETAIL_COMPILED_BUILDER
#else
#define ISIN_DETAIL_COMPILED_BUILDER extern
#endif
#if ISIN_COMPILED_PART == 2
#define ISIN_DETAIL_COMPILED_FLOAT
#else
#define ISIN_DETAIL_COMPILED_FLOAT extern
#endif
#if ISIN_COMPILED_PART == 3
#define ISIN_DETAIL_COMPILED_DOUBLE
#else
#define ISIN_DETAIL_COMPILED_DOUBLE extern
#endif
#endif
