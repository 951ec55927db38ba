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
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <utility>
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

/// common_subdivision(), one method per step: the inputs checked and the metric measured, the
/// crossings indexed by (current edge, slot), the input edges' pieces gathered per current face,
/// then each current face cut (its boundary cycle, its chords, the walk round its pieces), and
/// finally the 3D positions and the subdivision's topology and lengths. Each step returns false
/// after fail() has recorded why.
class Subdivider {
 public:
  Subdivider(const IntrinsicTriangulation& tri, std::span<const double> u, const Mesh& input_mesh,
             const Topology& input, const InputEdgePaths& paths, std::span<const double> crossings)
      : tri_(tri), t_(tri.topology), g_(tri.geometry), u_(u), input_mesh_(input_mesh), input_(input), paths_(paths),
        crossings_(crossings), nv_(t_.num_vertices), nin_(input.num_edges) {}

  CommonSubdivision run() {
    if (!check_and_measure() || !index_crossings()) return std::move(r_);
    gather_pieces();
    for (Index f = 0; f < t_.num_faces; ++f)
      if (!cut_face(f)) return std::move(r_);
    finish();
    return std::move(r_);
  }

 private:
  // The pieces of input edges inside one current face, before their cycle positions are known.
  struct RawChord {
    Index face;
    Index from_corner, from_cross;  // a corner of the face (vertex end) or kInvalid and a crossing
    Index to_corner, to_cross;
    Index input_edge;
    Index piece;  // index into piece_length_
  };

  const IntrinsicTriangulation& tri_;
  const Topology& t_;
  const Geometry g_;
  std::span<const double> u_;
  const Mesh& input_mesh_;
  const Topology& input_;
  const InputEdgePaths& paths_;
  std::span<const double> crossings_;
  const Index nv_, nin_;
  Index ncross_ = 0;
  CommonSubdivision r_;
  std::vector<double> l_;                      // #E(current): lengths at u
  std::vector<Index> slot_offset_, crossing_at_, input_of_;
  // piece_length_[k]: length of input edge a's piece ending at crossing k; [ncross + a]: its last piece.
  std::vector<double> piece_length_;
  std::vector<RawChord> raw_;
  std::vector<Index> face_chord_offset_, face_chords_;
  // The output faces so far: vertices, input face, lengths opposite their corners.
  std::vector<Index> faces_, face_input_;
  std::vector<double> face_sides_;
  // The current face being cut: its first corner, boundary cycle (vertex ids and model points),
  // where each corner starts in it, its chords and their partners, and what the walks used.
  Index f_ = 0, c0_ = 0, n_ = 0;
  Index start_[3] = {0, 0, 0};
  std::vector<Index> cycle_id_;
  std::vector<P3> cycle_pos_;
  std::vector<Chord> chords_;
  std::vector<std::vector<std::pair<Index, Index>>> partners_;  // per cycle position: (partner, chord)
  std::vector<std::uint8_t> used_side_;
  std::vector<std::vector<std::uint8_t>> used_chord_;
  std::vector<Index> piece_;
  // The current face's rounding: one unit in the last place of its points' coordinates in its
  // model triangle, as a length (ε × its longest side l; in H ε sinh l, the hyperboloid's
  // coordinates growing with the distance from the pole); per output face, that of its face.
  double rounding_ = 0;
  std::vector<double> face_rounding_;

  /// The distance of two points of the current face's cycle. Two distinct points that coincide in
  /// double (crossings of two input edges from one vertex whose parameters on a side are equal in
  /// double, a crossing rounded onto a corner) are apart by less than the face's rounding; they get
  /// 8 times that rounding instead of 0, which no metric takes: their faces are needles within their
  /// coarse face's rounding.
  double apart(Index a, Index b) const {
    const double d = distance(g_, cycle_pos_[a], cycle_pos_[b]);
    return d > 0 || std::isnan(d) ? d : 8 * rounding_;  // NaN stays, for the checks to name
  }

  bool fail(Status s, std::string m) {
    r_.status = s;
    r_.message = std::move(m);
    return false;
  }

