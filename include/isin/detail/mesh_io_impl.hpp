#pragma once
/// isin — private: the code of mesh.hpp, compiled where ISIN_IMPLEMENTATION is defined (one
/// translation unit of a program, or CMake's isin::io), for T = float and double.
#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <istream>
#include <limits>
#include <locale>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "../mesh.hpp"
#include "../read_limits.hpp"
#include "../triangle.hpp"
#include "../vec.hpp"
#include "file.hpp"
#include "tinyobj.hpp"

#if !defined(ISIN_DETAIL_FLOAT_FROM_CHARS)
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
#define ISIN_DETAIL_FLOAT_FROM_CHARS 1 // std::from_chars for double: exact and locale-free
#else
#define ISIN_DETAIL_FLOAT_FROM_CHARS 0 // e.g. older libc++: a classic-locale stream instead
#endif
#endif

namespace isin {

namespace detail {

[[nodiscard]] inline MeshError mesh_error(const char* who, const std::string& path, const std::string& why) {
    return MeshError(std::string(who) + ": '" + path + "': " + why);
}

/// The whole file, read once (regular files up to limits.max_file_bytes); its size bounds
/// everything the loaders allocate.
[[nodiscard]] inline std::string mesh_read_file(const char* who, const std::string& path, const ReadLimits& limits) {
    std::string bytes;
    const std::string why = read_whole_file(path, bytes, limits);
    if (!why.empty()) throw mesh_error(who, path, why);
    return bytes;
}

/// Text of a token for a message: at most 40 characters, unprintable bytes as '?'.
[[nodiscard]] inline std::string mesh_quote(const char* b, const char* e) {
    std::string s = "'";
    for (const char* p = b; p != e && s.size() <= 40; ++p) s += (*p >= 32 && *p < 127) ? *p : '?';
    if (e - b > 40) s += "...";
    return s + "'";
}

/// A number for a message: 9 significant digits, '.' as the decimal point.
[[nodiscard]] inline std::string mesh_number(double v) {
    std::ostringstream out;
    out.imbue(std::locale::classic());
    out.precision(9);
    out << v;
    return out.str();
}

template <class T>
[[nodiscard]] constexpr const char* mesh_type_name() noexcept {
    if constexpr (std::is_same_v<T, float>)
        return "float";
    else if constexpr (std::is_same_v<T, double>)
        return "double";
    else
        return "long double";
}

/// True when the finite `v` is representable in T (converting anything larger is undefined).
template <class T>
[[nodiscard]] inline bool mesh_fits(double v) noexcept {
    if constexpr (std::numeric_limits<T>::max_exponent >= std::numeric_limits<double>::max_exponent)
        return std::isfinite(v);
    else
        return std::isfinite(v) && std::fabs(v) <= static_cast<double>(std::numeric_limits<T>::max());
}

/// "nan", "inf", "infinity" with optional sign and "nan(…)" payload, in any letter case.
/// 1 for NaN, 2 for infinity, 0 otherwise.
[[nodiscard]] inline int mesh_special_word(const char* b, const char* e) noexcept {
    if (b != e && (*b == '+' || *b == '-')) ++b;
    const auto is = [&](const char* word) {
        const std::size_t n = std::strlen(word);
        if (static_cast<std::size_t>(e - b) < n) return false;
        for (std::size_t i = 0; i < n; ++i)
            if ((b[i] | 0x20) != word[i]) return false;
        return true;
    };
    if (is("nan")) return 1;
    if (is("inf")) return 2;
    return 0;
}

/// Strict decimal grammar: [+-] (d+ [. d*] | . d+) [(e|E) [+-] d+], the whole of [b, e).
[[nodiscard]] inline bool mesh_is_decimal(const char* b, const char* e) noexcept {
    const auto digits = [&](const char*& p) {
        const char* s = p;
        while (p != e && *p >= '0' && *p <= '9') ++p;
        return p != s;
    };
    const char* p = b;
    if (p != e && (*p == '+' || *p == '-')) ++p;
    const bool whole = digits(p);
    bool fraction = false;
    if (p != e && *p == '.') {
        ++p;
        fraction = digits(p);
    }
    if (!whole && !fraction) return false;
    if (p != e && (*p == 'e' || *p == 'E')) {
        ++p;
        if (p != e && (*p == '+' || *p == '-')) ++p;
        if (!digits(p)) return false;
    }
    return p == e;
}

/// For a decimal whose value does not fit a double: true if it is tiny (underflows to 0),
/// false if huge. Compares the decimal exponent of the leading digit with 0.
[[nodiscard]] inline bool mesh_decimal_is_tiny(const char* b, const char* e) noexcept {
    constexpr long long cap = 1000000000000LL;
    const char* p = b;
    if (p != e && (*p == '+' || *p == '-')) ++p;
    long long lead = 0; // decimal exponent of the first nonzero digit, plus one
    bool nonzero = false, point = false;
    for (; p != e && *p != 'e' && *p != 'E'; ++p) {
        if (*p == '.') {
            point = true;
        } else if (!nonzero) {
            if (*p != '0') {
                nonzero = true;
                if (!point) lead = 1;
            } else if (point && lead > -cap) {
                --lead;
            }
        } else if (!point && lead < cap) {
            ++lead;
        }
    }
    long long exp10 = 0;
    bool negative = false;
    if (p != e) ++p; // 'e'
    if (p != e && (*p == '+' || *p == '-')) negative = *p++ == '-';
    for (; p != e; ++p)
        if (exp10 < cap) exp10 = exp10 * 10 + (*p - '0');
    return !nonzero || lead + (negative ? -exp10 : exp10) <= 0;
}

enum class NumberStatus { ok, malformed, out_of_range };

/// Parses all of [b, e) as a decimal real, locale-independently ("1e-400" gives 0; "nan" and
/// "inf" are reported as malformed here, see mesh_special_word).
[[nodiscard]] inline NumberStatus mesh_parse_real(const char* b, const char* e, double& out) {
    if (!mesh_is_decimal(b, e)) return NumberStatus::malformed;
    const char* s = (*b == '+') ? b + 1 : b; // from_chars takes no '+'
#if ISIN_DETAIL_FLOAT_FROM_CHARS
    const std::from_chars_result r = std::from_chars(s, e, out);
    if (r.ec == std::errc() && r.ptr == e) return NumberStatus::ok;
    if (r.ec != std::errc::result_out_of_range) return NumberStatus::malformed;
#else
    std::istringstream in(std::string(s, e));
    in.imbue(std::locale::classic());
    double v = 0;
    if ((in >> v) && in.peek() == std::char_traits<char>::eof()) {
        out = v;
        return std::isfinite(v) ? NumberStatus::ok : NumberStatus::out_of_range;
    }
#endif
    if (!mesh_decimal_is_tiny(b, e)) return NumberStatus::out_of_range;
    out = (*b == '-') ? -0.0 : 0.0;
    return NumberStatus::ok;
}

/// Parses all of [b, e) as a decimal integer with optional sign.
[[nodiscard]] inline NumberStatus mesh_parse_int(const char* b, const char* e, long long& out) {
    if (b != e && *b == '+' && e - b > 1 && b[1] != '-') ++b;
    const std::from_chars_result r = std::from_chars(b, e, out);
    if (r.ptr != e || b == e) return NumberStatus::malformed;
    if (r.ec == std::errc::result_out_of_range) return NumberStatus::out_of_range;
    return r.ec == std::errc() ? NumberStatus::ok : NumberStatus::malformed;
}

/// Why a real-number token is bad, for messages; `what` is e.g. "coordinate".
[[nodiscard]] inline std::string mesh_bad_real(const char* what, const char* b, const char* e, NumberStatus status) {
    const int special = mesh_special_word(b, e);
    if (special == 1) return std::string("NaN ") + what + " " + mesh_quote(b, e);
    if (special == 2) return std::string("infinite ") + what + " " + mesh_quote(b, e);
    if (status == NumberStatus::out_of_range) return std::string(what) + " " + mesh_quote(b, e) + " is out of range";
    return std::string("malformed number ") + mesh_quote(b, e);
}

// =================================================================================================
// OBJ: isin checks the text, tinyobjloader parses it, isin checks the result.
// =================================================================================================

/// Calls f(line_number, begin, end) for each line as tinyobjloader splits them ('\n', "\r\n"
/// or '\r' ends a line; a NUL byte ends its content); stops when f returns false.
template <class F>
inline void obj_for_each_line(std::string_view text, F&& f) {
    const char* const data = text.data();
    const std::size_t n = text.size();
    std::size_t pos = 0, line = 0;
    while (pos < n) {
        std::size_t end = pos;
        while (end < n && data[end] != '\n' && data[end] != '\r') ++end;
        ++line;
        const char* b = data + pos;
        const char* e = data + end;
        if (const void* nul = std::memchr(b, 0, end - pos)) e = static_cast<const char*>(nul);
        if (!f(line, b, e)) return;
        pos = end;
        if (pos < n) pos += (data[pos] == '\r' && pos + 1 < n && data[pos + 1] == '\n') ? 2 : 1;
    }
}

/// 'v' for a vertex statement, 'f' for a face, 'n' for a normal (vn), 't' for a texture
/// coordinate (vt), 0 otherwise (tinyobjloader's classification); `b` is left after the keyword.
[[nodiscard]] inline char obj_statement(const char*& b, const char* e) noexcept {
    while (b != e && (*b == ' ' || *b == '\t')) ++b;
    const auto blank = [](char c) { return c == ' ' || c == '\t'; };
    if (e - b >= 3 && b[0] == 'v' && (b[1] == 'n' || b[1] == 't') && blank(b[2])) {
        const char kind = b[1];
        b += 3;
        return kind;
    }
    if (e - b < 2 || !blank(b[1])) return 0;
    const char kind = (*b == 'v' || *b == 'f') ? *b : 0;
    if (kind) b += 2;
    return kind;
}

/// Why tinyobjloader's number parser must not see the token [b, e), or "". It accumulates the
/// exponent in an int whose overflow guard is off by one (ten or more significant exponent
/// digits are undefined behaviour) and counts digits in an int; isin refuses such tokens first.
[[nodiscard]] inline std::string obj_unsafe_number(const char* b, const char* e) {
    constexpr std::ptrdiff_t longest = 4096;
    if (e - b > longest)
        return "number " + mesh_quote(b, e) + " is longer than " + std::to_string(longest) + " characters";
    for (const char* p = b; p != e; ++p) {
        if (*p != 'e' && *p != 'E') continue;
        const char* d = p + 1;
        if (d != e && (*d == '+' || *d == '-')) ++d;
        while (d != e && *d == '0') ++d;
        int digits = 0;
        for (; d != e && *d >= '0' && *d <= '9'; ++d) ++digits;
        if (digits > 9) return "exponent of " + mesh_quote(b, e) + " is out of range";
    }
    return "";
}

/// Next token separated by spaces or tabs; false at the end of the line.
[[nodiscard]] inline bool obj_token(const char*& p, const char* e, const char*& tb, const char*& te) noexcept {
    while (p != e && (*p == ' ' || *p == '\t')) ++p;
    if (p == e) return false;
    tb = p;
    while (p != e && *p != ' ' && *p != '\t') ++p;
    te = p;
    return true;
}

/// Checks one face vertex reference v, v/vt, v//vn or v/vt/vn; returns "" or the problem.
[[nodiscard]] inline std::string obj_check_reference(const char* b, const char* e) {
    const char* slash = static_cast<const char*>(std::memchr(b, '/', static_cast<std::size_t>(e - b)));
    const char* v_end = slash ? slash : e;
    long long v = 0;
    const NumberStatus status = mesh_parse_int(b, v_end, v);
    if (status == NumberStatus::out_of_range ||
        (status == NumberStatus::ok && (v > std::numeric_limits<int>::max() || v < std::numeric_limits<int>::min())))
        return "vertex index " + mesh_quote(b, v_end) + " is out of range";
    if (status != NumberStatus::ok) return "malformed vertex reference " + mesh_quote(b, e);
    if (v == 0) return "vertex index 0 is invalid (OBJ counts from 1)";
    if (!slash) return "";
    // "/vt", "/vt/vn" or "//vn": each part present is an integer, vn never empty.
    const char* p = slash + 1;
    const char* second = static_cast<const char*>(std::memchr(p, '/', static_cast<std::size_t>(e - p)));
    const char* vt_end = second ? second : e;
    // tinyobjloader reads each part with atoi: every part must also fit an int.
    const auto part = [](const char* pb, const char* pe) {
        long long index = 0;
        const NumberStatus part_status = mesh_parse_int(pb, pe, index);
        if (part_status == NumberStatus::malformed) return 1;
        if (part_status == NumberStatus::out_of_range || index > std::numeric_limits<int>::max() ||
            index < std::numeric_limits<int>::min())
            return 2;
        return 0;
    };
    const int vt = (p == vt_end && second) ? 0 : part(p, vt_end);
    const int vn = second ? part(second + 1, e) : 0;
    if (vt == 1 || vn == 1) return "malformed vertex reference " + mesh_quote(b, e);
    if (vt == 2 || vn == 2) return "index in " + mesh_quote(b, e) + " is out of range";
    return "";
}

/// isin's own pass over the text: every number on a `v` line well formed and finite, the first
/// three within T; every `f` line with at least 3 well-formed references, none 0.
template <class T>
inline void obj_check_text(const char* who, const std::string& path, std::string_view text) {
    obj_for_each_line(text, [&](std::size_t line, const char* b, const char* e) {
        const auto fail = [&](const std::string& why) {
            throw mesh_error(who, path, "line " + std::to_string(line) + ": " + why);
        };
        const char kind = obj_statement(b, e);
        const char *tb = nullptr, *te = nullptr;
        int count = 0;
        if (kind == 'n' || kind == 't') { // not read by isin: only what tinyobjloader must not see
            for (int k = 0; k < 3 && obj_token(b, e, tb, te); ++k) {
                const std::string why = obj_unsafe_number(tb, te);
                if (!why.empty()) fail(why);
            }
        } else if (kind == 'v') {
            while (obj_token(b, e, tb, te) && *tb != '#') { // numbers until a trailing comment
                const std::string unsafe = obj_unsafe_number(tb, te);
                if (!unsafe.empty()) fail(unsafe);
                double value = 0;
                const NumberStatus status = mesh_parse_real(tb, te, value);
                if (status != NumberStatus::ok) fail(mesh_bad_real("coordinate", tb, te, status));
                if (count < 3 && !mesh_fits<T>(value))
                    fail("coordinate " + mesh_quote(tb, te) + " does not fit in " + mesh_type_name<T>());
                ++count;
            }
            if (count < 3) fail("vertex has " + std::to_string(count) + " coordinates, needs 3");
        } else if (kind == 'f') {
            while (obj_token(b, e, tb, te)) {
                const std::string why = obj_check_reference(tb, te);
                if (!why.empty()) fail(why);
                ++count;
            }
            if (count < 3) fail("face has " + std::to_string(count) + " vertices, needs at least 3");
        }
        return true;
    });
}

/// Sets the vertices listed in `redo` (ordinals of `v` statements, ascending) from the text with
/// isin's own number parser; returns false if one does not give three numbers that fit T.
template <class T>
[[nodiscard]] inline bool obj_reread_vertices(std::string_view text, const std::vector<std::size_t>& redo,
                                              std::vector<Vertex<T>>& vertices) {
    std::size_t seen = 0, next = 0;
    bool ok = true;
    obj_for_each_line(text, [&](std::size_t, const char* b, const char* e) {
        if (next == redo.size()) return false;
        if (obj_statement(b, e) != 'v' || seen++ != redo[next]) return true;
        double xyz[3] = {0, 0, 0};
        const char *tb = nullptr, *te = nullptr;
        for (double& v : xyz)
            ok = ok && obj_token(b, e, tb, te) && mesh_parse_real(tb, te, v) == NumberStatus::ok && mesh_fits<T>(v);
        if (ok && redo[next] < vertices.size())
            vertices[redo[next]] = {static_cast<T>(xyz[0]), static_cast<T>(xyz[1]), static_cast<T>(xyz[2])};
        ++next;
        return ok;
    });
    return ok && next == redo.size();
}

/// Line number of the `ordinal`-th (from 0) statement of `kind` ('v' or 'f'); 0 if none.
[[nodiscard]] inline std::size_t obj_statement_line(std::string_view text, char kind, std::size_t ordinal) {
    std::size_t seen = 0, found = 0;
    obj_for_each_line(text, [&](std::size_t line, const char* b, const char* e) {
        if (obj_statement(b, e) == kind && seen++ == ordinal) {
            found = line;
            return false;
        }
        return true;
    });
    return found;
}

#if ISIN_HAVE_TINYOBJLOADER

/// Hands a string to tinyobjloader as a stream, without copying it.
class ObjTextBuf : public std::streambuf {
public:
    explicit ObjTextBuf(std::string_view text) { // read only: the get area is never written
        char* b = const_cast<char*>(text.data());
        setg(b, b, b + text.size());
    }
};

/// What tinyobjloader's callbacks collect: vertices, fan triangles as 0-based indices, and the
/// first problem (statement kind and ordinal; its line is looked up only if there is one).
template <class T>
struct ObjCollector {
    std::vector<Vertex<T>> vertices;
    std::vector<std::array<std::size_t, 3>> triangles;
    std::vector<std::pair<std::size_t, long long>> forward; // (face, index) beyond vertices so far
    std::vector<std::size_t> redo;                          // vertices whose value tinyobjloader got wrong, in order
    std::size_t faces = 0;
    char bad_kind = 0;
    std::size_t bad_ordinal = 0;
    std::string bad_why;

