// ricci (internal) — polishing a developed layout so that it reproduces its metric more closely.
//
// Takes: a disk (E, H) or closed genus-0 surface (S) in corner-table form, its edge lengths l, and
// positions x from the face-by-face propagation of layout.cpp (E: #V×2 plane coordinates; H:
// #V×2 Poincaré-disk coordinates; S: #V×3 unit vectors). Gives: the same array, moved so that
// the relative edge-length errors (d(x_i, x_j) − l_ij) / l_ij shrink. Two tools, used in this
// order:
//
// - polish_by_sweeps(): nonlinear Gauss–Seidel, each vertex in turn taking one 2×2 Gauss–Newton
//   step over its own edges. Cheap (one pass over the edges per sweep), and it removes the
//   short-range error that the propagation leaves where its fronts meet.
// - polish_globally(): Gauss–Newton on all positions at once, min Σ_e ((d_e − l_e) / l_e)², with
//   one sparse Cholesky factorization of JᵀJ (CHOLMOD, through SymmetricSolver) reused by every
//   step; at 2·#V unknowns that factorization costs several of the flow's Newton steps. The
//   long-range part of the error (a drift accumulated along hundreds of faces, which local sweeps
//   reduce only by a factor close to 1 each) goes in one or two steps. A step is kept only when
//   it lowers the largest relative error.
//
// Both are deterministic; the sweeps run each colour class of vertices in parallel, the global
// steps' factorization may use the BLAS's threads.
#pragma once

#include <span>
#include <vector>

#include "ricci/metric.h"
#include "ricci/topology.h"

namespace ricci::detail {

/// The order of a sweep: the vertices (all, or `only` when it is not empty) coloured greedily in
/// their order so that no two of one colour share an edge; class c is
/// vertices[class_start[c] .. class_start[c + 1]), the classes in colour order, each in the
/// given order.
struct SweepOrder {
  std::vector<Index> vertices;
  std::vector<Index> class_start;
};
SweepOrder sweep_order(const Topology& t, std::span<const Index> only = {});

/// `sweeps` Gauss–Seidel sweeps over the vertices (all, or `only` when it is not empty), colour
/// class after colour class of sweep_order(), each class in parallel: deterministic, the same on
/// any number of threads (H: a vertex whose step would leave the unit disk stays).
void polish_by_sweeps(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x,
                      int sweeps, std::span<const Index> only = {});
/// The same over an order made before by sweep_order() (rounds over the same vertices colour them
/// once).
void polish_by_sweeps(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x,
                      int sweeps, const SweepOrder& order);

/// What polish_globally() did.
struct GlobalPolish {
  int steps = 0;              ///< Gauss–Newton steps kept
  double error_before = 0;    ///< max relative edge-length error on entry
  double error_after = 0;     ///< … on return (≤ error_before)
  bool factorized = true;     ///< false when the normal equations could not be factorized
};

/// Up to `max_steps` global Gauss–Newton steps (E, H or S; in H the unknowns are the Poincaré
/// coordinates, ∂d/∂z the conformal factor 2/(1 − |z|²) times the geodesic's direction); stops early when a step does not
/// lower the max relative edge-length error by at least a tenth.
GlobalPolish polish_globally(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x,
                             int max_steps);

/// E only: plane positions from the triangles' shapes alone, by one sparse linear least-squares
/// solve. Each corner i of a face (i, j, k) asks z_k − z_i = (l_ik / l_ij) e^{iθ_i} (z_j − z_i),
/// θ_i its angle from the lengths, weighted by 1/l_ij²; vertex s0 is held at 0 and s1 at l_01 on
/// the +x axis. A flat metric on a disk satisfies every equation exactly, so this is its layout;
/// unlike the face-by-face propagation, whose error can grow geometrically along chains of
/// needle triangles (each placed from a short base), the solve spreads every rounding over the
/// whole disk (its matrix is a Laplacian of the shapes). False, with x unchanged, when the system
/// cannot be factorized. theta: 3·#F corner angles; x: #V×2.
bool develop_by_shapes(const Topology& t, std::span<const double> l, std::span<const double> theta, Index s0,
                       Index s1, std::vector<double>& x);

}  // namespace ricci::detail
