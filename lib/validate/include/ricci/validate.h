// ricci — checking, repairing and loading meshes.
//
// diagnose()      describes any triangle soup (never fails): counts of vertices, edges, boundary
//                 loops, components, non-manifold elements, orientation defects, …
// validate_mesh() turns a soup into a clean mesh ready for the flow — connected, manifold,
//                 consistently oriented, no degenerate or duplicate faces, no unused vertices —
//                 repairing what can be repaired without guessing and refusing the rest.
// load_mesh()     read_mesh() followed by validate_mesh().
//
// Checks, in this order; the first failing one decides the status:
//   1. NoFaces                  the mesh has no faces
//   2. IndexOutOfRange          a face index is outside [0, #V)
//   3. NonFiniteCoordinate      a vertex used by a face has a NaN or infinite coordinate
//   4. DegenerateFace           a face repeats a vertex
//   5. MultipleComponents       faces form several components (connected through shared vertices);
//                               with keep_largest_component the largest (most faces; ties: the
//                               one with the smallest face index) is kept and the rest dropped
//   6. DegenerateFace           a face has zero area: twice its area is at most
//                               degenerate_tolerance × (its longest edge)² (default 0: exactly
//                               zero, two vertices at one position or three on a line, named in
//                               the message; nearly flat faces pass and the metric mollifies
//                               them, mollify_lengths())
//   7. DuplicateFace            two faces use the same three vertices (in any order)
//   8. NonManifoldEdge          an edge has more than two faces
//   9. NonOrientable            no consistent orientation exists; otherwise inconsistent
//                               orientation is repaired by flipping faces (breadth-first), keeping
//                               the orientation of the majority of the area
//  10. NonManifoldVertex        the faces around a vertex form several fans (pinched vertex)
// Repairs: unused vertices are dropped, faces are flipped, components dropped (option), ears split
// (option, see split_ears()); each is reported in ValidateResult::repairs. A consistently oriented
// input keeps its orientation.
//
// find_ears()     the boundary vertices that lie in a single triangle ("ears").
// split_ears()    splits the interior edge opposite each ear at its midpoint, so the ear lies in two
//                 triangles; new vertices are appended, so every earlier vertex keeps its index.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/mesh.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

/// Facts about a triangle soup; every field is well defined for any input (faces with
/// out-of-range indices or repeated vertices are excluded from the edge-based counts).
struct MeshDiagnostics {
  std::int64_t vertices_listed = 0;       ///< #V in the buffer
  std::int64_t vertices_referenced = 0;   ///< vertices used by at least one face
  std::int64_t faces = 0;                 ///< #F
  std::int64_t edges = 0;                 ///< distinct undirected edges
  std::int64_t boundary_edges = 0;        ///< edges with exactly one face
  std::int64_t boundary_loops = 0;        ///< connected components of the boundary edges
  std::int64_t components = 0;            ///< components of faces sharing vertices
  std::int64_t euler_characteristic = 0;  ///< vertices_referenced − edges + faces
  std::int64_t out_of_range_faces = 0;    ///< faces with an index outside [0, #V)
  std::int64_t non_finite_vertices = 0;   ///< referenced vertices with a NaN/inf coordinate
  std::int64_t repeated_vertex_faces = 0; ///< faces that repeat a vertex
  std::int64_t zero_area_faces = 0;       ///< faces of zero area (2·area ≤ degenerate_tolerance · longest²)
  std::int64_t duplicate_faces = 0;       ///< faces whose vertex set appeared before
  std::int64_t non_manifold_edges = 0;    ///< edges with more than two faces
  std::int64_t non_manifold_vertices = 0; ///< vertices whose faces form more than one fan
  std::int64_t inconsistent_edges = 0;    ///< manifold edges traversed the same way by both faces
  bool orientable = true;                 ///< a consistent orientation exists (per component)
  bool manifold = true;                   ///< no non-manifold edge or vertex
  /// Total genus (2·components − χ − b)/2; meaningful only when manifold and orientable.
  std::int64_t genus = 0;
  double min_corner_angle = 0;            ///< radians, over non-degenerate faces
  double max_corner_angle = 0;            ///< radians, over non-degenerate faces
  double obtuse_face_fraction = 0;        ///< share of faces with an angle > π/2
};

