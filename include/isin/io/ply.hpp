#pragma once
/// isin — private: the PLY reader (header, then the elements in order; ASCII or binary of either
/// byte order) behind load_ply, load_mesh and load_model: positions, the vertices' normals,
/// texture coordinates and colours, and polygons triangulated.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include "../mesh.hpp"
#include "../indexed_mesh.hpp"
#include "parse.hpp"
#include "polygon.hpp"

namespace isin {

namespace detail {

// =================================================================================================
// PLY: header, then the elements in order, ASCII or binary (little- or big-endian).
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

/// The PLY type of the integer type I.
template <class I>
[[nodiscard]] constexpr PlyType ply_type_of() noexcept {
    if constexpr (std::is_same_v<I, std::int8_t>) return PlyType::i8;
    if constexpr (std::is_same_v<I, std::uint8_t>) return PlyType::u8;
    if constexpr (std::is_same_v<I, std::int16_t>) return PlyType::i16;
    if constexpr (std::is_same_v<I, std::uint16_t>) return PlyType::u16;
    if constexpr (std::is_same_v<I, std::int32_t>) return PlyType::i32;
    if constexpr (std::is_same_v<I, std::uint32_t>) return PlyType::u32;
    return PlyType::none;
}

/// Whether `count` values of `size` bytes (1, 2, 4 or 8) fit in `room` bytes: a shift, not a
/// division, as it runs once a face.
[[nodiscard]] constexpr bool ply_fits(unsigned long long count, std::size_t size, std::size_t room) noexcept {
    const int shift = size == 8 ? 3 : size == 4 ? 2 : size == 2 ? 1 : 0;
    return count <= (room >> shift);
}

enum class PlyFormat : unsigned char { ascii, binary_little_endian, binary_big_endian };

/// What isin takes from a property: a coordinate, a normal's or texture coordinate's component,
/// a colour channel, a face's corners, or nothing. Keep x … blue in this order (ply_read_body
/// indexes by it).
enum class PlyRole : unsigned char { skip, x, y, z, nx, ny, nz, tex_u, tex_v, red, green, blue, indices };

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::none;       // scalar type, or the item type of a list
    PlyType count_type = PlyType::none; // none for a scalar
    PlyRole role = PlyRole::skip;
    double divisor = 1; // a colour channel's value is divided by it: the maximum of an integer type
};

struct PlyElement {
    std::string name;
    unsigned long long count = 0;
    std::size_t line = 0; // of its header line
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::ascii;
    std::vector<PlyElement> elements;
    std::size_t data_offset = 0; // first byte after end_header's line
    std::size_t data_line = 0;   // its line number (ASCII)
    unsigned long long vertex_count = 0;
    bool normals = false, uvs = false, colors = false; // what `vertex` carries
};

/// The scalar property `name` of `el`, or nullptr.
[[nodiscard]] inline PlyProperty* ply_scalar(PlyElement& el, std::string_view name) noexcept {
    for (PlyProperty& p : el.properties)
        if (p.count_type == PlyType::none && p.name == name) return &p;
    return nullptr;
}

/// Marks the attributes of `vertex` that isin reads: normals nx, ny, nz (all three, else none),
/// the first complete pair of texture coordinates in header order (s/t, u/v, texture_u/texture_v,
/// texture_s/texture_t), colours red, green, blue (all three, else none; alpha is not read).
inline void ply_mark_attributes(PlyElement& el, PlyHeader& h) {
    PlyProperty* const n[3] = {ply_scalar(el, "nx"), ply_scalar(el, "ny"), ply_scalar(el, "nz")};
    if (n[0] && n[1] && n[2]) {
        n[0]->role = PlyRole::nx, n[1]->role = PlyRole::ny, n[2]->role = PlyRole::nz;
        h.normals = true;
    }
    static constexpr const char* pairs[4][2] = {
        {"s", "t"}, {"u", "v"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
    for (std::size_t i = 0; i < el.properties.size() && !h.uvs; ++i) {
        for (const auto& pair : pairs) {
            if (el.properties[i].name != pair[0] && el.properties[i].name != pair[1]) continue;
            PlyProperty* const u = ply_scalar(el, pair[0]);
            PlyProperty* const v = ply_scalar(el, pair[1]);
            if (!u || !v) continue;
            u->role = PlyRole::tex_u, v->role = PlyRole::tex_v;
            h.uvs = true;
            break;
        }
    }
    PlyProperty* const c[3] = {ply_scalar(el, "red"), ply_scalar(el, "green"), ply_scalar(el, "blue")};
    if (c[0] && c[1] && c[2]) {
        const PlyRole roles[3] = {PlyRole::red, PlyRole::green, PlyRole::blue};
        for (int k = 0; k < 3; ++k) {
            c[k]->role = roles[k];
            if (ply_is_integer(c[k]->type)) c[k]->divisor = static_cast<double>(ply_range(c[k]->type).second);
        }
        h.colors = true;
    }
}

/// Checks the elements isin reads: `vertex` has x, y and z and at most 2^32 − 1 instances (its
/// attributes then marked), `face` its index list.
inline void ply_check_elements(const char* who, const std::string& path, PlyHeader& h) {
    for (PlyElement& el : h.elements) {
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
            if (el.count > std::numeric_limits<std::uint32_t>::max())
                throw mesh_error(who, path,
                                 "line " + std::to_string(el.line) + ": element 'vertex' declares " +
                                     std::to_string(el.count) +
                                     " vertices; isin's 32-bit indices address at most 2^32 - 1 = 4294967295");
            h.vertex_count = el.count;
            ply_mark_attributes(el, h);
        }
        if (el.name == "face" && !has(PlyRole::indices))
            throw mesh_error(who, path, at + "list property vertex_indices");
    }
}

/// Parses the header and marks the properties isin reads (x, y, z and the attributes of
/// `vertex`, the index list of `face`). Unknown keywords after the format line are skipped.
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
            if (tokens[1] == "ascii")
                h.format = PlyFormat::ascii;
            else if (tokens[1] == "binary_little_endian")
                h.format = PlyFormat::binary_little_endian;
            else if (tokens[1] == "binary_big_endian")
                h.format = PlyFormat::binary_big_endian;
            else
                throw fail("unknown PLY format " + mesh_quote(tokens[1].data(), tokens[1].data() + tokens[1].size()));
            if (tokens[2] != "1.0") throw fail("unsupported PLY version '" + tokens[2].substr(0, 40) + "'");
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
        } else if (!have_format) {
            throw fail("unknown header keyword " + mesh_quote(key.data(), key.data() + key.size()) +
                       " before the format line");
        } // else skipped, as other readers do: exporters write their own lines (Blender does)
    }
    if (!have_format) throw fail("header has no format line");
    h.data_offset = pos;
    h.data_line = line + 1;
    ply_check_elements(who, path, h);
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

