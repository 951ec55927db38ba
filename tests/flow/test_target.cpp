// Targets: uniformization targets, boundary modes, the effective target, target files and the
// feasibility checks (Gauss–Bonnet, cone angles, the paper's Theorem 4).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "ricci/flow.h"
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
  Geometry natural;  // what natural_geometry() must say
};

Surface make_surface(const char* name, const Mesh& m, Geometry natural) {
  const auto r = validate_mesh(m);
  REQUIRE_MESSAGE(r.status == Status::Ok, name << ": " << r.message);
  return {name, r.mesh, r.topology, natural};
}

// Every topology the targets distinguish: closed with χ > 0, = 0, < 0; genus 0 with one, two and
// three boundary loops (loops of equal and of different sizes); genus 1 with boundary.
std::vector<Surface> fixtures() {
  using namespace ricci_shapes;
  std::vector<Surface> out;
  out.push_back(make_surface("icosphere", icosphere(1), Geometry::Spherical));
  out.push_back(make_surface("torus", torus(9, 6, 2.0, 0.8), Geometry::Euclidean));
  out.push_back(make_surface("genus-2", pretzel(2, 2), Geometry::Hyperbolic));
  out.push_back(make_surface("disk", disk(3), Geometry::Euclidean));
  out.push_back(make_surface("annulus", annulus(2, 12), Geometry::Euclidean));
  out.push_back(make_surface("disk with a hole", remove_vertex_stars(disk(4), {0}), Geometry::Euclidean));
  out.push_back(
      make_surface("sphere with 3 holes", remove_vertex_stars(icosphere(2), {0, 5, 9}), Geometry::Euclidean));
  out.push_back(make_surface("torus with a hole", remove_vertex_stars(torus(9, 6, 2.0, 0.8), {0}),
                             Geometry::Hyperbolic));
  out.push_back(make_surface("torus with 2 holes", remove_vertex_stars(torus(12, 8, 2.0, 0.8), {0, 52}),
                             Geometry::Hyperbolic));
  return out;
}

Surface find_fixture(const char* name) {
  for (auto& s : fixtures())
    if (std::string(s.name) == name) return s;
  FAIL("no fixture " << name);
  return {};
}

InitialMetric metric_for(const Surface& s, Geometry g, Scheme scheme = Scheme::CirclePacking) {
  InitialMetricOptions o;
  o.geometry = g;
  o.scheme = scheme;
  InitialMetric m = initial_metric(s.mesh, s.topology, o);
  REQUIRE_MESSAGE(m.status == Status::Ok, m.message);
  return m;
}

double two_pi_chi(const Topology& t) {
  return 2 * kPi * static_cast<double>(t.euler_characteristic());
}

// The Gauss–Bonnet sum of a target: explicit K̄ plus the loop totals for Circle / LoopTotals.
double gauss_bonnet_sum(const Topology& t, const Target& target) {
  const bool totals = target.boundary == BoundaryMode::Circle || target.boundary == BoundaryMode::LoopTotals;
  double sum = 0;
  for (Index v = 0; v < t.num_vertices; ++v)
    if (!(totals && t.is_boundary_vertex(v))) sum += target.K[v];
  if (totals)
    for (double x : target.loop_total) sum += x;
  return sum;
}

Index loop_size(const Topology& t, Index i) {
  return t.boundary_offsets[i + 1] - t.boundary_offsets[i];
}

Index first_interior_vertex(const Topology& t) {
  for (Index v = 0; v < t.num_vertices; ++v)
    if (!t.is_boundary_vertex(v)) return v;
  return kInvalid;
}

Index first_boundary_vertex(const Topology& t) {
  return t.boundary_vertices.empty() ? kInvalid : t.boundary_vertices[0];
}

// Σ (π − Φ) over the edges opposite v (the Theorem 4 bound on v's cone angle), Φ = acos η.
double opposite_link(const Topology& t, const ConformalStructure& s, Index v) {
  double sum = 0;
  for (Index k = t.vertex_corner_offsets[v]; k < t.vertex_corner_offsets[v + 1]; ++k)
    sum += kPi - std::acos(s.eta[t.corner_edge[t.vertex_corners[k]]]);
  return sum;
}

struct Evaluation {
  std::vector<double> l, theta, K;
};

Evaluation evaluate(const Topology& t, const ConformalStructure& s, const std::vector<double>& u) {
  Evaluation e;
  e.l.resize(t.num_edges);
  e.theta.resize(3 * t.num_faces);
  e.K.resize(t.num_vertices);
  REQUIRE(edge_lengths(t, s, u, e.l) == kInvalid);
  REQUIRE(corner_angles(t, s.geometry, e.l, e.theta).violations == 0);
  vertex_curvature(t, e.theta, e.K);
  return e;
}

// A target with the given curvatures at every vertex (free boundary).
Target free_target(const std::vector<double>& K) {
  Target target;
  target.K = K;
  target.boundary = BoundaryMode::Free;
  return target;
}

// Random circle packings of every fixture in E and H (seeds 1–3): each vertex's u shrunk from the
// initial metric's by up to `shrink` (H needs u < 0: only shrink); fn(surface, metric, u, the
// packing's lengths, angles and curvatures, the seed's generator).
template <class Fn>
void for_each_random_packing(double shrink, Fn&& fn) {
  for (const auto& f : fixtures()) {
    for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic}) {
      ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
        INFO(f.name << " " << geometry_name(g));
        std::mt19937_64 rng(seed);
        const InitialMetric m = metric_for(f, g);
        std::vector<double> u = m.u;
        for (double& x : u) x -= shrink * ricci_shapes::unit_double(rng);
        const Evaluation e = evaluate(f.topology, m.structure, u);
        fn(f, m, u, e, rng);
      });
    }
  }
}

std::string write_target(const ricci_test::TempDir& dir, const std::string& name, const std::string& text) {
  const auto path = dir / name;
  ricci_test::write_bytes(path, text);
  return path.string();
}

}  // namespace

TEST_CASE("target: boundary mode names") {
  CHECK(boundary_mode_name(BoundaryMode::Free) == "free");
  CHECK(boundary_mode_name(BoundaryMode::FixedLengths) == "fixed");
  CHECK(boundary_mode_name(BoundaryMode::Circle) == "circle");
  CHECK(boundary_mode_name(BoundaryMode::Geodesic) == "geodesic");
  CHECK(boundary_mode_name(BoundaryMode::LoopTotals) == "loop-totals");
}

TEST_CASE("target: natural geometry and boundary mode for each topology") {
  for (const auto& s : fixtures()) {
    INFO(s.name);
    const Topology& t = s.topology;
    CHECK(natural_geometry(t) == s.natural);
    if (t.is_closed()) {
      for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical})
        CHECK(natural_boundary_mode(t, g) == BoundaryMode::Free);
    } else {
      CHECK(natural_boundary_mode(t, Geometry::Euclidean) == BoundaryMode::Circle);
      CHECK(natural_boundary_mode(t, Geometry::Hyperbolic) == BoundaryMode::Geodesic);
      CHECK(natural_boundary_mode(t, natural_geometry(t)) ==
            (t.genus() == 0 ? BoundaryMode::Circle : BoundaryMode::Geodesic));
    }
  }
}