    void fail(char kind, std::size_t ordinal, std::string why) {
        if (bad_kind) return;
        bad_kind = kind;
        bad_ordinal = ordinal;
        bad_why = std::move(why);
    }

    static void on_vertex(void* self, tobj::real_t x, tobj::real_t y, tobj::real_t z, tobj::real_t) {
        auto& c = *static_cast<ObjCollector*>(self);
        const std::size_t k = c.vertices.size();
        const double xyz[3] = {static_cast<double>(x), static_cast<double>(y), static_cast<double>(z)};
        if (mesh_fits<T>(xyz[0]) && mesh_fits<T>(xyz[1]) && mesh_fits<T>(xyz[2])) {
            c.vertices.push_back({static_cast<T>(xyz[0]), static_cast<T>(xyz[1]), static_cast<T>(xyz[2])});
            return;
        }
        // The text passed obj_check_text, so the number fits T and tinyobjloader's arithmetic
        // went astray ("0e500" gives NaN; its float real_t overflows): reread it after parsing.
        c.redo.push_back(k);
        c.vertices.push_back({T(0), T(0), T(0)});
    }

    static void on_face(void* self, tobj::index_t* indices, int n) {
        auto& c = *static_cast<ObjCollector*>(self);
        const std::size_t face = c.faces++;
        if (c.bad_kind) return;
        if (n < 3) return c.fail('f', face, "face has " + std::to_string(n) + " vertices, needs at least 3");
        const std::size_t count = c.vertices.size();
        bool ok = true;
        const auto resolve = [&](int raw) -> std::size_t {
            if (raw == 0) {
                c.fail('f', face, "vertex index 0 is invalid (OBJ counts from 1)");
                ok = false;
                return 0;
            }
            if (raw < 0) { // relative: −1 is the last vertex read so far
                const auto back = static_cast<std::size_t>(-static_cast<long long>(raw));
                if (back > count) {
                    c.fail('f', face,
                           "vertex index " + std::to_string(raw) + " is out of range (" + std::to_string(count) +
                               " vertices precede it)");
                    ok = false;
                    return 0;
                }
                return count - back;
            }
            const auto index = static_cast<std::size_t>(raw) - 1;
            if (index >= count) c.forward.emplace_back(face, raw); // checked once all are read
            return index;
        };
        // Fan (v0, vi, vi+1): the polygon's winding is kept.
        const std::size_t v0 = resolve(indices[0].vertex_index);
        std::size_t prev = resolve(indices[1].vertex_index);
        for (int i = 2; i < n && ok; ++i) {
            const std::size_t cur = resolve(indices[i].vertex_index);
            c.triangles.push_back({v0, prev, cur});
            prev = cur;
        }
    }
};

#endif // ISIN_HAVE_TINYOBJLOADER

// =================================================================================================
// PLY: header, then the elements in order, ASCII or binary little-endian.
// =================================================================================================

enum class PlyType : unsigned char { none, i8, u8, i16, u16, i32, u32, f32, f64 };

[[nodiscard]] inline PlyType ply_type(const std::string& name) noexcept {
    if (name == "char" || name == "int8") return PlyType::i8;
    if (name == "uchar" || name == "uint8") return PlyType::u8;
    if (name == "short" || name == "int16") return PlyType::i16;
    if (name == "ushort" || name == "uint16") return PlyType::u16;
    if (name == "int" || name == "int32") return PlyType::i32;
    if (name == "uint" || name == "uint32") return PlyType::u32;
    if (name == "float" || name == "float32") return PlyType::f32;
    if (name == "double" || name == "float64") return PlyType::f64;
    return PlyType::none;
}

[[nodiscard]] constexpr std::size_t ply_size(PlyType t) noexcept {
    switch (t) {
    case PlyType::i8:
    case PlyType::u8: return 1;
    case PlyType::i16:
    case PlyType::u16: return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32: return 4;
    case PlyType::f64: return 8;
    default: return 0;
    }
}

[[nodiscard]] constexpr bool ply_is_integer(PlyType t) noexcept {
    return t != PlyType::none && t != PlyType::f32 && t != PlyType::f64;
}

/// Range of an integer PLY type.
[[nodiscard]] constexpr std::pair<long long, long long> ply_range(PlyType t) noexcept {
    switch (t) {
    case PlyType::i8: return {-128, 127};
    case PlyType::u8: return {0, 255};
    case PlyType::i16: return {-32768, 32767};
    case PlyType::u16: return {0, 65535};
    case PlyType::i32: return {-2147483648LL, 2147483647LL};
    case PlyType::u32: return {0, 4294967295LL};
    default: return {0, 0};
    }
}

enum class PlyRole : unsigned char { skip, x, y, z, indices };

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::none;       // scalar type, or the item type of a list
    PlyType count_type = PlyType::none; // none for a scalar
    PlyRole role = PlyRole::skip;
};

struct PlyElement {
    std::string name;
    unsigned long long count = 0;
    std::size_t line = 0; // of its header line
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    bool binary = false;
    std::vector<PlyElement> elements;
    std::size_t data_offset = 0; // first byte after end_header's line
    std::size_t data_line = 0;   // its line number (ASCII)
    unsigned long long vertex_count = 0;
};

/// Parses the header and marks the properties isin reads (x, y, z of `vertex`, the index list
/// of `face`).
[[nodiscard]] inline PlyHeader ply_parse_header(const char* who, const std::string& path, std::string_view file) {
    PlyHeader h;
    std::size_t pos = 0, line = 0;
    std::vector<std::string> tokens;
    bool have_format = false;
    const auto fail = [&](const std::string& why) -> MeshError {
        return mesh_error(who, path, "line " + std::to_string(line) + ": " + why);
    };
    for (;;) {
        if (pos >= file.size()) {
            if (line == 0) throw mesh_error(who, path, "not a PLY file (empty)");
            throw mesh_error(who, path, "truncated header at line " + std::to_string(line) + ": no end_header");
        }
        std::size_t end = file.find('\n', pos);
        if (end == std::string::npos) end = file.size();
        std::size_t text_end = end;
        if (text_end > pos && file[text_end - 1] == '\r') --text_end;
        ++line;
        tokens.clear();
        for (std::size_t p = pos; p < text_end;) {
            while (p < text_end && (file[p] == ' ' || file[p] == '\t')) ++p;
            const std::size_t s = p;
            while (p < text_end && file[p] != ' ' && file[p] != '\t') ++p;
            if (p > s) tokens.emplace_back(file.substr(s, p - s));
        }
        const std::string_view whole = file.substr(pos, text_end - pos);
        pos = end < file.size() ? end + 1 : end;

        if (line == 1) {
            if (whole != "ply") throw mesh_error(who, path, "not a PLY file (it does not start with 'ply')");
            continue;
        }
        if (tokens.empty()) continue;
        const std::string& key = tokens[0];
        if (key == "comment" || key == "obj_info") continue;
        if (key == "format") {
            if (have_format) throw fail("second format line");
            if (tokens.size() != 3) throw fail("malformed format line");
            if (tokens[1] == "binary_big_endian")
                throw fail("binary_big_endian PLY is not supported (use ascii or binary_little_endian)");
            if (tokens[1] != "ascii" && tokens[1] != "binary_little_endian")
                throw fail("unknown PLY format " + mesh_quote(tokens[1].data(), tokens[1].data() + tokens[1].size()));
            if (tokens[2] != "1.0") throw fail("unsupported PLY version '" + tokens[2].substr(0, 40) + "'");
            h.binary = tokens[1] != "ascii";
            have_format = true;
        } else if (key == "element") {
            if (tokens.size() != 3) throw fail("malformed element line");
            PlyElement el;
            el.name = tokens[1];
            el.line = line;
            const std::string& c = tokens[2];
            const auto r = std::from_chars(c.data(), c.data() + c.size(), el.count);
            if (c.empty() || r.ec != std::errc() || r.ptr != c.data() + c.size())
                throw fail("bad element count " + mesh_quote(c.data(), c.data() + c.size()));
            for (const PlyElement& other : h.elements)
                if (other.name == el.name && (el.name == "vertex" || el.name == "face"))
                    throw fail("second element '" + el.name + "'");
            h.elements.push_back(std::move(el));
        } else if (key == "property") {
            if (h.elements.empty()) throw fail("property before any element");
            PlyProperty prop;
            const auto type_of = [&](const std::string& name) {
                const PlyType t = ply_type(name);
                if (t == PlyType::none)
                    throw fail("unknown property type " + mesh_quote(name.data(), name.data() + name.size()));
                return t;
            };
            if (tokens.size() >= 2 && tokens[1] == "list") {
                if (tokens.size() != 5) throw fail("malformed property list line");
                prop.count_type = type_of(tokens[2]);
                prop.type = type_of(tokens[3]);
                prop.name = tokens[4];
                if (!ply_is_integer(prop.count_type)) throw fail("list length type must be an integer type");
            } else {
                if (tokens.size() != 3) throw fail("malformed property line");
                prop.type = type_of(tokens[1]);
                prop.name = tokens[2];
            }
            PlyElement& el = h.elements.back();
            for (const PlyProperty& other : el.properties)
                if (other.name == prop.name) throw fail("second property '" + prop.name.substr(0, 40) + "'");
            if (el.name == "vertex" && (prop.name == "x" || prop.name == "y" || prop.name == "z")) {
                if (prop.count_type != PlyType::none) throw fail("vertex property " + prop.name + " is a list");
                prop.role = prop.name == "x" ? PlyRole::x : prop.name == "y" ? PlyRole::y : PlyRole::z;
            }
            if (el.name == "face" && (prop.name == "vertex_indices" || prop.name == "vertex_index")) {
                if (prop.count_type == PlyType::none) throw fail("face property " + prop.name + " is not a list");
                if (!ply_is_integer(prop.type)) throw fail("face property " + prop.name + " must hold integers");
                for (const PlyProperty& other : el.properties)
                    if (other.role == PlyRole::indices) throw fail("face has both vertex_indices and vertex_index");
                prop.role = PlyRole::indices;
            }
            el.properties.push_back(std::move(prop));
        } else if (key == "end_header") {
            if (tokens.size() != 1) throw fail("malformed end_header line");
            break;
        } else {
            throw fail("unknown header keyword " + mesh_quote(key.data(), key.data() + key.size()));
        }
    }
    if (!have_format) throw fail("header has no format line");
    h.data_offset = pos;
    h.data_line = line + 1;
    for (const PlyElement& el : h.elements) {
        const auto has = [&](PlyRole role) {
            for (const PlyProperty& p : el.properties)
                if (p.role == role) return true;
            return false;
        };
        const std::string at = "line " + std::to_string(el.line) + ": element '" + el.name + "' has no ";
        if (el.name == "vertex") {
            if (!has(PlyRole::x)) throw mesh_error(who, path, at + "property x");
            if (!has(PlyRole::y)) throw mesh_error(who, path, at + "property y");
            if (!has(PlyRole::z)) throw mesh_error(who, path, at + "property z");
            h.vertex_count = el.count;
        }
        if (el.name == "face" && !has(PlyRole::indices))
            throw mesh_error(who, path, at + "list property vertex_indices");
    }
    return h;
}

/// Where the reader is, for messages: the element and its instance.
struct PlyContext {
    const PlyElement* element = nullptr;
    unsigned long long index = 0;
    [[nodiscard]] std::string text() const {
        if (!element) return "data";
        std::string name = mesh_quote(element->name.data(), element->name.data() + element->name.size());
        return name.substr(1, name.size() - 2) + "[" + std::to_string(index) + "]";
    }
    [[nodiscard]] std::string prefix() const { return element ? text() + ": " : std::string(); }
};

/// Binary little-endian data; positions are byte offsets from the start of the file.
class PlyBinaryReader {
public:
    PlyBinaryReader(const char* who, const std::string& path, std::string_view file, std::size_t pos)
        : who_(who), path_(path), data_(file.data()), size_(file.size()), pos_(pos), start_(pos) {}

