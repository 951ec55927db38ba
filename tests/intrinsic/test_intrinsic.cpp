// Intrinsic triangulations and the vertex-scaling flow with Delaunay flips: exact inverse flips,
// Ptolemy's relation, flips commuting with vertex scaling, the Delaunay test against angles, the
// metric's independence of the flip path, Gauss–Bonnet, the Hessian on flipped triangulations,
// Delaunay after every Newton step, thread invariance, and convergence on hard meshes and known
// answers in E, H and S; the fill-reducing ordering carried over a pattern changed by flips.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/intrinsic.h"
#include "ricci/validate.h"
#include "hessian.h"
#include "sparse_solver.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;

namespace {

constexpr double kPi = std::numbers::pi;

struct Case {
  std::string name;
  Mesh mesh;
  Topology topology;
  Geometry geometry;
  std::vector<double> l;  // the mesh's own lengths in `geometry` (scaled to fit S)
};

Case make_case(const std::string& name, const Mesh& input, Geometry g) {
  Case c;
  c.name = name;
  const ValidateResult v = validate_mesh(input);
  REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
  c.mesh = v.mesh;
  c.topology = v.topology;
  c.geometry = g;
  // The lengths the pipeline starts from, read off a triangulation made without flips.
  const IntrinsicResult r = mesh_intrinsic_triangulation(c.mesh, c.topology, g);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  c.l = mesh_edge_lengths(c.mesh, c.topology);
  if (g != Geometry::Euclidean) {
    // Same scale as mesh_intrinsic_triangulation(): recover it from any edge it kept unflipped.
    const Topology& t = r.triangulation.topology;
    for (Index e = 0; e < t.num_edges; ++e) {
      if (t.edge_vertices[2 * e] != c.topology.edge_vertices[2 * e] ||
          t.edge_vertices[2 * e + 1] != c.topology.edge_vertices[2 * e + 1])
        continue;
      const double L = std::exp(r.triangulation.log_chord_of(e));
      const double length = g == Geometry::Hyperbolic ? 2 * std::asinh(L) : 2 * std::asin(L);
      const double scale = length / c.l[e];
      for (double& x : c.l) x *= scale;
      break;
    }
  }
  return c;
}

std::vector<Case> cases() {
  using namespace ricci_shapes;
  std::vector<Case> out;
  std::mt19937_64 rng(7);
  out.push_back(make_case("torus with needles (E)", insert_needles_and_caps(torus(16, 8, 2.0, 0.7), rng, 0.3, 0.02),
                          Geometry::Euclidean));
  out.push_back(make_case("genus-2 pretzel with needles (H)", insert_needles_and_caps(pretzel(2, 3), rng, 0.3, 0.02),
                          Geometry::Hyperbolic));
  out.push_back(make_case("icosphere with needles (S)", insert_needles_and_caps(icosphere(2), rng, 0.3, 0.02),
                          Geometry::Spherical));
  out.push_back(make_case("disk with needles (E)", insert_needles_and_caps(disk(6), rng, 0.3, 0.02),
                          Geometry::Euclidean));
  return out;
}

IntrinsicTriangulation intrinsic(const Case& c, bool delaunay) {
  if (delaunay) {
    IntrinsicResult r = mesh_intrinsic_triangulation(c.mesh, c.topology, c.geometry);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    return std::move(r.triangulation);
  }
  IntrinsicResult r = make_intrinsic_triangulation(c.topology, c.geometry, c.l, delaunay);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  return std::move(r.triangulation);
}

std::vector<double> random_u(Index n, std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> d(-scale, scale);
  std::vector<double> u(static_cast<std::size_t>(n));
  for (double& x : u) x = d(rng);
  return u;
}

// Curvature and face areas of the triangulation at u; the number of triangle-inequality violations.
Index curvature(const IntrinsicTriangulation& tri, std::span<const double> u, std::vector<double>& K,
                std::vector<double>* area = nullptr) {
  ConformalStructure s;
  vertex_scaling_structure(tri, s);
  const Topology& t = tri.topology;
  std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(3 * static_cast<std::size_t>(t.num_faces));
  K.assign(static_cast<std::size_t>(t.num_vertices), 0.0);
  if (edge_lengths(t, s, u, l) != kInvalid) return -1;
  const AngleReport angles = corner_angles(t, tri.geometry, l, theta);
  vertex_curvature(t, theta, K);
  if (area) {
    area->assign(static_cast<std::size_t>(t.num_faces), 0.0);
    face_areas(t, tri.geometry, l, theta, *area);
  }
  return angles.violations;
}

double max_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

// Faces as cyclically normalized vertex triples, sorted (the triangulation up to corner slots).
std::vector<std::array<Index, 3>> face_set(const Topology& t) {
  std::vector<std::array<Index, 3>> faces;
  for (Index f = 0; f < t.num_faces; ++f) {
    std::array<Index, 3> a = {t.corner_vertex[3 * f], t.corner_vertex[3 * f + 1], t.corner_vertex[3 * f + 2]};
    std::rotate(a.begin(), std::min_element(a.begin(), a.end()), a.end());
    faces.push_back(a);
  }
  std::sort(faces.begin(), faces.end());
  return faces;
}

Index random_flippable_edge(const IntrinsicTriangulation& tri, std::mt19937_64& rng) {
  std::uniform_int_distribution<Index> pick(0, tri.topology.num_edges - 1);
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const Index e = pick(rng);
    if (can_flip(tri, e) == FlipCheck::Ok) return e;
  }
  return kInvalid;
}