TEST_CASE("target: uniform targets satisfy Gauss-Bonnet and pass check_target for every fixture") {
  for (const auto& s : fixtures()) {
    INFO(s.name);
    const Topology& t = s.topology;
    const Geometry g = natural_geometry(t);
    const BoundaryMode mode = natural_boundary_mode(t, g);
    const Target target = uniform_target(t, mode);
    REQUIRE(target.K.size() == static_cast<std::size_t>(t.num_vertices));
    CHECK(target.boundary == mode);
    for (Index v = 0; v < t.num_vertices; ++v)
      if (!t.is_boundary_vertex(v)) CHECK(target.K[v] == 0);
    const double sum = gauss_bonnet_sum(t, target);
    if (g == Geometry::Euclidean)
      CHECK(std::abs(sum - two_pi_chi(t)) <= 1e-12 * (1 + std::abs(two_pi_chi(t))));
    if (g == Geometry::Hyperbolic) CHECK(sum > two_pi_chi(t));
    if (g == Geometry::Spherical) CHECK(sum < two_pi_chi(t));
    // The stored K̄ of Circle boundary vertices are the equal shares, so Σ K̄ is the same sum.
    double stored = 0;
    for (double k : target.K) stored += k;
    CHECK(std::abs(stored - sum) <= 1e-12 * (1 + std::abs(sum)));

    const InitialMetric m = metric_for(s, g);
    const TargetCheck c = check_target(t, m.structure, target);
    CHECK_MESSAGE(c.status == Status::Ok, c.message);
  }
}

TEST_CASE("target: uniform targets in every boundary mode on surfaces with boundary") {
  for (const auto& s : fixtures()) {
    const Topology& t = s.topology;
    if (t.is_closed()) continue;
    INFO(s.name);
    const double expected = two_pi_chi(t);
    const double tol = 1e-12 * (1 + std::abs(expected));

    // Free: the boundary vertices share 2πχ, so euclidean Gauss–Bonnet holds for any topology.
    const Target free = uniform_target(t, BoundaryMode::Free);
    CHECK(std::abs(gauss_bonnet_sum(t, free) - expected) <= tol);
    CHECK(free.fixed_u.empty());
    CHECK(free.loop_total.empty());
    if (t.genus() == 0) {
      const TargetCheck c = check_target(t, metric_for(s, Geometry::Euclidean).structure, free);
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
    }

    // Geodesic: zero everywhere; feasible in H for χ < 0.
    const Target geodesic = uniform_target(t, BoundaryMode::Geodesic);
    for (double k : geodesic.K) CHECK(k == 0);
    if (t.euler_characteristic() < 0) {
      const TargetCheck c = check_target(t, metric_for(s, Geometry::Hyperbolic).structure, geodesic);
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
    }

    // FixedLengths: u held on the boundary only; no Gauss–Bonnet condition.
    const Target fixed = uniform_target(t, BoundaryMode::FixedLengths);
    REQUIRE(fixed.fixed_u.size() == static_cast<std::size_t>(t.num_vertices));
    for (Index v = 0; v < t.num_vertices; ++v) CHECK((fixed.fixed_u[v] != 0) == t.is_boundary_vertex(v));
    for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic}) {
      const TargetCheck c = check_target(t, metric_for(s, g).structure, fixed);
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
    }

    // Circle and LoopTotals start with the same totals.
    const Target circle = uniform_target(t, BoundaryMode::Circle);
    const Target totals = uniform_target(t, BoundaryMode::LoopTotals);
    CHECK(circle.loop_total == totals.loop_total);
    CHECK(std::abs(gauss_bonnet_sum(t, circle) - 2 * kPi * (2 - t.num_boundary_loops())) <= tol);
  }
}

TEST_CASE("target: Circle loop totals are +2π for the loop with most vertices and −2π for the others") {
  for (const auto& s : fixtures()) {
    const Topology& t = s.topology;
    INFO(s.name);
    const Target target = uniform_target(t, BoundaryMode::Circle);
    REQUIRE(target.loop_total.size() == static_cast<std::size_t>(t.num_boundary_loops()));
    if (t.is_closed()) continue;
    // The outer loop: most vertices, ties broken by the smallest loop index.
    Index outer = 0;
    for (Index i = 1; i < t.num_boundary_loops(); ++i)
      if (loop_size(t, i) > loop_size(t, outer)) outer = i;
    for (Index i = 0; i < t.num_boundary_loops(); ++i)
      CHECK(target.loop_total[i] == (i == outer ? 2 * kPi : -2 * kPi));
    double sum = 0;
    for (double x : target.loop_total) sum += x;
    CHECK(sum == doctest::Approx(2 * kPi * (2 - t.num_boundary_loops())));
    if (t.genus() == 0) CHECK(std::abs(gauss_bonnet_sum(t, target) - two_pi_chi(t)) < 1e-12);
  }
  // Pinned cases: the annulus's loops tie (12 vertices each), so loop 0 is outer; the disk with a
  // hole has its 24-vertex rim outer and its 6-vertex hole inner, whatever their order.
  const Surface annulus = find_fixture("annulus");
  REQUIRE(annulus.topology.num_boundary_loops() == 2);
  CHECK(loop_size(annulus.topology, 0) == loop_size(annulus.topology, 1));
  CHECK(uniform_target(annulus.topology).loop_total == std::vector<double>{2 * kPi, -2 * kPi});
  const Surface holed = find_fixture("disk with a hole");
  const Topology& ht = holed.topology;
  REQUIRE(ht.num_boundary_loops() == 2);
  const Target ct = uniform_target(ht);
  for (Index i = 0; i < 2; ++i) CHECK(ct.loop_total[i] == (loop_size(ht, i) == 24 ? 2 * kPi : -2 * kPi));
  CHECK(loop_size(ht, 0) + loop_size(ht, 1) == 30);
}

TEST_CASE("target: effective_target spreads each loop total in proportion to length (H, loop totals)") {
  for (const auto& s : fixtures()) {
    const Topology& t = s.topology;
    if (t.is_closed()) continue;
    for (BoundaryMode mode : {BoundaryMode::Circle, BoundaryMode::LoopTotals}) {
      ricci_test::for_each_seed(1, 5, [&](std::uint64_t seed) {
        INFO(s.name << " " << boundary_mode_name(mode));
        std::mt19937_64 rng(seed);
        Target target = uniform_target(t, mode);
        if (mode == BoundaryMode::LoopTotals)
          for (double& x : target.loop_total) x = 10 * ricci_shapes::unit_double(rng) - 5;
        for (Index v = 0; v < t.num_vertices; ++v)
          if (!t.is_boundary_vertex(v)) target.K[v] = ricci_shapes::unit_double(rng) - 0.5;
        std::vector<double> l(t.num_edges);
        for (double& x : l) x = 0.1 + 2 * ricci_shapes::unit_double(rng);
        std::vector<double> K(t.num_vertices, -99.0);
        effective_target(t, target, l, K, Geometry::Hyperbolic);

        for (Index v = 0; v < t.num_vertices; ++v)
          if (!t.is_boundary_vertex(v)) CHECK(K[v] == target.K[v]);
        for (Index i = 0; i < t.num_boundary_loops(); ++i) {
          const Index b = t.boundary_offsets[i], e = t.boundary_offsets[i + 1];
          double length = 0, sum = 0;
          for (Index j = b; j < e; ++j) length += l[t.corner_edge[t.boundary_corners[j]]];
          for (Index j = b; j < e; ++j) sum += K[t.boundary_vertices[j]];
          CHECK(std::abs(sum - target.loop_total[i]) <= 1e-12 * (1 + std::abs(target.loop_total[i])));
          for (Index j = b; j < e; ++j) {
            // The vertex at position j joins the edges at positions j−1 and j.
            const Index jp = j == b ? e - 1 : j - 1;
            const double half =
                0.5 * (l[t.corner_edge[t.boundary_corners[jp]]] + l[t.corner_edge[t.boundary_corners[j]]]);
            CHECK(K[t.boundary_vertices[j]] ==
                  doctest::Approx(target.loop_total[i] * half / length).epsilon(1e-13));
          }
        }
        // Deterministic: the same bits again.
        std::vector<double> again(t.num_vertices, 0.0);
        effective_target(t, target, l, again, Geometry::Hyperbolic);
        CHECK(again == K);
      });
    }
  }
}

