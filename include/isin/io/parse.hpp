#pragma once
/// isin — private: what the mesh readers share (errors, the whole-file read, number parsing and
/// checking, the line grammar of OBJ and MTL), for io/obj.hpp, io/mtl.hpp and io/ply.hpp.
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
#include "../vec.hpp"
#include "file.hpp"

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

// The line grammar of OBJ and MTL text (tinyobjloader's), for io/obj.hpp and io/mtl.hpp.

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

/// Hands a string to tinyobjloader as a stream, without copying it.
class ObjTextBuf : public std::streambuf {
public:
    explicit ObjTextBuf(std::string_view text) { // read only: the get area is never written
        char* b = const_cast<char*>(text.data());
        setg(b, b, b + text.size());
    }
};

} // namespace detail

} // namespace isin
