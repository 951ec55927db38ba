// ricci_shapes — deterministic generators of test meshes and topology-preserving random
// transforms. Used by tools/make_fixtures, the tests and benchmarks; never part of the library.
//
// Every generator returns a ricci::Mesh in flat buffers (positions #V×3, faces #F×3) with no
// texture coordinates. Closed surfaces have counter-clockwise faces seen from outside (outward
// normals, positive signed volume); open surfaces are consistently oriented with normals pointing
// up (+z). No generator uses randomness, and the arithmetic is plain IEEE double (+ − × ÷ and
// sqrt; trigonometry is computed here, not by the C library), so the output is the same bits on
// every platform whose compiler does not contract a·b + c into fused multiply-adds.
//
// The random transforms take an explicit std::mt19937_64& and draw from its raw 64-bit outputs
// only (no std distributions, whose algorithms are implementation-defined), so a seed gives the
// same mesh everywhere. Every transform preserves the topology of a valid mesh: the Euler
// characteristic χ, the number of boundary loops b, the genus, connectedness, manifoldness and
// consistent orientation.
#pragma once

#include <random>
#include <vector>

#include "ricci/mesh.h"

namespace ricci_shapes {

using ricci::Index;
using ricci::Mesh;

// ---------------------------------------------------------------------------------------------
// Closed surfaces.

/// Unit sphere (genus 0) from a regular icosahedron whose faces are split 1→4 `subdivisions`
/// times, new vertices projected onto the sphere. #V = 10·4^s + 2, #F = 20·4^s.
/// Precondition: 0 ≤ subdivisions ≤ 10.
Mesh icosphere(int subdivisions);

/// Torus of revolution about the z axis (genus 1): major radius R, tube radius r, an
/// n_major × n_minor grid of quads, each split into two triangles along the same diagonal (every
/// vertex has valence 6).
/// #V = n_major·n_minor, #F = 2·n_major·n_minor.
/// Preconditions: n_major ≥ 3, n_minor ≥ 3, 0 < r < R.
Mesh torus(int n_major, int n_minor, double R, double r);

/// Closed surface of genus g ("pretzel"): the boundary of a thick plate of voxels with g square
/// holes in a row, each voxel face split into two triangles, vertices welded on the integer grid,
/// then Taubin-smoothed (λ/μ) so the surface is round rather than blocky, and finally scaled to
/// lie in [−1, 1] along x, centred at the origin. `cells_per_unit` voxels span one unit of the
/// layout (hole width = bar width = plate thickness = one unit), so #F grows as cells_per_unit².
/// With cells_per_unit = 4: 1600 faces for g = 2, 2176 for g = 3.
/// Preconditions: 1 ≤ genus ≤ 64, 2 ≤ cells_per_unit ≤ 32.
Mesh pretzel(int genus, int cells_per_unit);

/// Closed surface of genus cols·rows: as pretzel(), with the holes in a grid of cols × rows (so
/// the surface stays round as the genus grows, where a row of holes grows long: its hyperbolic
/// metric's diameter grows with the genus). pretzel_grid(g, 1, c) is pretzel(g, c).
/// Preconditions: cols, rows ≥ 1, cols·rows ≤ 256, 2 ≤ cells_per_unit ≤ 32.
Mesh pretzel_grid(int cols, int rows, int cells_per_unit);

/// Sorted, duplicate-free neighbour lists of every vertex (CSR: vertex v's neighbours are
/// nbrs[offsets[v] … offsets[v+1]]), so that sums over neighbours run in a fixed order.
void vertex_neighbours(const Mesh& m, std::vector<Index>& offsets, std::vector<Index>& nbrs);

/// Closed surface of genus g made of g handles joined in a row by long thin tubes, and a dead-end
/// finger: each handle is a ring of 3 × 3 units around a one-unit hole, one unit thick;
/// consecutive rings are joined by a tube of one unit × one unit cross-section and `tube_units`
/// units long (aspect tube_units : 1), and the last ring carries a finger of the same
/// cross-section, `finger_units` long (0: none); built and smoothed as pretzel().
/// Their hyperbolic metric has a short closed geodesic around each tube, and a finger's faces
/// shrink about e^{−π/2} ≈ 0.2 per unit along it (the conformal factor of a capped cylinder): a
/// finger of 20 units holds faces some 1e-14 times the handles' size, which one Poincaré chart
/// around the handles cannot resolve.
/// Genus 0: one solid block of 3 × 3 × 1 units with the finger.
/// Preconditions: 0 ≤ genus ≤ 16 (genus 0 and 1 only with a finger), 1 ≤ tube_units ≤ 200,
/// 0 ≤ finger_units ≤ 200, 2 ≤ cells_per_unit ≤ 16.
Mesh tube_pretzel(int genus, int tube_units, int finger_units, int cells_per_unit);

// ---------------------------------------------------------------------------------------------
// Surfaces with boundary.

/// Disk (one boundary loop) of radius 1 about the origin: a centre vertex and `rings` concentric
/// rings of 6k vertices (k = 1..rings), zipped into near-equilateral triangles, lifted slightly
/// off the plane (z = 0.15·(x² − y²)) so it is not planar. Normals point up.
/// #V = 3·rings·(rings+1) + 1, #F = 6·rings². Precondition: 1 ≤ rings ≤ 1000.
Mesh disk(int rings);

/// Annulus (two boundary loops) between radii 0.5 and 1: `rings` layers of `segments` quads, each
/// split into two triangles along the same diagonal, lifted slightly off the plane like
/// disk(). Normals point up; the outer loop runs counter-clockwise, the inner one clockwise.
/// #V = (rings+1)·segments, #F = 2·rings·segments. Preconditions: rings ≥ 1, segments ≥ 3.
Mesh annulus(int rings, int segments);

/// The annulus r1 ≤ |z| ≤ r2 (0 < r1 < r2 ≤ 1) carried into 3D by conformal maps: w = z + 0.2 z²,
/// then the inverse stereographic projection of 0.8 w onto the unit sphere. Its conformal modulus
/// is log(r2/r1)/2π exactly, while the mesh is neither flat nor rotationally symmetric. `rings`
/// rings spaced geometrically in z, `segments` vertices each, alternate rings offset by half a
/// segment (near-equilateral triangles when rings ≈ segments·log(r2/r1)/(π√3)).
/// `flat`: the planar annulus itself (z at height 0), no maps.
/// #V = (rings+1)·segments, #F = 2·rings·segments. Preconditions: rings ≥ 1, segments ≥ 3.
Mesh conformal_annulus(double r1, double r2, int rings, int segments, bool flat = false);

/// Cuts a hole around each vertex in `centres`: removes every face incident to it and drops the
/// vertices no longer used (the remaining vertices keep their relative order). Each hole adds one
/// boundary loop (the link of its centre) and lowers χ by one.
/// Preconditions (checked; std::invalid_argument otherwise): `mesh` is a valid manifold mesh;
/// each centre is an interior vertex; the closed stars of the centres are pairwise disjoint and
/// do not touch the boundary (no link vertex is a centre, lies on the boundary or lies in
/// another centre's link), so holes never touch each other.
Mesh remove_vertex_stars(const Mesh& mesh, const std::vector<Index>& centres);

// ---------------------------------------------------------------------------------------------
// Random transforms for property tests. Precondition for all: `mesh` is valid (manifold,
// consistently oriented, no degenerate faces), as from validate_mesh().

/// Renumbers the vertices by a uniformly random permutation (faces are rewritten accordingly;
/// texture coordinates are kept as they are).
Mesh permute_vertices(const Mesh& mesh, std::mt19937_64& rng);

/// Reorders the faces by a uniformly random permutation (per-corner texture indices follow).
Mesh permute_faces(const Mesh& mesh, std::mt19937_64& rng);

/// Rotates the three corners of each face cyclically by a random 0, 1 or 2 steps: the face and
/// its orientation are unchanged, only which corner is listed first (texture indices follow).
Mesh rotate_face_corners(const Mesh& mesh, std::mt19937_64& rng);

/// Splits every face 1→4 at its edge midpoints (new vertices are not projected). Deterministic:
/// new vertices are appended in the order their edges are first met in the face list. #V + #E
/// vertices and 4·#F faces. Texture coordinates are dropped.
Mesh subdivide_midpoint(const Mesh& mesh);
/// Same as subdivide_midpoint(mesh); `rng` is unused and is accepted so that every transform has
/// the same signature.
Mesh subdivide_midpoint(const Mesh& mesh, std::mt19937_64& rng);

/// Splits each face 1→3 with probability `fraction` by inserting a vertex at a random interior
/// point (barycentric coordinates each at least 0.1, so no new triangle is degenerate); the new
/// vertices are appended. Texture coordinates are dropped. Precondition: 0 ≤ fraction ≤ 1.
Mesh split_random_faces(const Mesh& mesh, std::mt19937_64& rng, double fraction = 0.25);

/// Flips about `fraction` of the interior edges, visited in random order. An edge is flipped
/// only if the result stays valid: the new edge does not exist yet (no duplicate edge or face, so
/// the mesh stays manifold) and both new triangles are well away from degenerate (twice the area
/// above 1e-3 × the longest edge squared) and neither folds over (each new normal points to the
/// side of the sum of the two old normals). Orientation is kept. Texture coordinates are dropped.
/// Precondition: 0 ≤ fraction ≤ 1.
Mesh flip_random_edges(const Mesh& mesh, std::mt19937_64& rng, double fraction = 0.25);

// ---------------------------------------------------------------------------------------------
// Small geometric measures used by the tests and make_fixtures.

/// Signed volume enclosed by the faces, Σ det(p0, p1, p2)/6: positive for a closed mesh with
/// outward normals.
double signed_volume(const Mesh& mesh);

/// Smallest corner angle over all faces, in degrees (0 for a degenerate face; 180 for no faces).
double min_angle_degrees(const Mesh& mesh);

/// Uniform double in [0, 1) from the top 53 bits of one raw rng() output (portable, unlike
/// std::uniform_real_distribution).
double unit_double(std::mt19937_64& rng);

/// Uniform integer in [0, n) from one raw rng() output (by modulo; the bias is negligible for the
/// sizes used here). Precondition: n > 0.
Index uniform_index(std::mt19937_64& rng, Index n);

}  // namespace ricci_shapes
