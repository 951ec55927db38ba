// Tests of the GIFTI reader and writer (io_gifti.cpp): exact round trips of single-precision
// surfaces and of functional overlays; hand-built documents (written here, independently of the
// library) in every encoding, byte order, index order and data type; named errors with their
// lines and elements; hostile declared sizes; truncated and corrupted files; and files exchanged
// with nibabel, an independent implementation (skipped when python3-nibabel is absent).
#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/io.h"
#include "support.h"

namespace {

using ricci::Element;
using ricci::FileFormat;
using ricci::Index;
using ricci::Mesh;
using ricci::OverlayFormat;
using ricci::OverlayReadResult;
using ricci::ReadResult;
using ricci::Status;
using ricci_test::TempDir;

// ---------------------------------------------------------------------------------------------
// Meshes.

/// Six vertices with coordinates that every data type holds exactly (small integers), eight faces.
Mesh octahedron() {
  Mesh m;
  m.positions = {2, 0, 0, -2, 0, 0, 0, 3, 0, 0, -3, 0, 0, 0, 4, 1, 1, -4};
  m.faces = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return m;
}

/// Random float coordinates (special values included) and random faces: exact in GIFTI.
Mesh random_float_mesh(std::uint32_t seed) {
  std::mt19937 rng(seed);
  static const float kSpecial[] = {0.0f,
                                   -0.0f,
                                   1.0f,
                                   0.1f,
                                   -1.0f / 3.0f,
                                   std::numeric_limits<float>::max(),
                                   -std::numeric_limits<float>::max(),
                                   std::numeric_limits<float>::min(),
                                   std::numeric_limits<float>::denorm_min(),
                                   16777217.0f};
  Mesh m;
  const int nv = 3 + static_cast<int>(rng() % 60);
  const int nf = 1 + static_cast<int>(rng() % 90);
  for (int i = 0; i < 3 * nv; ++i) {
    const float x = rng() % 4 == 0 ? kSpecial[rng() % std::size(kSpecial)]
                                   : static_cast<float>(static_cast<std::int32_t>(rng())) * 0x1p-20f;
    m.positions.push_back(static_cast<double>(x));
  }
  for (int i = 0; i < 3 * nf; ++i)
    m.faces.push_back(static_cast<Index>(rng() % static_cast<std::uint32_t>(nv)));
  return m;
}

/// Coordinates k/64 (exact in float and in nibabel's "%10.6f" ASCII), random faces.
Mesh sixty_fourths_mesh() {
  std::mt19937 rng(64);
  Mesh m;
  for (int i = 0; i < 3 * 30; ++i)
    m.positions.push_back(static_cast<double>(static_cast<int>(rng() % 513) - 256) / 64.0);
  for (int i = 0; i < 3 * 50; ++i) m.faces.push_back(static_cast<Index>(rng() % 30));
  return m;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

std::vector<double> as_doubles(const std::vector<Index>& v) {
  return {v.begin(), v.end()};
}

// ---------------------------------------------------------------------------------------------
// An independent GIFTI writer: every encoding, byte order, index order and data type.

enum class Enc { Ascii, Base64, Zlib, Gzip };  ///< Zlib and Gzip: GZipBase64Binary with either header

struct TypeSpec {
  const char* name;
  int bytes;
  bool is_float;
};
constexpr TypeSpec kFloat32{"NIFTI_TYPE_FLOAT32", 4, true};
constexpr TypeSpec kFloat64{"NIFTI_TYPE_FLOAT64", 8, true};
constexpr TypeSpec kIntegerTypes[] = {{"NIFTI_TYPE_INT32", 4, false}, {"NIFTI_TYPE_UINT8", 1, false},
                                      {"NIFTI_TYPE_INT16", 2, false}, {"NIFTI_TYPE_UINT16", 2, false},
                                      {"NIFTI_TYPE_INT64", 8, false}, {"NIFTI_TYPE_UINT32", 4, false},
                                      {"NIFTI_TYPE_INT8", 1, false}};

const char* encoding_attribute(Enc e) {
  return e == Enc::Ascii ? "ASCII" : e == Enc::Base64 ? "Base64Binary" : "GZipBase64Binary";
}

/// One value in the type's binary form and the given byte order.
void put_value(std::string& out, const TypeSpec& t, double x, bool big_endian) {
  unsigned char b[8] = {};
  if (t.is_float && t.bytes == 4) {
    const auto u = std::bit_cast<std::uint32_t>(static_cast<float>(x));
    for (int i = 0; i < 4; ++i) b[i] = static_cast<unsigned char>(u >> (8 * i));
  } else if (t.is_float) {
    const auto u = std::bit_cast<std::uint64_t>(x);
    for (int i = 0; i < 8; ++i) b[i] = static_cast<unsigned char>(u >> (8 * i));
  } else {
    const auto u = static_cast<std::uint64_t>(static_cast<std::int64_t>(x));  // two's complement
    for (int i = 0; i < t.bytes; ++i) b[i] = static_cast<unsigned char>(u >> (8 * i));
  }
  if (big_endian) std::reverse(b, b + t.bytes);
  out.append(reinterpret_cast<const char*>(b), static_cast<std::size_t>(t.bytes));
}

std::string base64(std::string_view bytes, bool wrap) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    std::uint32_t group = 0;
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    for (std::size_t k = 0; k < 3; ++k)
      group = (group << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(group >> (18 - 6 * k)) & 63] : '=';
    if (wrap && (i / 3) % 19 == 18) out += "\n        ";  // whitespace inside the data is ignored
  }
  return out;
}

std::uint32_t adler32(std::string_view s) {
  std::uint32_t a = 1, b = 0;
  for (const char c : s) {
    a = (a + static_cast<unsigned char>(c)) % 65521;
    b = (b + a) % 65521;
  }
  return (b << 16) | a;
}

