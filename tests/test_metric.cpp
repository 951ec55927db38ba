// Metric kernels: lengths, angles, curvature, areas, Gauss–Bonnet and the Hessian ∂K/∂u, for
// every scheme × geometry, on closed surfaces and surfaces with boundary.
#include <doctest/doctest.h>
#include <omp.h>

#include <cmath>
#include <numbers>
#include <random>

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
      for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        INFO(s.name << " " << geometry_name(g));
        CAPTURE(seed);
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
      }
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

TEST_CASE("metric: the E Hessian of a closed surface is PSD with the constants as null space; H is PD") {
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
