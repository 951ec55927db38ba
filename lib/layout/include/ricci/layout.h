// ricci — layouts: a discrete metric (edge lengths) turned into positions in the plane (E), the
// Poincaré disk (H) or on the unit sphere (S); the metric carried to a refined (cut) surface; and
// the comparison of two layouts up to the isometries of their geometry.
//
//   RefinedMetric rm = refined_edge_lengths(cut, topology, g, flow.l);   // lengths on the refined surface
//   TopologyResult disk = build_topology(cut.cut_faces, cut.num_cut_vertices());
//   std::vector<double> ld = disk_edge_lengths(cut, rm.surface, rm.l, disk.topology);
//   Layout lay = layout_disk(disk.topology, g, ld);            // E, H (or S) — a disk
//   Layout sph = layout_sphere(topology, flow.l);               // S — a closed genus-0 surface
//   LayoutAlignment a = align_layouts(g, lay.positions, other.positions);
//
// Positions (Layout::positions, #V×dims, row-major):
//   E  dims 2  the plane
//   H  dims 2  the Poincaré disk |z| < 1 (curvature −1); geodesics are arcs orthogonal to |z| = 1
//   S  dims 3  unit vectors (the unit sphere, curvature +1)
//
// Propagation (the paper's Section 5 Step 4). The seed face is placed first (corner 0 at the
// origin / north pole, its edge to corner 1 along +x), then faces are taken cheapest-first over the
// dual graph (Dijkstra's costs in linear time by Dial's buckets; each face costs 1 − log sin of
// its smallest angle in E and S, so slivers
// are entered last, and 1 in H, which makes it breadth-first): every face reached across an edge
// of a face already taken gets its third vertex placed, when that vertex has no position yet:
//   E  by the face's orientation, carried along the faces taken: the direction of each face's
//      side 0 → 1 (a unit complex number) is its parent's turned by the two faces' angles alone,
//      and the vertex is its edge's first end plus the edge length times that direction turned by
//      the corner's angle. Positions never feed back into directions, so the error grows only as
//      the turns' rounding adds up (placing from the measured directions of placed neighbours
//      instead turns every later face by their misplacement: geometric growth with the depth);
//   H  as an intersection of the two geodesic circles about the edge's placed ends (radii: the
//      face's two other edge lengths; on the left of the edge, since faces are counter-clockwise),
//      in closed form: a Möbius map z ↦ (z − p)/(1 − p̄ z) moves the first end p to 0, a rotation
//      puts the second end on the positive real axis; there the circle about 0 of radius r is the
//      euclidean circle |z| = tanh(r/2) and the point on it at the angle of the hyperbolic
//      half-angle formula (Möbius maps are conformal) is the intersection; the inverse maps take
//      it back;
//   S  directly on the unit sphere: the point at great-circle distance r from P in the tangent
//      direction turned by the spherical angle from the direction towards Q.
// Positions are double-double (about 106 bits) while the faces are developed: each vertex is its
// edge's first end plus an offset, and differences of placed neighbours keep the digits that
// double coordinates far from the origin would round away; the layout returns them rounded.
// The default seed is a central face: the face minimising max(d(f, a), d(f, b)) for the two ends
// a, b of a double-sweep breadth-first diameter of the dual graph (a cheap approximation of the
// face of least eccentricity), so the propagation depth — along which rounding and the metric's
// residual curvature accumulate — is about half the dual diameter.
//
// Errors. max_edge_length_error is max over edges |d(x_i, x_j) − l_ij| / l_ij with d the distance
// of the geometry (euclidean; hyperbolic 2 asinh(|z−w| / √((1−|z|²)(1−|w|²))); great circle
// atan2(|x×y|, x·y)). A flipped face is one whose geodesic triangle is negatively oriented:
// E: signed area < 0; H: signed area of the triangle in Klein coordinates 2z/(1+|z|²) (where
// geodesics are straight) < 0; S: det(x_i, x_j, x_k) < 0.
//
// Normalisation (LayoutOptions::normalize):
//   E  the rigid motion of the propagation: seed corner 0 at the origin, seed edge 0→1 on +x;
//      with unit_box, then a translation and uniform scale putting the bounding box in [0,1]²
//      with its lower-left corner at the origin (Layout::scale holds the factor; the edge-length
//      error is measured before scaling, relative errors do not depend on it).
//   H  the hyperboloid centre of mass moved to 0: with X_i the hyperboloid points of the vertices
//      and w_i their areas (a third of the incident faces' hyperbolic areas), C = Σ w_i X_i is
//      normalised to the hyperboloid and the disk automorphism taking it to 0 is applied (Lorentz
//      maps are linear, so afterwards Σ w_i X_i points at the origin exactly); then the rotation
//      putting the seed face's corner-0 vertex on the positive real axis (corner 1 if corner 0 is
//      at 0). An isometry: lengths are unchanged. Then the propagation runs a second time in this
//      final frame, from the seed face's normalised position, and the map is re-fitted; repeated
//      (at most 4 times) until the fitted map moves the centre by less than 1e-6: Poincaré
//      coordinates resolve hyperbolic distance only to ~2^-52 / (1 − |z|²), so no vertex should
//      be computed farther out than it ends up.
//   S  Möbius centring (Baden, Crane, Kazhdan 2018, "Möbius registration"): with fixed weights
//      w_i (vertex areas of the metric), Newton iterations c = −J⁻¹ μ on the centre of mass
//      μ = Σ w_i x_i / Σ w_i, J = 2 Σ w_i (I − x_i x_iᵀ) / Σ w_i, each applying the Möbius map
//      x ↦ (1 − |c|²)(x + c)/|x + c|² + c (|c| capped at 0.5), until |μ| < 1e-14 or 100 steps;
//      then the rotation putting the seed's corner-0 vertex at +z and corner 1 in the half-plane
//      y = 0, x > 0. Möbius maps are conformal, NOT isometries: the centred positions no longer
//      have the metric's edge lengths. max_edge_length_error is measured on the isometric layout
//      before centring, and mobius_length_change reports the largest relative change of an edge's
//      great-circle length made by the centring. Set sphere_mobius = false for the isometric
//      layout (only the rotation is applied).
#pragma once

