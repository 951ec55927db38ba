// Flow solvers: Newton and gradient descent in E, H and S with every scheme; targets with held
// vertices and derived boundary curvature; quadratic convergence; the gauges; invariance under
// vertex permutation and scaling; thread invariance; validation and the failure paths.
#include <doctest/doctest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <utility>

#include "ricci/flow.h"
#include "ricci/intrinsic.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;

namespace {

constexpr double kPi = std::numbers::pi;

const Scheme kSchemes[] = {Scheme::CirclePacking, Scheme::InversiveDistance, Scheme::Yamabe};

struct Problem {
  std::string name;
  Mesh mesh;
  Topology topology;
  InitialMetric metric;
  Target target;
};

Problem make_problem(const std::string& name, const Mesh& input, Geometry g,
                     Scheme scheme = Scheme::CirclePacking, BoundaryMode mode = BoundaryMode::Circle) {
  Problem p;
  p.name = name;
  const ValidateResult v = validate_mesh(input);
  REQUIRE(v.status == Status::Ok);
  p.mesh = v.mesh;
  p.topology = v.topology;
  InitialMetricOptions o;
  o.geometry = g;
  o.scheme = scheme;
  p.metric = initial_metric(p.mesh, p.topology, o);
  REQUIRE_MESSAGE(p.metric.status == Status::Ok, p.metric.message);
  p.target = uniform_target(p.topology, mode);
  return p;
}

// The closed surfaces of the convergence tests: the paper's scheme and the natural geometry.
std::vector<Problem> closed_problems(Scheme scheme = Scheme::CirclePacking) {
  using namespace ricci_shapes;
  std::vector<Problem> out;
  out.push_back(make_problem("torus", torus(24, 12, 2.0, 0.8), Geometry::Euclidean, scheme));
  out.push_back(make_problem("genus-2 pretzel", pretzel(2, 4), Geometry::Hyperbolic, scheme));
  out.push_back(make_problem("genus-3 pretzel", pretzel(3, 4), Geometry::Hyperbolic, scheme));
  out.push_back(make_problem("icosphere", icosphere(3), Geometry::Spherical, scheme));
  return out;
}

FlowResult solve(const Problem& p, const FlowOptions& o = {}) {
  return solve_flow(p.topology, p.metric.structure, p.metric.u, p.target, o);
}

// The problem solved to 1e-12 with a flag of FlowOptions on (first) and off (second).
std::pair<FlowResult, FlowResult> solve_on_and_off(const Problem& p, bool FlowOptions::*flag) {
  FlowOptions on, off;
  on.tolerance = off.tolerance = 1e-12;
  on.*flag = true;
  off.*flag = false;
  return {solve(p, on), solve(p, off)};
}

bool all_finite(const std::vector<double>& x) {
  return std::all_of(x.begin(), x.end(), [](double v) { return std::isfinite(v); });
}

double max_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

double sum(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return s;
}

// Checks that the outputs of a result describe one consistent metric: sizes, finiteness, l and
// K recomputed from u, and the reported error recomputed from K and K_target.
void check_consistent(const Problem& p, const FlowResult& r) {
  const Topology& t = p.topology;
  REQUIRE(r.u.size() == static_cast<std::size_t>(t.num_vertices));
  REQUIRE(r.l.size() == static_cast<std::size_t>(t.num_edges));
  REQUIRE(r.K.size() == static_cast<std::size_t>(t.num_vertices));
  REQUIRE(r.K_target.size() == static_cast<std::size_t>(t.num_vertices));
  CHECK(all_finite(r.u));
  CHECK(all_finite(r.l));
  CHECK(all_finite(r.K));
  CHECK(all_finite(r.K_target));
  CHECK(std::isfinite(r.max_curvature_error));
  CHECK(std::isfinite(r.gauss_bonnet_error));
  std::vector<double> l(t.num_edges), theta(3 * t.num_faces), K(t.num_vertices);
  CHECK(edge_lengths(t, p.metric.structure, r.u, l) == kInvalid);
  CHECK(l == r.l);
  corner_angles(t, p.metric.structure.geometry, l, theta);
  vertex_curvature(t, theta, K);
  CHECK(K == r.K);
  double error = 0;
  for (Index v = 0; v < t.num_vertices; ++v) {
    const bool held = !p.target.fixed_u.empty() && p.target.fixed_u[v];
    if (!held) error = std::max(error, std::abs(r.K_target[v] - r.K[v]));
  }
  CHECK(error == r.max_curvature_error);
  CHECK(static_cast<int>(r.history.size()) == r.iterations);
  for (const IterationRecord& h : r.history) {
    CHECK(std::isfinite(h.max_error));
    CHECK(std::isfinite(h.energy));
    CHECK(h.step > 0);
    CHECK(h.seconds >= 0);
  }
  if (!r.history.empty()) CHECK(r.history.back().max_error == r.max_curvature_error);
}

// Vertex i of `permuted` is vertex map[i] of `original` (positions are unique and copied exactly).
std::vector<Index> vertex_map(const Mesh& original, const Mesh& permuted) {
  std::map<std::array<double, 3>, Index> index;
  for (Index v = 0; v < original.num_vertices(); ++v)
    index[{original.positions[3 * v], original.positions[3 * v + 1], original.positions[3 * v + 2]}] = v;
  std::vector<Index> map(permuted.num_vertices(), kInvalid);
  for (Index v = 0; v < permuted.num_vertices(); ++v) {
    const auto it =
        index.find({permuted.positions[3 * v], permuted.positions[3 * v + 1], permuted.positions[3 * v + 2]});
    REQUIRE(it != index.end());
    map[v] = it->second;
  }
  return map;
}

}  // namespace

TEST_CASE(
    "flow: Newton converges with circle packing on a torus (E) and pretzels of genus 2 and 3 (H) and a "
    "sphere (S)") {
  for (const Problem& p : closed_problems()) {
    INFO(p.name);
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    CHECK(r.status == Status::Ok);
    CHECK(r.max_curvature_error < 1e-10);
    CHECK(r.iterations >= 1);
    CHECK(r.iterations <= 10);
    CHECK(r.gauss_bonnet_error < 1e-9);
    check_consistent(p, r);
    for (double k : r.K_target) CHECK(k == 0);
    CHECK(r.geometry == p.metric.structure.geometry);
    CHECK(r.brief_report().find("ok: " + std::string(geometry_name(r.geometry))) == 0);
    // Newton converges quadratically: the last step gains more than the square of the one before.
    if (r.history.size() >= 2) {
      const double before = r.history[r.history.size() - 2].max_error;
      CHECK(r.history.back().max_error < std::max(100 * before * before, 1e-12));
    }
  }
}

