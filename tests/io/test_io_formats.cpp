// Tests of the STL and FreeSurfer readers and writers and of the overlay files (curv): exact
// round trips of single-precision meshes, welding (exact and with a tolerance), recognition by
// content, named errors on truncated and corrupted files, and files written and read by nibabel
// (an independent implementation; skipped when python3-nibabel is absent).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/validate.h"
#include "support.h"

namespace {

using ricci::FileFormat;
using ricci::Index;
using ricci::Mesh;
using ricci::OverlayFormat;
using ricci::ReadResult;
using ricci::Status;
using ricci_test::TempDir;

/// A closed octahedron-like random mesh whose coordinates are floats (exact in every format).
Mesh float_mesh(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.25f, 0.25f);
  Mesh m;
  const float base[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const auto& p : base)
    for (int i = 0; i < 3; ++i) m.positions.push_back(static_cast<double>(p[i] + jitter(rng) * 1e-3f * static_cast<float>(seed % 7)));
  m.faces = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return m;
}

ReadResult read_as(const std::string& bytes, const std::string& name, FileFormat f = FileFormat::Auto,
                   double weld = 0) {
  ricci::ReadOptions o;
  o.format = f;
  o.weld_tolerance = weld;
  return ricci::read_mesh_from_memory(bytes, name, o);
}

ricci::WriteOptions freesurfer_options() {
  ricci::WriteOptions o;
  o.format = FileFormat::FreeSurfer;
  return o;
}

/// Same triangles with the same corner positions (vertex numbering may differ).
bool same_triangles(const Mesh& a, const Mesh& b) {
  if (a.faces.size() != b.faces.size()) return false;
  for (std::size_t c = 0; c < a.faces.size(); ++c)
    for (int i = 0; i < 3; ++i)
      if (a.positions[3 * static_cast<std::size_t>(a.faces[c]) + i] != b.positions[3 * static_cast<std::size_t>(b.faces[c]) + i])
        return false;
  return true;
}

}  // namespace

TEST_CASE("io formats: STL binary and ascii round trips are exact for float coordinates") {
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    const Mesh m = float_mesh(seed);
    for (const FileFormat f : {FileFormat::StlBinary, FileFormat::StlAscii}) {
      const std::string bytes = ricci::serialize_mesh(m, f);
      REQUIRE(!bytes.empty());
      const ReadResult r = read_as(bytes, "m.stl");
      REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
      CHECK(r.format == f);
      CHECK(r.mesh.num_vertices() == 6);  // welding restores the shared vertices
      CHECK(same_triangles(r.mesh, m));
      CHECK(r.welded_vertices == 24 - 6);
      CHECK(r.message.find("18 corners welded") != std::string::npos);
      CHECK(!r.format_details.empty());
    }
  }
}

TEST_CASE("io formats: STL welding with a tolerance merges near corners and keeps far ones") {
  Mesh m = float_mesh(7);  // no jitter: vertex 4 is (0, 0, 1)
  std::string bytes = ricci::serialize_mesh(m, FileFormat::StlAscii);
  // Move one corner of vertex 4 (first in face 0) by 1e-4: exact welding splits it off.
  const std::string needle = "vertex " ;
  std::size_t pos = 0;
  for (int k = 0; k < 3; ++k) pos = bytes.find(needle, pos + 1);  // third corner of facet 0 (vertex 4)
  const std::size_t end = bytes.find('\n', pos);
  bytes = bytes.substr(0, pos) + "vertex 0.0001 0 1" + bytes.substr(end);
  const ReadResult exact = read_as(bytes, "m.stl");
  REQUIRE(exact.status == Status::Ok);
  CHECK(exact.mesh.num_vertices() == 7);
  CHECK(exact.welded_vertices == 24 - 7);
  const ReadResult loose = read_as(bytes, "m.stl", FileFormat::Auto, 1e-3);
  REQUIRE(loose.status == Status::Ok);
  CHECK(loose.mesh.num_vertices() == 6);
  const ReadResult tight = read_as(bytes, "m.stl", FileFormat::Auto, 1e-5);
  CHECK(tight.mesh.num_vertices() == 7);
  CHECK(read_as(bytes, "m.stl", FileFormat::Auto, -1).status == Status::InvalidArgument);
  CHECK(read_as(bytes, "m.stl", FileFormat::Auto, INFINITY).status == Status::InvalidArgument);
}

TEST_CASE("io formats: welding that makes a degenerate or non-manifold mesh is refused by validation") {
  // Two triangles; with a large tolerance two corners of the first collapse.
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.01, 0, 0};
  m.faces = {0, 4, 2, 1, 3, 2};
  const std::string bytes = ricci::serialize_mesh(m, FileFormat::StlBinary);
  const ReadResult r = read_as(bytes, "m.stl", FileFormat::Auto, 0.1);
  REQUIRE(r.status == Status::Ok);
  const ricci::LoadResult l = ricci::validate_read(r, "m.stl", {});
  CHECK(l.status != Status::Ok);
  CHECK(l.element == ricci::Element::Face);
}

