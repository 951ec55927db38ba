// The common subdivision of the input triangulation and a flipped intrinsic triangulation (see
// ricci/intrinsic_trace.h, common_subdivision()).
//
// Takes: the triangulation at u, the input, the traced input edges and their crossings. Gives: a
// triangle mesh whose faces each lie in one current face and one input face, with its lengths.
//
// Per current face: the face is laid out in its model triangle (model_geometry.h); the points on
// its boundary — its three corners and the crossings on its sides — form a cycle in
// counter-clockwise order, and the input edges' pieces inside it are chords between points of
// that cycle (pairwise disjoint: input edges do not cross). The chords cut the face into convex
// pieces, found by walking: from a step i → j (a side step i → i+1, or a chord), the next point is
// the neighbour k of j (j + 1 along the side, or a chord partner) that comes last before i going
// counter-clockwise around the cycle, i.e. the one with the smallest positive (i − k) mod n. A piece
// lies to the left of every step; a step along an input edge (a chord, or a side that is one)
// names the input face there. Pieces are fanned from their first point.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "model_geometry.h"
#include "ricci/intrinsic_trace.h"

namespace ricci {

using namespace model;

namespace {

struct Chord {
  Index from = 0, to = 0;  // cycle positions
  Index input_edge = kInvalid;
  bool forward = true;     // from → to runs along the input edge's orientation
};

}  // namespace

CommonSubdivision common_subdivision(const IntrinsicTriangulation& tri, std::span<const double> u,
                                     const Mesh& input_mesh, const Topology& input, const InputEdgePaths& paths,
                                     std::span<const double> crossings) {
  CommonSubdivision r;
  const Topology& t = tri.topology;
  const Geometry g = tri.geometry;
  const Index nv = t.num_vertices, nin = input.num_edges;
  auto fail = [&r](Status s, std::string m) {
    r.status = s;
    r.message = std::move(m);
    return r;
  };
  if (paths.status != Status::Ok || paths.along.size() != static_cast<std::size_t>(nin) ||
      crossings.size() != paths.crossed_edge.size() || u.size() != static_cast<std::size_t>(nv) ||
      input.num_vertices != nv || input_mesh.num_vertices() != nv || tri.normal.size() != static_cast<std::size_t>(t.num_edges))
    return fail(Status::InvalidArgument, "the traced paths, crossings, u or the input do not match the triangulation");
  const Index ncross = static_cast<Index>(crossings.size());

  ConformalStructure structure;
  vertex_scaling_structure(tri, structure);
  std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(static_cast<std::size_t>(3 * t.num_faces));
  const Index bad_edge = edge_lengths(t, structure, u, l);
  const AngleReport angles = corner_angles(t, g, l, theta);
  if (bad_edge != kInvalid || angles.violations > 0)
    return fail(Status::TriangleInequality, "the metric at u has a face without valid angles");

  // Crossing k by (current edge, slot); input edge of every current edge that is one.
  std::vector<Index> slot_offset(static_cast<std::size_t>(t.num_edges) + 1, 0);
  for (Index e = 0; e < t.num_edges; ++e) slot_offset[e + 1] = slot_offset[e] + std::max<Index>(0, static_cast<Index>(tri.normal[e]));
  if (slot_offset[t.num_edges] != ncross) return fail(Status::InvalidArgument, "the crossings do not match the normal coordinates");
  std::vector<Index> crossing_at(static_cast<std::size_t>(ncross), kInvalid);
  for (Index k = 0; k < ncross; ++k) crossing_at[slot_offset[paths.crossed_edge[k]] + paths.crossed_slot[k]] = k;
  std::vector<Index> input_of(static_cast<std::size_t>(t.num_edges), kInvalid);
  for (Index a = 0; a < nin; ++a)
    if (paths.along[a] != kInvalid) input_of[paths.along[a]] = a;

  // Vertices: the input's, then the crossings, each on its input edge's 3D segment at the fraction
  // of the edge's length in the metric (the sum of its pieces' lengths, filled in below).
  r.vertex_input_edge.assign(static_cast<std::size_t>(nv + ncross), kInvalid);
  for (Index a = 0; a < nin; ++a)
    for (Index k = paths.offsets[a]; k < paths.offsets[a + 1]; ++k) r.vertex_input_edge[nv + k] = a;
  std::vector<double> piece_length(static_cast<std::size_t>(ncross) + static_cast<std::size_t>(nin), 0.0);
  // piece_length[k]: length of input edge a's piece ending at crossing k; [ncross + a]: its last piece.

  // Chords per face (cycle positions are resolved per face below).
  struct RawChord {
    Index face;
    Index from_corner, from_cross;  // a corner of the face (vertex end) or kInvalid and a crossing
    Index to_corner, to_cross;
    Index input_edge;
    Index piece;                     // index into piece_length
  };
  std::vector<RawChord> raw;
  raw.reserve(static_cast<std::size_t>(ncross + nin));
  for (Index a = 0; a < nin; ++a) {
    if (paths.along[a] != kInvalid) continue;
    const Index k0 = paths.offsets[a], k1 = paths.offsets[a + 1];
    raw.push_back({corner_face(paths.first_corner[a]), paths.first_corner[a], kInvalid, kInvalid, k0, a, k0});
    for (Index k = k0; k + 1 < k1; ++k)
      raw.push_back({corner_face(paths.crossed_corner[k + 1]), kInvalid, k, kInvalid, k + 1, a, k + 1});
    raw.push_back({corner_face(paths.last_corner[a]), kInvalid, k1 - 1, paths.last_corner[a], kInvalid, a, ncross + a});
  }
  std::vector<Index> face_chord_offset(static_cast<std::size_t>(t.num_faces) + 1, 0);
  for (const RawChord& c : raw) ++face_chord_offset[c.face + 1];
  for (Index f = 0; f < t.num_faces; ++f) face_chord_offset[f + 1] += face_chord_offset[f];
  std::vector<Index> face_chords(raw.size()), fill(face_chord_offset.begin(), face_chord_offset.end() - 1);
  for (Index i = 0; i < static_cast<Index>(raw.size()); ++i) face_chords[fill[raw[i].face]++] = i;

  std::vector<Index> faces, face_input;
  std::vector<double> face_sides;  // per output face: lengths opposite its corners
  std::vector<Index> cycle_id;
  std::vector<P3> cycle_pos;
  std::vector<Chord> chords;
  std::vector<std::vector<std::pair<Index, Index>>> partners;  // per cycle position: (partner, chord)
  std::vector<std::uint8_t> used_side;
  std::vector<std::vector<std::uint8_t>> used_chord;
  for (Index f = 0; f < t.num_faces; ++f) {
    const Index c0 = 3 * f;
    P3 pos[3];
    pos[0] = pole(g);
    pos[1] = polar(g, l[t.corner_edge[c0 + 2]], 0);
    // Corner 0's angle as the layout's frames take it (FaceFrames: the same function of the same
    // lengths, so the pieces' points sit exactly where the frames put the face's corners).
    pos[2] = polar(g, l[t.corner_edge[c0 + 1]],
                   detail::angle_from_lengths(g, l[t.corner_edge[c0]], l[t.corner_edge[c0 + 1]], l[t.corner_edge[c0 + 2]]));
    for (Index k = 0; k < 3; ++k) r.frames.frame_lengths.push_back(l[t.corner_edge[c0 + k]]);
    // The cycle: corner x, then the crossings on the side from x to next(x) (opposite prev(x)).
    cycle_id.clear();
    cycle_pos.clear();
    Index start[3];
    for (Index k = 0; k < 3; ++k) {
      const Index x = c0 + k, p = prev_corner(x);
      start[k] = static_cast<Index>(cycle_id.size());
      cycle_id.push_back(t.corner_vertex[x]);
      cycle_pos.push_back(pos[k]);
      const Index e = t.corner_edge[p];
      const Index count = std::max<Index>(0, static_cast<Index>(tri.normal[e]));
      const bool along_e = t.edge_corners[2 * e] == p;  // the edge runs from vertex(x) here
      const P3& e0 = along_e ? pos[k] : pos[corner_slot(next_corner(x))];
      const P3& e1 = along_e ? pos[corner_slot(next_corner(x))] : pos[k];
      for (Index i = 0; i < count; ++i) {
        const Index slot = along_e ? i : count - 1 - i;
        const Index kc = crossing_at[slot_offset[e] + slot];
        cycle_id.push_back(nv + kc);
        cycle_pos.push_back(on_chord(g, e0, e1, crossings[kc]));
      }
    }
    const Index n = static_cast<Index>(cycle_id.size());
    // Cycle position of a chord end: a corner of this face, or crossing kc seen from this face.
    auto position_of = [&](Index corner, Index kc) -> Index {
      if (corner != kInvalid) return start[corner_slot(corner)];
      const Index e = paths.crossed_edge[kc];
      // The corner of this face opposite e on the side the crossing is on.
      Index p = kInvalid;
      for (Index k = 0; k < 3; ++k)
        if (t.corner_edge[c0 + k] == e) {
          const Index x = next_corner(c0 + k);
          const Index count = static_cast<Index>(tri.normal[e]);
          const bool along_e = t.edge_corners[2 * e] == c0 + k;
          const Index i = along_e ? paths.crossed_slot[kc] : count - 1 - paths.crossed_slot[kc];
          const Index q = start[corner_slot(x)] + 1 + i;
          if (cycle_id[q] == nv + kc) p = q;
        }
      return p;
    };
    chords.clear();
    partners.assign(static_cast<std::size_t>(n), {});
    for (Index i = face_chord_offset[f]; i < face_chord_offset[f + 1]; ++i) {
      const RawChord& rc = raw[face_chords[i]];
      const Index from = position_of(rc.from_corner, rc.from_cross), to = position_of(rc.to_corner, rc.to_cross);
      if (from == kInvalid || to == kInvalid || from == to)
        return fail(Status::NumericalFailure, "input edge " + std::to_string(rc.input_edge) +
                                                  " has a piece in current face " + std::to_string(f) +
                                                  " that does not join two points of its boundary");
      piece_length[rc.piece] = distance(g, cycle_pos[from], cycle_pos[to]);
      partners[from].push_back({to, static_cast<Index>(chords.size())});
      partners[to].push_back({from, static_cast<Index>(chords.size())});
      chords.push_back({from, to, rc.input_edge, true});
    }
    // The input face left of a step, from a chord or from a side that is an input edge.
    auto side_input_face = [&](Index i) -> Index {  // side step i → i+1
      if (cycle_id[i] >= nv || cycle_id[(i + 1) % n] >= nv) return kInvalid;
      Index k = 0;
      while (k < 3 && start[k] != i) ++k;
      if (k == 3) return kInvalid;
      const Index a = input_of[t.corner_edge[prev_corner(c0 + k)]];
      if (a == kInvalid) return kInvalid;
      const bool fwd = input.edge_vertices[2 * a] == cycle_id[i];
      const Index c = input.edge_corners[2 * a + (fwd ? 0 : 1)];
      return c == kInvalid ? kInvalid : corner_face(c);
    };
    auto chord_input_face = [&](Index ci, Index from) -> Index {
      const Chord& ch = chords[ci];
      const bool fwd = (from == ch.from) == ch.forward;
      const Index c = input.edge_corners[2 * ch.input_edge + (fwd ? 0 : 1)];
      return c == kInvalid ? kInvalid : corner_face(c);
    };
    used_side.assign(static_cast<std::size_t>(n), 0);
    used_chord.assign(chords.size(), std::vector<std::uint8_t>(2, 0));
    std::vector<Index> piece;
    auto walk = [&](Index i, Index j, Index first_face) -> bool {
      piece.assign({i});
      Index tag = first_face, prev = i, cur = j;
      for (Index guard = 0; cur != i; ++guard) {
        if (guard > n) return false;
        piece.push_back(cur);
        // Candidates at cur: the side step cur → cur+1, and its chords.
        auto key = [&](Index k) { return ((prev - k) % n + n) % n; };
        Index best = kInvalid, best_chord = kInvalid;
        if (key((cur + 1) % n) > 0) best = (cur + 1) % n;
        for (const auto& [k, ci] : partners[cur])
          if (key(k) > 0 && (best == kInvalid || key(k) < key(best))) {
            best = k;
            best_chord = ci;
          }
        if (best == kInvalid) return false;
        if (best_chord == kInvalid) {
          used_side[cur] = 1;
          if (tag == kInvalid) tag = side_input_face(cur);
        } else {
          used_chord[best_chord][chords[best_chord].from == cur ? 0 : 1] = 1;
          if (tag == kInvalid) tag = chord_input_face(best_chord, cur);
        }
        prev = cur;
        cur = best;
      }
      if (tag == kInvalid) return false;
      for (std::size_t m = 1; m + 1 < piece.size(); ++m) {
        const Index a = piece[0], b = piece[m], c = piece[m + 1];
        faces.insert(faces.end(), {cycle_id[a], cycle_id[b], cycle_id[c]});
        r.frames.face_frame.push_back(f);
        for (const Index q : {a, b, c}) r.frames.corner_model.insert(r.frames.corner_model.end(), cycle_pos[q].begin(), cycle_pos[q].end());
        face_sides.insert(face_sides.end(), {distance(g, cycle_pos[b], cycle_pos[c]),
                                             distance(g, cycle_pos[c], cycle_pos[a]),
                                             distance(g, cycle_pos[a], cycle_pos[b])});
        face_input.push_back(tag);
      }
      return true;
    };
    for (Index i = 0; i < n; ++i)
      if (!used_side[i]) {
        used_side[i] = 1;
        if (!walk(i, (i + 1) % n, side_input_face(i)))
          return fail(Status::NumericalFailure, "current face " + std::to_string(f) +
                                                    " has a piece that lies in no input face");
      }
    for (Index ci = 0; ci < static_cast<Index>(chords.size()); ++ci)
      for (int side = 0; side < 2; ++side)
        if (!used_chord[ci][side]) {
          used_chord[ci][side] = 1;
          const Index from = side == 0 ? chords[ci].from : chords[ci].to, to = side == 0 ? chords[ci].to : chords[ci].from;
          if (!walk(from, to, chord_input_face(ci, from)))
            return fail(Status::NumericalFailure, "current face " + std::to_string(f) +
                                                      " has a piece that lies in no input face");
        }
  }

  // 3D positions: input vertices as they are; crossings along their input edge's segment.
  r.mesh.positions.resize(static_cast<std::size_t>(3 * (nv + ncross)));
  std::copy(input_mesh.positions.begin(), input_mesh.positions.begin() + 3 * nv, r.mesh.positions.begin());
  for (Index a = 0; a < nin; ++a) {
    const Index k0 = paths.offsets[a], k1 = paths.offsets[a + 1];
    if (k0 == k1) continue;
    double total = piece_length[ncross + a];
    for (Index k = k0; k < k1; ++k) total += piece_length[k];
    const Index va = input.edge_vertices[2 * a], vb = input.edge_vertices[2 * a + 1];
    double run = 0;
    for (Index k = k0; k < k1; ++k) {
      run += piece_length[k];
      const double s = total > 0 ? run / total : double(k - k0 + 1) / double(k1 - k0 + 1);
      for (int d = 0; d < 3; ++d)
        r.mesh.positions[3 * (nv + k) + d] =
            (1 - s) * input_mesh.positions[3 * va + d] + s * input_mesh.positions[3 * vb + d];
    }
  }
  r.mesh.faces = std::move(faces);
  TopologyResult tr = build_topology(r.mesh.faces, nv + ncross);
  if (tr.status != Status::Ok)
    return fail(Status::NumericalFailure, "the common subdivision is not a manifold triangulation: " + tr.message);
  r.topology = std::move(tr.topology);
  r.l.assign(static_cast<std::size_t>(r.topology.num_edges), 0.0);
  for (Index c = 0; c < r.topology.num_corners(); ++c) {
    const Index e = r.topology.corner_edge[c];
    if (r.topology.edge_corners[2 * e] == c) r.l[e] = face_sides[c];
  }
  r.face_input = std::move(face_input);
  r.frames.frame_opposite = t.opposite;
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

}  // namespace ricci
