// ricci — connectivity of a manifold, consistently oriented triangle mesh, as flat arrays.
//
// Built once by build_topology() and never mutated. Corner, edge and rotation conventions are in
// conventions.h. All arrays are indexed by 0-based Index values; kInvalid (-1) marks a boundary.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ricci/conventions.h"
#include "ricci/status.h"

namespace ricci {

/// Connectivity of a manifold, consistently oriented triangle mesh (see the top of this header).
/// Plain data filled by build_topology(); #V, #E, #F below are num_vertices, num_edges, num_faces.
struct Topology {
  Index num_vertices = 0;  ///< #V, including vertices used by no face
  Index num_edges = 0;     ///< #E; edges are numbered in the order of (smaller, larger) end vertex
  Index num_faces = 0;     ///< #F

  /// #F×3: corner → vertex (a copy of the face buffer, so kernels need the topology alone).
  std::vector<Index> corner_vertex;
  /// #F×3: corner → corner across the edge opposite it, kInvalid on the boundary.
  std::vector<Index> opposite;
  /// #F×3: corner → edge opposite it (per-face edge k is opposite corner k).
  std::vector<Index> corner_edge;
  /// #E×2: edge → its two end vertices, oriented as the edge runs in the face of
  /// edge_corners[2e] (from vertex(next(c)) to vertex(prev(c)) for c = edge_corners[2e]).
  std::vector<Index> edge_vertices;
  /// #E×2: edge → the corners opposite it. The first is the smaller corner index of an interior
  /// edge; the second is kInvalid for a boundary edge.
  std::vector<Index> edge_corners;
  /// CSR vertex → corners: the corners of vertex v are
  /// vertex_corners[vertex_corner_offsets[v] .. vertex_corner_offsets[v+1]), in counter-clockwise
  /// order. An interior vertex's cycle starts at its smallest corner; a boundary vertex's fan
  /// starts at the corner with no clockwise neighbour (see conventions.h). #V+1 and #F×3.
  std::vector<Index> vertex_corner_offsets;  ///< #V+1: CSR offsets into vertex_corners
  std::vector<Index> vertex_corners;         ///< #F×3: the corners of every vertex, vertex by vertex
  /// CSR boundary loops: loop i has vertices boundary_vertices[boundary_offsets[i] ..
  /// boundary_offsets[i+1]) in the order the loop runs (surface on the left), and
  /// boundary_corners[j] is the corner opposite the edge from boundary_vertices[j] to the next
  /// vertex of the loop. Loops are ordered by their smallest boundary corner; each loop starts at
  /// the edge of its smallest corner. #b+1, #boundary edges, #boundary edges.
  std::vector<Index> boundary_offsets;   ///< #b+1: CSR offsets of the loops (just {0} when closed)
  std::vector<Index> boundary_vertices;  ///< #boundary edges: the loops' vertices, loop by loop
  std::vector<Index> boundary_corners;   ///< #boundary edges: corner opposite each boundary edge
  /// #F: face → connected component (components numbered by their smallest face).
  std::vector<Index> face_component;
  Index num_components = 0;  ///< number of edge-connected components of faces

