// ricci — where the input's edges run on a flipped intrinsic triangulation.
//
// Takes: an IntrinsicTriangulation whose `normal` coordinates were kept through its flips, and the
// Topology it was made from (the input). Gives: for every input edge, the sequence of current edges
// it crosses, in order, with which crossing of each it is — or the current edge it coincides with.
//
// Normal coordinates (Gillespie, Sharp, Crane, "Integer coordinates for intrinsic geometry
// processing", 2021). Every edge of the current triangulation T stores n_e, the number of times the
// input edges cross it, or −1 when e is itself an input edge. The input edges are pairwise
// disjoint curves between vertices, so inside a triangle of T they are arcs of two kinds: corner
// arcs, which cut off one corner (crossing its two sides), and arcs that leave a vertex and cross
// the opposite side. With n⁺ = max(n, 0) and the corner x opposite side n_x:
//
//     E_x = max(0, n_x⁺ − n_y⁺ − n_z⁺)                     arcs from the vertex at x
//     C_x = (n_y⁺ + n_z⁺ − n_x⁺ + E_x − E_y − E_z) / 2      corner arcs at x       (y, z the others)
//
// and along a side, counted from one end a, the arcs come in the order: the corner arcs at a, the
// arcs from the opposite vertex, the corner arcs at the other end. This order is what makes the
// counts determine the curves (up to isotopy), and what flip_edge() uses to count the crossings of
// the new diagonal: the strands of the quadrilateral whose two ends lie on different sides of it
// (intrinsic.cpp). Flips of either rule keep them, since both put in the other diagonal of the same
// quadrilateral.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ricci/intrinsic.h"
#include "ricci/face_frames.h"
#include "ricci/mesh.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

/// The input edges on the current triangulation: CSR lists of crossings, one per input edge.
struct InputEdgePaths {
  /// Ok; InvalidArgument when the triangulation keeps no normal coordinates or has another vertex
  /// count than the input; NumericalFailure when its coordinates are not those of the input's
  /// edges (a strand ends between two vertices no input edge joins, or an input edge is missing).
  Status status = Status::NotRun;
  std::string message = "not run";
  /// #E(input) + 1: the crossings of input edge a are [offsets[a], offsets[a+1]).
  std::vector<Index> offsets;
  /// The current edge each crossing lies on, in order from the input edge's first vertex
  /// (input.edge_vertices[2a]) to its second.
  std::vector<Index> crossed_edge;
  /// Which crossing of that edge it is: 0 for the one nearest the current edge's first vertex
  /// (edge_vertices[2e]).
  std::vector<Index> crossed_slot;
  /// The corner opposite the crossed edge in the face the input edge leaves there.
  std::vector<Index> crossed_corner;
  /// #E(input): the current edge the input edge coincides with (normal −1), kInvalid when it
  /// crosses edges instead.
  std::vector<Index> along;
  /// #E(input): the current corners at the input edge's first and second vertex in whose faces it
  /// starts and ends (for an input edge that coincides with a current edge e: e's corners'
  /// neighbours in e's first face, i.e. next/prev of edge_corners[2e]).
  std::vector<Index> first_corner, last_corner;
};

/// True when the triangulation is still the input's own (no flip changed it, or flips undid each
/// other into the same indices): the same corner_vertex and corner_edge arrays, and every edge an
/// input edge (normal −1). trace_input_edges() and straight_input_metric() then take every input
/// edge as the current edge of its own index without walking or developing anything.
bool is_input_triangulation(const IntrinsicTriangulation& triangulation, const Topology& input);

/// Traces every input edge over the current triangulation from its normal coordinates. O(#E +
/// total crossings).
InputEdgePaths trace_input_edges(const IntrinsicTriangulation& triangulation, const Topology& input);

