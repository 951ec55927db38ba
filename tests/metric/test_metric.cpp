// Metric kernels: lengths, angles, curvature, areas, Gauss–Bonnet and the Hessian ∂K/∂u, for
// every scheme × geometry, on closed surfaces and surfaces with boundary.
#include <doctest/doctest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <span>

#include "ricci/metric.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;

namespace {

constexpr double kPi = std::numbers::pi;

struct Surface {
  const char* name;
  Mesh mesh;
  Topology topology;
};

std::vector<Surface> small_surfaces() {
  using namespace ricci_shapes;
  std::vector<Surface> out;
  auto add = [&](const char* name, const Mesh& m) {
    const auto r = validate_mesh(m);
    REQUIRE(r.status == Status::Ok);
    out.push_back({name, r.mesh, r.topology});
  };
  add("icosphere", icosphere(1));
  add("torus", torus(9, 6, 2.0, 0.8));
  add("genus-2", pretzel(2, 2));
  add("disk", disk(3));
  add("annulus", annulus(2, 12));
  add("sphere with 3 holes", remove_vertex_stars(icosphere(2), {0, 5, 9}));
  return out;
}

const Geometry kGeometries[] = {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical};
const Scheme kSchemes[] = {Scheme::CirclePacking, Scheme::InversiveDistance, Scheme::Yamabe};

struct Evaluation {
  std::vector<double> l, theta, K, area;
  AngleReport angles;
  Index bad_edge = kInvalid;
};

Evaluation evaluate(const Topology& t, const ConformalStructure& s, const std::vector<double>& u) {
  Evaluation e;
  e.l.resize(t.num_edges);
  e.theta.resize(3 * t.num_faces);
  e.K.resize(t.num_vertices);
  e.area.resize(t.num_faces);
  e.bad_edge = edge_lengths(t, s, u, e.l);
  e.angles = corner_angles(t, s.geometry, e.l, e.theta);
  vertex_curvature(t, e.theta, e.K);
  face_areas(t, s.geometry, e.l, e.theta, e.area);
  return e;
}

// Dense ∂K/∂u from the per-face blocks: ∂K_a/∂u_b = −Σ_f ∂θ_a/∂u_b.
std::vector<double> dense_hessian(const Topology& t, const ConformalStructure& s, const std::vector<double>& u,
                                  const Evaluation& e) {
  std::vector<double> blocks(9 * t.num_faces);
  angle_derivative_blocks(t, s, u, e.l, e.theta, blocks);
  const Index n = t.num_vertices;
  std::vector<double> H(static_cast<std::size_t>(n) * n, 0.0);
  for (Index f = 0; f < t.num_faces; ++f)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        H[t.corner_vertex[3 * f + a] * n + t.corner_vertex[3 * f + b]] -= blocks[9 * f + 3 * a + b];
  return H;
}

// Small random perturbation of the starting metric that stays admissible.
std::vector<double> perturbed(const std::vector<double>& u0, std::mt19937_64& rng, double amplitude) {
  std::vector<double> u = u0;
  for (double& x : u) x += amplitude * (2 * ricci_shapes::unit_double(rng) - 1);
  return u;
}

}  // namespace

TEST_CASE("metric: the initial metric reproduces the mesh lengths (exactly for inversive distance and Yamabe)") {
  for (const auto& s : small_surfaces()) {
    for (Geometry g : kGeometries) {
      for (Scheme sc : kSchemes) {
        INFO(s.name << " " << geometry_name(g) << " " << scheme_name(sc));
        InitialMetricOptions o;
        o.geometry = g;
        o.scheme = sc;
        const InitialMetric m = initial_metric(s.mesh, s.topology, o);
        REQUIRE_MESSAGE(m.status == Status::Ok, m.message);
        const Evaluation e = evaluate(s.topology, m.structure, m.u);
        CHECK(e.bad_edge == kInvalid);
        double worst = 0;
        for (Index i = 0; i < s.topology.num_edges; ++i) worst = std::max(worst, std::abs(e.l[i] / m.l0[i] - 1));
        if (sc == Scheme::CirclePacking) {
          CHECK(worst < 0.5);  // an approximation (clamped edges differ most)
        } else {
          CHECK(worst < 1e-12);
        }
      }
    }
  }
}