TEST_CASE("target: in E a Circle loop is an inscribed polygon whose layout closes") {
  for (const auto& s : fixtures()) {
    const Topology& t = s.topology;
    if (t.is_closed()) continue;
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      INFO(s.name);
      CAPTURE(seed);
      std::mt19937_64 rng(seed);
      const Target target = uniform_target(t, BoundaryMode::Circle);
      std::vector<double> l(t.num_edges);
      for (double& x : l) x = 0.5 + ricci_shapes::unit_double(rng);
      std::vector<double> K(t.num_vertices, -99.0);
      effective_target(t, target, l, K, Geometry::Euclidean);
      for (Index i = 0; i < t.num_boundary_loops(); ++i) {
        const Index b = t.boundary_offsets[i], e = t.boundary_offsets[i + 1];
        const InscribedCircle circle = inscribed_circle(t, i, l);
        // Sides in [0.5, 1.5) on loops of at least 3 sides: the polygon inequality holds, so
        // there is a circle (its centre inside or, past the longest side, outside).
        REQUIRE(circle.radius > 0);
        CHECK(circle.radius == inscribed_radius(t, i, l));
        REQUIRE(inscribed_circle_loop(target, Geometry::Euclidean, i));
        CHECK_FALSE(inscribed_circle_loop(target, Geometry::Hyperbolic, i));
        double sum = 0, arcs = 0;
        for (Index j = b; j < e; ++j) {
          sum += K[t.boundary_vertices[j]];
          arcs += circle.arc(j - b, l[t.corner_edge[t.boundary_corners[j]]]);
        }
        CHECK(std::abs(sum - target.loop_total[i]) <= 1e-12);
        CHECK(std::abs(arcs - 2 * kPi) <= 1e-12);
        // Walk the polygon: side j, then turn by |K̄| at the next vertex; it closes.
        std::complex<double> z = 0, dir = 1;
        for (Index j = b; j < e; ++j) {
          z += l[t.corner_edge[t.boundary_corners[j]]] * dir;
          const Index next = j + 1 < e ? j + 1 : b;
          dir *= std::polar(1.0, std::abs(K[t.boundary_vertices[next]]));
        }
        CHECK(std::abs(z) <= 1e-12 * (e - b));
      }
    }
  }
  // The radius: a regular n-gon of side s has R = s/(2 sin(π/n)); an impossible polygon gives 0.
  for (const int n : {3, 4, 7, 100}) {
    const std::vector<double> sides(static_cast<std::size_t>(n), 0.3);
    CHECK(inscribed_radius(sides) == doctest::Approx(0.3 / (2 * std::sin(kPi / n))).epsilon(1e-14));
  }
  CHECK(inscribed_radius(std::vector<double>{1.0, 1.0, 5.0}) == 0);
  CHECK(inscribed_radius(std::vector<double>{1.0, 1.0, 2.0}) == 0);  // degenerate: no polygon
  CHECK(inscribed_radius(std::vector<double>{1.0, 0.0, 1.0}) == 0);
  CHECK(inscribed_radius(std::vector<double>{1.0, 1.0}) == 0);
}

TEST_CASE("target: a polygon whose circle's centre lies outside it — the longest side's major arc") {
  // Triangles: the circumradius abc/(4·area) whatever the angles; obtuse ones have the centre
  // outside, beyond the longest side, which then subtends 2π − 2·arcsin(l/2R).
  std::mt19937_64 rng(17);
  for (int trial = 0; trial < 200; ++trial) {
    CAPTURE(trial);
    std::vector<double> sides(3);
    for (double& x : sides) x = 0.05 + ricci_shapes::unit_double(rng);
    const double a = sides[0], b = sides[1], c = sides[2], s = 0.5 * (a + b + c);
    const double area2 = s * (s - a) * (s - b) * (s - c);
    if (!(area2 > 1e-6)) continue;
    const InscribedCircle circle = inscribed_circle(sides);
    CHECK(circle.radius == doctest::Approx(a * b * c / (4 * std::sqrt(area2))).epsilon(1e-12));
    const Index longest = static_cast<Index>(std::max_element(sides.begin(), sides.end()) - sides.begin());
    const double m = sides[static_cast<std::size_t>(longest)];
    const bool obtuse = m * m > a * a + b * b + c * c - m * m;
    CHECK(circle.major == (obtuse ? longest : -1));
  }
  // Polygons with one long side: the arcs sum to 2π, the vertices lie on the circle, the turning
  // (α_in + α_out)/2 closes the polygon, and the solution is continuous through the semicircle.
  for (const int n : {3, 4, 6, 12, 50}) {
    for (const double stretch : {0.9, 0.99, 0.999999}) {
      CAPTURE(n);
      CAPTURE(stretch);
      std::vector<double> sides(static_cast<std::size_t>(n));
      for (int j = 0; j < n; ++j) sides[static_cast<std::size_t>(j)] = 0.5 + 0.4 * std::sin(1.7 * j);
      double others = 0;
      for (int j = 1; j < n; ++j) others += sides[static_cast<std::size_t>(j)];
      sides[0] = stretch * others;
      const InscribedCircle circle = inscribed_circle(sides);
      REQUIRE(circle.radius > 0);
      CHECK(circle.major == 0);
      double arcs = 0;
      for (int j = 0; j < n; ++j) arcs += circle.arc(j, sides[static_cast<std::size_t>(j)]);
      CHECK(std::abs(arcs - 2 * kPi) <= 1e-11);
      std::complex<double> z = 0, dir = 1;
      double before = circle.arc(n - 1, sides.back());
      for (int j = 0; j < n; ++j) {
        const double turn = 0.5 * (before + circle.arc(j, sides[static_cast<std::size_t>(j)]));
        if (j > 0) dir *= std::polar(1.0, turn);
        z += sides[static_cast<std::size_t>(j)] * dir;
        before = circle.arc(j, sides[static_cast<std::size_t>(j)]);
      }
      CHECK(std::abs(z) <= 1e-9 * others);
    }
  }
  // Through the semicircle: the radius is continuous as the longest side grows past 2R.
  std::vector<double> sides{1.0, 1.0, 1.0, 1.0};
  double last = 0;
  for (double top = 2.0; top < 2.5; top += 0.01) {
    sides[0] = top;
    const double R = inscribed_radius(sides);
    REQUIRE(R > 0);
    if (last > 0) CHECK(std::abs(R - last) < 0.05);
    last = R;
  }
}

