// fixtures/: the generator reproduces the committed files, the loader reports the numbers of
// fixtures/README.md, and every malformed file in fixtures/bad/ gives its documented status.
// The random transforms of tools/shapes.h keep the topology of every fixture, and the generators
// themselves give outward, consistently oriented, well-shaped meshes.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;
namespace fs = std::filesystem;

namespace {

// Rows of a Markdown table whose first cell is a `file` name: name → the remaining cells.
std::map<std::string, std::vector<std::string>> markdown_table(const fs::path& path) {
  std::map<std::string, std::vector<std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("| `", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    std::string cell;
    while (std::getline(ss, cell, '|')) {
      const auto b = cell.find_first_not_of(' '), e = cell.find_last_not_of(' ');
      cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    const std::string name = cells[0].substr(1, cells[0].size() - 2);
    cells.erase(cells.begin());
    rows[name] = cells;
  }
  return rows;
}

}  // namespace

TEST_CASE("fixtures: the generator reproduces the committed files byte for byte") {
  ricci_test::TempDir tmp;
  const auto r = ricci_test::run_program(RICCI_MAKE_FIXTURES_PATH, {tmp.path().string()});
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  const auto made = ricci_test::mesh_files(tmp.path());
  CHECK(made.size() == 9);
  CHECK(ricci_test::mesh_files(ricci_test::fixtures_dir()).size() == made.size());  // none stale
  for (const auto& file : made) {
    INFO(file.filename().string());
    CHECK(ricci_test::read_bytes(file) == ricci_test::read_bytes(ricci_test::fixtures_dir() / file.filename()));
  }
}

TEST_CASE("fixtures: the README table matches the loader") {
  const auto table = markdown_table(ricci_test::fixtures_dir() / "README.md");
  int checked = 0;
  for (const auto& [name, cells] : table) {
    REQUIRE(cells.size() == 7);
    INFO(name);
    const LoadResult r = load_mesh((ricci_test::fixtures_dir() / name).string());
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.repairs.empty());
    const Topology& t = r.validated.topology;
    CHECK(std::to_string(t.num_vertices) == cells[0]);
    CHECK(std::to_string(t.num_edges) == cells[1]);
    CHECK(std::to_string(t.num_faces) == cells[2]);
    CHECK(std::to_string(t.num_boundary_loops()) == cells[3]);
    CHECK(std::to_string(t.euler_characteristic()) == cells[4]);
    CHECK(std::to_string(t.genus()) == cells[5]);
    CHECK(std::to_string(t.num_components) == cells[6]);
    CHECK(t.euler_characteristic() == 2 - 2 * t.genus() - t.num_boundary_loops());
    CHECK(ricci_test::check_topology(t, r.validated.mesh.faces) == "");
    ++checked;
  }
  CHECK(checked == 9);
}

