// The flipped solution carried back to the input: straight input edges (straight_input_metric())
// and the common subdivision (common_subdivision()), the planar start of the round sphere, and
// uniformize() with intrinsic flips as the default — invariants on seeded hard meshes in E, H, S.
#include <doctest/doctest.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "ricci/deck.h"
#include "ricci/flow.h"
#include "ricci/intrinsic.h"
#include "ricci/intrinsic_trace.h"
#include "ricci/io.h"
#include "ricci/layout.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;

namespace {

constexpr double kPi = std::numbers::pi;

struct Solved {
  std::string name;
  Mesh mesh;
  Topology input;
  IntrinsicTriangulation tri;
  FlowResult flow;
  InputEdgePaths paths;
};

Solved solve(const std::string& name, const Mesh& m, Geometry g) {
  Solved s;
  s.name = name;
  const ValidateResult v = validate_mesh(m);
  REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
  s.mesh = v.mesh;
  s.input = v.topology;
  IntrinsicResult ir = mesh_intrinsic_triangulation(s.mesh, s.input, g);
  REQUIRE_MESSAGE(ir.status == Status::Ok, ir.message);
  s.tri = std::move(ir.triangulation);
  const Target target = uniform_target(s.input, BoundaryMode::Circle);
  const std::vector<double> u0(static_cast<std::size_t>(s.input.num_vertices), 0.0);
  FlowOptions o;
  o.tolerance = 1e-12;
  s.flow = solve_flow_with_flips(s.tri, u0, target, o);
  REQUIRE_MESSAGE(s.flow.status == Status::Ok, s.flow.message);
  s.paths = trace_input_edges(s.tri, s.input);
  REQUIRE_MESSAGE(s.paths.status == Status::Ok, s.paths.message);
  return s;
}

std::vector<Solved> hard_cases() {
  using namespace ricci_shapes;
  std::mt19937_64 rng(11);
  std::vector<Solved> out;
  out.push_back(solve("torus with needles (E)", insert_needles_and_caps(torus(16, 8, 2.0, 0.7), rng, 0.3, 0.02),
                      Geometry::Euclidean));
  out.push_back(solve("genus-2 pretzel with needles (H)", insert_needles_and_caps(pretzel(2, 3), rng, 0.3, 0.02),
                      Geometry::Hyperbolic));
  out.push_back(solve("icosphere with needles (S)", insert_needles_and_caps(icosphere(2), rng, 0.3, 0.02),
                      Geometry::Spherical));
  out.push_back(solve("disk with needles (E)", insert_needles_and_caps(disk(6), rng, 0.3, 0.02), Geometry::Euclidean));
  return out;
}

// Curvature per vertex and total area of a metric given by lengths; violations of the triangle inequality.
Index curvature_of(const Topology& t, Geometry g, const std::vector<double>& l, std::vector<double>& K, double& area) {
  std::vector<double> theta(static_cast<std::size_t>(3 * t.num_faces)), a(static_cast<std::size_t>(t.num_faces));
  const AngleReport r = corner_angles(t, g, l, theta);
  K.assign(static_cast<std::size_t>(t.num_vertices), 0.0);
  vertex_curvature(t, theta, K);
  face_areas(t, g, l, theta, a);
  area = 0;
  for (double x : a) area += x;
  return r.violations;
}

double total_area(const Solved& s) {
  std::vector<double> K;
  double area = 0;
  REQUIRE(curvature_of(s.tri.topology, s.tri.geometry, s.flow.l, K, area) == 0);
  return area;
}

}  // namespace

TEST_CASE("straight input edges: where they tile, the input's triangulation carries the solution exactly") {
  for (const Solved& s : hard_cases()) {
    INFO(s.name);
    const StraightInputMetric st = straight_input_metric(s.tri, s.flow.u, s.input, s.paths);
    REQUIRE_MESSAGE(st.status == Status::Ok, st.message);
    // An input edge that is a current edge keeps its length; a straight edge is never longer
    // than its path, and at least as long as nothing (positive).
    for (Index a = 0; a < s.input.num_edges; ++a) {
      CHECK(st.l[a] > 0);
      if (s.paths.along[a] != kInvalid) CHECK(st.l[a] == s.flow.l[s.paths.along[a]]);
    }
    MESSAGE(s.name << ": tiles " << st.tiles() << ", " << st.inconsistent_vertices << " vertices off, max "
                   << st.max_angle_sum_error);
    if (!st.tiles()) continue;
    std::vector<double> K;
    double area = 0;
    REQUIRE(curvature_of(s.input, s.tri.geometry, st.l, K, area) == 0);
    // Same curvature as the solution at every vertex, same area (Gauss–Bonnet).
    for (Index v = 0; v < s.input.num_vertices; ++v) CHECK(std::abs(K[v] - s.flow.K[v]) <= 1e-9);
    CHECK(std::abs(area - total_area(s)) <= 1e-9 * std::max(1.0, area));
  }
}

