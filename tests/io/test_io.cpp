// Tests of io.h: exact write→read round trips, every accepted syntax variant, error statuses and
// their locations, robustness against truncated, corrupted and random input, atomic writes and
// protected paths, and the real meshes in ../shared/meshes.
#include <doctest/doctest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstdint>
#include <cstring>
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
using ricci::ReadResult;
using ricci::Status;
using ricci_test::TempDir;
namespace fs = std::filesystem;

constexpr FileFormat kAllFormats[] = {FileFormat::Obj, FileFormat::Off, FileFormat::PlyAscii,
                                      FileFormat::PlyBinary};

const char* format_label(FileFormat f) {
  switch (f) {
    case FileFormat::Obj:
      return "obj";
    case FileFormat::Off:
      return "off";
    case FileFormat::PlyAscii:
      return "ply-ascii";
    case FileFormat::PlyBinary:
      return "ply-binary";
    case FileFormat::StlAscii:
    case FileFormat::StlBinary:
    case FileFormat::Gifti:
    case FileFormat::FreeSurfer:
      return ricci::format_name(f);
    case FileFormat::Auto:
      break;
  }
  return "auto";
}

std::string extension(FileFormat f) {
  return f == FileFormat::Obj ? ".obj" : f == FileFormat::Off ? ".off" : ".ply";
}

/// Reads bytes in a given format, named "test.EXT" in messages.
ReadResult parse(std::string_view data, FileFormat format, bool texcoords = true) {
  ricci::ReadOptions options;
  options.format = format;
  options.read_texcoords = texcoords;
  return ricci::read_mesh_from_memory(data, "test" + extension(format), options);
}

/// Reads bytes from a heap buffer of exactly their size, so that AddressSanitizer reports any
/// read past the end.
ReadResult parse_exact(std::string_view data, FileFormat format) {
  const std::unique_ptr<char[]> copy(new char[std::max<std::size_t>(data.size(), 1)]);
  if (!data.empty()) std::memcpy(copy.get(), data.data(), data.size());
  return parse(std::string_view(copy.get(), data.size()), format);
}

bool finite_bits(double x) {
  return (std::bit_cast<std::uint64_t>(x) & 0x7ff0000000000000ull) != 0x7ff0000000000000ull;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

/// Empty when a read result is self-consistent: a failure has a message naming the file; a
/// success has finite coordinates, in-range indices and consistent buffer sizes.
std::string check_sane(const ReadResult& r, const std::string& name) {
  if (r.status == Status::NotRun) return "status is NotRun";
  if (r.message.rfind(name + ": ", 0) != 0) return "message does not start with the name: " + r.message;
  if (r.status != Status::Ok) return {};
  const Mesh& m = r.mesh;
  if (m.positions.size() % 3 != 0 || m.faces.size() % 3 != 0) return "buffer sizes";
  for (const double x : m.positions) {
    if (!finite_bits(x)) return "non-finite coordinate";
  }
  for (const Index v : m.faces) {
    if (v < 0 || v >= m.num_vertices()) return "face index out of range";
  }
  if (!m.corner_texcoords.empty()) {
    if (m.corner_texcoords.size() != m.faces.size()) return "corner_texcoords size";
    for (const Index t : m.corner_texcoords) {
      if (t < 0 || t >= m.num_texcoords()) return "texcoord index out of range";
    }
  }
  if (r.polygons_triangulated > r.polygons_read) return "more polygons triangulated than read";
  if (static_cast<std::int64_t>(m.num_faces()) < r.polygons_read) return "fewer triangles than polygons";
  return {};
}

// ---------------------------------------------------------------------------------------------
// Random meshes with awkward coordinates.

double random_coordinate(std::mt19937_64& rng) {
  static const double kSpecial[] = {
      0.0,
      -0.0,
      1.0,
      -1.0,
      0.1,
      1.0 / 3.0,
      -2.0 / 3.0,
      1e-300,
      -1e300,
      123456789.123456789,
      1e22,
      1e23,
      std::numeric_limits<double>::max(),
      -std::numeric_limits<double>::max(),
      std::numeric_limits<double>::min(),
      std::numeric_limits<double>::denorm_min(),
      -std::numeric_limits<double>::denorm_min(),
      std::bit_cast<double>(std::uint64_t{0x000fffffffffffff}),  // largest subnormal
      std::numeric_limits<double>::epsilon(),
      9007199254740993.0};
  switch (rng() % 4) {
    case 0:
      return kSpecial[rng() % std::size(kSpecial)];
    case 1:
      for (;;) {  // any finite bit pattern
        const double x = std::bit_cast<double>(static_cast<std::uint64_t>(rng()));
        if (finite_bits(x)) return x;
      }
    default:
      return static_cast<double>(static_cast<std::int64_t>(rng()) >> 11) * 0x1p-40;
  }
}

Mesh random_mesh(std::mt19937_64& rng, bool with_texcoords) {
  Mesh m;
  const Index nv = 3 + static_cast<Index>(rng() % 60);
  const Index nf = 1 + static_cast<Index>(rng() % 80);
  for (Index i = 0; i < 3 * nv; ++i) m.positions.push_back(random_coordinate(rng));
  for (Index i = 0; i < 3 * nf; ++i)
    m.faces.push_back(static_cast<Index>(rng() % static_cast<std::uint64_t>(nv)));
  if (with_texcoords) {
    const Index nt = 1 + static_cast<Index>(rng() % 50);
    for (Index i = 0; i < 2 * nt; ++i) m.texcoords.push_back(random_coordinate(rng));
    for (Index i = 0; i < 3 * nf; ++i) {
      m.corner_texcoords.push_back(static_cast<Index>(rng() % static_cast<std::uint64_t>(nt)));
    }
  }
  return m;
}

/// Checks that `back` holds exactly `mesh` (texture coordinates only for OBJ).
void check_same_mesh(const Mesh& mesh, const ReadResult& back, FileFormat format) {
  REQUIRE(back.status == Status::Ok);
  CHECK(same_bits(back.mesh.positions, mesh.positions));
  CHECK(back.mesh.faces == mesh.faces);
  if (format == FileFormat::Obj) {
    CHECK(same_bits(back.mesh.texcoords, mesh.texcoords));
    CHECK(back.mesh.corner_texcoords == mesh.corner_texcoords);
  } else {
    CHECK(back.mesh.texcoords.empty());
    CHECK(back.mesh.corner_texcoords.empty());
  }
  CHECK(back.polygons_read == mesh.num_faces());
  CHECK(back.polygons_triangulated == 0);
}

void check_round_trips(FileFormat format) {
  ricci_test::for_each_seed({1, 2, 3, 17, 2024, 99991}, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const Mesh mesh = random_mesh(rng, format == FileFormat::Obj && seed % 2 == 1);
    const std::string bytes = ricci::serialize_mesh(mesh, format);
    const ReadResult back = parse(bytes, format);
    INFO(back.message);
    check_same_mesh(mesh, back, format);
    CHECK(back.format == format);
  });
}

// ---------------------------------------------------------------------------------------------
// Hand-written binary PLY.

/// Appends a value in the given byte order.
template <class T>
void put(std::string& out, T value, bool big_endian) {
  auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
  if ((std::endian::native == std::endian::big) != big_endian) std::reverse(bytes.begin(), bytes.end());
  out.append(bytes.data(), bytes.size());
}

/// A one-triangle binary PLY with float coordinates; `body_offset` receives the header size.
std::string binary_triangle_ply(std::size_t* body_offset = nullptr) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  if (body_offset) *body_offset = s.size();
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (const float x : xyz) put(s, x, false);
  put(s, std::uint8_t{3}, false);
  for (const std::int32_t i : {0, 1, 2}) put(s, i, false);
  return s;
}

