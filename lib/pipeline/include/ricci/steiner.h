// ricci — Steiner points for conformality: the input surface subdivided on its own faces.
//
// Takes: a mesh and its topology. Gives: the same piecewise-flat surface with more vertices —
// every edge split at its midpoint and every face into four, `levels` times (the new vertices lie
// on the input's edges and faces, so the surface and its metric are exactly the input's) — and
// where each new vertex, edge and face lies on the input.
//
// Why. A discrete conformal (vertex-scaling) map is piecewise linear: it is conformal only as far
// as one scale per vertex resolves the smooth map's conformal factor. Where |u_i − u_j| is large
// across an edge, the triangles between them are sheared (boundary/pig-7holes, 891 faces, median
// |Δu| 0.19 over its edges: the fifth of its faces with the largest |Δu| (above 0.765) have a mean
// angle distortion of 0.31, the fifth with the smallest (below 0.145) 0.05). |Δu| halves with the
// edge length, so `steiner_levels()` asks for the levels that bring the median |Δu| below a
// resolution.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ricci/flow.h"
#include "ricci/mesh.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

/// Where a vertex of a subdivided surface lies on the input.
struct SteinerPlace {
  enum class Kind : std::uint8_t { Vertex = 0, Edge = 1, Face = 2 };
  Kind kind = Kind::Vertex;
  Index index = kInvalid;  ///< the input vertex, edge or face
};

/// The input surface subdivided on its own faces (subdivide_on_faces()).
struct SteinerMesh {
  Status status = Status::NotRun;  ///< Ok, or InvalidArgument (sizes, levels)
  std::string message = "not run";
  int levels = 0;
  /// The input's vertices first (same indices and positions), then the new ones.
  Mesh mesh;
  Topology topology;                  ///< build_topology() of mesh.faces
  std::vector<Index> face_input;      ///< #F: the input face each face lies in
  std::vector<SteinerPlace> place;    ///< #V: where each vertex lies on the input
  /// #E: the input edge each edge lies on, kInvalid for an edge inside an input face.
  std::vector<Index> edge_input;
};

/// Subdivides every face into 4^levels faces by repeated midpoint splits (levels in [0, 8]).
/// O(4^levels · #F).
SteinerMesh subdivide_on_faces(const Mesh& mesh, const Topology& topology, int levels);

/// Splits the given boundary edges of `s` (edge indices of s.topology) at their midpoints, each
/// one's triangle into two (a boundary vertex more, on the same input edge; the surface and its
/// metric unchanged), into a subdivision of the same input: the vertices of `s` keep their indices,
/// the new ones follow in the order of `edges`. An edge that is not a boundary edge, or whose
/// triangle an earlier edge of the list already split, is left alone; `split` counts the rest.
/// InvalidArgument for an edge index out of range. O(#F).
SteinerMesh split_boundary_edges(const SteinerMesh& s, std::span<const Index> edges, Index* split = nullptr);

/// Splits every chord of `s` — an interior edge whose two ends are boundary vertices — at its
/// midpoint, each of its two triangles into two (an interior vertex more, flat, on the same input
/// edge; the surface and its metric unchanged), in rounds until none is left (a split makes no
/// chord: the new vertex is interior). The vertices of `s` keep their indices, the new ones follow.
/// Without chords the double of a bordered surface (its mirror image glued along the boundary) is
/// a closed surface; with one, the chord and its mirror copy join the same two vertices. `split`
/// counts the chords split. O(#F) per round.
SteinerMesh split_chords(const SteinerMesh& s, Index* split = nullptr);

/// The chords of a surface (interior edges whose two ends are boundary vertices), ascending. O(#E).
std::vector<Index> find_chords(const Topology& topology);

/// The same target on the subdivided surface: the input's vertices keep theirs, a Steiner vertex
/// gets K̄ = 0 (flat inside a face or on an interior edge; on a boundary edge the boundary does
/// not turn there, and Circle / LoopTotals loops spread their totals by length anyway), held u on
/// a boundary edge whose two ends are held; loop totals follow the loops to the subdivision's
/// loop order.
Target steiner_target(const SteinerMesh& s, const Topology& input, const Target& target);

/// Median over the edges of |u_i − u_j| (#V u), 0 for no edges.
double median_edge_jump(const Topology& topology, const std::vector<double>& u);

/// The levels of subdivision that bring a median edge jump of `median_jump` to at most
/// `resolution` (each level halves it), at most `max_levels`, and no more than keep
/// #F · 4^levels ≤ max_faces.
int steiner_levels(double median_jump, double resolution, int max_levels, Index faces, std::int64_t max_faces);

}  // namespace ricci