TEST_CASE("flow: the E gauge holds Σu at its start, the S gauge keeps three pinned vertices at their start") {
  const std::vector<Problem> problems = closed_problems();
  const Problem& torus = problems[0];
  const FlowResult e = solve(torus);
  REQUIRE(e.status == Status::Ok);
  CHECK(std::abs(sum(e.u) - sum(torus.metric.u)) < 1e-9);
  CHECK(e.notes.empty());

  // Newton from u0 itself (no planar start): three vertices keep u0, the rest is free.
  const Problem& sphere = problems[3];
  FlowOptions direct;
  direct.spherical_safeguards = false;
  const FlowResult s = solve(sphere, direct);
  REQUIRE_MESSAGE(s.status == Status::Ok, s.message);
  REQUIRE(s.notes.size() >= 1);
  CHECK(s.notes[0].find("Möbius") != std::string::npos);
  Index kept = 0;
  for (Index v = 0; v < sphere.topology.num_vertices; ++v) kept += s.u[v] == sphere.metric.u[v] ? 1 : 0;
  CHECK(kept == 3);
  // Every vertex, pinned or not, meets its curvature condition.
  for (Index v = 0; v < sphere.topology.num_vertices; ++v) CHECK(std::abs(s.K[v]) < 1e-10);

  // The default round-sphere start (the stereographic image of a planar solution) is noted, and
  // it converges at every vertex too.
  const FlowResult d = solve(sphere);
  REQUIRE_MESSAGE(d.status == Status::Ok, d.message);
  REQUIRE(d.notes.size() >= 1);
  CHECK(d.notes[0].find("stereographic") != std::string::npos);
  for (Index v = 0; v < sphere.topology.num_vertices; ++v) CHECK(std::abs(d.K[v]) < 1e-10);
}

TEST_CASE("flow: Newton converges on a disk whose boundary u is held and with circular boundaries") {
  using namespace ricci_shapes;
  {
    const Problem p =
        make_problem("disk", disk(8), Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::FixedLengths);
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    check_consistent(p, r);
    CHECK(r.iterations <= 6);
    Index held = 0;
    for (Index v = 0; v < p.topology.num_vertices; ++v) {
      if (p.topology.is_boundary_vertex(v)) {
        ++held;
        CHECK(r.u[v] == p.metric.u[v]);
      } else {
        CHECK(std::abs(r.K[v]) < 1e-10);
      }
    }
    CHECK(held == p.topology.num_boundary_edges());
  }
  // Circle targets depend on the lengths; Newton includes that dependence and converges
  // quadratically (holding K̄ within a step would take 20–110 steps here, or oscillate).
  for (const auto& [name, mesh] :
       {std::pair<const char*, Mesh>{"disk", disk(6)},
        {"annulus", annulus(4, 24)},
        {"sphere with 3 holes", remove_vertex_stars(icosphere(3), {0, 5, 9})},
        {"sphere with 6 holes", remove_vertex_stars(icosphere(3), {0, 1, 2, 3, 4, 5})}}) {
    INFO(name);
    const Problem p =
        make_problem(name, mesh, Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::Circle);
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.iterations <= 8);
    check_consistent(p, r);
    // The boundary target follows the final lengths: each loop's total, spread by length.
    const Topology& t = p.topology;
    for (Index loop = 0; loop < t.num_boundary_loops(); ++loop) {
      double total = 0;
      for (Index j = t.boundary_offsets[loop]; j < t.boundary_offsets[loop + 1]; ++j)
        total += r.K_target[t.boundary_vertices[j]];
      CHECK(std::abs(total - p.target.loop_total[loop]) < 1e-9);
    }
  }
}

TEST_CASE("flow: loop totals with a single cone converge on a disk (E) and a holed torus (H)") {
  using namespace ricci_shapes;
  {
    // Gauss–Bonnet on a disk: the boundary takes π, the centre vertex the other π.
    Problem p =
        make_problem("disk", disk(6), Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::LoopTotals);
    p.target = single_vertex_target(p.topology, 0, BoundaryMode::LoopTotals);
    p.target.loop_total = {kPi};
    p.target.K[0] = kPi;
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.iterations <= 8);
    check_consistent(p, r);
    CHECK(std::abs(r.K[0] - kPi) < 1e-10);
  }
  {
    Problem p = make_problem("torus with a hole", remove_vertex_stars(torus(12, 6, 2.0, 0.8), {0}),
                             Geometry::Hyperbolic, Scheme::CirclePacking, BoundaryMode::LoopTotals);
    p.target.loop_total = {1.0};  // H: Σ K̄ = 1 > 2πχ = −2π
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.iterations <= 8);
    check_consistent(p, r);
  }
}

TEST_CASE("flow: reaching 1e-12 takes at most two more Newton steps than 1e-10") {
  for (const Problem& p : closed_problems()) {
    INFO(p.name);
    FlowOptions o;
    o.tolerance = 1e-10;
    const FlowResult coarse = solve(p, o);
    o.tolerance = 1e-12;
    const FlowResult fine = solve(p, o);
    REQUIRE(coarse.status == Status::Ok);
    REQUIRE(fine.status == Status::Ok);
    CHECK(fine.max_curvature_error < 1e-12);
    CHECK(fine.iterations <= coarse.iterations + 2);
  }
}

TEST_CASE("flow: gradient descent (the paper's step 3.1) and Newton reach the same metric") {
  using namespace ricci_shapes;
  // (E only: in H the flow needs thousands of steps even on the smallest pretzel; gradient descent
  // in H and S is exercised by the thread-invariance test.)
  const Problem problems[] = {
      make_problem("torus", torus(12, 6, 2.0, 0.8), Geometry::Euclidean),
      make_problem("disk", disk(4), Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::FixedLengths)};
  for (const Problem& p : problems) {
    INFO(p.name);
    const FlowResult newton = solve(p);
    REQUIRE(newton.status == Status::Ok);
    FlowOptions o;
    o.method = Method::GradientDescent;
    o.tolerance = 1e-8;
    o.max_iterations = 20000;
    const FlowResult gd = solve(p, o);
    INFO(gd.brief_report() << " — " << gd.message);
    REQUIRE(gd.status == Status::Ok);
    check_consistent(p, gd);
    CHECK(gd.iterations > newton.iterations);
    for (const IterationRecord& h : gd.history) CHECK(h.step == o.gradient_step);
    // Both hold Σu at its start in E (or the boundary u), so the same u, not only up to a constant.
    CHECK(max_abs_difference(gd.u, newton.u) < 1e-6);
    // The energy decreases along the flow.
    for (std::size_t i = 1; i < gd.history.size(); ++i)
      CHECK(gd.history[i].energy <= gd.history[i - 1].energy + 1e-15);
    // (Gradient descent records the energy by the trapezoidal rule, Newton by quadrature.)
    CHECK(std::abs(gd.history.back().energy - newton.history.back().energy) < 1e-4);
  }
}

