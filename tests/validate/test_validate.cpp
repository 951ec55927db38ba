// validate_mesh() and diagnose(): each check in its documented order, each repair, the index
// maps back to the input, and diagnose() on soups that are not surfaces.
#include <doctest/doctest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;

namespace {

Mesh tetrahedron() {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.faces = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};  // outward
  return m;
}

// A triangulated Möbius strip: n quads around a circle with a half twist at the seam.
Mesh moebius(int n) {
  Mesh m;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n, t = a / 2;
    for (int s : {-1, 1}) {
      const double w = 0.3 * s;
      m.positions.insert(m.positions.end(), {(1 + w * std::cos(t)) * std::cos(a), (1 + w * std::cos(t)) * std::sin(a),
                                             w * std::sin(t)});
    }
  }
  for (int i = 0; i < n; ++i) {
    const Index t0 = 2 * i, b0 = 2 * i + 1;
    Index t1 = 2 * ((i + 1) % n), b1 = 2 * ((i + 1) % n) + 1;
    if (i == n - 1) std::swap(t1, b1);  // the half twist
    m.faces.insert(m.faces.end(), {t0, b0, b1, t0, b1, t1});
  }
  return m;
}

bool has_repair(const ValidateResult& r, RepairKind k, std::int64_t count) {
  for (const auto& rep : r.repairs)
    if (rep.kind == k) return rep.count == count;
  return false;
}

}  // namespace

TEST_CASE("validate: a clean mesh passes unchanged") {
  const Mesh m = ricci_shapes::icosphere(1);
  const auto r = validate_mesh(m);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.repairs.empty());
  CHECK(r.mesh.faces == m.faces);
  CHECK(r.mesh.positions == m.positions);
  CHECK(r.topology.euler_characteristic() == 2);
  CHECK(ricci_test::check_topology(r.topology, r.mesh.faces) == "");
}

TEST_CASE("validate: every check has its own status and names the element") {
  SUBCASE("no faces") {
    Mesh m;
    m.positions = {0, 0, 0};
    CHECK(validate_mesh(m).status == Status::NoFaces);
  }
  SUBCASE("index out of range") {
    Mesh m = tetrahedron();
    m.faces[7] = 9;
    const auto r = validate_mesh(m);
    CHECK(r.status == Status::IndexOutOfRange);
    CHECK(r.element_index == 2);
  }
  SUBCASE("non-finite coordinate of a used vertex") {
    Mesh m = tetrahedron();
    m.positions[7] = std::numeric_limits<double>::quiet_NaN();
    const auto r = validate_mesh(m);
    CHECK(r.status == Status::NonFiniteCoordinate);
    CHECK(r.element == Element::Vertex);
    CHECK(r.element_index == 2);
  }
  SUBCASE("face repeating a vertex") {
    Mesh m = tetrahedron();
    m.faces[5] = m.faces[4];
    const auto r = validate_mesh(m);
    CHECK(r.status == Status::DegenerateFace);
    CHECK(r.element_index == 1);
  }
  SUBCASE("zero-area face") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 2, 0, 0};
    m.faces = {0, 1, 2};
    const auto r = validate_mesh(m);
    CHECK(r.status == Status::DegenerateFace);
    CHECK(r.message.find("zero area") != std::string::npos);
  }
  SUBCASE("duplicate face") {
    Mesh m = tetrahedron();
    m.faces.insert(m.faces.end(), {2, 1, 0});
    const auto r = validate_mesh(m);
    CHECK(r.status == Status::DuplicateFace);
    CHECK(r.element_index == 4);
  }
  SUBCASE("non-manifold edge") {
    Mesh m = tetrahedron();
    m.positions.insert(m.positions.end(), {1, 1, 1});
    m.faces.insert(m.faces.end(), {0, 1, 4});
    CHECK(validate_mesh(m).status == Status::NonManifoldEdge);
  }
  SUBCASE("non-orientable") {
    CHECK(validate_mesh(moebius(8)).status == Status::NonOrientable);
  }
  SUBCASE("pinched vertex, reported in input numbering") {
    Mesh m = tetrahedron();
    m.positions.insert(m.positions.end(), {7, 7, 7});  // unused vertex 4 shifts nothing before it
    for (double x : {-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0}) m.positions.push_back(x);
    // Second tetrahedron on vertices 0, 5, 6, 7 (mirror image), sharing only vertex 0.
    m.faces.insert(m.faces.end(), {0, 5, 6, 0, 7, 5, 5, 7, 6, 0, 6, 7});
    const auto r = validate_mesh(m);
    CHECK(r.status == Status::NonManifoldVertex);
    CHECK(r.element_index == 0);
  }
  SUBCASE("several components") {
    Mesh m = tetrahedron();
    const Mesh t = tetrahedron();
    for (double x : t.positions) m.positions.push_back(x + 5);
    for (Index v : t.faces) m.faces.push_back(v + 4);
    CHECK(validate_mesh(m).status == Status::MultipleComponents);
  }
}