TEST_CASE("common subdivision: every piece in one input face, the solution's metric, flat at every crossing") {
  for (const Solved& s : hard_cases()) {
    INFO(s.name);
    const std::vector<double> t = input_edge_crossings(s.tri, s.flow.u, s.paths);
    const CommonSubdivision cs = common_subdivision(s.tri, s.flow.u, s.mesh, s.input, s.paths, t);
    REQUIRE_MESSAGE(cs.status == Status::Ok, cs.message);
    const Topology& r = cs.topology;
    const Index nv = s.input.num_vertices;
    CHECK(r.num_vertices == nv + static_cast<Index>(t.size()));
    CHECK(r.euler_characteristic() == s.input.euler_characteristic());
    CHECK(r.num_boundary_loops() == s.input.num_boundary_loops());
    CHECK(ricci_test::check_topology(r, cs.mesh.faces).empty());
    std::vector<double> K;
    double area = 0;
    REQUIRE(curvature_of(r, s.tri.geometry, cs.l, K, area) == 0);
    // Input vertices keep the solution's curvature; a crossing is flat (2π inside, π on a border).
    for (Index v = 0; v < nv; ++v) CHECK(std::abs(K[v] - s.flow.K[v]) <= 1e-9);
    double worst = 0;
    for (Index v = nv; v < r.num_vertices; ++v) worst = std::max(worst, std::abs(K[v]));
    CHECK(worst <= 1e-9);
    CHECK(std::abs(area - total_area(s)) <= 1e-9 * std::max(1.0, area));
    // Every input face is covered by its pieces, with the input face's corner angles positive.
    std::vector<int> pieces(static_cast<std::size_t>(s.input.num_faces), 0);
    for (const Index f : cs.face_input) {
      REQUIRE(f >= 0);
      REQUIRE(f < s.input.num_faces);
      ++pieces[f];
    }
    CHECK(*std::min_element(pieces.begin(), pieces.end()) >= 1);
    // A piece's vertices are its input face's vertices or crossings of that face's edges.
    for (Index f = 0; f < r.num_faces; ++f) {
      const Index g = cs.face_input[f];
      for (Index k = 0; k < 3; ++k) {
        const Index v = r.corner_vertex[3 * f + k];
        if (v < nv) {
          CHECK((s.input.corner_vertex[3 * g] == v || s.input.corner_vertex[3 * g + 1] == v ||
                 s.input.corner_vertex[3 * g + 2] == v));
        } else {
          const Index a = cs.vertex_input_edge[v];
          bool edge_of_face = false;
          for (Index j = 0; j < 3; ++j) edge_of_face = edge_of_face || s.input.corner_edge[3 * g + j] == a;
          CHECK(edge_of_face);
        }
      }
    }
  }
}

namespace {

// Per current edge, its crossings' positions in slot order.
std::vector<std::vector<double>> positions_by_edge(const Solved& s, const std::vector<double>& t) {
  std::vector<std::vector<double>> by(static_cast<std::size_t>(s.tri.topology.num_edges));
  for (Index e = 0; e < s.tri.topology.num_edges; ++e)
    by[static_cast<std::size_t>(e)].assign(static_cast<std::size_t>(std::max<std::int64_t>(0, s.tri.normal[e])), NAN);
  for (std::size_t k = 0; k < t.size(); ++k)
    by[static_cast<std::size_t>(s.paths.crossed_edge[k])][static_cast<std::size_t>(s.paths.crossed_slot[k])] = t[k];
  return by;
}

// The length of input edge a in the common subdivision: the sum of its pieces.
double piecewise_length(const Solved& s, const CommonSubdivision& cs, Index a) {
  const Topology& r = cs.topology;
  auto length_between = [&](Index x, Index y) {
    for (Index e = 0; e < r.num_edges; ++e)
      if ((r.edge_vertices[2 * e] == x && r.edge_vertices[2 * e + 1] == y) ||
          (r.edge_vertices[2 * e] == y && r.edge_vertices[2 * e + 1] == x))
        return cs.l[e];
    return static_cast<double>(NAN);
  };
  const Index nv = s.input.num_vertices;
  Index prev = s.input.edge_vertices[2 * a];
  double sum = 0;
  for (Index k = s.paths.offsets[a]; k < s.paths.offsets[a + 1]; ++k) {
    sum += length_between(prev, nv + k);
    prev = nv + k;
  }
  return sum + length_between(prev, s.input.edge_vertices[2 * a + 1]);
}

}  // namespace

