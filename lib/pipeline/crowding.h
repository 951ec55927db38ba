// ricci (internal) — crowding of circle domains: how small a boundary piece of a genus-0 surface
// with boundary becomes when the surface is mapped conformally onto a circle domain.
//
// Takes: a mesh (E lengths from its positions) and its topology, genus 0 with at least one
// boundary loop. Gives: the discrete harmonic measure of the boundary edges seen from a centre
// vertex, and the smallest one. A conformal map onto a circle domain that sends the centre to the
// origin gives each boundary piece about 2π times its harmonic measure of the unit circle (exactly
// so for a disk). Long thin parts make that measure exponentially small (a 100 × 1 strip seen
// from its middle: about e^(−π·50) at its ends), so the circle domain cannot be represented in
// double-precision coordinates at all.
//
// Method: the intrinsic Delaunay triangulation of the mesh's own metric (so every cotangent weight
// is non-negative and the Dirichlet Laplacian is an M-matrix); the centre is the interior vertex
// in the middle of the boundary's longest extent (three Dijkstra passes over edge lengths, see
// crowding.cpp); one sparse
// Cholesky solve of the Dirichlet problem L G = δ_centre; the harmonic measure of boundary vertex
// b is the flux of G into b, Σ_j w_bj G_j, and a boundary edge gets half of each end's (the
// measures add up to 1). Computed values carry an
// absolute error of about 1e-16, so a measure below that reads as zero or slightly negative:
// crowded either way.
#pragma once

#include <string>

#include "ricci/mesh.h"
#include "ricci/topology.h"

namespace ricci::detail {

struct Crowding {
  bool computed = false;      ///< false when the surface is not genus 0 with boundary, or a step failed
  std::string why_not;        ///< why not computed
  Index centre = kInvalid;    ///< the interior vertex sent to the origin
  Index vertex = kInvalid;    ///< one end of the boundary edge with the smallest harmonic measure
  Index other = kInvalid;     ///< its other end (on a subdivided strip both name input vertices)
  double min_measure = 0;     ///< that edge's harmonic measure (may read ≤ 0 below the rounding level)
  double total = 0;           ///< Σ over boundary edges (1 up to rounding)
};

Crowding circle_domain_crowding(const Mesh& mesh, const Topology& topology);

}  // namespace ricci::detail