/// A PLY exercising every scalar type and skipped elements, in either byte order: vertex x is a
/// float, y a double, z an int16, with skipped properties of every other type and a skipped list;
/// element `face` (a quad and a triangle, uint32 indices after an int32 property); then an extra
/// element. Vertices: (1.5, 0.25, -3), (2, -0.5, 7), (-1, 1e-3 as double, 0), (4, 4, 4).
std::string binary_ply_all_types(bool big_endian) {
  std::string s = "ply\r\nformat ";
  s += big_endian ? "binary_big_endian" : "binary_little_endian";
  s += " 1.0\r\ncomment every type\r\nobj_info made by hand\r\n"
       "element vertex 4\r\n"
       "property char a\nproperty uchar b\nproperty short c\nproperty ushort d\nproperty int e\n"
       "property uint f\nproperty float x\nproperty double y\nproperty int16 z\n"
       "property list uint16 int8 junk\nproperty float64 w\n"
       "element face 2\nproperty int32 flags\nproperty list uint8 uint32 vertex_indices\n"
       "element extra 2\nproperty list int32 float32 values\n"
       "end_header\n";
  const float xs[4] = {1.5f, 2.0f, -1.0f, 4.0f};
  const double ys[4] = {0.25, -0.5, 1e-3, 4.0};
  const std::int16_t zs[4] = {-3, 7, 0, 4};
  for (int v = 0; v < 4; ++v) {
    put(s, std::int8_t{-5}, big_endian);
    put(s, std::uint8_t{250}, big_endian);
    put(s, std::int16_t{-300}, big_endian);
    put(s, std::uint16_t{60000}, big_endian);
    put(s, std::int32_t{-70000}, big_endian);
    put(s, std::uint32_t{4000000000u}, big_endian);
    put(s, xs[v], big_endian);
    put(s, ys[v], big_endian);
    put(s, zs[v], big_endian);
    put(s, static_cast<std::uint16_t>(v), big_endian);  // list of v int8 values
    for (int k = 0; k < v; ++k) put(s, static_cast<std::int8_t>(k), big_endian);
    put(s, 3.5, big_endian);
  }
  put(s, std::int32_t{42}, big_endian);
  put(s, std::uint8_t{4}, big_endian);
  for (const std::uint32_t i : {0u, 1u, 2u, 3u}) put(s, i, big_endian);
  put(s, std::int32_t{-1}, big_endian);
  put(s, std::uint8_t{3}, big_endian);
  for (const std::uint32_t i : {3u, 2u, 1u}) put(s, i, big_endian);
  for (int e = 0; e < 2; ++e) {
    put(s, std::int32_t{2}, big_endian);
    put(s, 1.0f, big_endian);
    put(s, 2.0f, big_endian);
  }
  return s;
}

void check_all_types_mesh(const ReadResult& r) {
  INFO(r.message);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.format == FileFormat::PlyBinary);
  const std::vector<double> expected = {1.5, 0.25, -3, 2, -0.5, 7, -1, 1e-3, 0, 4, 4, 4};
  CHECK(same_bits(r.mesh.positions, expected));
  CHECK(r.mesh.faces == std::vector<Index>{0, 1, 2, 0, 2, 3, 3, 2, 1});
  CHECK(r.polygons_read == 2);
  CHECK(r.polygons_triangulated == 1);
}

// ---------------------------------------------------------------------------------------------
// Files.

/// Names of the entries of a directory.
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

const char* const kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

}  // namespace

// =============================================================================================

TEST_CASE("io: format_from_path picks the format from the extension") {
  CHECK(ricci::format_from_path("a.obj") == FileFormat::Obj);
  CHECK(ricci::format_from_path("dir/A.OBJ") == FileFormat::Obj);
  CHECK(ricci::format_from_path("x.Off") == FileFormat::Off);
  CHECK(ricci::format_from_path("/p/q.r/mesh.ply") == FileFormat::PlyBinary);
  CHECK(ricci::format_from_path("mesh.stl") == FileFormat::StlBinary);
  CHECK(ricci::format_from_path("lh.surf.GII") == FileFormat::Gifti);
  CHECK(ricci::format_from_path("lh.white") == FileFormat::Auto);
  CHECK(ricci::format_from_path("mesh.3ds") == FileFormat::Auto);
  CHECK(ricci::format_from_path("mesh") == FileFormat::Auto);
  CHECK(ricci::format_from_path("dir.obj/mesh") == FileFormat::Auto);
  CHECK(ricci::format_from_path("") == FileFormat::Auto);
}

TEST_CASE("io: obj round trip is exact") {
  check_round_trips(FileFormat::Obj);
}
TEST_CASE("io: off round trip is exact") {
  check_round_trips(FileFormat::Off);
}
TEST_CASE("io: ply ascii round trip is exact") {
  check_round_trips(FileFormat::PlyAscii);
}
TEST_CASE("io: ply binary round trip is exact") {
  check_round_trips(FileFormat::PlyBinary);
}

TEST_CASE("io: write_mesh then read_mesh round trips through files in every format") {
  TempDir dir;
  std::mt19937_64 rng(7);
  const Mesh mesh = random_mesh(rng, true);
  for (const FileFormat format : kAllFormats) {
    CAPTURE(format_label(format));
    const fs::path file = dir / (std::string("mesh-") + format_label(format) + extension(format));
    ricci::WriteOptions wo;
    wo.format = format;
    const ricci::WriteResult w = ricci::write_mesh(file.string(), mesh, wo);
    INFO(w.message);
    REQUIRE(w.status == Status::Ok);
    CHECK(w.bytes_written == fs::file_size(file));
    const ReadResult r = ricci::read_mesh(file.string());  // format from the extension and header
    INFO(r.message);
    CHECK(r.format == format);
    Mesh expected = mesh;
    if (format != FileFormat::Obj) {
      expected.texcoords.clear();
      expected.corner_texcoords.clear();
    }
    check_same_mesh(expected, r, format);
  }
  // Without texture coordinates on request.
  ricci::WriteOptions plain;
  plain.write_texcoords = false;
  REQUIRE(ricci::write_mesh((dir / "plain.obj").string(), mesh, plain).status == Status::Ok);
  const ReadResult r = ricci::read_mesh((dir / "plain.obj").string());
  CHECK(r.status == Status::Ok);
  CHECK(!r.mesh.has_texcoords());
  CHECK(ricci_test::read_bytes(dir / "plain.obj").find("vt ") == std::string::npos);
}

TEST_CASE("io: serialised formats have the documented layout") {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.faces = {0, 1, 2};
  const std::string off = ricci::serialize_mesh(m, FileFormat::Off);
  CHECK(off.rfind("OFF\n3 1 0\n", 0) == 0);
  CHECK(off.find("\n3 0 1 2\n") != std::string::npos);
  const std::string obj = ricci::serialize_mesh(m, FileFormat::Obj);
  CHECK(obj.find("\nv 1 0 0\n") != std::string::npos);
  CHECK(obj.find("\nf 1 2 3\n") != std::string::npos);
  const std::string ply = ricci::serialize_mesh(m, FileFormat::PlyBinary);
  CHECK(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0) == 0);
  CHECK(ply.find("property double x\n") != std::string::npos);
  CHECK(ply.find("property list uchar int vertex_indices\nend_header\n") != std::string::npos);
  CHECK(ply.size() == ply.find("end_header\n") + 11 + 9 * 8 + 13);
  CHECK(ricci::serialize_mesh(m, FileFormat::PlyAscii).find("format ascii 1.0\n") != std::string::npos);
  CHECK(ricci::serialize_mesh(m, FileFormat::Auto).empty());
}