TEST_CASE("flow: one gradient descent step is u + ε(K̄ − K) with the mean of the update removed in E") {
  const Problem p = make_problem("torus", ricci_shapes::torus(9, 6, 2.0, 0.8), Geometry::Euclidean);
  FlowOptions o;
  o.method = Method::GradientDescent;
  o.gradient_step = 0.03;
  o.max_iterations = 1;
  const FlowResult r = solve(p, o);
  CHECK(r.status == Status::NotConverged);
  REQUIRE(r.iterations == 1);
  const Topology& t = p.topology;
  std::vector<double> l(t.num_edges), theta(3 * t.num_faces), K(t.num_vertices);
  edge_lengths(t, p.metric.structure, p.metric.u, l);
  corner_angles(t, Geometry::Euclidean, l, theta);
  vertex_curvature(t, theta, K);
  std::vector<double> update(t.num_vertices);
  double mean = 0;
  for (Index v = 0; v < t.num_vertices; ++v) mean += (update[v] = 0.03 * (0 - K[v])) / t.num_vertices;
  for (Index v = 0; v < t.num_vertices; ++v)
    CHECK(std::abs(r.u[v] - (p.metric.u[v] + update[v] - mean)) < 1e-15);
}

TEST_CASE("flow: the euclidean result is invariant under vertex permutation") {
  const Problem p = make_problem("torus", ricci_shapes::torus(16, 8, 2.0, 0.7), Geometry::Euclidean);
  const FlowResult r = solve(p);
  REQUIRE(r.status == Status::Ok);
  ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const Problem q =
        make_problem("permuted torus", ricci_shapes::permute_vertices(p.mesh, rng), Geometry::Euclidean);
    const FlowResult s = solve(q);
    REQUIRE(s.status == Status::Ok);
    const std::vector<Index> map = vertex_map(p.mesh, q.mesh);
    double worst = 0;
    for (Index v = 0; v < q.topology.num_vertices; ++v)
      worst = std::max(worst, std::abs(s.u[v] - r.u[map[v]]));
    CHECK(worst < 1e-9);
  });
}

TEST_CASE("flow: the euclidean result is invariant under global scaling (u shifts by log scale)") {
  const Problem p = make_problem("torus", ricci_shapes::torus(16, 8, 2.0, 0.7), Geometry::Euclidean);
  const FlowResult r = solve(p);
  REQUIRE(r.status == Status::Ok);
  for (double scale : {0.01, 3.7, 250.0}) {
    CAPTURE(scale);
    Mesh scaled = p.mesh;
    for (double& x : scaled.positions) x *= scale;
    const Problem q = make_problem("scaled torus", scaled, Geometry::Euclidean);
    const FlowResult s = solve(q);
    REQUIRE(s.status == Status::Ok);
    CHECK(s.iterations == r.iterations);
    double worst_u = 0, worst_l = 0;
    for (Index v = 0; v < p.topology.num_vertices; ++v)
      worst_u = std::max(worst_u, std::abs(s.u[v] - r.u[v] - std::log(scale)));
    for (Index e = 0; e < p.topology.num_edges; ++e)
      worst_l = std::max(worst_l, std::abs(s.l[e] / (scale * r.l[e]) - 1));
    CHECK(worst_u < 1e-9);
    CHECK(worst_l < 1e-9);
  }
}

TEST_CASE("flow: thread counts past the processors are clamped, never a crash") {
  const int saved = omp_get_max_threads();
  const int available = available_threads();
  CHECK(available >= 1);
  const Problem p = closed_problems().front();
  FlowOptions o;
  o.threads = 1;
  const FlowResult one = solve(p, o);
  REQUIRE(one.status == Status::Ok);
  // A count no system can start (it crashed the OpenMP runtime before).
  o.threads = 1000000;
  const FlowResult many = solve(p, o);
  CHECK(many.status == Status::Ok);
  CHECK(many.u == one.u);
  CHECK(omp_get_max_threads() == saved);
  // The same through the OpenMP default (OMP_NUM_THREADS or omp_set_num_threads()).
  omp_set_num_threads(available + 7);
  o.threads = 0;
  const FlowResult fallback = solve(p, o);
  CHECK(fallback.status == Status::Ok);
  CHECK(fallback.u == one.u);
  CHECK(cap_default_threads() == available + 7);
  CHECK(omp_get_max_threads() == available);
  CHECK(cap_default_threads() == 0);
  omp_set_num_threads(saved);
}

TEST_CASE("flow: results are bitwise identical for 1 and 2 threads") {
  const int saved = omp_get_max_threads();
  std::vector<Problem> problems = closed_problems();
  problems.push_back(make_problem("disk", ricci_shapes::disk(6), Geometry::Euclidean));
  for (const Problem& p : problems) {
    for (Method method : {Method::Newton, Method::GradientDescent}) {
      INFO(p.name << (method == Method::Newton ? " newton" : " gradient descent"));
      FlowOptions o;
      o.method = method;
      if (method == Method::GradientDescent) o.max_iterations = 20;
      o.threads = 1;
      const FlowResult one = solve(p, o);
      CHECK(omp_get_max_threads() == saved);  // restored
      o.threads = 2;
      const FlowResult two = solve(p, o);
      CHECK(omp_get_max_threads() == saved);
      CHECK(one.status == two.status);
      CHECK(one.iterations == two.iterations);
      CHECK(one.u == two.u);
      CHECK(one.l == two.l);
      CHECK(one.K == two.K);
      CHECK(one.K_target == two.K_target);
      CHECK(one.gauss_bonnet_error == two.gauss_bonnet_error);
      REQUIRE(one.history.size() == two.history.size());
      for (std::size_t i = 0; i < one.history.size(); ++i) {
        CHECK(one.history[i].max_error == two.history[i].max_error);
        CHECK(one.history[i].energy == two.history[i].energy);
        CHECK(one.history[i].step == two.history[i].step);
      }
    }
  }
}

