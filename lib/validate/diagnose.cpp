#include <algorithm>
#include <cmath>
#include <numbers>

#include "edge_table.h"
#include "ricci/validate.h"

namespace ricci {

MeshDiagnostics diagnose(const Mesh& mesh, double degenerate_tolerance) {
  MeshDiagnostics d;
  const Index nv = mesh.num_vertices();
  const Index nf = mesh.num_faces();
  const std::span<const Index> faces(mesh.faces.data(), 3 * static_cast<std::size_t>(nf));
  d.vertices_listed = nv;
  d.faces = nf;

  // Faces usable for edge analysis: indices in range and three distinct vertices.
  std::vector<std::uint8_t> in_range(static_cast<std::size_t>(nf), 0), proper(static_cast<std::size_t>(nf), 0);
  std::vector<std::uint8_t> referenced(static_cast<std::size_t>(nv), 0);
  for (Index f = 0; f < nf; ++f) {
    bool ok = true;
    for (Index k = 0; k < 3; ++k) ok = ok && faces[3 * f + k] >= 0 && faces[3 * f + k] < nv;
    if (!ok) {
      ++d.out_of_range_faces;
      continue;
    }
    in_range[f] = 1;
    for (Index k = 0; k < 3; ++k) referenced[faces[3 * f + k]] = 1;
    proper[f] = detail::face_is_proper(faces, f, nv);
    d.repeated_vertex_faces += !proper[f];
  }
  for (Index v = 0; v < nv; ++v) {
    if (!referenced[v]) continue;
    ++d.vertices_referenced;
    const double* p = &mesh.positions[3 * static_cast<std::size_t>(v)];
    d.non_finite_vertices += !(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
  }

  // Shape: degeneracy and angles.
  double min_angle = std::numbers::pi, max_angle = 0;
  std::int64_t shaped = 0, obtuse = 0;
  for (Index f = 0; f < nf; ++f) {
    if (!proper[f]) continue;
    const auto s = detail::triangle_shape(&mesh.positions[3 * static_cast<std::size_t>(faces[3 * f])],
                                          &mesh.positions[3 * static_cast<std::size_t>(faces[3 * f + 1])],
                                          &mesh.positions[3 * static_cast<std::size_t>(faces[3 * f + 2])]);
    if (detail::is_degenerate(s, degenerate_tolerance)) {
      ++d.zero_area_faces;
      continue;
    }
    ++shaped;
    const double lo = std::min({s.angles[0], s.angles[1], s.angles[2]});
    const double hi = std::max({s.angles[0], s.angles[1], s.angles[2]});
    min_angle = std::min(min_angle, lo);
    max_angle = std::max(max_angle, hi);
    obtuse += hi > std::numbers::pi / 2;
  }
  if (shaped > 0) {
    d.min_corner_angle = min_angle;
    d.max_corner_angle = max_angle;
    d.obtuse_face_fraction = static_cast<double>(obtuse) / static_cast<double>(shaped);
  }

  const auto duplicates = detail::find_duplicate_faces(faces, nv, proper);
  for (Index f = 0; f < nf; ++f) d.duplicate_faces += proper[f] && duplicates[f] != kInvalid;

  // Edges, boundary, non-manifold edges, orientation.
  const detail::EdgeTable table = detail::build_edge_table(faces, nv, proper);
  d.edges = table.num_groups();
  detail::DisjointSets boundary_sets(nv);
  std::vector<std::uint8_t> on_boundary(static_cast<std::size_t>(nv), 0);
  for (Index g = 0; g < table.num_groups(); ++g) {
    const Index size = table.group_size(g);
    if (size == 1) {
      ++d.boundary_edges;
      const Index c = table.group_corners[table.group_offsets[g]];
      const Index a = detail::edge_from(faces, c), b = detail::edge_to(faces, c);
      boundary_sets.unite(a, b);
      on_boundary[a] = on_boundary[b] = 1;
    } else if (size > 2) {
      ++d.non_manifold_edges;
    }
  }
  for (Index v = 0; v < nv; ++v) d.boundary_loops += on_boundary[v] && boundary_sets.find(v) == v;

  const detail::Orientation orientation = detail::orient_faces(faces, table, proper);
  d.orientable = orientation.orientable;
  d.inconsistent_edges = orientation.inconsistent_edges;

  // Fans: corners at a vertex joined across manifold edges through that vertex.
  detail::DisjointSets fans(3 * nf);
  for (Index g = 0; g < table.num_groups(); ++g) {
    if (table.group_size(g) != 2) continue;
    const Index c0 = table.group_corners[table.group_offsets[g]];
    const Index c1 = table.group_corners[table.group_offsets[g] + 1];
    // The edge opposite c0 has end corners next(c0), prev(c0); match them by vertex in c1's face.
    for (const Index a : {next_corner(c0), prev_corner(c0)}) {
      const Index b = faces[next_corner(c1)] == faces[a] ? next_corner(c1) : prev_corner(c1);
      fans.unite(a, b);
    }
  }
  std::vector<Index> fan_count(static_cast<std::size_t>(nv), 0);
  for (Index c = 0; c < 3 * nf; ++c)
    if (proper[c / 3] && fans.find(c) == c) ++fan_count[faces[c]];
  for (Index v = 0; v < nv; ++v) d.non_manifold_vertices += fan_count[v] > 1;
  d.manifold = d.non_manifold_edges == 0 && d.non_manifold_vertices == 0;

  std::vector<Index> component;
  std::vector<Index> in_range_faces;
  in_range_faces.reserve(faces.size());
  for (Index f = 0; f < nf; ++f)
    if (in_range[f]) in_range_faces.insert(in_range_faces.end(), &faces[3 * f], &faces[3 * f] + 3);
  d.components = detail::face_components_by_vertex(in_range_faces, nv, &component);
  d.euler_characteristic = d.vertices_referenced - d.edges + d.faces;
  d.genus = (2 * d.components - d.euler_characteristic - d.boundary_loops) / 2;
  return d;
}

}  // namespace ricci
