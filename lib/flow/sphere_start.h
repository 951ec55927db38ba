// The round sphere in vertex scaling from a plane problem (sphere_start.cpp; internal).
#pragma once

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
};

/// u solving the round sphere (S, closed genus 0, K̄ = 0) for the chords of `triangulation`, from
/// the planar problem with one vertex at infinity (see sphere_start.cpp). Options: the planar
/// solve's (tolerance, iterations, threads).
SphereStart round_sphere_start(const IntrinsicTriangulation& triangulation, const FlowOptions& options);

}  // namespace ricci::detail
