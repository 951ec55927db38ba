// Stress meshes (issue 8, item 3): needles and caps, high valence, extreme scales, nearly coplanar
// folds, long thin strips, tiny and huge edges side by side, random vertex order
// (tools/stress_shapes.h, small sizes). Each either uniformizes to the documented accuracy or
// stops with a named status whose message names an element; never NaN, never flips reported as
// success.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;
namespace fs = std::filesystem;

namespace {

// The sanitizer build uses smaller random-order meshes so the suite stays within the CI budget.
using ricci_test::kSanitized;

constexpr std::uint64_t kSeed = 20261121;

bool all_finite(const std::vector<double>& x) {
  return std::all_of(x.begin(), x.end(), [](double v) { return std::isfinite(v); });
}

/// The element words a failure message must contain one of.
bool names_an_element(const std::string& m) {
  for (const char* w : {"face", "vertex", "vertices", "edge", "loop", "iteration", "step", "set"})
    if (m.find(w) != std::string::npos) return true;
  return false;
}

UniformizeOptions fast_options() {
  UniformizeOptions o;
  o.seed_checks = 1;
  o.base_candidates = 2;
  return o;
}

/// The outcome rules for one stress mesh. Returns true when it uniformized.
bool check_outcome(const UniformizeResult& r) {
  INFO(r.brief_report());
  INFO(r.message);
  // Whatever was computed is finite.
  CHECK(all_finite(r.flow.u));
  CHECK(all_finite(r.flow.l));
  CHECK(all_finite(r.flow.K));
  CHECK(all_finite(r.layout.positions));
  CHECK(std::isfinite(r.flow.max_curvature_error));
  if (r.status == Status::Ok) {
    CHECK(r.flow.max_curvature_error <= std::max(1e-10, r.flow.curvature_resolution));
    CHECK(r.layout.status == Status::Ok);
    CHECK(r.layout.flipped_faces == 0);
    CHECK(r.layout.unplaced_vertices == 0);
    CHECK(r.layout.max_edge_length_error < std::max(1e-9, 8 * r.layout.rounding_floor));
    CHECK(std::isfinite(r.seed_independence_error));
    // A distance of the geometry: in E in the metric's units, where rounding moves a position by
    // about the floor times its distance from the seed, so the allowance scales with the layout's
    // extent (the accordion spans 42 units); H and S are bounded models.
    double extent = 1;
    if (r.geometry == Geometry::Euclidean && r.layout.scale > 0 && !r.layout.positions.empty()) {
      const std::vector<double>& x = r.layout.positions;
      const std::size_t nv = x.size() / 2;
      double mx = 0, my = 0, far = 0;
      for (std::size_t i = 0; i < nv; ++i) {
        mx += x[2 * i];
        my += x[2 * i + 1];
      }
      mx /= static_cast<double>(nv);
      my /= static_cast<double>(nv);
      for (std::size_t i = 0; i < nv; ++i) far = std::max(far, std::hypot(x[2 * i] - mx, x[2 * i + 1] - my));
      extent = std::max(1.0, far / r.layout.scale);
    }
    CHECK(r.seed_independence_error < std::max(1e-9, 8 * r.layout.rounding_floor) * extent);
    CHECK(!r.layout.positions.empty());
    return true;
  }
  // A named failure: the stage, and a message naming an element.
  CHECK(r.status != Status::NotRun);
  CHECK(!r.failed_stage.empty());
  CHECK(r.message.find(r.failed_stage) == 0);
  CHECK(names_an_element(r.message));
  return false;
}

}  // namespace

TEST_CASE("stress: every stress kind uniformizes to the documented accuracy or stops with a named status") {
  const std::vector<ricci_shapes::StressMesh> meshes =
      ricci_shapes::stress_meshes(ricci_shapes::StressSize::Small, kSeed);
  REQUIRE(meshes.size() >= 12);
  int converged = 0;
  for (const ricci_shapes::StressMesh& s : meshes) {
    INFO(s.name);
    CAPTURE(s.mesh.num_faces());
    const ValidateResult v = validate_mesh(s.mesh);
    INFO(v.message);
    if (v.status != Status::Ok) {
      // Refused at validation: named, with the element.
      CHECK(v.element != Element::None);
      CHECK(names_an_element(v.message));
      continue;
    }
    const UniformizeResult r = uniformize(v.mesh, v.topology, fast_options());
    MESSAGE(s.name << ": " << r.brief_report());
    const bool ok = check_outcome(r);
    if (ok) ++converged;
    // Every kind converges but the long strips, whose circle domains crowd: mapped onto a disk,
    // the ends of a 100 × 1 strip shrink by about e^(−π·50), far below what coordinates resolve.
    // They stop saying so (crowding.h), not with the solver's symptom.
    if (s.name != "strip-100" && s.name != "strip-1000") {
      CHECK(ok);
    } else {
      CHECK(r.status == Status::NumericalFailure);
      CHECK(r.message.find("crowds beyond double precision") != std::string::npos);
    }
  }
  CHECK(converged >= static_cast<int>(meshes.size()) - 2);
}