double min_margin(const IntrinsicTriangulation& tri, std::span<const double> u) {
  double m = 1;
  for (Index e = 0; e < tri.topology.num_edges; ++e) m = std::min(m, delaunay_margin(tri, u, e));
  return m;
}

}  // namespace

TEST_CASE("intrinsic: random flips keep the corner table valid and flipping back restores every log-chord bit for bit") {
  for (const Case& c : cases()) {
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      INFO(c.name);
      std::mt19937_64 rng(seed);
      IntrinsicTriangulation tri = intrinsic(c, false);
      const std::vector<std::int64_t> chords0 = tri.log_chord;
      const auto faces0 = face_set(tri.topology);
      std::vector<Index> flipped;
      // Enough flips for Δ-complex quadrilaterals (two sides one edge, loops) to arise.
      for (int i = 0; i < 2000; ++i) {
        const Index e = random_flippable_edge(tri, rng);
        REQUIRE(e != kInvalid);
        flip_edge(tri, e);
        flipped.push_back(e);
      }
      refresh_vertex_corners(tri.topology);
      REQUIRE(ricci_test::check_topology(tri.topology, tri.topology.corner_vertex) == "");
      CHECK(tri.flips == 2000);
      // Boundary edges never move.
      for (Index p = 0; p < tri.topology.num_boundary_edges(); ++p)
        CHECK(tri.boundary_position[tri.topology.corner_edge[tri.topology.boundary_corners[p]]] == p);
      // Flipping back in reverse order: each flip's inverse is the flip of the same edge.
      for (auto it = flipped.rbegin(); it != flipped.rend(); ++it) {
        REQUIRE(can_flip(tri, *it) == FlipCheck::Ok);
        flip_edge(tri, *it);
      }
      refresh_vertex_corners(tri.topology);
      CHECK(tri.log_chord == chords0);
      CHECK(face_set(tri.topology) == faces0);
      CHECK(ricci_test::check_topology(tri.topology, tri.topology.corner_vertex) == "");
    });
  }
}

