#pragma once
/// isin — private: the PLY reader (header, then the elements in order; ASCII or binary) behind
/// load_ply, load_mesh and load_model.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "../mesh.hpp"
#include "../indexed_mesh.hpp"
#include "mesh_text.hpp"
#include "polygon.hpp"

namespace isin {

namespace detail {

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
[[nodiscard]] Mesh<T> parse_ply_mesh(const char* who, const std::string& name, std::string_view file) {
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
    Mesh<T> mesh;
    mesh.positions = std::move(vertices);
    mesh.indices.reserve(tris.size());
    for (const auto& t : tris)
        mesh.indices.push_back({static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[1]),
                                static_cast<std::uint32_t>(t[2])});
    return mesh;
}


} // namespace detail

} // namespace isin
