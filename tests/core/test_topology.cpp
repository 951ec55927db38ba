// build_topology(): exact counts on small meshes, every connectivity invariant on generated
// surfaces and on their random re-numberings and refinements, and each refusal status.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>

#include "ricci/topology.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;

namespace {

struct Expected {
  const char* name;
  Mesh mesh;
  std::int64_t chi;
  Index boundary_loops;
  std::int64_t genus;
};

std::vector<Expected> surfaces() {
  using namespace ricci_shapes;
  const Mesh sphere = icosphere(2);
  const Mesh g2 = pretzel(2, 2);
  return {
      {"icosphere", sphere, 2, 0, 0},
      {"torus", torus(12, 8, 2.0, 0.7), 0, 0, 1},
      {"genus-2", g2, -2, 0, 2},
      {"genus-3", pretzel(3, 2), -4, 0, 3},
      {"disk", disk(6), 1, 1, 0},
      {"annulus", annulus(4, 24), 0, 2, 0},
      {"sphere with 3 holes", remove_vertex_stars(sphere, {0, 5, 9}), -1, 3, 0},
      {"genus-2 with a hole", remove_vertex_stars(g2, {0}), -3, 1, 2},
  };
}

void check_surface(const Mesh& m, std::int64_t chi, Index b, std::int64_t g) {
  const auto r = build_topology(m.faces, m.num_vertices());
  REQUIRE(r.status == Status::Ok);
  const Topology& t = r.topology;
  CHECK(t.num_vertices - t.num_edges + t.num_faces == t.euler_characteristic());
  CHECK(t.euler_characteristic() == chi);
  CHECK(t.num_boundary_loops() == b);
  CHECK(t.genus() == g);
  CHECK(t.num_components == 1);
  CHECK(t.euler_characteristic() == 2 - 2 * t.genus() - t.num_boundary_loops());
  CHECK(ricci_test::check_topology(t, m.faces) == "");
}

}  // namespace

TEST_CASE("topology: tetrahedron, single triangle and two components have the exact counts") {
  const std::vector<Index> tet = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
  auto r = build_topology(tet, 4);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.topology.num_edges == 6);
  CHECK(r.topology.euler_characteristic() == 2);
  CHECK(r.topology.is_closed());
  CHECK(r.topology.genus() == 0);
  CHECK(ricci_test::check_topology(r.topology, tet) == "");

  const std::vector<Index> tri = {0, 1, 2};
  r = build_topology(tri, 3);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.topology.num_boundary_loops() == 1);
  CHECK(r.topology.boundary_vertices == std::vector<Index>{1, 2, 0});
  CHECK(ricci_test::check_topology(r.topology, tri) == "");

  std::vector<Index> two = tet;
  for (Index v : tet) two.push_back(v + 4);
  r = build_topology(two, 8);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.topology.num_components == 2);
  CHECK(r.topology.genus() == 0);  // total genus of two spheres
  CHECK(ricci_test::check_topology(r.topology, two) == "");
}

TEST_CASE("topology: invariants and Euler characteristic on generated surfaces") {
  for (const auto& s : surfaces()) {
    INFO(s.name);
    check_surface(s.mesh, s.chi, s.boundary_loops, s.genus);
  }
}

TEST_CASE("topology: random renumberings, rotations, splits, flips and subdivisions keep every invariant") {
  using namespace ricci_shapes;
  for (const auto& s : surfaces()) {
    ricci_test::for_each_seed(1, 4, [&](std::uint64_t seed) {
      INFO(s.name);
      std::mt19937_64 rng(seed);
      Mesh m = permute_vertices(s.mesh, rng);
      m = permute_faces(m, rng);
      m = rotate_face_corners(m, rng);
      check_surface(m, s.chi, s.boundary_loops, s.genus);
      m = split_random_faces(m, rng);
      check_surface(m, s.chi, s.boundary_loops, s.genus);
      m = flip_random_edges(m, rng);
      check_surface(m, s.chi, s.boundary_loops, s.genus);
      if (seed == 1) check_surface(subdivide_midpoint(m), s.chi, s.boundary_loops, s.genus);
    });
  }
}

