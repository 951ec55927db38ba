// The round sphere in vertex scaling from a plane problem (sphere_start.cpp; internal).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/intrinsic.h"

namespace ricci::detail {

struct SphereStart {
  Status status = Status::NotRun;  ///< Ok, or NotRun with `message` saying why there is no start
  std::string message = "not run";
  std::vector<double> u;           ///< #V: the round sphere's u (up to Möbius maps)
  Index vertex_at_infinity = kInvalid;
  int iterations = 0;              ///< Newton steps of the planar solves
  int rounds = 0;                  ///< link flips rounds (solves − 1)
  /// The planar Newton system's last fill-reducing ordering as vertices of the sphere (the vertex
  /// at infinity and its link, held in the plane, not in it).
  std::vector<Index> order;
};

/// solve_flow_with_flips() with vertex orders for the symbolic analysis of the Newton system
/// (hint: used when not null and not empty; out: the last ordering used), see
/// FlowSolver::set_ordering() in flow.cpp.
FlowResult solve_flow_with_flips_ordered(IntrinsicTriangulation& triangulation, std::span<const double> u0,
                                         const Target& target, const FlowOptions& options,
                                         const std::vector<Index>* order_hint, std::vector<Index>* order_out);

/// u solving the round sphere (S, closed genus 0, K̄ = 0) for the chords of `triangulation`, from
/// the planar problem with one vertex at infinity (see sphere_start.cpp). Options: the planar
/// solve's (tolerance, iterations, threads).
SphereStart round_sphere_start(const IntrinsicTriangulation& triangulation, const FlowOptions& options);

}  // namespace ricci::detail