TEST_CASE("fixtures: every bad file gives its documented status") {
  const fs::path dir = ricci_test::fixtures_dir() / "bad";
  const auto table = markdown_table(dir / "README.md");
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().filename() != "README.md";
  CHECK(files == table.size());  // every file is documented
  for (const auto& [name, cells] : table) {
    INFO(name);
    REQUIRE(fs::exists(dir / name));
    const LoadResult r = load_mesh((dir / name).string());
    CHECK(status_name(r.status) == cells[0]);
    if (r.status != Status::Ok) CHECK(r.message.find(name) != std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------------
// Random transforms.

namespace {

using Transform = std::function<Mesh(const Mesh&, std::mt19937_64&)>;

// Every transform alone, then compositions (applied left to right).
std::vector<std::pair<std::string, Transform>> transforms() {
  using namespace ricci_shapes;
  std::vector<std::pair<std::string, Transform>> t = {
      {"permute_vertices", [](const Mesh& m, std::mt19937_64& rng) { return permute_vertices(m, rng); }},
      {"permute_faces", [](const Mesh& m, std::mt19937_64& rng) { return permute_faces(m, rng); }},
      {"rotate_face_corners", [](const Mesh& m, std::mt19937_64& rng) { return rotate_face_corners(m, rng); }},
      {"subdivide_midpoint", [](const Mesh& m, std::mt19937_64& rng) { return subdivide_midpoint(m, rng); }},
      {"split_random_faces", [](const Mesh& m, std::mt19937_64& rng) { return split_random_faces(m, rng, 0.3); }},
      {"flip_random_edges", [](const Mesh& m, std::mt19937_64& rng) { return flip_random_edges(m, rng, 0.3); }},
  };
  auto chain = [t](std::vector<std::size_t> steps) -> Transform {
    return [t, steps](const Mesh& m, std::mt19937_64& rng) {
      Mesh out = m;
      for (const std::size_t s : steps) out = t[s].second(out, rng);
      return out;
    };
  };
  t.push_back({"split, flip, split, flip", chain({4, 5, 4, 5})});
  t.push_back({"flip, permute_vertices, rotate, permute_faces", chain({5, 0, 2, 1})});
  t.push_back({"subdivide, flip, split, permute_vertices", chain({3, 5, 4, 0})});
  return t;
}

struct Counts {
  std::int64_t V, E, F, b, chi, genus, components;
};
Counts counts(const Topology& t) {
  return {t.num_vertices, t.num_edges, t.num_faces, t.num_boundary_loops(), t.euler_characteristic(),
          t.genus(), t.num_components};
}

// The faces as position triples, each rotated to start at its smallest corner, sorted: equal for
// two meshes that differ only by vertex numbering, face order and corner rotation.
std::vector<std::array<double, 9>> geometric_faces(const Mesh& m) {
  std::vector<std::array<double, 9>> out;
  for (Index f = 0; f < m.num_faces(); ++f) {
    std::array<std::array<double, 3>, 3> p;
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) p[k][d] = m.positions[3 * m.faces[3 * f + k] + d];
    const int first = static_cast<int>(std::min_element(p.begin(), p.end()) - p.begin());
    std::array<double, 9> key;
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) key[3 * k + d] = p[(first + k) % 3][d];
    out.push_back(key);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::pair<std::string, Mesh>> loaded_fixtures() {
  std::vector<std::pair<std::string, Mesh>> out;
  ricci_test::for_each_fixture([&](const ricci_test::fs::path& path) {
    const LoadResult r = load_mesh(path.string());
    if (r.status == Status::Ok) out.emplace_back(path.filename().string(), r.validated.mesh);
  });
  return out;
}

}  // namespace

TEST_CASE("fixtures: random transforms and their compositions keep the topology of every fixture") {
  const auto fixtures = loaded_fixtures();
  REQUIRE(fixtures.size() == 9);
  const auto list = transforms();
  for (const auto& [name, mesh] : fixtures) {
    INFO(name);
    const ValidateResult base = validate_mesh(mesh);
    REQUIRE(base.status == Status::Ok);
    const Counts want = counts(base.topology);
    for (const auto& [tname, transform] : list) {
      INFO(tname);
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        CAPTURE(seed);
        std::mt19937_64 rng(seed);
        const Mesh m = transform(mesh, rng);
        const ValidateResult r = validate_mesh(m);
        REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
        CHECK(r.repairs.empty());  // nothing flipped, dropped or merged
        CHECK(r.mesh.faces == m.faces);
        const Counts got = counts(r.topology);
        CHECK(got.chi == want.chi);
        CHECK(got.b == want.b);
        CHECK(got.genus == want.genus);
        CHECK(got.components == 1);
        CHECK(ricci_test::check_topology(r.topology, r.mesh.faces) == "");
      }
    }
  }
}

TEST_CASE("shapes: permutations and corner rotations change only the numbering") {
  using namespace ricci_shapes;
  for (const Mesh& mesh : {torus(12, 6, 1.0, 0.4), disk(4), pretzel(2, 2)}) {
    const auto want = geometric_faces(mesh);
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      std::mt19937_64 rng(seed);
      const Mesh a = permute_vertices(mesh, rng), b = permute_faces(mesh, rng), c = rotate_face_corners(mesh, rng);
      CHECK(a.faces != mesh.faces);
      CHECK(b.faces != mesh.faces);
      CHECK(c.faces != mesh.faces);
      CHECK(geometric_faces(a) == want);
      CHECK(geometric_faces(b) == want);
      CHECK(geometric_faces(c) == want);
      CHECK(b.positions == mesh.positions);
      CHECK(c.positions == mesh.positions);
    });
  }
}