    PlyContext context;

    [[noreturn]] void fail(const std::string& why) const {
        throw mesh_error(who_, path_, "offset " + std::to_string(start_) + ": " + context.prefix() + why);
    }
    [[noreturn]] void truncated(const std::string& why) const {
        throw mesh_error(who_, path_, "truncated at offset " + std::to_string(pos_) + ": " + why);
    }
    /// Throws unless `count` instances of `el` can fit in the bytes left.
    void check_room(const PlyElement& el) const {
        std::size_t least = 0; // bytes of one instance whose lists are all empty
        for (const PlyProperty& p : el.properties)
            least += ply_size(p.count_type == PlyType::none ? p.type : p.count_type);
        if (least > 0 && el.count > (size_ - pos_) / least)
            truncated("element " + mesh_quote(el.name.data(), el.name.data() + el.name.size()) + " declares " +
                      std::to_string(el.count) + " entries of at least " + std::to_string(least) + " bytes, but " +
                      std::to_string(size_ - pos_) + " bytes follow");
    }
    [[nodiscard]] std::size_t remaining() const noexcept { return size_ - pos_; }
    [[nodiscard]] static std::size_t least_size(PlyType t) noexcept { return ply_size(t); }

    long long read_int(PlyType t) {
        switch (t) {
        case PlyType::i8: return bits<std::int8_t>(1);
        case PlyType::u8: return bits<std::uint8_t>(1);
        case PlyType::i16: return bits<std::int16_t>(2);
        case PlyType::u16: return bits<std::uint16_t>(2);
        case PlyType::i32: return bits<std::int32_t>(4);
        case PlyType::u32: return bits<std::uint32_t>(4);
        default: fail("an integer type is needed here"); // not reached: the header checks it
        }
    }
    double read_real(PlyType t) {
        if (t == PlyType::f32) return static_cast<double>(bits<float>(4));
        if (t == PlyType::f64) return bits<double>(8);
        return static_cast<double>(read_int(t));
    }
    void skip(PlyType t) { take(ply_size(t)); }
    void skip_items(PlyType t, unsigned long long count) {
        start_ = pos_;
        if (count > (size_ - pos_) / ply_size(t))
            truncated(context.text() + ": list of " + std::to_string(count) + " items");
        pos_ += static_cast<std::size_t>(count) * ply_size(t);
    }
    /// Throws unless `count` values of type t are left (a list about to be read).
    void need_items(PlyType t, unsigned long long count) const {
        if (count > (size_ - pos_) / ply_size(t))
            truncated(context.text() + ": list of " + std::to_string(count) + " items");
    }
    void finish() const noexcept {} // bytes after the last element are ignored

private:
    const unsigned char* take(std::size_t n) {
        start_ = pos_;
        if (size_ - pos_ < n) truncated(context.text());
        const auto* p = reinterpret_cast<const unsigned char*>(data_ + pos_);
        pos_ += n;
        return p;
    }
    /// The n little-endian bytes at the cursor as a V (same size), whatever the host's order.
    template <class V>
    V bits(std::size_t n) {
        const unsigned char* p = take(n);
        std::uint64_t u = 0;
        for (std::size_t i = n; i-- > 0;) u = (u << 8) | static_cast<std::uint64_t>(p[i]);
        V v;
        if constexpr (sizeof(V) == 1) {
            const auto b = static_cast<std::uint8_t>(u);
            std::memcpy(&v, &b, 1);
        } else if constexpr (sizeof(V) == 2) {
            const auto b = static_cast<std::uint16_t>(u);
            std::memcpy(&v, &b, 2);
        } else if constexpr (sizeof(V) == 4) {
            const auto b = static_cast<std::uint32_t>(u);
            std::memcpy(&v, &b, 4);
        } else {
            std::memcpy(&v, &u, 8);
        }
        return v;
    }

