#include "hessian.h"

#include <algorithm>

namespace ricci::detail {

HessianPattern build_hessian_pattern(const Topology& t, std::span<const std::uint8_t> is_unknown) {
  HessianPattern p;
  const Index nv = t.num_vertices, ne = t.num_edges;
  p.vertex_unknown.assign(static_cast<std::size_t>(nv), kInvalid);
  for (Index v = 0; v < nv; ++v) {
    if (!is_unknown[v]) continue;
    p.vertex_unknown[v] = p.num_unknowns++;
    p.unknown_vertex.push_back(v);
  }
  const Index n = p.num_unknowns;

  // Count the strictly upper entries per column: edge (a, b) between unknowns goes to the column
  // of the larger unknown index.
  p.col_ptr.assign(static_cast<std::size_t>(n) + 1, 0);
  for (Index e = 0; e < ne; ++e) {
    const Index a = p.vertex_unknown[t.edge_vertices[2 * e]],
                b = p.vertex_unknown[t.edge_vertices[2 * e + 1]];
    if (a == kInvalid || b == kInvalid || a == b) continue;
    ++p.col_ptr[static_cast<std::size_t>(std::max(a, b)) + 1];
  }
  for (Index j = 0; j < n; ++j) p.col_ptr[j + 1] += p.col_ptr[j] + 1;  // + 1: the diagonal
  const std::int64_t nnz = p.col_ptr[n];
  p.row.assign(static_cast<std::size_t>(nnz), 0);
  p.entry_edge.assign(static_cast<std::size_t>(nnz), kInvalid);

  // Fill: off-diagonals from the start of each column, the diagonal at its end.
  std::vector<std::int64_t> next(p.col_ptr.begin(), p.col_ptr.end() - 1);
  for (Index e = 0; e < ne; ++e) {
    const Index a = p.vertex_unknown[t.edge_vertices[2 * e]],
                b = p.vertex_unknown[t.edge_vertices[2 * e + 1]];
    if (a == kInvalid || b == kInvalid || a == b) continue;
    const std::int64_t k = next[std::max(a, b)]++;
    p.row[k] = std::min(a, b);
    p.entry_edge[k] = e;
  }
  // Sort each column's off-diagonal entries by row (a column has as many as the vertex has
  // neighbours with a smaller unknown index: a handful).
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) {
    const std::int64_t begin = p.col_ptr[j], end = p.col_ptr[j + 1] - 1;
    // Insertion sort of (row, edge) pairs.
    for (std::int64_t k = begin + 1; k < end; ++k) {
      const std::int64_t r = p.row[k];
      const Index e = p.entry_edge[k];
      std::int64_t m = k;
      for (; m > begin && p.row[m - 1] > r; --m) {
        p.row[m] = p.row[m - 1];
        p.entry_edge[m] = p.entry_edge[m - 1];
      }
      p.row[m] = r;
      p.entry_edge[m] = e;
    }
    p.row[end] = j;
    p.entry_edge[end] = kInvalid;
  }
  // Several edges between the same two vertices (intrinsic triangulations): one entry each pair.
  bool repeated = false;
  for (Index j = 0; j < n && !repeated; ++j)
    for (std::int64_t k = p.col_ptr[j] + 1; k < p.col_ptr[j + 1] - 1; ++k)
      if (p.row[k] == p.row[k - 1]) repeated = true;
  if (repeated) {
    std::int64_t out = 0;
    std::int64_t begin = 0;
    for (Index j = 0; j < n; ++j) {
      const std::int64_t end = p.col_ptr[j + 1];
      for (std::int64_t k = begin; k < end; ++k) {
        if (k > begin && k < end - 1 && p.row[k] == p.row[k - 1]) {
          p.more_edges.emplace_back(out - 1, p.entry_edge[k]);
          continue;
        }
        p.row[out] = p.row[k];
        p.entry_edge[out] = p.entry_edge[k];
        ++out;
      }
      begin = end;
      p.col_ptr[j + 1] = out;
    }
    p.row.resize(static_cast<std::size_t>(out));
    p.entry_edge.resize(static_cast<std::size_t>(out));
  }
  return p;
}

namespace {

// Whether the upper-triangle pattern has an entry at unknowns (i, j), i != j.
bool has_entry(const HessianPattern& p, Index i, Index j) {
  const Index col = std::max(i, j), r = std::min(i, j);
  const auto begin = p.row.begin() + p.col_ptr[col], end = p.row.begin() + p.col_ptr[col + 1] - 1;
  return std::binary_search(begin, end, static_cast<std::int64_t>(r));
}

}  // namespace

