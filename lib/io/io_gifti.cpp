// ricci — GIFTI surfaces and functional files (see io.h).
//
// Takes the bytes of a .gii file; gives a Mesh (the first data array of intent
// NIFTI_INTENT_POINTSET, #V×3, and the first of intent NIFTI_INTENT_TRIANGLE, #F×3) or per-vertex
// value arrays (every data array, #V or #V×1, any intent). Writes the same two kinds of file.
//
// The XML is parsed by expat; each <DataArray> is collected with its attributes, its MetaData
// entry "Name" and the text of its <Data>, then decoded:
//   ASCII             whitespace-separated decimal numbers
//   Base64Binary      base64 (whitespace ignored) of the values in the array's Endian
//   GZipBase64Binary  the same, zlib- or gzip-compressed; inflated by zlib to exactly the size that
//                     Dim0 × Dim1 × the DataType's size declare, never further
// ExternalFileBinary (the data in another file) is refused; gifticlib's spellings of the attribute
// values (GIFTI_ENCODING_B64GZ, GIFTI_ENDIAN_BIG, …) are read too. ColumnMajorOrder arrays are
// transposed into the row-major buffers of a Mesh. ASCII numbers of a FLOAT32 array are rounded to
// float, as the binary encodings hold them. Coordinates may have any numeric type, indices any
// integer type. Memory follows the data present, never a declared size: base64 text is decoded
// before its size is compared with the declaration, and inflated output grows with what the stream
// really yields. Line numbers in messages are those of the XML.
#include <expat.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "io_internal.h"

namespace ricci::io_detail {

namespace {

// ---------------------------------------------------------------------------------------------
// Data types, encodings and the layout of one data array.

enum class GiftiType : std::uint8_t { Uint8, Int8, Int16, Uint16, Int32, Uint32, Int64, Float32, Float64 };

struct GiftiTypeInfo {
  std::string_view name;  ///< the DataType attribute
  GiftiType type;
  std::int64_t bytes;
  bool is_float;
  std::int64_t min, max;  ///< range of the integer types
};

constexpr std::int64_t kInt64Min = std::numeric_limits<std::int64_t>::min();
constexpr std::int64_t kInt64Max = std::numeric_limits<std::int64_t>::max();

constexpr std::array<GiftiTypeInfo, 9> kTypes{{
    {"NIFTI_TYPE_UINT8", GiftiType::Uint8, 1, false, 0, 255},
    {"NIFTI_TYPE_INT8", GiftiType::Int8, 1, false, -128, 127},
    {"NIFTI_TYPE_INT16", GiftiType::Int16, 2, false, -32768, 32767},
    {"NIFTI_TYPE_UINT16", GiftiType::Uint16, 2, false, 0, 65535},
    {"NIFTI_TYPE_INT32", GiftiType::Int32, 4, false, -2147483648LL, 2147483647LL},
    {"NIFTI_TYPE_UINT32", GiftiType::Uint32, 4, false, 0, 4294967295LL},
    {"NIFTI_TYPE_INT64", GiftiType::Int64, 8, false, kInt64Min, kInt64Max},
    {"NIFTI_TYPE_FLOAT32", GiftiType::Float32, 4, true, 0, 0},
    {"NIFTI_TYPE_FLOAT64", GiftiType::Float64, 8, true, 0, 0},
}};

constexpr std::string_view kTypePrefix = "NIFTI_TYPE_";

/// "FLOAT32" for NIFTI_TYPE_FLOAT32.
std::string_view short_name(const GiftiTypeInfo& t) {
  return t.name.substr(kTypePrefix.size());
}

enum class Encoding : std::uint8_t { Ascii, Base64, GzipBase64, External };

/// Attribute spellings: the standard's, and the enumerator names that gifticlib 1.08 wrote
/// (Encoding="GIFTI_ENCODING_B64BIN", Endian="GIFTI_ENDIAN_LITTLE"), which nibabel reads too.
template <class T>
struct Spelling {
  std::string_view text;
  T value;
};
constexpr std::array<Spelling<Encoding>, 8> kEncodings{{
    {"ASCII", Encoding::Ascii},
    {"Base64Binary", Encoding::Base64},
    {"GZipBase64Binary", Encoding::GzipBase64},
    {"ExternalFileBinary", Encoding::External},
    {"GIFTI_ENCODING_ASCII", Encoding::Ascii},
    {"GIFTI_ENCODING_B64BIN", Encoding::Base64},
    {"GIFTI_ENCODING_B64GZ", Encoding::GzipBase64},
    {"GIFTI_ENCODING_EXTBIN", Encoding::External},
}};
/// Endian spellings (true: big-endian).
constexpr std::array<Spelling<bool>, 4> kEndians{{
    {"LittleEndian", false},
    {"BigEndian", true},
    {"GIFTI_ENDIAN_LITTLE", false},
    {"GIFTI_ENDIAN_BIG", true},
}};
/// ArrayIndexingOrder spellings (true: column-major).
constexpr std::array<Spelling<bool>, 4> kOrders{{
    {"RowMajorOrder", false},
    {"ColumnMajorOrder", true},
    {"GIFTI_IND_ORD_ROW_MAJOR", false},
    {"GIFTI_IND_ORD_COL_MAJOR", true},
}};

/// The value spelled `text`; false when none is.
template <class T, std::size_t N>
bool lookup(const std::array<Spelling<T>, N>& table, std::string_view text, T& value) {
  for (const Spelling<T>& s : table) {
    if (s.text == text) {
      value = s.value;
      return true;
    }
  }
  return false;
}

constexpr std::string_view kIntentPointset = "NIFTI_INTENT_POINTSET";
constexpr std::string_view kIntentTriangle = "NIFTI_INTENT_TRIANGLE";

/// A data array as the XML gives it: attribute values ("" when absent) and the text of <Data>.
struct XmlArray {
  std::int64_t index = 0;  ///< 0-based position among the file's data arrays
  std::int64_t line = 0;   ///< line of its <DataArray> tag
  std::string intent, data_type, encoding, endian, order, dimensionality, external_file;
  std::array<std::string, 2> dims;  ///< Dim0, Dim1
  bool has_name = false;
  std::string name;  ///< the value of the MetaData entry "Name"
  int data_elements = 0;
  std::int64_t data_line = 0;  ///< line where the text of <Data> starts
  std::string data;
};

/// What the element is for.
enum class Role : std::uint8_t {
  Coordinates,  ///< the pointset: #V×3 numbers
  Indices,      ///< the triangles: #F×3 integers in [0, #V)
  Values,       ///< a functional array: #V numbers, or #V×1
};

/// A data array validated for its role.
struct Layout {
  const GiftiTypeInfo* type = nullptr;
  Encoding encoding = Encoding::Ascii;
  bool big_endian = false;
  bool column_major = false;
  std::int64_t rows = 0;                               ///< Dim0
  std::int64_t cols = 1;                               ///< Dim1 (1 for a 1-D array)
  std::string encoding_name, endian_name, order_name;  ///< as in the file, for format_details
};

/// One array being read: where it is, what it is for, how to name it in messages.
struct ArrayRef {
  const XmlArray* xml = nullptr;
  Role role = Role::Values;
  std::string label;  ///< "the pointset (data array 0)", "data array 2 ('u')"
  Layout layout;
};

/// Values of an array in row-major order: `reals` for the float types, `integers` for the others.
struct Values {
  std::vector<double> reals;
  std::vector<std::int64_t> integers;
};

std::string array_label(const XmlArray& a, Role role) {
  const std::string index = "data array " + std::to_string(a.index);
  if (role == Role::Coordinates) return "the pointset (" + index + ")";
  if (role == Role::Indices) return "the triangle array (" + index + ")";
  return a.has_name && !a.name.empty() ? index + " (" + quote(a.name) + ")" : index;
}

/// "r×c" as declared.
std::string shape_text(const Layout& l) {
  return std::to_string(l.rows) + "×" + std::to_string(l.cols);
}

// ---------------------------------------------------------------------------------------------
// XML: expat → data arrays.

/// Collects the data arrays of a GIFTI document. `wanted` says, at an array's start tag, whether
/// its content is needed; `take` receives each wanted array at its end tag and returns false after
/// recording a failure. Failures (expat's or the callbacks') go to the ReadContext.
class GiftiXml {
 public:
  using Wanted = std::function<bool(const XmlArray&)>;
  using Take = std::function<bool(XmlArray&)>;