TEST_CASE("flow: every scheme converges in E and H and S on a small closed mesh") {
  for (Scheme scheme : kSchemes) {
    for (const Problem& p : closed_problems(scheme)) {
      if (p.name == "genus-3 pretzel") continue;
      INFO(p.name << " " << scheme_name(scheme));
      const FlowResult r = solve(p);
      INFO(r.brief_report() << " — " << r.message);
      CHECK(r.status == Status::Ok);
      CHECK(r.max_curvature_error < 1e-10);
      CHECK(r.iterations <= 12);
      check_consistent(p, r);
    }
  }
}

TEST_CASE("flow: an infeasible target returns InfeasibleTarget and no metric") {
  for (const Problem& p : closed_problems()) {
    INFO(p.name);
    Target target = p.target;
    // E: Σ K̄ must equal 2πχ; H: exceed it; S: stay below it. Put 2πχ ± 1 at vertex 0.
    const double chi = static_cast<double>(p.topology.euler_characteristic());
    switch (p.metric.structure.geometry) {
      case Geometry::Euclidean:
        target.K[0] = 0.5;
        break;
      case Geometry::Hyperbolic:
        target.K[0] = 2 * kPi * chi - 1;
        break;
      case Geometry::Spherical:
        target.K[0] = 2 * kPi * chi + 1 - 2 * kPi;
        target.K[1] = 2 * kPi - 1e-3;
        break;
    }
    const FlowResult r = solve_flow(p.topology, p.metric.structure, p.metric.u, target);
    CHECK(r.status == Status::InfeasibleTarget);
    CHECK(!r.message.empty());
    CHECK(r.u.empty());
    CHECK(r.iterations == 0);
    CHECK(r.brief_report().find("infeasible_target") == 0);
  }
  // A cone angle that is not positive.
  const Problem p = closed_problems()[0];
  Target target = p.target;
  target.K[0] = 2 * kPi;
  target.K[1] = -2 * kPi;
  CHECK(solve_flow(p.topology, p.metric.structure, p.metric.u, target).status == Status::InfeasibleTarget);
}

TEST_CASE("flow: NotConverged and LineSearchFailed return the last finite iterate") {
  const Problem p = closed_problems()[1];  // genus 2, H
  {
    FlowOptions o;
    o.max_iterations = 0;
    const FlowResult r = solve(p, o);
    CHECK(r.status == Status::NotConverged);
    CHECK(r.iterations == 0);
    CHECK(r.u == p.metric.u);
    check_consistent(p, r);
  }
  {
    FlowOptions o;
    o.max_iterations = 2;
    const FlowResult r = solve(p, o);
    CHECK(r.status == Status::NotConverged);
    CHECK(r.iterations == 2);
    CHECK(r.message.find("iteration limit") != std::string::npos);
    check_consistent(p, r);
    CHECK(r.max_curvature_error < r.history[0].max_error);
  }
  {
    // Below the rounding level of the curvatures no step can be ranked: the tolerance is raised
    // to that level, with a note.
    FlowOptions o;
    o.tolerance = 1e-300;
    const FlowResult r = solve(p, o);
    INFO(r.message);
    CHECK(r.status == Status::Ok);
    bool noted = false;
    for (const std::string& n : r.notes) noted = noted || n.find("below the rounding level of the curvatures") != std::string::npos;
    CHECK(noted);
    CHECK(r.max_curvature_error < 1e-12);
    check_consistent(p, r);
  }
  {
    // Vertex scaling cannot open the centre of a disk to a cone angle of 2π + 9 without breaking
    // triangles: the line search rejects every trial that violates a triangle inequality.
    Problem q = make_problem("disk", ricci_shapes::disk(5), Geometry::Euclidean, Scheme::Yamabe,
                             BoundaryMode::FixedLengths);
    q.target.K[0] = -9;
    const FlowResult r = solve(q);
    INFO(r.brief_report() << " — " << r.message);
    CHECK(r.status == Status::LineSearchFailed);
    CHECK(r.message.find("triangle") != std::string::npos);
    check_consistent(q, r);
  }
}

TEST_CASE("flow: options and inputs are validated before any iteration") {
  std::string why;
  CHECK(FlowOptions{}.is_valid(&why));
  auto invalid = [](auto change) {
    FlowOptions o;
    change(o);
    std::string text;
    const bool ok = o.is_valid(&text);
    CHECK(!text.empty());
    return !ok;
  };
  CHECK(invalid([](FlowOptions& o) { o.tolerance = 0; }));
  CHECK(invalid([](FlowOptions& o) { o.tolerance = std::nan(""); }));
  CHECK(invalid([](FlowOptions& o) { o.max_iterations = -1; }));
  CHECK(invalid([](FlowOptions& o) { o.gradient_step = 0; }));
  CHECK(invalid([](FlowOptions& o) { o.gradient_step = INFINITY; }));
  CHECK(invalid([](FlowOptions& o) { o.threads = -2; }));
  CHECK(invalid([](FlowOptions& o) { o.polish_steps = -1; }));
  CHECK(invalid([](FlowOptions& o) { o.method = static_cast<Method>(7); }));
  FlowOptions large_step;
  large_step.gradient_step = 0.5;  // above the paper's 0.05, but allowed
  CHECK(large_step.is_valid(nullptr));

  const Problem p = closed_problems()[1];
  FlowOptions bad;
  bad.tolerance = -1;
  FlowResult r = solve(p, bad);
  CHECK(r.status == Status::InvalidArgument);
  CHECK(r.message.find("tolerance") != std::string::npos);
  CHECK(r.u.empty());

  std::vector<double> u = p.metric.u;
  u.pop_back();
  CHECK(solve_flow(p.topology, p.metric.structure, u, p.target).status == Status::InvalidArgument);
  u = p.metric.u;
  u[3] = std::nan("");
  CHECK(solve_flow(p.topology, p.metric.structure, u, p.target).status == Status::InvalidArgument);
  u = p.metric.u;
  u[3] = 0.1;  // a hyperbolic radius tanh(γ/2) must be below 1: u < 0
  r = solve_flow(p.topology, p.metric.structure, u, p.target);
  CHECK(r.status == Status::InvalidArgument);
  CHECK(r.u.empty());
  ConformalStructure s = p.metric.structure;
  s.eta.pop_back();
  CHECK(solve_flow(p.topology, s, p.metric.u, p.target).status == Status::InvalidArgument);
  Target t = p.target;
  t.K.push_back(0);
  CHECK(solve_flow(p.topology, p.metric.structure, p.metric.u, t).status == Status::InvalidArgument);
  t = p.target;
  t.fixed_u.assign(3, 1);
  CHECK(solve_flow(p.topology, p.metric.structure, p.metric.u, t).status == Status::InvalidArgument);

  FlowResult not_run;
  CHECK(not_run.status == Status::NotRun);
  CHECK(not_run.brief_report().find("not_run") == 0);
}

