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
#include <cstdint>
#include <string>
#include <unordered_map>

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

std::uint64_t pair_key(Index a, Index b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

}  // namespace

CornerArcs corner_arcs(const IntrinsicTriangulation& tri, Index c) {
  const Index n = next_corner(c), p = prev_corner(c);
  const std::int64_t nc = positive_normal(tri, c), nn = positive_normal(tri, n), np = positive_normal(tri, p);
  const std::int64_t ec = std::max<std::int64_t>(0, nc - nn - np), en = std::max<std::int64_t>(0, nn - np - nc),
                     ep = std::max<std::int64_t>(0, np - nc - nn);
  return {ec, (nn + np - nc + ec - en - ep) / 2};
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
  // Crossing slots of every current edge, to mark the ones walked.
  std::vector<std::int64_t> slot_offset(static_cast<std::size_t>(ne) + 1, 0);
  for (Index e = 0; e < ne; ++e) slot_offset[e + 1] = slot_offset[e] + std::max<std::int64_t>(0, tri.normal[e]);
  std::vector<std::uint8_t> walked(static_cast<std::size_t>(slot_offset[ne]), 0);

  std::unordered_map<std::uint64_t, Index> input_edge;
  input_edge.reserve(static_cast<std::size_t>(nin));
  for (Index a = 0; a < nin; ++a)
    input_edge.emplace(pair_key(input.edge_vertices[2 * a], input.edge_vertices[2 * a + 1]), a);

  struct Strand {
    Index first_corner = kInvalid, last_corner = kInvalid;
    std::vector<Index> edges, slots;
  };
  std::vector<Strand> strands(static_cast<std::size_t>(nin));
  std::vector<std::uint8_t> found(static_cast<std::size_t>(nin), 0);
  r.along.assign(static_cast<std::size_t>(nin), kInvalid);
  auto fail = [&r](std::string why) {
    r.status = Status::NumericalFailure;
    r.message = "the normal coordinates are not those of the input's edges: " + std::move(why);
    return r;
  };
  // The input edge joining va and vb, marked found; kInvalid when there is none or it was found.
  auto claim = [&](Index va, Index vb) -> Index {
    const auto it = input_edge.find(pair_key(va, vb));
    if (it == input_edge.end() || found[it->second]) return kInvalid;
    found[it->second] = 1;
    return it->second;
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
    strands[a].first_corner = same ? next_corner(c) : prev_corner(c);
    strands[a].last_corner = same ? prev_corner(c) : next_corner(c);
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
      Strand strand;
      strand.first_corner = x;
      for (std::int64_t step = 0;; ++step) {
        if (step > total_slots) return fail("a walk from corner " + std::to_string(x) + " does not end");
        walked[slot_offset[e] + slot] = 1;
        strand.edges.push_back(e);
        strand.slots.push_back(slot);
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
          strand.last_corner = y;
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
      const Index va = t.corner_vertex[strand.first_corner], vb = t.corner_vertex[strand.last_corner];
      const Index a = claim(va, vb);
      if (a == kInvalid)
        return fail("a strand joins vertices " + std::to_string(va) + " and " + std::to_string(vb) +
                    ", which no input edge (not yet found) joins");
      if (input.edge_vertices[2 * a] != va) {
        std::reverse(strand.edges.begin(), strand.edges.end());
        std::reverse(strand.slots.begin(), strand.slots.end());
        std::swap(strand.first_corner, strand.last_corner);
      }
      strands[a] = std::move(strand);
    }
  }
  for (Index a = 0; a < nin; ++a)
    if (!found[a]) return fail("input edge " + std::to_string(a) + " was not found");
  for (std::int64_t k = 0; k < total_slots; ++k)
    if (!walked[k]) return fail("a crossing is on no walk from a vertex");

  r.offsets.assign(static_cast<std::size_t>(nin) + 1, 0);
  for (Index a = 0; a < nin; ++a) r.offsets[a + 1] = r.offsets[a] + static_cast<Index>(strands[a].edges.size());
  r.crossed_edge.reserve(static_cast<std::size_t>(r.offsets[nin]));
  r.crossed_slot.reserve(static_cast<std::size_t>(r.offsets[nin]));
  r.first_corner.resize(static_cast<std::size_t>(nin));
  r.last_corner.resize(static_cast<std::size_t>(nin));
  for (Index a = 0; a < nin; ++a) {
    r.crossed_edge.insert(r.crossed_edge.end(), strands[a].edges.begin(), strands[a].edges.end());
    r.crossed_slot.insert(r.crossed_slot.end(), strands[a].slots.begin(), strands[a].slots.end());
    r.first_corner[a] = strands[a].first_corner;
    r.last_corner[a] = strands[a].last_corner;
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

}  // namespace ricci
