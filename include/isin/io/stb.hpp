#pragma once
/// isin — private: brings in stb_image (PNG/JPEG decoding) and stb_image_write (PNG encoding).
///
/// stb is not copied into isin; this header only includes the system's copy (Debian/Ubuntu:
/// `apt install libstb-dev`, headers in /usr/include/stb/; other layouts: <stb_image.h> on the
/// include path). Only the implementation of image_io.hpp includes it (ISIN_IMPLEMENTATION or
/// isin::io). Without the headers that is a compile-time error naming the package, unless
/// ISIN_HAVE_STB is defined to 0: then PPM works and the PNG/JPEG functions throw
/// std::runtime_error saying isin was built without stb.
///
/// Linkage, so that a header-only library cannot clash with anybody's stb:
///  - Normally isin compiles stb's implementation into its implementation's translation unit as `static`
///    functions (STB_IMAGE_STATIC, STB_IMAGE_WRITE_STATIC), reduced to what isin needs
///    (STBI_ONLY_PNG, STBI_ONLY_JPEG, STBI_NO_STDIO, STBI_WRITE_NO_STDIO: isin does its own file
///    I/O). No external symbol is defined, so nothing clashes with a user's stb at link time.
///  - If a translation unit included <stb_image.h> or <stb_image_write.h> itself *before* any isin
///    header, isin uses those declarations as they are and compiles no second copy; the user then
///    links an implementation as usual (one .cpp with STB_IMAGE_IMPLEMENTATION), and isin reads
///    and writes through it (including any STBI_NO_PNG or flip-on-load settings made there).
///  - A translation unit that compiles stb's implementation itself (defines
///    STB_IMAGE_IMPLEMENTATION / STB_IMAGE_WRITE_IMPLEMENTATION) must include stb before isin:
///    stb's implementation section has no include guard, so a second copy after isin's would
///    be a redefinition.
///  - Define ISIN_HAVE_STB to 0 before including isin to build without stb; define it the same
///    way in every translation unit.
/// Every macro isin defines for stb's configuration is removed again afterwards.

#if defined(__GNUC__) || defined(__clang__)
#pragma GCC system_header // stb's code is not ours: no warnings from it under -Wall -Werror
#elif defined(_MSC_VER)
#pragma warning(push, 0)
#endif

// Which stb header can be included, and how.
#if defined(STBI_INCLUDE_STB_IMAGE_H)
#define ISIN_DETAIL_STB_IMAGE 1 // already included by the user: use theirs
#elif __has_include(<stb/stb_image.h>)
#define ISIN_DETAIL_STB_IMAGE 2 // Debian layout
#elif __has_include(<stb_image.h>)
#define ISIN_DETAIL_STB_IMAGE 3 // upstream layout
#else
#define ISIN_DETAIL_STB_IMAGE 0
#endif

#if defined(INCLUDE_STB_IMAGE_WRITE_H)
#define ISIN_DETAIL_STB_IMAGE_WRITE 1
#elif __has_include(<stb/stb_image_write.h>)
#define ISIN_DETAIL_STB_IMAGE_WRITE 2
#elif __has_include(<stb_image_write.h>)
#define ISIN_DETAIL_STB_IMAGE_WRITE 3
#else
#define ISIN_DETAIL_STB_IMAGE_WRITE 0
#endif

#ifndef ISIN_HAVE_STB
#if ISIN_DETAIL_STB_IMAGE != 0 && ISIN_DETAIL_STB_IMAGE_WRITE != 0
#define ISIN_HAVE_STB 1
#else
#error                                                                                                                 \
    "isin: PNG and JPEG files need the stb headers: install Debian/Ubuntu's libstb-dev (stb_image.h, stb_image_write.h), or define ISIN_HAVE_STB to 0 to build with PPM files only"
#endif
#endif

#if ISIN_HAVE_STB

// ---- stb_image: decoding, PNG and JPEG only, from memory, static linkage ------------------------
#if ISIN_DETAIL_STB_IMAGE >= 2
#pragma push_macro("STBIDEF")
#undef STBIDEF
#define STBIDEF static
#ifndef STB_IMAGE_STATIC
#define STB_IMAGE_STATIC
#define ISIN_DETAIL_UNDEF_STB_IMAGE_STATIC
#endif
#ifndef STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_IMPLEMENTATION
#define ISIN_DETAIL_UNDEF_STB_IMAGE_IMPLEMENTATION
#endif
#ifndef STBI_NO_STDIO
#define STBI_NO_STDIO
#define ISIN_DETAIL_UNDEF_STBI_NO_STDIO
#endif
#ifndef STBI_MAX_DIMENSIONS
#define STBI_MAX_DIMENSIONS (1 << 15) // isin::Image::max_side
#define ISIN_DETAIL_UNDEF_STBI_MAX_DIMENSIONS
#endif
#if !defined(STBI_ONLY_PNG) && !defined(STBI_ONLY_JPEG)
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define ISIN_DETAIL_UNDEF_STBI_ONLY
#endif
// Zeroed allocations: stb 2.27 reads decoder state it never wrote (tables a corrupt JPEG does
// not define); isin's checks refuse such files, and zeroed memory makes anything they miss
// deterministic instead of a read of old heap contents.
#if !defined(STBI_MALLOC) && !defined(STBI_REALLOC) && !defined(STBI_REALLOC_SIZED) && !defined(STBI_FREE)
#define STBI_MALLOC(size) calloc(1, size)
#define STBI_REALLOC(p, size) realloc(p, size)
#define STBI_FREE(p) free(p)
#define ISIN_DETAIL_UNDEF_STBI_ALLOC
#endif

