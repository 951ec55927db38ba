// Tracing the input edges over a flipped intrinsic triangulation from its normal coordinates (see
// ricci/intrinsic_trace.h for the arcs and their order along a side).
//
// Every input edge that is not a current edge crosses at least one current edge, and its first arc
// leaves a vertex: it is one of the E_x arcs of some corner x. Walking from each such arc through
// the faces — entering a face across a side at a known position, the position says whether the arc
// turns at one end of that side (and at which position it meets the next side) or ends at the
// opposite vertex — visits the crossings of one input edge; each is walked once, from the end whose
// first crossing comes first in (face, corner, arc) order, and named by its two end vertices.
#include "ricci/intrinsic_trace.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

namespace ricci {

namespace {

std::int64_t positive_normal(const IntrinsicTriangulation& tri, Index c) {
  return std::max<std::int64_t>(0, tri.normal[tri.topology.corner_edge[c]]);
}

// The position on the edge opposite corner c of a crossing at face-local position p (counted from
// vertex(next(c)), the side's start in c's face) in the edge's own order (from edge_vertices[2e]),
// and back: the two orders agree for the edge's first corner and are reversed for its second.
Index to_edge_slot(const Topology& t, Index c, Index p, Index count) {
  return t.edge_corners[2 * t.corner_edge[c]] == c ? p : count - 1 - p;
}

// The paths of an unflipped triangulation's input edges (is_input_triangulation()): every input
// edge is the current edge of its own index (the walks of trace_input_edges() would find exactly
// this, edge by edge).
InputEdgePaths paths_as_themselves(const IntrinsicTriangulation& tri, const Topology& input) {
  InputEdgePaths r;
  const Topology& t = tri.topology;
  const Index nin = input.num_edges;
  r.offsets.assign(static_cast<std::size_t>(nin) + 1, 0);
  r.along.resize(static_cast<std::size_t>(nin));
  r.first_corner.resize(static_cast<std::size_t>(nin));
  r.last_corner.resize(static_cast<std::size_t>(nin));
#pragma omp parallel for schedule(static) if (nin >= 8192)
  for (Index a = 0; a < nin; ++a) {
    const Index c = t.edge_corners[2 * a];
    const bool same = input.edge_vertices[2 * a] == t.corner_vertex[next_corner(c)];
    r.along[a] = a;
    r.first_corner[a] = same ? next_corner(c) : prev_corner(c);
    r.last_corner[a] = same ? prev_corner(c) : next_corner(c);
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

}  // namespace

CornerArcs corner_arcs(const IntrinsicTriangulation& tri, Index c) {
  const Index n = next_corner(c), p = prev_corner(c);
  const std::int64_t nc = positive_normal(tri, c), nn = positive_normal(tri, n), np = positive_normal(tri, p);
  const std::int64_t ec = std::max<std::int64_t>(0, nc - nn - np), en = std::max<std::int64_t>(0, nn - np - nc),
                     ep = std::max<std::int64_t>(0, np - nc - nn);
  return {ec, (nn + np - nc + ec - en - ep) / 2};
}

bool is_input_triangulation(const IntrinsicTriangulation& tri, const Topology& input) {
  const Topology& t = tri.topology;
  return t.num_vertices == input.num_vertices && t.num_edges == input.num_edges &&
         tri.normal.size() == static_cast<std::size_t>(t.num_edges) && t.corner_vertex == input.corner_vertex &&
         t.corner_edge == input.corner_edge &&
         std::all_of(tri.normal.begin(), tri.normal.end(), [](std::int64_t n) { return n == -1; });
}

InputEdgePaths trace_input_edges(const IntrinsicTriangulation& tri, const Topology& input) {
  InputEdgePaths r;
  const Topology& t = tri.topology;
  const Index ne = t.num_edges, nin = input.num_edges;
  if (tri.normal.size() != static_cast<std::size_t>(ne) || t.num_vertices != input.num_vertices) {
    r.status = Status::InvalidArgument;
    r.message = tri.normal.size() != static_cast<std::size_t>(ne)
                    ? "the intrinsic triangulation keeps no normal coordinates"
                    : "the intrinsic triangulation has " + std::to_string(t.num_vertices) +
                          " vertices, the input " + std::to_string(input.num_vertices);
    return r;
  }
  if (is_input_triangulation(tri, input)) return paths_as_themselves(tri, input);
  // Crossing slots of every current edge, to mark the ones walked.
  std::vector<std::int64_t> slot_offset(static_cast<std::size_t>(ne) + 1, 0);
  for (Index e = 0; e < ne; ++e) slot_offset[e + 1] = slot_offset[e] + std::max<std::int64_t>(0, tri.normal[e]);
  std::vector<std::uint8_t> walked(static_cast<std::size_t>(slot_offset[ne]), 0);

  // Per input edge, the walked strand that follows it (kInvalid: none, it is a current edge); the
  // strands' crossings are kept one after the other in `walk`, each in the input edge's direction.
  std::vector<Index> strand_of(static_cast<std::size_t>(nin), kInvalid);
  std::vector<std::int64_t> strand_begin{0};
  std::vector<Index> walk_edges, walk_slots, walk_corners;
  std::vector<std::uint8_t> found(static_cast<std::size_t>(nin), 0);
  r.along.assign(static_cast<std::size_t>(nin), kInvalid);
  r.first_corner.assign(static_cast<std::size_t>(nin), kInvalid);
  r.last_corner.assign(static_cast<std::size_t>(nin), kInvalid);
  auto fail = [&r](std::string why) {
    r.status = Status::NumericalFailure;
    r.message = "the normal coordinates are not those of the input's edges: " + std::move(why);
    return r;
  };
  // The input edge joining va and vb (looked up in va's fan), marked found; kInvalid when there is
  // none or it was found.
  auto claim = [&](Index va, Index vb) -> Index {
    const Index a = input.edge_between(va, vb);
    if (a == kInvalid || found[a]) return kInvalid;
    found[a] = 1;
    return a;
  };

  // Input edges that are current edges.
  for (Index e = 0; e < ne; ++e) {
    if (tri.normal[e] != -1) continue;
    const Index va = t.edge_vertices[2 * e], vb = t.edge_vertices[2 * e + 1];
    const Index a = claim(va, vb);
    if (a == kInvalid)
      return fail("current edge " + std::to_string(e) + " (vertices " + std::to_string(va) + ", " +
                  std::to_string(vb) + ") is marked as an input edge, but it is not one or is one twice");
    r.along[a] = e;
    const Index c = t.edge_corners[2 * e];
    const bool same = input.edge_vertices[2 * a] == t.corner_vertex[next_corner(c)];
    r.first_corner[a] = same ? next_corner(c) : prev_corner(c);
    r.last_corner[a] = same ? prev_corner(c) : next_corner(c);
  }

  // Walks from every arc that leaves a vertex.
  const std::int64_t total_slots = slot_offset[ne];
  for (Index x = 0; x < t.num_corners(); ++x) {
    const CornerArcs from = corner_arcs(tri, x);
    if (from.from_vertex == 0) continue;
    const Index before = static_cast<Index>(corner_arcs(tri, next_corner(x)).around);
    for (std::int64_t s = 0; s < from.from_vertex; ++s) {
      Index exit = x;  // the corner opposite the side being crossed, in the face being left
      Index e = t.corner_edge[x];
      Index slot = to_edge_slot(t, x, before + static_cast<Index>(s), static_cast<Index>(tri.normal[e]));
      if (walked[slot_offset[e] + slot]) continue;
      Index first = x, last = kInvalid;
      for (std::int64_t step = 0;; ++step) {
        if (step > total_slots) return fail("a walk from corner " + std::to_string(x) + " does not end");
        walked[slot_offset[e] + slot] = 1;
        walk_edges.push_back(e);
        walk_slots.push_back(slot);
        walk_corners.push_back(exit);
        const Index y = t.opposite[exit];
        if (y == kInvalid) return fail("a walk from corner " + std::to_string(x) + " leaves the surface");
        const Index count = static_cast<Index>(tri.normal[e]);
        const Index p = to_edge_slot(t, y, slot, count);  // face-local from vertex(next(y))
        const Index turn_a = static_cast<Index>(corner_arcs(tri, next_corner(y)).around);
        const Index ends = static_cast<Index>(corner_arcs(tri, y).from_vertex);
        if (p < turn_a) {
          exit = prev_corner(y);  // turns around vertex(next(y)) into the side opposite prev(y)
          const Index len = static_cast<Index>(positive_normal(tri, exit));
          e = t.corner_edge[exit];
          slot = to_edge_slot(t, exit, len - 1 - p, len);
        } else if (p < turn_a + ends) {
          last = y;
          break;
        } else {
          exit = next_corner(y);  // turns around vertex(prev(y)) into the side opposite next(y)
          const Index len = static_cast<Index>(positive_normal(tri, exit));
          e = t.corner_edge[exit];
          slot = to_edge_slot(t, exit, count - 1 - p, len);
        }
        if (slot < 0 || slot >= static_cast<Index>(positive_normal(tri, exit)))
          return fail("a walk from corner " + std::to_string(x) + " reaches a side without room for it");
      }
      const Index va = t.corner_vertex[first], vb = t.corner_vertex[last];
      const Index a = claim(va, vb);
      if (a == kInvalid)
        return fail("a strand joins vertices " + std::to_string(va) + " and " + std::to_string(vb) +
                    ", which no input edge (not yet found) joins");
      const std::int64_t begin = strand_begin.back();
      if (input.edge_vertices[2 * a] != va) {
        // Walked from the other end: the same crossings backwards, each left from the other side.
        std::reverse(walk_edges.begin() + begin, walk_edges.end());
        std::reverse(walk_slots.begin() + begin, walk_slots.end());
        std::reverse(walk_corners.begin() + begin, walk_corners.end());
        for (auto it = walk_corners.begin() + begin; it != walk_corners.end(); ++it) *it = t.opposite[*it];
        std::swap(first, last);
      }
      strand_of[a] = static_cast<Index>(strand_begin.size()) - 1;
      strand_begin.push_back(static_cast<std::int64_t>(walk_edges.size()));
      r.first_corner[a] = first;
      r.last_corner[a] = last;
    }
  }
  for (Index a = 0; a < nin; ++a)
    if (!found[a]) return fail("input edge " + std::to_string(a) + " was not found");
  for (std::int64_t k = 0; k < total_slots; ++k)
    if (!walked[k]) return fail("a crossing is on no walk from a vertex");

  // The strands in input-edge order.
  r.offsets.assign(static_cast<std::size_t>(nin) + 1, 0);
  for (Index a = 0; a < nin; ++a) {
    const Index k = strand_of[a];
    r.offsets[a + 1] = r.offsets[a] + (k == kInvalid ? 0 : static_cast<Index>(strand_begin[k + 1] - strand_begin[k]));
  }
  r.crossed_edge.resize(walk_edges.size());
  r.crossed_slot.resize(walk_edges.size());
  r.crossed_corner.resize(walk_edges.size());
  for (Index a = 0; a < nin; ++a) {
    const Index k = strand_of[a];
    if (k == kInvalid) continue;
    const std::int64_t b = strand_begin[k], n = strand_begin[k + 1] - b;
    std::copy_n(walk_edges.begin() + b, n, r.crossed_edge.begin() + r.offsets[a]);
    std::copy_n(walk_slots.begin() + b, n, r.crossed_slot.begin() + r.offsets[a]);
    std::copy_n(walk_corners.begin() + b, n, r.crossed_corner.begin() + r.offsets[a]);
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

}  // namespace ricci

namespace ricci {

std::vector<double> input_edge_crossings(const IntrinsicTriangulation& tri, std::span<const double> u,
                                         const InputEdgePaths& paths) {
  const Topology& t = tri.topology;
  const Index nin = static_cast<Index>(paths.offsets.size()) - 1;
  std::vector<double> fraction(paths.crossed_edge.size(), 0.0);
  // log λ of a current edge at u.
  auto log_lambda = [&](Index e) {
    return tri.log_chord_of(e) + 0.5 * (u[t.edge_vertices[2 * e]] + u[t.edge_vertices[2 * e + 1]]);
  };
#pragma omp parallel if (nin >= 1024)
  {
    // Per crossing of one input edge: log √(diameter) of the horocycles at the crossed edge's ends p,
    // q (p = vertex(next(corner)), in the edge's interval renormalised to [0, 1]), and the affine map
    // t_k = α_k + β_k t_{k+1} from the next interval into this one.
    std::vector<double> rho_p, rho_q, alpha, beta;
#pragma omp for schedule(dynamic, 64)
    for (Index a = 0; a < nin; ++a) {
      const Index begin = paths.offsets[a], end = paths.offsets[a + 1], m = end - begin;
      if (m == 0) continue;
      rho_p.resize(static_cast<std::size_t>(m));
      rho_q.resize(static_cast<std::size_t>(m));
      alpha.resize(static_cast<std::size_t>(m));
      beta.resize(static_cast<std::size_t>(m));
      // The first face: its corner at the input edge's start is at ∞ (horocycle height 1), the
      // crossed side is the interval [p, q] scaled to [0, 1].
      const Index x = paths.first_corner[a];
      {
        const double l_ap = log_lambda(t.corner_edge[prev_corner(x)]), l_aq = log_lambda(t.corner_edge[next_corner(x)]);
        const double l_pq = log_lambda(t.corner_edge[x]);
        rho_p[0] = 0.5 * (l_aq - l_ap - l_pq);
        rho_q[0] = 0.5 * (l_ap - l_aq - l_pq);
      }
      double last = 0;  // t of the input edge's end in the last interval
      for (Index k = 0; k < m; ++k) {
        // Across the side into the face of y: its apex r lies under the side's semicircle.
        const Index y = t.opposite[paths.crossed_corner[begin + k]];
        const double l_pr = log_lambda(t.corner_edge[next_corner(y)]), l_qr = log_lambda(t.corner_edge[prev_corner(y)]);
        const double sp = l_pr + rho_p[k], sq = l_qr + rho_q[k];
        const double top = std::max(sp, sq);
        const double rho_r = -(top + std::log(std::exp(sp - top) + std::exp(sq - top)));
        // x_r + rest = 1; floored at 1e-300 so that no log below meets 0 (no such face is resolved in
        // double precision anyway).
        const double x_r = std::max(1e-300, std::exp(sp + rho_r)), rest = std::max(1e-300, std::exp(sq + rho_r));
        if (k + 1 == m) {
          last = x_r;
          break;
        }
        if (paths.crossed_corner[begin + k + 1] == next_corner(y)) {  // on to side p r: [0, x_r]
          alpha[k] = 0;
          beta[k] = x_r;
          rho_p[k + 1] = rho_p[k] - 0.5 * std::log(x_r);
          rho_q[k + 1] = rho_r - 0.5 * std::log(x_r);
        } else {  // on to side r q: [x_r, 1]
          alpha[k] = x_r;
          beta[k] = rest;
          rho_p[k + 1] = rho_r - 0.5 * std::log(rest);
          rho_q[k + 1] = rho_q[k] - 0.5 * std::log(rest);
        }
      }
      // Back from the end: the vertical line's place in each interval, then the point on the
      // semicircle measured from the horocycles' halfway point: t' = t D_q / (t D_q + (1 − t) D_p).
      double tk = last;
      for (Index k = m - 1; k >= 0; --k) {
        if (k + 1 < m) tk = alpha[k] + beta[k] * tk;
        const double ratio = std::exp(std::clamp(2 * (rho_q[k] - rho_p[k]), -700.0, 700.0));
        const double chord = tk * ratio / (tk * ratio + (1 - tk));
        const Index c = paths.crossed_corner[begin + k], e = t.corner_edge[c];
        fraction[static_cast<std::size_t>(begin + k)] = t.edge_corners[2 * e] == c ? chord : 1 - chord;
      }
    }
  }
  return fraction;
}

}  // namespace ricci