  /// #F×3.
  Index num_corners() const { return 3 * num_faces; }
  /// b: the number of boundary loops (0 for a closed surface).
  Index num_boundary_loops() const {
    return boundary_offsets.empty() ? 0 : static_cast<Index>(boundary_offsets.size() - 1);
  }
  /// Number of boundary edges (edges with one face).
  Index num_boundary_edges() const { return static_cast<Index>(boundary_corners.size()); }
  /// χ = V − E + F.
  std::int64_t euler_characteristic() const {
    return std::int64_t{num_vertices} - num_edges + num_faces;
  }
  /// Total genus Σ g_i over the components: (2·components − χ − b) / 2.
  std::int64_t genus() const {
    return (2 * std::int64_t{num_components} - euler_characteristic() - num_boundary_loops()) / 2;
  }
  /// The surface is closed (no boundary edges).
  bool is_closed() const { return boundary_corners.empty(); }
  /// Vertex v lies on the boundary (its fan starts at a corner whose clockwise edge is a
  /// boundary edge). False for a vertex used by no face.
  bool is_boundary_vertex(Index v) const {
    if (vertex_corner_offsets[v] == vertex_corner_offsets[v + 1]) return false;
    const Index c = vertex_corners[vertex_corner_offsets[v]];
    return opposite[prev_corner(c)] == kInvalid;
  }
  /// Number of corners (faces) around vertex v.
  Index valence(Index v) const { return vertex_corner_offsets[v + 1] - vertex_corner_offsets[v]; }
  /// The edge joining vertices u and v, found in u's fan (O(valence)); kInvalid when none does.
  Index edge_between(Index u, Index v) const {
    for (Index k = vertex_corner_offsets[u]; k < vertex_corner_offsets[u + 1]; ++k) {
      const Index c = vertex_corners[k];
      if (corner_vertex[next_corner(c)] == v) return corner_edge[prev_corner(c)];
      if (corner_vertex[prev_corner(c)] == v) return corner_edge[next_corner(c)];
    }
    return kInvalid;
  }
};

/// What build_topology() returns.
struct TopologyResult {
  /// Ok, or one of IndexOutOfRange, DegenerateFace (a face repeats a vertex), NonManifoldEdge,
  /// InconsistentOrientation, NonManifoldVertex, InvalidArgument (buffer sizes).
  Status status = Status::NotRun;
  std::string message = "not run";   ///< what went wrong, naming the face or vertex; "ok" on success
  Element element = Element::None;   ///< Face or Vertex the error names; None for InvalidArgument
  std::int64_t element_index = -1;   ///< index of that face or vertex; -1 when element is None
  Topology topology;                 ///< the connectivity (valid only when status is Ok)
};

/// Builds the connectivity of a triangle mesh. Preconditions (each checked, each a status):
/// faces.size() is a multiple of 3; all indices in [0, num_vertices); no face repeats a vertex;
/// every edge has one or two faces; neighbouring faces are consistently oriented; the faces
/// around every vertex form a single fan. Vertices used by no face are allowed (their corner
/// range is empty; they count in V). Linear time and memory; deterministic.
TopologyResult build_topology(std::span<const Index> faces, Index num_vertices);

/// True when `t` holds the connectivity of `faces` over `num_vertices` vertices (the same vertex
/// count and the same corners), so that a stage may take it instead of building it again.
bool is_topology_of(const Topology& t, std::span<const Index> faces, Index num_vertices);

/// What cut_open() returns.
struct CutOpenResult {
  Status status = Status::NotRun;  ///< Ok, InvalidArgument (sizes), or build_topology()'s status
  std::string message = "not run";
  std::vector<Index> faces;       ///< #F×3: corner → vertex copy
  std::vector<Index> to_surface;  ///< #copies: copy → vertex of the surface (non-decreasing)
  Topology topology;              ///< the connectivity of `faces` (valid only when status is Ok)
};

/// The surface `t` cut open along the edges with cut[e] != 0 (#E flags; boundary edges are open
/// already). Every vertex used by a face gets one copy per wedge of its fan between cut or
/// boundary edges; copies are numbered by vertex, then by wedge counter-clockwise, an interior
/// vertex's first wedge starting at the first cut edge of its fan (at its fan's start when none
/// is cut). Unused vertices get no copy. `topology` equals build_topology(faces, #copies) bit for
/// bit, derived from `t` in linear time without sorting; where two copies of a cut edge would
/// join the same two vertex copies, build_topology() itself decides (it glues or refuses them).
CutOpenResult cut_open(const Topology& t, std::span<const char> cut);

/// cut_open() into `out`, whose buffers are reused (a caller that cuts the same surface again and
/// again, as the canonical cut's moves do, gets no fresh pages after the first). The result is
/// cut_open()'s whatever `out` held before.
void cut_open(const Topology& t, std::span<const char> cut, CutOpenResult& out);

}  // namespace ricci