  /// Sizes of the paths, crossings, u and input against the triangulation; lengths and angles at u.
  bool check_and_measure() {
    if (paths_.status != Status::Ok || paths_.along.size() != static_cast<std::size_t>(nin_) ||
        crossings_.size() != paths_.crossed_edge.size() || u_.size() != static_cast<std::size_t>(nv_) ||
        input_.num_vertices != nv_ || input_mesh_.num_vertices() != nv_ ||
        tri_.normal.size() != static_cast<std::size_t>(t_.num_edges))
      return fail(Status::InvalidArgument, "the traced paths, crossings, u or the input do not match the triangulation");
    ncross_ = static_cast<Index>(crossings_.size());
    ConformalStructure structure;
    vertex_scaling_structure(tri_, structure);
    l_.resize(static_cast<std::size_t>(t_.num_edges));
    std::vector<double> theta(static_cast<std::size_t>(3 * t_.num_faces));
    const Index bad_edge = edge_lengths(t_, structure, u_, l_);
    const AngleReport angles = corner_angles(t_, g_, l_, theta);
    if (bad_edge != kInvalid || angles.violations > 0)
      return fail(Status::TriangleInequality, "the metric at u has a face without valid angles");
    return true;
  }

  /// Crossing k by (current edge, slot); the input edge of every current edge that is one; the
  /// input edge of every crossing vertex.
  bool index_crossings() {
    slot_offset_.assign(static_cast<std::size_t>(t_.num_edges) + 1, 0);
    for (Index e = 0; e < t_.num_edges; ++e)
      slot_offset_[e + 1] = slot_offset_[e] + std::max<Index>(0, static_cast<Index>(tri_.normal[e]));
    if (slot_offset_[t_.num_edges] != ncross_)
      return fail(Status::InvalidArgument, "the crossings do not match the normal coordinates");
    crossing_at_.assign(static_cast<std::size_t>(ncross_), kInvalid);
    for (Index k = 0; k < ncross_; ++k) crossing_at_[slot_offset_[paths_.crossed_edge[k]] + paths_.crossed_slot[k]] = k;
    input_of_.assign(static_cast<std::size_t>(t_.num_edges), kInvalid);
    for (Index a = 0; a < nin_; ++a)
      if (paths_.along[a] != kInvalid) input_of_[paths_.along[a]] = a;
    // Vertices: the input's, then the crossings, each on its input edge's 3D segment at the
    // fraction of the edge's length in the metric (the sum of its pieces' lengths, filled in by
    // cut_face()).
    r_.vertex_input_edge.assign(static_cast<std::size_t>(nv_ + ncross_), kInvalid);
    for (Index a = 0; a < nin_; ++a)
      for (Index k = paths_.offsets[a]; k < paths_.offsets[a + 1]; ++k) r_.vertex_input_edge[nv_ + k] = a;
    piece_length_.assign(static_cast<std::size_t>(ncross_) + static_cast<std::size_t>(nin_), 0.0);
    return true;
  }

  /// The pieces of every input edge that crosses current edges, listed per current face (CSR).
  void gather_pieces() {
    raw_.reserve(static_cast<std::size_t>(ncross_ + nin_));
    for (Index a = 0; a < nin_; ++a) {
      if (paths_.along[a] != kInvalid) continue;
      const Index k0 = paths_.offsets[a], k1 = paths_.offsets[a + 1];
      raw_.push_back({corner_face(paths_.first_corner[a]), paths_.first_corner[a], kInvalid, kInvalid, k0, a, k0});
      for (Index k = k0; k + 1 < k1; ++k)
        raw_.push_back({corner_face(paths_.crossed_corner[k + 1]), kInvalid, k, kInvalid, k + 1, a, k + 1});
      raw_.push_back({corner_face(paths_.last_corner[a]), kInvalid, k1 - 1, paths_.last_corner[a], kInvalid, a, ncross_ + a});
    }
    face_chord_offset_.assign(static_cast<std::size_t>(t_.num_faces) + 1, 0);
    for (const RawChord& c : raw_) ++face_chord_offset_[c.face + 1];
    for (Index f = 0; f < t_.num_faces; ++f) face_chord_offset_[f + 1] += face_chord_offset_[f];
    face_chords_.resize(raw_.size());
    std::vector<Index> fill(face_chord_offset_.begin(), face_chord_offset_.end() - 1);
    for (Index i = 0; i < static_cast<Index>(raw_.size()); ++i) face_chords_[fill[raw_[i].face]++] = i;
  }

