// ricci — discrete conformal metrics: edge lengths, corner angles, curvature, areas and the
// Hessian ∂K/∂u, in euclidean (E), hyperbolic (H) and spherical (S) background geometry.
//
// One length formula serves every scheme (Zhang, Guo, Zeng, Luo, Yau, Gu 2014, "The unified
// discrete surface Ricci flow"). With a per-scheme constant ε and a fixed weight η_ij per edge,
//
//     Q_ij = 2 η_ij e^{u_i + u_j} + ε e^{2 u_i} + ε e^{2 u_j}
//
//     E:  l_ij²          = Q_ij
//     H:  sinh²(l_ij/2)  = Q_ij / ((1 − ε e^{2u_i}) (1 − ε e^{2u_j}))
//     S:  sin²(l_ij/2)   = Q_ij / ((1 + ε e^{2u_i}) (1 + ε e^{2u_j}))
//
// with u_i = log γ_i (E), log tanh(γ_i/2) (H), log tan(γ_i/2) (S) (the paper's eq. 9).
//   circle packing (Thurston; the paper's eq. 12):  ε = 1, η = cos Φ_ij, Φ ∈ [0, π/2]
//   inversive distance:                              ε = 1, η = I_ij (any value > −1)
//   vertex scaling / Yamabe:                         ε = 0, η = l⁰²/2, sinh²(l⁰/2)/2, sin²(l⁰/2)/2
// For ε = 1 these are the cosine laws l² = γ_i² + γ_j² + 2γ_iγ_j η (E), cosh l = cosh γ_i cosh γ_j
// + sinh γ_i sinh γ_j η (H) and cos l = cos γ_i cos γ_j − sin γ_i sin γ_j η (S), written in the
// half-length form so that short edges keep full relative precision.
//
// Angles come from lengths by the half-angle formula tan²(θ_i/2) = f(s−l_j) f(s−l_k) /
// (f(s) f(s−l_i)), f = identity / sinh / sin, s the half perimeter (atan2 form, no acos). A
// triangle that violates the triangle inequality (or, in S, has perimeter ≥ 2π) is reported; its
// angles are set to the limit (π at the vertex opposite the longest edge, 0 elsewhere) so no NaN
// ever leaves a kernel.
//
// Curvature K_i = 2π − Σθ at interior vertices and π − Σθ on the boundary (eq. 7); discrete
// Gauss–Bonnet reads Σ K_i + λ Σ A_f = 2πχ with λ = 0 (E), −1 (H), +1 (S).
//
// Kernels write into caller-sized outputs, allocate nothing and run as OpenMP loops over faces
// (angles, Hessian blocks) or vertices (curvature, gathered through the vertex → corner lists),
// each iteration writing only its own slots: results are bitwise identical for any thread count.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/mesh.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

/// Background geometry of a metric: Euclidean (E, the plane, curvature 0), Hyperbolic (H,
/// curvature −1) or Spherical (S, curvature +1).
enum class Geometry : int { Euclidean = 0, Hyperbolic, Spherical };
/// Discrete conformal scheme (see the top of this header): CirclePacking (ε = 1, η = cos Φ),
/// InversiveDistance (ε = 1, η = I) or Yamabe, i.e. vertex scaling (ε = 0).
enum class Scheme : int { CirclePacking = 0, InversiveDistance, Yamabe };

std::string_view geometry_name(Geometry g);  ///< "euclidean", "hyperbolic", "spherical"
std::string_view scheme_name(Scheme s);      ///< "circle-packing", "inversive-distance", "yamabe"

/// λ in Gauss–Bonnet: 0 (E), −1 (H), +1 (S).
double gauss_bonnet_lambda(Geometry g);

/// The fixed part of a discrete conformal metric: background geometry, scheme and edge weights.
/// Together with a vector u (#V) it determines every edge length.
struct ConformalStructure {
  Geometry geometry = Geometry::Euclidean;  ///< background geometry
  Scheme scheme = Scheme::CirclePacking;    ///< the scheme that fixes epsilon and the meaning of eta
  double epsilon = 1;        ///< ε: 1 for circle packing and inversive distance, 0 for Yamabe
  std::vector<double> eta;   ///< #E: η_ij (cos Φ_ij, inversive distance, or the Yamabe weight)
};

/// Default margin of mollify_lengths(), relative to the mean edge length.
inline constexpr double kMollifyMargin = 1e-12;

/// What mollify_lengths() did.
struct Mollification {
  double delta = 0;       ///< the margin: afterwards l_i + l_j ≥ l_k + delta in every triangle
  double epsilon = 0;     ///< the length added to every edge; 0 when no triangle was below the margin
  double mean_edge = 0;   ///< the mean edge length before (delta = margin × mean_edge)
  Index faces = 0;        ///< triangles below the margin before
  Index worst_face = kInvalid;  ///< the triangle that set epsilon (kInvalid when epsilon is 0)
};