/// Where the input edges cross the current ones in the metric at u (#V): per crossing of `paths`,
/// the position on the crossed edge e as a fraction t ∈ (0, 1) of its chord from edge_vertices[2e]
/// (E: the point (1 − t) P₀ + t P₁ of the straight edge; H and S: that point of the chord in the
/// plane of the edge's two ends on the hyperboloid or the sphere, projected back from the centre).
///
/// This is the map of Bobenko–Pinkall–Springborn 2015 and Gillespie–Springborn–Crane 2021: the
/// metric's chords are Penner λ-lengths of one decorated ideal hyperbolic surface, every
/// triangulation's edges (the input's and the current) are its ideal geodesics, and each triangle
/// is mapped to its ideal triangle projectively (the ideal triangle in the Klein model of the
/// triangle's circumdisk). In each face an input edge is therefore a straight segment, the pieces
/// meet on the edges, and the map does not depend on the flips that led to the triangulation. An
/// input edge from a to b is laid out over the faces it crosses in the upper half plane with a at
/// ∞ (horocycle diameters from the λ-lengths, renormalised at each edge, so the layout's nested
/// intervals never underflow); it is the vertical line through b, and its height on the crossed
/// edge's semicircle, measured from the point halfway between the two ends' horocycles, gives t.
///
/// The crossings are those of the input's edges taken as ideal geodesics of that surface. They are
/// the images of the straight input edges when the flips were all Ptolemy flips; after
/// FlipRule::Geometric flips (make_intrinsic_triangulation() with `delaunay`) an input edge that
/// was flipped away is not one of those geodesics, and its image crosses the same edges in the same
/// order but elsewhere (the map of the input surface goes through its intrinsic Delaunay
/// triangulation). O(total crossings).
std::vector<double> input_edge_crossings(const IntrinsicTriangulation& triangulation, std::span<const double> u,
                                         const InputEdgePaths& paths);

/// Tolerance of StraightInputMetric's angle-sum comparison (radians).
inline constexpr double kStraightAngleSumTolerance = 1e-9;

/// The metric of a triangulation at u carried to the input's own triangulation.
struct StraightInputMetric {
  /// Ok; InvalidArgument (paths or sizes); TriangleInequality (a face of the metric at u has no
  /// valid angles); NumericalFailure (an input edge's path does not walk through adjacent faces).
  Status status = Status::NotRun;
  std::string message = "not run";
  /// #E(input): the length of the geodesic of the metric homotopic, with its ends fixed, to each
  /// input edge (its path over the triangulation): the input edge made straight.
  std::vector<double> l;
  /// Per crossing of the paths: where the straight input edge crosses the current edge, as
  /// input_edge_crossings() gives it (a fraction of the chord from edge_vertices[2e]). Outside
  /// (0, 1) where the straight edge leaves its path's faces (a folding straight triangle), NaN
  /// where it runs along the crossed edge.
  std::vector<double> crossings;
  /// Input faces whose straight lengths violate the triangle inequality (a straight triangle that
  /// is degenerate), the smallest of them.
  Index degenerate_faces = 0;
  Index first_degenerate_face = kInvalid;
  /// Vertices where the angles of the straight input triangles (from `l`) do not add up to the
  /// metric's angle sum there, within kStraightAngleSumTolerance, and the largest difference.
  /// Both 0 exactly when the straight triangles tile the surface without folding: a straight
  /// triangle that comes out flipped (negatively oriented) shows as a difference at its vertices.
  Index inconsistent_vertices = 0;
  double max_angle_sum_error = 0;
  Index worst_vertex = kInvalid;

  /// The straight input triangles carry the metric: every angle sum matches, none is degenerate.
  /// Then `l` on the input's triangulation is the same surface as the triangulation at u.
  bool tiles() const { return status == Status::Ok && degenerate_faces == 0 && inconsistent_vertices == 0; }
};

/// Every input edge developed along its path (`paths`, from trace_input_edges()) over the faces of
/// the triangulation in the metric at u (#V), in the triangulation's geometry: the length of the
/// straight (geodesic) input edge in that metric, and whether the straight input triangles tile
/// the surface (StraightInputMetric::tiles()). When they do, the input's triangulation with these
/// lengths is the metric at u exactly (the same cone angles at every vertex), so every stage that
/// works on the input's connectivity (cut, layout, deck group) can take it. O(#E + crossings).
StraightInputMetric straight_input_metric(const IntrinsicTriangulation& triangulation, std::span<const double> u,
                                          const Topology& input, const InputEdgePaths& paths);

