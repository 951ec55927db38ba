// ricci — cutting a surface open: tree–cotree cut graph, cut-and-paste canonicalisation of the
// polygon schema realised on the mesh (with exact local refinement when no edge path exists),
// arcs to the boundary loops, labelled sides and an independent intersection check. See cut.h.
// cut_surface() runs its stages in this order: start_cutter; slit_sphere (closed genus 0),
// base_on_boundary (genus 0 with boundary) or loops_by_tree_cotree (genus ≥ 1); cut_arcs;
// name_letters, write_sides, intersections_canonical.
//
// Vocabulary used below:
//   S      the (refined) surface: faces, positions, topology; starts as the input mesh.
//   cut    flags on S's interior edges: the cut graph C.
//   node   flags on S's vertices: the polygon corners N (every vertex of C ∪ ∂S whose degree
//          there is not 2 is a node, and so is the base; the ends of a new cut path become nodes
//          unless the move leaves one an interior point of a single path, degree 2).
//   R      the disk (with holes while boundary loops are detached): S cut open along C
//          (cut_open()). Its faces are S's faces (same indices and corners) over cut-vertex
//          copies.
//   Ŝ      S with every boundary loop collapsed to one point B_i. The polygon schema is read in
//          Ŝ: a run of boundary sides between two cut sides is one corner of class B_i.
#include "ricci/cut.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <queue>
#include <random>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>

#include <parallel/algorithm>

namespace ricci {

bool CutOptions::is_valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (base_vertex < -1) return fail("base_vertex must be -1 (automatic) or a vertex index");
  if (max_moves < 0) return fail("max_moves must be >= 0");
  if (!std::isfinite(max_refined_per_face) || max_refined_per_face < 0)
    return fail("max_refined_per_face must be finite and >= 0");
  for (double w : edge_weights)
    if (!std::isfinite(w) || w < 0) return fail("edge_weights must be finite and >= 0");
  return true;
}

std::string CutResult::brief_report() const {
  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "cut: %s, genus %d, %d boundary loops, %d sides, canonical %s, %d added vertices, %d moves, %.3f s",
      status == Status::Ok ? "ok" : std::string(status_name(status)).c_str(), static_cast<int>(genus),
      static_cast<int>(boundary_loops), static_cast<int>(num_sides()), canonical ? "yes" : "no",
      static_cast<int>(num_refined_vertices()), static_cast<int>(moves), seconds);
  return buf;
}

namespace {

using Clock = std::chrono::steady_clock;
using Pair = std::pair<Index, Index>;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- the refined surface ----------------------------------------------------------------------

struct Surface {
  const Mesh* input = nullptr;
  Index n_input = 0;
  bool has_pos = false;
  double mean_length = 1;  ///< mean edge length of the input (1 without positions)
  std::vector<double> pos;
  std::vector<Index> faces;
  std::vector<Index> face_origin;
  std::vector<Index> rec_face;
  std::vector<double> rec_bary;
  std::vector<Index> vertex_loop;  ///< input boundary loop of a vertex, -1 if interior
  Topology topo;
  double max_refined_per_face = 64;  ///< CutOptions::max_refined_per_face

  Index nv() const { return topo.num_vertices; }
  double length(Index u, Index v) const {
    if (!has_pos) return 1.0;
    const double dx = pos[3 * u] - pos[3 * v], dy = pos[3 * u + 1] - pos[3 * v + 1],
                 dz = pos[3 * u + 2] - pos[3 * v + 2];
    return std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  /// Class of a vertex in Ŝ.
  Index cls(Index v) const { return vertex_loop[v] >= 0 ? nv() + vertex_loop[v] : v; }
};

/// What a refinement of S changes, to undo it: it only appends vertices and faces, rewrites the
/// faces it splits and replaces the connectivity (the old one moved here, not copied).
struct SurfaceUndo {
  std::size_t pos = 0, faces = 0, face_origin = 0, rec_face = 0, rec_bary = 0, vertex_loop = 0;
  std::vector<std::pair<Index, std::array<Index, 3>>> split;  ///< faces rewritten, as they were
  Topology topo;
  bool took_topo = false;

  explicit SurfaceUndo(const Surface& S)
      : pos(S.pos.size()), faces(S.faces.size()), face_origin(S.face_origin.size()), rec_face(S.rec_face.size()),
        rec_bary(S.rec_bary.size()), vertex_loop(S.vertex_loop.size()) {}
  void restore(Surface& S) {
    S.pos.resize(pos);
    S.faces.resize(faces);
    S.face_origin.resize(face_origin);
    S.rec_face.resize(rec_face);
    S.rec_bary.resize(rec_bary);
    S.vertex_loop.resize(vertex_loop);
    for (const auto& [f, tri] : split)
      for (int k = 0; k < 3; ++k) S.faces[3 * f + k] = tri[k];
    if (took_topo) S.topo = std::move(topo);
    took_topo = false;
  }
};


/// Input-vertex weights of surface vertex v (up to three (vertex, weight) pairs).
void vertex_weights(const Surface& S, Index v, std::array<Index, 3>& ov, std::array<double, 3>& w) {
  if (v < S.n_input) {
    ov = {v, kInvalid, kInvalid};
    w = {1, 0, 0};
    return;
  }
  const Index k = v - S.n_input, f = S.rec_face[k];
  for (int i = 0; i < 3; ++i) {
    ov[i] = S.input->faces[3 * f + i];
    w[i] = S.rec_bary[3 * k + i];
  }
}

/// Barycentric coordinates in input face O of the average of `verts`. False if a vertex does not
/// lie in the closure of O (an internal error).
bool average_in_face(const Surface& S, Index O, std::span<const Index> verts, std::array<double, 3>& bary) {
  bary = {0, 0, 0};
  const double share = 1.0 / static_cast<double>(verts.size());
  for (Index v : verts) {
    std::array<Index, 3> ov;
    std::array<double, 3> w;
    vertex_weights(S, v, ov, w);
    for (int i = 0; i < 3; ++i) {
      if (ov[i] == kInvalid || w[i] == 0) continue;
      int slot = -1;
      for (int j = 0; j < 3; ++j)
        if (S.input->faces[3 * O + j] == ov[i]) slot = j;
      if (slot < 0) return false;
      bary[slot] += share * w[i];
    }
  }
  return true;
}

Index add_vertex(Surface& S, Index O, const std::array<double, 3>& bary) {
  const Index id = S.n_input + static_cast<Index>(S.rec_face.size());
  S.rec_face.push_back(O);
  for (double b : bary) S.rec_bary.push_back(b);
  if (S.has_pos) {
    for (int d = 0; d < 3; ++d) {
      double x = 0;
      for (int j = 0; j < 3; ++j) x += bary[j] * S.input->positions[3 * S.input->faces[3 * O + j] + d];
      S.pos.push_back(x);
    }
  }
  S.vertex_loop.push_back(-1);
  return id;
}

// ---- cut state, disk, polygon -----------------------------------------------------------------

struct State {
  std::vector<char> cut;   ///< #E
  std::vector<char> node;  ///< #V
};

struct Disk {
  std::vector<Index> faces;
  std::vector<Index> to_surface;
  Topology topo;
  bool ok = false;
};

/// R made again for `cut`, in R's own buffers (the cut's moves rebuild it each time: no fresh pages).
void build_disk(const Surface& S, const std::vector<char>& cut, Disk& R) {
  CutOpenResult o;
  o.faces = std::move(R.faces);
  o.to_surface = std::move(R.to_surface);
  o.topology = std::move(R.topo);
  cut_open(S.topo, cut, o);
  R.faces = std::move(o.faces);
  R.to_surface = std::move(o.to_surface);
  R.ok = o.status == Status::Ok;
  R.topo = std::move(o.topology);
}

struct Polygon {
  bool ok = false;
  std::string why;
  std::vector<Index> loop;        ///< R vertices of the outer loop, starting at a corner
  std::vector<Index> side_begin;  ///< position in loop
  std::vector<Index> side_len;    ///< edges
  std::vector<char> side_cut;
  std::vector<Index> side_partner;
  std::vector<Index> side_loop;  ///< input boundary loop of a boundary side, else -1
  std::vector<Index> holes;      ///< R boundary loops without cut edges (other than the outer)
  // The word in Ŝ: tokens are the cut sides in order; corner t lies before token t.
  std::vector<Index> tok_side;
  std::vector<Index> tok_letter;
  std::vector<int> tok_sign;
  std::vector<Index> corner_class;
  std::vector<std::vector<Index>> corner_anchor;
  Index num_letters = 0;

  Index m() const { return static_cast<Index>(loop.size()); }
  Index at(Index p) const { return loop[static_cast<std::size_t>(p % m())]; }
  Index ntok() const { return static_cast<Index>(tok_side.size()); }
};

std::uint64_t key(Index u, Index v) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) | static_cast<std::uint32_t>(v);
}