/// The host's byte order: 1 little-endian, 2 big-endian, 0 unknown (then bytes are assembled one
/// by one).
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) && defined(__ORDER_BIG_ENDIAN__)
inline constexpr int ply_host_order = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ ? 1
                                      : __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__  ? 2
                                                                                : 0;
#elif defined(_MSC_VER) // every Windows target is little-endian
inline constexpr int ply_host_order = 1;
#else
inline constexpr int ply_host_order = 0;
#endif

/// Unsigned integer of n bytes.
template <std::size_t n>
using PlyUint = std::conditional_t<
    n == 1, std::uint8_t,
    std::conditional_t<n == 2, std::uint16_t, std::conditional_t<n == 4, std::uint32_t, std::uint64_t>>>;

/// `u` with its bytes reversed.
template <class U>
[[nodiscard]] inline U ply_byte_swap(U u) noexcept {
#if defined(__GNUC__) || defined(__clang__)
    if constexpr (sizeof(U) == 2)
        return __builtin_bswap16(u);
    else if constexpr (sizeof(U) == 4)
        return __builtin_bswap32(u);
    else
        return __builtin_bswap64(u);
#else
    std::uint64_t r = 0, w = u;
    for (std::size_t i = 0; i < sizeof(U); ++i, w >>= 8) r = (r << 8) | (w & 0xFFu);
    return static_cast<U>(r);
#endif
}