TEST_CASE("topology: counts do not depend on vertex or face order") {
  using namespace ricci_shapes;
  const Mesh base = remove_vertex_stars(pretzel(2, 2), {3});
  const auto ref = build_topology(base.faces, base.num_vertices());
  REQUIRE(ref.status == Status::Ok);
  for (std::uint64_t seed = 10; seed < 16; ++seed) {
    CAPTURE(seed);
    std::mt19937_64 rng(seed);
    const Mesh m = permute_faces(permute_vertices(base, rng), rng);
    const auto r = build_topology(m.faces, m.num_vertices());
    REQUIRE(r.status == Status::Ok);
    CHECK(r.topology.num_edges == ref.topology.num_edges);
    CHECK(r.topology.num_boundary_edges() == ref.topology.num_boundary_edges());
    // Valence multiset is a property of the surface, not of the numbering.
    std::vector<Index> a, b;
    for (Index v = 0; v < base.num_vertices(); ++v) a.push_back(ref.topology.valence(v));
    for (Index v = 0; v < m.num_vertices(); ++v) b.push_back(r.topology.valence(v));
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    CHECK(a == b);
  }
}

TEST_CASE("topology: refusals name the status and the element") {
  SUBCASE("buffer not a multiple of three") {
    const std::vector<Index> f = {0, 1};
    CHECK(build_topology(f, 3).status == Status::InvalidArgument);
  }
  SUBCASE("index out of range") {
    const std::vector<Index> f = {0, 1, 2, 0, 2, 7};
    const auto r = build_topology(f, 4);
    CHECK(r.status == Status::IndexOutOfRange);
    CHECK(r.element == Element::Face);
    CHECK(r.element_index == 1);
  }
  SUBCASE("repeated vertex") {
    const std::vector<Index> f = {0, 1, 1};
    CHECK(build_topology(f, 3).status == Status::DegenerateFace);
  }
  SUBCASE("three faces on one edge") {
    const std::vector<Index> f = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    const auto r = build_topology(f, 5);
    CHECK(r.status == Status::NonManifoldEdge);
    CHECK(r.message.find("(0, 1)") != std::string::npos);
  }
  SUBCASE("inconsistent orientation") {
    const std::vector<Index> f = {0, 1, 2, 0, 1, 3};
    CHECK(build_topology(f, 4).status == Status::InconsistentOrientation);
  }
  SUBCASE("two fans at one vertex (bow tie)") {
    const std::vector<Index> f = {0, 1, 2, 0, 3, 4};
    const auto r = build_topology(f, 5);
    CHECK(r.status == Status::NonManifoldVertex);
    CHECK(r.element == Element::Vertex);
    CHECK(r.element_index == 0);
  }
  SUBCASE("two closed fans at one vertex (two tetrahedra sharing a vertex)") {
    const std::vector<Index> f = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2, 0, 5, 4, 0, 4, 6, 4, 5, 6, 0, 6, 5};
    const auto r = build_topology(f, 7);
    CHECK(r.status == Status::NonManifoldVertex);
    CHECK(r.element_index == 0);
  }
}

namespace {

// Cut flags along the edges of a random spanning forest grown from `roots` vertices, so that
// most cut edges join long paths (the cuts a disk is made of).
std::vector<char> tree_cut(const Topology& t, std::mt19937_64& rng, int roots, double keep) {
  std::vector<char> cut(static_cast<std::size_t>(t.num_edges), 0), seen(static_cast<std::size_t>(t.num_vertices), 0);
  std::vector<Index> stack;
  for (int i = 0; i < roots; ++i) {
    const Index r = static_cast<Index>(rng() % static_cast<std::uint64_t>(t.num_vertices));
    if (!seen[r]) stack.push_back(r);
    seen[r] = 1;
  }
  std::uniform_real_distribution<double> u(0, 1);
  while (!stack.empty()) {
    const Index v = stack.back();
    stack.pop_back();
    for (Index k = t.vertex_corner_offsets[v]; k < t.vertex_corner_offsets[v + 1]; ++k) {
      const Index c = t.vertex_corners[k];
      const Index w = t.corner_vertex[next_corner(c)];
      if (seen[w] || u(rng) > keep) continue;
      seen[w] = 1;
      cut[t.corner_edge[prev_corner(c)]] = 1;
      stack.push_back(w);
    }
  }
  return cut;
}

}  // namespace