TEST_CASE("metric: Gauss-Bonnet holds for random admissible metrics in E, H and S") {
  for (const auto& s : small_surfaces()) {
    for (Geometry g : kGeometries) {
      ricci_test::for_each_seed(1, 5, [&](std::uint64_t seed) {
        INFO(s.name << " " << geometry_name(g));
        std::mt19937_64 rng(seed);
        InitialMetricOptions o;
        o.geometry = g;
        const InitialMetric m = initial_metric(s.mesh, s.topology, o);
        REQUIRE(m.status == Status::Ok);
        // Circle packing with Φ ≤ π/2 is admissible for any u in E and any u < 0 in H (radii
        // tanh(γ/2) < 1); S needs small steps.
        std::vector<double> u = perturbed(m.u, rng, g == Geometry::Spherical ? 0.05 : 1.0);
        if (g == Geometry::Hyperbolic)
          for (Index i = 0; i < s.topology.num_vertices; ++i) u[i] = m.u[i] - std::abs(u[i] - m.u[i]);
        const Evaluation e = evaluate(s.topology, m.structure, u);
        REQUIRE(e.angles.violations == 0);
        const double chi = static_cast<double>(s.topology.euler_characteristic());
        CHECK(std::abs(gauss_bonnet_defect(s.topology, g, e.K, e.area)) < 1e-10 * (1 + std::abs(2 * kPi * chi)));
        for (Index f = 0; f < s.topology.num_faces; ++f) {
          const double sum = e.theta[3 * f] + e.theta[3 * f + 1] + e.theta[3 * f + 2];
          if (g == Geometry::Euclidean) CHECK(std::abs(sum - kPi) < 1e-13);
          if (g == Geometry::Hyperbolic) CHECK(std::abs((kPi - sum) - e.area[f]) < 1e-12);
          if (g == Geometry::Spherical) CHECK(std::abs((sum - kPi) - e.area[f]) < 1e-12);
          CHECK(e.area[f] > 0);
        }
      });
    }
  }
}

TEST_CASE("metric: the Hessian matches finite differences of K for every scheme and geometry") {
  for (const auto& s : small_surfaces()) {
    for (Geometry g : kGeometries) {
      for (Scheme sc : kSchemes) {
        INFO(s.name << " " << geometry_name(g) << " " << scheme_name(sc));
        std::mt19937_64 rng(7);
        InitialMetricOptions o;
        o.geometry = g;
        o.scheme = sc;
        const InitialMetric m = initial_metric(s.mesh, s.topology, o);
        REQUIRE(m.status == Status::Ok);
        const std::vector<double> u = perturbed(m.u, rng, 0.02);
        const Evaluation e = evaluate(s.topology, m.structure, u);
        REQUIRE(e.angles.violations == 0);
        const Index n = s.topology.num_vertices;
        const std::vector<double> H = dense_hessian(s.topology, m.structure, u, e);
        double scale = 0, worst = 0, asym = 0;
        for (double x : H) scale = std::max(scale, std::abs(x));
        const double h = 1e-6;
        for (Index j = 0; j < n; ++j) {
          std::vector<double> up = u, um = u;
          up[j] += h;
          um[j] -= h;
          const Evaluation ep = evaluate(s.topology, m.structure, up), em = evaluate(s.topology, m.structure, um);
          for (Index i = 0; i < n; ++i) {
            const double fd = (ep.K[i] - em.K[i]) / (2 * h);
            worst = std::max(worst, std::abs(fd - H[i * n + j]));
            asym = std::max(asym, std::abs(H[i * n + j] - H[j * n + i]));
          }
        }
        CHECK(worst < 1e-6 * scale);
        CHECK(asym < 1e-12 * scale);
      }
    }
  }
}

TEST_CASE("metric: the E Hessian of a closed surface is PSD with the constants as null space, H is PD") {
  for (const auto& s : small_surfaces()) {
    for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic}) {
      INFO(s.name << " " << geometry_name(g));
      std::mt19937_64 rng(3);
      InitialMetricOptions o;
      o.geometry = g;
      const InitialMetric m = initial_metric(s.mesh, s.topology, o);
      REQUIRE(m.status == Status::Ok);
      const std::vector<double> u = perturbed(m.u, rng, 0.5);
      const Evaluation e = evaluate(s.topology, m.structure, u);
      const Index n = s.topology.num_vertices;
      const std::vector<double> H = dense_hessian(s.topology, m.structure, u, e);
      double scale = 0;
      for (double x : H) scale = std::max(scale, std::abs(x));
      if (g == Geometry::Euclidean) {
        for (Index i = 0; i < n; ++i) {
          double row = 0;
          for (Index j = 0; j < n; ++j) row += H[i * n + j];
          CHECK(std::abs(row) < 1e-12 * scale * n);
        }
      }
      for (int trial = 0; trial < 20; ++trial) {
        std::vector<double> x(n);
        double mean = 0;
        for (double& v : x) mean += (v = 2 * ricci_shapes::unit_double(rng) - 1) / n;
        if (g == Geometry::Euclidean)
          for (double& v : x) v -= mean;  // orthogonal to the null space
        double q = 0, norm2 = 0;
        for (Index i = 0; i < n; ++i) {
          norm2 += x[i] * x[i];
          for (Index j = 0; j < n; ++j) q += x[i] * H[i * n + j] * x[j];
        }
        CHECK(q > 1e-9 * scale * norm2);
      }
    }
  }
}