/// Binary data in byte order `Format` (binary_little_endian or binary_big_endian); positions are
/// byte offsets from the start of the file.
template <PlyFormat Format>
class PlyBinaryReader {
    static_assert(Format != PlyFormat::ascii, "PlyBinaryReader reads binary data");

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
        case PlyType::i8: return bits<std::int8_t>();
        case PlyType::u8: return bits<std::uint8_t>();
        case PlyType::i16: return bits<std::int16_t>();
        case PlyType::u16: return bits<std::uint16_t>();
        case PlyType::i32: return bits<std::int32_t>();
        case PlyType::u32: return bits<std::uint32_t>();
        default: fail("an integer type is needed here"); // not reached: the header checks it
        }
    }
    /// The next value, of the integer type I (a list's item type, resolved once a list).
    template <class I>
    long long read_int_as() {
        return bits<I>();
    }
    double read_real(PlyType t) {
        if (t == PlyType::f32) return static_cast<double>(bits<float>());
        if (t == PlyType::f64) return bits<double>();
        return static_cast<double>(read_int(t));
    }
    /// An attribute's value: as read_real (binary values cannot overflow a double).
    double read_attribute(PlyType t) { return read_real(t); }
    void skip(PlyType t) { take(ply_size(t)); }
    void skip_items(PlyType t, unsigned long long count) {
        start_ = pos_;
        if (!ply_fits(count, ply_size(t), size_ - pos_))
            truncated(context.text() + ": list of " + std::to_string(count) + " items");
        pos_ += static_cast<std::size_t>(count) * ply_size(t);
    }
    /// Throws unless `count` values of type t are left (a list about to be read).
    void need_items(PlyType t, unsigned long long count) const {
        if (!ply_fits(count, ply_size(t), size_ - pos_))
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
    /// The sizeof(V) bytes at the cursor, in the file's byte order, as a V: one copy, plus a
    /// byte swap where the host's order differs.
    template <class V>
    V bits() {
        constexpr std::size_t n = sizeof(V);
        constexpr bool big = Format == PlyFormat::binary_big_endian;
        const unsigned char* p = take(n);
        PlyUint<n> u = 0;
        if constexpr (ply_host_order != 0) {
            std::memcpy(&u, p, n);
            if constexpr (n > 1 && big != (ply_host_order == 2)) u = ply_byte_swap(u);
        } else {
            for (std::size_t i = 0; i < n; ++i) {
                const unsigned char byte = p[big ? i : n - 1 - i];
                u = static_cast<PlyUint<n>>((static_cast<std::uint64_t>(u) << 8) | byte);
            }
        }
        V v;
        std::memcpy(&v, &u, n);
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
    template <class I>
    long long read_int_as() {
        return read_int(ply_type_of<I>());
    }
    double read_real(PlyType t) { return real(t, false); }
    /// An attribute's value: as read_real, but a decimal beyond a double's range is infinite.
    double read_attribute(PlyType t) { return real(t, true); }
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
    double real(PlyType t, bool overflow_is_infinite) {
        if (ply_is_integer(t)) return static_cast<double>(read_int(t));
        next();
        double v = 0;
        const NumberStatus status = mesh_parse_real(tb_, te_, v);
        if (status == NumberStatus::ok) return v;
        constexpr double inf = std::numeric_limits<double>::infinity();
        const int special = mesh_special_word(tb_, te_); // NaN and infinity are values here
        if (special == 1) return std::numeric_limits<double>::quiet_NaN();
        if (special == 2 || (overflow_is_infinite && status == NumberStatus::out_of_range))
            return *tb_ == '-' ? -inf : inf;
        fail(mesh_bad_real("number", tb_, te_, status));
    }

    const char* who_;
    const std::string& path_;
    const char* data_;
    std::size_t size_, pos_, line_, start_line_;
    const char* tb_ = nullptr;
    const char* te_ = nullptr;
};

/// True when every one of the n values is finite and representable in T: an attribute that is
/// not is stored as zeros (a zero normal: no usable normal).
template <class T>
[[nodiscard]] inline bool ply_all_fit(const double* v, int n) noexcept {
    for (int k = 0; k < n; ++k)
        if (!mesh_fits<T>(v[k])) return false;
    return true;
}

/// Throws for a coordinate v that is NaN, infinite or beyond T's range.
template <class T, class Reader>
[[noreturn]] void ply_bad_coordinate(const Reader& r, PlyRole role, double v) {
    const std::string axis = role == PlyRole::x ? "x" : role == PlyRole::y ? "y" : "z";
    if (std::isnan(v)) r.fail("coordinate " + axis + " is NaN");
    if (!std::isfinite(v)) r.fail("coordinate " + axis + " is infinite");
    r.fail("coordinate " + axis + " = " + mesh_number(v) + " does not fit in " + mesh_type_name<T>());
}

/// Reads a face's n corner indices (items of type I) and appends its fan (v0, vi, vi+1).
template <class I, class Reader>
inline void ply_read_fan(Reader& r, long long n, unsigned long long vertex_count,
                         std::vector<std::array<std::uint32_t, 3>>& indices) {
    std::uint32_t v0 = 0, prev = 0;
    for (long long k = 0; k < n; ++k) {
        const long long index = r.template read_int_as<I>();
        if (index < 0 || static_cast<unsigned long long>(index) >= vertex_count)
            r.fail("vertex index " + std::to_string(index) + " is out of range (the file has " +
                   std::to_string(vertex_count) + " vertices)");
        const auto cur = static_cast<std::uint32_t>(index); // vertex_count ≤ 2^32 − 1
        if (k == 0)
            v0 = cur;
        else if (k > 1)
            indices.push_back({v0, prev, cur}); // fan (v0, vi, vi+1)
        prev = cur;
    }
}

/// Reads every element in order into `mesh`: the vertices' positions and attributes, the faces'
/// fans; `runs` records each polygon of 4 or more corners for retriangulate_fans.
template <class T, class Reader>
inline void ply_read_body(Reader& r, const PlyHeader& h, Mesh<T>& mesh, std::vector<FanRun>& runs) {
    constexpr auto attr = [](PlyRole role) { return static_cast<int>(role) - static_cast<int>(PlyRole::nx); };
    for (const PlyElement& el : h.elements) {
        if (el.properties.empty() || el.count == 0) continue;
        r.context = {&el, 0};
        r.check_room(el);
        const bool is_vertex = el.name == "vertex", is_face = el.name == "face";
        if (is_vertex) { // bounded by check_room; the attributes only where the file has them
            const auto n = static_cast<std::size_t>(el.count);
            mesh.positions.reserve(n);
            if (h.normals) mesh.normals.reserve(n);
            if (h.uvs) mesh.uvs.reserve(n);
            if (h.colors) mesh.colors.reserve(n);
        }
        if (is_face) // a real face has at least 3 indices: reserve no more than that allows
            mesh.indices.reserve(static_cast<std::size_t>(
                std::min<unsigned long long>(el.count, r.remaining() / (4 * Reader::least_size(PlyType::u8)))));
        for (unsigned long long i = 0; i < el.count; ++i) {
            r.context.index = i;
            T xyz[3] = {T(0), T(0), T(0)};
            double a[8]; // nx, ny, nz, u, v, red, green, blue as read (each set when its flag is)
            for (const PlyProperty& p : el.properties) {
                if (p.count_type == PlyType::none) {
                    if (p.role == PlyRole::skip) {
                        r.skip(p.type);
                        continue;
                    }
                    if (p.role >= PlyRole::nx) {
                        a[attr(p.role)] = r.read_attribute(p.type) / p.divisor;
                        continue;
                    }
                    const double v = r.read_real(p.type);
                    if (!mesh_fits<T>(v)) ply_bad_coordinate<T>(r, p.role, v); // one test while all is well
                    xyz[static_cast<int>(p.role) - static_cast<int>(PlyRole::x)] = static_cast<T>(v);
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
                if (n > 3) runs.push_back({mesh.indices.size(), static_cast<std::size_t>(n)});
                switch (p.type) { // the item type chosen once a face, not once an index
                case PlyType::i8: ply_read_fan<std::int8_t>(r, n, h.vertex_count, mesh.indices); break;
                case PlyType::u8: ply_read_fan<std::uint8_t>(r, n, h.vertex_count, mesh.indices); break;
                case PlyType::i16: ply_read_fan<std::int16_t>(r, n, h.vertex_count, mesh.indices); break;
                case PlyType::u16: ply_read_fan<std::uint16_t>(r, n, h.vertex_count, mesh.indices); break;
                case PlyType::i32: ply_read_fan<std::int32_t>(r, n, h.vertex_count, mesh.indices); break;
                default: ply_read_fan<std::uint32_t>(r, n, h.vertex_count, mesh.indices); break; // the header checks it
                }
            }
            if (!is_vertex) continue;
            mesh.positions.push_back({xyz[0], xyz[1], xyz[2]});
            if (h.normals) {
                const double* N = a + attr(PlyRole::nx);
                mesh.normals.push_back(ply_all_fit<T>(N, 3)
                                           ? Vertex<T>{static_cast<T>(N[0]), static_cast<T>(N[1]), static_cast<T>(N[2])}
                                           : Vertex<T>{T(0), T(0), T(0)});
            }
            if (h.uvs) {
                const double* uv = a + attr(PlyRole::tex_u);
                mesh.uvs.push_back(ply_all_fit<T>(uv, 2)
                                       ? std::array<T, 2>{static_cast<T>(uv[0]), static_cast<T>(uv[1])}
                                       : std::array<T, 2>{T(0), T(0)});
            }
            if (h.colors) {
                const double* c = a + attr(PlyRole::red);
                mesh.colors.push_back(ply_all_fit<T>(c, 3)
                                          ? Color<T>{static_cast<T>(c[0]), static_cast<T>(c[1]), static_cast<T>(c[2])}
                                          : Color<T>{T(0), T(0), T(0)});
            }
        }
    }
    r.context = {};
    r.finish();
}

/// The mesh of a PLY file's bytes: positions, the normals, texture coordinates and colours
/// `vertex` has (else empty), every face of n corners as n − 2 triangles (polygons triangulated
/// by retriangulate_fans, winding kept). Throws MeshError naming `name` and where.
template <class T>
[[nodiscard]] Mesh<T> parse_ply_mesh(const char* who, const std::string& name, std::string_view file) {
    static_assert(std::is_floating_point_v<T>, "isin::load_ply needs a floating-point type");
    const PlyHeader h = ply_parse_header(who, name, file);
    Mesh<T> mesh;
    std::vector<FanRun> runs;
    if (h.format == PlyFormat::binary_little_endian) {
        PlyBinaryReader<PlyFormat::binary_little_endian> r(who, name, file, h.data_offset);
        ply_read_body<T>(r, h, mesh, runs);
    } else if (h.format == PlyFormat::binary_big_endian) {
        PlyBinaryReader<PlyFormat::binary_big_endian> r(who, name, file, h.data_offset);
        ply_read_body<T>(r, h, mesh, runs);
    } else {
        PlyAsciiReader r(who, name, file, h.data_offset, h.data_line);
        ply_read_body<T>(r, h, mesh, runs);
    }
    if (!runs.empty()) retriangulate_fans(mesh.positions, mesh.indices, runs); // faces may precede vertices
    return mesh;
}

} // namespace detail

} // namespace isin