    const char* who_;
    const std::string& path_;
    const char* data_;
    std::size_t size_, pos_, start_;
};

/// ASCII data: whitespace-separated numbers; positions are line numbers.
class PlyAsciiReader {
public:
    PlyAsciiReader(const char* who, const std::string& path, std::string_view file, std::size_t pos, std::size_t line)
        : who_(who), path_(path), data_(file.data()), size_(file.size()), pos_(pos), line_(line), start_line_(line) {}

    PlyContext context;

    [[noreturn]] void fail(const std::string& why) const {
        throw mesh_error(who_, path_, "line " + std::to_string(start_line_) + ": " + context.prefix() + why);
    }
    [[noreturn]] void truncated(const std::string& why) const {
        throw mesh_error(who_, path_, "truncated at line " + std::to_string(line_) + ": " + why);
    }
    /// Throws unless `count` instances of `el` can fit: each value is at least one character
    /// and a separator.
    void check_room(const PlyElement& el) const {
        const std::size_t least = 2 * el.properties.size();
        if (least > 0 && el.count > (size_ - pos_ + 1) / least)
            truncated("element " + mesh_quote(el.name.data(), el.name.data() + el.name.size()) + " declares " +
                      std::to_string(el.count) + " entries, but " + std::to_string(size_ - pos_) + " bytes follow");
    }
    [[nodiscard]] std::size_t remaining() const noexcept { return size_ - pos_; }
    [[nodiscard]] static std::size_t least_size(PlyType) noexcept { return 2; }