TEST_CASE("io formats: binary STL whose header starts with solid is read as binary") {
  const Mesh m = float_mesh(2);
  std::string bytes = ricci::serialize_mesh(m, FileFormat::StlBinary);
  std::memcpy(bytes.data(), "solid abc", 9);
  const ReadResult r = read_as(bytes, "m.stl");
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.format == FileFormat::StlBinary);
  CHECK(same_triangles(r.mesh, m));
}

TEST_CASE("io formats: STL errors name the place and the element") {
  const Mesh m = float_mesh(1);
  const std::string bin = ricci::serialize_mesh(m, FileFormat::StlBinary);
  ReadResult r = read_as(bin.substr(0, bin.size() - 7), "t.stl");
  CHECK(r.status == Status::ParseError);
  CHECK(r.message.find("t.stl: byte ") == 0);
  CHECK(r.message.find("ends in triangle 7") != std::string::npos);
  r = read_as(bin.substr(0, 40), "t.stl");
  CHECK(r.status == Status::ParseError);
  std::string nan = bin;
  const float q = NAN;
  std::memcpy(&nan[84 + 50 * 3 + 12 + 4], &q, 4);
  r = read_as(nan, "t.stl");
  CHECK(r.status == Status::NonFiniteCoordinate);
  CHECK(r.element_index == 3);
  const std::string ascii = ricci::serialize_mesh(m, FileFormat::StlAscii);
  r = read_as(ascii.substr(0, ascii.size() / 2), "a.stl");
  CHECK(r.status == Status::ParseError);
  CHECK(r.message.find("a.stl: line ") == 0);
  std::string bad = ascii;
  bad[bad.find("vertex ") + 7] = 'x';
  r = read_as(bad, "a.stl");
  CHECK(r.status == Status::ParseError);
  CHECK(r.message.find("facet 0") != std::string::npos);
  r = read_as("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n", "b.stl");
  CHECK(r.status == Status::ParseError);
  CHECK(r.message.find("needs at least 3") != std::string::npos);
}

TEST_CASE("io formats: FreeSurfer surface round trip is exact and recognised without extension") {
  const Mesh m = float_mesh(5);
  const std::string bytes = ricci::serialize_mesh(m, FileFormat::FreeSurfer);
  CHECK(ricci::format_from_content(bytes) == FileFormat::FreeSurfer);
  const ReadResult r = read_as(bytes, "lh.white");
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.format == FileFormat::FreeSurfer);
  CHECK(r.mesh.positions == m.positions);
  CHECK(r.mesh.faces == m.faces);
  CHECK(r.format_details.find("created by ricci") != std::string::npos);
  TempDir dir;
  REQUIRE(ricci::write_mesh((dir / "lh.white").string(), m, freesurfer_options()).status == Status::Ok);
  const ReadResult f = ricci::read_mesh((dir / "lh.white").string());
  CHECK(f.status == Status::Ok);
  CHECK(f.mesh.faces == m.faces);
}

TEST_CASE("io formats: FreeSurfer errors are named") {
  const Mesh m = float_mesh(5);
  const std::string bytes = ricci::serialize_mesh(m, FileFormat::FreeSurfer);
  ReadResult r = read_as(bytes.substr(0, bytes.size() - 5), "lh.white", FileFormat::FreeSurfer);
  CHECK(r.status == Status::ParseError);
  CHECK(r.element == ricci::Element::Face);
  CHECK(r.message.find("of the 8 faces") != std::string::npos);
  std::string bad = bytes;
  bad[bad.size() - 1] = 9;  // last index 9 of 6 vertices
  r = read_as(bad, "lh.white", FileFormat::FreeSurfer);
  CHECK(r.status == Status::IndexOutOfRange);
  CHECK(r.element_index == 7);
  std::string huge = bytes;
  const std::size_t counts = huge.find("\n\n") + 2;
  huge[counts] = 0x7f;  // vertex count near 2^31
  r = read_as(huge, "lh.white", FileFormat::FreeSurfer);
  CHECK((r.status == Status::ParseError || r.status == Status::FileTooLarge));
  r = read_as(std::string("\xFF\xFF\xFF", 3) + std::string(40, '\0'), "lh.quad", FileFormat::FreeSurfer);
  CHECK(r.status == Status::UnknownFormat);
  r = read_as(std::string("\xFF\xFF\xFE" "created by x"), "lh.white", FileFormat::FreeSurfer);
  CHECK(r.status == Status::ParseError);
}

