// ricci fuzzing — invariants shared by the libFuzzer harnesses in tools/fuzz (not part of the
// library). Every check traps (__builtin_trap) on violation so that libFuzzer records the input
// as a crash, after printing which invariant failed.
//
// What is asserted:
//   reading, Ok      the documented shape of a ReadResult: flat buffers of whole rows, indices in
//                    range, finite numbers, consistent polygon bookkeeping; and a write→read
//                    round trip in every format reproduces the mesh bit for bit (io.h's promise)
//   reading, failed  a status other than Ok / NotRun and a message naming the input
//   topology         the connectivity contract of topology.h / conventions.h, checked in full
//   validating, Ok   the clean mesh is what validate.h promises, and diagnose() agrees
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/io.h"
#include "ricci/mesh.h"
#include "ricci/status.h"
#include "ricci/topology.h"
#include "ricci/validate.h"

namespace ricci_fuzz {

/// Stops the process with a message naming the failed invariant (libFuzzer saves the input).
[[noreturn]] inline void violated(const char* what, const char* file, int line) {
  std::fprintf(stderr, "ricci fuzz: invariant violated: %s (%s:%d)\n", what, file, line);
  std::fflush(stderr);
  __builtin_trap();
}

#define RICCI_FUZZ_CHECK(cond)                                      \
  do {                                                              \
    if (!(cond)) ::ricci_fuzz::violated(#cond, __FILE__, __LINE__); \
  } while (false)

inline bool finite(double x) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &x, sizeof bits);
  return (bits & 0x7ff0000000000000ull) != 0x7ff0000000000000ull;
}

inline bool all_finite(std::span<const double> xs) {
  for (const double x : xs)
    if (!finite(x)) return false;
  return true;
}

inline bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

