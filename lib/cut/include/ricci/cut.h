// ricci — cutting a surface open into one topological disk: cut graph, homotopy generators and
// the canonical fundamental polygon.
//
//   CutResult r = cut_surface(mesh, topology);          // mesh: positions #V×3, faces #F×3
//   r.cut_faces            #F'×3   the disk's faces over cut vertices (per-corner cut vertex)
//   r.cut_to_surface       #Vc     cut vertex → vertex of the (refined) surface
//   r.side_offsets/…       CSR     the disk boundary as a cyclic list of labelled sides
//   r.generator_offsets/…  CSR     the loops a1 b1 … ag bg (and arcs t1 … to boundary loops)
//   r.word                 "a1 b1 a1^-1 b1^-1 a2 b2 a2^-1 b2^-1"
//
// Algorithm (all on flat index buffers, near-linear per step, O(g·n log n) in total):
//  1. Cut graph by tree–cotree on the surface with every boundary loop collapsed to a point
//     (Ŝ): a shortest-path tree T from the base vertex (Dijkstra, edge weights), a dual spanning
//     tree over the edges not in T built greedily by descending loop length d(u)+w(e)+d(v)
//     (Erickson–Whittlesey: the 2g left-over edges close the shortest loop system through the
//     base vertex), then spurs are pruned. Cutting along it plus the boundary gives a disk with
//     holes (holes: boundary loops the pruned graph does not touch).
//  2. Canonicalisation by cut-and-paste on the polygon schema of Ŝ (the classification proof;
//     Lazarus–Pocchiola–Vegter–Verroust 2001): (A) cancel adjacent x x^-1 (remove a spur),
//     (B) reduce the polygon's corners to one vertex class by cutting a triangle b a c^-1 off and
//     regluing it along a's partner, (C) bring each linked pair a…b…a^-1…b^-1 to a commutator
//     by two more cut-and-paste moves. Every move is realised on the mesh: a path c inside the
//     current disk between two polygon corners that touches the disk boundary only at its ends;
//     the new cut is (cut ∪ c) ∖ (the reglued side). Each move is the cheapest of up to 12
//     candidates; paths are shortest paths weighted by 1 + 30/h² (h: hops from the disk's
//     boundary), so they keep away from the cut and leave room for later moves (found by A*
//     with the 3D distance to the targets as its bound; the chosen candidate is cut as found).
//     After each move the disk's connectivity is read off the surface's (cut_open()).
//  3. Arcs t_i from the base corner to every hole (shortest paths inside the disk).
//  When no edge path exists (coarse mesh, too few free edges at a corner, one-face-wide parts of
//  the disk), the surface is refined locally and exactly: the path is the cheapest one in the
//  mesh graph extended by face centroids and edge midpoints (each such point costs a penalty of
//  20 mean edge lengths, so few are used), and every face it crosses gets its centroid and the
//  crossed edges their midpoints, the faces fan-triangulated from the centroid. Every new vertex
//  is recorded as (input face, barycentric coordinates). Without refinement the surface is the
//  input mesh.
//
// Independent check: the algebraic intersection numbers of the final 2g loops are counted as
// signed crossings on the surface (each loop pushed off to its left), not read from the word;
// `canonical` is true only when the word is a1 b1 a1^-1 b1^-1 … and a_i·b_j = δ_ij,
// a_i·a_j = b_i·b_j = 0 hold. Sign convention: a·b = +1 when b crosses a from a's right to its
// left (the surface oriented by its counter-clockwise faces); the commutator word read along the
// disk boundary (surface on the left) gives a_i·b_i = +1.
//
// Word format (`word`): sides in disk-boundary order starting at a1, separated by spaces:
//   closed genus g ≥ 1     a1 b1 a1^-1 b1^-1 … ag bg ag^-1 bg^-1                 (4g sides)
//   genus g ≥ 1, b holes   a1 b1 a1^-1 b1^-1 … t1 ∂1 t1^-1 … tb ∂b tb^-1        (4g + 3b sides)
//   genus 0, b ≥ 1         ∂o t2 ∂2 t2^-1 …  (1 + 3(b−1) sides; ∂o: the loop of the base
//                          vertex, or of the boundary vertex nearest to it, where all arcs start)
//   closed genus 0         s1 s1^-1: a slit along the two shortest edges x–y–z from the base
//                          vertex x (2 sides; the sphere needs no cut for its layout, the slit
//                          only makes the result a disk; one edge would not open)
// ∂i is boundary loop i (1-based, in the order of Topology's boundary loops), t_i the arc to
// it. When canonicalisation is off or fails, loop letters are x1, x2, … (canonical = false, and
// `reason` says why).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ricci/mesh.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