TEST_CASE("target: effective_target keeps the outer loop whatever the lengths do") {
  const Surface s = find_fixture("annulus");
  const Topology& t = s.topology;
  const Target target = uniform_target(t, BoundaryMode::Circle);
  std::vector<double> l(t.num_edges, 1.0);
  // Make loop 1 ten times longer than loop 0: loop 0 stays the +2π loop.
  for (Index j = t.boundary_offsets[1]; j < t.boundary_offsets[2]; ++j)
    l[t.corner_edge[t.boundary_corners[j]]] = 10;
  std::vector<double> K(t.num_vertices);
  effective_target(t, target, l, K, Geometry::Euclidean);
  double loop0 = 0, loop1 = 0;
  for (Index j = t.boundary_offsets[0]; j < t.boundary_offsets[1]; ++j) loop0 += K[t.boundary_vertices[j]];
  for (Index j = t.boundary_offsets[1]; j < t.boundary_offsets[2]; ++j) loop1 += K[t.boundary_vertices[j]];
  CHECK(loop0 == doctest::Approx(2 * kPi));
  CHECK(loop1 == doctest::Approx(-2 * kPi));
  // Equal lengths give the equal shares stored in target.K.
  std::fill(l.begin(), l.end(), 0.7);
  effective_target(t, target, l, K, Geometry::Euclidean);
  for (Index v = 0; v < t.num_vertices; ++v) CHECK(K[v] == doctest::Approx(target.K[v]).epsilon(1e-14));
  // Degenerate lengths (all zero) fall back to equal shares without a floating-point exception.
  std::fill(l.begin(), l.end(), 0.0);
  effective_target(t, target, l, K, Geometry::Euclidean);
  for (Index v = 0; v < t.num_vertices; ++v) CHECK(K[v] == doctest::Approx(target.K[v]).epsilon(1e-14));
}

TEST_CASE("target: effective_target copies K̄ for the modes without loop totals") {
  const Surface s = find_fixture("disk with a hole");
  const Topology& t = s.topology;
  std::vector<double> l(t.num_edges, 0.3);
  for (BoundaryMode mode : {BoundaryMode::Free, BoundaryMode::FixedLengths, BoundaryMode::Geodesic}) {
    INFO(boundary_mode_name(mode));
    Target target = uniform_target(t, mode);
    for (Index v = 0; v < t.num_vertices; ++v) target.K[v] = 0.01 * v;
    std::vector<double> K(t.num_vertices, -1.0);
    effective_target(t, target, l, K, Geometry::Euclidean);
    CHECK(K == target.K);
  }
}

TEST_CASE("target: single_vertex_target puts 2πχ minus the loop totals at one vertex") {
  for (const auto& s : fixtures()) {
    const Topology& t = s.topology;
    INFO(s.name);
    const Index v = first_interior_vertex(t);
    REQUIRE(v != kInvalid);
    for (BoundaryMode mode : {BoundaryMode::Free, BoundaryMode::Circle, BoundaryMode::Geodesic,
                              BoundaryMode::FixedLengths, BoundaryMode::LoopTotals}) {
      INFO(boundary_mode_name(mode));
      const Target target = single_vertex_target(t, v, mode);
      REQUIRE(target.K.size() == static_cast<std::size_t>(t.num_vertices));
      const bool totals = mode == BoundaryMode::Circle || mode == BoundaryMode::LoopTotals;
      double taken = 0;
      for (double x : target.loop_total) taken += x;
      CHECK(target.K[v] == doctest::Approx(two_pi_chi(t) - taken));
      for (Index w = 0; w < t.num_vertices; ++w) {
        if (w == v) continue;
        if (totals && t.is_boundary_vertex(w)) continue;  // derived from the loop totals
        CHECK(target.K[w] == 0);
      }
      if (mode != BoundaryMode::FixedLengths)
        CHECK(std::abs(gauss_bonnet_sum(t, target) - two_pi_chi(t)) < 1e-12);
    }
  }
  // Closed surfaces: the whole 2πχ at the vertex; genus-0 Circle targets leave the vertex flat.
  CHECK(single_vertex_target(find_fixture("icosphere").topology, 3).K[3] == doctest::Approx(4 * kPi));
  CHECK(single_vertex_target(find_fixture("genus-2").topology, 3).K[3] == doctest::Approx(-4 * kPi));
  const Topology holes = find_fixture("sphere with 3 holes").topology;
  const Index hv = first_interior_vertex(holes);
  CHECK(single_vertex_target(holes, hv, BoundaryMode::Circle).K[hv] == doctest::Approx(0).epsilon(1e-12));
  CHECK(single_vertex_target(holes, hv, BoundaryMode::Geodesic).K[hv] == doctest::Approx(-2 * kPi));

  // A disk with a geodesic (straight) boundary and one cone: feasible in E.
  const Surface disk = find_fixture("disk");
  const Index dv = first_interior_vertex(disk.topology);
  const Target cone = single_vertex_target(disk.topology, dv, BoundaryMode::Geodesic);
  CHECK(cone.K[dv] == doctest::Approx(2 * kPi));
  // ... but a cone of 2π leaves no angle: rejected.
  CHECK(check_target(disk.topology, metric_for(disk, Geometry::Euclidean).structure, cone).status ==
        Status::InfeasibleTarget);

  // A chosen boundary vertex of a FixedLengths target is released from its held u.
  const Index bv = first_boundary_vertex(disk.topology);
  const Target fixed = single_vertex_target(disk.topology, bv, BoundaryMode::FixedLengths);
  CHECK(fixed.fixed_u[bv] == 0);
  CHECK(fixed.K[bv] == doctest::Approx(2 * kPi));

  // Out of range: an empty K, which check_target reports.
  const Target bad = single_vertex_target(disk.topology, disk.topology.num_vertices);
  CHECK(bad.K.empty());
  CHECK(check_target(disk.topology, metric_for(disk, Geometry::Euclidean).structure, bad).status ==
        Status::InvalidArgument);
  CHECK(single_vertex_target(disk.topology, -1).K.empty());
}

