// Layout polishing (white box, lib/layout/layout_polish.h): exact positions of a seeded jittered disk
// (E; H: the same disk shrunk to radius 0.8 in the Poincaré disk) and icosphere (S) give exact
// edge lengths; the positions are then bent by a smooth drift
// (what a long propagation accumulates) plus noise. Global Gauss–Newton brings the layout back to
// the lengths' own precision, holds the gauge vertex fixed, never raises the max error, and does
// what the local sweeps alone cannot; the sweeps remove short-range noise in all three
// geometries; a consistent layout is left as it is.
#include <doctest/doctest.h>

#include <omp.h>

#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "layout_internal.h"
#include "layout_polish.h"
#include "model_geometry.h"
#include "ricci/layout.h"
#include "ricci/metric.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "ricci/topology.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;

namespace {

struct Case {
  Topology topo;
  Geometry g = Geometry::Euclidean;
  std::vector<double> exact;  // positions with which the lengths agree exactly
  std::vector<double> l;
};

double dist(const Case& c, const std::vector<double>& x, Index a, Index b) {
  if (c.g == Geometry::Euclidean) return std::hypot(x[2 * a] - x[2 * b], x[2 * a + 1] - x[2 * b + 1]);
  if (c.g == Geometry::Hyperbolic)
    return model::disk_distance({x[2 * a], x[2 * a + 1]}, {x[2 * b], x[2 * b + 1]});
  return model::sphere_distance({x[3 * a], x[3 * a + 1], x[3 * a + 2]}, {x[3 * b], x[3 * b + 1], x[3 * b + 2]});
}

double max_error(const Case& c, const std::vector<double>& x) {
  double worst = 0;
  for (Index e = 0; e < c.topo.num_edges; ++e) {
    const double d = dist(c, x, c.topo.edge_vertices[2 * e], c.topo.edge_vertices[2 * e + 1]);
    worst = std::max(worst, std::abs(d - c.l[e]) / c.l[e]);
  }
  return worst;
}

Case make_case(Geometry g, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Case c;
  c.g = g;
  const Mesh m = g == Geometry::Spherical ? ricci_shapes::icosphere(4) : ricci_shapes::disk(24);
  const TopologyResult tr = build_topology(m.faces, static_cast<Index>(m.positions.size() / 3));
  REQUIRE(tr.status == Status::Ok);
  c.topo = tr.topology;
  const Index nv = c.topo.num_vertices;
  std::uniform_real_distribution<double> jitter(-0.25, 0.25);
  const double h = g == Geometry::Spherical ? 0.07 : 1.0 / 24;  // about one edge length
  const double radius = g == Geometry::Hyperbolic ? 0.8 : 1.0;
  for (Index v = 0; v < nv; ++v) {
    if (g != Geometry::Spherical) {
      c.exact.push_back(radius * (m.positions[3 * v] + jitter(rng) * h));
      c.exact.push_back(radius * (m.positions[3 * v + 1] + jitter(rng) * h));
    } else {
      double p[3];
      for (int d = 0; d < 3; ++d) p[d] = m.positions[3 * v + d] + jitter(rng) * h;
      const double n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      for (double& q : p) c.exact.push_back(q / n);
    }
  }
  for (Index e = 0; e < c.topo.num_edges; ++e)
    c.l.push_back(dist(c, c.exact, c.topo.edge_vertices[2 * e], c.topo.edge_vertices[2 * e + 1]));
  return c;
}

/// The exact positions bent by a smooth drift of relative size `drift` (E, H: a slow rotation and
/// stretch growing with the distance from the origin; S: a rotation about an axis by an angle that
/// varies with height) plus uniform noise of size `noise` times an edge length.
std::vector<double> bent(const Case& c, double drift, double noise, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> x = c.exact;
  const Index nv = c.topo.num_vertices;
  for (Index v = 0; v < nv; ++v) {
    if (c.g != Geometry::Spherical) {
      const double X = x[2 * v], Y = x[2 * v + 1], r2 = X * X + Y * Y;
      const double a = drift * r2, s = 1 + drift * X * (c.g == Geometry::Hyperbolic ? 0.1 : 1.0);
      x[2 * v] = s * (std::cos(a) * X - std::sin(a) * Y) + noise * u(rng) / 24;
      x[2 * v + 1] = s * (std::sin(a) * X + std::cos(a) * Y) + noise * u(rng) / 24;
    } else {
      const double X = x[3 * v], Y = x[3 * v + 1], Z = x[3 * v + 2];
      const double a = drift * (1 + Z) * (1 + Z);  // a twist about the z axis, growing towards +z
      double p[3] = {std::cos(a) * X - std::sin(a) * Y + noise * u(rng) * 0.07,
                     std::sin(a) * X + std::cos(a) * Y + noise * u(rng) * 0.07, Z + noise * u(rng) * 0.07};
      const double n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      for (int d = 0; d < 3; ++d) x[3 * v + d] = p[d] / n;
    }
  }
  return x;
}

}  // namespace

