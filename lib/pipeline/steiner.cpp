// Steiner points on the input's own faces. See steiner.h.
#include "ricci/steiner.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace ricci {

namespace {

// The topology of out.mesh.faces (num_vertices vertices) and its edges' input edges from the
// input edge under each corner's opposite edge; false with out.status set when not a manifold.
bool finish_subdivision(SteinerMesh& out, Index num_vertices, const std::vector<Index>& opposite_input,
                        const char* what) {
  TopologyResult tr = build_topology(out.mesh.faces, num_vertices);
  if (tr.status != Status::Ok) {
    out.status = tr.status;
    out.message = std::string(what) + " is not a manifold triangulation: " + tr.message;
    return false;
  }
  out.topology = std::move(tr.topology);
  out.edge_input.assign(static_cast<std::size_t>(out.topology.num_edges), kInvalid);
  for (Index c = 0; c < out.topology.num_corners(); ++c)
    if (opposite_input[c] != kInvalid) out.edge_input[out.topology.corner_edge[c]] = opposite_input[c];
  out.status = Status::Ok;
  out.message = "ok";
  return true;
}

// The start of a split of `s` into `out`: its mesh, places and face inputs copied; returns the
// input edge under each corner's opposite edge (kInvalid inside an input face).
std::vector<Index> start_split(const SteinerMesh& s, SteinerMesh& out) {
  out.mesh.positions = s.mesh.positions;
  out.mesh.faces = s.mesh.faces;
  out.place = s.place;
  out.face_input = s.face_input;
  const Topology& t = s.topology;
  std::vector<Index> opposite_input(static_cast<std::size_t>(t.num_corners()));
  for (Index c = 0; c < t.num_corners(); ++c) opposite_input[c] = s.edge_input[t.corner_edge[c]];
  return opposite_input;
}

// One midpoint split of `in` (level k) into `out` (level k + 1).
bool split_once(const SteinerMesh& in, SteinerMesh& out) {
  const Topology& t = in.topology;
  const Index nv = t.num_vertices, ne = t.num_edges, nf = t.num_faces;
  out.mesh.positions = in.mesh.positions;
  out.mesh.positions.resize(3 * static_cast<std::size_t>(nv + ne));
  out.place = in.place;
  out.place.resize(static_cast<std::size_t>(nv + ne));
  for (Index e = 0; e < ne; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    for (int d = 0; d < 3; ++d)
      out.mesh.positions[3 * static_cast<std::size_t>(nv + e) + d] =
          0.5 * (in.mesh.positions[3 * static_cast<std::size_t>(a) + d] + in.mesh.positions[3 * static_cast<std::size_t>(b) + d]);
    const Index c = t.edge_corners[2 * e];
    out.place[nv + e] = in.edge_input[e] != kInvalid
                            ? SteinerPlace{SteinerPlace::Kind::Edge, in.edge_input[e]}
                            : SteinerPlace{SteinerPlace::Kind::Face, in.face_input[corner_face(c)]};
  }
  out.mesh.faces.resize(12 * static_cast<std::size_t>(nf));
  out.face_input.resize(4 * static_cast<std::size_t>(nf));
  // The input edge under each new corner's opposite edge (kInvalid inside an old face).
  std::vector<Index> opposite_input(12 * static_cast<std::size_t>(nf), kInvalid);
  for (Index f = 0; f < nf; ++f) {
    const Index v[3] = {t.corner_vertex[3 * f], t.corner_vertex[3 * f + 1], t.corner_vertex[3 * f + 2]};
    Index side[3], mid[3];  // side[k]: the old edge opposite corner k; mid[k] splits it
    for (int k = 0; k < 3; ++k) {
      side[k] = in.edge_input[t.corner_edge[3 * f + k]];
      mid[k] = nv + t.corner_edge[3 * f + k];
    }
    const Index faces[4][3] = {{v[0], mid[2], mid[1]}, {v[1], mid[0], mid[2]}, {v[2], mid[1], mid[0]}, {mid[0], mid[1], mid[2]}};
    const Index under[4][3] = {{kInvalid, side[1], side[2]}, {kInvalid, side[2], side[0]}, {kInvalid, side[0], side[1]},
                               {kInvalid, kInvalid, kInvalid}};
    for (int q = 0; q < 4; ++q) {
      const std::size_t nf_ = 4 * static_cast<std::size_t>(f) + q;
      out.face_input[nf_] = in.face_input[f];
      for (int k = 0; k < 3; ++k) {
        out.mesh.faces[3 * nf_ + k] = faces[q][k];
        opposite_input[3 * nf_ + k] = under[q][k];
      }
    }
  }
  if (!finish_subdivision(out, nv + ne, opposite_input, "the subdivision")) return false;
  out.levels = in.levels + 1;
  return true;
}

}  // namespace