    long long read_int(PlyType t) {
        next();
        long long v = 0;
        const NumberStatus status = mesh_parse_int(tb_, te_, v);
        const auto range = ply_range(t);
        if (status == NumberStatus::malformed) fail("malformed integer " + mesh_quote(tb_, te_));
        if (status == NumberStatus::out_of_range || v < range.first || v > range.second)
            fail("value " + mesh_quote(tb_, te_) + " is out of range for its type");
        return v;
    }
    double read_real(PlyType t) {
        if (ply_is_integer(t)) return static_cast<double>(read_int(t));
        next();
        double v = 0;
        const NumberStatus status = mesh_parse_real(tb_, te_, v);
        if (status == NumberStatus::ok) return v;
        const int special = mesh_special_word(tb_, te_); // NaN and infinity are values here
        if (special == 1) return std::numeric_limits<double>::quiet_NaN();
        if (special == 2)
            return *tb_ == '-' ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
        fail(mesh_bad_real("number", tb_, te_, status));
    }
    void skip(PlyType) { next(); }
    void skip_items(PlyType, unsigned long long count) {
        need_items(PlyType::none, count);
        for (unsigned long long i = 0; i < count; ++i) next();
    }
    void need_items(PlyType, unsigned long long count) const {
        if (count > (size_ - pos_ + 1) / 2) truncated(context.text() + ": list of " + std::to_string(count) + " items");
    }
    /// Nothing but whitespace may follow the last element.
    void finish() {
        skip_space();
        if (pos_ < size_) {
            start_line_ = line_;
            context = {};
            fail("unexpected data after the last element");
        }
    }

private:
    static bool space(char c) noexcept {
        return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
    }
    void skip_space() noexcept {
        for (; pos_ < size_ && space(data_[pos_]); ++pos_)
            if (data_[pos_] == '\n') ++line_;
    }
    void next() {
        skip_space();
        if (pos_ >= size_) truncated(context.text());
        start_line_ = line_;
        tb_ = data_ + pos_;
        while (pos_ < size_ && !space(data_[pos_])) ++pos_;
        te_ = data_ + pos_;
    }