/// Describes a triangle soup. Never fails; linear time up to sorting.
/// `degenerate_tolerance` as in ValidateOptions.
MeshDiagnostics diagnose(const Mesh& mesh, double degenerate_tolerance = 0);

/// Options of validate_mesh() (and of validate_read(), load_mesh() through LoadOptions).
struct ValidateOptions {
  /// Keep the largest component instead of failing with MultipleComponents.
  bool keep_largest_component = false;
  /// Repair inconsistent face orientation by flipping faces; false makes it an error
  /// (Status::InconsistentOrientation).
  bool repair_orientation = true;
  /// A face is degenerate when 2·area ≤ degenerate_tolerance · (longest edge)². In [0, 1); the
  /// default 0 refuses exactly flat faces only (initial_metric() mollifies nearly flat ones).
  double degenerate_tolerance = 0;
  /// After all checks passed, split every ear with split_ears() (reported as RepairKind::EarsSplit).
  /// Off by default: the mesh is then changed only where a check requires it. An ear's angle is
  /// below π whatever the metric, so a boundary target giving it a curvature ≤ 0 (the inner loops
  /// of a circle domain, geodesic boundaries) is infeasible unless the ear is split.
  bool split_ears = false;

  /// True when degenerate_tolerance is in [0, 1); otherwise false, with the reason in *why (when
  /// why is not null).
  bool is_valid(std::string* why) const;
};

/// Kind of change made to a mesh while loading and validating it.
enum class RepairKind : int {
  UnreferencedVerticesDropped,  ///< vertices used by no face were removed
  FacesFlipped,                 ///< faces were reversed to orient the surface consistently
  ComponentsDropped,            ///< components other than the largest were removed (keep_largest_component)
  PolygonsTriangulated,         ///< the reader fan-triangulated polygons with more than three sides
  EarsSplit,                    ///< the edge opposite each ear was split at its midpoint (split_ears)
  /// The metric's lengths were mollified (mollify_lengths(); made by initial_metric(), listed by
  /// the CLI next to validation's repairs): `value` is ε relative to the mean edge length.
  LengthsMollified,
};

/// Stable snake_case name of a repair ("faces_flipped", …).
std::string_view repair_name(RepairKind k);

/// One change made to a mesh, as listed in ValidateResult::repairs and LoadResult::repairs.
struct Repair {
  RepairKind kind;         ///< what was changed
  /// vertices dropped, faces flipped, components dropped, polygons split, ears split or faces
  /// below the mollification margin
  std::int64_t count = 0;
  std::string message;     ///< a full sentence, e.g. "dropped 1113 vertices used by no face (first: 34835)"
  double value = 0;        ///< lengths_mollified: ε / mean edge length; 0 for the others
};

/// What validate_mesh() returns.
struct ValidateResult {
  /// Ok, a check's status from the list at the top of this header, InconsistentOrientation (when
  /// repair_orientation is false), InvalidArgument (options, buffer sizes) or OutOfMemory.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong, naming the element; "ok" on success
  /// Element the error refers to, with its index in the *input* numbering.
  Element element = Element::None;
  std::int64_t element_index = -1;  ///< index of that element (input numbering); -1 when element is None

  /// The clean mesh (valid only when status is Ok). Texture coordinates are carried along.
  Mesh mesh;
  /// Its connectivity (valid only when status is Ok).
  Topology topology;
  /// #V_out: output vertex → input vertex; kInvalid for a vertex added by split_ears (those come
  /// last, after the input's vertices in their input order).
  std::vector<Index> vertex_to_input;
  /// #F_out: output face → input face (for a face made by split_ears: the face it is part of).
  std::vector<Index> face_to_input;
  /// What was changed, in the order it was done.
  std::vector<Repair> repairs;
};

/// Checks and repairs a mesh; see the list at the top of this header.
ValidateResult validate_mesh(const Mesh& mesh, const ValidateOptions& options = {});

/// The ears of a surface: boundary vertices that lie in exactly one face, ascending. An ear's
/// angle is below π in every metric. Linear time.
std::vector<Index> find_ears(const Topology& topology);