SteinerMesh subdivide_on_faces(const Mesh& mesh, const Topology& topology, int levels) {
  SteinerMesh s;
  if (levels < 0 || levels > 8) {
    s.status = Status::InvalidArgument;
    s.message = "levels must be in [0, 8], not " + std::to_string(levels);
    return s;
  }
  if (mesh.faces.size() != static_cast<std::size_t>(3 * topology.num_faces) ||
      mesh.num_vertices() != topology.num_vertices) {
    s.status = Status::InvalidArgument;
    s.message = "the mesh does not match its topology";
    return s;
  }
  s.mesh.positions = mesh.positions;
  s.mesh.faces = mesh.faces;
  s.topology = topology;
  s.face_input.resize(static_cast<std::size_t>(topology.num_faces));
  for (Index f = 0; f < topology.num_faces; ++f) s.face_input[f] = f;
  s.place.resize(static_cast<std::size_t>(topology.num_vertices));
  for (Index v = 0; v < topology.num_vertices; ++v) s.place[v] = {SteinerPlace::Kind::Vertex, v};
  s.edge_input.resize(static_cast<std::size_t>(topology.num_edges));
  for (Index e = 0; e < topology.num_edges; ++e) s.edge_input[e] = e;
  for (int k = 0; k < levels; ++k) {
    SteinerMesh next;
    if (!split_once(s, next)) return next;
    s = std::move(next);
  }
  s.status = Status::Ok;
  s.message = "ok";
  return s;
}

SteinerMesh split_boundary_edges(const SteinerMesh& s, std::span<const Index> edges, Index* split) {
  SteinerMesh out;
  if (split) *split = 0;
  const Topology& t = s.topology;
  const Index nv = t.num_vertices, nf = t.num_faces;
  for (const Index e : edges)
    if (e < 0 || e >= t.num_edges) {
      out.status = Status::InvalidArgument;
      out.message = "edge " + std::to_string(e) + " is not an edge (the surface has " + std::to_string(t.num_edges) + ")";
      return out;
    }
  std::vector<Index> opposite_input = start_split(s, out);
  std::vector<std::uint8_t> touched(static_cast<std::size_t>(nf), 0);
  Index n = 0;
  for (const Index e : edges) {
    const Index c = t.edge_corners[2 * e];  // the corner opposite e in its only face
    if (t.edge_corners[2 * e + 1] != kInvalid || c == kInvalid || touched[corner_face(c)]) continue;
    const Index f = corner_face(c);
    touched[f] = 1;
    const Index cn = next_corner(c), cp = prev_corner(c);
    const Index a = t.corner_vertex[c], b = t.corner_vertex[cn], d = t.corner_vertex[cp];
    const Index m = nv + n++;
    for (int k = 0; k < 3; ++k)
      out.mesh.positions.push_back(0.5 * (s.mesh.positions[3 * static_cast<std::size_t>(b) + k] +
                                          s.mesh.positions[3 * static_cast<std::size_t>(d) + k]));
    out.place.push_back({SteinerPlace::Kind::Edge, s.edge_input[e]});
    const Index on_e = s.edge_input[e], under_ab = opposite_input[cp], under_da = opposite_input[cn];
    // (a, b, d) becomes (a, b, m) in place and (a, m, d) after the faces.
    const Index first[3] = {a, b, m}, second[3] = {a, m, d};
    const Index first_under[3] = {on_e, kInvalid, under_ab}, second_under[3] = {on_e, under_da, kInvalid};
    for (int k = 0; k < 3; ++k) {
      out.mesh.faces[3 * static_cast<std::size_t>(f) + k] = first[k];
      opposite_input[3 * static_cast<std::size_t>(f) + k] = first_under[k];
      out.mesh.faces.push_back(second[k]);
      opposite_input.push_back(second_under[k]);
    }
    out.face_input.push_back(s.face_input[f]);
  }
  if (!finish_subdivision(out, nv + n, opposite_input, "the split surface")) return out;
  out.levels = s.levels;
  if (split) *split = n;
  return out;
}