TEST_CASE("shapes: refinements and flips give the expected counts") {
  using namespace ricci_shapes;
  const Mesh mesh = icosphere(2);  // V 162, E 480, F 320
  std::mt19937_64 rng(7);
  const Mesh sub = subdivide_midpoint(mesh);
  CHECK(sub.num_vertices() == 162 + 480);
  CHECK(sub.num_faces() == 4 * 320);
  const Mesh split = split_random_faces(mesh, rng, 0.5);
  CHECK(split.num_faces() - mesh.num_faces() == 2 * (split.num_vertices() - mesh.num_vertices()));
  CHECK(split.num_vertices() > mesh.num_vertices());
  CHECK(split_random_faces(mesh, rng, 0.0).faces == mesh.faces);
  const Mesh flipped = flip_random_edges(mesh, rng, 0.5);
  CHECK(flipped.num_faces() == mesh.num_faces());
  CHECK(flipped.positions == mesh.positions);
  CHECK(flipped.faces != mesh.faces);
  CHECK(flip_random_edges(mesh, rng, 0.0).faces == mesh.faces);
  // Flips never fold the surface: no face of the sphere turns inward (a flip may create a face
  // whose plane passes through the centre, when its vertices lie on a great circle).
  for (Index f = 0; f < flipped.num_faces(); ++f) {
    const double* p[3];
    for (int k = 0; k < 3; ++k) p[k] = &flipped.positions[3 * flipped.faces[3 * f + k]];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    CHECK(n[0] * p[0][0] + n[1] * p[0][1] + n[2] * p[0][2] > -1e-12);
  }
  // The same seed gives the same mesh.
  std::mt19937_64 r1(42), r2(42);
  CHECK(flip_random_edges(split_random_faces(mesh, r1), r1).faces ==
        flip_random_edges(split_random_faces(mesh, r2), r2).faces);
}

// ---------------------------------------------------------------------------------------------
// The generators.

namespace {

struct Shape {
  std::string name;
  Mesh mesh;
  std::int64_t chi, b, genus;
  double min_angle;  // degrees
};

std::vector<Shape> shapes() {
  using namespace ricci_shapes;
  std::vector<Shape> out;
  for (int s = 0; s <= 3; ++s) out.push_back({"icosphere(" + std::to_string(s) + ")", icosphere(s), 2, 0, 0, 50});
  out.push_back({"torus(32,16)", torus(32, 16, 1.0, 0.4), 0, 0, 1, 25});
  out.push_back({"torus(5,3)", torus(5, 3, 2.0, 0.5), 0, 0, 1, 10});
  for (int g = 1; g <= 4; ++g)
    for (int c = 2; c <= 4; ++c)
      out.push_back({"pretzel(" + std::to_string(g) + "," + std::to_string(c) + ")", pretzel(g, c), 2 - 2 * g, 0, g, 20});
  for (int r = 1; r <= 12; r += 5) out.push_back({"disk(" + std::to_string(r) + ")", disk(r), 1, 1, 0, 25});
  out.push_back({"annulus(8,48)", annulus(8, 48), 0, 2, 0, 20});
  out.push_back({"annulus(1,3)", annulus(1, 3), 0, 2, 0, 10});
  out.push_back({"sphere-3holes", remove_vertex_stars(icosphere(3), {0, 5, 9}), -1, 3, 0, 50});
  for (const auto& [c, r] : {std::pair{2, 2}, std::pair{3, 2}})
    out.push_back({"pretzel_grid(" + std::to_string(c) + "," + std::to_string(r) + ")", pretzel_grid(c, r, 3),
                   2 - 2 * c * r, 0, c * r, 20});
  out.push_back({"genus2-2holes", remove_vertex_stars(pretzel(2, 4), {0, 400}), -4, 2, 2, 20});
  return out;
}

// Smallest cosine between the normals of two neighbouring faces (1 for a flat mesh).
double min_neighbour_normal_cosine(const Mesh& m, const Topology& t) {
  auto normal = [&](Index f) {
    std::array<double, 3> p[3];
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) p[k][d] = m.positions[3 * m.faces[3 * f + k] + d];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    std::array<double, 3> n = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                               e1[0] * e2[1] - e1[1] * e2[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (double& x : n) x /= len;
    return n;
  };
  double worst = 1;
  for (Index c = 0; c < t.num_corners(); ++c) {
    if (t.opposite[c] == kInvalid) continue;
    const auto a = normal(c / 3), b = normal(t.opposite[c] / 3);
    worst = std::min(worst, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
  }
  return worst;
}

// Twice the signed area of a boundary loop projected on the xy plane.
double loop_area_xy(const Mesh& m, const Topology& t, Index loop) {
  double sum = 0;
  const Index b = t.boundary_offsets[loop], e = t.boundary_offsets[loop + 1];
  for (Index i = b; i < e; ++i) {
    const Index v = t.boundary_vertices[i], w = t.boundary_vertices[i + 1 < e ? i + 1 : b];
    sum += m.positions[3 * v] * m.positions[3 * w + 1] - m.positions[3 * w] * m.positions[3 * v + 1];
  }
  return sum;
}

}  // namespace

TEST_CASE("shapes: generators give valid meshes of the documented topology") {
  for (const Shape& s : shapes()) {
    INFO(s.name);
    const ValidateResult r = validate_mesh(s.mesh);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.repairs.empty());  // consistently oriented, no unused vertex
    CHECK(r.mesh.faces == s.mesh.faces);
    CHECK(r.topology.euler_characteristic() == s.chi);
    CHECK(r.topology.num_boundary_loops() == s.b);
    CHECK(r.topology.genus() == s.genus);
    CHECK(r.topology.num_components == 1);
    CHECK(ricci_test::check_topology(r.topology, r.mesh.faces) == "");
  }
  using namespace ricci_shapes;
  CHECK(icosphere(3).num_vertices() == 642);
  CHECK(icosphere(3).num_faces() == 1280);
  CHECK(torus(7, 5, 1, 0.3).num_vertices() == 35);
  CHECK(torus(7, 5, 1, 0.3).num_faces() == 70);
  CHECK(disk(5).num_vertices() == 3 * 5 * 6 + 1);
  CHECK(disk(5).num_faces() == 6 * 25);
  CHECK(annulus(3, 10).num_vertices() == 40);
  CHECK(annulus(3, 10).num_faces() == 60);
  // A row of holes is the grid with one row, to the bit.
  CHECK(pretzel_grid(3, 1, 3).positions == pretzel(3, 3).positions);
  CHECK(pretzel_grid(3, 1, 3).faces == pretzel(3, 3).faces);
}

