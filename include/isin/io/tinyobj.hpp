#pragma once
/// isin — private: brings in tinyobjloader (it reads the .mtl files of OBJ models) for isin/mesh.hpp.
///
/// tinyobjloader is not copied into isin; this header only includes the system's copy
/// (Debian/Ubuntu: `apt install libtinyobjloader-dev`, header /usr/include/tiny_obj_loader.h).
/// Only the implementation of mesh.hpp includes it (ISIN_IMPLEMENTATION or isin::io). Without the
/// header that is a compile-time error naming the package, unless ISIN_HAVE_TINYOBJLOADER is
/// defined to 0: then PLY works and isin::load_obj throws std::runtime_error saying so.
///
/// Linkage, so that a header-only library cannot clash with anybody's tinyobjloader:
///  - Normally isin compiles tinyobjloader's implementation into its implementation's translation unit inside
///    `isin::detail::<anonymous namespace>`: every symbol has internal linkage, so nothing
///    clashes at link time with another translation unit, with a user's own copy of the
///    implementation, or with the system's libtinyobjloader.so. This private copy stores reals
///    as double (TINYOBJLOADER_USE_DOUBLE) and never triangulates with earcut.
///    Afterwards TINY_OBJ_LOADER_H_ is undefined again and every macro tinyobjloader or isin
///    set (TINYOBJLOADER_IMPLEMENTATION, TINYOBJLOADER_USE_DOUBLE, TINYOBJ_OVERRIDE, IS_SPACE,
///    IS_DIGIT, IS_NEW_LINE, ...) is put back as it was, so a translation unit may still
///    include <tiny_obj_loader.h> itself later, with or without TINYOBJLOADER_IMPLEMENTATION.
///  - If a translation unit included <tiny_obj_loader.h> itself *before* any isin header
///    (TINY_OBJ_LOADER_H_ is defined), isin uses that ::tinyobj as it is and compiles no second
///    copy; the user then provides the implementation as usual (one .cpp with
///    TINYOBJLOADER_IMPLEMENTATION, or linking libtinyobjloader), and isin parses with it
///    (with its real_t: float unless TINYOBJLOADER_USE_DOUBLE was defined there).
///  - Define ISIN_HAVE_TINYOBJLOADER to 0 before including isin to build without it; define it
///    the same way in every translation unit.
/// Either way, isin reaches the parser as `isin::detail::tobj`.

#if defined(__GNUC__) || defined(__clang__)
#pragma GCC system_header // tinyobjloader's code is not ours: no warnings from it under -Werror
#elif defined(_MSC_VER)
#pragma warning(push, 0)
#endif

// Which tinyobjloader, if any.
#if defined(TINY_OBJ_LOADER_H_)
#define ISIN_DETAIL_TINYOBJ 1 // already included by the user: use theirs
#elif defined(__has_include)
#if __has_include(<tiny_obj_loader.h>)
#define ISIN_DETAIL_TINYOBJ 2 // the system's copy: compile a private one
#else
#define ISIN_DETAIL_TINYOBJ 0
#endif
#else
#define ISIN_DETAIL_TINYOBJ 0
#endif

#ifndef ISIN_HAVE_TINYOBJLOADER
#if ISIN_DETAIL_TINYOBJ != 0
#define ISIN_HAVE_TINYOBJLOADER 1
#else
#error                                                                                                                 \
    "isin: OBJ files need tinyobjloader: install Debian/Ubuntu's libtinyobjloader-dev (tiny_obj_loader.h), or define ISIN_HAVE_TINYOBJLOADER to 0 to build with PLY files only"
#endif
#endif
#if ISIN_HAVE_TINYOBJLOADER && ISIN_DETAIL_TINYOBJ == 2

// Every standard header tiny_obj_loader.h includes (or relies on) comes first, at global scope:
// their include guards then make tinyobjloader's own #includes no-ops inside the namespace below.
#include <algorithm>
#include <array>
#include <cassert>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <istream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#pragma push_macro("TINYOBJLOADER_IMPLEMENTATION")
#pragma push_macro("TINYOBJLOADER_USE_DOUBLE")
#pragma push_macro("TINYOBJLOADER_USE_MAPBOX_EARCUT")
#pragma push_macro("TINYOBJLOADER_DONOT_INCLUDE_MAPBOX_EARCUT")
#pragma push_macro("TINY_OBJ_LOADER_PYTHON_BINDING")
#pragma push_macro("TINYOBJ_OVERRIDE")
#pragma push_macro("IS_SPACE")
#pragma push_macro("IS_DIGIT")
#pragma push_macro("IS_NEW_LINE")
#undef TINYOBJLOADER_USE_MAPBOX_EARCUT // earcut would #include mapbox/earcut.hpp in our namespace
#undef TINYOBJLOADER_DONOT_INCLUDE_MAPBOX_EARCUT
#undef TINY_OBJ_LOADER_PYTHON_BINDING
#undef TINYOBJ_OVERRIDE
#undef IS_SPACE
#undef IS_DIGIT
#undef IS_NEW_LINE
#undef TINYOBJLOADER_IMPLEMENTATION
#define TINYOBJLOADER_IMPLEMENTATION
#undef TINYOBJLOADER_USE_DOUBLE
#define TINYOBJLOADER_USE_DOUBLE

namespace isin {
namespace detail {
namespace { // internal linkage: each translation unit gets its own private copy
#include <tiny_obj_loader.h>
} // namespace
namespace tobj = ::isin::detail::tinyobj;
} // namespace detail
} // namespace isin

#undef TINY_OBJ_LOADER_H_ // a later #include <tiny_obj_loader.h> declares ::tinyobj as usual
#pragma pop_macro("IS_NEW_LINE")
#pragma pop_macro("IS_DIGIT")
#pragma pop_macro("IS_SPACE")
#pragma pop_macro("TINYOBJ_OVERRIDE")
#pragma pop_macro("TINY_OBJ_LOADER_PYTHON_BINDING")
#pragma pop_macro("TINYOBJLOADER_DONOT_INCLUDE_MAPBOX_EARCUT")
#pragma pop_macro("TINYOBJLOADER_USE_MAPBOX_EARCUT")
#pragma pop_macro("TINYOBJLOADER_USE_DOUBLE")
#pragma pop_macro("TINYOBJLOADER_IMPLEMENTATION")

#elif ISIN_HAVE_TINYOBJLOADER && ISIN_DETAIL_TINYOBJ == 1

namespace isin {
namespace detail {
namespace tobj = ::tinyobj;
} // namespace detail
} // namespace isin

#endif

#undef ISIN_DETAIL_TINYOBJ

#if !defined(__GNUC__) && !defined(__clang__) && defined(_MSC_VER)
#pragma warning(pop)
#endif
