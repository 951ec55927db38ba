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