#include <complex>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ricci/cut.h"
#include "ricci/deck.h"
#include "ricci/face_frames.h"
#include "ricci/metric.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

// ---------------------------------------------------------------------------------------------
// The metric on the refined surface of a cut.

/// What refined_edge_lengths() returns.
struct RefinedMetric {
  /// Ok; InvalidArgument (cut not Ok, sizes, records inconsistent with `input`);
  /// DegenerateFace (a length not a positive finite number: element Edge); TriangleInequality
  /// (an input face that holds added vertices violates it: element Face); NumericalFailure (an
  /// added vertex's record names vertices that are not corners of a face it lies in).
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong; on success the number of edges copied and computed
  Element element = Element::None;  ///< Edge (input edge) or Face (input face) the error names, else None
  std::int64_t element_index = -1;  ///< index of that edge or face; -1 when element is None
  /// build_topology(cut.surface_faces, cut.num_input_vertices + cut.num_refined_vertices()).
  Topology surface;
  /// #E': the length of every edge of `surface`, in the geometry given.
  std::vector<double> l;
  Index edges_copied = 0;    ///< edges of the input, copied bit for bit
  Index edges_computed = 0;  ///< sub-edges measured inside an input face
};

/// Exact edge lengths on the refined surface of a cut (cut.h) for a metric given by its lengths
/// on the input mesh (`input_lengths`, #E of `input`, in background geometry `g`).
///
/// An edge of the refined surface that is an edge of the input keeps its length bit for bit.
/// Every other edge lies inside one input face O (the face of one of its refined faces); O is laid
/// out in its geometry, corner 0 at the base point, corner 1 along the first axis:
///   E  the plane: P_k ∈ R²; a point with barycentric coordinates β is Σ β_k P_k;
///   H  the hyperboloid {t² − x² − y² = 1, t > 0}: X_k; the point is Σ β_k X_k rescaled onto the
///      hyperboloid, i.e. the affine combination Σ β_k t_k K_k / Σ β_k t_k of the corners' Klein
///      coordinates K_k = (x_k, y_k)/t_k (affine in the Klein chart with weights β_k t_k);
///   S  the unit sphere: X_k; the point is Σ β_k X_k / |Σ β_k X_k|, i.e. the affine combination
///      with weights β_k z_k of the corners in the gnomonic chart centred at the north pole
///      (corner 0), K_k = (x_k, y_k)/z_k.
/// Linear maps of the hyperboloid / sphere are exactly the isometries, so this rule does not depend
/// on where O is placed. Points lie inside the geodesic triangle (its cone over the corners is
/// convex), sub-edges are geodesics inside the face; a point with β_k = 0 lies on the opposite
/// edge and only that edge's ends enter, so both faces of a split edge agree, and β = (½, ½, 0)
/// is the geodesic midpoint. Sub-edge lengths: euclidean distance; H 2 asinh(½ √⟨X−Y, X−Y⟩);
/// S atan2(|X×Y|, X·Y). Added vertices recorded on a neighbouring input face (edge points) are
/// re-expressed through the shared corners.
RefinedMetric refined_edge_lengths(const CutResult& cut, const Topology& input, Geometry g,
                                   std::span<const double> input_lengths);