TEST_CASE("straightest crossings: in order on every edge, straight where the gaps allow, straight input edges where they tile") {
  for (const Solved& s : hard_cases()) {
    INFO(s.name);
    const StraightInputMetric st = straight_input_metric(s.tri, s.flow.u, s.input, s.paths);
    REQUIRE_MESSAGE(st.status == Status::Ok, st.message);
    REQUIRE(st.crossings.size() == s.paths.crossed_edge.size());
    const std::vector<double> ideal = input_edge_crossings(s.tri, s.flow.u, s.paths);
    const std::vector<double> t = straightest_crossings(s.tri, s.paths, st.crossings, ideal);
    REQUIRE(t.size() == ideal.size());
    const auto by_t = positions_by_edge(s, t), by_straight = positions_by_edge(s, st.crossings),
               by_ideal = positions_by_edge(s, ideal);
    Index straight_edges = 0, crossed_edges = 0;
    for (std::size_t e = 0; e < by_t.size(); ++e) {
      const std::vector<double>& x = by_t[e];
      if (x.empty()) continue;
      ++crossed_edges;
      // In slot order, inside the edge, each gap at least the fraction of the ideal one.
      bool gaps_kept = true, straight_kept = true;
      for (std::size_t j = 0; j <= x.size(); ++j) {
        const double lo = j == 0 ? 0.0 : x[j - 1], hi = j == x.size() ? 1.0 : x[j];
        const double ideal_gap = (j == x.size() ? 1.0 : by_ideal[e][j]) - (j == 0 ? 0.0 : by_ideal[e][j - 1]);
        const double straight_gap =
            (j == x.size() ? 1.0 : by_straight[e][j]) - (j == 0 ? 0.0 : by_straight[e][j - 1]);
        CHECK(hi - lo >= kCrossingGapFraction * ideal_gap * (1 - 1e-12) - 1e-15);
        gaps_kept = gaps_kept && hi - lo > 0;
        straight_kept = straight_kept && straight_gap >= kCrossingGapFraction * ideal_gap;
      }
      CHECK(gaps_kept);
      // Where the straight positions keep the gaps, they are taken as they are.
      if (straight_kept) {
        ++straight_edges;
        for (std::size_t j = 0; j < x.size(); ++j) CHECK(x[j] == by_straight[e][j]);
      }
    }
    MESSAGE(s.name << ": " << straight_edges << " of " << crossed_edges << " crossed edges keep the straight positions");
    const CommonSubdivision cs = common_subdivision(s.tri, s.flow.u, s.mesh, s.input, s.paths, t);
    REQUIRE_MESSAGE(cs.status == Status::Ok, cs.message);
    std::vector<double> K;
    double area = 0;
    REQUIRE(curvature_of(cs.topology, s.tri.geometry, cs.l, K, area) == 0);
    CHECK(std::abs(area - total_area(s)) <= 1e-9 * std::max(1.0, area));
    if (!st.tiles()) continue;
    // Where the straight triangles tile, every straight position lies inside its edge, and an input
    // edge whose crossings all kept them is straight: its pieces add up to the straight length.
    for (const double x : st.crossings) CHECK((x > 0 && x < 1));
    Index checked = 0;
    for (Index a = 0; a < s.input.num_edges; ++a) {
      bool straight = true;
      for (Index k = s.paths.offsets[a]; k < s.paths.offsets[a + 1]; ++k) straight = straight && t[k] == st.crossings[k];
      if (!straight || s.paths.offsets[a] == s.paths.offsets[a + 1]) continue;
      ++checked;
      CHECK(std::abs(piecewise_length(s, cs, a) - st.l[a]) <= 1e-9 * st.l[a]);
    }
    CHECK(checked > 0);
  }
}

