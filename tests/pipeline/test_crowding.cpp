// Crowding of circle domains (white box, lib/pipeline/crowding.h): discrete harmonic measure adds up to
// one, is nearly uniform on a round disk seen from its centre, decays like e^(−π·L/2) along a
// strip of width 1 and length L seen from its middle (the conformal map of a rectangle), and the
// long stress strips, whose circle domains no double-precision layout can hold, stop with a
// status that names the crowding and a vertex instead of the solver's symptom.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "crowding.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"

using namespace ricci;

namespace {

detail::Crowding crowding_of(const Mesh& m) {
  const ValidateResult v = validate_mesh(m);
  REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
  return detail::circle_domain_crowding(v.mesh, v.topology);
}

}  // namespace

TEST_CASE("crowding: harmonic measure on a round disk is nearly uniform and adds up to one") {
  const Mesh m = ricci_shapes::disk(12);
  const detail::Crowding c = crowding_of(m);
  REQUIRE_MESSAGE(c.computed, c.why_not);
  CHECK(std::abs(c.total - 1) < 1e-12);
  // 72 boundary edges: 1/72 each for the continuous disk; the lifted, discretised disk stays close.
  CHECK(c.min_measure > 0.7 / 72);
  CHECK(c.min_measure <= 1.0 / 72 + 1e-12);
  CHECK(c.centre == 0);  // the disk's centre vertex
}

TEST_CASE("crowding: along a strip the measure of the ends decays like e^(-pi L / 2)") {
  // Width 1, lengths 4, 6 and 8, 8 rows and 8 columns per unit length: from the middle the ends'
  // measure falls by e^(−π) per unit of length (the rectangle's conformal map onto the disk).
  double log_measure[3];
  const int lengths[3] = {4, 6, 8};
  for (int k = 0; k < 3; ++k) {
    const detail::Crowding c = crowding_of(ricci_shapes::strip(8 * lengths[k], 8, lengths[k], 1));
    REQUIRE_MESSAGE(c.computed, c.why_not);
    CHECK(std::abs(c.total - 1) < 1e-12);
    CHECK(c.min_measure > 0);
    log_measure[k] = std::log(c.min_measure);
  }
  const double rate1 = (log_measure[0] - log_measure[1]) / 2, rate2 = (log_measure[1] - log_measure[2]) / 2;
  MESSAGE("decay per unit length: " << rate1 << ", " << rate2 << " (continuum: pi/2 per unit at each end: "
                                    << std::numbers::pi / 2 << ")");
  CHECK(rate1 == doctest::Approx(std::numbers::pi / 2).epsilon(0.03));
  CHECK(rate2 == doctest::Approx(std::numbers::pi / 2).epsilon(0.03));
}

TEST_CASE("crowding: a strip one triangle wide is subdivided to have an interior point") {
  const detail::Crowding c = crowding_of(ricci_shapes::strip(40, 1, 4, 1));
  REQUIRE_MESSAGE(c.computed, c.why_not);
  CHECK(std::abs(c.total - 1) < 1e-12);
  CHECK(c.centre >= 0);
  CHECK(c.centre < 82);  // named by an input vertex
  CHECK(c.vertex < 82);
  CHECK(c.other < 82);
  CHECK(c.min_measure > 0);
  CHECK(c.min_measure < 1e-3);
}

TEST_CASE("crowding: closed surfaces are not measured") {
  const detail::Crowding c = crowding_of(ricci_shapes::icosphere(1));
  CHECK_FALSE(c.computed);
  CHECK_FALSE(c.why_not.empty());
}

TEST_CASE("crowding: the long strips stop naming the crowding and a vertex, by default and on the CLI's path") {
  for (const auto& [columns, rows, length] : {std::tuple{200, 2, 100.0}, std::tuple{1000, 1, 1000.0}}) {
    CAPTURE(length);
    const ValidateResult v = validate_mesh(ricci_shapes::strip(columns, rows, length, 1));
    REQUIRE(v.status == Status::Ok);
    const UniformizeResult r = uniformize(v.mesh, v.topology, UniformizeOptions{});
    CHECK(r.status == Status::NumericalFailure);
    CHECK(r.failed_stage == "flow");
    CHECK(r.message.find("crowds beyond double precision") != std::string::npos);
    CHECK((r.message.find("the boundary edge from vertex ") != std::string::npos ||
           r.message.find("the boundary at vertex ") != std::string::npos));
    // Fixed boundary lengths need no circle: the flat strip is its own answer.
    UniformizeOptions fixed;
    fixed.boundary = BoundaryMode::FixedLengths;
    fixed.seed_checks = 0;
    const UniformizeResult f = uniformize(v.mesh, v.topology, fixed);
    CHECK_MESSAGE(f.status == Status::Ok, f.message);
    CHECK(f.flow.max_curvature_error < 1e-12);
  }
}