/// Lengths per edge of the cut disk (build_topology(cut.cut_faces, cut.num_cut_vertices())):
/// the length of the surface edge in the same face slot (corner c of cut_faces ↔ corner c of
/// surface_faces). `surface` is RefinedMetric::surface, `surface_lengths` its lengths. Empty on a
/// size mismatch.
std::vector<double> disk_edge_lengths(const CutResult& cut, const Topology& surface,
                                      std::span<const double> surface_lengths, const Topology& disk);

// ---------------------------------------------------------------------------------------------
// Layouts.

// FaceFrames (face_frames.h): where each face lies in a coarser triangulation.

/// The triangles' shapes a layout reads from its lengths (Layout::shapes): every corner's angle
/// (#F×3, as corner_angles() gives them) and, in H and S, every face's area (#F; zeros in E).
struct LayoutShapes {
  std::vector<double> corner_angles;
  std::vector<double> face_areas;
};

/// Options of layout_disk() and layout_sphere().
struct LayoutOptions {
  /// Seed face; -1 picks a central face (see the top of this header).
  Index seed_face = -1;
  /// Apply the normalisation of the geometry (see the top of this header).
  bool normalize = true;
  /// E only: scale and translate the layout into the unit box [0,1]² after normalising.
  bool unit_box = false;
  /// S only: with normalize, Möbius-centre the sphere layout (not an isometry); false: rotation only.
  bool sphere_mobius = true;
  /// The refinement after the propagation (patches, shape solve, sweeps, global steps below) runs
  /// only while the layout's relative edge-length error exceeds the edges' rounding floor
  /// (Layout::max_error_above_rounding) by more than this. One E propagation reproduces a
  /// converged metric to about 1e-11 on 50k–425k faces (tools/BENCHMARK-pipeline.md); H and S
  /// propagations leave the residual curvature of the metric's double-precision lengths where
  /// their front closes on itself (one seam of edges), 1e-10–1e-9 on 100k–330k faces; below this
  /// threshold one pass over the faces is the layout. 0: refine every layout down to its rounding
  /// floor.
  double refine_above = 1e-10;
  /// E, H and S: sweeps of nonlinear Gauss–Seidel — each vertex in turn takes a Gauss–Newton step
  /// on Σ ((d(x, x_j) − l_j)/l_j)² over its edges (H: in the Poincaré disk; S: in its tangent
  /// plane, then back onto the sphere). The sweeps spread the seam's error over its
  /// neighbourhood, which matters on large meshes (tools/sweep_uniformize --polish-sweeps
  /// compares; on the shared nefertiti's subdivision, 1.7e-7 → 4.4e-9). They run in rounds of 1,
  /// 2, 4, … sweeps, each only while the layout is still above refine_above (or the last round
  /// halved its error), each over the vertices within two edges of an edge whose error (above its
  /// rounding floor, or in all) is above a quarter of the largest, until such a round lowers the
  /// largest error above the floor by less than a quarter or raises the largest error, then over
  /// every vertex; this is the most in all (Layout::polish_sweeps: how many ran). The vertices of
  /// one sweep are taken colour class by colour class (no two of a class share an edge), each
  /// class in parallel: the same result on any number of threads. 0: none.
  int polish_sweeps = 30;
  /// E, H and S: then, while still above refine_above, up to this many
  /// Gauss–Newton steps on all positions at once (min Σ ((d_ij − l_ij)/l_ij)², one sparse Cholesky
  /// factorization reused by every step; a step is kept only when it lowers the max error, and
  /// the steps only when they lower the max error above the rounding floor). The sweeps reduce
  /// short-range error; these remove the long-range drift that the propagation accumulates over
  /// hundreds of faces. In E, a propagation that misses its metric by more than 1e-8 (needle
  /// triangles placed from short bases grow an error geometrically along a chain) is first
  /// replaced by the layout from the triangles' shapes alone — z_k − z_i = (l_ik/l_ij) e^{iθ_i}
  /// (z_j − z_i) per corner, one sparse linear least-squares solve — when that is closer
  /// (Layout::shape_solve). 0: none of this.
  int polish_steps = 3;
  /// E, H and S: divide and conquer (paper §6.1 item 5). 0 or 1: one propagation over the whole
  /// disk. k ≥ 2: the faces are split into k patches grown breadth-first from farthest-point seeds
  /// over the dual graph, each patch is laid out by its own propagation (in parallel), and the
  /// patches' isometries into one frame are fitted jointly with Ceres over every vertex two patches
  /// share (each vertex then sits at the mean of its copies) (Layout::patches says whether the
  /// result was kept). S likewise, with rotations as the isometries. -1 (default): automatic — min(32, #F /
  /// 4000) patches (none below 8000 faces) and one per 10k faces above 320k faces (at most 256),
  /// and only when the layout is still above refine_above after up to 7 sweeps near its largest
  /// errors (the first rounds of polish_sweeps, counted there; where the propagation misses only
  /// along a few seams they reach it for a fraction of the patches' cost). The result is kept only
  /// when neither its max error nor its max error above rounding (Layout::max_error_above_rounding)
  /// exceeds that of the positions it starts from. k ≥ 2 always tries them, on the
  /// propagation itself. At most 256.
  int patches = -1;
  /// A vertex whose position leaves the range of double precision (E: not finite; H: at or
  /// beyond the unit circle) fails the layout
  /// (NumericalFailure) by default. true: it is put on the first end of the edge it was placed
  /// from and counted (Layout::unresolved_vertices), so the layout completes with those faces
  /// missed, for layout_atlas() to lay them out in charts of their own. Such a layout is not
  /// refined (patches, sweeps, global steps): their positions are no estimate to improve.
  bool keep_unresolved = false;
  /// Develop the coarse faces these frames name instead of the faces (FaceFrames; the common
  /// subdivision's, as uniformize() passes them). The refinement below applies as to any layout.
  /// Null (default): develop the faces. Sizes that do not match the mesh are refused
  /// (InvalidArgument).
  std::shared_ptr<const FaceFrames> frames;
  /// The shapes of a layout of the same mesh with the same lengths and geometry (Layout::shapes
  /// of an earlier call): read instead of computed again, as a second layout from another seed
  /// does (uniformize()'s seed check). The caller vouches that the lengths are the same; shapes
  /// whose sizes do not match the mesh are not used. Null (default): computed from the lengths.
  std::shared_ptr<const LayoutShapes> shapes;