/// Reads the disk's outer boundary as sides and as the word in Ŝ. `outer_hint`: a surface
/// vertex on the loop to read when no loop carries a cut edge (genus 0 with boundary).
Polygon read_polygon(const Surface& S, const State& st, const Disk& R, Index outer_hint) {
  Polygon P;
  const Topology& rt = R.topo;
  Index outer = kInvalid, with_cut = 0;
  for (Index L = 0; L < rt.num_boundary_loops(); ++L) {
    bool has_cut = false, has_hint = false;
    for (Index k = rt.boundary_offsets[L]; k < rt.boundary_offsets[L + 1]; ++k) {
      if (st.cut[S.topo.corner_edge[rt.boundary_corners[k]]]) has_cut = true;
      if (R.to_surface[rt.boundary_vertices[k]] == outer_hint) has_hint = true;
    }
    if (has_cut) {
      ++with_cut;
      outer = L;
    } else if (has_hint && outer == kInvalid) {
      outer = L;
    }
  }
  if (with_cut > 1) {
    P.why = "several boundary loops of the disk carry cut edges";
    return P;
  }
  if (with_cut == 0) {
    // Take the hinted loop (outer may already be it).
    outer = kInvalid;
    for (Index L = 0; L < rt.num_boundary_loops() && outer == kInvalid; ++L)
      for (Index k = rt.boundary_offsets[L]; k < rt.boundary_offsets[L + 1]; ++k)
        if (R.to_surface[rt.boundary_vertices[k]] == outer_hint) outer = L;
  }
  if (outer == kInvalid) {
    P.why = "the disk has no outer boundary loop";
    return P;
  }
  for (Index L = 0; L < rt.num_boundary_loops(); ++L)
    if (L != outer) P.holes.push_back(L);
  const Index b0 = rt.boundary_offsets[outer], b1 = rt.boundary_offsets[outer + 1], m = b1 - b0;
  Index first = kInvalid;
  for (Index k = 0; k < m && first == kInvalid; ++k)
    if (st.node[R.to_surface[rt.boundary_vertices[b0 + k]]]) first = k;
  if (first == kInvalid) {
    P.why = "the disk boundary has no corner";
    return P;
  }
  std::vector<Index> edge(static_cast<std::size_t>(m));
  P.loop.resize(static_cast<std::size_t>(m));
  for (Index k = 0; k < m; ++k) {
    P.loop[k] = rt.boundary_vertices[b0 + (first + k) % m];
    edge[k] = S.topo.corner_edge[rt.boundary_corners[b0 + (first + k) % m]];
  }
  // Sides.
  for (Index k = 0; k < m;) {
    Index len = 1;
    while (k + len < m && !st.node[R.to_surface[P.loop[k + len]]]) ++len;
    P.side_begin.push_back(k);
    P.side_len.push_back(len);
    const bool is_cut = st.cut[edge[k]] != 0;
    P.side_cut.push_back(is_cut);
    P.side_loop.push_back(is_cut ? -1 : S.vertex_loop[R.to_surface[P.loop[k]]]);
    for (Index i = 1; i < len; ++i)
      if ((st.cut[edge[k + i]] != 0) != is_cut) {
        P.why = "a side mixes cut and boundary edges";
        return P;
      }
    k += len;
  }
  const Index ns = static_cast<Index>(P.side_begin.size());
  std::unordered_map<std::uint64_t, Index> by_first;
  by_first.reserve(static_cast<std::size_t>(ns) * 2);
  for (Index s = 0; s < ns; ++s) {
    if (!P.side_cut[s]) continue;
    const Index b = P.side_begin[s];
    by_first[key(R.to_surface[P.at(b)], R.to_surface[P.at(b + 1)])] = s;
  }
  P.side_partner.assign(static_cast<std::size_t>(ns), kInvalid);
  for (Index s = 0; s < ns; ++s) {
    if (!P.side_cut[s]) continue;
    const Index e = P.side_begin[s] + P.side_len[s];
    const auto it = by_first.find(key(R.to_surface[P.at(e)], R.to_surface[P.at(e - 1)]));
    if (it == by_first.end() || P.side_len[it->second] != P.side_len[s]) {
      P.why = "a cut side has no partner";
      return P;
    }
    P.side_partner[s] = it->second;
  }
  // Tokens and corners of the word in Ŝ.
  std::vector<Index> letter_of_side(static_cast<std::size_t>(ns), kInvalid);
  for (Index s = 0; s < ns; ++s) {
    if (!P.side_cut[s]) continue;
    P.tok_side.push_back(s);
    if (letter_of_side[P.side_partner[s]] != kInvalid) {
      letter_of_side[s] = letter_of_side[P.side_partner[s]];
      P.tok_sign.push_back(-1);
    } else {
      letter_of_side[s] = P.num_letters++;
      P.tok_sign.push_back(+1);
    }
    P.tok_letter.push_back(letter_of_side[s]);
  }
  const Index nt = P.ntok();
  for (Index t = 0; t < nt; ++t) {
    const Index s = P.tok_side[t];
    const Index prev = P.tok_side[(t + nt - 1) % nt];
    // boundary sides strictly between prev and s (cyclically)
    std::vector<Index> anchors;
    Index cls = kInvalid;
    for (Index q = (prev + 1) % ns; q != s; q = (q + 1) % ns) {
      if (cls == kInvalid) cls = S.nv() + P.side_loop[q];
      for (Index i = 0; i <= P.side_len[q]; ++i) {
        const Index u = P.at(P.side_begin[q] + i);
        if (anchors.empty() || anchors.back() != u) anchors.push_back(u);
      }
    }
    if (cls == kInvalid) {
      const Index u = P.at(P.side_begin[s]);
      anchors.push_back(u);
      cls = S.cls(R.to_surface[u]);
    }
    P.corner_class.push_back(cls);
    P.corner_anchor.push_back(std::move(anchors));
  }
  P.ok = true;
  return P;
}

/// Surface vertices of side s, in order.
std::vector<Index> side_surface_vertices(const Polygon& P, const Disk& R, Index s) {
  std::vector<Index> out;
  for (Index i = 0; i <= P.side_len[s]; ++i) out.push_back(R.to_surface[P.at(P.side_begin[s] + i)]);
  return out;
}

Pair side_first_edge(const Polygon& P, const Disk& R, Index s) {
  return {R.to_surface[P.at(P.side_begin[s])], R.to_surface[P.at(P.side_begin[s] + 1)]};
}

Index side_with_first_edge(const Polygon& P, const Disk& R, Pair e) {
  for (Index s = 0; s < static_cast<Index>(P.side_begin.size()); ++s)
    if (side_first_edge(P, R, s) == e) return s;
  return kInvalid;
}

Index token_of_side(const Polygon& P, Index s) {
  for (Index t = 0; t < P.ntok(); ++t)
    if (P.tok_side[t] == s) return t;
  return kInvalid;
}

std::vector<Pair> cut_pairs(const Surface& S, const State& st) {
  std::vector<Pair> out;
  for (Index e = 0; e < S.topo.num_edges; ++e)
    if (st.cut[e]) out.push_back({S.topo.edge_vertices[2 * e], S.topo.edge_vertices[2 * e + 1]});
  return out;
}

/// Cut degree of every vertex.
std::vector<Index> cut_degree(const Surface& S, const State& st) {
  std::vector<Index> deg(static_cast<std::size_t>(S.nv()), 0);
  for (Index e = 0; e < S.topo.num_edges; ++e)
    if (st.cut[e]) {
      ++deg[S.topo.edge_vertices[2 * e]];
      ++deg[S.topo.edge_vertices[2 * e + 1]];
    }
  return deg;
}

/// Drops nodes that left the cut graph (vertices with no cut edge) and interior vertices left
/// with two cut edges, which are points on one path: their two sides join into one letter, so a
/// move that takes a branch point down to degree 2 merges its corner class at once. `keep` (the
/// base) stays a node.
void cleanup_nodes(const Surface& S, State& st, Index keep) {
  const std::vector<Index> deg = cut_degree(S, st);
  for (Index v = 0; v < S.nv(); ++v)
    if (st.node[v] && v != keep && (deg[v] == 0 || (deg[v] == 2 && S.vertex_loop[v] < 0))) st.node[v] = 0;
}

// ---- paths inside the disk, and refinement ------------------------------------------------------

/// How refine() says so (CutResult::refinement_bound is read from the reason).
constexpr std::string_view kRefinementBound = "refinement: the paths would add more than ";

struct PathSearch {
  double cost = kInf;        ///< weighted length (with the refinement penalty)
  Index virtual_points = 0;  ///< points a refinement would add
  /// The path's nodes in the disk's search graph: R vertices (< #V_R), then face centroids
  /// (#V_R + f), then edge midpoints (#V_R + #F_R + e).
  std::vector<Index> nodes;
  std::vector<Index> path;   ///< surface vertices (after realize_path())
  bool refined = false;
  bool ok = false;
  std::string why;
};

/// Refines S: every face in `fan_faces` gets a vertex at its centroid (and is fan-triangulated
/// from it), every edge in `split_corners` (given by a corner opposite it; both its faces must be
/// in fan_faces) gets a vertex at its midpoint. Returns the new vertex of each face / edge.
bool refine(Surface& S, const std::vector<Index>& fan_faces, const std::vector<Index>& split_corners,
            std::vector<Index>& centroid, std::vector<Index>& mid, SurfaceUndo& undo, std::string* why) {
  centroid.clear();
  mid.clear();
  // Each path refines the faces it crosses; paths that keep crossing refined faces (many moves at a
  // high genus) would grow the surface without bound. Past S.max_refined_per_face added vertices
  // per input face (and 65536) the cut stops with a message instead.
  const std::size_t input_faces = S.input != nullptr ? static_cast<std::size_t>(S.input->num_faces()) : S.faces.size() / 3;
  const double bound = S.max_refined_per_face * static_cast<double>(input_faces) + 65536;
  if (static_cast<double>(S.rec_face.size() + fan_faces.size() + split_corners.size()) > bound) {
    char per[32];
    std::snprintf(per, sizeof per, "%g", S.max_refined_per_face);
    *why = std::string(kRefinementBound) + per + " vertices per input face (and 65536; " +
           std::to_string(S.rec_face.size()) + " added so far)";
    return false;
  }
  std::unordered_map<Index, Index> mid_of_edge;  // surface edge -> midpoint vertex
  for (Index c : split_corners) {
    const Index f = corner_face(c);
    const std::array<Index, 2> ev = {S.faces[next_corner(c)], S.faces[prev_corner(c)]};
    std::array<double, 3> bary;
    if (!average_in_face(S, S.face_origin[f], ev, bary)) {
      *why = "refinement: an edge is outside its input face";
      return false;
    }
    mid.push_back(add_vertex(S, S.face_origin[f], bary));
    mid_of_edge[S.topo.corner_edge[c]] = mid.back();
  }
  for (Index f : fan_faces) {
    const std::array<Index, 3> fv = {S.faces[3 * f], S.faces[3 * f + 1], S.faces[3 * f + 2]};
    std::array<double, 3> bary;
    if (!average_in_face(S, S.face_origin[f], fv, bary)) {
      *why = "refinement: a vertex is outside its input face";
      return false;
    }
    centroid.push_back(add_vertex(S, S.face_origin[f], bary));
  }
  for (Index f : fan_faces) undo.split.push_back({f, {S.faces[3 * f], S.faces[3 * f + 1], S.faces[3 * f + 2]}});
  for (std::size_t i = 0; i < fan_faces.size(); ++i) {
    const Index f = fan_faces[i];
    std::vector<Index> poly;
    for (int k = 0; k < 3; ++k) {
      poly.push_back(S.faces[3 * f + k]);
      const Index e = S.topo.corner_edge[3 * f + (k + 2) % 3];  // the edge from corner k to corner k+1
      const auto it = mid_of_edge.find(e);
      if (it != mid_of_edge.end()) poly.push_back(it->second);
    }
    const Index origin = S.face_origin[f];
    for (std::size_t j = 0; j < poly.size(); ++j) {
      const std::array<Index, 3> tri = {poly[j], poly[(j + 1) % poly.size()], centroid[i]};
      if (j == 0) {
        for (int k = 0; k < 3; ++k) S.faces[3 * f + k] = tri[k];
      } else {
        S.faces.insert(S.faces.end(), tri.begin(), tri.end());
        S.face_origin.push_back(origin);
      }
    }
  }
  TopologyResult tr = build_topology(S.faces, S.n_input + static_cast<Index>(S.rec_face.size()));
  if (tr.status != Status::Ok) {
    *why = "refinement produced an invalid surface: " + tr.message;
    return false;
  }
  undo.topo = std::move(S.topo);
  undo.took_topo = true;
  S.topo = std::move(tr.topology);
  return true;
}