TEST_CASE("target: reading a valid target file") {
  ricci_test::TempDir dir;
  const Surface torus = find_fixture("torus");
  const Topology& t = torus.topology;

  const std::string text =
      "# cone singularities\n"
      "0 1.5\n"
      "\n"
      "   3\t-0.25   # a comment after the values\n"
      "7 +2e-1\n"
      "# last line without a newline\n"
      "8 -1.75";
  const TargetFileResult r = read_target_file(write_target(dir, "cones.txt", text), t);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.line == -1);
  CHECK(r.message.find("4 target curvatures") != std::string::npos);
  REQUIRE(r.target.K.size() == static_cast<std::size_t>(t.num_vertices));
  for (Index v = 0; v < t.num_vertices; ++v) {
    const double expected = v == 0 ? 1.5 : v == 3 ? -0.25 : v == 7 ? 0.2 : v == 8 ? -1.75 : 0.0;
    CHECK(r.target.K[v] == expected);
  }
  CHECK(r.target.boundary == BoundaryMode::Free);
  CHECK(r.target.fixed_u.empty());
  // Σ = −0.3 ≠ 2πχ = 0: the reader accepts it, the check does not.
  CHECK(check_target(t, metric_for(torus, Geometry::Euclidean).structure, r.target).status ==
        Status::InfeasibleTarget);

  // CRLF line ends, a byte-order mark, a lone CR, and an empty file.
  const TargetFileResult crlf = read_target_file(
      write_target(dir, "crlf.txt", "\xEF\xBB\xBF# x\r\n2 0.5\r\n\r\n4 -0.5\r\n5 1\r6 -1\r\n"), t);
  REQUIRE_MESSAGE(crlf.status == Status::Ok, crlf.message);
  CHECK(crlf.target.K[2] == 0.5);
  CHECK(crlf.target.K[4] == -0.5);
  CHECK(crlf.target.K[5] == 1);
  CHECK(crlf.target.K[6] == -1);
  CHECK(check_target(t, metric_for(torus, Geometry::Euclidean).structure, crlf.target).status == Status::Ok);
  const TargetFileResult empty = read_target_file(write_target(dir, "empty.txt", ""), t);
  REQUIRE(empty.status == Status::Ok);
  CHECK(empty.target.K == std::vector<double>(t.num_vertices, 0.0));
  // A file above the size limit is refused before it is read, naming its size and the limit.
  const std::string big = write_target(dir, "big.txt", "0 0.5\n1 -0.5\n");
  const TargetFileResult refused = read_target_file(big, t, BoundaryMode::Free, 8);
  CHECK(refused.status == Status::FileTooLarge);
  CHECK(refused.message.find("13 bytes") != std::string::npos);
  CHECK(refused.message.find("limit of 8") != std::string::npos);
  CHECK(read_target_file(big, t, BoundaryMode::Free, 13).status == Status::Ok);
}

TEST_CASE("target: unlisted boundary vertices of a target file follow the boundary mode") {
  ricci_test::TempDir dir;
  const Surface disk = find_fixture("disk");
  const Topology& t = disk.topology;
  const Index inner = first_interior_vertex(t), rim = first_boundary_vertex(t);
  const std::string interior_only = write_target(dir, "inner.txt", std::to_string(inner) + " 0.25\n");
  const std::string with_rim =
      write_target(dir, "rim.txt", std::to_string(inner) + " 0.25\n" + std::to_string(rim) + " 0.5\n");

  // Free: unlisted boundary vertices get 0 like interior ones.
  const TargetFileResult f = read_target_file(interior_only, t, BoundaryMode::Free);
  REQUIRE(f.status == Status::Ok);
  for (Index v = 0; v < t.num_vertices; ++v) CHECK(f.target.K[v] == (v == inner ? 0.25 : 0.0));

  // FixedLengths: unlisted boundary vertices hold u; a listed one carries its curvature instead.
  const TargetFileResult x = read_target_file(with_rim, t, BoundaryMode::FixedLengths);
  REQUIRE(x.status == Status::Ok);
  REQUIRE(x.target.fixed_u.size() == static_cast<std::size_t>(t.num_vertices));
  for (Index v = 0; v < t.num_vertices; ++v)
    CHECK((x.target.fixed_u[v] != 0) == (t.is_boundary_vertex(v) && v != rim));
  CHECK(x.target.K[rim] == 0.5);

  // Geodesic: unlisted boundary vertices get 0, listed ones their value.
  const TargetFileResult gd = read_target_file(with_rim, t, BoundaryMode::Geodesic);
  REQUIRE(gd.status == Status::Ok);
  CHECK(gd.target.K[rim] == 0.5);
  CHECK(gd.target.K[t.boundary_vertices[1]] == 0);

  // Circle: the loop totals decide the boundary; listing a boundary vertex is an error.
  const TargetFileResult c = read_target_file(interior_only, t, BoundaryMode::Circle);
  REQUIRE(c.status == Status::Ok);
  CHECK(c.target.loop_total == std::vector<double>{2 * kPi});
  CHECK(c.target.K[inner] == 0.25);
  const TargetFileResult cr = read_target_file(with_rim, t, BoundaryMode::Circle);
  CHECK(cr.status == Status::ParseError);
  CHECK(cr.line == 2);
  CHECK(cr.message.find("boundary") != std::string::npos);
  CHECK(read_target_file(with_rim, t, BoundaryMode::LoopTotals).status == Status::ParseError);
}

TEST_CASE("target: each target file error names its line") {
  ricci_test::TempDir dir;
  const Topology t = find_fixture("torus").topology;  // 54 vertices
  REQUIRE(t.num_vertices == 54);
  struct Case {
    const char* text;
    Status status;
    std::int64_t line;
    const char* mentions;
  };
  const Case cases[] = {
      {"0 1\n1\n", Status::ParseError, 2, "only"},
      {"0 1 2\n", Status::ParseError, 1, "third"},
      {"# c\nx 1\n", Status::ParseError, 2, "not an integer"},
      {"1.5 1\n", Status::ParseError, 1, "not an integer"},
      {"\n\n0 abc\n", Status::ParseError, 3, "not a number"},
      {"0 1\n1 nan\n", Status::ParseError, 2, "finite"},
      {"0 inf\n", Status::ParseError, 1, "finite"},
      {"0 -1e999\n", Status::ParseError, 1, "finite"},
      {"0 1\r\n-1 0\r\n", Status::IndexOutOfRange, 2, "54"},
      {"54 0\n", Status::IndexOutOfRange, 1, "54"},
      {"99999999999999999999999 0\n", Status::IndexOutOfRange, 1, "54"},
      {"3 1\n\n# again\n3 2\n", Status::ParseError, 4, "line 1"},
  };
  int k = 0;
  for (const Case& c : cases) {
    INFO(c.text);
    const std::string path = write_target(dir, "bad" + std::to_string(k++) + ".txt", c.text);
    const TargetFileResult r = read_target_file(path, t);
    CHECK(r.status == c.status);
    CHECK(r.line == c.line);
    CHECK(r.message.find(path) != std::string::npos);
    CHECK(r.message.find("line " + std::to_string(c.line)) != std::string::npos);
    CHECK(r.message.find(c.mentions) != std::string::npos);
  }
  // Out of range names the index and #V.
  const TargetFileResult oor = read_target_file(write_target(dir, "oor.txt", "-1 0\n"), t);
  CHECK(oor.message.find("-1") != std::string::npos);
  CHECK(oor.message.find("54 vertices") != std::string::npos);
  // The duplicate names both lines.
  const TargetFileResult dup = read_target_file(write_target(dir, "dup.txt", "3 1\n4 1\n3 2\n"), t);
  CHECK(dup.message.find("line 1") != std::string::npos);
  CHECK(dup.message.find("line 3") != std::string::npos);

  // Files that cannot be read name the path.
  const std::string missing = (dir / "no-such-file.txt").string();
  const TargetFileResult nf = read_target_file(missing, t);
  CHECK(nf.status == Status::FileNotFound);
  CHECK(nf.message.find(missing) != std::string::npos);
  CHECK(read_target_file((dir / "no-such-dir" / "x.txt").string(), t).status == Status::FileNotFound);
  const TargetFileResult isdir = read_target_file(dir.path().string(), t);
  CHECK(isdir.status == Status::FileUnreadable);
  CHECK(isdir.message.find(dir.path().string()) != std::string::npos);
}

