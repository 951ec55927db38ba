// Any scale a double holds (issue 23): the stages read positions times an exact power of two
// (unit_power_of_two()), so a mesh scaled by 2^k gives the same metric bit for bit, and meshes at
// 1e-300 or 1e300 map like the unit-size ones. The property test that draws surfaces, similarities,
// near-degenerate perturbations and option values is in test_robustness_property.cpp.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/metric.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"

using namespace ricci;

namespace {

Mesh scaled_by(Mesh m, double factor) {
  for (double& x : m.positions) x *= factor;
  return m;
}

struct Case {
  std::string name;
  Mesh mesh;
};

std::vector<Case> cases() {
  return {{"pretzel(2, 2) in H", ricci_shapes::pretzel(2, 2)},
          {"torus in E", ricci_shapes::torus(16, 8, 2, 0.7)},
          {"disk in E", ricci_shapes::disk(6)},
          {"icosphere in S", ricci_shapes::icosphere(2)}};
}

}  // namespace

TEST_CASE("unit_power_of_two: 1 from 2^-100 to 2^100, otherwise the power of two that brings the extent to 1 up to 2") {
  CHECK(unit_power_of_two(1) == 1);
  CHECK(unit_power_of_two(0x1p-100) == 1);
  CHECK(unit_power_of_two(0x1p100) == 1);
  CHECK(unit_power_of_two(0) == 1);
  CHECK(unit_power_of_two(INFINITY) == 1);
  CHECK(unit_power_of_two(NAN) == 1);
  CHECK(unit_power_of_two(4e-320) == 0x1p1023);  // subnormal: as far as a double goes
  for (const double x : {1e-300, 3e-200, 0x1p-101, 0x1p101, 7e150, 1.7e308, 0x1p-1022}) {
    CAPTURE(x);
    const double s = unit_power_of_two(x);
    CHECK(x * s >= 1);
    CHECK(x * s < 2);
    int e = 0;
    CHECK(std::frexp(s, &e) == 0.5);  // a power of two
  }
}

TEST_CASE("uniformize: a mesh scaled by 2^k gives the same metric (H and S bit for bit, E to rounding in its scaled unit)") {
  for (const Case& c : cases()) {
    const ValidateResult base_v = validate_mesh(c.mesh);
    REQUIRE_MESSAGE(base_v.status == Status::Ok, base_v.message);
    UniformizeOptions o;
    o.seed_checks = 0;
    const UniformizeResult base = uniformize(base_v.mesh, base_v.topology, o);
    REQUIRE_MESSAGE(base.status == Status::Ok, base.message);
    CHECK(base.input_scale == 1);
    for (const int k : {-1000, -400, 400, 1000}) {
      CAPTURE(c.name);
      CAPTURE(k);
      const ValidateResult v = validate_mesh(scaled_by(c.mesh, std::ldexp(1.0, k)));
      REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
      const UniformizeResult r = uniformize(v.mesh, v.topology, o);
      REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
      CHECK(r.input_scale != 1);
      // Lengths in the stages' unit: the input's times metric.length_scale.
      const double ratio = r.metric.length_scale * std::ldexp(1.0, k) / base.metric.length_scale;
      int e = 0;
      CHECK(std::frexp(ratio, &e) == 0.5);  // the two runs differ by a power of two
      CHECK(r.flow.iterations == base.flow.iterations);
      // H and S fix their unit by area, so the stages see the same lengths: bit for bit. E keeps
      // the scaled unit, and the intrinsic triangulation stores lengths as fixed-point logarithms
      // (log 2 is not a multiple of their unit): equal to rounding.
      const bool exact = base.geometry != Geometry::Euclidean;
      const double tol = exact ? 0 : 1e-13;
      REQUIRE(r.flow.u.size() == base.flow.u.size());
      double worst_u = 0;
      for (std::size_t i = 0; i < r.flow.u.size(); ++i) worst_u = std::max(worst_u, std::abs(r.flow.u[i] - base.flow.u[i]));
      CHECK(worst_u <= tol);
      REQUIRE(r.flow.l.size() == base.flow.l.size());
      double worst_l = 0;
      for (std::size_t i = 0; i < r.flow.l.size(); ++i)
        worst_l = std::max(worst_l, std::abs(r.flow.l[i] / (base.flow.l[i] * ratio) - 1));
      CHECK(worst_l <= tol);
      REQUIRE(r.layout.positions.size() == base.layout.positions.size());
      const double position_ratio = exact ? 1 : ratio;
      double worst = 0, extent = 0;
      for (std::size_t i = 0; i < r.layout.positions.size(); ++i) {
        worst = std::max(worst, std::abs(r.layout.positions[i] - base.layout.positions[i] * position_ratio));
        extent = std::max(extent, std::abs(base.layout.positions[i] * position_ratio));
      }
      CHECK(worst <= tol * extent);
      CHECK(std::abs(r.angles.mean_abs_log - base.angles.mean_abs_log) <= tol);
    }
  }
}

TEST_CASE("uniformize: meshes at 1e-300 and 1e300 map as at unit size (E, H, S)") {
  for (const Case& c : cases()) {
    const ValidateResult base_v = validate_mesh(c.mesh);
    REQUIRE(base_v.status == Status::Ok);
    UniformizeOptions o;
    o.seed_checks = 0;
    const UniformizeResult base = uniformize(base_v.mesh, base_v.topology, o);
    REQUIRE(base.status == Status::Ok);
    for (const double s : {1e-300, 1e-150, 1e150, 1e300}) {
      CAPTURE(c.name);
      CAPTURE(s);
      const ValidateResult v = validate_mesh(scaled_by(c.mesh, s));
      REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
      const UniformizeResult r = uniformize(v.mesh, v.topology, o);
      REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
      CHECK(r.flow.max_curvature_error < 1e-12);
      CHECK(r.layout.max_edge_length_error < 1e-9);
      CHECK(r.layout.flipped_faces == 0);
      CHECK(std::abs(r.angles.mean_abs_log - base.angles.mean_abs_log) < 1e-9);
      for (const double x : r.layout.positions) REQUIRE(std::isfinite(x));
    }
  }
}

TEST_CASE("initial_metric and solve_flow at 1e-300 and 1e300: every scheme converges (no prescaled positions)") {
  for (const Case& c : cases()) {
    for (const double s : {1e-300, 1e300}) {
      const ValidateResult v = validate_mesh(scaled_by(c.mesh, s));
      REQUIRE(v.status == Status::Ok);
      const Geometry g = natural_geometry(v.topology);
      for (const Scheme scheme : {Scheme::CirclePacking, Scheme::Yamabe}) {
        CAPTURE(c.name);
        CAPTURE(s);
        CAPTURE(scheme_name(scheme));
        InitialMetricOptions mo;
        mo.geometry = g;
        mo.scheme = scheme;
        const InitialMetric m = initial_metric(v.mesh, v.topology, mo);
        REQUIRE_MESSAGE(m.status == Status::Ok, m.message);
        for (const double x : m.l0) REQUIRE((x > 1e-3 && x < 1e3));
        const Target target = uniform_target(v.topology, natural_boundary_mode(v.topology, g));
        const FlowResult f = solve_flow(v.topology, m.structure, m.u, target);
        CHECK_MESSAGE(f.status == Status::Ok, f.message);
        CHECK(f.max_curvature_error < 1e-10);
      }
    }
  }
}