std::uint32_t crc32(std::string_view s) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (const char c : s) {
    crc ^= static_cast<unsigned char>(c);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

/// Deflate "stored" blocks (RFC 1951 §3.2.4): valid compressed data without a compressor.
std::string stored_blocks(std::string_view s) {
  std::string out;
  std::size_t i = 0;
  do {
    const std::size_t n = std::min<std::size_t>(s.size() - i, 65535);
    out += static_cast<char>(i + n == s.size() ? 1 : 0);  // BFINAL, BTYPE 00
    for (const std::uint32_t v : {static_cast<std::uint32_t>(n), static_cast<std::uint32_t>(~n & 0xFFFF)}) {
      out += static_cast<char>(v & 0xFF);
      out += static_cast<char>((v >> 8) & 0xFF);
    }
    out.append(s.substr(i, n));
    i += n;
  } while (i < s.size());
  return out;
}

/// A zlib (RFC 1950) or gzip (RFC 1952) stream of `s`.
std::string compressed(std::string_view s, bool gzip) {
  std::string out;
  auto put32 = [&](std::uint32_t v, bool big) {
    for (int k = 0; k < 4; ++k) out += static_cast<char>((v >> (big ? 24 - 8 * k : 8 * k)) & 0xFF);
  };
  if (gzip) {
    out.append("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff", 10);
    out += stored_blocks(s);
    put32(crc32(s), false);
    put32(static_cast<std::uint32_t>(s.size()), false);
  } else {
    out.append("\x78\x01", 2);
    out += stored_blocks(s);
    put32(adler32(s), true);
  }
  return out;
}

/// One data array of a hand-built document. `values` are row-major.
struct ArrayDoc {
  std::string intent = "NIFTI_INTENT_POINTSET";
  TypeSpec type = kFloat32;
  Enc encoding = Enc::Base64;
  bool big_endian = false;
  bool column_major = false;
  std::int64_t rows = 0;
  std::int64_t cols = 3;  ///< 0: a 1-D array
  std::vector<double> values;
  std::string name;  ///< MetaData Name; none when empty
};

ArrayDoc pointset(const Mesh& m, TypeSpec type = kFloat32, Enc e = Enc::Base64) {
  ArrayDoc a;
  a.type = type;
  a.encoding = e;
  a.rows = m.num_vertices();
  a.values = m.positions;
  return a;
}

ArrayDoc triangles(const Mesh& m, TypeSpec type = kIntegerTypes[0], Enc e = Enc::Base64) {
  ArrayDoc a;
  a.intent = "NIFTI_INTENT_TRIANGLE";
  a.type = type;
  a.encoding = e;
  a.rows = m.num_faces();
  a.values = as_doubles(m.faces);
  return a;
}

/// The values in the stored order (column-major transposes a 2-D array).
std::vector<double> stored_order(const ArrayDoc& a) {
  if (!a.column_major || a.cols <= 1) return a.values;
  std::vector<double> t(a.values.size());
  const auto r = static_cast<std::size_t>(a.rows), c = static_cast<std::size_t>(a.cols);
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < c; ++j) t[j * r + i] = a.values[i * c + j];
  return t;
}

/// The text of <Data>.
std::string encode_data(const ArrayDoc& a) {
  const std::vector<double> v = stored_order(a);
  if (a.encoding == Enc::Ascii) {
    std::string text = "\n";
    for (std::size_t i = 0; i < v.size(); ++i) {
      char buf[40];
      if (a.type.is_float) {
        std::snprintf(buf, sizeof buf, "%.17g", v[i]);
      } else {
        std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(v[i]));
      }
      text += buf;
      text += (a.cols > 1 && i % static_cast<std::size_t>(a.cols) == static_cast<std::size_t>(a.cols) - 1)
                  ? "\n"
                  : " ";
    }
    return text;
  }
  std::string bytes;
  for (const double x : v) put_value(bytes, a.type, x, a.big_endian);
  if (a.encoding == Enc::Base64) return base64(bytes, true);
  return base64(compressed(bytes, a.encoding == Enc::Gzip), true);
}

/// A DataArray element with the given <Data> text.
std::string data_array(const ArrayDoc& a, const std::string& data) {
  std::string s = "  <DataArray Intent=\"" + a.intent + "\" DataType=\"" + a.type.name + "\"\n";
  s += std::string("    ArrayIndexingOrder=\"") + (a.column_major ? "ColumnMajorOrder" : "RowMajorOrder") +
       "\"\n";
  s += "    Dimensionality=\"" + std::string(a.cols > 0 ? "2" : "1") + "\" Dim0=\"" + std::to_string(a.rows) +
       "\"";
  if (a.cols > 0) s += " Dim1=\"" + std::to_string(a.cols) + "\"";
  s += std::string("\n    Encoding=\"") + encoding_attribute(a.encoding) + "\" Endian=\"" +
       (a.big_endian ? "BigEndian" : "LittleEndian") + "\" ExternalFileName=\"\" ExternalFileOffset=\"\">\n";
  if (!a.name.empty()) {
    s += "    <MetaData>\n      <MD><Name><![CDATA[Description]]></Name><Value>x</Value></MD>\n";
    s += "      <MD>\n        <Name><![CDATA[Name]]></Name>\n        <Value><![CDATA[" + a.name +
         "]]></Value>\n";
    s += "      </MD>\n    </MetaData>\n";
  }
  s += "    <Data>" + data + "</Data>\n  </DataArray>\n";
  return s;
}

std::string document(const std::vector<std::string>& arrays) {
  std::string s = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  s += "<!DOCTYPE GIFTI SYSTEM \"http://www.nitrc.org/frs/download.php/115/gifti.dtd\">\n";
  s += "<GIFTI Version=\"1.0\" NumberOfDataArrays=\"" + std::to_string(arrays.size()) + "\">\n";
  s += "  <MetaData><MD><Name>date</Name><Value>today</Value></MD></MetaData>\n  <LabelTable/>\n";
  for (const std::string& a : arrays) s += a;
  s += "</GIFTI>\n";
  return s;
}

std::string document(const std::vector<ArrayDoc>& arrays) {
  std::vector<std::string> parts;
  for (const ArrayDoc& a : arrays) parts.push_back(data_array(a, encode_data(a)));
  return document(parts);
}

/// `s` with the first `from` replaced by `to`; fails the test when `from` is absent.
std::string replaced(std::string s, std::string_view from, std::string_view to) {
  const std::size_t at = s.find(from);
  REQUIRE_MESSAGE(at != std::string::npos, "not found: " << from);
  return s.replace(at, from.size(), to);
}

/// Reads a surface from a heap buffer of exactly its size (AddressSanitizer sees any overrun).
ReadResult read_surface(std::string_view data, const std::string& name = "x.surf.gii") {
  const std::unique_ptr<char[]> copy(new char[std::max<std::size_t>(data.size(), 1)]);
  if (!data.empty()) std::memcpy(copy.get(), data.data(), data.size());
  return ricci::read_mesh_from_memory(std::string_view(copy.get(), data.size()), name);
}