TEST_CASE("io formats: single-precision formats refuse coordinates beyond float range") {
  Mesh m = float_mesh(1);
  m.positions[4] = 1e300;
  TempDir dir;
  for (const char* name : {"m.stl", "m.gii"}) {
    const ricci::WriteResult w = ricci::write_mesh((dir / name).string(), m);
    CHECK(w.status == Status::InvalidArgument);
    CHECK(w.message.find("vertex 1") != std::string::npos);
    CHECK(!std::filesystem::exists(dir / name));
  }
}

TEST_CASE("io formats: curv overlays round trip, and errors are named") {
  const std::vector<double> values = {0.5, -1.25, 3.0, 0.0, 1e-3f, 7};
  const std::string bytes = ricci::serialize_overlay(values, OverlayFormat::FreeSurferCurv, "u", 8);
  ricci::OverlayReadResult r = ricci::read_overlay_from_memory(bytes, "lh.u");
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.format == OverlayFormat::FreeSurferCurv);
  REQUIRE(r.arrays.size() == 1);
  CHECK(r.arrays[0] == values);
  CHECK(r.num_faces == 8);
  r = ricci::read_overlay_from_memory(bytes.substr(0, bytes.size() - 2), "lh.u");
  CHECK(r.status == Status::ParseError);
  CHECK(r.arrays.empty());
  std::string nan = bytes;
  nan[15] = '\x7f';
  nan[16] = '\xc0';
  r = ricci::read_overlay_from_memory(nan, "lh.u");
  CHECK(r.status == Status::NonFiniteCoordinate);
  CHECK(ricci::serialize_overlay(std::vector<double>{NAN}, OverlayFormat::FreeSurferCurv, "u", 0).empty());
  CHECK(ricci::read_overlay_from_memory("hello", "x.txt").status == Status::UnknownFormat);
}

TEST_CASE("io formats: nibabel reads ricci's FreeSurfer files and ricci reads nibabel's") {
  const std::string python = ricci_test::nibabel_python();
  if (python.empty()) {
    MESSAGE("python3 nibabel not installed: skipped");
    return;
  }
  TempDir dir;
  const Mesh m = float_mesh(6);
  REQUIRE(ricci::write_mesh((dir / "lh.white").string(), m, freesurfer_options()).status == Status::Ok);
  const std::vector<double> values = {0.5, -1.25, 3.0, 0.0, 2.5, 7};
  ricci_test::write_bytes(dir / "lh.u", ricci::serialize_overlay(values, OverlayFormat::FreeSurferCurv, "u", 8));
  std::string expected_xyz, expected_faces;
  for (const double x : m.positions) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g,", x);  // exact
    expected_xyz += buf;
  }
  for (const Index f : m.faces) expected_faces += std::to_string(f) + ",";
  const std::string script = R"(
import sys, numpy as np, nibabel.freesurfer as fs
d = sys.argv[1]
xyz, faces = fs.read_geometry(d + '/lh.white')
want_xyz = np.array([float(x) for x in sys.argv[2].split(',') if x]).reshape(-1, 3)
want_faces = np.array([int(x) for x in sys.argv[3].split(',') if x]).reshape(-1, 3)
assert np.array_equal(xyz, want_xyz), 'coordinates differ'
assert (faces == want_faces).all(), 'faces differ'
u = fs.read_morph_data(d + '/lh.u')
assert np.array_equal(u, np.array([0.5, -1.25, 3.0, 0.0, 2.5, 7], dtype=np.float32)), 'curv differs'
# nibabel writes; ricci reads (checked on the C++ side)
fs.write_geometry(d + '/rh.pial', want_xyz.astype(np.float32) * 2, want_faces.astype(np.int32), create_stamp='created by nibabel')
fs.write_morph_data(d + '/rh.curv', np.arange(6, dtype=np.float32) / 4)
)";
  ricci_test::write_bytes(dir / "check.py", script);
  const ricci_test::CommandResult py =
      ricci_test::run_program(python, {(dir / "check.py").string(), dir.path().string(), expected_xyz, expected_faces});
  REQUIRE_MESSAGE(py.exit_code == 0, py.err);
  const ReadResult pial = ricci::read_mesh((dir / "rh.pial").string());
  REQUIRE_MESSAGE(pial.status == Status::Ok, pial.message);
  CHECK(pial.format == FileFormat::FreeSurfer);
  CHECK(pial.mesh.faces == m.faces);
  for (std::size_t i = 0; i < m.positions.size(); ++i)
    CHECK(pial.mesh.positions[i] == static_cast<double>(static_cast<float>(m.positions[i]) * 2.0f));
  const ricci::OverlayReadResult curv = ricci::read_overlay((dir / "rh.curv").string());
  REQUIRE_MESSAGE(curv.status == Status::Ok, curv.message);
  CHECK(curv.arrays.at(0) == std::vector<double>{0, 0.25, 0.5, 0.75, 1.0, 1.25});
}