  /// Current face f laid out in its model triangle, and its boundary cycle: corner x, then the
  /// crossings on the side from x to next(x) (opposite prev(x)), for x = corners 0, 1, 2.
  void face_cycle(Index f) {
    f_ = f;
    c0_ = 3 * f;
    P3 pos[3];
    pos[0] = pole(g_);
    pos[1] = polar(g_, l_[t_.corner_edge[c0_ + 2]], 0);
    // Corner 0's angle as the layout's frames take it (FaceFrames: the same function of the same
    // lengths, so the pieces' points sit exactly where the frames put the face's corners).
    pos[2] = polar(g_, l_[t_.corner_edge[c0_ + 1]],
                   detail::angle_from_lengths(g_, l_[t_.corner_edge[c0_]], l_[t_.corner_edge[c0_ + 1]],
                                              l_[t_.corner_edge[c0_ + 2]]));
    for (Index k = 0; k < 3; ++k) r_.frames.frame_lengths.push_back(l_[t_.corner_edge[c0_ + k]]);
    const double longest = std::max({l_[t_.corner_edge[c0_]], l_[t_.corner_edge[c0_ + 1]], l_[t_.corner_edge[c0_ + 2]]});
    rounding_ = std::numeric_limits<double>::epsilon() * (g_ == Geometry::Hyperbolic ? std::sinh(longest) : longest);
    cycle_id_.clear();
    cycle_pos_.clear();
    for (Index k = 0; k < 3; ++k) {
      const Index x = c0_ + k, p = prev_corner(x);
      start_[k] = static_cast<Index>(cycle_id_.size());
      cycle_id_.push_back(t_.corner_vertex[x]);
      cycle_pos_.push_back(pos[k]);
      const Index e = t_.corner_edge[p];
      const Index count = std::max<Index>(0, static_cast<Index>(tri_.normal[e]));
      const bool along_e = t_.edge_corners[2 * e] == p;  // the edge runs from vertex(x) here
      const P3& e0 = along_e ? pos[k] : pos[corner_slot(next_corner(x))];
      const P3& e1 = along_e ? pos[corner_slot(next_corner(x))] : pos[k];
      for (Index i = 0; i < count; ++i) {
        const Index slot = along_e ? i : count - 1 - i;
        const Index kc = crossing_at_[slot_offset_[e] + slot];
        cycle_id_.push_back(nv_ + kc);
        cycle_pos_.push_back(on_chord(g_, e0, e1, crossings_[kc]));
      }
    }
    n_ = static_cast<Index>(cycle_id_.size());
  }

  /// Cycle position of a chord end: a corner of this face, or crossing kc seen from this face.
  Index position_of(Index corner, Index kc) const {
    if (corner != kInvalid) return start_[corner_slot(corner)];
    const Index e = paths_.crossed_edge[kc];
    // The corner of this face opposite e on the side the crossing is on.
    Index p = kInvalid;
    for (Index k = 0; k < 3; ++k)
      if (t_.corner_edge[c0_ + k] == e) {
        const Index x = next_corner(c0_ + k);
        const Index count = static_cast<Index>(tri_.normal[e]);
        const bool along_e = t_.edge_corners[2 * e] == c0_ + k;
        const Index i = along_e ? paths_.crossed_slot[kc] : count - 1 - paths_.crossed_slot[kc];
        const Index q = start_[corner_slot(x)] + 1 + i;
        if (cycle_id_[q] == nv_ + kc) p = q;
      }
    return p;
  }

  /// The face's chords between cycle positions, their partners, and the pieces' lengths.
  bool face_chords() {
    chords_.clear();
    partners_.assign(static_cast<std::size_t>(n_), {});
    for (Index i = face_chord_offset_[f_]; i < face_chord_offset_[f_ + 1]; ++i) {
      const RawChord& rc = raw_[face_chords_[i]];
      const Index from = position_of(rc.from_corner, rc.from_cross), to = position_of(rc.to_corner, rc.to_cross);
      if (from == kInvalid || to == kInvalid || from == to)
        return fail(Status::NumericalFailure, "input edge " + std::to_string(rc.input_edge) + " has a piece in current face " +
                                                  std::to_string(f_) + " that does not join two points of its boundary");
      piece_length_[rc.piece] = apart(from, to);
      partners_[from].push_back({to, static_cast<Index>(chords_.size())});
      partners_[to].push_back({from, static_cast<Index>(chords_.size())});
      chords_.push_back({from, to, rc.input_edge, true});
    }
    return true;
  }