TEST_CASE("layout polish: global Gauss–Newton removes a smooth drift in E, H and S") {
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      CAPTURE(static_cast<int>(g));
      const Case c = make_case(g, seed);
      const std::vector<double> start = bent(c, 1e-6, 1e-9, seed + 100);
      const double before = max_error(c, start);
      REQUIRE(before > 1e-8);

      std::vector<double> x = start;
      const detail::GlobalPolish gp = detail::polish_globally(c.topo, g, c.l, x, 5);
      CHECK(gp.factorized);
      CHECK(gp.steps >= 1);
      CHECK(gp.error_before == doctest::Approx(before).epsilon(1e-12));
      CHECK(gp.error_after == doctest::Approx(max_error(c, x)).epsilon(1e-12));
      CHECK(gp.error_after < 1e-13);
      // The gauge: the first edge's first vertex does not move.
      const Index p = c.topo.edge_vertices[0];
      const int dims = g == Geometry::Spherical ? 3 : 2;
      for (int d = 0; d < dims; ++d) CHECK(x[dims * p + d] == start[dims * p + d]);

      // Local sweeps alone reduce the smooth part only slowly.
      std::vector<double> swept = start;
      detail::polish_by_sweeps(c.topo, g, c.l, swept, 30);
      CHECK(max_error(c, swept) > 100 * gp.error_after);
    });
  }
}

TEST_CASE("layout polish: Gauss–Seidel sweeps remove short-range noise in E, H and S") {
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      CAPTURE(static_cast<int>(g));
      const Case c = make_case(g, seed);
      const std::vector<double> start = bent(c, 0, 1e-7, seed + 200);
      const double before = max_error(c, start);
      REQUIRE(before > 1e-9);
      std::vector<double> x = start;
      detail::polish_by_sweeps(c.topo, g, c.l, x, 10);
      const double after = max_error(c, x);
      MESSAGE("sweeps: " << before << " -> " << after);
      CHECK(after < before / 10);
      // Deterministic, and H stays inside the unit disk.
      std::vector<double> again = start;
      detail::polish_by_sweeps(c.topo, g, c.l, again, 10);
      CHECK(again == x);
      if (g == Geometry::Hyperbolic)
        for (Index v = 0; v < c.topo.num_vertices; ++v) CHECK(std::hypot(x[2 * v], x[2 * v + 1]) < 1);
    });
  }
}

TEST_CASE("layout polish: a sweep's colour classes share no edge, cover each vertex once, and give the same result on 1 and 3 threads") {
  // A disk large enough that each colour class is swept in parallel (classes of over 4096).
  const Mesh m = ricci_shapes::disk(200);
  const TopologyResult tr = build_topology(m.faces, static_cast<Index>(m.positions.size() / 3));
  REQUIRE(tr.status == Status::Ok);
  const Topology& t = tr.topology;
  const Index nv = t.num_vertices;
  std::vector<Index> odd;  // a subset in a scrambled order
  for (Index v = nv - 1; v >= 0; v -= 3) odd.push_back(v);
  for (const std::vector<Index>& only : {std::vector<Index>{}, odd}) {
    const detail::SweepOrder order = detail::sweep_order(t, only);
    const std::size_t classes = order.class_start.size() - 1;
    if (only.empty()) CHECK(classes >= 3);  // a triangulation needs three at least
    CHECK(classes <= 12);
    REQUIRE(order.vertices.size() == (only.empty() ? static_cast<std::size_t>(nv) : only.size()));
    std::vector<int> colour(static_cast<std::size_t>(nv), -1);
    for (std::size_t c = 0; c < classes; ++c)
      for (Index i = order.class_start[c]; i < order.class_start[c + 1]; ++i) {
        const Index v = order.vertices[static_cast<std::size_t>(i)];
        CHECK(colour[v] == -1);  // once
        colour[v] = static_cast<int>(c);
      }
    for (Index v : only) CHECK(colour[v] >= 0);
    Index clashes = 0;
    for (Index e = 0; e < t.num_edges; ++e) {
      const int a = colour[t.edge_vertices[2 * e]], b = colour[t.edge_vertices[2 * e + 1]];
      clashes += a >= 0 && a == b ? 1 : 0;
    }
    CHECK(clashes == 0);
  }
  // Plane positions of the disk, noisy against their own lengths; 1 and 3 threads agree bit for bit.
  std::vector<double> exact, l;
  for (Index v = 0; v < nv; ++v) {
    exact.push_back(m.positions[3 * v]);
    exact.push_back(m.positions[3 * v + 1]);
  }
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    l.push_back(std::hypot(exact[2 * a] - exact[2 * b], exact[2 * a + 1] - exact[2 * b + 1]));
  }
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e-7, 1e-7);
  std::vector<double> start = exact;
  for (double& x : start) x += u(rng) / 200;
  const int saved = omp_get_max_threads();
  std::vector<double> one = start, three = start;
  omp_set_num_threads(1);
  detail::polish_by_sweeps(t, Geometry::Euclidean, l, one, 3);
  omp_set_num_threads(3);
  detail::polish_by_sweeps(t, Geometry::Euclidean, l, three, 3);
  omp_set_num_threads(saved);
  CHECK(one == three);
  CHECK(one != start);
}