TEST_CASE("io: serialize_mesh_to hands over serialize_mesh()'s bytes in pieces and stops when told") {
  // A grid of 300 x 300 quads with texture coordinates: about 8 MB of OBJ, several pieces.
  Mesh m;
  const int n = 300;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      m.positions.insert(m.positions.end(), {i / 7.0, j / 3.0, std::sin(i * 0.1) * std::cos(j * 0.2)});
      m.texcoords.insert(m.texcoords.end(), {i / double(n), std::sqrt(j + 0.5)});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Index a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.faces.insert(m.faces.end(), {a, b, d, a, d, c});
    }
  m.corner_texcoords = m.faces;
  for (const FileFormat format : kAllFormats) {
    CAPTURE(format_name(format));
    const std::string whole = ricci::serialize_mesh(m, format);
    std::string joined;
    std::size_t pieces = 0, largest = 0;
    REQUIRE(ricci::serialize_mesh_to(m, format, [&](std::string_view piece) {
      joined += piece;
      ++pieces;
      largest = std::max(largest, piece.size());
      return true;
    }));
    CHECK(joined == whole);
    if (format == FileFormat::Obj) {
      CHECK(whole.size() > 4 * (std::size_t{1} << 20));
      CHECK(pieces >= 4);
      CHECK(largest < (std::size_t{1} << 20) + 256);  // never the whole file at once
    } else {
      CHECK(pieces == 1);
    }
    // A sink that stops at its first piece: false, no second call, and what it got is a prefix.
    std::string prefix;
    int calls = 0;
    CHECK_FALSE(ricci::serialize_mesh_to(m, format, [&](std::string_view piece) {
      prefix += piece;
      ++calls;
      return false;
    }));
    CHECK(calls == 1);
    CHECK(whole.compare(0, prefix.size(), prefix) == 0);
    if (format == FileFormat::Obj) CHECK(prefix.size() < whole.size());
  }
  CHECK_FALSE(ricci::serialize_mesh_to(m, FileFormat::Auto, [](std::string_view) { return true; }));
  // write_mesh streams the same bytes to the file.
  TempDir dir;
  const ricci::WriteResult w = ricci::write_mesh((dir / "grid.obj").string(), m);
  REQUIRE(w.status == Status::Ok);
  const std::string written = ricci_test::read_bytes(dir / "grid.obj");
  CHECK(w.bytes_written == written.size());
  CHECK(written == ricci::serialize_mesh(m, FileFormat::Obj));
}

// ---------------------------------------------------------------------------------------------
// Syntax variants.

TEST_CASE("io: obj statements, comments, negative indices and v/vt/vn tokens") {
  const std::string obj =
      "# a comment\n"
      "mtllib scene.mtl\n"
      "o thing\n"
      "g group\n"
      "s off\n"
      "usemtl red\n"
      "v 0 0 0\n"
      "v 1.0 0 0 1.0\n"        // w
      "v 0 1 0 0.5 0.5 0.5\n"  // colour
      "v +1 1e0 .0   # trailing comment\n"
      "vn 0 0 1\n"
      "vt 0 0\n"
      "vt 1 0 0\n"
      "vt 0 1\n"
      "vt 0.5\n"  // v defaults to 0
      "vp 0.5\n"
      "f 1/1/1 2/2/1 3/3/1\n"
      "f -3/-3 -1/-1 -2/-2\n"  // relative to what precedes: 2 4 3 and texcoords 2 4 3
      "l 1 2\n"
      "p 1\n"
      "unknown statement here\n";
  const ReadResult r = parse(obj, FileFormat::Obj);
  INFO(r.message);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.mesh.positions == std::vector<double>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});
  CHECK(r.mesh.faces == std::vector<Index>{0, 1, 2, 1, 3, 2});
  CHECK(r.mesh.texcoords == std::vector<double>{0, 0, 1, 0, 0, 1, 0.5, 0});
  CHECK(r.mesh.corner_texcoords == std::vector<Index>{0, 1, 2, 1, 3, 2});
  CHECK(r.format == FileFormat::Obj);
  CHECK(r.polygons_read == 2);

  const ReadResult without = parse(obj, FileFormat::Obj, /*texcoords=*/false);
  REQUIRE(without.status == Status::Ok);
  CHECK(without.mesh.texcoords.empty());
  CHECK(without.mesh.corner_texcoords.empty());
  CHECK(without.mesh.faces == r.mesh.faces);
}

TEST_CASE("io: obj polygons are fan-triangulated and counted") {
  const ReadResult r = parse(
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 2 2\n"
      "f 1/1 2/2 3/3 4/4\nf 1/1 2/2 3/3 4/4 5/5\nf 1/1 3/3 4/4\n",
      FileFormat::Obj);
  INFO(r.message);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.mesh.faces == std::vector<Index>{0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 2, 3});
  CHECK(r.mesh.corner_texcoords == r.mesh.faces);  // vt k goes with v k here
  CHECK(r.polygons_read == 3);
  CHECK(r.polygons_triangulated == 2);
}

TEST_CASE("io: obj texture coordinates are kept only when every face has them") {
  const std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";
  SUBCASE("a face without vt") {
    const ReadResult r = parse(head + "f 1/1 2/2 3/3\nf 2 4 3\n", FileFormat::Obj);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.mesh.texcoords.empty());
    CHECK(r.mesh.corner_texcoords.empty());
    CHECK(r.mesh.num_faces() == 2);
  }
  SUBCASE("a face with vt on some corners only") {
    const ReadResult r = parse(head + "f 1/1 2/2 3\n", FileFormat::Obj);
    REQUIRE(r.status == Status::Ok);
    CHECK(!r.mesh.has_texcoords());
  }
  SUBCASE("v//vn has no texture coordinates") {
    const ReadResult r = parse(head + "vn 0 0 1\nf 1//1 2//1 3//1\n", FileFormat::Obj);
    REQUIRE(r.status == Status::Ok);
    CHECK(!r.mesh.has_texcoords());
    CHECK(r.mesh.faces == std::vector<Index>{0, 1, 2});
  }
  SUBCASE("no faces, no texture coordinates") {
    const ReadResult r = parse(head, FileFormat::Obj);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.mesh.texcoords.empty());
    CHECK(r.mesh.num_vertices() == 4);
  }
}