  /// The input face left of side step i → i+1 when that side is an input edge, else kInvalid.
  Index side_input_face(Index i) const {
    if (cycle_id_[i] >= nv_ || cycle_id_[(i + 1) % n_] >= nv_) return kInvalid;
    Index k = 0;
    while (k < 3 && start_[k] != i) ++k;
    if (k == 3) return kInvalid;
    const Index a = input_of_[t_.corner_edge[prev_corner(c0_ + k)]];
    if (a == kInvalid) return kInvalid;
    const bool fwd = input_.edge_vertices[2 * a] == cycle_id_[i];
    const Index c = input_.edge_corners[2 * a + (fwd ? 0 : 1)];
    return c == kInvalid ? kInvalid : corner_face(c);
  }
  /// The input face left of chord ci walked from cycle position `from`.
  Index chord_input_face(Index ci, Index from) const {
    const Chord& ch = chords_[ci];
    const bool fwd = (from == ch.from) == ch.forward;
    const Index c = input_.edge_corners[2 * ch.input_edge + (fwd ? 0 : 1)];
    return c == kInvalid ? kInvalid : corner_face(c);
  }

  /// The piece to the left of step i → j (see the top of this file), fanned from i into the
  /// output; false when the walk does not close or the piece names no input face.
  bool walk(Index i, Index j, Index first_face) {
    piece_.assign({i});
    Index tag = first_face, prev = i, cur = j;
    for (Index guard = 0; cur != i; ++guard) {
      if (guard > n_) return false;
      piece_.push_back(cur);
      // Candidates at cur: the side step cur → cur+1, and its chords.
      auto key = [&](Index k) { return ((prev - k) % n_ + n_) % n_; };
      Index best = kInvalid, best_chord = kInvalid;
      if (key((cur + 1) % n_) > 0) best = (cur + 1) % n_;
      for (const auto& [k, ci] : partners_[cur])
        if (key(k) > 0 && (best == kInvalid || key(k) < key(best))) {
          best = k;
          best_chord = ci;
        }
      if (best == kInvalid) return false;
      if (best_chord == kInvalid) {
        used_side_[cur] = 1;
        if (tag == kInvalid) tag = side_input_face(cur);
      } else {
        used_chord_[best_chord][chords_[best_chord].from == cur ? 0 : 1] = 1;
        if (tag == kInvalid) tag = chord_input_face(best_chord, cur);
      }
      prev = cur;
      cur = best;
    }
    if (tag == kInvalid) return false;
    for (std::size_t m = 1; m + 1 < piece_.size(); ++m) {
      const Index a = piece_[0], b = piece_[m], c = piece_[m + 1];
      faces_.insert(faces_.end(), {cycle_id_[a], cycle_id_[b], cycle_id_[c]});
      r_.frames.face_frame.push_back(f_);
      for (const Index q : {a, b, c})
        r_.frames.corner_model.insert(r_.frames.corner_model.end(), cycle_pos_[q].begin(), cycle_pos_[q].end());
      face_sides_.insert(face_sides_.end(), {apart(b, c), apart(c, a), apart(a, b)});
      face_rounding_.push_back(rounding_);
      face_input_.push_back(tag);
    }
    return true;
  }

  /// Current face f cut into its pieces: every side step and both sides of every chord start a
  /// walk unless an earlier walk used them.
  bool cut_face(Index f) {
    face_cycle(f);
    if (!face_chords()) return false;
    used_side_.assign(static_cast<std::size_t>(n_), 0);
    used_chord_.assign(chords_.size(), std::vector<std::uint8_t>(2, 0));
    const std::string lost = "current face " + std::to_string(f) + " has a piece that lies in no input face";
    for (Index i = 0; i < n_; ++i)
      if (!used_side_[i]) {
        used_side_[i] = 1;
        if (!walk(i, (i + 1) % n_, side_input_face(i))) return fail(Status::NumericalFailure, lost);
      }
    for (Index ci = 0; ci < static_cast<Index>(chords_.size()); ++ci)
      for (int side = 0; side < 2; ++side)
        if (!used_chord_[ci][side]) {
          used_chord_[ci][side] = 1;
          const Index from = side == 0 ? chords_[ci].from : chords_[ci].to;
          const Index to = side == 0 ? chords_[ci].to : chords_[ci].from;
          if (!walk(from, to, chord_input_face(ci, from))) return fail(Status::NumericalFailure, lost);
        }
    return true;
  }

