// ricci_shapes — stress meshes for the hardening tests (issue 8, item 3): needles and caps,
// high-valence vertices, extreme coordinate scales, nearly coplanar folds, long thin strips, tiny
// and huge edges side by side, random vertex order. Used by tools/stress_meshes (which writes
// them to files) and tests/whole/test_stress.cpp (which builds small versions in memory).
//
// Every generator is deterministic for its arguments (a seed where randomness is used, drawn from
// raw std::mt19937_64 outputs only). Unlike shapes.h, some use std::sin/std::cos, so their bits
// may differ between C libraries; nothing is stored as a fixture. Every mesh returned is a valid,
// connected, consistently oriented manifold (closed ones with outward normals).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "ricci/mesh.h"
#include "ricci/validate.h"
#include "shapes.h"

namespace ricci_shapes {

/// Inserts one vertex into about `fraction` of the faces of a valid mesh, chosen at random, each
/// splitting its face 1→3 into badly shaped triangles: alternately a *needle* (the new vertex at
/// relative distance ~`angle` from a corner, giving two triangles with angles ≈ `angle` rad) and a
/// *cap* (the new vertex at relative distance ~`angle` from the midpoint of an edge, inside the
/// face, giving a triangle with an angle ≈ π − 2·`angle` and two ≈ `angle`). The surface in space
/// is unchanged; new vertices are appended. Preconditions: 0 < angle ≤ 0.1, 0 ≤ fraction ≤ 1.
Mesh insert_needles_and_caps(const Mesh& mesh, std::mt19937_64& rng, double fraction, double angle);

/// Sphere of radius 1 as a latitude–longitude grid: `segments` meridians and `rings` latitude
/// circles between the poles; each pole has valence `segments`. #V = segments·rings + 2,
/// #F = 2·segments·rings. Preconditions: segments ≥ 3, rings ≥ 1.
Mesh polar_sphere(int segments, int rings);

/// Disk of radius 1 (open, normals up): a centre vertex of valence `segments`, then `rings`
/// circles of `segments` vertices at radii k/rings, lifted like disk() (z = 0.15·(x² − y²)).
/// #V = segments·rings + 1, #F = segments·(2·rings − 1). Preconditions: segments ≥ 3, rings ≥ 1.
Mesh fan_disk(int segments, int rings);

/// The mesh with every coordinate multiplied by `factor` (> 0).
Mesh scaled(const Mesh& mesh, double factor);

/// A closed surface squashed flat: icosphere(subdivisions) with z multiplied by `flatness`
/// (e.g. 1e-6). Top and bottom are nearly coplanar, folded onto each other at the rim.
Mesh pancake(int subdivisions, double flatness);

/// A disk (rectangle) folded `folds` times like a paper fan: a `columns_per_fold`·folds ×
/// `rows` grid of the parameter rectangle [0, folds] × [0, 1], mapped to x = triangle wave of s
/// (0 → 1 → 0 → …), y = t, z = gap·s, so consecutive layers are nearly coplanar and lie `gap`
/// apart. #F = 2·columns_per_fold·folds·rows. Preconditions: folds ≥ 1, columns_per_fold ≥ 1,
/// rows ≥ 1, gap > 0.
Mesh accordion(int folds, int columns_per_fold, int rows, double gap);

/// A planar rectangle [0, length] × [0, width] as a grid of `columns` × `rows` quads, each split
/// into two triangles (a disk, normals up). #V = (columns+1)(rows+1), #F = 2·columns·rows.
/// Preconditions: columns, rows ≥ 1; length, width > 0.
Mesh strip(int columns, int rows, double length, double width);

/// A disk whose edges shrink geometrically towards its centre: a centre vertex, then `rings`
/// circles of `segments` vertices at radii r_min·q^k (k = 0..rings−1, q chosen so the last radius
/// is 1), lifted like disk(). Triangles are well shaped; edge lengths span about r_min to 1.
/// #F = segments·(2·rings − 1). Preconditions: segments ≥ 3, rings ≥ 2, 0 < r_min < 1.
Mesh graded_disk(int segments, int rings, double r_min);

/// Torus of revolution (R = 1, r = 0.4) whose meridian circles alternate between a tiny angular
/// gap `tiny` (in turns of the major circle, relative) and a regular one, so tiny edges lie beside
/// long ones: 2·pairs meridians, `n_minor` vertices each. #F = 4·pairs·n_minor.
/// Preconditions: pairs ≥ 2, n_minor ≥ 3, 0 < tiny < 1.
Mesh tiny_huge_torus(int pairs, int n_minor, double tiny);

/// Nearly flat faces, the class the metric mollifies: `count` times, a random face's first vertex
/// is moved toward its second (a short edge) or toward the middle of the opposite edge (a cap),
/// alternately, leaving 10^-U(exponent_min, exponent_max) of the way. The topology is unchanged;
/// a vertex may land exactly on the other point or line in double (a zero-area face, which
/// validation refuses by name). Preconditions: count ≥ 0, 0 ≤ exponent_min ≤ exponent_max.
Mesh nearly_flat_faces(const Mesh& mesh, std::mt19937_64& rng, int count, double exponent_min, double exponent_max);

/// Random vertex and face order of a mesh (permute_vertices then permute_faces from `seed`).
Mesh random_order(const Mesh& mesh, std::uint64_t seed);

/// One named stress mesh, as written by tools/stress_meshes and looped over by the tests.
struct StressMesh {
  std::string name;      ///< file stem, e.g. "needles-caps-torus"
  std::string what;      ///< one line: what it stresses
  Mesh mesh;
};

/// Size of the stress set: Small (≤ ~6k faces each, for the test suite under ASan), Medium (the
/// default of tools/stress_meshes, ≤ ~25k faces each).
enum class StressSize { Small, Medium };

/// Every stress kind of issue 8 item 3 except the 1M-face mesh (see large_random_order()), seeded.
std::vector<StressMesh> stress_meshes(StressSize size, std::uint64_t seed);

/// The large random-order mesh: a torus of about `faces` faces (rounded to a square grid) with its
/// vertices and faces in random order.
StressMesh large_random_order(std::int64_t faces, std::uint64_t seed);

/// Smallest corner angle over all faces in radians (0 for a degenerate face).
double min_angle_radians(const Mesh& mesh);

/// One draw of random_surface(): the mesh and what was drawn.
struct RandomSurface {
  Mesh mesh;
  int genus = 0;          ///< genus of the surface
  int loops = 0;          ///< boundary loops (holes cut around vertices)
  double aspect = 1;      ///< the stretch along x (triangles up to about this aspect ratio)
  double jitter = 0;      ///< vertex displacement, relative to the shortest edge at the vertex
  std::string description;  ///< one line: genus, loops, faces, aspect, jitter, base
};

/// A random surface for sweeps: genus uniform in 0..12 and 0..8 boundary loops, about
/// `target_faces` faces (±30 %), a voxel pretzel grid (genus ≥ 1, holes in a random cols × rows
/// grid) or an icosphere (genus 0), some edges flipped and faces split at random, every vertex
/// jittered by up to a random fraction (≤ 0.3) of its shortest edge inside its tangent plane,
/// then stretched along x by a factor drawn log-uniformly in [1, 100] (anisotropic "CAD"
/// triangles); the holes are the stars of random vertices whose closed stars are disjoint.
/// Deterministic for (seed, target_faces). Precondition: 500 ≤ target_faces ≤ 200000.
RandomSurface random_surface(std::uint64_t seed, Index target_faces);

/// The face count tools/random_surface_sweep draws for `seed`: log-uniform in [min_faces,
/// max_faces], from a generator of its own (seed ^ 0x5eed5eed).
Index random_surface_faces(std::uint64_t seed, Index min_faces, Index max_faces);

/// validate_mesh() of `mesh`, then, as `ricci uniformize` does by default, the ears that the
/// uniform target of the natural boundary mode makes infeasible split (ricci::infeasible_ears(),
/// ricci::split_ears()); a failed split sets status and message ("splitting ears: …").
ricci::ValidateResult validate_as_cli(const Mesh& mesh);

}  // namespace ricci_shapes
