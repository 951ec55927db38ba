// ricci — intrinsic triangulations: the vertex-scaling (discrete conformal) metric on a
// triangulation that edge flips change, in E, H and S.
//
// Takes: a Topology and the edge lengths l⁰ of a metric on it. Gives: an IntrinsicTriangulation,
// i.e. the same corner-table arrays (conventions.h) updated in place by edge flips, plus one
// log-length per edge; Ptolemy flips, the Delaunay test and flip-to-Delaunay at any u.
//
// Vertex scaling in the three geometries (Bobenko–Pinkall–Springborn 2015; Gu, Luo, Sun, Wu 2018
// I and II) has one form. With the "chord" of an edge
//
//     E: L = l,   H: L = sinh(l/2),   S: L = sin(l/2),
//
// a conformal factor u (#V) scales every chord as L_ij(u) = e^{(u_i + u_j)/2} B_ij, where B_ij is
// the chord of edge ij at u = 0. (This is metric.h's Yamabe scheme: η_ij = B_ij²/2, ε = 0.) The
// chords of four points on a circle — a Euclidean circle, a hyperbolic circle on the hyperboloid,
// a circle on the unit sphere: in each case the points span a Euclidean plane in which L is half
// the straight distance — obey Ptolemy's relation. Flipping edge ij of the triangles ijk and jil
// to kl sets
//
//     B_kl = (B_il B_jk + B_lj B_ki) / B_ij,
//
// which commutes with vertex scaling (both sides scale by e^{(u_k + u_l)/2}), so a flip never
// changes the discrete conformal class. Edge ij is Delaunay at u when the diagonal is at most the
// diagonal of the cyclic quadrilateral with the same four sides, in chords (Gillespie–Springborn–
// Crane 2021, eq. 9, which extends the Euclidean test α + β ≤ π to triangles that violate the
// triangle inequality):
//
//     Q_ij = (L_il L_ki + L_jk L_lj)(L_il L_jk + L_ki L_lj) − L_ij² (L_jk L_ki + L_il L_lj) ≥ 0.
//
// For triangles that satisfy the triangle inequality this is α + β ≤ π in E and α + β ≤ the sum of
// the other four angles of the two triangles in H and S.
//
// Exactness. log B is stored in fixed point, in units of 2⁻⁵⁰ (a relative length resolution of
// 8.9·10⁻¹⁶). A flip computes σ = log(B_il B_jk + B_lj B_ki) from the four unchanged edges
// (symmetric in the two products) and sets log B_kl = σ − log B_ij exactly in integers; the flip
// back computes the same σ, so a flip and its inverse restore every log-length bit for bit.
//
// Connectivity. Flips keep the number of vertices, edges and faces and every edge's index;
// boundary edges are never flipped. Unlike build_topology()'s result, edges are not ordered by
// their end vertices once flipped. The triangulation may become a Δ-complex — an edge from a
// vertex to itself, several edges between two vertices — as the Delaunay triangulation of a
// metric can need (a vertex of valence 1 or 2 inside a thin region); the corner table, the
// kernels and the Newton matrix handle both. vertex_corners is brought up to date by
// refresh_vertex_corners() (make_delaunay() does it).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ricci/metric.h"
#include "ricci/topology.h"

namespace ricci {

/// Fixed-point unit of IntrinsicTriangulation::log_chord: 2⁻⁵⁰ (log_chord[e] · kLogChordUnit = log B_e).
inline constexpr double kLogChordUnit = 0x1p-50;

/// A triangulation of the vertices of a mesh with a vertex-scaling metric on it (see the top of
/// this header). Plain data; the functions below keep it consistent.
struct IntrinsicTriangulation {
  Geometry geometry = Geometry::Euclidean;  ///< what the chords mean: l, sinh(l/2) or sin(l/2)
  /// The connectivity, in Topology's arrays and conventions; corner_vertex, opposite, corner_edge,
  /// edge_vertices, edge_corners and boundary_corners change with flips.
  Topology topology;
  /// #E: log B_e in units of kLogChordUnit (the chord of edge e at u = 0).
  std::vector<std::int64_t> log_chord;
  /// #E: position of a boundary edge in topology.boundary_corners, kInvalid for interior edges.
  std::vector<Index> boundary_position;
  /// Flips applied since the triangulation was made.
  std::int64_t flips = 0;
  /// #E: the normal coordinates of the edges of the triangulation it was made from (the input;
  /// intrinsic_trace.h): how many times they cross edge e, −1 when e is one of them. Every flip
  /// keeps them; trace_input_edges() reads the input's edges off them. Empty: not kept.
  std::vector<std::int64_t> normal;

