// Normal coordinates and the tracing of the input's edges over a flipped intrinsic triangulation:
// the counts against straight segments in the plane, the order of the crossings along each input
// edge, flipping back to the input, and traces after the flow's Ptolemy flips in E, H and S.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <complex>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/intrinsic.h"
#include "ricci/intrinsic_trace.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;

namespace {

// A planar mesh of obtuse triangles: a jittered n×n grid with random diagonals, stretched 4× in x,
// with needles and caps inserted into a third of its faces.
Mesh planar_obtuse_mesh(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  Mesh m;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      const bool inner = x > 0 && x < n && y > 0 && y < n;
      m.positions.push_back(4.0 * (x + (inner ? jitter(rng) : 0.0)));
      m.positions.push_back(y + (inner ? jitter(rng) : 0.0));
      m.positions.push_back(0.0);
    }
  auto id = [n](int x, int y) { return static_cast<Index>(y * (n + 1) + x); };
  std::bernoulli_distribution coin(0.5);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const Index a = id(x, y), b = id(x + 1, y), c = id(x + 1, y + 1), d = id(x, y + 1);
      const std::array<Index, 6> f = coin(rng) ? std::array<Index, 6>{a, b, c, a, c, d} : std::array<Index, 6>{a, b, d, b, c, d};
      m.faces.insert(m.faces.end(), f.begin(), f.end());
    }
  std::mt19937_64 rng2(seed + 1);
  return ricci_shapes::insert_needles_and_caps(m, rng2, 0.35, 0.03);
}

struct Point {
  double x, y;
};

double cross(Point o, Point a, Point b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }

// Whether the open segments pq and rs cross at one interior point (shared end points do not count).
bool segments_cross(Point p, Point q, Point r, Point s) {
  const double d1 = cross(p, q, r), d2 = cross(p, q, s), d3 = cross(r, s, p), d4 = cross(r, s, q);
  return ((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0));
}

// Where segment pq meets line rs, as the parameter t along pq.
double crossing_parameter(Point p, Point q, Point r, Point s) {
  const double d1 = cross(r, s, p), d2 = cross(r, s, q);
  return d1 / (d1 - d2);
}

// The arcs of every face are consistent: counts are whole and not negative, at most one corner of a
// face sends arcs across the opposite side.
void check_arcs(const IntrinsicTriangulation& tri) {
  const Topology& t = tri.topology;
  for (Index f = 0; f < t.num_faces; ++f) {
    int sending = 0;
    for (Index c = 3 * f; c < 3 * f + 3; ++c) {
      const CornerArcs arcs = corner_arcs(tri, c);
      REQUIRE(arcs.around >= 0);
      REQUIRE(arcs.from_vertex >= 0);
      sending += arcs.from_vertex > 0 ? 1 : 0;
      std::int64_t sum = 0;
      for (Index x = 3 * f; x < 3 * f + 3; ++x) sum += std::max<std::int64_t>(0, tri.normal[t.corner_edge[x]]);
      sum -= corner_arcs(tri, 3 * f).from_vertex + corner_arcs(tri, 3 * f + 1).from_vertex +
             corner_arcs(tri, 3 * f + 2).from_vertex;
      REQUIRE(sum % 2 == 0);
    }
    REQUIRE(sending <= 1);
  }
}

}  // namespace