TEST_CASE("flow: a starting metric that violates a triangle inequality is reported and not iterated") {
  Problem p = make_problem("disk", ricci_shapes::disk(3), Geometry::Euclidean, Scheme::Yamabe,
                           BoundaryMode::FixedLengths);
  std::vector<double> u = p.metric.u;
  u[0] = -8;  // shrinks every edge at the centre: the opposite rim edges become too long
  const FlowResult r = solve_flow(p.topology, p.metric.structure, u, p.target);
  CHECK(r.status == Status::TriangleInequality);
  CHECK(r.iterations == 0);
  CHECK(r.u == u);
  CHECK(all_finite(r.K));
  CHECK(all_finite(r.l));
}

TEST_CASE("flow: on_iteration sees every history record as it is made") {
  const Problem p = closed_problems()[1];
  std::vector<IterationRecord> seen;
  FlowOptions o;
  o.on_iteration = [&](const IterationRecord& record) { seen.push_back(record); };
  const FlowResult r = solve(p, o);
  REQUIRE(r.status == Status::Ok);
  REQUIRE(seen.size() == r.history.size());
  for (std::size_t i = 0; i < seen.size(); ++i) {
    CHECK(seen[i].iteration == static_cast<int>(i) + 1);
    CHECK(seen[i].max_error == r.history[i].max_error);
    CHECK(seen[i].energy == r.history[i].energy);
    if (i > 0) CHECK(seen[i].seconds >= seen[i - 1].seconds);
  }
  CHECK(r.seconds >= seen.back().seconds);
  // The energy decreases along Newton steps in H (convex energy).
  for (std::size_t i = 1; i < seen.size(); ++i) CHECK(seen[i].energy <= seen[i - 1].energy);
}

TEST_CASE("flow: a disk maps to a rectangle — four corners of curvature π/2, straight sides elsewhere") {
  using namespace ricci_shapes;
  const Problem base =
      make_problem("disk", disk(8), Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::Free);
  const Topology& t = base.topology;
  REQUIRE(t.num_boundary_loops() == 1);
  const Index begin = t.boundary_offsets[0], n = t.boundary_offsets[1] - begin;
  REQUIRE(n >= 8);
  for (const Index shift : {Index{0}, n / 8}) {
    CAPTURE(shift);
    // Corners a quarter of the loop apart (by vertex count), starting at `shift`.
    std::vector<Index> corners;
    for (int k = 0; k < 4; ++k) corners.push_back(begin + (shift + k * n / 4) % n);
    Problem p = base;
    for (Index v = 0; v < t.num_vertices; ++v) p.target.K[v] = 0;
    for (Index c : corners) p.target.K[t.boundary_vertices[c]] = kPi / 2;
    REQUIRE(check_target(t, p.metric.structure, p.target).status == Status::Ok);
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    check_consistent(p, r);
    CHECK(r.max_curvature_error < 1e-10);
    CHECK(r.iterations <= 10);
    // Boundary turning angles: π/2 at the corners, 0 elsewhere. A closed polygon with four right
    // turns and straight sides is a rectangle: opposite sides have equal length.
    std::array<double, 4> side{};
    for (int k = 0; k < 4; ++k) {
      const Index from = corners[k] - begin, to = corners[(k + 1) % 4] - begin;
      for (Index j = from; j != to; j = (j + 1) % n)
        side[k] += r.l[t.corner_edge[t.boundary_corners[begin + j]]];
    }
    CHECK(std::abs(side[0] - side[2]) < 1e-9 * (side[0] + side[2]));
    CHECK(std::abs(side[1] - side[3]) < 1e-9 * (side[1] + side[3]));
    for (Index j = begin; j < begin + n; ++j) {
      const Index v = t.boundary_vertices[j];
      const bool corner = std::find(corners.begin(), corners.end(), j) != corners.end();
      CHECK(std::abs(r.K[v] - (corner ? kPi / 2 : 0.0)) < 1e-10);
    }
  }
}

TEST_CASE("flow: valence-3 vertices in obtuse triangles — infeasible with Step 2's angles, solved after relaxing") {
  using namespace ricci_shapes;
  ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    // Splitting split faces again makes valence-3 vertices inside thin, obtuse triangles.
    const ValidateResult v =
        validate_mesh(split_random_faces(split_random_faces(torus(16, 8, 2.0, 0.8), rng, 0.3), rng, 0.3));
    REQUIRE(v.status == Status::Ok);
    const Target target = uniform_target(v.topology, BoundaryMode::Free);
    InitialMetricOptions strict;
    strict.relax_angles = false;
    const InitialMetric step2 = initial_metric(v.mesh, v.topology, strict);
    REQUIRE(step2.status == Status::Ok);
    const FlowResult infeasible = solve_flow(v.topology, step2.structure, step2.u, target);
    CHECK(infeasible.status == Status::InfeasibleTarget);
    CHECK(infeasible.message.find("Theorem 4") != std::string::npos);
    CHECK(infeasible.u.empty());

    const InitialMetric relaxed = initial_metric(v.mesh, v.topology, {});
    REQUIRE(relaxed.status == Status::Ok);
    CHECK(relaxed.edges_relaxed > 0);
    const FlowResult r = solve_flow(v.topology, relaxed.structure, relaxed.u, target);
    INFO(r.brief_report() << " — " << r.message);
    CHECK(r.status == Status::Ok);
    CHECK(r.max_curvature_error < 1e-10);
    CHECK(r.iterations <= 15);
  });
}