/// The smallest gap the straightest crossings keep, as a fraction of the ideal-geodesic gap.
inline constexpr double kCrossingGapFraction = 0.5;

/// Crossing positions for common_subdivision() that keep the input edges as straight as the
/// subdivision allows. Per current edge, its crossings' positions are (1 − s)·straight + s·ideal
/// with the smallest s ∈ [0, 1] that keeps them in the order the normal coordinates give, every gap
/// between two of them or to an end of the edge at least kCrossingGapFraction of the same gap
/// among the ideal positions. `straight`: StraightInputMetric::crossings; `ideal`:
/// input_edge_crossings(), which are always in that order. An edge whose straight positions
/// already keep the gaps takes them as they are (s = 0), so where the straight input triangles
/// tile the surface the subdivision's input edges are straight; an edge with a NaN straight
/// position takes the ideal ones (s = 1). Each current face's chords stay pairwise disjoint
/// whatever s each edge takes, since their ends keep their order around the face. O(crossings).
std::vector<double> straightest_crossings(const IntrinsicTriangulation& triangulation, const InputEdgePaths& paths,
                                          std::span<const double> straight, std::span<const double> ideal);

/// The common subdivision of the input triangulation and the current one (CommonSubdivision).
struct CommonSubdivision {
  /// Ok; InvalidArgument (paths, crossings or sizes); TriangleInequality (a face of the metric at
  /// u has no valid angles); NumericalFailure (the input edges do not cut a face into pieces that
  /// each lie in one input face, or the pieces do not form a manifold triangulation).
  Status status = Status::NotRun;
  std::string message = "not run";
  /// Vertices: the input's (same indices), then one per crossing of an input edge with a current
  /// edge (in the order of InputEdgePaths' crossings). 3D positions: the input's; a crossing's on
  /// its input edge's segment, at the fraction of the edge's length in the metric up to it.
  /// Faces: every piece of a current face cut by the input edges, fan-triangulated,
  /// counter-clockwise.
  Mesh mesh;
  Topology topology;                ///< build_topology() of mesh.faces
  std::vector<double> l;            ///< #E: lengths in the metric at u (the triangulation's geometry)
  std::vector<Index> face_input;    ///< #F: the input face each face lies in
  std::vector<Index> vertex_input_edge;  ///< #V: kInvalid for input vertices, else the crossing's input edge
  /// Each face's current face and its corners there (face_frames.h): the current
  /// triangulation at u is intrinsic Delaunay and well shaped where the subdivision has slivers
  /// (crossings a hair apart on one current edge), so layouts develop it instead (uniformize()).
  FaceFrames frames;
};

/// The exact common subdivision of the input triangulation (its edges as `paths` and `crossings`,
/// from trace_input_edges() and input_edge_crossings()) and the current triangulation at u (#V):
/// every current face cut along the input edges' pieces (straight in its model triangle), each
/// piece triangulated. The surface it describes with `l` is the metric at u itself, and each of its
/// faces lies in one input face, so a layout of it is a bijective map of the input surface even
/// where straight input triangles would fold (StraightInputMetric::tiles() false). `input_mesh`
/// gives the 3D positions. O(#F + crossings).
CommonSubdivision common_subdivision(const IntrinsicTriangulation& triangulation, std::span<const double> u,
                                     const Mesh& input_mesh, const Topology& input, const InputEdgePaths& paths,
                                     std::span<const double> crossings);

/// The arcs of the input edges inside the face of corner c, seen from c (see the top of this header).
struct CornerArcs {
  std::int64_t from_vertex = 0;  ///< E_c: arcs from the vertex at c across the opposite side
  std::int64_t around = 0;       ///< C_c: corner arcs cutting off c
};
/// CornerArcs of corner c; O(1). Precondition: normal coordinates are kept.
CornerArcs corner_arcs(const IntrinsicTriangulation& triangulation, Index c);

}  // namespace ricci