TEST_CASE("metric: kernels give bitwise identical results on 1 and 2 threads") {
  const Surface s = small_surfaces()[2];
  for (Geometry g : kGeometries) {
    InitialMetricOptions o;
    o.geometry = g;
    const InitialMetric m = initial_metric(s.mesh, s.topology, o);
    REQUIRE(m.status == Status::Ok);
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    const Evaluation one = evaluate(s.topology, m.structure, m.u);
    omp_set_num_threads(2);
    const Evaluation two = evaluate(s.topology, m.structure, m.u);
    omp_set_num_threads(saved);
    CHECK(one.l == two.l);
    CHECK(one.theta == two.theta);
    CHECK(one.K == two.K);
    CHECK(one.area == two.area);
  }
}

TEST_CASE("metric: a violated triangle inequality is reported, never NaN") {
  // Yamabe lengths on a single triangle: blowing up one vertex breaks the triangle inequality.
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.faces = {0, 1, 2};
  const auto v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  for (Geometry g : kGeometries) {
    INFO(geometry_name(g));
    InitialMetricOptions o;
    o.geometry = g;
    o.scheme = Scheme::Yamabe;
    o.length_scale = 0.1;
    const InitialMetric im = initial_metric(v.mesh, v.topology, o);
    REQUIRE(im.status == Status::Ok);
    std::vector<double> u = {0, 0, -3};  // shrink the edges at vertex 2: edge (0,1) becomes too long
    const Evaluation e = evaluate(v.topology, im.structure, u);
    CHECK(e.angles.violations == 1);
    CHECK(e.angles.first_violation == 0);
    for (double th : e.theta) CHECK(std::isfinite(th));
    for (double k : e.K) CHECK(std::isfinite(k));
  }
}

namespace {

// Independent enumeration for the tests: every cycle of 3 or 4 edges that is not a face (3) or
// the outline of two faces sharing a diagonal (4), as edge lists, by brute force over vertex sets.
struct Cycles {
  std::vector<std::array<Index, 3>> three;
  std::vector<std::array<Index, 4>> four;
};
Cycles separating_cycles(const Topology& t) {
  std::map<std::pair<Index, Index>, Index> edge;
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    edge[{std::min(a, b), std::max(a, b)}] = e;
  }
  std::set<std::array<Index, 3>> faces;
  for (Index f = 0; f < t.num_faces; ++f) {
    std::array<Index, 3> v = {t.corner_vertex[3 * f], t.corner_vertex[3 * f + 1], t.corner_vertex[3 * f + 2]};
    std::sort(v.begin(), v.end());
    faces.insert(v);
  }
  auto find = [&](Index a, Index b) {
    const auto it = edge.find({std::min(a, b), std::max(a, b)});
    return it == edge.end() ? kInvalid : it->second;
  };
  auto is_face = [&](Index a, Index b, Index c) {
    std::array<Index, 3> v = {a, b, c};
    std::sort(v.begin(), v.end());
    return faces.count(v) > 0;
  };
  Cycles out;
  const Index n = t.num_vertices;
  for (Index a = 0; a < n; ++a)
    for (Index b = a + 1; b < n; ++b) {
      if (find(a, b) == kInvalid) continue;
      for (Index c = b + 1; c < n; ++c)
        if (find(b, c) != kInvalid && find(a, c) != kInvalid && !is_face(a, b, c))
          out.three.push_back({find(a, b), find(b, c), find(a, c)});
    }
  // 4-cycles a-b-c-d-a with a the smallest vertex and b < d.
  for (Index a = 0; a < n; ++a)
    for (Index b = a + 1; b < n; ++b)
      for (Index d = b + 1; d < n; ++d) {
        if (find(a, b) == kInvalid || find(a, d) == kInvalid) continue;
        for (Index c = a + 1; c < n; ++c) {
          if (c == b || c == d || find(b, c) == kInvalid || find(c, d) == kInvalid) continue;
          const bool two_faces = (is_face(a, b, c) && is_face(a, c, d)) || (is_face(a, b, d) && is_face(b, c, d));
          if (!two_faces) out.four.push_back({find(a, b), find(b, c), find(c, d), find(a, d)});
        }
      }
  return out;
}