TEST_CASE("layout polish: sweeps over a subset move only it and remove a local defect there") {
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
      CAPTURE(static_cast<int>(g));
      const Case c = make_case(g, seed);
      const Index nv = c.topo.num_vertices, dims = g == Geometry::Spherical ? 3 : 2;
      // One vertex pushed off its place (the kind of defect a seam leaves), the rest exact.
      std::mt19937_64 rng(seed + 300);
      const Index v0 = static_cast<Index>(rng() % static_cast<std::uint64_t>(nv));
      std::vector<double> start = c.exact;
      for (Index d = 0; d < dims; ++d) start[dims * v0 + d] += 1e-7 * (d == 0 ? 1 : 0.5);
      if (g == Geometry::Spherical) {
        const double n = std::hypot(start[3 * v0], start[3 * v0 + 1], start[3 * v0 + 2]);
        for (int d = 0; d < 3; ++d) start[3 * v0 + d] /= n;
      }
      // The subset: v0 and the vertices within two edges of it, in index order.
      std::vector<int> ring(static_cast<std::size_t>(nv), -1);
      ring[v0] = 0;
      for (int r = 0; r < 2; ++r)
        for (Index e = 0; e < c.topo.num_edges; ++e) {
          const Index a = c.topo.edge_vertices[2 * e], b = c.topo.edge_vertices[2 * e + 1];
          if (ring[a] == r && ring[b] < 0) ring[b] = r + 1;
          if (ring[b] == r && ring[a] < 0) ring[a] = r + 1;
        }
      std::vector<Index> only;
      for (Index v = 0; v < nv; ++v)
        if (ring[v] >= 0) only.push_back(v);
      REQUIRE(only.size() > 7);
      REQUIRE(static_cast<Index>(only.size()) < nv / 4);
      const double before = max_error(c, start);
      std::vector<double> x = start;
      detail::polish_by_sweeps(c.topo, g, c.l, x, 4, only);
      const double after = max_error(c, x);
      MESSAGE("subset sweeps: " << before << " -> " << after);
      CHECK(after < before / 10);
      Index moved_outside = 0, moved_inside = 0;
      for (Index v = 0; v < nv; ++v) {
        bool moved = false;
        for (Index d = 0; d < dims; ++d) moved = moved || x[dims * v + d] != start[dims * v + d];
        (ring[v] >= 0 ? moved_inside : moved_outside) += moved ? 1 : 0;
      }
      CHECK(moved_outside == 0);
      CHECK(moved_inside > 1);
    });
  }
}

TEST_CASE("layout polish: a consistent layout stays, and no step raises the max error") {
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    const Case c = make_case(g, 7);
    std::vector<double> x = c.exact;
    const double e0 = max_error(c, x);
    const detail::GlobalPolish gp = detail::polish_globally(c.topo, g, c.l, x, 5);
    CHECK(gp.error_after <= e0);
    CHECK(max_error(c, x) <= e0);
    CHECK(max_error(c, x) < 1e-14);

    // Noise at the level of double rounding: whatever is kept is no worse.
    std::vector<double> y = bent(c, 0, 1e-15, 11);
    const double e1 = max_error(c, y);
    const detail::GlobalPolish gq = detail::polish_globally(c.topo, g, c.l, y, 5);
    CHECK(gq.error_after <= e1);
    CHECK(max_error(c, y) == doctest::Approx(gq.error_after).epsilon(1e-12));

    // No steps asked: nothing moves.
    std::vector<double> z = bent(c, 1e-6, 0, 12);
    const std::vector<double> z0 = z;
    const detail::GlobalPolish none = detail::polish_globally(c.topo, g, c.l, z, 0);
    CHECK(none.steps == 0);
    CHECK(z == z0);
  }
}

TEST_CASE("layout polish: polish_steps is validated and reported") {
  LayoutOptions o;
  std::string why;
  CHECK(o.is_valid(&why));
  o.polish_steps = -1;
  CHECK_FALSE(o.is_valid(&why));
  CHECK(why.find("polish_steps") != std::string::npos);
  o.polish_steps = 21;
  CHECK_FALSE(o.is_valid(&why));
  o.polish_steps = 0;
  CHECK(o.is_valid(&why));
}