namespace {

// One round of split_chords(): the chords of `s` whose two faces no earlier chord of the round
// touched, split into `out`; `n` counts them.
bool split_chords_once(const SteinerMesh& s, SteinerMesh& out, Index& n) {
  const Topology& t = s.topology;
  const Index nv = t.num_vertices, nf = t.num_faces;
  std::vector<Index> opposite_input = start_split(s, out);
  std::vector<std::uint8_t> touched(static_cast<std::size_t>(nf), 0);
  n = 0;
  // Splits face corner_face(c) at the new vertex m on the edge opposite c: the face keeps its
  // slots with the edge's second end replaced by m, a copy with its first end replaced follows.
  auto split_face = [&](Index c, Index m, Index on_e) {
    const Index f = corner_face(c), cn = next_corner(c), cp = prev_corner(c);
    const std::size_t f2 = out.mesh.faces.size() / 3;
    for (int k = 0; k < 3; ++k) {
      out.mesh.faces.push_back(out.mesh.faces[3 * static_cast<std::size_t>(f) + k]);
      opposite_input.push_back(opposite_input[3 * static_cast<std::size_t>(f) + k]);
    }
    out.face_input.push_back(out.face_input[f]);
    out.mesh.faces[cp] = m;  // (x, a, m): its edges (m, x) inside the old face, (x, a) as before
    opposite_input[c] = on_e;
    opposite_input[cn] = kInvalid;
    out.mesh.faces[3 * f2 + corner_slot(cn)] = m;  // (x, m, b): (b, x) as before, (x, m) inside
    opposite_input[3 * f2 + corner_slot(c)] = on_e;
    opposite_input[3 * f2 + corner_slot(cp)] = kInvalid;
  };
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index c = t.edge_corners[2 * e], o = t.edge_corners[2 * e + 1];
    if (o == kInvalid || !t.is_boundary_vertex(t.edge_vertices[2 * e]) || !t.is_boundary_vertex(t.edge_vertices[2 * e + 1]))
      continue;
    if (touched[corner_face(c)] || touched[corner_face(o)]) continue;
    touched[corner_face(c)] = touched[corner_face(o)] = 1;
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    const Index m = nv + n++;
    for (int k = 0; k < 3; ++k)
      out.mesh.positions.push_back(0.5 * (s.mesh.positions[3 * static_cast<std::size_t>(a) + k] +
                                          s.mesh.positions[3 * static_cast<std::size_t>(b) + k]));
    out.place.push_back(s.edge_input[e] != kInvalid ? SteinerPlace{SteinerPlace::Kind::Edge, s.edge_input[e]}
                                                    : SteinerPlace{SteinerPlace::Kind::Face, s.face_input[corner_face(c)]});
    split_face(c, m, s.edge_input[e]);
    split_face(o, m, s.edge_input[e]);
  }
  if (!finish_subdivision(out, nv + n, opposite_input, "the surface with its chords split")) return false;
  out.levels = s.levels;
  return true;
}

}  // namespace