#if ISIN_DETAIL_STB_IMAGE == 2
#include <stb/stb_image.h>
#else
#include <stb_image.h>
#endif

#ifdef ISIN_DETAIL_UNDEF_STB_IMAGE_STATIC
#undef STB_IMAGE_STATIC
#undef ISIN_DETAIL_UNDEF_STB_IMAGE_STATIC
#endif
#ifdef ISIN_DETAIL_UNDEF_STB_IMAGE_IMPLEMENTATION
#undef STB_IMAGE_IMPLEMENTATION
#undef ISIN_DETAIL_UNDEF_STB_IMAGE_IMPLEMENTATION
#endif
#ifdef ISIN_DETAIL_UNDEF_STBI_NO_STDIO
#undef STBI_NO_STDIO
#undef ISIN_DETAIL_UNDEF_STBI_NO_STDIO
#endif
#ifdef ISIN_DETAIL_UNDEF_STBI_MAX_DIMENSIONS
#undef STBI_MAX_DIMENSIONS
#undef ISIN_DETAIL_UNDEF_STBI_MAX_DIMENSIONS
#endif
#ifdef ISIN_DETAIL_UNDEF_STBI_ONLY
#undef STBI_ONLY_PNG
#undef STBI_ONLY_JPEG
#undef ISIN_DETAIL_UNDEF_STBI_ONLY
#endif
#ifdef ISIN_DETAIL_UNDEF_STBI_ALLOC
#undef STBI_MALLOC
#undef STBI_REALLOC
#undef STBI_FREE
#undef ISIN_DETAIL_UNDEF_STBI_ALLOC
#endif
#pragma pop_macro("STBIDEF")
#endif // ISIN_DETAIL_STB_IMAGE >= 2

// ---- stb_image_write: PNG encoding to memory, static linkage -------------------------------------
#if ISIN_DETAIL_STB_IMAGE_WRITE >= 2
#pragma push_macro("STBIWDEF")
#undef STBIWDEF
#define STBIWDEF static
#ifndef STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_STATIC
#define ISIN_DETAIL_UNDEF_STB_IMAGE_WRITE_STATIC
#endif
#ifndef STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define ISIN_DETAIL_UNDEF_STB_IMAGE_WRITE_IMPLEMENTATION
#endif
#ifndef STBI_WRITE_NO_STDIO
#define STBI_WRITE_NO_STDIO
#define ISIN_DETAIL_UNDEF_STBI_WRITE_NO_STDIO
#endif

#if ISIN_DETAIL_STB_IMAGE_WRITE == 2
#include <stb/stb_image_write.h>
#else
#include <stb_image_write.h>
#endif

#ifdef ISIN_DETAIL_UNDEF_STB_IMAGE_WRITE_STATIC
#undef STB_IMAGE_WRITE_STATIC
#undef ISIN_DETAIL_UNDEF_STB_IMAGE_WRITE_STATIC
#endif
#ifdef ISIN_DETAIL_UNDEF_STB_IMAGE_WRITE_IMPLEMENTATION
#undef STB_IMAGE_WRITE_IMPLEMENTATION
#undef ISIN_DETAIL_UNDEF_STB_IMAGE_WRITE_IMPLEMENTATION
#endif
#ifdef ISIN_DETAIL_UNDEF_STBI_WRITE_NO_STDIO
#undef STBI_WRITE_NO_STDIO
#undef ISIN_DETAIL_UNDEF_STBI_WRITE_NO_STDIO
#endif
#pragma pop_macro("STBIWDEF")
#endif // ISIN_DETAIL_STB_IMAGE_WRITE >= 2

#endif // ISIN_HAVE_STB

#undef ISIN_DETAIL_STB_IMAGE
#undef ISIN_DETAIL_STB_IMAGE_WRITE

#if !defined(__GNUC__) && !defined(__clang__) && defined(_MSC_VER)
#pragma warning(pop)
#endif