  GiftiXml(ReadContext& ctx, Wanted wanted, Take take)
      : ctx_(ctx), wanted_(std::move(wanted)), take_(std::move(take)) {}

  /// Parses the whole document; false once a failure has been recorded.
  bool parse(std::string_view data) {
    const std::unique_ptr<std::remove_pointer_t<XML_Parser>, decltype(&XML_ParserFree)> parser(
        XML_ParserCreate(nullptr), &XML_ParserFree);
    if (!parser) throw std::bad_alloc();
    parser_ = parser.get();
    XML_SetUserData(parser_, this);
    XML_SetElementHandler(parser_, &GiftiXml::on_start, &GiftiXml::on_end);
    XML_SetCharacterDataHandler(parser_, &GiftiXml::on_text);
    XML_SetEntityDeclHandler(parser_, &GiftiXml::on_entity);
    // XML_Parse takes an int length: feed files beyond 1 GiB in pieces.
    constexpr std::size_t kPiece = std::size_t{1} << 30;
    std::size_t done = 0;
    do {
      const std::size_t n = std::min(kPiece, data.size() - done);
      const bool last = done + n == data.size();
      const XML_Status status = XML_Parse(parser_, data.data() + done, static_cast<int>(n), last);
      if (pending_) std::rethrow_exception(pending_);
      if (failed_) return false;
      if (status != XML_STATUS_OK) return fail_expat();
      done += n;
    } while (done < data.size());
    if (!seen_root_) return ctx_.fail_at_line(Status::ParseError, 1, "the file holds no XML element");
    return true;
  }

  std::int64_t root_line() const { return root_line_; }
  const std::string& version() const { return version_; }
  std::int64_t arrays_seen() const { return arrays_seen_; }

 private:
  /// Where an element sits, as far as GIFTI is concerned.
  enum class Tag : std::uint8_t { Gifti, DataArray, ArrayMetaData, MD, MDName, MDValue, Data, Other };

  static void XMLCALL on_start(void* self, const XML_Char* name, const XML_Char** atts) {
    static_cast<GiftiXml*>(self)->guard([&] { static_cast<GiftiXml*>(self)->start(name, atts); });
  }
  static void XMLCALL on_end(void* self, const XML_Char*) {
    static_cast<GiftiXml*>(self)->guard([&] { static_cast<GiftiXml*>(self)->end(); });
  }
  static void XMLCALL on_text(void* self, const XML_Char* s, int len) {
    static_cast<GiftiXml*>(self)->guard(
        [&] { static_cast<GiftiXml*>(self)->text(std::string_view(s, static_cast<std::size_t>(len))); });
  }
  static void XMLCALL on_entity(void* self, const XML_Char* name, int, const XML_Char*, int, const XML_Char*,
                                const XML_Char*, const XML_Char*, const XML_Char*) {
    auto* x = static_cast<GiftiXml*>(self);
    x->guard([&] {
      x->stop(Status::ParseError,
              "the document declares the XML entity " + quote(name) +
                  "; GIFTI files declare none (refused: entities can expand without bound)");
    });
  }

  /// Runs a handler body; an exception (out of memory) stops the parser and is rethrown by parse(),
  /// outside expat's C frames.
  template <class F>
  void guard(F&& body) {
    if (failed_ || pending_) return;
    try {
      body();
    } catch (...) {
      pending_ = std::current_exception();
      XML_StopParser(parser_, XML_FALSE);
    }
  }

  std::int64_t line() const { return static_cast<std::int64_t>(XML_GetCurrentLineNumber(parser_)); }

  /// Records a failure at the current line and stops the parser.
  void stop(Status status, const std::string& what) {
    if (failed_) return;
    ctx_.fail_at_line(status, line(), what);
    failed_ = true;
    XML_StopParser(parser_, XML_FALSE);
  }