TEST_CASE("intrinsic trace: in the plane, normal coordinates count the input segments each flipped edge crosses, and traces list them in order") {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    CAPTURE(seed);
    const ValidateResult v = validate_mesh(planar_obtuse_mesh(9, seed));
    REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
    const Topology& input = v.topology;
    // Geometric flips to the intrinsic Delaunay triangulation: in a planar region every new edge is
    // the straight segment between its end points.
    const IntrinsicResult r = make_intrinsic_triangulation(input, Geometry::Euclidean, mesh_edge_lengths(v.mesh, input));
    REQUIRE(r.status == Status::Ok);
    REQUIRE(r.delaunay_flips > 20);
    const IntrinsicTriangulation& tri = r.triangulation;
    check_arcs(tri);
    auto point = [&v](Index i) { return Point{v.mesh.positions[3 * i], v.mesh.positions[3 * i + 1]}; };
    Index coinciding = 0;
    for (Index e = 0; e < tri.topology.num_edges; ++e) {
      const Point p = point(tri.topology.edge_vertices[2 * e]), q = point(tri.topology.edge_vertices[2 * e + 1]);
      std::int64_t crossings = 0;
      bool is_input = false;
      for (Index a = 0; a < input.num_edges; ++a) {
        const Index ia = input.edge_vertices[2 * a], ib = input.edge_vertices[2 * a + 1];
        const Index ta = tri.topology.edge_vertices[2 * e], tb = tri.topology.edge_vertices[2 * e + 1];
        if ((ia == ta && ib == tb) || (ia == tb && ib == ta)) is_input = true;
        if (segments_cross(p, q, point(ia), point(ib))) ++crossings;
      }
      CAPTURE(e);
      CHECK(tri.normal[e] == (is_input ? -1 : crossings));
      coinciding += is_input ? 1 : 0;
    }
    CHECK(coinciding < input.num_edges);  // some input edges were flipped away

    const InputEdgePaths paths = trace_input_edges(tri, input);
    REQUIRE_MESSAGE(paths.status == Status::Ok, paths.message);
    std::int64_t total = 0;
    for (Index e = 0; e < tri.topology.num_edges; ++e) total += std::max<std::int64_t>(0, tri.normal[e]);
    CHECK(paths.offsets.back() == total);
    for (Index a = 0; a < input.num_edges; ++a) {
      CAPTURE(a);
      const Point p = point(input.edge_vertices[2 * a]), q = point(input.edge_vertices[2 * a + 1]);
      const Index begin = paths.offsets[a], end = paths.offsets[a + 1];
      CHECK((paths.along[a] != kInvalid) == (begin == end));
      CHECK(tri.topology.corner_vertex[paths.first_corner[a]] == input.edge_vertices[2 * a]);
      CHECK(tri.topology.corner_vertex[paths.last_corner[a]] == input.edge_vertices[2 * a + 1]);
      double last_t = 0;
      for (Index k = begin; k < end; ++k) {
        const Index e = paths.crossed_edge[k];
        const Point r0 = point(tri.topology.edge_vertices[2 * e]), r1 = point(tri.topology.edge_vertices[2 * e + 1]);
        REQUIRE(segments_cross(p, q, r0, r1));
        const double t = crossing_parameter(p, q, r0, r1);
        CHECK(t > last_t);  // in order along the input edge
        last_t = t;
        // The slot: how many other input segments cross e nearer its first vertex.
        const double s = crossing_parameter(r0, r1, p, q);
        Index nearer = 0;
        for (Index b = 0; b < input.num_edges; ++b) {
          const Point pb = point(input.edge_vertices[2 * b]), qb = point(input.edge_vertices[2 * b + 1]);
          if (b != a && segments_cross(r0, r1, pb, qb) && crossing_parameter(r0, r1, pb, qb) < s) ++nearer;
        }
        CHECK(paths.crossed_slot[k] == nearer);
      }
    }
  }
}