TEST_CASE("round sphere: the planar start with one vertex at infinity needs at most two spherical Newton steps") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 3; ++trial) {
    const Solved s = solve("icosphere with needles, seed " + std::to_string(trial),
                           insert_needles_and_caps(icosphere(2 + trial % 2), rng, 0.3, 0.02), Geometry::Spherical);
    INFO(s.name);
    const bool planar = std::any_of(s.flow.notes.begin(), s.flow.notes.end(),
                                    [](const std::string& n) { return n.find("at infinity") != std::string::npos; });
    CHECK(planar);
    CHECK(s.flow.iterations <= 2);
    CHECK(s.flow.max_curvature_error < 1e-12);
    CHECK(std::abs(total_area(s) - 4 * kPi) <= 1e-9);
  }
}

TEST_CASE("uniformize: vertex scaling with flips is the default, conformal beyond circle packing, in E, H and S") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(3);
  const std::pair<std::string, Mesh> meshes[] = {
      {"torus with needles", insert_needles_and_caps(torus(16, 8, 2.0, 0.7), rng, 0.3, 0.02)},
      {"pretzel with needles", insert_needles_and_caps(pretzel(2, 3), rng, 0.3, 0.02)},
      {"icosphere with needles", insert_needles_and_caps(icosphere(2), rng, 0.3, 0.02)},
      {"disk with needles", insert_needles_and_caps(disk(6), rng, 0.3, 0.02)}};
  for (const auto& [name, m] : meshes) {
    INFO(name);
    const ValidateResult v = validate_mesh(m);
    REQUIRE(v.status == Status::Ok);
    UniformizeOptions o;
    o.seed_checks = 1;
    const UniformizeResult r = uniformize(v.mesh, v.topology, o);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.intrinsic.used);
    CHECK(r.intrinsic.fallback.empty());
    CHECK(r.metric.structure.scheme == Scheme::Yamabe);
    CHECK(r.flow.max_curvature_error < 1e-12);
    // Needles of relative size 0.02 leave the propagation at up to 9e-9 (H) here; the global
    // Gauss–Newton steps bring it to the coordinates' own precision.
    CHECK(r.layout.max_edge_length_error < std::max(1e-9, 8 * r.layout.rounding_floor));
    CHECK(r.layout.max_error_above_rounding < 1e-10);
    CHECK(r.layout.flipped_faces == 0);
    CHECK(r.seed_independence_error < 1e-9);
    // The same surface by the paper's circle packing: the flips' map is more conformal.
    UniformizeOptions cp = o;
    cp.metric.scheme = Scheme::CirclePacking;
    const UniformizeResult p = uniformize(v.mesh, v.topology, cp);
    REQUIRE_MESSAGE(p.status == Status::Ok, p.message);
    CHECK_FALSE(p.intrinsic.used);
    MESSAGE(name << ": angle distortion " << r.angles.mean_abs_log << " with flips, " << p.angles.mean_abs_log
                 << " circle packing; refined " << r.intrinsic.refined << "; layout error "
                 << r.layout.max_edge_length_error << " (floor " << r.layout.rounding_floor << ", above it "
                 << r.layout.max_error_above_rounding << ", " << r.layout.polish_steps << " global steps)");
    CHECK(r.angles.mean_abs_log < p.angles.mean_abs_log);
    if (r.intrinsic.refined) {
      const InputSurfaceLayout in = input_surface_layout(v.mesh, v.topology, r);
      REQUIRE_MESSAGE(in.status == Status::Ok, in.message);
      CHECK(in.mesh.faces == v.mesh.faces);
    }
  }
}

