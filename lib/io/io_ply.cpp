// ricci — PLY reader (ascii, binary little- and big-endian) and writer (see io.h).
//
// The header is parsed into elements and properties; the body is then read element by element
// through a "value source" (AsciiValues or BinaryValues<big_endian>) so that one templated body
// reader serves all three encodings. Only element `vertex` (x, y, z) and element `face` (list
// vertex_indices or vertex_index) are kept; every other element and property is skipped.
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "io_internal.h"

namespace ricci::io_detail {

namespace {

// ---------------------------------------------------------------------------------------------
// Header.

enum class PlyType : std::uint8_t { Int8, Uint8, Int16, Uint16, Int32, Uint32, Float32, Float64 };

struct PlyTypeName {
  std::string_view name;
  PlyType type;
};
constexpr std::array<PlyTypeName, 16> kPlyTypeNames{{
    {"char", PlyType::Int8},
    {"int8", PlyType::Int8},
    {"uchar", PlyType::Uint8},
    {"uint8", PlyType::Uint8},
    {"short", PlyType::Int16},
    {"int16", PlyType::Int16},
    {"ushort", PlyType::Uint16},
    {"uint16", PlyType::Uint16},
    {"int", PlyType::Int32},
    {"int32", PlyType::Int32},
    {"uint", PlyType::Uint32},
    {"uint32", PlyType::Uint32},
    {"float", PlyType::Float32},
    {"float32", PlyType::Float32},
    {"double", PlyType::Float64},
    {"float64", PlyType::Float64},
}};

bool parse_type(std::string_view name, PlyType& type) {
  for (const PlyTypeName& t : kPlyTypeNames) {
    if (t.name == name) {
      type = t.type;
      return true;
    }
  }
  return false;
}

std::int64_t type_size(PlyType t) {
  switch (t) {
    case PlyType::Int8:
    case PlyType::Uint8:
      return 1;
    case PlyType::Int16:
    case PlyType::Uint16:
      return 2;
    case PlyType::Int32:
    case PlyType::Uint32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 1;
}

bool is_integer_type(PlyType t) {
  return t != PlyType::Float32 && t != PlyType::Float64;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;  ///< the scalar type, or the item type of a list
  bool is_list = false;
  PlyType count_type = PlyType::Uint8;  ///< lists only
};

struct PlyElement {
  std::string name;
  std::int64_t count = 0;
  std::int64_t line = 0;  ///< header line that declares it
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::Ascii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;  ///< first byte after end_header's newline
  std::int64_t body_line = 1;   ///< line where the body starts (ascii)
};

/// Parses the header lines of a PLY file, from `ply` to `end_header`.
class PlyHeaderParser {
 public:
  PlyHeaderParser(std::string_view data, ReadContext& ctx) : cur_(data, 1, false, false), ctx_(ctx) {}

  bool run(PlyHeader& header) {
    cur_.skip_byte_order_mark();
    if (cur_.token_on_line() != "ply" || !cur_.at_line_end()) {
      return ctx_.fail_at_line(Status::ParseError, 1, "the file does not start with the line 'ply'");
    }
    cur_.next_line();
    bool have_format = false;
    for (;;) {
      if (cur_.at_end())
        return ctx_.fail_at_line(Status::ParseError, cur_.line(), "the header has no end_header line");
      const std::string_view keyword = cur_.token_on_line();
      bool ok = true;
      if (keyword == "end_header") {
        if (!have_format)
          return ctx_.fail_at_line(Status::ParseError, cur_.line(), "the header has no format line");
        cur_.next_line();
        header.body_offset = cur_.offset();
        header.body_line = cur_.line();
        return true;
      }
      if (keyword == "format") {
        ok = parse_format(header);
        have_format = true;
      } else if (keyword == "element") {
        ok = parse_element(header);
      } else if (keyword == "property") {
        ok = parse_property(header);
      } else if (!keyword.empty() && keyword != "comment" && keyword != "obj_info") {
        ok = fail("unknown header keyword " + quote(keyword));
      }
      if (!ok) return false;
      cur_.next_line();
    }
  }

 private:
  bool fail(const std::string& what) { return ctx_.fail_at_line(Status::ParseError, cur_.line(), what); }

  /// `format ascii|binary_little_endian|binary_big_endian VERSION`
  bool parse_format(PlyHeader& header) {
    const std::string_view encoding = cur_.token_on_line();
    if (encoding == "ascii") {
      header.encoding = PlyEncoding::Ascii;
    } else if (encoding == "binary_little_endian") {
      header.encoding = PlyEncoding::BinaryLittleEndian;
    } else if (encoding == "binary_big_endian") {
      header.encoding = PlyEncoding::BinaryBigEndian;
    } else {
      return ctx_.fail_at_line(Status::UnknownFormat, cur_.line(),
                               "unknown PLY format " + quote(encoding) +
                                   " (expected ascii, binary_little_endian or binary_big_endian)");
    }
    if (cur_.token_on_line().empty()) return fail("the format line has no version");
    return true;
  }

  /// `element NAME COUNT`
  bool parse_element(PlyHeader& header) {
    PlyElement element;
    element.line = cur_.line();
    element.name = std::string(cur_.token_on_line());
    const std::string_view count = cur_.token_on_line();
    if (element.name.empty() || !parse_integer(count, element.count) || element.count < 0) {
      return fail("expected 'element NAME COUNT' with a count of at least 0");
    }
    header.elements.push_back(std::move(element));
    return true;
  }

  /// `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`
  bool parse_property(PlyHeader& header) {
    if (header.elements.empty()) return fail("a property is declared before any element");
    PlyProperty property;
    std::string_view type = cur_.token_on_line();
    if (type == "list") {
      property.is_list = true;
      const std::string_view count_type = cur_.token_on_line();
      if (!parse_type(count_type, property.count_type)) return fail("unknown PLY type " + quote(count_type));
      if (!is_integer_type(property.count_type))
        return fail("the length of a list must have an integer type");
      type = cur_.token_on_line();
    }
    if (!parse_type(type, property.type)) return fail("unknown PLY type " + quote(type));
    property.name = std::string(cur_.token_on_line());
    if (property.name.empty()) return fail("the property has no name");
    header.elements.back().properties.push_back(std::move(property));
    return true;
  }

  TextCursor cur_;
  ReadContext& ctx_;
};

/// Where the data ricci reads sits in the header.
struct PlyLayout {
  std::int64_t vertex_element = -1;
  /// For each property of the vertex element: 0, 1, 2 for x, y, z, else -1.
  std::vector<int> vertex_slot;
  std::int64_t face_element = -1;
  std::int64_t face_list = -1;  ///< property index of vertex_indices
  std::int64_t num_vertices = 0;
};

bool find_vertex_layout(const PlyElement& e, ReadContext& ctx, PlyLayout& layout) {
  static constexpr const char* kAxes[3] = {"x", "y", "z"};
  layout.vertex_slot.assign(e.properties.size(), -1);
  for (int d = 0; d < 3; ++d) {
    bool found = false;
    for (std::size_t k = 0; k < e.properties.size() && !found; ++k) {
      if (e.properties[k].name != kAxes[d]) continue;
      if (e.properties[k].is_list) {
        return ctx.fail_at_line(
            Status::ParseError, e.line,
            std::string("property ") + kAxes[d] + " of element vertex is a list, not a number");
      }
      layout.vertex_slot[k] = d;
      found = true;
    }
    if (!found) {
      return ctx.fail_at_line(Status::ParseError, e.line,
                              std::string("element vertex has no property ") + kAxes[d]);
    }
  }
  if (e.count > kMaxVertices) {
    return ctx.fail_at_line(Status::FileTooLarge, e.line,
                            "element vertex declares " + std::to_string(e.count) +
                                " vertices, more than ricci can index (" + std::to_string(kMaxVertices) +
                                ")");
  }
  layout.num_vertices = e.count;
  return true;
}

bool find_face_layout(const PlyElement& e, ReadContext& ctx, PlyLayout& layout) {
  for (std::size_t k = 0; k < e.properties.size(); ++k) {
    const PlyProperty& p = e.properties[k];
    if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
    if (!p.is_list) {
      return ctx.fail_at_line(Status::ParseError, e.line,
                              "property " + p.name + " of element face is not a list");
    }
    if (!is_integer_type(p.type)) {
      return ctx.fail_at_line(Status::ParseError, e.line,
                              "property " + p.name + " of element face has a non-integer type");
    }
    if (e.count > kMaxCorners / 3) {
      return ctx.fail_at_line(Status::FileTooLarge, e.line,
                              "element face declares " + std::to_string(e.count) +
                                  " faces, more than ricci can index (" + std::to_string(kMaxCorners / 3) +
                                  ")");
    }
    layout.face_list = static_cast<std::int64_t>(k);
    return true;
  }
  return ctx.fail_at_line(Status::ParseError, e.line,
                          "element face has no list property vertex_indices (or vertex_index)");
}

/// Finds element vertex (x, y, z) and element face (its index list); the first of each name counts.
bool find_layout(const PlyHeader& header, ReadContext& ctx, PlyLayout& layout) {
  for (std::size_t i = 0; i < header.elements.size(); ++i) {
    const PlyElement& e = header.elements[i];
    if (e.name == "vertex" && layout.vertex_element < 0) {
      if (!find_vertex_layout(e, ctx, layout)) return false;
      layout.vertex_element = static_cast<std::int64_t>(i);
    } else if (e.name == "face" && layout.face_element < 0) {
      if (!find_face_layout(e, ctx, layout)) return false;
      layout.face_element = static_cast<std::int64_t>(i);
    }
  }
  return true;
}

/// Fewest bytes one record of `e` can take: binary, the sizes of its scalars and list lengths;
/// ascii, two characters (a digit and a separator) per scalar and per list length.
std::int64_t min_record_bytes(const PlyElement& e, PlyEncoding encoding) {
  std::int64_t bytes = 0;
  for (const PlyProperty& p : e.properties) {
    if (encoding == PlyEncoding::Ascii) {
      bytes += 2;
    } else {
      bytes += type_size(p.is_list ? p.count_type : p.type);
    }
  }
  return bytes;
}

/// Reserves the mesh buffers for the declared vertex and face counts, capped by what the body
/// can hold (see capped_reservation()).
void reserve(const PlyHeader& header, const PlyLayout& layout, std::size_t body_bytes, Mesh& mesh) {
  auto element = [&](std::int64_t i) -> const PlyElement& {
    return header.elements[static_cast<std::size_t>(i)];
  };
  if (layout.vertex_element >= 0) {
    const PlyElement& e = element(layout.vertex_element);
    mesh.positions.reserve(3 * capped_reservation(e.count, min_record_bytes(e, header.encoding), body_bytes));
  }
  if (layout.face_element >= 0) {
    const PlyElement& e = element(layout.face_element);
    mesh.faces.reserve(3 * capped_reservation(e.count, min_record_bytes(e, header.encoding), body_bytes));
  }
}

// ---------------------------------------------------------------------------------------------
// Body: value sources.

enum class ValueRead { Ok, End, Malformed, NonFinite };

/// Values of an ascii body: whitespace-separated tokens. where() is the line of the last token.
class AsciiValues {
 public:
  static constexpr bool kBinary = false;

  AsciiValues(std::string_view data, const PlyHeader& header)
      : cur_(data.substr(header.body_offset), header.body_line, false, false) {}

  ValueRead real(PlyType, double& value) {
    if (!next()) return ValueRead::End;
    switch (parse_real(token_, value)) {
      case NumberParse::Ok:
        return ValueRead::Ok;
      case NumberParse::NonFinite:
        return ValueRead::NonFinite;
      case NumberParse::Malformed:
        break;
    }
    return ValueRead::Malformed;
  }
  ValueRead integer(PlyType, std::int64_t& value) {
    if (!next()) return ValueRead::End;
    return parse_integer(token_, value) ? ValueRead::Ok : ValueRead::Malformed;
  }
  ValueRead skip(PlyType) { return next() ? ValueRead::Ok : ValueRead::End; }
  ValueRead skip_items(PlyType, std::int64_t n) {
    for (std::int64_t i = 0; i < n; ++i) {
      if (!next()) return ValueRead::End;
    }
    return ValueRead::Ok;
  }
  std::int64_t where() const { return cur_.line(); }
  std::string_view token() const { return token_; }

 private:
  bool next() {
    token_ = cur_.token();
    return !token_.empty();
  }

  TextCursor cur_;
  std::string_view token_;
};

/// Values of a binary body in either byte order. where() is the offset of the last value
/// started, or the file size once the data has run out.
template <bool kBigEndian>
class BinaryValues {
 public:
  static constexpr bool kBinary = true;

  BinaryValues(std::string_view data, const PlyHeader& header) : data_(data), pos_(header.body_offset) {}

  ValueRead real(PlyType t, double& value) {
    const char* p = take(t);
    if (!p) return ValueRead::End;
    if (t == PlyType::Float32) {
      const auto f = std::bit_cast<float>(load<std::uint32_t>(p));
      if (!is_finite_bits(f)) return ValueRead::NonFinite;
      value = static_cast<double>(f);
    } else if (t == PlyType::Float64) {
      const auto d = std::bit_cast<double>(load<std::uint64_t>(p));
      if (!is_finite_bits(d)) return ValueRead::NonFinite;
      value = d;
    } else {
      value = static_cast<double>(integer_at(t, p));
    }
    return ValueRead::Ok;
  }
  ValueRead integer(PlyType t, std::int64_t& value) {
    if (!is_integer_type(t)) return ValueRead::Malformed;  // excluded by the header checks
    const char* p = take(t);
    if (!p) return ValueRead::End;
    value = integer_at(t, p);
    return ValueRead::Ok;
  }
  ValueRead skip(PlyType t) { return take(t) ? ValueRead::Ok : ValueRead::End; }
  ValueRead skip_items(PlyType t, std::int64_t n) {
    start_ = pos_;
    if (n > static_cast<std::int64_t>(data_.size() - pos_) / type_size(t)) {
      start_ = data_.size();
      return ValueRead::End;
    }
    pos_ += static_cast<std::size_t>(n * type_size(t));
    return ValueRead::Ok;
  }
  std::int64_t where() const { return static_cast<std::int64_t>(start_); }
  std::string_view token() const { return {}; }

 private:
  /// Pointer to the next value of type t and advances past it; nullptr when the data ends.
  const char* take(PlyType t) {
    const auto size = static_cast<std::size_t>(type_size(t));
    start_ = pos_;
    if (data_.size() - pos_ < size) {
      start_ = data_.size();
      return nullptr;
    }
    const char* p = data_.data() + pos_;
    pos_ += size;
    return p;
  }
  /// Unsigned integer of sizeof(U) bytes in the file's byte order.
  template <class U>
  static U load(const char* p) {
    U u = 0;
    for (std::size_t i = 0; i < sizeof(U); ++i) {
      const std::size_t shift = 8 * (kBigEndian ? sizeof(U) - 1 - i : i);
      u = static_cast<U>(u | static_cast<U>(static_cast<U>(static_cast<unsigned char>(p[i])) << shift));
    }
    return u;
  }
  static std::int64_t integer_at(PlyType t, const char* p) {
    switch (t) {
      case PlyType::Int8:
        return static_cast<std::int8_t>(load<std::uint8_t>(p));
      case PlyType::Uint8:
        return load<std::uint8_t>(p);
      case PlyType::Int16:
        return static_cast<std::int16_t>(load<std::uint16_t>(p));
      case PlyType::Uint16:
        return load<std::uint16_t>(p);
      case PlyType::Int32:
        return static_cast<std::int32_t>(load<std::uint32_t>(p));
      case PlyType::Uint32:
        return load<std::uint32_t>(p);
      case PlyType::Float32:
      case PlyType::Float64:
        break;
    }
    return 0;
  }

  std::string_view data_;
  std::size_t pos_;
  std::size_t start_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Body: elements.

/// Reads every element of the body from a value source.
template <class Values>
class PlyBodyReader {
 public:
  PlyBodyReader(Values values, const PlyHeader& header, const PlyLayout& layout, ReadContext& ctx)
      : in_(std::move(values)), header_(header), layout_(layout), ctx_(ctx), mesh_(ctx.result().mesh) {}

  bool run() {
    for (std::size_t i = 0; i < header_.elements.size(); ++i) {
      const PlyElement& e = header_.elements[i];
      if (e.properties.empty()) continue;  // nothing to read, however large the count
      const auto index = static_cast<std::int64_t>(i);
      const Role role = index == layout_.vertex_element ? Role::Vertex
                        : index == layout_.face_element ? Role::Face
                                                        : Role::Other;
      for (std::int64_t r = 0; r < e.count; ++r) {
        if (!read_record(e, role, r)) return false;
      }
    }
    return true;
  }

 private:
  enum class Role { Vertex, Face, Other };

  bool read_record(const PlyElement& e, Role role, std::int64_t r) {
    double xyz[3] = {0.0, 0.0, 0.0};
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const PlyProperty& p = e.properties[k];
      ValueRead read = ValueRead::Ok;
      if (p.is_list && role == Role::Face && static_cast<std::int64_t>(k) == layout_.face_list) {
        if (!read_polygon(e, p, r)) return false;
        continue;
      }
      if (p.is_list) {
        std::int64_t n = 0;
        read = in_.integer(p.count_type, n);
        if (read == ValueRead::Ok && n < 0) return fail_negative_length(e, p, r, role, n);
        if (read == ValueRead::Ok) read = in_.skip_items(p.type, n);
      } else if (role == Role::Vertex && layout_.vertex_slot[k] >= 0) {
        read = in_.real(p.type, xyz[layout_.vertex_slot[k]]);
        if (read == ValueRead::Malformed || read == ValueRead::NonFinite) {
          const NumberParse parse =
              read == ValueRead::NonFinite ? NumberParse::NonFinite : NumberParse::Malformed;
          return fail_coordinate(ctx_, parse, in_.token(), Values::kBinary, in_.where(),
                                 "vertex " + std::to_string(r), r);
        }
      } else {
        read = in_.skip(p.type);
      }
      if (read != ValueRead::Ok) return fail_value(read, e, p, r, role);
    }
    if (role == Role::Vertex) mesh_.positions.insert(mesh_.positions.end(), xyz, xyz + 3);
    return true;
  }

  /// The face list: length n ≥ 3, then n vertex indices in [0, #V).
  bool read_polygon(const PlyElement& e, const PlyProperty& p, std::int64_t f) {
    std::int64_t n = 0;
    ValueRead read = in_.integer(p.count_type, n);
    if (read != ValueRead::Ok) return fail_value(read, e, p, f, Role::Face);
    const std::int64_t start = in_.where();
    if (n < 3) {
      return ctx_.fail_at(Status::ParseError, Values::kBinary, in_.where(),
                          "face " + std::to_string(f) + " has " + count_of(n, "vertex", "vertices") +
                              "; a face needs at least 3",
                          Element::Face, f);
    }
    polygon_.clear();
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t index = 0;
      read = in_.integer(p.type, index);
      if (read != ValueRead::Ok) return fail_value(read, e, p, f, Role::Face);
      if (index < 0 || index >= layout_.num_vertices) {
        return ctx_.fail_at(Status::IndexOutOfRange, Values::kBinary, in_.where(),
                            "face " + std::to_string(f) + " refers to vertex " + std::to_string(index) +
                                ", but the file has " + count_of(layout_.num_vertices, "vertex", "vertices"),
                            Element::Face, f);
      }
      polygon_.push_back(static_cast<Index>(index));
    }
    return append_polygon(ctx_, polygon_, start, Values::kBinary);
  }

  static Element element_of(Role role) {
    return role == Role::Vertex ? Element::Vertex : role == Role::Face ? Element::Face : Element::None;
  }

  bool fail_value(ValueRead read, const PlyElement& e, const PlyProperty& p, std::int64_t r, Role role) {
    const std::string record = "record " + std::to_string(r) + " of element " + e.name;
    const Element element = element_of(role);
    const std::int64_t index = element == Element::None ? -1 : r;
    if (read == ValueRead::End) {
      return ctx_.fail_at(
          Status::ParseError, Values::kBinary, in_.where(),
          "the file ends in " + record + " (the header declares " + std::to_string(e.count) + ")", element,
          index);
    }
    return ctx_.fail_at(Status::ParseError, Values::kBinary, in_.where(),
                        record + ": property " + p.name + " has the value " + quote(in_.token()) +
                            ", which is not a valid " + (p.is_list ? "list length or item" : "number"),
                        element, index);
  }

  bool fail_negative_length(const PlyElement& e, const PlyProperty& p, std::int64_t r, Role role,
                            std::int64_t n) {
    const Element element = element_of(role);
    return ctx_.fail_at(Status::ParseError, Values::kBinary, in_.where(),
                        "record " + std::to_string(r) + " of element " + e.name + ": list " + p.name +
                            " has the negative length " + std::to_string(n),
                        element, element == Element::None ? -1 : r);
  }

  Values in_;
  const PlyHeader& header_;
  const PlyLayout& layout_;
  ReadContext& ctx_;
  Mesh& mesh_;
  std::vector<Index> polygon_;
};

template <class Values>
bool read_body(std::string_view data, const PlyHeader& header, const PlyLayout& layout, ReadContext& ctx) {
  return PlyBodyReader<Values>(Values(data, header), header, layout, ctx).run();
}

// ---------------------------------------------------------------------------------------------
// Writing.

/// Appends the low sizeof(U) bytes of u, least significant first.
template <class U>
void append_little_endian(std::string& out, U u) {
  for (std::size_t i = 0; i < sizeof(U); ++i) out += static_cast<char>((u >> (8 * i)) & 0xff);
}

}  // namespace

bool read_ply(std::string_view data, ReadContext& ctx) {
  PlyHeader header;
  PlyLayout layout;
  if (!PlyHeaderParser(data, ctx).run(header)) return false;
  if (!find_layout(header, ctx, layout)) return false;
  ctx.result().format = header.encoding == PlyEncoding::Ascii ? FileFormat::PlyAscii : FileFormat::PlyBinary;
  reserve(header, layout, data.size() - header.body_offset, ctx.result().mesh);
  switch (header.encoding) {
    case PlyEncoding::Ascii:
      return read_body<AsciiValues>(data, header, layout, ctx);
    case PlyEncoding::BinaryLittleEndian:
      return read_body<BinaryValues<false>>(data, header, layout, ctx);
    case PlyEncoding::BinaryBigEndian:
      return read_body<BinaryValues<true>>(data, header, layout, ctx);
  }
  return false;
}

void append_ply(const Mesh& mesh, bool binary, std::string& out) {
  const std::size_t nv = mesh.positions.size() / 3;
  const std::size_t nf = mesh.faces.size() / 3;
  out.reserve(out.size() + 256 + (binary ? nv * 24 + nf * 13 : nv * 62 + nf * 26));
  out += "ply\nformat ";
  out += binary ? "binary_little_endian" : "ascii";
  out += " 1.0\ncomment written by ricci\nelement vertex ";
  append_integer(out, static_cast<std::int64_t>(nv));
  out += "\nproperty double x\nproperty double y\nproperty double z\nelement face ";
  append_integer(out, static_cast<std::int64_t>(nf));
  out += "\nproperty list uchar int vertex_indices\nend_header\n";
  if (binary) {
    for (std::size_t i = 0; i < 3 * nv; ++i)
      append_little_endian(out, std::bit_cast<std::uint64_t>(mesh.positions[i]));
    for (std::size_t f = 0; f < nf; ++f) {
      out += static_cast<char>(3);
      for (int k = 0; k < 3; ++k)
        append_little_endian(out, static_cast<std::uint32_t>(mesh.faces[3 * f + k]));
    }
    return;
  }
  append_vertex_lines(mesh, out);
  append_triangle_lines(mesh, out);
}

}  // namespace ricci::io_detail