    const char* who_;
    const std::string& path_;
    const char* data_;
    std::size_t size_, pos_, line_, start_line_;
    const char* tb_ = nullptr;
    const char* te_ = nullptr;
};

/// Reads every element in order; keeps the vertices' positions and the faces' fan triangles.
template <class T, class Reader>
inline void ply_read_body(Reader& r, const PlyHeader& h, std::vector<Vertex<T>>& vertices,
                          std::vector<std::array<std::size_t, 3>>& triangles) {
    for (const PlyElement& el : h.elements) {
        if (el.properties.empty() || el.count == 0) continue;
        r.context = {&el, 0};
        r.check_room(el);
        const bool is_vertex = el.name == "vertex", is_face = el.name == "face";
        if (is_vertex) vertices.reserve(static_cast<std::size_t>(el.count)); // bounded by check_room
        if (is_face) // a real face has at least 3 indices: reserve no more than that allows
            triangles.reserve(static_cast<std::size_t>(
                std::min<unsigned long long>(el.count, r.remaining() / (4 * Reader::least_size(PlyType::u8)))));
        for (unsigned long long i = 0; i < el.count; ++i) {
            r.context.index = i;
            T xyz[3] = {T(0), T(0), T(0)};
            for (const PlyProperty& p : el.properties) {
                if (p.count_type == PlyType::none) {
                    if (p.role == PlyRole::skip) {
                        r.skip(p.type);
                        continue;
                    }
                    const double v = r.read_real(p.type);
                    const char* axis = p.role == PlyRole::x ? "x" : p.role == PlyRole::y ? "y" : "z";
                    if (std::isnan(v)) r.fail(std::string("coordinate ") + axis + " is NaN");
                    if (!std::isfinite(v)) r.fail(std::string("coordinate ") + axis + " is infinite");
                    if (!mesh_fits<T>(v))
                        r.fail(std::string("coordinate ") + axis + " = " + mesh_number(v) + " does not fit in " +
                               mesh_type_name<T>());
                    xyz[p.role == PlyRole::x ? 0 : p.role == PlyRole::y ? 1 : 2] = static_cast<T>(v);
                    continue;
                }
                const long long n = r.read_int(p.count_type);
                if (n < 0) r.fail("negative list length " + std::to_string(n));
                if (p.role != PlyRole::indices) {
                    r.skip_items(p.type, static_cast<unsigned long long>(n));
                    continue;
                }
                if (n < 3) r.fail("face has " + std::to_string(n) + " vertices, needs at least 3");
                r.need_items(p.type, static_cast<unsigned long long>(n));
                std::size_t v0 = 0, prev = 0;
                for (long long k = 0; k < n; ++k) {
                    const long long index = r.read_int(p.type);
                    if (index < 0 || static_cast<unsigned long long>(index) >= h.vertex_count)
                        r.fail("vertex index " + std::to_string(index) + " is out of range (the file has " +
                               std::to_string(h.vertex_count) + " vertices)");
                    const auto cur = static_cast<std::size_t>(index);
                    if (k == 0)
                        v0 = cur;
                    else if (k > 1)
                        triangles.push_back({v0, prev, cur}); // fan (v0, vi, vi+1)
                    prev = cur;
                }
            }
            if (is_vertex) vertices.push_back({xyz[0], xyz[1], xyz[2]});
        }
    }
    r.context = {};
    r.finish();
}

template <class T>
[[nodiscard]] inline std::vector<Triangle<T>> mesh_triangles(const std::vector<Vertex<T>>& vertices,
                                                             const std::vector<std::array<std::size_t, 3>>& tris) {
    std::vector<Triangle<T>> out;
    out.reserve(tris.size());
    for (const auto& t : tris) out.push_back({vertices[t[0]], vertices[t[1]], vertices[t[2]]});
    return out;
}

} // namespace detail