TEST_CASE("stress: the needles and caps reach angles of 1e-4 rad and valence 512") {
  std::mt19937_64 rng(kSeed);
  const Mesh m = ricci_shapes::insert_needles_and_caps(ricci_shapes::torus(24, 12, 1, 0.4), rng, 0.3, 1e-4);
  const double a = ricci_shapes::min_angle_radians(m);
  CHECK(a < 3e-4);
  CHECK(a > 1e-5);
  const Mesh p = ricci_shapes::polar_sphere(512, 4);
  std::vector<int> valence(static_cast<std::size_t>(p.num_vertices()), 0);
  for (Index c : p.faces) ++valence[static_cast<std::size_t>(c)];
  CHECK(*std::max_element(valence.begin(), valence.end()) == 512);
}

namespace {

/// Max over vertices of |a − (s·b + t)| / diameter for the similarity (complex s, t) fitted on
/// the first two vertices (2D layouts), or |a − b| / diameter (3D, the unit sphere).
double similarity_distance(const Layout& a, const Layout& b) {
  if (a.dims != b.dims || a.positions.size() != b.positions.size() || a.positions.empty()) return INFINITY;
  const std::size_t n = a.positions.size() / static_cast<std::size_t>(a.dims);
  double diam = 0, worst = 0;
  if (a.dims == 2) {
    auto za = [&](std::size_t i) { return std::complex<double>(a.positions[2 * i], a.positions[2 * i + 1]); };
    auto zb = [&](std::size_t i) { return std::complex<double>(b.positions[2 * i], b.positions[2 * i + 1]); };
    const std::complex<double> s = (za(1) - za(0)) / (zb(1) - zb(0));
    const std::complex<double> t = za(0) - s * zb(0);
    for (std::size_t i = 0; i < n; ++i) {
      diam = std::max(diam, std::abs(za(i) - za(0)));
      worst = std::max(worst, std::abs(za(i) - (s * zb(i) + t)));
    }
  } else {
    for (std::size_t i = 0; i < a.positions.size(); ++i) worst = std::max(worst, std::abs(a.positions[i] - b.positions[i]));
    diam = 2;
  }
  return worst / diam;
}

}  // namespace

TEST_CASE("stress: coordinates scaled by 1e-8 and 1e8 give the same angles, curvature and layout") {
  struct Base {
    const char* name;
    Mesh mesh;
  };
  const Base bases[] = {
      {"torus (E)", ricci_shapes::torus(16, 8, 1, 0.4)},
      {"disk (E)", ricci_shapes::disk(6)},
      {"icosphere (S)", ricci_shapes::icosphere(2)},
      {"pretzel genus 2 (H)", ricci_shapes::pretzel(2, 3)},
  };
  for (const Base& b : bases) {
    INFO(b.name);
    const ValidateResult v1 = validate_mesh(b.mesh);
    REQUIRE(v1.status == Status::Ok);
    const UniformizeResult r1 = uniformize(v1.mesh, v1.topology, fast_options());
    REQUIRE(r1.status == Status::Ok);
    for (double factor : {1e-8, 1e8}) {
      CAPTURE(factor);
      const ValidateResult v = validate_mesh(ricci_shapes::scaled(b.mesh, factor));
      REQUIRE(v.status == Status::Ok);
      const UniformizeResult r = uniformize(v.mesh, v.topology, fast_options());
      INFO(r.brief_report());
      REQUIRE(r.status == Status::Ok);
      CHECK(r.geometry == r1.geometry);
      CHECK(r.layout.flipped_faces == 0);
      // Curvature of the final metric.
      REQUIRE(r.flow.K.size() == r1.flow.K.size());
      double dK = 0;
      for (std::size_t i = 0; i < r.flow.K.size(); ++i) dK = std::max(dK, std::abs(r.flow.K[i] - r1.flow.K[i]));
      CHECK(dK <= 1e-10);
      // Corner angles of the final metric (θ_input / θ_metric; θ_input is scale invariant).
      REQUIRE(r.angles.ratio.size() == r1.angles.ratio.size());
      double dA = 0;
      for (std::size_t i = 0; i < r.angles.ratio.size(); ++i)
        dA = std::max(dA, std::abs(r.angles.ratio[i] - r1.angles.ratio[i]) / r1.angles.ratio[i]);
      CHECK(dA <= 1e-8);
      // The layout, up to a similarity (E) or exactly (S, H: the geometry fixes the scale), when
      // the cut is the same: the torus's shortest loops tie, and rounding may then pick others.
      if (r.cut.cut_faces == r1.cut.cut_faces) {
        REQUIRE(r.layout.positions.size() == r1.layout.positions.size());
        CHECK(similarity_distance(r1.layout, r.layout) <= 1e-7);
      } else {
        MESSAGE(std::string(b.name) << " x " << factor << ": another cut of equal length; layouts not compared");
        CHECK(r.layout.max_edge_length_error < 1e-9);
      }
    }
  }
}