  /// log B_e as a double.
  double log_chord_of(Index e) const { return static_cast<double>(log_chord[e]) * kLogChordUnit; }
};

/// What make_intrinsic_triangulation() returns.
struct IntrinsicResult {
  /// Ok, InvalidArgument (sizes), DegenerateFace (an edge length not positive and finite, or in S
  /// not below π; element_index names the edge).
  Status status = Status::NotRun;
  std::string message = "not run";
  std::int64_t element_index = -1;  ///< the edge the error names, -1 otherwise
  IntrinsicTriangulation triangulation;
  std::int64_t delaunay_flips = 0;  ///< geometric flips to the intrinsic Delaunay triangulation
  Index delaunay_refused = 0;       ///< non-Delaunay edges left there (flip refused, see can_flip())
  Mollification mollification;      ///< mesh_intrinsic_triangulation(): of the 3D lengths
};

/// The triangulation of `topology` with the metric of edge lengths l (#E) in `geometry`, keeping
/// normal coordinates (all −1 at the start: every edge is an input edge); with `delaunay`, flipped by FlipRule::Geometric to the intrinsic Delaunay triangulation of that
/// metric (the same surface; where the flow's conformal class is read from), its `flips` reset to 0;
/// flips that would make a boundary vertex an ear are refused (DelaunayOptions::keep_boundary_fans).
IntrinsicResult make_intrinsic_triangulation(const Topology& topology, Geometry geometry, std::span<const double> l,
                                             bool delaunay = true);

/// The intrinsic Delaunay triangulation of a mesh's own metric for a vertex-scaling solve in
/// `geometry`: the 3D edge lengths, in E times unit_power_of_two() of the longest (as they are
/// unless that is shorter than 2^-100 or longer than 2^100); in H scaled as initial_metric() does
/// (total area 2π|χ|); in S scaled so that, read as spherical arcs, their triangles have total
/// area 4π (by regula falsi; where the spherical triangle inequality ends that
/// first, 0.9 of the largest admissible scale). Reading them at euclidean area 4π instead breaks the
/// spherical triangle inequality on coarse meshes (a tetrahedron) and starts far from the round
/// sphere's scale. Statuses as make_intrinsic_triangulation().
/// The 3D lengths are mollified first (mollify_lengths() with mollify_margin; 0: not at all), as
/// initial_metric() does.
IntrinsicResult mesh_intrinsic_triangulation(const Mesh& mesh, const Topology& topology, Geometry geometry,
                                             double mollify_margin = kMollifyMargin);

/// ConformalStructure of the Yamabe scheme (metric.h) for the current triangulation: η_e = B_e²/2.
/// Overwrites `structure` (its eta is resized to #E). False when some chord is beyond double range
/// (B_e² > e^709: its η is then +∞).
bool vertex_scaling_structure(const IntrinsicTriangulation& triangulation, ConformalStructure& structure);
/// η of edge e as vertex_scaling_structure() sets it (+∞ beyond double range), for updating a
/// structure after flips changed a few edges.
double vertex_scaling_eta(const IntrinsicTriangulation& triangulation, Index e);

/// Why an edge cannot be flipped (FlipCheck::Ok when it can).
enum class FlipCheck : int { Ok = 0, Boundary, SameFace };

/// Whether flip_edge(e) is allowed: e is interior and its two sides lie in two different faces.
/// O(1).
FlipCheck can_flip(const IntrinsicTriangulation& triangulation, Index e);

/// One flip as FlipJournal keeps it: the edge, its two corners and the corners across the two
/// sides the flip regroups (jk and il, from next(c0) and next(c1)) before it, its log-chord and
/// normal coordinate before it. The rest of what the flip wrote follows from these.
struct FlipRecord {
  Index edge = kInvalid, c0 = kInvalid, c1 = kInvalid, across_jk = kInvalid, across_il = kInvalid;
  std::int64_t log_chord = 0, normal = 0;
};

/// The flips made since some state of a triangulation, to put it back bit for bit (undo_flips())
/// instead of keeping a copy of it: 40 bytes per flip against about 108 bytes per face for a copy.
/// The flip functions below record into one when given it.
struct FlipJournal {
  std::vector<FlipRecord> records;  ///< oldest first