TEST_CASE("validate: the largest component is kept on request, with maps to the input") {
  Mesh m = tetrahedron();                       // 4 faces
  const Mesh big = ricci_shapes::icosphere(1);  // 80 faces
  const Index offset = m.num_vertices();
  m.positions.insert(m.positions.end(), big.positions.begin(), big.positions.end());
  for (Index v : big.faces) m.faces.push_back(v + offset);
  ValidateOptions o;
  o.keep_largest_component = true;
  const auto r = validate_mesh(m, o);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.mesh.num_faces() == big.num_faces());
  CHECK(r.mesh.num_vertices() == big.num_vertices());
  CHECK(has_repair(r, RepairKind::ComponentsDropped, 1));
  for (Index f = 0; f < r.mesh.num_faces(); ++f) {
    const Index g = r.face_to_input[f];
    for (Index k = 0; k < 3; ++k) CHECK(r.vertex_to_input[r.mesh.faces[3 * f + k]] == m.faces[3 * g + k]);
  }
}

TEST_CASE("validate: inconsistent orientation is repaired outward, or refused on request") {
  using namespace ricci_shapes;
  ricci_test::for_each_seed(1, 6, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    Mesh m = icosphere(2);
    // Flip a random majority of the faces: the outward choice must still win on a closed surface.
    Index flipped = 0;
    for (Index f = 0; f < m.num_faces(); ++f) {
      if (uniform_index(rng, 10) < 7) {
        std::swap(m.faces[3 * f + 1], m.faces[3 * f + 2]);
        ++flipped;
      }
    }
    const auto r = validate_mesh(m);
    REQUIRE(r.status == Status::Ok);
    CHECK(has_repair(r, RepairKind::FacesFlipped, flipped));
    CHECK(signed_volume(r.mesh) > 0);
    CHECK(ricci_test::check_topology(r.topology, r.mesh.faces) == "");
    ValidateOptions strict;
    strict.repair_orientation = false;
    CHECK(validate_mesh(m, strict).status == Status::InconsistentOrientation);
  });
  // An open surface: the majority orientation is kept, and texture corners follow their faces.
  Mesh d = disk(5);
  d.texcoords = {0, 0, 1, 0, 0, 1};
  for (Index c = 0; c < 3 * d.num_faces(); ++c) d.corner_texcoords.push_back(c % 3);
  std::swap(d.faces[1], d.faces[2]);
  std::swap(d.corner_texcoords[1], d.corner_texcoords[2]);
  const auto r = validate_mesh(d);
  REQUIRE(r.status == Status::Ok);
  CHECK(has_repair(r, RepairKind::FacesFlipped, 1));
  CHECK(r.mesh.faces == disk(5).faces);
  for (Index c = 0; c < 3 * d.num_faces(); ++c) CHECK(r.mesh.corner_texcoords[c] == c % 3);
}

TEST_CASE("validate: a consistently inward surface keeps its orientation") {
  Mesh m = ricci_shapes::icosphere(1);
  for (Index f = 0; f < m.num_faces(); ++f) std::swap(m.faces[3 * f + 1], m.faces[3 * f + 2]);
  const auto r = validate_mesh(m);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.repairs.empty());
  CHECK(r.mesh.faces == m.faces);
}

TEST_CASE("validate: unused vertices are dropped and reported") {
  Mesh m = tetrahedron();
  m.positions.insert(m.positions.begin(), {9, 9, 9});  // new vertex 0, used by nothing
  for (Index& v : m.faces) ++v;
  m.positions.insert(m.positions.end(), {8, 8, 8});
  const auto r = validate_mesh(m);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.mesh.num_vertices() == 4);
  CHECK(has_repair(r, RepairKind::UnreferencedVerticesDropped, 2));
  CHECK(r.vertex_to_input == std::vector<Index>{1, 2, 3, 4});
  CHECK(r.mesh.faces == tetrahedron().faces);
}

TEST_CASE("validate: options are checked") {
  ValidateOptions o;
  o.degenerate_tolerance = -1;
  std::string why;
  CHECK_FALSE(o.is_valid(&why));
  CHECK(!why.empty());
  CHECK(validate_mesh(tetrahedron(), o).status == Status::InvalidArgument);
}