TEST_CASE("topology: cut_open equals build_topology of the cut faces, bit for bit") {
  using namespace ricci_shapes;
  Index refused = 0, glued = 0, opened = 0;
  // One result reused by every cut below (the overload that keeps its buffers): whatever it held
  // before (another surface, more boundary, a refused cut), it ends as the fresh result.
  CutOpenResult reused;
  for (const auto& s : surfaces()) {
    const Topology t = build_topology(s.mesh.faces, s.mesh.num_vertices()).topology;
    for (std::uint64_t seed = 1; seed <= 6; ++seed) {
      INFO(s.name);
      CAPTURE(seed);
      std::mt19937_64 rng(seed);
      std::vector<char> cut;
      if (seed <= 3) {
        cut = tree_cut(t, rng, static_cast<int>(seed), seed == 3 ? 0.5 : 1.0);
      } else {
        // isolated edges and short pieces: two copies of an edge may join the same two copies
        cut.assign(static_cast<std::size_t>(t.num_edges), 0);
        for (Index e = 0; e < t.num_edges; ++e) cut[e] = rng() % (seed == 6 ? 2 : 7) == 0;
      }
      const CutOpenResult o = cut_open(t, cut);
      cut_open(t, cut, reused);
      CHECK(reused.status == o.status);
      CHECK(reused.message == o.message);
      CHECK(reused.faces == o.faces);
      CHECK(reused.to_surface == o.to_surface);
      if (o.status == Status::Ok) CHECK(ricci_test::same_topology(reused.topology, o.topology));
      const TopologyResult b = build_topology(o.faces, static_cast<Index>(o.to_surface.size()));
      CHECK(o.status == b.status);
      CHECK(o.message == b.message);
      if (b.status != Status::Ok) {
        ++refused;
        continue;
      }
      ++opened;
      CHECK(ricci_test::same_topology(o.topology, b.topology));
      CHECK(ricci_test::check_topology(o.topology, o.faces) == "");
      // Copies: each is a corner's vertex; copies of one vertex are consecutive.
      REQUIRE(o.faces.size() == t.corner_vertex.size());
      for (std::size_t c = 0; c < o.faces.size(); ++c) CHECK(o.to_surface[o.faces[c]] == t.corner_vertex[c]);
      CHECK(std::is_sorted(o.to_surface.begin(), o.to_surface.end()));
      // Cut edges become boundary, except where both sides of one join the same two copies
      // (an isolated cut edge, say): build_topology() glues those back.
      for (Index e = 0; e < t.num_edges; ++e) {
        if (!cut[e] || t.edge_corners[2 * e + 1] == kInvalid) continue;
        const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
        const bool same_ends = o.faces[next_corner(c0)] == o.faces[prev_corner(c1)] &&
                               o.faces[prev_corner(c0)] == o.faces[next_corner(c1)];
        CHECK(o.topology.opposite[c0] == (same_ends ? c1 : kInvalid));
        glued += same_ends ? 1 : 0;
      }
    }
  }
  CHECK(opened > 20);
  CHECK(glued > 0);  // the isolated edges take build_topology()'s path
  MESSAGE("cut_open: " << opened << " cuts opened, " << glued << " edges glued back, " << refused << " refused");
  // No cut: the surface itself.
  const Mesh m = torus(12, 8, 2.0, 0.7);
  const Topology t = build_topology(m.faces, m.num_vertices()).topology;
  const CutOpenResult none = cut_open(t, std::vector<char>(static_cast<std::size_t>(t.num_edges), 0));
  REQUIRE(none.status == Status::Ok);
  CHECK(ricci_test::same_topology(none.topology, t));
  CHECK(is_topology_of(none.topology, m.faces, m.num_vertices()));
  CHECK_FALSE(is_topology_of(none.topology, m.faces, m.num_vertices() + 1));
  std::vector<Index> other = m.faces;
  std::swap(other[0], other[1]);
  CHECK_FALSE(is_topology_of(none.topology, other, m.num_vertices()));
  // Wrong size.
  const CutOpenResult bad = cut_open(t, std::vector<char>(3, 0));
  CHECK(bad.status == Status::InvalidArgument);
  CHECK(bad.message.find("3 cut flags") != std::string::npos);
  cut_open(t, std::vector<char>(3, 0), reused);  // refused: nothing of the last result is left
  CHECK(reused.status == Status::InvalidArgument);
  CHECK(reused.faces.empty());
  CHECK(reused.to_surface.empty());
  CHECK(reused.topology.num_faces == 0);
  CHECK(reused.topology.corner_vertex.empty());
}