namespace {

// Every array of the two triangulations equal, vertex_corners and normal coordinates included.
void check_same_triangulation(const IntrinsicTriangulation& a, const IntrinsicTriangulation& b) {
  const Topology &s = a.topology, &t = b.topology;
  CHECK(s.corner_vertex == t.corner_vertex);
  CHECK(s.opposite == t.opposite);
  CHECK(s.corner_edge == t.corner_edge);
  CHECK(s.edge_vertices == t.edge_vertices);
  CHECK(s.edge_corners == t.edge_corners);
  CHECK(s.vertex_corner_offsets == t.vertex_corner_offsets);
  CHECK(s.vertex_corners == t.vertex_corners);
  CHECK(s.boundary_offsets == t.boundary_offsets);
  CHECK(s.boundary_vertices == t.boundary_vertices);
  CHECK(s.boundary_corners == t.boundary_corners);
  CHECK(a.log_chord == b.log_chord);
  CHECK(a.boundary_position == b.boundary_position);
  CHECK(a.normal == b.normal);
  CHECK(a.flips == b.flips);
}

}  // namespace

TEST_CASE("intrinsic: a flip journal puts the triangulation back bit for bit, wholly or to a mark") {
  for (const Case& c : cases()) {
    ricci_test::for_each_seed(1, 2, [&](std::uint64_t seed) {
      INFO(c.name);
      std::mt19937_64 rng(seed);
      // Odd seeds start from build_topology()'s vertex_corners (no flips yet), even ones from a
      // Delaunay triangulation's.
      const IntrinsicTriangulation start = intrinsic(c, seed % 2 == 0);
      REQUIRE(!start.normal.empty());
      IntrinsicTriangulation tri = start;
      FlipJournal journal;
      // Delaunay at one u, then at another on top of it (what a trial and a quadrature node do).
      const std::vector<double> u1 = random_u(tri.topology.num_vertices, rng, 0.5);
      const DelaunayReport first = make_delaunay(tri, u1, non_delaunay_edges(tri, u1), {}, &journal);
      REQUIRE(first.flips > 0);
      CHECK(journal.flips() == first.flips);
      CHECK(tri.flips == start.flips + first.flips);
      const IntrinsicTriangulation after_first = tri;
      const std::int64_t mark = journal.flips();
      const std::vector<double> u2 = random_u(tri.topology.num_vertices, rng, 1.0);
      const DelaunayReport second = make_delaunay(tri, u2, non_delaunay_edges(tri, u2), {}, &journal);
      REQUIRE(second.flips > 0);
      CHECK(non_delaunay_edges(tri, u2).size() == static_cast<std::size_t>(second.refused));
      undo_flips(tri, journal, mark);
      CHECK(journal.flips() == mark);
      check_same_triangulation(tri, after_first);
      // Random Ptolemy flips and geometric ones, recorded too: enough for Δ-complex quadrilaterals
      // (two sides one edge, loops) to arise.
      int glued = 0;  // flips of a quadrilateral with two of its sides one edge
      for (int i = 0; i < 2000; ++i) {
        const Index e = random_flippable_edge(tri, rng);
        REQUIRE(e != kInvalid);
        const Topology& t = tri.topology;
        const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
        std::array<Index, 4> sides = {t.corner_edge[next_corner(c0)], t.corner_edge[prev_corner(c0)],
                                      t.corner_edge[next_corner(c1)], t.corner_edge[prev_corner(c1)]};
        std::sort(sides.begin(), sides.end());
        if (std::adjacent_find(sides.begin(), sides.end()) != sides.end()) ++glued;
        if (i % 2 == 0 || !flip_edge_geometric(tri, u1, e, &journal)) flip_edge(tri, e, &journal);
      }
      CHECK(glued > 0);
      undo_flips(tri, journal);
      CHECK(journal.flips() == 0);
      check_same_triangulation(tri, start);
      CHECK(ricci_test::check_topology(tri.topology, tri.topology.corner_vertex) == "");
    });
  }
}

