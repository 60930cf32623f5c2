#pragma once
/// isin — private: what isin::io compiles once. Where ISIN_COMPILED is defined (CMake's isin::io
/// and pkg-config's isin-io set it for their users), the Bvh builder (bvh/build.hpp),
/// StandardScene<float> and <double> (scene.hpp) and their renderer (render.hpp) are explicitly
/// instantiated in the one file that also defines ISIN_IMPLEMENTATION (isin::io's) and declared
/// `extern` everywhere else, so that no other file compiles them again. They run as isin::io was
/// compiled (its flags, e.g. -march): give it the program's. Without ISIN_COMPILED every file
/// compiles what it uses, as header-only code does.
#if defined(ISIN_IMPLEMENTATION)
#define ISIN_DETAIL_COMPILED_HERE
#else
#define ISIN_DETAIL_COMPILED_HERE extern
#endif
