// Invariants of the performance work on the flow: the timing breakdown is consistent, and the
// spherical Newton system (indefinite: solved by a pinned supernodal LLᵀ and a Woodbury
// correction, simplicial LDLᵀ only as a fallback) gives quadratic convergence, the same bits for
// any thread count, and the same solution as before within the tolerance.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/metric.h"
#include "ricci/validate.h"
#include "shapes.h"

using namespace ricci;

namespace {

struct Solved {
  ValidateResult mesh;
  InitialMetric metric;
  Target target;
};

Solved prepare(const Mesh& raw) {
  Solved s;
  s.mesh = validate_mesh(raw);
  REQUIRE(s.mesh.status == Status::Ok);
  InitialMetricOptions o;
  o.geometry = natural_geometry(s.mesh.topology);
  s.metric = initial_metric(s.mesh.mesh, s.mesh.topology, o);
  REQUIRE(s.metric.status == Status::Ok);
  s.target = uniform_target(s.mesh.topology, natural_boundary_mode(s.mesh.topology, o.geometry));
  return s;
}

double sum(const FlowTimings& t) {
  return t.setup + t.analysis + t.derivatives + t.assembly + t.factorization + t.solve + t.line_search;
}

}  // namespace

TEST_CASE("flow: the timing breakdown is non-negative, within the total and the sum of its iterations") {
  for (const auto& [name, raw] : {std::pair{"torus", ricci_shapes::torus(40, 20, 1.0, 0.5)},
                                  std::pair{"genus 2", ricci_shapes::pretzel(2, 4)},
                                  std::pair{"sphere", ricci_shapes::icosphere(3)},
                                  std::pair{"disk", ricci_shapes::disk(12)}}) {
    INFO(name);
    const Solved s = prepare(raw);
    const FlowResult r = solve_flow(s.mesh.topology, s.metric.structure, s.metric.u, s.target);
    REQUIRE(r.status == Status::Ok);
    const FlowTimings& t = r.timings;
    for (const double x : {t.setup, t.analysis, t.derivatives, t.assembly, t.factorization, t.solve, t.line_search})
      CHECK(x >= 0);
    CHECK(sum(t) <= r.seconds * 1.0001 + 1e-6);
    CHECK(t.factorization > 0);
    CHECK(r.factor_nonzeros > 0);
    // The iterations' shares add up to the totals of the Newton run(s) (the round sphere's
    // planar start is not part of them).
    double iterations = 0;
    for (const IterationRecord& h : r.history)
      iterations += h.timings.derivatives + h.timings.assembly + h.timings.factorization + h.timings.solve +
                    h.timings.line_search;
    CHECK(iterations <= sum(t) - t.setup - t.analysis + 1e-9);
  }
}

TEST_CASE("flow: the spherical Newton system is solved exactly (quadratic convergence, no shift, thread invariance)") {
  for (int subdivisions : {3, 4}) {
    CAPTURE(subdivisions);
    const Solved s = prepare(ricci_shapes::icosphere(subdivisions));
    FlowOptions o;
    o.tolerance = 1e-12;
    o.threads = 1;
    const FlowResult one = solve_flow(s.mesh.topology, s.metric.structure, s.metric.u, s.target, o);
    REQUIRE(one.status == Status::Ok);
    CHECK(one.max_curvature_error < 1e-12);
    CHECK(one.iterations - one.chord_steps <= 5);
    for (const std::string& note : one.notes) {
      INFO(note);
      CHECK(note.find("shifted matrix") == std::string::npos);
      CHECK(note.find("direction was unusable") == std::string::npos);
    }
    // Quadratic convergence: once below 1e-3, each Newton step at least squares the error (up to a
    // constant) until rounding; a chord step (the last factor reused) gains at least what the
    // Newton step that made its factor gained, within the flow's own margin (8×).
    double newton_gain = 1;
    for (std::size_t i = 1; i < one.history.size(); ++i) {
      const double before = one.history[i - 1].max_error, after = one.history[i].max_error;
      if (one.history[i].chord) {
        CHECK(after < before);
        if (after > 1e-13) CHECK(after <= 8 * newton_gain * before);
      } else {
        newton_gain = after / before;
        if (before < 1e-3 && after > 1e-13) CHECK(after <= 100 * before * before);
      }
    }
    o.threads = 2;
    const FlowResult two = solve_flow(s.mesh.topology, s.metric.structure, s.metric.u, s.target, o);
    REQUIRE(two.status == Status::Ok);
    REQUIRE(two.u.size() == one.u.size());
    CHECK(std::equal(one.u.begin(), one.u.end(), two.u.begin()));
  }
}

TEST_CASE("flow: spherical targets other than the round sphere converge (indefinite, no Möbius pins)") {
  const Solved s = prepare(ricci_shapes::icosphere(3));
  const Topology& topo = s.mesh.topology;
  // The curvature of a nearby metric: a feasible target whose solution is known.
  const Index nv = topo.num_vertices;
  std::vector<double> u(s.metric.u), l(static_cast<std::size_t>(topo.num_edges)),
      theta(3 * static_cast<std::size_t>(topo.num_faces));
  for (Index v = 0; v < nv; ++v) u[v] += 0.05 * std::sin(0.37 * v);
  REQUIRE(edge_lengths(topo, s.metric.structure, u, l) == kInvalid);
  REQUIRE(corner_angles(topo, Geometry::Spherical, l, theta).violations == 0);
  Target t = s.target;
  vertex_curvature(topo, theta, t.K);
  FlowOptions o;
  o.tolerance = 1e-10;
  const FlowResult r = solve_flow(topo, s.metric.structure, s.metric.u, t, o);
  INFO(r.message);
  CHECK(r.status == Status::Ok);
  CHECK(r.max_curvature_error < 1e-10);
  double du = 0;
  for (Index v = 0; v < nv; ++v) du = std::max(du, std::abs(r.u[v] - u[v]));
  CHECK(du < 1e-6);
}