inline bool starts_with(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

/// A failed operation: a real failure status and a message that names the input.
inline void check_failure(ricci::Status status, const std::string& message, std::string_view name) {
  RICCI_FUZZ_CHECK(status != ricci::Status::Ok);
  RICCI_FUZZ_CHECK(status != ricci::Status::NotRun);
  RICCI_FUZZ_CHECK(starts_with(message, name));
  RICCI_FUZZ_CHECK(message.size() > name.size() + 2);
}

/// A Mesh whose buffers are whole rows, indices in range and numbers finite.
inline void check_mesh(const ricci::Mesh& mesh) {
  RICCI_FUZZ_CHECK(mesh.positions.size() % 3 == 0);
  RICCI_FUZZ_CHECK(mesh.faces.size() % 3 == 0);
  RICCI_FUZZ_CHECK(all_finite(mesh.positions));
  const ricci::Index nv = mesh.num_vertices();
  for (const ricci::Index v : mesh.faces) RICCI_FUZZ_CHECK(v >= 0 && v < nv);
  RICCI_FUZZ_CHECK(mesh.texcoords.size() % 2 == 0);
  RICCI_FUZZ_CHECK(all_finite(mesh.texcoords));
  RICCI_FUZZ_CHECK(mesh.corner_texcoords.empty() || mesh.corner_texcoords.size() == mesh.faces.size());
  const ricci::Index nt = mesh.num_texcoords();
  for (const ricci::Index t : mesh.corner_texcoords) RICCI_FUZZ_CHECK(t >= 0 && t < nt);
}

/// Writes `mesh` in `format`, reads it back and requires the same buffers, bit for bit.
inline void check_round_trip(const ricci::Mesh& mesh, ricci::FileFormat format) {
  const std::string bytes = ricci::serialize_mesh(mesh, format);
  RICCI_FUZZ_CHECK(!bytes.empty());
  ricci::ReadOptions options;
  options.format = format;
  const ricci::ReadResult back = ricci::read_mesh_from_memory(bytes, "round-trip", options);
  RICCI_FUZZ_CHECK(back.status == ricci::Status::Ok);
  RICCI_FUZZ_CHECK(same_bits(back.mesh.positions, mesh.positions));
  RICCI_FUZZ_CHECK(back.mesh.faces == mesh.faces);
  RICCI_FUZZ_CHECK(back.polygons_triangulated == 0);
  if (format == ricci::FileFormat::Obj && mesh.has_texcoords()) {
    RICCI_FUZZ_CHECK(same_bits(back.mesh.texcoords, mesh.texcoords));
    RICCI_FUZZ_CHECK(back.mesh.corner_texcoords == mesh.corner_texcoords);
  }
}

/// The documented shape of a ReadResult (io.h), for either outcome. `requested` is the format
/// asked for (the PLY reader reports ascii or binary from the header).
inline void check_read(const ricci::ReadResult& r, std::string_view name, ricci::FileFormat requested,
                       bool round_trip = true) {
  if (r.status != ricci::Status::Ok) {
    check_failure(r.status, r.message, name);
    return;
  }
  RICCI_FUZZ_CHECK(starts_with(r.message, name));
  RICCI_FUZZ_CHECK(r.line == -1);
  check_mesh(r.mesh);
  const bool ply = requested == ricci::FileFormat::PlyAscii || requested == ricci::FileFormat::PlyBinary;
  const bool stl = requested == ricci::FileFormat::StlAscii || requested == ricci::FileFormat::StlBinary;
  if (ply) {
    RICCI_FUZZ_CHECK(r.format == ricci::FileFormat::PlyAscii || r.format == ricci::FileFormat::PlyBinary);
  } else if (stl) {
    RICCI_FUZZ_CHECK(r.format == ricci::FileFormat::StlAscii || r.format == ricci::FileFormat::StlBinary);
  } else {
    RICCI_FUZZ_CHECK(r.format == requested);
  }
  // Polygon bookkeeping: every polygon gives at least one triangle; triangle_polygon is empty
  // when nothing was triangulated, else it maps #F triangles to polygons in file order.
  const std::int64_t nf = r.mesh.num_faces();
  RICCI_FUZZ_CHECK(r.polygons_read >= 0 && r.polygons_read <= nf);
  RICCI_FUZZ_CHECK(r.polygons_triangulated >= 0 && r.polygons_triangulated <= r.polygons_read);
  if (r.polygons_triangulated == 0) {
    RICCI_FUZZ_CHECK(r.triangle_polygon.empty());
    RICCI_FUZZ_CHECK(r.polygons_read == nf);
  } else {
    RICCI_FUZZ_CHECK(static_cast<std::int64_t>(r.triangle_polygon.size()) == nf);
    ricci::Index previous = 0;
    for (const ricci::Index p : r.triangle_polygon) {
      RICCI_FUZZ_CHECK(p >= previous && p < r.polygons_read);
      previous = p;
    }
  }
  if (r.format != ricci::FileFormat::Obj) RICCI_FUZZ_CHECK(!r.mesh.has_texcoords());
  if (round_trip) {
    for (const ricci::FileFormat f : {ricci::FileFormat::Obj, ricci::FileFormat::Off,
                                      ricci::FileFormat::PlyAscii, ricci::FileFormat::PlyBinary})
      check_round_trip(r.mesh, f);
  }
}

/// The connectivity contract of topology.h and conventions.h for `faces` on `nv` vertices.
inline void check_topology(const ricci::Topology& t, std::span<const ricci::Index> faces, ricci::Index nv) {
  using ricci::Index;
  using ricci::kInvalid;
  const Index nc = 3 * t.num_faces;
  RICCI_FUZZ_CHECK(t.num_vertices == nv);
  RICCI_FUZZ_CHECK(static_cast<std::size_t>(nc) == faces.size());
  RICCI_FUZZ_CHECK(t.corner_vertex.size() == faces.size());
  RICCI_FUZZ_CHECK(std::equal(faces.begin(), faces.end(), t.corner_vertex.begin()));
  RICCI_FUZZ_CHECK(t.opposite.size() == faces.size() && t.corner_edge.size() == faces.size());
  RICCI_FUZZ_CHECK(t.edge_vertices.size() == 2 * static_cast<std::size_t>(t.num_edges));
  RICCI_FUZZ_CHECK(t.edge_corners.size() == 2 * static_cast<std::size_t>(t.num_edges));
  auto vertex = [&](Index c) { return t.corner_vertex[c]; };

  // Opposite corners: an involution pairing the two sides of an edge, traversed both ways.
  Index boundary_corners = 0;
  for (Index c = 0; c < nc; ++c) {
    const Index o = t.opposite[c];
    if (o == kInvalid) {
      ++boundary_corners;
      continue;
    }
    RICCI_FUZZ_CHECK(o >= 0 && o < nc && o != c);
    RICCI_FUZZ_CHECK(t.opposite[o] == c);
    RICCI_FUZZ_CHECK(vertex(ricci::next_corner(o)) == vertex(ricci::prev_corner(c)));
    RICCI_FUZZ_CHECK(vertex(ricci::prev_corner(o)) == vertex(ricci::next_corner(c)));
    RICCI_FUZZ_CHECK(t.corner_edge[o] == t.corner_edge[c]);
  }
  // Edges: each is opposite one or two corners, listed in edge_corners.
  std::vector<int> corners_of_edge(static_cast<std::size_t>(t.num_edges), 0);
  for (Index c = 0; c < nc; ++c) {
    const Index e = t.corner_edge[c];
    RICCI_FUZZ_CHECK(e >= 0 && e < t.num_edges);
    ++corners_of_edge[e];
  }
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
    RICCI_FUZZ_CHECK(c0 >= 0 && c0 < nc && t.corner_edge[c0] == e);
    RICCI_FUZZ_CHECK(t.opposite[c0] == c1);
    RICCI_FUZZ_CHECK(corners_of_edge[e] == (c1 == kInvalid ? 1 : 2));
    if (c1 != kInvalid) RICCI_FUZZ_CHECK(c0 < c1);
    RICCI_FUZZ_CHECK(t.edge_vertices[2 * e] == vertex(ricci::next_corner(c0)));
    RICCI_FUZZ_CHECK(t.edge_vertices[2 * e + 1] == vertex(ricci::prev_corner(c0)));
  }
  // Vertex → corner CSR: a partition of the corners by vertex.
  RICCI_FUZZ_CHECK(t.vertex_corner_offsets.size() == static_cast<std::size_t>(nv) + 1);
  RICCI_FUZZ_CHECK(t.vertex_corner_offsets[0] == 0 && t.vertex_corner_offsets[nv] == nc);
  RICCI_FUZZ_CHECK(t.vertex_corners.size() == faces.size());
  std::vector<std::uint8_t> seen(faces.size(), 0);
  for (Index v = 0; v < nv; ++v) {
    RICCI_FUZZ_CHECK(t.vertex_corner_offsets[v] <= t.vertex_corner_offsets[v + 1]);
    for (Index j = t.vertex_corner_offsets[v]; j < t.vertex_corner_offsets[v + 1]; ++j) {
      const Index c = t.vertex_corners[j];
      RICCI_FUZZ_CHECK(c >= 0 && c < nc && !seen[c] && vertex(c) == v);
      seen[c] = 1;
    }
  }
  // Boundary loops: one entry per boundary edge, each loop closed.
  RICCI_FUZZ_CHECK(t.boundary_vertices.size() == t.boundary_corners.size());
  RICCI_FUZZ_CHECK(t.num_boundary_edges() == boundary_corners);
  if (!t.boundary_offsets.empty()) {
    RICCI_FUZZ_CHECK(t.boundary_offsets.front() == 0);
    RICCI_FUZZ_CHECK(t.boundary_offsets.back() == t.num_boundary_edges());
  } else {
    RICCI_FUZZ_CHECK(boundary_corners == 0);
  }
  for (Index i = 0; i < t.num_boundary_loops(); ++i) {
    const Index begin = t.boundary_offsets[i], end = t.boundary_offsets[i + 1];
    RICCI_FUZZ_CHECK(begin < end);
    for (Index j = begin; j < end; ++j) {
      const Index c = t.boundary_corners[j];
      RICCI_FUZZ_CHECK(c >= 0 && c < nc && t.opposite[c] == kInvalid);
      // The edge opposite c runs from vertex(next(c)) to vertex(prev(c)) = the next loop vertex.
      RICCI_FUZZ_CHECK(t.boundary_vertices[j] == vertex(ricci::next_corner(c)));
      const Index following = j + 1 < end ? t.boundary_vertices[j + 1] : t.boundary_vertices[begin];
      RICCI_FUZZ_CHECK(vertex(ricci::prev_corner(c)) == following);
    }
  }
  // Components.
  RICCI_FUZZ_CHECK(t.face_component.size() == static_cast<std::size_t>(t.num_faces));
  for (const Index k : t.face_component) RICCI_FUZZ_CHECK(k >= 0 && k < t.num_components);
  if (t.num_faces > 0) RICCI_FUZZ_CHECK(t.num_components >= 1);
}

