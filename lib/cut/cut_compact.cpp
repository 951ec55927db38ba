// ricci — a compact fundamental domain: the surface cut along the complement of a shortest-path
// tree of the dual graph grown from a central face (see cut_compact() in cut.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <queue>
#include <string>
#include <unordered_map>
#include <vector>

#include "radix_heap.h"
#include "ricci/cut.h"

namespace ricci {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Distance between the centroids of the two faces of interior edge e (corner c opposite it in
/// one face), the faces unfolded into the plane along e with the given lengths.
double dual_weight(const Topology& t, std::span<const double> l, Index c) {
  const Index c2 = t.opposite[c];
  const double L = l[t.corner_edge[c]];
  // Face of c: the edge runs from vertex(next(c)) (A) to vertex(prev(c)) (B); the third vertex
  // C is at distance l[corner_edge[prev(c)]] from A and l[corner_edge[next(c)]] from B.
  auto apex = [&](Index corner, double sign) {
    const double la = l[t.corner_edge[prev_corner(corner)]], lb = l[t.corner_edge[next_corner(corner)]];
    const double x = (L * L + la * la - lb * lb) / (2 * L);
    const double y = std::sqrt(std::max(0.0, la * la - x * x));
    return std::array<double, 2>{x, sign * y};
  };
  const std::array<double, 2> p = apex(c, 1.0);
  // In the other face the edge runs the other way: measured from B, so mirror x.
  std::array<double, 2> q = apex(c2, -1.0);
  q[0] = L - q[0];
  const double dx = (p[0] - q[0]) / 3, dy = (p[1] - q[1]) / 3;
  return std::sqrt(dx * dx + dy * dy);
}

// Quantum of the dual weights: 2^-kWeightBits of the largest one.
constexpr int kWeightBits = 30;
// A corner with no face across its edge (boundary), or a weight that is not a finite number.
constexpr std::uint64_t kNoEdge = std::numeric_limits<std::uint64_t>::max();

/// The dual weight of every interior edge (per corner: the edge opposite it; one value for both
/// sides) in integer units of 2^-kWeightBits of the largest weight. Path sums are then exact
/// and equal weights compare equal, so the shortest-path tree, the double sweep and the centre of
/// a symmetric mesh break their ties by face index (dual_distances()) and not by the last bits of
/// the metric: metrics that differ by rounding (another factorization, another BLAS) give
/// the same domain, and with it the same canonical words downstream.
std::vector<std::uint64_t> dual_weights(const Topology& t, std::span<const double> l) {
  std::vector<double> w(static_cast<std::size_t>(3 * t.num_faces), kInf);
  double largest = 0;
  for (Index c = 0; c < 3 * t.num_faces; ++c) {
    const Index o = t.opposite[c];
    if (o == kInvalid || o < c) continue;
    w[c] = w[o] = dual_weight(t, l, c);
    if (std::isfinite(w[c])) largest = std::max(largest, w[c]);
  }
  std::vector<std::uint64_t> units(w.size(), kNoEdge);
  const int e = largest > 0 ? std::ilogb(largest) - kWeightBits : 0;
  for (std::size_t c = 0; c < w.size(); ++c)
    if (std::isfinite(w[c])) units[c] = largest > 0 ? static_cast<std::uint64_t>(std::nearbyint(std::ldexp(w[c], -e))) : 0;
  return units;
}

/// Dijkstra on the dual graph from face `source` with the weights w (per corner); per face its
/// distance (kNoEdge where unreached) and, with `via`, the corner it was reached across. Faces of
/// equal distance are settled in index order (the radix heap pops (distance, face) in order).
std::vector<std::uint64_t> dual_distances(const Topology& t, std::span<const std::uint64_t> w, Index source,
                                          std::vector<Index>* via) {
  const Index F = t.num_faces;
  std::vector<std::uint64_t> d(static_cast<std::size_t>(F), kNoEdge);
  if (via) via->assign(static_cast<std::size_t>(F), kInvalid);
  detail::RadixHeap<Index> heap;
  d[source] = 0;
  heap.push(0, source);
  while (!heap.empty()) {
    const auto [df, f] = heap.pop();
    if (df > d[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const Index c = 3 * f + k, o = t.opposite[c];
      if (o == kInvalid || w[c] == kNoEdge) continue;
      const Index g = corner_face(o);
      const std::uint64_t nd = df + w[c];
      if (nd < d[g]) {
        d[g] = nd;
        if (via) (*via)[g] = o;  // g is reached across the edge of its corner o
        heap.push(nd, g);
      }
    }
  }
  return d;
}

std::uint64_t pair_key(Index u, Index v) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) | static_cast<std::uint32_t>(v);
}

/// The face minimising the larger distance to the two ends of a double-sweep diameter of the dual
/// graph with edge weights w (per corner: the edge opposite it).
Index dual_centre(const Topology& topo, const std::vector<std::uint64_t>& w) {
  const Index F = topo.num_faces;
  auto farthest = [&](const std::vector<std::uint64_t>& d) {
    Index best = 0;
    for (Index f = 0; f < F; ++f)
      if (d[f] > d[best]) best = f;
    return best;
  };
  const Index a = farthest(dual_distances(topo, w, 0, nullptr));
  const std::vector<std::uint64_t> da = dual_distances(topo, w, a, nullptr);
  const std::vector<std::uint64_t> db = dual_distances(topo, w, farthest(da), nullptr);
  Index centre = 0;
  for (Index f = 1; f < F; ++f)
    if (std::max(da[f], db[f]) < std::max(da[centre], db[centre])) centre = f;
  return centre;
}

/// The cut graph: the edges the dual tree (`via`, per face the corner it was reached across) does
/// not cross, spurs pruned. Vertices in `keep` (cones) are never pruned: the branch to each stays, a
/// slit whose two sides are paired by the rotation about it. `degree`: per vertex, its cut edges.
std::vector<char> cut_graph(const Topology& topo, const std::vector<Index>& via, std::span<const Index> keep,
                            std::vector<Index>& degree) {
  const Index V = topo.num_vertices, F = topo.num_faces, E = topo.num_edges;
  std::vector<char> cut(static_cast<std::size_t>(E), 1);
  for (Index f = 0; f < F; ++f)
    if (via[f] != kInvalid) cut[topo.corner_edge[via[f]]] = 0;
  degree.assign(static_cast<std::size_t>(V), 0);
  for (Index e = 0; e < E; ++e)
    if (cut[e]) {
      ++degree[topo.edge_vertices[2 * e]];
      ++degree[topo.edge_vertices[2 * e + 1]];
    }
  std::vector<char> kept(static_cast<std::size_t>(V), 0);
  for (const Index v : keep)
    if (v >= 0 && v < V) kept[v] = 1;
  std::vector<Index> stack;
  for (Index v = 0; v < V; ++v)
    if (degree[v] == 1 && !kept[v]) stack.push_back(v);
  while (!stack.empty()) {
    const Index v = stack.back();
    stack.pop_back();
    if (degree[v] != 1) continue;
    for (Index k = topo.vertex_corner_offsets[v]; k < topo.vertex_corner_offsets[v + 1]; ++k) {
      const Index c = topo.vertex_corners[k];
      for (const Index e : {topo.corner_edge[next_corner(c)], topo.corner_edge[prev_corner(c)]}) {
        if (!cut[e]) continue;
        cut[e] = 0;
        for (int s = 0; s < 2; ++s) {
          const Index u = topo.edge_vertices[2 * e + s];
          if (--degree[u] == 1 && !kept[u]) stack.push_back(u);
        }
      }
    }
  }
  return cut;
}

/// The sides: the disk's boundary (dt) split at the cut graph's nodes (degree ≥ 3, boundary edges
/// counted, and the ends of kept branches, degree 1); which sides lie on the surface's boundary
/// (their edges have no partner); each other side's partner. Empty string, or what went wrong.
std::string pair_sides(const Topology& topo, const Topology& dt, const std::vector<Index>& degree, CutResult& r,
                       std::vector<char>& boundary_side) {
  std::unordered_map<std::uint64_t, char> on_boundary;  // directed disk edges on the surface's boundary
  for (Index c = 0; c < 3 * topo.num_faces; ++c)
    if (topo.opposite[c] == kInvalid) on_boundary[pair_key(r.cut_faces[next_corner(c)], r.cut_faces[prev_corner(c)])] = 1;
  const Index b0 = dt.boundary_offsets[0], m = dt.boundary_offsets[1] - b0;
  Index first = kInvalid;
  for (Index k = 0; k < m && first == kInvalid; ++k)
    if (degree[r.cut_to_surface[dt.boundary_vertices[b0 + k]]] != 2) first = k;
  if (first == kInvalid) return "the cut graph has no node";
  auto at = [&](Index k) { return dt.boundary_vertices[b0 + (first + k) % m]; };
  r.side_offsets.push_back(0);
  for (Index k = 0; k < m;) {
    r.side_vertices.push_back(at(k));
    Index j = k + 1;
    while (j < m && degree[r.cut_to_surface[at(j)]] == 2) r.side_vertices.push_back(at(j++));
    r.side_vertices.push_back(at(j));  // the closing node (at(m) == at(0))
    r.side_offsets.push_back(static_cast<Index>(r.side_vertices.size()));
    k = j;
  }
  const Index ns = static_cast<Index>(r.side_offsets.size()) - 1;
  auto sv = [&](Index s, Index i) { return r.cut_to_surface[r.side_vertices[r.side_offsets[s] + i]]; };
  auto len = [&](Index s) { return r.side_offsets[s + 1] - r.side_offsets[s]; };
  boundary_side.assign(static_cast<std::size_t>(ns), 0);
  for (Index s = 0; s < ns; ++s) {
    const Index a = r.side_vertices[r.side_offsets[s]], b = r.side_vertices[r.side_offsets[s] + 1];
    boundary_side[s] = on_boundary.count(pair_key(a, b)) > 0 || on_boundary.count(pair_key(b, a)) > 0;
  }
  std::unordered_map<std::uint64_t, Index> by_first;
  for (Index s = 0; s < ns; ++s)
    if (!boundary_side[s]) by_first[pair_key(sv(s, 0), sv(s, 1))] = s;
  r.side_partner.assign(static_cast<std::size_t>(ns), kInvalid);
  for (Index s = 0; s < ns; ++s) {
    if (boundary_side[s]) continue;
    const Index n = len(s);
    const auto it = by_first.find(pair_key(sv(s, n - 1), sv(s, n - 2)));
    if (it == by_first.end() || len(it->second) != n) return "a side has no partner";
    r.side_partner[s] = it->second;
  }
  return {};
}

/// Kinds and labels of the sides (∂i on boundary loop i, x_k / x_k^-1 for the k-th pair), the
/// generators, the word, and the rest of a compact CutResult.
void label_sides(const Mesh& mesh, const Topology& topo, const std::vector<char>& boundary_side, CutResult& r) {
  const Index ns = static_cast<Index>(r.side_offsets.size()) - 1;
  auto sv = [&](Index s, Index i) { return r.cut_to_surface[r.side_vertices[r.side_offsets[s] + i]]; };
  auto len = [&](Index s) { return r.side_offsets[s + 1] - r.side_offsets[s]; };
  std::vector<Index> loop_of(static_cast<std::size_t>(topo.num_vertices), kInvalid);
  for (Index i = 0; i < topo.num_boundary_loops(); ++i)
    for (Index j = topo.boundary_offsets[i]; j < topo.boundary_offsets[i + 1]; ++j) loop_of[topo.boundary_vertices[j]] = i;
  r.side_kind.assign(static_cast<std::size_t>(ns), SideKind::Loop);
  r.side_generator.assign(static_cast<std::size_t>(ns), kInvalid);
  r.side_orientation.assign(static_cast<std::size_t>(ns), 0);
  r.side_boundary_loop.assign(static_cast<std::size_t>(ns), -1);
  r.side_label.assign(static_cast<std::size_t>(ns), "");
  for (Index s = 0; s < ns; ++s) {
    if (!boundary_side[s]) continue;
    // A piece of boundary loop i: its vertices between two nodes all lie on that loop.
    const Index loop = loop_of[sv(s, 1 < len(s) - 1 ? 1 : 0)];
    r.side_kind[s] = SideKind::Boundary;
    r.side_boundary_loop[s] = loop;
    r.side_label[s] = "∂" + std::to_string(loop + 1);
  }
  r.generator_offsets.push_back(0);
  for (Index s = 0; s < ns; ++s) {
    if (r.side_generator[s] != kInvalid || r.side_kind[s] == SideKind::Boundary) continue;
    const Index k = r.num_generators(), p = r.side_partner[s];
    const std::string name = "x" + std::to_string(k + 1);
    r.side_generator[s] = r.side_generator[p] = k;
    r.side_orientation[s] = 1;
    r.side_orientation[p] = -1;
    r.side_label[s] = name;
    r.side_label[p] = name + "^-1";
    for (Index i = 0; i < len(s); ++i) r.generator_vertices.push_back(sv(s, i));
    r.generator_offsets.push_back(static_cast<Index>(r.generator_vertices.size()));
    r.generator_kind.push_back(SideKind::Loop);
    r.generator_name.push_back(name);
    r.generator_boundary_loop.push_back(-1);
  }
  for (Index s = 0; s < ns; ++s) r.word += (s ? " " : "") + r.side_label[s];

  r.genus = topo.genus();
  r.boundary_loops = topo.num_boundary_loops();
  r.compact = true;
  r.base_vertex = -1;
  r.requested_base_vertex = -1;
  r.canonical = false;
  r.reason = "compact domain: the sides are the branches of a cut graph, not a canonical system of loops";
  r.num_input_vertices = topo.num_vertices;
  r.surface_positions = mesh.positions;
  r.surface_faces = mesh.faces;
  r.surface_face_to_input.resize(static_cast<std::size_t>(topo.num_faces));
  std::iota(r.surface_face_to_input.begin(), r.surface_face_to_input.end(), 0);
}

}  // namespace