TEST_CASE("intrinsic: Ptolemy's relation holds for every flip and flips commute with vertex scaling") {
  for (const Case& c : cases()) {
    INFO(c.name);
    std::mt19937_64 rng(11);
    IntrinsicTriangulation tri = intrinsic(c, false);
    const Topology& t = tri.topology;
    for (int i = 0; i < 100; ++i) {
      const std::vector<double> u = random_u(t.num_vertices, rng, 0.5);
      const Index e = random_flippable_edge(tri, rng);
      REQUIRE(e != kInvalid);
      const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
      const Index k = t.corner_vertex[c0], i0 = t.corner_vertex[next_corner(c0)], j0 = t.corner_vertex[prev_corner(c0)],
                  l = t.corner_vertex[c1];
      auto chord = [&](Index edge, Index a, Index b) { return std::exp(tri.log_chord_of(edge) + 0.5 * (u[a] + u[b])); };
      const double ij = chord(e, i0, j0), ki = chord(t.corner_edge[prev_corner(c0)], k, i0),
                   jk = chord(t.corner_edge[next_corner(c0)], j0, k), il = chord(t.corner_edge[next_corner(c1)], i0, l),
                   lj = chord(t.corner_edge[prev_corner(c1)], l, j0);
      // Scale, then flip: a triangulation whose chords at u = 0 are those at u.
      IntrinsicTriangulation scaled = tri;
      for (Index f = 0; f < t.num_edges; ++f) {
        const Index a = t.edge_vertices[2 * f], b = t.edge_vertices[2 * f + 1];
        scaled.log_chord[f] += std::llround(0.5 * (u[a] + u[b]) / kLogChordUnit);
      }
      flip_edge(scaled, e);
      flip_edge(tri, e);
      const double kl = chord(e, k, l);
      CHECK(std::abs(kl * ij - (il * jk + lj * ki)) <= 1e-13 * (il * jk + lj * ki));
      CHECK(std::abs(scaled.log_chord_of(e) - (tri.log_chord_of(e) + 0.5 * (u[k] + u[l]))) <= 1e-13);
    }
  }
}

TEST_CASE("intrinsic: the chord test of Delaunay agrees with the angle test (E: α + β ≤ π, H and S: ≤ the other four)") {
  for (const Case& c : cases()) {
    INFO(c.name);
    const IntrinsicTriangulation tri = intrinsic(c, false);
    const Topology& t = tri.topology;
    const std::vector<double> u(static_cast<std::size_t>(t.num_vertices), 0.0);  // the mesh's own metric
    ConformalStructure s;
    vertex_scaling_structure(tri, s);
    std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(3 * static_cast<std::size_t>(t.num_faces));
    REQUIRE(edge_lengths(t, s, u, l) == kInvalid);
    REQUIRE(corner_angles(t, tri.geometry, l, theta).violations == 0);
    int compared = 0, non_delaunay = 0;
    for (Index e = 0; e < t.num_edges; ++e) {
      const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
      if (c1 == kInvalid) continue;
      const double facing = theta[c0] + theta[c1];
      const double others = theta[next_corner(c0)] + theta[prev_corner(c0)] + theta[next_corner(c1)] + theta[prev_corner(c1)];
      const double gap = others - facing;
      const double margin = delaunay_margin(tri, u, e);
      if (std::abs(gap) < 1e-9) continue;
      ++compared;
      if (gap < 0) ++non_delaunay;
      CHECK_MESSAGE((margin >= 0) == (gap >= 0), "edge " << e << ": margin " << margin << ", angle gap " << gap);
    }
    CHECK(compared > 100);
    CHECK(non_delaunay > 0);  // the needles make some edges non-Delaunay: both outcomes are tested
  }
}