OverlayReadResult read_func(std::string_view data, const std::string& name = "u.func.gii") {
  const std::unique_ptr<char[]> copy(new char[std::max<std::size_t>(data.size(), 1)]);
  if (!data.empty()) std::memcpy(copy.get(), data.data(), data.size());
  return ricci::read_overlay_from_memory(std::string_view(copy.get(), data.size()), name,
                                         OverlayFormat::GiftiFunc);
}

bool contains(const std::string& s, std::string_view part) {
  return s.find(part) != std::string::npos;
}

/// A failure with the status, "x.surf.gii: line N: " and every part given.
void check_failure(const ReadResult& r, Status status, std::initializer_list<std::string_view> parts) {
  INFO(r.message);
  CHECK(r.status == status);
  CHECK(r.message.rfind("x.surf.gii: line ", 0) == 0);
  CHECK(r.line > 0);
  for (const std::string_view p : parts) CHECK_MESSAGE(contains(r.message, p), "missing: " << p);
}

}  // namespace

// =============================================================================================
// Round trips.

TEST_CASE("gifti: surface round trip through serialize_mesh is exact for float coordinates") {
  for (const std::uint32_t seed : {1u, 2u, 3u, 4u, 5u, 99u}) {
    CAPTURE(seed);
    const Mesh m = random_float_mesh(seed);
    const std::string bytes = ricci::serialize_mesh(m, FileFormat::Gifti);
    REQUIRE(!bytes.empty());
    CHECK(bytes == ricci::serialize_mesh(m, FileFormat::Gifti));  // deterministic
    CHECK(ricci::format_from_content(bytes) == FileFormat::Gifti);
    const ReadResult r = ricci::read_mesh_from_memory(bytes, "x.surf.gii");
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.format == FileFormat::Gifti);
    CHECK(same_bits(r.mesh.positions, m.positions));
    CHECK(r.mesh.faces == m.faces);
    CHECK(r.polygons_read == m.num_faces());
    CHECK(r.polygons_triangulated == 0);
    CHECK(r.format_details ==
          "GIFTI 1.0; pointset: FLOAT32 GZipBase64Binary LittleEndian RowMajorOrder; "
          "triangles: INT32 GZipBase64Binary LittleEndian RowMajorOrder");
  }
}

TEST_CASE("gifti: the written surface has the attributes Connectome Workbench expects") {
  const std::string s = ricci::serialize_mesh(octahedron(), FileFormat::Gifti);
  for (const char* part : {"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!DOCTYPE GIFTI",
                           "<GIFTI Version=\"1.0\" NumberOfDataArrays=\"2\"",
                           "Intent=\"NIFTI_INTENT_POINTSET\"",
                           "Intent=\"NIFTI_INTENT_TRIANGLE\"",
                           "DataType=\"NIFTI_TYPE_FLOAT32\"",
                           "DataType=\"NIFTI_TYPE_INT32\"",
                           "Dimensionality=\"2\"",
                           "Dim0=\"6\"",
                           "Dim0=\"8\"",
                           "Dim1=\"3\"",
                           "Encoding=\"GZipBase64Binary\"",
                           "Endian=\"LittleEndian\"",
                           "ArrayIndexingOrder=\"RowMajorOrder\"",
                           "ExternalFileName=\"\"",
                           "ExternalFileOffset=\"\"",
                           "<CoordinateSystemTransformMatrix>",
                           "<DataSpace>NIFTI_XFORM_UNKNOWN</DataSpace>",
                           "<TransformedSpace>NIFTI_XFORM_UNKNOWN</TransformedSpace>",
                           "<MatrixData>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</MatrixData>",
                           "</GIFTI>\n"}) {
    CHECK_MESSAGE(contains(s, part), part);
  }
  // One transform, on the pointset (before the triangle array).
  CHECK(s.find("<CoordinateSystemTransformMatrix>") < s.find("NIFTI_INTENT_TRIANGLE"));
  CHECK(s.find("<CoordinateSystemTransformMatrix>", s.find("NIFTI_INTENT_TRIANGLE")) == std::string::npos);
}

TEST_CASE("gifti: doubles are stored as float32, empty meshes and files round trip") {
  Mesh m = octahedron();
  m.positions[0] = 0.1;
  m.positions[4] = 1.0 / 3.0;
  ReadResult r = ricci::read_mesh_from_memory(ricci::serialize_mesh(m, FileFormat::Gifti), "x.gii");
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.mesh.positions[0] == static_cast<double>(0.1f));
  CHECK(r.mesh.positions[4] == static_cast<double>(1.0f / 3.0f));
  r = ricci::read_mesh_from_memory(ricci::serialize_mesh(Mesh{}, FileFormat::Gifti), "x.gii");
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.mesh.positions.empty());
  CHECK(r.mesh.faces.empty());
  TempDir dir;
  const Mesh o = octahedron();
  const ricci::WriteResult w = ricci::write_mesh((dir / "o.surf.gii").string(), o);
  REQUIRE_MESSAGE(w.status == Status::Ok, w.message);
  r = ricci::read_mesh((dir / "o.surf.gii").string());
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.mesh.positions == o.positions);
  CHECK(r.mesh.faces == o.faces);
  // Recognised by content without the extension.
  std::filesystem::rename(dir / "o.surf.gii", dir / "surface");
  CHECK(ricci::read_mesh((dir / "surface").string()).format == FileFormat::Gifti);
}

// =============================================================================================
// Hand-built documents.

TEST_CASE("gifti: every encoding, byte order, index order and data type reads back the same arrays") {
  const Mesh m = octahedron();
  int documents = 0;
  for (const Enc e : {Enc::Ascii, Enc::Base64, Enc::Zlib, Enc::Gzip}) {
    for (const bool big : {false, true}) {
      for (const bool column : {false, true}) {
        for (const TypeSpec& ptype : {kFloat32, kFloat64, kIntegerTypes[2], kIntegerTypes[4]}) {
          for (const TypeSpec& itype : kIntegerTypes) {
            ArrayDoc p = pointset(m, ptype, e), t = triangles(m, itype, e);
            p.big_endian = t.big_endian = big;
            p.column_major = t.column_major = column;
            const std::string doc = document({t, p});  // the triangles first: order does not matter
            CAPTURE(doc);
            const ReadResult r = read_surface(doc);
            REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
            CHECK(r.mesh.positions == m.positions);
            CHECK(r.mesh.faces == m.faces);
            const std::string order = column ? "ColumnMajorOrder" : "RowMajorOrder";
            const std::string itype_short = std::string(itype.name).substr(11);
            CHECK(r.format_details ==
                  "GIFTI 1.0; pointset: " + std::string(ptype.name).substr(11) + " " + encoding_attribute(e) +
                      (big ? " BigEndian " : " LittleEndian ") + order + "; triangles: " + itype_short + " " +
                      encoding_attribute(e) + (big ? " BigEndian " : " LittleEndian ") + order);
            ++documents;
          }
        }
      }
    }
  }
  CHECK(documents == 4 * 2 * 2 * 4 * 7);
}