  bool fail_expat() {
    const XML_Error code = XML_GetErrorCode(parser_);
    const auto column = static_cast<std::int64_t>(XML_GetCurrentColumnNumber(parser_));
    return ctx_.fail_at_line(Status::ParseError, line(),
                             std::string("malformed XML: ") + XML_ErrorString(code) + " (column " +
                                 std::to_string(column + 1) + ")");
  }

  /// "<name>" for a message: at most 40 bytes, non-printable ones as \xNN (see quote()).
  static std::string shown_tag(std::string_view name) {
    const std::string q = quote(name);  // quoted: "…"
    std::string out(1, '<');
    out.append(q, 1, q.size() - 2);
    out.push_back('>');
    return out;
  }

  Tag classify(std::string_view name) const {
    const Tag parent = stack_.empty() ? Tag::Other : stack_.back();
    if (parent == Tag::Gifti && name == "DataArray") return Tag::DataArray;
    if (parent == Tag::DataArray && name == "MetaData") return Tag::ArrayMetaData;
    if (parent == Tag::DataArray && name == "Data") return Tag::Data;
    if (parent == Tag::ArrayMetaData && name == "MD") return Tag::MD;
    if (parent == Tag::MD && name == "Name") return Tag::MDName;
    if (parent == Tag::MD && name == "Value") return Tag::MDValue;
    return Tag::Other;
  }

  void start(std::string_view name, const XML_Char** atts) {
    if (!seen_root_) {
      seen_root_ = true;
      root_line_ = line();
      if (name != "GIFTI") {
        return stop(Status::ParseError,
                    "the root element is " + shown_tag(name) + ", not <GIFTI>: not a GIFTI file");
      }
      for (const XML_Char** a = atts; *a; a += 2) {
        if (std::string_view(a[0]) == "Version") version_ = a[1];
      }
      stack_.push_back(Tag::Gifti);
      return;
    }
    const Tag tag = classify(name);
    if (!stack_.empty() && stack_.back() == Tag::Data) {
      return stop(Status::ParseError, "data array " + std::to_string(current_.index) + ": element " +
                                          shown_tag(name) + " inside <Data>");
    }
    stack_.push_back(tag);
    if (tag == Tag::DataArray) return start_array(atts);
    if (!collecting_) return;
    if (tag == Tag::Data && ++current_.data_elements > 1) {
      return stop(Status::ParseError,
                  "data array " + std::to_string(current_.index) + " has more than one <Data> element");
    }
    if (tag == Tag::Data) current_.data_line = line();
    if (tag == Tag::MD) {
      md_name_.clear();
      md_value_.clear();
    }
  }

  void start_array(const XML_Char** atts) {
    current_ = XmlArray{};
    current_.index = arrays_seen_++;
    current_.line = line();
    for (const XML_Char** a = atts; *a; a += 2) {
      const std::string_view key = a[0];
      std::string* field = key == "Intent"               ? &current_.intent
                           : key == "DataType"           ? &current_.data_type
                           : key == "Encoding"           ? &current_.encoding
                           : key == "Endian"             ? &current_.endian
                           : key == "ArrayIndexingOrder" ? &current_.order
                           : key == "Dimensionality"     ? &current_.dimensionality
                           : key == "ExternalFileName"   ? &current_.external_file
                           : key == "Dim0"               ? &current_.dims[0]
                           : key == "Dim1"               ? &current_.dims[1]
                                                         : nullptr;
      if (field) *field = a[1];
    }
    collecting_ = wanted_(current_);
  }

  void end() {
    const Tag tag = stack_.back();
    stack_.pop_back();
    if (!collecting_) return;
    if (tag == Tag::MD && !current_.has_name && trimmed(md_name_) == "Name") {
      current_.has_name = true;
      current_.name = md_value_;
    }
    if (tag == Tag::DataArray) {
      collecting_ = false;
      if (!take_(current_)) {
        failed_ = true;  // recorded by take_
        XML_StopParser(parser_, XML_FALSE);
      }
      current_.data = std::string();
    }
  }

  void text(std::string_view s) {
    if (!collecting_ || stack_.empty()) return;
    switch (stack_.back()) {
      case Tag::Data:
        if (current_.data.empty()) current_.data_line = line();
        current_.data.append(s);
        break;
      case Tag::MDName:
        md_name_.append(s);
        break;
      case Tag::MDValue:
        md_value_.append(s);
        break;
      default:
        break;
    }
  }

  static std::string_view trimmed(std::string_view s) {
    const std::size_t first = s.find_first_not_of(" \t\r\n");
    if (first == std::string_view::npos) return {};
    return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
  }