TEST_CASE("intrinsic: non_delaunay_edges() finds exactly the edges the margin flags, and seeds make_delaunay() to the same result") {
  std::mt19937_64 rng(17);
  for (const Case& c : cases()) {
    INFO(c.name);
    const IntrinsicTriangulation start = intrinsic(c, false);
    const Topology& t = start.topology;
    // Mild, strong and extreme factors: the last sends chords past 1e100, where the test falls
    // back to delaunay_margin() itself.
    for (const double scale : {0.0, 0.5, 3.0, 300.0}) {
      CAPTURE(scale);
      const std::vector<double> u = random_u(t.num_vertices, rng, scale);
      const double tol = DelaunayOptions{}.tolerance;
      std::vector<Index> expected;
      for (Index e = 0; e < t.num_edges; ++e)
        if (delaunay_margin(start, u, e) < -tol) expected.push_back(e);
      const std::vector<Index> found = non_delaunay_edges(start, u);
      CHECK(found == expected);
      if (scale == 0.0) CHECK(!found.empty());  // the needles: some edges are not Delaunay
      if (scale > 100) continue;  // chords beyond double range: no metric to flip to
      IntrinsicTriangulation a = start, b = start;
      const DelaunayReport ra = make_delaunay(a, u);
      const DelaunayReport rb = make_delaunay(b, u, found);
      CHECK(ra.flips == rb.flips);
      CHECK(a.log_chord == b.log_chord);
      CHECK(a.topology.corner_vertex == b.topology.corner_vertex);
      CHECK(non_delaunay_edges(a, u).size() == static_cast<std::size_t>(ra.refused));
    }
  }
}

TEST_CASE("intrinsic: the metric at u does not depend on the flips before it — any flip path, then Delaunay, gives the same curvature") {
  for (const Case& c : cases()) {
    INFO(c.name);
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      std::mt19937_64 rng(seed);
      IntrinsicTriangulation a = intrinsic(c, true);
      IntrinsicTriangulation b = a;
      const std::vector<double> u = random_u(a.topology.num_vertices, rng, c.geometry == Geometry::Spherical ? 0.2 : 1.0);
      // b takes a random walk of Ptolemy flips first (which changes its triangles, not its class).
      for (int i = 0; i < 300; ++i) flip_edge(b, random_flippable_edge(b, rng));
      refresh_vertex_corners(b.topology);
      const DelaunayReport ra = make_delaunay(a, u), rb = make_delaunay(b, u);
      CHECK(ra.complete);
      CHECK(rb.complete);
      CHECK(ra.refused == 0);
      CHECK(rb.refused == 0);
      CHECK(ra.flips > 0);
      CHECK(min_margin(a, u) >= -1e-12);
      CHECK(min_margin(b, u) >= -1e-12);
      REQUIRE(ricci_test::check_topology(a.topology, a.topology.corner_vertex) == "");
      std::vector<double> Ka, Kb, area;
      // A Delaunay triangulation satisfies the triangle inequality on a closed surface; with a
      // boundary, whose edges never flip, a triangle on it may not at such a far u.
      const Index va = curvature(a, u, Ka, &area), vb = curvature(b, u, Kb);
      if (c.topology.is_closed()) {
        CHECK(va == 0);
        CHECK(vb == 0);
      }
      CHECK(max_abs_difference(Ka, Kb) <= 1e-11);
      // Gauss–Bonnet on the flipped triangulation.
      CHECK(std::abs(gauss_bonnet_defect(a.topology, a.geometry, Ka, area)) <= 1e-10);
    });
  }
}

TEST_CASE("intrinsic: geometric flips to the intrinsic Delaunay triangulation keep the surface — every curvature unchanged") {
  for (const Case& c : cases()) {
    INFO(c.name);
    const IntrinsicTriangulation before = intrinsic(c, false);
    IntrinsicResult after = make_intrinsic_triangulation(c.topology, c.geometry, c.l, true);
    REQUIRE(after.status == Status::Ok);
    CHECK(after.delaunay_flips > 0);
    CHECK(after.delaunay_refused == 0);
    const std::vector<double> zero(static_cast<std::size_t>(c.topology.num_vertices), 0.0);
    CHECK(min_margin(after.triangulation, zero) >= -1e-12);
    std::vector<double> K0, K1;
    REQUIRE(curvature(before, zero, K0) == 0);
    REQUIRE(curvature(after.triangulation, zero, K1) == 0);
    CHECK(max_abs_difference(K0, K1) <= 1e-11);
  }
}