/// Hop distance of every vertex of R from R's boundary. Paths pay more near the boundary, so they
/// keep away from the cut and do not leave one-face-wide corridors for later moves.
void boundary_hops(const Disk& R, std::vector<Index>& hops, std::vector<Index>& queue) {
  const Topology& rt = R.topo;
  hops.assign(static_cast<std::size_t>(rt.num_vertices), kInvalid);
  queue.clear();
  for (Index v = 0; v < rt.num_vertices; ++v)
    if (rt.is_boundary_vertex(v)) {
      hops[v] = 0;
      queue.push_back(v);
    }
  for (std::size_t qi = 0; qi < queue.size(); ++qi) {
    const Index u = queue[qi];
    for (Index k = rt.vertex_corner_offsets[u]; k < rt.vertex_corner_offsets[u + 1]; ++k) {
      const Index w = R.faces[next_corner(rt.vertex_corners[k])];
      if (hops[w] == kInvalid) {
        hops[w] = hops[u] + 1;
        queue.push_back(w);
      }
    }
  }
}

/// What a search reads of one R vertex, in one place (one cache line): its 3D point (zeros
/// without positions) and its hops from R's boundary (boundary_hops(); 0 on the boundary).
struct SearchVertex {
  double p[3];
  Index hops;
};

/// The search vertices of R (rebuilt with R) into `out`; `hops`, `queue`: boundary_hops()'s
/// buffers, kept by the caller like `out`.
void search_vertices(const Surface& S, const Disk& R, std::vector<SearchVertex>& out, std::vector<Index>& hops,
                     std::vector<Index>& queue) {
  boundary_hops(R, hops, queue);
  out.resize(hops.size());
  for (std::size_t v = 0; v < hops.size(); ++v) {
    SearchVertex& x = out[v];
    for (int d = 0; d < 3; ++d) x.p[d] = S.has_pos ? S.pos[3 * static_cast<std::size_t>(R.to_surface[v]) + d] : 0.0;
    x.hops = hops[v];
  }
}

/// Buffers of search_path(), kept from one search to the next: a search touches only the nodes
/// it reaches and resets them before it returns, so large meshes get no fresh pages per search.
struct SearchWork {
  std::vector<double> dist;  ///< kInf between searches
  std::vector<Index> prev;   ///< set wherever dist is (sources: kInvalid), read only there
  std::vector<Index> touched;
  std::vector<std::uint8_t> flags;  ///< per R vertex: kSource | kTarget; 0 between searches
  std::vector<std::pair<double, Index>> heap;
  static constexpr std::uint8_t kSource = 1, kTarget = 2;
};

/// The graph search_path() runs on: R's vertices (nodes < n), then face centroids (n + f), then
/// edge midpoints (n + #F_R + e), with their 3D points and the cost factor near R's boundary.
struct SearchGraph {
  const Disk& R;
  const std::vector<SearchVertex>& V;  ///< search_vertices(S, R)
  bool has_pos = false;

  Index n() const { return R.topo.num_vertices; }
  Index nf() const { return R.topo.num_faces; }
  bool on_boundary(Index v) const { return V[v].hops == 0; }
  /// The 3D point of a node (zeros without positions).
  void point(Index node, std::array<double, 3>& p) const {
    p = {0, 0, 0};
    if (!has_pos) return;
    if (node < n()) {
      for (int d = 0; d < 3; ++d) p[d] = V[node].p[d];
    } else if (node < n() + nf()) {
      const Index f = node - n();
      for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d) p[d] += V[R.faces[3 * f + k]].p[d] / 3;
    } else {
      const Index e = node - n() - nf();
      const Index c = R.topo.edge_corners[2 * e];
      for (int d = 0; d < 3; ++d) p[d] = 0.5 * (V[R.faces[next_corner(c)]].p[d] + V[R.faces[prev_corner(c)]].p[d]);
    }
  }
  /// 1 + 30/h² for a node h hops from the boundary; virtual points (centroids, midpoints) sit half
  /// a hop further in than their vertices.
  double factor(Index w) const {
    double h = 0;
    if (w < n()) {
      h = V[w].hops;
      if (h <= 0) return 1.0;
    } else if (w < n() + nf()) {
      for (int k = 0; k < 3; ++k) h = std::max(h, static_cast<double>(V[R.faces[3 * (w - n()) + k]].hops));
      h += 0.5;
    } else {
      const Index c = R.topo.edge_corners[2 * (w - n() - nf())];
      h = 0.5 + std::max(V[R.faces[next_corner(c)]].hops, V[R.faces[prev_corner(c)]].hops);
    }
    return 1.0 + 30.0 / (h * h);
  }
};

/// Whether an edge path can exist: an interior edge leaves some source, and one enters some
/// target (else only the extended graph can join them). `flags`: SearchWork::flags of this search.
bool edge_path_possible(const SearchGraph& G, const std::vector<Index>& sources, const std::vector<Index>& targets,
                        const std::vector<std::uint8_t>& flags) {
  const Topology& rt = G.R.topo;
  auto has_free_edge = [&](Index u, bool to_target) {
    for (Index k = rt.vertex_corner_offsets[u]; k < rt.vertex_corner_offsets[u + 1]; ++k) {
      const Index c = rt.vertex_corners[k];
      for (int side = 0; side < 2; ++side) {
        const Index ec = side == 0 ? prev_corner(c) : next_corner(c);
        const Index w = G.R.faces[side == 0 ? next_corner(c) : prev_corner(c)];
        if (rt.opposite[ec] == kInvalid) continue;
        if (!G.on_boundary(w) || (flags[w] & (to_target ? SearchWork::kSource : SearchWork::kTarget)) != 0) return true;
      }
    }
    return false;
  };
  bool out_of_sources = false;
  for (Index a : sources) out_of_sources |= has_free_edge(a, false);
  if (!out_of_sources) return false;
  for (Index v : targets)
    if ((flags[v] & SearchWork::kSource) == 0 && has_free_edge(v, true)) return true;
  return false;
}

/// The ball A* aims at: the targets' centroid and their largest distance from it (a hair more).
/// A path's cost is at least its 3D length (factors ≥ 1, penalties ≥ 0), so the distance to this
/// ball never overestimates what is left. Without positions it is 0 everywhere (Dijkstra).
struct TargetBall {
  bool used = false;
  std::array<double, 3> c = {0, 0, 0};
  double r = 0;
  double ahead(const std::array<double, 3>& p) const {
    if (!used) return 0.0;
    const double dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2];
    return std::max(0.0, std::sqrt(dx * dx + dy * dy + dz * dz) - r);
  }
};

/// `targets`: distinct R vertices in increasing order.
TargetBall target_ball(const SearchGraph& G, const std::vector<Index>& targets) {
  TargetBall ball;
  if (!G.has_pos) return ball;
  ball.used = true;
  for (Index v : targets)
    for (int d = 0; d < 3; ++d) ball.c[d] += G.V[v].p[d];
  if (!targets.empty())
    for (double& x : ball.c) x /= static_cast<double>(targets.size());
  for (Index v : targets) {
    double r2 = 0;
    for (int d = 0; d < 3; ++d) r2 += (G.V[v].p[d] - ball.c[d]) * (G.V[v].p[d] - ball.c[d]);
    ball.r = std::max(ball.r, std::sqrt(r2));
  }
  ball.r *= 1 + 1e-12;
  return ball;
}