/// Options of cut_surface().
struct CutOptions {
  /// Base vertex of the loops (the root of the shortest-path tree). -1: vertex 0 when seed is 0,
  /// else a vertex drawn from `seed` (std::mt19937_64). At genus ≥ 1 the loops are based at the
  /// branch point of the pruned cut graph (an interior vertex where three or more of its paths
  /// meet) nearest to it, which is a corner of the polygon anyway; where no interior vertex
  /// branches, at the nearest interior vertex of the cut graph. CutResult::base_vertex says which.
  Index base_vertex = -1;
  std::uint64_t seed = 0;  ///< draws the base vertex when base_vertex is -1; 0: use vertex 0
  /// Optional per-edge weights (#E, in the topology's edge numbering, finite and ≥ 0) for the
  /// shortest-path tree and the loop lengths. Empty: 3D edge lengths (uniform without positions).
  std::vector<double> edge_weights;
  /// Run the cut-and-paste canonicalisation (else: the tree–cotree polygon, canonical = false).
  bool canonicalize = true;
  /// Upper bound on cut-and-paste moves (0: 64 + 40·g).
  Index max_moves = 0;
  /// Upper bound on the vertices the cut's local refinements add: this many per face of the input,
  /// plus 65536. Past it the cut ends uncanonical (CutResult::refinement_bound): loops that keep
  /// crossing refined faces (many moves at a high genus) would grow the surface without bound.
  double max_refined_per_face = 64;

  /// True when base_vertex ≥ -1, max_moves ≥ 0, max_refined_per_face ≥ 0 and edge_weights are
  /// finite and ≥ 0; otherwise false, with the reason in *why (when why is not null). Sizes are
  /// checked by cut_surface().
  bool is_valid(std::string* why) const;
};

/// What a side of the disk boundary or a generator is.
enum class SideKind : int {
  Loop = 0,  ///< a closed generator loop through the base vertex (a_i, b_i; x_i if not canonical)
  Arc,       ///< a cut from the base to boundary loop i (t_i)
  Boundary,  ///< a piece of the surface's boundary (∂i); no partner
  Slit,      ///< the single-edge slit of a closed genus-0 surface (s1)
};

/// What cut_surface() and cut_compact() return: the (refined) surface, the disk it is cut into,
/// the disk's labelled sides and the generators they come from.
struct CutResult {
  /// Ok: every output below is valid. InvalidArgument: options, buffer sizes or a vertex used by
  /// no face (message says which); MultipleComponents: the surface is not connected;
  /// NumericalFailure: an internal invariant failed (the message names it; no output).
  Status status = Status::NotRun;
  /// What went wrong; on success "cut into a disk with N sides" (cut_surface()) or "ok" (cut_compact()).
  std::string message = "not run";

  Index genus = 0;                   ///< total genus of the input surface
  Index boundary_loops = 0;          ///< number of boundary loops of the input surface
  Index base_vertex = -1;            ///< the base actually used, surface numbering (-1 for cut_compact())
  Index requested_base_vertex = -1;  ///< options.base_vertex, or the vertex drawn for -1 (-1 for cut_compact())
  /// The disk boundary reads the canonical word and the independent intersection check agrees.
  bool canonical = false;
  /// Made by cut_compact(): a compact fundamental domain (sides x1, x1^-1, …, and ∂i pieces of
  /// boundary loops), not a canonical system of loops.
  bool compact = false;
  /// Why canonical is false (empty when true).
  std::string reason;
  /// canonical is false because the loops' refinement would pass its bound (more than
  /// CutOptions::max_refined_per_face added vertices per input face): loops that long cross the
  /// surface many times from any base vertex.
  bool refinement_bound = false;
  /// The side labels in disk-boundary order, space-separated (format in the header comment).
  std::string word;

