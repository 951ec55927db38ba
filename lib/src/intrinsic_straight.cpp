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

  r.l.assign(static_cast<std::size_t>(nin), 0.0);
  std::vector<std::uint8_t> broken(static_cast<std::size_t>(nin), 0);
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
      at(next_corner(oc)) = p;
      at(prev_corner(oc)) = q;
      at(oc) = turn_and_walk(g, p, q, theta[next_corner(oc)], l[t.corner_edge[prev_corner(oc)]]);
      face = corner_face(oc);
    }
    const Index last = paths.last_corner[a];
    if (broken[a] || corner_face(last) != face) {
      broken[a] = 1;
      continue;
    }
    r.l[a] = from_pole(g, at(last));
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

}  // namespace ricci