TEST_CASE("intrinsic trace: random Ptolemy flips keep the normal coordinates consistent, and flipping back marks every edge as an input edge again") {
  std::mt19937_64 rng(11);
  const ValidateResult v = validate_mesh(ricci_shapes::insert_needles_and_caps(ricci_shapes::torus(12, 6, 2.0, 0.7), rng, 0.3, 0.03));
  REQUIRE(v.status == Status::Ok);
  IntrinsicResult r = make_intrinsic_triangulation(v.topology, Geometry::Euclidean, mesh_edge_lengths(v.mesh, v.topology), false);
  REQUIRE(r.status == Status::Ok);
  IntrinsicTriangulation tri = r.triangulation;
  std::vector<Index> done;
  for (int k = 0; k < 3000; ++k) {
    const Index e = static_cast<Index>(rng() % static_cast<std::uint64_t>(tri.topology.num_edges));
    if (can_flip(tri, e) != FlipCheck::Ok) continue;
    flip_edge(tri, e);
    done.push_back(e);
    if (k % 500 == 0) {
      check_arcs(tri);
      refresh_vertex_corners(tri.topology);
      const InputEdgePaths paths = trace_input_edges(tri, v.topology);
      REQUIRE_MESSAGE(paths.status == Status::Ok, paths.message);
    }
  }
  check_arcs(tri);
  const InputEdgePaths paths = trace_input_edges(tri, v.topology);
  REQUIRE_MESSAGE(paths.status == Status::Ok, paths.message);
  Index crossing = 0;
  for (Index a = 0; a < v.topology.num_edges; ++a) crossing += paths.along[a] == kInvalid ? 1 : 0;
  CHECK(crossing > v.topology.num_edges / 2);
  // Each flip undone by flipping the same edge again, last first.
  for (auto it = done.rbegin(); it != done.rend(); ++it) flip_edge(tri, *it);
  for (Index e = 0; e < tri.topology.num_edges; ++e) REQUIRE(tri.normal[e] == -1);
  refresh_vertex_corners(tri.topology);
  // Every input edge is a current edge again; the unflipped triangulation says so without walking
  // (is_input_triangulation()), with the same answer's form: the edge of its own index, its ends at
  // the first and last corner of one of its faces.
  CHECK_FALSE(is_input_triangulation(IntrinsicTriangulation{}, v.topology));
  REQUIRE(is_input_triangulation(r.triangulation, v.topology));
  IntrinsicTriangulation once = r.triangulation;
  Index flipped = kInvalid;
  for (Index e = 0; e < once.topology.num_edges && flipped == kInvalid; ++e)
    if (can_flip(once, e) == FlipCheck::Ok) flipped = e;
  REQUIRE(flipped != kInvalid);
  flip_edge(once, flipped);
  CHECK_FALSE(is_input_triangulation(once, v.topology));
  for (const IntrinsicTriangulation* t : {&tri, &r.triangulation}) {
    const InputEdgePaths back = trace_input_edges(*t, v.topology);
    REQUIRE_MESSAGE(back.status == Status::Ok, back.message);
    CHECK(back.crossed_edge.empty());
    CHECK(back.offsets == std::vector<Index>(static_cast<std::size_t>(v.topology.num_edges) + 1, 0));
    for (Index a = 0; a < v.topology.num_edges; ++a) {
      const Index e = back.along[a];
      REQUIRE(e != kInvalid);
      CHECK(t->topology.corner_vertex[back.first_corner[a]] == v.topology.edge_vertices[2 * a]);
      CHECK(t->topology.corner_vertex[back.last_corner[a]] == v.topology.edge_vertices[2 * a + 1]);
      CHECK(back.first_corner[a] / 3 == back.last_corner[a] / 3);
      const Index f = back.first_corner[a] / 3, apex = 3 - back.first_corner[a] % 3 - back.last_corner[a] % 3;
      CHECK(t->topology.corner_edge[3 * f + apex] == e);
    }
    // Its straight metric is the metric itself: the same lengths, angle sums equal.
    const std::vector<double> u(static_cast<std::size_t>(v.topology.num_vertices), 0.1);
    const StraightInputMetric m = straight_input_metric(*t, u, v.topology, back);
    REQUIRE_MESSAGE(m.status == Status::Ok, m.message);
    CHECK(m.max_angle_sum_error < 1e-12);
    CHECK(m.inconsistent_vertices == 0);
    CHECK(m.degenerate_faces == 0);
    const std::vector<double> l0 = mesh_edge_lengths(v.mesh, v.topology);
    for (Index a = 0; a < v.topology.num_edges; ++a)
      CHECK(m.l[a] == doctest::Approx(std::exp(0.1) * l0[a]).epsilon(1e-12));
  }
}