TEST_CASE("conformal_metric: uniformize's metric stages alone, bit for bit, in E, H and S") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(5);
  const std::pair<std::string, Mesh> meshes[] = {
      {"torus with needles", insert_needles_and_caps(torus(12, 6, 2.0, 0.7), rng, 0.3, 0.02)},
      {"pretzel with needles", insert_needles_and_caps(pretzel(2, 2), rng, 0.3, 0.02)},
      {"icosphere with needles", insert_needles_and_caps(icosphere(2), rng, 0.3, 0.02)},
      {"annulus", annulus(24, 6)}};
  for (const auto& [name, m] : meshes) {
    INFO(name);
    const ValidateResult v = validate_mesh(m);
    REQUIRE(v.status == Status::Ok);
    UniformizeOptions o;
    o.seed_checks = 0;
    o.steiner_max_levels = 0;  // the same triangulation (Steiner points: their own test case)
    const UniformizeResult full = uniformize(v.mesh, v.topology, o);
    REQUIRE_MESSAGE(full.status == Status::Ok, full.message);
    const UniformizeResult c = conformal_metric(v.mesh, v.topology, o);
    REQUIRE_MESSAGE(c.status == Status::Ok, c.message);
    CHECK(c.intrinsic.used);
    CHECK(c.flow.u == full.flow.u);
    CHECK(c.flow.K == full.flow.K);
    CHECK(c.flow.l == full.flow.l);  // the input's edges, straight in the solution's metric
    REQUIRE(c.flow.l.size() == static_cast<std::size_t>(v.topology.num_edges));
    CHECK(c.intrinsic.straight_tiles == !full.intrinsic.refined);
    CHECK(c.flow.max_curvature_error < 1e-12);
    // Stops after the metric: no cut, no layout.
    CHECK(c.layout.status == Status::NotRun);
    CHECK(c.cut.cut_faces.empty());
    std::vector<std::string> stages;
    for (const auto& [stage, seconds] : c.timings) stages.push_back(stage);
    CHECK(stages == std::vector<std::string>{"initial_metric", "target", "flow", "straighten"});
    // Where the straight triangles tile, their lengths lay the input out as the metric is.
    if (c.intrinsic.straight_tiles) {
      const UniformizeResult laid = lay_out_metric(v.mesh, v.topology, c.geometry, c.flow.l, o);
      REQUIRE_MESSAGE(laid.status == Status::Ok, laid.message);
      CHECK(laid.layout.max_edge_length_error < 1e-9);
      CHECK(laid.layout.flipped_faces == 0);
    }
  }
  // Errors come back as uniformize's, naming the stage.
  const ValidateResult v = validate_mesh(ricci_shapes::torus(8, 4, 2.0, 0.7));
  UniformizeOptions bad;
  bad.flow.tolerance = -1;
  const UniformizeResult b = conformal_metric(v.mesh, v.topology, bad);
  CHECK(b.status == Status::InvalidArgument);
  CHECK(b.failed_stage == "options");
}

TEST_CASE("uniformize: a planar disk with needles and its boundary held keeps u = 0 and is laid out as it is") {
  // A flat disk whose needles and caps make it far from Delaunay: its metric is already flat, so
  // the solution is the metric itself, and the layout is the input up to a rigid motion.
  std::mt19937_64 rng(11);
  Mesh flat = ricci_shapes::disk(6);
  for (std::size_t v = 0; v < flat.positions.size(); v += 3) flat.positions[v + 2] = 0;
  const Mesh m = ricci_shapes::insert_needles_and_caps(flat, rng, 0.4, 0.02);
  const ValidateResult v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  UniformizeOptions o;
  o.boundary = BoundaryMode::FixedLengths;
  o.seed_checks = 0;
  const UniformizeResult r = uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.intrinsic.used);
  CHECK(r.intrinsic.delaunay_flips > 0);
  CHECK(r.intrinsic.flow_flips == 0);
  for (const double x : r.flow.u) CHECK(std::abs(x) <= 1e-12);
  CHECK(r.intrinsic.straight_tiles);
  REQUIRE_FALSE(r.intrinsic.refined);
  // Rigid fit of the layout onto the input's (x, y): centroids, then the rotation.
  const Index nv = v.topology.num_vertices;
  REQUIRE(r.layout.positions.size() >= static_cast<std::size_t>(2 * nv));
  double cx = 0, cy = 0, px = 0, py = 0;
  for (Index i = 0; i < nv; ++i) {
    cx += v.mesh.positions[3 * i] / nv;
    cy += v.mesh.positions[3 * i + 1] / nv;
    px += r.layout.positions[2 * i] / nv;
    py += r.layout.positions[2 * i + 1] / nv;
  }
  double dot = 0, cross = 0;
  for (Index i = 0; i < nv; ++i) {
    const double ax = r.layout.positions[2 * i] - px, ay = r.layout.positions[2 * i + 1] - py;
    const double bx = v.mesh.positions[3 * i] - cx, by = v.mesh.positions[3 * i + 1] - cy;
    dot += ax * bx + ay * by;
    cross += ax * by - ay * bx;
  }
  const double angle = std::atan2(cross, dot), c = std::cos(angle), s = std::sin(angle);
  double worst = 0;
  for (Index i = 0; i < nv; ++i) {
    const double ax = r.layout.positions[2 * i] - px, ay = r.layout.positions[2 * i + 1] - py;
    const double bx = v.mesh.positions[3 * i] - cx, by = v.mesh.positions[3 * i + 1] - cy;
    worst = std::max(worst, std::hypot(c * ax - s * ay - bx, s * ax + c * ay - by));
  }
  CHECK(worst < 1e-11);  // the disk has radius 1
  CHECK(r.angles.mean_abs_log < 1e-10);
}