/// The cheapest path inside the disk R from one of `sources` to one of `targets` (R vertices;
/// search_vertices() in V), touching R's boundary only at its ends; R is not changed. First the
/// shortest edge path; only when none exists, the shortest path in the graph extended by face
/// centroids and edge midpoints (each extra point costs a penalty, so as few faces as possible
/// are refined). The search stops past `bound` (then ok is false). It is A* towards the smallest
/// ball around the targets (centroid, largest distance): every edge costs at least its 3D length,
/// so the 3D distance to that ball never overestimates what is left and the path found is a
/// cheapest one, only sooner (on a genus-1 grid of 1M faces it touches 0.3–0.6 of the nodes
/// Dijkstra's order touched). realize_path() turns the result into surface vertices.
PathSearch search_path(const Surface& S, const Disk& R, const std::vector<SearchVertex>& V,
                       const std::vector<Index>& sources, std::vector<Index> targets, SearchWork& work,
                       double bound = kInf) {
  PathSearch out;
  const Topology& rt = R.topo;
  const Index n = rt.num_vertices, nf = rt.num_faces;
  std::sort(targets.begin(), targets.end());
  targets.erase(std::unique(targets.begin(), targets.end()), targets.end());
  std::vector<std::uint8_t>& flags = work.flags;
  if (flags.size() < static_cast<std::size_t>(n)) flags.resize(static_cast<std::size_t>(n), 0);
  for (Index a : sources) flags[a] |= SearchWork::kSource;
  for (Index t : targets) flags[t] |= SearchWork::kTarget;
  struct ClearFlags {
    std::vector<std::uint8_t>& flags;
    const std::vector<Index>& sources;
    const std::vector<Index>& targets;
    ~ClearFlags() {
      for (Index a : sources) flags[a] = 0;
      for (Index t : targets) flags[t] = 0;
    }
  } clear_flags{flags, sources, targets};
  const SearchGraph G{R, V, S.has_pos};
  const double penalty = 20 * S.mean_length;
  const bool edge_possible = edge_path_possible(G, sources, targets, flags);
  const TargetBall ball = target_ball(G, targets);
  for (int phase = edge_possible ? 0 : 1; phase < 2; ++phase) {
    const bool extended = phase == 1;
    const Index total = extended ? n + nf + rt.num_edges : n;
    if (work.dist.size() < static_cast<std::size_t>(total)) {
      work.dist.resize(static_cast<std::size_t>(total), kInf);
      work.prev.resize(static_cast<std::size_t>(total), kInvalid);
    }
    std::vector<double>& dist = work.dist;
    std::vector<Index>& prev = work.prev;
    std::vector<Index>& touched = work.touched;
    touched.clear();
    // A binary heap of (distance, node), smallest first (as std::priority_queue keeps it).
    using Item = std::pair<double, Index>;
    std::vector<Item>& heap = work.heap;
    heap.clear();
    const std::greater<Item> later;
    auto push = [&](double d, Index v) {
      heap.push_back({d, v});
      std::push_heap(heap.begin(), heap.end(), later);
    };
    for (Index a : sources) {
      if (dist[a] == kInf) touched.push_back(a);
      dist[a] = 0;
      prev[a] = kInvalid;
      push(0.0, a);
    }
    Index found = kInvalid;
    std::array<double, 3> pu, pw;
    auto relax = [&](Index u, Index w, double d) {
      double len = 1;
      if (G.has_pos) {
        G.point(w, pw);
        len = std::sqrt((pu[0] - pw[0]) * (pu[0] - pw[0]) + (pu[1] - pw[1]) * (pu[1] - pw[1]) +
                        (pu[2] - pw[2]) * (pu[2] - pw[2]));
      }
      const double nd = d + len * G.factor(w) + (w >= n ? penalty : 0);
      if (nd < dist[w]) {
        if (dist[w] == kInf) touched.push_back(w);
        dist[w] = nd;
        prev[w] = u;
        push(nd + ball.ahead(pw), w);
      }
    };
    // Not a source, and a target or off R's boundary.
    auto vertex_ok = [&](Index w) {
      const std::uint8_t f = flags[w];
      return (f & SearchWork::kSource) == 0 && ((f & SearchWork::kTarget) != 0 || !G.on_boundary(w));
    };
    // Only faces touching the boundary get virtual points: a face whose corners are all
    // interior is crossed through its corners just as well (this keeps the search small).
    auto touches_boundary = [&](Index f) {
      return G.on_boundary(R.faces[3 * f]) || G.on_boundary(R.faces[3 * f + 1]) || G.on_boundary(R.faces[3 * f + 2]);
    };
    while (!heap.empty()) {
      std::pop_heap(heap.begin(), heap.end(), later);
      const auto [key, u] = heap.back();
      heap.pop_back();
      if (G.has_pos) G.point(u, pu);
      const double d = dist[u];
      if (key > d + ball.ahead(pu)) continue;  // a stale entry
      if (key > bound) break;
      if (u < n) {
        const std::uint8_t fu = flags[u];
        if ((fu & SearchWork::kTarget) != 0 && (fu & SearchWork::kSource) == 0) {
          found = u;
          break;
        }
        if ((fu & SearchWork::kSource) == 0 && G.on_boundary(u)) continue;
        // Every interior edge at u is the clockwise edge (u, next(c)) of exactly one corner c
        // of u's fan; ties pop in (distance, node) order, so the order of relaxation is moot.
        for (Index k = rt.vertex_corner_offsets[u]; k < rt.vertex_corner_offsets[u + 1]; ++k) {
          const Index c = rt.vertex_corners[k];
          if (rt.opposite[prev_corner(c)] != kInvalid && vertex_ok(R.faces[next_corner(c)]))
            relax(u, R.faces[next_corner(c)], d);
          if (extended && touches_boundary(corner_face(c))) relax(u, n + corner_face(c), d);
        }
      } else if (u < n + nf) {
        const Index f = u - n;
        for (int k = 0; k < 3; ++k) {
          const Index c = 3 * f + k;
          if (vertex_ok(R.faces[c])) relax(u, R.faces[c], d);
          if (rt.opposite[c] != kInvalid && touches_boundary(corner_face(rt.opposite[c])))
            relax(u, n + nf + rt.corner_edge[c], d);
        }
      } else {
        const Index e = u - n - nf;
        relax(u, n + corner_face(rt.edge_corners[2 * e]), d);
        relax(u, n + corner_face(rt.edge_corners[2 * e + 1]), d);
      }
    }
    if (found != kInvalid) {
      for (Index v = found; v != kInvalid; v = prev[v]) out.nodes.push_back(v);
      std::reverse(out.nodes.begin(), out.nodes.end());
      out.cost = dist[found];
      for (Index v : out.nodes) out.virtual_points += v >= n ? 1 : 0;
      out.ok = true;
    }
    for (Index v : touched) dist[v] = kInf;
    if (out.ok) return out;
  }
  out.why = "no path inside the disk";
  return out;
}

/// The surface vertices of a found path (ps.path). A path through face centroids or edge
/// midpoints refines S exactly there first (which invalidates R); `undo` then receives what a caller
/// needs to undo the refinement (SurfaceUndo::restore()).
bool realize_path(Surface& S, const Disk& R, PathSearch& ps, std::optional<SurfaceUndo>& undo) {
  const Index n = R.topo.num_vertices, nf = R.topo.num_faces;
  ps.path.clear();
  if (ps.virtual_points == 0) {
    for (Index v : ps.nodes) ps.path.push_back(R.to_surface[v]);
    return true;
  }
  std::vector<Index> fan_faces, split_corners;
  for (Index v : ps.nodes) {
    if (v >= n && v < n + nf) fan_faces.push_back(v - n);
    if (v >= n + nf) split_corners.push_back(R.topo.edge_corners[2 * (v - n - nf)]);
  }
  undo.emplace(S);
  std::vector<Index> centroid, mid;
  if (!refine(S, fan_faces, split_corners, centroid, mid, *undo, &ps.why)) return false;
  std::size_t fi = 0, ei = 0;
  for (Index v : ps.nodes) {
    if (v < n)
      ps.path.push_back(R.to_surface[v]);
    else if (v < n + nf)
      ps.path.push_back(centroid[fi++]);
    else
      ps.path.push_back(mid[ei++]);
  }
  ps.refined = true;
  return true;
}

/// Sets the cut flags from vertex pairs (after a refinement renumbered the edges).
bool set_cut(const Surface& S, State& st, const std::vector<Pair>& pairs, bool value) {
  for (const auto& [u, v] : pairs) {
    const Index e = S.topo.edge_between(u, v);
    if (e == kInvalid) return false;
    st.cut[e] = value ? 1 : 0;
  }
  return true;
}

std::vector<Pair> path_pairs(const std::vector<Index>& path) {
  std::vector<Pair> out;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) out.push_back({path[i], path[i + 1]});
  return out;
}

// ---- the driver state ---------------------------------------------------------------------------

struct Cutter {
  Surface S;
  State st;
  Disk R;
  Polygon P;
  Index base = kInvalid;  ///< class P of the polygon schema (an interior vertex), or the arcs' origin
  Index outer_hint = kInvalid;
  Index moves = 0, refinements = 0;
  std::string error;  ///< internal failure

  std::vector<SearchVertex> verts;  ///< search_vertices(S, R)
  std::vector<Index> hops, queue;   ///< search_vertices()'s buffers
  SearchWork work;

  bool rebuild() {
    build_disk(S, st.cut, R);
    if (!R.ok) {
      error = "the cut surface is not a manifold";
      return false;
    }
    search_vertices(S, R, verts, hops, queue);
    P = read_polygon(S, st, R, outer_hint);
    if (!P.ok) {
      error = P.why;
      return false;
    }
    if (R.topo.num_components != 1) {
      error = "the cut surface is not connected";
      return false;
    }
    if (R.topo.euler_characteristic() != 1 - static_cast<std::int64_t>(P.holes.size())) {
      error = "the cut surface is not a disk with holes";
      return false;
    }
    return true;
  }

  /// Cut along a path from `sources` to `targets` (R vertices) and un-cut the edges `glue`
  /// (surface vertex pairs). `found`: the search's result when the caller has it already (the
  /// same sources and targets on the current disk). On failure the state is restored and false
  /// returned.
  bool cut_paste(const std::vector<Index>& sources, const std::vector<Index>& targets,
                 const std::vector<Pair>& glue, std::vector<Index>* path_out, std::string* why,
                 PathSearch* found = nullptr) {
    const State st_saved = st;
    std::optional<SurfaceUndo> S_saved;  // how to undo a refinement of S
    auto restore = [&](const std::string& m) {
      if (S_saved) S_saved->restore(S);
      st = st_saved;
      *why = m;
      rebuild();
      return false;
    };
    PathSearch own;
    if (!found) {
      own = search_path(S, R, verts, sources, targets, work);
      found = &own;
    }
    PathSearch& ps = *found;
    if (!ps.ok) return restore(ps.why);
    const std::vector<Pair> before = cut_pairs(S, st);
    if (!realize_path(S, R, ps, S_saved)) return restore(ps.why);
    if (ps.refined) {
      ++refinements;
      st.cut.assign(static_cast<std::size_t>(S.topo.num_edges), 0);
      st.node.resize(static_cast<std::size_t>(S.nv()), 0);
      if (!set_cut(S, st, before, true)) return restore("refinement lost a cut edge");
    }
    if (!set_cut(S, st, glue, false)) return restore("a reglued side is not an edge path");
    if (!set_cut(S, st, path_pairs(ps.path), true)) return restore("a cut path is not an edge path");
    st.node[ps.path.front()] = 1;
    st.node[ps.path.back()] = 1;
    cleanup_nodes(S, st, base);
    ++moves;
    if (!rebuild()) return restore("move broke the disk: " + error);
    if (path_out) *path_out = ps.path;
    return true;
  }

  std::vector<Pair> side_pairs(Index s) const { return path_pairs(side_surface_vertices(P, R, s)); }

  /// Removes a spur branch (cancellation x x^-1).
  bool cancel(Index token, std::string* why) {
    const State st_saved = st;  // S does not change
    set_cut(S, st, side_pairs(P.tok_side[token]), false);
    cleanup_nodes(S, st, base);
    if (!rebuild()) {
      st = st_saved;
      *why = "cancellation broke the disk: " + error;
      rebuild();
      return false;
    }
    return true;
  }
};

/// Number of disjoint commutator blocks u v u^-1 v^-1 found by a greedy cyclic scan, and the
/// per-token flags.
Index commutator_blocks(const Polygon& P, std::vector<char>& done) {
  const Index n = P.ntok();
  done.assign(static_cast<std::size_t>(n), 0);
  Index blocks = 0;
  if (n < 4) return 0;
  std::vector<Index> count(static_cast<std::size_t>(P.num_letters), 0);
  for (Index t = 0; t < n; ++t) ++count[P.tok_letter[t]];
  for (Index t = 0; t < n; ++t) {
    const Index i0 = t, i1 = (t + 1) % n, i2 = (t + 2) % n, i3 = (t + 3) % n;
    if (done[i0] || done[i1] || done[i2] || done[i3]) continue;
    const Index u = P.tok_letter[i0], v = P.tok_letter[i1];
    if (u == v || P.tok_letter[i2] != u || P.tok_letter[i3] != v) continue;
    if (P.tok_sign[i2] != -P.tok_sign[i0] || P.tok_sign[i3] != -P.tok_sign[i1]) continue;
    done[i0] = done[i1] = done[i2] = done[i3] = 1;
    ++blocks;
  }
  return blocks;
}

