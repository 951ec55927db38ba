// The round sphere in vertex scaling from a plane problem: one vertex sent to infinity.
//
// Takes: an intrinsic triangulation in S of a closed genus-0 surface (chords B, intrinsic.h).
// Gives: u on its vertices that solves the round-sphere problem (K = 0 everywhere in S), up to the
// rounding of one planar solve and one layout; solve_flow_with_flips() starts from it.
//
// Stereographic projection σ from a point N of the unit sphere is a vertex scaling: for points
// P, Q of the sphere and x = σ(P), y = σ(Q) in the plane, |P − Q| = 2 |x − y| ρ(x) ρ(y) with
// ρ(x) = 1 / √(1 + |x|²), and |P − N| = 2 ρ(x). So if u solves the round sphere with N a vertex,
// the sphere without N's star, projected from N, is a planar (E) vertex-scaling metric with
//     U_p = u_p − 2 log ρ(x_p)   (chords L^E = e^{(U_p + U_q)/2} B_pq),
// flat at every vertex off N's link and, at every link vertex p, U_p = −2 log B_pN − u_N. That
// Dirichlet problem on the disk is strictly convex and (with intrinsic flips) has exactly one
// solution (Gu–Luo–Sun–Wu 2018, I), which is therefore the projection of the round sphere
// (Delaunay is Möbius invariant; the link edges are the planar hull). Solving it, laying it out,
// and reading back u_p = U_p + log s + 2 log ρ(x_p) and u_N = m − log s (s: the planar scale, m:
// the shift of the link values below) gives the sphere. Unlike the spherical energy, the planar
// one is convex, so Newton converges from any start.
#include "sphere_start.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "ricci/layout.h"