TEST_CASE("intrinsic trace: after the flow's flips in E, H and S every input edge is traced") {
  std::mt19937_64 rng(5);
  struct Item {
    const char* name;
    Mesh mesh;
    Geometry g;
  };
  std::vector<Item> items;
  items.push_back({"torus (E)", ricci_shapes::insert_needles_and_caps(ricci_shapes::torus(16, 8, 2.0, 0.7), rng, 0.3, 0.02), Geometry::Euclidean});
  items.push_back({"pretzel (H)", ricci_shapes::insert_needles_and_caps(ricci_shapes::pretzel(2, 3), rng, 0.3, 0.02), Geometry::Hyperbolic});
  items.push_back({"icosphere (S)", ricci_shapes::insert_needles_and_caps(ricci_shapes::icosphere(2), rng, 0.3, 0.02), Geometry::Spherical});
  for (const Item& item : items) {
    CAPTURE(item.name);
    const ValidateResult v = validate_mesh(item.mesh);
    REQUIRE(v.status == Status::Ok);
    const IntrinsicResult r = mesh_intrinsic_triangulation(v.mesh, v.topology, item.g);
    REQUIRE(r.status == Status::Ok);
    const Target target = uniform_target(v.topology);
    const std::vector<double> u0(static_cast<std::size_t>(v.topology.num_vertices), 0.0);
    IntrinsicTriangulation tri = r.triangulation;
    const FlowResult flow = solve_flow_with_flips(tri, u0, target);
    REQUIRE_MESSAGE(flow.status == Status::Ok, flow.message);
    CHECK(r.delaunay_flips + flow.flips > 0);
    check_arcs(tri);
    const InputEdgePaths paths = trace_input_edges(tri, v.topology);
    REQUIRE_MESSAGE(paths.status == Status::Ok, paths.message);
    std::int64_t total = 0;
    for (Index e = 0; e < tri.topology.num_edges; ++e) total += std::max<std::int64_t>(0, tri.normal[e]);
    CHECK(paths.offsets.back() == total);
    // The crossings' positions at the solution lie inside their edges, in the order of their slots.
    const std::vector<double> t = input_edge_crossings(tri, flow.u, paths);
    std::vector<std::vector<double>> along(static_cast<std::size_t>(tri.topology.num_edges));
    for (Index e = 0; e < tri.topology.num_edges; ++e) along[e].assign(static_cast<std::size_t>(std::max<std::int64_t>(0, tri.normal[e])), -1.0);
    for (std::size_t k = 0; k < t.size(); ++k) {
      REQUIRE(t[k] > 0);
      REQUIRE(t[k] < 1);
      along[paths.crossed_edge[k]][paths.crossed_slot[k]] = t[k];
    }
    for (const auto& list : along) CHECK(std::is_sorted(list.begin(), list.end()));
  }
}

TEST_CASE("intrinsic trace: on points of a circle, where input edges cross the flipped ones is where their chords meet, also after a Möbius map (a vertex scaling)") {
  using C = std::complex<double>;
  ricci_test::for_each_seed({4, 5, 6}, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    // n points on the unit circle, a fan triangulation; every quadrilateral is cyclic, so Ptolemy
    // flips are the straight diagonals.
    const int n = 40;
    std::vector<double> angle(n);
    std::uniform_real_distribution<double> d(0, 2 * std::numbers::pi);
    for (double& x : angle) x = d(rng);
    std::sort(angle.begin(), angle.end());
    std::vector<C> z(n);
    Mesh m;
    for (int i = 0; i < n; ++i) {
      z[i] = std::polar(1.0, angle[i]);
      m.positions.insert(m.positions.end(), {z[i].real(), z[i].imag(), 0.0});
    }
    for (int i = 1; i + 1 < n; ++i) m.faces.insert(m.faces.end(), {0, i, i + 1});
    const ValidateResult v = validate_mesh(m);
    REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
    const IntrinsicResult r = make_intrinsic_triangulation(v.topology, Geometry::Euclidean, mesh_edge_lengths(v.mesh, v.topology), false);
    REQUIRE(r.status == Status::Ok);
    IntrinsicTriangulation tri = r.triangulation;
    for (int k = 0; k < 400; ++k) {
      const Index e = static_cast<Index>(rng() % static_cast<std::uint64_t>(tri.topology.num_edges));
      if (can_flip(tri, e) == FlipCheck::Ok) flip_edge(tri, e);
    }
    refresh_vertex_corners(tri.topology);
    const InputEdgePaths paths = trace_input_edges(tri, v.topology);
    REQUIRE_MESSAGE(paths.status == Status::Ok, paths.message);
    REQUIRE(paths.offsets.back() > 100);
    // u = 0: the points themselves; then the disk automorphism f(z) = (z − w)/(1 − w̄z), which scales
    // every edge as vertex scaling does with u_i = log |f'(z_i)|.
    const C w(0.55, -0.3);
    for (const bool moved : {false, true}) {
      CAPTURE(moved);
      std::vector<double> u(n, 0.0);
      std::vector<C> image = z;
      if (moved)
        for (int i = 0; i < n; ++i) {
          image[i] = (z[i] - w) / (1.0 - std::conj(w) * z[i]);
          u[i] = std::log((1 - std::norm(w)) / std::norm(1.0 - std::conj(w) * z[i]));
        }
      const std::vector<double> t = input_edge_crossings(tri, u, paths);
      double worst = 0;
      for (Index a = 0; a < v.topology.num_edges; ++a)
        for (Index k = paths.offsets[a]; k < paths.offsets[a + 1]; ++k) {
          const Index e = paths.crossed_edge[k];
          const Point p{image[v.topology.edge_vertices[2 * a]].real(), image[v.topology.edge_vertices[2 * a]].imag()};
          const Point q{image[v.topology.edge_vertices[2 * a + 1]].real(), image[v.topology.edge_vertices[2 * a + 1]].imag()};
          const Point r0{image[tri.topology.edge_vertices[2 * e]].real(), image[tri.topology.edge_vertices[2 * e]].imag()};
          const Point r1{image[tri.topology.edge_vertices[2 * e + 1]].real(), image[tri.topology.edge_vertices[2 * e + 1]].imag()};
          worst = std::max(worst, std::abs(t[k] - crossing_parameter(r0, r1, p, q)));
        }
      MESSAGE("seed " << seed << std::string(moved ? " after the Möbius map" : "") << ": largest error in t " << worst);
      CHECK(worst < 1e-10);
    }
  });
}