/// Rotation r such that the whole word is commutator blocks starting at token r, or -1.
Index canonical_rotation(const Polygon& P) {
  const Index n = P.ntok();
  if (n == 0 || n % 4 != 0) return -1;
  for (Index r = 0; r < n; ++r) {
    bool ok = true;
    std::vector<char> seen(static_cast<std::size_t>(P.num_letters), 0);
    for (Index k = 0; k < n && ok; k += 4) {
      const Index i0 = (r + k) % n, i1 = (r + k + 1) % n, i2 = (r + k + 2) % n, i3 = (r + k + 3) % n;
      const Index u = P.tok_letter[i0], v = P.tok_letter[i1];
      ok = u != v && !seen[u] && !seen[v] && P.tok_letter[i2] == u && P.tok_letter[i3] == v &&
           P.tok_sign[i2] == -P.tok_sign[i0] && P.tok_sign[i3] == -P.tok_sign[i1];
      if (ok) seen[u] = seen[v] = 1;
    }
    if (ok) return r;
  }
  return -1;
}

// ---- tree–cotree ---------------------------------------------------------------------------------

struct UnionFind {
  std::vector<Index> p;
  explicit UnionFind(Index n) : p(static_cast<std::size_t>(n)) { std::iota(p.begin(), p.end(), 0); }
  Index find(Index x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
  }
  bool unite(Index a, Index b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b) std::swap(a, b);
    p[a] = b;
    return true;
  }
};

