#pragma once
/// isin — private: the OBJ reader behind load_obj, load_mesh and load_model: isin checks the
/// text, tinyobjloader parses it, isin checks the result.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <istream>
#include <limits>
#include <streambuf>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "../mesh.hpp"
#include "mesh_text.hpp"
#include "tinyobj.hpp"

namespace isin {

namespace detail {

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

template <class T>
[[nodiscard]] inline std::vector<Triangle<T>> mesh_triangles(const std::vector<Vertex<T>>& vertices,
                                                             const std::vector<std::array<std::size_t, 3>>& tris) {
    std::vector<Triangle<T>> out;
    out.reserve(tris.size());
    for (const auto& t : tris) out.push_back({vertices[t[0]], vertices[t[1]], vertices[t[2]]});
    return out;
}


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


} // namespace detail

} // namespace isin