TEST_CASE("stress: a random vertex and face order gives the same metric, up to the permutation") {
  // ~50k faces in Release; 20k under the sanitizers (the same code paths, less time).
  const int n = kSanitized ? 100 : 158;
  const Mesh ordered = ricci_shapes::torus(n, n, 1, 0.4);
  const Mesh shuffled = ricci_shapes::random_order(ordered, kSeed);
  CAPTURE(ordered.num_faces());
  // The permutation, recovered from the (copied, hence bit-identical) positions.
  std::map<std::array<double, 3>, Index> where;
  for (Index v = 0; v < ordered.num_vertices(); ++v)
    where[{ordered.positions[3 * v], ordered.positions[3 * v + 1], ordered.positions[3 * v + 2]}] = v;
  REQUIRE(where.size() == static_cast<std::size_t>(ordered.num_vertices()));
  std::vector<Index> to_ordered(static_cast<std::size_t>(shuffled.num_vertices()));
  for (Index v = 0; v < shuffled.num_vertices(); ++v)
    to_ordered[v] = where.at({shuffled.positions[3 * v], shuffled.positions[3 * v + 1], shuffled.positions[3 * v + 2]});

  const ValidateResult vo = validate_mesh(ordered);
  const ValidateResult vs = validate_mesh(shuffled);
  REQUIRE(vo.status == Status::Ok);
  REQUIRE(vs.status == Status::Ok);
  UniformizeOptions opt = fast_options();
  const UniformizeResult ro = uniformize(vo.mesh, vo.topology, opt);
  const UniformizeResult rs = uniformize(vs.mesh, vs.topology, opt);
  INFO(ro.brief_report());
  INFO(rs.brief_report());
  REQUIRE(ro.status == Status::Ok);
  REQUIRE(rs.status == Status::Ok);
  CHECK(check_outcome(rs));
  // Validation keeps the vertex numbering of these clean meshes.
  REQUIRE(vs.vertex_to_input.size() == to_ordered.size());
  double du = 0, dK = 0;
  for (Index v = 0; v < vs.topology.num_vertices; ++v) {
    const Index w = to_ordered[vs.vertex_to_input[v]];
    du = std::max(du, std::abs(rs.flow.u[v] - ro.flow.u[w]));
    dK = std::max(dK, std::abs(rs.flow.K[v] - ro.flow.K[w]));
  }
  CHECK(du <= 1e-9);
  CHECK(dK <= 1e-10);
  // Edge lengths by their (ordered) end vertices.
  std::map<std::pair<Index, Index>, double> lo;
  for (Index e = 0; e < vo.topology.num_edges; ++e) {
    Index a = vo.topology.edge_vertices[2 * e], b = vo.topology.edge_vertices[2 * e + 1];
    lo[{std::min(a, b), std::max(a, b)}] = ro.flow.l[e];
  }
  double dl = 0;
  for (Index e = 0; e < vs.topology.num_edges; ++e) {
    Index a = to_ordered[vs.vertex_to_input[vs.topology.edge_vertices[2 * e]]];
    Index b = to_ordered[vs.vertex_to_input[vs.topology.edge_vertices[2 * e + 1]]];
    const double l = lo.at({std::min(a, b), std::max(a, b)});
    dl = std::max(dl, std::abs(rs.flow.l[e] - l) / l);
  }
  CHECK(dl <= 1e-9);
  CHECK(std::abs(rs.angles.max_abs_log - ro.angles.max_abs_log) <= 1e-9);
}

TEST_CASE("stress: ricci uniformize on the stress meshes exits 0 or with a named error, never NaN") {
  ricci_test::TempDir dir;
  const std::vector<ricci_shapes::StressMesh> meshes =
      ricci_shapes::stress_meshes(ricci_shapes::StressSize::Small, kSeed);
  for (const ricci_shapes::StressMesh& s : meshes) {
    // The CLI path on a few kinds (the library test above covers all): one per geometry and the
    // extreme strip.
    if (s.name != "needles-caps-torus" && s.name != "high-valence-sphere" && s.name != "scale-1e8-pretzel" &&
        s.name != "strip-1000")
      continue;
    INFO(s.name);
    const fs::path in = dir / (s.name + ".obj");
    REQUIRE(write_mesh(in.string(), s.mesh).status == Status::Ok);
    const std::string before = ricci_test::read_bytes(in);
    const fs::path out = dir / (s.name + "-out");
    const ricci_test::CommandResult r =
        ricci_test::run_cli({"uniformize", in.string(), "-o", out.string(), "--no-pictures", "--seed-checks", "1", "-q"});
    INFO(r.err);
    CHECK(ricci_test::read_bytes(in) == before);
    if (r.exit_code == 0) {
      const std::string report = ricci_test::read_bytes(out / "report.json");
      REQUIRE(!report.empty());
      CHECK(report.find("nan") == std::string::npos);
      CHECK(report.find("NaN") == std::string::npos);
      const nlohmann::json j = nlohmann::json::parse(report);
      CHECK(j.is_object());
    } else {
      CHECK((r.exit_code == 5 || r.exit_code == 7 || r.exit_code == 8));
      CHECK(r.err.find("ricci: error: ") != std::string::npos);
      CHECK(r.err.find(in.string()) != std::string::npos);
      CHECK(!fs::exists(out));
    }
  }
}