  ReadContext& ctx_;
  Wanted wanted_;
  Take take_;
  XML_Parser parser_ = nullptr;
  std::exception_ptr pending_;
  bool failed_ = false;
  bool seen_root_ = false;
  std::int64_t root_line_ = 1;
  std::string version_;
  std::vector<Tag> stack_;
  bool collecting_ = false;
  XmlArray current_;
  std::int64_t arrays_seen_ = 0;
  std::string md_name_, md_value_;
};

// ---------------------------------------------------------------------------------------------
// Layout: the attributes of one array, checked for its role.

bool fail_array(ReadContext& ctx, const ArrayRef& ref, Status status, const std::string& what) {
  return ctx.fail_at_line(status, ref.xml->line, ref.label + " " + what);
}

/// Encoding and DataType.
bool read_encoding_and_type(ReadContext& ctx, ArrayRef& ref) {
  const XmlArray& a = *ref.xml;
  Layout& l = ref.layout;
  if (!lookup(kEncodings, a.encoding, l.encoding)) {
    return fail_array(ctx, ref, Status::ParseError,
                      "has the Encoding " + quote(a.encoding) +
                          " (expected ASCII, Base64Binary, GZipBase64Binary or ExternalFileBinary)");
  }
  if (l.encoding == Encoding::External) {
    return fail_array(ctx, ref, Status::UnknownFormat,
                      "keeps its data in the external file " + quote(a.external_file) + " (Encoding " +
                          quote(a.encoding) +
                          "), which ricci does not read; re-save the file with the data "
                          "inline (ASCII, Base64Binary or GZipBase64Binary)");
  }
  l.encoding_name = a.encoding;
  for (const GiftiTypeInfo& t : kTypes) {
    if (t.name == a.data_type) l.type = &t;
  }
  if (!l.type) {
    return fail_array(
        ctx, ref, Status::ParseError,
        "has the DataType " + quote(a.data_type) +
            " (expected NIFTI_TYPE_FLOAT32, FLOAT64, INT8, UINT8, INT16, UINT16, INT32, UINT32 or INT64)");
  }
  if (ref.role == Role::Indices && l.type->is_float) {
    return fail_array(ctx, ref, Status::ParseError,
                      "has the DataType " + a.data_type + "; vertex indices need an integer type");
  }
  return true;
}

bool read_dimension(ReadContext& ctx, const ArrayRef& ref, int d, std::int64_t& value) {
  const std::string& text = ref.xml->dims[static_cast<std::size_t>(d)];
  if (!parse_integer(text, value) || value < 0) {
    const std::string name = "Dim" + std::to_string(d);
    return fail_array(ctx, ref, Status::ParseError,
                      text.empty() ? "has no " + name + " attribute"
                                   : "has " + name + "=" + quote(text) + ", not a count of at least 0");
  }
  return true;
}

/// Dimensionality, Dim0, Dim1 and the limits of a Mesh.
bool read_shape(ReadContext& ctx, ArrayRef& ref) {
  const XmlArray& a = *ref.xml;
  Layout& l = ref.layout;
  std::int64_t dimensionality = 0;
  const bool per_vertex = ref.role == Role::Values;
  const bool valid = parse_integer(a.dimensionality, dimensionality) &&
                     (dimensionality == 2 || (per_vertex && dimensionality == 1));
  if (!valid) {
    return fail_array(
        ctx, ref, Status::ParseError,
        "has Dimensionality=" + quote(a.dimensionality) +
            (per_vertex ? "; per-vertex values are 1-D (#V) or 2-D (#V×1)" : "; it must be 2 (#N×3)"));
  }
  if (!read_dimension(ctx, ref, 0, l.rows)) return false;
  l.cols = 1;
  if (dimensionality == 2 && !read_dimension(ctx, ref, 1, l.cols)) return false;
  const std::int64_t want_cols = per_vertex ? 1 : 3;
  if (l.cols != want_cols) {
    return fail_array(
        ctx, ref, Status::ParseError,
        "is " + shape_text(l) + (per_vertex ? ", not #V×1: not one value per vertex" : ", not #N×3"));
  }
  const std::int64_t limit = ref.role == Role::Indices ? kMaxCorners / 3 : kMaxVertices;
  if (l.rows > limit) {
    return fail_array(ctx, ref, Status::FileTooLarge,
                      "declares " + std::to_string(l.rows) +
                          (ref.role == Role::Indices ? " triangles" : " vertices") +
                          ", more than ricci can index (" + std::to_string(limit) + ")");
  }
  return true;
}

/// Endian and ArrayIndexingOrder: required only where they change the meaning of the data.
bool read_order(ReadContext& ctx, ArrayRef& ref) {
  const XmlArray& a = *ref.xml;
  Layout& l = ref.layout;
  const bool binary = l.encoding != Encoding::Ascii;
  if (lookup(kEndians, a.endian, l.big_endian)) {
    l.endian_name = a.endian;
  } else if (!a.endian.empty()) {
    return fail_array(ctx, ref, Status::ParseError,
                      "has Endian=" + quote(a.endian) + " (expected BigEndian or LittleEndian)");
  } else if (binary && l.type->bytes > 1) {
    return fail_array(ctx, ref, Status::ParseError, "has no Endian attribute, which its binary data needs");
  }
  if (lookup(kOrders, a.order, l.column_major)) {
    l.order_name = a.order;
  } else if (!a.order.empty()) {
    return fail_array(
        ctx, ref, Status::ParseError,
        "has ArrayIndexingOrder=" + quote(a.order) + " (expected RowMajorOrder or ColumnMajorOrder)");
  } else if (l.cols > 1) {
    return fail_array(ctx, ref, Status::ParseError,
                      "has no ArrayIndexingOrder attribute, which a 2-D array needs");
  }
  return true;
}

bool read_layout(ReadContext& ctx, const XmlArray& a, Role role, ArrayRef& ref) {
  ref.xml = &a;
  ref.role = role;
  ref.label = array_label(a, role);
  return read_encoding_and_type(ctx, ref) && read_shape(ctx, ref) && read_order(ctx, ref);
}

// ---------------------------------------------------------------------------------------------
// Decoding.

/// Row (vertex, face) of the value stored at position k.
std::int64_t row_of(const Layout& l, std::int64_t k) {
  return l.column_major ? k % std::max<std::int64_t>(l.rows, 1) : k / l.cols;
}

/// A value that is NaN, infinite or beyond the range of its type.
bool fail_not_finite(ReadContext& ctx, const ArrayRef& ref, std::int64_t row, std::string_view token,
                     std::int64_t line, const char* why) {
  const std::string shown = token.empty() ? std::string() : " " + quote(token);
  if (ref.role == Role::Coordinates) {
    return ctx.fail_at_line(Status::NonFiniteCoordinate, line,
                            "vertex " + std::to_string(row) + " has a coordinate" + shown + " that is " + why,
                            Element::Vertex, row);
  }
  return ctx.fail_at_line(Status::NonFiniteCoordinate, line,
                          ref.label + ": the value of vertex " + std::to_string(row) + shown + " is " + why,
                          Element::Vertex, row);
}

/// A token that is not a number of the array's type.
bool fail_token(ReadContext& ctx, const ArrayRef& ref, std::int64_t k, std::string_view token,
                std::int64_t line) {
  const std::int64_t row = row_of(ref.layout, k);
  const std::string type(short_name(*ref.layout.type));
  if (ref.role == Role::Coordinates) {
    return fail_coordinate(ctx, NumberParse::Malformed, token, false, line, "vertex " + std::to_string(row),
                           row);
  }
  if (ref.role == Role::Indices) {
    return ctx.fail_at_line(Status::ParseError, line,
                            "face " + std::to_string(row) + " has a vertex index " + quote(token) +
                                " that is not an integer in the range of " + type,
                            Element::Face, row);
  }
  return ctx.fail_at_line(Status::ParseError, line,
                          ref.label + ": the value of vertex " + std::to_string(row) + ", " + quote(token) +
                              ", is not a number in the range of " + type,
                          Element::Vertex, row);
}

/// One ASCII token into `out` (reals or integers by the type). False after recording a failure.
bool parse_token(ReadContext& ctx, const ArrayRef& ref, std::int64_t k, std::string_view token,
                 std::int64_t line, Values& out) {
  const GiftiTypeInfo& t = *ref.layout.type;
  if (!t.is_float) {
    std::int64_t v = 0;
    if (!parse_integer(token, v) || v < t.min || v > t.max) return fail_token(ctx, ref, k, token, line);
    out.integers.push_back(v);
    return true;
  }
  double x = 0;
  const NumberParse parse = parse_real(token, x);
  if (parse == NumberParse::Malformed) return fail_token(ctx, ref, k, token, line);
  const std::int64_t row = row_of(ref.layout, k);
  if (parse == NumberParse::NonFinite) {
    return fail_not_finite(ctx, ref, row, token, line,
                           "not finite (NaN, infinite or beyond the range of a double)");
  }
  if (t.type == GiftiType::Float32) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (x > kMax || x < -kMax)
      return fail_not_finite(ctx, ref, row, token, line, "beyond the range of FLOAT32");
    x = static_cast<double>(static_cast<float>(x));  // the value a FLOAT32 array holds
  }
  out.reals.push_back(x);
  return true;
}

bool decode_ascii(ReadContext& ctx, const ArrayRef& ref, Values& out) {
  const XmlArray& a = *ref.xml;
  const Layout& l = ref.layout;
  const std::int64_t count = l.rows * l.cols;
  TextCursor cur(a.data, a.data_line, /*comments=*/false, /*continuations=*/false);
  const std::size_t room = capped_reservation(count, 2, a.data.size());
  if (l.type->is_float) {
    out.reals.reserve(room);
  } else {
    out.integers.reserve(room);
  }
  for (std::int64_t k = 0; k < count; ++k) {
    const std::string_view token = cur.token();
    if (token.empty()) {
      return ctx.fail_at_line(Status::ParseError, cur.line(),
                              "the data of " + ref.label + " ends after " + std::to_string(k) + " of the " +
                                  std::to_string(count) + " values declared (Dim0×Dim1 = " + shape_text(l) +
                                  ")");
    }
    if (!parse_token(ctx, ref, k, token, cur.line(), out)) return false;
  }
  const std::string_view extra = cur.token();
  if (!extra.empty()) {
    return ctx.fail_at_line(Status::ParseError, cur.line(),
                            "the data of " + ref.label + " has more than the " + std::to_string(count) +
                                " values declared (Dim0×Dim1 = " + shape_text(l) + "): " + quote(extra));
  }
  return true;
}

/// Value of each base64 character, -1 for the others.
constexpr std::array<std::int8_t, 256> kBase64 = [] {
  std::array<std::int8_t, 256> t{};
  t.fill(-1);
  constexpr std::string_view kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (std::size_t i = 0; i < kAlphabet.size(); ++i)
    t[static_cast<unsigned char>(kAlphabet[i])] = static_cast<std::int8_t>(i);
  return t;
}();

/// Decodes the base64 text of an array, ignoring whitespace; '=' padding is optional at the end.
bool base64_decode(ReadContext& ctx, const ArrayRef& ref, std::string& out) {
  const std::string& text = ref.xml->data;
  std::int64_t line = ref.xml->data_line;
  out.clear();
  out.reserve(text.size() / 4 * 3 + 3);
  std::uint32_t bits = 0;
  int held = 0;     // characters of the current group of 4
  int padding = 0;  // '=' seen
  auto bad = [&](const std::string& what) {
    return ctx.fail_at_line(Status::ParseError, line, "the base64 data of " + ref.label + " " + what);
  };
  for (const char c : text) {
    if (c == '\n') ++line;
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f') continue;
    if (c == '=') {
      if (held < 2 || padding >= 4 - held) return bad("has a misplaced padding character '='");
      ++padding;
      continue;
    }
    const int v = kBase64[static_cast<unsigned char>(c)];
    if (v < 0) return bad("has the character " + quote(std::string_view(&c, 1)) + ", which is not base64");
    if (padding > 0) return bad("continues after its padding '='");
    bits = (bits << 6) | static_cast<std::uint32_t>(v);
    if (++held == 4) {
      out += static_cast<char>((bits >> 16) & 0xff);
      out += static_cast<char>((bits >> 8) & 0xff);
      out += static_cast<char>(bits & 0xff);
      bits = 0;
      held = 0;
    }
  }
  if (held == 1) return bad("ends with a lone character (a base64 group needs at least 2)");
  if (held == 2) out += static_cast<char>((bits >> 4) & 0xff);
  if (held == 3) {
    out += static_cast<char>((bits >> 10) & 0xff);
    out += static_cast<char>((bits >> 2) & 0xff);
  }
  return true;
}

/// Ends a zlib stream when it goes out of scope.
struct InflateGuard {
  z_stream* zs;
  ~InflateGuard() { inflateEnd(zs); }
};

/// Inflates a zlib or gzip stream to exactly `expected` bytes. The output grows with what the
/// stream yields, so a small stream never makes a large declared size allocate.
bool inflate_exact(ReadContext& ctx, const ArrayRef& ref, std::string_view in, std::uint64_t expected,
                   std::string& out) {
  const std::int64_t line = ref.xml->data_line;
  const std::string declared = std::to_string(expected) + " bytes declared (" + shape_text(ref.layout) + " " +
                               std::string(short_name(*ref.layout.type)) + ")";
  out.clear();
  if (in.empty() && expected == 0) return true;
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw std::bad_alloc();  // 15 + 32: zlib or gzip header
  const InflateGuard guard{&zs};
  std::size_t fed = 0;
  char chunk[1 << 16];
  for (;;) {
    if (zs.avail_in == 0 && fed < in.size()) {
      const std::size_t n = std::min<std::size_t>(in.size() - fed, std::size_t{1} << 30);
      zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data() + fed));
      zs.avail_in = static_cast<uInt>(n);
      fed += n;
    }
    zs.next_out = reinterpret_cast<Bytef*>(chunk);
    zs.avail_out = sizeof chunk;
    const int rc = inflate(&zs, Z_NO_FLUSH);
    const std::size_t produced = sizeof chunk - zs.avail_out;
    if (out.size() + produced > expected) {
      return ctx.fail_at_line(
          Status::ParseError, line,
          "the compressed data of " + ref.label + " inflates to more than the " + declared);
    }
    out.append(chunk, produced);
    if (rc == Z_STREAM_END) break;
    if (rc == Z_MEM_ERROR) throw std::bad_alloc();
    if (rc == Z_BUF_ERROR && zs.avail_in == 0 && fed == in.size()) {
      return ctx.fail_at_line(Status::ParseError, line,
                              "the compressed data of " + ref.label + " ends early: it inflates to " +
                                  std::to_string(out.size()) + " of the " + declared);
    }
    if (rc != Z_OK && rc != Z_BUF_ERROR) {
      return ctx.fail_at_line(Status::ParseError, line,
                              "the compressed data of " + ref.label + " is corrupt (zlib: " +
                                  (zs.msg ? zs.msg : "error " + std::to_string(rc)) + ")");
    }
  }
  if (zs.avail_in != 0 || fed != in.size()) {
    return ctx.fail_at_line(Status::ParseError, line,
                            "the compressed data of " + ref.label + " has " +
                                std::to_string(zs.avail_in + (in.size() - fed)) +
                                " bytes after the end of its stream");
  }
  if (out.size() != expected) {
    return ctx.fail_at_line(Status::ParseError, line,
                            "the compressed data of " + ref.label + " inflates to only " +
                                std::to_string(out.size()) + " bytes, but Dim0×Dim1 need the " + declared);
  }
  return true;
}