TEST_CASE("shapes: closed surfaces face outward, open ones face up, and none folds over") {
  for (const Shape& s : shapes()) {
    INFO(s.name);
    const ValidateResult r = validate_mesh(s.mesh);
    REQUIRE(r.status == Status::Ok);
    if (s.b == 0) CHECK(ricci_shapes::signed_volume(s.mesh) > 0);
    // No triangle is flipped against its neighbours (smoothing and lifting keep the surface
    // free of folds): neighbouring normals differ by less than 90 degrees (except on the
    // deliberately coarse shapes, whose cross-sections are triangles).
    if (s.min_angle >= 20) CHECK(min_neighbour_normal_cosine(s.mesh, r.topology) > 0);
  }
  // Disk and annulus: normals up, so the outer loop runs counter-clockwise seen from above and
  // the annulus's inner loop clockwise.
  for (const Mesh& m : {ricci_shapes::disk(6), ricci_shapes::annulus(4, 24)}) {
    const ValidateResult r = validate_mesh(m);
    REQUIRE(r.status == Status::Ok);
    double up = 0;
    for (Index f = 0; f < m.num_faces(); ++f) {
      const double* p[3];
      for (int k = 0; k < 3; ++k) p[k] = &m.positions[3 * m.faces[3 * f + k]];
      up += (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
      CHECK((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]) > 0);
    }
    CHECK(up > 0);
    std::vector<double> areas;
    for (Index l = 0; l < r.topology.num_boundary_loops(); ++l) areas.push_back(loop_area_xy(m, r.topology, l));
    std::sort(areas.begin(), areas.end());
    CHECK(areas.back() > 0);
    if (areas.size() == 2) CHECK(areas.front() < 0);
  }
}

TEST_CASE("shapes: triangle quality") {
  for (const Shape& s : shapes()) {
    INFO(s.name);
    CHECK(ricci_shapes::min_angle_degrees(s.mesh) > s.min_angle);
  }
  for (const auto& [name, mesh] : loaded_fixtures()) {
    INFO(name);
    CHECK(ricci_shapes::min_angle_degrees(mesh) > 20);
  }
}