  // ---- the (refined) surface -------------------------------------------------------------
  /// Number of vertices of the input (vertices < num_input_vertices are the input's own).
  Index num_input_vertices = 0;
  /// Positions and faces of the refined surface. With no refinement these equal the input mesh.
  std::vector<double> surface_positions;  ///< #V'×3; empty when the input had no positions
  std::vector<Index> surface_faces;       ///< #F'×3
  /// #F': refined face → input face.
  std::vector<Index> surface_face_to_input;
  /// For every added vertex v (v ≥ num_input_vertices), record k = v − num_input_vertices:
  /// the input face refined_vertex_face[k] and barycentric coordinates refined_vertex_bary[3k..3k+2]
  /// with respect to that face's corners 0, 1, 2. In E the vertex is the barycentric combination;
  /// In H and S the point is Σ β_k X_k of the corners' points X_k on the hyperboloid / unit
  /// sphere, rescaled onto it (see refined_edge_lengths() in layout.h).
  std::vector<Index> refined_vertex_face;   ///< #added: input face of each added vertex
  std::vector<double> refined_vertex_bary;  ///< #added×3: its barycentric coordinates in that face
  /// The input vertices at that face's corners 0, 1, 2 (#added×3), so records are self-contained.
  std::vector<Index> refined_vertex_corners;
  /// #added: number of vertices added by refinement (#V' − num_input_vertices).
  Index num_refined_vertices() const { return static_cast<Index>(refined_vertex_face.size()); }

  // ---- the disk ----------------------------------------------------------------------------
  /// #F'×3: per-corner cut vertex (the disk's face buffer; faces in surface order).
  std::vector<Index> cut_faces;
  /// #Vc: cut vertex → surface vertex.
  std::vector<Index> cut_to_surface;
  /// #Vc.
  Index num_cut_vertices() const { return static_cast<Index>(cut_to_surface.size()); }

  /// The connectivity of surface_faces and of cut_faces as the cut built them (each equal to
  /// build_topology() of that buffer), so that later stages need not build them again:
  /// refined_edge_lengths() takes the first when it matches surface_faces, the layout and
  /// deck_through_domain() the second. uniformize() moves them into its `cut_metric.surface` and
  /// `disk`, so there they are empty. cut_compact() gives the disk's only (its surface is the
  /// input's own topology).
  Topology surface_topology;
  Topology disk_topology;

  /// Sides, CSR: side s runs along cut vertices side_vertices[side_offsets[s] .. side_offsets[s+1])
  /// (both end corners included), in disk-boundary order (disk on the left). #S+1, …
  std::vector<Index> side_offsets;   ///< #S+1: CSR offsets into side_vertices
  std::vector<Index> side_vertices;  ///< the sides' cut vertices, side by side (a shared corner appears in both)
  /// Per side, #S each: kind, generator, orientation, partner, boundary loop and label.
  std::vector<SideKind> side_kind;         ///< what the side is
  std::vector<Index> side_generator;       ///< index into generator_*; -1 for Boundary
  std::vector<int> side_orientation;       ///< +1: runs along its generator, −1: against it; 0 for Boundary
  std::vector<Index> side_partner;         ///< the side glued to this one (same generator); -1 for Boundary
  std::vector<Index> side_boundary_loop;   ///< boundary loop (0-based) of a Boundary or Arc side; -1 otherwise
  std::vector<std::string> side_label;     ///< "a1", "b2^-1", "∂1", … as in `word`
  /// #S.
  Index num_sides() const { return static_cast<Index>(side_kind.size()); }

  /// Generators, CSR over surface vertices: loops start and end at the base vertex; arcs run
  /// from the base to boundary loop generator_boundary_loop[i]. Names "a1", "b1", "t2", "x3", "s1".
  /// Canonical: a1 b1 … ag bg, then the arcs. Otherwise the loop entries are the branches of the
  /// reduced cut graph (x1, x2, …; at least 2g, closed only when their ends coincide).
  std::vector<Index> generator_offsets;        ///< #generators+1: CSR offsets into generator_vertices
  std::vector<Index> generator_vertices;       ///< the generators' surface vertices, generator by generator
  std::vector<SideKind> generator_kind;        ///< Loop, Arc or Slit
  std::vector<std::string> generator_name;     ///< "a1", "b1", "t2", "x3", "s1"
  std::vector<Index> generator_boundary_loop;  ///< 0-based boundary loop an Arc runs to; -1 otherwise
  /// Number of generators.
  Index num_generators() const { return static_cast<Index>(generator_kind.size()); }