/// The values of type T stored in `bytes`, in the array's byte order.
template <class T>
void load_values(std::string_view bytes, bool big_endian, Values& out) {
  const std::size_t n = bytes.size() / sizeof(T);
  if constexpr (std::is_floating_point_v<T>) {
    out.reals.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const T x = load_endian<T>(bytes.data() + i * sizeof(T), big_endian);
      // Non-finite values are flagged without converting them (a signalling NaN would trap).
      out.reals[i] = is_finite_bits(x) ? static_cast<double>(x) : std::numeric_limits<double>::quiet_NaN();
    }
  } else {
    out.integers.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      out.integers[i] = static_cast<std::int64_t>(load_endian<T>(bytes.data() + i * sizeof(T), big_endian));
  }
}

void values_from_bytes(std::string_view bytes, const Layout& l, Values& out) {
  switch (l.type->type) {
    case GiftiType::Uint8:
      return load_values<std::uint8_t>(bytes, l.big_endian, out);
    case GiftiType::Int8:
      return load_values<std::int8_t>(bytes, l.big_endian, out);
    case GiftiType::Int16:
      return load_values<std::int16_t>(bytes, l.big_endian, out);
    case GiftiType::Uint16:
      return load_values<std::uint16_t>(bytes, l.big_endian, out);
    case GiftiType::Int32:
      return load_values<std::int32_t>(bytes, l.big_endian, out);
    case GiftiType::Uint32:
      return load_values<std::uint32_t>(bytes, l.big_endian, out);
    case GiftiType::Int64:
      return load_values<std::int64_t>(bytes, l.big_endian, out);
    case GiftiType::Float32:
      return load_values<float>(bytes, l.big_endian, out);
    case GiftiType::Float64:
      return load_values<double>(bytes, l.big_endian, out);
  }
}