TEST_CASE("gifti: ASCII values keep their decimal precision in FLOAT64 and are rounded in FLOAT32") {
  Mesh m = octahedron();
  m.positions[0] = 0.1;
  m.positions[1] = -1e-300;  // underflows to -0 in FLOAT32
  for (const TypeSpec& t : {kFloat32, kFloat64}) {
    const ReadResult r =
        read_surface(document({pointset(m, t, Enc::Ascii), triangles(m, kIntegerTypes[0], Enc::Ascii)}));
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.mesh.positions[0] == (t.bytes == 4 ? static_cast<double>(0.1f) : 0.1));
    CHECK(r.mesh.positions[1] == (t.bytes == 4 ? 0.0 : -1e-300));
    CHECK(std::signbit(r.mesh.positions[1]));
  }
}

TEST_CASE("gifti: other data arrays, metadata, CDATA and a byte order mark are accepted") {
  const Mesh m = octahedron();
  ArrayDoc normals = pointset(m);
  normals.intent = "NIFTI_INTENT_VECTOR";
  normals.values.assign(normals.values.size(), 7.0);
  ArrayDoc second = pointset(m);  // only the first pointset counts
  second.values.assign(second.values.size(), 9.0);
  ArrayDoc t = triangles(m, kIntegerTypes[0], Enc::Ascii);
  std::string doc = document(
      {data_array(normals, encode_data(normals)), data_array(pointset(m), encode_data(pointset(m))),
       data_array(t, "<![CDATA[" + encode_data(t) + "]]>"), data_array(second, encode_data(second))});
  doc = "\xEF\xBB\xBF" +
        replaced(doc, "<LabelTable/>", "<LabelTable><Label Key=\"0\">unknown</Label></LabelTable>");
  const ReadResult r = read_surface(doc);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.mesh.positions == m.positions);
  CHECK(r.mesh.faces == m.faces);
}

TEST_CASE("gifti: gifticlib's enumerator spellings of Encoding, Endian and ArrayIndexingOrder are read") {
  // gifticlib 1.08 wrote Encoding="GIFTI_ENCODING_B64BIN" Endian="GIFTI_ENDIAN_LITTLE" (nibabel reads them).
  const Mesh m = octahedron();
  ArrayDoc p = pointset(m, kFloat32, Enc::Zlib), t = triangles(m, kIntegerTypes[0], Enc::Base64);
  p.big_endian = true;
  p.column_major = true;
  std::string doc = document({p, t});
  doc = replaced(doc, "\"GZipBase64Binary\" Endian=\"BigEndian\"",
                 "\"GIFTI_ENCODING_B64GZ\" Endian=\"GIFTI_ENDIAN_BIG\"");
  doc = replaced(doc, "\"ColumnMajorOrder\"", "\"GIFTI_IND_ORD_COL_MAJOR\"");
  doc = replaced(doc, "\"Base64Binary\" Endian=\"LittleEndian\"",
                 "\"GIFTI_ENCODING_B64BIN\" Endian=\"GIFTI_ENDIAN_LITTLE\"");
  ReadResult r = read_surface(doc);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.mesh.positions == m.positions);
  CHECK(r.mesh.faces == m.faces);
  CHECK(r.format_details ==
        "GIFTI 1.0; pointset: FLOAT32 GIFTI_ENCODING_B64GZ GIFTI_ENDIAN_BIG GIFTI_IND_ORD_COL_MAJOR; "
        "triangles: INT32 GIFTI_ENCODING_B64BIN GIFTI_ENDIAN_LITTLE RowMajorOrder");
  doc = replaced(document({pointset(m, kFloat32, Enc::Ascii), t}), "\"ASCII\"", "\"GIFTI_ENCODING_ASCII\"");
  r = read_surface(doc);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.mesh.positions == m.positions);
}

// =============================================================================================
// Errors.

TEST_CASE("gifti: malformed XML is a ParseError naming the line") {
  const std::string good = ricci::serialize_mesh(octahedron(), FileFormat::Gifti);
  check_failure(read_surface(good.substr(0, good.size() / 2)), Status::ParseError, {"malformed XML"});
  check_failure(read_surface(good.substr(0, good.size() - 3)), Status::ParseError, {"malformed XML"});
  check_failure(read_surface(""), Status::ParseError, {"malformed XML"});
  check_failure(read_surface(replaced(good, "</DataArray>", "</DataArra>")), Status::ParseError,
                {"malformed XML"});
  check_failure(read_surface("<?xml version=\"1.0\"?>\n<mesh/>\n"), Status::ParseError,
                {"line 2:", "not <GIFTI>"});
  // Entity declarations are refused (no expansion), however small.
  const std::string entity = replaced(good, "gifti.dtd\">", "gifti.dtd\" [<!ENTITY a \"aaaa\">]>");
  check_failure(read_surface(entity), Status::ParseError, {"entity"});
  // The line is that of the problem.
  const ReadResult r = read_surface(replaced(good, "<Data>", "<Data><b/>"));
  check_failure(r, Status::ParseError, {"<b>"});
  CHECK(r.line == 22);  // the <Data> of the pointset in ricci's layout
}