CutResult cut_compact(const Mesh& mesh, const Topology& topo, std::span<const double> lengths, Index centre_face,
                      std::span<const Index> keep) {
  const auto t0 = std::chrono::steady_clock::now();
  CutResult r;
  auto fail = [&](Status s, const std::string& m) {
    r.status = s;
    r.message = "cut_compact: " + m;
    return r;
  };
  const Index F = topo.num_faces, E = topo.num_edges;
  if (mesh.faces.size() != static_cast<std::size_t>(3 * F)) return fail(Status::InvalidArgument, "faces do not match the topology");
  if (lengths.size() != static_cast<std::size_t>(E))
    return fail(Status::InvalidArgument, "lengths must have one value per edge (" + std::to_string(E) + ")");
  for (Index e = 0; e < E; ++e)
    if (!(lengths[e] > 0) || !std::isfinite(lengths[e]))
      return fail(Status::InvalidArgument, "the length of edge " + std::to_string(e) + " is not a positive finite number");
  if (topo.num_components != 1) return fail(Status::MultipleComponents, "the surface is not connected");
  if (topo.is_closed() ? topo.genus() < 1 : topo.genus() == 0 && topo.num_boundary_loops() == 1)
    return fail(Status::InvalidArgument,
                "a compact domain is built for closed surfaces of genus >= 1 and for bordered surfaces other "
                "than a disk");
  if (centre_face < -1 || centre_face >= F) return fail(Status::InvalidArgument, "centre_face out of range");

  // Dual edge weights (per corner: the edge opposite it), the centre, and the dual tree from it.
  const std::vector<std::uint64_t> w = dual_weights(topo, lengths);
  if (centre_face < 0) centre_face = dual_centre(topo, w);
  std::vector<Index> via;
  dual_distances(topo, w, centre_face, &via);

  std::vector<Index> degree;
  const std::vector<char> cut = cut_graph(topo, via, keep, degree);
  // The disk: the surface opened along the cut (its connectivity derived from topo's, no sort).
  CutOpenResult disk = cut_open(topo, cut);
  if (disk.status != Status::Ok) return fail(Status::NumericalFailure, "the cut surface is not a manifold: " + disk.message);
  r.cut_faces = std::move(disk.faces);
  r.cut_to_surface = std::move(disk.to_surface);
  const Topology& dt = disk.topology;
  if (dt.num_components != 1 || dt.euler_characteristic() != 1 || dt.num_boundary_loops() != 1)
    return fail(Status::NumericalFailure, "the cut surface is not a disk");
  std::vector<char> boundary_side;
  const std::string why = pair_sides(topo, dt, degree, r, boundary_side);
  if (!why.empty()) return fail(Status::NumericalFailure, why);
  label_sides(mesh, topo, boundary_side, r);
  r.disk_topology = std::move(disk.topology);  // the layout takes it (one build per cut)
  r.status = Status::Ok;
  r.message = "ok";
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace ricci