/// Intrinsic mollification (Sharp & Crane 2020, "A Laplacian for nonmanifold triangle meshes",
/// §4.5): adds the smallest ε ≥ 0 to every edge length l (#E) so that every triangle satisfies
/// the triangle inequalities with the margin δ = relative_margin × mean edge length,
/// ε = max over corners of (l_k − l_i − l_j + δ). Near-degenerate triangles (needles with an edge
/// below δ, caps whose longest edge is within δ of the other two) get a metric the flow and the
/// layout resolve; where no triangle is below the margin nothing changes (ε = 0). Being the same
/// shift for every edge, it changes the metric by ε/l relative, the least uniform repair.
/// relative_margin ≤ 0 or no edges: nothing is done.
Mollification mollify_lengths(const Topology& topology, std::span<double> l, double relative_margin = kMollifyMargin);

/// Options of initial_metric().
struct InitialMetricOptions {
  Geometry geometry = Geometry::Euclidean;  ///< background geometry of the metric
  Scheme scheme = Scheme::CirclePacking;    ///< conformal scheme
  /// Uniform scale applied to the 3D edge lengths before they are read; 0 picks the default: in E
  /// unit_power_of_two() of the longest edge (1, the input's unit, unless that edge is shorter
  /// than 2^-100 or longer than 2^100); in S the scale making the total area 4π (every scheme: lowered where that
  /// puts an edge past π, so that the longest is 0.9 π); in H the scale making the total
  /// euclidean area equal the hyperbolic area 2π|χ| (1 when χ ≥ 0).
  double length_scale = 0;
  /// Circle packing: after Step 2, lower Φ on the separating 3- and 4-cycles that would make
  /// curvature 0 inside them infeasible (relax_intersection_angles()). Off: Step 2 exactly.
  bool relax_angles = true;
  /// mollify_lengths() margin applied to the 3D edge lengths before anything else (relative to
  /// the mean edge length; 0 turns it off). In [0, 1e-3].
  double mollify_margin = kMollifyMargin;

  /// True when length_scale is finite and ≥ 0; otherwise false, with the reason in *why (when why
  /// is not null).
  bool is_valid(std::string* why) const;
};

/// What initial_metric() returns: the conformal structure and the starting u (Step 2 of the paper).
struct InitialMetric {
  /// Ok, InvalidArgument (options), DegenerateFace (a vertex's averaged radius is not a positive
  /// finite number, or an edge gets an inversive distance ≤ −1),
  /// NumericalFailure (in S, after scaling, an edge of length ≥ π or a radius ≥ π).
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong, naming the vertex or edge; "ok" on success
  ConformalStructure structure;     ///< geometry, scheme, ε and η (#E)
  std::vector<double> u;        ///< #V: the starting metric (u = 0 for Yamabe)
  std::vector<double> gamma;    ///< #V: initial radii γ_i (circle schemes; empty for Yamabe)
  std::vector<double> l0;       ///< #E: the scaled 3D edge lengths the metric approximates
  double length_scale = 1;      ///< the scale that was applied
  /// The mollification of the 3D lengths (before length_scale; epsilon 0 when none was needed).
  Mollification mollification;
  Index edges_clamped_high = 0; ///< circle packing: Φ clamped to π/2 (cos Φ < 0)
  Index edges_clamped_low = 0;  ///< circle packing: Φ clamped to 0 (circles did not meet)
  Index cycles_relaxed = 0;     ///< circle packing: 3- and 4-cycles whose Φ were lowered
  Index edges_relaxed = 0;      ///< circle packing: edges whose Φ was lowered
};

/// What relax_intersection_angles() changed.
struct AngleRelaxation {
  Index cycles3 = 0;  ///< 3-cycles (not faces) whose angles were lowered
  Index cycles4 = 0;  ///< 4-cycles (not the outline of two faces) whose angles were lowered
  Index edges = 0;    ///< distinct edges whose Φ changed
};

