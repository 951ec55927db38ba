// Crowding of circle domains by discrete harmonic measure. See crowding.h.
#include "crowding.h"

#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <queue>
#include <tuple>
#include <vector>

#include "ricci/intrinsic.h"
#include "ricci/steiner.h"
#include "sparse_solver.h"

namespace ricci::detail {

namespace {

Crowding measure(const Mesh& mesh, const Topology& topology) {
  Crowding out;
  IntrinsicResult ir = mesh_intrinsic_triangulation(mesh, topology, Geometry::Euclidean);
  if (ir.status != Status::Ok) {
    out.why_not = ir.message;
    return out;
  }
  const IntrinsicTriangulation& tri = ir.triangulation;
  const Topology& t = tri.topology;
  const Index nv = t.num_vertices, ne = t.num_edges, nf = t.num_faces;
  std::vector<double> l(static_cast<std::size_t>(ne));
  for (Index e = 0; e < ne; ++e) l[e] = std::exp(tri.log_chord_of(e));

  // The centre: a vertex in the middle of the boundary's longest extent. p is the boundary vertex
  // farthest (along edges) from an arbitrary boundary vertex, q the one farthest from p, and the
  // centre the interior vertex minimising max(d(p, ·), d(q, ·)) (ties to the smaller index): the
  // middle of a strip, the centre of a round disk.
  std::vector<std::uint8_t> boundary(static_cast<std::size_t>(nv), 0);
  for (const Index c : t.boundary_corners) {
    const Index e = t.corner_edge[c];
    boundary[t.edge_vertices[2 * e]] = boundary[t.edge_vertices[2 * e + 1]] = 1;
  }
  std::vector<std::vector<std::pair<Index, Index>>> adjacent(static_cast<std::size_t>(nv));  // (vertex, edge)
  for (Index e = 0; e < ne; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    if (a == b) continue;
    adjacent[a].emplace_back(b, e);
    adjacent[b].emplace_back(a, e);
  }
  auto distances = [&](Index source) {
    std::vector<double> dist(static_cast<std::size_t>(nv), std::numeric_limits<double>::infinity());
    using Item = std::pair<double, Index>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
    heap.emplace(dist[source] = 0, source);
    while (!heap.empty()) {
      const auto [d, v] = heap.top();
      heap.pop();
      if (d > dist[v]) continue;
      for (const auto& [w, e] : adjacent[v])
        if (d + l[e] < dist[w]) heap.emplace(dist[w] = d + l[e], w);
    }
    return dist;
  };
  auto farthest_boundary = [&](const std::vector<double>& dist) {
    Index best = kInvalid;
    for (Index v = 0; v < nv; ++v)
      if (boundary[v] && std::isfinite(dist[v]) && (best == kInvalid || dist[v] > dist[best])) best = v;
    return best;
  };
  const Index b0 = t.edge_vertices[2 * t.corner_edge[t.boundary_corners[0]]];
  const Index p = farthest_boundary(distances(b0));
  const std::vector<double> dp = distances(p);
  const Index q = farthest_boundary(dp);
  const std::vector<double> dq = distances(q);
  double best = std::numeric_limits<double>::infinity();
  for (Index v = 0; v < nv; ++v) {
    const double m = std::max(dp[v], dq[v]);
    if (!boundary[v] && m < best) {
      best = m;
      out.centre = v;
    }
  }
  if (out.centre == kInvalid) {
    out.why_not = "no interior vertex";
    return out;
  }

  // Cotangent weights of the Delaunay triangulation: w_e = ½ Σ cot of the angles opposite e.
  std::vector<double> w(static_cast<std::size_t>(ne), 0.0);
  for (Index f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const Index c = 3 * f + k;
      const double a = l[t.corner_edge[c]], b = l[t.corner_edge[next_corner(c)]], cc = l[t.corner_edge[prev_corner(c)]];
      // The angle at corner c is opposite edge corner_edge[c]: cot from the three lengths.
      const double s = (b + cc + a) / 2;
      const double area = std::sqrt(std::max(0.0, s * (s - a) * (s - b) * (s - cc)));
      if (!(area > 0)) {
        out.why_not = "a degenerate triangle in the Delaunay triangulation";
        return out;
      }
      w[t.corner_edge[c]] += (b * b + cc * cc - a * a) / (8 * area);
    }
  }