TEST_CASE("flow: S safeguards — a planar start for the round sphere, a continuation for other targets") {
  using namespace ricci_shapes;
  auto ellipsoid = [](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    Mesh m = icosphere(3);
    for (std::size_t i = 0; i < m.positions.size(); i += 3) {  // elongated and flattened
      m.positions[i] *= 3.0;
      m.positions[i + 1] *= 0.5;
    }
    return flip_random_edges(split_random_faces(m, rng, 0.3), rng, 0.3);
  };
  FlowOptions plain;
  plain.spherical_safeguards = false;
  int rescued_round = 0, rescued_cones = 0;
  for (std::uint64_t seed : {2, 4}) {
    CAPTURE(seed);
    const Problem p = make_problem("ellipsoid", ellipsoid(seed), Geometry::Spherical);
    // The round sphere.
    const FlowResult d = solve(p, plain);
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    check_consistent(p, r);
    CHECK(r.iterations <= 10);
    bool planar = false;
    for (const std::string& n : r.notes) planar = planar || n.find("stereographic image of a planar") != std::string::npos;
    CHECK(planar);
    rescued_round += d.status != Status::Ok ? 1 : 0;
    // Cone targets (no Möbius freedom): curvature 0.05 at every 25th vertex, 0 elsewhere.
    Problem q = p;
    for (Index v = 0; v < q.topology.num_vertices; ++v) q.target.K[v] = v % 25 == 0 ? 0.05 : 0.0;
    const FlowResult dc = solve(q, plain);
    const FlowResult rc = solve(q);
    INFO(rc.brief_report() << " — " << rc.message);
    REQUIRE(rc.status == Status::Ok);
    check_consistent(q, rc);
    CHECK(rc.iterations <= FlowOptions{}.max_iterations);
    if (dc.status != Status::Ok) {
      ++rescued_cones;
      REQUIRE(!rc.notes.empty());
      CHECK(rc.notes.front().find("continuation") != std::string::npos);
    }
    // History records are numbered in order across the stages.
    for (std::size_t i = 0; i < rc.history.size(); ++i) CHECK(rc.history[i].iteration == static_cast<int>(i) + 1);
  }
  // Newton from Step 2's radii alone stalls on these surfaces: both safeguards are exercised.
  CHECK(rescued_round > 0);
  CHECK(rescued_cones > 0);
}

namespace {

/// A disk bent into a saddle: its map to the unit disk is far from the identity.
Mesh bent_disk() {
  Mesh bent = ricci_shapes::disk(20);
  for (std::size_t i = 0; i < bent.positions.size(); i += 3) {
    const double x = bent.positions[i], y = bent.positions[i + 1];
    bent.positions[i + 2] = 0.6 * (x * x - 0.5 * y * y) + 0.3 * x;
  }
  return bent;
}

/// Largest relative deviation of a loop's K̄ from the inscribed polygon's ±(α_in + α_out)/2.
double inscribed_deviation(const Topology& t, const FlowResult& r, Index loop, double total) {
  const InscribedCircle circle = inscribed_circle(t, loop, r.l);
  REQUIRE(circle.radius > 0);
  const double sign = total > 0 ? 1.0 : -1.0;
  const Index b = t.boundary_offsets[loop], e = t.boundary_offsets[loop + 1];
  double worst = 0;
  for (Index j = b; j < e; ++j) {
    const Index before = j > b ? j - 1 : e - 1;
    const double in = circle.arc(before - b, r.l[t.corner_edge[t.boundary_corners[before]]]);
    const double out = circle.arc(j - b, r.l[t.corner_edge[t.boundary_corners[j]]]);
    const double inscribed = sign * 0.5 * (in + out);
    worst = std::max(worst, std::abs(r.K_target[t.boundary_vertices[j]] - inscribed) / std::abs(inscribed));
  }
  return worst;
}

}  // namespace

TEST_CASE("flow: circle domains are Möbius-normalized — few Newton steps, loop totals kept, small modes") {
  using namespace ricci_shapes;
  const Mesh bent = bent_disk();
  for (const auto& [name, mesh] : {std::pair<const char*, Mesh>{"bent disk", bent},
                                   {"annulus", annulus(6, 32)},
                                   {"sphere with 3 holes", remove_vertex_stars(icosphere(3), {0, 5, 9})}}) {
    CAPTURE(name);
    const Problem p = make_problem(name, mesh, Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::Circle);
    const Topology& t = p.topology;
    const FlowResult r = solve(p);
    INFO(r.brief_report() << " — " << r.message);
    REQUIRE(r.status == Status::Ok);
    check_consistent(p, r);
    CHECK(r.iterations <= 6);
    bool noted = false;
    for (const std::string& n : r.notes) noted = noted || n.find("Möbius normalization") != std::string::npos;
    CHECK(noted);
    // Every loop keeps its total; the inner loops are exactly inscribed polygons
    // (K̄ = −(α_in + α_out)/2, α = 2·arcsin(l/2R)); the outer loop deviates from its inscribed
    // target by a small zero-sum amount (the normalization's modes).
    for (Index loop = 0; loop < t.num_boundary_loops(); ++loop) {
      const double worst = inscribed_deviation(t, r, loop, p.target.loop_total[loop]);
      double total = 0;
      for (Index j = t.boundary_offsets[loop]; j < t.boundary_offsets[loop + 1]; ++j) total += r.K_target[t.boundary_vertices[j]];
      CHECK(std::abs(total - p.target.loop_total[loop]) < 1e-9);
      if (p.target.loop_total[loop] > 0) {
        CHECK(worst < 0.02);
      } else {
        CHECK(worst < 1e-12);
      }
    }
  }
  // Without the normalization the same bent disk converges to the inscribed-polygon target
  // exactly on every loop (one member of the Möbius family).
  const Problem p = make_problem("bent disk", bent, Geometry::Euclidean, Scheme::CirclePacking, BoundaryMode::Circle);
  FlowOptions exact;
  exact.normalize_circle_domains = false;
  const FlowResult free_gauge = solve(p, exact);
  INFO(free_gauge.brief_report() << " — " << free_gauge.message);
  REQUIRE(free_gauge.status == Status::Ok);
  for (Index loop = 0; loop < p.topology.num_boundary_loops(); ++loop)
    CHECK(inscribed_deviation(p.topology, free_gauge, loop, p.target.loop_total[loop]) < 1e-12);
}