TEST_CASE("uniformize: a sphere with one vertex far out maps to the round sphere (vertex scaling scales to edges below π)") {
  // The area-4π scale of such a mesh puts its long edges past π; the sphere's metric must not
  // depend on the embedding's extent.
  for (const double far : {1e3, 1e6, 1e12, 1e15}) {  // from 1e12 on its faces are nearly flat
    CAPTURE(far);
    Mesh m = ricci_shapes::icosphere(2);
    m.positions[0] = far;
    m.positions[1] = 0;
    m.positions[2] = 0;
    const ValidateResult v = validate_mesh(m);
    REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
    UniformizeOptions o;
    o.seed_checks = 0;
    const UniformizeResult r = uniformize(v.mesh, v.topology, o);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.geometry == Geometry::Spherical);
    CHECK(r.intrinsic.used);
    CHECK(r.flow.max_curvature_error < 1e-12);
    CHECK(r.layout.max_edge_length_error < 1e-9);
    CHECK(r.layout.flipped_faces == 0);
    // Every edge of the initial metric is below π, the longest at 0.9 π.
    double longest = 0;
    for (const double x : r.metric.l0) longest = std::max(longest, x);
    CHECK(longest <= 0.9 * kPi * (1 + 1e-12));
  }
}

TEST_CASE("uniformize: the regular tetrahedron maps to the round sphere by default") {
  Mesh tet;
  const double s = 1 / std::sqrt(3.0);
  tet.positions = {s, s, s, s, -s, -s, -s, s, -s, -s, -s, s};
  tet.faces = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  const ValidateResult v = validate_mesh(tet);
  REQUIRE(v.status == Status::Ok);
  const UniformizeResult r = uniformize(v.mesh, v.topology);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.intrinsic.used);
  CHECK(r.flow.max_curvature_error < 1e-12);
  CHECK(r.layout.flipped_faces == 0);
  // Every edge the same length on the sphere: a regular inscribed tetrahedron, arc acos(−1/3).
  for (const double l : r.flow.l) CHECK(std::abs(l - std::acos(-1.0 / 3)) <= 1e-10);
  // 3D angles π/3 against the spherical regular tetrahedron's 2π/3 at every corner.
  CHECK(std::abs(r.angles.max_abs_log - std::log(2.0)) <= 1e-9);
  CHECK(std::abs(r.angles.mean_abs_log - std::log(2.0)) <= 1e-9);
}