TEST_CASE("intrinsic flow: the stress kinds converge with flips and their input edges trace") {
  const std::vector<ricci_shapes::StressMesh> meshes = ricci_shapes::stress_meshes(ricci_shapes::StressSize::Small, 20260101);
  // Not solved yet (the line search stops): the strips of aspect 100 and 1000 with circle
  // boundaries in E. Each must still stop with a named status and no NaN. The nearly flat torus
  // and pretzel keep edges of 1e-8 to 1e-13 of their neighbours after mollification, and the
  // pancake needles: the angles at their ends follow from the double lengths only to about ε·l/s,
  // so those vertices converge to their curvature resolution (FlowResult::curvature_resolution).
  const std::vector<std::string> open = {"strip-100", "strip-1000"};
  const std::vector<std::string> near_coincident = {"nearly-flat-torus", "nearly-flat-pretzel"};
  int solved = 0, refused = 0, unsolved = 0;
  for (const ricci_shapes::StressMesh& s : meshes) {
    INFO(s.name);
    const ValidateResult v = validate_mesh(s.mesh);
    if (v.status != Status::Ok) {
      ++refused;  // refused at validation, as the pipeline refuses it (test_stress.cpp)
      continue;
    }
    const Geometry g = natural_geometry(v.topology);
    const Target target = uniform_target(v.topology, natural_boundary_mode(v.topology, g));
    IntrinsicResult r = mesh_intrinsic_triangulation(v.mesh, v.topology, g);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    const std::vector<double> u0(static_cast<std::size_t>(v.topology.num_vertices), 0.0);
    const FlowResult flow = solve_flow_with_flips(r.triangulation, u0, target);
    MESSAGE(s.name << " (" << v.topology.num_faces << " faces, " << geometry_name(g) << "): "
                   << status_name(flow.status) << ", " << flow.iterations << " Newton steps, "
                   << r.delaunay_flips + flow.flips << " flips, max error " << flow.max_curvature_error);
    if (std::find(open.begin(), open.end(), s.name) != open.end()) {
      CHECK(flow.status != Status::Ok);  // when one is solved, move it out of `open`
      CHECK(!flow.message.empty());
      for (const double x : flow.u) REQUIRE(std::isfinite(x));
      ++unsolved;
      continue;
    }
    CHECK_MESSAGE(flow.status == Status::Ok, flow.message);
    if (flow.status != Status::Ok) continue;
    CHECK(flow.iterations <= 12);
    CHECK(flow.max_curvature_error < std::max(1e-10, flow.curvature_resolution));
    if (std::find(near_coincident.begin(), near_coincident.end(), s.name) != near_coincident.end()) {
      CHECK(flow.resolution_vertices > 0);
      CHECK(flow.curvature_resolution > 1e-10);  // the reason they stop above the tolerance
    }
    const InputEdgePaths paths = trace_input_edges(r.triangulation, v.topology);
    CHECK_MESSAGE(paths.status == Status::Ok, paths.message);
    ++solved;
  }
  CHECK(solved + refused + unsolved == static_cast<int>(meshes.size()));
  CHECK(unsolved == static_cast<int>(open.size()));
  CHECK(solved >= 13);
}