/// What split_ears() returns.
struct SplitEarsResult {
  /// Ok (also when nothing was split), InvalidArgument (mesh and topology disagree in size, or an
  /// ear index is outside [0, #V)), OutOfMemory, or NumericalFailure (an internal invariant broke:
  /// the split surface failed build_topology(); not expected). Outputs are valid only when Ok.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong; "ok" on success
  /// The mesh with the ears split (valid when status is Ok; a copy of the input when nothing was
  /// split). Vertices 0 … #V_in−1 and their positions are the input's; split i added vertex
  /// #V_in + i. Texture coordinates are carried along (midpoints appended to `texcoords`).
  Mesh mesh;
  Topology topology;                ///< its connectivity (valid when status is Ok)
  std::vector<Index> face_to_input; ///< #F_out: output face → the input face it is part of
  std::vector<Index> split;         ///< the ears split, in the order of the vertices they added
  /// Ears left alone because the edge opposite them is on the boundary too (an isolated triangle).
  std::vector<Index> unsplittable;
  /// The change as a Repair (kind EarsSplit, count = split.size(), a message naming the ears).
  Repair repair{RepairKind::EarsSplit, 0, "no ears were split"};
};

/// Splits ears. For an ear b in the single triangle (b, a, c) whose edge (a, c) is interior,
/// shared with the triangle (d, c, a), the edge (a, c) is split at its midpoint m (a new vertex,
/// appended): the faces become (b, a, m), (b, m, c), (d, c, m), (d, m, a), with the orientation of
/// the input. Then b lies in two triangles and m is an interior vertex of valence 4 (more if a
/// later round splits an edge of its faces); χ, the number of boundary loops, the boundary itself
/// and every input vertex's position and index are unchanged. The first of each pair of faces
/// keeps the split face's index, the second is appended.
/// A split never creates an ear; ears sharing a face are split in later rounds (in a connected
/// mesh only a mesh of two triangles has two ears on one edge, and one split removes both).
/// `topology` must be build_topology() of `mesh`. Linear time per round; allocates the output.
SplitEarsResult split_ears(const Mesh& mesh, const Topology& topology);
/// split_ears() for the given vertices only (in any order; vertices that are not ears are skipped).
SplitEarsResult split_ears(const Mesh& mesh, const Topology& topology, std::span<const Index> ears);

/// split_ears() on a validated mesh, in place, for the given ears (validated numbering): when
/// something was split, its mesh and topology are replaced, vertex_to_input gets kInvalid for the
/// new vertices, face_to_input names the input face each output face is part of, and the repair
/// is appended to `repairs`. Returns split_ears()'s status; on failure `validated` is unchanged
/// and *why (when not null) says why. (validate_mesh() with ValidateOptions::split_ears does this
/// for all ears.)
Status split_ears(ValidateResult& validated, std::span<const Index> ears, std::string* why = nullptr);

/// Options of load_mesh().
struct LoadOptions {
  ReadOptions read;          ///< passed to read_mesh()
  ValidateOptions validate;  ///< passed to validate_mesh()
};

/// What load_mesh() and validate_read() return.
struct LoadResult {
  /// Status of reading or, if reading succeeded, of validating. Messages name the file.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< the reader's message, or "<name>: " + validation message; "ok" on success
  std::int64_t line = -1;  ///< as ReadResult::line (-1 for validation errors)
  Element element = Element::None;  ///< as ReadResult::element or ValidateResult::element
  /// Index of that element; a face named by validation is given as the polygon of the file it
  /// came from when the reader triangulated polygons. -1 when element is None.
  std::int64_t element_index = -1;

  ReadResult read;          ///< the raw file content, unchanged (diagnose() it for reports)
  ValidateResult validated; ///< the clean mesh and its topology (when status is Ok)
  /// Repairs from reading (polygon triangulation) and from validation.
  std::vector<Repair> repairs;
};

/// read_mesh() + validate_read(). The raw soup stays in `read.mesh` so callers can diagnose() it.
LoadResult load_mesh(const std::string& path, const LoadOptions& options = {});

/// validate_mesh() on what a reader returned: messages start with `name`, repairs include the
/// reader's polygon triangulation, and a face named by an error is mapped to the polygon of the
/// file it came from. (Returns the reader's error unchanged when reading failed.)
LoadResult validate_read(ReadResult read, const std::string& name, const ValidateOptions& options = {});

}  // namespace ricci