TEST_CASE("target: random garbage target files never crash") {
  ricci_test::TempDir dir;
  const Topology t = find_fixture("disk").topology;
  const std::string alphabet =
      std::string("0123456789 \t\r\n#-+.eEinfaxN\xFF\xEF\xBB\xBF", 30) + std::string(1, '\0');
  const std::string valid = "0 0.5\n3 -0.25\n# comment\n7 1e-3\r\n";
  ricci_test::for_each_seed(1, 300, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::string text;
    if (seed % 2 == 0) {
      const Index n = ricci_shapes::uniform_index(rng, 200);
      for (Index i = 0; i < n; ++i)
        text += alphabet[ricci_shapes::uniform_index(rng, static_cast<Index>(alphabet.size()))];
    } else {
      text = valid;
      const Index edits = 1 + ricci_shapes::uniform_index(rng, 4);
      for (Index i = 0; i < edits; ++i) {
        const auto pos =
            static_cast<std::size_t>(ricci_shapes::uniform_index(rng, static_cast<Index>(text.size()) + 1));
        const char c = alphabet[ricci_shapes::uniform_index(rng, static_cast<Index>(alphabet.size()))];
        if (ricci_shapes::unit_double(rng) < 0.5 && pos < text.size())
          text[pos] = c;
        else
          text.insert(pos, 1, c);
      }
    }
    for (BoundaryMode mode : {BoundaryMode::Free, BoundaryMode::Circle, BoundaryMode::FixedLengths}) {
      const TargetFileResult r = read_target_file(write_target(dir, "garbage.txt", text), t, mode);
      const bool known =
          r.status == Status::Ok || r.status == Status::ParseError || r.status == Status::IndexOutOfRange;
      CHECK(known);
      if (r.status == Status::Ok) {
        REQUIRE(r.target.K.size() == static_cast<std::size_t>(t.num_vertices));
        for (double k : r.target.K) CHECK(std::isfinite(k));
      } else {
        CHECK(r.line >= 1);
      }
    }
  });
}

TEST_CASE("target: check_target rejects a Gauss-Bonnet violation and states 2πχ and the sum") {
  const Surface torus = find_fixture("torus");
  Target target = uniform_target(torus.topology);
  target.K[0] = 0.5;
  const TargetCheck c =
      check_target(torus.topology, metric_for(torus, Geometry::Euclidean).structure, target);
  CHECK(c.status == Status::InfeasibleTarget);
  CHECK(c.message.find("2πχ = 0") != std::string::npos);
  CHECK(c.message.find("sum to 0.5") != std::string::npos);

  // Circle loop totals count in the sum: a disk whose loop takes 3π instead of 2π.
  const Surface disk = find_fixture("disk");
  Target circle = uniform_target(disk.topology, BoundaryMode::Circle);
  circle.loop_total[0] = 3 * kPi;
  const TargetCheck cc = check_target(disk.topology, metric_for(disk, Geometry::Euclidean).structure, circle);
  CHECK(cc.status == Status::InfeasibleTarget);
  CHECK(cc.message.find("2πχ = 6.28318530718") != std::string::npos);
  CHECK(cc.message.find("sum to 9.42477796077") != std::string::npos);

  // H needs Σ K̄ > 2πχ: all of 2πχ at one vertex leaves no hyperbolic area.
  const Surface g2 = find_fixture("genus-2");
  const TargetCheck ch = check_target(g2.topology, metric_for(g2, Geometry::Hyperbolic).structure,
                                      single_vertex_target(g2.topology, 0));
  CHECK(ch.status == Status::InfeasibleTarget);
  CHECK(ch.message.find("more than 2πχ") != std::string::npos);
  // S needs Σ K̄ < 2πχ.
  const Surface sphere = find_fixture("icosphere");
  const TargetCheck cs = check_target(sphere.topology, metric_for(sphere, Geometry::Spherical).structure,
                                      single_vertex_target(sphere.topology, 0));
  CHECK(cs.status == Status::InfeasibleTarget);
  CHECK(cs.message.find("less than 2πχ") != std::string::npos);

  // Held vertices lift the condition: any interior sum is accepted with FixedLengths.
  Target fixed = uniform_target(disk.topology, BoundaryMode::FixedLengths);
  fixed.K[first_interior_vertex(disk.topology)] = 1.0;
  const TargetCheck cf = check_target(disk.topology, metric_for(disk, Geometry::Euclidean).structure, fixed);
  CHECK_MESSAGE(cf.status == Status::Ok, cf.message);
}

TEST_CASE("target: check_target rejects cone angles that are not positive") {
  const Surface torus = find_fixture("torus");
  const ConformalStructure st = metric_for(torus, Geometry::Euclidean).structure;
  Target target = uniform_target(torus.topology);
  target.K[5] = 2 * kPi;   // cone angle 0
  target.K[6] = -2 * kPi;  // keeps Σ = 0
  const TargetCheck c = check_target(torus.topology, st, target);
  CHECK(c.status == Status::InfeasibleTarget);
  CHECK(c.element == Element::Vertex);
  CHECK(c.element_index == 5);
  CHECK(c.message.find("vertex 5") != std::string::npos);
  CHECK(c.message.find("cone angle") != std::string::npos);

  // On the boundary the limit is π.
  const Surface disk = find_fixture("disk");
  const Topology& t = disk.topology;
  Target b = uniform_target(t, BoundaryMode::Free);
  const Index rim = first_boundary_vertex(t), inner = first_interior_vertex(t);
  b.K[inner] -= kPi - b.K[rim];
  b.K[rim] = kPi;
  const TargetCheck cb = check_target(t, metric_for(disk, Geometry::Euclidean).structure, b);
  CHECK(cb.status == Status::InfeasibleTarget);
  CHECK(cb.element_index == rim);
  CHECK(cb.message.find("below π") != std::string::npos);

  // In every geometry and scheme.
  for (Scheme sc : {Scheme::CirclePacking, Scheme::InversiveDistance, Scheme::Yamabe})
    CHECK(check_target(torus.topology, metric_for(torus, Geometry::Euclidean, sc).structure, target).status ==
          Status::InfeasibleTarget);

  // A loop total cannot reach π times its vertex count.
  Target circle = uniform_target(t, BoundaryMode::LoopTotals);
  const Index n = loop_size(t, 0);
  circle.loop_total[0] = kPi * n;
  circle.K[inner] = 2 * kPi - kPi * n;
  const TargetCheck cl = check_target(t, metric_for(disk, Geometry::Euclidean).structure, circle);
  CHECK(cl.status == Status::InfeasibleTarget);
  CHECK(cl.message.find("boundary loop 0") != std::string::npos);
}

namespace {

// A closed surface with a vertex of valence 3: an icosphere with face 0 split at its centroid.
Surface sphere_with_valence_3(Index* apex) {
  Mesh m = ricci_shapes::icosphere(1);
  const Index a = m.faces[0], b = m.faces[1], c = m.faces[2];
  const Index p = m.num_vertices();
  for (int d = 0; d < 3; ++d)
    m.positions.push_back((m.positions[3 * a + d] + m.positions[3 * b + d] + m.positions[3 * c + d]) / 3);
  m.faces[2] = p;
  m.faces.insert(m.faces.end(), {b, c, p, c, a, p});
  Surface s = make_surface("split icosphere", m, Geometry::Spherical);
  *apex = p;
  REQUIRE(s.topology.valence(p) == 3);
  return s;
}

}  // namespace