namespace ricci::detail {

namespace {

constexpr double kReflexTolerance = 1e-8;  // a link vertex this far past π is flipped inside (nearer π: cocircular, either way)
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegenerateAngle = 1e-3;  // a disk triangle on the link this close to flat is flipped
constexpr int kMaxRounds = 12;
constexpr std::size_t kCandidates = 3;  // vertices at infinity tried
constexpr int kMaxContinuation = 60;
constexpr int kMaxPlanarIterations = 50;  // a convex problem: Newton needs far fewer
constexpr double kPlanarTolerance = 1e-8;  // max |K| of a planar solve good enough for a start
// The planar solves' work over every vertex tried, counted as each solve's Newton steps plus one
// (a solve that stops in its first line search still evaluated the energy there up to ~30 times):
// past this the start costs more than solving on the sphere directly (≤ 12 steps where that
// converges), so it stops.
constexpr int kStartBudget = 40;

// Vertices whose star is a disk of distinct faces around distinct link vertices: up to `count`,
// the ones where the starting metric is flattest first (least |K| in S at u = 0; ties: smaller
// index). A vertex whose neighbourhood is already round is likely to keep its star at the
// solution, which the planar problem assumes.
std::vector<Index> vertices_at_infinity(const IntrinsicTriangulation& tri, std::size_t count) {
  const Topology& t = tri.topology;
  ConformalStructure structure;
  vertex_scaling_structure(tri, structure);
  std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(static_cast<std::size_t>(3 * t.num_faces)),
      K(static_cast<std::size_t>(t.num_vertices), 0.0);
  const std::vector<double> zero(static_cast<std::size_t>(t.num_vertices), 0.0);
  if (edge_lengths(t, structure, zero, l) == kInvalid) {
    corner_angles(t, Geometry::Spherical, l, theta);
    vertex_curvature(t, theta, K);
  }
  std::vector<std::pair<double, Index>> simple;  // (|K|, vertex)
  std::vector<Index> seen(static_cast<std::size_t>(t.num_vertices), kInvalid);
  for (Index v = 0; v < t.num_vertices; ++v) {
    const Index b = t.vertex_corner_offsets[v], e = t.vertex_corner_offsets[v + 1];
    bool ok = e - b >= 3;
    for (Index i = b; i < e && ok; ++i) {
      const Index c = t.vertex_corners[i];
      const Index w = t.corner_vertex[next_corner(c)];
      ok = w != v && t.corner_vertex[prev_corner(c)] != v && seen[w] != v;
      seen[w] = v;
    }
    if (ok) simple.push_back({std::abs(K[v]), v});
  }
  std::sort(simple.begin(), simple.end());
  std::vector<Index> out;
  for (std::size_t i = 0; i < simple.size() && i < count; ++i) out.push_back(simple[i].second);
  return out;
}

// edge_corners and edge_vertices from corner_edge: corners in increasing order, so an edge's first
// corner is its smaller one, and the edge runs as in that corner's face.
void edges_from_corners(Topology& t) {
  t.edge_corners.assign(static_cast<std::size_t>(2 * t.num_edges), kInvalid);
  t.edge_vertices.assign(static_cast<std::size_t>(2 * t.num_edges), kInvalid);
  for (Index c = 0; c < t.num_corners(); ++c) {
    const Index e = t.corner_edge[c];
    if (t.edge_corners[2 * e] == kInvalid) {
      t.edge_corners[2 * e] = c;
      t.edge_vertices[2 * e] = t.corner_vertex[next_corner(c)];
      t.edge_vertices[2 * e + 1] = t.corner_vertex[prev_corner(c)];
    } else {
      t.edge_corners[2 * e + 1] = c;
    }
  }
}

// The triangulation without the faces around vertex n (a simple star), n removed from the vertex
// numbering, as a euclidean intrinsic triangulation with the same chords: a corner table of its
// own (edges in the order of their old indices, boundary loop walked along the faces), so that
// several edges between two vertices survive.
IntrinsicTriangulation disk_without_star(const IntrinsicTriangulation& tri, Index n, std::vector<Index>& old_edge,
                                         std::vector<Index>& old_face) {
  const Topology& t = tri.topology;
  IntrinsicTriangulation out;
  out.geometry = Geometry::Euclidean;
  Topology& d = out.topology;
  std::vector<Index> face_map(static_cast<std::size_t>(t.num_faces), kInvalid);
  for (Index f = 0; f < t.num_faces; ++f) {
    const Index c = 3 * f;
    if (t.corner_vertex[c] != n && t.corner_vertex[c + 1] != n && t.corner_vertex[c + 2] != n) {
      face_map[f] = d.num_faces++;
      old_face.push_back(f);
    }
  }
  auto corner = [&](Index c) { return c == kInvalid || face_map[corner_face(c)] == kInvalid ? kInvalid : 3 * face_map[corner_face(c)] + corner_slot(c); };
  d.num_vertices = t.num_vertices - 1;
  const Index nc = 3 * d.num_faces;
  d.corner_vertex.resize(static_cast<std::size_t>(nc));
  d.opposite.resize(static_cast<std::size_t>(nc));
  d.corner_edge.resize(static_cast<std::size_t>(nc));
  std::vector<Index> edge_map(static_cast<std::size_t>(t.num_edges), kInvalid);
  for (Index c = 0; c < t.num_corners(); ++c)
    if (corner(c) != kInvalid) edge_map[t.corner_edge[c]] = 0;
  for (Index e = 0; e < t.num_edges; ++e)
    if (edge_map[e] == 0) {
      edge_map[e] = d.num_edges++;
      old_edge.push_back(e);
      out.log_chord.push_back(tri.log_chord[e]);
    }
  for (Index c = 0; c < t.num_corners(); ++c) {
    const Index k = corner(c);
    if (k == kInvalid) continue;
    const Index v = t.corner_vertex[c];
    d.corner_vertex[k] = v < n ? v : v - 1;
    d.opposite[k] = corner(t.opposite[c]);
    d.corner_edge[k] = edge_map[t.corner_edge[c]];
  }
  edges_from_corners(d);
  // Boundary loops, each from its smallest corner, along the faces.
  std::vector<std::uint8_t> walked(static_cast<std::size_t>(nc), 0);
  d.boundary_offsets.assign(1, 0);
  for (Index k = 0; k < nc; ++k) {
    if (d.opposite[k] != kInvalid || walked[k]) continue;
    Index c = k;
    while (!walked[c]) {
      walked[c] = 1;
      d.boundary_vertices.push_back(d.corner_vertex[next_corner(c)]);
      d.boundary_corners.push_back(c);
      Index x = prev_corner(c);  // at the edge's end; turn clockwise to the next boundary edge
      for (Index guard = 0; d.opposite[prev_corner(x)] != kInvalid && guard < nc; ++guard) x = prev_corner(d.opposite[prev_corner(x)]);
      c = prev_corner(x);
    }
    d.boundary_offsets.push_back(static_cast<Index>(d.boundary_corners.size()));
  }
  d.face_component.assign(static_cast<std::size_t>(d.num_faces), 0);
  d.num_components = d.num_faces > 0 ? 1 : 0;
  refresh_vertex_corners(d);
  out.boundary_position.assign(static_cast<std::size_t>(d.num_edges), kInvalid);
  for (Index p = 0; p < d.num_boundary_edges(); ++p) out.boundary_position[d.corner_edge[d.boundary_corners[p]]] = p;
  out.normal.assign(static_cast<std::size_t>(d.num_edges), -1);
  return out;
}

// Writes the disk's connectivity and chords (after its flips) back into the sphere it was cut
// from (disk_without_star() with the same n, old_edge and old_face): the disk's faces and edges
// keep their sphere indices; the star of n is unchanged and glued along the link again.
void write_back(IntrinsicTriangulation& sphere, const IntrinsicTriangulation& disk, Index n,
                const std::vector<Index>& old_edge, const std::vector<Index>& old_face) {
  Topology& t = sphere.topology;
  const Topology& d = disk.topology;
  auto back = [n](Index v) { return v < n ? v : v + 1; };
  auto sphere_corner = [&](Index c) { return 3 * old_face[corner_face(c)] + corner_slot(c); };
  for (Index e = 0; e < d.num_edges; ++e) sphere.log_chord[old_edge[e]] = disk.log_chord[e];
  // The star's corners across each link edge, before the disk's corners are rewritten.
  std::vector<Index> star_across(static_cast<std::size_t>(t.num_edges), kInvalid);
  for (Index c = 0; c < t.num_corners(); ++c) {
    const Index f = corner_face(c);
    if (t.corner_vertex[3 * f] == n || t.corner_vertex[3 * f + 1] == n || t.corner_vertex[3 * f + 2] == n)
      star_across[t.corner_edge[c]] = c;
  }
  for (Index c = 0; c < d.num_corners(); ++c) {
    const Index sc = sphere_corner(c), e = old_edge[d.corner_edge[c]];
    t.corner_vertex[sc] = back(d.corner_vertex[c]);
    t.corner_edge[sc] = e;
    if (d.opposite[c] != kInvalid) {
      t.opposite[sc] = sphere_corner(d.opposite[c]);
    } else {
      t.opposite[sc] = star_across[e];
      t.opposite[star_across[e]] = sc;
    }
  }
  edges_from_corners(t);
  refresh_vertex_corners(t);
}

}  // namespace

static SphereStart start_from(const IntrinsicTriangulation& tri, Index n, const FlowOptions& options, int budget,
                              int& spent) {
  SphereStart out;
  const Index nv = tri.topology.num_vertices;
  out.vertex_at_infinity = n;
  // The disk: every face off N, vertices renumbered without N; its chords read as euclidean. In
  // rounds (at most kMaxRounds), one Ptolemy flip in the sphere's own triangulation per round:
  // where the plane is reflex at a link vertex, N's edge to it is not Delaunay (with N at infinity
  // its circumcircles are lines) and its flip moves the vertex inside; where Newton stalls on a
  // disk triangle on the link going flat, its vertex reaches the hull and the link edge's flip
  // joins it to N. Until the link is convex and the plane solved. For some vertices the link
  // alternates (an edge flipped back: on the shared decimated-max and nefertiti the vertex of
  // largest valence does); round_sphere_start() then tries the next vertex.
  auto renumber = [n](Index v) { return v < n ? v : v - 1; };
  IntrinsicTriangulation sphere = tri;
  Target target;
  target.K.assign(static_cast<std::size_t>(nv - 1), 0.0);
  std::vector<double> u0(static_cast<std::size_t>(nv - 1), 0.0);
  double c_shift = 0;
  IntrinsicTriangulation disk_tri;
  FlowResult plane;
  std::vector<Index> disk_order;  // the last planar solve's ordering, as disk vertices
  FlowOptions eo = options;
  eo.on_iteration = nullptr;
  eo.max_iterations = std::min(options.max_iterations, kMaxPlanarIterations);
  // A start: the spherical Newton steps after it converge quadratically from here.
  eo.tolerance = std::max(options.tolerance, kPlanarTolerance);
  eo.polish_steps = 0;
  std::vector<Index> flipped_before;  // link flips so far: flipping one back means the link alternates
  auto alternates = [&](Index e) {
    if (std::find(flipped_before.begin(), flipped_before.end(), e) != flipped_before.end()) return true;
    flipped_before.push_back(e);
    return false;
  };
  for (int round = 0;; ++round) {
    if (spent >= budget) {
      out.message = "the planar solves used up their budget (" + std::to_string(kStartBudget) +
                    " Newton steps and solves)";
      return out;
    }
    const Topology& t2 = sphere.topology;
    std::vector<Index> old_edge, old_face;
    disk_tri = disk_without_star(sphere, n, old_edge, old_face);
    const Topology& d = disk_tri.topology;
    if (d.num_boundary_loops() != 1 || d.euler_characteristic() != 1) {
      out.message = "the sphere without the star of vertex " + std::to_string(n) + " is not a disk";
      return out;
    }
    // Link vertices held at −2 log B_pN − m (m the first round's mean, so u_N = m), flat
    // everywhere else. In the first round the inside starts from the link's values spread
    // breadth-first (each vertex the mean of its neighbours reached before it), so that no
    // triangle starts far from the triangle inequality; later rounds from the last solution.
    target.fixed_u.assign(static_cast<std::size_t>(nv - 1), 0);
    std::vector<Index> queue;
    double sum_link = 0;
    for (Index i = t2.vertex_corner_offsets[n]; i < t2.vertex_corner_offsets[n + 1]; ++i) {
      const Index c = t2.vertex_corners[i];
      const Index p = renumber(t2.corner_vertex[next_corner(c)]);
      target.fixed_u[p] = 1;
      u0[p] = -2 * sphere.log_chord_of(t2.corner_edge[prev_corner(c)]);  // the edge N–next(c)
      sum_link += u0[p];
      queue.push_back(p);
    }
    if (round == 0) c_shift = sum_link / static_cast<double>(queue.size());
    for (Index p : queue) u0[p] -= c_shift;
    if (round == 0) {
      std::vector<std::uint8_t> reached(target.fixed_u.begin(), target.fixed_u.end());
      for (std::size_t head = 0; head < queue.size(); ++head) {
        const Index v = queue[head];
        for (Index i = d.vertex_corner_offsets[v]; i < d.vertex_corner_offsets[v + 1]; ++i) {
          const Index c = d.vertex_corners[i];
          for (const Index w : {d.corner_vertex[next_corner(c)], d.corner_vertex[prev_corner(c)]}) {
            if (reached[w]) continue;
            reached[w] = 1;
            double sum = 0;
            int count = 0;
            for (Index j = d.vertex_corner_offsets[w]; j < d.vertex_corner_offsets[w + 1]; ++j) {
              const Index x = d.vertex_corners[j];
              for (const Index y : {d.corner_vertex[next_corner(x)], d.corner_vertex[prev_corner(x)]})
                if (reached[y] && y != w) {
                  sum += u0[y];
                  ++count;
                }
            }
            u0[w] = count > 0 ? sum / count : 0.0;
            queue.push_back(w);
          }
        }
      }
    }
    {
      const IntrinsicTriangulation fresh = disk_tri;
      // A later round's disk differs from the last by one flip at the link: the last ordering
      // serves it (sphere_start.h's order, FlowSolver::set_ordering()).
      const std::vector<Index> hint = disk_order;
      plane = solve_flow_with_flips_ordered(disk_tri, u0, target, eo, &hint, &disk_order);
      out.iterations += plane.iterations;
      spent += plane.iterations + 1;
      if (plane.status == Status::TriangleInequality && plane.iterations == 0) {
        // The link's values are too far from the inside's for the start's triangles: walk them
        // there from the chords as given (u = 0, whose triangles are the sphere's flat chord
        // triangles), each step from the last solution, halving a step whose start fails.
        std::vector<double> u_t(u0.size(), 0.0), trial(u0.size());
        double t = 0, step = 1;
        disk_tri = fresh;
        plane = solve_flow_with_flips_ordered(disk_tri, u_t, target, eo, nullptr, &disk_order);
        out.iterations += plane.iterations;
        spent += plane.iterations + 1;
        for (int k = 0; plane.status == Status::Ok && t < 1 && k < kMaxContinuation && spent < budget; ++k) {
          const double next = std::min(1.0, t + step);
          trial = plane.u;
          for (std::size_t v = 0; v < u0.size(); ++v)
            if (target.fixed_u[v]) trial[v] = next * u0[v];
          IntrinsicTriangulation attempt = disk_tri;
          std::vector<Index> attempt_order;
          FlowResult f = solve_flow_with_flips_ordered(attempt, trial, target, eo, &disk_order, &attempt_order);
          out.iterations += f.iterations;
          spent += f.iterations + 1;
          if (f.status == Status::Ok) {
            t = next;
            step *= 2;
            plane = std::move(f);
            disk_tri = std::move(attempt);
            disk_order = std::move(attempt_order);
          } else {
            step /= 2;
          }
        }
        if (plane.status == Status::Ok && t < 1) {
          plane.status = Status::NotConverged;
          plane.message = "the link values could not be reached from the chords";
        }
      }
    }
    // The sphere takes the disk's flips, so that a link edge is flipped in the quadrilateral the
    // disk's solution has there.
    write_back(sphere, disk_tri, n, old_edge, old_face);
    Index flipped = 0;
    if (plane.status != Status::Ok) {
      // A disk triangle on a link edge that degenerates (its angle opposite the edge reaching π)
      // stops Newton: its vertex reaches the hull, so the link edge is not Delaunay with N at
      // infinity. Flip it in the sphere (Ptolemy), which joins that vertex to N.
      const Topology& dt = disk_tri.topology;
      std::vector<double> theta(static_cast<std::size_t>(3 * dt.num_faces));
      corner_angles(dt, Geometry::Euclidean, plane.l, theta);
      // One flip per round, the flattest triangle (several at once can overshoot and cycle).
      Index flattest = kInvalid;
      for (const Index c : dt.boundary_corners)
        if (theta[c] > kPi - kDegenerateAngle && can_flip(sphere, old_edge[dt.corner_edge[c]]) == FlipCheck::Ok &&
            (flattest == kInvalid || theta[c] > theta[flattest]))
          flattest = c;
      if (flattest != kInvalid) {
        const Index e = old_edge[dt.corner_edge[flattest]];
        if (alternates(e)) {
          out.message = "the link of the vertex at infinity alternates (edge " + std::to_string(e) + ")";
          return out;
        }
        flip_edge(sphere, e);
        ++flipped;
      }
      if (flipped == 0) {
        out.message = "the planar problem: " + plane.message;
        return out;
      }
    }
    // Reflex link vertices (interior angle above π, K < 0): flip N's edge to them.
    // One per round, the most reflex.
    std::vector<std::pair<Index, Index>> reflex;  // (edge N–v, v)
    double most = -kReflexTolerance;
    for (Index i = t2.vertex_corner_offsets[n]; i < t2.vertex_corner_offsets[n + 1] && flipped == 0; ++i) {
      const Index c = t2.vertex_corners[i];
      const Index v = t2.corner_vertex[next_corner(c)];
      if (plane.K[renumber(v)] < most) {
        most = plane.K[renumber(v)];
        reflex.assign(1, {t2.corner_edge[prev_corner(c)], v});
      }
    }
    Index valence = t2.vertex_corner_offsets[n + 1] - t2.vertex_corner_offsets[n];
    for (const auto& [e, v] : reflex) {
      const Index a = sphere.topology.edge_vertices[2 * e], b = sphere.topology.edge_vertices[2 * e + 1];
      const bool still = (a == n && b == v) || (a == v && b == n);
      if (!still || valence <= 3 || can_flip(sphere, e) != FlipCheck::Ok) continue;
      if (alternates(e)) {
        out.message = "the link of the vertex at infinity alternates (edge " + std::to_string(e) + ")";
        return out;
      }
      flip_edge(sphere, e);
      --valence;
      ++flipped;
    }
    if (flipped == 0) break;
    refresh_vertex_corners(sphere.topology);
    if (round >= kMaxRounds) {
      out.message = "the link of the vertex at infinity was still not convex after " + std::to_string(kMaxRounds) + " rounds";
      return out;
    }
    u0 = plane.u;
    out.rounds = round + 1;
  }
  LayoutOptions lo;
  lo.normalize = false;
  lo.polish_steps = 0;  // a start: the flow refines it
  lo.polish_sweeps = 0;
  const Layout lay = layout_disk(disk_tri.topology, Geometry::Euclidean, plane.l, lo);
  if (lay.status != Status::Ok) {
    out.message = "the planar layout: " + lay.message;
    return out;
  }
  // Centre the plane on its vertices' mean and scale their root mean square distance to 1, so
  // the sphere's points spread over it; then read u back.
  double mx = 0, my = 0, r2 = 0;
  for (Index p = 0; p < nv - 1; ++p) {
    mx += lay.positions[2 * p];
    my += lay.positions[2 * p + 1];
  }
  mx /= nv - 1;
  my /= nv - 1;
  for (Index p = 0; p < nv - 1; ++p)
    r2 += std::pow(lay.positions[2 * p] - mx, 2) + std::pow(lay.positions[2 * p + 1] - my, 2);
  const double s = 1 / std::sqrt(r2 / (nv - 1));
  if (!std::isfinite(s) || !(s > 0)) {
    out.message = "the planar layout has no extent";
    return out;
  }
  out.u.assign(static_cast<std::size_t>(nv), 0.0);
  for (Index v = 0; v < nv; ++v) {
    if (v == n) {
      out.u[v] = c_shift - std::log(s);
      continue;
    }
    const Index p = renumber(v);
    const double x = s * (lay.positions[2 * p] - mx), y = s * (lay.positions[2 * p + 1] - my);
    out.u[v] = plane.u[p] + std::log(s) - std::log1p(x * x + y * y);
  }
  // Möbius centring of the points on the sphere (their mean to the centre, so the centre lies
  // inside their hull and no face spans a hemisphere): x ↦ (1 − |c|²)(x + c)/|x + c|² + c scales
  // chords by √(f(x) f(y)), f(x) = (1 − |c|²)/|x + c|², i.e. adds log f to u.
  std::vector<std::array<double, 3>> P(static_cast<std::size_t>(nv));
  for (Index v = 0; v < nv; ++v) {
    if (v == n) {
      P[v] = {0, 0, 1};
      continue;
    }
    const Index p = renumber(v);
    const double x = s * (lay.positions[2 * p] - mx), y = s * (lay.positions[2 * p + 1] - my), q = 1 + x * x + y * y;
    P[v] = {2 * x / q, 2 * y / q, (x * x + y * y - 1) / q};
  }
  for (int it = 0; it < 100; ++it) {
    double mu[3] = {0, 0, 0}, J[3][3] = {};
    for (const auto& x : P)
      for (int a = 0; a < 3; ++a) {
        mu[a] += x[a] / nv;
        for (int b = 0; b < 3; ++b) J[a][b] += 2 * ((a == b ? 1.0 : 0.0) - x[a] * x[b]) / nv;
      }
    if (std::sqrt(mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2]) < 1e-13) break;
    // c = −J⁻¹ μ (Cramer), capped at |c| ≤ 0.5.
    const double det = J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
                       J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
    if (!(std::abs(det) > 1e-300)) break;
    double c[3];
    for (int k = 0; k < 3; ++k) {
      double M[3][3];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) M[a][b] = b == k ? -mu[a] : J[a][b];
      c[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
              M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) / det;
    }
    const double cn = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if (cn > 0.5)
      for (double& x : c) x *= 0.5 / cn;
    const double c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    for (Index v = 0; v < nv; ++v) {
      auto& x = P[v];
      const double w[3] = {x[0] + c[0], x[1] + c[1], x[2] + c[2]};
      const double w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
      out.u[v] += std::log((1 - c2) / w2);
      for (int a = 0; a < 3; ++a) x[a] = (1 - c2) * w[a] / w2 + c[a];
    }
  }
  out.order.reserve(disk_order.size());
  for (const Index p : disk_order) out.order.push_back(p < n ? p : p + 1);
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

SphereStart round_sphere_start(const IntrinsicTriangulation& tri, const FlowOptions& options) {
  // A few vertices at infinity in turn: where one's link does not settle, another's may.
  SphereStart out;
  out.message = "no vertex has a simple star";
  int iterations = 0, spent = 0;
  for (const Index n : vertices_at_infinity(tri, kCandidates)) {
    if (spent >= kStartBudget) break;
    SphereStart s = start_from(tri, n, options, kStartBudget, spent);
    iterations += s.iterations;
    s.iterations = iterations;
    if (s.status == Status::Ok) return s;
    if (out.vertex_at_infinity == kInvalid) out = std::move(s);
  }
  out.iterations = iterations;
  return out;
}

}  // namespace ricci::detail