bool decode_binary(ReadContext& ctx, const ArrayRef& ref, Values& out) {
  const Layout& l = ref.layout;
  const auto expected = static_cast<std::uint64_t>(l.rows * l.cols * l.type->bytes);
  std::string bytes;
  if (!base64_decode(ctx, ref, bytes)) return false;
  if (l.encoding == Encoding::GzipBase64) {
    std::string raw;
    if (!inflate_exact(ctx, ref, bytes, expected, raw)) return false;
    bytes = std::move(raw);
  } else if (bytes.size() != expected) {
    return ctx.fail_at_line(Status::ParseError, ref.xml->data_line,
                            "the data of " + ref.label + " holds " + std::to_string(bytes.size()) +
                                " bytes, but " + shape_text(l) + " values of " +
                                std::string(short_name(*l.type)) + " need " + std::to_string(expected));
  }
  values_from_bytes(bytes, l, out);
  return true;
}

/// Column-major #rows×#cols storage into row-major.
template <class T>
void to_row_major(std::vector<T>& v, std::int64_t rows, std::int64_t cols) {
  if (v.empty()) return;
  std::vector<T> t(v.size());
  const auto r = static_cast<std::size_t>(rows), c = static_cast<std::size_t>(cols);
  for (std::size_t j = 0; j < c; ++j)
    for (std::size_t i = 0; i < r; ++i) t[i * c + j] = v[j * r + i];
  v.swap(t);
}

