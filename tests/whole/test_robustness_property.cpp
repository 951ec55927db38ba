// Seeded property test of issue 23's rule: a valid surface (manifold, oriented, one component,
// finite coordinates) at any scale a double holds, under any similarity, with near-degenerate
// perturbations and random option values, either maps or ends with a named status — never NaN,
// a crash or (through the CLI) a partial output directory, and no `ok` summary on failure.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;
namespace fs = std::filesystem;

namespace {

double uniform(std::mt19937_64& rng, double lo, double hi) { return lo + (hi - lo) * ricci_shapes::unit_double(rng); }

Mesh base_surface(std::mt19937_64& rng) {
  switch (ricci_shapes::uniform_index(rng, 6)) {
    case 0: return ricci_shapes::icosphere(1);
    case 1: return ricci_shapes::icosphere(2);
    case 2: return ricci_shapes::torus(12, 6, 2, 0.7);
    case 3: return ricci_shapes::pretzel(2, 2);
    case 4: return ricci_shapes::disk(4);
    default: return ricci_shapes::annulus(3, 12);
  }
}

// One nearly flat face (stress_shapes.h): a short edge or a cap, 1e-3 to 1e-15 of the way left.
std::string perturb(Mesh& m, std::mt19937_64& rng) {
  m = ricci_shapes::nearly_flat_faces(m, rng, 1 + static_cast<int>(ricci_shapes::uniform_index(rng, 2)), 3, 15);
  return "nearly flat faces";
}

// A random rotation (normalized quaternion), scale and translation.
std::string similarity(Mesh& m, std::mt19937_64& rng) {
  double q[4], n = 0;
  for (double& x : q) {
    x = uniform(rng, -1, 1);
    n += x * x;
  }
  n = std::sqrt(n);
  for (double& x : q) x /= n;
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  // Scales 1e-30 … 1e30, and one case in six near the ends of the double range.
  const bool extreme = ricci_shapes::uniform_index(rng, 6) == 0;
  const double exponent = extreme ? (ricci_shapes::uniform_index(rng, 2) ? 1 : -1) * uniform(rng, 250, 300) : uniform(rng, -30, 30);
  const double scale = std::pow(10.0, exponent);
  double t[3] = {0, 0, 0};
  if (ricci_shapes::uniform_index(rng, 2) == 0)
    for (double& ti : t) ti = uniform(rng, -1e12, 1e12);
  for (Index v = 0; v < m.num_vertices(); ++v) {
    const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
    for (int i = 0; i < 3; ++i) m.positions[3 * v + i] = scale * (R[i][0] * p[0] + R[i][1] * p[1] + R[i][2] * p[2]) + t[i];
  }
  char buf[96];
  std::snprintf(buf, sizeof buf, "scale 1e%.1f, translation (%.3g, %.3g, %.3g)", exponent, t[0], t[1], t[2]);
  return buf;
}


template <class T>
const T& pick(std::mt19937_64& rng, const std::vector<T>& v) {
  return v[ricci_shapes::uniform_index(rng, static_cast<Index>(v.size()))];
}

bool all_finite(const std::vector<double>& x) {
  for (const double v : x)
    if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

TEST_CASE("property: random surfaces, similarities, near-degenerate faces and options map or end with a named status") {
  std::mt19937_64 rng(20261126);
  int ok = 0, named = 0, refused = 0, excused = 0, resolution_fallbacks = 0;
  const int draws = ricci_test::kSanitized ? 80 : 160;  // the sanitizer build: the same paths, less time
  for (int i = 0; i < draws; ++i) {
    Mesh m = base_surface(rng);
    m = ricci_shapes::permute_vertices(m, rng);
    std::string what = "surface " + std::to_string(m.num_faces()) + " faces";
    if (ricci_shapes::uniform_index(rng, 2) == 0) what += ", " + perturb(m, rng);
    what += ", " + similarity(m, rng);
    UniformizeOptions o;
    // Half the cases keep the defaults (natural geometry and boundary, vertex scaling with flips):
    // those must map. The others request any geometry, boundary and scheme, which a surface may
    // not admit (a named status then).
    const bool defaults = ricci_shapes::uniform_index(rng, 2) == 0;
    if (!defaults) {
      if (ricci_shapes::uniform_index(rng, 2) == 0)
        o.geometry = pick(rng, std::vector<Geometry>{Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical});
      if (ricci_shapes::uniform_index(rng, 2) == 0)
        o.boundary = pick(rng, std::vector<BoundaryMode>{BoundaryMode::Free, BoundaryMode::FixedLengths,
                                                         BoundaryMode::Circle, BoundaryMode::Geodesic});
      o.metric.scheme = pick(rng, std::vector<Scheme>{Scheme::Yamabe, Scheme::CirclePacking, Scheme::InversiveDistance});
      o.intrinsic_flips = ricci_shapes::uniform_index(rng, 2) != 0;
      o.flow.tolerance = pick(rng, std::vector<double>{1e-300, 1e-12, 1e-9});  // 1e-300: raised, with a note
    }
    o.seed_checks = static_cast<int>(ricci_shapes::uniform_index(rng, 3));
    o.flow.threads = pick(rng, std::vector<int>{0, 1, 2, 1000000});
    o.polish = ricci_shapes::uniform_index(rng, 2) == 0;
    what += ", options: geometry " + (o.geometry ? std::string(geometry_name(*o.geometry)) : std::string("auto")) +
            ", scheme " + std::string(scheme_name(o.metric.scheme)) + (o.intrinsic_flips ? "" : " no flips") +
            ", threads " + std::to_string(o.flow.threads) + ", tolerance " + std::to_string(o.flow.tolerance);
    CAPTURE(i);
    CAPTURE(what);
    const ValidateResult v = validate_mesh(m);
    if (v.status != Status::Ok) {
      // Only a collapse of the coordinates in double (a tiny mesh far out) may refuse it.
      CHECK(v.status == Status::DegenerateFace);
      CHECK(v.message.find("zero area") != std::string::npos);
      ++refused;
      continue;
    }
    const UniformizeResult r = uniformize(v.mesh, v.topology, o);
    if (defaults) CHECK_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.status != Status::NotRun);
    CHECK(!r.message.empty());
    if (r.status == Status::Ok) {
      ++ok;
      if (r.layout_excused.edges > 0) ++excused;
      if (r.intrinsic.fallback.find("curvature resolution") != std::string::npos) ++resolution_fallbacks;
      // An excused layout misses only within its coordinates' resolution, on a negligible area.
      if (r.layout_excused.edges > 0) {
        CHECK(r.layout_excused.worst_unexplained <= 0);
        CHECK(r.layout_excused.area_fraction <= o.max_layout_error);
      }
      CHECK(all_finite(r.flow.u));
      CHECK(all_finite(r.layout.positions));
      // Within the tolerance, or at vertices that resolve their curvature less (near-coincident
      // ones; FlowResult::curvature_resolution) within that.
      CHECK(r.flow.max_curvature_error < std::max({o.flow.tolerance, 1e-13, r.flow.curvature_resolution}));
      CHECK(std::isfinite(r.angles.mean_abs_log));
    } else {
      ++named;
      MESSAGE(what << ": " << status_name(r.status) << ": " << r.message);
      CHECK(status_name(r.status) != "unknown");
      CHECK(!r.failed_stage.empty());
      CHECK(r.message.rfind(r.failed_stage, 0) == 0);  // "<stage>: <why>"
    }
  }
  MESSAGE(ok << " mapped (" << excused << " with short edges excused by the layout gate, " << resolution_fallbacks
             << " by circle packing after vertex scaling's resolution-limited solution failed later), " << named
             << " named failures, " << refused << " refused by validation");
  CHECK(ok >= draws * 3 / 8);  // every draw with the defaults, and more
}

TEST_CASE("property (CLI): a random run leaves a complete output directory or none, and prints ok only on success") {
  std::mt19937_64 rng(7);
  ricci_test::TempDir dir;
  for (int i = 0; i < 8; ++i) {
    Mesh m = ricci_shapes::permute_vertices(base_surface(rng), rng);
    std::string what;
    if (ricci_shapes::uniform_index(rng, 2) == 0) what += perturb(m, rng) + ", ";
    what += similarity(m, rng);
    const fs::path in = dir / ("in" + std::to_string(i) + ".obj");
    const fs::path out = dir / ("out" + std::to_string(i));
    ricci_test::write_bytes(in, ricci::serialize_mesh(m, FileFormat::Obj));
    std::vector<std::string> args = {"uniformize", in.string(), "-o", out.string(), "--no-pictures"};
    args.insert(args.end(), {"--geometry", pick(rng, std::vector<std::string>{"auto", "auto", "euclidean", "hyperbolic", "spherical"})});
    args.insert(args.end(), {"--scheme", pick(rng, std::vector<std::string>{"auto", "circle-packing", "inversive-distance", "yamabe"})});
    args.insert(args.end(), {"--threads", pick(rng, std::vector<std::string>{"0", "1", "2", "1000000"})});
    args.insert(args.end(), {"--seed-checks", std::to_string(ricci_shapes::uniform_index(rng, 3))});
    if (ricci_shapes::uniform_index(rng, 4) == 0) args.push_back("--no-flips");
    args.insert(args.end(), {"--tol", pick(rng, std::vector<std::string>{"1e-300", "1e-12", "1e-9"})});
    CAPTURE(what);
    std::string line;
    for (const std::string& a : args) line += a + " ";
    CAPTURE(line);
    const ricci_test::CommandResult r = ricci_test::run_cli(args);
    CHECK(r.exit_code != 1);   // never an unclassified error
    CHECK(r.exit_code < 128);  // never a signal
    if (r.exit_code == 0) {
      CHECK(fs::exists(out / "report.json"));
      CHECK(fs::exists(out / "mesh.obj"));
      CHECK(r.out.rfind("ok ", 0) == 0);
    } else {
      MESSAGE(line << "(" << what << "): exit " << r.exit_code << ": " << r.err.substr(r.err.rfind("ricci: error")));
      CHECK(!fs::exists(out));
      CHECK(r.out.find("ok ") == std::string::npos);
      CHECK(r.err.find(in.filename().string()) != std::string::npos);  // the error names the file
    }
  }
}