TEST_CASE("uniformize: cone targets are laid out through a cut that passes through every cone (E, H, bordered H)") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(17);
  struct Case {
    std::string name;
    Mesh mesh;
    double cone;  // ± this curvature at two random interior vertices (E: they must cancel)
  };
  const Case cases[] = {
      {"torus (E)", torus(16, 8, 2.0, 0.7), 0.5},
      {"pretzel (H)", pretzel(2, 3), 0.4},
      {"pretzel with two holes (H, geodesic boundary)", remove_vertex_stars(pretzel(2, 3), {5, 60}), 0.4},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const ValidateResult v = validate_mesh(c.mesh);
    REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
    const Topology& t = v.topology;
    UniformizeOptions o;
    o.seed_checks = 1;
    const Geometry g = natural_geometry(t);
    Target target = uniform_target(t, natural_boundary_mode(t, g));
    std::vector<Index> interior;
    for (Index x = 0; x < t.num_vertices; ++x)
      if (!t.is_boundary_vertex(x)) interior.push_back(x);
    std::shuffle(interior.begin(), interior.end(), rng);
    const Index a = interior[0], b = interior[1];
    target.K[a] += c.cone;
    target.K[b] -= c.cone;
    const UniformizeResult r = uniformize(v.mesh, t, o, &target);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.intrinsic.used);
    CHECK(r.flow.max_curvature_error < 1e-12);
    CHECK(r.layout.max_edge_length_error < 1e-9);
    CHECK(r.layout.flipped_faces == 0);
    CHECK(r.seed_independence_error < 1e-9);
    CHECK_FALSE(r.has_deck);
    // Both cones lie on the domain's boundary (the cut passes through them).
    for (const Index cone : {a, b}) {
      bool on_cut = false;
      for (Index x = 0; x < r.cut.num_cut_vertices(); ++x)
        on_cut = on_cut || (r.cut.cut_to_surface[x] == cone && r.disk.is_boundary_vertex(x));
      CHECK_MESSAGE(on_cut, "cone vertex " << cone);
    }
    // In E the layout's angles around a cone add up to its cone angle 2π − K̄.
    if (g == Geometry::Euclidean) {
      const std::vector<double>& p = r.layout.positions;
      for (const Index cone : {a, b}) {
        double sum = 0;
        for (Index f = 0; f < r.disk.num_faces; ++f)
          for (Index k = 0; k < 3; ++k) {
            const Index x = r.disk.corner_vertex[3 * f + k];
            if (r.cut.cut_to_surface[x] != cone) continue;
            const Index y = r.disk.corner_vertex[3 * f + (k + 1) % 3], z = r.disk.corner_vertex[3 * f + (k + 2) % 3];
            const double ux = p[2 * y] - p[2 * x], uy = p[2 * y + 1] - p[2 * x + 1];
            const double vx = p[2 * z] - p[2 * x], vy = p[2 * z + 1] - p[2 * x + 1];
            sum += std::atan2(ux * vy - uy * vx, ux * vx + uy * vy);
          }
        CHECK(std::abs(sum - (2 * kPi - target.K[cone])) <= 1e-9);
      }
    }
  }
  // A disk is laid out uncut: cones there are refused by name.
  const ValidateResult d = validate_mesh(ricci_shapes::disk(6));
  REQUIRE(d.status == Status::Ok);
  Target target = uniform_target(d.topology, BoundaryMode::Circle);
  double cone = 0.3;  // +0.3 and −0.3 at the first two interior vertices
  for (Index x = 0; x < d.topology.num_vertices && cone > -1; ++x)
    if (!d.topology.is_boundary_vertex(x)) {
      target.K[x] += cone;
      cone = cone > 0 ? -0.3 : -2;
    }
  const UniformizeResult r = uniformize(d.mesh, d.topology, UniformizeOptions{}, &target);
  INFO(r.message);
  CHECK(r.status != Status::Ok);
  CHECK(r.failed_stage == "cut");
  CHECK(r.message.find("cone vertices") != std::string::npos);
}

TEST_CASE("the library prints nothing: Ceres stopping on invalid steps stays silent") {
  // The side pairings of a cone metric's domain are no surface group's: fitting them anyway makes
  // Ceres' minimizer stop on consecutive invalid steps, which glog would report on stderr.
  const LoadResult lr = load_mesh((ricci_test::fixtures_dir() / "genus2.obj").string());
  REQUIRE(lr.status == Status::Ok);
  Target target = uniform_target(lr.validated.topology, BoundaryMode::Free);
  target.K[0] += 0.5;
  target.K[5] -= 0.3;
  UniformizeOptions o;
  o.seed_checks = 0;
  o.intrinsic_flips = false;
  const UniformizeResult r = uniformize(lr.validated.mesh, lr.validated.topology, o, &target);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  std::fflush(stderr);
  const std::string path = (std::filesystem::temp_directory_path() / "ricci-test-stderr.txt").string();
  const int saved = dup(2);
  const int file = open(path.c_str(), O_CREAT | O_TRUNC | O_WRONLY, 0600);
  REQUIRE(saved >= 0);
  REQUIRE(file >= 0);
  dup2(file, 2);
  const DomainDeck dd = fit_domain_pairings(r.cut, r.layout.positions, DeckOptions{});
  std::fflush(stderr);
  dup2(saved, 2);
  close(saved);
  close(file);
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  std::filesystem::remove(path, ec);
  CHECK(dd.status != Status::NotRun);
  CHECK(bytes == 0);
}