TEST_CASE("io: obj forward references, CRLF, continuations and a byte order mark") {
  SUBCASE("positive indices may refer forward") {
    const ReadResult r = parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", FileFormat::Obj);
    INFO(r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.mesh.faces == std::vector<Index>{0, 1, 2});
  }
  SUBCASE("CRLF and backslash continuations") {
    const ReadResult r =
        parse("\xEF\xBB\xBFv 0 0 0\r\nv 1 \\\r\n0 0\r\nv 0 1 0 \t \r\nf 1 2 \\\n3\r\nv 2 2 2\r\nv 3 3 x\r\n",
              FileFormat::Obj);
    // The malformed coordinate is on line 8 (lines 2-3 and 5-6 are joined but still counted).
    CHECK(r.status == Status::ParseError);
    CHECK(r.line == 8);
    CHECK(r.element == Element::Vertex);
    CHECK(r.element_index == 4);
    const ReadResult ok = parse("v 0 0 0\r\nv 1 \\\r\n0 0\r\nv 0 1 0\r\nf 1 2 \\\n3\r\n", FileFormat::Obj);
    INFO(ok.message);
    REQUIRE(ok.status == Status::Ok);
    CHECK(ok.mesh.positions == std::vector<double>{0, 0, 0, 1, 0, 0, 0, 1, 0});
    CHECK(ok.mesh.faces == std::vector<Index>{0, 1, 2});
  }
  SUBCASE("a comment ending in a backslash does not swallow the next line") {
    const ReadResult r = parse("# C:\\meshes\\\nv 0 0 0\nv 1 0 0 # \\\nv 0 1 0\nf 1 2 3\n", FileFormat::Obj);
    INFO(r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.mesh.num_vertices() == 3);
    CHECK(r.mesh.num_faces() == 1);
  }
  SUBCASE("underflow gives zero, overflow is not finite") {
    const ReadResult r = parse("v 1e-400 -1e-400 0.0000000000000000000000000000001e-320\n", FileFormat::Obj);
    INFO(r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(same_bits(r.mesh.positions, {0.0, -0.0, 0.0}));
    CHECK(parse("v 1 2 1e99999999999999999999999\n", FileFormat::Obj).status == Status::NonFiniteCoordinate);
    CHECK(parse("v 1 2 -12345678901234567890e300\n", FileFormat::Obj).status == Status::NonFiniteCoordinate);
    CHECK(parse("v 1 2 INF\n", FileFormat::Obj).status == Status::NonFiniteCoordinate);
    CHECK(parse("v 1 2 infinity\n", FileFormat::Obj).status == Status::NonFiniteCoordinate);
  }
  SUBCASE("empty input and comments only are an empty mesh") {
    for (const char* text : {"", "# nothing\n", "\n\n\r\n", "g only\n"}) {
      CAPTURE(text);
      const ReadResult r = parse(text, FileFormat::Obj);
      CHECK(r.status == Status::Ok);
      CHECK(r.mesh.positions.empty());
      CHECK(r.mesh.faces.empty());
    }
  }
}

TEST_CASE("io: off headers, comments, extra columns and split faces") {
  struct Variant {
    const char* label;
    std::string text;
  };
  const std::vector<Variant> variants = {
      {"plain", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n"},
      {"comments and blank lines first",
       "\n# one\n\n# two\nOFF\n# between\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n"
       "3 0 1 2\n3 1 3 2\n"},
      {"counts on the keyword line", "OFF 4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n"},
      {"no edge count", "OFF\n4 2\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n"},
      {"CRLF", "OFF\r\n4 2 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n1 1 0\r\n3 0 1 2\r\n3 1 3 2\r\n"},
      {"comments everywhere",
       "OFF # keyword\n4 2 0 # counts\n0 0 0 # v0\n# line\n1 0 0\n0 1 0\n1 1 0\n"
       "3 0 1 2 # f0\n3 1 3 2\n"},
      {"COFF colours",
       "COFF\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n1 1 0 1 1 1 1\n"
       "3 0 1 2\n3 1 3 2\n"},
      {"NOFF normals", "NOFF\n4 2 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 0 0 0 1\n3 0 1 2\n3 1 3 2\n"},
      {"STCNOFF",
       "STCNOFF\n4 2 0\n0 0 0 0 0 1 1 1 1 1 0 0\n1 0 0 0 0 1 1 1 1 1 0 0\n0 1 0 0 0 1 1 1 1 1 0 0\n"
       "1 1 0 0 0 1 1 1 1 1 0 0\n3 0 1 2\n3 1 3 2\n"},
      {"face colours", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2 255 0 0\n3 1 3 2 0.5 0.5 0.5 1\n"},
      {"a face continued on the next line", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0\n1 2\n3 1 3 2\n"},
      {"trailing content", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\nanything at all\n"},
      {"no final newline", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2"},
      {"tabs and leading +", "OFF\n4\t2\t0\n+0 0 0\n1.0e0 -0 0\n0 1 0\n1 1 0\n\t3 0 1 2\n3 1 3 2\n"},
  };
  for (const Variant& v : variants) {
    CAPTURE(v.label);
    const ReadResult r = parse(v.text, FileFormat::Off);
    INFO(r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.mesh.positions == std::vector<double>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});
    CHECK(r.mesh.faces == std::vector<Index>{0, 1, 2, 1, 3, 2});
    CHECK(r.format == FileFormat::Off);
  }
  const ReadResult quads =
      parse("OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 2\n4 0 1 2 3\n5 0 1 2 3 4\n", FileFormat::Off);
  REQUIRE(quads.status == Status::Ok);
  CHECK(quads.mesh.faces == std::vector<Index>{0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3, 0, 3, 4});
  CHECK(quads.polygons_read == 2);
  CHECK(quads.polygons_triangulated == 2);
  const ReadResult empty = parse("OFF\n0 0 0\n", FileFormat::Off);
  CHECK(empty.status == Status::Ok);
  CHECK(empty.mesh.positions.empty());
}

TEST_CASE("io: ply ascii with extra elements, properties and types") {
  const std::string ply =
      "ply\r\n"
      "format ascii 1.0\r\n"
      "comment made by hand\r\n"
      "obj_info nothing\r\n"
      "element material 1\r\n"
      "property uchar red\r\n"
      "property list uchar float weights\r\n"
      "element vertex 4\r\n"
      "property float nx\r\n"
      "property double x\r\n"
      "property float32 y\r\n"
      "property int z\r\n"
      "property uchar red\r\n"
      "element face 2\r\n"
      "property uchar flags\r\n"
      "property list uint8 uint32 vertex_index\r\n"
      "property list uchar float texcoord\r\n"
      "element edge 1\r\n"
      "property int vertex1\r\n"
      "property int vertex2\r\n"
      "end_header\r\n"
      "255 3 0.1 0.2 0.3\r\n"
      "9 0 0 0 1\r\n"
      "9 1 0 0 2\r\n"
      "9 0 1 0 3\r\n"
      "9 1 1 0 4\r\n"
      "7 4 0 1 3 2 0\r\n"
      "7 3 1 3 2 6 0 0 1 1 0 1\r\n"
      "0 1\r\n";
  const ReadResult r = parse(ply, FileFormat::PlyAscii);
  INFO(r.message);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.format == FileFormat::PlyAscii);
  CHECK(r.mesh.positions == std::vector<double>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});
  CHECK(r.mesh.faces == std::vector<Index>{0, 1, 3, 0, 3, 2, 1, 3, 2});
  CHECK(r.polygons_read == 2);
  CHECK(r.polygons_triangulated == 1);
  // Read with the binary format requested: the header decides.
  const ReadResult again = parse(ply, FileFormat::PlyBinary);
  CHECK(again.status == Status::Ok);
  CHECK(again.format == FileFormat::PlyAscii);
}

TEST_CASE("io: ply face element before the vertex element") {
  const ReadResult r = parse(
      "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n3 2 1 0\n0 0 0\n1 0 0\n0 1 0\n",
      FileFormat::PlyAscii);
  INFO(r.message);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.mesh.faces == std::vector<Index>{2, 1, 0});
  CHECK(r.mesh.num_vertices() == 3);
}

TEST_CASE("io: binary ply in both byte orders with every scalar type") {
  for (const bool big_endian : {false, true}) {
    CAPTURE(big_endian);
    check_all_types_mesh(parse(binary_ply_all_types(big_endian), FileFormat::PlyBinary));
  }
  const ReadResult tri = parse(binary_triangle_ply(), FileFormat::PlyBinary);
  REQUIRE(tri.status == Status::Ok);
  CHECK(tri.mesh.positions == std::vector<double>{0, 0, 0, 1, 0, 0, 0, 1, 0});
}

// ---------------------------------------------------------------------------------------------
// Errors.

namespace {

struct ErrorCase {
  const char* label;
  FileFormat format;
  std::string data;
  Status status;
  std::int64_t line;  ///< or byte offset
  Element element;
  std::int64_t element_index;
  std::string message_part;
};

void check_error(const ErrorCase& c) {
  CAPTURE(c.label);
  const ReadResult r = parse(c.data, c.format);
  INFO(r.message);
  CHECK(r.status == c.status);
  CHECK(r.line == c.line);
  CHECK(r.element == c.element);
  CHECK(r.element_index == c.element_index);
  CHECK(r.message.find(c.message_part) != std::string::npos);
  CHECK(r.message.rfind("test" + extension(c.format) + ": ", 0) == 0);
}

const std::string kTriangleVertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
const std::string kOffHead = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
const std::string kPlyHead =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";

}  // namespace

TEST_CASE("io: obj errors give the status, line and element") {
  using S = Status;
  using E = Element;
  const FileFormat F = FileFormat::Obj;
  const std::vector<ErrorCase> cases = {
      {"index beyond the vertices", F, kTriangleVertices + "f 1 2 3\nf 1 2 4\n", S::IndexOutOfRange, 5,
       E::Face, 1, "line 5: face 1 refers to vertex 4, but the file has 3 vertices"},
      {"index 0", F, kTriangleVertices + "f 1 2 0\n", S::IndexOutOfRange, 4, E::Face, 0,
       "OBJ indices start at 1"},
      {"relative index before the first vertex", F, kTriangleVertices + "f -4 -1 -2\n", S::IndexOutOfRange, 4,
       E::Face, 0, "vertex -4, but only 3 vertices precede it"},
      {"forward reference never satisfied", F, "f 1 2 9\n" + kTriangleVertices + "f 1 2 3\n",
       S::IndexOutOfRange, 1, E::Face, 0, "face 0 refers to vertex 9, but the file has 3 vertices"},
      {"texture index out of range", F, kTriangleVertices + "vt 0 0\nf 1/1 2/1 3/2\n", S::IndexOutOfRange, 5,
       E::Face, 0, "texture coordinate 2, but the file has 1 texture coordinate"},
      {"nan coordinate", F, kTriangleVertices + "v 1 nan 0\n", S::NonFiniteCoordinate, 4, E::Vertex, 3,
       "'nan'"},
      {"inf coordinate", F, "v inf 0 0\n", S::NonFiniteCoordinate, 1, E::Vertex, 0, "not finite"},
      {"overflowing coordinate", F, "v 0 0 0\n\nv 0 0 -1e999\n", S::NonFiniteCoordinate, 3, E::Vertex, 1,
       "'-1e999'"},
      {"malformed coordinate", F, "v 0 0 0\nv 0 banana 0\n", S::ParseError, 2, E::Vertex, 1, "'banana'"},
      {"comma decimal", F, "v 0,5 0 0\n", S::ParseError, 1, E::Vertex, 0, "'0,5'"},
      {"too few coordinates", F, "v 0 0\n", S::ParseError, 1, E::Vertex, 0, "fewer than 3 coordinates"},
      {"face with two vertices", F, kTriangleVertices + "f 1 2\n", S::ParseError, 4, E::Face, 0,
       "has 2 vertices"},
      {"face with four fields", F, kTriangleVertices + "f 1/1/1/1 2 3\n", S::ParseError, 4, E::Face, 0,
       "more than three fields"},
      {"malformed index", F, kTriangleVertices + "f 1 two 3\n", S::ParseError, 4, E::Face, 0, "'two'"},
      {"malformed texture index", F, kTriangleVertices + "vt 0 0\nf 1/x 2/1 3/1\n", S::ParseError, 5, E::Face,
       0, "'x'"},
      {"malformed vt", F, "vt 0 q\n", S::ParseError, 1, E::None, -1, "texture coordinate 0"},
  };
  for (const ErrorCase& c : cases) check_error(c);
}

TEST_CASE("io: off errors give the status, line and element") {
  using S = Status;
  using E = Element;
  const FileFormat F = FileFormat::Off;
  const std::vector<ErrorCase> cases = {
      {"empty", F, "", S::ParseError, 1, E::None, -1, "no OFF keyword"},
      {"comments only", F, "# one\n# two\n", S::ParseError, 3, E::None, -1, "no OFF keyword"},
      {"not OFF", F, "# c\nPLY\n3 1 0\n", S::ParseError, 2, E::None, -1, "found 'PLY'"},
      {"4OFF", F, "4OFF\n3 1 0\n", S::UnknownFormat, 1, E::None, -1, "4-D or n-D"},
      {"nOFF", F, "nOFF\n4\n3 1 0\n", S::UnknownFormat, 1, E::None, -1, "4-D or n-D"},
      {"binary OFF", F, "OFF BINARY\n", S::UnknownFormat, 1, E::None, -1, "binary OFF"},
      {"malformed count", F, "OFF\n3 x 0\n", S::ParseError, 2, E::None, -1, "number of faces"},
      {"negative count", F, "OFF\n-3 1 0\n", S::ParseError, 2, E::None, -1, "number of vertices"},
      {"no counts", F, "OFF\n", S::ParseError, 2, E::None, -1, "ends before the number of vertices"},
      {"index out of range", F, kOffHead + "3 0 1 3\n", S::IndexOutOfRange, 6, E::Face, 0,
       "line 6: face 0 refers to vertex 3, but the file has 3 vertices"},
      {"negative index", F, kOffHead + "3 0 -1 2\n", S::IndexOutOfRange, 6, E::Face, 0, "vertex -1"},
      {"index on a continued line", F, kOffHead + "3 0\n1 7\n", S::IndexOutOfRange, 7, E::Face, 0,
       "vertex 7"},
      {"face with two vertices", F, kOffHead + "2 0 1\n", S::ParseError, 6, E::Face, 0, "has 2 vertices"},
      {"malformed index", F, kOffHead + "3 0 1 x\n", S::ParseError, 6, E::Face, 0, "'x'"},
      {"nan coordinate", F, "OFF\n3 1 0\n0 0 0\n1 NaN 0\n", S::NonFiniteCoordinate, 4, E::Vertex, 1, "'NaN'"},
      {"overflowing coordinate", F, "OFF\n3 1 0\n0 0 0\n1 0 0\n1e400 0 0\n", S::NonFiniteCoordinate, 5,
       E::Vertex, 2, "'1e400'"},
      {"malformed coordinate", F, "OFF\n3 1 0\n0 0 0\n1 0x1 0\n", S::ParseError, 4, E::Vertex, 1, "'0x1'"},
      {"truncated in the vertices", F, "OFF\n3 1 0\n0.0000000 0.0000000 0.0000000\n1.0000000 0.0000000",
       S::ParseError, 4, E::Vertex, 1, "line 4: the file ends after 1 of 3 vertices"},
      {"truncated in the faces", F, kOffHead + "3 0 1", S::ParseError, 6, E::Face, 0,
       "ends after 3 vertices and 0 of 1 face"},
      {"declared counts the file cannot hold", F, "OFF\n1000000 1 0\n0 0 0\n", S::ParseError, 4, E::Vertex, 1,
       "ends after 1 of 1000000 vertices"},
      {"counts beyond what a mesh can index", F, "OFF\n4000000000 1 0\n", S::FileTooLarge, 2, E::None, -1,
       "4000000000 vertices"},
  };
  for (const ErrorCase& c : cases) check_error(c);
}

TEST_CASE("io: ply errors give the status, line or byte offset, and element") {
  using S = Status;
  using E = Element;
  const FileFormat F = FileFormat::PlyAscii;
  std::size_t body = 0;
  const std::string tri = binary_triangle_ply(&body);
  const auto at = [&](std::size_t offset) { return static_cast<std::int64_t>(offset); };
  std::string nan_y = tri;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan_y.data() + body + 4 * 4, &nan, 4);  // vertex 1, y (host order = little endian here)
  std::string bad_index = tri;
  const std::int32_t five = 5;
  std::memcpy(bad_index.data() + body + 36 + 1 + 8, &five, 4);  // face 0, third index
  std::string huge_list = tri;
  huge_list[body + 36] = static_cast<char>(200);
  const std::vector<ErrorCase> cases = {
      {"not ply", F, "plx\n", S::ParseError, 1, E::None, -1, "does not start with the line 'ply'"},
      {"no end_header", F, "ply\nformat ascii 1.0\nelement vertex 0\n", S::ParseError, 4, E::None, -1,
       "end_header"},
      {"no format", F, "ply\nelement vertex 0\nend_header\n", S::ParseError, 3, E::None, -1,
       "no format line"},
      {"unknown format", F, "ply\nformat binary_middle_endian 1.0\nend_header\n", S::UnknownFormat, 2,
       E::None, -1, "binary_middle_endian"},
      {"unknown type", F, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
       S::ParseError, 4, E::None, -1, "'float128'"},
      {"property before element", F, "ply\nformat ascii 1.0\nproperty float x\nend_header\n", S::ParseError,
       3, E::None, -1, "before any element"},
      {"unknown keyword", F, "ply\nformat ascii 1.0\nelephant 3\nend_header\n", S::ParseError, 3, E::None, -1,
       "'elephant'"},
      {"vertex without z", F,
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
       S::ParseError, 3, E::None, -1, "no property z"},
      {"face without indices", F,
       "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int corners\nend_header\n3 0 1 2\n",
       S::ParseError, 3, E::None, -1, "vertex_indices"},
      {"float indices", F,
       "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar float vertex_indices\nend_header\n3 0 1 "
       "2\n",
       S::ParseError, 3, E::None, -1, "non-integer"},
      {"ascii index out of range", F, kPlyHead + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", S::IndexOutOfRange, 13,
       E::Face, 0, "line 13: face 0 refers to vertex 3, but the file has 3 vertices"},
      {"ascii face with two vertices", F, kPlyHead + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", S::ParseError, 13,
       E::Face, 0, "has 2 vertices"},
      {"ascii negative list length", F, kPlyHead + "0 0 0\n1 0 0\n0 1 0\n-1\n", S::ParseError, 13, E::Face, 0,
       "has -1 vertices"},
      {"ascii nan", F, kPlyHead + "0 0 0\n1 0 0\n0 -nan 0\n3 0 1 2\n", S::NonFiniteCoordinate, 12, E::Vertex,
       2, "'-nan'"},
      {"ascii malformed", F, kPlyHead + "0 0 0\n1 0 0\n0 zero 0\n3 0 1 2\n", S::ParseError, 12, E::Vertex, 2,
       "'zero'"},
      {"ascii truncated", F, kPlyHead + "0 0 0\n1 0 0\n0 1", S::ParseError, 12, E::Vertex, 2,
       "the file ends"},
      {"binary truncated", FileFormat::PlyBinary, tri.substr(0, tri.size() - 3), S::ParseError,
       at(tri.size() - 3), E::Face, 0, "the file ends in record 0 of element face"},
      {"binary truncated in the vertices", FileFormat::PlyBinary, tri.substr(0, body + 10), S::ParseError,
       at(body + 10), E::Vertex, 0, "byte " + std::to_string(body + 10)},
      {"binary nan", FileFormat::PlyBinary, nan_y, S::NonFiniteCoordinate, at(body + 16), E::Vertex, 1,
       "not finite"},
      {"binary index out of range", FileFormat::PlyBinary, bad_index, S::IndexOutOfRange, at(body + 45),
       E::Face, 0, "face 0 refers to vertex 5"},
      {"binary list longer than the file", FileFormat::PlyBinary, huge_list, S::ParseError, at(tri.size()),
       E::Face, 0, "the file ends"},
      {"vertex count beyond what a mesh can index", FileFormat::PlyBinary,
       "ply\nformat binary_little_endian 1.0\nelement vertex 3000000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       S::FileTooLarge, 3, E::None, -1, "3000000000"},
      {"face count beyond what a mesh can index", FileFormat::PlyBinary,
       "ply\nformat binary_little_endian 1.0\nelement face 2147483648\n"
       "property list uchar int vertex_indices\nend_header\n",
       S::FileTooLarge, 3, E::None, -1, "2147483648"},
  };
  if (std::endian::native != std::endian::little) return;  // the hand-patched bytes assume it
  for (const ErrorCase& c : cases) check_error(c);
}

TEST_CASE("io: huge declared counts are refused quickly without allocating") {
  // Under AddressSanitizer an attempt to reserve for these counts would abort the test.
  const std::vector<std::pair<FileFormat, std::string>> inputs = {
      {FileFormat::Off, "OFF\n4000000000 1 0\n"},
      {FileFormat::Off, "OFF\n2000000000 700000000 0\n0 0 0\n"},
      {FileFormat::Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2000000000 0 1 2\n"},
      {FileFormat::PlyBinary,
       "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty double x\nproperty double "
       "y\n"
       "property double z\nelement face 700000000\nproperty list uint int vertex_indices\nend_header\n"},
      {FileFormat::PlyAscii,
       "ply\nformat ascii 1.0\nelement vertex 2000000000\nproperty double x\nproperty double y\n"
       "property double z\nend_header\n1 2 3\n"},
      {FileFormat::PlyBinary,
       "ply\nformat binary_little_endian 1.0\nelement junk 9223372036854775807\nend_header\n"},
      {FileFormat::PlyBinary,
       "ply\nformat binary_little_endian 1.0\nelement junk 9223372036854775807\nproperty list uint double v\n"
       "end_header\n\xff\xff\xff\xff"},
  };
  for (const auto& [format, data] : inputs) {
    CAPTURE(data);
    const auto start = std::chrono::steady_clock::now();
    const ReadResult r = parse(data, format);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    INFO(r.message);
    if (data.find("element junk 9223372036854775807\nend_header") != std::string::npos) {
      CHECK(r.status == Status::Ok);  // an element without properties has no data
    } else {
      CHECK((r.status == Status::FileTooLarge || r.status == Status::ParseError));
    }
    CHECK(seconds < 1.0);
  }
}

TEST_CASE("io: file errors: missing, directory, too large, unknown extension") {
  TempDir dir;
  const std::string missing = (dir / "missing.obj").string();
  ReadResult r = ricci::read_mesh(missing);
  CHECK(r.status == Status::FileNotFound);
  CHECK(r.message.rfind(missing + ": ", 0) == 0);

  r = ricci::read_mesh((dir / "sub" / "missing.off").string());
  CHECK(r.status == Status::FileNotFound);

  fs::create_directory(dir / "folder.obj");
  r = ricci::read_mesh((dir / "folder.obj").string());
  CHECK(r.status == Status::FileUnreadable);
  CHECK(r.message.find("directory") != std::string::npos);

  ricci_test::write_bytes(dir / "tri.obj", kTriangleObj);
  ricci::ReadOptions small;
  small.max_file_bytes = 10;
  r = ricci::read_mesh((dir / "tri.obj").string(), small);
  CHECK(r.status == Status::FileTooLarge);
  CHECK(r.mesh.positions.empty());
  r = ricci::read_mesh((dir / "tri.obj").string());
  CHECK(r.status == Status::Ok);
  CHECK(r.mesh.num_faces() == 1);

  ricci_test::write_bytes(dir / "tri.3ds", kTriangleObj);
  r = ricci::read_mesh((dir / "tri.3ds").string());
  CHECK(r.status == Status::UnknownFormat);
  ricci::ReadOptions as_obj;
  as_obj.format = FileFormat::Obj;
  CHECK(ricci::read_mesh((dir / "tri.3ds").string(), as_obj).status == Status::Ok);
  CHECK(ricci::read_mesh_from_memory(kTriangleObj, "blob").status == Status::UnknownFormat);
  CHECK(ricci::read_mesh_from_memory(kTriangleObj, "blob", small).status == Status::FileTooLarge);

  if (::geteuid() != 0) {  // root reads anything
    ricci_test::write_bytes(dir / "secret.obj", kTriangleObj);
    fs::permissions(dir / "secret.obj", fs::perms::none);
    r = ricci::read_mesh((dir / "secret.obj").string());
    CHECK(r.status == Status::FileUnreadable);
    fs::permissions(dir / "secret.obj", fs::perms::owner_all);
  }
}

// ---------------------------------------------------------------------------------------------
// Robustness.

namespace {

/// Small valid files of every format with quads, texture coordinates, comments and extra data.
std::vector<std::pair<FileFormat, std::string>> robustness_inputs() {
  std::mt19937_64 rng(5);
  Mesh m = random_mesh(rng, true);
  m.positions.resize(3 * 8);
  m.faces.resize(3 * 6);
  for (Index& v : m.faces) v %= 8;
  m.corner_texcoords.resize(m.faces.size());
  for (Index& t : m.corner_texcoords) t %= m.num_texcoords();
  std::vector<std::pair<FileFormat, std::string>> inputs;
  for (const FileFormat format : kAllFormats) inputs.emplace_back(format, ricci::serialize_mesh(m, format));
  inputs.emplace_back(FileFormat::Obj,
                      "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0 # c\nv 0 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\n"
                      "f 1/1/1 2/2/1 3/1/1 4/2/1\nf -1//1 -2//1 -3//1\nf 1 \\\n2 3\n");
  inputs.emplace_back(FileFormat::Off,
                      "# c\nCOFF 4 2 0\n0 0 0 1 1 1\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 9 9\n3 0\n2 3\n");
  inputs.emplace_back(FileFormat::PlyBinary, binary_ply_all_types(false));
  inputs.emplace_back(FileFormat::PlyBinary, binary_ply_all_types(true));
  return inputs;
}

}  // namespace

TEST_CASE("io: every truncation of valid files is handled") {
  for (const auto& [format, data] : robustness_inputs()) {
    CAPTURE(format_label(format));
    const std::string name = "test" + extension(format);
    REQUIRE(parse(data, format).status == Status::Ok);
    std::string first_problem;
    for (std::size_t n = 0; n <= data.size() && first_problem.empty(); ++n) {
      const std::string problem = check_sane(parse_exact(std::string_view(data).substr(0, n), format), name);
      if (!problem.empty()) first_problem = "length " + std::to_string(n) + ": " + problem;
    }
    CHECK(first_problem == "");
  }
}

TEST_CASE("io: random byte changes and random bytes are handled") {
  static const char kInteresting[] = "0123456789 .-+eE\n\r\t#/\\fvOFFplyxyz\0\xff";
  for (const std::uint64_t seed : {11ull, 12ull, 13ull}) {
    CAPTURE(seed);
    std::mt19937_64 rng(seed);
    auto random_byte = [&]() {
      return rng() % 2 ? kInteresting[rng() % (sizeof kInteresting - 1)] : static_cast<char>(rng() & 0xff);
    };
    std::string first_problem;
    for (const auto& [format, data] : robustness_inputs()) {
      const std::string name = "test" + extension(format);
      for (int trial = 0; trial < 150 && first_problem.empty(); ++trial) {
        std::string changed = data;
        const int changes = 1 + static_cast<int>(rng() % 4);
        for (int k = 0; k < changes; ++k) changed[rng() % changed.size()] = random_byte();
        const std::string problem = check_sane(parse_exact(changed, format), name);
        if (!problem.empty())
          first_problem =
              std::string(format_label(format)) + " flip trial " + std::to_string(trial) + ": " + problem;
      }
    }
    for (const FileFormat format : kAllFormats) {
      const std::string name = "test" + extension(format);
      static const char* const kPrefixes[] = {
          "", "OFF\n", "ply\nformat ascii 1.0\n",
          "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
          "property float x\nproperty float y\nproperty float z\n"
          "element face 2\nproperty list uchar int vertex_indices\nend_header\n"};
      for (int trial = 0; trial < 100 && first_problem.empty(); ++trial) {
        std::string bytes = kPrefixes[rng() % std::size(kPrefixes)];
        const std::size_t n = rng() % 600;
        for (std::size_t i = 0; i < n; ++i) bytes += random_byte();
        const std::string problem = check_sane(parse_exact(bytes, format), name);
        if (!problem.empty())
          first_problem =
              std::string(format_label(format)) + " random trial " + std::to_string(trial) + ": " + problem;
      }
    }
    CHECK(first_problem == "");
  }
}

// ---------------------------------------------------------------------------------------------
// Writing.

TEST_CASE("io: atomic write replaces the target and leaves nothing else") {
  TempDir dir;
  const fs::path target = dir / "report.txt";
  ricci_test::write_bytes(target, "old content");
  fs::permissions(target, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  const ricci::WriteResult w = ricci::write_file_atomic(target.string(), "new content");
  INFO(w.message);
  REQUIRE(w.status == Status::Ok);
  CHECK(w.bytes_written == 11);
  CHECK(ricci_test::read_bytes(target) == "new content");
  CHECK(entries(dir.path()) == std::vector<std::string>{"report.txt"});
  // The permissions of the replaced file are kept.
  CHECK((fs::status(target).permissions() & fs::perms::all) ==
        (fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read));
  // A new file in the current directory (a path without a directory part) works too.
  const fs::path old_cwd = fs::current_path();
  fs::current_path(dir.path());
  CHECK(ricci::write_file_atomic("plain.txt", "x").status == Status::Ok);
  fs::current_path(old_cwd);
  CHECK(ricci_test::read_bytes(dir / "plain.txt") == "x");
}

TEST_CASE("io: atomic write failure leaves no temporary and the target unchanged") {
  TempDir dir;
  SUBCASE("missing directory") {
    const ricci::WriteResult w = ricci::write_file_atomic((dir / "no" / "such" / "out.obj").string(), "data");
    INFO(w.message);
    CHECK(w.status == Status::WriteFailed);
    CHECK(w.message.find("does not exist") != std::string::npos);
    CHECK(entries(dir.path()).empty());
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    m.faces = {0, 1, 2};
    CHECK(ricci::write_mesh((dir / "nope" / "m.off").string(), m).status == Status::WriteFailed);
    CHECK(entries(dir.path()).empty());
  }
  SUBCASE("the target is a directory") {
    fs::create_directory(dir / "out.obj");
    const ricci::WriteResult w = ricci::write_file_atomic((dir / "out.obj").string(), "data");
    CHECK(w.status == Status::WriteFailed);
    CHECK(fs::is_directory(dir / "out.obj"));
    CHECK(entries(dir.path()) == std::vector<std::string>{"out.obj"});
  }
  SUBCASE("read-only directory") {
    if (::geteuid() == 0) return;  // root writes anyway
    ricci_test::write_bytes(dir / "out.obj", "original");
    fs::permissions(dir.path(), fs::perms::owner_read | fs::perms::owner_exec);
    const ricci::WriteResult w = ricci::write_file_atomic((dir / "out.obj").string(), "data");
    fs::permissions(dir.path(), fs::perms::owner_all);
    INFO(w.message);
    CHECK(w.status == Status::WriteFailed);
    CHECK(w.message.find("permission denied") != std::string::npos);
    CHECK(ricci_test::read_bytes(dir / "out.obj") == "original");
    CHECK(entries(dir.path()) == std::vector<std::string>{"out.obj"});
  }
}

TEST_CASE("io: protected paths are refused and left untouched") {
  TempDir dir;
  const fs::path input = dir / "input.obj";
  ricci_test::write_bytes(input, kTriangleObj);
  fs::create_directory(dir / "sub");
  fs::create_hard_link(input, dir / "hard.obj");
  fs::create_symlink(input, dir / "link.obj");
  Mesh m;
  m.positions = {0, 0, 0, 2, 0, 0, 0, 2, 0};
  m.faces = {0, 2, 1};
  ricci::WriteOptions wo;
  wo.protected_paths = {input.string()};
  for (const fs::path& target :
       {input, dir / "sub" / ".." / "input.obj", dir / "hard.obj", dir / "link.obj"}) {
    CAPTURE(target.string());
    const ricci::WriteResult w = ricci::write_mesh(target.string(), m, wo);
    CHECK(w.status == Status::OutputIsInput);
    CHECK(ricci::write_file_atomic(target.string(), "x", wo.protected_paths).status == Status::OutputIsInput);
  }
  CHECK(ricci_test::read_bytes(input) == kTriangleObj);
  CHECK(entries(dir.path()) == std::vector<std::string>{"hard.obj", "input.obj", "link.obj", "sub"});
  // A protected path that does not exist yet is matched lexically.
  const ricci::WriteResult w = ricci::write_file_atomic((dir / "sub" / "new.txt").string(), "x",
                                                        {(dir / "sub" / "." / "new.txt").string()});
  CHECK(w.status == Status::OutputIsInput);
  CHECK(!fs::exists(dir / "sub" / "new.txt"));
  // Other paths are fine.
  CHECK(ricci::write_mesh((dir / "output.obj").string(), m, wo).status == Status::Ok);
}

TEST_CASE("io: write_mesh refuses unknown extensions and inconsistent meshes") {
  TempDir dir;
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.faces = {0, 1, 2};
  CHECK(ricci::write_mesh((dir / "m.3ds").string(), m).status == Status::UnknownFormat);
  Mesh bad_index = m;
  bad_index.faces[2] = 3;
  CHECK(ricci::write_mesh((dir / "m.obj").string(), bad_index).status == Status::InvalidArgument);
  Mesh bad_size = m;
  bad_size.positions.pop_back();
  CHECK(ricci::write_mesh((dir / "m.obj").string(), bad_size).status == Status::InvalidArgument);
  Mesh infinite = m;
  infinite.positions[4] = std::numeric_limits<double>::infinity();
  CHECK(ricci::write_mesh((dir / "m.ply").string(), infinite).status == Status::InvalidArgument);
  Mesh bad_texcoords = m;
  bad_texcoords.texcoords = {0, 0};
  bad_texcoords.corner_texcoords = {0, 0, 1};
  CHECK(ricci::write_mesh((dir / "m.obj").string(), bad_texcoords).status == Status::InvalidArgument);
  CHECK(ricci::write_mesh((dir / "m.off").string(), bad_texcoords).status ==
        Status::Ok);  // not written to OFF
  CHECK(entries(dir.path()) == std::vector<std::string>{"m.off"});
}

// ---------------------------------------------------------------------------------------------
// Real meshes.

TEST_CASE("io: shared meshes give the counts of their README") {
  const fs::path dir = ricci_test::shared_meshes_dir();
  if (dir.empty()) {
    MESSAGE("shared meshes not found; skipped");
    return;
  }
  struct Expected {
    const char* file;
    Index vertices;
    Index triangles;
    std::int64_t polygons;
    std::int64_t triangulated;
    bool texcoords;
  };
  const Expected table[] = {
      {"boundary/camelhead.off", 11381, 22704, 22704, 0, false},          // CRLF
      {"boundary/punctured-torus.obj", 4599, 9184, 9184, 0, true},        // f v/vt/vn, g, usemtl, mtllib
      {"bad/blobby-shuffled.off", 2027, 4050, 4050, 0, false},            // comments before OFF
      {"bad/tref-soup.off", 1280, 640, 320, 320, false},                  // blank line first, quads
      {"bad/moebius.obj", 280, 448, 224, 224, false},                     // quads
      {"genus2/skull_low_resolution.obj", 5154, 10312, 10312, 0, false},  // f v//vn
      {"genus0/spot.obj", 2930, 5856, 5856, 0, true},                     // f v/vt
      {"bad/inverted_triangles.obj", 12577, 24685, 24685, 0, false},      // CRLF
  };
  for (const Expected& e : table) {
    CAPTURE(e.file);
    const fs::path file = dir / e.file;
    if (!fs::exists(file)) continue;
    const ReadResult r = ricci::read_mesh(file.string());
    INFO(r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.mesh.num_vertices() == e.vertices);
    CHECK(r.mesh.num_faces() == e.triangles);
    CHECK(r.polygons_read == e.polygons);
    CHECK(r.polygons_triangulated == e.triangulated);
    CHECK(r.mesh.has_texcoords() == e.texcoords);
    CHECK(check_sane(r, file.string()) == "");
  }
}

TEST_CASE("io: a shared mesh round trips exactly through every format") {
  const fs::path dir = ricci_test::shared_meshes_dir();
  if (dir.empty() || !fs::exists(dir / "genus0/spot.obj")) {
    MESSAGE("shared meshes not found; skipped");
    return;
  }
  const ReadResult original = ricci::read_mesh((dir / "genus0/spot.obj").string());
  REQUIRE(original.status == Status::Ok);
  TempDir tmp;
  for (const FileFormat format : kAllFormats) {
    CAPTURE(format_label(format));
    const fs::path out = tmp / (std::string("spot-") + format_label(format) + extension(format));
    ricci::WriteOptions wo;
    wo.format = format;
    wo.protected_paths = {(dir / "genus0/spot.obj").string()};
    REQUIRE(ricci::write_mesh(out.string(), original.mesh, wo).status == Status::Ok);
    const ReadResult back = ricci::read_mesh(out.string());
    REQUIRE(back.status == Status::Ok);
    CHECK(same_bits(back.mesh.positions, original.mesh.positions));
    CHECK(back.mesh.faces == original.mesh.faces);
    if (format == FileFormat::Obj) {
      CHECK(same_bits(back.mesh.texcoords, original.mesh.texcoords));
      CHECK(back.mesh.corner_texcoords == original.mesh.corner_texcoords);
    }
  }
}

TEST_CASE("io: OBJ and OFF in another encoding or with binary content are named, not read as no faces") {
  const std::string obj = std::string(kTriangleObj);
  const std::string off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  // UTF-16 and UTF-32 as a Windows editor saves them: each ASCII character widened.
  auto widen = [](const std::string& text, int width, bool big_endian, bool mark) {
    std::string out;
    auto put = [&](unsigned code) {
      for (int k = 0; k < width; ++k) {
        const int shift = 8 * (big_endian ? width - 1 - k : k);
        out.push_back(static_cast<char>((code >> shift) & 0xFF));
      }
    };
    if (mark) put(0xFEFF);
    for (const char c : text) put(static_cast<unsigned char>(c));
    return out;
  };
  for (const FileFormat format : {FileFormat::Obj, FileFormat::Off}) {
    const std::string& text = format == FileFormat::Obj ? obj : off;
    CAPTURE(extension(format));
    struct Case {
      std::string what, bytes, expected;
    };
    std::mt19937_64 rng(29);
    std::string noise(4096, '\0');
    for (char& c : noise) c = static_cast<char>(rng() & 0xFF);
    std::string controls = text;  // ASCII with control bytes but no NUL
    for (int k = 0; k < 20; ++k) controls.insert(controls.begin() + 2 * k, static_cast<char>(1 + k % 7));
    const Case cases[] = {
        {"UTF-16 LE with mark", widen(text, 2, false, true), "UTF-16 text (byte-order mark)"},
        {"UTF-16 BE with mark", widen(text, 2, true, true), "UTF-16 text (byte-order mark)"},
        {"UTF-32 LE with mark", widen(text, 4, false, true), "UTF-32 text (byte-order mark)"},
        {"UTF-16 LE without mark", widen(text, 2, false, false), "UTF-16 text without a byte-order mark"},
        {"random bytes", noise, "binary content"},
        {"control bytes", controls, "binary content"},
    };
    for (const Case& c : cases) {
      CAPTURE(c.what);
      const ReadResult r = parse(c.bytes, format);
      CHECK(r.status == Status::ParseError);
      CHECK(r.message.find(c.expected) != std::string::npos);
      CHECK(r.message.find("test" + extension(format)) == 0);  // names the file
      CHECK(r.message.find("byte ") != std::string::npos);     // and where
    }
    // Text that is still text: UTF-8 in a comment, a DOS end-of-file mark, a few stray control bytes.
    const std::string kept[] = {"# räumlich — maillage\n" + text, text + "\x1a", "#\x01\x02\x03 odd\n" + text};
    for (const std::string& k : kept) {
      const ReadResult r = parse(k, format);
      CHECK_MESSAGE(r.status == Status::Ok, r.message);
      CHECK(r.mesh.faces.size() == 3);
    }
  }
}