/// Tree–cotree on Ŝ; sets st.cut to the pruned cut graph and returns the Ŝ distances.
bool tree_cotree(Surface& S, State& st, Index root, std::span<const double> weights, Index genus,
                 std::vector<double>& dhat, std::string* why) {
  const Topology& t = S.topo;
  const Index V = t.num_vertices, E = t.num_edges, F = t.num_faces;
  const Index N = V + t.num_boundary_loops();
  // Each edge's weight once (a 3D length unless weights are given).
  std::vector<double> edge_weight;
  if (weights.empty()) {
    edge_weight.resize(static_cast<std::size_t>(E));
    for (Index e = 0; e < E; ++e) edge_weight[e] = S.length(t.edge_vertices[2 * e], t.edge_vertices[2 * e + 1]);
    weights = edge_weight;
  }
  auto w = [&](Index e) { return weights[e]; };
  auto interior = [&](Index e) { return t.edge_corners[2 * e + 1] != kInvalid; };
  // Ŝ adjacency (CSR) over interior edges that are not self-loops.
  std::vector<Index> off(static_cast<std::size_t>(N) + 1, 0);
  for (Index e = 0; e < E; ++e) {
    if (!interior(e)) continue;
    const Index a = S.cls(t.edge_vertices[2 * e]), b = S.cls(t.edge_vertices[2 * e + 1]);
    if (a == b) continue;
    ++off[a + 1];
    ++off[b + 1];
  }
  for (Index i = 0; i < N; ++i) off[i + 1] += off[i];
  std::vector<Index> adj(static_cast<std::size_t>(off[N])), fill(off.begin(), off.end() - 1);
  for (Index e = 0; e < E; ++e) {
    if (!interior(e)) continue;
    const Index a = S.cls(t.edge_vertices[2 * e]), b = S.cls(t.edge_vertices[2 * e + 1]);
    if (a == b) continue;
    adj[fill[a]++] = e;
    adj[fill[b]++] = e;
  }
  dhat.assign(static_cast<std::size_t>(N), kInf);
  std::vector<Index> parent_edge(static_cast<std::size_t>(N), kInvalid);
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> pq;
  const Index r = S.cls(root);
  dhat[r] = 0;
  pq.push({0.0, r});
  while (!pq.empty()) {
    const auto [d, u] = pq.top();
    pq.pop();
    if (d > dhat[u]) continue;
    for (Index k = off[u]; k < off[u + 1]; ++k) {
      const Index e = adj[k];
      const Index a = S.cls(t.edge_vertices[2 * e]), b = S.cls(t.edge_vertices[2 * e + 1]);
      const Index x = a == u ? b : a;
      const double nd = d + w(e);
      if (nd < dhat[x] || (nd == dhat[x] && parent_edge[x] != kInvalid && e < parent_edge[x] && x != r)) {
        if (nd < dhat[x]) pq.push({nd, x});
        dhat[x] = nd;
        parent_edge[x] = e;
      }
    }
  }
  std::vector<char> in_tree(static_cast<std::size_t>(E), 0);
  for (Index x = 0; x < N; ++x)
    if (parent_edge[x] != kInvalid) in_tree[parent_edge[x]] = 1;
  // Dual tree by descending loop length (ties: the smaller edge first), sorted as packed pairs.
  std::vector<std::pair<double, Index>> cand;
  for (Index e = 0; e < E; ++e) {
    if (!interior(e) || in_tree[e]) continue;
    cand.emplace_back(dhat[S.cls(t.edge_vertices[2 * e])] + w(e) + dhat[S.cls(t.edge_vertices[2 * e + 1])], e);
  }
  // Edges are distinct, so the order is total and the parallel sort's result is std::sort's.
  __gnu_parallel::sort(cand.begin(), cand.end(), [](const std::pair<double, Index>& a, const std::pair<double, Index>& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  UnionFind uf(F);
  std::vector<char> cut(static_cast<std::size_t>(E), 0);
  Index leftover = 0;
  for (const auto& [loop_length, e] : cand) {
    const Index f0 = corner_face(t.edge_corners[2 * e]), f1 = corner_face(t.edge_corners[2 * e + 1]);
    if (!uf.unite(f0, f1)) {
      cut[e] = 1;
      ++leftover;
    }
  }
  if (leftover != 2 * genus) {
    *why = "tree-cotree left " + std::to_string(leftover) + " edges for genus " + std::to_string(genus);
    return false;
  }
  for (Index e = 0; e < E; ++e)
    if (in_tree[e]) cut[e] = 1;
  // Prune leaves of the cut graph in Ŝ.
  std::vector<Index> deg(static_cast<std::size_t>(N), 0);
  for (Index e = 0; e < E; ++e)
    if (cut[e]) {
      ++deg[S.cls(t.edge_vertices[2 * e])];
      ++deg[S.cls(t.edge_vertices[2 * e + 1])];
    }
  std::vector<Index> stack;
  for (Index x = 0; x < N; ++x)
    if (deg[x] == 1) stack.push_back(x);
  while (!stack.empty()) {
    const Index x = stack.back();
    stack.pop_back();
    if (deg[x] != 1) continue;
    for (Index k = off[x]; k < off[x + 1]; ++k) {
      const Index e = adj[k];
      if (!cut[e]) continue;
      cut[e] = 0;
      const Index a = S.cls(t.edge_vertices[2 * e]), b = S.cls(t.edge_vertices[2 * e + 1]);
      const Index y = a == x ? b : a;
      --deg[x];
      if (--deg[y] == 1) stack.push_back(y);
      break;
    }
  }
  st.cut = std::move(cut);
  return true;
}

std::string label(const std::string& name, int orientation) {
  return orientation < 0 ? name + "^-1" : name;
}

// ---- the stages of cut_surface() -----------------------------------------------------------------

/// What the stages leave for the outputs: the side the word starts with (its first directed
/// edge), the arcs' first edges and boundary loops, and whether the word is canonical (else why
/// not).
struct CutNames {
  Pair anchor_edge{kInvalid, kInvalid};
  std::vector<Pair> arc_first;
  std::vector<Index> arc_loop;
  bool word_canonical = false;
  std::string reason;
};

/// The cutter before any cut: the surface is the input (its boundary loops and mean edge length
/// noted), no edge is cut.
void start_cutter(Cutter& C, const Mesh& mesh, const Topology& topo) {
  const Index V = topo.num_vertices;
  Surface& S = C.S;
  S.input = &mesh;
  S.n_input = V;
  S.has_pos = !mesh.positions.empty();
  S.pos = mesh.positions;
  S.faces = mesh.faces;
  S.face_origin.resize(static_cast<std::size_t>(topo.num_faces));
  std::iota(S.face_origin.begin(), S.face_origin.end(), 0);
  S.vertex_loop.assign(static_cast<std::size_t>(V), -1);
  for (Index L = 0; L < topo.num_boundary_loops(); ++L)
    for (Index k = topo.boundary_offsets[L]; k < topo.boundary_offsets[L + 1]; ++k)
      S.vertex_loop[topo.boundary_vertices[k]] = L;
  S.topo = topo;
  if (S.has_pos && topo.num_edges > 0) {
    double sum = 0;
    for (Index e = 0; e < topo.num_edges; ++e)
      sum += S.length(topo.edge_vertices[2 * e], topo.edge_vertices[2 * e + 1]);
    S.mean_length = sum > 0 ? sum / topo.num_edges : 1;
  }
  C.st.cut.assign(static_cast<std::size_t>(topo.num_edges), 0);
  C.st.node.assign(static_cast<std::size_t>(V), 0);
}

/// Closed genus 0: a slit along two edges x–y–z from the base x (one edge would not open: its two
/// sides would join the same two vertices), each the shortest available. False on an internal
/// error (C.error).
bool slit_sphere(Cutter& C, const CutOptions& options, Index x, CutNames& names) {
  const Topology& topo = C.S.topo;
  auto shortest = [&](Index from, Index avoid, Index* to) {
    Index best = kInvalid;
    double best_len = kInf;
    for (Index k = topo.vertex_corner_offsets[from]; k < topo.vertex_corner_offsets[from + 1]; ++k) {
      const Index c = topo.vertex_corners[k];
      const Index e = topo.corner_edge[prev_corner(c)];
      const Index z = topo.corner_vertex[next_corner(c)];
      if (z == avoid) continue;
      const double l = options.edge_weights.empty() ? C.S.length(from, z) : options.edge_weights[e];
      if (l < best_len || (l == best_len && e < best)) {
        best_len = l;
        best = e;
        *to = z;
      }
    }
    return best;
  };
  Index other = kInvalid, third = kInvalid;
  C.st.cut[shortest(x, kInvalid, &other)] = 1;
  C.st.cut[shortest(other, x, &third)] = 1;
  C.st.node[x] = 1;
  C.st.node[third] = 1;
  C.base = x;
  if (!C.rebuild()) return false;
  names.anchor_edge = {x, other};
  names.word_canonical = true;
  return true;
}

/// Genus 0 with boundary: the base moves to the boundary vertex nearest to it (Dijkstra on the
/// surface), where the arcs to the other loops will start. False on an internal error (C.error).
bool base_on_boundary(Cutter& C, const CutOptions& options, Index& x, CutNames& names) {
  const Surface& S = C.S;
  const Topology& topo = S.topo;
  Index w0 = x;
  if (S.vertex_loop[x] < 0) {
    std::vector<double> d(static_cast<std::size_t>(topo.num_vertices), kInf);
    using Item = std::pair<double, Index>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> pq;
    d[x] = 0;
    pq.push({0.0, x});
    w0 = kInvalid;
    while (!pq.empty()) {
      const auto [dd, u] = pq.top();
      pq.pop();
      if (dd > d[u]) continue;
      if (S.vertex_loop[u] >= 0) {
        w0 = u;
        break;
      }
      for (Index k = topo.vertex_corner_offsets[u]; k < topo.vertex_corner_offsets[u + 1]; ++k) {
        const Index c = topo.vertex_corners[k];
        const Index z = topo.corner_vertex[next_corner(c)];
        const double l = options.edge_weights.empty()
                             ? S.length(u, z)
                             : options.edge_weights[topo.corner_edge[prev_corner(c)]];
        if (dd + l < d[z]) {
          d[z] = dd + l;
          pq.push({d[z], z});
        }
      }
    }
    if (w0 == kInvalid) {
      C.error = "no boundary vertex reachable";
      return false;
    }
  }
  C.st.node[w0] = 1;
  C.base = w0;
  C.outer_hint = w0;
  x = w0;
  // the boundary edge leaving w0 along its loop
  const Index L = S.vertex_loop[w0];
  for (Index k = topo.boundary_offsets[L]; k < topo.boundary_offsets[L + 1]; ++k)
    if (topo.boundary_vertices[k] == w0) {
      const Index nk = k + 1 < topo.boundary_offsets[L + 1] ? k + 1 : topo.boundary_offsets[L];
      names.anchor_edge = {w0, topo.boundary_vertices[nk]};
    }
  if (!C.rebuild()) return false;
  names.word_canonical = true;
  return true;
}

/// The polygon's candidate moves are tried in order of a cheap proxy (the length of the sides the
/// path replaces), so that the first bound is tight and later searches stop early; at most this
/// many are searched per move.
constexpr Index kCandidates = 12;

struct Candidate {
  Index proxy, t, ja, tb;
  bool after;
};

/// The cheapest path between two corners of the polygon (by their anchors), or none past `bound`.
PathSearch corner_path(Cutter& C, Index alpha, Index beta, double bound) {
  const Polygon& Pg = C.P;
  return search_path(C.S, C.R, C.verts, Pg.corner_anchor[alpha], Pg.corner_anchor[beta], C.work, bound);
}

enum class Move { Made, NoneNeeded, Failed };

/// Step (B), one vertex class: among the corners of another class next to a base corner, the move
/// whose path is cheapest (fewest refined points, then shortest) cuts that corner off and reglues
/// it. NoneNeeded when every corner is in the base's class; Failed with `reason`.
Move merge_corner_class(Cutter& C, std::string& reason) {
  const Polygon& Pg = C.P;
  const Index n = Pg.ntok();
  auto tok_len = [&](Index t) { return Pg.side_len[Pg.tok_side[t]]; };
  std::vector<Candidate> cands;
  bool any_other = false;
  for (Index t = 0; t < n; ++t) {
    if (Pg.corner_class[t] == C.base) continue;
    any_other = true;
    for (int side = 0; side < 2; ++side) {
      const bool after = side == 0;
      if (Pg.corner_class[after ? (t + n - 1) % n : (t + 1) % n] != C.base) continue;
      cands.push_back({tok_len((t + n - 1) % n) + tok_len(t), t, kInvalid, kInvalid, after});
      break;  // both variants use the same path
    }
  }
  std::stable_sort(cands.begin(), cands.end(),
                   [](const Candidate& p, const Candidate& q) { return p.proxy < q.proxy; });
  double best = kInf;
  PathSearch best_path;  // the chosen move's path, cut by cut_paste() without a new search
  Index bad = kInvalid, evaluated = 0;
  bool glue_after = true;
  for (const Candidate& cd : cands) {
    if (evaluated++ >= kCandidates) break;
    PathSearch ps = corner_path(C, (cd.t + n - 1) % n, (cd.t + 1) % n, best);
    if (ps.cost < best) {
      best = ps.cost;
      best_path = std::move(ps);
      bad = cd.t;
      glue_after = cd.after;
    }
  }
  if (bad == kInvalid) {
    if (!any_other) return Move::NoneNeeded;
    reason = "no corner of another class is next to a base corner";
    return Move::Failed;
  }
  // corner `bad` lies between token bad-1 (b) and token bad (a)
  const Index alpha = (bad + n - 1) % n, beta = (bad + 1) % n;
  const Index glue_tok = glue_after ? bad : (bad + n - 1) % n;
  const std::vector<Pair> glue = C.side_pairs(Pg.tok_side[glue_tok]);
  const std::vector<Index> src = Pg.corner_anchor[alpha], dst = Pg.corner_anchor[beta];
  std::string why;
  if (!C.cut_paste(src, dst, glue, nullptr, &why, &best_path)) {
    reason = "cut-and-paste failed: " + why;
    return Move::Failed;
  }
  return Move::Made;
}

/// Step (C), commutators: among linked pairs a…b…a^-1…b^-1 of letters not yet in a commutator,
/// the one whose first path is cheapest becomes one by two cut-and-paste moves. NoneNeeded when
/// the word is all commutators; Failed with `reason`.
Move make_commutator(Cutter& C, std::string& reason) {
  const Polygon& Pg = C.P;
  const Index n = Pg.ntok();
  auto tok_len = [&](Index t) { return Pg.side_len[Pg.tok_side[t]]; };
  std::vector<char> done;
  const Index blocks = commutator_blocks(Pg, done);
  if (4 * blocks == n) return Move::NoneNeeded;  // canonical
  auto partner_token = [&](Index t) {
    for (Index q = 0; q < n; ++q)
      if (q != t && Pg.tok_letter[q] == Pg.tok_letter[t]) return q;
    return kInvalid;
  };
  std::vector<Candidate> cands;
  Index total = 0;
  for (Index t = 0; t < n; ++t) total += tok_len(t);
  for (Index ta = 0; ta < n; ++ta) {
    if (done[ta]) continue;
    const Index ja = partner_token(ta);
    Index arc = 0;
    for (Index k = 0; (ta + k) % n != (ja + 1) % n; ++k) arc += tok_len((ta + k) % n);
    for (Index k = 1; (ta + k) % n != ja; ++k) {
      const Index t = (ta + k) % n;
      if (done[t]) continue;
      const Index other = partner_token(t);
      if ((other - ta + n) % n < (ja - ta + n) % n) continue;  // not linked
      cands.push_back({std::min(arc, total - arc), ta, ja, t, false});
      break;  // the path does not depend on b
    }
  }
  std::stable_sort(cands.begin(), cands.end(),
                   [](const Candidate& p, const Candidate& q) { return p.proxy < q.proxy; });
  Index i0 = kInvalid, j0 = kInvalid, tb = kInvalid, evaluated = 0;
  double best = kInf;
  PathSearch best_path;
  for (const Candidate& cd : cands) {
    if (evaluated++ >= kCandidates) break;
    PathSearch ps = corner_path(C, cd.t, (cd.ja + 1) % n, best);
    if (ps.cost < best) {
      best = ps.cost;
      best_path = std::move(ps);
      i0 = cd.t;
      j0 = cd.ja;
      tb = cd.tb;
    }
  }
  if (j0 == kInvalid || tb == kInvalid) {
    reason = "no linked pair of letters";
    return Move::Failed;
  }
  std::string why;
  // Move 1: from the corner before a to the corner after a^-1, reglue along b.
  const Pair a_inv_first = side_first_edge(Pg, C.R, Pg.tok_side[j0]);
  const std::vector<Pair> glue_b = C.side_pairs(Pg.tok_side[tb]);
  std::vector<Index> path;
  {
    const std::vector<Index> src = Pg.corner_anchor[i0], dst = Pg.corner_anchor[(j0 + 1) % n];
    if (!C.cut_paste(src, dst, glue_b, &path, &why, &best_path)) {
      reason = "cut-and-paste failed: " + why;
      return Move::Failed;
    }
  }
  // Move 2: from the corner after a^-1 to the corner after c, reglue along a.
  {
    const Polygon& P1 = C.P;
    const Index sa = side_with_first_edge(P1, C.R, a_inv_first);
    const Index sc = side_with_first_edge(P1, C.R, Pair{path[0], path[1]});
    const Index ta = sa == kInvalid ? kInvalid : token_of_side(P1, sa);
    const Index tc = sc == kInvalid ? kInvalid : token_of_side(P1, sc);
    if (ta == kInvalid || tc == kInvalid) {
      reason = "lost track of a side after a move";
      return Move::Failed;
    }
    const Index n1 = P1.ntok();
    const std::vector<Pair> glue_a = C.side_pairs(P1.tok_side[ta]);
    const std::vector<Index> src = P1.corner_anchor[(ta + 1) % n1], dst = P1.corner_anchor[(tc + 1) % n1];
    if (!C.cut_paste(src, dst, glue_a, nullptr, &why)) {
      reason = "cut-and-paste failed: " + why;
      return Move::Failed;
    }
  }
  std::vector<char> done2;
  if (commutator_blocks(C.P, done2) <= blocks) {
    reason = "a commutator move did not make progress";
    return Move::Failed;
  }
  return Move::Made;
}

/// Genus ≥ 1: the cut graph by tree–cotree (the loops based at its interior branch point nearest
/// to x in Ŝ, else its interior vertex nearest to x; that base becomes x), then, when asked,
/// cut-and-paste to the canonical word: (A) cancel x x^-1, (B) one vertex class, (C)
/// commutators, until canonical or `max_moves`. False on an internal error (C.error); a word
/// left non-canonical is not one (names.reason says why).
bool loops_by_tree_cotree(Cutter& C, const CutOptions& options, Index g, Index max_moves, Index& x,
                          CutNames& names) {
  Surface& S = C.S;
  const Index V = S.nv();
  std::string& reason = names.reason;
  std::vector<double> dhat;
  if (!tree_cotree(S, C.st, x, options.edge_weights, g, dhat, &C.error)) return false;
  const std::vector<Index> deg = cut_degree(S, C.st);
  // The base is the branch point of the cut graph (degree ≥ 3) nearest x: it is a polygon corner
  // anyway, while a base inside a path adds a corner class that moves must merge (on a torus grid
  // of 1M faces: 1 move instead of 4, and no refinement).
  Index P = kInvalid, branch = kInvalid;
  for (Index v = 0; v < V; ++v) {
    if (deg[v] == 0) continue;
    if (S.vertex_loop[v] >= 0 || deg[v] != 2) C.st.node[v] = 1;
    if (S.vertex_loop[v] >= 0) continue;
    if (P == kInvalid || dhat[v] < dhat[P]) P = v;
    if (deg[v] >= 3 && (branch == kInvalid || dhat[v] < dhat[branch])) branch = v;
  }
  if (branch != kInvalid) P = branch;
  if (P == kInvalid) {
    // Every cut vertex lies on the boundary: the loops cannot be based at an interior point.
    reason = "the cut graph has no interior vertex to base the loops at";
    for (Index v = 0; v < V; ++v)
      if (deg[v] > 0) {
        P = v;
        break;
      }
  }
  C.st.node[P] = 1;
  C.base = P;
  x = P;
  if (!C.rebuild()) return false;

  if (!options.canonicalize) reason = "canonicalisation was not requested";
  bool stop = !options.canonicalize || !reason.empty();
  Index guard = 0;
  while (!stop) {
    if (++guard > 4 * max_moves + 16 || C.moves >= max_moves) {
      reason = "move limit reached";
      break;
    }
    const Polygon& Pg = C.P;
    const Index n = Pg.ntok();
    // (A) cancel x x^-1
    Index cancel = kInvalid;
    for (Index t = 0; t < n && n > 2; ++t) {
      const Index u = (t + 1) % n;
      if (Pg.tok_letter[t] == Pg.tok_letter[u] && Pg.tok_sign[t] == -Pg.tok_sign[u]) {
        cancel = t;
        break;
      }
    }
    if (cancel != kInvalid) {
      std::string why;
      if (!C.cancel(cancel, &why)) {
        reason = why;
        break;
      }
      if (!C.st.node[C.base]) {
        reason = "the base vertex left the cut graph";
        break;
      }
      continue;
    }
    const Move b = merge_corner_class(C, reason);
    if (b == Move::Failed) break;
    if (b == Move::Made) continue;
    if (make_commutator(C, reason) != Move::Made) break;
  }
  x = C.base;
  const Index rotation_token = canonical_rotation(C.P);
  names.word_canonical = rotation_token >= 0 && 4 * g == C.P.ntok();
  if (!names.word_canonical && reason.empty()) reason = "the polygon word is not canonical";
  const Index anchor_tok = names.word_canonical ? rotation_token : 0;
  names.anchor_edge = side_first_edge(C.P, C.R, C.P.tok_side[anchor_tok]);
  return true;
}

/// Arcs from the base corner to every hole (the one with the smallest input loop first),
/// shortest paths inside the disk. False on an internal error (C.error).
bool cut_arcs(Cutter& C, CutNames& names) {
  while (!C.P.holes.empty()) {
    const Polygon& Pg = C.P;
    const Index s0 = side_with_first_edge(Pg, C.R, names.anchor_edge);
    if (s0 == kInvalid) {
      C.error = "lost the anchor side";
      return false;
    }
    Index best_hole = kInvalid, best_loop = kInvalid;
    for (Index h : Pg.holes) {
      const Index L = C.S.vertex_loop[C.R.to_surface[C.R.topo.boundary_vertices[C.R.topo.boundary_offsets[h]]]];
      if (best_loop == kInvalid || L < best_loop) {
        best_loop = L;
        best_hole = h;
      }
    }
    std::vector<Index> targets;
    for (Index k = C.R.topo.boundary_offsets[best_hole]; k < C.R.topo.boundary_offsets[best_hole + 1]; ++k)
      targets.push_back(C.R.topo.boundary_vertices[k]);
    std::vector<Index> path;
    const std::vector<Index> src = {Pg.at(Pg.side_begin[s0])};
    std::string why;
    if (!C.cut_paste(src, targets, {}, &path, &why)) {
      C.error = "arc to boundary loop " + std::to_string(best_loop) + ": " + why;
      return false;
    }
    names.arc_first.push_back({path[0], path[1]});
    names.arc_loop.push_back(best_loop);
  }
  return true;
}

/// The word's letters as the user reads them: arcs t_i, the slit s1, and the loops, a_k b_k in
/// commutator order when the word is canonical (else x1, x2, … in side order from s_start).
struct Letters {
  std::vector<std::string> name;
  std::vector<int> dir;  ///< token sign of the + occurrence
  std::vector<SideKind> kind;
  std::vector<Index> loop;        ///< the boundary loop of an arc
  std::vector<Index> order;       ///< letters in generator order
  std::vector<Index> generator;   ///< letter → generator
};

/// "t3", "a1", …
std::string letter_name(const char* prefix, Index k) {
  std::string s = prefix;
  s += std::to_string(k);
  return s;
}

/// Names the letters of the final polygon. False on an internal error (C.error).
bool name_letters(Cutter& C, const CutNames& names, Index g, Index b, Index s_start, Letters& out) {
  const Polygon& Pg = C.P;
  const Disk& R = C.R;
  const std::size_t nl = static_cast<std::size_t>(Pg.num_letters);
  out.name.assign(nl, std::string());
  out.dir.assign(nl, 0);
  out.kind.assign(nl, SideKind::Loop);
  out.loop.assign(nl, kInvalid);
  out.order.clear();
  for (std::size_t i = 0; i < names.arc_first.size(); ++i) {
    const Index s = side_with_first_edge(Pg, R, names.arc_first[i]);
    if (s == kInvalid) {
      C.error = "lost an arc";
      return false;
    }
    const Index t = token_of_side(Pg, s);
    const Index L = Pg.tok_letter[t];
    out.name[L] = letter_name("t", names.arc_loop[i] + 1);
    out.dir[L] = Pg.tok_sign[t];
    out.kind[L] = SideKind::Arc;
    out.loop[L] = names.arc_loop[i];
  }
  if (g == 0 && b == 0) {
    out.name[Pg.tok_letter[0]] = "s1";
    out.kind[Pg.tok_letter[0]] = SideKind::Slit;
    const Index t = token_of_side(Pg, s_start);
    out.dir[Pg.tok_letter[0]] = Pg.tok_sign[t];
  }
  Index next_x = 1, handle = 1;
  // Walk sides from s_start; name loop letters in order.
  const Index ns = static_cast<Index>(Pg.side_begin.size());
  for (Index k = 0; k < ns; ++k) {
    const Index s = (s_start + k) % ns;
    if (!Pg.side_cut[s]) continue;
    const Index t = token_of_side(Pg, s);
    const Index L = Pg.tok_letter[t];
    if (!out.name[L].empty()) continue;
    if (names.word_canonical && g > 0) {
      // in a commutator block u v u^-1 v^-1 starting at this token
      const Index n = Pg.ntok();
      const Index v = Pg.tok_letter[(t + 1) % n];
      out.name[L] = letter_name("a", handle);
      out.dir[L] = Pg.tok_sign[t];
      out.name[v] = letter_name("b", handle);
      out.dir[v] = Pg.tok_sign[(t + 1) % n];
      out.order.push_back(L);
      out.order.push_back(v);
      ++handle;
    } else {
      out.name[L] = letter_name("x", next_x++);
      out.dir[L] = Pg.tok_sign[t];
      out.order.push_back(L);
    }
  }
  for (Index L = 0; L < Pg.num_letters; ++L)
    if (out.kind[L] != SideKind::Loop) out.order.push_back(L);
  out.generator.assign(nl, kInvalid);
  for (std::size_t i = 0; i < out.order.size(); ++i) out.generator[out.order[i]] = static_cast<Index>(i);
  return true;
}

/// The sides in order from s_start (their vertices, kinds, generators, partners, labels and the
/// word), and the generators' surface vertices (each from its + occurrence).
void write_sides(const Cutter& C, Index s_start, const Letters& letters, CutResult& r) {
  const Polygon& Pg = C.P;
  const Disk& R = C.R;
  const Index ns = static_cast<Index>(Pg.side_begin.size());
  std::vector<Index> new_index(static_cast<std::size_t>(ns));
  for (Index k = 0; k < ns; ++k) new_index[(s_start + k) % ns] = k;
  r.side_offsets.push_back(0);
  std::vector<std::string> words;
  for (Index k = 0; k < ns; ++k) {
    const Index s = (s_start + k) % ns;
    for (Index i = 0; i <= Pg.side_len[s]; ++i) r.side_vertices.push_back(Pg.at(Pg.side_begin[s] + i));
    r.side_offsets.push_back(static_cast<Index>(r.side_vertices.size()));
    if (!Pg.side_cut[s]) {
      r.side_kind.push_back(SideKind::Boundary);
      r.side_generator.push_back(kInvalid);
      r.side_orientation.push_back(0);
      r.side_partner.push_back(kInvalid);
      r.side_boundary_loop.push_back(Pg.side_loop[s]);
      r.side_label.push_back("∂" + std::to_string(Pg.side_loop[s] + 1));
    } else {
      const Index t = token_of_side(Pg, s);
      const Index L = Pg.tok_letter[t];
      const int o = Pg.tok_sign[t] == letters.dir[L] ? +1 : -1;
      r.side_kind.push_back(letters.kind[L]);
      r.side_generator.push_back(letters.generator[L]);
      r.side_orientation.push_back(o);
      r.side_partner.push_back(new_index[Pg.side_partner[s]]);
      r.side_boundary_loop.push_back(letters.loop[L]);
      r.side_label.push_back(label(letters.name[L], o));
    }
    words.push_back(r.side_label.back());
  }
  for (std::size_t i = 0; i < words.size(); ++i) r.word += (i ? " " : "") + words[i];
  // Generators: the + occurrence's surface vertices.
  r.generator_offsets.push_back(0);
  for (Index L : letters.order) {
    Index side = kInvalid;
    for (Index k = 0; k < ns && side == kInvalid; ++k)
      if (r.side_generator[k] == letters.generator[L] && r.side_orientation[k] == +1) side = k;
    for (Index i = r.side_offsets[side]; i < r.side_offsets[side + 1]; ++i)
      r.generator_vertices.push_back(R.to_surface[r.side_vertices[i]]);
    r.generator_offsets.push_back(static_cast<Index>(r.generator_vertices.size()));
    r.generator_kind.push_back(letters.kind[L]);
    r.generator_name.push_back(letters.name[L]);
    r.generator_boundary_loop.push_back(letters.loop[L]);
  }
}

/// Loop `a` pushed off to its left as a 1-form on the edges: at every vertex of `a`, each edge
/// leaving it on the left (strictly between the outgoing and the incoming edge, counter-clockwise)
/// gets +1 in the direction away from `a`. `form` (#E, zeros) receives the values, oriented from
/// edge_vertices[2e] to edge_vertices[2e + 1]; `touched` lists the edges set. False (form left
/// as zeros) when `a` is not a closed path of interior vertices.
bool loop_form(const Topology& t, std::span<const Index> a, std::vector<int>& form, std::vector<Index>& touched) {
  auto clear = [&] {
    for (Index e : touched) form[e] = 0;
    touched.clear();
    return false;
  };
  if (a.size() < 3 || a.front() != a.back()) return false;
  const std::size_t m = a.size() - 1;
  for (std::size_t k = 0; k < m; ++k) {
    const Index v = a[k], out = a[k + 1], in = a[(k + m - 1) % m];
    if (v < 0 || v >= t.num_vertices || t.is_boundary_vertex(v)) return clear();
    const Index o0 = t.vertex_corner_offsets[v], n = t.valence(v);
    // ccw neighbour sequence: vertex(next(c_j)), over the edge opposite prev(c_j)
    Index jo = kInvalid, ji = kInvalid;
    for (Index j = 0; j < n; ++j) {
      const Index z = t.corner_vertex[next_corner(t.vertex_corners[o0 + j])];
      if (z == out) jo = j;
      if (z == in) ji = j;
    }
    if (jo == kInvalid || ji == kInvalid) return clear();
    for (Index j = (jo + 1) % n; j != ji; j = (j + 1) % n) {
      const Index c = t.vertex_corners[o0 + j];
      const Index e = t.corner_edge[prev_corner(c)];
      if (form[e] == 0) touched.push_back(e);
      form[e] += t.edge_vertices[2 * e] == v ? 1 : -1;
    }
  }
  return true;
}

/// The form's value along the closed path `b`, or 0 when a step of `b` is not an edge.
int form_along(const Topology& t, const std::vector<int>& form, std::span<const Index> b) {
  if (b.size() < 2 || b.front() != b.back()) return 0;
  int sum = 0;
  for (std::size_t k = 0; k + 1 < b.size(); ++k) {
    const Index e = t.edge_between(b[k], b[k + 1]);
    if (e == kInvalid) return 0;
    sum += t.edge_vertices[2 * e] == b[k] ? form[e] : -form[e];
  }
  return sum;
}

/// The independent check of a canonical word: the loops' algebraic intersection numbers, counted
/// on the surface, must be a_i·b_j = δ_ij and a_i·a_j = b_i·b_j = 0 (r.intersection holds them).
/// False when they are not.
bool intersections_canonical(const Topology& surface, Index g, CutResult& r) {
  const Index n2 = 2 * g;
  r.intersection.assign(static_cast<std::size_t>(n2 * n2), 0);
  auto loop = [&](Index i) {
    return std::span<const Index>(r.generator_vertices.data() + r.generator_offsets[i],
                                  static_cast<std::size_t>(r.generator_offsets[i + 1] - r.generator_offsets[i]));
  };
  // One form per loop, read along every other loop (both orders: antisymmetry is checked too).
  std::vector<int> form(static_cast<std::size_t>(surface.num_edges), 0);
  std::vector<Index> touched;
  bool ok = true;
  for (Index i = 0; i < n2; ++i) {
    const bool valid = loop_form(surface, loop(i), form, touched);
    for (Index j = 0; j < n2; ++j) {
      const int val = i == j || !valid ? 0 : form_along(surface, form, loop(j));
      r.intersection[static_cast<std::size_t>(i * n2 + j)] = val;
      // loops are ordered a1 b1 a2 b2 …: a_k = 2k, b_k = 2k+1
      const int expect = (i / 2 == j / 2 && i != j) ? (i % 2 == 0 ? +1 : -1) : 0;
      if (val != expect) ok = false;
    }
    for (Index e : touched) form[e] = 0;
    touched.clear();
  }
  return ok;
}

}  // namespace

// ---- intersection numbers -------------------------------------------------------------------------

int intersection_number(const Topology& t, std::span<const Index> a, std::span<const Index> b) {
  std::vector<int> form(static_cast<std::size_t>(t.num_edges), 0);
  std::vector<Index> touched;
  if (!loop_form(t, a, form, touched)) return 0;
  return form_along(t, form, b);
}

// ---- the driver -----------------------------------------------------------------------------------

CutResult cut_surface(const Mesh& mesh, const Topology& topo, const CutOptions& options) {
  const Clock::time_point start = Clock::now();
  CutResult r;
  std::string why;
  auto fail = [&](Status s, const std::string& m) {
    r.status = s;
    r.message = m;
    r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return r;
  };
  if (!options.is_valid(&why)) return fail(Status::InvalidArgument, "cut options: " + why);
  const Index V = topo.num_vertices;
  if (static_cast<std::size_t>(topo.num_faces) * 3 != mesh.faces.size() || V <= 0)
    return fail(Status::InvalidArgument, "cut: the topology does not match the mesh's faces");
  if (!mesh.positions.empty() && mesh.positions.size() != static_cast<std::size_t>(V) * 3)
    return fail(Status::InvalidArgument, "cut: positions must be #V x 3 or empty");
  if (!options.edge_weights.empty() &&
      options.edge_weights.size() != static_cast<std::size_t>(topo.num_edges))
    return fail(Status::InvalidArgument, "cut: edge_weights must have one value per edge (" +
                                             std::to_string(topo.num_edges) + "), got " +
                                             std::to_string(options.edge_weights.size()));
  if (topo.num_components != 1)
    return fail(Status::MultipleComponents, "cut: the surface has several components");
  for (Index v = 0; v < V; ++v)
    if (topo.valence(v) == 0)
      return fail(Status::InvalidArgument, "cut: vertex " + std::to_string(v) + " is used by no face");
  if (options.base_vertex >= V)
    return fail(Status::InvalidArgument, "cut: base vertex " + std::to_string(options.base_vertex) +
                                             " is out of range (the mesh has " + std::to_string(V) +
                                             " vertices)");
  Index x = options.base_vertex;
  if (x < 0) {
    if (options.seed == 0) {
      x = 0;
    } else {
      std::mt19937_64 rng(options.seed);
      x = static_cast<Index>(rng() % static_cast<std::uint64_t>(V));
    }
  }
  r.requested_base_vertex = x;
  const Index g = static_cast<Index>(topo.genus());
  const Index b = topo.num_boundary_loops();
  r.genus = g;
  r.boundary_loops = b;
  r.num_input_vertices = V;

  auto internal = [&](const std::string& m) {
    return fail(Status::NumericalFailure, "cut: internal error: " + m);
  };
  Cutter C;
  start_cutter(C, mesh, topo);
  C.S.max_refined_per_face = options.max_refined_per_face;
  CutNames names;
  const bool cut = g == 0 && b == 0 ? slit_sphere(C, options, x, names)
                   : g == 0         ? base_on_boundary(C, options, x, names)
                                    : loops_by_tree_cotree(C, options, g, options.max_moves > 0 ? options.max_moves : 64 + 40 * g, x, names);
  if (!cut || !cut_arcs(C, names)) return internal(C.error);

  // ---- outputs ----
  const Polygon& Pg = C.P;
  const Disk& R = C.R;
  const Surface& S = C.S;
  if (R.topo.num_boundary_loops() != 1 || R.topo.euler_characteristic() != 1 || R.topo.num_components != 1)
    return internal("the result is not a disk");
  r.base_vertex = x;
  r.moves = C.moves;
  r.refinements = C.refinements;

  Index s_start = side_with_first_edge(Pg, R, names.anchor_edge);
  if (s_start == kInvalid) s_start = 0;
  Letters letters;
  if (!name_letters(C, names, g, b, s_start, letters)) return internal(C.error);
  write_sides(C, s_start, letters, r);
  if (g > 0 && names.word_canonical && !intersections_canonical(S.topo, g, r)) {
    names.word_canonical = false;
    names.reason = "the intersection numbers of the loops are not canonical";
  }
  // The cutter's surface and disk move into the result (no second copy at the peak).
  for (Index f : S.rec_face)
    for (int k = 0; k < 3; ++k) r.refined_vertex_corners.push_back(mesh.faces[3 * f + k]);
  r.surface_positions = std::move(C.S.pos);
  r.surface_faces = std::move(C.S.faces);
  r.surface_face_to_input = std::move(C.S.face_origin);
  r.refined_vertex_face = std::move(C.S.rec_face);
  r.refined_vertex_bary = std::move(C.S.rec_bary);
  r.cut_faces = std::move(C.R.faces);
  r.cut_to_surface = std::move(C.R.to_surface);
  r.surface_topology = std::move(C.S.topo);
  r.disk_topology = std::move(C.R.topo);
  r.canonical = names.word_canonical && names.reason.empty();
  r.reason = r.canonical ? std::string() : names.reason;
  r.refinement_bound = !r.canonical && names.reason.find(kRefinementBound) != std::string::npos;
  r.status = Status::Ok;
  r.message = "cut into a disk with " + std::to_string(r.num_sides()) + " sides";
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

std::vector<double> cut_vertex_data(const CutResult& cut, std::span<const double> data, int dims) {
  if (dims <= 0) return {};
  const std::size_t d = static_cast<std::size_t>(dims);
  const Index n_surface = cut.num_input_vertices + cut.num_refined_vertices();
  std::vector<double> per_surface;
  std::span<const double> src;
  if (data.size() == static_cast<std::size_t>(n_surface) * d) {
    src = data;
  } else if (data.size() == static_cast<std::size_t>(cut.num_input_vertices) * d) {
    per_surface.assign(data.begin(), data.end());
    per_surface.resize(static_cast<std::size_t>(n_surface) * d, 0);
    for (Index k = 0; k < cut.num_refined_vertices(); ++k) {
      const std::size_t v = static_cast<std::size_t>(cut.num_input_vertices + k);
      for (int j = 0; j < 3; ++j) {
        const std::size_t w = static_cast<std::size_t>(cut.refined_vertex_corners[3 * k + j]);
        for (std::size_t q = 0; q < d; ++q)
          per_surface[v * d + q] += cut.refined_vertex_bary[3 * k + j] * data[w * d + q];
      }
    }
    src = per_surface;
  } else {
    return {};
  }
  std::vector<double> out(static_cast<std::size_t>(cut.num_cut_vertices()) * d);
  for (Index v = 0; v < cut.num_cut_vertices(); ++v)
    for (std::size_t k = 0; k < d; ++k)
      out[v * d + k] = src[static_cast<std::size_t>(cut.cut_to_surface[v]) * d + k];
  return out;
}

Mesh cut_disk_mesh(const CutResult& cut) {
  Mesh m;
  m.faces = cut.cut_faces;
  if (!cut.surface_positions.empty()) {
    m.positions.resize(static_cast<std::size_t>(cut.num_cut_vertices()) * 3);
    for (Index v = 0; v < cut.num_cut_vertices(); ++v)
      for (int d = 0; d < 3; ++d)
        m.positions[3 * v + d] = cut.surface_positions[3 * cut.cut_to_surface[v] + d];
  }
  return m;
}

Mesh surface_with_cut_uvs(const CutResult& cut, std::span<const double> uv) {
  Mesh m;
  if (uv.size() != static_cast<std::size_t>(cut.num_cut_vertices()) * 2) return m;
  m.positions = cut.surface_positions;
  m.faces = cut.surface_faces;
  m.texcoords.assign(uv.begin(), uv.end());
  m.corner_texcoords = cut.cut_faces;
  return m;
}

}  // namespace ricci