TEST_CASE("flow: vertex scaling's split coupling takes the boundary system's Newton steps, on every loop kind") {
  using namespace ricci_shapes;
  // The split (the target's loop-local derivative in the Newton matrix, one rank-one term per loop,
  // soft pins along the positive loops) solves the same Newton system as the boundary system of
  // the size of the boundary: the same solution, on a disk, an annulus, spheres with 3
  // and 8 holes (circle domains, with the Möbius bordering), loop totals with a cone (E) and in H.
  const Mesh bent = bent_disk();
  std::vector<Problem> problems;
  problems.push_back(make_problem("bent disk", bent, Geometry::Euclidean, Scheme::Yamabe, BoundaryMode::Circle));
  problems.push_back(make_problem("annulus", annulus(6, 32), Geometry::Euclidean, Scheme::Yamabe, BoundaryMode::Circle));
  problems.push_back(make_problem("sphere with 3 holes", remove_vertex_stars(icosphere(3), {0, 5, 9}),
                                  Geometry::Euclidean, Scheme::Yamabe, BoundaryMode::Circle));
  problems.push_back(make_problem("sphere with 8 holes", remove_vertex_stars(icosphere(3), {0, 21, 63, 84, 126, 147, 168, 210}),
                                  Geometry::Euclidean, Scheme::Yamabe, BoundaryMode::Circle));
  Problem cone = make_problem("disk, loop total and a cone", disk(6), Geometry::Euclidean, Scheme::Yamabe,
                              BoundaryMode::LoopTotals);
  cone.target = single_vertex_target(cone.topology, 0, BoundaryMode::LoopTotals);
  cone.target.loop_total = {kPi};
  cone.target.K[0] = kPi;
  problems.push_back(cone);
  Problem holed = make_problem("torus with a hole (H)", remove_vertex_stars(torus(12, 6, 2.0, 0.8), {0}),
                               Geometry::Hyperbolic, Scheme::Yamabe, BoundaryMode::LoopTotals);
  holed.target.loop_total = {1.0};
  problems.push_back(holed);
  for (const Problem& p : problems) {
    CAPTURE(p.name);
    const auto [a, b] = solve_on_and_off(p, &FlowOptions::split_loop_coupling);
    INFO(a.brief_report() << " — " << a.message);
    INFO(b.brief_report() << " — " << b.message);
    REQUIRE(a.status == Status::Ok);
    REQUIRE(b.status == Status::Ok);
    check_consistent(p, a);
    CHECK(a.iterations <= b.iterations + 1);
    CHECK(max_abs_difference(a.u, b.u) < 1e-9);
    CHECK(max_abs_difference(a.K_target, b.K_target) < 1e-9);
    for (const std::string& n : a.notes) {
      CHECK(n.find("split of the length-dependent target") == std::string::npos);
      CHECK(n.find("boundary system") == std::string::npos);
    }
    // The same Newton steps: the boundary system's GMRES stops at a forcing of 1 % of the error
    // (inexact Newton), the split solves exactly, so the first errors agree to a few per cent.
    for (std::size_t i = 0; i < std::min(a.history.size(), b.history.size()) && i < 2; ++i)
      CHECK(a.history[i].max_error == doctest::Approx(b.history[i].max_error).epsilon(0.05));
  }
}

TEST_CASE("flow: an ear on a boundary loop with a negative or zero target is infeasible, named") {
  using namespace ricci_shapes;
  // An annulus with one extra triangle glued onto an inner boundary edge makes an ear: a boundary
  // vertex in a single triangle, whose curvature π − θ is always positive.
  const ValidateResult base = validate_mesh(annulus(3, 16));
  REQUIRE(base.status == Status::Ok);
  Mesh m = base.mesh;
  const Topology& bt = base.topology;
  Index inner = kInvalid;
  for (Index loop = 0; loop < bt.num_boundary_loops(); ++loop)
    if (inner == kInvalid || bt.boundary_offsets[loop + 1] - bt.boundary_offsets[loop] <
                                 bt.boundary_offsets[inner + 1] - bt.boundary_offsets[inner])
      inner = loop;
  const Index j = bt.boundary_offsets[inner];
  const Index a = bt.boundary_vertices[j], b = bt.boundary_vertices[j + 1];
  // The ear's apex: the midpoint of a and b pushed towards the hole's centre (the origin).
  const Index apex = m.num_vertices();
  for (int k = 0; k < 3; ++k) m.positions.push_back(0.4 * (m.positions[3 * a + k] + m.positions[3 * b + k]));
  // The boundary runs a → b with the surface on the left, so the new face is (b, a, apex).
  m.faces.insert(m.faces.end(), {b, a, apex});
  const ValidateResult v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  InitialMetricOptions o;
  const InitialMetric im = initial_metric(v.mesh, v.topology, o);
  REQUIRE(im.status == Status::Ok);
  for (const BoundaryMode mode : {BoundaryMode::Circle, BoundaryMode::Free}) {
    CAPTURE(static_cast<int>(mode));
    Target target = uniform_target(v.topology, mode);  // Free: K̄ = 0 on the boundary
    if (mode == BoundaryMode::Circle) {
      // The ear's loop is the inner circle (−2π), the other the outer one (+2π).
      const Topology& t = v.topology;
      for (Index loop = 0; loop < t.num_boundary_loops(); ++loop) {
        bool has_apex = false;
        for (Index k = t.boundary_offsets[loop]; k < t.boundary_offsets[loop + 1]; ++k)
          has_apex = has_apex || t.boundary_vertices[k] == apex;
        target.loop_total[loop] = has_apex ? -2 * kPi : 2 * kPi;
      }
    }
    const TargetCheck c = check_target(v.topology, im.structure, target);
    CHECK(c.status == Status::InfeasibleTarget);
    CHECK(c.element == Element::Vertex);
    CHECK(c.element_index == apex);
    CHECK(c.message.find("single triangle") != std::string::npos);
    const FlowResult r = solve_flow(v.topology, im.structure, im.u, target);
    CHECK(r.status == Status::InfeasibleTarget);
    CHECK(r.u.empty());
    if (mode == BoundaryMode::Free) {
      target.K[apex] = 0.5;  // a positive target at the ear passes this check
      const TargetCheck positive = check_target(v.topology, im.structure, target);
      CHECK(positive.message.find("single triangle") == std::string::npos);
    }
  }
}

TEST_CASE("flow: Newton's recorded energy (E, H) matches a fine quadrature of the Ricci energy") {
  // The energy is path independent (∂K_i/∂u_j is symmetric), so E(u_end) − E(u_start) is the
  // integral of (K − K̄)·(u_end − u_start) along the straight segment: composite Simpson with 200
  // panels against the line search's per-step estimates (Hermite or Gauss–Lobatto), summed. The
  // Hermite estimate is used when it agrees with a lower-degree rule to 10 %; its actual error is
  // far smaller (0.1 % on the first, far-from-solution step in H, 1e-7 from the third on).
  for (std::size_t k : {std::size_t{0}, std::size_t{1}, std::size_t{2}}) {
    const Problem p = closed_problems()[k];
    INFO(p.name);
    const FlowResult r = solve(p);
    REQUIRE(r.status == Status::Ok);
    const Topology& t = p.topology;
    const std::vector<double>& u0 = p.metric.u;
    std::vector<double> u(u0.size()), l(static_cast<std::size_t>(t.num_edges)),
        theta(3 * static_cast<std::size_t>(t.num_faces)), K(u0.size());
    auto f = [&](double s) {
      for (std::size_t i = 0; i < u.size(); ++i) u[i] = u0[i] + s * (r.u[i] - u0[i]);
      REQUIRE(edge_lengths(t, p.metric.structure, u, l) == kInvalid);
      REQUIRE(corner_angles(t, p.metric.structure.geometry, l, theta).violations == 0);
      vertex_curvature(t, theta, K);
      double sum = 0;
      for (std::size_t i = 0; i < u.size(); ++i) sum += (K[i] - p.target.K[i]) * (r.u[i] - u0[i]);
      return sum;
    };
    constexpr int kPanels = 200;
    double integral = f(0) + f(1);
    for (int i = 1; i < 2 * kPanels; ++i) integral += (i % 2 ? 4 : 2) * f(i / (2.0 * kPanels));
    integral /= 6.0 * kPanels;
    INFO("recorded " << r.history.back().energy << ", quadrature " << integral);
    CHECK(std::abs(r.history.back().energy - integral) <= 3e-3 * std::abs(integral));
  }
}