std::vector<Index> find_chords(const Topology& t) {
  std::vector<Index> out;
  for (Index e = 0; e < t.num_edges; ++e)
    if (t.edge_corners[2 * e + 1] != kInvalid && t.is_boundary_vertex(t.edge_vertices[2 * e]) &&
        t.is_boundary_vertex(t.edge_vertices[2 * e + 1]))
      out.push_back(e);
  return out;
}

SteinerMesh split_chords(const SteinerMesh& s, Index* split) {
  if (split) *split = 0;
  SteinerMesh cur = s;
  Index total = 0;
  for (;;) {
    SteinerMesh next;
    Index n = 0;
    if (!split_chords_once(cur, next, n)) return next;
    if (n == 0) break;
    total += n;
    cur = std::move(next);
  }
  if (split) *split = total;
  return cur;
}

Target steiner_target(const SteinerMesh& s, const Topology& input, const Target& target) {
  const Index nv = input.num_vertices, nr = s.topology.num_vertices;
  Target out;
  out.boundary = target.boundary;
  out.K.assign(static_cast<std::size_t>(nr), 0.0);
  std::copy(target.K.begin(), target.K.begin() + std::min<std::size_t>(target.K.size(), nv), out.K.begin());
  if (!target.fixed_u.empty()) {
    out.fixed_u.assign(static_cast<std::size_t>(nr), 0);
    for (Index v = 0; v < nr; ++v) {
      const SteinerPlace p = s.place[v];
      if (p.kind == SteinerPlace::Kind::Vertex) {
        out.fixed_u[v] = target.fixed_u[p.index];
      } else if (p.kind == SteinerPlace::Kind::Edge && input.edge_corners[2 * p.index + 1] == kInvalid) {
        out.fixed_u[v] = target.fixed_u[input.edge_vertices[2 * p.index]] && target.fixed_u[input.edge_vertices[2 * p.index + 1]];
      }
    }
  }
  if (!target.loop_total.empty()) {
    // The input's loop of each vertex, then each loop of the subdivision by one of its input vertices.
    std::vector<Index> loop_of(static_cast<std::size_t>(nv), kInvalid);
    for (Index i = 0; i < input.num_boundary_loops(); ++i)
      for (Index j = input.boundary_offsets[i]; j < input.boundary_offsets[i + 1]; ++j) loop_of[input.boundary_vertices[j]] = i;
    const Index loops = s.topology.num_boundary_loops();
    out.loop_total.assign(static_cast<std::size_t>(loops), 0.0);
    for (Index i = 0; i < loops; ++i)
      for (Index j = s.topology.boundary_offsets[i]; j < s.topology.boundary_offsets[i + 1]; ++j) {
        const Index v = s.topology.boundary_vertices[j];
        if (v < nv && loop_of[v] != kInvalid && static_cast<std::size_t>(loop_of[v]) < target.loop_total.size()) {
          out.loop_total[i] = target.loop_total[loop_of[v]];
          break;
        }
      }
  }
  return out;
}

double median_edge_jump(const Topology& topology, const std::vector<double>& u) {
  const Index ne = topology.num_edges;
  if (ne == 0 || u.size() != static_cast<std::size_t>(topology.num_vertices)) return 0;
  std::vector<double> jump(static_cast<std::size_t>(ne));
  for (Index e = 0; e < ne; ++e)
    jump[e] = std::abs(u[topology.edge_vertices[2 * e]] - u[topology.edge_vertices[2 * e + 1]]);
  const auto mid = jump.begin() + ne / 2;
  std::nth_element(jump.begin(), mid, jump.end());
  return *mid;
}

int steiner_levels(double median_jump, double resolution, int max_levels, Index faces, std::int64_t max_faces) {
  // Quiet comparisons: a NaN jump asks for nothing and raises no floating-point exception.
  if (!std::isgreater(median_jump, resolution) || !std::isgreater(resolution, 0.0) || max_levels <= 0) return 0;
  int k = std::min(max_levels, static_cast<int>(std::ceil(std::log2(median_jump / resolution))));
  while (k > 0 && static_cast<std::int64_t>(faces) << (2 * k) > max_faces) --k;
  return std::max(k, 0);
}

}  // namespace ricci
