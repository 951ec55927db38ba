// ricci (internal) — the Hessian ∂K/∂u of the Ricci energy as a sparse matrix with a pattern
// computed once, assembled every Newton step from the per-face blocks of
// angle_derivative_blocks() (metric.h).
//
// Only the unknowns take part: the vertices whose u moves in the Newton step (vertices that hold
// their u, vertices used by no face and gauge-pinned vertices are left out, i.e. Dirichlet).
// Unknown j is the j-th unknown vertex in vertex order. The matrix is stored as its upper
// triangle in compressed columns (what CHOLMOD reads for a symmetric matrix): column j holds the
// rows i < j of the unknown neighbours of unknown j (one per edge, rows increasing), then the
// diagonal. Each off-diagonal entry remembers its edge; the diagonal its vertex.
//
// Assembly gathers, per entry, the block entries of the faces that contribute to it:
//   H_jj = −Σ_{corners c at v_j} B_f[c][c]
//   H_ij = −½ Σ_{faces f at edge e = v_i v_j} (B_f[i][j] + B_f[j][i])
// (B_f[a][b] = ∂θ(corner a of f)/∂u(vertex of corner b); the two terms of the off-diagonal are
// equal up to rounding, their mean is symmetric by construction). Every entry is written by one
// iteration of a parallel loop over columns, in a fixed order: no atomics, and the values do not
// depend on the number of threads.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "ricci/topology.h"

namespace ricci::detail {

/// Loops shorter than this run on the calling thread: forking a team costs more than the work,
/// and idle team members spin (badly so on an oversubscribed machine). The results are the same.
inline constexpr Index kParallelMin = 8192;

struct HessianPattern {
  Index num_unknowns = 0;
  std::vector<Index> unknown_vertex;  ///< #unknowns: unknown → vertex
  std::vector<Index> vertex_unknown;  ///< #V: vertex → unknown, kInvalid when not an unknown
  std::vector<std::int64_t> col_ptr;  ///< #unknowns + 1
  std::vector<std::int64_t> row;      ///< nnz: row of each entry of the upper triangle
  std::vector<Index> entry_edge;      ///< nnz: edge of an off-diagonal entry, kInvalid on the diagonal
  /// (entry, edge) for every further edge between the same two vertices (intrinsic triangulations
  /// may have several), by entry: the entry sums them all. Empty for a simplicial mesh.
  std::vector<std::pair<std::int64_t, Index>> more_edges;

  std::int64_t num_nonzeros() const { return col_ptr.empty() ? 0 : col_ptr.back(); }
};

/// ∂K_i/∂u_j for the edge e = v_i v_j (either order): −½ Σ over its faces of the two block entries.
inline double hessian_edge_entry(const Topology& t, std::span<const double> blocks, Index e) {
  double sum = 0;
  for (int side = 0; side < 2; ++side) {
    const Index c = t.edge_corners[2 * e + side];
    if (c == kInvalid) continue;
    // Edge e (opposite corner c) joins the vertices of next(c) and prev(c).
    const std::size_t f9 = 9 * static_cast<std::size_t>(corner_face(c));
    const Index a = corner_slot(next_corner(c)), b = corner_slot(prev_corner(c));
    sum += blocks[f9 + 3 * a + b] + blocks[f9 + 3 * b + a];
  }
  return -0.5 * sum;
}

/// The pattern for the vertices with is_unknown[v] != 0 (#V flags). Linear time and memory
/// (plus a sort of each column's few entries); deterministic. Edges from a vertex to itself add
/// no entry (they act on the diagonal, see assemble_hessian()); several edges between two
/// vertices share one entry (HessianPattern::more_edges).
HessianPattern build_hessian_pattern(const Topology& topology, std::span<const std::uint8_t> is_unknown);

/// A fill-reducing ordering of `before` (order[k]: the unknown eliminated k-th) carried over to
/// `after`, the pattern of the same unknowns on `topology` after edge flips. An entry new in
/// `after` joins the two ends a, b of a flipped-in edge. Where the ordering eliminates both before
/// the two vertices c, d across that edge (old neighbours of both), a and b sit in different
/// subtrees of the elimination tree below c and d (a nested-dissection separator crossed by the
/// flip), and the new entry would merge the two subtrees' fill; the one of a, b eliminated later
/// moves to just before the earlier of c, d, i.e. into the separator. Otherwise one of them is an
/// ancestor of the other already and the entry only fills their path. Linear time; the caller
/// still checks the fill of the result (a heuristic: moves are decided on the old positions).
std::vector<std::int64_t> repair_ordering(const Topology& topology, const HessianPattern& before,
                                          const HessianPattern& after, std::span<const std::int64_t> order);

/// Writes the entries of ∂K/∂u (pattern order, num_nonzeros() values) from the per-face blocks
/// (#F×9). Allocates nothing; OpenMP over columns.
void assemble_hessian(const Topology& topology, const HessianPattern& pattern, std::span<const double> blocks,
                      std::span<double> values);

/// y = H x for the symmetric matrix stored as its upper triangle (x, y: #unknowns). Serial, in a
/// fixed order.
void multiply_hessian(const HessianPattern& pattern, std::span<const double> values,
                      std::span<const double> x, std::span<double> y);

}  // namespace ricci::detail