TEST_CASE("target: check_target rejects a single vertex that violates Theorem 4") {
  Index p = kInvalid;
  const Surface s = sphere_with_valence_3(&p);
  const Topology& t = s.topology;
  const ConformalStructure st = metric_for(s, Geometry::Euclidean).structure;
  const double bound = opposite_link(t, st, p);  // the largest cone angle p can have (≈ 3π: Φ ≈ 0)
  for (double margin : {-0.1, 0.1}) {
    CAPTURE(margin);
    // Cone angle bound + margin at p, the rest of 4π shared by the other vertices.
    Target target = uniform_target(t);
    target.K[p] = 2 * kPi - (bound + margin);
    for (Index v = 0; v < t.num_vertices; ++v)
      if (v != p) target.K[v] = (4 * kPi - target.K[p]) / (t.num_vertices - 1);
    const TargetCheck c = check_target(t, st, target);
    if (margin > 0) {
      CHECK(c.status == Status::InfeasibleTarget);
      CHECK(c.element == Element::Vertex);
      CHECK(c.element_index == p);
      CHECK(c.message.find("Theorem 4") != std::string::npos);
      CHECK(c.message.find("vertex " + std::to_string(p)) != std::string::npos);
      CHECK(c.message.find("3 opposite edges") != std::string::npos);
      // Hyperbolic circle packing has the same bound.
      Target h = target;
      for (Index v = 0; v < t.num_vertices; ++v)
        if (v != p) h.K[v] = 0.5;
      CHECK(check_target(t, metric_for(s, Geometry::Hyperbolic).structure, h).element_index == p);
      // Other schemes and S have no such bound: only Gauss–Bonnet and cone angles are checked.
      for (Scheme sc : {Scheme::InversiveDistance, Scheme::Yamabe})
        CHECK(check_target(t, metric_for(s, Geometry::Euclidean, sc).structure, target).status == Status::Ok);
    } else {
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
    }
  }
  // A boundary vertex: its cone angle π − K̄ must be below Σ(π − Φ) too.
  const Surface disk = find_fixture("disk");
  const ConformalStructure ds = metric_for(disk, Geometry::Euclidean).structure;
  const Index rim = first_boundary_vertex(disk.topology), inner = first_interior_vertex(disk.topology);
  Target b = uniform_target(disk.topology, BoundaryMode::Free);
  const double old = b.K[rim];
  b.K[rim] = kPi - (opposite_link(disk.topology, ds, rim) + 0.05);
  b.K[inner] += old - b.K[rim];
  const TargetCheck cb = check_target(disk.topology, ds, b);
  CHECK(cb.status == Status::InfeasibleTarget);
  CHECK(cb.element_index == rim);
  CHECK(cb.message.find("boundary vertex") != std::string::npos);
}

TEST_CASE("target: the Theorem 4 bound is the limit of a shrinking circle and real metrics pass") {
  // The cone angle at a vertex whose radius shrinks tends to Σ(π − Φ) from below (E and H).
  Index p = kInvalid;
  const Surface s = sphere_with_valence_3(&p);
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic}) {
    INFO(geometry_name(g));
    const InitialMetric m = metric_for(s, g);
    const double bound = opposite_link(s.topology, m.structure, p);
    double previous = 0;
    for (double shrink : {2.0, 8.0, 30.0}) {
      std::vector<double> u = m.u;
      u[p] -= shrink;
      const Evaluation e = evaluate(s.topology, m.structure, u);
      const double angle = 2 * kPi - e.K[p];
      CHECK(angle < bound);
      CHECK(angle > previous);
      previous = angle;
      // The realised curvatures are admissible, however close to the bound.
      const TargetCheck c = check_target(s.topology, m.structure, free_target(e.K));
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
    }
    // Near Φ = 0 the angles approach π, so the gap closes like √r: e^{-15} here.
    CHECK(previous == doctest::Approx(bound).epsilon(1e-5));
  }
  // Shrinking every circle of a boundary loop drives the loop's total towards its Theorem 4
  // bound (π n − π F₂ − Σ_Lk(π − Φ)), from above: the realised curvatures still pass.
  const Surface holed = find_fixture("disk with a hole");
  const Topology& ht = holed.topology;
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic}) {
    for (Index loop = 0; loop < 2; ++loop) {
      INFO(geometry_name(g) << " loop " << loop);
      const InitialMetric m = metric_for(holed, g);
      std::vector<double> u = m.u;
      for (Index j = ht.boundary_offsets[loop]; j < ht.boundary_offsets[loop + 1]; ++j)
        u[ht.boundary_vertices[j]] -= 30;
      const Evaluation e = evaluate(ht, m.structure, u);
      const TargetCheck c = check_target(ht, m.structure, free_target(e.K));
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
      // Tighten: move the loop's curvature down by a little more than the remaining gap.
      Target tight = free_target(e.K);
      const Index n = loop_size(ht, loop);
      const double shift = 1e-3;
      for (Index j = ht.boundary_offsets[loop]; j < ht.boundary_offsets[loop + 1]; ++j)
        tight.K[ht.boundary_vertices[j]] -= shift / n;
      tight.K[first_interior_vertex(ht)] += shift;  // keeps Σ K̄
      const TargetCheck ct = check_target(ht, m.structure, tight);
      CHECK(ct.status == Status::InfeasibleTarget);
      CHECK(ct.message.find("boundary loop " + std::to_string(loop)) != std::string::npos);
    }
  }

  // Curvatures of random circle packings pass on every fixture (free boundary: explicit K̄).
  for_each_random_packing(2, [](const Surface& f, const InitialMetric& m, std::vector<double>&, const Evaluation& e,
                                std::mt19937_64&) {
    const TargetCheck c = check_target(f.topology, m.structure, free_target(e.K));
    CHECK_MESSAGE(c.status == Status::Ok, c.message);
  });
}