TEST_CASE("shapes: generators are deterministic and pretzels are centred and scaled") {
  using namespace ricci_shapes;
  CHECK(pretzel(2, 3).positions == pretzel(2, 3).positions);
  CHECK(torus(9, 5, 1.0, 0.3).positions == torus(9, 5, 1.0, 0.3).positions);
  const Mesh p = pretzel(3, 3);
  double lo = 0, hi = 0;
  for (Index v = 0; v < p.num_vertices(); ++v) {
    lo = std::min(lo, p.positions[3 * v]);
    hi = std::max(hi, p.positions[3 * v]);
  }
  CHECK(lo == doctest::Approx(-1.0));
  CHECK(hi == doctest::Approx(1.0));
  // The torus lies on its surface of revolution: (sqrt(x² + y²) − R)² + z² = r².
  const Mesh t = torus(24, 12, 2.0, 0.5);
  for (Index v = 0; v < t.num_vertices(); ++v) {
    const double x = t.positions[3 * v], y = t.positions[3 * v + 1], z = t.positions[3 * v + 2];
    const double rho = std::sqrt(x * x + y * y) - 2.0;
    CHECK(rho * rho + z * z == doctest::Approx(0.25).epsilon(1e-12));
  }
  const Mesh s = icosphere(2);
  for (Index v = 0; v < s.num_vertices(); ++v) {
    const double* q = &s.positions[3 * v];
    CHECK(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] == doctest::Approx(1.0).epsilon(1e-14));
  }
}

TEST_CASE("shapes: remove_vertex_stars cuts one hole per centre and refuses touching holes") {
  using namespace ricci_shapes;
  const Mesh sphere = icosphere(2);
  const Mesh holed = remove_vertex_stars(sphere, {0});
  CHECK(holed.num_vertices() == sphere.num_vertices() - 1);
  CHECK(holed.num_faces() == sphere.num_faces() - 5);  // icosahedron vertices have valence 5
  // A neighbour of a centre, two centres whose links share a vertex, a repeated centre, a centre
  // out of range, a centre on (or next to) the boundary.
  Index neighbour = sphere.faces[1], far_neighbour = kInvalid;
  for (Index f = 0; f < sphere.num_faces() && far_neighbour == kInvalid; ++f) {
    // A vertex at distance two from vertex 0: a vertex of a face touching a neighbour of 0 but
    // not 0 itself.
    bool has0 = false, has_n = false;
    for (int k = 0; k < 3; ++k) {
      has0 |= sphere.faces[3 * f + k] == 0;
      has_n |= sphere.faces[3 * f + k] == neighbour;
    }
    if (!has0 && has_n)
      for (int k = 0; k < 3; ++k) {
        const Index w = sphere.faces[3 * f + k];
        bool adjacent_to_0 = false;
        for (Index g = 0; g < sphere.num_faces(); ++g) {
          bool g0 = false, gw = false;
          for (int j = 0; j < 3; ++j) {
            g0 |= sphere.faces[3 * g + j] == 0;
            gw |= sphere.faces[3 * g + j] == w;
          }
          adjacent_to_0 |= g0 && gw;
        }
        if (!adjacent_to_0 && w != 0) far_neighbour = w;
      }
  }
  REQUIRE(far_neighbour != kInvalid);
  CHECK_THROWS_AS(remove_vertex_stars(sphere, {0, neighbour}), std::invalid_argument);
  CHECK_THROWS_AS(remove_vertex_stars(sphere, {0, far_neighbour}), std::invalid_argument);
  CHECK_THROWS_AS(remove_vertex_stars(sphere, {0, 0}), std::invalid_argument);
  CHECK_THROWS_AS(remove_vertex_stars(sphere, {sphere.num_vertices()}), std::invalid_argument);
  const Mesh d = disk(3);
  CHECK_THROWS_AS(remove_vertex_stars(d, {d.num_vertices() - 1}), std::invalid_argument);  // on the rim
  CHECK_THROWS_AS(remove_vertex_stars(d, {1 + 3 * 2 * 1}), std::invalid_argument);         // ring 2 touches it
  CHECK_NOTHROW(remove_vertex_stars(d, {0}));
}