  /// Flips recorded.
  std::int64_t flips() const { return static_cast<std::int64_t>(records.size()); }
  /// Forgets the recorded flips (they stay applied); frees the buffer when it has grown past
  /// `keep_bytes`.
  void clear(std::size_t keep_bytes = std::size_t{1} << 20);
};

/// Undoes the flips of `journal` after its first `keep` (newest first), restoring every entry they
/// wrote and the flip count, then refreshes vertex_corners when any was undone; the journal keeps
/// its first `keep`. The triangulation is then bit for bit what it was after those `keep` flips,
/// vertex_corners included. O(undone flips + #F when any).
void undo_flips(IntrinsicTriangulation& triangulation, FlipJournal& journal, std::int64_t keep = 0);

/// Flips edge e (precondition: can_flip() is Ok) by Ptolemy's relation, in place, recording into
/// `journal` when given. Leaves topology.vertex_corners stale (see refresh_vertex_corners()). O(1).
void flip_edge(IntrinsicTriangulation& triangulation, Index e, FlipJournal* journal = nullptr);
/// Flips edge e (precondition: can_flip() is Ok) to the other diagonal of its quadrilateral in
/// the metric at u (FlipRule::Geometric), recording into `journal` when given. False, with nothing
/// changed or recorded, when a triangle of the quadrilateral violates the triangle inequality or
/// the quadrilateral is not convex at the ends of e. O(1).
bool flip_edge_geometric(IntrinsicTriangulation& triangulation, std::span<const double> u, Index e,
                         FlipJournal* journal = nullptr);

/// Q_e of the Delaunay test at u (#V), scaled by the largest chord of the two triangles to the
/// fourth power (so it lies in [−4, 4]); +∞ for a boundary edge. Edge e is Delaunay when Q_e ≥ 0.
double delaunay_margin(const IntrinsicTriangulation& triangulation, std::span<const double> u, Index e);

/// How make_delaunay() sets the new edge of a flip.
enum class FlipRule : int {
  /// Ptolemy's relation (above): keeps the discrete conformal class; what the flow uses.
  Ptolemy = 0,
  /// The other diagonal of the quadrilateral laid out in the background geometry (at the given
  /// u): keeps the metric itself (the piecewise E/H/S surface). For a metric given by lengths
  /// before a solve: its intrinsic Delaunay triangulation is where its vertex-scaling class is
  /// read from (Bobenko–Pinkall–Springborn 2015), so that a metric already in that class (a flat
  /// disk, say) stays where it is. Needs triangles that satisfy the triangle inequality.
  Geometric,
};

struct DelaunayOptions {
  FlipRule rule = FlipRule::Ptolemy;
  /// An edge is flipped only when its margin is below −tolerance (cocircular quadrilaterals are
  /// left alone, so no flip sequence can cycle on rounding).
  double tolerance = 1e-12;
  /// Stop after this many flips (0: 100 · #E + 1000). Edge flipping to Delaunay terminates in exact
  /// arithmetic; this bounds the work on rounding.
  std::int64_t max_flips = 0;
  /// Refuse a flip that would leave a boundary vertex in a single face (an ear: its angle is
  /// below π, which circle and geodesic targets on inner loops cannot have). Such edges are
  /// counted in DelaunayReport::refused.
  bool keep_boundary_fans = false;
};

/// What make_delaunay() did.
struct DelaunayReport {
  std::int64_t flips = 0;    ///< flips applied
  Index refused = 0;         ///< non-Delaunay edges left because the flip was refused (can_flip)
  bool complete = true;      ///< false when max_flips stopped it
};

/// Flips non-Delaunay interior edges at u (#V) until none is left (a FIFO of suspect edges, first in
/// index order: deterministic), then refreshes vertex_corners. O(#E + flips).
DelaunayReport make_delaunay(IntrinsicTriangulation& triangulation, std::span<const double> u,
                             const DelaunayOptions& options = {});

/// The interior edges whose Delaunay margin at u (#V) is below −tolerance, in index order — what
/// make_delaunay() would start from. Chords from e^{u/2} per vertex and B per edge (#V + #E
/// exponentials instead of five per edge; the quadrilaterals whose chords leave [1e-100, 1e100]
/// take delaunay_margin() itself). Parallel over edges, deterministic. O(#E).
std::vector<Index> non_delaunay_edges(const IntrinsicTriangulation& triangulation, std::span<const double> u,
                                      double tolerance = DelaunayOptions{}.tolerance);

/// make_delaunay() when every non-Delaunay edge at u is among `suspects` (non_delaunay_edges(),
/// say): they seed the queue in their order instead of a first test of every edge.
DelaunayReport make_delaunay(IntrinsicTriangulation& triangulation, std::span<const double> u,
                             std::span<const Index> suspects, const DelaunayOptions& options = {});
/// The same, recording its flips into `journal` (undo_flips() takes them back).
DelaunayReport make_delaunay(IntrinsicTriangulation& triangulation, std::span<const double> u,
                             std::span<const Index> suspects, const DelaunayOptions& options, FlipJournal* journal);

/// Recomputes topology.vertex_corners (and offsets) from corner_vertex and opposite, in the order
/// build_topology() gives. O(#F).
void refresh_vertex_corners(Topology& topology);

}  // namespace ricci