TEST_CASE("target: Theorem 4 on the level sets of u finds the sets single vertices and loops miss") {
  // A torus of tangent circles (Φ = 0): two adjacent vertices of valence 6 each pass the
  // single-vertex bound K̄ > 2π − 6π = −4π at −3.5π, but together they must exceed
  // 4π − π·2 − 8π = −6π (2 faces with both, 8 faces with one of them): −7π is infeasible.
  const Surface s = find_fixture("torus");
  const Topology& t = s.topology;
  ConformalStructure st = metric_for(s, Geometry::Euclidean).structure;
  std::fill(st.eta.begin(), st.eta.end(), 1.0);
  const Index v = t.edge_vertices[0], w = t.edge_vertices[1];
  REQUIRE(t.valence(v) == 6);
  REQUIRE(t.valence(w) == 6);
  Target target = uniform_target(t);
  for (Index x = 0; x < t.num_vertices; ++x) target.K[x] = 7 * kPi / (t.num_vertices - 2);
  target.K[v] = target.K[w] = -3.5 * kPi;
  const TargetCheck before = check_target(t, st, target);
  REQUIRE_MESSAGE(before.status == Status::Ok, before.message);

  // The pair at the bottom of u: the sublevel set of 2 is violated.
  std::vector<double> u(static_cast<std::size_t>(t.num_vertices), 0.0);
  u[v] = -5;
  u[w] = -4;
  const TargetCheck pair = check_theorem4_levels(t, st, target, u);
  CHECK(pair.status == Status::InfeasibleTarget);
  CHECK(pair.element_index == v);
  CHECK(pair.message.find("the 2 vertices whose radii shrank") != std::string::npos);
  CHECK(pair.message.find("vertex scaling") != std::string::npos);
  // Inversive distance with these η is the same circle pattern; Yamabe, S, and a weight outside
  // [0, 1] have no such bound.
  ConformalStructure other = st;
  other.scheme = Scheme::InversiveDistance;
  CHECK(check_theorem4_levels(t, other, target, u).status == Status::InfeasibleTarget);
  other.eta[5] = 1.5;
  CHECK(check_theorem4_levels(t, other, target, u).status == Status::Ok);
  other = st;
  other.scheme = Scheme::Yamabe;
  CHECK(check_theorem4_levels(t, other, target, u).status == Status::Ok);
  other = st;
  other.geometry = Geometry::Spherical;
  CHECK(check_theorem4_levels(t, other, target, u).status == Status::Ok);
  // The solve itself stalls there, and says why.
  FlowOptions fo;
  fo.max_iterations = 60;
  const FlowResult r = solve_flow(t, st, std::vector<double>(static_cast<std::size_t>(t.num_vertices), 0.0), target, fo);
  CHECK_MESSAGE(r.status == Status::InfeasibleTarget, r.message);
  CHECK(r.message.find("Theorem 4") != std::string::npos);
  CHECK(r.message.find("shrank") != std::string::npos);
  CHECK(!r.notes.empty());
  CHECK(r.u.size() == static_cast<std::size_t>(t.num_vertices));
  MESSAGE("stalled torus: " << r.iterations << " Newton steps; " << r.message);

  // Never on a realised curvature: the curvatures of random packings satisfy (T4) on every set,
  // so no level set of any u — theirs or a shuffled one — is violated (E, H, every fixture).
  for_each_random_packing(3, [](const Surface& f, const InitialMetric& m, std::vector<double>& ur, const Evaluation& e,
                                std::mt19937_64& rng) {
    const Target realised = free_target(e.K);
    const TargetCheck c = check_theorem4_levels(f.topology, m.structure, realised, ur);
    CHECK_MESSAGE(c.status == Status::Ok, c.message);
    std::shuffle(ur.begin(), ur.end(), rng);
    CHECK(check_theorem4_levels(f.topology, m.structure, realised, ur).status == Status::Ok);
  });
}

TEST_CASE("target: check_target rejects a boundary loop that violates Theorem 4") {
  const Surface s = find_fixture("disk with a hole");
  const Topology& t = s.topology;
  const ConformalStructure st = metric_for(s, Geometry::Euclidean).structure;
  const Index hole = loop_size(t, 0) == 6 ? 0 : 1, rim = 1 - hole;
  REQUIRE(loop_size(t, hole) == 6);
  // The bound for I = the hole's vertices: π n − π F₂ − Σ over faces touching the hole at one
  // vertex of (π − Φ(opposite edge)).
  std::vector<bool> on_hole(t.num_vertices, false);
  for (Index j = t.boundary_offsets[hole]; j < t.boundary_offsets[hole + 1]; ++j)
    on_hole[t.boundary_vertices[j]] = true;
  double link = 0;
  Index two = 0;
  for (Index f = 0; f < t.num_faces; ++f) {
    Index count = 0, corner = kInvalid;
    for (Index k = 0; k < 3; ++k)
      if (on_hole[t.corner_vertex[3 * f + k]]) {
        ++count;
        corner = 3 * f + k;
      }
    if (count >= 2) ++two;
    if (count == 1) link += kPi - std::acos(st.eta[t.corner_edge[corner]]);
  }
  const double bound = kPi * 6 - kPi * two - link;
  CHECK(two == 6);
  CHECK(bound < -2 * kPi);  // the uniform Circle target (−2π) is admissible
  for (double margin : {-0.5, 0.5}) {
    CAPTURE(margin);
    Target target = uniform_target(t, BoundaryMode::LoopTotals);
    target.loop_total[hole] = bound + margin;
    target.loop_total[rim] = -(bound + margin);  // χ = 0
    const TargetCheck c = check_target(t, st, target);
    if (margin < 0) {
      CHECK(c.status == Status::InfeasibleTarget);
      CHECK(c.message.find("boundary loop " + std::to_string(hole)) != std::string::npos);
      CHECK(c.message.find("Theorem 4") != std::string::npos);
    } else {
      CHECK_MESSAGE(c.status == Status::Ok, c.message);
    }
  }
  // The same loop with explicit (Free) boundary curvatures: the loop's sum counts.
  Target free = uniform_target(t, BoundaryMode::Free);
  for (Index v = 0; v < t.num_vertices; ++v) free.K[v] = 0;
  for (Index j = t.boundary_offsets[hole]; j < t.boundary_offsets[hole + 1]; ++j)
    free.K[t.boundary_vertices[j]] = (bound - 0.5) / 6;
  for (Index j = t.boundary_offsets[rim]; j < t.boundary_offsets[rim + 1]; ++j)
    free.K[t.boundary_vertices[j]] = -(bound - 0.5) / loop_size(t, rim);
  const TargetCheck cf = check_target(t, st, free);
  CHECK(cf.status == Status::InfeasibleTarget);
  CHECK(cf.message.find("boundary loop " + std::to_string(hole)) != std::string::npos);
}

TEST_CASE("target: check_target validates sizes and values") {
  const Surface disk = find_fixture("disk");
  const Topology& t = disk.topology;
  const ConformalStructure st = metric_for(disk, Geometry::Euclidean).structure;
  const Target good = uniform_target(t);
  REQUIRE(check_target(t, st, good).status == Status::Ok);

  Target k = good;
  k.K.pop_back();
  CHECK(check_target(t, st, k).status == Status::InvalidArgument);
  Target fx = good;
  fx.fixed_u.assign(3, 0);
  CHECK(check_target(t, st, fx).status == Status::InvalidArgument);
  Target lt = good;
  lt.loop_total.push_back(0);
  CHECK(check_target(t, st, lt).status == Status::InvalidArgument);
  ConformalStructure short_eta = st;
  short_eta.eta.pop_back();
  CHECK(check_target(t, short_eta, good).status == Status::InvalidArgument);
  Target nan = good;
  nan.K[first_interior_vertex(t)] = std::numeric_limits<double>::quiet_NaN();
  const TargetCheck cn = check_target(t, st, nan);
  CHECK(cn.status == Status::InvalidArgument);
  CHECK(cn.element == Element::Vertex);
  Target inf = good;
  inf.loop_total[0] = std::numeric_limits<double>::infinity();
  CHECK(check_target(t, st, inf).status == Status::InvalidArgument);
  // A held vertex's K̄ is not a condition: a NaN there is ignored.
  Target held = uniform_target(t, BoundaryMode::FixedLengths);
  held.K[first_boundary_vertex(t)] = std::numeric_limits<double>::quiet_NaN();
  CHECK(check_target(t, st, held).status == Status::Ok);
}