TEST_CASE("layout from shapes: a flat disk's own layout, to the solve's conditioning, then polished to rounding") {
  ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
    const Case c = make_case(Geometry::Euclidean, seed);
    std::vector<double> theta(3 * static_cast<std::size_t>(c.topo.num_faces));
    corner_angles(c.topo, Geometry::Euclidean, c.l, theta);
    const Index s0 = c.topo.corner_vertex[0], s1 = c.topo.corner_vertex[1];
    std::vector<double> x(c.exact.size(), 0.0);
    REQUIRE(detail::develop_by_shapes(c.topo, c.l, theta, s0, s1, x));
    // One solve of a Laplacian-like system of 1.8k vertices: about 1e-11.
    CHECK(max_error(c, x) < 1e-10);
    CHECK(x[2 * s0] == 0);
    CHECK(x[2 * s0 + 1] == 0);
    CHECK(x[2 * s1 + 1] == 0);
    CHECK(x[2 * s1] > 0);
    // The exact positions moved so that s0 is at the origin and s1 on +x: the same layout.
    const double ox = c.exact[2 * s0], oy = c.exact[2 * s0 + 1];
    const double dx = c.exact[2 * s1] - ox, dy = c.exact[2 * s1 + 1] - oy, r = std::hypot(dx, dy);
    double apart = 0;
    for (Index v = 0; v < c.topo.num_vertices; ++v) {
      const double px = c.exact[2 * v] - ox, py = c.exact[2 * v + 1] - oy;
      const double rx = (px * dx + py * dy) / r, ry = (py * dx - px * dy) / r;
      apart = std::max(apart, std::hypot(rx - x[2 * v], ry - x[2 * v + 1]));
    }
    CHECK(apart < 1e-10);
    const detail::GlobalPolish gp = detail::polish_globally(c.topo, Geometry::Euclidean, c.l, x, 3);
    CHECK(gp.error_after < 1e-13);
  });
}

TEST_CASE("layout: a long annulus of needles lays out by one propagation, where trilateration cannot") {
  // annulus(60, 40) by vertex scaling with circle boundaries: the circle domain squeezes one side
  // into needles of aspect ~12 and angle ~0.05 rad. Placed face by face from the measured
  // directions of placed neighbours (trilateration: detail::propagate_faces(), the patches' own
  // development), each misplacement turns every later face, and the error grows geometrically
  // (a relative edge error of 33 here). The propagation of
  // layout_disk() carries each face's orientation from its parent's by the faces' angles alone,
  // so one pass reproduces the metric to near rounding, without any refinement.
  const ValidateResult v = validate_mesh(ricci_shapes::annulus(60, 40));
  REQUIRE(v.status == Status::Ok);
  UniformizeOptions o;
  o.seed_checks = 1;
  const UniformizeResult r = uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.layout.max_edge_length_error < 1e-11);
  CHECK(r.layout.flipped_faces == 0);
  CHECK(r.seed_independence_error < 1e-9);
  LayoutOptions lenient;
  lenient.refine_above = 1e3;
  const Layout as_propagated = layout_disk(r.disk, r.geometry, r.disk_lengths, lenient);
  REQUIRE(as_propagated.status == Status::Ok);
  MESSAGE("one propagation: " << as_propagated.max_edge_length_error);
  CHECK(as_propagated.max_edge_length_error < 1e-10);
  CHECK(as_propagated.patches + as_propagated.polish_sweeps + as_propagated.polish_steps == 0);
  CHECK_FALSE(as_propagated.shape_solve);
  // Trilateration from the same seed over the same faces.
  std::vector<double> x;
  std::vector<Index> touched;
  Layout tri;
  const std::vector<Index> owner(static_cast<std::size_t>(r.disk.num_faces), 0);
  REQUIRE(detail::propagate_faces(r.disk, r.geometry, r.disk_lengths, as_propagated.seed_face, owner, 0, x, touched, tri));
  REQUIRE(touched.size() == static_cast<std::size_t>(r.disk.num_vertices));
  const Layout measured = measure_layout(r.disk, r.geometry, r.disk_lengths, x);
  MESSAGE("trilateration: " << measured.max_edge_length_error);
  CHECK(measured.max_edge_length_error > 1e-8);
  // Without the polishing steps (and so without the shape solve) the metric lays out all the same.
  UniformizeOptions raw = o;
  raw.layout.polish_steps = 0;
  raw.use_atlas = false;
  const UniformizeResult q = uniformize(v.mesh, v.topology, raw);
  REQUIRE_MESSAGE(q.status == Status::Ok, q.message);
  CHECK(q.layout.max_edge_length_error < 1e-10);
}