  /// True when seed_face ≥ -1, refine_above is finite and ≥ 0, polish_sweeps is in 0..10000 and
  /// polish_steps in 0..20; otherwise false, with the reason
  /// in *why (when why is not null). A seed face beyond the mesh is refused by the layout call.
  bool is_valid(std::string* why) const;
};

/// Positions of a layout and its figures; returned by layout_disk(), layout_sphere() and
/// measure_layout().
struct Layout {
  /// Ok: positions are valid (flips are reported, not an error). InvalidArgument: sizes, options,
  /// or a mesh that is not a disk (layout_disk) / not a closed genus-0 surface (layout_sphere);
  /// DegenerateFace: a length is not a positive finite number (element Edge); TriangleInequality:
  /// a face violates it by more than 4 units in the last place of its longest side (or, in S, has
  /// perimeter ≥ 2π) (element Face; a face flat to that rounding is laid out flat); NumericalFailure: a placed
  /// vertex left the range of double precision (element Vertex). Otherwise positions empty.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong, naming the element; on success a summary
  Element element = Element::None;  ///< Edge, Face or Vertex named by the error; None otherwise
  std::int64_t element_index = -1;  ///< index of that element; -1 when element is None

  Geometry geometry = Geometry::Euclidean;  ///< geometry of the positions
  int dims = 0;                   ///< 2 (E, H) or 3 (S)
  std::vector<double> positions;  ///< #V×dims (see the top of this header)
  Index seed_face = -1;           ///< the seed face used
  Index depth = 0;                ///< the most faces between the seed and a face along the propagation