TEST_CASE("flow: polishing steps continue the same solve and never raise the error") {
  // Up to two Newton steps after the tolerance, within the solve: the trajectory up to the
  // tolerance is the plain solve's, bit for bit; every kept step lowers the maximal error; a note
  // reports what the polishing did. A loose tolerance leaves room for it.
  for (const Problem& p : closed_problems()) {
    INFO(p.name);
    FlowOptions plain_options;
    plain_options.tolerance = 1e-7;
    FlowOptions polish_options = plain_options;
    polish_options.polish_steps = 2;
    const FlowResult plain = solve(p, plain_options);
    const FlowResult polished = solve(p, polish_options);
    REQUIRE(plain.status == Status::Ok);
    REQUIRE(polished.status == Status::Ok);
    CHECK(polished.message == plain.message);
    REQUIRE(polished.iterations >= plain.iterations);
    CHECK(polished.iterations <= plain.iterations + 2);
    REQUIRE(polished.history.size() == static_cast<std::size_t>(polished.iterations));
    for (int i = 0; i < plain.iterations; ++i) CHECK(polished.history[i].max_error == plain.history[i].max_error);
    for (int i = plain.iterations; i < polished.iterations; ++i)
      CHECK(polished.history[i].max_error < (i == 0 ? INFINITY : polished.history[i - 1].max_error));
    CHECK(polished.max_curvature_error <= plain.max_curvature_error);
    const bool noted = std::any_of(polished.notes.begin(), polished.notes.end(),
                                   [](const std::string& n) { return n.find("polished by") != std::string::npos; });
    CHECK(noted == (polished.iterations > plain.iterations));
    // From an error above 1e-10, Newton's next step reaches the rounding level: the polish runs.
    if (plain.max_curvature_error > 1e-10) {
      CHECK(polished.iterations > plain.iterations);
      CHECK(polished.max_curvature_error < 1e-12);
    }
    INFO("plain " << plain.iterations << " it, " << plain.max_curvature_error << "; polished " << polished.iterations
                  << " it, " << polished.max_curvature_error);
    CHECK(all_finite(polished.u));
    // At the rounding level of the curvatures (K̄ = 0 here) no polishing step is attempted: a solve
    // from the polished metric takes no step at all. (S starts from a planar solve instead of u0.)
    if (p.metric.structure.geometry != Geometry::Spherical &&
        polished.max_curvature_error <= 4 * std::numeric_limits<double>::epsilon() * 4 * std::numbers::pi) {
      const FlowResult again = solve_flow(p.topology, p.metric.structure, polished.u, p.target, polish_options);
      CHECK(again.status == Status::Ok);
      CHECK(again.iterations == 0);
      CHECK(again.max_curvature_error == polished.max_curvature_error);
    }
  }
}

TEST_CASE("flow: chord steps reach the Newton-only solution with no more factorizations, to the rounding level") {
  // Circle packing on a fine torus (E), a genus-2 pretzel (H) and a squashed sphere (S); vertex
  // scaling with circle boundaries (the split coupling) on a disk with intrinsic flips.
  using namespace ricci_shapes;
  std::vector<Problem> problems;
  problems.push_back(make_problem("torus 160x80", torus(160, 80, 3.0, 1.0), Geometry::Euclidean));
  problems.push_back(make_problem("pretzel(2, 8)", pretzel(2, 8), Geometry::Hyperbolic));
  problems.push_back(make_problem("icosphere(4)", icosphere(4), Geometry::Spherical));
  int chords = 0;
  for (const Problem& p : problems) {
    INFO(p.name);
    const auto [a, b] = solve_on_and_off(p, &FlowOptions::chord_steps);
    REQUIRE_MESSAGE(a.status == Status::Ok, a.message);
    REQUIRE_MESSAGE(b.status == Status::Ok, b.message);
    CHECK(b.chord_steps == 0);
    CHECK(a.iterations - a.chord_steps <= b.iterations);  // full Newton steps: never more
    CHECK(max_abs_difference(a.u, b.u) < 1e-9);
    // A run of chord steps goes on to the rounding level, where the Newton step would have ended.
    if (a.chord_steps > 0 && a.history.back().chord) CHECK(a.max_curvature_error < 1e-13);
    int in_history = 0;
    for (const IterationRecord& h : a.history) in_history += h.chord ? 1 : 0;
    CHECK(in_history == a.chord_steps);
    chords += a.chord_steps;
    MESSAGE(p.name << ": " << a.iterations << " steps (" << a.chord_steps << " chord), max error "
                   << a.max_curvature_error << "; Newton only " << b.iterations << " steps, " << b.max_curvature_error);
  }
  CHECK(chords > 0);
  // Vertex scaling with flips and circle boundaries: the split's factor is reused as well.
  const ValidateResult v = validate_mesh(disk(24));
  REQUIRE(v.status == Status::Ok);
  for (const bool chord : {true, false}) {
    IntrinsicResult ir = mesh_intrinsic_triangulation(v.mesh, v.topology, Geometry::Euclidean);
    REQUIRE(ir.status == Status::Ok);
    FlowOptions o;
    o.tolerance = 1e-12;
    o.polish_steps = 2;
    o.chord_steps = chord;
    const std::vector<double> u0(static_cast<std::size_t>(v.topology.num_vertices), 0.0);
    const FlowResult r = solve_flow_with_flips(ir.triangulation, u0, uniform_target(v.topology, BoundaryMode::Circle), o);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.max_curvature_error < 1e-13);
    if (!chord) CHECK(r.chord_steps == 0);
    MESSAGE("disk(24) with flips, chord steps " << std::string(chord ? "on" : "off") << ": " << r.iterations << " steps ("
                                                << r.chord_steps << " chord), max error " << r.max_curvature_error);
  }
}