TEST_CASE("gifti: bad base64 is named with the array and the line") {
  const Mesh m = octahedron();
  const ArrayDoc p = pointset(m);
  const ArrayDoc t = triangles(m);
  const std::string data = encode_data(p);
  const std::string good = document({data_array(p, data), data_array(t, encode_data(t))});
  REQUIRE(read_surface(good).status == Status::Ok);
  ReadResult r = read_surface(document(
      {data_array(p, "\n" + data.substr(0, 8) + "\n*" + data.substr(8)), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"the pointset (data array 0)", "'*'", "not base64"});
  CHECK(r.line == 12);  // the line of the '*' (the <Data> text starts on line 10)
  r = read_surface(document({data_array(p, data + "A"), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"lone character"});
  r = read_surface(document({data_array(p, "AA=A" + data), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"padding"});
  r = read_surface(document({data_array(p, "A=" + data), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"misplaced padding"});
  // The right characters, the wrong length.
  r = read_surface(document({data_array(p, data + "AAAA"), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"holds 75 bytes", "6×3 values of FLOAT32 need 72"});
  r = read_surface(document({data_array(p, data.substr(0, 48)), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"holds 36 bytes"});
}

TEST_CASE("gifti: compressed data must inflate to exactly the declared size") {
  const Mesh m = octahedron();
  ArrayDoc p = pointset(m, kFloat32, Enc::Zlib);
  const ArrayDoc t = triangles(m);
  std::string bytes;
  for (const double x : m.positions) put_value(bytes, kFloat32, x, false);
  auto with_stream = [&](const std::string& stream) {
    return read_surface(document({data_array(p, base64(stream, false)), data_array(t, encode_data(t))}));
  };
  for (const bool gzip : {false, true}) {
    CAPTURE(gzip);
    const std::string stream = compressed(bytes, gzip);
    REQUIRE(with_stream(stream).status == Status::Ok);
    check_failure(with_stream(stream.substr(0, stream.size() - 20)), Status::ParseError,
                  {"the pointset (data array 0)", "ends early"});
    check_failure(with_stream(stream.substr(0, 4)), Status::ParseError, {"ends early"});
    check_failure(with_stream(stream + "junk"), Status::ParseError, {"4 bytes after the end of its stream"});
    check_failure(with_stream(compressed(bytes.substr(0, 60), gzip)), Status::ParseError,
                  {"inflates to only 60 bytes", "72 bytes declared"});
    check_failure(with_stream(compressed(bytes + "abcd", gzip)), Status::ParseError,
                  {"inflates to more than the 72 bytes"});
    std::string corrupt = stream;
    corrupt[gzip ? 10 : 2] = '\x07';  // an invalid block type
    check_failure(with_stream(corrupt), Status::ParseError, {"corrupt"});
  }
  check_failure(with_stream("garbage, not zlib"), Status::ParseError, {"corrupt"});
  check_failure(with_stream(""), Status::ParseError, {"ends early"});
}

TEST_CASE("gifti: out-of-range indices name the face and the vertex") {
  Mesh m = octahedron();
  m.faces[23] = 6;
  ReadResult r = read_surface(document({pointset(m), triangles(m)}));
  check_failure(r, Status::IndexOutOfRange, {"face 7 refers to vertex 6", "has 6 vertices"});
  CHECK(r.element == Element::Face);
  CHECK(r.element_index == 7);
  m.faces[23] = 5;
  m.faces[4] = -1;
  r = read_surface(document({pointset(m, kFloat32, Enc::Ascii), triangles(m, kIntegerTypes[0], Enc::Ascii)}));
  check_failure(r, Status::IndexOutOfRange, {"face 1 refers to vertex -1"});
  CHECK(r.element_index == 1);
  // An unsigned index beyond int32 and a value beyond its ASCII type.
  ArrayDoc t = triangles(m, kIntegerTypes[5]);  // UINT32
  t.values[4] = 4294967295.0;
  r = read_surface(document({pointset(m), t}));
  check_failure(r, Status::IndexOutOfRange, {"face 1 refers to vertex 4294967295"});
  t = triangles(m, kIntegerTypes[1], Enc::Ascii);  // UINT8
  t.values[4] = 300;
  r = read_surface(document({pointset(m), t}));
  check_failure(r, Status::ParseError, {"face 1", "'300'", "range of UINT8"});
  CHECK(r.element == Element::Face);
}

TEST_CASE("gifti: non-finite coordinates name the vertex") {
  const Mesh m = octahedron();
  ArrayDoc p = pointset(m, kFloat32, Enc::Ascii);
  const ArrayDoc t = triangles(m);
  std::string data = encode_data(p);
  ReadResult r = read_surface(
      document({data_array(p, replaced(data, "\n0 0 4\n", "\n0 nan 4\n")), data_array(t, encode_data(t))}));
  check_failure(r, Status::NonFiniteCoordinate, {"vertex 4", "'nan'"});
  CHECK(r.element == Element::Vertex);
  CHECK(r.element_index == 4);
  r = read_surface(
      document({data_array(p, replaced(data, "\n0 0 4\n", "\n0 1e39 4\n")), data_array(t, encode_data(t))}));
  check_failure(r, Status::NonFiniteCoordinate, {"vertex 4", "FLOAT32"});
  r = read_surface(
      document({data_array(p, replaced(data, "\n0 0 4\n", "\n0 zero 4\n")), data_array(t, encode_data(t))}));
  check_failure(r, Status::ParseError, {"vertex 4", "'zero'", "not a number"});
  // Binary, column-major: the vertex is found through the transposition.
  for (const TypeSpec& type : {kFloat32, kFloat64}) {
    Mesh bad = m;
    bad.positions[3 * 2 + 1] =
        type.bytes == 4 ? std::numeric_limits<double>::infinity() : std::numeric_limits<double>::quiet_NaN();
    ArrayDoc b = pointset(bad, type, Enc::Gzip);
    b.column_major = true;
    b.big_endian = true;
    r = read_surface(document({b, t}));
    check_failure(r, Status::NonFiniteCoordinate, {"vertex 2 has a coordinate that is not finite"});
    CHECK(r.element_index == 2);
  }
}

TEST_CASE("gifti: missing arrays, wrong shapes, types and attributes are named") {
  const Mesh m = octahedron();
  const std::string good = document({pointset(m), triangles(m)});
  REQUIRE(read_surface(good).status == Status::Ok);
  check_failure(read_surface(document({pointset(m)})), Status::ParseError,
                {"line 3:", "no data array of intent NIFTI_INTENT_TRIANGLE", "1 data array)"});
  check_failure(read_surface(document({triangles(m)})), Status::ParseError, {"NIFTI_INTENT_POINTSET"});
  check_failure(read_surface(replaced(good, "Dim1=\"3\"", "Dim1=\"4\"")), Status::ParseError,
                {"line 6:", "the pointset (data array 0) is 6×4, not #N×3"});
  check_failure(read_surface(replaced(good, "Dimensionality=\"2\"", "Dimensionality=\"3\"")),
                Status::ParseError, {"Dimensionality='3'"});
  check_failure(read_surface(replaced(good, " Dim0=\"6\"", "")), Status::ParseError, {"no Dim0 attribute"});
  check_failure(read_surface(replaced(good, "Dim0=\"6\"", "Dim0=\"-6\"")), Status::ParseError, {"Dim0='-6'"});
  check_failure(read_surface(replaced(good, "NIFTI_TYPE_INT32", "NIFTI_TYPE_FLOAT32")), Status::ParseError,
                {"the triangle array (data array 1)", "integer type"});
  check_failure(read_surface(replaced(good, "NIFTI_TYPE_FLOAT32", "NIFTI_TYPE_COMPLEX64")),
                Status::ParseError, {"'NIFTI_TYPE_COMPLEX64'"});
  check_failure(read_surface(replaced(good, "Base64Binary", "Base32")), Status::ParseError,
                {"Encoding 'Base32'"});
  check_failure(read_surface(replaced(good, " Endian=\"LittleEndian\"", "")), Status::ParseError,
                {"no Endian attribute"});
  check_failure(read_surface(replaced(good, "LittleEndian", "MiddleEndian")), Status::ParseError,
                {"Endian='MiddleEndian'"});
  check_failure(read_surface(replaced(good, "    ArrayIndexingOrder=\"RowMajorOrder\"\n", "")),
                Status::ParseError, {"no ArrayIndexingOrder attribute"});
  check_failure(read_surface(replaced(good, "RowMajorOrder", "Diagonal")), Status::ParseError,
                {"'Diagonal'"});
  // ASCII: too few and too many values.
  ArrayDoc p = pointset(m, kFloat64, Enc::Ascii);
  const std::string text = encode_data(p);
  ReadResult r = read_surface(document(
      {data_array(p, text.substr(0, text.size() - 3)), data_array(triangles(m), encode_data(triangles(m)))}));
  check_failure(r, Status::ParseError, {"ends after 17 of the 18 values declared (Dim0×Dim1 = 6×3)"});
  r = read_surface(
      document({data_array(p, text + " 5"), data_array(triangles(m), encode_data(triangles(m)))}));
  check_failure(r, Status::ParseError, {"more than the 18 values", "'5'"});
}

TEST_CASE("gifti: ExternalFileBinary is refused as an unknown format") {
  const Mesh m = octahedron();
  std::string doc = document({pointset(m), triangles(m)});
  doc = replaced(doc, "Encoding=\"Base64Binary\"", "Encoding=\"ExternalFileBinary\"");
  doc = replaced(doc, "ExternalFileName=\"\"", "ExternalFileName=\"lh.dat\"");
  check_failure(read_surface(doc), Status::UnknownFormat, {"ExternalFileBinary", "'lh.dat'", "inline"});
  const ReadResult r = read_surface(replaced(doc, "ExternalFileBinary", "GIFTI_ENCODING_EXTBIN"));
  check_failure(r, Status::UnknownFormat, {"'GIFTI_ENCODING_EXTBIN'", "'lh.dat'"});
  CHECK(r.line == 6);  // the <DataArray> tag
}

TEST_CASE("gifti: huge declared sizes with little data are refused quickly without allocating") {
  // Under AddressSanitizer an attempt to allocate for these sizes would abort the test.
  const Mesh m = octahedron();
  for (const Enc e : {Enc::Ascii, Enc::Base64, Enc::Zlib, Enc::Gzip}) {
    for (const char* dim0 : {"2000000000", "2147483647", "3000000000", "99999999999999999"}) {
      CAPTURE(encoding_attribute(e));
      CAPTURE(dim0);
      for (const bool points : {true, false}) {
        const std::string doc = document({pointset(m, kFloat64, e), triangles(m, kIntegerTypes[4], e)});
        const std::string from = points ? "Dim0=\"6\"" : "Dim0=\"8\"";
        const auto start = std::chrono::steady_clock::now();
        const ReadResult r = read_surface(replaced(doc, from, std::string("Dim0=\"") + dim0 + "\""));
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        INFO(r.message);
        CHECK((r.status == Status::FileTooLarge || r.status == Status::ParseError));
        if (std::string_view(dim0).size() > 10) CHECK(r.status == Status::FileTooLarge);
        CHECK(seconds < 1.0);
      }
    }
  }
  // A valid zlib stream of 1 MiB of zeros is small; declared as 2^31 − 1 vertices it is too short.
  const std::string zeros(1 << 20, '\0');
  ArrayDoc p = pointset(m, kFloat32, Enc::Zlib);
  p.rows = 2147483647;
  const ReadResult r = read_surface(document({data_array(p, base64(compressed(zeros, false), false)),
                                              data_array(triangles(m), encode_data(triangles(m)))}));
  check_failure(r, Status::ParseError, {"inflates to only 1048576 bytes", "the 25769803764 bytes declared"});
}

// =============================================================================================
// Overlays.

TEST_CASE("gifti: functional overlays round trip with their names") {
  const std::vector<double> values = {0.5, -1.25, 3.0, 0.0, 1e-3f, 7, 1e30f, -0.0};
  const std::string bytes = ricci::serialize_overlay(values, OverlayFormat::GiftiFunc, "u", 0);
  REQUIRE(!bytes.empty());
  CHECK(contains(bytes, "Intent=\"NIFTI_INTENT_SHAPE\""));
  CHECK(contains(bytes, "Dimensionality=\"1\""));
  CHECK(contains(bytes, "<Name>Name</Name>"));
  OverlayReadResult r = ricci::read_overlay_from_memory(bytes, "u.func.gii");
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.format == OverlayFormat::GiftiFunc);
  REQUIRE(r.arrays.size() == 1);
  CHECK(same_bits(r.arrays[0], values));
  CHECK(r.names == std::vector<std::string>{"u"});
  CHECK(r.num_faces == -1);
  // Doubles are stored as floats; names with XML's special characters come back unchanged.
  const std::string odd = "a<b> & \"c\" ]]> \r\n\tü 😀";
  r = read_func(ricci::serialize_overlay(std::vector<double>{0.1, 2}, OverlayFormat::GiftiFunc, odd, 0));
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.arrays.at(0) == std::vector<double>{static_cast<double>(0.1f), 2});
  CHECK(r.names.at(0) == odd);
  // Bytes XML cannot hold become '?'; the file stays readable.
  r = read_func(ricci::serialize_overlay(std::vector<double>{1}, OverlayFormat::GiftiFunc, "x\xff\x01y", 0));
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.names.at(0) == "x??y");
  r = read_func(ricci::serialize_overlay(std::vector<double>{}, OverlayFormat::GiftiFunc, "", 0));
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.arrays.at(0).empty());
  CHECK(r.names.at(0).empty());
}

TEST_CASE("gifti: functional files with several arrays of any type, 1-D or #V×1") {
  ArrayDoc a;
  a.intent = "NIFTI_INTENT_NONE";
  a.type = kIntegerTypes[2];  // INT16
  a.encoding = Enc::Ascii;
  a.rows = 5;
  a.cols = 0;
  a.values = {-3, 0, 7, 32767, -32768};
  ArrayDoc b = a;
  b.type = kFloat64;
  b.encoding = Enc::Gzip;
  b.big_endian = true;
  b.column_major = true;
  b.cols = 1;
  b.values = {0.1, 0.2, 1e300, -1e-300, 5};
  b.name = "curvature";
  ArrayDoc c = a;
  c.intent = "NIFTI_INTENT_LABEL";
  c.type = kIntegerTypes[1];  // UINT8
  c.encoding = Enc::Base64;
  c.values = {255, 0, 1, 2, 3};
  c.name = "labels";
  ArrayDoc d = c;
  d.type = kIntegerTypes[5];  // UINT32
  d.values = {4294967295.0, 0, 1, 2, 3};
  d.name.clear();
  const OverlayReadResult r = read_func(document({a, b, c, d}));
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  REQUIRE(r.arrays.size() == 4);
  CHECK(r.arrays[0] == a.values);
  CHECK(r.arrays[1] == b.values);
  CHECK(r.arrays[2] == c.values);
  CHECK(r.arrays[3] == d.values);
  CHECK(r.names == std::vector<std::string>{"", "curvature", "labels", ""});
}

TEST_CASE("gifti: functional file errors are named") {
  ArrayDoc a;
  a.intent = "NIFTI_INTENT_SHAPE";
  a.encoding = Enc::Ascii;
  a.rows = 4;
  a.cols = 0;
  a.values = {1, 2, 3, 4};
  a.name = "u";
  OverlayReadResult r = read_func(replaced(document({a}), "3 4", "inf 4"));
  CHECK(r.status == Status::NonFiniteCoordinate);
  CHECK(contains(r.message, "u.func.gii: line "));
  CHECK(contains(r.message, "data array 0 ('u'): the value of vertex 2 'inf' is not finite"));
  CHECK(r.arrays.empty());
  ArrayDoc b = a;
  b.rows = 3;
  b.values = {1, 2, 3};
  r = read_func(document({a, b}));
  CHECK(r.status == Status::ParseError);
  CHECK(contains(r.message, "data array 1 ('u') has 3 values, but data array 0 has 4"));
  r = read_func(ricci::serialize_mesh(octahedron(), FileFormat::Gifti));
  CHECK(r.status == Status::ParseError);
  CHECK(contains(r.message, "data array 0 is 6×3, not #V×1"));
  r = read_func(document(std::vector<std::string>{}));
  CHECK(r.status == Status::ParseError);
  CHECK(contains(r.message, "no data arrays"));
  b = a;
  b.type = kFloat32;
  b.encoding = Enc::Zlib;
  b.values = {1, 2, std::numeric_limits<double>::quiet_NaN(), 4};
  r = read_func(document({b}));
  CHECK(r.status == Status::NonFiniteCoordinate);
  CHECK(contains(r.message, "the value of vertex 2 is not finite"));
  CHECK(ricci::serialize_overlay(b.values, OverlayFormat::GiftiFunc, "u", 0).empty());
  // A surface read as an overlay, an overlay read as a surface.
  const ReadResult s = ricci::read_mesh_from_memory(
      ricci::serialize_overlay(a.values, OverlayFormat::GiftiFunc, "u", 0), "u.gii");
  CHECK(s.status == Status::ParseError);
  CHECK(contains(s.message, "NIFTI_INTENT_POINTSET"));
}

// =============================================================================================
// Robustness.

TEST_CASE("gifti: every truncation and random corruptions of small files are handled") {
  const Mesh m = octahedron();
  ArrayDoc p = pointset(m, kFloat32, Enc::Ascii), t = triangles(m, kIntegerTypes[1], Enc::Gzip);
  t.column_major = true;
  const std::vector<std::string> inputs = {
      ricci::serialize_mesh(m, FileFormat::Gifti), document({p, t}),
      ricci::serialize_overlay(std::vector<double>{1, 2, 3}, OverlayFormat::GiftiFunc, "u", 0)};
  auto sane = [](const std::string& message, Status status, const char* name) {
    return status != Status::NotRun && message.rfind(std::string(name) + ": ", 0) == 0;
  };
  static const char kBytes[] =
      "0 =A/+<>\"\n\xff\x01"
      "Dim";  // the terminating NUL too
  std::mt19937 rng(7);
  for (const std::string& input : inputs) {
    bool all_sane = true;
    const std::size_t complete = input.rfind('>') + 1;  // from here on the XML is whole
    for (std::size_t n = 0; n < complete && all_sane; ++n) {
      const std::string_view cut = std::string_view(input).substr(0, n);
      const ReadResult r = read_surface(cut);
      const OverlayReadResult o = read_func(cut);
      all_sane = sane(r.message, r.status, "x.surf.gii") && sane(o.message, o.status, "u.func.gii") &&
                 r.status != Status::Ok && o.status != Status::Ok;
      if (!all_sane) FAIL_CHECK("truncation to " << n << " bytes: " << r.message << " / " << o.message);
    }
    for (int trial = 0; trial < 400 && all_sane; ++trial) {
      std::string bad = input;
      for (int k = 0; k < 1 + static_cast<int>(rng() % 4); ++k)
        bad[rng() % bad.size()] = kBytes[rng() % sizeof kBytes];
      const ReadResult r = read_surface(bad);
      const OverlayReadResult o = read_func(bad);
      all_sane = sane(r.message, r.status, "x.surf.gii") && sane(o.message, o.status, "u.func.gii");
      if (r.status == Status::Ok) {
        for (const Index v : r.mesh.faces) all_sane = all_sane && v >= 0 && v < r.mesh.num_vertices();
        all_sane = all_sane && r.mesh.positions.size() % 3 == 0 && r.mesh.faces.size() % 3 == 0;
      }
      if (!all_sane) FAIL_CHECK("corrupted input: " << r.message << " / " << o.message);
    }
  }
}

// =============================================================================================
// nibabel.

namespace {

/// Checks with nibabel the files that write_interop_inputs() leaves in argv[1], then writes
/// nibabel's own surfaces (every encoding, both requested byte orders, both orders, FLOAT32 and
/// FLOAT64) and a functional file there for ricci to read. Exits non-zero on a difference.
constexpr const char* kNibabelScript = R"(
import glob, sys
import numpy as np, nibabel as nib
from nibabel.gifti import GiftiDataArray, GiftiImage
d = sys.argv[1]
xyz = np.loadtxt(d + '/xyz.txt').reshape(-1, 3)
faces = np.loadtxt(d + '/faces.txt', dtype=np.int64).reshape(-1, 3)
values = np.loadtxt(d + '/values.txt')
# nibabel reads ricci's files and the hand-built ones.
paths = sorted(glob.glob(d + '/ricci.surf.gii') + glob.glob(d + '/hand-*.surf.gii'))
assert len(paths) == 11, paths
for path in paths:
    img = nib.load(path)
    pts = img.get_arrays_from_intent('NIFTI_INTENT_POINTSET')[0].data
    tri = img.get_arrays_from_intent('NIFTI_INTENT_TRIANGLE')[0].data
    assert np.array_equal(pts.astype(np.float64), xyz), path + ': coordinates differ'
    assert np.array_equal(tri.astype(np.int64), faces), path + ': triangles differ'
func = nib.load(d + '/ricci.func.gii')
assert len(func.darrays) == 1
a = func.darrays[0]
assert np.array_equal(a.data.astype(np.float64), values), 'func values differ'
assert a.meta['Name'] == 'thickness', a.meta
assert nib.nifti1.intent_codes.niistring[a.intent] == 'NIFTI_INTENT_SHAPE'
# nibabel writes; ricci reads (checked on the C++ side).
for enc in ('ASCII', 'B64BIN', 'B64GZ'):
    for endian in ('big', 'little'):
        for order in ('C', 'F'):
            if enc == 'ASCII' and order == 'F':
                continue  # nibabel writes ASCII rows whatever the order
            for ctype in ('float32', 'float64'):
                pts = GiftiDataArray(xyz.astype(ctype), intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_' + ctype.upper(),
                                     encoding=enc, endian=endian, ordering=order)
                tri = GiftiDataArray(faces.astype(np.int32), intent='NIFTI_INTENT_TRIANGLE', datatype='NIFTI_TYPE_INT32',
                                     encoding=enc, endian=endian, ordering=order)
                nib.save(GiftiImage(darrays=[pts, tri]), '%s/nib-%s-%s-%s-%s.surf.gii' % (d, enc, endian, order, ctype))
arrays = [GiftiDataArray(values.astype(np.float32), intent='NIFTI_INTENT_SHAPE', datatype='NIFTI_TYPE_FLOAT32',
                         encoding='B64GZ', meta={'Name': 'thickness'}),
          GiftiDataArray(np.arange(len(values), dtype=np.int32), intent='NIFTI_INTENT_LABEL', datatype='NIFTI_TYPE_INT32',
                         encoding='ASCII', meta={'Name': 'index'}),
          GiftiDataArray(np.arange(len(values), dtype=np.uint8)[:, None], intent='NIFTI_INTENT_NONE',
                         datatype='NIFTI_TYPE_UINT8', encoding='B64BIN')]
nib.save(GiftiImage(darrays=arrays), d + '/nib.func.gii')
)";

/// Writes ricci's surface and functional file, hand-built surfaces (nibabel ignores
/// ArrayIndexingOrder in ASCII data, so no ASCII column-major one) and the expected arrays as text.
void write_interop_inputs(const std::filesystem::path& dir, const Mesh& m,
                          const std::vector<double>& values) {
  ricci_test::write_bytes(dir / "ricci.surf.gii", ricci::serialize_mesh(m, FileFormat::Gifti));
  ricci_test::write_bytes(dir / "ricci.func.gii",
                          ricci::serialize_overlay(values, OverlayFormat::GiftiFunc, "thickness", 0));
  int hand = 0;
  for (const Enc e : {Enc::Ascii, Enc::Base64, Enc::Zlib})
    for (const bool big : {false, true})
      for (const bool column : {false, true}) {
        if (e == Enc::Ascii && column) continue;
        ArrayDoc p = pointset(m, big ? kFloat64 : kFloat32, e),
                 t = triangles(m, kIntegerTypes[big ? 3 : 0], e);
        p.big_endian = t.big_endian = big;
        p.column_major = t.column_major = column;
        ricci_test::write_bytes(dir / ("hand-" + std::to_string(hand++) + ".surf.gii"), document({p, t}));
      }
  std::string xyz, faces, vals;
  for (const double x : m.positions) xyz += std::to_string(x) + "\n";  // k/64: exact in 6 decimals
  for (const Index f : m.faces) faces += std::to_string(f) + "\n";
  for (const double v : values) vals += std::to_string(v) + "\n";
  ricci_test::write_bytes(dir / "xyz.txt", xyz);
  ricci_test::write_bytes(dir / "faces.txt", faces);
  ricci_test::write_bytes(dir / "values.txt", vals);
  ricci_test::write_bytes(dir / "check.py", kNibabelScript);
}

}  // namespace

TEST_CASE("gifti: nibabel reads ricci's and hand-built files, and ricci reads nibabel's") {
  const std::string python = ricci_test::nibabel_python();
  if (python.empty()) {
    MESSAGE("python3 nibabel not installed: skipped");
    return;
  }
  TempDir dir;
  const Mesh m = sixty_fourths_mesh();
  std::vector<double> values;
  for (int i = 0; i < m.num_vertices(); ++i) values.push_back(static_cast<double>(i % 7) * 0.25 - 0.5);
  write_interop_inputs(dir.path(), m, values);
  const ricci_test::CommandResult py =
      ricci_test::run_program(python, {(dir / "check.py").string(), dir.path().string()});
  REQUIRE_MESSAGE(py.exit_code == 0, py.err);
  int read = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("nib-", 0) != 0) continue;
    CAPTURE(name);
    const ReadResult r = ricci::read_mesh(entry.path().string());
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.mesh.positions == m.positions);
    CHECK(r.mesh.faces == m.faces);
    ++read;
  }
  CHECK(read == 20);
  const OverlayReadResult f = ricci::read_overlay((dir / "nib.func.gii").string());
  REQUIRE_MESSAGE(f.status == Status::Ok, f.message);
  REQUIRE(f.arrays.size() == 3);
  CHECK(f.arrays[0] == values);
  for (std::size_t i = 0; i < values.size(); ++i) {
    CHECK(f.arrays[1][i] == static_cast<double>(i));
    CHECK(f.arrays[2][i] == static_cast<double>(i));
  }
  CHECK(f.names == std::vector<std::string>{"thickness", "index", ""});
}