/// What validate.h promises about a successful validation of `input` (#V_in, #F_in).
inline void check_validated(const ricci::ValidateResult& v, const ricci::Mesh& input,
                            const ricci::ValidateOptions& options) {
  const ricci::Mesh& m = v.mesh;
  check_mesh(m);
  RICCI_FUZZ_CHECK(m.num_faces() > 0);
  RICCI_FUZZ_CHECK(v.vertex_to_input.size() == static_cast<std::size_t>(m.num_vertices()));
  RICCI_FUZZ_CHECK(v.face_to_input.size() == static_cast<std::size_t>(m.num_faces()));
  for (std::size_t i = 0; i < v.vertex_to_input.size(); ++i) {
    const ricci::Index w = v.vertex_to_input[i];
    RICCI_FUZZ_CHECK(w >= 0 && w < input.num_vertices());
    for (int d = 0; d < 3; ++d)
      RICCI_FUZZ_CHECK(m.positions[3 * i + d] == input.positions[3 * std::size_t(w) + d]);
  }
  for (const ricci::Index f : v.face_to_input) RICCI_FUZZ_CHECK(f >= 0 && f < input.num_faces());
  check_topology(v.topology, m.faces, m.num_vertices());
  // Every vertex is used; one component; manifold and consistently oriented: diagnose() agrees.
  for (ricci::Index i = 0; i < m.num_vertices(); ++i) RICCI_FUZZ_CHECK(v.topology.valence(i) > 0);
  RICCI_FUZZ_CHECK(v.topology.num_components == 1);
  const ricci::MeshDiagnostics d = ricci::diagnose(m, options.degenerate_tolerance);
  RICCI_FUZZ_CHECK(d.vertices_listed == d.vertices_referenced);
  RICCI_FUZZ_CHECK(d.components == 1);
  RICCI_FUZZ_CHECK(d.out_of_range_faces == 0 && d.non_finite_vertices == 0 && d.repeated_vertex_faces == 0);
  RICCI_FUZZ_CHECK(d.zero_area_faces == 0 && d.duplicate_faces == 0);
  RICCI_FUZZ_CHECK(d.non_manifold_edges == 0 && d.non_manifold_vertices == 0 && d.manifold);
  RICCI_FUZZ_CHECK(d.inconsistent_edges == 0 && d.orientable);
  RICCI_FUZZ_CHECK(d.edges == v.topology.num_edges);
  RICCI_FUZZ_CHECK(d.boundary_loops == v.topology.num_boundary_loops());
  RICCI_FUZZ_CHECK(d.euler_characteristic == v.topology.euler_characteristic());
}

}  // namespace ricci_fuzz