TEST_CASE("intrinsic: the Hessian blocks on a flipped triangulation match finite differences of the curvature") {
  for (const Case& c : cases()) {
    INFO(c.name);
    std::mt19937_64 rng(5);
    IntrinsicTriangulation tri = intrinsic(c, true);
    const Topology& t = tri.topology;
    const std::vector<double> u =
        random_u(t.num_vertices, rng, c.geometry == Geometry::Spherical || !t.is_closed() ? 0.2 : 1.0);
    REQUIRE(make_delaunay(tri, u).flips > 0);
    ConformalStructure s;
    vertex_scaling_structure(tri, s);
    std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(3 * static_cast<std::size_t>(t.num_faces)),
        blocks(9 * static_cast<std::size_t>(t.num_faces));
    REQUIRE(edge_lengths(t, s, u, l) == kInvalid);
    REQUIRE(corner_angles(t, tri.geometry, l, theta).violations == 0);
    angle_derivative_blocks(t, s, u, l, theta, blocks);
    std::uniform_int_distribution<Index> pick(0, t.num_vertices - 1);
    for (int trial = 0; trial < 10; ++trial) {
      const Index v = pick(rng);
      CAPTURE(v);
      // ∂K/∂u_v from the blocks: K_w = 2π − Σθ (or π − Σθ), so ∂K_w/∂u_v = −Σ B[c_w][c_v].
      std::vector<double> column(static_cast<std::size_t>(t.num_vertices), 0.0);
      for (Index f = 0; f < t.num_faces; ++f)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            if (t.corner_vertex[3 * f + b] == v) column[t.corner_vertex[3 * f + a]] -= blocks[9 * f + 3 * a + b];
      const double h = 1e-6;
      std::vector<double> up = u, down = u, Kp, Km;
      up[v] += h;
      down[v] -= h;
      REQUIRE(curvature(tri, up, Kp) == 0);
      REQUIRE(curvature(tri, down, Km) == 0);
      for (Index w = 0; w < t.num_vertices; ++w) CHECK(std::abs((Kp[w] - Km[w]) / (2 * h) - column[w]) <= 1e-6);
    }
  }
}

TEST_CASE("intrinsic flow: converges on needle-and-cap meshes in E, H and S, Delaunay after every Newton step") {
  for (const Case& c : cases()) {
    INFO(c.name);
    const Target target = uniform_target(c.topology, BoundaryMode::Circle);
    const std::vector<double> u0(static_cast<std::size_t>(c.topology.num_vertices), 0.0);
    IntrinsicTriangulation tri = intrinsic(c, true);
    const FlowResult r = solve_flow_with_flips(tri, u0, target);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.max_curvature_error < 1e-10);
    CHECK(r.gauss_bonnet_error < 1e-9);
    CHECK(r.iterations <= 12);
    CHECK(min_margin(tri, r.u) >= -1e-12);
    MESSAGE(c.name << ": " << r.iterations << " Newton steps, " << r.flips << " flips");
    // The state after each step: a solve stopped after k steps follows the same path.
    for (int k = 1; k < r.iterations; ++k) {
      CAPTURE(k);
      FlowOptions o;
      o.max_iterations = k;
      IntrinsicTriangulation partial = intrinsic(c, true);
      const FlowResult p = solve_flow_with_flips(partial, u0, target, o);
      REQUIRE(p.iterations == k);
      CHECK(min_margin(partial, p.u) >= -1e-12);
      std::vector<double> K;
      CHECK(curvature(partial, p.u, K) == 0);
      CHECK(max_abs_difference(K, p.K) == 0);
    }
  }
}

TEST_CASE("intrinsic flow: bitwise identical for 1 and 2 threads") {
  const Case c = make_case("icosphere(5) with needles", [] {
    std::mt19937_64 rng(2);
    return ricci_shapes::insert_needles_and_caps(ricci_shapes::icosphere(5), rng, 0.1, 0.02);
  }(), Geometry::Spherical);
  const Target target = uniform_target(c.topology, BoundaryMode::Circle);
  const std::vector<double> u0(static_cast<std::size_t>(c.topology.num_vertices), 0.0);
  FlowResult r[2];
  std::vector<std::int64_t> chords[2];
  for (int threads = 1; threads <= 2; ++threads) {
    FlowOptions o;
    o.threads = threads;
    IntrinsicTriangulation tri = intrinsic(c, true);
    r[threads - 1] = solve_flow_with_flips(tri, u0, target, o);
    REQUIRE_MESSAGE(r[threads - 1].status == Status::Ok, r[threads - 1].message);
    chords[threads - 1] = tri.log_chord;
  }
  CHECK(r[0].u == r[1].u);
  CHECK(r[0].K == r[1].K);
  CHECK(r[0].flips == r[1].flips);
  CHECK(chords[0] == chords[1]);
}