TEST_CASE("diagnose: counts on soups that are not surfaces") {
  SUBCASE("bow tie") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0};
    m.faces = {0, 1, 2, 0, 3, 4};
    const auto d = diagnose(m);
    CHECK(d.non_manifold_vertices == 1);
    CHECK(d.non_manifold_edges == 0);
    CHECK_FALSE(d.manifold);
    CHECK(d.components == 1);
    CHECK(d.boundary_loops == 1);  // the boundary graph is connected through the pinched vertex
    CHECK(d.euler_characteristic == 5 - 6 + 2);
  }
  SUBCASE("Möbius strip") {
    const auto d = diagnose(moebius(8));
    CHECK_FALSE(d.orientable);
    CHECK(d.boundary_loops == 1);
    CHECK(d.euler_characteristic == 0);
    CHECK(d.manifold);
  }
  SUBCASE("flipped faces, duplicates, out of range, repeated vertices, zero area, unused vertices") {
    Mesh m = tetrahedron();
    std::swap(m.faces[1], m.faces[2]);                        // 3 inconsistent edges
    m.positions.insert(m.positions.end(), {5, 5, 5, 6, 6, 6, 7, 7, 7, 50, 50, 50});
    m.faces.insert(m.faces.end(), {4, 5, 6, 4, 6, 5, 0, 0, 1, 0, 1, 99});  // zero area twice, repeated, out of range
    const auto d = diagnose(m);
    CHECK(d.vertices_listed == 8);
    CHECK(d.vertices_referenced == 7);
    CHECK(d.inconsistent_edges == 3);
    CHECK(d.duplicate_faces == 1);
    CHECK(d.zero_area_faces == 2);
    CHECK(d.repeated_vertex_faces == 1);
    CHECK(d.out_of_range_faces == 1);
    CHECK(d.orientable);
    CHECK(d.components == 2);
  }
  SUBCASE("angles of a right isosceles triangle") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    m.faces = {0, 1, 2};
    const auto d = diagnose(m);
    CHECK(d.min_corner_angle == doctest::Approx(M_PI / 4));
    CHECK(d.max_corner_angle == doctest::Approx(M_PI / 2));
    CHECK(d.obtuse_face_fraction == 0);
  }
}

TEST_CASE("validate: diagnose agrees with the topology on valid surfaces") {
  using namespace ricci_shapes;
  for (const Mesh& m : {icosphere(2), torus(10, 6, 2, 0.5), pretzel(2, 2), annulus(3, 20)}) {
    const auto d = diagnose(m);
    const auto r = validate_mesh(m);
    REQUIRE(r.status == Status::Ok);
    CHECK(d.manifold);
    CHECK(d.orientable);
    CHECK(d.edges == r.topology.num_edges);
    CHECK(d.euler_characteristic == r.topology.euler_characteristic());
    CHECK(d.boundary_loops == r.topology.num_boundary_loops());
    CHECK(d.genus == r.topology.genus());
    CHECK(d.inconsistent_edges == 0);
  }
}

TEST_CASE("validate: errors in triangulated polygons name the polygon of the file") {
  // Quad 1 (vertices 2 3 6 5, 1-based) has three collinear corners: its first fan triangle is degenerate.
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 3 0 0\n"
      "f 1 2 5 4\nf 2 3 6 5\n";
  ReadResult read = read_mesh_from_memory(obj, "quads.obj");
  REQUIRE(read.status == Status::Ok);
  CHECK(read.triangle_polygon == std::vector<Index>{0, 0, 1, 1});
  const LoadResult r = validate_read(std::move(read), "quads.obj");
  CHECK(r.status == Status::DegenerateFace);
  CHECK(r.element == Element::Face);
  CHECK(r.element_index == 1);
  CHECK(r.message.find("quads.obj") == 0);
  CHECK(r.message.find("polygon 1") != std::string::npos);
  CHECK(r.repairs.size() == 1);
  // Files of triangles only need no map.
  CHECK(read_mesh_from_memory("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").triangle_polygon.empty());
}