  /// Max over edges of |d(x_i, x_j) − l_ij| / l_ij (S with Möbius centring: before centring).
  double max_edge_length_error = 0;
  Index worst_edge = kInvalid;  ///< the edge where max_edge_length_error occurs
  /// Max over edges of the relative length change that rounding the two ends' coordinates to
  /// double could cause alone (E: 2^-53·√2·(|x_i| + |x_j|) / l_ij; H: 2^-52·√2·Σ 1/(1 − |z|²) / l_ij,
  /// the Poincaré metric's growth; S: 2^-52·√3 / l_ij). No layout stored in these coordinates can be
  /// more accurate; H layouts that reach far from the origin (long, thin cut polygons) or have very
  /// short edges there are limited by it.
  double rounding_floor = 0;
  /// Max over edges of the relative error minus that edge's own rounding floor (≤ 0 when every
  /// edge is as accurate as its coordinates allow): the part of the error a better layout of the
  /// same coordinates could remove.
  double max_error_above_rounding = 0;
  /// Faces whose geodesic triangle is negatively oriented in the final positions.
  Index flipped_faces = 0;
  Index first_flipped_face = kInvalid;  ///< smallest flipped face; kInvalid when there is none
  /// Vertices used by no face (placed at the origin / north pole).
  Index unplaced_vertices = 0;
  /// With LayoutOptions::keep_unresolved: vertices whose position left double range, put on a
  /// neighbour instead (in the last propagation).
  Index unresolved_vertices = 0;

  double scale = 1;                  ///< E with unit_box: the factor applied
  double mobius_length_change = 0;   ///< S with Möbius centring: max relative change of an edge
  double centre_of_mass = 0;         ///< S: |μ| after normalising; H: |z| of the centre of mass
  int normalization_iterations = 0;  ///< S: Möbius centring steps
  /// H with normalize: normalising disk maps applied (until the frame moves < 1e-6): to the
  /// propagation's double-double positions, or by frames the development run again in the map.
  int propagation_passes = 0;
  /// Gauss–Seidel sweeps kept (LayoutOptions::polish_sweeps; a round that raises the max error, or the
  /// max error above rounding, is undone).
  int polish_sweeps = 0;
  /// E, H and S: global Gauss–Newton steps kept (LayoutOptions::polish_steps).
  int polish_steps = 0;
  /// The positions come from the development by coarse frames (LayoutOptions::frames).
  bool by_frames = false;
  /// E: the propagation missed the metric by more than 1e-8 and the layout from the triangles'
  /// shapes (one sparse least-squares solve; see LayoutOptions::polish_steps) was closer and kept.
  bool shape_solve = false;
  /// Divide and conquer: patches used (0: off, or not kept), Ceres iterations of the joint fit,
  /// and the largest distance between two fitted copies of a shared vertex relative to its mean
  /// edge length.
  int patches = 0;
  int patch_fit_iterations = 0;   ///< Ceres iterations of the joint patch fit
  double patch_seam_error = 0;    ///< largest spread of a shared vertex's copies / its mean edge length
  double seconds = 0;  ///< wall-clock time of layout_disk() / layout_sphere(); 0 on failure and for measure_layout()
  /// The corner angles and face areas this layout read (LayoutOptions::shapes, for another layout
  /// of the same lengths); null on failure and for measure_layout().
  std::shared_ptr<const LayoutShapes> shapes;

  /// One line: status, geometry, seed, edge error, flips, time.
  std::string brief_report() const;
};

/// Lays out a topological disk (connected, one boundary loop, χ = 1; e.g. the cut disk with
/// disk_edge_lengths()) in geometry g (E: plane, H: Poincaré disk, S: unit sphere) from edge
/// lengths `l` (#E). Deterministic; linear time.
Layout layout_disk(const Topology& disk, Geometry g, std::span<const double> l, const LayoutOptions& options = {});

/// Lays out a closed genus-0 surface (connected, χ = 2, no boundary) with a spherical metric `l`
/// (#E) on the unit sphere — no cut is needed: the last faces close up by themselves.
Layout layout_sphere(const Topology& surface, std::span<const double> l, const LayoutOptions& options = {});

/// The face farthest from face `seed` in steps across edges (breadth-first over the dual graph; the
/// smallest index among the farthest). `seed` itself when it is the only face reached.
Index farthest_face(const Topology& t, Index seed);

/// The seed layout_disk() and layout_sphere() take when LayoutOptions::seed_face is -1: the
/// central face of the double-sweep diameter (see the top of this header). kInvalid without faces.
Index central_face(const Topology& t);

/// An edge of a layout may miss its length by up to this many times its rounding floor (Layout::
/// rounding_floor) and still count as reproduced as well as its coordinates allow.
inline constexpr double kRoundingAllowance = 8;

/// The edges of a layout whose relative length error exceeds a limit, and where they are.
struct LayoutMisses {
  Index edges = 0;  ///< edges above the limit
  /// Max over those edges of the error minus kRoundingAllowance times the edge's own rounding
  /// floor: ≤ 0 when each is within what its coordinates resolve, > 0 (or NaN) when a better
  /// layout of the same coordinates would reproduce it.
  double worst_unexplained = 0;
  /// The weight (face_area) of the faces on those edges over the total: 0 when there are none.
  double area_fraction = 0;
};

