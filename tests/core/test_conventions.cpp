// The corner/edge/rotation conventions of conventions.h, checked on concrete meshes.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

#include "ricci/conventions.h"
#include "ricci/topology.h"

using namespace ricci;

TEST_CASE("conventions: corner arithmetic") {
  for (Index f = 0; f < 50; ++f) {
    for (Index k = 0; k < 3; ++k) {
      const Index c = face_corner(f, k);
      CHECK(corner_face(c) == f);
      CHECK(corner_slot(c) == k);
      CHECK(corner_face(next_corner(c)) == f);
      CHECK(corner_face(prev_corner(c)) == f);
      CHECK(corner_slot(next_corner(c)) == (k + 1) % 3);
      CHECK(corner_slot(prev_corner(c)) == (k + 2) % 3);
      CHECK(next_corner(prev_corner(c)) == c);
      CHECK(next_corner(next_corner(next_corner(c))) == c);
    }
  }
}

TEST_CASE("conventions: edges, opposite corners and counter-clockwise fans on a planar fan") {
  // Vertex 0 at the origin surrounded by n vertices on the unit circle; faces (0, i, i+1) are
  // counter-clockwise seen from +z.
  const Index n = 7;
  std::vector<Index> faces;
  for (Index i = 0; i < n; ++i) faces.insert(faces.end(), {0, 1 + i, 1 + (i + 1) % n});
  const auto r = build_topology(faces, n + 1);
  REQUIRE(r.status == Status::Ok);
  const Topology& t = r.topology;
  CHECK(t.num_edges == 2 * n);
  CHECK(t.euler_characteristic() == 1);
  CHECK(t.num_boundary_loops() == 1);
  CHECK_FALSE(t.is_boundary_vertex(0));
  // Per-face edge k is opposite corner k, running next(c) -> prev(c) in the face.
  for (Index c = 0; c < 3 * n; ++c) {
    const Index e = t.corner_edge[c];
    const Index a = faces[next_corner(c)], b = faces[prev_corner(c)];
    const bool same = t.edge_vertices[2 * e] == a && t.edge_vertices[2 * e + 1] == b;
    const bool reversed = t.edge_vertices[2 * e] == b && t.edge_vertices[2 * e + 1] == a;
    CHECK((same || reversed));
    if (t.edge_corners[2 * e] == c) CHECK(same);
  }
  // The fan of the centre visits the outer vertices with increasing polar angle (counter-clockwise).
  const Index b = t.vertex_corner_offsets[0];
  REQUIRE(t.valence(0) == n);
  for (Index i = 0; i < n; ++i) {
    const Index c = t.vertex_corners[b + i];
    const Index c_next = t.vertex_corners[b + (i + 1) % n];
    CHECK(faces[next_corner(c_next)] == faces[prev_corner(c)]);  // ccw(c) shares the edge 0 -> prev(c)
    CHECK(faces[next_corner(c_next)] - 1 == (faces[next_corner(c)] - 1 + 1) % n);
  }
  // The boundary loop runs counter-clockwise (surface on the left): 1, 2, …, n.
  REQUIRE(t.boundary_offsets[1] == n);
  for (Index i = 0; i < n; ++i) {
    const Index v = t.boundary_vertices[i], w = t.boundary_vertices[(i + 1) % n];
    CHECK((w - 1) == (v - 1 + 1) % n);
  }
  // Boundary fans start at the corner with no clockwise neighbour and end with no ccw neighbour.
  for (Index v = 1; v <= n; ++v) {
    CHECK(t.is_boundary_vertex(v));
    const Index first = t.vertex_corners[t.vertex_corner_offsets[v]];
    const Index last = t.vertex_corners[t.vertex_corner_offsets[v + 1] - 1];
    CHECK(t.opposite[prev_corner(first)] == kInvalid);
    CHECK(t.opposite[next_corner(last)] == kInvalid);
  }
}