namespace detail {

template <class T>
[[nodiscard]] std::vector<Triangle<T>> parse_obj(const char* who, const std::string& name, std::string_view text) {
    static_assert(std::is_floating_point_v<T>, "isin::load_obj needs a floating-point type");
#if ISIN_HAVE_TINYOBJLOADER
    obj_check_text<T>(who, name, text);
    ObjCollector<T> c;
    tobj::callback_t callbacks;
    callbacks.vertex_cb = &ObjCollector<T>::on_vertex;
    callbacks.index_cb = &ObjCollector<T>::on_face;
    ObjTextBuf buf(text);
    std::istream in(&buf);
    std::string warn, err;
    // No MaterialReader: mtllib lines are skipped, no .mtl file is opened.
    const bool ok = tobj::LoadObjWithCallback(in, callbacks, &c, nullptr, &warn, &err);
    if (!ok || !err.empty())
        throw mesh_error(who, name, "tinyobjloader: " + (err.empty() ? std::string("failed") : err));

    const auto at_line = [&](char kind, std::size_t ordinal, const std::string& why) {
        return mesh_error(who, name, "line " + std::to_string(obj_statement_line(text, kind, ordinal)) + ": " + why);
    };
    for (const auto& [face, raw] : c.forward) { // forward references, now that all vertices are in
        if (static_cast<std::size_t>(raw) <= c.vertices.size()) continue;
        if (c.bad_kind && c.bad_ordinal < face) break; // report whichever face comes first
        c.bad_kind = 0;
        c.fail('f', face,
               "vertex index " + std::to_string(raw) + " is out of range (the file has " +
                   std::to_string(c.vertices.size()) + " vertices)");
        break;
    }
    if (c.bad_kind) throw at_line(c.bad_kind, c.bad_ordinal, c.bad_why);
    if (!c.redo.empty() && !obj_reread_vertices(text, c.redo, c.vertices))
        throw at_line('v', c.redo.front(), "coordinate out of range for " + std::string(mesh_type_name<T>()));
    return mesh_triangles(c.vertices, c.triangles);
#else
    (void)text;
    throw std::runtime_error(std::string(who) + ": '" + name +
                             "': reading OBJ needs tinyobjloader "
                             "(Debian/Ubuntu: install libtinyobjloader-dev); PLY works without it");
#endif
}

template <class T>
[[nodiscard]] std::vector<Triangle<T>> parse_ply(const char* who, const std::string& name, std::string_view file) {
    static_assert(std::is_floating_point_v<T>, "isin::load_ply needs a floating-point type");
    const PlyHeader h = ply_parse_header(who, name, file);
    std::vector<Vertex<T>> vertices;
    std::vector<std::array<std::size_t, 3>> tris;
    if (h.binary) {
        PlyBinaryReader r(who, name, file, h.data_offset);
        ply_read_body<T>(r, h, vertices, tris);
    } else {
        PlyAsciiReader r(who, name, file, h.data_offset, h.data_line);
        ply_read_body<T>(r, h, vertices, tris);
    }
    return mesh_triangles(vertices, tris);
}

} // namespace detail