double angle_sum(const std::vector<double>& eta, std::span<const Index> edges) {
  double s = 0;
  for (Index e : edges) s += std::acos(eta[e]);
  return s;
}

}  // namespace

TEST_CASE("metric: relaxing the angles clears every separating 3- and 4-cycle and only lowers angles") {
  using namespace ricci_shapes;
  struct Case {
    std::string name;
    Mesh mesh;
    bool all_right_angles;  // set every Φ to π/2 instead of Step 2's angles
  };
  std::vector<Case> cases;
  ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    // Splitting split faces again makes valence-3 vertices inside thin, obtuse triangles.
    cases.push_back({"torus with twice split faces, seed " + std::to_string(seed),
                     split_random_faces(split_random_faces(torus(16, 8, 2.0, 0.8), rng, 0.3), rng, 0.3), false});
    cases.push_back({"icosphere with twice split faces, seed " + std::to_string(seed),
                     split_random_faces(split_random_faces(icosphere(2), rng, 0.3), rng, 0.3), false});
  });
  // The octahedron: every vertex link is a 4-cycle; with right angles everywhere each violates.
  Mesh octahedron;
  octahedron.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  octahedron.faces = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  cases.push_back({"octahedron, all angles π/2", octahedron, true});
  cases.push_back({"torus with split faces, all angles π/2",
                   [] {
                     std::mt19937_64 rng(7);
                     return split_random_faces(torus(12, 8, 2.0, 0.8), rng, 0.3);
                   }(),
                   true});

  for (const Case& c : cases) {
    CAPTURE(c.name);
    const auto v = validate_mesh(c.mesh);
    REQUIRE(v.status == Status::Ok);
    const Topology& t = v.topology;
    InitialMetricOptions o;
    o.relax_angles = false;
    const InitialMetric m = initial_metric(v.mesh, t, o);
    REQUIRE(m.status == Status::Ok);
    std::vector<double> before = m.structure.eta;
    if (c.all_right_angles) std::fill(before.begin(), before.end(), 0.0);
    const Cycles cycles = separating_cycles(t);
    Index violating = 0;
    for (const auto& k : cycles.three) violating += angle_sum(before, k) > 5 * kPi / 6 ? 1 : 0;
    for (const auto& k : cycles.four) violating += angle_sum(before, k) > 11 * kPi / 6 ? 1 : 0;
    CHECK(violating > 0);  // the case exercises the relaxation

    std::vector<double> after = before;
    const AngleRelaxation r = relax_intersection_angles(t, after);
    CHECK(r.cycles3 + r.cycles4 >= 1);
    Index changed = 0;
    for (Index e = 0; e < t.num_edges; ++e) {
      CHECK(after[e] >= before[e]);  // η = cos Φ rises: Φ never grows
      CHECK(after[e] <= 1);
      changed += after[e] != before[e] ? 1 : 0;
    }
    CHECK(changed == r.edges);
    for (const auto& k : cycles.three) CHECK(angle_sum(after, k) <= 5 * kPi / 6 + 1e-12);
    for (const auto& k : cycles.four) CHECK(angle_sum(after, k) <= 11 * kPi / 6 + 1e-12);
    // Only edges of violating cycles move.
    std::set<Index> on_violating;
    for (const auto& k : cycles.three)
      if (angle_sum(before, k) > 5 * kPi / 6) on_violating.insert(k.begin(), k.end());
    for (Index e = 0; e < t.num_edges; ++e)
      if (after[e] != before[e] && !on_violating.count(e)) {
        bool on_four = false;
        for (const auto& k : cycles.four)
          on_four = on_four || (std::find(k.begin(), k.end(), e) != k.end() && angle_sum(before, k) > 11 * kPi / 6 - 1e-9);
        CHECK(on_four);
      }
    // A second pass finds nothing to do.
    std::vector<double> again = after;
    const AngleRelaxation r2 = relax_intersection_angles(t, again);
    CHECK(r2.cycles3 + r2.cycles4 == 0);
    CHECK(again == after);
    // initial_metric reports what the relaxation did.
    if (!c.all_right_angles) {
      InitialMetricOptions relaxed;
      const InitialMetric mr = initial_metric(v.mesh, t, relaxed);
      CHECK(mr.edges_relaxed == r.edges);
      CHECK(mr.cycles_relaxed == r.cycles3 + r.cycles4);
      CHECK(mr.structure.eta == after);
    }
  }
}