TEST_CASE("layout: Gauss–Seidel sweeps on the sphere keep every point on it and lower the edge error") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(23);
  for (int trial = 0; trial < 3; ++trial) {
    const Solved s = solve("icosphere with needles, seed " + std::to_string(trial),
                           insert_needles_and_caps(icosphere(3), rng, 0.3, 0.01), Geometry::Spherical);
    INFO(s.name);
    // The metric on the input's triangulation: where the straight triangles tile (else skip).
    const StraightInputMetric st = straight_input_metric(s.tri, s.flow.u, s.input, s.paths);
    REQUIRE(st.status == Status::Ok);
    if (!st.tiles()) continue;
    LayoutOptions raw, polished;
    raw.polish_sweeps = 0;
    raw.polish_steps = polished.polish_steps = 0;  // the sweeps alone
    polished.polish_sweeps = 30;
    polished.refine_above = 0;  // sweep even though the propagation is within 1e-10 of its floor
    raw.sphere_mobius = polished.sphere_mobius = false;
    const Layout a = layout_sphere(s.input, st.l, raw), b = layout_sphere(s.input, st.l, polished);
    REQUIRE(a.status == Status::Ok);
    REQUIRE(b.status == Status::Ok);
    // In rounds of 1, 2, 4, …: all 30 unless the layout reaches its rounding floor before or a
    // round raises the error (that round is undone): the count is always a whole number of rounds.
    CHECK(b.polish_sweeps >= 1);
    CHECK(b.polish_sweeps <= 30);
    const bool whole_rounds = b.polish_sweeps == 30 || ((b.polish_sweeps + 1) & b.polish_sweeps) == 0;
    CHECK(whole_rounds);
    CHECK(a.polish_sweeps == 0);
    double off_sphere = 0;
    for (Index v = 0; v < s.input.num_vertices; ++v) {
      const double* x = &b.positions[3 * static_cast<std::size_t>(v)];
      off_sphere = std::max(off_sphere, std::abs(std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) - 1));
    }
    CHECK(off_sphere <= 1e-15);
    MESSAGE(s.name << ": edge error " << a.max_edge_length_error << " without sweeps, " << b.max_edge_length_error
                   << " with " << b.polish_sweeps);
    // The sweeps spread the seam where the front closes: here they take 1e-11 to below 1e-12.
    CHECK(b.max_edge_length_error <= std::max(0.1 * a.max_edge_length_error, 1e-14));
    CHECK(b.flipped_faces == 0);
  }
}

TEST_CASE("circle domains: the boundary system goes direct once GMRES has cost more, deterministically") {
  // A long annulus (100 rings of 40), vertex scaling, circle boundaries: the estimate picks GMRES
  // for the boundary system of the length-dependent target; GMRES then needs more full solves in
  // a step than the direct solve costs, and the later steps solve it directly (a count, not a
  // clock: the same on every run and thread count).
  const ValidateResult v = validate_mesh(ricci_shapes::annulus(100, 40));
  REQUIRE(v.status == Status::Ok);
  InitialMetricOptions mo;
  mo.scheme = Scheme::Yamabe;
  const InitialMetric m = initial_metric(v.mesh, v.topology, mo);
  REQUIRE(m.status == Status::Ok);
  const Target target = uniform_target(v.topology, BoundaryMode::Circle);
  std::vector<double> first;
  for (int threads : {1, 2, 1}) {
    CAPTURE(threads);
    FlowOptions fo;
    fo.tolerance = 1e-12;
    fo.threads = threads;
    fo.split_loop_coupling = false;  // the boundary system (vertex scaling takes the split by default)
    const FlowResult f = solve_flow(v.topology, m.structure, m.u, target, fo);
    REQUIRE_MESSAGE(f.status == Status::Ok, f.message);
    CHECK(f.max_curvature_error < 1e-12);
    bool switched = false;
    for (const std::string& n : f.notes) switched = switched || n.find("solved directly from Newton step") != std::string::npos;
    CHECK(switched);
    if (first.empty()) first = f.u;
    else CHECK(f.u == first);
  }
}