  /// Slivers whose lengths (each edge measured in the face of the two that rounds less) miss the
  /// triangle inequality, or meet it with less than their current face's rounding r to spare, by
  /// no more than 16 r — a piece between two input edges from one vertex that rounding does not
  /// separate — get their longest side shortened to the sum of the others less r (a change far
  /// below that side's own length; a side shorter than r first becomes r, as no measurement
  /// resolves it). A longest side shortened in one face is checked again in its other (a few
  /// passes). A larger miss stays, for the metric's checks to name.
  void settle_slivers() {
    const Topology& s = r_.topology;
    for (int pass = 0; pass < 16; ++pass) {
      bool changed = false;
      for (Index f = 0; f < s.num_faces; ++f) {
        Index e[3] = {s.corner_edge[3 * f], s.corner_edge[3 * f + 1], s.corner_edge[3 * f + 2]};
        std::sort(e, e + 3, [&](Index a, Index b) { return r_.l[a] < r_.l[b]; });
        const double r = face_rounding_[f];
        const double miss = r_.l[e[2]] - r_.l[e[1]] - r_.l[e[0]];
        if (!(miss > -r && miss <= 16 * r)) continue;
        r_.l[e[0]] = std::max(r_.l[e[0]], r);
        r_.l[e[2]] = std::min(r_.l[e[2]], r_.l[e[1]] + r_.l[e[0]] - r);
        changed = true;
      }
      if (!changed) break;
    }
  }

  /// 3D positions (input vertices as they are, crossings along their input edge's segment), the
  /// subdivision's topology and its lengths.
  bool finish() {
    Mesh& mesh = r_.mesh;
    mesh.positions.resize(static_cast<std::size_t>(3 * (nv_ + ncross_)));
    std::copy(input_mesh_.positions.begin(), input_mesh_.positions.begin() + 3 * nv_, mesh.positions.begin());
    for (Index a = 0; a < nin_; ++a) {
      const Index k0 = paths_.offsets[a], k1 = paths_.offsets[a + 1];
      if (k0 == k1) continue;
      double total = piece_length_[ncross_ + a];
      for (Index k = k0; k < k1; ++k) total += piece_length_[k];
      const Index va = input_.edge_vertices[2 * a], vb = input_.edge_vertices[2 * a + 1];
      double run = 0;
      for (Index k = k0; k < k1; ++k) {
        run += piece_length_[k];
        const double s = total > 0 ? run / total : double(k - k0 + 1) / double(k1 - k0 + 1);
        for (int d = 0; d < 3; ++d)
          mesh.positions[3 * (nv_ + k) + d] = (1 - s) * input_mesh_.positions[3 * va + d] + s * input_mesh_.positions[3 * vb + d];
      }
    }
    mesh.faces = std::move(faces_);
    TopologyResult tr = build_topology(mesh.faces, nv_ + ncross_);
    if (tr.status != Status::Ok)
      return fail(Status::NumericalFailure, "the common subdivision is not a manifold triangulation: " + tr.message);
    r_.topology = std::move(tr.topology);
    // An edge between two current faces (a step along a current edge) is measured in both, each
    // to its own rounding (the hyperboloid's coordinates grow with the distance from the face's
    // pole): it takes the measurement of the face that rounds less.
    r_.l.assign(static_cast<std::size_t>(r_.topology.num_edges), 0.0);
    for (Index e = 0; e < r_.topology.num_edges; ++e) {
      Index c = r_.topology.edge_corners[2 * e];
      const Index o = r_.topology.edge_corners[2 * e + 1];
      if (o != kInvalid && face_rounding_[corner_face(o)] < face_rounding_[corner_face(c)]) c = o;
      r_.l[e] = face_sides_[c];
    }
    settle_slivers();
    r_.face_input = std::move(face_input_);
    r_.frames.frame_opposite = t_.opposite;
    r_.status = Status::Ok;
    r_.message = "ok";
    return true;
  }
};

}  // namespace

CommonSubdivision common_subdivision(const IntrinsicTriangulation& tri, std::span<const double> u,
                                     const Mesh& input_mesh, const Topology& input, const InputEdgePaths& paths,
                                     std::span<const double> crossings) {
  return Subdivider(tri, u, input_mesh, input, paths, crossings).run();
}

}  // namespace ricci