/// Which edges of positions (#V×dims of `disk`, in geometry g) miss their lengths l (#E) by more
/// than `limit` (relative), weighed by face_area (#F, e.g. the faces' areas in the input's 3D
/// coordinates). On a size mismatch, an empty result.
LayoutMisses layout_misses(const Topology& disk, Geometry g, std::span<const double> l,
                           std::span<const double> positions, std::span<const double> face_area, double limit);

/// Per vertex of `disk` (#V): 1 when every edge at it reproduces its length l (#E) to `limit`
/// (relative) in positions (#V×dims, geometry g), else 0. On a size mismatch, all 0.
std::vector<std::uint8_t> resolved_vertices(const Topology& disk, Geometry g, std::span<const double> l,
                                            std::span<const double> positions, double limit);

/// The figures of a Layout (max_edge_length_error, worst_edge, rounding_floor, flipped_faces)
/// for positions computed elsewhere (e.g. deck_through_domain()'s canonical polygon): `l` #E of
/// `disk`, positions #V×dims. Status NonFiniteCoordinate names a vertex without a valid position.
Layout measure_layout(const Topology& disk, Geometry g, std::span<const double> l, std::span<const double> positions);

// ---------------------------------------------------------------------------------------------
// An atlas of charts: a layout of every face to full precision where one chart cannot hold them.
//
// A conformal factor that spans many orders of magnitude (a long finger of a hyperbolic surface
// shrinks about e^{-π/2} per width along it) leaves faces far smaller than what one chart's
// double coordinates resolve where they lie: Poincaré coordinates resolve hyperbolic distance to
// about 2^-52 / (1 − |z|²), plane coordinates to 2^-53·|z|. Near a chart's own origin they resolve
// relative to the distance from it, so a finger laid out from its smallest face (its tip) keeps
// every digit: its faces grow with their distance from the tip.
//
// layout_atlas() starts from a layout (chart 0, the root: its positions as given) and repeats,
// chart by chart in the order they are made: each face of a chart that misses an edge length by
// more than AtlasOptions::limit starts a group, which takes every face connected to it across
// edges that misses the limit too or whose coordinates resolve it to less than 1e-2 × the limit
// (so that the collar below lies where the parent is good to well below the limit; with coarse
// frames, a needle resolved to within 64 times its coarse face's rounding counts as resolved, and
// as collar where that places it to 1e-2 × the limit of its coarse face's shortest side);
// each group becomes a new chart, laid out by propagation from its smallest face (least longest
// edge; placed as layout_disk()'s seed: corner 0 at the origin, corner 1 along +x) together with
// a collar of the parent's resolved faces around it (collar_rings rings across edges). The parent
// is the group's chart, or, where that chart resolves no face around the group (a nested group at
// its rim), the chart holding most of the group's neighbours that has a collar there. The
// transition map into the parent is the isometry fitted on the collar's vertices (align_layouts():
// closed form, every point); the group's faces then belong to the new chart, the collar's stay in
// the parent. With coarse frames in H, a chart's floor at a face also counts the drift of the
// SU(1,1) maps that placed its corners (each product at distance r from the chart's origin adds
// about ε·e^r, in quadrature along the development), and a development kept for an atlas leaves
// a face whose map drifted beyond 1e-6 of its coarse face's shortest side unresolved (its corners
// would resolve in double yet sit off the faces developed along other paths, so no collar could
// hold both); H chart developments keep going past vertices they cannot resolve, whose faces
// then go to nested charts. A chart whose own collar points its coordinates and maps do not
// resolve to 1e-2 of max_transition_error (seeded at the smallest face of a long thin group, far
// from the collar) is laid out again from the smallest group face across an edge from the
// collar; in H, where that chart still holds its collar more than 4 units from its origin (a long
// strip of needles, the collar running all along it), the group is cut instead into pieces
// reaching about 2 units each, made from the group's rim inwards, each a chart of its own whose
// collar lies in the charts made before it. A face the new chart misses only by its floor where
// the face lies, 4 times above what a chart around it gives, starts a nested group, whose chart is
// seeded at the smallest such face — again only where its floor has fallen 4 times since; one
// that no chart would resolve that much better stays unresolvable. A group no chart has a collar
// for is tried again after the others; pieces still without one are taken whole again, and last
// any resolved face may be collar (the transition check still applies, a miss then meaning no
// collar); a group still without a collar stays where it is (its faces unresolvable). A face its
// own chart misses by more than max_transition_error and by more than 64 times its floor there, a
// transition map that misses its collar by more than max_transition_error, or charts nested
// deeper than max_depth end the atlas with NumericalFailure naming the face.
//
// The charts are consistent: a face's three edges always fit one chart, so what ties the charts to
// one metric is the collar, whose vertices both charts place; transition_error is the largest
// distance between a collar vertex's two positions after the fitted map, relative to the shortest
// collar edge at that vertex (with frames, to the shortest side of the coarse faces at it: both
// charts place all of a coarse face by its one isometry, so rounding moves it rigidly, at the
// coarse face's scale).
//
// Maps into the root chart compose the transition maps: H in 113-bit arithmetic (to_root +
// to_root_low, as DeckGenerator's map + map_low), E as rigid motions in double.