std::vector<std::int64_t> repair_ordering(const Topology& t, const HessianPattern& before, const HessianPattern& after,
                                          std::span<const std::int64_t> order) {
  const Index n = after.num_unknowns;
  std::vector<std::int64_t> out(order.begin(), order.end());
  if (before.num_unknowns != n || static_cast<Index>(order.size()) != n) return out;
  std::vector<std::int64_t> pos(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) pos[order[k]] = k;
  // target[x]: the position x moves to the front of (the latest over x's new entries), or −1.
  std::vector<std::int64_t> target(static_cast<std::size_t>(n), -1);
  bool moved = false;
  for (Index j = 0; j < n; ++j) {
    for (std::int64_t k = after.col_ptr[j]; k < after.col_ptr[j + 1] - 1; ++k) {
      const auto i = static_cast<Index>(after.row[k]);
      if (has_entry(before, i, j)) continue;
      const Index e = after.entry_edge[k];
      const std::int64_t hi = std::max(pos[i], pos[j]);
      std::int64_t common = -1;  // earliest position of an old common neighbour across e
      bool related = false;
      for (int side = 0; side < 2 && !related; ++side) {
        const Index c = t.edge_corners[2 * e + side];
        if (c == kInvalid) continue;
        const Index w = after.vertex_unknown[t.corner_vertex[c]];
        if (w == kInvalid || w == i || w == j || !has_entry(before, w, i) || !has_entry(before, w, j)) continue;
        if (pos[w] < hi) related = true;  // w lies below one of i, j and is adjacent to both
        else if (common < 0 || pos[w] < common) common = pos[w];
      }
      if (related || common < 0) continue;
      const Index later = pos[i] > pos[j] ? i : j;
      target[later] = std::max(target[later], common);
      moved = true;
    }
  }
  if (!moved) return out;
  // Moved unknowns go in front of their target position, in their old order.
  std::vector<Index> head(static_cast<std::size_t>(n), kInvalid), tail(static_cast<std::size_t>(n), kInvalid),
      link(static_cast<std::size_t>(n), kInvalid);
  for (Index k = 0; k < n; ++k) {
    const auto x = static_cast<Index>(order[k]);
    const std::int64_t to = target[x];
    if (to < 0) continue;
    if (head[to] == kInvalid) head[to] = x;
    else link[tail[to]] = x;
    tail[to] = x;
  }
  std::size_t m = 0;
  for (Index k = 0; k < n; ++k) {
    for (Index x = head[k]; x != kInvalid; x = link[x]) out[m++] = x;
    if (target[order[k]] < 0) out[m++] = order[k];
  }
  return out;
}

void assemble_hessian(const Topology& t, const HessianPattern& p, std::span<const double> blocks,
                      std::span<double> values) {
  const Index n = p.num_unknowns;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) {
    const std::int64_t begin = p.col_ptr[j], end = p.col_ptr[j + 1] - 1;
    for (std::int64_t k = begin; k < end; ++k) values[k] = hessian_edge_entry(t, blocks, p.entry_edge[k]);
    const Index v = p.unknown_vertex[j];
    double diag = 0;
    for (Index i = t.vertex_corner_offsets[v]; i < t.vertex_corner_offsets[v + 1]; ++i) {
      const Index c = t.vertex_corners[i];
      const std::size_t f9 = 9 * static_cast<std::size_t>(corner_face(c));
      diag += blocks[f9 + 4 * corner_slot(c)];
      // A face with v at two corners (an edge from v to itself): ∂θ_c/∂u_v has both terms.
      for (const Index d : {next_corner(c), prev_corner(c)})
        if (t.corner_vertex[d] == v) diag += blocks[f9 + 3 * corner_slot(c) + corner_slot(d)];
    }
    values[end] = -diag;
  }
  for (const auto& [k, e] : p.more_edges) values[k] += hessian_edge_entry(t, blocks, e);
}

void multiply_hessian(const HessianPattern& p, std::span<const double> values, std::span<const double> x,
                      std::span<double> y) {
  const Index n = p.num_unknowns;
  std::fill(y.begin(), y.begin() + n, 0.0);
  for (Index j = 0; j < n; ++j) {
    for (std::int64_t k = p.col_ptr[j]; k < p.col_ptr[j + 1]; ++k) {
      const auto i = static_cast<Index>(p.row[k]);
      y[i] += values[k] * x[j];
      if (i != j) y[j] += values[k] * x[i];
    }
  }
}

}  // namespace ricci::detail