/// Decodes an array into row-major values: reals for Coordinates and Values (finite), integers for
/// Indices. False after recording a failure.
bool decode_array(ReadContext& ctx, const ArrayRef& ref, Values& out) {
  const Layout& l = ref.layout;
  if (!(l.encoding == Encoding::Ascii ? decode_ascii(ctx, ref, out) : decode_binary(ctx, ref, out)))
    return false;
  if (l.column_major && l.cols > 1) {
    to_row_major(out.reals, l.rows, l.cols);
    to_row_major(out.integers, l.rows, l.cols);
  }
  if (ref.role == Role::Indices) return true;
  if (!l.type->is_float) {
    out.reals.assign(out.integers.begin(), out.integers.end());
    out.integers = {};
  }
  for (std::size_t i = 0; i < out.reals.size(); ++i) {
    if (!is_finite_bits(out.reals[i])) {
      return fail_not_finite(ctx, ref, static_cast<std::int64_t>(i) / l.cols, {}, ref.xml->data_line,
                             "not finite (NaN or infinite)");
    }
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Surfaces.

/// The triangle indices into faces, each in [0, #V).
bool take_faces(ReadContext& ctx, const ArrayRef& ref, const std::vector<std::int64_t>& indices,
                std::int64_t num_vertices, std::vector<Index>& faces) {
  faces.resize(indices.size());
  for (std::size_t c = 0; c < indices.size(); ++c) {
    const std::int64_t v = indices[c];
    if (v < 0 || v >= num_vertices) {
      const auto f = static_cast<std::int64_t>(c / 3);
      return ctx.fail_at_line(Status::IndexOutOfRange, ref.xml->data_line,
                              "face " + std::to_string(f) + " refers to vertex " + std::to_string(v) +
                                  ", but the pointset has " + count_of(num_vertices, "vertex", "vertices") +
                                  " (GIFTI indices start at 0)",
                              Element::Face, f);
    }
    faces[c] = static_cast<Index>(v);
  }
  return true;
}

/// "FLOAT32 GZipBase64Binary LittleEndian RowMajorOrder" (the attributes present).
std::string describe(const Layout& l) {
  std::string s(short_name(*l.type));
  for (const std::string* part : {&l.encoding_name, &l.endian_name, &l.order_name}) {
    if (!part->empty()) s += " " + *part;
  }
  return s;
}

/// Printable characters of the Version attribute, at most 20.
std::string printable(std::string_view s) {
  std::string out;
  for (const char c : s.substr(0, 20)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return out;
}

}  // namespace

bool read_gifti(std::string_view data, ReadContext& ctx) {
  std::unique_ptr<XmlArray> arrays[2];  // pointset, triangles: the first of each intent
  auto slot = [](const XmlArray& a) {
    return a.intent == kIntentPointset ? 0 : a.intent == kIntentTriangle ? 1 : -1;
  };
  GiftiXml xml(
      ctx, [&](const XmlArray& a) { return slot(a) >= 0 && !arrays[slot(a)]; },
      [&](XmlArray& a) {
        const int i = slot(a);  // before the move (the right side of = is evaluated first)
        arrays[i] = std::make_unique<XmlArray>(std::move(a));
        return true;
      });
  if (!xml.parse(data)) return false;
  for (int i = 0; i < 2; ++i) {
    if (arrays[i]) continue;
    return ctx.fail_at_line(Status::ParseError, xml.root_line(),
                            std::string("the file has no data array of intent ") +
                                std::string(i == 0 ? kIntentPointset : kIntentTriangle) + " (it has " +
                                count_of(xml.arrays_seen(), "data array", "data arrays") +
                                "); not a GIFTI surface");
  }
  ArrayRef points, triangles;
  if (!read_layout(ctx, *arrays[0], Role::Coordinates, points) ||
      !read_layout(ctx, *arrays[1], Role::Indices, triangles))
    return false;
  ReadResult& r = ctx.result();
  Values p, t;
  if (!decode_array(ctx, points, p)) return false;
  arrays[0].reset();  // points.xml is not used any more
  r.mesh.positions = std::move(p.reals);
  if (!decode_array(ctx, triangles, t)) return false;
  if (!take_faces(ctx, triangles, t.integers, points.layout.rows, r.mesh.faces)) return false;
  r.polygons_read = triangles.layout.rows;
  r.format_details = "GIFTI" + (xml.version().empty() ? std::string() : " " + printable(xml.version())) +
                     "; pointset: " + describe(points.layout) + "; triangles: " + describe(triangles.layout);
  return true;
}

bool read_gifti_overlay(std::string_view data, ReadContext& ctx, OverlayReadResult& out) {
  GiftiXml xml(
      ctx, [](const XmlArray&) { return true; },
      [&](XmlArray& a) {
        ArrayRef ref;
        Values v;
        if (!read_layout(ctx, a, Role::Values, ref) || !decode_array(ctx, ref, v)) return false;
        if (!out.arrays.empty() && v.reals.size() != out.arrays.front().size()) {
          return ctx.fail_at_line(Status::ParseError, a.line,
                                  ref.label + " has " + count_of(ref.layout.rows, "value", "values") +
                                      ", but data array 0 has " + std::to_string(out.arrays.front().size()) +
                                      " (every array of a functional file holds one value per vertex)");
        }
        out.arrays.push_back(std::move(v.reals));
        out.names.push_back(a.has_name ? a.name : std::string());
        return true;
      });
  if (!xml.parse(data)) return false;
  if (out.arrays.empty()) {
    return ctx.fail_at_line(Status::ParseError, xml.root_line(), "the file has no data arrays");
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Writing.

namespace {

void append_base64(std::string& out, std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  out.reserve(out.size() + (bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  auto byte = [&](std::size_t k) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[k])); };
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t b = (byte(i) << 16) | (byte(i + 1) << 8) | byte(i + 2);
    for (int s = 18; s >= 0; s -= 6) out += kAlphabet[(b >> s) & 63];
  }
  const std::size_t rest = bytes.size() - i;
  if (rest == 0) return;
  const std::uint32_t b = (byte(i) << 16) | (rest == 2 ? byte(i + 1) << 8 : 0);
  out += kAlphabet[(b >> 18) & 63];
  out += kAlphabet[(b >> 12) & 63];
  out += rest == 2 ? kAlphabet[(b >> 6) & 63] : '=';
  out += '=';
}

/// zlib stream (default level: deterministic for a given zlib) of `bytes`.
std::string compress_bytes(std::string_view bytes) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::string out(size, '\0');
  const int rc =
      compress2(reinterpret_cast<Bytef*>(out.data()), &size, reinterpret_cast<const Bytef*>(bytes.data()),
                static_cast<uLong>(bytes.size()), Z_DEFAULT_COMPRESSION);
  if (rc != Z_OK) throw std::bad_alloc();  // Z_MEM_ERROR; Z_BUF_ERROR cannot happen with compressBound
  out.resize(size);
  return out;
}

/// Text for XML content: & < > escaped, a carriage return as &#13; (a parser would turn it into a
/// newline), valid UTF-8 kept; bytes of invalid UTF-8 and characters XML cannot hold become '?'.
void append_xml_text(std::string& out, std::string_view s) {
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      if (c == '&')
        out += "&amp;";
      else if (c == '<')
        out += "&lt;";
      else if (c == '>')
        out += "&gt;";
      else if (c == '\r')
        out += "&#13;";
      else if (c >= 0x20 || c == '\t' || c == '\n')
        out += static_cast<char>(c);
      else
        out += '?';
      ++i;
      continue;
    }
    const int n = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC0 ? 2 : 0;
    std::uint32_t cp = n == 4 ? c & 0x07u : n == 3 ? c & 0x0Fu : c & 0x1Fu;
    bool ok = n > 0 && c < 0xF5 && i + static_cast<std::size_t>(n) <= s.size();
    for (int k = 1; ok && k < n; ++k) {
      const auto d = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
      ok = (d & 0xC0) == 0x80;
      cp = (cp << 6) | (d & 0x3Fu);
    }
    constexpr std::uint32_t kMinOfLength[5] = {0, 0, 0x80, 0x800, 0x10000};
    ok = ok && cp >= kMinOfLength[n] && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF) && cp != 0xFFFE &&
         cp != 0xFFFF;
    if (ok) {
      out.append(s.substr(i, static_cast<std::size_t>(n)));
      i += static_cast<std::size_t>(n);
    } else {
      out += '?';
      ++i;
    }
  }
}