/// Options of layout_atlas().
struct AtlasOptions {
  /// A face is resolved by a chart when each of its edges misses its length by at most this
  /// (relative) in that chart's coordinates.
  double limit = 1e-9;
  /// Rings of the parent's faces around a new chart's group, laid out with it to fit the
  /// transition map.
  int collar_rings = 2;
  /// Charts nest at most this deep (the root: 0). A strip cut into pieces nests a chart per piece
  /// along it.
  int max_depth = 4096;
  /// A chart whose transition_error exceeds this ends the atlas (NumericalFailure): its collar
  /// does not lie where its parent's does, so the two charts are not layouts of one metric
  /// (each face always fits its own chart; only the collars tie the charts together).
  double max_transition_error = 1e-6;
  /// The disk's coarse frames (LayoutOptions::frames): new charts are developed by them. Null:
  /// through the faces.
  std::shared_ptr<const FaceFrames> frames;

  /// True when limit and max_transition_error are finite and > 0, collar_rings in 1..16 and
  /// max_depth in 1..65536; otherwise false, with the reason in *why (when why is not null).
  bool is_valid(std::string* why) const;
};

/// One chart of an atlas.
struct LayoutChart {
  Index parent = -1;           ///< the chart its transition map goes into; -1 for the root
  int depth = 0;               ///< 0 for the root, parent's + 1 otherwise
  Index seed_face = kInvalid;  ///< the face placed at its origin (the root: kInvalid, its positions were given)
  Index faces = 0;             ///< faces it holds (LayoutAtlas::face_chart)
  double max_edge_length_error = 0;  ///< over the edges of its faces, in its coordinates (relative)
  Index worst_face = kInvalid;       ///< a face where that occurs; kInvalid without faces
  double rounding_floor = 0;         ///< max over those edges of Layout::rounding_floor's measure (H with frames: plus the maps' drift)
  Index collar_vertices = 0;         ///< vertices the transition map was fitted on
  double transition_error = 0;       ///< see the top of this section (0 for the root)
  /// The map from this chart's coordinates into its parent's, and into the root chart's:
  ///   H  z ↦ (a z + b)/(b̄ z + ā) (Moebius); to_root + to_root_low, entry by entry, is the
  ///      composition along the parents to about 106 bits;
  ///   E  z ↦ e^{i angle} z + translation.
  Moebius to_parent, to_root;
  Moebius to_root_low{{0, 0}, {0, 0}};
  double angle_to_parent = 0, angle_to_root = 0;                        ///< E
  std::complex<double> translation_to_parent{0, 0}, translation_to_root{0, 0};  ///< E
};

/// What layout_atlas() returns.
struct LayoutAtlas {
  /// Ok: every face resolved within AtlasOptions::limit in its chart, but unresolvable_faces.
  /// InvalidArgument (sizes, options, S); NumericalFailure (a face its own chart misses beyond
  /// max_transition_error, a chart's collar missing its parent, charts too deep, a propagation
  /// leaving double range), naming the face or vertex.
  Status status = Status::NotRun;
  std::string message = "not run";
  Element element = Element::None;
  std::int64_t element_index = -1;