  /// (2g)×(2g) algebraic intersection numbers of the loops in order a1 b1 a2 b2 … (row-major),
  /// counted on the surface; empty unless the word has the canonical form (then canonical is
  /// true exactly when this matrix is [[0,1],[-1,0]] per handle and 0 elsewhere).
  std::vector<int> intersection;

  Index moves = 0;        ///< cut-and-paste moves performed (arcs to boundary loops included)
  Index refinements = 0;  ///< local refinements (each along one dual path)
  double seconds = 0;     ///< wall-clock time of the call

  /// One line: status, genus, boundary loops, sides, canonical, added vertices, moves, time.
  std::string brief_report() const;
};

/// Cuts a connected, consistently oriented manifold mesh into one topological disk (see the top
/// of this header). `mesh.positions` may be empty (then lengths are uniform); `topology` is
/// build_topology(mesh.faces, V). Deterministic for fixed options.
CutResult cut_surface(const Mesh& mesh, const Topology& topology, const CutOptions& options = {});

/// A compact fundamental domain of a closed surface of genus ≥ 1 for a metric given by its edge
/// lengths (#E): faces are reached from a central face by a shortest-path tree of the dual graph
/// (dual edge weight: the distance between the two faces' centroids, the pair unfolded into the
/// plane along their edge), and the surface is cut along the edges that tree does not cross, spurs
/// pruned. The domain grows like a metric ball until it meets itself, as a Dirichlet domain does,
/// so its layout stays within about the surface's radius of the centre — in the Poincaré disk,
/// where coordinates lose precision as e^r, that is what keeps it accurate, unlike canonical
/// polygons, whose loops share long paths from their base vertex and make thin spikes.
/// `centre_face` −1: the face minimising the larger dual distance to the two ends of a
/// double-sweep diameter. The result is a CutResult with no refinement (surface = input):
/// sides are the branches of the cut graph between nodes (cut-graph degree ≥ 3), labelled x1,
/// x1^-1, x2, … in boundary order with partners and orientations; canonical is false. Errors:
/// InvalidArgument (sizes, lengths, closed of genus 0, a disk), MultipleComponents, NumericalFailure.
/// Bordered surfaces (all but a disk) get the same construction: the cut graph then ends on the
/// boundary loops, and the pieces of boundary between its nodes are sides of kind Boundary
/// (labelled ∂i, no partner). boundary_loops is set; `compact` is true. Vertices in `keep` (the
/// cones of a metric with cone singularities) stay on the cut: the branch of the cut graph to each
/// is not pruned, so each ends a slit whose two sides are a pair x_k, x_k^-1 (paired by the
/// rotation about the cone), and the disk's layout is consistent.
CutResult cut_compact(const Mesh& mesh, const Topology& topology, std::span<const double> lengths,
                      Index centre_face = -1, std::span<const Index> keep = {});

/// Per-vertex data (#rows×dims, row-major) carried to the cut vertices (#Vc×dims). `data` is
/// either per surface vertex (#V'×dims) or per input vertex (#V×dims; added vertices are then
/// interpolated barycentrically in their input face). Empty on a size mismatch.
std::vector<double> cut_vertex_data(const CutResult& cut, std::span<const double> data, int dims);

/// The disk as a mesh of its own: positions per cut vertex, faces = cut_faces.
Mesh cut_disk_mesh(const CutResult& cut);

/// The refined surface with per-corner texture coordinates: `uv` holds #Vc×2 coordinates per cut
/// vertex (e.g. a layout of the disk); texcoords = uv, corner_texcoords = cut_faces, so an OBJ
/// written with write_mesh() has seams exactly along the cut. Empty mesh on a size mismatch.
Mesh surface_with_cut_uvs(const CutResult& cut, std::span<const double> uv);

/// Signed algebraic intersection number of two closed vertex loops (first == last vertex, every
/// vertex interior, consecutive vertices adjacent) on a closed-or-bordered surface, by counting
/// crossings of `b` with `a` pushed off to its left (sign convention in the header comment).
/// Returns 0 for loops that are not valid paths.
int intersection_number(const Topology& topology, std::span<const Index> a, std::span<const Index> b);

}  // namespace ricci