TEST_CASE("validate: of several zero-area faces the first is named, on 1 and 2 threads") {
  Mesh m = ricci_shapes::disk(40);
  const Index nf = m.num_faces();
  REQUIRE(nf > 1000);
  // Two interior vertices, one in the first faces and one in the last, each moved onto a
  // neighbour: every face on both becomes of zero area.
  auto collapse = [&](Index f) {
    const Index v = m.faces[3 * f], w = m.faces[3 * f + 1];
    for (int d = 0; d < 3; ++d) m.positions[3 * v + d] = m.positions[3 * w + d];
  };
  collapse(nf - 5);
  collapse(5);
  Index expected = kInvalid;
  for (Index f = 0; f < nf && expected == kInvalid; ++f) {
    const double* p = &m.positions[3 * m.faces[3 * f]];
    const double* q = &m.positions[3 * m.faces[3 * f + 1]];
    const double* r = &m.positions[3 * m.faces[3 * f + 2]];
    const double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, v[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
    const double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    if (c[0] == 0 && c[1] == 0 && c[2] == 0) expected = f;
  }
  REQUIRE(expected != kInvalid);
  CHECK(expected <= 5);
  const int saved = omp_get_max_threads();
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    const ValidateResult r = validate_mesh(m);
    CHECK(r.status == Status::DegenerateFace);
    CHECK(r.element == Element::Face);
    CHECK(r.element_index == expected);
  }
  omp_set_num_threads(saved);
}

// validate_mesh() hands on the edge table it built for its checks to the topology where no face
// was flipped, and the table's per-vertex work runs in parallel: the topology must still be
// build_topology() of the validated faces, field by field, and the same on 1 and 2 threads, on
// meshes with vertices of valence above 32 (the table's std::sort branch), dropped vertices (the
// renumbering) and flipped faces (the path that builds the table again).
TEST_CASE("validate: the topology it returns is build_topology() of its faces, on 1 and 2 threads") {
  using namespace ricci_shapes;
  std::vector<std::pair<std::string, Mesh>> meshes;
  meshes.emplace_back("torus", torus(48, 24, 2.0, 0.7));
  meshes.emplace_back("pretzel", pretzel(3, 6));
  meshes.emplace_back("annulus", annulus(6, 40));
  {
    // A cone of valence 70 at vertex 0 (its corners take the sorted branch), closed by a fan at
    // vertex 1 on the other side: a sphere with two high-valence poles.
    Mesh m;
    const int n = 70;
    m.positions = {0, 0, 1, 0, 0, -1};
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      m.positions.insert(m.positions.end(), {std::cos(a), std::sin(a), 0});
    }
    for (int i = 0; i < n; ++i) {
      const Index p = 2 + i, q = 2 + (i + 1) % n;
      m.faces.insert(m.faces.end(), {0, p, q, 1, q, p});
    }
    meshes.emplace_back("two poles", m);
  }
  std::mt19937_64 rng(7);
  {
    // Unreferenced vertices in between: validation drops them and renumbers the rest in order.
    Mesh m = permute_vertices(torus(30, 14, 2.0, 0.7), rng);
    Mesh spaced;
    for (Index v = 0; v < m.num_vertices(); ++v) {
      spaced.positions.insert(spaced.positions.end(), {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]});
      if (v % 5 == 0) spaced.positions.insert(spaced.positions.end(), {9.0, 9.0, 9.0 + v});
    }
    for (Index i : m.faces) spaced.faces.push_back(i + (i + 4) / 5);
    meshes.emplace_back("dropped vertices", spaced);
  }
  {
    // Faces flipped at random: validation orients them again (the table is built anew).
    Mesh m = permute_faces(pretzel(2, 6), rng);
    for (Index f = 0; f < m.num_faces(); ++f)
      if (rng() % 4 == 0) std::swap(m.faces[3 * f + 1], m.faces[3 * f + 2]);
    meshes.emplace_back("flipped faces", m);
  }
  const int saved = omp_get_max_threads();
  for (const auto& [name, mesh] : meshes) {
    INFO(name);
    std::vector<ValidateResult> results;
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      results.push_back(validate_mesh(mesh));
      const ValidateResult& r = results.back();
      REQUIRE(r.status == Status::Ok);
      const TopologyResult b = build_topology(r.mesh.faces, r.mesh.num_vertices());
      REQUIRE(b.status == Status::Ok);
      CHECK(ricci_test::same_topology(r.topology, b.topology));
      CHECK(ricci_test::check_topology(r.topology, r.mesh.faces) == "");
    }
    CHECK(ricci_test::same_topology(results[0].topology, results[1].topology));
    CHECK(results[0].mesh.faces == results[1].mesh.faces);
  }
  omp_set_num_threads(saved);
  CHECK(meshes[4].second.num_vertices() > validate_mesh(meshes[4].second).mesh.num_vertices());
  bool flipped = false;
  for (const Repair& rep : validate_mesh(meshes[5].second).repairs) flipped |= rep.kind == RepairKind::FacesFlipped;
  CHECK(flipped);
}