/// Thurston's conditions for a circle pattern with Φ ∈ [0, π/2] and zero curvature inside a
/// disk bounded by a cycle of k edges (the paper's Theorem 4 for I = the vertices inside):
/// Σ (π − Φ) > 2π over the cycle, i.e. Σ Φ < π for a 3-cycle and Σ Φ < 2π for a 4-cycle (longer
/// cycles always pass). Step 2 breaks them where the mesh has valence-3 or valence-4 vertices in
/// triangles with obtuse or right angles (the link of such a vertex is such a cycle). This lowers
/// Φ on every 3-cycle that is not a face with Σ Φ > 5π/6 (scaled so that Σ Φ = 2π/3) and on every
/// 4-cycle that is not the outline of two faces with Σ Φ > 11π/6 (scaled to 7π/4), and then on the
/// two edges opposite a boundary vertex in two faces with Σ Φ > 5π/6 (scaled to 2π/3: that
/// vertex's angle is below 2π − Σ Φ, so Φ = π/2 on both, as Step 2 gives after an ear split, would
/// cap it at π and rule out K̄ ≤ 0 on inner circle and geodesic loops; `edges` counts these too),
/// in a fixed order; lowering Φ never breaks a condition that held. eta holds η = cos Φ per edge
/// (#E, values in [0, 1]; edges outside are left alone). Deterministic; linear in the mesh for
/// bounded valence.
AngleRelaxation relax_intersection_angles(const Topology& topology, std::span<double> eta);

/// Step 2 of the paper for circle packing: radii γ_i^{jk} = (l_ki + l_ij − l_jk)/2 per face,
/// averaged per vertex; Φ_ij from the cosine law of the geometry, clamped to [0, π/2], then (with
/// options.relax_angles) relaxed on separating 3- and 4-cycles, see relax_intersection_angles(). For
/// inversive distance the same radii with I_ij chosen so that u reproduces l0 exactly; for
/// Yamabe u = 0 and η reproducing l0.
InitialMetric initial_metric(const Mesh& mesh, const Topology& topology, const InitialMetricOptions& options = {});

/// The mesh's own 3D edge lengths, #E in topology's edge order (hypot: no overflow or underflow
/// of the squares at any scale).
std::vector<double> mesh_edge_lengths(const Mesh& mesh, const Topology& topology);

/// The power of two by which lengths (or positions) whose largest size is `extent` are multiplied
/// before any product of them is formed: 1 when extent lies in [2^-100, 2^100] (the input's own
/// unit is kept), otherwise the power of two that brings extent into [1, 2). Multiplying by it is
/// exact in binary floating point, so the geometry is unchanged, and squares and Heron's products
/// stay far from underflow and overflow at any scale a double holds. 1 when extent is 0, infinite
/// or NaN; 2^1023 for extents below 2^-1022 (subnormal).
double unit_power_of_two(double extent);

/// The factor s for which the euclidean triangles of lengths s·l (#E) have total area
/// target_area (Heron's formula in Kahan's stable form, evaluated on l times a power of two so
/// that no product under- or overflows at any scale); 1 when that area is 0.
double euclidean_area_scale(const Topology& topology, std::span<const double> l, double target_area);

// ---------------------------------------------------------------------------------------------
// Kernels. Shapes: u #V, l #E, theta #F×3 (per corner), K #V, area #F, blocks #F×9.

/// Edge lengths from u. Returns the first edge whose length is not a positive finite number (or,
/// in S, exceeds π; in H, whose radius is not below 1 in tanh form), else kInvalid.
Index edge_lengths(const Topology& topology, const ConformalStructure& structure, std::span<const double> u,
                   std::span<double> l);

/// What corner_angles() found.
struct AngleReport {
  Index violations = 0;         ///< faces that violate the triangle inequality (or S perimeter)
  Index first_violation = kInvalid;  ///< smallest such face, kInvalid when there is none
};

/// Corner angles theta[c] from edge lengths (per-face edge k opposite corner k).
AngleReport corner_angles(const Topology& topology, Geometry geometry, std::span<const double> l,
                          std::span<double> theta);

/// Curvature per vertex from corner angles: 2π − Σθ inside, π − Σθ on the boundary.
void vertex_curvature(const Topology& topology, std::span<const double> theta, std::span<double> K);

/// Face areas: E from the side lengths (½ l_j l_k sin θ_i), H and S by L'Huilier's formula.
void face_areas(const Topology& topology, Geometry geometry, std::span<const double> l,
                std::span<const double> theta, std::span<double> area);

/// Per-face 3×3 blocks of ∂θ/∂u: blocks[9f + 3a + b] = ∂θ(corner 3f+a) / ∂u(vertex of corner
/// 3f+b). Needs u, l and theta of the same metric.
void angle_derivative_blocks(const Topology& topology, const ConformalStructure& structure,
                             std::span<const double> u, std::span<const double> l, std::span<const double> theta,
                             std::span<double> blocks);

/// Gauss–Bonnet defect Σ K + λ Σ A − 2πχ (0 up to rounding for every admissible metric).
double gauss_bonnet_defect(const Topology& topology, Geometry geometry, std::span<const double> K,
                           std::span<const double> area);

}  // namespace ricci