TEST_CASE("intrinsic flow: a planar disk with its boundary held keeps u = 0") {
  const Case c = make_case("strip", ricci_shapes::strip(12, 5, 3.0, 1.0), Geometry::Euclidean);
  Target target = uniform_target(c.topology, BoundaryMode::FixedLengths);
  const std::vector<double> u0(static_cast<std::size_t>(c.topology.num_vertices), 0.0);
  IntrinsicTriangulation tri = intrinsic(c, true);
  const FlowResult r = solve_flow_with_flips(tri, u0, target);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.flips == 0);
  for (const double x : r.u) CHECK(std::abs(x) <= 1e-12);
}

TEST_CASE("intrinsic flow: the regular tetrahedron, octahedron and an icosphere map to the round sphere with their symmetry") {
  // Regular tetrahedron and octahedron as meshes (outward faces).
  Mesh tet;
  const double s = 1 / std::sqrt(3.0);
  tet.positions = {s, s, s, s, -s, -s, -s, s, -s, -s, -s, s};
  tet.faces = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  Mesh oct;
  oct.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  oct.faces = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  const std::pair<std::string, Mesh> meshes[] = {
      {"tetrahedron", tet}, {"octahedron", oct}, {"icosphere(2)", ricci_shapes::icosphere(2)}};
  for (const auto& [name, mesh] : meshes) {
    INFO(name);
    const Case c = make_case(name, mesh, Geometry::Spherical);
    const Target target = uniform_target(c.topology, BoundaryMode::Circle);
    const std::vector<double> u0(static_cast<std::size_t>(c.topology.num_vertices), 0.0);
    IntrinsicTriangulation tri = intrinsic(c, true);
    const FlowResult r = solve_flow_with_flips(tri, u0, target);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.max_curvature_error < 1e-10);
    // Symmetric inputs stay symmetric: all lengths of a platonic solid are equal at the solution.
    if (name != "icosphere(2)") {
      const auto [lo, hi] = std::minmax_element(r.l.begin(), r.l.end());
      CHECK(*hi - *lo <= 1e-10);
    }
    // The round sphere: K = 0 at every vertex, total area 4π.
    std::vector<double> K, area;
    REQUIRE(curvature(tri, r.u, K, &area) == 0);
    double total = 0;
    for (const double a : area) total += a;
    CHECK(std::abs(total - 4 * kPi) <= 1e-9);
  }
}

namespace {

// Nonzeros of the Cholesky factor of `p` with `order` (empty: a fresh AMD / METIS ordering), and
// that ordering.
double factor_fill(const detail::HessianPattern& p, std::span<const std::int64_t> order,
                   std::vector<std::int64_t>* used = nullptr) {
  detail::SymmetricSolver s;
  REQUIRE(s.analyze(p.num_unknowns, p.col_ptr, p.row, detail::FactorKind::PositiveDefinite, order) ==
          detail::FactorOutcome::Ok);
  if (used) {
    used->resize(static_cast<std::size_t>(p.num_unknowns));
    REQUIRE(s.ordering(*used));
  }
  return s.factor_nonzeros();
}

}  // namespace