void append_header(std::string& out, int arrays) {
  out += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<!DOCTYPE GIFTI SYSTEM \"http://www.nitrc.org/frs/download.php/115/gifti.dtd\">\n";
  out += "<GIFTI Version=\"1.0\" NumberOfDataArrays=\"";
  append_integer(out, arrays);
  out += "\">\n  <MetaData/>\n  <LabelTable/>\n";
}

/// What varies between the data arrays ricci writes.
struct ArraySpec {
  std::string_view intent, data_type;
  std::int64_t rows = 0, cols = 0;         ///< cols 0: a 1-D array
  const std::string_view* name = nullptr;  ///< MetaData Name, when given
  bool transform = false;                  ///< write the identity CoordinateSystemTransformMatrix
};

/// One data array; `bytes` are its little-endian values, written GZipBase64Binary.
void append_data_array(std::string& out, const ArraySpec& spec, std::string_view bytes) {
  out += "  <DataArray Intent=\"";
  out += spec.intent;
  out += "\"\n             DataType=\"";
  out += spec.data_type;
  out += "\"\n             ArrayIndexingOrder=\"RowMajorOrder\"\n             Dimensionality=\"";
  out += spec.cols > 0 ? '2' : '1';
  out += "\"\n             Dim0=\"";
  append_integer(out, spec.rows);
  if (spec.cols > 0) {
    out += "\"\n             Dim1=\"";
    append_integer(out, spec.cols);
  }
  out +=
      "\"\n             Encoding=\"GZipBase64Binary\"\n             Endian=\"LittleEndian\"\n"
      "             ExternalFileName=\"\"\n             ExternalFileOffset=\"\">\n";
  if (spec.name) {
    out += "    <MetaData>\n      <MD>\n        <Name>Name</Name>\n        <Value>";
    append_xml_text(out, *spec.name);
    out += "</Value>\n      </MD>\n    </MetaData>\n";
  } else {
    out += "    <MetaData/>\n";
  }
  if (spec.transform) {
    out +=
        "    <CoordinateSystemTransformMatrix>\n"
        "      <DataSpace>NIFTI_XFORM_UNKNOWN</DataSpace>\n"
        "      <TransformedSpace>NIFTI_XFORM_UNKNOWN</TransformedSpace>\n"
        "      <MatrixData>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</MatrixData>\n"
        "    </CoordinateSystemTransformMatrix>\n";
  }
  out += "    <Data>";
  append_base64(out, compress_bytes(bytes));
  out += "</Data>\n  </DataArray>\n";
}

}  // namespace

void append_gifti(const Mesh& mesh, std::string& out) {
  const std::size_t nv = mesh.positions.size() / 3;
  const std::size_t nf = mesh.faces.size() / 3;
  append_header(out, 2);
  std::string bytes;
  bytes.reserve(12 * std::max(nv, nf));
  for (std::size_t i = 0; i < 3 * nv; ++i) append_endian<float>(bytes, to_float(mesh.positions[i]), false);
  append_data_array(
      out, {kIntentPointset, "NIFTI_TYPE_FLOAT32", static_cast<std::int64_t>(nv), 3, nullptr, true}, bytes);
  bytes.clear();
  for (std::size_t c = 0; c < 3 * nf; ++c)
    append_endian<std::int32_t>(bytes, static_cast<std::int32_t>(mesh.faces[c]), false);
  append_data_array(
      out, {kIntentTriangle, "NIFTI_TYPE_INT32", static_cast<std::int64_t>(nf), 3, nullptr, false}, bytes);
  out += "</GIFTI>\n";
}

void append_gifti_overlay(std::span<const double> values, std::string_view name, std::string& out) {
  append_header(out, 1);
  std::string bytes;
  bytes.reserve(4 * values.size());
  for (const double x : values) append_endian<float>(bytes, to_float(x), false);
  append_data_array(
      out,
      {"NIFTI_INTENT_SHAPE", "NIFTI_TYPE_FLOAT32", static_cast<std::int64_t>(values.size()), 0, &name, false},
      bytes);
  out += "</GIFTI>\n";
}

}  // namespace ricci::io_detail