  // The Dirichlet Laplacian on the interior vertices.
  std::vector<std::int64_t> index(static_cast<std::size_t>(nv), -1);
  std::int64_t n = 0;
  for (Index v = 0; v < nv; ++v)
    if (!boundary[v]) index[v] = n++;
  std::vector<Eigen::Triplet<double, std::int64_t>> entries;
  entries.reserve(static_cast<std::size_t>(3 * ne));
  for (Index e = 0; e < ne; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    if (a == b) continue;
    const std::int64_t ia = index[a], ib = index[b];
    if (ia >= 0) entries.emplace_back(ia, ia, w[e]);
    if (ib >= 0) entries.emplace_back(ib, ib, w[e]);
    if (ia >= 0 && ib >= 0) entries.emplace_back(std::min(ia, ib), std::max(ia, ib), -w[e]);
  }
  Eigen::SparseMatrix<double, Eigen::ColMajor, std::int64_t> A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  SymmetricSolver solver;
  const std::span<const std::int64_t> cp(A.outerIndexPtr(), static_cast<std::size_t>(n) + 1);
  const std::span<const std::int64_t> rows(A.innerIndexPtr(), static_cast<std::size_t>(A.nonZeros()));
  std::vector<double> rhs(static_cast<std::size_t>(n), 0.0), G(static_cast<std::size_t>(n), 0.0);
  rhs[index[out.centre]] = 1;
  if (solver.analyze(n, cp, rows, FactorKind::PositiveDefinite) != FactorOutcome::Ok) {
    out.why_not = "the Laplacian's analysis failed";
    return out;
  }
  std::copy(A.valuePtr(), A.valuePtr() + A.nonZeros(), solver.values().begin());
  if (solver.factorize() != FactorOutcome::Ok || !solver.solve(rhs, G)) {
    out.why_not = "the Laplacian could not be factorized";
    return out;
  }

  // Harmonic measure of each boundary vertex: the flux of G into it.
  std::vector<double> measure(static_cast<std::size_t>(nv), 0.0);
  for (Index e = 0; e < ne; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    if (a == b) continue;
    if (boundary[a] && index[b] >= 0) measure[a] += w[e] * G[index[b]];
    if (boundary[b] && index[a] >= 0) measure[b] += w[e] * G[index[a]];
  }
  // A boundary edge's share: half of each end's (a corner vertex with no interior neighbour has
  // none of its own, like the continuum's measure at a convex corner).
  for (const Index c : t.boundary_corners) {
    const Index e = t.corner_edge[c];
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    const double m = 0.5 * (measure[a] + measure[b]);
    out.total += m;
    if (out.vertex == kInvalid || m < out.min_measure) {
      out.vertex = a;
      out.other = b;
      out.min_measure = m;
    }
  }
  out.computed = true;
  return out;
}

}  // namespace

Crowding circle_domain_crowding(const Mesh& mesh, const Topology& topology) {
  Crowding out;
  if (topology.is_closed() || topology.genus() != 0 || topology.num_components != 1) {
    out.why_not = "not a connected genus-0 surface with boundary";
    return out;
  }
  // Harmonic measure needs an interior point: a mesh whose vertices all lie on the boundary (a
  // strip one triangle wide) is subdivided once, and a new vertex is named by an end of its edge.
  bool interior = false;
  for (Index v = 0; v < topology.num_vertices && !interior; ++v)
    interior = topology.valence(v) > 0 && !topology.is_boundary_vertex(v);
  if (interior) return measure(mesh, topology);
  const SteinerMesh fine = subdivide_on_faces(mesh, topology, 1);
  if (fine.status != Status::Ok) {
    out.why_not = fine.message;
    return out;
  }
  out = measure(fine.mesh, fine.topology);
  if (out.computed) {
    // A new vertex (the midpoint of an input edge) is named by the edge's first end.
    auto parent = [&](Index v) {
      const SteinerPlace p = fine.place[v];
      return p.kind == SteinerPlace::Kind::Vertex ? p.index : topology.edge_vertices[2 * p.index];
    };
    out.centre = parent(out.centre);
    out.vertex = parent(out.vertex);
    out.other = parent(out.other);
  }
  return out;
}

}  // namespace ricci::detail
