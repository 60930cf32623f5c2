#pragma once
/// isin — private: the OBJ reader behind load_obj, load_mesh and load_model. isin reads the
/// statements in one pass, checking every number and reference (tinyobjloader's own parser reads
/// "1,5" or "nan" as 0 without complaint and would parse the text a second time); the .mtl files
/// are read as io/mtl.hpp says.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <istream>
#include <map>
#include <memory>
#include <limits>
#include <streambuf>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "../mesh.hpp"
#include "parse.hpp"
#include "file.hpp"
#include "model_files.hpp"
#include "mtl.hpp"
#include "polygon.hpp"
#include "tinyobj.hpp"

namespace isin {

namespace detail {

// =================================================================================================
// OBJ: statements read by isin, .mtl files by tinyobjloader (io/mtl.hpp).
// =================================================================================================

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

/// Reads one face vertex reference v, v/vt, v//vn or v/vt/vn into `index` (v, vt, vn as written:
/// 1-based, negative for relative, 0 for an absent vt or vn); returns "" or the problem.
[[nodiscard]] inline std::string obj_parse_reference(const char* b, const char* e, int (&index)[3]) {
    index[0] = index[1] = index[2] = 0;
    const char* slash = static_cast<const char*>(std::memchr(b, '/', static_cast<std::size_t>(e - b)));
    const char* v_end = slash ? slash : e;
    long long v = 0;
    const NumberStatus status = mesh_parse_int(b, v_end, v);
    if (status == NumberStatus::out_of_range ||
        (status == NumberStatus::ok && (v > std::numeric_limits<int>::max() || v < std::numeric_limits<int>::min())))
        return "vertex index " + mesh_quote(b, v_end) + " is out of range";
    if (status != NumberStatus::ok) return "malformed vertex reference " + mesh_quote(b, e);
    if (v == 0) return "vertex index 0 is invalid (OBJ counts from 1)";
    index[0] = static_cast<int>(v);
    if (!slash) return "";
    // "/vt", "/vt/vn" or "//vn": each part present is an integer that fits an int, vn never empty.
    const char* p = slash + 1;
    const char* second = static_cast<const char*>(std::memchr(p, '/', static_cast<std::size_t>(e - p)));
    const char* vt_end = second ? second : e;
    const auto part = [](const char* pb, const char* pe, int& out) {
        long long value = 0;
        const NumberStatus part_status = mesh_parse_int(pb, pe, value);
        if (part_status == NumberStatus::malformed) return 1;
        if (part_status == NumberStatus::out_of_range || value > std::numeric_limits<int>::max() ||
            value < std::numeric_limits<int>::min())
            return 2;
        out = static_cast<int>(value);
        return 0;
    };
    const int vt = (p == vt_end && second) ? 0 : part(p, vt_end, index[1]);
    const int vn = second ? part(second + 1, e, index[2]) : 0;
    if (vt == 1 || vn == 1) return "malformed vertex reference " + mesh_quote(b, e);
    if (vt == 2 || vn == 2) return "index in " + mesh_quote(b, e) + " is out of range";
    return "";
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

// Internal linkage, as tinyobjloader's types in them (see tinyobj.hpp).
namespace {

/// What an OBJ holds: positions, normals, texture coordinates, each face's corners (0-based,
/// resolved as far as the file allows at that point), part and material, the materials of the
/// .mtl files, and the first problem found after the line it is on (statement kind and ordinal).
template <class T>
struct ObjCollector {
    /// A face corner: indices into vertices, uvs and normals; −1 for "none". A positive index may
    /// be ≥ the count read so far (OBJ lets faces refer to later vertices): checked at the end.
    struct Corner {
        std::int32_t v, vt, vn;
    };
    struct Face {
        std::uint32_t corners; // how many, after those of the faces before it
        std::uint32_t part;    // index into part_names
        std::int32_t material; // tinyobjloader's material id, −1 = none
    };
    bool attributes = true; // false: normals and uvs only counted (load_obj reads positions only)
    std::vector<Vertex<T>> vertices, normals;
    std::vector<std::array<T, 2>> uvs;
    std::size_t normal_count = 0, uv_count = 0;
    std::vector<Corner> corners;
    std::vector<Face> faces;
    std::vector<std::string> part_names{std::string()};
    std::unordered_map<std::string, std::uint32_t> part_ids{{std::string(), 0}}; // index of each name
    std::uint64_t max_parts = ~std::uint64_t(0);                                 // ModelBudget::meshes
    std::uint64_t max_vertices = ~std::uint64_t(0);                              // ModelBudget::vertices
    std::uint32_t part = 0;
    std::int32_t material = -1;
    std::vector<tobj::material_t> materials;           // all .mtl files' materials so far
    std::unordered_map<std::string, int> material_ids; // their names (the first of a name counts)
    std::vector<std::string> material_dirs;            // the directory of each material's .mtl (texture paths)
    std::vector<std::string> warnings;
    char bad_kind = 0;
    std::size_t bad_ordinal = 0;
    std::string bad_why;

    void fail(char kind, std::size_t ordinal, std::string why) {
        if (bad_kind) return;
        bad_kind = kind;
        bad_ordinal = ordinal;
        bad_why = std::move(why);
    }

    /// An attribute value as T: non-finite values and values beyond T read as 0.
    [[nodiscard]] static T attribute(double v) noexcept { return mesh_fits<T>(v) ? static_cast<T>(v) : T(0); }

    void add_normal(const double (&xyz)[3]) {
        ++normal_count;
        if (attributes) normals.push_back({attribute(xyz[0]), attribute(xyz[1]), attribute(xyz[2])});
    }
    void add_uv(const double (&xyz)[3]) {
        ++uv_count;
        if (attributes) uvs.push_back({attribute(xyz[0]), attribute(xyz[1])});
    }
    void use_material(const std::string& name) {
        const auto found = material_ids.find(name);
        material = found == material_ids.end() ? -1 : found->second;
        if (material < 0) warnings.push_back("material '" + name.substr(0, 80) + "' is not defined");
    }
    /// Makes `name` the current part; false if it would be one more than max_parts.
    [[nodiscard]] bool set_part(const std::string& name) {
        const auto [at, added] = part_ids.try_emplace(name, static_cast<std::uint32_t>(part_names.size()));
        if (added &&
            (part_names.size() > max_parts || part_names.size() >= std::numeric_limits<std::uint32_t>::max())) {
            part_ids.erase(at);
            return false;
        }
        if (added) part_names.push_back(name);
        part = at->second;
        return true;
    }

    /// Adds a face of n ≥ 3 references (as obj_parse_reference reads them).
    void add_face(const std::array<int, 3>* refs, std::size_t n) {
        const std::size_t face = faces.size();
        faces.push_back({static_cast<std::uint32_t>(n), part, material});
        if (bad_kind) return;
        // Resolves one index; `what` names it, `count` is how many were read so far.
        const auto resolve = [&](int raw, const char* what, std::size_t count) -> std::int32_t {
            if (raw == 0) return -1; // no vt or vn (a vertex index 0 is refused when read)
            if (raw < 0) {           // relative: −1 is the last one read so far
                const auto back = static_cast<std::size_t>(-static_cast<long long>(raw));
                if (back > count) {
                    fail('f', face,
                         std::string(what) + " index " + std::to_string(raw) + " is out of range (" +
                             std::to_string(count) + " precede it)");
                    return -1;
                }
                return static_cast<std::int32_t>(count - back);
            }
            return raw - 1;
        };
        for (std::size_t i = 0; i < n; ++i)
            corners.push_back({resolve(refs[i][0], "vertex", vertices.size()),
                               resolve(refs[i][1], "texture coordinate", uv_count),
                               resolve(refs[i][2], "normal", normal_count)});
    }

    /// After parsing: the first face (in file order, before any earlier problem) whose index is
    /// beyond what the file holds becomes the problem.
    void check_ranges() {
        std::size_t at = 0;
        for (std::size_t f = 0; f < faces.size(); ++f) {
            if (bad_kind && bad_ordinal <= f) return;
            for (std::uint32_t i = 0; i < faces[f].corners; ++i) {
                const Corner& k = corners[at + i];
                const auto beyond = [&](std::int32_t index, std::size_t count, const char* what, const char* things) {
                    if (index < 0 || static_cast<std::size_t>(index) < count) return false;
                    bad_kind = 0;
                    fail('f', f,
                         std::string(what) + " index " + std::to_string(static_cast<long long>(index) + 1) +
                             " is out of range (the file has " + std::to_string(count) + " " + things + ")");
                    return true;
                };
                if (beyond(k.v, vertices.size(), "vertex", "vertices") ||
                    beyond(k.vt, uv_count, "texture coordinate", "texture coordinates") ||
                    beyond(k.vn, normal_count, "normal", "normals"))
                    return;
            }
            at += faces[f].corners;
        }
    }
};

} // namespace

/// The rest of a line after `keyword` and one space or tab, or nullptr if the line is not that
/// statement (tinyobjloader's reading of g, o, usemtl and mtllib lines).
[[nodiscard]] inline const char* obj_keyword(const char* b, const char* e, const char* keyword) noexcept {
    while (b != e && (*b == ' ' || *b == '\t')) ++b;
    const std::size_t n = std::strlen(keyword);
    if (static_cast<std::size_t>(e - b) <= n || std::memcmp(b, keyword, n) != 0 || (b[n] != ' ' && b[n] != '\t'))
        return nullptr;
    return b + n + 1;
}

/// Parses OBJ text into `c` in one pass, checking every number and reference on the way; throws
/// MeshError naming the line for any problem. `dir` (ending in '/', or "") is where .mtl files
/// are looked for, through `files`; without `attributes`: positions and faces only (load_obj).
/// Without `files` (data from memory), mtllib lines are left out with a warning.
template <class T>
inline void obj_collect(const char* who, const std::string& name, std::string_view text, ObjCollector<T>& c,
                        const std::string& dir, bool attributes, ModelFiles* files) {
    // A NUL byte: UTF-16 text or binary data, which no OBJ reader reads as what it holds.
    if (const void* nul = std::memchr(text.data(), 0, text.size())) {
        const auto at = static_cast<std::size_t>(static_cast<const char*>(nul) - text.data());
        const bool utf16 = text.size() >= 2 && ((text[0] == '\xff' && text[1] == '\xfe') ||
                                                (text[0] == '\xfe' && text[1] == '\xff') || at < 2);
        throw mesh_error(who, name,
                         utf16 ? std::string("UTF-16 text; OBJ files are read as ASCII or UTF-8 (save it as UTF-8)")
                               : "binary data (a NUL byte at offset " + std::to_string(at) + "), not OBJ text");
    }
    if (text.size() >= 3 && text.substr(0, 3) == "\xef\xbb\xbf") text.remove_prefix(3); // UTF-8 byte order mark
    c.attributes = attributes;
    std::unique_ptr<ObjMaterialReader<ObjCollector<T>>> mtl;
    if (files) mtl = std::make_unique<ObjMaterialReader<ObjCollector<T>>>(dir, *files, c);
    std::vector<std::array<int, 3>> refs; // a face's references
    obj_for_each_line(text, [&](std::size_t line, const char* b, const char* e) {
        const auto fail = [&](const std::string& why) {
            throw mesh_error(who, name, "line " + std::to_string(line) + ": " + why);
        };
        const auto too_many_parts = [&] {
            return "more than " + std::to_string(c.max_parts) + " group and object names (ModelBudget::meshes)";
        };
        const char kind = obj_statement(b, e);
        const char *tb = nullptr, *te = nullptr;
        if (kind == 'v') {
            double xyz[3] = {0, 0, 0};
            int count = 0;
            while (obj_token(b, e, tb, te) && *tb != '#') { // numbers (x y z [w] or x y z r g b) until a comment
                const std::string unsafe = obj_unsafe_number(tb, te);
                if (!unsafe.empty()) fail(unsafe);
                double value = 0;
                const NumberStatus status = mesh_parse_real(tb, te, value);
                if (status != NumberStatus::ok) fail(mesh_bad_real("coordinate", tb, te, status));
                if (count < 3) {
                    if (!mesh_fits<T>(value))
                        fail("coordinate " + mesh_quote(tb, te) + " does not fit in " + mesh_type_name<T>());
                    xyz[count] = value;
                }
                ++count;
            }
            if (count < 3) fail("vertex has " + std::to_string(count) + " coordinates, needs 3");
            if (c.vertices.size() >= c.max_vertices)
                fail("more than " + std::to_string(c.max_vertices) + " vertices (ModelBudget::vertices)");
            c.vertices.push_back({static_cast<T>(xyz[0]), static_cast<T>(xyz[1]), static_cast<T>(xyz[2])});
        } else if (kind == 'n' || kind == 't') { // up to three numbers; missing or malformed ones read as 0
            double xyz[3] = {0, 0, 0};
            for (int k = 0; k < 3 && obj_token(b, e, tb, te); ++k) {
                const std::string unsafe = obj_unsafe_number(tb, te);
                if (!unsafe.empty()) fail(unsafe);
                if (mesh_parse_real(tb, te, xyz[k]) != NumberStatus::ok) xyz[k] = 0;
            }
            if (kind == 'n')
                c.add_normal(xyz);
            else
                c.add_uv(xyz);
        } else if (kind == 'f') {
            refs.clear();
            while (obj_token(b, e, tb, te)) {
                int index[3];
                const std::string why = obj_parse_reference(tb, te, index);
                if (!why.empty()) fail(why);
                refs.push_back({index[0], index[1], index[2]});
            }
            const std::size_t n = refs.size();
            if (n < 3) fail("face has " + std::to_string(n) + " vertices, needs at least 3");
            if (n > std::numeric_limits<std::uint32_t>::max()) fail("face has more than 2^32 - 1 vertices");
            c.add_face(refs.data(), n);
        } else if (c.attributes) {
            if (const char* rest = obj_keyword(b, e, "g")) { // group: the names on the line
                std::string names;
                while (obj_token(rest, e, tb, te)) names += (names.empty() ? "" : " ") + std::string(tb, te);
                if (!c.set_part(names)) fail(too_many_parts());
            } else if ((rest = obj_keyword(b, e, "o"))) {
                if (!c.set_part(std::string(rest, e))) fail(too_many_parts());
            } else if ((rest = obj_keyword(b, e, "usemtl"))) {
                c.use_material(std::string(rest, e));
            } else if ((rest = obj_keyword(b, e, "mtllib")) && !files) {
                c.warnings.push_back("line " + std::to_string(line) +
                                     ": mtllib: no material files are read for data in memory");
            } else if (rest) {
                // File names separated by spaces ('\ ' is a space in a name); the first that reads is used.
                std::vector<std::string> names(1);
                for (const char* p = rest; p != e; ++p) {
                    if (*p == '\\' && p + 1 != e && p[1] == ' ')
                        names.back() += *++p;
                    else if (*p == ' ')
                        names.emplace_back();
                    else
                        names.back() += *p;
                }
                for (const std::string& file : names) {
                    if (file.empty()) continue;
                    if (mtl->read(file)) break;
                    if (!mtl->error.empty()) throw mesh_error(who, name, "material file " + mtl->error);
                }
            }
        }
        return true;
    });
    c.check_ranges();
    if (c.bad_kind)
        throw mesh_error(who, name,
                         "line " + std::to_string(obj_statement_line(text, c.bad_kind, c.bad_ordinal)) + ": " +
                             c.bad_why);
    if (c.vertices.size() > std::numeric_limits<std::uint32_t>::max())
        throw mesh_error(who, name, "more than 2^32 - 1 vertices");
}

/// Appends face `f`'s fan (corners local[0 … n)) to `mesh`, recording polygons for
/// retriangulate_fans.
inline void obj_add_fan(std::vector<std::array<std::uint32_t, 3>>& indices, std::vector<FanRun>& runs,
                        const std::uint32_t* local, std::uint32_t n) {
    if (n > 3) runs.push_back({indices.size(), n});
    for (std::uint32_t k = 1; k + 1 < n; ++k) indices.push_back({local[0], local[k], local[k + 1]});
}

#endif // ISIN_HAVE_TINYOBJLOADER

template <class T>
[[nodiscard]] std::vector<Triangle<T>> parse_obj(const char* who, const std::string& name, std::string_view text) {
    static_assert(std::is_floating_point_v<T>, "isin::load_obj needs a floating-point type");
#if ISIN_HAVE_TINYOBJLOADER
    ObjCollector<T> c;
    obj_collect<T>(who, name, text, c, "", false, nullptr);
    std::vector<std::array<std::uint32_t, 3>> indices;
    indices.reserve(c.corners.size() > 2 * c.faces.size() ? c.corners.size() - 2 * c.faces.size() : 0);
    std::vector<FanRun> runs;
    std::vector<std::uint32_t> local;
    std::size_t at = 0;
    for (const auto& face : c.faces) {
        local.resize(face.corners);
        for (std::uint32_t i = 0; i < face.corners; ++i) local[i] = static_cast<std::uint32_t>(c.corners[at + i].v);
        obj_add_fan(indices, runs, local.data(), face.corners);
        at += face.corners;
    }
    retriangulate_fans(c.vertices, indices, runs);
    std::vector<Triangle<T>> out;
    out.reserve(indices.size());
    for (const auto& t : indices) out.push_back({c.vertices[t[0]], c.vertices[t[1]], c.vertices[t[2]]});
    return out;
#else
    (void)text;
    throw std::runtime_error(std::string(who) + ": '" + name +
                             "': reading OBJ needs tinyobjloader "
                             "(Debian/Ubuntu: install libtinyobjloader-dev); PLY works without it");
#endif
}

} // namespace detail

} // namespace isin
