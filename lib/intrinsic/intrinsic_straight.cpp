// The metric of a flipped intrinsic triangulation carried back to the input's own triangulation:
// every input edge replaced by the geodesic of the metric homotopic to it (see
// ricci/intrinsic_trace.h, straight_input_metric()).
//
// Takes: the triangulation at u, the input Topology and the traced paths of its edges. Gives: one
// length per input edge, and how well the straight input triangles tile the surface.
//
// Each input edge a→b is developed along the faces its path crosses: the first face is placed with
// a at the pole of the model (E the origin of the plane, S the north pole of the unit sphere, H the
// apex (0, 0, 1) of the hyperboloid x² + y² − z² = −1), and every further face is unfolded across
// the crossed edge onto the left of that edge's image, at the corner angle the metric gives it.
// The distance from the pole to b's image is the length of the straight edge. The metric is flat,
// spherical or hyperbolic without cone points away from the vertices, so the development is
// the isometric immersion of the strip and the distance does not depend on anything but the path's
// homotopy class.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "hessian.h"
#include "model_geometry.h"
#include "ricci/intrinsic_trace.h"

namespace ricci {

namespace {

using namespace model;

// A model point as a vector of R³ whose span is the point's line through the origin: E's plane
// z = 0 is lifted to z = 1, so that in all three models a geodesic is the model's section by a
// plane through the origin.
P3 lift(Geometry g, const P3& x) { return g == Geometry::Euclidean ? P3{x[0], x[1], 1} : x; }

// Where the geodesic through (lifted) a and b meets the chord from p to q: the fraction s with
// (1 − s) p + s q on the line where the two planes meet. Outside [0, 1] when the geodesic misses
// the segment; NaN when the two coincide.
double chord_crossing(const P3& a, const P3& b, const P3& p, const P3& q) {
  const P3 n = cross(p, q);
  const P3 x = cross(cross(a, b), n);
  const double alpha = dot(cross(x, q), n), beta = dot(cross(p, x), n);
  const double s = beta / (alpha + beta);
  return std::isfinite(s) ? s : NAN;
}

}  // namespace

StraightInputMetric straight_input_metric(const IntrinsicTriangulation& tri, std::span<const double> u,
                                          const Topology& input, const InputEdgePaths& paths) {
  StraightInputMetric r;
  const Topology& t = tri.topology;
  const Geometry g = tri.geometry;
  const Index nin = input.num_edges;
  if (paths.status != Status::Ok || paths.along.size() != static_cast<std::size_t>(nin) ||
      u.size() != static_cast<std::size_t>(t.num_vertices) || input.num_vertices != t.num_vertices) {
    r.status = Status::InvalidArgument;
    r.message = paths.status != Status::Ok ? "the input edges were not traced: " + paths.message
                                           : "the traced paths, u or the input do not match the triangulation";
    return r;
  }
  // The metric at u on the current triangulation: lengths and corner angles.
  ConformalStructure structure;
  vertex_scaling_structure(tri, structure);
  std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(static_cast<std::size_t>(3 * t.num_faces));
  const Index bad_edge = edge_lengths(t, structure, u, l);
  const AngleReport angles = corner_angles(t, g, l, theta);
  if (bad_edge != kInvalid || angles.violations > 0) {
    r.status = Status::TriangleInequality;
    r.message = bad_edge != kInvalid ? "edge " + std::to_string(bad_edge) + " of the metric has no valid length"
                                     : "face " + std::to_string(angles.first_violation) +
                                           " of the metric violates the triangle inequality";
    return r;
  }

  if (paths.crossed_edge.empty() && is_input_triangulation(tri, input)) {
    // The input's own triangles at u: its straight edges are the current ones, its angles the
    // metric's (the general path below computes the same numbers: angle sums equal bit for bit).
    r.l = std::move(l);
    r.status = Status::Ok;
    r.message = "ok";
    return r;
  }
  r.l.assign(static_cast<std::size_t>(nin), 0.0);
  r.crossings.assign(paths.crossed_edge.size(), NAN);
  std::vector<std::uint8_t> broken(static_cast<std::size_t>(nin), 0);
  // Per crossing, the crossed edge's ends in the development: at next(cc), then at prev(cc).
  std::vector<P3> ends(2 * paths.crossed_edge.size());
#pragma omp parallel for schedule(dynamic, 256) if (nin >= detail::kParallelMin)
  for (Index a = 0; a < nin; ++a) {
    if (paths.along[a] != kInvalid) {
      r.l[a] = l[paths.along[a]];
      continue;
    }
    // The first face, its corner at the input edge's first vertex on the pole.
    Index c0 = paths.first_corner[a];
    std::array<P3, 3> pos;  // by slot of the current face's corners
    auto at = [&](Index c) -> P3& { return pos[static_cast<std::size_t>(corner_slot(c))]; };
    at(c0) = pole(g);
    at(next_corner(c0)) = polar(g, l[t.corner_edge[prev_corner(c0)]], 0);
    at(prev_corner(c0)) = polar(g, l[t.corner_edge[next_corner(c0)]], theta[c0]);
    Index face = corner_face(c0);
    for (Index k = paths.offsets[a]; k < paths.offsets[a + 1]; ++k) {
      const Index cc = paths.crossed_corner[k];
      const Index oc = cc == kInvalid ? kInvalid : t.opposite[cc];
      if (corner_face(cc) != face || oc == kInvalid) {
        broken[a] = 1;
        break;
      }
      // Across the edge opposite cc: its ends keep their images; oc's vertex goes to the left of
      // the edge from next(oc) to prev(oc), at the corner angle of next(oc).
      const P3 p = at(prev_corner(cc)), q = at(next_corner(cc));
      ends[2 * static_cast<std::size_t>(k)] = q;
      ends[2 * static_cast<std::size_t>(k) + 1] = p;
      at(next_corner(oc)) = p;
      at(prev_corner(oc)) = q;
      // A development that rounding has carried out of reach or left without a direction is
      // broken (named below), not continued into overflow or NaN.
      if (!within_reach(p) || !within_reach(q) ||
          !turn_and_walk(g, p, q, theta[next_corner(oc)], l[t.corner_edge[prev_corner(oc)]], at(oc)) ||
          !within_reach(at(oc))) {
        broken[a] = 1;
        break;
      }
      face = corner_face(oc);
    }
    const Index last = paths.last_corner[a];
    if (broken[a] || corner_face(last) != face) {
      broken[a] = 1;
      continue;
    }
    r.l[a] = from_pole(g, at(last));
    const P3 a0 = lift(g, pole(g)), b = lift(g, at(last));
    for (Index k = paths.offsets[a]; k < paths.offsets[a + 1]; ++k) {
      const Index cc = paths.crossed_corner[k], e = t.corner_edge[cc];
      const double s = chord_crossing(a0, b, lift(g, ends[2 * static_cast<std::size_t>(k)]),
                                      lift(g, ends[2 * static_cast<std::size_t>(k) + 1]));
      r.crossings[static_cast<std::size_t>(k)] = t.edge_corners[2 * e] == cc ? s : 1 - s;
    }
  }
  for (Index a = 0; a < nin; ++a)
    if (broken[a] || !(r.l[a] > 0) || !std::isfinite(r.l[a])) {
      r.status = Status::NumericalFailure;
      r.message = "input edge " + std::to_string(a) + " (vertices " + std::to_string(input.edge_vertices[2 * a]) +
                  ", " + std::to_string(input.edge_vertices[2 * a + 1]) +
                  ") could not be developed along its path over the triangulation";
      return r;
    }

  // How the straight input triangles fit: their angle sums against the metric's cone angles.
  std::vector<double> theta_in(static_cast<std::size_t>(3 * input.num_faces));
  const AngleReport in_angles = corner_angles(input, g, r.l, theta_in);
  r.degenerate_faces = in_angles.violations;
  r.first_degenerate_face = in_angles.first_violation;
  std::vector<double> sum_t(static_cast<std::size_t>(t.num_vertices), 0.0), sum_in(sum_t.size(), 0.0);
  for (Index c = 0; c < 3 * t.num_faces; ++c) sum_t[t.corner_vertex[c]] += theta[c];
  for (Index c = 0; c < 3 * input.num_faces; ++c) sum_in[input.corner_vertex[c]] += theta_in[c];
  for (Index v = 0; v < t.num_vertices; ++v) {
    const double d = std::abs(sum_in[v] - sum_t[v]);
    if (!(d <= r.max_angle_sum_error)) {
      r.max_angle_sum_error = std::isfinite(d) ? d : INFINITY;
      r.worst_vertex = v;
    }
    if (!(d <= kStraightAngleSumTolerance)) ++r.inconsistent_vertices;
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

std::vector<double> straightest_crossings(const IntrinsicTriangulation& tri, const InputEdgePaths& paths,
                                          std::span<const double> straight, std::span<const double> ideal) {
  const Topology& t = tri.topology;
  const std::size_t n = paths.crossed_edge.size();
  if (straight.size() != n || ideal.size() != n) return std::vector<double>(ideal.begin(), ideal.end());
  // The crossings of every current edge, in slot order.
  std::vector<Index> offset(static_cast<std::size_t>(t.num_edges) + 1, 0), by_slot(n, kInvalid);
  for (std::size_t k = 0; k < n; ++k) ++offset[static_cast<std::size_t>(paths.crossed_edge[k]) + 1];
  for (Index e = 0; e < t.num_edges; ++e) offset[e + 1] += offset[e];
  for (std::size_t k = 0; k < n; ++k)
    by_slot[static_cast<std::size_t>(offset[paths.crossed_edge[k]] + paths.crossed_slot[k])] = static_cast<Index>(k);

  std::vector<double> out(ideal.begin(), ideal.end());
#pragma omp parallel for schedule(dynamic, 256) if (t.num_edges >= detail::kParallelMin)
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index begin = offset[e], end = offset[e + 1];
    if (begin == end) continue;
    // Every gap g(s) = (1 − s) g_straight + s g_ideal must reach kCrossingGapFraction · g_ideal: a
    // lower bound on s per gap (the gaps from 0 to the first crossing, between neighbours, and
    // from the last to 1).
    double s = 0;
    auto need = [&s](double g_straight, double g_ideal) {
      const double floor = kCrossingGapFraction * g_ideal;
      if (!(g_straight >= floor)) s = std::max(s, std::isfinite(g_straight) ? (floor - g_straight) / (g_ideal - g_straight) : 1.0);
    };
    double prev_straight = 0, prev_ideal = 0;
    for (Index j = begin; j <= end; ++j) {
      double x_straight = 1, x_ideal = 1;
      if (j < end) {
        const Index k = by_slot[static_cast<std::size_t>(j)];
        if (k == kInvalid) {
          s = 1;
          break;
        }
        x_straight = straight[static_cast<std::size_t>(k)];
        x_ideal = ideal[static_cast<std::size_t>(k)];
      }
      need(x_straight - prev_straight, x_ideal - prev_ideal);
      prev_straight = x_straight;
      prev_ideal = x_ideal;
    }
    s = std::min(s, 1.0);
    if (s == 1) continue;
    for (Index j = begin; j < end; ++j) {
      const std::size_t k = static_cast<std::size_t>(by_slot[static_cast<std::size_t>(j)]);
      out[k] = (1 - s) * straight[k] + s * ideal[k];
    }
  }
  return out;
}

}  // namespace ricci