TEST_CASE("intrinsic: the ordering carried over flips keeps the factor near a fresh ordering's, where the old one fills") {
  // A genus-2 surface (METIS nested dissection: a flip across a separator joins its two halves)
  // and a torus (AMD), each with random flips of a few percent of its edges.
  using namespace ricci_shapes;
  struct Surface {
    const char* name;
    Mesh mesh;
  };
  Mesh pretzel_fine = pretzel(2, 8);
  for (int i = 0; i < 2; ++i) pretzel_fine = subdivide_midpoint(pretzel_fine);
  const Surface surfaces[] = {{"genus-2, 2 subdivisions", pretzel_fine}, {"torus 160x80", torus(160, 80, 2.0, 0.7)}};
  // Random flips of 1 % of the edges, spread over the whole surface (a flow's flips gather where the
  // metric changes most).
  for (const Surface& surface : surfaces) {
    const Case c = make_case(surface.name, surface.mesh, Geometry::Euclidean);
    const IntrinsicTriangulation start = intrinsic(c, false);
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      const std::string name = surface.name;
      INFO(name << ", seed " << seed);
      IntrinsicTriangulation tri = start;
      const Topology& t = tri.topology;
      std::vector<std::uint8_t> unknown(static_cast<std::size_t>(t.num_vertices), 1);
      unknown[0] = 0;  // one vertex held, as the flow's gauge
      const detail::HessianPattern before = detail::build_hessian_pattern(t, unknown);
      std::vector<std::int64_t> order;
      factor_fill(before, {}, &order);
      // Unchanged pattern: unchanged ordering.
      CHECK(detail::repair_ordering(t, before, before, order) == order);
      std::mt19937_64 rng(seed);
      for (Index k = 0; k < t.num_edges / 100; ++k) flip_edge(tri, random_flippable_edge(tri, rng));
      refresh_vertex_corners(tri.topology);
      const detail::HessianPattern after = detail::build_hessian_pattern(tri.topology, unknown);
      const std::vector<std::int64_t> repaired = detail::repair_ordering(tri.topology, before, after, order);
      std::vector<std::int64_t> sorted = repaired;
      std::sort(sorted.begin(), sorted.end());
      std::vector<std::int64_t> identity(sorted.size());
      for (std::size_t k = 0; k < identity.size(); ++k) identity[k] = static_cast<std::int64_t>(k);
      REQUIRE(sorted == identity);  // a permutation of the unknowns
      const double old_fill = factor_fill(after, order), repaired_fill = factor_fill(after, repaired),
                   fresh_fill = factor_fill(after, {});
      MESSAGE(name << " seed " << seed << ": factor nonzeros, old ordering " << old_fill << ", carried over "
                           << repaired_fill << ", fresh " << fresh_fill);
      CHECK(repaired_fill < old_fill);
      CHECK(repaired_fill <= 1.25 * fresh_fill);  // FlowSolver's kRefillGrowth
    });
  }
}

TEST_CASE("intrinsic: a chord beyond double range gives η = +∞ and says so, without an overflow") {
  // Far line-search trials can flip edges to chords whose η = B²/2 leaves double range (random
  // sweep draw 168, on its double): the structure marks them +∞ and returns false, which the flow
  // takes for a trial with no finite length (the floating-point traps of the tests stop an
  // overflowing exp()).
  const Case c = cases()[1];
  IntrinsicTriangulation tri = intrinsic(c, true);
  ConformalStructure s;
  REQUIRE(vertex_scaling_structure(tri, s));
  for (double eta : s.eta) CHECK((std::isfinite(eta) && eta > 0));
  const Index e = tri.topology.num_edges / 2;
  tri.log_chord[e] = static_cast<std::int64_t>(356.0 / kLogChordUnit);  // B = e^356: η ≈ e^712 / 2
  CHECK_FALSE(vertex_scaling_structure(tri, s));
  CHECK(std::isinf(s.eta[e]));
  for (Index k = 0; k < tri.topology.num_edges; ++k)
    if (k != e) CHECK(std::isfinite(s.eta[k]));
  tri.log_chord[e] = static_cast<std::int64_t>(354.0 / kLogChordUnit);  // η ≈ e^708 / 2: still finite
  CHECK(vertex_scaling_structure(tri, s));
  CHECK(std::isfinite(s.eta[e]));
}