  std::vector<LayoutChart> charts;       ///< charts[0] is the root (the positions given)
  std::vector<Index> face_chart;         ///< #F: the chart holding each face
  /// #F×3×2: each face's corners in its chart's coordinates, corner c of face f at
  /// [6f + 2c, 6f + 2c + 1].
  std::vector<double> corner_positions;
  double max_edge_length_error = 0;  ///< max over the charts
  double max_transition_error = 0;   ///< max over the charts
  /// Faces above AtlasOptions::limit in the chart made for their own group, laid out from that
  /// group's smallest face: what no chart's coordinates resolve better (with coarse frames, a
  /// sliver of the common subdivision far smaller than its coarse face, whose corners that face's
  /// isometry places to its own scale's rounding). A face that chart misses only by its own
  /// floor where the face lies, 4 times above what a chart around the face would give (far
  /// from the group's smallest face), starts a nested chart instead. Unresolvable faces start no
  /// further chart; their worst error is unresolvable_error (within max_edge_length_error).
  Index unresolvable_faces = 0;
  double unresolvable_error = 0;
  /// With coarse frames: the unresolvable faces whose error is within 64 times the rounding of
  /// their coarse face relative to their shortest edge (2^-53 × its longest side / that edge),
  /// ascending — needles of the common subdivision that every chart places by their coarse face's
  /// isometry; their error above max_transition_error in the chart made for them is not taken for
  /// lengths that are not one metric. max_resolved_error: the max edge error over the other faces.
  std::vector<Index> frame_rounding_faces;
  double max_resolved_error = 0;
  /// Faces negatively oriented in their chart (H: in Klein coordinates), and the smallest; the
  /// frame_rounding_faces are not counted: placed only to about their own size (an edge 3.8e-16
  /// of a coarse face 0.12 across, to 3.5 % of its length), their orientation is rounding's.
  Index flipped_faces = 0;
  Index first_flipped_face = kInvalid;
  double seconds = 0;

  Index num_charts() const { return static_cast<Index>(charts.size()); }
};

/// An atlas of `disk` (E or H) with edge lengths l (#E) from the layout `positions` (#V×2; the
/// root chart): see the top of this section. With every face resolved by `positions`, one chart.
LayoutAtlas layout_atlas(const Topology& disk, Geometry g, std::span<const double> l,
                         std::span<const double> positions, const AtlasOptions& options = {});

/// A point of chart `from`'s coordinates in chart `to`'s (E: the rigid motions to the root; H: the
/// maps to the root composed in quad). NaN for a chart that does not exist.
std::complex<double> chart_to_chart(const LayoutAtlas& atlas, Geometry g, Index from, Index to, std::complex<double> z);

/// The cut's surface (cut.surface_positions, cut.surface_faces) with texture coordinates from an
/// atlas of its disk (the disk's faces are the cut's faces, slot for slot): one texture coordinate
/// per cut vertex and chart it appears in, numbered in the order of first use, each corner taking
/// the one of its face's chart. An empty mesh when the atlas is not Ok or the sizes differ.
Mesh surface_with_atlas_uvs(const CutResult& cut, const LayoutAtlas& atlas);

// ---------------------------------------------------------------------------------------------
// Comparing layouts.

/// What align_layouts() returns: the fitted isometry and the deviation left after it.
struct LayoutAlignment {
  /// Ok; InvalidArgument (sizes differ or do not match the geometry's dims, no points, a point
  /// outside the disk in H or not a unit vector in S).
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong; on success "aligned N points"
  /// Max / root-mean-square distance (of the geometry) between a_i and M(b_i) after alignment.
  double max_deviation = 0;  ///< max_i d(a_i, M(b_i))
  double rms_deviation = 0;  ///< √(mean_i d(a_i, M(b_i))²)
  /// The fitted map M taking b onto a:
  ///   E  x ↦ R(angle) x + t  (translation = t, angle)
  ///   H  z ↦ e^{i angle} (z − z0) / (1 − z̄0 z)  (z0 = translation)
  ///   S  x ↦ R x (rotation, 3×3 row-major)
  double angle = 0;                                  ///< E, H: rotation angle in radians
  double translation[2] = {0, 0};                    ///< E: t; H: z0 (real, imaginary part)
  double rotation[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< S: R, 3×3 row-major
};

/// Fits the isometry of geometry g that takes layout b onto layout a (same vertices, #V×dims
/// each) and measures what is left. E: orientation-preserving Procrustes in closed form (centroids
/// and the angle atan2(Σ b'×a', Σ b'·a')). S: Kabsch (SVD of Σ b_i a_iᵀ, determinant fixed to +1).
/// H: both point sets moved by the disk automorphisms taking their hyperboloid centroids Σ X_i to
/// 0, then the rotation about 0 by the Procrustes angle of the moved points. This closed form uses
/// every point and is exact for point sets that differ by an isometry (Lorentz maps are linear, so
/// centroids are equivariant); no iterative refinement is done.
LayoutAlignment align_layouts(Geometry g, std::span<const double> a, std::span<const double> b);

/// align_layouts(g, a, b).max_deviation, or +∞ when the alignment fails.
double layout_alignment_error(Geometry g, std::span<const double> a, std::span<const double> b);

}  // namespace ricci