/// Triangles of a Wavefront OBJ file (`v` and `f` statements; polygons as fans, winding kept).
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line; std::runtime_error without tinyobjloader.
template <class T>
std::vector<Triangle<T>> load_obj(const std::string& path, const ReadLimits& limits) {
    const char* who = "isin::load_obj";
    return detail::parse_obj<T>(who, path, detail::mesh_read_file(who, path, limits));
}

/// Triangles of a PLY file: ascii or binary_little_endian 1.0, positions from vertex x, y, z
/// (any scalar type), polygons from face vertex_indices (or vertex_index) as fans, winding kept.
/// Only regular files of at most limits.max_file_bytes are read. Throws MeshError naming the
/// file and line (ASCII) or byte offset (binary).
template <class T>
std::vector<Triangle<T>> load_ply(const std::string& path, const ReadLimits& limits) {
    const char* who = "isin::load_ply";
    return detail::parse_ply<T>(who, path, detail::mesh_read_file(who, path, limits));
}

/// Triangles of OBJ or PLY data in memory (`size` bytes at `data`), as load_obj / load_ply read
/// a file: for meshes that arrive over a network or from an archive, with no temporary file.
/// Errors are MeshError naming `name` in place of a file.
template <class T>
std::vector<Triangle<T>> load_mesh_from_memory(const void* data, std::size_t size, MeshFormat format,
                                               const std::string& name) {
    const std::string_view bytes(data ? static_cast<const char*>(data) : "", data ? size : 0);
    return format == MeshFormat::obj ? detail::parse_obj<T>("isin::load_obj", name, bytes)
                                     : detail::parse_ply<T>("isin::load_ply", name, bytes);
}

/// Triangles of an OBJ or PLY file, chosen by the extension (.obj, .ply, any letter case).
/// Throws std::invalid_argument naming the path for any other extension, else as load_obj/ply.
template <class T>
std::vector<Triangle<T>> load_mesh(const std::string& path, const ReadLimits& limits) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& ch : ext)
        if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
    if (ext == ".obj") return load_obj<T>(path, limits);
    if (ext == ".ply") return load_ply<T>(path, limits);
    throw std::invalid_argument("isin::load_mesh: '" + path + "': unknown extension '" + ext + "' (use .obj or .ply)");
}

#define ISIN_DETAIL_MESH_IO(T)                                                                                         \
    template std::vector<Triangle<T>> load_obj<T>(const std::string&, const ReadLimits&);                              \
    template std::vector<Triangle<T>> load_ply<T>(const std::string&, const ReadLimits&);                              \
    template std::vector<Triangle<T>> load_mesh_from_memory<T>(const void*, std::size_t, MeshFormat,                   \
                                                               const std::string&);                                    \
    template std::vector<Triangle<T>> load_mesh<T>(const std::string&, const ReadLimits&);
ISIN_DETAIL_MESH_IO(float)
ISIN_DETAIL_MESH_IO(double)
#undef ISIN_DETAIL_MESH_IO

} // namespace isin
