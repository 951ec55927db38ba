// Internal: analysis of triangle soups shared by build_topology(), diagnose() and validate_mesh().
// Nothing here assumes the soup is manifold or oriented.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ricci/conventions.h"
#include "ricci/topology.h"

namespace ricci::detail {

/// Union–find over 0..n-1 with path halving and union by index (deterministic roots: the
/// smaller index of two joined roots becomes the root).
class DisjointSets {
 public:
  explicit DisjointSets(Index n);
  Index find(Index x);
  void unite(Index a, Index b);

 private:
  std::vector<Index> parent_;
};

/// Corners of a soup grouped by the undirected edge opposite them. A corner of face f takes part
/// only when face_ok[f] is nonzero (all faces when face_ok is empty). Groups are ordered by
/// (smaller vertex, larger vertex); inside a group corners are ascending.
struct EdgeTable {
  std::vector<Index> group_offsets;  ///< #groups+1
  std::vector<Index> group_corners;  ///< corners, grouped
  std::vector<Index> corner_group;   ///< #corners → group, kInvalid for excluded faces

  Index num_groups() const { return static_cast<Index>(group_offsets.size()) - 1; }
  Index group_size(Index g) const { return group_offsets[g + 1] - group_offsets[g]; }
};

/// Builds the edge table. Faces of excluded faces (face_ok[f] == 0) are ignored; every included
/// face must have indices in [0, num_vertices) and three distinct vertices.
EdgeTable build_edge_table(std::span<const Index> faces, Index num_vertices,
                           std::span<const std::uint8_t> face_ok = {});

/// build_topology() from the soup's edge table (faces: in range, each with three distinct
/// vertices; table: build_edge_table(faces, num_vertices), or one equal to it), so that a caller
/// that already has the table does not build it again.
TopologyResult topology_from_edge_table(std::span<const Index> faces, Index num_vertices, const EdgeTable& table);

/// The manifold edges (groups of two corners) that both their faces traverse in the same direction.
std::int64_t count_inconsistent_edges(std::span<const Index> faces, const EdgeTable& table);

/// Start and end vertex of the edge opposite corner c, in the orientation of c's face.
inline Index edge_from(std::span<const Index> faces, Index c) { return faces[next_corner(c)]; }
inline Index edge_to(std::span<const Index> faces, Index c) { return faces[prev_corner(c)]; }

/// True when the face's indices are in range and distinct.
inline bool face_is_proper(std::span<const Index> faces, Index f, Index num_vertices) {
  const Index a = faces[3 * f], b = faces[3 * f + 1], c = faces[3 * f + 2];
  const bool in_range = a >= 0 && b >= 0 && c >= 0 && a < num_vertices && b < num_vertices && c < num_vertices;
  return in_range && a != b && b != c && a != c;
}

/// Scale-free shape of a 3D triangle (p, q, r), computed after rescaling so nothing overflows.
struct TriangleShape {
  bool finite = false;      ///< all coordinates and differences are finite
  double area_ratio = 0;    ///< 2·area / (longest edge)², in [0, √3/2]; 0 when all points coincide
  double angles[3] = {0, 0, 0};  ///< interior angles at p, q, r (atan2 of |cross| and dot)
};
/// Without `with_angles` the angles stay 0 (what is_degenerate() reads costs no arctangent).
TriangleShape triangle_shape(const double* p, const double* q, const double* r, bool with_angles = true);

/// A triangle is degenerate when 2·area ≤ tolerance · longest², or it is not finite.
inline bool is_degenerate(const TriangleShape& s, double tolerance) {
  return !s.finite || s.area_ratio <= tolerance;
}

/// For each face included by face_ok (all when empty): kInvalid when its vertex set did not occur
/// in an earlier face, else the index of the first face with that vertex set. Included faces
/// must have indices in [0, num_vertices).
std::vector<Index> find_duplicate_faces(std::span<const Index> faces, Index num_vertices,
                                        std::span<const std::uint8_t> face_ok = {});

/// Component label of every face (faces sharing a vertex are connected), labels numbered by
/// smallest face. Faces must have in-range indices. Returns the number of components.
Index face_components_by_vertex(std::span<const Index> faces, Index num_vertices, std::vector<Index>* label);

/// Result of trying to orient a soup consistently across its manifold edges (groups of size 2).
struct Orientation {
  bool orientable = true;
  Index conflict_face = kInvalid;     ///< a face where no consistent choice exists
  std::vector<std::uint8_t> flip;     ///< #F: 1 when the face must be flipped
  std::vector<Index> patch;           ///< #F: edge-connected patch label (kInvalid: excluded face)
  Index num_patches = 0;
  std::int64_t inconsistent_edges = 0;  ///< manifold edges traversed the same way by both faces
};
/// Breadth-first orientation from the smallest face of every edge-connected patch (that face keeps
/// its orientation). Excluded faces (face_ok[f] == 0) are left alone.
Orientation orient_faces(std::span<const Index> faces, const EdgeTable& table,
                         std::span<const std::uint8_t> face_ok = {});

}  // namespace ricci::detail
